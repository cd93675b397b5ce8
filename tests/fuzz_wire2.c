/* fuzz_wire2.c - a fast libFuzzer harness over the quantized decoder of wire
   v3: decode and deliver only, no world step per input.

   The world of tests/fuzz_world.h (host 1; peers 2 and 3; objects 10..15:
   a cloth, a chain, a sphere, a probe, a custom point, an empty custom)
   with every ghost in GS_ENCODING_QUANT and delta coding on is built once.
   So is a sender (host 2, the same objects) whose first snapshots, in
   quant, are the templates, with a heartbeat of each object besides; then,
   acknowledged by hosts 1 and 3, its next snapshots, delta chunks against
   the first (which the receiver is given once, so that it holds them as
   baselines), and an acknowledgement chunk for the receiver's objects;
   then one datagram of delta chunks in each of the three codings (packed,
   bitmap, Rice), one of a cloth-like chunk in the spatial coding (3), and
   several chunks of one time and sequence, whose headers
   are the short ones (no time, ids by their difference).
   An input is either datagrams back to back (it starts with "GSIM": cut
   before each magic, as tests/fuzz_wire.c does), or an edit: byte 0 picks
   a template (bit 7 set: the checksum is left as the edits make it), and
   each following 3 bytes write a byte (offset u16 modulo the datagram's
   size, value u8); a template's datagram sequence is a counter of the
   harness's, so a template is not refused as a duplicate the second time.
   Every datagram: gs_wire_decode on an exact-size heap copy (refused: a
   reason decode gives; accepted: every chunk's payload inside it, its
   values finite, a quantized one encodes again to the same values, a
   delta chunk to the same differences, an acknowledgement chunk to the
   same entries), then
   gs_net_deliver at a clock moving 1 ms a datagram: GS_OK or
   GS_ERR_REJECTED, for decode's own reason when decode refused it. Every
   4096 inputs the world advances 4 ms (the queued snapshots blend) and its
   states must stay finite: often enough to reach the blend, rarely
   enough for the harness's speed (the world step is what made the full
   harness slow). */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz_world.h"

#define FUZZ_FAIL2(what) \
    (fprintf(stderr, "fuzz_wire2: %s:%d: check failed: %s\n", __FILE__, __LINE__, what), abort())
#define CHECK(c) do { if (!(c)) FUZZ_FAIL2(#c); } while (0)

#define TEMPLATES 32

typedef struct harness {
    fuzz_world rx, tx;
    unsigned char tpl[TEMPLATES][GS_WIRE_MAX_DATAGRAM];
    size_t tpl_size[TEMPLATES];
    int ntpl;
    uint32_t seq;
    double now;
    uint64_t inputs;
    gs_wire_view view, again;
} harness;

/* The next "GSIM" (the magic) in data at or after from, or size: a plain
   scan, left out of coverage (tests/fuzz_ignore.txt) because a memcmp at
   every byte went through libFuzzer's memcmp hook and took a tenth of the
   harness's time, and the splitting tells the fuzzer nothing. */
static size_t fuzz2_next_magic(const uint8_t *data, size_t size, size_t from) {
    size_t i;
    for (i = from; i + 4 <= size; ++i)
        if (data[i] == 'G' && data[i + 1] == 'S' && data[i + 2] == 'I' && data[i + 3] == 'M')
            return i;
    return size;
}
static void put32(unsigned char *p, uint32_t v) {
    p[0] = (unsigned char)v; p[1] = (unsigned char)(v >> 8);
    p[2] = (unsigned char)(v >> 16); p[3] = (unsigned char)(v >> 24);
}

static gs_result keep_template(void *user, uint32_t to, const void *data, size_t size) {
    harness *h = (harness *)user;
    if (to == FUZZ_HOST && h->ntpl < TEMPLATES) {
        memcpy(h->tpl[h->ntpl], data, size);
        h->tpl_size[h->ntpl++] = size;
    }
    return GS_OK;
}
static gs_result drop(void *user, uint32_t to, const void *data, size_t size) {
    (void)user; (void)to; (void)data; (void)size;
    return GS_OK;
}

/* Every ghost of f in quant: the full harness's desc otherwise. */
static void requant(fuzz_world *f) {
    int i;
    for (i = 0; i < FUZZ_OBJECTS; ++i) {
        gs_ghost_desc gd = gs_ghost_desc_default();
        gd.object_id = 10u + (uint32_t)i;
        gd.encoding = GS_ENCODING_QUANT;
        gd.queue_size = 4;
        gd.rest_threshold = i == 2 ? 1e-3 : 0.0;
        gd.delta = 1;
        if (i == 3) {
            gd.owner = FUZZ_PEER_A;
            gd.weight = gs_weight_owner;
        }
        CHECK(gs_ghost_detach(f->agent[i]) == GS_OK);
        CHECK(gs_ghost_attach(f->agent[i], &gd) == GS_OK);
    }
}

/* A heartbeat of each object from host 2. */
static void heartbeats(harness *h) {
    gs_wire_header hd;
    size_t size;
    int i;
    memset(&hd, 0, sizeof hd);
    hd.session = FUZZ_SESSION;
    hd.sender = FUZZ_PEER_A;
    for (i = 0; i < FUZZ_OBJECTS && h->ntpl < TEMPLATES; ++i) {
        gs_wire_chunk c;
        memset(&c, 0, sizeof c);
        c.object_id = 10u + (uint32_t)i;
        c.sequence = 100;
        c.time = 0.01;
        c.count = i < 2 ? 2 : 1; /* 294 and 288 values: chunks of 240 */
        c.encoding = GS_ENCODING_QUANT;
        c.flags = GS_WIRE_CHUNK_REST;
        CHECK(gs_wire_begin(h->tpl[h->ntpl], GS_WIRE_MAX_DATAGRAM, &hd, &size) == GS_OK);
        CHECK(gs_wire_add(h->tpl[h->ntpl], GS_WIRE_MAX_DATAGRAM, &size, &c, NULL) == GS_OK);
        h->tpl_size[h->ntpl] = gs_wire_end(h->tpl[h->ntpl], size);
        h->ntpl++;
    }
}

/* A datagram from host `from` to `to` with one acknowledgement chunk of
   every object at sequence seq[i] (seq NULL: 1). */
static size_t ack_datagram(unsigned char *buf, uint32_t from, uint32_t to, const uint32_t *seq) {
    gs_wire_header hd;
    gs_wire_ack a[FUZZ_OBJECTS];
    size_t size;
    int i;
    memset(&hd, 0, sizeof hd);
    hd.session = FUZZ_SESSION;
    hd.sender = from;
    for (i = 0; i < FUZZ_OBJECTS; ++i) {
        a[i].object_id = 10u + (uint32_t)i;
        a[i].sequence = seq ? seq[i] : 1u;
        a[i].refused = i == 5;
    }
    CHECK(gs_wire_begin(buf, GS_WIRE_MAX_DATAGRAM, &hd, &size) == GS_OK);
    CHECK(gs_wire_add_ack(buf, GS_WIRE_MAX_DATAGRAM, &size, to, a, FUZZ_OBJECTS) == GS_OK);
    return gs_wire_end(buf, size);
}

/* The sender's next snapshots as deltas: its first ones acknowledged by
   both its peers, and given to the receiver as baselines. */
static void deltas(harness *h, int keys) {
    static gs_wire_view v;
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    uint32_t seq[FUZZ_OBJECTS];
    int t, i;
    size_t n;
    for (i = 0; i < FUZZ_OBJECTS; ++i) seq[i] = 1;
    for (t = 0; t < keys; ++t) {
        CHECK(gs_wire_decode(h->tpl[t], h->tpl_size[t], &v, NULL) == GS_OK);
        for (i = 0; i < v.chunk_count; ++i)
            if (v.chunks[i].object_id >= 10 && v.chunks[i].object_id < 10 + FUZZ_OBJECTS)
                seq[v.chunks[i].object_id - 10] = v.chunks[i].sequence;
        CHECK(gs_net_deliver(h->rx.net, h->tpl[t], h->tpl_size[t], 0.01, NULL) == GS_OK);
    }
    n = ack_datagram(buf, FUZZ_HOST, FUZZ_PEER_A, seq);
    CHECK(gs_net_deliver(h->tx.net, buf, n, 0.03, NULL) == GS_OK);
    n = ack_datagram(buf, FUZZ_PEER_B, FUZZ_PEER_A, seq);
    CHECK(gs_net_deliver(h->tx.net, buf, n, 0.03, NULL) == GS_OK);
    CHECK(gs_world_advance(h->tx.w, 0.02, NULL) == GS_OK);
    CHECK(gs_net_update(h->tx.net, 0.04) == GS_OK);
    if (h->ntpl < TEMPLATES) { /* acknowledgements for the receiver's objects */
        h->tpl_size[h->ntpl] = ack_datagram(h->tpl[h->ntpl], FUZZ_PEER_A, FUZZ_HOST, NULL);
        h->ntpl++;
    }
}

/* Delta chunks of objects 12 (a sphere, 13 values) against the snapshot
   the receiver holds (sequence 1 upwards: the first template's), in each
   coding: differences all 3 (packed), one large (bitmap), small with one
   large (Rice); the three share a time, so their headers are short. */
static void codings(harness *h) {
    gs_wire_header hd;
    gs_wire_chunk c;
    int64_t d[13];
    size_t size;
    int k, i;
    static gs_wire_view v;
    if (h->ntpl >= TEMPLATES) return;
    memset(&hd, 0, sizeof hd);
    hd.session = FUZZ_SESSION;
    hd.sender = FUZZ_PEER_A;
    memset(&c, 0, sizeof c);
    c.object_id = 12;
    c.count = 1;
    c.elements = 13;
    c.encoding = GS_ENCODING_QUANT;
    c.flags = GS_WIRE_CHUNK_DELTA;
    c.time = 0.05;
    CHECK(gs_wire_begin(h->tpl[h->ntpl], GS_WIRE_MAX_DATAGRAM, &hd, &size) == GS_OK);
    for (k = 0; k < 3; ++k) {
        for (i = 0; i < 13; ++i) d[i] = k == 0 ? 3 : k == 1 ? (i == 5) * 100000 : (i % 3) - (i == 9) * 900;
        c.baseline = 1;
        c.sequence = 2 + (uint32_t)k;
        CHECK(gs_wire_add_delta(h->tpl[h->ntpl], GS_WIRE_MAX_DATAGRAM, &size, &c, d) == GS_OK);
    }
    h->tpl_size[h->ntpl] = gs_wire_end(h->tpl[h->ntpl], size);
    CHECK(gs_wire_decode(h->tpl[h->ntpl], h->tpl_size[h->ntpl], &v, NULL) == GS_OK);
    for (k = 0; k < 3; ++k) CHECK(v.chunks[k].delta_coding == k);
    h->ntpl++;
    if (h->ntpl >= TEMPLATES) return;
    /* the spatial coding: 60 differences of the cloth (object 10), rows
       of 4 particles, each coordinate a plane (as a cloth moving) */
    {
        int64_t e[60];
        c.object_id = 10;
        c.elements = 60;
        c.sequence = 2;
        c.delta_row = 4;
        for (i = 0; i < 60; ++i) e[i] = 900 + 40 * (i / 3 % 4) + 25 * (i / 12) + 7 * (i % 3);
        CHECK(gs_wire_begin(h->tpl[h->ntpl], GS_WIRE_MAX_DATAGRAM, &hd, &size) == GS_OK);
        CHECK(gs_wire_add_delta(h->tpl[h->ntpl], GS_WIRE_MAX_DATAGRAM, &size, &c, e) == GS_OK);
        h->tpl_size[h->ntpl] = gs_wire_end(h->tpl[h->ntpl], size);
        CHECK(gs_wire_decode(h->tpl[h->ntpl], h->tpl_size[h->ntpl], &v, NULL) == GS_OK);
        CHECK(v.chunks[0].delta_coding == 3);
        h->ntpl++;
    }
}

static harness *harness_get(void) {
    static harness *h; /* the harness's one world, built on the first input */
    if (h) return h;
    h = (harness *)calloc(1, sizeof *h);
    CHECK(h != NULL);
    CHECK(fuzz_world_create(&h->rx, FUZZ_HOST, 0.0, drop, NULL) == GS_OK);
    CHECK(fuzz_world_create(&h->tx, FUZZ_PEER_A, 0.0, keep_template, h) == GS_OK);
    requant(&h->rx);
    requant(&h->tx);
    CHECK(gs_world_advance(h->tx.w, 0.02, NULL) == GS_OK);
    CHECK(gs_net_update(h->tx.net, 0.02) == GS_OK);
    {
        int keys = h->ntpl;
        heartbeats(h);
        deltas(h, keys);
        codings(h);
    }
    fuzz_world_destroy(&h->tx); /* the templates are all it was for */
    CHECK(h->ntpl > FUZZ_OBJECTS);
    return h;
}

/* The reasons gs_wire_decode gives. */
static int decode_reason(gs_reject r) {
    return r == GS_REJECT_SHORT || r == GS_REJECT_MAGIC || r == GS_REJECT_VERSION ||
           r == GS_REJECT_OLD_VERSION || r == GS_REJECT_CHECKSUM || r == GS_REJECT_LAYOUT ||
           r == GS_REJECT_NOT_FINITE || r == GS_REJECT_TIME;
}

/* A quantized chunk's values encode again to the same values: scalars
   exactly; a quaternion (its bits may say one whose largest component is
   not the one they name, and the encoder then names the other) within two
   component steps, sqrt(2) / (2^8 - 1) at the fewest bits. */
static void requant_same(harness *h, const gs_wire_chunk *c) {
    unsigned char out[GS_WIRE_MAX_DATAGRAM];
    double v[GS_WIRE_MAX_DATAGRAM], w[GS_WIRE_MAX_DATAGRAM];
    gs_wire_header hd;
    gs_reject why;
    size_t n = 0;
    int k, g;
    memset(&hd, 0, sizeof hd);
    gs_wire_values(c, v);
    CHECK(gs_wire_begin(out, sizeof out, &hd, &n) == GS_OK);
    CHECK(gs_wire_add(out, sizeof out, &n, c, v) == GS_OK);
    n = gs_wire_end(out, n);
    CHECK(gs_wire_decode(out, n, &h->again, &why) == GS_OK);
    gs_wire_values(&h->again.chunks[0], w);
    for (g = 0, k = 0; g < c->segment_count; ++g) {
        int end = k + c->segments[g].count;
        for (; k < end; ++k) {
            double d = fabs(w[k] - v[k]);
            CHECK(c->segments[g].kind == GS_WIRE_SCALAR ? d == 0.0 : d <= 0.0111);
        }
    }
}

/* A delta chunk's differences code again to the same (the coding may
   differ: the input's need not be the smaller), and an acknowledgement
   chunk's entries to the same entries. */
static void recode_same(harness *h, const gs_wire_chunk *c) {
    unsigned char out[GS_WIRE_MAX_DATAGRAM];
    int64_t d[GS_WIRE_MAX_DATAGRAM], e[GS_WIRE_MAX_DATAGRAM];
    gs_wire_ack a[GS_WIRE_MAX_ACKS], b[GS_WIRE_MAX_ACKS];
    gs_wire_header hd;
    size_t n = 0;
    int k, na;
    memset(&hd, 0, sizeof hd);
    CHECK(gs_wire_begin(out, sizeof out, &hd, &n) == GS_OK);
    if (c->flags & GS_WIRE_CHUNK_DELTA) {
        gs_wire_deltas(c, d);
        /* a spatial chunk may decode past +-2^31 (the receiver refuses
           it): no coding says that again */
        for (k = 0; k < c->elements; ++k)
            if (d[k] < -2147483648LL || d[k] > 2147483647LL) return;
        CHECK(gs_wire_add_delta(out, sizeof out, &n, c, d) == GS_OK);
        n = gs_wire_end(out, n);
        CHECK(gs_wire_decode(out, n, &h->again, NULL) == GS_OK);
        CHECK(h->again.chunks[0].baseline == c->baseline);
        gs_wire_deltas(&h->again.chunks[0], e);
        for (k = 0; k < c->elements; ++k) CHECK(d[k] == e[k]);
        return;
    }
    na = gs_wire_acks(c, a, GS_WIRE_MAX_ACKS);
    CHECK(na == c->elements);
    CHECK(gs_wire_add_ack(out, sizeof out, &n, c->object_id, a, na) == GS_OK);
    n = gs_wire_end(out, n);
    CHECK(gs_wire_decode(out, n, &h->again, NULL) == GS_OK);
    CHECK(gs_wire_acks(&h->again.chunks[0], b, GS_WIRE_MAX_ACKS) == na);
    for (k = 0; k < na; ++k)
        CHECK(a[k].object_id == b[k].object_id && a[k].sequence == b[k].sequence &&
              a[k].refused == b[k].refused);
}

static void one_datagram(harness *h, const unsigned char *src, size_t size) {
    unsigned char *buf = (unsigned char *)malloc(size ? size : 1);
    gs_reject dwhy = GS_REJECT_COUNT, why = GS_REJECT_COUNT;
    gs_result r;
    int ok, i, k;
    CHECK(buf != NULL);
    if (size) memcpy(buf, src, size);
    ok = gs_wire_decode(buf, size, &h->view, &dwhy) == GS_OK;
    if (!ok) {
        CHECK(decode_reason(dwhy));
    } else {
        for (i = 0; i < h->view.chunk_count; ++i) {
            const gs_wire_chunk *c = &h->view.chunks[i];
            CHECK(c->payload > buf + GS_WIRE_HEADER); /* after its header */
            CHECK(c->payload <= buf + size - 4);
            double v[GS_WIRE_MAX_DATAGRAM];
            gs_wire_values(c, v);
            for (k = 0; k < c->elements; ++k) CHECK(isfinite(v[k]));
            /* the one-value reader agrees, at both ends */
            if (c->elements) {
                CHECK(gs_wire_value(c, 0) == v[0]);
                CHECK(gs_wire_value(c, c->elements - 1) == v[c->elements - 1]);
            }
            if (c->flags & (GS_WIRE_CHUNK_DELTA | GS_WIRE_CHUNK_ACK))
                recode_same(h, c);
            else if (c->encoding == GS_ENCODING_QUANT && !(c->flags & GS_WIRE_CHUNK_REST) &&
                     c->elements <= 240)
                requant_same(h, c);
        }
    }
    h->now += 0.001;
    r = gs_net_deliver(h->rx.net, buf, size, h->now, &why);
    CHECK(r == GS_OK || r == GS_ERR_REJECTED);
    if (r == GS_OK) CHECK(ok);
    else if (!ok) CHECK(why == dwhy);
    else CHECK(!decode_reason(why));
    free(buf);
}

static void check_states(harness *h) {
    double s[1 + 49 * 6];
    int i;
    size_t k;
    for (i = 0; i < FUZZ_OBJECTS; ++i) {
        size_t n = gs_agent_state_size(h->rx.agent[i]);
        CHECK(gs_agent_get_state(h->rx.agent[i], s, n) == GS_OK);
        for (k = 0; k < n; ++k) CHECK(isfinite(s[k]));
    }
}

static int fuzz_wire2_one(const uint8_t *data, size_t size) {
    harness *h = harness_get();
    if (size >= 4 && memcmp(data, "GSIM", 4) == 0) {
        size_t start = 0, i;
        for (i = fuzz2_next_magic(data, size, 4); i < size; i = fuzz2_next_magic(data, size, i + 1)) {
            one_datagram(h, data + start, i - start);
            start = i;
        }
        one_datagram(h, data + start, size - start);
    } else if (size >= 1) {
        unsigned char buf[GS_WIRE_MAX_DATAGRAM];
        int t = (data[0] & 0x7f) % h->ntpl;
        size_t n = h->tpl_size[t], i;
        memcpy(buf, h->tpl[t], n);
        put32(buf + 16, h->seq++); /* the datagram sequence */
        for (i = 1; i + 3 <= size; i += 3) buf[(data[i] | data[i + 1] << 8) % n] = data[i + 2];
        if (!(data[0] & 0x80)) gs_wire_end(buf, n - 4); /* the checksum again */
        one_datagram(h, buf, n);
    }
    if (++h->inputs % 4096 == 0) {
        gs_world_advance(h->rx.w, 0.004, NULL);
        check_states(h);
    }
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    return fuzz_wire2_one(data, size);
}
