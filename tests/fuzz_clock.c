/* fuzz_clock.c - libFuzzer harness over time: sequences of datagrams from
   two peers whose clocks run, round trips and all, against the world of
   tests/fuzz_world.h (host 1, peers 2 and 3, six ghosts of every kind).

   tests/fuzz_wire.c mutates datagrams; the clock fields it makes rarely
   describe a round trip (an echo of the host's own send time), so it never
   reached the state that issue 14's remote freeze needs: a known clock
   offset, then one datagram whose send time makes an age of 1e300 s. Here
   the input is a program of 4-byte operations, each on the state the
   previous ones left:
     frame       1/60 s of wall time: each peer sends an honest datagram
                 (its clock, an echo of the host's latest send), the world
                 advances 1/60 s, the net sends what is due
     datagram    one from a peer, its fields picked from tables that hold
                 the honest value and hostile ones: the snapshot time (the
                 local time, near it, a year on, 0, GS_WIRE_MAX_TIME), the
                 send time (the peer's clock, off it by ms to 100 s, 0,
                 -1e12, -1e300, past GS_WIRE_MAX_TIME), the echo (none, the
                 true one, off it, in the future, negative), the hold, the
                 sequence (next, or the last again), the objects it carries
     advance     the world by 0 .. 0.1 s, or by -1 or 1e308 (refused)
     clock       wall time on by 0 .. 1000 s; a peer's clock stepped
     update      gs_net_update at the wall time
     set_state   one agent's time set to a hostile or a valid value
   After every operation:
     - every agent's state and render state is finite, and every agent's
       time and the world's time are in [0, GS_WIRE_MAX_TIME];
     - an advance moves each agent by its steps (steps * dt), plus at most
       GS_MAX_TIME_CORRECTION of blending, plus the world's follow (a
       lagging agent may jump to the clock the others set, which the
       world's time shows);
     - a refused call changes no time; every call returns one of the codes
       its declaration lists; a send time outside [0, GS_WIRE_MAX_TIME] is
       refused as GS_REJECT_TIME.

   Build: make fuzz (clang -fsanitize=fuzzer,address,undefined). The cmocka
   test tests/test_fuzz_regress.c replays the regressions and an input of
   the attack through the same checks (FUZZ_FAIL). Plain C. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz_world.h"

#ifndef FUZZ_FAIL
#define FUZZ_FAIL(what) \
    (fprintf(stderr, "fuzz_clock: %s:%d: check failed: %s\n", __FILE__, __LINE__, what), \
     abort())
#endif
#ifndef FUZZ_CHECK
#define FUZZ_CHECK(c) do { if (!(c)) FUZZ_FAIL(#c); } while (0)
#endif

#define FC_MAX_OPS 48     /* operations taken from one input */
#define FC_FRAME (1.0 / 60.0)

typedef struct fc_state {
    fuzz_world f;
    double now;             /* the host's wall clock (s) */
    double peer_off[2];     /* each peer's clock less the host's (s) */
    uint32_t seq[2];        /* each peer's next datagram sequence */
    uint32_t snap_seq[2];   /* and snapshot sequence */
    double host_sent;       /* the send time of the host's latest datagram */
} fc_state;

static const uint32_t fc_peer[2] = {FUZZ_PEER_A, FUZZ_PEER_B};

/* The host's transport: notes the send time a peer will echo. */
static gs_result fc_send(void *user, uint32_t host, const void *data, size_t size) {
    fc_state *s = (fc_state *)user;
    gs_wire_view v;
    gs_reject why;
    FUZZ_CHECK(host == FUZZ_PEER_A || host == FUZZ_PEER_B);
    FUZZ_CHECK(gs_wire_decode((const unsigned char *)data, size, &v, &why) == GS_OK);
    FUZZ_CHECK(v.header.send_time >= 0.0 && v.header.send_time <= GS_WIRE_MAX_TIME);
    s->host_sent = v.header.send_time;
    return GS_OK;
}

static int fc_time_ok(double t) { return t >= 0.0 && t <= GS_WIRE_MAX_TIME; }

/* Every agent's state and render state finite, every time in range. */
static void fc_check(const fc_state *s) {
    double st[1 + 49 * 6];
    int i;
    size_t k;
    for (i = 0; i < FUZZ_OBJECTS; ++i) {
        const gs_agent *a = s->f.agent[i];
        size_t n = gs_agent_state_size(a);
        FUZZ_CHECK(n <= sizeof st / sizeof st[0]);
        FUZZ_CHECK(gs_agent_get_state(a, st, n) == GS_OK);
        for (k = 0; k < n; ++k) FUZZ_CHECK(isfinite(st[k]));
        FUZZ_CHECK(fc_time_ok(st[0]) && st[0] == gs_agent_time(a));
        FUZZ_CHECK(gs_ghost_render_state(a, st, n) == GS_OK);
        for (k = 0; k < n; ++k) FUZZ_CHECK(isfinite(st[k]));
    }
    FUZZ_CHECK(fc_time_ok(gs_world_time(s->f.w)));
}

/* Appends the snapshot of object `id` (agent i) at time t: its own state,
   chunk 0 only (a lost chunk leaves the rest unblended). 0 if the encoder
   refuses the time. */
static int fc_add(fc_state *s, unsigned char *buf, size_t *size, int i, double t,
                  uint32_t sseq) {
    double st[1 + 49 * 6];
    gs_wire_chunk c;
    size_t n = gs_agent_state_size(s->f.agent[i]), vars = n - 1;
    FUZZ_CHECK(gs_agent_get_state(s->f.agent[i], st, n) == GS_OK);
    memset(&c, 0, sizeof c);
    c.object_id = 10u + (uint32_t)i;
    c.sequence = sseq;
    c.time = t;
    c.count = (uint16_t)(i == 0 ? 3 : 1); /* the cloth: 3 chunks of 135 f64 */
    c.elements = (uint16_t)(vars > 135 ? 135 : vars);
    c.encoding = GS_ENCODING_F64;
    return gs_wire_add(buf, GS_WIRE_MAX_DATAGRAM, size, &c, st + 1) == GS_OK;
}

/* One datagram from peer p, its fields from b[0..3]; honest: the peer's
   clock, the true echo, the local time. */
static void fc_datagram(fc_state *s, int p, const uint8_t *b, int honest) {
    static const double dt_snap[16] = {0.0, 1e-3, -1e-3, 0.02, -0.02, 0.5, -0.5, 5.0,
                                       -5.0, 100.0, -100.0, 1e6, 3e7, 0.0, 0.0, 0.0};
    static const double d_send[16] = {0.0, -0.001, -0.005, -0.05, -0.5, -3.0, -100.0, 0.001,
                                      1.0, 100.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    static const double abs_send[6] = {0.0, GS_WIRE_MAX_TIME, -1.0, -1e12, -1e300, 2e9};
    static const double hold[4] = {0.0, 0.001, 0.05, -0.05};
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    gs_wire_header h;
    size_t size = 0;
    int i, any = 0, ts = honest ? 0 : b[1] % 16, ss = honest ? 2 : b[2] % 16;
    int es = honest ? 1 : b[3] % 8, objs = honest ? 15 : (b[3] >> 5) | (b[0] & 8);
    double t_local = gs_agent_time(s->f.agent[2]), t, t0 = gs_world_time(s->f.w);
    gs_reject why = GS_REJECT_COUNT;
    gs_result r;
    memset(&h, 0, sizeof h);
    h.session = FUZZ_SESSION;
    h.sender = fc_peer[p];
    h.sequence = (!honest && (b[0] & 16) && s->seq[p]) ? s->seq[p] - 1 : s->seq[p]++;
    h.send_time = ss < 10 ? s->now + s->peer_off[p] + d_send[ss] : abs_send[ss - 10];
    switch (es) {
    case 0: h.echo_time = 0.0; break;
    case 1: h.echo_time = s->host_sent; break;
    case 2: h.echo_time = s->host_sent - 0.01; break;
    case 3: h.echo_time = s->host_sent + 1.0; break;
    case 4: h.echo_time = s->now; break;
    case 5: h.echo_time = s->now + 1.0; break;
    case 6: h.echo_time = -1.0; break;
    default: h.echo_time = 1e300;
    }
    h.echo_hold = honest ? 0.0 : hold[(b[3] >> 3) % 4];
    t = ts == 13 ? 0.0 : ts == 14 ? GS_WIRE_MAX_TIME : ts == 15 ? 0.5 * GS_WIRE_MAX_TIME
                                                      : t_local + dt_snap[ts];
    FUZZ_CHECK(gs_wire_begin(buf, sizeof buf, &h, &size) == GS_OK);
    s->snap_seq[p]++;
    /* objects 12, 14, 15 and the cloth's first chunk */
    for (i = 0; i < 4; ++i) {
        static const int agent[4] = {2, 4, 5, 0};
        if (!(objs & (1 << i))) continue;
        if (!fc_add(s, buf, &size, agent[i], t, s->snap_seq[p])) break;
        any = 1;
    }
    if (!any) return;
    size = gs_wire_end(buf, size);
    r = gs_net_deliver(s->f.net, buf, size, s->now, &why);
    FUZZ_CHECK(r == GS_OK || r == GS_ERR_REJECTED);
    if (!fc_time_ok(h.send_time) || !fc_time_ok(h.echo_time))
        FUZZ_CHECK(r == GS_ERR_REJECTED && why == GS_REJECT_TIME);
    FUZZ_CHECK(gs_world_time(s->f.w) == t0); /* delivery queues, never blends */
}

/* Advances the world by `seconds` and checks what moved each agent: its
   steps, at most GS_MAX_TIME_CORRECTION of blending, and the follow. */
static void fc_advance(fc_state *s, double seconds) {
    double t_before[FUZZ_OBJECTS], w_before = gs_world_time(s->f.w), w_after;
    uint64_t steps_before[FUZZ_OBJECTS];
    gs_result r;
    int i;
    for (i = 0; i < FUZZ_OBJECTS; ++i) {
        t_before[i] = gs_agent_time(s->f.agent[i]);
        steps_before[i] = agent_stats(s->f.agent[i]).steps;
    }
    r = gs_world_advance(s->f.w, seconds, NULL);
    w_after = gs_world_time(s->f.w);
    if (!(seconds >= 0.0) || seconds > GS_WIRE_MAX_TIME - w_before)
        FUZZ_CHECK(r == GS_ERR_INVALID_ARG || r == GS_ERR_NOT_FINITE);
    if (r == GS_ERR_INVALID_ARG || r == GS_ERR_NOT_FINITE) {
        /* refused (also a target past GS_WIRE_MAX_TIME once the world's
           clock has followed its agents): nothing moved */
        FUZZ_CHECK(w_after == w_before);
        for (i = 0; i < FUZZ_OBJECTS; ++i)
            FUZZ_CHECK(gs_agent_time(s->f.agent[i]) == t_before[i]);
        return;
    }
    FUZZ_CHECK(r == GS_OK || r == GS_ERR_UNSTABLE || r == GS_ERR_OUT_OF_RANGE);
    for (i = 0; i < FUZZ_OBJECTS; ++i) {
        const gs_agent *a = s->f.agent[i];
        double t = gs_agent_time(a);
        double stepped = (double)(agent_stats(a).steps - steps_before[i]) * gs_agent_dt(a);
        double moved = t - t_before[i] - stepped;
        double follow = w_after - seconds - t_before[i];
        /* t = steps * dt + offset: a sum of numbers up to 1e9 rounds */
        double eps = 1e-12 * (fabs(t) + fabs(t_before[i]) + stepped) + 1e-9;
        FUZZ_CHECK(fabs(moved) <= GS_MAX_TIME_CORRECTION + (follow > 0.0 ? follow : 0.0) + eps);
    }
}

/* Runs one input. */
int fuzz_clock_one(const uint8_t *data, size_t size);
int fuzz_clock_one(const uint8_t *data, size_t size) {
    static const double frames[8] = {0.0, 1e-3, 4e-3, FC_FRAME, 0.05, 0.1, -1.0, 1e308};
    static const double hops[8] = {0.0, 1e-3, 4e-3, FC_FRAME, 0.1, 1.0, 10.0, 1000.0};
    static const double steps[4] = {0.0, 0.01, -50.0, 50.0};
    static const double set_t[8] = {-1e300, -1.0, 0.0, 1.0, GS_WIRE_MAX_TIME, 2e9, NAN, 1e300};
    static fc_state s;
    size_t at;
    int ops = 0, p;
    memset(&s, 0, sizeof s);
    s.now = 10.0;
    s.peer_off[1] = 100.0; /* peer 3's clock reads 100 s more */
    FUZZ_CHECK(fuzz_world_create(&s.f, FUZZ_HOST, 0.0, fc_send, &s) == GS_OK);
    for (at = 0; at + 4 <= size && ops++ < FC_MAX_OPS; at += 4) {
        const uint8_t *b = data + at;
        p = (b[0] >> 7) & 1;
        switch (b[0] % 8) {
        case 0: case 1: /* a frame, round trips and all */
            s.now += FC_FRAME;
            fc_datagram(&s, 0, b, 1);
            fc_datagram(&s, 1, b, 1);
            fc_advance(&s, FC_FRAME);
            FUZZ_CHECK(gs_net_update(s.f.net, s.now) == GS_OK);
            break;
        case 2: case 3:
            fc_datagram(&s, p, b, 0);
            break;
        case 4:
            fc_advance(&s, frames[b[1] % 8]);
            break;
        case 5: /* wall time on (never past the bound), a peer's clock stepped */
            if (s.now + hops[b[1] % 8] <= GS_WIRE_MAX_TIME) s.now += hops[b[1] % 8];
            s.peer_off[p] += steps[b[2] % 4];
            break;
        case 6:
            FUZZ_CHECK(gs_net_update(s.f.net, s.now) == GS_OK);
            break;
        default: { /* one agent's time set */
            gs_agent *a = s.f.agent[b[1] % FUZZ_OBJECTS];
            double st[1 + 49 * 6], t_before = gs_agent_time(a), v = set_t[b[2] % 8];
            size_t n = gs_agent_state_size(a);
            gs_result r;
            FUZZ_CHECK(gs_agent_get_state(a, st, n) == GS_OK);
            st[0] = v;
            r = gs_agent_set_state(a, st, n);
            if (fc_time_ok(v)) {
                FUZZ_CHECK(r == GS_OK && gs_agent_time(a) == v);
            } else {
                FUZZ_CHECK(r == GS_ERR_INVALID_ARG || r == GS_ERR_NOT_FINITE);
                FUZZ_CHECK(gs_agent_time(a) == t_before);
            }
        }
        }
        fc_check(&s);
    }
    fc_advance(&s, 0.05);
    fc_check(&s);
    fuzz_world_destroy(&s.f);
    return 0;
}

#ifndef FUZZ_NO_ENTRY
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    return fuzz_clock_one(data, size);
}
#endif
