/* udp_pair: two hosts of one shared cloth over real UDP on loopback, in one
   process (each world on its own socket, with the gather and scatter
   threads). Host 2's cloth starts 5 cm higher; the ghosts pull the two
   copies together. Prints the gap between them as they converge. */
#define GHOSTSIM_IMPLEMENTATION
#include "ghostsim.h"

#include <math.h>
#include <stdio.h>
#include <time.h>

static double max_gap(gs_agent *a, gs_agent *b) {
    const gs_vec3 *x = gs_mesh_positions(a), *y = gs_mesh_positions(b);
    double worst = 0.0;
    int i;
    for (i = 0; i < gs_mesh_particle_count(a); ++i) {
        double d = fabs(x[i].x - y[i].x) + fabs(x[i].y - y[i].y) + fabs(x[i].z - y[i].z);
        if (d > worst) worst = d;
    }
    return worst;
}

int main(void) {
    const char *addr[2] = {"127.0.0.1:47001", "127.0.0.1:47002"};
    gs_world *w[2];
    gs_agent *cloth[2];
    gs_net *net[2];
    int h, frame;

    for (h = 0; h < 2; ++h) {
        gs_world_desc wd = gs_world_desc_default();
        gs_cloth_desc cd = gs_cloth_desc_default();
        gs_ghost_desc gd = gs_ghost_desc_default();
        gs_udp_desc ud = gs_udp_desc_default();
        gs_net_desc nd = gs_net_desc_default();
        gs_udp *u;
        wd.host_id = (uint32_t)h + 1;
        if (gs_world_create(&wd, &w[h]) != GS_OK) return 1;
        cd.nx = cd.ny = 12;
        cd.origin.y = 0.05 * h; /* the disagreement: 5 cm */
        cd.pin_corners = GS_CORNER_ALL;
        cd.spring_damping = 1.0;
        cd.solver.integrator = GS_INTEGRATOR_IMPLICIT_EULER;
        cd.solver.dt = 0.002;
        gd.object_id = 1;
        ud.bind = addr[h];
        ud.threads = 1;
        if (gs_cloth_create(w[h], &cd, &cloth[h]) != GS_OK ||
            gs_ghost_attach(cloth[h], &gd) != GS_OK ||
            gs_udp_create(w[h], &ud, &u) != GS_OK ||      /* the socket first */
            gs_udp_transport(u, &nd.transport) != GS_OK ||
            gs_net_create(w[h], &nd, &net[h]) != GS_OK || /* the net owns u */
            gs_net_add_peer(net[h], 2 - (uint32_t)h, addr[1 - h]) != GS_OK) {
            fprintf(stderr, "udp_pair: %s\n", gs_world_error(w[h]));
            return 1;
        }
    }
    for (frame = 1; frame <= 180; ++frame) { /* 3 s at 60 frames/s */
        struct timespec nap = {0, 16666667};
        for (h = 0; h < 2; ++h) gs_world_advance(w[h], 1.0 / 60.0, NULL);
        nanosleep(&nap, NULL);
        if (frame % 30 == 0) {
            gs_peer_stats ps;
            gs_net_peer_stats(net[0], 2, &ps);
            printf("t = %.1f s  gap %.2e m  rtt %.2f ms  rx %llu  rejected %llu\n",
                   frame / 60.0, max_gap(cloth[0], cloth[1]), ps.rtt * 1e3,
                   (unsigned long long)ps.snapshots_received,
                   (unsigned long long)ps.rejected_total);
        }
    }
    for (h = 0; h < 2; ++h) gs_world_destroy(w[h]); /* the net and its gs_udp too */
    return 0;
}
