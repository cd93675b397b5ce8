/* test_cloth.c - spring-mass agents (>>cloth) and their integrators, against
   closed forms.

   Most tests use one spring: an anchor pinned at the origin and a free
   particle of m = 1 kg on a spring of rest length L = 1 m and k = 4 pi^2 N/m,
   so omega = 2 pi rad/s and the period is exactly 1 s. Gravity is off and
   nothing is damped unless a test says so; the particle starts A = 0.1 m out
   along x, at rest: u(t) = A cos(2 pi t), u the stretch.

   On this linear oscillator every integrator is a linear map of
   z = u + i v / omega, so its discrete solution is known in closed form
   (see `turn_per_step` and `gain_per_step`); the tests compare with both the
   continuous solution and the integrator's own. State layout of the rig:
   [t, anchor xyz, particle xyz, anchor v xyz, particle v xyz] (13 doubles). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <string.h>

#include "ghostsim.h"
#include "world_helpers.h"

#define PI 3.14159265358979323846
#define OMEGA (2.0 * PI)       /* rad/s */
#define K_UNIT (4.0 * PI * PI) /* N/m: omega = 2 pi for 1 kg */
#define AMP 0.1                /* m, initial stretch */
#define REST 1.0               /* m, rest length */
#define G 9.81                 /* m/s^2, the default world's |gravity| */
#define NSTATE 13              /* doubles in the rig's state */

/* Asserts cond; on failure prints the values that explain it first. */
#define CHECK(cond, ...)                                                       \
    do {                                                                       \
        if (!(cond)) print_message(__VA_ARGS__);                               \
        assert_true(cond);                                                     \
    } while (0)

typedef struct spring_rig {
    gs_world *w;
    gs_agent *a;
} spring_rig;

/* One spring to a pinned anchor; `solver` is taken as given (zero fields
   are defaults). max_speed is lifted unless the caller set it, because most
   tests watch growth themselves. */
static spring_rig spring_make_solver(double k, double m, int gravity,
                                     gs_solver_desc solver) {
    spring_rig r;
    gs_mesh_desc md = gs_mesh_desc_default();
    gs_vec3 pos[2] = {{0.0, 0.0, 0.0}, {REST + AMP, 0.0, 0.0}};
    double masses[2];
    gs_spring sp;
    int pin = 0;
    gs_result res;
    assert_int_equal(gs_world_create(NULL, &r.w), GS_OK);
    if (!gravity) {
        gs_vec3 zero = {0.0, 0.0, 0.0};
        assert_int_equal(gs_world_set_gravity(r.w, zero), GS_OK);
    }
    masses[0] = masses[1] = m; /* the anchor's mass does not matter: pinned */
    sp.a = 0;
    sp.b = 1;
    sp.rest_length = REST;
    sp.stiffness = k;
    sp.damping = 0.0;
    md.particle_count = 2;
    md.positions = pos;
    md.masses = masses;
    md.spring_count = 1;
    md.springs = &sp;
    md.pin_count = 1;
    md.pins = &pin;
    md.air_damping = 0.0;
    md.solver = solver;
    if (md.solver.max_speed == 0.0) md.solver.max_speed = 1e300;
    res = gs_mesh_create(r.w, &md, &r.a);
    CHECK(res == GS_OK, "gs_mesh_create: %s (%s)\n", gs_result_str(res), gs_world_error(r.w));
    return r;
}

static spring_rig spring_make(double k, double m, double dt, gs_integrator it,
                              gs_stability st, int gravity) {
    gs_solver_desc s;
    memset(&s, 0, sizeof s);
    s.dt = dt;
    s.integrator = it;
    s.stability = st;
    return spring_make_solver(k, m, gravity, s);
}

static double stretch(const spring_rig *r) { /* u = x - rest, m */
    return gs_mesh_positions(r->a)[1].x - REST;
}

/* |z| = sqrt(u^2 + (v / omega)^2): the amplitude, in m (omega = 2 pi). */
static double phase_amplitude(const spring_rig *r) {
    double u = stretch(r), v = gs_mesh_velocities(r->a)[1].x / OMEGA;
    return sqrt(u * u + v * v);
}

static double energy(const spring_rig *r) {
    double ke, pe;
    assert_int_equal(gs_mesh_energy(r->a, &ke, &pe), GS_OK);
    return ke + pe;
}

static void step_ok(spring_rig *r, int steps) {
    int s;
    for (s = 0; s < steps; ++s) {
        gs_result res = gs_agent_step(r->a);
        CHECK(res == GS_OK, "step %d: %s (%s)\n", s, gs_result_str(res), gs_world_error(r->w));
    }
}

static int all_finite(const double *v, size_t n) {
    size_t i;
    for (i = 0; i < n; ++i)
        if (!isfinite(v[i])) return 0;
    return 1;
}

static const gs_integrator all_integrators[5] = {
    GS_INTEGRATOR_EXPLICIT_EULER, GS_INTEGRATOR_SYMPLECTIC_EULER,
    GS_INTEGRATOR_VERLET, GS_INTEGRATOR_RK4, GS_INTEGRATOR_IMPLICIT_EULER};

static const char *name_of(gs_integrator it) {
    switch (it) {
    case GS_INTEGRATOR_EXPLICIT_EULER: return "explicit Euler";
    case GS_INTEGRATOR_SYMPLECTIC_EULER: return "symplectic Euler";
    case GS_INTEGRATOR_VERLET: return "Verlet";
    case GS_INTEGRATOR_RK4: return "RK4";
    case GS_INTEGRATOR_IMPLICIT_EULER: return "implicit Euler";
    default: return "?";
    }
}

/* The angle (rad) by which the integrator turns z per step of x = omega h on
   an undamped oscillator: explicit and implicit Euler multiply z by
   1 -+ i x (to the power -+1), so atan x; symplectic Euler and Verlet have
   trace 2 - x^2, so acos(1 - x^2 / 2) = 2 asin(x / 2); RK4 multiplies by its
   Taylor polynomial R(-i x). */
static double turn_per_step(gs_integrator it, double x) {
    switch (it) {
    case GS_INTEGRATOR_SYMPLECTIC_EULER:
    case GS_INTEGRATOR_VERLET: return 2.0 * asin(x / 2.0);
    case GS_INTEGRATOR_RK4:
        return atan2(x - x * x * x / 6.0, 1.0 - x * x / 2.0 + x * x * x * x / 24.0);
    default: return atan(x);
    }
}

/* |R|: the factor by which |z| changes per step (1 for the symplectic pair,
   whose eigenvalues lie on the unit circle). */
static double gain_per_step(gs_integrator it, double x) {
    double re = 1.0 - x * x / 2.0 + x * x * x * x / 24.0, im = x - x * x * x / 6.0;
    switch (it) {
    case GS_INTEGRATOR_EXPLICIT_EULER: return sqrt(1.0 + x * x);
    case GS_INTEGRATOR_IMPLICIT_EULER: return 1.0 / sqrt(1.0 + x * x);
    case GS_INTEGRATOR_RK4: return sqrt(re * re + im * im);
    default: return 1.0;
    }
}

/* ------------------------------------------------------------------------
   Period and amplitude per integrator at dt = 1 ms (omega dt = 6.3e-3)
   ------------------------------------------------------------------------ */

/* Period from two downward zero crossings of u, linearly interpolated. */
static double measure_period(spring_rig *r, double dt, int steps) {
    double prev = stretch(r), first = -1.0, second = -1.0;
    int i;
    for (i = 1; i <= steps && second < 0.0; ++i) {
        double u;
        step_ok(r, 1);
        u = stretch(r);
        if (prev > 0.0 && u <= 0.0) {
            double tc = (i - 1) * dt + dt * prev / (prev - u);
            if (first < 0.0) first = tc;
            else second = tc;
        }
        prev = u;
    }
    CHECK(second > 0.0, "fewer than two downward crossings in %d steps\n", steps);
    return second - first;
}

/* The zeros of |R|^n cos(n theta + phi) are evenly spaced, so the measured
   period is 2 pi dt / theta: for symplectic Euler and Verlet
   1 - (omega dt)^2 / 24 = 1 - 1.6e-6 s, for explicit and implicit Euler
   1 + (omega dt)^2 / 3 = 1 + 1.3e-5 s, for RK4 1 + (omega dt)^4 / 120.
   Checks: (a) within 1e-7 s of that prediction - linear interpolation of a
   crossing errs by about (dt^2 / 8) |u''| / |u'|, and u'' vanishes at a
   zero of a sinusoid (explicit/implicit Euler's growth rate of 0.02/s
   leaves ~1e-9 s), so 1e-7 s is a wide margin that still tells the
   families apart (their difference is 1.5e-5 s); (b) within twice the
   predicted error of the closed form's 1 s (plus the 1e-7 s). */
static void test_period_per_integrator(void **state) {
    double dt = 1e-3, x = OMEGA * dt;
    int i;
    (void)state;
    for (i = 0; i < 5; ++i) {
        gs_integrator it = all_integrators[i];
        spring_rig r = spring_make(K_UNIT, 1.0, dt, it, GS_STABILITY_UNCHECKED, 0);
        double T = measure_period(&r, dt, 3000);
        double want = 2.0 * PI * dt / turn_per_step(it, x);
        print_message("%-16s period %.9f s, predicted %.9f s\n", name_of(it), T, want);
        CHECK(fabs(T - want) < 1e-7, "%s: period %.9g s, its discrete closed form %.9g s\n",
              name_of(it), T, want);
        CHECK(fabs(T - 1.0) < 2.0 * fabs(want - 1.0) + 1e-7,
              "%s: period %.9g s, closed form 1 s\n", name_of(it), T);
        gs_world_destroy(r.w);
    }
}

/* After exactly one period of the closed form (n = 1000 steps, t = 1 s),
   u(1 s) = A cos(2 pi) = A in closed form. Each integrator's own answer:
     explicit Euler  u_n = A (1 + x^2)^(n/2) cos(n theta): 1.0199 A (+2%),
                     its amplitude growing by (1 + (omega dt)^2)^(1/2) a step;
     implicit Euler  the inverse gain: 0.9805 A (-2%);
     RK4             |R|^n = 1 - 4e-13, phase off by 1e-10 rad: A;
     Verlet          u_n = A cos(n theta) exactly (Stormer form with
                     u_1 = A cos theta): 1 - 5e-11;
     symplectic Euler u_n = A cos(n theta) -+ c sin(n theta),
                     c = A (x / 2) / sqrt(1 - x^2 / 4) (its invariant ellipse
                     is tilted; the sign is - when v is updated first, + when
                     x is, and either variant is accepted): n theta - 2 pi =
                     1e-5 rad, so 3.2e-8 A below or above A.
   Tolerances: the linear recurrences are exact up to round-off (1000 steps
   of ~1e-16: 1e-9 relative is a margin of 1e4); implicit Euler solves by CG
   to a relative residual of 1e-6 per step, on a velocity change that is
   omega dt = 6e-3 of the velocity: at most 6e-9 of the state per step,
   6e-6 over 1000 steps, so 1e-5. The phase-space amplitude |z| / A must be gain^n to the same
   tolerances (explicit/implicit/RK4), within x / 2 = 3.1e-3 of 1 for the
   symplectic pair (the ellipse's half-width about the circle). */
static void test_amplitude_per_integrator(void **state) {
    double dt = 1e-3, x = OMEGA * dt;
    int n = 1000, i;
    (void)state;
    for (i = 0; i < 5; ++i) {
        gs_integrator it = all_integrators[i];
        spring_rig r = spring_make(K_UNIT, 1.0, dt, it, GS_STABILITY_UNCHECKED, 0);
        double th = turn_per_step(it, x), gain = pow(gain_per_step(it, x), n);
        double want = gain * cos(n * th), tol = 1e-9, u, amp;
        int symplectic = it == GS_INTEGRATOR_SYMPLECTIC_EULER || it == GS_INTEGRATOR_VERLET;
        if (it == GS_INTEGRATOR_IMPLICIT_EULER) tol = 1e-5;
        step_ok(&r, n);
        u = stretch(&r) / AMP;
        if (it == GS_INTEGRATOR_SYMPLECTIC_EULER) { /* the variant u is nearer to */
            double c = x / 2.0 / sqrt(1.0 - x * x / 4.0) * sin(n * th);
            want += fabs(u - (want - c)) < fabs(u - (want + c)) ? -c : c;
        }
        amp = phase_amplitude(&r) / AMP;
        print_message("%-16s u(1 s) = %.10f A (closed form 1; integrator's own %.10f, "
                      "off by %.1e), |z| = %.10f A\n",
                      name_of(it), u, want, fabs(u - want), amp);
        CHECK(fabs(u - want) < tol, "%s: u(1 s) / A = %.12g, want %.12g +- %.2g\n",
              name_of(it), u, want, tol);
        if (symplectic)
            CHECK(fabs(amp - 1.0) < x / 2.0, "%s: |z| / A = %.12g, want 1 +- %.3g\n",
                  name_of(it), amp, x / 2.0);
        else
            CHECK(fabs(amp - gain) < tol, "%s: |z| / A = %.12g, want %.12g\n", name_of(it),
                  amp, gain);
        gs_world_destroy(r.w);
    }
}

/* ------------------------------------------------------------------------
   Order of convergence
   ------------------------------------------------------------------------ */

/* Phase-space error at t = 1.25 s: the distance between (u, v / omega) and
   the exact (A cos wt, -A sin wt), in metres. Not the position alone at
   1 s: there symplectic Euler's first-order term (c sin(n theta) above)
   vanishes and it would measure order 2; and at a zero of u (1.25 s),
   explicit and implicit Euler's first-order amplitude error hides, leaving
   their second-order phase error. Taking u and v / omega together, every
   integrator's leading term shows wherever it is measured. */
static double error_at(gs_integrator it, double dt) {
    spring_rig r = spring_make(K_UNIT, 1.0, dt, it, GS_STABILITY_UNCHECKED, 0);
    int n = (int)(1.25 / dt + 0.5);
    double du, dv;
    step_ok(&r, n);
    du = stretch(&r) - AMP * cos(OMEGA * 1.25);
    dv = gs_mesh_velocities(r.a)[1].x / OMEGA + AMP * sin(OMEGA * 1.25);
    gs_world_destroy(r.w);
    return sqrt(du * du + dv * dv);
}

/* Halving dt divides the error by 2^order. The dt pairs divide 1.25 s
   evenly and sit in each method's asymptotic range, well above round-off
   (the smallest error, RK4's at 25 ms, is ~4e-6 m against round-off of
   ~1e-14 m). A measured order within 0.3 of the theory allows for the next
   term of the error series: relative to the leading one it is O(omega dt)
   for the Euler methods (0.016 at 2.5 ms; the order comes out 0.02 off)
   and O((omega dt)^2) for Verlet and RK4, whose phase errors run in odd
   powers of omega dt (4e-3 at 10 ms, 0.1 at 50 ms). 0.3 covers these with
   margin and still tells every order from the next one up or down. */
static void test_order_of_convergence(void **state) {
    static const double dts[5] = {2.5e-3, 2.5e-3, 1e-2, 5e-2, 2.5e-3};
    static const double order[5] = {1.0, 1.0, 2.0, 4.0, 1.0};
    int i;
    (void)state;
    for (i = 0; i < 5; ++i) {
        double e1 = error_at(all_integrators[i], dts[i]);
        double e2 = error_at(all_integrators[i], dts[i] / 2.0);
        double p = log(e1 / e2) / log(2.0);
        print_message("%-16s error %.3e m at %g s, %.3e m at %g s: order %.3f\n",
                      name_of(all_integrators[i]), e1, dts[i], e2, dts[i] / 2.0, p);
        CHECK(fabs(p - order[i]) < 0.3, "%s: order %.3f, want %.0f +- 0.3\n",
              name_of(all_integrators[i]), p, order[i]);
    }
}

/* ------------------------------------------------------------------------
   Energy over 100 000 steps of 1 ms (100 periods), omega dt = 6.3e-3
   ------------------------------------------------------------------------ */

/* Symplectic methods keep a modified energy exactly, so the true energy
   only breathes, with no drift: by up to omega dt / 2 = 3.1e-3 relative for
   symplectic Euler (bound 1e-2) and (omega dt)^2 / 4 = 9.9e-6 for Verlet
   (bound 1e-4). After 100 whole periods the state is back near its start
   (the discrete period is off by 1.6e-6, 1.6e-4 of a period after 100), so
   the energy is back within a tenth of those bounds. */
static void test_energy_bounded_symplectic(void **state) {
    static const gs_integrator its[2] = {GS_INTEGRATOR_SYMPLECTIC_EULER, GS_INTEGRATOR_VERLET};
    static const double bound[2] = {1e-2, 1e-4};
    int i, s;
    (void)state;
    for (i = 0; i < 2; ++i) {
        spring_rig r = spring_make(K_UNIT, 1.0, 1e-3, its[i], GS_STABILITY_UNCHECKED, 0);
        double e0 = energy(&r), worst = 0.0, end;
        for (s = 1; s <= 100000; ++s) {
            double dev;
            step_ok(&r, 1);
            dev = fabs(energy(&r) / e0 - 1.0);
            if (dev > worst) worst = dev;
        }
        end = fabs(energy(&r) / e0 - 1.0);
        print_message("%-16s worst energy deviation %.2e, after 100 periods %.2e\n",
                      name_of(its[i]), worst, end);
        CHECK(worst < bound[i], "%s: energy strayed by %.3g (bound %.3g)\n", name_of(its[i]),
              worst, bound[i]);
        CHECK(end < bound[i] / 10.0, "%s: energy off by %.3g after 100 periods (bound %.3g)\n",
              name_of(its[i]), end, bound[i] / 10.0);
        gs_world_destroy(r.w);
    }
}

/* Explicit Euler multiplies the energy (k |z|^2 / 2) by exactly
   1 + (omega dt)^2 every step, implicit Euler divides it by the same: over
   100 000 steps x51.8 and /51.8. So the energy must rise (fall) at every
   step and, at every whole period, equal (1 + (omega dt)^2)^(+-n) E0:
   to 1e-9 for explicit Euler (round-off of 1e5 steps ~1e-11); to 2e-3 for
   implicit Euler, whose CG stops at a relative residual of 1e-6 per step
   (at most 6e-9 of the state per step, 6e-4 over 1e5 steps, twice that in
   energy). */
static void test_energy_euler_grows_and_decays(void **state) {
    static const gs_integrator its[2] = {GS_INTEGRATOR_EXPLICIT_EULER,
                                         GS_INTEGRATOR_IMPLICIT_EULER};
    static const double tol[2] = {1e-9, 2e-3};
    double x = OMEGA * 1e-3;
    int i, s;
    (void)state;
    for (i = 0; i < 2; ++i) {
        spring_rig r = spring_make(K_UNIT, 1.0, 1e-3, its[i], GS_STABILITY_UNCHECKED, 0);
        double e0 = energy(&r), prev = e0, sign = i == 0 ? 1.0 : -1.0;
        for (s = 1; s <= 100000; ++s) {
            double e;
            step_ok(&r, 1);
            e = energy(&r);
            CHECK(sign * (e - prev) > 0.0, "%s: energy %.15g J after step %d, %.15g J before\n",
                  name_of(its[i]), e, s, prev);
            prev = e;
            if (s % 1000 == 0) {
                double want = pow(1.0 + x * x, sign * s);
                CHECK(fabs(e / e0 / want - 1.0) < tol[i],
                      "%s: energy x%.12g after %d steps, closed form x%.12g\n",
                      name_of(its[i]), e / e0, s, want);
            }
        }
        print_message("%-16s energy x%.6f after 100 periods (closed form x%.6f)\n",
                      name_of(its[i]), prev / e0, pow(1.0 + x * x, sign * 100000));
        gs_world_destroy(r.w);
    }
}

/* Forward Euler has no stable dt on an undamped spring: even at dt = 0.1 ms
   (omega dt = 6.3e-4) the amplitude after 10 periods is above the start, by
   the closed form (1 + (omega dt)^2)^(n/2) = 1.0199 (tolerance 1e-9 as
   above: round-off). The test expects growth, not a limit. */
static void test_forward_euler_grows_at_tiny_dt(void **state) {
    double dt = 1e-4, x = OMEGA * dt;
    spring_rig r = spring_make(K_UNIT, 1.0, dt, GS_INTEGRATOR_EXPLICIT_EULER,
                               GS_STABILITY_UNCHECKED, 0);
    double want = pow(1.0 + x * x, 100000 / 2.0), amp, u;
    (void)state;
    step_ok(&r, 100000);
    amp = phase_amplitude(&r) / AMP;
    u = stretch(&r) / AMP;
    print_message("after 10 periods at 0.1 ms: |z| = %.9f A, u = %.9f A (closed form %.9f)\n",
                  amp, u, want);
    CHECK(u > 1.0 && amp > 1.0, "no growth: u / A = %.12g, |z| / A = %.12g\n", u, amp);
    CHECK(fabs(amp / want - 1.0) < 1e-9, "|z| / A = %.12g, closed form %.12g\n", amp, want);
    gs_world_destroy(r.w);
}

/* ------------------------------------------------------------------------
   Stability: the grid, the guard, the limit, substep and refuse
   ------------------------------------------------------------------------ */

typedef struct grid_tally { /* outcomes of one integrator's cells in one mode */
    int cells, refused_first, failed_later, all_ok;
    double reach; /* implicit Euler: the largest |stretch| / implicit_reach */
} grid_tally;

/* How far implicit Euler may stretch or compress the spring, in m. Gravity
   on, no damping; the particle starts at rest at height 0 with stretch A.
   If the step does not create energy (implicit Euler dissipates),
   k s^2 / 2 <= k A^2 / 2 + m g (L + s), because the particle cannot drop
   further than the spring's length L + s below the anchor. So
   s <= a + sqrt(a^2 + 2 a L + A^2), a = m g / k the static sag: the sag plus
   the swing about it (a pendulum at the bottom of its swing pulls 3 m g, a
   stretch of 3 a, inside this bound). Compression is at most A by the same
   energy argument. The factor 1.01 allows for the linearized solve (one
   Newton step of Baraff-Witkin, not the exact backward Euler) and 1e-9 m
   of round-off. */
static double implicit_reach(double k, double m) {
    double a = m * G / k;
    return 1.01 * (a + sqrt(a * a + 2.0 * a * REST + AMP * AMP)) + 1e-9;
}

/* One cell: 200 steps. Every step returns GS_OK with a finite state, or
   GS_ERR_UNSTABLE with the state exactly (bitwise) as before the call, and
   finite; the cell stops at the first refusal. Then what the stability
   bound sd = gs_mesh_stable_dt implies:
     refuse:  dt > sd           -> the first step is refused;
              dt <= safety sd   -> it is not, and (not explicit Euler) all
                                   200 steps succeed;
     substep: dt > 64 sd        -> refused (needs over max_substeps = 64);
              dt <= 64 safety sd -> not refused, and (not explicit Euler)
                                   all steps succeed.
   Between the two thresholds (the 0.9 safety margin) either answer is
   right. Explicit Euler grows at any dt, so its steps may end in the
   guard's GS_ERR_UNSTABLE. Implicit Euler must never fail and stays within
   implicit_reach() at every step. */
static void grid_cell(double k, double m, double dt, gs_integrator it, gs_stability st,
                      grid_tally *tally) {
    spring_rig r = spring_make(k, m, dt, it, st, 1);
    double before[NSTATE], after[NSTATE], sd = gs_mesh_stable_dt(r.a), worst = 0.0;
    double limit = st == GS_STABILITY_REFUSE ? 1.0 : 64.0, safety = 0.9;
    int s, fail_at = -1, implicit = it == GS_INTEGRATOR_IMPLICIT_EULER;
    for (s = 0; s < 200; ++s) {
        gs_result res;
        assert_int_equal(gs_agent_get_state(r.a, before, NSTATE), GS_OK);
        res = gs_agent_step(r.a);
        assert_int_equal(gs_agent_get_state(r.a, after, NSTATE), GS_OK);
        CHECK(all_finite(after, NSTATE),
              "k %g m %g dt %g %s stability %d: non-finite state after step %d (%s)\n", k, m,
              dt, name_of(it), (int)st, s, gs_result_str(res));
        if (res == GS_ERR_UNSTABLE) {
            CHECK(memcmp(before, after, sizeof before) == 0,
                  "k %g m %g dt %g %s stability %d: refused step %d changed the state\n", k, m,
                  dt, name_of(it), (int)st, s);
            fail_at = s;
            break;
        }
        CHECK(res == GS_OK, "k %g m %g dt %g %s stability %d: step %d returned %s (%s)\n", k,
              m, dt, name_of(it), (int)st, s, gs_result_str(res), gs_world_error(r.w));
        if (implicit) {
            const gs_vec3 *x = gs_mesh_positions(r.a);
            double len = sqrt(x[1].x * x[1].x + x[1].y * x[1].y + x[1].z * x[1].z);
            if (fabs(len - REST) > worst) worst = fabs(len - REST);
        }
    }
    tally->cells++;
    if (fail_at == 0) tally->refused_first++;
    else if (fail_at > 0) tally->failed_later++;
    else tally->all_ok++;
    if (implicit) {
        double reach = implicit_reach(k, m);
        CHECK(fail_at < 0, "k %g m %g dt %g implicit Euler failed at step %d: %s\n", k, m, dt,
              fail_at, gs_world_error(r.w));
        if (worst / reach > tally->reach) tally->reach = worst / reach;
        CHECK(worst <= reach,
              "k %g m %g dt %g implicit Euler: |stretch| reached %.6g m, bound %.6g m\n", k, m,
              dt, worst, reach);
    } else {
        if (dt > limit * sd)
            CHECK(fail_at == 0, "k %g m %g dt %g %s stability %d: dt is %.3g stable steps but "
                                "step 0 was not refused (failed at %d)\n",
                  k, m, dt, name_of(it), (int)st, dt / sd, fail_at);
        if (dt <= limit * safety * sd) {
            /* explicit Euler may blow up within its first step of up to 64
               substeps (|z| x 2 a substep at omega h = 1.8 carries it past
               GS_MAX_COORD): the guard's refusal, not the planner's */
            CHECK(fail_at != 0 || (it == GS_INTEGRATOR_EXPLICIT_EULER &&
                                   strstr(gs_world_error(r.w), "blew up")),
                  "k %g m %g dt %g %s stability %d: dt is %.3g stable steps, "
                  "yet step 0 was refused: %s\n",
                  k, m, dt, name_of(it), (int)st, dt / sd, gs_world_error(r.w));
            if (it != GS_INTEGRATOR_EXPLICIT_EULER)
                CHECK(fail_at < 0, "k %g m %g dt %g %s stability %d: dt is %.3g stable steps, "
                                   "yet step %d failed: %s\n",
                      k, m, dt, name_of(it), (int)st, dt / sd, fail_at, gs_world_error(r.w));
        }
    }
    gs_world_destroy(r.w);
}

/* Stiffness 1 to 1e8 N/m, particle mass 1e-4 to 1e3 kg, dt 1e-5 to 0.1 s,
   gravity on: omega dt from 3e-7 to 1e5. 200 steps per cell keep it cheap
   even at 64 substeps a step. */
static void test_stability_grid(void **state) {
    static const double ks[5] = {1.0, 1e2, 1e4, 1e6, 1e8};
    static const double ms[4] = {1e-4, 1e-2, 1.0, 1e3};
    static const double dts[3] = {1e-5, 1e-3, 1e-1};
    grid_tally tally[5][2]; /* [integrator][default, refuse] */
    int a, b, c, i, j;
    (void)state;
    memset(tally, 0, sizeof tally);
    for (a = 0; a < 5; ++a)
        for (b = 0; b < 4; ++b)
            for (c = 0; c < 3; ++c) {
                grid_cell(ks[a], ms[b], dts[c], GS_INTEGRATOR_IMPLICIT_EULER,
                          GS_STABILITY_DEFAULT, &tally[4][0]);
                for (i = 0; i < 4; ++i) {
                    grid_cell(ks[a], ms[b], dts[c], all_integrators[i], GS_STABILITY_DEFAULT,
                              &tally[i][0]);
                    grid_cell(ks[a], ms[b], dts[c], all_integrators[i], GS_STABILITY_REFUSE,
                              &tally[i][1]);
                }
            }
    for (i = 0; i < 5; ++i)
        for (j = 0; j < (i < 4 ? 2 : 1); ++j)
            print_message("%-16s %-7s %2d cells: %2d all ok, %2d refused at once, "
                          "%2d failed later\n",
                          name_of(all_integrators[i]), j ? "refuse" : "default",
                          tally[i][j].cells, tally[i][j].all_ok, tally[i][j].refused_first,
                          tally[i][j].failed_later);
    print_message("implicit Euler: largest |stretch| %.3f of the energy bound\n",
                  tally[4][0].reach);
}

/* With no check at all, a blow-up still never leaves the agent. At
   omega dt = 1e5 (k 1e8 N/m, m 1e-4 kg, dt 0.1 s) with max_speed lifted, the
   non-finite guard must stop it; with the default max_speed (1e4 m/s) and a
   slower blow-up the speed guard must. That one runs at omega dt = 5, past
   every explicit integrator's limit (2 for the Euler pair and Verlet, 2.83
   for RK4) by enough that |z| grows 5 to 23 times a step: a milder excess
   does not reliably blow up, because the spring pulls towards |x| = L, so
   an orbit that grows past the anchor is folded back (RK4 at omega dt = 3,
   |R| = 1.5, wanders in a bounded chaotic orbit for 1e5 steps, measured).
   The failing step returns GS_ERR_UNSTABLE, leaves state and time bitwise
   as they were, and what is left is finite (and under max_speed). */
static void test_unchecked_blowup_is_caught(void **state) {
    int i, g;
    (void)state;
    for (g = 0; g < 2; ++g)
        for (i = 0; i < 4; ++i) {
            gs_solver_desc sd;
            spring_rig r;
            double before[NSTATE], after[NSTATE], t_before = 0.0, vmax;
            gs_result res = GS_OK;
            int s;
            memset(&sd, 0, sizeof sd);
            sd.integrator = all_integrators[i];
            sd.stability = GS_STABILITY_UNCHECKED;
            if (g == 0) {
                sd.dt = 0.1;
                r = spring_make_solver(1e8, 1e-4, 0, sd);
            } else {
                sd.dt = 5.0 / OMEGA;
                sd.max_speed = 1e4;
                r = spring_make_solver(K_UNIT, 1.0, 0, sd);
            }
            for (s = 0; s < 100000 && res == GS_OK; ++s) {
                gs_agent_get_state(r.a, before, NSTATE);
                t_before = gs_agent_time(r.a);
                res = gs_agent_step(r.a);
            }
            gs_agent_get_state(r.a, after, NSTATE);
            vmax = hypot(hypot(after[10], after[11]), after[12]); /* no overflow */
            print_message("%-16s %s guard: GS_ERR_UNSTABLE on call %d, speed kept %.3g m/s\n",
                          name_of(all_integrators[i]), g == 0 ? "non-finite" : "speed", s, vmax);
            CHECK(res == GS_ERR_UNSTABLE, "%s: blow-up ended in %s\n",
                  name_of(all_integrators[i]), gs_result_str(res));
            CHECK(gs_agent_result(r.a) == GS_ERR_UNSTABLE, "%s: gs_agent_result is %s\n",
                  name_of(all_integrators[i]), gs_result_str(gs_agent_result(r.a)));
            CHECK(all_finite(after, NSTATE), "%s: non-finite state kept\n",
                  name_of(all_integrators[i]));
            CHECK(memcmp(before, after, sizeof before) == 0,
                  "%s: the failing step changed the state\n", name_of(all_integrators[i]));
            CHECK(gs_agent_time(r.a) == t_before, "%s: time moved from %.17g to %.17g\n",
                  name_of(all_integrators[i]), t_before, gs_agent_time(r.a));
            if (g == 1)
                CHECK(vmax <= 1e4, "%s: kept a speed of %.6g m/s over max_speed\n",
                      name_of(all_integrators[i]), vmax);
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

/* Symplectic Euler on one spring, unchecked, undamped: bounded at
   omega dt = 1.9 (the invariant ellipse reaches 1/sqrt(1 - (omega dt / 2)^2)
   = 3.2 times the start; bound 5x), growing at 2.1 (an eigenvalue of
   modulus 1.37 per step: past 10x within a dozen steps, or caught by the
   guard). gs_mesh_stable_dt gives 2 / omega for this spring to 1e-9
   relative: the Gershgorin bound is exact for one spring to a pinned anchor
   with no damping (only round-off of a sqrt and a division separates
   them). */
static void test_symplectic_limit_near_two(void **state) {
    spring_rig lo = spring_make(K_UNIT, 1.0, 1.9 / OMEGA, GS_INTEGRATOR_SYMPLECTIC_EULER,
                                GS_STABILITY_UNCHECKED, 0);
    spring_rig hi = spring_make(K_UNIT, 1.0, 2.1 / OMEGA, GS_INTEGRATOR_SYMPLECTIC_EULER,
                                GS_STABILITY_UNCHECKED, 0);
    gs_result r1, r2;
    double s1 = max_stretch(&lo, 2000, &r1), s2 = max_stretch(&hi, 2000, &r2);
    double sd = gs_mesh_stable_dt(lo.a);
    (void)state;
    print_message("omega dt 1.9: max |u| %.3f A (%s); 2.1: max |u| %.3g A (%s); "
                  "stable dt %.12g s, 2/omega %.12g s\n",
                  s1 / AMP, gs_result_str(r1), s2 / AMP, gs_result_str(r2), sd, 2.0 / OMEGA);
    CHECK(r1 == GS_OK, "omega dt 1.9: %s\n", gs_result_str(r1));
    CHECK(s1 < 5.0 * AMP, "omega dt 1.9: |u| reached %.4g A\n", s1 / AMP);
    CHECK(r2 == GS_ERR_UNSTABLE || s2 > 10.0 * AMP, "omega dt 2.1: |u| only %.4g A (%s)\n",
          s2 / AMP, gs_result_str(r2));
    CHECK(fabs(sd * OMEGA / 2.0 - 1.0) < 1e-9, "stable dt %.15g s, want 2 / omega = %.15g s\n",
          sd, 2.0 / OMEGA);
    gs_world_destroy(lo.w);
    gs_world_destroy(hi.w);
}

/* dt = 3 / omega is over the bound (2 / omega). The default (substep) mode
   splits it - ceil(3 / (0.9 * 2)) = 2 substeps a step - so it returns GS_OK,
   counts more substeps than steps and stays bounded (the ellipse at
   omega h = 1.5 reaches 1.5 A; bound 5 A). Refuse mode returns
   GS_ERR_UNSTABLE and leaves state and time alone. Substep mode refuses
   too when the split would need more than max_substeps (dt = 10 / omega
   needs 6 > 2). */
static void test_substep_or_refuse(void **state) {
    double before[NSTATE], after[NSTATE];
    spring_rig sub = spring_make(K_UNIT, 1.0, 3.0 / OMEGA, GS_INTEGRATOR_SYMPLECTIC_EULER,
                                 GS_STABILITY_DEFAULT, 0);
    spring_rig ref = spring_make(K_UNIT, 1.0, 3.0 / OMEGA, GS_INTEGRATOR_SYMPLECTIC_EULER,
                                 GS_STABILITY_REFUSE, 0);
    spring_rig cap;
    gs_solver_desc sd;
    gs_agent_stats st;
    gs_result r;
    double worst;
    (void)state;
    worst = max_stretch(&sub, 200, &r);
    st = agent_stats(sub.a);
    print_message("substep: %s, %llu steps, %llu substeps, max |u| %.3f A\n", gs_result_str(r),
                  (unsigned long long)st.steps, (unsigned long long)st.substeps, worst / AMP);
    CHECK(r == GS_OK, "substep mode: %s (%s)\n", gs_result_str(r), gs_world_error(sub.w));
    CHECK(st.steps == 200 && st.substeps > st.steps, "steps %llu, substeps %llu\n",
          (unsigned long long)st.steps, (unsigned long long)st.substeps);
    CHECK(worst < 5.0 * AMP, "substep mode: |u| reached %.4g A\n", worst / AMP);
    CHECK(fabs(gs_agent_time(sub.a) - 200 * 3.0 / OMEGA) < 1e-9,
          "substep mode: time %.12g s after 200 steps of %.12g s\n", gs_agent_time(sub.a),
          3.0 / OMEGA);

    gs_agent_get_state(ref.a, before, NSTATE);
    r = gs_agent_step(ref.a);
    gs_agent_get_state(ref.a, after, NSTATE);
    CHECK(r == GS_ERR_UNSTABLE, "refuse mode: %s\n", gs_result_str(r));
    CHECK(memcmp(before, after, sizeof before) == 0, "refuse mode changed the state\n");
    CHECK(gs_agent_time(ref.a) == 0.0, "refuse mode: time %.17g\n", gs_agent_time(ref.a));
    CHECK(agent_stats(ref.a).steps == 0, "refuse mode counted a step\n");
    CHECK(gs_world_error(ref.w)[0] != '\0', "refuse mode: gs_world_error is empty\n");
    print_message("refuse: %s\n", gs_world_error(ref.w));
    gs_world_destroy(sub.w);
    gs_world_destroy(ref.w);

    memset(&sd, 0, sizeof sd);
    sd.dt = 10.0 / OMEGA;
    sd.integrator = GS_INTEGRATOR_SYMPLECTIC_EULER;
    sd.max_substeps = 2;
    cap = spring_make_solver(K_UNIT, 1.0, 0, sd);
    gs_agent_get_state(cap.a, before, NSTATE);
    r = gs_agent_step(cap.a);
    gs_agent_get_state(cap.a, after, NSTATE);
    CHECK(r == GS_ERR_UNSTABLE, "over max_substeps: %s\n", gs_result_str(r));
    CHECK(memcmp(before, after, sizeof before) == 0, "over max_substeps: state changed\n");
    CHECK(gs_world_error(cap.w)[0] != '\0', "over max_substeps: gs_world_error is empty\n");
    print_message("over max_substeps: %s\n", gs_world_error(cap.w));
    gs_world_destroy(cap.w);
}

/* 1 if the README's 16 x 16 cloth (defaults, corners pinned), positions
   perturbed by a seeded 1e-4 m so every mode starts excited, survives 2000
   unchecked symplectic Euler steps of dt: no failed step, no particle
   faster than 100 m/s (falling, it stays under 5 m/s). */
static int cloth_survives(double dt) {
    gs_world *w;
    gs_agent *c;
    gs_cloth_desc cd = gs_cloth_desc_default();
    double s[1 + 6 * 256];
    uint32_t seed = 7;
    int i, ok = 1;
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    cd.nx = cd.ny = 16;
    cd.pin_corners = GS_CORNER_ALL;
    cd.solver.dt = dt;
    cd.solver.stability = GS_STABILITY_UNCHECKED;
    assert_int_equal(gs_cloth_create(w, &cd, &c), GS_OK);
    assert_int_equal(gs_agent_get_state(c, s, 1 + 6 * 256), GS_OK);
    for (i = 1; i <= 3 * 256; ++i) {
        seed = seed * 1664525u + 1013904223u;
        s[i] += 1e-4 * ((double)(seed >> 8) / 16777216.0 - 0.5);
    }
    assert_int_equal(gs_agent_set_state(c, s, 1 + 6 * 256), GS_OK);
    for (i = 0; i < 2000 && ok; ++i) {
        ok = gs_agent_step(c) == GS_OK;
        if (ok && i % 50 == 49) {
            const gs_vec3 *v = gs_mesh_velocities(c);
            int j;
            for (j = 0; j < 256; ++j)
                if (!(v[j].x * v[j].x + v[j].y * v[j].y + v[j].z * v[j].z < 1e4)) ok = 0;
        }
    }
    gs_world_destroy(w);
    return ok;
}

/* The README's worked example: a 16 x 16 cloth of 1 kg with the default
   springs (1000 / 100 / 10 N/m). gs_mesh_stable_dt estimates its highest
   frequency by power iteration on the springs' real stiffness; the
   measured limit of symplectic Euler (bisection in log dt, 16 halvings,
   cloth_survives) must lie within 10% above it and at most 2% below (the
   estimate stays under the limit where the 0.9 safety is not needed). It is
   never more cautious than Gershgorin's bound, whose rule h = 4 / (g +
   sqrt(g^2 + 4 w^2)) for the inner particle (4 structural, 4 shear, 4 bend
   springs, each counted twice; damping 0.02 N s/m on 12 springs, twice,
   plus 0.1 /s of air) gives 1.27 ms, which the limit exceeds by 1.4-1.5x. */
static void test_cloth_stable_dt_near_measured_limit(void **state) {
    gs_world *w;
    gs_agent *c;
    gs_cloth_desc cd = gs_cloth_desc_default();
    double m = 1.0 / 256.0, w2 = 2.0 * 4440.0 / m, g = 2.0 * 12.0 * 0.02 / m + 0.1;
    double gersh = 4.0 / (g + sqrt(g * g + 4.0 * w2)), got, lo = 1e-4, hi = 1e-2;
    int i;
    (void)state;
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    cd.nx = cd.ny = 16;
    cd.pin_corners = GS_CORNER_ALL;
    assert_int_equal(gs_cloth_create(w, &cd, &c), GS_OK);
    got = gs_mesh_stable_dt(c);
    gs_world_destroy(w);
    for (i = 0; i < 16; ++i) {
        double mid = sqrt(lo * hi);
        if (cloth_survives(mid)) lo = mid;
        else hi = mid;
    }
    print_message("stable dt %.4g ms, measured limit %.4g ms (limit / estimate %.3f), "
                  "Gershgorin %.4g ms (limit / Gershgorin %.3f)\n",
                  1e3 * got, 1e3 * lo, lo / got, 1e3 * gersh, lo / gersh);
    CHECK(fabs(gersh - 1.27e-3) < 0.01e-3, "Gershgorin rule %.6g s, README says 1.27 ms\n", gersh);
    CHECK(got >= gersh * (1.0 - 1e-12), "estimate %.6g s under Gershgorin's %.6g s\n", got, gersh);
    CHECK(lo / got >= 0.98 && lo / got <= 1.10, "limit %.6g s is %.3f x the estimate %.6g s\n",
          lo, lo / got, got);
}

/* ------------------------------------------------------------------------
   A hanging cloth
   ------------------------------------------------------------------------ */

/* A 10 x 10 cloth of 1 kg hung by its 4 corners from rest, flat at y = 0,
   implicit Euler at 1 ms, 10 s in frames of 1/60 s. The sag is how far the
   middle sits below the pinned corners: with an even grid, the mean depth
   of the 4 central particles (equal by symmetry). *ke_last is the largest
   kinetic energy over the last second. */
static double settle_sag(double stiffness, double *ke_last) {
    gs_world *w;
    gs_agent *c;
    gs_cloth_desc cd = gs_cloth_desc_default();
    const gs_vec3 *x;
    double sag, corner;
    int f, n = 10, mid[4];
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    cd.nx = cd.ny = n;
    cd.pin_corners = GS_CORNER_ALL;
    cd.stretch_stiffness = stiffness;
    cd.air_damping = 2.0;
    cd.solver.integrator = GS_INTEGRATOR_IMPLICIT_EULER;
    cd.solver.dt = 1e-3;
    assert_int_equal(gs_cloth_create(w, &cd, &c), GS_OK);
    *ke_last = 0.0;
    for (f = 1; f <= 600; ++f) {
        gs_result r = gs_world_advance(w, 1.0 / 60.0, NULL);
        double ke;
        CHECK(r == GS_OK, "k %g: frame %d: %s (%s)\n", stiffness, f, gs_result_str(r),
              gs_world_error(w));
        assert_int_equal(gs_mesh_energy(c, &ke, NULL), GS_OK);
        if (f > 540 && ke > *ke_last) *ke_last = ke;
    }
    x = gs_mesh_positions(c);
    mid[0] = n / 2 - 1 + n * (n / 2 - 1);
    mid[1] = mid[0] + 1;
    mid[2] = mid[0] + n;
    mid[3] = mid[0] + n + 1;
    corner = (x[0].y + x[n - 1].y + x[n * (n - 1)].y + x[n * n - 1].y) / 4.0;
    CHECK(corner == 0.0, "k %g: the pinned corners moved to y = %.6g m\n", stiffness, corner);
    sag = corner - (x[mid[0]].y + x[mid[1]].y + x[mid[2]].y + x[mid[3]].y) / 4.0;
    gs_world_destroy(w);
    return sag;
}

/* It settles: the potential-energy scale is m g sag ~ 1 kg * 9.81 * 0.15 m
   ~ 1.5 J, and that much (PE at equilibrium is -0.57 to -1.14 J from the
   flat start) must be shed. Air damping of 2 /s takes energy at 2 x 2 KE,
   i.e. at rate 2 /s on average over an oscillation (spring damping and
   implicit Euler's own damping only add), so after 9 s at most
   1.14 J * e^-18 = 1.7e-8 J is left. The bound 1e-6 J over the whole last
   second (a millionth of m g sag, an rms speed of 1.4 mm/s) leaves a margin
   of 60 over that. The sag grows as the stretch stiffness falls
   (5000 > 500 > 50 N/m): strictly increasing. */
static void test_hanging_cloth_settles_and_sags(void **state) {
    static const double ks[3] = {5000.0, 500.0, 50.0};
    double sag[3], ke[3];
    int i;
    (void)state;
    for (i = 0; i < 3; ++i) {
        sag[i] = settle_sag(ks[i], &ke[i]);
        print_message("stretch %5g N/m: sag %.5f m, kinetic energy over the last second "
                      "<= %.2e J\n", ks[i], sag[i], ke[i]);
        CHECK(ke[i] < 1e-6, "k %g: kinetic energy %.3g J over the last second\n", ks[i], ke[i]);
    }
    CHECK(sag[0] > 0.0 && sag[0] < sag[1] && sag[1] < sag[2],
          "sags %.6g / %.6g / %.6g m are not increasing as the stiffness falls\n", sag[0],
          sag[1], sag[2]);
}

/* ------------------------------------------------------------------------
   Accessors: counts, positions, energy, pins
   ------------------------------------------------------------------------ */

/* Spring counts per family and in all, on a non-square grid (7 x 5) so that
   nx and ny cannot be swapped unnoticed. */
static void test_counts(void **state) {
    static const int masks[4] = {GS_SPRINGS_STRUCTURAL, GS_SPRINGS_SHEAR, GS_SPRINGS_BEND, 0};
    int nx = 7, ny = 5, i;
    int structural = (nx - 1) * ny + nx * (ny - 1), shear = 2 * (nx - 1) * (ny - 1);
    int bend = (nx - 2) * ny + nx * (ny - 2);
    int want[4];
    (void)state;
    want[0] = structural;
    want[1] = shear;
    want[2] = bend;
    want[3] = structural + shear + bend;
    for (i = 0; i < 4; ++i) {
        gs_world *w;
        gs_agent *c;
        gs_cloth_desc cd = gs_cloth_desc_default();
        assert_int_equal(gs_world_create(NULL, &w), GS_OK);
        cd.nx = nx;
        cd.ny = ny;
        cd.springs = masks[i];
        assert_int_equal(gs_cloth_create(w, &cd, &c), GS_OK);
        assert_int_equal(gs_mesh_particle_count(c), nx * ny);
        CHECK(gs_mesh_spring_count(c) == want[i], "springs mask %d: %d springs, want %d\n",
              masks[i], gs_mesh_spring_count(c), want[i]);
        gs_world_destroy(w);
    }
}

/* Particle i + nx j sits at origin + u (width i / (nx - 1)) +
   v (height j / (ny - 1)) with the default axes +x, +z; a cloth of 1 kg at
   rest at height 0.5 m has kinetic energy 0 and potential energy
   m g h = 4.905 J (its springs are at rest length). Tolerances: round-off
   of a few operations (1e-12). */
static void test_positions_and_energy(void **state) {
    gs_world *w;
    gs_agent *c;
    gs_cloth_desc cd = gs_cloth_desc_default();
    const gs_vec3 *x;
    double ke = -1.0, pe = -1.0;
    int nx = 7, ny = 5, i, j;
    (void)state;
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    cd.nx = nx;
    cd.ny = ny;
    cd.width = 2.0;
    cd.height = 0.5;
    cd.origin.x = -1.0;
    cd.origin.y = 0.5;
    assert_int_equal(gs_cloth_create(w, &cd, &c), GS_OK);
    x = gs_mesh_positions(c);
    assert_non_null(x);
    for (j = 0; j < ny; ++j)
        for (i = 0; i < nx; ++i) {
            gs_vec3 p = x[i + nx * j];
            double wx = -1.0 + 2.0 * i / (nx - 1), wz = 0.5 * j / (ny - 1);
            CHECK(fabs(p.x - wx) < 1e-12 && fabs(p.y - 0.5) < 1e-12 && fabs(p.z - wz) < 1e-12,
                  "particle (%d, %d) at (%g, %g, %g), want (%g, 0.5, %g)\n", i, j, p.x, p.y,
                  p.z, wx, wz);
        }
    assert_int_equal(gs_mesh_energy(c, &ke, &pe), GS_OK);
    CHECK(ke == 0.0 && fabs(pe - 1.0 * G * 0.5) < 1e-12, "ke %.17g J, pe %.17g J (want 4.905)\n",
          ke, pe);
    assert_int_equal(gs_mesh_energy(c, NULL, NULL), GS_OK); /* either may be NULL */
    gs_world_destroy(w);

    /* The spring rig, gravity off: k A^2 / 2 = 0.197 J, all potential. */
    {
        spring_rig r = spring_make(K_UNIT, 1.0, 1e-3, GS_INTEGRATOR_SYMPLECTIC_EULER,
                                   GS_STABILITY_DEFAULT, 0);
        assert_int_equal(gs_mesh_energy(r.a, &ke, &pe), GS_OK);
        CHECK(ke == 0.0 && fabs(pe / (0.5 * K_UNIT * AMP * AMP) - 1.0) < 1e-12,
              "spring: ke %.17g J, pe %.17g J, want %.17g J\n", ke, pe, 0.5 * K_UNIT * AMP * AMP);
        gs_world_destroy(r.w);
    }
}

/* gs_mesh_move_pin moves a pinned particle, which stays there through
   steps; it refuses a particle that is not pinned (GS_ERR_INVALID_ARG: a
   valid index, a wrong particle), an index outside 0..n-1
   (GS_ERR_OUT_OF_RANGE) and a NaN or infinite position
   (GS_ERR_NOT_FINITE), changing nothing. */
static void test_move_pin(void **state) {
    gs_world *w;
    gs_agent *c;
    gs_cloth_desc cd = gs_cloth_desc_default();
    gs_vec3 p = {0.25, 0.5, -0.125}, nan3 = {NAN, 0.0, 0.0}, inf3 = {0.0, INFINITY, 0.0};
    double before[1 + 6 * 35], after[1 + 6 * 35];
    int nx = 7, ny = 5;
    (void)state;
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    cd.nx = nx;
    cd.ny = ny;
    cd.pin_corners = GS_CORNER_00 | GS_CORNER_11;
    assert_int_equal(gs_cloth_create(w, &cd, &c), GS_OK);
    assert_int_equal(gs_agent_state_size(c), 1 + 6 * nx * ny);
    assert_int_equal(gs_mesh_move_pin(c, 0, p), GS_OK);
    CHECK(gs_mesh_positions(c)[0].x == p.x && gs_mesh_positions(c)[0].y == p.y &&
              gs_mesh_positions(c)[0].z == p.z,
          "pin 0 at (%g, %g, %g)\n", gs_mesh_positions(c)[0].x, gs_mesh_positions(c)[0].y,
          gs_mesh_positions(c)[0].z);
    assert_int_equal(gs_mesh_move_pin(c, nx * ny - 1, p), GS_OK); /* the other corner */
    assert_int_equal(gs_agent_step(c), GS_OK);
    assert_int_equal(gs_agent_step(c), GS_OK);
    CHECK(gs_mesh_positions(c)[0].x == p.x && gs_mesh_positions(c)[0].y == p.y &&
              gs_mesh_positions(c)[nx * ny - 1].z == p.z,
          "pins drifted while stepping\n");

    gs_agent_get_state(c, before, sizeof before / sizeof before[0]);
    assert_int_equal(gs_mesh_move_pin(c, 1, p), GS_ERR_INVALID_ARG); /* not pinned */
    assert_int_equal(gs_mesh_move_pin(c, nx * ny, p), GS_ERR_OUT_OF_RANGE);
    assert_int_equal(gs_mesh_move_pin(c, -1, p), GS_ERR_OUT_OF_RANGE);
    assert_int_equal(gs_mesh_move_pin(c, 0, nan3), GS_ERR_NOT_FINITE);
    assert_int_equal(gs_mesh_move_pin(c, 0, inf3), GS_ERR_NOT_FINITE);
    gs_agent_get_state(c, after, sizeof after / sizeof after[0]);
    CHECK(memcmp(before, after, sizeof before) == 0, "a refused move_pin changed the state\n");
    gs_world_destroy(w);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_period_per_integrator),
        cmocka_unit_test(test_amplitude_per_integrator),
        cmocka_unit_test(test_order_of_convergence),
        cmocka_unit_test(test_energy_bounded_symplectic),
        cmocka_unit_test(test_energy_euler_grows_and_decays),
        cmocka_unit_test(test_forward_euler_grows_at_tiny_dt),
        cmocka_unit_test(test_stability_grid),
        cmocka_unit_test(test_unchecked_blowup_is_caught),
        cmocka_unit_test(test_symplectic_limit_near_two),
        cmocka_unit_test(test_substep_or_refuse),
        cmocka_unit_test(test_cloth_stable_dt_near_measured_limit),
        cmocka_unit_test(test_hanging_cloth_settles_and_sags),
        cmocka_unit_test(test_counts),
        cmocka_unit_test(test_positions_and_energy),
        cmocka_unit_test(test_move_pin),
    };
    return cmocka_run_group_tests_name("cloth", tests, NULL, NULL);
}
