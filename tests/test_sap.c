/* test_sap.c - the broad phase (>>contact) against brute force.

   The broad phase answers a query with the bodies near it (from a uniform
   grid, or a list sorted on x), wide ones (walls, fast bodies) listed
   apart. Whatever it leaves out must be a
   body that cannot touch, and what it keeps must come in the order of the
   sorted list, so that contact forces add up in the same order as a loop
   over every body: on random scenes of spheres, boxes and wide walls at
   random speeds and times, the forces of each body are compared bit for bit
   with that loop, and each query with the pairs a brute-force distance test
   finds. This file compiles the implementation itself (GHOSTSIM_STATIC) to
   reach the private functions. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define GHOSTSIM_STATIC
#define GHOSTSIM_IMPLEMENTATION
#include "ghostsim.h"

static uint64_t rng_next(uint64_t *s) {
    *s ^= *s << 13;
    *s ^= *s >> 7;
    *s ^= *s << 17;
    return *s;
}

static double uniform(uint64_t *s, double lo, double hi) {
    return lo + (hi - lo) * (double)(rng_next(s) >> 11) / 9007199254740992.0;
}

static gs_vec3 rand_vec(uint64_t *s, double lo, double hi) {
    return gs__v3(uniform(s, lo, hi), uniform(s, lo, hi), uniform(s, lo, hi));
}

/* A world of n bodies in a 2 m box: spheres and boxes of mixed sizes, some
   fast, and a few wide walls (probes), advanced a little so that their
   times differ. */
static gs_world *random_scene(uint64_t seed, int n) {
    gs_world *w = NULL;
    gs_world_desc wd = gs_world_desc_default();
    int i;
    wd.tolerance = 0.02;
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    gs_world_set_ground(w, 1, -1.0, gs_material_default());
    for (i = 0; i < n; ++i) {
        gs_agent *a = NULL;
        int kind = (int)(rng_next(&seed) % 10);
        if (kind == 0) { /* a wall */
            gs_probe_desc pd = gs_probe_desc_default();
            pd.shape.type = GS_SHAPE_BOX;
            pd.shape.half_extents = gs__v3(uniform(&seed, 0.02, 0.1), uniform(&seed, 0.3, 1.0),
                                           uniform(&seed, 0.3, 1.0));
            pd.position = rand_vec(&seed, -1.0, 1.0);
            pd.dt = 1e-3;
            assert_int_equal(gs_probe_create(w, &pd, &a), GS_OK);
        } else {
            gs_rigid_desc rd = gs_rigid_desc_default();
            double speed = kind == 1 ? 20.0 : kind == 2 ? 3.0 : 0.3;
            if (kind % 3 == 0) {
                rd.shape.type = GS_SHAPE_BOX;
                rd.shape.half_extents = rand_vec(&seed, 0.02, 0.12);
            } else {
                rd.shape.type = GS_SHAPE_SPHERE;
                rd.shape.radius = uniform(&seed, 0.02, 0.15);
            }
            rd.position = rand_vec(&seed, -1.0, 1.0);
            rd.velocity = rand_vec(&seed, -speed, speed);
            rd.solver.dt = rng_next(&seed) % 2 ? 1e-3 : 2.5e-3;
            assert_int_equal(gs_rigid_create(w, &rd, &a), GS_OK);
        }
    }
    return w;
}

typedef struct sums {
    gs_vec3 force, torque;
    double k_sum, c_sum;
} sums;

static sums sums_of(const gs__rigid *r) {
    sums s;
    s.force = r->force;
    s.torque = r->torque;
    s.k_sum = r->k_sum;
    s.c_sum = r->c_sum;
    return s;
}

/* The contact forces on r at time t from every body, in list order, over
   a substep of SUBSTEP s: longer than any lag here, so that every pair
   has a share of it to compute (a pair is computed for the part of the
   substep after the other body's time). */
#define SUBSTEP 1.0
static sums brute_contacts(gs__rigid *r, double t) {
    gs_world *w = r->base.world;
    int i;
    r->force = r->torque = gs__v3(0.0, 0.0, 0.0);
    r->k_sum = r->c_sum = 0.0;
    if (w->ground) gs__rigid_ground(r);
    for (i = 0; i < w->nbodies; ++i)
        if (w->bodies[i] != r) gs__rigid_vs_rigid(r, w->bodies[i], i, t, SUBSTEP);
    gs__push_end(w, 0); /* a look, not a step: the pushes are dropped */
    return sums_of(r);
}

/* Does o come within reach of r at a lag of o's time (as gs__rigid_vs_rigid
   looks at it)? */
static int touches(const gs__rigid *r, const gs__rigid *o, double lag) {
    double la = fmax(-o->base.dt, fmin(o->base.dt, lag));
    gs_vec3 p = o->probe ? o->x
                         : gs__madd(gs__madd(o->x, o->v, lag), o->a_own, la * (lag - 0.5 * la));
    double reach = r->shape.bound + o->shape.bound;
    gs_vec3 d = gs__sub(r->x, p);
    return gs__dot(d, d) < reach * reach;
}

static int in_query(const gs_world *w, int n, const gs__rigid *o) {
    int i;
    for (i = 0; i < n; ++i)
        if (w->cand[i] == o) return 1;
    return 0;
}

/* Every body of the world, at times around its own: the forces equal the
   brute-force loop's bit for bit; every touching pair is in the query and
   passes the sweep test; the query is in list order. Returns the number of
   touching pairs seen. */
static long check_world(gs_world *w, uint64_t *seed) {
    long touching = 0;
    double bound;
    int i, k, j, n;
    for (i = 0; i < w->nbodies; ++i) {
        gs__rigid *r = w->bodies[i];
        for (k = 0; k < 3; ++k) {
            double t = gs__agent_time(&r->base) + uniform(seed, -0.15, 0.15);
            sums got, want;
            gs__rigid_contacts(r, t, SUBSTEP);
            got = sums_of(r);
            gs__push_end(w, 0);
            want = brute_contacts(r, t);
            assert_memory_equal(&got, &want, sizeof got);
            bound = gs__lag_bound(w, t, 0.1);
            n = gs__sap_query_near(w, r, bound);
            for (j = 1; j < n; ++j) assert_true(w->cand[j - 1]->sap < w->cand[j]->sap);
            for (j = 0; j < n; ++j) assert_int_equal(w->cand_sap[j], w->cand[j]->sap);
            for (j = 0; j < w->nbodies; ++j) {
                gs__rigid *o = w->bodies[j];
                double lag = fmax(-0.1, fmin(0.1, t - gs__agent_time(&o->base)));
                if (o == r || !touches(r, o, lag)) continue;
                touching++;
                assert_true(fabs(lag) <= bound);
                assert_true(in_query(w, n, o));
                assert_true(gs__sweeps_meet(r, o, bound));
            }
        }
    }
    return touching;
}

static void test_sap_against_brute_force(void **state) {
    static const int sizes[4] = {3, 12, 60, 240};
    uint64_t seed = 0x243f6a8885a308d3ull;
    long touching = 0;
    int s, f;
    (void)state;
    for (s = 0; s < 4; ++s) {
        gs_world *w = random_scene(seed + (uint64_t)s, sizes[s]);
        touching += check_world(w, &seed); /* before any advance */
        for (f = 0; f < 4; ++f) {
            assert_int_equal(gs_world_advance(w, 0.004, NULL), GS_OK);
            touching += check_world(w, &seed);
            /* as inside an advance: the lag bound from the scheduler's
               heaps, still those of the last advance (nothing moved since) */
            w->busy = 1;
            touching += check_world(w, &seed);
            w->busy = 0;
        }
        gs_world_destroy(w);
    }
    assert_true(touching > 100); /* the scenes do have contacts */
}

/* A mesh's query (an x range, a lag): every body whose reach meets the
   range is in it, in list order. */
static void test_sap_range_queries(void **state) {
    uint64_t seed = 0x13198a2e03707344ull;
    gs_world *w = random_scene(seed, 150);
    int k, j, n;
    (void)state;
    assert_int_equal(gs_world_advance(w, 0.004, NULL), GS_OK);
    for (k = 0; k < 400; ++k) {
        double lo = uniform(&seed, -1.5, 1.5), hi = lo + uniform(&seed, 0.0, 0.5);
        double lag = k % 2 ? 0.1 : uniform(&seed, 0.0, 0.02);
        n = gs__sap_query(w, lo, hi, lag);
        for (j = 1; j < n; ++j) assert_true(w->cand[j - 1]->sap < w->cand[j]->sap);
        for (j = 0; j < w->nbodies; ++j) {
            const gs__rigid *o = w->bodies[j];
            double reach = o->shape.bound + (o->probe ? 0.0 : gs__len(o->v)) * lag;
            if (o->x.x - reach <= hi && o->x.x + reach >= lo) assert_true(in_query(w, n, o));
        }
    }
    gs_world_destroy(w);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sap_against_brute_force),
        cmocka_unit_test(test_sap_range_queries),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
