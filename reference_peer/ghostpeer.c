/* ghostpeer - one host of the paper's scene over UDP: the reference peer.

     ghostpeer --id N --listen HOST:PORT [--peer ID@HOST:PORT]... [--duration S]
               [--cloth N] [--spheres K] [--weight cs|exp[:RATE]|owner]
               [--integrator NAME] [--dt S] [--substeps N] [--probe-until S] [--seed N]
               [--encoding f64|f32|quant|quant-delta] [--stats-every S] [--trace FILE] [--key FILE]
               [--clock-step AT:SECONDS] [--probe-wild AT:SECONDS:SPEED]
               [--resolution M] [--rest-threshold M] [--heartbeat-rate HZ]
               [--sync present|replay] [--clock local|session]
               [--frame-lock on|off]

   --encoding quant sends positions at --resolution metres (default 5e-5),
   velocities at the library's default step (3 mm/s) and orientations as
   smallest three (wire v2);
   --encoding quant-delta the same, each snapshot coded as its differences
   from the newest one the peers acknowledged (gs_ghost_desc.delta);
   --rest-threshold M (default 0: off) sends a ghost that moved less than M
   since its last snapshot as a heartbeat only, at --heartbeat-rate Hz
   (default 4). Each JSON line gives per peer "bytes_sent" and "bytes_rx"
   (datagram bytes so far), "heartbeats_rx", "resting" (objects the peer
   says are at rest), "heard" (s since its last datagram, -1 never), and
   the peer's diagnosis: "health" (gs_peer_health_str), "reason" (a
   sentence for a user, "" when all is well) and "clock_back" (times the
   clock went back, gs_peer_stats.clock_backwards).

   Every host builds the same scene (gs_scene_create: a cloth pinned by its
   corners, K spheres above it, one probe per host of the session) and runs
   it at wall-clock pace. Host N drives probe N-1 along its scripted path
   until --probe-until seconds of simulation time, then parks it above the
   cloth. Ghosts: the cloth is object 1, sphere i object 100 + i (both under
   --weight, default cs: client/server, whose tie between hosts in step goes
   to the lowest id, so the hosts settle on one scene; under exp every host
   pulls the others toward their states of a latency ago, and the scene
   never quite comes to rest), probe i object 200 + i (owner authority:
   host i + 1 owns it).

   --sync replay runs the world on the session clock (GS_SYNC_CLOCK_SESSION:
   the hosts' simulation times follow the lowest id's timeline) and blends
   each snapshot at its own simulation time in a replay from the world
   history (GS_SYNC_REPLAY); present (the default) is the paper's blend at
   the local present on the local clock. Each JSON line then carries a
   "replay" object: the mode, replays, agent steps replayed per second of
   wall time, fallbacks (snapshots older than the history or past the
   replay budget, blended at the present), the lag (s the slowest agent
   is behind the target: this host not keeping pace), the timekeeper,
   replays_skipped (replays whose blends changed no state, or moved states
   within the replay tolerance: the present stood), replays_near (of
   those, the ones within the tolerance), clock_steps (steps of the local
   clock the session clock absorbed) and joins (times this host took a
   peer's timeline).
   --clock session puts the present blend on the session clock too; local
   keeps each host's target its own seconds advanced (--sync replay always
   runs on the session clock).

   --frame-lock on (with --clock session or --sync replay; default off)
   locks the host's 5 ms frame loop in phase with the session's: the world
   rounds each target to the session's 5 ms grid (gs_sync_desc.frame) and
   the loop sleeps until the next boundary (gs_world_next_frame), so the
   hosts of a session step at the same wall instants to the same times;
   off, each loop sleeps 5 ms from its own phase, which puts up to a frame
   of simulation time between hosts at any one instant. Locked, a frame is
   computed 3.5 ms before the boundary it stands for and held until it (the
   lines, the trace and the datagrams come out at the boundary). Each JSON
   line carries "frame_lock" (true/false), "t_done": the wall time (as
   "wall") at which the advance that took the world to "t" ended, and
   "t_since": the wall time from which the host shows "t" (t_done, or
   locked the boundary), so that a host's simulation time at any wall
   instant can be read from its lines (bench/process_gap.py).

   --key FILE seals every datagram under a pre-shared key (32 raw bytes, or
   64 hex digits and an optional newline) that every host of the session
   uses: datagrams not sealed under it are refused and counted. It needs a
   build with GHOSTSIM_SODIUM (the Makefile's); without, the peer says so
   and exits with 1.

   For the fault suite (tests/faults.py): --clock-step AT:SECONDS makes the
   clock this host paces its world with jump by SECONDS (negative: back)
   once, AT seconds into the run; the JSON "wall", --stats-every, --trace
   and --duration keep the real clocks. --probe-wild AT:SECONDS:SPEED has
   host N place probe N-1 itself (gs_agent_set_state, past the probe's own
   speed limit) along its scripted circle at SPEED m/s, with that velocity,
   from simulation time AT for SECONDS; then it follows its path again.

   --substeps N (XPBD only; 0..64, 0 or absent: the scene's default 4)
   sets the cloth's substeps per step of --dt: the cost of a simulated second is substeps / dt passes over
   the springs (README, Performance: the schedule for large cloths). Each
   JSON line carries "cpu": the process's CPU seconds (every thread) since
   the run began, after the scene was built; over "wall" it is the share
   of a core the host takes.

   stdout is for machines: one JSON object per line every --stats-every
   seconds of wall time, and a last line with "final": true and the totals
   (also on SIGINT or SIGTERM). Everything for humans goes to stderr. The
   command line and the JSON are a contract that tests drive: change them
   only by adding. Exit status: 0 done, 1 a runtime failure (port in use),
   2 a bad command line. */
#define GHOSTSIM_IMPLEMENTATION
#include "ghostsim.h"

#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define MAX_PEERS 15
#define KEY_BYTES GS_WIRE_KEY_BYTES
#define FRAME 0.005        /* s of wall time between world advances */
#define TRACE_EVERY 0.010  /* s of wall time between trace rows */
#define PARK_HEIGHT 0.4    /* m: a parked probe hangs clear of the cloth */
#define LEAD 0.0035        /* s; --frame-lock: a frame is computed this much
                              before the boundary it stands for. The session
                              clock reads that boundary's instant (show_clock),
                              not the instant the loop woke, so a late wake
                              does not move the target to another boundary;
                              the 1.5 ms left after a boundary carry its
                              datagrams and line out */

typedef struct peer_arg {
    uint32_t id;
    char addr[128];
} peer_arg;

typedef struct options {
    uint32_t id;
    const char *listen;
    peer_arg peers[MAX_PEERS];
    int npeers;
    double duration;       /* s; 0 = until a signal */
    int cloth, spheres;
    gs_weight_fn weight;
    double exp_rate;       /* 1/s for exp */
    gs_integrator integrator;
    double dt;
    int substeps;          /* XPBD cloth substeps per step; 0 = the scene's default */
    double probe_until;    /* s of simulation time */
    uint32_t seed;
    gs_encoding encoding;
    int delta;             /* --encoding quant-delta */
    double resolution;     /* m, quant positions; 0 = the library's default */
    double rest_threshold; /* m; 0 = send every state */
    double heartbeat_rate; /* Hz; 0 = the library's default */
    double stats_every;
    const char *trace;
    double step_at, step;  /* --clock-step: s into the run, s of jump */
    double wild_at, wild_for, wild_speed; /* --probe-wild: s, s, m/s */
    int has_key;
    unsigned char key[KEY_BYTES];
    int replay;            /* --sync replay */
    int session;           /* --clock session (--sync replay implies it) */
    int frame_lock;        /* --frame-lock on */
} options;

static volatile sig_atomic_t g_stop = 0; /* the only static: signal handlers need one */

static void on_signal(int sig) {
    (void)sig;
    g_stop = 1;
}

static void usage(const char *why) {
    if (why) fprintf(stderr, "ghostpeer: %s\n", why);
    fprintf(stderr,
            "usage: ghostpeer --id N --listen HOST:PORT [--peer ID@HOST:PORT]... [--duration S]\n"
            "                 [--cloth N] [--spheres K] [--weight cs|exp[:RATE]|owner]\n"
            "                 [--integrator explicit|symplectic|verlet|rk4|implicit|xpbd] [--dt S]\n"
            "                 [--substeps N] [--probe-until S] [--seed N] [--encoding f64|f32|quant|quant-delta]\n"
            "                 [--stats-every S] [--trace FILE] [--key FILE]\n"
            "                 [--clock-step AT:SECONDS] [--probe-wild AT:SECONDS:SPEED]\n"
            "                 [--resolution M] [--rest-threshold M] [--heartbeat-rate HZ]\n"
            "                 [--sync present|replay] [--clock local|session]\n"
            "                 [--frame-lock on|off]\n");
    exit(2);
}

/* ---- the command line ---- */

static double parse_number(const char *flag, const char *s, double lo, double hi) {
    char *end = NULL, msg[160];
    double v;
    errno = 0;
    v = strtod(s, &end);
    if (errno || end == s || *end != '\0' || !(v >= lo && v <= hi)) {
        snprintf(msg, sizeof msg, "%s: '%s' is not a number in [%g, %g]", flag, s, lo, hi);
        usage(msg);
    }
    return v;
}

/* A whole number in [lo, hi]: a fraction is refused, not truncated. */
static int parse_count(const char *flag, const char *s, int lo, int hi) {
    double v = parse_number(flag, s, lo, hi);
    char msg[160];
    if (v != floor(v)) {
        snprintf(msg, sizeof msg, "%s: '%s' is not a whole number", flag, s);
        usage(msg);
    }
    return (int)v;
}

static void parse_weight(options *o, const char *s) {
    if (strcmp(s, "cs") == 0) {
        o->weight = gs_weight_cs;
    } else if (strcmp(s, "owner") == 0) {
        o->weight = gs_weight_owner;
    } else if (strncmp(s, "exp", 3) == 0 && (s[3] == '\0' || s[3] == ':')) {
        o->weight = gs_weight_exp;
        if (s[3] == ':') o->exp_rate = parse_number("--weight exp:RATE", s + 4, -1e3, 1e3);
    } else {
        char msg[160];
        snprintf(msg, sizeof msg, "--weight: unknown rule '%s' (cs, exp[:RATE], owner)", s);
        usage(msg);
    }
}

static gs_integrator parse_integrator(const char *s) {
    static const char *const names[] = {"explicit", "symplectic", "verlet", "rk4", "implicit",
                                        "xpbd"};
    static const gs_integrator ids[] = {GS_INTEGRATOR_EXPLICIT_EULER, GS_INTEGRATOR_SYMPLECTIC_EULER,
                                        GS_INTEGRATOR_VERLET, GS_INTEGRATOR_RK4,
                                        GS_INTEGRATOR_IMPLICIT_EULER, GS_INTEGRATOR_XPBD};
    size_t i;
    char msg[160];
    for (i = 0; i < sizeof names / sizeof names[0]; ++i)
        if (strcmp(s, names[i]) == 0) return ids[i];
    snprintf(msg, sizeof msg, "--integrator: unknown '%s'", s);
    usage(msg);
    return GS_INTEGRATOR_DEFAULT;
}

static int hex_digit(int c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

/* --key FILE: 32 raw bytes, or 64 hex digits (trailing whitespace allowed). */
static void parse_key(options *o, const char *path) {
    unsigned char buf[130];
    char msg[300];
    size_t n, i;
    FILE *f = fopen(path, "rb");
    if (!f) {
        snprintf(msg, sizeof msg, "--key: cannot read '%s': %s", path, strerror(errno));
        usage(msg);
    }
    n = fread(buf, 1, sizeof buf, f);
    fclose(f);
    if (n == KEY_BYTES) {
        memcpy(o->key, buf, KEY_BYTES);
        o->has_key = 1;
        return;
    }
    while (n > 2 * KEY_BYTES && (buf[n - 1] == '\n' || buf[n - 1] == '\r' ||
                                 buf[n - 1] == ' ' || buf[n - 1] == '\t'))
        --n;
    for (i = 0; n == 2 * KEY_BYTES && i < KEY_BYTES; ++i) {
        int hi = hex_digit(buf[2 * i]), lo = hex_digit(buf[2 * i + 1]);
        if (hi < 0 || lo < 0) break;
        o->key[i] = (unsigned char)(hi << 4 | lo);
    }
    if (n != 2 * KEY_BYTES || i != KEY_BYTES) {
        snprintf(msg, sizeof msg, "--key: '%s' holds neither 32 raw bytes nor 64 hex digits",
                 path);
        usage(msg);
    }
    o->has_key = 1;
}

/* ID@HOST:PORT */
static void parse_peer(options *o, const char *s) {
    const char *at = strchr(s, '@');
    char msg[200];
    peer_arg *p;
    if (o->npeers == MAX_PEERS) usage("too many --peer (at most 15)");
    if (!at || at == s || strlen(at + 1) == 0 || strlen(at + 1) >= sizeof p->addr) {
        snprintf(msg, sizeof msg, "--peer: '%s' is not ID@HOST:PORT", s);
        usage(msg);
    }
    p = &o->peers[o->npeers++];
    {
        char idbuf[16];
        size_t n = (size_t)(at - s);
        if (n >= sizeof idbuf) usage("--peer: the id is too long");
        memcpy(idbuf, s, n);
        idbuf[n] = '\0';
        p->id = (uint32_t)parse_number("--peer ID", idbuf, 1, 65535);
    }
    strcpy(p->addr, at + 1);
}

/* A:B or A:B:C into v[0..n-1], each checked against [lo, hi]. */
static void parse_tuple(const char *flag, const char *s, int n, double *v, const double *lo,
                        const double *hi) {
    char buf[128], msg[200], *part = buf, *colon;
    int k;
    if (strlen(s) >= sizeof buf) usage("a flag value is too long");
    strcpy(buf, s);
    for (k = 0; k < n; ++k) {
        colon = strchr(part, ':');
        if ((k < n - 1) != (colon != NULL)) {
            snprintf(msg, sizeof msg, "%s: '%s' is not %s", flag, s,
                     n == 2 ? "AT:SECONDS" : "AT:SECONDS:SPEED");
            usage(msg);
        }
        if (colon) *colon = '\0';
        v[k] = parse_number(flag, part, lo[k], hi[k]);
        part = colon + 1;
    }
}

static void parse_args(int argc, char **argv, options *o) {
    int i, k;
    memset(o, 0, sizeof *o);
    o->cloth = 16;
    o->spheres = 3;
    o->weight = gs_weight_cs;
    o->exp_rate = 1.0;
    o->integrator = GS_INTEGRATOR_IMPLICIT_EULER;
    o->dt = 0.002;
    o->probe_until = 1e300;
    o->seed = 1;
    o->encoding = GS_ENCODING_F64;
    o->stats_every = 0.1;
    for (i = 1; i < argc; ++i) {
        const char *f = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(f, "--help") == 0 || strcmp(f, "-h") == 0) usage(NULL);
        if (!v) {
            char msg[160];
            snprintf(msg, sizeof msg, "%s needs a value", f);
            usage(msg);
        }
        ++i;
        if (strcmp(f, "--id") == 0) o->id = (uint32_t)parse_number(f, v, 1, 65535);
        else if (strcmp(f, "--listen") == 0) o->listen = v;
        else if (strcmp(f, "--peer") == 0) parse_peer(o, v);
        else if (strcmp(f, "--duration") == 0) o->duration = parse_number(f, v, 0, 1e7);
        else if (strcmp(f, "--cloth") == 0) o->cloth = (int)parse_number(f, v, 2, 256);
        else if (strcmp(f, "--spheres") == 0) o->spheres = (int)parse_number(f, v, 0, GS_SCENE_MAX_SPHERES);
        else if (strcmp(f, "--weight") == 0) parse_weight(o, v);
        else if (strcmp(f, "--integrator") == 0) o->integrator = parse_integrator(v);
        else if (strcmp(f, "--dt") == 0) o->dt = parse_number(f, v, 1e-5, 0.05);
        else if (strcmp(f, "--substeps") == 0) o->substeps = parse_count(f, v, 0, 64);
        else if (strcmp(f, "--probe-until") == 0) o->probe_until = parse_number(f, v, 0, 1e300);
        else if (strcmp(f, "--seed") == 0) o->seed = (uint32_t)parse_number(f, v, 0, 4294967295.0);
        else if (strcmp(f, "--encoding") == 0) {
            if (strcmp(v, "f64") == 0) o->encoding = GS_ENCODING_F64;
            else if (strcmp(v, "f32") == 0) o->encoding = GS_ENCODING_F32;
            else if (strcmp(v, "quant") == 0) o->encoding = GS_ENCODING_QUANT;
            else if (strcmp(v, "quant-delta") == 0) {
                o->encoding = GS_ENCODING_QUANT;
                o->delta = 1;
            }
            else usage("--encoding: f64, f32, quant or quant-delta");
        }
        else if (strcmp(f, "--resolution") == 0) o->resolution = parse_number(f, v, 1e-9, 1.0);
        else if (strcmp(f, "--rest-threshold") == 0)
            o->rest_threshold = parse_number(f, v, 0, 1.0);
        else if (strcmp(f, "--heartbeat-rate") == 0)
            o->heartbeat_rate = parse_number(f, v, 0.01, 1000.0);
        else if (strcmp(f, "--stats-every") == 0) o->stats_every = parse_number(f, v, 1e-3, 3600);
        else if (strcmp(f, "--trace") == 0) o->trace = v;
        else if (strcmp(f, "--clock-step") == 0) {
            static const double lo[] = {0, -1e6}, hi[] = {1e7, 1e6};
            double t[2];
            parse_tuple(f, v, 2, t, lo, hi);
            o->step_at = t[0];
            o->step = t[1];
        } else if (strcmp(f, "--probe-wild") == 0) {
            static const double lo[] = {0, 0, 0}, hi[] = {1e7, 1e7, 1e6};
            double t[3];
            parse_tuple(f, v, 3, t, lo, hi);
            o->wild_at = t[0];
            o->wild_for = t[1];
            o->wild_speed = t[2];
        }
        else if (strcmp(f, "--key") == 0) parse_key(o, v);
        else if (strcmp(f, "--sync") == 0) {
            if (strcmp(v, "present") == 0) o->replay = 0;
            else if (strcmp(v, "replay") == 0) o->replay = 1;
            else usage("--sync: present or replay");
        }
        else if (strcmp(f, "--clock") == 0) {
            if (strcmp(v, "local") == 0) o->session = 0;
            else if (strcmp(v, "session") == 0) o->session = 1;
            else usage("--clock: local or session");
        }
        else if (strcmp(f, "--frame-lock") == 0) {
            if (strcmp(v, "on") == 0) o->frame_lock = 1;
            else if (strcmp(v, "off") == 0) o->frame_lock = 0;
            else usage("--frame-lock: on or off");
        }
        else {
            char msg[160];
            snprintf(msg, sizeof msg, "unknown flag '%s'", f);
            usage(msg);
        }
    }
    if (o->id == 0) usage("--id is required");
    if (o->frame_lock && !o->session && !o->replay)
        usage("--frame-lock on needs the session clock (--clock session or --sync replay)");
    if (!o->listen) usage("--listen is required");
    for (k = 0; k < o->npeers; ++k)
        if (o->peers[k].id == o->id) usage("--peer: a peer has this host's own id");
}

/* ---- the scene ---- */

typedef struct peer_host {
    options o;
    gs_world *w;
    gs_scene sc;
    gs_net *net;         /* on UDP; it owns its gs_udp */
    double wall0, mono0;   /* clocks at the start */
    double cpu0;           /* process CPU seconds at the start (after the scene's settle) */
    double t_since;        /* wall time since the host shows "t" */
    double t_done;         /* wall time at the end of the advance to "t" */
    double show_at;        /* --frame-lock: the instant (CLOCK_MONOTONIC) the
                              frame being computed is shown at; 0 before the
                              first boundary is known */
    FILE *trace;
    uint64_t rx_seen[MAX_PEERS];
    int announced[MAX_PEERS];
} peer_host;

static double wall_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* CPU seconds of the whole process (every thread: the world's and UDP's). */
static double cpu_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int fail(peer_host *h, const char *what) {
    fprintf(stderr, "ghostpeer %u: %s: %s\n", (unsigned)h->o.id, what,
            h->w ? gs_world_error(h->w) : "out of memory");
    return 1;
}

/* The session's probes: one per host, as many as the largest id. */
static int probe_count(const options *o) {
    uint32_t top = o->id;
    int k;
    for (k = 0; k < o->npeers; ++k)
        if (o->peers[k].id > top) top = o->peers[k].id;
    return top > GS_SCENE_MAX_PROBES ? GS_SCENE_MAX_PROBES : (int)top;
}

/* --frame-lock: the session clock's reading for an advance is the instant
   its frame will be shown (the boundary gs_world_next_frame gave), so the
   world runs to that boundary however late the loop woke to compute it:
   with the clock read at the wake, a host woken over half a frame late
   rounded to the next boundary and skipped one, and the lead had to stay
   under half a frame. */
static double show_clock(void *user) {
    const peer_host *h = (const peer_host *)user;
    return h->show_at > 0.0 ? h->show_at : gs_udp_now();
}

static int build(peer_host *h) {
    const options *o = &h->o;
    gs_world_desc wd = gs_world_desc_default();
    gs_scene_desc sd = gs_scene_desc_default();
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_udp_desc ud;
    gs_net_desc nd = gs_net_desc_default();
    gs_udp *u;
    int i;
    wd.host_id = o->id;
    if (o->replay || o->session)
        wd.sync.clock = GS_SYNC_CLOCK_SESSION; /* reads CLOCK_MONOTONIC, as gs_udp does */
    if (o->replay) {
        wd.sync.mode = GS_SYNC_REPLAY;
        wd.sync.history_frames = 64; /* 5 ms frames: 320 ms, a 250 ms round trip and more */
    }
    if (o->frame_lock) {
        wd.sync.frame = FRAME;
        wd.sync.now = show_clock;
        wd.sync.now_user = h;
    }
    if (gs_world_create(&wd, &h->w) != GS_OK) return fail(h, "world");
    sd.cloth_n = o->cloth;
    sd.sphere_count = o->spheres ? o->spheres : GS_NONE;
    sd.probe_count = probe_count(o);
    sd.seed = o->seed;
    sd.cloth_integrator = o->integrator;
    sd.dt = o->dt;
    sd.cloth_substeps = o->substeps;
    if (gs_scene_create(h->w, &sd, &h->sc) != GS_OK) return fail(h, "scene");
    gd.weight = o->weight;
    gd.weight_user = o->weight == gs_weight_exp ? (void *)&h->o.exp_rate : NULL;
    gd.encoding = o->encoding;
    gd.position_resolution = o->resolution;
    gd.rest_threshold = o->rest_threshold;
    gd.delta = o->delta;
    gd.heartbeat_rate = o->heartbeat_rate;
    if (gs_scene_attach_ghosts(&h->sc, &gd) != GS_OK) return fail(h, "ghost");
    ud = gs_udp_desc_default(); /* its rcvbuf and the net's are what zero gave */
    ud.bind = o->listen;
    ud.threads = 1;
    nd.key = o->has_key ? o->key : NULL;
    u = NULL; /* the socket first, then the net on it, which then owns it */
    if (gs_udp_create(h->w, &ud, &u) != GS_OK || gs_udp_transport(u, &nd.transport) != GS_OK ||
        gs_net_create(h->w, &nd, &h->net) != GS_OK) {
        if (u) gs_udp_close(u);
        return fail(h, o->has_key ? "cannot listen with --key" : "cannot listen");
    }
    for (i = 0; i < o->npeers; ++i)
        if (gs_net_add_peer(h->net, o->peers[i].id, o->peers[i].addr) != GS_OK)
            return fail(h, "bad --peer address");
    return 0;
}

/* Host N's probe: its path until probe_until, then parked above where it
   stopped. */
static void drive_probe(peer_host *h, double t) {
    const gs_quat id = {0.0, 0.0, 0.0, 1.0};
    int i = (int)h->o.id - 1;
    gs_vec3 p;
    if (i >= h->sc.probe_count) return;
    if (h->o.wild_speed > 0.0 && t >= h->o.wild_at && t < h->o.wild_at + h->o.wild_for) {
        /* its circle (0.38 m round in 4 s) sped up to wild_speed m/s */
        double k = h->o.wild_speed / (2.0 * 3.14159265358979323846 * 0.38 / 4.0), s[14];
        double tau = h->o.wild_at + (t - h->o.wild_at) * k;
        gs_vec3 q = gs_scene_probe_path(i, tau + 1e-4 * k);
        p = gs_scene_probe_path(i, tau);
        if (gs_agent_get_state(h->sc.probes[i], s, 14) == GS_OK) {
            s[1] = p.x; s[2] = p.y; s[3] = p.z;
            s[4] = 0.0; s[5] = 0.0; s[6] = 0.0; s[7] = 1.0;
            s[8] = (q.x - p.x) / 1e-4; s[9] = (q.y - p.y) / 1e-4; s[10] = (q.z - p.z) / 1e-4;
            s[11] = 0.0; s[12] = 0.0; s[13] = 0.0;
            gs_agent_set_state(h->sc.probes[i], s, 14);
        }
    } else if (t < h->o.probe_until) {
        p = gs_scene_probe_path(i, t);
    } else {
        p = gs_scene_probe_path(i, h->o.probe_until);
        p.y = PARK_HEIGHT;
    }
    gs_probe_set_target(h->sc.probes[i], p, id);
}

/* ---- output ---- */

/* cloth centroid, cloth centre particle, each sphere's centre (m) */
static int digest(const peer_host *h, double *d) {
    const gs_vec3 *x = gs_mesh_positions(h->sc.cloth);
    int n = gs_mesh_particle_count(h->sc.cloth), side = h->sc.desc.cloth_n, i, k = 0;
    gs_vec3 c = {0.0, 0.0, 0.0}, m = x[(side / 2) * side + side / 2];
    for (i = 0; i < n; ++i) {
        c.x += x[i].x;
        c.y += x[i].y;
        c.z += x[i].z;
    }
    d[k++] = c.x / n; d[k++] = c.y / n; d[k++] = c.z / n;
    d[k++] = m.x; d[k++] = m.y; d[k++] = m.z;
    for (i = 0; i < h->sc.sphere_count; ++i) {
        gs_vec3 p = gs_rigid_position(h->sc.spheres[i]);
        d[k++] = p.x; d[k++] = p.y; d[k++] = p.z;
    }
    return k;
}

static double sim_time(const peer_host *h) { return gs_agent_time(h->sc.cloth); }

/* A string as a JSON string: quotes, backslashes and control characters
   escaped. */
static void print_json_string(const char *s) {
    putchar('"');
    for (; *s; ++s) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\') printf("\\%c", c);
        else if (c < 0x20) printf("\\u%04x", c);
        else putchar(c);
    }
    putchar('"');
}

static void print_line(peer_host *h, int final) {
    gs_net *net = h->net;
    double d[6 + 3 * GS_SCENE_MAX_SPHERES];
    int nd = digest(h, d), i;
    gs_unknown_stats unknown;
    uint64_t unknown_total = 0, rejected = 0, rx = 0, sent = 0;
    printf("{\"wall\": %.6f, \"host\": %u, \"t\": %.6f, \"digest\": [", wall_now(),
           (unsigned)h->o.id, sim_time(h));
    for (i = 0; i < nd; ++i) printf("%s%.9g", i ? ", " : "", d[i]);
    printf("], \"peers\": {");
    for (i = 0; i < h->o.npeers; ++i) {
        gs_peer_stats ps;
        memset(&ps, 0, sizeof ps);
        gs_net_peer_stats(net, h->o.peers[i].id, &ps);
        printf("%s\"%u\": {\"gap\": %.6f, \"div\": %.9g, \"rtt\": %.6f, \"rx\": %llu, "
               "\"lost\": %llu, \"rejected\": %llu, \"bytes_sent\": %llu, \"bytes_rx\": %llu, "
               "\"heartbeats_rx\": %llu, \"resting\": %d, \"heard\": %.3f",
               i ? ", " : "", (unsigned)h->o.peers[i].id,
               ps.snapshots_received ? ps.gap : 0.0, ps.divergence, ps.rtt,
               (unsigned long long)ps.snapshots_received, (unsigned long long)ps.lost,
               (unsigned long long)ps.rejected_total, (unsigned long long)ps.bytes_sent,
               (unsigned long long)ps.bytes_received, (unsigned long long)ps.heartbeats_received,
               ps.objects_resting,
               ps.datagrams_received ? gs_udp_now() - ps.last_heard : -1.0);
        /* keys added after "heard" (the JSON changes only by adding) */
        printf(", \"health\": \"%s\", \"reason\": ", gs_peer_health_str(ps.health));
        print_json_string(ps.reason);
        printf(", \"clock_back\": %llu}", (unsigned long long)ps.clock_backwards);
        rejected += ps.rejected_total;
        rx += ps.snapshots_received;
        sent += ps.snapshots_sent;
    }
    printf("}");
    {
        gs_sync_stats st;
        double wall = gs_udp_now() - h->mono0;
        memset(&st, 0, sizeof st);
        gs_world_sync_stats(h->w, &st);
        printf(", \"replay\": {\"mode\": \"%s\", \"replays\": %llu, \"steps_per_s\": %.1f, "
               "\"fallbacks\": %llu, \"lag\": %.6f, \"timekeeper\": %u, "
               "\"replays_skipped\": %llu, \"replays_near\": %llu, \"clock_steps\": %llu, "
               "\"joins\": %llu}",
               h->o.replay ? "replay" : "present", (unsigned long long)st.replays,
               wall > 0.0 ? (double)st.replay_steps / wall : 0.0,
               (unsigned long long)st.fallbacks, st.lag, (unsigned)st.timekeeper,
               (unsigned long long)st.replays_skipped, (unsigned long long)st.replays_near,
               (unsigned long long)st.clock_steps, (unsigned long long)st.joins);
    }
    printf(", \"frame_lock\": %s, \"t_since\": %.6f, \"t_done\": %.6f",
           h->o.frame_lock ? "true" : "false", h->t_since, h->t_done);
    printf(", \"cpu\": %.6f", cpu_now() - h->cpu0);
    if (final) {
        if (gs_net_unknown_stats(net, &unknown) == GS_OK) unknown_total = unknown.rejected_total;
        printf(", \"final\": true, \"totals\": {\"wall_seconds\": %.3f, \"snapshots_sent\": %llu, "
               "\"snapshots_received\": %llu, \"rejected\": %llu, \"rejected_unknown\": %llu}",
               gs_udp_now() - h->mono0, (unsigned long long)sent, (unsigned long long)rx,
               (unsigned long long)rejected, (unsigned long long)unknown_total);
    }
    printf("}\n");
    fflush(stdout);
}

static void trace_row(peer_host *h) {
    double d[6 + 3 * GS_SCENE_MAX_SPHERES];
    int nd = digest(h, d), i;
    fprintf(h->trace, "%.6f,%.6f", wall_now(), sim_time(h));
    for (i = 0; i < nd; ++i) fprintf(h->trace, ",%.9g", d[i]);
    fputc('\n', h->trace);
}

static void trace_header(peer_host *h) {
    int i;
    fprintf(h->trace, "wall,t,centroid_x,centroid_y,centroid_z,centre_x,centre_y,centre_z");
    for (i = 0; i < h->sc.sphere_count; ++i)
        fprintf(h->trace, ",sphere%d_x,sphere%d_y,sphere%d_z", i, i, i);
    fputc('\n', h->trace);
}

/* Says once on stderr when a peer is first heard, and when one has not been
   heard 2 s into the run (it may not be up yet: we keep simulating). */
static void watch_peers(peer_host *h, double elapsed) {
    int i;
    for (i = 0; i < h->o.npeers; ++i) {
        gs_peer_stats ps;
        if (gs_net_peer_stats(h->net, h->o.peers[i].id, &ps) != GS_OK) continue;
        if (ps.snapshots_received > 0 && h->announced[i] != 2) {
            fprintf(stderr, "ghostpeer %u: peer %u at %s is up\n", (unsigned)h->o.id,
                    (unsigned)h->o.peers[i].id, h->o.peers[i].addr);
            h->announced[i] = 2;
        } else if (ps.snapshots_received == 0 && elapsed > 2.0 && h->announced[i] == 0) {
            fprintf(stderr, "ghostpeer %u: nothing from peer %u at %s yet; simulating alone\n",
                    (unsigned)h->o.id, (unsigned)h->o.peers[i].id, h->o.peers[i].addr);
            h->announced[i] = 1;
        }
    }
}

static void nap(double seconds) {
    struct timespec ts;
    if (seconds <= 0.0) return;
    ts.tv_sec = (time_t)seconds;
    ts.tv_nsec = (long)((seconds - (double)ts.tv_sec) * 1e9);
    nanosleep(&ts, NULL);
}

/* Until `at` on CLOCK_MONOTONIC (gs_udp_now): an absolute wake, so the time
   the loop spent since it read the clock does not shift the phase. */
static void nap_until(double at) {
    struct timespec ts;
    if (!(at > gs_udp_now())) return;
    ts.tv_sec = (time_t)at;
    ts.tv_nsec = (long)((at - (double)ts.tv_sec) * 1e9);
    if (ts.tv_nsec >= 1000000000L) ts.tv_nsec = 999999999L;
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL);
}

/* At wall-clock pace until the duration or a signal. */
static int run(peer_host *h) {
    double last = gs_udp_now(), next_stats = last, next_trace = last, skew = 0.0, at = 0.0;
    int stepped = h->o.step == 0.0;
    h->mono0 = last;
    h->cpu0 = cpu_now();
    while (!g_stop) {
        double now = gs_udp_now(), elapsed = now - h->mono0, pnow;
        gs_result r;
        if (h->o.duration > 0.0 && elapsed >= h->o.duration) break;
        if (!stepped && elapsed >= h->o.step_at) { /* --clock-step */
            skew = h->o.step;
            stepped = 1;
            fprintf(stderr, "ghostpeer %u: pacing clock stepped by %+g s at %.3f s\n",
                    (unsigned)h->o.id, skew, elapsed);
        }
        pnow = now + skew; /* the clock the world is paced with */
        drive_probe(h, sim_time(h));
        r = gs_world_advance(h->w, pnow - last, NULL);
        h->t_done = wall_now();
        if (r != GS_OK && r != GS_ERR_UNSTABLE)
            fprintf(stderr, "ghostpeer %u: %s\n", (unsigned)h->o.id, gs_world_error(h->w));
        last = pnow;
        if (h->o.frame_lock && at > 0.0) nap_until(at); /* shown at its boundary */
        h->t_since = wall_now();
        gs_net_poll(h->net, h->o.frame_lock ? gs_udp_now() + skew : pnow); /* wakes the scatter thread */
        if (now >= next_stats) {
            print_line(h, 0);
            watch_peers(h, elapsed);
            next_stats += h->o.stats_every;
            if (next_stats < now) next_stats = now + h->o.stats_every;
        }
        if (h->trace && now >= next_trace) {
            trace_row(h);
            next_trace += TRACE_EVERY;
            if (next_trace < now) next_trace = now + TRACE_EVERY;
        }
        if (h->o.frame_lock && gs_world_next_frame(h->w, gs_udp_now(), &at) == GS_OK) {
            h->show_at = at;
            nap_until(at - LEAD); /* computed ahead of the session's next boundary */
        }
        else
            nap(FRAME - (gs_udp_now() - now));
    }
    print_line(h, 1);
    return 0;
}

int main(int argc, char **argv) {
    peer_host h;
    struct sigaction sa;
    int rc;
    memset(&h, 0, sizeof h);
    parse_args(argc, argv, &h.o);
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    signal(SIGPIPE, SIG_IGN);
    rc = build(&h);
    if (rc == 0 && h.o.trace) {
        h.trace = fopen(h.o.trace, "w");
        if (!h.trace) {
            fprintf(stderr, "ghostpeer %u: cannot write %s: %s\n", (unsigned)h.o.id, h.o.trace,
                    strerror(errno));
            rc = 1;
        } else {
            trace_header(&h);
        }
    }
    if (rc == 0) {
        fprintf(stderr, "ghostpeer %u: listening on %s, %d peer(s), %d sphere(s), %d probe(s)%s, "
                "sync %s on the %s clock\n",
                (unsigned)h.o.id, h.o.listen, h.o.npeers, h.sc.sphere_count, h.sc.probe_count,
                h.o.has_key ? ", datagrams sealed (--key)" : "", h.o.replay ? "replay" : "present",
                h.o.replay || h.o.session ? "session" : "local");
        rc = run(&h);
    }
    if (h.trace) fclose(h.trace);
    gs_world_destroy(h.w); /* its net too, which stops the UDP threads */
    memset(h.o.key, 0, sizeof h.o.key);
    return rc;
}
