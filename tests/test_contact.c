/* test_contact.c - the stability rule for penalty contact, measured.

   A sphere resting on the ground is a mass on a spring-damper: omega^2 =
   k / m, gamma = c / m. Symplectic Euler is stable while
   dt^2 omega^2 + 2 dt gamma < 4, so the largest stable step is
   dt* = 4 / (gamma + sqrt(gamma^2 + 4 omega^2)); ghostsim substeps a rigid body
   to stay under it. Here the substepping is switched off
   (GS_STABILITY_UNCHECKED) and the real limit is found by bisection on dt;
   it must match dt* (this is the rule the README gives for choosing contact
   stiffness). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>

#include "ghostsim.h"
#include "world_helpers.h"

#include <string.h>

/* 1 if a 1 kg sphere resting in its contact spring, started a tenth of its
   rest depth off rest, stays in the linear regime for 10000 steps of dt: it
   never swings further than half the rest depth from rest. An unstable step
   grows the swing by |lambda| per step until the spring lets go (the penalty
   never pulls) and the sphere chatters, bounded but wrong; a stable one
   swings at most 1/sqrt(1 - (omega dt / 2)^2) times its offset, which passes
   5x only within 2% of the limit. */
static int stays_bounded(double k, double c, double dt) {
    gs_world *w;
    gs_agent *s;
    gs_rigid_desc rd = gs_rigid_desc_default();
    gs_material m;
    double rest, swing = 0.0;
    int i, ok = 1;
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    m.stiffness = k;
    m.damping = c;
    m.friction = 0.0;
    assert_int_equal(gs_world_set_ground(w, 1, 0.0, m), GS_OK);
    rd.shape.type = GS_SHAPE_SPHERE;
    rd.shape.radius = 0.1;
    rd.mass = 1.0;
    rd.material = m;
    rd.solver.dt = dt;
    rd.solver.stability = GS_STABILITY_UNCHECKED;
    rest = 0.1 - 9.81 / k; /* weight balanced by the spring */
    rd.position.y = rest - 0.1 * (9.81 / k);
    assert_int_equal(gs_rigid_create(w, &rd, &s), GS_OK);
    for (i = 0; i < 10000 && ok; ++i) {
        gs_result r = gs_agent_step(s);
        double off = fabs(gs_rigid_position(s).y - rest);
        ok = r == GS_OK && isfinite(off);
        if (off > swing) swing = off;
    }
    gs_world_destroy(w);
    return ok && swing < 0.5 * (9.81 / k);
}

static double measured_limit(double k, double c) {
    double lo = 1e-6, hi = 1.0;
    int i;
    for (i = 0; i < 40; ++i) { /* bisection on a log scale */
        double mid = sqrt(lo * hi);
        if (stays_bounded(k, c, mid)) lo = mid;
        else hi = mid;
    }
    return lo;
}

static double theory_limit(double k, double c) {
    double w2 = k / 1.0, g = c / 1.0; /* per kg: the sphere is 1 kg */
    return 4.0 / (g + sqrt(g * g + 4.0 * w2));
}

/* The measured limit lies within 3% of dt*: the bisection resolves far
   finer than that; what remains is the detector (see stays_bounded), which
   can call a stable step unstable within 2% below dt* and catches an
   unstable one within a fraction of a percent above it. */
static void test_contact_stability_rule(void **state) {
    static const double ks[] = {1e3, 1e5, 1e7};
    static const double cs[] = {0.0, 20.0};
    int i, j;
    (void)state;
    for (i = 0; i < 3; ++i)
        for (j = 0; j < 2; ++j) {
            double got = measured_limit(ks[i], cs[j]);
            double want = theory_limit(ks[i], cs[j]);
            print_message("contact k=%g N/m c=%g N s/m: stable dt measured %.4g s, "
                          "rule %.4g s (ratio %.3f)\n", ks[i], cs[j], got, want,
                          got / want);
            assert_true(fabs(got / want - 1.0) < 0.03);
        }
}

/* With substepping on (the default), a step 10x over the limit is split and
   the sphere stays at rest. */
static void test_contact_substeps_keep_it_stable(void **state) {
    gs_world *w;
    gs_agent *s;
    gs_rigid_desc rd = gs_rigid_desc_default();
    gs_material m = gs_material_default();
    int i;
    (void)state;
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    m.stiffness = 1e5;
    m.damping = 20.0;
    assert_int_equal(gs_world_set_ground(w, 1, 0.0, m), GS_OK);
    rd.shape.type = GS_SHAPE_SPHERE;
    rd.shape.radius = 0.1;
    rd.mass = 1.0;
    rd.material = m;
    rd.position.y = 0.1 - 9.81 / 1e5;
    rd.solver.dt = 10.0 * theory_limit(1e5, 20.0);
    assert_int_equal(gs_rigid_create(w, &rd, &s), GS_OK);
    for (i = 0; i < 500; ++i) assert_int_equal(gs_agent_step(s), GS_OK);
    /* 1 mm: the rest depth is 0.1 mm; anything unstable leaves by metres */
    assert_true(fabs(gs_rigid_position(s).y - rd.position.y) < 1e-3);
    assert_true(agent_stats(s).substeps >= 10 * agent_stats(s).steps);
    gs_world_destroy(w);
}

/* gs_rigid_stable_dt is the same rule for one contact of the body's own
   material: a sphere's normal forces pass its centre, so only its mass
   counts (1 kg, 1e5 N/m, 20 N s/m). And the solver's documented defaults. */
static void test_rigid_stable_dt_and_solver_defaults(void **state) {
    gs_world *w;
    gs_agent *s;
    gs_rigid_desc rd = gs_rigid_desc_default();
    gs_solver_desc sd = gs_solver_desc_default();
    (void)state;
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    rd.shape.type = GS_SHAPE_SPHERE;
    rd.shape.radius = 0.1;
    rd.mass = 1.0;
    rd.material.stiffness = 1e5;
    rd.material.damping = 20.0;
    rd.material.friction = 0.0;
    assert_int_equal(gs_rigid_create(w, &rd, &s), GS_OK);
    assert_true(fabs(gs_rigid_stable_dt(s) / theory_limit(1e5, 20.0) - 1.0) < 1e-12);
    gs_world_destroy(w);
    assert_true(sd.dt == 0.001 && sd.integrator == GS_INTEGRATOR_SYMPLECTIC_EULER);
    assert_true(sd.stability == GS_STABILITY_SUBSTEP && sd.max_substeps == 64);
    assert_true(sd.safety == 0.9 && sd.cg_tolerance == 1e-6 && sd.cg_max_iterations == 200);
    assert_true(sd.max_speed == 1e4);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rigid_stable_dt_and_solver_defaults),
        cmocka_unit_test(test_contact_stability_rule),
        cmocka_unit_test(test_contact_substeps_keep_it_stable),
    };
    return cmocka_run_group_tests_name("contact", tests, NULL, NULL);
}
