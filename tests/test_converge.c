/* test_converge.c - two hosts of the paper's scene under the client/server
   rule converge after a clock step, deterministically on the simnet.

   The fault suite's clock-fwd scenario (tests/faults.py: one ghostpeer's
   pacing clock steps +2 s) failed about one run in five on a loaded
   machine: the host that stepped catches up over a few frames, the other
   follows it, and the two are left in step but up to a whole time band
   apart (the host that stepped ahead). A snapshot waits up to a send
   period to be sent, which its age does not count, and the agents of a
   world spread over the tolerance, so each host sees the other older than
   it is: the host ahead saw the one behind past the band and led, while
   the one behind saw it inside the band, a tie that it won (the lowest
   id), and led too. Nobody copied anybody, and whatever differed then
   stayed (spheres 2.9 m apart here; 7-14 mm in the suite). And once the
   host ahead does copy the one behind, its clock must go back with the
   states it took (see expect_converged).

   Here the steps are made by hand on the simnet (gs_world_advance on one
   host between simnet runs: its world moves on, as ghostpeer's world does
   when its pacing clock jumps), at offsets inside the band (default
   tolerance 10 ms + one send period at 60 Hz = 26.7 ms). After the step
   one host's sphere is nudged 1 cm: under the client/server rule one of
   the two states must be imposed on the other, so the nudge either spreads
   or goes, and the copies end within TOL. Two hosts that both lead keep
   it: 10 mm apart. */
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

#define FRAME 0.005  /* s; ghostpeer's frame */
#define NUDGE 0.01   /* m */
/* m: the fault suite's convergence figure. The spheres rest on the cloth
   by then: the copies of hosts in step differ by the motion over the time
   between them (tens of ms, micrometres at rest); a nudge nobody takes
   over stays whole (10 mm). */
#define TOL 1e-3

typedef struct pair {
    gs_simnet *sim;
    gs_world *w[2];
    gs_scene sc[2];
} pair;

static void pair_open(pair *p) {
    gs_scene_desc sd = gs_scene_desc_default();
    gs_ghost_desc gd = gs_ghost_desc_default();
    gs_link_desc link;
    gs_net *net;
    int h;
    memset(p, 0, sizeof *p);
    gd.weight = gs_weight_cs;
    sd.probe_count = 2;
    memset(&link, 0, sizeof link);
    link.latency = 0.0005; /* s: loopback through the suite's proxy */
    assert_int_equal(gs_simnet_create(NULL, &p->sim), GS_OK);
    for (h = 0; h < 2; ++h) {
        gs_world_desc wd = gs_world_desc_default();
        wd.host_id = (uint32_t)h + 1;
        assert_int_equal(gs_world_create(&wd, &p->w[h]), GS_OK);
        assert_int_equal(gs_scene_create(p->w[h], &sd, &p->sc[h]), GS_OK);
        assert_int_equal(gs_scene_attach_ghosts(&p->sc[h], &gd), GS_OK);
        assert_int_equal(test_join(p->sim, p->w[h], NULL, &net), GS_OK);
    }
    assert_int_equal(gs_simnet_link(p->sim, 1, 2, &link), GS_OK);
    assert_int_equal(gs_simnet_link(p->sim, 2, 1, &link), GS_OK);
}

static void pair_close(pair *p) {
    gs_world_destroy(p->w[0]);
    gs_world_destroy(p->w[1]);
    gs_simnet_destroy(p->sim);
}

static void pair_run(pair *p, double seconds) {
    assert_int_equal(gs_simnet_run(p->sim, seconds, FRAME), GS_OK);
}

/* The largest distance between the hosts' copies of a sphere or of the
   cloth's centre particle (m). */
static double pair_gap(const pair *p) {
    double worst = 0.0;
    int i, n = p->sc[0].desc.cloth_n, mid = (n / 2) * n + n / 2;
    gs_vec3 a, b;
    for (i = 0; i <= p->sc[0].sphere_count; ++i) {
        if (i < p->sc[0].sphere_count) {
            a = gs_rigid_position(p->sc[0].spheres[i]);
            b = gs_rigid_position(p->sc[1].spheres[i]);
        } else {
            a = gs_mesh_positions(p->sc[0].cloth)[mid];
            b = gs_mesh_positions(p->sc[1].cloth)[mid];
        }
        worst = fmax(worst, sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) +
                                 (a.z - b.z) * (a.z - b.z)));
    }
    return worst;
}

static void nudge(gs_agent *sphere) {
    double s[14];
    assert_int_equal(gs_agent_get_state(sphere, s, 14), GS_OK);
    s[1] += NUDGE;
    assert_int_equal(gs_agent_set_state(sphere, s, 14), GS_OK);
}

/* Host N drives probe N-1 along the scripted path until `until` seconds
   of its simulation time, then parks it clear of the cloth (ghostpeer's
   --probe-until). */
static void drive(pair *p, double until) {
    const gs_quat id = {0.0, 0.0, 0.0, 1.0};
    int h;
    for (h = 0; h < 2; ++h) {
        double t = gs_agent_time(p->sc[h].cloth);
        gs_vec3 at = gs_scene_probe_path(h, t < until ? t : until);
        if (t >= until) at.y = 0.4;
        gs_probe_set_target(p->sc[h].probes[h], at, id);
    }
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* After the step (and the nudge): the copies within TOL over the last
   half second of `seconds`. Two hosts that both lead never mend anything:
   the nudge stays, or grows. A host in step that copies a lead it is
   ahead of and steps on from there, object by object as each snapshot
   says, kicks a sphere resting on the cloth now and then (up to 15 mm for
   a send period, measured, before the next copy mends it); the world's
   clock following its agents back ends that. The median is printed for a
   diagnosis. */
#define SAMPLES 100
static void expect_converged(pair *p, const char *what, double offset, double seconds,
                             double probe_until) {
    double gap[SAMPLES], end;
    int k;
    for (k = 0; k < (int)((seconds - 0.5) / FRAME + 0.5); ++k) {
        drive(p, probe_until);
        pair_run(p, FRAME);
    }
    for (k = 0; k < SAMPLES; ++k) {
        drive(p, probe_until);
        pair_run(p, FRAME);
        gap[k] = pair_gap(p);
    }
    end = gap[SAMPLES - 1];
    qsort(gap, SAMPLES, sizeof gap[0], cmp_double);
    printf("    %s %.0f ms: copies %.3g mm apart at the end, median %.3g mm, largest %.3g mm "
           "over the last 0.5 s; host 2 %+.1f ms from host 1\n", what, 1e3 * offset, 1e3 * end,
           1e3 * gap[SAMPLES / 2], 1e3 * gap[SAMPLES - 1],
           1e3 * (gs_agent_time(p->sc[1].cloth) - gs_agent_time(p->sc[0].cloth)));
    assert_true(end < TOL);
    assert_true(gap[SAMPLES - 1] < TOL);
}

/* Host 2's clock steps by `offset`, near the edge of the band (nobody's
   time is corrected), then host 2's sphere is nudged. */
static void test_step_inside_band(void **state) {
    static const double offsets[] = {0.016, 0.026};
    size_t i;
    (void)state;
    for (i = 0; i < sizeof offsets / sizeof offsets[0]; ++i) {
        pair p;
        pair_open(&p);
        pair_run(&p, 1.5);
        assert_int_equal(gs_world_advance(p.w[1], offsets[i], NULL), GS_OK);
        pair_run(&p, 0.5);
        nudge(p.sc[1].spheres[0]);
        expect_converged(&p, "host 2 ahead by", offsets[i], 1.5, 0.0);
        pair_close(&p);
    }
}

/* ghostpeer's +2 s step as it plays out on a loaded machine, the fault
   suite's clock-fwd with the probes pushing until 5 s: host 2 catches up
   over 20 frames of 0.1 s, and a remainder inside the band is left once
   host 1 has followed the last jump it saw past the band. The probes
   follow their paths into the cloth (they are not held back by the blend
   of their own ghosts), so the spheres take until about 7.5 s to rest
   after they park: measured, the copies' largest gap over the last half
   second is 1.09 mm after 6 s, 0.49 mm after 7 s, 0.083 mm after 8 s. */
static void test_step_caught_up_in_frames(void **state) {
    pair p;
    int k;
    (void)state;
    pair_open(&p);
    while (gs_simnet_time(p.sim) < 2.0) {
        drive(&p, 5.0);
        pair_run(&p, FRAME);
    }
    for (k = 0; k <= 20; ++k) {
        drive(&p, 5.0);
        assert_int_equal(gs_world_advance(p.w[1], k < 20 ? 0.1 : 0.005, NULL), GS_OK);
        pair_run(&p, FRAME);
    }
    expect_converged(&p, "+2 s in 20 frames, then", 0.005, 8.0, 5.0);
    pair_close(&p);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_step_inside_band),
        cmocka_unit_test(test_step_caught_up_in_frames),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
