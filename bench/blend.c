/* blend - how fast a ghost blends a snapshot into its agent's state, against
   memcpy of the same bytes on the same buffers, in the same run.

   A custom agent whose step does nothing holds N doubles in user memory; it
   is wrapped in a ghost (queue of 1, default exponential weight) on host 1.
   Host 2 runs the same agent with different values and sends its state at
   every step through a net whose send callback keeps the datagrams. Each
   iteration delivers one whole snapshot to host 1 (untimed), then times
   gs_world_advance(w, dt) with the snapshot waiting (step + blend) and
   again with nothing waiting (step alone). blend = median(first) -
   median(second). memcpy: the same N doubles from the snapshot-sized buffer
   into the agent's state buffer, median of as many repeats.

   Also timed alone, through the public API: gs_agent_get_state and
   gs_agent_set_state of the same agent (the blend reads the state once and
   writes it once through them), and a reference blend written as one pass
   (x += w (q - x) / (w0 + w)) over the same buffers: what the formula costs
   when nothing else is done. Target: blend throughput >= half of memcpy. */
#define GHOSTSIM_IMPLEMENTATION
#include "ghostsim.h"
#include "bench_util.h"

#define DT 0.001

typedef struct user_state {
    double *x;
    size_t n;
} user_state;

static gs_result noop_step(void *user, double t, double dt)
{
    (void)user; (void)t; (void)dt;
    return GS_OK;
}
static void get_cb(const void *user, double *out)
{
    const user_state *u = (const user_state *)user;
    memcpy(out, u->x, u->n * sizeof(double));
}
static gs_result set_cb(void *user, const double *in)
{
    user_state *u = (user_state *)user;
    memcpy(u->x, in, u->n * sizeof(double));
    return GS_OK;
}

/* Datagrams host 2 sends, kept for delivery to host 1. */
typedef struct outbox {
    unsigned char *data;
    size_t *size;
    int count, cap;
} outbox;

static gs_result keep_send(void *user, uint32_t host, const void *data, size_t size)
{
    outbox *o = (outbox *)user;
    (void)host;
    if (!o) return GS_OK; /* host 1's own sends go nowhere */
    if (o->count == o->cap) {
        int cap = o->cap ? 2 * o->cap : 256;
        o->data = (unsigned char *)realloc(o->data, (size_t)cap * GS_WIRE_MAX_DATAGRAM);
        o->size = (size_t *)realloc(o->size, (size_t)cap * sizeof *o->size);
        if (!o->data || !o->size) return GS_ERR_NO_MEMORY;
        o->cap = cap;
    }
    memcpy(o->data + (size_t)o->count * GS_WIRE_MAX_DATAGRAM, data, size);
    o->size[o->count++] = size;
    return GS_OK;
}

static void die(const char *what, gs_world *w, gs_result r)
{
    fprintf(stderr, "blend: %s: %s (%s)\n", what, gs_result_str(r), w ? gs_world_error(w) : "");
    exit(1);
}

typedef struct side {
    gs_world *w;
    gs_agent *a;
    gs_net *net;
    user_state u;
} side;

static void side_make(side *s, uint32_t id, size_t n, double send_rate, outbox *o, double base)
{
    gs_world_desc wd = gs_world_desc_default();
    gs_custom_desc cd;
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_net_desc nd;
    gs_result r;
    size_t i;
    memset(s, 0, sizeof *s);
    wd.host_id = id;
    if ((r = gs_world_create(&wd, &s->w)) != GS_OK) die("gs_world_create", NULL, r);
    s->u.n = n;
    s->u.x = (double *)malloc(n * sizeof(double));
    if (!s->u.x) die("malloc", NULL, GS_ERR_NO_MEMORY);
    for (i = 0; i < n; ++i) s->u.x[i] = base + 1e-3 * (double)(i % 1000);
    memset(&cd, 0, sizeof cd);
    cd.dt = DT;
    cd.state_size = n;
    cd.step = noop_step;
    cd.get_state = get_cb;
    cd.set_state = set_cb;
    cd.user = &s->u;
    if ((r = gs_custom_create(s->w, &cd, &s->a)) != GS_OK) die("gs_custom_create", s->w, r);
    memset(&nd, 0, sizeof nd);
    nd.transport.send = keep_send;
    nd.transport.user = o;
    nd.bandwidth = 1e12;
    if ((r = gs_net_create(s->w, &nd, &s->net)) != GS_OK) die("gs_net_create", s->w, r);
    if ((r = gs_net_add_peer(s->net, id == 1 ? 2 : 1, NULL)) != GS_OK) die("gs_net_add_peer", s->w, r);
    gd.object_id = 1;
    gd.send_rate = send_rate;
    gd.queue_size = 1;
    gd.weight = gs_weight_exp; /* the rule of the figures recorded so far */
    if ((r = gs_ghost_attach(s->a, &gd)) != GS_OK) die("gs_ghost_attach", s->w, r);
}

static void side_free(side *s)
{
    gs_world_destroy(s->w);
    free(s->u.x);
}

typedef struct result {
    size_t n;
    double blend, memcpy_t, get, set, ref, step;
    int samples;
} result;

/* The formula for one snapshot, one pass: what it costs when nothing else
   is done (reads x and q, writes x). */
static void ref_blend(double *x, const double *q, size_t n, double w0, double w)
{
    double k = w / (w0 + w);
    size_t i;
    for (i = 0; i < n; ++i) x[i] += k * (q[i] - x[i]);
}

static result run_size(size_t n, int iters)
{
    side rx, tx;
    outbox o = {0};
    double *tb = (double *)malloc((size_t)iters * sizeof(double));
    double *tp = (double *)malloc((size_t)iters * sizeof(double));
    double *tm = (double *)malloc((size_t)iters * sizeof(double));
    double *tg = (double *)malloc((size_t)iters * sizeof(double));
    double *ts = (double *)malloc((size_t)iters * sizeof(double));
    double *tr = (double *)malloc((size_t)iters * sizeof(double));
    double *snap = (double *)malloc(n * sizeof(double));
    double *state = (double *)malloc((n + 1) * sizeof(double));
    double *keep = (double *)malloc(n * sizeof(double));
    double now = 0.0;
    int it, k;
    result res;
    gs_result r;
    if (!tb || !tp || !tm || !tg || !ts || !tr || !snap || !state || !keep) die("malloc", NULL, GS_ERR_NO_MEMORY);
    memset(&res, 0, sizeof res);
    side_make(&rx, 1, n, 1e-6, NULL, 0.0); /* publishes once, then never */
    side_make(&tx, 2, n, 1e6, &o, 0.5);    /* publishes at every step */
    memcpy(keep, rx.u.x, n * sizeof(double));
    memcpy(snap, tx.u.x, n * sizeof(double));
    gs_world_advance(rx.w, DT, NULL); /* the one publish */
    for (it = -2; it < iters; ++it) {
        double t0;
        gs_ghost_stats g0 = {0}, g1 = {0};
        /* host 2 steps twice (host 1 does too) and sends its state */
        now += 2 * DT;
        if ((r = gs_world_advance(tx.w, 2 * DT, NULL)) != GS_OK) die("advance tx", tx.w, r);
        o.count = 0;
        gs_net_update(tx.net, now);
        for (k = 0; k < o.count; ++k) {
            gs_reject why;
            if (gs_net_deliver(rx.net, o.data + (size_t)k * GS_WIRE_MAX_DATAGRAM, o.size[k], now, &why) != GS_OK)
                fprintf(stderr, "blend: datagram refused: %s\n", gs_reject_str(why));
        }
        /* host 1's state back to its start, so that values never creep
           towards denormals as blends pull them together */
        memcpy(rx.u.x, keep, n * sizeof(double));
        gs_ghost_get_stats(rx.a, &g0);
        t0 = bu_now();
        gs_world_advance(rx.w, DT, NULL);
        if (it >= 0) tb[it] = bu_now() - t0;
        gs_ghost_get_stats(rx.a, &g1);
        if (g1.blends != g0.blends + 1) { fprintf(stderr, "blend: no blend at iteration %d\n", it); exit(1); }
        t0 = bu_now();
        gs_world_advance(rx.w, DT, NULL);
        if (it >= 0) tp[it] = bu_now() - t0;
        if (it < 0) continue;
        /* the same bytes by memcpy, into the same buffer */
        t0 = bu_now();
        memcpy(rx.u.x, snap, n * sizeof(double));
        tm[it] = bu_now() - t0;
        bu_sink(rx.u.x[n / 2]);
        t0 = bu_now();
        gs_agent_get_state(rx.a, state, n + 1);
        tg[it] = bu_now() - t0;
        t0 = bu_now();
        gs_agent_set_state(rx.a, state, n + 1);
        ts[it] = bu_now() - t0;
        memcpy(rx.u.x, keep, n * sizeof(double));
        t0 = bu_now();
        ref_blend(rx.u.x, snap, n, 1.0, 1.0);
        tr[it] = bu_now() - t0;
        bu_sink(rx.u.x[n / 3]);
    }
    res.n = n;
    res.step = bu_median(tp, iters);
    res.blend = bu_median(tb, iters) - res.step;
    res.memcpy_t = bu_median(tm, iters);
    res.get = bu_median(tg, iters);
    res.set = bu_median(ts, iters);
    res.ref = bu_median(tr, iters);
    res.samples = iters;
    side_free(&rx);
    side_free(&tx);
    free(o.data); free(o.size);
    free(tb); free(tp); free(tm); free(tg); free(ts); free(tr);
    free(snap); free(state); free(keep);
    return res;
}

int main(int argc, char **argv)
{
    static const size_t sizes_full[] = {1024, 4096, 16384, 65536, 262144, 1048576};
    static const size_t sizes_quick[] = {1024, 16384, 262144};
    bu_args a;
    const size_t *sizes;
    int ns, i, best_i = 0;
    result res[8];
    bu_json *j;
    double t_start = bu_now(), worst = 1e300;
    int pa = bu_parse_args(argc, argv, "blend", &a);
    if (pa) return pa > 0 ? 0 : 2;
    sizes = a.quick ? sizes_quick : sizes_full;
    ns = a.quick ? 3 : 6;
    fprintf(stderr, "blend%s: one snapshot blended into a custom agent's state, against memcpy of the same bytes\n",
            a.quick ? " --quick" : "");
    fprintf(stderr, "%9s %9s %10s %10s %8s %9s %9s %10s %10s %8s\n", "doubles", "KiB", "blend us", "memcpy us",
            "blend/mc", "get us", "set us", "1-pass us", "blend GB/s", "mc GB/s");
    for (i = 0; i < ns; ++i) {
        size_t n = sizes[i];
        int iters = n <= 16384 ? 301 : n <= 65536 ? 151 : n <= 262144 ? 41 : 15;
        if (a.quick) iters = iters / 4 + 5;
        res[i] = run_size(n, iters);
        fprintf(stderr, "%9zu %9.0f %10.2f %10.2f %8.3f %9.2f %9.2f %10.2f %10.2f %8.2f\n", n,
                n * 8.0 / 1024.0, res[i].blend * 1e6, res[i].memcpy_t * 1e6, res[i].memcpy_t / res[i].blend,
                res[i].get * 1e6, res[i].set * 1e6, res[i].ref * 1e6, n * 8.0 / res[i].blend * 1e-9,
                n * 8.0 / res[i].memcpy_t * 1e-9);
        if (res[i].memcpy_t / res[i].blend < worst) { worst = res[i].memcpy_t / res[i].blend; best_i = i; }
    }

    j = bu_json_open(a.out);
    if (!j) return 1;
    bu_json_obj_begin(j, NULL);
    bu_json_header(j, "blend", a.quick);
    bu_json_str(j, "method",
                "A custom agent (no-op step) of N doubles under a ghost on host 1; host 2 sends a whole snapshot "
                "before each iteration (untimed). blend = median time of gs_world_advance(dt) with the snapshot "
                "queued minus median without. memcpy: N doubles from a snapshot-sized buffer into the agent's "
                "state buffer. get/set: gs_agent_get_state / gs_agent_set_state alone. 1-pass: the formula for one "
                "snapshot in one loop over the same buffers. Throughput = state bytes (8 N) / time.");
    bu_json_arr_begin(j, "results");
    for (i = 0; i < ns; ++i) {
        double bytes = res[i].n * 8.0;
        bu_json_obj_begin(j, NULL);
        bu_json_int(j, "doubles", (long long)res[i].n);
        bu_json_num(j, "state_bytes", bytes);
        bu_json_num(j, "blend_us", res[i].blend * 1e6);
        bu_json_num(j, "memcpy_us", res[i].memcpy_t * 1e6);
        bu_json_num(j, "blend_over_memcpy_throughput", res[i].memcpy_t / res[i].blend);
        bu_json_num(j, "blend_gb_s", bytes / res[i].blend * 1e-9);
        bu_json_num(j, "memcpy_gb_s", bytes / res[i].memcpy_t * 1e-9);
        bu_json_num(j, "get_state_us", res[i].get * 1e6);
        bu_json_num(j, "set_state_us", res[i].set * 1e6);
        bu_json_num(j, "one_pass_us", res[i].ref * 1e6);
        bu_json_num(j, "one_pass_over_memcpy_throughput", res[i].memcpy_t / res[i].ref);
        bu_json_num(j, "step_alone_us", res[i].step * 1e6);
        bu_json_int(j, "samples", res[i].samples);
        bu_json_obj_end(j);
    }
    bu_json_arr_end(j);
    bu_json_obj_begin(j, "summary");
    bu_json_num(j, "worst_blend_over_memcpy", worst);
    bu_json_int(j, "worst_at_doubles", (long long)res[best_i].n);
    {
        double lo = 1e300, hi = 0.0;
        for (i = 0; i < ns; ++i) {
            double q = res[i].memcpy_t / res[i].blend;
            if (q < lo) lo = q;
            if (q > hi) hi = q;
        }
        bu_json_num(j, "blend_over_memcpy_min", lo);
        bu_json_num(j, "blend_over_memcpy_max", hi);
    }
    bu_json_str(j, "target", "blend throughput >= 0.5 x memcpy, at every state size");
    bu_json_bool(j, "target_met", worst >= 0.5);
    bu_json_num(j, "wall_s", bu_now() - t_start);
    bu_json_obj_end(j);
    bu_json_arr_begin(j, "plots");
    {
        double x[8], yb[8], ym[8], yr[8];
        const char *names[3] = {"ghost blend", "memcpy", "one-pass formula"};
        const double *xs[3] = {x, x, x}, *ys[3] = {yb, ym, yr};
        int cnt[3] = {ns, ns, ns};
        for (i = 0; i < ns; ++i) {
            x[i] = res[i].n * 8.0;
            yb[i] = x[i] / res[i].blend * 1e-9;
            ym[i] = x[i] / res[i].memcpy_t * 1e-9;
            yr[i] = x[i] / res[i].ref * 1e-9;
        }
        bu_json_plot(j, "Blend throughput against memcpy", "state bytes", "GB/s", 1, 3, names, xs, ys, cnt);
    }
    {
        double x[8], y0[8], y1[8];
        for (i = 0; i < ns; ++i) {
            x[i] = res[i].n * 8.0;
            y0[i] = res[i].memcpy_t / res[i].blend;
            y1[i] = res[i].memcpy_t / res[i].ref;
        }
        bu_json_obj_begin(j, NULL);
        bu_json_str(j, "title", "Throughput as a fraction of memcpy");
        bu_json_str(j, "xlabel", "state bytes");
        bu_json_str(j, "ylabel", "throughput / memcpy");
        bu_json_bool(j, "log", 1);
        bu_json_obj_begin(j, "hline");
        bu_json_num(j, "y", 0.5);
        bu_json_str(j, "title", "target 0.5");
        bu_json_obj_end(j);
        bu_json_arr_begin(j, "series");
        bu_json_obj_begin(j, NULL);
        bu_json_str(j, "name", "ghost blend");
        bu_json_num_array(j, "x", x, ns);
        bu_json_num_array(j, "y", y0, ns);
        bu_json_obj_end(j);
        bu_json_obj_begin(j, NULL);
        bu_json_str(j, "name", "one-pass formula");
        bu_json_num_array(j, "x", x, ns);
        bu_json_num_array(j, "y", y1, ns);
        bu_json_obj_end(j);
        bu_json_arr_end(j);
        bu_json_obj_end(j);
    }
    bu_json_arr_end(j);
    bu_json_obj_end(j);
    if (bu_json_close(j) != 0) return 1;
    fprintf(stderr, "blend: wrote %s in %.1f s\n", a.out, bu_now() - t_start);
    return 0;
}
