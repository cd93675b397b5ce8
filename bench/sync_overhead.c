/* sync_overhead - what ghosts cost a host, per step of its own simulation.

   Each host is a world with one cloth (nx x nx, the library's defaults:
   symplectic Euler, dt 1 ms, substeps where the stability bound asks for
   them), pinned at its four corners, under a ghost (object 1, default rate
   60 Hz, f64 or f32). Frames are 1/60 s. Cloth 8x8 .. 128x128, 2, 4 and 8
   hosts.

   Method (also in bench/README.md and in the JSON "method"):
   1. Phases. The hosts run on an in-process bus that does what gs_simnet's
      perfect link does (every datagram sent in a frame is delivered at the
      end of that frame, in order), but lets us hold a clock to each phase:
        - step: every gs_world_advance(w, dt) call is timed alone (one step
          each; from 32x32 on, where a step takes 0.1 ms and more, in thread
          CPU time, else by the monotonic clock). Calls in which the ghost blended (its blend counter moved)
          are "blend steps", the others "plain steps". step = median of the
          plain steps; blend = median(blend steps) - step.
        - publish: what the ghost does when its rate is due, a
          gs_agent_get_state of the whole state into B: timed alone
          (median), counted at the rate snapshots were sent.
        - encode: every gs_net_update call (chunking, encoding, CRC, the
          send callback) timed alone.
        - deliver: every gs_net_deliver call (CRC, validation, decoding into
          the ghost's queue) timed, summed per host and frame.
      ghost work per simulated second = blend x blends/s + publish x
      publishes/s + encode + deliver (each the median per event times the
      events per second); ghost % = that / (step x steps/s).
   2. Cross-check on gs_simnet itself: the same hosts with ghosts, and the
      same hosts without ghosts (joined to a simnet, nothing to send), run
      by gs_simnet_run in alternating slices; overhead = median thread CPU
      time per host-step with ghosts / without - 1. This includes everything;
      CPU time keeps it steady on a busy machine (wall time swung by +-25%
      under a load of 4 on 2 cores, CPU time by under 0.5 points).
   Bytes per second per host are the bytes each host sent on gs_simnet
   (to all its peers), per second of simulated time, with the net's
   bandwidth budget raised to 1 GB/s so that nothing is held back; the
   JSON says whether the default budget (1e7 B/s per peer) would hold. */
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

#define MAX_HOSTS 8
#define FRAME (1.0 / 60.0)
#define DT 0.001

/* ---- an in-process bus: gs_simnet's perfect link, with clocks on it ---- */
typedef struct msg {
    int to;
    size_t size;
    unsigned char data[GS_WIRE_MAX_DATAGRAM];
} msg;

typedef struct bus {
    msg *q;
    int count, cap;
} bus;

typedef struct host {
    bus *b;
    gs_world *w;
    gs_agent *cloth;
    gs_net *net;
    uint32_t id;
} host;

static gs_result bus_send(void *user, uint32_t to, const void *data, size_t size)
{
    host *h = (host *)user;
    bus *b = h->b;
    if (b->count == b->cap) {
        int cap = b->cap ? 2 * b->cap : 1024;
        msg *q = (msg *)realloc(b->q, (size_t)cap * sizeof *q);
        if (!q) return GS_ERR_NO_MEMORY;
        b->q = q;
        b->cap = cap;
    }
    b->q[b->count].to = (int)to - 1;
    b->q[b->count].size = size;
    memcpy(b->q[b->count].data, data, size);
    b->count++;
    return GS_OK;
}

static void die(const char *what, gs_world *w, gs_result r)
{
    fprintf(stderr, "sync_overhead: %s: %s (%s)\n", what, gs_result_str(r), w ? gs_world_error(w) : "");
    exit(1);
}

/* One host's world and cloth; a ghost unless enc is 0. */
static void host_make(host *h, uint32_t id, int n, gs_encoding enc)
{
    gs_world_desc wd = gs_world_desc_default();
    gs_cloth_desc cd = gs_cloth_desc_default();
    gs_result r;
    memset(h, 0, sizeof *h);
    h->id = id;
    wd.host_id = id;
    if ((r = gs_world_create(&wd, &h->w)) != GS_OK) die("gs_world_create", NULL, r);
    cd.nx = cd.ny = n;
    cd.pin_corners = GS_CORNER_ALL;
    if ((r = gs_cloth_create(h->w, &cd, &h->cloth)) != GS_OK) die("gs_cloth_create", h->w, r);
    if (enc) {
        gs_ghost_desc gd = gs_ghost_desc_default();
        gd.object_id = 1;
        gd.encoding = enc;
        gd.weight = gs_weight_exp; /* the rule of the figures recorded so far */
        if ((r = gs_ghost_attach(h->cloth, &gd)) != GS_OK) die("gs_ghost_attach", h->w, r);
    }
}

static uint64_t sent_snapshots(const host *h, uint32_t peer)
{
    gs_peer_stats st;
    if (gs_net_peer_stats(h->net, peer, &st) != GS_OK) return 0;
    return st.snapshots_sent;
}

/* Growable sample arrays. */
typedef struct samples {
    double *v;
    int n, cap;
} samples;

static void push(samples *s, double x)
{
    if (s->n == s->cap) {
        s->cap = s->cap ? 2 * s->cap : 256;
        s->v = (double *)realloc(s->v, (size_t)s->cap * sizeof *s->v);
        if (!s->v) { fprintf(stderr, "sync_overhead: out of memory\n"); exit(1); }
    }
    s->v[s->n++] = x;
}

typedef struct phase_result {
    double step, substeps, blend, publish, encode_send, encode_idle, deliver;
    double steps_per_s, blends_per_s, publishes_per_s, sends_per_s, idles_per_s, deliver_frames_per_s;
    double ghost_per_s, step_per_s, ghost_pct;
    int plain_samples, blend_samples;
} phase_result;

static double publish_cost(gs_agent *a)
{
    size_t n = gs_agent_state_size(a);
    double *buf = (double *)malloc(n * sizeof *buf), v[31];
    int r, i, inner = n > 20000 ? 20 : 200;
    for (r = 0; r < 31; ++r) {
        double t0 = bu_now();
        for (i = 0; i < inner; ++i) gs_agent_get_state(a, buf, n);
        v[r] = (bu_now() - t0) / inner;
    }
    bu_sink(buf[n - 1]);
    free(buf);
    return bu_median(v, 31);
}

/* Phase timings on the bus: H hosts, `frames` frames after one warm-up. */
static phase_result run_phases(int n, int H, gs_encoding enc, int frames)
{
    host hs[MAX_HOSTS];
    bus b = {0};
    samples plain = {0}, blend = {0}, send = {0}, idle = {0}, deliv = {0};
    double now = 0.0, dtime[MAX_HOSTS];
    long long steps_done[MAX_HOSTS], nsteps = 0, nblends = 0;
    uint64_t sent0 = 0, sent1 = 0, substeps0 = 0, substeps1 = 0, st0 = 0, st1 = 0;
    int i, j, f, dcount[MAX_HOSTS];
    phase_result pr;
    gs_result r;
    /* steps of 0.1 ms and more: thread CPU time, which a busy machine does
       not inflate; shorter ones: the monotonic clock (a CPU-time read is a
       system call of ~0.2 us), where the median drops preempted samples */
    double (*clk)(void) = n >= 32 ? bu_cpu_now : bu_now;
    memset(&pr, 0, sizeof pr);
    for (i = 0; i < H; ++i) {
        gs_net_desc nd;
        memset(&nd, 0, sizeof nd);
        host_make(&hs[i], (uint32_t)i + 1, n, enc);
        hs[i].b = &b;
        nd.transport.send = bus_send;
        nd.transport.user = &hs[i];
        nd.bandwidth = 1e9;
        if ((r = gs_net_create(hs[i].w, &nd, &hs[i].net)) != GS_OK) die("gs_net_create", hs[i].w, r);
        steps_done[i] = 0;
    }
    for (i = 0; i < H; ++i)
        for (j = 0; j < H; ++j)
            if (i != j && (r = gs_net_add_peer(hs[i].net, (uint32_t)j + 1, NULL)) != GS_OK)
                die("gs_net_add_peer", hs[i].w, r);
    for (f = -1; f < frames; ++f) { /* frame -1 warms up, untimed */
        int timed = f >= 0;
        now += FRAME;
        if (f == 0) {
            sent0 = sent_snapshots(&hs[0], 2);
            st0 = agent_stats(hs[0].cloth).steps;
            substeps0 = agent_stats(hs[0].cloth).substeps;
        }
        for (i = 0; i < H; ++i) {
            long long target = (long long)(now / DT + 0.5);
            double t0, t1;
            uint64_t before;
            while (steps_done[i] < target) {
                gs_ghost_stats gs0 = {0}, gs1 = {0};
                gs_ghost_get_stats(hs[i].cloth, &gs0);
                t0 = clk();
                r = gs_world_advance(hs[i].w, DT, NULL);
                t1 = clk();
                if (r != GS_OK) die("gs_world_advance", hs[i].w, r);
                gs_ghost_get_stats(hs[i].cloth, &gs1);
                steps_done[i]++;
                if (!timed) continue;
                nsteps++;
                if (gs1.blends != gs0.blends) { push(&blend, t1 - t0); nblends++; }
                else push(&plain, t1 - t0);
            }
            before = sent_snapshots(&hs[i], i == 0 ? 2 : 1);
            t0 = clk();
            gs_net_update(hs[i].net, now);
            t1 = clk();
            if (timed) {
                if (sent_snapshots(&hs[i], i == 0 ? 2 : 1) != before) push(&send, t1 - t0);
                else push(&idle, t1 - t0);
            }
        }
        for (i = 0; i < H; ++i) { dtime[i] = 0.0; dcount[i] = 0; }
        /* one clock per run of datagrams to the same host (the bus holds
           them in send order: sender by sender, peer by peer) */
        for (j = 0; j < b.count;) {
            int to = b.q[j].to, k = j;
            double t0 = clk();
            for (; k < b.count && b.q[k].to == to; ++k)
                gs_net_deliver(hs[to].net, b.q[k].data, b.q[k].size, now, NULL);
            dtime[to] += clk() - t0;
            dcount[to] += k - j;
            j = k;
        }
        b.count = 0;
        if (timed)
            for (i = 0; i < H; ++i)
                if (dcount[i]) push(&deliv, dtime[i]);
    }
    sent1 = sent_snapshots(&hs[0], 2);
    st1 = agent_stats(hs[0].cloth).steps;
    substeps1 = agent_stats(hs[0].cloth).substeps;
    {
        double sim = frames * FRAME, hsim = sim * H; /* host-seconds */
        pr.step = bu_median(plain.v, plain.n);
        pr.blend = blend.n ? bu_median(blend.v, blend.n) - pr.step : 0.0;
        if (pr.blend < 0.0) pr.blend = 0.0;
        pr.publish = publish_cost(hs[0].cloth);
        pr.encode_send = bu_median(send.v, send.n);
        pr.encode_idle = bu_median(idle.v, idle.n);
        pr.deliver = bu_median(deliv.v, deliv.n);
        pr.substeps = st1 > st0 ? (double)(substeps1 - substeps0) / (double)(st1 - st0) : 0.0;
        pr.steps_per_s = nsteps / hsim;
        pr.blends_per_s = nblends / hsim;
        pr.publishes_per_s = (double)(sent1 - sent0) / sim;
        pr.sends_per_s = send.n / hsim;
        pr.idles_per_s = idle.n / hsim;
        pr.deliver_frames_per_s = deliv.n / hsim;
        pr.ghost_per_s = pr.blend * pr.blends_per_s + pr.publish * pr.publishes_per_s +
                         pr.encode_send * pr.sends_per_s + pr.encode_idle * pr.idles_per_s +
                         pr.deliver * pr.deliver_frames_per_s;
        pr.step_per_s = pr.step * pr.steps_per_s;
        pr.ghost_pct = 100.0 * pr.ghost_per_s / pr.step_per_s;
        pr.plain_samples = plain.n;
        pr.blend_samples = blend.n;
    }
    for (i = 0; i < H; ++i) gs_world_destroy(hs[i].w);
    free(b.q);
    free(plain.v); free(blend.v); free(send.v); free(idle.v); free(deliv.v);
    return pr;
}

/* ---- the cross-check on gs_simnet ---- */
typedef struct simset {
    gs_simnet *sim;
    host hs[MAX_HOSTS];
    int H;
} simset;

static void simset_make(simset *s, int n, int H, gs_encoding enc)
{
    gs_result r;
    int i;
    memset(s, 0, sizeof *s);
    s->H = H;
    if ((r = gs_simnet_create(NULL, &s->sim)) != GS_OK) die("gs_simnet_create", NULL, r);
    for (i = 0; i < H; ++i) {
        gs_net_desc nd;
        memset(&nd, 0, sizeof nd);
        nd.bandwidth = 1e9;
        host_make(&s->hs[i], (uint32_t)i + 1, n, enc);
        if ((r = test_join(s->sim, s->hs[i].w, &nd, &s->hs[i].net)) != GS_OK)
            die("gs_net_create on the simnet", s->hs[i].w, r);
    }
}

static void simset_free(simset *s)
{
    int i;
    gs_simnet_destroy(s->sim);
    for (i = 0; i < s->H; ++i) gs_world_destroy(s->hs[i].w);
}

/* Bytes and datagrams host 1..H sent in all, per host. */
static void simset_sent(const simset *s, double *bytes, double *datagrams)
{
    int i, j;
    *bytes = *datagrams = 0.0;
    for (i = 0; i < s->H; ++i)
        for (j = 0; j < s->H; ++j) {
            gs_peer_stats st;
            if (i == j || gs_net_peer_stats(s->hs[i].net, (uint32_t)j + 1, &st) != GS_OK) continue;
            *bytes += (double)st.bytes_sent;
            *datagrams += (double)st.datagrams_sent;
        }
    *bytes /= s->H;
    *datagrams /= s->H;
}

typedef struct ab_result {
    double plain_step, ghost_step[2], overhead_pct[2];
    double bytes_per_s[2], datagrams_per_s[2];
} ab_result;

static ab_result run_ab(int n, int H, double sim, int reps)
{
    simset set[3];
    double t[3][64], b0[2], d0[2], b1, d1;
    long steps_per_slice;
    int k, rep;
    ab_result ab;
    memset(&ab, 0, sizeof ab);
    if (reps > 64) reps = 64;
    simset_make(&set[0], n, H, (gs_encoding)0);
    simset_make(&set[1], n, H, GS_ENCODING_F64);
    simset_make(&set[2], n, H, GS_ENCODING_F32);
    for (k = 0; k < 3; ++k) gs_simnet_run(set[k].sim, FRAME, FRAME); /* warm up */
    for (k = 1; k < 3; ++k) simset_sent(&set[k], &b0[k - 1], &d0[k - 1]);
    {
        int frames = (int)(sim / reps / FRAME + 0.5);
        if (frames < 1) frames = 1;
        steps_per_slice = (long)(frames * FRAME / DT + 0.5);
        for (rep = 0; rep < reps; ++rep)
            for (k = 0; k < 3; ++k) {
                int which = (k + rep) % 3; /* rotate the order */
                double t0 = bu_cpu_now();
                gs_result r = gs_simnet_run(set[which].sim, frames * FRAME, FRAME);
                t[which][rep] = (bu_cpu_now() - t0) / ((double)H * (double)steps_per_slice);
                if (r != GS_OK) die("gs_simnet_run", set[which].hs[0].w, r);
            }
        for (k = 1; k < 3; ++k) {
            simset_sent(&set[k], &b1, &d1);
            ab.bytes_per_s[k - 1] = (b1 - b0[k - 1]) / (reps * frames * FRAME);
            ab.datagrams_per_s[k - 1] = (d1 - d0[k - 1]) / (reps * frames * FRAME);
        }
    }
    ab.plain_step = bu_median(t[0], reps);
    for (k = 0; k < 2; ++k) {
        ab.ghost_step[k] = bu_median(t[k + 1], reps);
        ab.overhead_pct[k] = 100.0 * (ab.ghost_step[k] / ab.plain_step - 1.0);
    }
    for (k = 0; k < 3; ++k) simset_free(&set[k]);
    return ab;
}

/* ---- one full datagram through the public wire functions ----
   What encode and deliver spend per datagram: the values (gs_wire_add,
   which checks and writes each one), the CRC-32 (gs_wire_end), decoding
   and checking (gs_wire_decode), against memcpy of the same bytes; runs of
   2000 datagrams in thread CPU time. */
typedef struct wire_cost {
    double add, end, decode, copy, crc8; /* s per datagram */
    int crc8_agrees;
    size_t bytes;
    int values;
} wire_cost;

typedef struct wire_job {
    unsigned char buf[GS_WIRE_MAX_DATAGRAM], copy[GS_WIRE_MAX_DATAGRAM];
    double values[GS_WIRE_MAX_DATAGRAM / 4];
    gs_wire_chunk ch;
    gs_wire_header h;
    gs_wire_view view;
    size_t size;
} wire_job;

static void wire_add_fn(void *u)
{
    wire_job *w = (wire_job *)u;
    gs_wire_begin(w->buf, sizeof w->buf, &w->h, &w->size);
    gs_wire_add(w->buf, sizeof w->buf, &w->size, &w->ch, w->values);
}
static void wire_end_fn(void *u)
{
    wire_job *w = (wire_job *)u;
    bu_sink((double)gs_wire_end(w->buf, w->size));
}
static void wire_decode_fn(void *u)
{
    wire_job *w = (wire_job *)u;
    gs_reject why;
    bu_sink((double)gs_wire_decode(w->buf, w->size + 4, &w->view, &why));
}
static void wire_copy_fn(void *u)
{
    wire_job *w = (wire_job *)u;
    memcpy(w->copy, w->buf, w->size + 4);
    bu_sink(w->copy[w->size / 2]);
}

/* The same CRC-32 (IEEE, reflected) by slicing-by-8: what the fix would
   cost, checked against the library's own checksum. */
static uint32_t crc8_table[8][256];

static void crc8_init(void)
{
    uint32_t i, k;
    for (i = 0; i < 256; ++i) {
        uint32_t c = i;
        for (k = 0; k < 8; ++k) c = (c & 1) ? 0xedb88320u ^ (c >> 1) : c >> 1;
        crc8_table[0][i] = c;
    }
    for (i = 0; i < 256; ++i)
        for (k = 1; k < 8; ++k)
            crc8_table[k][i] = (crc8_table[k - 1][i] >> 8) ^ crc8_table[0][crc8_table[k - 1][i] & 0xff];
}

static uint32_t crc32_slice8(const unsigned char *p, size_t n)
{
    uint32_t c = 0xffffffffu;
    while (n >= 8) {
        uint32_t lo = c ^ ((uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24);
        uint32_t hi = (uint32_t)p[4] | (uint32_t)p[5] << 8 | (uint32_t)p[6] << 16 | (uint32_t)p[7] << 24;
        c = crc8_table[7][lo & 0xff] ^ crc8_table[6][(lo >> 8) & 0xff] ^ crc8_table[5][(lo >> 16) & 0xff] ^
            crc8_table[4][lo >> 24] ^ crc8_table[3][hi & 0xff] ^ crc8_table[2][(hi >> 8) & 0xff] ^
            crc8_table[1][(hi >> 16) & 0xff] ^ crc8_table[0][hi >> 24];
        p += 8;
        n -= 8;
    }
    while (n--) c = crc8_table[0][(c ^ *p++) & 0xff] ^ (c >> 8);
    return c ^ 0xffffffffu;
}

static void wire_crc8_fn(void *u)
{
    wire_job *w = (wire_job *)u;
    bu_sink((double)crc32_slice8(w->buf, w->size));
}

static wire_cost wire_breakdown(gs_encoding enc, int quick)
{
    static wire_job w;
    wire_cost c;
    size_t vs = enc == GS_ENCODING_F32 ? 4 : 8;
    int i, reps = quick ? 9 : 31, inner = 2000;
    memset(&w, 0, sizeof w);
    w.ch.object_id = 1;
    w.ch.sequence = 1;
    w.ch.time = 1.0;
    w.ch.count = 1;
    w.ch.elements = (uint16_t)((GS_WIRE_MAX_DATAGRAM - GS_WIRE_HEADER - GS_WIRE_CHUNK_HEADER - 4) / vs);
    w.ch.encoding = enc;
    w.h.session = 1;
    w.h.sender = 2;
    for (i = 0; i < w.ch.elements; ++i) w.values[i] = 0.001 * i;
    wire_add_fn(&w);
    c.add = bu_cpu_time_median(wire_add_fn, &w, reps, inner);
    c.end = bu_cpu_time_median(wire_end_fn, &w, reps, inner);
    gs_wire_end(w.buf, w.size);
    c.decode = bu_cpu_time_median(wire_decode_fn, &w, reps, inner);
    c.copy = bu_cpu_time_median(wire_copy_fn, &w, reps, inner);
    crc8_init();
    c.crc8 = bu_cpu_time_median(wire_crc8_fn, &w, reps, inner);
    {
        const unsigned char *q = w.buf + w.size;
        uint32_t lib = (uint32_t)q[0] | (uint32_t)q[1] << 8 | (uint32_t)q[2] << 16 | (uint32_t)q[3] << 24;
        c.crc8_agrees = lib == crc32_slice8(w.buf, w.size);
    }
    c.bytes = w.size + 4;
    c.values = w.ch.elements;
    return c;
}

/* ---- main ---- */
typedef struct row {
    int n, H;
    phase_result ph[2]; /* f64, f32 */
    ab_result ab;
} row;

int main(int argc, char **argv)
{
    static const int sizes_full[] = {8, 16, 32, 64, 128}, sizes_quick[] = {8, 16, 64};
    static const int hosts_full[] = {2, 4, 8}, hosts_quick[] = {2, 4};
    bu_args a;
    const int *sizes, *hostv;
    int nsizes, nhosts, si, hi, nrows = 0, k, e;
    row rows[32];
    bu_json *j;
    int pa = bu_parse_args(argc, argv, "sync_overhead", &a);
    double t_start = bu_now();
    wire_cost wire[2];
    if (pa) return pa > 0 ? 0 : 2;
    sizes = a.quick ? sizes_quick : sizes_full;
    nsizes = a.quick ? 3 : 5;
    hostv = a.quick ? hosts_quick : hosts_full;
    nhosts = a.quick ? 2 : 3;

    fprintf(stderr, "sync_overhead%s: ghost work against the cloth's own step (dt 1 ms, 60 Hz sends, frames 1/60 s)\n",
            a.quick ? " --quick" : "");
    fprintf(stderr, "%8s %5s %4s %9s %5s %9s %9s %9s %9s %9s %8s %8s %11s %11s\n", "cloth", "hosts", "enc",
            "step us", "subst", "blend us", "publ us", "encode us", "deliv us", "ghost/stp", "ghost%",
            "simnet%", "B/s/host", "dgram/s/h");
    for (si = 0; si < nsizes; ++si)
        for (hi = 0; hi < nhosts; ++hi) {
            int n = sizes[si], H = hostv[hi];
            row *rw = &rows[nrows++];
            /* simulated seconds per measurement, so that each takes about
               the same wall time whatever the size */
            double per_step = n <= 16 ? 1.0 : n <= 32 ? 4.0 : n <= 64 ? 30.0 : 300.0;
            double sim = (a.quick ? 0.15 : 0.6) * 30.0 / per_step;
            int frames, reps = a.quick ? 3 : 9;
            if (sim > 2.0) sim = 2.0;
            if (n >= 128) sim = 0.1;
            frames = (int)(sim / FRAME + 0.5);
            if (frames < 6) frames = 6;
            rw->n = n;
            rw->H = H;
            rw->ph[0] = run_phases(n, H, GS_ENCODING_F64, frames);
            rw->ph[1] = run_phases(n, H, GS_ENCODING_F32, frames);
            rw->ab = run_ab(n, H, frames * FRAME, reps);
            for (e = 0; e < 2; ++e) {
                const phase_result *p = &rw->ph[e];
                char cl[16];
                snprintf(cl, sizeof cl, "%dx%d", n, n);
                fprintf(stderr, "%8s %5d %4s %9.1f %5.1f %9.1f %9.2f %9.1f %9.1f %9.2f %8.2f %8.2f %11.3g %11.3g\n",
                        cl, H, e ? "f32" : "f64", p->step * 1e6, p->substeps, p->blend * 1e6,
                        p->publish * 1e6, p->encode_send * 1e6, p->deliver * 1e6,
                        p->ghost_per_s / p->steps_per_s * 1e6, p->ghost_pct, rw->ab.overhead_pct[e],
                        rw->ab.bytes_per_s[e], rw->ab.datagrams_per_s[e]);
            }
        }

    {
        wire_cost wc[2];
        wc[0] = wire_breakdown(GS_ENCODING_F64, a.quick);
        wc[1] = wire_breakdown(GS_ENCODING_F32, a.quick);
        fprintf(stderr, "one full datagram (%zu B): %10s %10s %10s %10s %14s %14s\n", wc[0].bytes, "values us",
                "CRC us", "decode us", "memcpy us", "encode+dec MB/s", "CRC by 8s us");
        for (e = 0; e < 2; ++e)
            fprintf(stderr, "  %-27s %10.3f %10.3f %10.3f %10.3f %14.0f %11.3f%s\n", e ? "f32" : "f64",
                    wc[e].add * 1e6, wc[e].end * 1e6, wc[e].decode * 1e6, wc[e].copy * 1e6,
                    wc[e].bytes / (wc[e].add + wc[e].end + wc[e].decode) * 1e-6, wc[e].crc8 * 1e6,
                    wc[e].crc8_agrees ? "" : " (DISAGREES)");
        wire[0] = wc[0];
        wire[1] = wc[1];
    }

    j = bu_json_open(a.out);
    if (!j) return 1;
    bu_json_obj_begin(j, NULL);
    bu_json_header(j, "sync_overhead", a.quick);
    bu_json_str(j, "method",
                "Phases on an in-process bus with gs_simnet's perfect-link behaviour (delivery at the end of the "
                "frame): each gs_world_advance(w, dt) is timed alone (thread CPU time from 32x32 on, monotonic clock below); step = median of the calls without a blend, "
                "blend = median of the calls with one minus step; publish = median gs_agent_get_state of the state "
                "(what the ghost copies into B); encode = each gs_net_update; deliver = each host's gs_net_deliver "
                "calls per frame. ghost % = sum(median cost x events per simulated second) / (step x steps per "
                "second). Cross-check: the same hosts with and without ghosts on gs_simnet, alternating slices of "
                "gs_simnet_run, overhead = median thread CPU time per host-step with / without - 1. Bytes: sent per host to "
                "all peers per simulated second on gs_simnet, bandwidth budget raised to 1e9 B/s.");
    bu_json_obj_begin(j, "config");
    bu_json_num(j, "dt_s", DT);
    bu_json_num(j, "frame_s", FRAME);
    bu_json_num(j, "send_rate_hz", 60.0);
    bu_json_str(j, "cloth", "gs_cloth_desc_default(): 1 kg, 1 m x 1 m, symplectic Euler, four corners pinned");
    bu_json_obj_end(j);
    bu_json_arr_begin(j, "results");
    for (k = 0; k < nrows; ++k)
        for (e = 0; e < 2; ++e) {
            const row *rw = &rows[k];
            const phase_result *p = &rw->ph[e];
            char cl[16];
            double per_peer = rw->ab.bytes_per_s[e] / (rw->H - 1);
            snprintf(cl, sizeof cl, "%dx%d", rw->n, rw->n);
            bu_json_obj_begin(j, NULL);
            bu_json_str(j, "cloth", cl);
            bu_json_int(j, "particles", (long long)rw->n * rw->n);
            bu_json_int(j, "hosts", rw->H);
            bu_json_str(j, "encoding", e ? "f32" : "f64");
            bu_json_num(j, "step_us", p->step * 1e6);
            bu_json_num(j, "substeps", p->substeps);
            bu_json_num(j, "blend_us", p->blend * 1e6);
            bu_json_num(j, "publish_us", p->publish * 1e6);
            bu_json_num(j, "encode_us", p->encode_send * 1e6);
            bu_json_num(j, "deliver_us", p->deliver * 1e6);
            bu_json_num(j, "ghost_us_per_step", p->ghost_per_s / p->steps_per_s * 1e6);
            bu_json_num(j, "ghost_pct", p->ghost_pct);
            bu_json_num(j, "simnet_overhead_pct", rw->ab.overhead_pct[e]);
            bu_json_num(j, "bytes_per_s_per_host", rw->ab.bytes_per_s[e]);
            bu_json_num(j, "datagrams_per_s_per_host", rw->ab.datagrams_per_s[e]);
            bu_json_bool(j, "fits_default_budget", per_peer <= 1e7);
            bu_json_int(j, "plain_samples", p->plain_samples);
            bu_json_int(j, "blend_samples", p->blend_samples);
            bu_json_obj_end(j);
        }
    bu_json_arr_end(j);

    bu_json_obj_begin(j, "summary");
    for (k = 0; k < nrows; ++k)
        if (rows[k].n == 64 && rows[k].H == 2) {
            const row *rw = &rows[k];
            bu_json_num(j, "ghost_pct_64x64_2hosts_f64", rw->ph[0].ghost_pct);
            bu_json_num(j, "ghost_pct_64x64_2hosts_f32", rw->ph[1].ghost_pct);
            bu_json_num(j, "simnet_overhead_pct_64x64_2hosts_f64", rw->ab.overhead_pct[0]);
            bu_json_num(j, "bytes_per_s_per_host_64x64_2hosts_f64", rw->ab.bytes_per_s[0]);
            bu_json_num(j, "bytes_per_s_per_host_64x64_2hosts_f32", rw->ab.bytes_per_s[1]);
            bu_json_num(j, "f32_over_f64_bytes", rw->ab.bytes_per_s[1] / rw->ab.bytes_per_s[0]);
            bu_json_str(j, "target", "ghost work <= 3% of the step (64x64 cloth, 2 hosts, f64)");
            bu_json_bool(j, "target_met", rw->ph[0].ghost_pct <= 3.0);
        }
    for (e = 0; e < 2; ++e) {
        bu_json_obj_begin(j, e ? "datagram_f32" : "datagram_f64");
        bu_json_int(j, "bytes", (long long)wire[e].bytes);
        bu_json_num(j, "values_us", wire[e].add * 1e6);
        bu_json_num(j, "crc_us", wire[e].end * 1e6);
        bu_json_num(j, "decode_us", wire[e].decode * 1e6);
        bu_json_num(j, "memcpy_us", wire[e].copy * 1e6);
        bu_json_num(j, "crc_slicing_by_8_us", wire[e].crc8 * 1e6);
        bu_json_bool(j, "crc_slicing_by_8_agrees", wire[e].crc8_agrees);
        bu_json_num(j, "encode_decode_mb_s", wire[e].bytes / (wire[e].add + wire[e].end + wire[e].decode) * 1e-6);
        bu_json_obj_end(j);
    }
    bu_json_num(j, "wall_s", bu_now() - t_start);
    bu_json_obj_end(j);

    bu_json_arr_begin(j, "plots");
    {
        /* ghost % against particles, one series per host count and
           encoding; bytes per second per host likewise */
        int pl;
        for (pl = 0; pl < 2; ++pl) {
            bu_json_obj_begin(j, NULL);
            bu_json_str(j, "title", pl == 0 ? "Ghost work as % of the cloth's own step"
                                           : "Bytes sent per second per host");
            bu_json_str(j, "xlabel", "particles");
            bu_json_str(j, "ylabel", pl == 0 ? "ghost work / step (%)" : "bytes/s per host");
            bu_json_bool(j, "log", 1);
            if (pl == 0) {
                bu_json_obj_begin(j, "hline");
                bu_json_num(j, "y", 3.0);
                bu_json_str(j, "title", "target 3%");
                bu_json_obj_end(j);
            }
            bu_json_arr_begin(j, "series");
            for (hi = 0; hi < nhosts; ++hi)
                for (e = 0; e < 2; ++e) {
                    double x[32], y[32];
                    int m = 0;
                    char name[64];
                    for (k = 0; k < nrows; ++k) {
                        if (rows[k].H != hostv[hi]) continue;
                        x[m] = (double)rows[k].n * rows[k].n;
                        y[m] = pl == 0 ? rows[k].ph[e].ghost_pct : rows[k].ab.bytes_per_s[e];
                        m++;
                    }
                    snprintf(name, sizeof name, "%d hosts, %s", hostv[hi], e ? "f32" : "f64");
                    bu_json_obj_begin(j, NULL);
                    bu_json_str(j, "name", name);
                    bu_json_num_array(j, "x", x, m);
                    bu_json_num_array(j, "y", y, m);
                    bu_json_obj_end(j);
                }
            bu_json_arr_end(j);
            bu_json_obj_end(j);
        }
    }
    bu_json_arr_end(j);
    bu_json_obj_end(j);
    if (bu_json_close(j) != 0) return 1;
    fprintf(stderr, "sync_overhead: wrote %s in %.1f s\n", a.out, bu_now() - t_start);
    return 0;
}
