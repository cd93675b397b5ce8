/* test_rest.c - hosts that stop interacting converge: the paper's scene
   under the client/server rule on the simnet, in the fault suite's and
   the peer tests' scenarios (tests/faults.py, tests/peers.py), which run
   real processes and retry a failed run. Here every run is deterministic
   (the bad link with three simnet seeds).

   Each host drives its probe along the scripted path until PROBE_UNTIL
   seconds of its own simulation time, then parks it clear of the cloth
   (ghostpeer's --probe-until); the scenario's fault happens while the
   probes push; then the hosts are left alone and judged at the end. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ghostsim.h"
#include "net_helpers.h"

#define FRAME 0.005 /* s; ghostpeer's frame */
#define MAX_HOSTS 3

typedef struct session {
    gs_simnet *sim;
    int n;
    gs_world *w[MAX_HOSTS];
    gs_scene sc[MAX_HOSTS];
    double probe_until; /* s of each host's simulation time */
} session;

static void session_open(session *s, int n, uint64_t seed, const gs_link_desc *link,
                         double probe_until) {
    gs_scene_desc sd = gs_scene_desc_default();
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_simnet_desc simd = gs_simnet_desc_default();
    gs_net *net;
    int h, k;
    memset(s, 0, sizeof *s);
    s->n = n;
    s->probe_until = probe_until;
    gd.weight = gs_weight_cs;
    sd.probe_count = n;
    simd.seed = seed;
    assert_int_equal(gs_simnet_create(&simd, &s->sim), GS_OK);
    for (h = 0; h < n; ++h) {
        gs_world_desc wd = gs_world_desc_default();
        wd.host_id = (uint32_t)h + 1;
        assert_int_equal(gs_world_create(&wd, &s->w[h]), GS_OK);
        assert_int_equal(gs_scene_create(s->w[h], &sd, &s->sc[h]), GS_OK);
        assert_int_equal(gs_scene_attach_ghosts(&s->sc[h], &gd), GS_OK);
        assert_int_equal(test_join(s->sim, s->w[h], NULL, &net), GS_OK);
    }
    for (h = 0; h < n; ++h)
        for (k = 0; k < n; ++k)
            if (h != k)
                assert_int_equal(gs_simnet_link(s->sim, (uint32_t)h + 1, (uint32_t)k + 1, link),
                                 GS_OK);
}

static void session_close(session *s) {
    int h;
    for (h = 0; h < s->n; ++h) gs_world_destroy(s->w[h]);
    gs_simnet_destroy(s->sim);
}

/* Host h's probe at its time t: the scripted path until probe_until, then
   parked clear of the cloth (ghostpeer's probe_point). */
static gs_vec3 probe_point(const session *s, int h, double t) {
    gs_vec3 at = gs_scene_probe_path(h, t < s->probe_until ? t : s->probe_until);
    if (t >= s->probe_until) at.y = 0.4;
    return at;
}

static void drive_one(session *s, int h) {
    const gs_quat id = {0.0, 0.0, 0.0, 1.0};
    gs_probe_set_target(s->sc[h].probes[h], probe_point(s, h, gs_agent_time(s->sc[h].cloth)), id);
}

static void frame(session *s) {
    int h;
    for (h = 0; h < s->n; ++h) drive_one(s, h);
    assert_int_equal(gs_simnet_run(s->sim, FRAME, FRAME), GS_OK);
}

/* Host h's world on by `seconds` outside the simnet's frames, in one
   advance toward the target set before it, as ghostpeer runs a pacing
   clock that stepped. */
static void host_step(session *s, int h, double seconds) {
    drive_one(s, h);
    assert_int_equal(gs_world_advance(s->w[h], seconds, NULL), GS_OK);
}

static void run_until(session *s, double t) {
    while (gs_simnet_time(s->sim) < t - 0.5 * FRAME) frame(s);
}

static double dist(gs_vec3 a, gs_vec3 b) {
    return sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) + (a.z - b.z) * (a.z - b.z));
}

/* The largest distance between host 1's copy and another host's of any
   sphere or any cloth particle (m). */
static double session_gap(const session *s) {
    double worst = 0.0;
    int h, i, np = s->sc[0].desc.cloth_n * s->sc[0].desc.cloth_n;
    for (h = 1; h < s->n; ++h) {
        const gs_vec3 *a = gs_mesh_positions(s->sc[0].cloth), *b = gs_mesh_positions(s->sc[h].cloth);
        for (i = 0; i < s->sc[0].sphere_count; ++i)
            worst = fmax(worst, dist(gs_rigid_position(s->sc[0].spheres[i]),
                                     gs_rigid_position(s->sc[h].spheres[i])));
        for (i = 0; i < np; ++i) worst = fmax(worst, dist(a[i], b[i]));
    }
    return worst;
}

/* Runs to `end` and returns the largest gap over the last second; *settle
   gets the simnet time from which the gap stayed under 1e-6 m (HUGE_VAL:
   never), for the diagnosis printed. */
static double settle(session *s, double end, double *settle_at) {
    double worst = 0.0;
    *settle_at = HUGE_VAL;
    while (gs_simnet_time(s->sim) < end - 0.5 * FRAME) {
        double g;
        frame(s);
        g = session_gap(s);
        if (g >= 1e-6) *settle_at = HUGE_VAL;
        else if (*settle_at == HUGE_VAL) *settle_at = gs_simnet_time(s->sim);
        if (gs_simnet_time(s->sim) >= end - 1.0) worst = fmax(worst, g);
    }
    return worst;
}

static void report(const char *what, double arg, const session *s, double worst,
                   double at) {
    int h;
    printf("    %s %g: largest gap %.3g mm over the last second; under 1 um from ", what, arg,
           1e3 * worst);
    if (at == HUGE_VAL) printf("never");
    else printf("%.2f s", at);
    for (h = 1; h < s->n; ++h)
        printf("; host %d %+.1f ms from host 1", h + 1,
               1e3 * (gs_agent_time(s->sc[h].cloth) - gs_agent_time(s->sc[0].cloth)));
    printf("\n");
}

/* m: the fault suite's and the peer tests' figure (tests/faults.py,
   tests/peers.py). Not bitwise: under the client/server rule the host that
   follows copies the lead's snapshots, a latency and up to a send period
   old, at its own present, and steps on from them; the spheres and the
   cloth creep for tens of seconds before they rest (at 14 s still about
   1 mm/s), so the copies differ by that motion over the tens of ms between
   the hosts, micrometres to a fraction of a millimetre. A sphere thrown to
   the ground rolls at up to 1 m/s for seconds: tens of mm. */
#define TOL 1e-3

/* Every sphere still on the cloth (above the ground's 1.42 m below). */
static double lowest_sphere(const session *s) {
    double y = HUGE_VAL;
    int h, i;
    for (h = 0; h < s->n; ++h)
        for (i = 0; i < s->sc[h].sphere_count; ++i)
            y = fmin(y, gs_rigid_position(s->sc[h].spheres[i]).y);
    return y;
}
#define ON_CLOTH (-0.5) /* m: the cloth hangs at about -0.1 */

static void expect_rest(const session *s, double worst) {
    assert_true(lowest_sphere(s) > ON_CLOTH);
    assert_true(worst < TOL);
}

/* faults.py clock-fwd: host 2's pacing clock steps +2 s while the probes
   push; ghostpeer then runs the 2 s in one advance (host_step) toward the
   probe target it set before, and host 1 follows host 2 in a jump. Known
   to fail (issue 15): it runs only with GHOSTSIM_KNOWN_FAILURES=1. Steps
   at 1.5, 2.5, 2.75 and 3 s throw a sphere to the ground (20-70 mm apart
   at 14 s; at 2 s 0.37 mm). Each host's own probe, whose target jumps
   with its time, crosses a chord of its circle at 5 m/s, through the
   hollow where the spheres rest; a driver that puts the probe at its
   path's new point after a jump keeps the spheres on the cloth here
   (0.02-0.05 mm at all five). Between processes that is not enough: a
   sphere is thrown during the stepped host's catch-up even with the other
   host's probe parked clear of the cloth throughout, which this test,
   whose deliveries come between advances, does not reproduce. */
static void test_clock_step(void **state) {
    static const double at[] = {1.5, 2.0, 2.5, 2.75, 3.0};
    double gap[sizeof at / sizeof at[0]], low[sizeof at / sizeof at[0]];
    size_t i;
    (void)state;
    if (!getenv("GHOSTSIM_KNOWN_FAILURES")) {
        printf("    skipped: known to fail (issue 15); GHOSTSIM_KNOWN_FAILURES=1 runs it\n");
        skip();
    }
    for (i = 0; i < sizeof at / sizeof at[0]; ++i) {
        session s;
        gs_link_desc link;
        double worst, settled;
        memset(&link, 0, sizeof link);
        link.latency = 0.0005;
        session_open(&s, 2, 1, &link, 5.0);
        run_until(&s, at[i]);
        host_step(&s, 1, 2.0);
        worst = settle(&s, 14.0, &settled);
        report("+2 s at", at[i], &s, worst, settled);
        gap[i] = worst;
        low[i] = lowest_sphere(&s);
        session_close(&s);
    }
    for (i = 0; i < sizeof at / sizeof at[0]; ++i) {
        assert_true(low[i] > ON_CLOTH);
        assert_true(gap[i] < TOL);
    }
}

static gs_link_desc loopback(void) {
    gs_link_desc link;
    memset(&link, 0, sizeof link);
    link.latency = 0.0005; /* s: loopback through the suite's proxy */
    return link;
}

/* peers.py three: three hosts, probes until 3 s, 15 s. */
static void test_three(void **state) {
    session s;
    gs_link_desc link = loopback();
    double worst, at;
    (void)state;
    session_open(&s, 3, 1, &link, 3.0);
    worst = settle(&s, 15.0, &at);
    report("three, probes until", 3.0, &s, worst, at);
    expect_rest(&s, worst);
    session_close(&s);
}

/* faults.py cut: the link cut both ways from 2 s to 5 s, probes until 5 s:
   each host goes its own way, then one takes the other's states. */
static void test_cut(void **state) {
    session s;
    gs_link_desc link = loopback();
    double worst, at;
    (void)state;
    link.outage_start[0] = 2.0;
    link.outage_end[0] = 5.0;
    session_open(&s, 2, 1, &link, 5.0);
    worst = settle(&s, 14.0, &at);
    report("cut from 2 s to", 5.0, &s, worst, at);
    expect_rest(&s, worst);
    session_close(&s);
}

/* faults.py bad-link(-3): from 2 s to 5 s drop 20%, dup 10%, reorder 10%,
   25-75 ms each way; probes until 5 s. One simnet seed in make test, three
   in make test-slow (GHOSTSIM_SLOW_TESTS=1): each seed is ~5 s of CPU, and
   ten more under ASan. */
static void set_links(session *s, const gs_link_desc *link) {
    int h, k;
    for (h = 0; h < s->n; ++h)
        for (k = 0; k < s->n; ++k)
            if (h != k)
                assert_int_equal(gs_simnet_link(s->sim, (uint32_t)h + 1, (uint32_t)k + 1, link),
                                 GS_OK);
}

static void bad_link(int n) {
    uint64_t seed, seeds = getenv("GHOSTSIM_SLOW_TESTS") ? 3 : 1;
    for (seed = 1; seed <= seeds; ++seed) {
        session s;
        gs_link_desc good = loopback(), bad = loopback();
        double worst, at;
        bad.latency = 0.025;
        bad.jitter = 0.05;
        bad.loss = 0.2;
        bad.duplicate = 0.1;
        bad.reorder = 0.1;
        session_open(&s, n, seed, &good, 5.0);
        run_until(&s, 2.0);
        set_links(&s, &bad);
        run_until(&s, 5.0);
        set_links(&s, &good);
        worst = settle(&s, 14.0, &at);
        report(n == 2 ? "bad link, seed" : "bad link, 3 hosts, seed", (double)seed, &s, worst, at);
        expect_rest(&s, worst);
        session_close(&s);
    }
}

static void test_bad_link(void **state) {
    (void)state;
    bad_link(2);
}

static void test_bad_link_3(void **state) {
    (void)state;
    bad_link(3);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_clock_step),
        cmocka_unit_test(test_three),
        cmocka_unit_test(test_cut),
        cmocka_unit_test(test_bad_link),
        cmocka_unit_test(test_bad_link_3),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
