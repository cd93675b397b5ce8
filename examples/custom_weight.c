/* custom_weight: a weight rule of your own.
   Three hosts share one cloth on a simulated network. Host 1 is the
   teacher: our rule gives its state a weight of 4 and everybody else's 1,
   and ignores snapshots older than 0.2 s of wall time (weight 0). Each host
   starts with its cloth at a different height (0, 0.1, 0.2 m, in zero
   gravity); after 2 s we print where each host's cloth centre is. They
   meet, and nearer host 1's start than the middle: the shared state leans
   toward the teacher. */
#define GHOSTSIM_IMPLEMENTATION
#include "ghostsim.h"

#include <stdio.h>

typedef struct teacher_rule {
    uint32_t teacher; /* host id */
    double trust;     /* its weight; everyone else has 1 */
    double max_age;   /* s; older snapshots count for nothing */
} teacher_rule;

/* A gs_weight_fn: `in` describes the local state or one snapshot. */
static double teacher_weight(const gs_weight_in *in, void *user) {
    const teacher_rule *rule = (const teacher_rule *)user;
    if (!in->local && in->age > rule->max_age) return 0.0;
    return in->host == rule->teacher ? rule->trust : 1.0;
}

int main(void) {
    teacher_rule rule = {1, 4.0, 0.2};
    gs_world *w[3];
    gs_agent *cloth[3];
    gs_simnet *sim;
    gs_net *net;
    int h, centre = 5 + 11 * 5;

    if (gs_simnet_create(NULL, &sim) != GS_OK) return 1;
    for (h = 0; h < 3; ++h) {
        gs_world_desc wd = gs_world_desc_default();
        gs_net_desc nd = gs_net_desc_default();
        gs_cloth_desc cd = gs_cloth_desc_default();
        gs_ghost_desc gd = gs_ghost_desc_default();
        wd.host_id = (uint32_t)h + 1;
        cd.nx = cd.ny = 11;
        cd.origin.y = 0.1 * h; /* host 1 at 0, host 2 at 0.1 m, host 3 at 0.2 m */
        cd.pin_count = 0;      /* free: nothing holds it but the rule */
        cd.solver.integrator = GS_INTEGRATOR_IMPLICIT_EULER;
        gd.object_id = 7;
        gd.weight = teacher_weight;
        gd.weight_user = &rule;
        if (gs_world_create(&wd, &w[h]) != GS_OK) return 1;
        gs_world_set_gravity(w[h], (gs_vec3){0.0, 0.0, 0.0});
        if (gs_cloth_create(w[h], &cd, &cloth[h]) != GS_OK ||
            gs_ghost_attach(cloth[h], &gd) != GS_OK ||
            gs_simnet_transport(sim, &nd.transport) != GS_OK ||
            gs_net_create(w[h], &nd, &net) != GS_OK) { /* joins the simnet */
            fprintf(stderr, "custom_weight: %s\n", gs_world_error(w[h]));
            return 1;
        }
    }
    gs_simnet_run(sim, 2.0, 1.0 / 60.0);
    for (h = 0; h < 3; ++h)
        printf("host %d: cloth centre y = %.4f m (started at %.1f m)\n", h + 1,
               gs_mesh_positions(cloth[h])[centre].y, 0.1 * h);
    printf("they met below 0.1 m, the middle an even rule would settle near: "
           "closer to host 1's start\n");
    for (h = 0; h < 3; ++h) gs_world_destroy(w[h]);
    gs_simnet_destroy(sim);
    return 0;
}
