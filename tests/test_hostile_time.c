/* test_hostile_time.c - what a hostile peer or caller can do to time.

   Issue 14, findings 1 and 6: a datagram's send time made its age, and the
   age a time correction, of any size (a host moved to t = 1e300 froze for
   good); loops that count time could make no progress (a frame of 1e-17 s,
   an agent set to t = -1e300, an advance of 1e9 s, dt = 1e-300, a scene
   settled at dt = 1e-9). What holds now, each case below:
   - no clock or agent time leaves [0, GS_WIRE_MAX_TIME];
   - an age is believed within GS_MAX_AGE only;
   - the blends of one advance move an agent's time by at most
     GS_MAX_TIME_CORRECTION;
   - every call that counts time returns, or refuses its arguments with a
     gs_result and a gs_world_error text, and a refused call changes
     nothing. */
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
#include "world_helpers.h"

/* ---- a host: a world with one still point, a ghost and a net ---- */

typedef struct host {
    gs_world *w;
    gs_agent *a;
    double x[3];
    gs_net *net;
    long sent;
} host;

static gs_result still_step(void *user, double t, double dt) {
    (void)user; (void)t; (void)dt;
    return GS_OK;
}
static void still_get(const void *user, double *out) {
    memcpy(out, user, 3 * sizeof(double));
}
static gs_result still_set(void *user, const double *in) {
    memcpy(user, in, 3 * sizeof(double));
    return GS_OK;
}
static gs_result count_send(void *user, uint32_t to, const void *data, size_t size) {
    (void)to; (void)data; (void)size;
    ((host *)user)->sent++;
    return GS_OK;
}

static gs_agent *still_new(gs_world *w, double dt, double *x) {
    return custom_new(w, dt, 3, still_step, still_get, still_set, x);
}

/* Host 1 with its point (object 5, exponential weights at rate 1/s) and
   a net in clear to host 2. */
static host *host_new(void) {
    host *h = (host *)calloc(1, sizeof *h);
    gs_ghost_desc gd = gs_ghost_desc_default();
    assert_non_null(h);
    h->w = world_new(1);
    h->a = still_new(h->w, 0.002, h->x);
    gd.object_id = 5;
    gd.weight = gs_weight_exp;
    assert_int_equal(gs_ghost_attach(h->a, &gd), GS_OK);
    assert_int_equal(send_only_net(h->w, NULL, count_send, h, &h->net), GS_OK);
    assert_int_equal(gs_net_add_peer(h->net, 2, NULL), GS_OK);
    return h;
}

static void host_free(host *h) {
    gs_world_destroy(h->w);
    free(h);
}

/* A datagram from host 2 with one snapshot of object 5 at simulation time
   t, sent at send_time on host 2's clock, echoing echo_time. */
static size_t datagram(unsigned char *buf, uint32_t seq, double t, double send_time,
                       double echo_time) {
    gs_wire_header h;
    gs_wire_chunk c;
    const double v[3] = {0.5, 0.5, 0.5};
    size_t size = 0;
    memset(&h, 0, sizeof h);
    h.session = 1;
    h.sender = 2;
    h.sequence = seq;
    h.send_time = send_time;
    h.echo_time = echo_time;
    memset(&c, 0, sizeof c);
    c.object_id = 5;
    c.sequence = seq;
    c.time = t;
    c.count = 1;
    c.elements = 3;
    c.encoding = GS_ENCODING_F64;
    assert_int_equal(gs_wire_begin(buf, GS_WIRE_MAX_DATAGRAM, &h, &size), GS_OK);
    assert_int_equal(gs_wire_add(buf, GS_WIRE_MAX_DATAGRAM, &size, &c, v), GS_OK);
    return gs_wire_end(buf, size);
}

static gs_result deliver(host *h, uint32_t seq, double t, double send_time, double echo_time,
                         double now, gs_reject *why) {
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    size_t n = datagram(buf, seq, t, send_time, echo_time);
    *why = GS_REJECT_COUNT;
    return gs_net_deliver(h->net, buf, n, now, why);
}

#define FRAME (1.0 / 60.0)

/* The host runs `frames` frames at wall time now (= its simulation time,
   clocks in step with host 2's), host 2's snapshots arriving 5 ms after
   they were sent, each echoing host 1's send 10 ms before: normal round
   trips, so the clock offset is known. Returns the next sequence. */
static uint32_t in_step(host *h, uint32_t seq, int frames, double *now) {
    gs_reject why;
    int k;
    for (k = 0; k < frames; ++k) {
        *now += FRAME;
        assert_int_equal(deliver(h, seq, *now - 0.005, *now - 0.005, *now - 0.01, *now, &why),
                         GS_OK);
        seq++;
        assert_int_equal(gs_world_advance(h->w, FRAME, NULL), GS_OK);
        assert_int_equal(gs_net_update(h->net, *now), GS_OK);
    }
    return seq;
}

/* ---- finding 1: a remote freeze ---- */

/* The datagram: after normal round trips, send_time = -1e300 and
   no echo. Its age was 1e300, the correction too; the agent went to
   t = 1e300 and never stepped again. Now the wire refuses the send time
   (a clock outside [0, GS_WIRE_MAX_TIME]) and the host keeps in step.
   -1e12 (a jump to t = 1e12) likewise. */
static void test_forged_send_time_refused(void **state) {
    static const double forged[2] = {-1e300, -1e12};
    int i;
    (void)state;
    for (i = 0; i < 2; ++i) {
        host *h = host_new();
        double now = 0.0, t_before;
        uint32_t seq = in_step(h, 0, 30, &now);
        gs_reject why;
        t_before = gs_agent_time(h->a);
        assert_int_equal(deliver(h, seq++, now, forged[i], 0.0, now, &why), GS_ERR_REJECTED);
        assert_int_equal(why, GS_REJECT_TIME);
        in_step(h, seq, 30, &now);
        /* 30 more frames of 1/60 s: 0.5 s on, to a step (2 ms) */
        assert_true(fabs(gs_agent_time(h->a) - (t_before + 0.5)) < 0.01);
        assert_true(fabs(gs_world_time(h->w) - now) < 0.01);
        assert_true(h->sent > 30);
        host_free(h);
    }
}

/* The same attack within the wire's bounds: send time 0 an hour into the
   session (an age of an hour, read against the known clock offset). The
   age is not believed (more than GS_MAX_AGE off the peer's clock): the
   snapshot, at the local time, moves nothing. It moved the host an hour. */
static void test_implausible_age_unknown(void **state) {
    host *h = host_new();
    double now = 3600.0, s[4];
    uint32_t seq;
    gs_reject why;
    (void)state;
    s[0] = now;
    s[1] = s[2] = s[3] = 0.0;
    assert_int_equal(gs_agent_set_state(h->a, s, 4), GS_OK);
    assert_int_equal(gs_world_advance(h->w, 0.0, NULL), GS_OK); /* the clock follows */
    assert_true(gs_world_time(h->w) == now);
    seq = in_step(h, 0, 10, &now);
    assert_int_equal(deliver(h, seq, now - 0.005, 0.0, 0.0, now, &why), GS_OK);
    assert_int_equal(gs_world_advance(h->w, FRAME, NULL), GS_OK);
    /* one frame on from where it was, to a step (2 ms) and the band */
    assert_true(fabs(gs_agent_time(h->a) - (now + FRAME)) < 0.05);
    host_free(h);
}

/* A peer that says it is at GS_WIRE_MAX_TIME (allowed on the wire: a key
   holder can say so) moves the host at most GS_MAX_TIME_CORRECTION per
   advance, plus the advance itself, and never past GS_WIRE_MAX_TIME. It
   took the host to 1e9 s at once. */
static void test_correction_bounded_per_advance(void **state) {
    host *h = host_new();
    double now = 0.0;
    uint32_t seq = in_step(h, 0, 10, &now);
    int k;
    (void)state;
    for (k = 0; k < 5; ++k) {
        double t0 = gs_agent_time(h->a), t1;
        gs_reject why;
        now += FRAME;
        assert_int_equal(deliver(h, seq, GS_WIRE_MAX_TIME, now - 0.005, now - 0.01, now, &why),
                         GS_OK);
        seq++;
        assert_int_equal(gs_world_advance(h->w, FRAME, NULL), GS_OK);
        t1 = gs_agent_time(h->a);
        /* the frame's own steps (up to one 2 ms step past it) + the bound */
        assert_true(t1 - t0 <= GS_MAX_TIME_CORRECTION + FRAME + 0.002 + 1e-9);
        assert_true(t1 > t0 + 1.0); /* it is pulled on, as far as allowed */
        assert_true(t1 <= GS_WIRE_MAX_TIME && gs_world_time(h->w) <= GS_WIRE_MAX_TIME);
    }
    host_free(h);
}

/* The age a weight rule sees stays in [0, GS_MAX_AGE] whatever the send
   time says: here 100 s older than the peer's clock. It was 100 s. */
static double note_age(const gs_weight_in *in, void *user) {
    if (!in->local) *(double *)user = in->age;
    return 1.0;
}

static void test_age_bounded(void **state) {
    host *h = host_new();
    gs_ghost_desc gd = gs_ghost_desc_default();
    double now = 200.0, age = -1.0;
    uint32_t seq;
    gs_reject why;
    (void)state;
    assert_int_equal(gs_ghost_detach(h->a), GS_OK);
    gd.object_id = 5;
    gd.weight = note_age;
    gd.weight_user = &age;
    assert_int_equal(gs_ghost_attach(h->a, &gd), GS_OK);
    seq = in_step(h, 0, 5, &now);
    assert_true(age >= 0.0 && age < 0.01); /* 5 ms, to the estimate's error */
    assert_int_equal(deliver(h, seq, 1.0, now - 100.0, 0.0, now, &why), GS_OK);
    assert_int_equal(gs_world_advance(h->w, FRAME, NULL), GS_OK);
    assert_true(age >= 0.0 && age <= GS_MAX_AGE);
    host_free(h);
}

/* Decode refuses a send or echo time outside [0, GS_WIRE_MAX_TIME]. */
static void test_wire_refuses_header_times(void **state) {
    static const double bad[4] = {-1e300, -1.0, 2e9, 1e300};
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    gs_wire_view v;
    gs_reject why;
    int i;
    (void)state;
    for (i = 0; i < 4; ++i) {
        size_t n = datagram(buf, 1, 1.0, bad[i], 0.0);
        assert_int_equal(gs_wire_decode(buf, n, &v, &why), GS_ERR_REJECTED);
        assert_int_equal(why, GS_REJECT_TIME);
        n = datagram(buf, 1, 1.0, 1.0, bad[i]);
        assert_int_equal(gs_wire_decode(buf, n, &v, &why), GS_ERR_REJECTED);
        assert_int_equal(why, GS_REJECT_TIME);
    }
    assert_int_equal(gs_wire_decode(buf, datagram(buf, 1, 1.0, GS_WIRE_MAX_TIME, 0.0), &v, &why),
                     GS_OK);
}

/* The net's own clock: now outside [0, GS_WIRE_MAX_TIME] is refused by
   gs_net_update and gs_net_deliver, and counts nothing. */
static void test_net_now_bounded(void **state) {
    host *h = host_new();
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    size_t n = datagram(buf, 0, 0.0, 1.0, 0.0);
    gs_peer_stats ps;
    gs_unknown_stats unknown;
    int r;
    (void)state;
    assert_int_equal(gs_net_update(h->net, 1e300), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_update(h->net, -1.0), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_update(h->net, NAN), GS_ERR_NOT_FINITE);
    assert_int_equal(gs_net_deliver(h->net, buf, n, -1e12, NULL), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_deliver(h->net, buf, n, 2e9, NULL), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_deliver(h->net, buf, n, NAN, NULL), GS_ERR_NOT_FINITE);
    assert_int_equal(gs_net_peer_stats(h->net, 2, &ps), GS_OK);
    assert_int_equal(ps.datagrams_received + ps.rejected_total, 0);
    assert_int_equal(gs_net_unknown_stats(h->net, &unknown), GS_OK);
    for (r = 0; r < GS_REJECT_COUNT; ++r) assert_int_equal(unknown.rejected[r], 0);
    assert_int_equal(gs_net_deliver(h->net, buf, n, 1.0, NULL), GS_OK);
    host_free(h);
}

/* ---- finding 6: loops that count time ---- */

/* A frame that cannot move the simnet's clock (1e-17 s once now = 1: the
   loop ran for ever) is refused, as is a run past GS_WIRE_MAX_TIME. */
static void test_simnet_frame_progress(void **state) {
    gs_simnet *sim = NULL;
    gs_world *w = world_new(1);
    gs_net *net = NULL;
    double x[3] = {0.0, 0.0, 0.0};
    (void)state;
    assert_int_equal(gs_simnet_create(NULL, &sim), GS_OK);
    still_new(w, 0.01, x);
    assert_int_equal(test_join(sim, w, NULL, &net), GS_OK);
    assert_int_equal(gs_simnet_run(sim, 1.0, 0.1), GS_OK);
    assert_int_equal(gs_simnet_run(sim, 1.0, 1e-17), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_simnet_run(sim, 1.0, 0.5 * GS_MIN_DT), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_simnet_run(sim, GS_WIRE_MAX_TIME, 0.1), GS_ERR_INVALID_ARG);
    assert_true(fabs(gs_simnet_time(sim) - 1.0) < 1e-9); /* 10 frames of 0.1 s */
    assert_int_equal(gs_simnet_run(sim, 1e-5, GS_MIN_DT), GS_OK);
    gs_world_destroy(w);
    gs_simnet_destroy(sim);
}

/* A state whose time is outside [0, GS_WIRE_MAX_TIME] is refused (-1e300:
   the next advance never returned; -1e6: 1e9 steps of catching up), and
   the agent keeps its state. */
static void test_set_state_time_bounded(void **state) {
    static const double bad[5] = {-1e300, -1e6, -1e-9, 1.5e9, 1e300};
    gs_world *w = world_new(1);
    double x[3] = {1.0, 2.0, 3.0}, s[4];
    gs_agent *a;
    int i;
    (void)state;
    a = still_new(w, 0.001, x);
    for (i = 0; i < 5; ++i) {
        s[0] = bad[i];
        s[1] = s[2] = s[3] = 9.0;
        assert_int_equal(gs_agent_set_state(a, s, 4), GS_ERR_INVALID_ARG);
        assert_non_null(strstr(gs_world_error(w), "GS_WIRE_MAX_TIME"));
        assert_true(gs_agent_time(a) == 0.0 && x[0] == 1.0);
    }
    s[0] = GS_WIRE_MAX_TIME;
    assert_int_equal(gs_agent_set_state(a, s, 4), GS_OK);
    /* at the end of time a step is refused, and the time stays */
    assert_int_equal(gs_agent_step(a), GS_ERR_OUT_OF_RANGE);
    assert_true(gs_agent_time(a) == GS_WIRE_MAX_TIME);
    gs_world_destroy(w);
}

/* An advance past GS_WIRE_MAX_TIME is refused and changes nothing; two
   advances of 1e308 made the world's time infinite. */
static void test_advance_target_bounded(void **state) {
    gs_world *w = world_new(1);
    double x[3] = {0.0, 0.0, 0.0};
    gs_advance_report rep;
    (void)state;
    still_new(w, 0.01, x);
    assert_int_equal(gs_world_advance(w, 0.1, NULL), GS_OK);
    assert_int_equal(gs_world_advance(w, 1e308, &rep), GS_ERR_INVALID_ARG);
    assert_non_null(strstr(gs_world_error(w), "GS_WIRE_MAX_TIME"));
    assert_int_equal(gs_world_advance(w, 1e308, NULL), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_world_advance(w, GS_WIRE_MAX_TIME, NULL), GS_ERR_INVALID_ARG);
    assert_true(gs_world_time(w) == 0.1);
    assert_int_equal(gs_world_advance(w, 0.1, NULL), GS_OK);
    gs_world_destroy(w);
}

/* An advance of 1e9 s returns: at most max_steps steps per call (it ran
   for ever), then reached = 0, and the next call goes on from there. */
static void test_advance_steps_bounded(void **state) {
    gs_world_desc wd = gs_world_desc_default();
    gs_world *w = NULL;
    double x[3] = {0.0, 0.0, 0.0};
    gs_advance_report rep;
    gs_agent *a[2];
    (void)state;
    assert_true(wd.max_steps == GS_DEFAULT_MAX_STEPS);
    wd.max_steps = 10000;
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    a[0] = still_new(w, 0.001, x);
    a[1] = still_new(w, 0.002, x);
    assert_int_equal(gs_world_advance(w, 1e9 - 1.0, &rep), GS_OK);
    assert_int_equal(rep.reached, 0);
    assert_true(rep.steps == 10000);
    assert_int_equal(gs_world_advance(w, 0.0, &rep), GS_OK);
    assert_true(rep.steps == 10000 && rep.reached == 0);
    assert_true(gs_agent_time(a[0]) > 0.0 && gs_agent_time(a[1]) > 0.0);
    gs_world_destroy(w);
}

/* The same with the default bound: one call of 1e9 s returns after
   GS_DEFAULT_MAX_STEPS cheap steps (0.3 s measured, 1.2 s under ASan). */
static void test_advance_default_bound(void **state) {
    gs_world *w = world_new(1);
    double x[3] = {0.0, 0.0, 0.0};
    gs_advance_report rep;
    (void)state;
    still_new(w, 0.001, x);
    assert_int_equal(gs_world_advance(w, 1e9, &rep), GS_OK);
    assert_int_equal(rep.reached, 0);
    assert_true(rep.steps == GS_DEFAULT_MAX_STEPS);
    gs_world_destroy(w);
}

/* A dt below GS_MIN_DT is refused by every create call that takes one
   (1e-300 was taken). */
static void test_min_dt(void **state) {
    static const double bad[3] = {1e-300, 1e-9, 0.5 * GS_MIN_DT};
    gs_world *w = world_new(1);
    gs_agent *a = NULL;
    double x[3] = {0.0, 0.0, 0.0};
    int i;
    (void)state;
    for (i = 0; i < 3; ++i) {
        gs_custom_desc cd = custom_desc(bad[i], 3, still_step, still_get, still_set, x);
        gs_cloth_desc cl = gs_cloth_desc_default();
        gs_rigid_desc rd = gs_rigid_desc_default();
        gs_probe_desc pd = gs_probe_desc_default();
        assert_int_equal(gs_custom_create(w, &cd, &a), GS_ERR_INVALID_ARG);
        assert_non_null(strstr(gs_world_error(w), "GS_MIN_DT"));
        cl.nx = cl.ny = 4;
        cl.solver.dt = bad[i];
        assert_int_equal(gs_cloth_create(w, &cl, &a), GS_ERR_INVALID_ARG);
        rd.shape.type = GS_SHAPE_SPHERE;
        rd.shape.radius = 0.1;
        rd.solver.dt = bad[i];
        assert_int_equal(gs_rigid_create(w, &rd, &a), GS_ERR_INVALID_ARG);
        pd.shape.type = GS_SHAPE_SPHERE;
        pd.shape.radius = 0.1;
        pd.dt = bad[i];
        assert_int_equal(gs_probe_create(w, &pd, &a), GS_ERR_INVALID_ARG);
        assert_int_equal(gs_world_agent_count(w), 0);
    }
    still_new(w, GS_MIN_DT, x);
    assert_int_equal(gs_world_advance(w, 1e-4, NULL), GS_OK);
    gs_world_destroy(w);
}

/* Scene settling is bounded: dt = 1e-9 overflowed (int)(3.0 / dt) (UB),
   dt = 1e-7 and cloth_n = 4096 settled for minutes. Each is refused at
   once now and the world is left as it was. */
static void test_scene_settle_bounded(void **state) {
    gs_world *w = world_new(1);
    gs_scene sc;
    gs_scene_desc sd;
    (void)state;
    sd = gs_scene_desc_default();
    sd.dt = 1e-9;
    assert_int_equal(gs_scene_create(w, &sd, &sc), GS_ERR_INVALID_ARG);
    sd.dt = 1e-7;
    assert_int_equal(gs_scene_create(w, &sd, &sc), GS_ERR_INVALID_ARG);
    sd.dt = GS_MIN_DT; /* allowed alone, but 256 * 3e6 particle steps */
    assert_int_equal(gs_scene_create(w, &sd, &sc), GS_ERR_INVALID_ARG);
    assert_non_null(strstr(gs_world_error(w), "GS_SCENE_SETTLE_WORK"));
    sd = gs_scene_desc_default();
    sd.cloth_n = 4096;
    assert_int_equal(gs_scene_create(w, &sd, &sc), GS_ERR_INVALID_ARG);
    assert_non_null(strstr(gs_world_error(w), "GS_SCENE_SETTLE_WORK"));
    assert_int_equal(gs_world_agent_count(w), 0);
    /* a small one still settles */
    sd.cloth_n = 4;
    assert_int_equal(gs_scene_create(w, &sd, &sc), GS_OK);
    assert_true(gs_agent_time(sc.cloth) == 0.0);
    gs_world_destroy(w);
}

/* A host 100 s behind the session (a late joiner) still catches up, at
   GS_MAX_TIME_CORRECTION per advance: in 100 / 10 advances or a few more,
   and no advance moves it by more. */
static void test_late_joiner_bounded(void **state) {
    host *h = host_new();
    double now = 100.0, prev = 0.0;
    uint32_t seq = 0;
    int k, caught = -1;
    gs_reject why;
    (void)state;
    for (k = 0; k < 30; ++k) {
        double t;
        now += FRAME;
        assert_int_equal(deliver(h, seq, now - 0.005, now - 0.005, 0.0, now, &why), GS_OK);
        seq++;
        assert_int_equal(gs_world_advance(h->w, FRAME, NULL), GS_OK);
        assert_int_equal(gs_net_update(h->net, now), GS_OK);
        t = gs_agent_time(h->a);
        assert_true(t - prev <= GS_MAX_TIME_CORRECTION + FRAME + 0.002 + 1e-9);
        prev = t;
        /* within 0.1 s: the time band (tolerance + a send period, 27 ms)
           under which no correction is made, and a step */
        if (caught < 0 && fabs(t - now) < 0.1) caught = k;
    }
    print_message("late joiner 100 s behind: within 0.1 s after %d advances\n", caught + 1);
    assert_true(caught >= 9 && caught < 15);
    assert_true(fabs(gs_agent_time(h->a) - now) < 0.1);
    host_free(h);
}

int main(int argc, char **argv) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_forged_send_time_refused),
        cmocka_unit_test(test_implausible_age_unknown),
        cmocka_unit_test(test_correction_bounded_per_advance),
        cmocka_unit_test(test_age_bounded),
        cmocka_unit_test(test_wire_refuses_header_times),
        cmocka_unit_test(test_net_now_bounded),
        cmocka_unit_test(test_simnet_frame_progress),
        cmocka_unit_test(test_set_state_time_bounded),
        cmocka_unit_test(test_advance_target_bounded),
        cmocka_unit_test(test_advance_steps_bounded),
        cmocka_unit_test(test_advance_default_bound),
        cmocka_unit_test(test_min_dt),
        cmocka_unit_test(test_scene_settle_bounded),
        cmocka_unit_test(test_late_joiner_bounded),
    };
    if (argc > 1) cmocka_set_test_filter(argv[1]);
    return cmocka_run_group_tests_name("hostile_time", tests, NULL, NULL);
}
