/* test_probepace.c - a probe's pace (>>rigid, gs__probe_step): a host
   that catches up many frames in one gs_world_advance moves its probe as
   a host that advanced frame by frame did (issue 15).

   The paper's scene (gs_scene_create: cloth, 3 spheres, one probe), driven
   as ghostpeer drives it: before each advance the probe's target is its
   scripted path at the cloth's time, then one frame (1/60 s). The smooth
   run advances every frame; the burst run is descheduled for BURST frames
   once while the probe pushes into the cloth (the path dips to its lowest
   at 1 s): its application sets the target once, and one advance catches
   up the BURST frames, as a host under load does. Before the pace, the
   target of the frame after the burst was a burst's distance away and the
   probe took it at max_speed (5 m/s in the scene, about 8 times the
   path's speed): the cloth it pushed threw the spheres, and the two runs
   ended apart; the smooth run's other host saw a smooth path. */
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
#include "world_helpers.h"

#define FRAME (1.0 / 60.0)
#define FRAMES 240     /* 4 s: the probes' 2 s of path, then 2 s parked */
#define BURST_AT 48    /* frame: 0.8 s, the probe on its way down into
                          the cloth */
#define PARK_AT 120    /* frame: 2 s; then it hangs above where it stopped */

typedef struct run_out {
    double probe_peak;  /* m/s, the probe's fastest step */
    double sphere_peak; /* m/s, the fastest sphere at a frame's end */
    gs_vec3 sphere[GS_SCENE_MAX_SPHERES];
    int spheres;
    uint64_t hash;
} run_out;

typedef struct watch {
    const gs_agent *probe;
    double peak;
} watch;

/* The probe's behaviour rule, only to see each of its steps. */
static int watch_probe(const gs_behaviour_in *in, void *user) {
    watch *wt = (watch *)user;
    gs_vec3 v = gs_rigid_velocity(wt->probe);
    wt->peak = fmax(wt->peak, sqrt(v.x * v.x + v.y * v.y + v.z * v.z));
    return gs_behaviour_default(in, NULL);
}

static double speed(const gs_agent *a) {
    gs_vec3 v = gs_rigid_velocity(a);
    return sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
}

/* ghostpeer's drive_probe: the path until PARK_AT, then parked 0.4 m up */
static void drive(gs_scene *sc, int f) {
    const gs_quat id = {0.0, 0.0, 0.0, 1.0};
    gs_vec3 p = gs_scene_probe_path(0, f < PARK_AT ? gs_agent_time(sc->cloth) : PARK_AT * FRAME);
    if (f >= PARK_AT) p.y = 0.4;
    assert_int_equal(gs_probe_set_target(sc->probes[0], p, id), GS_OK);
}

/* burst: frames caught up in one advance at BURST_AT (0: the smooth run) */
static void run_scene_at(int at, int burst, run_out *o) {
    gs_world *w = world_new(1);
    gs_scene_desc sd = gs_scene_desc_default();
    gs_scene sc;
    watch wt;
    int f, i;
    memset(o, 0, sizeof *o);
    sd.probe_count = 1;
    assert_int_equal(gs_scene_create(w, &sd, &sc), GS_OK);
    wt.probe = sc.probes[0];
    wt.peak = 0.0;
    gs_agent_set_behaviour(sc.probes[0], watch_probe, &wt);
    for (f = 0; f < FRAMES;) {
        int k = burst > 0 && f == at ? burst : 1;
        gs_result r;
        drive(&sc, f);
        r = gs_world_advance(w, k * FRAME, NULL);
        assert_true(r == GS_OK || r == GS_ERR_UNSTABLE);
        f += k;
        for (i = 0; i < sc.sphere_count && f > at; ++i)
            o->sphere_peak = fmax(o->sphere_peak, speed(sc.spheres[i]));
        /* the park's lift is a jump the application asked for, not a catch-up */
        if (f < PARK_AT) o->probe_peak = fmax(o->probe_peak, wt.peak);
        wt.peak = 0.0;
    }
    o->spheres = sc.sphere_count;
    for (i = 0; i < sc.sphere_count; ++i) o->sphere[i] = gs_rigid_position(sc.spheres[i]);
    o->hash = gs_world_hash(w);
    gs_world_destroy(w);
}

static void run_scene(int burst, run_out *o) { run_scene_at(BURST_AT, burst, o); }

/* The path's fastest: 0.6 m/s round the circle and 0.38 m/s down into the
   cloth, 0.71 m/s together at most. */
static double path_peak(void) {
    double peak = 0.0;
    int f;
    for (f = 0; f < PARK_AT * 10; ++f) {
        gs_vec3 a = gs_scene_probe_path(0, f * 1e-3), b = gs_scene_probe_path(0, (f + 1) * 1e-3);
        peak = fmax(peak, sqrt((b.x - a.x) * (b.x - a.x) + (b.y - a.y) * (b.y - a.y) +
                               (b.z - a.z) * (b.z - a.z)) / 1e-3);
    }
    return peak;
}

static double apart(const run_out *a, const run_out *b) {
    double d = 0.0;
    int i;
    for (i = 0; i < a->spheres; ++i) {
        gs_vec3 p = a->sphere[i], q = b->sphere[i];
        d = fmax(d, sqrt((p.x - q.x) * (p.x - q.x) + (p.y - q.y) * (p.y - q.y) + (p.z - q.z) * (p.z - q.z)));
    }
    return d;
}


/* ---- two hosts: the descheduled one and its peer ---- */

#define MAIL 512 /* datagrams in flight to a host, at most */

typedef struct mailbox {
    unsigned char data[MAIL][GS_WIRE_MAX_DATAGRAM];
    size_t size[MAIL];
    int n;
} mailbox;

typedef struct duo {
    gs_world *w[2];
    gs_scene sc[2];
    gs_net *net[2];
    mailbox *box; /* [2]: what waits for host k + 1 */
    double last[2];
} duo;

/* The transport: a datagram to host h waits in its box until its next
   frame (no loss, a frame of latency at most). */
static gs_result mail_send(void *user, uint32_t host, const void *data, size_t size) {
    mailbox *box = (mailbox *)user;
    mailbox *b = &box[host - 1];
    if (host < 1 || host > 2 || b->n == MAIL || size > GS_WIRE_MAX_DATAGRAM) return GS_OK;
    memcpy(b->data[b->n], data, size);
    b->size[b->n++] = size;
    return GS_OK;
}

static void duo_new(duo *d) {
    gs_scene_desc sd = gs_scene_desc_default();
    gs_ghost_desc gd = gs_ghost_desc_default();
    int k;
    memset(d, 0, sizeof *d);
    d->box = (mailbox *)calloc(2, sizeof *d->box);
    assert_non_null(d->box);
    sd.probe_count = 2;
    for (k = 0; k < 2; ++k) {
        gs_net_desc nd = gs_net_desc_default();
        d->w[k] = world_new((uint32_t)k + 1);
        assert_int_equal(gs_scene_create(d->w[k], &sd, &d->sc[k]), GS_OK);
        assert_int_equal(gs_scene_attach_ghosts(&d->sc[k], &gd), GS_OK);
        memset(&nd.transport, 0, sizeof nd.transport);
        nd.transport.send = mail_send;
        nd.transport.user = d->box;
        assert_int_equal(gs_net_create(d->w[k], &nd, &d->net[k]), GS_OK);
        assert_int_equal(gs_net_add_peer(d->net[k], 2 - (uint32_t)k, NULL), GS_OK);
    }
}

static void duo_free(duo *d) {
    gs_world_destroy(d->w[0]);
    gs_world_destroy(d->w[1]);
    free(d->box);
}

/* Host k's frame at wall time now: what arrived, its own probe's target
   (ghostpeer's drive), the advance to now, the sends. */
static void duo_frame(duo *d, int k, int f, double now) {
    const gs_quat id = {0.0, 0.0, 0.0, 1.0};
    mailbox *b = &d->box[k];
    gs_vec3 p;
    gs_result r;
    int i;
    for (i = 0; i < b->n; ++i) {
        gs_reject why;
        gs_net_deliver(d->net[k], b->data[i], b->size[i], now, &why);
    }
    b->n = 0;
    p = gs_scene_probe_path(k, f < PARK_AT ? gs_agent_time(d->sc[k].cloth) : PARK_AT * FRAME);
    if (f >= PARK_AT) p.y = 0.4;
    assert_int_equal(gs_probe_set_target(d->sc[k].probes[k], p, id), GS_OK);
    r = gs_world_advance(d->w[k], now - d->last[k], NULL);
    assert_true(r == GS_OK || r == GS_ERR_UNSTABLE);
    d->last[k] = now;
    assert_int_equal(gs_net_update(d->net[k], now), GS_OK);
}

/* The two hosts' spheres apart at the end (m); the fastest sphere of
   either after `at` (m/s); host 2's copy of host 1's probe, its largest
   move in a frame while the probe is on its path (m): it goes where host
   1's snapshots put it; host 1's probe, its largest distance at a frame's
   end from the target of the frame before (m), but over the burst and
   twice its time after it (the lag it leaves is made up at half the
   pace) and 6 frames. Host 1 misses `burst` - 1 frames from `at` on
   and catches them up in one advance. */
static double duo_run(int at, int burst, double *fastest, double *jump, double *behind) {
    duo d;
    double gap = 0.0;
    gs_vec3 was;
    int f, k, i;
    duo_new(&d);
    *fastest = *jump = *behind = 0.0;
    was = gs_rigid_position(d.sc[1].probes[0]);
    for (f = 0; f < FRAMES; ++f) {
        double now = (f + 1) * FRAME;
        gs_vec3 c;
        for (k = 0; k < 2; ++k) {
            if (k == 0 && burst > 1 && f >= at && f < at + burst - 1) continue;
            duo_frame(&d, k, f, now);
            for (i = 0; i < d.sc[k].sphere_count && f >= at; ++i)
                *fastest = fmax(*fastest, speed(d.sc[k].spheres[i]));
        }
        if (f < PARK_AT && !(f >= at && f < at + 3 * burst + 6)) { /* host 1's probe on its path */
            gs_vec3 p = gs_rigid_position(d.sc[0].probes[0]);
            gs_vec3 q = gs_scene_probe_path(0, gs_agent_time(d.sc[0].cloth) - FRAME);
            *behind = fmax(*behind, sqrt((p.x - q.x) * (p.x - q.x) + (p.y - q.y) * (p.y - q.y) +
                                         (p.z - q.z) * (p.z - q.z)));
        }
        c = gs_rigid_position(d.sc[1].probes[0]);
        if (f < PARK_AT && f > 0)
            *jump = fmax(*jump, sqrt((c.x - was.x) * (c.x - was.x) + (c.y - was.y) * (c.y - was.y) +
                                     (c.z - was.z) * (c.z - was.z)));
        was = c;
    }
    for (i = 0; i < d.sc[0].sphere_count; ++i) {
        gs_vec3 p = gs_rigid_position(d.sc[0].spheres[i]), q = gs_rigid_position(d.sc[1].spheres[i]);
        gap = fmax(gap, sqrt((p.x - q.x) * (p.x - q.x) + (p.y - q.y) * (p.y - q.y) +
                             (p.z - q.z) * (p.z - q.z)));
    }
    duo_free(&d);
    return gap;
}

/* One host, bursts of 6 and 12 frames (100 and 200 ms, what a host
   descheduled at load 10 catches up) against the smooth run. The probe's
   fastest step stays within the pace's gain (1.5) of the path's fastest,
   and a little more for a pace read over a frame of 16 steps of 2 ms where
   the path was sampled 16.7 ms apart: 1.6 times (it was the scene's
   max_speed, 5 m/s, in every frame, smooth or not: each frame's 1.2 cm in
   two or three steps). The spheres are not thrown, with the pace or
   without (measured 0.29 m/s at most before it, 0.31 with it): their
   fastest at a frame's end after the burst within twice the smooth run's
   and 0.1 m/s more. Where they come to rest differs by a centimetre or more
   from the smooth run's with the pace or without (they settle in one of
   the hollow's places; printed). The same burst twice gives the same
   hash. */
static void test_burst_one_host(void **state) {
    run_out smooth, burst[2], again;
    const int bursts[2] = {6, 12};
    double peak = path_peak();
    int b;
    (void)state;
    run_scene(0, &smooth);
    print_message("path's fastest %.3f m/s; smooth: probe's fastest step %.3f m/s, spheres' "
                  "fastest %.3f m/s from %.2f s on\n", peak, smooth.probe_peak, smooth.sphere_peak,
                  BURST_AT * FRAME);
    for (b = 0; b < 2; ++b) {
        run_scene(bursts[b], &burst[b]);
        print_message("burst of %d frames: probe's fastest step %.3f m/s, spheres' fastest "
                      "%.3f m/s, spheres %.4f m from the smooth run's at rest\n", bursts[b],
                      burst[b].probe_peak, burst[b].sphere_peak, apart(&smooth, &burst[b]));
    }
    run_scene(bursts[1], &again);
    assert_true(smooth.probe_peak <= 1.6 * peak);
    for (b = 0; b < 2; ++b) {
        assert_true(burst[b].probe_peak <= 1.6 * peak);
        assert_true(burst[b].sphere_peak <= 2.0 * smooth.sphere_peak + 0.1);
    }
    assert_true(again.hash == burst[1].hash);
}

/* Two hosts, present mode, a frame of latency: host 1 descheduled for 6,
   12 and 24 frames once while its probe dips into the cloth. Host 1's
   probe follows its path, within a frame's move (1.2 cm) of the target of
   the frame before at every frame's end (2 cm asked; measured 0.9 mm)
   but while it makes up a burst's lag, where before it
   stood still wherever the blend of its own ghost put it (that blend set
   its state, and the state set its target: measured 14 cm behind) and
   took the target of a frame without a blend at 5 m/s. So host 2's copy
   of it moves at most 3 frames' worth of the path's fastest in a frame
   (3.5 cm; measured 2.8: a snapshot of two frames, and the pace's gain):
   before, 8 cm, every 14 frames or so, and 8.4 cm after a burst. In this
   deterministic setting the spheres were not thrown either way (under
   0.8 m/s) and the hosts agree at rest within 0.1 mm (measured 0.07 mm at
   most), with the fix or without. */
static void test_burst_two_hosts(void **state) {
    const int bursts[4] = {1, 6, 12, 24};
    double peak = path_peak();
    int b;
    (void)state;
    for (b = 0; b < 4; ++b) {
        double fastest, jump, behind, gap = duo_run(BURST_AT, bursts[b], &fastest, &jump, &behind);
        print_message("host 1 %s %d frames: its probe %.4f m behind its target at most, host 2's "
                      "copy's largest move in a frame %.4f m, the spheres' fastest %.3f m/s, the "
                      "hosts' spheres %.2g m apart at rest\n",
                      bursts[b] > 1 ? "caught up" : "advanced every frame,", bursts[b], behind,
                      jump, fastest, gap);
        assert_true(behind < 0.02);
        assert_true(jump <= 3.0 * peak * FRAME);
        assert_true(fastest < 1.0);
        assert_true(gap < 1e-4);
    }
}

/* A target moved once after one long advance (the pace read over at most
   GS__PROBE_PACE_SPAN, 0.25 s) is reached within 0.25 s / 1.5 and a step.
   One moved after frames that set none is read over the last frame: it is
   reached within the frame, as one moved every frame is, at no more than
   1.5 times its pace. */
static void test_pace_after_pause(void **state) {
    gs_world *w = world_new(1);
    gs_probe_desc pd = gs_probe_desc_default();
    const gs_quat id = {0.0, 0.0, 0.0, 1.0};
    gs_agent *p;
    watch wt;
    int f;
    (void)state;
    pd.shape.type = GS_SHAPE_SPHERE;
    pd.shape.radius = 0.05;
    assert_int_equal(gs_probe_create(w, &pd, &p), GS_OK);
    wt.probe = p;
    wt.peak = 0.0;
    gs_agent_set_behaviour(p, watch_probe, &wt);
    assert_int_equal(gs_world_advance(w, 2.0, NULL), GS_OK); /* a pause */
    assert_int_equal(gs_probe_set_target(p, v3(0.1, 0.0, 0.0), id), GS_OK);
    assert_int_equal(gs_world_advance(w, 0.25 / 1.5 + 0.002, NULL), GS_OK);
    assert_true(gs_rigid_position(p).x == 0.1);
    print_message("moved 0.1 m after a 2 s advance: the probe's fastest step %.3f m/s\n", wt.peak);
    assert_true(wt.peak <= 1.5 * 0.1 / 0.25 + 1e-9);
    for (f = 0; f < 10; ++f) assert_int_equal(gs_world_advance(w, FRAME, NULL), GS_OK);
    wt.peak = 0.0;
    for (f = 1; f <= 30; ++f) { /* 6 mm a frame: 0.36 m/s */
        assert_int_equal(gs_probe_set_target(p, v3(0.1 + 0.006 * f, 0.0, 0.0), id), GS_OK);
        assert_int_equal(gs_world_advance(w, FRAME, NULL), GS_OK);
        assert_true(fabs(gs_rigid_position(p).x - (0.1 + 0.006 * f)) < 1e-12);
    }
    print_message("moved every frame at 0.36 m/s after 10 frames at rest: the probe's fastest "
                  "step %.3f m/s\n", wt.peak);
    assert_true(wt.peak <= 1.5 * 0.006 / 0.016 + 1e-9);
    gs_world_destroy(w);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_burst_one_host),
        cmocka_unit_test(test_burst_two_hosts),
        cmocka_unit_test(test_pace_after_pause),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
