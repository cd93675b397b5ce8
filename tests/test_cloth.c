/* test_cloth.c - spring-mass agents and their integrators, against closed
   forms.

   Most tests use one spring: an anchor pinned at the origin and a free
   particle of m = 1 kg on a spring of rest length 1 m and k = 4 pi^2 N/m,
   so omega = 2 pi rad/s and the period is exactly 1 s. Gravity is off and
   nothing is damped unless a test says so; the particle starts 0.1 m out,
   at rest: u(t) = 0.1 cos(2 pi t). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <string.h>

#include "ghostsim.h"

#define PI 3.14159265358979323846
#define K_UNIT (4.0 * PI * PI) /* N/m: omega = 2 pi for 1 kg */
#define AMP 0.1                /* m, initial stretch */

typedef struct spring_rig {
    gs_world *w;
    gs_agent *a;
} spring_rig;

static spring_rig spring_make(double k, double m, double dt, gs_integrator it,
                              gs_stability st, int gravity) {
    spring_rig r;
    gs_mesh_desc md = gs_mesh_desc_default();
    gs_vec3 pos[2];
    double masses[2];
    gs_spring sp;
    int pin = 0;
    assert_int_equal(gs_world_create(NULL, &r.w), GS_OK);
    if (!gravity) {
        gs_vec3 zero = {0.0, 0.0, 0.0};
        assert_int_equal(gs_world_set_gravity(r.w, zero), GS_OK);
    }
    pos[0].x = pos[0].y = pos[0].z = 0.0;
    pos[1].x = 1.0 + AMP;
    pos[1].y = pos[1].z = 0.0;
    masses[0] = masses[1] = m;
    sp.a = 0;
    sp.b = 1;
    sp.rest_length = 1.0;
    sp.stiffness = k;
    sp.damping = 0.0;
    md.particle_count = 2;
    md.positions = pos;
    md.masses = masses;
    md.spring_count = 1;
    md.springs = &sp;
    md.pin_count = 1;
    md.pins = &pin;
    md.solver.dt = dt;
    md.solver.integrator = it;
    md.solver.stability = st;
    md.solver.max_speed = 1e300; /* the tests watch growth themselves */
    assert_int_equal(gs_mesh_create(r.w, &md, &r.a), GS_OK);
    return r;
}

static double stretch(const spring_rig *r) { /* u = x - rest, m */
    return gs_mesh_positions(r->a)[1].x - 1.0;
}

static double energy(const spring_rig *r) {
    double ke, pe;
    assert_int_equal(gs_mesh_energy(r->a, &ke, &pe), GS_OK);
    return ke + pe;
}

static const gs_integrator all_integrators[5] = {
    GS_INTEGRATOR_EXPLICIT_EULER, GS_INTEGRATOR_SYMPLECTIC_EULER,
    GS_INTEGRATOR_VERLET, GS_INTEGRATOR_RK4, GS_INTEGRATOR_IMPLICIT_EULER};

/* Period from two downward zero crossings, linearly interpolated. */
static double measure_period(spring_rig *r, double dt, int steps) {
    double prev = stretch(r), first = -1.0, second = -1.0;
    int i;
    for (i = 1; i <= steps && second < 0.0; ++i) {
        double u;
        assert_int_equal(gs_agent_step(r->a), GS_OK);
        u = stretch(r);
        if (prev > 0.0 && u <= 0.0) {
            double tc = (i - 1) * dt + dt * prev / (prev - u);
            if (first < 0.0) first = tc;
            else second = tc;
        }
        prev = u;
    }
    assert_true(second > 0.0);
    return second - first;
}

/* Period per integrator at dt = 1 ms (omega dt = 6.3e-3). The discrete
   frequencies are known: symplectic Euler and Verlet turn by
   2 asin(omega dt / 2) per step, a period error of (omega dt)^2 / 24 = 1.6e-6;
   explicit and implicit Euler by atan(omega dt), (omega dt)^2 / 3 = 1.3e-5;
   RK4 by far less. Linear interpolation of the crossing adds under 1e-7 s.
   So 5e-5 relative holds every integrator with a margin of 4 over the worst. */
static void test_period_per_integrator(void **state) {
    int i;
    (void)state;
    for (i = 0; i < 5; ++i) {
        spring_rig r = spring_make(K_UNIT, 1.0, 1e-3, all_integrators[i],
                                   GS_STABILITY_UNCHECKED, 0);
        double T = measure_period(&r, 1e-3, 3000);
        print_message("integrator %d: period %.9f s\n", (int)all_integrators[i], T);
        assert_true(fabs(T - 1.0) < 5e-5);
        gs_world_destroy(r.w);
    }
}

/* Energy after exactly one period (1000 steps of 1 ms), relative to the
   start. Explicit Euler multiplies |z| by sqrt(1 + (omega dt)^2) per step:
   energy by (1 + 3.95e-5)^1000 = 1.0403; implicit Euler divides by the same.
   Symplectic Euler's energy breathes by about omega dt / 2 = 3e-3 within a
   period and returns; Verlet's by (omega dt)^2 / 4 = 1e-5; RK4 loses
   (omega dt)^6 / 72 per step, 1e-15 in all. Bounds: the closed forms within
   1e-3 for the Euler pair, and 3x the breathing for the symplectic ones. */
static void test_amplitude_per_integrator(void **state) {
    static const double want[5] = {1.0403, 1.0, 1.0, 1.0, 1.0 / 1.0403};
    static const double tol[5] = {1e-3, 1e-2, 3e-5, 1e-9, 1e-3};
    int i, s;
    (void)state;
    for (i = 0; i < 5; ++i) {
        spring_rig r = spring_make(K_UNIT, 1.0, 1e-3, all_integrators[i],
                                   GS_STABILITY_UNCHECKED, 0);
        double e0 = energy(&r), ratio;
        for (s = 0; s < 1000; ++s) assert_int_equal(gs_agent_step(r.a), GS_OK);
        ratio = energy(&r) / e0;
        print_message("integrator %d: energy after one period x%.7f\n",
                      (int)all_integrators[i], ratio);
        assert_true(fabs(ratio - want[i]) < tol[i]);
        gs_world_destroy(r.w);
    }
}

/* Phase-space error at t = 1.25 s: the distance between (u, v / omega) and
   the exact (A cos wt, -A sin wt), in metres. Both parts count, because the
   integrators err in different ones: explicit and implicit Euler first in
   amplitude, symplectic Euler first in a velocity offset of h a / 2; at any
   single point one of u or v alone can hide the leading term. */
static double error_at(gs_integrator it, double dt) {
    spring_rig r = spring_make(K_UNIT, 1.0, dt, it, GS_STABILITY_UNCHECKED, 0);
    int n = (int)(1.25 / dt + 0.5), i;
    double omega = 2.0 * PI, du, dv;
    for (i = 0; i < n; ++i) assert_int_equal(gs_agent_step(r.a), GS_OK);
    du = stretch(&r) - AMP * cos(omega * 1.25);
    dv = gs_mesh_velocities(r.a)[1].x / omega + AMP * sin(omega * 1.25);
    gs_world_destroy(r.w);
    return sqrt(du * du + dv * dv);
}

/* Halving dt divides the error by 2^order. The dt pairs (dividing 1.25 s
   evenly) sit in each method's asymptotic range, well above round-off
   (RK4's smallest error is ~1e-6 m). A measured order within 0.3 of the
   theory allows for the next term of the error series at these dt (it
   shifts log2 of the ratio by about omega dt: 0.03 to 0.3 here). */
static void test_order_of_convergence(void **state) {
    static const double dts[5] = {2.5e-3, 2.5e-3, 1e-2, 5e-2, 2.5e-3};
    static const double order[5] = {1.0, 1.0, 2.0, 4.0, 1.0};
    int i;
    (void)state;
    for (i = 0; i < 5; ++i) {
        double e1 = error_at(all_integrators[i], dts[i]);
        double e2 = error_at(all_integrators[i], dts[i] / 2.0);
        double p = log(e1 / e2) / log(2.0);
        print_message("integrator %d: error %.3e -> %.3e m, order %.2f\n",
                      (int)all_integrators[i], e1, e2, p);
        assert_true(fabs(p - order[i]) < 0.3);
    }
}

/* 100 000 steps of 1 ms (100 periods). Symplectic methods keep a modified
   energy exactly, so the true energy only breathes: by omega dt / 2 = 3e-3
   for symplectic Euler (bound 1e-2) and (omega dt)^2 / 4 = 1e-5 for Verlet
   (bound 1e-4), with no drift: after 100 whole periods it is back within
   the same bounds divided by 10. */
static void test_energy_drift_symplectic(void **state) {
    static const gs_integrator its[2] = {GS_INTEGRATOR_SYMPLECTIC_EULER, GS_INTEGRATOR_VERLET};
    static const double bound[2] = {1e-2, 1e-4};
    int i, s;
    (void)state;
    for (i = 0; i < 2; ++i) {
        spring_rig r = spring_make(K_UNIT, 1.0, 1e-3, its[i], GS_STABILITY_UNCHECKED, 0);
        double e0 = energy(&r), worst = 0.0;
        for (s = 1; s <= 100000; ++s) {
            double dev;
            assert_int_equal(gs_agent_step(r.a), GS_OK);
            dev = fabs(energy(&r) / e0 - 1.0);
            if (dev > worst) worst = dev;
        }
        print_message("integrator %d: worst energy deviation %.2e, at the end %.2e\n",
                      (int)its[i], worst, fabs(energy(&r) / e0 - 1.0));
        assert_true(worst < bound[i]);
        assert_true(fabs(energy(&r) / e0 - 1.0) < bound[i] / 10.0);
        gs_world_destroy(r.w);
    }
}

/* Explicit Euler's energy grows every period and implicit Euler's falls,
   even at a tiny dt (1e-4 s): forward Euler has no stable dt on an undamped
   spring, which is what the test expects. */
static void test_euler_growth_and_decay(void **state) {
    spring_rig ex = spring_make(K_UNIT, 1.0, 1e-4, GS_INTEGRATOR_EXPLICIT_EULER,
                                GS_STABILITY_UNCHECKED, 0);
    spring_rig im = spring_make(K_UNIT, 1.0, 1e-4, GS_INTEGRATOR_IMPLICIT_EULER,
                                GS_STABILITY_UNCHECKED, 0);
    double last_ex = energy(&ex), last_im = energy(&im);
    int p, s;
    (void)state;
    for (p = 0; p < 10; ++p) {
        for (s = 0; s < 10000; ++s) {
            assert_int_equal(gs_agent_step(ex.a), GS_OK);
            assert_int_equal(gs_agent_step(im.a), GS_OK);
        }
        assert_true(energy(&ex) > last_ex);
        assert_true(energy(&im) < last_im);
        last_ex = energy(&ex);
        last_im = energy(&im);
    }
    gs_world_destroy(ex.w);
    gs_world_destroy(im.w);
}

static int all_finite(const double *v, size_t n) {
    size_t i;
    for (i = 0; i < n; ++i)
        if (!isfinite(v[i])) return 0;
    return 1;
}

/* One cell of the grid: 200 steps; every step is either GS_OK with a finite
   state, or GS_ERR_UNSTABLE with the state exactly as before it. Implicit
   Euler must never fail and stays within the swing an undamped spring could
   have: |u| <= AMP + 2 m g / k about the anchor's rest length, plus the
   particle's free fall m g / k already counted (1e-9 m of round-off). */
static void grid_cell(double k, double m, double dt, gs_integrator it, gs_stability st) {
    spring_rig r = spring_make(k, m, dt, it, st, 1);
    double before[13], after[13];
    int s;
    for (s = 0; s < 200; ++s) {
        gs_result res;
        assert_int_equal(gs_agent_get_state(r.a, before, 13), GS_OK);
        res = gs_agent_step(r.a);
        assert_int_equal(gs_agent_get_state(r.a, after, 13), GS_OK);
        assert_true(all_finite(after, 13));
        if (res == GS_ERR_UNSTABLE) {
            assert_memory_equal(before, after, sizeof before);
            assert_true(it != GS_INTEGRATOR_IMPLICIT_EULER);
            break;
        }
        assert_int_equal(res, GS_OK);
    }
    if (it == GS_INTEGRATOR_IMPLICIT_EULER) {
        const gs_vec3 *x = gs_mesh_positions(r.a);
        double reach = sqrt(x[1].x * x[1].x + x[1].y * x[1].y + x[1].z * x[1].z);
        assert_true(fabs(reach - 1.0) <= AMP + 2.0 * m * 9.81 / k + 1e-9);
    }
    gs_world_destroy(r.w);
}

/* Stiffness 1 to 1e8 N/m, particle mass 1e-4 to 1e3 kg, dt 1e-5 to 0.1 s:
   omega dt from 3e-7 to 1e5. */
static void test_stability_grid(void **state) {
    static const double ks[5] = {1.0, 1e2, 1e4, 1e6, 1e8};
    static const double ms[4] = {1e-4, 1e-2, 1.0, 1e3};
    static const double dts[3] = {1e-5, 1e-3, 1e-1};
    int a, b, c, i;
    (void)state;
    for (a = 0; a < 5; ++a)
        for (b = 0; b < 4; ++b)
            for (c = 0; c < 3; ++c) {
                grid_cell(ks[a], ms[b], dts[c], GS_INTEGRATOR_IMPLICIT_EULER, GS_STABILITY_SUBSTEP);
                for (i = 0; i < 4; ++i) {
                    grid_cell(ks[a], ms[b], dts[c], all_integrators[i], GS_STABILITY_SUBSTEP);
                    grid_cell(ks[a], ms[b], dts[c], all_integrators[i], GS_STABILITY_REFUSE);
                }
            }
}

/* With no check at all, a blow-up still never leaves the agent: the guard
   undoes the step that goes non-finite or past max_speed. */
static void test_unchecked_blowup_is_caught(void **state) {
    int i, s;
    (void)state;
    for (i = 0; i < 4; ++i) {
        spring_rig r = spring_make(1e8, 1e-4, 0.1, all_integrators[i], GS_STABILITY_UNCHECKED, 0);
        double before[13], after[13];
        gs_result res = GS_OK;
        for (s = 0; s < 1000 && res == GS_OK; ++s) {
            gs_agent_get_state(r.a, before, 13);
            res = gs_agent_step(r.a);
        }
        gs_agent_get_state(r.a, after, 13);
        assert_int_equal(res, GS_ERR_UNSTABLE);
        assert_true(all_finite(after, 13));
        assert_memory_equal(before, after, sizeof before);
        gs_world_destroy(r.w);
    }
}

static double max_stretch(spring_rig *r, int steps, gs_result *res) {
    double worst = 0.0;
    int s;
    *res = GS_OK;
    for (s = 0; s < steps && *res == GS_OK; ++s) {
        *res = gs_agent_step(r->a);
        if (fabs(stretch(r)) > worst) worst = fabs(stretch(r));
    }
    return worst;
}

/* Symplectic Euler on one spring: bounded at omega dt = 1.9 (its swing is
   at most 1/sqrt(1 - (omega dt / 2)^2) = 3.2 times the start, bound 5x),
   growing at 2.1 (|lambda| = 1.37 per step: past 10x within a few dozen
   steps, or caught by the guard). gs_mesh_stable_dt gives 2 / omega exactly
   here: the Gershgorin bound is exact for one spring to a pinned anchor. */
static void test_symplectic_limit_near_two(void **state) {
    double omega = 2.0 * PI;
    spring_rig lo = spring_make(K_UNIT, 1.0, 1.9 / omega, GS_INTEGRATOR_SYMPLECTIC_EULER,
                                GS_STABILITY_UNCHECKED, 0);
    spring_rig hi = spring_make(K_UNIT, 1.0, 2.1 / omega, GS_INTEGRATOR_SYMPLECTIC_EULER,
                                GS_STABILITY_UNCHECKED, 0);
    gs_result r1, r2;
    double s1 = max_stretch(&lo, 2000, &r1), s2 = max_stretch(&hi, 2000, &r2);
    (void)state;
    assert_int_equal(r1, GS_OK);
    assert_true(s1 < 5.0 * AMP);
    assert_true(r2 == GS_ERR_UNSTABLE || s2 > 10.0 * AMP);
    assert_true(fabs(gs_mesh_stable_dt(lo.a) * omega / 2.0 - 1.0) < 1e-9);
    gs_world_destroy(lo.w);
    gs_world_destroy(hi.w);
}

/* dt = 3 / omega is over the bound (2 / omega). Substep mode splits it
   (ceil(3 / (0.9 * 2)) = 2 substeps) and stays bounded; refuse mode says
   GS_ERR_UNSTABLE and leaves state and time alone; so does substep mode
   when the split would need more than max_substeps. */
static void test_substep_or_refuse(void **state) {
    double omega = 2.0 * PI, before[13], after[13];
    spring_rig sub = spring_make(K_UNIT, 1.0, 3.0 / omega, GS_INTEGRATOR_SYMPLECTIC_EULER,
                                 GS_STABILITY_SUBSTEP, 0);
    spring_rig ref = spring_make(K_UNIT, 1.0, 3.0 / omega, GS_INTEGRATOR_SYMPLECTIC_EULER,
                                 GS_STABILITY_REFUSE, 0);
    gs_result r;
    (void)state;
    assert_true(max_stretch(&sub, 200, &r) < 5.0 * AMP);
    assert_int_equal(r, GS_OK);
    assert_true(gs_agent_get_stats(sub.a).substeps >= 2 * gs_agent_get_stats(sub.a).steps);
    gs_agent_get_state(ref.a, before, 13);
    assert_int_equal(gs_agent_step(ref.a), GS_ERR_UNSTABLE);
    gs_agent_get_state(ref.a, after, 13);
    assert_memory_equal(before, after, sizeof before);
    assert_true(strstr(gs_world_error(ref.w), "stable") != NULL);
    gs_world_destroy(sub.w);
    gs_world_destroy(ref.w);
    {
        gs_world *w;
        gs_agent *a;
        gs_mesh_desc d = gs_mesh_desc_default();
        gs_vec3 pos[2] = {{0, 0, 0}, {1.1, 0, 0}};
        gs_spring sp = {0, 1, 1.0, K_UNIT, 0.0};
        int pin = 0;
        assert_int_equal(gs_world_create(NULL, &w), GS_OK);
        d.particle_count = 2;
        d.positions = pos;
        d.mass = 2.0; /* 1 kg each */
        d.spring_count = 1;
        d.springs = &sp;
        d.pin_count = 1;
        d.pins = &pin;
        d.solver.dt = 10.0 / omega; /* needs ceil(10 / 1.8) = 6 substeps */
        d.solver.max_substeps = 2;
        assert_int_equal(gs_mesh_create(w, &d, &a), GS_OK);
        assert_int_equal(gs_agent_step(a), GS_ERR_UNSTABLE);
        assert_true(strstr(gs_world_error(w), "max_substeps") != NULL);
        gs_world_destroy(w);
    }
}

/* The README's worked example: a 16 x 16 cloth of 1 kg with the default
   springs. The inner particle is the worst: 4 structural (1000), 4 shear
   (100), 4 bend (10) N/m, each counted twice; damping 0.02 N s/m on 12
   springs twice, plus 0.1 /s of air. */
static void test_cloth_stable_dt_matches_rule(void **state) {
    gs_world *w;
    gs_agent *c;
    gs_cloth_desc cd = gs_cloth_desc_default();
    double m = 1.0 / 256.0, w2 = 2.0 * 4440.0 / m, g = 2.0 * 12.0 * 0.02 / m + 0.1;
    double want = 4.0 / (g + sqrt(g * g + 4.0 * w2));
    (void)state;
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    cd.nx = cd.ny = 16;
    assert_int_equal(gs_cloth_create(w, &cd, &c), GS_OK);
    assert_true(fabs(gs_mesh_stable_dt(c) / want - 1.0) < 1e-12);
    assert_true(fabs(want - 1.27e-3) < 0.01e-3); /* the README's 1.27 ms */
    gs_world_destroy(w);
}

static double settle_sag(double stiffness, double *kinetic) {
    gs_world *w;
    gs_agent *c;
    gs_cloth_desc cd = gs_cloth_desc_default();
    const gs_vec3 *x;
    int f;
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    cd.nx = cd.ny = 11;
    cd.pin_corners = GS_CORNER_ALL;
    cd.stretch_stiffness = stiffness;
    cd.spring_damping = 0.5;
    cd.air_damping = 1.0;
    cd.solver.integrator = GS_INTEGRATOR_IMPLICIT_EULER;
    cd.solver.dt = 2e-3;
    assert_int_equal(gs_cloth_create(w, &cd, &c), GS_OK);
    for (f = 0; f < 600; ++f) assert_int_equal(gs_world_advance(w, 1.0 / 60.0, NULL), GS_OK);
    assert_int_equal(gs_mesh_energy(c, kinetic, NULL), GS_OK);
    x = gs_mesh_positions(c);
    {
        double sag = -x[5 + 11 * 5].y; /* the centre, below the corners at 0 */
        gs_world_destroy(w);
        return sag;
    }
}

/* A cloth hanging by its corners settles: after 10 s its kinetic energy is
   under 1e-6 J, a millionth of its potential-energy scale m g sag (1 kg,
   ~0.1 m: ~1 J), i.e. it moves at well under a millimetre per second. Its
   sag grows as the stiffness falls. */
static void test_hanging_cloth_settles_and_sags(void **state) {
    double k1, k2, k3;
    double s1 = settle_sag(5000.0, &k1), s2 = settle_sag(500.0, &k2), s3 = settle_sag(50.0, &k3);
    (void)state;
    print_message("sag %.4f / %.4f / %.4f m at 5000 / 500 / 50 N/m; kinetic %.1e J\n",
                  s1, s2, s3, k1);
    assert_true(k1 < 1e-6 && k2 < 1e-6 && k3 < 1e-6);
    assert_true(s1 > 0.0 && s1 < s2 && s2 < s3);
}

static void test_counts_energy_and_pins(void **state) {
    gs_world *w;
    gs_agent *c;
    gs_cloth_desc cd = gs_cloth_desc_default();
    gs_vec3 p = {0.25, 0.5, 0.0}, nan3 = {NAN, 0.0, 0.0};
    int nx = 7, ny = 5;
    double ke = -1.0, pe = -1.0;
    (void)state;
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    cd.nx = nx;
    cd.ny = ny;
    cd.pin_corners = GS_CORNER_00;
    assert_int_equal(gs_cloth_create(w, &cd, &c), GS_OK);
    assert_int_equal(gs_mesh_particle_count(c), nx * ny);
    assert_int_equal(gs_mesh_spring_count(c),
                     (nx - 1) * ny + nx * (ny - 1) + 2 * (nx - 1) * (ny - 1) +
                         (nx - 2) * ny + nx * (ny - 2));
    assert_int_equal(gs_mesh_energy(c, &ke, &pe), GS_OK);
    assert_true(ke == 0.0 && fabs(pe) < 1e-12); /* at rest, flat at y = 0 */
    assert_int_equal(gs_mesh_move_pin(c, 0, p), GS_OK);
    assert_true(gs_mesh_positions(c)[0].x == 0.25 && gs_mesh_positions(c)[0].y == 0.5);
    assert_int_equal(gs_mesh_move_pin(c, 1, p), GS_ERR_INVALID_ARG); /* not pinned */
    assert_int_equal(gs_mesh_move_pin(c, nx * ny, p), GS_ERR_OUT_OF_RANGE);
    assert_int_equal(gs_mesh_move_pin(c, -1, p), GS_ERR_OUT_OF_RANGE);
    assert_int_equal(gs_mesh_move_pin(c, 0, nan3), GS_ERR_NOT_FINITE);
    assert_true(gs_mesh_positions(c)[0].x == 0.25); /* unchanged */
    gs_world_destroy(w);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_period_per_integrator),
        cmocka_unit_test(test_amplitude_per_integrator),
        cmocka_unit_test(test_order_of_convergence),
        cmocka_unit_test(test_energy_drift_symplectic),
        cmocka_unit_test(test_euler_growth_and_decay),
        cmocka_unit_test(test_stability_grid),
        cmocka_unit_test(test_unchecked_blowup_is_caught),
        cmocka_unit_test(test_symplectic_limit_near_two),
        cmocka_unit_test(test_substep_or_refuse),
        cmocka_unit_test(test_cloth_stable_dt_matches_rule),
        cmocka_unit_test(test_hanging_cloth_settles_and_sags),
        cmocka_unit_test(test_counts_energy_and_pins),
    };
    return cmocka_run_group_tests_name("cloth", tests, NULL, NULL);
}
