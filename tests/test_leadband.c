/* test_leadband.c - hosts near the edge of the ghosts' time band agree on
   one lead, for every object of a world (issue 15: convergence between
   processes without retries).

   What must hold: two hosts of a small paper scene under the
   client/server rule, in 5 ms frames (ghostpeer's loop); once they run
   in step, host 2 is put JUMP ahead (a little past the time band, 26.7
   ms), as host 1 reads a peer 20-24 ms ahead of it whenever it is
   descheduled for a few ms and catches up (two ghostpeer processes after
   faults.py's cut). Then, in every frame:
   - each host's weight rules see one lead for every object (the world's:
     objects in contact need one authority);
   - both hosts see the same lead: host 1, the lowest id of hosts within
     two bands, whom host 2 follows back in time.
   Before, host 1 took host 2 for the lead when it read it past one band,
   ghost by ghost, while host 2 took host 1: each copied the other, and
   some of host 1's spheres (and their times) came from host 2 while its
   cloth stayed its own; the scene at rest was kicked apart again and
   again (faults.py cut, final 1.48 mm). And host 2 is back in step
   within half a second, and ends with host 1's scene. */
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

#define FRAME 0.005 /* s: ghostpeer's loop */
#define JUMP 0.03   /* s: host 2 put ahead, just past the band */
#define RUN 3.0     /* s after the jump */

typedef struct record {
    uint64_t calls; /* weight rule calls */
    uint32_t lead;  /* the lead the first call of this frame saw, 0: none */
    int mixed;      /* another lead seen in this frame */
} record;

static double recording_cs(const gs_weight_in *in, void *user) {
    record *r = (record *)user;
    r->calls++;
    if (r->lead == 0) r->lead = in->lead;
    else if (in->lead != r->lead) r->mixed = 1;
    return gs_weight_cs(in, NULL);
}

static void test_edge_of_band_one_lead(void **state) {
    gs_simnet *sim = NULL;
    gs_link_desc ld = gs_link_desc_default();
    gs_world *w[2] = {NULL, NULL};
    gs_scene sc[2];
    record rec[2];
    double t, worst = 0.0;
    int k, i, mixed = 0, apart = 0, not_one = 0, frames = 0;
    (void)state;
    memset(rec, 0, sizeof rec);
    assert_int_equal(gs_simnet_create(NULL, &sim), GS_OK);
    {
        gs_world_desc wd = gs_world_desc_default();
        void *users[2];
        users[0] = &rec[0];
        users[1] = &rec[1];
        assert_int_equal(test_scene_pair_rule(sim, &wd, w, sc, recording_cs, users), GS_OK);
    }
    ld.latency = 0.0005; /* loopback */
    assert_int_equal(gs_simnet_link(sim, 1, 2, &ld), GS_OK);
    assert_int_equal(gs_simnet_link(sim, 2, 1, &ld), GS_OK);
    assert_int_equal(gs_simnet_run(sim, 1.0, FRAME), GS_OK); /* in step */
    assert_int_equal(gs_world_advance(w[1], JUMP, NULL), GS_OK);
    for (t = 0.0; t < RUN; t += FRAME) {
        for (k = 0; k < 2; ++k) rec[k].lead = 0, rec[k].mixed = 0;
        assert_int_equal(gs_simnet_run(sim, FRAME, FRAME), GS_OK);
        mixed += rec[0].mixed || rec[1].mixed;
        if (rec[0].lead && rec[1].lead) {
            frames++;
            apart += rec[0].lead != rec[1].lead;
            not_one += rec[0].lead != 1u || rec[1].lead != 1u;
        }
        /* host 2 back in step within half a second: 20 ms allows for
           the band it may stay within */
        if (t > 0.5)
            assert_true(fabs(gs_agent_time(sc[1].cloth) - gs_agent_time(sc[0].cloth)) < 0.02);
    }
    for (i = 0; i < sc[0].sphere_count; ++i) {
        gs_vec3 a = gs_rigid_position(sc[0].spheres[i]), b = gs_rigid_position(sc[1].spheres[i]);
        double d = sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) +
                        (a.z - b.z) * (a.z - b.z));
        if (d > worst) worst = d;
    }
    print_message("frames with both blending %d: leads apart %d, not host 1 %d, mixed in a world"
                  " %d; spheres apart at the end %.3g m\n", frames, apart, not_one, mixed, worst);
    assert_true(frames > 100); /* the check saw blends on both hosts */
    assert_int_equal(mixed, 0);
    assert_int_equal(apart, 0);
    assert_int_equal(not_one, 0);
    /* host 2 copies host 1's scene of a latency ago (0.5 ms) and steps
       it for a frame: micrometres at rest; 0.1 mm is far under what a
       thrown sphere gives (centimetres) */
    assert_true(worst < 1e-4);
    for (k = 0; k < 2; ++k) gs_world_destroy(w[k]);
    gs_simnet_destroy(sim);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_edge_of_band_one_lead),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
