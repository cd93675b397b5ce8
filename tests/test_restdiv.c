/* test_restdiv.c - a follower's copy of a scene at rest stays with the
   leader's under send on change (issue 16).

   What must hold: two hosts of an 8x8 cloth with a sphere resting on it,
   each ghost quantized, delta-coded and sent on change, with heartbeats
   at 4 Hz, under the client/server rule (host 1 leads). Once the sphere
   rests, host 2's copy stays on average within half the rest threshold
   of host 1's. Before, host 2 stepped its copy on its own between
   heartbeats from a state that is no equilibrium there (quantized, the
   sphere's last send and the cloth's from other instants) and its
   contacts pushed it off (in the paper scene at rest, mm to cm:
   docs/sync-notes.md). Now the follower holds a copy at a resting
   leader's state (it sleeps after its next step), and a beat after any
   state went sends every resting ghost's state, so that what it holds
   is one instant's scene. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ghostsim.h"
#include "net_helpers.h"

#define FRAME (1.0 / 60.0)
#define SETTLE 6.0  /* s: the sphere has sunk into the cloth and rests */
#define SPAN 3.0    /* s measured after it */

typedef struct host {
    gs_world *w;
    gs_net *net;
    gs_scene sc;
} host;

static void host_open(host *h, gs_simnet *sim, uint32_t id) {
    gs_world_desc wd = gs_world_desc_default();
    gs_ghost_desc gd = gs_ghost_desc_default();
    wd.host_id = id;
    assert_int_equal(gs_world_create(&wd, &h->w), GS_OK);
    assert_int_equal(test_small_scene(h->w, &h->sc), GS_OK);
    gd.encoding = GS_ENCODING_QUANT;
    gd.delta = 1;
    /* the paper scene's steps (0.05 mm, 0.1 mm) scaled up tenfold and
       twofold: on this small cloth they show what they do within the
       seconds a test may take */
    gd.position_resolution = 1e-4;
    gd.rest_threshold = 1e-3;
    gd.weight = gs_weight_cs;
    assert_int_equal(gs_scene_attach_ghosts(&h->sc, &gd), GS_OK);
    assert_int_equal(test_join(sim, h->w, NULL, &h->net), GS_OK);
}

static double apart(gs_vec3 a, gs_vec3 b) {
    return sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) + (a.z - b.z) * (a.z - b.z));
}

static void test_follower_stays_with_resting_leader(void **state) {
    gs_simnet *sim = NULL;
    host h[2];
    double t = 0.0, worst = 0.0, sum = 0.0;
    int i, frames = 0;
    (void)state;
    memset(h, 0, sizeof h);
    assert_int_equal(gs_simnet_create(NULL, &sim), GS_OK);
    for (i = 0; i < 2; ++i) host_open(&h[i], sim, (uint32_t)i + 1);
    while (t < SETTLE + SPAN) {
        for (i = 0; i < 2; ++i) { /* each probe parked above the cloth */
            gs_quat q = {0, 0, 0, 1};
            gs_vec3 p = {0.3 * ((double)i - 0.5), 0.6, 0.0};
            gs_probe_set_target(h[i].sc.probes[i], p, q);
        }
        assert_int_equal(gs_simnet_run(sim, FRAME, FRAME), GS_OK);
        t += FRAME;
        if (t >= SETTLE) {
            double d = apart(gs_rigid_position(h[0].sc.spheres[0]),
                             gs_rigid_position(h[1].sc.spheres[0]));
            worst = d > worst ? d : worst;
            sum += d;
            frames++;
        }
    }
    print_message("sphere apart over %.0f s at rest: mean %.3g m, max %.3g m\n", SPAN,
                  sum / frames, worst);
    /* Mean under half the rest threshold (0.5 mm): held at what host 1
       last sent, host 2's sphere is off by what host 1's moved since (it
       still sinks, by up to the threshold before it sends again) and a
       0.1 mm step. Stepped on its own between heartbeats (before the
       hold) it crept off: mean 0.69-0.79 mm at settle 5-7 s, against
       0.25-0.38 mm with the hold (this machine, 2026-12-03). The largest
       (1.1 mm against 1.4 mm) is left unchecked: a moved snapshot wakes
       the copy, which is then stepped on its own until the next beat. */
    assert_true(sum / frames < 5e-4);
    for (i = 0; i < 2; ++i) {
        gs_net_destroy(h[i].net);
        gs_world_destroy(h[i].w);
    }
    gs_simnet_destroy(sim);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_follower_stays_with_resting_leader),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
