/* test_api.c - the API a newcomer meets (issue 18): the weight rule names
   the object it weighs, per-object rules through gs_scene_attach_ghosts,
   the defaults are the advice (zero means default in every desc, and each
   desc's _default() gives the documented values), gs_result everywhere,
   stats calls in one shape, and a transport's failures counted and
   returned. Hosts run on a gs_simnet (virtual clock: nothing here depends
   on wall time). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ghostsim.h"
#include "net_helpers.h"
#include "world_helpers.h"

/* Host `host`'s world with a small paper scene: a 4 x 4 cloth, and the
   spheres and probes asked (0: the defaults; GS_NONE: none). */
static gs_world *small_scene(uint32_t host, int spheres, int probes, gs_scene *sc) {
    gs_world *w = world_new(host);
    gs_scene_desc sd = gs_scene_desc_default();
    sd.cloth_n = 4;
    sd.sphere_count = spheres;
    sd.probe_count = probes;
    assert_int_equal(gs_scene_create(w, &sd, sc), GS_OK);
    return w;
}

/* ---- the weight rule names the object ---- */

#define SEEN_MAX 16
/* What a recording rule saw: each object id once, with its agent. */
typedef struct seen {
    uint32_t ids[SEEN_MAX];
    const gs_agent *agents[SEEN_MAX];
    int count;
    int calls, bad_agent;
    const gs_scene *scene; /* the host's own scene: in->agent is one of its */
} seen;

static int scene_has_agent(const gs_scene *sc, const gs_agent *a) {
    int i;
    if (a == sc->cloth) return 1;
    for (i = 0; i < sc->sphere_count; ++i) if (a == sc->spheres[i]) return 1;
    for (i = 0; i < sc->probe_count; ++i) if (a == sc->probes[i]) return 1;
    return 0;
}

/* The client/server rule, noting which object it weighs. */
static double recording_cs(const gs_weight_in *in, void *user) {
    seen *s = (seen *)user;
    int i;
    s->calls++;
    if (!scene_has_agent(s->scene, in->agent)) s->bad_agent++;
    for (i = 0; i < s->count && s->ids[i] != in->object_id; ++i) {}
    if (i == s->count && s->count < SEEN_MAX) {
        s->ids[s->count] = in->object_id;
        s->agents[s->count++] = in->agent;
    }
    return gs_weight_cs(in, NULL);
}

/* rule_for: the recording rule for the cloth and the spheres, the default
   (NULL) for the probes; it notes every object it is asked about. */
typedef struct rules {
    seen rec;
    uint32_t asked[SEEN_MAX];
    const gs_agent *asked_agent[SEEN_MAX];
    int asked_count;
} rules;

static gs_weight_rule rule_for(uint32_t object_id, const gs_agent *a, void *user) {
    rules *r = (rules *)user;
    gs_weight_rule rule;
    if (r->asked_count < SEEN_MAX) {
        r->asked[r->asked_count] = object_id;
        r->asked_agent[r->asked_count++] = a;
    }
    rule.fn = object_id < 200 ? recording_cs : NULL;
    rule.user = &r->rec;
    return rule;
}

static const gs_agent *seen_agent(const seen *s, uint32_t id) {
    int i;
    for (i = 0; i < s->count; ++i) if (s->ids[i] == id) return s->agents[i];
    return NULL;
}

/* Two hosts of a small paper scene on a perfect simnet, every object's rule
   from rule_for: each host's rule is called for the cloth and both spheres
   with the host's own agents, never for a probe (they keep the owner
   rule); rule_for is asked once per object, probes included, with the
   scene's agent. */
static void test_weight_rule_names_object(void **state) {
    gs_simnet *sim;
    gs_world *w[2];
    gs_scene sc[2];
    rules r[2];
    int h, i;
    (void)state;
    memset(r, 0, sizeof r);
    assert_int_equal(gs_simnet_create(NULL, &sim), GS_OK);
    for (h = 0; h < 2; ++h) {
        gs_ghost_desc gd = gs_ghost_desc_default();
        gs_net *net;
        w[h] = small_scene((uint32_t)h + 1, 2, 2, &sc[h]);
        r[h].rec.scene = &sc[h];
        gd.rule_for = rule_for;
        gd.rule_for_user = &r[h];
        assert_int_equal(gs_scene_attach_ghosts(&sc[h], &gd), GS_OK);
        assert_int_equal(test_join(sim, w[h], NULL, &net), GS_OK);
    }
    assert_int_equal(gs_simnet_run(sim, 0.5, 1.0 / 60.0), GS_OK);
    for (h = 0; h < 2; ++h) {
        static const uint32_t ids[5] = {1, 100, 101, 200, 201};
        assert_int_equal(r[h].asked_count, 5);
        for (i = 0; i < 5; ++i) {
            assert_int_equal(r[h].asked[i], ids[i]);
            assert_true(scene_has_agent(&sc[h], r[h].asked_agent[i]));
        }
        assert_ptr_equal(r[h].asked_agent[0], sc[h].cloth);
        assert_ptr_equal(r[h].asked_agent[3], sc[h].probes[0]);
        assert_true(r[h].rec.calls > 0);
        assert_int_equal(r[h].rec.bad_agent, 0);
        assert_int_equal(r[h].rec.count, 3); /* cloth and two spheres only */
        assert_ptr_equal(seen_agent(&r[h].rec, 1), sc[h].cloth);
        assert_ptr_equal(seen_agent(&r[h].rec, 100), sc[h].spheres[0]);
        assert_ptr_equal(seen_agent(&r[h].rec, 101), sc[h].spheres[1]);
        assert_null(seen_agent(&r[h].rec, 200));
    }
    for (h = 0; h < 2; ++h) gs_world_destroy(w[h]);
    gs_simnet_destroy(sim);
}

/* A ghost attached on its own: the rule sees its object id and agent. */
static void test_weight_in_single_ghost(void **state) {
    gs_simnet *sim;
    gs_world *w[2];
    gs_scene sc[2];
    seen s[2];
    int h;
    (void)state;
    memset(s, 0, sizeof s);
    assert_int_equal(gs_simnet_create(NULL, &sim), GS_OK);
    for (h = 0; h < 2; ++h) {
        gs_ghost_desc gd = gs_ghost_desc_default();
        gs_net *net;
        w[h] = small_scene((uint32_t)h + 1, GS_NONE, GS_NONE, &sc[h]);
        assert_int_equal(sc[h].sphere_count + sc[h].probe_count, 0);
        s[h].scene = &sc[h];
        gd.object_id = 7;
        gd.weight = recording_cs;
        gd.weight_user = &s[h];
        assert_int_equal(gs_ghost_attach(sc[h].cloth, &gd), GS_OK);
        assert_int_equal(test_join(sim, w[h], NULL, &net), GS_OK);
    }
    assert_int_equal(gs_simnet_run(sim, 0.3, 1.0 / 60.0), GS_OK);
    for (h = 0; h < 2; ++h) {
        assert_int_equal(s[h].count, 1);
        assert_int_equal(s[h].ids[0], 7);
        assert_ptr_equal(s[h].agents[0], sc[h].cloth);
        assert_int_equal(s[h].bad_agent, 0);
    }
    for (h = 0; h < 2; ++h) gs_world_destroy(w[h]);
    gs_simnet_destroy(sim);
}

/* ---- defaults are the advice ---- */

static void test_default_weight_rule(void **state) {
    gs_ghost_desc gd = gs_ghost_desc_default();
    (void)state;
    assert_true(gd.weight == gs_weight_cs);
    assert_null(gd.weight_user);
    assert_true(gd.rule_for == NULL);
}

static gs_result drop_send(void *user, uint32_t host, const void *data, size_t size) {
    (void)user; (void)host; (void)data; (void)size;
    return GS_OK;
}

/* A world of host `id` with a net whose peers are `peers` (0-ended). */
static gs_world *world_with_peers(uint32_t id, const uint32_t *peers) {
    gs_world_desc wd = gs_world_desc_default();
    gs_net_desc nd = gs_net_desc_default();
    gs_world *w;
    gs_net *net;
    wd.host_id = id;
    nd.transport.send = drop_send;
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    if (peers) {
        assert_int_equal(gs_net_create(w, &nd, &net), GS_OK);
        for (; *peers; ++peers) assert_int_equal(gs_net_add_peer(net, *peers, NULL), GS_OK);
    }
    return w;
}

/* A zeroed gs_scene_desc, NULL and gs_scene_desc_default() are one scene:
   the paper's (3 spheres, a 16 x 16 cloth), with one probe per host id the
   net knows, GS_SCENE_DEFAULT_PROBES without a net; GS_NONE asks for none;
   any other negative count is refused by name. */
static void test_zeroed_scene_desc(void **state) {
    static const uint32_t peers23[] = {2, 3, 0}, peers1[] = {1, 0}, peers5[] = {1, 5, 0};
    gs_scene_desc zero, def = gs_scene_desc_default();
    gs_scene sc;
    gs_world *w;
    (void)state;
    memset(&zero, 0, sizeof zero);
    assert_int_equal(def.sphere_count, 3);
    assert_int_equal(def.probe_count, 0); /* one per host, known at create */
    w = world_with_peers(1, NULL);
    assert_int_equal(gs_scene_create(w, &zero, &sc), GS_OK);
    assert_int_equal(sc.sphere_count, 3);
    assert_int_equal(sc.probe_count, GS_SCENE_DEFAULT_PROBES);
    assert_int_equal(sc.desc.cloth_n, 16);
    assert_int_equal(gs_mesh_particle_count(sc.cloth), 16 * 16);
    assert_true(sc.desc.dt == def.dt && sc.desc.sphere_radius == def.sphere_radius);
    gs_world_destroy(w);
    w = world_with_peers(1, NULL);
    assert_int_equal(gs_scene_create(w, NULL, &sc), GS_OK);
    assert_int_equal(sc.sphere_count + sc.probe_count, 3 + GS_SCENE_DEFAULT_PROBES);
    gs_world_destroy(w);
    /* hosts 1, 2, 3: three probes on each of them */
    w = world_with_peers(1, peers23);
    assert_int_equal(gs_scene_create(w, &zero, &sc), GS_OK);
    assert_int_equal(sc.probe_count, 3);
    assert_int_equal(sc.desc.probe_count, 3);
    gs_world_destroy(w);
    w = world_with_peers(2, peers1);
    assert_int_equal(gs_scene_create(w, &def, &sc), GS_OK);
    assert_int_equal(sc.probe_count, 2);
    gs_world_destroy(w);
    /* probe i is host i + 1's: host 5 needs five */
    w = world_with_peers(2, peers5);
    assert_int_equal(gs_scene_create(w, &def, &sc), GS_OK);
    assert_int_equal(sc.probe_count, 5);
    gs_world_destroy(w);
    /* none, and a count that is neither */
    w = world_with_peers(1, peers23);
    zero.sphere_count = GS_NONE;
    zero.probe_count = GS_NONE;
    assert_int_equal(gs_scene_create(w, &zero, &sc), GS_OK);
    assert_int_equal(sc.sphere_count + sc.probe_count, 0);
    gs_world_destroy(w);
    w = world_with_peers(1, NULL);
    zero.sphere_count = -2;
    assert_int_equal(gs_scene_create(w, &zero, &sc), GS_ERR_INVALID_ARG);
    assert_non_null(strstr(gs_world_error(w), "sphere_count"));
    gs_world_destroy(w);
}

/* ---- every desc has a _default() ---- */

static gs_result custom_step(void *user, double t, double dt) {
    (void)user; (void)t; (void)dt;
    return GS_OK;
}

/* Each _default() gives the values its desc documents, and a zeroed desc
   makes what the _default() makes. */
static void test_desc_defaults(void **state) {
    gs_net_desc nd = gs_net_desc_default(), nz;
    gs_link_desc ld = gs_link_desc_default();
    gs_simnet_desc smd = gs_simnet_desc_default(), smz;
    gs_custom_desc cd = gs_custom_desc_default(), cz;
    gs_shape_desc shd = gs_shape_desc_default();
    gs_sync_desc syd = gs_sync_desc_default();
    gs_sim_clock ck = gs_sim_clock_default();
    gs_world_desc wd = gs_world_desc_default();
    gs_udp_desc ud = gs_udp_desc_default();
    gs_world *w;
    gs_net *net;
    gs_simnet *sim;
    gs_agent *a, *b;
    int i;
    (void)state;
    assert_int_equal(nd.session, 1);
    assert_true(nd.bandwidth == 1e7);
    assert_int_equal(nd.max_peers, 16);
    assert_true(nd.transport.send == NULL && nd.transport.user == NULL && nd.key == NULL && nd.time_window == 0.0 && nd.max_rate == 0.0);
    assert_true(ld.latency == 0.0 && ld.jitter == 0.0 && ld.loss == 0.0 && ld.duplicate == 0.0 &&
                ld.reorder == 0.0 && ld.bandwidth == 0.0);
    for (i = 0; i < GS_MAX_OUTAGES; ++i) assert_true(ld.outage_start[i] == ld.outage_end[i]);
    assert_true(smd.seed == 1 && smd.max_in_flight == 16384);
    assert_true(smd.allocator.alloc == NULL && smd.allocator.free == NULL);
    assert_true(cd.dt == 0.001 && cd.state_size == 0 && cd.step == NULL);
    assert_int_equal(shd.type, GS_SHAPE_NONE);
    assert_int_equal(syd.mode, wd.sync.mode);
    assert_int_equal(syd.clock, wd.sync.clock);
    assert_int_equal(syd.history_frames, 16);
    assert_int_equal(syd.replay_budget, 4096);
    assert_true(syd.replay_reach == GS_REPLAY_REACH);
    assert_true(ck.rate == 1.0 && ck.offset == 0.0 && ck.step_by == 0.0);
    assert_null(ud.bind);
    assert_int_equal(ud.threads, 0);
    assert_int_equal(ud.rcvbuf, 4 << 20);
    /* zeroed descs take the same defaults */
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    memset(&nz, 0, sizeof nz);
    nz.transport.send = drop_send;
    assert_int_equal(gs_net_create(w, &nz, &net), GS_OK);
    for (i = 2; i < 2 + 16; ++i) assert_int_equal(gs_net_add_peer(net, (uint32_t)i, NULL), GS_OK);
    assert_int_equal(gs_net_add_peer(net, 99, NULL), GS_ERR_CAPACITY); /* max_peers 16 */
    memset(&cz, 0, sizeof cz);
    cz.step = custom_step;
    assert_int_equal(gs_custom_create(w, &cz, &a), GS_OK);
    cd.step = custom_step;
    assert_int_equal(gs_custom_create(w, &cd, &b), GS_OK);
    assert_true(gs_agent_dt(a) == 0.001 && gs_agent_dt(b) == 0.001);
    {   /* a zeroed cloth: 16 x 16 particles, as gs_cloth_desc_default() */
        gs_cloth_desc clz, cld = gs_cloth_desc_default();
        memset(&clz, 0, sizeof clz);
        assert_true(cld.nx == 16 && cld.ny == 16);
        assert_int_equal(gs_cloth_create(w, &clz, &a), GS_OK);
        assert_int_equal(gs_mesh_particle_count(a), 16 * 16);
    }
    {   /* a shape must be given */
        gs_rigid_desc rd = gs_rigid_desc_default();
        rd.shape = gs_shape_desc_default();
        assert_int_not_equal(gs_rigid_create(w, &rd, &a), GS_OK);
        rd.shape.type = GS_SHAPE_SPHERE;
        rd.shape.radius = 0.1;
        assert_int_equal(gs_rigid_create(w, &rd, &a), GS_OK);
    }
    gs_world_destroy(w);
    memset(&smz, 0, sizeof smz);
    assert_int_equal(gs_simnet_create(&smz, &sim), GS_OK);
    gs_simnet_destroy(sim);
    assert_int_equal(gs_simnet_create(&smd, &sim), GS_OK);
    gs_simnet_destroy(sim);
}

/* ---- transport errors counted and returned; gs_result everywhere ---- */

/* A transport that refuses every datagram to `bad` (GS_ERR_SYSTEM, as a
   socket would) and keeps the last one to anyone else. */
typedef struct flaky {
    uint32_t bad;
    int calls, sent;
    unsigned char last[GS_WIRE_MAX_DATAGRAM];
    size_t last_size;
} flaky;

static gs_result flaky_send(void *user, uint32_t host, const void *data, size_t size) {
    flaky *f = (flaky *)user;
    f->calls++;
    if (host == f->bad) return GS_ERR_SYSTEM;
    f->sent++;
    memcpy(f->last, data, size);
    f->last_size = size;
    return GS_OK;
}

/* Host 1 with a ghosted cloth, peers 2 and 3, on a flaky transport. */
static gs_world *flaky_host(flaky *f, gs_net **net) {
    gs_scene sc;
    gs_world *w = small_scene(1, GS_NONE, GS_NONE, &sc);
    assert_int_equal(gs_scene_attach_ghosts(&sc, NULL), GS_OK);
    assert_int_equal(send_only_net(w, NULL, flaky_send, f, net), GS_OK);
    assert_int_equal(gs_net_add_peer(*net, 2, NULL), GS_OK);
    assert_int_equal(gs_net_add_peer(*net, 3, NULL), GS_OK);
    return w;
}

/* A send callback that fails: gs_net_update still sends to the others and
   returns the error, naming the host; the peer's send_failures count it
   and datagrams_sent / bytes_sent count only what went. Once the
   transport works again, so does the update. */
static void test_send_failures(void **state) {
    flaky f;
    gs_net *net;
    gs_world *w;
    gs_peer_stats p2, p3;
    int k, failed = 0;
    (void)state;
    memset(&f, 0, sizeof f);
    f.bad = 3;
    w = flaky_host(&f, &net);
    for (k = 1; k <= 10; ++k) {
        gs_result r;
        assert_int_equal(gs_world_advance(w, 1.0 / 60.0, NULL), GS_OK);
        r = gs_net_update(net, k / 60.0);
        if (r != GS_OK) {
            assert_int_equal(r, GS_ERR_SYSTEM);
            assert_non_null(strstr(gs_world_error(w), "host 3"));
            failed++;
        }
    }
    assert_true(failed > 0);
    assert_int_equal(gs_net_peer_stats(net, 2, &p2), GS_OK);
    assert_int_equal(gs_net_peer_stats(net, 3, &p3), GS_OK);
    assert_true(p2.datagrams_sent > 0);
    assert_int_equal(p2.datagrams_sent, (uint64_t)f.sent);
    assert_int_equal(p2.send_failures, 0);
    assert_int_equal(p3.datagrams_sent, 0);
    assert_int_equal(p3.bytes_sent, 0);
    assert_int_equal(p3.send_failures, p2.datagrams_sent); /* the same datagrams */
    assert_int_equal((uint64_t)f.calls, p2.datagrams_sent + p3.send_failures);
    /* the transport recovers */
    f.bad = 0;
    for (; k <= 20; ++k) {
        assert_int_equal(gs_world_advance(w, 1.0 / 60.0, NULL), GS_OK);
        assert_int_equal(gs_net_update(net, k / 60.0), GS_OK);
    }
    assert_int_equal(gs_net_peer_stats(net, 3, &p3), GS_OK);
    assert_true(p3.datagrams_sent > 0);
    assert_int_equal(p3.send_failures, (uint64_t)failed);
    gs_world_destroy(w);
}

/* gs_wire_decode and gs_collide_shapes return a gs_result; their answer
   is in the out parameters. */
static void test_results(void **state) {
    flaky f;
    gs_net *net;
    gs_world *w;
    gs_wire_view *v = (gs_wire_view *)malloc(sizeof *v);
    gs_reject why = GS_REJECT_COUNT;
    gs_shape_desc ball = gs_shape_desc_default();
    gs_vec3 o = {0.0, 0.0, 0.0}, near_ = {0.15, 0.0, 0.0}, far_ = {1.0, 0.0, 0.0};
    gs_quat q = {0.0, 0.0, 0.0, 1.0};
    gs_contact c;
    int hit = -1;
    (void)state;
    assert_non_null(v);
    memset(&f, 0, sizeof f);
    w = flaky_host(&f, &net);
    assert_int_equal(gs_world_advance(w, 1.0 / 60.0, NULL), GS_OK);
    assert_int_equal(gs_net_update(net, 1.0 / 60.0), GS_OK);
    assert_true(f.last_size > 0);
    assert_int_equal(gs_wire_decode(f.last, f.last_size, v, &why), GS_OK);
    assert_int_equal(v->header.sender, 1);
    f.last[f.last_size / 2] ^= 0x40;
    assert_int_equal(gs_wire_decode(f.last, f.last_size, v, &why), GS_ERR_REJECTED);
    assert_int_equal(why, GS_REJECT_CHECKSUM);
    assert_int_equal(gs_wire_decode(f.last, f.last_size, v, NULL), GS_ERR_REJECTED);
    assert_int_equal(gs_wire_decode(NULL, f.last_size, v, &why), GS_ERR_INVALID_ARG);
    gs_world_destroy(w);
    free(v);
    ball.type = GS_SHAPE_SPHERE;
    ball.radius = 0.1;
    assert_int_equal(gs_collide_shapes(&ball, o, q, &ball, near_, q, &c, &hit), GS_OK);
    assert_int_equal(hit, 1);
    assert_true(fabs(c.depth - 0.05) < 1e-12); /* 0.2 m of radii, 0.15 m apart */
    assert_int_equal(gs_collide_shapes(&ball, o, q, &ball, far_, q, &c, &hit), GS_OK);
    assert_int_equal(hit, 0);
    ball.radius = -1.0;
    assert_int_equal(gs_collide_shapes(&ball, o, q, &ball, far_, q, &c, &hit), GS_ERR_INVALID_ARG);
    assert_int_equal(hit, 0);
}

/* Every stats call: gs_result, the object, *out; NULL is refused. */
static void test_stats_shape(void **state) {
    gs_simnet *sim;
    gs_world *w[2];
    gs_scene sc[2];
    gs_agent_stats as;
    gs_ghost_stats gst;
    gs_sync_stats sy;
    gs_peer_stats ps;
    gs_unknown_stats us;
    gs_simnet_stats ss;
    gs_link_desc lossy = gs_link_desc_default();
    unsigned char junk[40];
    int h, r;
    uint64_t sum = 0;
    (void)state;
    assert_int_equal(gs_simnet_create(NULL, &sim), GS_OK);
    for (h = 0; h < 2; ++h) {
        gs_net *net;
        w[h] = small_scene((uint32_t)h + 1, 0, 0, &sc[h]);
        assert_int_equal(gs_scene_attach_ghosts(&sc[h], NULL), GS_OK);
        assert_int_equal(test_join(sim, w[h], NULL, &net), GS_OK);
    }
    lossy.loss = 0.3;
    lossy.duplicate = 0.2;
    assert_int_equal(gs_simnet_link(sim, 1, 2, &lossy), GS_OK);
    assert_int_equal(gs_simnet_run(sim, 0.5, 1.0 / 60.0), GS_OK);
    memset(junk, 0x5a, sizeof junk); /* bad magic: an unknown sender's */
    assert_int_equal(gs_net_deliver(gs_world_net(w[1]), junk, sizeof junk, 1.0, NULL),
                     GS_ERR_REJECTED);
    assert_int_equal(gs_agent_get_stats(sc[0].cloth, &as), GS_OK);
    assert_true(as.steps > 0);
    assert_int_equal(gs_ghost_get_stats(sc[0].cloth, &gst), GS_OK);
    assert_int_equal(gs_world_sync_stats(w[0], &sy), GS_OK);
    assert_int_equal(gs_net_peer_stats(gs_world_net(w[0]), 2, &ps), GS_OK);
    assert_int_equal(gs_net_unknown_stats(gs_world_net(w[1]), &us), GS_OK);
    for (r = 0; r < GS_REJECT_COUNT; ++r) sum += us.rejected[r];
    assert_int_equal(us.rejected_total, sum);
    assert_int_equal(us.rejected_total, 1);
    assert_int_equal(gs_simnet_get_stats(sim, &ss), GS_OK);
    assert_true(ss.delivered > 0 && ss.dropped > 0 && ss.duplicated > 0);
    assert_int_equal(gs_agent_get_stats(NULL, &as), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_agent_get_stats(sc[0].cloth, NULL), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_ghost_get_stats(sc[0].cloth, NULL), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_unknown_stats(NULL, &us), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_unknown_stats(gs_world_net(w[0]), NULL), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_simnet_get_stats(NULL, &ss), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_simnet_get_stats(sim, NULL), GS_ERR_INVALID_ARG);
    for (h = 0; h < 2; ++h) gs_world_destroy(w[h]);
    gs_simnet_destroy(sim);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_weight_rule_names_object),
        cmocka_unit_test(test_weight_in_single_ghost),
        cmocka_unit_test(test_default_weight_rule),
        cmocka_unit_test(test_zeroed_scene_desc),
        cmocka_unit_test(test_desc_defaults),
        cmocka_unit_test(test_send_failures),
        cmocka_unit_test(test_results),
        cmocka_unit_test(test_stats_shape),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
