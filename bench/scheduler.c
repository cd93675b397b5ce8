/* scheduler - what the world's scheduler costs per dispatch, against a
   plain loop that steps the same agents.

   N custom agents (gs_custom_create) whose step is one multiply-add on their
   own few bytes, so that nearly all the time is the scheduler's. The world
   advances by frames of 1/60 s (gs_world_advance(w, 1/60)); every agent
   steps about 17 times per frame. The plain loop calls the same step
   callbacks through the same function pointers over the same agents, in
   time order, for the same number of steps. Both are timed in the same run,
   alternating, in thread CPU time, medians of repeats:
       overhead per dispatch = (scheduler time - loop time) / dispatches.
   Two populations: every agent at dt = 1 ms, and mixed steps (1, 2 and 5
   ms), where holding and the behaviour rules have work to do.
   The growth of the overhead with N is fitted (least squares, overhead =
   a + b N from 100 agents on): b is what one more agent adds to every
   dispatch; and the exponent k of overhead ~ N^k (least squares on logs). */
#define GHOSTSIM_IMPLEMENTATION
#include "ghostsim.h"
#include "bench_util.h"

#define FRAME (1.0 / 60.0)

typedef struct cheap {
    double x, v;
    double t, dt; /* the plain loop's own clock */
} cheap;

typedef gs_result (*step_fn)(void *user, double t, double dt);

static gs_result cheap_step(void *user, double t, double dt)
{
    cheap *c = (cheap *)user;
    (void)t;
    c->x += c->v * dt;
    return GS_OK;
}
static void cheap_get(const void *user, double *out) { out[0] = ((const cheap *)user)->x; }
static gs_result cheap_set(void *user, const double *in)
{
    ((cheap *)user)->x = in[0];
    return GS_OK;
}

/* Through a volatile pointer, so that the loop cannot inline the step
   while the scheduler calls it indirectly. */
static step_fn volatile the_step = cheap_step;

typedef struct pop {
    gs_world *w;
    cheap *c;
    int n;
} pop;

static void pop_make(pop *p, int n, int mixed)
{
    static const double dts[3] = {0.001, 0.002, 0.005};
    gs_result r;
    int i;
    p->n = n;
    p->c = (cheap *)calloc((size_t)n, sizeof *p->c);
    if (!p->c || (r = gs_world_create(NULL, &p->w)) != GS_OK) {
        fprintf(stderr, "scheduler: cannot create the world\n");
        exit(1);
    }
    for (i = 0; i < n; ++i) {
        gs_custom_desc cd;
        gs_agent *a;
        memset(&cd, 0, sizeof cd);
        p->c[i].v = 1.0 + i;
        p->c[i].dt = cd.dt = mixed ? dts[i % 3] : 0.001;
        cd.state_size = 1;
        cd.step = cheap_step;
        cd.get_state = cheap_get;
        cd.set_state = cheap_set;
        cd.user = &p->c[i];
        if ((r = gs_custom_create(p->w, &cd, &a)) != GS_OK) {
            fprintf(stderr, "scheduler: %s\n", gs_world_error(p->w));
            exit(1);
        }
    }
}

static void pop_free(pop *p)
{
    gs_world_destroy(p->w);
    free(p->c);
}

/* One frame by the scheduler; returns the dispatches. */
static uint64_t sched_frame(pop *p)
{
    gs_advance_report rep;
    gs_world_advance(p->w, FRAME, &rep);
    return rep.steps;
}

/* One frame by a plain loop: in time order, each agent that is due steps,
   as the scheduler does when it is done: within half a step of the target. */
static uint64_t loop_frame(pop *p, double target)
{
    uint64_t steps = 0;
    int i, any = 1;
    while (any) {
        any = 0;
        for (i = 0; i < p->n; ++i) {
            cheap *c = &p->c[i];
            if (c->t >= target - 0.5 * c->dt) continue;
            the_step(c, c->t, c->dt);
            c->t += c->dt;
            steps++;
            any = 1;
        }
    }
    return steps;
}

typedef struct result {
    int n, mixed;
    double sched_ns, loop_ns, overhead_ns;
    double dispatches_per_frame;
} result;

static result run(int n, int mixed, int reps, double min_time)
{
    pop p;
    double ts[64], tl[64], target = 0.0;
    uint64_t ds = 0, dl = 0;
    int frames = 1, r, f;
    result res;
    pop_make(&p, n, mixed);
    /* enough frames per repeat to last min_time */
    {
        double t0 = bu_now();
        target += FRAME;
        sched_frame(&p);
        loop_frame(&p, target);
        frames = (int)(min_time / (bu_now() - t0 + 1e-9)) + 1;
        if (frames > 100000) frames = 100000;
    }
    if (reps > 64) reps = 64;
    for (r = 0; r < reps; ++r) {
        double t0;
        uint64_t d = 0;
        t0 = bu_cpu_now();
        for (f = 0; f < frames; ++f) d += sched_frame(&p);
        ts[r] = (bu_cpu_now() - t0) / (double)d;
        ds += d;
        t0 = bu_cpu_now();
        d = 0;
        for (f = 0; f < frames; ++f) {
            target += FRAME;
            d += loop_frame(&p, target);
        }
        tl[r] = (bu_cpu_now() - t0) / (double)d;
        dl += d;
    }
    res.n = n;
    res.mixed = mixed;
    res.sched_ns = bu_median(ts, reps) * 1e9;
    res.loop_ns = bu_median(tl, reps) * 1e9;
    res.overhead_ns = res.sched_ns - res.loop_ns;
    res.dispatches_per_frame = (double)ds / ((double)reps * frames);
    if (ds != dl)
        fprintf(stderr, "scheduler: note: %llu dispatches against %llu loop steps (n %d)\n",
                (unsigned long long)ds, (unsigned long long)dl, n);
    pop_free(&p);
    return res;
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

int main(int argc, char **argv)
{
    static const int n_full[] = {1, 3, 10, 30, 100, 300, 1000, 3000};
    static const int n_quick[] = {1, 10, 100, 1000};
    bu_args a;
    const int *ns;
    int nn, i, m;
    result res[2][8];
    bu_json *j;
    double t_start = bu_now(), fa[2], fb[2], fe[2];
    int pa = bu_parse_args(argc, argv, "scheduler", &a);
    if (pa) return pa > 0 ? 0 : 2;
    ns = a.quick ? n_quick : n_full;
    nn = a.quick ? 4 : 8;
    fprintf(stderr, "scheduler%s: gs_world_advance(1/60 s) over N cheap custom agents against a plain loop\n",
            a.quick ? " --quick" : "");
    fprintf(stderr, "%6s %6s %12s %12s %14s %8s %12s\n", "agents", "dt", "sched ns", "loop ns",
            "overhead ns", "ratio", "dispatch/frm");
    for (m = 0; m < 2; ++m)
        for (i = 0; i < nn; ++i) {
            result *r = &res[m][i];
            *r = run(ns[i], m, a.quick ? 5 : ns[i] >= 1000 ? 5 : 11, a.quick ? 0.01 : 0.04);
            fprintf(stderr, "%6d %6s %12.1f %12.1f %14.1f %8.1f %12.0f\n", r->n, m ? "mixed" : "1 ms",
                    r->sched_ns, r->loop_ns, r->overhead_ns, r->sched_ns / r->loop_ns, r->dispatches_per_frame);
        }
    /* the line through the points from 100 agents on, where the O(N) term
       dominates; the exponent of overhead ~ N^k over every point */
    for (m = 0; m < 2; ++m) {
        double x[8], y[8], lx[8], ly[8], la;
        int k = 0;
        for (i = 0; i < nn; ++i) {
            lx[i] = log(res[m][i].n);
            ly[i] = log(res[m][i].overhead_ns > 0.1 ? res[m][i].overhead_ns : 0.1);
            if (res[m][i].n < 100) continue;
            x[k] = res[m][i].n;
            y[k] = res[m][i].overhead_ns;
            k++;
        }
        fit_line(x, y, k, &fa[m], &fb[m]);
        fit_line(lx, ly, nn, &la, &fe[m]);
    }
    fprintf(stderr, "scheduler: from 100 agents on, overhead per dispatch ~ %.2f ns x agents (dt 1 ms), %.2f ns x agents (mixed); "
            "exponent over all N %.2f / %.2f\n", fb[0], fb[1], fe[0], fe[1]);

    j = bu_json_open(a.out);
    if (!j) return 1;
    bu_json_obj_begin(j, NULL);
    bu_json_header(j, "scheduler", a.quick);
    bu_json_str(j, "method",
                "N custom agents with a one multiply-add step. Scheduler: gs_world_advance(w, 1/60) per frame, time "
                "per dispatch (gs_advance_report.steps). Loop: the same step callbacks through a function pointer, "
                "in time order, each agent stepping while it is more than half a step short of the frame's end. "
                "Alternating repeats of at least 10 ms (40 in the full run), thread CPU time, medians. overhead = scheduler - loop per dispatch; b in a + b N by least "
                "squares over N >= 100, and the exponent k of overhead ~ N^k over every N (least squares on logs).");
    bu_json_arr_begin(j, "results");
    for (m = 0; m < 2; ++m)
        for (i = 0; i < nn; ++i) {
            const result *r = &res[m][i];
            bu_json_obj_begin(j, NULL);
            bu_json_int(j, "agents", r->n);
            bu_json_str(j, "dt", m ? "mixed 1/2/5 ms" : "1 ms");
            bu_json_num(j, "sched_ns_per_dispatch", r->sched_ns);
            bu_json_num(j, "loop_ns_per_step", r->loop_ns);
            bu_json_num(j, "overhead_ns_per_dispatch", r->overhead_ns);
            bu_json_num(j, "sched_over_loop", r->sched_ns / r->loop_ns);
            bu_json_num(j, "dispatches_per_frame", r->dispatches_per_frame);
            bu_json_obj_end(j);
        }
    bu_json_arr_end(j);
    bu_json_obj_begin(j, "summary");
    for (i = 0; i < nn; ++i)
        if (ns[i] == 1 || ns[i] == 100 || ns[i] == 1000) {
            char key[64];
            snprintf(key, sizeof key, "overhead_ns_per_dispatch_%d_agents", ns[i]);
            bu_json_num(j, key, res[0][i].overhead_ns);
        }
    bu_json_num(j, "fit_overhead_ns_per_agent", fb[0]);
    bu_json_num(j, "fit_overhead_ns_per_agent_mixed", fb[1]);
    bu_json_num(j, "fit_exponent", fe[0]);
    bu_json_num(j, "fit_exponent_mixed", fe[1]);
    bu_json_str(j, "finding",
                "The slowest and fastest agent time come from two heaps updated when a time changes (O(log N) "
                "per step), no longer from a scan of every agent at every dispatch (which made a frame O(N^2)): "
                "see fit_exponent for how the overhead per dispatch grows with N.");
    bu_json_num(j, "wall_s", bu_now() - t_start);
    bu_json_obj_end(j);
    bu_json_arr_begin(j, "plots");
    {
        double x[8], y0[8], y1[8], y2[8];
        const char *names[3] = {"scheduler overhead, dt 1 ms", "scheduler overhead, mixed dt",
                                "plain loop step"};
        const double *xs[3] = {x, x, x}, *ys[3] = {y0, y1, y2};
        int cnt[3] = {nn, nn, nn};
        for (i = 0; i < nn; ++i) {
            x[i] = ns[i];
            y0[i] = res[0][i].overhead_ns;
            y1[i] = res[1][i].overhead_ns;
            y2[i] = res[0][i].loop_ns;
        }
        bu_json_plot(j, "Scheduler overhead per dispatch", "agents", "ns per dispatch", 1, 3, names, xs, ys, cnt);
    }
    bu_json_arr_end(j);
    bu_json_obj_end(j);
    if (bu_json_close(j) != 0) return 1;
    fprintf(stderr, "scheduler: wrote %s in %.1f s\n", a.out, bu_now() - t_start);
    return 0;
}
