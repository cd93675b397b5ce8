/* test_security.c - who may speak, and bounded resources (>>net, the seal
   in >>wire, the allow-list in >>udp).

   Built twice by the Makefile: build/test_security with GHOSTSIM_SODIUM
   (sealed datagrams under a pre-shared key) and build/test_security_nosodium
   without it, where a key is GS_ERR_UNSUPPORTED and the tests that need no
   key run in clear. What is checked:
   - a key without GHOSTSIM_SODIUM is a clear error; with it, datagrams are
     sealed (flag set, values not in clear) and blended as before;
   - a snapshot is encoded once for every peer: in clear, the datagrams
     differ only in the sequence, the echo and the CRC; sealed, each has
     its own nonce; each peer takes its own;
   - forged, tampered (every byte of a datagram, one at a time), replayed,
     wrongly keyed and in-clear datagrams are refused, each counted under
     its reason, and never blended; a forgery does not move the replay
     window or spend the sender's rate;
   - a restarted peer is taken at once, while its earlier run can no longer
     be replayed; nonces never repeat across runs or peers;
   - the receive cap (max_rate) drops and counts the excess;
   - UDP: a datagram from an address other than its sender's is refused
     (GS_REJECT_ADDRESS), IPv4 and IPv6, and peers can be moved at run time;
   - a flood of 1e6 garbage, forged and replayed datagrams through
     gs_net_deliver leaves the world's memory (counted through its
     allocator) exactly where it was, every one is refused and counted,
     and the legitimate snapshots sent meanwhile are all taken and blended.
   The costs it prints (flood rate, seal + open per datagram) are measured
   on a shared machine: informative, not asserted tightly.

   Pass a cmocka glob to run some tests only: test_security 'test_udp*'. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#ifndef GHOSTSIM_NO_UDP
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>
#endif

#include "ghostsim.h"
#include "alloc_helpers.h"
#include "net_helpers.h"
#include "world_helpers.h"
#ifdef GHOSTSIM_SODIUM
#include <sodium.h> /* the seal's cost against libsodium's alone */
#endif

#define TOY_MAX 135 /* one full chunk of f64: a datagram of 1200 B sealed */

static const unsigned char key_a[GS_WIRE_KEY_BYTES] = "ghostsim test key, 32 bytes ok!";
#ifdef GHOSTSIM_SODIUM
static const unsigned char key_b[GS_WIRE_KEY_BYTES] = "another key, also 32 bytes long";
#endif

/* ---- a host: a toy agent of n values under ghost 5, owned by host 2, on
   a transport of the test's own that keeps what it sends ---- */

typedef struct toy {
    double x[TOY_MAX];
    int n;
} toy;

static gs_result toy_step(void *user, double t, double dt) {
    (void)user; (void)t; (void)dt;
    return GS_OK;
}
static void toy_get(const void *user, double *out) {
    const toy *t = (const toy *)user;
    memcpy(out, t->x, (size_t)t->n * sizeof(double));
}
static gs_result toy_set(void *user, const double *in) {
    toy *t = (toy *)user;
    memcpy(t->x, in, (size_t)t->n * sizeof(double));
    return GS_OK;
}

#define BOX 64
typedef struct box {
    unsigned char data[BOX][GS_WIRE_MAX_DATAGRAM];
    size_t size[BOX];
    uint32_t to[BOX];
    int count;
} box;

static gs_result box_send(void *user, uint32_t host, const void *data, size_t size) {
    box *b = (box *)user;
    assert_true(size <= GS_WIRE_MAX_DATAGRAM);
    assert_true(b->count < BOX);
    memcpy(b->data[b->count], data, size);
    b->size[b->count] = size;
    b->to[b->count++] = host;
    return GS_OK;
}

typedef struct host {
    gs_world *w;
    gs_agent *a;
    gs_net *net;
    toy t;
    box out;
    counter mem; /* the world's allocations: bytes live and the peak */
    double now; /* s, this host's wall clock for gs_net_update */
} host;

typedef struct host_opts {
    const unsigned char *key;
    double max_rate;
    int n;             /* toy values; default 3 */
    uint32_t peers[3]; /* 0-ended; default {other} */
} host_opts;

/* Host `id` (1 or 2) with peer 3 - id, or as opts say. Returns NULL and
   *r when the net cannot be made. */
static host *host_try(uint32_t id, const host_opts *o, gs_result *r) {
    host *h = (host *)calloc(1, sizeof *h);
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_net_desc nd = gs_net_desc_default();
    int i;
    assert_non_null(h);
    h->w = counted_world(&h->mem, id);
    h->t.n = o && o->n ? o->n : 3;
    for (i = 0; i < h->t.n; ++i) h->t.x[i] = (double)(id * 100 + (uint32_t)i);
    h->a = custom_new(h->w, 0.01, (size_t)h->t.n, toy_step, toy_get, toy_set, &h->t);
    gd.object_id = 5;
    gd.weight = gs_weight_owner; /* host 1 takes host 2's state as it is */
    gd.owner = 2;
    gd.send_rate = 1000.0;       /* every step is sent */
    gd.time_deadband = -1.0;
    assert_int_equal(gs_ghost_attach(h->a, &gd), GS_OK);
    nd.key = o ? o->key : NULL;
    nd.max_rate = o ? o->max_rate : 0.0;
    *r = send_only_net(h->w, &nd, box_send, &h->out, &h->net);
    if (*r != GS_OK) return h;
    if (o && o->peers[0])
        for (i = 0; i < 3 && o->peers[i]; ++i) assert_int_equal(gs_net_add_peer(h->net, o->peers[i], NULL), GS_OK);
    else
        assert_int_equal(gs_net_add_peer(h->net, 3 - id, NULL), GS_OK);
    return h;
}

static host *host_new(uint32_t id, const host_opts *o) {
    gs_result r;
    host *h = host_try(id, o, &r);
    if (r != GS_OK) print_error("gs_net_create: %s\n", gs_world_error(h->w));
    assert_int_equal(r, GS_OK);
    return h;
}

static void host_free(host *h) {
    gs_world_destroy(h->w);
    assert_int_equal(h->mem.live, 0); /* everything went back */
    free(h);
}

/* Host h (2) moves its toy to `base + i`, steps (publishes) and sends:
   returns the number of datagrams now in h->out. */
static int host_send(host *h, double base) {
    int i;
    for (i = 0; i < h->t.n; ++i) h->t.x[i] = base + i;
    assert_int_equal(gs_agent_step(h->a), GS_OK);
    h->now += 0.002;
    assert_int_equal(gs_net_update(h->net, h->now), GS_OK);
    return h->out.count;
}

/* Sends once and takes the one datagram out of the box. */
static size_t host_one(host *h, double base, unsigned char *buf) {
    size_t n;
    h->out.count = 0;
    assert_int_equal(host_send(h, base), 1);
    n = h->out.size[0];
    memcpy(buf, h->out.data[0], n);
    h->out.count = 0;
    return n;
}

static gs_result deliver(host *h, const unsigned char *buf, size_t n, double now,
                         gs_reject *why) {
    *why = GS_REJECT_COUNT;
    return gs_net_deliver(h->net, buf, n, now, why);
}

static uint64_t rejected_all(const host *h, uint32_t peer) {
    gs_unknown_stats unk;
    uint64_t sum = 0;
    gs_peer_stats ps;
    int r;
    assert_int_equal(gs_net_unknown_stats(h->net, &unk), GS_OK);
    for (r = 0; r < GS_REJECT_COUNT; ++r) sum += unk.rejected[r];
    assert_int_equal(gs_net_peer_stats(h->net, peer, &ps), GS_OK);
    return sum + ps.rejected_total;
}

static uint64_t peer_rejected(const host *h, uint32_t peer, gs_reject r) {
    gs_peer_stats ps;
    assert_int_equal(gs_net_peer_stats(h->net, peer, &ps), GS_OK);
    return ps.rejected[r];
}

static uint64_t blended(const host *h) {
    gs_ghost_stats st;
    assert_int_equal(gs_ghost_get_stats(h->a, &st), GS_OK);
    return st.snapshots_blended;
}

/* Host 1 steps (blends what is queued); its toy must then hold base + i. */
static void expect_state(host *h, double base) {
    int i;
    assert_int_equal(gs_agent_step(h->a), GS_OK);
    for (i = 0; i < h->t.n; ++i) {
        if (fabs(h->t.x[i] - (base + i)) > 1e-9)
            print_error("value %d is %.17g, expected %.17g\n", i, h->t.x[i], base + i);
        assert_true(fabs(h->t.x[i] - (base + i)) <= 1e-9);
    }
}

/* ---- one encoding, every peer ---- */

/* gs_net_update encodes a snapshot once and sends it to every peer: each
   peer's datagram carries its own sequence and echo and its own CRC (or
   seal, with its own nonce), and each one is taken by its peer. Host 2
   has peers 1 and 3; host 1 was heard from first, so its echo differs. */
static void one_encoding_every_peer(const unsigned char *key) {
    host_opts o;
    host *h1, *h2, *h3;
    gs_reject why;
    size_t n;
    int k;
    memset(&o, 0, sizeof o);
    o.key = key;
    h1 = host_new(1, &o);
    o.peers[0] = 2;
    h3 = host_new(3, &o);
    o.peers[0] = 1;
    o.peers[1] = 3;
    h2 = host_new(2, &o);
    h1->now = 0.5;
    assert_int_equal(host_send(h1, 1.0), 1);
    assert_int_equal(deliver(h2, h1->out.data[0], h1->out.size[0], 0.6, &why), GS_OK);
    for (k = 0; k < 3; ++k) {
        h2->out.count = 0;
        assert_int_equal(host_send(h2, 10.0 * k), 2);
        assert_int_equal(h2->out.to[0], 1);
        assert_int_equal(h2->out.to[1], 3);
        n = h2->out.size[0];
        assert_int_equal(h2->out.size[1], n);
        if (!key) { /* the same bytes but the sequence, the echo and the CRC */
            const unsigned char *a = h2->out.data[0], *b = h2->out.data[1];
            assert_memory_equal(a, b, 16);
            assert_memory_equal(a + 20, b + 20, 12);
            assert_memory_equal(a + GS_WIRE_HEADER, b + GS_WIRE_HEADER, n - 4 - GS_WIRE_HEADER);
            assert_memory_not_equal(a + 32, b + 32, 8);
        }
        assert_int_equal(deliver(h1, h2->out.data[0], n, 1.0 + k, &why), GS_OK);
        expect_state(h1, 10.0 * k);
        assert_int_equal(deliver(h3, h2->out.data[1], n, 1.0 + k, &why), GS_OK);
        expect_state(h3, 10.0 * k);
    }
    host_free(h1);
    host_free(h2);
    host_free(h3);
}

static void test_one_encoding_every_peer(void **state) {
    (void)state;
    one_encoding_every_peer(NULL);
#ifdef GHOSTSIM_SODIUM
    one_encoding_every_peer(key_a);
#endif
}

/* ---- the key ---- */

#ifdef GHOSTSIM_SODIUM
static uint64_t get64(const unsigned char *p) {
    uint64_t v = 0;
    int i;
    for (i = 7; i >= 0; --i) v = v << 8 | p[i];
    return v;
}

static void test_key(void **state) {
    host *h1, *h2;
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    gs_wire_view *v = (gs_wire_view *)malloc(sizeof *v);
    host_opts o;
    gs_reject why;
    double marker = 1234.5678;
    size_t n, i;
    int seen = 0;
    (void)state;
    assert_non_null(v);
    memset(&o, 0, sizeof o);
    o.key = key_a;
    h1 = host_new(1, &o);
    h2 = host_new(2, &o);
    n = host_one(h2, marker, buf);
    /* sealed: the flag, the trailer instead of the CRC, no value in clear */
    assert_int_equal(buf[5], GS_WIRE_FLAG_SEALED);
    /* a first chunk's header (>>wire): kind, id and sequence varints of a
       byte each, its time, its element count */
    assert_int_equal(n, GS_WIRE_HEADER + 12 + 3 * 8 + GS_WIRE_SEAL_TRAILER);
    for (i = 0; i + 8 <= n; ++i) seen |= memcmp(buf + i, &marker, 8) == 0;
    assert_int_equal(seen, 0);
    /* the public decoder has no key: the trailer is no CRC */
    assert_int_equal(gs_wire_decode(buf, n, v, &why), GS_ERR_REJECTED);
    assert_int_equal(why, GS_REJECT_CHECKSUM);
    /* the net with the key takes it, and it is blended */
    assert_int_equal(deliver(h1, buf, n, 1.0, &why), GS_OK);
    expect_state(h1, marker);
    assert_int_equal(blended(h1), 1);
    free(v);
    host_free(h1);
    host_free(h2);
}

/* The nonce: a run's epoch and salt, then a counter that never repeats,
   whichever peer a datagram goes to; a restart brings a new salt and a
   later epoch. */
static void test_nonces_never_repeat(void **state) {
    enum { RUNS = 3, SENDS = 40 };
    static uint64_t seen[RUNS * SENDS * 2][3];
    host_opts o;
    int run, k, i, j, count = 0;
    (void)state;
    memset(&o, 0, sizeof o);
    o.key = key_a;
    o.peers[0] = 1;
    o.peers[1] = 3;
    for (run = 0; run < RUNS; ++run) {
        struct timespec ts = {0, 2000000};
        host *h2 = host_new(2, &o);
        for (k = 0; k < SENDS; ++k) {
            h2->out.count = 0;
            assert_int_equal(host_send(h2, k), 2); /* one to each peer */
            for (i = 0; i < 2; ++i) {
                const unsigned char *nonce = h2->out.data[i] + h2->out.size[i] - GS_WIRE_SEAL_TRAILER;
                seen[count][0] = get64(nonce);
                seen[count][1] = get64(nonce + 8);
                seen[count][2] = get64(nonce + 16);
                count++;
            }
        }
        host_free(h2);
        nanosleep(&ts, NULL); /* the epoch counts microseconds */
    }
    for (i = 0; i < count; ++i)
        for (j = i + 1; j < count; ++j)
            assert_false(seen[i][0] == seen[j][0] && seen[i][1] == seen[j][1] &&
                         seen[i][2] == seen[j][2]);
    for (run = 1; run < RUNS; ++run) {
        assert_true(seen[run * SENDS * 2][0] > seen[(run - 1) * SENDS * 2][0]);
        assert_true(seen[run * SENDS * 2][1] != seen[(run - 1) * SENDS * 2][1]);
    }
}
#endif

/* Without GHOSTSIM_SODIUM a key is refused, and says why. */
static void test_key_without_sodium(void **state) {
    host_opts o;
    gs_result r;
    host *h;
    (void)state;
    memset(&o, 0, sizeof o);
    o.key = key_a;
    h = host_try(1, &o, &r);
#ifdef GHOSTSIM_SODIUM
    assert_int_equal(r, GS_OK);
#else
    print_message("a key without GHOSTSIM_SODIUM: %s: \"%s\"\n", gs_result_str(r),
                  gs_world_error(h->w));
    assert_int_equal(r, GS_ERR_UNSUPPORTED);
    assert_non_null(strstr(gs_world_error(h->w), "GHOSTSIM_SODIUM"));
    assert_null(gs_world_net(h->w));
#endif
    host_free(h);
}

/* ---- forged, tampered, replayed ---- */

#ifdef GHOSTSIM_SODIUM
/* Every refusal is counted once, under its reason, on the peer or among
   the unknown ones; the state is not touched. */
static void expect_refused(host *h, const unsigned char *buf, size_t n, double now,
                           gs_reject expect) {
    uint64_t before = rejected_all(h, 2), b0 = blended(h);
    gs_reject why;
    assert_int_equal(deliver(h, buf, n, now, &why), GS_ERR_REJECTED);
    if (why != expect)
        print_error("expected %s, got %s\n", gs_reject_str(expect), gs_reject_str(why));
    assert_int_equal(why, expect);
    assert_int_equal(rejected_all(h, 2), before + 1);
    assert_int_equal(blended(h), b0);
}

static void test_forged_tampered_replayed(void **state) {
    host *h1, *h2, *wrong, *plain1, *plain2;
    unsigned char good[GS_WIRE_MAX_DATAGRAM], bad[GS_WIRE_MAX_DATAGRAM];
    host_opts o;
    gs_reject why;
    gs_peer_stats ps;
    size_t n, i;
    int bit;
    uint64_t counts[GS_REJECT_COUNT];
    (void)state;
    memset(&o, 0, sizeof o);
    memset(counts, 0, sizeof counts);
    o.key = key_a;
    h1 = host_new(1, &o);
    h2 = host_new(2, &o);
    n = host_one(h2, 10.0, good);
    assert_int_equal(deliver(h1, good, n, 1.0, &why), GS_OK);
    expect_state(h1, 10.0);

    /* replayed as it is */
    expect_refused(h1, good, n, 1.0, GS_REJECT_REPLAY);
    assert_int_equal(gs_net_peer_stats(h1->net, 2, &ps), GS_OK);
    assert_int_equal(ps.duplicates, 1);

    /* tampered: a fresh datagram with one bit flipped, each bit of each
       byte in turn: refused every time, and the right one is still taken */
    n = host_one(h2, 20.0, good);
    for (i = 0; i < n; ++i)
        for (bit = 0; bit < 8; ++bit) {
            uint64_t before = rejected_all(h1, 2);
            memcpy(bad, good, n);
            bad[i] ^= (unsigned char)(1u << bit);
            assert_int_equal(deliver(h1, bad, n, 1.0, &why), GS_ERR_REJECTED);
            assert_true(why < GS_REJECT_COUNT);
            counts[why]++;
            assert_int_equal(rejected_all(h1, 2), before + 1);
        }
    print_message("one bit flipped, %lu datagrams: magic %llu, version %llu, layout %llu, "
                  "session %llu, sender %llu, key %llu, replay %llu, auth %llu\n",
                  (unsigned long)(8 * n), (unsigned long long)counts[GS_REJECT_MAGIC],
                  (unsigned long long)counts[GS_REJECT_VERSION],
                  (unsigned long long)counts[GS_REJECT_LAYOUT],
                  (unsigned long long)counts[GS_REJECT_SESSION],
                  (unsigned long long)counts[GS_REJECT_SENDER],
                  (unsigned long long)counts[GS_REJECT_KEY],
                  (unsigned long long)counts[GS_REJECT_REPLAY],
                  (unsigned long long)counts[GS_REJECT_AUTH]);
    /* everything but the cheap fields fails authentication (or, for a
       counter or epoch flipped into the past, the replay window) */
    assert_int_equal(counts[GS_REJECT_MAGIC], 32);
    /* version 3's low two bits flipped read 2 and 1: old versions */
    assert_int_equal(counts[GS_REJECT_VERSION] + counts[GS_REJECT_OLD_VERSION], 8);
    /* the flags byte: the sealed bit and five unknown ones are refused
       on sight; bits 1 and 2 (the sender's sync) are allowed there, and
       the header is authenticated, so flipped they fail the tag */
    assert_int_equal(counts[GS_REJECT_LAYOUT] + counts[GS_REJECT_KEY], 6);
    assert_int_equal(counts[GS_REJECT_SESSION], 32);
    assert_int_equal(counts[GS_REJECT_SENDER], 32);
    assert_int_equal(counts[GS_REJECT_AUTH] + counts[GS_REJECT_REPLAY], 8 * n - 110);
    assert_true(counts[GS_REJECT_AUTH] > counts[GS_REJECT_REPLAY]);
    assert_int_equal(blended(h1), 1);
    assert_int_equal(deliver(h1, good, n, 1.0, &why), GS_OK); /* the window did not move */
    expect_state(h1, 20.0);

    /* forged from nothing: a datagram that looks sealed, from host 2, with
       a counter far ahead */
    memcpy(bad, good, n);
    for (i = GS_WIRE_HEADER; i < n; ++i) bad[i] = (unsigned char)(i * 7u + 3u);
    expect_refused(h1, bad, n, 1.0, GS_REJECT_AUTH);
    /* truncated or extended */
    expect_refused(h1, good, n - 1, 1.0, GS_REJECT_AUTH);
    memcpy(bad, good, n);
    bad[n] = 0; /* the nonce read one byte on: a later epoch or an earlier one */
    assert_int_equal(deliver(h1, bad, n + 1, 1.0, &why), GS_ERR_REJECTED);
    assert_true(why == GS_REJECT_AUTH || why == GS_REJECT_REPLAY);
    expect_refused(h1, good, GS_WIRE_HEADER + GS_WIRE_SEAL_TRAILER - 1, 1.0, GS_REJECT_SHORT);

    /* sealed under another key */
    wrong = host_new(2, &(host_opts){key_b, 0.0, 0, {0, 0, 0}});
    n = host_one(wrong, 30.0, bad);
    expect_refused(h1, bad, n, 1.0, GS_REJECT_AUTH);
    /* in clear to a net with a key; sealed to a net without (there the
       trailer is no CRC, as for gs_wire_decode) */
    plain1 = host_new(1, NULL);
    plain2 = host_new(2, NULL);
    n = host_one(plain2, 40.0, bad);
    expect_refused(h1, bad, n, 1.0, GS_REJECT_KEY);
    assert_int_equal(peer_rejected(h1, 2, GS_REJECT_KEY), 2); /* and the flag flipped above */
    n = host_one(h2, 50.0, bad);
    expect_refused(plain1, bad, n, 1.0, GS_REJECT_CHECKSUM);

    /* none of it reached host 1's state */
    expect_state(h1, 20.0);
    assert_int_equal(blended(h1), 2);
    assert_int_equal(gs_net_peer_stats(h1->net, 2, &ps), GS_OK);
    assert_int_equal(ps.datagrams_received, 2);
    host_free(h1);
    host_free(h2);
    host_free(wrong);
    host_free(plain1);
    host_free(plain2);
}

/* A restarted peer: its new run is taken at once; its earlier run, even a
   datagram never heard, is a replay from then on. Reordering within the
   window is taken; older than the window is not. */
static void test_restart_and_window(void **state) {
    static unsigned char late[300][GS_WIRE_MAX_DATAGRAM];
    static size_t late_n[300];
    unsigned char a1[GS_WIRE_MAX_DATAGRAM], a2[GS_WIRE_MAX_DATAGRAM], b1[GS_WIRE_MAX_DATAGRAM];
    struct timespec ts = {0, 2000000};
    host_opts o;
    host *h1, *h2;
    gs_reject why;
    size_t n1, n2, nb;
    int k;
    (void)state;
    memset(&o, 0, sizeof o);
    o.key = key_a;
    h1 = host_new(1, &o);
    h2 = host_new(2, &o);
    n1 = host_one(h2, 1.0, a1);
    n2 = host_one(h2, 2.0, a2); /* never delivered while run A lasts */
    assert_int_equal(deliver(h1, a1, n1, 1.0, &why), GS_OK);
    expect_state(h1, 1.0);
    host_free(h2);
    nanosleep(&ts, NULL);
    h2 = host_new(2, &o); /* run B: the same host and key, restarted */
    nb = host_one(h2, 3.0, b1);
    assert_int_equal(deliver(h1, b1, nb, 1.1, &why), GS_OK);
    expect_state(h1, 3.0);
    expect_refused(h1, a2, n2, 1.1, GS_REJECT_REPLAY); /* run A is over */
    expect_refused(h1, a1, n1, 1.1, GS_REJECT_REPLAY);
    expect_refused(h1, b1, nb, 1.1, GS_REJECT_REPLAY);
    /* 300 more of run B, delivered newest first from 10 on: 10..199 back
       are late but in the window (192 wide), the rest too old */
    for (k = 0; k < 300; ++k) late_n[k] = host_one(h2, 100.0 + k, late[k]);
    assert_int_equal(deliver(h1, late[299], late_n[299], 1.2, &why), GS_OK);
    for (k = 298; k >= 0; --k) {
        gs_result r = deliver(h1, late[k], late_n[k], 1.2, &why);
        if (299 - k < 192) {
            assert_int_equal(r, GS_OK);
        } else {
            assert_int_equal(r, GS_ERR_REJECTED);
            assert_int_equal(why, GS_REJECT_REPLAY);
        }
    }
    assert_int_equal(peer_rejected(h1, 2, GS_REJECT_REPLAY), 3 + 300 - 192);
    host_free(h1);
    host_free(h2);
}
#endif /* GHOSTSIM_SODIUM */

/* ---- the receive cap ---- */

#ifdef GHOSTSIM_SODIUM
#define TEST_KEY key_a
#define TEST_MODE "sealed"
#else
#define TEST_KEY NULL
#define TEST_MODE "in clear"
#endif

static void test_rate_cap(void **state) {
    static unsigned char dg[240][GS_WIRE_MAX_DATAGRAM];
    static size_t dn[240];
    host_opts o;
    host *h1, *h2;
    gs_reject why;
    gs_peer_stats ps;
    int k, ok = 0;
    (void)state;
    memset(&o, 0, sizeof o);
    o.key = TEST_KEY;
    o.max_rate = 100.0; /* a burst of 25, then 100/s */
    h1 = host_new(1, &o);
    o.max_rate = 0.0;
    h2 = host_new(2, &o);
    for (k = 0; k < 240; ++k) dn[k] = host_one(h2, k, dg[k]);
#ifdef GHOSTSIM_SODIUM
    { /* forgeries do not spend the peer's rate: 1000 first */
        unsigned char bad[GS_WIRE_MAX_DATAGRAM];
        int f;
        for (f = 0; f < 1000; ++f) {
            memcpy(bad, dg[0], dn[0]);
            bad[GS_WIRE_HEADER + (size_t)f % 24] ^= 0x10;
            bad[dn[0] - 24] = (unsigned char)f; /* a counter of its own */
            bad[dn[0] - 23] = (unsigned char)(f >> 8);
            assert_int_equal(deliver(h1, bad, dn[0], 10.0, &why), GS_ERR_REJECTED);
            assert_int_equal(why, GS_REJECT_AUTH);
        }
    }
#endif
    for (k = 0; k < 200; ++k) ok += deliver(h1, dg[k], dn[k], 10.0, &why) == GS_OK;
    assert_int_equal(ok, 25);
    assert_int_equal(peer_rejected(h1, 2, GS_REJECT_RATE), 175);
    for (k = 200; k < 240; ++k) ok += deliver(h1, dg[k], dn[k], 10.125, &why) == GS_OK;
    assert_int_equal(ok, 37); /* 0.125 s refilled 12.5 */
    assert_int_equal(gs_net_peer_stats(h1->net, 2, &ps), GS_OK);
    assert_int_equal(ps.datagrams_received, 37);
    assert_int_equal(ps.rejected[GS_REJECT_RATE], 175 + 28);
    /* a clock that goes back refills nothing */
    h2->out.count = 0;
    dn[0] = host_one(h2, 1.0, dg[0]);
    assert_int_equal(deliver(h1, dg[0], dn[0], 5.0, &why), GS_ERR_REJECTED);
    assert_int_equal(why, GS_REJECT_RATE);
    host_free(h1);
    host_free(h2);
}

/* ---- the flood ---- */

static uint64_t rng_state = 0x9e3779b97f4a7c15ull;
static uint64_t rng(void) {
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return rng_state;
}

static void put32(unsigned char *p, uint32_t v) {
    p[0] = (unsigned char)v; p[1] = (unsigned char)(v >> 8);
    p[2] = (unsigned char)(v >> 16); p[3] = (unsigned char)(v >> 24);
}

/* Resident memory of the process (kB), from /proc; 0 if unknown. */
static long rss_kb(void) {
    FILE *f = fopen("/proc/self/statm", "r");
    long pages = 0, resident = 0;
    if (!f) return 0;
    if (fscanf(f, "%ld %ld", &pages, &resident) != 2) resident = 0;
    fclose(f);
    return resident * 4;
}

/* One flood datagram of kind k into buf; returns its size. `recent` is a
   legitimate datagram already delivered (its replay), `tmpl` one of the
   right shape never delivered (forgeries are made from it). */
static size_t flood_one(unsigned char *buf, int kind, const unsigned char *recent,
                        size_t recent_n, const unsigned char *tmpl, size_t tmpl_n) {
    size_t n, i;
    uint64_t r = rng();
    switch (kind) {
    case 0: /* noise of any length */
        n = (size_t)(r % (GS_WIRE_MAX_DATAGRAM + 1));
        for (i = 0; i + 8 <= n; i += 8) {
            uint64_t x = rng();
            memcpy(buf + i, &x, 8);
        }
        for (; i < n; ++i) buf[i] = (unsigned char)rng();
        return n;
    case 1: /* noise behind a good magic and version */
        n = flood_one(buf, 0, recent, recent_n, tmpl, tmpl_n);
        if (n < 8) return n;
        memcpy(buf, "GSIM", 4);
        buf[4] = GS_WIRE_VERSION;
        return n;
    case 2: /* the right shape from host 2, chunks scrambled, a fresh counter */
        memcpy(buf, tmpl, tmpl_n);
        for (i = 0; i < 4; ++i)
            buf[GS_WIRE_HEADER + (size_t)((r >> (8 * i)) % (tmpl_n - GS_WIRE_HEADER - 40))] ^=
                (unsigned char)(1u << i);
        put32(buf + tmpl_n - 24, (uint32_t)(r >> 32)); /* the counter, when sealed */
        return tmpl_n;
    case 3: /* a replay */
        memcpy(buf, recent, recent_n);
        return recent_n;
    case 4: /* an unknown sender */
        memcpy(buf, tmpl, tmpl_n);
        put32(buf + 12, 9 + (uint32_t)(r % 1000));
        return tmpl_n;
    default: /* another session */
        memcpy(buf, tmpl, tmpl_n);
        put32(buf + 8, 2 + (uint32_t)(r % 1000));
        return tmpl_n;
    }
}

static void test_flood(void **state) {
    const long total = 1000000, every = 1000; /* a legitimate datagram every 1000 */
    unsigned char buf[GS_WIRE_MAX_DATAGRAM], recent[GS_WIRE_MAX_DATAGRAM],
        tmpl[GS_WIRE_MAX_DATAGRAM];
    size_t recent_n, tmpl_n;
    host_opts o;
    host *h1, *h2;
    gs_reject why;
    gs_peer_stats ps;
    counter before;
    uint64_t rej0, b0, kinds[6] = {0, 0, 0, 0, 0, 0}, reasons[GS_REJECT_COUNT];
    long i, legit = 0, rss0, rss1;
    double now = 100.0, t0, t1, base = 0.0;
    struct timespec ts;
    (void)state;
    memset(&o, 0, sizeof o);
    memset(reasons, 0, sizeof reasons);
    o.key = TEST_KEY;
    o.n = 64;
    h1 = host_new(1, &o);
    h2 = host_new(2, &o);
    recent_n = host_one(h2, -1.0, recent);
    assert_int_equal(deliver(h1, recent, recent_n, now, &why), GS_OK);
    tmpl_n = host_one(h2, -2.0, tmpl); /* never delivered */
    assert_int_equal(gs_agent_step(h1->a), GS_OK);
    before = h1->mem;
    rej0 = rejected_all(h1, 2);
    b0 = blended(h1);
    rss0 = rss_kb();
    clock_gettime(CLOCK_MONOTONIC, &ts);
    t0 = (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
    for (i = 0; i < total; ++i) {
        int kind = (int)(i % 6);
        size_t n = flood_one(buf, kind, recent, recent_n, tmpl, tmpl_n);
        now += 1e-5; /* 100 000 a second */
        if (deliver(h1, buf, n, now, &why) == GS_OK) {
            print_error("flood datagram %ld (kind %d, %lu B) was taken\n", i, kind,
                        (unsigned long)n);
            fail();
        }
        kinds[kind]++;
        reasons[why]++;
        if (i % every == every - 1) { /* host 2 speaks: taken and blended */
            base = (double)(i / every) * 1000.0;
            recent_n = host_one(h2, base, recent);
            assert_int_equal(deliver(h1, recent, recent_n, now, &why), GS_OK);
            expect_state(h1, base);
            legit++;
        }
    }
    clock_gettime(CLOCK_MONOTONIC, &ts);
    t1 = (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
    rss1 = rss_kb();
    print_message("flood (%s): %ld datagrams refused in %.2f s (%.2f us each); world memory "
                  "%lu B live, peak %lu B before and after, %lu allocations during; RSS %ld -> "
                  "%ld kB; %ld legitimate snapshots all blended\n",
                  TEST_MODE, total, t1 - t0, (t1 - t0) / (double)total * 1e6,
                  (unsigned long)h1->mem.live, (unsigned long)h1->mem.peak,
                  h1->mem.calls - before.calls, rss0, rss1, legit);
    print_message("flood reasons:");
    for (i = 0; i < GS_REJECT_COUNT; ++i)
        if (reasons[i]) print_message(" %s %llu;", gs_reject_str((gs_reject)i), (unsigned long long)reasons[i]);
    print_message("\n");
    /* memory: not a byte more, not an allocation */
    assert_int_equal(h1->mem.live, before.live);
    assert_int_equal(h1->mem.peak, before.peak);
    assert_int_equal(h1->mem.calls, before.calls);
    /* every flood datagram refused and counted; every legitimate one taken */
    assert_int_equal(rejected_all(h1, 2), rej0 + (uint64_t)total);
    assert_int_equal(blended(h1), b0 + (uint64_t)legit);
    assert_int_equal(legit, total / every);
    assert_int_equal(gs_net_peer_stats(h1->net, 2, &ps), GS_OK);
    assert_int_equal(ps.datagrams_received, (uint64_t)legit + 1);
    assert_int_equal(ps.rejected[GS_REJECT_RATE], 0);
#ifdef GHOSTSIM_SODIUM
    assert_true(reasons[GS_REJECT_AUTH] + 10 >= kinds[2]); /* a random counter may be old */
    assert_int_equal(reasons[GS_REJECT_REPLAY] + reasons[GS_REJECT_AUTH], kinds[2] + kinds[3]);
#endif
    host_free(h1);
    host_free(h2);
}

/* ---- the cost of the seal ---- */

#ifdef GHOSTSIM_SODIUM
static double mono(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* One full datagram (135 f64, about 1183 B sealed, 1147 B in clear) through
   gs_net_update on host 2 and gs_net_deliver on host 1, sealed and in
   clear in alternating blocks; the median block's time per datagram. */
static void test_seal_cost(void **state) {
    enum { BLOCKS = 21, PER = 500 };
    double t_seal[BLOCKS], t_clear[BLOCKS], send_s, recv_s;
    host *pair[2][2];
    host_opts o;
    gs_reject why;
    int mode, b, k;
    (void)state;
    memset(&o, 0, sizeof o);
    o.n = TOY_MAX;
    o.max_rate = 1e12;
    for (mode = 0; mode < 2; ++mode) {
        o.key = mode ? key_a : NULL;
        pair[mode][0] = host_new(1, &o);
        pair[mode][1] = host_new(2, &o);
    }
    for (b = 0; b < BLOCKS; ++b)
        for (mode = 0; mode < 2; ++mode) {
            host *h1 = pair[mode][0], *h2 = pair[mode][1];
            double t0 = mono();
            for (k = 0; k < PER; ++k) {
                h2->out.count = 0;
                assert_int_equal(gs_agent_step(h2->a), GS_OK);
                h2->now += 0.002;
                gs_net_update(h2->net, h2->now);
                assert_int_equal(deliver(h1, h2->out.data[0], h2->out.size[0], h2->now, &why),
                                 GS_OK);
            }
            (mode ? t_seal : t_clear)[b] = (mono() - t0) / PER;
            /* one full chunk: its header's sequence varint grows with the
               run (>>wire), so the size is known to a few bytes */
            assert_true(h2->out.size[0] >= (mode ? 1180u : 1144u) &&
                        h2->out.size[0] <= (mode ? 1186u : 1150u));
        }
    qsort(t_seal, BLOCKS, sizeof(double), cmp_double);
    qsort(t_clear, BLOCKS, sizeof(double), cmp_double);
    { /* libsodium alone, the same bytes */
        unsigned char m[1200], out[1200], n24[24], tag[16];
        unsigned long long tl;
        double t0;
        memset(m, 1, sizeof m);
        memset(n24, 2, sizeof n24);
        t0 = mono();
        for (k = 0; k < 20000; ++k) {
            n24[0] = (unsigned char)k;
            crypto_aead_xchacha20poly1305_ietf_encrypt_detached(m + 48, tag, &tl, m + 48, 1112, m,
                                                                48, NULL, n24, key_a);
        }
        send_s = (mono() - t0) / 20000;
        t0 = mono();
        for (k = 0; k < 20000; ++k) /* the last seal's: authentic, decrypted */
            assert_int_equal(crypto_aead_xchacha20poly1305_ietf_decrypt_detached(
                                 out + 48, NULL, m + 48, 1112, tag, m, 48, n24, key_a), 0);
        recv_s = (mono() - t0) / 20000;
    }
    print_message("seal cost, one full datagram sent and received (median of %d blocks of %d): "
                  "sealed %.2f us, in clear %.2f us, difference %.2f us; libsodium alone: "
                  "seal %.2f us + open %.2f us\n",
                  BLOCKS, PER, t_seal[BLOCKS / 2] * 1e6, t_clear[BLOCKS / 2] * 1e6,
                  (t_seal[BLOCKS / 2] - t_clear[BLOCKS / 2]) * 1e6, send_s * 1e6, recv_s * 1e6);
    assert_true(t_seal[BLOCKS / 2] < 1e-3); /* a loose bound: a shared machine */
    for (mode = 0; mode < 2; ++mode) {
        host_free(pair[mode][0]);
        host_free(pair[mode][1]);
    }
}
#endif

/* ---- UDP: the allow-list ---- */
#ifndef GHOSTSIM_NO_UDP

typedef struct udp_host {
    host *h;
    gs_net *u;
} udp_host;

/* Host id on a poll-mode socket at addr, with the toy and its ghost. */
static void udp_host_open(udp_host *x, uint32_t id, const char *addr) {
    gs_world_desc wd = gs_world_desc_default();
    gs_custom_desc cd;
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_udp_desc ud;
    gs_net_desc nd = gs_net_desc_default();
    gs_result r;
    x->h = (host *)calloc(1, sizeof *x->h);
    assert_non_null(x->h);
    wd.host_id = id;
    assert_int_equal(gs_world_create(&wd, &x->h->w), GS_OK);
    x->h->t.n = 3;
    memset(&cd, 0, sizeof cd);
    cd.dt = 0.01;
    cd.state_size = 3;
    cd.step = toy_step;
    cd.get_state = toy_get;
    cd.set_state = toy_set;
    cd.user = &x->h->t;
    assert_int_equal(gs_custom_create(x->h->w, &cd, &x->h->a), GS_OK);
    gd.object_id = 5;
    gd.weight = gs_weight_owner;
    gd.owner = 2;
    gd.send_rate = 1000.0;
    gd.time_deadband = -1.0;
    assert_int_equal(gs_ghost_attach(x->h->a, &gd), GS_OK);
    memset(&ud, 0, sizeof ud);
    ud.bind = addr;
    nd.key = TEST_KEY;
    r = test_udp_open(x->h->w, &ud, &nd, &x->u);
    if (r != GS_OK) print_error("udp net %s: %s\n", addr, gs_world_error(x->h->w));
    assert_int_equal(r, GS_OK);
}

static void udp_host_close(udp_host *x) {
    gs_net_destroy(x->u);
    gs_world_destroy(x->h->w);
    free(x->h);
}

/* Host x steps with its toy at `v` and sends (`times` times); host `to`
   polls meanwhile, so that what was sent arrives. */
static void udp_round(udp_host *x, double v, udp_host *to, int times) {
    struct timespec ts = {0, 2000000};
    int i, k;
    for (k = 0; k < times; ++k) {
        for (i = 0; i < 3; ++i) x->h->t.x[i] = v + i;
        assert_int_equal(gs_agent_step(x->h->a), GS_OK);
        nanosleep(&ts, NULL); /* the ghost is due again (1 ms) */
        assert_int_equal(gs_net_poll(x->u, gs_udp_now()), GS_OK);
    }
    for (k = 0; k < 5; ++k) {
        nanosleep(&ts, NULL);
        assert_int_equal(gs_net_poll(to->u, gs_udp_now()), GS_OK);
    }
}

static uint64_t udp_rejected(udp_host *x, uint32_t peer, gs_reject r) {
    gs_peer_stats ps;
    assert_int_equal(gs_net_peer_stats(x->u, peer, &ps), GS_OK);
    return ps.rejected[r];
}

/* Host 1 at a, host 2 at b, and an impostor that also says it is host 2,
   at c. */
static void allow_list(const char *a, const char *b, const char *c, const char *label) {
    udp_host x[3];
    gs_peer_stats ps;
    uint64_t b0;
    udp_host_open(&x[0], 1, a);
    udp_host_open(&x[1], 2, b);
    udp_host_open(&x[2], 2, c);
    assert_int_equal(gs_net_add_peer(x[0].u, 2, b), GS_OK);
    assert_int_equal(gs_net_add_peer(x[1].u, 1, a), GS_OK);
    assert_int_equal(gs_net_add_peer(x[2].u, 1, a), GS_OK);
    /* the impostor speaks: refused by address, counted on peer 2, not blended */
    udp_round(&x[2], 66.0, &x[0], 1);
    assert_true(udp_rejected(&x[0], 2, GS_REJECT_ADDRESS) >= 1);
    assert_int_equal(blended(x[0].h), 0);
    assert_int_equal(gs_agent_step(x[0].h->a), GS_OK);
    assert_true(x[0].h->t.x[0] == 0.0);
    /* the real host 2 speaks: taken */
    udp_round(&x[1], 7.0, &x[0], 1);
    assert_int_equal(gs_agent_step(x[0].h->a), GS_OK);
    assert_true(blended(x[0].h) >= 1);
    assert_true(x[0].h->t.x[0] == 7.0);
    /* host 2 moves to c at run time: now c is taken and b refused */
    assert_int_equal(gs_net_add_peer(x[0].u, 2, c), GS_OK);
    b0 = udp_rejected(&x[0], 2, GS_REJECT_ADDRESS);
    udp_round(&x[1], 8.0, &x[0], 1);
    assert_true(udp_rejected(&x[0], 2, GS_REJECT_ADDRESS) > b0);
    udp_round(&x[2], 9.0, &x[0], 3); /* in clear, past host 2's sequence */
    assert_int_equal(gs_agent_step(x[0].h->a), GS_OK);
    assert_true(x[0].h->t.x[0] == 9.0);
    assert_int_equal(gs_net_peer_stats(x[0].u, 2, &ps), GS_OK);
    print_message("allow-list %s: %llu refused by address, %llu datagrams taken\n", label,
                  (unsigned long long)ps.rejected[GS_REJECT_ADDRESS],
                  (unsigned long long)ps.datagrams_received);
    udp_host_close(&x[0]);
    udp_host_close(&x[1]);
    udp_host_close(&x[2]);
}

static void allow_list_on(int v6, const char *label) {
    char a[3][64];
    int i;
    for (i = 0; i < 3; ++i)
        if (!loopback_addr(v6, a[i], sizeof a[i])) {
            print_message("allow-list %s: no loopback here, skipped\n", label);
            skip();
        }
    allow_list(a[0], a[1], a[2], label);
}

static void test_udp_allow_list(void **state) {
    (void)state;
    allow_list_on(0, "ipv4");
}

static void test_udp_allow_list_ipv6(void **state) {
    (void)state;
    allow_list_on(1, "ipv6");
}
#endif /* GHOSTSIM_NO_UDP */

int main(int argc, char **argv) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_key_without_sodium),
        cmocka_unit_test(test_one_encoding_every_peer),
#ifdef GHOSTSIM_SODIUM
        cmocka_unit_test(test_key),
        cmocka_unit_test(test_nonces_never_repeat),
        cmocka_unit_test(test_forged_tampered_replayed),
        cmocka_unit_test(test_restart_and_window),
        cmocka_unit_test(test_seal_cost),
#endif
        cmocka_unit_test(test_rate_cap),
        cmocka_unit_test(test_flood),
#ifndef GHOSTSIM_NO_UDP
        cmocka_unit_test(test_udp_allow_list),
        cmocka_unit_test(test_udp_allow_list_ipv6),
#endif
    };
    if (argc > 1) cmocka_set_test_filter(argv[1]);
#ifdef GHOSTSIM_SODIUM
    return cmocka_run_group_tests_name("security (sealed)", tests, NULL, NULL);
#else
    return cmocka_run_group_tests_name("security (no GHOSTSIM_SODIUM)", tests, NULL, NULL);
#endif
}
