/* world_helpers.h - the tests' short ways to make a vector, a quaternion,
   a world and a custom agent, to read an agent's counters, and a custom
   agent of two values that counts what is done to it.
   Include after cmocka.h and ghostsim.h (the makers assert that the
   create calls succeed; tests of the failures call them directly). */
#ifndef GS_TEST_WORLD_HELPERS_H
#define GS_TEST_WORLD_HELPERS_H

#include <string.h>

#include "helpers.h"

static GS_TEST_UNUSED gs_vec3 v3(double x, double y, double z) {
    gs_vec3 v;
    v.x = x; v.y = y; v.z = z;
    return v;
}

static GS_TEST_UNUSED gs_quat quat(double x, double y, double z, double w) {
    gs_quat q;
    q.x = x; q.y = y; q.z = z; q.w = w;
    return q;
}

/* An agent's counters by value (gs_agent_get_stats fills an out-pointer). */
static GS_TEST_UNUSED gs_agent_stats agent_stats(const gs_agent *a) {
    gs_agent_stats st;
    memset(&st, 0, sizeof st);
    gs_agent_get_stats(a, &st);
    return st;
}

/* A world of the default desc but for its host id. */
static GS_TEST_UNUSED gs_world *world_new(uint32_t host) {
    gs_world_desc wd = gs_world_desc_default();
    gs_world *w = NULL;
    wd.host_id = host;
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    return w;
}

/* A custom agent's desc: n values (time excluded) stepped every dt s by
   step, read and written by get and set on user. */
static GS_TEST_UNUSED gs_custom_desc custom_desc(double dt, size_t n,
                                                      gs_result (*step)(void *, double, double),
                                                      void (*get)(const void *, double *),
                                                      gs_result (*set)(void *, const double *),
                                                      void *user) {
    gs_custom_desc d = gs_custom_desc_default();
    d.dt = dt;
    d.state_size = n;
    d.step = step; d.get_state = get; d.set_state = set;
    d.user = user;
    return d;
}

/* The custom agent of custom_desc's arguments, created in w. */
static GS_TEST_UNUSED gs_agent *custom_new(gs_world *w, double dt, size_t n,
                                                gs_result (*step)(void *, double, double),
                                                void (*get)(const void *, double *),
                                                gs_result (*set)(void *, const double *),
                                                void *user) {
    gs_custom_desc d = custom_desc(dt, n, step, get, set, user);
    gs_agent *a = NULL;
    assert_int_equal(gs_custom_create(w, &d, &a), GS_OK);
    return a;
}

/* ---- a custom agent of two values: each step adds dt to v[0] (so a
   step shows in the state) and counts itself; each set counts too ---- */

typedef struct two_values {
    double v[2];
    long steps, sets;
} two_values;

static GS_TEST_UNUSED gs_result two_values_step(void *user, double t, double dt) {
    two_values *p = (two_values *)user;
    (void)t;
    p->v[0] += dt;
    p->steps++;
    return GS_OK;
}
static GS_TEST_UNUSED void two_values_get(const void *user, double *out) {
    const two_values *p = (const two_values *)user;
    out[0] = p->v[0];
    out[1] = p->v[1];
}
static GS_TEST_UNUSED gs_result two_values_set(void *user, const double *in) {
    two_values *p = (two_values *)user;
    p->sets++;
    p->v[0] = in[0];
    p->v[1] = in[1];
    return GS_OK;
}

/* Its desc on p, stepped every 10 ms. */
static GS_TEST_UNUSED gs_custom_desc two_values_desc(two_values *p) {
    return custom_desc(0.01, 2, two_values_step, two_values_get, two_values_set, p);
}

#endif
