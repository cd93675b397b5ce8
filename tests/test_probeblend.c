/* test_probeblend.c - a blend of the owner's own probe ghost does not stop
   the probe (>>rigid, gs__rigid_set_state; issue 15).

   In present mode the owner blends its own probe's ghost with its peers'
   snapshots like every other ghost, and a blend sets the probe's state. A
   state set inside an advance must leave the target the application set:
   were the blended state taken as the target, the probe would stand
   wherever the blend put it in every frame with a blend and jump to its
   target at max_speed in a frame without one, and the peers would see it
   move in jumps. A state set by hand between advances still places the
   probe and makes that its target. */
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
#define FRAMES 120 /* 2 s of the probes' paths */
#define MAIL 512   /* datagrams in flight to a host, at most */

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
} duo;

static double dist(gs_vec3 a, gs_vec3 b) {
    return sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) + (a.z - b.z) * (a.z - b.z));
}

/* The transport: a datagram to host h waits in its box until h's next
   frame (no loss, a frame of latency at most). */
static gs_result mail_send(void *user, uint32_t host, const void *data, size_t size) {
    mailbox *box = (mailbox *)user;
    mailbox *b;
    if (host < 1 || host > 2 || size > GS_WIRE_MAX_DATAGRAM) return GS_OK;
    b = &box[host - 1];
    if (b->n == MAIL) return GS_OK;
    memcpy(b->data[b->n], data, size);
    b->size[b->n++] = size;
    return GS_OK;
}

/* The paper's scene on two hosts, a probe each, ghosts attached (present
   mode, the library's default). */
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

/* Host k's frame f, as an application (ghostpeer) runs it: what arrived,
   its own probe's target from its path at the cloth's time, one frame's
   advance, the sends. Returns the target. */
static gs_vec3 duo_frame(duo *d, int k, int f) {
    const gs_quat id = {0.0, 0.0, 0.0, 1.0};
    double now = (f + 1) * FRAME;
    mailbox *b = &d->box[k];
    gs_vec3 to = gs_scene_probe_path(k, gs_agent_time(d->sc[k].cloth));
    gs_result r;
    int i;
    for (i = 0; i < b->n; ++i) {
        gs_reject why;
        gs_net_deliver(d->net[k], b->data[i], b->size[i], now, &why);
    }
    b->n = 0;
    assert_int_equal(gs_probe_set_target(d->sc[k].probes[k], to, id), GS_OK);
    r = gs_world_advance(d->w[k], FRAME, NULL);
    assert_true(r == GS_OK || r == GS_ERR_UNSTABLE);
    assert_int_equal(gs_net_update(d->net[k], now), GS_OK);
    return to;
}

/* The path's largest move in a frame (m). */
static double path_frame_peak(void) {
    double peak = 0.0;
    int f;
    for (f = 0; f < FRAMES; ++f)
        peak = fmax(peak, dist(gs_scene_probe_path(0, f * FRAME), gs_scene_probe_path(0, (f + 1) * FRAME)));
    return peak;
}

/* Two hosts, each frame's target from the path. At every frame's end host
   1's probe is at the target it was given that frame: the scene's
   max_speed (5 m/s, 8 cm in a frame) is about 7 times the path's fastest,
   so it gets there within the frame; 1 mm is room for the last step's
   rounding (measured 0; on a header that takes a blended state as the
   target, 0.30 m: it stood where the blends put it). Host 2's copy of it
   moves at most 3 frames' worth of the path's fastest in a frame: a
   snapshot may carry two frames' moves and the blend's weight leaves a
   lag it makes up (measured 3.05 cm against 3.54; 8.0 cm on that header,
   the jump of a frame without a blend). */
static void test_owner_blend_keeps_target(void **state) {
    duo d;
    double behind = 0.0, jump = 0.0, peak = path_frame_peak();
    gs_vec3 was;
    int f;
    (void)state;
    duo_new(&d);
    was = gs_rigid_position(d.sc[1].probes[0]);
    for (f = 0; f < FRAMES; ++f) {
        gs_vec3 to = duo_frame(&d, 0, f), c;
        duo_frame(&d, 1, f);
        behind = fmax(behind, dist(gs_rigid_position(d.sc[0].probes[0]), to));
        c = gs_rigid_position(d.sc[1].probes[0]);
        if (f > 0) jump = fmax(jump, dist(c, was));
        was = c;
    }
    print_message("host 1's probe %.3g m from its frame's target at most; host 2's copy's largest "
                  "move in a frame %.4f m (the path's %.4f m)\n", behind, jump, peak);
    assert_true(behind < 1e-3);
    assert_true(jump <= 3.0 * peak);
    duo_free(&d);
}

/* Between advances a state set by hand places the owner's probe and makes
   that its target: it stays there, not back to the old target. */
static void test_set_state_between_advances(void **state) {
    gs_world *w = world_new(1);
    gs_probe_desc pd = gs_probe_desc_default();
    const gs_quat id = {0.0, 0.0, 0.0, 1.0};
    gs_agent *p;
    double s[14];
    (void)state;
    pd.shape.type = GS_SHAPE_SPHERE;
    pd.shape.radius = 0.05;
    assert_int_equal(gs_probe_create(w, &pd, &p), GS_OK);
    assert_int_equal(gs_probe_set_target(p, v3(0.1, 0.0, 0.0), id), GS_OK);
    assert_int_equal(gs_world_advance(w, 0.1, NULL), GS_OK);
    assert_true(gs_rigid_position(p).x == 0.1);
    assert_int_equal(gs_agent_state_size(p), 14);
    assert_int_equal(gs_agent_get_state(p, s, 14), GS_OK);
    s[1] = -0.2;
    s[8] = s[9] = s[10] = 0.0;
    assert_int_equal(gs_agent_set_state(p, s, 14), GS_OK);
    assert_int_equal(gs_world_advance(w, 0.1, NULL), GS_OK);
    assert_true(gs_rigid_position(p).x == -0.2);
    gs_world_destroy(w);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_owner_blend_keeps_target),
        cmocka_unit_test(test_set_state_between_advances),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
