/* hello_cloth: the smallest useful ghostsim program.
   A 1 m x 1 m cloth lies flat, pinned at two adjacent corners; gravity pulls
   the free edge down and it swings. After 2 s of simulation we print where
   the centre of the cloth has fallen to. */
#define GHOSTSIM_IMPLEMENTATION
#include "ghostsim.h"

#include <stdio.h>

int main(void) {
    gs_world *world;
    gs_agent *cloth;
    gs_world_desc wd = gs_world_desc_default();
    gs_cloth_desc cd = gs_cloth_desc_default();
    const gs_vec3 *x;
    int frame, centre;

    if (gs_world_create(&wd, &world) != GS_OK) return 1;
    cd.nx = 15;                                      /* odd: a centre particle */
    cd.ny = 15;
    cd.pin_corners = GS_CORNER_00 | GS_CORNER_10;    /* the edge along +x */
    cd.solver.integrator = GS_INTEGRATOR_IMPLICIT_EULER;
    cd.solver.dt = 1.0 / 240.0;                      /* s */
    if (gs_cloth_create(world, &cd, &cloth) != GS_OK) {
        fprintf(stderr, "hello_cloth: %s\n", gs_world_error(world));
        gs_world_destroy(world);
        return 1;
    }
    for (frame = 0; frame < 120; ++frame)            /* 120 frames of 1/60 s */
        gs_world_advance(world, 1.0 / 60.0, NULL);

    x = gs_mesh_positions(cloth);
    centre = cd.nx / 2 + cd.nx * (cd.ny / 2);
    printf("after %.2f s the cloth centre is at (%.3f, %.3f, %.3f) m; "
           "it started at (0.500, 0.000, 0.500) m\n",
           gs_agent_time(cloth), x[centre].x, x[centre].y, x[centre].z);
    gs_world_destroy(world);
    return 0;
}
