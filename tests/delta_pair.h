/* delta_pair.h - two hosts of a small paper scene (12x12 cloth, 2 spheres,
   2 probes) in quantized delta coding, over this header's own transport:
   every datagram is held, then delivered (or lost, duplicated, held back)
   by a seeded generator, and each one delivered is checked at once
   against the sender's record (the receiver's queued values are the
   sender's quantized state bit for bit). For tests that compile the
   implementation themselves (GHOSTSIM_STATIC, GHOSTSIM_IMPLEMENTATION):
   the check reads both sides' private state. test_delta.c and
   test_spatial.c use it. */
#ifndef GS_TEST_DELTA_PAIR_H
#define GS_TEST_DELTA_PAIR_H

#define FRAME (1.0 / 60.0)
#define MAXQ 512

typedef struct held {
    int to; /* 0 or 1: the host index */
    size_t size;
    unsigned char d[GS_WIRE_MAX_DATAGRAM];
} held;

typedef struct pair {
    gs_world *w[2];
    gs_net *net[2];
    gs_scene sc[2];
    held q[MAXQ];
    int nq;
    int sending; /* the host index whose update is running */
    double now;
    uint64_t rng;
    double loss, dup, reorder;
    /* what the checks saw */
    long matched, mismatched, deltas, keys, acks;
    long spatial; /* delta chunks in the spatial coding (3) */
} pair;

static GS_TEST_UNUSED double rnd(pair *pr) {
    pr->rng = pr->rng * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(pr->rng >> 11) / 9007199254740992.0;
}

static GS_TEST_UNUSED gs_result hold(void *user, uint32_t host, const void *data, size_t size) {
    pair *pr = (pair *)user;
    if (pr->nq < MAXQ) {
        pr->q[pr->nq].to = (int)host - 1;
        pr->q[pr->nq].size = size;
        memcpy(pr->q[pr->nq].d, data, size);
        pr->nq++;
    }
    return GS_OK;
}

static GS_TEST_UNUSED gs_ghost_desc delta_desc(void) {
    gs_ghost_desc gd = gs_ghost_desc_default();
    gd.encoding = GS_ENCODING_QUANT;
    gd.delta = 1;
    gd.weight = gs_weight_cs;
    gd.queue_size = 64; /* the receiver never blends here: keep them */
    return gd;
}

static GS_TEST_UNUSED void host_make(pair *pr, int i) {
    gs_world_desc wd = gs_world_desc_default();
    gs_scene_desc sd = gs_scene_desc_default();
    gs_ghost_desc gd = delta_desc();
    gs_net_desc nd;
    wd.host_id = (uint32_t)i + 1;
    assert_int_equal(gs_world_create(&wd, &pr->w[i]), GS_OK);
    sd.cloth_n = 12; /* 864 values: 4 chunks */
    sd.sphere_count = 2;
    sd.probe_count = 2;
    assert_int_equal(gs_scene_create(pr->w[i], &sd, &pr->sc[i]), GS_OK);
    assert_int_equal(gs_scene_attach_ghosts(&pr->sc[i], &gd), GS_OK);
    memset(&nd, 0, sizeof nd);
    nd.transport.send = hold;
    nd.transport.user = pr;
    nd.bandwidth = 1e9;
    assert_int_equal(gs_net_create(pr->w[i], &nd, &pr->net[i]), GS_OK);
    assert_int_equal(gs_net_add_peer(pr->net[i], (uint32_t)(2 - i), NULL), GS_OK);
}

static GS_TEST_UNUSED void host_drop(pair *pr, int i) {
    gs_net_destroy(pr->net[i]);
    gs_world_destroy(pr->w[i]);
    pr->net[i] = NULL;
    pr->w[i] = NULL;
}

static GS_TEST_UNUSED void pair_make(pair *pr, uint64_t seed) {
    memset(pr, 0, sizeof *pr);
    pr->rng = seed;
    host_make(pr, 0);
    host_make(pr, 1);
}

static GS_TEST_UNUSED void pair_free(pair *pr) {
    int i;
    for (i = 0; i < 2; ++i)
        if (pr->w[i]) host_drop(pr, i);
}

/* The sender's quantized state of snapshot seq, chunk c (its values as
   the wire makes them), or 0 if its ring no longer holds it. */
static GS_TEST_UNUSED int sender_values(gs__ghost *g, uint32_t seq, int c, double *out) {
    gs__base *e = gs__ring_find(g->ring, seq);
    size_t first = (size_t)c * (size_t)g->per_chunk;
    if (!e || !e->got[c]) return 0;
    gs__qk_values(e->seg + (size_t)c * GS_WIRE_MAX_SEGMENTS, e->nseg[c], e->k + first, out);
    return 1;
}

/* Every value chunk of a datagram host `from` sent host `to`, as the
   receiver queued it, against the sender's record. */
static GS_TEST_UNUSED void check_datagram(pair *pr, int from, int to, const unsigned char *d,
                                          size_t size) {
    static gs_wire_view v;
    double want[GS_WIRE_QUANT_CHUNK];
    int i, k;
    int p = gs__peer_slot(pr->net[to], (uint32_t)from + 1);
    if (gs_wire_decode(d, size, &v, NULL) != GS_OK) return;
    for (i = 0; i < v.chunk_count; ++i) {
        const gs_wire_chunk *c = &v.chunks[i];
        gs__ghost *gs = gs__ghost_find(pr->w[from], c->object_id);
        gs__ghost *gr = gs__ghost_find(pr->w[to], c->object_id);
        if (c->flags & GS_WIRE_CHUNK_ACK) { pr->acks++; continue; }
        if (c->flags & GS_WIRE_CHUNK_REST || !gs || !gr) continue;
        if ((c->flags & GS_WIRE_CHUNK_DELTA) && c->delta_coding == 3) pr->spatial++;
        if (c->flags & GS_WIRE_CHUNK_DELTA) pr->deltas++;
        else pr->keys++;
        if (!sender_values(gs, c->sequence, c->index, want)) continue;
        for (k = 0; k < gr->d.queue_size; ++k) {
            gs__snap *s = &gr->gp[p].q[k];
            if (!s->used || s->seq != c->sequence || !s->got[c->index]) continue;
            if (memcmp(s->data + c->first, want, c->elements * sizeof(double)) == 0)
                pr->matched++;
            else
                pr->mismatched++;
        }
    }
}

/* Delivers what is held: each datagram lost, delivered, or also
   duplicated, and some held back to the next round (reordered). */
static GS_TEST_UNUSED void deliver(pair *pr) {
    static held keep[MAXQ];
    int i, nk = 0, n = pr->nq;
    for (i = 0; i < n; ++i) {
        held *h = &pr->q[i];
        int from = 1 - h->to, times = 1;
        if (!pr->net[h->to] || !pr->net[from]) continue;
        if (rnd(pr) < pr->loss) continue;
        if (rnd(pr) < pr->reorder && nk < MAXQ) { keep[nk++] = *h; continue; }
        if (rnd(pr) < pr->dup) times = 2;
        while (times--) {
            gs_net_deliver(pr->net[h->to], h->d, h->size, pr->now, NULL);
            check_datagram(pr, from, h->to, h->d, h->size);
        }
    }
    memcpy(pr->q, keep, (size_t)nk * sizeof keep[0]);
    pr->nq = nk;
}

/* One frame: the sender's world steps (the receiver's does not, so that
   its queues keep what came), both nets send, the network delivers. */
static GS_TEST_UNUSED void frame(pair *pr, int probes) {
    int i;
    pr->now += FRAME;
    if (probes && pr->w[0]) {
        gs_quat q = {0, 0, 0, 1};
        gs_probe_set_target(pr->sc[0].probes[0], gs_scene_probe_path(0, pr->now), q);
    }
    if (pr->w[0]) gs_world_advance(pr->w[0], FRAME, NULL);
    for (i = 0; i < 2; ++i)
        if (pr->net[i]) gs_net_update(pr->net[i], pr->now);
    deliver(pr);
}

static GS_TEST_UNUSED uint64_t refused(pair *pr, int host) {
    gs_peer_stats st;
    if (gs_net_peer_stats(pr->net[host], (uint32_t)(2 - host), &st) != GS_OK) return 0;
    return st.rejected[GS_REJECT_BASELINE];
}

/* A pair of seed `seed` run `frames` frames with the probes pushing over
   a bad link: 15% of datagrams lost, 10% duplicated, 20% held back to the
   next round. The caller checks it, then pair_free and free. */
static GS_TEST_UNUSED pair *pair_lossy(uint64_t seed, int frames) {
    pair *pr = (pair *)calloc(1, sizeof *pr);
    int f;
    assert_non_null(pr);
    pair_make(pr, seed);
    pr->loss = 0.15;
    pr->dup = 0.1;
    pr->reorder = 0.2;
    for (f = 0; f < frames; ++f) frame(pr, 1);
    return pr;
}

#endif
