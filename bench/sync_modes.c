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
     sampled: bench/equal_time.h's et_equal_at, not interpolated; a
     host whose target fell just short of a step boundary at a frame's
     end is a step behind there and is not compared at that frame) from
     1 s after the stop to the end, and the last figure;
   - the simulation-time gap at equal wall time: |target_k - target_1| at
     the end of every frame (gs_world_time), p95 over the run from the push;
   - replay CPU: the agent steps that replays re-ran
     (gs_sync_stats.replay_steps) per frame, on the busiest host while the
     probe pushes (and over every host and the run), times the CPU of one
     agent step: the thread's CPU time of gs_simnet_run over every agent
     step the hosts ran, first runs and re-runs (the steps gs_agent_stats
     counts, which a rewind restores, plus replay_steps), as a share of
     the 1/60 s frame. (Until session 14 the bench took the re-run steps'
     share of the first-run steps times a host's whole frame CPU, re-runs
     included, which counted the re-runs' own CPU twice: 1.4-1.7x the
     figure on a follower that re-runs a frame per frame.) `push:rep` is
     the load-independent part: the busiest host's re-run steps over its
     first-run steps while the probe pushes;
   - convergence after the stop: the time from the stop after which every
     compared sample is bitwise equal (`conv 0`, at the times both hosts
     sampled, as above; the JSON also has the interpolated figure, which
     an equal pair one step apart at a frame's end leaves at the scene's
     interpolation error, ~1e-6 m at rest), or within 1 mm (`conv 1mm`,
     interpolated), to the end of the run; "never" when the last one is
     not;
   - the outage (`--outage`, WAN link, 2 hosts): host 1's probe pushes from
     the start, the links are cut OUT_AT..OUT_AT+OUT_LEN s, host 2's probe
     pushes during the cut too, both park when it ends; pace during the
     cut: the least simulation time a host advanced over the cut's
     seconds, the largest lag (gs_sync_stats.lag) and the CPU of a host's
     frame as a share of the frame; after it: conv 0 and conv 1mm from the
     reconnection. */
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
#define OUT_AT 1.0  /* s from the start: the outage scenario's cut */
#define OUT_LEN 5.0
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
    double replay_cpu_frame;      /* share of the 1/60 s frame, over every
                                     host and the run */
    double replay_cpu_push;       /* share of the frame, the busiest host
                                     while the probe pushes */
    double frame_cpu;             /* s of CPU per host frame */
    double conv0, conv1mm;        /* s from the stop (or the reconnection)
                                     to bitwise equal / within 1 mm for
                                     good; -1: not by the end */
    double conv0_interp;          /* conv0 with host k interpolated to
                                     host 1's time at every frame */
    double exact_share;           /* of the host pairs and frames from 1 s
                                     after the stop: those compared at a
                                     time both sampled */
    int outage;                   /* the outage scenario */
    double out_pace;              /* the least of a host's simulation time
                                     advanced during the cut over its s */
    double out_lag;               /* s, the largest lag during the cut */
    double out_cpu;               /* CPU of a host frame during the cut,
                                     share of the frame */
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

/* Host h's own probe (index i) on the scene's path i until `push`, then
   parked above it. */
static void drive(host *h, int i, double t, double push) {
    const gs_quat id = {0.0, 0.0, 0.0, 1.0};
    gs_vec3 p = gs_scene_probe_path(i, t < push ? t : push);
    if (t >= push) p.y = PARK_HEIGHT;
    gs_probe_set_target(h->sc.probes[i], p, id);
}

/* s from `from` after which every compared sample (d[i] at time
   (i + 1) * FRAME, -1 when none) is within lim to the end; -1 when the
   last is not. */
static double converged(const double *d, int n, double from, double lim) {
    double at = -1.0;
    int i;
    for (i = 0; i < n; ++i) {
        double t = (i + 1) * FRAME;
        if (t < from || d[i] < 0.0) continue;
        if (d[i] > lim) at = -1.0;
        else if (at < 0.0) at = t - from;
    }
    return at;
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
static int replay_every; /* gs_sync_desc.replay_every; 0: the default */

/* outage: the outage scenario (see the top), push is then the cut's end */
static int run(const profile *pr, int mode, int nhosts, double push, double after, int outage,
               result *r) {
    static double push_div[MAX_FRAMES], gaps[MAX_FRAMES], divs[MAX_FRAMES], eqs[MAX_FRAMES];
    gs_simnet *sim = NULL;
    gs_simnet_desc simd;
    host h[MAX_HOSTS];
    int frames = (int)((push + after) / FRAME + 0.5), k, i, j, np = 0, ng = 0, ok = 0, n;
    double cpu = 0.0, out_cpu = 0.0, out_t0[MAX_HOSTS];
    uint64_t steps = 0, rsteps = 0, push_steps[MAX_HOSTS], push_rsteps[MAX_HOSTS];
    uint64_t loop_steps = 0, loop_rsteps = 0, worst_rsteps = 0;
    int out_frames = 0, pairs = 0, exact = 0;
    memset(r, 0, sizeof *r);
    memset(h, 0, sizeof h);
    memset(&simd, 0, sizeof simd);
    simd.seed = 7;
    r->profile = pr->name;
    r->mode = mode_names[mode];
    r->hosts = nhosts;
    r->bitwise_after_1s = 1;
    r->outage = outage;
    r->out_pace = HUGE_VAL;
    if (frames > MAX_FRAMES) frames = MAX_FRAMES;
    if (gs_simnet_create(&simd, &sim) != GS_OK) return 0;
    for (k = 0; k < nhosts; ++k) {
        gs_world_desc wd = gs_world_desc_default();
        gs_scene_desc sd = gs_scene_desc_default();
        wd.host_id = (uint32_t)k + 1;
        if (mode > 0) wd.sync.clock = GS_SYNC_CLOCK_SESSION;
        if (mode > 1) wd.sync.mode = GS_SYNC_REPLAY;
        wd.sync.replay_every = replay_every;
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
            if (j != k) {
                gs_link_desc l = pr->link;
                if (outage) {
                    l.outage_start[0] = gs_simnet_time(sim) + OUT_AT;
                    l.outage_end[0] = gs_simnet_time(sim) + OUT_AT + OUT_LEN;
                }
                gs_simnet_link(sim, (uint32_t)k + 1, (uint32_t)j + 1, &l);
            }
    for (k = 0; k < nhosts; ++k) count_steps(h[k].w, &push_steps[k], &push_rsteps[k]);
    for (i = 0; i < frames; ++i) {
        double c0, t = i * FRAME;
        int cut = outage && t >= OUT_AT && t < OUT_AT + OUT_LEN;
        if (i == (int)(push / FRAME + 0.5))
            for (k = 0; k < nhosts; ++k) {
                uint64_t s, rs;
                count_steps(h[k].w, &s, &rs);
                if (s > push_steps[k] && (double)(rs - push_rsteps[k]) / (double)(s - push_steps[k]) >=
                                             r->replay_push_worst) {
                    r->replay_push_worst = (double)(rs - push_rsteps[k]) / (double)(s - push_steps[k]);
                    worst_rsteps = rs - push_rsteps[k];
                }
            }
        if (outage && i == (int)(OUT_AT / FRAME + 0.5))
            for (k = 0; k < nhosts; ++k) out_t0[k] = gs_world_time(h[k].w);
        if (outage && i == (int)((OUT_AT + OUT_LEN) / FRAME + 0.5))
            for (k = 0; k < nhosts; ++k)
                r->out_pace = fmin(r->out_pace, (gs_world_time(h[k].w) - out_t0[k]) / OUT_LEN);
        drive(&h[0], 0, t, push);
        if (outage && nhosts > 1 && t >= OUT_AT) drive(&h[1], 1, t, push);
        c0 = bu_cpu_now();
        gs_simnet_run(sim, FRAME, FRAME);
        c0 = bu_cpu_now() - c0;
        cpu += c0;
        if (cut) {
            out_cpu += c0;
            out_frames++;
            for (k = 0; k < nhosts; ++k) {
                gs_sync_stats st;
                gs_world_sync_stats(h[k].w, &st);
                r->out_lag = fmax(r->out_lag, st.lag);
            }
        }
        for (k = 0; k < nhosts; ++k) keep(&h[k]);
        {
            double g = 0.0;
            for (k = 1; k < nhosts; ++k) g = fmax(g, fabs(gs_world_time(h[k].w) - gs_world_time(h[0].w)));
            gaps[ng++] = g;
        }
    }
    for (i = 0; i < frames; ++i) {
        double now = (i + 1) * FRAME, d = 0.0, e = -1.0;
        int any = 0;
        for (k = 1; k < nhosts; ++k) {
            double dk = et_diverge_at(&h[0].s, i, &h[k].s), ek = et_equal_at(&h[0].s, i, &h[k].s);
            if (dk >= 0.0) { any = 1; if (dk > d) d = dk; }
            if (ek >= 0.0 && ek > e) e = ek;
            if (now >= push + 1.0) pairs++, exact += ek >= 0.0;
        }
        divs[i] = any ? d : -1.0;
        eqs[i] = e;
        if (!any) continue;
        if (now <= push && !(outage && now > OUT_AT)) push_div[np++] = d;
        if (now >= push + 1.0 && d > r->after_max) r->after_max = d;
        if (now >= push + 1.0 && e > 0.0) r->bitwise_after_1s = 0;
        r->after_end = d;
    }
    r->exact_share = pairs ? (double)exact / pairs : 0.0;
    r->push_med = bu_quantile(push_div, np, 0.5);
    r->push_p95 = bu_quantile(push_div, np, 0.95);
    r->push_max = bu_quantile(push_div, np, 1.0);
    r->gap_p95 = bu_quantile(gaps, ng, 0.95);
    r->gap_max = bu_quantile(gaps, ng, 1.0);
    r->conv0 = converged(eqs, frames, push, 0.0);
    r->conv0_interp = converged(divs, frames, push, 0.0);
    r->conv1mm = converged(divs, frames, push, 1e-3);
    for (k = 0; k < nhosts; ++k) {
        gs_sync_stats st;
        int a;
        uint64_t s0, rs0;
        gs_world_sync_stats(h[k].w, &st);
        count_steps(h[k].w, &s0, &rs0);
        loop_steps += s0 - push_steps[k];
        loop_rsteps += rs0 - push_rsteps[k];
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
    if (loop_steps + loop_rsteps > 0) {
        double step_cpu = cpu / (double)(loop_steps + loop_rsteps);
        r->replay_cpu_frame = (double)loop_rsteps / frames / nhosts * step_cpu / FRAME;
        r->replay_cpu_push = (double)worst_rsteps / (push / FRAME) * step_cpu / FRAME;
    }
    if (out_frames) r->out_cpu = out_cpu / out_frames / nhosts / FRAME;
    ok = 1;
done:
    for (k = 0; k < nhosts; ++k) {
        gs_world_destroy(h[k].w);
        et_free(&h[k].s);
    }
    gs_simnet_destroy(sim);
    return ok;
}

/* "never" for a convergence time of -1 */
static const char *secs(char *buf, size_t n, double t) {
    if (t < 0.0) snprintf(buf, n, "never");
    else snprintf(buf, n, "%.2fs", t);
    return buf;
}

static void print_row(const result *r) {
    char c0[16], c1[16];
    if (r->outage) {
        fprintf(stderr,
                "%-6s %-8s %5d | outage %.0f s: pace %.3f, lag max %6.2fms, frame cpu %5.1f%% | after: "
                "conv 0 %7s, conv 1mm %7s, end %8.2em | replays %lu fallb %lu\n",
                r->profile, r->mode, r->hosts, OUT_LEN, r->out_pace, 1e3 * r->out_lag, 100.0 * r->out_cpu,
                secs(c0, sizeof c0, r->conv0), secs(c1, sizeof c1, r->conv1mm), r->after_end,
                (unsigned long)r->replays, (unsigned long)r->fallbacks);
        return;
    }
    fprintf(stderr,
            "%-6s %-8s %5d | %7.3fmm %7.3fmm %7.3fmm | %8.2em %8.2em %7s %7s %8s | %6.2fms %6.2fms | "
            "%6.1f%% %6.1f%% %6lu %6lu %6lu %6lu | %6.1f%% %6.1f%%\n",
            r->profile, r->mode, r->hosts, 1e3 * r->push_med, 1e3 * r->push_p95, 1e3 * r->push_max,
            r->after_max, r->after_end, r->bitwise_after_1s ? "yes" : "no", secs(c0, sizeof c0, r->conv0),
            secs(c1, sizeof c1, r->conv1mm), 1e3 * r->gap_p95, 1e3 * r->gap_max, 100.0 * r->replay_share,
            100.0 * r->replay_cpu_frame, (unsigned long)r->fallbacks, (unsigned long)r->replays,
            (unsigned long)r->skipped, (unsigned long)r->near, 100.0 * r->replay_push_worst,
            100.0 * r->replay_cpu_push);
}

int main(int argc, char **argv) {
    static profile profs[3];
    static result res[40];
    bu_args args;
    bu_json *j;
    int np, nh, p, m, hh, nr = 0, i, hosts[2] = {2, 4}, outage_only = 0, outages = 0;
    double push, after;
    const char *only = NULL;
    int a;
    /* --profile lan|wan|harsh runs that one alone; --outage the outage
       scenario alone; --replay-every K sets gs_sync_desc.replay_every (then
       the other flags) */
    while (argc >= 2) {
        int used = 0;
        if (argc >= 3 && strcmp(argv[1], "--profile") == 0) {
            only = argv[2];
            used = 2;
        } else if (argc >= 3 && strcmp(argv[1], "--replay-every") == 0) {
            replay_every = atoi(argv[2]);
            used = 2;
        } else if (strcmp(argv[1], "--outage") == 0) {
            outage_only = 1;
            used = 1;
        }
        if (!used) break;
        argv[used] = argv[0];
        argv += used;
        argc -= used;
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
    after = args.quick ? 1.5 : 6.0; /* 6: the harsh link's "bitwise within 5 s" */
    fprintf(stderr, "%-6s %-8s %5s | %9s %9s %9s | %9s %9s %7s %7s %8s | %8s %8s | %7s %7s %6s %6s %6s %6s | %7s %7s\n",
            "link", "mode", "hosts", "push med", "push p95", "push max", "stop+1s", "end", "bitwise",
            "conv 0", "conv 1mm", "gap p95", "gap max", "replay", "cpu/fr", "fallb", "replays", "skip",
            "near", "push:rep", "cpu/fr");
    if (only) np = 3;
    if (outage_only) np = 0;
    for (p = 0; p < np; ++p)
        for (hh = 0; hh < nh; ++hh)
            for (m = 0; m < 3; ++m) {
                result *r = &res[nr];
                if (only && strcmp(only, profs[p].name) != 0) continue;
                if (!run(&profs[p], m, hosts[hh], push, after, 0, r)) {
                    fprintf(stderr, "sync_modes: a run failed to set up\n");
                    return 1;
                }
                print_row(r);
                nr++;
            }
    /* the outage: WAN, 2 and 4 hosts (2 in quick mode), in the full run,
       or alone with --outage */
    if (outage_only || (!only && !args.quick)) outages = 2;
    for (hh = 0; hh < outages; ++hh)
        for (m = 0; m < 3; ++m) {
            result *r = &res[nr];
            if (!run(&profs[1], m, hosts[hh], OUT_AT + OUT_LEN, 6.0, 1, r)) {
                fprintf(stderr, "sync_modes: a run failed to set up\n");
                return 1;
            }
            print_row(r);
            nr++;
        }
    j = bu_json_open(args.out);
    if (!j) return 1;
    bu_json_obj_begin(j, NULL);
    bu_json_header(j, "sync_modes", args.quick);
    bu_json_str(j, "method",
                "paper scene on the simnet, client/server rule; divergence at equal simulation time "
                "(host k's samples interpolated to host 1's cloth time), p95 over the push; gap: "
                "|target_k - target_1| at equal wall time; replay CPU = re-run steps per frame x CPU per "
                "agent step (first runs and re-runs) / (1/60 s); convergence: s from the stop to bitwise "
                "equal (at the times both hosts sampled; also interpolated) or within 1 mm "
                "(interpolated) for good; outage: links cut 5 s, both probes pushing");
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
        bu_json_num(j, "replay_cpu_frame_share_push_worst_host", r->replay_cpu_push);
        bu_json_num(j, "replay_cpu_frame_share", r->replay_cpu_frame);
        bu_json_int(j, "replays", (long long)r->replays);
        bu_json_int(j, "replays_skipped", (long long)r->skipped);
        bu_json_int(j, "replays_skipped_near", (long long)r->near);
        bu_json_int(j, "fallbacks", (long long)r->fallbacks);
        bu_json_num(j, "converged_bitwise_s", r->conv0 >= 0.0 ? r->conv0 : NAN);
        bu_json_num(j, "converged_1mm_s", r->conv1mm >= 0.0 ? r->conv1mm : NAN);
        bu_json_num(j, "converged_bitwise_interpolated_s", r->conv0_interp >= 0.0 ? r->conv0_interp : NAN);
        bu_json_num(j, "bitwise_compared_share", r->exact_share);
        bu_json_bool(j, "outage", r->outage);
        if (r->outage) {
            bu_json_num(j, "outage_s", OUT_LEN);
            bu_json_num(j, "outage_pace", r->out_pace);
            bu_json_num(j, "outage_lag_max_s", r->out_lag);
            bu_json_num(j, "outage_frame_cpu_share", r->out_cpu);
        }
        bu_json_obj_end(j);
    }
    bu_json_arr_end(j);
    bu_json_obj_begin(j, "summary");
    for (i = 0; i < nr; ++i) {
        char key[96];
        result *r = &res[i];
        if (r->hosts != 2 || r->outage) continue;
        snprintf(key, sizeof key, "%s_%s_push_p95_m", r->profile, r->mode);
        bu_json_num(j, key, r->push_p95);
    }
    bu_json_obj_end(j);
    bu_json_arr_begin(j, "plots");
    bu_json_arr_end(j);
    bu_json_obj_end(j);
    return bu_json_close(j) == 0 ? 0 : 1;
}
