/* test_wire2.c - wire format v2 (>>wire, >>net): the quantized encoding
   and send on change.

   What is checked: quantized scalars come back within half their step at
   the edges of the ranges the header states (a span just under 2^32 steps,
   just over it, values near GS_MAX_COORD, the smallest step), quaternions
   within the smallest-three bound and in the sender's hemisphere; a
   quantized state read back re-encodes to the same bytes; every malformed
   quantized payload is refused as a layout error; a v1 datagram gets its
   own reason; between two nets a quantized state arrives bit for bit as
   the sender's quantized state; a state at rest costs heartbeats only,
   and the receiver tells "at rest" from "silent".

   Worlds talk through this file's own transport (datagrams kept in a
   list, handed over by hand), so that nothing depends on timing. */
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
#include "wire_helpers.h"

/* ---- helpers ---- */


static uint64_t rng_state = 0x9e3779b97f4a7c15ull;
static double rnd(void) { /* xorshift64*, in [0, 1) */
    rng_state ^= rng_state >> 12;
    rng_state ^= rng_state << 25;
    rng_state ^= rng_state >> 27;
    return (double)((rng_state * 2685821657736338717ull) >> 11) / 9007199254740992.0;
}

static gs_wire_header header_v2(void) {
    gs_wire_header h;
    memset(&h, 0, sizeof h);
    h.session = 1;
    h.sender = 2;
    h.sequence = 7;
    h.send_time = 1.0;
    return h;
}

/* One quantized chunk of n scalars at step, or of quaternions (quat: n a
   multiple of 4), encoded, decoded; the decoded values in out. Returns
   the datagram's size. */
static size_t quant_roundtrip(const double *v, int n, double step, int quat, int bits,
                              double *out, gs_wire_chunk *dec, unsigned char *buf) {
    gs_wire_header h = header_v2();
    gs_wire_chunk c;
    gs_wire_view *view = (gs_wire_view *)malloc(sizeof *view);
    gs_reject why = GS_REJECT_COUNT;
    size_t size;
    int i;
    assert_non_null(view);
    memset(&c, 0, sizeof c);
    c.object_id = 9;
    c.sequence = 3;
    c.time = 12.5;
    c.count = 1;
    c.elements = (uint16_t)n;
    c.encoding = GS_ENCODING_QUANT;
    c.segment_count = 1;
    c.segments[0].kind = quat ? GS_WIRE_QUATERNION : GS_WIRE_SCALAR;
    c.segments[0].count = (uint16_t)n;
    c.segments[0].step = step;
    c.segments[0].bits = bits;
    assert_int_equal(gs_wire_begin(buf, GS_WIRE_MAX_DATAGRAM, &h, &size), GS_OK);
    assert_int_equal(gs_wire_add(buf, GS_WIRE_MAX_DATAGRAM, &size, &c, v), GS_OK);
    size = gs_wire_end(buf, size);
    assert_int_equal(gs_wire_decode(buf, size, view, &why), GS_OK);
    assert_int_equal(view->chunk_count, 1);
    *dec = view->chunks[0];
    assert_int_equal(dec->encoding, GS_ENCODING_QUANT);
    assert_true(dec->time == 12.5); /* the time exact */
    for (i = 0; i < n; ++i) out[i] = gs_wire_value(dec, i);
    {
        /* the one-pass reader gives the same, bit for bit */
        double *all = (double *)malloc((size_t)n * sizeof(double));
        assert_non_null(all);
        gs_wire_values(dec, all);
        assert_memory_equal(all, out, (size_t)n * sizeof(double));
        free(all);
    }
    free(view);
    return size;
}

/* ---- quantization ---- */

static void check_scalars(const double *v, int n, double step, double want_step) {
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    double out[240];
    gs_wire_chunk d;
    int i;
    quant_roundtrip(v, n, step, 0, 0, out, &d, buf);
    if (d.segments[0].step != want_step)
        fail_msg("step %g sent, %g expected", d.segments[0].step, want_step);
    for (i = 0; i < n; ++i) {
        /* half the step sent, the bound the header states; v / step is
           rounded to the nearest double first, which may add one unit of
           v's last place */
        double tol = 0.5 * want_step + 2.3e-16 * fabs(v[i]);
        if (!(fabs(out[i] - v[i]) <= tol))
            fail_msg("value %d: %.17g came back %.17g (step %g)", i, v[i], out[i], want_step);
    }
}

static void test_quant_scalar_edges(void **state) {
    const double res = 5e-5, span = 4294967295.0 * res; /* 2^32 - 1 steps */
    double v[240];
    int i;
    (void)state;
    /* a paper-sized scene: within 1 m, the step as asked */
    for (i = 0; i < 240; ++i) v[i] = 2.0 * rnd() - 1.0;
    check_scalars(v, 240, res, res);
    /* the range's edges: a span of just under 2^32 steps keeps the step */
    v[0] = -0.5 * span + 2 * res;
    v[1] = 0.5 * span - 2 * res;
    for (i = 2; i < 240; ++i) v[i] = v[0] + (v[1] - v[0]) * rnd();
    check_scalars(v, 240, res, res);
    /* just over it: the step doubles, once */
    v[0] = -0.5 * span - 4 * res;
    v[1] = 0.5 * span + 4 * res;
    check_scalars(v, 240, res, 2 * res);
    /* values near GS_MAX_COORD, close together: 2e13 steps from 0 fit in
       a double's 53 bits, the step stays */
    for (i = 0; i < 240; ++i) v[i] = GS_MAX_COORD - 10.0 * rnd();
    check_scalars(v, 240, res, res);
    for (i = 0; i < 240; ++i) v[i] = -GS_MAX_COORD + 10.0 * rnd();
    check_scalars(v, 240, res, res);
    /* the smallest step far from 0: 1e21 steps do not fit in 2^51 (the
       encoder's exact rounding), the step doubles until they do (1e9 /
       2^51 = 4.4e-7: 2^19 * 1e-12) */
    for (i = 0; i < 240; ++i) v[i] = GS_MAX_COORD - 10.0 * rnd();
    check_scalars(v, 240, 1e-12, 1e-12 * 524288.0);
    /* all equal: width 0, no bits at all */
    for (i = 0; i < 240; ++i) v[i] = 0.125;
    check_scalars(v, 240, res, res);
}

/* The defaults' bounds as >>wire states them: a position within 0.025 mm,
   a velocity within 1.5 mm/s, and that velocity error over one send
   period no more than the position's own (the reason for its step). */
static void test_quant_default_steps(void **state) {
    const gs_ghost_desc gd = gs_ghost_desc_default();
    double v[240];
    int i;
    (void)state;
    assert_true(0.5 * gd.position_resolution <= 2.5e-5);
    assert_true(0.5 * gd.velocity_resolution <= 1.5e-3);
    assert_true(0.5 * gd.velocity_resolution / gd.send_rate <=
                0.5 * gd.position_resolution * (1.0 + 1e-12));
    /* a cloth's velocities (a push: up to 3 m/s), then its positions */
    for (i = 0; i < 240; ++i) v[i] = 6.0 * rnd() - 3.0;
    check_scalars(v, 240, gd.velocity_resolution, gd.velocity_resolution);
    for (i = 0; i < 240; ++i) v[i] = 2.0 * rnd() - 1.0;
    check_scalars(v, 240, gd.position_resolution, gd.position_resolution);
}

static void test_quant_quaternion_edges(void **state) {
    static const int bits_list[3] = {8, 16, 24};
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    double q[240], out[240];
    gs_wire_chunk d;
    int b, i, k;
    (void)state;
    for (b = 0; b < 3; ++b) {
        int bits = bits_list[b];
        double st = 1.4142135623730951 / (double)((1u << bits) - 1u);
        for (i = 0; i < 240; i += 4) {
            double nrm = 0.0;
            for (k = 0; k < 4; ++k) {
                q[i + k] = 2.0 * rnd() - 1.0;
                nrm += q[i + k] * q[i + k];
            }
            for (k = 0; k < 4; ++k) q[i + k] /= sqrt(nrm);
        }
        /* the edges: identity either sign, two components tied for the
           largest (each 1/sqrt(2)), all four tied, one negative largest */
        memcpy(q, (const double[]){0, 0, 0, 1, 0, 0, 0, -1, 0.7071067811865476, 0,
                                   0, 0.7071067811865476, 0.5, -0.5, 0.5, -0.5, 0.1, -0.9, 0.3,
                                   0.2},
               20 * sizeof(double));
        {
            double n4 = sqrt(0.01 + 0.81 + 0.09 + 0.04);
            for (k = 16; k < 20; ++k) q[k] /= n4;
        }
        quant_roundtrip(q, 240, 0, 1, bits, out, &d, buf);
        for (i = 0; i < 240; i += 4) {
            double dot = 0.0, err = 0.0;
            for (k = 0; k < 4; ++k) {
                dot += q[i + k] * out[i + k];
                err = fmax(err, fabs(q[i + k] - out[i + k]));
            }
            /* the sender's hemisphere: a blend of q and -q would vanish */
            assert_true(dot > 0.0);
            /* three components within half a step each (the header's
               bound); the largest, from the unit norm, by at most
               sqrt(3) times that over its size (>= 1/2): 2 sqrt(3) / 2 */
            if (!(err <= 1.8 * st)) fail_msg("bits %d quaternion %d: error %g, step %g", bits,
                                              i / 4, err, st);
        }
    }
}

/* A quantized state read back encodes to the same bytes: the receiver
   holds exactly the sender's quantized state. */
static void test_quant_idempotent(void **state) {
    unsigned char a[GS_WIRE_MAX_DATAGRAM], b[GS_WIRE_MAX_DATAGRAM];
    double v[200], once[200], twice[200];
    gs_wire_chunk d;
    size_t na, nb;
    int i;
    (void)state;
    for (i = 0; i < 200; ++i) v[i] = 30.0 * rnd() - 15.0;
    na = quant_roundtrip(v, 200, 5e-5, 0, 0, once, &d, a);
    nb = quant_roundtrip(once, 200, 5e-5, 0, 0, twice, &d, b);
    assert_int_equal(na, nb);
    assert_memory_equal(a, b, na);
    assert_memory_equal(once, twice, sizeof once);
    /* 16 bits a value for a 30 m span at 0.05 mm (6e5 steps: 20 bits) */
    assert_true(na < GS_WIRE_HEADER + GS_WIRE_CHUNK_HEADER + 200 * 20 / 8 + 40);
}

/* Where the first chunk's payload starts in datagram buf (n bytes): its
   header's length varies (>>wire). */
static size_t payload_at(const unsigned char *buf, size_t n) {
    gs_wire_view *v = (gs_wire_view *)malloc(sizeof *v);
    size_t at;
    assert_non_null(v);
    assert_int_equal(gs_wire_decode(buf, n, v, NULL), GS_OK);
    at = (size_t)(v->chunks[0].payload - buf);
    free(v);
    return at;
}

/* ---- validation ---- */

static void expect_reject(const unsigned char *buf, size_t n, gs_reject want) {
    gs_wire_view *v = (gs_wire_view *)malloc(sizeof *v);
    unsigned char *copy = (unsigned char *)malloc(n);
    gs_reject why = GS_REJECT_COUNT;
    assert_non_null(v);
    assert_non_null(copy);
    memcpy(copy, buf, n); /* exactly n bytes: ASan sees a read past them */
    assert_int_equal(gs_wire_decode(copy, n, v, &why), GS_ERR_REJECTED);
    if (why != want) fail_msg("refused as %s, not %s", gs_reject_str(why), gs_reject_str(want));
    free(copy);
    free(v);
}

static void test_quant_rejects(void **state) {
    unsigned char buf[GS_WIRE_MAX_DATAGRAM], m[GS_WIRE_MAX_DATAGRAM];
    double v[8] = {0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8}, out[8];
    gs_wire_chunk d;
    size_t n = quant_roundtrip(v, 8, 1e-3, 0, 0, out, &d, buf);
    const size_t pay = payload_at(buf, n); /* the payload's start */
    int k, rejected = 0;
    gs_wire_view *view = (gs_wire_view *)malloc(sizeof *view);
    (void)state;
    assert_non_null(view);
    /* v1 and v2: their own reason */
    memcpy(m, buf, n);
    m[4] = 1;
    recrc(m, n);
    expect_reject(m, n, GS_REJECT_OLD_VERSION);
    m[4] = 2;
    recrc(m, n);
    expect_reject(m, n, GS_REJECT_OLD_VERSION);
    assert_non_null(strstr(gs_reject_str(GS_REJECT_OLD_VERSION), "v1"));
    /* segment count 0 and 5 */
    memcpy(m, buf, n); m[pay] = 0; recrc(m, n); expect_reject(m, n, GS_REJECT_LAYOUT);
    memcpy(m, buf, n); m[pay] = 5; recrc(m, n); expect_reject(m, n, GS_REJECT_LAYOUT);
    /* a kind that is neither */
    memcpy(m, buf, n); m[pay + 1] = 3; recrc(m, n); expect_reject(m, n, GS_REJECT_LAYOUT);
    /* a count that does not add up to the chunk's elements */
    memcpy(m, buf, n); m[pay + 2] = 7; recrc(m, n); expect_reject(m, n, GS_REJECT_LAYOUT);
    /* a step of 0, NaN, inf (f64 at pay + 4) */
    memcpy(m, buf, n); memset(m + pay + 4, 0, 8); recrc(m, n); expect_reject(m, n, GS_REJECT_LAYOUT);
    memcpy(m, buf, n); memset(m + pay + 4, 0xff, 8); recrc(m, n); expect_reject(m, n, GS_REJECT_LAYOUT);
    /* a width of 33 */
    memcpy(m, buf, n); m[pay + 12] = 33; recrc(m, n); expect_reject(m, n, GS_REJECT_LAYOUT);
    /* the length is implied: a byte more after the payload, or one less */
    memcpy(m, buf, n - 4); m[n - 4] = 0; recrc(m, n + 1); expect_reject(m, n + 1, GS_REJECT_LAYOUT);
    memcpy(m, buf, n); recrc(m, n - 1); expect_reject(m, n - 1, GS_REJECT_LAYOUT);
    /* the kind byte's reserved bits, encoding 0, a delta in f64 */
    memcpy(m, buf, n); m[GS_WIRE_HEADER] |= 0x40; recrc(m, n); expect_reject(m, n, GS_REJECT_LAYOUT);
    memcpy(m, buf, n); m[GS_WIRE_HEADER] &= 0xe7; recrc(m, n); expect_reject(m, n, GS_REJECT_LAYOUT);
    memcpy(m, buf, n); m[GS_WIRE_HEADER] = (unsigned char)((m[GS_WIRE_HEADER] & 0xe4) | 0x09);
    recrc(m, n); expect_reject(m, n, GS_REJECT_LAYOUT);
    /* any byte of the payload changed: refused, or values that are all
       finite (the decoder's bounds make them so) */
    for (k = 0; k < 4000; ++k) {
        size_t at = pay + (size_t)(rnd() * (double)(n - 4 - pay));
        gs_reject why;
        memcpy(m, buf, n);
        m[at] = (unsigned char)(rnd() * 256.0);
        recrc(m, n);
        if (gs_wire_decode(m, n, view, &why) == GS_OK) {
            int i;
            for (i = 0; i < view->chunks[0].elements; ++i)
                assert_true(isfinite(gs_wire_value(&view->chunks[0], i)));
        } else {
            rejected++;
        }
    }
    print_message("one payload byte changed: %d of 4000 refused\n", rejected);
    {
        /* a quaternion whose three smaller components are all 1/sqrt(2):
           their squares add up to 3/2, no rotation; refused */
        double q[4] = {0, 0, 0, 1};
        n = quant_roundtrip(q, 4, 0, 1, 16, out, &d, buf);
        memcpy(m, buf, n);
        memset(m + pay + 5, 0xff, 7); /* index, sign, 3 x 16 bits: all ones */
        recrc(m, n);
        expect_reject(m, n, GS_REJECT_LAYOUT);
    }
    free(view);
}

/* Encoder arguments: the segments must describe the values. */
static void test_quant_encode_args(void **state) {
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    gs_wire_header h = header_v2();
    gs_wire_chunk c;
    double v[4] = {0, 0, 0, 0}, nan_v[4] = {0, NAN, 0, 1};
    size_t size;
    (void)state;
    memset(&c, 0, sizeof c);
    c.count = 1;
    c.elements = 4;
    c.encoding = GS_ENCODING_QUANT;
    c.segment_count = 1;
    c.segments[0].kind = GS_WIRE_QUATERNION;
    c.segments[0].count = 4;
    c.segments[0].bits = 16;
    assert_int_equal(gs_wire_begin(buf, sizeof buf, &h, &size), GS_OK);
    assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c, v), GS_ERR_INVALID_ARG); /* zero q */
    assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c, nan_v), GS_ERR_NOT_FINITE);
    c.segments[0].bits = 25;
    v[3] = 1.0;
    assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c, v), GS_ERR_INVALID_ARG);
    c.segments[0].kind = GS_WIRE_SCALAR;
    c.segments[0].step = 0.0;
    assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c, v), GS_ERR_INVALID_ARG);
    c.segments[0].step = 1e-3;
    c.segments[0].count = 3; /* 3 of 4 elements */
    assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c, v), GS_ERR_INVALID_ARG);
    c.segments[0].count = 4;
    assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c, v), GS_OK);
    /* a heartbeat carries nothing and is index 0 */
    c.flags = GS_WIRE_CHUNK_REST;
    assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c, v), GS_ERR_INVALID_ARG);
    c.elements = 0;
    assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c, NULL), GS_OK);
    /* the first chunk's header (kind, id and sequence varints, its time, its
       element count), segment count, kind, count, step, width, base, then 4
       values of 10 bits (0 and 1000 steps of 1 mm); the heartbeat's header:
       kind, id and sequence (its time is the chunk's before) */
    assert_int_equal(size, GS_WIRE_HEADER + 12 + 1 + 1 + 2 + 8 + 1 + 1 + 5 + 3);
}

/* ---- between nets ---- */

#define KEEP 512
typedef struct box {
    double x[8];
    int n;
} box;
static void box_get(const void *user, double *out) {
    const box *b = (const box *)user;
    memcpy(out, b->x, (size_t)b->n * sizeof(double));
}
static gs_result box_set(void *user, const double *in) {
    box *b = (box *)user;
    memcpy(b->x, in, (size_t)b->n * sizeof(double));
    return GS_OK;
}
static gs_result box_step(void *user, double t, double dt) {
    (void)user; (void)t; (void)dt;
    return GS_OK;
}

typedef struct host {
    gs_world *w;
    gs_net *net;
    gs_agent *a;
    box b;
    unsigned char keep[KEEP][GS_WIRE_MAX_DATAGRAM];
    size_t keep_size[KEEP];
    int kept;
    size_t bytes;
} host;

static gs_result keep_send(void *user, uint32_t to, const void *data, size_t size) {
    host *h = (host *)user;
    (void)to;
    if (h->kept < KEEP) {
        memcpy(h->keep[h->kept], data, size);
        h->keep_size[h->kept++] = size;
    }
    h->bytes += size;
    return GS_OK;
}

/* Host id with a box of n values under object 5 (owned by host 1), encoding
   e, rest threshold rest; its peer is the other of 1 and 2. */
static host *host_new(uint32_t id, int n, gs_encoding e, double rest) {
    host *h = (host *)calloc(1, sizeof *h);
    gs_world_desc wd = gs_world_desc_default();
    gs_custom_desc cd;
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_net_desc nd;
    int i;
    assert_non_null(h);
    wd.host_id = id;
    assert_int_equal(gs_world_create(&wd, &h->w), GS_OK);
    h->b.n = n;
    for (i = 0; i < n; ++i) h->b.x[i] = 0.1 * (i + 1) + 0.01 * id;
    memset(&cd, 0, sizeof cd);
    cd.dt = 0.01;
    cd.state_size = (size_t)n;
    cd.step = box_step;
    cd.get_state = box_get;
    cd.set_state = box_set;
    cd.user = &h->b;
    assert_int_equal(gs_custom_create(h->w, &cd, &h->a), GS_OK);
    gd.object_id = 5;
    gd.owner = 1;
    gd.weight = gs_weight_owner;
    gd.encoding = e;
    gd.rest_threshold = rest;
    gd.time_deadband = -1.0; /* the formula as is: the test reads states */
    assert_int_equal(gs_ghost_attach(h->a, &gd), GS_OK);
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

/* Everything a has sent, handed to b at time now; returns how many. */
static int hand_over(host *a, host *b, double now) {
    int i, n = a->kept;
    for (i = 0; i < a->kept; ++i)
        assert_int_equal(gs_net_deliver(b->net, a->keep[i], a->keep_size[i], now, NULL), GS_OK);
    a->kept = 0;
    return n;
}

/* One frame of 1/60 s at wall time now on both hosts, 1 -> 2. */
static void frame(host *s, host *r, double now) {
    assert_int_equal(gs_world_advance(s->w, 1.0 / 60.0, NULL), GS_OK);
    assert_int_equal(gs_net_update(s->net, now), GS_OK);
    hand_over(s, r, now);
    assert_int_equal(gs_world_advance(r->w, 1.0 / 60.0, NULL), GS_OK);
}

/* The owner's state, quantized at 0.05 mm (a custom state is all
   positions), arrives bit for bit: under owner authority the receiver
   takes it whole. */
static void test_net_quant_bit_exact(void **state) {
    host *s = host_new(1, 6, GS_ENCODING_QUANT, 0.0), *r = host_new(2, 6, GS_ENCODING_QUANT, 0.0);
    double now = 0.0;
    int f, i;
    (void)state;
    s->b.x[0] = -3.14159265358979; s->b.x[5] = 1234.56789012345;
    for (f = 0; f < 10; ++f) frame(s, r, now += 1.0 / 60.0);
    for (i = 0; i < 6; ++i) {
        double want = (double)llround(s->b.x[i] / 5e-5) * 5e-5;
        if (memcmp(&want, &r->b.x[i], sizeof want) != 0)
            fail_msg("value %d: %.17g, the quantized state is %.17g", i, r->b.x[i], want);
    }
    host_free(s);
    host_free(r);
}

/* At rest: a snapshot, the same again with the first two heartbeats,
   then heartbeats at 4 Hz only; the receiver counts the object at rest
   while heartbeats come, and hears nothing once the sender is silent. A
   move past the threshold sends the state at once. */
static void test_net_send_on_change(void **state) {
    host *s = host_new(1, 3, GS_ENCODING_QUANT, 1e-4), *r = host_new(2, 3, GS_ENCODING_QUANT, 1e-4);
    gs_peer_stats ps, pr;
    double now = 0.0;
    int f;
    (void)state;
    for (f = 0; f < 120; ++f) frame(s, r, now += 1.0 / 60.0); /* 2 s */
    assert_int_equal(gs_net_peer_stats(s->net, 2, &ps), GS_OK);
    assert_int_equal(gs_net_peer_stats(r->net, 1, &pr), GS_OK);
    print_message("2 s at rest: %llu snapshots, %llu heartbeats, %llu bytes\n",
                  (unsigned long long)ps.snapshots_sent, (unsigned long long)ps.heartbeats_sent,
                  (unsigned long long)ps.bytes_sent);
    assert_int_equal(ps.snapshots_sent, 3);   /* the first, then two repeats */
    /* 4 Hz over 2 s, less the two that carried the state (one either way
       for where the 0.25 s periods fall on the 1/60 s frames) */
    assert_in_range(ps.heartbeats_sent, 5, 7);
    assert_int_equal(pr.heartbeats_received, ps.heartbeats_sent);
    assert_int_equal(pr.objects_resting, 1);
    assert_true(now - pr.last_heard < 0.26); /* at rest, not silent */
    /* f64 every frame would have been 120 datagrams */
    assert_true(ps.datagrams_sent < 12);
    /* the receiver drifts off on its own: the next heartbeat pulls it
       back to the sender's (quantized) state, which still stands */
    r->b.x[2] += 0.5;
    for (f = 0; f < 20; ++f) frame(s, r, now += 1.0 / 60.0); /* > one 0.25 s period */
    assert_true(fabs(r->b.x[2] - s->b.x[2]) <= 2.5e-5 + 1e-15);
    /* a move under the threshold: still at rest */
    s->b.x[1] += 5e-5;
    for (f = 0; f < 10; ++f) frame(s, r, now += 1.0 / 60.0);
    assert_int_equal(gs_net_peer_stats(s->net, 2, &ps), GS_OK);
    assert_int_equal(ps.snapshots_sent, 3);
    /* past it: sent at the next publish, and the receiver no longer counts it at rest */
    s->b.x[1] += 1e-3;
    /* the box steps at 10 ms and publishes every second step (at most
       60 Hz): within two frames */
    frame(s, r, now += 1.0 / 60.0);
    frame(s, r, now += 1.0 / 60.0);
    assert_int_equal(gs_net_peer_stats(s->net, 2, &ps), GS_OK);
    assert_int_equal(gs_net_peer_stats(r->net, 1, &pr), GS_OK);
    assert_int_equal(ps.snapshots_sent, 4);
    assert_int_equal(pr.objects_resting, 0);
    assert_true(fabs(r->b.x[1] - s->b.x[1]) <= 2.5e-5 + 1e-15); /* half the 0.05 mm step */
    /* silent: nothing comes for 2 s; last_heard tells it */
    for (f = 0; f < 120; ++f) {
        assert_int_equal(gs_world_advance(r->w, 1.0 / 60.0, NULL), GS_OK);
        now += 1.0 / 60.0;
    }
    assert_int_equal(gs_net_peer_stats(r->net, 1, &pr), GS_OK);
    assert_true(now - pr.last_heard > 1.9);
    host_free(s);
    host_free(r);
}

/* ---- priority within a budget ---- */

#define NPRIO 10
typedef struct counter {
    uint64_t chunks[NPRIO];
    size_t bytes;
    gs_wire_view v;
} counter;
static gs_result count_send(void *user, uint32_t to, const void *data, size_t size) {
    counter *c = (counter *)user;
    gs_reject why;
    int i;
    (void)to;
    c->bytes += size;
    assert_int_equal(gs_wire_decode((const unsigned char *)data, size, &c->v, &why), GS_OK);
    for (i = 0; i < c->v.chunk_count; ++i) c->chunks[c->v.chunks[i].object_id - 1]++;
    return GS_OK;
}
static gs_result moving_step(void *user, double t, double dt) {
    box *b = (box *)user;
    (void)t;
    b->x[0] += dt; /* always moving: always due */
    return GS_OK;
}

/* Ten ghosts of 8 values (one chunk, 96 bytes) due at 60 Hz: 57.6 kB/s
   wanted, a budget of 12 kB/s. Over 10 s every ghost gets its share (none
   starves), the one of importance 4 about four times the others', and the
   bytes keep to the budget. */
/* The budget tests' run: a net to peer 2 at 12 kB/s through send, then
   10 s of 60 Hz frames. Returns the net (the caller destroys it). */
static gs_net *budget_run(gs_world *w, gs_result (*send)(void *, uint32_t, const void *, size_t),
                          void *user) {
    gs_net_desc nd;
    gs_net *net = NULL;
    double now = 0.0;
    int f;
    memset(&nd, 0, sizeof nd);
    nd.transport.send = send;
    nd.transport.user = user;
    nd.bandwidth = 12000.0;
    assert_int_equal(gs_net_create(w, &nd, &net), GS_OK);
    assert_int_equal(gs_net_add_peer(net, 2, NULL), GS_OK);
    for (f = 0; f < 600; ++f) {
        assert_int_equal(gs_world_advance(w, 1.0 / 60.0, NULL), GS_OK);
        assert_int_equal(gs_net_update(net, now += 1.0 / 60.0), GS_OK);
    }
    return net;
}

static void test_budget_priority(void **state) {
    gs_world_desc wd = gs_world_desc_default();
    gs_world *w = NULL;
    gs_net *net = NULL;
    box b[NPRIO];
    counter *cnt = (counter *)calloc(1, sizeof *cnt);
    double lo = 1e30, hi = 0.0;
    int i;
    (void)state;
    assert_non_null(cnt);
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    for (i = 0; i < NPRIO; ++i) {
        gs_custom_desc cd;
        gs_ghost_desc gd = gs_ghost_desc_default();
        gs_agent *a = NULL;
        memset(&cd, 0, sizeof cd);
        memset(&b[i], 0, sizeof b[i]);
        b[i].n = 8;
        cd.dt = 0.01;
        cd.state_size = 8;
        cd.step = moving_step;
        cd.get_state = box_get;
        cd.set_state = box_set;
        cd.user = &b[i];
        assert_int_equal(gs_custom_create(w, &cd, &a), GS_OK);
        gd.object_id = (uint32_t)i + 1;
        gd.importance = i == NPRIO - 1 ? 4.0 : 0.0; /* 0: the default, 1 */
        assert_int_equal(gs_ghost_attach(a, &gd), GS_OK);
    }
    net = budget_run(w, count_send, cnt);
    for (i = 0; i < NPRIO - 1; ++i) {
        lo = fmin(lo, (double)cnt->chunks[i]);
        hi = fmax(hi, (double)cnt->chunks[i]);
    }
    print_message("10 s at 12 kB/s: %zu bytes; importance 1: %.0f..%.0f snapshots, "
                  "importance 4: %llu\n", cnt->bytes, lo, hi,
                  (unsigned long long)cnt->chunks[NPRIO - 1]);
    /* the budget: 12 kB/s for 10 s plus its 50 ms burst (its floor is one
       full datagram) */
    assert_true(cnt->bytes <= 12000.0 * 10.0 + 1200.0);
    /* none starves, and equal importance shares evenly: priority grows
       with the wait, so the counts differ by a send or two */
    assert_true(lo >= 50.0);
    assert_true(hi - lo <= 3.0);
    /* four times the importance: a quarter of the wait, within a frame's
       rounding of the waits (1/60 s on waits of about 0.1 s) */
    assert_true((double)cnt->chunks[NPRIO - 1] >= 2.5 * lo);
    assert_true((double)cnt->chunks[NPRIO - 1] <= 5.0 * hi);
    gs_net_destroy(net);
    gs_world_destroy(w);
    free(cnt);
}

/* A ghost whose snapshot is larger than 50 ms of the budget (600 values,
   4.8 kB in f64, against a 12 kB/s budget whose 50 ms is 600 bytes)
   beside three small ones due every frame: it goes (once its bucket holds
   it, the small ones wait too, else they would drain it every frame and
   it would never go), none of them starves, and the bytes keep to the
   budget plus one such snapshot. */
#define BIG 600
typedef struct big_box {
    double x[BIG];
} big_box;
static void big_get(const void *user, double *out) {
    memcpy(out, ((const big_box *)user)->x, sizeof ((const big_box *)user)->x);
}
static gs_result big_set(void *user, const double *in) {
    memcpy(((big_box *)user)->x, in, sizeof ((big_box *)user)->x);
    return GS_OK;
}
static gs_result big_step(void *user, double t, double dt) {
    (void)t;
    ((big_box *)user)->x[0] += dt; /* always moving: always due */
    return GS_OK;
}
typedef struct first_counter {
    uint64_t snapshots[4]; /* chunks 0, by object id - 1 */
    size_t bytes;
    gs_wire_view v;
} first_counter;
static gs_result count_first(void *user, uint32_t to, const void *data, size_t size) {
    first_counter *c = (first_counter *)user;
    gs_reject why;
    int i;
    (void)to;
    c->bytes += size;
    assert_int_equal(gs_wire_decode((const unsigned char *)data, size, &c->v, &why), GS_OK);
    for (i = 0; i < c->v.chunk_count; ++i)
        if (c->v.chunks[i].index == 0) c->snapshots[c->v.chunks[i].object_id - 1]++;
    return GS_OK;
}
static void test_budget_large_ghost(void **state) {
    gs_world_desc wd = gs_world_desc_default();
    gs_world *w = NULL;
    gs_net *net = NULL;
    big_box *big = (big_box *)calloc(1, sizeof *big);
    box b[3];
    first_counter *cnt = (first_counter *)calloc(1, sizeof *cnt);
    int i;
    (void)state;
    assert_non_null(big);
    assert_non_null(cnt);
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    for (i = 0; i < 4; ++i) {
        gs_custom_desc cd;
        gs_ghost_desc gd = gs_ghost_desc_default();
        gs_agent *a = NULL;
        memset(&cd, 0, sizeof cd);
        cd.dt = 0.01;
        if (i == 0) {
            cd.state_size = BIG;
            cd.step = big_step;
            cd.get_state = big_get;
            cd.set_state = big_set;
            cd.user = big;
        } else {
            memset(&b[i - 1], 0, sizeof b[i - 1]);
            b[i - 1].n = 8;
            cd.state_size = 8;
            cd.step = moving_step;
            cd.get_state = box_get;
            cd.set_state = box_set;
            cd.user = &b[i - 1];
        }
        assert_int_equal(gs_custom_create(w, &cd, &a), GS_OK);
        gd.object_id = (uint32_t)i + 1;
        assert_int_equal(gs_ghost_attach(a, &gd), GS_OK);
    }
    net = budget_run(w, count_first, cnt);
    print_message("10 s at 12 kB/s: %zu bytes; the 4.8 kB ghost %llu snapshots, the small "
                  "ones %llu, %llu, %llu\n", cnt->bytes, (unsigned long long)cnt->snapshots[0],
                  (unsigned long long)cnt->snapshots[1], (unsigned long long)cnt->snapshots[2],
                  (unsigned long long)cnt->snapshots[3]);
    /* about 12 kB/s over 4.9 kB and the small ones' share: two a second */
    assert_true(cnt->snapshots[0] >= 10);
    for (i = 1; i < 4; ++i) assert_true(cnt->snapshots[i] >= 10);
    /* the budget, plus the bucket's burst: one large snapshot (5 datagrams
       of at most 1200 bytes) */
    assert_true(cnt->bytes <= 12000.0 * 10.0 + 5.0 * 1200.0);
    gs_net_destroy(net);
    gs_world_destroy(w);
    free(cnt);
    free(big);
}

/* Send on change under loss and a restart. The first snapshot is lost:
   the two repeats that go with the first heartbeats bring the state. Then
   the receiver starts again (a new run): the sender sees the new run in
   its next datagram and sends the state whole, although it has not moved. */
static void test_rest_loss_and_restart(void **state) {
    host *s = host_new(1, 3, GS_ENCODING_QUANT, 1e-4), *r = host_new(2, 3, GS_ENCODING_QUANT, 1e-4);
    gs_peer_stats ps, pr;
    double now = 0.0;
    int f, i;
    (void)state;
    /* frame one: its datagrams are dropped */
    assert_int_equal(gs_world_advance(s->w, 1.0 / 60.0, NULL), GS_OK);
    assert_int_equal(gs_net_update(s->net, now += 1.0 / 60.0), GS_OK);
    assert_true(s->kept > 0);
    s->kept = 0;
    for (f = 0; f < 60; ++f) frame(s, r, now += 1.0 / 60.0);
    for (i = 0; i < 3; ++i) /* half the 0.05 mm step */
        assert_true(fabs(r->b.x[i] - s->b.x[i]) <= 2.5e-5 + 1e-15);
    /* the receiver is heard (its run known), then starts again and says so
       in a datagram of its own (made while the old one lives, so that the
       two nets, whose address goes into the run number, differ) */
    assert_int_equal(gs_net_update(r->net, now), GS_OK);
    hand_over(r, s, now);
    for (f = 0; f < 60; ++f) frame(s, r, now += 1.0 / 60.0); /* at rest again */
    {
        host *r2 = host_new(2, 3, GS_ENCODING_QUANT, 1e-4);
        host_free(r);
        r = r2;
    }
    assert_int_equal(gs_world_advance(r->w, 1.0 / 60.0, NULL), GS_OK);
    assert_int_equal(gs_net_update(r->net, now), GS_OK);
    hand_over(r, s, now);
    assert_int_equal(gs_net_peer_stats(s->net, 2, &ps), GS_OK);
    for (f = 0; f < 3; ++f) frame(s, r, now += 1.0 / 60.0);
    assert_int_equal(gs_net_peer_stats(s->net, 2, &pr), GS_OK);
    assert_true(pr.snapshots_sent > ps.snapshots_sent); /* whole, not a heartbeat */
    for (i = 0; i < 3; ++i) assert_true(fabs(r->b.x[i] - s->b.x[i]) <= 2.5e-5 + 1e-15);
    host_free(s);
    host_free(r);
}

/* The descs: resolutions and heartbeat rate checked at attach. */
static void test_ghost_desc_quant(void **state) {
    gs_world *w = NULL;
    gs_world_desc wd = gs_world_desc_default();
    gs_agent *a = NULL;
    gs_rigid_desc rd = gs_rigid_desc_default();
    gs_ghost_desc gd = gs_ghost_desc_default();
    (void)state;
    assert_true(gd.position_resolution == 5e-5);
    assert_true(gd.velocity_resolution == 3e-3);
    assert_int_equal(gd.orientation_bits, 16);
    assert_true(gd.heartbeat_rate == 4.0);
    assert_true(gd.rest_threshold == 0.0);
    rd.shape.type = GS_SHAPE_SPHERE;
    rd.shape.radius = 0.1;
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    assert_int_equal(gs_rigid_create(w, &rd, &a), GS_OK);
    gd.object_id = 1;
    gd.encoding = GS_ENCODING_QUANT;
    gd.position_resolution = -1.0;
    assert_int_equal(gs_ghost_attach(a, &gd), GS_ERR_INVALID_ARG);
    gd.position_resolution = 0.0;
    gd.orientation_bits = 30;
    assert_int_equal(gs_ghost_attach(a, &gd), GS_ERR_INVALID_ARG);
    gd.orientation_bits = 0;
    gd.rest_threshold = -1.0;
    assert_int_equal(gs_ghost_attach(a, &gd), GS_ERR_INVALID_ARG);
    gd.rest_threshold = 0.0;
    gd.importance = -1.0;
    assert_int_equal(gs_ghost_attach(a, &gd), GS_ERR_INVALID_ARG);
    gd.importance = 0.0;
    assert_int_equal(gs_ghost_attach(a, &gd), GS_OK);
    gs_world_destroy(w);
}

int main(int argc, char **argv) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_quant_scalar_edges),
        cmocka_unit_test(test_quant_default_steps),
        cmocka_unit_test(test_quant_quaternion_edges),
        cmocka_unit_test(test_quant_idempotent),
        cmocka_unit_test(test_quant_rejects),
        cmocka_unit_test(test_quant_encode_args),
        cmocka_unit_test(test_net_quant_bit_exact),
        cmocka_unit_test(test_net_send_on_change),
        cmocka_unit_test(test_rest_loss_and_restart),
        cmocka_unit_test(test_budget_priority),
        cmocka_unit_test(test_budget_large_ghost),
        cmocka_unit_test(test_ghost_desc_quant),
    };
    if (argc > 1) cmocka_set_test_filter(argv[1]);
    return cmocka_run_group_tests(tests, NULL, NULL);
}
