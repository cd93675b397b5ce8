/* fuzz_world.h - the small world that tests/fuzz_wire.c feeds datagrams
   into and tests/fuzz_seeds.c sends its seed datagrams from.

   Both sides build the same objects under the same ids, so that the seeds
   are datagrams this world accepts: host FUZZ_HOST receives from the
   peers FUZZ_PEER_A and FUZZ_PEER_B in session FUZZ_SESSION. One object of
   each kind of ghost, so that every path into the blend is reached:
       id  agent                 encoding  weight  catchup   chunks
       10  cloth 7x7             f64       exp     none      3
       11  chain of 48 particles f32       cs      velocity  2
       12  rigid sphere          f64       exp     velocity  1
       13  probe owned by host 2 f32       owner   none      1
       14  custom point (6)      f64       wild    velocity  1  raw time,
                                                             no deadband
       15  custom, no variables  f64       exp     none      1  (0 values)
   "wild" is a rule of the harness's own that returns negative, huge,
   infinite and NaN weights (which the ghost must count and ignore). The
   small ones (12..15) travel packed in one datagram. With a nonzero
   time_window the net refuses snapshots that far from the local time.
   Only the public API is used. */
#ifndef FUZZ_WORLD_H
#define FUZZ_WORLD_H

#include <math.h>
#include <string.h>

#include "ghostsim.h"

#define FUZZ_SESSION 7u
#define FUZZ_HOST 1u
#define FUZZ_PEER_A 2u
#define FUZZ_PEER_B 3u
#define FUZZ_OBJECTS 6

/* An agent's counters by value (gs_agent_get_stats fills an out-pointer);
   inline: not every harness reads them. */
static inline gs_agent_stats agent_stats(const gs_agent *a) {
    gs_agent_stats st;
    memset(&st, 0, sizeof st);
    gs_agent_get_stats(a, &st);
    return st;
}

typedef struct fuzz_world {
    gs_world *w;
    gs_net *net;
    gs_agent *agent[FUZZ_OBJECTS];
    double point[6]; /* object 14: position, velocity */
} fuzz_world;

static gs_result fuzz_point_step(void *user, double t, double dt) {
    double *s = (double *)user;
    (void)t;
    s[4] -= 9.81 * dt;
    s[0] += s[3] * dt;
    s[1] += s[4] * dt;
    s[2] += s[5] * dt;
    return GS_OK;
}
static void fuzz_point_get(const void *user, double *out) {
    memcpy(out, user, 6 * sizeof(double));
}
static gs_result fuzz_point_set(void *user, const double *in) {
    memcpy(user, in, 6 * sizeof(double));
    return GS_OK;
}
static gs_result fuzz_empty_step(void *user, double t, double dt) {
    (void)user; (void)t; (void)dt;
    return GS_OK;
}
static void fuzz_empty_get(const void *user, double *out) { (void)user; (void)out; }
static gs_result fuzz_empty_set(void *user, const double *in) {
    (void)user; (void)in;
    return GS_OK;
}

/* Any number a careless rule could return: x_comp scaled up, so negative
   for a snapshot behind, infinite or NaN for one far away. */
static double fuzz_weight_wild(const gs_weight_in *in, void *user) {
    (void)user;
    if (in->local) return 1.0;
    if (in->x_comp > 1e6) return in->x_comp * 1e300 - in->x_comp * 1e300; /* NaN */
    return in->x_comp * 1e300;
}

static gs_result fuzz_cloth(gs_world *w, gs_agent **out) {
    gs_cloth_desc cd = gs_cloth_desc_default();
    cd.nx = cd.ny = 7;
    cd.pin_corners = GS_CORNER_ALL;
    cd.solver.dt = 0.002;
    cd.solver.stability = GS_STABILITY_UNCHECKED; /* no substeps: cheap */
    return gs_cloth_create(w, &cd, out);
}

/* A hanging chain of 48 particles, away from the cloth. */
static gs_result fuzz_chain(gs_world *w, gs_agent **out) {
    gs_vec3 x[48];
    gs_spring sp[47];
    int pin = 0, i;
    gs_mesh_desc md = gs_mesh_desc_default();
    memset(sp, 0, sizeof sp);
    for (i = 0; i < 48; ++i) {
        x[i].x = 5.0 + 0.02 * i;
        x[i].y = x[i].z = 0.0;
        if (i) {
            sp[i - 1].a = i - 1;
            sp[i - 1].b = i;
            sp[i - 1].stiffness = 200.0;
            sp[i - 1].damping = 0.1;
        }
    }
    md.particle_count = 48;
    md.positions = x;
    md.spring_count = 47;
    md.springs = sp;
    md.pin_count = 1;
    md.pins = &pin;
    md.solver.dt = 0.002;
    md.solver.stability = GS_STABILITY_UNCHECKED;
    return gs_mesh_create(w, &md, out);
}

static gs_result fuzz_agents(fuzz_world *f) {
    gs_rigid_desc rd = gs_rigid_desc_default();
    gs_probe_desc pd = gs_probe_desc_default();
    gs_custom_desc cu;
    gs_result r;
    if ((r = fuzz_cloth(f->w, &f->agent[0])) != GS_OK) return r;
    if ((r = fuzz_chain(f->w, &f->agent[1])) != GS_OK) return r;
    rd.shape.type = GS_SHAPE_SPHERE;
    rd.shape.radius = 0.1;
    rd.position.y = 1.0;
    rd.solver.dt = 0.002;
    if ((r = gs_rigid_create(f->w, &rd, &f->agent[2])) != GS_OK) return r;
    pd.shape.type = GS_SHAPE_BOX;
    pd.shape.half_extents.x = pd.shape.half_extents.y = pd.shape.half_extents.z = 0.05;
    pd.position.y = 0.5;
    pd.owner = FUZZ_PEER_A;
    if ((r = gs_probe_create(f->w, &pd, &f->agent[3])) != GS_OK) return r;
    memset(&cu, 0, sizeof cu);
    cu.dt = 0.004;
    cu.state_size = 6;
    cu.step = fuzz_point_step;
    cu.get_state = fuzz_point_get;
    cu.set_state = fuzz_point_set;
    cu.user = f->point;
    if ((r = gs_custom_create(f->w, &cu, &f->agent[4])) != GS_OK) return r;
    cu.state_size = 0;
    cu.step = fuzz_empty_step;
    cu.get_state = fuzz_empty_get;
    cu.set_state = fuzz_empty_set;
    cu.user = NULL;
    return gs_custom_create(f->w, &cu, &f->agent[5]);
}

static gs_result fuzz_ghosts(fuzz_world *f) {
    static const gs_weight_fn weight[FUZZ_OBJECTS] = {
        gs_weight_exp, gs_weight_cs, gs_weight_exp, gs_weight_owner, fuzz_weight_wild,
        gs_weight_exp};
    static const gs_encoding enc[FUZZ_OBJECTS] = {
        GS_ENCODING_F64, GS_ENCODING_F32, GS_ENCODING_F64, GS_ENCODING_F32,
        GS_ENCODING_F64, GS_ENCODING_F64};
    static const gs_catchup catchup[FUZZ_OBJECTS] = {
        GS_CATCHUP_NONE, GS_CATCHUP_VELOCITY, GS_CATCHUP_VELOCITY, GS_CATCHUP_NONE,
        GS_CATCHUP_VELOCITY, GS_CATCHUP_NONE};
    int i;
    for (i = 0; i < FUZZ_OBJECTS; ++i) {
        gs_ghost_desc gd = gs_ghost_desc_default();
        gs_result r;
        gd.object_id = 10u + (uint32_t)i;
        gd.weight = weight[i];
        gd.encoding = enc[i];
        gd.catchup = catchup[i];
        gd.queue_size = 4; /* small: a few datagrams overflow it */
        if (i == 3) gd.owner = FUZZ_PEER_A;
        if (i == 4) { gd.raw_time = 1; gd.time_deadband = -1.0; }
        if ((r = gs_ghost_attach(f->agent[i], &gd)) != GS_OK) return r;
    }
    return GS_OK;
}

/* Builds the world of host `host` with the two other hosts of the session
   as peers; datagrams it sends go to send(user, ...). time_window: s, 0 =
   none. key: GS_WIRE_KEY_BYTES bytes (a sealing net, GHOSTSIM_SODIUM), or
   NULL. */
static gs_result fuzz_world_create_keyed(fuzz_world *f, uint32_t host, double time_window,
                                         const unsigned char *key, gs_send_fn send,
                                         void *user) {
    static const uint32_t hosts[3] = {FUZZ_HOST, FUZZ_PEER_A, FUZZ_PEER_B};
    gs_world_desc wd = gs_world_desc_default();
    gs_net_desc nd;
    gs_result r;
    int i;
    memset(f, 0, sizeof *f);
    wd.host_id = host;
    if ((r = gs_world_create(&wd, &f->w)) != GS_OK) return r;
    if ((r = fuzz_agents(f)) != GS_OK || (r = fuzz_ghosts(f)) != GS_OK) return r;
    memset(&nd, 0, sizeof nd);
    nd.session = FUZZ_SESSION;
    nd.transport.send = send;
    nd.transport.user = user;
    nd.time_window = time_window;
    nd.key = key;
    if ((r = gs_net_create(f->w, &nd, &f->net)) != GS_OK) return r;
    for (i = 0; i < 3; ++i)
        if (hosts[i] != host && (r = gs_net_add_peer(f->net, hosts[i], NULL)) != GS_OK) return r;
    return GS_OK;
}

/* The world with a net in clear. */
static gs_result fuzz_world_create(fuzz_world *f, uint32_t host, double time_window,
                                   gs_send_fn send, void *user) {
    return fuzz_world_create_keyed(f, host, time_window, NULL, send, user);
}

/* The world takes its net with it. */
static void fuzz_world_destroy(fuzz_world *f) {
    gs_world_destroy(f->w);
    memset(f, 0, sizeof *f);
}

#endif
