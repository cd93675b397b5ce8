/* test_sleep.c - sleeping rigid bodies (>>rigid, >>contact, >>sched).

   A body at rest for the world's sleep_time sleeps: it takes no steps and
   its time follows the world. These tests build a small resting stack
   (three boxes on the ground, a 2x2 layer of spheres on it), let it fall
   asleep, then wake it in each of the documented ways: a falling body, a
   probe that moves, a state set by hand, gs_agent_wake. Two identical
   worlds that sleep and wake must stay equal bit for bit. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <string.h>

#include "ghostsim.h"
#include "world_helpers.h"

#define FRAME (1.0 / 60.0)
#define STACK 3 /* boxes */
#define LAYER 4 /* spheres on top */
#define BODIES (STACK + LAYER)

typedef struct scene {
    gs_world *w;
    gs_agent *body[BODIES + 1]; /* + a falling sphere, when dropped */
    int n;
} scene;

static void scene_make_layer(scene *s, double sleep_time, int layer) {
    gs_world_desc wd = gs_world_desc_default();
    int i;
    memset(s, 0, sizeof *s);
    wd.sleep_time = sleep_time;
    assert_int_equal(gs_world_create(&wd, &s->w), GS_OK);
    assert_int_equal(gs_world_set_ground(s->w, 1, 0.0, gs_material_default()), GS_OK);
    for (i = 0; i < STACK; ++i) { /* 0.2 m cubes, 1 kg, resting on each other */
        gs_rigid_desc rd = gs_rigid_desc_default();
        rd.shape.type = GS_SHAPE_BOX;
        rd.shape.half_extents.x = rd.shape.half_extents.y = rd.shape.half_extents.z = 0.1;
        rd.mass = 1.0;
        rd.position.y = 0.1 + 0.2 * i;
        rd.rolling = 0.01;
        assert_int_equal(gs_rigid_create(s->w, &rd, &s->body[s->n++]), GS_OK);
    }
    for (i = 0; layer && i < LAYER; ++i) { /* four 3 cm spheres on the top box */
        gs_rigid_desc rd = gs_rigid_desc_default();
        rd.shape.type = GS_SHAPE_SPHERE;
        rd.shape.radius = 0.03;
        rd.position.x = i % 2 ? 0.05 : -0.05;
        rd.position.z = i / 2 ? 0.05 : -0.05;
        rd.position.y = 0.2 * STACK + 0.03;
        rd.rolling = 0.003;
        assert_int_equal(gs_rigid_create(s->w, &rd, &s->body[s->n++]), GS_OK);
    }
}

static void scene_make(scene *s, double sleep_time) { scene_make_layer(s, sleep_time, 1); }

static void advance(scene *s, double seconds) {
    int i, frames = (int)(seconds / FRAME + 0.5);
    for (i = 0; i < frames; ++i) assert_int_equal(gs_world_advance(s->w, FRAME, NULL), GS_OK);
}

/* A body created after the world has run starts at time 0: it is put at
   the world's time, as an application would. */
static void at_world_time(gs_agent *a) {
    double st[14];
    assert_int_equal(gs_agent_get_state(a, st, 14), GS_OK);
    st[0] = gs_world_time(gs_agent_world(a));
    assert_int_equal(gs_agent_set_state(a, st, 14), GS_OK);
}

static int asleep(const scene *s) {
    int i, n = 0;
    for (i = 0; i < s->n; ++i) n += gs_agent_sleeping(s->body[i]);
    return n;
}

static uint64_t steps_of(const scene *s) {
    uint64_t n = 0;
    int i;
    for (i = 0; i < s->n; ++i) n += agent_stats(s->body[i]).steps;
    return n;
}

/* A resting stack falls asleep, stops stepping, and its time follows the
   world's. */
static void test_sleep_resting_stack_sleeps(void **state) {
    scene s;
    uint64_t steps;
    int i;
    (void)state;
    scene_make(&s, 0.0);
    advance(&s, 3.0);
    assert_int_equal(asleep(&s), BODIES);
    for (i = 0; i < s.n; ++i) {
        gs_agent_stats st = agent_stats(s.body[i]);
        assert_true(st.sleeps >= 1);
        assert_true(gs_rigid_position(s.body[i]).y > 0.0); /* nothing fell through */
    }
    assert_true(fabs(gs_rigid_position(s.body[STACK - 1]).y - (0.2 * STACK - 0.1)) < 0.01);
    steps = steps_of(&s);
    advance(&s, 1.0);
    assert_true(steps_of(&s) == steps); /* no steps while asleep */
    for (i = 0; i < s.n; ++i) { /* its time is the world's */
        assert_true(fabs(gs_agent_time(s.body[i]) - gs_world_time(s.w)) < 1e-9);
        assert_true(gs_rigid_velocity(s.body[i]).y == 0.0);
    }
    /* a probe and a custom agent never sleep; NULL is not asleep */
    assert_int_equal(gs_agent_sleeping(NULL), 0);
    gs_world_destroy(s.w);
}

/* Switched off (sleep_time < 0), nothing sleeps; a bad desc is refused. */
static void test_sleep_off_and_desc(void **state) {
    scene s;
    gs_world *w = NULL;
    gs_world_desc wd = gs_world_desc_default();
    (void)state;
    scene_make(&s, -1.0);
    advance(&s, 2.0);
    assert_int_equal(asleep(&s), 0);
    gs_world_destroy(s.w);
    wd.sleep_speed = -1.0;
    assert_int_equal(gs_world_create(&wd, &w), GS_ERR_INVALID_ARG);
    assert_null(w);
    wd = gs_world_desc_default();
    wd.sleep_time = NAN;
    assert_int_equal(gs_world_create(&wd, &w), GS_ERR_NOT_FINITE);
    assert_null(w);
    assert_true(gs_world_desc_default().sleep_time == 0.5);
    assert_true(gs_world_desc_default().sleep_speed == 0.1);
}

/* A sleeping stack (the boxes alone) wakes when a falling sphere hits it,
   and the sphere does not pass through: the top sleeper is a fixed body
   until it wakes, then the pair is computed from the waker's time. The
   sphere ends at rest on the top box. */
static void test_sleep_stack_wakes_when_hit(void **state) {
    scene s;
    gs_rigid_desc rd = gs_rigid_desc_default();
    gs_agent *ball;
    gs_shape_desc shape, box;
    gs_quat q = {0.0, 0.0, 0.0, 1.0};
    gs_contact c;
    int hit = 0;
    double top = 0.2 * STACK;
    int i, woke = 0;
    (void)state;
    memset(&box, 0, sizeof box);
    box.type = GS_SHAPE_BOX;
    box.half_extents.x = box.half_extents.y = box.half_extents.z = 0.1;
    scene_make_layer(&s, 0.0, 0);
    advance(&s, 3.0);
    assert_int_equal(asleep(&s), STACK);
    rd.shape.type = GS_SHAPE_SPHERE;
    rd.shape.radius = 0.05;
    rd.mass = 1.0;
    rd.rolling = 0.005;
    rd.position.y = top + 0.5;
    shape = rd.shape;
    assert_int_equal(gs_rigid_create(s.w, &rd, &ball), GS_OK);
    at_world_time(ball);
    s.body[s.n++] = ball;
    for (i = 0; i < 120; ++i) {
        assert_int_equal(gs_world_advance(s.w, FRAME, NULL), GS_OK);
        woke |= !gs_agent_sleeping(s.body[STACK - 1]);
        /* it may knock the top box about, never pass into it */
        assert_true(gs_rigid_position(ball).y > gs_rigid_position(s.body[STACK - 1]).y);
        assert_int_equal(gs_collide_shapes(&shape, gs_rigid_position(ball), q, &box,
                                           gs_rigid_position(s.body[STACK - 1]),
                                           gs_rigid_orientation(s.body[STACK - 1]), &c, &hit),
                         GS_OK);
        assert_false(hit && c.depth > 0.02);
    }
    assert_true(woke);
    assert_true(agent_stats(s.body[STACK - 1]).wakes >= 1);
    assert_true(fabs(gs_rigid_position(ball).y - (top + 0.05)) < 0.01);
    /* the bodies still sit on one another */
    for (i = 0; i < STACK; ++i) assert_true(fabs(gs_rigid_position(s.body[i]).y - (0.1 + 0.2 * i)) < 0.02);
    gs_world_destroy(s.w);
}

/* Nothing sleeps while a moving probe touches it; a probe that comes to a
   sleeping stack wakes what it reaches. */
static void test_sleep_probe_keeps_awake(void **state) {
    scene s;
    gs_probe_desc pd = gs_probe_desc_default();
    gs_agent *probe;
    gs_quat q = {0.0, 0.0, 0.0, 1.0};
    double top = 0.2 * STACK;
    int i;
    (void)state;
    scene_make(&s, 0.0);
    /* a 1 cm sphere on a corner of the top box (clear of the small
       spheres), 0.5 mm under its top as built (the stack settles about
       0.3 mm into its contacts): some 20 N down on the stack */
    pd.shape.type = GS_SHAPE_SPHERE;
    pd.shape.radius = 0.01;
    pd.position.x = pd.position.z = 0.09;
    pd.position.y = top + 0.01 - 5e-4;
    assert_int_equal(gs_probe_create(s.w, &pd, &probe), GS_OK);
    for (i = 0; i < 180; ++i) { /* it presses 0.02 mm more or less, slowly */
        gs_vec3 p = pd.position;
        p.y += 2e-5 * sin(0.1 * i);
        assert_int_equal(gs_probe_set_target(probe, p, q), GS_OK);
        assert_int_equal(gs_world_advance(s.w, FRAME, NULL), GS_OK);
        assert_int_equal(gs_agent_sleeping(s.body[STACK - 1]), 0);
    }
    assert_true(agent_stats(s.body[STACK - 1]).sleeps == 0);
    /* held still, it is scenery: the stack sleeps */
    advance(&s, 3.0);
    assert_int_equal(gs_agent_sleeping(s.body[STACK - 1]), 1);
    /* moved against the top box's side, it wakes it */
    pd.position.x = 0.1 + 0.01 - 1e-4;
    pd.position.y = top - 0.1;
    pd.position.z = 0.0;
    assert_int_equal(gs_probe_set_target(probe, pd.position, q), GS_OK);
    for (i = 0; i < 30 && gs_agent_sleeping(s.body[STACK - 1]); ++i)
        assert_int_equal(gs_world_advance(s.w, FRAME, NULL), GS_OK);
    assert_int_equal(gs_agent_sleeping(s.body[STACK - 1]), 0);
    gs_world_destroy(s.w);
}

/* A state set by hand (as a ghost snapshot sets it) wakes a sleeper, and
   so do gs_agent_wake and gs_agent_step. */
static void test_sleep_set_state_wakes(void **state) {
    scene s;
    double st[14];
    uint64_t wakes;
    (void)state;
    scene_make(&s, 0.0);
    advance(&s, 3.0);
    assert_int_equal(asleep(&s), BODIES);
    assert_int_equal(gs_agent_get_state(s.body[0], st, 14), GS_OK);
    wakes = agent_stats(s.body[0]).wakes;
    assert_int_equal(gs_agent_set_state(s.body[0], st, 14), GS_OK);
    assert_int_equal(gs_agent_sleeping(s.body[0]), 0);
    assert_true(agent_stats(s.body[0]).wakes == wakes + 1);
    assert_int_equal(gs_agent_wake(s.body[1]), GS_OK);
    assert_int_equal(gs_agent_sleeping(s.body[1]), 0);
    assert_int_equal(gs_agent_wake(s.body[1]), GS_OK); /* awake: nothing */
    assert_int_equal(gs_agent_step(s.body[2]), GS_OK);
    assert_int_equal(gs_agent_sleeping(s.body[2]), 0);
    assert_int_equal(gs_agent_wake(NULL), GS_ERR_INVALID_ARG);
    /* at rest still, they fall asleep again */
    advance(&s, 1.5);
    assert_int_equal(asleep(&s), BODIES);
    gs_world_destroy(s.w);
}

/* Two identical worlds that sleep, are hit and wake give the same hash. */
static void test_sleep_deterministic(void **state) {
    scene a, b;
    int k, i;
    (void)state;
    scene_make(&a, 0.0);
    scene_make(&b, 0.0);
    for (k = 0; k < 2; ++k) {
        scene *s = k ? &b : &a;
        gs_rigid_desc rd = gs_rigid_desc_default();
        advance(s, 2.5);
        rd.shape.type = GS_SHAPE_SPHERE;
        rd.shape.radius = 0.05;
        rd.position.x = 0.04;
        rd.position.y = 0.2 * STACK + 0.3;
        assert_int_equal(gs_rigid_create(s->w, &rd, &s->body[s->n]), GS_OK);
        at_world_time(s->body[s->n++]);
        advance(s, 1.5);
    }
    assert_true(gs_world_hash(a.w) == gs_world_hash(b.w));
    for (i = 0; i < a.n; ++i) {
        assert_int_equal(gs_agent_sleeping(a.body[i]), gs_agent_sleeping(b.body[i]));
        assert_true(agent_stats(a.body[i]).wakes == agent_stats(b.body[i]).wakes);
    }
    assert_true(agent_stats(a.body[STACK - 1]).sleeps >= 1);
    gs_world_destroy(a.w);
    gs_world_destroy(b.w);
}

/* The world history re-runs advances in which bodies fall asleep and are
   woken bit for bit (gs_world_sync_test): the sleep state is in it. */
static void test_sleep_history_rerun(void **state) {
    scene s;
    gs_rigid_desc rd = gs_rigid_desc_default();
    gs_agent *ball;
    int bad = 0, i, slept = 0, woke = 0;
    (void)state;
    scene_make(&s, 0.0);
    rd.shape.type = GS_SHAPE_SPHERE;
    rd.shape.radius = 0.05;
    rd.position.y = 0.2 * STACK + 2.0; /* lands after the stack sleeps */
    assert_int_equal(gs_rigid_create(s.w, &rd, &ball), GS_OK);
    s.body[s.n++] = ball;
    for (i = 0; i < 240; ++i) {
        int before = asleep(&s), after;
        assert_int_equal(gs_world_advance(s.w, FRAME, NULL), GS_OK);
        after = asleep(&s);
        slept |= after > before;
        woke |= after < before;
        assert_int_equal(gs_world_sync_test(s.w, i < 8 ? 1 : 8, &bad), GS_OK);
        assert_int_equal(bad, -1);
    }
    assert_true(slept);
    assert_true(woke);
    gs_world_destroy(s.w);
}

/* The paper's scene at rest: the cloth (a whole mesh) and the spheres on it
   sleep once the probe is held still; a pin moved wakes the cloth, which
   then wakes the spheres as it moves under them. */
static void test_sleep_cloth_scene(void **state) {
    gs_world *w = NULL;
    gs_scene sc;
    gs_vec3 corner;
    int i, spheres = 0;
    uint64_t steps;
    (void)state;
    assert_int_equal(gs_world_create(NULL, &w), GS_OK);
    assert_int_equal(gs_scene_create(w, NULL, &sc), GS_OK);
    for (i = 0; i < 480; ++i) assert_int_equal(gs_world_advance(w, FRAME, NULL), GS_OK);
    assert_int_equal(gs_agent_sleeping(sc.cloth), 1);
    for (i = 0; i < sc.sphere_count; ++i) spheres += gs_agent_sleeping(sc.spheres[i]);
    assert_int_equal(spheres, sc.sphere_count);
    steps = agent_stats(sc.cloth).steps;
    assert_int_equal(gs_world_advance(w, 1.0, NULL), GS_OK);
    assert_true(agent_stats(sc.cloth).steps == steps);
    assert_true(fabs(gs_agent_time(sc.cloth) - gs_world_time(w)) < 1e-9);
    corner = gs_mesh_positions(sc.cloth)[0];
    corner.y += 0.1;
    assert_int_equal(gs_mesh_move_pin(sc.cloth, 0, corner), GS_OK);
    assert_int_equal(gs_agent_sleeping(sc.cloth), 0);
    for (i = 0; i < 60; ++i) assert_int_equal(gs_world_advance(w, FRAME, NULL), GS_OK);
    assert_true(agent_stats(sc.cloth).steps > steps);
    for (i = 0, spheres = 0; i < sc.sphere_count; ++i)
        spheres += agent_stats(sc.spheres[i]).wakes > 0;
    assert_true(spheres > 0);
    gs_world_destroy(w);
}

/* A ghosted body never sleeps: frozen at its own state, it would stop its
   hosts from meeting (the copies of a peer still moving it by a little).
   The same stack, every body under a ghost, stays awake; detached, it
   falls asleep. */
static void test_sleep_not_under_ghost(void **state) {
    scene s;
    int i;
    (void)state;
    scene_make(&s, 0.0);
    for (i = 0; i < s.n; ++i) {
        gs_ghost_desc gd = gs_ghost_desc_default();
        gd.object_id = (uint32_t)(100 + i);
        assert_int_equal(gs_ghost_attach(s.body[i], &gd), GS_OK);
    }
    advance(&s, 3.0);
    assert_int_equal(asleep(&s), 0);
    for (i = 0; i < s.n; ++i) assert_int_equal(gs_ghost_detach(s.body[i]), GS_OK);
    advance(&s, 1.0);
    assert_int_equal(asleep(&s), BODIES);
    gs_world_destroy(s.w);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sleep_resting_stack_sleeps),
        cmocka_unit_test(test_sleep_off_and_desc),
        cmocka_unit_test(test_sleep_stack_wakes_when_hit),
        cmocka_unit_test(test_sleep_probe_keeps_awake),
        cmocka_unit_test(test_sleep_set_state_wakes),
        cmocka_unit_test(test_sleep_deterministic),
        cmocka_unit_test(test_sleep_history_rerun),
        cmocka_unit_test(test_sleep_cloth_scene),
        cmocka_unit_test(test_sleep_not_under_ghost),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
