/* test_stillbeat.c - a resting delta ghost whose state is the very one
   every peer acknowledged beats with a heartbeat, not its state (issue 16,
   bench/bandwidth spheres900).

   What must hold:
   - while one ghost of a net moves (its state goes every frame), the beat
     after it sends every resting delta ghost's state (so that a receiver
     holds one instant's scene); a ghost whose values are bit for bit the
     ones it last sent, which every peer acknowledged, sends a heartbeat
     instead (3 bytes, no acknowledgement back);
   - without that acknowledgement (every datagram back lost) the beat still
     sends the state: a heartbeat stands only for a state the peer holds;
   - the receiver's copies are the sender's quantized states bit for bit.
   Scene: bodies 1 m apart without gravity (no contacts), body 0 drifting at
   0.2 m/s, the rest at rest, delta + send on change, 4 Hz heartbeats. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>


#include "ghostsim.h"
#include "net_helpers.h"
#include "world_helpers.h"

#define FRAME (1.0 / 60.0)
#define BODIES 10
#define HB 4.0 /* Hz, the default heartbeat rate */
#define SPAN 2.0 /* s measured */

typedef struct pair {
    gs_simnet *sim;
    gs_world *w[2];
    gs_net *net[2];
    gs_agent *ball[2][BODIES];
} pair;

/* Host h + 1's world: the bodies, each under a delta ghost. */
static void host_open(pair *pr, int h) {
    gs_world_desc wd = gs_world_desc_default();
    int i;
    wd.host_id = (uint32_t)h + 1;
    assert_int_equal(gs_world_create(&wd, &pr->w[h]), GS_OK);
    gs_world_set_gravity(pr->w[h], v3(0.0, 0.0, 0.0));
    for (i = 0; i < BODIES; ++i) {
        gs_rigid_desc rd = gs_rigid_desc_default();
        gs_ghost_desc gd = gs_ghost_desc_default();
        rd.shape.type = GS_SHAPE_SPHERE;
        rd.shape.radius = 0.1;
        rd.position = v3((double)i, 0.0, 0.0);
        if (i == 0) rd.velocity = v3(0.0, 0.0, 0.2);
        rd.solver.dt = 0.01;
        assert_int_equal(gs_rigid_create(pr->w[h], &rd, &pr->ball[h][i]), GS_OK);
        gd.object_id = 1000u + (uint32_t)i;
        gd.encoding = GS_ENCODING_QUANT;
        gd.delta = 1;
        gd.rest_threshold = 1e-4; /* 0.1 mm, as bench/bandwidth's */
        gd.heartbeat_rate = HB;
        assert_int_equal(gs_ghost_attach(pr->ball[h][i], &gd), GS_OK);
    }
    assert_int_equal(test_join(pr->sim, pr->w[h], NULL, &pr->net[h]), GS_OK);
}

/* back_loss: the probability a datagram from host 2 to host 1 is lost. */
static pair *pair_open(double back_loss) {
    pair *pr = (pair *)calloc(1, sizeof *pr);
    gs_link_desc link = gs_link_desc_default();
    assert_non_null(pr);
    assert_int_equal(gs_simnet_create(NULL, &pr->sim), GS_OK);
    host_open(pr, 0);
    host_open(pr, 1);
    link.loss = back_loss;
    assert_int_equal(gs_simnet_link(pr->sim, 2, 1, &link), GS_OK);
    return pr;
}

static void pair_close(pair *pr) {
    int h;
    for (h = 0; h < 2; ++h) gs_world_destroy(pr->w[h]);
    gs_simnet_destroy(pr->sim);
    free(pr);
}

/* Host 1's snapshots and heartbeats over SPAN after a 1 s start. */
static void measure(pair *pr, uint64_t *snaps, uint64_t *beats) {
    gs_peer_stats a, b;
    assert_int_equal(gs_simnet_run(pr->sim, 1.0, FRAME), GS_OK);
    assert_int_equal(gs_net_peer_stats(pr->net[0], 2, &a), GS_OK);
    assert_int_equal(gs_simnet_run(pr->sim, SPAN, FRAME), GS_OK);
    assert_int_equal(gs_net_peer_stats(pr->net[0], 2, &b), GS_OK);
    *snaps = b.snapshots_sent - a.snapshots_sent;
    *beats = b.heartbeats_sent - a.heartbeats_sent;
    print_message("host 1: %llu snapshots, %llu heartbeats in %.0f s\n",
                  (unsigned long long)*snaps, (unsigned long long)*beats, SPAN);
}

/* The resting bodies beat with heartbeats: the snapshots are the drifting
   one's (60 a second) and the heartbeats the others' (HB a second each).
   Tolerances: one beat and one frame more or less at the window's edges. */
static void test_still_beats(void **state) {
    pair *pr = pair_open(0.0);
    uint64_t snaps, beats, rest_beats = (uint64_t)(HB * SPAN) * (BODIES - 1);
    int i, k;
    (void)state;
    measure(pr, &snaps, &beats);
    assert_true(snaps <= (uint64_t)(SPAN * 60.0) + 2);
    assert_true(beats + (BODIES - 1) >= rest_beats);
    assert_true(beats <= rest_beats + (BODIES - 1));
    /* the copies are the sender's states: the resting bodies exactly
       (their quantized state is where they are: integer metres), the
       drifting one within the quantization step and the blend's lag */
    for (i = 1; i < BODIES; ++i) {
        gs_vec3 p1 = gs_rigid_position(pr->ball[0][i]), p2 = gs_rigid_position(pr->ball[1][i]);
        assert_true(p1.x == p2.x && p1.y == p2.y && p1.z == p2.z);
    }
    for (k = 0; k < 2; ++k) {
        gs_vec3 v = gs_rigid_velocity(pr->ball[k][0]);
        /* a copy keeps drifting (a held copy would stop) */
        assert_true(fabs(v.z - 0.2) <= 1.5e-3 + 1e-12); /* half the 3 mm/s velocity step */
    }
    pair_close(pr);
}

/* No acknowledgement comes back: each beat sends the resting states (the
   heartbeat would stand for a state the peer may not hold). */
static void test_unacked_beats_send_states(void **state) {
    pair *pr = pair_open(1.0);
    uint64_t snaps, beats, rest_states = (uint64_t)(HB * SPAN) * (BODIES - 1);
    (void)state;
    measure(pr, &snaps, &beats);
    assert_true(beats == 0);
    /* every beat's resting states (one beat less at the window's edges)
       and the drifting body's: at least 30 a second (it sends 50 here, at
       most one a frame, 60; test_still_beats's count is all its own) */
    assert_true(snaps + (BODIES - 1) >= (uint64_t)(SPAN * 30.0) + rest_states);
    pair_close(pr);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_still_beats),
        cmocka_unit_test(test_unacked_beats_send_states),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
