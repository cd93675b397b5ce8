/* test_codecspeed.c - the delta codec's fast paths against their
   definitions, bit for bit, on random inputs at their ranges' edges.

   What must hold: the Rice writer (a value's unary run, its 1 and its low
   bits put as one code when they fit in 32 bits, else in two) writes the
   bits >>wire defines, for every k from 0 to 24, values whose codes take
   up to and past 32 bits, and escapes at +-2^31; the reader gives the
   differences back (gs_wire_deltas, and gs_wire_value one at a time) and
   the parse takes the run's length from its own bit count; gs__qk_diff
   (integers, differences, their range and bit-length histogram in one pass) agrees
   with gs__qk_make and the differences taken one by one, and refuses as
   they do at +-(2^31 - 1) and at the decoder's 2^51 - 2^32. The reference
   writer here is the definition, bit by bit. No tolerance: integers and
   bytes are compared exactly. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define GHOSTSIM_STATIC
#define GHOSTSIM_IMPLEMENTATION /* gs__qk_diff and gs__qk_make */
#include "ghostsim.h"
#include "wire_helpers.h"

static uint64_t rng_next(uint64_t *s) {
    *s ^= *s << 13;
    *s ^= *s >> 7;
    *s ^= *s << 17;
    return *s;
}

/* A difference of about `bits` (1 to 31) bits, either sign, now and then
   at the edges of the 32-bit range. */
static int64_t rnd_diff(uint64_t *s, int bits) {
    uint64_t r = rng_next(s);
    int64_t v;
    switch (r % 16) {
    case 0: return -2147483648LL;
    case 1: return 2147483647LL;
    case 2: return 0;
    default: break;
    }
    v = (int64_t)(rng_next(s) & (((uint64_t)1 << bits) - 1));
    /* now and then 8 to 15 times more: with k about bits, q of 8 to 15,
       codes of past 32 bits once k is 17 or more */
    if (r % 16 == 3) v = (v | (int64_t)1 << (bits - 1)) * (int64_t)(8 + (r >> 8) % 8);
    if (v > 2147483647LL) v = 2147483647LL;
    return r & 16 ? -v : v;
}

/* A bit writer by the definition: one bit at a time, from the least
   significant bit of the first byte on. */
typedef struct refw {
    unsigned char *p;
    size_t bit;
} refw;
static void ref_put(refw *w, uint64_t v, int bits) {
    int i;
    for (i = 0; i < bits; ++i, ++w->bit)
        if (v >> i & 1) w->p[w->bit >> 3] = (unsigned char)(w->p[w->bit >> 3] | 1u << (w->bit & 7));
}
/* >>wire's coding 2: q = z >> k; q < 16: q 0s, a 1, z's k low bits; else
   16 0s and z in 32 bits. Its length in bytes. */
static size_t ref_rice(unsigned char *p, const int64_t *d, int n, int k) {
    refw w;
    int i;
    memset(p, 0, GS_WIRE_MAX_DATAGRAM);
    w.p = p;
    w.bit = 0;
    for (i = 0; i < n; ++i) {
        uint64_t z = ((uint64_t)d[i] << 1) ^ (uint64_t)(d[i] >> 63), q = z >> k;
        if (q < 16) {
            ref_put(&w, 0, (int)q);
            ref_put(&w, 1, 1);
            ref_put(&w, z, k);
        } else {
            ref_put(&w, 0, 16);
            ref_put(&w, z, 32);
        }
    }
    return (w.bit + 7) / 8;
}

/* Random runs at every k (the encoder picks k; marked predicted, the
   chunk always goes in Rice) come out as the definition writes them, and
   back as they went in. */
static void test_rice_bits(void **state) {
    static unsigned char buf[GS_WIRE_MAX_DATAGRAM], ref[GS_WIRE_MAX_DATAGRAM];
    static gs_wire_view v;
    uint64_t s = 0x9e3779b97f4a7c15ull;
    int64_t d[GS_WIRE_QUANT_CHUNK], out[GS_WIRE_QUANT_CHUNK];
    int trial, seen_k[GS__RICE_MAX_K + 1] = {0}, long_codes = 0, escapes = 0;
    gs_wire_header h;
    (void)state;
    memset(&h, 0, sizeof h);
    h.session = 1;
    h.sender = 1;
    h.sequence = 1;
    for (trial = 0; trial < 3000; ++trial) {
        gs_wire_chunk c;
        const gs_wire_chunk *r;
        const unsigned char *q;
        int n = 1 + (int)(rng_next(&s) % GS_WIRE_QUANT_CHUNK), bits = (int)(rng_next(&s) % 32);
        int i, k;
        uint64_t dist = 0;
        size_t len;
        /* the widths that fit a datagram's room in Rice (escapes take 48
           bits): short chunks for the wide ones */
        if (bits > 20 && n > 120) n = 120;
        for (i = 0; i < n; ++i) d[i] = rnd_diff(&s, bits < 1 ? 1 : bits);
        memset(&c, 0, sizeof c);
        c.object_id = 7;
        c.sequence = 100 + (uint32_t)trial;
        c.baseline = c.sequence - 1 - (uint32_t)(rng_next(&s) % 16);
        c.time = 1.0;
        c.count = 1;
        c.elements = (uint16_t)n;
        c.encoding = GS_ENCODING_QUANT;
        c.flags = GS_WIRE_CHUNK_DELTA | GS_WIRE_CHUNK_PREDICT;
        delta_round_trip(buf, &h, &c, d, &v);
        r = &v.chunks[0];
        assert_true(r->flags & GS_WIRE_CHUNK_PREDICT);
        assert_int_equal(r->delta_coding, 2);
        k = r->delta_width;
        seen_k[k] = 1;
        q = r->payload;
        assert_true(gs__varint_get(&q, r->payload + r->payload_bytes, 5, &dist));
        assert_int_equal(dist, c.sequence - c.baseline);
        assert_int_equal(*q, k | 0x20 | 2 << 6);
        ++q;
        len = ref_rice(ref, d, n, k);
        /* the parse's length is the run's, to the byte */
        assert_int_equal((size_t)(r->payload + r->payload_bytes - q), len);
        assert_memory_equal(q, ref, len);
        for (i = 0; i < n; ++i) {
            uint64_t z = ((uint64_t)d[i] << 1) ^ (uint64_t)(d[i] >> 63);
            if (z >> k >= 16) ++escapes;
            else if ((int)(z >> k) + 1 + k > 32) ++long_codes;
        }
        gs_wire_deltas(r, out);
        assert_memory_equal(out, d, (size_t)n * sizeof *d);
        i = (int)(rng_next(&s) % (uint64_t)n);
        assert_true(gs_wire_value(r, i) == (double)d[i]);
    }
    /* the inputs reached what they are for */
    for (trial = 0; trial <= 20; ++trial) assert_true(seen_k[trial]);
    assert_true(escapes > 100);
    assert_true(long_codes > 100);
}

/* gs__qk_diff against gs__qk_make and the differences one by one, on
   scalars near the decoder's range and differences near +-(2^31 - 1),
   with a quaternion segment between. */
static void test_qk_diff(void **state) {
    uint64_t s = 12345;
    int trial, refused = 0, taken = 0;
    (void)state;
    for (trial = 0; trial < 4000; ++trial) {
        gs_wire_segment seg[3], seg2[3];
        double v[40];
        int64_t bk[40], k1[40], k2[40], d[40], ref_d[40];
        long bits = -1, ref_bits = 0;
        gs__dstat st;
        int i, ok1, ok2, n = 40, edge = (int)(rng_next(&s) % 4);
        double step = 5e-5;
        memset(seg, 0, sizeof seg);
        seg[0].kind = GS_WIRE_SCALAR;
        seg[0].count = 16;
        seg[0].step = step;
        seg[1].kind = GS_WIRE_QUATERNION;
        seg[1].count = 8;
        seg[1].bits = 16;
        seg[2].kind = GS_WIRE_SCALAR;
        seg[2].count = 16;
        seg[2].step = 1e-3;
        for (i = 0; i < n; ++i) {
            double st = i < 16 ? step : 1e-3;
            int64_t base = (int64_t)(rng_next(&s) % 2000000) - 1000000;
            int64_t dd = (int64_t)(rng_next(&s) % 64) - 32;
            if (edge == 1 && rng_next(&s) % 8 == 0) /* at +-(2^31 - 1), one past */
                dd = (rng_next(&s) & 1 ? 1 : -1) * (2147483647LL + (int64_t)(rng_next(&s) % 2));
            if (edge == 2 && rng_next(&s) % 8 == 0) /* near 2^51 - 2^32 steps */
                base = (rng_next(&s) & 1 ? 1 : -1) *
                       (GS__QK_MAX - 2 + (int64_t)(rng_next(&s) % 4));
            bk[i] = base;
            v[i] = (double)(base + dd) * st;
        }
        for (i = 16; i < 24; i += 4) { /* a rotation, and the baseline's integers of it */
            double a = (double)(rng_next(&s) % 1000) * 1e-3, nn;
            v[i] = sin(a); v[i + 1] = 0.3; v[i + 2] = -0.2; v[i + 3] = cos(a);
            nn = sqrt(v[i] * v[i] + 0.13 + v[i + 3] * v[i + 3]);
            v[i] /= nn; v[i + 1] /= nn; v[i + 2] /= nn; v[i + 3] /= nn;
            bk[i] = 3; bk[i + 1] = 30000; bk[i + 2] = 40000; bk[i + 3] = 20000;
        }
        memcpy(seg2, seg, sizeof seg);
        ok1 = gs__qk_diff(seg, 3, v, k1, bk, d, &st, NULL);
        ok2 = gs__qk_make(seg2, 3, v, k2, 0);
        for (i = 0; i < n && ok2; ++i) {
            uint64_t z;
            ref_d[i] = k2[i] - bk[i];
            ok2 = ref_d[i] >= -2147483647LL && ref_d[i] <= 2147483647LL;
            z = ((uint64_t)ref_d[i] << 1) ^ (uint64_t)(ref_d[i] >> 63);
            while (z) { ++ref_bits; z >>= 1; }
        }
        assert_int_equal(ok1, ok2);
        if (!ok1) { ++refused; continue; }
        ++taken;
        assert_memory_equal(k1, k2, sizeof k1);
        assert_memory_equal(d, ref_d, sizeof d);
        bits = gs__hist_bits(st.hist);
        assert_int_equal(bits, ref_bits);
    }
    assert_true(refused > 100);
    assert_true(taken > 1000);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rice_bits),
        cmocka_unit_test(test_qk_diff),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
