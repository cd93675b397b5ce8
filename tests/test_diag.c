/* test_diag.c - the mistakes that were silent, each with what now says so.

   Issue 18, item 5: forgetting to poll, to call gs_net_update or to add a
   peer sent nothing and said nothing; every datagram refused for one
   reason (mismatched ids, another state size, session or key) showed only
   as a counter; a clock that went back was taken without a word;
   gs_simnet_link before a join failed with no text; a failing custom step
   left a stale error text. What holds now, each case below:
   - gs_peer_stats.health / .reason say, with the figures, which of
     silent, refused (and what did not match), clock back, not sending or
     no update holds for a peer (see gs_peer_health in the header), and
     whether it runs another sync mode or clock (issue 15: three hosts in
     replay joined by one in present ended 15 cm apart, and nothing said
     why);
   - gs_world_diagnose says it for the world, and what no peer can: ghosts
     and no net, a net and no peers, a net and no ghosts;
   - gs_simnet_error holds the simnet's failures; gs_world_error names a
     failing custom agent and is "" after a good advance.

   Two hosts (1 and 2) in one process: each a world with one custom agent
   (a still point, ghosted) and a net whose send callback keeps the
   datagrams; the test carries them over at the clock it chooses. Every
   loop is a fixed number of frames; no test reads a clock. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ghostsim.h"
#include "net_helpers.h"
#include "world_helpers.h"

#define FRAME (1.0 / 60.0)
#define BOX 256 /* datagrams a host keeps between two carries */

typedef struct box {
    int n;
    size_t size[BOX];
    unsigned char data[BOX][GS_WIRE_MAX_DATAGRAM];
} box;

typedef struct host {
    double now;   /* s; what its session clock reads (run sets it) */
    gs_world *w;
    gs_agent *a;
    double x[8];
    gs_net *net;
    box out;
} host;

static gs_result still_step(void *user, double t, double dt) {
    (void)user; (void)t; (void)dt;
    return GS_OK;
}
/* state_size is read from x[7] (a host's points have 3 or 6 values) */
static void still_get(const void *user, double *out) {
    const double *x = (const double *)user;
    memcpy(out, x, (size_t)x[7] * sizeof(double));
}
static gs_result still_set(void *user, const double *in) {
    double *x = (double *)user;
    memcpy(x, in, (size_t)x[7] * sizeof(double));
    return GS_OK;
}
static gs_result keep_send(void *user, uint32_t to, const void *data, size_t size) {
    box *b = &((host *)user)->out;
    (void)to;
    if (b->n < BOX) {
        memcpy(b->data[b->n], data, size);
        b->size[b->n++] = size;
    }
    return GS_OK;
}

typedef struct host_opts {
    uint32_t object;     /* 0: no ghost */
    int values;          /* the point's state values: 3 or 6 */
    uint32_t session;    /* 0: default */
    int no_net, no_peer;
    const unsigned char *key;
    gs_sync_mode mode;   /* the world's gs_sync_desc (0: defaults) */
    gs_sync_clock clock;
} host_opts;

static double host_clock(void *user) { return *(const double *)user; }

static host *host_new(uint32_t id, uint32_t peer, const host_opts *o) {
    host *h = (host *)calloc(1, sizeof *h);
    gs_net_desc nd = gs_net_desc_default();
    assert_non_null(h);
    if (o->mode || o->clock) {
        gs_world_desc wd = gs_world_desc_default();
        wd.host_id = id;
        wd.sync.mode = o->mode;
        wd.sync.clock = o->clock;
        wd.sync.now = host_clock; /* the test's clock, not the machine's */
        wd.sync.now_user = &h->now;
        assert_int_equal(gs_world_create(&wd, &h->w), GS_OK);
    } else {
        h->w = world_new(id);
    }
    h->x[7] = o->values ? o->values : 3;
    h->a = custom_new(h->w, 0.002, (size_t)h->x[7], still_step, still_get, still_set, h->x);
    if (o->object) {
        gs_ghost_desc gd = gs_ghost_desc_default();
        gd.object_id = o->object;
        assert_int_equal(gs_ghost_attach(h->a, &gd), GS_OK);
    }
    if (o->no_net) return h;
    nd.session = o->session;
    nd.key = o->key;
    assert_int_equal(send_only_net(h->w, &nd, keep_send, h, &h->net), GS_OK);
    if (!o->no_peer) assert_int_equal(gs_net_add_peer(h->net, peer, NULL), GS_OK);
    return h;
}

static void host_free(host *h) {
    gs_world_destroy(h->w);
    free(h);
}

/* Hands what `from` sent to `to` at `now`; returns how many were taken. */
static int carry(host *from, host *to, double now) {
    int i, taken = 0;
    for (i = 0; i < from->out.n; ++i)
        taken += gs_net_deliver(to->net, from->out.data[i], from->out.size[i], now, NULL) ==
                 GS_OK;
    from->out.n = 0;
    return taken;
}

/* `frames` frames from *now on: each host advances, updates (unless its
   `update` flag is 0) and the datagrams cross both ways. */
static void run(host *a, host *b, int frames, double *now, int update_a, int update_b) {
    int k;
    for (k = 0; k < frames; ++k) {
        *now += FRAME;
        a->now = b->now = *now;
        assert_int_equal(gs_world_advance(a->w, FRAME, NULL), GS_OK);
        assert_int_equal(gs_world_advance(b->w, FRAME, NULL), GS_OK);
        if (update_a) assert_int_equal(gs_net_update(a->net, *now), GS_OK);
        if (update_b) assert_int_equal(gs_net_update(b->net, *now), GS_OK);
        carry(a, b, *now);
        carry(b, a, *now);
    }
}

/* Host h's stats of peer, its reason shown (what a user would read). */
static gs_peer_stats stats(const host *h, uint32_t peer) {
    gs_peer_stats st;
    memset(&st, 0, sizeof st);
    assert_int_equal(gs_net_peer_stats(h->net, peer, &st), GS_OK);
    if (st.health != GS_PEER_OK)
        print_message("host %u, peer %u: %s: %s\n", (unsigned)gs_world_host_id(h->w),
                      (unsigned)peer, gs_peer_health_str(st.health), st.reason);
    return st;
}

static void assert_contains(const char *text, const char *part) {
    if (!strstr(text, part)) fail_msg("\"%s\" is not in \"%s\"", part, text);
}

static const host_opts plain = {7, 3, 0, 0, 0, NULL, GS_SYNC_DEFAULT, GS_SYNC_CLOCK_DEFAULT};

/* ---- the good case: nothing to say ---- */

static void test_ok_both_ways(void **state) {
    host *a = host_new(1, 2, &plain), *b = host_new(2, 1, &plain);
    gs_peer_stats st;
    double now = 10.0;
    (void)state;
    run(a, b, 90, &now, 1, 1);
    st = stats(a, 2);
    assert_int_equal(st.health, GS_PEER_OK);
    assert_string_equal(st.reason, "");
    assert_int_equal(st.refused_reason, GS_REJECT_COUNT);
    assert_int_equal(st.clock_backwards, 0);
    assert_int_equal(stats(b, 1).health, GS_PEER_OK);
    assert_string_equal(gs_world_diagnose(a->w), "");
    assert_string_equal(gs_world_diagnose(b->w), "");
    host_free(a);
    host_free(b);
}

static void test_health_names(void **state) {
    int h;
    (void)state;
    for (h = 0; h < GS_PEER_HEALTH_COUNT; ++h)
        assert_string_not_equal(gs_peer_health_str((gs_peer_health)h), "unknown");
    assert_string_equal(gs_peer_health_str(GS_PEER_SILENT), "silent");
    assert_string_equal(gs_peer_health_str(GS_PEER_HEALTH_COUNT), "unknown");
    assert_string_equal(gs_world_diagnose(NULL), "");
}

/* ---- hosts of one session in different sync modes ---- */

/* Host 1 replays on the session clock, host 2 blends at its present on its
   local clock: each says the other runs another mode, naming both, and
   still takes the other's datagrams (nobody stops). */
static void test_other_mode(void **state) {
    host_opts r = plain;
    host *a, *b;
    gs_peer_stats st;
    double now = 10.0;
    (void)state;
    r.mode = GS_SYNC_REPLAY;
    r.clock = GS_SYNC_CLOCK_SESSION;
    a = host_new(1, 2, &r);
    b = host_new(2, 1, &plain);
    run(a, b, 90, &now, 1, 1);
    st = stats(a, 2);
    assert_int_equal(st.health, GS_PEER_OTHER_MODE);
    assert_contains(st.reason, "this peer runs the present blend on its local clock");
    assert_contains(st.reason, "this host the replay blend on the session clock");
    assert_true(st.datagrams_received > 0);
    st = stats(b, 1);
    assert_int_equal(st.health, GS_PEER_OTHER_MODE);
    assert_contains(st.reason, "this peer runs the replay blend on the session clock");
    assert_true(st.datagrams_received > 0);
    assert_contains(gs_world_diagnose(a->w), "other_mode");
    assert_string_equal(gs_peer_health_str(GS_PEER_OTHER_MODE), "other_mode");
    host_free(a);
    host_free(b);
}

/* Hosts 1 (of oa) and 2 (of ob) run 1.5 s together; each sees the other
   as `want`. */
static void pair_health(const host_opts *oa, const host_opts *ob, gs_peer_health want) {
    host *a = host_new(1, 2, oa), *b = host_new(2, 1, ob);
    double now = 10.0;
    run(a, b, 90, &now, 1, 1);
    assert_int_equal(stats(a, 2).health, want);
    assert_int_equal(stats(b, 1).health, want);
    host_free(a);
    host_free(b);
}

/* The clock alone differs (both present): still another mode. Both on the
   session clock, and both in replay: nothing to say. */
static void test_other_clock_and_same_mode(void **state) {
    host_opts s = plain, r = plain;
    host *a, *b;
    double now = 10.0;
    (void)state;
    s.clock = GS_SYNC_CLOCK_SESSION;
    a = host_new(1, 2, &s);
    b = host_new(2, 1, &plain);
    run(a, b, 90, &now, 1, 1);
    assert_contains(stats(a, 2).reason, "this host the present blend on the session clock");
    host_free(a);
    host_free(b);
    pair_health(&s, &plain, GS_PEER_OTHER_MODE);
    pair_health(&s, &s, GS_PEER_OK);
    r.mode = GS_SYNC_REPLAY;
    r.clock = GS_SYNC_CLOCK_SESSION;
    pair_health(&r, &r, GS_PEER_OK);
}

/* ---- silence: the peer did not add this host, or stopped ---- */

/* Host 2 never added host 1: it refuses host 1's datagrams (unknown
   sender) and sends nothing. Host 1 waits for a second, then says so. */
static void test_peer_not_added_is_silent(void **state) {
    host_opts o2 = plain;
    host *a = host_new(1, 2, &plain), *b;
    gs_peer_stats st;
    gs_unknown_stats unknown;
    double now = 10.0;
    (void)state;
    o2.no_peer = 1;
    b = host_new(2, 1, &o2);
    run(a, b, 30, &now, 1, 1); /* half a second: too early to tell */
    st = stats(a, 2);
    assert_int_equal(st.health, GS_PEER_WAITING);
    assert_contains(st.reason, "nothing received from it yet");
    run(a, b, 40, &now, 1, 1); /* 1.17 s */
    st = stats(a, 2);
    assert_int_equal(st.health, GS_PEER_SILENT);
    assert_contains(st.reason, "nothing received from this peer in the 1.");
    assert_contains(st.reason, "has it added this host (1) as a peer");
    assert_contains(gs_world_diagnose(a->w), "peer 2: silent: nothing received");
    /* the other side: no peers, and host 1's datagrams refused unknown */
    assert_contains(gs_world_diagnose(b->w), "a net and no peers: nothing is sent");
    assert_int_equal(gs_net_unknown_stats(b->net, &unknown), GS_OK);
    assert_true(unknown.rejected[GS_REJECT_SENDER] > 0);
    host_free(a);
    host_free(b);
}

/* A peer heard, then not (it stopped, or the link went down). */
static void test_peer_stops(void **state) {
    host *a = host_new(1, 2, &plain), *b = host_new(2, 1, &plain);
    gs_peer_stats st;
    double now = 10.0;
    int k;
    (void)state;
    run(a, b, 60, &now, 1, 1);
    assert_int_equal(stats(a, 2).health, GS_PEER_OK);
    for (k = 0; k < 72; ++k) { /* 1.2 s: host 2's datagrams are lost */
        now += FRAME;
        assert_int_equal(gs_world_advance(a->w, FRAME, NULL), GS_OK);
        assert_int_equal(gs_net_update(a->net, now), GS_OK);
        assert_int_equal(gs_net_update(b->net, now), GS_OK);
        a->out.n = b->out.n = 0;
    }
    st = stats(a, 2);
    assert_int_equal(st.health, GS_PEER_SILENT);
    assert_contains(st.reason, "nothing received from this peer for 1.2 s");
    run(a, b, 3, &now, 1, 1); /* it comes back */
    assert_int_equal(stats(a, 2).health, GS_PEER_OK);
    host_free(a);
    host_free(b);
}

/* ---- nothing sent ---- */

/* The world advances and gs_net_update is never called (a transport of
   one's own, and the call forgotten). Host 2 says it hears nothing. */
static void test_update_never_called(void **state) {
    host *a = host_new(1, 2, &plain), *b = host_new(2, 1, &plain);
    gs_peer_stats st;
    double now = 10.0;
    (void)state;
    run(a, b, 70, &now, 0, 1);
    st = stats(a, 2);
    assert_int_equal(st.health, GS_PEER_NO_UPDATE);
    assert_contains(st.reason, "gs_net_update has not run for 1.2 s of world time");
    assert_contains(st.reason, "never called");
    assert_int_equal(stats(b, 1).health, GS_PEER_SILENT);
    assert_contains(gs_world_diagnose(a->w), "peer 2: no_update: nothing sent");
    run(a, b, 2, &now, 1, 1); /* called again */
    assert_int_equal(stats(a, 2).health, GS_PEER_OK);
    run(a, b, 70, &now, 0, 1); /* and forgotten again */
    assert_contains(stats(a, 2).reason, "since its last call");
    host_free(a);
    host_free(b);
}

/* Datagrams delivered, the world not advanced, update not called: the
   net's own clock tells. */
static void test_update_not_called_while_delivering(void **state) {
    host *a = host_new(1, 2, &plain), *b = host_new(2, 1, &plain);
    gs_peer_stats st;
    double now = 10.0;
    int k;
    (void)state;
    for (k = 0; k < 70; ++k) {
        now += FRAME;
        assert_int_equal(gs_world_advance(b->w, FRAME, NULL), GS_OK);
        assert_int_equal(gs_net_update(b->net, now), GS_OK);
        carry(b, a, now);
    }
    st = stats(a, 2);
    assert_int_equal(st.health, GS_PEER_NO_UPDATE);
    assert_contains(st.reason, "gs_net_update has not run for 1.");
    assert_contains(st.reason, "gs_net_deliver has");
    host_free(a);
    host_free(b);
}

/* A net and a peer, but no ghost: nothing to send (and every snapshot
   from the peer is refused: it names an object that is not here). */
static void test_no_ghosts_not_sending(void **state) {
    host_opts o1 = plain;
    host *a, *b = host_new(2, 1, &plain);
    gs_peer_stats st;
    double now = 10.0;
    (void)state;
    o1.object = 0;
    a = host_new(1, 2, &o1);
    run(a, b, 70, &now, 1, 1);
    st = stats(a, 2);
    assert_int_equal(st.health, GS_PEER_NOT_SENDING);
    assert_contains(st.reason, "this world has no ghosts");
    assert_contains(gs_world_diagnose(a->w), "a net and no ghosts");
    assert_int_equal(stats(b, 1).health, GS_PEER_SILENT);
    host_free(a);
    host_free(b);
}

static void test_ghosts_and_no_net(void **state) {
    host_opts o = plain;
    host *a, *c;
    (void)state;
    o.no_net = 1;
    a = host_new(1, 2, &o);
    assert_string_equal(gs_world_diagnose(a->w),
                        "1 ghost and no net: nothing is sent or received (gs_net_create)");
    o.object = 0; /* a world of its own: nothing to say */
    c = host_new(3, 2, &o);
    assert_string_equal(gs_world_diagnose(c->w), "");
    host_free(a);
    host_free(c);
}

/* ---- every datagram refused for one reason ---- */

/* Runs the pair 70 frames (past one full second) and returns host 1's
   stats of host 2, which must be GS_PEER_REFUSED for `why`. */
static gs_peer_stats refused(host *a, host *b, gs_reject why) {
    gs_peer_stats st;
    double now = 10.0;
    run(a, b, 70, &now, 1, 1);
    st = stats(a, 2);
    assert_int_equal(st.health, GS_PEER_REFUSED);
    assert_int_equal(st.refused_reason, why);
    assert_contains(st.reason, "datagrams from this peer in the last 1 s refused");
    return st;
}

/* The same object id, another state size (a cloth of another size). */
static void test_refused_state_size(void **state) {
    host_opts o2 = plain;
    host *a = host_new(1, 2, &plain), *b;
    gs_peer_stats st;
    (void)state;
    o2.values = 6;
    b = host_new(2, 1, &o2);
    st = refused(a, b, GS_REJECT_RANGE);
    assert_contains(st.reason, "GS_REJECT_RANGE (elements or chunk index outside");
    assert_contains(st.reason, "object 7's state has 3 values here, 6 in the datagram");
    assert_true(st.rejected[GS_REJECT_RANGE] > 0);
    assert_contains(gs_world_diagnose(a->w), "peer 2: refused: all ");
    host_free(a);
    host_free(b);
}

/* Another object id on the other host. */
static void test_refused_object_id(void **state) {
    host_opts o2 = plain;
    host *a = host_new(1, 2, &plain), *b;
    gs_peer_stats st;
    (void)state;
    o2.object = 8;
    b = host_new(2, 1, &o2);
    st = refused(a, b, GS_REJECT_OBJECT);
    assert_contains(st.reason, "object 8 has no ghost here");
    host_free(a);
    host_free(b);
}

/* Another session: refused before the sender counts (among the unknown
   ones, not the peer's), but the diagnosis reads the sender the header
   names. */
static void test_refused_session(void **state) {
    host_opts o2 = plain;
    host *a = host_new(1, 2, &plain), *b;
    gs_peer_stats st;
    gs_unknown_stats unknown;
    (void)state;
    o2.session = 2;
    b = host_new(2, 1, &o2);
    st = refused(a, b, GS_REJECT_SESSION);
    assert_contains(st.reason, "session 2 in the datagram, 1 here");
    assert_int_equal(st.rejected_total, 0);
    assert_int_equal(gs_net_unknown_stats(a->net, &unknown), GS_OK);
    assert_true(unknown.rejected[GS_REJECT_SESSION] > 0);
    host_free(a);
    host_free(b);
}

#ifdef GHOSTSIM_SODIUM
static const unsigned char key[GS_WIRE_KEY_BYTES] = {1, 2, 3, 4, 5, 6, 7, 8};

/* A key on one host only, either way round. */
static void test_refused_key(void **state) {
    host_opts keyed = plain;
    host *a, *b;
    gs_peer_stats st;
    (void)state;
    keyed.key = key;
    a = host_new(1, 2, &plain);
    b = host_new(2, 1, &keyed);
    st = refused(a, b, GS_REJECT_CHECKSUM); /* sealed, to a net with no key */
    assert_contains(st.reason, "sealed under a key, and this net has none");
    host_free(a);
    host_free(b);
    a = host_new(1, 2, &keyed);
    b = host_new(2, 1, &plain);
    st = refused(a, b, GS_REJECT_KEY); /* in clear, to a keyed net */
    assert_contains(st.reason, "in clear, but this net has a key");
    host_free(a);
    host_free(b);
}

/* Sealed datagrams carry the sync flags in their authenticated header:
   two keyed hosts in replay hear each other as OK, and a keyed host in
   present hears a keyed one in replay as another mode. */
static void test_sealed_sync_flags(void **state) {
    host_opts r = plain, p = plain;
    (void)state;
    r.key = p.key = key;
    r.mode = GS_SYNC_REPLAY;
    r.clock = GS_SYNC_CLOCK_SESSION;
    pair_health(&r, &r, GS_PEER_OK);
    pair_health(&r, &p, GS_PEER_OTHER_MODE);
}
#endif

/* A datagram from host 2 with one snapshot of object 7 of `values`
   values, sequence seq, sent at `now`. */
static size_t datagram(unsigned char *buf, uint32_t seq, int values, double now) {
    gs_wire_header h;
    gs_wire_chunk c;
    const double v[6] = {0.5, 0.5, 0.5, 0.0, 0.0, 0.0};
    size_t size = 0;
    memset(&h, 0, sizeof h);
    h.session = 1;
    h.sender = 2;
    h.sequence = seq;
    h.send_time = now;
    memset(&c, 0, sizeof c);
    c.object_id = 7;
    c.sequence = seq;
    c.time = now - 10.0;
    c.count = 1;
    c.elements = (uint32_t)values;
    c.encoding = GS_ENCODING_F64;
    assert_int_equal(gs_wire_begin(buf, GS_WIRE_MAX_DATAGRAM, &h, &size), GS_OK);
    assert_int_equal(gs_wire_add(buf, GS_WIRE_MAX_DATAGRAM, &size, &c, v), GS_OK);
    return gs_wire_end(buf, size);
}

/* Some datagrams taken, one in five refused for a state size that does
   not match (as when one object of a scene differs and the rest meet):
   said, though the peer is heard. */
static void test_partly_refused(void **state) {
    host *a = host_new(1, 2, &plain);
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    gs_peer_stats st;
    double now = 10.0;
    uint32_t seq;
    (void)state;
    for (seq = 1; seq <= 90; ++seq) {
        size_t n = datagram(buf, seq, seq % 5 == 0 ? 6 : 3, now);
        now += FRAME;
        assert_int_equal(gs_world_advance(a->w, FRAME, NULL), GS_OK);
        assert_int_equal(gs_net_update(a->net, now), GS_OK);
        gs_net_deliver(a->net, buf, n, now, NULL);
    }
    st = stats(a, 2);
    assert_int_equal(st.health, GS_PEER_PARTLY_REFUSED);
    assert_int_equal(st.refused_reason, GS_REJECT_RANGE);
    assert_contains(st.reason, " datagrams from this peer in the last 1 s refused as "
                               "GS_REJECT_RANGE: object 7's state has 3 values here, 6 in");
    host_free(a);
}

/* Refusals among datagrams taken are no sign: a forger cannot make a
   peer that is heard look refused. */
static void test_refusals_among_taken_are_ok(void **state) {
    host *a = host_new(1, 2, &plain), *b = host_new(2, 1, &plain);
    unsigned char junk[GS_WIRE_HEADER + 8];
    double now = 10.0;
    int k;
    (void)state;
    memset(junk, 0, sizeof junk);
    for (k = 0; k < 90; ++k) {
        run(a, b, 1, &now, 1, 1);
        assert_int_equal(gs_net_deliver(a->net, junk, sizeof junk, now, NULL), GS_ERR_REJECTED);
    }
    assert_int_equal(stats(a, 2).health, GS_PEER_OK);
    host_free(a);
    host_free(b);
}

/* ---- a clock that goes back ---- */

/* Taken (the host goes on sending), counted, and said until the clock is
   past its old reading again and a second more. */
static void test_clock_back(void **state) {
    host *a = host_new(1, 2, &plain), *b = host_new(2, 1, &plain);
    gs_peer_stats st;
    double now = 10.0;
    (void)state;
    run(a, b, 60, &now, 1, 1);
    assert_int_equal(gs_net_update(a->net, now - 0.05), GS_OK); /* under GS_CLOCK_SLACK */
    assert_int_equal(stats(a, 2).clock_backwards, 0);
    now -= 2.0;
    assert_int_equal(gs_net_update(a->net, now), GS_OK);
    st = stats(a, 2);
    assert_int_equal(st.health, GS_PEER_CLOCK_BACK);
    assert_int_equal(st.clock_backwards, 1);
    /* the step is 2 s to within rounding of the sum of 60 frames */
    assert_true(fabs(st.clock_back_max - 2.0) < 1e-9);
    assert_contains(st.reason, "the clock went back 2.000 s");
    assert_contains(st.reason, "from 11.000 s to 9.000 s; 1 time so far");
    run(a, b, 60, &now, 1, 1); /* behind still, by a second */
    st = stats(a, 2);
    assert_int_equal(st.health, GS_PEER_CLOCK_BACK);
    assert_contains(st.reason, "went back 2.000 s (from 11.000 s to 9.000 s");
    run(a, b, 130, &now, 1, 1); /* past the old reading and a second on */
    st = stats(a, 2);
    assert_int_equal(st.health, GS_PEER_OK);
    assert_int_equal(st.clock_backwards, 1);
    host_free(a);
    host_free(b);
}

/* A clock that runs backwards all the time (now = 20 - t): counted once
   (it never catches up), said throughout, and the simulation keeps to the
   time it was advanced by. At e74b36a such a clock ran a host to 212 s in
   5 s of frames; the bound below is the 5 s advanced plus the blend's
   correction limit (GS_MAX_TIME_CORRECTION per advance is far more than
   is used here: the peer's snapshots are at its own time, 5 s at most). */
static void test_clock_runs_backwards(void **state) {
    host *a = host_new(1, 2, &plain), *b = host_new(2, 1, &plain);
    gs_peer_stats st;
    double back = 20.0, fwd = 10.0;
    int k;
    (void)state;
    for (k = 0; k < 300; ++k) {
        back -= FRAME;
        fwd += FRAME;
        assert_int_equal(gs_world_advance(a->w, FRAME, NULL), GS_OK);
        assert_int_equal(gs_world_advance(b->w, FRAME, NULL), GS_OK);
        assert_int_equal(gs_net_update(a->net, back), GS_OK);
        assert_int_equal(gs_net_update(b->net, fwd), GS_OK);
        carry(a, b, fwd);
        carry(b, a, back);
    }
    st = stats(a, 2);
    assert_int_equal(st.health, GS_PEER_CLOCK_BACK);
    assert_int_equal(st.clock_backwards, 1);
    assert_true(st.clock_back_max > 4.9);
    assert_true(gs_agent_time(a->a) < 5.0 + 0.1);
    assert_true(gs_world_time(a->w) < 5.0 + 0.1);
    assert_true(st.datagrams_sent > 0); /* it went on sending */
    host_free(a);
    host_free(b);
}

/* On the simnet: a host clock stepped back 2 s. */
static void test_simnet_clock_step_back(void **state) {
    gs_simnet *sim = NULL;
    host_opts o = plain;
    host *a, *b;
    gs_net *na = NULL, *nb = NULL;
    gs_sim_clock c;
    gs_peer_stats st;
    gs_net_desc nd;
    (void)state;
    o.no_net = 1;
    a = host_new(1, 2, &o);
    b = host_new(2, 1, &o);
    assert_int_equal(gs_simnet_create(NULL, &sim), GS_OK);
    memset(&nd, 0, sizeof nd);
    assert_int_equal(test_join(sim, a->w, &nd, &na), GS_OK);
    assert_int_equal(test_join(sim, b->w, &nd, &nb), GS_OK);
    memset(&c, 0, sizeof c);
    c.offset = 10.0; /* a clock never reads below 0 (it would be refused) */
    c.step_at = 1.0;
    c.step_by = -2.0;
    assert_int_equal(gs_simnet_set_clock(sim, 1, &c), GS_OK);
    assert_int_equal(gs_simnet_run(sim, 1.5, FRAME), GS_OK);
    assert_int_equal(gs_net_peer_stats(na, 2, &st), GS_OK);
    assert_int_equal(st.health, GS_PEER_CLOCK_BACK);
    assert_int_equal(st.clock_backwards, 1);
    assert_int_equal(gs_net_peer_stats(nb, 1, &st), GS_OK);
    assert_int_equal(st.health, GS_PEER_OK); /* host 2 still hears host 1 */
    gs_simnet_destroy(sim);
    host_free(a);
    host_free(b);
}

/* ---- the simnet's own errors ---- */

static void test_simnet_error_text(void **state) {
    gs_simnet *sim = NULL;
    gs_link_desc l;
    gs_sim_clock c;
    host_opts o = plain;
    host *a, *a2;
    gs_net *na = NULL;
    gs_net_desc nd;
    (void)state;
    assert_string_equal(gs_simnet_error(NULL), "");
    assert_int_equal(gs_simnet_create(NULL, &sim), GS_OK);
    assert_string_equal(gs_simnet_error(sim), "");
    memset(&l, 0, sizeof l);
    l.latency = 0.05;
    assert_int_equal(gs_simnet_link(sim, 1, 2, &l), GS_ERR_INVALID_ARG);
    assert_contains(gs_simnet_error(sim), "host 1 has not joined this simnet");
    assert_contains(gs_simnet_error(sim), "gs_net_create its world's net on it first");
    o.no_net = 1;
    a = host_new(1, 2, &o);
    memset(&nd, 0, sizeof nd);
    assert_int_equal(test_join(sim, a->w, &nd, &na), GS_OK);
    assert_int_equal(gs_simnet_link(sim, 1, 2, &l), GS_ERR_INVALID_ARG);
    assert_contains(gs_simnet_error(sim), "host 2 has not joined");
    a2 = host_new(1, 2, &o); /* another world with the same host id */
    assert_int_equal(test_join(sim, a2->w, &nd, &na), GS_ERR_INVALID_ARG);
    assert_contains(gs_simnet_error(sim), "host 1 has joined this simnet already");
    assert_contains(gs_world_error(a2->w), "host 1 has joined this simnet already");
    memset(&c, 0, sizeof c);
    assert_int_equal(gs_simnet_set_clock(sim, 9, &c), GS_ERR_INVALID_ARG);
    assert_contains(gs_simnet_error(sim), "host 9 has not joined");
    assert_int_equal(gs_simnet_run(sim, 1.0, 0.0), GS_ERR_INVALID_ARG);
    assert_contains(gs_simnet_error(sim), "gs_simnet_run: seconds 1 ");
    l.loss = 2.0;
    assert_int_equal(gs_simnet_link(sim, 1, 1, &l), GS_ERR_INVALID_ARG);
    assert_contains(gs_simnet_error(sim), "loss 2");
    gs_simnet_destroy(sim);
    host_free(a);
    host_free(a2);
}

/* ---- a custom step that fails ---- */

typedef struct flaky {
    double x[3];
    int fail;
} flaky;
static gs_result flaky_step(void *user, double t, double dt) {
    (void)t; (void)dt;
    return ((flaky *)user)->fail ? GS_ERR_OUT_OF_RANGE : GS_OK;
}
static void flaky_get(const void *user, double *out) {
    memcpy(out, ((const flaky *)user)->x, sizeof ((const flaky *)user)->x);
}
static gs_result flaky_set(void *user, const double *in) {
    memcpy(((flaky *)user)->x, in, sizeof ((flaky *)user)->x);
    return GS_OK;
}

static void test_custom_step_failure_named(void **state) {
    gs_world *w = world_new(1);
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_agent *other, *a;
    flaky f, g;
    gs_vec3 nan_g;
    (void)state;
    memset(&f, 0, sizeof f);
    memset(&g, 0, sizeof g);
    f.fail = 1;
    other = custom_new(w, 0.01, 3, flaky_step, flaky_get, flaky_set, &g);
    a = custom_new(w, 0.01, 3, flaky_step, flaky_get, flaky_set, &f);
    gd.object_id = 9;
    assert_int_equal(gs_ghost_attach(a, &gd), GS_OK);
    assert_int_equal(gs_world_advance(w, 0.1, NULL), GS_ERR_OUT_OF_RANGE);
    assert_contains(gs_world_error(w), "custom agent 1 (object 9): its step from t = 0 s");
    assert_contains(gs_world_error(w), "returned -3 (an index, count or coordinate");
    assert_contains(gs_world_error(w), "stays at t = 0 s");
    assert_true(gs_agent_time(a) == 0.0);
    assert_true(gs_agent_time(other) > 0.09); /* the other agent went on */
    assert_int_equal(gs_agent_result(a), GS_ERR_OUT_OF_RANGE);
    f.fail = 0; /* mended: the next advance is good and says nothing */
    assert_int_equal(gs_world_advance(w, 0.1, NULL), GS_OK);
    assert_string_equal(gs_world_error(w), "");
    assert_true(gs_agent_time(a) > 0.0);
    /* a failed call's text does not outlive a good advance either */
    nan_g.x = nan_g.y = nan_g.z = NAN;
    assert_int_not_equal(gs_world_set_gravity(w, nan_g), GS_OK);
    assert_string_not_equal(gs_world_error(w), "");
    assert_int_equal(gs_world_advance(w, 0.1, NULL), GS_OK);
    assert_string_equal(gs_world_error(w), "");
    gs_world_destroy(w);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ok_both_ways),
        cmocka_unit_test(test_health_names),
        cmocka_unit_test(test_other_mode),
        cmocka_unit_test(test_other_clock_and_same_mode),
        cmocka_unit_test(test_peer_not_added_is_silent),
        cmocka_unit_test(test_peer_stops),
        cmocka_unit_test(test_update_never_called),
        cmocka_unit_test(test_update_not_called_while_delivering),
        cmocka_unit_test(test_no_ghosts_not_sending),
        cmocka_unit_test(test_ghosts_and_no_net),
        cmocka_unit_test(test_refused_state_size),
        cmocka_unit_test(test_refused_object_id),
        cmocka_unit_test(test_refused_session),
#ifdef GHOSTSIM_SODIUM
        cmocka_unit_test(test_refused_key),
        cmocka_unit_test(test_sealed_sync_flags),
#endif
        cmocka_unit_test(test_partly_refused),
        cmocka_unit_test(test_refusals_among_taken_are_ok),
        cmocka_unit_test(test_clock_back),
        cmocka_unit_test(test_clock_runs_backwards),
        cmocka_unit_test(test_simnet_clock_step_back),
        cmocka_unit_test(test_simnet_error_text),
        cmocka_unit_test(test_custom_step_failure_named),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
