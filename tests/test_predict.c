/* test_predict.c - send on change against the extrapolated state
   (gs_ghost_desc.rest_extrapolate): a heartbeat stands for the last state
   sent carried along its velocities, so that an object moving steadily
   sends only heartbeats and its follower keeps up. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ghostsim.h"
#include "world_helpers.h"

#define KEEP 64
#define THRESHOLD 1e-4 /* m, the rest threshold of both hosts */

typedef struct host {
    gs_world *w;
    gs_agent *ball;
    gs_net *net;
    unsigned char keep[KEEP][GS_WIRE_MAX_DATAGRAM];
    size_t keep_size[KEEP];
    int kept;
} host;

static gs_result keep_send(void *user, uint32_t to, const void *data, size_t size) {
    host *h = (host *)user;
    (void)to;
    assert_true(h->kept < KEEP); /* one frame's datagrams; handed over each frame */
    memcpy(h->keep[h->kept], data, size);
    h->keep_size[h->kept++] = size;
    return GS_OK;
}

/* Host id with one sphere (object 7, owned by host 1, its state taken
   whole by host 2) at 0.21 m/s along x without gravity; quantized, send on
   change at THRESHOLD, against the prediction if predict. The follower's
   own copy starts still: only what it is sent moves it. */
static host *host_new(uint32_t id, int predict) {
    host *h = (host *)calloc(1, sizeof *h);
    gs_world_desc wd = gs_world_desc_default();
    gs_rigid_desc rd = gs_rigid_desc_default();
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_net_desc nd;
    assert_non_null(h);
    wd.host_id = id;
    assert_int_equal(gs_world_create(&wd, &h->w), GS_OK);
    gs_world_set_gravity(h->w, v3(0.0, 0.0, 0.0));
    rd.shape.type = GS_SHAPE_SPHERE;
    rd.shape.radius = 0.1;
    rd.position = v3(0.0, 1.0, 0.0);
    if (id == 1) rd.velocity = v3(0.21, 0.0, 0.0);
    rd.solver.dt = 0.01;
    assert_int_equal(gs_rigid_create(h->w, &rd, &h->ball), GS_OK);
    gd.object_id = 7;
    gd.owner = 1;
    gd.weight = gs_weight_owner;
    gd.encoding = GS_ENCODING_QUANT;
    gd.rest_threshold = THRESHOLD;
    gd.rest_extrapolate = predict;
    gd.time_deadband = -1.0; /* the formula as is: the test reads states */
    assert_int_equal(gs_ghost_attach(h->ball, &gd), GS_OK);
    memset(&nd, 0, sizeof nd);
    nd.transport.send = keep_send;
    nd.transport.user = h;
    assert_int_equal(gs_net_create(h->w, &nd, &h->net), GS_OK);
    assert_int_equal(gs_net_add_peer(h->net, id == 1 ? 2 : 1, NULL), GS_OK);
    return h;
}

static void host_free(host *h) {
    gs_net_destroy(h->net);
    gs_world_destroy(h->w);
    free(h);
}

/* One frame of 1/60 s at wall time now, 1 -> 2 (a perfect link). */
static void frame(host *s, host *r, double now) {
    int i;
    assert_int_equal(gs_world_advance(s->w, 1.0 / 60.0, NULL), GS_OK);
    assert_int_equal(gs_net_update(s->net, now), GS_OK);
    for (i = 0; i < s->kept; ++i)
        assert_int_equal(gs_net_deliver(r->net, s->keep[i], s->keep_size[i], now, NULL), GS_OK);
    s->kept = 0;
    assert_int_equal(gs_world_advance(r->w, 1.0 / 60.0, NULL), GS_OK);
    assert_int_equal(gs_net_update(r->net, now), GS_OK);
    r->kept = 0; /* the follower's acknowledgements and heartbeats: not needed */
}

static double apart(const host *s, const host *r) {
    gs_vec3 a = gs_rigid_position(s->ball), b = gs_rigid_position(r->ball);
    return sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) +
                (a.z - b.z) * (a.z - b.z));
}

/* The follower's distance to the sender, the largest over `frames` frames
   after the first `skip`. */
static double run(host *s, host *r, double *now, int frames, int skip) {
    double worst = 0.0;
    int f;
    for (f = 0; f < frames; ++f) {
        frame(s, r, *now += 1.0 / 60.0);
        if (f >= skip && apart(s, r) > worst) worst = apart(s, r);
    }
    return worst;
}

static uint64_t snapshots(const host *s) {
    gs_peer_stats ps;
    assert_int_equal(gs_net_peer_stats(s->net, 2, &ps), GS_OK);
    return ps.snapshots_sent;
}

/* Moving at a steady 0.21 m/s (on the default 3 mm/s velocity grid, so the
   prediction from the quantized state is the motion itself): the first
   snapshot and its two repeats, then heartbeats only, and the follower
   within the threshold all along. Then a change of course is sent at
   once, and after it again only heartbeats. */
static void test_steady_motion_sends_heartbeats(void **state) {
    host *s = host_new(1, 1), *r = host_new(2, 1);
    gs_peer_stats ps, pr;
    double now = 0.0, st[14], worst;
    uint64_t n;
    (void)state;
    /* the first datagrams take a few frames to reach it */
    worst = run(s, r, &now, 120, 6); /* 2 s */
    n = snapshots(s);
    assert_int_equal(gs_net_peer_stats(s->net, 2, &ps), GS_OK);
    assert_int_equal(gs_net_peer_stats(r->net, 1, &pr), GS_OK);
    print_message("2 s at 0.21 m/s: %llu snapshots, %llu heartbeats, follower within %.3g m\n",
                  (unsigned long long)n, (unsigned long long)ps.heartbeats_sent, worst);
    assert_int_equal(n, 3); /* the first, then two repeats */
    assert_in_range(ps.heartbeats_sent, 5, 7); /* 4 Hz over 2 s, less the repeats */
    assert_int_equal(pr.heartbeats_received, ps.heartbeats_sent);
    /* The follower: the sender's state within the threshold (the
       prediction's), plus half a 0.05 mm position step of quantization,
       plus the owner rule's blend of a heartbeat it takes one frame late
       at most: it moves on by its own steps at the same velocity, so
       nothing beyond rounding. */
    assert_true(worst <= THRESHOLD + 2.5e-5);
    /* the follower knocked off: the next heartbeat puts it back where the
       sender's prediction is now, not where the last snapshot was (0.42 m
       behind by now) */
    assert_int_equal(gs_agent_get_state(r->ball, st, 14), GS_OK);
    st[3] += 0.5;
    assert_int_equal(gs_agent_set_state(r->ball, st, 14), GS_OK);
    run(s, r, &now, 20, 0); /* > one 0.25 s heartbeat period */
    print_message("knocked off 0.5 m: back within %.3g m\n", apart(s, r));
    assert_true(apart(s, r) <= THRESHOLD + 2.5e-5);
    assert_int_equal(snapshots(s), n);
    /* a change of course: sent again at the next publish */
    assert_int_equal(gs_agent_get_state(s->ball, st, 14), GS_OK);
    st[8] = 0.0; st[9] = 0.0; st[10] = 0.3; /* state: time, x, q, v, w */
    assert_int_equal(gs_agent_set_state(s->ball, st, 14), GS_OK);
    frame(s, r, now += 1.0 / 60.0);
    frame(s, r, now += 1.0 / 60.0);
    assert_true(snapshots(s) > n);
    worst = run(s, r, &now, 120, 6);
    print_message("after the turn: %llu snapshots, follower within %.3g m\n",
                  (unsigned long long)snapshots(s), worst);
    assert_true(snapshots(s) <= n + 4); /* the new state, its repeats, a frame's slack */
    assert_true(worst <= THRESHOLD + 2.5e-5);
    host_free(s);
    host_free(r);
}

/* Without the prediction (the default), the same motion is a change at
   every publish: the ball publishes every second 10 ms step (50 Hz), 100
   snapshots in 2 s, less a frame's slack at the start. */
static void test_default_sends_every_change(void **state) {
    host *s = host_new(1, 0), *r = host_new(2, 0);
    double now = 0.0;
    gs_ghost_desc d = gs_ghost_desc_default();
    (void)state;
    assert_int_equal(d.rest_extrapolate, 0);
    run(s, r, &now, 120, 6);
    print_message("2 s at 0.21 m/s without the prediction: %llu snapshots\n",
                  (unsigned long long)snapshots(s));
    assert_true(snapshots(s) >= 95);
    host_free(s);
    host_free(r);
}

/* Out of range: rest_extrapolate is 0 or 1. */
static void test_desc_checked(void **state) {
    gs_world *w;
    gs_agent *a;
    gs_world_desc wd = gs_world_desc_default();
    gs_rigid_desc rd = gs_rigid_desc_default();
    gs_ghost_desc gd = gs_ghost_desc_default();
    (void)state;
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    rd.shape.type = GS_SHAPE_SPHERE;
    rd.shape.radius = 0.1;
    assert_int_equal(gs_rigid_create(w, &rd, &a), GS_OK);
    gd.object_id = 7;
    gd.rest_extrapolate = 2;
    assert_int_equal(gs_ghost_attach(a, &gd), GS_ERR_INVALID_ARG);
    gd.rest_extrapolate = 1;
    assert_int_equal(gs_ghost_attach(a, &gd), GS_OK);
    gs_world_destroy(w);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_steady_motion_sends_heartbeats),
        cmocka_unit_test(test_default_sends_every_change),
        cmocka_unit_test(test_desc_checked),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
