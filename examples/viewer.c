/* viewer: a live window on one peer of the paper's scene, over real UDP.
   It is a full peer, like reference_peer/ghostpeer: it builds the scene
   (a cloth hanging by its four corners, spheres falling on it, one probe
   box per host), wraps every object in a ghost, opens POSIX UDP with the
   gather and scatter threads and keeps wall-clock pace. The mouse moves
   this host's probe (green); the other hosts' probes are purple.

     viewer --id 1 --listen 127.0.0.1:47500 --peer 2@127.0.0.1:47501
     viewer --id 2 --listen 127.0.0.1:47501 --peer 1@127.0.0.1:47500

   Mouse: the probe follows the pointer across the floor plane at its
   height; the wheel raises and lowers it; hold the left button to press it
   into the cloth. Until the mouse moves (and after P), the probe follows
   the scripted path the tests use. Esc or closing the window quits.

   Headless (no window, no SDL video): runs for --duration seconds, then
   draws the scene with a small software rasterizer (the one the window
   shows) and writes a PNG with its own encoder (stored deflate, no zlib):
     viewer --headless --out scene.png --id 1 --listen 127.0.0.1:47500 ...
   --frames N writes N pictures scene-000.png... evenly over the duration.

   Build: cc -std=c99 -D_POSIX_C_SOURCE=200809L -I. examples/viewer.c
          -o build/viewer $(pkg-config --cflags --libs sdl2) -lccd -lm -lpthread */
#define GHOSTSIM_IMPLEMENTATION
#include "ghostsim.h"

#define SDL_MAIN_HANDLED
#include <SDL.h>

#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define VW_MAX_PEERS GS_SCENE_MAX_PROBES
#define VW_PI 3.14159265358979323846

/* ------------------------------------------------------------------------
   Command line
   ------------------------------------------------------------------------ */
typedef struct vw_options {
    uint32_t id;
    const char *listen;
    int peer_count;
    uint32_t peer_id[VW_MAX_PEERS];
    const char *peer_addr[VW_MAX_PEERS];
    double duration;     /* s; window: 0 = until closed; headless: 2 */
    int duration_set;
    int cloth_n, spheres, probes;
    double dt;           /* s */
    uint32_t seed;
    int headless;
    const char *out;
    int frames;          /* headless: 0 = one picture at the end */
    int width, height;   /* pixels */
    int replay;          /* --sync replay: the session's mode, as ghostpeer's */
} vw_options;

static void usage(FILE *f, const char *argv0) {
    fprintf(f,
            "usage: %s --id N --listen HOST:PORT [--peer ID@HOST:PORT]...\n"
            "          [--duration S] [--cloth N] [--spheres K] [--dt S] [--seed N]\n"
            "          [--probes N] [--size WxH] [--sync present|replay]\n"
            "          [--headless --out FILE.png [--frames N]]\n"
            "  --id N          this host, 1..%d (it owns probe N-1)\n"
            "  --listen        UDP address to bind, HOST:PORT or [V6]:PORT\n"
            "  --peer          another host and its address (repeatable)\n"
            "  --duration S    seconds to run (window: 0 = until closed; headless: 2)\n"
            "  --cloth N       cloth particles per side, 2..256 (default 16)\n"
            "  --spheres K     spheres, 0..%d (default 3)\n"
            "  --dt S          step of every agent in seconds (default 0.002)\n"
            "  --seed N        sphere placement (default 1)\n"
            "  --probes N      probes in the scene (default the largest host id)\n"
            "  --size WxH      picture size in pixels (default 800x600)\n"
            "  --sync MODE     present (default) or replay: the session's mode, as\n"
            "                  ghostpeer's --sync (a host in another mode breaks it)\n"
            "  --headless      no window: write PNG pictures instead\n"
            "  --out FILE.png  headless output; --frames N writes FILE-000.png...\n",
            argv0, GS_SCENE_MAX_PROBES, GS_SCENE_MAX_SPHERES);
}

static int parse_long(const char *s, long lo, long hi, long *out) {
    char *end;
    long v;
    if (!s || !*s) return 0;
    errno = 0;
    v = strtol(s, &end, 10);
    if (errno || *end || v < lo || v > hi) return 0;
    *out = v;
    return 1;
}

static int parse_double(const char *s, double lo, double hi, double *out) {
    char *end;
    double v;
    if (!s || !*s) return 0;
    errno = 0;
    v = strtod(s, &end);
    if (errno || *end || !(v >= lo && v <= hi)) return 0;
    *out = v;
    return 1;
}

/* "ID@HOST:PORT" */
static int parse_peer(const char *s, vw_options *o) {
    const char *at = strchr(s, '@');
    char id[16];
    long v;
    if (!at || at == s || (size_t)(at - s) >= sizeof id || !at[1]) return 0;
    if (o->peer_count >= VW_MAX_PEERS) return 0;
    memcpy(id, s, (size_t)(at - s));
    id[at - s] = '\0';
    if (!parse_long(id, 1, GS_SCENE_MAX_PROBES, &v)) return 0;
    o->peer_id[o->peer_count] = (uint32_t)v;
    o->peer_addr[o->peer_count] = at + 1;
    o->peer_count++;
    return 1;
}

static int parse_size(const char *s, vw_options *o) {
    long w, h;
    char buf[32];
    char *x;
    if (strlen(s) >= sizeof buf) return 0;
    strcpy(buf, s);
    x = strchr(buf, 'x');
    if (!x) return 0;
    *x = '\0';
    if (!parse_long(buf, 64, 4096, &w) || !parse_long(x + 1, 64, 4096, &h)) return 0;
    o->width = (int)w;
    o->height = (int)h;
    return 1;
}

/* One flag and its value; returns 0 for a bad flag or value. */
static int parse_flag(const char *f, const char *v, vw_options *o, int *used) {
    long n;
    *used = 1;
    if (!strcmp(f, "--headless")) { o->headless = 1; *used = 0; return 1; }
    if (!v) return 0;
    if (!strcmp(f, "--id")) {
        if (!parse_long(v, 1, GS_SCENE_MAX_PROBES, &n)) return 0;
        o->id = (uint32_t)n;
    } else if (!strcmp(f, "--listen")) {
        o->listen = v;
    } else if (!strcmp(f, "--peer")) {
        return parse_peer(v, o);
    } else if (!strcmp(f, "--duration")) {
        o->duration_set = 1;
        return parse_double(v, 0.0, 1e7, &o->duration);
    } else if (!strcmp(f, "--cloth")) {
        if (!parse_long(v, 2, 256, &n)) return 0;
        o->cloth_n = (int)n;
    } else if (!strcmp(f, "--spheres")) {
        if (!parse_long(v, 0, GS_SCENE_MAX_SPHERES, &n)) return 0;
        o->spheres = (int)n;
    } else if (!strcmp(f, "--probes")) {
        if (!parse_long(v, 1, GS_SCENE_MAX_PROBES, &n)) return 0;
        o->probes = (int)n;
    } else if (!strcmp(f, "--dt")) {
        return parse_double(v, 1e-6, 0.1, &o->dt);
    } else if (!strcmp(f, "--seed")) {
        if (!parse_long(v, 1, 2147483647L, &n)) return 0;
        o->seed = (uint32_t)n;
    } else if (!strcmp(f, "--out")) {
        o->out = v;
    } else if (!strcmp(f, "--frames")) {
        if (!parse_long(v, 1, 100000, &n)) return 0;
        o->frames = (int)n;
    } else if (!strcmp(f, "--size")) {
        return parse_size(v, o);
    } else if (!strcmp(f, "--sync")) {
        if (!strcmp(v, "replay")) o->replay = 1;
        else if (!strcmp(v, "present")) o->replay = 0;
        else return 0;
    } else {
        return 0;
    }
    return 1;
}

/* The probes every host builds: enough that every host in the session owns
   one. Hosts of one session must agree on it (--probes, else the largest
   id each knows: the same when every host lists every other). */
static void finish_options(vw_options *o) {
    int i, most = (int)o->id;
    for (i = 0; i < o->peer_count; ++i)
        if ((int)o->peer_id[i] > most) most = (int)o->peer_id[i];
    if (o->probes < most) o->probes = most;
    if (!o->duration_set) o->duration = o->headless ? 2.0 : 0.0;
}

/* Returns 0, 1 for --help, or -1 after printing what is wrong. */
static int parse_options(int argc, char **argv, vw_options *o) {
    int i, j, used;
    gs_scene_desc sd = gs_scene_desc_default();
    memset(o, 0, sizeof *o);
    o->cloth_n = sd.cloth_n;
    o->spheres = sd.sphere_count;
    o->dt = sd.dt;
    o->seed = sd.seed;
    o->width = 800;
    o->height = 600;
    for (i = 1; i < argc; i += 1 + used) {
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) return 1;
        if (!parse_flag(argv[i], i + 1 < argc ? argv[i + 1] : NULL, o, &used)) {
            fprintf(stderr, "viewer: bad flag or value: %s%s%s\n", argv[i],
                    i + 1 < argc ? " " : "", i + 1 < argc ? argv[i + 1] : "");
            return -1;
        }
    }
    if (!o->id || !o->listen) {
        fprintf(stderr, "viewer: --id and --listen are required\n");
        return -1;
    }
    for (i = 0; i < o->peer_count; ++i) {
        int dup = o->peer_id[i] == o->id;
        for (j = 0; j < i; ++j) dup |= o->peer_id[j] == o->peer_id[i];
        if (dup) {
            fprintf(stderr, "viewer: peer id %u repeats this host or another peer\n",
                    (unsigned)o->peer_id[i]);
            return -1;
        }
    }
    if (o->headless != (o->out != NULL) || (o->frames && !o->headless)) {
        fprintf(stderr, "viewer: --headless needs --out, and --out/--frames need --headless\n");
        return -1;
    }
    finish_options(o);
    return 0;
}

/* ------------------------------------------------------------------------
   Camera: fixed perspective, from above and in front, looking at the cloth
   ------------------------------------------------------------------------ */
typedef struct vw_camera {
    gs_vec3 eye, fwd, right, up;
    double focal, cx, cy; /* pixels */
} vw_camera;

static gs_vec3 v3(double x, double y, double z) {
    gs_vec3 v;
    v.x = x; v.y = y; v.z = z;
    return v;
}
static gs_vec3 v3_sub(gs_vec3 a, gs_vec3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static double v3_dot(gs_vec3 a, gs_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static gs_vec3 v3_cross(gs_vec3 a, gs_vec3 b) {
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static gs_vec3 v3_norm(gs_vec3 a) {
    double l = sqrt(v3_dot(a, a));
    return l > 0.0 ? v3(a.x / l, a.y / l, a.z / l) : a;
}

static vw_camera camera_make(int w, int h) {
    vw_camera c;
    gs_vec3 look = v3(0.0, -0.15, 0.0);
    c.eye = v3(0.0, 1.0, 1.4);
    c.fwd = v3_norm(v3_sub(look, c.eye));
    c.right = v3_norm(v3_cross(c.fwd, v3(0.0, 1.0, 0.0)));
    c.up = v3_cross(c.right, c.fwd);
    c.focal = 0.5 * h / tan(0.5 * 50.0 * VW_PI / 180.0); /* 50 degrees tall */
    c.cx = 0.5 * w;
    c.cy = 0.5 * h;
    return c;
}

/* Screen x, y in pixels and depth z in metres; 0 behind the camera. */
typedef struct vw_point { double x, y, z; } vw_point;

static int project(const vw_camera *c, gs_vec3 p, vw_point *out) {
    gs_vec3 d = v3_sub(p, c->eye);
    double z = v3_dot(d, c->fwd);
    if (z < 0.05) return 0;
    out->x = c->cx + c->focal * v3_dot(d, c->right) / z;
    out->y = c->cy - c->focal * v3_dot(d, c->up) / z;
    out->z = z;
    return 1;
}

/* Where the ray through pixel (sx, sy) meets the plane y = height. */
static int unproject_to_height(const vw_camera *c, double sx, double sy, double height,
                               gs_vec3 *out) {
    double a = (sx - c->cx) / c->focal, b = (c->cy - sy) / c->focal, s;
    gs_vec3 d = v3(c->fwd.x + a * c->right.x + b * c->up.x,
                   c->fwd.y + a * c->right.y + b * c->up.y,
                   c->fwd.z + a * c->right.z + b * c->up.z);
    if (d.y > -1e-6) return 0; /* the plane is behind the ray */
    s = (height - c->eye.y) / d.y;
    *out = v3(c->eye.x + s * d.x, height, c->eye.z + s * d.z);
    return 1;
}

/* ------------------------------------------------------------------------
   Software rasterizer: RGB buffer with a depth buffer
   ------------------------------------------------------------------------ */
typedef struct vw_canvas {
    int w, h;
    unsigned char *rgb; /* w * h * 3 */
    float *depth;       /* w * h, metres from the eye */
} vw_canvas;

typedef struct vw_rgb { unsigned char r, g, b; } vw_rgb;

static vw_rgb rgb(int r, int g, int b) {
    vw_rgb c;
    c.r = (unsigned char)(r < 0 ? 0 : r > 255 ? 255 : r);
    c.g = (unsigned char)(g < 0 ? 0 : g > 255 ? 255 : g);
    c.b = (unsigned char)(b < 0 ? 0 : b > 255 ? 255 : b);
    return c;
}
static vw_rgb shade(vw_rgb c, double k) {
    return rgb((int)(c.r * k + 0.5), (int)(c.g * k + 0.5), (int)(c.b * k + 0.5));
}

/* The paper's colours: the local probe green, remote probes purple. */
#define VW_LOCAL_PROBE rgb(40, 200, 60)
#define VW_REMOTE_PROBE rgb(150, 60, 200)
#define VW_CLOTH rgb(225, 200, 150)
#define VW_SPHERE rgb(220, 80, 50)
#define VW_GROUND rgb(150, 155, 165)

static int canvas_init(vw_canvas *c, int w, int h) {
    c->w = w;
    c->h = h;
    c->rgb = (unsigned char *)malloc((size_t)w * (size_t)h * 3);
    c->depth = (float *)malloc((size_t)w * (size_t)h * sizeof(float));
    return c->rgb && c->depth;
}

static void canvas_free(vw_canvas *c) {
    free(c->rgb);
    free(c->depth);
    c->rgb = NULL;
    c->depth = NULL;
}

static void canvas_clear(vw_canvas *c) {
    int x, y;
    for (y = 0; y < c->h; ++y) { /* a sky-to-floor gradient */
        double k = (double)y / c->h;
        vw_rgb col = rgb((int)(235 - 90 * k), (int)(240 - 85 * k), (int)(250 - 70 * k));
        unsigned char *p = c->rgb + (size_t)y * c->w * 3;
        for (x = 0; x < c->w; ++x) {
            p[3 * x] = col.r;
            p[3 * x + 1] = col.g;
            p[3 * x + 2] = col.b;
        }
    }
    for (x = 0; x < c->w * c->h; ++x) c->depth[x] = 1e30f;
}

static void plot(vw_canvas *c, int x, int y, double z, vw_rgb col) {
    size_t i;
    if (x < 0 || y < 0 || x >= c->w || y >= c->h) return;
    i = (size_t)y * c->w + x;
    if (z >= c->depth[i]) return;
    c->depth[i] = (float)z;
    c->rgb[3 * i] = col.r;
    c->rgb[3 * i + 1] = col.g;
    c->rgb[3 * i + 2] = col.b;
}

/* A depth-tested line; bias pulls it towards the eye (edges over faces). */
static void draw_line(vw_canvas *c, vw_point a, vw_point b, double bias, vw_rgb col) {
    double dx = b.x - a.x, dy = b.y - a.y;
    double n = fabs(dx) > fabs(dy) ? fabs(dx) : fabs(dy);
    int i, steps;
    if (!(n < 1e5)) return; /* off in the distance, or not finite */
    steps = (int)ceil(n);
    if (steps < 1) steps = 1;
    for (i = 0; i <= steps; ++i) {
        double s = (double)i / steps;
        plot(c, (int)floor(a.x + s * dx + 0.5), (int)floor(a.y + s * dy + 0.5),
             a.z + s * (b.z - a.z) - bias, col);
    }
}

static double edge(vw_point a, vw_point b, double x, double y) {
    return (b.x - a.x) * (y - a.y) - (b.y - a.y) * (x - a.x);
}

static void draw_triangle(vw_canvas *c, vw_point a, vw_point b, vw_point p, vw_rgb col) {
    double area = edge(a, b, p.x, p.y);
    double lx = fmin(a.x, fmin(b.x, p.x)), hx = fmax(a.x, fmax(b.x, p.x));
    double ly = fmin(a.y, fmin(b.y, p.y)), hy = fmax(a.y, fmax(b.y, p.y));
    int x, y, x0, x1, y0, y1;
    if (fabs(area) < 1e-9 || hx < 0 || hy < 0 || lx >= c->w || ly >= c->h) return;
    x0 = lx < 0 ? 0 : (int)lx;
    y0 = ly < 0 ? 0 : (int)ly;
    x1 = hx >= c->w ? c->w - 1 : (int)hx;
    y1 = hy >= c->h ? c->h - 1 : (int)hy;
    for (y = y0; y <= y1; ++y) {
        for (x = x0; x <= x1; ++x) {
            double px = x + 0.5, py = y + 0.5;
            double wa = edge(b, p, px, py) / area, wb = edge(p, a, px, py) / area;
            double wp = 1.0 - wa - wb;
            if (wa < 0 || wb < 0 || wp < 0) continue;
            plot(c, x, y, wa * a.z + wb * b.z + wp * p.z, col);
        }
    }
}

/* A shaded ball: screen centre, radius in pixels, world radius for depth. */
static void draw_ball(vw_canvas *c, vw_point ctr, double rpx, double rw, vw_rgb col) {
    int x, y;
    if (!(rpx > 0.5 && rpx < 4096)) rpx = 0.5;
    for (y = (int)floor(ctr.y - rpx); y <= (int)ceil(ctr.y + rpx); ++y) {
        for (x = (int)floor(ctr.x - rpx); x <= (int)ceil(ctr.x + rpx); ++x) {
            double u = (x + 0.5 - ctr.x) / rpx, v = (y + 0.5 - ctr.y) / rpx;
            double d2 = u * u + v * v, nz, lit;
            if (d2 > 1.0) continue;
            nz = sqrt(1.0 - d2);
            lit = 0.35 + 0.65 * fmax(0.0, -0.4 * u - 0.5 * v + 0.77 * nz);
            plot(c, x, y, ctr.z - nz * rw, d2 > 0.86 ? shade(col, 0.45) : shade(col, lit));
        }
    }
}

/* A filled square with a dark rim (probes). */
static void draw_square(vw_canvas *c, vw_point ctr, double half, double z, vw_rgb col) {
    int x, y, x0 = (int)floor(ctr.x - half), x1 = (int)ceil(ctr.x + half);
    int y0 = (int)floor(ctr.y - half), y1 = (int)ceil(ctr.y + half);
    if (!(half < 4096)) return;
    for (y = y0; y <= y1; ++y)
        for (x = x0; x <= x1; ++x) {
            int rim = x - x0 < 2 || x1 - x < 2 || y - y0 < 2 || y1 - y < 2;
            plot(c, x, y, z, rim ? shade(col, 0.5) : col);
        }
}

/* ------------------------------------------------------------------------
   The peer: world, scene, ghosts, UDP
   ------------------------------------------------------------------------ */
typedef struct vw_peer {
    gs_world *world;
    gs_scene scene;
    gs_net *net;         /* on UDP; it owns its gs_udp */
    double *state;       /* the largest render state of any agent */
    vw_point *cloth_px;  /* the cloth's particles on screen */
    int *cloth_ok;       /* 1 where the particle is in front of the eye */
    int local;           /* index of this host's probe */
    int warned;          /* an advance error was reported already */
} vw_peer;

static int peer_buffers(vw_peer *p) {
    size_t most = 0;
    int i, n = gs_mesh_particle_count(p->scene.cloth);
    for (i = 0; i < gs_world_agent_count(p->world); ++i) {
        size_t s = gs_agent_state_size(gs_world_agent(p->world, i));
        if (s > most) most = s;
    }
    p->state = (double *)malloc(most * sizeof(double));
    p->cloth_px = (vw_point *)malloc((size_t)n * sizeof(vw_point));
    p->cloth_ok = (int *)malloc((size_t)n * sizeof(int));
    return p->state && p->cloth_px && p->cloth_ok;
}

static void peer_close(vw_peer *p) {
    gs_world_destroy(p->world); /* its net too, which stops the UDP threads */
    free(p->state);
    free(p->cloth_px);
    free(p->cloth_ok);
    memset(p, 0, sizeof *p);
}

/* Returns 0, or the exit status: 1 (the system refused, e.g. the port is in
   use), 2 (a bad address on the command line). */
static int peer_open_udp(vw_peer *p, const vw_options *o) {
    gs_udp_desc ud = gs_udp_desc_default();
    gs_net_desc nd = gs_net_desc_default();
    gs_udp *u = NULL;
    gs_result r;
    int i;
    ud.bind = o->listen;
    ud.threads = 1;
    r = gs_udp_create(p->world, &ud, &u); /* the socket, then its net */
    if (r == GS_OK) r = gs_udp_transport(u, &nd.transport);
    if (r == GS_OK) r = gs_net_create(p->world, &nd, &p->net);
    if (r != GS_OK) {
        if (u && !p->net) gs_udp_close(u);
        fprintf(stderr, "viewer: cannot listen on %s: %s\n", o->listen, gs_world_error(p->world));
        if (r == GS_ERR_SYSTEM && strstr(gs_world_error(p->world), "in use"))
            fprintf(stderr, "viewer: another program holds that port; pick another --listen\n");
        return r == GS_ERR_INVALID_ARG ? 2 : 1;
    }
    for (i = 0; i < o->peer_count; ++i) {
        r = gs_net_add_peer(p->net, o->peer_id[i], o->peer_addr[i]);
        if (r != GS_OK) {
            fprintf(stderr, "viewer: peer %u at %s: %s\n", (unsigned)o->peer_id[i],
                    o->peer_addr[i], gs_world_error(p->world));
            return r == GS_ERR_INVALID_ARG ? 2 : 1;
        }
    }
    return 0;
}

/* Returns 0 or the exit status; on failure everything is released. */
static int peer_open(vw_peer *p, const vw_options *o) {
    gs_world_desc wd = gs_world_desc_default();
    gs_scene_desc sd = gs_scene_desc_default();
    gs_ghost_desc gd = gs_ghost_desc_default();
    int status;
    memset(p, 0, sizeof *p);
    wd.host_id = o->id;
    wd.budget = 0.05; /* s per advance: the window stays live if we lag */
    if (o->replay) {
        /* Every host of a session runs one mode: a present host's snapshots
           stand on its own local timeline, seconds off the session's, and
           its probe then pushes each replaying host's cloth differently
           (three ghostpeers in replay were 15 cm apart 2.5 s after such a
           host left, micrometres after a replaying one did). */
        wd.sync.clock = GS_SYNC_CLOCK_SESSION;
        wd.sync.mode = GS_SYNC_REPLAY;
    }
    if (gs_world_create(&wd, &p->world) != GS_OK) {
        fprintf(stderr, "viewer: cannot create the world\n");
        return 1;
    }
    sd.cloth_n = o->cloth_n;
    sd.sphere_count = o->spheres ? o->spheres : GS_NONE;
    sd.probe_count = o->probes ? o->probes : GS_NONE;
    sd.dt = o->dt;
    sd.seed = o->seed;
    p->local = (int)o->id - 1;
    gd.weight = gs_weight_cs; /* as ghostpeer: the lowest id in step leads */
    if (gs_scene_create(p->world, &sd, &p->scene) != GS_OK ||
        gs_scene_attach_ghosts(&p->scene, &gd) != GS_OK) {
        fprintf(stderr, "viewer: %s\n", gs_world_error(p->world));
        peer_close(p);
        return 1;
    }
    if (!peer_buffers(p)) {
        fprintf(stderr, "viewer: out of memory\n");
        peer_close(p);
        return 1;
    }
    status = peer_open_udp(p, o);
    if (status) peer_close(p);
    return status;
}

/* Runs the world on by `seconds` of wall time. */
static void peer_advance(vw_peer *p, double seconds, double now) {
    gs_result r;
    if (seconds < 0.0) seconds = 0.0;
    r = gs_world_advance(p->world, seconds, NULL);
    if (r != GS_OK && !p->warned) {
        fprintf(stderr, "viewer: advance: %s (%s); going on\n", gs_result_str(r),
                gs_world_error(p->world));
        p->warned = 1;
    }
    gs_net_poll(p->net, now); /* thread mode: wakes the scatter thread, sends */
}

static void set_probe(vw_peer *p, gs_vec3 target) {
    gs_quat q = {0.0, 0.0, 0.0, 1.0};
    gs_probe_set_target(p->scene.probes[p->local], target, q);
}

/* The pose to draw: the ghost's smoothed render state, else the physics. */
static gs_vec3 body_position(vw_peer *p, gs_agent *a) {
    if (gs_ghost_render_state(a, p->state, gs_agent_state_size(a)) == GS_OK)
        return v3(p->state[1], p->state[2], p->state[3]);
    return gs_rigid_position(a);
}

/* ------------------------------------------------------------------------
   Drawing the scene
   ------------------------------------------------------------------------ */
static void draw_ground(vw_canvas *c, const vw_camera *cam) {
    const double y = -1.5, e = 2.0;
    int i;
    for (i = 0; i <= 16; ++i) {
        double s = -e + 2.0 * e * i / 16;
        vw_point a, b;
        if (project(cam, v3(s, y, -e), &a) && project(cam, v3(s, y, e), &b))
            draw_line(c, a, b, 0.0, VW_GROUND);
        if (project(cam, v3(-e, y, s), &a) && project(cam, v3(e, y, s), &b))
            draw_line(c, a, b, 0.0, VW_GROUND);
    }
}

/* One cloth quad as two lit triangles (lit from both sides). */
static void draw_cloth_quad(vw_canvas *c, const vw_point *px, const double *pos, int i00,
                            int i10, int i01, int i11) {
    const int tri[2][3] = {{i00, i10, i11}, {i00, i11, i01}};
    const gs_vec3 light = v3_norm(v3(0.3, 1.0, 0.6));
    int t;
    for (t = 0; t < 2; ++t) {
        const double *a = pos + 3 * tri[t][0], *b = pos + 3 * tri[t][1], *d = pos + 3 * tri[t][2];
        gs_vec3 n = v3_norm(v3_cross(v3(b[0] - a[0], b[1] - a[1], b[2] - a[2]),
                                     v3(d[0] - a[0], d[1] - a[1], d[2] - a[2])));
        double lit = 0.4 + 0.6 * fabs(v3_dot(n, light));
        draw_triangle(c, px[tri[t][0]], px[tri[t][1]], px[tri[t][2]], shade(VW_CLOTH, lit));
    }
}

static void draw_cloth(vw_canvas *c, const vw_camera *cam, vw_peer *p) {
    gs_agent *cl = p->scene.cloth;
    int n = p->scene.desc.cloth_n, count = gs_mesh_particle_count(cl), i, j;
    const double *pos;
    vw_rgb wire = shade(VW_CLOTH, 0.55);
    if (gs_ghost_render_state(cl, p->state, gs_agent_state_size(cl)) != GS_OK)
        memcpy(p->state + 1, gs_mesh_positions(cl), (size_t)count * sizeof(gs_vec3));
    pos = p->state + 1; /* [t, x0, y0, z0, ...] */
    for (i = 0; i < count; ++i)
        p->cloth_ok[i] = project(cam, v3(pos[3 * i], pos[3 * i + 1], pos[3 * i + 2]),
                                 &p->cloth_px[i]);
    for (j = 0; j + 1 < n; ++j)
        for (i = 0; i + 1 < n; ++i) {
            int a = i + n * j, b = a + 1, d = a + n, e = d + 1;
            if (p->cloth_ok[a] && p->cloth_ok[b] && p->cloth_ok[d] && p->cloth_ok[e])
                draw_cloth_quad(c, p->cloth_px, pos, a, b, d, e);
        }
    for (j = 0; j < n; ++j) /* the structural springs on top */
        for (i = 0; i < n; ++i) {
            int a = i + n * j;
            if (i + 1 < n && p->cloth_ok[a] && p->cloth_ok[a + 1])
                draw_line(c, p->cloth_px[a], p->cloth_px[a + 1], 0.004, wire);
            if (j + 1 < n && p->cloth_ok[a] && p->cloth_ok[a + n])
                draw_line(c, p->cloth_px[a], p->cloth_px[a + n], 0.004, wire);
        }
}

static void draw_bodies(vw_canvas *c, const vw_camera *cam, vw_peer *p) {
    const gs_scene *sc = &p->scene;
    double r = sc->desc.sphere_radius;
    int i;
    vw_point q;
    for (i = 0; i < sc->sphere_count; ++i)
        if (project(cam, body_position(p, sc->spheres[i]), &q))
            draw_ball(c, q, cam->focal * r / q.z, r, VW_SPHERE);
    for (i = 0; i < sc->probe_count; ++i) /* the scene's probes: 5 cm half-size boxes */
        if (project(cam, body_position(p, sc->probes[i]), &q))
            draw_square(c, q, cam->focal * 0.05 / q.z, q.z - 0.05,
                        i == p->local ? VW_LOCAL_PROBE : VW_REMOTE_PROBE);
}

static void draw_scene(vw_canvas *c, const vw_camera *cam, vw_peer *p) {
    canvas_clear(c);
    draw_ground(c, cam);
    draw_cloth(c, cam, p);
    draw_bodies(c, cam, p);
}

/* ------------------------------------------------------------------------
   PNG: 8-bit RGB, one IDAT of stored (uncompressed) deflate blocks
   ------------------------------------------------------------------------ */
typedef struct vw_png {
    FILE *f;
    uint32_t crc;
    uint32_t table[256];
    int failed;
} vw_png;

static void png_bytes(vw_png *p, const unsigned char *b, size_t n) {
    size_t i;
    for (i = 0; i < n; ++i) p->crc = p->table[(p->crc ^ b[i]) & 0xffu] ^ (p->crc >> 8);
    if (fwrite(b, 1, n, p->f) != n) p->failed = 1;
}

static void png_u32(vw_png *p, uint32_t v) { /* big-endian, into the CRC */
    unsigned char b[4];
    b[0] = (unsigned char)(v >> 24); b[1] = (unsigned char)(v >> 16);
    b[2] = (unsigned char)(v >> 8); b[3] = (unsigned char)v;
    png_bytes(p, b, 4);
}

static void png_chunk_begin(vw_png *p, uint32_t length, const char *type) {
    png_u32(p, length); /* the length is outside the CRC: reset after it */
    p->crc = 0xffffffffu;
    png_bytes(p, (const unsigned char *)type, 4);
}

static void png_chunk_end(vw_png *p) { png_u32(p, p->crc ^ 0xffffffffu); }

static uint32_t adler32(const unsigned char *b, size_t n) {
    uint32_t s1 = 1, s2 = 0;
    size_t i;
    for (i = 0; i < n; ++i) {
        s1 = (s1 + b[i]) % 65521u;
        s2 = (s2 + s1) % 65521u;
    }
    return (s2 << 16) | s1;
}

/* The zlib stream: header, stored blocks of at most 65535 bytes, Adler-32. */
static void png_idat(vw_png *p, const unsigned char *raw, size_t n) {
    size_t blocks = (n + 65534) / 65535, off = 0;
    static const unsigned char zhead[2] = {0x78, 0x01};
    png_chunk_begin(p, (uint32_t)(2 + n + 5 * blocks + 4), "IDAT");
    png_bytes(p, zhead, 2);
    while (off < n) {
        size_t len = n - off > 65535 ? 65535 : n - off;
        unsigned char h[5];
        h[0] = off + len == n ? 1 : 0; /* BFINAL, BTYPE 00: stored */
        h[1] = (unsigned char)len; h[2] = (unsigned char)(len >> 8);
        h[3] = (unsigned char)~len; h[4] = (unsigned char)(~len >> 8);
        png_bytes(p, h, 5);
        png_bytes(p, raw + off, len);
        off += len;
    }
    png_u32(p, adler32(raw, n));
    png_chunk_end(p);
}

/* Returns 0, or -1 after saying why. */
static int png_write(const char *path, const vw_canvas *c) {
    static const unsigned char sig[8] = {137, 'P', 'N', 'G', '\r', '\n', 26, '\n'};
    static const unsigned char ihdr_tail[5] = {8, 2, 0, 0, 0}; /* 8 bit RGB */
    size_t row = 1 + 3 * (size_t)c->w, n = row * (size_t)c->h;
    unsigned char *raw = (unsigned char *)malloc(n);
    vw_png p;
    uint32_t i, k;
    int y;
    if (!raw) {
        fprintf(stderr, "viewer: out of memory for %s\n", path);
        return -1;
    }
    for (y = 0; y < c->h; ++y) { /* filter type 0 (none) before each row */
        raw[row * y] = 0;
        memcpy(raw + row * y + 1, c->rgb + (size_t)y * c->w * 3, row - 1);
    }
    memset(&p, 0, sizeof p);
    for (i = 0; i < 256; ++i) {
        uint32_t v = i;
        for (k = 0; k < 8; ++k) v = v & 1u ? 0xedb88320u ^ (v >> 1) : v >> 1;
        p.table[i] = v;
    }
    p.f = fopen(path, "wb");
    if (!p.f) {
        fprintf(stderr, "viewer: cannot write %s: %s\n", path, strerror(errno));
        free(raw);
        return -1;
    }
    png_bytes(&p, sig, 8);
    png_chunk_begin(&p, 13, "IHDR");
    png_u32(&p, (uint32_t)c->w);
    png_u32(&p, (uint32_t)c->h);
    png_bytes(&p, ihdr_tail, 5);
    png_chunk_end(&p);
    png_idat(&p, raw, n);
    png_chunk_begin(&p, 0, "IEND");
    png_chunk_end(&p);
    free(raw);
    if (fclose(p.f) != 0) p.failed = 1;
    if (p.failed) fprintf(stderr, "viewer: writing %s failed: %s\n", path, strerror(errno));
    return p.failed ? -1 : 0;
}

/* ------------------------------------------------------------------------
   Headless mode
   ------------------------------------------------------------------------ */
static volatile sig_atomic_t vw_stop = 0;
static void on_signal(int sig) {
    (void)sig;
    vw_stop = 1;
}

static void catch_signals(void) {
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
}

static void nap(double seconds) {
    struct timespec ts;
    if (seconds <= 0.0) return;
    ts.tv_sec = (time_t)seconds;
    ts.tv_nsec = (long)((seconds - (double)ts.tv_sec) * 1e9);
    nanosleep(&ts, NULL);
}

/* FILE.png -> FILE-007.png */
static int frame_path(char *buf, size_t cap, const char *out, int k) {
    size_t n = strlen(out);
    int w;
    if (n >= 4 && !strcmp(out + n - 4, ".png")) n -= 4;
    w = snprintf(buf, cap, "%.*s-%03d.png", (int)n, out, k);
    return w > 0 && (size_t)w < cap;
}

static int write_picture(vw_canvas *c, const vw_camera *cam, vw_peer *p, const char *path) {
    draw_scene(c, cam, p);
    if (png_write(path, c) != 0) return -1;
    printf("viewer: host %u wrote %s at t = %.3f s\n", (unsigned)gs_world_host_id(p->world),
           path, gs_world_time(p->world));
    return 0;
}

static void print_peer_stats(vw_peer *p, const vw_options *o) {
    int i;
    printf("viewer: host %u spheres at", (unsigned)o->id);
    for (i = 0; i < p->scene.sphere_count; ++i) {
        gs_vec3 x = gs_rigid_position(p->scene.spheres[i]);
        printf(" (%.2f %.2f %.2f)", x.x, x.y, x.z);
    }
    printf(" m\n");
    for (i = 0; i < o->peer_count; ++i) {
        gs_peer_stats ps;
        if (gs_net_peer_stats(p->net, o->peer_id[i], &ps) != GS_OK) continue;
        printf("viewer: host %u <- peer %u: %llu snapshots, %llu datagrams, lost %llu, "
               "rejected %llu, rtt %.2f ms, remote t %.3f s\n",
               (unsigned)o->id, (unsigned)o->peer_id[i],
               (unsigned long long)ps.snapshots_received,
               (unsigned long long)ps.datagrams_received, (unsigned long long)ps.lost,
               (unsigned long long)ps.rejected_total, ps.rtt * 1e3, ps.last_remote_time);
    }
}

/* Writes the due frames; returns how many are written now, -1 on error. */
static int headless_frames(vw_canvas *c, const vw_camera *cam, vw_peer *p,
                           const vw_options *o, int done, double elapsed, char *path,
                           size_t cap) {
    while (done < o->frames && elapsed >= o->duration * (done + 1) / o->frames) {
        if (!frame_path(path, cap, o->out, done) || write_picture(c, cam, p, path) != 0)
            return -1;
        ++done;
    }
    return done;
}

static int run_headless(vw_peer *p, const vw_options *o) {
    vw_canvas c;
    vw_camera cam = camera_make(o->width, o->height);
    size_t cap = strlen(o->out) + 32;
    char *path = (char *)malloc(cap);
    double start = gs_udp_now(), last = start, elapsed = 0.0;
    int done = 0, status = 0;
    memset(&c, 0, sizeof c);
    if (!path || !canvas_init(&c, o->width, o->height)) {
        fprintf(stderr, "viewer: out of memory for a %dx%d picture\n", o->width, o->height);
        free(path);
        canvas_free(&c);
        return 1;
    }
    catch_signals();
    while (!vw_stop) {
        double now = gs_udp_now();
        elapsed = now - start;
        set_probe(p, gs_scene_probe_path(p->local, gs_world_time(p->world)));
        peer_advance(p, now - last, now);
        last = now;
        done = headless_frames(&c, &cam, p, o, done, elapsed, path, cap);
        if (done < 0 || elapsed >= o->duration) break;
        nap(fmin(1.0 / 120.0, o->duration - elapsed));
    }
    if (vw_stop) {
        fprintf(stderr, "viewer: interrupted\n");
        status = 1;
    } else if (done < 0) {
        status = 1;
    } else if (o->frames) { /* any left over by rounding: the final scene */
        done = headless_frames(&c, &cam, p, o, done, o->duration, path, cap);
        status = done < 0;
    } else {
        status = write_picture(&c, &cam, p, o->out) != 0;
    }
    print_peer_stats(p, o);
    free(path);
    canvas_free(&c);
    return status;
}

/* ------------------------------------------------------------------------
   Window mode
   ------------------------------------------------------------------------ */
typedef struct vw_mouse {
    int steering;     /* 0: the scripted path until the mouse moves */
    double sx, sy;    /* pointer in canvas pixels */
    double height;    /* m; the probe's height, set by the wheel */
    int pressed;      /* left button: press into the cloth */
    gs_vec3 target;   /* last target on the floor plane */
} vw_mouse;

typedef struct vw_window {
    SDL_Window *window;
    SDL_Renderer *renderer;
    SDL_Texture *texture;
} vw_window;

static void window_close(vw_window *win) {
    if (win->texture) SDL_DestroyTexture(win->texture);
    if (win->renderer) SDL_DestroyRenderer(win->renderer);
    if (win->window) SDL_DestroyWindow(win->window);
    SDL_Quit();
}

static int window_open(vw_window *win, const vw_options *o) {
    memset(win, 0, sizeof *win);
    SDL_SetMainReady();
    if (SDL_Init(SDL_INIT_VIDEO) != 0) {
        fprintf(stderr, "viewer: SDL_Init: %s (try --headless)\n", SDL_GetError());
        return 0;
    }
    win->window = SDL_CreateWindow("ghostsim viewer", SDL_WINDOWPOS_CENTERED,
                                   SDL_WINDOWPOS_CENTERED, o->width, o->height, 0);
    if (win->window) {
        win->renderer = SDL_CreateRenderer(win->window, -1, SDL_RENDERER_PRESENTVSYNC);
        if (!win->renderer) win->renderer = SDL_CreateRenderer(win->window, -1, 0);
    }
    if (win->renderer)
        win->texture = SDL_CreateTexture(win->renderer, SDL_PIXELFORMAT_RGB24,
                                         SDL_TEXTUREACCESS_STREAMING, o->width, o->height);
    if (!win->texture) {
        fprintf(stderr, "viewer: SDL: %s\n", SDL_GetError());
        window_close(win);
        return 0;
    }
    return 1;
}

/* Handles the waiting events; returns 0 when the user quits. */
static int window_events(vw_window *win, vw_mouse *m, const vw_options *o) {
    SDL_Event e;
    while (SDL_PollEvent(&e)) {
        if (e.type == SDL_QUIT) return 0;
        if (e.type == SDL_KEYDOWN && e.key.keysym.sym == SDLK_ESCAPE) return 0;
        if (e.type == SDL_KEYDOWN && e.key.keysym.sym == SDLK_p) m->steering = 0;
        if (e.type == SDL_MOUSEMOTION) {
            int ww, wh;
            SDL_GetWindowSize(win->window, &ww, &wh);
            m->sx = (double)e.motion.x * o->width / (ww > 0 ? ww : 1);
            m->sy = (double)e.motion.y * o->height / (wh > 0 ? wh : 1);
            m->steering = 1;
        }
        if (e.type == SDL_MOUSEWHEEL) {
            m->height += 0.03 * (e.wheel.y > 0 ? 1 : e.wheel.y < 0 ? -1 : 0);
            m->height = fmin(0.8, fmax(-0.6, m->height));
        }
        if ((e.type == SDL_MOUSEBUTTONDOWN || e.type == SDL_MOUSEBUTTONUP) &&
            e.button.button == SDL_BUTTON_LEFT)
            m->pressed = e.type == SDL_MOUSEBUTTONDOWN;
    }
    return !vw_stop;
}

/* The pointer's ray meets the plane at the probe's height there. */
static gs_vec3 mouse_target(vw_mouse *m, const vw_camera *cam) {
    gs_vec3 t;
    double y = m->height - (m->pressed ? 0.3 : 0.0);
    if (unproject_to_height(cam, m->sx, m->sy, y, &t)) {
        t.x = fmin(1.0, fmax(-1.0, t.x));
        t.z = fmin(1.0, fmax(-1.0, t.z));
        m->target = t;
    }
    m->target.y = y;
    return m->target;
}

static void window_title(vw_window *win, vw_peer *p, const vw_options *o) {
    char title[256];
    int i, n;
    n = snprintf(title, sizeof title, "ghostsim viewer - host %u - t %.2f s",
                 (unsigned)o->id, gs_world_time(p->world));
    for (i = 0; i < o->peer_count && n > 0 && (size_t)n < sizeof title; ++i) {
        gs_peer_stats ps;
        if (gs_net_peer_stats(p->net, o->peer_id[i], &ps) != GS_OK) continue;
        n += snprintf(title + n, sizeof title - (size_t)n, " | peer %u: rx %llu rtt %.1f ms",
                      (unsigned)o->peer_id[i], (unsigned long long)ps.snapshots_received,
                      ps.rtt * 1e3);
    }
    SDL_SetWindowTitle(win->window, title);
}

static int run_window(vw_peer *p, const vw_options *o) {
    vw_window win;
    vw_canvas c;
    vw_camera cam = camera_make(o->width, o->height);
    vw_mouse m;
    double start, last, titled = -1.0;
    catch_signals();
    if (!canvas_init(&c, o->width, o->height)) {
        fprintf(stderr, "viewer: out of memory for a %dx%d picture\n", o->width, o->height);
        canvas_free(&c);
        return 1;
    }
    if (!window_open(&win, o)) {
        canvas_free(&c);
        return 1;
    }
    memset(&m, 0, sizeof m);
    m.height = 0.15;
    start = last = gs_udp_now();
    while (window_events(&win, &m, o)) {
        double now = gs_udp_now(), frame_start = now;
        if (o->duration > 0.0 && now - start >= o->duration) break;
        set_probe(p, m.steering ? mouse_target(&m, &cam)
                                : gs_scene_probe_path(p->local, gs_world_time(p->world)));
        peer_advance(p, now - last, now);
        last = now;
        draw_scene(&c, &cam, p);
        SDL_UpdateTexture(win.texture, NULL, c.rgb, c.w * 3);
        SDL_RenderClear(win.renderer);
        SDL_RenderCopy(win.renderer, win.texture, NULL, NULL);
        SDL_RenderPresent(win.renderer);
        if (now - titled >= 0.5) {
            window_title(&win, p, o);
            titled = now;
        }
        nap(1.0 / 60.0 - (gs_udp_now() - frame_start)); /* in case there is no vsync */
    }
    window_close(&win);
    canvas_free(&c);
    print_peer_stats(p, o);
    return 0;
}

int main(int argc, char **argv) {
    vw_options o;
    vw_peer p;
    int status = parse_options(argc, argv, &o);
    if (status != 0) {
        usage(status > 0 ? stdout : stderr, argv[0]);
        return status > 0 ? 0 : 2;
    }
    status = peer_open(&p, &o);
    if (status != 0) {
        if (status == 2) usage(stderr, argv[0]);
        return status;
    }
    status = o.headless ? run_headless(&p, &o) : run_window(&p, &o);
    peer_close(&p);
    return status;
}
