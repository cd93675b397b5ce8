/* bench/transport.c - ghostsim's POSIX UDP transport on loopback, against raw
   sendto/recvfrom and against ENet, datagrams of the same sizes in one run.

   usage: build/bench/transport [--quick] [--out FILE.json]

   What is measured (the same for the three transports):
     one sender thread floods 127.0.0.1 with messages of S bytes as fast as
     it can, one receiver thread takes them; after a warm-up the sender reads
     the receiver's count of delivered messages at t0 and again at
     t1 = t0 + window, and stops. delivered/s = (c1 - c0) / (t1 - t0): the
     steady-state rate at which messages reach the receiving application,
     whichever side is the bottleneck (a flooded receive buffer drops, and
     that loss is not counted as delivered). Every loop stops by itself: the
     sender at t1, the receiver when told to and at the latest 50 ms after.
     Each receive socket gets SO_RCVBUF = 4 MiB (ghostsim's default; the
     kernel's rmem_max caps it, and the effective value is reported).
   The three sides:
     raw       sendto() of an S-byte buffer; a thread in recv() counts.
     ghostsim  the sender is a world with one custom agent whose state makes
               a snapshot of exactly one S-byte datagram (wire v1: 48 B
               header + 32 B chunk header + 8 B per value + 4 B CRC), a ghost
               at an unlimited send rate and bandwidth, and gs_udp in poll
               mode: each message is gs_agent_step (the ghost publishes B)
               then gs_net_update (encode, CRC, sendto). The receiver is a
               world with the same object and gs_udp with its gather thread
               (recv, decode, CRC check, validation, queue copy; the scatter
               thread runs too). Delivered = the peer's datagrams_received.
     ENet      enet_peer_send of an S-byte unreliable packet (flags 0), then
               enet_host_flush: one datagram per message, S + ENet's own
               header (10 B); every 64 messages the sender services its host
               (pings, throttle). A thread in enet_host_service counts
               RECEIVE events. ENet's default packet throttle stays on.
   The three run in rotating order within each repeat; the reported figures
   are medians over repeats, and the ratios are medians of per-repeat
   ratios. cpu_us = process CPU time (all threads, both ends) per delivered
   message over the window. */
#define GHOSTSIM_IMPLEMENTATION
#include "ghostsim.h"
#include "tests/net_helpers.h"
#include "bench/bench_util.h"

#include <arpa/inet.h>
#include <enet/enet.h>
#include <netinet/in.h>
#include <pthread.h>
#include <sys/socket.h>
#include <sys/time.h>

#define NSIZES 4
#define NKINDS 3
#define MAX_REPEATS 16
#define RCVBUF (4 << 20)

enum { K_RAW, K_GS, K_ENET };
static const char *const kind_name[NKINDS] = {"raw", "ghostsim", "enet"};

/* Values per snapshot: datagrams of 84 + 8 * E bytes (100 ... 1164). The
   largest is the largest one-chunk datagram: a chunk holds at most
   GS_WIRE_CHUNK_ROOM (1080) bytes of values, 135 f64, so that it can
   always be sealed; 139 values (1196 B) went out as two datagrams of
   640 B and failed the size check. */
static const int values_for_size[NSIZES] = {2, 21, 64, 135};

typedef struct run_cfg {
    double warmup, window; /* s */
    int size;              /* bytes per message */
    int values;            /* ghostsim: doubles per snapshot */
} run_cfg;

typedef struct run_result {
    double delivered_per_s; /* at the receiver */
    double sent_per_s;      /* offered by the sender loop */
    double cpu_us;          /* process CPU per delivered message */
    double send_cpu_us;     /* the sender thread's CPU per sent message */
    int rcvbuf;             /* effective SO_RCVBUF of the receive socket */
    double wire_bytes;      /* UDP payload bytes per datagram sent */
    int ok;
} run_result;

static double cpu_clock(clockid_t id) {
    struct timespec ts;
    clock_gettime(id, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* A free UDP port on 127.0.0.1 (bind to 0, read it, close). */
static int free_port(void) {
    struct sockaddr_in a;
    socklen_t len = sizeof a;
    int fd = socket(AF_INET, SOCK_DGRAM, 0), port = 0;
    if (fd < 0) return 0;
    memset(&a, 0, sizeof a);
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (bind(fd, (struct sockaddr *)&a, sizeof a) == 0 &&
        getsockname(fd, (struct sockaddr *)&a, &len) == 0)
        port = ntohs(a.sin_port);
    close(fd);
    return port;
}

static int rcvbuf_of(int fd) {
    int v = 0;
    socklen_t len = sizeof v;
    getsockopt(fd, SOL_SOCKET, SO_RCVBUF, &v, &len);
    return v;
}

/* Samples a delivered counter at t0 and t1; the loop body is the caller's.
   Returns 1 while the sender should go on. */
typedef struct window {
    double start, t0, t1, cpu0, cpu1, tcpu0, tcpu1; /* process, sender thread */
    uint64_t c0, c1, sent0, sent1;
    int phase; /* 0 warm-up, 1 measuring, 2 done */
} window;

static int window_tick(window *w, const run_cfg *cfg, uint64_t delivered, uint64_t sent,
                       double now) {
    if (w->phase == 0 && now - w->start >= cfg->warmup) {
        w->t0 = now;
        w->c0 = delivered;
        w->sent0 = sent;
        w->cpu0 = cpu_clock(CLOCK_PROCESS_CPUTIME_ID);
        w->tcpu0 = cpu_clock(CLOCK_THREAD_CPUTIME_ID);
        w->phase = 1;
    } else if (w->phase == 1 && now - w->t0 >= cfg->window) {
        w->t1 = now;
        w->c1 = delivered;
        w->sent1 = sent;
        w->cpu1 = cpu_clock(CLOCK_PROCESS_CPUTIME_ID);
        w->tcpu1 = cpu_clock(CLOCK_THREAD_CPUTIME_ID);
        w->phase = 2;
    }
    return w->phase < 2;
}

static void window_result(const window *w, run_result *r) {
    double span = w->t1 - w->t0;
    uint64_t n = w->c1 - w->c0;
    r->delivered_per_s = span > 0.0 ? (double)n / span : 0.0;
    r->sent_per_s = span > 0.0 ? (double)(w->sent1 - w->sent0) / span : 0.0;
    r->cpu_us = n ? 1e6 * (w->cpu1 - w->cpu0) / (double)n : 0.0;
    r->send_cpu_us = w->sent1 > w->sent0 ? 1e6 * (w->tcpu1 - w->tcpu0) / (double)(w->sent1 - w->sent0) : 0.0;
    r->ok = n > 0;
}

/* ---- raw sockets ---------------------------------------------------------- */

typedef struct raw_rx {
    int fd, stop;
    uint64_t count;
} raw_rx;

static void *raw_receiver(void *arg) {
    raw_rx *rx = (raw_rx *)arg;
    char buf[2048];
    while (!__atomic_load_n(&rx->stop, __ATOMIC_ACQUIRE)) {
        ssize_t n = recvfrom(rx->fd, buf, sizeof buf, 0, NULL, NULL);
        if (n > 0) __atomic_store_n(&rx->count, rx->count + 1, __ATOMIC_RELAXED);
    }
    return NULL;
}

static int udp_socket(int port, int rcvbuf) {
    struct sockaddr_in a;
    struct timeval tv = {0, 50000}; /* recv gives up after 50 ms: bounded */
    int fd = socket(AF_INET, SOCK_DGRAM, 0);
    if (fd < 0) return -1;
    if (rcvbuf) setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    memset(&a, 0, sizeof a);
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons((uint16_t)port);
    if (bind(fd, (struct sockaddr *)&a, sizeof a) != 0) {
        close(fd);
        return -1;
    }
    return fd;
}

static run_result run_raw(const run_cfg *cfg) {
    run_result r;
    raw_rx rx;
    pthread_t th;
    window w;
    struct sockaddr_in to;
    char buf[2048];
    uint64_t sent = 0;
    int port = free_port(), tx;
    memset(&r, 0, sizeof r);
    memset(&rx, 0, sizeof rx);
    memset(&w, 0, sizeof w);
    memset(buf, 0x5a, sizeof buf);
    rx.fd = udp_socket(port, RCVBUF);
    tx = socket(AF_INET, SOCK_DGRAM, 0);
    if (rx.fd < 0 || tx < 0) return r;
    r.rcvbuf = rcvbuf_of(rx.fd);
    memset(&to, 0, sizeof to);
    to.sin_family = AF_INET;
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    to.sin_port = htons((uint16_t)port);
    pthread_create(&th, NULL, raw_receiver, &rx);
    w.start = bu_now();
    for (;;) {
        if (sendto(tx, buf, (size_t)cfg->size, 0, (struct sockaddr *)&to, sizeof to) ==
            (ssize_t)cfg->size)
            sent++;
        if (!window_tick(&w, cfg, __atomic_load_n(&rx.count, __ATOMIC_RELAXED), sent, bu_now()))
            break;
    }
    __atomic_store_n(&rx.stop, 1, __ATOMIC_RELEASE);
    pthread_join(th, NULL);
    close(tx);
    close(rx.fd);
    window_result(&w, &r);
    return r;
}

/* ---- ghostsim ------------------------------------------------------------- */

typedef struct blob {
    double v[GS_WIRE_MAX_DATAGRAM / 8];
    int n;
} blob;

static gs_result blob_step(void *user, double t, double dt) {
    blob *b = (blob *)user;
    (void)dt;
    b->v[0] = t; /* something changes */
    return GS_OK;
}
static void blob_get(const void *user, double *out) {
    const blob *b = (const blob *)user;
    memcpy(out, b->v, (size_t)b->n * sizeof(double));
}
static gs_result blob_set(void *user, const double *in) {
    blob *b = (blob *)user;
    memcpy(b->v, in, (size_t)b->n * sizeof(double));
    return GS_OK;
}

typedef struct gs_side {
    gs_world *w;
    gs_agent *a;
    gs_net *u;
    blob b;
} gs_side;

static int gs_side_open(gs_side *s, uint32_t host, int values, int port, int threads) {
    gs_world_desc wd = gs_world_desc_default();
    gs_custom_desc cd;
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_udp_desc ud;
    gs_net_desc nd = gs_net_desc_default();
    char bind[64];
    int i;
    memset(&cd, 0, sizeof cd);
    memset(&ud, 0, sizeof ud);
    for (i = 0; i < values; ++i) s->b.v[i] = 0.25 * i;
    s->b.n = values;
    wd.host_id = host;
    if (gs_world_create(&wd, &s->w) != GS_OK) return 0;
    cd.dt = 0.001;
    cd.state_size = (size_t)values;
    cd.step = blob_step;
    cd.get_state = blob_get;
    cd.set_state = blob_set;
    cd.user = &s->b;
    if (gs_custom_create(s->w, &cd, &s->a) != GS_OK) return 0;
    gd.object_id = 1;
    gd.send_rate = 1e9; /* every step publishes and every update sends */
    gd.weight = gs_weight_exp; /* the rule of the figures recorded so far */
    if (gs_ghost_attach(s->a, &gd) != GS_OK) return 0;
    snprintf(bind, sizeof bind, "127.0.0.1:%d", port);
    ud.bind = bind;
    ud.threads = threads;
    ud.rcvbuf = RCVBUF;
    nd.bandwidth = 1e12; /* no budget: the transport's own limit */
    if (test_udp_open(s->w, &ud, &nd, &s->u) != GS_OK) {
        fprintf(stderr, "transport: gs_net_create on gs_udp: %s\n", gs_world_error(s->w));
        return 0;
    }
    return 1;
}

static void gs_side_close(gs_side *s) {
    if (s->u) gs_net_destroy(s->u);
    if (s->w) gs_world_destroy(s->w);
}

static uint64_t gs_delivered(gs_net *u, uint32_t from) {
    gs_peer_stats ps;
    if (gs_net_peer_stats(u, from, &ps) != GS_OK) return 0;
    return ps.datagrams_received;
}

/* The receive socket's effective buffer: the gather thread's socket is
   private, so ask the kernel for a socket given the same request. */
static int requested_rcvbuf(void) {
    int fd = socket(AF_INET, SOCK_DGRAM, 0), rcv = RCVBUF, v;
    setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcv, sizeof rcv);
    v = rcvbuf_of(fd);
    close(fd);
    return v;
}

static run_result run_gs(const run_cfg *cfg) {
    run_result r;
    gs_side tx, rx;
    window w;
    char addr[64];
    int ptx = free_port(), prx = free_port();
    uint64_t sent0;
    memset(&r, 0, sizeof r);
    memset(&tx, 0, sizeof tx);
    memset(&rx, 0, sizeof rx);
    memset(&w, 0, sizeof w);
    if (!gs_side_open(&rx, 2, cfg->values, prx, 1) || !gs_side_open(&tx, 1, cfg->values, ptx, 0))
        goto done;
    snprintf(addr, sizeof addr, "127.0.0.1:%d", prx);
    gs_net_add_peer(tx.u, 2, addr);
    snprintf(addr, sizeof addr, "127.0.0.1:%d", ptx);
    gs_net_add_peer(rx.u, 1, addr);
    r.rcvbuf = requested_rcvbuf();
    {
        gs_peer_stats ps;
        gs_net_peer_stats(tx.u, 2, &ps);
        sent0 = ps.datagrams_sent;
    }
    w.start = bu_now();
    for (;;) {
        gs_peer_stats ps;
        double now;
        gs_agent_step(tx.a);
        now = gs_udp_now();
        gs_net_update(tx.u, now);
        if (w.phase == 1 && now - w.t0 < cfg->window) continue; /* no lock taken */
        gs_net_peer_stats(tx.u, 2, &ps);
        if (!window_tick(&w, cfg, gs_delivered(rx.u, 1), ps.datagrams_sent - sent0, now)) break;
    }
    window_result(&w, &r);
    {
        /* every sent datagram must have been one message of the right size */
        gs_peer_stats ps;
        gs_net_peer_stats(tx.u, 2, &ps);
        if (ps.datagrams_sent && ps.bytes_sent / ps.datagrams_sent != (uint64_t)cfg->size) {
            fprintf(stderr, "transport: ghostsim datagrams are %llu B, expected %d\n",
                    (unsigned long long)(ps.bytes_sent / ps.datagrams_sent), cfg->size);
            r.ok = 0;
        }
        gs_net_peer_stats(rx.u, 1, &ps);
        if (ps.rejected_total) {
            fprintf(stderr, "transport: the receiver refused %llu datagrams\n",
                    (unsigned long long)ps.rejected_total);
            r.ok = 0;
        }
    }
done:
    gs_side_close(&tx);
    gs_side_close(&rx);
    return r;
}

/* ---- ENet ------------------------------------------------------------------ */

typedef struct enet_rx {
    ENetHost *host;
    int stop;
    uint64_t count;
} enet_rx;

static void *enet_receiver(void *arg) {
    enet_rx *rx = (enet_rx *)arg;
    while (!__atomic_load_n(&rx->stop, __ATOMIC_ACQUIRE)) {
        ENetEvent ev;
        int got = enet_host_service(rx->host, &ev, 10);
        while (got > 0) {
            if (ev.type == ENET_EVENT_TYPE_RECEIVE) {
                __atomic_store_n(&rx->count, rx->count + 1, __ATOMIC_RELAXED);
                enet_packet_destroy(ev.packet);
            }
            got = enet_host_check_events(rx->host, &ev);
        }
    }
    return NULL;
}

/* Connects client to server, servicing both from this thread (bounded:
   2 s). Returns the client's peer or NULL. */
static ENetPeer *enet_pair(ENetHost *server, ENetHost *client, int port) {
    ENetAddress a;
    ENetPeer *peer;
    int up_c = 0, up_s = 0;
    double until = bu_now() + 2.0;
    enet_address_set_host(&a, "127.0.0.1");
    a.port = (enet_uint16)port;
    peer = enet_host_connect(client, &a, 1, 0);
    if (!peer) return NULL;
    while ((!up_c || !up_s) && bu_now() < until) {
        ENetEvent ev;
        if (enet_host_service(client, &ev, 1) > 0 && ev.type == ENET_EVENT_TYPE_CONNECT) up_c = 1;
        if (enet_host_service(server, &ev, 1) > 0 && ev.type == ENET_EVENT_TYPE_CONNECT) up_s = 1;
    }
    return up_c && up_s ? peer : NULL;
}

static run_result run_enet(const run_cfg *cfg) {
    run_result r;
    enet_rx rx;
    pthread_t th;
    window w;
    ENetAddress a;
    ENetHost *client = NULL;
    ENetPeer *peer;
    unsigned char buf[2048];
    uint64_t sent = 0;
    int port = free_port();
    memset(&r, 0, sizeof r);
    memset(&rx, 0, sizeof rx);
    memset(&w, 0, sizeof w);
    memset(buf, 0x5a, sizeof buf);
    enet_address_set_host(&a, "127.0.0.1");
    a.port = (enet_uint16)port;
    rx.host = enet_host_create(&a, 1, 1, 0, 0);
    client = enet_host_create(NULL, 1, 1, 0, 0);
    if (!rx.host || !client) goto done;
    /* ENet asks for 256 KiB; give it the same buffer as the others */
    enet_socket_set_option(rx.host->socket, ENET_SOCKOPT_RCVBUF, RCVBUF);
    r.rcvbuf = rcvbuf_of(rx.host->socket);
    peer = enet_pair(rx.host, client, port);
    if (!peer) {
        fprintf(stderr, "transport: ENet did not connect\n");
        goto done;
    }
    pthread_create(&th, NULL, enet_receiver, &rx);
    w.start = bu_now();
    for (;;) {
        ENetPacket *p = enet_packet_create(buf, (size_t)cfg->size, 0);
        if (p && enet_peer_send(peer, 0, p) == 0) sent++;
        else if (p) enet_packet_destroy(p);
        enet_host_flush(client);
        if ((sent & 63) == 0) {
            ENetEvent ev;
            while (enet_host_service(client, &ev, 0) > 0)
                if (ev.type == ENET_EVENT_TYPE_RECEIVE) enet_packet_destroy(ev.packet);
        }
        if (!window_tick(&w, cfg, __atomic_load_n(&rx.count, __ATOMIC_RELAXED), sent, bu_now()))
            break;
    }
    __atomic_store_n(&rx.stop, 1, __ATOMIC_RELEASE);
    pthread_join(th, NULL);
    window_result(&w, &r);
    if (client->totalSentPackets)
        r.wire_bytes = (double)client->totalSentData / (double)client->totalSentPackets;
done:
    if (client) enet_host_destroy(client);
    if (rx.host) enet_host_destroy(rx.host);
    return r;
}

/* ---- the library alone: no sockets ---------------------------------------- */

/* ghostsim's own CPU per message, without the kernel: the sender's
   gs_agent_step + gs_net_update with a send callback that does nothing, and
   the same with a callback that hands the datagram straight to the
   receiver's gs_net_deliver (decode, CRC, validation, queue). The receive
   cost is the difference. Medians over repeats of `inner` messages. */
typedef struct lib_pair {
    gs_world *w[2];
    gs_agent *a[2];
    gs_net *net[2];
    blob b[2];
    int deliver;
    double now;
} lib_pair;

static gs_result lib_send(void *user, uint32_t host, const void *data, size_t size) {
    lib_pair *lp = (lib_pair *)user;
    (void)host;
    if (lp->deliver) return gs_net_deliver(lp->net[1], data, size, lp->now, NULL);
    bu_sink((double)size);
    return GS_OK;
}

static int lib_open(lib_pair *lp, int values) {
    int h, i;
    memset(lp, 0, sizeof *lp);
    for (h = 0; h < 2; ++h) {
        gs_world_desc wd = gs_world_desc_default();
        gs_custom_desc cd;
        gs_ghost_desc gd = gs_ghost_desc_default();
        gs_net_desc nd;
        memset(&cd, 0, sizeof cd);
        memset(&nd, 0, sizeof nd);
        for (i = 0; i < values; ++i) lp->b[h].v[i] = 0.25 * i;
        lp->b[h].n = values;
        wd.host_id = (uint32_t)h + 1;
        if (gs_world_create(&wd, &lp->w[h]) != GS_OK) return 0;
        cd.dt = 0.001;
        cd.state_size = (size_t)values;
        cd.step = blob_step;
        cd.get_state = blob_get;
        cd.set_state = blob_set;
        cd.user = &lp->b[h];
        if (gs_custom_create(lp->w[h], &cd, &lp->a[h]) != GS_OK) return 0;
        gd.object_id = 1;
        gd.send_rate = 1e9;
        gd.weight = gs_weight_exp; /* the rule of the figures recorded so far */
        if (gs_ghost_attach(lp->a[h], &gd) != GS_OK) return 0;
        nd.transport.send = lib_send;
        nd.transport.user = lp;
        nd.bandwidth = 1e12;
        if (gs_net_create(lp->w[h], &nd, &lp->net[h]) != GS_OK) return 0;
        if (gs_net_add_peer(lp->net[h], h == 0 ? 2u : 1u, NULL) != GS_OK) return 0;
    }
    return 1;
}

static void lib_close(lib_pair *lp) {
    int h;
    for (h = 0; h < 2; ++h)
        if (lp->w[h]) gs_world_destroy(lp->w[h]);
}

/* Seconds per message, median of `repeats` runs of `inner` messages. */
static double lib_time(lib_pair *lp, int deliver, int repeats, int inner) {
    double v[MAX_REPEATS * 4];
    int r, i;
    lp->deliver = deliver;
    if (repeats > MAX_REPEATS * 4) repeats = MAX_REPEATS * 4;
    for (r = 0; r < repeats; ++r) {
        double t0 = bu_now();
        for (i = 0; i < inner; ++i) {
            gs_agent_step(lp->a[0]);
            lp->now += 1e-6;
            gs_net_update(lp->net[0], lp->now);
        }
        v[r] = (bu_now() - t0) / inner;
    }
    return bu_median(v, repeats);
}

/* ---- driver ---------------------------------------------------------------- */

static run_result run_kind(int kind, const run_cfg *cfg) {
    if (kind == K_RAW) return run_raw(cfg);
    if (kind == K_GS) return run_gs(cfg);
    return run_enet(cfg);
}

typedef struct cell { /* one size, one transport, all repeats */
    double delivered[MAX_REPEATS], sent[MAX_REPEATS], cpu[MAX_REPEATS], scpu[MAX_REPEATS];
    double med_delivered, med_sent, med_cpu, med_scpu, wire_bytes;
    int rcvbuf, failures;
} cell;

static double median_of(const double *v, int n) {
    double t[MAX_REPEATS];
    memcpy(t, v, (size_t)n * sizeof *t);
    return bu_median(t, n);
}

int main(int argc, char **argv) {
    bu_args args;
    run_cfg cfg;
    cell cells[NSIZES][NKINDS];
    double ratio_raw[NSIZES][MAX_REPEATS], ratio_enet[NSIZES][MAX_REPEATS];
    double med_raw[NSIZES], med_enet[NSIZES], sizes[NSIZES];
    double lib_send_ns[NSIZES], lib_recv_ns[NSIZES];
    int repeats, s, k, rep, pa = bu_parse_args(argc, argv, "transport", &args);
    double worst_raw = 1e300, worst_enet = 1e300;
    bu_json *j;
    if (pa) return pa > 0 ? 0 : 2;
    if (enet_initialize() != 0) {
        fprintf(stderr, "transport: enet_initialize failed\n");
        return 1;
    }
    memset(cells, 0, sizeof cells);
    repeats = args.quick ? 3 : 7;
    cfg.warmup = args.quick ? 0.1 : 0.2;
    cfg.window = args.quick ? 0.25 : 1.0;
    fprintf(stderr, "transport: loopback, %d repeats of a %.2f s window per cell (median)\n",
            repeats, cfg.window);
    for (s = 0; s < NSIZES; ++s) {
        cfg.values = values_for_size[s];
        cfg.size = GS_WIRE_HEADER + GS_WIRE_CHUNK_HEADER + 8 * cfg.values + 4;
        sizes[s] = cfg.size;
        for (rep = 0; rep < repeats; ++rep) {
            run_result rr[NKINDS];
            for (k = 0; k < NKINDS; ++k) { /* rotate the order */
                int kind = (k + rep) % NKINDS;
                rr[kind] = run_kind(kind, &cfg);
            }
            for (k = 0; k < NKINDS; ++k) {
                cell *c = &cells[s][k];
                c->delivered[rep] = rr[k].delivered_per_s;
                c->sent[rep] = rr[k].sent_per_s;
                c->cpu[rep] = rr[k].cpu_us;
                c->scpu[rep] = rr[k].send_cpu_us;
                c->wire_bytes = k == K_ENET ? rr[k].wire_bytes : sizes[s];
                c->rcvbuf = rr[k].rcvbuf;
                if (!rr[k].ok) c->failures++;
            }
            ratio_raw[s][rep] = rr[K_RAW].delivered_per_s > 0
                                    ? rr[K_GS].delivered_per_s / rr[K_RAW].delivered_per_s : 0;
            ratio_enet[s][rep] = rr[K_ENET].delivered_per_s > 0
                                     ? rr[K_GS].delivered_per_s / rr[K_ENET].delivered_per_s : 0;
        }
        for (k = 0; k < NKINDS; ++k) {
            cell *c = &cells[s][k];
            c->med_delivered = median_of(c->delivered, repeats);
            c->med_sent = median_of(c->sent, repeats);
            c->med_cpu = median_of(c->cpu, repeats);
            c->med_scpu = median_of(c->scpu, repeats);
        }
        {
            lib_pair lp;
            double ts[MAX_REPEATS], tb[MAX_REPEATS];
            gs_peer_stats ps;
            int inner = args.quick ? 5000 : 20000;
            memset(&ps, 0, sizeof ps);
            if (lib_open(&lp, cfg.values)) {
                for (rep = 0; rep < repeats; ++rep) {
                    ts[rep] = lib_time(&lp, 0, 1, inner);
                    tb[rep] = lib_time(&lp, 1, 1, inner);
                }
                gs_net_peer_stats(lp.net[1], 1, &ps);
            }
            lib_send_ns[s] = 1e9 * median_of(ts, repeats);
            lib_recv_ns[s] = 1e9 * (median_of(tb, repeats) - median_of(ts, repeats));
            if (ps.datagrams_received == 0 || ps.rejected_total) {
                fprintf(stderr, "transport: in-process delivery failed (%llu rejected)\n",
                        (unsigned long long)ps.rejected_total);
                lib_send_ns[s] = lib_recv_ns[s] = NAN;
            }
            lib_close(&lp);
        }
        med_raw[s] = median_of(ratio_raw[s], repeats);
        med_enet[s] = median_of(ratio_enet[s], repeats);
        if (med_raw[s] < worst_raw) worst_raw = med_raw[s];
        if (med_enet[s] < worst_enet) worst_enet = med_enet[s];
    }
    enet_deinitialize();

    fprintf(stderr, "\n%6s  %-9s %12s %9s %12s %9s %9s %6s\n", "bytes", "transport",
            "delivered/s", "MB/s", "offered/s", "cpu us", "send us", "wire");
    for (s = 0; s < NSIZES; ++s) {
        for (k = 0; k < NKINDS; ++k) {
            const cell *c = &cells[s][k];
            fprintf(stderr, "%6d  %-9s %12.0f %9.1f %12.0f %9.2f %9.2f %6.0f%s\n", (int)sizes[s],
                    kind_name[k], c->med_delivered, c->med_delivered * sizes[s] / 1e6,
                    c->med_sent, c->med_cpu, c->med_scpu, c->wire_bytes,
                    c->failures ? "  (failures)" : "");
        }
        fprintf(stderr, "%6s  ghostsim/raw %.3f   ghostsim/enet %.3f   library alone: send %.0f ns, "
                "receive %.0f ns per message\n", "", med_raw[s], med_enet[s], lib_send_ns[s],
                lib_recv_ns[s]);
    }
    fprintf(stderr, "\ntarget ghostsim >= 0.90 x raw: %s (worst size %.3f)\n",
            worst_raw >= 0.9 ? "met" : "MISSED", worst_raw);
    fprintf(stderr, "target ghostsim ahead of ENet: %s (worst size %.3f)\n",
            worst_enet > 1.0 ? "met" : "MISSED", worst_enet);

    j = bu_json_open(args.out);
    if (!j) return 1;
    bu_json_obj_begin(j, NULL);
    bu_json_header(j, "transport", args.quick);
    bu_json_str(j, "method",
                "One sender thread floods 127.0.0.1 with S-byte messages as fast as it can; one "
                "receiver thread takes them. After a warm-up the sender samples the receiver's "
                "delivered count at t0 and t0+window: delivered/s is the steady rate at which "
                "messages reach the receiving application (kernel drops in a full receive "
                "buffer are not delivered). raw = sendto/recvfrom; ghostsim = gs_agent_step "
                "(ghost publishes) + gs_net_update (encode, CRC-32, sendto) in poll mode to a "
                "gs_udp receiver with its gather thread (decode, CRC check, validation, queue); "
                "one S-byte wire-v1 datagram per message; ENet = enet_peer_send of an S-byte "
                "unreliable packet + enet_host_flush (one datagram per message, S + 10 B ENet "
                "header), default throttle. SO_RCVBUF 4 MiB on every receive socket. Rotating "
                "order, medians over repeats; ratios are medians of per-repeat ratios. cpu_us: "
                "process CPU (both ends, all threads) per delivered message; sender_cpu_us: the "
                "sender thread's CPU per sent message. library_send_ns / library_receive_ns: "
                "ghostsim's own CPU per message with no socket (send callback that does nothing, "
                "or that calls the receiver's gs_net_deliver directly; receive = the difference).");
    bu_json_int(j, "repeats", repeats);
    bu_json_num(j, "window_s", cfg.window);
    bu_json_num(j, "warmup_s", cfg.warmup);
    bu_json_arr_begin(j, "results");
    for (s = 0; s < NSIZES; ++s)
        for (k = 0; k < NKINDS; ++k) {
            const cell *c = &cells[s][k];
            bu_json_obj_begin(j, NULL);
            bu_json_int(j, "bytes", (long long)sizes[s]);
            bu_json_str(j, "transport", kind_name[k]);
            bu_json_num(j, "delivered_per_s", c->med_delivered);
            bu_json_num(j, "mb_per_s", c->med_delivered * sizes[s] / 1e6);
            if (k == K_GS)
                bu_json_num(j, "state_mb_per_s", c->med_delivered * 8.0 * values_for_size[s] / 1e6);
            bu_json_num(j, "offered_per_s", c->med_sent);
            bu_json_num(j, "cpu_us_per_message", c->med_cpu);
            bu_json_num(j, "sender_cpu_us_per_message", c->med_scpu);
            bu_json_num(j, "udp_payload_bytes", c->wire_bytes);
            bu_json_int(j, "rcvbuf_effective", c->rcvbuf);
            bu_json_int(j, "failed_repeats", c->failures);
            bu_json_num_array(j, "delivered_per_s_repeats", c->delivered, repeats);
            if (k == K_GS) {
                bu_json_num(j, "library_send_ns", lib_send_ns[s]);
                bu_json_num(j, "library_receive_ns", lib_recv_ns[s]);
                bu_json_num(j, "ratio_to_raw", med_raw[s]);
                bu_json_num(j, "ratio_to_enet", med_enet[s]);
            }
            bu_json_obj_end(j);
        }
    bu_json_arr_end(j);
    bu_json_obj_begin(j, "summary");
    bu_json_num(j, "worst_ratio_to_raw", worst_raw);
    bu_json_num(j, "worst_ratio_to_enet", worst_enet);
    bu_json_num(j, "ratio_to_raw_1164B", med_raw[NSIZES - 1]);
    bu_json_num(j, "ratio_to_enet_1164B", med_enet[NSIZES - 1]);
    bu_json_bool(j, "target_90pct_of_raw_met", worst_raw >= 0.9);
    bu_json_bool(j, "target_ahead_of_enet_met", worst_enet > 1.0);
    bu_json_obj_end(j);
    bu_json_arr_begin(j, "plots");
    {
        double y[NKINDS][NSIZES], mb[NKINDS][NSIZES];
        const double *xs[NKINDS], *ys[NKINDS], *ms[NKINDS];
        int ns[NKINDS];
        for (k = 0; k < NKINDS; ++k) {
            for (s = 0; s < NSIZES; ++s) {
                y[k][s] = cells[s][k].med_delivered;
                mb[k][s] = cells[s][k].med_delivered * sizes[s] / 1e6;
            }
            xs[k] = sizes;
            ys[k] = y[k];
            ms[k] = mb[k];
            ns[k] = NSIZES;
        }
        bu_json_plot(j, "UDP loopback: messages delivered per second", "datagram bytes",
                     "delivered/s", 0, NKINDS, kind_name, xs, ys, ns);
        bu_json_plot(j, "UDP loopback: MB/s delivered", "datagram bytes", "MB/s", 0, NKINDS,
                     kind_name, xs, ms, ns);
    }
    bu_json_arr_end(j);
    bu_json_obj_end(j);
    if (bu_json_close(j) != 0) return 1;
    fprintf(stderr, "transport: wrote %s\n", args.out);
    return 0;
}
