/* seal - what sealing a datagram (GHOSTSIM_SODIUM, XChaCha20-Poly1305 under a
   pre-shared key) costs per datagram, against the same datagram in clear
   (CRC-32), in the same run.

   Host 2 holds a custom agent of N doubles under a ghost and sends its state
   at every step through a net whose send callback keeps the datagram; host 1
   receives it with gs_net_deliver. N = 1, 16, 64 and 135 f64 make one-chunk
   datagrams of 92 .. 1164 B in clear, 128 .. 1200 B sealed. For each size
   and each mode (clear, sealed) the two calls are timed one by one, send =
   gs_net_update (encode + CRC, or encode + seal) and receive =
   gs_net_deliver (CRC + decode + queue, or window + open + decode +
   queue), median of many, clear and sealed in alternating blocks so that
   both see the same machine. Also timed: libsodium's
   crypto_aead_xchacha20poly1305_ietf encrypt/decrypt (detached) alone on
   the same bytes, and the refusal of a forged sealed datagram (one bit
   flipped: one authentication, nothing decrypted) and of garbage.
   Target: sealing adds at most 3 us to a full datagram sent and received
   (about what the kernel spends on one datagram on loopback). */
#define GHOSTSIM_IMPLEMENTATION
#define GHOSTSIM_SODIUM
#include "ghostsim.h"
#include "bench_util.h"

#define MAXN 135
#define SIZES 4

static const unsigned char KEY[GS_WIRE_KEY_BYTES] = "bench key: 32 bytes, not secret";

typedef struct agent_user {
    double x[MAXN];
    int n;
} agent_user;

static gs_result noop_step(void *user, double t, double dt) {
    (void)user; (void)t; (void)dt;
    return GS_OK;
}
static void get_cb(const void *user, double *out) {
    const agent_user *u = (const agent_user *)user;
    memcpy(out, u->x, (size_t)u->n * sizeof(double));
}
static gs_result set_cb(void *user, const double *in) {
    agent_user *u = (agent_user *)user;
    memcpy(u->x, in, (size_t)u->n * sizeof(double));
    return GS_OK;
}

typedef struct last {
    unsigned char data[GS_WIRE_MAX_DATAGRAM];
    size_t size;
} last;

static gs_result keep_send(void *user, uint32_t host, const void *data, size_t size) {
    last *l = (last *)user;
    (void)host;
    memcpy(l->data, data, size);
    l->size = size;
    return GS_OK;
}

typedef struct side {
    gs_world *w;
    gs_agent *a;
    gs_net *net;
    agent_user u;
    last out;
} side;

static void die(const char *what, gs_world *w, gs_result r) {
    fprintf(stderr, "seal: %s: %s (%s)\n", what, gs_result_str(r), w ? gs_world_error(w) : "");
    exit(1);
}

static void side_make(side *s, uint32_t id, int n, int sealed) {
    gs_world_desc wd = gs_world_desc_default();
    gs_custom_desc cd;
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_net_desc nd;
    gs_result r;
    int i;
    memset(s, 0, sizeof *s);
    wd.host_id = id;
    if ((r = gs_world_create(&wd, &s->w)) != GS_OK) die("world", NULL, r);
    s->u.n = n;
    for (i = 0; i < n; ++i) s->u.x[i] = id + 0.001 * i;
    memset(&cd, 0, sizeof cd);
    cd.dt = 0.001;
    cd.state_size = (size_t)n;
    cd.step = noop_step;
    cd.get_state = get_cb;
    cd.set_state = set_cb;
    cd.user = &s->u;
    if ((r = gs_custom_create(s->w, &cd, &s->a)) != GS_OK) die("agent", s->w, r);
    gd.object_id = 1;
    gd.send_rate = 1e6;
    gd.queue_size = 1;
    gd.weight = gs_weight_owner;
    gd.owner = 2;
    if ((r = gs_ghost_attach(s->a, &gd)) != GS_OK) die("ghost", s->w, r);
    memset(&nd, 0, sizeof nd);
    nd.transport.send = keep_send;
    nd.transport.user = &s->out;
    nd.bandwidth = 1e12;
    nd.max_rate = 1e12;
    nd.key = sealed ? KEY : NULL;
    if ((r = gs_net_create(s->w, &nd, &s->net)) != GS_OK) die("net", s->w, r);
    if ((r = gs_net_add_peer(s->net, 3 - id, NULL)) != GS_OK) die("peer", s->w, r);
}

static void side_free(side *s) { gs_world_destroy(s->w); }

typedef struct pair {
    side tx, rx;
    double now;
} pair;

/* One datagram: host 2 steps (untimed), sends (timed), host 1 receives
   (timed). */
static void one(pair *p, double *t_send, double *t_recv) {
    double t0, t1, t2;
    gs_reject why;
    gs_result r;
    if ((r = gs_agent_step(p->tx.a)) != GS_OK) die("step", p->tx.w, r);
    p->now += 1e-3;
    p->tx.out.size = 0;
    t0 = bu_now();
    gs_net_update(p->tx.net, p->now);
    t1 = bu_now();
    r = gs_net_deliver(p->rx.net, p->tx.out.data, p->tx.out.size, p->now, &why);
    t2 = bu_now();
    if (r != GS_OK) {
        fprintf(stderr, "seal: refused: %s\n", gs_reject_str(why));
        exit(1);
    }
    *t_send = t1 - t0;
    *t_recv = t2 - t1;
    gs_agent_step(p->rx.a); /* blends: the queue stays short (untimed) */
}

/* The refusal of a copy of the last datagram with one bit flipped, or of
   garbage of the same size. */
static double refuse(pair *p, int garbage) {
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    size_t n = p->tx.out.size, i;
    double t0;
    gs_reject why;
    memcpy(buf, p->tx.out.data, n);
    if (garbage) for (i = 0; i < n; ++i) buf[i] = (unsigned char)(i * 131u + 7u);
    else { /* a counter ahead of the window, so that it is authenticated */
        buf[GS_WIRE_HEADER + 3] ^= 0x20;
        buf[n - GS_WIRE_TAG_BYTES - 1] = 0x7f;
    }
    t0 = bu_now();
    if (gs_net_deliver(p->rx.net, buf, n, p->now, &why) == GS_OK) {
        fprintf(stderr, "seal: a forgery was taken\n");
        exit(1);
    }
    return bu_now() - t0;
}

typedef struct aead_arg {
    unsigned char m[GS_WIRE_MAX_DATAGRAM], out[GS_WIRE_MAX_DATAGRAM], tag[16], nonce[24];
    size_t len;
} aead_arg;

static void aead_seal(void *user) {
    aead_arg *a = (aead_arg *)user;
    unsigned long long tl;
    a->nonce[0]++;
    crypto_aead_xchacha20poly1305_ietf_encrypt_detached(a->m + 48, a->tag, &tl, a->m + 48,
                                                        a->len - 48, a->m, 48, NULL, a->nonce, KEY);
}
static void aead_open(void *user) {
    aead_arg *a = (aead_arg *)user;
    int r = crypto_aead_xchacha20poly1305_ietf_decrypt_detached(
        a->out + 48, NULL, a->m + 48, a->len - 48, a->tag, a->m, 48, a->nonce, KEY);
    if (r != 0) { fprintf(stderr, "seal: open failed\n"); exit(1); }
    bu_sink((double)a->out[48]);
}

int main(int argc, char **argv) {
    static const int ns[SIZES] = {1, 16, 64, MAXN};
    static double s_send[2][20000], s_recv[2][20000], s_forge[20000], s_garb[2][20000];
    double send_med[SIZES][2], recv_med[SIZES][2], forge_med[SIZES], garb_med[SIZES][2];
    double aseal[SIZES], aopen[SIZES], bytes[SIZES][2], x[SIZES], y[4][SIZES];
    bu_args a;
    bu_json *j;
    int k, mode, b, i, blocks, per;
    if ((k = bu_parse_args(argc, argv, "seal", &a)) != 0) return k > 0 ? 0 : 2;
    if (sodium_init() < 0) { fprintf(stderr, "seal: libsodium failed\n"); return 1; }
    blocks = a.quick ? 10 : 40;
    per = a.quick ? 200 : 500;
    fprintf(stderr, "%6s %6s %6s | %9s %9s | %9s %9s | %9s %9s | %9s %9s\n", "values", "clear",
            "sealed", "send clr", "send seal", "recv clr", "recv seal", "aead seal",
            "aead open", "forged", "garbage");
    for (k = 0; k < SIZES; ++k) {
        pair p[2];
        aead_arg aa;
        for (mode = 0; mode < 2; ++mode) {
            side_make(&p[mode].tx, 2, ns[k], mode);
            side_make(&p[mode].rx, 1, ns[k], mode);
            p[mode].now = 1.0;
        }
        for (b = 0; b < blocks; ++b)
            for (mode = 0; mode < 2; ++mode)
                for (i = 0; i < per; ++i) {
                    int at = b * per + i;
                    one(&p[mode], &s_send[mode][at], &s_recv[mode][at]);
                    s_garb[mode][at] = refuse(&p[mode], 1);
                    if (mode) s_forge[at] = refuse(&p[mode], 0);
                }
        for (mode = 0; mode < 2; ++mode) {
            send_med[k][mode] = bu_median(s_send[mode], blocks * per);
            recv_med[k][mode] = bu_median(s_recv[mode], blocks * per);
            garb_med[k][mode] = bu_median(s_garb[mode], blocks * per);
            bytes[k][mode] = (double)p[mode].tx.out.size;
        }
        forge_med[k] = bu_median(s_forge, blocks * per);
        memset(&aa, 1, sizeof aa);
        aa.len = p[1].tx.out.size - GS_WIRE_SEAL_TRAILER;
        aseal[k] = bu_time_median(aead_seal, &aa, blocks, per);
        aopen[k] = bu_time_median(aead_open, &aa, blocks, per); /* the last seal's */
        fprintf(stderr, "%6d %5.0fB %5.0fB | %7.2fus %7.2fus | %7.2fus %7.2fus | %7.2fus %7.2fus "
                "| %7.2fus %7.2fus\n", ns[k], bytes[k][0], bytes[k][1], send_med[k][0] * 1e6,
                send_med[k][1] * 1e6, recv_med[k][0] * 1e6, recv_med[k][1] * 1e6, aseal[k] * 1e6,
                aopen[k] * 1e6, forge_med[k] * 1e6, garb_med[k][1] * 1e6);
        for (mode = 0; mode < 2; ++mode) {
            side_free(&p[mode].tx);
            side_free(&p[mode].rx);
        }
    }
    j = bu_json_open(a.out);
    if (!j) return 1;
    bu_json_obj_begin(j, NULL);
    bu_json_header(j, "seal", a.quick);
    bu_json_str(j, "method",
                "One-chunk datagrams between two in-process hosts; send = gs_net_update, receive "
                "= gs_net_deliver, each timed alone, median over blocks alternating clear and "
                "sealed; aead = libsodium's XChaCha20-Poly1305 detached on the same bytes; "
                "forged = a sealed datagram with one bit flipped and a counter ahead "
                "(refused after one authentication); garbage = bytes without the magic.");
    bu_json_arr_begin(j, "results");
    for (k = 0; k < SIZES; ++k) {
        bu_json_obj_begin(j, NULL);
        bu_json_int(j, "values", ns[k]);
        bu_json_num(j, "bytes_clear", bytes[k][0]);
        bu_json_num(j, "bytes_sealed", bytes[k][1]);
        bu_json_num(j, "send_clear_us", send_med[k][0] * 1e6);
        bu_json_num(j, "send_sealed_us", send_med[k][1] * 1e6);
        bu_json_num(j, "recv_clear_us", recv_med[k][0] * 1e6);
        bu_json_num(j, "recv_sealed_us", recv_med[k][1] * 1e6);
        bu_json_num(j, "aead_seal_us", aseal[k] * 1e6);
        bu_json_num(j, "aead_open_us", aopen[k] * 1e6);
        bu_json_num(j, "refuse_forged_us", forge_med[k] * 1e6);
        bu_json_num(j, "refuse_garbage_us", garb_med[k][1] * 1e6);
        bu_json_obj_end(j);
    }
    bu_json_arr_end(j);
    k = SIZES - 1;
    bu_json_obj_begin(j, "summary");
    bu_json_num(j, "full_datagram_clear_us", (send_med[k][0] + recv_med[k][0]) * 1e6);
    bu_json_num(j, "full_datagram_sealed_us", (send_med[k][1] + recv_med[k][1]) * 1e6);
    bu_json_num(j, "seal_overhead_us",
                (send_med[k][1] + recv_med[k][1] - send_med[k][0] - recv_med[k][0]) * 1e6);
    bu_json_num(j, "aead_seal_plus_open_us", (aseal[k] + aopen[k]) * 1e6);
    bu_json_str(j, "target", "sealing adds at most 3 us to a full datagram sent and received");
    bu_json_bool(j, "target_met",
                 send_med[k][1] + recv_med[k][1] - send_med[k][0] - recv_med[k][0] <= 3e-6);
    bu_json_obj_end(j);
    bu_json_arr_begin(j, "plots");
    for (k = 0; k < SIZES; ++k) {
        x[k] = bytes[k][1];
        y[0][k] = (send_med[k][0] + recv_med[k][0]) * 1e6;
        y[1][k] = (send_med[k][1] + recv_med[k][1]) * 1e6;
        y[2][k] = (aseal[k] + aopen[k]) * 1e6;
        y[3][k] = forge_med[k] * 1e6;
    }
    {
        static const char *const names[4] = {"in clear: send + receive", "sealed: send + receive",
                                             "libsodium alone: seal + open",
                                             "refusing a forgery"};
        const double *xs[4] = {x, x, x, x}, *ys[4] = {y[0], y[1], y[2], y[3]};
        const int n[4] = {SIZES, SIZES, SIZES, SIZES};
        bu_json_plot(j, "Cost per datagram, sealed against in clear", "datagram bytes (sealed)",
                     "us per datagram", 0, 4, names, xs, ys, n);
    }
    bu_json_arr_end(j);
    bu_json_obj_end(j);
    return bu_json_close(j) == 0 ? 0 : 1;
}
