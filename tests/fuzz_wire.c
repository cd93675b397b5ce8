/* fuzz_wire.c - libFuzzer harness over the receiving side of wire format v2:
   gs_wire_decode, the net's validation (gs_net_deliver) and the blend.

   An input is one or more datagrams back to back: it is cut before every
   "GSIM" (the magic), so a seed made of several datagrams (a snapshot in
   several chunks, a run of sequence numbers) stays several datagrams when
   mutated. For each datagram:
     1. gs_wire_decode on an exact-size heap copy (ASan sees any overread).
        Accepted: every chunk lies inside the datagram, its values and time
        are finite, and encoding the view again with gs_wire_begin/add/end
        gives the same bytes (the fields decode ignores copied over); a
        quantized chunk, whose encoder picks the width and base itself,
        gives the same values.
     2. gs_net_deliver into a small world (tests/fuzz_world.h: host 1, peers
        2 and 3, six ghosts of every kind; an input of odd length gets a
        time window of 100 s, an even one none) at a wall time moving 4 ms
        per datagram. It refuses exactly what decode refuses, for the same
        reason, and returns nothing but GS_OK or GS_ERR_REJECTED.
     3. A datagram refused for its checksum is delivered again with the
        checksum made right, so that mutations reach past the CRC.
     4. The world advances 4 ms (ghosts blend what was queued) and the net
        sends what is due; every datagram it sends must decode.
   Every advance moves each agent's time by its steps, at most
   GS_MAX_TIME_CORRECTION of blending and the world's follow; after each,
   every agent's and the world's time is in [0, GS_WIRE_MAX_TIME].
   At the end the world advances 50 ms more, and then: every agent's state
   and render state is finite, no statistic is NaN, and the counters add
   up: per reason, what the peers and the unknown-sender counters hold is
   what the deliveries were refused for; datagrams and bytes received are
   the accepted ones.

   Build: make fuzz (clang -fsanitize=fuzzer,address,undefined). The same
   checks replay the files of tests/fuzz-regressions/ in the cmocka test
   tests/test_fuzz_regress.c, which defines FUZZ_FAIL. Plain C, no
   FuzzedDataProvider. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz_world.h"

#ifndef FUZZ_FAIL
#define FUZZ_FAIL(what) \
    (fprintf(stderr, "fuzz_wire: %s:%d: check failed: %s\n", __FILE__, __LINE__, what), \
     abort())
#endif
#define FUZZ_CHECK(c) do { if (!(c)) FUZZ_FAIL(#c); } while (0)

#define FUZZ_MAX_PIECES 32 /* datagrams taken from one input */
#define FUZZ_STEP 0.004    /* s of wall and simulation time per datagram */

/* What the harness saw, to compare with the library's counters. */
typedef struct fuzz_tally {
    uint64_t accepted, rejected, bytes, chunks;
    uint64_t why[GS_REJECT_COUNT];
    uint64_t sent;
    int window; /* the net has a time window: it refuses for GS_REJECT_TIME too */
} fuzz_tally;

/* The reasons gs_wire_decode gives; the net's own come after decoding. */
static int fuzz_decode_reason(gs_reject r) {
    return r == GS_REJECT_SHORT || r == GS_REJECT_MAGIC || r == GS_REJECT_VERSION ||
           r == GS_REJECT_OLD_VERSION ||
           r == GS_REJECT_CHECKSUM || r == GS_REJECT_LAYOUT ||
           r == GS_REJECT_NOT_FINITE || r == GS_REJECT_TIME;
}

/* Standard CRC-32 (reflected 0xEDB88320), bit by bit: the harness's own. */
static uint32_t fuzz_crc32(const unsigned char *p, size_t n) {
    uint32_t c = 0xffffffffu;
    size_t i;
    int k;
    for (i = 0; i < n; ++i) {
        c ^= p[i];
        for (k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
    }
    return c ^ 0xffffffffu;
}

static void fuzz_put32(unsigned char *p, uint32_t v) {
    p[0] = (unsigned char)v; p[1] = (unsigned char)(v >> 8);
    p[2] = (unsigned char)(v >> 16); p[3] = (unsigned char)(v >> 24);
}

/* A quantized chunk's values encode again (in a datagram of their own)
   to the same values. */
static void fuzz_requant(const gs_wire_chunk *c, const double *values) {
    static gs_wire_view w;
    unsigned char out[GS_WIRE_MAX_DATAGRAM];
    gs_wire_header h;
    gs_reject why;
    size_t n = 0;
    int k;
    memset(&h, 0, sizeof h);
    FUZZ_CHECK(gs_wire_begin(out, sizeof out, &h, &n) == GS_OK);
    FUZZ_CHECK(gs_wire_add(out, sizeof out, &n, c, values) == GS_OK);
    n = gs_wire_end(out, n);
    FUZZ_CHECK(gs_wire_decode(out, n, &w, &why) == GS_OK);
    for (k = 0; k < c->elements; ++k) FUZZ_CHECK(gs_wire_value(&w.chunks[0], k) == values[k]);
}

/* An accepted view encodes back to the very bytes it came from, the
   header's flags (the sender's sync) included; the run field is copied
   over here. */
static void fuzz_reencode(const unsigned char *buf, size_t size, const gs_wire_view *v) {
    unsigned char out[GS_WIRE_MAX_DATAGRAM];
    double values[GS_WIRE_MAX_DATAGRAM];
    size_t n = 0;
    int i, k, quant = 0;
    FUZZ_CHECK(gs_wire_begin(out, sizeof out, &v->header, &n) == GS_OK);
    for (i = 0; i < v->chunk_count; ++i) {
        const gs_wire_chunk *c = &v->chunks[i];
        for (k = 0; k < c->elements; ++k) values[k] = gs_wire_value(c, k);
        if (c->flags & (GS_WIRE_CHUNK_DELTA | GS_WIRE_CHUNK_ACK)) {
            quant = 1; /* their coding is the sender's pick: fuzz_wire2 checks them */
        } else if (c->encoding == GS_ENCODING_QUANT && !(c->flags & GS_WIRE_CHUNK_REST)) {
            fuzz_requant(c, values);
            quant = 1;
        } else {
            FUZZ_CHECK(gs_wire_add(out, sizeof out, &n, c, values) == GS_OK);
        }
    }
    if (quant) return;
    FUZZ_CHECK(n + 4 == size);
    memcpy(out + 20, buf + 20, 4);  /* reserved */
    FUZZ_CHECK(gs_wire_end(out, n) == size);
    FUZZ_CHECK(memcmp(out, buf, size) == 0);
}

/* Decode on its own: refused with a reason, or accepted and sound. */
static int fuzz_decode(const unsigned char *buf, size_t size, gs_reject *why) {
    static gs_wire_view v; /* kept off the stack */
    const unsigned char *at = buf + GS_WIRE_HEADER; /* where the next chunk starts */
    int ok, i, k;
    *why = GS_REJECT_COUNT;
    ok = gs_wire_decode(buf, size, &v, why) == GS_OK;
    if (!ok) {
        FUZZ_CHECK(*why >= 0 && *why < GS_REJECT_COUNT && fuzz_decode_reason(*why));
        return 0;
    }
    FUZZ_CHECK(size <= GS_WIRE_MAX_DATAGRAM);
    FUZZ_CHECK(v.chunk_count >= 1 && v.chunk_count <= GS_WIRE_MAX_CHUNKS);
    for (i = 0; i < v.chunk_count; ++i) {
        const gs_wire_chunk *c = &v.chunks[i];
        /* the payload's length, implied by its contents (>>wire) */
        size_t len = c->payload_bytes;
        FUZZ_CHECK(c->encoding == GS_ENCODING_F64 || c->encoding == GS_ENCODING_F32 ||
                   c->encoding == GS_ENCODING_QUANT);
        if (c->flags & GS_WIRE_CHUNK_REST) FUZZ_CHECK(len == 0 && c->elements == 0);
        else if (c->encoding != GS_ENCODING_QUANT)
            FUZZ_CHECK(len == (size_t)c->elements * (c->encoding == GS_ENCODING_F32 ? 4u : 8u));
        FUZZ_CHECK(c->index < c->count);
        FUZZ_CHECK(isfinite(c->time) && c->time >= 0.0);
        /* a header of 1..GS_WIRE_CHUNK_HEADER bytes after the chunk before */
        FUZZ_CHECK(c->payload >= at + 1 && c->payload <= at + GS_WIRE_CHUNK_HEADER);
        FUZZ_CHECK(c->payload + len <= buf + size - 4);
        for (k = 0; k < c->elements; ++k) FUZZ_CHECK(isfinite(gs_wire_value(c, k)));
        at = c->payload + len;
    }
    FUZZ_CHECK(at == buf + size - 4);
    fuzz_reencode(buf, size, &v);
    return 1;
}

/* The world's transport: what it sends must be a datagram it would take. */
static gs_result fuzz_send(void *user, uint32_t host, const void *data, size_t size) {
    fuzz_tally *t = (fuzz_tally *)user;
    static gs_wire_view v;
    gs_reject why;
    int i;
    FUZZ_CHECK(host == FUZZ_PEER_A || host == FUZZ_PEER_B);
    FUZZ_CHECK(size <= GS_WIRE_MAX_DATAGRAM);
    FUZZ_CHECK(gs_wire_decode((const unsigned char *)data, size, &v, &why) == GS_OK);
    FUZZ_CHECK(v.header.session == FUZZ_SESSION && v.header.sender == FUZZ_HOST);
    for (i = 0; i < v.chunk_count; ++i)
        FUZZ_CHECK(v.chunks[i].object_id >= 10 && v.chunks[i].object_id < 10 + FUZZ_OBJECTS);
    t->sent++;
    return GS_OK;
}

/* Tallies a delivery of buf (size bytes): taken, or refused for why. */
static void fuzz_count(fuzz_tally *t, gs_result r, gs_reject why, const unsigned char *buf,
                       size_t size) {
    if (r == GS_OK) {
        t->accepted++;
        t->bytes += size;
        t->chunks += (uint64_t)(buf[6] | buf[7] << 8); /* taken: a whole header */
    } else {
        FUZZ_CHECK(why >= 0 && why < GS_REJECT_COUNT);
        t->rejected++;
        t->why[why]++;
    }
}

/* Delivers one datagram from an exact-size copy and tallies the outcome. */
static gs_reject fuzz_deliver(fuzz_world *f, fuzz_tally *t, const unsigned char *src,
                              size_t size, double now) {
    unsigned char *buf = (unsigned char *)malloc(size ? size : 1);
    gs_reject dec_why, why = GS_REJECT_COUNT;
    gs_result r;
    int ok;
    FUZZ_CHECK(buf != NULL);
    if (size) memcpy(buf, src, size);
    ok = fuzz_decode(buf, size, &dec_why);
    r = gs_net_deliver(f->net, buf, size, now, &why);
    FUZZ_CHECK(r == GS_OK || r == GS_ERR_REJECTED);
    fuzz_count(t, r, why, buf, size);
    if (r == GS_OK) {
        FUZZ_CHECK(ok);
        why = GS_REJECT_COUNT;
    } else if (!ok) {
        FUZZ_CHECK(why == dec_why);
    } else {
        FUZZ_CHECK(!fuzz_decode_reason(why) || (t->window && why == GS_REJECT_TIME));
    }
    free(buf);
    return why;
}

static int fuzz_finite_all(const double *x, size_t n) {
    size_t i;
    for (i = 0; i < n; ++i)
        if (!isfinite(x[i])) return 0;
    return 1;
}

/* Every agent's state and render state finite; no ghost statistic NaN. */
static void fuzz_check_states(const fuzz_world *f) {
    double s[1 + 49 * 6];
    int i;
    for (i = 0; i < FUZZ_OBJECTS; ++i) {
        const gs_agent *a = f->agent[i];
        size_t n = gs_agent_state_size(a);
        gs_ghost_stats gst;
        FUZZ_CHECK(n <= sizeof s / sizeof s[0]);
        FUZZ_CHECK(gs_agent_get_state(a, s, n) == GS_OK);
        FUZZ_CHECK(fuzz_finite_all(s, n));
        FUZZ_CHECK(s[0] >= 0.0 && s[0] <= GS_WIRE_MAX_TIME);
        FUZZ_CHECK(gs_ghost_render_state(a, s, n) == GS_OK);
        FUZZ_CHECK(fuzz_finite_all(s, n));
        FUZZ_CHECK(gs_ghost_get_stats(a, &gst) == GS_OK);
        FUZZ_CHECK(!isnan(gst.last_correction));
    }
    FUZZ_CHECK(gs_world_time(f->w) >= 0.0 && gs_world_time(f->w) <= GS_WIRE_MAX_TIME);
}

/* Advances the world; what moved each agent is its steps (steps * dt),
   at most GS_MAX_TIME_CORRECTION of blending, and the world's follow (a
   lagging agent jumps to the clock the others set: the world's time less
   the advance). A refused advance moves nothing. */
static void fuzz_advance(fuzz_world *f, double seconds) {
    double t0[FUZZ_OBJECTS], w0 = gs_world_time(f->w), w1;
    uint64_t n0[FUZZ_OBJECTS];
    gs_result r;
    int i;
    for (i = 0; i < FUZZ_OBJECTS; ++i) {
        t0[i] = gs_agent_time(f->agent[i]);
        n0[i] = agent_stats(f->agent[i]).steps;
    }
    r = gs_world_advance(f->w, seconds, NULL);
    w1 = gs_world_time(f->w);
    if (r == GS_ERR_INVALID_ARG) FUZZ_CHECK(w1 == w0);
    for (i = 0; i < FUZZ_OBJECTS; ++i) {
        const gs_agent *a = f->agent[i];
        double t = gs_agent_time(a), follow = w1 - seconds - t0[i];
        double stepped = (double)(agent_stats(a).steps - n0[i]) * gs_agent_dt(a);
        /* t = steps * dt + offset: sums of numbers up to 1e9 round */
        double eps = 1e-12 * (fabs(t) + fabs(t0[i]) + stepped) + 1e-9;
        FUZZ_CHECK(fabs(t - t0[i] - stepped) <=
                   GS_MAX_TIME_CORRECTION + (follow > 0.0 ? follow : 0.0) + eps);
    }
}

/* The library's counters against the harness's tally. */
static void fuzz_check_counters(const fuzz_world *f, const fuzz_tally *t) {
    static const uint32_t peers[2] = {FUZZ_PEER_A, FUZZ_PEER_B};
    gs_unknown_stats unknown;
    uint64_t why[GS_REJECT_COUNT];
    uint64_t received = 0, bytes = 0, chunks = 0, rejected = 0;
    int p, r;
    FUZZ_CHECK(gs_net_unknown_stats(f->net, &unknown) == GS_OK);
    memcpy(why, unknown.rejected, sizeof why);
    for (r = 0; r < GS_REJECT_COUNT; ++r) rejected += unknown.rejected[r];
    FUZZ_CHECK(rejected == unknown.rejected_total);
    for (p = 0; p < 2; ++p) {
        gs_peer_stats st;
        uint64_t sum = 0;
        FUZZ_CHECK(gs_net_peer_stats(f->net, peers[p], &st) == GS_OK);
        for (r = 0; r < GS_REJECT_COUNT; ++r) {
            sum += st.rejected[r];
            why[r] += st.rejected[r];
        }
        FUZZ_CHECK(st.rejected_total == sum);
        /* a keyed net refuses a datagram seen already as a replay */
        FUZZ_CHECK(st.duplicates >= st.rejected[GS_REJECT_DUPLICATE] &&
                   st.duplicates - st.rejected[GS_REJECT_DUPLICATE] <=
                       st.rejected[GS_REJECT_REPLAY]);
        FUZZ_CHECK(st.snapshots_received <= st.chunks_received);
        FUZZ_CHECK(!isnan(st.gap) && !isnan(st.rtt) && !isnan(st.divergence) &&
                   !isnan(st.last_remote_time));
        FUZZ_CHECK(st.rtt >= 0.0);
        rejected += sum;
        received += st.datagrams_received;
        bytes += st.bytes_received;
        chunks += st.chunks_received;
    }
    FUZZ_CHECK(received == t->accepted);
    FUZZ_CHECK(rejected == t->rejected);
    FUZZ_CHECK(bytes == t->bytes);
    FUZZ_CHECK(chunks <= t->chunks); /* a duplicated chunk is not counted */
    for (r = 0; r < GS_REJECT_COUNT; ++r) FUZZ_CHECK(why[r] == t->why[r]);
}

/* After a datagram: the world steps FUZZ_STEP (ghosts blend what was
   queued; it may report GS_ERR_UNSTABLE), the net sends what is due, and
   every state is checked. */
static void fuzz_step(fuzz_world *f, double now) {
    fuzz_advance(f, FUZZ_STEP);
    FUZZ_CHECK(gs_net_update(f->net, now) == GS_OK);
    fuzz_check_states(f);
}

/* The end of an input: 50 ms more, the states, and the counters against
   the tally; the world goes. */
static void fuzz_finish(fuzz_world *f, const fuzz_tally *t, double now) {
    fuzz_advance(f, 0.05);
    FUZZ_CHECK(gs_net_update(f->net, now + 0.05) == GS_OK);
    fuzz_check_states(f);
    fuzz_check_counters(f, t);
    fuzz_world_destroy(f);
}

/* The end of the datagram that starts at data[start]: the next magic. */
static size_t fuzz_next_piece(const uint8_t *data, size_t size, size_t start) {
    size_t i;
    for (i = start + 1; i + 4 <= size; ++i)
        if (memcmp(data + i, "GSIM", 4) == 0) return i;
    return size;
}

int fuzz_wire_one(const uint8_t *data, size_t size);
int fuzz_wire_one(const uint8_t *data, size_t size) {
    fuzz_world f;
    fuzz_tally t;
    double now = 10.0;
    size_t start = 0;
    int pieces = 0;
    memset(&t, 0, sizeof t);
    t.window = (int)(size % 2);
    FUZZ_CHECK(fuzz_world_create(&f, FUZZ_HOST, t.window ? 100.0 : 0.0, fuzz_send, &t) == GS_OK);
    while (start < size && pieces++ < FUZZ_MAX_PIECES) {
        size_t end = fuzz_next_piece(data, size, start), n = end - start;
        now += FUZZ_STEP;
        if (fuzz_deliver(&f, &t, data + start, n, now) == GS_REJECT_CHECKSUM) {
            unsigned char fixed[GS_WIRE_MAX_DATAGRAM];
            memcpy(fixed, data + start, n); /* n <= 1200: longer is LAYOUT */
            fuzz_put32(fixed + n - 4, fuzz_crc32(fixed, n - 4));
            fuzz_deliver(&f, &t, fixed, n, now);
        }
        fuzz_step(&f, now);
        start = end;
    }
    fuzz_finish(&f, &t, now);
    return 0;
}

#ifndef FUZZ_NO_ENTRY
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    return fuzz_wire_one(data, size);
}
#endif
