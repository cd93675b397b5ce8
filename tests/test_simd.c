/* test_simd.c - the rule for the cloth's vector paths (>>cloth): where the
   CPU has AVX, a mesh's spring runs (symplectic Euler) and its XPBD blocks,
   gathered tails and substep end go four lanes wide; every lane does the
   plain C loop's IEEE operations in its order (no FMA, no reassociation,
   no approximate reciprocal), so the two paths are meant to give the same
   bits, and this file checks that bit for bit: the same scene stepped with
   the AVX paths and with them switched off (gs__mesh.avx = 0) ends in the
   same state, contacts with a sphere and a probe included. The only
   values allowed to differ are inside the checks: the sum that asks
   "finite?" and the largest speed are taken per lane, which changes
   neither check's outcome (the state compared here would differ if it
   did). When the CPU has no AVX both runs are plain C and this holds
   trivially.
   This file compiles the implementation itself (GHOSTSIM_STATIC) to reach
   the private switch. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define GHOSTSIM_STATIC
#define GHOSTSIM_IMPLEMENTATION
#include "ghostsim.h"

/* The paper's scene (gs_scene_create: its settle leaves the spheres on
   the cloth) with an n x n cloth under `it`; then the cloth's vector
   paths on or off. */
static gs_world *scene(gs_integrator it, int n, int avx, gs_scene *sc) {
    gs_world_desc wd = gs_world_desc_default();
    gs_scene_desc sd = gs_scene_desc_default();
    gs_world *w;
    wd.sleep_time = -1.0; /* a cloth at rest would sleep: nothing compared */
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    sd.cloth_n = n;
    sd.cloth_integrator = it;
    assert_int_equal(gs_scene_create(w, &sd, sc), GS_OK);
    gs__as_mesh(sc->cloth)->avx = avx && gs__as_mesh(sc->cloth)->avx;
    return w;
}

/* 0.3 s of the scene both ways; the states must be the same bytes. */
static void same_bits(gs_integrator it, int n) {
    gs_scene sca, scb;
    gs_world *a = scene(it, n, 1, &sca), *b = scene(it, n, 0, &scb);
    gs_agent *ca = sca.cloth, *cb = scb.cloth;
    gs_quat id = {0.0, 0.0, 0.0, 1.0};
    size_t sz = gs_agent_state_size(ca);
    double *sa = (double *)malloc(sz * sizeof *sa), *sb = (double *)malloc(sz * sizeof *sb);
    int k, touched = 0;
    assert_non_null(sa);
    assert_non_null(sb);
    assert_int_equal(gs__as_mesh(cb)->avx, 0);
    for (k = 0; k < 18; ++k) {
        gs_result ra, rb;
        gs_probe_set_target(sca.probes[0], gs_scene_probe_path(0, k / 60.0), id);
        gs_probe_set_target(scb.probes[0], gs_scene_probe_path(0, k / 60.0), id);
        ra = gs_world_advance(a, 1.0 / 60.0, NULL);
        rb = gs_world_advance(b, 1.0 / 60.0, NULL);
        if (ra != GS_OK) print_message("%s\n", gs_world_error(a));
        assert_int_equal(ra, GS_OK);
        assert_int_equal(rb, GS_OK);
        touched += gs__as_mesh(ca)->ext_active;
    }
    /* the contact paths ran: a frame ended in contact, or the sphere lies
       in the sagging cloth's box (it rests on it) */
    touched += gs_rigid_position(sca.spheres[0]).y < gs__as_mesh(ca)->hi.y &&
               gs_rigid_position(sca.spheres[0]).y > gs__as_mesh(ca)->lo.y;
    assert_true(touched > 0);
    assert_int_equal(gs_agent_get_state(ca, sa, sz), GS_OK);
    assert_int_equal(gs_agent_get_state(cb, sb, sz), GS_OK);
    for (k = 0; k < (int)sz; ++k) assert_false(sa[k] != sa[k]); /* no NaN out */
    assert_memory_equal(sa, sb, sz * sizeof *sa);
    free(sa);
    free(sb);
    gs_world_destroy(a);
    gs_world_destroy(b);
}

/* 37 x 29 would leave tails in every family; a square odd size does too
   and keeps the scene simple. */
static void test_xpbd_avx_plain_same_bits(void **state) {
    (void)state;
    same_bits(GS_INTEGRATOR_XPBD, 37);
    same_bits(GS_INTEGRATOR_XPBD, 64);
}

static void test_symplectic_avx_plain_same_bits(void **state) {
    (void)state;
    same_bits(GS_INTEGRATOR_SYMPLECTIC_EULER, 17);
}

/* The gathered tails: every lane of a GATHER block is one of the
   one-spring entries it replaced, no two share a particle. */
static void test_gather_lanes_disjoint(void **state) {
    gs_world *w;
    gs_scene sc;
    gs__mesh *m;
    int i, q, e, f, gathered = 0;
    (void)state;
    w = scene(GS_INTEGRATOR_XPBD, 37, 1, &sc);
    m = gs__as_mesh(sc.cloth);
    for (i = 0; i < m->nxblk; ++i) {
        const struct gs__xblk *k = &m->xblk[i];
        int ends[8];
        if (k->kind != GS__XB_GATHER) continue;
        assert_true(k->lanes >= 2 && k->lanes <= 4);
        for (q = 0; q < k->lanes; ++q) gs__xblk_lane(m, k, 0, q, &ends[2 * q], &ends[2 * q + 1]);
        for (e = 0; e < 2 * k->lanes; ++e)
            for (f = e + 1; f < 2 * k->lanes; ++f) assert_int_not_equal(ends[e], ends[f]);
        gathered += k->lanes;
    }
    assert_true(gathered > 0);
    gs_world_destroy(w);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_xpbd_avx_plain_same_bits),
        cmocka_unit_test(test_symplectic_avx_plain_same_bits),
        cmocka_unit_test(test_gather_lanes_disjoint),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
