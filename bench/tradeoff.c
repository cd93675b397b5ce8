/* bench/tradeoff.c - what speed costs in accuracy, and what each sync choice
   costs in consistency.

   usage: build/bench/tradeoff [--quick] [--out FILE.json]

   1. integrators: a cloth (n x n, 1 kg, pinned at its 4 corners, released
      flat) for each integrator x dt x stretch stiffness: the RMS position
      error at T against a reference (RK4 at a tiny dt), ns per step, the
      cost of a simulated second, the largest stable dt found by bisection,
      the Pareto front (for each accuracy, the fastest setting), and the
      measured limits against theory (omega dt = 2 for symplectic Euler with
      omega = sqrt(k / m) of the stiffest spring and a particle's mass; the
      library's Gershgorin bound; one spring alone, where the theory is
      exact). Explicit integrators run with GS_STABILITY_UNCHECKED so that
      the library does not substep behind our back.
   2. wire encoding: f64 against f32 on gs_simnet with the paper's scene:
      bytes per second against the divergence between the hosts' copies.
   3. weight rules x catch-up modes x network profiles on gs_simnet with the
      paper's scene (gs_scene_create, ghosts attached as the reference peer
      does): the simulation-time gap between the hosts (median, p99), the
      divergence while host 1's probe pushes and after it stops, the time to
      converge after a 5 s outage, and whether every host kept pace with the
      simulated wall clock. Both worlds live in this process, so the gap and
      the divergence are measured exactly, not estimated from snapshots.
   Everything is seeded: the same build gives the same accuracy and network
   figures; only the timings vary. */
#define GHOSTSIM_IMPLEMENTATION
#include "ghostsim.h"
#include "tests/net_helpers.h"
#include "bench/bench_util.h"

#include <float.h>

/* ======================================================================
   part 1: integrators x dt x stiffness
   ====================================================================== */

typedef struct integ_info {
    gs_integrator id;
    const char *name;
} integ_info;

static const integ_info INTEGS[] = {
    {GS_INTEGRATOR_SYMPLECTIC_EULER, "symplectic Euler"},
    {GS_INTEGRATOR_VERLET, "Verlet"},
    {GS_INTEGRATOR_RK4, "RK4"},
    {GS_INTEGRATOR_IMPLICIT_EULER, "implicit Euler"},
    {GS_INTEGRATOR_EXPLICIT_EULER, "explicit Euler"},
    {GS_INTEGRATOR_XPBD, "XPBD"}, /* at its default 4 substeps per step */
};
#define NINTEG ((int)(sizeof INTEGS / sizeof INTEGS[0]))

#define MAX_K 4
#define MAX_DT 10
#define CLOTH_N 10
#define DT_HI 0.1    /* s: the bisection's upper end */
#define DT_LO 1e-6   /* s: and its lower end */

typedef struct accuracy_cfg {
    int nk, ndt;
    double k[MAX_K];
    double dt[MAX_DT];
    double T;          /* s simulated */
    double dt_ref;     /* s, the RK4 reference */
    int timing_repeats;
    int stab_steps;    /* steps a candidate dt must survive */
    int bisect_iters;
} accuracy_cfg;

typedef struct point {
    int integ, ki, di;
    double dt, error, ns_per_step, us_per_sim_s;
    int stable;
} point;

typedef struct stab {
    double dt_max;       /* s; measured */
    int capped;          /* stable at DT_HI */
    int never;           /* unstable at DT_LO */
} stab;

/* A world with one cloth; NULL on failure. */
static gs_world *cloth_world(int n, double k, gs_integrator integ, double dt, gs_agent **cloth) {
    gs_world *w = NULL;
    gs_world_desc wd = gs_world_desc_default();
    gs_cloth_desc cd = gs_cloth_desc_default();
    if (gs_world_create(&wd, &w) != GS_OK) return NULL;
    cd.nx = cd.ny = n;
    cd.stretch_stiffness = k; /* shear k/10, bend k/100 by default */
    cd.pin_corners = GS_CORNER_ALL;
    cd.solver.dt = dt;
    cd.solver.integrator = integ;
    cd.solver.stability = GS_STABILITY_UNCHECKED;
    if (gs_cloth_create(w, &cd, cloth) != GS_OK) {
        fprintf(stderr, "tradeoff: %s\n", gs_world_error(w));
        gs_world_destroy(w);
        return NULL;
    }
    return w;
}

/* Steps a cloth `steps` times; 0 if a step failed. */
static int run_steps(gs_agent *a, long steps) {
    long i;
    for (i = 0; i < steps; ++i)
        if (gs_agent_step(a) != GS_OK) return 0;
    return 1;
}

static double rms_dist(const gs_vec3 *a, const gs_vec3 *b, int n) {
    double s = 0.0;
    int i;
    for (i = 0; i < n; ++i)
        s += (a[i].x - b[i].x) * (a[i].x - b[i].x) + (a[i].y - b[i].y) * (a[i].y - b[i].y) +
             (a[i].z - b[i].z) * (a[i].z - b[i].z);
    return sqrt(s / n);
}

/* Positions at T with integrator/dt; 0 on failure. `ns` gets ns per step
   (median of `repeats` runs). */
static int cloth_at(double k, gs_integrator integ, double dt, double T, int repeats,
                    gs_vec3 *out, double *ns) {
    long steps = lround(T / dt);
    double times[16];
    int r, ok = 1;
    if (repeats > 16) repeats = 16;
    for (r = 0; r < repeats && ok; ++r) {
        gs_agent *c;
        gs_world *w = cloth_world(CLOTH_N, k, integ, dt, &c);
        double t0;
        if (!w) return 0;
        t0 = bu_now();
        ok = run_steps(c, steps);
        times[r] = (bu_now() - t0) / (double)steps;
        if (ok && r == 0) memcpy(out, gs_mesh_positions(c), sizeof(gs_vec3) * CLOTH_N * CLOTH_N);
        gs_world_destroy(w);
    }
    if (ns) *ns = ok ? 1e9 * bu_median(times, repeats) : NAN;
    return ok;
}

/* Positions perturbed by a seeded 1e-4 m, so every mode starts excited. */
static void perturb(gs_agent *a, uint32_t seed) {
    size_t n = gs_agent_state_size(a), i, np = (n - 1) / 2;
    double *s = (double *)malloc(n * sizeof(double));
    if (!s) return;
    gs_agent_get_state(a, s, n);
    for (i = 1; i <= np; ++i) {
        seed = seed * 1664525u + 1013904223u;
        s[i] += 1e-4 * (((double)(seed >> 8) / 16777216.0) - 0.5);
    }
    gs_agent_set_state(a, s, n);
    free(s);
}

static double max_speed(const gs_agent *a) {
    const gs_vec3 *v = gs_mesh_velocities(a);
    int i, n = gs_mesh_particle_count(a);
    double m = 0.0;
    for (i = 0; i < n; ++i) {
        double s = sqrt(v[i].x * v[i].x + v[i].y * v[i].y + v[i].z * v[i].z);
        if (!(s <= m)) m = s; /* NaN counts as the largest */
    }
    return m;
}

/* A cloth survives `steps` steps at dt: no failed step, no particle faster
   than 100 m/s (a cloth falling under gravity stays under 5 m/s). The
   world's pinned pieces are deterministic: the same answer every run. */
static int cloth_stable(double k, gs_integrator integ, double dt, int steps) {
    gs_agent *c;
    gs_world *w = cloth_world(CLOTH_N, k, integ, dt, &c);
    int i, ok = 1;
    if (!w) return 0;
    perturb(c, 7);
    for (i = 0; i < steps && ok; ++i) {
        if (gs_agent_step(c) != GS_OK) ok = 0;
        else if (i % 50 == 49 && max_speed(c) > 100.0) ok = 0;
    }
    if (ok && !(max_speed(c) <= 100.0)) ok = 0;
    gs_world_destroy(w);
    return ok;
}

/* One free particle on one spring to a pinned one, no damping, no gravity:
   theory is exact here (omega = sqrt(k/m)). Stable: the stretch stays under
   1000x its start over `steps` steps. */
static int spring_stable(double k, double m, gs_integrator integ, double dt, int steps) {
    gs_world *w = NULL;
    gs_world_desc wd = gs_world_desc_default();
    gs_mesh_desc md = gs_mesh_desc_default();
    /* a long spring: 1000x the start stretch stays far inside its length,
       so the motion stays linear (through the anchor it would not be) */
    gs_vec3 x[2] = {{0.0, 0.0, 0.0}, {100.01, 0.0, 0.0}};
    double masses[2];
    gs_spring s;
    int pin = 0, i, ok = 1;
    gs_agent *a;
    const gs_vec3 zero = {0.0, 0.0, 0.0};
    masses[0] = masses[1] = m;
    s.a = 0;
    s.b = 1;
    s.rest_length = 100.0;
    s.stiffness = k;
    s.damping = 0.0;
    if (gs_world_create(&wd, &w) != GS_OK) return 0;
    gs_world_set_gravity(w, zero);
    md.particle_count = 2;
    md.positions = x;
    md.masses = masses;
    md.spring_count = 1;
    md.springs = &s;
    md.pin_count = 1;
    md.pins = &pin;
    md.air_damping = 0.0;
    md.solver.dt = dt;
    md.solver.integrator = integ;
    md.solver.stability = GS_STABILITY_UNCHECKED;
    if (gs_mesh_create(w, &md, &a) != GS_OK) {
        gs_world_destroy(w);
        return 0;
    }
    for (i = 0; i < steps && ok; ++i) {
        const gs_vec3 *p;
        if (gs_agent_step(a) != GS_OK) { ok = 0; break; }
        p = gs_mesh_positions(a);
        /* 1000x the start: symplectic Euler's orbit stretches as
           1 / sqrt(1 - (omega dt / 2)^2) near its limit without growing */
        if (!(fabs(p[1].x - 100.0) < 10.0 && fabs(p[1].y) < 10.0 && fabs(p[1].z) < 10.0)) ok = 0;
    }
    gs_world_destroy(w);
    return ok;
}

typedef int (*stable_fn)(const void *ctx, double dt);
typedef struct cloth_ctx { double k; gs_integrator integ; int steps; } cloth_ctx;
typedef struct spring_ctx { double k, m; gs_integrator integ; int steps; } spring_ctx;
static int cloth_ctx_stable(const void *c, double dt) {
    const cloth_ctx *x = (const cloth_ctx *)c;
    return cloth_stable(x->k, x->integ, dt, x->steps);
}
static int spring_ctx_stable(const void *c, double dt) {
    const spring_ctx *x = (const spring_ctx *)c;
    return spring_stable(x->k, x->m, x->integ, dt, x->steps);
}

/* The largest dt in [DT_LO, DT_HI] that is stable, by bisection in log dt
   (assumes one threshold, which holds for these linear-ish systems). */
static stab bisect(stable_fn f, const void *ctx, int iters) {
    stab s;
    double lo = DT_LO, hi = DT_HI;
    int i;
    memset(&s, 0, sizeof s);
    if (f(ctx, hi)) { s.dt_max = hi; s.capped = 1; return s; }
    if (!f(ctx, lo)) { s.dt_max = 0.0; s.never = 1; return s; }
    for (i = 0; i < iters; ++i) {
        double mid = sqrt(lo * hi);
        if (f(ctx, mid)) lo = mid;
        else hi = mid;
    }
    s.dt_max = lo;
    return s;
}

typedef struct part1 {
    accuracy_cfg cfg;
    point pts[MAX_K * NINTEG * MAX_DT];
    int npts;
    stab cloth_stab[MAX_K][NINTEG];
    stab spring_stab[NINTEG];
    double bound[MAX_K];     /* gs_mesh_stable_dt, symplectic */
    double omega[MAX_K];     /* sqrt(k / m_particle) */
    double ref_err[MAX_K];   /* |RK4(dt_ref) - RK4(2 dt_ref)| */
    double spring_omega;
} part1;

static void part1_run(part1 *p, int quick) {
    accuracy_cfg *c = &p->cfg;
    static const double ks_full[] = {100.0, 1000.0, 10000.0};
    static const double dts_full[] = {1e-4, 2e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2};
    static const double dts_quick[] = {2e-4, 1e-3, 2e-3, 5e-3};
    const double m_particle = 1.0 / (CLOTH_N * CLOTH_N);
    int ki, ii, di;
    memset(c, 0, sizeof *c);
    if (quick) {
        c->nk = 1;
        c->k[0] = 1000.0;
        c->ndt = 4;
        memcpy(c->dt, dts_quick, sizeof dts_quick);
        c->T = 0.25;
        c->dt_ref = 2e-5;
        c->timing_repeats = 1;
        c->stab_steps = 1000;
        c->bisect_iters = 10;
    } else {
        c->nk = 3;
        memcpy(c->k, ks_full, sizeof ks_full);
        c->ndt = 7;
        memcpy(c->dt, dts_full, sizeof dts_full);
        c->T = 0.5;
        c->dt_ref = 1e-5;
        c->timing_repeats = 3;
        c->stab_steps = 2000;
        c->bisect_iters = 14;
    }
    p->npts = 0;
    for (ki = 0; ki < c->nk; ++ki) {
        gs_vec3 ref[CLOTH_N * CLOTH_N], ref2[CLOTH_N * CLOTH_N], x[CLOTH_N * CLOTH_N];
        gs_agent *cl;
        gs_world *w = cloth_world(CLOTH_N, c->k[ki], GS_INTEGRATOR_SYMPLECTIC_EULER, 1e-3, &cl);
        p->bound[ki] = w ? gs_mesh_stable_dt(cl) : NAN;
        gs_world_destroy(w);
        p->omega[ki] = sqrt(c->k[ki] / m_particle);
        cloth_at(c->k[ki], GS_INTEGRATOR_RK4, c->dt_ref, c->T, 1, ref, NULL);
        cloth_at(c->k[ki], GS_INTEGRATOR_RK4, 2 * c->dt_ref, c->T, 1, ref2, NULL);
        p->ref_err[ki] = rms_dist(ref, ref2, CLOTH_N * CLOTH_N) / 15.0; /* RK4: e(2h) = 16 e(h) */
        for (ii = 0; ii < NINTEG; ++ii) {
            cloth_ctx cc;
            cc.k = c->k[ki];
            cc.integ = INTEGS[ii].id;
            cc.steps = c->stab_steps;
            p->cloth_stab[ki][ii] = bisect(cloth_ctx_stable, &cc, c->bisect_iters);
            for (di = 0; di < c->ndt; ++di) {
                point *pt = &p->pts[p->npts++];
                pt->integ = ii;
                pt->ki = ki;
                pt->di = di;
                pt->dt = c->dt[di];
                pt->stable = cloth_at(c->k[ki], INTEGS[ii].id, c->dt[di], c->T, c->timing_repeats,
                                      x, &pt->ns_per_step);
                pt->error = pt->stable ? rms_dist(x, ref, CLOTH_N * CLOTH_N) : NAN;
                /* a run that finished but went wild is not a usable setting */
                if (pt->stable && !(pt->error < 1.0)) pt->stable = 0;
                pt->us_per_sim_s = pt->stable ? 1e-3 * pt->ns_per_step / pt->dt : NAN;
            }
        }
    }
    /* one spring: k = 1000 N/m, m = 0.01 kg, omega = 316 rad/s */
    p->spring_omega = sqrt(1000.0 / 0.01);
    for (ii = 0; ii < NINTEG; ++ii) {
        spring_ctx sc;
        sc.k = 1000.0;
        sc.m = 0.01;
        sc.integ = INTEGS[ii].id;
        sc.steps = c->stab_steps;
        p->spring_stab[ii] = bisect(spring_ctx_stable, &sc, c->bisect_iters + 4);
    }
}

/* Pareto front for stiffness ki: the settings no other setting beats on both
   error and cost. Fills idx (sorted by cost), returns the count. */
static int pareto(const part1 *p, int ki, int *idx) {
    int order[MAX_K * NINTEG * MAX_DT], n = 0, i, j, m = 0;
    double best = DBL_MAX;
    for (i = 0; i < p->npts; ++i)
        if (p->pts[i].ki == ki && p->pts[i].stable) order[n++] = i;
    for (i = 1; i < n; ++i) /* insertion sort by cost */
        for (j = i; j > 0 && p->pts[order[j]].us_per_sim_s < p->pts[order[j - 1]].us_per_sim_s; --j) {
            int t = order[j];
            order[j] = order[j - 1];
            order[j - 1] = t;
        }
    for (i = 0; i < n; ++i)
        if (p->pts[order[i]].error < best) {
            best = p->pts[order[i]].error;
            idx[m++] = order[i];
        }
    return m;
}

static const double ACCURACIES[] = {1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7};
#define NACC ((int)(sizeof ACCURACIES / sizeof ACCURACIES[0]))

/* The cheapest stable setting with error <= acc, or -1. */
static int fastest_for(const part1 *p, int ki, double acc) {
    int i, best = -1;
    for (i = 0; i < p->npts; ++i) {
        const point *pt = &p->pts[i];
        if (pt->ki != ki || !pt->stable || !(pt->error <= acc)) continue;
        if (best < 0 || pt->us_per_sim_s < p->pts[best].us_per_sim_s) best = i;
    }
    return best;
}

static void part1_print(const part1 *p) {
    const accuracy_cfg *c = &p->cfg;
    int ki, ii, di, a;
    fprintf(stderr, "\n== 1. integrators: %dx%d cloth, 1 kg, corners pinned, released flat; error = "
                    "RMS position error at T = %.2f s against RK4 at dt = %g s\n",
            CLOTH_N, CLOTH_N, c->T, c->dt_ref);
    for (ki = 0; ki < c->nk; ++ki) {
        int idx[MAX_K * NINTEG * MAX_DT], n;
        fprintf(stderr, "\nk = %g N/m (shear k/10, bend k/100); reference error about %.1e m\n",
                c->k[ki], p->ref_err[ki]);
        fprintf(stderr, "%-17s", "error m | dt ms");
        for (di = 0; di < c->ndt; ++di) fprintf(stderr, " %9.2g", 1e3 * c->dt[di]);
        fprintf(stderr, "   %9s\n", "ns/step");
        for (ii = 0; ii < NINTEG; ++ii) {
            double ns = NAN;
            fprintf(stderr, "%-17s", INTEGS[ii].name);
            for (di = 0; di < c->ndt; ++di) {
                const point *pt = &p->pts[(ki * NINTEG + ii) * c->ndt + di];
                if (pt->stable) {
                    fprintf(stderr, " %9.1e", pt->error);
                    if (isnan(ns)) ns = pt->ns_per_step;
                } else {
                    fprintf(stderr, " %9s", "unstable");
                }
            }
            fprintf(stderr, "   %9.0f\n", ns);
        }
        fprintf(stderr, "largest stable dt (bisection, %d steps from a perturbed start) against "
                        "theory; omega = sqrt(k/m) = %.0f rad/s, library bound %.3g ms:\n",
                c->stab_steps, p->omega[ki], 1e3 * p->bound[ki]);
        for (ii = 0; ii < NINTEG; ++ii) {
            const stab *s = &p->cloth_stab[ki][ii];
            if (s->capped) fprintf(stderr, "  %-17s stable up to %g s (the largest tried)\n",
                                   INTEGS[ii].name, DT_HI);
            else if (s->never) fprintf(stderr, "  %-17s unstable even at %g s\n", INTEGS[ii].name, DT_LO);
            else fprintf(stderr, "  %-17s dt_max %.4g ms  omega*dt_max %.3f  measured/bound %.3f\n",
                         INTEGS[ii].name, 1e3 * s->dt_max, p->omega[ki] * s->dt_max,
                         s->dt_max / p->bound[ki]);
        }
        n = pareto(p, ki, idx);
        fprintf(stderr, "Pareto front (cheapest first; each more accurate than every cheaper one):\n");
        for (a = 0; a < n; ++a) {
            const point *pt = &p->pts[idx[a]];
            fprintf(stderr, "  %-17s dt %6.3g ms  error %8.1e m  %9.0f us per simulated s\n",
                    INTEGS[pt->integ].name, 1e3 * pt->dt, pt->error, pt->us_per_sim_s);
        }
        fprintf(stderr, "fastest setting for each accuracy:\n");
        for (a = 0; a < NACC; ++a) {
            int b = fastest_for(p, ki, ACCURACIES[a]);
            if (b < 0) fprintf(stderr, "  error <= %.0e m: none of the settings tried\n", ACCURACIES[a]);
            else fprintf(stderr, "  error <= %.0e m: %-17s dt %6.3g ms (%9.0f us per simulated s)\n",
                         ACCURACIES[a], INTEGS[p->pts[b].integ].name, 1e3 * p->pts[b].dt,
                         p->pts[b].us_per_sim_s);
        }
    }
    fprintf(stderr, "\none spring (k 1000 N/m, m 0.01 kg, undamped, omega %.1f rad/s): measured "
                    "omega*dt_max (theory: symplectic Euler 2, Verlet 2, RK4 2.83, implicit "
                    "none, explicit Euler 0, XPBD none)\n", p->spring_omega);
    for (ii = 0; ii < NINTEG; ++ii) {
        const stab *s = &p->spring_stab[ii];
        if (s->capped) fprintf(stderr, "  %-17s stable up to %g s\n", INTEGS[ii].name, DT_HI);
        else if (s->never) fprintf(stderr, "  %-17s unstable at %g s\n", INTEGS[ii].name, DT_LO);
        else fprintf(stderr, "  %-17s omega*dt_max %.4f\n", INTEGS[ii].name,
                     p->spring_omega * s->dt_max);
    }
}

/* ======================================================================
   parts 2 and 3: sessions of the paper's scene on gs_simnet
   ====================================================================== */

#define HOSTS 2
#define FRAME 0.005       /* s: the reference peer's frame */
#define PARK_HEIGHT 0.4   /* m: a parked probe hangs clear of the cloth */
#define MAX_SAMPLES 8192

typedef struct net_profile {
    const char *name;
    const char *text;
    gs_link_desc link;
} net_profile;

typedef struct weight_rule {
    const char *name;
    gs_weight_fn fn;
    double rate; /* 1/s for gs_weight_exp */
} weight_rule;

/* The catch-up modes under test: one line each. When GS_CATCHUP_MATCHED
   (or another mode) lands in ghostsim.h, add it here. */
typedef struct catchup_mode {
    const char *name;
    gs_catchup mode;
} catchup_mode;
static const catchup_mode CATCHUPS[] = {
    {"none", GS_CATCHUP_NONE},
    {"velocity", GS_CATCHUP_VELOCITY},
};
#define NCATCHUP ((int)(sizeof CATCHUPS / sizeof CATCHUPS[0]))

static const weight_rule RULES[] = {
    {"client/server", gs_weight_cs, 0.0},
    {"exp rate 1", gs_weight_exp, 1.0},
    {"exp rate 10", gs_weight_exp, 10.0},
    {"exp rate 100", gs_weight_exp, 100.0},
};
#define NRULES ((int)(sizeof RULES / sizeof RULES[0]))

static net_profile make_profile(int i) {
    net_profile p;
    memset(&p, 0, sizeof p);
    if (i == 0) {
        p.name = "LAN";
        p.text = "1 ms";
        p.link.latency = 0.001;
    } else if (i == 1) {
        p.name = "WAN";
        p.text = "50 ms +-10 ms, 2% loss";
        p.link.latency = 0.040;
        p.link.jitter = 0.020; /* uniform in [0, 20 ms]: 40..60 ms */
        p.link.loss = 0.02;
    } else {
        p.name = "bad";
        p.text = "150 ms +-50 ms, 10% loss, 5% duplicates, 10% reordered";
        p.link.latency = 0.100;
        p.link.jitter = 0.100; /* 100..200 ms */
        p.link.loss = 0.10;
        p.link.duplicate = 0.05;
        p.link.reorder = 0.10;
    }
    return p;
}
#define NPROFILES 3
#define START_OFFSET 0.1 /* s: host 1 starts this long before host 2 */
#define SETTLE 2.0       /* s each host runs alone before they connect */

/* The few sessions --quick runs: every rule kind, catch-up mode and two
   profiles are exercised once. */
static int quick_pick(int profile, int rule, int catchup) {
    if (profile == 0) return rule == 0 && catchup == 0;
    if (profile == 2) return rule == 2 && catchup == 1;
    return 0;
}

typedef struct timeline {
    double offset;         /* s: host 1 started this long before host 2 */
    double push0, push1;   /* s: host 1's probe pushes */
    double out0, out1;     /* s: both links cut */
    double out_push1;      /* s: the probe pushes during the outage until */
    double end;
} timeline;

typedef struct session_cfg {
    net_profile prof;
    const weight_rule *rule;
    const catchup_mode *catchup;
    gs_encoding encoding;
    timeline tl;
    int no_spheres;  /* 1: the scene without its spheres (no chaos) */
} session_cfg;

typedef struct session_result {
    double gap_med, gap_p99, gap_max;   /* s, outside the outage */
    double frac_under_20ms, frac_under_40ms;
    double div_push_med, div_push_p99;  /* m, while pushing */
    double div_after_med;               /* m, last second before the outage */
    double div_end;                     /* m, at the end */
    double gap_start;                   /* s, the gap at the first sample */
    double converge_s;                  /* s after the outage until within 1 cm
                                           for good; NAN if never */
    double rebaseline_s;                /* s until back under 2x the pre-outage
                                           level (1 mm at least) for good */
    double bytes_per_s;                 /* per host, sent to its peer */
    double pace_min, pace_max;          /* agent time / simulated wall time */
    double max_clock_error;             /* s, largest |t_agent - t_wall| */
    int kept_pace;
    double wall_s;                      /* s this session took to compute */
    int ok;
} session_result;

typedef struct host {
    gs_world *w;
    gs_scene sc;
    double rate;
} host;

static int attach(host *h, const session_cfg *c) {
    gs_ghost_desc gd = gs_ghost_desc_default();
    int i;
    h->rate = c->rule->rate;
    gd.weight = c->rule->fn;
    gd.weight_user = c->rule->fn == gs_weight_exp ? &h->rate : NULL;
    gd.encoding = c->encoding;
    gd.catchup = c->catchup->mode;
    gd.object_id = 1;
    if (gs_ghost_attach(h->sc.cloth, &gd) != GS_OK) return 0;
    for (i = 0; i < h->sc.sphere_count; ++i) {
        gd.object_id = 100 + (uint32_t)i;
        if (gs_ghost_attach(h->sc.spheres[i], &gd) != GS_OK) return 0;
    }
    gd.weight = gs_weight_owner;
    gd.weight_user = NULL;
    for (i = 0; i < h->sc.probe_count; ++i) {
        gd.object_id = 200 + (uint32_t)i;
        gd.owner = (uint32_t)i + 1;
        if (gs_ghost_attach(h->sc.probes[i], &gd) != GS_OK) return 0;
    }
    return 1;
}

static double dist3(gs_vec3 a, gs_vec3 b) {
    return sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) + (a.z - b.z) * (a.z - b.z));
}

/* The largest over the shared objects of the RMS distance between the two
   copies (the library's own definition of a peer's divergence). */
static double divergence(const host *a, const host *b) {
    int n = gs_mesh_particle_count(a->sc.cloth), i;
    double worst = rms_dist(gs_mesh_positions(a->sc.cloth), gs_mesh_positions(b->sc.cloth), n);
    for (i = 0; i < a->sc.sphere_count && i < b->sc.sphere_count; ++i) {
        double d = dist3(gs_rigid_position(a->sc.spheres[i]), gs_rigid_position(b->sc.spheres[i]));
        if (d > worst) worst = d;
    }
    return worst;
}

/* The largest simulation-time difference between the copies of an object. */
static double time_gap(const host *a, const host *b) {
    double g = fabs(gs_agent_time(a->sc.cloth) - gs_agent_time(b->sc.cloth));
    int i;
    for (i = 0; i < a->sc.sphere_count; ++i) {
        double d = fabs(gs_agent_time(a->sc.spheres[i]) - gs_agent_time(b->sc.spheres[i]));
        if (d > g) g = d;
    }
    return g;
}

/* Host 1's probe: on its path while pushing, otherwise parked above the
   point where it last was (or will start). */
static void drive_probe(host *h, const timeline *tl, double t) {
    const gs_quat id = {0.0, 0.0, 0.0, 1.0};
    int pushing = (t >= tl->push0 && t < tl->push1) || (t >= tl->out0 && t < tl->out_push1);
    double where = t;
    gs_vec3 p;
    if (!pushing) {
        if (t < tl->push0) where = tl->push0;
        else if (t < tl->out0) where = tl->push1;
        else where = tl->out_push1;
    }
    p = gs_scene_probe_path(0, where);
    if (!pushing) p.y = PARK_HEIGHT;
    gs_probe_set_target(h->sc.probes[0], p, id);
}

static double quantile_of(const double *v, int n, double q) {
    double *t;
    double r;
    if (n <= 0) return NAN;
    t = (double *)malloc((size_t)n * sizeof *t);
    if (!t) return NAN;
    memcpy(t, v, (size_t)n * sizeof *t);
    r = bu_quantile(t, n, q);
    free(t);
    return r;
}

/* From some moment to the end every sample is under `thr`, for at least
   the last second: that moment (s since the first sample), or NAN. */
static double settles_under(const double *t, const double *v, int n, double thr) {
    int i, last_bad = -1;
    for (i = 0; i < n; ++i)
        if (!(v[i] < thr)) last_bad = i;
    if (n == 0 || last_bad == n - 1 || t[n - 1] - t[last_bad + 1] < 1.0) return NAN;
    return last_bad < 0 ? 0.0 : t[last_bad + 1];
}

/* Each host runs the scene alone for SETTLE seconds (host 1 `offset`
   longer: it started earlier, as peers of a real session do), then both
   join the simnet and advance on its clock in frames; the timeline counts
   from that moment. Samples are taken after every frame. */
static void run_session(const session_cfg *c, session_result *r) {
    static double gaps[MAX_SAMPLES], push_div[MAX_SAMPLES], after_div[MAX_SAMPLES];
    static double rec_t[MAX_SAMPLES], rec_div[MAX_SAMPLES];
    gs_simnet *sim = NULL;
    gs_simnet_desc simd;
    host h[HOSTS];
    gs_link_desc link = c->prof.link;
    const timeline *tl = &c->tl;
    double quiet_end = tl->out1 > tl->out0 ? tl->out0 : tl->end;
    double t0 = bu_now(), err = 0.0, a_start[HOSTS], pace_from = tl->push0;
    int ng = 0, np = 0, na = 0, nr = 0, k, frames, i, started = 0;
    memset(r, 0, sizeof *r);
    memset(h, 0, sizeof h);
    memset(&simd, 0, sizeof simd);
    simd.seed = 1;
    r->gap_start = NAN;
    if (gs_simnet_create(&simd, &sim) != GS_OK) return;
    for (k = 0; k < HOSTS; ++k) {
        gs_world_desc wd = gs_world_desc_default();
        gs_scene_desc sd = gs_scene_desc_default();
        wd.host_id = (uint32_t)k + 1;
        sd.probe_count = HOSTS;
        if (c->no_spheres) sd.sphere_count = GS_NONE;
        if (gs_world_create(&wd, &h[k].w) != GS_OK ||
            gs_scene_create(h[k].w, &sd, &h[k].sc) != GS_OK || !attach(&h[k], c)) {
            fprintf(stderr, "tradeoff: session setup: %s\n", h[k].w ? gs_world_error(h[k].w) : "");
            goto done;
        }
    }
    /* each host alone first, so the spheres rest on the cloth when they
       connect; host 1 started earlier */
    gs_world_advance(h[0].w, SETTLE + tl->offset, NULL);
    gs_world_advance(h[1].w, SETTLE, NULL);
    for (k = 0; k < HOSTS; ++k) {
        gs_net *net;
        if (test_join(sim, h[k].w, NULL, &net) != GS_OK) goto done;
    }
    if (tl->out1 > tl->out0) {
        link.outage_start[0] = tl->out0;
        link.outage_end[0] = tl->out1;
    }
    gs_simnet_link(sim, 1, 2, &link);
    gs_simnet_link(sim, 2, 1, &link);
    frames = (int)(tl->end / FRAME + 0.5);
    for (k = 1; k <= frames; ++k) {
        double now, d;
        drive_probe(&h[0], tl, gs_simnet_time(sim));
        gs_simnet_run(sim, FRAME, FRAME); /* a failed agent step shows in the figures */
        now = gs_simnet_time(sim);
        d = divergence(&h[0], &h[1]);
        if (k == 1) r->gap_start = time_gap(&h[0], &h[1]);
        if (!started && now >= pace_from) {
            for (i = 0; i < HOSTS; ++i) a_start[i] = gs_agent_time(h[i].sc.cloth);
            pace_from = now;
            started = 1;
        }
        if (started)
            for (i = 0; i < HOSTS; ++i) {
                /* how far each agent is off its own host's clock since
                   pace_from (a host's clock runs from where it started) */
                int n = gs_world_agent_count(h[i].w), a;
                double base = a_start[i] + (now - pace_from);
                for (a = 0; a < n; ++a) {
                    double e = fabs(gs_agent_time(gs_world_agent(h[i].w, a)) - base);
                    if (e > err) err = e;
                }
            }
        if (now >= tl->push0 && !(now > tl->out0 && now <= tl->out1) && ng < MAX_SAMPLES)
            gaps[ng++] = time_gap(&h[0], &h[1]);
        if (now > tl->push0 && now <= tl->push1 && np < MAX_SAMPLES) push_div[np++] = d;
        if (now > quiet_end - 1.0 && now <= quiet_end && na < MAX_SAMPLES) after_div[na++] = d;
        if (tl->out1 > tl->out0 && now > tl->out1 && nr < MAX_SAMPLES) {
            rec_t[nr] = now - tl->out1;
            rec_div[nr++] = d;
        }
        r->div_end = d;
    }
    r->gap_med = quantile_of(gaps, ng, 0.5);
    r->gap_p99 = quantile_of(gaps, ng, 0.99);
    r->gap_max = quantile_of(gaps, ng, 1.0);
    for (i = 0; i < ng; ++i) {
        r->frac_under_20ms += gaps[i] < 0.020;
        r->frac_under_40ms += gaps[i] < 0.040;
    }
    if (ng) { r->frac_under_20ms /= ng; r->frac_under_40ms /= ng; }
    r->div_push_med = quantile_of(push_div, np, 0.5);
    r->div_push_p99 = quantile_of(push_div, np, 0.99);
    r->div_after_med = quantile_of(after_div, na, 0.5);
    r->converge_s = settles_under(rec_t, rec_div, nr, 0.01);
    r->rebaseline_s = settles_under(rec_t, rec_div, nr, fmax(1e-3, 2.0 * r->div_after_med));
    {
        gs_peer_stats ps;
        double bytes = 0.0;
        for (i = 0; i < HOSTS; ++i)
            if (gs_net_peer_stats(gs_world_net(h[i].w), (uint32_t)(HOSTS - i), &ps) == GS_OK)
                bytes += (double)ps.bytes_sent;
        r->bytes_per_s = bytes / HOSTS / tl->end;
    }
    r->pace_min = 1e300;
    r->pace_max = -1e300;
    for (i = 0; i < HOSTS && started; ++i) {
        int n = gs_world_agent_count(h[i].w), a;
        double span = gs_simnet_time(sim) - pace_from;
        for (a = 0; a < n; ++a) {
            double pace = (gs_agent_time(gs_world_agent(h[i].w, a)) - a_start[i]) / span;
            if (pace < r->pace_min) r->pace_min = pace;
            if (pace > r->pace_max) r->pace_max = pace;
        }
    }
    r->max_clock_error = err;
    r->kept_pace = r->pace_min > 0.99 && r->pace_max < 1.01 && err < 0.1;
    r->ok = started;
done:
    for (k = 0; k < HOSTS; ++k)
        if (h[k].w) gs_world_destroy(h[k].w);
    gs_simnet_destroy(sim);
    r->wall_s = bu_now() - t0;
}

/* ---- part 2: encoding ---- */

typedef struct enc_row {
    int profile, no_spheres;
    gs_encoding enc;
    session_result r;
} enc_row;

/* ---- part 3: rules ---- */

typedef struct rule_row {
    int profile, rule, catchup;
    double offset; /* s, host 1's head start */
    session_result r;
} rule_row;

/* Runs one session of the weights grid and prints its line. */
static void run_row(rule_row *rr, const net_profile *prof, int pi, int ri, int ci,
                    timeline tl, double offset) {
    session_cfg c;
    char conv[32], reb[32];
    c.prof = *prof;
    c.rule = &RULES[ri];
    c.catchup = &CATCHUPS[ci];
    c.encoding = GS_ENCODING_F64;
    c.tl = tl;
    c.tl.offset = offset;
    c.no_spheres = 0;
    rr->profile = pi;
    rr->rule = ri;
    rr->catchup = ci;
    rr->offset = offset;
    run_session(&c, &rr->r);
    if (isnan(rr->r.converge_s)) snprintf(conv, sizeof conv, "never");
    else snprintf(conv, sizeof conv, "%.2f s", rr->r.converge_s);
    if (isnan(rr->r.rebaseline_s)) snprintf(reb, sizeof reb, "never");
    else snprintf(reb, sizeof reb, "%.2f s", rr->r.rebaseline_s);
    fprintf(stderr, "%-4s %-14s %-9s %6.1fms %6.1fms %5.0f%% %10.2em %10.2em %10.2em "
                    "%9s %9s %6.3f %5s%s%s\n",
            prof->name, RULES[ri].name, CATCHUPS[ci].name, 1e3 * rr->r.gap_med,
            1e3 * rr->r.gap_p99, 100 * rr->r.frac_under_20ms, rr->r.div_push_med,
            rr->r.div_push_p99, rr->r.div_after_med, conv, reb, rr->r.pace_min,
            rr->r.kept_pace ? "yes" : "NO", rr->r.ok ? "" : " (setup failed)",
            offset == START_OFFSET ? "" : "  (control: no head start)");
}

static void json_session(bu_json *j, const session_result *r) {
    bu_json_num(j, "gap_median_s", r->gap_med);
    bu_json_num(j, "gap_p99_s", r->gap_p99);
    bu_json_num(j, "gap_max_s", r->gap_max);
    bu_json_num(j, "gap_fraction_under_20ms", r->frac_under_20ms);
    bu_json_num(j, "gap_fraction_under_40ms", r->frac_under_40ms);
    bu_json_num(j, "divergence_pushing_median_m", r->div_push_med);
    bu_json_num(j, "divergence_pushing_p99_m", r->div_push_p99);
    bu_json_num(j, "divergence_after_stop_median_m", r->div_after_med);
    bu_json_num(j, "divergence_end_m", r->div_end);
    bu_json_num(j, "gap_at_start_s", r->gap_start);
    if (isnan(r->converge_s)) bu_json_null(j, "converge_within_1cm_after_outage_s");
    else bu_json_num(j, "converge_within_1cm_after_outage_s", r->converge_s);
    if (isnan(r->rebaseline_s)) bu_json_null(j, "back_to_pre_outage_level_s");
    else bu_json_num(j, "back_to_pre_outage_level_s", r->rebaseline_s);
    bu_json_num(j, "bytes_per_s_per_host", r->bytes_per_s);
    bu_json_num(j, "pace_min", r->pace_min);
    bu_json_num(j, "pace_max", r->pace_max);
    bu_json_num(j, "max_clock_error_s", r->max_clock_error);
    bu_json_bool(j, "kept_pace", r->kept_pace);
    bu_json_num(j, "compute_wall_s", r->wall_s);
}

static const char *enc_name(gs_encoding e) { return e == GS_ENCODING_F32 ? "f32" : "f64"; }

int main(int argc, char **argv) {
    bu_args args;
    static part1 p1;
    enc_row enc[16];
    rule_row rows[NPROFILES * NRULES * NCATCHUP + NPROFILES];
    int nenc = 0, nrows = 0, pa = bu_parse_args(argc, argv, "tradeoff", &args);
    int pi, ri, ci, ki, ii, a, e;
    timeline tl_rules, tl_enc;
    net_profile profs[NPROFILES];
    double t_start = bu_now();
    bu_json *j;
    if (pa) return pa > 0 ? 0 : 2;
    for (pi = 0; pi < NPROFILES; ++pi) profs[pi] = make_profile(pi);

    /* ---- part 1 ---- */
    part1_run(&p1, args.quick);
    part1_print(&p1);
    fprintf(stderr, "(part 1 took %.1f s)\n", bu_now() - t_start);

    /* ---- part 2 ---- */
    tl_enc.offset = START_OFFSET;
    if (args.quick) {
        tl_enc.push0 = 0.5; tl_enc.push1 = 2.0; tl_enc.end = 3.0;
    } else {
        tl_enc.push0 = 2.0; tl_enc.push1 = 6.0; tl_enc.end = 8.0;
    }
    tl_enc.out0 = tl_enc.out1 = tl_enc.out_push1 = tl_enc.end + 1.0; /* no outage */
    fprintf(stderr, "\n== 2. wire encoding on gs_simnet: the paper's scene, %d hosts, rule exp rate "
                    "1 (the default), host 1's probe pushes %.0f..%.0f s\n",
            HOSTS, tl_enc.push0, tl_enc.push1);
    fprintf(stderr, "(spheres: their contacts are chaotic, so the same run with the cloth and "
                    "probes alone isolates what the encoding itself costs)\n");
    fprintf(stderr, "%-5s %-8s %-4s %12s %14s %14s %14s\n", "net", "spheres", "enc", "bytes/s/host",
            "div push med", "div push p99", "div after med");
    for (pi = 0; pi < (args.quick ? 1 : 2); ++pi)
        for (e = 0; e < 4; ++e) {
            session_cfg c;
            enc_row *er = &enc[nenc++];
            c.no_spheres = e >= 2;
            er->no_spheres = c.no_spheres;
            c.prof = profs[pi];
            c.rule = &RULES[1];
            c.catchup = &CATCHUPS[0];
            c.encoding = e & 1 ? GS_ENCODING_F32 : GS_ENCODING_F64;
            c.tl = tl_enc;
            er->profile = pi;
            er->enc = c.encoding;
            run_session(&c, &er->r);
            fprintf(stderr, "%-5s %-8s %-4s %12.0f %13.2em %13.2em %13.2em\n", profs[pi].name,
                    c.no_spheres ? "none" : "3", enc_name(c.encoding), er->r.bytes_per_s,
                    er->r.div_push_med, er->r.div_push_p99, er->r.div_after_med);
        }

    /* ---- part 3 ---- */
    tl_rules.offset = START_OFFSET;
    if (args.quick) {
        tl_rules.push0 = 0.5; tl_rules.push1 = 1.5;
        tl_rules.out0 = 2.0; tl_rules.out1 = 7.0; tl_rules.out_push1 = 3.0;
        tl_rules.end = 8.5;
    } else {
        tl_rules.push0 = 2.0; tl_rules.push1 = 6.0;
        tl_rules.out0 = 8.0; tl_rules.out1 = 13.0; tl_rules.out_push1 = 10.0;
        tl_rules.end = 20.0;
    }
    fprintf(stderr, "\n== 3. weight rules x catch-up x networks on gs_simnet: the paper's scene, %d "
                    "hosts, frame %g ms; probe pushes %.0f..%.0f s, outage %.0f..%.0f s (probe "
                    "pushes %.0f..%.0f s in it), end %.0f s\n",
            HOSTS, FRAME * 1e3, tl_rules.push0, tl_rules.push1, tl_rules.out0, tl_rules.out1,
            tl_rules.out0, tl_rules.out_push1, tl_rules.end);
    fprintf(stderr, "(gap from %.0f s on, outside the outage; host 1 starts %.0f ms before host "
                    "2; converge: after the outage, within 1 cm for good / back under 2x the "
                    "pre-outage level for good)\n", tl_rules.push0, 1e3 * START_OFFSET);
    fprintf(stderr, "%-4s %-14s %-9s %8s %8s %6s %11s %11s %11s %9s %9s %6s %5s\n", "net",
            "rule", "catch-up", "gap med", "gap p99", "<20ms", "div push", "div p99",
            "div after", "to 1 cm", "to level", "pace", "kept");
    for (pi = 0; pi < NPROFILES; ++pi)
        for (ri = 0; ri < NRULES; ++ri)
            for (ci = 0; ci < NCATCHUP; ++ci)
                if (!args.quick || quick_pick(pi, ri, ci))
                    run_row(&rows[nrows++], &profs[pi], pi, ri, ci, tl_rules, START_OFFSET);
    /* the control: the default rule when both hosts start together */
    for (pi = 0; pi < NPROFILES && !args.quick; ++pi)
        run_row(&rows[nrows++], &profs[pi], pi, 1, 0, tl_rules, 0.0);
    fprintf(stderr, "\nthe paper: gap under 40 ms, mostly under 20 ms, on a 100 Mb/s LAN. "
                    "ghostsim, per profile (best and worst rule by p99 gap):\n");
    for (pi = 0; pi < NPROFILES; ++pi) {
        int best = -1, worst = -1, i;
        for (i = 0; i < nrows; ++i) {
            if (rows[i].profile != pi || rows[i].offset != START_OFFSET) continue;
            if (best < 0 || rows[i].r.gap_p99 < rows[best].r.gap_p99) best = i;
            if (worst < 0 || rows[i].r.gap_p99 > rows[worst].r.gap_p99) worst = i;
        }
        if (best < 0) continue;
        fprintf(stderr, "  %-4s (%s): best %s/%s p99 %.1f ms (%.0f%% under 20 ms); worst %s/%s "
                        "p99 %.1f ms (%.0f%% under 20 ms)\n",
                profs[pi].name, profs[pi].text, RULES[rows[best].rule].name,
                CATCHUPS[rows[best].catchup].name, 1e3 * rows[best].r.gap_p99,
                100 * rows[best].r.frac_under_20ms, RULES[rows[worst].rule].name,
                CATCHUPS[rows[worst].catchup].name, 1e3 * rows[worst].r.gap_p99,
                100 * rows[worst].r.frac_under_20ms);
    }

    /* ---- JSON ---- */
    j = bu_json_open(args.out);
    if (!j) return 1;
    bu_json_obj_begin(j, NULL);
    bu_json_header(j, "tradeoff", args.quick);
    bu_json_str(j, "method",
                "1: a 10x10 cloth (1 kg, corners pinned, released flat) per integrator x dt x "
                "stretch stiffness (shear k/10, bend k/100), GS_STABILITY_UNCHECKED; error = RMS "
                "particle distance at T from RK4 at dt_ref (its own error estimated by "
                "Richardson from 2 dt_ref); ns per step = median wall time per step over "
                "repeats; cost = ns per step / dt. Largest stable dt: bisection in log dt over "
                "[1e-6, 0.1] s; stable = survives stab_steps steps from a start perturbed by "
                "1e-4 m with no failed step and no particle above 100 m/s. Theory: omega = "
                "sqrt(k_stretch / m_particle) (the brief's rule, exact only for one spring) and "
                "the library's Gershgorin bound gs_mesh_stable_dt; one undamped spring checks the "
                "exact theory. 2 and 3: two worlds running the paper's scene (gs_scene_create, "
                "cloth + spheres ghosted with the rule under test, probes with owner authority), "
                "each host first runs the scene alone for 2 s (host 1 0.1 s longer: it started "
                "earlier) so the spheres rest on the cloth, then both join gs_simnet, links both "
                "ways set to the profile, seed 1, frames of 5 ms; times below count from then; "
                "host 1 drives probe 0 along gs_scene_probe_path while pushing and parks it 0.4 m "
                "up otherwise. Gap = largest |t_host1 - t_host2| over the shared objects, sampled "
                "every frame from the start of the push on, outside the outage (the 0.1 s start "
                "offset gives the time blend a gap to close). "
                "Divergence = largest over the shared objects of "
                "the RMS distance between the two hosts' copies (cloth particles, sphere "
                "centres), measured directly. Converge = seconds after the outage from which the "
                "divergence stays under 1 cm to the end, for at least the last second (null if "
                "never); back to level = the "
                "same under max(1 mm, 2 x its median in the last second before the outage). "
                "Pace = agent time advanced / simulated wall time from the start of the push to "
                "the end, min and max over every agent of both hosts; kept = within 1% and no "
                "agent ever more than 0.1 s off its host's clock.");
    bu_json_arr_begin(j, "results");
    for (a = 0; a < p1.npts; ++a) {
        const point *pt = &p1.pts[a];
        bu_json_obj_begin(j, NULL);
        bu_json_str(j, "part", "integrators");
        bu_json_str(j, "integrator", INTEGS[pt->integ].name);
        bu_json_num(j, "stiffness_n_per_m", p1.cfg.k[pt->ki]);
        bu_json_num(j, "dt_s", pt->dt);
        bu_json_bool(j, "stable", pt->stable);
        bu_json_num(j, "error_m", pt->error);
        bu_json_num(j, "ns_per_step", pt->ns_per_step);
        bu_json_num(j, "us_per_simulated_s", pt->us_per_sim_s);
        bu_json_obj_end(j);
    }
    for (ki = 0; ki < p1.cfg.nk; ++ki)
        for (ii = 0; ii < NINTEG; ++ii) {
            const stab *s = &p1.cloth_stab[ki][ii];
            bu_json_obj_begin(j, NULL);
            bu_json_str(j, "part", "stability");
            bu_json_str(j, "system", "cloth");
            bu_json_str(j, "integrator", INTEGS[ii].name);
            bu_json_num(j, "stiffness_n_per_m", p1.cfg.k[ki]);
            if (s->never) bu_json_num(j, "dt_max_s", 0.0);
            else bu_json_num(j, "dt_max_s", s->dt_max);
            bu_json_bool(j, "stable_at_largest_tried", s->capped);
            bu_json_num(j, "omega_spring_rad_s", p1.omega[ki]);
            bu_json_num(j, "omega_dt_max", p1.omega[ki] * s->dt_max);
            bu_json_num(j, "library_bound_s", p1.bound[ki]);
            bu_json_num(j, "measured_over_library_bound", s->dt_max / p1.bound[ki]);
            bu_json_obj_end(j);
        }
    for (ii = 0; ii < NINTEG; ++ii) {
        const stab *s = &p1.spring_stab[ii];
        bu_json_obj_begin(j, NULL);
        bu_json_str(j, "part", "stability");
        bu_json_str(j, "system", "one spring, undamped");
        bu_json_str(j, "integrator", INTEGS[ii].name);
        bu_json_num(j, "dt_max_s", s->never ? 0.0 : s->dt_max);
        bu_json_bool(j, "stable_at_largest_tried", s->capped);
        bu_json_num(j, "omega_rad_s", p1.spring_omega);
        bu_json_num(j, "omega_dt_max", p1.spring_omega * (s->never ? 0.0 : s->dt_max));
        bu_json_obj_end(j);
    }
    for (ki = 0; ki < p1.cfg.nk; ++ki) {
        int idx[MAX_K * NINTEG * MAX_DT], n = pareto(&p1, ki, idx);
        for (a = 0; a < n; ++a) {
            const point *pt = &p1.pts[idx[a]];
            bu_json_obj_begin(j, NULL);
            bu_json_str(j, "part", "pareto");
            bu_json_num(j, "stiffness_n_per_m", p1.cfg.k[ki]);
            bu_json_str(j, "integrator", INTEGS[pt->integ].name);
            bu_json_num(j, "dt_s", pt->dt);
            bu_json_num(j, "error_m", pt->error);
            bu_json_num(j, "us_per_simulated_s", pt->us_per_sim_s);
            bu_json_obj_end(j);
        }
        for (a = 0; a < NACC; ++a) {
            int b = fastest_for(&p1, ki, ACCURACIES[a]);
            bu_json_obj_begin(j, NULL);
            bu_json_str(j, "part", "fastest_for_accuracy");
            bu_json_num(j, "stiffness_n_per_m", p1.cfg.k[ki]);
            bu_json_num(j, "max_error_m", ACCURACIES[a]);
            if (b < 0) {
                bu_json_null(j, "integrator");
            } else {
                bu_json_str(j, "integrator", INTEGS[p1.pts[b].integ].name);
                bu_json_num(j, "dt_s", p1.pts[b].dt);
                bu_json_num(j, "error_m", p1.pts[b].error);
                bu_json_num(j, "us_per_simulated_s", p1.pts[b].us_per_sim_s);
            }
            bu_json_obj_end(j);
        }
    }
    for (a = 0; a < nenc; ++a) {
        bu_json_obj_begin(j, NULL);
        bu_json_str(j, "part", "encoding");
        bu_json_str(j, "profile", profs[enc[a].profile].name);
        bu_json_str(j, "encoding", enc_name(enc[a].enc));
        bu_json_bool(j, "spheres", !enc[a].no_spheres);
        json_session(j, &enc[a].r);
        bu_json_obj_end(j);
    }
    for (a = 0; a < nrows; ++a) {
        bu_json_obj_begin(j, NULL);
        bu_json_str(j, "part", "weights");
        bu_json_str(j, "profile", profs[rows[a].profile].name);
        bu_json_str(j, "profile_link", profs[rows[a].profile].text);
        bu_json_str(j, "rule", RULES[rows[a].rule].name);
        bu_json_str(j, "catchup", CATCHUPS[rows[a].catchup].name);
        bu_json_num(j, "start_offset_s", rows[a].offset);
        json_session(j, &rows[a].r);
        bu_json_obj_end(j);
    }
    bu_json_arr_end(j);

    bu_json_obj_begin(j, "summary");
    {
        char key[128];
        for (ki = 0; ki < p1.cfg.nk; ++ki) {
            const stab *s = &p1.cloth_stab[ki][0];
            snprintf(key, sizeof key, "k%g_symplectic_dt_max_s", p1.cfg.k[ki]);
            bu_json_num(j, key, s->dt_max);
            snprintf(key, sizeof key, "k%g_symplectic_omega_dt_max", p1.cfg.k[ki]);
            bu_json_num(j, key, p1.omega[ki] * s->dt_max);
            snprintf(key, sizeof key, "k%g_symplectic_measured_over_library_bound", p1.cfg.k[ki]);
            bu_json_num(j, key, s->dt_max / p1.bound[ki]);
            for (a = 0; a < NACC; ++a) {
                int b = fastest_for(&p1, ki, ACCURACIES[a]);
                snprintf(key, sizeof key, "k%g_fastest_for_%.0e_m", p1.cfg.k[ki], ACCURACIES[a]);
                if (b < 0) bu_json_null(j, key);
                else {
                    char val[96];
                    snprintf(val, sizeof val, "%s at dt %.3g ms", INTEGS[p1.pts[b].integ].name,
                             1e3 * p1.pts[b].dt);
                    bu_json_str(j, key, val);
                }
            }
        }
        bu_json_num(j, "one_spring_symplectic_omega_dt_max",
                    p1.spring_omega * p1.spring_stab[0].dt_max);
        bu_json_num(j, "one_spring_verlet_omega_dt_max", p1.spring_omega * p1.spring_stab[1].dt_max);
        bu_json_num(j, "one_spring_rk4_omega_dt_max", p1.spring_omega * p1.spring_stab[2].dt_max);
        for (a = 0; a + 1 < nenc; a += 2) { /* rows come in pairs: f64, f32 */
            const char *what = enc[a].no_spheres ? "cloth_only" : "scene";
            snprintf(key, sizeof key, "%s_%s_f32_over_f64_bytes", profs[enc[a].profile].name, what);
            bu_json_num(j, key, enc[a + 1].r.bytes_per_s / enc[a].r.bytes_per_s);
            snprintf(key, sizeof key, "%s_%s_divergence_pushing_f64_m", profs[enc[a].profile].name,
                     what);
            bu_json_num(j, key, enc[a].r.div_push_med);
            snprintf(key, sizeof key, "%s_%s_divergence_pushing_f32_m", profs[enc[a].profile].name,
                     what);
            bu_json_num(j, key, enc[a + 1].r.div_push_med);
        }
        for (pi = 0; pi < NPROFILES; ++pi) {
            int i, all_pace = 1, any = 0, best = -1;
            for (i = 0; i < nrows; ++i) {
                if (rows[i].profile != pi) continue;
                if (rows[i].offset != START_OFFSET) {
                    snprintf(key, sizeof key, "%s_control_no_head_start_divergence_pushing_m",
                             profs[pi].name);
                    bu_json_num(j, key, rows[i].r.div_push_med);
                    snprintf(key, sizeof key, "%s_control_no_head_start_divergence_after_m",
                             profs[pi].name);
                    bu_json_num(j, key, rows[i].r.div_after_med);
                    continue;
                }
                any = 1;
                all_pace &= rows[i].r.kept_pace;
                if (best < 0 || rows[i].r.gap_p99 < rows[best].r.gap_p99) best = i;
            }
            if (!any) continue;
            snprintf(key, sizeof key, "%s_every_session_kept_pace", profs[pi].name);
            bu_json_bool(j, key, all_pace);
            snprintf(key, sizeof key, "%s_best_gap_p99_s", profs[pi].name);
            bu_json_num(j, key, rows[best].r.gap_p99);
            snprintf(key, sizeof key, "%s_best_gap_p99_rule", profs[pi].name);
            {
                char val[64];
                snprintf(val, sizeof val, "%s/%s", RULES[rows[best].rule].name,
                         CATCHUPS[rows[best].catchup].name);
                bu_json_str(j, key, val);
            }
            snprintf(key, sizeof key, "%s_paper_gap_claim_met_by_best", profs[pi].name);
            bu_json_bool(j, key, rows[best].r.gap_max < 0.040 && rows[best].r.frac_under_20ms > 0.5);
        }
        bu_json_str(j, "paper_gap_claim", "gap under 40 ms, mostly under 20 ms, on a 100 Mb/s LAN");
    }
    bu_json_obj_end(j);

    bu_json_arr_begin(j, "plots");
    if (p1.cfg.nk > 0) {
        /* error against cost at the middle stiffness, one series per integrator */
        int kmid = p1.cfg.nk / 2;
        const char *names[NINTEG];
        const double *xs[NINTEG], *ys[NINTEG];
        double xv[NINTEG][MAX_DT], yv[NINTEG][MAX_DT];
        int ns[NINTEG];
        char title[128];
        for (ii = 0; ii < NINTEG; ++ii) {
            int di;
            ns[ii] = 0;
            names[ii] = INTEGS[ii].name;
            for (di = 0; di < p1.cfg.ndt; ++di) {
                const point *pt = &p1.pts[(kmid * NINTEG + ii) * p1.cfg.ndt + di];
                if (!pt->stable) continue;
                xv[ii][ns[ii]] = pt->us_per_sim_s;
                yv[ii][ns[ii]++] = pt->error;
            }
            xs[ii] = xv[ii];
            ys[ii] = yv[ii];
        }
        snprintf(title, sizeof title, "Cloth %dx%d, k = %g N/m: error against cost", CLOTH_N,
                 CLOTH_N, p1.cfg.k[kmid]);
        bu_json_plot(j, title, "us of CPU per simulated second", "RMS error at T (m)", 1, NINTEG,
                     names, xs, ys, ns);
    }
    {
        /* Pareto fronts, one series per stiffness */
        const char *names[MAX_K];
        const double *xs[MAX_K], *ys[MAX_K];
        double xv[MAX_K][MAX_K * NINTEG * MAX_DT], yv[MAX_K][MAX_K * NINTEG * MAX_DT];
        char nb[MAX_K][32];
        int ns[MAX_K];
        for (ki = 0; ki < p1.cfg.nk; ++ki) {
            int idx[MAX_K * NINTEG * MAX_DT], n = pareto(&p1, ki, idx);
            for (a = 0; a < n; ++a) {
                xv[ki][a] = p1.pts[idx[a]].us_per_sim_s;
                yv[ki][a] = p1.pts[idx[a]].error;
            }
            ns[ki] = n;
            snprintf(nb[ki], sizeof nb[ki], "k = %g N/m", p1.cfg.k[ki]);
            names[ki] = nb[ki];
            xs[ki] = xv[ki];
            ys[ki] = yv[ki];
        }
        bu_json_plot(j, "Pareto front: the fastest setting for each accuracy",
                     "us of CPU per simulated second", "RMS error at T (m)", 1, p1.cfg.nk, names,
                     xs, ys, ns);
    }
    {
        /* gap p99 and divergence while pushing per rule/catch-up, x = profile */
        const char *names[NRULES * NCATCHUP];
        const double *xs[NRULES * NCATCHUP], *ys[NRULES * NCATCHUP], *ds[NRULES * NCATCHUP];
        double xv[NRULES * NCATCHUP][NPROFILES], yv[NRULES * NCATCHUP][NPROFILES],
            dv[NRULES * NCATCHUP][NPROFILES];
        char nb[NRULES * NCATCHUP][48];
        int ns[NRULES * NCATCHUP], nser = 0, i;
        for (ri = 0; ri < NRULES; ++ri)
            for (ci = 0; ci < NCATCHUP; ++ci) {
                int n = 0;
                for (i = 0; i < nrows; ++i)
                    if (rows[i].rule == ri && rows[i].catchup == ci &&
                        rows[i].offset == START_OFFSET) {
                        xv[nser][n] = rows[i].profile;
                        yv[nser][n] = 1e3 * rows[i].r.gap_p99;
                        dv[nser][n++] = rows[i].r.div_push_med;
                    }
                if (!n) continue;
                snprintf(nb[nser], sizeof nb[nser], "%s, catch-up %s", RULES[ri].name,
                         CATCHUPS[ci].name);
                names[nser] = nb[nser];
                xs[nser] = xv[nser];
                ys[nser] = yv[nser];
                ds[nser] = dv[nser];
                ns[nser++] = n;
            }
        bu_json_plot(j, "Simulation-time gap p99 between hosts (0 LAN, 1 WAN, 2 bad)",
                     "network profile", "gap p99 (ms)", 0, nser, names, xs, ys, ns);
        bu_json_plot(j, "Divergence while the probe pushes, median (0 LAN, 1 WAN, 2 bad)",
                     "network profile", "divergence (m)", 1, nser, names, xs, ds, ns);
    }
    {
        const char *names[4] = {"f64, scene", "f32, scene", "f64, no spheres", "f32, no spheres"};
        double xv[4][4], yv[4][4];
        const double *xs[4], *ys[4];
        int ns[4] = {0, 0, 0, 0};
        for (a = 0; a < nenc; ++a) {
            int s = (enc[a].enc == GS_ENCODING_F32) + 2 * enc[a].no_spheres;
            xv[s][ns[s]] = enc[a].r.bytes_per_s;
            yv[s][ns[s]++] = enc[a].r.div_push_med;
        }
        for (a = 0; a < 4; ++a) { xs[a] = xv[a]; ys[a] = yv[a]; }
        bu_json_plot(j, "Wire encoding: bytes against divergence (LAN, WAN)", "bytes/s per host",
                     "divergence while pushing, median (m)", 1, 4, names, xs, ys, ns);
    }
    bu_json_arr_end(j);
    bu_json_obj_end(j);
    if (bu_json_close(j) != 0) return 1;
    fprintf(stderr, "tradeoff: wrote %s (%.1f s)\n", args.out, bu_now() - t_start);
    return 0;
}
