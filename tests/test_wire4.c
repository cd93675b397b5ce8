/* test_wire4.c - predicted delta chunks (>>wire's GS_WIRE_CHUNK_PREDICT):
   differences from the baseline carried along its own velocities.

   What must hold: a receiver decodes a predicted chunk to the sender's
   quantized state bit for bit whatever the network does (loss, duplicates,
   reordering), because both sides compute the prediction from the same
   integers and times; a body drifting at a steady velocity costs next to
   nothing; a predicted chunk whose baseline lacks the velocities it needs
   (held in another chunk), or that claims a prediction where there is
   nothing to carry, is refused (GS_REJECT_BASELINE) and the chain takes up
   again. The checks read both sides' private state (the sender's ring of
   states sent, the receiver's queue), so this file compiles the
   implementation itself (GHOSTSIM_STATIC), as test_delta.c does; the
   scene here is its own: free-flying spheres (no gravity, no contacts, so
   their velocities hold) and a small cloth whose positions and velocities
   fall in different chunks. No tolerance: the comparison is memcmp. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define GHOSTSIM_STATIC
#define GHOSTSIM_IMPLEMENTATION /* the test reads the ghosts' baseline rings */
#include "ghostsim.h"
#include "wire_helpers.h"

#define FRAME (1.0 / 60.0)
#define MAXQ 256
#define NBALLS 4
#define CLOTH_ID 50u
#define BALL_ID 60u

typedef struct msg {
    int to; /* host index */
    size_t size;
    unsigned char d[GS_WIRE_MAX_DATAGRAM];
} msg;

typedef struct link2 {
    gs_world *w[2];
    gs_net *net[2];
    gs_agent *cloth[2], *ball[2][NBALLS];
    msg q[MAXQ];
    int nq;
    double now, loss, dup, reorder;
    uint64_t rng;
    int forge; /* 1: mark each plain Rice delta of the cloth's velocities predicted */
    long matched, mismatched, predicted, ball_predicted, ball_residual, forged;
} link2;

static gs_vec3 v3(double x, double y, double z) {
    gs_vec3 v;
    v.x = x; v.y = y; v.z = z;
    return v;
}

static double rnd(link2 *l) {
    l->rng = l->rng * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(l->rng >> 11) / 9007199254740992.0;
}

static gs_result keep_msg(void *user, uint32_t host, const void *data, size_t size) {
    link2 *l = (link2 *)user;
    if (l->nq < MAXQ) {
        l->q[l->nq].to = (int)host - 1;
        l->q[l->nq].size = size;
        memcpy(l->q[l->nq].d, data, size);
        l->nq++;
    }
    return GS_OK;
}

static void host_make(link2 *l, int i) {
    gs_world_desc wd = gs_world_desc_default();
    gs_cloth_desc cd = gs_cloth_desc_default();
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_net_desc nd;
    int b;
    wd.host_id = (uint32_t)i + 1;
    assert_int_equal(gs_world_create(&wd, &l->w[i]), GS_OK);
    gs_world_set_gravity(l->w[i], v3(0.0, 0.0, 0.0)); /* the spheres' drifts hold */
    gd.encoding = GS_ENCODING_QUANT;
    gd.delta = 1;
    gd.queue_size = 64; /* the receiver never blends here: keep them */
    cd.nx = cd.ny = 8; /* 384 values: positions in chunk 0, velocities in 1 */
    assert_int_equal(gs_cloth_create(l->w[i], &cd, &l->cloth[i]), GS_OK);
    { /* the cloth set moving, a wave of velocities its springs then swing */
        double st[1 + 6 * 64];
        int j;
        assert_int_equal(gs_agent_state_size(l->cloth[i]), 1 + 6 * 64);
        gs_agent_get_state(l->cloth[i], st, 1 + 6 * 64);
        for (j = 0; j < 3 * 64; ++j) st[1 + 3 * 64 + j] = 0.3 * sin(0.7 * j);
        assert_int_equal(gs_agent_set_state(l->cloth[i], st, 1 + 6 * 64), GS_OK);
    }
    gd.object_id = CLOTH_ID;
    assert_int_equal(gs_ghost_attach(l->cloth[i], &gd), GS_OK);
    for (b = 0; b < NBALLS; ++b) {
        gs_rigid_desc rd = gs_rigid_desc_default();
        rd.shape.type = GS_SHAPE_SPHERE;
        rd.shape.radius = 0.05;
        rd.position = v3(5.0 + 2.0 * b, 3.0, -1.0);
        /* steady drifts, one fast (1.7 m/s: 566 steps a frame) */
        rd.velocity = v3(0.2 * b - 0.3, 0.05, b == 3 ? 1.7 : 0.0);
        rd.angular_velocity = v3(0.0, b == 1 ? 2.0 : 0.0, 0.0);
        assert_int_equal(gs_rigid_create(l->w[i], &rd, &l->ball[i][b]), GS_OK);
        gd.object_id = BALL_ID + (uint32_t)b;
        assert_int_equal(gs_ghost_attach(l->ball[i][b], &gd), GS_OK);
    }
    memset(&nd, 0, sizeof nd);
    nd.transport.send = keep_msg;
    nd.transport.user = l;
    nd.bandwidth = 1e9;
    assert_int_equal(gs_net_create(l->w[i], &nd, &l->net[i]), GS_OK);
    assert_int_equal(gs_net_add_peer(l->net[i], (uint32_t)(2 - i), NULL), GS_OK);
}

static link2 *link_make(uint64_t seed) {
    link2 *l = (link2 *)calloc(1, sizeof *l);
    assert_non_null(l);
    l->rng = seed;
    host_make(l, 0);
    host_make(l, 1);
    return l;
}

static void link_free(link2 *l) {
    int i;
    for (i = 0; i < 2; ++i) {
        gs_net_destroy(l->net[i]);
        gs_world_destroy(l->w[i]);
    }
    free(l);
}

/* forge: the width byte of each plain Rice delta chunk of the cloth's
   velocity chunk (index 1) gets the predicted bit: a chunk that claims a
   prediction where no position is carried. */
static void forge_predicted(link2 *l, msg *m) {
    static gs_wire_view v;
    int i, hit = 0;
    if (gs_wire_decode(m->d, m->size, &v, NULL) != GS_OK) return;
    for (i = 0; i < v.chunk_count; ++i) {
        const gs_wire_chunk *c = &v.chunks[i];
        unsigned char *wb;
        if (!(c->flags & GS_WIRE_CHUNK_DELTA) || (c->flags & GS_WIRE_CHUNK_PREDICT) ||
            c->object_id != CLOTH_ID || c->index != 1 || c->delta_coding != 2)
            continue;
        /* payload: the baseline distance varint (none when the chunk
           before's, see >>wire), then the width byte */
        wb = m->d + (size_t)(c->payload - m->d) + c->delta_skip;
        *wb |= 0x20;
        hit = 1;
    }
    if (hit) {
        recrc(m->d, m->size);
        l->forged++;
    }
}

/* What host `to` queued of each value chunk of a datagram, against the
   sender's record of that snapshot (its ring: the integers sent). */
static void check(link2 *l, int from, int to, const unsigned char *d, size_t size) {
    static gs_wire_view v;
    double want[GS_WIRE_QUANT_CHUNK];
    int i, k, p = gs__peer_slot(l->net[to], (uint32_t)from + 1);
    if (gs_wire_decode(d, size, &v, NULL) != GS_OK) return;
    for (i = 0; i < v.chunk_count; ++i) {
        const gs_wire_chunk *c = &v.chunks[i];
        gs__ghost *gs = gs__ghost_find(l->w[from], c->object_id);
        gs__ghost *gr = gs__ghost_find(l->w[to], c->object_id);
        gs__base *e;
        if (!gs || !gr || (c->flags & (GS_WIRE_CHUNK_ACK | GS_WIRE_CHUNK_REST))) continue;
        if (c->flags & GS_WIRE_CHUNK_PREDICT) {
            l->predicted++;
            if (c->object_id >= BALL_ID) {
                int64_t r[GS_WIRE_QUANT_CHUNK];
                int j;
                l->ball_predicted++;
                gs_wire_deltas(c, r);
                for (j = 0; j < 3; ++j) l->ball_residual += r[j] < 0 ? -r[j] : r[j];
            }
        }
        e = gs__ring_find(gs->ring, c->sequence);
        if (!e || !e->got[c->index]) continue;
        gs__qk_values(e->seg + (size_t)c->index * GS_WIRE_MAX_SEGMENTS, e->nseg[c->index],
                      e->k + c->first, want);
        for (k = 0; k < gr->d.queue_size; ++k) {
            gs__snap *s = &gr->gp[p].q[k];
            if (!s->used || s->seq != c->sequence || !s->got[c->index]) continue;
            if (memcmp(s->data + c->first, want, c->elements * sizeof(double)) == 0)
                l->matched++;
            else
                l->mismatched++;
        }
    }
}

/* Each held datagram lost, delivered (maybe twice), or held back a round. */
static void deliver(link2 *l) {
    static msg back[MAXQ];
    int i, nb = 0, n = l->nq;
    for (i = 0; i < n; ++i) {
        msg *m = &l->q[i];
        int times = 1;
        if (rnd(l) < l->loss) continue;
        if (rnd(l) < l->reorder && nb < MAXQ) { back[nb++] = *m; continue; }
        if (rnd(l) < l->dup) times = 2;
        if (l->forge && m->to == 1) forge_predicted(l, m);
        while (times--) {
            gs_net_deliver(l->net[m->to], m->d, m->size, l->now, NULL);
            check(l, 1 - m->to, m->to, m->d, m->size);
        }
    }
    memcpy(l->q, back, (size_t)nb * sizeof back[0]);
    l->nq = nb;
}

/* Host 1 steps and sends; host 2 only acknowledges (its queues keep). */
static void frame(link2 *l) {
    l->now += FRAME;
    gs_world_advance(l->w[0], FRAME, NULL);
    gs_net_update(l->net[0], l->now);
    gs_net_update(l->net[1], l->now);
    deliver(l);
}

static uint64_t refused(link2 *l) {
    gs_peer_stats st;
    if (gs_net_peer_stats(l->net[1], 1, &st) != GS_OK) return 0;
    return st.rejected[GS_REJECT_BASELINE];
}

/* A clean link: the spheres' chunks go predicted, and their positions
   differ from the prediction by at most a step or two a coordinate (the
   rounding of the state and of the carried velocity: a drift of 566 steps
   a frame costs what a resting body costs); the cloth's position chunk
   goes predicted too; every value is the sender's. */
static void test_wire4_drift(void **state) {
    link2 *l = link_make(3);
    int f;
    (void)state;
    for (f = 0; f < 90; ++f) frame(l);
    assert_int_equal(l->mismatched, 0);
    assert_true(l->matched > 400);
    assert_true(l->ball_predicted > 60 * NBALLS); /* after the first keys, all */
    /* 3 coordinates a chunk, each within +-2 steps (measured: 0 or 1) */
    assert_true(l->ball_residual <= 6 * l->ball_predicted);
    assert_true(l->predicted > l->ball_predicted + 30); /* the cloth's chunk 0 */
    assert_int_equal(refused(l), 0);
    link_free(l);
}

/* Loss, duplicates and reordering, three seeds: predicted or not, what the
   receiver queues is the sender's state bit for bit. */
static void test_wire4_lossy(void **state) {
    uint64_t seed;
    (void)state;
    for (seed = 1; seed <= 3; ++seed) {
        link2 *l = link_make(seed);
        int f;
        l->loss = 0.15;
        l->dup = 0.1;
        l->reorder = 0.2;
        for (f = 0; f < 150; ++f) frame(l);
        assert_int_equal(l->mismatched, 0);
        assert_true(l->matched > 300);
        assert_true(l->predicted > 150);
        link_free(l);
    }
}

/* The receiver lost the baseline's velocities (the cloth's chunk 1 of
   every snapshot it holds) but kept its positions: the next predicted
   position chunks are refused and counted, never decoded against another
   velocity; the refusal goes back, and the chain takes up again. */
static void test_wire4_velocity_lost(void **state) {
    link2 *l = link_make(5);
    gs__ghost *g;
    long matched;
    uint64_t r;
    int f, k, p;
    (void)state;
    for (f = 0; f < 30; ++f) frame(l);
    assert_int_equal(refused(l), 0);
    g = gs__ghost_find(l->w[1], CLOTH_ID);
    p = gs__peer_slot(l->net[1], 1);
    for (k = 0; k < GS_DELTA_RING; ++k) g->gp[p].ring[k].got[1] = 0;
    frame(l);
    assert_true(refused(l) > 0);
    matched = l->matched;
    for (f = 0; f < 30; ++f) frame(l);
    assert_int_equal(l->mismatched, 0);
    assert_true(l->matched > matched + 30);
    r = refused(l);
    for (f = 0; f < 30; ++f) frame(l);
    assert_true(refused(l) == r); /* and holds */
    link_free(l);
}

/* A chunk that claims a prediction with nothing to carry (the cloth's
   velocities) is refused, not read as a plain delta: one meaning. */
static void test_wire4_forged(void **state) {
    link2 *l = link_make(9);
    int f;
    (void)state;
    for (f = 0; f < 30; ++f) frame(l);
    l->forge = 1;
    for (f = 0; f < 30; ++f) frame(l);
    assert_true(l->forged > 0);
    assert_true(refused(l) >= (uint64_t)l->forged);
    assert_int_equal(l->mismatched, 0);
    link_free(l);
}

/* The wire: a predicted delta round trips (Rice, the flag back); the flag
   needs GS_WIRE_CHUNK_DELTA; a width byte's bit 5 reads as the flag only
   under Rice (packed, it is part of the width: 32). */
static void test_wire4_codec(void **state) {
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    static gs_wire_view v;
    gs_wire_header h;
    gs_wire_chunk c;
    int64_t d[120], out[120];
    size_t size;
    int i;
    (void)state;
    memset(&h, 0, sizeof h);
    h.session = 1;
    h.sender = 2;
    memset(&c, 0, sizeof c);
    c.object_id = 9;
    c.sequence = 40;
    c.baseline = 38;
    c.count = 1;
    c.elements = 120;
    c.encoding = GS_ENCODING_QUANT;
    c.flags = GS_WIRE_CHUNK_DELTA | GS_WIRE_CHUNK_PREDICT;
    /* sparse large values: plain, this would go as a bitmap */
    for (i = 0; i < 120; ++i) d[i] = i % 40 == 0 ? 100000 - i : 0;
    delta_round_trip(buf, &h, &c, d, &v);
    assert_int_equal(v.chunks[0].flags, GS_WIRE_CHUNK_DELTA | GS_WIRE_CHUNK_PREDICT);
    assert_int_equal(v.chunks[0].delta_coding, 2);
    assert_true(v.chunks[0].delta_width <= 24);
    gs_wire_deltas(&v.chunks[0], out);
    assert_memory_equal(out, d, sizeof d);
    /* the same plain: no flag */
    c.flags = GS_WIRE_CHUNK_DELTA;
    delta_round_trip(buf, &h, &c, d, &v);
    assert_int_equal(v.chunks[0].flags, GS_WIRE_CHUNK_DELTA);
    /* the flag alone, or with another kind: refused */
    assert_int_equal(gs_wire_begin(buf, sizeof buf, &h, &size), GS_OK);
    c.flags = GS_WIRE_CHUNK_PREDICT;
    assert_int_equal(gs_wire_add_delta(buf, sizeof buf, &size, &c, d), GS_ERR_INVALID_ARG);
    c.flags = GS_WIRE_CHUNK_PREDICT | GS_WIRE_CHUNK_DELTA | GS_WIRE_CHUNK_REST;
    assert_int_equal(gs_wire_add_delta(buf, sizeof buf, &size, &c, d), GS_ERR_INVALID_ARG);
    c.flags = GS_WIRE_CHUNK_PREDICT;
    assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c, (const double *)buf),
                     GS_ERR_INVALID_ARG);
    /* packed at width 32 (bit 5 set): a width, not the flag */
    for (i = 0; i < 120; ++i) d[i] = i & 1 ? 2147483647LL - i : -2147483647LL + i;
    c.flags = GS_WIRE_CHUNK_DELTA;
    delta_round_trip(buf, &h, &c, d, &v);
    assert_int_equal(v.chunks[0].delta_coding, 0);
    assert_int_equal(v.chunks[0].delta_width, 32);
    assert_int_equal(v.chunks[0].flags, GS_WIRE_CHUNK_DELTA);
    gs_wire_deltas(&v.chunks[0], out);
    assert_memory_equal(out, d, sizeof d);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_wire4_codec),
        cmocka_unit_test(test_wire4_drift),
        cmocka_unit_test(test_wire4_lossy),
        cmocka_unit_test(test_wire4_velocity_lost),
        cmocka_unit_test(test_wire4_forged),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
