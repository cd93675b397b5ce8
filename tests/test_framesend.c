/* test_framesend.c - on a frame grid (gs_sync_desc.frame) every snapshot
   leaves at the boundary it stands for, at the ghost's send rate.

   The peers read the session's timeline from a snapshot's time less its
   send time (the largest of their last 9: the least delayed), so a state
   sent a frame after its boundary puts a follower a frame behind. Until
   session 15 the send phase was the wall clock's (a period after the last
   send), beating against the 5 ms grid: of a 60 Hz ghost's sends two in
   three left 5 or 10 ms after their boundary, 42 a second, and four
   ghostpeer processes on loopback showed the followers 3.3 ms (median)
   behind the timekeeper (bench/process_gap.py).

   Every clock is a variable the test sets (gs_sync_desc.now): nothing
   sleeps and every time is exact to the rounding of a sum. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ghostsim.h"
#include "net_helpers.h"
#include "world_helpers.h"

#define F 0.005     /* s; the frame, ghostpeer's */
#define LEAD 0.002  /* s; ghostpeer computes a frame this far ahead */
#define DT 0.001    /* s; the agent's step: a whole number of them a frame, so a
                       state's time is its boundary (the paper scene's 2 ms
                       cloth is up to 1 ms off it) */
#define T0 100.0    /* s; the fake clock starts here (session time 0) */
#define FRAMES 400  /* 2 s */
#define EPS 1e-9    /* s; sums of clock readings near 100 s */

typedef struct fake_clock {
    double now;
} fake_clock;

static double fake_now(void *user) { return ((fake_clock *)user)->now; }

typedef struct sent_log {
    double now;        /* s; the update sending (set by the test) */
    int snapshots;
    double late_max;   /* s; send time less the instant the state stands for */
    int late;          /* snapshots sent after their boundary */
} sent_log;

static gs_result log_send(void *user, uint32_t host, const void *data, size_t size) {
    sent_log *s = (sent_log *)user;
    double t[GS_WIRE_MAX_CHUNKS];
    int n = wire_snapshot_times(data, size, t, GS_WIRE_MAX_CHUNKS), i;
    (void)host;
    for (i = 0; i < n; ++i) {
        /* the origin is -T0: session time t stands at T0 + t */
        double late = s->now - (T0 + t[i]);
        s->snapshots++;
        if (late > s->late_max) s->late_max = late;
        if (late > EPS) s->late++;
    }
    return GS_OK;
}

/* A host's frame loop as ghostpeer's locked one: the advance LEAD before
   each boundary, the net's update at it and again `poll2` after it (0:
   none). Returns the snapshots sent after the first second. */
static int run_loop(double send_rate, double poll2, sent_log *log) {
    fake_clock c = {T0};
    gs_world_desc wd = gs_world_desc_default();
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_world *w = NULL;
    gs_net *net = NULL;
    gs_agent *x;
    two_values t; /* v0 += dt each step: never at rest, so every publish
                     is a snapshot to send */
    int k, first = 0;
    wd.sync.clock = GS_SYNC_CLOCK_SESSION;
    wd.sync.frame = F;
    wd.sync.now = fake_now;
    wd.sync.now_user = &c;
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    memset(&t, 0, sizeof t);
    x = custom_new(w, DT, 2, two_values_step, two_values_get, two_values_set, &t);
    gd.object_id = 1;
    gd.send_rate = send_rate;
    assert_int_equal(gs_ghost_attach(x, &gd), GS_OK);
    memset(log, 0, sizeof *log);
    assert_int_equal(send_only_net(w, NULL, log_send, log, &net), GS_OK);
    assert_int_equal(gs_net_add_peer(net, 2, NULL), GS_OK);
    assert_int_equal(gs_world_advance(w, 0.0, NULL), GS_OK); /* origin -T0 */
    log->now = T0;
    assert_int_equal(gs_net_update(net, T0), GS_OK); /* the state at 0 */
    for (k = 1; k <= FRAMES; ++k) {
        double b = T0 + k * F, seconds = b - LEAD - c.now;
        c.now = b - LEAD;
        assert_int_equal(gs_world_advance(w, seconds, NULL), GS_OK);
        log->now = b;
        assert_int_equal(gs_net_update(net, b), GS_OK);
        if (poll2 > 0.0) {
            log->now = b + poll2;
            assert_int_equal(gs_net_update(net, b + poll2), GS_OK);
        }
        if (k == FRAMES / 2) first = log->snapshots;
    }
    gs_world_destroy(w);
    return log->snapshots - first;
}

static void test_sent_at_boundary(void **state) {
    sent_log log;
    int n;
    (void)state;
    /* 60 Hz on the 5 ms grid: every snapshot leaves at the update at its
       boundary; 60 in the last second (the publishes 15 and 20 ms apart,
       a period on average: 59-61 for where the second's edges fall) */
    n = run_loop(60.0, 0.0, &log);
    printf("60 Hz: %d snapshots in the last second, %d late, latest %.4f s after its boundary\n",
           n, log.late, log.late_max);
    assert_int_equal(log.late, 0);
    assert_true(n >= 59 && n <= 61);
    /* a second update in the frame (a host that polls twice) sends nothing
       more: the rate is the publishes' */
    n = run_loop(60.0, 0.0021, &log);
    assert_int_equal(log.late, 0);
    assert_true(n >= 59 && n <= 61);
    /* 30 Hz (every 6.67 frames) and 200 Hz (every frame, the grid's most) */
    n = run_loop(30.0, 0.0, &log);
    assert_int_equal(log.late, 0);
    assert_true(n >= 29 && n <= 31);
    n = run_loop(200.0, 0.0, &log);
    assert_int_equal(log.late, 0);
    assert_true(n >= 199 && n <= 201);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sent_at_boundary),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
