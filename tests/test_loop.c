/* test_loop - the one-way step loop: weight rules run with the net's lock
   released (the snapshots are taken out of the net's queues under it and
   blended after), in both sync modes, so that a rule's calls into the net
   neither deadlock nor find the lock held; and the advance that blends
   allocates nothing. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>
#if !defined(GHOSTSIM_NO_UDP)
#include <pthread.h>
#include <unistd.h>
#endif

#include "ghostsim.h"
#include "net_helpers.h"
#include "wire_helpers.h"

/* ---- an allocator that counts ---- */
typedef struct counter {
    long allocs, frees;
} counter;

static void *count_alloc(size_t size, void *user) {
    ((counter *)user)->allocs++;
    return malloc(size);
}

static void count_free(void *p, void *user) {
    ((counter *)user)->frees++;
    free(p);
}

static gs_world *counted_world(counter *c, gs_sync_mode mode) {
    gs_world_desc wd = gs_world_desc_default();
    gs_world *w = NULL;
    memset(c, 0, sizeof *c);
    wd.host_id = 1;
    wd.allocator.alloc = count_alloc;
    wd.allocator.free = count_free;
    wd.allocator.user = c;
    wd.sync.mode = mode;
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    return w;
}

/* ---- a custom agent of two values: the first grows with time ---- */
typedef struct pend {
    double v[2];
} pend;

static gs_result pend_step(void *user, double t, double dt) {
    (void)t;
    ((pend *)user)->v[0] += dt;
    return GS_OK;
}

static void pend_get(const void *user, double *out) {
    memcpy(out, ((const pend *)user)->v, sizeof((const pend *)user)->v);
}

static gs_result pend_set(void *user, const double *in) {
    memcpy(((pend *)user)->v, in, sizeof((pend *)user)->v);
    return GS_OK;
}

static gs_agent *make_pend(gs_world *w, pend *p) {
    gs_custom_desc d;
    gs_agent *a = NULL;
    memset(&d, 0, sizeof d);
    memset(p, 0, sizeof *p);
    d.dt = 0.01;
    d.state_size = 2;
    d.step = pend_step;
    d.get_state = pend_get;
    d.set_state = pend_set;
    d.user = p;
    assert_int_equal(gs_custom_create(w, &d, &a), GS_OK);
    return a;
}


static gs_result sink_send(void *user, uint32_t host, const void *data, size_t size) {
    (void)user;
    (void)host;
    (void)data;
    (void)size;
    return GS_OK;
}

/* ---- a lock of our own that is not recursive: it records whether it
   was asked for while held, where a mutex would block forever ---- */
typedef struct lock_probe {
    int depth, max_depth;
    long takes;
    int would_block;
} lock_probe;

static void probe_lock(void *user) {
    lock_probe *l = (lock_probe *)user;
    if (l->depth > 0) l->would_block = 1;
    if (++l->depth > l->max_depth) l->max_depth = l->depth;
    l->takes++;
}

static void probe_unlock(void *user) { ((lock_probe *)user)->depth--; }

typedef struct rule_seen {
    lock_probe *lock;
    gs_net *net;
    long calls;
    int depth_in_rule;  /* the most the lock was held at a rule's call */
    gs_result stats, deliver, update;
    int delivered;
} rule_seen;

static double checking_rule(const gs_weight_in *in, void *user) {
    rule_seen *r = (rule_seen *)user;
    gs_peer_stats ps;
    r->calls++;
    if (r->lock->depth > r->depth_in_rule) r->depth_in_rule = r->lock->depth;
    r->stats = gs_net_peer_stats(r->net, 2, &ps);
    r->update = gs_net_update(r->net, 2.0);
    if (!r->delivered && !in->local) {
        unsigned char buf[GS_WIRE_MAX_DATAGRAM];
        size_t n = snapshot_datagram(buf, 2, 90, 7, gs_agent_time(in->agent));
        r->delivered = 1;
        r->deliver = gs_net_deliver(r->net, buf, n, 2.0, NULL);
    }
    return 1.0;
}

/* In each mode: a snapshot in the present (present mode blends it after a
   step) and one a frame in the past (replay mode takes it at the start of
   the advance: a re-run, or the blend at the present if the history is
   short). Every rule call finds the lock free, and its calls into the net
   take it and work. */
static void run_unlocked(gs_sync_mode mode) {
    counter cnt;
    gs_world *w = counted_world(&cnt, mode);
    pend p;
    gs_agent *a = make_pend(w, &p);
    gs_net_desc nd;
    gs_net *net = NULL;
    gs_net_lock lk;
    lock_probe lp;
    rule_seen rs;
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_ghost_stats gst;
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    size_t n;
    long allocs;
    int i;
    memset(&nd, 0, sizeof nd);
    memset(&lp, 0, sizeof lp);
    memset(&rs, 0, sizeof rs);
    nd.transport.send = sink_send;
    assert_int_equal(gs_net_create(w, &nd, &net), GS_OK);
    lk.lock = probe_lock;
    lk.unlock = probe_unlock;
    lk.user = &lp;
    gs_net_set_lock(net, lk);
    assert_int_equal(gs_net_add_peer(net, 2, NULL), GS_OK);
    gd.object_id = 7;
    gd.weight = checking_rule;
    gd.weight_user = &rs;
    rs.lock = &lp;
    rs.net = net;
    assert_int_equal(gs_ghost_attach(a, &gd), GS_OK);
    for (i = 0; i < 5; ++i) assert_int_equal(gs_world_advance(w, 0.02, NULL), GS_OK);
    allocs = cnt.allocs;
    n = snapshot_datagram(buf, 2, 1, 7, gs_world_time(w) - 0.02);
    assert_int_equal(gs_net_deliver(net, buf, n, 1.0, NULL), GS_OK);
    for (i = 0; i < 3; ++i) assert_int_equal(gs_world_advance(w, 0.02, NULL), GS_OK);
    assert_true(rs.calls >= 2); /* the local state and a snapshot at least */
    assert_int_equal(rs.depth_in_rule, 0);
    assert_int_equal(lp.would_block, 0);
    assert_int_equal(lp.depth, 0);
    assert_int_equal(rs.stats, GS_OK);
    assert_int_equal(rs.update, GS_OK);
    assert_int_equal(rs.delivered, 1);
    assert_int_equal(rs.deliver, GS_OK);
    assert_int_equal(gs_ghost_get_stats(a, &gst), GS_OK);
    assert_true(gst.blends >= 2); /* ours, and the one the rule delivered */
    assert_int_equal(cnt.allocs, allocs); /* the advances allocated nothing */
    gs_world_destroy(w);
    assert_int_equal(cnt.allocs, cnt.frees);
}

static void test_loop_rule_unlocked_present(void **state) {
    (void)state;
    run_unlocked(GS_SYNC_PRESENT);
}

static void test_loop_rule_unlocked_replay(void **state) {
    (void)state;
    run_unlocked(GS_SYNC_REPLAY);
}

#if !defined(GHOSTSIM_NO_UDP)
/* gs_udp's mutex is recursive, so a call from the rule's own thread would
   not show whether it is held: the rule asks another thread, which would
   block on a held mutex until the alarm fails the test. */
typedef struct udp_seen {
    gs_net *net;
    int done;
    gs_result stats, update;
} udp_seen;

static void *other_thread(void *arg) {
    udp_seen *u = (udp_seen *)arg;
    gs_peer_stats ps;
    u->stats = gs_net_peer_stats(u->net, 2, &ps);
    u->update = gs_net_update(u->net, gs_udp_now());
    return NULL;
}

static double asking_rule(const gs_weight_in *in, void *user) {
    udp_seen *u = (udp_seen *)user;
    pthread_t th;
    if (u->done || in->local) return 1.0;
    u->done = 1;
    if (pthread_create(&th, NULL, other_thread, u) == 0) pthread_join(th, NULL);
    else u->done = -1;
    return 1.0;
}

static void test_loop_udp_rule_other_thread(void **state) {
    gs_world_desc wd = gs_world_desc_default();
    gs_world *w = NULL;
    pend p;
    gs_agent *a;
    gs_udp_desc ud;
    udp_seen us;
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_ghost_stats gst;
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    size_t n;
    (void)state;
    memset(&ud, 0, sizeof ud);
    memset(&us, 0, sizeof us);
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    a = make_pend(w, &p);
    ud.bind = "127.0.0.1:0";
    ud.threads = 1; /* the gather and scatter threads take the mutex too */
    assert_int_equal(test_udp_open(w, &ud, NULL, &us.net), GS_OK);
    assert_int_equal(gs_net_add_peer(us.net, 2, "127.0.0.1:9"), GS_OK);
    gd.object_id = 7;
    gd.weight = asking_rule;
    gd.weight_user = &us;
    assert_int_equal(gs_ghost_attach(a, &gd), GS_OK);
    n = snapshot_datagram(buf, 2, 1, 7, 0.0);
    assert_int_equal(gs_net_deliver(us.net, buf, n, gs_udp_now(), NULL), GS_OK);
    alarm(20);
    assert_int_equal(gs_world_advance(w, 0.02, NULL), GS_OK);
    alarm(0);
    assert_int_equal(us.done, 1);
    assert_int_equal(us.stats, GS_OK);
    assert_int_equal(us.update, GS_OK);
    assert_int_equal(gs_ghost_get_stats(a, &gst), GS_OK);
    assert_int_equal(gst.blends, 1);
    gs_world_destroy(w);
}
#endif

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_loop_rule_unlocked_present),
        cmocka_unit_test(test_loop_rule_unlocked_replay),
#if !defined(GHOSTSIM_NO_UDP)
        cmocka_unit_test(test_loop_udp_rule_other_thread),
#endif
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
