/* test_hostile_api.c - the public API used as a hostile (or careless) user
   would use it: sizes that wrap, callbacks that call back into the world or
   the net, calls that fail half way, NULL handles, wild arguments.

   The header's promises checked here (ERRORS, THREADS): a bad argument is a
   gs_result, never a crash; a failed call changes nothing; a call from a
   callback that would change the world, an agent, a ghost or the net
   returns GS_ERR_BUSY, and a destroy from one frees nothing; nothing in an
   advance allocates. Each section names the finding of issue 14 it covers.
   Pass a cmocka glob to run some tests only. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "ghostsim.h"
#include "alloc_helpers.h"
#include "net_helpers.h"
#include "wire_helpers.h"
#include "world_helpers.h"

/* ---- the counting allocator (alloc_helpers.h): it refuses on demand,
   and anything over a gigabyte (as an allocator on a small machine
   would) unless told to lie ---- */

static gs_agent *make_probe(gs_world *w) {
    gs_probe_desc pd = gs_probe_desc_default();
    gs_agent *a = NULL;
    pd.shape.type = GS_SHAPE_SPHERE;
    pd.shape.radius = 0.1;
    pd.position.y = 5.0;
    assert_int_equal(gs_probe_create(w, &pd, &a), GS_OK);
    return a;
}

static gs_agent *make_cloth(gs_world *w) {
    gs_cloth_desc cd = gs_cloth_desc_default();
    gs_agent *a = NULL;
    cd.nx = cd.ny = 3;
    cd.width = cd.height = 1.0;
    cd.origin.y = 10.0;
    cd.pin_corners = GS_CORNER_ALL;
    assert_int_equal(gs_cloth_create(w, &cd, &a), GS_OK);
    return a;
}

/* A transport of the test's own: counts what goes out. */
typedef struct sink {
    long sent;
} sink;
static gs_result sink_send(void *user, uint32_t host, const void *data, size_t size) {
    (void)host;
    (void)data;
    (void)size;
    ((sink *)user)->sent++;
    return GS_OK;
}

static gs_net *make_net(gs_world *w, sink *s) {
    gs_net *net = NULL;
    assert_int_equal(send_only_net(w, NULL, sink_send, s, &net), GS_OK);
    return net;
}


static int has_text(const gs_world *w, const char *word) {
    if (strstr(gs_world_error(w), word)) return 1;
    print_error("error text \"%s\" lacks \"%s\"\n", gs_world_error(w), word);
    return 0;
}

/* ---- finding 2: sizes that wrap ---- */

static void test_hostile_custom_size(void **state) {
    counter cnt;
    gs_world *w = counted_world(&cnt, 1);
    two_values p;
    gs_custom_desc d;
    gs_agent *a = (gs_agent *)&p;
    long before = live_blocks(&cnt);
    size_t bad[3];
    int i;
    (void)state;
    memset(&p, 0, sizeof p);
    bad[0] = SIZE_MAX;
    bad[1] = SIZE_MAX / sizeof(double) + 4;  /* 2^61 + 4 on 64 bits: 32 bytes */
    bad[2] = (SIZE_MAX - 8) / sizeof(double); /* the header tips it over */
    for (i = 0; i < 3; ++i) {
        d = two_values_desc(&p);
        d.state_size = bad[i];
        a = (gs_agent *)&p;
        assert_int_equal(gs_custom_create(w, &d, &a), GS_ERR_OUT_OF_RANGE);
        assert_null(a);
        assert_true(has_text(w, "state_size"));
        assert_int_equal(gs_world_agent_count(w), 0);
        assert_int_equal(live_blocks(&cnt), before);
    }
    /* a size that fits in size_t (the agent keeps two copies of the state:
       16 bytes a value) but that no allocator gives */
    d = two_values_desc(&p);
    d.state_size = SIZE_MAX / 32;
    assert_int_equal(gs_custom_create(w, &d, &a), GS_ERR_NO_MEMORY);
    assert_null(a);
    assert_int_equal(gs_world_agent_count(w), 0);
    assert_int_equal(live_blocks(&cnt), before);
    gs_world_destroy(w);
    assert_int_equal(cnt.allocs, cnt.frees);
}

/* A custom agent whose state fits in size_t but whose ghost would not:
   gs_ghost_attach must refuse it before it allocates. */
static void test_hostile_ghost_size(void **state) {
#if SIZE_MAX > 0xffffffffu
    counter cnt;
    gs_world *w = counted_world(&cnt, 1);
    two_values p;
    gs_custom_desc d;
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_agent *a = NULL;
    long before;
    (void)state;
    memset(&p, 0, sizeof p);
    cnt.lie = 1;
    d = two_values_desc(&p);
    d.state_size = (size_t)1 << 59; /* 2^63 bytes: the allocator lies */
    assert_int_equal(gs_custom_create(w, &d, &a), GS_OK);
    cnt.lie = 0;
    before = live_blocks(&cnt);
    gd.object_id = 5;
    /* the wire's chunk limit refuses it first; the ghost's own size check
       stays for a 32-bit size_t, where a state within the limit may still
       overflow the queues' bytes */
    assert_int_equal(gs_ghost_attach(a, &gd), GS_ERR_CAPACITY);
    assert_true(has_text(w, "GS_WIRE_MAX_OBJECT_CHUNKS"));
    assert_int_equal(live_blocks(&cnt), before);
    gs_world_destroy(w);
    assert_int_equal(cnt.allocs, cnt.frees);
#else
    (void)state;
    skip();
#endif
}

/* ---- finding 3: calls from a custom step ---- */

typedef struct step_probe {
    gs_world *w;
    gs_net *net;
    gs_agent *self, *other, *probe, *cloth;
    int done;
    gs_result set_other, set_self, gravity, budget, ground, target, pin, attach, detach,
        add_peer, remove_peer, net_create, advance, destroy_other, update;
    gs_vec3 gravity_after;
} step_probe;

static gs_result meddling_step(void *user, double t, double dt) {
    step_probe *p = (step_probe *)user;
    double st[3] = {0.0, 1.0, 2.0};
    gs_vec3 g = {1.0, 2.0, 3.0};
    gs_quat q = {0.0, 0.0, 0.0, 1.0};
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_net_desc nd;
    gs_net *net2 = NULL;
    (void)t;
    (void)dt;
    if (p->done) return GS_OK;
    p->done = 1;
    st[0] = gs_agent_time(p->other);
    p->set_other = gs_agent_set_state(p->other, st, 3);
    p->set_self = gs_agent_set_state(p->self, st, 1);
    p->gravity = gs_world_set_gravity(p->w, g);
    p->budget = gs_world_set_budget(p->w, 1.0);
    p->ground = gs_world_set_ground(p->w, 1, 0.0, gs_material_default());
    p->target = gs_probe_set_target(p->probe, g, q);
    p->pin = gs_mesh_move_pin(p->cloth, 0, g);
    gd.object_id = 99;
    p->attach = gs_ghost_attach(p->probe, &gd);
    p->detach = gs_ghost_detach(p->other);
    p->add_peer = gs_net_add_peer(p->net, 3, NULL);
    p->remove_peer = gs_net_remove_peer(p->net, 2);
    memset(&nd, 0, sizeof nd);
    nd.transport.send = sink_send;
    p->net_create = gs_net_create(p->w, &nd, &net2);
    p->advance = gs_world_advance(p->w, 1.0, NULL);
    p->destroy_other = gs_agent_destroy(p->other);
    p->update = gs_net_update(p->net, 1.0); /* any thread's call: it works */
    gs_net_destroy(p->net);   /* refused: frees nothing */
    gs_world_destroy(p->w);   /* refused: frees nothing */
    p->gravity_after = gs_world_gravity(p->w);
    return GS_OK;
}

static void test_hostile_custom_step_calls(void **state) {
    counter cnt;
    gs_world *w = counted_world(&cnt, 1);
    step_probe sp;
    two_values other, mine;
    gs_custom_desc d;
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_peer_stats ps;
    gs_vec3 g0;
    sink sk;
    long before;
    (void)state;
    memset(&sp, 0, sizeof sp);
    memset(&other, 0, sizeof other);
    memset(&mine, 0, sizeof mine);
    memset(&sk, 0, sizeof sk);
    sp.w = w;
    d = two_values_desc(&other);
    assert_int_equal(gs_custom_create(w, &d, &sp.other), GS_OK);
    d = two_values_desc(&mine);
    d.state_size = 0;
    d.get_state = NULL;
    d.set_state = NULL;
    d.step = meddling_step;
    d.user = &sp;
    assert_int_equal(gs_custom_create(w, &d, &sp.self), GS_OK);
    sp.probe = make_probe(w);
    sp.cloth = make_cloth(w);
    sp.net = make_net(w, &sk);
    assert_int_equal(gs_net_add_peer(sp.net, 2, NULL), GS_OK);
    gd.object_id = 1;
    assert_int_equal(gs_ghost_attach(sp.other, &gd), GS_OK);
    g0 = gs_world_gravity(w);
    before = live_blocks(&cnt);
    assert_int_equal(gs_world_advance(w, 0.05, NULL), GS_OK);
    assert_int_equal(sp.done, 1);
    assert_int_equal(sp.set_other, GS_ERR_BUSY);
    assert_int_equal(sp.set_self, GS_ERR_BUSY);
    assert_int_equal(sp.gravity, GS_ERR_BUSY);
    assert_int_equal(sp.budget, GS_ERR_BUSY);
    assert_int_equal(sp.ground, GS_ERR_BUSY);
    assert_int_equal(sp.target, GS_ERR_BUSY);
    assert_int_equal(sp.pin, GS_ERR_BUSY);
    assert_int_equal(sp.attach, GS_ERR_BUSY);
    assert_int_equal(sp.detach, GS_ERR_BUSY);
    assert_int_equal(sp.add_peer, GS_ERR_BUSY);
    assert_int_equal(sp.remove_peer, GS_ERR_BUSY);
    assert_int_equal(sp.net_create, GS_ERR_BUSY);
    assert_int_equal(sp.advance, GS_ERR_BUSY);
    assert_int_equal(sp.destroy_other, GS_ERR_BUSY);
    assert_int_equal(sp.update, GS_OK);
    assert_true(sk.sent > 0);
    /* nothing changed, nothing was allocated or freed */
    assert_true(sp.gravity_after.x == g0.x && sp.gravity_after.y == g0.y);
    assert_true(gs_world_gravity(w).y == g0.y);
    assert_int_equal(live_blocks(&cnt), before);
    assert_ptr_equal(gs_world_net(w), sp.net);
    assert_int_equal(gs_world_agent_count(w), 4);
    assert_int_equal(gs_net_peer_stats(sp.net, 2, &ps), GS_OK);
    assert_int_equal(gs_net_peer_stats(sp.net, 3, &ps), GS_ERR_INVALID_ARG);
    assert_true(has_text(w, "refused"));
    assert_int_equal(other.steps, 5);
    /* after the advance the same calls work */
    assert_int_equal(gs_world_set_gravity(w, g0), GS_OK);
    assert_int_equal(gs_net_add_peer(sp.net, 3, NULL), GS_OK);
    gs_world_destroy(w);
    assert_int_equal(cnt.allocs, cnt.frees);
}

/* Outside an advance, user code runs too: gs_agent_step runs the step,
   gs_world_hash the custom get_state. */
typedef struct outside_probe {
    gs_world *w;
    gs_agent *victim;
    gs_result destroy;
    int calls;
} outside_probe;

static gs_result destroying_step(void *user, double t, double dt) {
    outside_probe *o = (outside_probe *)user;
    (void)t;
    (void)dt;
    o->calls++;
    gs_world_destroy(o->w);
    o->destroy = gs_agent_destroy(o->victim);
    return GS_OK;
}
static void destroying_get(const void *user, double *out) {
    outside_probe *o = (outside_probe *)(uintptr_t)user;
    o->calls++;
    o->destroy = gs_agent_destroy(o->victim);
    gs_world_destroy(o->w);
    out[0] = 1.0;
}
static gs_result destroying_set(void *user, const double *in) {
    (void)user;
    (void)in;
    return GS_OK;
}

static void test_hostile_outside_advance_calls(void **state) {
    counter cnt;
    gs_world *w = counted_world(&cnt, 1);
    outside_probe o;
    two_values v;
    gs_custom_desc d;
    gs_agent *a;
    (void)state;
    memset(&o, 0, sizeof o);
    memset(&v, 0, sizeof v);
    o.w = w;
    d = two_values_desc(&v);
    assert_int_equal(gs_custom_create(w, &d, &o.victim), GS_OK);
    d.state_size = 1;
    d.step = destroying_step;
    d.get_state = destroying_get;
    d.set_state = destroying_set;
    d.user = &o;
    assert_int_equal(gs_custom_create(w, &d, &a), GS_OK);
    assert_int_equal(gs_agent_step(a), GS_OK);
    assert_int_equal(o.destroy, GS_ERR_BUSY);
    assert_int_equal(gs_world_agent_count(w), 2);
    o.destroy = GS_OK;
    (void)gs_world_hash(w);
    assert_int_equal(o.destroy, GS_ERR_BUSY);
    assert_int_equal(gs_world_agent_count(w), 2);
    assert_true(o.calls >= 2);
    gs_world_destroy(w);
    assert_int_equal(cnt.allocs, cnt.frees);
}

/* ---- finding 3: calls from a weight rule ---- */

typedef struct rule_probe {
    gs_world *w;
    gs_net *net;
    gs_agent *agent, *probe;
    int done, calls;
    gs_result add_peer, remove_peer, gravity, ground, set_state, target, update, deliver,
        peer_stats, unknown_stats, detach, destroy_agent;
    long allocs_inside;
    counter *cnt;
    long lock_calls; /* of the lock the rule tried to set: it must not be */
} rule_probe;

static void probe_lock(void *user) { ((rule_probe *)user)->lock_calls++; }

static double meddling_rule(const gs_weight_in *in, void *user) {
    rule_probe *p = (rule_probe *)user;
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    size_t n;
    double st[3] = {0.0, 0.0, 0.0};
    gs_vec3 g = {0.0, 1.0, 0.0};
    gs_quat q = {0.0, 0.0, 0.0, 1.0};
    gs_peer_stats ps;
    gs_unknown_stats rej;
    p->calls++;
    if (p->done || in->local) return 1.0;
    p->done = 1;
    n = snapshot_datagram(buf, 2, 50, 7, 0.0);
    gs_net_destroy(p->net); /* refused: the blend holds it */
    gs_world_destroy(p->w); /* refused */
    p->add_peer = gs_net_add_peer(p->net, 3, NULL);
    p->remove_peer = gs_net_remove_peer(p->net, 2);
    p->gravity = gs_world_set_gravity(p->w, g);
    p->ground = gs_world_set_ground(p->w, 1, 0.0, gs_material_default());
    st[0] = gs_agent_time(p->agent);
    p->set_state = gs_agent_set_state(p->agent, st, 3);
    p->target = gs_probe_set_target(p->probe, g, q);
    p->update = gs_net_update(p->net, 2.0);
    p->deliver = gs_net_deliver(p->net, buf, n, 2.0, NULL);
    p->peer_stats = gs_net_peer_stats(p->net, 2, &ps);
    p->unknown_stats = gs_net_unknown_stats(p->net, &rej);
    p->detach = gs_ghost_detach(p->agent);
    p->destroy_agent = gs_agent_destroy(p->agent);
    {
        gs_net_lock lk;
        lk.lock = probe_lock;
        lk.unlock = probe_lock;
        lk.user = p;
        gs_net_set_lock(p->net, lk); /* refused: the blend holds the old one */
    }
    p->allocs_inside = p->cnt->allocs;
    return 1.0;
}

static void test_hostile_weight_rule_calls(void **state) {
    counter cnt;
    gs_world *w = counted_world(&cnt, 1);
    rule_probe rp;
    two_values v;
    gs_custom_desc d;
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_ghost_stats gst;
    gs_peer_stats ps;
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    size_t n;
    sink sk;
    gs_vec3 g0;
    long allocs;
    (void)state;
    memset(&rp, 0, sizeof rp);
    memset(&v, 0, sizeof v);
    memset(&sk, 0, sizeof sk);
    rp.w = w;
    rp.cnt = &cnt;
    d = two_values_desc(&v);
    assert_int_equal(gs_custom_create(w, &d, &rp.agent), GS_OK);
    rp.probe = make_probe(w);
    rp.net = make_net(w, &sk);
    assert_int_equal(gs_net_add_peer(rp.net, 2, NULL), GS_OK);
    gd.object_id = 7;
    gd.weight = meddling_rule;
    gd.weight_user = &rp;
    assert_int_equal(gs_ghost_attach(rp.agent, &gd), GS_OK);
    n = snapshot_datagram(buf, 2, 1, 7, 0.0);
    assert_int_equal(gs_net_deliver(rp.net, buf, n, 1.0, NULL), GS_OK);
    g0 = gs_world_gravity(w);
    allocs = cnt.allocs;
    assert_int_equal(gs_world_advance(w, 0.02, NULL), GS_OK);
    assert_int_equal(rp.done, 1);
    assert_int_equal(rp.add_peer, GS_ERR_BUSY);
    assert_int_equal(rp.remove_peer, GS_ERR_BUSY);
    assert_int_equal(rp.gravity, GS_ERR_BUSY);
    assert_int_equal(rp.ground, GS_ERR_BUSY);
    assert_int_equal(rp.set_state, GS_ERR_BUSY);
    assert_int_equal(rp.target, GS_ERR_BUSY);
    /* the rule runs with the net's lock released and its queues not in
       use (the blend reads the snapshots it took out of them): the net's
       calls any thread may make work from it too */
    assert_int_equal(rp.update, GS_OK);
    assert_int_equal(rp.deliver, GS_OK);
    assert_int_equal(rp.peer_stats, GS_OK); /* reading is safe */
    assert_int_equal(rp.unknown_stats, GS_OK);
    assert_int_equal(rp.detach, GS_ERR_BUSY);
    assert_int_equal(rp.destroy_agent, GS_ERR_BUSY);
    /* the advance allocated nothing, inside the rule or after it */
    assert_int_equal(rp.allocs_inside, allocs);
    assert_int_equal(cnt.allocs, allocs);
    assert_ptr_equal(gs_world_net(w), rp.net);
    assert_true(gs_world_gravity(w).y == g0.y);
    assert_int_equal(gs_net_peer_stats(rp.net, 2, &ps), GS_OK);
    assert_int_equal(ps.datagrams_received, 2); /* the rule's was taken */
    assert_int_equal(gs_net_peer_stats(rp.net, 3, &ps), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_ghost_get_stats(rp.agent, &gst), GS_OK);
    assert_int_equal(gst.blends, 2); /* the rule's snapshot at a later step */
    assert_true(sk.sent > 0); /* the rule's update sent */
    /* and the net works once the advance is over */
    assert_int_equal(gs_net_update(rp.net, 3.0), GS_OK);
    assert_int_equal(rp.lock_calls, 0);
    gs_world_destroy(w);
    assert_int_equal(cnt.allocs, cnt.frees);
}

/* The send callback runs inside gs_net_update, under the net's lock. */
typedef struct send_probe {
    gs_world *w;
    gs_net *net;
    int calls;
    gs_result update, add_peer, remove_peer;
} send_probe;

static gs_result meddling_send(void *user, uint32_t host, const void *data, size_t size) {
    send_probe *s = (send_probe *)user;
    (void)host;
    (void)data;
    (void)size;
    if (s->calls++) return GS_OK;
    s->update = gs_net_update(s->net, 5.0);
    s->add_peer = gs_net_add_peer(s->net, 3, NULL);
    s->remove_peer = gs_net_remove_peer(s->net, 2);
    gs_net_destroy(s->net);
    gs_world_destroy(s->w);
    return GS_OK;
}

static void test_hostile_send_callback_calls(void **state) {
    counter cnt;
    gs_world *w = counted_world(&cnt, 1);
    send_probe sp;
    two_values v;
    gs_custom_desc d;
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_agent *a;
    gs_peer_stats ps;
    (void)state;
    memset(&sp, 0, sizeof sp);
    memset(&v, 0, sizeof v);
    sp.w = w;
    d = two_values_desc(&v);
    assert_int_equal(gs_custom_create(w, &d, &a), GS_OK);
    assert_int_equal(send_only_net(w, NULL, meddling_send, &sp, &sp.net), GS_OK);
    assert_int_equal(gs_net_add_peer(sp.net, 2, NULL), GS_OK);
    gd.object_id = 1;
    assert_int_equal(gs_ghost_attach(a, &gd), GS_OK);
    assert_int_equal(gs_world_advance(w, 0.05, NULL), GS_OK);
    assert_int_equal(gs_net_update(sp.net, 1.0), GS_OK);
    assert_int_equal(sp.calls, 1);
    assert_int_equal(sp.update, GS_ERR_BUSY);
    assert_int_equal(sp.add_peer, GS_ERR_BUSY);
    assert_int_equal(sp.remove_peer, GS_ERR_BUSY);
    assert_ptr_equal(gs_world_net(w), sp.net);
    assert_int_equal(gs_net_peer_stats(sp.net, 2, &ps), GS_OK);
    assert_int_equal(ps.datagrams_sent, 1);
    gs_world_destroy(w);
    assert_int_equal(cnt.allocs, cnt.frees);
}

#ifndef GHOSTSIM_NO_UDP
/* A rule's call into a gs_udp net must not deadlock on its lock (weight
   rules run with it released) nor touch the snapshots being blended. A
   deadlock would hang: the alarm turns it into a failure. */
typedef struct udp_rule {
    gs_net *u;
    int done;
    gs_result peer_stats, update, poll, add_peer, remove_peer;
} udp_rule;

static double udp_meddling_rule(const gs_weight_in *in, void *user) {
    udp_rule *r = (udp_rule *)user;
    gs_peer_stats ps;
    if (r->done || in->local) return 1.0;
    r->done = 1;
    r->peer_stats = gs_net_peer_stats(r->u, 2, &ps);
    r->update = gs_net_update(r->u, 3.0);
    r->poll = gs_net_poll(r->u, 3.0);
    r->add_peer = gs_net_add_peer(r->u, 4, "127.0.0.1:9");
    r->remove_peer = gs_net_remove_peer(r->u, 2);
    gs_net_destroy(r->u); /* refused */
    return 1.0;
}

static void test_hostile_udp_weight_rule(void **state) {
    counter cnt;
    gs_world *w = counted_world(&cnt, 1);
    udp_rule ur;
    two_values v;
    gs_custom_desc d;
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_udp_desc ud;
    gs_ghost_stats gst;
    gs_peer_stats ps;
    gs_agent *a;
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    size_t n;
    (void)state;
    memset(&ur, 0, sizeof ur);
    memset(&v, 0, sizeof v);
    memset(&ud, 0, sizeof ud);
    d = two_values_desc(&v);
    assert_int_equal(gs_custom_create(w, &d, &a), GS_OK);
    ud.bind = "127.0.0.1:0";
    ud.threads = 0;
    assert_int_equal(test_udp_open(w, &ud, NULL, &ur.u), GS_OK);
    assert_int_equal(gs_net_add_peer(ur.u, 2, "127.0.0.1:9"), GS_OK);
    gd.object_id = 7;
    gd.weight = udp_meddling_rule;
    gd.weight_user = &ur;
    assert_int_equal(gs_ghost_attach(a, &gd), GS_OK);
    n = snapshot_datagram(buf, 2, 1, 7, 0.0);
    assert_int_equal(gs_net_deliver(ur.u, buf, n, 1.0, NULL), GS_OK);
    alarm(20);
    assert_int_equal(gs_world_advance(w, 0.02, NULL), GS_OK);
    alarm(0);
    assert_int_equal(ur.done, 1);
    assert_int_equal(ur.peer_stats, GS_OK);
    assert_int_equal(ur.update, GS_OK); /* any thread's call: the lock is free */
    assert_int_equal(ur.poll, GS_ERR_BUSY); /* the world's thread's: it is advancing */
    assert_int_equal(ur.add_peer, GS_ERR_BUSY);
    assert_int_equal(ur.remove_peer, GS_ERR_BUSY);
    assert_int_equal(gs_net_peer_stats(ur.u, 2, &ps), GS_OK);
    assert_int_equal(gs_net_peer_stats(ur.u, 4, &ps), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_ghost_get_stats(a, &gst), GS_OK);
    assert_int_equal(gst.blends, 1);
    gs_net_destroy(ur.u);
    assert_null(gs_world_net(w));
    gs_world_destroy(w);
    assert_int_equal(cnt.allocs, cnt.frees);
}
#endif

/* A callback of one world of a running simnet: the simnet and its other
   worlds are in use. */
typedef struct sim_probe {
    gs_simnet *sim;
    gs_world *other, *late;
    int done;
    gs_result run, link, join;
    char other_text[256]; /* the other world's error text after its destroy
                             (its next advance starts the text afresh) */
} sim_probe;

static gs_result sim_meddling_step(void *user, double t, double dt) {
    sim_probe *p = (sim_probe *)user;
    gs_link_desc ld;
    gs_net *net = NULL;
    (void)t;
    (void)dt;
    if (p->done) return GS_OK;
    p->done = 1;
    memset(&ld, 0, sizeof ld);
    p->run = gs_simnet_run(p->sim, 1.0, 0.01);
    p->link = gs_simnet_link(p->sim, 1, 2, &ld);
    p->join = test_join(p->sim, p->late, NULL, &net);
    gs_world_destroy(p->other); /* refused: its simnet runs */
    snprintf(p->other_text, sizeof p->other_text, "%s", gs_world_error(p->other));
    gs_simnet_destroy(p->sim);  /* ignored */
    return GS_OK;
}

static void test_hostile_simnet_calls(void **state) {
    gs_world *w[3];
    gs_net *net[2];
    gs_simnet *sim = NULL;
    sim_probe sp;
    two_values v[2];
    gs_custom_desc d;
    gs_agent *a;
    int h;
    (void)state;
    memset(&sp, 0, sizeof sp);
    memset(v, 0, sizeof v);
    assert_int_equal(gs_simnet_create(NULL, &sim), GS_OK);
    for (h = 0; h < 3; ++h) w[h] = world_new((uint32_t)h + 1);
    for (h = 0; h < 2; ++h) assert_int_equal(test_join(sim, w[h], NULL, &net[h]), GS_OK);
    sp.sim = sim;
    sp.other = w[1];
    sp.late = w[2];
    d = two_values_desc(&v[0]);
    d.step = sim_meddling_step;
    d.user = &sp;
    d.state_size = 0;
    d.get_state = NULL;
    d.set_state = NULL;
    assert_int_equal(gs_custom_create(w[0], &d, &a), GS_OK);
    d = two_values_desc(&v[1]);
    assert_int_equal(gs_custom_create(w[1], &d, &a), GS_OK);
    assert_int_equal(gs_simnet_run(sim, 0.1, 0.02), GS_OK);
    assert_int_equal(sp.done, 1);
    assert_int_equal(sp.run, GS_ERR_BUSY);
    assert_int_equal(sp.link, GS_ERR_BUSY);
    assert_int_equal(sp.join, GS_ERR_BUSY);
    assert_null(gs_world_net(w[2]));
    assert_true(fabs(gs_simnet_time(sim) - 0.1) < 1e-9);
    assert_true(v[1].steps >= 9); /* world 2 lived on and advanced */
    assert_non_null(strstr(sp.other_text, "refused"));
    /* after the run: joining works, destroying works */
    assert_int_equal(test_join(sim, w[2], NULL, &net[0]), GS_OK);
    gs_simnet_destroy(sim);
    for (h = 0; h < 3; ++h) gs_world_destroy(w[h]);
}

/* ---- finding 8: a failed call changes nothing ---- */

static void test_hostile_scene_rollback(void **state) {
    gs_world *w;
    gs_world_desc wd = gs_world_desc_default();
    gs_scene_desc sd = gs_scene_desc_default();
    gs_scene sc;
    gs_rigid_desc rd = gs_rigid_desc_default();
    gs_agent *ball;
    (void)state;
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    sd.cloth_integrator = (gs_integrator)99;
    assert_int_equal(gs_scene_create(w, &sd, &sc), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_world_agent_count(w), 0);
    /* the ground stayed off: a ball dropped past y = -1.5 falls through */
    rd.shape.type = GS_SHAPE_SPHERE;
    rd.shape.radius = 0.1;
    rd.position.y = -1.45;
    assert_int_equal(gs_rigid_create(w, &rd, &ball), GS_OK);
    assert_int_equal(gs_world_advance(w, 1.0, NULL), GS_OK);
    assert_true(gs_rigid_position(ball).y < -5.0);
    gs_world_destroy(w);
}

static void test_hostile_simnet_join_rollback(void **state) {
    gs_world *w[3];
    gs_net *net[3];
    gs_simnet *sim = NULL;
    gs_net_desc small;
    gs_peer_stats ps;
    int h;
    (void)state;
    assert_int_equal(gs_simnet_create(NULL, &sim), GS_OK);
    for (h = 0; h < 3; ++h) w[h] = world_new((uint32_t)h + 1);
    memset(&small, 0, sizeof small);
    small.max_peers = 1;
    assert_int_equal(test_join(sim, w[0], NULL, &net[0]), GS_OK);
    assert_int_equal(test_join(sim, w[1], &small, &net[1]), GS_OK);
    net[2] = (gs_net *)(void *)&small;
    assert_int_equal(test_join(sim, w[2], NULL, &net[2]), GS_ERR_CAPACITY);
    assert_null(net[2]);
    assert_true(has_text(w[2], "max_peers"));
    assert_null(gs_world_net(w[2]));
    /* host 1 forgot host 3 again; host 2 never had it */
    assert_int_equal(gs_net_peer_stats(net[0], 3, &ps), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_peer_stats(net[1], 3, &ps), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_peer_stats(net[0], 2, &ps), GS_OK);
    assert_int_equal(gs_simnet_run(sim, 0.05, 0.01), GS_OK);
    gs_simnet_destroy(sim);
    for (h = 0; h < 3; ++h) gs_world_destroy(w[h]);
}

static void test_hostile_add_peer_rollback(void **state) {
    counter cnt;
    gs_world *w = counted_world(&cnt, 1);
    two_values v[2];
    gs_custom_desc d;
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_agent *a[2];
    gs_peer_stats ps;
    sink sk;
    gs_net *net;
    long before;
    int i;
    (void)state;
    memset(v, 0, sizeof v);
    memset(&sk, 0, sizeof sk);
    net = make_net(w, &sk);
    for (i = 0; i < 2; ++i) {
        d = two_values_desc(&v[i]);
        assert_int_equal(gs_custom_create(w, &d, &a[i]), GS_OK);
        gd.object_id = (uint32_t)i + 1;
        assert_int_equal(gs_ghost_attach(a[i], &gd), GS_OK);
    }
    before = live_blocks(&cnt);
    cnt.fail_once = 2; /* the second ghost's queue */
    assert_int_equal(gs_net_add_peer(net, 2, NULL), GS_ERR_NO_MEMORY);
    assert_int_equal(live_blocks(&cnt), before);
    assert_int_equal(gs_net_peer_stats(net, 2, &ps), GS_ERR_INVALID_ARG);
    assert_true(has_text(w, "gs_net_add_peer"));
    cnt.fail_once = 0;
    assert_int_equal(gs_net_add_peer(net, 2, NULL), GS_OK);
    assert_int_equal(live_blocks(&cnt), before + 2);
    gs_world_destroy(w);
    assert_int_equal(cnt.allocs, cnt.frees);
}

/* ---- finding 9: NULL handles ---- */

static void test_hostile_null_handles(void **state) {
    gs_world *w;
    gs_net *net;
    gs_agent *a;
    two_values v;
    gs_custom_desc d;
    gs_shape_desc sh;
    gs_contact c;
    int hit = 1;
    gs_vec3 zero = {0.0, 0.0, 0.0};
    gs_quat one = {0.0, 0.0, 0.0, 1.0};
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_ghost_stats gst;
    gs_peer_stats ps;
    gs_link_desc ld;
    gs_unknown_stats rej;
    double st[3];
    sink sk;
    (void)state;
    memset(&v, 0, sizeof v);
    memset(&sk, 0, sizeof sk);
    memset(&ld, 0, sizeof ld);
    assert_int_equal(gs_world_advance(NULL, 0.1, NULL), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_world_set_gravity(NULL, zero), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_world_set_budget(NULL, 1.0), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_world_set_ground(NULL, 1, 0.0, gs_material_default()),
                     GS_ERR_INVALID_ARG);
    assert_int_equal(gs_agent_get_state(NULL, st, 3), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_agent_set_state(NULL, st, 3), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_agent_step(NULL), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_agent_destroy(NULL), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_ghost_attach(NULL, &gd), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_ghost_detach(NULL), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_ghost_get_stats(NULL, &gst), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_ghost_render_state(NULL, st, 3), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_add_peer(NULL, 2, NULL), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_remove_peer(NULL, 2), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_update(NULL, 1.0), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_deliver(NULL, st, 8, 1.0, NULL), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_peer_stats(NULL, 2, &ps), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_unknown_stats(NULL, &rej), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_simnet_link(NULL, 1, 2, &ld), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_simnet_run(NULL, 1.0, 0.1), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_mesh_energy(NULL, NULL, NULL), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_mesh_move_pin(NULL, 0, zero), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_probe_set_target(NULL, zero, one), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_scene_attach_ghosts(NULL, NULL), GS_ERR_INVALID_ARG);
#ifndef GHOSTSIM_NO_UDP
    assert_int_equal(gs_net_add_peer(NULL, 2, "127.0.0.1:9"), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_remove_peer(NULL, 2), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_poll(NULL, 1.0), GS_ERR_INVALID_ARG);
    assert_null(NULL);
    gs_udp_close(NULL);
#endif
    memset(&sh, 0, sizeof sh);
    sh.type = GS_SHAPE_SPHERE;
    sh.radius = 1.0;
    assert_int_equal(gs_collide_shapes(NULL, zero, one, &sh, zero, one, &c, &hit),
                     GS_ERR_INVALID_ARG);
    assert_int_equal(hit, 0);
    assert_int_equal(gs_collide_shapes(&sh, zero, one, NULL, zero, one, &c, &hit),
                     GS_ERR_INVALID_ARG);
    assert_int_equal(gs_collide_shapes(&sh, zero, one, &sh, zero, one, NULL, &hit),
                     GS_ERR_INVALID_ARG);
    assert_int_equal(gs_collide_shapes(&sh, zero, one, &sh, zero, one, &c, NULL),
                     GS_ERR_INVALID_ARG);
    gs_net_destroy(NULL);
    gs_world_destroy(NULL);
    gs_simnet_destroy(NULL);
    assert_string_equal(gs_world_error(NULL), "");
    {
        gs_wire_view view;
        gs_reject why;
        assert_int_equal(gs_wire_decode(NULL, 100, &view, &why), GS_ERR_INVALID_ARG);
        assert_int_equal(why, GS_REJECT_SHORT);
        assert_int_equal(gs_wire_end(NULL, 100), 0);
    }
    /* NULL outputs on live handles */
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    d = two_values_desc(&v);
    assert_int_equal(gs_custom_create(w, &d, &a), GS_OK);
    net = make_net(w, &sk);
    assert_int_equal(gs_net_add_peer(net, 2, NULL), GS_OK);
    assert_int_equal(gs_net_unknown_stats(net, NULL), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_peer_stats(net, 2, NULL), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_deliver(net, NULL, 100, 1.0, NULL), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_ghost_attach(a, NULL), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_ghost_get_stats(a, NULL), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_agent_get_state(a, NULL, 3), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_agent_set_state(a, NULL, 3), GS_ERR_INVALID_ARG);
    gs_world_destroy(w);
}

/* ---- finding 11: smaller gaps ---- */

static void test_hostile_deliver_nan_now(void **state) {
    gs_world *w;
    gs_net *net;
    gs_agent *a;
    two_values v;
    gs_custom_desc d;
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_peer_stats ps;
    gs_unknown_stats rej;
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    size_t n;
    sink sk;
    int i;
    (void)state;
    memset(&v, 0, sizeof v);
    memset(&sk, 0, sizeof sk);
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    d = two_values_desc(&v);
    assert_int_equal(gs_custom_create(w, &d, &a), GS_OK);
    net = make_net(w, &sk);
    assert_int_equal(gs_net_add_peer(net, 2, NULL), GS_OK);
    gd.object_id = 7;
    assert_int_equal(gs_ghost_attach(a, &gd), GS_OK);
    n = snapshot_datagram(buf, 2, 1, 7, 0.0);
    assert_int_equal(gs_net_deliver(net, buf, n, NAN, NULL), GS_ERR_NOT_FINITE);
    assert_int_equal(gs_net_deliver(net, buf, n, INFINITY, NULL), GS_ERR_NOT_FINITE);
    assert_int_equal(gs_net_peer_stats(net, 2, &ps), GS_OK);
    assert_int_equal(ps.datagrams_received, 0);
    assert_int_equal(ps.rejected_total, 0);
    assert_int_equal(gs_net_unknown_stats(net, &rej), GS_OK);
    for (i = 0; i < GS_REJECT_COUNT; ++i) assert_int_equal(rej.rejected[i], 0);
    assert_int_equal(rej.rejected_total, 0);
    /* the same datagram at a finite time is taken */
    assert_int_equal(gs_net_deliver(net, buf, n, 1.0, NULL), GS_OK);
    gs_world_destroy(w);
}

static void test_hostile_wire_add_size(void **state) {
    unsigned char buf[256];
    gs_wire_header h;
    gs_wire_chunk c;
    double vals[2] = {1.0, 2.0};
    size_t size, wild[4];
    int i, k;
    (void)state;
    memset(&h, 0, sizeof h);
    memset(&c, 0, sizeof c);
    c.object_id = 1;
    c.count = 1;
    c.elements = 2;
    c.encoding = GS_ENCODING_F64;
    wild[0] = SIZE_MAX - 40; /* wrapped the room check: a write past buf */
    wild[1] = SIZE_MAX;
    wild[2] = 10;            /* inside the header */
    wild[3] = sizeof buf + 1;
    for (i = 0; i < 4; ++i) {
        memset(buf, 0xab, sizeof buf);
        assert_int_equal(gs_wire_begin(buf, 128, &h, &size), GS_OK);
        size = wild[i];
        assert_int_equal(gs_wire_add(buf, 128, &size, &c, vals), GS_ERR_INVALID_ARG);
        assert_true(size == wild[i]);
        for (k = GS_WIRE_HEADER; k < (int)sizeof buf; ++k) assert_int_equal(buf[k], 0xab);
    }
    /* a true size still works, and a chunk that does not fit is capacity */
    assert_int_equal(gs_wire_begin(buf, 128, &h, &size), GS_OK);
    assert_int_equal(gs_wire_add(buf, 128, &size, &c, vals), GS_OK);
    /* a first chunk's header (>>wire): kind, one-byte id and sequence
       varints, its time, its element count */
    assert_int_equal(size, GS_WIRE_HEADER + 12 + 16);
    /* the next ones share its time: 4-byte headers; a fourth does not fit */
    assert_int_equal(gs_wire_add(buf, 128, &size, &c, vals), GS_OK);
    assert_int_equal(size, GS_WIRE_HEADER + 12 + 16 + 4 + 16);
    assert_int_equal(gs_wire_add(buf, 128, &size, &c, vals), GS_OK);
    assert_int_equal(gs_wire_add(buf, 128, &size, &c, vals), GS_ERR_CAPACITY);
}

static void test_hostile_udp_port(void **state) {
#ifndef GHOSTSIM_NO_UDP
    gs_world *w;
    gs_net *u = NULL;
    gs_udp_desc ud;
    static const char *bad[] = {"127.0.0.1:99999", "127.0.0.1:65536", "[::1]:100000",
                                "127.0.0.1:123456789012345678901234567890", "127.0.0.1:8x"};
    int i;
    (void)state;
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    memset(&ud, 0, sizeof ud);
    for (i = 0; i < (int)(sizeof bad / sizeof bad[0]); ++i) {
        ud.bind = bad[i];
        assert_int_equal(test_udp_open(w, &ud, NULL, &u), GS_ERR_INVALID_ARG);
        assert_null(u);
        assert_null(gs_world_net(w));
    }
    ud.bind = "127.0.0.1:0";
    assert_int_equal(test_udp_open(w, &ud, NULL, &u), GS_OK);
    assert_int_equal(gs_net_add_peer(u, 2, "127.0.0.1:99999"), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_add_peer(u, 2, "127.0.0.1:65535"), GS_OK);
    gs_net_destroy(u);
    gs_world_destroy(w);
#else
    (void)state;
    skip();
#endif
}

static void test_hostile_huge_bandwidth(void **state) {
    gs_world *w;
    gs_net *net = NULL;
    gs_net_desc nd;
    sink sk;
    (void)state;
    memset(&sk, 0, sizeof sk);
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    memset(&nd, 0, sizeof nd);
    nd.transport.send = sink_send;
    nd.transport.user = &sk;
    nd.bandwidth = INFINITY; /* the caller's own field is named */
    assert_int_equal(gs_net_create(w, &nd, &net), GS_ERR_NOT_FINITE);
    assert_true(has_text(w, "bandwidth"));
    nd.bandwidth = 1e308; /* finite: max_rate derived from it stays finite */
    assert_int_equal(gs_net_create(w, &nd, &net), GS_OK);
    assert_int_equal(gs_net_add_peer(net, 2, NULL), GS_OK);
    assert_int_equal(gs_net_update(net, 1.0), GS_OK);
    gs_world_destroy(w);
}

/* Creating bodies in an order unsorted on x was O(n) per body (each one
   bubbled through the sweep-and-prune lists): 60 000 took 71 s. Here
   30 000 in descending x, which took about 18 s that way; the bound is
   loose so that a loaded machine never fails it. */
static double wall(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void test_hostile_rigid_creation_order(void **state) {
    gs_world *w;
    gs_world_desc wd = gs_world_desc_default();
    gs_rigid_desc rd = gs_rigid_desc_default();
    gs_agent *a, *b[3];
    gs_vec3 zero = {0.0, 0.0, 0.0};
    double t0, x[3] = {5.0, 0.9, 0.0};
    int i;
    (void)state;
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    rd.shape.type = GS_SHAPE_SPHERE;
    rd.shape.radius = 0.25;
    t0 = wall();
    for (i = 0; i < 30000; ++i) {
        rd.position.x = 30000.0 - (double)i;
        rd.position.z = (double)(i % 7);
        assert_int_equal(gs_rigid_create(w, &rd, &a), GS_OK);
    }
    print_message("30000 bodies created in descending x: %.3f s\n", wall() - t0);
    assert_true(wall() - t0 < 5.0);
    gs_world_destroy(w);

    /* and the lists sorted late still find every contact: two overlapping
       spheres created out of order push each other apart */
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    assert_int_equal(gs_world_set_gravity(w, zero), GS_OK);
    rd.shape.radius = 0.5;
    rd.position.z = 0.0;
    for (i = 0; i < 3; ++i) {
        rd.position.x = x[i];
        assert_int_equal(gs_rigid_create(w, &rd, &b[i]), GS_OK);
    }
    assert_int_equal(gs_world_advance(w, 0.01, NULL), GS_OK);
    assert_true(gs_rigid_velocity(b[1]).x > 0.0);
    assert_true(gs_rigid_velocity(b[2]).x < 0.0);
    assert_true(gs_rigid_velocity(b[0]).x == 0.0);
    gs_world_destroy(w);
}

int main(int argc, char **argv) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_hostile_custom_size),
        cmocka_unit_test(test_hostile_ghost_size),
        cmocka_unit_test(test_hostile_custom_step_calls),
        cmocka_unit_test(test_hostile_outside_advance_calls),
        cmocka_unit_test(test_hostile_weight_rule_calls),
        cmocka_unit_test(test_hostile_send_callback_calls),
#ifndef GHOSTSIM_NO_UDP
        cmocka_unit_test(test_hostile_udp_weight_rule),
#endif
        cmocka_unit_test(test_hostile_simnet_calls),
        cmocka_unit_test(test_hostile_scene_rollback),
        cmocka_unit_test(test_hostile_simnet_join_rollback),
        cmocka_unit_test(test_hostile_add_peer_rollback),
        cmocka_unit_test(test_hostile_null_handles),
        cmocka_unit_test(test_hostile_deliver_nan_now),
        cmocka_unit_test(test_hostile_wire_add_size),
        cmocka_unit_test(test_hostile_udp_port),
        cmocka_unit_test(test_hostile_huge_bandwidth),
        cmocka_unit_test(test_hostile_rigid_creation_order),
    };
    if (argc > 1) cmocka_set_test_filter(argv[1]); /* a glob: 'test_hostile_udp*' */
    return cmocka_run_group_tests(tests, NULL, NULL);
}
