/* test_world.c - the world and its scheduler (>>world, >>sched, >>agent).

   Most tests use custom agents: their dt is free, their step can cost any
   amount of work, and their step callback sees the order in which the
   scheduler runs them. The scheduler rules under test are the header's:
   highest queue first, FIFO within a queue, aging after aging_limit
   dispatches, an agent that leads the slowest one by more than the
   tolerance is held, and every advance ends with each agent within half its
   dt of the target. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ghostsim.h"
#include "alloc_helpers.h"
#include "world_helpers.h"

/* ---- a custom agent that records what the scheduler does with it ---- */

#define TRACE_MAX 8192

/* The order of step calls across every agent of a world. */
typedef struct trace {
    int id[TRACE_MAX];
    int n;
} trace;

/* Simulation times as the agents' own step callbacks last left them. */
typedef struct spread_probe {
    double t[8];
    int n;            /* agents taking part */
    double max_spread;
    long checks;
} spread_probe;

typedef struct rec {
    gs_agent *self;
    int id;
    long calls;         /* step callback invocations */
    long fail_after;    /* steps that succeed before every step fails; -1 */
    long cost;          /* busy-loop iterations per step */
    int set_priority_at; /* on this call, set own priority; 0 = never */
    int new_priority;
    double last_t, last_dt; /* what the last call was given */
    double x[2];        /* a unit oscillator [position, velocity] */
    long set_calls;     /* set_state callback invocations */
    trace *tr;
    spread_probe *sp;
} rec;

static volatile double sink;

static gs_result rec_step(void *user, double t, double dt) {
    rec *r = (rec *)user;
    long i;
    double acc = 0.0;
    r->calls++;
    r->last_t = t;
    r->last_dt = dt;
    if (r->fail_after >= 0 && r->calls > r->fail_after) return GS_ERR_UNSTABLE;
    for (i = 0; i < r->cost; ++i) acc += (double)i * 1e-9;
    sink = acc;
    if (r->tr && r->tr->n < TRACE_MAX) r->tr->id[r->tr->n++] = r->id;
    if (r->set_priority_at && r->calls == r->set_priority_at)
        gs_agent_set_priority(r->self, r->new_priority);
    r->x[1] -= r->x[0] * dt; /* symplectic Euler, omega = 1 */
    r->x[0] += r->x[1] * dt;
    if (r->sp) { /* the times of every agent just after this step */
        double lo = HUGE_VAL, hi = -HUGE_VAL;
        int k;
        r->sp->t[r->id] = t + dt;
        for (k = 0; k < r->sp->n; ++k) {
            if (r->sp->t[k] < lo) lo = r->sp->t[k];
            if (r->sp->t[k] > hi) hi = r->sp->t[k];
        }
        if (hi - lo > r->sp->max_spread) r->sp->max_spread = hi - lo;
        r->sp->checks++;
    }
    return GS_OK;
}

static void rec_get(const void *user, double *out) {
    const rec *r = (const rec *)user;
    out[0] = r->x[0];
    out[1] = r->x[1];
}

static gs_result rec_set(void *user, const double *in) {
    rec *r = (rec *)user;
    r->set_calls++;
    r->x[0] = in[0];
    r->x[1] = in[1];
    return GS_OK;
}

static void rec_init(rec *r, int id) {
    memset(r, 0, sizeof *r);
    r->id = id;
    r->fail_after = -1;
    r->x[0] = 1.0;
}

/* A custom agent with a 2-double state backed by r. */
static gs_agent *add_rec(gs_world *w, rec *r, double dt) {
    gs_custom_desc cd = custom_desc(dt, 2, rec_step, rec_get, rec_set, r);
    assert_int_equal(gs_custom_create(w, &cd, &r->self), GS_OK);
    assert_non_null(r->self);
    return r->self;
}

/* Behaviour rules. */
static int rule_fixed(const gs_behaviour_in *in, void *user) {
    (void)in;
    return *(const int *)user;
}

static int rule_keep(const gs_behaviour_in *in, void *user) {
    (void)user;
    return in->priority;
}

static gs_world *world_with(double tolerance, int aging_limit, int queues) {
    gs_world_desc wd = gs_world_desc_default();
    gs_world *w = NULL;
    wd.tolerance = tolerance;
    wd.aging_limit = aging_limit;
    wd.queue_count = queues;
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    assert_non_null(w);
    return w;
}

/* A huge tolerance: nothing is ever held, only priorities and aging act. */
#define NO_HOLD 1e9
#define NO_AGING (1 << 20)

/* ---- priorities ---- */

/* Two agents pinned high and two pinned low, created interleaved: every high
   step runs before any low one, and within each queue they alternate. */
static void test_world_priorities(void **state) {
    static const int high = 6, low = 1;
    gs_world *w = world_with(NO_HOLD, NO_AGING, 8);
    trace tr;
    rec r[4];
    int i, ids_high[2] = {1, 3};
    (void)state;
    memset(&tr, 0, sizeof tr);
    for (i = 0; i < 4; ++i) { /* ids 0, 2 low; 1, 3 high */
        const int *p = (i % 2) ? &high : &low;
        rec_init(&r[i], i);
        r[i].tr = &tr;
        add_rec(w, &r[i], 0.01);
        gs_agent_set_behaviour(r[i].self, rule_fixed, (void *)p);
        gs_agent_set_priority(r[i].self, *p);
        assert_int_equal(gs_agent_priority(r[i].self), *p);
    }
    assert_int_equal(gs_world_advance(w, 0.1, NULL), GS_OK);
    assert_int_equal(tr.n, 40); /* 10 steps each */
    for (i = 0; i < 40; ++i) {
        int is_high = tr.id[i] % 2 == 1;
        assert_int_equal(is_high, i < 20); /* every high step first */
        if (i % 20 >= 1) assert_int_not_equal(tr.id[i], tr.id[i - 1]);
        if (i % 20 >= 2) assert_int_equal(tr.id[i], tr.id[i - 2]); /* FIFO */
    }
    assert_true(tr.id[0] == ids_high[0] || tr.id[0] == ids_high[1]);
    for (i = 0; i < 4; ++i) {
        assert_int_equal(r[i].calls, 10);
        assert_int_equal(gs_agent_priority(r[i].self), (i % 2) ? high : low);
    }
    gs_world_destroy(w);
}

/* Three agents in one queue take turns: A B C A B C ... */
static void test_world_fifo(void **state) {
    static const int prio = 3;
    gs_world *w = world_with(NO_HOLD, NO_AGING, 8);
    trace tr;
    rec r[3];
    int i;
    (void)state;
    memset(&tr, 0, sizeof tr);
    for (i = 0; i < 3; ++i) {
        rec_init(&r[i], i);
        r[i].tr = &tr;
        add_rec(w, &r[i], 0.01);
        gs_agent_set_behaviour(r[i].self, rule_fixed, (void *)&prio);
        gs_agent_set_priority(r[i].self, prio);
    }
    assert_int_equal(gs_world_advance(w, 0.2, NULL), GS_OK);
    assert_int_equal(tr.n, 60);
    assert_int_not_equal(tr.id[0], tr.id[1]);
    assert_int_not_equal(tr.id[1], tr.id[2]);
    assert_int_not_equal(tr.id[0], tr.id[2]);
    for (i = 3; i < tr.n; ++i) assert_int_equal(tr.id[i], tr.id[i - 3]);
    gs_world_destroy(w);
}

/* One agent pinned at priority 0 under four pinned at the top. Aging must
   run it long before the top agents are done.

   The bound: an agent whose wait at the head of its queue exceeds
   aging_limit is aged and runs ahead of every non-aged agent. The only
   agents that can still go first are other aged queue heads that have waited
   longer; each of those is one of the other agent_count - 1 agents and, once
   run, is queued again behind it. So it runs after at most aging_limit + 1 +
   (agent_count - 1) = aging_limit + agent_count dispatches of waiting: that
   is the bound on stats.max_wait, and on the gap between two of its steps. */
static void test_world_no_starvation(void **state) {
    enum { HIGH = 4, N = HIGH + 1, AGING = 8 };
    static const int top = 7, bottom = 0;
    gs_world *w = world_with(NO_HOLD, AGING, 8);
    trace tr;
    rec r[N];
    int i, prev = -1, last_high = -1, low_before_last_high = 0;
    (void)state;
    memset(&tr, 0, sizeof tr);
    for (i = 0; i < N; ++i) { /* id 0 is the low one */
        const int *p = i == 0 ? &bottom : &top;
        rec_init(&r[i], i);
        r[i].tr = &tr;
        add_rec(w, &r[i], 0.001);
        gs_agent_set_behaviour(r[i].self, rule_fixed, (void *)p);
        gs_agent_set_priority(r[i].self, *p);
    }
    assert_int_equal(gs_world_advance(w, 0.1, NULL), GS_OK);
    assert_int_equal(tr.n, N * 100);
    for (i = 0; i < tr.n; ++i)
        if (tr.id[i] != 0) last_high = i;
    for (i = 0; i < tr.n; ++i) {
        if (tr.id[i] != 0) continue;
        if (i < last_high) low_before_last_high++;
        assert_true(i - prev - 1 <= AGING + N); /* dispatches it waited */
        prev = i;
    }
    /* It ran about once per AGING + 1 dispatches while the others ran. */
    assert_true(low_before_last_high >= (HIGH * 100) / (AGING + N) - 1);
    assert_true(gs_agent_time(r[0].self) > 0.0);
    for (i = 0; i < N; ++i) {
        gs_agent_stats st = agent_stats(r[i].self);
        assert_true(st.max_wait <= (uint64_t)(AGING + N));
        assert_int_equal(st.steps, 100);
    }
    /* it ran because it aged, so it had waited more than aging_limit */
    assert_true(agent_stats(r[0].self).aged > 0);
    assert_true(agent_stats(r[0].self).max_wait > (uint64_t)AGING);
    gs_world_destroy(w);
}

/* An agent lowers its own priority from inside its step; with a rule that
   keeps the priority, the change sticks and orders the later steps. */
static void test_world_set_own_priority(void **state) {
    gs_world *w = world_with(NO_HOLD, NO_AGING, 8);
    trace tr;
    rec a, b;
    int i;
    (void)state;
    memset(&tr, 0, sizeof tr);
    rec_init(&a, 0);
    rec_init(&b, 1);
    a.tr = b.tr = &tr;
    a.set_priority_at = 2; /* its 2nd step moves it from 5 to 0 */
    a.new_priority = 0;
    add_rec(w, &a, 0.01);
    add_rec(w, &b, 0.01);
    gs_agent_set_behaviour(a.self, rule_keep, NULL);
    gs_agent_set_behaviour(b.self, rule_keep, NULL);
    gs_agent_set_priority(a.self, 5);
    gs_agent_set_priority(b.self, 3);
    assert_int_equal(gs_world_advance(w, 0.1, NULL), GS_OK);
    /* A A, then B's ten steps, then A's last eight. */
    assert_int_equal(tr.n, 20);
    for (i = 0; i < 20; ++i)
        assert_int_equal(tr.id[i], (i < 2 || i >= 12) ? 0 : 1);
    assert_int_equal(gs_agent_priority(a.self), 0);
    assert_int_equal(gs_agent_priority(b.self), 3);
    gs_world_destroy(w);
}

/* ---- behaviour tuning ---- */

static int clamp(int p, int n) { return p < 0 ? 0 : p > n ? n : p; }

/* The paper's rule called directly. The header lets a rule return any int
   and clamps it to 0..N, so the clamp is checked on the clamped value. */
static void test_world_behaviour_default(void **state) {
    gs_behaviour_in in;
    (void)state;
    memset(&in, 0, sizeof in);
    in.tolerance = 0.01;
    in.dt = 0.001;
    in.priority = 3;
    in.priority_max = 7;
    /* ahead of the slowest by more than the tolerance: one lower */
    in.t = 1.0; in.t_min = 0.98; in.t_max = 1.0;
    assert_int_equal(gs_behaviour_default(&in, NULL), 2);
    /* behind the fastest by more: one higher */
    in.t = 0.98; in.t_min = 0.98; in.t_max = 1.0;
    assert_int_equal(gs_behaviour_default(&in, NULL), 4);
    /* within the tolerance both ways: unchanged */
    in.t = 0.995; in.t_min = 0.99; in.t_max = 1.0;
    assert_int_equal(gs_behaviour_default(&in, NULL), 3);
    in.t = 1.0; in.t_min = 0.995; in.t_max = 1.0;
    assert_int_equal(gs_behaviour_default(&in, NULL), 3);
    /* clamped at 0 and N */
    in.priority = 0;
    in.t = 1.0; in.t_min = 0.9; in.t_max = 1.0;
    assert_int_equal(clamp(gs_behaviour_default(&in, NULL), 7), 0);
    in.priority = 7;
    in.t = 0.9; in.t_min = 0.9; in.t_max = 1.0;
    assert_int_equal(clamp(gs_behaviour_default(&in, NULL), 7), 7);
    /* the user pointer is not needed */
    in.priority = 5;
    in.t = 0.5; in.t_min = 0.5; in.t_max = 0.5;
    assert_int_equal(gs_behaviour_default(&in, &in), 5);
}

/* What the scheduler tells a rule, and what it does with out-of-range
   answers. */
typedef struct seen {
    long calls, bad;
    double tolerance, dt;
    int priority_max, answer;
} seen;

static int rule_inspect(const gs_behaviour_in *in, void *user) {
    seen *s = (seen *)user;
    s->calls++;
    if (!(in->t_min <= in->t && in->t <= in->t_max) ||
        in->tolerance != s->tolerance || in->dt != s->dt ||
        in->priority_max != s->priority_max || in->priority < 0 ||
        in->priority > in->priority_max)
        s->bad++;
    return s->answer;
}

static void test_world_behaviour_in_and_clamp(void **state) {
    gs_world *w = world_with(0.02, 16, 5);
    rec r[2];
    seen s[2];
    int i;
    (void)state;
    for (i = 0; i < 2; ++i) {
        rec_init(&r[i], i);
        add_rec(w, &r[i], i ? 0.003 : 0.007);
        memset(&s[i], 0, sizeof s[i]);
        s[i].tolerance = 0.02;
        s[i].dt = i ? 0.003 : 0.007;
        s[i].priority_max = 4;
        s[i].answer = i ? 100 : -5;
        gs_agent_set_behaviour(r[i].self, rule_inspect, &s[i]);
    }
    assert_int_equal(gs_world_advance(w, 0.1, NULL), GS_OK);
    for (i = 0; i < 2; ++i) {
        assert_true(s[i].calls > 0);
        assert_int_equal(s[i].bad, 0);
        assert_int_equal(agent_stats(r[i].self).activations,
                         (uint64_t)s[i].calls);
    }
    assert_int_equal(gs_agent_priority(r[0].self), 0);
    assert_int_equal(gs_agent_priority(r[1].self), 4);
    /* set_priority clamps too; NULL restores the default rule */
    gs_agent_set_priority(r[0].self, 99);
    assert_int_equal(gs_agent_priority(r[0].self), 4);
    gs_agent_set_priority(r[0].self, -3);
    assert_int_equal(gs_agent_priority(r[0].self), 0);
    gs_agent_set_behaviour(r[1].self, NULL, NULL);
    {
        long before = s[1].calls;
        uint64_t act = agent_stats(r[1].self).activations;
        assert_int_equal(gs_world_advance(w, 0.1, NULL), GS_OK);
        assert_int_equal(s[1].calls, before); /* the default rule ran */
        assert_true(agent_stats(r[1].self).activations > act);
        assert_true(gs_agent_priority(r[1].self) >= 0 &&
                    gs_agent_priority(r[1].self) <= 4);
    }
    gs_world_destroy(w);
}

/* ---- spread ---- */

/* Three agents with steps of 1, 7 and 13 ms and step costs 1000 times apart,
   tolerance 5 ms, the default behaviour rule, 60 frames of 1/60 s. After
   every single step the spread between the fastest and slowest simulation
   time stays within tolerance + the largest dt: an agent only runs while it
   leads the slowest by at most the tolerance, and one step moves it on by at
   most the largest dt. The 1e-12 s slack covers rounding: times are steps *
   dt in doubles near 1 s, off by a few 1e-16 s, while a real breach would be
   a whole step (>= 1 ms). */
static void test_world_spread(void **state) {
    static const double dts[3] = {1e-3, 7e-3, 1.3e-2};
    static const long costs[3] = {10000, 10, 10000};
    const double tol = 5e-3, bound = tol + 1.3e-2 + 1e-12;
    gs_world *w = world_with(tol, 64, 8);
    spread_probe sp;
    rec r[3];
    uint64_t held = 0;
    int i, f;
    (void)state;
    memset(&sp, 0, sizeof sp);
    sp.n = 3;
    for (i = 0; i < 3; ++i) {
        rec_init(&r[i], i);
        r[i].cost = costs[i];
        r[i].sp = &sp;
        add_rec(w, &r[i], dts[i]);
    }
    for (f = 0; f < 60; ++f) {
        gs_advance_report rep;
        assert_int_equal(gs_world_advance(w, 1.0 / 60.0, &rep), GS_OK);
        assert_int_equal(rep.reached, 1);
        assert_true(rep.t_max - rep.t_min <= bound);
        for (i = 0; i < 3; ++i)
            assert_true(fabs(gs_agent_time(r[i].self) - gs_world_time(w)) <=
                        0.5 * dts[i] + 1e-12);
    }
    assert_true(sp.checks > 1000);
    if (sp.max_spread > bound)
        print_error("spread %.9g s > bound %.9g s\n", sp.max_spread, bound);
    assert_true(sp.max_spread <= bound);
    assert_true(fabs(gs_world_time(w) - 1.0) < 1e-9);
    for (i = 0; i < 3; ++i) held += agent_stats(r[i].self).held;
    assert_true(held > 0); /* the rule that keeps the spread was exercised */
    gs_world_destroy(w);
}

/* ---- advancing to a target ---- */

static void test_world_advance_target(void **state) {
    static const double dts[3] = {0.01, 0.003, 0.007};
    static const double steps[4] = {0.25, 0.1, 1.0 / 60.0, 0.5};
    gs_world *w;
    gs_advance_report rep;
    rec r[3];
    double sum = 0.0;
    int i, k;
    (void)state;
    /* one agent: dt 0.01, 1 s is exactly 100 steps */
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    rec_init(&r[0], 0);
    add_rec(w, &r[0], 0.01);
    memset(&rep, 0xff, sizeof rep);
    assert_int_equal(gs_world_advance(w, 1.0, &rep), GS_OK);
    assert_int_equal(rep.reached, 1);
    assert_int_equal(rep.steps, 100);
    assert_int_equal(rep.failed_agents, 0);
    assert_true(fabs(rep.target - 1.0) < 1e-12);
    assert_true(fabs(gs_agent_time(r[0].self) - 1.0) < 1e-9);
    assert_int_equal(r[0].calls, 100);
    assert_int_equal(agent_stats(r[0].self).steps, 100);
    /* advancing by 0 does nothing */
    assert_int_equal(gs_world_advance(w, 0.0, &rep), GS_OK);
    assert_int_equal(rep.reached, 1);
    assert_int_equal(rep.steps, 0);
    gs_world_destroy(w);

    /* three agents, several advances: the world time is their sum */
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    assert_true(gs_world_time(w) == 0.0);
    for (i = 0; i < 3; ++i) {
        rec_init(&r[i], i);
        add_rec(w, &r[i], dts[i]);
    }
    for (k = 0; k < 4; ++k) {
        uint64_t before = 0, after = 0;
        for (i = 0; i < 3; ++i) before += agent_stats(r[i].self).steps;
        assert_int_equal(gs_world_advance(w, steps[k], &rep), GS_OK);
        sum += steps[k];
        assert_true(fabs(gs_world_time(w) - sum) < 1e-12);
        assert_true(fabs(rep.target - sum) < 1e-12);
        assert_int_equal(rep.reached, 1);
        for (i = 0; i < 3; ++i) {
            double t = gs_agent_time(r[i].self);
            assert_true(fabs(t - sum) <= 0.5 * dts[i] + 1e-12);
            assert_true(t >= rep.t_min && t <= rep.t_max);
            after += agent_stats(r[i].self).steps;
        }
        assert_int_equal(rep.steps, after - before);
    }
    gs_world_destroy(w);
}

/* ---- the wall-clock budget ---- */

typedef struct fake_clock {
    double now, tick;
    long calls;
} fake_clock;

static double fake_now(void *user) {
    fake_clock *c = (fake_clock *)user;
    c->calls++;
    c->now += c->tick;
    return c->now;
}

static void test_world_budget(void **state) {
    gs_world_desc wd = gs_world_desc_default();
    fake_clock clk = {100.0, 0.001, 0};
    gs_advance_report rep;
    gs_world *w;
    rec r;
    double t1, t2;
    (void)state;
    wd.budget = 0.05;
    wd.clock = fake_now;
    wd.clock_user = &clk;
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    rec_init(&r, 0);
    add_rec(w, &r, 0.001);
    assert_int_equal(gs_world_advance(w, 10.0, &rep), GS_OK);
    assert_int_equal(rep.reached, 0);
    assert_true(clk.calls > 0); /* the budget was measured on our clock */
    t1 = gs_agent_time(r.self);
    assert_true(t1 > 0.0);
    assert_true(t1 < 10.0 - 0.0005);
    /* 1 ms per clock reading, 50 ms budget: about 50 steps, not 10000 */
    assert_true(rep.steps > 0 && rep.steps <= 60);
    assert_true(fabs(gs_world_time(w) - 10.0) < 1e-12);
    assert_true(fabs(rep.target - 10.0) < 1e-12);
    /* the next advance goes on from there */
    assert_int_equal(gs_world_advance(w, 0.0, &rep), GS_OK);
    assert_int_equal(rep.reached, 0);
    t2 = gs_agent_time(r.self);
    assert_true(t2 > t1);
    assert_true(fabs(gs_world_time(w) - 10.0) < 1e-12);
    /* unbounded: it reaches the target */
    assert_int_equal(gs_world_set_budget(w, 0.0), GS_OK);
    assert_int_equal(gs_world_advance(w, 0.0, &rep), GS_OK);
    assert_int_equal(rep.reached, 1);
    assert_true(fabs(gs_agent_time(r.self) - 10.0) <= 0.0005 + 1e-9);
    assert_int_equal(agent_stats(r.self).steps, 10000);
    /* and a budget can be set again */
    assert_int_equal(gs_world_set_budget(w, 0.01), GS_OK);
    assert_int_equal(gs_world_advance(w, 1.0, &rep), GS_OK);
    assert_int_equal(rep.reached, 0);
    gs_world_destroy(w);
}

/* ---- determinism ---- */

typedef struct det_world {
    gs_world *w;
    gs_agent *cloth;
    rec r[2];
} det_world;

static void det_build(det_world *d, double nudge) {
    gs_cloth_desc cd = gs_cloth_desc_default();
    assert_int_equal(gs_world_create(NULL, &d->w), GS_OK);
    cd.nx = cd.ny = 8;
    cd.pin_corners = GS_CORNER_ALL;
    assert_int_equal(gs_cloth_create(d->w, &cd, &d->cloth), GS_OK);
    rec_init(&d->r[0], 0);
    rec_init(&d->r[1], 1);
    d->r[1].x[0] = 0.25;
    add_rec(d->w, &d->r[0], 0.003);
    add_rec(d->w, &d->r[1], 0.005);
    if (nudge != 0.0) { /* move one free particle (index 9: i=1, j=1) */
        size_t n = gs_agent_state_size(d->cloth);
        double s[1 + 6 * 64];
        assert_int_equal(n, 1 + 6 * 64);
        assert_int_equal(gs_agent_get_state(d->cloth, s, n), GS_OK);
        s[1 + 3 * 9 + 0] += nudge;
        assert_int_equal(gs_agent_set_state(d->cloth, s, n), GS_OK);
    }
}

static void det_run(det_world *d) {
    int f;
    for (f = 0; f < 12; ++f)
        assert_int_equal(gs_world_advance(d->w, 1.0 / 60.0, NULL), GS_OK);
}

static void test_world_determinism(void **state) {
    det_world a, b, c;
    int i;
    (void)state;
    det_build(&a, 0.0);
    det_build(&b, 0.0);
    det_build(&c, 1e-9);
    det_run(&a);
    det_run(&b);
    det_run(&c);
    assert_int_equal(gs_world_agent_count(a.w), 3);
    assert_true(gs_world_hash(a.w) == gs_world_hash(b.w));
    for (i = 0; i < 3; ++i) {
        gs_agent *x = gs_world_agent(a.w, i), *y = gs_world_agent(b.w, i);
        size_t n = gs_agent_state_size(x);
        double sx[1 + 6 * 64], sy[1 + 6 * 64];
        assert_int_equal(n, gs_agent_state_size(y));
        assert_true(n <= sizeof sx / sizeof sx[0]);
        assert_int_equal(gs_agent_get_state(x, sx, n), GS_OK);
        assert_int_equal(gs_agent_get_state(y, sy, n), GS_OK);
        assert_memory_equal(sx, sy, n * sizeof(double));
    }
    assert_true(gs_world_hash(a.w) != gs_world_hash(c.w));
    /* the cloth moved at all (else equal hashes prove little) */
    assert_true(gs_mesh_positions(a.cloth)[9].y < -1e-4);
    gs_world_destroy(a.w);
    gs_world_destroy(b.w);
    gs_world_destroy(c.w);
}

/* ---- a failing agent ---- */

static void test_world_failing_agent(void **state) {
    gs_world *w;
    gs_advance_report rep;
    rec bad, ok1, ok2;
    (void)state;
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    rec_init(&bad, 0);
    rec_init(&ok1, 1);
    rec_init(&ok2, 2);
    bad.fail_after = 5;
    add_rec(w, &ok1, 0.002);
    add_rec(w, &bad, 0.01);
    add_rec(w, &ok2, 0.005);
    assert_int_equal(gs_world_advance(w, 0.2, &rep), GS_ERR_UNSTABLE);
    assert_int_equal(rep.failed_agents, 1);
    assert_int_equal(gs_agent_result(bad.self), GS_ERR_UNSTABLE);
    assert_int_equal(gs_agent_result(ok1.self), GS_OK);
    assert_int_equal(gs_agent_result(ok2.self), GS_OK);
    /* it stopped after its first failure, its time where it failed */
    assert_int_equal(bad.calls, 6);
    assert_true(fabs(gs_agent_time(bad.self) - 0.05) < 1e-12);
    assert_int_equal(agent_stats(bad.self).steps, 5);
    /* the others reached the target */
    assert_true(fabs(gs_agent_time(ok1.self) - 0.2) <= 0.001 + 1e-12);
    assert_true(fabs(gs_agent_time(ok2.self) - 0.2) <= 0.0025 + 1e-12);
    assert_int_equal(rep.steps, 100 + 5 + 40);
    assert_true(fabs(gs_world_time(w) - 0.2) < 1e-12);
    gs_world_destroy(w);
}

/* ---- destroy, lookup, kinds, defaults ---- */

static void test_world_destroy_and_lookup(void **state) {
    gs_world *w;
    gs_cloth_desc cd = gs_cloth_desc_default();
    gs_mesh_desc md = gs_mesh_desc_default();
    gs_vec3 pts[2] = {{0, 0, 0}, {0.1, 0, 0}};
    gs_agent *cloth, *mesh;
    rec r[3];
    int i;
    (void)state;
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    assert_int_equal(gs_world_agent_count(w), 0);
    assert_null(gs_world_agent(w, 0));
    for (i = 0; i < 3; ++i) {
        rec_init(&r[i], i);
        add_rec(w, &r[i], 0.01);
    }
    assert_int_equal(gs_world_agent_count(w), 3);
    assert_ptr_equal(gs_world_agent(w, 1), r[1].self);
    assert_null(gs_world_agent(w, -1));
    assert_null(gs_world_agent(w, 3));
    assert_ptr_equal(gs_agent_world(r[0].self), w);
    assert_true(gs_agent_dt(r[0].self) == 0.01);

    assert_int_equal(gs_agent_destroy(r[1].self), GS_OK);
    assert_int_equal(gs_world_agent_count(w), 2);
    assert_ptr_equal(gs_world_agent(w, 0), r[0].self);
    assert_ptr_equal(gs_world_agent(w, 1), r[2].self);
    assert_null(gs_world_agent(w, 2));
    assert_int_equal(gs_world_advance(w, 0.1, NULL), GS_OK);
    assert_int_equal(r[0].calls, 10);
    assert_int_equal(r[1].calls, 0);
    assert_int_equal(r[2].calls, 10);

    cd.nx = cd.ny = 3;
    assert_int_equal(gs_cloth_create(w, &cd, &cloth), GS_OK);
    md.particle_count = 2;
    md.positions = pts;
    assert_int_equal(gs_mesh_create(w, &md, &mesh), GS_OK);
    assert_string_equal(gs_agent_kind(r[0].self), "custom");
    assert_string_equal(gs_agent_kind(cloth), "cloth");
    assert_string_equal(gs_agent_kind(mesh), "mesh");
    assert_int_equal(gs_world_agent_count(w), 4);
    /* destroy the first and the last; the rest still advance */
    assert_int_equal(gs_agent_destroy(r[0].self), GS_OK);
    assert_int_equal(gs_agent_destroy(mesh), GS_OK);
    assert_int_equal(gs_world_agent_count(w), 2);
    assert_ptr_equal(gs_world_agent(w, 0), r[2].self);
    assert_ptr_equal(gs_world_agent(w, 1), cloth);
    assert_int_equal(gs_world_advance(w, 0.1, NULL), GS_OK);
    assert_int_equal(r[0].calls, 10);
    assert_int_equal(r[2].calls, 20);
    assert_true(fabs(gs_agent_time(cloth) - 0.2) <= 0.0005 + 1e-9);
    gs_world_destroy(w);
    gs_world_destroy(NULL); /* ignored */
}

static void test_world_defaults(void **state) {
    gs_world_desc d = gs_world_desc_default(), zero;
    gs_world *w;
    gs_vec3 g, z = {0.0, 0.0, 0.0};
    (void)state;
    assert_int_equal(d.host_id, 1);
    assert_int_equal(d.queue_count, 8);
    assert_true(d.tolerance == 0.01);
    assert_int_equal(d.aging_limit, 64);
    assert_true(d.budget == 0.0);
    assert_true(d.gravity.x == 0.0 && d.gravity.y == -9.81 &&
                d.gravity.z == 0.0);
    assert_null(d.allocator.alloc);
    assert_null(d.allocator.free);

    /* NULL desc and an all-zero desc give the defaults */
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    assert_int_equal(gs_world_host_id(w), 1);
    assert_true(gs_world_time(w) == 0.0);
    assert_string_equal(gs_world_error(w), "");
    g = gs_world_gravity(w);
    assert_true(g.x == 0.0 && g.y == -9.81 && g.z == 0.0);
    /* zero gravity is a real setting */
    assert_int_equal(gs_world_set_gravity(w, z), GS_OK);
    g = gs_world_gravity(w);
    assert_true(g.x == 0.0 && g.y == 0.0 && g.z == 0.0);
    g.x = 1.5; g.y = 2.0; g.z = -3.0;
    assert_int_equal(gs_world_set_gravity(w, g), GS_OK);
    g = gs_world_gravity(w);
    assert_true(g.x == 1.5 && g.y == 2.0 && g.z == -3.0);
    gs_world_destroy(w);

    memset(&zero, 0, sizeof zero);
    assert_int_equal(gs_world_create(&zero, &w), GS_OK);
    assert_int_equal(gs_world_host_id(w), 1);
    g = gs_world_gravity(w);
    assert_true(g.x == 0.0 && g.y == -9.81 && g.z == 0.0);
    gs_world_destroy(w);

    zero.host_id = 42;
    zero.gravity.y = -1.62;
    assert_int_equal(gs_world_create(&zero, &w), GS_OK);
    assert_int_equal(gs_world_host_id(w), 42);
    assert_true(gs_world_gravity(w).y == -1.62);
    gs_world_destroy(w);
}

/* ---- allocation ---- */

static void test_world_allocator(void **state) {
    counter c;
    gs_world_desc wd = counted_world_desc(&c);
    gs_cloth_desc cd = gs_cloth_desc_default();
    gs_world *w;
    gs_agent *cl1, *cl2;
    rec r;
    long allocs, frees;
    size_t live;
    int f;
    (void)state;
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    assert_true(c.allocs >= 1); /* the world itself */
    cd.nx = cd.ny = 8;
    cd.pin_corners = GS_CORNER_ALL;
    assert_int_equal(gs_cloth_create(w, &cd, &cl1), GS_OK);
    cd.solver.integrator = GS_INTEGRATOR_IMPLICIT_EULER;
    cd.solver.dt = 0.01;
    assert_int_equal(gs_cloth_create(w, &cd, &cl2), GS_OK);
    rec_init(&r, 0);
    add_rec(w, &r, 0.004);
    assert_true(c.live >= 64 * 2 * 2 * sizeof(gs_vec3)); /* x and v, twice */
    allocs = c.allocs;
    frees = c.frees; /* the world history grows with each agent created */
    live = c.live;
    for (f = 0; f < 6; ++f)
        assert_int_equal(gs_world_advance(w, 1.0 / 60.0, NULL), GS_OK);
    (void)gs_world_hash(w);
    /* the step loop allocates nothing */
    assert_int_equal(c.allocs, allocs);
    assert_int_equal(c.frees, frees);
    assert_true(c.live == live);
    assert_true(gs_agent_time(cl1) > 0.09);
    assert_int_equal(gs_agent_destroy(cl2), GS_OK);
    assert_true(c.frees > 0 && c.live < live);
    gs_world_destroy(w);
    assert_true(c.allocs > 0);
    assert_int_equal(c.allocs, c.frees);
    assert_true(c.live == 0);
}

/* Every allocation in turn fails: each create call returns
   GS_ERR_NO_MEMORY with *out NULL and the world as it was, and destroying
   the world then frees everything. */
static void test_world_failing_allocator(void **state) {
    long n;
    int all_ok = 0;
    (void)state;
    for (n = 0; n < 64 && !all_ok; ++n) {
        counter c;
        gs_world_desc wd = counted_world_desc(&c);
        gs_cloth_desc cd = gs_cloth_desc_default();
        gs_world *w = (gs_world *)&c; /* not NULL before the call */
        gs_agent *a;
        gs_result r;
        rec recs[10];
        int i, count;
        c.fail_from = n + 1; /* n blocks given, then refusals */
        r = gs_world_create(&wd, &w);
        if (r != GS_OK) {
            assert_int_equal(r, GS_ERR_NO_MEMORY);
            assert_null(w);
            assert_int_equal(c.allocs, c.frees);
            continue;
        }
        cd.nx = cd.ny = 6;
        cd.pin_corners = GS_CORNER_00;
        a = (gs_agent *)&c;
        r = gs_cloth_create(w, &cd, &a);
        if (r != GS_OK) {
            assert_int_equal(r, GS_ERR_NO_MEMORY);
            assert_null(a);
            assert_int_equal(gs_world_agent_count(w), 0);
            assert_true(strlen(gs_world_error(w)) > 0);
        }
        /* ten custom agents: the agent list grows past its first size */
        for (i = 0; i < 10; ++i) {
            gs_custom_desc xd = custom_desc(0.01, 2, rec_step, rec_get, rec_set, &recs[i]);
            count = gs_world_agent_count(w);
            rec_init(&recs[i], i);
            a = (gs_agent *)&c;
            r = gs_custom_create(w, &xd, &a);
            if (r != GS_OK) {
                assert_int_equal(r, GS_ERR_NO_MEMORY);
                assert_null(a);
                assert_int_equal(gs_world_agent_count(w), count);
            } else {
                assert_int_equal(gs_world_agent_count(w), count + 1);
            }
        }
        /* whatever got built still runs */
        assert_int_equal(gs_world_advance(w, 0.05, NULL), GS_OK);
        all_ok = c.refused == 0;
        gs_world_destroy(w);
        assert_int_equal(c.allocs, c.frees);
        assert_true(c.live == 0);
    }
    assert_true(all_ok); /* some n let every call through */
    assert_true(n >= 4); /* world, cloth, custom agents, a grown list */
}

/* ---- state ---- */

static void test_world_state_roundtrip(void **state) {
    gs_world *w;
    gs_cloth_desc cd = gs_cloth_desc_default();
    gs_agent *cloth;
    rec r;
    double s[3], back[3], set[3] = {5.0, 0.5, -0.25};
    double cs[1 + 6 * 16], cs2[1 + 6 * 16];
    size_t n;
    (void)state;
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    rec_init(&r, 0);
    add_rec(w, &r, 0.01);
    assert_int_equal(gs_agent_state_size(r.self), 3);
    assert_int_equal(gs_agent_get_state(r.self, s, 3), GS_OK);
    assert_true(s[0] == 0.0 && s[1] == 1.0 && s[2] == 0.0);
    /* time shift */
    assert_int_equal(gs_agent_set_state(r.self, set, 3), GS_OK);
    assert_int_equal(r.set_calls, 1);
    assert_true(gs_agent_time(r.self) == 5.0);
    assert_int_equal(gs_agent_get_state(r.self, back, 3), GS_OK);
    assert_memory_equal(back, set, sizeof set);
    assert_int_equal(gs_agent_step(r.self), GS_OK);
    assert_true(r.last_t == 5.0 && r.last_dt == 0.01);
    assert_true(fabs(gs_agent_time(r.self) - 5.01) < 1e-12);
    assert_int_equal(gs_agent_result(r.self), GS_OK);
    /* after some steps the shift still holds */
    assert_int_equal(gs_agent_step(r.self), GS_OK);
    set[0] = 2.0;
    assert_int_equal(gs_agent_set_state(r.self, set, 3), GS_OK);
    assert_true(fabs(gs_agent_time(r.self) - 2.0) < 1e-12);
    assert_int_equal(gs_agent_step(r.self), GS_OK);
    assert_true(fabs(gs_agent_time(r.self) - 2.01) < 1e-12);

    /* a cloth: get, set the same, get again: bit for bit */
    cd.nx = cd.ny = 4;
    cd.pin_corners = GS_CORNER_00 | GS_CORNER_10;
    assert_int_equal(gs_cloth_create(w, &cd, &cloth), GS_OK);
    n = gs_agent_state_size(cloth);
    assert_int_equal(n, 1 + 6 * 16);
    assert_int_equal(gs_agent_step(cloth), GS_OK);
    assert_int_equal(gs_agent_step(cloth), GS_OK);
    assert_int_equal(gs_agent_get_state(cloth, cs, n), GS_OK);
    assert_true(fabs(cs[0] - 0.002) < 1e-12);
    assert_int_equal(gs_agent_set_state(cloth, cs, n), GS_OK);
    assert_int_equal(gs_agent_get_state(cloth, cs2, n), GS_OK);
    assert_memory_equal(cs, cs2, n * sizeof(double));
    /* time shift on a cloth, and a moved free particle */
    cs[0] = 5.0;
    cs[1 + 3 * 5 + 1] = 0.125; /* particle 5, y */
    assert_int_equal(gs_agent_set_state(cloth, cs, n), GS_OK);
    assert_true(fabs(gs_agent_time(cloth) - 5.0) < 1e-12);
    assert_true(gs_mesh_positions(cloth)[5].y == 0.125);
    assert_int_equal(gs_agent_step(cloth), GS_OK);
    assert_true(fabs(gs_agent_time(cloth) - 5.001) < 1e-12);
    gs_world_destroy(w);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_world_priorities),
        cmocka_unit_test(test_world_fifo),
        cmocka_unit_test(test_world_no_starvation),
        cmocka_unit_test(test_world_set_own_priority),
        cmocka_unit_test(test_world_behaviour_default),
        cmocka_unit_test(test_world_behaviour_in_and_clamp),
        cmocka_unit_test(test_world_spread),
        cmocka_unit_test(test_world_advance_target),
        cmocka_unit_test(test_world_budget),
        cmocka_unit_test(test_world_determinism),
        cmocka_unit_test(test_world_failing_agent),
        cmocka_unit_test(test_world_destroy_and_lookup),
        cmocka_unit_test(test_world_defaults),
        cmocka_unit_test(test_world_allocator),
        cmocka_unit_test(test_world_failing_allocator),
        cmocka_unit_test(test_world_state_roundtrip),
    };
    return cmocka_run_group_tests_name("world", tests, NULL, NULL);
}
