/* test_wire.c - wire format v1 (>>wire).

   Encoding and decoding of datagrams without any world: every header and
   chunk field round-trips, chunks pack until the datagram is full, and every
   reason gs_wire_decode has to refuse a datagram is produced on purpose and
   checked. Datagrams that are wrong in one way only are made by editing the
   bytes of a valid one at the offsets the header's comment documents and
   computing the CRC-32 again with this file's own (bitwise) CRC, so that
   only the edited field is wrong. Every buffer handed to gs_wire_decode is
   a malloc of exactly its size: under ASan a read past its end is caught. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ghostsim.h"
#include "wire_helpers.h"

/* Offsets of the documented layout (header 48 B; a chunk's header is
   coded against the chunk before it, see >>wire). */
enum {
    OFF_MAGIC = 0, OFF_VERSION = 4, OFF_FLAGS = 5, OFF_NCHUNKS = 6,
    OFF_SESSION = 8, OFF_SENDER = 12, OFF_SEQ = 16, OFF_SEND_TIME = 24,
    OFF_ECHO_TIME = 32, OFF_ECHO_HOLD = 40,
    /* within a chunk */
    C_KIND = 0, C_OBJECT = 1,
    /* valid_datagram's chunk: kind, id 42 (1 byte), sequence 77 (2), its
       time, element count 4 (1), then its values */
    V_TIME = 4, V_ELEMENTS = 12, V_PAY = 13
};

/* ---- little helpers: bytes, CRC ---- */


static void put16(unsigned char *p, uint16_t v) {
    p[0] = (unsigned char)v;
    p[1] = (unsigned char)(v >> 8);
}
static void put32(unsigned char *p, uint32_t v) {
    put16(p, (uint16_t)v);
    put16(p + 2, (uint16_t)(v >> 16));
}
static uint16_t get16(const unsigned char *p) { return (uint16_t)(p[0] | p[1] << 8); }
static uint32_t get32(const unsigned char *p) {
    return (uint32_t)get16(p) | (uint32_t)get16(p + 2) << 16;
}
static void putf64(unsigned char *p, double v) {
    uint64_t u;
    memcpy(&u, &v, 8);
    put32(p, (uint32_t)u);
    put32(p + 4, (uint32_t)(u >> 32));
}
static void putf32(unsigned char *p, float v) {
    uint32_t u;
    memcpy(&u, &v, 4);
    put32(p, u);
}

/* A double rounded to float. Through a volatile: GCC 12's vectorizer at -O2
   can fold (double)(float)x in a loop over a constant array to x. */
static double to_f32(double v) {
    volatile float f = (float)v;
    return f;
}


/* Decodes a private copy of exactly `size` bytes (so that ASan sees any
   read past the end); returns gs_wire_decode's answer. */
static int decode_copy(const unsigned char *buf, size_t size, gs_wire_view *v,
                       gs_reject *why) {
    unsigned char *copy = (unsigned char *)malloc(size ? size : 1);
    int ok;
    assert_non_null(copy);
    if (size) memcpy(copy, buf, size);
    ok = gs_wire_decode(copy, size, v, why) == GS_OK;
    free(copy);
    return ok;
}

/* A heap copy of exactly `size` bytes, for a decode whose chunk payloads
   are read afterwards (they point into it). */
static unsigned char *dup_exact(const unsigned char *buf, size_t size) {
    unsigned char *copy = (unsigned char *)malloc(size);
    assert_non_null(copy);
    memcpy(copy, buf, size);
    return copy;
}

/* Expects a refusal for `expect`. */
static void expect_reject(const unsigned char *buf, size_t size, gs_reject expect) {
    gs_wire_view *v = (gs_wire_view *)malloc(sizeof *v);
    gs_reject why = GS_REJECT_COUNT;
    assert_non_null(v);
    assert_int_equal(decode_copy(buf, size, v, &why), 0);
    if (why != expect)
        print_error("expected reject %d (%s), got %d (%s)\n", (int)expect,
                    gs_reject_str(expect), (int)why, gs_reject_str(why));
    assert_int_equal(why, expect);
    free(v);
}

static gs_wire_header header_example(void) {
    gs_wire_header h;
    memset(&h, 0, sizeof h); /* run 0 (not said), sync 0 (present, local clock) */
    h.session = 0x01020304u;
    h.sender = 3;
    h.sequence = 0xdeadbeefu;
    h.send_time = 12.5;
    h.echo_time = 3.25;
    h.echo_hold = 0.001;
    return h;
}

static gs_wire_chunk chunk_example(uint32_t object, gs_encoding enc, uint16_t elements) {
    gs_wire_chunk c;
    memset(&c, 0, sizeof c);
    c.object_id = object;
    c.sequence = 77;
    c.time = 1.75;
    c.index = 0;
    c.count = 1;
    c.first = 0;
    c.elements = elements;
    c.encoding = enc;
    return c;
}

/* A valid datagram with one f64 chunk of 4 values; returns its size.
   The chunk starts at GS_WIRE_HEADER, its payload V_PAY bytes later. */
static size_t valid_datagram(unsigned char *buf, size_t cap) {
    static const double vals[4] = {0.25, -1.5, 3.0, 1e-3};
    gs_wire_header h = header_example();
    gs_wire_chunk c = chunk_example(42, GS_ENCODING_F64, 4);
    size_t size = 0;
    assert_int_equal(gs_wire_begin(buf, cap, &h, &size), GS_OK);
    assert_int_equal(gs_wire_add(buf, cap, &size, &c, vals), GS_OK);
    return gs_wire_end(buf, size);
}

/* ---- round trip ---- */

static void test_roundtrip_fields(void **state) {
    /* f64 values that stress the encoding: extremes, a subnormal, -0. */
    static const double v64[7] = {3.141592653589793, -1e300, 1e-300, 4.9e-324,
                                  -0.0, 123456789.123456789, DBL_MAX};
    /* f32 values: none is exactly representable in float except 0.5. */
    static const double v32[6] = {3.141592653589793, 1.0 / 3.0, -2.5e7 - 0.3,
                                  1e-3, 0.5, -65504.123};
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    gs_wire_header h = header_example();
    gs_wire_chunk c64 = chunk_example(42, GS_ENCODING_F64, 7);
    gs_wire_chunk c32 = chunk_example(0xfffffffeu, GS_ENCODING_F32, 6);
    gs_wire_view *v = (gs_wire_view *)malloc(sizeof *v);
    gs_reject why = GS_REJECT_COUNT;
    unsigned char *copy;
    size_t size = 0, total;
    int i;
    (void)state;
    assert_non_null(v);
    c64.sequence = 0x89abcdefu;
    c64.time = 1234.000000001;
    c64.index = 3;
    c64.count = 9;
    c64.first = 417;
    c32.sequence = 1;
    c32.time = 0.0; /* the earliest allowed time */
    c32.index = 65534;
    c32.count = 65535;
    c32.first = 0xfffffff0u;

    assert_int_equal(gs_wire_begin(buf, sizeof buf, &h, &size), GS_OK);
    assert_int_equal(size, GS_WIRE_HEADER);
    assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c64, v64), GS_OK);
    assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c32, v32), GS_OK);
    /* chunk headers (>>wire): kind; id, sequence as zigzag varints from the
       chunk before (42: 1 byte; 0x89abcdef: 5); the time; index 3, count 9,
       first 417 (1 + 1 + 2); elements 7 (1): 20 bytes. Then id -44 (1),
       sequence +0x76543212 (5), time 0 (8), index 65534, count 65535 (3 +
       3), first 0xfffffff0 - 417 (5), elements 6 (1): 27 */
    assert_int_equal(size, GS_WIRE_HEADER + 20 + 27 + 7 * 8 + 6 * 4);
    total = gs_wire_end(buf, size);
    assert_int_equal(total, size + 4);

    /* the documented bytes: magic, version, chunk count, little-endian
       fields, and a standard CRC-32 of everything before it */
    assert_memory_equal(buf + OFF_MAGIC, "GSIM", 4);
    assert_int_equal(buf[OFF_VERSION], GS_WIRE_VERSION);
    assert_int_equal(get16(buf + OFF_NCHUNKS), 2);
    assert_int_equal(get32(buf + OFF_SESSION), h.session);
    assert_int_equal(get32(buf + OFF_SENDER), h.sender);
    assert_int_equal(get32(buf + OFF_SEQ), h.sequence);
    /* kind: values (0), a time (0x04), f64 (1 << 3), split (0x20) */
    assert_int_equal(buf[GS_WIRE_HEADER + C_KIND], 0x04 | GS_ENCODING_F64 << 3 | 0x20);
    assert_int_equal(buf[GS_WIRE_HEADER + C_OBJECT], 84); /* zigzag(42) */
    assert_int_equal(buf[GS_WIRE_HEADER + 20 - 1], 7);    /* elements, last */
    assert_int_equal(get32(buf + total - 4), crc32_ref(buf, total - 4));

    copy = dup_exact(buf, total);
    assert_int_equal(gs_wire_decode(copy, total, v, &why), GS_OK);
    assert_int_equal(v->header.session, h.session);
    assert_int_equal(v->header.sender, h.sender);
    assert_int_equal(v->header.sequence, h.sequence);
    /* f64 on the wire is the IEEE bit pattern: exact */
    assert_true(v->header.send_time == h.send_time);
    assert_true(v->header.echo_time == h.echo_time);
    assert_true(v->header.echo_hold == h.echo_hold);
    assert_int_equal(v->chunk_count, 2);

    assert_int_equal(v->chunks[0].object_id, 42);
    assert_int_equal(v->chunks[0].sequence, 0x89abcdefu);
    assert_true(v->chunks[0].time == c64.time);
    assert_int_equal(v->chunks[0].index, 3);
    assert_int_equal(v->chunks[0].count, 9);
    assert_int_equal(v->chunks[0].first, 417);
    assert_int_equal(v->chunks[0].elements, 7);
    assert_int_equal(v->chunks[0].encoding, GS_ENCODING_F64);
    for (i = 0; i < 7; ++i) {
        double got = gs_wire_value(&v->chunks[0], i);
        assert_memory_equal(&got, &v64[i], sizeof got); /* bit for bit, -0 too */
    }

    assert_int_equal(v->chunks[1].object_id, 0xfffffffeu);
    assert_int_equal(v->chunks[1].sequence, 1);
    assert_true(v->chunks[1].time == 0.0);
    assert_int_equal(v->chunks[1].index, 65534);
    assert_int_equal(v->chunks[1].count, 65535);
    assert_int_equal(v->chunks[1].first, 0xfffffff0u);
    assert_int_equal(v->chunks[1].elements, 6);
    assert_int_equal(v->chunks[1].encoding, GS_ENCODING_F32);
    for (i = 0; i < 6; ++i) {
        double got = gs_wire_value(&v->chunks[1], i);
        /* f32 keeps a 24-bit significand; rounding to nearest errs by at
           most half an ulp: 2^-24 = 5.96e-8 relative. 6e-8 is that bound. */
        assert_true(fabs(got - v32[i]) <= 6e-8 * fabs(v32[i]));
        /* and it is exactly the float the value rounds to */
        assert_true(got == to_f32(v32[i]));
    }
    /* the payload pointers point into the datagram that was decoded: the
       chunks follow each other */
    assert_true(v->chunks[1].payload - v->chunks[0].payload == (ptrdiff_t)(7 * 8 + 27));
    assert_true(v->chunks[0].payload == copy + GS_WIRE_HEADER + 20);
    free(copy);
    free(v);
}

/* A datagram with no chunk at all is refused by its reader; gs_wire_end
   still closes it (the net never sends one). */
static void test_empty_datagram_is_refused(void **state) {
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    gs_wire_header h = header_example();
    size_t size = 0, total;
    (void)state;
    assert_int_equal(gs_wire_begin(buf, sizeof buf, &h, &size), GS_OK);
    total = gs_wire_end(buf, size);
    assert_int_equal(total, GS_WIRE_HEADER + 4);
    expect_reject(buf, total, GS_REJECT_LAYOUT);
}

/* ---- packing and capacity ---- */

static void test_pack_until_full(void **state) {
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    double vals[10];
    gs_wire_header h = header_example();
    gs_wire_view *v = (gs_wire_view *)malloc(sizeof *v);
    gs_reject why;
    unsigned char *copy;
    size_t size = 0, before, total;
    int i, k, added = 0;
    (void)state;
    assert_non_null(v);
    assert_int_equal(gs_wire_begin(buf, sizeof buf, &h, &size), GS_OK);
    /* each chunk: a header of 12 B (kind, id +1, sequence +0, a time of its
       own, elements; the first 14: id 100 and sequence 77 take 2 bytes
       each) + 10 f64 = 92 B; 14 + 80 + 11 * 92 = 1106 <= 1200 - 48 - 4:
       twelve fit, the thirteenth does not */
    for (k = 0; k < 13; ++k) {
        gs_wire_chunk c = chunk_example(100 + (uint32_t)k, GS_ENCODING_F64, 10);
        gs_result r;
        for (i = 0; i < 10; ++i) vals[i] = k * 100.0 + i;
        c.time = 0.5 * k;
        before = size;
        r = gs_wire_add(buf, sizeof buf, &size, &c, vals);
        if (k < 12) {
            assert_int_equal(r, GS_OK);
            added++;
        } else {
            assert_int_equal(r, GS_ERR_CAPACITY);
            assert_int_equal(size, before); /* a refused chunk leaves no trace */
        }
    }
    assert_int_equal(get16(buf + OFF_NCHUNKS), 12);
    total = gs_wire_end(buf, size);
    assert_true(total <= GS_WIRE_MAX_DATAGRAM);
    copy = dup_exact(buf, total);
    assert_int_equal(gs_wire_decode(copy, total, v, &why), GS_OK);
    assert_int_equal(v->chunk_count, added);
    for (k = 0; k < added; ++k) {
        assert_int_equal(v->chunks[k].object_id, 100 + (uint32_t)k);
        assert_true(v->chunks[k].time == 0.5 * k);
        for (i = 0; i < 10; ++i)
            assert_true(gs_wire_value(&v->chunks[k], i) == k * 100.0 + i);
    }
    free(copy);
    free(v);
}

static void test_capacity_limits(void **state) {
    static double vals[300];
    unsigned char big[4096], small[200];
    gs_wire_header h = header_example();
    gs_wire_chunk c;
    size_t size = 0, total;
    int i;
    (void)state;
    for (i = 0; i < 300; ++i) vals[i] = i * 0.5;

    /* the datagram limit holds whatever cap the caller gives: 141 f64 make
       48 + 14 (the chunk's header: kind, id, sequence 77 in 2 bytes, time,
       elements in 2) + 1128 + 4 = 1194 B; 142 would make 1202 B */
    assert_int_equal(gs_wire_begin(big, sizeof big, &h, &size), GS_OK);
    c = chunk_example(1, GS_ENCODING_F64, 142);
    assert_int_equal(gs_wire_add(big, sizeof big, &size, &c, vals), GS_ERR_CAPACITY);
    assert_int_equal(size, GS_WIRE_HEADER);
    c.elements = 141;
    assert_int_equal(gs_wire_add(big, sizeof big, &size, &c, vals), GS_OK);
    assert_int_equal(gs_wire_end(big, size), 1194);

    /* exactly full: 283 f32 make 48 + 16 (a sequence of 2^20: 4 bytes) +
       1132 + 4 = 1200 B */
    assert_int_equal(gs_wire_begin(big, sizeof big, &h, &size), GS_OK);
    c = chunk_example(1, GS_ENCODING_F32, 284);
    c.sequence = 0x100000u;
    assert_int_equal(gs_wire_add(big, sizeof big, &size, &c, vals), GS_ERR_CAPACITY);
    c.elements = 283;
    assert_int_equal(gs_wire_add(big, sizeof big, &size, &c, vals), GS_OK);
    total = gs_wire_end(big, size);
    assert_int_equal(total, GS_WIRE_MAX_DATAGRAM);
    {
        gs_wire_view *v = (gs_wire_view *)malloc(sizeof *v);
        gs_reject why;
        assert_non_null(v);
        assert_int_equal(decode_copy(big, total, v, &why), 1);
        assert_int_equal(v->chunks[0].elements, 283);
        free(v);
    }
    /* a full datagram takes not even an empty chunk */
    c.elements = 0;
    assert_int_equal(gs_wire_add(big, sizeof big, &size, &c, vals), GS_ERR_CAPACITY);

    /* and the caller's cap: 200 B hold 48 + 13 + 4 + 16 f64 (128 B) = 193 */
    assert_int_equal(gs_wire_begin(small, sizeof small, &h, &size), GS_OK);
    c = chunk_example(1, GS_ENCODING_F64, 17);
    assert_int_equal(gs_wire_add(small, sizeof small, &size, &c, vals), GS_ERR_CAPACITY);
    c.elements = 16;
    assert_int_equal(gs_wire_add(small, sizeof small, &size, &c, vals), GS_OK);
    assert_int_equal(size + 4, 193);

    /* a buffer too small for a header and its checksum */
    assert_int_equal(gs_wire_begin(small, GS_WIRE_HEADER + 3, &h, &size), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_wire_begin(small, GS_WIRE_HEADER + 4, &h, &size), GS_OK);
}

static void test_add_refuses_non_finite(void **state) {
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    double vals[3] = {1.0, 2.0, 3.0};
    gs_wire_header h = header_example();
    gs_wire_chunk c = chunk_example(5, GS_ENCODING_F64, 3);
    size_t size = 0;
    (void)state;
    assert_int_equal(gs_wire_begin(buf, sizeof buf, &h, &size), GS_OK);
    vals[1] = NAN;
    assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c, vals), GS_ERR_NOT_FINITE);
    vals[1] = INFINITY;
    assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c, vals), GS_ERR_NOT_FINITE);
    vals[1] = -INFINITY;
    c.encoding = GS_ENCODING_F32;
    assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c, vals), GS_ERR_NOT_FINITE);
    vals[1] = 2.0;
    c.time = NAN;
    assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c, vals), GS_ERR_NOT_FINITE);
    c.time = 1.0;
    c.encoding = GS_ENCODING_DEFAULT; /* the wire names f64 or f32 only */
    assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c, vals), GS_ERR_INVALID_ARG);
    c.encoding = (gs_encoding)7;
    assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c, vals), GS_ERR_INVALID_ARG);
    /* nothing was written by any refused call */
    assert_int_equal(size, GS_WIRE_HEADER);
    assert_int_equal(get16(buf + OFF_NCHUNKS), 0);
}

/* A value finite as a double but beyond float's range (3.4e38) becomes
   infinity in f32. gs_wire_add must not write it: the reader would refuse
   the whole datagram (GS_REJECT_NOT_FINITE) and every other chunk in it
   would be lost with it. */
static void test_add_refuses_f32_overflow(void **state) {
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    double vals[2] = {1.0, 1e39};
    gs_wire_header h = header_example();
    gs_wire_chunk c = chunk_example(5, GS_ENCODING_F32, 2);
    size_t size = 0;
    (void)state;
    assert_int_equal(gs_wire_begin(buf, sizeof buf, &h, &size), GS_OK);
    assert_int_not_equal(gs_wire_add(buf, sizeof buf, &size, &c, vals), GS_OK);
    assert_int_equal(size, GS_WIRE_HEADER);
    /* the largest float is fine */
    vals[1] = (double)FLT_MAX;
    assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c, vals), GS_OK);
}

/* ---- every reason to refuse ---- */

static void test_reject_short(void **state) {
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    size_t n = valid_datagram(buf, sizeof buf), k;
    gs_wire_view *v = (gs_wire_view *)malloc(sizeof *v);
    gs_reject why = GS_REJECT_COUNT;
    (void)state;
    assert_non_null(v);
    for (k = 0; k < GS_WIRE_HEADER + 4; ++k) expect_reject(buf, k, GS_REJECT_SHORT);
    assert_int_equal(gs_wire_decode(NULL, n, v, &why), GS_ERR_INVALID_ARG);
    assert_int_equal(why, GS_REJECT_SHORT);
    /* why may be NULL */
    assert_int_equal(gs_wire_decode(buf, 3, v, NULL), GS_ERR_REJECTED);
    /* the whole valid datagram decodes */
    assert_int_equal(decode_copy(buf, n, v, &why), 1);
    free(v);
}

static void test_reject_too_long(void **state) {
    unsigned char buf[GS_WIRE_MAX_DATAGRAM + 8];
    size_t n = valid_datagram(buf, sizeof buf);
    (void)state;
    /* a datagram past the documented maximum, otherwise well formed: the
       chunk's payload stays the same and 8 bytes of junk follow it */
    memset(buf + n - 4, 0, GS_WIRE_MAX_DATAGRAM + 8 - n);
    recrc(buf, GS_WIRE_MAX_DATAGRAM + 1);
    expect_reject(buf, GS_WIRE_MAX_DATAGRAM + 1, GS_REJECT_LAYOUT);
}

static void test_reject_magic_version(void **state) {
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    size_t n = valid_datagram(buf, sizeof buf);
    (void)state;
    buf[OFF_MAGIC + 3] = 'N';
    recrc(buf, n); /* only the magic is wrong */
    expect_reject(buf, n, GS_REJECT_MAGIC);
    n = valid_datagram(buf, sizeof buf);
    buf[OFF_VERSION] = GS_WIRE_VERSION + 1;
    recrc(buf, n);
    expect_reject(buf, n, GS_REJECT_VERSION);
    buf[OFF_VERSION] = 0;
    recrc(buf, n);
    expect_reject(buf, n, GS_REJECT_VERSION);
}

/* Every single corrupted byte is caught (CRC-32 detects every burst of up
   to 32 bits); the magic and version bytes are caught by their own check. */
static void test_reject_every_corrupted_byte(void **state) {
    static const unsigned char flips[4] = {0x01, 0x80, 0xff, 0x5a};
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    gs_wire_view *v = (gs_wire_view *)malloc(sizeof *v);
    size_t n, i;
    int f;
    (void)state;
    assert_non_null(v);
    n = valid_datagram(buf, sizeof buf);
    for (f = 0; f < 4; ++f)
        for (i = 0; i < n; ++i) {
            gs_reject why = GS_REJECT_COUNT;
            /* version 3 ^ 0x01 is 2: an old version */
            gs_reject expect = i < 4 ? GS_REJECT_MAGIC
                               : i == OFF_VERSION ? (flips[f] == 0x01 ? GS_REJECT_OLD_VERSION
                                                                      : GS_REJECT_VERSION)
                                                  : GS_REJECT_CHECKSUM;
            buf[i] ^= flips[f];
            if (decode_copy(buf, n, v, &why) != 0 || why != expect)
                print_error("byte %lu ^ 0x%02x: decoded or wrong reason %s\n",
                            (unsigned long)i, flips[f], gs_reject_str(why));
            assert_int_equal(decode_copy(buf, n, v, &why), 0);
            assert_int_equal(why, expect);
            buf[i] ^= flips[f];
        }
    free(v);
}

/* The sender's sync in the header's flags (>>wire): bits 1 and 2 as the
   header says, read back as written; bits it does not name are not
   written, and a datagram that has one (or the sealed bit, in clear) is
   refused. */
static void test_header_sync_flags(void **state) {
    static const double vals[1] = {0.5};
    static const unsigned modes[4] = {0, GS_WIRE_FLAG_SESSION, GS_WIRE_FLAG_REPLAY,
                                      GS_WIRE_FLAG_SESSION | GS_WIRE_FLAG_REPLAY};
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    gs_wire_view *v = (gs_wire_view *)malloc(sizeof *v);
    gs_wire_header h = header_example();
    gs_wire_chunk c = chunk_example(42, GS_ENCODING_F64, 1);
    gs_reject why;
    size_t size = 0, n;
    int i;
    (void)state;
    assert_non_null(v);
    for (i = 0; i < 4; ++i) {
        h.sync = modes[i];
        assert_int_equal(gs_wire_begin(buf, sizeof buf, &h, &size), GS_OK);
        assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c, vals), GS_OK);
        n = gs_wire_end(buf, size);
        assert_int_equal(buf[OFF_FLAGS], modes[i]);
        assert_int_equal(decode_copy(buf, n, v, &why), 1);
        assert_int_equal(v->header.sync, modes[i]);
    }
    h.sync = 0xffu; /* only what GS_WIRE_FLAG_SYNC names goes out */
    assert_int_equal(gs_wire_begin(buf, sizeof buf, &h, &size), GS_OK);
    assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c, vals), GS_OK);
    n = gs_wire_end(buf, size);
    assert_int_equal(buf[OFF_FLAGS], GS_WIRE_FLAG_SYNC);
    buf[OFF_FLAGS] = 0x08;
    recrc(buf, n);
    expect_reject(buf, n, GS_REJECT_LAYOUT);
    buf[OFF_FLAGS] = GS_WIRE_FLAG_SEALED | GS_WIRE_FLAG_REPLAY;
    recrc(buf, n);
    expect_reject(buf, n, GS_REJECT_LAYOUT);
    free(v);
}

static void test_reject_chunk_count(void **state) {
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    size_t n = valid_datagram(buf, sizeof buf);
    (void)state;
    put16(buf + OFF_NCHUNKS, 0);
    recrc(buf, n);
    expect_reject(buf, n, GS_REJECT_LAYOUT);
    put16(buf + OFF_NCHUNKS, GS_WIRE_MAX_CHUNKS + 1);
    recrc(buf, n);
    expect_reject(buf, n, GS_REJECT_LAYOUT);
    put16(buf + OFF_NCHUNKS, 0xffff);
    recrc(buf, n);
    expect_reject(buf, n, GS_REJECT_LAYOUT);
    /* two announced, one present: the second runs off the end */
    put16(buf + OFF_NCHUNKS, 2);
    recrc(buf, n);
    expect_reject(buf, n, GS_REJECT_SHORT);
}

static void test_reject_encoding(void **state) {
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    size_t n;
    int k;
    (void)state;
    for (k = 0; k < 4; ++k) {
        unsigned char *kind = buf + GS_WIRE_HEADER + C_KIND;
        n = valid_datagram(buf, sizeof buf);
        if (k == 0) *kind &= (unsigned char)~0x18u;             /* encoding 0 */
        if (k == 1) *kind |= 0x40;                              /* reserved bits */
        if (k == 2) *kind |= 0x80;
        if (k == 3) *kind = (unsigned char)((*kind & ~3u) | 1); /* a delta in f64 */
        recrc(buf, n);
        expect_reject(buf, n, GS_REJECT_LAYOUT);
    }
    /* a valid encoding, but the other one: 4 f64 read as f32 use 16 of the
       32 payload bytes; the 16 left over make the lengths disagree */
    n = valid_datagram(buf, sizeof buf);
    buf[GS_WIRE_HEADER + C_KIND] =
        (unsigned char)((buf[GS_WIRE_HEADER + C_KIND] & ~0x18u) | GS_ENCODING_F32 << 3);
    recrc(buf, n);
    expect_reject(buf, n, GS_REJECT_LAYOUT);
}

/* valid_datagram's chunk split (kind bit 0x20): index, count and first as
   the varints given (bytes, their lengths), then its elements and values. */
static size_t split_datagram(unsigned char *buf, const unsigned char *split, size_t len) {
    unsigned char tmp[GS_WIRE_MAX_DATAGRAM];
    size_t n = valid_datagram(tmp, sizeof tmp), at = GS_WIRE_HEADER + V_ELEMENTS;
    memcpy(buf, tmp, at);
    buf[GS_WIRE_HEADER + C_KIND] |= 0x20;
    memcpy(buf + at, split, len);
    memcpy(buf + at + len, tmp + at, n - at);
    recrc(buf, n + len);
    return n + len;
}

static void test_reject_chunk_index(void **state) {
    static const unsigned char ok[] = {2, 9, 0}, one[] = {1, 1, 0}, high[] = {0xff, 0xff, 3,
                                      0xff, 0xff, 3, 0}, none[] = {0, 0, 0}, plain[] = {0, 1, 0},
                                      wide[] = {0, 0x80, 0x80, 4, 0};
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    gs_wire_view *v = (gs_wire_view *)malloc(sizeof *v);
    gs_reject why;
    size_t n;
    (void)state;
    assert_non_null(v);
    n = split_datagram(buf, ok, sizeof ok); /* index 2 of 9: taken */
    assert_int_equal(decode_copy(buf, n, v, &why), 1);
    assert_int_equal(v->chunks[0].index, 2);
    assert_int_equal(v->chunks[0].count, 9);
    free(v);
    n = split_datagram(buf, one, sizeof one); /* index 1 of count 1 */
    expect_reject(buf, n, GS_REJECT_LAYOUT);
    n = split_datagram(buf, high, sizeof high); /* index 65535 of 65535 */
    expect_reject(buf, n, GS_REJECT_LAYOUT);
    n = split_datagram(buf, none, sizeof none); /* a snapshot of no chunks */
    expect_reject(buf, n, GS_REJECT_LAYOUT);
    n = split_datagram(buf, plain, sizeof plain); /* 0 of 1 from 0: not split */
    expect_reject(buf, n, GS_REJECT_LAYOUT);
    n = split_datagram(buf, wide, sizeof wide); /* a count of 65536 */
    expect_reject(buf, n, GS_REJECT_LAYOUT);
}

static void test_reject_lengths(void **state) {
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    size_t n = valid_datagram(buf, sizeof buf), k;
    (void)state;
    /* truncated: the last value loses 1..8 bytes, checksum redone */
    for (k = 1; k <= 8; ++k) {
        n = valid_datagram(buf, sizeof buf);
        memmove(buf + n - 4 - k, buf + n - 4, 4);
        recrc(buf, n - k);
        expect_reject(buf, n - k, GS_REJECT_SHORT);
    }
    /* extended: 1..8 bytes of junk after the last chunk */
    for (k = 1; k <= 8; ++k) {
        n = valid_datagram(buf, sizeof buf);
        memset(buf + n - 4, 0x11, k);
        recrc(buf, n + k);
        expect_reject(buf, n + k, GS_REJECT_LAYOUT);
    }
    /* the element count says more than there is, then less */
    n = valid_datagram(buf, sizeof buf);
    buf[GS_WIRE_HEADER + V_ELEMENTS] = 5;
    recrc(buf, n);
    expect_reject(buf, n, GS_REJECT_SHORT);
    buf[GS_WIRE_HEADER + V_ELEMENTS] = 127;
    recrc(buf, n);
    expect_reject(buf, n, GS_REJECT_SHORT);
    buf[GS_WIRE_HEADER + V_ELEMENTS] = 3;
    recrc(buf, n);
    expect_reject(buf, n, GS_REJECT_LAYOUT);
    /* a chunk header cut in the middle of its time, and of a varint */
    for (k = 6; k <= 8; k += 2) {
        n = valid_datagram(buf, sizeof buf);
        if (k == 8) buf[GS_WIRE_HEADER + 1] |= 0x80; /* the id goes on */
        memmove(buf + GS_WIRE_HEADER + (k == 8 ? 2 : k), buf + n - 4, 4);
        recrc(buf, GS_WIRE_HEADER + (k == 8 ? 2 : k));
        expect_reject(buf, GS_WIRE_HEADER + (k == 8 ? 2 : k), GS_REJECT_SHORT);
    }
}

/* Non-finite values, written by hand (gs_wire_add would refuse them) and
   re-checksummed so that the value is the only thing wrong. */
static void test_reject_not_finite_value(void **state) {
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    const size_t pay = GS_WIRE_HEADER + V_PAY; /* the f32 chunk's too: id 9 is 1 byte */
    size_t n;
    int k;
    (void)state;
    for (k = 0; k < 4; ++k) { /* each of the 4 values in turn */
        n = valid_datagram(buf, sizeof buf);
        putf64(buf + pay + 8 * (size_t)k, k % 2 ? INFINITY : NAN);
        recrc(buf, n);
        expect_reject(buf, n, GS_REJECT_NOT_FINITE);
    }
    /* an f32 chunk holding a NaN float */
    {
        static const double vals[3] = {1.0, 2.0, 3.0};
        gs_wire_header h = header_example();
        gs_wire_chunk c = chunk_example(9, GS_ENCODING_F32, 3);
        size_t size = 0;
        assert_int_equal(gs_wire_begin(buf, sizeof buf, &h, &size), GS_OK);
        assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c, vals), GS_OK);
        n = gs_wire_end(buf, size);
        putf32(buf + pay + 4, (float)NAN);
        recrc(buf, n);
        expect_reject(buf, n, GS_REJECT_NOT_FINITE);
        putf32(buf + pay + 4, -(float)INFINITY);
        recrc(buf, n);
        expect_reject(buf, n, GS_REJECT_NOT_FINITE);
    }
    /* and in the header's clock fields */
    n = valid_datagram(buf, sizeof buf);
    putf64(buf + OFF_SEND_TIME, NAN);
    recrc(buf, n);
    expect_reject(buf, n, GS_REJECT_NOT_FINITE);
    n = valid_datagram(buf, sizeof buf);
    putf64(buf + OFF_ECHO_HOLD, INFINITY);
    recrc(buf, n);
    expect_reject(buf, n, GS_REJECT_NOT_FINITE);
}

static void test_reject_time(void **state) {
    static const double bad[7] = {-1e-300, -1.0, -INFINITY, INFINITY, 1e308,
                                  GS_WIRE_MAX_TIME * (1.0 + 1e-15), 0.0 /* NaN below */};
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    size_t n;
    int k;
    (void)state;
    for (k = 0; k < 7; ++k) {
        n = valid_datagram(buf, sizeof buf);
        putf64(buf + GS_WIRE_HEADER + V_TIME, k < 6 ? bad[k] : NAN);
        recrc(buf, n);
        expect_reject(buf, n, GS_REJECT_TIME);
    }
    /* the encoder does not make what the decoder refuses */
    {
        gs_wire_header h;
        gs_wire_chunk c;
        double v = 1.0;
        size_t size;
        memset(&h, 0, sizeof h);
        memset(&c, 0, sizeof c);
        c.count = 1;
        c.elements = 1;
        c.encoding = GS_ENCODING_F64;
        c.time = 1e308;
        assert_int_equal(gs_wire_begin(buf, sizeof buf, &h, &size), GS_OK);
        assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c, &v), GS_ERR_INVALID_ARG);
        c.time = GS_WIRE_MAX_TIME;
        assert_int_equal(gs_wire_add(buf, sizeof buf, &size, &c, &v), GS_OK);
    }
    /* -0.0 is not negative */
    {
        gs_wire_view *v = (gs_wire_view *)malloc(sizeof *v);
        gs_reject why;
        assert_non_null(v);
        n = valid_datagram(buf, sizeof buf);
        putf64(buf + GS_WIRE_HEADER + V_TIME, -0.0);
        recrc(buf, n);
        assert_int_equal(decode_copy(buf, n, v, &why), 1);
        free(v);
    }
}

static void test_reject_strings(void **state) {
    int r, s;
    (void)state;
    for (r = 0; r < GS_REJECT_COUNT; ++r) {
        const char *t = gs_reject_str((gs_reject)r);
        assert_non_null(t);
        assert_true(strlen(t) > 0);
        for (s = 0; s < r; ++s) /* each reason says something different */
            assert_string_not_equal(t, gs_reject_str((gs_reject)s));
    }
    assert_non_null(gs_reject_str(GS_REJECT_COUNT));
    assert_non_null(gs_reject_str((gs_reject)-1));
    assert_true(strlen(gs_reject_str((gs_reject)1000)) > 0);
}

/* ---- garbage ---- */

static uint32_t lcg_state;
static uint32_t lcg(void) {
    lcg_state = lcg_state * 1664525u + 1013904223u;
    return lcg_state >> 8; /* the low bits of an LCG are poor */
}

/* A decoded datagram must be consistent with the bytes it came from. */
static void check_decoded(const unsigned char *buf, size_t n, const gs_wire_view *v) {
    int k, i;
    assert_true(n >= GS_WIRE_HEADER + 4 && n <= GS_WIRE_MAX_DATAGRAM);
    assert_true(v->chunk_count >= 1 && v->chunk_count <= GS_WIRE_MAX_CHUNKS);
    for (k = 0; k < v->chunk_count; ++k) {
        const gs_wire_chunk *c = &v->chunks[k];
        size_t vs = c->encoding == GS_ENCODING_F32 ? 4 : 8;
        assert_true(c->encoding == GS_ENCODING_F32 || c->encoding == GS_ENCODING_F64);
        assert_true(c->index < c->count);
        assert_true(c->time >= 0.0 && isfinite(c->time));
        assert_true(c->payload >= buf + GS_WIRE_HEADER + 4); /* the least header */
        assert_true(c->payload + vs * c->elements <= buf + n - 4);
        for (i = 0; i < c->elements; ++i) assert_true(isfinite(gs_wire_value(c, i)));
    }
}

/* 10000 random buffers of 0..1300 bytes in three families: pure noise; a
   valid magic and version then noise; the same with a correct checksum
   (so that the chunk parser sees the noise). Decoding never crashes; the
   first two families never decode (a random CRC matches once in 2^32);
   the third almost never does, and whatever decodes is self-consistent. */
/* The CRC-32 that gs_wire_end writes (the header's sliced-by-8 tables):
   the published check values of CRC-32/ISO-HDLC (zlib's crc32), then
   random bytes of every length from 0 to past a datagram at every
   alignment of the start, against this file's bitwise CRC. Each buffer
   is a malloc of exactly its size, so a read past the end trips ASan. */
static uint32_t crc_of(const unsigned char *p, size_t n, size_t align) {
    unsigned char *buf = (unsigned char *)malloc(align + n + 4);
    uint32_t c;
    assert_non_null(buf);
    if (n) memcpy(buf + align, p, n);
    assert_int_equal(gs_wire_end(buf + align, n), n + 4);
    c = (uint32_t)buf[align + n] | (uint32_t)buf[align + n + 1] << 8 |
        (uint32_t)buf[align + n + 2] << 16 | (uint32_t)buf[align + n + 3] << 24;
    free(buf);
    return c;
}

static void test_crc32_known_values(void **state) {
    static const struct { const char *text; uint32_t crc; } known[] = {
        {"", 0x00000000u},
        {"a", 0xe8b7be43u},
        {"abc", 0x352441c2u},
        {"123456789", 0xcbf43926u},
        {"The quick brown fox jumps over the lazy dog", 0x414fa339u},
    };
    unsigned char buf[GS_WIRE_MAX_DATAGRAM + 100];
    size_t i, n, align;
    (void)state;
    for (i = 0; i < sizeof known / sizeof known[0]; ++i)
        for (align = 0; align < 8; ++align)
            assert_int_equal(crc_of((const unsigned char *)known[i].text,
                                    strlen(known[i].text), align), known[i].crc);
    lcg_state = 4242u;
    for (n = 0; n < sizeof buf; ++n) {
        for (i = 0; i < n; ++i) buf[i] = (unsigned char)lcg();
        align = n % 8;
        assert_int_equal(crc_of(buf, n, align), crc32_ref(buf, n));
    }
    memset(buf, 0xff, sizeof buf); /* every table entry's high byte path */
    for (n = 0; n < 64; ++n)
        for (align = 0; align < 8; ++align)
            assert_int_equal(crc_of(buf, n, align), crc32_ref(buf, n));
}

static void test_random_garbage(void **state) {
    gs_wire_view *v = (gs_wire_view *)malloc(sizeof *v);
    int k, decoded[3] = {0, 0, 0}, tries[3] = {0, 0, 0};
    (void)state;
    assert_non_null(v);
    lcg_state = 12345u;
    for (k = 0; k < 10000; ++k) {
        size_t n = lcg() % 1301, i;
        int fam = k % 3;
        unsigned char *buf = (unsigned char *)malloc(n ? n : 1);
        gs_reject why = GS_REJECT_COUNT;
        assert_non_null(buf);
        for (i = 0; i < n; ++i) buf[i] = (unsigned char)lcg();
        if (fam >= 1 && n >= 8) {
            memcpy(buf, "GSIM", 4);
            buf[OFF_VERSION] = GS_WIRE_VERSION;
            /* a plausible chunk count so that the parser goes further */
            if (n >= GS_WIRE_HEADER + 4) put16(buf + OFF_NCHUNKS, (uint16_t)(1 + lcg() % 4));
        }
        if (fam == 2 && n >= GS_WIRE_HEADER + 4) recrc(buf, n);
        tries[fam]++;
        if (gs_wire_decode(buf, n, v, &why) == GS_OK) {
            decoded[fam]++;
            check_decoded(buf, n, v);
        } else {
            assert_true((int)why >= 0 && why < GS_REJECT_COUNT);
        }
        free(buf);
    }
    print_message("garbage: decoded %d/%d noise, %d/%d magic, %d/%d magic+crc\n",
                  decoded[0], tries[0], decoded[1], tries[1], decoded[2], tries[2]);
    assert_int_equal(decoded[0], 0);
    assert_int_equal(decoded[1], 0);
    assert_true(decoded[2] <= tries[2] / 100); /* "nearly always fails" */
    free(v);
}

/* Structured garbage: a valid datagram of several chunks with random bytes
   overwritten and the checksum redone, 5000 times. Never crashes; any
   datagram that still decodes is self-consistent. */
static void test_mutated_datagrams(void **state) {
    unsigned char base[GS_WIRE_MAX_DATAGRAM];
    gs_wire_view *v = (gs_wire_view *)malloc(sizeof *v);
    gs_wire_header h = header_example();
    double vals[20];
    size_t size = 0, n;
    int k, i, ok = 0;
    (void)state;
    assert_non_null(v);
    for (i = 0; i < 20; ++i) vals[i] = i - 7.5;
    assert_int_equal(gs_wire_begin(base, sizeof base, &h, &size), GS_OK);
    for (k = 0; k < 4; ++k) {
        gs_wire_chunk c = chunk_example(10 + (uint32_t)k, k % 2 ? GS_ENCODING_F32 : GS_ENCODING_F64,
                                        (uint16_t)(5 * k));
        assert_int_equal(gs_wire_add(base, sizeof base, &size, &c, vals), GS_OK);
    }
    n = gs_wire_end(base, size);
    lcg_state = 777u;
    for (k = 0; k < 5000; ++k) {
        unsigned char *buf = (unsigned char *)malloc(n);
        int m, edits = 1 + (int)(lcg() % 4);
        gs_reject why;
        assert_non_null(buf);
        memcpy(buf, base, n);
        for (m = 0; m < edits; ++m) /* anywhere after the magic and version */
            buf[5 + lcg() % (n - 9)] = (unsigned char)lcg();
        recrc(buf, n);
        if (gs_wire_decode(buf, n, v, &why) == GS_OK) {
            ok++;
            check_decoded(buf, n, v);
        }
        free(buf);
    }
    print_message("mutated: %d of 5000 still decode (edits in values or ids)\n", ok);
    free(v);
}

int main(int argc, char **argv) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_roundtrip_fields),
        cmocka_unit_test(test_empty_datagram_is_refused),
        cmocka_unit_test(test_pack_until_full),
        cmocka_unit_test(test_capacity_limits),
        cmocka_unit_test(test_add_refuses_non_finite),
        cmocka_unit_test(test_add_refuses_f32_overflow),
        cmocka_unit_test(test_reject_short),
        cmocka_unit_test(test_reject_too_long),
        cmocka_unit_test(test_reject_magic_version),
        cmocka_unit_test(test_reject_every_corrupted_byte),
        cmocka_unit_test(test_header_sync_flags),
        cmocka_unit_test(test_reject_chunk_count),
        cmocka_unit_test(test_reject_encoding),
        cmocka_unit_test(test_reject_chunk_index),
        cmocka_unit_test(test_reject_lengths),
        cmocka_unit_test(test_reject_not_finite_value),
        cmocka_unit_test(test_reject_time),
        cmocka_unit_test(test_reject_strings),
        cmocka_unit_test(test_crc32_known_values),
        cmocka_unit_test(test_random_garbage),
        cmocka_unit_test(test_mutated_datagrams),
    };
    if (argc > 1) cmocka_set_test_filter(argv[1]); /* e.g. "test_reject_*" */
    return cmocka_run_group_tests_name("wire", tests, NULL, NULL);
}
