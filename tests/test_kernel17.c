/* test_kernel17.c - issue 17's kernel variants (>>cloth) against plain C:
   - XPBD's short blocks (a segment's last one to three springs as one
     four-lane TAIL block, a parity class's last ones as one PAIRS or DUOS
     block; the lanes past them loaded but stored back as they were);
   - symplectic Euler's copy into the transposed state and its update
     with the checks, four particles at a time, a scalar remainder after.
   Every lane does the plain loop's IEEE operations in its order, so the
   tolerance is zero: the states must be the same bytes. Only the check's
   sum and largest speed are taken per lane, which changes no outcome;
   the blow-up case checks that both paths refuse the same step. Where
   the CPU has no AVX every run is plain C and this holds trivially.
   Compiles the implementation itself (GHOSTSIM_STATIC) to reach the
   private switch gs__mesh.avx.
   Built as GCC builds C++ and GNU C by default (products fused into sums
   wherever the target has FMA, as AVX-512 has): the header's kernels
   must keep plain C's bits under it too. */
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC optimize("fp-contract=fast")
#endif
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

/* An nx x ny cloth pinned at two corners, falling and swinging under
   `it`, with the cloth's vector paths at level avx at most (0 = off). */
static gs_agent *cloth(gs_world **w, gs_integrator it, int nx, int ny, int avx) {
    gs_world_desc wd = gs_world_desc_default();
    gs_cloth_desc cd = gs_cloth_desc_default();
    gs_agent *c;
    wd.sleep_time = -1.0; /* nothing compared would sleep */
    assert_int_equal(gs_world_create(&wd, w), GS_OK);
    cd.nx = nx;
    cd.ny = ny;
    cd.origin = gs__v3(-0.5, 1.0, -0.5);
    cd.pin_corners = GS_CORNER_00 | GS_CORNER_10;
    cd.spring_damping = 0.5;
    cd.air_damping = 0.2;
    cd.solver.integrator = it;
    cd.solver.dt = it == GS_INTEGRATOR_XPBD ? 0.002 : 0.0005;
    assert_int_equal(gs_cloth_create(*w, &cd, &c), GS_OK);
    if (gs__as_mesh(c)->avx > avx) gs__as_mesh(c)->avx = avx;
    return c;
}

/* `steps` steps at vector level `level` and in plain C: the same bytes. */
static void same_bits(gs_integrator it, int nx, int ny, int level, int steps) {
    gs_world *wa, *wb;
    gs_agent *ca = cloth(&wa, it, nx, ny, level), *cb = cloth(&wb, it, nx, ny, 0);
    size_t sz = gs_agent_state_size(ca), k;
    double *sa = (double *)malloc(sz * sizeof *sa), *sb = (double *)malloc(sz * sizeof *sb);
    double dt = gs__as_mesh(ca)->solver.dt;
    int i;
    assert_non_null(sa);
    assert_non_null(sb);
    assert_true(gs__as_mesh(ca)->nruns > 0); /* the runs' paths, not the colours' */
    for (i = 0; i < steps; ++i) {
        assert_int_equal(gs_world_advance(wa, dt, NULL), GS_OK);
        assert_int_equal(gs_world_advance(wb, dt, NULL), GS_OK);
    }
    assert_int_equal(gs_agent_get_state(ca, sa, sz), GS_OK);
    assert_int_equal(gs_agent_get_state(cb, sb, sz), GS_OK);
    for (k = 0; k < sz; ++k) assert_false(sa[k] != sa[k]); /* no NaN out */
    assert_memory_equal(sa, sb, sz * sizeof *sa);
    free(sa);
    free(sb);
    gs_world_destroy(wa);
    gs_world_destroy(wb);
}

/* Shear runs of a row are nx - 1 long in segments of nx +- 1 (one
   segment): tails of (nx - 1) % 4 springs; bend columns (offset 2 nx)
   leave tails of 2 nx % 4. A row's neighbours (nx - 1 springs) and bend
   springs (nx - 2) end their parity classes in short PAIRS and DUOS
   blocks. 10 to 17 wide give every length of both. */
static void test_short_block_lanes(void **state) {
    int nx, tail[4] = {0, 0, 0, 0}, parity[4] = {0, 0, 0, 0};
    (void)state;
    for (nx = 10; nx <= 17; ++nx) {
        gs_world *w;
        gs__mesh *m = gs__as_mesh(cloth(&w, GS_INTEGRATOR_XPBD, nx, 9, 2));
        int i;
        for (i = 0; i < m->nxblk; ++i) {
            const struct gs__xblk *k = &m->xblk[i];
            if (k->kind == GS__XB_ONE || k->kind == GS__XB_GATHER || k->lanes == 4) continue;
            assert_int_equal(k->count, 1); /* never merged */
            assert_false(k->uni);
            assert_true(k->lanes >= 1 && k->lanes <= 3);
            if (k->kind == GS__XB_TAIL) {
                assert_true(k->b - k->a >= 4); /* ends a and b apart: lanes independent */
                tail[k->lanes]++;
            } else {
                assert_true(k->kind == GS__XB_PAIRS || k->kind == GS__XB_DUOS);
                parity[k->lanes]++;
            }
        }
        gs_world_destroy(w);
    }
    assert_true(tail[1] > 0 && tail[2] > 0 && tail[3] > 0);
    assert_true(parity[1] > 0 && parity[2] > 0 && parity[3] > 0);
}

static void test_xpbd_tails_same_bits(void **state) {
    int nx;
    (void)state;
    for (nx = 10; nx <= 17; ++nx) {
        same_bits(GS_INTEGRATOR_XPBD, nx, 9, 1, 60);
        same_bits(GS_INTEGRATOR_XPBD, nx, 9, 2, 60);
    }
}

/* 9 x 9, 10 x 11, 9 x 7, 8 x 8: n % 4 = 1, 2, 3, 0. */
static void test_symplectic_remainders_same_bits(void **state) {
    static const int sizes[][2] = {{9, 9}, {10, 11}, {9, 7}, {8, 8}};
    size_t s;
    (void)state;
    for (s = 0; s < sizeof sizes / sizeof sizes[0]; ++s)
        same_bits(GS_INTEGRATOR_SYMPLECTIC_EULER, sizes[s][0], sizes[s][1], 1, 200);
}

/* A particle over max_speed in the vector part (0) or the remainder
   (n - 1): both paths refuse the step and keep the state. */
static void test_symplectic_blowup_refused_alike(void **state) {
    int where, level;
    (void)state;
    for (where = 0; where < 2; ++where)
        for (level = 0; level <= 1; ++level) {
            gs_world *w;
            gs_agent *c = cloth(&w, GS_INTEGRATOR_SYMPLECTIC_EULER, 9, 9, level);
            gs__mesh *m = gs__as_mesh(c);
            size_t sz = gs_agent_state_size(c);
            double *st = (double *)malloc(sz * sizeof *st);
            int i = where ? m->n - 1 : 1; /* 1: particle 0 is pinned */
            assert_non_null(st);
            assert_int_equal(gs_agent_get_state(c, st, sz), GS_OK);
            st[3 * (size_t)m->n + 3 * (size_t)i + 1] = 2.0 * m->solver.max_speed;
            assert_int_equal(gs_agent_set_state(c, st, sz), GS_OK);
            assert_int_equal(gs_world_advance(w, m->solver.dt, NULL), GS_ERR_UNSTABLE);
            free(st);
            gs_world_destroy(w);
        }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_short_block_lanes),
        cmocka_unit_test(test_xpbd_tails_same_bits),
        cmocka_unit_test(test_symplectic_remainders_same_bits),
        cmocka_unit_test(test_symplectic_blowup_refused_alike),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
