/* test_substeps.c - gs_scene_desc.cloth_substeps, the XPBD cloth's substeps
   per step of a scene (ghostpeer --substeps): 0 is the default 4, bit for
   bit the scene of a desc that does not set it; a count is what each step
   takes and it changes the cloth's path; a negative or too large count is
   refused with GS_ERR_INVALID_ARG and a message that names the field, as
   is a count whose settle would exceed GS_SCENE_SETTLE_WORK; a refused
   scene leaves the world without an agent. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "ghostsim.h"

/* Asserts cond; on failure prints the values that explain it first. */
#define CHECK(cond, ...)                                                       \
    do {                                                                       \
        if (!(cond)) print_message(__VA_ARGS__);                               \
        assert_true(cond);                                                     \
    } while (0)

#define STEPS 10 /* steps after the settle: enough for the probe to press in */

static gs_world *world_make(void) {
    gs_world_desc wd = gs_world_desc_default();
    gs_world *w = NULL;
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    return w;
}

/* A world holding an XPBD scene (cloth_n, dt 0: the default, substeps 0:
   unset), built or the test fails. */
static gs_world *xpbd_scene(int cloth_n, double dt, int substeps, gs_scene *sc) {
    gs_world *w = world_make();
    gs_scene_desc sd = gs_scene_desc_default();
    gs_result r;
    sd.cloth_n = cloth_n;
    sd.cloth_integrator = GS_INTEGRATOR_XPBD;
    if (dt > 0.0) sd.dt = dt;
    sd.cloth_substeps = substeps;
    r = gs_scene_create(w, &sd, sc);
    CHECK(r == GS_OK, "gs_scene_create: %s (%s)\n", gs_result_str(r), gs_world_error(w));
    return w;
}

static uint64_t substeps_of(const gs_agent *a) {
    gs_agent_stats st;
    memset(&st, 0, sizeof st);
    assert_int_equal(gs_agent_get_stats(a, &st), GS_OK);
    return st.substeps;
}

/* A small XPBD scene of `substeps` (0: unset), its probe driven on its path
   for STEPS steps; its cloth's positions copied to out (n_out particles). */
static void scene_run(int substeps, int cloth_n, gs_vec3 *out, int n_out,
                      uint64_t *substeps_taken) {
    gs_scene sc;
    gs_world *w = xpbd_scene(cloth_n, 0.0, substeps, &sc);
    gs_result r;
    const gs_quat id = {0.0, 0.0, 0.0, 1.0};
    int i;
    assert_int_equal(sc.desc.cloth_substeps, substeps == 0 ? 4 : substeps);
    for (i = 0; i < STEPS; ++i) {
        gs_probe_set_target(sc.probes[0], gs_scene_probe_path(0, i * sc.desc.dt), id);
        r = gs_world_advance(w, sc.desc.dt, NULL);
        CHECK(r == GS_OK, "gs_world_advance: %s (%s)\n", gs_result_str(r), gs_world_error(w));
    }
    assert_int_equal(gs_mesh_particle_count(sc.cloth), n_out);
    memcpy(out, gs_mesh_positions(sc.cloth), (size_t)n_out * sizeof *out);
    *substeps_taken = substeps_of(sc.cloth);
    gs_world_destroy(w);
}

/* 0 is the default: the same bits as 4 set explicitly, 4 substeps a step;
   8 takes 8 a step and moves the cloth otherwise (else the field would not
   reach the solver and every test above would pass regardless). */
static void test_count_reaches_the_solver(void **state) {
    enum { N = 8, P = N * N };
    gs_vec3 a[P], b[P], c[P];
    uint64_t sa, sb, sc;
    int i, differ = 0;
    (void)state;
    scene_run(0, N, a, P, &sa);
    scene_run(4, N, b, P, &sb);
    scene_run(8, N, c, P, &sc);
    assert_int_equal(sa, 4 * STEPS); /* stats are reset after the settle */
    assert_int_equal(sb, 4 * STEPS);
    assert_int_equal(sc, 8 * STEPS);
    assert_memory_equal(a, b, sizeof a);
    for (i = 0; i < P; ++i) differ += a[i].x != c[i].x || a[i].y != c[i].y || a[i].z != c[i].z;
    CHECK(differ > P / 2, "8 substeps moved only %d of %d particles otherwise than 4\n", differ, P);
}

/* One refused desc: the result, the message naming `what`, no agent left. */
static void refused(int cloth_n, gs_integrator it, int substeps, const char *what) {
    gs_world *w = world_make();
    gs_scene_desc sd = gs_scene_desc_default();
    gs_scene sc;
    gs_result r;
    sd.cloth_n = cloth_n;
    sd.cloth_integrator = it;
    sd.cloth_substeps = substeps;
    r = gs_scene_create(w, &sd, &sc);
    CHECK(r == GS_ERR_INVALID_ARG, "substeps %d: %s (%s)\n", substeps, gs_result_str(r),
          gs_world_error(w));
    CHECK(strstr(gs_world_error(w), what) != NULL, "substeps %d: message '%s' lacks '%s'\n",
          substeps, gs_world_error(w), what);
    assert_int_equal(gs_world_agent_count(w), 0);
    gs_world_destroy(w);
}

static void test_bad_counts_refused(void **state) {
    (void)state;
    refused(8, GS_INTEGRATOR_XPBD, -1, "cloth_substeps");
    refused(8, GS_INTEGRATOR_XPBD, -2147483647 - 1, "cloth_substeps");
    refused(8, GS_INTEGRATOR_XPBD, (1 << 20) + 1, "cloth_substeps");
    /* Within the field's range but 8 x 8 x 1500 steps x 25000 / 4 substeps
       = 6e8 particle substeps of settle, over GS_SCENE_SETTLE_WORK (1e8). */
    refused(8, GS_INTEGRATOR_XPBD, 25000, "GS_SCENE_SETTLE_WORK");
    /* The field is checked whatever the integrator: a desc is valid or not. */
    refused(8, GS_INTEGRATOR_SYMPLECTIC_EULER, -1, "cloth_substeps");
}

/* The settle bound counts substeps under XPBD only: the same count under an
   integrator that ignores it builds. 16 x 16 at dt 2 ms is 3.8e5 particle
   steps to settle; times 1100 / 4 substeps 1.06e8, over the bound. */
static void test_bound_counts_xpbd_only(void **state) {
    gs_world *w = world_make();
    gs_scene_desc sd = gs_scene_desc_default();
    gs_scene sc;
    gs_result r;
    (void)state;
    sd.cloth_integrator = GS_INTEGRATOR_IMPLICIT_EULER;
    sd.cloth_substeps = 1100;
    r = gs_scene_create(w, &sd, &sc);
    CHECK(r == GS_OK, "implicit, substeps 1100: %s (%s)\n", gs_result_str(r), gs_world_error(w));
    gs_world_destroy(w);
    refused(16, GS_INTEGRATOR_XPBD, 1100, "GS_SCENE_SETTLE_WORK");
}

/* A step per 60 Hz frame on a 64 x 64 cloth (a 16 x 16 one is softer under a
   sphere: 13 substeps do): the scene's spheres on the cloth need more than
   the default max_substeps (64) for their contact stiffness at dt 1/60 s,
   and the scene lets them take up to 256. The substeps counted show the
   cap is what is tested (if a sphere never needed more than 64, this test
   would not cover the scene's cap: it says so by failing). */
static void test_frame_step_scene_runs(void **state) {
    const gs_quat id = {0.0, 0.0, 0.0, 1.0};
    const double dt = 1.0 / 60.0;
    uint64_t most = 0, prev[GS_SCENE_MAX_SPHERES];
    gs_scene sc;
    gs_world *w = xpbd_scene(64, dt, 4, &sc);
    gs_result r;
    int i, k;
    (void)state;
    for (i = 0; i < 60; ++i) { /* 1 s: the spheres land on the cloth */
        gs_probe_set_target(sc.probes[0], gs_scene_probe_path(0, i * dt), id);
        for (k = 0; k < sc.sphere_count; ++k) prev[k] = substeps_of(sc.spheres[k]);
        r = gs_world_advance(w, dt, NULL);
        CHECK(r == GS_OK, "step %d: %s (%s)\n", i, gs_result_str(r), gs_world_error(w));
        for (k = 0; k < sc.sphere_count; ++k)
            if (substeps_of(sc.spheres[k]) - prev[k] > most) most = substeps_of(sc.spheres[k]) - prev[k];
    }
    CHECK(most > 64, "the spheres took at most %llu substeps a step\n", (unsigned long long)most);
    gs_world_destroy(w);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_count_reaches_the_solver),
        cmocka_unit_test(test_bad_counts_refused),
        cmocka_unit_test(test_bound_counts_xpbd_only),
        cmocka_unit_test(test_frame_step_scene_runs),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
