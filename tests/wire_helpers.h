/* wire_helpers.h - the tests' hand-built datagrams: a CRC-32 of their own,
   to make a changed datagram's checksum good again, and a one-snapshot
   datagram, a delta chunk's round trip, a decode of an exact-size copy.
   Include after cmocka.h and ghostsim.h. */
#ifndef GS_TEST_WIRE_HELPERS_H
#define GS_TEST_WIRE_HELPERS_H

#include <stdlib.h>
#include <string.h>

#include "helpers.h"

/* CRC-32 (IEEE 802.3, reflected polynomial 0xEDB88320), bit by bit: an
   implementation independent of the header's table. */
static GS_TEST_UNUSED uint32_t crc32_ref(const unsigned char *p, size_t n) {
    uint32_t c = 0xffffffffu;
    size_t i;
    int k;
    for (i = 0; i < n; ++i) {
        c ^= p[i];
        for (k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
    }
    return c ^ 0xffffffffu;
}

/* The checksum of an n-byte datagram made good again (little-endian, in
   its last four bytes). */
static GS_TEST_UNUSED void recrc(unsigned char *buf, size_t n) {
    uint32_t c = crc32_ref(buf, n - 4);
    buf[n - 4] = (unsigned char)c;
    buf[n - 3] = (unsigned char)(c >> 8);
    buf[n - 2] = (unsigned char)(c >> 16);
    buf[n - 1] = (unsigned char)(c >> 24);
}

/* A datagram from `sender` (session 1) carrying one f64 snapshot of object
   `object`: two values at simulation time t. Returns its size. */
static GS_TEST_UNUSED size_t snapshot_datagram(unsigned char *buf, uint32_t sender, uint32_t seq,
                                               uint32_t object, double t) {
    gs_wire_header h;
    gs_wire_chunk c;
    double vals[2] = {0.5, -0.25};
    size_t size;
    memset(&h, 0, sizeof h);
    h.session = 1;
    h.sender = sender;
    h.sequence = seq;
    h.send_time = 1.0;
    memset(&c, 0, sizeof c);
    c.object_id = object;
    c.sequence = seq;
    c.time = t;
    c.count = 1;
    c.elements = 2;
    c.encoding = GS_ENCODING_F64;
    assert_int_equal(gs_wire_begin(buf, GS_WIRE_MAX_DATAGRAM, &h, &size), GS_OK);
    assert_int_equal(gs_wire_add(buf, GS_WIRE_MAX_DATAGRAM, &size, &c, vals), GS_OK);
    return gs_wire_end(buf, size);
}

/* A datagram with h's header and one delta chunk c of differences d,
   decoded into v: the round trip every delta codec test starts with. */
static GS_TEST_UNUSED void delta_round_trip(unsigned char *buf, const gs_wire_header *h,
                                            const gs_wire_chunk *c, const int64_t *d,
                                            gs_wire_view *v) {
    size_t size, n;
    gs_reject why;
    assert_int_equal(gs_wire_begin(buf, GS_WIRE_MAX_DATAGRAM, h, &size), GS_OK);
    assert_int_equal(gs_wire_add_delta(buf, GS_WIRE_MAX_DATAGRAM, &size, c, d), GS_OK);
    n = gs_wire_end(buf, size);
    assert_int_equal(gs_wire_decode(buf, n, v, &why), GS_OK);
}

/* Decodes an exact-size copy of buf (ASan sees a read past it): the
   refusal's reason, or GS_REJECT_COUNT when taken; then *v holds it, its
   payloads in the copy, which wire_copy keeps until the next call. */
static GS_TEST_UNUSED unsigned char *wire_copy;
static GS_TEST_UNUSED gs_reject wire_decode_copy(const unsigned char *buf, size_t n,
                                                 gs_wire_view *v) {
    gs_reject why = GS_REJECT_COUNT;
    free(wire_copy);
    wire_copy = (unsigned char *)malloc(n ? n : 1);
    assert_non_null(wire_copy);
    memcpy(wire_copy, buf, n);
    if (gs_wire_decode(wire_copy, n, v, &why) == GS_OK) return GS_REJECT_COUNT;
    return why;
}

#endif
