/* paper_scene: the scene of the paper on one host, for 5 s.
   A 1 m cloth hangs by its four corners, three spheres fall on it, and one
   probe (a small box, the user's hand) circles and dips into the cloth.
   Every second we print where things are. */
#define GHOSTSIM_IMPLEMENTATION
#include "ghostsim.h"

#include <stdio.h>

int main(void) {
    gs_world *world;
    gs_scene scene;
    gs_scene_desc sd = gs_scene_desc_default();
    int frame, i, centre;

    if (gs_world_create(NULL, &world) != GS_OK) return 1;
    if (gs_scene_create(world, &sd, &scene) != GS_OK) {
        fprintf(stderr, "paper_scene: %s\n", gs_world_error(world));
        gs_world_destroy(world);
        return 1;
    }
    centre = sd.cloth_n / 2 + sd.cloth_n * (sd.cloth_n / 2);
    for (frame = 1; frame <= 300; ++frame) {          /* 300 frames of 1/60 s */
        double t = frame / 60.0;
        gs_probe_set_target(scene.probes[0], gs_scene_probe_path(0, t),
                            gs_rigid_orientation(scene.probes[0]));
        if (gs_world_advance(world, 1.0 / 60.0, NULL) != GS_OK)
            fprintf(stderr, "paper_scene: %s\n", gs_world_error(world));
        if (frame % 60 == 0) {
            gs_vec3 c = gs_mesh_positions(scene.cloth)[centre];
            gs_vec3 p = gs_rigid_position(scene.probes[0]);
            printf("t = %.1f s  cloth centre y = %+.3f m  probe (%+.2f, %+.2f, %+.2f)",
                   t, c.y, p.x, p.y, p.z);
            for (i = 0; i < scene.sphere_count; ++i)
                printf("  sphere %d y = %+.3f", i, gs_rigid_position(scene.spheres[i]).y);
            printf("\n");
        }
    }
    gs_world_destroy(world);
    return 0;
}
