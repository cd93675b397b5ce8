/* test_sched.c - the scheduler's span (>>sched): the slowest and fastest
   simulation times an agent is told on activation, and the dispatch order
   that follows from them.

   The span is kept in heaps updated as times change, where it used to be a
   scan of every agent at every dispatch. The rule is unchanged, so these
   tests hold the heaps to the scan: on a random mix of dt's, with agents
   that fail and agents whose time is set back from another agent's step
   (what a ghost's blend does), every activation must see the span a scan of
   the live agents gives, and the order of steps must be the order the scan
   gave (pinned as a hash recorded before the change). The set-back goes
   through the private path a blend takes (gs__agent_put_state): the public
   gs_agent_set_state is refused from a step (GS_ERR_BUSY), so this file
   compiles the implementation itself (GHOSTSIM_STATIC), as test_sap.c. */
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

#define NAGENTS 40

typedef struct mix mix;

typedef struct member {
    mix *m;
    gs_agent *self;
    int id;
    long calls;
    long fail_at;     /* this call fails; 0 = never */
    int pull;         /* on every 7th call, set this agent back a step; -1 */
    double x;
} member;

struct mix {
    gs_world *w;
    member a[NAGENTS];
    int n;
    int failed[NAGENTS]; /* failed during the current advance */
    uint64_t order;      /* FNV-1a of the ids in step order */
    long steps, checks, mismatches;
};

static uint64_t rng_next(uint64_t *s) {
    *s ^= *s << 13;
    *s ^= *s >> 7;
    *s ^= *s << 17;
    return *s;
}

static gs_result member_step(void *user, double t, double dt) {
    member *me = (member *)user;
    mix *m = me->m;
    unsigned char id = (unsigned char)me->id;
    (void)t;
    me->calls++;
    if (me->fail_at && me->calls == me->fail_at) {
        m->failed[me->id] = 1;
        return GS_ERR_UNSTABLE;
    }
    m->order = (m->order ^ id) * 1099511628211ull;
    m->steps++;
    me->x += dt;
    if (me->pull >= 0 && me->calls % 7 == 0) { /* a blend, as it were */
        gs_agent *o = m->a[me->pull].self;
        double s[2];
        assert_int_equal(gs_agent_get_state(o, s, 2), GS_OK);
        s[0] -= 1.5 * gs_agent_dt(o);
        if (s[0] < 0.0) s[0] = 0.0; /* no time is negative */
        assert_int_equal(gs_agent_set_state(o, s, 2), GS_ERR_BUSY);
        assert_int_equal(gs__agent_put_state(o, s), GS_OK);
    }
    return GS_OK;
}

static void member_get(const void *user, double *out) {
    out[0] = ((const member *)user)->x;
}

static gs_result member_set(void *user, const double *in) {
    ((member *)user)->x = in[0];
    return GS_OK;
}

/* The old rule: a scan of every agent that has not failed in this advance. */
static void scan_span(const mix *m, double *lo, double *hi) {
    int i;
    *lo = HUGE_VAL;
    *hi = -HUGE_VAL;
    for (i = 0; i < m->n; ++i) {
        double t;
        if (m->failed[i]) continue;
        t = gs_agent_time(m->a[i].self);
        if (t < *lo) *lo = t;
        if (t > *hi) *hi = t;
    }
    if (*lo > *hi) *lo = *hi = gs_world_time(m->w);
}

/* The default rule, after checking the span it is given against the scan
   (exactly: both come from the same times). */
static int checking_rule(const gs_behaviour_in *in, void *user) {
    mix *m = (mix *)user;
    double lo, hi;
    scan_span(m, &lo, &hi);
    m->checks++;
    if (in->t_min != lo || in->t_max != hi) m->mismatches++;
    return gs_behaviour_default(in, NULL);
}

static void mix_make(mix *m, uint64_t seed, int with_trouble) {
    static const double dts[5] = {1e-3, 2e-3, 5e-3, 7e-3, 1.3e-2};
    gs_world_desc wd = gs_world_desc_default();
    int i;
    memset(m, 0, sizeof *m);
    m->n = NAGENTS;
    m->order = 14695981039346656037ull;
    wd.tolerance = 4e-3;
    wd.aging_limit = 16;
    wd.queue_count = 6;
    assert_int_equal(gs_world_create(&wd, &m->w), GS_OK);
    for (i = 0; i < m->n; ++i) {
        member *me = &m->a[i];
        gs_custom_desc cd;
        memset(&cd, 0, sizeof cd);
        me->m = m;
        me->id = i;
        me->pull = -1;
        cd.dt = dts[rng_next(&seed) % 5] * (1.0 + 0.1 * (double)(rng_next(&seed) % 7));
        cd.state_size = 1;
        cd.step = member_step;
        cd.get_state = member_get;
        cd.set_state = member_set;
        cd.user = me;
        assert_int_equal(gs_custom_create(m->w, &cd, &me->self), GS_OK);
        gs_agent_set_behaviour(me->self, checking_rule, m);
        gs_agent_set_priority(me->self, (int)(rng_next(&seed) % 6));
        if (with_trouble && i % 9 == 4) me->fail_at = 5 + (long)(rng_next(&seed) % 40);
        if (with_trouble && i % 5 == 1) me->pull = (int)(rng_next(&seed) % NAGENTS);
    }
}

static void mix_run(mix *m, int frames) {
    int f;
    for (f = 0; f < frames; ++f) {
        memset(m->failed, 0, sizeof m->failed);
        gs_world_advance(m->w, 1.0 / 60.0, NULL);
    }
}

/* Random dt's, priorities and seeds: every activation sees the scan's span. */
static void test_sched_span_matches_scan(void **state) {
    uint64_t seed;
    (void)state;
    for (seed = 1; seed <= 6; ++seed) {
        mix m;
        mix_make(&m, seed * 0x9e3779b97f4a7c15ull, (int)(seed & 1));
        mix_run(&m, 20);
        assert_true(m.checks > 1000);
        if (m.mismatches)
            print_error("seed %lu: %ld of %ld activations told another span\n",
                        (unsigned long)seed, m.mismatches, m.checks);
        assert_int_equal(m.mismatches, 0);
        gs_world_destroy(m.w);
    }
}

/* The order of steps, failures and set-backs included, is the order the
   scan gave: hashes recorded with the scan, before the heaps. Case 1's was
   recorded again when set-backs stopped at time 0 (no agent time is
   negative); case 0's did not change. */
static void test_sched_order_pinned(void **state) {
    static const uint64_t want[2] = {0x1e794df3675f69d4ull, 0xf538ec9eb135c41full};
    int k;
    (void)state;
    for (k = 0; k < 2; ++k) {
        mix m;
        mix_make(&m, 12345u + (uint64_t)k, k);
        mix_run(&m, 30);
        if (m.order != want[k])
            print_error("case %d: order hash 0x%016llx, steps %ld\n", k,
                        (unsigned long long)m.order, m.steps);
        assert_true(m.order == want[k]);
        gs_world_destroy(m.w);
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sched_span_matches_scan),
        cmocka_unit_test(test_sched_order_pinned),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
