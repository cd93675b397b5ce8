/* two_hosts_simnet: two hosts of the paper's scene on a simulated network.
   Each host builds the same scene, one sphere nudged 1 cm on host 2 (as if
   it had been poked before they met). Ghosts on every object blend the
   hosts' states over a link of 50 ms latency and 2% loss; nobody interacts.
   Every half second we print how far apart the two copies are, the round
   trip the ghosts measured and what arrived. Both hosts keep wall-clock pace
   (their simulation times match the simnet's clock). The shared objects use
   the client/server rule: the hosts are in step, a tie that host 1 wins, so
   host 2 copies host 1 and the copies meet as the scene settles (under the
   exponential rule both pull each other toward states 50 ms old and stay
   millimetres apart: see "Convergence" in the README). */
#define GHOSTSIM_IMPLEMENTATION
#include "ghostsim.h"

#include <math.h>
#include <stdio.h>

#define HOSTS 2

/* Largest distance between the two hosts' copies of any cloth particle. */
static double cloth_gap(const gs_scene *a, const gs_scene *b) {
    const gs_vec3 *x = gs_mesh_positions(a->cloth), *y = gs_mesh_positions(b->cloth);
    double worst = 0.0;
    int i;
    for (i = 0; i < gs_mesh_particle_count(a->cloth); ++i) {
        double d = sqrt((x[i].x - y[i].x) * (x[i].x - y[i].x) + (x[i].y - y[i].y) * (x[i].y - y[i].y) +
                        (x[i].z - y[i].z) * (x[i].z - y[i].z));
        if (d > worst) worst = d;
    }
    return worst;
}

int main(void) {
    gs_world *world[HOSTS];
    gs_scene scene[HOSTS];
    gs_simnet *sim;
    gs_net *net;
    gs_link_desc wan = gs_link_desc_default();
    gs_scene_desc sd = gs_scene_desc_default();
    gs_ghost_desc gd = gs_ghost_desc_default();
    int h, step;
    gd.weight = gs_weight_cs;

    wan.latency = 0.050; /* s */
    wan.jitter = 0.005;
    wan.loss = 0.02;
    if (gs_simnet_create(NULL, &sim) != GS_OK) return 1;
    for (h = 0; h < HOSTS; ++h) {
        gs_world_desc wd = gs_world_desc_default();
        gs_net_desc nd = gs_net_desc_default();
        double st[14];
        wd.host_id = (uint32_t)h + 1;
        if (gs_world_create(&wd, &world[h]) != GS_OK) return 1;
        if (gs_scene_create(world[h], &sd, &scene[h]) != GS_OK ||
            gs_scene_attach_ghosts(&scene[h], &gd) != GS_OK) {
            fprintf(stderr, "two_hosts_simnet: %s\n", gs_world_error(world[h]));
            return 1;
        }
        gs_agent_get_state(scene[h].spheres[0], st, 14); /* the nudge: 1 cm */
        st[1] += 0.01 * h;
        gs_agent_set_state(scene[h].spheres[0], st, 14);
        if (gs_simnet_transport(sim, &nd.transport) != GS_OK ||
            gs_net_create(world[h], &nd, &net) != GS_OK) /* linked to those before */
            return 1;
    }
    gs_simnet_link(sim, 1, 2, &wan);
    gs_simnet_link(sim, 2, 1, &wan);
    for (step = 1; step <= 40; ++step) {
        gs_peer_stats ps;
        gs_simnet_run(sim, 0.5, 1.0 / 60.0);
        gs_net_peer_stats(gs_world_net(world[0]), 2, &ps);
        printf("t = %4.1f s  sim times %.3f / %.3f s  cloth gap %.2e m  sphere 0 gap %.2e m  "
               "rtt %.0f ms  rx %llu lost %llu\n",
               gs_simnet_time(sim), gs_agent_time(scene[0].cloth), gs_agent_time(scene[1].cloth),
               cloth_gap(&scene[0], &scene[1]),
               fabs(gs_rigid_position(scene[0].spheres[0]).x - gs_rigid_position(scene[1].spheres[0]).x),
               ps.rtt * 1e3, (unsigned long long)ps.snapshots_received,
               (unsigned long long)ps.lost);
    }
    for (h = 0; h < HOSTS; ++h) gs_world_destroy(world[h]);
    gs_simnet_destroy(sim);
    return 0;
}
