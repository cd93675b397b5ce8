/* bandwidth - what a host sends, per peer and per object, in each wire
   encoding, and what each costs in divergence and CPU.

   Scenes (two hosts on gs_simnet, a perfect link, 60 Hz frames; ghosts at
   their default 60 Hz, the net's budget raised to 1e9 B/s so that nothing
   is held back):
     paper-push   the paper's scene (16x16 cloth, 3 spheres, 2 probes),
                  each host driving its probe along gs_scene_probe_path
     paper-rest   the same scene with the probes parked above the cloth
                  from the start; measured after 20 s (1 s quick) of
                  settling, over the next 4 s (1 s): the spheres land on
                  the cloth and roll and sink for about 7 s, and the cloth
                  creeps under them (by more than the rest threshold, 0.1
                  mm, per frame) until about 16 s (docs/sync-notes.md), so
                  that a shorter settle measures a scene still settling
     cloth64-push the scene with a 64x64 cloth and no spheres, probes
                  pushing
     spheres900   900 spheres in a 30 x 30 grid, no gravity, no contacts
                  (1 m apart), 90 of them (one in ten) drifting at 0.2 m/s,
                  the rest at rest
   Encodings: f64, f32, quant (0.05 mm, 3 mm/s, 16-bit smallest three),
   quant+rest (send on change: rest threshold 0.1 mm, heartbeats at 4 Hz),
   quant+delta (gs_ghost_desc.delta: each chunk as its differences from
   the newest snapshot the peer acknowledged), delta+rest (both),
   delta+predict (delta+rest, with gs_ghost_desc.rest_extrapolate: "at
   rest" measured against the last state sent carried along its
   velocity, so a steady drift sends only heartbeats).
   --quick runs the paper scenes only, in f64, quant+rest and quant+delta,
   over 1 s, and times f64, quant and quant+delta only (the cloth64 and
   spheres900 rows take minutes: a 64x64 cloth settles 3 s at creation on
   each host, and 900 ghosts are looked up linearly per chunk); their rows
   are then null.
   --scene NAME and --encoding NAME (each may be given more than once) run
   only the scenes and encodings named (the others' rows are null; f64's
   row is what the divergence targets compare against); a --scene, or
   --no-cpu, leaves the CPU timing out (its figures are then null).
   --adopt 0|1 sets gs_ghost_desc.adopt_sent in every encoding (else its
   default); --mode present|replay the hosts' gs_sync_desc.mode (default
   present); --cloth-rate HZ the cloth ghost's gs_ghost_desc.send_rate in
   every encoding (else the default, 60 Hz; the other ghosts keep it);
   --send-rate HZ every ghost's (--cloth-rate then the cloth's over it);
   --velocity-resolution M/S gs_ghost_desc.velocity_resolution in the
   quantized encodings (else 3 mm/s; a coarse one, e.g. 1000, sends every
   velocity as 0: what the positions cost predicted from the baseline
   alone, for their bytes only, as the peers then take velocities of 0);
   --budget B/S both nets' gs_net_desc.bandwidth (else 1e9). Each of
   these number flags takes a positive finite number, and --adopt 0 or 1:
   anything else is said and the bench exits with status 2. --split
   prints under each row what host 1's kbit/s carry: the datagrams' own
   bytes (header and CRC), the cloth's, the spheres' and the probes'
   chunks (chunk headers and payload, heartbeats included) and the
   acknowledgement chunks, from each datagram it sent decoded
   (gs_wire_decode), with its datagrams and cloth chunks a second (and
   those not coded as deltas), and the cloth's bytes split into positions
   and velocities (a chunk holding both split by its count of each; a
   heartbeat, which holds no values, is counted with the velocities).
   --fidelity asks whether an encoding changes the physics, not only
   whether the hosts agree (with adopt_sent each host takes its own
   quantized state at every publish, so both can agree on another scene).
   Before each scene's rows it runs the f64 reference (the same scene and
   flags in f64) and keeps host 1's trajectory from the first frame, then
   the noise floor: the same f64 run 3 times (--floors N) with every
   position of the cloth's particles and the spheres nudged by +-1e-9 m
   (--nudge M sets it), a pattern of signs each, on both hosts alike,
   once after the scene is made: the scene is chaotic (spheres on a
   cloth), so any perturbation grows, and a row departs from f64 "beyond
   the floor" only by more than these. Under each row and each floor run
   it prints host 1's departure from the reference's host 1 at equal
   simulation time (the reference interpolated to the row's time, as
   div@t): the cloth's RMS distance over its particles and the largest
   sphere distance, each as a mean over the measured span (under a row,
   also as a multiple of the floor's largest mean), and at 0.25 s (before
   the paper scenes' spheres reach the cloth) and at the span's start,
   quarters and end. Under those and the reference: the mean over the
   span of host 1's kinetic energy, the cloth's and the spheres'
   (translational), each as a multiple of the reference's (damping shows
   there); and the speed of one sphere after 0.5 s of free fall, alone in
   a world of the default desc (present mode) without a net, with the
   row's ghost desc, against f64's (no contact, so no chaos: with
   adopt_sent each publish rounds the velocity gravity added since the
   last, and the fall runs faster or slower). The JSON rows get
   fidelity_* keys, the summary the floor's largest means. The f64 row
   departs by 0 (the simnet is deterministic).

   Figures: kbit/s that host 1 sent to host 2 (its gs_peer_stats
   bytes_sent, datagram bytes, no UDP/IP headers) over the measured span;
   that per object; the divergence at equal simulation time, as
   bench/sync_modes measures it, with the same code (bench/equal_time.h;
   the project's rule: a comparison at equal wall time or against the
   latest snapshot mixes the hosts' clock gap or the snapshot's age into
   what the encoding costs): at the end of every frame of the measured
   span each host keeps the time of its reference agent (the cloth; the
   first sphere in spheres900) and its objects' positions; host 2's
   samples are interpolated linearly to host 1's time, and the divergence
   of a frame is the largest over the objects of the RMS distance over the
   cloth's particles or the distance of a sphere (the probes left out: see
   samples_alloc); "div@t mean" and "div@t p95" over the frames. Beside
   it, as before, "div-vs-snap": host 1's gs_peer_stats.divergence (RMS
   distance between its positions and host 2's latest snapshot of each
   object, at that snapshot's time, the largest over the objects), mean
   over the same frames. CPU: one full snapshot of the paper scene encoded
   (gs_net_update after a publish) and decoded (gs_net_deliver of each
   datagram) between two nets of the program's own transport, median of
   repeats, monotonic clock; in quant+delta the receiver's
   acknowledgements go back between repeats (not timed), so that the
   snapshots timed are deltas. The ratios to f64 come from the same run.
   Last, each target against the best encoding for it, met or missed, with
   its divergence at equal simulation time (the mean) beside f64's plus one
   position step (5e-5 m), and the CPU ratios against theirs (<= 1).
   --cpu (alone) prints the CPU table only, in f64, quant and quant+delta,
   and writes no JSON: what a profiler runs, e.g. valgrind --tool=callgrind
   --toggle-collect=cpu_encode --toggle-collect=cpu_decode
   --dump-after=cpu_times build/bench/bandwidth --cpu, one part per
   encoding (cpu_encode and cpu_decode are the timed calls, cpu_times one
   encoding's run: all three kept out of line for that). */
#define GHOSTSIM_IMPLEMENTATION
#include "ghostsim.h"
#include "tests/net_helpers.h"
#include "bench_util.h"
#include "equal_time.h"

#define FRAME (1.0 / 60.0)
/* m: the position resolution of GS_ENCODING_QUANT (its default, or
   --position-resolution) */
#define STEP (pos_res > 0.0 ? pos_res : 5e-5)
#define NSPHERES 900

static gs_vec3 v3(double x, double y, double z) {
    gs_vec3 v;
    v.x = x; v.y = y; v.z = z;
    return v;
}

enum { ENC_F64, ENC_F32, ENC_QUANT, ENC_QUANT_REST, ENC_DELTA, ENC_DELTA_REST, ENC_PREDICT,
       ENC_COUNT };
static const char *enc_name[ENC_COUNT] = {"f64", "f32", "quant", "quant+rest", "quant+delta",
                                          "delta+rest", "delta+predict"};

enum { SC_PAPER_PUSH, SC_PAPER_REST, SC_CLOTH64, SC_SPHERES, SC_COUNT };
static const char *sc_name[SC_COUNT] = {"paper-push", "paper-rest", "cloth64-push", "spheres900"};
/* the targets, kbit/s per host (0: none) */
static const double sc_target[SC_COUNT] = {256.0, 16.0, 2000.0, 256.0};

/* --adopt 0|1: gs_ghost_desc.adopt_sent in every encoding (-1: the default) */
static int adopt = -1;
/* --mode present|replay: gs_sync_desc.mode of both hosts (the default's:
   present) */
static gs_sync_mode sync_mode = GS_SYNC_PRESENT;
/* --cloth-rate HZ: the cloth ghost's gs_ghost_desc.send_rate (0: the
   default, 60 Hz) */
static double cloth_rate = 0.0;
/* --send-rate HZ: every ghost's gs_ghost_desc.send_rate (0: the default,
   60 Hz); --cloth-rate then sets the cloth's over it */
static double send_rate = 0.0;
/* --velocity-resolution M/S: gs_ghost_desc.velocity_resolution in the
   quantized encodings (0: the default, 3 mm/s) */
static double vel_res = 0.0;
/* --position-resolution M: gs_ghost_desc.position_resolution in the
   quantized encodings (0: the default, 5e-5 m); the divergence targets
   then allow f64's plus this step */
static double pos_res = 0.0;
/* --budget B/S: gs_net_desc.bandwidth of both hosts (0: 1e9, nothing held
   back) */
static double budget = 0.0;
/* --split: what host 1's bytes to host 2 carry, printed under each row */
static int split = 0;
/* --fidelity: host 1's trajectory against host 1's in the f64 run of the
   same scene and flags, printed under each row, beside a noise floor (the
   f64 run with its positions nudged, see nudge_agent); --nudge M the
   floor's nudge (default 1e-9 m) */
static int fidelity = 0;
static double nudge = 1e-9;
/* --floors N: how many nudged f64 runs, each its own pattern of signs
   (the kinetic energy of a few rolling spheres spreads widely between
   runs, so its range needs several) */
static int floors_n = 3;
/* the nudge pattern of the run being built (0: none); both hosts build the
   same, so the floor is another initial condition of one scene, not a
   disagreement the sync then resolves */
static uint32_t nudge_seed = 0;

static gs_ghost_desc ghost_desc(int enc) {
    gs_ghost_desc gd = gs_ghost_desc_default();
    gd.encoding = enc == ENC_F64 ? GS_ENCODING_F64 : enc == ENC_F32 ? GS_ENCODING_F32
                                                                     : GS_ENCODING_QUANT;
    if (enc == ENC_QUANT_REST || enc == ENC_DELTA_REST || enc == ENC_PREDICT)
        gd.rest_threshold = 1e-4;
    gd.delta = enc == ENC_DELTA || enc == ENC_DELTA_REST || enc == ENC_PREDICT;
    /* delta+predict: send on change against the last state sent carried
       along its velocity (both hosts predict alike) */
    gd.rest_extrapolate = enc == ENC_PREDICT;
    gd.weight = gs_weight_cs;
    if (adopt >= 0) gd.adopt_sent = adopt;
    if (send_rate > 0.0) gd.send_rate = send_rate;
    if (vel_res > 0.0) gd.velocity_resolution = vel_res;
    if (pos_res > 0.0) gd.position_resolution = pos_res;
    return gd;
}

/* Every position coordinate of a's state moved by +-nudge (signs from a
   xorshift of *seed): by default a perturbation far below any
   quantization step, so what grows from it is the scene's own
   sensitivity. */
static int nudge_agent(gs_agent *a, uint32_t *seed) {
    size_t n = gs_agent_state_size(a), i, coords;
    double *st = (double *)malloc(n * sizeof *st);
    gs_result r;
    if (!st || gs_agent_get_state(a, st, n) != GS_OK) {
        free(st);
        return -1;
    }
    /* [t, positions...]: a mesh's 3 a particle first, a rigid body's 3 */
    coords = gs_mesh_particle_count(a) > 0 ? 3u * (size_t)gs_mesh_particle_count(a) : 3u;
    for (i = 1; i <= coords; ++i) {
        *seed ^= *seed << 13;
        *seed ^= *seed >> 17;
        *seed ^= *seed << 5;
        st[i] += *seed & 1u ? nudge : -nudge;
    }
    r = gs_agent_set_state(a, st, n);
    free(st);
    return r == GS_OK ? 0 : -1;
}

typedef struct host {
    gs_world *w;
    gs_net *net;
    gs_scene sc;
    gs_agent *ball[NSPHERES];
    int objects;
    et_samples s; /* the divergence at equal simulation time (samples_keep) */
    et_samples fc, fb; /* --fidelity, host 1: the cloth's particles and the
                          bodies (spheres), every frame from the first */
} host;

static int host_scene(host *h, uint32_t id, int scene, int enc) {
    gs_world_desc wd = gs_world_desc_default();
    gs_ghost_desc gd = ghost_desc(enc);
    uint32_t seed = nudge_seed * 2654435761u; /* xorshift: never 0 */
    wd.host_id = id;
    wd.sync.mode = sync_mode;
    if (gs_world_create(&wd, &h->w) != GS_OK) return -1;
    if (scene == SC_SPHERES) {
        int i;
        gs_world_set_gravity(h->w, v3(0, 0, 0));
        for (i = 0; i < NSPHERES; ++i) {
            gs_rigid_desc rd = gs_rigid_desc_default();
            rd.shape.type = GS_SHAPE_SPHERE;
            rd.shape.radius = 0.1;
            rd.position = v3((double)(i % 30), 0.0, (double)(i / 30));
            if (i % 10 == 0) rd.velocity = v3(0.2, 0.0, 0.0);
            rd.solver.dt = 0.01;
            if (gs_rigid_create(h->w, &rd, &h->ball[i]) != GS_OK) return -1;
            if (nudge_seed && nudge_agent(h->ball[i], &seed) != 0) return -1;
            gd.object_id = 1000u + (uint32_t)i;
            if (gs_ghost_attach(h->ball[i], &gd) != GS_OK) return -1;
        }
        h->objects = NSPHERES;
        return 0;
    }
    {
        gs_scene_desc sd = gs_scene_desc_default();
        sd.probe_count = 2;
        if (scene == SC_CLOTH64) {
            sd.cloth_n = 64;
            sd.sphere_count = GS_NONE;
        }
        if (gs_scene_create(h->w, &sd, &h->sc) != GS_OK) return -1;
        if (nudge_seed) { /* after the cloth's settling, before any ghost */
            int k;
            if (nudge_agent(h->sc.cloth, &seed) != 0) return -1;
            for (k = 0; k < h->sc.sphere_count; ++k)
                if (nudge_agent(h->sc.spheres[k], &seed) != 0) return -1;
        }
        if (gs_scene_attach_ghosts(&h->sc, &gd) != GS_OK) return -1;
        if (cloth_rate > 0.0) { /* the cloth's ghost again, at its own rate */
            gd.object_id = 1; /* gs_scene_attach_ghosts' id of the cloth */
            gd.send_rate = cloth_rate;
            if (gs_ghost_detach(h->sc.cloth) != GS_OK || gs_ghost_attach(h->sc.cloth, &gd) != GS_OK)
                return -1;
        }
        h->objects = 1 + h->sc.sphere_count + h->sc.probe_count;
    }
    return 0;
}

static void drive(host *h, uint32_t id, int scene, double t) {
    gs_quat q = {0, 0, 0, 1};
    gs_vec3 p;
    if (scene == SC_SPHERES) return;
    if (scene == SC_PAPER_REST) p = v3(0.3 * ((double)id - 1.5), 0.6, 0.0);
    else p = gs_scene_probe_path((int)id - 1, t);
    gs_probe_set_target(h->sc.probes[id - 1], p, q);
}

/* The samples kept for the divergence at equal simulation time
   (bench/equal_time.h), at the end of every frame of the measured span:
   the time of the host's reference agent (the cloth; the first sphere in
   spheres900), the cloth's particles, then one point per sphere. The
   probes are left out, as bench/sync_modes leaves them out: a probe's
   copy follows its owner's input a frame later in every encoding (up to
   8 cm while it pushes), which would hide what the encodings cost the
   simulated objects. */
static int samples_alloc(host *h, int scene, int cap) {
    int mesh_n = scene == SC_SPHERES ? 0 : gs_mesh_particle_count(h->sc.cloth);
    return et_alloc(&h->s, cap, scene == SC_SPHERES ? NSPHERES : mesh_n + h->sc.sphere_count,
                    mesh_n);
}

static void samples_keep(host *h, int scene) {
    gs_vec3 *p;
    int i;
    if (scene == SC_SPHERES) {
        if (!(p = et_push(&h->s, gs_agent_time(h->ball[0])))) return;
        for (i = 0; i < NSPHERES; ++i) p[i] = gs_rigid_position(h->ball[i]);
    } else {
        if (!(p = et_push(&h->s, gs_agent_time(h->sc.cloth)))) return;
        memcpy(p, gs_mesh_positions(h->sc.cloth), (size_t)h->s.mesh_n * sizeof *p);
        for (i = 0; i < h->sc.sphere_count; ++i)
            p[h->s.mesh_n + i] = gs_rigid_position(h->sc.spheres[i]);
    }
}

/* Mean and p95 over host 1's frames of the divergence at equal time from
   host 2 (frames whose time host 2 did not bracket left out). */
static void equal_time(const host *h, double *mean, double *p95) {
    double *d = (double *)malloc((size_t)(h[0].s.frames + 1) * sizeof *d), sum = 0.0;
    int k, n = 0;
    *mean = *p95 = 0.0;
    if (!d) return;
    for (k = 0; k < h[0].s.frames; ++k) {
        double x = et_diverge_at(&h[0].s, k, &h[1].s);
        if (x >= 0.0) { d[n++] = x; sum += x; }
    }
    if (n > 0) {
        *mean = sum / n;
        *p95 = bu_quantile(d, n, 0.95);
    }
    free(d);
}

/* --fidelity: host 1's samples from the first frame, the cloth and the
   bodies apart (a sphere's departure is larger than the cloth's RMS and
   would hide it in one figure). */
static int fid_alloc(host *h, int scene, int cap) {
    int mesh_n = scene == SC_SPHERES ? 0 : gs_mesh_particle_count(h->sc.cloth);
    int bodies = scene == SC_SPHERES ? NSPHERES : h->sc.sphere_count;
    /* a set with nothing in it (no cloth, no sphere) keeps one point at
       the origin, which departs by 0 */
    if (et_alloc(&h->fc, cap, mesh_n > 0 ? mesh_n : 1, mesh_n) != 0) return -1;
    return et_alloc(&h->fb, cap, bodies > 0 ? bodies : 1, 0);
}

static void fid_keep(host *h, int scene) {
    double t = scene == SC_SPHERES ? gs_agent_time(h->ball[0]) : gs_agent_time(h->sc.cloth);
    gs_vec3 *c = et_push(&h->fc, t), *b = et_push(&h->fb, t);
    int i;
    if (!c || !b) return;
    if (scene == SC_SPHERES) {
        for (i = 0; i < NSPHERES; ++i) b[i] = gs_rigid_position(h->ball[i]);
        return;
    }
    memcpy(c, gs_mesh_positions(h->sc.cloth), (size_t)h->fc.mesh_n * sizeof *c);
    for (i = 0; i < h->sc.sphere_count; ++i) b[i] = gs_rigid_position(h->sc.spheres[i]);
}

/* Kinetic energy, J: the cloth's and the bodies' (translational only: the
   API gives no inertia), host 1, at the end of a frame. */
static void fid_energy(const host *h, int scene, double *cloth, double *bodies) {
    int i, n = scene == SC_SPHERES ? NSPHERES : h->sc.sphere_count;
    *cloth = *bodies = 0.0;
    if (scene != SC_SPHERES) gs_mesh_energy(h->sc.cloth, cloth, NULL);
    for (i = 0; i < n; ++i) {
        const gs_agent *a = scene == SC_SPHERES ? h->ball[i] : h->sc.spheres[i];
        gs_vec3 v = gs_rigid_velocity(a);
        *bodies += 0.5 * gs_rigid_mass(a) * (v.x * v.x + v.y * v.y + v.z * v.z);
    }
}

/* --fidelity: one sphere falling freely for 0.5 s (30 frames; the paper
   scene's dt), alone in a world without a net, with encoding enc's ghost
   desc (or none): its speed at the end. No contact, nothing chaotic: what
   a ghost's own publishes do to the physics shows bare (with adopt_sent
   each publish rounds the velocity gravity added since the last one). */
static double fid_fall(int enc) {
    gs_world_desc wd = gs_world_desc_default();
    gs_rigid_desc rd = gs_rigid_desc_default();
    gs_ghost_desc gd = ghost_desc(enc);
    gs_world *w;
    gs_agent *b;
    double v = -1.0;
    int k;
    if (gs_world_create(&wd, &w) != GS_OK) return -1.0;
    rd.shape.type = GS_SHAPE_SPHERE;
    rd.shape.radius = 0.08;
    rd.position = v3(0.0, 10.0, 0.0);
    rd.solver.dt = 0.002;
    gd.object_id = 1;
    if (gs_rigid_create(w, &rd, &b) == GS_OK && gs_ghost_attach(b, &gd) == GS_OK) {
        for (k = 0; k < 30; ++k) gs_world_advance(w, FRAME, NULL);
        v = -gs_rigid_velocity(b).y;
    }
    gs_world_destroy(w);
    return v;
}

/* departures printed at 0.25 s (the paper scenes' spheres still falling:
   no contact yet, so nothing chaotic has amplified what differs), then at
   the span's start, its quarters and its end */
enum { FID_AT = 6 };
static double fid_time(int q, double settle, double span) {
    return q == 0 ? 0.25 : settle + span * (q - 1) / (FID_AT - 2);
}
/* --fidelity: the f64 reference's host 1 samples, kept by the run that
   fid_ref_pending marks */
static int fid_ref_pending = 0;
static et_samples fid_ref_c, fid_ref_b;

/* Host 1's departure from the reference's host 1 at its frame k: the
   cloth's RMS distance and the largest sphere distance, at equal
   simulation time (the reference interpolated to this run's time); -1
   where the reference did not sample around it. */
static void fid_depart(const host *h, int k, double *cloth, double *bodies) {
    *cloth = h->fc.mesh_n > 0 ? et_diverge_at(&h->fc, k, &fid_ref_c) : 0.0;
    *bodies = et_diverge_at(&h->fb, k, &fid_ref_b); /* no body: one point at 0, 0 */
}

/* --split: host 1's transport wrapped, each datagram it sends decoded and
   its bytes put to what they carry: the datagram's own (header and CRC),
   acknowledgement chunks, and the chunks (header and payload, heartbeats
   too) of the cloth (object 1), the spheres (100..) and the probes
   (200.., gs_scene_attach_ghosts' ids). */
enum { PART_HEADER, PART_CLOTH, PART_SPHERES, PART_PROBES, PART_ACKS, PART_COUNT };
static const char *part_name[PART_COUNT] = {"headers", "cloth", "spheres", "probes", "acks"};
typedef struct tally {
    gs_transport inner;
    gs_wire_view *view;
    double bytes[PART_COUNT];
    double datagrams, cloth_chunks, cloth_keys; /* keys: chunks not coded as a delta */
    double cloth_pos;   /* bytes of the cloth's chunks that are positions */
    uint32_t positions; /* the cloth's position values (3 a particle) */
    int counting;
} tally;

static gs_result tally_send(void *user, uint32_t to, const void *data, size_t size) {
    tally *t = (tally *)user;
    if (t->counting && t->view &&
        gs_wire_decode((const unsigned char *)data, size, t->view, NULL) == GS_OK) {
        const unsigned char *at = (const unsigned char *)data + GS_WIRE_HEADER;
        double chunks = 0.0;
        int i;
        for (i = 0; i < t->view->chunk_count; ++i) {
            const gs_wire_chunk *c = &t->view->chunks[i];
            const unsigned char *end = c->payload + c->payload_bytes;
            int part = c->flags & GS_WIRE_CHUNK_ACK ? PART_ACKS
                       : c->object_id >= 200u    ? PART_PROBES
                       : c->object_id >= 100u    ? PART_SPHERES
                                                 : PART_CLOTH;
            t->bytes[part] += (double)(end - at);
            chunks += (double)(end - at);
            if (part == PART_CLOTH) { /* a chunk of both: split by its values */
                uint32_t pos = c->first >= t->positions ? 0u
                               : t->positions - c->first < c->elements ? t->positions - c->first
                                                                     : c->elements;
                t->cloth_chunks += 1.0;
                if (!(c->flags & (GS_WIRE_CHUNK_DELTA | GS_WIRE_CHUNK_REST))) t->cloth_keys += 1.0;
                if (c->elements) t->cloth_pos += (double)(end - at) * pos / c->elements;
            }
            at = end;
        }
        t->bytes[PART_HEADER] += (double)size - chunks;
        t->datagrams += 1.0;
    }
    return t->inner.send(t->inner.user, to, data, size);
}
static gs_result tally_add_peer(void *user, uint32_t host, const char *addr) {
    tally *t = (tally *)user;
    return t->inner.add_peer ? t->inner.add_peer(t->inner.user, host, addr) : GS_OK;
}
static gs_result tally_remove_peer(void *user, uint32_t host) {
    tally *t = (tally *)user;
    return t->inner.remove_peer ? t->inner.remove_peer(t->inner.user, host) : GS_OK;
}
static gs_result tally_attach(void *user, gs_net *net) {
    tally *t = (tally *)user;
    return t->inner.attach ? t->inner.attach(t->inner.user, net) : GS_OK;
}
static gs_result tally_poll(void *user, gs_net *net, double now) {
    tally *t = (tally *)user;
    return t->inner.poll ? t->inner.poll(t->inner.user, net, now) : GS_OK;
}
static void tally_detach(void *user, gs_net *net) {
    tally *t = (tally *)user;
    if (t->inner.detach) t->inner.detach(t->inner.user, net);
}

/* test_join with the transport wrapped by t. */
static gs_result tally_join(gs_simnet *sim, gs_world *w, const gs_net_desc *desc, tally *t,
                            gs_net **out) {
    gs_net_desc nd = *desc;
    gs_result r = gs_simnet_transport(sim, &t->inner);
    if (r != GS_OK) return r;
    nd.transport = t->inner;
    nd.transport.user = t;
    nd.transport.send = tally_send;
    nd.transport.add_peer = tally_add_peer;
    nd.transport.remove_peer = tally_remove_peer;
    nd.transport.attach = tally_attach;
    nd.transport.poll = tally_poll;
    nd.transport.detach = tally_detach;
    return gs_net_create(w, &nd, out);
}

typedef struct result {
    double kbps, kbps_object;
    double divergence;          /* m: host 1's peer stat against the latest snapshot */
    double eq_mean, eq_p95;     /* m: at equal simulation time */
    double part_kbps[PART_COUNT]; /* --split: kbit/s of each part */
    double datagrams, cloth_chunks, cloth_keys; /* --split: per second */
    double cloth_pos_kbps;          /* --split: the cloth's positions */
    /* --fidelity (m, J), host 1 against the f64 reference's host 1 at
       equal simulation time: means over the measured span of the cloth's
       RMS departure and the largest sphere's, each at FID_AT times, and
       mean kinetic energies over the span */
    double fid_cloth, fid_bodies, fid_at_c[FID_AT], fid_at_b[FID_AT], ke_cloth, ke_bodies;
    double fall; /* m/s: fid_fall's speed in this row's encoding */
    int ok;
} result;

/* The --fidelity figures of a run from host 1's samples (frames from k0 on
   are the measured span's), or its samples kept as the reference. */
static void fid_finish(host *h, result *res, int k0, double settle, double span) {
    double sum_c = 0.0, sum_b = 0.0;
    int k, n = 0, q;
    if (fid_ref_pending) { /* the reference: its samples move to fid_ref_* */
        et_free(&fid_ref_c);
        et_free(&fid_ref_b);
        fid_ref_c = h->fc;
        fid_ref_b = h->fb;
        memset(&h->fc, 0, sizeof h->fc);
        memset(&h->fb, 0, sizeof h->fb);
        fid_ref_pending = 0;
    }
    for (k = k0; k < h->fc.frames; ++k) {
        double c, b;
        fid_depart(h, k, &c, &b);
        if (c < 0.0 || b < 0.0) continue;
        sum_c += c;
        sum_b += b;
        n++;
    }
    res->fid_cloth = n ? sum_c / n : -1.0;
    res->fid_bodies = n ? sum_b / n : -1.0;
    for (q = 0; q < FID_AT; ++q) { /* the frame that ends nearest the time */
        res->fid_at_c[q] = res->fid_at_b[q] = -1.0;
        k = (int)(fid_time(q, settle, span) / FRAME + 0.5) - 1;
        if (k >= h->fc.frames) k = h->fc.frames - 1;
        if (k >= 0) fid_depart(h, k, &res->fid_at_c[q], &res->fid_at_b[q]);
    }
}

/* s: the settling before the measured span, and the span */
static void scene_times(int scene, int quick, double *settle, double *span) {
    *settle = scene == SC_PAPER_REST ? (quick ? 1.0 : 20.0) : (quick ? 0.25 : 1.0);
    *span = scene == SC_CLOTH64 || scene == SC_SPHERES ? 2.0 : quick ? 1.0 : 4.0;
}

static result run_scene(int scene, int enc, int quick) {
    result res;
    host h[2];
    gs_simnet *sim = NULL;
    gs_simnet_desc smd;
    gs_net_desc nd;
    gs_peer_stats a, b;
    double settle, span;
    double t = 0.0, wall0 = 0.0, div = 0.0, wall, ke_c = 0.0, ke_b = 0.0;
    int i, frames = 0, fid_k0 = 0;
    tally tl;
    scene_times(scene, quick, &settle, &span);
    memset(&res, 0, sizeof res);
    memset(h, 0, sizeof h);
    memset(&smd, 0, sizeof smd);
    memset(&nd, 0, sizeof nd);
    memset(&tl, 0, sizeof tl);
    nd.bandwidth = budget > 0.0 ? budget : 1e9;
    if (split && !(tl.view = (gs_wire_view *)malloc(sizeof *tl.view))) return res;
    if (gs_simnet_create(&smd, &sim) != GS_OK) return res;
    for (i = 0; i < 2; ++i) {
        if (host_scene(&h[i], (uint32_t)i + 1, scene, enc) != 0 ||
            samples_alloc(&h[i], scene, (int)(span / FRAME) + 4) != 0 ||
            (i == 0 && fidelity && fid_alloc(&h[i], scene, (int)((settle + span) / FRAME) + 4)) ||
            (i == 0 && split ? tally_join(sim, h[i].w, &nd, &tl, &h[i].net)
                             : test_join(sim, h[i].w, &nd, &h[i].net)) != GS_OK) {
            fprintf(stderr, "bandwidth: %s %s: setup failed\n", sc_name[scene], enc_name[enc]);
            return res;
        }
    }
    if (scene != SC_SPHERES) tl.positions = 3u * (uint32_t)gs_mesh_particle_count(h[0].sc.cloth);
    memset(&a, 0, sizeof a);
    while (t < settle + span) {
        for (i = 0; i < 2; ++i) drive(&h[i], (uint32_t)i + 1, scene, t);
        if (gs_simnet_run(sim, FRAME, FRAME) != GS_OK) break;
        t += FRAME;
        if (fidelity) fid_keep(&h[0], scene);
        if (t >= settle && wall0 == 0.0) {
            fid_k0 = h[0].fc.frames - 1;
            gs_net_peer_stats(h[0].net, 2, &a);
            wall0 = gs_simnet_time(sim);
            tl.counting = 1; /* what is sent from here on, as bytes_sent */
        }
        if (wall0 > 0.0) {
            gs_net_peer_stats(h[0].net, 2, &b);
            div += b.divergence;
            frames++;
            for (i = 0; i < 2; ++i) samples_keep(&h[i], scene);
            if (fidelity) {
                double c, b;
                fid_energy(&h[0], scene, &c, &b);
                ke_c += c;
                ke_b += b;
            }
        }
    }
    gs_net_peer_stats(h[0].net, 2, &b);
    wall = gs_simnet_time(sim) - wall0;
    res.kbps = (double)(b.bytes_sent - a.bytes_sent) * 8.0 / wall / 1e3;
    for (i = 0; i < PART_COUNT; ++i) res.part_kbps[i] = tl.bytes[i] * 8.0 / wall / 1e3;
    res.datagrams = tl.datagrams / wall;
    res.cloth_chunks = tl.cloth_chunks / wall;
    res.cloth_keys = tl.cloth_keys / wall;
    res.cloth_pos_kbps = tl.cloth_pos * 8.0 / wall / 1e3;
    res.kbps_object = res.kbps / h[0].objects;
    res.divergence = frames ? div / frames : 0.0;
    equal_time(h, &res.eq_mean, &res.eq_p95);
    if (fidelity) {
        res.ke_cloth = frames ? ke_c / frames : 0.0;
        res.ke_bodies = frames ? ke_b / frames : 0.0;
        fid_finish(&h[0], &res, fid_k0, settle, span);
        res.fall = fid_fall(enc);
    }
    res.ok = 1;
    for (i = 0; i < 2; ++i) {
        gs_net_destroy(h[i].net);
        gs_world_destroy(h[i].w);
        et_free(&h[i].s);
        et_free(&h[i].fc);
        et_free(&h[i].fb);
    }
    gs_simnet_destroy(sim);
    free(tl.view);
    return res;
}

/* ---- --fidelity: the reference, the noise floor, a row's line ---- */

/* The largest departures and the kinetic energies' range over the floor's
   nudged runs. */
typedef struct fid_floor {
    double cloth, bodies;     /* m: the largest span means */
    double ke_lo[2], ke_hi[2]; /* x f64's: cloth, bodies */
} fid_floor;

/* kinetic energy as a multiple of the reference's (0 when it has none) */
static double ke_ratio(double x, double ref) { return ref > 0.0 ? x / ref : 0.0; }

static void fid_print(int scene, int quick, const result *r, const result *ref,
                      const fid_floor *fl) {
    double settle, span;
    int q;
    scene_times(scene, quick, &settle, &span);
    if (r != ref) { /* the reference: no departure from itself */
        fprintf(stderr, "  fidelity, host 1 vs f64's host 1 (m, at equal simulation time): "
                "cloth RMS mean %.3g", r->fid_cloth);
        if (fl) fprintf(stderr, " (%.2g x floor)", fl->cloth > 0.0 ? r->fid_cloth / fl->cloth : 0.0);
        fprintf(stderr, ", spheres mean %.3g", r->fid_bodies);
        if (fl)
            fprintf(stderr, " (%.2g x floor)", fl->bodies > 0.0 ? r->fid_bodies / fl->bodies : 0.0);
        fprintf(stderr, "\n    at");
        for (q = 0; q < FID_AT; ++q) fprintf(stderr, " %g", fid_time(q, settle, span));
        fprintf(stderr, " s: cloth");
        for (q = 0; q < FID_AT; ++q) fprintf(stderr, " %.2g", r->fid_at_c[q]);
        fprintf(stderr, "; spheres");
        for (q = 0; q < FID_AT; ++q) fprintf(stderr, " %.2g", r->fid_at_b[q]);
        fprintf(stderr, "\n");
    }
    fprintf(stderr, "    kinetic energy, mean over the span: cloth %.4g J (%.3f x f64's), "
            "spheres %.4g J (%.3f x); free fall, 0.5 s: %.4f m/s (%.4f x f64's)\n", r->ke_cloth,
            ke_ratio(r->ke_cloth, ref->ke_cloth), r->ke_bodies,
            ke_ratio(r->ke_bodies, ref->ke_bodies), r->fall, ke_ratio(r->fall, ref->fall));
}

/* The f64 reference of a scene (its host 1 kept for every later row) and
   floors_n nudged f64 runs, printed; *fl their range. */
static result fid_reference(int scene, int quick, fid_floor *fl) {
    result ref, f;
    int k, i;
    fid_ref_pending = 1;
    ref = run_scene(scene, ENC_F64, quick);
    fid_ref_pending = 0; /* (a failed run kept nothing) */
    if (!ref.ok) return ref;
    fprintf(stderr, "%-13s %-11s %12.1f %12.3f %11.3g %11.3g %12.3g   (--fidelity reference)\n",
            sc_name[scene], "f64", ref.kbps, ref.kbps_object, ref.eq_mean, ref.eq_p95,
            ref.divergence);
    fid_print(scene, quick, &ref, &ref, NULL);
    memset(fl, 0, sizeof *fl);
    for (k = 1; k <= floors_n; ++k) {
        nudge_seed = (uint32_t)k;
        f = run_scene(scene, ENC_F64, quick);
        nudge_seed = 0;
        if (!f.ok) continue;
        fprintf(stderr, "%-13s f64 nudged %.0e m, pattern %d: %.1f kbit/s, div@t mean %.3g\n",
                sc_name[scene], nudge, k, f.kbps, f.eq_mean);
        fid_print(scene, quick, &f, &ref, NULL);
        if (f.fid_cloth > fl->cloth) fl->cloth = f.fid_cloth;
        if (f.fid_bodies > fl->bodies) fl->bodies = f.fid_bodies;
        for (i = 0; i < 2; ++i) {
            double x = ke_ratio(i ? f.ke_bodies : f.ke_cloth, i ? ref.ke_bodies : ref.ke_cloth);
            if (k == 1 || x < fl->ke_lo[i]) fl->ke_lo[i] = x;
            if (k == 1 || x > fl->ke_hi[i]) fl->ke_hi[i] = x;
        }
    }
    fprintf(stderr, "  noise floor (%d nudges of %.0e m): cloth RMS mean up to %.3g, spheres up to "
            "%.3g; kinetic energy cloth %.3f..%.3f x f64's, spheres %.3f..%.3f\n", floors_n, nudge,
            fl->cloth, fl->bodies, fl->ke_lo[0], fl->ke_hi[0], fl->ke_lo[1], fl->ke_hi[1]);
    return ref;
}

/* ---- CPU: one full paper-scene snapshot encoded and decoded ---- */

#define MAXD 64
typedef struct cpu_pair {
    host h[2];
    unsigned char d[MAXD][GS_WIRE_MAX_DATAGRAM];
    size_t size[MAXD];
    int n;
    double now;
} cpu_pair;

static gs_result keep(void *user, uint32_t to, const void *data, size_t size) {
    cpu_pair *c = (cpu_pair *)user;
    (void)to;
    if (c->n < MAXD) {
        memcpy(c->d[c->n], data, size);
        c->size[c->n++] = size;
    }
    return GS_OK;
}

/* The datagrams kept, delivered to host `to` (not timed). */
static void cpu_deliver(cpu_pair *c, int to) {
    int i;
    for (i = 0; i < c->n; ++i) gs_net_deliver(c->h[to].net, c->d[i], c->size[i], c->now, NULL);
    c->n = 0;
}

#if defined(__GNUC__) || defined(__clang__)
#define NOINLINE __attribute__((noinline))
#else
#define NOINLINE
#endif
/* The two timed calls. */
static NOINLINE void cpu_encode(cpu_pair *c) { gs_net_update(c->h[0].net, c->now); }
static NOINLINE void cpu_decode(cpu_pair *c) {
    int i;
    for (i = 0; i < c->n; ++i) gs_net_deliver(c->h[1].net, c->d[i], c->size[i], c->now, NULL);
}

static NOINLINE void cpu_times(int enc, double *enc_us, double *dec_us, double *bytes) {
    cpu_pair *c = (cpu_pair *)calloc(1, sizeof *c);
    double te[200], td[200];
    int i, k, reps = 200;
    if (!c) {
        *enc_us = *dec_us = *bytes = 0.0;
        return;
    }
    gs_net_desc nd;
    memset(&nd, 0, sizeof nd);
    nd.transport.send = keep;
    nd.transport.user = c;
    nd.bandwidth = 1e9;
    for (i = 0; i < 2; ++i) {
        host_scene(&c->h[i], (uint32_t)i + 1, SC_PAPER_PUSH, enc);
        gs_net_create(c->h[i].w, &nd, &c->h[i].net);
        gs_net_add_peer(c->h[i].net, (uint32_t)(2 - i), NULL);
    }
    *bytes = 0.0;
    for (k = 0; k < reps; ++k) {
        double t0;
        gs_world_advance(c->h[0].w, FRAME, NULL); /* publishes every ghost */
        c->n = 0;
        c->now += FRAME;
        t0 = bu_now();
        cpu_encode(c);
        te[k] = bu_now() - t0;
        t0 = bu_now();
        cpu_decode(c);
        td[k] = bu_now() - t0;
        for (i = 0; i < c->n; ++i) *bytes += (double)c->size[i];
        c->n = 0; /* the acknowledgements back */
        gs_net_update(c->h[1].net, c->now);
        cpu_deliver(c, 0);
    }
    *bytes /= reps;
    *enc_us = 1e6 * bu_median(te, reps);
    *dec_us = 1e6 * bu_median(td, reps);
    for (i = 0; i < 2; ++i) {
        gs_net_destroy(c->h[i].net);
        gs_world_destroy(c->h[i].w);
    }
    free(c);
}

/* --cpu: the CPU table alone, f64 first (the ratios are to it). */
static int cpu_only(void) {
    static const int enc[3] = {ENC_F64, ENC_QUANT, ENC_DELTA};
    double eu[3], du[3], by[3];
    int e;
    fprintf(stderr, "paper scene, one full snapshot (all 6 objects), median of 200:\n");
    fprintf(stderr, "%-11s %10s %10s %10s\n", "encoding", "bytes", "encode us", "decode us");
    for (e = 0; e < 3; ++e) {
        cpu_times(enc[e], &eu[e], &du[e], &by[e]);
        fprintf(stderr, "%-11s %10.0f %10.1f %10.1f   encode+decode %.2f x f64's\n",
                enc_name[enc[e]], by[e], eu[e], du[e], (eu[e] + du[e]) / (eu[0] + du[0]));
    }
    return 0;
}

/* Is argv[*i] the flag name with a value after it? Then the value is read
   into *out and *i moves onto it: 1. Every one of these flags is a
   positive finite quantity (a rate, a step, a budget, a nudge), so a value
   that is not one is said and refused (-1), rather than read as 0, which
   would mean "the default". 0: not this flag. */
static int number_flag(int argc, char **argv, int *i, const char *name, double *out) {
    char *end;
    double v;
    if (strcmp(argv[*i], name) != 0 || *i + 1 >= argc) return 0;
    v = strtod(argv[++*i], &end);
    if (end == argv[*i] || *end != '\0' || !(v > 0.0 && v < HUGE_VAL)) {
        fprintf(stderr, "bandwidth: %s '%s' is not a positive number\n", name, argv[*i]);
        return -1;
    }
    *out = v;
    return 1;
}

/* Takes --scene, --encoding and --no-cpu out of argv (the rest goes to
   bu_parse_args): *sc and *en get a bit per name chosen (0: all). */
static int pick_args(int *argc, char **argv, unsigned *sc, unsigned *en, int *no_cpu) {
    int i, o = 1, k, n;
    *sc = *en = 0;
    *no_cpu = 0;
    for (i = 1; i < *argc; ++i) {
        int is_sc = strcmp(argv[i], "--scene") == 0, is_en = strcmp(argv[i], "--encoding") == 0;
        if (strcmp(argv[i], "--no-cpu") == 0) { *no_cpu = 1; continue; }
        if (strcmp(argv[i], "--adopt") == 0 && i + 1 < *argc) {
            ++i;
            if (strcmp(argv[i], "0") != 0 && strcmp(argv[i], "1") != 0) {
                fprintf(stderr, "bandwidth: --adopt '%s' is not 0 or 1\n", argv[i]);
                return -1;
            }
            adopt = argv[i][0] - '0';
            continue;
        }
        if (strcmp(argv[i], "--split") == 0) { split = 1; continue; }
        if (strcmp(argv[i], "--fidelity") == 0) { fidelity = 1; continue; }
        {
            static const char *const names[] = {"--cloth-rate", "--send-rate",
                                                 "--velocity-resolution",
                                                 "--position-resolution", "--budget", "--nudge"};
            double *const outs[] = {&cloth_rate, &send_rate, &vel_res, &pos_res, &budget, &nudge};
            int f, taken = 0;
            for (f = 0; f < 6 && taken == 0; ++f)
                taken = number_flag(*argc, argv, &i, names[f], outs[f]);
            if (taken < 0) return -1;
            if (taken) continue;
        }
        if (strcmp(argv[i], "--floors") == 0 && i + 1 < *argc) {
            char *end;
            long n = strtol(argv[++i], &end, 10);
            if (end == argv[i] || *end != '\0' || n < 1 || n > 64) {
                fprintf(stderr, "bandwidth: --floors '%s' is not a whole number in 1..64\n",
                        argv[i]);
                return -1;
            }
            floors_n = (int)n;
            continue;
        }
        if (strcmp(argv[i], "--mode") == 0 && i + 1 < *argc) {
            ++i;
            if (strcmp(argv[i], "replay") == 0) sync_mode = GS_SYNC_REPLAY;
            else if (strcmp(argv[i], "present") != 0) {
                fprintf(stderr, "bandwidth: unknown mode '%s' (present, replay)\n", argv[i]);
                return -1;
            }
            continue;
        }
        if (!is_sc && !is_en) { argv[o++] = argv[i]; continue; }
        if (i + 1 >= *argc) break;
        ++i;
        /* ints: C++ refuses a conditional between two enums' values */
        n = is_sc ? (int)SC_COUNT : (int)ENC_COUNT;
        for (k = 0; k < n; ++k)
            if (strcmp(argv[i], is_sc ? sc_name[k] : enc_name[k]) == 0) break;
        if (k == n) {
            fprintf(stderr, "bandwidth: unknown %s '%s'\n", is_sc ? "scene" : "encoding", argv[i]);
            return -1;
        }
        *(is_sc ? sc : en) |= 1u << k;
    }
    if (i < *argc) {
        fprintf(stderr, "bandwidth: %s needs a name\n", argv[i]);
        return -1;
    }
    *argc = o;
    return 0;
}

int main(int argc, char **argv) {
    bu_args args;
    bu_json *j;
    result r[SC_COUNT][ENC_COUNT];
    double eu[ENC_COUNT], du[ENC_COUNT], by[ENC_COUNT];
    fid_floor floors[SC_COUNT]; /* --fidelity: each scene's noise floor */
    unsigned pick_sc, pick_en;
    int no_cpu, s, e, rc;
    if (argc == 2 && strcmp(argv[1], "--cpu") == 0) return cpu_only();
    if (pick_args(&argc, argv, &pick_sc, &pick_en, &no_cpu) != 0) return 2;
    if (pick_sc) no_cpu = 1;
    memset(floors, 0, sizeof floors);
    rc = bu_parse_args(argc, argv, "bandwidth", &args);
    if (rc) return rc < 0 ? 2 : 0;
    fprintf(stderr, "%-13s %-11s %12s %12s %11s %11s %12s %10s\n", "scene", "encoding",
            "kbit/s/host", "kbit/s/obj", "div@t mean", "div@t p95", "div-vs-snap", "target");
    for (s = 0; s < SC_COUNT; ++s) {
        result ref;
        if (fidelity && !(args.quick && (s == SC_CLOTH64 || s == SC_SPHERES)) &&
            !(pick_sc && !(pick_sc >> s & 1u)))
            ref = fid_reference(s, args.quick, &floors[s]);
        else
            ref.ok = 0;
        for (e = 0; e < ENC_COUNT; ++e) {
            if ((args.quick && (s == SC_CLOTH64 || s == SC_SPHERES || e == ENC_F32 ||
                                e == ENC_QUANT || e == ENC_DELTA_REST || e == ENC_PREDICT)) ||
                (pick_sc && !(pick_sc >> s & 1u)) || (pick_en && !(pick_en >> e & 1u))) {
                memset(&r[s][e], 0, sizeof r[s][e]);
                continue;
            }
            r[s][e] = run_scene(s, e, args.quick);
            fprintf(stderr, "%-13s %-11s %12.1f %12.3f %11.3g %11.3g %12.3g %10.0f %s\n",
                    sc_name[s], enc_name[e], r[s][e].kbps, r[s][e].kbps_object, r[s][e].eq_mean,
                    r[s][e].eq_p95, r[s][e].divergence, sc_target[s],
                    r[s][e].kbps <= sc_target[s] ? "met" : "missed");
            if (split && r[s][e].ok) {
                int k;
                fprintf(stderr, "  split kbit/s:");
                for (k = 0; k < PART_COUNT; ++k)
                    fprintf(stderr, " %s %.1f", part_name[k], r[s][e].part_kbps[k]);
                fprintf(stderr, "; %.1f datagrams/s; cloth: %.1f chunks/s (%.1f not deltas), "
                        "positions %.1f kbit/s, velocities %.1f\n", r[s][e].datagrams,
                        r[s][e].cloth_chunks, r[s][e].cloth_keys, r[s][e].cloth_pos_kbps,
                        r[s][e].part_kbps[PART_CLOTH] - r[s][e].cloth_pos_kbps);
            }
            if (ref.ok && r[s][e].ok) fid_print(s, args.quick, &r[s][e], &ref, &floors[s]);
        }
    }
    if (!no_cpu) {
        fprintf(stderr, "\npaper scene, one full snapshot (all 6 objects), median of 200:\n");
        fprintf(stderr, "%-11s %10s %10s %10s\n", "encoding", "bytes", "encode us", "decode us");
    }
    for (e = 0; e < ENC_COUNT; ++e) {
        if ((args.quick && e == ENC_F32) || e == ENC_QUANT_REST || e == ENC_DELTA_REST ||
            e == ENC_PREDICT || no_cpu || (pick_en && !(pick_en >> e & 1u))) {
            eu[e] = du[e] = by[e] = 0.0; /* send on change: the same encoders */
            continue;
        }
        cpu_times(e, &eu[e], &du[e], &by[e]);
        fprintf(stderr, "%-11s %10.0f %10.1f %10.1f   encode+decode %.2f x f64's\n", enc_name[e],
                by[e], eu[e], du[e], (eu[e] + du[e]) / (eu[ENC_F64] + du[ENC_F64]));
    }
    /* the targets, each against the best encoding measured for it; the
       divergence at equal simulation time (mean) beside f64's (allowed: one
       position step more) */
    fprintf(stderr, "\ntargets (kbit/s per host; divergence at equal simulation time, mean, "
            "within f64's + %.0e m):\n", STEP);
    for (s = 0; s < SC_COUNT; ++s) {
        double best = -1.0;
        int be = 0;
        for (e = 0; e < ENC_COUNT; ++e)
            if (r[s][e].ok && (best < 0.0 || r[s][e].kbps < best)) { best = r[s][e].kbps; be = e; }
        if (best < 0.0) continue;
        fprintf(stderr, "  %-13s <= %6.0f: best %-11s %9.1f  %-6s  divergence %.3g vs f64 %.3g: %s\n",
                sc_name[s], sc_target[s], enc_name[be], best,
                best <= sc_target[s] ? "met" : "missed", r[s][be].eq_mean,
                r[s][ENC_F64].eq_mean,
                !r[s][ENC_F64].ok ? "f64 not run"
                : r[s][be].eq_mean <= r[s][ENC_F64].eq_mean + STEP ? "met" : "missed");
    }
    for (e = ENC_QUANT; e <= ENC_DELTA; e += ENC_DELTA - ENC_QUANT)
        if (by[e] > 0.0 && by[ENC_F64] > 0.0)
            fprintf(stderr, "  cpu %-11s encode+decode %.2f x f64's (<= 1): %s\n", enc_name[e],
                    (eu[e] + du[e]) / (eu[ENC_F64] + du[ENC_F64]),
                    eu[e] + du[e] <= eu[ENC_F64] + du[ENC_F64] ? "met" : "missed");
    j = bu_json_open(args.out);
    if (!j) return 1;
    bu_json_obj_begin(j, NULL);
    bu_json_header(j, "bandwidth", args.quick);
    bu_json_str(j, "method", "two hosts on gs_simnet (perfect link), 60 Hz frames and ghosts; "
                "kbit/s of datagram bytes host 1 sent host 2 over the measured span; "
                "divergence at equal simulation time: every frame of that span each host's "
                "reference time (the cloth's; the first sphere's in spheres900) and object "
                "positions are kept, host 2's samples interpolated linearly to host 1's time, the "
                "largest over the objects of the RMS distance (cloth) or distance (spheres; "
                "probes left out), mean and p95 over the frames (divergence_equal_time_*; "
                "the target check divergence_equal_time_within_f64_plus_step uses the mean); "
                "divergence_m = divergence_latest_snapshot_m = mean of host 1's peer divergence "
                "stat (its objects against host 2's latest snapshot) over that span, "
                "divergence_within_f64_plus_step on it as before; "
                "CPU = median gs_net_update / gs_net_deliver time of one full paper-scene "
                "snapshot");
    bu_json_arr_begin(j, "results");
    for (s = 0; s < SC_COUNT; ++s)
        for (e = 0; e < ENC_COUNT; ++e) {
            bu_json_obj_begin(j, NULL);
            bu_json_str(j, "scene", sc_name[s]);
            bu_json_str(j, "encoding", enc_name[e]);
            bu_json_num(j, "target_kbit_s", sc_target[s]);
            if (!r[s][e].ok) { /* not run (--quick) */
                bu_json_null(j, "kbit_s_per_host");
                bu_json_obj_end(j);
                continue;
            }
            bu_json_num(j, "kbit_s_per_host", r[s][e].kbps);
            bu_json_num(j, "kbit_s_per_object", r[s][e].kbps_object);
            bu_json_num(j, "divergence_m", r[s][e].divergence);
            bu_json_num(j, "divergence_latest_snapshot_m", r[s][e].divergence);
            bu_json_num(j, "divergence_equal_time_mean_m", r[s][e].eq_mean);
            bu_json_num(j, "divergence_equal_time_p95_m", r[s][e].eq_p95);
            bu_json_bool(j, "target_met", r[s][e].kbps <= sc_target[s]);
            if (fidelity) { /* --fidelity: against the f64 reference's host 1 */
                bu_json_num(j, "fidelity_cloth_rms_mean_m", r[s][e].fid_cloth);
                bu_json_num(j, "fidelity_spheres_mean_m", r[s][e].fid_bodies);
                bu_json_num(j, "fidelity_cloth_kinetic_energy_j", r[s][e].ke_cloth);
                bu_json_num(j, "fidelity_spheres_kinetic_energy_j", r[s][e].ke_bodies);
                bu_json_num(j, "fidelity_free_fall_speed_m_s", r[s][e].fall);
            }
            if (r[s][ENC_F64].ok) {
                bu_json_bool(j, "divergence_within_f64_plus_step",
                             r[s][e].divergence <= r[s][ENC_F64].divergence + STEP);
                bu_json_bool(j, "divergence_equal_time_within_f64_plus_step",
                             r[s][e].eq_mean <= r[s][ENC_F64].eq_mean + STEP);
            }
            bu_json_obj_end(j);
        }
    for (e = 0; e < ENC_COUNT; ++e) {
        if (by[e] == 0.0) continue; /* not run (--quick, or send on change) */
        bu_json_obj_begin(j, NULL);
        bu_json_str(j, "scene", "cpu-paper-snapshot");
        bu_json_str(j, "encoding", enc_name[e]);
        bu_json_num(j, "bytes", by[e]);
        bu_json_num(j, "encode_us", eu[e]);
        bu_json_num(j, "decode_us", du[e]);
        bu_json_num(j, "encode_decode_vs_f64", (eu[e] + du[e]) / (eu[ENC_F64] + du[ENC_F64]));
        bu_json_obj_end(j);
    }
    bu_json_arr_end(j);
    /* each target against the best encoding measured for it */
    bu_json_obj_begin(j, "summary");
    for (s = 0; s < SC_COUNT; ++s) {
        char k1[64], k2[64], k3[64], k4[64], txt[160];
        double best = -1.0;
        int be = 0;
        for (e = 0; e < ENC_COUNT; ++e)
            if (r[s][e].ok && (best < 0.0 || r[s][e].kbps < best)) { best = r[s][e].kbps; be = e; }
        if (best < 0.0) continue;
        snprintf(k1, sizeof k1, "target_%s", sc_name[s]);
        snprintf(k2, sizeof k2, "target_met_%s", sc_name[s]);
        snprintf(txt, sizeof txt, "%s <= %.0f kbit/s per host (best: %s, %.1f)", sc_name[s],
                 sc_target[s], enc_name[be], best);
        bu_json_str(j, k1, txt);
        bu_json_bool(j, k2, best <= sc_target[s]);
        if (fidelity) { /* the largest span means of the nudged f64 runs */
            snprintf(k3, sizeof k3, "fidelity_floor_cloth_rms_mean_m_%s", sc_name[s]);
            bu_json_num(j, k3, floors[s].cloth);
            snprintf(k3, sizeof k3, "fidelity_floor_spheres_mean_m_%s", sc_name[s]);
            bu_json_num(j, k3, floors[s].bodies);
        }
        if (!r[s][ENC_F64].ok) continue;
        snprintf(k3, sizeof k3, "target_divergence_%s", sc_name[s]);
        snprintf(k4, sizeof k4, "target_met_divergence_%s", sc_name[s]);
        snprintf(txt, sizeof txt, "%s: %s's divergence at equal simulation time (mean, %.3g m) "
                 "<= f64's (%.3g m) + %.0e m", sc_name[s], enc_name[be], r[s][be].eq_mean,
                 r[s][ENC_F64].eq_mean, STEP);
        bu_json_str(j, k3, txt);
        bu_json_bool(j, k4, r[s][be].eq_mean <= r[s][ENC_F64].eq_mean + STEP);
    }
    bu_json_str(j, "target_cpu", "quant encode + decode of the paper scene no slower than f64");
    bu_json_bool(j, "target_met_cpu", eu[ENC_QUANT] + du[ENC_QUANT] <= eu[ENC_F64] + du[ENC_F64]);
    bu_json_str(j, "target_cpu_delta",
                "quant+delta encode + decode of the paper scene no slower than f64");
    bu_json_bool(j, "target_met_cpu_delta",
                 eu[ENC_DELTA] + du[ENC_DELTA] <= eu[ENC_F64] + du[ENC_F64]);
    bu_json_obj_end(j);
    bu_json_obj_end(j);
    return bu_json_close(j) == 0 ? 0 : 1;
}
