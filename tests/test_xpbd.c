/* test_xpbd.c - the XPBD integrator (GS_INTEGRATOR_XPBD, >>cloth): it
   converges to the spring-mass solution as its substeps grow, at order 1;
   it never lets a NaN out over the stiffness / mass / dt grid; it is
   deterministic bit for bit, replay included; it meets a sphere and a probe
   through the same penalty contacts as the other integrators; and a scene
   means the same under it (a spring's N/m is its compliance).

   The reference is RK4 at dt = 1e-5 s: its error there (order 4) is far
   below anything XPBD reaches at the substeps tested. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <string.h>

#include "ghostsim.h"

/* An agent's counters by value (gs_agent_get_stats fills an out-pointer). */
static gs_agent_stats agent_stats(const gs_agent *a) {
    gs_agent_stats st;
    memset(&st, 0, sizeof st);
    gs_agent_get_stats(a, &st);
    return st;
}

#define G 9.81 /* m/s^2, the default world's |gravity| */

/* Asserts cond; on failure prints the values that explain it first. */
#define CHECK(cond, ...)                                                       \
    do {                                                                       \
        if (!(cond)) print_message(__VA_ARGS__);                               \
        assert_true(cond);                                                     \
    } while (0)

/* An n x n cloth of 1 kg, 1 m square, pinned at its 4 corners, flat at
   y = 0, springs 1000 / 1000 / 10 N/m with 0.02 N s/m (bench/physics). */
static gs_agent *cloth_air(gs_world *w, int n, gs_integrator it, double dt, int substeps,
                           double air) {
    gs_cloth_desc cd = gs_cloth_desc_default();
    gs_agent *c = NULL;
    gs_result r;
    cd.nx = cd.ny = n;
    cd.stretch_stiffness = 1000.0;
    cd.shear_stiffness = 1000.0;
    cd.bend_stiffness = 10.0;
    cd.spring_damping = 0.02;
    cd.pin_corners = GS_CORNER_ALL;
    cd.air_damping = air;
    cd.solver.dt = dt;
    cd.solver.integrator = it;
    cd.solver.substeps = substeps;
    r = gs_cloth_create(w, &cd, &c);
    CHECK(r == GS_OK, "gs_cloth_create: %s (%s)\n", gs_result_str(r), gs_world_error(w));
    return c;
}

static gs_agent *cloth_make(gs_world *w, int n, gs_integrator it, double dt, int substeps) {
    return cloth_air(w, n, it, dt, substeps, 0.0);
}

static void run(gs_world *w, gs_agent *a, int steps) {
    int s;
    for (s = 0; s < steps; ++s) {
        gs_result r = gs_agent_step(a);
        CHECK(r == GS_OK, "step %d: %s (%s)\n", s, gs_result_str(r), gs_world_error(w));
    }
}

/* RMS distance between the particles of two meshes, m. */
static double rms(const gs_agent *a, const gs_agent *b) {
    const gs_vec3 *x = gs_mesh_positions(a), *y = gs_mesh_positions(b);
    int i, n = gs_mesh_particle_count(a);
    double s = 0.0;
    for (i = 0; i < n; ++i) {
        double dx = x[i].x - y[i].x, dy = x[i].y - y[i].y, dz = x[i].z - y[i].z;
        s += dx * dx + dy * dy + dz * dz;
    }
    return sqrt(s / n);
}

/* An 8 x 8 cloth falls from flat for 0.1 s (the first swing, 5 cm deep).
   At dt = 1 ms XPBD takes 1, 2, 4, ... 64 substeps; the RMS distance to the
   RK4 reference must fall at every doubling, and at order 1: the last
   three ratios between 1.6 and 2.5 (2 is order 1 exactly), and at 64
   substeps (h = 16 us) under 0.1 mm. */
static void test_converges_to_spring_mass(void **state) {
    static const int subs[7] = {1, 2, 4, 8, 16, 32, 64};
    gs_world *w;
    gs_agent *ref, *x[7];
    double err[7];
    int i;
    (void)state;
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    ref = cloth_make(w, 8, GS_INTEGRATOR_RK4, 1e-5, 0);
    run(w, ref, 10000);
    for (i = 0; i < 7; ++i) {
        x[i] = cloth_make(w, 8, GS_INTEGRATOR_XPBD, 1e-3, subs[i]);
        run(w, x[i], 100);
        err[i] = rms(x[i], ref);
        print_message("XPBD %2d substeps: rms %.4g mm to RK4%s", subs[i], 1e3 * err[i],
                      i ? "" : "\n");
        if (i) print_message(" (ratio %.3f)\n", err[i - 1] / err[i]);
    }
    for (i = 1; i < 7; ++i)
        CHECK(err[i] < err[i - 1], "%d substeps: %.4g m, %d: %.4g m\n", subs[i], err[i],
              subs[i - 1], err[i - 1]);
    for (i = 4; i < 7; ++i)
        CHECK(err[i - 1] / err[i] > 1.6 && err[i - 1] / err[i] < 2.5,
              "%d -> %d substeps: error ratio %.3f, order 1 is 2\n", subs[i - 1], subs[i],
              err[i - 1] / err[i]);
    CHECK(err[6] < 1e-4, "64 substeps: rms %.4g m\n", err[6]);
    gs_world_destroy(w);
}

/* One spring (rest 1 m) from a pinned anchor to a particle, gravity on,
   started at rest stretched by 0.1 m. */
static gs_agent *spring_make(gs_world *w, double k, double m, double dt) {
    gs_mesh_desc md = gs_mesh_desc_default();
    gs_vec3 pos[2] = {{0.0, 0.0, 0.0}, {1.1, 0.0, 0.0}};
    double masses[2];
    gs_spring sp;
    gs_agent *a = NULL;
    int pin = 0;
    gs_result r;
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
    md.solver.integrator = GS_INTEGRATOR_XPBD;
    md.solver.max_speed = 1e300; /* k 1e8, m 1e-4 swings at 1e5 m/s */
    r = gs_mesh_create(w, &md, &a);
    CHECK(r == GS_OK, "gs_mesh_create: %s (%s)\n", gs_result_str(r), gs_world_error(w));
    return a;
}

/* Stiffness 1 to 1e8 N/m, mass 1e-4 to 1e3 kg, dt 1e-5 to 0.1 s (omega h
   from 8e-8 to 2.5e4 at 4 substeps): XPBD needs no stability bound, so every
   one of 200 steps succeeds, the state stays finite, and the stretch stays
   within what energy allows: the spring is implicit in XPBD (it only
   loses energy), so k s^2 / 2 <= k A^2 / 2 + m g (L + s), s <= a +
   sqrt(a^2 + 2 a L + A^2), a = m g / k (test_cloth's implicit_reach), with
   1% for the one Gauss-Seidel pass. A 16 x 16 cloth at 1e8 N/m and dt
   0.1 s does not blow up either. */
static void test_extremes_grid(void **state) {
    static const double ks[5] = {1.0, 1e2, 1e4, 1e6, 1e8};
    static const double ms[4] = {1e-4, 1e-2, 1.0, 1e3};
    static const double dts[3] = {1e-5, 1e-3, 1e-1};
    double worst = 0.0, st[13];
    int a, b, c, s, cells = 0;
    gs_world *w;
    gs_agent *cl;
    gs_cloth_desc cd = gs_cloth_desc_default();
    (void)state;
    for (a = 0; a < 5; ++a)
        for (b = 0; b < 4; ++b)
            for (c = 0; c < 3; ++c) {
                double kk = ks[a], mm = ms[b], sag = mm * G / kk;
                double reach = 1.01 * (sag + sqrt(sag * sag + 2.0 * sag + 0.01)) + 1e-9;
                gs_agent *sp;
                assert_int_equal(gs_world_create(NULL, &w), GS_OK);
                sp = spring_make(w, kk, mm, dts[c]);
                for (s = 0; s < 200; ++s) {
                    const gs_vec3 *x;
                    double len;
                    gs_result r = gs_agent_step(sp);
                    CHECK(r == GS_OK, "k %g m %g dt %g: step %d: %s (%s)\n", kk, mm, dts[c], s,
                          gs_result_str(r), gs_world_error(w));
                    assert_int_equal(gs_agent_get_state(sp, st, 13), GS_OK);
                    for (cells = 0; cells < 13; ++cells)
                        CHECK(isfinite(st[cells]), "k %g m %g dt %g: step %d: not finite\n",
                              kk, mm, dts[c], s);
                    x = gs_mesh_positions(sp);
                    len = sqrt(x[1].x * x[1].x + x[1].y * x[1].y + x[1].z * x[1].z);
                    CHECK(fabs(len - 1.0) <= reach,
                          "k %g m %g dt %g: step %d: |stretch| %.6g m, energy bound %.6g m\n",
                          kk, mm, dts[c], s, fabs(len - 1.0), reach);
                    if (fabs(len - 1.0) / reach > worst) worst = fabs(len - 1.0) / reach;
                }
                gs_world_destroy(w);
            }
    print_message("60 cells, 200 steps each: largest |stretch| %.3f of the energy bound\n",
                  worst);
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    cd.nx = cd.ny = 16;
    cd.stretch_stiffness = 1e8;
    cd.pin_corners = GS_CORNER_ALL;
    cd.solver.dt = 0.1;
    cd.solver.integrator = GS_INTEGRATOR_XPBD;
    assert_int_equal(gs_cloth_create(w, &cd, &cl), GS_OK);
    run(w, cl, 100);
    {
        const gs_vec3 *x = gs_mesh_positions(cl);
        for (s = 0; s < 256; ++s)
            CHECK(isfinite(x[s].x) && isfinite(x[s].y) && isfinite(x[s].z) &&
                      fabs(x[s].y) < 10.0,
                  "stiff cloth: particle %d at (%g, %g, %g)\n", s, x[s].x, x[s].y, x[s].z);
    }
    gs_world_destroy(w);
}

/* The paper's scene in small: a 16 x 16 cloth and a 0.1 m, 0.5 kg sphere
   dropped on its middle from 0.3 m, in world `w`; air damping in 1/s. */
static void sphere_scene(gs_world **w, gs_agent **cloth, gs_agent **ball, gs_integrator it,
                         double air) {
    gs_rigid_desc rd = gs_rigid_desc_default();
    gs_result r;
    assert_int_equal(gs_world_create(NULL, w), GS_OK);
    *cloth = cloth_air(*w, 16, it, 1e-3, 0, air);
    rd.shape.type = GS_SHAPE_SPHERE;
    rd.shape.radius = 0.1;
    rd.mass = 0.5;
    rd.position.x = 0.5;
    rd.position.y = 0.3;
    rd.position.z = 0.5;
    r = gs_rigid_create(*w, &rd, ball);
    CHECK(r == GS_OK, "gs_rigid_create: %s (%s)\n", gs_result_str(r), gs_world_error(*w));
}

static uint64_t fnv(const double *v, size_t n) {
    const unsigned char *p = (const unsigned char *)v;
    uint64_t h = 1469598103934665603ull;
    size_t i;
    for (i = 0; i < n * sizeof *v; ++i) h = (h ^ p[i]) * 1099511628211ull;
    return h;
}

/* Two worlds built alike and advanced alike (1 s of the sphere scene, in
   frames of 1/60 s) end bitwise alike; and a state set back (the replay a
   ghost's history does) runs to the same bits again: XPBD keeps nothing
   between steps that the state does not hold. */
static void test_deterministic_bit_for_bit(void **state) {
    gs_world *w[2];
    gs_agent *c[2], *b[2];
    static double s0[6 * 256 + 1], s1[6 * 256 + 1], mid[6 * 256 + 1];
    size_t n;
    int f, k;
    (void)state;
    for (k = 0; k < 2; ++k) sphere_scene(&w[k], &c[k], &b[k], GS_INTEGRATOR_XPBD, 0.0);
    n = gs_agent_state_size(c[0]);
    assert_int_equal((int)n, 6 * 256 + 1);
    for (f = 0; f < 60; ++f)
        for (k = 0; k < 2; ++k) {
            gs_result r = gs_world_advance(w[k], 1.0 / 60.0, NULL);
            CHECK(r == GS_OK, "frame %d: %s (%s)\n", f, gs_result_str(r), gs_world_error(w[k]));
            if (k == 0 && f == 29) assert_int_equal(gs_agent_get_state(c[0], mid, n), GS_OK);
        }
    assert_int_equal(gs_agent_get_state(c[0], s0, n), GS_OK);
    assert_int_equal(gs_agent_get_state(c[1], s1, n), GS_OK);
    print_message("two worlds: state hash %016llx and %016llx\n",
                  (unsigned long long)fnv(s0, n), (unsigned long long)fnv(s1, n));
    CHECK(memcmp(s0, s1, n * sizeof *s0) == 0, "two identical worlds differ\n");
    for (k = 0; k < 2; ++k) gs_world_destroy(w[k]);

    /* replay: the cloth alone, from a state set by hand, twice */
    assert_int_equal(gs_world_create(NULL, &w[0]), GS_OK);
    c[0] = cloth_make(w[0], 16, GS_INTEGRATOR_XPBD, 1e-3, 0);
    mid[0] = 0.0;
    assert_int_equal(gs_agent_set_state(c[0], mid, n), GS_OK);
    run(w[0], c[0], 300);
    assert_int_equal(gs_agent_get_state(c[0], s0, n), GS_OK);
    run(w[0], c[0], 17); /* somewhere else, then back */
    assert_int_equal(gs_agent_set_state(c[0], mid, n), GS_OK);
    run(w[0], c[0], 300);
    assert_int_equal(gs_agent_get_state(c[0], s1, n), GS_OK);
    CHECK(memcmp(s0, s1, n * sizeof *s0) == 0, "a replay from the same state differs\n");
    gs_world_destroy(w[0]);
}

/* The sphere lands on the cloth and stays on it: at every frame of 3 s its
   centre is above the cloth's middle particle and no particle is more than
   a third of its radius inside it, nothing is NaN, and over the last second
   (air damping 3 /s; the penalty contact keeps it bobbing by a few cm under
   every integrator) it rides, on average, within 10 mm of where it rides
   on the same cloth under symplectic Euler: the same scene, the same
   physics. XPBD's contacts are constraints of the same stiffness, so it
   keeps its 4 substeps a step where symplectic Euler substeps for them. */
static void test_contact_with_sphere(void **state) {
    double mean[2], depth[2], below[2];
    int k, f, i;
    (void)state;
    for (k = 0; k < 2; ++k) {
        gs_world *w;
        gs_agent *c, *b;
        sphere_scene(&w, &c, &b, k ? GS_INTEGRATOR_SYMPLECTIC_EULER : GS_INTEGRATOR_XPBD, 3.0);
        mean[k] = depth[k] = 0.0;
        below[k] = -1.0;
        for (f = 0; f < 180; ++f) {
            const gs_vec3 *x;
            gs_vec3 p;
            gs_result r = gs_world_advance(w, 1.0 / 60.0, NULL);
            CHECK(r == GS_OK, "frame %d: %s (%s)\n", f, gs_result_str(r), gs_world_error(w));
            x = gs_mesh_positions(c);
            p = gs_rigid_position(b);
            if (f >= 120) mean[k] += p.y / 60.0;
            if (x[8 * 16 + 8].y - p.y > below[k]) below[k] = x[8 * 16 + 8].y - p.y;
            for (i = 0; i < 256; ++i) {
                double dx = x[i].x - p.x, dy = x[i].y - p.y, dz = x[i].z - p.z;
                double d = 0.1 - sqrt(dx * dx + dy * dy + dz * dz);
                CHECK(isfinite(x[i].x + x[i].y + x[i].z), "particle %d not finite\n", i);
                if (d > depth[k]) depth[k] = d;
            }
        }
        if (k == 0) { /* contacts are constraints too: no substeps beyond the 4 */
            gs_agent_stats st = agent_stats(c);
            CHECK(st.substeps == 4 * st.steps, "XPBD took %llu substeps in %llu steps\n",
                  (unsigned long long)st.substeps, (unsigned long long)st.steps);
        }
        print_message("%s: sphere rides at y %.4f m on average over the last second; "
                      "deepest particle %.2f mm inside it; cloth middle at most %.4f m "
                      "above its centre\n",
                      k ? "symplectic" : "XPBD", mean[k], 1e3 * depth[k], below[k]);
        gs_world_destroy(w);
    }
    CHECK(below[0] < 0.0, "XPBD: the sphere went %.4f m below the cloth's middle\n", below[0]);
    CHECK(depth[0] < 0.1 / 3.0, "XPBD: a particle %.3g m inside the sphere\n", depth[0]);
    CHECK(fabs(mean[0] - mean[1]) < 0.01, "XPBD rides at %.4f m, symplectic Euler at %.4f m\n",
          mean[0], mean[1]);
}

/* A probe (the user's hand) pushed down into the middle of a resting cloth
   moves it: the middle particle ends below where it hung without the
   probe, by most of the push, and nothing is NaN. */
static void test_probe_pushes_cloth(void **state) {
    gs_world *w;
    gs_agent *c, *p;
    gs_probe_desc pd = gs_probe_desc_default();
    gs_quat q = {0.0, 0.0, 0.0, 1.0};
    double rest_y, pushed_y;
    int f;
    (void)state;
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    c = cloth_make(w, 16, GS_INTEGRATOR_XPBD, 1e-3, 0);
    for (f = 0; f < 60; ++f) assert_int_equal(gs_world_advance(w, 1.0 / 60.0, NULL), GS_OK);
    rest_y = gs_mesh_positions(c)[8 * 16 + 8].y;
    pd.shape.type = GS_SHAPE_SPHERE;
    pd.shape.radius = 0.05;
    pd.position.x = 0.5;
    pd.position.y = rest_y + 0.2;
    pd.position.z = 0.5;
    assert_int_equal(gs_probe_create(w, &pd, &p), GS_OK);
    for (f = 0; f < 60; ++f) {
        gs_vec3 to;
        to.x = 0.5;
        to.y = rest_y + 0.2 - 0.3 * (f + 1) / 60.0; /* 0.1 m below rest at the end */
        to.z = 0.5;
        assert_int_equal(gs_probe_set_target(p, to, q), GS_OK);
        assert_int_equal(gs_world_advance(w, 1.0 / 60.0, NULL), GS_OK);
    }
    pushed_y = gs_mesh_positions(c)[8 * 16 + 8].y;
    print_message("middle particle: %.4f m at rest, %.4f m under the probe (at %.4f m)\n",
                  rest_y, pushed_y, rest_y - 0.1);
    CHECK(isfinite(pushed_y) && pushed_y < rest_y - 0.05,
          "the probe moved the middle from %.4f m only to %.4f m\n", rest_y, pushed_y);
    gs_world_destroy(w);
}

/* A scene means the same under every integrator: a 24 x 24 cloth hung by
   its corners settles (air damping 2 /s, 4 s) to the same sag under XPBD
   as under implicit Euler, within 2%: compliance is 1 / k. */
static void test_same_sag_as_spring_mass(void **state) {
    double sag[2];
    int k, f;
    (void)state;
    for (k = 0; k < 2; ++k) {
        gs_world *w;
        gs_agent *c;
        gs_cloth_desc cd = gs_cloth_desc_default();
        assert_int_equal(gs_world_create(NULL, &w), GS_OK);
        cd.nx = cd.ny = 24;
        cd.pin_corners = GS_CORNER_ALL;
        cd.air_damping = 2.0;
        cd.solver.integrator = k ? GS_INTEGRATOR_IMPLICIT_EULER : GS_INTEGRATOR_XPBD;
        assert_int_equal(gs_cloth_create(w, &cd, &c), GS_OK);
        for (f = 0; f < 240; ++f) assert_int_equal(gs_world_advance(w, 1.0 / 60.0, NULL), GS_OK);
        sag[k] = -gs_mesh_positions(c)[12 * 24 + 12].y;
        gs_world_destroy(w);
    }
    print_message("sag: XPBD %.5f m, implicit Euler %.5f m\n", sag[0], sag[1]);
    CHECK(fabs(sag[0] / sag[1] - 1.0) < 0.02, "XPBD sags %.5f m, implicit Euler %.5f m\n",
          sag[0], sag[1]);
}

/* solver.substeps: zero means 4; a negative count is refused with a
   message naming the field; a rigid body refuses XPBD. */
static void test_substeps_field(void **state) {
    gs_world *w;
    gs_agent *c = NULL, *b = NULL;
    gs_cloth_desc cd = gs_cloth_desc_default();
    gs_rigid_desc rd = gs_rigid_desc_default();
    gs_result r;
    (void)state;
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    assert_int_equal(gs_solver_desc_default().substeps, 4);
    c = cloth_make(w, 4, GS_INTEGRATOR_XPBD, 1e-3, 0);
    run(w, c, 10);
    assert_int_equal((int)agent_stats(c).substeps, 40);
    CHECK(isinf(gs_mesh_stable_dt(c)), "XPBD stable dt %g, want +inf\n", gs_mesh_stable_dt(c));
    cd.nx = cd.ny = 4;
    cd.solver.integrator = GS_INTEGRATOR_XPBD;
    cd.solver.substeps = -1;
    r = gs_cloth_create(w, &cd, &c);
    print_message("substeps -1: %s: %s\n", gs_result_str(r), gs_world_error(w));
    CHECK(r != GS_OK && strstr(gs_world_error(w), "substeps") != NULL,
          "substeps -1: %s (%s)\n", gs_result_str(r), gs_world_error(w));
    rd.shape.type = GS_SHAPE_SPHERE;
    rd.shape.radius = 0.1;
    rd.solver.integrator = GS_INTEGRATOR_XPBD;
    r = gs_rigid_create(w, &rd, &b);
    CHECK(r == GS_ERR_INVALID_ARG, "rigid with XPBD: %s\n", gs_result_str(r));
    gs_world_destroy(w);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_converges_to_spring_mass),
        cmocka_unit_test(test_extremes_grid),
        cmocka_unit_test(test_deterministic_bit_for_bit),
        cmocka_unit_test(test_contact_with_sphere),
        cmocka_unit_test(test_probe_pushes_cloth),
        cmocka_unit_test(test_same_sag_as_spring_mass),
        cmocka_unit_test(test_substeps_field),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
