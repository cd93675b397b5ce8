/* test_errors.c - every bad input gets a clear gs_result and changes nothing.

   The header's promise (ERRORS): bad data from outside is an error code,
   never an assert; a failed call changes nothing; gs_world_error() says
   what was wrong. Each case below feeds one bad field to a create call that
   is otherwise valid and checks the code, that *out is NULL, that the world
   kept its agents and its memory, and that the message names the field. */
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

/* ---- a counting allocator (alloc_helpers.h): a failed call must not
   leak or allocate ---- */

static void destroy_counted(gs_world *w, const counter *c) {
    gs_world_destroy(w);
    assert_int_equal(c->allocs, c->frees);
}

/* A pointer that is not NULL, to see that a failed call clears *out. */
static int not_null_target;
#define NOT_NULL_AGENT ((gs_agent *)(void *)&not_null_target)

/* ---- the checking helpers ---- */

/* After a failed create: the right code, *out NULL, no agent added, no
   memory kept, and a message that names `word`. Returns 1 if all hold; on
   failure it prints what was wrong (the caller's assert gives the line). */
static int failed_cleanly(gs_world *w, const counter *c, const char *what,
                          gs_result got, gs_result want, const gs_agent *out, int count,
                          long live, const char *word) {
    const char *msg = gs_world_error(w);
    int ok = 1;
    if (got != want) {
        print_error("%s: returned %d (%s), want %d (%s)\n", what, (int)got,
                    gs_result_str(got), (int)want, gs_result_str(want));
        ok = 0;
    }
    if (out != NULL) {
        print_error("%s: *out is not NULL\n", what);
        ok = 0;
    }
    if (gs_world_agent_count(w) != count) {
        print_error("%s: agent count went from %d to %d\n", what, count,
                    gs_world_agent_count(w));
        ok = 0;
    }
    if (live_blocks(c) != live) {
        print_error("%s: %ld blocks live before, %ld after\n", what, live,
                    live_blocks(c));
        ok = 0;
    }
    if (!msg || !*msg || (word && !strstr(msg, word))) {
        print_error("%s: message \"%s\" does not name \"%s\"\n", what,
                    msg ? msg : "(null)", word ? word : "");
        ok = 0;
    }
    return ok;
}

static int cloth_fails(gs_world *w, const counter *c, const gs_cloth_desc *d,
                       gs_result want, const char *word) {
    gs_agent *out = NOT_NULL_AGENT;
    int count = gs_world_agent_count(w);
    long live = live_blocks(c);
    gs_result r = gs_cloth_create(w, d, &out);
    return failed_cleanly(w, c, "gs_cloth_create", r, want, out, count, live,
                          word);
}

static int mesh_fails(gs_world *w, const counter *c, const gs_mesh_desc *d,
                      gs_result want, const char *word) {
    gs_agent *out = NOT_NULL_AGENT;
    int count = gs_world_agent_count(w);
    long live = live_blocks(c);
    gs_result r = gs_mesh_create(w, d, &out);
    return failed_cleanly(w, c, "gs_mesh_create", r, want, out, count, live,
                          word);
}

static int custom_fails(gs_world *w, const counter *c, const gs_custom_desc *d,
                        gs_result want, const char *word) {
    gs_agent *out = NOT_NULL_AGENT;
    int count = gs_world_agent_count(w);
    long live = live_blocks(c);
    gs_result r = gs_custom_create(w, d, &out);
    return failed_cleanly(w, c, "gs_custom_create", r, want, out, count, live,
                          word);
}

/* gs_world_create has no world to hold a message: code and *out only. */
static int world_fails(const gs_world_desc *d, gs_result want) {
    gs_world *w = (gs_world *)(void *)&not_null_target;
    gs_result r = gs_world_create(d, &w);
    if (r != want || w != NULL) {
        print_error("gs_world_create: returned %d (%s), want %d (%s); "
                    "*out %s\n", (int)r, gs_result_str(r), (int)want,
                    gs_result_str(want), w ? "not NULL" : "NULL");
        if (r == GS_OK && w) gs_world_destroy(w);
        return 0;
    }
    return 1;
}

/* ---- result strings ---- */

static void test_errors_result_str(void **state) {
#define CODE(name, value, text) name,
    static const gs_result codes[] = {GS__RESULT_LIST(CODE)};
#undef CODE
#define TEXT(name, value, text) text,
    static const char *const texts[] = {GS__RESULT_LIST(TEXT)};
#undef TEXT
    const size_t n = sizeof codes / sizeof codes[0];
    size_t i, j;
    (void)state;
    assert_true(n >= 9);
    assert_int_equal(GS_OK, 0);
    for (i = 0; i < n; ++i) {
        const char *s = gs_result_str(codes[i]);
        assert_non_null(s);
        assert_true(strlen(s) > 0);
        assert_string_equal(s, texts[i]);
        if (i > 0) assert_true(codes[i] < 0); /* errors are negative */
        for (j = 0; j < i; ++j) {
            assert_int_not_equal(codes[i], codes[j]);
            assert_string_not_equal(s, gs_result_str(codes[j]));
        }
    }
    assert_non_null(gs_result_str((gs_result)-999));
    assert_true(strlen(gs_result_str((gs_result)-999)) > 0);
    assert_non_null(gs_result_str((gs_result)12345));
    for (i = 0; i < n; ++i) /* and it is none of the known ones */
        assert_string_not_equal(gs_result_str((gs_result)-999), texts[i]);
}

/* ---- gs_world_create ---- */

static void test_errors_world_create(void **state) {
    counter cnt;
    gs_world_desc d;
    gs_world *w;
    (void)state;
    assert_int_equal(gs_world_create(NULL, NULL), GS_ERR_INVALID_ARG);
    d = gs_world_desc_default();
    assert_int_equal(gs_world_create(&d, NULL), GS_ERR_INVALID_ARG);

    d = gs_world_desc_default(); d.queue_count = -1;
    assert_true(world_fails(&d, GS_ERR_INVALID_ARG));
    d = gs_world_desc_default(); d.queue_count = 65;
    assert_true(world_fails(&d, GS_ERR_INVALID_ARG));
    d = gs_world_desc_default(); d.queue_count = 1000000;
    assert_true(world_fails(&d, GS_ERR_INVALID_ARG));
    d = gs_world_desc_default(); d.tolerance = -0.001;
    assert_true(world_fails(&d, GS_ERR_INVALID_ARG));
    d = gs_world_desc_default(); d.tolerance = NAN;
    assert_true(world_fails(&d, GS_ERR_NOT_FINITE));
    d = gs_world_desc_default(); d.tolerance = INFINITY;
    assert_true(world_fails(&d, GS_ERR_NOT_FINITE));
    d = gs_world_desc_default(); d.budget = -1.0;
    assert_true(world_fails(&d, GS_ERR_INVALID_ARG));
    d = gs_world_desc_default(); d.budget = NAN;
    assert_true(world_fails(&d, GS_ERR_NOT_FINITE));
    d = gs_world_desc_default(); d.gravity.y = NAN;
    assert_true(world_fails(&d, GS_ERR_NOT_FINITE));
    d = gs_world_desc_default(); d.gravity.x = -INFINITY;
    assert_true(world_fails(&d, GS_ERR_NOT_FINITE));
    d = gs_world_desc_default(); d.aging_limit = -1;
    assert_true(world_fails(&d, GS_ERR_INVALID_ARG));
    d = counted_world_desc(&cnt); d.allocator.free = NULL; /* one without the other */
    assert_true(world_fails(&d, GS_ERR_INVALID_ARG));
    d = counted_world_desc(&cnt); d.allocator.alloc = NULL;
    assert_true(world_fails(&d, GS_ERR_INVALID_ARG));

    /* the limits themselves are fine */
    d = gs_world_desc_default(); d.queue_count = 64;
    assert_int_equal(gs_world_create(&d, &w), GS_OK);
    gs_world_destroy(w);
    d = gs_world_desc_default(); d.queue_count = 1;
    assert_int_equal(gs_world_create(&d, &w), GS_OK);
    gs_world_destroy(w);
}

/* ---- gs_cloth_create ---- */

static gs_cloth_desc good_cloth(void) {
    gs_cloth_desc d = gs_cloth_desc_default();
    d.nx = d.ny = 4;
    d.pin_corners = GS_CORNER_ALL;
    return d;
}

static void test_errors_cloth_create(void **state) {
    counter cnt;
    gs_world *w = counted_world(&cnt, 1);
    gs_cloth_desc d;
    gs_agent *out = NOT_NULL_AGENT;
    int pin_big[1] = {16}, pin_neg[2] = {0, -1};
    (void)state;
    /* the base desc is good */
    d = good_cloth();
    assert_int_equal(gs_cloth_create(w, &d, &out), GS_OK);
    assert_non_null(out);
    assert_int_equal(gs_world_agent_count(w), 1);

    out = NOT_NULL_AGENT;
    assert_int_equal(gs_cloth_create(w, NULL, &out), GS_ERR_INVALID_ARG);
    assert_null(out);
    d = good_cloth();
    assert_int_equal(gs_cloth_create(w, &d, NULL), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_cloth_create(NULL, &d, &out), GS_ERR_INVALID_ARG);

    /* sizes */
    d = good_cloth(); d.nx = 1;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "nx"));
    d = good_cloth(); d.nx = -3;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "nx"));
    d = good_cloth(); d.ny = 1;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "ny"));
    d = good_cloth(); d.width = -1.0; /* 0 means the default */
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "width"));
    d = good_cloth(); d.height = -0.5;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "height"));
    d = good_cloth(); d.mass = -1.0;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "mass"));
    /* stiffness and damping */
    d = good_cloth(); d.stretch_stiffness = -10.0;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "stretch_stiffness"));
    d = good_cloth(); d.shear_stiffness = -10.0;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "shear_stiffness"));
    d = good_cloth(); d.bend_stiffness = -1.0;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "bend_stiffness"));
    d = good_cloth(); d.spring_damping = -0.1;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "spring_damping"));
    d = good_cloth(); d.air_damping = -0.1;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "air_damping"));
    d = good_cloth(); d.particle_radius = -0.01;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "particle_radius"));
    d = good_cloth(); d.material.stiffness = -1.0;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "stiffness"));
    /* NaN and infinity anywhere */
    d = good_cloth(); d.origin.x = NAN;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_NOT_FINITE, "origin"));
    d = good_cloth(); d.origin.z = INFINITY;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_NOT_FINITE, "origin"));
    d = good_cloth(); d.width = NAN;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_NOT_FINITE, "width"));
    d = good_cloth(); d.height = INFINITY;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_NOT_FINITE, "height"));
    d = good_cloth(); d.mass = NAN;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_NOT_FINITE, "mass"));
    d = good_cloth(); d.spring_damping = NAN;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_NOT_FINITE, "damping"));
    d = good_cloth(); d.air_damping = NAN;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_NOT_FINITE, "air_damping"));
    d = good_cloth(); d.stretch_stiffness = NAN;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_NOT_FINITE, "stretch_stiffness"));
    d = good_cloth(); d.axis_v.y = NAN;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_NOT_FINITE, "axis_v"));
    d = good_cloth(); d.solver.dt = NAN;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_NOT_FINITE, "dt"));
    d = good_cloth(); d.solver.dt = INFINITY;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_NOT_FINITE, "dt"));
    d = good_cloth(); d.material = gs_material_default();
    d.material.damping = NAN; /* a material that is not all zero is taken
                                 field by field */
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_NOT_FINITE, "material.damping"));
    /* the step */
    d = good_cloth(); d.solver.dt = -0.001; /* 0 means the default */
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "dt"));
    /* pins */
    d = good_cloth(); d.pin_count = 1; d.pins = pin_big;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_OUT_OF_RANGE, "pins"));
    d = good_cloth(); d.pin_count = 2; d.pins = pin_neg;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_OUT_OF_RANGE, "pins"));
    d = good_cloth(); d.pin_count = 1; d.pins = NULL;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "pins"));
    d = good_cloth(); d.pin_count = -1; d.pins = pin_big;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "pin_count"));
    d = good_cloth(); d.pin_corners = 16;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "pin_corners"));
    d = good_cloth(); d.springs = 8;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "springs"));
    /* axes: parallel (a zero axis means the default, so it is not an
       error; tested on the non-zero parallel and antiparallel cases) */
    d = good_cloth();
    d.axis_u.x = 1.0; d.axis_u.y = 0.0; d.axis_u.z = 0.0;
    d.axis_v.x = 2.0; d.axis_v.y = 0.0; d.axis_v.z = 0.0;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "axis"));
    d = good_cloth();
    d.axis_u.x = 0.0; d.axis_u.y = 0.0; d.axis_u.z = 1.0;
    d.axis_v.x = 0.0; d.axis_v.y = 0.0; d.axis_v.z = -3.0;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "axis"));
    d = good_cloth(); /* only axis_u given, along the default axis_v */
    d.axis_u.x = 0.0; d.axis_u.y = 0.0; d.axis_u.z = 0.5;
    d.axis_v.x = 0.0; d.axis_v.y = 0.0; d.axis_v.z = 0.0;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "axis"));
    /* solver enums and limits */
    d = good_cloth(); d.solver.integrator = (gs_integrator)99;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "integrator"));
    d = good_cloth(); d.solver.integrator = GS__INTEGRATOR_COUNT;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "integrator"));
    d = good_cloth(); d.solver.integrator = (gs_integrator)-1;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "integrator"));
    d = good_cloth(); d.solver.stability = GS__STABILITY_COUNT;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "stability"));
    d = good_cloth(); d.solver.stability = (gs_stability)-2;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "stability"));
    d = good_cloth(); d.solver.max_substeps = -1;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "max_substeps"));
    d = good_cloth(); d.solver.safety = 1.5;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "safety"));
    d = good_cloth(); d.solver.safety = -0.5; /* 0 means the default */
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "safety"));
    d = good_cloth(); d.solver.safety = NAN;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_NOT_FINITE, "safety"));
    d = good_cloth(); d.solver.max_speed = -1.0;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "max_speed"));
    d = good_cloth(); d.solver.cg_tolerance = -1e-6;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "cg_tolerance"));
    d = good_cloth(); d.solver.cg_max_iterations = -5;
    assert_true(cloth_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "cg_max_iterations"));

    /* still usable after all that, and the good limits pass */
    d = good_cloth(); d.solver.safety = 1.0; d.nx = 2; d.ny = 2;
    out = NULL;
    assert_int_equal(gs_cloth_create(w, &d, &out), GS_OK);
    assert_non_null(out);
    assert_int_equal(gs_world_agent_count(w), 2);
    assert_int_equal(gs_world_advance(w, 0.01, NULL), GS_OK);
    destroy_counted(w, &cnt);
}

/* ---- gs_mesh_create ---- */

static const gs_vec3 tri[3] = {{0, 0, 0}, {0.1, 0, 0}, {0, 0.1, 0}};

static gs_spring springs3[3];

static gs_mesh_desc good_mesh(void) {
    gs_mesh_desc d = gs_mesh_desc_default();
    int i;
    for (i = 0; i < 3; ++i) {
        springs3[i].a = i;
        springs3[i].b = (i + 1) % 3;
        springs3[i].rest_length = 0.0;
        springs3[i].stiffness = 100.0;
        springs3[i].damping = 0.1;
    }
    d.particle_count = 3;
    d.positions = tri;
    d.spring_count = 3;
    d.springs = springs3;
    return d;
}

static void test_errors_mesh_create(void **state) {
    counter cnt;
    gs_world *w = counted_world(&cnt, 1);
    gs_mesh_desc d;
    gs_agent *out = NULL;
    gs_vec3 bad_pos[3] = {{0, 0, 0}, {0.1, 0, 0}, {0, 0.1, 0}};
    gs_vec3 bad_vel[3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
    double masses[3] = {0.1, 0.1, 0.1};
    int pins[2] = {0, 3};
    (void)state;
    d = good_mesh();
    assert_int_equal(gs_mesh_create(w, &d, &out), GS_OK);
    assert_non_null(out);
    assert_int_equal(gs_world_agent_count(w), 1);

    out = NOT_NULL_AGENT;
    assert_int_equal(gs_mesh_create(w, NULL, &out), GS_ERR_INVALID_ARG);
    assert_null(out);

    d = good_mesh(); d.particle_count = 0;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "particle_count"));
    d = good_mesh(); d.particle_count = -2;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "particle_count"));
    d = good_mesh(); d.positions = NULL;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "positions"));
    /* springs to missing particles */
    d = good_mesh(); springs3[1].b = -1;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_OUT_OF_RANGE, "spring"));
    d = good_mesh(); springs3[2].a = 3;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_OUT_OF_RANGE, "spring"));
    d = good_mesh(); springs3[0].b = 1000;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_OUT_OF_RANGE, "spring"));
    /* a spring from a particle to itself */
    d = good_mesh(); springs3[1].b = springs3[1].a;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "spring"));
    d = good_mesh(); d.springs = NULL;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "springs"));
    d = good_mesh(); d.spring_count = -1;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "spring_count"));
    /* spring parameters */
    d = good_mesh(); springs3[0].stiffness = 0.0;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "stiffness"));
    d = good_mesh(); springs3[2].stiffness = -5.0;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "stiffness"));
    d = good_mesh(); springs3[1].damping = -0.5;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "damping"));
    d = good_mesh(); springs3[1].stiffness = NAN;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_NOT_FINITE, "stiffness"));
    d = good_mesh(); springs3[0].rest_length = -0.1;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "rest_length"));
    /* masses */
    d = good_mesh(); masses[1] = 0.0; d.masses = masses;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "masses"));
    d = good_mesh(); masses[1] = 0.1; masses[2] = -1.0; d.masses = masses;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "masses"));
    d = good_mesh(); masses[2] = NAN; d.masses = masses;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_NOT_FINITE, "masses"));
    masses[2] = 0.1;
    d = good_mesh(); d.mass = -1.0;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "mass"));
    /* NaN positions and velocities */
    d = good_mesh(); bad_pos[2].y = NAN; d.positions = bad_pos;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_NOT_FINITE, "positions"));
    d = good_mesh(); bad_vel[1].z = INFINITY; d.velocities = bad_vel;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_NOT_FINITE, "velocities"));
    /* pins */
    d = good_mesh(); d.pin_count = 2; d.pins = pins;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_OUT_OF_RANGE, "pins"));
    pins[1] = -1;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_OUT_OF_RANGE, "pins"));
    /* the rest */
    d = good_mesh(); d.air_damping = -1.0;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "air_damping"));
    d = good_mesh(); d.particle_radius = -0.01;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "particle_radius"));
    d = good_mesh(); d.solver.dt = -1.0;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "dt"));
    d = good_mesh(); d.solver.integrator = GS__INTEGRATOR_COUNT;
    assert_true(mesh_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "integrator"));

    d = good_mesh();
    assert_int_equal(gs_mesh_create(w, &d, &out), GS_OK);
    assert_int_equal(gs_world_agent_count(w), 2);
    destroy_counted(w, &cnt);
}

/* ---- gs_custom_create ---- */

static void test_errors_custom_create(void **state) {
    counter cnt;
    gs_world *w = counted_world(&cnt, 1);
    two_values c;
    gs_custom_desc d;
    gs_agent *out = NOT_NULL_AGENT;
    (void)state;
    memset(&c, 0, sizeof c);
    assert_int_equal(gs_custom_create(w, NULL, &out), GS_ERR_INVALID_ARG);
    assert_null(out);
    d = two_values_desc(&c);
    assert_int_equal(gs_custom_create(w, &d, NULL), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_custom_create(NULL, &d, &out), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_world_agent_count(w), 0);

    d = two_values_desc(&c); d.dt = 0.5 * GS_MIN_DT; /* 0 is the default (test_api) */
    assert_true(custom_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "dt"));
    d = two_values_desc(&c); d.dt = -0.01;
    assert_true(custom_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "dt"));
    d = two_values_desc(&c); d.dt = NAN;
    assert_true(custom_fails(w, &cnt, &d, GS_ERR_NOT_FINITE, "dt"));
    d = two_values_desc(&c); d.dt = INFINITY;
    assert_true(custom_fails(w, &cnt, &d, GS_ERR_NOT_FINITE, "dt"));
    d = two_values_desc(&c); d.step = NULL;
    assert_true(custom_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "step"));
    d = two_values_desc(&c); d.get_state = NULL;
    assert_true(custom_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "get_state"));
    d = two_values_desc(&c); d.set_state = NULL;
    assert_true(custom_fails(w, &cnt, &d, GS_ERR_INVALID_ARG, "set_state"));

    /* state_size 0 needs neither */
    d = two_values_desc(&c); d.state_size = 0; d.get_state = NULL;
    d.set_state = NULL;
    assert_int_equal(gs_custom_create(w, &d, &out), GS_OK);
    assert_int_equal(gs_agent_state_size(out), 1);
    assert_int_equal(gs_world_agent_count(w), 1);
    destroy_counted(w, &cnt);
}

/* ---- gs_world_advance ---- */

static void test_errors_advance(void **state) {
    counter cnt;
    gs_world *w = counted_world(&cnt, 1);
    two_values c;
    gs_custom_desc d;
    gs_agent *a;
    gs_advance_report rep;
    static const double bad[] = {-1.0, -1e-12, -1e300};
    gs_result r_nan, r_inf, r_ninf;
    size_t i;
    (void)state;
    memset(&c, 0, sizeof c);
    d = two_values_desc(&c);
    assert_int_equal(gs_custom_create(w, &d, &a), GS_OK);
    assert_int_equal(gs_world_advance(w, 0.1, NULL), GS_OK);
    assert_int_equal(c.steps, 10);
    for (i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
        assert_int_equal(gs_world_advance(w, bad[i], &rep), GS_ERR_INVALID_ARG);
        assert_true(strstr(gs_world_error(w), "seconds") != NULL);
    }
    /* NaN and +inf are non-finite seconds */
    r_nan = gs_world_advance(w, NAN, &rep);
    assert_true(strstr(gs_world_error(w), "seconds") != NULL);
    r_inf = gs_world_advance(w, INFINITY, NULL);
    assert_true(strstr(gs_world_error(w), "seconds") != NULL);
    r_ninf = gs_world_advance(w, -INFINITY, NULL);
    /* nothing moved */
    assert_true(fabs(gs_world_time(w) - 0.1) < 1e-12);
    assert_true(fabs(gs_agent_time(a) - 0.1) < 1e-12);
    assert_int_equal(c.steps, 10);
    assert_int_equal(gs_world_advance(w, 0.1, NULL), GS_OK);
    assert_int_equal(c.steps, 20);
    destroy_counted(w, &cnt);
    /* The header (gs_world_advance): GS_ERR_NOT_FINITE for NaN or infinite
       seconds, as everywhere in the library. */
    assert_int_equal(r_nan, GS_ERR_NOT_FINITE);
    assert_int_equal(r_inf, GS_ERR_NOT_FINITE);
    assert_int_equal(r_ninf, GS_ERR_NOT_FINITE);
}

/* ---- gs_agent_set_state / get_state ---- */

static void test_errors_state(void **state) {
    counter cnt;
    gs_world *w = counted_world(&cnt, 1);
    two_values c;
    gs_custom_desc d;
    gs_cloth_desc cd = good_cloth();
    gs_agent *a, *cloth;
    double s[3] = {1.0, 2.0, 3.0}, before[3], after[3];
    double cs[1 + 6 * 16], cbefore[1 + 6 * 16], cafter[1 + 6 * 16];
    size_t n, i, k;
    static const size_t where[] = {0, 1, 2};
    (void)state;
    memset(&c, 0, sizeof c);
    d = two_values_desc(&c);
    assert_int_equal(gs_custom_create(w, &d, &a), GS_OK);
    assert_int_equal(gs_agent_set_state(a, s, 3), GS_OK);
    assert_int_equal(c.sets, 1);
    assert_int_equal(gs_agent_get_state(a, before, 3), GS_OK);
    /* wrong sizes */
    assert_int_equal(gs_agent_set_state(a, s, 2), GS_ERR_SIZE_MISMATCH);
    assert_int_equal(gs_agent_set_state(a, s, 4), GS_ERR_SIZE_MISMATCH);
    assert_int_equal(gs_agent_set_state(a, s, 0), GS_ERR_SIZE_MISMATCH);
    assert_true(strlen(gs_world_error(w)) > 0);
    assert_int_equal(gs_agent_get_state(a, after, 2), GS_ERR_SIZE_MISMATCH);
    /* a NaN or infinity anywhere, the time included */
    for (k = 0; k < 3; ++k) {
        double bad[3] = {4.0, 5.0, 6.0};
        bad[where[k]] = k == 1 ? INFINITY : NAN;
        assert_int_equal(gs_agent_set_state(a, bad, 3), GS_ERR_NOT_FINITE);
        assert_true(strlen(gs_world_error(w)) > 0);
    }
    assert_int_equal(c.sets, 1); /* the user's set_state never saw them */
    assert_int_equal(gs_agent_get_state(a, after, 3), GS_OK);
    assert_memory_equal(before, after, sizeof before);
    assert_true(gs_agent_time(a) == 1.0);

    /* a cloth: same rules over 97 numbers */
    assert_int_equal(gs_cloth_create(w, &cd, &cloth), GS_OK);
    n = gs_agent_state_size(cloth);
    assert_int_equal(n, 1 + 6 * 16);
    assert_int_equal(gs_agent_step(cloth), GS_OK);
    assert_int_equal(gs_agent_get_state(cloth, cbefore, n), GS_OK);
    assert_int_equal(gs_agent_set_state(cloth, cbefore, n - 1),
                     GS_ERR_SIZE_MISMATCH);
    assert_int_equal(gs_agent_set_state(cloth, cbefore, n + 1),
                     GS_ERR_SIZE_MISMATCH);
    for (i = 0; i < n; i += 7) { /* time, positions, velocities */
        memcpy(cs, cbefore, sizeof cs);
        for (k = 0; k < n; ++k) cs[k] += 0.01; /* all would change... */
        cs[i] = NAN;                           /* ...but one is NaN */
        assert_int_equal(gs_agent_set_state(cloth, cs, n), GS_ERR_NOT_FINITE);
    }
    memcpy(cs, cbefore, sizeof cs);
    cs[n - 1] = -INFINITY;
    assert_int_equal(gs_agent_set_state(cloth, cs, n), GS_ERR_NOT_FINITE);
    assert_int_equal(gs_agent_get_state(cloth, cafter, n), GS_OK);
    assert_memory_equal(cbefore, cafter, n * sizeof(double));
    destroy_counted(w, &cnt);
}

/* ---- GS_ERR_BUSY from inside an advance ---- */

typedef struct busy_probe {
    gs_world *w;
    gs_agent *self, *other;
    two_values other_values; /* other's state and counts */
    int done;
    gs_result advance, step_other, destroy_other, cloth, custom, mesh,
        step_self, destroy_self;
    gs_agent *cloth_out, *custom_out, *mesh_out;
    int count_inside;
    long other_steps_before, other_steps_after;
} busy_probe;

static gs_result busy_step(void *user, double t, double dt) {
    busy_probe *p = (busy_probe *)user;
    gs_cloth_desc cd = good_cloth();
    gs_mesh_desc md = good_mesh();
    two_values dummy;
    gs_custom_desc xd = two_values_desc(&dummy);
    (void)t;
    (void)dt;
    if (p->done) return GS_OK;
    p->done = 1;
    p->other_steps_before = p->other_values.steps;
    p->cloth_out = p->custom_out = p->mesh_out = NOT_NULL_AGENT;
    p->advance = gs_world_advance(p->w, 0.1, NULL);
    p->step_other = gs_agent_step(p->other);
    p->destroy_other = gs_agent_destroy(p->other);
    p->step_self = gs_agent_step(p->self);
    p->destroy_self = gs_agent_destroy(p->self);
    p->cloth = gs_cloth_create(p->w, &cd, &p->cloth_out);
    p->custom = gs_custom_create(p->w, &xd, &p->custom_out);
    p->mesh = gs_mesh_create(p->w, &md, &p->mesh_out);
    p->count_inside = gs_world_agent_count(p->w);
    p->other_steps_after = p->other_values.steps;
    return GS_OK;
}

static void test_errors_busy(void **state) {
    counter cnt;
    gs_world *w = counted_world(&cnt, 1);
    busy_probe p;
    gs_custom_desc d;
    gs_agent_stats st;
    long live;
    (void)state;
    memset(&p, 0, sizeof p);
    p.w = w;
    d = two_values_desc(&p.other_values);
    assert_int_equal(gs_custom_create(w, &d, &p.other), GS_OK);
    d.state_size = 0;
    d.get_state = NULL;
    d.set_state = NULL;
    d.step = busy_step;
    d.user = &p;
    assert_int_equal(gs_custom_create(w, &d, &p.self), GS_OK);
    live = live_blocks(&cnt);
    assert_int_equal(gs_world_advance(w, 0.05, NULL), GS_OK);
    assert_int_equal(p.done, 1);
    assert_int_equal(p.advance, GS_ERR_BUSY);
    assert_int_equal(p.step_other, GS_ERR_BUSY);
    assert_int_equal(p.destroy_other, GS_ERR_BUSY);
    assert_int_equal(p.step_self, GS_ERR_BUSY);
    assert_int_equal(p.destroy_self, GS_ERR_BUSY);
    assert_int_equal(p.cloth, GS_ERR_BUSY);
    assert_int_equal(p.custom, GS_ERR_BUSY);
    assert_int_equal(p.mesh, GS_ERR_BUSY);
    assert_null(p.cloth_out);
    assert_null(p.mesh_out);
    assert_int_equal(p.count_inside, 2);
    assert_int_equal(p.other_steps_after, p.other_steps_before);
    /* nothing changed: same agents, no memory, the outer target only */
    assert_int_equal(gs_world_agent_count(w), 2);
    assert_ptr_equal(gs_world_agent(w, 0), p.other);
    assert_int_equal(live_blocks(&cnt), live);
    assert_true(fabs(gs_world_time(w) - 0.05) < 1e-12);
    st = agent_stats(p.other);
    assert_int_equal(st.steps, (uint64_t)p.other_values.steps);
    assert_int_equal(st.activations, (uint64_t)p.other_values.steps);
    assert_int_equal(p.other_values.steps, 5);
    assert_true(strstr(gs_world_error(w), "advancing") != NULL ||
                strlen(gs_world_error(w)) > 0);
    /* and once the advance is over, the same calls work */
    assert_int_equal(gs_agent_step(p.other), GS_OK);
    assert_int_equal(gs_agent_destroy(p.other), GS_OK);
    assert_int_equal(gs_world_agent_count(w), 1);
    destroy_counted(w, &cnt);
    /* a failed create leaves *out NULL, as gs_cloth_create and
       gs_mesh_create do (last: the checks above do not depend on it) */
    assert_null(p.custom_out);
}

/* ---- world setters ---- */

static void test_errors_world_setters(void **state) {
    counter cnt;
    gs_world *w = counted_world(&cnt, 1);
    gs_vec3 g, bad;
    two_values c;
    gs_custom_desc d;
    gs_agent *a;
    gs_advance_report rep;
    (void)state;
    g = gs_world_gravity(w);
    bad = g;
    bad.x = NAN;
    assert_int_equal(gs_world_set_gravity(w, bad), GS_ERR_NOT_FINITE);
    assert_true(strstr(gs_world_error(w), "gravity") != NULL);
    bad = g;
    bad.z = INFINITY;
    assert_int_equal(gs_world_set_gravity(w, bad), GS_ERR_NOT_FINITE);
    assert_true(gs_world_gravity(w).x == g.x && gs_world_gravity(w).y == g.y &&
                gs_world_gravity(w).z == g.z);

    assert_int_equal(gs_world_set_budget(w, -1.0), GS_ERR_INVALID_ARG);
    assert_true(strstr(gs_world_error(w), "budget") != NULL);
    assert_int_equal(gs_world_set_budget(w, NAN), GS_ERR_NOT_FINITE);
    assert_int_equal(gs_world_set_budget(w, -INFINITY), GS_ERR_NOT_FINITE);
    /* the budget stayed unbounded: a long advance still gets there */
    memset(&c, 0, sizeof c);
    d = two_values_desc(&c);
    assert_int_equal(gs_custom_create(w, &d, &a), GS_OK);
    assert_int_equal(gs_world_advance(w, 5.0, &rep), GS_OK);
    assert_int_equal(rep.reached, 1);
    assert_int_equal(c.steps, 500);
    destroy_counted(w, &cnt);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_errors_result_str),
        cmocka_unit_test(test_errors_world_create),
        cmocka_unit_test(test_errors_cloth_create),
        cmocka_unit_test(test_errors_mesh_create),
        cmocka_unit_test(test_errors_custom_create),
        cmocka_unit_test(test_errors_advance),
        cmocka_unit_test(test_errors_state),
        cmocka_unit_test(test_errors_busy),
        cmocka_unit_test(test_errors_world_setters),
    };
    return cmocka_run_group_tests_name("errors", tests, NULL, NULL);
}
