/* scaling - cost per step against particle count, rigid agent count and
   host count, with the fitted exponent of each (cost ~ size^k, least
   squares on the logs); memory per particle and per host, counted through
   the world's allocator hook (gs_world_desc.allocator).

   - particles: one cloth, nx = ny = 8 .. 128 (181 in the full run), pinned
     at its corners, symplectic Euler, dt 1 ms. Two series: "same particle"
     keeps each particle's mass (1/256 kg) and the spacing (1/15 m) of the
     default 16x16 cloth, so the stable step stays 1.27 ms and every step is
     one substep: the cost of a particle. "1 kg, 1 m" is the default cloth
     desc: finer cloths need more substeps, as a user would see.
   - rigid agents: 1 .. 1000 spheres (r 5 cm) resting on the ground in a
     grid 20 cm apart (each touches only the ground), dt 1 ms; one step =
     gs_world_advance(w, dt), every body steps once.
   - hosts: 2 .. 16 worlds on gs_simnet (perfect links), each with a 16x16
     cloth under a ghost (60 Hz, f64); cost per host-step = wall time of
     gs_simnet_run / (hosts x steps).
   - the paper scene: gs_scene_create's scene at 16 .. 128 (64 in the
     quick run) per cloth integrator: CPU seconds per simulated second.
   Cost is the median over repeats, in thread CPU time (a busy machine's
   waits do not count). Memory: bytes the world allocated
   (live, after creation and a few steps) for each size; per particle and
   per host are least-squares slopes. */
#define GHOSTSIM_IMPLEMENTATION
#include "ghostsim.h"
#include "tests/net_helpers.h"
#include "bench_util.h"

#include <string.h>

/* An agent's counters by value (gs_agent_get_stats fills an out-pointer). */
static gs_agent_stats agent_stats(const gs_agent *a) {
    gs_agent_stats st;
    memset(&st, 0, sizeof st);
    gs_agent_get_stats(a, &st);
    return st;
}

#define DT 0.001
#define FRAME (1.0 / 60.0)

/* ---- a counting allocator ---- */
typedef struct counter {
    double live, peak, total;
    long calls;
} counter;

typedef union hdr {
    size_t size;
    long double ld;
    void *p;
    long long ll;
} hdr;

static void *count_alloc(size_t size, void *user)
{
    counter *c = (counter *)user;
    hdr *h = (hdr *)malloc(sizeof(hdr) + size);
    if (!h) return NULL;
    h->size = size;
    c->live += (double)size;
    c->total += (double)size;
    c->calls++;
    if (c->live > c->peak) c->peak = c->live;
    return h + 1;
}

static void count_free(void *p, void *user)
{
    counter *c = (counter *)user;
    hdr *h;
    if (!p) return;
    h = (hdr *)p - 1;
    c->live -= (double)h->size;
    free(h);
}

static gs_allocator counting(counter *c)
{
    gs_allocator a;
    a.alloc = count_alloc;
    a.free = count_free;
    a.user = c;
    return a;
}

static void die(const char *what, gs_world *w, gs_result r)
{
    fprintf(stderr, "scaling: %s: %s (%s)\n", what, gs_result_str(r), w ? gs_world_error(w) : "");
    exit(1);
}

/* Least squares y = a + b x. */
static void fit_line(const double *x, const double *y, int n, double *a, double *b)
{
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    int i;
    for (i = 0; i < n; ++i) { sx += x[i]; sy += y[i]; sxx += x[i] * x[i]; sxy += x[i] * y[i]; }
    *b = (n * sxy - sx * sy) / (n * sxx - sx * sx);
    *a = (sy - *b * sx) / n;
}

/* Exponent k of y ~ x^k (least squares on logs). */
static double fit_exponent(const double *x, const double *y, int n)
{
    double lx[32], ly[32], a, b;
    int i;
    for (i = 0; i < n; ++i) { lx[i] = log(x[i]); ly[i] = log(y[i]); }
    fit_line(lx, ly, n, &a, &b);
    return b;
}

/* Median seconds per step of `steps_per_rep` single-dt advances. */
static double time_steps(gs_world *w, int reps, int steps_per_rep)
{
    double v[64];
    int r, s;
    if (reps > 64) reps = 64;
    for (r = 0; r < reps; ++r) {
        double t0 = bu_cpu_now();
        for (s = 0; s < steps_per_rep; ++s) {
            gs_result res = gs_world_advance(w, DT, NULL);
            if (res != GS_OK) die("gs_world_advance", w, res);
        }
        v[r] = (bu_cpu_now() - t0) / steps_per_rep;
    }
    return bu_median(v, reps);
}

/* ---- particles ---- */
typedef struct cloth_row {
    int n;
    double step_same, step_default, substeps_default;
    double bytes, bytes_ghost;
} cloth_row;

static gs_world *cloth_world(int n, int same_particle, counter *c, int ghost, gs_agent **out)
{
    gs_world_desc wd = gs_world_desc_default();
    gs_cloth_desc cd = gs_cloth_desc_default();
    gs_world *w;
    gs_result r;
    if (c) wd.allocator = counting(c);
    if ((r = gs_world_create(&wd, &w)) != GS_OK) die("gs_world_create", NULL, r);
    cd.nx = cd.ny = n;
    cd.pin_corners = GS_CORNER_ALL;
    if (same_particle) {
        cd.width = cd.height = (n - 1) / 15.0;
        cd.mass = n * n / 256.0;
    }
    if ((r = gs_cloth_create(w, &cd, out)) != GS_OK) die("gs_cloth_create", w, r);
    if (ghost) {
        gs_ghost_desc gd = gs_ghost_desc_default();
        gd.object_id = 1;
        gd.weight = gs_weight_exp; /* the rule of the figures recorded so far */
        if ((r = gs_ghost_attach(*out, &gd)) != GS_OK) die("gs_ghost_attach", w, r);
    }
    return w;
}

static cloth_row run_cloth(int n, int quick)
{
    cloth_row row;
    gs_agent *a;
    gs_world *w;
    counter c0, c1;
    double work = (double)n * n; /* particle-substeps per step, roughly */
    int steps = (int)(20000.0 / work) + 1, reps = quick ? 5 : 9;
    gs_agent_stats st;
    memset(&row, 0, sizeof row);
    row.n = n;
    w = cloth_world(n, 1, NULL, 0, &a);
    time_steps(w, 1, 2);
    row.step_same = time_steps(w, reps, steps);
    gs_world_destroy(w);
    w = cloth_world(n, 0, NULL, 0, &a);
    time_steps(w, 1, 2);
    row.step_default = time_steps(w, reps, steps);
    st = agent_stats(a);
    row.substeps_default = (double)st.substeps / (double)st.steps;
    gs_world_destroy(w);
    memset(&c0, 0, sizeof c0);
    w = cloth_world(n, 1, &c0, 0, &a);
    gs_world_advance(w, 3 * DT, NULL);
    row.bytes = c0.live;
    gs_world_destroy(w);
    memset(&c1, 0, sizeof c1);
    w = cloth_world(n, 1, &c1, 1, &a);
    gs_world_advance(w, 3 * DT, NULL);
    row.bytes_ghost = c1.live;
    gs_world_destroy(w);
    return row;
}

/* ---- rigid agents ---- */
typedef struct rigid_row {
    int n;
    double step, step_asleep, bytes;
} rigid_row;

/* Awake (sleeping off: what the contacts cost), then the same spheres left
   to fall asleep (what a resting scene costs). */
static rigid_row run_rigid(int n, int quick)
{
    gs_world_desc wd = gs_world_desc_default();
    gs_world *w;
    gs_result r;
    counter c;
    rigid_row row;
    int i, side = (int)ceil(sqrt((double)n));
    int steps = 2000 / n + 3, reps = quick ? 5 : 9;
    memset(&c, 0, sizeof c);
    wd.allocator = counting(&c);
    wd.sleep_time = -1.0;
again:
    if ((r = gs_world_create(&wd, &w)) != GS_OK) die("gs_world_create", NULL, r);
    gs_world_set_ground(w, 1, 0.0, gs_material_default());
    for (i = 0; i < n; ++i) {
        gs_rigid_desc rd = gs_rigid_desc_default();
        gs_agent *a;
        rd.shape.type = GS_SHAPE_SPHERE;
        rd.shape.radius = 0.05;
        rd.position.x = 0.2 * (i % side);
        rd.position.z = 0.2 * (i / side);
        rd.position.y = 0.05; /* resting on the ground */
        if ((r = gs_rigid_create(w, &rd, &a)) != GS_OK) die("gs_rigid_create", w, r);
    }
    row.n = n;
    if (wd.sleep_time < 0.0) {
        gs_world_advance(w, 0.05, NULL); /* settle on the ground */
        row.step = time_steps(w, reps, steps);
        row.bytes = c.live;
        gs_world_destroy(w);
        wd.sleep_time = 0.0; /* the default */
        goto again;
    }
    gs_world_advance(w, 1.0, NULL); /* settle and fall asleep */
    row.step_asleep = time_steps(w, reps, steps);
    gs_world_destroy(w);
    return row;
}

/* ---- the paper's scene at rest: asleep against awake ----
   gs_scene_create's default scene (16x16 cloth, 3 spheres, 1 probe), the
   probe held still, 6 s after the drop (the spheres lie on the cloth);
   then CPU time per 1/60 s frame with sleeping on (the default) and off. */
typedef struct rest_row {
    double frame_awake, frame_asleep;
    int asleep;
} rest_row;

static double scene_frames(int sleep, int frames, int *asleep)
{
    gs_world_desc wd = gs_world_desc_default();
    gs_world *w;
    gs_scene sc;
    gs_result r;
    double t0, v[64];
    int i, k;
    wd.sleep_time = sleep ? 0.0 : -1.0;
    if ((r = gs_world_create(&wd, &w)) != GS_OK) die("gs_world_create", NULL, r);
    if ((r = gs_scene_create(w, NULL, &sc)) != GS_OK) die("gs_scene_create", w, r);
    for (i = 0; i < 360; ++i) gs_world_advance(w, 1.0 / 60.0, NULL);
    for (k = 0; k < 9; ++k) {
        t0 = bu_cpu_now();
        for (i = 0; i < frames; ++i) gs_world_advance(w, 1.0 / 60.0, NULL);
        v[k] = (bu_cpu_now() - t0) / frames;
    }
    *asleep = 0;
    for (i = 0; i < gs_world_agent_count(w); ++i) *asleep += gs_agent_sleeping(gs_world_agent(w, i));
    gs_world_destroy(w);
    return bu_median(v, 9);
}

static rest_row run_rest(int quick)
{
    rest_row row;
    int awake_sleepers;
    row.frame_asleep = scene_frames(1, quick ? 6 : 20, &row.asleep);
    row.frame_awake = scene_frames(0, quick ? 6 : 20, &awake_sleepers);
    return row;
}

/* ---- the paper's scene at sizes: CPU per simulated second ----
   gs_scene_create's scene (3 spheres, 1 probe on its path) with an n x n
   cloth under one integrator, after its settle: thread CPU seconds per
   simulated second over 60 Hz frames (under 0.5: the simulation of a host
   keeps wall-clock pace on half a core). A size whose settle is over the
   budget, or whose step an integrator refuses, is -1 (refused). */
#define PACE_SIZES 4
#define PACE_INTEGRATORS 3
static const int pace_n[PACE_SIZES] = {16, 32, 64, 128};
static const gs_integrator pace_it[PACE_INTEGRATORS] = {
    GS_INTEGRATOR_IMPLICIT_EULER, GS_INTEGRATOR_SYMPLECTIC_EULER, GS_INTEGRATOR_XPBD};
static const char *const pace_name[PACE_INTEGRATORS] = {"implicit", "symplectic", "xpbd"};

static double scene_pace(int n, gs_integrator it, double seconds)
{
    gs_world_desc wd = gs_world_desc_default();
    gs_scene_desc sd = gs_scene_desc_default();
    gs_world *w;
    gs_scene sc;
    gs_result r;
    double t0, cost = -1.0;
    int i, frames = (int)(seconds * 60.0 + 0.5);
    if ((r = gs_world_create(&wd, &w)) != GS_OK) die("gs_world_create", NULL, r);
    sd.cloth_n = n;
    sd.cloth_integrator = it;
    if (gs_scene_create(w, &sd, &sc) == GS_OK) {
        gs_quat id = {0.0, 0.0, 0.0, 1.0};
        t0 = bu_cpu_now();
        for (i = 0; i < frames; ++i) {
            gs_probe_set_target(sc.probes[0], gs_scene_probe_path(0, i / 60.0), id);
            if (gs_world_advance(w, 1.0 / 60.0, NULL) != GS_OK) break;
        }
        if (i == frames) cost = (bu_cpu_now() - t0) / (frames / 60.0);
    }
    gs_world_destroy(w);
    return cost;
}

/* Implicit Euler's settle alone at 128 x 128 is minutes: left out there. */
static void run_pace(int quick, double cost[PACE_SIZES][PACE_INTEGRATORS])
{
    int i, k;
    for (i = 0; i < PACE_SIZES; ++i)
        for (k = 0; k < PACE_INTEGRATORS; ++k)
            cost[i][k] = (quick && pace_n[i] > 64) ||
                                 (pace_it[k] == GS_INTEGRATOR_IMPLICIT_EULER && pace_n[i] > 64)
                             ? -2.0
                             : scene_pace(pace_n[i], pace_it[k], quick ? 0.5 : 2.0);
}

/* ---- hosts ---- */
typedef struct host_row {
    int hosts;
    double host_step, bytes_per_world, simnet_bytes;
} host_row;

typedef struct host_set {
    gs_simnet *sim;
    gs_world *w[16];
    counter cw[16], cs;
    int H;
    double v[16];
} host_set;

static void host_set_make(host_set *s, int H)
{
    gs_simnet_desc sd;
    gs_result r;
    int i;
    memset(s, 0, sizeof *s);
    s->H = H;
    memset(&sd, 0, sizeof sd);
    sd.allocator = counting(&s->cs);
    if ((r = gs_simnet_create(&sd, &s->sim)) != GS_OK) die("gs_simnet_create", NULL, r);
    for (i = 0; i < H; ++i) {
        gs_world_desc wd = gs_world_desc_default();
        gs_cloth_desc cd = gs_cloth_desc_default();
        gs_ghost_desc gd = gs_ghost_desc_default();
        gs_net_desc nd;
        gs_net *net;
        gs_agent *a;
        wd.host_id = (uint32_t)i + 1;
        wd.allocator = counting(&s->cw[i]);
        if ((r = gs_world_create(&wd, &s->w[i])) != GS_OK) die("gs_world_create", NULL, r);
        cd.nx = cd.ny = 16;
        cd.pin_corners = GS_CORNER_ALL;
        if ((r = gs_cloth_create(s->w[i], &cd, &a)) != GS_OK) die("gs_cloth_create", s->w[i], r);
        gd.object_id = 1;
        gd.weight = gs_weight_exp; /* the rule of the figures recorded so far */
        if ((r = gs_ghost_attach(a, &gd)) != GS_OK) die("gs_ghost_attach", s->w[i], r);
        memset(&nd, 0, sizeof nd);
        nd.bandwidth = 1e9;
        if ((r = test_join(s->sim, s->w[i], &nd, &net)) != GS_OK) die("gs_net_create on the simnet", s->w[i], r);
    }
    gs_simnet_run(s->sim, 2 * FRAME, FRAME);
}

/* Every host count is built first, then timed in turns (the order rotates
   each round), so that a noisy moment on a shared machine is spread over
   all of them. */
static void run_hosts(const int *hs, int nhs, int quick, host_row *rows)
{
    host_set *sets = (host_set *)calloc((size_t)nhs, sizeof *sets);
    int i, k, rep, reps = quick ? 3 : 9, frames = quick ? 4 : 12;
    gs_result r;
    if (!sets) die("calloc", NULL, GS_ERR_NO_MEMORY);
    for (k = 0; k < nhs; ++k) host_set_make(&sets[k], hs[k]);
    for (rep = 0; rep < reps; ++rep)
        for (i = 0; i < nhs; ++i) {
            host_set *s = &sets[(i + rep) % nhs];
            double t0 = bu_cpu_now();
            if ((r = gs_simnet_run(s->sim, frames * FRAME, FRAME)) != GS_OK) die("gs_simnet_run", s->w[0], r);
            s->v[rep] = (bu_cpu_now() - t0) / ((double)s->H * (frames * FRAME / DT));
        }
    for (k = 0; k < nhs; ++k) {
        host_set *s = &sets[k];
        rows[k].hosts = s->H;
        rows[k].host_step = bu_median(s->v, reps);
        rows[k].bytes_per_world = 0.0;
        for (i = 0; i < s->H; ++i) rows[k].bytes_per_world += s->cw[i].live;
        rows[k].bytes_per_world /= s->H;
        rows[k].simnet_bytes = s->cs.live;
        gs_simnet_destroy(s->sim);
        for (i = 0; i < s->H; ++i) gs_world_destroy(s->w[i]);
    }
    free(sets);
}

int main(int argc, char **argv)
{
    static const int cl_full[] = {8, 16, 32, 64, 128, 181}, cl_quick[] = {8, 16, 32, 64};
    static const int rg_full[] = {1, 3, 10, 30, 100, 300, 1000}, rg_quick[] = {1, 10, 100, 1000};
    static const int hs_full[] = {2, 3, 4, 6, 8, 12, 16}, hs_quick[] = {2, 4, 8, 16};
    bu_args a;
    const int *cl, *rg, *hs;
    int ncl, nrg, nhs, i;
    cloth_row crow[8];
    rigid_row rrow[8];
    rest_row rest;
    host_row hrow[8];
    double pace[PACE_SIZES][PACE_INTEGRATORS];
    double x[8], y[8], y2[8], k_same, k_default, k_rigid, k_hosts, k_hosts_total, fa, per_particle,
        per_particle_ghost, per_peer, per_body;
    bu_json *j;
    double t_start = bu_now();
    int pa = bu_parse_args(argc, argv, "scaling", &a);
    if (pa) return pa > 0 ? 0 : 2;
    cl = a.quick ? cl_quick : cl_full;
    ncl = a.quick ? 4 : 6;
    rg = a.quick ? rg_quick : rg_full;
    nrg = a.quick ? 4 : 7;
    hs = a.quick ? hs_quick : hs_full;
    nhs = a.quick ? 4 : 7;

    fprintf(stderr, "scaling%s: cost per step against size (dt 1 ms)\n", a.quick ? " --quick" : "");
    fprintf(stderr, "%10s %10s %14s %14s %9s %12s %12s\n", "cloth", "particles", "same-part us",
            "1kg-1m us", "substeps", "bytes", "with ghost");
    for (i = 0; i < ncl; ++i) {
        crow[i] = run_cloth(cl[i], a.quick);
        fprintf(stderr, "%7dx%-3d %10d %14.2f %14.2f %9.1f %12.0f %12.0f\n", cl[i], cl[i], cl[i] * cl[i],
                crow[i].step_same * 1e6, crow[i].step_default * 1e6, crow[i].substeps_default, crow[i].bytes,
                crow[i].bytes_ghost);
        x[i] = (double)cl[i] * cl[i];
        y[i] = crow[i].step_same;
        y2[i] = crow[i].step_default;
    }
    k_same = fit_exponent(x, y, ncl);
    k_default = fit_exponent(x, y2, ncl);
    for (i = 0; i < ncl; ++i) { y[i] = crow[i].bytes; y2[i] = crow[i].bytes_ghost; }
    fit_line(x, y, ncl, &fa, &per_particle);
    fit_line(x, y2, ncl, &fa, &per_particle_ghost);
    fprintf(stderr, "  exponent: %.2f (same particle), %.2f (1 kg, 1 m); memory %.0f B/particle, %.0f with a ghost\n",
            k_same, k_default, per_particle, per_particle_ghost);

    fprintf(stderr, "%10s %14s %14s %12s %14s\n", "spheres", "step us", "us per body", "bytes",
            "asleep us");
    for (i = 0; i < nrg; ++i) {
        rrow[i] = run_rigid(rg[i], a.quick);
        fprintf(stderr, "%10d %14.2f %14.3f %12.0f %14.2f\n", rg[i], rrow[i].step * 1e6,
                rrow[i].step * 1e6 / rg[i], rrow[i].bytes, rrow[i].step_asleep * 1e6);
        x[i] = rg[i];
        y[i] = rrow[i].step;
        y2[i] = rrow[i].bytes;
    }
    k_rigid = fit_exponent(x, y, nrg);
    fit_line(x, y2, nrg, &fa, &per_body);
    fprintf(stderr, "  exponent: %.2f; memory %.0f B/body\n", k_rigid, per_body);
    rest = run_rest(a.quick);
    fprintf(stderr, "paper scene at rest (16x16 cloth, 3 spheres, probe held): %.1f us per 1/60 s "
                    "frame asleep (%d agents asleep), %.1f awake: %.2fx\n",
            rest.frame_asleep * 1e6, rest.asleep, rest.frame_awake * 1e6,
            rest.frame_awake / rest.frame_asleep);

    fprintf(stderr, "paper scene (3 spheres, probe on its path): CPU s per simulated s after the settle "
                    "(-1 refused, - not run)\n%10s %12s %12s %12s\n", "cloth", pace_name[0], pace_name[1],
            pace_name[2]);
    run_pace(a.quick, pace);
    for (i = 0; i < PACE_SIZES; ++i) {
        int k;
        fprintf(stderr, "%7dx%-3d", pace_n[i], pace_n[i]);
        for (k = 0; k < PACE_INTEGRATORS; ++k)
            if (pace[i][k] < -1.5)
                fprintf(stderr, " %12s", "-");
            else
                fprintf(stderr, " %12.3f", pace[i][k]);
        fputc('\n', stderr);
    }

    fprintf(stderr, "%10s %16s %16s %14s %14s\n", "hosts", "us/host-step", "us/step (all)", "bytes/world",
            "simnet bytes");
    run_hosts(hs, nhs, a.quick, hrow);
    for (i = 0; i < nhs; ++i) {
        fprintf(stderr, "%10d %16.2f %16.2f %14.0f %14.0f\n", hs[i], hrow[i].host_step * 1e6,
                hrow[i].host_step * hs[i] * 1e6, hrow[i].bytes_per_world, hrow[i].simnet_bytes);
        x[i] = hs[i];
        y[i] = hrow[i].host_step;
        y2[i] = hrow[i].host_step * hs[i];
    }
    k_hosts = fit_exponent(x, y, nhs);
    k_hosts_total = fit_exponent(x, y2, nhs);
    for (i = 0; i < nhs; ++i) { x[i] = hs[i] - 1; y[i] = hrow[i].bytes_per_world; }
    fit_line(x, y, nhs, &fa, &per_peer);
    fprintf(stderr, "  exponent: %.2f per host, %.2f for all hosts; memory %.0f B per world + %.0f B per peer\n",
            k_hosts, k_hosts_total, fa, per_peer);

    j = bu_json_open(a.out);
    if (!j) return 1;
    bu_json_obj_begin(j, NULL);
    bu_json_header(j, "scaling", a.quick);
    bu_json_str(j, "method",
                "Median thread CPU time per step (gs_world_advance(w, 1 ms)) over repeats; on gs_simnet, wall time of "
                "gs_simnet_run / (hosts x steps). Exponent k of cost ~ size^k by least squares on the logs. Memory: "
                "live bytes through a counting gs_allocator after creation and a few steps; per particle, per "
                "body and per peer are least-squares slopes.");
    bu_json_arr_begin(j, "results");
    for (i = 0; i < ncl; ++i) {
        bu_json_obj_begin(j, NULL);
        bu_json_str(j, "series", "particles");
        bu_json_int(j, "size", (long long)cl[i] * cl[i]);
        bu_json_num(j, "step_us", crow[i].step_same * 1e6);
        bu_json_num(j, "step_us_1kg_1m", crow[i].step_default * 1e6);
        bu_json_num(j, "substeps_1kg_1m", crow[i].substeps_default);
        bu_json_num(j, "ns_per_particle", crow[i].step_same * 1e9 / ((double)cl[i] * cl[i]));
        bu_json_num(j, "bytes", crow[i].bytes);
        bu_json_num(j, "bytes_with_ghost", crow[i].bytes_ghost);
        bu_json_obj_end(j);
    }
    for (i = 0; i < nrg; ++i) {
        bu_json_obj_begin(j, NULL);
        bu_json_str(j, "series", "rigid spheres");
        bu_json_int(j, "size", rg[i]);
        bu_json_num(j, "step_us", rrow[i].step * 1e6);
        bu_json_num(j, "us_per_body", rrow[i].step * 1e6 / rg[i]);
        bu_json_num(j, "step_us_asleep", rrow[i].step_asleep * 1e6);
        bu_json_num(j, "bytes", rrow[i].bytes);
        bu_json_obj_end(j);
    }
    for (i = 0; i < nhs; ++i) {
        bu_json_obj_begin(j, NULL);
        bu_json_str(j, "series", "hosts (16x16 cloth + ghost each)");
        bu_json_int(j, "size", hs[i]);
        bu_json_num(j, "step_us", hrow[i].host_step * 1e6);
        bu_json_num(j, "step_us_all_hosts", hrow[i].host_step * hs[i] * 1e6);
        bu_json_num(j, "bytes", hrow[i].bytes_per_world);
        bu_json_num(j, "simnet_bytes", hrow[i].simnet_bytes);
        bu_json_obj_end(j);
    }
    bu_json_arr_end(j);
    bu_json_obj_begin(j, "summary");
    bu_json_num(j, "exponent_particles", k_same);
    bu_json_num(j, "exponent_particles_1kg_1m", k_default);
    bu_json_num(j, "exponent_rigid_agents", k_rigid);
    bu_json_num(j, "scene_rest_frame_us_asleep", rest.frame_asleep * 1e6);
    bu_json_num(j, "scene_rest_frame_us_awake", rest.frame_awake * 1e6);
    bu_json_num(j, "scene_rest_awake_over_asleep", rest.frame_awake / rest.frame_asleep);
    bu_json_int(j, "scene_rest_agents_asleep", rest.asleep);
    bu_json_num(j, "exponent_hosts_per_host", k_hosts);
    bu_json_num(j, "exponent_hosts_all", k_hosts_total);
    bu_json_num(j, "bytes_per_particle", per_particle);
    bu_json_num(j, "bytes_per_particle_with_ghost", per_particle_ghost);
    bu_json_num(j, "bytes_per_rigid_body", per_body);
    bu_json_num(j, "bytes_per_world_16x16_ghost", fa);
    bu_json_num(j, "bytes_per_peer_16x16_ghost", per_peer);
    bu_json_num(j, "simnet_bytes", hrow[0].simnet_bytes);
    for (i = 0; i < PACE_SIZES; ++i) {
        int k;
        for (k = 0; k < PACE_INTEGRATORS; ++k) {
            char key[64];
            if (pace[i][k] < -1.5) continue;
            snprintf(key, sizeof key, "scene%d_%s_cpu_per_sim_s", pace_n[i], pace_name[k]);
            bu_json_num(j, key, pace[i][k]);
        }
    }
    bu_json_num(j, "wall_s", bu_now() - t_start);
    bu_json_obj_end(j);

    bu_json_arr_begin(j, "plots");
    {
        char title[128];
        const char *names[2];
        const double *xs[2], *ys[2];
        int cnt[2];
        double px[8], py0[8], py1[8];
        for (i = 0; i < ncl; ++i) {
            px[i] = (double)cl[i] * cl[i];
            py0[i] = crow[i].step_same * 1e6;
            py1[i] = crow[i].step_default * 1e6;
        }
        names[0] = "same particle (1 substep)";
        names[1] = "1 kg, 1 m cloth (substeps grow)";
        xs[0] = xs[1] = px;
        ys[0] = py0;
        ys[1] = py1;
        cnt[0] = cnt[1] = ncl;
        snprintf(title, sizeof title, "Cloth step against particles (k = %.2f; %.2f)", k_same, k_default);
        bu_json_plot(j, title, "particles", "us per step", 1, 2, names, xs, ys, cnt);

        for (i = 0; i < nrg; ++i) { px[i] = rg[i]; py0[i] = rrow[i].step * 1e6; }
        names[0] = "spheres resting on the ground";
        cnt[0] = nrg;
        snprintf(title, sizeof title, "World step against rigid agents (k = %.2f)", k_rigid);
        bu_json_plot(j, title, "rigid agents", "us per step", 1, 1, names, xs, ys, cnt);

        for (i = 0; i < nhs; ++i) {
            px[i] = hs[i];
            py0[i] = hrow[i].host_step * 1e6;
            py1[i] = hrow[i].host_step * hs[i] * 1e6;
        }
        names[0] = "per host";
        names[1] = "all hosts";
        cnt[0] = cnt[1] = nhs;
        snprintf(title, sizeof title, "Step on gs_simnet against hosts (k = %.2f per host, %.2f all)", k_hosts,
                 k_hosts_total);
        bu_json_plot(j, title, "hosts", "us per step", 1, 2, names, xs, ys, cnt);
    }
    bu_json_arr_end(j);
    bu_json_obj_end(j);
    if (bu_json_close(j) != 0) return 1;
    fprintf(stderr, "scaling: wrote %s in %.1f s\n", a.out, bu_now() - t_start);
    return 0;
}
