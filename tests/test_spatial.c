/* test_spatial.c - GS_WIRE_CHUNK_DELTA's spatial coding (coding 3, see
   >>wire): each difference less the median edge prediction from the
   chunk's differences before it (the particle before, a row up).

   What must hold: a cloth's delta chunks take it (it is smaller), the
   receiver's values are still the sender's quantized state bit for bit
   under loss, duplicates and reordering, a spatial delta without its
   baseline is refused and counted, a malformed one refused as a layout,
   and a pushed cloth's stream costs fewer bytes than without it. The
   chain runs on delta_pair.h's transport, which reads both sides'
   private state, so this file compiles the implementation itself. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define GHOSTSIM_STATIC
#define GHOSTSIM_IMPLEMENTATION
#include "ghostsim.h"
#include "net_helpers.h"
#include "wire_helpers.h"
#include "delta_pair.h"

/* Loss, duplicates and reordering (test_delta.c runs three seeds of it): spatial chunks flow and
   every value queued is the sender's. */
static void test_spatial_chain_lossy(void **state) {
    uint64_t seed;
    (void)state;
    for (seed = 1; seed <= 1; ++seed) {
        pair *pr = pair_lossy(seed, 150);
        assert_int_equal(pr->mismatched, 0);
        assert_true(pr->matched > 300);
        assert_true(pr->spatial > 120); /* the cloth's 4 chunks a snapshot, most of them */
        pair_free(pr);
        free(pr);
    }
}

/* The receiver's baselines gone: its next spatial deltas are refused and
   counted, none decoded against anything else; the chain takes up again. */
static void test_spatial_refused_without_baseline(void **state) {
    pair *pr = (pair *)calloc(1, sizeof *pr);
    gs_world *w;
    long spatial;
    int f, i, k;
    (void)state;
    assert_non_null(pr);
    pair_make(pr, 5);
    for (f = 0; f < 30; ++f) frame(pr, 1);
    assert_true(pr->spatial > 0);
    assert_int_equal(refused(pr, 1), 0);
    w = pr->w[1];
    for (i = 0; i < w->agent_count; ++i) {
        gs__ghost *g = gs__ghost_of(w->agents[i]);
        for (k = 0; g && k < GS_DELTA_RING; ++k) g->gp[0].ring[k].used = 0;
    }
    spatial = pr->spatial;
    frame(pr, 1);
    assert_true(pr->spatial > spatial); /* what was refused was spatial too */
    assert_true(refused(pr, 1) > 0);
    for (f = 0; f < 30; ++f) frame(pr, 1);
    assert_int_equal(pr->mismatched, 0);
    assert_true(pr->spatial > spatial + 30);
    pair_free(pr);
    free(pr);
}

/* The wire: a smooth field of differences in two segments round trips
   through coding 3 with its row and restart; without delta_row it goes
   in another coding and takes more; a bad row or restart is refused. */
static void test_spatial_wire(void **state) {
    unsigned char buf[GS_WIRE_MAX_DATAGRAM], *q;
    static gs_wire_view v;
    gs_wire_header h;
    gs_wire_chunk c;
    int64_t d[240], out[240];
    size_t size, n, with;
    gs_reject why;
    int i, bad;
    (void)state;
    memset(&h, 0, sizeof h);
    h.session = 1;
    h.sender = 2;
    memset(&c, 0, sizeof c);
    c.object_id = 9;
    c.sequence = 40;
    c.baseline = 38;
    c.count = 1;
    c.elements = 240;
    c.encoding = GS_ENCODING_QUANT;
    c.flags = GS_WIRE_CHUNK_DELTA;
    c.segment_count = 2; /* 150 positions, then 90 velocities */
    c.segments[0].kind = c.segments[1].kind = GS_WIRE_SCALAR;
    c.segments[0].count = 150;
    c.segments[1].count = 90;
    /* rows of 8 particles, each coordinate a plane of slope 40 and 25
       steps, the velocities another, and a little noise */
    for (i = 0; i < 240; ++i) {
        int j = i < 150 ? i : i - 150, p = j / 3;
        d[i] = (i < 150 ? 900 : -3000) + 40 * (p % 8) + 25 * (p / 8) + 7 * (j % 3) + (i * 7 % 5);
    }
    c.delta_row = 8;
    assert_int_equal(gs_wire_begin(buf, sizeof buf, &h, &size), GS_OK);
    assert_int_equal(gs_wire_add_delta(buf, sizeof buf, &size, &c, d), GS_OK);
    with = size;
    n = gs_wire_end(buf, size);
    assert_int_equal(gs_wire_decode(buf, n, &v, &why), GS_OK);
    assert_int_equal(v.chunks[0].delta_coding, 3);
    assert_int_equal(v.chunks[0].delta_row, 8);
    assert_int_equal(v.chunks[0].delta_restart, 150);
    gs_wire_deltas(&v.chunks[0], out);
    assert_memory_equal(out, d, sizeof d);
    assert_true(gs_wire_value(&v.chunks[0], 200) == (double)d[200]);
    /* malformed: row 0, a row past GS_WIRE_SPATIAL_ROW, a restart past
       the chunk (the bytes after the distance and the coding byte) */
    q = (unsigned char *)v.chunks[0].payload + 2;
    for (bad = 0; bad < 3; ++bad) {
        unsigned char row = q[0], restart = q[1];
        if (bad == 0) q[0] = 0;
        if (bad == 1) q[0] = GS_WIRE_SPATIAL_ROW + 1;
        if (bad == 2) q[1] = 240;
        recrc(buf, n);
        assert_int_equal(gs_wire_decode(buf, n, &v, &why), GS_ERR_REJECTED);
        assert_int_equal(why, GS_REJECT_LAYOUT);
        q[0] = row;
        q[1] = restart;
    }
    /* the same differences without it */
    c.delta_row = 0;
    assert_int_equal(gs_wire_begin(buf, sizeof buf, &h, &size), GS_OK);
    assert_int_equal(gs_wire_add_delta(buf, sizeof buf, &size, &c, d), GS_OK);
    n = gs_wire_end(buf, size);
    assert_int_equal(gs_wire_decode(buf, n, &v, &why), GS_OK);
    assert_true(v.chunks[0].delta_coding != 3);
    assert_true(with < size);
}

/* Bytes host 1 sent over 60 frames of a pushed 12x12 cloth on a perfect
   link, with its ghosts' spatial coding tried or (row 0) not. */
static uint64_t pushed_bytes(int spatial) {
    pair *pr = (pair *)calloc(1, sizeof *pr);
    gs_peer_stats st;
    int f, i;
    uint64_t bytes;
    assert_non_null(pr);
    pair_make(pr, 3);
    for (i = 0; i < pr->w[0]->agent_count && !spatial; ++i) {
        gs__ghost *g = gs__ghost_of(pr->w[0]->agents[i]);
        if (g) g->row = 0;
    }
    for (f = 0; f < 60; ++f) frame(pr, 1);
    assert_int_equal(pr->mismatched, 0);
    assert_int_equal(gs_net_peer_stats(pr->net[0], 2, &st), GS_OK);
    bytes = st.bytes_sent;
    pair_free(pr);
    free(pr);
    return bytes;
}

/* The same pushed stream (the same seed, the same states: the coding
   does not change what is decoded) costs fewer bytes in the spatial
   coding. The bound (0.95) is loose on purpose: measured 0.922 at this
   commit, where the bytes also hold the spheres', probes', datagram and
   chunk headers' and acknowledgements', which the coding does not touch;
   bench/bandwidth's paper-push and cloth64-push rows measure the
   scenes. */
static void test_spatial_cheaper(void **state) {
    uint64_t with, without;
    (void)state;
    with = pushed_bytes(1);
    without = pushed_bytes(0);
    print_message("pushed 12x12 cloth: %llu bytes spatial, %llu without (%.3f)\n",
                  (unsigned long long)with, (unsigned long long)without,
                  (double)with / (double)without);
    assert_true((double)with < 0.95 * (double)without);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_spatial_wire),
        cmocka_unit_test(test_spatial_chain_lossy),
        cmocka_unit_test(test_spatial_refused_without_baseline),
        cmocka_unit_test(test_spatial_cheaper),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
