/* test_net.c - the network side (>>net, >>simnet, >>udp).

   Worlds on the simulated network, on real UDP over loopback (127.0.0.1
   and ::1 only, on ports the kernel says are free) and on a transport of
   the test's own.
   What is checked: determinism of the simnet, that ghosts bring diverged
   hosts together (and how close, measured: the numbers are printed), that
   every host keeps pace with the clock through an outage, that a late
   joiner is taken in, that every malformed datagram is refused, counted and
   never blended, that sequence numbers wrap, and the statistics.

   Distances are the largest distance between two hosts' copies of any
   cloth particle, in metres. The "perturbation" of the convergence tests is
   a 1 cm displacement of a pinned corner: an interior particle displaced
   by 1 cm is damped back by the cloth's own physics (measured without any
   ghost: 3e-8 m after 10 s), so it would not tell whether the ghosts do
   anything; a pinned particle stays where it is put unless a blend moves it.

   Pass a cmocka glob to run some tests only: test_net 'test_udp*'. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#ifndef GHOSTSIM_NO_UDP
#include <dirent.h>
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>
#endif

#include "ghostsim.h"
#include "net_helpers.h"
#include "world_helpers.h"

/* Under valgrind (50x slower) the 20 s scene runs 2 s, for memory checks
   only; its distance bounds need the full run. */
#if defined(__has_include)
#if __has_include(<valgrind/valgrind.h>)
#include <valgrind/valgrind.h>

#define UNDER_VALGRIND() (RUNNING_ON_VALGRIND != 0)
#endif
#endif
#ifndef UNDER_VALGRIND
#define UNDER_VALGRIND() 0
#endif

#define FRAME (1.0 / 60.0) /* s: the applications' frame */
#define NCLOTH 12          /* particles per side of the small cloth */

/* ---- worlds and cloths ---- */

/* The brief's cloth: 12x12, four pinned corners, implicit Euler at 2 ms,
   spring damping 1 N s/m; origin_y moves the whole cloth, pins included. */
static gs_agent *cloth_new(gs_world *w, double origin_y) {
    gs_cloth_desc cd = gs_cloth_desc_default();
    gs_agent *a = NULL;
    cd.nx = cd.ny = NCLOTH;
    cd.origin.y = origin_y;
    cd.pin_corners = GS_CORNER_ALL;
    cd.spring_damping = 1.0;
    cd.solver.integrator = GS_INTEGRATOR_IMPLICIT_EULER;
    cd.solver.dt = 0.002;
    assert_int_equal(gs_cloth_create(w, &cd, &a), GS_OK);
    return a;
}

/* Under the paper's exponential rule, whose convergence these tests measure
   (the default rule is client/server). */
static void ghost_on(gs_agent *a, uint32_t id) {
    gs_ghost_desc gd = gs_ghost_desc_default();
    gd.object_id = id;
    gd.weight = gs_weight_exp;
    assert_int_equal(gs_ghost_attach(a, &gd), GS_OK);
}

/* Moves particle i of a mesh by dy metres (a pinned one stays there). */
static void nudge_particle(gs_agent *a, int i, double dy) {
    size_t n = gs_agent_state_size(a);
    double *s = (double *)malloc(n * sizeof(double));
    assert_non_null(s);
    assert_int_equal(gs_agent_get_state(a, s, n), GS_OK);
    s[1 + 3 * i + 1] += dy;
    assert_int_equal(gs_agent_set_state(a, s, n), GS_OK);
    free(s);
}

/* Largest distance between the two copies of any particle, m. */
static double mesh_gap(const gs_agent *a, const gs_agent *b) {
    const gs_vec3 *x = gs_mesh_positions(a), *y = gs_mesh_positions(b);
    double worst = 0.0;
    int i;
    assert_int_equal(gs_mesh_particle_count(a), gs_mesh_particle_count(b));
    for (i = 0; i < gs_mesh_particle_count(a); ++i) {
        double dx = x[i].x - y[i].x, dy = x[i].y - y[i].y, dz = x[i].z - y[i].z;
        double d = sqrt(dx * dx + dy * dy + dz * dz);
        if (d > worst) worst = d;
    }
    return worst;
}

static double vec_dist(gs_vec3 a, gs_vec3 b) {
    return sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) + (a.z - b.z) * (a.z - b.z));
}

/* The brief's bad link: 100 ms, 20 ms jitter, 30% loss, 5% duplicates,
   10% reordering. */
static gs_link_desc bad_link(void) {
    gs_link_desc l;
    memset(&l, 0, sizeof l);
    l.latency = 0.1;
    l.jitter = 0.02;
    l.loss = 0.3;
    l.duplicate = 0.05;
    l.reorder = 0.1;
    return l;
}

static void link_both(gs_simnet *sim, uint32_t a, uint32_t b, const gs_link_desc *l) {
    assert_int_equal(gs_simnet_link(sim, a, b, l), GS_OK);
    assert_int_equal(gs_simnet_link(sim, b, a, l), GS_OK);
}

static gs_simnet *simnet_new(uint64_t seed) {
    gs_simnet_desc sd;
    gs_simnet *sim = NULL;
    memset(&sd, 0, sizeof sd);
    sd.seed = seed;
    assert_int_equal(gs_simnet_create(&sd, &sim), GS_OK);
    return sim;
}

/* ---- two cloths on a simnet ---- */

typedef struct pair {
    gs_simnet *sim;
    gs_world *w[2];
    gs_agent *c[2];
    gs_net *net[2];
} pair;

/* Hosts 1 and 2, one cloth each (ghost id 1 unless ghosts is 0); host 2's
   corner particle 0 is 1 cm higher. */
static void pair_open(pair *p, uint64_t seed, const gs_link_desc *link, int ghosts) {
    int h;
    memset(p, 0, sizeof *p);
    p->sim = simnet_new(seed);
    for (h = 0; h < 2; ++h) {
        p->w[h] = world_new((uint32_t)h + 1);
        p->c[h] = cloth_new(p->w[h], 0.0);
        if (ghosts) ghost_on(p->c[h], 1);
        assert_int_equal(test_join(p->sim, p->w[h], NULL, &p->net[h]), GS_OK);
    }
    nudge_particle(p->c[1], 0, 0.01);
    if (link) link_both(p->sim, 1, 2, link);
}

static void pair_close(pair *p) {
    gs_world_destroy(p->w[0]);
    gs_world_destroy(p->w[1]);
    gs_simnet_destroy(p->sim);
}

/* ---- simnet determinism ---- */

static void det_run(uint64_t seed, uint64_t hash[2], uint64_t counts[3]) {
    gs_link_desc l = bad_link();
    pair p;
    pair_open(&p, seed, &l, 1);
    assert_int_equal(gs_simnet_run(p.sim, 2.0, FRAME), GS_OK);
    hash[0] = gs_world_hash(p.w[0]);
    hash[1] = gs_world_hash(p.w[1]);
    {
        gs_simnet_stats ss;
        assert_int_equal(gs_simnet_get_stats(p.sim, &ss), GS_OK);
        counts[0] = ss.dropped;
        counts[1] = ss.duplicated;
        counts[2] = ss.delivered;
    }
    pair_close(&p);
}

static void test_simnet_determinism(void **state) {
    uint64_t a[2], b[2], c[2], ca[3], cb[3], cc[3];
    (void)state;
    det_run(7, a, ca);
    det_run(7, b, cb);
    det_run(8, c, cc);
    /* same seed: bit for bit, every world, every count */
    assert_true(a[0] == b[0] && a[1] == b[1]);
    assert_memory_equal(ca, cb, sizeof ca);
    /* another seed draws other losses and delays: other states */
    assert_true(a[0] != c[0] || a[1] != c[1]);
    assert_true(ca[0] > 0 && ca[1] > 0); /* loss and duplicates happened */
}

/* ---- convergence of two cloths ---- */

/* Runs up to `seconds` and returns the gap at the end; *t_below gets the
   first time (s) from which the gap stayed below `below` (-1 if it never
   did). With `done` > 0 it stops once the gap has stayed below `done` for
   a second. */
static double pair_converge(pair *p, double seconds, double below, double done,
                            double *t_below) {
    int k, frames = (int)(seconds / FRAME + 0.5), quiet = 0;
    double g = 0.0;
    *t_below = -1.0;
    for (k = 0; k < frames; ++k) {
        assert_int_equal(gs_simnet_run(p->sim, FRAME, FRAME), GS_OK);
        g = mesh_gap(p->c[0], p->c[1]);
        if (g >= below) *t_below = -1.0;
        else if (*t_below < 0.0) *t_below = gs_simnet_time(p->sim);
        quiet = g < done ? quiet + 1 : 0;
        if (quiet >= 60) break;
    }
    return g;
}

static void test_converge_perfect_link(void **state) {
    pair p;
    double g, t_below, g_control;
    (void)state;
    /* control: without ghosts the displaced pin stays 1 cm off */
    pair_open(&p, 1, NULL, 0);
    g_control = pair_converge(&p, 2.0, 1e-6, 0.0, &t_below);
    pair_close(&p);
    assert_true(fabs(g_control - 0.01) < 1e-9);

    pair_open(&p, 1, NULL, 1);
    g = pair_converge(&p, 10.0, 1e-6, 1e-12, &t_below);
    print_message("perfect link: gap %.2e m at %.2f s (stops once below 1e-12 m for 1 s), "
                  "below 1e-6 m from t = %.2f s (without ghosts: %.2e m)\n", g,
                  gs_simnet_time(p.sim), t_below, g_control);
    /* measured: below 1e-6 m from 0.12 s on, 1e-16 m (rounding) after */
    assert_true(g < 1e-6);
    assert_true(t_below >= 0.0 && t_below < 10.0);
    assert_true(g < 1e-12); /* identical physics on both: rounding only */
    pair_close(&p);
}

static void test_converge_bad_link(void **state) {
    gs_link_desc l = bad_link();
    pair p;
    double g, t_below;
    gs_peer_stats ps;
    (void)state;
    pair_open(&p, 1, &l, 1);
    g = pair_converge(&p, 10.0, 1e-4, 0.0, &t_below);
    assert_int_equal(gs_net_peer_stats(p.net[0], 2, &ps), GS_OK);
    print_message("bad link: gap %.2e m after 10 s, below 1e-4 m from t = %.2f s; "
                  "lost %llu dup %llu\n", g, t_below, (unsigned long long)ps.lost,
                  (unsigned long long)ps.duplicates);
    /* Measured over seeds 1..8: 2.8e-7 to 3.6e-6 m at 10 s (3.6e-6 with
       seed 1; 4.6e-7 to 6.9e-6 before the time deadband). With 100-140 ms
       of delay the hosts blend states that are a latency apart while the
       cloth still swings, so the residual follows the swing and decays as
       it settles (1e-10 m at 20 s, rounding at 40 s). 5e-5 m is 7x the
       worst seed. */
    assert_true(g < 5e-5);
    assert_true(t_below > 0.0 && t_below < 10.0);
    assert_true(ps.lost > 0 && ps.duplicates > 0);
    pair_close(&p);
}

/* ---- the paper's scene ---- */

typedef struct scene_host {
    gs_world *w;
    gs_scene sc;
    gs_net *net;
} scene_host;

/* Every agent of the scene under a ghost (shared objects under `weight`,
   NULL for the exponential one), probe i owned by host i + 1 (owner rule). No
   cmocka assert here: the scene runs on threads too. */
static gs_result scene_open(scene_host *s, gs_simnet *sim, uint32_t id, int spheres,
                            int probes, gs_weight_fn weight) {
    gs_world_desc wd = gs_world_desc_default();
    gs_scene_desc sd = gs_scene_desc_default();
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_result r;
    wd.host_id = id;
    r = gs_world_create(&wd, &s->w);
    if (r != GS_OK) return r;
    sd.sphere_count = spheres ? spheres : GS_NONE;
    sd.probe_count = probes ? probes : GS_NONE;
    r = gs_scene_create(s->w, &sd, &s->sc);
    gd.weight = weight ? weight : gs_weight_exp;
    if (r == GS_OK) r = gs_scene_attach_ghosts(&s->sc, &gd);
    if (r == GS_OK) r = test_join(sim, s->w, NULL, &s->net);
    return r;
}

static double scene_gap(const scene_host *a, const scene_host *b) {
    double g = mesh_gap(a->sc.cloth, b->sc.cloth);
    int i;
    for (i = 0; i < a->sc.sphere_count; ++i) {
        double d = vec_dist(gs_rigid_position(a->sc.spheres[i]), gs_rigid_position(b->sc.spheres[i]));
        if (d > g) g = d;
    }
    for (i = 0; i < a->sc.probe_count; ++i) {
        double d = vec_dist(gs_rigid_position(a->sc.probes[i]), gs_rigid_position(b->sc.probes[i]));
        if (d > g) g = d;
    }
    return g;
}

/* A different small perturbation on each host: moves one sphere's centre
   by dy along axis `axis` (0 x, 2 z) before anything steps. */
static gs_result nudge_sphere(gs_agent *sphere, int axis, double d) {
    double st[14]; /* t, position, orientation, velocity, angular velocity */
    gs_result r = gs_agent_get_state(sphere, st, 14);
    st[1 + axis] += d;
    return r == GS_OK ? gs_agent_set_state(sphere, st, 14) : r;
}

#define SCENE_BELOW 1e-6 /* m: the convergence the issue asks for */

typedef struct scene_result {
    const gs_link_desc *link; /* NULL: perfect */
    gs_weight_fn weight;      /* shared objects' rule; NULL: exponential */
    double seconds;           /* s of simnet time to run */
    gs_result r;              /* the first error, GS_OK */
    double final_gap;         /* m, at the end */
    double t_below;           /* s; from then on the gap stayed below
                                 SCENE_BELOW (-1: it did not) */
    double every5[16];        /* m; the gap at 5, 10, ... s */
    double max_lag;           /* s, |agent time - simnet time| */
} scene_result;

/* The paper's scene on two hosts, nobody interacting: the spheres fall on
   the cloth and settle, each host's probe parked above the cloth at 0.4 m.
   Host 1's sphere 0 starts 1 cm off in x, host 2's sphere 1 1 cm off in z.
   Errors go to r->r. */
static void scene_run(scene_result *r) {
    const gs_quat id = {0.0, 0.0, 0.0, 1.0};
    gs_simnet *sim = NULL;
    gs_simnet_desc sdesc;
    scene_host s[2];
    int h, k, i, frames = (int)(r->seconds / FRAME + 0.5);
    memset(s, 0, sizeof s);
    memset(&sdesc, 0, sizeof sdesc);
    sdesc.seed = 1;
    r->max_lag = 0.0;
    r->t_below = -1.0;
    r->r = gs_simnet_create(&sdesc, &sim);
    for (h = 0; h < 2 && r->r == GS_OK; ++h)
        r->r = scene_open(&s[h], sim, (uint32_t)h + 1, 3, 2, r->weight);
    if (r->r == GS_OK) r->r = nudge_sphere(s[0].sc.spheres[0], 0, 0.01);
    if (r->r == GS_OK) r->r = nudge_sphere(s[1].sc.spheres[1], 2, -0.01);
    if (r->r == GS_OK && r->link) r->r = gs_simnet_link(sim, 1, 2, r->link);
    if (r->r == GS_OK && r->link) r->r = gs_simnet_link(sim, 2, 1, r->link);
    for (k = 1; k <= frames && r->r == GS_OK; ++k) {
        double now, g;
        for (h = 0; h < 2 && r->r == GS_OK; ++h) {
            gs_vec3 park = gs_scene_probe_path(h, 0.0);
            park.y = 0.4;
            r->r = gs_probe_set_target(s[h].sc.probes[h], park, id);
        }
        if (r->r == GS_OK) r->r = gs_simnet_run(sim, FRAME, FRAME);
        now = gs_simnet_time(sim);
        for (h = 0; h < 2; ++h)
            for (i = 0; i < gs_world_agent_count(s[h].w); ++i) {
                double lag = fabs(gs_agent_time(gs_world_agent(s[h].w, i)) - now);
                if (lag > r->max_lag) r->max_lag = lag;
            }
        g = scene_gap(&s[0], &s[1]);
        if (g >= SCENE_BELOW) r->t_below = -1.0;
        else if (r->t_below < 0.0) r->t_below = now;
        if (k % (int)(5.0 / FRAME + 0.5) == 0 && k / (int)(5.0 / FRAME + 0.5) <= 16)
            r->every5[k / (int)(5.0 / FRAME + 0.5) - 1] = g;
        r->final_gap = g;
    }
    for (h = 0; h < 2; ++h) gs_world_destroy(s[h].w);
    gs_simnet_destroy(sim);
}

static void *scene_thread(void *arg) {
    scene_run((scene_result *)arg);
    return NULL;
}

static void scene_print(const char *label, const scene_result *r) {
    char line[256] = ""; /* runs under 5 s (valgrind's) have no sample */
    int i, n = 0;
    for (i = 0; i < 16 && (i + 1) * 5.0 <= r->seconds + 1e-9; ++i)
        n += snprintf(line + n, sizeof line - (size_t)n, " %.0e", r->every5[i]);
    print_message("scene, %s: gap every 5 s (m):%s; below %.0e m from t = %.2f s; "
                  "max |t - clock| %.4f s\n", label, line, SCENE_BELOW, r->t_below,
                  r->max_lag);
}

/* The convergence: the paper's scene, different small
   perturbations on the two hosts, nobody interacting; positions agree
   within 1e-6 m after a bounded time, on a perfect link and on the bad one.

   Perfect link, default rule (exponential): every blend takes half of a
   snapshot that is one frame old, and the hosts agree to rounding within
   a second (measured: below 1e-6 m from 0.72 s, exactly 0 at 5 s).

   Bad link (100 ms, 20 ms jitter, 30% loss, duplicates, reordering): the
   client/server rule. Hosts in step are a tie that host 1 wins, so host 2
   copies host 1's snapshots, whose only error is how far host 1 moved in
   the 100 ms they spent on the wire: the gap falls as the scene comes to
   rest (measured: below 1e-6 m from 32.35 s, 1e-7 m at 50 s). The
   exponential rule here blends two hosts that pull each other toward
   their states of 100 ms ago; the scene
   never comes to rest and they stay millimetres apart (measured 2e-3 m at
   20 s, printed below): see the README's "Convergence". */
static void test_scene_perfect_and_bad(void **state) {
    gs_link_desc bad = bad_link();
    scene_result *res = (scene_result *)calloc(3, sizeof *res);
    pthread_t th;
    int threaded, slow = UNDER_VALGRIND();
    (void)state;
    /* 85 s of simulated scene (a minute of CPU, four under ASan): make
       test-slow runs it, so make test keeps within its 10 minutes */
    if (!getenv("GHOSTSIM_SLOW_TESTS")) {
        print_message("scene: 85 s of simulation, left to make test-slow\n");
        free(res);
        skip();
    }
    assert_non_null(res);
    res[0].seconds = slow ? 2.0 : 15.0;
    res[1].seconds = slow ? 2.0 : 50.0;
    res[1].link = &bad;
    res[1].weight = gs_weight_cs;
    res[2].seconds = slow ? 1.0 : 20.0;
    res[2].link = &bad;
    /* the runs share nothing (no global state): the long one on a thread
       of its own halves the wall time on two cores */
    threaded = pthread_create(&th, NULL, scene_thread, &res[1]) == 0;
    scene_run(&res[0]);
    scene_run(&res[2]);
    if (threaded) pthread_join(th, NULL);
    else scene_run(&res[1]);
    assert_int_equal(res[0].r, GS_OK);
    assert_int_equal(res[1].r, GS_OK);
    assert_int_equal(res[2].r, GS_OK);
    scene_print("perfect link, exponential", &res[0]);
    scene_print("bad link, client/server", &res[1]);
    scene_print("bad link, exponential (measured only)", &res[2]);
    if (slow) {
        print_message("scene: shortened under valgrind, distances not checked\n");
        free(res);
        return;
    }
    /* bounded times: 4x and 1.2x the measured ones (the bad link's is
       the scene's own settling, which every seed shares) */
    assert_true(res[0].t_below >= 0.0 && res[0].t_below < 3.0);
    assert_true(res[0].final_gap < SCENE_BELOW);
    assert_true(res[1].t_below >= 0.0 && res[1].t_below < 47.0);
    assert_true(res[1].final_gap < SCENE_BELOW);
    /* both keep pace: the scheduler leaves every agent within dt/2 = 1 ms
       of the clock (measured 0.7 ms on both links); a time blend would
       move one by more than the deadband, 27 ms */
    assert_true(res[0].max_lag < 0.01);
    assert_true(res[1].max_lag < 0.01);
    free(res);
}

/* ---- an outage ---- */

/* The cloth-and-probe variant of the scene (no spheres): the link is cut
   both ways for 5 s, during which host 1 pokes the cloth with its probe;
   afterwards the probe goes home (above the cloth). */
static void test_outage(void **state) {
    const double t_cut = 1.0, t_back = 6.0, t_end = 9.0;
    const gs_quat id = {0.0, 0.0, 0.0, 1.0};
    gs_simnet *sim = simnet_new(1);
    gs_link_desc l;
    scene_host s[2];
    gs_vec3 home = gs_scene_probe_path(0, 0.0);
    double max_lag = 0.0, max_gap_cut = 0.0, t_below = -1.0, g = 0.0;
    uint64_t dropped_before = 0, dropped = 0, rx_cut = 0, rx_after;
    gs_simnet_stats ss;
    gs_peer_stats ps;
    int h, k, frames = (int)(t_end / FRAME + 0.5);
    (void)state;
    for (h = 0; h < 2; ++h)
        assert_int_equal(scene_open(&s[h], sim, (uint32_t)h + 1, 0, 1, NULL), GS_OK);
    memset(&l, 0, sizeof l);
    l.outage_start[0] = t_cut;
    l.outage_end[0] = t_back;
    link_both(sim, 1, 2, &l);
    for (k = 1; k <= frames; ++k) {
        double now = gs_simnet_time(sim);
        int cut = now >= t_cut && now < t_back;
        gs_vec3 target = cut ? gs_scene_probe_path(0, now - t_cut) : home;
        assert_int_equal(gs_probe_set_target(s[0].sc.probes[0], target, id), GS_OK);
        assert_int_equal(gs_simnet_run(sim, FRAME, FRAME), GS_OK);
        now = gs_simnet_time(sim);
        for (h = 0; h < 2; ++h) {
            double lag = fabs(gs_agent_time(s[h].sc.cloth) - now);
            double lagp = fabs(gs_agent_time(s[h].sc.probes[0]) - now);
            if (lag > max_lag) max_lag = lag;
            if (lagp > max_lag) max_lag = lagp;
        }
        g = mesh_gap(s[0].sc.cloth, s[1].sc.cloth);
        if (now > t_cut && now < t_back && g > max_gap_cut) max_gap_cut = g;
        if (now > t_back) {
            if (g >= 1e-4) t_below = -1.0;
            else if (t_below < 0.0) t_below = now - t_back;
        }
        if (fabs(now - (t_cut + 0.2)) < 0.5 * FRAME) { /* early in the cut */
            assert_int_equal(gs_simnet_get_stats(sim, &ss), GS_OK);
            dropped_before = ss.dropped;
            assert_int_equal(gs_net_peer_stats(s[1].net, 1, &ps), GS_OK);
            rx_cut = ps.datagrams_received;
        }
        if (fabs(now - (t_back - 0.1)) < 0.5 * FRAME) { /* late in the cut */
            assert_int_equal(gs_simnet_get_stats(sim, &ss), GS_OK);
            dropped = ss.dropped;
            assert_int_equal(gs_net_peer_stats(s[1].net, 1, &ps), GS_OK);
            assert_int_equal(ps.datagrams_received, rx_cut); /* nothing came */
        }
    }
    assert_int_equal(gs_net_peer_stats(s[1].net, 1, &ps), GS_OK);
    rx_after = ps.datagrams_received;
    print_message("outage: gap up to %.2e m while cut; after: below 1e-4 m %.2f s after the "
                  "link came back, %.2e m at the end; max |t - clock| %.4f s; simnet "
                  "dropped %llu, host 2 counted %llu lost\n", max_gap_cut, t_below, g, max_lag,
                  (unsigned long long)dropped, (unsigned long long)ps.lost);
    /* every world kept pace through the cut (measured: 1 ms, dt / 2) */
    assert_true(max_lag < 0.1);
    /* the cut was real: datagrams dropped during it, counted as lost once
       the sequence resumed, and the hosts drifted apart (measured 9 cm) */
    assert_true(dropped > dropped_before && dropped_before > 0);
    assert_true(ps.lost > 0);
    assert_true(rx_after > rx_cut);
    assert_true(max_gap_cut > 1e-2);
    /* after: below 1e-4 m within 10 s (measured 0.2-0.3 s), and at the end
       (3 s after, probe out of the cloth) equal to rounding (measured
       6e-17 m) */
    assert_true(t_below >= 0.0 && t_below < 10.0);
    assert_true(g < 1e-9);
    for (h = 0; h < 2; ++h) gs_world_destroy(s[h].w);
    gs_simnet_destroy(sim);
}

/* ---- a late joiner ---- */

/* Hosts 1-3 run 3 s; host 4's world is created then, at time 0, and joins.
   Its snapshots from the others are 3 s ahead (weight e^3 each against its
   own 1), so its first blend takes their state and time. What should
   follow: host 4 simulates on from there, in step with the others. */
static void test_late_joiner(void **state) {
    gs_simnet *sim = simnet_new(1);
    gs_world *w[4];
    gs_agent *c[4];
    gs_net *net;
    double t_close = -1.0, worst_after = 0.0, lag_end, steps_rate, steps_rate1;
    uint64_t steps_mid = 0, steps_end, steps1_mid = 0;
    int h, k;
    (void)state;
    for (h = 0; h < 3; ++h) {
        w[h] = world_new((uint32_t)h + 1);
        c[h] = cloth_new(w[h], 0.0);
        ghost_on(c[h], 1);
        assert_int_equal(test_join(sim, w[h], NULL, &net), GS_OK);
    }
    assert_int_equal(gs_simnet_run(sim, 3.0, FRAME), GS_OK);
    w[3] = world_new(4);
    c[3] = cloth_new(w[3], 0.0);
    ghost_on(c[3], 1);
    assert_int_equal(test_join(sim, w[3], NULL, &net), GS_OK);
    assert_true(gs_agent_time(c[3]) == 0.0 && gs_world_time(w[3]) == 0.0);
    for (k = 1; k <= 6 * 60; ++k) { /* 6 s after the join */
        double g;
        assert_int_equal(gs_simnet_run(sim, FRAME, FRAME), GS_OK);
        g = mesh_gap(c[3], c[0]);
        if (g < 1e-3 && t_close < 0.0) t_close = k * FRAME;
        if (t_close >= 0.0 && k * FRAME > t_close + 1.0 && g > worst_after) worst_after = g;
        if (k == 3 * 60) {
            steps_mid = agent_stats(c[3]).steps;
            steps1_mid = agent_stats(c[0]).steps;
        }
    }
    steps_end = agent_stats(c[3]).steps;
    lag_end = gs_agent_time(c[3]) - gs_agent_time(c[0]);
    steps_rate = (double)(steps_end - steps_mid) / 3.0;
    steps_rate1 = (double)(agent_stats(c[0]).steps - steps1_mid) / 3.0;
    print_message("late joiner: within 1e-3 m of host 1 %.2f s after joining, then at most "
                  "%.2e m; at the end its time is %.3f s vs host 1's %.3f s (world clock "
                  "%.3f s); over the last 3 s it stepped %.0f times/s, host 1 %.0f times/s "
                  "(1/dt = 500)\n", t_close, worst_after, gs_agent_time(c[3]),
                  gs_agent_time(c[0]), gs_world_time(w[3]), steps_rate, steps_rate1);
    for (h = 0; h < 4; ++h) gs_world_destroy(w[h]); /* before any assert fails */
    gs_simnet_destroy(sim);
    /* its cloth is pulled to the others' */
    assert_true(t_close >= 0.0 && t_close < 3.0);
    assert_true(worst_after < 1e-3);
    /* its time catches up with the others' and stays there */
    assert_true(fabs(lag_end) < 0.1);
    /* and it keeps simulating, at ~1/dt steps per second, while the others
       do not redo much work for it (four hosts in step from the start:
       571 steps/s each, measured) */
    assert_true(steps_rate > 0.8 * 500.0);
    assert_true(steps_rate1 < 1.3 * 500.0);
}

/* ---- malformed datagrams, by hand ---- */

/* A toy agent: 3 doubles, its step does nothing. */
typedef struct toy { double x[3]; } toy;
static gs_result toy_step(void *user, double t, double dt) {
    (void)user; (void)t; (void)dt;
    return GS_OK;
}
static void toy_get(const void *user, double *out) { memcpy(out, ((const toy *)user)->x, 3 * sizeof(double)); }
static gs_result toy_set(void *user, const double *in) {
    memcpy(((toy *)user)->x, in, 3 * sizeof(double));
    return GS_OK;
}

static gs_result drop_send(void *user, uint32_t host, const void *data, size_t size) {
    (void)user; (void)host; (void)data; (void)size;
    return GS_OK;
}

typedef struct toy_host {
    gs_world *w;
    gs_agent *a;
    toy t;
    gs_net *net;
} toy_host;

/* Host 1 with a toy (ghost id 5) at time t0 and a net (peer 2). */
static toy_host *toy_host_new(double t0, double window) {
    toy_host *h = (toy_host *)calloc(1, sizeof *h);
    gs_net_desc nd = gs_net_desc_default();
    double s[4] = {0.0, 1.0, 2.0, 3.0};
    assert_non_null(h);
    h->w = world_new(1);
    h->a = custom_new(h->w, 0.01, 3, toy_step, toy_get, toy_set, &h->t);
    s[0] = t0;
    assert_int_equal(gs_agent_set_state(h->a, s, 4), GS_OK);
    ghost_on(h->a, 5);
    nd.time_window = window;
    assert_int_equal(send_only_net(h->w, &nd, drop_send, NULL, &h->net), GS_OK);
    assert_int_equal(gs_net_add_peer(h->net, 2, NULL), GS_OK);
    return h;
}

static void toy_host_free(toy_host *h) {
    gs_world_destroy(h->w);
    free(h);
}

typedef struct dgram {
    uint32_t session, sender, dseq, object;
    double time;
    uint16_t index, count, elements;
    uint32_t first;
    gs_encoding enc;
} dgram;

/* A well-formed snapshot datagram for toy_host: session 1, from host 2,
   object 5, one chunk of the 3 values, at time 0.05. */
static dgram dgram_ok(uint32_t dseq) {
    dgram d;
    d.session = 1;
    d.sender = 2;
    d.dseq = dseq;
    d.object = 5;
    d.time = 0.05;
    d.index = 0;
    d.count = 1;
    d.elements = 3;
    d.first = 0;
    d.enc = GS_ENCODING_F64;
    return d;
}

static size_t dgram_build(unsigned char *buf, const dgram *d) {
    static const double vals[8] = {7.0, 8.0, 9.0, 10.0, 11.0, 12.0, 13.0, 14.0};
    gs_wire_header h;
    gs_wire_chunk c;
    size_t size = 0;
    memset(&h, 0, sizeof h);
    h.session = d->session;
    h.sender = d->sender;
    h.sequence = d->dseq;
    h.send_time = 1.0;
    memset(&c, 0, sizeof c);
    c.object_id = d->object;
    c.sequence = d->dseq + 1;
    c.time = d->time;
    c.index = d->index;
    c.count = d->count;
    c.first = d->first;
    c.elements = d->elements;
    c.encoding = d->enc;
    assert_int_equal(gs_wire_begin(buf, GS_WIRE_MAX_DATAGRAM, &h, &size), GS_OK);
    assert_int_equal(gs_wire_add(buf, GS_WIRE_MAX_DATAGRAM, &size, &c, vals), GS_OK);
    return gs_wire_end(buf, size);
}

static gs_result dgram_send(gs_net *net, const dgram *d, gs_reject *why) {
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    size_t n = dgram_build(buf, d);
    *why = GS_REJECT_COUNT;
    return gs_net_deliver(net, buf, n, 0.0, why);
}

/* Expects a refusal for `r`, counted per peer (known sender) or among
   the unknown ones, and nothing else counted. */
static void expect_refused(toy_host *h, const dgram *d, gs_reject r, int known) {
    gs_unknown_stats unk0, unk1;
    gs_peer_stats p0, p1;
    gs_reject why;
    assert_int_equal(gs_net_unknown_stats(h->net, &unk0), GS_OK);
    assert_int_equal(gs_net_peer_stats(h->net, 2, &p0), GS_OK);
    assert_int_equal(dgram_send(h->net, d, &why), GS_ERR_REJECTED);
    if (why != r) print_error("expected %s, got %s\n", gs_reject_str(r), gs_reject_str(why));
    assert_int_equal(why, r);
    assert_int_equal(gs_net_unknown_stats(h->net, &unk1), GS_OK);
    assert_int_equal(gs_net_peer_stats(h->net, 2, &p1), GS_OK);
    if (known) {
        assert_int_equal(p1.rejected[r], p0.rejected[r] + 1);
        assert_int_equal(p1.rejected_total, p0.rejected_total + 1);
        assert_memory_equal(&unk0, &unk1, sizeof unk0);
    } else {
        assert_int_equal(unk1.rejected[r], unk0.rejected[r] + 1);
        assert_int_equal(p1.rejected_total, p0.rejected_total);
    }
    assert_int_equal(p1.datagrams_received, p0.datagrams_received);
    assert_int_equal(p1.chunks_received, p0.chunks_received);
}

static void test_malformed_datagrams(void **state) {
    toy_host *h = toy_host_new(0.0, 0.5), *twin = toy_host_new(0.0, 0.5);
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    gs_ghost_stats st;
    gs_peer_stats ps;
    gs_reject why;
    dgram d;
    size_t n;
    (void)state;
    /* before the sender is known */
    d = dgram_ok(0);
    d.session = 2;
    expect_refused(h, &d, GS_REJECT_SESSION, 0);
    d = dgram_ok(0);
    d.sender = 9;
    expect_refused(h, &d, GS_REJECT_SENDER, 0);
    d.sender = 1; /* ourselves */
    expect_refused(h, &d, GS_REJECT_SENDER, 0);
    d = dgram_ok(0);
    n = dgram_build(buf, &d);
    buf[0] = 'X';
    assert_int_equal(gs_net_deliver(h->net, buf, n, 0.0, &why), GS_ERR_REJECTED);
    assert_int_equal(why, GS_REJECT_MAGIC);
    n = dgram_build(buf, &d);
    buf[n - 1] ^= 0x40;
    assert_int_equal(gs_net_deliver(h->net, buf, n, 0.0, &why), GS_ERR_REJECTED);
    assert_int_equal(why, GS_REJECT_CHECKSUM);
    assert_int_equal(gs_net_deliver(h->net, buf, 10, 0.0, NULL), GS_ERR_REJECTED); /* why NULL */
    {
        gs_unknown_stats unk;
        assert_int_equal(gs_net_unknown_stats(h->net, &unk), GS_OK);
        assert_int_equal(unk.rejected[GS_REJECT_MAGIC], 1);
        assert_int_equal(unk.rejected[GS_REJECT_CHECKSUM], 1);
        assert_int_equal(unk.rejected[GS_REJECT_SHORT], 1);
    }
    /* from the known peer */
    d = dgram_ok(1);
    d.object = 77;
    expect_refused(h, &d, GS_REJECT_OBJECT, 1);
    d = dgram_ok(2);
    d.elements = 4; /* the toy has 3 values after its time */
    expect_refused(h, &d, GS_REJECT_RANGE, 1);
    d = dgram_ok(3);
    d.elements = 2;
    d.first = 1; /* chunk 0 must start at 0 */
    expect_refused(h, &d, GS_REJECT_RANGE, 1);
    d = dgram_ok(4);
    d.count = 2; /* the toy's snapshot is one chunk */
    expect_refused(h, &d, GS_REJECT_RANGE, 1);
    d = dgram_ok(5);
    d.enc = GS_ENCODING_F32; /* the ghost uses f64 */
    expect_refused(h, &d, GS_REJECT_RANGE, 1);
    d = dgram_ok(7);
    d.time = 0.7; /* 0.7 s from the local 0 s: outside the 0.5 s window */
    expect_refused(h, &d, GS_REJECT_TIME, 1);

    /* none of it reached the state */
    assert_int_equal(gs_agent_step(h->a), GS_OK);
    assert_int_equal(gs_agent_step(twin->a), GS_OK);
    assert_true(gs_world_hash(h->w) == gs_world_hash(twin->w));
    assert_int_equal(gs_ghost_get_stats(h->a, &st), GS_OK);
    assert_int_equal(st.blends, 0);

    /* a good datagram to both, then its duplicate to one: refused */
    d = dgram_ok(20);
    assert_int_equal(dgram_send(h->net, &d, &why), GS_OK);
    assert_int_equal(dgram_send(twin->net, &d, &why), GS_OK);
    expect_refused(h, &d, GS_REJECT_DUPLICATE, 1);
    assert_int_equal(gs_net_peer_stats(h->net, 2, &ps), GS_OK);
    assert_int_equal(ps.duplicates, 1);
    assert_int_equal(ps.datagrams_received, 1);
    assert_int_equal(ps.rejected_total, 7);
    assert_int_equal(gs_agent_step(h->a), GS_OK);
    assert_int_equal(gs_agent_step(twin->a), GS_OK);
    assert_true(gs_world_hash(h->w) == gs_world_hash(twin->w));
    assert_int_equal(gs_ghost_get_stats(h->a, &st), GS_OK);
    assert_int_equal(st.blends, 1);
    assert_int_equal(st.snapshots_blended, 1);
    toy_host_free(h);
    toy_host_free(twin);
}

/* The time window is measured from the local time: a ghost on an agent
   that starts at 5 s must take a snapshot at 5.1 s (0.5 s window) even
   before its first step. */
static void test_time_window_before_first_step(void **state) {
    toy_host *h = toy_host_new(5.0, 0.5);
    dgram d = dgram_ok(0);
    gs_reject why, why2;
    gs_result r, r2;
    (void)state;
    d.time = 5.1;
    r = dgram_send(h->net, &d, &why);
    if (r != GS_OK)
        print_error("snapshot at 5.1 s refused (%s) by a ghost at 5.0 s with a 0.5 s window\n",
                    gs_reject_str(why));
    /* and one 1.1 s off is refused */
    d = dgram_ok(1);
    d.time = 6.1;
    r2 = dgram_send(h->net, &d, &why2);
    toy_host_free(h);
    assert_int_equal(r, GS_OK);
    assert_int_equal(r2, GS_ERR_REJECTED);
    assert_int_equal(why2, GS_REJECT_TIME);
}

/* A snapshot whose only chunk holds fewer values than the state: the
   chunk claims to be the last (index 0 of 1) so its length is not that of
   a full chunk, but it does not reach the end of the state either. The
   values it lacks were never received and must not be blended. */
static void test_short_last_chunk(void **state) {
    toy_host *h = toy_host_new(0.0, 0.0);
    dgram d = dgram_ok(0);
    gs_reject why;
    gs_result r;
    (void)state;
    d.elements = 2; /* of 3 */
    r = dgram_send(h->net, &d, &why);
    if (r == GS_OK) {
        double s[4];
        assert_int_equal(gs_agent_step(h->a), GS_OK);
        assert_int_equal(gs_agent_get_state(h->a, s, 4), GS_OK);
        print_error("a 2-value chunk for a 3-value state was queued as a whole snapshot; "
                    "after the blend the third value is %g (local 3, nothing received)\n",
                    s[3]);
    }
    toy_host_free(h);
    assert_int_equal(r, GS_ERR_REJECTED);
    assert_int_equal(why, GS_REJECT_RANGE);
}

/* ---- sequence numbers ---- */

static void test_sequence_wrap(void **state) {
    toy_host *h = toy_host_new(0.0, 0.0);
    static const uint32_t seqs[6] = {UINT32_MAX - 2, UINT32_MAX - 1, UINT32_MAX, 0, 1, 2};
    gs_peer_stats ps;
    gs_reject why;
    dgram d;
    int k;
    (void)state;
    for (k = 0; k < 6; ++k) {
        d = dgram_ok(seqs[k]);
        assert_int_equal(dgram_send(h->net, &d, &why), GS_OK);
    }
    assert_int_equal(gs_net_peer_stats(h->net, 2, &ps), GS_OK);
    assert_int_equal(ps.datagrams_received, 6);
    assert_int_equal(ps.lost, 0);
    assert_int_equal(ps.duplicates, 0);
    assert_int_equal(ps.rejected_total, 0);
    /* an old one across the wrap is a duplicate */
    d = dgram_ok(UINT32_MAX);
    assert_int_equal(dgram_send(h->net, &d, &why), GS_ERR_REJECTED);
    assert_int_equal(why, GS_REJECT_DUPLICATE);
    /* a gap of two, then one of the two arrives late */
    d = dgram_ok(5);
    assert_int_equal(dgram_send(h->net, &d, &why), GS_OK);
    assert_int_equal(gs_net_peer_stats(h->net, 2, &ps), GS_OK);
    assert_int_equal(ps.lost, 2);
    d = dgram_ok(3);
    assert_int_equal(dgram_send(h->net, &d, &why), GS_OK);
    assert_int_equal(gs_net_peer_stats(h->net, 2, &ps), GS_OK);
    assert_int_equal(ps.lost, 1);
    assert_int_equal(ps.duplicates, 1);
    toy_host_free(h);

    /* a gap across the wrap: MAX-1 then 1 misses MAX and 0 */
    h = toy_host_new(0.0, 0.0);
    d = dgram_ok(UINT32_MAX - 1);
    assert_int_equal(dgram_send(h->net, &d, &why), GS_OK);
    d = dgram_ok(1);
    assert_int_equal(dgram_send(h->net, &d, &why), GS_OK);
    assert_int_equal(gs_net_peer_stats(h->net, 2, &ps), GS_OK);
    assert_int_equal(ps.lost, 2);
    assert_int_equal(ps.duplicates, 0);
    toy_host_free(h);
}

/* ---- statistics ---- */

static void test_stats_on_simnet(void **state) {
    gs_link_desc l;
    pair p;
    gs_peer_stats a1, a2, b2;
    uint64_t dropped, dup, delivered;
    double rtt_min = 1e9, rtt_max = 0.0;
    int k;
    (void)state;
    memset(&l, 0, sizeof l);
    l.latency = 0.05; /* s, one way */
    pair_open(&p, 3, &l, 1);
    assert_int_equal(gs_simnet_run(p.sim, 1.0, FRAME), GS_OK);
    assert_int_equal(gs_net_peer_stats(p.net[0], 2, &a1), GS_OK);
    for (k = 0; k < 60; ++k) {
        gs_peer_stats s;
        assert_int_equal(gs_simnet_run(p.sim, FRAME, FRAME), GS_OK);
        assert_int_equal(gs_net_peer_stats(p.net[0], 2, &s), GS_OK);
        if (s.rtt < rtt_min) rtt_min = s.rtt;
        if (s.rtt > rtt_max) rtt_max = s.rtt;
    }
    assert_int_equal(gs_net_peer_stats(p.net[0], 2, &a2), GS_OK);
    assert_int_equal(gs_net_peer_stats(p.net[1], 1, &b2), GS_OK);
    print_message("stats, 50 ms: rtt %.4f..%.4f s; in 1 s %llu snapshots, %llu datagrams, "
                  "%llu bytes received\n", rtt_min, rtt_max,
                  (unsigned long long)(a2.snapshots_received - a1.snapshots_received),
                  (unsigned long long)(a2.datagrams_received - a1.datagrams_received),
                  (unsigned long long)(a2.bytes_received - a1.bytes_received));
    /* A datagram sent at a frame end arrives at the first frame end at
       least 50 ms later, is echoed at the next frame end (the hold, one
       frame, is taken off) and comes back at the first frame end 50 ms
       after that: rtt in [0.1, 0.1 + 2 frames] s (measured 0.1 and
       0.1333). 1e-9 s covers the rounding of the virtual clock. */
    assert_true(rtt_min >= 0.1 - 1e-9);
    assert_true(rtt_max <= 0.1 + 2.0 * FRAME + 1e-9);
    /* snapshots keep coming: about 60 a second (the ghost's rate) */
    assert_true(a2.snapshots_received - a1.snapshots_received >= 45);
    assert_true(a2.snapshots_received - a1.snapshots_received <= 61);
    assert_true(a2.bytes_received > a1.bytes_received);
    /* a 12x12 cloth is 864 values: ceil(864 / 135) = 7 chunks each */
    assert_int_equal(a2.chunks_received, 7 * a2.snapshots_received);
    /* a perfect link loses nothing, and host 1's view of host 2's time is
       one latency (plus the publish period) behind */
    assert_int_equal(a2.lost, 0);
    assert_int_equal(a2.duplicates, 0);
    assert_true(a2.gap < 0.0 && a2.gap > -0.1 - 2.0 * FRAME);
    assert_true(fabs(a2.last_remote_time - gs_simnet_time(p.sim)) < 0.1 + 2.0 * FRAME);
    assert_true(b2.snapshots_sent >= a2.snapshots_received);
    assert_true(a2.divergence >= 0.0 && a2.divergence < 1e-2);
    pair_close(&p);

    /* loss: every datagram the simnet dropped shows as lost at the other
       end, but for those whose successors are still on the wire */
    memset(&l, 0, sizeof l);
    l.latency = 0.05;
    l.loss = 0.2;
    pair_open(&p, 3, &l, 1);
    assert_int_equal(gs_simnet_run(p.sim, 2.0, FRAME), GS_OK);
    assert_int_equal(gs_net_peer_stats(p.net[0], 2, &a2), GS_OK);
    assert_int_equal(gs_net_peer_stats(p.net[1], 1, &b2), GS_OK);
    {
        gs_simnet_stats ss;
        assert_int_equal(gs_simnet_get_stats(p.sim, &ss), GS_OK);
        dropped = ss.dropped;
        dup = ss.duplicated;
        delivered = ss.delivered;
    }
    print_message("stats, 20%% loss: simnet dropped %llu, hosts counted %llu + %llu lost\n",
                  (unsigned long long)dropped, (unsigned long long)a2.lost,
                  (unsigned long long)b2.lost);
    assert_true(dropped > 0);
    assert_true(a2.lost + b2.lost <= dropped);
    assert_true((double)(a2.lost + b2.lost) >= 0.9 * (double)dropped);
    assert_int_equal(dup, 0);
    assert_int_equal(delivered, a2.datagrams_received + b2.datagrams_received);
    pair_close(&p);
}

/* Reordering on the link: a datagram held back arrives after newer ones.
   The round trip must still be measured from the newest datagram the peer
   echoes; an echo of an old send time makes the rtt, and with it the age
   of every snapshot (rtt / 2), look up to one latency longer, the
   snapshots look ahead of the local time, and blending pushes the hosts'
   clocks ahead of the wall clock, a little more after each such sample.
   Toy agents (3 doubles): the clock does not depend on the physics. */
static void test_pace_with_reordering(void **state) {
    gs_simnet *sim = simnet_new(1);
    gs_world *w[2];
    gs_agent *a[2];
    gs_net *net[2];
    toy ty[2];
    gs_link_desc l;
    double rtt_max = 0.0, lead = 0.0;
    int h, k, rtt_over = 0;
    (void)state;
    memset(ty, 0, sizeof ty);
    for (h = 0; h < 2; ++h) {
        gs_custom_desc cd;
        memset(&cd, 0, sizeof cd);
        cd.dt = 0.002;
        cd.state_size = 3;
        cd.step = toy_step;
        cd.get_state = toy_get;
        cd.set_state = toy_set;
        cd.user = &ty[h];
        ty[h].x[0] = h; /* the hosts disagree by 1 (unit) */
        w[h] = world_new((uint32_t)h + 1);
        assert_int_equal(gs_custom_create(w[h], &cd, &a[h]), GS_OK);
        ghost_on(a[h], 5);
        assert_int_equal(test_join(sim, w[h], NULL, &net[h]), GS_OK);
    }
    memset(&l, 0, sizeof l);
    l.latency = 0.1;  /* s */
    l.reorder = 0.1;  /* 10% held back by up to another 0.1 s */
    link_both(sim, 1, 2, &l);
    for (k = 1; k <= 60 * 60; ++k) { /* 60 s */
        gs_peer_stats ps;
        assert_int_equal(gs_simnet_run(sim, FRAME, FRAME), GS_OK);
        assert_int_equal(gs_net_peer_stats(net[0], 2, &ps), GS_OK);
        if (ps.rtt > rtt_max) rtt_max = ps.rtt;
        /* see test_stats_on_simnet: the true rtt is 0.2 s plus at most two
           frames. An estimator may stray by a held-back datagram's extra
           delay now and then (smoothing), not by a whole latency: 50 ms of
           slack */
        if (ps.rtt > 0.2 + 2.0 * FRAME + 0.05) rtt_over++;
        for (h = 0; h < 2; ++h) {
            double d = fabs(gs_agent_time(a[h]) - gs_simnet_time(sim));
            if (d > lead) lead = d;
        }
    }
    print_message("reordering 10%%, 100 ms: rtt up to %.4f s (true <= %.4f s; %d of 3600 "
                  "frames over it by 50 ms), hosts up to %.4f s off the clock in 60 s\n",
                  rtt_max, 0.2 + 2.0 * FRAME, rtt_over, lead);
    for (h = 0; h < 2; ++h) gs_world_destroy(w[h]);
    gs_simnet_destroy(sim);
    assert_int_equal(rtt_over, 0);
    /* an agent may lead its world's clock by the tolerance and a step
       (12 ms) before the clock follows it; 50 ms leaves room for a blend */
    assert_true(lead < 0.05);
}

/* ---- the application's own transport ---- */

#define MAILBOX 256

typedef struct mailbox {
    unsigned char data[MAILBOX][GS_WIRE_MAX_DATAGRAM];
    size_t size[MAILBOX];
    int count;
    long overflow;
} mailbox;

/* The send callback: keeps the datagram for the test to carry over. */
static gs_result mailbox_send(void *user, uint32_t host, const void *data, size_t size) {
    mailbox *m = (mailbox *)user;
    (void)host;
    if (m->count == MAILBOX || size > GS_WIRE_MAX_DATAGRAM) {
        m->overflow++;
        return GS_ERR_CAPACITY;
    }
    memcpy(m->data[m->count], data, size);
    m->size[m->count++] = size;
    return GS_OK;
}

static void test_own_transport(void **state) {
    mailbox *box = (mailbox *)calloc(2, sizeof *box); /* box[h]: what h sent */
    gs_world *w[2];
    gs_agent *c[2];
    gs_net *net[2];
    double g = 1.0, t_below = -1.0;
    long delivered = 0;
    int h, k, i;
    (void)state;
    assert_non_null(box);
    for (h = 0; h < 2; ++h) {
        gs_net_desc nd;
        w[h] = world_new((uint32_t)h + 1);
        c[h] = cloth_new(w[h], 0.0);
        ghost_on(c[h], 1);
        memset(&nd, 0, sizeof nd);
        nd.transport.send = mailbox_send;
        nd.transport.user = &box[h];
        assert_int_equal(gs_net_create(w[h], &nd, &net[h]), GS_OK);
        assert_int_equal(gs_net_add_peer(net[h], 2 - (uint32_t)h, NULL), GS_OK);
        assert_true(gs_world_net(w[h]) == net[h]);
    }
    nudge_particle(c[1], 0, 0.01);
    for (k = 1; k <= 3 * 60; ++k) { /* 3 s; the "wire" takes one frame */
        double now = k * FRAME;
        for (h = 0; h < 2; ++h) {
            assert_int_equal(gs_world_advance(w[h], FRAME, NULL), GS_OK);
            assert_int_equal(gs_net_update(net[h], now), GS_OK);
        }
        for (h = 0; h < 2; ++h) {
            for (i = 0; i < box[h].count; ++i) {
                assert_int_equal(gs_net_deliver(net[1 - h], box[h].data[i], box[h].size[i],
                                                now, NULL), GS_OK);
                delivered++;
            }
            box[h].count = 0;
        }
        g = mesh_gap(c[0], c[1]);
        if (g >= 1e-6) t_below = -1.0;
        else if (t_below < 0.0) t_below = now;
    }
    print_message("own transport: %ld datagrams carried, gap %.2e m after 3 s, below 1e-6 m "
                  "from %.2f s\n", delivered, g, t_below);
    assert_int_equal(box[0].overflow + box[1].overflow, 0);
    assert_true(delivered > 0);
    assert_true(g < 1e-9); /* as on the perfect simnet: rounding only */
    for (h = 0; h < 2; ++h) gs_world_destroy(w[h]);
    free(box);
}

/* ---- net API errors ---- */

static void test_net_errors(void **state) {
    gs_world *w = world_new(1), *w2 = world_new(2);
    gs_net *net = NULL, *net2 = NULL;
    gs_net_desc nd;
    gs_peer_stats ps;
    int i;
    (void)state;
    memset(&nd, 0, sizeof nd);
    assert_int_equal(gs_net_create(w, &nd, &net), GS_ERR_INVALID_ARG); /* no send */
    assert_null(net);
    nd.transport.send = drop_send;
    nd.bandwidth = -1.0;
    assert_int_equal(gs_net_create(w, &nd, &net), GS_ERR_INVALID_ARG);
    nd.bandwidth = 0.0;
    nd.time_window = NAN;
    assert_int_equal(gs_net_create(w, &nd, &net), GS_ERR_NOT_FINITE);
    nd.time_window = 0.0;
    nd.max_peers = 2;
    assert_int_equal(gs_net_create(w, &nd, &net), GS_OK);
    assert_int_equal(gs_net_create(w, &nd, &net2), GS_ERR_INVALID_ARG); /* has one */
    assert_int_equal(gs_net_add_peer(net, 0, NULL), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_add_peer(net, 1, NULL), GS_ERR_INVALID_ARG); /* itself */
    assert_int_equal(gs_net_add_peer(net, 2, NULL), GS_OK);
    assert_int_equal(gs_net_add_peer(net, 2, NULL), GS_OK); /* again: nothing new */
    assert_int_equal(gs_net_add_peer(net, 3, NULL), GS_OK);
    assert_int_equal(gs_net_add_peer(net, 4, NULL), GS_ERR_CAPACITY);
    assert_int_equal(gs_net_peer_stats(net, 4, &ps), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_remove_peer(net, 3), GS_OK);
    assert_int_equal(gs_net_remove_peer(net, 3), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_add_peer(net, 4, NULL), GS_OK);
    assert_int_equal(gs_net_update(net, NAN), GS_ERR_NOT_FINITE);
    assert_int_equal(gs_net_update(net, 1.0), GS_OK);
    /* peers up to the limit, then capacity */
    nd.max_peers = 0; /* default 16 */
    assert_int_equal(gs_net_create(w2, &nd, &net2), GS_OK);
    for (i = 0; i < 16; ++i) assert_int_equal(gs_net_add_peer(net2, 100 + (uint32_t)i, NULL), GS_OK);
    assert_int_equal(gs_net_add_peer(net2, 200, NULL), GS_ERR_CAPACITY);
    gs_net_destroy(net2);
    assert_null(gs_world_net(w2));
    gs_world_destroy(w); /* with its net */
    gs_world_destroy(w2);
}

static void test_simnet_errors(void **state) {
    gs_simnet *sim = NULL;
    gs_simnet_desc sd;
    gs_world *w = world_new(1), *w2 = world_new(1);
    gs_net *net = NULL;
    gs_link_desc l;
    (void)state;
    memset(&sd, 0, sizeof sd);
    sd.max_in_flight = -1;
    assert_int_equal(gs_simnet_create(&sd, &sim), GS_ERR_INVALID_ARG);
    assert_null(sim);
    assert_int_equal(gs_simnet_create(NULL, &sim), GS_OK);
    assert_int_equal(test_join(sim, w, NULL, &net), GS_OK);
    assert_int_equal(test_join(sim, w2, NULL, &net), GS_ERR_INVALID_ARG); /* host 1 again */
    memset(&l, 0, sizeof l);
    assert_int_equal(gs_simnet_link(sim, 1, 5, &l), GS_ERR_INVALID_ARG); /* no host 5 */
    l.loss = 1.5;
    assert_int_equal(gs_simnet_link(sim, 1, 1, &l), GS_ERR_INVALID_ARG);
    l.loss = 0.0;
    l.latency = -1.0;
    assert_int_equal(gs_simnet_link(sim, 1, 1, &l), GS_ERR_INVALID_ARG);
    l.latency = 0.0;
    l.outage_start[1] = NAN;
    assert_int_equal(gs_simnet_link(sim, 1, 1, &l), GS_ERR_NOT_FINITE);
    assert_int_equal(gs_simnet_run(sim, -1.0, FRAME), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_simnet_run(sim, 1.0, 0.0), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_simnet_run(sim, 0.5, 0.1), GS_OK);
    assert_true(fabs(gs_simnet_time(sim) - 0.5) < 1e-12);
    gs_world_destroy(w);
    gs_world_destroy(w2);
    gs_simnet_destroy(sim);
}

/* ---- UDP on loopback ---- */
#ifndef GHOSTSIM_NO_UDP

/* Sleeps until the wall clock reaches `until` (s, gs_udp_now's clock). */
static void sleep_until(double until) {
    double now = gs_udp_now();
    if (until > now) {
        struct timespec ts;
        double d = until - now;
        ts.tv_sec = (time_t)d;
        ts.tv_nsec = (long)((d - (double)ts.tv_sec) * 1e9);
        nanosleep(&ts, NULL);
    }
}

typedef struct udp_pair {
    gs_world *w[2];
    gs_agent *c[2];
    gs_net *u[2];
} udp_pair;

/* Two worlds of one cloth each on two sockets; host 2's cloth, pins and
   all, hangs 5 cm higher. Each cloth first settles alone for 3 s (a cloth
   that still swings leaves a residual of millimetres that follows the
   swing: the two hosts' frames are not simultaneous on a real clock).
   Peers are added unless no_peers. */
static void udp_pair_open(udp_pair *p, const char *a1, const char *a2, int threads, int no_peers) {
    const char *addr[2];
    int h;
    addr[0] = a1;
    addr[1] = a2;
    memset(p, 0, sizeof *p);
    for (h = 0; h < 2; ++h) {
        gs_udp_desc ud;
        gs_result r;
        p->w[h] = world_new((uint32_t)h + 1);
        p->c[h] = cloth_new(p->w[h], 0.05 * h);
        ghost_on(p->c[h], 1);
        assert_int_equal(gs_world_advance(p->w[h], 3.0, NULL), GS_OK);
        memset(&ud, 0, sizeof ud);
        ud.bind = addr[h];
        ud.threads = threads;
        r = test_udp_open(p->w[h], &ud, NULL, &p->u[h]);
        if (r != GS_OK) print_error("udp net %s: %s\n", addr[h], gs_world_error(p->w[h]));
        assert_int_equal(r, GS_OK);
    }
    if (!no_peers)
        for (h = 0; h < 2; ++h)
            assert_int_equal(gs_net_add_peer(p->u[h], 2 - (uint32_t)h, addr[1 - h]), GS_OK);
}

static void udp_pair_close(udp_pair *p) {
    int h;
    for (h = 0; h < 2; ++h) {
        gs_net_destroy(p->u[h]); /* joins the threads; before the world goes */
        gs_world_destroy(p->w[h]);
    }
}

/* Runs up to max_frames frames paced at FRAME of wall time; stops once the
   gap has stayed below `below` for 30 frames. Returns the gap at the end;
   *frames_run gets the frames run. */
static double udp_pair_run(udp_pair *p, int max_frames, double below, int *frames_run) {
    double next = gs_udp_now(), g = 1.0;
    int k, good = 0, h;
    for (k = 1; k <= max_frames; ++k) {
        for (h = 0; h < 2; ++h) {
            assert_int_equal(gs_world_advance(p->w[h], FRAME, NULL), GS_OK);
            assert_int_equal(gs_net_poll(p->u[h], gs_udp_now()), GS_OK);
        }
        g = mesh_gap(p->c[0], p->c[1]);
        good = g < below ? good + 1 : 0;
        if (good >= 30) break;
        next += FRAME;
        sleep_until(next);
    }
    *frames_run = k > max_frames ? max_frames : k;
    return g;
}

static void udp_converge(const char *a1, const char *a2, int threads, const char *label) {
    udp_pair p;
    gs_peer_stats ps;
    int frames;
    double g;
    udp_pair_open(&p, a1, a2, threads, 0);
    g = udp_pair_run(&p, 240, 1e-4, &frames);
    assert_int_equal(gs_net_peer_stats(p.u[0], 2, &ps), GS_OK);
    print_message("udp %s: gap %.2e m after %.2f s; rx %llu snapshots, rejected %llu, "
                  "rtt %.2f ms\n", label, g, frames * FRAME,
                  (unsigned long long)ps.snapshots_received,
                  (unsigned long long)ps.rejected_total, ps.rtt * 1e3);
    /* 5 cm apart at the start; the brief's bound, held for 30 frames.
       Measured on an idle machine: from 0.2 s on with threads, ~1.5 s in
       poll mode (there a datagram waits for the receiver's next poll, up
       to a frame); up to 4 s are allowed for a loaded machine. Under
       valgrind (50x slower, one thread at a time) the run is for leaks and
       races: CI saw round trips of 3.4 s there and the gap at 1.03e-3 m,
       so it asks only that the hosts came a fifth of the way together. */
    assert_true(g < (UNDER_VALGRIND() ? 1e-2 : 1e-4));
    assert_true(ps.snapshots_received > 0);
    assert_int_equal(ps.rejected_total, 0);
    udp_pair_close(&p);
}

static void test_udp_threads(void **state) {
    char a[2][64];
    (void)state;
    assert_true(loopback_addr(0, a[0], sizeof a[0]) && loopback_addr(0, a[1], sizeof a[1]));
    udp_converge(a[0], a[1], 1, "threads");
}

static void test_udp_poll(void **state) {
    char a[2][64];
    (void)state;
    assert_true(loopback_addr(0, a[0], sizeof a[0]) && loopback_addr(0, a[1], sizeof a[1]));
    udp_converge(a[0], a[1], 0, "poll");
}

static void test_udp_ipv6(void **state) {
    char a[2][64];
    (void)state;
    if (!loopback_addr(1, a[0], sizeof a[0]) || !loopback_addr(1, a[1], sizeof a[1])) {
        print_message("udp ipv6: no IPv6 loopback here, skipped\n");
        skip();
    }
    udp_converge(a[0], a[1], 1, "ipv6 threads");
}

/* Peers come and go while the threads run. */
static void test_udp_peers_at_run_time(void **state) {
    udp_pair p;
    gs_peer_stats ps;
    gs_unknown_stats unk;
    uint64_t rx;
    int frames, i;
    double g;
    char a[2][64];
    (void)state;
    assert_true(loopback_addr(0, a[0], sizeof a[0]) && loopback_addr(0, a[1], sizeof a[1]));
    udp_pair_open(&p, a[0], a[1], 1, 1);
    /* nobody knows anybody: the cloths stay 5 cm apart */
    g = udp_pair_run(&p, 15, 0.0, &frames);
    assert_true(g > 0.04);
    /* host 2 learns host 1 first: host 1 refuses it as an unknown sender
       (within 4 s: under valgrind on a busy machine the first datagram can
       take more than the quarter second it takes here alone) */
    assert_int_equal(gs_net_add_peer(p.u[1], 1, a[0]), GS_OK);
    memset(&unk, 0, sizeof unk);
    for (i = 0; i < 16 && unk.rejected[GS_REJECT_SENDER] == 0; ++i) {
        udp_pair_run(&p, 15, 0.0, &frames);
        assert_int_equal(gs_net_unknown_stats(p.u[0], &unk), GS_OK);
    }
    assert_true(unk.rejected[GS_REJECT_SENDER] > 0);
    /* then both: they converge */
    assert_int_equal(gs_net_add_peer(p.u[0], 2, a[1]), GS_OK);
    g = udp_pair_run(&p, 240, 1e-4, &frames);
    print_message("udp peers at run time: gap %.2e m %.2f s after both knew each other\n", g,
                  frames * FRAME);
    /* as in udp_converge: under valgrind round trips take seconds */
    assert_true(g < (UNDER_VALGRIND() ? 1e-2 : 1e-4));
    /* replacing a peer's address is allowed */
    assert_int_equal(gs_net_add_peer(p.u[0], 2, a[1]), GS_OK);
    /* host 1 drops host 2: host 2 hears nothing more from host 1 */
    assert_int_equal(gs_net_remove_peer(p.u[0], 2), GS_OK);
    assert_int_equal(gs_net_peer_stats(p.u[0], 2, &ps), GS_ERR_INVALID_ARG);
    /* What was on the wire still arrives: a quarter second here, but under
       valgrind the gather thread can lag seconds behind (CI saw 70 more
       datagrams after 6 frames). So: quarter seconds until one passes
       with nothing new, at most 40 (10 s); a host that kept sending
       would fill every one of them. */
    rx = UINT64_MAX;
    for (i = 0; i < 40; ++i) {
        assert_int_equal(gs_net_peer_stats(p.u[1], 1, &ps), GS_OK);
        if (ps.datagrams_received == rx) break;
        rx = ps.datagrams_received;
        udp_pair_run(&p, 15, 0.0, &frames);
    }
    assert_true(i < 40);
    assert_int_equal(gs_net_remove_peer(p.u[0], 2), GS_ERR_INVALID_ARG);
    udp_pair_close(&p);
}

/* The voluntary context switches of every thread of this process so far
   (Linux /proc), or -1 where they cannot be read. */
static long voluntary_switches(void) {
    DIR *d = opendir("/proc/self/task");
    struct dirent *e;
    long total = 0;
    if (!d) return -1;
    while ((e = readdir(d)) != NULL) {
        char path[300], line[256];
        FILE *f;
        if (e->d_name[0] == '.') continue;
        snprintf(path, sizeof path, "/proc/self/task/%s/status", e->d_name);
        f = fopen(path, "r");
        if (!f) continue;
        while (fgets(line, sizeof line, f))
            if (strncmp(line, "voluntary_ctxt_switches:", 24) == 0) total += atol(line + 24);
        fclose(f);
    }
    closedir(d);
    return total;
}

/* The scatter thread ticks every millisecond only while ghosts publish:
   an endpoint with nothing published for 0.1 s hardly wakes, and a ghost's
   snapshots still go out at its rate with nobody calling gs_net_poll.
   Ticking whatever was due, it made 569 switches in the 0.3 s below and
   cost bench/transport 15% of its rate on this project's 2-core machine. */
static void test_udp_scatter_sleeps(void **state) {
    gs_world *w = world_new(1), *w2 = world_new(2);
    gs_net *u = NULL, *u2 = NULL;
    gs_udp_desc ud;
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_agent *a = cloth_new(w, 0.0), *a2 = cloth_new(w2, 0.0);
    gs_peer_stats ps;
    char addr[2][64];
    long s0, s1;
    double t0;
    int k;
    (void)state;
    gd.object_id = 1;
    gd.send_rate = 20.0; /* Hz */
    assert_int_equal(gs_ghost_attach(a, &gd), GS_OK);
    ghost_on(a2, 1);
    assert_true(loopback_addr(0, addr[0], sizeof addr[0]) &&
                loopback_addr(0, addr[1], sizeof addr[1]));
    memset(&ud, 0, sizeof ud);
    ud.threads = 1;
    ud.bind = addr[0];
    assert_int_equal(test_udp_open(w, &ud, NULL, &u), GS_OK);
    ud.bind = addr[1];
    assert_int_equal(test_udp_open(w2, &ud, NULL, &u2), GS_OK);
    assert_int_equal(gs_net_add_peer(u, 2, addr[1]), GS_OK);
    assert_int_equal(gs_net_add_peer(u2, 1, addr[0]), GS_OK);
    /* the ghosts' first B (at attach) goes out, and 0.1 s without a
       publish puts the scatter threads to sleep */
    sleep_until(gs_udp_now() + 0.2);

    /* idle: two endpoints, four threads, nothing published */
    s0 = voluntary_switches();
    sleep_until(gs_udp_now() + 0.3);
    s1 = voluntary_switches();
    if (s0 >= 0 && !UNDER_VALGRIND()) {
        print_message("udp idle: %ld voluntary switches in 0.3 s (4 threads)\n", s1 - s0);
        /* each thread sleeps up to 20 ms at a time (the gather threads'
           receive timeout, the scatter threads' idle bound): 4 x 15 = 60 */
        assert_true(s1 - s0 < 120);
    }

    /* 0.5 s of 5 ms frames and no gs_net_poll: 20 Hz is 10 snapshots */
    assert_int_equal(gs_net_peer_stats(u, 2, &ps), GS_OK);
    s0 = (long)ps.snapshots_sent;
    t0 = gs_udp_now();
    for (k = 1; k <= 100; ++k) {
        assert_int_equal(gs_world_advance(w, 0.005, NULL), GS_OK);
        sleep_until(t0 + 0.005 * k);
    }
    sleep_until(gs_udp_now() + 0.05);
    assert_int_equal(gs_net_peer_stats(u, 2, &ps), GS_OK);
    s1 = (long)ps.snapshots_sent - s0;
    print_message("udp 20 Hz ghost, no poll: %ld snapshots sent in 0.5 s\n", s1);
    /* 10, give or take one at either end of the window, and never more
       than the rate allows. Fewer on a loaded machine: frames that run late
       come in bursts, and a B published before the one held back by the
       rate went out replaces it (under valgrind, most of them) */
    assert_true(s1 <= 11 && s1 >= (UNDER_VALGRIND() ? 1 : 7));
    assert_int_equal(gs_net_peer_stats(u2, 1, &ps), GS_OK);
    assert_true(ps.snapshots_received > 0);
    gs_net_destroy(u);
    gs_net_destroy(u2);
    gs_world_destroy(w);
    gs_world_destroy(w2);
}

static void test_udp_errors(void **state) {
    /* numeric or local names only: no DNS lookup */
    static const char *bad[] = {"nonsense", "127.0.0.1:", "[::1", "[::1]47110", "",
                                "127.0.0.1:notaport", "300.1.2.3:47110"};
    gs_world *w = world_new(1), *w2 = world_new(2);
    gs_net *u = NULL, *u2 = NULL;
    gs_udp_desc ud;
    size_t i;
    char a[64], port[16];
    (void)state;
    assert_true(loopback_addr(0, a, sizeof a));
    strcpy(port, strchr(a, ':') + 1);
    memset(&ud, 0, sizeof ud);
    assert_int_equal(test_udp_open(w, &ud, NULL, &u), GS_ERR_INVALID_ARG); /* bind NULL */
    assert_null(u);
    for (i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
        gs_result r;
        ud.bind = bad[i];
        r = test_udp_open(w, &ud, NULL, &u);
        if (r != GS_ERR_INVALID_ARG) print_error("bind \"%s\": %d\n", bad[i], (int)r);
        assert_int_equal(r, GS_ERR_INVALID_ARG);
        assert_null(u);
        assert_true(strlen(gs_world_error(w)) > 0);
    }
    assert_null(gs_world_net(w)); /* nothing was left behind */
    /* a port in use */
    ud.bind = a;
    ud.threads = 1;
    assert_int_equal(test_udp_open(w, &ud, NULL, &u), GS_OK);
    assert_int_equal(test_udp_open(w2, &ud, NULL, &u2), GS_ERR_SYSTEM);
    assert_null(u2);
    print_message("port in use: \"%s\"\n", gs_world_error(w2));
    assert_non_null(strstr(gs_world_error(w2), port));
    assert_null(gs_world_net(w2));
    /* a bad peer address */
    assert_int_equal(gs_net_add_peer(u, 2, "nowhere"), GS_ERR_INVALID_ARG);
    assert_int_equal(gs_net_add_peer(u, 1, "127.0.0.1:47111"), GS_ERR_INVALID_ARG); /* itself */
    assert_int_equal(gs_net_poll(u, NAN), GS_ERR_NOT_FINITE);
    gs_net_destroy(u); /* joins its threads and frees the port: */
    ud.threads = 0;
    assert_int_equal(test_udp_open(w2, &ud, NULL, &u2), GS_OK);
    assert_true(gs_world_net(w2) == u2);
    gs_net_destroy(u2);
    gs_world_destroy(w);
    gs_world_destroy(w2);
}
#endif /* GHOSTSIM_NO_UDP */

int main(int argc, char **argv) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_simnet_determinism),
        cmocka_unit_test(test_converge_perfect_link),
        cmocka_unit_test(test_converge_bad_link),
        cmocka_unit_test(test_scene_perfect_and_bad),
        cmocka_unit_test(test_outage),
        cmocka_unit_test(test_late_joiner),
        cmocka_unit_test(test_malformed_datagrams),
        cmocka_unit_test(test_time_window_before_first_step),
        cmocka_unit_test(test_short_last_chunk),
        cmocka_unit_test(test_sequence_wrap),
        cmocka_unit_test(test_stats_on_simnet),
        cmocka_unit_test(test_pace_with_reordering),
        cmocka_unit_test(test_own_transport),
        cmocka_unit_test(test_net_errors),
        cmocka_unit_test(test_simnet_errors),
#ifndef GHOSTSIM_NO_UDP
        cmocka_unit_test(test_udp_threads),
        cmocka_unit_test(test_udp_poll),
        cmocka_unit_test(test_udp_ipv6),
        cmocka_unit_test(test_udp_peers_at_run_time),
        cmocka_unit_test(test_udp_scatter_sleeps),
        cmocka_unit_test(test_udp_errors),
#endif
    };
    if (argc > 1) cmocka_set_test_filter(argv[1]);
    return cmocka_run_group_tests_name("net", tests, NULL, NULL);
}
