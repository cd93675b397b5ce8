/* test_pile.c - the broad phase at pile sizes (>>contact, >>rigid).

   What bench/physics's sphere pile leans on, checked with answers known
   without the broad phase: a pile in a box of four wall probes runs the
   same bit for bit twice; a wall probe whose bounding sphere spans the
   scene wakes the sleepers it touches and only those, whether its query
   walks the grid's cells over its box (a wall across many bodies) or the
   slab of bodies on x (a wall across few), upright or turned. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <string.h>

#include "ghostsim.h"
#include "world_helpers.h"

#define R 0.05       /* m, sphere radius */
#define SPACING 0.12 /* m: 2 cm between neighbours, so no contact among them */
#define SIDE 36      /* a SIDE x SIDE layer on the ground: an edge of more
                        spheres than a short query answer (put in order by
                        merging, not insertion) */
#define FRAME (1.0 / 60.0)

typedef struct layer {
    gs_world *w;
    gs_agent *ball[SIDE * SIDE];
} layer;

static double coord(int i) { return (i - 0.5 * (SIDE - 1)) * SPACING; }

/* SIDE x SIDE spheres resting on the ground, asleep. */
static void layer_make(layer *l) {
    gs_world_desc wd = gs_world_desc_default();
    int i, frames;
    memset(l, 0, sizeof *l);
    assert_int_equal(gs_world_create(&wd, &l->w), GS_OK);
    assert_int_equal(gs_world_set_ground(l->w, 1, 0.0, gs_material_default()), GS_OK);
    for (i = 0; i < SIDE * SIDE; ++i) {
        gs_rigid_desc rd = gs_rigid_desc_default();
        rd.shape.type = GS_SHAPE_SPHERE;
        rd.shape.radius = R;
        rd.position.x = coord(i % SIDE);
        rd.position.z = coord(i / SIDE);
        rd.position.y = R;
        rd.rolling = 0.005;
        assert_int_equal(gs_rigid_create(l->w, &rd, &l->ball[i]), GS_OK);
    }
    /* they settle into the ground (m g / k: 5 um) and sleep after 0.5 s
       below 0.1 m/s; 3 s is ample */
    for (frames = 0; frames < 180; ++frames)
        assert_int_equal(gs_world_advance(l->w, FRAME, NULL), GS_OK);
    for (i = 0; i < SIDE * SIDE; ++i) assert_int_equal(gs_agent_sleeping(l->ball[i]), 1);
}

/* A thin wall probe beside the layer, then moved 1 cm into the spheres of
   one edge: those wake, a far part stays asleep. along_x: the wall runs
   along x (every body is in its x slab: the grid's cells are fewer), else
   along z (its slab holds one column: the slab is smaller). Turned by yaw
   about y, it stands back so that its nearer end is as clear as the
   upright wall, and that end alone reaches the edge: the spheres there
   wake, those at the other end, 5 cm clear of it, sleep on (its box on each
   axis counts the turn: the box of its unturned extents is 2 cm short
   of them). */
static void wall_wakes_edge(int along_x, double yaw) {
    layer l;
    gs_probe_desc pd = gs_probe_desc_default();
    gs_agent *wall;
    gs_quat q;
    gs_vec3 target;
    double half = 0.5 * SIDE * SPACING + 0.3;
    double edge = coord(0) - R - 0.05 - 0.005 - half * fabs(sin(yaw)); /* 5 mm clear */
    int i, k, frames;
    layer_make(&l);
    q.x = q.z = 0.0;
    q.y = sin(0.5 * yaw);
    q.w = cos(0.5 * yaw);
    pd.shape.type = GS_SHAPE_BOX;
    pd.shape.half_extents.x = along_x ? half : 0.05;
    pd.shape.half_extents.y = 0.05;
    pd.shape.half_extents.z = along_x ? 0.05 : half;
    pd.position.y = 0.05;
    if (along_x) pd.position.z = edge;
    else pd.position.x = edge;
    pd.orientation = q;
    assert_int_equal(gs_probe_create(l.w, &pd, &wall), GS_OK);
    /* at rest beside the layer: nothing wakes */
    for (frames = 0; frames < 5; ++frames)
        assert_int_equal(gs_world_advance(l.w, FRAME, NULL), GS_OK);
    for (i = 0; i < SIDE * SIDE; ++i) assert_int_equal(gs_agent_sleeping(l.ball[i]), 1);
    /* 1.5 cm on: 1 cm into the edge's spheres */
    target = pd.position;
    if (along_x) target.z += 0.015;
    else target.x += 0.015;
    assert_int_equal(gs_probe_set_target(wall, target, q), GS_OK);
    for (frames = 0; frames < 2; ++frames)
        assert_int_equal(gs_world_advance(l.w, FRAME, NULL), GS_OK);
    if (yaw != 0.0) { /* yaw > 0 brings the wall's -x end (along x) or +z end (along z) nearer */
        int near_end = along_x ? 0 : (SIDE - 1) * SIDE, far_end = along_x ? SIDE - 1 : 0;
        assert_true(yaw > 0.0);
        assert_int_equal(gs_agent_sleeping(l.ball[near_end]), 0);
        assert_int_equal(gs_agent_sleeping(l.ball[far_end]), 1);
    }
    for (k = 0; yaw == 0.0 && k < SIDE; ++k) { /* the edge touched: row 0 or column 0 */
        int edge_i = along_x ? k : k * SIDE, far_i = along_x ? (SIDE - 1) * SIDE + k : k * SIDE + SIDE - 1;
        assert_int_equal(gs_agent_sleeping(l.ball[edge_i]), 0);
        assert_int_equal(gs_agent_sleeping(l.ball[far_i]), 1); /* 4.2 m away */
    }
    gs_world_destroy(l.w);
}

static void test_pile_wall_along_x_wakes_its_edge(void **state) {
    (void)state;
    wall_wakes_edge(1, 0.0);
}

static void test_pile_wall_along_z_wakes_its_edge(void **state) {
    (void)state;
    wall_wakes_edge(0, 0.0);
}

static void test_pile_turned_wall_wakes_its_edge(void **state) {
    (void)state;
    wall_wakes_edge(1, 0.02); /* 1.1 degrees: its ends 3 cm either side */
    wall_wakes_edge(0, 0.02);
}

/* n spheres dropped into a box of four walls, advanced 0.4 s: their
   states into st (13 each after the time). */
static void pile_run(int n, double *st) {
    gs_world *w;
    gs_world_desc wd = gs_world_desc_default();
    int side = (int)ceil(cbrt((double)n) - 1e-9), k, s, frames;
    double half = 0.5 * (side - 1) * SPACING + R + 0.03, height = side * SPACING + 0.4;
    gs_agent *a;
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    assert_int_equal(gs_world_set_ground(w, 1, 0.0, gs_material_default()), GS_OK);
    for (s = 0; s < 4; ++s) {
        gs_probe_desc pd = gs_probe_desc_default();
        double off = half + 0.05;
        pd.shape.type = GS_SHAPE_BOX;
        pd.shape.half_extents.x = s < 2 ? 0.05 : off + 0.05;
        pd.shape.half_extents.y = 0.5 * height;
        pd.shape.half_extents.z = s < 2 ? off + 0.05 : 0.05;
        pd.position.x = s == 0 ? -off : s == 1 ? off : 0.0;
        pd.position.y = 0.5 * height;
        pd.position.z = s == 2 ? -off : s == 3 ? off : 0.0;
        assert_int_equal(gs_probe_create(w, &pd, &a), GS_OK);
    }
    for (k = 0; k < n; ++k) { /* a lattice, each layer offset by a little */
        gs_rigid_desc rd = gs_rigid_desc_default();
        int i = k % side, j = (k / side) % side, l = k / (side * side);
        rd.shape.type = GS_SHAPE_SPHERE;
        rd.shape.radius = R;
        rd.position.x = (i - 0.5 * (side - 1)) * SPACING + 0.003 * ((k * 7) % 5 - 2);
        rd.position.z = (j - 0.5 * (side - 1)) * SPACING + 0.003 * ((k * 3) % 5 - 2);
        rd.position.y = R + 0.05 + l * SPACING;
        assert_int_equal(gs_rigid_create(w, &rd, &a), GS_OK);
    }
    for (frames = 0; frames < 24; ++frames)
        assert_int_equal(gs_world_advance(w, FRAME, NULL), GS_OK);
    for (k = 0; k < n; ++k) {
        double one[14];
        assert_int_equal(gs_agent_get_state(gs_world_agent(w, 4 + k), one, 14), GS_OK);
        memcpy(st + 13 * k, one + 1, 13 * sizeof *one);
    }
    gs_world_destroy(w);
}

static void test_pile_deterministic(void **state) {
    enum { N = 216 };
    static double a[13 * N], b[13 * N];
    int k, landed = 0;
    (void)state;
    pile_run(N, a);
    pile_run(N, b);
    assert_memory_equal(a, b, sizeof a);
    /* it fell and stayed sane: every sphere above the ground's overlap
       and the bottom layer down on the ground (0.4 s from 5 cm up) */
    for (k = 0; k < N; ++k) {
        assert_true(isfinite(a[13 * k + 1]) && a[13 * k + 1] > 0.9 * R);
        landed += a[13 * k + 1] < 1.1 * R;
    }
    assert_true(landed >= 36);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_pile_wall_along_x_wakes_its_edge),
        cmocka_unit_test(test_pile_wall_along_z_wakes_its_edge),
        cmocka_unit_test(test_pile_turned_wall_wakes_its_edge),
        cmocka_unit_test(test_pile_deterministic),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
