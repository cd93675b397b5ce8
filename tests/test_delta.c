/* test_delta.c - delta coding against acknowledged baselines (>>wire's
   GS_WIRE_CHUNK_DELTA and GS_WIRE_CHUNK_ACK, gs_ghost_desc.delta).

   What must hold: whatever the network does (loss, duplicates, reordering,
   a baseline gone, a peer restarted mid-chain), every value a receiver
   queues for a blend is the sender's quantized state of that snapshot bit
   for bit, and a delta against a baseline the receiver does not hold is
   refused and counted (GS_REJECT_BASELINE), never decoded against
   something else. The check reads both sides' private state (the sender's
   ring of states sent, the receiver's queue), so this file compiles the
   implementation itself (GHOSTSIM_STATIC), as test_sched.c.

   The hosts talk through delta_pair.h's own transport: every datagram is
   held, then delivered (or lost, duplicated, held back) by a seeded
   generator, and each one delivered is checked at once against the
   sender's record. A last test runs the same chain on gs_simnet. No
   tolerance anywhere: the comparison is memcmp of doubles. */
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
#include "net_helpers.h"

#include "delta_pair.h"

/* Loss, duplicates and reordering at once, three seeds: the receiver's
   values are always the sender's; deltas flow, and keys where needed. */
static void test_delta_chain_lossy(void **state) {
    uint64_t seed;
    (void)state;
    for (seed = 1; seed <= 3; ++seed) {
        pair *pr = pair_lossy(seed, 240);
        assert_int_equal(pr->mismatched, 0);
        assert_true(pr->matched > 500);
        assert_true(pr->deltas > 300);
        assert_true(pr->keys > 0);
        /* the receiver sends nothing else, so it holds its acks until
           GS__ACK_HOLD snapshots wait (240 / 4 = 60 datagrams in 240
           frames); 15% are lost and the first frames have none: 30 */
        assert_true(pr->acks > 240 / GS__ACK_HOLD / 2);
        pair_free(pr);
        free(pr);
    }
}

/* A perfect link: after the first key every chunk goes as a delta. */
static void test_delta_clean_link(void **state) {
    pair *pr = (pair *)calloc(1, sizeof *pr);
    long keys;
    int f;
    (void)state;
    assert_non_null(pr);
    pair_make(pr, 7);
    for (f = 0; f < 30; ++f) frame(pr, 1);
    keys = pr->keys;
    for (f = 0; f < 60; ++f) frame(pr, 1);
    assert_int_equal(pr->mismatched, 0);
    assert_int_equal(pr->keys, keys); /* no key since */
    assert_true(pr->deltas > 60 * 5);
    assert_int_equal(refused(pr, 1), 0);
    pair_free(pr);
    free(pr);
}

/* A baseline lost by the receiver (its ring emptied): the next deltas are
   refused and counted, not decoded; the refusal goes back and the sender
   sends whole snapshots until a new baseline is acknowledged. */
static void test_delta_lost_baseline(void **state) {
    pair *pr = (pair *)calloc(1, sizeof *pr);
    gs_world *w;
    long matched;
    int f, i, k;
    (void)state;
    assert_non_null(pr);
    pair_make(pr, 11);
    for (f = 0; f < 30; ++f) frame(pr, 1);
    assert_int_equal(refused(pr, 1), 0);
    w = pr->w[1];
    for (i = 0; i < w->agent_count; ++i) {
        gs__ghost *g = gs__ghost_of(w->agents[i]);
        for (k = 0; g && k < GS_DELTA_RING; ++k) g->gp[0].ring[k].used = 0;
    }
    frame(pr, 1);
    assert_true(refused(pr, 1) > 0);
    matched = pr->matched;
    for (f = 0; f < 30; ++f) frame(pr, 1);
    assert_int_equal(pr->mismatched, 0);
    assert_true(pr->matched > matched + 30); /* the chain took up again */
    {
        uint64_t r = refused(pr, 1);
        for (f = 0; f < 30; ++f) frame(pr, 1);
        assert_true(refused(pr, 1) == r); /* and holds */
    }
    pair_free(pr);
    free(pr);
}

/* A baseline too old: the sender's datagrams all lost for longer than its
   ring (the acknowledgements stay at the last one held), then the link
   comes back: the sender has no baseline left, and sends keys. */
static void test_delta_old_baseline(void **state) {
    pair *pr = (pair *)calloc(1, sizeof *pr);
    long keys;
    int f;
    (void)state;
    assert_non_null(pr);
    pair_make(pr, 13);
    for (f = 0; f < 30; ++f) frame(pr, 1);
    pr->loss = 1.0;
    for (f = 0; f < GS_DELTA_RING + 10; ++f) frame(pr, 1);
    pr->loss = 0.0;
    keys = pr->keys;
    for (f = 0; f < 30; ++f) frame(pr, 1);
    assert_true(pr->keys > keys);
    assert_int_equal(pr->mismatched, 0);
    assert_int_equal(refused(pr, 1), 0);
    pair_free(pr);
    free(pr);
}

/* The receiver restarted mid-chain (a new net and world: a new run, no
   baselines): the deltas it gets before the sender hears of it are
   refused; then keys, then deltas again, all matching. Then the sender
   restarts: its sequences start again, and the receiver must not take a
   new delta against a baseline of the old run with the same sequence. */
static void test_delta_peer_restart(void **state) {
    pair *pr = (pair *)calloc(1, sizeof *pr);
    long matched, deltas;
    int f;
    (void)state;
    assert_non_null(pr);
    pair_make(pr, 17);
    pr->loss = 0.05;
    for (f = 0; f < 40; ++f) frame(pr, 1);
    host_drop(pr, 1);
    frame(pr, 1);
    host_make(pr, 1);
    matched = pr->matched;
    deltas = pr->deltas;
    for (f = 0; f < 60; ++f) frame(pr, 1);
    assert_int_equal(pr->mismatched, 0);
    assert_true(pr->matched > matched + 60);
    assert_true(pr->deltas > deltas + 60);
    host_drop(pr, 0);
    frame(pr, 1);
    host_make(pr, 0);
    matched = pr->matched;
    for (f = 0; f < 60; ++f) frame(pr, 1);
    assert_int_equal(pr->mismatched, 0);
    assert_true(pr->matched > matched + 60);
    pair_free(pr);
    free(pr);
}

/* The same chain on gs_simnet, lossy, duplicating, reordering links, every
   world stepping and blending, 2 or 3 hosts (with 3, a sender codes
   against the newest snapshot both peers acknowledged): what each host
   holds of another's snapshots (its baselines, every frame) is that
   sender's record. */
static void delta_simnet(int hosts) {
    gs_simnet *sim;
    gs_simnet_desc smd;
    gs_link_desc ld;
    gs_world *w[3];
    gs_net *net[3];
    gs_scene sc[3];
    long matched = 0, mismatched = 0, based = 0;
    int i, j, f, a, k, c;
    memset(&smd, 0, sizeof smd);
    smd.seed = 5;
    assert_int_equal(gs_simnet_create(&smd, &sim), GS_OK);
    for (i = 0; i < hosts; ++i) {
        gs_world_desc wd = gs_world_desc_default();
        gs_scene_desc sd = gs_scene_desc_default();
        gs_ghost_desc gd = delta_desc();
        gs_net_desc nd;
        wd.host_id = (uint32_t)i + 1;
        assert_int_equal(gs_world_create(&wd, &w[i]), GS_OK);
        sd.cloth_n = 10;
        sd.probe_count = hosts;
        assert_int_equal(gs_scene_create(w[i], &sd, &sc[i]), GS_OK);
        gd.queue_size = 8;
        assert_int_equal(gs_scene_attach_ghosts(&sc[i], &gd), GS_OK);
        memset(&nd, 0, sizeof nd);
        nd.bandwidth = 1e9;
        assert_int_equal(test_join(sim, w[i], &nd, &net[i]), GS_OK);
    }
    memset(&ld, 0, sizeof ld);
    ld.latency = 0.03;
    ld.jitter = 0.02;
    ld.loss = 0.1;
    ld.duplicate = 0.05;
    ld.reorder = 0.1;
    for (i = 0; i < hosts; ++i)
        for (j = i + 1; j < hosts; ++j)
            assert_int_equal(gs_simnet_link(sim, (uint32_t)i + 1, (uint32_t)j + 1, &ld), GS_OK);
    for (f = 0; f < 240; ++f) {
        for (i = 0; i < hosts; ++i) {
            gs_quat q = {0, 0, 0, 1};
            gs_probe_set_target(sc[i].probes[i], gs_scene_probe_path(i, f * FRAME), q);
        }
        assert_int_equal(gs_simnet_run(sim, FRAME, FRAME), GS_OK);
        /* the cloth of host 1 has a baseline every peer acknowledged */
        based += gs__delta_base(net[0], gs__ghost_find(w[0], 1)) != NULL;
        for (i = 0; i < hosts; ++i) /* host i's baselines of host j */
            for (j = 0; j < hosts; ++j)
            for (a = 0; a < w[i]->agent_count && j != i; ++a) {
                gs__ghost *gr = gs__ghost_of(w[i]->agents[a]);
                gs__ghost *gs = gr ? gs__ghost_find(w[j], gr->d.object_id) : NULL;
                int p = gs__peer_slot(net[i], (uint32_t)j + 1);
                if (!gs) continue;
                for (k = 0; k < GS_DELTA_RING; ++k) {
                    gs__base *e = &gr->gp[p].ring[k], *s;
                    if (!e->used) continue;
                    s = gs__ring_find(gs->ring, e->seq);
                    for (c = 0; s && c < gr->nchunks; ++c) {
                        size_t first = (size_t)c * (size_t)gr->per_chunk;
                        size_t cnt = gr->n - 1 - first < (size_t)gr->per_chunk
                                         ? gr->n - 1 - first : (size_t)gr->per_chunk;
                        if (!e->got[c] || !s->got[c]) continue;
                        if (memcmp(e->k + first, s->k + first, cnt * sizeof(int64_t)) == 0 &&
                            e->nseg[c] == s->nseg[c])
                            matched++;
                        else
                            mismatched++;
                    }
                }
            }
    }
    assert_int_equal(mismatched, 0);
    assert_true(matched > 1000 * (hosts - 1));
    assert_true(based > 240 / 2); /* deltas most of the time, despite the loss */
    for (i = 0; i < hosts; ++i) {
        gs_net_destroy(net[i]);
        gs_world_destroy(w[i]);
    }
    gs_simnet_destroy(sim);
}

static void test_delta_simnet(void **state) {
    (void)state;
    delta_simnet(2);
}

static void test_delta_simnet_three(void **state) {
    (void)state;
    delta_simnet(3);
}

/* The wire: differences and acknowledgements round trip; each coding is
   picked where it is smaller; bad payloads are refused. */
static void test_delta_wire(void **state) {
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    static gs_wire_view v;
    gs_wire_header h;
    gs_wire_chunk c;
    gs_wire_ack acks[3], back[3];
    int64_t d[200], out[200];
    size_t size, n;
    gs_reject why;
    int i;
    (void)state;
    memset(&h, 0, sizeof h);
    h.session = 1;
    h.sender = 2;
    memset(&c, 0, sizeof c);
    c.object_id = 9;
    c.sequence = 40;
    c.baseline = 37;
    c.count = 1;
    c.elements = 200;
    c.encoding = GS_ENCODING_QUANT;
    c.flags = GS_WIRE_CHUNK_DELTA;
    /* sparse: the bitmap */
    for (i = 0; i < 200; ++i) d[i] = i % 50 == 0 ? -1000 + i : 0;
    assert_int_equal(gs_wire_begin(buf, sizeof buf, &h, &size), GS_OK);
    assert_int_equal(gs_wire_add_delta(buf, sizeof buf, &size, &c, d), GS_OK);
    n = gs_wire_end(buf, size);
    assert_int_equal(gs_wire_decode(buf, n, &v, &why), GS_OK);
    assert_int_equal(v.chunks[0].baseline, 37);
    assert_int_equal(v.chunks[0].delta_coding, 1);
    gs_wire_deltas(&v.chunks[0], out);
    assert_memory_equal(out, d, sizeof d);
    assert_true(gs_wire_value(&v.chunks[0], 100) == (double)d[100]);
    /* dense, wide: packed, the extremes of the range */
    for (i = 0; i < 200; ++i) d[i] = i & 1 ? 2147483647LL - i : -2147483647LL + i;
    assert_int_equal(gs_wire_begin(buf, sizeof buf, &h, &size), GS_OK);
    c.elements = 100;
    assert_int_equal(gs_wire_add_delta(buf, sizeof buf, &size, &c, d), GS_OK);
    n = gs_wire_end(buf, size);
    assert_int_equal(gs_wire_decode(buf, n, &v, &why), GS_OK);
    assert_int_equal(v.chunks[0].delta_coding, 0);
    assert_int_equal(v.chunks[0].delta_width, 32);
    gs_wire_deltas(&v.chunks[0], out);
    assert_memory_equal(out, d, 100 * sizeof d[0]);
    /* out of range, a baseline not older, a wrong flag */
    d[3] = 2147483648LL;
    assert_int_equal(gs_wire_add_delta(buf, sizeof buf, &size, &c, d), GS_ERR_INVALID_ARG);
    d[3] = 0;
    c.baseline = c.sequence;
    assert_int_equal(gs_wire_add_delta(buf, sizeof buf, &size, &c, d), GS_ERR_INVALID_ARG);
    c.baseline = 1;
    c.flags = 0;
    assert_int_equal(gs_wire_add_delta(buf, sizeof buf, &size, &c, d), GS_ERR_INVALID_ARG);
    c.flags = GS_WIRE_CHUNK_DELTA; /* deltas go through gs_wire_add_delta only */
    assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c, (const double *)buf),
                     GS_ERR_INVALID_ARG);
    /* acknowledgements */
    acks[0].object_id = 100; acks[0].sequence = 4000000000u; acks[0].refused = 0;
    acks[1].object_id = 1;   acks[1].sequence = 5;           acks[1].refused = 1;
    acks[2].object_id = 4294967295u; acks[2].sequence = 4294967295u; acks[2].refused = 0;
    assert_int_equal(gs_wire_begin(buf, sizeof buf, &h, &size), GS_OK);
    assert_int_equal(gs_wire_add_ack(buf, sizeof buf, &size, 7, acks, 3), GS_OK);
    n = gs_wire_end(buf, size);
    assert_int_equal(gs_wire_decode(buf, n, &v, &why), GS_OK);
    assert_int_equal(v.chunks[0].object_id, 7);
    assert_int_equal(gs_wire_acks(&v.chunks[0], back, 3), 3);
    for (i = 0; i < 3; ++i) {
        assert_int_equal(back[i].object_id, acks[i].object_id);
        assert_int_equal(back[i].sequence, acks[i].sequence);
        assert_int_equal(back[i].refused, acks[i].refused);
    }
    assert_int_equal(gs_wire_add_ack(buf, sizeof buf, &size, 7, acks, 0), GS_ERR_INVALID_ARG);
    /* a delta whose bitmap's padding bits are set: refused */
    for (i = 0; i < 200; ++i) d[i] = i == 3 ? 1000 : 0;
    c.flags = GS_WIRE_CHUNK_DELTA;
    c.baseline = 39;
    c.elements = 36; /* one large change in 36: the bitmap, 5 bytes, 4 bits of
                        padding (Rice would escape it, 48 bits) */
    assert_int_equal(gs_wire_begin(buf, sizeof buf, &h, &size), GS_OK);
    assert_int_equal(gs_wire_add_delta(buf, sizeof buf, &size, &c, d), GS_OK);
    n = gs_wire_end(buf, size);
    assert_int_equal(gs_wire_decode(buf, n, &v, &why), GS_OK);
    assert_int_equal(v.chunks[0].delta_coding, 1);
    /* payload: distance (1 byte), width, bitmap: its last byte at 2 + 4 */
    buf[(size_t)(v.chunks[0].payload - buf) + 6] |= 0x80;
    n = gs_wire_end(buf, size);
    assert_int_equal(gs_wire_decode(buf, n, &v, &why), GS_ERR_REJECTED);
    assert_int_equal(why, GS_REJECT_LAYOUT);
}

/* delta without GS_ENCODING_QUANT: refused at attach. */
static void test_delta_desc(void **state) {
    gs_world *w;
    gs_world_desc wd = gs_world_desc_default();
    gs_rigid_desc rd = gs_rigid_desc_default();
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_agent *a;
    (void)state;
    rd.shape.type = GS_SHAPE_SPHERE;
    rd.shape.radius = 0.1;
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    assert_int_equal(gs_rigid_create(w, &rd, &a), GS_OK);
    gd.object_id = 5;
    gd.delta = 1;
    assert_int_equal(gs_ghost_attach(a, &gd), GS_ERR_INVALID_ARG);
    gd.encoding = GS_ENCODING_QUANT;
    assert_int_equal(gs_ghost_attach(a, &gd), GS_OK);
    gs_world_destroy(w);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_delta_wire),
        cmocka_unit_test(test_delta_desc),
        cmocka_unit_test(test_delta_clean_link),
        cmocka_unit_test(test_delta_chain_lossy),
        cmocka_unit_test(test_delta_lost_baseline),
        cmocka_unit_test(test_delta_old_baseline),
        cmocka_unit_test(test_delta_peer_restart),
        cmocka_unit_test(test_delta_simnet),
        cmocka_unit_test(test_delta_simnet_three),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
