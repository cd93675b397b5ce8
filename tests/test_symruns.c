/* test_symruns.c - symplectic Euler's runs (>>cloth): each run's springs
   add their forces to both ends in one loop, four wide where the CPU has
   AVX (offsets of 4 or more as vectors, 1..3 by blocks of particles with
   the forces shifted, a run's last block masked, negative offsets under
   4 one at a time). Every path must give, bit for bit, the plain loop
   written out here: F[a] += f, F[b] -= f spring by spring in spring
   order, then a = (g - air v) + F / m, v += a h, x += v h, pinned
   particles unchanged at rest. A mesh whose springs come in runs of
   each kind (lengths 8..13: every remainder mod 4; varied stiffness,
   damping and rest) is stepped once, at vector level 1 and 0, and each
   result is compared with that loop: exact equality, no tolerance,
   since every path does the same IEEE operations in the same order.
   This file compiles the implementation itself (GHOSTSIM_STATIC) to
   reach the private switch gs__mesh.avx. */
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

#define NP 30
#define DT 1e-5 /* s: far under the stable step, so one substep */
#define DT_LONG 0.05 /* s: over the stable step, so several substeps (10 here) */

static const int runs[][3] = { /* a0, offset, length */
    {0, 1, 9}, {0, 2, 10}, {0, 3, 11}, {2, 5, 12}, {16, -5, 13}, {10, -2, 9}, {0, 7, 8}, {3, 4, 9}};
#define NRUNS ((int)(sizeof runs / sizeof runs[0]))

static double rnd(uint32_t *s) {
    *s = *s * 1664525u + 1013904223u;
    return (double)(*s >> 8) / 16777216.0;
}

static void make(gs_vec3 *x, gs_vec3 *v, gs_spring *sp, int *ns) {
    uint32_t seed = 7;
    int r, j, k = 0;
    for (j = 0; j < NP; ++j) {
        x[j] = gs__v3(0.1 * j + 0.01 * rnd(&seed), 0.05 * rnd(&seed), 0.05 * rnd(&seed));
        v[j] = gs__v3(rnd(&seed) - 0.5, rnd(&seed) - 0.5, rnd(&seed) - 0.5);
    }
    for (r = 0; r < NRUNS; ++r)
        for (j = 0; j < runs[r][2]; ++j, ++k) {
            sp[k].a = runs[r][0] + j;
            sp[k].b = runs[r][0] + j + runs[r][1];
            sp[k].rest_length = 0.05 + 0.1 * rnd(&seed);
            sp[k].stiffness = 100.0 + 900.0 * rnd(&seed);
            sp[k].damping = rnd(&seed);
        }
    *ns = k;
}

/* One step of dt of the mesh at vector level `avx`; its state into out,
   its substep count into *nsub. */
static void step(int avx, double dt, double *out, int *nsub) {
    gs_world_desc wd = gs_world_desc_default();
    gs_mesh_desc md = gs_mesh_desc_default();
    gs_vec3 x[NP], v[NP];
    gs_spring sp[100];
    gs_agent_stats st;
    double buf[1 + 6 * NP];
    gs_world *w;
    gs_agent *a;
    int ns, pin = 4;
    make(x, v, sp, &ns);
    assert_int_equal(gs_world_create(&wd, &w), GS_OK);
    md.particle_count = NP;
    md.positions = x;
    md.velocities = v;
    md.mass = 3.0;
    md.spring_count = ns;
    md.springs = sp;
    md.pin_count = 1;
    md.pins = &pin;
    md.air_damping = 0.3;
    md.solver.integrator = GS_INTEGRATOR_SYMPLECTIC_EULER;
    md.solver.dt = dt;
    if (gs_mesh_create(w, &md, &a) != GS_OK) fail_msg("%s", gs_world_error(w));
    assert_int_equal(gs__as_mesh(a)->nruns, NRUNS); /* the runs' path, each run its own */
    if (gs__as_mesh(a)->avx > avx) gs__as_mesh(a)->avx = avx;
    assert_int_equal(gs_world_advance(w, dt, NULL), GS_OK);
    assert_int_equal(gs_agent_get_stats(a, &st), GS_OK);
    *nsub = (int)st.substeps;
    assert_int_equal(gs_agent_state_size(a), 1 + 6 * NP); /* [t, x..., v...] */
    assert_int_equal(gs_agent_get_state(a, buf, 1 + 6 * NP), GS_OK);
    memcpy(out, buf + 1, sizeof(double) * 6 * NP);
    gs_world_destroy(w);
}

/* The plain loop, written out: nsub substeps of h. */
static void reference(int nsub, double h, double *out) {
    gs_vec3 x[NP], v[NP], F[NP], g = gs_world_desc_default().gravity;
    gs_spring sp[100];
    int ns, i, k;
    make(x, v, sp, &ns);
    v[4] = gs__v3(0.0, 0.0, 0.0); /* a pinned particle starts at rest (gs_mesh_create) */
    for (k = 0; k < nsub; ++k) {
        memset(F, 0, sizeof F);
        for (i = 0; i < ns; ++i) {
            int a = sp[i].a, b = sp[i].b;
            double dx = x[b].x - x[a].x, dy = x[b].y - x[a].y, dz = x[b].z - x[a].z;
            double l = sqrt(dx * dx + dy * dy + dz * dz), il = 1.0 / l;
            double ux = dx * il, uy = dy * il, uz = dz * il;
            double f = sp[i].stiffness * (l - sp[i].rest_length) +
                       sp[i].damping * ((v[b].x - v[a].x) * ux + (v[b].y - v[a].y) * uy + (v[b].z - v[a].z) * uz);
            F[a].x += ux * f; F[a].y += uy * f; F[a].z += uz * f;
            F[b].x -= ux * f; F[b].y -= uy * f; F[b].z -= uz * f;
        }
        for (i = 0; i < NP; ++i) {
            double im = 1.0 / (3.0 / NP);
            if (i == 4) {
                v[i] = gs__v3(0.0, 0.0, 0.0);
            } else {
                v[i].x = v[i].x + ((g.x + v[i].x * -0.3) + im * F[i].x) * h;
                v[i].y = v[i].y + ((g.y + v[i].y * -0.3) + im * F[i].y) * h;
                v[i].z = v[i].z + ((g.z + v[i].z * -0.3) + im * F[i].z) * h;
                x[i] = gs__v3(x[i].x + v[i].x * h, x[i].y + v[i].y * h, x[i].z + v[i].z * h);
            }
        }
    }
    for (i = 0; i < NP; ++i) {
        out[3 * i] = x[i].x; out[3 * i + 1] = x[i].y; out[3 * i + 2] = x[i].z;
        out[3 * NP + 3 * i] = v[i].x; out[3 * NP + 3 * i + 1] = v[i].y; out[3 * NP + 3 * i + 2] = v[i].z;
    }
}

static void test_runs_match_plain_loop(void **state) {
    double ref[6 * NP], got[6 * NP];
    int avx, nsub;
    (void)state;
    reference(1, DT, ref);
    for (avx = 0; avx <= 1; ++avx) {
        step(avx, DT, got, &nsub);
        assert_int_equal(nsub, 1);
        assert_memory_equal(got, ref, sizeof ref);
    }
}

/* Several substeps in one step: each but the last leaves its result in
   the transposed copy for the next (pred_next), which must give the same
   bits as starting each substep from the state. */
static void test_substeps_keep_the_copy(void **state) {
    double ref[6 * NP], got[6 * NP];
    int avx, nsub;
    (void)state;
    for (avx = 0; avx <= 1; ++avx) {
        step(avx, DT_LONG, got, &nsub);
        assert_true(nsub >= 3); /* the case under test: substeps that carry the copy */
        reference(nsub, DT_LONG / nsub, ref);
        assert_memory_equal(got, ref, sizeof ref);
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_runs_match_plain_loop),
        cmocka_unit_test(test_substeps_keep_the_copy),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
