/* test_nextchunk.c - the "next chunk" header (bit 6 of a chunk's kind
   byte, see >>wire): a chunk that continues the chunk before's snapshot
   (its object, sequence and time, the next index, the element after the
   chunk before's last, the same element count) is that one byte.

   What must hold: the encoder says it for every such chunk and only
   those, the decoder gives back the very fields (a last shorter chunk
   with its own element count), the long form of such a chunk and every
   malformed next chunk are refused as a layout, and on a lossy,
   duplicating, reordering link a pushed cloth's deltas in next chunks
   still decode to the sender's quantized state bit for bit while costing
   fewer bytes. The chain runs on delta_pair.h's transport, which reads
   both sides' private state, so this file compiles the implementation. */
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

#define NEXT_BIT 0x40

static gs_wire_header header(void) {
    gs_wire_header h;
    memset(&h, 0, sizeof h);
    h.session = 7;
    h.sender = 2;
    h.sequence = 1;
    h.send_time = 3.5;
    return h;
}

/* Chunk `index` of `count` of a snapshot cut in chunks of 10 f64. */
static gs_wire_chunk piece(uint32_t id, uint32_t seq, double t, int index, int count, int n) {
    gs_wire_chunk c;
    memset(&c, 0, sizeof c);
    c.object_id = id;
    c.sequence = seq;
    c.time = t;
    c.index = (uint16_t)index;
    c.count = (uint16_t)count;
    c.first = (uint32_t)(10 * index);
    c.elements = (uint16_t)n;
    c.encoding = GS_ENCODING_F64;
    return c;
}

/* Delta chunk `index` of `count` of snapshot 40 of object 8 at 2 s, n
   quantized differences from `first` against snapshot `baseline`. */
static gs_wire_chunk delta_piece(int index, int count, int first, int n, uint32_t baseline) {
    gs_wire_chunk c;
    memset(&c, 0, sizeof c);
    c.object_id = 8;
    c.sequence = 40;
    c.baseline = baseline;
    c.time = 2.0;
    c.index = (uint16_t)index;
    c.count = (uint16_t)count;
    c.first = (uint32_t)first;
    c.elements = (uint16_t)n;
    c.encoding = GS_ENCODING_QUANT;
    c.flags = GS_WIRE_CHUNK_DELTA;
    return c;
}

/* The offset of chunk i's first (kind) byte in the datagram v came from:
   right after the chunk before's payload. */
static size_t head_at(const gs_wire_view *v, int i) {
    if (i == 0) return GS_WIRE_HEADER;
    return (size_t)(v->chunks[i - 1].payload - wire_copy) + v->chunks[i - 1].payload_bytes;
}

/* A snapshot of 35 f64 in chunks 0..3 (10, 10, 10, 5), then chunk 0 of
   another object: the next chunks take 1 byte, the short last 2, and
   every field comes back. */
static void test_next_round_trip(void **state) {
    static gs_wire_view v;
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    double vals[10];
    gs_wire_header h = header();
    gs_wire_chunk c[5];
    size_t size, n;
    int i, k;
    (void)state;
    for (k = 0; k < 10; ++k) vals[k] = 0.125 * k - 0.5;
    for (i = 0; i < 4; ++i) c[i] = piece(3, 9, 1.5, i, 4, i == 3 ? 5 : 10);
    c[4] = piece(4, 9, 1.5, 0, 2, 10);
    assert_int_equal(gs_wire_begin(buf, sizeof buf, &h, &size), GS_OK);
    for (i = 0; i < 5; ++i) assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c[i], vals), GS_OK);
    n = gs_wire_end(buf, size);
    assert_int_equal(wire_decode_copy(buf, n, &v), GS_REJECT_COUNT);
    assert_int_equal(v.chunk_count, 5);
    for (i = 0; i < 5; ++i) {
        const gs_wire_chunk *d = &v.chunks[i];
        size_t at = head_at(&v, i), hn = (size_t)(d->payload - wire_copy) - at;
        assert_int_equal(d->object_id, c[i].object_id);
        assert_int_equal(d->sequence, c[i].sequence);
        assert_true(d->time == c[i].time);
        assert_int_equal(d->index, c[i].index);
        assert_int_equal(d->count, c[i].count);
        assert_int_equal(d->first, c[i].first);
        assert_int_equal(d->elements, c[i].elements);
        for (k = 0; k < d->elements; ++k) assert_true(gs_wire_value(d, k) == vals[k]);
        /* chunks 1, 2: the kind byte alone; 3: and its element count (5);
           4 (another object) and 0: the long form */
        if (i == 1 || i == 2) assert_int_equal(hn, 1);
        if (i == 3) assert_int_equal(hn, 2);
        assert_int_equal((wire_copy[at] & NEXT_BIT) != 0, i >= 1 && i <= 3);
    }
}

/* Chunks that do not continue the one before keep the long form: a
   skipped index, another sequence, another time, a first element that is
   not the one after. */
static void test_next_only_when_continuing(void **state) {
    static gs_wire_view v;
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    double vals[10] = {0};
    gs_wire_header h = header();
    gs_wire_chunk c[5];
    size_t size, n;
    int i;
    (void)state;
    c[0] = piece(3, 9, 1.5, 0, 6, 10);
    c[1] = piece(3, 9, 1.5, 2, 6, 10);  /* index skipped */
    c[2] = piece(3, 10, 1.5, 3, 6, 10); /* another sequence */
    c[3] = piece(3, 10, 2.5, 4, 6, 10); /* another time */
    c[4] = piece(3, 10, 2.5, 5, 6, 10);
    c[4].first = 51; /* not the element after chunk 4's last (50) */
    assert_int_equal(gs_wire_begin(buf, sizeof buf, &h, &size), GS_OK);
    for (i = 0; i < 5; ++i) assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c[i], vals), GS_OK);
    n = gs_wire_end(buf, size);
    assert_int_equal(wire_decode_copy(buf, n, &v), GS_REJECT_COUNT);
    assert_int_equal(v.chunk_count, 5);
    for (i = 0; i < 5; ++i) {
        assert_int_equal(wire_copy[head_at(&v, i)] & NEXT_BIT, 0);
        assert_int_equal(v.chunks[i].first, c[i].first);
        assert_int_equal(v.chunks[i].index, c[i].index);
    }
}

/* An acknowledgement between two chunks: the second is still the next
   chunk of the first (an acknowledgement is not coded against). */
static void test_next_across_ack(void **state) {
    static gs_wire_view v;
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    double vals[10] = {0};
    gs_wire_header h = header();
    gs_wire_chunk a = piece(3, 9, 1.5, 0, 2, 10), b = piece(3, 9, 1.5, 1, 2, 10);
    gs_wire_ack ack = {5, 77, 0};
    size_t size, n;
    (void)state;
    assert_int_equal(gs_wire_begin(buf, sizeof buf, &h, &size), GS_OK);
    assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &a, vals), GS_OK);
    assert_int_equal(gs_wire_add_ack(buf, sizeof buf, &size, 1, &ack, 1), GS_OK);
    assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &b, vals), GS_OK);
    n = gs_wire_end(buf, size);
    assert_int_equal(wire_decode_copy(buf, n, &v), GS_REJECT_COUNT);
    assert_int_equal(v.chunk_count, 3);
    assert_true(wire_copy[head_at(&v, 2)] & NEXT_BIT);
    assert_int_equal(v.chunks[2].index, 1);
    assert_int_equal(v.chunks[2].first, 10);
    assert_int_equal(v.chunks[2].sequence, 9);
}

/* Two chunks of 10 f64 (chunk 0 and 1 of `count`), the second's header
   at *at (the kind byte alone). */
static size_t two_chunks(unsigned char *buf, int count, size_t *at) {
    static gs_wire_view v;
    double vals[10] = {0};
    gs_wire_header h = header();
    gs_wire_chunk a = piece(3, 9, 1.5, 0, count, 10), b = piece(3, 9, 1.5, 1, count, 10);
    size_t size, n;
    assert_int_equal(gs_wire_begin(buf, GS_WIRE_MAX_DATAGRAM, &h, &size), GS_OK);
    assert_int_equal(gs_wire_add(buf, GS_WIRE_MAX_DATAGRAM, &size, &a, vals), GS_OK);
    *at = size;
    assert_int_equal(gs_wire_add(buf, GS_WIRE_MAX_DATAGRAM, &size, &b, vals), GS_OK);
    n = gs_wire_end(buf, size);
    assert_int_equal(wire_decode_copy(buf, n, &v), GS_REJECT_COUNT);
    assert_int_equal(head_at(&v, 1), *at);
    assert_int_equal((size_t)(v.chunks[1].payload - wire_copy), *at + 1);
    return n;
}

/* The second chunk's header (1 byte at at) replaced by hn bytes of h. */
static size_t reheader(unsigned char *buf, size_t n, size_t at, const unsigned char *h,
                       size_t hn) {
    memmove(buf + at + hn, buf + at + 1, n - at - 1);
    memcpy(buf + at, h, hn);
    n = n - 1 + hn;
    recrc(buf, n);
    return n;
}

/* Malformed next chunks and the long form of one: refused as a layout,
   never read as something else (one datagram, one meaning). */
static void test_next_refused(void **state) {
    static gs_wire_view v;
    unsigned char good[GS_WIRE_MAX_DATAGRAM + 16], buf[GS_WIRE_MAX_DATAGRAM + 16];
    size_t n, m, at;
    unsigned char kind;
    (void)state;
    n = two_chunks(good, 3, &at);
    kind = good[at];
    assert_int_equal(kind, 0x08 | NEXT_BIT); /* values, f64, next */
    {   /* the long form of the same chunk: id +0, seq +0, split 1 of 3
           from 10, 10 elements */
        unsigned char lf[] = {0x08 | 0x20, 0, 0, 1, 3, 10, 10};
        memcpy(buf, good, n);
        m = reheader(buf, n, at, lf, sizeof lf);
        assert_int_equal(wire_decode_copy(buf, m, &v), GS_REJECT_LAYOUT);
        lf[5] = 11; /* from 11: not the next chunk, taken */
        memcpy(buf, good, n);
        m = reheader(buf, n, at, lf, sizeof lf);
        assert_int_equal(wire_decode_copy(buf, m, &v), GS_REJECT_COUNT);
        assert_int_equal(v.chunks[1].first, 11);
    }
    {   /* an element count said again, the same: refused; another: taken */
        unsigned char ec[] = {0x08 | NEXT_BIT | 0x20, 10};
        memcpy(buf, good, n);
        m = reheader(buf, n, at, ec, sizeof ec);
        assert_int_equal(wire_decode_copy(buf, m, &v), GS_REJECT_LAYOUT);
        ec[1] = 9; /* 9 values: the last one's 8 bytes cut off */
        memcpy(buf, good, n);
        m = reheader(buf, n, at, ec, sizeof ec) - 8;
        recrc(buf, m);
        assert_int_equal(wire_decode_copy(buf, m, &v), GS_REJECT_COUNT);
        assert_int_equal(v.chunks[1].elements, 9);
        assert_int_equal(v.chunks[1].first, 10);
    }
    {   /* with a time bit, as a heartbeat, as an acknowledgement */
        static const unsigned char bad[][1] = {{0x08 | NEXT_BIT | 0x04}, {0x0a | NEXT_BIT},
                                               {0x1b | NEXT_BIT}, {0x08 | 0x80}};
        int i;
        for (i = 0; i < 4; ++i) {
            memcpy(buf, good, n);
            m = reheader(buf, n, at, bad[i], 1);
            assert_int_equal(wire_decode_copy(buf, m, &v), GS_REJECT_LAYOUT);
        }
    }
    /* past the snapshot's last chunk: chunk 1 of 1 */
    {
        /* the first chunk made 0 of 1 (not split: its header drops the
           split fields), the second still "next": refused */
        static gs_wire_view w;
        double vals[10] = {0};
        gs_wire_header h = header();
        gs_wire_chunk a = piece(3, 9, 1.5, 0, 1, 10);
        size_t size;
        unsigned char nx = 0x08 | NEXT_BIT;
        assert_int_equal(gs_wire_begin(buf, GS_WIRE_MAX_DATAGRAM, &h, &size), GS_OK);
        assert_int_equal(gs_wire_add(buf, GS_WIRE_MAX_DATAGRAM, &size, &a, vals), GS_OK);
        buf[size] = nx;
        memset(buf + size + 1, 0, 80);
        gs__hdr_set_chunks(buf, 2);
        m = size + 1 + 80 + 4;
        recrc(buf, m);
        assert_int_equal(wire_decode_copy(buf, m, &w), GS_REJECT_LAYOUT);
        /* as the first chunk of a datagram: nothing to continue */
        memmove(buf + GS_WIRE_HEADER, buf + size, 81);
        gs__hdr_set_chunks(buf, 1);
        m = GS_WIRE_HEADER + 81 + 4;
        recrc(buf, m);
        assert_int_equal(wire_decode_copy(buf, m, &w), GS_REJECT_LAYOUT);
    }
}

/* Delta chunks of a quantized snapshot cut in four: next chunks, their
   differences back bit for bit; the baseline is said once (bit 2, its
   distance left out of the payload) while it stays the chunk before's:
   chunk 3, against another baseline, says its own. */
static void test_next_delta(void **state) {
    static gs_wire_view v;
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    gs_wire_header h = header();
    int64_t d[4][60], got[GS_WIRE_QUANT_CHUNK];
    size_t size, n;
    int i, k;
    (void)state;
    assert_int_equal(gs_wire_begin(buf, sizeof buf, &h, &size), GS_OK);
    for (i = 0; i < 4; ++i) {
        gs_wire_chunk c = delta_piece(i, 4, i == 3 ? 165 : 60 * i, i >= 2 ? 45 : 60,
                                      i == 3 ? 36 : 37);
        c.delta_row = 5;
        for (k = 0; k < 60; ++k) d[i][k] = (int64_t)((k * 7 + i * 3) % 11) - 5;
        assert_int_equal(gs_wire_add_delta(buf, sizeof buf, &size, &c, d[i]), GS_OK);
    }
    n = gs_wire_end(buf, size);
    assert_int_equal(wire_decode_copy(buf, n, &v), GS_REJECT_COUNT);
    assert_int_equal(v.chunk_count, 4);
    for (i = 0; i < 4; ++i) {
        const gs_wire_chunk *c = &v.chunks[i];
        int same = i == 1 || i == 2;
        assert_int_equal((wire_copy[head_at(&v, i)] & NEXT_BIT) != 0, i > 0);
        if (i) assert_int_equal((wire_copy[head_at(&v, i)] & 0x04) != 0, same); /* 0: its time */
        assert_int_equal(c->delta_skip, same ? 0 : 1); /* distance 3 or 4: 1 byte */
        assert_int_equal(c->first, i == 3 ? 165 : 60 * i);
        assert_int_equal(c->elements, i >= 2 ? 45 : 60);
        assert_int_equal(c->baseline, i == 3 ? 36 : 37);
        gs_wire_deltas(c, got);
        for (k = 0; k < c->elements; ++k) assert_int_equal(got[k], d[i][k]);
    }
}

/* Bit 2 of a next chunk (the chunk before's baseline) where it cannot
   hold, and its long form (the distance said again): refused as a
   layout. Chunk 1's header and payload start at at: [kind][coding...]. */
static void test_next_same_base_refused(void **state) {
    static gs_wire_view v;
    unsigned char good[GS_WIRE_MAX_DATAGRAM + 16], buf[GS_WIRE_MAX_DATAGRAM + 16];
    gs_wire_header h = header();
    int64_t d[30];
    size_t size, n, m, at;
    int i, k;
    (void)state;
    for (k = 0; k < 30; ++k) d[k] = k % 5 - 2;
    assert_int_equal(gs_wire_begin(good, sizeof good, &h, &size), GS_OK);
    for (i = 0; i < 2; ++i) {
        gs_wire_chunk c = delta_piece(i, 2, 30 * i, 30, 37);
        if (i) at = size;
        assert_int_equal(gs_wire_add_delta(good, sizeof good, &size, &c, d), GS_OK);
    }
    n = gs_wire_end(good, size);
    assert_int_equal(wire_decode_copy(good, n, &v), GS_REJECT_COUNT);
    assert_int_equal(good[at], 0x19 | NEXT_BIT | 0x04); /* delta, quant, next, same base */
    {   /* the distance said again (3), bit 2 clear: refused */
        unsigned char lf[] = {0x19 | NEXT_BIT, 3};
        memcpy(buf, good, n);
        m = reheader(buf, n, at, lf, sizeof lf);
        assert_int_equal(wire_decode_copy(buf, m, &v), GS_REJECT_LAYOUT);
        lf[1] = 4; /* another baseline (36): taken */
        memcpy(buf, good, n);
        m = reheader(buf, n, at, lf, sizeof lf);
        assert_int_equal(wire_decode_copy(buf, m, &v), GS_REJECT_COUNT);
        assert_int_equal(v.chunks[1].baseline, 36);
        assert_int_equal(v.chunks[1].delta_skip, 1);
    }
    {   /* bit 2 after a chunk that is not a delta: the first made values */
        static gs_wire_view w;
        double vals[30] = {0};
        gs_wire_chunk a;
        memset(&a, 0, sizeof a);
        a.object_id = 8;
        a.sequence = 40;
        a.time = 2.0;
        a.count = 2;
        a.elements = 30;
        a.encoding = GS_ENCODING_F64;
        assert_int_equal(gs_wire_begin(buf, sizeof buf, &h, &size), GS_OK);
        assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &a, vals), GS_OK);
        memcpy(buf + size, good + at, n - 4 - at); /* chunk 1 as it was */
        gs__hdr_set_chunks(buf, 2);
        m = size + (n - 4 - at) + 4;
        recrc(buf, m);
        assert_int_equal(wire_decode_copy(buf, m, &w), GS_REJECT_LAYOUT);
    }
    /* bit 2 on a values chunk after a delta chunk: refused */
    memcpy(buf, good, n);
    buf[at] = 0x18 | NEXT_BIT | 0x04;
    recrc(buf, n);
    assert_int_equal(wire_decode_copy(buf, n, &v), GS_REJECT_LAYOUT);
}

/* Kind bit 7: the next chunks of a spatial delta (coding 3) of the same
   row and restart 0 leave their row and restart bytes out (2 bytes each
   fewer) and decode bit for bit with the row; the bit where it cannot
   hold and the long form (row and restart said again) are refused. */
static void test_next_same_row(void **state) {
    static gs_wire_view v;
    unsigned char good[GS_WIRE_MAX_DATAGRAM + 16], buf[GS_WIRE_MAX_DATAGRAM + 16];
    gs_wire_header h = header();
    int64_t d[3][60], got[GS_WIRE_QUANT_CHUNK];
    size_t size, n, m, at;
    int i, k;
    (void)state;
    assert_int_equal(gs_wire_begin(good, sizeof good, &h, &size), GS_OK);
    for (i = 0; i < 3; ++i) {
        gs_wire_chunk c = delta_piece(i, 3, 60 * i, 60, 37);
        c.delta_row = 5; /* rows of 5 particles: 15 values */
        /* a plane of slopes 40 and 25 steps per coordinate, a little noise */
        for (k = 0; k < 60; ++k) {
            int p = (60 * i + k) / 3;
            d[i][k] = 900 + 40 * (p % 5) + 25 * (p / 5) + 7 * (k % 3) + (k * 7 % 5);
        }
        assert_int_equal(gs_wire_add_delta(good, sizeof good, &size, &c, d[i]), GS_OK);
    }
    n = gs_wire_end(good, size);
    assert_int_equal(wire_decode_copy(good, n, &v), GS_REJECT_COUNT);
    assert_int_equal(v.chunk_count, 3);
    for (i = 0; i < 3; ++i) {
        const gs_wire_chunk *c = &v.chunks[i];
        assert_int_equal(c->delta_coding, 3);
        assert_int_equal(c->delta_row, 5);
        assert_int_equal(c->delta_restart, 0);
        assert_int_equal((wire_copy[head_at(&v, i)] & 0x80) != 0, i > 0);
        /* the distance (1 byte) in chunk 0, then the coding byte, then
           the row and restart unless bit 7 says them */
        assert_int_equal(c->delta_data, i ? 1 : 4);
        gs_wire_deltas(c, got);
        for (k = 0; k < 60; ++k) assert_int_equal(got[k], d[i][k]);
    }
    at = head_at(&v, 1);
    assert_int_equal(good[at], 0x19 | NEXT_BIT | 0x04 | 0x80); /* 1 byte of header */
    {   /* the long form: bit 7 clear, row 5 and restart 0 said: refused */
        unsigned char lf[3];
        memcpy(buf, good, n);
        buf[at] = (unsigned char)(buf[at] & 0x7f);
        lf[0] = buf[at + 1];
        lf[1] = 5;
        lf[2] = 0;
        m = reheader(buf, n, at + 1, lf, sizeof lf);
        assert_int_equal(wire_decode_copy(buf, m, &v), GS_REJECT_LAYOUT);
        lf[1] = 4; /* another row: taken (chunk 2's bit 7 then says row 4) */
        memcpy(buf, good, n);
        buf[at] = (unsigned char)(buf[at] & 0x7f);
        m = reheader(buf, n, at + 1, lf, sizeof lf);
        assert_int_equal(wire_decode_copy(buf, m, &v), GS_REJECT_COUNT);
        assert_int_equal(v.chunks[1].delta_row, 4);
        assert_int_equal(v.chunks[2].delta_row, 4);
    }
    /* bit 7 on the first chunk (no chunk before), and on a next chunk
       after a chunk that was not spatial: refused */
    memcpy(buf, good, n);
    buf[GS_WIRE_HEADER] = (unsigned char)(buf[GS_WIRE_HEADER] | 0x80);
    recrc(buf, n);
    assert_int_equal(wire_decode_copy(buf, n, &v), GS_REJECT_LAYOUT);
    assert_int_equal(gs_wire_begin(buf, sizeof buf, &h, &size), GS_OK);
    for (i = 0; i < 2; ++i) {
        gs_wire_chunk c = delta_piece(i, 2, 60 * i, 60, 37);
        c.delta_row = i ? 5 : 0; /* chunk 0 in coding 2 */
        assert_int_equal(gs_wire_add_delta(buf, sizeof buf, &size, &c, d[i]), GS_OK);
    }
    n = gs_wire_end(buf, size);
    assert_int_equal(wire_decode_copy(buf, n, &v), GS_REJECT_COUNT);
    assert_true(v.chunks[0].delta_coding != 3);
    assert_int_equal(v.chunks[1].delta_coding, 3);
    at = head_at(&v, 1);
    assert_int_equal(wire_copy[at] & 0x80, 0); /* said: row and restart */
    memcpy(good, wire_copy, n);
    good[at] = (unsigned char)(good[at] | 0x80);
    recrc(good, n);
    assert_int_equal(wire_decode_copy(good, n, &v), GS_REJECT_LAYOUT);
}

/* The pushed 12x12 cloth of delta_pair.h (4 chunks a snapshot) over a
   link losing 15%, duplicating 10% and holding back 20% of datagrams:
   next chunks go, and every value queued is the sender's. */
static void test_next_chain_lossy(void **state) {
    static gs_wire_view v;
    pair *pr = (pair *)calloc(1, sizeof *pr);
    long next = 0, chunks = 0;
    int f, i, j;
    (void)state;
    assert_non_null(pr);
    pair_make(pr, 11);
    pr->loss = 0.15;
    pr->dup = 0.1;
    pr->reorder = 0.2;
    for (f = 0; f < 120; ++f) {
        pr->now += FRAME;
        {
            gs_quat q = {0, 0, 0, 1};
            gs_probe_set_target(pr->sc[0].probes[0], gs_scene_probe_path(0, pr->now), q);
        }
        gs_world_advance(pr->w[0], FRAME, NULL);
        for (i = 0; i < 2; ++i) gs_net_update(pr->net[i], pr->now);
        for (i = 0; i < pr->nq; ++i) {
            if (pr->q[i].to != 1 || wire_decode_copy(pr->q[i].d, pr->q[i].size, &v) != GS_REJECT_COUNT)
                continue;
            for (j = 0; j < v.chunk_count; ++j) {
                if (v.chunks[j].flags & GS_WIRE_CHUNK_ACK) continue;
                chunks++;
                next += (wire_copy[head_at(&v, j)] & NEXT_BIT) != 0;
            }
        }
        deliver(pr);
    }
    print_message("chunks to host 2: %ld, %ld of them next chunks; %ld values matched\n",
                  chunks, next, pr->matched);
    assert_int_equal(pr->mismatched, 0);
    assert_true(pr->matched > 300);
    assert_true(pr->deltas > 200);
    /* the cloth's chunks 1-3 of a snapshot whenever they share a datagram
       (864 quantized values fit one): 3 of a snapshot's 8 chunks (4 cloth,
       2 spheres, 2 probes) when every ghost sends; a quarter leaves room
       for a snapshot cut by a datagram's end */
    assert_true(next * 4 > chunks);
    pair_free(pr);
    free(pr);
}

static int teardown(void **state) {
    (void)state;
    free(wire_copy);
    wire_copy = NULL;
    return 0;
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(test_next_round_trip, teardown),
        cmocka_unit_test_teardown(test_next_only_when_continuing, teardown),
        cmocka_unit_test_teardown(test_next_across_ack, teardown),
        cmocka_unit_test_teardown(test_next_refused, teardown),
        cmocka_unit_test_teardown(test_next_delta, teardown),
        cmocka_unit_test_teardown(test_next_same_base_refused, teardown),
        cmocka_unit_test_teardown(test_next_same_row, teardown),
        cmocka_unit_test_teardown(test_next_chain_lossy, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
