/* test_rigid.c - rigid bodies, probes, contacts (libccd and exact paths) and
   the paper's scene. SI units; every tolerance says where it comes from. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <string.h>

#include "ghostsim.h"

#define PI 3.14159265358979323846

static gs_world *world_with_ground(gs_material m) {
    gs_world *w;
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    assert_int_equal(gs_world_set_ground(w, 1, 0.0, m), GS_OK);
    return w;
}

static gs_agent *sphere(gs_world *w, double r, double mass, gs_vec3 p, gs_vec3 v,
                        gs_material m) {
    gs_rigid_desc d = gs_rigid_desc_default();
    gs_agent *a;
    d.shape.type = GS_SHAPE_SPHERE;
    d.shape.radius = r;
    d.mass = mass;
    d.position = p;
    d.velocity = v;
    d.material = m;
    assert_int_equal(gs_rigid_create(w, &d, &a), GS_OK);
    return a;
}

static gs_agent *box(gs_world *w, gs_vec3 half, double mass, gs_vec3 p) {
    gs_rigid_desc d = gs_rigid_desc_default();
    gs_agent *a;
    d.shape.type = GS_SHAPE_BOX;
    d.shape.half_extents = half;
    d.mass = mass;
    d.position = p;
    assert_int_equal(gs_rigid_create(w, &d, &a), GS_OK);
    return a;
}

static gs_vec3 v3(double x, double y, double z) {
    gs_vec3 v;
    v.x = x; v.y = y; v.z = z;
    return v;
}

static void run(gs_world *w, double seconds) {
    int f, n = (int)(seconds * 60.0 + 0.5);
    for (f = 0; f < n; ++f) assert_int_equal(gs_world_advance(w, 1.0 / 60.0, NULL), GS_OK);
}

static int state_finite(const gs_agent *a) {
    double s[64];
    size_t n = gs_agent_state_size(a), i;
    if (n > 64) return 1;
    gs_agent_get_state(a, s, n);
    for (i = 0; i < n; ++i)
        if (!isfinite(s[i])) return 0;
    return 1;
}

/* A 1 kg sphere of radius 0.1 m dropped from 0.5 m comes to rest with its
   centre at r - m g / k: the penalty spring holds its weight at a depth of
   m g / k = 98 um for k = 1e5 N/m. After 3 s the default damping (100 N s/m,
   damping ratio 0.16) has shrunk the bounce below 1 um; the bound 2 um
   allows for that residue. */
static void test_sphere_rests_on_ground(void **state) {
    gs_material m = gs_material_default();
    gs_world *w = world_with_ground(m);
    gs_agent *s = sphere(w, 0.1, 1.0, v3(0, 0.5, 0), v3(0, 0, 0), m);
    double want = 0.1 - 1.0 * 9.81 / m.stiffness;
    (void)state;
    run(w, 3.0);
    assert_true(fabs(gs_rigid_position(s).y - want) < 2e-6);
    assert_true(fabs(gs_rigid_velocity(s).y) < 1e-4);
    gs_world_destroy(w);
}

/* Two 1 kg spheres meet head on at 2 m/s each in zero gravity, frictionless.
   Returns the restitution (separation speed / approach speed) and checks
   momentum: the spheres step at different moments, so each sees the other
   up to one step (1 ms) off; that leaves an O(dt) imbalance in the impulse,
   bounded here by 1% of the 2 kg m/s each carries. */
static double head_on(double damping) {
    gs_world *w;
    gs_material m;
    gs_agent *a, *b;
    gs_vec3 zero = v3(0, 0, 0);
    double p;
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    assert_int_equal(gs_world_set_gravity(w, zero), GS_OK);
    m.stiffness = 1e5;
    m.damping = damping;
    m.friction = 0.0;
    a = sphere(w, 0.1, 1.0, v3(-0.3, 0, 0), v3(2, 0, 0), m);
    b = sphere(w, 0.1, 1.0, v3(0.3, 0, 0), v3(-2, 0, 0), m);
    run(w, 0.5);
    p = gs_rigid_velocity(a).x + gs_rigid_velocity(b).x;
    assert_true(fabs(p) < 0.02 * 2.0);
    p = (gs_rigid_velocity(b).x - gs_rigid_velocity(a).x) / 4.0;
    gs_world_destroy(w);
    return p;
}

/* Restitution follows the damping: the linear spring-dashpot gives
   e = exp(-pi zeta / sqrt(1 - zeta^2)), zeta = c / (2 sqrt(k m_eff)),
   m_eff = 0.5 kg. The penalty never pulls, so the contact ends a little
   before the dashpot would have taken its last share: e comes out a few
   percent above the formula (bound +10%, and never below it by more than
   the 1% of step effects). Undamped, e stays within 2% of 1. */
static void test_head_on_momentum_and_restitution(void **state) {
    double e0 = head_on(0.0), e1 = head_on(20.0), e2 = head_on(100.0);
    double z1 = 20.0 / (2.0 * sqrt(1e5 * 0.5)), z2 = 100.0 / (2.0 * sqrt(1e5 * 0.5));
    double f1 = exp(-PI * z1 / sqrt(1 - z1 * z1)), f2 = exp(-PI * z2 / sqrt(1 - z2 * z2));
    (void)state;
    print_message("restitution %.3f %.3f %.3f; linear model %.3f %.3f\n", e0, e1, e2, f1, f2);
    assert_true(fabs(e0 - 1.0) < 0.02);
    assert_true(e0 > e1 && e1 > e2);
    assert_true(e1 > f1 - 0.01 && e1 < f1 * 1.10);
    assert_true(e2 > f2 - 0.01 && e2 < f2 * 1.10);
}

/* A 0.2 m cube resting on a 1 m x 0.2 m x 1 m slab of 100 kg that rests on
   the ground. The slab settles into the ground in about 5 s (its damping
   ratio on the default material is 0.06); from then on the cube stays put
   for 10 s: height within 1 um (the corner springs hold it at a fixed
   depth), horizontal drift under 1 um and rotation under 1e-6 rad (nothing
   pushes it sideways). */
static void test_box_rests_on_box(void **state) {
    gs_world *w = world_with_ground(gs_material_default());
    gs_agent *slab = box(w, v3(0.5, 0.1, 0.5), 100.0, v3(0, 0.1, 0));
    gs_agent *cube = box(w, v3(0.1, 0.1, 0.1), 1.0, v3(0, 0.3, 0));
    double y_start;
    gs_quat q;
    (void)state;
    run(w, 5.0);
    y_start = gs_rigid_position(cube).y;
    run(w, 10.0);
    q = gs_rigid_orientation(cube);
    assert_true(fabs(gs_rigid_position(cube).x) < 1e-6 && fabs(gs_rigid_position(cube).z) < 1e-6);
    assert_true(fabs(gs_rigid_position(cube).y - y_start) < 1e-6);
    assert_true(fabs(q.x) < 1e-6 && fabs(q.y) < 1e-6 && fabs(q.z) < 1e-6);
    assert_true(gs_rigid_position(cube).y > gs_rigid_position(slab).y);
    gs_world_destroy(w);
}

/* The paper's scene with one sphere dropped onto the cloth's centre: after
   3 s it lies on the cloth (above the centre particle, slower than 1 cm/s)
   and the cloth under it sags below where it hung alone. */
static void test_sphere_rests_on_cloth(void **state) {
    gs_world *w;
    gs_scene sc;
    gs_scene_desc sd = gs_scene_desc_default();
    double st[14], before;
    int centre;
    (void)state;
    sd.sphere_count = 1;
    sd.probe_count = 0;
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    assert_int_equal(gs_scene_create(w, &sd, &sc), GS_OK);
    centre = sd.cloth_n / 2 + sd.cloth_n * (sd.cloth_n / 2);
    before = gs_mesh_positions(sc.cloth)[centre].y;
    assert_int_equal(gs_agent_get_state(sc.spheres[0], st, 14), GS_OK);
    st[1] = 0.0; st[2] = 0.3; st[3] = 0.0;
    assert_int_equal(gs_agent_set_state(sc.spheres[0], st, 14), GS_OK);
    run(w, 3.0);
    {
        gs_vec3 p = gs_rigid_position(sc.spheres[0]), v = gs_rigid_velocity(sc.spheres[0]);
        double cy = gs_mesh_positions(sc.cloth)[centre].y;
        print_message("cloth centre %.4f -> %.4f m, sphere at %.4f m\n", before, cy, p.y);
        assert_true(sqrt(v.x * v.x + v.y * v.y + v.z * v.z) < 0.01);
        assert_true(p.y > cy);
        assert_true(cy < before - 0.005);
    }
    gs_world_destroy(w);
}

static gs_shape_desc sphere_shape(double r) {
    gs_shape_desc s;
    memset(&s, 0, sizeof s);
    s.type = GS_SHAPE_SPHERE;
    s.radius = r;
    return s;
}

/* An icosahedron of circumradius 0.1 m: the 12 cyclic permutations of
   (0, +-1, +-phi). Its faces sit at 0.795 of the radius, so libccd's answer
   on it may differ from the exact sphere's by up to 0.21 r in depth, and
   its normal by the tilt of a facet. */
static int ico_points(gs_vec3 *p) {
    const double t = (1.0 + sqrt(5.0)) / 2.0, l = sqrt(1.0 + t * t);
    int s1, s2, n = 0;
    for (s1 = -1; s1 <= 1; s1 += 2)
        for (s2 = -1; s2 <= 1; s2 += 2) {
            p[n++] = v3(0.0, 0.1 * s1 / l, 0.1 * s2 * t / l);
            p[n++] = v3(0.1 * s1 / l, 0.1 * s2 * t / l, 0.0);
            p[n++] = v3(0.1 * s2 * t / l, 0.0, 0.1 * s1 / l);
        }
    return n;
}

static void test_libccd_matches_exact_spheres(void **state) {
    gs_vec3 pts[12];
    gs_shape_desc hull, ball = sphere_shape(0.1);
    gs_quat id = {0, 0, 0, 1};
    gs_contact exact, ccd;
    double gaps[4] = {0.19, 0.15, 0.1, 0.05};
    int i, n = ico_points(pts);
    (void)state;
    memset(&hull, 0, sizeof hull);
    hull.type = GS_SHAPE_HULL;
    hull.points = pts;
    hull.point_count = n;
    for (i = 0; i < 4; ++i) {
        gs_vec3 a = v3(gaps[i] * 0.6, gaps[i] * 0.8, 0.0), o = v3(0, 0, 0);
        assert_int_equal(gs_collide_shapes(&ball, a, id, &ball, o, id, &exact), 1);
        assert_true(fabs(exact.depth - (0.2 - gaps[i])) < 1e-12);
        assert_true(fabs(exact.normal.x - 0.6) < 1e-12 && fabs(exact.normal.y - 0.8) < 1e-12);
        assert_int_equal(gs_collide_shapes(&ball, a, id, &hull, o, id, &ccd), 1);
        /* the hull's faces sit up to 0.21 r inside the sphere: depth differs
           by at most that (0.021 m); the normal by the facet's tilt */
        assert_true(fabs(ccd.depth - exact.depth) < 0.021);
        assert_true(ccd.normal.x * 0.6 + ccd.normal.y * 0.8 > cos(0.4));
    }
}

static int unit_finite(gs_vec3 n) {
    double l = sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
    return isfinite(l) && fabs(l - 1.0) < 1e-9;
}

/* Touching, coincident and deeply overlapping shapes: every answer is
   finite with a unit normal (libccd can return a zero or NaN direction at
   depth 0 or coincident centres; ghostsim checks and falls back). */
static void test_degenerate_contacts_are_finite(void **state) {
    gs_vec3 pts[12];
    gs_shape_desc shapes[3];
    gs_quat id = {0, 0, 0, 1};
    double offsets[4] = {0.2, 0.0, 0.01, 1e-12};
    int i, j, k;
    (void)state;
    shapes[0] = sphere_shape(0.1);
    memset(&shapes[1], 0, sizeof shapes[1]);
    shapes[1].type = GS_SHAPE_BOX;
    shapes[1].half_extents = v3(0.1, 0.1, 0.1);
    memset(&shapes[2], 0, sizeof shapes[2]);
    shapes[2].type = GS_SHAPE_HULL;
    shapes[2].points = pts;
    shapes[2].point_count = ico_points(pts);
    for (i = 0; i < 3; ++i)
        for (j = 0; j < 3; ++j)
            for (k = 0; k < 4; ++k) {
                gs_contact c;
                int hit = gs_collide_shapes(&shapes[i], v3(offsets[k], 0, 0), id, &shapes[j],
                                            v3(0, 0, 0), id, &c);
                if (!hit) continue;
                assert_true(unit_finite(c.normal));
                assert_true(isfinite(c.depth) && c.depth >= 0.0);
                assert_true(isfinite(c.point.x) && isfinite(c.point.y) && isfinite(c.point.z));
            }
}

/* A box probe moving along +x at 0.5 m/s pushes a sphere across the ground.
   The probe follows its target exactly (nothing pushes it back) and the
   sphere ends up ahead of it, most of the probe's 0.6 m travel further on. */
static void test_probe_pushes_sphere(void **state) {
    gs_material m = gs_material_default();
    gs_world *w = world_with_ground(m);
    gs_probe_desc pd = gs_probe_desc_default();
    gs_agent *probe, *ball = sphere(w, 0.1, 1.0, v3(0.3, 0.1 - 9.81e-5, 0), v3(0, 0, 0), m);
    gs_quat id = {0, 0, 0, 1};
    int f;
    (void)state;
    pd.shape.type = GS_SHAPE_BOX;
    pd.shape.half_extents = v3(0.05, 0.1, 0.2);
    pd.position = v3(0.0, 0.1, 0.0);
    assert_int_equal(gs_probe_create(w, &pd, &probe), GS_OK);
    for (f = 1; f <= 72; ++f) { /* 1.2 s at 0.5 m/s */
        assert_int_equal(gs_probe_set_target(probe, v3(0.5 * f / 60.0, 0.1, 0.0), id), GS_OK);
        assert_int_equal(gs_world_advance(w, 1.0 / 60.0, NULL), GS_OK);
    }
    assert_true(fabs(gs_rigid_position(probe).x - 0.6) < 1e-9);
    assert_true(gs_rigid_position(ball).x > 0.6 + 0.05 + 0.1 - 0.01); /* in front of it */
    assert_true(gs_rigid_mass(probe) == 0.0);
    /* an absurd target: the probe moves at most max_speed (10 m/s) per second */
    assert_int_equal(gs_probe_set_target(probe, v3(1e6, 0.1, 0.0), id), GS_OK);
    assert_int_equal(gs_world_advance(w, 0.1, NULL), GS_OK);
    assert_true(gs_rigid_position(probe).x < 0.6 + 10.0 * 0.1 + 1e-9);
    gs_world_destroy(w);
}

/* Extremes. A 1000 kg box on a 1 kg box on the ground: everything stays
   finite and in order (the light box is not squeezed out). */
static void test_mass_ratio_stack(void **state) {
    gs_world *w = world_with_ground(gs_material_default());
    gs_agent *light = box(w, v3(0.2, 0.1, 0.2), 1.0, v3(0, 0.1, 0));
    gs_agent *heavy = box(w, v3(0.2, 0.1, 0.2), 1000.0, v3(0, 0.3, 0));
    (void)state;
    run(w, 5.0);
    assert_true(state_finite(light) && state_finite(heavy));
    assert_true(gs_rigid_position(heavy).y > gs_rigid_position(light).y + 0.15);
    assert_true(fabs(gs_rigid_position(light).x) < 1e-3);
    gs_world_destroy(w);
}

/* A 0.5 kg sphere thrown at 100 m/s at the hanging cloth. With
   continuous = 1 it substeps so that it never moves more than a quarter of
   its size at once: it is caught by the cloth (stays above the lowest
   particle near it) and nothing goes NaN. */
static void test_fast_sphere_into_cloth(void **state) {
    gs_world *w;
    gs_agent *c, *s;
    gs_cloth_desc cd = gs_cloth_desc_default();
    gs_rigid_desc d = gs_rigid_desc_default();
    int f, i;
    (void)state;
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    cd.nx = cd.ny = 16;
    cd.origin = v3(-0.5, 0.0, -0.5);
    cd.pin_corners = GS_CORNER_ALL;
    cd.spring_damping = 1.0;
    cd.solver.integrator = GS_INTEGRATOR_IMPLICIT_EULER;
    cd.solver.dt = 0.002;
    assert_int_equal(gs_cloth_create(w, &cd, &c), GS_OK);
    d.shape.type = GS_SHAPE_SPHERE;
    d.shape.radius = 0.1;
    d.mass = 0.5;
    d.position = v3(0, 0.5, 0);
    d.velocity = v3(0, -100, 0);
    d.continuous = 1;
    d.solver.dt = 0.002;
    d.solver.max_substeps = 1000;
    assert_int_equal(gs_rigid_create(w, &d, &s), GS_OK);
    for (f = 0; f < 120; ++f) {
        const gs_vec3 *x;
        double lowest = 1e9;
        assert_int_equal(gs_world_advance(w, 1.0 / 60.0, NULL), GS_OK);
        assert_true(state_finite(s));
        x = gs_mesh_positions(c);
        for (i = 0; i < 256; ++i) {
            assert_true(isfinite(x[i].x) && isfinite(x[i].y) && isfinite(x[i].z));
            if (fabs(x[i].x) < 0.15 && fabs(x[i].z) < 0.15 && x[i].y < lowest) lowest = x[i].y;
        }
        assert_true(gs_rigid_position(s).y > lowest - 0.1); /* not through */
    }
    assert_true(gs_agent_get_stats(s).substeps > gs_agent_get_stats(s).steps);
    gs_world_destroy(w);
}

/* Bad input: a clear code, a message naming the field, nothing created. */
static void expect_rigid_error(gs_rigid_desc d, gs_result code, const char *word) {
    gs_world *w;
    gs_agent *a = (gs_agent *)&w; /* not NULL, to see it cleared */
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    assert_int_equal(gs_rigid_create(w, &d, &a), code);
    assert_null(a);
    assert_int_equal(gs_world_agent_count(w), 0);
    assert_non_null(strstr(gs_world_error(w), word));
    gs_world_destroy(w);
}

static void test_bad_rigid_input(void **state) {
    gs_vec3 three[3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    gs_vec3 flat[4] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
    gs_vec3 line[5] = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}, {4, 0, 0}};
    gs_rigid_desc d = gs_rigid_desc_default(), e;
    (void)state;
    d.shape.type = GS_SHAPE_HULL;
    e = d; e.shape.points = three; e.shape.point_count = 3;
    expect_rigid_error(e, GS_ERR_INVALID_ARG, "point_count");
    e = d; e.shape.points = flat; e.shape.point_count = 4;
    expect_rigid_error(e, GS_ERR_INVALID_ARG, "plane");
    e = d; e.shape.points = line; e.shape.point_count = 5;
    expect_rigid_error(e, GS_ERR_INVALID_ARG, "plane");
    d.shape.type = GS_SHAPE_SPHERE;
    e = d; e.shape.radius = 0.0; expect_rigid_error(e, GS_ERR_INVALID_ARG, "radius");
    e = d; e.shape.radius = -1.0; expect_rigid_error(e, GS_ERR_INVALID_ARG, "radius");
    e = d; e.shape.radius = NAN; expect_rigid_error(e, GS_ERR_NOT_FINITE, "radius");
    d.shape.radius = 0.1;
    e = d; e.density = -5.0; expect_rigid_error(e, GS_ERR_INVALID_ARG, "density");
    e = d; e.position.y = NAN; expect_rigid_error(e, GS_ERR_NOT_FINITE, "position");
    e = d; e.orientation.w = NAN; expect_rigid_error(e, GS_ERR_NOT_FINITE, "orientation");
    e = d; e.shape.type = (gs_shape_type)99; expect_rigid_error(e, GS_ERR_INVALID_ARG, "shape.type");
    e = d; e.solver.integrator = GS_INTEGRATOR_IMPLICIT_EULER;
    expect_rigid_error(e, GS_ERR_INVALID_ARG, "implicit");
    e = d; e.shape.type = GS_SHAPE_BOX; e.shape.half_extents = v3(0.1, -0.1, 0.1);
    expect_rigid_error(e, GS_ERR_INVALID_ARG, "half_extents.y");
    {
        gs_world *w;
        gs_agent *p, *s;
        gs_probe_desc pd = gs_probe_desc_default();
        gs_vec3 nanp = {NAN, 0, 0};
        gs_quat id = {0, 0, 0, 1};
        gs_material bad = gs_material_default();
        assert_int_equal(gs_world_create(NULL, &w), GS_OK);
        pd.shape = sphere_shape(0.1);
        pd.dt = -1.0;
        assert_int_equal(gs_probe_create(w, &pd, &p), GS_ERR_INVALID_ARG);
        pd.dt = 0.0;
        assert_int_equal(gs_probe_create(w, &pd, &p), GS_OK);
        assert_int_equal(gs_probe_set_target(p, nanp, id), GS_ERR_NOT_FINITE);
        assert_int_equal(gs_agent_step(p), GS_OK);
        assert_true(gs_rigid_position(p).x == 0.0); /* the target did not change */
        s = sphere(w, 0.1, 1.0, v3(1, 1, 1), v3(0, 0, 0), gs_material_default());
        assert_int_equal(gs_probe_set_target(s, v3(0, 0, 0), id), GS_ERR_INVALID_ARG);
        assert_int_equal(gs_world_set_ground(w, 1, NAN, bad), GS_ERR_NOT_FINITE);
        bad.stiffness = -1.0;
        assert_int_equal(gs_world_set_ground(w, 1, 0.0, bad), GS_ERR_INVALID_ARG);
        gs_world_destroy(w);
    }
    {
        gs_world *w;
        gs_scene sc;
        gs_scene_desc sd = gs_scene_desc_default();
        assert_int_equal(gs_world_create(NULL, &w), GS_OK);
        sd.cloth_n = 1;
        assert_int_equal(gs_scene_create(w, &sd, &sc), GS_ERR_INVALID_ARG);
        sd = gs_scene_desc_default();
        sd.sphere_count = GS_SCENE_MAX_SPHERES + 1;
        assert_int_equal(gs_scene_create(w, &sd, &sc), GS_ERR_INVALID_ARG);
        assert_int_equal(gs_world_agent_count(w), 0);
        gs_world_destroy(w);
    }
}

/* Mass from shape and density: a 0.2 x 0.4 x 0.6 m box of 1000 kg/m^3 is
   48 kg; the hull of its eight corners is the same solid (1e-9 relative:
   a sum of 12 tetrahedra); a sphere of 0.1 m is 4/3 pi 1e-3 * 1000 kg. */
static void test_mass_properties(void **state) {
    gs_world *w;
    gs_agent *b, *h, *s;
    gs_rigid_desc d = gs_rigid_desc_default();
    gs_vec3 corners[8];
    int i;
    (void)state;
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    d.shape.type = GS_SHAPE_BOX;
    d.shape.half_extents = v3(0.1, 0.2, 0.3);
    assert_int_equal(gs_rigid_create(w, &d, &b), GS_OK);
    assert_true(fabs(gs_rigid_mass(b) - 48.0) < 1e-9);
    for (i = 0; i < 8; ++i)
        corners[i] = v3(i & 1 ? 0.1 : -0.1, i & 2 ? 0.2 : -0.2, i & 4 ? 0.3 : -0.3);
    d.shape.type = GS_SHAPE_HULL;
    d.shape.points = corners;
    d.shape.point_count = 8;
    assert_int_equal(gs_rigid_create(w, &d, &h), GS_OK);
    assert_true(fabs(gs_rigid_mass(h) / 48.0 - 1.0) < 1e-9);
    d.shape = sphere_shape(0.1);
    assert_int_equal(gs_rigid_create(w, &d, &s), GS_OK);
    assert_true(fabs(gs_rigid_mass(s) - 4.0 / 3.0 * PI * 1e-3 * 1000.0) < 1e-9);
    gs_world_destroy(w);
}

/* Rigid state round trip; a blended (non-unit) quaternion is renormalized on
   set; a zero quaternion is refused and changes nothing. */
static void test_rigid_state(void **state) {
    gs_world *w;
    gs_agent *s;
    double st[14], back[14];
    gs_quat q;
    (void)state;
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    s = sphere(w, 0.1, 1.0, v3(1, 2, 3), v3(4, 5, 6), gs_material_default());
    assert_int_equal(gs_agent_state_size(s), 14u);
    assert_int_equal(gs_agent_get_state(s, st, 14), GS_OK);
    assert_true(st[1] == 1 && st[2] == 2 && st[3] == 3 && st[7] == 1 && st[8] == 4);
    st[4] = 0.0; st[5] = 0.0; st[6] = 0.0; st[7] = 2.0; /* |q| = 2 */
    assert_int_equal(gs_agent_set_state(s, st, 14), GS_OK);
    q = gs_rigid_orientation(s);
    assert_true(fabs(q.w - 1.0) < 1e-15);
    assert_int_equal(gs_agent_get_state(s, back, 14), GS_OK);
    st[7] = 0.0;
    assert_int_equal(gs_agent_set_state(s, st, 14), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_agent_get_state(s, st, 14), GS_OK);
    assert_memory_equal(st, back, sizeof st);
    gs_world_destroy(w);
}

/* The paper's scene, twice, with the same probe path: bit-identical. */
static uint64_t scene_hash(void) {
    gs_world *w;
    gs_scene sc;
    gs_scene_desc sd = gs_scene_desc_default();
    gs_quat id = {0, 0, 0, 1};
    uint64_t h;
    int f;
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    assert_int_equal(gs_scene_create(w, &sd, &sc), GS_OK);
    for (f = 1; f <= 60; ++f) {
        gs_probe_set_target(sc.probes[0], gs_scene_probe_path(0, f / 60.0), id);
        assert_int_equal(gs_world_advance(w, 1.0 / 60.0, NULL), GS_OK);
    }
    h = gs_world_hash(w);
    gs_world_destroy(w);
    return h;
}

static void test_scene_determinism(void **state) {
    (void)state;
    assert_true(scene_hash() == scene_hash());
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sphere_rests_on_ground),
        cmocka_unit_test(test_head_on_momentum_and_restitution),
        cmocka_unit_test(test_box_rests_on_box),
        cmocka_unit_test(test_sphere_rests_on_cloth),
        cmocka_unit_test(test_libccd_matches_exact_spheres),
        cmocka_unit_test(test_degenerate_contacts_are_finite),
        cmocka_unit_test(test_probe_pushes_sphere),
        cmocka_unit_test(test_mass_ratio_stack),
        cmocka_unit_test(test_fast_sphere_into_cloth),
        cmocka_unit_test(test_bad_rigid_input),
        cmocka_unit_test(test_mass_properties),
        cmocka_unit_test(test_rigid_state),
        cmocka_unit_test(test_scene_determinism),
    };
    return cmocka_run_group_tests_name("rigid", tests, NULL, NULL);
}
