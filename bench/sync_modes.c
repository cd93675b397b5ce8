/* sync_modes - the two sync modes side by side: GS_SYNC_PRESENT (the
   paper's blend at the local present, the local clock: the library's
   default) and GS_SYNC_REPLAY (the session clock, each snapshot blended at
   its own time in a re-run from the world history).

   Each host is a world with the paper's scene (gs_scene: 16x16 cloth,
   three spheres, one probe per host), ghosts under the client/server rule
   (probes under owner authority). Each host runs alone for SETTLE s, then
   all join the simnet; host 1's probe follows the scene's scripted path
   for PUSH s and parks, and the run goes on for AFTER s. Frames of 1/60 s.

   Method (also in the JSON "method"):
   - divergence at equal simulation time (bench/equal_time.h, shared with
     bench/bandwidth): every frame, each host's cloth time and its
     objects' positions are kept; host k's samples are interpolated
     (linearly) to host 1's cloth time, and the divergence is
     the largest over the objects of the RMS distance (cloth) or the
     distance (spheres), the largest over hosts 2..n. While pushing: the
     samples of the push; after: whether the copies are bitwise equal
     (divergence exactly 0 at equal time: compared at a time both hosts
     sampled) from 1 s after the stop to the end, and the last figure;
   - the simulation-time gap at equal wall time: |target_k - target_1| at
     the end of every frame (gs_world_time), p95 over the run from the push;
   - replay CPU: the share of agent steps that replays re-ran
     (gs_sync_stats.replay_steps over all steps), times the CPU time of a
     host's frame (the thread's CPU time of gs_simnet_run over hosts),
     as a share of the 1/60 s frame. */
#include "bench_util.h"

#define GHOSTSIM_IMPLEMENTATION
#include "../ghostsim.h"
#include "../tests/net_helpers.h"
#include "equal_time.h"

#include <string.h>

/* An agent's counters by value (gs_agent_get_stats fills an out-pointer). */
static gs_agent_stats agent_stats(const gs_agent *a) {
    gs_agent_stats st;
    memset(&st, 0, sizeof st);
    gs_agent_get_stats(a, &st);
    return st;
}

#define FRAME (1.0 / 60.0)
#define SETTLE 1.0
#define PARK_HEIGHT 0.4
#define MAX_HOSTS 4
#define MAX_FRAMES 1200
#define NOBJ 4 /* the cloth and three spheres */

typedef struct profile {
    const char *name;
    gs_link_desc link;
} profile;

typedef struct host {
    gs_world *w;
    gs_scene sc;
    et_samples s;                 /* MAX_FRAMES: the cloth's time, its
                                     particles, then the spheres */
} host;

typedef struct result {
    const char *profile, *mode;
    int hosts;
    double push_med, push_p95, push_max; /* m */
    double after_end;             /* m, at the end */
    double after_max;             /* m, the largest from 1 s after the stop */
    int bitwise_after_1s;         /* 1: equal at every compared sample from
                                     1 s after the stop */
    double gap_p95, gap_max;      /* s, at equal wall time */
    double replay_share;          /* of the steps */
    double replay_push_worst;     /* the largest over hosts of the share
                                     during the push (a follower's) */
    double replay_cpu_frame;      /* share of the 1/60 s frame */
    double frame_cpu;             /* s of CPU per host frame */
    uint64_t replays, fallbacks;
    uint64_t skipped;             /* replays whose blends changed no state */
    uint64_t near;                /* of those, whose blends moved states
                                     within gs_sync_desc.replay_tolerance */
} result;

static int attach(host *h) {
    gs_ghost_desc gd = gs_ghost_desc_default();
    gd.weight = gs_weight_cs;
    return gs_scene_attach_ghosts(&h->sc, &gd) == GS_OK;
}

static void keep(host *h) {
    int n = gs_mesh_particle_count(h->sc.cloth), i;
    gs_vec3 *p = et_push(&h->s, gs_agent_time(h->sc.cloth));
    if (!p) return;
    memcpy(p, gs_mesh_positions(h->sc.cloth), (size_t)n * sizeof *p);
    for (i = 0; i < h->sc.sphere_count && i < 3; ++i) p[n + i] = gs_rigid_position(h->sc.spheres[i]);
}

static void drive(host *h, double t, double push) {
    const gs_quat id = {0.0, 0.0, 0.0, 1.0};
    gs_vec3 p = gs_scene_probe_path(0, t < push ? t : push);
    if (t >= push) p.y = PARK_HEIGHT;
    gs_probe_set_target(h->sc.probes[0], p, id);
}

static const char *const mode_names[3] = {"present", "pres+clk", "replay"};

/* A host's steps so far, and the steps its replays re-ran. */
static void count_steps(gs_world *w, uint64_t *steps, uint64_t *rsteps) {
    gs_sync_stats st;
    int a;
    gs_world_sync_stats(w, &st);
    *rsteps = st.replay_steps;
    *steps = 0;
    for (a = 0; a < gs_world_agent_count(w); ++a) *steps += agent_stats(gs_world_agent(w, a)).steps;
}

/* mode 0: the defaults (present, local clock); 1: present on the session
   clock; 2: replay on the session clock. */
static int run(const profile *pr, int mode, int nhosts, double push, double after, result *r) {
    static double push_div[MAX_FRAMES], gaps[MAX_FRAMES];
    gs_simnet *sim = NULL;
    gs_simnet_desc simd;
    host h[MAX_HOSTS];
    int frames = (int)((push + after) / FRAME + 0.5), k, i, j, np = 0, ng = 0, ok = 0, n;
    double cpu = 0.0;
    uint64_t steps = 0, rsteps = 0, push_steps[MAX_HOSTS], push_rsteps[MAX_HOSTS];
    memset(r, 0, sizeof *r);
    memset(h, 0, sizeof h);
    memset(&simd, 0, sizeof simd);
    simd.seed = 7;
    r->profile = pr->name;
    r->mode = mode_names[mode];
    r->hosts = nhosts;
    r->bitwise_after_1s = 1;
    if (frames > MAX_FRAMES) frames = MAX_FRAMES;
    if (gs_simnet_create(&simd, &sim) != GS_OK) return 0;
    for (k = 0; k < nhosts; ++k) {
        gs_world_desc wd = gs_world_desc_default();
        gs_scene_desc sd = gs_scene_desc_default();
        wd.host_id = (uint32_t)k + 1;
        if (mode > 0) wd.sync.clock = GS_SYNC_CLOCK_SESSION;
        if (mode > 1) wd.sync.mode = GS_SYNC_REPLAY;
        sd.probe_count = nhosts;
        if (gs_world_create(&wd, &h[k].w) != GS_OK || gs_scene_create(h[k].w, &sd, &h[k].sc) != GS_OK ||
            !attach(&h[k]))
            goto done;
        n = gs_mesh_particle_count(h[k].sc.cloth);
        if (et_alloc(&h[k].s, MAX_FRAMES, n + (h[k].sc.sphere_count < 3 ? h[k].sc.sphere_count : 3),
                     n) != 0)
            goto done;
        gs_world_advance(h[k].w, SETTLE, NULL);
    }
    for (k = 0; k < nhosts; ++k) {
        gs_net *net;
        if (test_join(sim, h[k].w, NULL, &net) != GS_OK) goto done;
    }
    for (k = 0; k < nhosts; ++k)
        for (j = 0; j < nhosts; ++j)
            if (j != k) gs_simnet_link(sim, (uint32_t)k + 1, (uint32_t)j + 1, &pr->link);
    for (k = 0; k < nhosts; ++k) count_steps(h[k].w, &push_steps[k], &push_rsteps[k]);
    for (i = 0; i < frames; ++i) {
        double c0;
        if (i == (int)(push / FRAME + 0.5))
            for (k = 0; k < nhosts; ++k) {
                uint64_t s, rs;
                count_steps(h[k].w, &s, &rs);
                if (s > push_steps[k])
                    r->replay_push_worst = fmax(r->replay_push_worst, (double)(rs - push_rsteps[k]) /
                                                                        (double)(s - push_steps[k]));
            }
        drive(&h[0], gs_simnet_time(sim), push);
        c0 = bu_cpu_now();
        gs_simnet_run(sim, FRAME, FRAME);
        cpu += bu_cpu_now() - c0;
        for (k = 0; k < nhosts; ++k) keep(&h[k]);
        {
            double g = 0.0;
            for (k = 1; k < nhosts; ++k) g = fmax(g, fabs(gs_world_time(h[k].w) - gs_world_time(h[0].w)));
            gaps[ng++] = g;
        }
    }
    for (i = 0; i < frames; ++i) {
        double now = (i + 1) * FRAME, d = 0.0;
        int any = 0;
        for (k = 1; k < nhosts; ++k) {
            double dk = et_diverge_at(&h[0].s, i, &h[k].s);
            if (dk >= 0.0) { any = 1; if (dk > d) d = dk; }
        }
        if (!any) continue;
        if (now <= push) push_div[np++] = d;
        if (now >= push + 1.0 && d > r->after_max) r->after_max = d;
        if (now >= push + 1.0 && d != 0.0) r->bitwise_after_1s = 0;
        r->after_end = d;
    }
    r->push_med = bu_quantile(push_div, np, 0.5);
    r->push_p95 = bu_quantile(push_div, np, 0.95);
    r->push_max = bu_quantile(push_div, np, 1.0);
    r->gap_p95 = bu_quantile(gaps, ng, 0.95);
    r->gap_max = bu_quantile(gaps, ng, 1.0);
    for (k = 0; k < nhosts; ++k) {
        gs_sync_stats st;
        int a;
        gs_world_sync_stats(h[k].w, &st);
        rsteps += st.replay_steps;
        r->replays += st.replays;
        r->skipped += st.replays_skipped;
        r->near += st.replays_near;
        r->fallbacks += st.fallbacks;
        for (a = 0; a < gs_world_agent_count(h[k].w); ++a)
            steps += agent_stats(gs_world_agent(h[k].w, a)).steps;
    }
    r->replay_share = steps ? (double)rsteps / (double)steps : 0.0;
    r->frame_cpu = cpu / frames / nhosts;
    r->replay_cpu_frame = r->replay_share * r->frame_cpu / FRAME;
    ok = 1;
done:
    for (k = 0; k < nhosts; ++k) {
        gs_world_destroy(h[k].w);
        et_free(&h[k].s);
    }
    gs_simnet_destroy(sim);
    return ok;
}

int main(int argc, char **argv) {
    static profile profs[3];
    static result res[32];
    bu_args args;
    bu_json *j;
    int np, nh, p, m, hh, nr = 0, i, hosts[2] = {2, 4};
    double push, after;
    const char *only = NULL;
    int a;
    /* --profile lan|wan|harsh runs that one alone (then the other flags) */
    if (argc >= 3 && strcmp(argv[1], "--profile") == 0) {
        only = argv[2];
        argv[2] = argv[0];
        argv += 2;
        argc -= 2;
    }
    a = bu_parse_args(argc, argv, "sync_modes", &args);
    if (a) return a < 0 ? 2 : 0;
    memset(profs, 0, sizeof profs);
    profs[0].name = "lan";
    profs[0].link.latency = 0.0005;
    profs[1].name = "wan";
    profs[1].link.latency = 0.025;
    profs[1].link.jitter = 0.005;
    profs[1].link.loss = 0.02;
    profs[2].name = "harsh";
    profs[2].link.latency = 0.075;
    profs[2].link.jitter = 0.025;
    profs[2].link.loss = 0.10;
    profs[2].link.duplicate = 0.05;
    np = args.quick ? 2 : 3;
    nh = args.quick ? 1 : 2;
    push = args.quick ? 1.5 : 4.0;
    after = args.quick ? 1.5 : 4.0;
    fprintf(stderr, "%-6s %-8s %5s | %9s %9s %9s | %9s %9s %7s | %8s %8s | %7s %7s %6s %6s %6s %6s | %7s %7s\n", "link",
            "mode", "hosts", "push med", "push p95", "push max", "stop+1s", "end", "bitwise",
            "gap p95", "gap max", "replay", "cpu/fr", "fallb", "replays", "skip", "near", "push:rep",
            "cpu/fr");
    if (only) np = 3;
    for (p = 0; p < np; ++p)
        for (hh = 0; hh < nh; ++hh)
            for (m = 0; m < 3; ++m) {
                result *r = &res[nr];
                if (only && strcmp(only, profs[p].name) != 0) continue;
                if (!run(&profs[p], m, hosts[hh], push, after, r)) {
                    fprintf(stderr, "sync_modes: a run failed to set up\n");
                    return 1;
                }
                fprintf(stderr,
                        "%-6s %-8s %5d | %7.3fmm %7.3fmm %7.3fmm | %8.2em %8.2em %7s | %6.2fms %6.2fms | %6.1f%% %6.1f%% %6lu %6lu %6lu %6lu | %6.1f%% %6.1f%%\n",
                        r->profile, r->mode, r->hosts, 1e3 * r->push_med, 1e3 * r->push_p95,
                        1e3 * r->push_max, r->after_max, r->after_end,
                        r->bitwise_after_1s ? "yes" : "no",
                        1e3 * r->gap_p95, 1e3 * r->gap_max, 100.0 * r->replay_share,
                        100.0 * r->replay_cpu_frame, (unsigned long)r->fallbacks,
                        (unsigned long)r->replays, (unsigned long)r->skipped, (unsigned long)r->near,
                        100.0 * r->replay_push_worst,
                        100.0 * r->replay_push_worst * r->frame_cpu / FRAME);
                nr++;
            }
    j = bu_json_open(args.out);
    if (!j) return 1;
    bu_json_obj_begin(j, NULL);
    bu_json_header(j, "sync_modes", args.quick);
    bu_json_str(j, "method",
                "paper scene on the simnet, client/server rule; divergence at equal simulation time "
                "(host k's samples interpolated to host 1's cloth time), p95 over the push; gap: "
                "|target_k - target_1| at equal wall time; replay CPU = replayed share of steps x a host's "
                "frame CPU / (1/60 s)");
    bu_json_arr_begin(j, "results");
    for (i = 0; i < nr; ++i) {
        result *r = &res[i];
        bu_json_obj_begin(j, NULL);
        bu_json_str(j, "profile", r->profile);
        bu_json_str(j, "mode", r->mode);
        bu_json_int(j, "hosts", r->hosts);
        bu_json_num(j, "divergence_push_median_m", r->push_med);
        bu_json_num(j, "divergence_push_p95_m", r->push_p95);
        bu_json_num(j, "divergence_push_max_m", r->push_max);
        bu_json_num(j, "divergence_end_m", r->after_end);
        bu_json_num(j, "divergence_max_from_1s_after_stop_m", r->after_max);
        bu_json_bool(j, "bitwise_equal_1s_after_stop", r->bitwise_after_1s);
        bu_json_num(j, "gap_p95_s", r->gap_p95);
        bu_json_num(j, "gap_max_s", r->gap_max);
        bu_json_num(j, "replay_step_share", r->replay_share);
        bu_json_num(j, "replay_step_share_push_worst_host", r->replay_push_worst);
        bu_json_num(j, "replay_cpu_frame_share_push_worst_host",
                    r->replay_push_worst * r->frame_cpu / FRAME);
        bu_json_num(j, "replay_cpu_frame_share", r->replay_cpu_frame);
        bu_json_int(j, "replays", (long long)r->replays);
        bu_json_int(j, "replays_skipped", (long long)r->skipped);
        bu_json_int(j, "replays_skipped_near", (long long)r->near);
        bu_json_int(j, "fallbacks", (long long)r->fallbacks);
        bu_json_obj_end(j);
    }
    bu_json_arr_end(j);
    bu_json_obj_begin(j, "summary");
    for (i = 0; i < nr; ++i) {
        char key[96];
        result *r = &res[i];
        if (r->hosts != 2) continue;
        snprintf(key, sizeof key, "%s_%s_push_p95_m", r->profile, r->mode);
        bu_json_num(j, key, r->push_p95);
    }
    bu_json_obj_end(j);
    bu_json_arr_begin(j, "plots");
    bu_json_arr_end(j);
    bu_json_obj_end(j);
    return bu_json_close(j) == 0 ? 0 : 1;
}
