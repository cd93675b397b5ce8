/* pace - does the paper scene keep wall-clock pace, and what does a
   spring cost: the figures of issue 17's targets, in one short run.

   - scene: gs_scene_create's scene (3 spheres, one probe per host on its
     path) with an n x n cloth (default 128) under XPBD, the integrator the
     README recommends from 32 x 32 up, its default 4 substeps; after the
     settle, thread CPU seconds per simulated second over 60 Hz frames,
     alone (one world, no net) and with 2 hosts on gs_simnet (both worlds
     in this thread, every agent under a ghost as ghostpeer has them, CPU
     divided by 2: per host). Under 0.5 a host keeps wall-clock pace on
     half a core. Then 2 hosts again at README's schedule for large
     cloths (dt 4 ms, 4 substeps; 0 in a desc is the default 2 ms x 4).
   - springs: a 64 x 64 cloth of 1 kg, 1 m, stiffness 5000 / 5000 / 500
     N/m, damping 0.5 N s/m (bench/physics's cloth), dt 1 ms, pinned at
     its corners, under XPBD and symplectic Euler: CPU ns per spring per
     substep (everything the step does, divided by springs x substeps).
   Both are CPU time: a busy machine's waits do not count, but its shared
   caches do; compare figures taken in one run.

   usage: build/bench/pace [--quick] [--out FILE.json] */
#define GHOSTSIM_IMPLEMENTATION
#include "ghostsim.h"
#include "tests/net_helpers.h"
#include "bench_util.h"

#define FRAME (1.0 / 60.0)
/* README's schedule for large XPBD cloths (bench/schedule: its accuracy). */
#define REC_DT 0.004
#define REC_SUBSTEPS 4
#ifndef PACE_N
#define PACE_N 128 /* the cloth of the scene; -DPACE_N=64 for a profile under valgrind */
#endif
/* -DPACE_CALLGRIND: only the 2-host run, instrumented from the first frame
   (valgrind --tool=callgrind --instr-atstart=no): the scenes' settle is not
   in the profile. */
#ifdef PACE_CALLGRIND
#include <valgrind/callgrind.h>
#define PACE_PROFILE_BEGIN() CALLGRIND_START_INSTRUMENTATION
#define PACE_PROFILE_END() CALLGRIND_STOP_INSTRUMENTATION
#else
#define PACE_PROFILE_BEGIN() ((void)0)
#define PACE_PROFILE_END() ((void)0)
#endif

static void die(const char *what, gs_world *w, gs_result r)
{
    fprintf(stderr, "pace: %s: %s (%s)\n", what, gs_result_str(r), w ? gs_world_error(w) : "");
    exit(1);
}

typedef struct host {
    gs_world *w;
    gs_scene sc;
} host;

/* Host id (1-based) of H hosts, its scene built once the net knows its
   peers (one probe per host) and ghosts on every agent. */
static void host_make(host *h, gs_simnet *sim, uint32_t id, int H, int n, double dt, int substeps)
{
    gs_world_desc wd = gs_world_desc_default();
    gs_scene_desc sd = gs_scene_desc_default();
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_net_desc nd;
    gs_net *net;
    gs_result r;
    wd.host_id = id;
    if ((r = gs_world_create(&wd, &h->w)) != GS_OK) die("gs_world_create", NULL, r);
    if (sim) {
        memset(&nd, 0, sizeof nd);
        nd.bandwidth = 1e9;
        if ((r = test_join(sim, h->w, &nd, &net)) != GS_OK) die("gs_net_create on the simnet", h->w, r);
    }
    sd.cloth_n = n;
    sd.cloth_integrator = GS_INTEGRATOR_XPBD;
    sd.dt = dt;
    sd.cloth_substeps = substeps;
    sd.probe_count = H;
    if ((r = gs_scene_create(h->w, &sd, &h->sc)) != GS_OK) die("gs_scene_create", h->w, r);
    if (sim && (r = gs_scene_attach_ghosts(&h->sc, &gd)) != GS_OK) die("gs_scene_attach_ghosts", h->w, r);
}

/* Host k moves probe k (host k + 1's, as ghostpeer's hosts do). */
static void drive(host *h, int k, double t)
{
    const gs_quat id = {0.0, 0.0, 0.0, 1.0};
    if (k < h->sc.probe_count) gs_probe_set_target(h->sc.probes[k], gs_scene_probe_path(k, t), id);
}

/* CPU seconds per simulated second per host: H = 1 alone, else H hosts
   on a simnet. Each host drives its own probe (probe i is host i + 1's). */
static double scene_pace(int n, int H, double seconds, double dt, int substeps)
{
    host hs[2];
    gs_simnet *sim = NULL;
    gs_simnet_desc smd = gs_simnet_desc_default();
    gs_result r;
    int i, k, frames = (int)(seconds * 60.0 + 0.5);
    double t0, cost;
    if (H > 1 && (r = gs_simnet_create(&smd, &sim)) != GS_OK) die("gs_simnet_create", NULL, r);
    for (k = 0; k < H; ++k) host_make(&hs[k], sim, (uint32_t)k + 1u, H, n, dt, substeps);
    if (sim) gs_simnet_run(sim, 2 * FRAME, FRAME); /* the hosts meet */
    t0 = bu_cpu_now();
    PACE_PROFILE_BEGIN();
    for (i = 0; i < frames; ++i) {
        for (k = 0; k < H; ++k) drive(&hs[k], k, i * FRAME);
        if (sim) {
            if ((r = gs_simnet_run(sim, FRAME, FRAME)) != GS_OK) die("gs_simnet_run", hs[0].w, r);
        } else if ((r = gs_world_advance(hs[0].w, FRAME, NULL)) != GS_OK) {
            die("gs_world_advance", hs[0].w, r);
        }
    }
    PACE_PROFILE_END();
    cost = (bu_cpu_now() - t0) / (H * (frames * FRAME));
    if (sim) gs_simnet_destroy(sim);
    for (k = 0; k < H; ++k) gs_world_destroy(hs[k].w);
    return cost;
}

/* CPU ns per spring per substep of bench/physics's cloth. */
static double spring_ns(int n, gs_integrator it, int steps)
{
    gs_world_desc wd = gs_world_desc_default();
    gs_cloth_desc cd = gs_cloth_desc_default();
    gs_agent_stats s0, s1;
    gs_world *w;
    gs_agent *cl;
    gs_result r;
    double t0, t;
    int i;
    if ((r = gs_world_create(&wd, &w)) != GS_OK) die("gs_world_create", NULL, r);
    cd.nx = cd.ny = n;
    cd.stretch_stiffness = cd.shear_stiffness = 5000.0;
    cd.bend_stiffness = 500.0;
    cd.spring_damping = 0.5;
    cd.pin_corners = GS_CORNER_ALL;
    cd.solver.dt = 0.001;
    cd.solver.integrator = it;
    if ((r = gs_cloth_create(w, &cd, &cl)) != GS_OK) die("gs_cloth_create", w, r);
    memset(&s0, 0, sizeof s0);
    memset(&s1, 0, sizeof s1);
    for (i = 0; i < 20; ++i) gs_world_advance(w, 0.001, NULL);
    if ((r = gs_agent_get_stats(cl, &s0)) != GS_OK) die("gs_agent_get_stats", w, r);
    t0 = bu_cpu_now();
    for (i = 0; i < steps; ++i)
        if ((r = gs_world_advance(w, 0.001, NULL)) != GS_OK) die("gs_world_advance", w, r);
    t = bu_cpu_now() - t0;
    if ((r = gs_agent_get_stats(cl, &s1)) != GS_OK) die("gs_agent_get_stats", w, r);
    t = 1e9 * t / ((double)(s1.substeps - s0.substeps) * gs_mesh_spring_count(cl));
    gs_world_destroy(w);
    return t;
}

int main(int argc, char **argv)
{
    bu_args a;
    bu_json *j;
    double alone, two, rec, xp, sy;
    int n = PACE_N;
    int pa = bu_parse_args(argc, argv, "pace", &a);
    if (pa) return pa > 0 ? 0 : 2;
#ifdef PACE_CALLGRIND
    fprintf(stderr, "%dx%d xpbd, 2 hosts: %.3f CPU s per sim s per host (under callgrind)\n", n, n,
            scene_pace(n, 2, 0.5, 0.0, 0));
    return 0;
#endif
    xp = spring_ns(64, GS_INTEGRATOR_XPBD, a.quick ? 100 : 400);
    sy = spring_ns(64, GS_INTEGRATOR_SYMPLECTIC_EULER, a.quick ? 30 : 120);
    fprintf(stderr, "64x64 cloth, dt 1 ms: %.2f ns per spring per substep (xpbd), %.2f (symplectic)\n", xp, sy);
    alone = scene_pace(n, 1, a.quick ? 1.0 : 4.0, 0.0, 0);
    fprintf(stderr, "%dx%d xpbd, alone: %.3f CPU s per sim s\n", n, n, alone);
    two = scene_pace(n, 2, a.quick ? 1.0 : 4.0, 0.0, 0);
    fprintf(stderr, "%dx%d xpbd, 2 hosts on simnet: %.3f CPU s per sim s per host (target <= 0.5)\n", n, n, two);
    rec = scene_pace(n, 2, a.quick ? 1.0 : 4.0, REC_DT, REC_SUBSTEPS);
    fprintf(stderr, "%dx%d xpbd at dt %g s x %d substeps (README's schedule for large cloths), 2 hosts: "
            "%.3f CPU s per sim s per host (target <= 0.5)\n", n, n, REC_DT, REC_SUBSTEPS, rec);
    j = bu_json_open(a.out);
    if (!j) return 1;
    bu_json_obj_begin(j, NULL);
    bu_json_header(j, "pace", a.quick);
    bu_json_str(j, "method",
                "Thread CPU time. Scene: gs_scene_create (XPBD cloth, 3 spheres, a probe per host on its path) "
                "after its settle, 60 Hz frames, alone and 2 hosts on gs_simnet under ghosts (per host). Springs: "
                "64x64 cloth of bench/physics at dt 1 ms, CPU per spring per substep of the whole step.");
    bu_json_obj_begin(j, "summary");
    bu_json_int(j, "cloth_n", n);
    bu_json_num(j, "scene_alone_cpu_per_sim_s", alone);
    bu_json_num(j, "scene_2hosts_cpu_per_sim_s_per_host", two);
    bu_json_num(j, "xpbd_64_ns_per_spring_substep", xp);
    bu_json_num(j, "symplectic_64_ns_per_spring_substep", sy);
    bu_json_str(j, "target", "128x128 XPBD scene, 2 hosts: <= 0.5 CPU s per simulated s per host");
    bu_json_num(j, "scene_2hosts_recommended_cpu_per_sim_s_per_host", rec);
    bu_json_num(j, "recommended_dt", REC_DT);
    bu_json_int(j, "recommended_substeps", REC_SUBSTEPS);
    bu_json_bool(j, "target_met", n == 128 && two <= 0.5);
    bu_json_str(j, "target_recommended", "the same at README's schedule for large cloths: <= 0.5");
    bu_json_bool(j, "target_met_recommended", n == 128 && rec <= 0.5);
    bu_json_str(j, "target_springs", "<= 3 ns per spring per substep at 64x64 (XPBD and symplectic)");
    bu_json_bool(j, "target_met_springs", xp <= 3.0 && sy <= 3.0);
    bu_json_obj_end(j);
    bu_json_obj_end(j);
    bu_json_close(j);
    return 0;
}
