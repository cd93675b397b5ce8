/* schedule - what a large XPBD cloth's step schedule (step dt, substeps per
   step) costs in accuracy, and what it saves in CPU: issue 17's choice of
   the schedule the README recommends for 128 x 128.

   - scene: gs_scene_create's scene (3 spheres resting on the cloth, one
     probe dipping into it on its scripted path, set every 1/60 s frame as
     ghostpeer does) with an n x n XPBD cloth (128; --quick 64), alone. Each
     schedule builds its own scene (the settle runs at its own schedule:
     that state is part of what a host of that schedule computes).
   - reference: dt 1 ms, 8 substeps (substep 0.125 ms). XPBD converges at
     order 1 in the substep, so the (1 ms, 4) row's error against it is
     about the reference's own error.
   - error: at every 0.2 s of simulated time (a multiple of every dt here)
     the distance of each cloth particle from the reference's: RMS over
     particles and samples, and the largest; the largest sphere centre
     distance; next to the reference cloth's own RMS motion over the run
     (distance from its settled state), the scale the error is read on.
   - CPU: thread CPU seconds per simulated second after the settle (one
     world; a host of a 2-host session adds its ghosts, bench/pace).

   usage: build/bench/schedule [--quick] [--out FILE.json] */
#define GHOSTSIM_IMPLEMENTATION
#include "ghostsim.h"
#include "bench_util.h"

#define FRAME (1.0 / 60.0)
#define SAMPLE_FRAMES 12 /* 0.2 s: a whole number of steps of every dt below */
#define MAX_SAMPLES 16

typedef struct schedule {
    double dt;
    int substeps;
    const char *name;
} schedule;

static const schedule SCHEDULES[] = {
    {0.001, 8, "1 ms x 8 (reference)"},
    {0.001, 4, "1 ms x 4"},
    {0.002, 4, "2 ms x 4 (default)"},
    {0.002, 8, "2 ms x 8"},
    {0.004, 2, "4 ms x 2"},
    {0.004, 4, "4 ms x 4"},
    {0.004, 8, "4 ms x 8"},
    {0.008, 4, "8 ms x 4"},
    {1.0 / 60.0, 8, "16.7 ms x 8"},
};
#define RECOMMENDED_DT 0.004
#define RECOMMENDED_SUBSTEPS 4
#define NSCHED ((int)(sizeof SCHEDULES / sizeof SCHEDULES[0]))

typedef struct run {
    gs_vec3 *cloth[MAX_SAMPLES];   /* positions at each sample */
    gs_vec3 spheres[MAX_SAMPLES][GS_SCENE_MAX_SPHERES];
    int samples, particles, sphere_count;
    double refused_at; /* s: when the world refused a step (GS_ERR_UNSTABLE), else 0 */
    double cpu_per_sim_s;
} run;

static void die(const char *what, gs_world *w, gs_result r)
{
    fprintf(stderr, "schedule: %s: %s (%s)\n", what, gs_result_str(r), w ? gs_world_error(w) : "");
    exit(1);
}

static void run_schedule(const schedule *s, int n, int samples, run *out)
{
    const gs_quat id = {0.0, 0.0, 0.0, 1.0};
    gs_world_desc wd = gs_world_desc_default();
    gs_scene_desc sd = gs_scene_desc_default();
    gs_agent_stats st;
    gs_world *w;
    gs_scene sc;
    gs_result r;
    long steps = 0;
    int f, k, frames = samples * SAMPLE_FRAMES;
    double t0;
    if ((r = gs_world_create(&wd, &w)) != GS_OK) die("gs_world_create", NULL, r);
    sd.cloth_n = n;
    sd.cloth_integrator = GS_INTEGRATOR_XPBD;
    sd.dt = s->dt;
    sd.cloth_substeps = s->substeps;
    sd.probe_count = 1;
    if ((r = gs_scene_create(w, &sd, &sc)) != GS_OK) die("gs_scene_create", w, r);
    out->particles = gs_mesh_particle_count(sc.cloth);
    out->sphere_count = sc.sphere_count;
    out->samples = samples;
    t0 = bu_cpu_now();
    for (f = 1; f <= frames; ++f) {
        /* Whole steps up to the frame's end: every schedule stands at the
           same simulated time at a sample. */
        long to = (long)floor(f * FRAME / s->dt + 0.5);
        gs_probe_set_target(sc.probes[0], gs_scene_probe_path(0, (f - 1) * FRAME), id);
        if (to > steps && (r = gs_world_advance(w, (double)(to - steps) * s->dt, NULL)) != GS_OK) {
            /* A sphere thrown off the cloth fast enough to need more than
               its max_substeps: the schedule is refused from here on. */
            if (r != GS_ERR_UNSTABLE) die("gs_world_advance", w, r);
            fprintf(stderr, "schedule: %s refused at %.3f s: %s\n", s->name, f * FRAME, gs_world_error(w));
            out->refused_at = f * FRAME;
            out->samples = (f - 1) / SAMPLE_FRAMES;
            break;
        }
        steps = to;
        if (f % SAMPLE_FRAMES) continue;
        memset(&st, 0, sizeof st);
        gs_agent_get_stats(sc.cloth, &st);
        if ((long)st.steps != steps) {
            fprintf(stderr, "schedule: %s took %llu steps, not %ld\n", s->name,
                    (unsigned long long)st.steps, steps);
            exit(1);
        }
        k = f / SAMPLE_FRAMES - 1;
        out->cloth[k] = (gs_vec3 *)malloc((size_t)out->particles * sizeof(gs_vec3));
        if (!out->cloth[k]) die("malloc", w, GS_ERR_NO_MEMORY);
        memcpy(out->cloth[k], gs_mesh_positions(sc.cloth), (size_t)out->particles * sizeof(gs_vec3));
        for (int i = 0; i < sc.sphere_count; ++i) out->spheres[k][i] = gs_rigid_position(sc.spheres[i]);
    }
    out->cpu_per_sim_s = (bu_cpu_now() - t0) / ((f > frames ? frames : f) * FRAME);
    if (getenv("SCHED_DEBUG"))
        for (k = 0; k < out->samples; ++k)
            for (int i = 0; i < sc.sphere_count; ++i)
                fprintf(stderr, "%s t %.1f sphere %d at %.3f %.3f %.3f\n", s->name, 0.2 * (k + 1), i,
                        out->spheres[k][i].x, out->spheres[k][i].y, out->spheres[k][i].z);
    gs_world_destroy(w);
}

static double dist(gs_vec3 a, gs_vec3 b)
{
    double dx = a.x - b.x, dy = a.y - b.y, dz = a.z - b.z;
    return sqrt(dx * dx + dy * dy + dz * dz);
}

typedef struct errors {
    double rms, max, sphere_max;
    double first_rms; /* at the first sample, 0.2 s: before the spheres land */
    double sphere_top; /* m: the highest sphere centre after the first sample */
} errors;

static errors compare(const run *a, const run *ref)
{
    errors e = {0.0, 0.0, 0.0, 0.0, -1e300};
    double sum = 0.0;
    int samples = a->samples < ref->samples ? a->samples : ref->samples;
    for (int k = 0; k < samples; ++k) {
        if (k == 1) e.first_rms = sqrt(sum / ref->particles);
        for (int i = 0; k > 0 && i < ref->sphere_count; ++i)
            if (a->spheres[k][i].y > e.sphere_top) e.sphere_top = a->spheres[k][i].y;
        for (int i = 0; i < ref->particles; ++i) {
            double d = dist(a->cloth[k][i], ref->cloth[k][i]);
            sum += d * d;
            if (d > e.max) e.max = d;
        }
        for (int i = 0; i < ref->sphere_count; ++i) {
            double d = dist(a->spheres[k][i], ref->spheres[k][i]);
            if (d > e.sphere_max) e.sphere_max = d;
        }
    }
    e.rms = samples ? sqrt(sum / ((double)samples * ref->particles)) : NAN;
    return e;
}

/* RMS distance of the reference cloth from its first sample: how far the
   probe and spheres move it, the scale of the errors. */
static double motion(const run *ref)
{
    double sum = 0.0;
    for (int k = 1; k < ref->samples; ++k)
        for (int i = 0; i < ref->particles; ++i) {
            double d = dist(ref->cloth[k][i], ref->cloth[0][i]);
            sum += d * d;
        }
    return sqrt(sum / ((double)(ref->samples - 1) * ref->particles));
}

int main(int argc, char **argv)
{
    bu_args a;
    bu_json *j;
    run runs[NSCHED];
    errors e[NSCHED];
    double mot, sub_s[NSCHED], rms_mm[NSCHED], cpu[NSCHED];
    int n, samples, best = -1;
    int pa = bu_parse_args(argc, argv, "schedule", &a);
    if (pa) return pa > 0 ? 0 : 2;
    n = a.quick ? 64 : 128;
    samples = a.quick ? 5 : 10; /* 1 s or 2 s */
    memset(runs, 0, sizeof runs);
    for (int s = 0; s < NSCHED; ++s) run_schedule(&SCHEDULES[s], n, samples, &runs[s]);
    mot = motion(&runs[0]);
    fprintf(stderr, "%dx%d XPBD scene, %g s after the settle, probe + 3 spheres; reference %s\n", n, n,
            samples * SAMPLE_FRAMES * FRAME, SCHEDULES[0].name);
    fprintf(stderr, "reference cloth's RMS motion from its settled state: %.2f mm\n", 1e3 * mot);
    fprintf(stderr, "%-22s %10s %9s %12s %12s %14s %11s %14s\n", "schedule", "substeps/s", "rms@0.2s",
            "cloth rms mm", "cloth max mm", "sphere max mm", "sphere top", "CPU s / sim s");
    for (int s = 0; s < NSCHED; ++s) {
        e[s] = compare(&runs[s], &runs[0]);
        sub_s[s] = SCHEDULES[s].substeps / SCHEDULES[s].dt;
        rms_mm[s] = 1e3 * e[s].rms;
        cpu[s] = runs[s].cpu_per_sim_s;
        fprintf(stderr, "%-22s %10.0f %9.3f %12.3f %12.3f %14.3f %11.3f %14.3f\n", SCHEDULES[s].name,
                sub_s[s], 1e3 * e[s].first_rms, rms_mm[s], 1e3 * e[s].max, 1e3 * e[s].sphere_max,
                e[s].sphere_top, cpu[s]);
    }
    /* The recommended schedule (README, Performance: the evidence). */
    for (int s = 0; s < NSCHED; ++s)
        if (SCHEDULES[s].dt == RECOMMENDED_DT && SCHEDULES[s].substeps == RECOMMENDED_SUBSTEPS) best = s;
    j = bu_json_open(a.out);
    if (!j) return 1;
    bu_json_obj_begin(j, NULL);
    bu_json_header(j, "schedule", a.quick);
    bu_json_str(j, "method",
                "gs_scene_create's scene (XPBD cloth, 3 spheres, probe 0 on its path set every 1/60 s), alone; "
                "each schedule from its own settle; cloth particle and sphere distances from the reference "
                "(1 ms x 8 substeps) every 0.2 s; thread CPU per simulated second after the settle.");
    bu_json_obj_begin(j, "config");
    bu_json_int(j, "cloth_n", n);
    bu_json_num(j, "seconds", samples * SAMPLE_FRAMES * FRAME);
    bu_json_obj_end(j);
    bu_json_arr_begin(j, "results");
    for (int s = 0; s < NSCHED; ++s) {
        bu_json_obj_begin(j, NULL);
        bu_json_str(j, "schedule", SCHEDULES[s].name);
        bu_json_num(j, "dt", SCHEDULES[s].dt);
        bu_json_int(j, "substeps", SCHEDULES[s].substeps);
        bu_json_num(j, "substeps_per_sim_s", sub_s[s]);
        bu_json_num(j, "cloth_rms_mm", rms_mm[s]);
        bu_json_num(j, "cloth_max_mm", 1e3 * e[s].max);
        bu_json_num(j, "sphere_max_mm", 1e3 * e[s].sphere_max);
        bu_json_num(j, "cloth_rms_mm_at_0_2s", 1e3 * e[s].first_rms);
        bu_json_num(j, "sphere_top_m", e[s].sphere_top);
        bu_json_num(j, "cpu_per_sim_s", cpu[s]);
        bu_json_num(j, "refused_at_s", runs[s].refused_at);
        bu_json_obj_end(j);
    }
    bu_json_arr_end(j);
    bu_json_obj_begin(j, "summary");
    bu_json_num(j, "reference_motion_rms_mm", 1e3 * mot);
    bu_json_str(j, "recommended", SCHEDULES[best].name);
    bu_json_num(j, "recommended_cloth_rms_mm", rms_mm[best]);
    bu_json_num(j, "default_cloth_rms_mm", rms_mm[2]);
    bu_json_num(j, "recommended_cpu_over_default", cpu[best] / cpu[2]);
    bu_json_obj_end(j);
    {   /* the reference's own row (error 0) is left out of a log plot */
        const char *names[1] = {"XPBD schedules"};
        const double *xs[1] = {sub_s + 1}, *ys[1] = {rms_mm + 1};
        const int ns[1] = {NSCHED - 1};
        bu_json_arr_begin(j, "plots");
        bu_json_plot(j, "XPBD scene: cloth RMS error against substeps per simulated second",
                     "substeps per sim s", "cloth RMS error (mm)", 1, 1, names, xs, ys, ns);
        bu_json_arr_end(j);
    }
    bu_json_obj_end(j);
    bu_json_close(j);
    for (int s = 0; s < NSCHED; ++s)
        for (int k = 0; k < runs[s].samples; ++k) free(runs[s].cloth[k]);
    return 0;
}
