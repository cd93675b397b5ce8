/* pile_profile.c - bench/physics's sphere pile (the same box, lattice,
   jitter, materials and dt), stepped a fixed number of steps after a
   settle, for counting under callgrind: instructions per sphere-step do not
   depend on the machine's load, and they say which function grows with n.

     gcc -std=c99 -D_POSIX_C_SOURCE=200809L -O2 -DNDEBUG -g -I. \
       bench/tools/pile_profile.c -o build/pile_profile $(pkg-config --cflags --libs ccd) -lm
     valgrind --tool=callgrind --instr-atstart=no --callgrind-out-file=cg.N \
       build/pile_profile N SETTLE STEPS
     callgrind_annotate --inclusive=yes cg.N

   Only the STEPS steps after SETTLE steps (1 ms each) are instrumented. It
   prints the substeps per sphere-step over the instrumented steps. Not in bench/ itself: make bench does not
   run it (its figures are instruction counts, taken by hand).

     build/pile_profile cpu [SIZES...]

   times bench/physics's schedule instead (25 batches of 40 steps from the
   drop, at 27, 125, 343, 1000 and 4096 spheres unless given) in this
   thread's CPU time, not the wall clock's, so that other processes on a
   shared machine inflate it less, and prints the median per step and the
   exponent fitted as bench/physics fits it. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <valgrind/callgrind.h>

#define GHOSTSIM_IMPLEMENTATION
#include "ghostsim.h"

#define R 0.05
#define SPACING 0.12
#define DT 0.001

static void die(gs_world *w) {
    fprintf(stderr, "pile_profile: %s\n", gs_world_error(w));
    exit(1);
}

/* bench/physics's pile of n spheres in its box (balls: n agents). */
static gs_world *make_pile(int n, gs_agent **balls) {
    int side = (int)ceil(cbrt((double)n) - 1e-9), k, s;
    double half = 0.5 * (side - 1) * SPACING + R + 0.03, height = side * SPACING + 0.4;
    uint32_t rng = 12345;
    gs_world_desc wd = gs_world_desc_default();
    gs_material m;
    gs_world *w = NULL;
    m.stiffness = 1e5;
    m.damping = 100.0;
    m.friction = 0.5;
    if (gs_world_create(&wd, &w) != GS_OK) exit(1);
    gs_world_set_ground(w, 1, 0.0, m);
    for (s = 0; s < 4; ++s) { /* the box: four kinematic walls */
        gs_probe_desc pd = gs_probe_desc_default();
        gs_agent *wall;
        double off = half + 0.05;
        pd.shape.type = GS_SHAPE_BOX;
        pd.shape.half_extents.x = s < 2 ? 0.05 : off + 0.05;
        pd.shape.half_extents.y = 0.5 * height;
        pd.shape.half_extents.z = s < 2 ? off + 0.05 : 0.05;
        pd.position.x = s == 0 ? -off : s == 1 ? off : 0.0;
        pd.position.y = 0.5 * height;
        pd.position.z = s == 2 ? -off : s == 3 ? off : 0.0;
        pd.material = m;
        pd.dt = DT;
        if (gs_probe_create(w, &pd, &wall) != GS_OK) die(w);
    }
    for (k = 0; k < n; ++k) {
        gs_rigid_desc rd = gs_rigid_desc_default();
        int i = k % side, j = (k / side) % side, l = k / (side * side);
        double jx, jz;
        rng = rng * 1664525u + 1013904223u;
        jx = ((rng >> 8) / 16777216.0 - 0.5) * 0.01;
        rng = rng * 1664525u + 1013904223u;
        jz = ((rng >> 8) / 16777216.0 - 0.5) * 0.01;
        rd.shape.type = GS_SHAPE_SPHERE;
        rd.shape.radius = R;
        rd.density = 1000.0;
        rd.position.x = (i - 0.5 * (side - 1)) * SPACING + jx;
        rd.position.z = (j - 0.5 * (side - 1)) * SPACING + jz;
        rd.position.y = R + 0.05 + l * SPACING;
        rd.material = m;
        rd.solver.dt = DT;
        if (gs_rigid_create(w, &rd, &balls[k]) != GS_OK) die(w);
    }
    return w;
}

static double cpu_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* Steps of 1 ms per gs_world_advance: an application advances once per
   display frame (16 ms at 60 Hz: the world history records once per
   advance, gs__sync_begin), so the default drive is 16 steps an advance;
   PILE_FRAME=1 drives one step an advance, as bench/physics did before
   2026-12-06 (a whole-world history copy every 1 ms step). */
static int frame_steps(void) {
    const char *e = getenv("PILE_FRAME");
    int f = e ? atoi(e) : 16;
    return f < 1 ? 1 : f > 1000 ? 1000 : f;
}

/* `steps` steps of 1 ms, in advances of at most `frame` steps. */
static void run_steps(gs_world *w, int steps, int frame) {
    while (steps > 0) {
        int k = steps < frame ? steps : frame;
        if (gs_world_advance(w, k * DT, NULL) != GS_OK) die(w);
        steps -= k;
    }
}

#define BATCHES 25
/* bench/physics's spheres timing in thread CPU time: us per step at each
   size and the least-squares exponent over them. */
static int cpu_mode(int nsizes, const int *sizes) {
    double lx[16], ly[16], sx = 0, sy = 0, sxx = 0, sxy = 0;
    int i, b;
    for (i = 0; i < nsizes; ++i) {
        gs_agent **balls = (gs_agent **)malloc((size_t)sizes[i] * sizeof *balls);
        gs_world *w = make_pile(sizes[i], balls);
        double t[BATCHES];
        for (b = 0; b < BATCHES; ++b) {
            double t0 = cpu_now();
            run_steps(w, 1000 / BATCHES, frame_steps());
            t[b] = (cpu_now() - t0) / (1000 / BATCHES);
        }
        qsort(t, BATCHES, sizeof *t, cmp_double);
        lx[i] = log((double)sizes[i]);
        ly[i] = log(t[BATCHES / 2]);
        printf("n %5d: %10.1f us per step (CPU), %.3f us per sphere-step\n", sizes[i],
               1e6 * t[BATCHES / 2], 1e6 * t[BATCHES / 2] / sizes[i]);
        gs_world_destroy(w);
        free(balls);
    }
    for (i = 0; i < nsizes; ++i) {
        sx += lx[i]; sy += ly[i]; sxx += lx[i] * lx[i]; sxy += lx[i] * ly[i];
    }
    printf("cost ~ n^e: e = %.3f (least squares), %.3f (ends)\n",
           (nsizes * sxy - sx * sy) / (nsizes * sxx - sx * sx),
           (ly[nsizes - 1] - ly[0]) / (lx[nsizes - 1] - lx[0]));
    return 0;
}

int main(int argc, char **argv) {
    int n, settle, steps, k;
    double sub0 = 0.0, sub1 = 0.0, y = 0.0;
    gs_world *w;
    gs_agent **balls;
    if (argc > 1 && strcmp(argv[1], "cpu") == 0) {
        int sizes[16] = {27, 125, 343, 1000, 4096}, ns = 5;
        if (argc > 2)
            for (ns = 0; ns < 16 && ns + 2 < argc; ++ns) sizes[ns] = atoi(argv[ns + 2]);
        return cpu_mode(ns, sizes);
    }
    n = argc > 1 ? atoi(argv[1]) : 1000;
    settle = argc > 2 ? atoi(argv[2]) : 1000;
    steps = argc > 3 ? atoi(argv[3]) : 20;
    balls = (gs_agent **)malloc((size_t)n * sizeof *balls);
    if (!balls) return 1;
    w = make_pile(n, balls);
    run_steps(w, settle, frame_steps());
    for (k = 0; k < n; ++k) {
        gs_agent_stats st = {0, 0, 0, 0, 0, 0, 0, 0};
        gs_agent_get_stats(balls[k], &st);
        sub0 += (double)st.substeps;
    }
    CALLGRIND_START_INSTRUMENTATION;
    run_steps(w, steps, frame_steps());
    CALLGRIND_STOP_INSTRUMENTATION;
    for (k = 0; k < n; ++k) {
        gs_agent_stats st = {0, 0, 0, 0, 0, 0, 0, 0};
        gs_agent_get_stats(balls[k], &st);
        sub1 += (double)st.substeps;
        y += gs_rigid_position(balls[k]).y;
    }
    printf("n %d settle %d steps %d frame %d: %.3f substeps per sphere-step, mean height %.4f m, "
           "time %.6f s, hash %016llx\n", n, settle, steps, frame_steps(),
           (sub1 - sub0) / ((double)n * steps), y / n, gs_world_time(w),
           (unsigned long long)gs_world_hash(w));
    gs_world_destroy(w);
    free(balls);
    return 0;
}
