/* test_replaynear.c - replays skipped within gs_sync_desc.replay_tolerance
   (issue 15, the replay's CPU): a replay whose first blend moves every
   ghost's state by less than the tolerance is not run, at most
   GS_REPLAY_NEAR_SKIPS in a row, and copies at rest still end bitwise
   equal.

   Two hosts of a small paper scene (6x6 cloth, two spheres, a probe each)
   under the client/server rule, replay mode on the session clock, 25 ms
   each way with 2% loss: host 1's probe pushes for 1.3 s, then parks; the
   run goes on 1.7 s. The follower (host 2) is the one that replays.
   Every 15 frames the follower's last 4 frames, and at the end each
   world's last 8, re-run bitwise (gs_world_sync_test). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "ghostsim.h"
#include "net_helpers.h"

#define FRAME (1.0 / 60.0)
#define PUSH 1.3
#define FRAMES 180 /* 3 s */

typedef struct near_run {
    gs_sync_stats st;  /* the follower's */
    double apart;      /* m, the largest distance of host 2's cloth
                          particles and spheres from host 1's at the end */
    double gap;        /* s, the cloths' times apart at the end */
} near_run;

static double dist(gs_vec3 a, gs_vec3 b) {
    return sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) + (a.z - b.z) * (a.z - b.z));
}

/* every: gs_sync_desc.replay_every (0: the default) */
static void run(double tol, int every, near_run *out) {
    gs_simnet *sim;
    gs_world *w[2];
    gs_scene sc[2];
    gs_link_desc link = gs_link_desc_default();
    gs_world_desc wd = gs_world_desc_default();
    const gs_quat id = {0.0, 0.0, 0.0, 1.0};
    int k, f, i;
    memset(out, 0, sizeof *out);
    link.latency = 0.025;
    link.loss = 0.02;
    wd.sync.mode = GS_SYNC_REPLAY;
    wd.sync.clock = GS_SYNC_CLOCK_SESSION;
    wd.sync.replay_tolerance = tol;
    wd.sync.replay_every = every;
    assert_int_equal(gs_simnet_create(NULL, &sim), GS_OK);
    assert_int_equal(test_scene_pair(sim, &wd, w, sc), GS_OK);
    assert_int_equal(gs_simnet_link(sim, 1, 2, &link), GS_OK);
    assert_int_equal(gs_simnet_link(sim, 2, 1, &link), GS_OK);
    for (f = 0; f < FRAMES; ++f) {
        double t = gs_simnet_time(sim);
        gs_vec3 p = gs_scene_probe_path(0, t < PUSH ? t : PUSH);
        if (t >= PUSH) p.y = 0.4;
        assert_int_equal(gs_probe_set_target(sc[0].probes[0], p, id), GS_OK);
        assert_int_equal(gs_simnet_run(sim, FRAME, FRAME), GS_OK);
        if (f >= 30 && f % 15 == 0) { /* while it pushes and after */
            int bad = 0;
            assert_int_equal(gs_world_sync_test(w[1], 4, &bad), GS_OK);
            assert_int_equal(bad, -1);
        }
    }
    out->gap = fabs(gs_agent_time(sc[0].cloth) - gs_agent_time(sc[1].cloth));
    for (i = 0; i < gs_mesh_particle_count(sc[0].cloth); ++i)
        out->apart = fmax(out->apart,
                          dist(gs_mesh_positions(sc[0].cloth)[i], gs_mesh_positions(sc[1].cloth)[i]));
    for (i = 0; i < 2; ++i)
        out->apart = fmax(out->apart, dist(gs_rigid_position(sc[0].spheres[i]),
                                           gs_rigid_position(sc[1].spheres[i])));
    assert_int_equal(gs_world_sync_stats(w[1], &out->st), GS_OK);
    /* the follower's history, skips and all, re-runs bit for bit: a skip
       leaves the present as it ran and logs nothing */
    for (k = 0; k < 2; ++k) {
        int bad = 0;
        assert_int_equal(gs_world_sync_test(w[k], 8, &bad), GS_OK);
        assert_int_equal(bad, -1);
    }
    for (k = 0; k < 2; ++k) gs_world_destroy(w[k]);
    gs_simnet_destroy(sim);
}

/* The default tolerance skips some of the follower's replays and re-runs
   fewer steps than none; the copies still come to rest bit for bit. */
static void test_near_skips_and_rests(void **state) {
    near_run off, on;
    (void)state;
    run(-1.0, 0, &off);
    run(0.0, 0, &on);
    printf("follower, no tolerance: %llu replays, %llu steps re-run, %.3g m apart at the end\n",
           (unsigned long long)off.st.replays, (unsigned long long)off.st.replay_steps, off.apart);
    printf("follower, default tolerance: %llu replays, %llu skipped within it, %llu steps re-run, "
           "%.3g m apart at the end\n", (unsigned long long)on.st.replays,
           (unsigned long long)on.st.replays_near, (unsigned long long)on.st.replay_steps, on.apart);
    assert_int_equal(off.st.replays_near, 0);
    assert_true(on.st.replays_near > 0);
    assert_true(on.st.replays_near <= on.st.replays_skipped);
    assert_true(on.st.replay_steps < off.st.replay_steps);
    /* at most GS_REPLAY_NEAR_SKIPS in a row: every run of them ends at a
       replay (or at the end of the test) */
    assert_true(on.st.replays_near <= (uint64_t)GS_REPLAY_NEAR_SKIPS * (on.st.replays + 1));
    /* 1.7 s after the stop host 2 runs host 1's states on from their own
       times: measured exactly 0 both ways; 1 um leaves room for another
       compiler's rounding (test_sync's test_modes_converge) */
    assert_true(off.apart < 1e-6);
    assert_true(on.apart < 1e-6);
    /* the session clock: a cloth step apart at most */
    assert_true(on.gap <= 0.002 + 1e-9);
}

/* A tolerance that is no number is refused with a message; negative is
   off, and 0 the default. */
static void test_near_bad_tolerance(void **state) {
    gs_world_desc wd = gs_world_desc_default();
    gs_world *w = NULL;
    (void)state;
    assert_true(gs_sync_desc_default().replay_tolerance == GS_REPLAY_TOLERANCE);
    wd.sync.replay_tolerance = NAN;
    assert_int_equal(gs_world_create(&wd, &w), GS_ERR_NOT_FINITE);
    assert_null(w);
    wd.sync.replay_tolerance = INFINITY;
    assert_int_equal(gs_world_create(&wd, &w), GS_ERR_NOT_FINITE);
    assert_null(w);
    wd.sync.replay_tolerance = -1.0;
    wd.sync.mode = GS_SYNC_REPLAY;
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    gs_world_destroy(w);
}

/* Snapshots taken every third advance (gs_sync_desc.replay_every): each
   replay spans about the latency as before, so the follower re-runs fewer
   steps; the history still re-runs bit for bit (run() checks) and the
   copies still come to rest bitwise equal. */
static void test_replay_every(void **state) {
    near_run one, three;
    (void)state;
    run(0.0, 1, &one);
    run(0.0, 3, &three);
    printf("follower, replay_every 1: %llu replays, %llu steps re-run; 3: %llu replays, %llu steps "
           "re-run, %.3g m apart at the end\n", (unsigned long long)one.st.replays,
           (unsigned long long)one.st.replay_steps, (unsigned long long)three.st.replays,
           (unsigned long long)three.st.replay_steps, three.apart);
    assert_true(three.st.replays + three.st.replays_skipped < one.st.replays + one.st.replays_skipped);
    assert_true(three.st.replay_steps < one.st.replay_steps);
    assert_int_equal(three.st.fallbacks, 0); /* the wait stays within the history */
    /* as in test_near_skips_and_rests: measured 0; 1 um for another
       compiler's rounding */
    assert_true(three.apart < 1e-6);
}

/* replay_every outside 1..GS_REPLAY_EVERY_MAX is refused; 0 is the
   default. */
static void test_replay_every_bad(void **state) {
    gs_world_desc wd = gs_world_desc_default();
    gs_world *w = NULL;
    int bad[3] = {-1, GS_REPLAY_EVERY_MAX + 1, 1 << 30}, i;
    (void)state;
    assert_int_equal(gs_sync_desc_default().replay_every, GS_REPLAY_EVERY);
    wd.sync.mode = GS_SYNC_REPLAY;
    for (i = 0; i < 3; ++i) {
        wd.sync.replay_every = bad[i];
        assert_int_equal(gs_world_create(&wd, &w), GS_ERR_INVALID_ARG);
        assert_null(w);
    }
    wd.sync.replay_every = 0;
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    gs_world_destroy(w);
    wd.sync.replay_every = GS_REPLAY_EVERY_MAX;
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    gs_world_destroy(w);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_near_skips_and_rests),
        cmocka_unit_test(test_near_bad_tolerance),
        cmocka_unit_test(test_replay_every),
        cmocka_unit_test(test_replay_every_bad),
    };
    return cmocka_run_group_tests_name("replaynear", tests, NULL, NULL);
}
