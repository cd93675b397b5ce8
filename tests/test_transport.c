/* test_transport.c - one way to make a net and add a peer: gs_net_create
   on a gs_transport (a table of callbacks) that the simnet, UDP or the
   application fills, and gs_net_add_peer(net, host, addr).

   The convergence checks use a toy custom agent (x += v dt) ghosted with
   the owner rule, host 1 the owner: host 2's copy must come to host 1's
   state. Host 1's x is set once and its v is 0, so its state stands still
   and host 2's copy, blended with weight 1 on the owner's snapshot, takes
   it exactly once a snapshot arrives; 1e-9 leaves room for the rounding
   of the time alignment only. UDP runs on loopback ports the kernel
   picks, every loop is bounded. */
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

#include "ghostsim.h"
#include "net_helpers.h"
#include "world_helpers.h"

/* ---- a toy agent: x0 += x1 dt ---- */
typedef struct toy {
    double x[2];
} toy;

static gs_result toy_step(void *user, double t, double dt) {
    toy *p = (toy *)user;
    (void)t;
    p->x[0] += p->x[1] * dt;
    return GS_OK;
}
static void toy_get(const void *user, double *out) {
    memcpy(out, ((const toy *)user)->x, sizeof ((const toy *)user)->x);
}
static gs_result toy_set(void *user, const double *in) {
    memcpy(((toy *)user)->x, in, sizeof ((toy *)user)->x);
    return GS_OK;
}

typedef struct host {
    gs_world *w;
    gs_agent *a;
    toy t;
    gs_net *net;
} host;

/* A world of host id `id` with one toy ghost (object 1, owned by host 1). */
static void host_make(host *h, uint32_t id, double x) {
    gs_ghost_desc gd = gs_ghost_desc_default();
    memset(h, 0, sizeof *h);
    h->t.x[0] = x;
    h->w = world_new(id);
    h->a = custom_new(h->w, 0.01, 2, toy_step, toy_get, toy_set, &h->t);
    gd.object_id = 1;
    gd.weight = gs_weight_owner;
    gd.owner = 1;
    assert_int_equal(gs_ghost_attach(h->a, &gd), GS_OK);
}

/* ---- the application's own transport: a table with only send ---- */

#define BOX_MAX 256
typedef struct box {
    int n;
    size_t size[BOX_MAX];
    unsigned char data[BOX_MAX][GS_WIRE_MAX_DATAGRAM];
    uint32_t to[BOX_MAX];
} box;

/* Keeps a copy: `data` lives only during the call. */
static gs_result box_send(void *user, uint32_t host, const void *data, size_t size) {
    box *b = (box *)user;
    if (b->n == BOX_MAX) return GS_OK; /* lost, as a network may */
    memcpy(b->data[b->n], data, size);
    b->size[b->n] = size;
    b->to[b->n] = host;
    b->n++;
    return GS_OK;
}

static void box_deliver(box *b, gs_net *to, double now) {
    int i;
    for (i = 0; i < b->n; ++i) gs_net_deliver(to, b->data[i], b->size[i], now, NULL);
    b->n = 0;
}

static void test_own_transport_converges(void **state) {
    host h1, h2;
    box *b1 = (box *)calloc(1, sizeof *b1), *b2 = (box *)calloc(1, sizeof *b2);
    gs_net_desc nd = gs_net_desc_default();
    gs_peer_stats ps;
    int f;
    (void)state;
    assert_non_null(b1);
    assert_non_null(b2);
    host_make(&h1, 1, 0.25);
    host_make(&h2, 2, -3.0);
    nd.transport.send = box_send; /* nothing else: no addresses, no poll */
    nd.transport.user = b1;
    assert_int_equal(gs_net_create(h1.w, &nd, &h1.net), GS_OK);
    nd.transport.user = b2;
    assert_int_equal(gs_net_create(h2.w, &nd, &h2.net), GS_OK);
    assert_int_equal(gs_net_add_peer(h1.net, 2, NULL), GS_OK);
    assert_int_equal(gs_net_add_peer(h2.net, 1, NULL), GS_OK);
    for (f = 1; f <= 60; ++f) { /* 1 s in frames of 1/60 s */
        double now = f / 60.0;
        box_deliver(b2, h1.net, now);
        box_deliver(b1, h2.net, now);
        assert_int_equal(gs_world_advance(h1.w, 1.0 / 60.0, NULL), GS_OK);
        assert_int_equal(gs_world_advance(h2.w, 1.0 / 60.0, NULL), GS_OK);
        /* a transport without poll: gs_net_poll is gs_net_update */
        assert_int_equal(gs_net_poll(h1.net, now), GS_OK);
        assert_int_equal(gs_net_update(h2.net, now), GS_OK);
    }
    assert_true(fabs(h2.t.x[0] - h1.t.x[0]) < 1e-9);
    assert_int_equal(gs_net_peer_stats(h2.net, 1, &ps), GS_OK);
    assert_true(ps.snapshots_received > 0);
    assert_int_equal(ps.rejected_total, 0);
    gs_world_destroy(h1.w);
    gs_world_destroy(h2.w);
    free(b1);
    free(b2);
}

/* ---- a transport that records what the net asks of it ---- */

typedef struct rec {
    int adds, removes, attaches, polls, detaches;
    uint32_t last_host;
    char last_addr[64];
    int addr_null;
    gs_result add_result, attach_result;
    double poll_now;
    int sends;
} rec;

static gs_result rec_send(void *user, uint32_t host, const void *data, size_t size) {
    (void)host;
    (void)data;
    (void)size;
    ((rec *)user)->sends++;
    return GS_OK;
}
static gs_result rec_add(void *user, uint32_t host, const char *addr) {
    rec *r = (rec *)user;
    r->adds++;
    r->last_host = host;
    r->addr_null = addr == NULL;
    snprintf(r->last_addr, sizeof r->last_addr, "%s", addr ? addr : "");
    return r->add_result;
}
static gs_result rec_remove(void *user, uint32_t host) {
    rec *r = (rec *)user;
    r->removes++;
    r->last_host = host;
    return GS_OK;
}
static gs_result rec_attach(void *user, gs_net *net) {
    rec *r = (rec *)user;
    assert_non_null(net);
    r->attaches++;
    return r->attach_result;
}
static gs_result rec_poll(void *user, gs_net *net, double now) {
    rec *r = (rec *)user;
    (void)net;
    r->polls++;
    r->poll_now = now;
    return GS_OK;
}
static void rec_detach(void *user, gs_net *net) {
    (void)net;
    ((rec *)user)->detaches++;
}

static gs_transport rec_table(rec *r) {
    gs_transport t;
    memset(&t, 0, sizeof t);
    t.user = r;
    t.send = rec_send;
    t.add_peer = rec_add;
    t.remove_peer = rec_remove;
    t.attach = rec_attach;
    t.poll = rec_poll;
    t.detach = rec_detach;
    return t;
}

static void test_create_needs_send(void **state) {
    host h;
    gs_net_desc nd = gs_net_desc_default();
    gs_net *net = (gs_net *)&nd; /* not NULL: the failure must clear it */
    (void)state;
    host_make(&h, 1, 0.0);
    assert_int_equal(gs_net_create(h.w, &nd, &net), GS_ERR_INVALID_ARG);
    assert_null(net);
    assert_non_null(strstr(gs_world_error(h.w), "transport.send is NULL"));
    assert_null(gs_world_net(h.w));
    gs_world_destroy(h.w);
}

static void test_attach_detach(void **state) {
    host h;
    rec r;
    gs_net_desc nd = gs_net_desc_default();
    gs_net *net;
    (void)state;
    host_make(&h, 1, 0.0);
    memset(&r, 0, sizeof r);
    nd.transport = rec_table(&r);
    r.attach_result = GS_ERR_SYSTEM; /* an attach that fails undoes the create */
    assert_int_equal(gs_net_create(h.w, &nd, &net), GS_ERR_SYSTEM);
    assert_null(net);
    assert_null(gs_world_net(h.w));
    assert_int_equal(r.attaches, 1);
    assert_int_equal(r.detaches, 0); /* never attached: nothing to detach */
    r.attach_result = GS_OK;
    assert_int_equal(gs_net_create(h.w, &nd, &net), GS_OK);
    assert_true(gs_world_net(h.w) == net);
    assert_int_equal(r.attaches, 2);
    /* the poll, then the update, at the frame's now */
    assert_int_equal(gs_net_add_peer(net, 2, NULL), GS_OK);
    assert_int_equal(gs_world_advance(h.w, 0.02, NULL), GS_OK);
    assert_int_equal(gs_net_poll(net, 0.5), GS_OK);
    assert_int_equal(r.polls, 1);
    assert_true(r.poll_now == 0.5);
    assert_true(r.sends > 0);
    assert_int_equal(gs_net_poll(net, NAN), GS_ERR_NOT_FINITE);
    assert_int_equal(gs_net_poll(net, -1.0), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_poll(NULL, 1.0), GS_ERR_INVALID_ARG);
    assert_int_equal(r.polls, 1); /* refused before the transport saw them */
    gs_world_destroy(h.w); /* destroys the net: the transport detaches */
    assert_int_equal(r.detaches, 1);
}

static void test_add_remove_peer(void **state) {
    host h;
    rec r;
    gs_net_desc nd = gs_net_desc_default();
    gs_net *net;
    gs_peer_stats ps;
    box *b = (box *)calloc(1, sizeof *b);
    (void)state;
    assert_non_null(b);
    host_make(&h, 1, 0.0);
    memset(&r, 0, sizeof r);
    nd.transport = rec_table(&r);
    assert_int_equal(gs_net_create(h.w, &nd, &net), GS_OK);
    /* with an address and without: the transport gets what was given */
    assert_int_equal(gs_net_add_peer(net, 2, "somewhere:7"), GS_OK);
    assert_int_equal(r.adds, 1);
    assert_int_equal(r.last_host, 2);
    assert_string_equal(r.last_addr, "somewhere:7");
    assert_int_equal(gs_net_add_peer(net, 3, NULL), GS_OK);
    assert_int_equal(r.adds, 2);
    assert_true(r.addr_null);
    /* a peer again: the transport takes the new address */
    assert_int_equal(gs_net_add_peer(net, 2, "elsewhere:8"), GS_OK);
    assert_int_equal(r.adds, 3);
    assert_string_equal(r.last_addr, "elsewhere:8");
    /* the net's own checks come before the transport's */
    assert_int_equal(gs_net_add_peer(net, 0, NULL), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_add_peer(net, 1, NULL), GS_ERR_INVALID_ARG);
    assert_int_equal(r.adds, 3);
    /* a transport that refuses the address refuses the peer */
    r.add_result = GS_ERR_INVALID_ARG;
    assert_int_equal(gs_net_add_peer(net, 4, "bad"), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_peer_stats(net, 4, &ps), GS_ERR_INVALID_ARG);
    r.add_result = GS_OK;
    /* remove_peer reaches the transport, after the net forgot the peer */
    assert_int_equal(gs_net_remove_peer(net, 3), GS_OK);
    assert_int_equal(r.removes, 1);
    assert_int_equal(r.last_host, 3);
    assert_int_equal(gs_net_peer_stats(net, 3, &ps), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_remove_peer(net, 3), GS_ERR_INVALID_ARG); /* not a peer */
    assert_int_equal(r.removes, 1);
    gs_world_destroy(h.w);

    /* a transport without add_peer uses no addresses: one given is refused */
    host_make(&h, 1, 0.0);
    memset(&nd.transport, 0, sizeof nd.transport);
    nd.transport.send = box_send;
    nd.transport.user = b;
    assert_int_equal(gs_net_create(h.w, &nd, &net), GS_OK);
    assert_int_equal(gs_net_add_peer(net, 2, NULL), GS_OK);
    assert_int_equal(gs_net_add_peer(net, 3, "127.0.0.1:9"), GS_ERR_INVALID_ARG);
    assert_non_null(strstr(gs_world_error(h.w), "uses no addresses"));
    assert_int_equal(gs_net_peer_stats(net, 3, &ps), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_remove_peer(net, 2), GS_OK); /* no remove_peer: fine */
    gs_world_destroy(h.w);
    free(b);
}

/* ---- the simnet's transport ---- */

static void test_simnet_transport(void **state) {
    gs_simnet *sim;
    host h[3];
    gs_net_desc nd = gs_net_desc_default();
    gs_transport spare;
    gs_peer_stats ps;
    gs_simnet_stats st;
    int i;
    (void)state;
    assert_int_equal(gs_simnet_create(NULL, &sim), GS_OK);
    assert_int_equal(gs_simnet_transport(NULL, &nd.transport), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_simnet_transport(sim, NULL), GS_ERR_INVALID_ARG);
    for (i = 0; i < 3; ++i) {
        host_make(&h[i], (uint32_t)i + 1, i == 0 ? 0.5 : 2.0);
        assert_int_equal(gs_simnet_transport(sim, &nd.transport), GS_OK);
        assert_int_equal(gs_net_create(h[i].w, &nd, &h[i].net), GS_OK);
    }
    /* every host is every other's peer already, without addresses */
    assert_int_equal(gs_net_peer_stats(h[0].net, 3, &ps), GS_OK);
    assert_int_equal(gs_net_peer_stats(h[2].net, 1, &ps), GS_OK);
    assert_int_equal(gs_net_add_peer(h[0].net, 2, NULL), GS_OK);  /* a peer already */
    assert_int_equal(gs_net_add_peer(h[0].net, 2, "127.0.0.1:9"), GS_ERR_INVALID_ARG);
    assert_non_null(strstr(gs_world_error(h[0].w), "uses no addresses"));
    /* remove and add again */
    assert_int_equal(gs_net_remove_peer(h[0].net, 3), GS_OK);
    assert_int_equal(gs_net_peer_stats(h[0].net, 3, &ps), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_add_peer(h[0].net, 3, NULL), GS_OK);
    /* host 3 leaves; its transport made its net: given again, refused */
    gs_net_destroy(h[2].net);
    assert_null(gs_world_net(h[2].w));
    assert_int_equal(gs_net_create(h[2].w, &nd, &h[2].net), GS_ERR_INVALID_ARG);
    assert_non_null(strstr(gs_world_error(h[2].w), "made a net already"));
    /* a transport given back by a failed create is given again */
    assert_int_equal(gs_simnet_transport(sim, &spare), GS_OK);
    nd.transport = spare;
    assert_int_equal(gs_net_create(h[1].w, &nd, &h[1].net), GS_ERR_INVALID_ARG); /* has one */
    assert_int_equal(gs_simnet_run(sim, 1.0, 1.0 / 60.0), GS_OK);
    /* host 3 left: what went to it is lost, the others met */
    assert_true(fabs(h[1].t.x[0] - h[0].t.x[0]) < 1e-9);
    assert_int_equal(gs_simnet_get_stats(sim, &st), GS_OK);
    assert_true(st.dropped > 0);
    /* host 3 joins again on a new transport */
    assert_int_equal(gs_simnet_transport(sim, &nd.transport), GS_OK);
    assert_int_equal(gs_net_create(h[2].w, &nd, &h[2].net), GS_OK);
    assert_int_equal(gs_simnet_run(sim, 1.0, 1.0 / 60.0), GS_OK);
    assert_true(fabs(h[2].t.x[0] - h[0].t.x[0]) < 1e-9);
    /* a peer that never joined the simnet: every send to it fails */
    assert_int_equal(gs_net_add_peer(h[0].net, 9, NULL), GS_OK);
    assert_int_equal(gs_simnet_run(sim, 0.1, 1.0 / 60.0), GS_OK);
    assert_int_equal(gs_net_peer_stats(h[0].net, 9, &ps), GS_OK);
    assert_true(ps.send_failures > 0 && ps.datagrams_sent == 0);
    assert_int_equal(gs_net_remove_peer(h[0].net, 9), GS_OK);
    /* the simnet goes first: the nets left send nothing, and say so */
    gs_simnet_destroy(sim);
    assert_int_equal(gs_world_advance(h[0].w, 0.1, NULL), GS_OK);
    assert_int_equal(gs_net_update(h[0].net, 100.0), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_peer_stats(h[0].net, 2, &ps), GS_OK);
    assert_true(ps.send_failures > 0);
    for (i = 0; i < 3; ++i) gs_world_destroy(h[i].w);
}

/* ---- UDP ---- */

/* h's net on a UDP socket at addr (threads 0: poll mode). */
static gs_result udp_net(host *h, const char *addr, int threads) {
    gs_udp_desc ud = gs_udp_desc_default();
    ud.bind = addr;
    ud.threads = threads;
    return test_udp_open(h->w, &ud, NULL, &h->net);
}

static void test_udp_peers(void **state) {
    host h1, h2;
    char a1[64], a2[64];
    gs_peer_stats ps;
    gs_udp_desc ud = gs_udp_desc_default();
    gs_net_desc nd = gs_net_desc_default();
    gs_udp *u;
    gs_net *net;
    (void)state;
    assert_true(loopback_addr(0, a1, sizeof a1) && loopback_addr(0, a2, sizeof a2));
    host_make(&h1, 1, 0.0);
    host_make(&h2, 2, 0.0);
    assert_int_equal(udp_net(&h1, a1, 0), GS_OK);
    /* an address is required, and must parse */
    assert_int_equal(gs_net_add_peer(h1.net, 2, NULL), GS_ERR_INVALID_ARG);
    assert_non_null(strstr(gs_world_error(h1.w), "needs its address"));
    assert_int_equal(gs_net_peer_stats(h1.net, 2, &ps), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_add_peer(h1.net, 2, "nowhere"), GS_ERR_INVALID_ARG);
    assert_non_null(strstr(gs_world_error(h1.w), "is not HOST:PORT"));
    assert_int_equal(gs_net_add_peer(h1.net, 2, a2), GS_OK);
    assert_int_equal(gs_net_peer_stats(h1.net, 2, &ps), GS_OK);
    assert_int_equal(gs_net_add_peer(h1.net, 2, a1), GS_OK); /* its address replaced */
    assert_int_equal(gs_net_remove_peer(h1.net, 2), GS_OK);
    assert_int_equal(gs_net_peer_stats(h1.net, 2, &ps), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_remove_peer(h1.net, 2), GS_ERR_INVALID_ARG);
    /* a gs_udp makes one net, for its own world */
    assert_int_equal(gs_udp_transport(NULL, &nd.transport), GS_ERR_INVALID_ARG);
    ud.bind = a2;
    assert_int_equal(gs_udp_create(h1.w, &ud, &u), GS_OK);
    assert_int_equal(gs_udp_transport(u, &nd.transport), GS_OK);
    assert_int_equal(gs_net_create(h2.w, &nd, &net), GS_ERR_INVALID_ARG);
    assert_non_null(strstr(gs_world_error(h2.w), "another world"));
    gs_udp_close(u); /* never attached: the socket closes, u is freed */
    assert_int_equal(gs_udp_create(NULL, &ud, &u), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_udp_create(h2.w, NULL, &u), GS_ERR_INVALID_ARG);
    ud.bind = a1; /* held by host 1's socket */
    assert_int_equal(gs_udp_create(h2.w, &ud, &u), GS_ERR_SYSTEM);
    assert_null(u);
    gs_world_destroy(h1.w); /* its net, and its gs_udp with it */
    /* the port is free again; threads this time, closed by gs_udp_close */
    ud.bind = a1;
    ud.threads = 1;
    assert_int_equal(gs_udp_create(h2.w, &ud, &u), GS_OK);
    assert_int_equal(gs_udp_transport(u, &nd.transport), GS_OK);
    assert_int_equal(gs_net_create(h2.w, &nd, &net), GS_OK);
    assert_int_equal(gs_net_add_peer(net, 1, a2), GS_OK);
    gs_udp_close(u); /* destroys its net, which frees u */
    assert_null(gs_world_net(h2.w));
    gs_world_destroy(h2.w);
}

static void test_udp_poll_mode(void **state) {
    host h1, h2;
    char a1[64], a2[64];
    gs_peer_stats ps1, ps2;
    double start, last, now;
    int frames = 0;
    (void)state;
    assert_true(loopback_addr(0, a1, sizeof a1) && loopback_addr(0, a2, sizeof a2));
    host_make(&h1, 1, 0.75);
    host_make(&h2, 2, -1.0);
    assert_int_equal(udp_net(&h1, a1, 0), GS_OK);
    assert_int_equal(udp_net(&h2, a2, 0), GS_OK);
    assert_int_equal(gs_net_add_peer(h1.net, 2, a2), GS_OK);
    assert_int_equal(gs_net_add_peer(h2.net, 1, a1), GS_OK);
    start = last = gs_udp_now();
    /* at most 2 s of wall time, or until host 2 has met host 1 for 20
       frames after hearing from it */
    while ((now = gs_udp_now()) - start < 2.0) {
        struct timespec nap = {0, 5000000};
        assert_int_equal(gs_world_advance(h1.w, now - last, NULL), GS_OK);
        assert_int_equal(gs_world_advance(h2.w, now - last, NULL), GS_OK);
        assert_int_equal(gs_net_poll(h1.net, now), GS_OK); /* receive, then send */
        assert_int_equal(gs_net_poll(h2.net, now), GS_OK);
        last = now;
        assert_int_equal(gs_net_peer_stats(h2.net, 1, &ps2), GS_OK);
        if (ps2.snapshots_received > 0 && fabs(h2.t.x[0] - h1.t.x[0]) < 1e-9 && ++frames >= 20)
            break;
        nanosleep(&nap, NULL);
    }
    assert_int_equal(gs_net_peer_stats(h1.net, 2, &ps1), GS_OK);
    assert_int_equal(gs_net_peer_stats(h2.net, 1, &ps2), GS_OK);
    assert_true(ps1.datagrams_received > 0 && ps2.datagrams_received > 0);
    assert_int_equal(ps1.send_failures + ps2.send_failures, 0);
    assert_true(fabs(h2.t.x[0] - h1.t.x[0]) < 1e-9);
    assert_int_equal(gs_net_poll(h1.net, NAN), GS_ERR_NOT_FINITE);
    gs_world_destroy(h1.w);
    gs_world_destroy(h2.w);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_own_transport_converges),
        cmocka_unit_test(test_create_needs_send),
        cmocka_unit_test(test_attach_detach),
        cmocka_unit_test(test_add_remove_peer),
        cmocka_unit_test(test_simnet_transport),
        cmocka_unit_test(test_udp_peers),
        cmocka_unit_test(test_udp_poll_mode),
    };
    return cmocka_run_group_tests_name("transport", tests, NULL, NULL);
}
