/* ghostsim.h - v0.1.0 - collaborative interactive physics in one C header

   Several people on several hosts push and pull one shared physical scene.
   Every host runs the whole simulation; ghosts blend each host's state of
   an object with the states its peers send, weighted by a rule (Dequidt,
   Grisoni, Chaillou: "Collaborative Interactive Physical Simulation").
   Nobody freezes when the network is slow or gone.

   GETTING THE IMPLEMENTATION
       In exactly one C or C++ file:
           #define GHOSTSIM_IMPLEMENTATION
           #include "ghostsim.h"
       Every other file includes the header alone. The implementation needs
       POSIX (clock_gettime, sockets, pthreads) and asks for it itself; if
       that file includes a system header before this one, compile it with
       -D_POSIX_C_SOURCE=200809L (or -std=gnu99, or as C++). Link with
       $(pkg-config --libs ccd) -lm -lpthread.

   QUICK START: two hosts share the paper's scene on a simulated network
       // The body of main(), with <math.h> and <stdio.h>. tests/test_manual.c
       // compiles and runs this text as it stands here.
       gs_simnet *sim;
       gs_world *w[2];
       gs_net *net[2];
       gs_scene sc[2];
       gs_scene_desc sd = gs_scene_desc_default(); // a cloth, 3 spheres
       gs_ghost_desc gd = gs_ghost_desc_default(); // client/server rule
       sd.probe_count = 2;                      // one probe per host
       if (gs_simnet_create(NULL, &sim) != GS_OK) return 1;
       for (int h = 0; h < 2; ++h) {            // every host builds the same
           gs_world_desc wd = gs_world_desc_default();
           gs_net_desc nd = gs_net_desc_default();
           wd.host_id = (uint32_t)h + 1;        // hosts 1 and 2
           if (gs_world_create(&wd, &w[h]) != GS_OK) return 1;
           if (gs_scene_create(w[h], &sd, &sc[h]) != GS_OK ||
               gs_scene_attach_ghosts(&sc[h], &gd) != GS_OK ||
               gs_simnet_transport(sim, &nd.transport) != GS_OK ||
               gs_net_create(w[h], &nd, &net[h]) != GS_OK) {  // joins
               fprintf(stderr, "%s\n", gs_world_error(w[h]));
               return 1;
           }
       }
       for (int f = 1; f <= 360; ++f) {         // 6 s in frames of 1/60 s
           double t = fmin(f / 60.0, 2.0);      // the probes stop at 2 s
           for (int h = 0; h < 2; ++h)          // each host moves its own
               gs_probe_set_target(sc[h].probes[h], gs_scene_probe_path(h, t),
                                   gs_rigid_orientation(sc[h].probes[h]));
           gs_simnet_run(sim, 1.0 / 60.0, 1.0 / 60.0); // one frame, all hosts
       }
       double gap = 0.0;                        // how far apart the hosts are
       for (int i = 0; i < sc[0].sphere_count; ++i) {
           gs_vec3 a = gs_rigid_position(sc[0].spheres[i]);
           gs_vec3 b = gs_rigid_position(sc[1].spheres[i]);
           gap = fmax(gap, fabs(a.x - b.x) + fabs(a.y - b.y) + fabs(a.z - b.z));
       }
       printf("the hosts' spheres are %.1e m apart\n", gap);
       for (int h = 0; h < 2; ++h) gs_world_destroy(w[h]);
       gs_simnet_destroy(sim);
       return gap < 1e-3 ? 0 : 1;               // within 1 mm: they agree

   QUICK START OVER UDP: the same two hosts on loopback sockets
       // The body of main(), with <math.h>, <stdio.h>, <string.h> and
       // <time.h>. Both hosts live in one process here; in an application
       // each is its own process (or machine) that runs one h of the loops.
       const char *addr[2] = {"127.0.0.1:47301", "127.0.0.1:47302"};
       gs_world *w[2];
       gs_net *net[2];
       gs_scene sc[2];
       gs_scene_desc sd = gs_scene_desc_default();
       gs_ghost_desc gd = gs_ghost_desc_default();
       sd.probe_count = 2;
       for (int h = 0; h < 2; ++h) {
           gs_world_desc wd = gs_world_desc_default();
           gs_udp_desc ud = gs_udp_desc_default(); // poll mode
           gs_net_desc nd = gs_net_desc_default();
           gs_udp *u;
           wd.host_id = (uint32_t)h + 1;
           ud.bind = addr[h];
           if (gs_world_create(&wd, &w[h]) != GS_OK) return 1;
           if (gs_scene_create(w[h], &sd, &sc[h]) != GS_OK ||
               gs_scene_attach_ghosts(&sc[h], &gd) != GS_OK ||
               gs_udp_create(w[h], &ud, &u) != GS_OK ||  // the socket first,
               gs_udp_transport(u, &nd.transport) != GS_OK ||
               gs_net_create(w[h], &nd, &net[h]) != GS_OK || // (owns u now)
               gs_net_add_peer(net[h], 2 - (uint32_t)h, addr[1 - h]) != GS_OK) {
               fprintf(stderr, "%s\n", gs_world_error(w[h]));  // then the peer
               return 1;
           }
       }
       double start = gs_udp_now(), last = start, now;
       while ((now = gs_udp_now()) - start < 6.0) {   // 6 s of wall time
           double t = fmin(now - start, 2.0);           // probes stop at 2 s
           for (int h = 0; h < 2; ++h) {
               gs_probe_set_target(sc[h].probes[h], gs_scene_probe_path(h, t),
                                   gs_rigid_orientation(sc[h].probes[h]));
               gs_world_advance(w[h], now - last, NULL); // blend, step, publish
               gs_net_poll(net[h], now);                 // receive, send
           }
           last = now;
           struct timespec frame = {0, 10000000};       // 100 frames a second
           nanosleep(&frame, NULL);
       }
       double gap = 0.0;
       for (int i = 0; i < sc[0].sphere_count; ++i) {
           gs_vec3 a = gs_rigid_position(sc[0].spheres[i]);
           gs_vec3 b = gs_rigid_position(sc[1].spheres[i]);
           gap = fmax(gap, fabs(a.x - b.x) + fabs(a.y - b.y) + fabs(a.z - b.z));
       }
       printf("the hosts' spheres are %.1e m apart\n", gap);
       for (int h = 0; h < 2; ++h)
           gs_world_destroy(w[h]);              // its net, and the gs_udp
       return gap < 1e-3 ? 0 : 1;

   THE FRAME LOOP
       Each host, once a frame, in this order:
         1. deliver what arrived: gs_net_deliver(net, data, size, now, &why)
            for each datagram your transport received;
         2. gs_world_advance(w, seconds, NULL): the agents step; after
            each step its agent's ghost publishes the new state, and the
            snapshots delivered since blend into every ghost at once;
         3. gs_net_update(net, now): sends each ghost's latest state, at its
            send rate and within each peer's bandwidth.
       Between frames (never from a callback) the application moves its
       probes (gs_probe_set_target) and pins, and reads what to draw
       (gs_ghost_render_state smooths the blends' corrections).
       The transports do parts of it: gs_simnet_run does 2 and 3 for every
       host it joined, then 1 with what arrived during the frame, for as
       many frames as asked; gs_net_poll(net, now) on gs_udp in poll mode
       (threads 0) does 1 then 3, so it comes right after the advance;
       with threads 1 the gather thread delivers as datagrams arrive and
       the scatter thread sends, and gs_net_poll only wakes the scatter
       thread.
       `now` is wall-clock time in seconds from one monotonic clock per
       host: the same clock for every gs_net_deliver, gs_net_update and
       gs_net_poll of that host, in [0, GS_WIRE_MAX_TIME], never going
       back. With gs_udp it is gs_udp_now() (its receive side reads that
       clock); a gs_simnet keeps its own. `seconds` is the same clock's
       time since the last frame, so that simulated time keeps wall-clock
       pace with the peers.

   RULES
       - Objects in contact have one authority. The cloth and the spheres
         on it push each other every step: if the cloth follows host 1 and
         the spheres host 2, each host's copy of one is pulled toward a
         state that the other's copy of the other produced, and the copies
         stay centimetres apart and drift. Weigh every shared object with
         the same rule that picks one host for all of them at once:
         gs_weight_cs, the client/server rule, whose authority is the
         leader (the most advanced host; hosts in step are a tie that the
         lowest host id wins). Probes are owned (gs_weight_owner): each is
         where its host puts it. gs_scene_attach_ghosts does both.
       - Object ids belong to the session: every host gives an object the
         same id (gs_ghost_desc.object_id; gs_scene_attach_ghosts numbers
         the scene's) and builds it the same way. A datagram holding an id
         this host does not know, or a state of another size or encoding,
         is refused whole (GS_REJECT_OBJECT, GS_REJECT_RANGE), every other
         object in it with it. Host ids are > 0 and distinct.
       - The paper's scene: the same gs_scene_desc on every host, with
         probe_count equal to the number of hosts (probe i belongs to host
         i + 1, so the hosts are numbered 1..N); a host with another count
         sends a probe the others do not know (see above).
       - One way to make a net: gs_net_create, on a transport
         (gs_simnet_transport, gs_udp_create + gs_udp_transport, or your
         own gs_transport). The transport exists before its peers:
         gs_net_add_peer(net, host, addr) names each (addr "HOST:PORT" on
         gs_udp, NULL on the simnet, which adds its hosts itself).
         Nothing goes to a host that is not a peer, and what it sends is
         refused (GS_REJECT_SENDER).
       - `now` never goes back. One that does is not refused (only NaN,
         infinity and values outside [0, GS_WIRE_MAX_TIME] are): until the
         clock is past where it was, every ghost is due at each update, the
         bandwidth budget and the receive cap refill nothing, and the peers
         misjudge the age of this host's snapshots (by more than GS_MAX_AGE:
         unknown), so their weight rules misjudge who leads. It is counted
         (gs_peer_stats.clock_backwards) and shows as every peer's health,
         GS_PEER_CLOCK_BACK, until the clock is past where it was.
         gs_world_advance refuses negative seconds (GS_ERR_INVALID_ARG; the
         world does not move).
       - Every host keeps wall-clock pace, in short frames (60 a second or
         so). A machine that cannot step its scene as fast as wall time
         passes makes each frame longer than the last: its snapshots go
         out, and its blends come, once a long frame, and its copies do not
         meet the others' (with a wall-clock budget, gs_world_desc.budget,
         it falls behind instead: gs_world_sync_stats.lag).
       - A world and its net belong to one thread (see THREADS), and user
         callbacks do not change them (GS_ERR_BUSY: see ERRORS).

   CONCEPTS
       world      Owns agents, the scheduler and the net. One thread's.
       agent      One simulated object with its own dt, integrator, state
                  and simulation time: a spring-mass mesh or cloth, a rigid
                  body, a probe (a kinematic body the user moves), or a
                  user agent (gs_custom_desc).
       scheduler  N+1 priority queues (the paper's Q_0..Q_N): the most
                  urgent runnable agent steps next, aging keeps low queues
                  from starving, an agent that leads the slowest by more
                  than the world's tolerance is held back.
       state      A flat array of doubles: [t, then the agent's variables];
                  what ghosts blend between hosts.
       contact    Penalty forces between agents (gs_material), momentum
                  exchanged, never made.
       ghost      Wraps an agent under an object id shared by all hosts:
                  publishes its state and blends the snapshots peers send
                  with the paper's weighted mean (gs_weight_fn rules).
       snapshot   One agent's state at one simulation time, on the wire in
                  chunks of at most one datagram (wire format v2).
       transport  What carries datagrams: gs_simnet (simulated, seeded),
                  gs_udp (POSIX), or yours; a gs_transport table.
       sync       The session clock (hosts at one simulation time at one
                  wall instant), the world history (gs_world_sync_test) and
                  the replay blend (GS_SYNC_REPLAY): gs_sync_desc.

   INDEX (search for a tag: it marks its part in the declarations and again
   in the implementation)
       >>config   version, GS_API, the allocator and clock callbacks
       >>math     gs_vec3, gs_quat, GS_MAX_COORD
       >>result   gs_result codes and gs_result_str
       >>world    create, advance, destroy; sync and sleep settings
       >>sched    behaviour rules, per-agent scheduling counters
       >>agent    solver settings, state get/set, stepping, sleep, custom
       >>cloth    spring-mass meshes and the cloth generator
       >>rigid    rigid bodies (sphere, box, hull) and probes
       >>contact  the narrow phase, materials, the ground plane
       >>scene    the paper's scene: cloth, spheres, a probe per host
       >>ghost    ghosts, weight rules, encodings, render smoothing
       >>sync     session clock, world history, replay blend
       >>wire     the datagram format, encode and decode
       >>net      peers, sending, delivering, validation, statistics
       >>simnet   several worlds on one virtual network
       >>udp      POSIX UDP: gather and scatter threads or poll mode
       >>crc      (implementation only) the datagram checksum

   OPTIONS (macros)
       macro                    where            default
       GHOSTSIM_IMPLEMENTATION  one .c file      off: declarations only
       GHOSTSIM_STATIC          before include   off: functions are extern
       GS_MALLOC(sz, ctx)       implementation   malloc(sz)  (define both
       GS_FREE(p, ctx)          implementation   free(p)      or neither)
       GS_ASSERT(c)             implementation   assert(c)
       GS_MAX_QUEUES            implementation   64: most priority queues
       GHOSTSIM_NO_UDP          before include   off: the POSIX UDP transport
                                                 is in (link -lpthread)
       GHOSTSIM_NO_SIMD         implementation   off: SSE2 (x86-64) runs two
                                                 springs at a time; on, plain
                                                 C, the same bits
       GHOSTSIM_SODIUM          implementation   off: no encryption; on, a key
                                                 in gs_net_desc seals every
                                                 datagram (libsodium AEAD;
                                                 link -lsodium)
       A runtime allocator {alloc, free, user} in gs_world_desc overrides
       GS_MALLOC/GS_FREE for that world.

   ERRORS
       Every call that can fail returns gs_result: GS_OK (0) or a negative
       code; gs_result_str() names it and gs_world_error() says what exactly
       was wrong with the last failed call on that world. Bad data from
       outside (a desc, a state vector) is an error code, never an assert;
       a failed call changes nothing (a call that fails half way undoes
       what it did). A NULL handle is GS_ERR_INVALID_ARG (no world to hold
       a message then); a count whose bytes would not fit in size_t is
       GS_ERR_OUT_OF_RANGE; out of memory is GS_ERR_NO_MEMORY, never
       abort(); a fixed limit (max_peers, the simnet's hosts) is
       GS_ERR_CAPACITY. The simnet's own failures are in gs_simnet_error.
       Mistakes no call can return (nothing sent or heard for a second,
       every datagram of a peer refused, a clock that went back) show in
       gs_peer_stats.health and .reason, and gs_world_diagnose(w) lists
       them (README: Troubleshooting).
       Callbacks: user code runs inside the library's calls: a custom
       agent's step, get_state and set_state, behaviour rules and weight
       rules run inside gs_world_advance, gs_agent_step, gs_world_hash,
       gs_agent_get_state/set_state and gs_ghost_attach; the send callback
       inside gs_net_update. From there, every call that would change the
       world, an agent, a ghost, the net or the simnet returns GS_ERR_BUSY
       (advance, create, destroy, set_state, step, set_gravity,
       set_budget, set_ground, probe targets, pins, ghost attach and
       detach, net create, peers added or removed, gs_net_poll on a
       transport with a poll; while a gs_simnet_run runs, gs_net_create
       on it, gs_simnet_link and _run); gs_world_destroy,
       gs_net_destroy, gs_udp_close and gs_net_set_lock are refused
       (nothing freed or changed, the reason in gs_world_error), and
       gs_simnet_destroy is ignored while its run goes on. gs_net_update
       and gs_net_deliver, which any thread may call, return GS_ERR_BUSY
       from the send callback (the net's datagram is in use then) and work
       from a custom step, a behaviour rule or a weight rule. Reading is
       always allowed (getters, gs_agent_get_state, gs_ghost_get_stats, gs_ghost_render_state,
       gs_net_peer_stats, gs_net_unknown_stats), and so are
       gs_agent_set_priority and gs_agent_set_behaviour.

   NUMBERS
       SI units throughout: seconds, metres, kilograms, newtons. Positions
       and sizes lie within +-GS_MAX_COORD (1e9 m): a create call,
       gs_agent_set_state (and so a snapshot blended in), gs_mesh_move_pin,
       gs_probe_set_target or gs_world_set_ground outside it is refused
       with GS_ERR_OUT_OF_RANGE, as is a mass or inertia whose inverse is
       not finite. No NaN or infinity ever leaves an agent, built-in or
       custom: a step that would produce one, leave the range, or move
       faster than solver.max_speed is undone and reported as
       GS_ERR_UNSTABLE; the agent keeps its last finite state (a custom
       agent's is read before each step and put back through its
       set_state). A quaternion of any finite size is normalized;
       set_state refuses one of norm under 1e-6. Bodies whose centres
       coincide (closer than 1e-12 of their size) are pushed apart along
       y, the lower agent index down. A pile of coincident or deeply
       overlapping rigid bodies keeps its momentum to rounding and ends
       with no more kinetic energy than its contact springs stored; one
       too stiff for max_substeps is refused (GS_ERR_UNSTABLE).
       Times: every agent's time, the world's and the simnet's clock, and
       the `now` a net is given stay in [0, GS_WIRE_MAX_TIME] (1e9 s): a
       state, an advance, a frame or a `now` that would leave it is
       refused (GS_ERR_INVALID_ARG), a step that would pass it fails with
       GS_ERR_OUT_OF_RANGE. Every dt is at least GS_MIN_DT (1e-6 s), so a
       step always moves a clock, and one gs_world_advance runs at most
       gs_world_desc.max_steps steps: every call that counts time returns.
       What a peer can do to this host's clock is bounded too (see >>ghost:
       GS_MAX_AGE, GS_MAX_TIME_CORRECTION): at most 10 s per advance.

   THREADS
       A world and everything in it belongs to the thread that calls into
       it. Two worlds on two threads share nothing. The library has no
       global mutable state. gs_udp (threads = 1) runs a gather thread
       (receive, validate, queue) and a scatter thread (send what is due);
       they touch only the net's peers, queues, published states and
       statistics, under one mutex that the world thread also takes when a
       ghost publishes or takes the snapshots waiting for it. gs_net_deliver,
       gs_net_update and the stats calls are safe from any thread;
       everything else (adding and removing peers included) belongs to the
       world's thread. Weight rules run with no lock held: the snapshots
       are taken out of the net's queues under the lock and blended after
       it is released, so a rule may call the calls any thread may (the
       calls that change the world or the net return GS_ERR_BUSY). The
       send callback runs with the lock held: gs_udp's mutex is recursive,
       so that its calls into the net take it again (stats answer; the
       calls that change the net return GS_ERR_BUSY) and never deadlock. A
       lock of your own (gs_net_set_lock) must be recursive as well if
       your send callback calls into the net.

   REVISION HISTORY
       0.1.0 (2026-11-23)  world, scheduler, spring-mass agents, integrators,
                           rigid bodies, probes, contacts, the paper's scene,
                           ghosts, wire format v1, simnet, POSIX UDP.
       unreleased          wire format v3 (v1 and v2 refused as
                           GS_REJECT_OLD_VERSION): GS_ENCODING_QUANT, send on
                           change with heartbeats, priority within a peer's
                           budget, gs_wire_values; delta coding against
                           acknowledged baselines (gs_ghost_desc.delta,
                           GS_REJECT_BASELINE); compact chunk headers coded
                           against the chunk before, lengths implied, a
                           Rice coding of deltas, and a spatial one (a
                           cloth's differences less the median edge
                           prediction from its neighbours in the chunk).
                           One way to make a net: gs_net_create on a
                           gs_transport (gs_simnet_transport,
                           gs_udp_create + gs_udp_transport, or yours);
                           gs_net_add_peer(net, host, addr); gs_net_poll.
                           gs_simnet_join, gs_udp_open, gs_udp_add_peer,
                           gs_udp_remove_peer, gs_udp_net, gs_udp_poll and
                           gs_net_desc.send/send_user are gone.
                           A frame grid on the session clock
                           (gs_sync_desc.frame, gs_world_next_frame): the
                           hosts' frame loops lock in phase.

   LICENSE: MIT, at the end of this file.
*/
#ifndef GHOSTSIM_H_INCLUDED
#define GHOSTSIM_H_INCLUDED

/* ========================================================================
   >>config
   ======================================================================== */
#define GHOSTSIM_VERSION_MAJOR 0
#define GHOSTSIM_VERSION_MINOR 1
#define GHOSTSIM_VERSION_PATCH 0
#define GHOSTSIM_VERSION_STRING "0.1.0"

/* The implementation needs POSIX (clock_gettime, getaddrinfo, threads);
   strict -std=c99 hides it unless asked for before the first system header. */
#if defined(GHOSTSIM_IMPLEMENTATION) && defined(__STRICT_ANSI__) && \
    !defined(_POSIX_C_SOURCE) && !defined(_GNU_SOURCE) && !defined(__cplusplus)
#define _POSIX_C_SOURCE 200809L
#endif

#include <stddef.h>
#include <stdint.h>

#ifndef GS_API
#if defined(GHOSTSIM_STATIC) && (defined(__GNUC__) || defined(__clang__))
#define GS_API static __attribute__((unused))
#elif defined(GHOSTSIM_STATIC)
#define GS_API static
#else
#define GS_API extern
#endif
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* Allocation callbacks with a context pointer, passed in gs_world_desc. */
typedef struct gs_allocator {
    void *(*alloc)(size_t size, void *user); /* NULL on failure */
    void (*free)(void *ptr, void *user);     /* ptr may be NULL */
    void *user;
} gs_allocator;

/* A clock in seconds that only ever moves forward. */
typedef double (*gs_clock_fn)(void *user);

/* ========================================================================
   >>math
   ======================================================================== */
typedef struct gs_vec3 { double x, y, z; } gs_vec3;
typedef struct gs_quat { double x, y, z, w; } gs_quat; /* w is the scalar */

/* The coordinate range, in metres: every position an agent holds (and every
   size: a radius, a half extent, a cloth's width) lies within +-GS_MAX_COORD.
   A double there still resolves 1.2e-7 m, and sums, differences and squared
   distances of such numbers cannot overflow. A create call, set_state,
   gs_mesh_move_pin, gs_probe_set_target or gs_world_set_ground outside it
   is GS_ERR_OUT_OF_RANGE; a step that would leave it is undone
   (GS_ERR_UNSTABLE). */
#define GS_MAX_COORD 1e9

/* ========================================================================
   >>result
   Negative codes are errors. The list makes both the enum and the strings.
   ======================================================================== */
#define GS__RESULT_LIST(X)                                                     \
    X(GS_OK, 0, "ok")                                                          \
    X(GS_ERR_INVALID_ARG, -1, "invalid argument")                              \
    X(GS_ERR_NOT_FINITE, -2, "a number is NaN or infinite")                    \
    X(GS_ERR_OUT_OF_RANGE, -3,                                                 \
      "an index, count or coordinate is out of range")                         \
    X(GS_ERR_SIZE_MISMATCH, -4, "an array has the wrong length")               \
    X(GS_ERR_NO_MEMORY, -5, "out of memory")                                   \
    X(GS_ERR_UNSTABLE, -6,                                                     \
      "the step would be numerically unstable; the agent kept its last "       \
      "finite state")                                                          \
    X(GS_ERR_BUSY, -7, "the world is advancing; not allowed from inside it")   \
    X(GS_ERR_CAPACITY, -8, "a fixed capacity is exhausted")                    \
    X(GS_ERR_REJECTED, -9, "a datagram was refused (see gs_reject)")           \
    X(GS_ERR_SYSTEM, -10, "the operating system refused (socket, thread)")     \
    X(GS_ERR_UNSUPPORTED, -11,                                                 \
      "not built in: its option macro was not defined (see OPTIONS)")

typedef enum gs_result {
#define GS__RESULT_ENUM(name, value, text) name = value,
    GS__RESULT_LIST(GS__RESULT_ENUM)
#undef GS__RESULT_ENUM
    GS__RESULT_FORCE_INT = 0x7fffffff
} gs_result;

/* Returns a static, human-readable description of a result code; never NULL
   (an unknown code gives "unknown result"). */
GS_API const char *gs_result_str(gs_result r);

/* ========================================================================
   >>world
   ======================================================================== */
typedef struct gs_world gs_world;
typedef struct gs_agent gs_agent;

/* How a world keeps time with its peers and what it remembers to re-run
   (the sync layer, >>sync). */
typedef enum gs_sync_clock {
    GS_SYNC_CLOCK_DEFAULT = 0, /* local */
    GS_SYNC_CLOCK_LOCAL,       /* the target moves on by the seconds each
                                  gs_world_advance is given */
    GS_SYNC_CLOCK_SESSION,     /* the target follows the session's timeline:
                                  the local clock plus an origin taken from
                                  the session's timekeeper (the lowest host
                                  id on the timeline), so that hosts in step
                                  are at the same simulation time at the
                                  same wall instant; ghosts publish at the
                                  end of each advance */
    GS__SYNC_CLOCK_COUNT
} gs_sync_clock;

typedef enum gs_sync_mode {
    GS_SYNC_DEFAULT = 0,   /* present */
    GS_SYNC_PRESENT,       /* the paper: a snapshot blends at the local
                              present, after the next step of its agent */
    GS_SYNC_REPLAY,        /* a peer's snapshots blend as a whole set (every
                              ghost, every chunk, one time) when the world
                              reaches that time, in a re-run from the last
                              recorded moment before it, then on to the
                              present, inside the same gs_world_advance (a
                              blend there that changes no state ends the
                              re-run: the present stands); sets older
                              than the history or replay_reach, past the
                              replay budget, or taken while the host
                              catches up, blend at the present; partial
                              sets a newer whole one supersedes are dropped.
                              A peer's probe goes on along its velocity
                              between snapshots. Meant with the session
                              clock, and ghosts of one send rate; time is
                              not blended */
    GS__SYNC_COUNT
} gs_sync_mode;

typedef struct gs_sync_desc {
    gs_sync_mode mode;     /* default present */
    gs_sync_clock clock;   /* default local. Every host of a session needs
                              the same mode and clock: a peer that runs
                              others shows as GS_PEER_OTHER_MODE */
    gs_clock_fn now;       /* the wall clock the session clock reads (s);
                              default the world's clock; a simnet transport
                              sets the simnet's clock of the host (so the
                              simnet must outlive the world's advances) */
    void *now_user;
    int history_frames;    /* advances the world history keeps, to re-run
                              from (gs_world_sync_test); default 16, a
                              200 ms round trip plus a send period at 60 Hz;
                              at most 1024; -1: no history */
    int replay_budget;     /* agent steps a replay may re-run per advance
                              (estimated from the last advance's steps per
                              frame); default 4096; past it the snapshots
                              blend at the present and are counted */
    double frame;          /* s; session clock only: each advance's target
                              is the session time rounded to the nearest
                              multiple of `frame` counted from the
                              session's time 0, so hosts that advance near
                              the same boundary (gs_world_next_frame) run
                              to the same time; default 0: off (the
                              target is the session time itself); at most
                              0.05 */
    double replay_tolerance; /* m; replay mode: a replay whose first blend
                              moves no ghost's state by more than this (a
                              position or quaternion component; a velocity
                              by what it moves in a send period) is not
                              run: the present stands, as for a blend that
                              changes no bit. At most GS_REPLAY_NEAR_SKIPS
                              in a row: the next one runs (so that copies
                              at rest still end bitwise equal). Default 0:
                              GS_REPLAY_TOLERANCE; negative: off (every
                              blend that changes a bit replays) */
    int replay_every;      /* advances; replay mode: the snapshots that
                              arrive wait in the queues and are taken (the
                              newest whole set of each peer, one replay)
                              once every `replay_every` advances that have
                              some: a replay costs about its span, the
                              latency, and one every k advances spans
                              hardly more, so the re-run steps fall about
                              k-fold, while each copy drifts on its own
                              k-1 frames longer between corrections.
                              Default 0: GS_REPLAY_EVERY; 1: every advance;
                              at most GS_REPLAY_EVERY_MAX */
    double replay_reach;   /* s of simulation; replay mode: how much of
                              the past a replay may take on. Snapshots
                              older than this before the advance's target
                              blend at the present (counted in fallbacks),
                              as past the history or the budget, which
                              count frames and steps and so stretch when
                              a host's advances grow long. And after an
                              advance over a fifth of it (a host catching
                              up, starved of CPU), the snapshots blend at
                              the present until one under a tenth
                              (counted in slow_fallbacks): re-running
                              would cost such a host as much again as
                              stepping, and its advances would grow
                              without end, dragging its peers' after
                              them. An application that advances in
                              steps over a fifth of it (50 ms at the
                              default: under 20 Hz) raises it. Default
                              0: GS_REPLAY_REACH; negative: no bound but
                              the history and the budget */
} gs_sync_desc;

/* m; the default gs_sync_desc.replay_tolerance (see docs/sync-notes.md) */
#define GS_REPLAY_TOLERANCE 1e-4
/* replays skipped in a row by replay_tolerance before one runs */
#define GS_REPLAY_NEAR_SKIPS 2
/* the default gs_sync_desc.replay_every, and its largest value (a
   snapshot's wait must leave room in the history and the ghosts' queues) */
#define GS_REPLAY_EVERY 1
#define GS_REPLAY_EVERY_MAX 8
/* s; the default gs_sync_desc.replay_reach: the harsh link's largest one-way
   delay (150 ms) plus a 60 Hz send period and a frame, rounded up */
#define GS_REPLAY_REACH 0.25

/* Mode present, local clock, the world's clock, 16 frames of history, a
   replay budget of 4096 steps, no frame grid, a replay tolerance of
   GS_REPLAY_TOLERANCE, a replay reach of GS_REPLAY_REACH. */
GS_API gs_sync_desc gs_sync_desc_default(void);

typedef struct gs_world_desc {
    uint32_t host_id;      /* this host's id in a session; default 1 */
    int queue_count;       /* N+1 priority queues Q_0..Q_N; default 8,
                              1..GS_MAX_QUEUES */
    double tolerance;      /* s; the allowed lead of an agent over the
                              slowest agent; default 0.01 */
    int aging_limit;       /* dispatches an agent may wait at the head of
                              its queue before it runs anyway; default 64 */
    double budget;         /* s of wall clock per gs_world_advance call;
                              default 0 = unbounded */
    gs_vec3 gravity;       /* m/s^2; default (0, -9.81, 0) when all zero;
                              gs_world_set_gravity sets any value */
    gs_clock_fn clock;     /* for the budget; default CLOCK_MONOTONIC */
    void *clock_user;
    gs_allocator allocator; /* default GS_MALLOC / GS_FREE */
    gs_sync_desc sync;     /* default: local clock, 16 frames of history */
    uint64_t max_steps;    /* agent steps (all agents together) one
                              gs_world_advance call runs at most, so that
                              every call returns whatever it is asked;
                              default GS_DEFAULT_MAX_STEPS */
    double sleep_time;     /* s; a rigid body whose every point has moved
                              slower than sleep_speed for this long sleeps
                              (see gs_agent_sleeping); default 0.5; < 0:
                              nothing sleeps */
    double sleep_speed;    /* m/s, > 0; default 0.1 */
} gs_world_desc;

/* The default of gs_world_desc.max_steps: 4 194 304 steps, about 70 minutes
   of simulated time for one agent at dt = 1 ms, far more than a frame
   needs; a call that reaches it returns with report->reached = 0. */
#define GS_DEFAULT_MAX_STEPS ((uint64_t)1 << 22)

/* What one gs_world_advance call did. */
typedef struct gs_advance_report {
    int reached;         /* 1: every live agent reached the target time;
                            0: the wall-clock budget ran out first */
    uint64_t steps;      /* agent steps run by this call */
    double target;       /* s; the world's target time after this call */
    double t_min, t_max; /* s; slowest and fastest live agent afterwards */
    int failed_agents;   /* agents whose step failed (see gs_agent_result)
                            and that stopped advancing for this call */
} gs_advance_report;

/* The desc with every default filled in (what zero fields become). */
GS_API gs_world_desc gs_world_desc_default(void);

/* Creates a world. desc may be NULL (all defaults).
   Returns GS_OK and *out, or GS_ERR_INVALID_ARG / GS_ERR_NOT_FINITE for a bad
   desc, GS_ERR_NO_MEMORY. *out is NULL on failure. */
GS_API gs_result gs_world_create(const gs_world_desc *desc, gs_world **out);

/* Destroys the world, every agent and ghost in it, and its net. Close its
   gs_udp first (its threads use the net), and do not run a gs_simnet it
   joined afterwards. NULL is ignored. From a callback of the world or its
   net, or while a gs_simnet_run runs it, it is refused: nothing is freed
   and gs_world_error says so (destroy it once that call has returned). */
GS_API void gs_world_destroy(gs_world *w);

/* Moves the target time on by `seconds` (>= 0) and runs agent steps, most
   urgent first, until every agent is within half its dt of the target, the
   wall-clock budget is spent or max_steps steps have run (then
   report->reached is 0 and the next call goes on). An agent whose step
   fails keeps its state and stops advancing for the rest of this call; the
   others go on. report may be NULL. Returns GS_OK, GS_ERR_INVALID_ARG
   (negative seconds, NULL w, or a target past GS_WIRE_MAX_TIME: nothing
   changes), GS_ERR_NOT_FINITE (NaN or infinite seconds), GS_ERR_BUSY
   (called from a callback: see ERRORS), or the first error an agent's
   step returned (every other agent still advanced). */
GS_API gs_result gs_world_advance(gs_world *w, double seconds,
                                  gs_advance_report *report);

/* The target time reached by the advance calls so far, in seconds. When
   ghost blending has moved every agent past it (a host that joins late takes
   the others' time), the next advance starts from the slowest agent. */
GS_API double gs_world_time(const gs_world *w);

/* The detail of the last failed call on this world ("" if none, or for a
   NULL w). gs_world_advance starts it afresh: after an advance it tells
   what failed in it (an agent whose step failed, named, with what its
   step returned; a call refused from one of its callbacks), or is "" when
   nothing did. The text stays valid until the next call on the world. */
GS_API const char *gs_world_error(const gs_world *w);

/* This host's id in its session (gs_world_desc.host_id: 1 by default). */
GS_API uint32_t gs_world_host_id(const gs_world *w);
/* How many agents the world holds (probes and custom agents included). */
GS_API int gs_world_agent_count(const gs_world *w);
/* The i-th agent in creation order, or NULL if i is out of range. */
GS_API gs_agent *gs_world_agent(const gs_world *w, int i);

/* The world's gravity, in m/s^2. */
GS_API gs_vec3 gs_world_gravity(const gs_world *w);
/* Any finite vector, zero included. GS_ERR_BUSY from a callback (as every
   setter of the world, the agents and the ghosts: see ERRORS). */
GS_API gs_result gs_world_set_gravity(gs_world *w, gs_vec3 g);
/* Wall seconds per advance call; 0 = unbounded. */
GS_API gs_result gs_world_set_budget(gs_world *w, double seconds);

/* A 64-bit FNV-1a hash of every agent's full state, bit for bit, in creation
   order: equal hashes on two worlds mean equal states (determinism checks). */
GS_API uint64_t gs_world_hash(const gs_world *w);

/* ========================================================================
   >>sched
   ======================================================================== */

/* What an agent learns when the scheduler activates it. */
typedef struct gs_behaviour_in {
    double t;            /* s; this agent's simulation time */
    double t_min, t_max; /* s; slowest and fastest live agent in the world */
    double tolerance;    /* s; the world's tolerance */
    double dt;           /* s; this agent's step */
    int priority;        /* its current priority, 0 = lowest */
    int priority_max;    /* N: the highest priority (queue_count - 1) */
} gs_behaviour_in;

/* A behaviour (decision) rule: returns the agent's new priority; values
   outside 0..priority_max are clamped. */
typedef int (*gs_behaviour_fn)(const gs_behaviour_in *in, void *user);

/* The paper's rule, used when an agent has none: leading the slowest agent
   by more than the tolerance lowers the priority by one; lagging the fastest
   by more than the tolerance raises it by one; otherwise it stays. */
GS_API int gs_behaviour_default(const gs_behaviour_in *in, void *user);

/* Per-agent scheduling counters. */
typedef struct gs_agent_stats {
    uint64_t steps;          /* steps taken (each may hold several substeps) */
    uint64_t substeps;       /* integrator substeps taken */
    uint64_t activations;    /* times the scheduler ran it */
    uint64_t held;           /* times it was passed over for leading */
    uint64_t max_wait;       /* most dispatches it waited in its queue */
    uint64_t aged;           /* times it ran because it had waited too long */
    uint64_t sleeps;         /* times it fell asleep (gs_agent_sleeping) */
    uint64_t wakes;          /* times it woke */
} gs_agent_stats;

/* ========================================================================
   >>agent
   ======================================================================== */
typedef enum gs_integrator {
    GS_INTEGRATOR_DEFAULT = 0,     /* symplectic Euler */
    GS_INTEGRATOR_EXPLICIT_EULER,  /* order 1; gains energy: tests only */
    GS_INTEGRATOR_SYMPLECTIC_EULER, /* order 1; cheapest stable choice */
    GS_INTEGRATOR_VERLET,          /* velocity Verlet, order 2 */
    GS_INTEGRATOR_RK4,             /* order 4; 4 force evaluations */
    GS_INTEGRATOR_IMPLICIT_EULER,  /* backward Euler, Baraff-Witkin + CG:
                                      stable at any dt, damps */
    GS_INTEGRATOR_XPBD,            /* spring-mass only: extended position-
                                      based dynamics in the small-steps form
                                      (solver.substeps of one constraint pass
                                      each); springs and contacts keep their
                                      N/m and N s/m (compliance 1 / k);
                                      stable at any stiffness, order 1 in
                                      the substep */
    GS__INTEGRATOR_COUNT
} gs_integrator;

typedef enum gs_stability {
    GS_STABILITY_DEFAULT = 0, /* substep */
    GS_STABILITY_SUBSTEP,     /* split a step that exceeds the agent's
                                 stability bound into up to max_substeps */
    GS_STABILITY_REFUSE,      /* refuse such a step with GS_ERR_UNSTABLE */
    GS_STABILITY_UNCHECKED,   /* step anyway; only the NaN/speed guard */
    GS__STABILITY_COUNT
} gs_stability;

/* The smallest dt (s) of any agent, probe or scene: at GS_WIRE_MAX_TIME a
   double still resolves 1.2e-7 s, so a step of GS_MIN_DT moves every clock
   the library keeps, and 1 s of simulated time is at most 1e6 steps. */
#define GS_MIN_DT 1e-6

/* How an agent steps. Zero fields take the defaults written beside them. */
typedef struct gs_solver_desc {
    double dt;               /* s, >= GS_MIN_DT; default 0.001 */
    gs_integrator integrator; /* default symplectic Euler */
    gs_stability stability;  /* default substep (ignored by implicit Euler) */
    int max_substeps;        /* default 64 */
    double safety;           /* fraction of the stability bound an agent
                                steps within, whether it substeps or refuses,
                                (0, 1]; default 0.9 */
    double cg_tolerance;     /* implicit Euler: relative residual; 1e-6 */
    int cg_max_iterations;   /* implicit Euler: default 200 */
    double max_speed;        /* m/s; a faster particle means the step blew
                                up and is undone; default 1e4 */
    int substeps;            /* XPBD: substeps per step, one pass over the
                                springs and contacts each, >= 1;
                                default 4 */
} gs_solver_desc;

/* The solver desc with every default filled in (what zero fields become). */
GS_API gs_solver_desc gs_solver_desc_default(void);

/* Penalty contact: a spring-damper along the normal, regularized Coulomb
   friction along the surface. A pair uses the mean stiffness and damping of
   its two materials and the geometric mean of their friction. An all-zero
   material means gs_material_default(); otherwise every field is taken as
   given (zero damping and zero friction are allowed). */
typedef struct gs_material {
    double stiffness; /* N/m, > 0; default 1e5 */
    double damping;   /* N s/m, >= 0; default 100 */
    double friction;  /* Coulomb coefficient, >= 0; default 0.5 */
} gs_material;


/* Simulation time in seconds: steps * dt plus what set_state moved it by. */
GS_API double gs_agent_time(const gs_agent *a);
/* The agent's step, in seconds (its solver's or its desc's dt). */
GS_API double gs_agent_dt(const gs_agent *a);
/* The world the agent belongs to. */
GS_API gs_world *gs_agent_world(const gs_agent *a);
/* "mesh", "cloth", "rigid", "probe" or "custom". */
GS_API const char *gs_agent_kind(const gs_agent *a);

/* Number of doubles in the state vector, time included. */
GS_API size_t gs_agent_state_size(const gs_agent *a);
/* Writes [t, variables...] into out, which holds n doubles.
   GS_ERR_SIZE_MISMATCH unless n == gs_agent_state_size(a). */
GS_API gs_result gs_agent_get_state(const gs_agent *a, double *out, size_t n);
/* Sets the state, time included. Every number must be finite
   (GS_ERR_NOT_FINITE), the time in [0, GS_WIRE_MAX_TIME]
   (GS_ERR_INVALID_ARG), every position within +-GS_MAX_COORD
   (GS_ERR_OUT_OF_RANGE), a rigid body's quaternion of norm at least 1e-6
   (GS_ERR_INVALID_ARG; of any finite size, it is normalized); on error
   nothing changes. GS_ERR_BUSY from a callback, even on the agent whose
   own step it is: ghosts and the scheduler read the state meanwhile. */
GS_API gs_result gs_agent_set_state(gs_agent *a, const double *in, size_t n);

/* Steps the agent once by its dt, outside the scheduler (for tools and
   tests). GS_ERR_BUSY from a callback (see ERRORS); its own step and
   weight rules are callbacks too while it runs. GS_ERR_OUT_OF_RANGE (and
   the time stays) if the step would take its time past GS_WIRE_MAX_TIME.
   Each call counts as an advance for GS_MAX_TIME_CORRECTION. */
GS_API gs_result gs_agent_step(gs_agent *a);
/* The result of the agent's last step. */
GS_API gs_result gs_agent_result(const gs_agent *a);

/* The queue the agent waits in: 0 (lowest) to queue_count - 1. */
GS_API int gs_agent_priority(const gs_agent *a);
/* Moves the agent to another queue; clamped to 0..N. Allowed from inside the
   agent's own step or behaviour rule: it takes effect when it is queued
   again. */
GS_API void gs_agent_set_priority(gs_agent *a, int priority);
/* Replaces the behaviour rule; NULL restores gs_behaviour_default. */
GS_API void gs_agent_set_behaviour(gs_agent *a, gs_behaviour_fn fn,
                                   void *user);
/* The agent's scheduling counters into *out. GS_ERR_INVALID_ARG for a
   NULL agent or out. Every stats call has this shape: a gs_result, the
   object, *out. */
GS_API gs_result gs_agent_get_stats(const gs_agent *a, gs_agent_stats *out);
/* Removes the agent from its world and frees it. GS_ERR_BUSY from a
   callback (see ERRORS). */
GS_API gs_result gs_agent_destroy(gs_agent *a);

/* Sleeping ("model only what a scene requires"). A rigid body at rest
   (every point slower than gs_world_desc.sleep_speed for sleep_time), or a
   whole spring-mass mesh (every particle), sleeps: its velocities are
   zeroed, it takes no steps and no contacts are computed among sleepers;
   awake bodies meet it as fixed. A mesh also wakes when a pin moves
   (gs_mesh_move_pin) and when a moving probe comes within its bounds. An
   agent under a ghost does not sleep (its hosts would not meet). Its
   time follows the world: at each advance it jumps to the target, so
   gs_agent_time of a sleeper is gs_world_time (a ghost attached to it
   publishes and blends at that time). It wakes, its time then that of
   what woke it, on: a contact from an awake body moving faster than
   sleep_speed, or from cloth particles that are; a probe that moved in
   the last sleep_time touching it (and while one does, nothing it
   touches falls asleep; a probe held still that long is scenery, as the
   walls of a box); gs_agent_set_state (ghost snapshots use it),
   gs_agent_step, gs_agent_wake; gs_world_set_gravity and
   gs_world_set_ground wake everything. Only gs_world_advance puts agents
   to sleep. Returns 1 when a sleeps, 0 otherwise (probes and custom agents
   never sleep). */
GS_API int gs_agent_sleeping(const gs_agent *a);
/* Wakes a sleeping agent (its rest time starts again); nothing for an
   awake one. GS_ERR_BUSY from a callback (see ERRORS). */
GS_API gs_result gs_agent_wake(gs_agent *a);

/* A user agent. Its variables live in user memory; ghostsim keeps its time
   and schedules it like any other. */
typedef struct gs_custom_desc {
    double dt;          /* s, >= GS_MIN_DT; default 0.001 (as a solver's) */
    size_t state_size;  /* doubles, excluding time; default 0 */
    /* Advances by dt seconds from time t. Returning an error leaves the
       agent's time unchanged; the callback should leave its state too.
       A step that leaves a NaN or infinity in the state is undone: the
       state read (get_state) before it is put back (set_state) and the
       step returns GS_ERR_UNSTABLE. */
    gs_result (*step)(void *user, double t, double dt);
    void (*get_state)(const void *user, double *out);  /* state_size */
    gs_result (*set_state)(void *user, const double *in);
    void *user;
} gs_custom_desc;

/* dt 0.001 s, no state, no callbacks (step is required). */
GS_API gs_custom_desc gs_custom_desc_default(void);

/* Creates a user agent from desc (copied; desc->user must outlive the
   agent); a zero dt is the default. Returns GS_OK and *out, or
   GS_ERR_INVALID_ARG (a NULL desc or out, dt below GS_MIN_DT, step NULL,
   or a state_size without get_state and set_state), GS_ERR_OUT_OF_RANGE
   for a state_size whose bytes do not fit in size_t, GS_ERR_NO_MEMORY,
   GS_ERR_BUSY from a callback; *out is NULL on failure, the reason in
   gs_world_error. The callbacks run with the world's guard up (see
   ERRORS). */
GS_API gs_result gs_custom_create(gs_world *w, const gs_custom_desc *desc,
                                  gs_agent **out);

/* ========================================================================
   >>cloth
   Spring-mass agents: a general mesh the user describes, and a cloth
   generator built on it. State: [t, x0,y0,z0, x1.., ..., vx0,vy0,vz0, ...].
   ======================================================================== */
typedef struct gs_spring {
    int a, b;           /* particle indices */
    double rest_length; /* m; 0 = the distance at creation */
    double stiffness;   /* N/m, > 0 */
    double damping;     /* N s/m along the spring, >= 0 */
} gs_spring;

/* A mesh has no default shape: its particles are required. */
typedef struct gs_mesh_desc {
    int particle_count;        /* >= 1, required */
    const gs_vec3 *positions;  /* m, within +-GS_MAX_COORD; particle_count
                                  of them, required */
    const gs_vec3 *velocities; /* m/s; NULL = at rest */
    const double *masses;      /* kg each, > 0; NULL = mass / count */
    double mass;               /* kg in all when masses is NULL; default 1 */
    int spring_count;          /* default 0: free particles */
    const gs_spring *springs;
    int pin_count;             /* default 0 */
    const int *pins;           /* particles held where they are */
    double air_damping;        /* 1/s; force -m * air_damping * v; default 0 */
    double particle_radius;    /* m, for contacts; default 0.01 */
    gs_material material;      /* contacts; zero fields take defaults */
    gs_solver_desc solver;
} gs_mesh_desc;

/* Which corners of a cloth to pin (bit mask). */
enum {
    GS_CORNER_00 = 1, /* particle (0, 0) */
    GS_CORNER_10 = 2, /* (nx-1, 0) */
    GS_CORNER_01 = 4, /* (0, ny-1) */
    GS_CORNER_11 = 8, /* (nx-1, ny-1) */
    GS_CORNER_ALL = 15
};

/* Which spring families a cloth gets (bit mask); 0 = all three. */
enum {
    GS_SPRINGS_STRUCTURAL = 1, /* to the 4 neighbours */
    GS_SPRINGS_SHEAR = 2,      /* to the 4 diagonal neighbours */
    GS_SPRINGS_BEND = 4        /* to the neighbours two away, along rows and
                                  columns */
};

typedef struct gs_cloth_desc {
    int nx, ny;          /* particles along u and v; each >= 2; default
                            16 x 16 (the paper's scene) */
    double width, height; /* m along u and v, at most GS_MAX_COORD;
                             default 1 x 1 */
    gs_vec3 origin;      /* m; where particle (0,0) is; default 0. Every
                            particle must lie within +-GS_MAX_COORD */
    gs_vec3 axis_u;      /* direction of rows, of length in (1e-100,
                            1e100); default +x */
    gs_vec3 axis_v;      /* direction of columns; default +z (the cloth
                            lies flat under y-up gravity) */
    double mass;         /* kg in all; default 1 */
    int springs;         /* GS_SPRINGS_* mask; default all */
    double stretch_stiffness; /* N/m, structural; default 1000 */
    double shear_stiffness;   /* N/m; default stretch / 10 */
    double bend_stiffness;    /* N/m; default stretch / 100 */
    double spring_damping;    /* N s/m on every spring; default 0.02 */
    double air_damping;       /* 1/s; default 0.1 */
    int pin_corners;     /* GS_CORNER_* mask; default 0: none */
    int pin_count;       /* more pins, as particle index i + nx * j;
                            default 0 */
    const int *pins;
    double particle_radius; /* m, for contacts; default half the smaller
                               spacing between particles */
    gs_material material;      /* contacts; zero fields take defaults */
    gs_solver_desc solver;
} gs_cloth_desc;

/* The mesh desc with its defaults (what zero fields become); positions
   and particle_count are still to be given. */
GS_API gs_mesh_desc gs_mesh_desc_default(void);
/* The cloth desc with its defaults; nx and ny are still to be given. */
GS_API gs_cloth_desc gs_cloth_desc_default(void);

/* Creates a spring-mass agent. Errors name the bad field in
   gs_world_error(w): GS_ERR_INVALID_ARG, GS_ERR_NOT_FINITE,
   GS_ERR_OUT_OF_RANGE (a spring or pin index; a position, size or rest
   length past GS_MAX_COORD; a particle mass without a finite inverse),
   GS_ERR_NO_MEMORY. */
GS_API gs_result gs_mesh_create(gs_world *w, const gs_mesh_desc *desc,
                                gs_agent **out);
/* Creates a cloth: an nx x ny grid of particles, mass spread evenly.
   GS_ERR_OUT_OF_RANGE also when origin, width and height put a particle
   outside +-GS_MAX_COORD. */
GS_API gs_result gs_cloth_create(gs_world *w, const gs_cloth_desc *desc,
                                 gs_agent **out);

/* For spring-mass agents (NULL / 0 for any other kind). */
GS_API int gs_mesh_particle_count(const gs_agent *a);
/* The springs the mesh was made with (0 for another kind). */
GS_API int gs_mesh_spring_count(const gs_agent *a);
/* The particles' positions, in metres (NULL for another kind): the
   agent's own array, valid while it lives; every step and blend rewrites
   it, so read it between advances. */
GS_API const gs_vec3 *gs_mesh_positions(const gs_agent *a);
/* The particles' velocities, in m/s, as gs_mesh_positions. */
GS_API const gs_vec3 *gs_mesh_velocities(const gs_agent *a);
/* Kinetic energy and potential energy (springs plus gravity, relative to
   the origin), in joules. Either pointer may be NULL. */
GS_API gs_result gs_mesh_energy(const gs_agent *a, double *kinetic,
                                double *potential);
/* The largest stable step of the agent's explicit integrator, in seconds:
   h = 4 / (gamma + sqrt(gamma^2 + 4 omega_max^2)) (RK4 1.39 times it), with
   omega_max^2 estimated at creation by power iteration on the springs'
   stiffness (within 10% under the measured limit of a cloth), never above
   Gershgorin's bound max_i (sum of k over i's springs, those to free
   particles counted twice) / m_i, which stands where the iteration does not
   converge; +inf for implicit Euler and XPBD (whose springs are stable at
   any step). */
GS_API double gs_mesh_stable_dt(const gs_agent *a);
/* Moves a pinned particle (the application drags a corner) to pos, in
   metres. GS_ERR_INVALID_ARG if the agent is not a spring-mass agent or the
   particle is not pinned, GS_ERR_OUT_OF_RANGE for a bad index or a
   position outside +-GS_MAX_COORD, GS_ERR_NOT_FINITE for a non-finite
   position, GS_ERR_BUSY from a callback; the mesh is unchanged then. A
   sleeping mesh wakes (see gs_agent_sleeping). */
GS_API gs_result gs_mesh_move_pin(gs_agent *a, int particle, gs_vec3 pos);

/* ========================================================================
   >>rigid
   Rigid bodies and probes. Rigid state: [t, position (3), orientation
   quaternion x y z w (4), velocity (3), angular velocity in world frame (3)].
   ======================================================================== */
typedef enum gs_shape_type {
    GS_SHAPE_NONE = 0,
    GS_SHAPE_SPHERE,  /* radius */
    GS_SHAPE_BOX,     /* half_extents */
    GS_SHAPE_HULL,    /* the convex hull of points (4 to GS_MAX_HULL_POINTS,
                         not all in one plane) */
    GS__SHAPE_COUNT
} gs_shape_type;

#define GS_MAX_HULL_POINTS 64

/* A shape has no default: its type is required (GS_SHAPE_NONE is refused,
   so that a forgotten shape is an error, not some ball). */
typedef struct gs_shape_desc {
    gs_shape_type type;     /* required; the sizes of that type too */
    double radius;          /* m, sphere; sizes at most GS_MAX_COORD */
    gs_vec3 half_extents;   /* m, box */
    const gs_vec3 *points;  /* m, hull, in body coordinates (within
                               +-GS_MAX_COORD); the body's origin becomes
                               the hull's centre of mass */
    int point_count;
} gs_shape_desc;

/* Every field zero: type GS_SHAPE_NONE, which the caller must set. */
GS_API gs_shape_desc gs_shape_desc_default(void);

typedef struct gs_rigid_desc {
    gs_shape_desc shape;
    double density;        /* kg/m^3; default 1000 */
    double mass;           /* kg; > 0 overrides density */
    gs_vec3 inertia;       /* kg m^2, principal moments in body axes;
                              default from shape and mass */
    gs_vec3 position;      /* m, within +-GS_MAX_COORD; default 0 */
    gs_quat orientation;   /* default identity (all zero); normalized on
                              create, whatever its finite size */
    gs_vec3 velocity;      /* m/s; default 0 */
    gs_vec3 angular_velocity; /* rad/s, world frame; default 0 */
    gs_material material;  /* all zero: gs_material_default() */
    int continuous;        /* 1: substep so that the body never moves more
                              than a quarter of its smallest size per
                              substep (stops tunnelling of fast bodies);
                              default 0: off */
    gs_solver_desc solver; /* symplectic Euler (default), Verlet or RK4;
                              substeps keep contact stiffness stable */
    double rolling;        /* m, >= 0; rolling resistance: at each contact
                              a torque of up to rolling * N (N the normal
                              force) against the body's spin relative to
                              what it touches, about axes in the contact
                              plane (rolling / radius is the usual
                              coefficient). Without it a ball that rolls
                              off onto the ground rolls for ever. Default 0 */
    double spin_friction;  /* m, >= 0; torsional friction: at each contact
                              a torque of up to spin_friction * N against
                              the body's spin about the contact normal
                              relative to what it touches. A real contact
                              is a patch, not a point: Coulomb friction mu
                              over a disc of radius a under even pressure
                              resists a spin with (2/3) mu a N, so this is
                              about (2/3) mu a. Without it nothing opposes a
                              spin about the normal (rolling resistance
                              acts about the contact plane's axes) and a
                              settled ball keeps its yaw rate for ever.
                              Default 0 (the contacts are points) */
} gs_rigid_desc;

/* A kinematic body the application moves: nothing pushes it back. */
typedef struct gs_probe_desc {
    gs_shape_desc shape;
    gs_vec3 position;      /* m, within +-GS_MAX_COORD; default 0 */
    gs_quat orientation;   /* default identity */
    gs_material material;  /* all zero: gs_material_default() */
    double dt;             /* s, >= GS_MIN_DT; default 0.001 */
    double max_speed;      /* m/s it may move at to reach its target;
                              default 10 */
    uint32_t owner;        /* host that drives it; default this world's */
} gs_probe_desc;

/* The rigid body desc with its defaults; the shape is still to be given. */
GS_API gs_rigid_desc gs_rigid_desc_default(void);
/* The probe desc with its defaults; the shape is still to be given. */
GS_API gs_probe_desc gs_probe_desc_default(void);
/* The default material: 1e5 N/m, 100 N s/m, friction 0.5. */
GS_API gs_material gs_material_default(void);

/* Creates a rigid body. Errors name the field: a degenerate hull (fewer
   than 4 points, all in one plane), a size <= 0, a negative density (0 is
   the default 1000 kg/m^3), NaN (GS_ERR_NOT_FINITE); a size or position
   past GS_MAX_COORD, a mass or inertia (given, or density * volume) that
   or whose inverse is not finite (GS_ERR_OUT_OF_RANGE). */
GS_API gs_result gs_rigid_create(gs_world *w, const gs_rigid_desc *desc,
                                 gs_agent **out);
/* Creates a probe, moved by gs_probe_set_target. Errors as
   gs_rigid_create's (the shape, position, orientation and material), and
   GS_ERR_INVALID_ARG for a dt below GS_MIN_DT or a max_speed <= 0; *out
   is NULL on failure. */
GS_API gs_result gs_probe_create(gs_world *w, const gs_probe_desc *desc,
                                 gs_agent **out);

/* Where the probe should be; it moves there over its next steps at no more
   than max_speed. GS_ERR_NOT_FINITE for a NaN, GS_ERR_OUT_OF_RANGE for a
   position outside +-GS_MAX_COORD; an all-zero orientation is the
   identity, any other finite one is normalized. GS_ERR_BUSY from a
   callback (set it between advances). */
GS_API gs_result gs_probe_set_target(gs_agent *probe, gs_vec3 position,
                                     gs_quat orientation);

/* For rigid bodies and probes (zero for other kinds). */
GS_API gs_vec3 gs_rigid_position(const gs_agent *a); /* m */
/* The orientation, a unit quaternion (the identity for other kinds). */
GS_API gs_quat gs_rigid_orientation(const gs_agent *a);
/* The velocity of the centre of mass, in m/s. */
GS_API gs_vec3 gs_rigid_velocity(const gs_agent *a);
/* The angular velocity, in rad/s, in the world frame. */
GS_API gs_vec3 gs_rigid_angular_velocity(const gs_agent *a);
GS_API double gs_rigid_mass(const gs_agent *a); /* kg; 0 for a probe */
/* Largest stable step under the agent's contact stiffness, in seconds. */
GS_API double gs_rigid_stable_dt(const gs_agent *a);

/* ========================================================================
   >>contact
   ======================================================================== */

/* One contact as the narrow phase sees it: the normal points from b to a,
   depth > 0 means overlap, point is in world coordinates. */
typedef struct gs_contact {
    gs_vec3 normal, point;
    double depth; /* m */
} gs_contact;

/* The exact or libccd answer for two shapes at two poses: GS_OK with
   *overlap 1 and *c filled when they overlap, *overlap 0 when apart. Every
   output is finite: where libccd returns a non-finite direction (touching
   or coincident shapes) the answer falls back to the direction between the
   centres, and coincident centres to +y (a's normal). GS_ERR_INVALID_ARG
   for a NULL pointer; a shape gs_rigid_create would refuse gives what it
   would (GS_ERR_INVALID_ARG, GS_ERR_NOT_FINITE, GS_ERR_OUT_OF_RANGE);
   GS_ERR_NOT_FINITE for a NaN or infinite position, GS_ERR_OUT_OF_RANGE
   for one outside +-GS_MAX_COORD. On an error *overlap is 0 (if given)
   and *c untouched. */
GS_API gs_result gs_collide_shapes(const gs_shape_desc *a, gs_vec3 pa, gs_quat qa,
                                   const gs_shape_desc *b, gs_vec3 pb, gs_quat qb,
                                   gs_contact *c, int *overlap);

/* A ground plane y = height (within +-GS_MAX_COORD) that every body
   meets. GS_ERR_BUSY from a callback. */
GS_API gs_result gs_world_set_ground(gs_world *w, int enabled, double height,
                                     gs_material material);

/* ========================================================================
   >>scene
   The paper's scene: a cloth hanging by its four corners, spheres falling
   on it, one probe per host. Examples, tests, the peer and the benchmarks
   all build it here.
   ======================================================================== */
#define GS_SCENE_MAX_SPHERES 64
#define GS_SCENE_MAX_PROBES 16
/* A count set to GS_NONE asks for none: zero is the default there, as in
   every desc (a zeroed desc is the paper's scene). */
#define GS_NONE (-1)
/* Probes of a scene whose world has no net when it is made. */
#define GS_SCENE_DEFAULT_PROBES 1

/* Zero means the default in every field: a zeroed desc, NULL, and
   gs_scene_desc_default() all give the paper's scene. */
typedef struct gs_scene_desc {
    int cloth_n;          /* particles per side; default 16 */
    double cloth_size;    /* m; default 1 */
    int sphere_count;     /* 1..GS_SCENE_MAX_SPHERES; default 3;
                             GS_NONE: no sphere */
    double sphere_radius; /* m; default 0.08 */
    int probe_count;      /* 1..GS_SCENE_MAX_PROBES; GS_NONE: no probe.
                             Default (0) one per host: probe i is host
                             i + 1's, so as many as the highest host id
                             the world's net knows (its own and its
                             peers') when the scene is made;
                             GS_SCENE_DEFAULT_PROBES if it has no net.
                             Probe ids are shared: every host of a
                             session needs the same count, so make the
                             scene once every peer is added, or set it */
    uint32_t seed;        /* sphere placement; default 1 */
    gs_integrator cloth_integrator; /* default implicit Euler */
    double dt;            /* s for every agent, >= GS_MIN_DT; default 0.002 */
    int cloth_substeps;   /* XPBD cloth: substeps per step (its
                             solver.substeps), 1..2^20 whatever the
                             integrator (others ignore it); default 4 */
} gs_scene_desc;

typedef struct gs_scene {
    gs_agent *cloth;
    gs_agent *spheres[GS_SCENE_MAX_SPHERES];
    gs_agent *probes[GS_SCENE_MAX_PROBES];
    int sphere_count, probe_count;
    gs_scene_desc desc;   /* with defaults applied */
} gs_scene;

/* Settling the cloth (3 s of simulated time, below) costs cloth_n^2 *
   3 s / dt particle steps (an XPBD cloth of more than the default 4
   substeps: times cloth_substeps / 4); a scene that would need more is
   refused (GS_ERR_INVALID_ARG). The bound admits the largest cloth ghostpeer takes
   (256 x 256 at the default dt: 9.8e7) and refuses what would run for
   hours (4096 x 4096 at the default dt; 16 x 16 at dt = 1e-6 s). */
#define GS_SCENE_SETTLE_WORK 1e8

/* The scene desc with its defaults: a 16 x 16 cloth of 1 m, 3 spheres of
   0.08 m, seed 1, implicit Euler, dt 0.002 s, and 1 probe: set
   probe_count to the number of hosts of the session (see RULES). */
GS_API gs_scene_desc gs_scene_desc_default(void);
/* Builds the scene in w (ground on at y = -1.5 m): cloth in the plane
   y = 0 centred on the origin, spheres above it, probes above the cloth.
   Probe i is owned by host i + 1. The cloth hangs for 3 s of simulated
   time before its clock is set back to 0 (bounded by
   GS_SCENE_SETTLE_WORK). */
GS_API gs_result gs_scene_create(gs_world *w, const gs_scene_desc *desc,
                                 gs_scene *out);
/* Where probe i should be at time t (s) on the scripted path the tests and
   the peer use: a circle of radius 0.38 m dipping into the cloth. */
GS_API gs_vec3 gs_scene_probe_path(int i, double t);

/* ========================================================================
   >>ghost
   A ghost wraps one agent under an object id that every host shares. After
   each step of its agent it publishes the state (buffer B) for the network
   to send, and blends every snapshot received since, once each:
       S <- (w_0 S + sum_j sum_q w_jq q.data) / (w_0 + sum_j sum_q w_jq)
   with w_0 the rule's weight of the local state (x = 0). The simulation
   time is part of S and is blended too.
   ======================================================================== */

/* What a peer can do to this host's clock is bounded:
   - an age (a send time read against the peer's clock) is believed only
     within GS_MAX_AGE seconds; past it the age is unknown (0, and the
     snapshot may pull the local time on, never back);
   - the blend moves an agent's simulation time by at most
     GS_MAX_TIME_CORRECTION seconds in all per gs_world_advance (or
     gs_agent_step) call, either way; a host that joins a session late
     catches up that much per call;
   - no agent's or world's time leaves [0, GS_WIRE_MAX_TIME]. */
#define GS_MAX_AGE 2.0              /* s */
#define GS_MAX_TIME_CORRECTION 10.0 /* s per advance, per agent */
/* Quantized snapshots a delta ghost keeps as baselines, sent and per peer
   received: a peer's acknowledgement older than this many snapshots sent
   since (a round trip past 16 / 60 Hz = 0.27 s) finds no baseline and the
   next goes whole. */
#define GS_DELTA_RING 16

/* What a weight rule sees, for the local state or one received snapshot. */
typedef struct gs_weight_in {
    double x;        /* s; t_j - t_i, the snapshot's simulation time minus the
                        local one, as sent (0 for the local state) */
    double x_comp;   /* s; x with t_j carried forward by the snapshot's age
                        (the time it spent on the wire and in the queue),
                        which is what the remote host is at by now */
    double x_max;    /* s; the largest x_comp of this blend, the local state
                        (0) included: the client/server rule's reference */
    double age;      /* s of wall time since the snapshot was sent (an
                        estimate: its datagram's arrival less its send
                        time, less the hosts' clock offset, which the
                        least-delayed round trip tells to half of it), in
                        [0, GS_MAX_AGE]; 0 when unknown */
    uint32_t host;   /* the sending host (this host for the local state) */
    uint32_t lead;   /* the most advanced host among this one and the
                        peers heard in the last 0.5 s (their snapshots in
                        this blend or not); but hosts within twice the
                        ghost's time deadband of it are in step, a tie,
                        and the lowest id among them leads (a peer's time,
                        which is read with an error, counts within three
                        times the deadband). One lead for every ghost of
                        the world's blend */
    uint32_t owner;  /* the object's owner, 0 if shared */
    int local;       /* 1 for the local state */
    int local_owns;  /* 1 if this host owns the object */
    uint32_t object_id;    /* the object weighed (its ghost's object id) */
    const gs_agent *agent; /* the local agent under that ghost: its kind,
                              state and time are readable here, not
                              writable (the blend is reading it) */
} gs_weight_in;

/* A weight rule: any finite value >= 0. A negative, NaN or infinite weight
   counts as 0 (and is counted); if every weight is 0 the local state stands.
   One rule may serve many objects (in->object_id and in->agent say which),
   or each object its own (gs_ghost_desc.weight; gs_scene_attach_ghosts asks
   gs_ghost_desc.rule_for for each object of the scene).
   Objects in contact need one authority: give every object that touches
   another (the cloth and the spheres resting on it) the same rule, so that
   the same host's state wins for all of them. Two authorities over objects
   that push each other never settle: each host corrects its copy of one
   object towards a peer whose copy of the other it overrides (two hosts of
   the paper's scene, the cloth under one host and the spheres under the
   other, drift apart by centimetres and more). */
typedef double (*gs_weight_fn)(const gs_weight_in *in, void *user);

/* Client/server: 1 for the lead (the local state or a snapshot), 0 for the
   rest: the most advanced host imposes its state. Hosts in step are a tie
   that the lowest host id wins, so that the lead does not change hands with
   the noise of the latency estimate (two hosts taking turns to copy each
   other's late snapshot never settle). */
GS_API double gs_weight_cs(const gs_weight_in *in, void *user);
/* Exponential: exp(rate * x_comp); user points to the rate in 1/s (NULL =
   1/s). The exponent is clamped to +-700 so that a far-ahead host counts as
   huge, not as an overflowed (discarded) infinity. */
GS_API double gs_weight_exp(const gs_weight_in *in, void *user);
/* Owner authority: only the owner's state counts (the local state if this
   host owns the object); a shared object (owner 0) blends evenly. */
GS_API double gs_weight_owner(const gs_weight_in *in, void *user);

/* A rule and its user pointer, as gs_ghost_desc.rule_for gives them. */
typedef struct gs_weight_rule {
    gs_weight_fn fn;   /* NULL: the object's default rule */
    void *user;
} gs_weight_rule;
/* The rule of one object of a scene (gs_scene_attach_ghosts): its object
   id, and the agent the ghost will wrap. */
typedef gs_weight_rule (*gs_rule_for_fn)(uint32_t object_id, const gs_agent *a,
                                         void *user);

typedef enum gs_encoding {
    GS_ENCODING_DEFAULT = 0, /* f64 */
    GS_ENCODING_F64,
    GS_ENCODING_F32,         /* half the bytes; ~1e-7 relative rounding */
    GS_ENCODING_QUANT,       /* quantized at the ghost's resolutions and
                                bit-packed (see >>wire for the error) */
    GS__ENCODING_COUNT
} gs_encoding;

/* How a ghost brings a snapshot taken at remote time t_q to the local time
   before blending (a snapshot arrives a latency late). */
typedef enum gs_catchup {
    GS_CATCHUP_DEFAULT = 0, /* none */
    GS_CATCHUP_NONE,        /* blend the snapshot as it is (the paper) */
    GS_CATCHUP_VELOCITY,    /* dead reckoning along the snapshot's own
                               velocities (a mesh moves by its mean
                               velocity: per-particle extrapolation would
                               amplify its vibrations) */
    GS__CATCHUP_COUNT
} gs_catchup;

typedef struct gs_ghost_desc {
    uint32_t object_id;    /* > 0, the same on every host */
    gs_weight_fn weight;   /* default gs_weight_cs: under latency only
                              one authority settles (the README's
                              measurements); gs_weight_exp is the paper's */
    void *weight_user;
    uint32_t owner;        /* owning host (probes); 0 = shared */
    double send_rate;      /* Hz of wall time; default 60 */
    gs_encoding encoding;  /* default f64 */
    int queue_size;        /* snapshots kept per peer; default 8. When full
                              the oldest goes (and is counted) */
    gs_catchup catchup;    /* default none */
    double catchup_max;    /* s; dead reckoning carries a snapshot at most
                              this far in time, either way; default 0.05
                              (three snapshots at 60 Hz). The cap keeps a
                              late snapshot from being carried far along
                              a velocity it no longer has: uncapped, a
                              jittery latency (150 ms +-50 ms) throws the
                              paper's scene apart under the exponential
                              rule and takes a host off wall-clock pace */
    int raw_time;          /* 1: the paper's formula literally: x_comp = x
                              and the raw remote time is blended (see the
                              latency trap in the README) */
    double smoothing;      /* s; render corrections fade over this time;
                              default 0.1 */
    double time_deadband;  /* s; time corrections smaller than this are not
                              applied (hosts in step differ by about the
                              error of the latency estimate, and chasing it
                              makes agents skip steps); default the world's
                              tolerance plus one send period (a snapshot
                              waits up to that long to be sent). Hosts
                              this close are in step (a tie for the
                              client/server rule). Unless it is negative,
                              a peer's time is read only from its latest
                              snapshot, as the upper envelope of what they
                              tell (a late datagram only looks older), and
                              before the first round trip it may pull the
                              clock on, never back. Negative: none of this,
                              the formula as is */
    /* GS_ENCODING_QUANT (see >>wire for the error each one introduces): */
    double position_resolution; /* m; step of positions (and of any value
                              of a custom agent's state); default 5e-5 */
    double velocity_resolution; /* m/s (rad/s for angular velocities);
                              default 3e-3: a velocity is off by at most
                              1.5 mm/s, which over one send period at the
                              default 60 Hz moves a point 0.025 mm, half
                              the default position step */
    int orientation_bits;  /* bits per smallest-three component, 8..24;
                              default 16 */
    /* Send on change, in every encoding: */
    double rest_threshold; /* m; while no position moved more than this
                              (nor a quaternion component, a rigid body's
                              by this over twice its bounding radius: how
                              far its surface turned; nor a velocity by
                              this over one send period) since the last
                              snapshot sent, only a heartbeat goes; the
                              last snapshot goes again with the first two
                              heartbeats of a rest, so that one loss does
                              not leave a peer a stale state. With delta,
                              the beat after any ghost of the net sent its
                              state sends every resting ghost's state (a
                              heartbeat where the state is the very one
                              every peer acknowledged), so that peers hold
                              one instant's scene; a peer
                              whose copy follows this host alone (weight 0
                              of its own) holds it at a heartbeat's state
                              (it sleeps after its next step, not under
                              rest_extrapolate). Default 0: every
                              published state is sent */
    double heartbeat_rate; /* Hz of wall time while at rest; default 4.
                              Heartbeats go at the multiples of the period
                              on the net's clock (not each ghost's own
                              phase), so that a net's resting ghosts of one
                              rate beat in the same gs_net_update and share
                              one datagram: a scene at rest sends this many
                              datagrams a second to each peer */
    double importance;     /* > 0; when a peer's bandwidth budget cannot
                              carry every ghost due, ghosts go by priority:
                              the wall time since each was last sent times
                              this, so that none starves (the first that
                              does not fit holds the ones after it until
                              it does); default 1 */
    /* gs_scene_attach_ghosts only (gs_ghost_attach ignores them): the rule
       of each object, asked once per object before any ghost is attached.
       A rule whose fn is NULL leaves the object its default (weight and
       weight_user for the cloth and the spheres, gs_weight_owner for the
       probes). NULL (default): the defaults for every object. */
    gs_rule_for_fn rule_for;
    void *rule_for_user;
    int delta;             /* GS_ENCODING_QUANT only: 1 codes each snapshot
                              chunk as its differences from the newest
                              snapshot every peer acknowledged (see >>wire),
                              whole when there is none; default 0 (every
                              snapshot whole). Each ghost then keeps its last
                              GS_DELTA_RING snapshots sent, and per peer the
                              last GS_DELTA_RING received, as integers */
    int rest_extrapolate;  /* send on change only: 1 compares the state with
                              what a peer predicts of it, the last snapshot
                              sent whole (as the peer decoded it) carried
                              along its velocities to now by the kind's dead
                              reckoning, so that an object drifting at a
                              steady velocity sends only heartbeats; and a
                              heartbeat received stands for that prediction
                              at its time. Both hosts must set it alike (a
                              receiver reads a heartbeat by its own desc).
                              A kind without dead reckoning (custom agents)
                              is compared as with 0. Default 0: the last
                              snapshot sent, as it was */
    int adopt_sent;        /* f32 and GS_ENCODING_QUANT: 1 makes the agent
                              take, at each publish, its state as the
                              peers decode it (a cloth, a rigid body; not a
                              probe, which follows its target): a copy
                              stepped on its own from the values it was
                              sent then runs from the same bits as the
                              sender, where from values the sender never
                              held the chaotic contacts of a resting scene
                              (spheres on a cloth) take the quantization's
                              half step apart. It moves the agent by up to
                              half a step a publish (velocities too); the
                              history logs each one (re-runs stay
                              bitwise). A trade, hence default 0: in
                              replay mode two hosts then end bit for bit
                              equal, but the snaps keep a resting scene
                              moving past rest_threshold (the spheres'
                              snaps alone too), so send on change no
                              longer rests: the paper scene at
                              rest, quant + send on change, 1068 kbit/s
                              against 59.9 (divergence 0 against 3.5e-5 m;
                              present mode 1045 against 7.9, 2.3e-4 m
                              against 8.1e-3), quant + delta 318 against
                              97. Pushed (the scene moving anyway), replay
                              mode gains: every quantized encoding at f64's
                              divergence (5.2e-4 m against 1.2e-3 to 2.2e-3)
                              for 3% more bytes; present mode loses (quant
                              0.0147 m against 0.0060). 1 or 0
                              (docs/sync-notes.md) */
} gs_ghost_desc;

/* The ghost desc with its defaults (what zero fields become); object_id
   is still to be given. */
GS_API gs_ghost_desc gs_ghost_desc_default(void);
/* Wraps an agent in a ghost. GS_ERR_INVALID_ARG for object id 0 or one
   already used in this world, a bad rate, encoding or queue size;
   GS_ERR_CAPACITY for a state too big for the wire: more than
   GS_WIRE_MAX_OBJECT_CHUNKS chunks in the chosen encoding;
   GS_ERR_OUT_OF_RANGE for a state too big for the ghost's buffers to fit
   in size_t (a custom agent's). */
GS_API gs_result gs_ghost_attach(gs_agent *a, const gs_ghost_desc *desc);
/* Removes the agent's ghost: it no longer publishes or blends, and the
   snapshots queued for it go. GS_OK for an agent without one,
   GS_ERR_INVALID_ARG for NULL, GS_ERR_BUSY from a callback. */
GS_API gs_result gs_ghost_detach(gs_agent *a);

/* Per ghost counters. */
typedef struct gs_ghost_stats {
    uint64_t blends;          /* blends that used at least one snapshot */
    uint64_t snapshots_blended;
    uint64_t queue_dropped;   /* snapshots pushed out of a full queue */
    uint64_t bad_weights;     /* weights that were negative, NaN or inf */
    double last_correction;   /* m (RMS over the state) the last blend moved */
} gs_ghost_stats;
/* The ghost's counters into *out. GS_ERR_INVALID_ARG if the agent has no
   ghost or out is NULL. */
GS_API gs_result gs_ghost_get_stats(const gs_agent *a, gs_ghost_stats *out);

/* The state to draw: the physics state plus the corrections of recent blends
   fading out over `smoothing` seconds of simulation time, so that a
   correction never shows as a pop. n = gs_agent_state_size(a). */
GS_API gs_result gs_ghost_render_state(const gs_agent *a, double *out,
                                       size_t n);

/* Ghosts on every agent of the paper's scene, under the object ids every
   host of a session shares: the cloth is 1 and sphere i is 100 + i, both
   under `shared` (NULL: gs_ghost_desc_default(); its object_id and owner
   are ignored); probe i is 200 + i under owner authority, owned by host
   i + 1 (its other fields from `shared`, catch-up none: a probe is where
   its owner puts it). shared->rule_for, if set, gives any object its own
   rule (keep one authority over objects in contact: see gs_weight_fn).
   On an error no ghost is left on the scene. */
GS_API gs_result gs_scene_attach_ghosts(gs_scene *sc, const gs_ghost_desc *shared);

/* ========================================================================
   >>sync
   Between the world and the net. The world calls it through two hooks,
   one that runs an advance and one after each step; the scheduler knows
   nothing of it. A snapshot's walk: received and queued by the net (>>net,
   under its lock); at the next advance taken out of the queue under the
   lock, the world rewound to the frame before its time, stepped to it,
   every ghost blended there with the lock released (>>ghost), the frames
   replayed to the present; then the ghosts publish for the net to send.
   It keeps the session clock (gs_sync_desc.clock) and
   the world history: at the start of each advance, every agent's state,
   its step count, time offset, priority and counters, what the contacts
   remember (a rigid body's own acceleration of its last step, a probe's target, the broad
   phase's order), and a log of the inputs applied since (states set by
   hand, blended snapshots, at the dispatch they came), so that a re-run
   from a recorded moment is bitwise the run that happened.
   ======================================================================== */

/* What the sync layer did (gs_world_sync_stats). */
typedef struct gs_sync_stats {
    double session_time;   /* s; the target of the last advance */
    double origin;         /* s; session time minus the local clock */
    uint32_t timekeeper;   /* host whose timeline this one follows (this
                              host when it keeps the time itself) */
    double lag;            /* s; the target less the slowest agent after the
                              last advance: above the tolerance, this host
                              cannot keep pace (it falls behind alone) */
    double lag_max;        /* s; the largest lag seen */
    uint64_t behind;       /* advances that ended more than the tolerance
                              behind the target */
    uint64_t joins;        /* times the origin jumped to a peer's timeline
                              (a late joiner takes the session's) */
    uint64_t clock_steps;  /* local clock steps detected and absorbed */
    int history;           /* frames recorded now (re-runnable) */
    uint64_t rerun_steps;  /* agent steps re-run (gs_world_sync_test) */
    uint64_t replays;      /* advances that re-ran the past to blend */
    uint64_t replay_steps; /* agent steps those replays ran (and the
                              probes of the skipped ones) */
    uint64_t replays_skipped; /* advances whose snapshots, blended in the
                              past, changed no state: the re-run stopped
                              there and the present stood */
    uint64_t fallbacks;    /* advances whose snapshots (replay mode) were
                              older than the history or replay_reach, or
                              past the budget, and blended at the present */
    uint64_t incomplete;   /* snapshots dropped in replay mode: superseded
                              by a newer whole set before theirs was whole */
    uint64_t replays_near; /* of replays_skipped: those whose blends moved
                              states, each within replay_tolerance */
    uint64_t slow_fallbacks; /* of fallbacks: advances that blended at the
                              present because this host was catching up
                              (gs_sync_desc.replay_reach) */
} gs_sync_stats;

/* The sync layer's counters. Returns GS_ERR_INVALID_ARG for NULL. */
GS_API gs_result gs_world_sync_stats(const gs_world *w, gs_sync_stats *out);

/* When to advance next, for an application that advances in frames on the
   session clock with a frame grid (gs_sync_desc.frame): *at is the instant,
   on the clock the session clock reads (gs_sync_desc.now, else the world's
   clock) and of which `now` is a reading, of the session's next frame
   boundary after the one the last advance ran to; if that instant is
   already past (the host fell behind), the first boundary at or after
   `now`. Every host that sleeps until its *at and then advances runs to
   the same time at the same wall instant, to within the session clock's
   offset error and its own wake-up latency: the frame loops of the hosts
   lock in phase. An application that computes a frame before it shows it
   wakes up to half a frame before *at (the target still rounds to that
   boundary), advances, and shows the state at *at; or, to compute further
   ahead or to be safe from a late wake, it gives the session clock
   (gs_sync_desc.now) a function that reads *at, the instant the frame is
   shown, so that the target is that boundary whenever the advance runs
   (reference_peer/ghostpeer.c's show_clock). Its ghosts' datagrams
   then leave at *at too (gs_net_update holds a state until the instant it
   stands for), so that the peers, which read the session's timeline from a
   state's time less its send time, read it right. Before the first advance
   *at is `now`. Returns GS_OK;
   GS_ERR_INVALID_ARG for a NULL world or at, a world not on the session
   clock or without a frame grid; GS_ERR_NOT_FINITE for a non-finite `now`.
   Example:
       for (;;) { double at, now = clock_now();
                  gs_world_advance(w, now - last, NULL); last = now;
                  draw(w);
                  if (gs_world_next_frame(w, clock_now(), &at) == GS_OK)
                      sleep_until(at); } */
GS_API gs_result gs_world_next_frame(gs_world *w, double now, double *at);

/* A determinism check in the spirit of GGPO's SyncTest: goes back `frames`
   advances in the history, re-runs them with the inputs recorded, and
   compares every agent's state, step count and time bit for bit with the
   present. *bad_agent is -1 when the re-run matched, else the index of the
   first agent that differs (a custom agent whose step depends on
   something its state does not hold); either way the world is left
   exactly as it was. Call between advances. Returns GS_OK, GS_ERR_BUSY
   inside an advance, GS_ERR_OUT_OF_RANGE when fewer than `frames` (>= 1)
   re-runnable advances are recorded (the history is cleared when an agent
   is created or destroyed, and an input log that overflowed ends it). */
GS_API gs_result gs_world_sync_test(gs_world *w, int frames, int *bad_agent);

/* ========================================================================
   >>wire
   Wire format v3, little-endian. A datagram (at most GS_WIRE_MAX_DATAGRAM
   bytes) is a header, whole chunks, and a CRC-32 of everything before it:
     header (48 B): magic "GSIM", version u8 = 3, flags u8, chunk count u16
       (1..GS_WIRE_MAX_CHUNKS), session u32, sender host u32, datagram
       sequence u32, run u32 (drawn by the sender at each start, so that
       its peers know it started again and its sequence with it; 0: not
       said), send time f64 (s, sender's clock), echo time f64 (the latest
       send time received from the destination), echo hold f64 (s it was
       held since)
     chunk: a header of 1 to GS_WIRE_CHUNK_HEADER bytes, coded against the
       datagram's chunk before it (an acknowledgement chunk aside: nothing
       before the first), then its payload, whose length its contents
       imply. Varints are unsigned LEB128; "zigzag" maps a signed
       difference d (u32 arithmetic read as signed) to 2d or -2d - 1.
       kind u8: bits 0-1 the chunk's kind (0 values, 1 delta, 2 heartbeat,
         3 acknowledgements), bit 2 a time follows, bits 3-4 the encoding
         (1 f64, 2 f32, 3 GS_ENCODING_QUANT), bit 5 the state is split
         (index, count and first follow), bit 6 the next chunk (below),
         bit 7 the same row (below; else 0);
       object id: zigzag(id - the chunk before's) varint (at most 5 bytes);
       snapshot sequence: zigzag(sequence - the chunk before's) varint;
       the simulation time f64 (exact) if bit 2, else the chunk before's
         (the first chunk of a datagram always says it);
       if bit 5: chunk index, chunk count (varints of at most 3 bytes,
         index < count <= 65535) and first element (of the state after its
         time; at most 5 bytes); without it 0 of 1 from 0 (and bit 5 with
         those is refused: one datagram, one meaning);
       element count varint (at most 2 bytes; a heartbeat has none: 0);
       an acknowledgement chunk is the kind byte (bits 2 and 5 clear, the
         encoding 3), the host it is for as a varint and its entry count
         (1..GS_WIRE_MAX_ACKS), nothing else: the chunk after it is coded
         against the chunk before it.
       The next chunk (bit 6; not a heartbeat or an acknowledgement): the
         chunk continues the chunk before's snapshot: its object id,
         sequence and time, chunk index + 1 (< its count), the same count,
         first element = the chunk before's first + its element count (at
         most 2^32 - 1), and its element count, unless bit 5 is set: then
         the element count varint alone follows (not the chunk before's).
         Bit 2 says, in a delta chunk after a delta chunk, that its
         baseline is the chunk before's: its payload then starts at the
         width and coding byte (no baseline distance); else bit 2 is
         clear. A chunk that continues the chunk before so says it with
         bit 6 and only so, and a delta against the chunk before's
         baseline with bit 2 and only so (the long forms are refused: one
         datagram, one meaning); each further chunk of a cut snapshot in
         a datagram takes 1 byte of header, a last shorter one 2 or 3.
         Bit 7 says, in a delta chunk with bit 6 after a chunk of coding 3
         (spatial, below), that this one is of coding 3 too, of the chunk
         before's row R and of restart 0: its payload then has no row and
         restart bytes. It is set only so (elsewhere refused), and a next
         chunk after a spatial one of row R that would say R and restart
         0 itself is refused (one meaning); the cloth's chunks of
         positions, of the same row, so save 2 bytes each.
       A chunk of 10 f64 after one of the same time and sequence (and not
       its next chunk): 4 bytes of header; a heartbeat 3. (Bit 6 is new in
       this revision of v3: a ghostsim before it refuses its datagram as
       GS_REJECT_LAYOUT.) The payload: count values as f64 or f32,
       or in
       GS_ENCODING_QUANT a segment count u8 (1..GS_WIRE_MAX_SEGMENTS) and
       segments whose value counts add up to the element count:
         scalar (kind 1): count u16, step f64 (> 0), width u8 (0..32),
           base (a zigzag LEB128 varint, at most 9 bytes, |base| <=
           2^51 - 2^32),
           then count unsigned integers q of width bits, packed from the
           least significant bit of the first byte on (the segment padded
           to a whole byte); value i = (base + q_i) * step.
         quaternion (kind 2): count u16 (a multiple of 4), bits u8
           (8..24), then per quaternion (x, y, z, w) 3 + 3 * bits bits
           packed as above: the index of the largest component (2 bits),
           its sign (1 bit: 1 negative), and the other three in order,
           each q in [0, 2^bits - 1] for (q / (2^bits - 1)) * sqrt(2) -
           1 / sqrt(2); the largest is sqrt(1 - the others' squares).
       The error, against the exact state: a scalar is off by at most half
       its step: the ghost's resolution, as long as the chunk's values of
       the segment span under 2^32 steps (214 km at 0.05 mm); a wider span
       doubles the step until it fits (then the error is half of that). A
       quaternion of a rotation is sent normalized, each of its three
       components off by at most sqrt(2) / (2 (2^bits - 1)) (1.1e-5 at 16
       bits), its rotation by about twice that in radians. At
       gs_ghost_desc's defaults a position is off by at most 0.025 mm
       and a velocity by 1.5 mm/s (rad/s): over one 60 Hz send period
       that velocity error moves a point 0.025 mm, no more than the
       position's own.
     The chunk kinds are the chunk flags of gs_wire_chunk:
     Kind 2 (GS_WIRE_CHUNK_REST): a heartbeat: no values
       (element count 0, payload 0 bytes, chunk index 0); the object is at
       rest at the time it carries, its state within the sender's
       rest_threshold of the last snapshot it sent of it (with
       gs_ghost_desc.rest_extrapolate on both hosts: of that snapshot as
       decoded, carried along its velocities to the heartbeat's time by the
       kind's dead reckoning; the receiver queues that prediction).
     Kind 1 (GS_WIRE_CHUNK_DELTA, GS_ENCODING_QUANT only, element count
       1..GS_WIRE_QUANT_CHUNK): the chunk's values as differences from the same chunk of an earlier snapshot of
       the object (its baseline), in the integers of the quantized state:
       a scalar's integer is its value over its segment's step (base + q
       above), a quaternion's four are the index of its largest component
       plus 4 if that one is negative, then the other three q. The
       segments (their kinds, counts, steps and bits) are the baseline's:
       a delta is decoded only against the very state it was coded from,
       so the receiver's state is the sender's quantized state bit for
       bit. Payload: sequence - baseline sequence (u32 arithmetic) as an
       unsigned LEB128 varint, 1..2^31 (left out after bit 6 and 2 of the
       kind byte: the chunk before's); one byte: the width w (0..32) in
       bits 0-5 and the coding in bits 6-7; then
         coding 0 (packed): element-count zigzag differences of w bits,
           packed as above;
         coding 1 (changed bitmap): element-count bits, bit i set when
           difference i is not 0 (padded with 0 bits to a whole byte),
           then for each set bit zigzag(difference) - 1 in w bits;
         coding 2 (Rice, w = k in 0..24 in bits 0-4; bit 5 set: predicted,
           below): per difference z = its zigzag,
           q = z >> k: if q < 16, q 0 bits, a 1 bit and z's k low bits;
           else 16 0 bits and z in 32 bits (only then); packed as above,
           the run padded with 0 bits to a whole byte.
         coding 3 (spatial Rice; k and bit 5 as coding 2): the row R u8
           (1..GS_WIRE_SPATIAL_ROW), the restart r u8 (0..element count -
           1) (both left out with kind bit 7: the chunk before's R, r 0),
           then coding 2's run of the residuals e_i = difference i -
           P_i, each within [-2^31, 2^31 - 1]. P_i comes from the chunk's
           differences before i (decoded first, in order; all in int64):
           with lo = r if r > 0 and i >= r, else 0, P_i = 0 if i - 3 < lo,
           else L = d[i-3] (the same coordinate of the particle before)
           if i - 3R - 3 < lo, else the median edge predictor of L, U =
           d[i-3R] (a row up) and D = d[i-3R-3]: min(L, U) if D >= max(L,
           U), max(L, U) if D <= min(L, U), else L + U - D. A cloth's
           neighbouring particles move alike: its chunks' differences
           (x, y, z per particle, positions then velocities, r where the
           velocities start) are about a bit smaller a value so. A
           receiver refuses as below a difference decoded past +-(2^31 -
           1). (Coding 3 is new in this revision of v3: a ghostsim
           before it refuses its datagram as GS_REJECT_LAYOUT.)
       Predicted (GS_WIRE_CHUNK_PREDICT, codings 2 and 3): the differences are
       from the baseline carried along its own velocities, so that a body
       moving steadily costs what its velocity changed, not what it moved.
       A position integer p (a mesh particle's coordinate, a rigid body's
       or probe's centre: the state's first run, before any quaternion)
       whose velocity is element e' of the state (a mesh: its index plus
       the position count; a rigid body or probe: plus 7) is predicted as
       p_base + round(v_base * f), f = (s_v * dt) / s_p, in IEEE doubles in
       that order, each product and quotient rounded to double, the last
       to the nearest integer (ties to even); v_base the baseline's integer
       of e', s_v and s_p the steps of their segments in the baseline,
       dt = the chunk's time - the baseline's. Every other integer
       (velocities, quaternions) is predicted as the baseline's. The
       receiver needs the baseline's chunk holding each e' as well, and
       refuses as below a predicted chunk that carries no position with a
       velocity, or whose v_base * f is past +-(2^31 - 1) or not finite.
       The sender picks whichever is smaller (Rice by an estimate from the
       differences' bit lengths): small differences with a few large ones
       take Rice about 2 bits fewer a value than packing at the largest's
       width; predicted or not by the sum of their bit lengths. A receiver
       that does not hold
       the baseline's chunk, or whose decoded integers leave the ranges
       above (a scalar past 2^51 - 2^32 steps, a quaternion component past
       2^bits - 1 or its three squares over 0.76), refuses that chunk
       (GS_REJECT_BASELINE, counted; the rest of the datagram stands) and
       says so in its next acknowledgement. (A predicted chunk is new in
       this revision of v3: a ghostsim before it refuses its datagram as
       GS_REJECT_LAYOUT.)
     Kind 3 (GS_WIRE_CHUNK_ACK): acknowledgements, no values: object id =
       the host they are for (every other host skips the chunk), decoded
       as sequence 0, time 0, chunk index 0, count 1, first element 0,
       encoding GS_ENCODING_QUANT, element count = the number of entries
       (1..GS_WIRE_MAX_ACKS), then per entry two unsigned LEB128 varints of at
       most 5 bytes: zigzag(object id - the previous entry's, from 0) * 2
       + refused, and zigzag(sequence - the previous entry's, from 0). An
       entry tells the newest snapshot of that object the sender of the
       chunk holds whole (every chunk), or with refused = 1 that it
       refused a delta of it: the next goes whole. Not every snapshot is
       acknowledged: a host with nothing else to send holds its
       acknowledgements a while (see gs_net_update); the sender codes
       against the newest it heard.
   v1 and v2 datagrams are refused as GS_REJECT_OLD_VERSION.
   A snapshot too big for one datagram is cut into chunks that each stand
   alone: a lost chunk leaves its range unblended, the rest still counts.
   A chunk carries at most GS_WIRE_CHUNK_ROOM bytes of values, so that a
   datagram holding one chunk can always be sealed.

   Flags: bit 0 (GS_WIRE_FLAG_SEALED) says the datagram is sealed; bit 1
   (GS_WIRE_FLAG_SESSION) that the sender steps on the session clock, bit
   2 (GS_WIRE_FLAG_REPLAY) that it blends in replay mode (its
   gs_sync_desc: hosts of one session must agree on both, and a receiver
   says so when they do not, GS_PEER_OTHER_MODE); every other bit is 0.
   A sealed datagram (sent when the net has a key, see
   GHOSTSIM_SODIUM) keeps the header in clear and replaces the CRC by a
   40-byte trailer:
     header (48 B, flag set; authenticated as additional data)
     chunks, encrypted (the same length as in clear)
     nonce (24 B): run epoch u64 (the sender's wall clock at its start, in
       microseconds since 1970), run salt u64 (random at each start),
       datagram counter u64 (counts every sealed datagram of the run, to
       every peer; never repeats)
     tag (16 B): the Poly1305 tag of XChaCha20-Poly1305-IETF over the
       header (additional data) and the encrypted chunks, under the 32-byte
       pre-shared key with the 24-byte nonce above.
   A restarted peer has a new salt (and a later epoch), so it never reuses
   a nonce under the same key; the epoch orders a peer's runs so that a
   recorded earlier run cannot be replayed once a later one was heard.
   ======================================================================== */
#define GS_WIRE_VERSION 3
#define GS_WIRE_MAX_SEGMENTS 4 /* segments in a quantized chunk */
#define GS_WIRE_CHUNK_REST 0x01 /* chunk flag: a heartbeat */
#define GS_WIRE_CHUNK_DELTA 0x02 /* chunk flag: differences from a baseline */
#define GS_WIRE_CHUNK_ACK 0x04 /* chunk flag: acknowledgements */
/* chunk flag, with GS_WIRE_CHUNK_DELTA: differences from the baseline
   carried along its velocities (see >>wire) */
#define GS_WIRE_CHUNK_PREDICT 0x08
#define GS_WIRE_MAX_ACKS 100 /* entries in one acknowledgement chunk */
#define GS_WIRE_MAX_DATAGRAM 1200
#define GS_WIRE_HEADER 48
#define GS_WIRE_CHUNK_HEADER 32 /* the most a chunk's header takes */
#define GS_WIRE_MAX_CHUNKS 255 /* chunks one datagram may carry */
/* Chunks one snapshot may have (its chunk index and count are u16): a
   state of at most 8 847 225 values in f64 (135 a chunk), 17 694 450 in
   f32 (270), e.g. a cloth of up to 1214 x 1214 particles in f64. */
#define GS_WIRE_MAX_OBJECT_CHUNKS 65535
#define GS_WIRE_FLAG_SEALED 0x01
#define GS_WIRE_FLAG_SESSION 0x02 /* the sender steps on the session clock */
#define GS_WIRE_FLAG_REPLAY 0x04  /* the sender blends in replay mode */
#define GS_WIRE_FLAG_SYNC (GS_WIRE_FLAG_SESSION | GS_WIRE_FLAG_REPLAY)
/* The latest simulation time a chunk may carry (s; 31 years). A double
   there still resolves 1.2e-7 s, so a 1 ms step still moves a clock; a time
   far past it (1e308 from a broken or hostile peer) would stop every clock
   that took it (t + dt == t). */
#define GS_WIRE_MAX_TIME 1e9
#define GS_WIRE_KEY_BYTES 32
#define GS_WIRE_NONCE_BYTES 24
#define GS_WIRE_TAG_BYTES 16
#define GS_WIRE_SEAL_TRAILER (GS_WIRE_NONCE_BYTES + GS_WIRE_TAG_BYTES) /* 40 */
/* bytes of values in one chunk at most (1080: 135 f64 or 270 f32) */
#define GS_WIRE_CHUNK_ROOM (GS_WIRE_MAX_DATAGRAM - GS_WIRE_HEADER - \
                            GS_WIRE_CHUNK_HEADER - GS_WIRE_SEAL_TRAILER)
/* Values a quantized chunk holds at most: at most 32 bits a value and the
   segments' own bytes (1 + 4 x 21) always fit in GS_WIRE_CHUNK_ROOM. */
#define GS_WIRE_QUANT_CHUNK 240
/* The longest row the spatial delta coding (3) names: a chunk's triples */
#define GS_WIRE_SPATIAL_ROW (GS_WIRE_QUANT_CHUNK / 3)

/* One run of a quantized chunk's values (GS_ENCODING_QUANT). To encode, the
   caller sets kind, count and step (scalar) or bits (quaternion); decode
   fills them all. */
typedef enum gs_wire_kind {
    GS_WIRE_SCALAR = 1,     /* each value to a multiple of step */
    GS_WIRE_QUATERNION = 2  /* unit quaternions (x, y, z, w), smallest three */
} gs_wire_kind;
typedef struct gs_wire_segment {
    gs_wire_kind kind;
    uint16_t count;           /* values (a quaternion is 4) */
    double step;              /* scalar: the resolution asked for; decode:
                                 the step sent (doubled for a wide span) */
    int bits;                 /* quaternion: bits per component, 8..24 */
    int width;                /* decode: bits per scalar */
    int64_t base;             /* decode: the scalars' offset, in steps */
    const unsigned char *data;/* decode: the packed bits */
} gs_wire_segment;

typedef struct gs_wire_header {
    uint32_t session, sender, sequence;
    uint32_t run;                           /* the sender's run, 0: not said */
    double send_time, echo_time, echo_hold; /* s */
    unsigned sync;                          /* GS_WIRE_FLAG_SESSION and
                                               GS_WIRE_FLAG_REPLAY as the
                                               sender runs (0: present on
                                               its local clock); other
                                               bits are not written */
} gs_wire_header;

typedef struct gs_wire_chunk {
    uint32_t object_id, sequence;
    double time;                  /* s, the snapshot's simulation time */
    uint16_t index, count;        /* this chunk of how many */
    uint32_t first;               /* element of the state after the time */
    uint16_t elements;
    gs_encoding encoding;
    unsigned flags;               /* GS_WIRE_CHUNK_* or 0 */
    int segment_count;            /* GS_ENCODING_QUANT: its segments */
    gs_wire_segment segments[GS_WIRE_MAX_SEGMENTS];
    const unsigned char *payload; /* decode only: into the datagram */
    uint32_t baseline;            /* GS_WIRE_CHUNK_DELTA: the sequence of
                                     the snapshot it is coded against */
    int delta_coding, delta_width;/* decode: GS_WIRE_CHUNK_DELTA's coding
                                     (0 packed, 1 bitmap, 2 Rice, 3
                                     spatial) and width */
    int delta_row;                /* delta, encode: 1..GS_WIRE_SPATIAL_ROW
                                     tries the spatial coding (3) with
                                     rows of that many (x, y, z) triples,
                                     anything else does not; decode: its
                                     row (coding 3), else 0 */
    int delta_restart;            /* decode, coding 3: where its
                                     neighbours start again (0: nowhere) */
    uint16_t payload_bytes;       /* decode: the payload's length */
    uint8_t delta_skip;           /* decode, delta: the payload's bytes
                                     before its coding byte (the baseline
                                     distance's varint; 0 when the kind
                                     byte's bit 2 says the chunk before's,
                                     see >>wire); 0 otherwise */
    uint8_t delta_data;           /* decode, delta: the payload's bytes
                                     before its coded differences (the
                                     distance, the coding byte, and in
                                     coding 3 its row and restart unless
                                     the kind byte's bit 7 says them);
                                     0 otherwise */
} gs_wire_chunk;

/* One entry of an acknowledgement chunk (GS_WIRE_CHUNK_ACK). */
typedef struct gs_wire_ack {
    uint32_t object_id;
    uint32_t sequence; /* the newest snapshot held whole */
    int refused;       /* 1: a delta of it was refused, send it whole */
} gs_wire_ack;

typedef struct gs_wire_view {
    gs_wire_header header;
    int chunk_count;
    gs_wire_chunk chunks[GS_WIRE_MAX_CHUNKS];
} gs_wire_view;

/* Why a datagram was refused. The list makes the enum and the names. */
#define GS__REJECT_LIST(X)                                                     \
    X(GS_REJECT_SHORT, "shorter than its header or its lengths say")           \
    X(GS_REJECT_MAGIC, "not a ghostsim datagram")                              \
    X(GS_REJECT_VERSION, "unknown wire version")                               \
    X(GS_REJECT_CHECKSUM, "checksum mismatch")                                 \
    X(GS_REJECT_LAYOUT, "chunk count, encoding or lengths inconsistent")       \
    X(GS_REJECT_SESSION, "another session")                                    \
    X(GS_REJECT_SENDER, "unknown sender or this host")                         \
    X(GS_REJECT_OBJECT, "unknown object id")                                   \
    X(GS_REJECT_RANGE, "elements or chunk index outside the object's state")   \
    X(GS_REJECT_NOT_FINITE, "a NaN or infinite value")                         \
    X(GS_REJECT_TIME,                                                          \
      "simulation time negative, past GS_WIRE_MAX_TIME, non-finite or off "    \
      "window")                                                                \
    X(GS_REJECT_DUPLICATE, "a datagram already received")                      \
    X(GS_REJECT_ADDRESS,                                                       \
      "from an address other than the one registered for its sender")          \
    X(GS_REJECT_KEY, "in clear, but this net has a key: only sealed ones go")  \
    X(GS_REJECT_AUTH,                                                          \
      "authentication failed: forged, tampered or under another key")          \
    X(GS_REJECT_REPLAY,                                                        \
      "replayed: seen already, older than the replay window, or from an "      \
      "earlier run of its sender")                                             \
    X(GS_REJECT_RATE, "over the sender's cap of datagrams per second")        \
    X(GS_REJECT_OLD_VERSION,                                                   \
      "wire format v1 or v2 (a ghostsim before wire v3): every host of a "    \
      "session must speak v3")                                                \
    X(GS_REJECT_BASELINE,                                                      \
      "a delta chunk whose baseline is not held (lost, too old, from before "  \
      "a restart) or that leaves its ranges: that chunk only")

typedef enum gs_reject {
#define GS__REJECT_ENUM(name, text) name,
    GS__REJECT_LIST(GS__REJECT_ENUM)
#undef GS__REJECT_ENUM
    GS_REJECT_COUNT
} gs_reject;

/* A static description of a reason; "unknown reason" for a value outside
   the list, never NULL. */
GS_API const char *gs_reject_str(gs_reject r);

/* Starts a datagram in buf (cap >= GS_WIRE_HEADER + 4). The header's
   times are written as given (tests forge datagrams with it); decode and
   every net refuse a send or echo time outside [0, GS_WIRE_MAX_TIME]. */
GS_API gs_result gs_wire_begin(unsigned char *buf, size_t cap,
                               const gs_wire_header *h, size_t *size);
/* Appends a chunk of `c->elements` values (none for a heartbeat: flags
   GS_WIRE_CHUNK_REST). In GS_ENCODING_QUANT, c->segments say how: their
   counts must add up to c->elements, a scalar step be in [1e-12, 1e12], a
   quaternion's bits in 8..24 and its values not all 0 (GS_ERR_INVALID_ARG
   otherwise). GS_ERR_CAPACITY if it does not
   fit in cap (leave room for the 4-byte checksum), GS_ERR_NOT_FINITE for a
   NaN or infinite value, or one beyond float range in f32 (never sent),
   GS_ERR_INVALID_ARG for a time negative or past GS_WIRE_MAX_TIME, or a
   *size that gs_wire_begin and gs_wire_add cannot have left (under
   GS_WIRE_HEADER, over cap or GS_WIRE_MAX_DATAGRAM): nothing is written. */
GS_API gs_result gs_wire_add(unsigned char *buf, size_t cap, size_t *size,
                             const gs_wire_chunk *c, const double *values);
/* Writes the checksum after size bytes (buf holds size + 4); returns the
   datagram size (0 for a NULL buf). */
GS_API size_t gs_wire_end(unsigned char *buf, size_t size);
/* Checks everything that needs no knowledge of the objects: size, magic,
   version, flags, checksum, chunk layout, encodings, finite numbers and
   times. Returns GS_OK and fills *out, or GS_ERR_REJECTED and *why (why
   may be NULL); GS_ERR_INVALID_ARG for a NULL buf or out (*why
   GS_REJECT_SHORT). Datagrams in clear
   only: a sealed one fails the checksum here (its trailer is no CRC), or
   if the CRC matched by chance its flag is a GS_REJECT_LAYOUT; only a net
   with the key opens it. */
GS_API gs_result gs_wire_decode(const unsigned char *buf, size_t size,
                                gs_wire_view *out, gs_reject *why);
/* Appends a delta chunk (c->flags GS_WIRE_CHUNK_DELTA, or with
   GS_WIRE_CHUNK_PREDICT for differences from the predicted baseline, see
   >>wire; GS_ENCODING_QUANT,
   c->baseline the baseline's sequence, older than c->sequence by 1..2^31)
   of c->elements (1..GS_WIRE_QUANT_CHUNK, a quantized chunk's most)
   integer differences from the baseline (see >>wire; each within
   +-2^31). c->delta_row in 1..GS_WIRE_SPATIAL_ROW tries the spatial
   coding (3) too, its neighbours starting again at the second of
   c->segment_count segments (c->segments' kinds and counts; none else
   read). The coding is whichever is smaller (Rice or spatial when
   predicted). Errors as gs_wire_add's; GS_ERR_INVALID_ARG for a difference
   out of range. */
GS_API gs_result gs_wire_add_delta(unsigned char *buf, size_t cap, size_t *size,
                                   const gs_wire_chunk *c, const int64_t *diff);
/* Appends an acknowledgement chunk for host `to` of n entries (1..
   GS_WIRE_MAX_ACKS). Errors as gs_wire_add's. */
GS_API gs_result gs_wire_add_ack(unsigned char *buf, size_t cap, size_t *size, uint32_t to,
                                 const gs_wire_ack *acks, int n);
/* The differences of a decoded delta chunk (c->elements), in steps (from
   the prediction if c->flags has GS_WIRE_CHUNK_PREDICT), the spatial
   coding's already added up (a hostile one may leave +-2^31: a receiver
   refuses it). */
GS_API void gs_wire_deltas(const gs_wire_chunk *c, int64_t *out);
/* The entries of a decoded acknowledgement chunk into out (room for max);
   returns how many were written. */
GS_API int gs_wire_acks(const gs_wire_chunk *c, gs_wire_ack *out, int max);
/* Value i of a decoded chunk (quantized: as the sender's state reads
   after the round trip, bit for bit; linear in i there; a delta chunk:
   its difference i, in steps; an acknowledgement chunk: 0). */
GS_API double gs_wire_value(const gs_wire_chunk *c, int i);
/* Every value of a decoded chunk into out (c->elements doubles), in one
   pass: what gs_wire_value gives for each i. */
GS_API void gs_wire_values(const gs_wire_chunk *c, double *out);

/* ========================================================================
   >>net
   The network side of a world: peers, sending within a rate and a
   bandwidth budget, receiving through validation into the ghosts' queues.
   It rides on a transport: the simulated network, POSIX UDP, or yours.
   ======================================================================== */
typedef struct gs_net gs_net;

/* Sends one datagram of `size` bytes to peer `host`; it may be dropped on
   the way. `data` lives only during the call: a transport that sends
   later copies it. It runs inside gs_net_update (under the net's lock,
   see THREADS): calls that change the world or the net return
   GS_ERR_BUSY there. Return GS_OK when it was sent (or lost on the way,
   as a network may), an error when it was not: the net counts it as a
   send failure (gs_peer_stats.send_failures), not as sent, and
   gs_net_update returns it. */
typedef gs_result (*gs_send_fn)(void *user, uint32_t host, const void *data,
                                size_t size);

/* What carries a net's datagrams, as a table of callbacks that the net
   calls (user is passed to each): gs_simnet_transport and gs_udp_transport
   fill one, or the application fills its own with a send alone and hands
   what it receives to gs_net_deliver. Only send is required; a NULL
   callback does nothing and succeeds. Each runs in the world's thread
   (send also in gs_udp's scatter thread, under the net's lock).
   - send: see gs_send_fn; inside gs_net_update.
   - add_peer: inside gs_net_add_peer, before the net takes the peer: the
     peer's address (addr, as the application gave it, NULL if none) is
     kept or refused here (an error refuses the peer). NULL: the
     transport uses no addresses, and gs_net_add_peer refuses one that is
     given.
   - remove_peer: inside gs_net_remove_peer, after the net forgot the peer
     (and when an add_peer succeeded but the net could not take the peer).
   - attach: inside gs_net_create, once the net is made and is the world's
     (peers may be added from here); an error undoes the create.
   - poll: inside gs_net_poll, before its gs_net_update: deliver what has
     arrived (gs_net_deliver) at `now`.
   - sends_itself: nonzero when a thread of the transport calls
     gs_net_update at its own reading of the clock (gs_udp with threads:
     the scatter thread); gs_net_poll then only polls, so that one net
     does not send at two clocks.
   - detach: inside gs_net_destroy (and so gs_world_destroy), before the
     net goes; nothing may call into the net after it returns. */
typedef struct gs_transport {
    void *user;
    gs_send_fn send;                                                    /* required */
    gs_result (*add_peer)(void *user, uint32_t host, const char *addr); /* may be NULL */
    gs_result (*remove_peer)(void *user, uint32_t host);               /* may be NULL */
    gs_result (*attach)(void *user, gs_net *net);                      /* may be NULL */
    gs_result (*poll)(void *user, gs_net *net, double now);            /* may be NULL */
    void (*detach)(void *user, gs_net *net);                           /* may be NULL */
    int sends_itself;                                                  /* default 0 */
} gs_transport;

typedef struct gs_net_desc {
    uint32_t session;   /* datagrams of other sessions are refused; default 1 */
    gs_transport transport; /* required: its send at least (see gs_transport) */
    double bandwidth;   /* bytes/s to each peer at most; default 1e7.
                           A token bucket holding 50 ms of it, or the
                           largest due ghost's snapshot if more (so a
                           snapshot larger than 50 ms of the budget still
                           goes, the others waiting while the bucket
                           fills for it) */
    double time_window; /* s; refuse snapshots further than this from the
                           local time; 0 = none (a late joiner must be able
                           to take the others' state) */
    int max_peers;      /* default 16 */
    const unsigned char *key; /* NULL (default): datagrams in clear, CRC
                           only. Else GS_WIRE_KEY_BYTES (32) bytes shared by
                           every host of the session, copied at create:
                           every datagram is sealed (see >>wire) and only
                           sealed ones under this key are taken. Needs
                           GHOSTSIM_SODIUM (else GS_ERR_UNSUPPORTED) */
    double max_rate;    /* datagrams/s taken from each peer at most, with a
                           burst of a quarter second; the rest is refused
                           (GS_REJECT_RATE). Default the larger of 20000 and
                           2 * bandwidth / GS_WIRE_MAX_DATAGRAM (a peer with
                           this desc sends at most bandwidth / 1200 full
                           datagrams a second) */
} gs_net_desc;

/* Session 1, bandwidth 1e7 bytes/s, no time window, 16 peers, no key;
   an empty transport (required: fill it); max_rate 0, which follows
   bandwidth. */
GS_API gs_net_desc gs_net_desc_default(void);

/* How a peer looks from here, in gs_peer_stats.health (a name a program
   can test, and gs_peer_stats.reason for a user to read, with the
   figures). Judged by gs_net_peer_stats at the latest (largest) `now`
   the net was given, in this order (the first that holds):
   - GS_PEER_NO_UPDATE: the world advanced GS_PEER_QUIET s since the last
     gs_net_update (or since the net was made, with none): nothing is sent.
   - GS_PEER_CLOCK_BACK: the latest `now` given to gs_net_update,
     gs_net_deliver or gs_net_poll is more than GS_CLOCK_SLACK before one
     given earlier, and the clock has not caught up with it yet.
   - GS_PEER_NOT_SENDING: updates run, but nothing went to this peer for
     GS_PEER_QUIET s (a world with no ghosts has nothing to send).
   - GS_PEER_REFUSED: datagrams naming the peer as sender came in the last
     full GS_PEER_QUIET s and every one was refused (the reason and what
     did not match: gs_peer_stats.refused_reason and .reason). A refusal
     made before the sender is known (another session, a checksum) is
     read from the header's sender field here, unauthenticated: a forger
     can make a silent peer look refused, never a heard one.
   - GS_PEER_SILENT: nothing taken from the peer for GS_PEER_QUIET s (it
     does not run, poll or update, has not added this host, or the link
     is down).
   - GS_PEER_OTHER_MODE: the peer's last datagram taken says it runs
     another gs_sync_desc mode or clock than this world (wire flags
     GS_WIRE_FLAG_SESSION, GS_WIRE_FLAG_REPLAY). Its snapshots are still
     blended, so nobody stops, but hosts that blend at different times
     do not agree while objects move (three hosts in replay joined by one
     in present: 15 cm apart after it left). Give every host one mode.
   - GS_PEER_PARTLY_REFUSED: datagrams are taken, but in the last full
     GS_PEER_QUIET s some were refused as GS_REJECT_OBJECT or
     GS_REJECT_RANGE: the hosts disagree on some objects (an id, a cloth
     size), which then never meet, while the rest do. A refusal the
     network causes (a duplicate, a corrupted datagram) is no sign.
   - GS_PEER_WAITING: added less than GS_PEER_QUIET s ago, nothing taken
     from it yet.
   - GS_PEER_OK: datagrams taken from it and sent to it within
     GS_PEER_QUIET s.
   The list makes the enum and the names (gs_peer_health_str). */
#define GS__PEER_HEALTH_LIST(X)                                                \
    X(GS_PEER_OK, "ok")                                                        \
    X(GS_PEER_WAITING, "waiting")                                              \
    X(GS_PEER_NO_UPDATE, "no_update")                                          \
    X(GS_PEER_CLOCK_BACK, "clock_back")                                        \
    X(GS_PEER_NOT_SENDING, "not_sending")                                      \
    X(GS_PEER_REFUSED, "refused")                                              \
    X(GS_PEER_SILENT, "silent")                                                \
    X(GS_PEER_PARTLY_REFUSED, "partly_refused")                                \
    X(GS_PEER_OTHER_MODE, "other_mode")

typedef enum gs_peer_health {
#define GS__PEER_HEALTH_ENUM(name, text) name,
    GS__PEER_HEALTH_LIST(GS__PEER_HEALTH_ENUM)
#undef GS__PEER_HEALTH_ENUM
    GS_PEER_HEALTH_COUNT
} gs_peer_health;

/* The health's short name ("silent", "refused"...; "unknown" out of
   range): what ghostpeer's JSON says. Static, never NULL. */
GS_API const char *gs_peer_health_str(gs_peer_health h);

#define GS_PEER_QUIET 1.0   /* s: silence, or refusal, this long is a sign */
#define GS_CLOCK_SLACK 0.1  /* s: a clock this little behind is no step back
                               (gs_udp delivers from its own thread at its
                               own reading of the clock) */
#define GS_PEER_REASON_CHARS 320

/* Per peer statistics. */
typedef struct gs_peer_stats {
    uint64_t datagrams_sent, datagrams_received;
    uint64_t bytes_sent, bytes_received;
    uint64_t snapshots_sent, snapshots_received; /* chunks 0 of snapshots */
    uint64_t chunks_received;
    uint64_t lost;          /* datagrams missing from the sequence */
    uint64_t duplicates;    /* datagrams received again: refused as
                               GS_REJECT_DUPLICATE, or with a key as
                               GS_REJECT_REPLAY */
    uint64_t rejected[GS_REJECT_COUNT]; /* by reason */
    uint64_t rejected_total;
    double last_remote_time; /* s; newest simulation time received */
    double gap;              /* s; last_remote_time - local time then */
    double rtt;              /* s; latest round-trip estimate, 0 unknown */
    uint64_t heartbeats_sent, heartbeats_received; /* GS_WIRE_CHUNK_REST */
    double last_heard;       /* s, the `now` of the last datagram taken from
                                the peer (0: none yet): with objects_resting,
                                a peer at rest is told from a silent one */
    int objects_resting;     /* objects whose latest word from the peer was
                                a heartbeat (filled by gs_net_peer_stats) */
    double divergence;       /* m; the largest over the objects of the RMS
                                distance between an object's local position
                                values and the peer's latest snapshot of it
                                (brought to local time when extrapolating) */
    /* Diagnostics (filled by gs_net_peer_stats; see gs_peer_health). */
    gs_peer_health health;
    char reason[GS_PEER_REASON_CHARS]; /* what health means here, with
                                the figures: "nothing received from this
                                peer for 1.2 s ...", "" for GS_PEER_OK */
    gs_reject refused_reason; /* GS_PEER_REFUSED: the first refusal's
                                reason (GS_PEER_PARTLY_REFUSED: the
                                mismatch's); GS_REJECT_COUNT otherwise */
    uint64_t clock_backwards; /* times the net's `now` went back more than
                                GS_CLOCK_SLACK (the net's count: the same
                                on each of its peers) */
    double clock_back_max;    /* s; the largest of those steps back */
    uint64_t send_failures;  /* datagrams to the peer whose send callback
                                returned an error: taken as not sent (not
                                in datagrams_sent or bytes_sent, and their
                                sequence number goes to the next one);
                                gs_net_update returns the first error */
} gs_peer_stats;

/* Gives the world its net: the one way to make one, whatever carries the
   datagrams. desc->transport is filled by gs_simnet_transport, by
   gs_udp_transport, or by the application (its own send; it hands what
   it receives to gs_net_deliver). The transport's attach runs last (the
   simnet links the new host to those before it, gs_udp starts its
   threads). Zero fields take the defaults beside them; desc and
   desc->transport.send are required. Peers come after (gs_net_add_peer).
   Returns GS_OK and *out, or GS_ERR_INVALID_ARG (a NULL desc, out or
   transport.send, a world that has a net already, a bandwidth, max_rate
   or max_peers out of range, a negative time_window), GS_ERR_NOT_FINITE
   for a NaN or infinite number, GS_ERR_UNSUPPORTED for a key without
   GHOSTSIM_SODIUM, GS_ERR_SYSTEM if libsodium fails to start,
   GS_ERR_NO_MEMORY, GS_ERR_BUSY from a callback, or the attach's error
   (then nothing is kept); *out is NULL on failure, the reason in
   gs_world_error. gs_world_destroy destroys the net too. */
GS_API gs_result gs_net_create(gs_world *w, const gs_net_desc *desc,
                               gs_net **out);
/* Detaches the transport (gs_udp: its threads stop, its socket closes
   and it is freed), then frees the net and the ghosts' queues. Refused
   from a callback or while a gs_simnet_run runs it, as gs_world_destroy. */
GS_API void gs_net_destroy(gs_net *net);
/* Adds host as a peer, at addr if the transport uses addresses (gs_udp:
   "HOST:PORT", "[v6]:PORT", required; the simnet's and a transport
   without add_peer: NULL). From then on the ghosts' states go to it and
   its datagrams are taken (a host that is not a peer is refused as
   GS_REJECT_SENDER; gs_udp takes them from that address only). A host
   that is a peer already: GS_OK, and the transport takes the new address.
   GS_ERR_INVALID_ARG for host 0 or this host's id, an address the
   transport refuses (gs_udp: none, or one that does not parse) or one
   given to a transport without addresses; GS_ERR_CAPACITY past
   max_peers, GS_ERR_NO_MEMORY for the ghosts' queues (then no queue is
   kept and the transport forgets the peer again), GS_ERR_BUSY from a
   callback; the reason in gs_world_error. */
GS_API gs_result gs_net_add_peer(gs_net *net, uint32_t host, const char *addr);
/* Forgets a peer: nothing more goes to it, its datagrams are refused and
   the snapshots queued from it go; then the transport forgets it (its
   remove_peer: gs_udp drops the address). GS_ERR_INVALID_ARG for a host
   that is not a peer, GS_ERR_BUSY from a callback. */
GS_API gs_result gs_net_remove_peer(gs_net *net, uint32_t host);
/* Sends what is due at wall time `now` (s): each ghost's latest state at its
   rate, within each peer's bandwidth. A send callback that fails is
   counted on its peer (gs_peer_stats.send_failures), the other datagrams
   still go, and the first failure's result is returned (with the host in
   gs_world_error). `now` is a clock that only moves
   forward, in [0, GS_WIRE_MAX_TIME] (GS_ERR_INVALID_ARG outside it,
   GS_ERR_NOT_FINITE for NaN or infinity): the same clock for
   gs_net_deliver. A `now` that goes back is taken (a host whose clock
   stepped back goes on sending) and counted: gs_peer_stats.clock_backwards,
   and the health GS_PEER_CLOCK_BACK until the clock is past its old
   reading again. Call it once a frame, after gs_world_advance (see THE
   FRAME LOOP at the top). GS_ERR_BUSY from the send callback.
   Acknowledgements of delta snapshots received (see >>wire, kind 3) ride
   a datagram that goes anyway; when nothing else would go (this host's
   ghosts at rest) they are held until one has waited its ghost's
   heartbeat period or 4 (GS_DELTA_RING / 4) snapshots of one ghost wait,
   which bounds how far behind the peer's delta baseline falls; a refusal
   goes at once. */
GS_API gs_result gs_net_update(gs_net *net, double now);
/* The frame's network call for a transport that needs one (gs_udp; any
   with a poll): the transport's poll delivers what waits (gs_udp in poll
   mode receives every waiting datagram, with threads it wakes the
   scatter thread), then gs_net_update(net, now) (not with a transport
   that sends itself: gs_udp's threads). Call it after
   gs_world_advance, with the clock the transport delivers at
   (gs_udp_now() for gs_udp: one net needs one clock, another shows as
   GS_PEER_CLOCK_BACK). Returns the poll's error, else gs_net_update's;
   GS_ERR_INVALID_ARG / GS_ERR_NOT_FINITE for a `now` as gs_net_update
   refuses it, GS_ERR_BUSY from a callback (nothing received). */
GS_API gs_result gs_net_poll(gs_net *net, double now);
/* Hands a received datagram to ghostsim (`data` is read during the call
   only), before the gs_world_advance that should blend it (see THE FRAME
   LOOP at the top). Returns GS_OK when it was queued,
   GS_ERR_REJECTED (reason in *why, may be NULL) when refused; refused
   datagrams are counted and never blended, and nothing is ever sent back.
   GS_ERR_INVALID_ARG / GS_ERR_NOT_FINITE for a `now` as gs_net_update
   refuses it, and GS_ERR_BUSY for a call from the send callback: neither
   is counted.
   Time: a send or echo time outside [0, GS_WIRE_MAX_TIME] is refused
   (GS_REJECT_TIME); a send time more than GS_MAX_AGE off the sender's
   clock as the round trips measured it leaves the snapshot's age unknown
   (it then may pull the local time on, never back); and the blend moves an
   agent's time by at most GS_MAX_TIME_CORRECTION per advance.
   The checks, cheapest first: size, magic, version; without a key the CRC
   and the decode (as gs_wire_decode: a sealed datagram fails the CRC);
   the session and the sender (a peer: until here a refusal counts among
   the unknown ones, from here on the peer's); with a key, the seal flag
   (GS_REJECT_KEY if in clear), the replay window, then one authentication
   and decryption, then the decode; then the objects and ranges, the
   sequence (duplicates) and the peer's rate cap (max_rate: only datagrams
   that passed everything count against it, so forgeries cannot starve a
   peer).
   Memory: nothing is allocated here. A net is one fixed struct (33 KB, 12 KB of it the
   decode view: 64 chunks with their quantized segments; a
   gs_udp adds 25 KB, 16 datagrams of them waiting to go out, and its
   socket's rcvbuf in the kernel), and each ghost
   keeps queue_size snapshots per peer and the newest values received
   ((queue_size + 1) * (48 + 8 * state values + chunks) bytes, allocated
   when the ghost or the peer is added;
   a full queue drops its oldest), whatever arrives. */
GS_API gs_result gs_net_deliver(gs_net *net, const void *data, size_t size,
                                double now, gs_reject *why);
/* A peer's statistics into *out (safe from any thread), and its health
   judged now (see gs_peer_health). GS_ERR_INVALID_ARG for a NULL net or
   out, or a host that is not a peer. */
GS_API gs_result gs_net_peer_stats(const gs_net *net, uint32_t host,
                                   gs_peer_stats *out);
/* Datagrams refused before their sender was known (bad magic, checksum,
   unknown sender...). */
typedef struct gs_unknown_stats {
    uint64_t rejected[GS_REJECT_COUNT]; /* by reason */
    uint64_t rejected_total;
} gs_unknown_stats;
/* Into *out (safe from any thread). GS_ERR_INVALID_ARG for a NULL net or
   out. */
GS_API gs_result gs_net_unknown_stats(const gs_net *net, gs_unknown_stats *out);
/* The world's net (made by gs_net_create), or NULL if it has none. */
GS_API gs_net *gs_world_net(const gs_world *w);
/* What is wrong with this world's networking that no call returned as an
   error, for a user to read: "" when nothing is found, else one line per
   finding, e.g. "3 ghosts and no net: nothing is sent or received
   (gs_net_create)", "a net and no peers:
   nothing is sent (...)", "a net and no ghosts: ...", then each peer
   whose health is not GS_PEER_OK or GS_PEER_WAITING, with its name and
   reason ("peer 2: silent: nothing received from this peer for 1.2 s
   ..."). The text lives in the world and stays valid until the next call
   on it; "" for a NULL w. Changes nothing else; cheap (a look at each
   peer): call it when hosts do not meet. */
GS_API const char *gs_world_diagnose(gs_world *w);

/* Optional lock around the queues, for transports that deliver from another
   thread (the UDP gather thread sets it). Weight rules and the send
   callback run under it: make it recursive if they call into the net (see
   THREADS). Refused from a callback (it may be held). */
typedef struct gs_net_lock {
    void (*lock)(void *user);
    void (*unlock)(void *user);
    void *user;
} gs_net_lock;
/* Sets the net's lock (all zero: none). A gs_udp sets its own: leave its
   net's alone. Returns nothing; from a callback it is refused and the
   lock stays as it was (the reason in gs_world_error). */
GS_API void gs_net_set_lock(gs_net *net, gs_net_lock lock);

/* ========================================================================
   >>simnet
   Several worlds in one process on a virtual clock. Each directed link has
   latency, jitter, loss, duplication, reordering, a bandwidth cap and outage
   windows, all drawn from one seed: the same seed gives the same run.
   ======================================================================== */
typedef struct gs_simnet gs_simnet;

#define GS_MAX_OUTAGES 4
/* Zero everywhere is the default: a perfect link. */
typedef struct gs_link_desc {
    double latency;    /* s, one way; default 0 */
    double jitter;     /* s; uniform in [0, jitter] added; default 0 */
    double loss;       /* probability a datagram is lost; default 0 */
    double duplicate;  /* probability it arrives twice; default 0 */
    double reorder;    /* probability it is held back by up to a latency;
                          default 0 */
    double bandwidth;  /* bytes/s; 0 (default) = unlimited */
    double outage_start[GS_MAX_OUTAGES]; /* s of virtual time; the link is */
    double outage_end[GS_MAX_OUTAGES];   /* cut in [start, end); an empty
                                            window (default) cuts nothing */
} gs_link_desc;

typedef struct gs_simnet_desc {
    uint64_t seed;        /* default 1 */
    int max_in_flight;    /* datagrams on the wire at once; default 16384 */
    gs_allocator allocator; /* default GS_MALLOC / GS_FREE */
} gs_simnet_desc;

/* A perfect link: no latency, loss or cap (what a host joins with). */
GS_API gs_link_desc gs_link_desc_default(void);
/* Seed 1, 16384 datagrams in flight, the default allocator. */
GS_API gs_simnet_desc gs_simnet_desc_default(void);

/* Creates an empty simulated network; desc may be NULL (all defaults).
   Returns GS_OK and *out, or GS_ERR_INVALID_ARG (a NULL out, max_in_flight
   outside 1..4194304, an allocator with only one of alloc and free),
   GS_ERR_OUT_OF_RANGE, GS_ERR_NO_MEMORY; *out is NULL on failure (there
   is no world to hold a message). */
GS_API gs_result gs_simnet_create(const gs_simnet_desc *desc, gs_simnet **out);
/* Destroys the simnet (not the worlds or their nets). Ignored from a
   callback inside its gs_simnet_run. */
GS_API void gs_simnet_destroy(gs_simnet *sim);
/* Fills *out with a transport on this simnet for one host: give it to
   gs_net_create (nd.transport), which joins the world there. The host is
   the world's host_id; at the create it is linked both ways to every host
   joined so far with a perfect link (each is the other's peer: no
   gs_net_add_peer needed, and no address is taken). If a host cannot
   take it (GS_ERR_CAPACITY past its max_peers) nothing is kept: no net,
   and no host keeps it as a peer. One transport makes one net (a second
   gs_net_create with it is GS_ERR_INVALID_ARG), and the same transport
   may be given again after a create that failed. Its net's destroy
   takes the host off the simnet (what is sent to it is lost). Returns
   GS_OK, or GS_ERR_INVALID_ARG for a NULL argument, GS_ERR_CAPACITY past
   16 transports on one simnet; at the create, GS_ERR_INVALID_ARG for a
   host that joined already, GS_ERR_BUSY while the simnet runs (so are
   gs_simnet_link and gs_simnet_run). Destroy the worlds (or their nets)
   before the simnet; a net that outlives its simnet sends nothing
   (GS_ERR_INVALID_ARG, counted as send failures). */
GS_API gs_result gs_simnet_transport(gs_simnet *sim, gs_transport *out);
/* Sets the link from host a to host b (one direction), both joined.
   GS_ERR_INVALID_ARG for a host not joined, a negative latency, jitter or
   bandwidth, a probability outside [0, 1]; GS_ERR_NOT_FINITE for an
   outage time; GS_ERR_BUSY while the simnet runs. gs_simnet_error says
   which. */
GS_API gs_result gs_simnet_link(gs_simnet *sim, uint32_t a, uint32_t b,
                                const gs_link_desc *desc);
/* Runs every world for `seconds` of virtual time in frames of `frame`
   seconds: each frame advances each world, sends what is due and delivers
   what has arrived. GS_ERR_INVALID_ARG for a frame below GS_MIN_DT (it
   would not move the clock) or a virtual time past GS_WIRE_MAX_TIME. */
GS_API gs_result gs_simnet_run(gs_simnet *sim, double seconds, double frame);
/* The simnet's virtual time, in seconds: the frames run so far. */
GS_API double gs_simnet_time(const gs_simnet *sim);
/* The detail of the last failed call on this simnet ("" if none, or for a
   NULL sim): the simnet may have no world to hold it. Its transport's
   failures at gs_net_create are also in the joining world's gs_world_error. Valid until the
   next call on the simnet. */
GS_API const char *gs_simnet_error(const gs_simnet *sim);
/* A host's own clock on the simnet (tests of the session clock): the
   simnet's time t reads as offset + rate * t, plus step_by from step_at on. */
typedef struct gs_sim_clock {
    double offset;   /* s; default 0 */
    double rate;     /* default (0) 1; 1.0001 runs 100 ppm fast */
    double step_at;  /* s of simnet time */
    double step_by;  /* s; 0 (default) = no step */
} gs_sim_clock;
/* The simnet's own clock: offset 0, rate 1, no step. */
GS_API gs_sim_clock gs_sim_clock_default(void);
/* Sets host's clock: its net's send and receive times and its world's
   session clock read it. GS_ERR_INVALID_ARG for an unknown host or a rate
   <= 0, GS_ERR_NOT_FINITE for a non-finite field. */
GS_API gs_result gs_simnet_set_clock(gs_simnet *sim, uint32_t host,
                                     const gs_sim_clock *clock);
/* What the simnet's links did to the datagrams. */
typedef struct gs_simnet_stats {
    uint64_t dropped;    /* lost, cut by an outage, or past max_in_flight */
    uint64_t duplicated; /* sent twice */
    uint64_t delivered;  /* handed to a net (gs_net_deliver) */
} gs_simnet_stats;
/* GS_ERR_INVALID_ARG for a NULL sim or out. */
GS_API gs_result gs_simnet_get_stats(const gs_simnet *sim, gs_simnet_stats *out);

/* ========================================================================
   >>udp
   POSIX UDP (left out by GHOSTSIM_NO_UDP): the paper's gather thread
   (receive, validate, queue) and scatter thread (send what is due), or
   no threads at all: call gs_net_poll from your loop.
   Peers are an allow-list of (host id, address) pairs: a datagram whose
   source address is not the one registered for the sender id in its
   header is refused (GS_REJECT_ADDRESS, counted on that peer) before
   gs_net_deliver sees it; one from an unregistered id is refused there
   (GS_REJECT_SENDER). Datagrams go to registered addresses only: nobody
   else ever gets a reply. An address names the host and the port (IPv4,
   or IPv6; an IPv4-mapped IPv6 source matches its IPv4 address).
   ======================================================================== */
#ifndef GHOSTSIM_NO_UDP
typedef struct gs_udp gs_udp;

typedef struct gs_udp_desc {
    const char *bind;      /* "HOST:PORT", "[v6]:PORT"; required; a port
                              outside 0..65535 is GS_ERR_INVALID_ARG (0:
                              the kernel picks one) */
    int threads;           /* 1: gather and scatter threads; 0 (default):
                              poll mode (call gs_net_poll each frame) */
    int rcvbuf;            /* bytes; default 4 MiB */
} gs_udp_desc;

/* bind NULL (required: set it), poll mode, 4 MiB of rcvbuf. */
GS_API gs_udp_desc gs_udp_desc_default(void);

/* Opens a UDP socket bound to desc->bind, for world w's net (w gives the
   allocator and holds the messages): the socket exists before the peers
   that send to it are named. Then gs_udp_transport and gs_net_create make
   the net (threads 1 starts the gather and scatter threads there), and
   gs_net_add_peer(net, host, "HOST:PORT") names each peer. Returns GS_OK
   and *out, or GS_ERR_INVALID_ARG (a NULL argument, a bad address or
   port), GS_ERR_SYSTEM (the socket or its bind, e.g. a port in use: the
   system's reason in gs_world_error), GS_ERR_NO_MEMORY, GS_ERR_BUSY from
   a callback; *out is NULL and nothing is kept on failure. Once its net
   is made, the net owns it: gs_net_destroy (or gs_world_destroy) stops
   its threads, closes the socket and frees it. */
GS_API gs_result gs_udp_create(gs_world *w, const gs_udp_desc *desc, gs_udp **out);
/* Fills *out with the transport of u, for gs_net_create on u's world
   (another world's net is GS_ERR_INVALID_ARG there, as is a second net).
   Its add_peer requires an address; its poll (gs_net_poll) receives in
   poll mode and wakes the scatter thread with threads. GS_ERR_INVALID_ARG
   for a NULL argument. */
GS_API gs_result gs_udp_transport(gs_udp *u, gs_transport *out);
/* Frees a gs_udp: with its net made, destroys that net (as
   gs_net_destroy, which frees the gs_udp with it); without (its
   gs_net_create failed or never came), closes the socket and frees it.
   Refused from a callback of its world (the threads may wait on the lock
   it holds). */
GS_API void gs_udp_close(gs_udp *u);
/* The wall clock gs_udp uses (CLOCK_MONOTONIC seconds). */
GS_API double gs_udp_now(void);
#endif

#ifdef __cplusplus
}
#endif
#endif /* GHOSTSIM_H_INCLUDED */

/* ########################################################################
   IMPLEMENTATION
   ######################################################################## */
#ifdef GHOSTSIM_IMPLEMENTATION
#ifndef GHOSTSIM_IMPLEMENTATION_DONE
#define GHOSTSIM_IMPLEMENTATION_DONE

#include <ccd/ccd.h>
#include <limits.h>
#include <float.h> /* FLT_EVAL_METHOD */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

/* ========================================================================
   >>config
   ======================================================================== */
#if defined(GS_MALLOC) && !defined(GS_FREE)
#error "ghostsim: define both GS_MALLOC and GS_FREE, or neither"
#endif
#if !defined(GS_MALLOC) && defined(GS_FREE)
#error "ghostsim: define both GS_MALLOC and GS_FREE, or neither"
#endif
#ifndef GS_MALLOC
#include <stdlib.h>
#define GS_MALLOC(size, ctx) ((void)(ctx), malloc(size))
#define GS_FREE(ptr, ctx) ((void)(ctx), free(ptr))
#endif
#ifndef GS_ASSERT
#include <assert.h>
#define GS_ASSERT(c) assert(c)
#endif
#ifndef GS_MAX_QUEUES
#define GS_MAX_QUEUES 64
#endif
#ifdef GHOSTSIM_SODIUM
#include <sodium.h>
#endif

#if defined(__GNUC__) || defined(__clang__)
#define GS__PRIVATE static __attribute__((unused))
#define GS__PRINTF(f, a) __attribute__((format(printf, f, a)))
/* an inner loop's step, inlined where the compiler would call it */
#define GS__PRIVATE_INLINE static inline __attribute__((unused, always_inline))
#else
#define GS__PRIVATE static
#define GS__PRINTF(f, a)
#define GS__PRIVATE_INLINE static
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* What the net keeps for its security (>>net and >>wire use it; here so
   that the net's and the peers' structs can hold it). */
#define GS__REPLAY_WORDS 4 /* a replay window of (4 - 1) * 64 datagrams */
typedef struct gs__replay {
    int known;                  /* a run of this peer was heard */
    uint64_t epoch, salt;       /* the run's, from its nonces */
    uint64_t top;               /* its highest datagram counter so far */
    uint64_t bits[GS__REPLAY_WORDS]; /* counter c seen: bit c % 256 */
} gs__replay;

typedef struct gs__peer_guard {
    gs__replay replay;          /* sealed datagrams only */
    int rate_init;
    double rate_tokens;         /* datagrams the receive cap allows now */
    double rate_at;             /* s, wall time of the last refill */
} gs__peer_guard;

typedef struct gs__net_guard {
    int keyed;                  /* 1: every datagram sealed */
    unsigned char key[GS_WIRE_KEY_BYTES];
    uint64_t epoch, salt;       /* this run's: wall clock us, random */
    uint64_t counter;           /* sealed datagrams sent in this run */
    unsigned char plain[GS_WIRE_MAX_DATAGRAM]; /* an opened datagram */
    unsigned char sealed[GS_WIRE_MAX_DATAGRAM]; /* one peer's copy, sealed */
} gs__net_guard;

GS__PRIVATE void *gs__default_alloc(size_t size, void *user) {
    return GS_MALLOC(size, user);
}

GS__PRIVATE void gs__default_free(void *ptr, void *user) {
    GS_FREE(ptr, user);
}

/* The default clock for the wall-clock budget. Without POSIX timers it falls
   back to processor time, which still bounds the work. */
GS__PRIVATE double gs__default_clock(void *user) {
    (void)user;
#if defined(CLOCK_MONOTONIC)
    {
        struct timespec ts;
        clock_gettime(CLOCK_MONOTONIC, &ts);
        return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
    }
#else
    return (double)clock() / (double)CLOCKS_PER_SEC;
#endif
}

/* ========================================================================
   >>math
   ======================================================================== */
GS__PRIVATE gs_vec3 gs__v3(double x, double y, double z) {
    gs_vec3 r;
    r.x = x; r.y = y; r.z = z;
    return r;
}
GS__PRIVATE gs_vec3 gs__add(gs_vec3 a, gs_vec3 b) {
    return gs__v3(a.x + b.x, a.y + b.y, a.z + b.z);
}
GS__PRIVATE gs_vec3 gs__sub(gs_vec3 a, gs_vec3 b) {
    return gs__v3(a.x - b.x, a.y - b.y, a.z - b.z);
}
GS__PRIVATE gs_vec3 gs__scale(gs_vec3 a, double s) {
    return gs__v3(a.x * s, a.y * s, a.z * s);
}
/* a + b * s: the integrators' inner operation */
GS__PRIVATE gs_vec3 gs__madd(gs_vec3 a, gs_vec3 b, double s) {
    return gs__v3(a.x + b.x * s, a.y + b.y * s, a.z + b.z * s);
}
GS__PRIVATE double gs__dot(gs_vec3 a, gs_vec3 b) {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}
GS__PRIVATE gs_vec3 gs__cross(gs_vec3 a, gs_vec3 b) {
    return gs__v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z,
                  a.x * b.y - a.y * b.x);
}
GS__PRIVATE double gs__len(gs_vec3 a) { return sqrt(gs__dot(a, a)); }
GS__PRIVATE int gs__finite(double v) { return v - v == 0.0; }
GS__PRIVATE int gs__finite3(gs_vec3 v) {
    return gs__finite(v.x) && gs__finite(v.y) && gs__finite(v.z);
}
GS__PRIVATE int gs__is_zero3(gs_vec3 v) {
    return v.x == 0.0 && v.y == 0.0 && v.z == 0.0;
}
GS__PRIVATE double gs__max_abs3(gs_vec3 v) {
    return fmax(fabs(v.x), fmax(fabs(v.y), fabs(v.z)));
}
/* Within +-GS_MAX_COORD on every axis (so also finite, and not NaN). */
GS__PRIVATE int gs__in_range3(gs_vec3 v) {
    return fabs(v.x) <= GS_MAX_COORD && fabs(v.y) <= GS_MAX_COORD &&
           fabs(v.z) <= GS_MAX_COORD;
}

/* ========================================================================
   >>result
   ======================================================================== */
GS_API const char *gs_result_str(gs_result r) {
    switch (r) {
#define GS__RESULT_CASE(name, value, text) \
    case name: return text;
        GS__RESULT_LIST(GS__RESULT_CASE)
#undef GS__RESULT_CASE
    default: return "unknown result";
    }
}

/* Validation of descs: the first failed check records a code and a message
   naming the field; later checks do nothing, so a create call reads as a
   list of checks followed by one test of c.r. */
typedef struct gs__check {
    char *buf;       /* where the message goes */
    size_t cap;
    const char *who; /* the public call being checked */
    gs_result r;
} gs__check;

GS__PRIVATE GS__PRINTF(3, 4) void gs__check_fail(gs__check *c, gs_result r,
                                                 const char *fmt, ...) {
    va_list ap;
    int n;
    if (c->r != GS_OK) return;
    c->r = r;
    if (!c->buf || c->cap == 0) return;
    n = snprintf(c->buf, c->cap, "%s: ", c->who);
    if (n < 0 || (size_t)n >= c->cap) return;
    va_start(ap, fmt);
    vsnprintf(c->buf + n, c->cap - (size_t)n, fmt, ap);
    va_end(ap);
}

GS__PRIVATE void gs__check_finite(gs__check *c, const char *field, double v) {
    if (!gs__finite(v))
        gs__check_fail(c, GS_ERR_NOT_FINITE, "%s is %g, must be finite",
                       field, v);
}

GS__PRIVATE void gs__check_positive(gs__check *c, const char *field,
                                    double v) {
    gs__check_finite(c, field, v);
    if (gs__finite(v) && v <= 0.0)
        gs__check_fail(c, GS_ERR_INVALID_ARG, "%s is %g, must be > 0", field,
                       v);
}

/* A step: finite, and at least GS_MIN_DT so that it moves a clock. */
GS__PRIVATE void gs__check_dt(gs__check *c, const char *field, double v) {
    gs__check_finite(c, field, v);
    if (gs__finite(v) && !(v >= GS_MIN_DT))
        gs__check_fail(c, GS_ERR_INVALID_ARG, "%s is %g, must be >= GS_MIN_DT (%g s)", field,
                       v, GS_MIN_DT);
}

GS__PRIVATE void gs__check_nonneg(gs__check *c, const char *field, double v) {
    gs__check_finite(c, field, v);
    if (gs__finite(v) && v < 0.0)
        gs__check_fail(c, GS_ERR_INVALID_ARG, "%s is %g, must be >= 0", field,
                       v);
}

GS__PRIVATE void gs__check_vec(gs__check *c, const char *field, gs_vec3 v) {
    if (!gs__finite3(v))
        gs__check_fail(c, GS_ERR_NOT_FINITE,
                       "%s is (%g, %g, %g), must be finite", field, v.x, v.y,
                       v.z);
}

/* A position: finite and within +-GS_MAX_COORD. */
GS__PRIVATE void gs__check_pos(gs__check *c, const char *field, gs_vec3 v) {
    gs__check_vec(c, field, v);
    if (c->r == GS_OK && !gs__in_range3(v))
        gs__check_fail(c, GS_ERR_OUT_OF_RANGE,
                       "%s is (%g, %g, %g) m, outside +-GS_MAX_COORD (%g m)",
                       field, v.x, v.y, v.z, GS_MAX_COORD);
}

/* A size (m): > 0 and at most GS_MAX_COORD. */
GS__PRIVATE void gs__check_size(gs__check *c, const char *field, double v) {
    gs__check_positive(c, field, v);
    if (c->r == GS_OK && v > GS_MAX_COORD)
        gs__check_fail(c, GS_ERR_OUT_OF_RANGE,
                       "%s is %g m, more than GS_MAX_COORD (%g m)", field, v,
                       GS_MAX_COORD);
}

GS__PRIVATE void gs__check_int(gs__check *c, const char *field, long v,
                               long lo, long hi) {
    if (v < lo || v > hi)
        gs__check_fail(c, GS_ERR_INVALID_ARG, "%s is %ld, must be in %ld..%ld",
                       field, v, lo, hi);
}

/* An index into an array of count elements. */
GS__PRIVATE void gs__check_index(gs__check *c, const char *what, int i,
                                 int v, int count) {
    if (v < 0 || v >= count)
        gs__check_fail(c, GS_ERR_OUT_OF_RANGE,
                       "%s %d is %d, must be in 0..%d", what, i, v,
                       count - 1);
}

/* ========================================================================
   >>world
   ======================================================================== */
typedef struct gs__queue {
    gs_agent *head, *tail;
} gs__queue;

/* What each kind of agent does; the scheduler sees only this. */
typedef struct gs__kind {
    const char *name;
    /* Integrates by dt. On error the state must be as before the call. */
    gs_result (*step)(gs_agent *a, double dt);
    size_t (*state_size)(const gs_agent *a);      /* without the time */
    void (*get_state)(const gs_agent *a, double *out);
    gs_result (*set_state)(gs_agent *a, const double *in); /* finite input */
    uint64_t (*hash)(const gs_agent *a, uint64_t h);
    /* Moves a state (without its time) dt seconds along its own velocities;
       NULL: the kind cannot (ghosts then blend it as it is). */
    void (*extrapolate)(const gs_agent *a, double *state, double dt);
    /* How many leading state values are positions (m), for divergence. */
    size_t (*positions)(const gs_agent *a);
} gs__kind;

struct gs_agent {
    const gs__kind *kind;
    gs_world *world;
    int index;           /* in world->agents */
    int sleeping;        /* 1: not stepped, time follows the world (here,
                            beside the time: a neighbour's contact reads
                            both, and one cache line of the agent) */
    double dt;           /* s */
    uint64_t steps;
    double t_offset;     /* s; time = steps * dt + t_offset */
    int priority;
    gs_behaviour_fn behaviour;
    void *behaviour_user;
    gs_result result;    /* of the last step */
    /* scheduler bookkeeping, valid during an advance */
    gs_agent *qprev, *qnext;
    int queued;
    int failed;
    uint64_t enqueued_at; /* world->dispatches when it was queued */
    double span_t;       /* s; its time when the span heaps last saw it */
    int span_lo, span_hi; /* its place in them, -1 when out (failed) */
    gs_agent_stats stats;
    void *ghost;         /* gs__ghost, if one is attached */
    /* The rest of the sleep state (a re-run from a saved moment restores
       it and sleeping with the agent's state): */
    double rest;         /* s it has been at rest (a probe: since it
                            last moved) */
    int hold;            /* 1: sleeps after its next step if slow (a
                            ghost held at a resting leader's state) */
};

/* The two calls the world makes into the layer above it, the sync layer
   (>>sync), which fills them in when it is created with the world: the
   world, the scheduler and the agents know nothing else of it (nor of
   ghosts or the net). `advance` runs one advance's dispatches once the
   world has checked the call (the sync layer runs them through
   gs__world_run_setup and gs__world_run_loop, and first rewinds and
   replays if snapshots belong in the past); `stepped` follows each
   agent step that succeeded, before the scheduler looks at the agent
   again (a blend there can move its time, and so whether it runs
   again). */
typedef struct gs__world_hooks {
    gs_result (*advance)(gs_world *w, double seconds, gs_advance_report *rep);
    void (*stepped)(gs_agent *a);
} gs__world_hooks;

struct gs_world {
    gs_allocator alloc;
    uint32_t host_id;
    int queue_count;
    double tolerance;
    int aging_limit;
    double budget;
    uint64_t max_steps;  /* per advance */
    uint64_t epoch;      /* advances and gs_agent_step calls so far: the
                            sync layer bounds what it moves per epoch */
    gs_vec3 gravity;
    gs_clock_fn clock;
    void *clock_user;
    double sleep_time;   /* s; < 0: nothing sleeps */
    double sleep_speed;  /* m/s */
    double target;       /* s */
    int busy;            /* inside gs_world_advance */
    int inside;          /* depth of the other calls that run user code on
                            this world: gs_agent_step, a custom agent's
                            callbacks (see gs__world_unlocked) */
    gs_agent **agents;
    int agent_count, agent_cap;
    /* During an advance, the live agents in a min-heap and a max-heap on
       their time (agent_cap each): the slowest and fastest time at every
       dispatch without a scan of every agent. */
    gs_agent **span_lo, **span_hi;
    int span_n;
    double failed_lo, failed_hi; /* s; the times of the agents out of them */
    uint64_t dispatches;
    gs_net *net;         /* at most one */
    struct gs__rigid **bodies; /* the broad phase: rigid bodies and probes
                                  in creation order (the order contacts
                                  are summed in: fixed, so nothing is
                                  re-sorted as bodies move) */
    int nbodies, bodies_cap;
    int sap_dirty;       /* near is not sorted yet: creation appends, the
                            next query or advance sorts */
    struct gs__rigid **near;   /* the same sorted by x - bound (searched) */
    double *near_keys;   /* m; near's keys in its order (bodies_cap): the
                            bubble and the searches compare these, not a
                            field of each body (a cache miss each in a
                            pile bigger than the cache) */
    struct gs__rigid **wide;   /* bodies with a sweep over wide_at */
    int nwide;
    struct gs__rigid **cand;   /* the answer to a query (bodies_cap) */
    int *cand_sap;       /* the answer's sap indices as a query finds
                            them, and the scratch that puts them in order
                            (2 bodies_cap): sorted as integers, not
                            through the bodies' structs */
    struct gs__rigid **touched; /* the bodies the stepping body's contacts
                                   push, whose push lands when its step
                                   ends (bodies_cap) */
    int ntouched;
    /* A uniform grid of the bodies not wide: 2 * bodies_cap hashed cells,
       each the sap index of its first body (-1: none), chained through
       gnext and gprev (bodies_cap each). A query walks the bodies' compact
       records (grec, in the order of bodies), not the bodies: a body's
       fields are spread over several cache lines of a struct of 0.9 kB or
       more, a record is one line. */
    int *grid, *gnext, *gprev;
    struct gs__grec *grec;
    struct gs__nrec *nrec; /* what a contact reads of a neighbour before
                              its distance test, besides its grec (bodies_cap,
                              in the order of bodies) */
    double cell;         /* m; its cell size, 0 when unused */
    double wide_at;      /* m; a sweep over this makes a body wide */
    double wide_lag;     /* s; the travel time a sweep counts: the lag the
                            scheduler allows (tolerance + largest dt, at
                            most 0.1 s); 0.1 until the first advance */
    double bound_max;    /* m; the largest bound of a body not wide */
    double speed_max;    /* m/s; the largest speed of a body not wide (not
                            a probe: contacts do not carry those on) */
    int nmeshes;         /* spring-mass agents (contacts loop over them) */
    gs_agent **meshes;   /* them, in creation order (agent_cap) */
    int meshes_dirty;    /* an agent came or went: meshes is rebuilt when
                            next used */
    int ground;          /* a plane y = ground_height */
    double ground_height;
    gs_material ground_material;
    gs__queue queues[GS_MAX_QUEUES];
    struct gs__sync *sync; /* session clock and history (>>sync) */
    gs__world_hooks hooks; /* the sync layer's, set with it */
    char error[256];
    char diag[2048];     /* gs_world_diagnose's text */
};

GS__PRIVATE void *gs__alloc(gs_world *w, size_t size) {
    return w->alloc.alloc(size, w->alloc.user);
}

GS__PRIVATE void gs__free(gs_world *w, void *p) {
    if (p) w->alloc.free(p, w->alloc.user);
}

GS__PRIVATE gs__check gs__check_begin(gs_world *w, const char *who) {
    gs__check c;
    c.buf = w ? w->error : NULL;
    c.cap = w ? sizeof w->error : 0;
    c.who = who;
    c.r = GS_OK;
    return c;
}

/* Records a failure on the world and returns its code. */
GS__PRIVATE GS__PRINTF(3, 4) gs_result gs__fail(gs_world *w, gs_result r,
                                                const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(w->error, sizeof w->error, fmt, ap);
    va_end(ap);
    return r;
}

/* The re-entrancy guard. User code runs inside the world's own calls: a
   custom agent's step and state callbacks, behaviour and weight rules,
   the budget clock. While it does (an advance, gs_agent_step, a custom
   callback), every call that would change the world, an agent, a ghost or
   the net is refused with GS_ERR_BUSY: the call that runs the callback
   walks those structures and would find them changed or freed. */
GS__PRIVATE int gs__world_locked(const gs_world *w) {
    return w->busy || w->inside;
}

GS__PRIVATE gs_result gs__world_unlocked(gs_world *w, const char *who) {
    if (!w) return GS_ERR_INVALID_ARG;
    if (gs__world_locked(w))
        return gs__fail(w, GS_ERR_BUSY, "%s: the world is advancing or runs a "
                        "callback; not allowed from inside it", who);
    return GS_OK;
}

/* a * b + c bytes into *out; 0 if that does not fit in size_t (a count in
   a desc that no allocator could give: callers say GS_ERR_OUT_OF_RANGE). */
GS__PRIVATE int gs__size(size_t a, size_t b, size_t c, size_t *out) {
    if (b != 0 && a > (SIZE_MAX - c) / b) return 0;
    *out = a * b + c;
    return 1;
}

GS_API gs_sync_desc gs_sync_desc_default(void) {
    gs_sync_desc d;
    memset(&d, 0, sizeof d);
    d.clock = GS_SYNC_CLOCK_LOCAL;
    d.mode = GS_SYNC_PRESENT;
    d.history_frames = 16;
    d.replay_budget = 4096;
    d.replay_tolerance = GS_REPLAY_TOLERANCE;
    d.replay_every = GS_REPLAY_EVERY;
    d.replay_reach = GS_REPLAY_REACH;
    return d;
}

GS_API gs_world_desc gs_world_desc_default(void) {
    gs_world_desc d;
    memset(&d, 0, sizeof d);
    d.host_id = 1;
    d.queue_count = 8;
    d.tolerance = 0.01;
    d.aging_limit = 64;
    d.gravity = gs__v3(0.0, -9.81, 0.0);
    d.sync = gs_sync_desc_default();
    d.max_steps = GS_DEFAULT_MAX_STEPS;
    d.sleep_time = 0.5;
    d.sleep_speed = 0.1;
    return d;
}

GS__PRIVATE gs_world_desc gs__world_defaults(const gs_world_desc *in) {
    gs_world_desc def = gs_world_desc_default(), d;
    if (!in) return def;
    d = *in;
    if (d.host_id == 0) d.host_id = def.host_id;
    if (d.queue_count == 0) d.queue_count = def.queue_count;
    if (d.tolerance == 0.0) d.tolerance = def.tolerance;
    if (d.aging_limit == 0) d.aging_limit = def.aging_limit;
    if (gs__is_zero3(d.gravity)) d.gravity = def.gravity;
    if (d.sync.clock == GS_SYNC_CLOCK_DEFAULT) d.sync.clock = def.sync.clock;
    if (d.sync.mode == GS_SYNC_DEFAULT) d.sync.mode = def.sync.mode;
    if (d.sync.replay_budget == 0) d.sync.replay_budget = def.sync.replay_budget;
    if (d.sync.history_frames == 0) d.sync.history_frames = def.sync.history_frames;
    if (d.sync.replay_tolerance == 0.0) d.sync.replay_tolerance = def.sync.replay_tolerance;
    if (d.sync.replay_every == 0) d.sync.replay_every = def.sync.replay_every;
    if (d.sync.replay_reach == 0.0) d.sync.replay_reach = def.sync.replay_reach;
    if (d.max_steps == 0) d.max_steps = def.max_steps;
    if (d.sleep_time == 0.0) d.sleep_time = def.sleep_time;
    if (d.sleep_speed == 0.0) d.sleep_speed = def.sleep_speed;
    return d;
}

/* s; the largest sync.frame: half the band within which two timelines are
   one (GS__SYNC_BAND), so a target rounded to the grid never reads as a
   session ahead */
#define GS__SYNC_FRAME_MAX 0.05

GS__PRIVATE gs_result gs__world_check(const gs_world_desc *d) {
    gs__check c = gs__check_begin(NULL, "gs_world_create");
    gs__check_int(&c, "queue_count", d->queue_count, 1, GS_MAX_QUEUES);
    gs__check_nonneg(&c, "tolerance", d->tolerance);
    gs__check_int(&c, "aging_limit", d->aging_limit, 1, 1L << 30);
    gs__check_nonneg(&c, "budget", d->budget);
    gs__check_vec(&c, "gravity", d->gravity);
    gs__check_finite(&c, "sleep_time", d->sleep_time);
    gs__check_positive(&c, "sleep_speed", d->sleep_speed);
    gs__check_int(&c, "sync.clock", (long)d->sync.clock, 1, GS__SYNC_CLOCK_COUNT - 1);
    gs__check_int(&c, "sync.mode", (long)d->sync.mode, 1, GS__SYNC_COUNT - 1);
    gs__check_int(&c, "sync.replay_budget", d->sync.replay_budget, 1, 1L << 30);
    if (d->sync.history_frames != -1)
        gs__check_int(&c, "sync.history_frames", d->sync.history_frames, 1, 1024);
    gs__check_finite(&c, "sync.frame", d->sync.frame);
    gs__check_finite(&c, "sync.replay_tolerance", d->sync.replay_tolerance);
    gs__check_int(&c, "sync.replay_every", d->sync.replay_every, 1, GS_REPLAY_EVERY_MAX);
    gs__check_finite(&c, "sync.replay_reach", d->sync.replay_reach);
    if (!(d->sync.frame >= 0.0 && d->sync.frame <= GS__SYNC_FRAME_MAX))
        gs__check_fail(&c, GS_ERR_INVALID_ARG, "sync.frame is %g s, must be in [0, %g]",
                       d->sync.frame, GS__SYNC_FRAME_MAX);
    if (!d->allocator.alloc != !d->allocator.free)
        gs__check_fail(&c, GS_ERR_INVALID_ARG,
                       "allocator needs both alloc and free, or neither");
    return c.r;
}

GS__PRIVATE gs_result gs__sync_create(gs_world *w, const gs_sync_desc *d);

GS_API gs_result gs_world_create(const gs_world_desc *desc, gs_world **out) {
    gs_world_desc d;
    gs_allocator al;
    gs_world *w;
    gs_result r;
    if (!out) return GS_ERR_INVALID_ARG;
    *out = NULL;
    d = gs__world_defaults(desc);
    r = gs__world_check(&d);
    if (r != GS_OK) return r;
    al = d.allocator;
    if (!al.alloc) {
        al.alloc = gs__default_alloc;
        al.free = gs__default_free;
    }
    w = (gs_world *)al.alloc(sizeof *w, al.user);
    if (!w) return GS_ERR_NO_MEMORY;
    memset(w, 0, sizeof *w);
    w->alloc = al;
    w->host_id = d.host_id;
    w->queue_count = d.queue_count;
    w->tolerance = d.tolerance;
    w->aging_limit = d.aging_limit;
    w->budget = d.budget;
    w->max_steps = d.max_steps;
    w->gravity = d.gravity;
    w->sleep_time = d.sleep_time;
    w->sleep_speed = d.sleep_speed;
    w->clock = d.clock ? d.clock : gs__default_clock;
    w->clock_user = d.clock ? d.clock_user : NULL;
    if (gs__sync_create(w, &d.sync) != GS_OK) {
        al.free(w, al.user);
        return GS_ERR_NO_MEMORY;
    }
    *out = w;
    return GS_OK;
}

struct gs__ghost;
GS__PRIVATE void gs__ghost_free(struct gs__ghost *g);
GS__PRIVATE void gs__sync_destroy(gs_world *w);
GS__PRIVATE int gs__net_in_use(const gs_net *net);

/* From a callback (see gs__world_unlocked) it frees nothing: the call
   that runs the callback would go on in freed memory. */
GS_API void gs_world_destroy(gs_world *w) {
    int i;
    if (!w) return;
    if (gs__world_locked(w) || gs__net_in_use(w->net)) {
        gs__fail(w, GS_ERR_BUSY, "gs_world_destroy: called from a callback of "
                 "this world or its net, or while its simnet runs; refused, "
                 "nothing freed (destroy it once that call has returned)");
        return;
    }
    gs_net_destroy(w->net);
    for (i = 0; i < w->agent_count; ++i) {
        if (w->agents[i]->ghost) gs__ghost_free((struct gs__ghost *)w->agents[i]->ghost);
        gs__free(w, w->agents[i]);
    }
    gs__free(w, w->agents);
    gs__free(w, w->span_lo);
    gs__free(w, w->bodies);
    gs__sync_destroy(w);
    w->alloc.free(w, w->alloc.user);
}

/* Adds a new agent to the world's list, growing it as needed (create time
   only: the step loop never allocates). */
GS__PRIVATE gs_result gs__world_add(gs_world *w, gs_agent *a) {
    if (w->agent_count == w->agent_cap) {
        int cap = w->agent_cap ? 2 * w->agent_cap : 8;
        if (w->agent_cap > INT_MAX / 2 || (size_t)cap > SIZE_MAX / (3 * sizeof(gs_agent *)))
            return gs__fail(w, GS_ERR_CAPACITY, "agent list: too many agents");
        gs_agent **list = (gs_agent **)gs__alloc(w, (size_t)cap * sizeof *list);
        gs_agent **heaps = (gs_agent **)gs__alloc(w, 3 * (size_t)cap * sizeof *heaps);
        if (!list || !heaps) {
            gs__free(w, list);
            gs__free(w, heaps);
            return gs__fail(w, GS_ERR_NO_MEMORY, "agent list: out of memory");
        }
        if (w->agent_count)
            memcpy(list, w->agents, (size_t)w->agent_count * sizeof *list);
        gs__free(w, w->agents);
        gs__free(w, w->span_lo);
        w->agents = list;
        w->span_lo = heaps; /* the heaps are rebuilt at each advance */
        w->span_hi = heaps + cap;
        w->meshes = heaps + 2 * cap; /* and the mesh list where it is used */
        w->agent_cap = cap;
    }
    w->meshes_dirty = 1;
    a->index = w->agent_count;
    w->agents[w->agent_count++] = a;
    return GS_OK;
}

GS_API double gs_world_time(const gs_world *w) { return w->target; }
GS_API const char *gs_world_error(const gs_world *w) { return w ? w->error : ""; }
GS_API uint32_t gs_world_host_id(const gs_world *w) { return w->host_id; }
GS_API int gs_world_agent_count(const gs_world *w) { return w->agent_count; }

GS_API gs_agent *gs_world_agent(const gs_world *w, int i) {
    return (i >= 0 && i < w->agent_count) ? w->agents[i] : NULL;
}

GS_API gs_vec3 gs_world_gravity(const gs_world *w) { return w->gravity; }

GS__PRIVATE void gs__agent_wake_at(gs_agent *a, double t);
GS__PRIVATE double gs__agent_time(const gs_agent *a);

/* What held a sleeper still (gravity, the ground) changed. */
GS__PRIVATE void gs__wake_all(gs_world *w) {
    int i;
    for (i = 0; i < w->agent_count; ++i) gs__agent_wake_at(w->agents[i], gs__agent_time(w->agents[i]));
}

GS_API gs_result gs_world_set_gravity(gs_world *w, gs_vec3 g) {
    gs_result r = gs__world_unlocked(w, "gs_world_set_gravity");
    if (r != GS_OK) return r;
    if (!gs__finite3(g))
        return gs__fail(w, GS_ERR_NOT_FINITE,
                        "gs_world_set_gravity: gravity must be finite");
    w->gravity = g;
    gs__wake_all(w);
    return GS_OK;
}

GS_API gs_result gs_world_set_budget(gs_world *w, double seconds) {
    gs__check c = gs__check_begin(w, "gs_world_set_budget");
    gs_result r = gs__world_unlocked(w, "gs_world_set_budget");
    if (r != GS_OK) return r;
    gs__check_nonneg(&c, "budget", seconds);
    if (c.r == GS_OK) w->budget = seconds;
    return c.r;
}

GS__PRIVATE uint64_t gs__fnv(uint64_t h, const void *data, size_t n) {
    const unsigned char *p = (const unsigned char *)data;
    size_t i;
    for (i = 0; i < n; ++i) {
        h ^= p[i];
        h *= 1099511628211ull;
    }
    return h;
}

GS_API uint64_t gs_world_hash(const gs_world *w) {
    uint64_t h = 14695981039346656037ull;
    int i;
    for (i = 0; i < w->agent_count; ++i) {
        const gs_agent *a = w->agents[i];
        double t = gs_agent_time(a);
        h = gs__fnv(h, &t, sizeof t);
        h = a->kind->hash(a, h);
    }
    return h;
}

/* ========================================================================
   >>sched
   The paper's scheduler: queues Q_0..Q_N, highest first, FIFO within one.
   Two rules keep it fair and consistent:
   - aging: a queue head that has waited more than aging_limit dispatches
     runs next whatever its priority, so no queue starves;
   - holding: an agent that leads the slowest agent by more than the
     tolerance does not run, so the spread between simulation times stays
     under tolerance + the largest dt. Priorities choose the order among the
     rest; behaviour rules move them on each activation.
   ======================================================================== */
GS__PRIVATE double gs__agent_time(const gs_agent *a) {
    return (double)a->steps * a->dt + a->t_offset;
}

GS__PRIVATE void gs__queue_push(gs_world *w, gs_agent *a) {
    gs__queue *q = &w->queues[a->priority];
    a->qprev = q->tail;
    a->qnext = NULL;
    if (q->tail) q->tail->qnext = a;
    else q->head = a;
    q->tail = a;
    a->queued = 1;
    a->enqueued_at = w->dispatches;
}

GS__PRIVATE void gs__queue_remove(gs_world *w, gs_agent *a) {
    gs__queue *q = &w->queues[a->priority];
    if (a->qprev) a->qprev->qnext = a->qnext;
    else q->head = a->qnext;
    if (a->qnext) a->qnext->qprev = a->qprev;
    else q->tail = a->qprev;
    a->qprev = a->qnext = NULL;
    a->queued = 0;
}

GS__PRIVATE int gs__clamp_priority(const gs_world *w, int p) {
    if (p < 0) return 0;
    if (p >= w->queue_count) return w->queue_count - 1;
    return p;
}

/* Done for this advance: within half a step of the target. */
GS__PRIVATE int gs__agent_done(const gs_agent *a) {
    return gs__agent_time(a) >= a->world->target - 0.5 * a->dt;
}

/* ---- the span heaps: the slowest and fastest live agent in O(log n) per
   change of a time, where a scan at every dispatch makes a frame O(n^2).
   They hold exactly the agents not failed, each one's time as
   gs__agent_time computed it at its last change. ---- */
GS__PRIVATE int *gs__span_pos(gs_agent *a, int hi) {
    return hi ? &a->span_hi : &a->span_lo;
}

/* Does a belong above b: earlier in the min-heap, later in the max-heap. */
GS__PRIVATE int gs__span_above(const gs_agent *a, const gs_agent *b, int hi) {
    return hi ? a->span_t > b->span_t : a->span_t < b->span_t;
}

GS__PRIVATE void gs__span_put(gs_agent **heap, int i, gs_agent *a, int hi) {
    heap[i] = a;
    *gs__span_pos(a, hi) = i;
}

GS__PRIVATE void gs__span_down(gs_world *w, int hi, int i) {
    gs_agent **heap = hi ? w->span_hi : w->span_lo, *a = heap[i];
    for (;;) {
        int c = 2 * i + 1;
        if (c >= w->span_n) break;
        if (c + 1 < w->span_n && gs__span_above(heap[c + 1], heap[c], hi)) c++;
        if (!gs__span_above(heap[c], a, hi)) break;
        gs__span_put(heap, i, heap[c], hi);
        i = c;
    }
    gs__span_put(heap, i, a, hi);
}

/* Moves heap[i] up or down to its place. */
GS__PRIVATE void gs__span_sift(gs_world *w, int hi, int i) {
    gs_agent **heap = hi ? w->span_hi : w->span_lo, *a = heap[i];
    while (i > 0 && gs__span_above(a, heap[(i - 1) / 2], hi)) {
        gs__span_put(heap, i, heap[(i - 1) / 2], hi);
        i = (i - 1) / 2;
    }
    gs__span_put(heap, i, a, hi);
    gs__span_down(w, hi, i);
}

/* Every agent not failed, at the start of an advance. */
GS__PRIVATE void gs__span_build(gs_world *w) {
    int i, hi;
    w->span_n = 0;
    w->failed_lo = HUGE_VAL;
    w->failed_hi = -HUGE_VAL;
    for (i = 0; i < w->agent_count; ++i) {
        gs_agent *a = w->agents[i];
        a->span_lo = a->span_hi = -1;
        if (a->failed || a->sleeping) continue; /* a sleeper is at the target */
        a->span_t = gs__agent_time(a);
        gs__span_put(w->span_lo, w->span_n, a, 0);
        gs__span_put(w->span_hi, w->span_n, a, 1);
        w->span_n++;
    }
    for (hi = 0; hi < 2; ++hi)
        for (i = w->span_n / 2 - 1; i >= 0; --i) gs__span_down(w, hi, i);
}

/* An agent that woke during the advance joins the span. */
GS__PRIVATE void gs__span_insert(gs_agent *a) {
    gs_world *w = a->world;
    int hi;
    if (a->span_lo >= 0) return;
    a->span_t = gs__agent_time(a);
    for (hi = 0; hi < 2; ++hi) {
        gs__span_put(hi ? w->span_hi : w->span_lo, w->span_n, a, hi);
        w->span_n++;
        gs__span_sift(w, hi, w->span_n - 1);
        if (!hi) w->span_n--; /* both heaps grow by the one agent */
    }
}

/* Widens the range of the failed agents' times to take in a's. */
GS__PRIVATE void gs__span_failed(gs_agent *a) {
    gs_world *w = a->world;
    double t = gs__agent_time(a);
    if (t < w->failed_lo) w->failed_lo = t;
    if (t > w->failed_hi) w->failed_hi = t;
}

/* After a's time changed (a step, a blend, a set_state). */
GS__PRIVATE void gs__span_update(gs_agent *a) {
    gs_world *w = a->world;
    if (!w->busy) return;
    if (a->span_lo < 0) {
        gs__span_failed(a);
        return;
    }
    a->span_t = gs__agent_time(a);
    gs__span_sift(w, 0, a->span_lo);
    gs__span_sift(w, 1, a->span_hi);
}

/* An agent leaves the span: failed (its time still bounds the lag), or
   asleep (it is a fixed body until it wakes). */
GS__PRIVATE void gs__span_leave(gs_agent *a, int failed) {
    gs_world *w = a->world;
    int hi;
    if (a->span_lo < 0) return;
    if (failed) gs__span_failed(a);
    w->span_n--;
    for (hi = 0; hi < 2; ++hi) {
        gs_agent **heap = hi ? w->span_hi : w->span_lo;
        int i = *gs__span_pos(a, hi);
        if (i < w->span_n) {
            gs__span_put(heap, i, heap[w->span_n], hi);
            gs__span_sift(w, hi, i);
        }
    }
    a->span_lo = a->span_hi = -1;
}

GS__PRIVATE void gs__span_remove(gs_agent *a) { gs__span_leave(a, 1); }

/* The slowest and fastest time of the agents still live (the target when
   none is). */
GS__PRIVATE void gs__span_get(const gs_world *w, double *t_min, double *t_max) {
    if (w->span_n == 0) {
        *t_min = *t_max = w->target;
        return;
    }
    *t_min = w->span_lo[0]->span_t;
    *t_max = w->span_hi[0]->span_t;
}

/* How far any agent's time can be from t (s), at most max_lag: while the
   world advances the heaps know every time, failed agents' included; out
   of it (gs_agent_step) nothing is known and max_lag is the answer. */
GS__PRIVATE double gs__lag_bound(const gs_world *w, double t, double max_lag) {
    double lo = w->failed_lo, hi = w->failed_hi, lag;
    if (!w->busy) return max_lag;
    if (w->span_n > 0) {
        lo = fmin(lo, w->span_lo[0]->span_t);
        hi = fmax(hi, w->span_hi[0]->span_t);
    }
    lag = fmax(t - lo, hi - t);
    if (!(lag > 0.0)) return 0.0; /* no agent at all: -inf */
    return lag < max_lag ? lag : max_lag;
}

GS__PRIVATE int gs__runnable(const gs_world *w, const gs_agent *a,
                             double t_min) {
    return gs__agent_time(a) - t_min <= w->tolerance;
}

/* The queue head that has waited longest past the aging limit, if any. */
GS__PRIVATE gs_agent *gs__pick_aged(gs_world *w, double t_min) {
    gs_agent *best = NULL;
    int q;
    for (q = 0; q < w->queue_count; ++q) {
        gs_agent *h = w->queues[q].head;
        if (!h || w->dispatches - h->enqueued_at <= (uint64_t)w->aging_limit)
            continue;
        if (!gs__runnable(w, h, t_min)) continue;
        if (!best || h->enqueued_at < best->enqueued_at) best = h;
    }
    if (best) best->stats.aged++;
    return best;
}

/* The first runnable agent of the highest non-empty queue; failing that
   (every queued agent leads too far, which happens when the slowest agent is
   already done), the slowest queued agent. */
GS__PRIVATE gs_agent *gs__pick_urgent(gs_world *w, double t_min) {
    gs_agent *slowest = NULL, *a;
    int q;
    for (q = w->queue_count - 1; q >= 0; --q) {
        for (a = w->queues[q].head; a; a = a->qnext) {
            if (gs__runnable(w, a, t_min)) return a;
            a->stats.held++;
            if (!slowest || gs__agent_time(a) < gs__agent_time(slowest))
                slowest = a;
        }
    }
    return slowest;
}

GS__PRIVATE gs_agent *gs__pick(gs_world *w, double t_min) {
    gs_agent *a = gs__pick_aged(w, t_min);
    uint64_t wait;
    if (!a) a = gs__pick_urgent(w, t_min);
    if (!a) return NULL;
    wait = w->dispatches - a->enqueued_at;
    if (wait > a->stats.max_wait) a->stats.max_wait = wait;
    gs__queue_remove(w, a);
    return a;
}

GS_API int gs_behaviour_default(const gs_behaviour_in *in, void *user) {
    (void)user;
    if (in->t - in->t_min > in->tolerance) return in->priority - 1;
    if (in->t_max - in->t > in->tolerance) return in->priority + 1;
    return in->priority;
}

/* The paper's activation: the agent learns the slowest and fastest times
   and its behaviour rule sets its priority. */
GS__PRIVATE void gs__activate(gs_world *w, gs_agent *a, double t_min,
                              double t_max) {
    gs_behaviour_in in;
    in.t = gs__agent_time(a);
    in.t_min = t_min;
    in.t_max = t_max;
    in.tolerance = w->tolerance;
    in.dt = a->dt;
    in.priority = a->priority;
    in.priority_max = w->queue_count - 1;
    a->priority = gs__clamp_priority(w, a->behaviour(&in, a->behaviour_user));
    a->stats.activations++;
}

/* One step (the caller then calls the world's `stepped` hook). A step
   that would take the agent's time past GS_WIRE_MAX_TIME is refused: no
   clock leaves [0, GS_WIRE_MAX_TIME]. */
GS__PRIVATE gs_result gs__agent_step(gs_agent *a) {
    gs_result r;
    if (!(gs__agent_time(a) + a->dt <= GS_WIRE_MAX_TIME)) {
        a->result = GS_ERR_OUT_OF_RANGE;
        return gs__fail(a->world, GS_ERR_OUT_OF_RANGE,
                        "agent step: its time %.17g s + dt would pass GS_WIRE_MAX_TIME",
                        gs__agent_time(a));
    }
    r = a->kind->step(a, a->dt);
    a->result = r;
    if (r == GS_OK) {
        a->steps++;
        a->stats.steps++;
    }
    return r;
}

/* ---- sleeping: a sleeper is left out of the queues and the span; its
   time jumps to the target at each advance. Woken during an advance, it
   takes the time t of what woke it (its state stood since it slept, so it
   is its state at t too): a body that wakes it at t computes the pair from
   t on, and a time left at the target would have told that body that the
   sleeper had already computed the pair up to there. ---- */
GS__PRIVATE void gs__sleepers_follow(gs_world *w) {
    int i;
    for (i = 0; i < w->agent_count; ++i) {
        gs_agent *a = w->agents[i];
        if (a->sleeping) a->t_offset = w->target - (double)a->steps * a->dt;
    }
}

GS__PRIVATE void gs__agent_wake_at(gs_agent *a, double t) {
    gs_world *w = a->world;
    if (!a->sleeping) return;
    a->sleeping = 0;
    a->rest = 0.0;
    a->stats.wakes++;
    if (!w->busy || a->failed) return;
    a->t_offset = t - (double)a->steps * a->dt;
    gs__span_insert(a);
    if (!a->queued && !gs__agent_done(a)) gs__queue_push(w, a);
}

GS__PRIVATE void gs__queue_all(gs_world *w) {
    int i;
    for (i = 0; i < w->agent_count; ++i) {
        gs_agent *a = w->agents[i];
        a->failed = 0;
        if (!gs__agent_done(a)) gs__queue_push(w, a);
    }
}

GS__PRIVATE void gs__unqueue_all(gs_world *w) {
    int i;
    for (i = 0; i < w->agent_count; ++i)
        if (w->agents[i]->queued) gs__queue_remove(w, w->agents[i]);
}

/* One dispatch: pick, activate, step, queue again unless done. Returns 0
   when nothing is left to run. */
GS__PRIVATE int gs__dispatch(gs_world *w, gs_result *first_error,
                             gs_advance_report *rep) {
    double t_min, t_max;
    gs_agent *a;
    gs_result r;
    gs__span_get(w, &t_min, &t_max);
    a = gs__pick(w, t_min);
    if (!a) return 0;
    gs__activate(w, a, t_min, t_max);
    w->dispatches++;
    r = gs__agent_step(a);
    if (r == GS_OK) w->hooks.stepped(a);
    gs__span_update(a);
    if (r != GS_OK) {
        a->failed = 1;
        gs__span_remove(a);
        rep->failed_agents++;
        if (*first_error == GS_OK) *first_error = r;
        return 1;
    }
    rep->steps++;
    if (a->sleeping) gs__span_leave(a, 0); /* fell asleep in that step */
    else if (!gs__agent_done(a)) gs__queue_push(w, a);
    return 1;
}

GS__PRIVATE void gs__sap_refresh(gs_world *w);

/* The world's clock follows its agents: when every agent is ahead of it
   (blending took them to the time of hosts that are further on, as for a
   host that joins late), it jumps to the slowest of them. Otherwise they
   would stand still until the clock caught up. */
#ifndef GS__FOLLOW_STEPS
#define GS__FOLLOW_STEPS 1000.0
#endif
GS__PRIVATE double gs__world_follow_target(const gs_world *w) {
    double dt_max = 0.0;
    int i;
    for (i = 0; i < w->agent_count; ++i)
        if (w->agents[i]->dt > dt_max) dt_max = w->agents[i]->dt;
    if (w->agent_count == 0) return w->target;
    /* agents stop up to half a step past the target: only a lead beyond
       that and the tolerance is a jump. The clock follows when most agents
       have jumped, to the slowest of those; the rest catch up by stepping.
       Waiting for all would wait forever for an object whose owner is this
       host: owner authority keeps its local state, time included. */
    {
        double edge = w->target + w->tolerance + dt_max, lead_min = HUGE_VAL;
        int leading = 0;
        for (i = 0; i < w->agent_count; ++i) {
            double t = gs__agent_time(w->agents[i]);
            if (t > edge) {
                leading++;
                if (t < lead_min) lead_min = t;
            }
        }
        return 2 * leading > w->agent_count ? lead_min : w->target;
    }
}

/* Applies the follow to `target` (from gs__world_follow_target): an agent
   left more than GS__FOLLOW_STEPS of its steps behind takes the clock's
   time instead: a time from the network (a late joiner an hour on, a
   datagram that says 1e6 s) must not buy a step per dt of catching up. */
GS__PRIVATE void gs__world_follow(gs_world *w, double target) {
    int i;
    for (i = 0; i < w->agent_count; ++i) w->agents[i]->failed = 0;
    if (target == w->target) return;
    w->target = target;
    for (i = 0; i < w->agent_count; ++i) {
        gs_agent *a = w->agents[i];
        double lag = w->target - gs__agent_time(a);
        if (lag > GS__FOLLOW_STEPS * a->dt) a->t_offset += lag;
    }
}

/* One run of the dispatches, to the target set: the setup (every agent not
   done queued, the span heaps built), then the loop. Returns the world's
   clock at the start if `budget` (s, 0 = none) is set. Apart so that the
   sync layer can blend the sleepers' ghosts in between. */
GS__PRIVATE double gs__world_run_setup(gs_world *w, double budget) {
    double start = 0.0;
    gs__sleepers_follow(w);
    gs__sap_refresh(w);
    if (budget > 0.0) start = w->clock(w->clock_user);
    gs__queue_all(w);
    gs__span_build(w);
    return start;
}

/* The dispatch loop: runs until every agent is done or `budget` of the
   world's clock from `start` is spent. */
GS__PRIVATE gs_result gs__world_run_loop(gs_world *w, double budget, double start,
                                         gs_advance_report *rep) {
    gs_result first_error = GS_OK;
    rep->reached = 1;
    for (;;) {
        /* the step cap counts the whole advance's dispatches (parts and all) */
        if ((budget > 0.0 && w->clock(w->clock_user) - start >= budget) ||
            rep->steps + (uint64_t)rep->failed_agents >= w->max_steps) {
            rep->reached = 0;
            break;
        }
        if (!gs__dispatch(w, &first_error, rep)) break;
    }
    if (rep->failed_agents) rep->reached = 0;
    gs__unqueue_all(w);
    rep->target = w->target;
    gs__span_get(w, &rep->t_min, &rep->t_max);
    return first_error;
}

GS_API gs_result gs_world_advance(gs_world *w, double seconds,
                                  gs_advance_report *report) {
    gs_advance_report rep;
    gs_result first_error = GS_OK;
    double from;
    memset(&rep, 0, sizeof rep);
    if (!w) return GS_ERR_INVALID_ARG;
    if (gs__world_locked(w))
        return gs__fail(w, GS_ERR_BUSY, "gs_world_advance: already advancing, "
                        "or called from a callback of this world");
    if (!gs__finite(seconds) || seconds < 0.0)
        return gs__fail(w, gs__finite(seconds) ? GS_ERR_INVALID_ARG
                                               : GS_ERR_NOT_FINITE,
                        "gs_world_advance: seconds is %g, must be finite and "
                        ">= 0", seconds);
    from = gs__world_follow_target(w);
    if (seconds > GS_WIRE_MAX_TIME - from)
        return gs__fail(w, GS_ERR_INVALID_ARG,
                        "gs_world_advance: %g s on from %.17g s would pass "
                        "GS_WIRE_MAX_TIME (%g s)", seconds, from, GS_WIRE_MAX_TIME);
    w->error[0] = '\0'; /* from here on the text is this advance's */
    w->busy = 1;
    w->epoch++;
    first_error = w->hooks.advance(w, seconds, &rep);
    w->busy = 0;
    if (report) *report = rep;
    return first_error;
}

/* ========================================================================
   >>agent
   ======================================================================== */
GS_API gs_solver_desc gs_solver_desc_default(void) {
    gs_solver_desc d;
    memset(&d, 0, sizeof d);
    d.dt = 0.001;
    d.integrator = GS_INTEGRATOR_SYMPLECTIC_EULER;
    d.stability = GS_STABILITY_SUBSTEP;
    d.max_substeps = 64;
    d.safety = 0.9;
    d.cg_tolerance = 1e-6;
    d.cg_max_iterations = 200;
    d.max_speed = 1e4;
    d.substeps = 4;
    return d;
}

GS__PRIVATE gs_solver_desc gs__solver_defaults(gs_solver_desc d) {
    gs_solver_desc def = gs_solver_desc_default();
    if (d.dt == 0.0) d.dt = def.dt;
    if (d.integrator == GS_INTEGRATOR_DEFAULT) d.integrator = def.integrator;
    if (d.stability == GS_STABILITY_DEFAULT) d.stability = def.stability;
    if (d.max_substeps == 0) d.max_substeps = def.max_substeps;
    if (d.safety == 0.0) d.safety = def.safety;
    if (d.cg_tolerance == 0.0) d.cg_tolerance = def.cg_tolerance;
    if (d.cg_max_iterations == 0) d.cg_max_iterations = def.cg_max_iterations;
    if (d.max_speed == 0.0) d.max_speed = def.max_speed;
    if (d.substeps == 0) d.substeps = def.substeps;
    return d;
}

GS__PRIVATE void gs__check_solver(gs__check *c, const gs_solver_desc *d) {
    gs__check_dt(c, "solver.dt", d->dt);
    gs__check_int(c, "solver.integrator", (long)d->integrator, 1,
                  GS__INTEGRATOR_COUNT - 1);
    gs__check_int(c, "solver.stability", (long)d->stability, 1,
                  GS__STABILITY_COUNT - 1);
    gs__check_int(c, "solver.max_substeps", d->max_substeps, 1, 1L << 20);
    gs__check_positive(c, "solver.safety", d->safety);
    if (gs__finite(d->safety) && d->safety > 1.0)
        gs__check_fail(c, GS_ERR_INVALID_ARG,
                       "solver.safety is %g, must be in (0, 1]", d->safety);
    gs__check_positive(c, "solver.cg_tolerance", d->cg_tolerance);
    gs__check_int(c, "solver.cg_max_iterations", d->cg_max_iterations, 1,
                  1L << 24);
    gs__check_positive(c, "solver.max_speed", d->max_speed);
    gs__check_int(c, "solver.substeps", d->substeps, 1, 1L << 20);
}

GS_API gs_material gs_material_default(void) {
    gs_material m;
    m.stiffness = 1e5;
    m.damping = 100.0;
    m.friction = 0.5;
    return m;
}

/* Zero damping and zero friction are real choices, so only an all-zero
   material stands for the default one. */
GS__PRIVATE gs_material gs__material_defaults(gs_material m) {
    if (m.stiffness == 0.0 && m.damping == 0.0 && m.friction == 0.0)
        return gs_material_default();
    return m;
}

GS__PRIVATE void gs__check_material(gs__check *c, const gs_material *m) {
    gs__check_positive(c, "material.stiffness", m->stiffness);
    gs__check_nonneg(c, "material.damping", m->damping);
    gs__check_nonneg(c, "material.friction", m->friction);
}

/* Common part of every create call: fills the agent header, registers it. */
GS__PRIVATE gs_result gs__sync_relayout(gs_world *w);
GS__PRIVATE gs_result gs__sync_added(gs_world *w, gs_agent *a, gs_agent **out);

GS__PRIVATE gs_result gs__agent_init(gs_world *w, gs_agent *a,
                                     const gs__kind *kind, double dt) {
    memset(a, 0, sizeof *a);
    a->kind = kind;
    a->world = w;
    a->dt = dt;
    a->priority = w->queue_count / 2;
    a->behaviour = gs_behaviour_default;
    return gs__world_add(w, a);
}

GS_API double gs_agent_time(const gs_agent *a) { return gs__agent_time(a); }
GS_API double gs_agent_dt(const gs_agent *a) { return a->dt; }
GS_API gs_world *gs_agent_world(const gs_agent *a) { return a->world; }
GS_API const char *gs_agent_kind(const gs_agent *a) { return a->kind->name; }
GS_API gs_result gs_agent_result(const gs_agent *a) { return a->result; }
GS_API int gs_agent_priority(const gs_agent *a) { return a->priority; }
GS_API gs_result gs_agent_get_stats(const gs_agent *a, gs_agent_stats *out) {
    if (!a || !out) return GS_ERR_INVALID_ARG;
    *out = a->stats;
    return GS_OK;
}

GS_API int gs_agent_sleeping(const gs_agent *a) { return a && a->sleeping; }

GS_API gs_result gs_agent_wake(gs_agent *a) {
    gs_result r = gs__world_unlocked(a ? a->world : NULL, "gs_agent_wake");
    if (r != GS_OK) return r;
    gs__agent_wake_at(a, gs__agent_time(a));
    a->rest = 0.0;
    return GS_OK;
}

GS_API size_t gs_agent_state_size(const gs_agent *a) {
    return 1 + a->kind->state_size(a);
}

GS_API gs_result gs_agent_get_state(const gs_agent *a, double *out,
                                    size_t n) {
    if (!a) return GS_ERR_INVALID_ARG;
    if (n != gs_agent_state_size(a))
        return gs__fail(a->world, GS_ERR_SIZE_MISMATCH,
                        "gs_agent_get_state: n is %lu, the state has %lu",
                        (unsigned long)n,
                        (unsigned long)gs_agent_state_size(a));
    if (!out)
        return gs__fail(a->world, GS_ERR_INVALID_ARG,
                        "gs_agent_get_state: out is NULL");
    out[0] = gs__agent_time(a);
    a->kind->get_state(a, out + 1);
    return GS_OK;
}

/* Sets a state already checked: right size, every value finite. */
GS__PRIVATE gs_result gs__agent_put_state(gs_agent *a, const double *in) {
    gs_result r = a->kind->set_state(a, in + 1);
    if (r != GS_OK) return r;
    gs__agent_wake_at(a, gs__agent_time(a)); /* a state set moves it */
    a->t_offset = in[0] - (double)a->steps * a->dt;
    gs__span_update(a);
    return GS_OK;
}

GS__PRIVATE void gs__sync_log(gs_agent *a, const double *in);
GS__PRIVATE void gs__sync_sighted(gs_agent *a);

GS_API gs_result gs_agent_set_state(gs_agent *a, const double *in, size_t n) {
    size_t i;
    gs_result r = gs__world_unlocked(a ? a->world : NULL, "gs_agent_set_state");
    if (r != GS_OK) return r;
    if (n != gs_agent_state_size(a))
        return gs__fail(a->world, GS_ERR_SIZE_MISMATCH,
                        "gs_agent_set_state: n is %lu, the state has %lu",
                        (unsigned long)n,
                        (unsigned long)gs_agent_state_size(a));
    if (!in)
        return gs__fail(a->world, GS_ERR_INVALID_ARG,
                        "gs_agent_set_state: in is NULL");
    for (i = 0; i < n; ++i)
        if (!gs__finite(in[i]))
            return gs__fail(a->world, GS_ERR_NOT_FINITE,
                            "gs_agent_set_state: element %lu is %g",
                            (unsigned long)i, in[i]);
    if (in[0] < 0.0 || in[0] > GS_WIRE_MAX_TIME)
        return gs__fail(a->world, GS_ERR_INVALID_ARG,
                        "gs_agent_set_state: time is %g s, must be in [0, "
                        "GS_WIRE_MAX_TIME = %g]", in[0], GS_WIRE_MAX_TIME);
    r = gs__agent_put_state(a, in);
    if (r == GS_OK) {
        gs__sync_log(a, in);
        gs__sync_sighted(a); /* as a re-run, which applies it as a blend */
    }
    return r;
}

GS_API gs_result gs_agent_step(gs_agent *a) {
    gs_result r = gs__world_unlocked(a ? a->world : NULL, "gs_agent_step");
    if (r != GS_OK) return r;
    a->world->epoch++; /* one call is one advance for the correction bound */
    gs__agent_wake_at(a, gs__agent_time(a));
    a->world->inside++; /* its step, ghost and weight rules are user code */
    r = gs__agent_step(a);
    if (r == GS_OK) a->world->hooks.stepped(a);
    a->world->inside--;
    return r;
}

GS_API void gs_agent_set_priority(gs_agent *a, int priority) {
    int p = gs__clamp_priority(a->world, priority);
    if (a->queued) {
        gs__queue_remove(a->world, a);
        a->priority = p;
        gs__queue_push(a->world, a);
    } else {
        a->priority = p;
    }
}

GS_API void gs_agent_set_behaviour(gs_agent *a, gs_behaviour_fn fn,
                                   void *user) {
    a->behaviour = fn ? fn : gs_behaviour_default;
    a->behaviour_user = fn ? user : NULL;
}

GS__PRIVATE void gs__agent_unlink(gs_agent *a);

GS_API gs_result gs_agent_destroy(gs_agent *a) {
    gs_world *w = a ? a->world : NULL;
    int i;
    gs_result r = gs__world_unlocked(w, "gs_agent_destroy");
    if (r != GS_OK) return r;
    if (a->ghost) gs_ghost_detach(a);
    gs__agent_unlink(a);
    w->meshes_dirty = 1;
    for (i = a->index + 1; i < w->agent_count; ++i) {
        w->agents[i - 1] = w->agents[i];
        w->agents[i - 1]->index = i - 1;
    }
    w->agent_count--;
    gs__free(w, a);
    gs__sync_relayout(w);
    return GS_OK;
}

/* ---- custom agents: the user's own state behind the same interface ---- */
typedef struct gs__custom {
    gs_agent base;
    gs_custom_desc d;
    double *scratch; /* state_size doubles, for hashing and checking */
    double *before;  /* state_size doubles: the state before a step */
} gs__custom;

GS__PRIVATE uint32_t gs__agent_object(const gs_agent *a);

/* The user's step, held to the NUMBERS promise like a built-in one: a
   state with a NaN or infinity after it is replaced by the one before. */
GS__PRIVATE gs_result gs__custom_step(gs_agent *a, double dt) {
    gs__custom *c = (gs__custom *)a;
    size_t n = c->d.state_size, i;
    gs_result r;
    a->world->inside++; /* the user's callbacks run inside */
    if (n) c->d.get_state(c->d.user, c->before);
    r = c->d.step(c->d.user, gs__agent_time(a), dt);
    if (r == GS_OK && n) c->d.get_state(c->d.user, c->scratch);
    a->world->inside--;
    if (r != GS_OK) { /* the user's code said no: say who and when */
        char label[40] = "";
        if (gs__agent_object(a))
            snprintf(label, sizeof label, " (object %lu)", (unsigned long)gs__agent_object(a));
        return gs__fail(a->world, r, "custom agent %d%s: its step from t = %.9g s by %g s "
                        "returned %d (%s); the agent stays at t = %.9g s and is tried "
                        "again at the next advance", a->index, label, gs__agent_time(a), dt,
                        (int)r, gs_result_str(r), gs__agent_time(a));
    }
    if (n == 0) return r;
    for (i = 0; i < n; ++i)
        if (!gs__finite(c->scratch[i])) break;
    if (i == n) return GS_OK;
    a->world->inside++;
    r = c->d.set_state(c->d.user, c->before);
    a->world->inside--;
    return gs__fail(a->world, GS_ERR_UNSTABLE,
                    "custom agent %d: its step of %g s left element %lu at %g; "
                    "%s", a->index, dt, (unsigned long)(i + 1), c->scratch[i],
                    r == GS_OK ? "the state before the step was put back"
                               : "and its set_state refused the state before "
                                 "the step");
}
GS__PRIVATE size_t gs__custom_state_size(const gs_agent *a) {
    return ((const gs__custom *)a)->d.state_size;
}
/* The user's get_state, with the world's guard up (a const agent: the
   world is the agent's, never const). */
GS__PRIVATE void gs__custom_get(const gs__custom *c, double *out) {
    gs_world *w = c->base.world;
    w->inside++;
    c->d.get_state(c->d.user, out);
    w->inside--;
}
GS__PRIVATE void gs__custom_get_state(const gs_agent *a, double *out) {
    const gs__custom *c = (const gs__custom *)a;
    if (c->d.state_size) gs__custom_get(c, out);
}
GS__PRIVATE gs_result gs__custom_set_state(gs_agent *a, const double *in) {
    gs__custom *c = (gs__custom *)a;
    gs_result r;
    if (!c->d.state_size) return GS_OK;
    a->world->inside++;
    r = c->d.set_state(c->d.user, in);
    a->world->inside--;
    return r;
}
/* Hashes the user's state through a scratch copy made at create time. */
GS__PRIVATE uint64_t gs__custom_hash(const gs_agent *a, uint64_t h) {
    const gs__custom *c = (const gs__custom *)a;
    if (c->d.state_size == 0) return h;
    gs__custom_get(c, c->scratch);
    return gs__fnv(h, c->scratch, c->d.state_size * sizeof(double));
}

static const gs__kind gs__custom_kind = {
    "custom", gs__custom_step, gs__custom_state_size, gs__custom_get_state,
    gs__custom_set_state, gs__custom_hash, NULL, NULL};

/* Refuses a NULL world or out, and any call while the world advances. */
GS__PRIVATE gs_result gs__create_begin(gs_world *w, const void *desc,
                                       gs_agent **out, const char *who) {
    gs_result r = gs__world_unlocked(w, who);
    if (out) *out = NULL;
    if (r != GS_OK) return r;
    if (!desc || !out)
        return gs__fail(w, GS_ERR_INVALID_ARG, "%s: desc and out are required",
                        who);
    return GS_OK;
}

GS_API gs_custom_desc gs_custom_desc_default(void) {
    gs_custom_desc d;
    memset(&d, 0, sizeof d);
    d.dt = 0.001;
    return d;
}

GS_API gs_result gs_custom_create(gs_world *w, const gs_custom_desc *in,
                                  gs_agent **out) {
    gs__check c;
    gs__custom *a;
    size_t bytes = 0;
    gs_custom_desc dd;
    const gs_custom_desc *desc = &dd;
    gs_result r = gs__create_begin(w, in, out, "gs_custom_create");
    if (r != GS_OK) return r;
    dd = *in;
    if (dd.dt == 0.0) dd.dt = gs_custom_desc_default().dt;
    c = gs__check_begin(w, "gs_custom_create");
    gs__check_dt(&c, "dt", desc->dt);
    if (!desc->step) gs__check_fail(&c, GS_ERR_INVALID_ARG, "step is NULL");
    if (desc->state_size && (!desc->get_state || !desc->set_state))
        gs__check_fail(&c, GS_ERR_INVALID_ARG,
                       "state_size is %lu but get_state or set_state is NULL",
                       (unsigned long)desc->state_size);
    /* bytes = sizeof *a + 16 * state_size (the state and the copy a step
       is checked against); the state with its time, 1 + state_size
       doubles, fits in size_t then too */
    if (c.r == GS_OK && !gs__size(desc->state_size, 2 * sizeof(double), sizeof *a, &bytes))
        gs__check_fail(&c, GS_ERR_OUT_OF_RANGE,
                       "state_size is %lu: its bytes do not fit in size_t",
                       (unsigned long)desc->state_size);
    if (c.r != GS_OK) return c.r;
    a = (gs__custom *)gs__alloc(w, bytes);
    if (!a)
        return gs__fail(w, GS_ERR_NO_MEMORY, "gs_custom_create: out of memory");
    r = gs__agent_init(w, &a->base, &gs__custom_kind, desc->dt);
    if (r != GS_OK) {
        gs__free(w, a);
        return r;
    }
    a->d = *desc;
    a->scratch = (double *)(a + 1);
    a->before = a->scratch + desc->state_size;
    return gs__sync_added(w, &a->base, out);
}

/* ========================================================================
   >>cloth
   Spring-mass agents. Every integrator reads (x, v) and writes (xn, vn);
   the buffers swap only when the new state passed the sanity check, so a
   failed step leaves the agent exactly as it was at no copying cost.
   ======================================================================== */
typedef struct gs__spring {
    int a, b;
    double rest, k, c; /* m, N/m, N s/m */
} gs__spring;

/* Particles per box of the particle-vs-body broad phase: a sixteenth of
   a 128 x 128 cloth's row, about the size of the scene's spheres. */
#define GS__CHUNK 16
#define GS__MESH_BATCHES 65 /* 64 conflict-free colours, then the rest */
#if defined(__SSE2__) && !defined(GHOSTSIM_NO_SIMD)
#define GS__MESH_SSE2 1
#include <emmintrin.h>
/* Four wide where the CPU has AVX (asked at creation), whatever -m flags
   the user builds with; IEEE sqrt, division, products and sums give the
   same bits at any width. */
#if (defined(__GNUC__) || defined(__clang__)) && (defined(__x86_64__) || defined(__i386__))
#define GS__MESH_AVX 1
#include <immintrin.h>
#endif
#endif

/* The distance between the rows of a transposed copy, in doubles: past n,
   and never a multiple of 4 KiB, where nine rows would share cache sets
   and every store would wait (18 ns a particle at n = 4096, measured). */
GS__PRIVATE size_t gs__soa_stride(size_t n) {
    size_t s = ((n + 7) & ~(size_t)7) + 8;
    return s % 512 == 0 ? s + 8 : s;
}

typedef struct gs__run {
    int s0, a0, off, len; /* springs s0.., particles a0.. and a0 + off.. */
} gs__run;

/* One block of the XPBD pass: four springs, or one (GS__XB_ONE), or the
   one to three at the end of a segment (GS__XB_TAIL: SPAN's layout, its
   lanes past `lanes` left out), whose ends lie in the transposed copy as
   `kind` says (gs__xblk_lane). */
enum { GS__XB_SPAN, GS__XB_PAIRS, GS__XB_DUOS, GS__XB_ONE, GS__XB_GATHER, GS__XB_TAIL };
struct gs__xblk {
    int kind, a, b, s; /* first end a, first end b, first k/c/rest in xsp */
    int count;         /* blocks of four in a row, each next to the last */
    int lanes;         /* springs a block: 4, ONE 1, TAIL 1..3, GATHER 1..4 (its
                          ends in xgi from b: a0 b0 a1 b1 ..) */
    int uni;           /* every lane has the same k, c, rest (a cloth's
                          family): the kernel holds them in registers */
};

typedef struct gs__mesh {
    gs_agent base;
    int n, ns, npins;
    int row;          /* a cloth: particles per grid row (nx); 0 else */
    gs_vec3 *x, *v;   /* the state */
    gs_vec3 *xn, *vn; /* the next state */
    gs_vec3 *x0, *v0; /* the state before a substepped step, to undo it */
    gs_vec3 *acc;     /* accelerations */
    double *sf;       /* N; per spring its force on end a, 3 each */
    /* Springs are ordered by colour: within one batch no two share a
       particle, so a batch's updates never wait on one another. The last
       batch (GS__MESH_SERIAL) takes what did not fit and may conflict. */
    /* Symplectic Euler on a mesh whose springs come in runs (spring s0 + j
       joins particles a0 + j and a0 + j + off, as a cloth's families do)
       works on a transposed copy of the state, so that both ends of a
       run's springs are contiguous loads: r* are the runs (0 = none), s*
       the copy (x y z, vx vy vz, ax ay az, n each), sp* the springs'
       k, c, rest and force on end a (x y z), ns each. */
    gs__run *runs;
    int nruns;
    int avx;          /* the CPU runs AVX: the runs go four wide */
    int checked;      /* the integrator ran gs__mesh_sane's checks itself */
    int check_ok;     /* and their outcome (lo, hi already set if 1) */
    double *soa, *sp_soa;
    /* XPBD on a mesh with runs: the pass goes block by block over a
       transposed copy (soa: x y z, then the substep's start x y z), each
       block four springs that share no particle, their k, c, rest in xsp
       in block order (see gs__xpbd_schedule). */
    struct gs__xblk *xblk;
    int nxblk;
    /* The end of one XPBD substep also predicts the next (pred_next, set
       by gs__mesh_step), so the next one starts from the copy
       (pred_ready) instead of reading the state again: within a step
       nothing but contacts and pins acts between substeps, and those
       particles are predicted again from the state. */
    int pred_next, pred_ready;
    double *xsp;
    int *xgi;         /* GATHER blocks' ends: a0 b0 a1 b1 .. per lane */
    int nbatch;
    int batch[GS__MESH_BATCHES + 1]; /* first spring of each batch, then ns */
    uint64_t *colours; /* per particle, the colours of its springs (build) */
    int *perm;         /* per spring, its place in colour order (build) */
    gs_vec3 *tx, *tv, *sx, *sv; /* RK4 stages, Verlet half-step velocity */
    double *mass, *inv_mass; /* kg, 1/kg (0 for pinned particles) */
    gs__spring *springs;
    int *pins;
    unsigned char *pinned;
    double air;       /* 1/s */
    gs_solver_desc solver;
    double stable_dt; /* s; the explicit integrator's bound */
    double omega2;    /* 1/s^2; the highest omega^2 of the springs by power
                         iteration, 0 = not converged (Gershgorin is used) */
    double gamma;     /* 1/s; the springs' damping rate of that mode */
    double stable_dt_contact; /* s; the same with a contact on every particle */
    /* contacts */
    gs_vec3 *ext;     /* N; contact force on each particle this substep */
    gs_vec3 *cn;      /* implicit Euler: contact normal per particle, */
    double *ck, *cc;  /* its stiffness (N/m) and damping (N s/m), 0 = none */
    double *cdepth;   /* XPBD: the deepest contact's depth (m) at x, */
    gs_vec3 *cvel;    /* and the velocity of what it touches (m/s) */
    gs_vec3 *clo, *chi; /* m; boxes of GS__CHUNK particles each, of x */
    double *cvm;      /* m/s; the largest velocity component in each box */
    int chunks_ok;    /* the boxes are those of x and v (gs__mesh_chunks) */
    int chunks_next;  /* the integrator left the boxes of xn and vn there */
    int ext_active;   /* ext holds a non-zero force */
    /* The particles a contact touched this substep, each once (tmark): a
       substep clears and visits those, not the whole cloth (clearing ext
       and ck for 16 384 particles was 6% of a 2-host scene's work). */
    int *touched, ntouched;
    unsigned char *tmark;
    int probe_touch;  /* in this step a probe that moves touched it: it
                         does not rest (gs__mesh_rest) */
    double radius;    /* m, particle radius for contacts */
    gs_material mat;
    gs_vec3 lo, hi;   /* m; bounding box of the particles */
    /* implicit Euler: per spring u, h^2 k alpha, h^2 k (1 - alpha), h c */
    double *jac;
    gs_vec3 *rhs, *dv, *r, *z, *p, *q, *diag;
    uint64_t cg_iterations;
} gs__mesh;

/* ---- memory: one block per mesh, carved twice (measure, then place) ---- */
typedef struct gs__carver {
    char *base;
    size_t used;
} gs__carver;

/* count * size, or SIZE_MAX when that does not fit (32-bit size_t: a
   4096 x 4096 cloth's spring Jacobians alone are 4.8 GB). */
GS__PRIVATE size_t gs__mul_sat(size_t count, size_t size) {
    return size && count > SIZE_MAX / size ? SIZE_MAX : count * size;
}

/* A layout that would not fit in size_t saturates at SIZE_MAX, which no
   allocator gives: the create call fails as out of memory. */
GS__PRIVATE void *gs__carve(gs__carver *cv, size_t bytes) {
    void *p = cv->base ? (void *)(cv->base + cv->used) : NULL;
    if (bytes > SIZE_MAX - 15 || cv->used > SIZE_MAX - ((bytes + 15) & ~(size_t)15))
        cv->used = SIZE_MAX;
    else
        cv->used += (bytes + 15) & ~(size_t)15;
    return p;
}

GS__PRIVATE void gs__mesh_layout(gs__mesh *m, gs__carver *cv) {
    size_t n = (size_t)m->n, v3 = n * sizeof(gs_vec3);
    gs_integrator it = m->solver.integrator;
    m->x = (gs_vec3 *)gs__carve(cv, v3);
    m->v = (gs_vec3 *)gs__carve(cv, v3);
    m->xn = (gs_vec3 *)gs__carve(cv, v3);
    m->vn = (gs_vec3 *)gs__carve(cv, v3);
    m->acc = (gs_vec3 *)gs__carve(cv, v3);
    m->sf = (double *)gs__carve(cv, (size_t)m->ns * 3 * sizeof(double));
    m->colours = (uint64_t *)gs__carve(cv, n * sizeof(uint64_t));
    if (it == GS_INTEGRATOR_XPBD) {
        m->runs = (gs__run *)gs__carve(cv, (size_t)m->ns * sizeof(gs__run));
        m->soa = (double *)gs__carve(cv, 6 * gs__soa_stride(n) * sizeof(double));
        m->xblk = (struct gs__xblk *)gs__carve(cv, gs__mul_sat((size_t)m->ns, sizeof(struct gs__xblk)));
        m->xsp = (double *)gs__carve(cv, gs__mul_sat(gs__soa_stride((size_t)m->ns), 3 * sizeof(double)));
        m->xgi = (int *)gs__carve(cv, gs__mul_sat((size_t)m->ns, 2 * sizeof(int)));
    }
    if (it == GS_INTEGRATOR_SYMPLECTIC_EULER) {
        m->runs = (gs__run *)gs__carve(cv, (size_t)m->ns * sizeof(gs__run));
        m->soa = (double *)gs__carve(cv, 9 * gs__soa_stride(n) * sizeof(double));
        m->sp_soa = (double *)gs__carve(cv, gs__soa_stride((size_t)m->ns) * 3 * sizeof(double));
    }
    m->perm = (int *)gs__carve(cv, (size_t)m->ns * sizeof(int));
    m->ext = (gs_vec3 *)gs__carve(cv, v3);
    m->touched = (int *)gs__carve(cv, n * sizeof(int));
    m->tmark = (unsigned char *)gs__carve(cv, n);
    m->clo = (gs_vec3 *)gs__carve(cv, (n / GS__CHUNK + 1) * sizeof(gs_vec3));
    m->chi = (gs_vec3 *)gs__carve(cv, (n / GS__CHUNK + 1) * sizeof(gs_vec3));
    m->cvm = (double *)gs__carve(cv, (n / GS__CHUNK + 1) * sizeof(double));
    m->mass = (double *)gs__carve(cv, n * sizeof(double));
    m->inv_mass = (double *)gs__carve(cv, n * sizeof(double));
    m->springs = (gs__spring *)gs__carve(cv, gs__mul_sat((size_t)m->ns, sizeof(gs__spring)));
    m->pins = (int *)gs__carve(cv, (size_t)m->npins * sizeof(int));
    m->pinned = (unsigned char *)gs__carve(cv, n);
    if (it == GS_INTEGRATOR_XPBD || (it != GS_INTEGRATOR_IMPLICIT_EULER &&
                                     m->solver.stability != GS_STABILITY_UNCHECKED)) {
        m->x0 = (gs_vec3 *)gs__carve(cv, v3);
        m->v0 = (gs_vec3 *)gs__carve(cv, v3);
    }
    if (it == GS_INTEGRATOR_VERLET || it == GS_INTEGRATOR_RK4)
        m->tv = (gs_vec3 *)gs__carve(cv, v3);
    if (it == GS_INTEGRATOR_RK4) {
        m->tx = (gs_vec3 *)gs__carve(cv, v3);
        m->sx = (gs_vec3 *)gs__carve(cv, v3);
        m->sv = (gs_vec3 *)gs__carve(cv, v3);
    }
    if (it == GS_INTEGRATOR_XPBD) {
        m->cn = (gs_vec3 *)gs__carve(cv, v3);
        m->cvel = (gs_vec3 *)gs__carve(cv, v3);
        m->ck = (double *)gs__carve(cv, n * sizeof(double));
        m->cc = (double *)gs__carve(cv, n * sizeof(double));
        m->cdepth = (double *)gs__carve(cv, n * sizeof(double));
    }
    if (it == GS_INTEGRATOR_IMPLICIT_EULER) {
        m->jac = (double *)gs__carve(cv, gs__mul_sat((size_t)m->ns, 6 * sizeof(double)));
        m->cn = (gs_vec3 *)gs__carve(cv, v3);
        m->ck = (double *)gs__carve(cv, n * sizeof(double));
        m->cc = (double *)gs__carve(cv, n * sizeof(double));
        m->rhs = (gs_vec3 *)gs__carve(cv, v3);
        m->dv = (gs_vec3 *)gs__carve(cv, v3);
        m->r = (gs_vec3 *)gs__carve(cv, v3);
        m->z = (gs_vec3 *)gs__carve(cv, v3);
        m->p = (gs_vec3 *)gs__carve(cv, v3);
        m->q = (gs_vec3 *)gs__carve(cv, v3);
        m->diag = (gs_vec3 *)gs__carve(cv, v3);
    }
}

/* ---- forces ---- */

/* One spring's force on its end a (toward b): f u, u = d / l, f = k (l -
   rest) + c (v_b - v_a) . u; coincident ends (l = 0) have no direction and
   give no force. The SSE2 path below computes the same bits. */
GS__PRIVATE void gs__spring_force(const gs__spring *sp, const gs_vec3 *x,
                                  const gs_vec3 *v, double *fo) {
    const gs_vec3 *xa = &x[sp->a], *xb = &x[sp->b], *va = &v[sp->a], *vb = &v[sp->b];
    double dx = xb->x - xa->x, dy = xb->y - xa->y, dz = xb->z - xa->z;
    double l = sqrt(dx * dx + dy * dy + dz * dz);
    double il = l > 0.0 ? 1.0 / l : 0.0, ux = dx * il, uy = dy * il, uz = dz * il;
    double f = sp->k * (l - sp->rest) +
               sp->c * ((vb->x - va->x) * ux + (vb->y - va->y) * uy +
                        (vb->z - va->z) * uz);
    f = l > 0.0 ? f : 0.0;
    fo[0] = ux * f;
    fo[1] = uy * f;
    fo[2] = uz * f;
}

GS__PRIVATE void gs__spring_apply(const gs__spring *sp, const double *im,
                                  const double *f, gs_vec3 *acc) {
    double ia = im[sp->a], ib = im[sp->b];
    gs_vec3 *aa = &acc[sp->a], *ab = &acc[sp->b];
    aa->x += f[0] * ia; aa->y += f[1] * ia; aa->z += f[2] * ia;
    ab->x -= f[0] * ib; ab->y -= f[1] * ib; ab->z -= f[2] * ib;
}

#ifdef GS__MESH_SSE2
#define GS__LD2(p, q, f) _mm_loadh_pd(_mm_load_sd(&(p)->f), &(q)->f)
/* Two springs of one batch (no shared particle) at once: the sqrt and the
   division, which bound the plain loop, run two wide. */
GS__PRIVATE void gs__spring_force2(const gs__spring *s0, const gs__spring *s1,
                                   const gs_vec3 *x, const gs_vec3 *v,
                                   double *f0, double *f1) {
    const gs_vec3 *xa0 = &x[s0->a], *xb0 = &x[s0->b], *xa1 = &x[s1->a], *xb1 = &x[s1->b];
    const gs_vec3 *va0 = &v[s0->a], *vb0 = &v[s0->b], *va1 = &v[s1->a], *vb1 = &v[s1->b];
    __m128d dx = _mm_sub_pd(GS__LD2(xb0, xb1, x), GS__LD2(xa0, xa1, x));
    __m128d dy = _mm_sub_pd(GS__LD2(xb0, xb1, y), GS__LD2(xa0, xa1, y));
    __m128d dz = _mm_sub_pd(GS__LD2(xb0, xb1, z), GS__LD2(xa0, xa1, z));
    __m128d l = _mm_sqrt_pd(_mm_add_pd(_mm_add_pd(_mm_mul_pd(dx, dx), _mm_mul_pd(dy, dy)),
                                       _mm_mul_pd(dz, dz)));
    __m128d ok = _mm_cmpgt_pd(l, _mm_setzero_pd());
    __m128d il = _mm_and_pd(ok, _mm_div_pd(_mm_set1_pd(1.0), l));
    __m128d ux = _mm_mul_pd(dx, il), uy = _mm_mul_pd(dy, il), uz = _mm_mul_pd(dz, il);
    __m128d k = GS__LD2(s0, s1, k), c = GS__LD2(s0, s1, c), rest = GS__LD2(s0, s1, rest);
    __m128d w = _mm_add_pd(
        _mm_add_pd(_mm_mul_pd(_mm_sub_pd(GS__LD2(vb0, vb1, x), GS__LD2(va0, va1, x)), ux),
                   _mm_mul_pd(_mm_sub_pd(GS__LD2(vb0, vb1, y), GS__LD2(va0, va1, y)), uy)),
        _mm_mul_pd(_mm_sub_pd(GS__LD2(vb0, vb1, z), GS__LD2(va0, va1, z)), uz));
    __m128d f = _mm_and_pd(ok, _mm_add_pd(_mm_mul_pd(k, _mm_sub_pd(l, rest)), _mm_mul_pd(c, w)));
    __m128d fx = _mm_mul_pd(ux, f), fy = _mm_mul_pd(uy, f), fz = _mm_mul_pd(uz, f);
    _mm_storel_pd(&f0[0], fx); _mm_storeh_pd(&f1[0], fx);
    _mm_storel_pd(&f0[1], fy); _mm_storeh_pd(&f1[1], fy);
    _mm_storel_pd(&f0[2], fz); _mm_storeh_pd(&f1[2], fz);
}
#undef GS__LD2
#endif

/* acc += each spring's force / mass at (x, v), batch by batch. */
GS__PRIVATE void gs__mesh_springs(const gs__mesh *m, const gs_vec3 *x,
                                  const gs_vec3 *v, gs_vec3 *acc) {
    const gs__spring *sp = m->springs;
    const double *im = m->inv_mass;
    double f0[3];
    int b, i;
    for (b = 0; b < m->nbatch; ++b) {
        i = m->batch[b];
#ifdef GS__MESH_SSE2
        if (b < GS__MESH_BATCHES - 1)
            for (; i + 1 < m->batch[b + 1]; i += 2) {
                double f1[3];
                gs__spring_force2(&sp[i], &sp[i + 1], x, v, f0, f1);
                gs__spring_apply(&sp[i], im, f0, acc);
                gs__spring_apply(&sp[i + 1], im, f1, acc);
            }
#endif
        for (; i < m->batch[b + 1]; ++i) {
            gs__spring_force(&sp[i], x, v, f0);
            gs__spring_apply(&sp[i], im, f0, acc);
        }
    }
}

/* Accelerations at (x, v): gravity, air damping, springs with damping along
   the spring. Pinned particles get none. */
GS__PRIVATE void gs__mesh_accel(const gs__mesh *m, const gs_vec3 *x,
                                const gs_vec3 *v, gs_vec3 *acc) {
    gs_vec3 g = m->base.world->gravity;
    const double *im = m->inv_mass;
    int i;
    for (i = 0; i < m->n; ++i) acc[i] = gs__madd(g, v[i], -m->air);
    if (m->ext_active)
        for (i = 0; i < m->n; ++i) acc[i] = gs__madd(acc[i], m->ext[i], im[i]);
    gs__mesh_springs(m, x, v, acc);
    for (i = 0; i < m->npins; ++i) acc[m->pins[i]] = gs__v3(0.0, 0.0, 0.0);
}

/* ---- explicit integrators: (x, v) -> (xn, vn) over h seconds ---- */
GS__PRIVATE void gs__int_explicit_euler(gs__mesh *m, double h) {
    int i;
    gs__mesh_accel(m, m->x, m->v, m->acc);
    for (i = 0; i < m->n; ++i) {
        m->xn[i] = gs__madd(m->x[i], m->v[i], h);
        m->vn[i] = gs__madd(m->v[i], m->acc[i], h);
    }
}

/* ---- vector helpers of the cloth's paths (symplectic runs, XPBD) ---- */

#ifdef GS__MESH_AVX
/* The AVX-512VL copies give plain C's bits only if no product is fused
   into a sum: GCC fuses them wherever the target has FMA (AVX-512 has)
   unless -ffp-contract=off, and its default is "fast" in C++ and GNU C
   (g++ -std=c++11 and gcc -std=gnu99 put 141 FMAs into them: a host with
   AVX-512 drifted from one without; tests/test_kernel17.c builds so).
   Clang fuses only within one expression, which intrinsics never are. */
#if defined(__GNUC__) && !defined(__clang__)
#define GS__NOFUSE __attribute__((optimize("fp-contract=off")))
#else
#define GS__NOFUSE
#endif
/* Inlined whatever the optimizer thinks: out of line, each block's
   sixteen vectors go through memory (a third of the pass, measured). */
#define GS__XINLINE __attribute__((target("avx"), always_inline, unused)) static inline
/* The largest (smallest) of four lanes, as the scalar loop's comparisons
   take them (a NaN lane is dropped as there). */
GS__XINLINE double gs__hmax4(__m256d v) {
    double t[4], r;
    int q;
    _mm256_storeu_pd(t, v);
    for (r = t[0], q = 1; q < 4; ++q) r = t[q] > r ? t[q] : r;
    return r;
}
GS__XINLINE double gs__hmin4(__m256d v) {
    double t[4], r;
    int q;
    _mm256_storeu_pd(t, v);
    for (r = t[0], q = 1; q < 4; ++q) r = t[q] < r ? t[q] : r;
    return r;
}

/* Four particles' x, y, z lanes as 12 doubles x0 y0 z0 x1 .. z3 at p. */
GS__XINLINE void gs__st_aos4(double *p, __m256d x, __m256d y, __m256d z) {
    __m256d t0 = _mm256_unpacklo_pd(x, y);          /* x0 y0 | x2 y2 */
    __m256d u = _mm256_shuffle_pd(z, x, 0xA);       /* z0 x1 | z2 x3 */
    __m256d w = _mm256_shuffle_pd(y, z, 0xF);       /* y1 z1 | y3 z3 */
    _mm256_storeu_pd(p, _mm256_permute2f128_pd(t0, u, 0x20));
    _mm256_storeu_pd(p + 4, _mm256_permute2f128_pd(w, t0, 0x30));
    _mm256_storeu_pd(p + 8, _mm256_permute2f128_pd(u, w, 0x31));
}

#endif

GS__PRIVATE void gs__int_symplectic_runs(gs__mesh *m, double h);

/* Finds the runs in spring order; 0 (the batched path) unless they average
   8 springs or more. Springs' k, c, rest go to the transposed copy. */
GS__PRIVATE void gs__mesh_find_runs(gs__mesh *m) {
    size_t ns = gs__soa_stride((size_t)m->ns);
    int i = 0, nr = 0;
    if (!m->runs || m->ns == 0) return;
    while (i < m->ns) {
        const gs__spring *s = &m->springs[i];
        int len = 1;
        while (i + len < m->ns && m->springs[i + len].a == s->a + len &&
               m->springs[i + len].b == s->b + len)
            ++len;
        m->runs[nr].s0 = i;
        m->runs[nr].a0 = s->a;
        m->runs[nr].off = s->b - s->a;
        m->runs[nr].len = len;
        ++nr;
        i += len;
    }
    m->nruns = m->ns >= 8 * nr ? nr : 0;
#ifdef GS__MESH_AVX
    m->avx = __builtin_cpu_supports("avx") ? 1 : 0;
    if (m->avx && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl")) m->avx = 2;
#endif
    if (!m->sp_soa) return;
    for (i = 0; i < m->ns; ++i) {
        m->sp_soa[i] = m->springs[i].k;
        m->sp_soa[ns + (size_t)i] = m->springs[i].c;
        m->sp_soa[2 * ns + (size_t)i] = m->springs[i].rest;
    }
}

GS__PRIVATE void gs__int_symplectic_euler(gs__mesh *m, double h) {
    int i;
    if (m->nruns > 0) {
        gs__int_symplectic_runs(m, h);
        return;
    }
    gs__mesh_accel(m, m->x, m->v, m->acc);
    for (i = 0; i < m->n; ++i) {
        m->vn[i] = gs__madd(m->v[i], m->acc[i], h);
        m->xn[i] = gs__madd(m->x[i], m->vn[i], h);
    }
}

/* Velocity Verlet; the damping forces see the half-step velocity. */
GS__PRIVATE void gs__int_verlet(gs__mesh *m, double h) {
    int i;
    gs__mesh_accel(m, m->x, m->v, m->acc);
    for (i = 0; i < m->n; ++i) {
        m->tv[i] = gs__madd(m->v[i], m->acc[i], 0.5 * h);
        m->xn[i] = gs__madd(m->x[i], m->tv[i], h);
    }
    gs__mesh_accel(m, m->xn, m->tv, m->acc);
    for (i = 0; i < m->n; ++i)
        m->vn[i] = gs__madd(m->tv[i], m->acc[i], 0.5 * h);
}

/* One inner RK4 stage: add the stage derivative (tv, acc) with weight 2 to
   the sums (sx, sv) and place the next stage point c * h along it. */
GS__PRIVATE void gs__rk4_stage(gs__mesh *m, double ch) {
    int i;
    for (i = 0; i < m->n; ++i) {
        m->sx[i] = gs__madd(m->sx[i], m->tv[i], 2.0);
        m->sv[i] = gs__madd(m->sv[i], m->acc[i], 2.0);
        m->tx[i] = gs__madd(m->x[i], m->tv[i], ch);
        m->tv[i] = gs__madd(m->v[i], m->acc[i], ch);
    }
}

GS__PRIVATE void gs__int_rk4(gs__mesh *m, double h) {
    int i;
    gs__mesh_accel(m, m->x, m->v, m->acc); /* k1 */
    for (i = 0; i < m->n; ++i) {
        m->sx[i] = m->v[i];
        m->sv[i] = m->acc[i];
        m->tx[i] = gs__madd(m->x[i], m->v[i], 0.5 * h);
        m->tv[i] = gs__madd(m->v[i], m->acc[i], 0.5 * h);
    }
    gs__mesh_accel(m, m->tx, m->tv, m->acc); /* k2 */
    gs__rk4_stage(m, 0.5 * h);
    gs__mesh_accel(m, m->tx, m->tv, m->acc); /* k3 */
    gs__rk4_stage(m, h);
    gs__mesh_accel(m, m->tx, m->tv, m->acc); /* k4 */
    for (i = 0; i < m->n; ++i) {
        m->xn[i] = gs__madd(m->x[i], gs__add(m->sx[i], m->tv[i]), h / 6.0);
        m->vn[i] = gs__madd(m->v[i], gs__add(m->sv[i], m->acc[i]), h / 6.0);
    }
}

/* Contact springs join the implicit solve: each touching particle gets
   (h^2 k + h c) n n^T on its diagonal block and -h^2 k (n . v0) n on the right,
   so stiff contacts are as stable as stiff cloth springs. */
GS__PRIVATE void gs__implicit_contacts(gs__mesh *m, double h) {
    int i;
    for (i = 0; i < m->n; ++i) {
        gs_vec3 n = m->cn[i];
        double s = h * h * m->ck[i] + h * m->cc[i];
        if (m->ck[i] == 0.0) continue;
        m->rhs[i] = gs__madd(m->rhs[i], n, -h * h * m->ck[i] * gs__dot(n, m->v[i]));
        m->diag[i] = gs__add(m->diag[i], gs__v3(s * n.x * n.x, s * n.y * n.y, s * n.z * n.z));
    }
}

/* ---- implicit Euler: Baraff & Witkin 1998, one linearized solve ----
   (M (1 + h air) + h D + h^2 K) dv = h f0 - h^2 K v0, with K each spring's
   stiffness matrix k (alpha I + (1 - alpha) u u^T), alpha =
   max(0, 1 - rest / l): the compressive part is dropped so that the matrix
   stays positive definite and CG applies; D = c u u^T. Pinned rows are
   filtered out. */
GS__PRIVATE void gs__implicit_assemble(gs__mesh *m, double h) {
    double md = 1.0 + h * m->air;
    int i;
    for (i = 0; i < m->n; ++i) {
        double d = m->mass[i] * md;
        m->rhs[i] = gs__scale(m->acc[i], h * m->mass[i]);
        m->diag[i] = gs__v3(d, d, d);
    }
    for (i = 0; i < m->ns; ++i) {
        const gs__spring *s = &m->springs[i];
        double *J = m->jac + 6 * i;
        gs_vec3 d = gs__sub(m->x[s->b], m->x[s->a]), u, w, kw;
        double l = gs__len(d), alpha, ka, kb, dc;
        memset(J, 0, 6 * sizeof *J);
        if (!(l > 0.0)) continue;
        u = gs__scale(d, 1.0 / l);
        alpha = 1.0 - s->rest / l;
        if (alpha < 0.0) alpha = 0.0;
        ka = h * h * s->k * alpha;
        kb = h * h * s->k * (1.0 - alpha);
        dc = h * s->c;
        J[0] = u.x; J[1] = u.y; J[2] = u.z; J[3] = ka; J[4] = kb; J[5] = dc;
        w = gs__sub(m->v[s->b], m->v[s->a]);
        kw = gs__madd(gs__scale(w, ka), u, kb * gs__dot(u, w));
        m->rhs[s->a] = gs__add(m->rhs[s->a], kw);
        m->rhs[s->b] = gs__sub(m->rhs[s->b], kw);
        kb += dc;
        m->diag[s->a] = gs__add(m->diag[s->a],
            gs__v3(ka + kb * u.x * u.x, ka + kb * u.y * u.y, ka + kb * u.z * u.z));
        m->diag[s->b] = gs__add(m->diag[s->b],
            gs__v3(ka + kb * u.x * u.x, ka + kb * u.y * u.y, ka + kb * u.z * u.z));
    }
    if (m->ext_active) gs__implicit_contacts(m, h);
    for (i = 0; i < m->npins; ++i) m->rhs[m->pins[i]] = gs__v3(0.0, 0.0, 0.0);
}

/* q = A p for the system above. */
GS__PRIVATE void gs__implicit_apply(const gs__mesh *m, double h,
                                    const gs_vec3 *p, gs_vec3 *q) {
    double md = 1.0 + h * m->air;
    int i;
    for (i = 0; i < m->n; ++i) q[i] = gs__scale(p[i], m->mass[i] * md);
    for (i = 0; i < m->ns; ++i) {
        const gs__spring *s = &m->springs[i];
        const double *J = m->jac + 6 * i;
        gs_vec3 u = gs__v3(J[0], J[1], J[2]);
        gs_vec3 w = gs__sub(p[s->b], p[s->a]);
        gs_vec3 bw = gs__madd(gs__scale(w, J[3]), u, (J[4] + J[5]) * gs__dot(u, w));
        q[s->a] = gs__sub(q[s->a], bw);
        q[s->b] = gs__add(q[s->b], bw);
    }
    if (m->ext_active)
        for (i = 0; i < m->n; ++i)
            if (m->ck[i] != 0.0)
                q[i] = gs__madd(q[i], m->cn[i], (h * h * m->ck[i] + h * m->cc[i]) *
                                                    gs__dot(m->cn[i], p[i]));
    for (i = 0; i < m->npins; ++i) q[m->pins[i]] = gs__v3(0.0, 0.0, 0.0);
}

GS__PRIVATE double gs__vdot(const gs_vec3 *a, const gs_vec3 *b, int n) {
    double s = 0.0;
    int i;
    for (i = 0; i < n; ++i) s += gs__dot(a[i], b[i]);
    return s;
}

/* z = r / diag (Jacobi preconditioner); returns r . z */
GS__PRIVATE double gs__precondition(gs__mesh *m) {
    double rz = 0.0;
    int i;
    for (i = 0; i < m->n; ++i) {
        m->z[i] = gs__v3(m->r[i].x / m->diag[i].x, m->r[i].y / m->diag[i].y,
                         m->r[i].z / m->diag[i].z);
        rz += gs__dot(m->r[i], m->z[i]);
    }
    return rz;
}

/* Preconditioned conjugate gradient for dv, to a relative residual of
   solver.cg_tolerance or solver.cg_max_iterations. */
GS__PRIVATE void gs__implicit_cg(gs__mesh *m, double h) {
    double bb = gs__vdot(m->rhs, m->rhs, m->n), tol2, rz;
    int it, i;
    memset(m->dv, 0, (size_t)m->n * sizeof *m->dv);
    if (!(bb > 0.0)) return;
    tol2 = m->solver.cg_tolerance * m->solver.cg_tolerance * bb;
    memcpy(m->r, m->rhs, (size_t)m->n * sizeof *m->r);
    rz = gs__precondition(m);
    memcpy(m->p, m->z, (size_t)m->n * sizeof *m->p);
    for (it = 0; it < m->solver.cg_max_iterations; ++it) {
        double pq, alpha, rz_next, beta;
        gs__implicit_apply(m, h, m->p, m->q);
        pq = gs__vdot(m->p, m->q, m->n);
        if (!(pq > 0.0)) break;
        alpha = rz / pq;
        for (i = 0; i < m->n; ++i) {
            m->dv[i] = gs__madd(m->dv[i], m->p[i], alpha);
            m->r[i] = gs__madd(m->r[i], m->q[i], -alpha);
        }
        m->cg_iterations++;
        if (gs__vdot(m->r, m->r, m->n) <= tol2) break;
        rz_next = gs__precondition(m);
        beta = rz_next / rz;
        rz = rz_next;
        for (i = 0; i < m->n; ++i) m->p[i] = gs__madd(m->z[i], m->p[i], beta);
    }
}

GS__PRIVATE void gs__int_implicit_euler(gs__mesh *m, double h) {
    int i;
    gs__mesh_accel(m, m->x, m->v, m->acc);
    gs__implicit_assemble(m, h);
    gs__implicit_cg(m, h);
    for (i = 0; i < m->n; ++i) {
        m->vn[i] = gs__add(m->v[i], m->dv[i]);
        m->xn[i] = gs__madd(m->x[i], m->vn[i], h);
    }
}

/* ---- XPBD (Macklin, Mueller, Chentanez 2016; small steps, Macklin et al.
   2019): predict with every force that is not a spring, then one pass that
   moves each spring's ends along it by dlambda, then v = (x_new - x) / h.
   For spring s with C = l - rest, compliance alpha = 1 / k and damping c
   (gamma = alpha~ beta~ / h with alpha~ = alpha / h^2, beta~ = h^2 c),
   XPBD's dlambda = -(C + gamma u . dx) / ((1 + gamma) W + alpha~), W = w_a +
   w_b, dx the ends' relative motion this substep. Multiplied through by
   k h^2 it needs no reciprocal of k: dlambda = -(k h^2 C + c h u . dx) /
   ((k h^2 + c h) W + 1), whose denominator is >= 1. With lambda from zero
   every substep, the pass is one Gauss-Seidel sweep batch by batch; in a
   batch the springs share no particle, so their order is free. Ends move by
   s d with s = dlambda / l, folded into one division:
   s = -(k h^2 (l^2 - rest l) + c h d . dx) / (l^2 ((k h^2 + c h) W + 1)).
   The ends' relative motion is d - e, e = p_b - p_a the spring at the
   substep's start, so d . dx = l^2 - d . e and the numerator regroups as
   (k h^2 rest) l + c h (d . e) - (k h^2 + c h) l^2, whose three products
   of constants are per spring and step: 43 operations for four springs
   instead of 50, the kernel's cost in cache. */
GS__PRIVATE void gs__xpbd_spring(const gs__spring *sp, const double *im,
                                 const gs_vec3 *x, gs_vec3 *xn, double h) {
    gs_vec3 *pa = &xn[sp->a], *pb = &xn[sp->b];
    const gs_vec3 *qa = &x[sp->a], *qb = &x[sp->b];
    double dx = pb->x - pa->x, dy = pb->y - pa->y, dz = pb->z - pa->z;
    double l2 = dx * dx + dy * dy + dz * dz, l = sqrt(l2);
    double kh = sp->k * h * h, ch = sp->c * h, kc = kh + ch, kr = kh * sp->rest;
    double wa = im[sp->a], wb = im[sp->b];
    double ex = qb->x - qa->x, ey = qb->y - qa->y, ez = qb->z - qa->z;
    double num = (kr * l + ch * ((dx * ex + dy * ey) + dz * ez)) - kc * l2;
    double den = l2 * (kc * (wa + wb) + 1.0);
    double s = den > 0.0 ? num / den : 0.0;
    pa->x -= wa * s * dx; pa->y -= wa * s * dy; pa->z -= wa * s * dz;
    pb->x += wb * s * dx; pb->y += wb * s * dy; pb->z += wb * s * dz;
}

#ifdef GS__MESH_SSE2
#define GS__LD2(p, q, f) _mm_loadh_pd(_mm_load_sd(&(p)->f), &(q)->f)
#define GS__ST2(p, q, f, v) (_mm_storel_pd(&(p)->f, v), _mm_storeh_pd(&(q)->f, v))
/* gs__xpbd_spring for two springs of one batch at once, the same bits. */
GS__PRIVATE void gs__xpbd_spring2(const gs__spring *s0, const gs__spring *s1,
                                  const double *im, const gs_vec3 *x, gs_vec3 *xn,
                                  __m128d hh, __m128d h) {
    gs_vec3 *pa0 = &xn[s0->a], *pb0 = &xn[s0->b], *pa1 = &xn[s1->a], *pb1 = &xn[s1->b];
    const gs_vec3 *qa0 = &x[s0->a], *qb0 = &x[s0->b], *qa1 = &x[s1->a], *qb1 = &x[s1->b];
    __m128d ax = GS__LD2(pa0, pa1, x), ay = GS__LD2(pa0, pa1, y), az = GS__LD2(pa0, pa1, z);
    __m128d bx = GS__LD2(pb0, pb1, x), by = GS__LD2(pb0, pb1, y), bz = GS__LD2(pb0, pb1, z);
    __m128d dx = _mm_sub_pd(bx, ax), dy = _mm_sub_pd(by, ay), dz = _mm_sub_pd(bz, az);
    __m128d l2 = _mm_add_pd(_mm_add_pd(_mm_mul_pd(dx, dx), _mm_mul_pd(dy, dy)), _mm_mul_pd(dz, dz));
    __m128d l = _mm_sqrt_pd(l2);
    __m128d kh = _mm_mul_pd(_mm_mul_pd(GS__LD2(s0, s1, k), h), h);
    __m128d ch = _mm_mul_pd(GS__LD2(s0, s1, c), h);
    __m128d kc = _mm_add_pd(kh, ch), kr = _mm_mul_pd(kh, GS__LD2(s0, s1, rest));
    __m128d wa = _mm_loadh_pd(_mm_load_sd(&im[s0->a]), &im[s1->a]);
    __m128d wb = _mm_loadh_pd(_mm_load_sd(&im[s0->b]), &im[s1->b]);
    __m128d ex = _mm_sub_pd(GS__LD2(qb0, qb1, x), GS__LD2(qa0, qa1, x));
    __m128d ey = _mm_sub_pd(GS__LD2(qb0, qb1, y), GS__LD2(qa0, qa1, y));
    __m128d ez = _mm_sub_pd(GS__LD2(qb0, qb1, z), GS__LD2(qa0, qa1, z));
    __m128d de = _mm_add_pd(_mm_add_pd(_mm_mul_pd(dx, ex), _mm_mul_pd(dy, ey)), _mm_mul_pd(dz, ez));
    __m128d num = _mm_sub_pd(_mm_add_pd(_mm_mul_pd(kr, l), _mm_mul_pd(ch, de)), _mm_mul_pd(kc, l2));
    __m128d den = _mm_mul_pd(l2, _mm_add_pd(_mm_mul_pd(kc, _mm_add_pd(wa, wb)), _mm_set1_pd(1.0)));
    __m128d sa, sb, s = _mm_and_pd(_mm_cmpgt_pd(den, _mm_setzero_pd()), _mm_div_pd(num, den));
    (void)hh;
    sa = _mm_mul_pd(wa, s);
    sb = _mm_mul_pd(wb, s);
    GS__ST2(pa0, pa1, x, _mm_sub_pd(ax, _mm_mul_pd(sa, dx)));
    GS__ST2(pa0, pa1, y, _mm_sub_pd(ay, _mm_mul_pd(sa, dy)));
    GS__ST2(pa0, pa1, z, _mm_sub_pd(az, _mm_mul_pd(sa, dz)));
    GS__ST2(pb0, pb1, x, _mm_add_pd(bx, _mm_mul_pd(sb, dx)));
    GS__ST2(pb0, pb1, y, _mm_add_pd(by, _mm_mul_pd(sb, dy)));
    GS__ST2(pb0, pb1, z, _mm_add_pd(bz, _mm_mul_pd(sb, dz)));
}
#undef GS__LD2
#undef GS__ST2
#endif

/* One constraint pass, batch by batch. */
GS__PRIVATE void gs__xpbd_pass(gs__mesh *m, double h) {
    const gs__spring *sp = m->springs;
    int b, i;
    for (b = 0; b < m->nbatch; ++b) {
        i = m->batch[b];
#ifdef GS__MESH_SSE2
        if (b < GS__MESH_BATCHES - 1)
            for (; i + 1 < m->batch[b + 1]; i += 2)
                gs__xpbd_spring2(&sp[i], &sp[i + 1], m->inv_mass, m->x, m->xn,
                                 _mm_set1_pd(h * h), _mm_set1_pd(h));
#endif
        for (; i < m->batch[b + 1]; ++i)
            gs__xpbd_spring(&sp[i], m->inv_mass, m->x, m->xn, h);
    }
}

/* ---- XPBD over runs (see gs__mesh.xblk) ----
   The pass takes the springs run by run in creation order, and within a
   run as two colours: a run of offset `off` (spring j joins a0 + j and a0
   + j + off) shares no particle among any `off` springs in a row, so it
   goes in segments of `off` springs, four at a time (GS__XB_SPAN), even
   segments first, then odd ones. (A sweep of the segments in order, as
   valid a Gauss-Seidel order on paper, carries one pass's correction from
   the pinned edge through the whole cloth: a 128 x 128 cloth gains energy
   under it and fails the sanity check within 200 steps.) Runs of
   offset 1 and 2 (a row's neighbours and bend springs) would be serial:
   they go even springs then odd ones (GS__XB_PAIRS: ends a + 2q and a +
   2q + 1 for q = 0..3), and pairs of pairs (GS__XB_DUOS: ends a, a + 1, a
   + 4, a + 5 and two further), so a block still shares nothing. Every lane
   does gs__xpbd_spring's operations in its order, so the AVX and scalar
   kernels give the same bits. */

/* Where lane q of block t of entry k has its ends: blocks of a SPAN
   follow each other by four particles, of PAIRS and DUOS by eight. */
GS__PRIVATE void gs__xblk_lane(const gs__mesh *m, const struct gs__xblk *k, int t, int q,
                               int *a, int *b) {
    static const int pairs[4] = {0, 4, 2, 6}, duos[4] = {0, 1, 4, 5};
    switch (k->kind) {
    case GS__XB_GATHER: *a = m->xgi[k->b + 2 * q]; *b = m->xgi[k->b + 2 * q + 1]; break;
    case GS__XB_PAIRS: *a = k->a + 8 * t + pairs[q]; *b = *a + 1; break;
    case GS__XB_DUOS: *a = k->a + 8 * t + duos[q]; *b = *a + 2; break;
    default: *a = k->a + 4 * t + q; *b = k->b + 4 * t + q; break;
    }
}

/* Appends a block whose lanes are springs s[0..lanes - 1]. */
GS__PRIVATE void gs__xpbd_block(gs__mesh *m, int kind, int a, int b, const int *s, int lanes) {
    size_t ns = gs__soa_stride((size_t)m->ns);
    struct gs__xblk *k = &m->xblk[m->nxblk++];
    int q, at = k == m->xblk ? 0 : k[-1].s + k[-1].lanes;
    k->kind = kind; k->a = a; k->b = b; k->s = at; k->count = 1; k->lanes = lanes;
    for (q = 0; q < lanes; ++q) {
        const gs__spring *sp = &m->springs[s[q]];
        m->xsp[at + q] = sp->k;
        m->xsp[ns + (size_t)(at + q)] = sp->c;
        m->xsp[2 * ns + (size_t)(at + q)] = sp->rest;
    }
}

/* Springs s0 + j, j = j0..j1 - 1, of run u: in fours with ends
   contiguous (SPAN), then the rest as one TAIL block (one by one where
   the run is serial, j1 = j0 + 1: ONE). */
GS__PRIVATE void gs__xpbd_span(gs__mesh *m, const gs__run *u, int j0, int j1) {
    int j = j0, s[4], q;
    for (; j + 3 < j1; j += 4) {
        for (q = 0; q < 4; ++q) s[q] = u->s0 + j + q;
        gs__xpbd_block(m, GS__XB_SPAN, u->a0 + j, u->a0 + u->off + j, s, 4);
    }
    if (j == j1) return;
    for (q = 0; j + q < j1; ++q) s[q] = u->s0 + j + q;
    gs__xpbd_block(m, j1 - j0 == 1 ? GS__XB_ONE : GS__XB_TAIL, u->a0 + j, u->a0 + u->off + j, s, q);
}

/* Offset 1 or 2: the springs of one parity class (cls = 0, 1) of run u. */
GS__PRIVATE void gs__xpbd_parity(gs__mesh *m, const gs__run *u, int cls) {
    int off = u->off, per = 2 * off, last = off == 1 ? 6 : 5, j, q, s[4], a, b;
    for (j = cls * off; j + last < u->len; j += 8) { /* eight particles a block */
        struct gs__xblk probe;
        probe.kind = off == 1 ? GS__XB_PAIRS : GS__XB_DUOS;
        probe.a = u->a0 + j;
        probe.b = 0;
        for (q = 0; q < 4; ++q) {
            gs__xblk_lane(m, &probe, 0, q, &a, &b);
            s[q] = u->s0 + (a - u->a0);
        }
        gs__xpbd_block(m, probe.kind, probe.a, 0, s, 4);
    }
    if (j < u->len) { /* the rest as one short block where its lanes come first */
        struct gs__xblk probe;
        int lanes = 0, more = 0;
        probe.kind = off == 1 ? GS__XB_PAIRS : GS__XB_DUOS;
        probe.a = u->a0 + j;
        probe.b = 0;
        for (q = 0; q < 4; ++q) {
            gs__xblk_lane(m, &probe, 0, q, &a, &b);
            if (a - u->a0 < u->len && q == lanes) s[lanes++] = u->s0 + (a - u->a0);
            else if (a - u->a0 < u->len) more = 1;
        }
        if (!more) {
            gs__xpbd_block(m, probe.kind, probe.a, 0, s, lanes);
            return;
        }
    }
    for (; j < u->len; j += per)
        for (q = 0; q < off && j + q < u->len; ++q) {
            s[0] = u->s0 + j + q;
            gs__xpbd_block(m, GS__XB_ONE, u->a0 + j + q, u->a0 + j + q + off, s, 1);
        }
}

/* Blocks that follow one another in memory become one entry: the pass
   then runs them in a loop of one kind, in the same order. */
GS__PRIVATE void gs__xpbd_merge(gs__mesh *m) {
    int i, o = 0;
    for (i = 1; i < m->nxblk; ++i) {
        struct gs__xblk *p = &m->xblk[o];
        const struct gs__xblk *k = &m->xblk[i];
        int step = k->kind == GS__XB_SPAN ? 4 : 8;
        if (k->lanes == 4 && p->lanes == 4 && k->kind == p->kind &&
            k->a == p->a + step * p->count &&
            (k->kind != GS__XB_SPAN || k->b == p->b + 4 * p->count) &&
            k->s == p->s + 4 * p->count)
            p->count++;
        else
            m->xblk[++o] = *k;
    }
    if (m->nxblk > 0) m->nxblk = o + 1;
}

/* Lanes i.. of entry k have the same k, c and rest bits. */
GS__PRIVATE int gs__xpbd_uniform(const gs__mesh *m, const struct gs__xblk *k) {
    size_t ns = gs__soa_stride((size_t)m->ns);
    int i, n = k->kind != GS__XB_GATHER && k->lanes == 4 ? 4 * k->count : 0;
    const double *sp = m->xsp + k->s;
    for (i = 1; i < n; ++i)
        if (memcmp(&sp[i], &sp[0], sizeof *sp) || memcmp(&sp[ns + (size_t)i], &sp[ns], sizeof *sp) ||
            memcmp(&sp[2 * ns + (size_t)i], &sp[2 * ns], sizeof *sp))
            return 0;
    return n > 0;
}

/* Consecutive one-spring entries that share no particle become one
   GATHER block of up to four lanes: taken together or one after the
   other they give the same bits, and the tails of a cloth's segments,
   a seventh of its springs, no longer run one sqrt and one division at
   a time (23 ns a spring against 3.3 in the four-blocks, measured). */
GS__PRIVATE void gs__xpbd_gather(gs__mesh *m) {
    int i, j, o = 0, used = 0;
    for (i = 0; i < m->nxblk; i = j) {
        struct gs__xblk k = m->xblk[i];
        j = i + 1;
        if (k.kind == GS__XB_ONE) {
            int ends[8], e, lanes = 0;
            for (j = i; lanes < 4 && j < m->nxblk && m->xblk[j].kind == GS__XB_ONE; ++j) {
                int a = m->xblk[j].a, b = m->xblk[j].b;
                for (e = 0; e < 2 * lanes && ends[e] != a && ends[e] != b; ++e) {}
                if (e < 2 * lanes) break;
                ends[2 * lanes] = a;
                ends[2 * lanes + 1] = b;
                lanes++;
            }
            if (lanes > 1) {
                k.kind = GS__XB_GATHER;
                k.b = used;
                k.lanes = lanes;
                for (e = 0; e < 2 * lanes; ++e) m->xgi[used++] = ends[e];
            }
        }
        k.uni = gs__xpbd_uniform(m, &k);
        m->xblk[o++] = k;
    }
    m->nxblk = o;
}

/* The blocks, from the runs (gs__mesh_find_runs). */
GS__PRIVATE void gs__xpbd_schedule(gs__mesh *m) {
    int r, j;
    m->nxblk = 0;
    for (r = 0; r < m->nruns; ++r) {
        const gs__run *u = &m->runs[r];
        if (u->off == 1 || u->off == 2) {
            gs__xpbd_parity(m, u, 0);
            gs__xpbd_parity(m, u, 1);
        } else if (u->off >= 4) {
            int cls;
            for (cls = 0; cls < 2; ++cls)
                for (j = cls * u->off; j < u->len; j += 2 * u->off)
                    gs__xpbd_span(m, u, j, j + u->off < u->len ? j + u->off : u->len);
        } else {
            for (j = 0; j < u->len; ++j) gs__xpbd_span(m, u, j, j + 1);
        }
    }
    gs__xpbd_merge(m);
    gs__xpbd_gather(m);
}

/* One spring of the transposed copy (X = the substep's positions so far,
   P = its start, stride st), as gs__xpbd_spring does it. */
GS__PRIVATE void gs__xpbd_one(double *X, const double *P, size_t st, const double *im,
                              const double *sp, size_t ns, int a, int b, double h) {
    double *Y = X + st, *Z = Y + st;
    const double *PY = P + st, *PZ = PY + st;
    double dx = X[b] - X[a], dy = Y[b] - Y[a], dz = Z[b] - Z[a];
    double l2 = dx * dx + dy * dy + dz * dz, l = sqrt(l2);
    double kh = sp[0] * h * h, ch = sp[ns] * h, kc = kh + ch, kr = kh * sp[2 * ns];
    double wa = im[a], wb = im[b];
    double ex = P[b] - P[a], ey = PY[b] - PY[a], ez = PZ[b] - PZ[a];
    double num = (kr * l + ch * ((dx * ex + dy * ey) + dz * ez)) - kc * l2;
    double den = l2 * (kc * (wa + wb) + 1.0);
    double s = den > 0.0 ? num / den : 0.0, sa = wa * s, sb = wb * s;
    X[a] -= sa * dx; Y[a] -= sa * dy; Z[a] -= sa * dz;
    X[b] += sb * dx; Y[b] += sb * dy; Z[b] += sb * dz;
}

#ifdef GS__MESH_AVX
/* A block's lanes of array p, and back (gs__xblk_lane's layouts). */
GS__XINLINE void gs__xld4(const double *p, int kind, int a,
                                                         int b, __m256d *va, __m256d *vb) {
    __m256d v0, v1;
    if (kind == GS__XB_SPAN) {
        *va = _mm256_loadu_pd(p + a);
        *vb = _mm256_loadu_pd(p + b);
        return;
    }
    v0 = _mm256_loadu_pd(p + a);
    v1 = _mm256_loadu_pd(p + a + 4);
    if (kind == GS__XB_PAIRS) {
        *va = _mm256_unpacklo_pd(v0, v1);
        *vb = _mm256_unpackhi_pd(v0, v1);
    } else {
        *va = _mm256_permute2f128_pd(v0, v1, 0x20);
        *vb = _mm256_permute2f128_pd(v0, v1, 0x31);
    }
}

GS__XINLINE void gs__xst4(double *p, int kind, int a, int b,
                                                         __m256d va, __m256d vb) {
    if (kind == GS__XB_SPAN) {
        _mm256_storeu_pd(p + a, va);
        _mm256_storeu_pd(p + b, vb);
    } else if (kind == GS__XB_PAIRS) {
        _mm256_storeu_pd(p + a, _mm256_unpacklo_pd(va, vb));
        _mm256_storeu_pd(p + a + 4, _mm256_unpackhi_pd(va, vb));
    } else {
        _mm256_storeu_pd(p + a, _mm256_permute2f128_pd(va, vb, 0x20));
        _mm256_storeu_pd(p + a + 4, _mm256_permute2f128_pd(va, vb, 0x31));
    }
}

/* gs__xpbd_one's arithmetic on four lanes: the ends a, b (x y z, updated
   in place), their start positions p*, inverse masses, and the springs'
   constants for this substep (gs__xk4). */
typedef struct gs__x4 {
    __m256d ax, ay, az, bx, by, bz, pax, pay, paz, pbx, pby, pbz, wa, wb;
} gs__x4;

/* k h^2 + c h, k h^2 rest and c h of four springs, as gs__xpbd_one makes
   them: once an entry where its lanes share them. */
typedef struct gs__xk4 {
    __m256d kc, kr, ch;
} gs__xk4;

GS__XINLINE gs__xk4 gs__xpbd_k4(__m256d k, __m256d c, __m256d rest, __m256d h) {
    gs__xk4 q;
    __m256d kh = _mm256_mul_pd(_mm256_mul_pd(k, h), h);
    q.ch = _mm256_mul_pd(c, h);
    q.kc = _mm256_add_pd(kh, q.ch);
    q.kr = _mm256_mul_pd(kh, rest);
    return q;
}

GS__XINLINE void gs__xpbd_core4(gs__x4 *e, const gs__xk4 *q) {
    __m256d dx, dy, dz, l2, l, de, num, den, s, sa, sb;
    dx = _mm256_sub_pd(e->bx, e->ax); dy = _mm256_sub_pd(e->by, e->ay); dz = _mm256_sub_pd(e->bz, e->az);
    l2 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy)),
                       _mm256_mul_pd(dz, dz));
    l = _mm256_sqrt_pd(l2);
    de = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(dx, _mm256_sub_pd(e->pbx, e->pax)),
                                     _mm256_mul_pd(dy, _mm256_sub_pd(e->pby, e->pay))),
                       _mm256_mul_pd(dz, _mm256_sub_pd(e->pbz, e->paz)));
    num = _mm256_sub_pd(_mm256_add_pd(_mm256_mul_pd(q->kr, l), _mm256_mul_pd(q->ch, de)),
                        _mm256_mul_pd(q->kc, l2));
    den = _mm256_mul_pd(l2, _mm256_add_pd(_mm256_mul_pd(q->kc, _mm256_add_pd(e->wa, e->wb)),
                                          _mm256_set1_pd(1.0)));
    s = _mm256_and_pd(_mm256_cmp_pd(den, _mm256_setzero_pd(), _CMP_GT_OQ), _mm256_div_pd(num, den));
    sa = _mm256_mul_pd(e->wa, s);
    sb = _mm256_mul_pd(e->wb, s);
    e->ax = _mm256_sub_pd(e->ax, _mm256_mul_pd(sa, dx));
    e->ay = _mm256_sub_pd(e->ay, _mm256_mul_pd(sa, dy));
    e->az = _mm256_sub_pd(e->az, _mm256_mul_pd(sa, dz));
    e->bx = _mm256_add_pd(e->bx, _mm256_mul_pd(sb, dx));
    e->by = _mm256_add_pd(e->by, _mm256_mul_pd(sb, dy));
    e->bz = _mm256_add_pd(e->bz, _mm256_mul_pd(sb, dz));
}

/* A block's ends and their start positions (all of gs__x4 but the
   inverse masses). */
GS__XINLINE void gs__xpbd_ld4(const double *X, const double *P, size_t st, int kind, int a, int b,
                              gs__x4 *e) {
    gs__xld4(X, kind, a, b, &e->ax, &e->bx);
    gs__xld4(X + st, kind, a, b, &e->ay, &e->by);
    gs__xld4(X + 2 * st, kind, a, b, &e->az, &e->bz);
    gs__xld4(P, kind, a, b, &e->pax, &e->pbx);
    gs__xld4(P + st, kind, a, b, &e->pay, &e->pby);
    gs__xld4(P + 2 * st, kind, a, b, &e->paz, &e->pbz);
}

/* gs__xpbd_one for the four lanes of a block of `kind` (a constant where
   it is inlined). */
GS__XINLINE void gs__xpbd_four(double *X, const double *P, size_t st, const double *im,
                               int kind, int a, int b, const gs__xk4 *q) {
    gs__x4 e;
    gs__xpbd_ld4(X, P, st, kind, a, b, &e);
    gs__xld4(im, kind, a, b, &e.wa, &e.wb);
    gs__xpbd_core4(&e, q);
    gs__xst4(X, kind, a, b, e.ax, e.bx);
    gs__xst4(X + st, kind, a, b, e.ay, e.by);
    gs__xst4(X + 2 * st, kind, a, b, e.az, e.bz);
}

/* The `count` blocks of an entry of `kind`, their k, c, rest from xsp at
   s (one value for all when uni). */
GS__XINLINE void gs__xpbd_entry4(double *X, const double *P, size_t st, const double *im,
                                 const double *sp, size_t ns, int kind, int a, int b, int s,
                                 int count, int uni, double h) {
    int step = kind == GS__XB_SPAN ? 4 : 8, t;
    __m256d hv = _mm256_set1_pd(h);
    if (uni) {
        gs__xk4 kq = gs__xpbd_k4(_mm256_set1_pd(sp[s]), _mm256_set1_pd(sp[ns + (size_t)s]),
                                 _mm256_set1_pd(sp[2 * ns + (size_t)s]), hv);
        for (t = 0; t < count; ++t)
            gs__xpbd_four(X, P, st, im, kind, a + step * t, b + 4 * t, &kq);
        return;
    }
    for (t = 0; t < count; ++t) {
        const double *q = sp + s + 4 * t;
        gs__xk4 kq = gs__xpbd_k4(_mm256_loadu_pd(q), _mm256_loadu_pd(q + ns),
                                 _mm256_loadu_pd(q + 2 * ns), hv);
        gs__xpbd_four(X, P, st, im, kind, a + step * t, b + 4 * t, &kq);
    }
}

/* A GATHER block: lanes past k->lanes repeat lane 0's end a as both ends
   (no length: no move) and are not stored. */
GS__XINLINE void gs__xpbd_gather4(double *X, const double *P, size_t st, const double *im,
                                  const double *sp, size_t ns, const int *ends, int lanes,
                                  int s, double h) {
    int ia[4], ib[4], q;
    double out[6][4];
    gs__xk4 kq;
    gs__x4 e;
    __m256d hv = _mm256_set1_pd(h);
    for (q = 0; q < 4; ++q) {
        ia[q] = ends[q < lanes ? 2 * q : 0];
        ib[q] = q < lanes ? ends[2 * q + 1] : ia[q];
    }
#define GS__G4(p, i) _mm256_set_pd((p)[i[3]], (p)[i[2]], (p)[i[1]], (p)[i[0]])
    e.ax = GS__G4(X, ia); e.ay = GS__G4(X + st, ia); e.az = GS__G4(X + 2 * st, ia);
    e.bx = GS__G4(X, ib); e.by = GS__G4(X + st, ib); e.bz = GS__G4(X + 2 * st, ib);
    e.pax = GS__G4(P, ia); e.pay = GS__G4(P + st, ia); e.paz = GS__G4(P + 2 * st, ia);
    e.pbx = GS__G4(P, ib); e.pby = GS__G4(P + st, ib); e.pbz = GS__G4(P + 2 * st, ib);
    e.wa = GS__G4(im, ia); e.wb = GS__G4(im, ib);
#undef GS__G4
    kq = gs__xpbd_k4(_mm256_loadu_pd(sp + s), _mm256_loadu_pd(sp + ns + s),
                     _mm256_loadu_pd(sp + 2 * ns + s), hv);
    gs__xpbd_core4(&e, &kq);
    _mm256_storeu_pd(out[0], e.ax); _mm256_storeu_pd(out[1], e.ay); _mm256_storeu_pd(out[2], e.az);
    _mm256_storeu_pd(out[3], e.bx); _mm256_storeu_pd(out[4], e.by); _mm256_storeu_pd(out[5], e.bz);
    for (q = 0; q < lanes; ++q) {
        X[ia[q]] = out[0][q]; X[st + (size_t)ia[q]] = out[1][q]; X[2 * st + (size_t)ia[q]] = out[2][q];
        X[ib[q]] = out[3][q]; X[st + (size_t)ib[q]] = out[4][q]; X[2 * st + (size_t)ib[q]] = out[5][q];
    }
}

/* gs__xld4 of an array of n elements: those past n load as zero. */
GS__XINLINE void gs__xld4n(const double *p, int n, int kind, int a, int b, __m256d *va,
                           __m256d *vb) {
    __m256d q = _mm256_set_pd(3.0, 2.0, 1.0, 0.0), lim = _mm256_set1_pd(n);
    int c = kind == GS__XB_SPAN ? b : a + 4;
    __m256i ma = _mm256_castpd_si256(_mm256_cmp_pd(_mm256_add_pd(q, _mm256_set1_pd(a)), lim, _CMP_LT_OQ));
    __m256i mc = _mm256_castpd_si256(_mm256_cmp_pd(_mm256_add_pd(q, _mm256_set1_pd(c)), lim, _CMP_LT_OQ));
    __m256d v0 = _mm256_maskload_pd(p + a, ma), v1 = _mm256_maskload_pd(p + c, mc);
    if (kind == GS__XB_SPAN) {
        *va = v0;
        *vb = v1;
    } else if (kind == GS__XB_PAIRS) {
        *va = _mm256_unpacklo_pd(v0, v1);
        *vb = _mm256_unpackhi_pd(v0, v1);
    } else {
        *va = _mm256_permute2f128_pd(v0, v1, 0x20);
        *vb = _mm256_permute2f128_pd(v0, v1, 0x31);
    }
}

/* A block of `kind` with its first `lanes` lanes only (a TAIL, or the
   last PAIRS or DUOS block of a parity class): the other lanes load
   what lies there (a row's padding past n is zeros, the inverse masses
   past n zero) and are stored back as they were loaded: blended, as
   masked stores cost four times a block (measured). */
GS__XINLINE void gs__xpbd_part4(double *X, const double *P, size_t st, const double *im, int n,
                                const double *sp, size_t ns, int kind, int a, int b, int s,
                                int lanes, double h) {
    __m256d keep = _mm256_cmp_pd(_mm256_set_pd(3.0, 2.0, 1.0, 0.0), _mm256_set1_pd(lanes), _CMP_LT_OQ);
    gs__xk4 kq;
    gs__x4 e, o;
    gs__xpbd_ld4(X, P, st, kind, a, b, &e);
    gs__xld4n(im, n, kind, a, b, &e.wa, &e.wb);
    kq = gs__xpbd_k4(_mm256_loadu_pd(sp + s), _mm256_loadu_pd(sp + ns + s),
                     _mm256_loadu_pd(sp + 2 * ns + s), _mm256_set1_pd(h));
    o = e;
    gs__xpbd_core4(&e, &kq);
    gs__xst4(X, kind, a, b, _mm256_blendv_pd(o.ax, e.ax, keep), _mm256_blendv_pd(o.bx, e.bx, keep));
    gs__xst4(X + st, kind, a, b, _mm256_blendv_pd(o.ay, e.ay, keep), _mm256_blendv_pd(o.by, e.by, keep));
    gs__xst4(X + 2 * st, kind, a, b, _mm256_blendv_pd(o.az, e.az, keep),
             _mm256_blendv_pd(o.bz, e.bz, keep));
}

GS__XINLINE void gs__xpbd_blocks4(gs__mesh *m, double h) {
    size_t st = gs__soa_stride((size_t)m->n), ns = gs__soa_stride((size_t)m->ns);
    double *X = m->soa;
    const double *P = X + 3 * st;
    const double *im = m->inv_mass, *sp = m->xsp;
    int i;
    for (i = 0; i < m->nxblk; ++i) {
        const struct gs__xblk *k = &m->xblk[i];
        switch (k->kind) { /* one loop per kind, the kind a constant in it */
        case GS__XB_SPAN:
            gs__xpbd_entry4(X, P, st, im, sp, ns, GS__XB_SPAN, k->a, k->b, k->s, k->count, k->uni, h);
            break;
        case GS__XB_PAIRS:
            if (k->lanes < 4)
                gs__xpbd_part4(X, P, st, im, m->n, sp, ns, GS__XB_PAIRS, k->a, 0, k->s, k->lanes, h);
            else
                gs__xpbd_entry4(X, P, st, im, sp, ns, GS__XB_PAIRS, k->a, 0, k->s, k->count, k->uni, h);
            break;
        case GS__XB_DUOS:
            if (k->lanes < 4)
                gs__xpbd_part4(X, P, st, im, m->n, sp, ns, GS__XB_DUOS, k->a, 0, k->s, k->lanes, h);
            else
                gs__xpbd_entry4(X, P, st, im, sp, ns, GS__XB_DUOS, k->a, 0, k->s, k->count, k->uni, h);
            break;
        case GS__XB_GATHER:
            gs__xpbd_gather4(X, P, st, im, sp, ns, m->xgi + k->b, k->lanes, k->s, h);
            break;
        case GS__XB_TAIL:
            gs__xpbd_part4(X, P, st, im, m->n, sp, ns, GS__XB_SPAN, k->a, k->b, k->s, k->lanes, h);
            break;
        default: gs__xpbd_one(X, P, st, im, sp + k->s, ns, k->a, k->b, h); break;
        }
    }
}

__attribute__((target("avx"))) GS__PRIVATE void gs__xpbd_blocks_avx(gs__mesh *m, double h) {
    gs__xpbd_blocks4(m, h);
}

/* The same four-wide operations where the CPU has AVX-512VL: its 32
   vector registers hold a block's sixteen vectors and constants, which
   sixteen registers cannot (a fifth of the AVX loop is spills and
   reloads, measured). Eight lanes (zmm) gain nothing: the pass is bound
   by the square roots and divisions, which cost twice as much at twice
   the width (docs/performance-notes.md). */
__attribute__((target("avx512f,avx512vl"))) GS__NOFUSE GS__PRIVATE void gs__xpbd_blocks_avx512(gs__mesh *m,
                                                                                  double h) {
    gs__xpbd_blocks4(m, h);
}
#endif

/* The pass over the blocks, lane by lane where the CPU has no AVX. */
GS__PRIVATE void gs__xpbd_blocks(gs__mesh *m, double h) {
    size_t st = gs__soa_stride((size_t)m->n), ns = gs__soa_stride((size_t)m->ns);
    double *X = m->soa;
    const double *P = X + 3 * st;
    int i, t, q, a, b;
#ifdef GS__MESH_AVX
    if (m->avx) {
        if (m->avx > 1)
            gs__xpbd_blocks_avx512(m, h);
        else
            gs__xpbd_blocks_avx(m, h);
        return;
    }
#endif
    for (i = 0; i < m->nxblk; ++i) {
        const struct gs__xblk *k = &m->xblk[i];
        for (t = 0; t < k->count; ++t)
            for (q = 0; q < k->lanes; ++q) {
                gs__xblk_lane(m, k, t, q, &a, &b);
                gs__xpbd_one(X, P, st, m->inv_mass, m->xsp + k->s + 4 * t + q, ns, a, b, h);
            }
    }
}

/* Contacts as XPBD constraints: the deepest contact of each particle is a
   penalty spring of its stiffness and damping along the normal (C = -depth,
   compliance 1 / k), so contact is as stable at any substep as the springs
   are; it only pushes. The depth follows the particle's motion this
   substep relative to what it touches. */
GS__PRIVATE gs_vec3 gs__xpbd_contact(const gs__mesh *m, int i, gs_vec3 p, double h) {
    double w = m->inv_mass[i], kh, ch, vn, d, dl;
    gs_vec3 n = m->cn[i];
    if (m->ck[i] == 0.0 || w == 0.0) return p;
    vn = gs__dot(n, gs__madd(gs__sub(p, m->x[i]), m->cvel[i], -h));
    d = m->cdepth[i] - vn;
    if (!(d > 0.0)) return p;
    kh = m->ck[i] * h * h;
    ch = m->cc[i] * h;
    dl = (kh * d - ch * vn) / ((kh + ch) * w + 1.0);
    return dl > 0.0 ? gs__madd(p, n, w * dl) : p;
}

GS__PRIVATE void gs__xpbd_contacts(gs__mesh *m, double h) {
    int i;
    for (i = 0; i < m->n; ++i) m->xn[i] = gs__xpbd_contact(m, i, m->xn[i], h);
}

/* The end of a substep over the transposed copy: v = (p - x) / h into
   (xn, vn), with gs__mesh_sane's checks and bounds and the boxes of
   gs__mesh_chunks in the same loop. Its outcome is kept in m (checked,
   check_ok, lo, hi, boxes). */
typedef struct gs__fin {
    double w2, sum, lo[3], hi[3];
    double h; /* s; the next substep's, for its prediction (pred_next) */
} gs__fin;

/* gs__int_xpbd_blocks's prediction of particle i from its state (x, v)
   over h, into the transposed copy. */
GS__PRIVATE void gs__xpbd_predict1(gs__mesh *m, size_t i, gs_vec3 x, gs_vec3 v0, double h) {
    size_t st = gs__soa_stride((size_t)m->n);
    double *X = m->soa, *Y = X + st, *Z = Y + st, *PX = Z + st, *PY = PX + st, *PZ = PY + st;
    gs_vec3 a = gs__madd(m->base.world->gravity, v0, -m->air);
    gs_vec3 v = m->inv_mass[i] > 0.0 ? gs__madd(v0, a, h) : v0;
    X[i] = x.x + v.x * h; Y[i] = x.y + v.y * h; Z[i] = x.z + v.z * h;
    PX[i] = x.x; PY[i] = x.y; PZ[i] = x.z;
}

/* Inlined, so that gs__xpbd_fin4 calls nothing out of line: called from
   there, an SSE-encoded copy after its AVX loop stalled and took two
   fifths of the substep's end (measured). */
GS__PRIVATE_INLINE void gs__fin_box(gs__mesh *m, size_t k, const double *lo, const double *hi,
                             double vm, gs__fin *f) {
    int c;
    m->clo[k] = gs__v3(lo[0], lo[1], lo[2]);
    m->chi[k] = gs__v3(hi[0], hi[1], hi[2]);
    m->cvm[k] = vm;
    for (c = 0; c < 3; ++c) {
        f->lo[c] = lo[c] < f->lo[c] ? lo[c] : f->lo[c];
        f->hi[c] = hi[c] > f->hi[c] ? hi[c] : f->hi[c];
    }
}

GS__PRIVATE void gs__fin_start(gs__fin *f, double h) {
    f->w2 = f->sum = 0.0;
    f->h = h; /* the substeps of a step are equal */
    f->lo[0] = f->lo[1] = f->lo[2] = HUGE_VAL;
    f->hi[0] = f->hi[1] = f->hi[2] = -HUGE_VAL;
}

/* The checks' outcome after the last box: the boxes are the new state's
   (chunks_next), and the next substep may start from the copy. */
GS__PRIVATE void gs__fin_done(gs__mesh *m, const gs__fin *f) {
    double vmax2 = m->solver.max_speed * m->solver.max_speed;
    m->chunks_next = 1;
    m->checked = 1;
    m->pred_ready = m->pred_next;
    m->check_ok = f->w2 <= vmax2 && gs__finite(f->sum) &&
                  gs__in_range3(gs__v3(f->lo[0], f->lo[1], f->lo[2])) &&
                  gs__in_range3(gs__v3(f->hi[0], f->hi[1], f->hi[2]));
    if (m->check_ok) {
        m->lo = gs__v3(f->lo[0] - m->radius, f->lo[1] - m->radius, f->lo[2] - m->radius);
        m->hi = gs__v3(f->hi[0] + m->radius, f->hi[1] + m->radius, f->hi[2] + m->radius);
    }
}

/* One particle's share of a substep end's checks and box (gs__fin): the
   largest speed^2, the sum of coordinates, the largest |v| component and
   the bounds, in the scalar ends (gs__xpbd_fin1, gs__sym_fin1). */
GS__PRIVATE void gs__fin_take(gs_vec3 p, gs_vec3 v, double *w2, double *sum, double *vm,
                               double *lo, double *hi) {
    double s2 = v.x * v.x + v.y * v.y + v.z * v.z, a;
    *w2 = s2 > *w2 ? s2 : *w2;
    *w2 = s2 == s2 ? *w2 : s2; /* a NaN speed stays NaN */
    *sum += (p.x + p.y) + p.z;
    a = fabs(v.x) > fabs(v.y) ? fabs(v.x) : fabs(v.y);
    a = fabs(v.z) > a ? fabs(v.z) : a;
    *vm = a > *vm ? a : *vm; /* a NaN fails the check above: no box of it is used */
    lo[0] = p.x < lo[0] ? p.x : lo[0]; lo[1] = p.y < lo[1] ? p.y : lo[1];
    lo[2] = p.z < lo[2] ? p.z : lo[2]; hi[0] = p.x > hi[0] ? p.x : hi[0];
    hi[1] = p.y > hi[1] ? p.y : hi[1]; hi[2] = p.z > hi[2] ? p.z : hi[2];
}

/* Particles i..end (one box), scalar. */
GS__PRIVATE void gs__xpbd_fin1(gs__mesh *m, size_t i, size_t end, size_t k, double ih,
                               gs__fin *f) {
    size_t st = gs__soa_stride((size_t)m->n);
    double *X = m->soa, *Y = X + st, *Z = Y + st, *PX = Z + st, *PY = PX + st, *PZ = PY + st;
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    double vm = 0.0, w2 = f->w2, sum = f->sum;
    for (; i < end; ++i) {
        gs_vec3 p = gs__v3(X[i], Y[i], Z[i]);
        gs_vec3 v = gs__v3((p.x - PX[i]) * ih, (p.y - PY[i]) * ih, (p.z - PZ[i]) * ih);
        m->xn[i] = p;
        m->vn[i] = v;
        if (m->pred_next) gs__xpbd_predict1(m, i, p, v, f->h);
        gs__fin_take(p, v, &w2, &sum, &vm, lo, hi);
    }
    f->w2 = w2;
    f->sum = sum;
    gs__fin_box(m, k, lo, hi, vm, f);
}

#ifdef GS__MESH_AVX
/* The four-lane substep ends' per-lane speed^2 (NaN flags), sums, |v|
   maxima and bounds into f and box k (gs__xpbd_fin4, gs__sym_fin4). */
GS__XINLINE void gs__fin_lanes(gs__mesh *m, size_t k, __m256d w2, __m256d nan, __m256d sum,
                               __m256d vm, __m256d lx, __m256d ly, __m256d lz, __m256d hx,
                               __m256d hy, __m256d hz, gs__fin *f) {
    double lo[3], hi[3];
    f->w2 = gs__hmax4(w2);
    if (_mm256_movemask_pd(nan)) f->w2 = NAN;
    f->sum += gs__hmax4(sum) + gs__hmin4(sum); /* a NaN or inf lane shows */
    if (_mm256_movemask_pd(_mm256_cmp_pd(sum, sum, _CMP_UNORD_Q))) f->sum = NAN;
    lo[0] = gs__hmin4(lx); lo[1] = gs__hmin4(ly); lo[2] = gs__hmin4(lz);
    hi[0] = gs__hmax4(hx); hi[1] = gs__hmax4(hy); hi[2] = gs__hmax4(hz);
    gs__fin_box(m, k, lo, hi, gs__hmax4(vm), f);
}

/* gs__xpbd_fin1 four particles at a time over whole boxes: the same xn,
   vn and boxes; the speed and the sum are per lane, which changes
   neither check's outcome (the sum only asks "finite?", and its terms
   are within GS_MAX_COORD). */
GS__XINLINE void gs__xpbd_fin4(gs__mesh *m, size_t i, size_t k, double ih, gs__fin *f) {
    size_t st = gs__soa_stride((size_t)m->n), end = i + GS__CHUNK;
    double *X = m->soa, *Y = X + st, *Z = Y + st, *PX = Z + st, *PY = PX + st, *PZ = PY + st;
    __m256d hv = _mm256_set1_pd(ih), sign = _mm256_set1_pd(-0.0), w2 = _mm256_set1_pd(f->w2);
    __m256d lx = _mm256_set1_pd(HUGE_VAL), ly = lx, lz = lx, hx = _mm256_set1_pd(-HUGE_VAL);
    __m256d hy = hx, hz = hx, vm = _mm256_setzero_pd(), sum = _mm256_setzero_pd(), nan = vm;
    double *xn = &m->xn[0].x, *vn = &m->vn[0].x;
    gs_vec3 g = m->base.world->gravity;
    __m256d h = _mm256_set1_pd(f->h), nair = _mm256_set1_pd(-m->air), zero = _mm256_setzero_pd();
    __m256d gx = _mm256_set1_pd(g.x), gy = _mm256_set1_pd(g.y), gz = _mm256_set1_pd(g.z);
    for (; i < end; i += 4) {
        __m256d px = _mm256_loadu_pd(X + i), py = _mm256_loadu_pd(Y + i), pz = _mm256_loadu_pd(Z + i);
        __m256d vx = _mm256_mul_pd(_mm256_sub_pd(px, _mm256_loadu_pd(PX + i)), hv);
        __m256d vy = _mm256_mul_pd(_mm256_sub_pd(py, _mm256_loadu_pd(PY + i)), hv);
        __m256d vz = _mm256_mul_pd(_mm256_sub_pd(pz, _mm256_loadu_pd(PZ + i)), hv);
        __m256d s2 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(vx, vx), _mm256_mul_pd(vy, vy)),
                                   _mm256_mul_pd(vz, vz));
        __m256d ax = _mm256_andnot_pd(sign, vx), ay = _mm256_andnot_pd(sign, vy);
        __m256d a = _mm256_max_pd(_mm256_andnot_pd(sign, vz), _mm256_max_pd(ax, ay));
        w2 = _mm256_max_pd(s2, w2);
        nan = _mm256_or_pd(nan, _mm256_cmp_pd(s2, s2, _CMP_UNORD_Q));
        sum = _mm256_add_pd(sum, _mm256_add_pd(_mm256_add_pd(px, py), pz));
        vm = _mm256_max_pd(a, vm);
        lx = _mm256_min_pd(px, lx); ly = _mm256_min_pd(py, ly); lz = _mm256_min_pd(pz, lz);
        hx = _mm256_max_pd(px, hx); hy = _mm256_max_pd(py, hy); hz = _mm256_max_pd(pz, hz);
        gs__st_aos4(xn + 3 * i, px, py, pz);
        gs__st_aos4(vn + 3 * i, vx, vy, vz);
        if (m->pred_next) { /* gs__xpbd_predict1, four lanes */
            __m256d free = _mm256_cmp_pd(_mm256_loadu_pd(m->inv_mass + i), zero, _CMP_GT_OQ);
            __m256d ux = _mm256_add_pd(vx, _mm256_mul_pd(_mm256_add_pd(gx, _mm256_mul_pd(vx, nair)), h));
            __m256d uy = _mm256_add_pd(vy, _mm256_mul_pd(_mm256_add_pd(gy, _mm256_mul_pd(vy, nair)), h));
            __m256d uz = _mm256_add_pd(vz, _mm256_mul_pd(_mm256_add_pd(gz, _mm256_mul_pd(vz, nair)), h));
            ux = _mm256_blendv_pd(vx, ux, free);
            uy = _mm256_blendv_pd(vy, uy, free);
            uz = _mm256_blendv_pd(vz, uz, free);
            _mm256_storeu_pd(X + i, _mm256_add_pd(px, _mm256_mul_pd(ux, h)));
            _mm256_storeu_pd(Y + i, _mm256_add_pd(py, _mm256_mul_pd(uy, h)));
            _mm256_storeu_pd(Z + i, _mm256_add_pd(pz, _mm256_mul_pd(uz, h)));
            _mm256_storeu_pd(PX + i, px);
            _mm256_storeu_pd(PY + i, py);
            _mm256_storeu_pd(PZ + i, pz);
        }
    }
    gs__fin_lanes(m, k, w2, nan, sum, vm, lx, ly, lz, hx, hy, hz, f);
}

__attribute__((target("avx"))) GS__PRIVATE void gs__xpbd_fin_avx(gs__mesh *m, size_t i, size_t k,
                                                                 double ih, gs__fin *f) {
    gs__xpbd_fin4(m, i, k, ih, f);
}

/* The same where the CPU has AVX-512VL: its 32 registers hold the
   loop's fourteen accumulators and constants without spills. */
__attribute__((target("avx512f,avx512vl"))) GS__NOFUSE GS__PRIVATE void gs__xpbd_fin_avx512(gs__mesh *m, size_t i,
                                                                                size_t k, double ih,
                                                                                gs__fin *f) {
    gs__xpbd_fin4(m, i, k, ih, f);
}
#endif

/* Contacts as constraints on the pass's result, particle by particle
   where one touches (ck set), into the transposed copy; each particle's
   own, so the order of the touched list is free. */
GS__PRIVATE void gs__xpbd_soa_contacts(gs__mesh *m, double h) {
    size_t st = gs__soa_stride((size_t)m->n);
    double *X = m->soa, *Y = X + st, *Z = Y + st;
    int j;
    for (j = 0; j < m->ntouched; ++j) {
        int i = m->touched[j];
        if (m->ck[i] != 0.0) {
            gs_vec3 p = gs__xpbd_contact(m, i, gs__v3(X[i], Y[i], Z[i]), h);
            X[i] = p.x; Y[i] = p.y; Z[i] = p.z;
        }
    }
}

/* gs__int_xpbd over the blocks: the prediction goes into the transposed
   copy, the pass and the contacts run there, and the velocities come out
   box by box with the checks (pinned particles neither move nor gain
   speed, as the substep's pin pass leaves them). */
GS__PRIVATE void gs__int_xpbd_blocks(gs__mesh *m, double h) {
    size_t n = (size_t)m->n, st = gs__soa_stride(n), i, k;
    double *X = m->soa, *Y = X + st, *Z = Y + st, *PX = Z + st, *PY = PX + st, *PZ = PY + st;
    const double *im = m->inv_mass;
    gs_vec3 g = m->base.world->gravity;
    double ih = 1.0 / h;
    gs__fin f;
    const gs_vec3 *x = m->x, *v0 = m->v, *ext = m->ext_active ? m->ext : NULL;
    int j;
    if (!m->pred_ready) {
        for (i = 0; i < n; ++i) {
            gs_vec3 a = gs__madd(g, v0[i], -m->air), v = im[i] > 0.0 ? gs__madd(v0[i], a, h) : v0[i];
            X[i] = x[i].x + v.x * h; Y[i] = x[i].y + v.y * h; Z[i] = x[i].z + v.z * h;
            PX[i] = x[i].x; PY[i] = x[i].y; PZ[i] = x[i].z;
        }
    } else { /* the last substep's end predicted from its state before the pins' reset */
        for (j = 0; j < m->npins; ++j) gs__xpbd_predict1(m, (size_t)m->pins[j], x[m->pins[j]], v0[m->pins[j]], h);
    }
    m->pred_ready = 0;
    for (j = 0; ext && j < m->ntouched; ++j) { /* ext is zero elsewhere */
        gs_vec3 a, v;
        i = (size_t)m->touched[j];
        a = gs__madd(g, v0[i], -m->air);
        v = im[i] > 0.0 ? gs__madd(v0[i], a, h) : v0[i];
        v = gs__madd(v, ext[i], im[i] * h);
        X[i] = x[i].x + v.x * h; Y[i] = x[i].y + v.y * h; Z[i] = x[i].z + v.z * h;
    }
    gs__xpbd_blocks(m, h);
    if (ext) gs__xpbd_soa_contacts(m, h);
    gs__fin_start(&f, h);
    for (k = 0, i = 0; i < n; ++k, i += GS__CHUNK) { /* box by box (gs__mesh_chunks) */
#ifdef GS__MESH_AVX
        if (m->avx && i + GS__CHUNK <= n) {
            if (m->avx > 1)
                gs__xpbd_fin_avx512(m, i, k, ih, &f);
            else
                gs__xpbd_fin_avx(m, i, k, ih, &f);
            continue;
        }
#endif
        gs__xpbd_fin1(m, i, i + GS__CHUNK < n ? i + GS__CHUNK : n, k, ih, &f);
    }
    gs__fin_done(m, &f);
}

GS__PRIVATE void gs__int_xpbd(gs__mesh *m, double h) {
    gs_vec3 g = m->base.world->gravity;
    const double *im = m->inv_mass;
    double ih = 1.0 / h;
    int i;
    if (m->nxblk > 0) {
        gs__int_xpbd_blocks(m, h);
        return;
    }
    for (i = 0; i < m->n; ++i) {
        gs_vec3 a = gs__madd(g, m->v[i], -m->air);
        m->vn[i] = im[i] > 0.0 ? gs__madd(m->v[i], a, h) : m->v[i];
    }
    if (m->ext_active)
        for (i = 0; i < m->n; ++i) m->vn[i] = gs__madd(m->vn[i], m->ext[i], im[i] * h);
    for (i = 0; i < m->n; ++i) m->xn[i] = gs__madd(m->x[i], m->vn[i], h);
    gs__xpbd_pass(m, h);
    if (m->ext_active) gs__xpbd_contacts(m, h);
    for (i = 0; i < m->n; ++i) m->vn[i] = gs__scale(gs__sub(m->xn[i], m->x[i]), ih);
}

/* ---- symplectic Euler over runs of springs (see gs__mesh.runs) ----
   The transposed copy (soa) holds x y z, vx vy vz and the substep's
   forces fx fy fz, n each; sp_soa the springs' k, c, rest. A run's
   springs add their forces to both ends in the one loop that makes them
   (no force array between two passes), as the plain loop
       F[a] += f;  F[b] -= f;   spring by spring
   does: a particle takes its end-b force of spring j - off before its
   end-a force of spring j, and every vector path keeps that order per
   particle, so all give the same bits. Accelerations come at the end,
   a = g - air v + F / m, in the pass that updates the state, checks it
   and makes the contacts' boxes; a substep followed by another in the
   same step leaves its result in the copy for the next one (pred_next),
   which then reads nothing of the AoS state. */

/* Run u's springs j0..len, one at a time: the plain path. */
GS__PRIVATE void gs__sym_run1(gs__mesh *m, const gs__run *u, int j0) {
    size_t st = gs__soa_stride((size_t)m->n), ns = gs__soa_stride((size_t)m->ns);
    const double *X = m->soa, *Y = X + st, *Z = Y + st, *VX = Z + st, *VY = VX + st, *VZ = VY + st;
    const double *K = m->sp_soa, *C = K + ns, *R = C + ns;
    double *FX = m->soa + 6 * st, *FY = FX + st, *FZ = FY + st;
    int j;
    for (j = j0; j < u->len; ++j) {
        int a = u->a0 + j, b = a + u->off, s = u->s0 + j;
        double dx = X[b] - X[a], dy = Y[b] - Y[a], dz = Z[b] - Z[a];
        double l = sqrt(dx * dx + dy * dy + dz * dz);
        double il = l > 0.0 ? 1.0 / l : 0.0, ux = dx * il, uy = dy * il, uz = dz * il;
        double f = K[s] * (l - R[s]) +
                   C[s] * ((VX[b] - VX[a]) * ux + (VY[b] - VY[a]) * uy + (VZ[b] - VZ[a]) * uz);
        f = l > 0.0 ? f : 0.0;
        FX[a] += ux * f; FY[a] += uy * f; FZ[a] += uz * f;
        FX[b] -= ux * f; FY[b] -= uy * f; FZ[b] -= uz * f;
    }
}

#ifdef GS__MESH_AVX
/* Forces on ends a of springs s..s+3 (ends a.., b..) into f[0..2],
   gs__sym_run1's operations lane by lane. */
GS__XINLINE void gs__sym_force4(const double *X, size_t st, const double *K, size_t ns, int a, int b,
                                int s, __m256d *fx, __m256d *fy, __m256d *fz) {
    const double *Y = X + st, *Z = Y + st, *VX = Z + st, *VY = VX + st, *VZ = VY + st;
    __m256d dx = _mm256_sub_pd(_mm256_loadu_pd(X + b), _mm256_loadu_pd(X + a));
    __m256d dy = _mm256_sub_pd(_mm256_loadu_pd(Y + b), _mm256_loadu_pd(Y + a));
    __m256d dz = _mm256_sub_pd(_mm256_loadu_pd(Z + b), _mm256_loadu_pd(Z + a));
    __m256d l = _mm256_sqrt_pd(_mm256_add_pd(
        _mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy)), _mm256_mul_pd(dz, dz)));
    __m256d ok = _mm256_cmp_pd(l, _mm256_setzero_pd(), _CMP_GT_OQ);
    __m256d il = _mm256_and_pd(ok, _mm256_div_pd(_mm256_set1_pd(1.0), l));
    __m256d ux = _mm256_mul_pd(dx, il), uy = _mm256_mul_pd(dy, il), uz = _mm256_mul_pd(dz, il);
    __m256d w = _mm256_add_pd(
        _mm256_add_pd(_mm256_mul_pd(_mm256_sub_pd(_mm256_loadu_pd(VX + b), _mm256_loadu_pd(VX + a)), ux),
                      _mm256_mul_pd(_mm256_sub_pd(_mm256_loadu_pd(VY + b), _mm256_loadu_pd(VY + a)), uy)),
        _mm256_mul_pd(_mm256_sub_pd(_mm256_loadu_pd(VZ + b), _mm256_loadu_pd(VZ + a)), uz));
    __m256d f = _mm256_and_pd(
        ok, _mm256_add_pd(_mm256_mul_pd(_mm256_loadu_pd(K + s), _mm256_sub_pd(l, _mm256_loadu_pd(K + 2 * ns + s))),
                          _mm256_mul_pd(_mm256_loadu_pd(K + ns + s), w)));
    *fx = _mm256_mul_pd(ux, f);
    *fy = _mm256_mul_pd(uy, f);
    *fz = _mm256_mul_pd(uz, f);
}

/* A run's last block: lanes past `left` (< 4) out, as -0 for the add to
   ends a and +0 for the subtract from ends b, what leave a value as it
   was. They read past the run, within the copy's padding
   (gs__soa_stride): their values are dropped. */
GS__XINLINE void gs__sym_cut4(int left, __m256d *ax, __m256d *ay, __m256d *az, __m256d *bx,
                              __m256d *by, __m256d *bz) {
    __m256d in = _mm256_cmp_pd(_mm256_set_pd(3.0, 2.0, 1.0, 0.0), _mm256_set1_pd((double)left), _CMP_LT_OQ);
    __m256d mz = _mm256_andnot_pd(in, _mm256_set1_pd(-0.0));
    *bx = _mm256_and_pd(in, *bx); *by = _mm256_and_pd(in, *by); *bz = _mm256_and_pd(in, *bz);
    *ax = _mm256_or_pd(*bx, mz); *ay = _mm256_or_pd(*by, mz); *az = _mm256_or_pd(*bz, mz);
}

/* Lanes of f shifted up by `off` (1..3), the lanes below from p: spring
   j - off's force for particle j's lane. */
GS__XINLINE __m256d gs__sym_shift(__m256d p, __m256d f, int off) {
    __m256d t = _mm256_permute2f128_pd(p, f, 0x21); /* p2 p3 f0 f1 */
    return off == 1 ? _mm256_shuffle_pd(t, f, 0x5) : off == 2 ? t : _mm256_shuffle_pd(p, t, 0x5);
}

/* gs__sym_run1 over a whole run four springs at a time. Offsets of 4 or
   more: a block's ends a and b are disjoint, so they take their forces
   as vectors, and a particle's end-b force (block j - off) comes before
   its end-a one (block j). Offsets 1..3: a block's ends overlap, so the
   loop goes by blocks of particles, each taking its end-b forces (the
   last block's and this one's forces shifted by off) and then its end-a
   ones. Other offsets (negative under 4) go one spring at a time. */
__attribute__((target("avx"))) GS__PRIVATE void gs__sym_run4(gs__mesh *m, const gs__run *u) {
    size_t st = gs__soa_stride((size_t)m->n), ns = gs__soa_stride((size_t)m->ns);
    const double *X = m->soa, *K = m->sp_soa;
    double *F = m->soa + 6 * st;
    int j, off = u->off, a = u->a0, s = u->s0, len = u->len;
    __m256d ax, ay, az, bx, by, bz, px, py, pz;
    if (off >= 4 || off <= -4) {
        for (j = 0; j < len; j += 4) {
            double *pa = F + a + j, *pb = pa + off;
            gs__sym_force4(X, st, K, ns, a + j, a + off + j, s + j, &ax, &ay, &az);
            bx = ax; by = ay; bz = az;
            if (len - j < 4) gs__sym_cut4(len - j, &ax, &ay, &az, &bx, &by, &bz);
            _mm256_storeu_pd(pa, _mm256_add_pd(_mm256_loadu_pd(pa), ax));
            _mm256_storeu_pd(pa + st, _mm256_add_pd(_mm256_loadu_pd(pa + st), ay));
            _mm256_storeu_pd(pa + 2 * st, _mm256_add_pd(_mm256_loadu_pd(pa + 2 * st), az));
            _mm256_storeu_pd(pb, _mm256_sub_pd(_mm256_loadu_pd(pb), bx));
            _mm256_storeu_pd(pb + st, _mm256_sub_pd(_mm256_loadu_pd(pb + st), by));
            _mm256_storeu_pd(pb + 2 * st, _mm256_sub_pd(_mm256_loadu_pd(pb + 2 * st), bz));
        }
        return;
    }
    if (off < 1) {
        gs__sym_run1(m, u, 0);
        return;
    }
    px = py = pz = _mm256_setzero_pd();
    for (j = 0; j < len + off; j += 4) {
        double *pa = F + a + j;
        if (j < len) {
            gs__sym_force4(X, st, K, ns, a + j, a + off + j, s + j, &ax, &ay, &az);
            bx = ax; by = ay; bz = az;
            if (len - j < 4) gs__sym_cut4(len - j, &ax, &ay, &az, &bx, &by, &bz);
        } else {
            ax = ay = az = _mm256_set1_pd(-0.0);
            bx = by = bz = _mm256_setzero_pd();
        }
        _mm256_storeu_pd(pa, _mm256_add_pd(_mm256_sub_pd(_mm256_loadu_pd(pa), gs__sym_shift(px, bx, off)), ax));
        _mm256_storeu_pd(pa + st, _mm256_add_pd(_mm256_sub_pd(_mm256_loadu_pd(pa + st), gs__sym_shift(py, by, off)), ay));
        _mm256_storeu_pd(pa + 2 * st, _mm256_add_pd(_mm256_sub_pd(_mm256_loadu_pd(pa + 2 * st), gs__sym_shift(pz, bz, off)), az));
        px = bx; py = by; pz = bz;
    }
}
#endif

/* The end of a symplectic substep from the copy's x, v and forces, into
   (xn, vn) as gs__xpbd_fin1 does, with the same checks and boxes;
   pinned particles keep their place and come out at rest. */
GS__PRIVATE void gs__sym_fin1(gs__mesh *m, size_t i, size_t end, size_t k, double h, gs__fin *f) {
    size_t st = gs__soa_stride((size_t)m->n);
    double *X = m->soa, *Y = X + st, *Z = Y + st, *VX = Z + st, *VY = VX + st, *VZ = VY + st;
    double *FX = VZ + st, *FY = FX + st, *FZ = FY + st;
    const double *im = m->inv_mass;
    gs_vec3 g = m->base.world->gravity;
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    double vm = 0.0, w2 = f->w2, sum = f->sum;
    for (; i < end; ++i) {
        gs_vec3 p = gs__v3(X[i], Y[i], Z[i]), v = gs__v3(0.0, 0.0, 0.0);
        if (im[i] > 0.0) {
            v.x = VX[i] + ((g.x + VX[i] * -m->air) + im[i] * FX[i]) * h;
            v.y = VY[i] + ((g.y + VY[i] * -m->air) + im[i] * FY[i]) * h;
            v.z = VZ[i] + ((g.z + VZ[i] * -m->air) + im[i] * FZ[i]) * h;
            p = gs__v3(p.x + v.x * h, p.y + v.y * h, p.z + v.z * h);
        }
        m->xn[i] = p;
        m->vn[i] = v;
        if (m->pred_next) {
            X[i] = p.x; Y[i] = p.y; Z[i] = p.z;
            VX[i] = v.x; VY[i] = v.y; VZ[i] = v.z;
            FX[i] = FY[i] = FZ[i] = 0.0;
        }
        gs__fin_take(p, v, &w2, &sum, &vm, lo, hi);
    }
    f->w2 = w2;
    f->sum = sum;
    gs__fin_box(m, k, lo, hi, vm, f);
}

#ifdef GS__MESH_AVX
/* gs__sym_fin1 four particles at a time over one whole box; the speed
   and the sum per lane, as in gs__xpbd_fin4. */
__attribute__((target("avx"))) GS__PRIVATE void gs__sym_fin4(gs__mesh *m, size_t i, size_t k, double h,
                                                             gs__fin *f) {
    size_t st = gs__soa_stride((size_t)m->n), end = i + GS__CHUNK;
    double *X = m->soa, *Y = X + st, *Z = Y + st, *VX = Z + st, *VY = VX + st, *VZ = VY + st;
    double *FX = VZ + st, *FY = FX + st, *FZ = FY + st, *xn = &m->xn[0].x, *vn = &m->vn[0].x;
    gs_vec3 g = m->base.world->gravity;
    __m256d hv = _mm256_set1_pd(h), nair = _mm256_set1_pd(-m->air), zero = _mm256_setzero_pd();
    __m256d gx = _mm256_set1_pd(g.x), gy = _mm256_set1_pd(g.y), gz = _mm256_set1_pd(g.z);
    __m256d sign = _mm256_set1_pd(-0.0), w2 = _mm256_set1_pd(f->w2), vm = zero, sum = zero, nan = zero;
    __m256d lx = _mm256_set1_pd(HUGE_VAL), ly = lx, lz = lx, hx = _mm256_set1_pd(-HUGE_VAL), hy = hx, hz = hx;
    for (; i < end; i += 4) {
        __m256d im = _mm256_loadu_pd(m->inv_mass + i), free = _mm256_cmp_pd(im, zero, _CMP_GT_OQ);
        __m256d vx = _mm256_loadu_pd(VX + i), vy = _mm256_loadu_pd(VY + i), vz = _mm256_loadu_pd(VZ + i);
        __m256d px = _mm256_loadu_pd(X + i), py = _mm256_loadu_pd(Y + i), pz = _mm256_loadu_pd(Z + i);
        __m256d s2, ax, ay, az;
        vx = _mm256_and_pd(free, _mm256_add_pd(vx, _mm256_mul_pd(_mm256_add_pd(_mm256_add_pd(gx, _mm256_mul_pd(vx, nair)), _mm256_mul_pd(im, _mm256_loadu_pd(FX + i))), hv)));
        vy = _mm256_and_pd(free, _mm256_add_pd(vy, _mm256_mul_pd(_mm256_add_pd(_mm256_add_pd(gy, _mm256_mul_pd(vy, nair)), _mm256_mul_pd(im, _mm256_loadu_pd(FY + i))), hv)));
        vz = _mm256_and_pd(free, _mm256_add_pd(vz, _mm256_mul_pd(_mm256_add_pd(_mm256_add_pd(gz, _mm256_mul_pd(vz, nair)), _mm256_mul_pd(im, _mm256_loadu_pd(FZ + i))), hv)));
        px = _mm256_blendv_pd(px, _mm256_add_pd(px, _mm256_mul_pd(vx, hv)), free);
        py = _mm256_blendv_pd(py, _mm256_add_pd(py, _mm256_mul_pd(vy, hv)), free);
        pz = _mm256_blendv_pd(pz, _mm256_add_pd(pz, _mm256_mul_pd(vz, hv)), free);
        s2 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(vx, vx), _mm256_mul_pd(vy, vy)), _mm256_mul_pd(vz, vz));
        ax = _mm256_andnot_pd(sign, vx); ay = _mm256_andnot_pd(sign, vy); az = _mm256_andnot_pd(sign, vz);
        w2 = _mm256_max_pd(s2, w2);
        nan = _mm256_or_pd(nan, _mm256_cmp_pd(s2, s2, _CMP_UNORD_Q));
        sum = _mm256_add_pd(sum, _mm256_add_pd(_mm256_add_pd(px, py), pz));
        vm = _mm256_max_pd(_mm256_max_pd(az, _mm256_max_pd(ax, ay)), vm);
        lx = _mm256_min_pd(px, lx); ly = _mm256_min_pd(py, ly); lz = _mm256_min_pd(pz, lz);
        hx = _mm256_max_pd(px, hx); hy = _mm256_max_pd(py, hy); hz = _mm256_max_pd(pz, hz);
        gs__st_aos4(xn + 3 * i, px, py, pz);
        gs__st_aos4(vn + 3 * i, vx, vy, vz);
        if (m->pred_next) {
            _mm256_storeu_pd(X + i, px); _mm256_storeu_pd(Y + i, py); _mm256_storeu_pd(Z + i, pz);
            _mm256_storeu_pd(VX + i, vx); _mm256_storeu_pd(VY + i, vy); _mm256_storeu_pd(VZ + i, vz);
            _mm256_storeu_pd(FX + i, zero); _mm256_storeu_pd(FY + i, zero); _mm256_storeu_pd(FZ + i, zero);
        }
    }
    gs__fin_lanes(m, k, w2, nan, sum, vm, lx, ly, lz, hx, hy, hz, f);
}
#endif

/* Symplectic Euler through the transposed copy: copy in (unless the last
   substep left it there), contact forces, the runs, then the end box by
   box. */
GS__PRIVATE void gs__int_symplectic_runs(gs__mesh *m, double h) {
    size_t n = (size_t)m->n, st = gs__soa_stride(n), i, k;
    double *X = m->soa, *Y = X + st, *Z = Y + st, *VX = Z + st, *VY = VX + st, *VZ = VY + st;
    double *FX = VZ + st, *FY = FX + st, *FZ = FY + st;
    gs__fin f;
    int r;
    if (!m->pred_ready)
        for (i = 0; i < n; ++i) {
            X[i] = m->x[i].x; Y[i] = m->x[i].y; Z[i] = m->x[i].z;
            VX[i] = m->v[i].x; VY[i] = m->v[i].y; VZ[i] = m->v[i].z;
            FX[i] = FY[i] = FZ[i] = 0.0;
        }
    m->pred_ready = 0;
    for (r = 0; m->ext_active && r < m->ntouched; ++r) { /* ext is zero elsewhere */
        i = (size_t)m->touched[r];
        FX[i] = m->ext[i].x; FY[i] = m->ext[i].y; FZ[i] = m->ext[i].z;
    }
    for (r = 0; r < m->nruns; ++r) {
#ifdef GS__MESH_AVX
        if (m->avx) {
            gs__sym_run4(m, &m->runs[r]);
            continue;
        }
#endif
        gs__sym_run1(m, &m->runs[r], 0);
    }
    gs__fin_start(&f, h);
    for (k = 0, i = 0; i < n; ++k, i += GS__CHUNK) {
#ifdef GS__MESH_AVX
        if (m->avx && i + GS__CHUNK <= n) {
            gs__sym_fin4(m, i, k, h, &f);
            continue;
        }
#endif
        gs__sym_fin1(m, i, i + GS__CHUNK < n ? i + GS__CHUNK : n, k, h, &f);
    }
    gs__fin_done(m, &f);
}

/* ---- stepping ---- */

/* Every new speed at most max_speed and every new position finite and in
   range, within GS_MAX_COORD (anything else means the step blew up), and
   the bounding box of the new positions for the broad phase, in the one
   pass that reads them: the box in range is every position in range. */
GS__PRIVATE int gs__mesh_sane(gs__mesh *m) {
    double vmax2 = m->solver.max_speed * m->solver.max_speed, sum = 0.0, w2 = 0.0;
    const gs_vec3 *xn = m->xn, *vn = m->vn;
    gs_vec3 lo = xn[0], hi = xn[0], r;
    int i;
    for (i = 0; i < m->n; ++i) {
        double s2 = vn[i].x * vn[i].x + vn[i].y * vn[i].y + vn[i].z * vn[i].z;
        w2 = s2 > w2 ? s2 : w2;
        w2 = s2 == s2 ? w2 : s2; /* a NaN speed stays NaN */
        sum += xn[i].x + xn[i].y + xn[i].z;
        lo.x = xn[i].x < lo.x ? xn[i].x : lo.x;
        lo.y = xn[i].y < lo.y ? xn[i].y : lo.y;
        lo.z = xn[i].z < lo.z ? xn[i].z : lo.z;
        hi.x = xn[i].x > hi.x ? xn[i].x : hi.x;
        hi.y = xn[i].y > hi.y ? xn[i].y : hi.y;
        hi.z = xn[i].z > hi.z ? xn[i].z : hi.z;
    }
    if (!(w2 <= vmax2) || !gs__finite(sum) || !gs__in_range3(lo) || !gs__in_range3(hi))
        return 0;
    r = gs__v3(m->radius, m->radius, m->radius);
    m->lo = gs__sub(lo, r);
    m->hi = gs__add(hi, r);
    return 1;
}

GS__PRIVATE void gs__mesh_contacts(gs__mesh *m, double t);
GS__PRIVATE void gs__mesh_update_bounds(gs__mesh *m);
GS__PRIVATE void gs__mesh_chunks(gs__mesh *m);

/* After x or v change: the boxes of the contacts' broad phase follow them
   where a body could ask (gs__rigid_vs_mesh), else they are marked stale
   and made when asked. */
GS__PRIVATE void gs__mesh_keep_chunks(gs__mesh *m) {
    if (m->base.world->nbodies > 0)
        gs__mesh_chunks(m);
    else
        m->chunks_ok = 0;
}

/* One integrator step of h seconds starting at simulation time t0. */
GS__PRIVATE gs_result gs__mesh_substep(gs__mesh *m, double t0, double h) {
    gs_vec3 *t;
    int i;
    gs__mesh_contacts(m, t0);
    m->checked = 0;
    m->chunks_next = 0;
    switch (m->solver.integrator) {
    case GS_INTEGRATOR_EXPLICIT_EULER: gs__int_explicit_euler(m, h); break;
    case GS_INTEGRATOR_VERLET: gs__int_verlet(m, h); break;
    case GS_INTEGRATOR_RK4: gs__int_rk4(m, h); break;
    case GS_INTEGRATOR_IMPLICIT_EULER: gs__int_implicit_euler(m, h); break;
    case GS_INTEGRATOR_XPBD: gs__int_xpbd(m, h); break;
    default: gs__int_symplectic_euler(m, h); break;
    }
    for (i = 0; i < m->npins; ++i) {
        m->xn[m->pins[i]] = m->x[m->pins[i]];
        m->vn[m->pins[i]] = gs__v3(0.0, 0.0, 0.0);
    }
    if (m->chunks_next) m->chunks_ok = 0; /* they are the new state's, which may fail */
    if (!(m->checked ? m->check_ok : gs__mesh_sane(m)))
        return gs__fail(m->base.world, GS_ERR_UNSTABLE,
                        "%s agent %d: a step of %g s blew up (non-finite "
                        "state or a speed over %g m/s); state kept",
                        m->base.kind->name, m->base.index, h,
                        m->solver.max_speed);
    t = m->x; m->x = m->xn; m->xn = t;
    t = m->v; m->v = m->vn; m->vn = t;
    if (m->chunks_next)
        m->chunks_ok = 1;
    else
        gs__mesh_keep_chunks(m);
    return GS_OK;
}

/* How many substeps a step of dt needs to stay under the stability bound. */
GS__PRIVATE int gs__world_has_contacts(const gs_world *w);

GS__PRIVATE gs_result gs__mesh_plan(gs__mesh *m, double dt, int *n_sub) {
    double lim = (gs__world_has_contacts(m->base.world) ? m->stable_dt_contact
                                                        : m->stable_dt) *
                 m->solver.safety, k;
    *n_sub = m->solver.integrator == GS_INTEGRATOR_XPBD ? m->solver.substeps : 1;
    if (m->solver.integrator == GS_INTEGRATOR_XPBD) return GS_OK; /* stable at any step */
    if (m->solver.integrator == GS_INTEGRATOR_IMPLICIT_EULER ||
        m->solver.stability == GS_STABILITY_UNCHECKED || dt <= lim)
        return GS_OK;
    if (m->solver.stability == GS_STABILITY_REFUSE)
        return gs__fail(m->base.world, GS_ERR_UNSTABLE,
                        "%s agent %d: dt %g s exceeds the stable step %g s "
                        "(stability = refuse)",
                        m->base.kind->name, m->base.index, dt, lim);
    k = ceil(dt / lim);
    if (k > (double)m->solver.max_substeps)
        return gs__fail(m->base.world, GS_ERR_UNSTABLE,
                        "%s agent %d: dt %g s needs %.0f substeps of the "
                        "stable step %g s, max_substeps is %d",
                        m->base.kind->name, m->base.index, dt, k, lim,
                        m->solver.max_substeps);
    *n_sub = (int)k;
    return GS_OK;
}

/* A substepped step keeps the state it started from: after the first
   substep that state sits in the spare buffers (x0, v0) and the substeps
   alternate between the other two, so undoing a failed step is a pointer
   swap, not a copy. */
GS__PRIVATE void gs__mesh_park(gs__mesh *m, const gs_vec3 *x_start) {
    gs_vec3 *t;
    if (m->xn != x_start) return;
    t = m->xn; m->xn = m->x0; m->x0 = t;
    t = m->vn; m->vn = m->v0; m->v0 = t;
}

/* A whole mesh sleeps as a rigid body does (gs__rigid_rest): every free
   particle slower than sleep_speed for sleep_time, no moving probe on it
   (probe_touch, set by its contacts), inside an advance. Not under a
   ghost: the blend of a cloth, still or not, moves every particle by a
   little, each one a wake, and a cloth that sleeps between blends lagged
   its peers (test_ghost's latency trap). */
GS__PRIVATE void gs__mesh_rest(gs__mesh *m, double dt) {
    const gs_world *w = m->base.world;
    double s2 = w->sleep_speed * w->sleep_speed;
    int i, still = w->sleep_time >= 0.0 && !m->probe_touch && (!m->base.ghost || m->base.hold);
    if (!w->busy) return;
    if (m->base.hold) m->base.rest = w->sleep_time;
    m->base.hold = 0;
    for (i = 0; still && i < m->n; ++i) still = gs__dot(m->v[i], m->v[i]) < s2;
    if (!still) {
        m->base.rest = 0.0;
        return;
    }
    m->base.rest += dt;
    if (m->base.rest < w->sleep_time) return;
    m->base.sleeping = 1;
    m->base.stats.sleeps++;
    memset(m->v, 0, (size_t)m->n * sizeof *m->v);
}

GS__PRIVATE gs_result gs__mesh_step(gs_agent *a, double dt) {
    gs__mesh *m = (gs__mesh *)a;
    const gs_vec3 *x_start = m->x;
    gs_vec3 lo = m->lo, hi = m->hi, *t;
    int n_sub, i;
    gs_result r = gs__mesh_plan(m, dt, &n_sub);
    m->probe_touch = 0;
    m->pred_ready = 0; /* the state may have been set or blended since */
    if (r != GS_OK) return r;
    for (i = 0; i < n_sub; ++i) {
        m->pred_next = i + 1 < n_sub;
        r = gs__mesh_substep(m, gs__agent_time(a) + i * (dt / n_sub), dt / n_sub);
        if (r == GS_OK) {
            if (n_sub > 1) gs__mesh_park(m, x_start);
            continue;
        }
        if (i > 0) { /* the start is parked in x0: swap it back */
            t = m->x; m->x = m->x0; m->x0 = t;
            t = m->v; m->v = m->v0; m->v0 = t;
            m->lo = lo; /* the broad phase must see the undone state */
            m->hi = hi;
            gs__mesh_keep_chunks(m);
        }
        return r;
    }
    a->stats.substeps += (uint64_t)n_sub;
    gs__mesh_rest(m, dt);
    return GS_OK;
}

/* ---- state ---- */
GS__PRIVATE size_t gs__mesh_state_size(const gs_agent *a) {
    return 6 * (size_t)((const gs__mesh *)a)->n;
}

GS__PRIVATE void gs__mesh_get_state(const gs_agent *a, double *out) {
    const gs__mesh *m = (const gs__mesh *)a;
    memcpy(out, m->x, (size_t)m->n * sizeof(gs_vec3));
    memcpy(out + 3 * m->n, m->v, (size_t)m->n * sizeof(gs_vec3));
}

/* Pinned particles take the position given and keep zero velocity. */
GS__PRIVATE gs_result gs__mesh_set_state(gs_agent *a, const double *in) {
    gs__mesh *m = (gs__mesh *)a;
    int i;
    for (i = 0; i < m->n; ++i)
        if (!gs__in_range3(gs__v3(in[3 * i], in[3 * i + 1], in[3 * i + 2])))
            return gs__fail(a->world, GS_ERR_OUT_OF_RANGE,
                            "gs_agent_set_state: particle %d at (%g, %g, %g) m "
                            "is outside +-GS_MAX_COORD (%g m)", i, in[3 * i],
                            in[3 * i + 1], in[3 * i + 2], GS_MAX_COORD);
    memcpy(m->x, in, (size_t)m->n * sizeof(gs_vec3));
    memcpy(m->v, in + 3 * m->n, (size_t)m->n * sizeof(gs_vec3));
    for (i = 0; i < m->npins; ++i) m->v[m->pins[i]] = gs__v3(0.0, 0.0, 0.0);
    gs__mesh_update_bounds(m);
    return GS_OK;
}

GS__PRIVATE uint64_t gs__mesh_hash(const gs_agent *a, uint64_t h) {
    const gs__mesh *m = (const gs__mesh *)a;
    h = gs__fnv(h, m->x, (size_t)m->n * sizeof(gs_vec3));
    return gs__fnv(h, m->v, (size_t)m->n * sizeof(gs_vec3));
}

/* Dead reckoning of a mesh: a rigid translation by its mean velocity, since
   its particles' own velocities carry its vibrations. */
GS__PRIVATE void gs__mesh_extrapolate(const gs_agent *a, double *s, double dt) {
    size_t n = (size_t)((const gs__mesh *)a)->n, i;
    double mx = 0.0, my = 0.0, mz = 0.0;
    for (i = 0; i < n; ++i) {
        mx += s[3 * n + 3 * i];
        my += s[3 * n + 3 * i + 1];
        mz += s[3 * n + 3 * i + 2];
    }
    mx *= dt / (double)n; my *= dt / (double)n; mz *= dt / (double)n;
    for (i = 0; i < n; ++i) {
        s[3 * i] += mx;
        s[3 * i + 1] += my;
        s[3 * i + 2] += mz;
    }
}

GS__PRIVATE size_t gs__mesh_positions(const gs_agent *a) {
    return 3 * (size_t)((const gs__mesh *)a)->n;
}

static const gs__kind gs__mesh_kind = {
    "mesh", gs__mesh_step, gs__mesh_state_size, gs__mesh_get_state,
    gs__mesh_set_state, gs__mesh_hash, gs__mesh_extrapolate, gs__mesh_positions};
static const gs__kind gs__cloth_kind = {
    "cloth", gs__mesh_step, gs__mesh_state_size, gs__mesh_get_state,
    gs__mesh_set_state, gs__mesh_hash, gs__mesh_extrapolate, gs__mesh_positions};

GS__PRIVATE gs__mesh *gs__as_mesh(const gs_agent *a) {
    if (!a || (a->kind != &gs__mesh_kind && a->kind != &gs__cloth_kind))
        return NULL;
    return (gs__mesh *)a;
}

/* ---- building ---- */

/* q = K p for the springs linearized about the positions (k u u^T each: a
   spring at its rest length has no geometric stiffness), pinned rows and
   columns removed; returns p . K p. With `damping`, the same for the
   damping matrix D (c u u^T). */
GS__PRIVATE double gs__mesh_stiffness_apply(const gs__mesh *m, const gs_vec3 *p,
                                            gs_vec3 *q, int damping) {
    double pkp = 0.0;
    int i;
    memset(q, 0, (size_t)m->n * sizeof *q);
    for (i = 0; i < m->ns; ++i) {
        const gs__spring *s = &m->springs[i];
        gs_vec3 d = gs__sub(m->x[s->b], m->x[s->a]);
        double l = gs__len(d), e, w;
        if (!(l > 0.0)) continue;
        d = gs__scale(d, 1.0 / l);
        e = gs__dot(d, gs__sub(p[s->b], p[s->a]));
        w = (damping ? s->c : s->k) * e;
        pkp += w * e;
        q[s->a] = gs__madd(q[s->a], d, -w);
        q[s->b] = gs__madd(q[s->b], d, w);
    }
    for (i = 0; i < m->npins; ++i) q[m->pins[i]] = gs__v3(0.0, 0.0, 0.0);
    return pkp;
}

/* The highest omega^2 of M^-1 K by power iteration (Rayleigh quotient
   p.Kp / p.Mp, which approaches it from below), from a seeded start, until
   it changes by under 1e-4 relative, times 1.15: it stalls a little below
   the top of a cloth's dense spectrum, and a stiff cloth in motion runs up
   to 6% (in dt) past its rest frequency, measured; so symplectic Euler's
   step comes out 0-8% under the measured limit (m->gamma gets that mode's
   damping rate p.Dp / p.Mp); 0 when it does not within an
   iteration budget of about 2e7 spring visits (then Gershgorin's bound
   stands). A cloth's Gershgorin bound is 1.4-1.5x too cautious in dt; this
   one is cached, since only creation and pinning change it. xn and vn are
   scratch: this runs before the first step. */
GS__PRIVATE double gs__mesh_power_omega2(gs__mesh *m) {
    gs_vec3 *p = m->xn, *q = m->vn;
    uint32_t seed = 0x9e3779b9u;
    double lam = 0.0, prev = 0.0;
    int i, it, iters = m->ns > 0 ? (int)(2e7 / m->ns) : 0;
    if (iters > 200) iters = 200;
    for (i = 0; i < m->n; ++i) {
        double r[3];
        int c;
        for (c = 0; c < 3; ++c) {
            seed = seed * 1664525u + 1013904223u;
            r[c] = (double)(seed >> 8) / 8388608.0 - 1.0;
        }
        p[i] = m->pinned[i] ? gs__v3(0.0, 0.0, 0.0) : gs__v3(r[0], r[1], r[2]);
    }
    for (it = 0; it < iters; ++it) {
        double pkp = gs__mesh_stiffness_apply(m, p, q, 0), pmp = 0.0, qq = 0.0;
        for (i = 0; i < m->n; ++i) pmp += m->mass[i] * gs__dot(p[i], p[i]);
        if (!(pmp > 0.0) || !(pkp > 0.0)) return 0.0;
        lam = pkp / pmp;
        if (it > 8 && fabs(lam - prev) <= 1e-4 * lam) {
            /* that mode's own damping rate */
            m->gamma = gs__mesh_stiffness_apply(m, p, q, 1) / pmp;
            return 1.15 * lam;
        }
        prev = lam;
        for (i = 0; i < m->n; ++i) {
            q[i] = gs__scale(q[i], m->inv_mass[i]);
            qq += gs__dot(q[i], q[i]);
        }
        qq = 1.0 / sqrt(qq);
        for (i = 0; i < m->n; ++i) p[i] = gs__scale(q[i], qq);
    }
    return 0.0;
}

GS__PRIVATE double gs__mesh_bound(gs__mesh *m, double contact_k, double contact_c);

/* Refreshes the cached frequency and both stable steps; for creation and
   pinning, which are all that change the springs' matrix. */
GS__PRIVATE void gs__mesh_refresh_bounds(gs__mesh *m) {
    m->omega2 = m->solver.integrator == GS_INTEGRATOR_IMPLICIT_EULER ||
                        m->solver.integrator == GS_INTEGRATOR_XPBD
                    ? 0.0
                    : gs__mesh_power_omega2(m);
    memset(m->xn, 0, (size_t)m->n * sizeof *m->xn);
    memset(m->vn, 0, (size_t)m->n * sizeof *m->vn);
    m->stable_dt = gs__mesh_bound(m, 0.0, 0.0);
    m->stable_dt_contact = gs__mesh_bound(m, m->mat.stiffness, m->mat.damping);
}

/* The largest stable explicit step. Per free particle i, Gershgorin on
   M^-1 K bounds omega^2 by (sum of k over its springs, plus k again for each
   spring to a free particle) / m_i, and the damping rate gamma likewise (plus
   air). Symplectic Euler on x'' = -w^2 x - g x' is stable for
   h^2 w^2 + 2 h g < 4, i.e. h < 4 / (g + sqrt(g^2 + 4 w^2)); Verlet and
   explicit Euler get the same bound, RK4 1.39 times it (its stability region
   reaches 2.78 on the real axis, 2.83 on the imaginary one). */
GS__PRIVATE double gs__mesh_bound(gs__mesh *m, double contact_k,
                                  double contact_c) {
    double w2 = 0.0, g = 0.0, h;
    int i;
    if (m->solver.integrator == GS_INTEGRATOR_IMPLICIT_EULER) return HUGE_VAL;
    if (m->solver.integrator == GS_INTEGRATOR_XPBD) return HUGE_VAL; /* contacts too */
    for (i = 0; i < m->n; ++i) m->acc[i] = gs__v3(contact_k, contact_c, 0.0);
    for (i = 0; m->solver.integrator != GS_INTEGRATOR_XPBD && i < m->ns; ++i) {
        /* acc as scratch: x = sum k, y = sum c */
        const gs__spring *s = &m->springs[i];
        double fa = m->pinned[s->b] ? 1.0 : 2.0, fb = m->pinned[s->a] ? 1.0 : 2.0;
        m->acc[s->a].x += fa * s->k; m->acc[s->a].y += fa * s->c;
        m->acc[s->b].x += fb * s->k; m->acc[s->b].y += fb * s->c;
    }
    for (i = 0; i < m->n; ++i) {
        if (m->pinned[i]) continue;
        if (m->acc[i].x * m->inv_mass[i] > w2) w2 = m->acc[i].x * m->inv_mass[i];
        if (m->acc[i].y * m->inv_mass[i] > g) g = m->acc[i].y * m->inv_mass[i];
    }
    g += m->air;
    if (m->omega2 > 0.0) { /* the power iteration's, plus the contacts' (Weyl) */
        double imax = 0.0;
        for (i = 0; i < m->n; ++i) imax = m->inv_mass[i] > imax ? m->inv_mass[i] : imax;
        if (m->omega2 + contact_k * imax < w2) {
            w2 = m->omega2 + contact_k * imax;
            g = m->gamma + contact_c * imax + m->air;
        }
    }
    if (w2 == 0.0 && g == 0.0) return HUGE_VAL;
    h = 4.0 / (g + sqrt(g * g + 4.0 * w2));
    return m->solver.integrator == GS_INTEGRATOR_RK4 ? 1.39 * h : h;
}

/* Allocates a mesh with room for n particles, ns springs, npins pins. */
GS__PRIVATE gs_result gs__mesh_new(gs_world *w, const gs__kind *kind, int n,
                                   int ns, int npins,
                                   const gs_solver_desc *solver,
                                   gs__mesh **out) {
    gs__mesh shape, *m;
    gs__carver cv;
    gs_result r;
    memset(&shape, 0, sizeof shape);
    shape.n = n; shape.ns = ns; shape.npins = npins;
    shape.solver = *solver;
    cv.base = NULL;
    cv.used = (sizeof(gs__mesh) + 15) & ~(size_t)15;
    gs__mesh_layout(&shape, &cv);
    m = (gs__mesh *)gs__alloc(w, cv.used);
    if (!m)
        return gs__fail(w, GS_ERR_NO_MEMORY, "%s: out of memory (%lu bytes)",
                        kind->name, (unsigned long)cv.used);
    *m = shape;
    cv.base = (char *)m;
    cv.used = (sizeof(gs__mesh) + 15) & ~(size_t)15;
    gs__mesh_layout(m, &cv);
    memset(cv.base + sizeof(gs__mesh), 0, cv.used - sizeof(gs__mesh));
    m->row = 0;
    r = gs__agent_init(w, &m->base, kind, solver->dt);
    if (r != GS_OK) {
        gs__free(w, m);
        return r;
    }
    w->nmeshes++;
    *out = m;
    return GS_OK;
}

/* Greedy colouring in spring order: each spring takes the first colour
   that neither end has; a particle with 64 colours sends the rest to the
   serial batch. */
GS__PRIVATE void gs__mesh_colour(gs__mesh *m, int *count) {
    int i;
    memset(m->colours, 0, (size_t)m->n * sizeof *m->colours);
    for (i = 0; i < GS__MESH_BATCHES; ++i) count[i] = 0;
    for (i = 0; i < m->ns; ++i) {
        int a = m->springs[i].a, b = m->springs[i].b, c = 0;
        uint64_t used = m->colours[a] | m->colours[b];
        while (c < GS__MESH_BATCHES - 1 && (used >> c & 1u)) ++c;
        if (c < GS__MESH_BATCHES - 1) {
            m->colours[a] |= (uint64_t)1 << c;
            m->colours[b] |= (uint64_t)1 << c;
        }
        m->perm[i] = c;
        count[c]++;
    }
}

/* Orders the springs by colour, stably (in place: perm becomes each
   spring's destination, then its cycles are followed). */
GS__PRIVATE void gs__mesh_batch(gs__mesh *m) {
    int count[GS__MESH_BATCHES], next[GS__MESH_BATCHES], i, c;
    gs__mesh_colour(m, count);
    m->nbatch = 0;
    for (c = 0, i = 0; c < GS__MESH_BATCHES; ++c) {
        if (count[c] == 0) continue;
        m->batch[m->nbatch++] = i;
        next[c] = i;
        i += count[c];
    }
    m->batch[m->nbatch] = m->ns;
    for (i = 0; i < m->ns; ++i) m->perm[i] = next[m->perm[i]]++;
    for (i = 0; i < m->ns; ++i)
        while (m->perm[i] != i) {
            int j = m->perm[i];
            gs__spring t = m->springs[j];
            m->springs[j] = m->springs[i];
            m->springs[i] = t;
            m->perm[i] = m->perm[j];
            m->perm[j] = j;
        }
}

/* After the arrays are filled: rest lengths, inverse masses, pins, the
   stability bound. `pins` may hold duplicates; they are merged. */
GS__PRIVATE void gs__mesh_finish(gs__mesh *m, const int *pins, int npins) {
    int i, k = 0;
    for (i = 0; i < m->ns; ++i) {
        gs__spring *s = &m->springs[i];
        if (s->rest == 0.0) s->rest = gs__len(gs__sub(m->x[s->b], m->x[s->a]));
    }
    for (i = 0; i < npins; ++i) {
        if (m->pinned[pins[i]]) continue;
        m->pinned[pins[i]] = 1;
        m->pins[k++] = pins[i];
    }
    m->npins = k;
    gs__mesh_find_runs(m);
    if (m->xblk && m->nruns > 0) gs__xpbd_schedule(m);
    if (m->nruns == 0) gs__mesh_batch(m);
    for (i = 0; i < m->n; ++i) {
        m->inv_mass[i] = m->pinned[i] ? 0.0 : 1.0 / m->mass[i];
        if (m->pinned[i]) m->v[i] = gs__v3(0.0, 0.0, 0.0);
    }
    gs__mesh_refresh_bounds(m);
    gs__mesh_update_bounds(m);
}

/* Element `i` of array `what` fails a check: the message names it. */
GS__PRIVATE void gs__check_item(gs__check *c, gs_result r, const char *what,
                                int i, const char *field, double v,
                                const char *rule) {
    gs__check_fail(c, r, "%s[%d]%s%s is %g, %s", what, i, *field ? "." : "",
                   field, v, rule);
}

GS__PRIVATE void gs__check_mesh_springs(gs__check *c, const gs_mesh_desc *d) {
    int i;
    if (d->spring_count > 0 && !d->springs)
        gs__check_fail(c, GS_ERR_INVALID_ARG, "springs is NULL");
    for (i = 0; c->r == GS_OK && i < d->spring_count; ++i) {
        const gs_spring *s = &d->springs[i];
        gs__check_index(c, "springs[].a of spring", i, s->a, d->particle_count);
        gs__check_index(c, "springs[].b of spring", i, s->b, d->particle_count);
        if (c->r != GS_OK) break;
        if (s->a == s->b)
            gs__check_item(c, GS_ERR_INVALID_ARG, "springs", i, "b", s->b,
                           "the same particle as a");
        if (!gs__finite(s->rest_length) || !gs__finite(s->stiffness) ||
            !gs__finite(s->damping))
            gs__check_item(c, GS_ERR_NOT_FINITE, "springs", i,
                           "rest_length, stiffness or damping", NAN,
                           "must be finite");
        if (!(s->stiffness > 0.0))
            gs__check_item(c, GS_ERR_INVALID_ARG, "springs", i, "stiffness",
                           s->stiffness, "must be > 0");
        if (s->damping < 0.0 || s->rest_length < 0.0)
            gs__check_item(c, GS_ERR_INVALID_ARG, "springs", i,
                           s->damping < 0.0 ? "damping" : "rest_length",
                           s->damping < 0.0 ? s->damping : s->rest_length,
                           "must be >= 0");
        /* two points in range are at most 2 sqrt(3) GS_MAX_COORD apart */
        if (c->r == GS_OK && s->rest_length > 4.0 * GS_MAX_COORD)
            gs__check_item(c, GS_ERR_OUT_OF_RANGE, "springs", i, "rest_length",
                           s->rest_length, "must be at most 4 GS_MAX_COORD");
        if (c->r == GS_OK && s->rest_length == 0.0 &&
            gs__len(gs__sub(d->positions[s->a], d->positions[s->b])) == 0.0)
            gs__check_item(c, GS_ERR_INVALID_ARG, "springs", i, "rest_length",
                           0.0, "and its ends coincide: no rest length");
    }
}

GS__PRIVATE void gs__check_pins(gs__check *c, const int *pins, int count,
                                int n) {
    int i;
    if (count < 0)
        gs__check_fail(c, GS_ERR_INVALID_ARG, "pin_count is %d, must be >= 0",
                       count);
    if (count > 0 && !pins)
        gs__check_fail(c, GS_ERR_INVALID_ARG, "pins is NULL");
    for (i = 0; c->r == GS_OK && i < count; ++i)
        gs__check_index(c, "pins[] entry", i, pins[i], n);
}

GS__PRIVATE void gs__check_mesh_particles(gs__check *c,
                                          const gs_mesh_desc *d) {
    int i;
    gs__check_int(c, "particle_count", d->particle_count, 1, 1L << 24);
    if (!d->positions)
        gs__check_fail(c, GS_ERR_INVALID_ARG, "positions is NULL");
    if (c->r != GS_OK) return;
    for (i = 0; i < d->particle_count && c->r == GS_OK; ++i) {
        if (!gs__finite3(d->positions[i]))
            gs__check_item(c, GS_ERR_NOT_FINITE, "positions", i, "", NAN,
                           "must be finite");
        else if (!gs__in_range3(d->positions[i]))
            gs__check_item(c, GS_ERR_OUT_OF_RANGE, "positions", i,
                           " largest coordinate", gs__max_abs3(d->positions[i]),
                           "must be within +-GS_MAX_COORD");
        if (d->velocities && !gs__finite3(d->velocities[i]))
            gs__check_item(c, GS_ERR_NOT_FINITE, "velocities", i, "", NAN,
                           "must be finite");
        if (d->masses && !gs__finite(d->masses[i]))
            gs__check_item(c, GS_ERR_NOT_FINITE, "masses", i, "", d->masses[i],
                           "must be finite");
        if (d->masses && gs__finite(d->masses[i]) && d->masses[i] <= 0.0)
            gs__check_item(c, GS_ERR_INVALID_ARG, "masses", i, "", d->masses[i],
                           "must be > 0");
        if (d->masses && !gs__finite(1.0 / d->masses[i]))
            gs__check_item(c, GS_ERR_OUT_OF_RANGE, "masses", i, "", d->masses[i],
                           "has no finite inverse");
    }
}

GS_API gs_mesh_desc gs_mesh_desc_default(void) {
    gs_mesh_desc d;
    memset(&d, 0, sizeof d);
    d.mass = 1.0;
    d.solver = gs_solver_desc_default();
    return d;
}

GS__PRIVATE gs_mesh_desc gs__mesh_defaults(const gs_mesh_desc *in) {
    gs_mesh_desc d = *in;
    if (d.mass == 0.0) d.mass = 1.0;
    if (d.particle_radius == 0.0) d.particle_radius = 0.01;
    d.material = gs__material_defaults(d.material);
    d.solver = gs__solver_defaults(d.solver);
    return d;
}

/* mass / count per particle: its inverse must be finite, or every step of
   that particle is inf * 0. */
GS__PRIVATE void gs__check_particle_mass(gs__check *c, double mass, int count) {
    if (c->r == GS_OK && count > 0 && !gs__finite(1.0 / (mass / count)))
        gs__check_fail(c, GS_ERR_OUT_OF_RANGE,
                       "mass is %g kg over %d particles: each particle's mass "
                       "has no finite inverse", mass, count);
}

GS__PRIVATE gs_result gs__mesh_check(gs_world *w, const gs_mesh_desc *d) {
    gs__check c = gs__check_begin(w, "gs_mesh_create");
    gs__check_mesh_particles(&c, d);
    gs__check_positive(&c, "mass", d->mass);
    gs__check_particle_mass(&c, d->mass, d->particle_count);
    gs__check_int(&c, "spring_count", d->spring_count, 0, 1L << 26);
    if (c.r == GS_OK) gs__check_mesh_springs(&c, d);
    if (c.r == GS_OK) gs__check_pins(&c, d->pins, d->pin_count, d->particle_count);
    gs__check_nonneg(&c, "air_damping", d->air_damping);
    gs__check_size(&c, "particle_radius", d->particle_radius);
    gs__check_material(&c, &d->material);
    gs__check_solver(&c, &d->solver);
    return c.r;
}

GS_API gs_result gs_mesh_create(gs_world *w, const gs_mesh_desc *desc,
                                gs_agent **out) {
    gs_mesh_desc d;
    gs__mesh *m = NULL; /* set by gs__mesh_new; GCC -O2 cannot tell when inlined */
    int i;
    gs_result r = gs__create_begin(w, desc, out, "gs_mesh_create");
    if (r != GS_OK) return r;
    d = gs__mesh_defaults(desc);
    r = gs__mesh_check(w, &d);
    if (r != GS_OK) return r;
    r = gs__mesh_new(w, &gs__mesh_kind, d.particle_count, d.spring_count,
                     d.pin_count, &d.solver, &m);
    if (r != GS_OK) return r;
    for (i = 0; i < m->n; ++i) {
        m->x[i] = d.positions[i];
        m->v[i] = d.velocities ? d.velocities[i] : gs__v3(0.0, 0.0, 0.0);
        m->mass[i] = d.masses ? d.masses[i] : d.mass / m->n;
    }
    for (i = 0; i < m->ns; ++i) {
        const gs_spring *s = &d.springs[i];
        m->springs[i].a = s->a;
        m->springs[i].b = s->b;
        m->springs[i].rest = s->rest_length;
        m->springs[i].k = s->stiffness;
        m->springs[i].c = s->damping;
    }
    m->air = d.air_damping;
    m->radius = d.particle_radius;
    m->mat = d.material;
    gs__mesh_finish(m, d.pins, d.pin_count);
    return gs__sync_added(w, &m->base, out);
}

/* ---- the cloth generator ---- */
GS_API gs_cloth_desc gs_cloth_desc_default(void) {
    gs_cloth_desc d;
    memset(&d, 0, sizeof d);
    d.nx = d.ny = 16;
    d.width = d.height = 1.0;
    d.axis_u = gs__v3(1.0, 0.0, 0.0);
    d.axis_v = gs__v3(0.0, 0.0, 1.0);
    d.mass = 1.0;
    d.springs = GS_SPRINGS_STRUCTURAL | GS_SPRINGS_SHEAR | GS_SPRINGS_BEND;
    d.stretch_stiffness = 1000.0;
    d.shear_stiffness = 100.0;
    d.bend_stiffness = 10.0;
    d.spring_damping = 0.02;
    d.air_damping = 0.1;
    d.solver = gs_solver_desc_default();
    return d;
}

GS__PRIVATE gs_cloth_desc gs__cloth_defaults(const gs_cloth_desc *in) {
    gs_cloth_desc def = gs_cloth_desc_default(), d = *in;
    if (d.nx == 0) d.nx = def.nx;
    if (d.ny == 0) d.ny = def.ny;
    if (d.width == 0.0) d.width = def.width;
    if (d.height == 0.0) d.height = def.height;
    if (gs__is_zero3(d.axis_u)) d.axis_u = def.axis_u;
    if (gs__is_zero3(d.axis_v)) d.axis_v = def.axis_v;
    if (d.mass == 0.0) d.mass = def.mass;
    if (d.springs == 0) d.springs = def.springs;
    if (d.stretch_stiffness == 0.0) d.stretch_stiffness = def.stretch_stiffness;
    if (d.shear_stiffness == 0.0) d.shear_stiffness = d.stretch_stiffness / 10.0;
    if (d.bend_stiffness == 0.0) d.bend_stiffness = d.stretch_stiffness / 100.0;
    if (d.spring_damping == 0.0) d.spring_damping = def.spring_damping;
    if (d.air_damping == 0.0) d.air_damping = def.air_damping;
    if (d.particle_radius == 0.0 && d.nx > 1 && d.ny > 1)
        d.particle_radius = 0.5 * fmin(d.width / (d.nx - 1), d.height / (d.ny - 1));
    d.material = gs__material_defaults(d.material);
    d.solver = gs__solver_defaults(d.solver);
    return d;
}

GS__PRIVATE void gs__check_axes(gs__check *c, gs_vec3 u, gs_vec3 v) {
    gs__check_vec(c, "axis_u", u);
    gs__check_vec(c, "axis_v", v);
    /* the cloth divides by their lengths and tests their cross product */
    if (c->r == GS_OK && !(gs__len(u) > 1e-100 && gs__len(u) < 1e100))
        gs__check_fail(c, GS_ERR_OUT_OF_RANGE, "axis_u has length %g, must "
                       "be in (1e-100, 1e100)", gs__len(u));
    if (c->r == GS_OK && !(gs__len(v) > 1e-100 && gs__len(v) < 1e100))
        gs__check_fail(c, GS_ERR_OUT_OF_RANGE, "axis_v has length %g, must "
                       "be in (1e-100, 1e100)", gs__len(v));
    if (c->r == GS_OK &&
        !(gs__len(gs__cross(u, v)) > 1e-9 * gs__len(u) * gs__len(v)))
        gs__check_fail(c, GS_ERR_INVALID_ARG,
                       "axis_u and axis_v are parallel: the cloth has no "
                       "plane");
}

GS__PRIVATE gs_result gs__cloth_check(gs_world *w, const gs_cloth_desc *d) {
    gs__check c = gs__check_begin(w, "gs_cloth_create");
    gs__check_int(&c, "nx", d->nx, 2, 4096);
    gs__check_int(&c, "ny", d->ny, 2, 4096);
    gs__check_size(&c, "width", d->width);
    gs__check_size(&c, "height", d->height);
    gs__check_pos(&c, "origin", d->origin);
    gs__check_axes(&c, d->axis_u, d->axis_v);
    gs__check_positive(&c, "mass", d->mass);
    if (c.r == GS_OK) gs__check_particle_mass(&c, d->mass, d->nx * d->ny);
    gs__check_int(&c, "springs", d->springs, 1, 7);
    gs__check_positive(&c, "stretch_stiffness", d->stretch_stiffness);
    gs__check_positive(&c, "shear_stiffness", d->shear_stiffness);
    gs__check_positive(&c, "bend_stiffness", d->bend_stiffness);
    gs__check_nonneg(&c, "spring_damping", d->spring_damping);
    gs__check_nonneg(&c, "air_damping", d->air_damping);
    gs__check_int(&c, "pin_corners", d->pin_corners, 0, GS_CORNER_ALL);
    if (c.r == GS_OK) gs__check_pins(&c, d->pins, d->pin_count, d->nx * d->ny);
    gs__check_size(&c, "particle_radius", d->particle_radius);
    gs__check_material(&c, &d->material);
    gs__check_solver(&c, &d->solver);
    return c.r;
}

GS__PRIVATE int gs__cloth_spring_count(int nx, int ny, int kinds) {
    int n = 0;
    if (kinds & GS_SPRINGS_STRUCTURAL) n += (nx - 1) * ny + nx * (ny - 1);
    if (kinds & GS_SPRINGS_SHEAR) n += 2 * (nx - 1) * (ny - 1);
    if (kinds & GS_SPRINGS_BEND) n += (nx - 2) * ny + nx * (ny - 2);
    return n;
}

/* Springs from every particle to the one (di, dj) away, where it exists,
   all of the grid's length for that step, rest: the distances between
   particles differ in their last bits, and one rest length a family lets
   the XPBD kernel hold its constants in registers (gs__xblk.uni). */
GS__PRIVATE int gs__cloth_link(gs__mesh *m, int k, int nx, int ny, int di,
                               int dj, double stiffness, double damping, double rest) {
    int i, j;
    for (j = 0; j < ny; ++j)
        for (i = 0; i < nx; ++i) {
            gs__spring *s;
            if (i + di < 0 || i + di >= nx || j + dj >= ny) continue;
            s = &m->springs[k++];
            s->a = i + nx * j;
            s->b = (i + di) + nx * (j + dj);
            s->rest = rest; /* 0 (underflow): the distance at creation */
            s->k = stiffness;
            s->c = damping;
        }
    return k;
}

GS__PRIVATE void gs__cloth_fill(gs__mesh *m, const gs_cloth_desc *d) {
    gs_vec3 u = gs__scale(d->axis_u, d->width / ((d->nx - 1) * gs__len(d->axis_u)));
    gs_vec3 v = gs__scale(d->axis_v, d->height / ((d->ny - 1) * gs__len(d->axis_v)));
    double c = d->spring_damping;
    int i, j, k = 0;
    for (j = 0; j < d->ny; ++j)
        for (i = 0; i < d->nx; ++i) {
            int p = i + d->nx * j;
            m->x[p] = gs__add(d->origin, gs__add(gs__scale(u, i), gs__scale(v, j)));
            m->mass[p] = d->mass / m->n;
        }
#define GS__LINK(di, dj, stiff) \
    k = gs__cloth_link(m, k, d->nx, d->ny, di, dj, stiff, c, \
                       gs__len(gs__add(gs__scale(u, di), gs__scale(v, dj))))
    if (d->springs & GS_SPRINGS_STRUCTURAL) {
        GS__LINK(1, 0, d->stretch_stiffness);
        GS__LINK(0, 1, d->stretch_stiffness);
    }
    if (d->springs & GS_SPRINGS_SHEAR) {
        GS__LINK(1, 1, d->shear_stiffness);
        GS__LINK(-1, 1, d->shear_stiffness);
    }
    if (d->springs & GS_SPRINGS_BEND) {
        GS__LINK(2, 0, d->bend_stiffness);
        GS__LINK(0, 2, d->bend_stiffness);
    }
#undef GS__LINK
    GS_ASSERT(k == m->ns);
    m->air = d->air_damping;
    m->radius = d->particle_radius;
    m->mat = d->material;
}

/* Origin, width and height each in range can still put a particle outside
   it (origin 9e8 m, width 5e8 m): every particle is checked once filled,
   and the cloth, the last agent added, is let go again if one is out. */
GS__PRIVATE gs_result gs__cloth_in_range(gs_world *w, gs__mesh *m) {
    int i;
    for (i = 0; i < m->n; ++i)
        if (!gs__in_range3(m->x[i])) {
            gs_vec3 x = m->x[i];
            w->agent_count--;
            w->nmeshes--;
            gs__free(w, m);
            return gs__fail(w, GS_ERR_OUT_OF_RANGE,
                            "gs_cloth_create: particle %d would be at (%g, %g, "
                            "%g) m, outside +-GS_MAX_COORD (%g m): origin, "
                            "width and height put the cloth out of range",
                            i, x.x, x.y, x.z, GS_MAX_COORD);
        }
    return GS_OK;
}

GS_API gs_result gs_cloth_create(gs_world *w, const gs_cloth_desc *desc,
                                 gs_agent **out) {
    gs_cloth_desc d;
    gs__mesh *m = NULL; /* set by gs__mesh_new; gcc cannot tell when it inlines */
    int pins[4], npins = 0, corner;
    gs_result r = gs__create_begin(w, desc, out, "gs_cloth_create");
    if (r != GS_OK) return r;
    d = gs__cloth_defaults(desc);
    r = gs__cloth_check(w, &d);
    if (r != GS_OK) return r;
    r = gs__mesh_new(w, &gs__cloth_kind, d.nx * d.ny,
                     gs__cloth_spring_count(d.nx, d.ny, d.springs),
                     d.pin_count + 4, &d.solver, &m);
    if (r != GS_OK) return r;
    gs__cloth_fill(m, &d);
    r = gs__cloth_in_range(w, m);
    if (r != GS_OK) return r;
    for (corner = 0; corner < 4; ++corner)
        if (d.pin_corners & (1 << corner))
            pins[npins++] = (corner & 1 ? d.nx - 1 : 0) +
                            d.nx * (corner & 2 ? d.ny - 1 : 0);
    /* corners first, then the user's pins; duplicates merge */
    gs__mesh_finish(m, pins, npins);
    m->row = d.nx;
    if (d.pin_count > 0) {
        int i;
        for (i = 0; i < d.pin_count; ++i)
            if (!m->pinned[d.pins[i]]) {
                m->pinned[d.pins[i]] = 1;
                m->pins[m->npins++] = d.pins[i];
                m->inv_mass[d.pins[i]] = 0.0;
            }
        gs__mesh_refresh_bounds(m);
    }
    return gs__sync_added(w, &m->base, out);
}

/* ---- accessors ---- */
/* Particles per row of a cloth's grid (consecutive particles are
   neighbours, and so are i and i + row), 1 for any other mesh (only
   consecutive ones taken as neighbours), 0 for another agent. */
GS__PRIVATE int gs__mesh_row(const gs_agent *a) {
    const gs__mesh *m = gs__as_mesh(a);
    return !m ? 0 : m->row > 0 ? m->row : 1;
}
GS_API int gs_mesh_particle_count(const gs_agent *a) {
    const gs__mesh *m = gs__as_mesh(a);
    return m ? m->n : 0;
}
GS_API int gs_mesh_spring_count(const gs_agent *a) {
    const gs__mesh *m = gs__as_mesh(a);
    return m ? m->ns : 0;
}
GS_API const gs_vec3 *gs_mesh_positions(const gs_agent *a) {
    const gs__mesh *m = gs__as_mesh(a);
    return m ? m->x : NULL;
}
GS_API const gs_vec3 *gs_mesh_velocities(const gs_agent *a) {
    const gs__mesh *m = gs__as_mesh(a);
    return m ? m->v : NULL;
}
GS_API double gs_mesh_stable_dt(const gs_agent *a) {
    const gs__mesh *m = gs__as_mesh(a);
    return m ? m->stable_dt : 0.0;
}

GS_API gs_result gs_mesh_energy(const gs_agent *a, double *kinetic,
                                double *potential) {
    const gs__mesh *m = gs__as_mesh(a);
    double ke = 0.0, pe = 0.0;
    gs_vec3 g;
    int i;
    if (!a) return GS_ERR_INVALID_ARG;
    if (!m)
        return gs__fail(a->world, GS_ERR_INVALID_ARG,
                        "gs_mesh_energy: agent %d is a %s, not a spring-mass agent",
                        a->index, a->kind->name);
    g = m->base.world->gravity;
    for (i = 0; i < m->n; ++i) {
        ke += 0.5 * m->mass[i] * gs__dot(m->v[i], m->v[i]);
        pe -= m->mass[i] * gs__dot(g, m->x[i]);
    }
    for (i = 0; i < m->ns; ++i) {
        const gs__spring *s = &m->springs[i];
        double e = gs__len(gs__sub(m->x[s->b], m->x[s->a])) - s->rest;
        pe += 0.5 * s->k * e * e;
    }
    if (kinetic) *kinetic = ke;
    if (potential) *potential = pe;
    return GS_OK;
}

GS_API gs_result gs_mesh_move_pin(gs_agent *a, int particle, gs_vec3 pos) {
    gs__mesh *m = gs__as_mesh(a);
    gs_result r = gs__world_unlocked(a ? a->world : NULL, "gs_mesh_move_pin");
    if (r != GS_OK) return r;
    if (!m)
        return gs__fail(a->world, GS_ERR_INVALID_ARG,
                        "gs_mesh_move_pin: agent %d is a %s, not a spring-mass agent",
                        a->index, a->kind->name);
    if (particle < 0 || particle >= m->n)
        return gs__fail(a->world, GS_ERR_OUT_OF_RANGE,
                        "gs_mesh_move_pin: particle %d, the mesh has %d",
                        particle, m->n);
    if (!m->pinned[particle])
        return gs__fail(a->world, GS_ERR_INVALID_ARG,
                        "gs_mesh_move_pin: particle %d is not pinned",
                        particle);
    if (!gs__finite3(pos))
        return gs__fail(a->world, GS_ERR_NOT_FINITE,
                        "gs_mesh_move_pin: position must be finite");
    if (!gs__in_range3(pos))
        return gs__fail(a->world, GS_ERR_OUT_OF_RANGE,
                        "gs_mesh_move_pin: position (%g, %g, %g) m is outside "
                        "+-GS_MAX_COORD (%g m)", pos.x, pos.y, pos.z,
                        GS_MAX_COORD);
    m->x[particle] = pos;
    gs__mesh_update_bounds(m);
    gs__agent_wake_at(a, gs__agent_time(a));
    return GS_OK;
}

/* ========================================================================
   >>rigid
   ======================================================================== */
GS__PRIVATE gs_quat gs__quat(double x, double y, double z, double w) {
    gs_quat q;
    q.x = x; q.y = y; q.z = z; q.w = w;
    return q;
}

/* |q| for any finite q: scaled by its largest component first when the sum
   of squares would overflow (a component over about 1e154) or underflow. */
GS__PRIVATE double gs__quat_norm(gs_quat q) {
    double n = sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w), m;
    if (n > 1e-150 && n < 1e150) return n;
    m = fmax(fmax(fabs(q.x), fabs(q.y)), fmax(fabs(q.z), fabs(q.w)));
    if (!(m > 0.0) || !gs__finite(m)) return m > 0.0 ? m : 0.0;
    q = gs__quat(q.x / m, q.y / m, q.z / m, q.w / m);
    return m * sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
}

/* q / |q|; the identity for a zero (or non-finite) q, which callers refuse
   or default before they get here. Unit quaternions take the first line,
   bit for bit what they always did. */
GS__PRIVATE gs_quat gs__quat_normalize(gs_quat q) {
    double n = sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w), m;
    if (n > 1e-150 && n < 1e150) return gs__quat(q.x / n, q.y / n, q.z / n, q.w / n);
    m = fmax(fmax(fabs(q.x), fabs(q.y)), fmax(fabs(q.z), fabs(q.w)));
    if (!(m > 0.0) || !gs__finite(m)) return gs__quat(0.0, 0.0, 0.0, 1.0);
    q = gs__quat(q.x / m, q.y / m, q.z / m, q.w / m); /* |q| in [1, 2] */
    n = sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
    return gs__quat(q.x / n, q.y / n, q.z / n, q.w / n);
}

/* v rotated by the unit quaternion q. */
GS__PRIVATE gs_vec3 gs__rotate(gs_quat q, gs_vec3 v) {
    gs_vec3 u = gs__v3(q.x, q.y, q.z);
    gs_vec3 t = gs__scale(gs__cross(u, v), 2.0);
    return gs__add(gs__add(v, gs__scale(t, q.w)), gs__cross(u, t));
}

GS__PRIVATE gs_vec3 gs__unrotate(gs_quat q, gs_vec3 v) {
    return gs__rotate(gs__quat(-q.x, -q.y, -q.z, q.w), v);
}

/* q advanced by angular velocity w (world frame) over h seconds. */
GS__PRIVATE gs_quat gs__quat_integrate(gs_quat q, gs_vec3 w, double h) {
    double hx = 0.5 * h * w.x, hy = 0.5 * h * w.y, hz = 0.5 * h * w.z;
    gs_quat r;
    r.x = q.x + hx * q.w + hy * q.z - hz * q.y;
    r.y = q.y + hy * q.w + hz * q.x - hx * q.z;
    r.z = q.z + hz * q.w + hx * q.y - hy * q.x;
    r.w = q.w - hx * q.x - hy * q.y - hz * q.z;
    return gs__quat_normalize(r);
}

/* A symmetric 3x3 matrix: xx yy zz xy xz yz. */
typedef struct gs__sym3 { double xx, yy, zz, xy, xz, yz; } gs__sym3;

GS__PRIVATE gs_vec3 gs__sym3_mul(const gs__sym3 *m, gs_vec3 v) {
    return gs__v3(m->xx * v.x + m->xy * v.y + m->xz * v.z,
                  m->xy * v.x + m->yy * v.y + m->yz * v.z,
                  m->xz * v.x + m->yz * v.y + m->zz * v.z);
}

GS__PRIVATE int gs__sym3_inverse(const gs__sym3 *m, gs__sym3 *inv) {
    double c00 = m->yy * m->zz - m->yz * m->yz;
    double c01 = m->xz * m->yz - m->xy * m->zz;
    double c02 = m->xy * m->yz - m->xz * m->yy;
    double det = m->xx * c00 + m->xy * c01 + m->xz * c02;
    if (!(fabs(det) > 0.0) || !gs__finite(det)) return 0;
    inv->xx = c00 / det;
    inv->xy = c01 / det;
    inv->xz = c02 / det;
    inv->yy = (m->xx * m->zz - m->xz * m->xz) / det;
    inv->yz = (m->xy * m->xz - m->xx * m->yz) / det;
    inv->zz = (m->xx * m->yy - m->xy * m->xy) / det;
    return 1;
}

/* A convex shape ready for collision: boxes and hulls are polytopes with
   vertices and outward face planes n . p = d in body coordinates. */
typedef struct gs__shape {
    gs_shape_type type;
    double radius;      /* sphere */
    gs_vec3 half;       /* box */
    int nv, nf;
    double bound;       /* m; radius of a sphere about the origin holding it */
    double size;        /* m; its smallest extent */
    double volume;      /* m^3 */
    gs__sym3 inertia;   /* about the origin, for density 1 */
    /* last: 5.6 kB that a sphere never reads, kept off the cache lines of
       what every contact reads */
    gs_vec3 v[GS_MAX_HULL_POINTS];
    gs_vec3 fn[2 * GS_MAX_HULL_POINTS];
    double fd[2 * GS_MAX_HULL_POINTS];
} gs__shape;

typedef struct gs__hull_face { int a, b, c; } gs__hull_face;

/* ---- hull: incremental construction over at most 64 points ---- */
GS__PRIVATE gs_vec3 gs__face_normal(const gs_vec3 *p, gs__hull_face f) {
    return gs__cross(gs__sub(p[f.b], p[f.a]), gs__sub(p[f.c], p[f.a]));
}

/* The first four points that span a volume, or 0 when all are in a plane
   (or on a line) within eps. */
GS__PRIVATE int gs__hull_seed(const gs_vec3 *p, int n, double eps, int s[4]) {
    int i;
    double best = 0.0;
    s[0] = 0; s[1] = s[2] = s[3] = -1;
    for (i = 1; i < n; ++i) {
        double d = gs__len(gs__sub(p[i], p[0]));
        if (d > best) { best = d; s[1] = i; }
    }
    if (s[1] < 0 || best <= eps) return 0;
    best = 0.0;
    for (i = 1; i < n; ++i) {
        double d = gs__len(gs__cross(gs__sub(p[s[1]], p[0]), gs__sub(p[i], p[0])));
        if (d > best) { best = d; s[2] = i; }
    }
    if (s[2] < 0 || best <= eps * gs__len(gs__sub(p[s[1]], p[0]))) return 0;
    best = 0.0;
    for (i = 1; i < n; ++i) {
        gs__hull_face f;
        double d;
        f.a = s[0]; f.b = s[1]; f.c = s[2];
        d = fabs(gs__dot(gs__face_normal(p, f), gs__sub(p[i], p[0])));
        if (d > best) { best = d; s[3] = i; }
    }
    if (s[3] < 0) return 0;
    {
        gs__hull_face f;
        f.a = s[0]; f.b = s[1]; f.c = s[2];
        if (best <= eps * gs__len(gs__face_normal(p, f))) return 0;
    }
    return 1;
}

/* Adds point i to the hull: removes the faces it sees and closes the hole
   with a fan of faces from its horizon edges. */
GS__PRIVATE int gs__hull_add(const gs_vec3 *p, gs__hull_face *f, int nf, int i,
                             double eps) {
    int vis[4 * GS_MAX_HULL_POINTS], k, e, m = 0, nnew = 0;
    gs__hull_face keep[4 * GS_MAX_HULL_POINTS], add[4 * GS_MAX_HULL_POINTS];
    for (k = 0; k < nf; ++k) {
        gs_vec3 nrm = gs__face_normal(p, f[k]);
        vis[k] = gs__dot(nrm, gs__sub(p[i], p[f[k].a])) > eps * gs__len(nrm);
    }
    for (k = 0; k < nf; ++k) {
        int ed[3][2];
        if (!vis[k]) { keep[m++] = f[k]; continue; }
        ed[0][0] = f[k].a; ed[0][1] = f[k].b;
        ed[1][0] = f[k].b; ed[1][1] = f[k].c;
        ed[2][0] = f[k].c; ed[2][1] = f[k].a;
        for (e = 0; e < 3; ++e) { /* horizon: the neighbour is not visible */
            int j, shared = 0;
            for (j = 0; j < nf && !shared; ++j) {
                if (j == k || !vis[j]) continue;
                shared = (f[j].a == ed[e][1] && f[j].b == ed[e][0]) ||
                         (f[j].b == ed[e][1] && f[j].c == ed[e][0]) ||
                         (f[j].c == ed[e][1] && f[j].a == ed[e][0]);
            }
            if (!shared) {
                add[nnew].a = ed[e][0]; add[nnew].b = ed[e][1]; add[nnew].c = i;
                nnew++;
            }
        }
    }
    if (m == nf) return nf; /* inside */
    if (m + nnew > 4 * GS_MAX_HULL_POINTS) return -1;
    for (k = 0; k < nnew; ++k) keep[m++] = add[k];
    memcpy(f, keep, (size_t)m * sizeof *f);
    return m;
}

/* Volume and inertia (density 1, about the origin) of the solid bounded by
   outward triangles, summed over tetrahedra with the origin. */
GS__PRIVATE void gs__hull_mass(gs__shape *s, const gs_vec3 *p,
                               const gs__hull_face *f, int nf) {
    double vol = 0.0, cxx = 0.0, cyy = 0.0, czz = 0.0, cxy = 0.0, cxz = 0.0,
           cyz = 0.0;
    int k;
    for (k = 0; k < nf; ++k) {
        gs_vec3 a = p[f[k].a], b = p[f[k].b], c = p[f[k].c];
        double det = gs__dot(a, gs__cross(b, c)), w = det / 120.0;
        vol += det / 6.0;
        /* covariance of tetra (0, a, b, c): det/120 (sum_i v v^T + S S^T) */
        cxx += w * (a.x * a.x + b.x * b.x + c.x * c.x + (a.x + b.x + c.x) * (a.x + b.x + c.x));
        cyy += w * (a.y * a.y + b.y * b.y + c.y * c.y + (a.y + b.y + c.y) * (a.y + b.y + c.y));
        czz += w * (a.z * a.z + b.z * b.z + c.z * c.z + (a.z + b.z + c.z) * (a.z + b.z + c.z));
        cxy += w * (a.x * a.y + b.x * b.y + c.x * c.y + (a.x + b.x + c.x) * (a.y + b.y + c.y));
        cxz += w * (a.x * a.z + b.x * b.z + c.x * c.z + (a.x + b.x + c.x) * (a.z + b.z + c.z));
        cyz += w * (a.y * a.z + b.y * b.z + c.y * c.z + (a.y + b.y + c.y) * (a.z + b.z + c.z));
    }
    s->volume = vol;
    s->inertia.xx = cyy + czz;
    s->inertia.yy = cxx + czz;
    s->inertia.zz = cxx + cyy;
    s->inertia.xy = -cxy;
    s->inertia.xz = -cxz;
    s->inertia.yz = -cyz;
}

/* Centre of mass of the solid hull (weighted tetra centroids). */
GS__PRIVATE gs_vec3 gs__hull_centroid(const gs_vec3 *p, const gs__hull_face *f,
                                      int nf, gs_vec3 inner) {
    gs_vec3 c = gs__v3(0.0, 0.0, 0.0);
    double vol = 0.0;
    int k;
    for (k = 0; k < nf; ++k) {
        gs_vec3 a = gs__sub(p[f[k].a], inner), b = gs__sub(p[f[k].b], inner),
                d = gs__sub(p[f[k].c], inner);
        double v = gs__dot(a, gs__cross(b, d)) / 6.0;
        vol += v;
        c = gs__madd(c, gs__add(gs__add(a, b), d), v / 4.0);
    }
    return gs__add(inner, gs__scale(c, 1.0 / vol));
}

/* Orients the seed tetrahedron's faces outward. */
GS__PRIVATE void gs__hull_tetra(const gs_vec3 *p, const int s[4],
                                gs__hull_face f[4]) {
    int k, idx[4][3] = {{0, 1, 2}, {0, 3, 1}, {0, 2, 3}, {1, 3, 2}};
    for (k = 0; k < 4; ++k) {
        int opposite = 6 - idx[k][0] - idx[k][1] - idx[k][2];
        f[k].a = s[idx[k][0]]; f[k].b = s[idx[k][1]]; f[k].c = s[idx[k][2]];
        if (gs__dot(gs__face_normal(p, f[k]), gs__sub(p[s[opposite]], p[f[k].a])) > 0.0) {
            int t = f[k].b; f[k].b = f[k].c; f[k].c = t;
        }
    }
}

/* Builds a hull shape: vertices recentred on the centre of mass, face planes,
   mass properties. Returns 0 for degenerate input. */
GS__PRIVATE int gs__hull_build(gs__shape *s, const gs_vec3 *pts, int n) {
    gs_vec3 p[GS_MAX_HULL_POINTS], com, lo = pts[0], hi = pts[0];
    gs__hull_face f[4 * GS_MAX_HULL_POINTS];
    int seed[4], nf = 4, i, k, used[GS_MAX_HULL_POINTS];
    double scale, eps;
    for (i = 0; i < n; ++i) {
        lo = gs__v3(fmin(lo.x, pts[i].x), fmin(lo.y, pts[i].y), fmin(lo.z, pts[i].z));
        hi = gs__v3(fmax(hi.x, pts[i].x), fmax(hi.y, pts[i].y), fmax(hi.z, pts[i].z));
    }
    scale = gs__len(gs__sub(hi, lo));
    eps = 1e-9 * scale;
    if (!(scale > 0.0) || !gs__hull_seed(pts, n, 1e-6, seed)) return 0;
    memcpy(p, pts, (size_t)n * sizeof *p);
    gs__hull_tetra(p, seed, f);
    for (i = 0; i < n && nf > 0; ++i) nf = gs__hull_add(p, f, nf, i, eps);
    if (nf <= 0) return 0;
    com = gs__hull_centroid(p, f, nf, gs__scale(gs__add(gs__add(p[seed[0]], p[seed[1]]),
                                                      gs__add(p[seed[2]], p[seed[3]])), 0.25));
    for (i = 0; i < n; ++i) p[i] = gs__sub(p[i], com);
    gs__hull_mass(s, p, f, nf);
    memset(used, 0, sizeof used);
    for (k = 0; k < nf; ++k) used[f[k].a] = used[f[k].b] = used[f[k].c] = 1;
    s->nv = 0;
    for (i = 0; i < n; ++i)
        if (used[i]) s->v[s->nv++] = p[i];
    s->nf = 0;
    for (k = 0; k < nf && s->nf < 2 * GS_MAX_HULL_POINTS; ++k) {
        gs_vec3 nrm = gs__face_normal(p, f[k]);
        nrm = gs__scale(nrm, 1.0 / gs__len(nrm));
        s->fn[s->nf] = nrm;
        s->fd[s->nf++] = gs__dot(nrm, p[f[k].a]);
    }
    return s->volume > 0.0;
}

GS__PRIVATE void gs__box_build(gs__shape *s, gs_vec3 h) {
    int i;
    for (i = 0; i < 8; ++i)
        s->v[i] = gs__v3(i & 1 ? h.x : -h.x, i & 2 ? h.y : -h.y, i & 4 ? h.z : -h.z);
    s->nv = 8;
    s->nf = 6;
    for (i = 0; i < 3; ++i) {
        gs_vec3 e = gs__v3(i == 0, i == 1, i == 2);
        double d = i == 0 ? h.x : i == 1 ? h.y : h.z;
        s->fn[2 * i] = e;
        s->fd[2 * i] = d;
        s->fn[2 * i + 1] = gs__scale(e, -1.0);
        s->fd[2 * i + 1] = d;
    }
    s->volume = 8.0 * h.x * h.y * h.z;
    memset(&s->inertia, 0, sizeof s->inertia);
    s->inertia.xx = s->volume * (h.y * h.y + h.z * h.z) / 3.0;
    s->inertia.yy = s->volume * (h.x * h.x + h.z * h.z) / 3.0;
    s->inertia.zz = s->volume * (h.x * h.x + h.y * h.y) / 3.0;
}

/* The bytes of a shape that its type uses: a sphere stops before the
   vertex arrays (a body is allocated at that size: gs__rigid_size). */
GS__PRIVATE size_t gs__shape_size(gs_shape_type type) {
    return type == GS_SHAPE_SPHERE ? offsetof(gs__shape, v) : sizeof(gs__shape);
}

/* Validates a shape desc and builds the collision shape (s holds at least
   gs__shape_size(d->type) bytes; the arrays are read only up to nv, nf). */
GS__PRIVATE void gs__shape_build(gs__check *c, const gs_shape_desc *d,
                                 gs__shape *s) {
    int i;
    memset(s, 0, offsetof(gs__shape, v));
    s->type = d->type;
    if (d->type == GS_SHAPE_SPHERE) {
        gs__check_size(c, "shape.radius", d->radius);
        if (c->r != GS_OK) return;
        s->radius = s->bound = d->radius;
        s->size = 2.0 * d->radius;
        s->volume = 4.0 / 3.0 * 3.14159265358979323846 * pow(d->radius, 3.0);
        s->inertia.xx = s->inertia.yy = s->inertia.zz =
            0.4 * s->volume * d->radius * d->radius;
    } else if (d->type == GS_SHAPE_BOX) {
        gs__check_size(c, "shape.half_extents.x", d->half_extents.x);
        gs__check_size(c, "shape.half_extents.y", d->half_extents.y);
        gs__check_size(c, "shape.half_extents.z", d->half_extents.z);
        if (c->r != GS_OK) return;
        s->half = d->half_extents;
        gs__box_build(s, d->half_extents);
    } else if (d->type == GS_SHAPE_HULL) {
        gs__check_int(c, "shape.point_count", d->point_count, 4, GS_MAX_HULL_POINTS);
        if (c->r == GS_OK && !d->points)
            gs__check_fail(c, GS_ERR_INVALID_ARG, "shape.points is NULL");
        for (i = 0; c->r == GS_OK && i < d->point_count; ++i)
            if (!gs__finite3(d->points[i]))
                gs__check_item(c, GS_ERR_NOT_FINITE, "shape.points", i, "", NAN,
                               "must be finite");
            else if (!gs__in_range3(d->points[i]))
                gs__check_item(c, GS_ERR_OUT_OF_RANGE, "shape.points", i,
                               " largest coordinate", gs__max_abs3(d->points[i]),
                               "must be within +-GS_MAX_COORD");
        if (c->r != GS_OK) return;
        if (!gs__hull_build(s, d->points, d->point_count))
            gs__check_fail(c, GS_ERR_INVALID_ARG,
                           "shape.points: the %d points lie in one plane or on "
                           "one line: the hull has no volume", d->point_count);
    } else {
        gs__check_fail(c, GS_ERR_INVALID_ARG, "shape.type is %d, must be a "
                       "GS_SHAPE_*", (int)d->type);
    }
    if (c->r != GS_OK || d->type == GS_SHAPE_SPHERE) return;
    s->size = HUGE_VAL;
    for (i = 0; i < s->nv; ++i)
        if (gs__len(s->v[i]) > s->bound) s->bound = gs__len(s->v[i]);
    for (i = 0; i < s->nf; ++i) /* twice the inradius, a lower bound on size */
        if (2.0 * s->fd[i] < s->size) s->size = 2.0 * s->fd[i];
}

/* A peer's probe in replay mode: how its owner's application moves it, as
   its snapshots tell (gs__sync_sighted, gs__sync_carry). All doubles: the
   world history keeps it as they are. */
typedef struct gs__lead {
    gs_vec3 x, d, dd;  /* m: the last snapshot's position, the path's step
                          per frame of the owner's before it, and that
                          step's change per frame */
    double t, per;     /* s: the last snapshot's time; the owner's frame
                          (smoothed over the snapshots' spacings) */
    double f;          /* s: the end of the owner's frame that snapshot
                          was taken at (estimated: gs__sync_sighted) */
    double next;       /* s: when the owner's next input is due */
    double j;          /* the owner's frames carried since the last
                          snapshot */
    double k;          /* frames between the last two snapshots */
    double n;          /* snapshots seen: 0, 1, 2, 3 (or more) */
} gs__lead;

typedef struct gs__rigid {
    gs_agent base;
    /* What only its own step reads (or nothing in a step) first; what
       other bodies' contacts read of it after, together and next to the
       shape's head: a neighbour costs a few cache lines of its struct,
       not one per field. */
    double mass;               /* kg */
    gs__sym3 inertia_body;
    gs_vec3 late;              /* N s; the forces of this substep that act
                                  from later in it, times how much later
                                  (the part of a pair after the other
                                  body's time) */
    int probe_touch;           /* in this step a probe that moves touched
                                  it: it does not rest (see gs__rigid_rest) */
    double near_key;           /* m; x - bound, the sort key of near */
    double sweep;              /* m; bound + the travel of world->wide_lag
                                  (what makes it wide) */
    gs_vec3 force, torque;     /* contact sums for the current substep */
    double k_sum, c_sum;       /* N/m, N s/m of the contacts touching it */
    double k_nn[6], c_nn[6];   /* a sphere's: the same as tensors over the
                                  contact normals (xx yy zz xy xz yz): see
                                  gs__rigid_bound */
    gs_solver_desc solver;
    int continuous;
    double stable_dt;          /* s; contact spring-damper bound */
    double rolling;            /* m; rolling resistance lever arm */
    double spin_friction;      /* m; torsional friction lever arm */
    double i_min;              /* kg m^2; smallest principal inertia */
    gs_vec3 target;            /* probe */
    gs_quat target_q;
    double max_speed;          /* probe, m/s */
    gs__lead lead;             /* a peer's probe, replay mode */
    uint32_t owner;
    int probe;                 /* kinematic: moved by the application */
    double inv_mass;           /* 1/kg (0 for a probe) */
    gs_vec3 x, v, w;           /* m, m/s, rad/s (world) */
    gs_quat q;
    gs_vec3 a_own;             /* m/s^2; the change of v over its last step,
                                  of its own forces and gravity (pushes
                                  land between its steps) */
    /* While another body steps, what its contacts have done to this one so
       far (see gs__rigid_vs_rigid): the change of velocity (m/s), of
       position (m) and of angular velocity (rad/s), and the force (N) and
       torque (N m) of the current substep. Zero between steps. */
    gs_vec3 sh_dv, sh_dx, sh_dw, sh_f, sh_t;
    int touched;               /* in world->touched */
    int sap;                   /* index in world->bodies */
    int near;                  /* index in world->near */
    int wide;                  /* index in world->wide, -1 if not wide */
    int in_grid;               /* in world->grid (its cell: world->grec) */
    double speed;              /* m/s, |v| + |a_own| dt when the broad phase saw it
                                  (0 for a probe) */
    double reach2;             /* 1/kg: 1/m + bound^2 / smallest inertia,
                                  how hard a contact at the surface moves it */
    gs_material mat;
    gs__sym3 inv_inertia_body;
    gs__shape shape;           /* last: see its vertex arrays */
} gs__rigid;

GS__PRIVATE gs_result gs__sap_add(gs_world *w, gs__rigid *r);
GS__PRIVATE void gs__sap_update(gs__rigid *r);
GS__PRIVATE void gs__sap_remove(gs_world *w, gs__rigid *r);

GS__PRIVATE gs__rigid *gs__as_rigid(const gs_agent *a);

/* A body of this shape type: a sphere without the 5.6 kB of vertex arrays,
   so that a pile's bodies sit 0.9 kB apart, not 6.5 kB (a page each: in a
   pile of 4096 the misses of cache and TLB grew the step as n^1.3 where
   its instructions grew as n). */
GS__PRIVATE size_t gs__rigid_size(gs_shape_type type) {
    return offsetof(gs__rigid, shape) + gs__shape_size(type);
}

GS_API gs_shape_desc gs_shape_desc_default(void) {
    gs_shape_desc d;
    memset(&d, 0, sizeof d);
    return d;
}

GS_API gs_rigid_desc gs_rigid_desc_default(void) {
    gs_rigid_desc d;
    memset(&d, 0, sizeof d);
    d.density = 1000.0;
    d.orientation = gs__quat(0.0, 0.0, 0.0, 1.0);
    d.material = gs_material_default();
    d.solver = gs_solver_desc_default();
    return d;
}

GS_API gs_probe_desc gs_probe_desc_default(void) {
    gs_probe_desc d;
    memset(&d, 0, sizeof d);
    d.orientation = gs__quat(0.0, 0.0, 0.0, 1.0);
    d.material = gs_material_default();
    d.dt = 0.001;
    d.max_speed = 10.0;
    return d;
}

GS__PRIVATE gs_quat gs__orientation_default(gs_quat q) {
    if (q.x == 0.0 && q.y == 0.0 && q.z == 0.0 && q.w == 0.0)
        return gs__quat(0.0, 0.0, 0.0, 1.0);
    return q;
}

GS__PRIVATE void gs__check_quat(gs__check *c, const char *field, gs_quat q) {
    if (!gs__finite(q.x) || !gs__finite(q.y) || !gs__finite(q.z) ||
        !gs__finite(q.w))
        gs__check_fail(c, GS_ERR_NOT_FINITE, "%s must be finite", field);
}

/* 1/m + b^2 / I_min: the inverse of the effective mass a contact at the
   body's surface (distance b from its centre) meets. I_min from Gershgorin:
   the smallest diagonal of the body inertia less its off-diagonal row sum. */
/* A lower bound on the smallest principal moment (Gershgorin), kg m^2. */
GS__PRIVATE double gs__rigid_i_min(const gs__rigid *r) {
    const gs__sym3 *I = &r->inertia_body;
    double lx = I->xx - fabs(I->xy) - fabs(I->xz);
    double ly = I->yy - fabs(I->xy) - fabs(I->yz);
    double lz = I->zz - fabs(I->xz) - fabs(I->yz);
    double imin = fmin(lx, fmin(ly, lz));
    return imin > 0.0 ? imin : fmin(I->xx, fmin(I->yy, I->zz));
}

GS__PRIVATE double gs__rigid_reach2(const gs__rigid *r) {
    if (r->shape.type == GS_SHAPE_SPHERE) /* normal forces pass the centre */
        return r->inv_mass;
    return r->inv_mass + r->shape.bound * r->shape.bound / gs__rigid_i_min(r);
}

GS__PRIVATE void gs__rigid_check(gs__check *c, const gs_rigid_desc *d,
                                 gs__shape *shape) {
    gs__shape_build(c, &d->shape, shape);
    gs__check_positive(c, "density", d->density);
    gs__check_nonneg(c, "mass", d->mass);
    gs__check_vec(c, "inertia", d->inertia);
    if (c->r == GS_OK && (d->inertia.x < 0.0 || d->inertia.y < 0.0 ||
                          d->inertia.z < 0.0))
        gs__check_fail(c, GS_ERR_INVALID_ARG, "inertia must be >= 0");
    gs__check_pos(c, "position", d->position);
    gs__check_quat(c, "orientation", d->orientation);
    gs__check_vec(c, "velocity", d->velocity);
    gs__check_vec(c, "angular_velocity", d->angular_velocity);
    gs__check_material(c, &d->material);
    gs__check_nonneg(c, "rolling", d->rolling);
    gs__check_nonneg(c, "spin_friction", d->spin_friction);
    gs__check_solver(c, &d->solver);
    if (c->r == GS_OK && (d->solver.integrator == GS_INTEGRATOR_IMPLICIT_EULER ||
                          d->solver.integrator == GS_INTEGRATOR_XPBD))
        gs__check_fail(c, GS_ERR_INVALID_ARG,
                       "solver.integrator: implicit Euler and XPBD are for "
                       "spring-mass agents; rigid bodies substep under stiff "
                       "contact");
}

/* Mass and body inertia from the desc: given values win over the shape's. */
GS__PRIVATE void gs__rigid_mass(gs__rigid *r, const gs_rigid_desc *d) {
    double rho;
    r->mass = d->mass > 0.0 ? d->mass : d->density * r->shape.volume;
    rho = r->mass / r->shape.volume;
    r->inertia_body = r->shape.inertia;
    r->inertia_body.xx *= rho; r->inertia_body.yy *= rho;
    r->inertia_body.zz *= rho; r->inertia_body.xy *= rho;
    r->inertia_body.xz *= rho; r->inertia_body.yz *= rho;
    if (d->inertia.x > 0.0 && d->inertia.y > 0.0 && d->inertia.z > 0.0) {
        memset(&r->inertia_body, 0, sizeof r->inertia_body);
        r->inertia_body.xx = d->inertia.x;
        r->inertia_body.yy = d->inertia.y;
        r->inertia_body.zz = d->inertia.z;
    }
    r->inv_mass = 1.0 / r->mass;
    if (!gs__sym3_inverse(&r->inertia_body, &r->inv_inertia_body))
        memset(&r->inv_inertia_body, 0, sizeof r->inv_inertia_body);
}

/* Mass and inertia, then that they can move the body: a mass or moment
   that overflows (density * volume) or whose inverse does (a mass under
   about 1e-308 kg) would turn every step into NaN. */
GS__PRIVATE void gs__rigid_mass_check(gs__check *c, gs__rigid *r,
                                      const gs_rigid_desc *d) {
    const gs__sym3 *I = &r->inertia_body, *J = &r->inv_inertia_body;
    gs__rigid_mass(r, d);
    if (!gs__finite(r->mass) || !gs__finite(r->inv_mass))
        gs__check_fail(c, GS_ERR_OUT_OF_RANGE,
                       "mass is %g kg (from mass, or density * volume): it "
                       "and its inverse must be finite", r->mass);
    else if (!gs__finite(I->xx + I->yy + I->zz + I->xy + I->xz + I->yz) ||
             !gs__finite(J->xx + J->yy + J->zz + J->xy + J->xz + J->yz))
        gs__check_fail(c, GS_ERR_OUT_OF_RANGE,
                       "inertia (%g, %g, %g) kg m^2: it and its inverse must "
                       "be finite", I->xx, I->yy, I->zz);
}

GS__PRIVATE gs_rigid_desc gs__rigid_defaults(const gs_rigid_desc *in) {
    gs_rigid_desc d = *in;
    if (d.density == 0.0) d.density = 1000.0;
    d.orientation = gs__orientation_default(d.orientation);
    d.material = gs__material_defaults(d.material);
    d.solver = gs__solver_defaults(d.solver);
    return d;
}

/* ---- rigid dynamics: contact forces are held over a substep ---- */
GS__PRIVATE gs_vec3 gs__rigid_angular_accel(const gs__rigid *r, gs_vec3 w) {
    /* world inertia applied through the body frame: I_w x = R I_b R^T x */
    gs_vec3 wl = gs__unrotate(r->q, w), tl = gs__unrotate(r->q, r->torque);
    gs_vec3 iw = gs__sym3_mul(&r->inertia_body, wl);
    gs_vec3 rhs = gs__sub(tl, gs__cross(wl, iw));
    return gs__rotate(r->q, gs__sym3_mul(&r->inv_inertia_body, rhs));
}

GS__PRIVATE void gs__rigid_integrate(gs__rigid *r, double h) {
    gs_vec3 a = gs__madd(r->base.world->gravity, r->force, r->inv_mass);
    switch (r->solver.integrator) {
    case GS_INTEGRATOR_EXPLICIT_EULER:
        r->x = gs__madd(r->x, r->v, h);
        r->q = gs__quat_integrate(r->q, r->w, h);
        r->v = gs__madd(r->v, a, h);
        r->w = gs__madd(r->w, gs__rigid_angular_accel(r, r->w), h);
        break;
    case GS_INTEGRATOR_RK4: { /* the gyroscopic term is the only nonlinearity */
        gs_vec3 k1 = gs__rigid_angular_accel(r, r->w);
        gs_vec3 k2 = gs__rigid_angular_accel(r, gs__madd(r->w, k1, 0.5 * h));
        gs_vec3 k3 = gs__rigid_angular_accel(r, gs__madd(r->w, k2, 0.5 * h));
        gs_vec3 k4 = gs__rigid_angular_accel(r, gs__madd(r->w, k3, h));
        gs_vec3 w0 = r->w;
        r->w = gs__madd(r->w, gs__add(gs__add(k1, k4), gs__scale(gs__add(k2, k3), 2.0)), h / 6.0);
        r->x = gs__madd(gs__madd(r->x, r->v, h), a, 0.5 * h * h);
        r->v = gs__madd(r->v, a, h);
        r->q = gs__quat_integrate(r->q, gs__scale(gs__add(w0, r->w), 0.5), h);
        break;
    }
    default: /* symplectic Euler; Verlet is the same under held forces */
        r->v = gs__madd(r->v, a, h);
        r->w = gs__madd(r->w, gs__rigid_angular_accel(r, r->w), h);
        r->x = gs__madd(r->x, r->v, h);
        r->q = gs__quat_integrate(r->q, r->w, h);
        break;
    }
}

GS__PRIVATE void gs__rigid_contacts(gs__rigid *r, double t, double h);
GS__PRIVATE int gs__push_advance(gs_world *w, double h);
GS__PRIVATE void gs__push_end(gs_world *w, int land);

/* An upper bound on the largest eigenvalue of a symmetric 3x3 (xx yy zz
   xy xz yz): the mean plus the most a deviation of that Frobenius norm
   allows, exact when the other two are equal (one contact, or a stack). */
GS__PRIVATE double gs__sym3_top(const double *a) {
    double m = (a[0] + a[1] + a[2]) / 3.0, d0 = a[0] - m, d1 = a[1] - m, d2 = a[2] - m;
    double f = d0 * d0 + d1 * d1 + d2 * d2 + 2.0 * (a[3] * a[3] + a[4] * a[4] + a[5] * a[5]);
    return m + sqrt(f * (2.0 / 3.0));
}

/* A contact's spring k and normal damping d (N/m, N s/m) and its friction
   slope (N s/m, tangential), each times both (see gs__rigid_apply), into
   r's sums. A sphere also sums them as tensors over the normal n: its
   normal forces pass the centre, so contacts at right angles stiffen
   different directions, and the stiffest direction is what bounds the
   substep, where the scalar sums count them as if all were in line. */
GS__PRIVATE void gs__rigid_stiffen(gs__rigid *r, gs_vec3 n, double k, double d,
                                   double slope, double both) {
    double nn[6], cd;
    int i;
    r->k_sum += k * both;
    r->c_sum += (d + slope) * both;
    if (r->shape.type != GS_SHAPE_SPHERE) return;
    k *= both;
    slope *= both;
    cd = d * both - slope;
    nn[0] = n.x * n.x; nn[1] = n.y * n.y; nn[2] = n.z * n.z;
    nn[3] = n.x * n.y; nn[4] = n.x * n.z; nn[5] = n.y * n.z;
    for (i = 0; i < 6; ++i) {
        r->k_nn[i] += k * nn[i];
        r->c_nn[i] += cd * nn[i];
    }
    for (i = 0; i < 3; ++i) r->c_nn[i] += slope; /* slope (I - n n^T) */
}

/* A cloth's particle contact counts in every direction: the particles
   under a sphere are coupled through the cloth, and a sphere on a cloth
   keeps the scalar sums' substeps (taken along the normals, the paper
   scene's hosts drifted apart: test_leadband). */
GS__PRIVATE void gs__rigid_stiffen_all(gs__rigid *r, double k, double d, double slope) {
    int i;
    r->k_sum += k;
    r->c_sum += d + slope;
    if (r->shape.type != GS_SHAPE_SPHERE) return;
    for (i = 0; i < 3; ++i) {
        r->k_nn[i] += k;
        r->c_nn[i] += d + slope;
    }
}

GS__PRIVATE void gs__rigid_sums_clear(gs__rigid *r) {
    int i;
    r->k_sum = r->c_sum = 0.0;
    for (i = 0; i < 6; ++i) r->k_nn[i] = r->c_nn[i] = 0.0;
}

/* The stable step under the contacts found now: a spring-damper with the
   summed stiffness and damping acting on 1 / reach2 kg (gs__mesh_bound's
   rule with omega^2 = k reach2, gamma = c reach2); for a sphere, the
   stiffness and damping of its stiffest direction (gs__rigid_stiffen). */
GS__PRIVATE double gs__rigid_bound(const gs__rigid *r) {
    double k = r->k_sum, c = r->c_sum, w2, g;
    if (r->shape.type == GS_SHAPE_SPHERE) { /* never above the scalar sums */
        k = fmin(k, gs__sym3_top(r->k_nn));
        c = fmin(c, gs__sym3_top(r->c_nn));
    }
    w2 = k * r->reach2;
    g = c * r->reach2;
    if (w2 == 0.0 && g == 0.0) return HUGE_VAL;
    return 4.0 / (g + sqrt(g * g + 4.0 * w2));
}

/* Substeps: under the contact bound (unless unchecked) and, when
   continuous, a travel of at most a quarter of the body's smallest size per
   substep. Expects the contacts of the current state to be computed. */
GS__PRIVATE gs_result gs__rigid_plan(gs__rigid *r, double dt, int *n_sub) {
    double k = 1.0, lim = gs__rigid_bound(r) * r->solver.safety;
    double speed = gs__len(r->v) + gs__len(r->w) * r->shape.bound;
    *n_sub = 1;
    if (r->solver.stability != GS_STABILITY_UNCHECKED && dt > lim) {
        if (r->solver.stability == GS_STABILITY_REFUSE)
            return gs__fail(r->base.world, GS_ERR_UNSTABLE,
                            "rigid agent %d: dt %g s exceeds the contact-stable "
                            "step %g s (stability = refuse)",
                            r->base.index, dt, lim);
        k = ceil(dt / lim);
    }
    if (r->continuous && speed * dt / k > 0.25 * r->shape.size)
        k = ceil(speed * dt / (0.25 * r->shape.size));
    if (k > (double)r->solver.max_substeps)
        return gs__fail(r->base.world, GS_ERR_UNSTABLE,
                        "rigid agent %d: dt %g s needs %.0f substeps, "
                        "max_substeps is %d", r->base.index, dt, k,
                        r->solver.max_substeps);
    *n_sub = (int)k;
    return GS_OK;
}

/* How fast its fastest point moves (m/s): what sleeping compares. */
GS__PRIVATE double gs__rigid_speed(const gs__rigid *r) {
    return gs__len(r->v) + gs__len(r->w) * r->shape.bound;
}

/* After a step of dt: at rest for the world's sleep_time, it sleeps, still
   (its velocities zeroed, so that its state stays what it is). Only the
   world's advance puts it to sleep: gs_agent_step steps what it is asked
   to, as tools and tests expect. Not under a ghost, as a mesh (below): a
   sleeper frozen at a state its peers' copies have not reached stops the
   hosts from meeting (test_scene_perfect_and_bad's bad link ended 9 cm
   apart with ghosted spheres asleep). */
GS__PRIVATE void gs__rigid_rest(gs__rigid *r, double dt) {
    const gs_world *w = r->base.world;
    if (!w->busy) return;
    if (r->base.hold && w->sleep_time >= 0.0 && !r->probe_touch &&
        gs__rigid_speed(r) < w->sleep_speed) {
        r->base.hold = 0;
        r->base.rest = w->sleep_time;
    } else if (w->sleep_time < 0.0 || r->probe_touch || r->base.ghost ||
        !(gs__rigid_speed(r) < w->sleep_speed)) {
        r->base.rest = 0.0;
        return;
    }
    r->base.rest += dt;
    if (r->base.rest < w->sleep_time) return;
    r->base.sleeping = 1;
    r->base.stats.sleeps++;
    r->v = r->w = r->a_own = gs__v3(0.0, 0.0, 0.0);
    gs__sap_update(r);
}

GS__PRIVATE int gs__rigid_sane(const gs__rigid *r) {
    double vmax = r->solver.max_speed;
    return gs__in_range3(r->x) && gs__finite(r->q.x + r->q.y + r->q.z + r->q.w) &&
           gs__dot(r->v, r->v) <= vmax * vmax &&
           gs__dot(r->w, r->w) * r->shape.bound * r->shape.bound <= vmax * vmax;
}

/* The contacts of the step's start plan its substeps, as if it took one
   (h = dt); with more, the first is found again for its own length, which
   decides what share of it falls after each other body's time. A step
   that blows up, its own state or a body it pushes, is undone whole: the
   pushes are dropped with it. */
GS__PRIVATE gs_result gs__rigid_step(gs_agent *a, double dt) {
    gs__rigid *r = (gs__rigid *)a;
    gs_vec3 x0 = r->x, v0 = r->v, w0 = r->w;
    gs_quat q0 = r->q;
    double t = gs__agent_time(a), h;
    int n_sub, i;
    gs_result res;
    r->probe_touch = 0;
    gs__rigid_contacts(r, t, dt);
    res = gs__rigid_plan(r, dt, &n_sub);
    if (res != GS_OK) {
        gs__push_end(a->world, 0);
        return res;
    }
    h = dt / n_sub;
    for (i = 0; i < n_sub; ++i) {
        if (i > 0 || n_sub > 1) gs__rigid_contacts(r, t + i * h, h);
        gs__rigid_integrate(r, h);
        /* a force that acts from later in the substep moves r less by its end */
        r->x = gs__madd(r->x, r->late, -r->inv_mass * h);
        if (gs__push_advance(a->world, h) && gs__rigid_sane(r)) continue;
        r->x = x0; r->v = v0; r->w = w0; r->q = q0;
        gs__push_end(a->world, 0);
        return gs__fail(a->world, GS_ERR_UNSTABLE,
                        "rigid agent %d: a step of %g s blew up (non-finite "
                        "state or a speed over %g m/s, its own or a body it "
                        "pushes); state kept",
                        a->index, h, r->solver.max_speed);
    }
    gs__push_end(a->world, 1);
    r->a_own = gs__scale(gs__sub(r->v, v0), 1.0 / dt);
    a->stats.substeps += (uint64_t)n_sub;
    gs__sap_update(r);
    gs__rigid_rest(r, dt);
    return GS_OK;
}

GS__PRIVATE void gs__probe_wake(gs__rigid *p);

/* A probe moves toward its target at no more than max_speed. Target and
   position are in range, so their difference is finite; its velocity d / dt
   may still not be (a tiny dt), and then the step is refused. */
GS__PRIVATE gs_result gs__probe_step(gs_agent *a, double dt) {
    gs__rigid *r = (gs__rigid *)a;
    gs_vec3 d = gs__sub(r->target, r->x), x, v;
    double dist = gs__len(d), reach = r->max_speed * dt;
    if (dist > reach) d = gs__scale(d, reach / dist);
    v = gs__scale(d, 1.0 / dt);
    x = gs__add(r->x, d);
    if (!gs__in_range3(x) || !gs__finite3(v))
        return gs__fail(a->world, GS_ERR_UNSTABLE,
                        "probe agent %d: a step of %g s toward (%g, %g, %g) "
                        "gives a non-finite velocity or leaves "
                        "+-GS_MAX_COORD; state kept",
                        a->index, dt, r->target.x, r->target.y, r->target.z);
    a->rest = (d.x != 0.0 || d.y != 0.0 || d.z != 0.0 || memcmp(&r->q, &r->target_q, sizeof r->q))
                  ? 0.0 : a->rest + dt;
    r->v = v;
    r->x = x;
    r->q = r->target_q;
    r->w = gs__v3(0.0, 0.0, 0.0);
    a->stats.substeps++;
    gs__sap_update(r);
    gs__probe_wake(r);
    return GS_OK;
}

GS__PRIVATE size_t gs__rigid_state_size(const gs_agent *a) {
    (void)a;
    return 13;
}

GS__PRIVATE void gs__rigid_get_state(const gs_agent *a, double *o) {
    const gs__rigid *r = (const gs__rigid *)a;
    o[0] = r->x.x; o[1] = r->x.y; o[2] = r->x.z;
    o[3] = r->q.x; o[4] = r->q.y; o[5] = r->q.z; o[6] = r->q.w;
    o[7] = r->v.x; o[8] = r->v.y; o[9] = r->v.z;
    o[10] = r->w.x; o[11] = r->w.y; o[12] = r->w.z;
}

/* The orientation is renormalized: a blend of unit quaternions is not one. */
GS__PRIVATE gs_result gs__rigid_set_state(gs_agent *a, const double *in) {
    gs__rigid *r = (gs__rigid *)a;
    gs_quat q = gs__quat(in[3], in[4], in[5], in[6]);
    gs_vec3 x = gs__v3(in[0], in[1], in[2]);
    /* a near-zero quaternion (a blend of q and -q) has no direction left */
    if (!(gs__quat_norm(q) > 1e-6))
        return gs__fail(a->world, GS_ERR_INVALID_ARG,
                        "gs_agent_set_state: the orientation quaternion "
                        "(%g, %g, %g, %g) is zero (norm under 1e-6)",
                        q.x, q.y, q.z, q.w);
    if (!gs__in_range3(x))
        return gs__fail(a->world, GS_ERR_OUT_OF_RANGE,
                        "gs_agent_set_state: the position (%g, %g, %g) m is "
                        "outside +-GS_MAX_COORD (%g m)", x.x, x.y, x.z,
                        GS_MAX_COORD);
    r->x = x;
    r->q = gs__quat_normalize(q);
    r->v = gs__v3(in[7], in[8], in[9]);
    r->w = gs__v3(in[10], in[11], in[12]);
    r->a_own = gs__v3(0.0, 0.0, 0.0); /* a state, not a step: no path known */
    /* A state set between advances places a probe and stops it there. One
       set inside an advance (a blend, or an input a re-run applies) leaves
       this host's own probe on its way to the target its application set:
       taken as the target, a blend of its own ghost would stop it in every
       frame with a blend, and it would take the path in jumps. A peer's
       probe goes where its blends put it. */
    if (r->probe && !(a->world->busy && r->owner == a->world->host_id)) {
        r->target = r->x;
        r->target_q = r->q;
    }
    gs__sap_update(r);
    return GS_OK;
}

GS__PRIVATE uint64_t gs__rigid_hash(const gs_agent *a, uint64_t h) {
    double s[13];
    gs__rigid_get_state(a, s);
    return gs__fnv(h, s, sizeof s);
}

/* Dead reckoning of [position, quaternion, velocity, angular velocity]. */
GS__PRIVATE void gs__rigid_extrapolate(const gs_agent *a, double *s, double dt) {
    gs_quat q = gs__quat_integrate(gs__quat(s[3], s[4], s[5], s[6]),
                                   gs__v3(s[10], s[11], s[12]), dt);
    (void)a;
    s[0] += s[7] * dt; s[1] += s[8] * dt; s[2] += s[9] * dt;
    s[3] = q.x; s[4] = q.y; s[5] = q.z; s[6] = q.w;
}

GS__PRIVATE size_t gs__rigid_positions(const gs_agent *a) {
    (void)a;
    return 3;
}

static const gs__kind gs__rigid_kind = {
    "rigid", gs__rigid_step, gs__rigid_state_size, gs__rigid_get_state,
    gs__rigid_set_state, gs__rigid_hash, gs__rigid_extrapolate, gs__rigid_positions};
static const gs__kind gs__probe_kind = {
    "probe", gs__probe_step, gs__rigid_state_size, gs__rigid_get_state,
    gs__rigid_set_state, gs__rigid_hash, gs__rigid_extrapolate, gs__rigid_positions};

GS__PRIVATE gs__rigid *gs__as_rigid(const gs_agent *a) {
    if (!a || (a->kind != &gs__rigid_kind && a->kind != &gs__probe_kind))
        return NULL;
    return (gs__rigid *)a;
}


/* The last step of creating a body: the broad phase takes it, or the world
   lets it go again. */
GS__PRIVATE gs_result gs__rigid_register(gs_world *w, gs__rigid *r, gs_agent **out) {
    gs_result res = gs__sap_add(w, r);
    if (res != GS_OK) {
        w->agent_count--; /* it was the last one added */
        gs__free(w, r);
        return res;
    }
    return gs__sync_added(w, &r->base, out);
}

GS_API gs_result gs_rigid_create(gs_world *w, const gs_rigid_desc *desc,
                                 gs_agent **out) {
    gs_rigid_desc d;
    gs__rigid *r;
    gs__check c;
    gs_result res = gs__create_begin(w, desc, out, "gs_rigid_create");
    if (res != GS_OK) return res;
    d = gs__rigid_defaults(desc);
    r = (gs__rigid *)gs__alloc(w, gs__rigid_size(d.shape.type));
    if (!r) return gs__fail(w, GS_ERR_NO_MEMORY, "gs_rigid_create: out of memory");
    memset(r, 0, gs__rigid_size(d.shape.type));
    c = gs__check_begin(w, "gs_rigid_create");
    gs__rigid_check(&c, &d, &r->shape);
    if (c.r == GS_OK) gs__rigid_mass_check(&c, r, &d);
    if (c.r == GS_OK) c.r = gs__agent_init(w, &r->base, &gs__rigid_kind, d.solver.dt);
    if (c.r != GS_OK) {
        gs__free(w, r);
        return c.r;
    }
    r->x = d.position;
    r->q = gs__quat_normalize(d.orientation);
    r->v = d.velocity;
    r->w = d.angular_velocity;
    r->mat = d.material;
    r->solver = d.solver;
    r->continuous = d.continuous;
    r->reach2 = gs__rigid_reach2(r);
    r->i_min = gs__rigid_i_min(r);
    r->rolling = d.rolling;
    r->spin_friction = d.spin_friction;
    gs__rigid_sums_clear(r); /* one contact with its own material */
    gs__rigid_stiffen(r, gs__v3(0.0, 1.0, 0.0), r->mat.stiffness, r->mat.damping, 0.0, 1.0);
    r->stable_dt = gs__rigid_bound(r);
    gs__rigid_sums_clear(r);
    return gs__rigid_register(w, r, out);
}

GS_API gs_result gs_probe_create(gs_world *w, const gs_probe_desc *desc,
                                 gs_agent **out) {
    gs_probe_desc d;
    gs__rigid *r;
    gs__check c;
    gs_result res = gs__create_begin(w, desc, out, "gs_probe_create");
    if (res != GS_OK) return res;
    d = *desc;
    d.orientation = gs__orientation_default(d.orientation);
    d.material = gs__material_defaults(d.material);
    if (d.dt == 0.0) d.dt = 0.001;
    if (d.max_speed == 0.0) d.max_speed = 10.0;
    if (d.owner == 0) d.owner = w->host_id;
    r = (gs__rigid *)gs__alloc(w, gs__rigid_size(d.shape.type));
    if (!r) return gs__fail(w, GS_ERR_NO_MEMORY, "gs_probe_create: out of memory");
    memset(r, 0, gs__rigid_size(d.shape.type));
    c = gs__check_begin(w, "gs_probe_create");
    gs__shape_build(&c, &d.shape, &r->shape);
    gs__check_pos(&c, "position", d.position);
    gs__check_quat(&c, "orientation", d.orientation);
    gs__check_material(&c, &d.material);
    gs__check_dt(&c, "dt", d.dt);
    gs__check_positive(&c, "max_speed", d.max_speed);
    if (c.r == GS_OK) c.r = gs__agent_init(w, &r->base, &gs__probe_kind, d.dt);
    if (c.r != GS_OK) {
        gs__free(w, r);
        return c.r;
    }
    r->probe = 1;
    r->x = r->target = d.position;
    r->q = r->target_q = gs__quat_normalize(d.orientation);
    r->mat = d.material;
    r->max_speed = d.max_speed;
    r->owner = d.owner;
    r->stable_dt = HUGE_VAL;
    return gs__rigid_register(w, r, out);
}

GS_API gs_result gs_probe_set_target(gs_agent *a, gs_vec3 position,
                                     gs_quat orientation) {
    gs__rigid *r = gs__as_rigid(a);
    gs_result res = gs__world_unlocked(a ? a->world : NULL, "gs_probe_set_target");
    if (res != GS_OK) return res;
    if (!r || !r->probe)
        return gs__fail(a->world, GS_ERR_INVALID_ARG,
                        "gs_probe_set_target: agent %d is a %s, not a probe", a->index,
                        a->kind->name);
    if (!gs__finite3(position) || !gs__finite(orientation.x) ||
        !gs__finite(orientation.y) || !gs__finite(orientation.z) ||
        !gs__finite(orientation.w))
        return gs__fail(a->world, GS_ERR_NOT_FINITE,
                        "gs_probe_set_target: the pose must be finite");
    if (!gs__in_range3(position))
        return gs__fail(a->world, GS_ERR_OUT_OF_RANGE,
                        "gs_probe_set_target: position (%g, %g, %g) m is "
                        "outside +-GS_MAX_COORD (%g m)", position.x,
                        position.y, position.z, GS_MAX_COORD);
    r->target = position;
    r->target_q = gs__quat_normalize(gs__orientation_default(orientation));
    return GS_OK;
}

GS_API gs_vec3 gs_rigid_position(const gs_agent *a) {
    const gs__rigid *r = gs__as_rigid(a);
    return r ? r->x : gs__v3(0.0, 0.0, 0.0);
}
GS_API gs_quat gs_rigid_orientation(const gs_agent *a) {
    const gs__rigid *r = gs__as_rigid(a);
    return r ? r->q : gs__quat(0.0, 0.0, 0.0, 1.0);
}
GS_API gs_vec3 gs_rigid_velocity(const gs_agent *a) {
    const gs__rigid *r = gs__as_rigid(a);
    return r ? r->v : gs__v3(0.0, 0.0, 0.0);
}
GS_API gs_vec3 gs_rigid_angular_velocity(const gs_agent *a) {
    const gs__rigid *r = gs__as_rigid(a);
    return r ? r->w : gs__v3(0.0, 0.0, 0.0);
}
GS_API double gs_rigid_mass(const gs_agent *a) {
    const gs__rigid *r = gs__as_rigid(a);
    return r && !r->probe ? r->mass : 0.0;
}
GS_API double gs_rigid_stable_dt(const gs_agent *a) {
    const gs__rigid *r = gs__as_rigid(a);
    return r ? r->stable_dt : 0.0;
}

/* ========================================================================
   >>contact
   Narrow phase: exact answers for spheres and boxes against spheres;
   boxes and hulls against each other through libccd's MPR for the normal
   and depth and their vertices inside each other for the points (several,
   so that a box rests on a face); MPR alone for spheres against hulls. Penalty forces: a
   rigid pair is computed once and pushed equal and opposite (see "rigid
   pairs" below); a mesh and a body each compute the forces on themselves
   from the other's state carried to their own simulation time.
   ======================================================================== */
/* ---- broad phase: sweep and prune on x ----
   Two lists of the same bodies:
   - bodies, in creation order: the order in which contacts are summed, so
     that forces keep their last bits whichever way a query found them
     (fixed: a list sorted on moving keys would cost a bubble of
     O(n^(2/3)) swaps per step in a pile, a slab of it being passed on x);
   - near, by x - bound, kept sorted by bubbling a body that moved to its
     place: what a range query searches. Travel is added at the query, for
     the lag the scheduler allows now (its tolerance and a step, not 0.1 s:
     gs__lag_bound), so a falling pile does not make every query span the
     world.
   A body whose sweep (bound + its travel over the lag the scheduler
   allows) is over wide_at (a wall, a floor, a body moving fast) is listed
   apart and left out of bound_max and speed_max, which stretch the
   search: one wall would otherwise stretch every query over the whole
   world.
   A body's query looks in a uniform grid of the bodies not wide (a range
   on x, a mesh's, searches near; the box of a probe's shape, for the
   sleepers it wakes, takes whichever of the two looks at fewer bodies).
   Each gathers candidates, adds the wide ones, then puts them in the
   order of bodies. */
/* Swaps near[i] and near[j], with their keys. */
GS__PRIVATE void gs__sap_swap(gs_world *w, int i, int j) {
    struct gs__rigid *t = w->near[i];
    double k = w->near_keys[i];
    w->near[i] = w->near[j];
    w->near[j] = t;
    w->near_keys[i] = w->near_keys[j];
    w->near_keys[j] = k;
    w->near[i]->near = i;
    w->near[j]->near = j;
}

/* Moves r to its place in near (by near_key). A list not sorted yet waits
   for gs__sap_sort. */
GS__PRIVATE void gs__sap_bubble(gs_world *w, gs__rigid *r) {
    int i = r->near, n = w->nbodies;
    double k = r->near_key;
    const double *keys = w->near_keys;
    if (w->sap_dirty) return;
    while (i > 0 && keys[i - 1] > k) { gs__sap_swap(w, i - 1, i); --i; }
    while (i + 1 < n && keys[i + 1] < k) { gs__sap_swap(w, i, i + 1); ++i; }
}

/* Puts r in the wide list or takes it out, as its sweep says. */
GS__PRIVATE void gs__sap_classify(gs_world *w, gs__rigid *r) {
    int wide = r->sweep > w->wide_at;
    if (wide && r->wide < 0) {
        r->wide = w->nwide;
        w->wide[w->nwide++] = r;
    } else if (!wide && r->wide >= 0) {
        w->wide[r->wide] = w->wide[--w->nwide];
        w->wide[r->wide]->wide = r->wide;
        r->wide = -1;
    }
    if (wide) return;
    if (r->shape.bound > w->bound_max) w->bound_max = r->shape.bound;
    if (r->speed > w->speed_max) w->speed_max = r->speed;
}

/* ---- the grid: a body not wide sits in the cell of its centre, so that
   a body's query looks at the few cells around it instead of the slab of
   the world its x range crosses (O(n^(2/3)) bodies in a pile). ---- */
#define GS__GRID_SPAN 1e15 /* cells either side of 0 (keeps int64 exact) */

/* What a grid query reads of each body it looks at, in one cache line
   (world->grec, aligned to 64 bytes, in the order of bodies): copies of
   the body's x, bound and speed as gs__sap_sweep last saw them, and its
   cell. A body's x changes only in its own step, which ends in
   gs__sap_update, or with its state (gs__sap_update too): the copy is the
   body's x whenever another body asks. Walking the bodies themselves cost
   four cache lines of a large struct per body looked at, and in a pile
   of 4096 those no longer fit the cache. */
typedef struct gs__grec {
    double x, y, z;  /* m; the centre */
    double bound;    /* m */
    double speed;    /* m/s; as gs__rigid.speed */
    int64_t cell[3]; /* if in the grid */
} gs__grec;

/* What gs__rigid_vs_rigid reads of a neighbour before its distance test
   rejects the pair (about 4 pairs in 5 in a pile), besides the neighbour's
   grec (x, bound) and the first line of its agent (time, sleeping): one
   cache line in place of the ~8 of its struct those fields sit on. v and
   a_own change only where grec's fields do (gs__sap_update follows), and
   touched where the pushes start and end. */
typedef struct gs__nrec {
    gs_vec3 v;      /* m/s */
    gs_vec3 a_own;  /* m/s^2 */
    int probe;
    int touched;    /* sh_dx is not zero only then: read from the body */
    double pad;     /* to a line */
} gs__nrec;

GS__PRIVATE int64_t gs__grid_coord(const gs_world *w, double x) {
    double c = floor(x / w->cell);
    if (!(c >= -GS__GRID_SPAN)) c = -GS__GRID_SPAN; /* and NaN */
    if (c > GS__GRID_SPAN) c = GS__GRID_SPAN;
    return (int64_t)c;
}

GS__PRIVATE size_t gs__grid_bucket(const gs_world *w, const int64_t c[3]) {
    /* cells next to each other on x in buckets next to each other: a
       query's row of cells reads one or two lines of the table, not one
       each */
    uint64_t h = ((uint64_t)c[1] * 19349663u ^ (uint64_t)c[2] * 83492791u) + (uint64_t)c[0];
    /* bodies_cap is a power of two (16, doubled): a mask, not a division,
       for each of the 27 cells of a query */
    return (size_t)(h & (2 * (uint64_t)w->bodies_cap - 1));
}

GS__PRIVATE void gs__grid_unlink(gs_world *w, gs__rigid *r) {
    int i = r->sap, prev, next;
    if (!r->in_grid) return;
    prev = w->gprev[i];
    next = w->gnext[i];
    if (prev >= 0) w->gnext[prev] = next;
    else w->grid[gs__grid_bucket(w, w->grec[i].cell)] = next;
    if (next >= 0) w->gprev[next] = prev;
    r->in_grid = 0;
}

/* Keeps r in the cell of its centre, or out of the grid if it is wide. */
GS__PRIVATE void gs__grid_place(gs_world *w, gs__rigid *r) {
    int64_t c[3], *cell = w->grec[r->sap].cell;
    int i = r->sap;
    size_t b;
    if (w->cell <= 0.0 || r->wide >= 0) {
        gs__grid_unlink(w, r);
        return;
    }
    c[0] = gs__grid_coord(w, r->x.x);
    c[1] = gs__grid_coord(w, r->x.y);
    c[2] = gs__grid_coord(w, r->x.z);
    if (r->in_grid && c[0] == cell[0] && c[1] == cell[1] && c[2] == cell[2]) return;
    gs__grid_unlink(w, r);
    memcpy(cell, c, sizeof c);
    b = gs__grid_bucket(w, c);
    w->gprev[i] = -1;
    w->gnext[i] = w->grid[b];
    if (w->gnext[i] >= 0) w->gprev[w->gnext[i]] = i;
    w->grid[b] = i;
    r->in_grid = 1;
}

/* Every body again (a new cell size, a bigger table, bodies renumbered).
   The order of a cell's list does not matter: every query puts its
   candidates in the order of bodies. */
GS__PRIVATE void gs__grid_rebuild(gs_world *w) {
    int i;
    for (i = 0; i < 2 * w->bodies_cap; ++i) w->grid[i] = -1;
    for (i = 0; i < w->nbodies; ++i) w->bodies[i]->in_grid = 0;
    for (i = 0; i < w->nbodies; ++i) gs__grid_place(w, w->bodies[i]);
}

/* r's record from r (its x, bound and speed). */
GS__PRIVATE void gs__grec_load(gs_world *w, const gs__rigid *r) {
    gs__grec *g = &w->grec[r->sap];
    g->x = r->x.x;
    g->y = r->x.y;
    g->z = r->x.z;
    g->bound = r->shape.bound;
    g->speed = r->speed;
    w->nrec[r->sap].v = r->v;
    w->nrec[r->sap].a_own = r->a_own;
    w->nrec[r->sap].probe = r->probe;
    w->nrec[r->sap].touched = r->touched;
}

/* A body's speed for the broad phase: what its carried position moves by
   per second of lag (gs__rigid_vs_rigid: its velocity, and the change of
   velocity of its last step over up to one step). */
GS__PRIVATE void gs__sap_sweep(gs_world *w, gs__rigid *r) {
    double v = gs__len(r->v) + gs__len(r->a_own) * r->base.dt;
    r->sweep = r->shape.bound + (w->wide_lag > 0.0 ? w->wide_lag : 0.1) * v;
    r->speed = r->probe ? 0.0 : v;
    r->near_key = r->x.x - r->shape.bound;
    w->near_keys[r->near] = r->near_key;
    gs__grec_load(w, r);
}

GS__PRIVATE void gs__sap_update(gs__rigid *r) {
    gs_world *w = r->base.world;
    gs__sap_sweep(w, r);
    gs__sap_classify(w, r);
    gs__sap_bubble(w, r);
    gs__grid_place(w, r);
}

/* A stable merge sort of near[0, n) by near_key through tmp, then each
   body's index in it: the order that bubbling each new body in from the
   end gives, in O(n log n) for all of them where bubbling is O(n) for
   each one. */
GS__PRIVATE void gs__sap_sort_list(gs__rigid **list, gs__rigid **tmp, int n) {
    gs__rigid **src = list, **dst = tmp, **t;
    int width, i;
    for (width = 1; width < n; width *= 2) {
        for (i = 0; i < n; i += 2 * width) {
            int a = i, m = n - i > width ? i + width : n, b = m, k = i;
            int e = n - i > 2 * width ? i + 2 * width : n;
            while (a < m && b < e)
                dst[k++] = src[b]->near_key < src[a]->near_key ? src[b++] : src[a++];
            while (a < m) dst[k++] = src[a++];
            while (b < e) dst[k++] = src[b++];
        }
        t = src; src = dst; dst = t;
    }
    if (src != list) memcpy(list, src, (size_t)n * sizeof *list);
    for (i = 0; i < n; ++i) list[i]->near = i;
}

/* Sorts near if bodies were appended since (cand is the scratch: nothing
   is being asked then). */
GS__PRIVATE void gs__sap_sort(gs_world *w) {
    int i;
    if (!w->sap_dirty) return;
    gs__sap_sort_list(w->near, w->cand, w->nbodies);
    for (i = 0; i < w->nbodies; ++i) w->near_keys[i] = w->near[i]->near_key;
    w->sap_dirty = 0;
}

/* The broad phase's lists for cap bodies, in one block (freed as
   w->bodies): 5 lists of pointers, near's keys, the grid's 2 cap cells and
   its 2 cap links, the answer's 2 cap indices, then the records on a line
   of their own each (grec, then nrec). */
GS__PRIVATE gs_result gs__sap_grow(gs_world *w) {
    int cap = w->bodies_cap ? 2 * w->bodies_cap : 16;
    size_t head, per = 5 * sizeof(struct gs__rigid *) + sizeof(double) + 6 * sizeof(int) +
                       sizeof(gs__grec) + sizeof(gs__nrec);
    struct gs__rigid **list;
    gs__grec *grec;
    gs__nrec *nrec;
    char *block;
    if (w->bodies_cap > INT_MAX / 4 || (size_t)cap > (SIZE_MAX - 64) / per)
        return gs__fail(w, GS_ERR_CAPACITY, "broad phase: too many bodies");
    block = (char *)gs__alloc(w, (size_t)cap * per + 64);
    if (!block) return gs__fail(w, GS_ERR_NO_MEMORY, "broad phase: out of memory");
    list = (struct gs__rigid **)(void *)block;
    head = (size_t)cap * (per - sizeof(gs__grec) - sizeof(gs__nrec));
    head += (64 - (size_t)((uintptr_t)(block + head) % 64)) % 64;
    grec = (gs__grec *)(void *)(block + head);
    nrec = (gs__nrec *)(void *)(grec + cap);
    if (w->nbodies) {
        memcpy(list, w->bodies, (size_t)w->nbodies * sizeof *list);
        memcpy(list + cap, w->near, (size_t)w->nbodies * sizeof *list);
        memcpy((void *)(list + 5 * cap), w->near_keys, (size_t)w->nbodies * sizeof(double));
        memcpy(grec, w->grec, (size_t)w->nbodies * sizeof *grec);
        memcpy(nrec, w->nrec, (size_t)w->nbodies * sizeof *nrec);
    }
    if (w->nwide) memcpy(list + 2 * cap, w->wide, (size_t)w->nwide * sizeof *list);
    gs__free(w, w->bodies);
    w->bodies = list;
    w->near = list + cap;
    w->wide = list + 2 * cap;
    w->cand = list + 3 * cap;
    w->touched = list + 4 * cap;
    w->near_keys = (double *)(void *)(list + 5 * cap);
    w->grid = (int *)(void *)(w->near_keys + cap);
    w->gnext = w->grid + 2 * cap;
    w->gprev = w->gnext + cap;
    w->cand_sap = w->gprev + cap;
    w->grec = grec;
    w->nrec = nrec;
    w->bodies_cap = cap;
    gs__grid_rebuild(w);
    return GS_OK;
}

GS__PRIVATE gs_result gs__sap_add(gs_world *w, gs__rigid *r) {
    int sorted;
    if (w->nbodies == w->bodies_cap) {
        gs_result res = gs__sap_grow(w);
        if (res != GS_OK) return res;
    }
    r->sap = r->near = w->nbodies;
    r->wide = -1;
    r->in_grid = 0;
    w->bodies[w->nbodies] = w->near[w->nbodies] = r;
    w->nbodies++;
    sorted = !w->sap_dirty;
    w->sap_dirty = 1; /* appended, not bubbled in: gs__sap_sort will */
    gs__sap_update(r);
    if (sorted && (r->near == 0 || w->near_keys[r->near - 1] <= r->near_key))
        w->sap_dirty = 0; /* it belongs at the end */
    return GS_OK;
}

/* The bodies after r move down one (in bodies, near and the records),
   and the grid, which links them by index, is built again. */
GS__PRIVATE void gs__sap_remove(gs_world *w, gs__rigid *r) {
    int i;
    if (r->wide >= 0) {
        w->wide[r->wide] = w->wide[--w->nwide];
        w->wide[r->wide]->wide = r->wide;
    }
    for (i = r->sap + 1; i < w->nbodies; ++i) {
        w->bodies[i - 1] = w->bodies[i];
        w->bodies[i - 1]->sap = i - 1;
        w->grec[i - 1] = w->grec[i];
        w->nrec[i - 1] = w->nrec[i];
    }
    for (i = r->near + 1; i < w->nbodies; ++i) {
        w->near[i - 1] = w->near[i];
        w->near_keys[i - 1] = w->near_keys[i];
        w->near[i - 1]->near = i - 1;
    }
    w->nbodies--;
    gs__grid_rebuild(w);
}

/* Takes an agent out of the contact bookkeeping before it is destroyed. */
GS__PRIVATE void gs__agent_unlink(gs_agent *a) {
    gs__rigid *r = gs__as_rigid(a);
    if (r) gs__sap_remove(a->world, r);
    else if (gs__as_mesh(a)) a->world->nmeshes--;
}

/* At each advance: wide means a sweep over 4 times the mean body bound,
   the sweep counting the travel over the lag the scheduler allows (a body
   falling at 5 m/s is not wide: with 0.1 s of travel, every body of a
   falling pile would be, and every query would go through all of them), and
   bound_max and speed_max are those of the others, exactly (updates only
   ever raise them). */
GS__PRIVATE void gs__sap_refresh(gs_world *w) {
    double mean = 0.0, dt_max = 0.0;
    int i;
    gs__sap_sort(w);
    for (i = 0; i < w->agent_count; ++i) dt_max = fmax(dt_max, w->agents[i]->dt);
    w->wide_lag = fmin(0.1, w->tolerance + dt_max);
    for (i = 0; i < w->nbodies; ++i) mean += w->bodies[i]->shape.bound;
    w->wide_at = w->nbodies ? 4.0 * mean / (double)w->nbodies : 0.0;
    w->bound_max = w->speed_max = 0.0;
    w->nwide = 0;
    for (i = 0; i < w->nbodies; ++i) {
        w->bodies[i]->wide = -1;
        gs__sap_sweep(w, w->bodies[i]);
    }
    for (i = 0; i < w->nbodies; ++i) gs__sap_classify(w, w->bodies[i]);
    /* a query of a body not wide at rest spans 4 bound_max: 3 cells a side
       of one body each in a pile (cells of 4 bound_max: 2 a side of 8
       bodies each, 2.4 times the bodies to test) */
    w->cell = 2.0 * w->bound_max;
    if (w->nbodies) gs__grid_rebuild(w);
}

/* How far o reaches from its centre on any axis when its state is taken
   up to lag seconds from its time (m), with a slack for rounding. */
GS__PRIVATE double gs__reach_of(double bound, double speed, double lag) {
    return (bound + speed * lag) * (1.0 + 1e-9) + 1e-12;
}
GS__PRIVATE double gs__sap_reach(const gs__rigid *o, double lag) {
    return gs__reach_of(o->shape.bound, o->speed, lag);
}

/* Does o's reach meet [lo, hi] on x? */
GS__PRIVATE int gs__sap_meets(const gs__rigid *o, double lo, double hi, double lag) {
    double reach = gs__sap_reach(o, lag), eps = 1e-12 * (fabs(lo) + fabs(hi));
    return o->x.x - reach <= hi + eps && o->x.x + reach >= lo - eps;
}

/* The first body of near that could reach past x = lo. */
GS__PRIVATE int gs__sap_first(const gs_world *w, double lo, double lag) {
    int a = 0, b = w->nbodies;
    lo -= 2.0 * w->bound_max + w->speed_max * lag;
    lo -= 1e-9 * (1.0 + fabs(lo));
    while (a < b) {
        int mid = (a + b) / 2;
        if (w->near_keys[mid] < lo) a = mid + 1;
        else b = mid;
    }
    return a;
}

/* The candidates (w->cand_sap[0, n), sap indices) in the order of bodies,
   into w->cand, and their indices so ordered in cand_sap[0, n) (a contact
   finds their records by them). A body's query finds a few, in an order near that one:
   insertion. A range that crosses the world (a wall, a cloth) finds up to
   every body, where insertion is O(n^2): a merge sort through the second
   half of cand_sap. The indices are distinct, so either gives the one
   order. */
#define GS__ORDER_INSERTION 32
GS__PRIVATE void gs__sap_order(gs_world *w, int n) {
    int *src = w->cand_sap, *dst = w->cand_sap + w->bodies_cap, *t;
    int i, j, width;
    for (i = 0; i < n; i += GS__ORDER_INSERTION) { /* sorted runs */
        int end = n - i > GS__ORDER_INSERTION ? i + GS__ORDER_INSERTION : n;
        for (j = i + 1; j < end; ++j) {
            int r = src[j], k;
            for (k = j; k > i && src[k - 1] > r; --k) src[k] = src[k - 1];
            src[k] = r;
        }
    }
    for (width = GS__ORDER_INSERTION; width < n; width *= 2) {
        for (i = 0; i < n; i += 2 * width) {
            int a = i, m = n - i > width ? i + width : n, b = m, k = i;
            int e = n - i > 2 * width ? i + 2 * width : n;
            while (a < m && b < e) dst[k++] = src[b] < src[a] ? src[b++] : src[a++];
            while (a < m) dst[k++] = src[a++];
            while (b < e) dst[k++] = src[b++];
        }
        t = src; src = dst; dst = t;
    }
    if (src != w->cand_sap) memcpy(w->cand_sap, src, (size_t)n * sizeof *src);
    for (i = 0; i < n; ++i) w->cand[i] = w->bodies[w->cand_sap[i]];
}

/* Every body that may meet [lo, hi] on x when taken up to lag seconds from
   its time, into w->cand in the order of bodies. Returns how many. */
GS__PRIVATE int gs__sap_query(gs_world *w, double lo, double hi, double lag) {
    double top = hi + w->speed_max * lag;
    int n = 0, i;
    gs__sap_sort(w);
    top += 1e-9 * (1.0 + fabs(top));
    for (i = 0; i < w->nwide; ++i)
        if (gs__sap_meets(w->wide[i], lo, hi, lag)) w->cand_sap[n++] = w->wide[i]->sap;
    for (i = gs__sap_first(w, lo, lag); i < w->nbodies && w->near_keys[i] <= top; ++i)
        if (w->near[i]->wide < 0 && gs__sap_meets(w->near[i], lo, hi, lag)) w->cand_sap[n++] = w->near[i]->sap;
    gs__sap_order(w, n);
    return n;
}

/* The bodies other than r that may touch r when taken up to lag seconds
   from their time (gs__sap_meets on x and gs__sweeps_meet on y and z),
   into w->cand in the order of bodies: the wide ones, and those of the
   cells within reach of r (any body not wide is within bound_max +
   speed_max lag of its cell's reach). A reach of many cells takes the list
   search instead. Returns how many. */
#define GS__GRID_MAX_CELLS 64
GS__PRIVATE double gs__own_reach(const gs__rigid *r, double lag);
GS__PRIVATE int gs__sweeps_meet(const gs__rigid *r, const gs__rigid *o, double lag);

/* gs__sap_query's answer less r and the bodies out of r's reach on y or z. */
GS__PRIVATE int gs__sap_query_sweeps(gs_world *w, const gs__rigid *r, double lo, double hi,
                                     double lag) {
    int n = gs__sap_query(w, lo, hi, lag), i, k = 0;
    for (i = 0; i < n; ++i)
        if (w->cand[i] != r && gs__sweeps_meet(r, w->cand[i], lag)) {
            w->cand_sap[k] = w->cand_sap[i];
            w->cand[k++] = w->cand[i];
        }
    return k;
}

/* gs__sap_meets(o, lo, hi, lag) && gs__sweeps_meet(r, o, lag), with r's
   reach (own) and o's found once: the same answer, bit for bit. */
GS__PRIVATE int gs__sap_meets3(const gs__rigid *o, const gs__rigid *r, double own,
                               double lo, double hi, double lag) {
    double reach = gs__sap_reach(o, lag), eps = 1e-12 * (fabs(lo) + fabs(hi));
    double both = reach + own * (1.0 + 1e-9);
    return o->x.x - reach <= hi + eps && o->x.x + reach >= lo - eps &&
           fabs(r->x.y - o->x.y) <= both && fabs(r->x.z - o->x.z) <= both;
}

GS__PRIVATE int gs__sap_query_near(gs_world *w, const gs__rigid *r, double lag) {
    double own = gs__own_reach(r, lag);
    double lo = r->x.x - own, hi = r->x.x + own;
    double reach = (own + w->bound_max + w->speed_max * lag) * (1.0 + 1e-9) + 1e-12;
    int64_t a[3], b[3], c[3];
    int n = 0, i;
    gs__sap_sort(w); /* the candidates go in the order of bodies */
    if (w->cell <= 0.0 || !(reach < 0.5 * GS__GRID_MAX_CELLS * w->cell))
        return gs__sap_query_sweeps(w, r, lo, hi, lag);
    a[0] = gs__grid_coord(w, r->x.x - reach); b[0] = gs__grid_coord(w, r->x.x + reach);
    a[1] = gs__grid_coord(w, r->x.y - reach); b[1] = gs__grid_coord(w, r->x.y + reach);
    a[2] = gs__grid_coord(w, r->x.z - reach); b[2] = gs__grid_coord(w, r->x.z + reach);
    if ((b[0] - a[0] + 1) * (b[1] - a[1] + 1) * (b[2] - a[2] + 1) > GS__GRID_MAX_CELLS)
        return gs__sap_query_sweeps(w, r, lo, hi, lag);
    /* on y and z too (gs__sweeps_meet, as the caller would): the cells hold
       about 27 times the bodies r can touch, and the fewer candidates the
       cheaper their sort */
    for (i = 0; i < w->nwide; ++i)
        if (w->wide[i] != r && gs__sap_meets3(w->wide[i], r, own, lo, hi, lag))
            w->cand_sap[n++] = w->wide[i]->sap;
    {   /* gs__sap_meets3 with what is the same for every body found once
           (the same operations: the same answer, bit for bit) */
        double eps = 1e-12 * (fabs(lo) + fabs(hi)), hi_e = hi + eps, lo_e = lo - eps;
        double own_e = own * (1.0 + 1e-9), ry = r->x.y, rz = r->x.z;
        const gs__grec *grec = w->grec;
        const int *grid = w->grid, *gnext = w->gnext;
        int *cand = w->cand_sap, self = r->sap;
        /* x innermost: a row of cells has its buckets side by side */
        for (c[2] = a[2]; c[2] <= b[2]; ++c[2])
            for (c[1] = a[1]; c[1] <= b[1]; ++c[1])
                for (c[0] = a[0]; c[0] <= b[0]; ++c[0]) {
                    for (i = grid[gs__grid_bucket(w, c)]; i >= 0; i = gnext[i]) {
                        const gs__grec *o = &grec[i];
                        double reach, both;
                        if (o->cell[0] != c[0] || o->cell[1] != c[1] || o->cell[2] != c[2] ||
                            i == self)
                            continue;
                        reach = gs__reach_of(o->bound, o->speed, lag);
                        both = reach + own_e;
                        if (o->x - reach <= hi_e && o->x + reach >= lo_e &&
                            fabs(ry - o->y) <= both && fabs(rz - o->z) <= both)
                            cand[n++] = i;
                    }
                }
    }
    gs__sap_order(w, n);
    return n;
}

/* Does the reach of a body at p (its bound and speed) meet [lo, hi] on
   all three axes? */
GS__PRIVATE int gs__meets_box(gs_vec3 p, double bound, double speed, gs_vec3 lo, gs_vec3 hi,
                              double lag) {
    double reach = gs__reach_of(bound, speed, lag);
    double ex = 1e-12 * (fabs(lo.x) + fabs(hi.x)), ey = 1e-12 * (fabs(lo.y) + fabs(hi.y));
    double ez = 1e-12 * (fabs(lo.z) + fabs(hi.z));
    return p.x - reach <= hi.x + ex && p.x + reach >= lo.x - ex &&
           p.y - reach <= hi.y + ey && p.y + reach >= lo.y - ey &&
           p.z - reach <= hi.z + ez && p.z + reach >= lo.z - ez;
}
GS__PRIVATE int gs__sap_meets_box(const gs__rigid *o, gs_vec3 lo, gs_vec3 hi, double lag) {
    return gs__meets_box(o->x, o->shape.bound, o->speed, lo, hi, lag);
}

/* The first body of near from i on whose near_key is over top. */
GS__PRIVATE int gs__sap_past(const gs_world *w, int a, double top) {
    int b = w->nbodies;
    while (a < b) {
        int mid = a + (b - a) / 2;
        if (w->near_keys[mid] <= top) a = mid + 1;
        else b = mid;
    }
    return a;
}

/* Every body whose reach may meet the box [lo, hi] (the box of a probe's
   shape: a wall's bounding sphere spans the world), into w->cand in the
   order of bodies. The grid's cells over the box, or near's slab of it on
   x, whichever looks at fewer: a wall across the pile on x has a slab of
   every body and a face of O(n^(2/3)) cells. Returns how many. */
GS__PRIVATE int gs__sap_query_box(gs_world *w, gs_vec3 lo, gs_vec3 hi, double lag) {
    double pad = (w->bound_max + w->speed_max * lag) * (1.0 + 1e-9) + 1e-12;
    double top = hi.x + w->speed_max * lag;
    int n = 0, i, first, past;
    int64_t a[3], b[3], c[3];
    gs__sap_sort(w);
    top += 1e-9 * (1.0 + fabs(top));
    first = gs__sap_first(w, lo.x, lag);
    past = gs__sap_past(w, first, top);
    for (i = 0; i < w->nwide; ++i)
        if (gs__sap_meets_box(w->wide[i], lo, hi, lag)) w->cand_sap[n++] = w->wide[i]->sap;
    if (w->cell > 0.0) {
        double cells = 1.0;
        a[0] = gs__grid_coord(w, lo.x - pad); b[0] = gs__grid_coord(w, hi.x + pad);
        a[1] = gs__grid_coord(w, lo.y - pad); b[1] = gs__grid_coord(w, hi.y + pad);
        a[2] = gs__grid_coord(w, lo.z - pad); b[2] = gs__grid_coord(w, hi.z + pad);
        for (i = 0; i < 3; ++i) cells *= (double)(b[i] - a[i]) + 1.0;
        if (cells < (double)(past - first)) {
            for (c[0] = a[0]; c[0] <= b[0]; ++c[0])
                for (c[1] = a[1]; c[1] <= b[1]; ++c[1])
                    for (c[2] = a[2]; c[2] <= b[2]; ++c[2]) {
                        int k;
                        for (k = w->grid[gs__grid_bucket(w, c)]; k >= 0; k = w->gnext[k]) {
                            const gs__grec *o = &w->grec[k];
                            if (o->cell[0] == c[0] && o->cell[1] == c[1] && o->cell[2] == c[2] &&
                                gs__meets_box(gs__v3(o->x, o->y, o->z), o->bound, o->speed, lo,
                                              hi, lag))
                                w->cand_sap[n++] = k;
                        }
                    }
            gs__sap_order(w, n);
            return n;
        }
    }
    for (i = first; i < past; ++i)
        if (w->near[i]->wide < 0 && gs__sap_meets_box(w->near[i], lo, hi, lag))
            w->cand_sap[n++] = w->near[i]->sap;
    gs__sap_order(w, n);
    return n;
}

/* How far r's shape reaches from its centre when a contact takes r up to
   lag seconds on along its velocity (gs__rigid_vs_rigid does, to the time
   of a body that is ahead of it within its substep). */
GS__PRIVATE double gs__own_reach(const gs__rigid *r, double lag) {
    return r->shape.bound + gs__len(r->v) * lag;
}

/* Can o touch r at a lag of o's time up to lag (s)? A contact needs
   |r - (o + v_o lag)| < both bounds, so on each axis the centres must be
   within both bounds and o's travel (x is the query's). */
GS__PRIVATE int gs__sweeps_meet(const gs__rigid *r, const gs__rigid *o, double lag) {
    double reach = gs__sap_reach(o, lag) + gs__own_reach(r, lag) * (1.0 + 1e-9);
    return fabs(r->x.y - o->x.y) <= reach && fabs(r->x.z - o->x.z) <= reach;
}

typedef struct gs__body {
    const gs__shape *s;
    gs_vec3 p;
    gs_quat q;
} gs__body;

/* `none` is the normal (b to a) when the centres coincide (closer than
   1e-12 of the radii, where the line between them is rounding noise: a
   body sees the other carried back along its velocity to nearly where it
   was). The caller makes it antisymmetric, so that the two bodies of a
   pair are pushed apart, never the same way together (which made energy
   from nothing). */
GS__PRIVATE int gs__sphere_sphere(gs_vec3 ca, double ra, gs_vec3 cb, double rb,
                                  gs_vec3 none, gs_contact *c) {
    gs_vec3 d = gs__sub(ca, cb);
    double l = gs__len(d), depth = ra + rb - l;
    if (!(depth > 0.0)) return 0;
    c->normal = l > 1e-12 * (ra + rb) ? gs__scale(d, 1.0 / l) : none;
    c->depth = depth;
    c->point = gs__madd(cb, c->normal, rb - 0.5 * depth);
    return 1;
}

/* Sphere (centre, r) against a box body; the normal points to the sphere. */
GS__PRIVATE int gs__sphere_box(gs_vec3 centre, double r, const gs__body *b,
                               gs_contact *c) {
    gs_vec3 h = b->s->half, l = gs__unrotate(b->q, gs__sub(centre, b->p));
    gs_vec3 k = gs__v3(fmax(-h.x, fmin(h.x, l.x)), fmax(-h.y, fmin(h.y, l.y)),
                       fmax(-h.z, fmin(h.z, l.z)));
    gs_vec3 d = gs__sub(l, k), n;
    double dist = gs__len(d);
    if (dist >= r) return 0;
    if (dist > 0.0) {
        n = gs__scale(d, 1.0 / dist);
        c->depth = r - dist;
    } else { /* centre inside: leave through the nearest face */
        double px = h.x - fabs(l.x), py = h.y - fabs(l.y), pz = h.z - fabs(l.z);
        if (px <= py && px <= pz) { n = gs__v3(l.x < 0 ? -1.0 : 1.0, 0, 0); c->depth = r + px; k.x = l.x < 0 ? -h.x : h.x; }
        else if (py <= pz) { n = gs__v3(0, l.y < 0 ? -1.0 : 1.0, 0); c->depth = r + py; k.y = l.y < 0 ? -h.y : h.y; }
        else { n = gs__v3(0, 0, l.z < 0 ? -1.0 : 1.0); c->depth = r + pz; k.z = l.z < 0 ? -h.z : h.z; }
    }
    c->normal = gs__rotate(b->q, n);
    c->point = gs__add(b->p, gs__rotate(b->q, k));
    return 1;
}

/* ---- libccd glue: a body's support and centre, in ccd_real_t ---- */
GS__PRIVATE gs_vec3 gs__body_support(const gs__body *b, gs_vec3 dir) {
    gs_vec3 dl = gs__unrotate(b->q, dir), best;
    double bd = -HUGE_VAL;
    int i;
    if (b->s->type == GS_SHAPE_SPHERE) {
        double l = gs__len(dir);
        return l > 0.0 ? gs__madd(b->p, dir, b->s->radius / l) : b->p;
    }
    best = b->s->v[0];
    for (i = 0; i < b->s->nv; ++i) {
        double d = gs__dot(b->s->v[i], dl);
        if (d > bd) { bd = d; best = b->s->v[i]; }
    }
    return gs__add(b->p, gs__rotate(b->q, best));
}

GS__PRIVATE void gs__ccd_support(const void *obj, const ccd_vec3_t *dir,
                                 ccd_vec3_t *out) {
    gs_vec3 d = gs__v3((double)dir->v[0], (double)dir->v[1], (double)dir->v[2]);
    gs_vec3 s = gs__body_support((const gs__body *)obj, d);
    out->v[0] = (ccd_real_t)s.x;
    out->v[1] = (ccd_real_t)s.y;
    out->v[2] = (ccd_real_t)s.z;
}

GS__PRIVATE void gs__ccd_center(const void *obj, ccd_vec3_t *out) {
    const gs__body *b = (const gs__body *)obj;
    out->v[0] = (ccd_real_t)b->p.x;
    out->v[1] = (ccd_real_t)b->p.y;
    out->v[2] = (ccd_real_t)b->p.z;
}

/* MPR through libccd, every output checked: a non-finite or zero direction
   (touching or coincident centres) falls back to the line between centres,
   then to `none` (see gs__sphere_sphere); a non-finite depth counts as
   touching. */
GS__PRIVATE int gs__mpr(const gs__body *a, const gs__body *b, gs_vec3 none,
                        gs_contact *c) {
    ccd_t ccd;
    ccd_real_t depth = 0;
    ccd_vec3_t dir, pos;
    gs_vec3 n, p;
    double ln;
    CCD_INIT(&ccd);
    ccd.support1 = gs__ccd_support;
    ccd.support2 = gs__ccd_support;
    ccd.center1 = gs__ccd_center;
    ccd.center2 = gs__ccd_center;
    ccd.max_iterations = 100;
    if (ccdMPRPenetration(b, a, &ccd, &depth, &dir, &pos) != 0) return 0;
    n = gs__v3((double)dir.v[0], (double)dir.v[1], (double)dir.v[2]); /* b -> a */
    p = gs__v3((double)pos.v[0], (double)pos.v[1], (double)pos.v[2]);
    ln = gs__len(n);
    if (!gs__finite(ln) || !(ln > 1e-12)) {
        n = gs__sub(a->p, b->p);
        ln = gs__len(n);
        if (!(ln > 1e-12)) { n = none; ln = 1.0; }
    }
    c->normal = gs__scale(n, 1.0 / ln);
    c->depth = gs__finite((double)depth) && depth > 0 ? (double)depth : 0.0;
    c->point = gs__finite3(p) ? p : gs__scale(gs__add(a->p, b->p), 0.5);
    return 1;
}

/* Largest extent of a body along direction n (its support value). */
GS__PRIVATE double gs__support_along(const gs__body *b, gs_vec3 n) {
    return gs__dot(gs__body_support(b, n), n);
}

/* Whether world point p lies inside polytope b, its faces moved out by eps
   (a corner lying exactly on a face, as when equal boxes stand aligned,
   still counts). */
GS__PRIVATE int gs__inside(const gs__body *b, gs_vec3 p, double eps) {
    gs_vec3 l = gs__unrotate(b->q, gs__sub(p, b->p));
    int f;
    for (f = 0; f < b->s->nf; ++f)
        if (gs__dot(b->s->fn[f], l) - b->s->fd[f] > eps) return 0;
    return 1;
}

/* Polytope against polytope: MPR gives the normal n (b to a) and depth of
   least translation; every vertex of either body inside the other becomes a
   contact along that one normal, with its own depth, so a box resting on a
   face gets four points and no torque from a single off-centre one. Edge
   against edge has no vertex inside: the MPR point stands alone. */
GS__PRIVATE int gs__poly_poly(const gs__body *a, const gs__body *b,
                              gs_vec3 none, gs_contact *out, int max) {
    gs_contact m;
    double eps, top_b, bottom_a;
    int i, n = 0;
    if (!gs__mpr(a, b, none, &m)) return 0;
    eps = 1e-6 * fmin(a->s->size, b->s->size);
    top_b = gs__support_along(b, m.normal);                      /* b's far side */
    bottom_a = -gs__support_along(a, gs__scale(m.normal, -1.0)); /* a's near side */
    for (i = 0; i < a->s->nv && n < max; ++i) {
        gs_vec3 v = gs__add(a->p, gs__rotate(a->q, a->s->v[i]));
        if (!gs__inside(b, v, eps)) continue;
        out[n].normal = m.normal;
        out[n].point = v;
        out[n].depth = fmin(m.depth, fmax(0.0, top_b - gs__dot(v, m.normal)));
        n++;
    }
    for (i = 0; i < b->s->nv && n < max; ++i) {
        gs_vec3 v = gs__add(b->p, gs__rotate(b->q, b->s->v[i]));
        if (!gs__inside(a, v, eps)) continue;
        out[n].normal = m.normal;
        out[n].point = v;
        out[n].depth = fmin(m.depth, fmax(0.0, gs__dot(v, m.normal) - bottom_a));
        n++;
    }
    if (n == 0) out[n++] = m;
    return n;
}

/* All contacts between two bodies, normals from b to a; `none` where the
   shapes give no direction (see gs__sphere_sphere). */
GS__PRIVATE int gs__collide(const gs__body *a, const gs__body *b, gs_vec3 none,
                            gs_contact *out, int max) {
    gs_shape_type ta = a->s->type, tb = b->s->type;
    int n;
    if (ta == GS_SHAPE_SPHERE && tb == GS_SHAPE_SPHERE)
        return gs__sphere_sphere(a->p, a->s->radius, b->p, b->s->radius, none, out);
    if (ta == GS_SHAPE_SPHERE && tb == GS_SHAPE_BOX)
        return gs__sphere_box(a->p, a->s->radius, b, out);
    if (ta == GS_SHAPE_BOX && tb == GS_SHAPE_SPHERE) {
        n = gs__sphere_box(b->p, b->s->radius, a, out);
        if (n) out->normal = gs__scale(out->normal, -1.0);
        return n;
    }
    if (ta == GS_SHAPE_SPHERE || tb == GS_SHAPE_SPHERE) return gs__mpr(a, b, none, out);
    return gs__poly_poly(a, b, none, out, max);
}

GS__PRIVATE gs__body gs__body_of(const gs__rigid *r) {
    gs__body b;
    b.s = &r->shape;
    b.p = r->x;
    b.q = r->q;
    return b;
}

GS_API gs_result gs_collide_shapes(const gs_shape_desc *a, gs_vec3 pa, gs_quat qa,
                                   const gs_shape_desc *b, gs_vec3 pb, gs_quat qb,
                                   gs_contact *c, int *overlap) {
    gs__shape sa, sb;
    gs__body ba, bb;
    gs_contact all[2 * GS_MAX_HULL_POINTS];
    gs__check chk = gs__check_begin(NULL, "gs_collide_shapes");
    int n, i, deepest = 0;
    if (overlap) *overlap = 0;
    if (!a || !b || !c || !overlap) return GS_ERR_INVALID_ARG;
    gs__shape_build(&chk, a, &sa);
    gs__shape_build(&chk, b, &sb);
    if (chk.r != GS_OK) return chk.r;
    if (!gs__finite(pa.x) || !gs__finite(pa.y) || !gs__finite(pa.z) ||
        !gs__finite(pb.x) || !gs__finite(pb.y) || !gs__finite(pb.z))
        return GS_ERR_NOT_FINITE;
    if (!gs__in_range3(pa) || !gs__in_range3(pb)) return GS_ERR_OUT_OF_RANGE;
    ba.s = &sa; ba.p = pa; ba.q = gs__quat_normalize(gs__orientation_default(qa));
    bb.s = &sb; bb.p = pb; bb.q = gs__quat_normalize(gs__orientation_default(qb));
    n = gs__collide(&ba, &bb, gs__v3(0.0, 1.0, 0.0), all, 2 * GS_MAX_HULL_POINTS);
    for (i = 1; i < n; ++i)
        if (all[i].depth > all[deepest].depth) deepest = i;
    if (n) *c = all[deepest];
    *overlap = n > 0;
    return GS_OK;
}

/* The force on a at a contact (normal from b to a) with relative velocity
   vrel = v_a - v_b at the point: a spring-damper that never pulls, and
   Coulomb friction made viscous below the slip speed where it would exceed
   slope N s/m. Friction is explicit, so slope must keep h * slope / m
   under 2: callers pass m_eff / (2 dt) (gs__friction_slope). */
GS__PRIVATE gs_vec3 gs__penalty(const gs_contact *c, gs_vec3 vrel,
                                const gs_material *ma, const gs_material *mb,
                                double slope) {
    double k = 0.5 * (ma->stiffness + mb->stiffness);
    double d = 0.5 * (ma->damping + mb->damping);
    double mu = sqrt(ma->friction * mb->friction);
    double vn = gs__dot(vrel, c->normal), fn = k * c->depth - d * vn, vt_len, ft;
    gs_vec3 vt;
    if (!(fn > 0.0)) return gs__v3(0.0, 0.0, 0.0);
    vt = gs__madd(vrel, c->normal, -vn);
    vt_len = gs__len(vt);
    ft = fmin(mu * fn, slope * vt_len);
    if (!(vt_len > 0.0)) return gs__scale(c->normal, fn);
    return gs__madd(gs__scale(c->normal, fn), vt, -ft / vt_len);
}

/* The friction slope for a contact between bodies of inverse effective
   masses ra and rb (1/kg) stepping by dt: half the explicit limit. A body
   in several contacts is damped by their sum: a rigid body counts every
   slope in c_sum and substeps for it (gs__rigid_bound). */
GS__PRIVATE double gs__friction_slope(double ra, double rb, double dt) {
    return 0.5 / ((ra + rb) * dt);
}

GS__PRIVATE gs_vec3 gs__point_velocity(const gs__rigid *r, gs_vec3 p) {
    return gs__add(r->v, gs__cross(r->w, gs__sub(p, r->x)));
}

/* A particle (a small sphere) against a body whose centre is taken at
   `centre`; normal from body to particle. Both sides of such a contact ask
   with the particle as a (the body takes minus the particle's force), so
   a fixed normal for coincident centres pushes them apart. */
GS__PRIVATE int gs__particle_contact(gs_vec3 x, double rp, const gs__rigid *r,
                                     gs_vec3 centre, gs_contact *c) {
    gs__body b, pb;
    gs__shape ps;
    /* the bounding test first: it rejects nearly every particle of a
       cloth, and the body's description is not free to make */
    if (gs__dot(gs__sub(x, centre), gs__sub(x, centre)) >=
        (rp + r->shape.bound) * (rp + r->shape.bound))
        return 0;
    b = gs__body_of(r);
    b.p = centre;
    if (r->shape.type == GS_SHAPE_SPHERE)
        return gs__sphere_sphere(x, rp, centre, r->shape.radius, gs__v3(0.0, 1.0, 0.0), c);
    if (r->shape.type == GS_SHAPE_BOX) return gs__sphere_box(x, rp, &b, c);
    ps.type = GS_SHAPE_SPHERE; /* only type and radius are read */
    ps.radius = rp;
    pb.s = &ps; pb.p = x; pb.q = gs__quat(0.0, 0.0, 0.0, 1.0);
    return gs__mpr(&pb, &b, gs__v3(0.0, 1.0, 0.0), c);
}

GS__PRIVATE int gs__is_collider(const gs_agent *a) { return gs__as_rigid(a) != NULL; }

GS__PRIVATE int gs__world_has_contacts(const gs_world *w) {
    return w->ground || w->nbodies > 0;
}

/* Rolling resistance on r at a contact with normal force fn (N): a torque
   of at most rolling * fn against r's spin w_rel (rad/s) relative to what
   it touches, about axes in the contact plane. Below that it is viscous,
   at a tenth of the explicit limit: friction couples the spin to the
   slide (a solid sphere's contact point moves 3.5x as easily as its
   centre, which the friction slope does not count), and at half the limit
   the two locked into a two-step oscillation, a ball crawling at 1 mm/s
   for ever (measured; at a fifth and below it stops cleanly).
   Torsional friction (spin_friction) is the same about the normal: up to
   spin_friction * fn against the spin about it, viscous below that at the
   same fraction of the explicit limit. */
#define GS__ROLL_K 0.1
GS__PRIVATE gs_vec3 gs__resist(gs_vec3 w, double lever, double fn, const gs__rigid *r) {
    double spin = gs__len(w), most;
    if (!(lever > 0.0) || !(spin > 0.0)) return gs__v3(0.0, 0.0, 0.0);
    most = fmin(lever * fn, GS__ROLL_K * r->i_min * spin / r->base.dt);
    return gs__scale(w, -most / spin);
}
GS__PRIVATE gs_vec3 gs__rolling_torque(const gs__rigid *r, gs_vec3 normal, double fn,
                                       gs_vec3 w_rel) {
    double wn = gs__dot(w_rel, normal);
    if (!(fn > 0.0)) return gs__v3(0.0, 0.0, 0.0);
    return gs__add(gs__resist(gs__madd(w_rel, normal, -wn), r->rolling, fn, r),
                   gs__resist(gs__scale(normal, wn), r->spin_friction, fn, r));
}

/* Adds a contact's force, times share (the part of the substep it acts
   in), to r and returns it; *roll gets the rolling torque (NULL: not
   wanted). The substep plan counts the contact's stiffness and damping on
   both bodies' reach (other_reach2 is 0 for the ground and a probe): when
   r moves a body it pushes (gs__rigid_vs_rigid), the pair's relative
   motion is what must stay stable, and for equal bodies it is twice as
   fast as r's alone. */
GS__PRIVATE gs_vec3 gs__rigid_apply(gs__rigid *r, const gs_contact *c,
                                    gs_vec3 vrel, gs_vec3 w_other,
                                    const gs_material *other, double other_reach2,
                                    double share, gs_vec3 *roll) {
    double slope = gs__friction_slope(r->reach2, other_reach2, r->base.dt);
    double both = (r->reach2 + other_reach2) / r->reach2;
    gs_vec3 f = gs__scale(gs__penalty(c, vrel, &r->mat, other, slope), share), tr;
    gs__rigid_stiffen(r, c->normal, 0.5 * (r->mat.stiffness + other->stiffness),
                      0.5 * (r->mat.damping + other->damping), slope, both);
    tr = gs__rolling_torque(r, c->normal, gs__dot(f, c->normal), gs__sub(r->w, w_other));
    r->force = gs__add(r->force, f);
    r->torque = gs__add(r->torque, gs__cross(gs__sub(c->point, r->x), f));
    r->torque = gs__add(r->torque, tr);
    if (roll) *roll = tr;
    return f;
}

GS__PRIVATE void gs__rigid_ground(gs__rigid *r) {
    const gs_world *w = r->base.world;
    gs_contact c;
    int i;
    c.normal = gs__v3(0.0, 1.0, 0.0);
    if (r->shape.type == GS_SHAPE_SPHERE) {
        c.depth = w->ground_height - (r->x.y - r->shape.radius);
        c.point = gs__v3(r->x.x, w->ground_height, r->x.z);
        if (c.depth > 0.0)
            (void)gs__rigid_apply(r, &c, gs__point_velocity(r, c.point), gs__v3(0.0, 0.0, 0.0),
                                  &w->ground_material, 0.0, 1.0, NULL);
        return;
    }
    for (i = 0; i < r->shape.nv; ++i) {
        c.point = gs__add(r->x, gs__rotate(r->q, r->shape.v[i]));
        c.depth = w->ground_height - c.point.y;
        if (c.depth > 0.0)
            (void)gs__rigid_apply(r, &c, gs__point_velocity(r, c.point), gs__v3(0.0, 0.0, 0.0),
                                  &w->ground_material, 0.0, 1.0, NULL);
    }
}

/* ---- rigid pairs: computed once, pushed equal and opposite ----
   Bodies step one at a time, each at its own time. Were a pair computed
   by both, each taking the other carried to its time along the other's
   velocity, that guess would miss the other's path under substeps (a
   body that substeps under stiff contact curves within its step): the
   two normals and depths would disagree, the two forces would not cancel,
   and a pile of coincident bodies would gain momentum and energy from
   nothing. So the body that steps over a stretch of the pair's time first computes
   it for that stretch, and pushes the other with the opposite force at the
   same point: momentum is exchanged, never made (angular momentum too, up
   to where each centre is taken at the time of the force).
   The stretch a pair is computed over ends at the later of its two
   bodies' times, so r computes the part of each substep after o's time
   (all of it while o is behind, none once o is past) and the pair is
   computed once whatever their steps.
   A push lands on o when r's step ends (o's velocity changes then, ahead
   of o's own steps over that time, so o moves away sooner, never later).
   Within r's step o follows the pushes so far (its shadow: sh_dv, sh_dx,
   sh_dw): o held on its path while r substeps against it would act as a
   wall for the whole step, r would bounce off it, and the push it lands
   would then give o energy that came from nowhere. ---- */

/* The inverse world inertia of o applied to a torque: rad/s^2 per N m. */
GS__PRIVATE gs_vec3 gs__rigid_inv_inertia(const gs__rigid *o, gs_vec3 t) {
    return gs__rotate(o->q, gs__sym3_mul(&o->inv_inertia_body, gs__unrotate(o->q, t)));
}

/* o takes the force -f at point p (its centre taken at centre) and the
   rolling torque -roll, in this substep. */
GS__PRIVATE void gs__push(gs_world *w, gs__rigid *o, gs_vec3 p, gs_vec3 centre,
                          gs_vec3 f, gs_vec3 roll) {
    if (!o->touched) {
        o->touched = w->nrec[o->sap].touched = 1;
        w->touched[w->ntouched++] = o;
    }
    o->sh_f = gs__sub(o->sh_f, f);
    o->sh_t = gs__sub(gs__sub(o->sh_t, gs__cross(gs__sub(p, centre), f)), roll);
}

/* After r's substep of h seconds, the bodies it pushes follow (symplectic
   Euler, r's default). 0 when one of them would leave its speed limit: r's
   step is then refused, as for r's own. */
GS__PRIVATE int gs__push_advance(gs_world *w, double h) {
    int i, ok = 1;
    for (i = 0; i < w->ntouched; ++i) {
        gs__rigid *o = w->touched[i];
        double vmax = o->solver.max_speed;
        gs_vec3 v, sp;
        o->sh_dv = gs__madd(o->sh_dv, o->sh_f, o->inv_mass * h);
        o->sh_dw = gs__madd(o->sh_dw, gs__rigid_inv_inertia(o, o->sh_t), h);
        o->sh_dx = gs__madd(o->sh_dx, o->sh_dv, h);
        o->sh_f = o->sh_t = gs__v3(0.0, 0.0, 0.0);
        v = gs__add(o->v, o->sh_dv);
        sp = gs__add(o->w, o->sh_dw);
        if (!(gs__dot(v, v) <= vmax * vmax) ||
            !(gs__dot(sp, sp) * o->shape.bound * o->shape.bound <= vmax * vmax))
            ok = 0;
    }
    return ok;
}

/* At the end of r's step: the pushes land (land) or are dropped. */
GS__PRIVATE void gs__push_end(gs_world *w, int land) {
    int i;
    for (i = 0; i < w->ntouched; ++i) {
        gs__rigid *o = w->touched[i];
        if (land) {
            o->v = gs__add(o->v, o->sh_dv);
            o->w = gs__add(o->w, o->sh_dw);
        }
        o->sh_dv = o->sh_dx = o->sh_dw = o->sh_f = o->sh_t = gs__v3(0.0, 0.0, 0.0);
        o->touched = w->nrec[o->sap].touched = 0;
        if (land) gs__sap_update(o); /* its speed changed: so did its sweep */
    }
    w->ntouched = 0;
}

/* Are o's records (index k) o's own fields, bit for bit? What the
   contact reads of them must be what it would read of o. */
GS__PRIVATE int gs__records_fresh(const gs_world *w, const gs__rigid *o, int k) {
    const gs__grec *g = &w->grec[k];
    const gs__nrec *nr = &w->nrec[k];
    gs_vec3 zero = gs__v3(0.0, 0.0, 0.0);
    return o->sap == k && !memcmp(&g->x, &o->x.x, sizeof g->x) &&
           !memcmp(&g->y, &o->x.y, sizeof g->y) && !memcmp(&g->z, &o->x.z, sizeof g->z) &&
           !memcmp(&g->bound, &o->shape.bound, sizeof g->bound) &&
           !memcmp(&nr->v, &o->v, sizeof nr->v) && !memcmp(&nr->a_own, &o->a_own, sizeof nr->a_own) &&
           nr->probe == o->probe && nr->touched == o->touched &&
           (o->touched || !memcmp(&o->sh_dx, &zero, sizeof zero));
}

/* The contacts of r with o over r's substep [t, t + h]. o is taken where it
   is at t: carried from its time along its velocity and the acceleration
   of its last step (for at most one of its steps), plus what r's pushes
   did to it this step. The acceleration counts: a body resting on another
   gets its weight's worth of push each step, and a path without its
   gravity rises under that push alone (one with gravity alone sinks a
   body that rests on the ground): the pair would settle at a depth that
   depends on which body computes it (a 1 kg cube on a slab would sit
   30 um deep where its weight asks 25), jolted at each change of who
   steps first. A probe is
   moved by the application, not by forces: r computes against it always
   and pushes nothing. o's records are at k (its sap index): up to the
   distance test, which rejects most pairs, the contact reads them and
   the first line of o's agent, not o's struct. */
GS__PRIVATE void gs__rigid_vs_rigid(gs__rigid *r, gs__rigid *o, int k, double t, double h) {
    const gs__grec *g = &r->base.world->grec[k];
    const gs__nrec *nr = &r->base.world->nrec[k];
    gs_contact cs[2 * GS_MAX_HULL_POINTS];
    gs__body a = gs__body_of(r), b;
    gs_vec3 ox = gs__v3(g->x, g->y, g->z), bp = ox, ov, ow;
    double reach = r->shape.bound + g->bound, t_o, lag, la = 0.0, share = 1.0, ahead = 0.0;
    int n, i, fixed;
    GS_ASSERT(gs__records_fresh(r->base.world, o, k));
    /* a sleeper is a fixed body to what rests on it; one that moves wakes it
       (at r's time: the pair is r's to compute from there) */
    if (o->base.sleeping && gs__dot(gs__sub(r->x, ox), gs__sub(r->x, ox)) < reach * reach &&
        !(gs__rigid_speed(r) < r->base.world->sleep_speed))
        gs__agent_wake_at(&o->base, gs__agent_time(&r->base));
    fixed = nr->probe || o->base.sleeping;
    t_o = gs__agent_time(&o->base);
    lag = fmax(-0.1, fmin(0.1, t - t_o));
    if (!fixed) {
        /* the part after o's time; under 1e-9 it is the rounding of two
           times that are equal (steps * dt), and counting it would plan
           substeps for a contact r does not compute: a push landed before
           a step of 3 substeps moves a body otherwise than before one of
           1, and a cube on a slab kept a 0.7 mm/s swing */
        share = fmin(1.0, (t + h - t_o) / h);
        if (!(share > 1e-9)) return; /* o has computed it */
        /* a part that starts at o's time is found there: r carried to it,
           o as it stands, and r's share of it moves r as from then (late
           in x: r->late). Found at r's time, before the part it stands
           for, the force would lag the motion, and a spring that lags
           gives back more than it took (restitution 1.10 for steps of 1
           and 0.7 ms); moving r from its substep's start, it would lead
           the motion and take energy away (0.93). */
        if (t_o > t) {
            ahead = fmin(0.1, t_o - t); /* as far as the broad phase looks */
            a.p = gs__madd(r->x, r->v, ahead);
            lag = 0.0;
        }
        la = fmax(-o->base.dt, fmin(o->base.dt, lag));
        bp = gs__madd(gs__madd(ox, nr->v, lag), nr->a_own, la * (lag - 0.5 * la));
        /* sh_dx is +0 unless touched: the same sum either way */
        bp = gs__add(bp, nr->touched ? o->sh_dx : gs__v3(0.0, 0.0, 0.0));
    }
    if (gs__dot(gs__sub(a.p, bp), gs__sub(a.p, bp)) >= reach * reach) return;
    b = gs__body_of(o);
    b.p = bp;
    ov = o->v;
    ow = o->w;
    if (!fixed) {
        ov = gs__add(gs__madd(o->v, o->a_own, la), o->sh_dv);
        ow = gs__add(o->w, o->sh_dw);
    }
    /* coincident shapes: the lower agent index is pushed along -y, the
       higher along +y (one body computes the pair, so any fixed direction
       would do; this one is the same whichever it is) */
    n = gs__collide(&a, &b, gs__v3(0.0, r->base.index < o->base.index ? -1.0 : 1.0, 0.0),
                    cs, 2 * GS_MAX_HULL_POINTS);
    if (n > 0 && o->probe && o->base.rest < r->base.world->sleep_time) r->probe_touch = 1;
    for (i = 0; i < n; ++i) {
        gs_vec3 vo = gs__add(ov, gs__cross(ow, gs__sub(cs[i].point, b.p))), roll, f;
        gs_vec3 vr = gs__add(r->v, gs__cross(r->w, gs__sub(cs[i].point, a.p)));
        f = gs__rigid_apply(r, &cs[i], gs__sub(vr, vo), ow,
                            &o->mat, fixed ? 0.0 : o->reach2, share, &roll);
        r->late = gs__madd(r->late, f, ahead);
        if (!fixed) gs__push(r->base.world, o, cs[i].point, b.p, f, roll);
    }
}

GS__PRIVATE void gs__meshes_list(gs_world *w);
GS__PRIVATE void gs__mesh_bounds(const gs_agent *a, gs_vec3 *lo, gs_vec3 *hi);

/* A probe that moves wakes the sleepers it reaches (they take no steps in
   which to find it). */
GS__PRIVATE void gs__probe_wake(gs__rigid *p) {
    gs_world *w = p->base.world;
    double t = gs__agent_time(&p->base);
    gs_vec3 ext = gs__v3(p->shape.bound, p->shape.bound, p->shape.bound);
    int n, i;
    if (w->sleep_time < 0.0 || !(p->base.rest < w->sleep_time)) return;
    if (p->shape.type == GS_SHAPE_BOX) { /* the half extents of its box on each axis */
        gs_vec3 h = p->shape.half, ax = gs__rotate(p->q, gs__v3(h.x, 0.0, 0.0));
        gs_vec3 ay = gs__rotate(p->q, gs__v3(0.0, h.y, 0.0)), az = gs__rotate(p->q, gs__v3(0.0, 0.0, h.z));
        ext = gs__v3(fabs(ax.x) + fabs(ay.x) + fabs(az.x), fabs(ax.y) + fabs(ay.y) + fabs(az.y),
                     fabs(ax.z) + fabs(ay.z) + fabs(az.z));
        ext = gs__scale(ext, 1.0 + 1e-9); /* rounding of the rotation */
        ext = gs__v3(fmin(ext.x, p->shape.bound), fmin(ext.y, p->shape.bound), fmin(ext.z, p->shape.bound));
    }
    if (w->meshes_dirty) gs__meshes_list(w);
    for (i = 0; i < w->nmeshes; ++i) { /* a mesh within its reach (boxes) */
        gs_agent *m = w->meshes[i];
        gs_vec3 lo, hi;
        double b = p->shape.bound;
        gs__mesh_bounds(m, &lo, &hi);
        if (m->sleeping && p->x.x + b >= lo.x && p->x.x - b <= hi.x && p->x.y + b >= lo.y &&
            p->x.y - b <= hi.y && p->x.z + b >= lo.z && p->x.z - b <= hi.z)
            gs__agent_wake_at(m, t);
    }
    n = gs__sap_query_box(w, gs__sub(p->x, ext), gs__add(p->x, ext), gs__lag_bound(w, t, 0.1));
    for (i = 0; i < n; ++i) {
        gs__rigid *o = w->cand[i];
        double reach = p->shape.bound + o->shape.bound;
        gs__body a = gs__body_of(p), b = gs__body_of(o);
        gs_contact c[2 * GS_MAX_HULL_POINTS];
        if (o->base.sleeping && gs__dot(gs__sub(p->x, o->x), gs__sub(p->x, o->x)) < reach * reach &&
            gs__collide(&a, &b, gs__v3(0.0, 1.0, 0.0), c, 2 * GS_MAX_HULL_POINTS) > 0)
            gs__agent_wake_at(&o->base, t);
    }
}

GS__PRIVATE void gs__mesh_bounds(const gs_agent *a, gs_vec3 *lo, gs_vec3 *hi);
GS__PRIVATE double gs__mesh_mass(const gs_agent *a, int i);
GS__PRIVATE int gs__mesh_info(const gs_agent *a, const gs_vec3 **x,
                              const gs_vec3 **v, double *radius,
                              const gs_material **mat);

/* The reaction of a mesh's particles on a rigid body, each particle taken
   where its velocity puts it at the body's time (see gs__mesh_vs_rigid: both
   sides of a contact must see the same overlap, or energy appears). */
GS__PRIVATE int gs__chunk_skip(gs__mesh *m, int k, gs_vec3 c, double far, double lag);
GS__PRIVATE double gs__chunk_reach(double rp, double reach);

GS__PRIVATE void gs__rigid_vs_mesh(gs__rigid *r, gs_agent *m, double t) {
    const gs_vec3 *x = NULL, *v = NULL;
    const gs_material *mat = NULL;
    gs_vec3 lo, hi;
    double rp = 0.0, reach, slope, lag = fmax(-0.1, fmin(0.1, t - gs__agent_time(m)));
    int n = gs__mesh_info(m, &x, &v, &rp, &mat), i, k, end;
    gs__mesh_bounds(m, &lo, &hi);
    reach = r->shape.bound + rp + fabs(lag) * r->solver.max_speed;
    if (r->x.x + reach < lo.x || r->x.x - reach > hi.x || r->x.y + reach < lo.y ||
        r->x.y - reach > hi.y || r->x.z + reach < lo.z || r->x.z - reach > hi.z)
        return;
    for (k = 0, i = 0; i < n; ++k, i = end) {
        end = i + GS__CHUNK < n ? i + GS__CHUNK : n;
        if (gs__chunk_skip(gs__as_mesh(m), k, r->x, gs__chunk_reach(rp, r->shape.bound), lag))
            continue;
        for (; i < end; ++i) {
        gs_contact c;
        gs_vec3 f;
        if (!gs__particle_contact(gs__madd(x[i], v[i], lag), rp, r, r->x, &c)) continue;
        /* a sleeping mesh is fixed to a body resting on it; one that moves
           wakes it (at r's time) */
        if (m->sleeping && !(gs__rigid_speed(r) < m->world->sleep_speed))
            gs__agent_wake_at(m, gs__agent_time(&r->base));
        slope = gs__friction_slope(r->reach2, 1.0 / gs__mesh_mass(m, i), r->base.dt);
        f = gs__penalty(&c, gs__sub(v[i], gs__point_velocity(r, c.point)), mat, &r->mat, slope);
        gs__rigid_stiffen_all(r, 0.5 * (r->mat.stiffness + mat->stiffness),
                              0.5 * (r->mat.damping + mat->damping), slope);
        r->force = gs__sub(r->force, f);
        r->torque = gs__sub(r->torque, gs__cross(gs__sub(c.point, r->x), f));
        r->torque = gs__add(r->torque, gs__rolling_torque(r, c.normal, gs__dot(f, c.normal), r->w));
        }
    }
}

/* The spring-mass agents into w->meshes: a body's contacts loop over them,
   where a loop over every agent made each body step O(agents). */
GS__PRIVATE void gs__meshes_list(gs_world *w) {
    int i, n = 0;
    for (i = 0; i < w->agent_count; ++i)
        if (gs__mesh_info(w->agents[i], NULL, NULL, NULL, NULL)) w->meshes[n++] = w->agents[i];
    w->nmeshes = n;
    w->meshes_dirty = 0;
}

/* Contact forces on r over its substep [t, t + h], and the pushes of this
   substep on the bodies it touches (found again: a first look for the
   plan is followed by the first substep's own). */
GS__PRIVATE void gs__rigid_contacts(gs__rigid *r, double t, double h) {
    gs_world *w = r->base.world;
    int i;
    double lag = gs__lag_bound(w, t, 0.1);
    int n = gs__sap_query_near(w, r, lag);
    r->force = r->torque = r->late = gs__v3(0.0, 0.0, 0.0);
    gs__rigid_sums_clear(r);
    for (i = 0; i < w->ntouched; ++i) w->touched[i]->sh_f = w->touched[i]->sh_t = r->force;
    if (w->ground) gs__rigid_ground(r);
    for (i = 0; i < n; ++i) gs__rigid_vs_rigid(r, w->cand[i], w->cand_sap[i], t, h);
    if (w->nmeshes == 0) return;
    if (w->meshes_dirty) gs__meshes_list(w);
    for (i = 0; i < w->nmeshes; ++i) gs__rigid_vs_mesh(r, w->meshes[i], t);
}

GS_API gs_result gs_world_set_ground(gs_world *w, int enabled, double height,
                                     gs_material material) {
    gs__check c = gs__check_begin(w, "gs_world_set_ground");
    gs_result r = gs__world_unlocked(w, "gs_world_set_ground");
    if (r != GS_OK) return r;
    material = gs__material_defaults(material);
    gs__check_finite(&c, "height", height);
    if (c.r == GS_OK && fabs(height) > GS_MAX_COORD)
        gs__check_fail(&c, GS_ERR_OUT_OF_RANGE,
                       "height is %g m, outside +-GS_MAX_COORD (%g m)", height,
                       GS_MAX_COORD);
    gs__check_material(&c, &material);
    if (c.r != GS_OK) return c.r;
    w->ground = enabled != 0;
    w->ground_height = height;
    w->ground_material = material;
    gs__wake_all(w);
    return GS_OK;
}

/* ---- contacts of a mesh's particles ---- */
GS__PRIVATE void gs__mesh_update_bounds(gs__mesh *m) {
    gs_vec3 lo = m->x[0], hi = m->x[0], r;
    int i;
    for (i = 1; i < m->n; ++i) {
        const gs_vec3 *p = &m->x[i];
        lo.x = p->x < lo.x ? p->x : lo.x;
        lo.y = p->y < lo.y ? p->y : lo.y;
        lo.z = p->z < lo.z ? p->z : lo.z;
        hi.x = p->x > hi.x ? p->x : hi.x;
        hi.y = p->y > hi.y ? p->y : hi.y;
        hi.z = p->z > hi.z ? p->z : hi.z;
    }
    r = gs__v3(m->radius, m->radius, m->radius);
    m->lo = gs__sub(lo, r);
    m->hi = gs__add(hi, r);
    gs__mesh_chunks(m);
}

GS__PRIVATE void gs__mesh_bounds(const gs_agent *a, gs_vec3 *lo, gs_vec3 *hi) {
    const gs__mesh *m = (const gs__mesh *)a;
    *lo = m->lo;
    *hi = m->hi;
}

/* The particle count, or 0 when a is not a spring-mass agent. */
GS__PRIVATE int gs__mesh_info(const gs_agent *a, const gs_vec3 **x,
                              const gs_vec3 **v, double *radius,
                              const gs_material **mat) {
    const gs__mesh *m = gs__as_mesh(a);
    if (!m) return 0;
    if (x) *x = m->x;
    if (v) *v = m->v;
    if (radius) *radius = m->radius;
    if (mat) *mat = &m->mat;
    return m->n;
}

/* Adds the force of one contact on particle i (normal toward the particle);
   implicit Euler also keeps the first contact's spring for its solve. */
GS__PRIVATE double gs__mesh_mass(const gs_agent *a, int i) {
    return ((const gs__mesh *)a)->mass[i];
}

GS__PRIVATE void gs__mesh_touch(gs__mesh *m, int i, const gs_contact *c,
                                gs_vec3 v_other, const gs_material *other,
                                double other_reach2) {
    double slope = gs__friction_slope(1.0 / m->mass[i], other_reach2, m->base.dt);
    gs_vec3 f = gs__penalty(c, gs__sub(m->v[i], v_other), &m->mat, other, slope);
    m->ext_active = 1;
    if (!m->tmark[i]) {
        m->tmark[i] = 1;
        m->touched[m->ntouched++] = i;
    }
    if (m->cdepth) { /* XPBD: friction is a force, the normal spring a constraint */
        m->ext[i] = gs__madd(m->ext[i], c->normal, -gs__dot(f, c->normal));
        m->ext[i] = gs__add(m->ext[i], f);
        if (m->ck[i] == 0.0 || c->depth > m->cdepth[i]) {
            m->cn[i] = c->normal;
            m->cvel[i] = v_other;
            m->cdepth[i] = c->depth;
            m->ck[i] = 0.5 * (m->mat.stiffness + other->stiffness);
            m->cc[i] = 0.5 * (m->mat.damping + other->damping);
        }
        return;
    }
    m->ext[i] = gs__add(m->ext[i], f);
    if (m->ck && m->ck[i] == 0.0) { /* the first contact's spring */
        m->cn[i] = c->normal;
        m->ck[i] = 0.5 * (m->mat.stiffness + other->stiffness);
        m->cc[i] = 0.5 * (m->mat.damping + other->damping);
    }
}

/* The body is taken where its velocity puts it at the mesh's time t (at
   most 0.1 s ahead or behind): held still, a body that steps less often
   than the mesh would jump into particles that have already relaxed against
   it, and each jump would store penalty energy the particles then release. */
/* The boxes of m's particles at x, GS__CHUNK at a time, and the fastest
   velocity component in each (a NaN makes the box's bound NaN: never
   apart, see gs__chunk_apart). */
GS__PRIVATE void gs__mesh_chunks(gs__mesh *m) {
    int i, k;
    for (k = 0, i = 0; i < m->n; ++k) {
        gs_vec3 lo = m->x[i], hi = m->x[i];
        double vm = 0.0;
        int end = i + GS__CHUNK < m->n ? i + GS__CHUNK : m->n;
        for (; i < end; ++i) {
            gs_vec3 p = m->x[i], v = m->v[i];
            double a = fabs(v.x) > fabs(v.y) ? fabs(v.x) : fabs(v.y);
            a = fabs(v.z) > a ? fabs(v.z) : a;
            vm = a > vm || a != a ? a : vm;
            lo.x = p.x < lo.x ? p.x : lo.x; lo.y = p.y < lo.y ? p.y : lo.y;
            lo.z = p.z < lo.z ? p.z : lo.z; hi.x = p.x > hi.x ? p.x : hi.x;
            hi.y = p.y > hi.y ? p.y : hi.y; hi.z = p.z > hi.z ? p.z : hi.z;
        }
        m->clo[k] = lo;
        m->chi[k] = hi;
        m->cvm[k] = vm;
    }
    m->chunks_ok = 1;
}

/* How far from a body's centre a particle may be and still touch it:
   gs__particle_contact's bound, rp + reach, and a margin over the
   rounding of its squared distance, so that a box skipped by
   gs__chunk_apart holds no particle that test would have let through
   (the culled and the full loop give the same bits). */
GS__PRIVATE double gs__chunk_reach(double rp, double reach) {
    return (rp + reach) * (1.0 + 1e-9) + 1e-300;
}

/* Every point of box [lo, hi] is farther than `far` from c along an axis
   (a NaN box is never apart: its particles go to the full test). */
GS__PRIVATE int gs__chunk_apart(gs_vec3 lo, gs_vec3 hi, gs_vec3 c, double far) {
    return lo.x - c.x > far || c.x - hi.x > far || lo.y - c.y > far || c.y - hi.y > far ||
           lo.z - c.z > far || c.z - hi.z > far;
}

/* Box k of m cannot touch a body at c when its particles are taken `lag`
   seconds along their velocities (gs__rigid_vs_mesh): the box grows by
   the fastest component times |lag|, and by 1e-9 of its coordinates for
   the rounding of x + v lag (1e-16 of them at most). */
GS__PRIVATE int gs__chunk_skip(gs__mesh *m, int k, gs_vec3 c, double far, double lag) {
    gs_vec3 lo, hi;
    double mag;
    if (!m->chunks_ok) gs__mesh_chunks(m);
    lo = m->clo[k];
    hi = m->chi[k];
    mag = fmax(fmax(fabs(lo.x), fabs(hi.x)), fmax(fmax(fabs(lo.y), fabs(hi.y)),
                                                fmax(fabs(lo.z), fabs(hi.z))));
    return gs__chunk_apart(lo, hi, c, far + m->cvm[k] * fabs(lag) * (1.0 + 1e-9) +
                                          1e-9 * (1.0 + mag + fabs(c.x) + fabs(c.y) + fabs(c.z)));
}

GS__PRIVATE void gs__mesh_vs_rigid(gs__mesh *m, gs__rigid *r, double t) {
    double reach = r->shape.bound;
    double lag = fmax(-0.1, fmin(0.1, t - gs__agent_time(&r->base)));
    gs_vec3 centre = r->probe ? r->x : gs__madd(r->x, r->v, lag);
    int i;
    double far = gs__chunk_reach(m->radius, reach);
    int k, end;
    if (centre.x + reach < m->lo.x || centre.x - reach > m->hi.x ||
        centre.y + reach < m->lo.y || centre.y - reach > m->hi.y ||
        centre.z + reach < m->lo.z || centre.z - reach > m->hi.z)
        return;
    if (!m->chunks_ok) gs__mesh_chunks(m);
    for (k = 0, i = 0; i < m->n; ++k, i = end) {
        end = i + GS__CHUNK < m->n ? i + GS__CHUNK : m->n;
        if (gs__chunk_apart(m->clo[k], m->chi[k], centre, far)) continue;
        for (; i < end; ++i) {
        gs_contact c;
        if (m->pinned[i] || !gs__particle_contact(m->x[i], m->radius, r, centre, &c)) continue;
        /* particles that move wake a sleeper (it is fixed to them until then) */
        if (r->base.sleeping && !(gs__len(m->v[i]) < m->base.world->sleep_speed))
            gs__agent_wake_at(&r->base, t);
        if (r->probe && r->base.rest < m->base.world->sleep_time) m->probe_touch = 1;
        gs__mesh_touch(m, i, &c, gs__point_velocity(r, c.point), &r->mat,
                       r->probe || r->base.sleeping ? 0.0 : r->reach2);
        }
    }
}

/* Contact forces on every particle from the ground and from the current
   state of every rigid body and probe. Costs nothing in a world without
   them. */
GS__PRIVATE void gs__mesh_contacts(gs__mesh *m, double t) {
    gs_world *w = m->base.world;
    int i, n;
    if (m->ext_active) {
        for (i = 0; i < m->ntouched; ++i) {
            int p = m->touched[i];
            m->ext[p] = gs__v3(0.0, 0.0, 0.0);
            if (m->ck) m->ck[p] = 0.0;
            m->tmark[p] = 0;
        }
        m->ntouched = 0;
        m->ext_active = 0;
    }
    if (w->ground && m->lo.y < w->ground_height) {
        gs_contact c;
        c.normal = gs__v3(0.0, 1.0, 0.0);
        for (i = 0; i < m->n; ++i) {
            c.depth = w->ground_height + m->radius - m->x[i].y;
            if (c.depth <= 0.0 || m->pinned[i]) continue;
            c.point = gs__v3(m->x[i].x, w->ground_height, m->x[i].z);
            gs__mesh_touch(m, i, &c, gs__v3(0.0, 0.0, 0.0), &w->ground_material, 0.0);
        }
    }
    n = gs__sap_query(w, m->lo.x, m->hi.x, gs__lag_bound(w, t, 0.1));
    for (i = 0; i < n; ++i) gs__mesh_vs_rigid(m, w->cand[i], t);
}

/* ========================================================================
   >>scene
   ======================================================================== */
GS__PRIVATE int gs__net_hosts(const gs_net *net);

GS_API gs_scene_desc gs_scene_desc_default(void) {
    gs_scene_desc d;
    memset(&d, 0, sizeof d);
    d.cloth_n = 16;
    d.cloth_size = 1.0;
    d.sphere_count = 3;
    d.sphere_radius = 0.08;
    d.probe_count = 0; /* one per host: known only when the scene is made */
    d.seed = 1;
    d.cloth_integrator = GS_INTEGRATOR_IMPLICIT_EULER;
    d.dt = 0.002;
    d.cloth_substeps = gs_solver_desc_default().substeps;
    return d;
}

GS__PRIVATE gs_scene_desc gs__scene_defaults(const gs_scene_desc *in, int hosts) {
    gs_scene_desc def = gs_scene_desc_default(), d = in ? *in : def;
    if (d.cloth_n == 0) d.cloth_n = def.cloth_n;
    if (d.cloth_size == 0.0) d.cloth_size = def.cloth_size;
    if (d.sphere_count == 0) d.sphere_count = def.sphere_count;
    else if (d.sphere_count == GS_NONE) d.sphere_count = 0;
    if (d.probe_count == 0) d.probe_count = hosts;
    else if (d.probe_count == GS_NONE) d.probe_count = 0;
    if (d.sphere_radius == 0.0) d.sphere_radius = def.sphere_radius;
    if (d.seed == 0) d.seed = def.seed;
    if (d.cloth_integrator == GS_INTEGRATOR_DEFAULT) d.cloth_integrator = def.cloth_integrator;
    if (d.dt == 0.0) d.dt = def.dt;
    if (d.cloth_substeps == 0) d.cloth_substeps = def.cloth_substeps;
    return d;
}

GS_API gs_vec3 gs_scene_probe_path(int i, double t) {
    const double pi = 3.14159265358979323846;
    double a = 2.0 * pi * (t / 4.0 + 0.25 * i);
    double dip = 0.5 - 0.5 * cos(2.0 * pi * t / 2.0); /* 0..1, period 2 s */
    /* outside the hollow where the spheres settle: a probe that sweeps
       through them pins them against the cloth and flings them off (a
       kinematic body is an endless source of penalty energy) */
    return gs__v3(0.38 * cos(a), 0.12 - 0.24 * dip, 0.38 * sin(a));
}

/* A number in [0, 1) from a 32-bit LCG: the scene is the same on every host
   given the same seed. */
GS__PRIVATE double gs__scene_rand(uint32_t *state) {
    *state = *state * 1664525u + 1013904223u;
    return (double)(*state >> 8) / 16777216.0;
}

/* Contacts in the scene are soft enough for a 2 ms step without many
   substeps: 2e4 N/m holds a 0.1 kg sphere at 50 um of penetration. */
/* Contact damping 20 N s/m: a damping ratio of 0.22 between two spheres.
   At 5 N s/m (0.056) three spheres resting in the cloth's hollow, each
   stepping on its own against the others and the implicit cloth, are
   kicked up again and again (0.3 m/s after 15 s); at 20 the
   scene comes to rest (its kinetic energy falls 10x every 2 s), and only a
   scene that comes to rest lets the hosts' copies meet. */
/* Rolling resistance of the scene's spheres: 4 mm, a coefficient of 0.05
   on a 8 cm sphere (a ball on cloth or carpet). A sphere a probe throws
   onto the ground otherwise rolls for ever, and on the cloth the spheres
   creep for tens of seconds before they rest. */
#ifndef GS__SCENE_SPIN
/* m; 0: the scene's spheres have no torsional friction. The patch's
   (2/3) mu a would be ~4 mm (friction 0.4, a ~18 mm contact patch), and
   at 4 mm the scene rests (bench/bandwidth paper-rest). Off: with it the
   paper scene at rest in replay mode, quant + send on change, falls from
   59.9 to 13.4 kbit/s but its divergence grows from 3.5e-5 to 5.0e-3 m
   (a moved snapshot wakes a copy against its held neighbours: without
   spin a sphere that never rests keeps the follower replaying every
   frame), so no mode meets issue 16's rest target either way
   (docs/sync-notes.md, s19d); build with -DGS__SCENE_SPIN=0.004 to
   measure it */
#define GS__SCENE_SPIN 0.0
#endif
#ifndef GS__SCENE_ROLLING
#define GS__SCENE_ROLLING 0.004
#endif

GS__PRIVATE gs_material gs__scene_material(void) {
    gs_material m;
    m.stiffness = 2e4;
    m.damping = 20.0;
    m.friction = 0.4;
    return m;
}

GS__PRIVATE gs_result gs__scene_bodies(gs_world *w, gs_scene *sc) {
    const gs_scene_desc *d = &sc->desc;
    uint32_t rng = d->seed;
    gs_result r = GS_OK;
    int i;
    for (i = 0; i < d->sphere_count && r == GS_OK; ++i) {
        gs_rigid_desc rd = gs_rigid_desc_default();
        rd.shape.type = GS_SHAPE_SPHERE;
        rd.shape.radius = d->sphere_radius;
        rd.mass = 0.1;
        rd.position = gs__v3((gs__scene_rand(&rng) - 0.5) * 0.5 * d->cloth_size,
                             0.3 + 0.25 * i,
                             (gs__scene_rand(&rng) - 0.5) * 0.5 * d->cloth_size);
        rd.material = gs__scene_material();
        rd.rolling = GS__SCENE_ROLLING;
        rd.spin_friction = GS__SCENE_SPIN;
        rd.solver.dt = d->dt;
        /* A sphere on the cloth substeps for its contact stiffness: about
           70 substeps a step at dt 1/60 s (a step per 60 Hz frame, the
           schedule large XPBD cloths take), 210 at ghostpeer's largest
           --dt, 0.05 s. The cap only refuses: a scene that ran under the
           default 64 runs as before. */
        rd.solver.max_substeps = 256;
        r = gs_rigid_create(w, &rd, &sc->spheres[i]);
        if (r == GS_OK) sc->sphere_count++;
    }
    for (i = 0; i < d->probe_count && r == GS_OK; ++i) {
        gs_probe_desc pd = gs_probe_desc_default();
        pd.shape.type = GS_SHAPE_BOX;
        pd.shape.half_extents = gs__v3(0.05, 0.05, 0.05);
        pd.position = gs_scene_probe_path(i, 0.0);
        pd.material = gs__scene_material();
        pd.dt = d->dt;
        pd.max_speed = 5.0;
        pd.owner = (uint32_t)i + 1u;
        r = gs_probe_create(w, &pd, &sc->probes[i]);
        if (r == GS_OK) sc->probe_count++;
    }
    return r;
}

/* The cloth starts flat; left alone it would fall and swing for seconds and
   toss the spheres like a trampoline. It hangs for 3 s of simulated time
   first, then its clock is set back to 0: every host computes the same
   settled state. */
#define GS__SCENE_SETTLE_TIME 3.0 /* s */
GS__PRIVATE gs_result gs__scene_settle(gs_agent *cloth) {
    long i, steps = (long)(GS__SCENE_SETTLE_TIME / cloth->dt); /* dt >= GS_MIN_DT */
    for (i = 0; i < steps; ++i) {
        gs_result r = gs__agent_step(cloth);
        if (r != GS_OK) return r;
    }
    cloth->t_offset = -(double)cloth->steps * cloth->dt;
    memset(&cloth->stats, 0, sizeof cloth->stats);
    return GS_OK;
}

GS_API gs_result gs_scene_create(gs_world *w, const gs_scene_desc *desc,
                                 gs_scene *out) {
    gs_cloth_desc cd = gs_cloth_desc_default();
    gs__check c = gs__check_begin(w, "gs_scene_create");
    gs_result r;
    int first, ground;
    double ground_height;
    gs_material ground_material;
    if (!w || !out) return GS_ERR_INVALID_ARG;
    memset(out, 0, sizeof *out);
    out->desc = gs__scene_defaults(desc, w->net ? gs__net_hosts(w->net) : GS_SCENE_DEFAULT_PROBES);
    gs__check_int(&c, "cloth_n", out->desc.cloth_n, 2, 4096);
    gs__check_positive(&c, "cloth_size", out->desc.cloth_size);
    gs__check_int(&c, "sphere_count", out->desc.sphere_count, 0, GS_SCENE_MAX_SPHERES);
    gs__check_positive(&c, "sphere_radius", out->desc.sphere_radius);
    gs__check_int(&c, "probe_count", out->desc.probe_count, 0, GS_SCENE_MAX_PROBES);
    gs__check_dt(&c, "dt", out->desc.dt);
    gs__check_int(&c, "cloth_substeps", out->desc.cloth_substeps, 1, 1L << 20);
    if (c.r == GS_OK) {
        double n = (double)out->desc.cloth_n, sub = out->desc.cloth_substeps / 4.0,
               work = n * n * floor(GS__SCENE_SETTLE_TIME / out->desc.dt);
        if (out->desc.cloth_integrator == GS_INTEGRATOR_XPBD && sub > 1.0) work *= sub;
        if (work > GS_SCENE_SETTLE_WORK)
            gs__check_fail(&c, GS_ERR_INVALID_ARG,
                           "cloth_n %d at dt %g s needs %.3g particle steps to settle, "
                           "more than GS_SCENE_SETTLE_WORK (%g): a smaller cloth or a larger dt",
                           out->desc.cloth_n, out->desc.dt, work, GS_SCENE_SETTLE_WORK);
    }
    if (c.r != GS_OK) return c.r;
    ground = w->ground; /* put back if anything below fails */
    ground_height = w->ground_height;
    ground_material = w->ground_material;
    r = gs_world_set_ground(w, 1, -1.5, gs__scene_material());
    if (r != GS_OK) return r;
    first = w->agent_count;
    cd.nx = cd.ny = out->desc.cloth_n;
    cd.width = cd.height = out->desc.cloth_size;
    cd.origin = gs__v3(-0.5 * cd.width, 0.0, -0.5 * cd.height);
    cd.pin_corners = GS_CORNER_ALL;
    cd.spring_damping = 1.0; /* N s/m: a cloth, not a trampoline */
    cd.air_damping = 0.5;
    cd.material = gs__scene_material();
    cd.solver.integrator = out->desc.cloth_integrator;
    cd.solver.dt = out->desc.dt;
    cd.solver.substeps = out->desc.cloth_substeps;
    r = gs_cloth_create(w, &cd, &out->cloth);
    if (r == GS_OK) r = gs__scene_settle(out->cloth);
    if (r == GS_OK) r = gs__scene_bodies(w, out);
    if (r != GS_OK) { /* leave the world as it was */
        while (w->agent_count > first) gs_agent_destroy(w->agents[w->agent_count - 1]);
        w->ground = ground;
        w->ground_height = ground_height;
        w->ground_material = ground_material;
        memset(out, 0, sizeof *out);
    }
    return r;
}

/* ========================================================================
   >>ghost
   ======================================================================== */
#define GS__MAX_PEERS 16

GS_API double gs_weight_cs(const gs_weight_in *in, void *user) {
    (void)user;
    return in->host == in->lead ? 1.0 : 0.0;
}

GS_API double gs_weight_exp(const gs_weight_in *in, void *user) {
    double rate = user ? *(const double *)user : 1.0;
    double e = rate * in->x_comp;
    return exp(e > 700.0 ? 700.0 : e < -700.0 ? -700.0 : e);
}

GS_API double gs_weight_owner(const gs_weight_in *in, void *user) {
    (void)user;
    if (in->owner == 0) return 1.0;
    return in->host == in->owner ? 1.0 : 0.0;
}

/* One snapshot from one peer, assembled from its chunks as they come. */
typedef struct gs__snap {
    int used;
    int waited;         /* replay mode: 1 when an incomplete snapshot was
                           left for its chunks still on the way, 2 after */
    uint32_t seq;
    double time;        /* s, remote simulation time */
    double age;         /* s, estimated one-way delay when it came */
    int age_known;      /* 0 before the first round trip to the peer: the
                           age is taken as 0, so the time is a lower bound */
    int chunks;         /* chunks received */
    unsigned char *got; /* per chunk index */
    double *data;       /* the state after its time; valid where got */
} gs__snap;

/* One quantized state of a delta ghost (gs_ghost_desc.delta), sent or
   received: the integers the wire codes differences of (see >>wire), and
   per chunk whether it is held (received, or sent fit to be a baseline)
   and its segments, whose steps and bits a delta against it reuses. */
typedef struct gs__base {
    int used;
    uint32_t seq;           /* the snapshot's sequence */
    double time;            /* s: its simulation time (a prediction's start) */
    int chunks;             /* chunks held */
    unsigned char *got;     /* per chunk */
    unsigned char *nseg;    /* per chunk: its segment count */
    gs_wire_segment *seg;   /* per chunk, GS_WIRE_MAX_SEGMENTS */
    int64_t *k;             /* the state's integers (after its time) */
} gs__base;

/* What a ghost keeps of one peer slot: its queue, what the blend learnt
   of its clock, and whether it said the object rests. */
struct gs__ghost_peer {
    gs__snap *q;          /* queue_size snapshots (and the last values),
                             the net's: read and written under its lock */
    gs__snap *taken;      /* queue_size slots (in q's block) that a blend
                             reads: the snapshots taken out of q under the
                             lock, blended after it is released */
    double divergence;    /* m; RMS distance to its latest snapshot */
    double newest;        /* s; the latest remote time that told the
                             peer's clock, -HUGE_VAL at first */
    double lead;          /* s; how far the peer's clock is ahead of ours
                             (see gs__peer_lead) */
    double lead_at;       /* s; local time of its last sample, -HUGE_VAL
                             before the first */
    double heard_at;      /* s; local time of the last blend with a
                             snapshot of the peer, -HUGE_VAL */
    double heard_x;       /* s; its x_comp then (the freshest) */
    int resting;          /* its latest word on the object was a heartbeat */
    /* delta coding (gs_ghost_desc.delta): */
    gs__base *ring;       /* the last GS_DELTA_RING snapshots received */
    uint32_t acked;       /* the newest snapshot of ours it holds whole, */
    int acked_known;      /* if it said one (0: send whole) */
    uint32_t ack_seq;     /* the newest of its snapshots we hold whole, */
    int ack_known;        /* if any, */
    int ack_due, nack_due;/* to tell it: held, or a delta refused */
    int acks_held;        /* snapshots held whole since our last ack went */
    int ack_waiting;      /* an ack is held (not sent) since ack_since */
    double ack_since;     /* s, wall time (the net's update clock) */
};

struct gs__ghost {
    gs_agent *agent;
    gs_ghost_desc d;
    size_t n;             /* state size, time included */
    int per_chunk;        /* values per chunk */
    int nchunks;          /* chunks per snapshot */
    double *B;            /* the published state (with its time) */
    uint32_t b_seq, sent_seq;
    double next_publish;  /* s, simulation time */
    double next_send;     /* s, wall time */
    double stands_at;     /* s, wall time: the instant B stands for, when
                             an advance on a frame grid ran ahead of it
                             (the net holds B until then), else 0 */
    double *local, *scratch;
    double *offset, *offset_next; /* render offsets; a blend writes the next
                                     ones and swaps only if it is applied */
    double *wq;           /* weight of each taken snapshot in a blend */
    int ntaken;           /* snapshots taken for the blend under way */
    struct gs__src *src;  /* the queued snapshots of a blend, in order */
    int nsrc;
    double offset_t;      /* s; simulation time the offset was last set */
    double t_local;       /* s; the agent's time after its last step, for
                             the receiving side (written under the lock) */
    double moved;         /* s; |time| the blends moved the agent by in the
                             world's epoch moved_epoch (one advance) */
    uint64_t moved_epoch;
    double pulled;        /* s; how far back its last blend took the time */
    int held_back;        /* its blended state (scratch) is held back: within
                             the replay tolerance (gs__blend_net.near); 2:
                             held (gs__ghost_held) when applied */
    double held_corr;     /* its last_correction, when applied */
    gs_ghost_stats stats;
    /* send on change */
    double *sent;         /* the values of the last snapshot sent whole
                             (rest_extrapolate: as the peers decode them) */
    double *pred;         /* rest_extrapolate: sent carried to B's time */
    int rest_repeats;     /* heartbeats of this rest that carry it again */
    int still;            /* delta: every state sent since `sent` had its
                             values (gs__ghost_still) */
    uint32_t still_seq;   /* delta: the snapshot `sent` went as */
    int sent_any;         /* 0: send the state whole next (a first send, a
                             peer added or started again) */
    double next_heartbeat;/* s, wall time, on the beat grid (gs__beat_next) */
    int at_rest;          /* its last send found it unmoved (send on change) */
    double sent_at;       /* s, wall time it was last sent (priority) */
    size_t wire_bytes;    /* bytes its last snapshot took on the wire */
    gs__base *ring;       /* delta: the last GS_DELTA_RING snapshots sent */
    int64_t *kbuf;        /* delta (or quantized rest_extrapolate): one
                             chunk's integers or differences, then (delta)
                             one chunk's prediction (gs__delta_pred) */
    int row;              /* delta: the spatial coding's row (a chunk's
                             gs_wire_chunk.delta_row), 0: not tried */
    struct gs__ghost_peer gp[GS__MAX_PEERS];
};
typedef struct gs__ghost gs__ghost;

/* One queued snapshot as a blend reads it. */
typedef struct gs__src {
    const double *v;          /* its values (the state without its time) */
    const unsigned char *got; /* per chunk */
    double w;                 /* its weight */
    double d2;                /* sum of squared position differences */
    size_t counted;           /* position values in d2 */
    int peer;
} gs__src;

/* What a refusal did not match, kept as numbers (the text is made only
   when gs_net_peer_stats is asked). */
typedef enum gs__mismatch {
    GS__MISMATCH_NONE,
    GS__MISMATCH_OBJECT,   /* object: no ghost of that id here */
    GS__MISMATCH_VALUES,   /* object: state values here, in the datagram
                              (there_min: at least that many) */
    GS__MISMATCH_ENCODING, /* object: encodings here, there */
    GS__MISMATCH_SESSION,  /* sessions here, there */
    GS__MISMATCH_SEALED    /* sealed datagrams to a net with no key */
} gs__mismatch;

typedef struct gs__detail {
    gs__mismatch what;
    uint32_t object;
    long here, there;
    int there_min;
} gs__detail;

/* One window of GS_PEER_QUIET s of datagrams naming a peer as sender. */
typedef struct gs__diag_win {
    uint32_t taken, refused;
    uint32_t mismatched;  /* refused as GS_REJECT_OBJECT or _RANGE: the
                             hosts disagree on the objects (a setup
                             mistake, where the rest is the network's) */
    int reasons;          /* distinct reasons seen: 0, 1 or 2 (more) */
    gs_reject reason;     /* the first refusal's */
    gs__detail detail;    /* and what it did not match */
} gs__diag_win;

/* A peer's diagnostics (gs_peer_health). Times are the net's `now`; -1:
   not yet. */
typedef struct gs__peer_diag {
    double added_at;      /* the first `now` after the peer was added */
    double sent_at;       /* the last datagram sent to it */
    double taken_at;      /* the last datagram taken from it */
    double win_at;        /* the start of win[0] */
    unsigned sync;        /* GS_WIRE_FLAG_SYNC of the last datagram taken */
    gs__diag_win win[2];  /* [0] the current window, [1] the one before it
                             (empty unless it ended when [0] began) */
} gs__peer_diag;

typedef struct gs__peer {
    int used;
    uint32_t host;
    gs_peer_stats st;
    gs__peer_diag diag;
    uint32_t send_seq;        /* our next datagram sequence to them */
    uint32_t recv_top;        /* highest datagram sequence received */
    uint64_t recv_window;     /* bit i: recv_top - i received */
    int recv_any;
    double their_send_time;   /* echo: their latest send time, and */
    double their_recv_now;    /* our clock when it came */
    double tokens;            /* bytes the budget allows now */
    double tokens_at;         /* s, wall time of the last refill */
    gs__peer_guard guard;     /* replay window, receive cap (>>net) */
    uint32_t run, prev_run;   /* their run, and the one before (0: none) */
    int clock_known;          /* their clock against ours, from the round */
    double clock_offset;      /* trip with the least delay: s, their */
    double clock_rtt;         /* datagrams' (arrival - send time) less the */
    double clock_at;          /* way; that round trip (s) and when (s) */
} gs__peer;

/* A chunk's header is coded against the datagram's chunk before it (see
   >>wire): its object id, sequence and time, and for the next chunk of the
   same snapshot its index, count, first element and element count.
   Nothing before the first (any 0): its time is always written. */
typedef struct gs__wire_ctx {
    uint32_t id, seq;
    double time;
    int any;
    uint16_t index, count, elements;
    uint32_t first;
    int delta;         /* the chunk before was a delta, against baseline */
    uint32_t baseline;
    int row;           /* the chunk before's row if it was a spatial delta
                          (coding 3), else 0: what kind bit 7 says again */
} gs__wire_ctx;

/* The Rice-coded deltas' values of a datagram, kept by its parse
   (gs__delta_parse's keep) for the sum that applies them, so that each
   value's bits are read once. Every value takes a bit at least, so a
   datagram's fit; a chunk that would not is read from its bits. */
#define GS__KEPT_VALUES (8 * (GS_WIRE_MAX_DATAGRAM - GS_WIRE_HEADER))
typedef struct gs__kept {
    int32_t v[GS__KEPT_VALUES];
    int used;
    const int32_t *at[GS_WIRE_MAX_CHUNKS]; /* chunk i's values, NULL: none */
} gs__kept;

struct gs_net {
    gs_world *world;
    gs_net_desc d;
    uint32_t run;             /* this run's number, in every header */
    gs__peer peers[GS__MAX_PEERS];
    uint64_t unknown_rejected[GS_REJECT_COUNT];
    gs_net_lock lock;
    int inside;               /* under the lock: the net runs user code
                                 under it (the send callback in
                                 gs_net_update), which must not re-enter
                                 the net */
    int held;                 /* a gs_simnet_run is running it */
    int published;            /* a ghost published B since gs_udp's scatter
                                 thread last looked (it ticks while they do) */
    double now;               /* s, wall time of the last update/deliver */
    gs_result send_error;     /* the first failed send of this update, */
    uint32_t send_error_host; /* and to whom */
    /* the clock's diagnostics (gs_peer_health): the latest `now` seen
       (-1: none yet), whether the clock is behind it now, the steps back
       counted, the largest, and the last one (from, to) */
    double clock_max;
    int clock_behind;
    uint64_t clock_backwards;
    double clock_back_max, clock_back_from, clock_back_to;
    int updated;              /* a gs_net_update has run */
    int peer_added;           /* since the last `now`: a peer's added_at
                                 waits for the next */
    double update_now;        /* s; its `now` (the first `now` seen before
                                 the first; -1: none yet) */
    double unsent_world;      /* s; the seconds given to gs_world_advance
                                 since (or since the create): a missing
                                 update is measured in them, not in the
                                 world's time, which also jumps to follow
                                 the agents of a late joiner */
    gs__detail detail;        /* what the refusal being made did not match */
    struct gs__ghost **order; /* the due ghosts of an update, by priority */
    int order_cap;            /* its room: at least the world's ghosts */
    double burst;             /* bytes; the wire cost of this update's
                                 largest due ghost: the budget's bucket
                                 holds at least that much */
    int beat_states;          /* a ghost's state went since the last beat
                                 (2: in this update): the next beat sends
                                 every resting ghost's state (gs__send_due) */
    int beat_went;            /* this update sent a beat's state */
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    gs__wire_ctx wctx;        /* what buf's next chunk is coded against */
    int flushes;              /* datagrams with chunks sent this update */
    gs_wire_view view;        /* decode scratch (too big for the stack) */
    gs__kept kept;            /* view's Rice values, as its parse read them */
    gs__net_guard guard;      /* key, nonces, opened datagram (>>net) */
};

/* The probes of a scene on this net: one per host id up to the highest
   it knows (its own and its peers'), as probe i is host i + 1's. */
GS__PRIVATE int gs__net_hosts(const gs_net *net) {
    uint32_t top = net->world->host_id;
    int i;
    for (i = 0; i < GS__MAX_PEERS; ++i)
        if (net->peers[i].used && net->peers[i].host > top) top = net->peers[i].host;
    return top < GS_SCENE_MAX_PROBES ? (int)top : GS_SCENE_MAX_PROBES;
}

GS__PRIVATE void gs__lock(gs_net *net) {
    if (net && net->lock.lock) net->lock.lock(net->lock.user);
}
GS__PRIVATE void gs__unlock(gs_net *net) {
    if (net && net->lock.unlock) net->lock.unlock(net->lock.user);
}

GS_API gs_ghost_desc gs_ghost_desc_default(void) {
    gs_ghost_desc d;
    memset(&d, 0, sizeof d);
    d.weight = gs_weight_cs;
    d.send_rate = 60.0;
    d.encoding = GS_ENCODING_F64;
    d.queue_size = 8;
    d.smoothing = 0.1;
    d.catchup = GS_CATCHUP_NONE;
    d.catchup_max = 0.05;
    d.position_resolution = 5e-5;
    d.velocity_resolution = 3e-3;
    d.orientation_bits = 16;
    d.heartbeat_rate = 4.0;
    d.importance = 1.0;
    return d;
}

GS__PRIVATE size_t gs__value_size(gs_encoding e) {
    return e == GS_ENCODING_F32 ? 4 : 8;
}

/* Values a chunk of a snapshot holds in encoding e. */
GS__PRIVATE size_t gs__per_chunk(gs_encoding e) {
    return e == GS_ENCODING_QUANT ? GS_WIRE_QUANT_CHUNK : GS_WIRE_CHUNK_ROOM / gs__value_size(e);
}

/* A ghost's queue for one peer slot: queue_size snapshots, and one more
   (index queue_size, never used as a queue slot) that keeps the newest
   values received of each chunk, which a heartbeat says still stand; then
   queue_size slots a blend takes snapshots into (gs__ghost_take), so
   that taking them allocates nothing. */
GS__PRIVATE gs__snap *gs__snaps_new(gs_world *w, const gs__ghost *g) {
    size_t qs = 2 * (size_t)g->d.queue_size + 1, vars = g->n - 1, i;
    size_t bytes = qs * (sizeof(gs__snap) + vars * sizeof(double) + (size_t)g->nchunks);
    gs__snap *s = (gs__snap *)gs__alloc(w, bytes);
    char *p;
    if (!s) return NULL;
    memset(s, 0, bytes);
    p = (char *)(s + qs);
    for (i = 0; i < qs; ++i, p += vars * sizeof(double)) s[i].data = (double *)p;
    for (i = 0; i < qs; ++i, p += g->nchunks) s[i].got = (unsigned char *)p;
    return s;
}

/* GS_DELTA_RING quantized states of a delta ghost, in one block; NULL if
   out of memory or too big for size_t. */
GS__PRIVATE gs__base *gs__ring_new(gs_world *w, const gs__ghost *g) {
    size_t R = GS_DELTA_RING, vars = g->n - 1, nc = (size_t)g->nchunks, per, bytes, i;
    gs__base *b;
    char *p;
    if (!gs__size(nc, GS_WIRE_MAX_SEGMENTS * sizeof(gs_wire_segment) + 2, 0, &per) ||
        !gs__size(vars, sizeof(int64_t), per, &per) ||
        !gs__size(R, sizeof(gs__base) + per, 0, &bytes) || per > SIZE_MAX - sizeof(gs__base))
        return NULL;
    b = (gs__base *)gs__alloc(w, bytes);
    if (!b) return NULL;
    memset(b, 0, bytes);
    p = (char *)(b + R);
    for (i = 0; i < R; ++i, p += vars * sizeof(int64_t)) b[i].k = (int64_t *)p;
    for (i = 0; i < R; ++i, p += nc * GS_WIRE_MAX_SEGMENTS * sizeof(gs_wire_segment))
        b[i].seg = (gs_wire_segment *)p;
    for (i = 0; i < R; ++i, p += nc) b[i].got = (unsigned char *)p;
    for (i = 0; i < R; ++i, p += nc) b[i].nseg = (unsigned char *)p;
    return b;
}

GS__PRIVATE gs__ghost *gs__ghost_of(const gs_agent *a);
GS__PRIVATE gs_result gs__ghost_add_peer(gs__ghost *g, int slot) {
    gs_world *w = g->agent->world;
    struct gs__ghost_peer *gp = &g->gp[slot];
    if (gp->q) return GS_OK;
    gp->resting = 0;
    gp->acked_known = gp->ack_known = gp->ack_due = gp->nack_due = 0;
    gp->acks_held = gp->ack_waiting = 0;
    g->sent_any = 0; /* the new peer has none of our states */
    gp->q = gs__snaps_new(w, g);
    gp->taken = gp->q ? gp->q + g->d.queue_size + 1 : NULL;
    if (gp->q && g->d.delta && !gp->ring) {
        gp->ring = gs__ring_new(w, g);
        if (!gp->ring) {
            gs__free(w, gp->q);
            gp->q = gp->taken = NULL;
        }
    }
    return gp->q ? GS_OK : gs__fail(w, GS_ERR_NO_MEMORY, "ghost: out of memory for a peer queue");
}

GS__PRIVATE void gs__ghost_free(gs__ghost *g) {
    gs_world *w = g->agent->world;
    int i;
    for (i = 0; i < GS__MAX_PEERS; ++i) {
        gs__free(w, g->gp[i].q);
        gs__free(w, g->gp[i].ring);
    }
    gs__free(w, g->ring);
    gs__free(w, g->kbuf);
    gs__free(w, g);
}

GS__PRIVATE gs__ghost *gs__ghost_of(const gs_agent *a) {
    return (gs__ghost *)a->ghost;
}

/* The object id of an agent's ghost, 0 for an agent without one. */
GS__PRIVATE uint32_t gs__agent_object(const gs_agent *a) {
    return a->ghost ? gs__ghost_of(a)->d.object_id : 0;
}

GS__PRIVATE gs__ghost *gs__ghost_find(const gs_world *w, uint32_t object_id) {
    int i;
    for (i = 0; i < w->agent_count; ++i) {
        gs__ghost *g = gs__ghost_of(w->agents[i]);
        if (g && g->d.object_id == object_id) return g;
    }
    return NULL;
}

GS__PRIVATE gs_ghost_desc gs__ghost_defaults(const gs_ghost_desc *in) {
    gs_ghost_desc def = gs_ghost_desc_default(), d = *in;
    if (!d.weight) { d.weight = def.weight; d.weight_user = NULL; }
    if (d.send_rate == 0.0) d.send_rate = def.send_rate;
    if (d.encoding == GS_ENCODING_DEFAULT) d.encoding = def.encoding;
    if (d.queue_size == 0) d.queue_size = def.queue_size;
    if (d.smoothing == 0.0) d.smoothing = def.smoothing;
    if (d.catchup == GS_CATCHUP_DEFAULT) d.catchup = def.catchup;
    if (d.catchup_max == 0.0) d.catchup_max = def.catchup_max;
    if (d.position_resolution == 0.0) d.position_resolution = def.position_resolution;
    if (d.velocity_resolution == 0.0) d.velocity_resolution = def.velocity_resolution;
    if (d.orientation_bits == 0) d.orientation_bits = def.orientation_bits;
    if (d.heartbeat_rate == 0.0) d.heartbeat_rate = def.heartbeat_rate;
    if (d.importance == 0.0) d.importance = def.importance;
    return d;
}

GS__PRIVATE gs_result gs__ghost_check(gs_world *w, const gs_ghost_desc *d) {
    gs__check c = gs__check_begin(w, "gs_ghost_attach");
    if (d->object_id == 0)
        gs__check_fail(&c, GS_ERR_INVALID_ARG, "object_id is 0, must be > 0");
    else if (gs__ghost_find(w, d->object_id))
        gs__check_fail(&c, GS_ERR_INVALID_ARG, "object_id %lu is already used",
                       (unsigned long)d->object_id);
    gs__check_positive(&c, "send_rate", d->send_rate);
    gs__check_int(&c, "encoding", (long)d->encoding, 1, GS__ENCODING_COUNT - 1);
    gs__check_int(&c, "queue_size", d->queue_size, 1, 1024);
    gs__check_positive(&c, "smoothing", d->smoothing);
    gs__check_finite(&c, "time_deadband", d->time_deadband);
    gs__check_int(&c, "catchup", (long)d->catchup, 1, GS__CATCHUP_COUNT - 1);
    gs__check_positive(&c, "catchup_max", d->catchup_max);
    /* the steps gs_wire_add takes */
    if (!(d->position_resolution >= 1e-12 && d->position_resolution <= 1e12))
        gs__check_fail(&c, GS_ERR_INVALID_ARG, "position_resolution %g is outside [1e-12, 1e12]",
                       d->position_resolution);
    if (!(d->velocity_resolution >= 1e-12 && d->velocity_resolution <= 1e12))
        gs__check_fail(&c, GS_ERR_INVALID_ARG, "velocity_resolution %g is outside [1e-12, 1e12]",
                       d->velocity_resolution);
    gs__check_int(&c, "orientation_bits", d->orientation_bits, 8, 24);
    gs__check_nonneg(&c, "rest_threshold", d->rest_threshold);
    gs__check_positive(&c, "heartbeat_rate", d->heartbeat_rate);
    gs__check_positive(&c, "importance", d->importance);
    gs__check_int(&c, "delta", d->delta, 0, 1);
    gs__check_int(&c, "rest_extrapolate", d->rest_extrapolate, 0, 1);
    gs__check_int(&c, "adopt_sent", d->adopt_sent, 0, 1);
    if (d->delta && d->encoding != GS_ENCODING_QUANT)
        gs__check_fail(&c, GS_ERR_INVALID_ARG, "delta is 1 but the encoding is not "
                       "GS_ENCODING_QUANT (deltas are of quantized integers)");
    return c.r;
}

GS__PRIVATE gs_result gs__ghost_queues(gs__ghost *g);

/* A snapshot's chunk index and count are u16 on the wire: a state that
   needs more chunks could never be sent whole (the indices would wrap and
   every peer refuse them). Counted without (vars + per - 1), which could
   wrap for a custom agent's state_size. */
GS__PRIVATE gs_result gs__ghost_chunks_fit(gs_world *w, size_t vars, gs_encoding e) {
    size_t per = gs__per_chunk(e);
    size_t chunks = vars / per + (vars % per != 0);
    if (chunks <= GS_WIRE_MAX_OBJECT_CHUNKS) return GS_OK;
    return gs__fail(w, GS_ERR_CAPACITY,
                    "gs_ghost_attach: the state has %lu values, %lu chunks of "
                    "%lu in %s; a snapshot may have at most %d chunks "
                    "(GS_WIRE_MAX_OBJECT_CHUNKS, %lu values)",
                    (unsigned long)vars, (unsigned long)chunks,
                    (unsigned long)per,
                    e == GS_ENCODING_F32 ? "f32" : e == GS_ENCODING_QUANT ? "quant" : "f64",
                    GS_WIRE_MAX_OBJECT_CHUNKS,
                    (unsigned long)(per * GS_WIRE_MAX_OBJECT_CHUNKS));
}

/* The bytes of a ghost (*bytes) and of one peer's queue (*queue) for a
   state of n values; 0 if either does not fit in size_t (a custom agent's
   state_size can be anything). */
GS__PRIVATE int gs__ghost_sizes(size_t n, const gs_ghost_desc *d, size_t *bytes,
                                size_t *queue) {
    size_t qs = (size_t)d->queue_size, slots = (size_t)GS__MAX_PEERS * qs, per, nchunks, vals;
    size_t room = gs__per_chunk(d->encoding);
    nchunks = (n - 1) / room + 1; /* at least one, as gs_ghost_attach counts */
    if (!gs__size(n, 7, slots, &vals) || !gs__size(vals, sizeof(double), 0, &vals) ||
        !gs__size(slots, sizeof(gs__src), sizeof(gs__ghost), bytes) || *bytes > SIZE_MAX - vals)
        return 0;
    *bytes += vals;
    return gs__size(n - 1, sizeof(double), sizeof(gs__snap) + nchunks, &per) &&
           gs__size(2 * qs + 1, per, 0, queue); /* + the last values, the taken
                                                   (gs__snaps_new) */
}

GS_API gs_result gs_ghost_attach(gs_agent *a, const gs_ghost_desc *desc) {
    gs_world *w = a ? a->world : NULL;
    gs_ghost_desc d;
    gs__ghost *g;
    size_t n, vars, bytes, queue;
    int i;
    gs_result r = gs__world_unlocked(w, "gs_ghost_attach");
    if (r != GS_OK) return r;
    n = gs_agent_state_size(a);
    vars = n - 1;
    if (!desc) return gs__fail(w, GS_ERR_INVALID_ARG, "gs_ghost_attach: desc is NULL");
    if (a->ghost) return gs__fail(w, GS_ERR_INVALID_ARG, "gs_ghost_attach: the agent has a ghost");
    d = gs__ghost_defaults(desc);
    r = gs__ghost_check(w, &d);
    if (r != GS_OK) return r;
    r = gs__ghost_chunks_fit(w, vars, d.encoding);
    if (r != GS_OK) return r;
    if (!gs__ghost_sizes(n, &d, &bytes, &queue))
        return gs__fail(w, GS_ERR_OUT_OF_RANGE, "gs_ghost_attach: a state of %lu values "
                        "with queue_size %d does not fit in size_t", (unsigned long)n,
                        d.queue_size);
    g = (gs__ghost *)gs__alloc(w, bytes);
    if (!g) return gs__fail(w, GS_ERR_NO_MEMORY, "gs_ghost_attach: out of memory");
    memset(g, 0, bytes);
    g->agent = a;
    g->d = d;
    g->n = n;
    g->per_chunk = (int)gs__per_chunk(d.encoding);
    g->nchunks = vars ? (int)((vars + (size_t)g->per_chunk - 1) / (size_t)g->per_chunk) : 1;
    g->src = (gs__src *)(g + 1);
    g->B = (double *)(g->src + (size_t)GS__MAX_PEERS * (size_t)d.queue_size);
    g->local = g->B + n;
    g->scratch = g->local + n;
    g->offset = g->scratch + n;
    g->offset_next = g->offset + n;
    g->wq = g->offset_next + n;
    g->sent = g->wq + (size_t)GS__MAX_PEERS * (size_t)d.queue_size;
    g->pred = g->sent + n;
    gs_agent_get_state(a, g->B, n);
    memcpy(g->sent, g->B, n * sizeof(double));
    g->b_seq = 1;
    g->t_local = g->B[0];
    for (i = 0; i < GS__MAX_PEERS; ++i)
        g->gp[i].newest = g->gp[i].lead_at = g->gp[i].heard_at = -HUGE_VAL;
    a->ghost = g;
    r = gs__ghost_queues(g);
    if (r == GS_OK && (d.delta || ((d.rest_extrapolate || d.adopt_sent) &&
                                   d.encoding == GS_ENCODING_QUANT))) {
        g->ring = d.delta ? gs__ring_new(w, g) : NULL;
        g->kbuf = (int64_t *)gs__alloc(w, 2 * (size_t)g->per_chunk * sizeof(int64_t));
        /* a row past a chunk's triples never has one above in the chunk */
        g->row = gs__mesh_row(a);
        if (g->row > GS_WIRE_SPATIAL_ROW) g->row = 1;
        if ((d.delta && !g->ring) || !g->kbuf)
            r = gs__fail(w, GS_ERR_NO_MEMORY, "gs_ghost_attach: out of memory for the "
                         "delta baselines");
    }
    if (r != GS_OK) {
        a->ghost = NULL;
        gs__ghost_free(g);
    }
    return r;
}

GS_API gs_result gs_ghost_detach(gs_agent *a) {
    gs_result r = gs__world_unlocked(a ? a->world : NULL, "gs_ghost_detach");
    gs__ghost *g;
    if (r != GS_OK) return r;
    g = gs__ghost_of(a);
    if (!g) return GS_OK;
    gs__lock(a->world->net);
    a->ghost = NULL;
    gs__unlock(a->world->net);
    gs__ghost_free(g);
    return GS_OK;
}

GS_API gs_result gs_ghost_get_stats(const gs_agent *a, gs_ghost_stats *out) {
    const gs__ghost *g = a ? gs__ghost_of(a) : NULL;
    if (!g || !out) return GS_ERR_INVALID_ARG;
    *out = g->stats;
    return GS_OK;
}

/* Render smoothing: the offset decays as exp(-(t - offset_t) / smoothing). */
GS__PRIVATE double gs__offset_fade(const gs__ghost *g, double t) {
    double dt = t - g->offset_t;
    return dt <= 0.0 ? 1.0 : exp(-dt / g->d.smoothing);
}

GS_API gs_result gs_ghost_render_state(const gs_agent *a, double *out,
                                       size_t n) {
    const gs__ghost *g = a ? gs__ghost_of(a) : NULL;
    gs_result r = gs_agent_get_state(a, out, n);
    double f;
    size_t i;
    if (r != GS_OK) return r;
    if (!g) return GS_OK;
    f = gs__offset_fade(g, out[0]);
    for (i = 1; i < n; ++i) /* huge state and offset: the state alone */
        if (gs__finite(out[i] + f * g->offset[i])) out[i] += f * g->offset[i];
    return GS_OK;
}

GS__PRIVATE int gs__scene_has_ghost(const gs_scene *sc) {
    int i, any = sc->cloth->ghost != NULL;
    for (i = 0; i < sc->sphere_count; ++i) any |= sc->spheres[i]->ghost != NULL;
    for (i = 0; i < sc->probe_count; ++i) any |= sc->probes[i]->ghost != NULL;
    return any;
}

/* The ghost of one object of the scene: `gd` with the object's id, owner
   and the rule rule_for gives it (its default if none). */
GS__PRIVATE gs_result gs__scene_attach_one(gs_agent *a, gs_ghost_desc gd, uint32_t id,
                                           uint32_t owner, const gs_weight_rule *rule) {
    gd.object_id = id;
    gd.owner = owner;
    if (rule->fn) {
        gd.weight = rule->fn;
        gd.weight_user = rule->user;
    }
    return gs_ghost_attach(a, &gd);
}

GS_API gs_result gs_scene_attach_ghosts(gs_scene *sc, const gs_ghost_desc *shared) {
    gs_ghost_desc gd = shared ? *shared : gs_ghost_desc_default(), pd;
    gs_weight_rule rules[1 + GS_SCENE_MAX_SPHERES + GS_SCENE_MAX_PROBES];
    gs_result r = GS_OK;
    int i, k;
    if (!sc || !sc->cloth) return GS_ERR_INVALID_ARG;
    if (gs__scene_has_ghost(sc))
        return gs__fail(sc->cloth->world, GS_ERR_INVALID_ARG,
                        "gs_scene_attach_ghosts: an agent of the scene has a ghost already");
    /* every rule first, so that nothing is attached while user code runs */
    memset(rules, 0, sizeof rules);
    if (gd.rule_for) {
        rules[0] = gd.rule_for(1, sc->cloth, gd.rule_for_user);
        for (i = 0; i < sc->sphere_count; ++i)
            rules[1 + i] = gd.rule_for(100 + (uint32_t)i, sc->spheres[i], gd.rule_for_user);
        for (i = 0; i < sc->probe_count; ++i)
            rules[1 + GS_SCENE_MAX_SPHERES + i] =
                gd.rule_for(200 + (uint32_t)i, sc->probes[i], gd.rule_for_user);
    }
    r = gs__scene_attach_one(sc->cloth, gd, 1, 0, &rules[0]);
    for (i = 0; r == GS_OK && i < sc->sphere_count; ++i)
        r = gs__scene_attach_one(sc->spheres[i], gd, 100 + (uint32_t)i, 0, &rules[1 + i]);
    pd = gd;
    pd.weight = gs_weight_owner;
    pd.weight_user = NULL;
    pd.catchup = GS_CATCHUP_NONE;
    for (i = 0; r == GS_OK && i < sc->probe_count; ++i) {
        k = 1 + GS_SCENE_MAX_SPHERES + i;
        r = gs__scene_attach_one(sc->probes[i], pd, 200 + (uint32_t)i, (uint32_t)i + 1, &rules[k]);
    }
    if (r != GS_OK) { /* the error message stays with the world */
        gs_ghost_detach(sc->cloth);
        for (i = 0; i < sc->sphere_count; ++i) gs_ghost_detach(sc->spheres[i]);
        for (i = 0; i < sc->probe_count; ++i) gs_ghost_detach(sc->probes[i]);
    }
    return r;
}

GS__PRIVATE void gs__ghost_decoded(gs__ghost *g, const double *S, double *out);
GS__PRIVATE void gs__sync_log_adopt(gs_agent *a);

/* adopt_sent: does the ghost's agent take what it sends? A probe does
   not: its state is set from its target each step, and set by hand it
   would lose the target. */
GS__PRIVATE int gs__ghost_adopts(const gs__ghost *g) {
    const gs_agent *a = g->agent;
    const gs__rigid *r = gs__as_rigid(a);
    return g->d.adopt_sent && g->d.encoding != GS_ENCODING_F64 &&
           (a->kind == &gs__mesh_kind || a->kind == &gs__cloth_kind || (r && !r->probe));
}

/* adopt_sent: the agent's values (not its time, not its sleep) become the
   decoded ones of state S, as a peer's blend of weight 1 sets them. S may
   be g->B; g->scratch takes the decoded state, and B too if to_b (in the
   net's lock: its send reads B and shares kbuf). */
GS__PRIVATE void gs__ghost_adopt(gs__ghost *g, const double *S, gs_net *net, int to_b) {
    gs__lock(net);
    gs__ghost_decoded(g, S, g->scratch);
    if (to_b) memcpy(g->B, g->scratch, g->n * sizeof(double));
    gs__unlock(net);
    g->agent->kind->set_state(g->agent, g->scratch + 1);
}

/* After a step: the latest state goes to B at the ghost's rate (simulation
   time stands in for wall time here: the world keeps pace with it);
   adopt_sent: B is what the peers decode, and the agent takes it. */
GS__PRIVATE void gs__ghost_publish_now(gs__ghost *g, gs_net *net) {
    double t = gs__agent_time(g->agent);
    gs__lock(net);
    gs_agent_get_state(g->agent, g->B, g->n);
    g->b_seq++;
    if (net) net->published = 1;
    gs__unlock(net);
    if (gs__ghost_adopts(g)) {
        gs__ghost_adopt(g, g->B, net, 1);
        gs__sync_log_adopt(g->agent);
    }
    g->next_publish = t + 1.0 / g->d.send_rate;
}

GS__PRIVATE void gs__ghost_publish(gs__ghost *g, gs_net *net) {
    double t = gs__agent_time(g->agent);
    if (t < g->next_publish && g->next_publish - t < 1.0 / g->d.send_rate) return;
    gs__ghost_publish_now(g, net);
}

GS__PRIVATE double gs__sane_weight(gs__ghost *g, double w) {
    if (gs__finite(w) && w >= 0.0) return w;
    g->stats.bad_weights++;
    return 0.0;
}

GS__PRIVATE gs_weight_in gs__weight_in(const gs__ghost *g, uint32_t host,
                                       double x, double age, int local) {
    gs_weight_in in;
    gs_world *w = g->agent->world;
    in.x = x;
    in.x_comp = g->d.raw_time ? x : x + age;
    in.x_max = 0.0;
    in.age = age;
    in.host = host;
    in.lead = host;
    in.owner = g->d.owner;
    in.local = local;
    in.local_owns = g->d.owner != 0 && g->d.owner == w->host_id;
    in.object_id = g->d.object_id;
    in.agent = g->agent;
    return in;
}

/* Dead reckoning: the snapshot carried to the local time along its
   velocities, at most catchup_max either way, in place (it is blended
   once, then dropped). Missing chunks take the local values first: the
   kind's extrapolation reads them. */
GS__PRIVATE void gs__snap_catch_up(gs__ghost *g, gs__snap *s, double t_i) {
    const gs__kind *k = g->agent->kind;
    size_t vars = g->n - 1;
    int c;
    if (g->d.catchup != GS_CATCHUP_VELOCITY || !k->extrapolate) return;
    for (c = 0; c < g->nchunks; ++c) {
        size_t first = (size_t)c * (size_t)g->per_chunk, cnt = (size_t)g->per_chunk;
        if (s->got[c]) continue;
        if (first + cnt > vars) cnt = vars - first;
        memcpy(s->data + first, g->local + 1 + first, cnt * sizeof(double));
    }
    k->extrapolate(g->agent, s->data,
                   fmax(-g->d.catchup_max, fmin(g->d.catchup_max, t_i - s->time)));
}

/* Time differences within this are noise: the hosts are in step. */
GS__PRIVATE double gs__time_band(const gs__ghost *g) {
    double band = g->d.time_deadband;
    if (band == 0.0) /* the tolerance, plus a snapshot's wait to be sent */
        band = g->agent->world->tolerance + 1.0 / g->d.send_rate;
    return band > 0.0 ? band : 0.0;
}

GS__PRIVATE double gs__snap_xcomp(const gs__ghost *g, const gs__snap *s, double t_i) {
    return g->d.raw_time ? s->time - t_i : s->time + s->age - t_i;
}

/* What a blend reads of the net and gives back to it. It runs with the
   net's lock not held (weight rules are user code, and gs_udp's threads
   wait on that lock): the peers' host ids are read before it and the
   figures it measures are written after it, both under the lock. */
typedef struct gs__blend_net {
    uint32_t host[GS__MAX_PEERS]; /* each peer slot's host id */
    double gap[GS__MAX_PEERS];    /* s; each peer's latest gap (st.gap), */
    uint32_t gapped;              /* bit p: measured for peer slot p */
    int fixed_time;               /* time is the clock's: no correction */
    int skip_equal;               /* a blended state equal bit for bit to
                                     the local one is not set (replay
                                     mode): setting it would still reset
                                     what the kind derives from it (a rigid
                                     body's own acceleration), so that a
                                     blend of weight 0 would change the
                                     run, and a replay could never find it
                                     changed nothing */
    double near;                  /* m; > 0: a replay's first blend, whose
                                     states within this of the local ones
                                     are held back (gs__ghost_blend) */
    int over;                     /* a ghost's state was beyond `near` */
    uint32_t lead;                /* the world's lead (gs__world_lead),
                                     0: elected ghost by ghost */
} gs__blend_net;

/* Notes, for each peer with a snapshot in this blend, that it was heard
   now and its freshest x_comp. */
GS__PRIVATE void gs__ghost_hear(gs__ghost *g, double t_i) {
    int p, k;
    for (p = 0; p < GS__MAX_PEERS; ++p)
        for (k = 0; g->gp[p].taken && k < g->d.queue_size; ++k) {
            double x;
            if (!g->gp[p].taken[k].used) continue;
            x = gs__snap_xcomp(g, &g->gp[p].taken[k], t_i);
            if (g->gp[p].heard_at != t_i || x > g->gp[p].heard_x) g->gp[p].heard_x = x;
            g->gp[p].heard_at = t_i;
        }
}

/* The lead: the lowest host id in step with the most advanced host among
   this one and the peers heard in the last GS__LIVE_TIME, whether or not a
   snapshot of theirs is in this blend. Elected from this blend's
   snapshots alone, the lead would change with whichever arrived first:
   with the link from 1 to 2 cut and 2 going its own way, a host that
   hears both would copy host 1's state at one blend and host 2's at the
   next (a sphere metres apart from one blend to the next).
   In step means within twice the time band for this host, and a peer's
   x_comp is read within three times it. Hosts settle up to a band apart
   (no time is corrected within it), and a peer's time is only ever read
   with an error: a snapshot waits to be sent, which its age does not
   count, it is read by whichever agent of the world is stepping, up to
   the tolerance away, and a host descheduled for a few ms reads the
   others that much ahead while it catches up. With one band for this
   host, two ghostpeer processes 22 ms apart (faults.py cut, band 26.7 ms)
   took turns: the host behind read the other past the band now and then
   and copied it while the other copied it back, and the scene at rest
   was kicked apart (final 1.48 mm). A peer's reading is allowed one band
   more than this host's own, so that two hosts near the edge never both
   lead: the one ahead sees the tie as well (read against the same band,
   neither would copy the other again: test_converge, spheres metres
   apart after a clock step); the host behind still takes a peer more
   than two bands ahead for the lead, and follows its time, and a host up
   to two bands ahead of the lead is pulled back to it. x[p] is peer slot
   p's freshest x_comp, -HUGE_VAL if it was not heard. */
#define GS__LIVE_TIME 0.5 /* s of local simulation time */
GS__PRIVATE uint32_t gs__elect(uint32_t self, const gs__blend_net *bn, const double *x,
                               double band) {
    double x_live = 0.0;
    uint32_t lead;
    int p;
    for (p = 0; p < GS__MAX_PEERS; ++p) x_live = fmax(x_live, x[p]);
    lead = x_live <= 2.0 * band ? self : 0;
    for (p = 0; p < GS__MAX_PEERS; ++p)
        if (x[p] > -HUGE_VAL && x[p] >= x_live - 3.0 * band && (lead == 0 || bn->host[p] < lead))
            lead = bn->host[p];
    return lead;
}

/* Each peer's freshest x_comp at g if heard in the last GS__LIVE_TIME
   (else -HUGE_VAL kept), as the largest of x[p] and it. */
GS__PRIVATE void gs__ghost_heard(gs__ghost *g, double t_i, double *x) {
    int p;
    gs__ghost_hear(g, t_i);
    for (p = 0; p < GS__MAX_PEERS; ++p)
        if (t_i - g->gp[p].heard_at <= GS__LIVE_TIME) x[p] = fmax(x[p], g->gp[p].heard_x);
}

/* The lead of a world's blend, one for every ghost in it: elected ghost
   by ghost, each against its own agent's time, objects in contact could
   take different hosts' states (a sphere from a peer on the local cloth,
   and 27 ms on from it: the same faults.py cut run). Objects in contact
   need one authority (gs_weight_fn). */
GS__PRIVATE uint32_t gs__world_lead(gs_world *w, const gs__blend_net *bn) {
    double x[GS__MAX_PEERS], band = 0.0;
    int i, p;
    for (p = 0; p < GS__MAX_PEERS; ++p) x[p] = -HUGE_VAL;
    for (i = 0; i < w->agent_count; ++i) {
        gs__ghost *g = gs__ghost_of(w->agents[i]);
        if (!g || g->ntaken == 0) continue;
        gs__ghost_heard(g, gs__agent_time(g->agent), x);
        band = fmax(band, gs__time_band(g));
    }
    return gs__elect(w->host_id, bn, x, band);
}

/* The largest x_comp of a blend (the local state's is 0), and the lead
   (the world's, bn->lead, if it was elected). */
GS__PRIVATE double gs__ghost_lead(gs__ghost *g, const gs__blend_net *bn, double t_i,
                                  uint32_t *lead) {
    double x_max = 0.0, x[GS__MAX_PEERS];
    int p, k;
    for (p = 0; p < GS__MAX_PEERS; ++p) {
        x[p] = -HUGE_VAL;
        for (k = 0; g->gp[p].taken && k < g->d.queue_size; ++k)
            if (g->gp[p].taken[k].used)
                x_max = fmax(x_max, gs__snap_xcomp(g, &g->gp[p].taken[k], t_i));
    }
    gs__ghost_heard(g, t_i, x);
    *lead = bn->lead ? bn->lead : gs__elect(g->agent->world->host_id, bn, x, gs__time_band(g));
    return x_max;
}

/* The weight of the local state and of every taken snapshot. Returns the
   local weight; all weights are scaled so that the largest is 1. The
   user's rules run here, with no lock held. */
GS__PRIVATE double gs__ghost_weigh(gs__ghost *g, const gs__blend_net *bn, double t_i,
                                   double *wq) {
    gs_world *wd = g->agent->world;
    gs_weight_in in0 = gs__weight_in(g, wd->host_id, 0.0, 0.0, 1);
    double x_max, w0, wmax;
    uint32_t lead;
    int p, k, m = 0;
    x_max = gs__ghost_lead(g, bn, t_i, &lead);
    in0.x_max = x_max;
    in0.lead = lead;
    wmax = w0 = gs__sane_weight(g, g->d.weight(&in0, g->d.weight_user));
    for (p = 0; p < GS__MAX_PEERS; ++p)
        for (k = 0; g->gp[p].taken && k < g->d.queue_size; ++k) {
            const gs__snap *s = &g->gp[p].taken[k];
            gs_weight_in in;
            if (!s->used) continue;
            in = gs__weight_in(g, bn->host[p], s->time - t_i, s->age, 0);
            in.x_max = x_max;
            in.lead = lead;
            wq[m] = gs__sane_weight(g, g->d.weight(&in, g->d.weight_user));
            if (wq[m] > wmax) wmax = wq[m];
            m++;
        }
    if (wmax <= 0.0) return -1.0; /* every weight 0: the local state stands */
    for (k = 0; k < m; ++k) wq[k] /= wmax;
    return w0 / wmax;
}

/* Moves the snapshots queued for g whose time is at most t (all, for t =
   HUGE_VAL), but for one left for its chunks still on the way when
   keep_waiting says so, out of the net's queue into the slots the blend
   reads. A swap of slots: nothing is copied or allocated. Under the net's
   lock. Returns how many. */
GS__PRIVATE int gs__ghost_take(gs__ghost *g, double t, int keep_waiting) {
    int p, k, m = 0;
    for (p = 0; p < GS__MAX_PEERS; ++p)
        for (k = 0; g->gp[p].q && k < g->d.queue_size; ++k) {
            gs__snap *s = &g->gp[p].q[k], *b = &g->gp[p].taken[k], tmp;
            b->used = 0;
            if (!s->used || s->time > t || (keep_waiting && s->waited == 1)) continue;
            tmp = *b;
            *b = *s;
            *s = tmp; /* the queue's slot is free again */
            s->used = s->chunks = s->waited = 0;
            memset(s->got, 0, (size_t)g->nchunks);
            m++;
        }
    return m;
}

/* After a blend: what it took is spent. */
GS__PRIVATE void gs__ghost_clear(gs__ghost *g) {
    int p, k;
    for (p = 0; p < GS__MAX_PEERS; ++p)
        for (k = 0; g->gp[p].taken && k < g->d.queue_size; ++k) g->gp[p].taken[k].used = 0;
    g->ntaken = 0;
}

/* The peer's divergence: the largest over the world's objects of the
   latest distance to that peer's snapshot of it. */
GS__PRIVATE double gs__peer_divergence(const gs_world *w, int p) {
    double worst = 0.0;
    int i;
    for (i = 0; i < w->agent_count; ++i) {
        const gs__ghost *o = gs__ghost_of(w->agents[i]);
        if (o && o->gp[p].divergence > worst) worst = o->gp[p].divergence;
    }
    return worst;
}

/* The formula as written (raw_time, or a negative deadband): every
   snapshot's x_comp counts in the time blend as it is. */
GS__PRIVATE int gs__time_literal(const gs__ghost *g) {
    return g->d.raw_time || g->d.time_deadband < 0.0;
}

/* Does s tell the peer's present time? Only its latest snapshot does: one
   held back on the way (reordering), or sent before one already blended,
   is older than its age says and would pull the clock back. Before the
   first round trip the age is unknown (taken as 0), so the time is only a
   lower bound: it may pull the clock on, never back; otherwise every host
   would drag the others a latency into the past at the start. A time over
   a second behind the latest is a peer that started again. */
GS__PRIVATE int gs__snap_tells_time(const gs__ghost *g, int p, const gs__snap *s,
                                    double t_i) {
    int k;
    if (gs__time_literal(g)) return 1;
    if (s->time < g->gp[p].newest && s->time > g->gp[p].newest - 1.0) return 0;
    for (k = 0; k < g->d.queue_size; ++k)
        if (g->gp[p].taken[k].used && g->gp[p].taken[k].time > s->time) return 0;
    return s->age_known || s->time > t_i;
}

/* A peer's lead (s; how far its clock is ahead of ours) from one more
   x_comp. A snapshot delayed on the way (jitter, a datagram held back)
   looks older than it is, never newer: so the lead follows a larger sample
   at once and a smaller one at GS__LEAD_FALL seconds per second, and a late
   datagram does not pull the clock back (which jumps the agents that get
   it apart from the rest, and their contacts with them). */
#define GS__LEAD_FALL 0.1
GS__PRIVATE double gs__peer_lead(gs__ghost *g, int p, double x, double t_i) {
    double fall;
    if (gs__time_literal(g)) return x;
    fall = g->gp[p].lead_at == -HUGE_VAL ? HUGE_VAL : GS__LEAD_FALL * fabs(t_i - g->gp[p].lead_at);
    if (x > g->gp[p].lead - fall) g->gp[p].lead = x;
    else g->gp[p].lead -= fall;
    g->gp[p].lead_at = t_i;
    return g->gp[p].lead;
}

/* Lists every taken snapshot with its weight in g->src, in queue order,
   and sums the blended time; notes the per-peer gap. Returns the number of
   snapshots. */
GS__PRIVATE int gs__ghost_gather(gs__ghost *g, gs__blend_net *bn, double t_i, double *num_t,
                                 double *den_t) {
    int p, k, m = 0;
    for (p = 0; p < GS__MAX_PEERS; ++p) {
        double newest = g->gp[p].newest;
        for (k = 0; g->gp[p].taken && k < g->d.queue_size; ++k) {
            gs__snap *s = &g->gp[p].taken[k];
            gs__src *src = &g->src[m];
            double tq;
            if (!s->used) continue;
            src->w = g->wq[m++];
            gs__snap_catch_up(g, s, t_i);
            src->v = s->data;
            src->got = s->got;
            src->d2 = 0.0;
            src->counted = 0;
            src->peer = p;
            tq = g->d.raw_time ? s->time : s->time + s->age;
            bn->gap[p] = s->time - t_i;
            bn->gapped |= (uint32_t)1 << p;
            if (gs__snap_tells_time(g, p, s, t_i)) {
                *num_t += src->w * gs__peer_lead(g, p, tq - t_i, t_i);
                *den_t += src->w;
                newest = s->time;
            }
        }
        g->gp[p].newest = newest;
    }
    g->nsrc = m;
    return m;
}

/* What one pass of a blend carries from chunk to chunk. Sums run in 4
   lanes, so that no chain of dependent adds sets the pace: the statistics
   they give (divergence, last_correction) may differ from a sum in element
   order in their last bits. */
typedef struct gs__pass {
    double w0, fade;
    double corr2[4];  /* squared corrections */
    int finite;       /* every new value finite so far */
} gs__pass;

/* How a chunk's new values are made from its weighted sum of differences:
   times 1 / (w0 + sum w) computed once per chunk; divided by it when the
   inverse would overflow; or not at all when every weight is 0. */
enum { GS__BLEND_MUL, GS__BLEND_DIV, GS__BLEND_KEEP };

/* One chunk's elements, where they are to be written. */
typedef struct gs__blend_out {
    const double *old, *off; /* local values, render offsets now */
    double *nv, *next;       /* new values, next render offsets */
} gs__blend_out;

/* Element e from its weighted sum of differences num: new value, next
   render offset; returns the squared correction. */
GS__PRIVATE double gs__blend_put(const gs__blend_out *o, size_t e, double num,
                                 int mode, double r, double d, double fade,
                                 int *finite) {
    double x = o->old[e], n, k, f;
    n = mode == GS__BLEND_MUL ? x + num * r : mode == GS__BLEND_DIV ? x + num / d : x;
    k = x - n;
    f = fade * o->off[e] + k;
    o->nv[e] = n;
    o->next[e] = f - f == 0.0 ? f : 0.0; /* huge: no fading */
    *finite &= n - n == 0.0;
    return k * k;
}

/* One element against a single snapshot (v, weight w), the chunk
   multiplying by r: new value, next render offset; adds its squared
   difference to *s2 (position values: pos) and its squared correction to
   *c2. A non-finite offset makes *c2 NaN too (f - f), and gs__blend_pass
   mends it then. Inline: the caller keeps the sums in registers. */
GS__PRIVATE inline void gs__blend_el(const gs__blend_out *o, const double *v, size_t i,
                                     double w, double r, double fade, int pos,
                                     double *s2, double *c2) {
    double x = o->old[i], dd = v[i] - x, n = x + (w * dd) * r, k = x - n;
    double f = fade * o->off[i] + k;
    o->nv[i] = n;
    o->next[i] = f;
    if (pos) *s2 += dd * dd;
    *c2 += k * k + (f - f);
}

/* Elements [a, b) against a single snapshot, the common case, four
   elements to a round with a sum each, so that no chain of dependent adds
   sets the pace. Its new values are not checked one by one: a non-finite
   one makes its correction, and so the sum of squared corrections,
   non-finite (gs__blend_pass looks closer then). d2 gets the squared
   differences of position values (pos). */
GS__PRIVATE void gs__blend_one(const gs__blend_out *o, const double *v, double w,
                               size_t a, size_t b, int pos, double r,
                               gs__pass *ps, double *d2) {
    double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0, fade = ps->fade;
    double c0 = ps->corr2[0], c1 = ps->corr2[1], c2 = ps->corr2[2], c3 = ps->corr2[3];
    size_t e = a;
    for (; e + 4 <= b; e += 4) {
        gs__blend_el(o, v, e, w, r, fade, pos, &s0, &c0);
        gs__blend_el(o, v, e + 1, w, r, fade, pos, &s1, &c1);
        gs__blend_el(o, v, e + 2, w, r, fade, pos, &s2, &c2);
        gs__blend_el(o, v, e + 3, w, r, fade, pos, &s3, &c3);
    }
    for (; e < b; ++e) gs__blend_el(o, v, e, w, r, fade, pos, &s0, &c0);
    ps->corr2[0] = c0; ps->corr2[1] = c1; ps->corr2[2] = c2; ps->corr2[3] = c3;
    *d2 += (s0 + s1) + (s2 + s3);
}

/* Elements [a, b) of chunk c against every snapshot that holds it, in
   queue order (the sum of differences in the order the formula had). */
GS__PRIVATE void gs__blend_many(gs__ghost *g, const gs__blend_out *o, int c,
                                size_t a, size_t b, size_t npos, int mode,
                                double r, double d, gs__pass *ps) {
    int j, fin = 1;
    size_t e;
    for (e = a; e < b; ++e) {
        double num = 0.0;
        for (j = 0; j < g->nsrc; ++j) {
            gs__src *q = &g->src[j];
            double dd;
            if (!q->got[c]) continue;
            dd = q->v[e] - o->old[e];
            num += q->w * dd;
            if (e < npos) q->d2 += dd * dd;
        }
        ps->corr2[e & 3] += gs__blend_put(o, e, num, mode, r, d, ps->fade, &fin);
    }
    ps->finite &= fin;
}

/* The elements [a, b) of chunk c, covered by the snapshots that hold it:
   new values into scratch and next render offsets, in one pass. The
   paper's (w0 S + sum w q) / (w0 + sum w) is written as S plus the
   weighted mean difference, so that agreeing states give exactly S, and
   its division as a multiplication by 1 / (w0 + sum w): a new value
   differs from the quotient by at most an ulp of the correction
   (|num / d| * 2^-52). */
GS__PRIVATE void gs__blend_chunk(gs__ghost *g, gs__pass *ps, int c, size_t a,
                                 size_t b, size_t npos) {
    gs__blend_out o;
    double den = 0.0, d, r = 0.0;
    gs__src *one = NULL;
    int j, nq = 0, mode;
    size_t pend = npos < a ? a : npos < b ? npos : b;
    o.old = g->local + 1;
    o.off = g->offset + 1;
    o.nv = g->scratch + 1;
    o.next = g->offset_next + 1;
    for (j = 0; j < g->nsrc; ++j)
        if (g->src[j].got[c]) {
            den += g->src[j].w;
            g->src[j].counted += pend - a;
            one = &g->src[j];
            nq++;
        }
    d = ps->w0 + den;
    if (d > 0.0) r = 1.0 / d;
    mode = !(d > 0.0) ? GS__BLEND_KEEP : r - r == 0.0 ? GS__BLEND_MUL : GS__BLEND_DIV;
    if (nq == 1 && mode == GS__BLEND_MUL) {
        gs__blend_one(&o, one->v, one->w, a, pend, 1, r, ps, &one->d2);
        gs__blend_one(&o, one->v, one->w, pend, b, 0, r, ps, &one->d2);
    } else {
        gs__blend_many(g, &o, c, a, b, npos, mode, r, d, ps);
    }
}

/* After a pass whose sums came out non-finite, element by element: is
   every new value finite; a huge render offset is dropped (no fading)
   rather than kept as inf; and the squared corrections are summed again
   without the offsets' NaN. */
GS__PRIVATE void gs__blend_mend(gs__ghost *g, gs__pass *ps) {
    double c2 = 0.0;
    size_t e;
    for (e = 1; e < g->n; ++e) {
        double k = g->local[e] - g->scratch[e];
        ps->finite &= gs__finite(g->scratch[e]);
        if (!gs__finite(g->offset_next[e])) g->offset_next[e] = 0.0;
        c2 += k * k;
    }
    memset(ps->corr2, 0, sizeof ps->corr2);
    ps->corr2[0] = c2;
}

/* Every element of the state once, chunk by chunk. Returns 0 if a new
   value is not finite (a sum that overflows, dead reckoning at an absurd
   speed: found by fuzzing), and then nothing may be applied. */
GS__PRIVATE int gs__blend_pass(gs__ghost *g, gs__pass *ps) {
    size_t vars = g->n - 1, first;
    size_t npos = g->agent->kind->positions ? g->agent->kind->positions(g->agent) : vars;
    int c;
    for (c = 0; c < g->nchunks; ++c) {
        first = (size_t)c * (size_t)g->per_chunk;
        if (first >= vars) break;
        gs__blend_chunk(g, ps, c, first,
                        first + (size_t)g->per_chunk < vars ? first + (size_t)g->per_chunk : vars,
                        npos);
    }
    if (ps->finite && !gs__finite((ps->corr2[0] + ps->corr2[1]) + (ps->corr2[2] + ps->corr2[3])))
        gs__blend_mend(g, ps); /* or corrections over 1e154 */
    return ps->finite;
}

/* Each snapshot's distance from the local state (RMS of its position
   values, m) becomes its peer's divergence; the latest snapshot of a peer
   counts. Returns the peers seen, bit p for peer slot p. */
GS__PRIVATE uint32_t gs__ghost_divergence(gs__ghost *g) {
    uint32_t seen = 0;
    int j;
    for (j = 0; j < g->nsrc; ++j) {
        const gs__src *q = &g->src[j];
        g->gp[q->peer].divergence = q->counted ? sqrt(3.0 * q->d2 / (double)q->counted) : 0.0;
        seen |= (uint32_t)1 << q->peer;
    }
    return seen;
}

/* Simulation time is blended only past the deadband (by default the world's
   tolerance). Hosts in step
   differ by less, and there the correction is mostly the error of the age
   estimate (the clock offset's, and a snapshot's wait to be sent, which
   the age does not count): applied at every blend it would push the time on, and the agent
   would skip steps to stay on its world's clock. A host far behind (one
   that joins late) is pulled to the others at once. On the session clock
   (bn->fixed_time) time is the clock's, not the blend's: a stepped clock
   misreads the ages until the net measures the offset again. */
GS__PRIVATE double gs__time_correction(const gs__ghost *g, const gs__blend_net *bn, double gap,
                                       double dt) {
    if (bn->fixed_time) return 0.0;
    return fabs(gap) > gs__time_band(g) ? dt : 0.0;
}

/* The blended time from the local t_i and a correction, bounded: all the
   blends of one advance move the agent by at most GS_MAX_TIME_CORRECTION,
   and never out of [0, GS_WIRE_MAX_TIME]. Whatever the snapshots say (a
   forged time, a peer a year on), the host keeps running; a late joiner
   catches up over a few advances. A non-finite correction is passed on for
   the pass to refuse. */
GS__PRIVATE double gs__time_bound(gs__ghost *g, double t_i, double corr) {
    double room, t;
    if (g->moved_epoch != g->agent->world->epoch) {
        g->moved_epoch = g->agent->world->epoch;
        g->moved = 0.0;
    }
    if (!gs__finite(corr)) return t_i + corr;
    room = GS_MAX_TIME_CORRECTION - g->moved;
    if (room < 0.0) room = 0.0;
    t = t_i + (corr > room ? room : corr < -room ? -room : corr);
    return t < 0.0 ? 0.0 : t > GS_WIRE_MAX_TIME ? GS_WIRE_MAX_TIME : t;
}

/* Applies a blended state (scratch) that the pass found finite: the kind
   may still refuse it (a zero quaternion), and then nothing moves. */
GS__PRIVATE int gs__blend_apply(gs__ghost *g, double t_i) {
    double *t;
    int e;
    if (gs__agent_put_state(g->agent, g->scratch) != GS_OK) return 0;
    gs__sync_sighted(g->agent);
    g->moved += fabs(g->scratch[0] - t_i);
    /* the formula as written pulls back at every blend, and the clock
       stays: the time pulled back is simulated again (the latency trap) */
    g->pulled = gs__time_literal(g) ? 0.0 : t_i - g->scratch[0];
    for (e = 0; e < GS__MAX_PEERS; ++e) g->gp[e].lead -= g->scratch[0] - t_i;
    t = g->offset; /* the next offsets are now the offsets */
    g->offset = g->offset_next;
    g->offset_next = t;
    g->offset_t = g->scratch[0];
    return 1;
}

/* Was the state just blended wholly a resting leader's (every snapshot
   taken a heartbeat's, the local state of weight 0)? Then the agent is
   held there: it sleeps after its next step (gs__rigid_rest,
   gs__mesh_rest). Stepped on its own from a state that is not its own
   (quantized, each object from its own send), a copy resting in contact
   is off its equilibrium by up to a quantization step or the rest
   threshold, and its contacts throw it off between heartbeats (mm to cm
   at 4 Hz in the paper scene at rest; docs/sync-notes.md). A sleeper
   still wakes on what wakes any (a probe, a faster body, a snapshot).
   Not under rest_extrapolate: there a heartbeat stands for a state
   carried along its velocity, which a sleeper would not follow. */
GS__PRIVATE int gs__ghost_held(const gs__ghost *g, const gs__pass *ps) {
    int j, held = ps->w0 == 0.0 && g->nsrc > 0 && !g->d.rest_extrapolate;
    for (j = 0; held && j < g->nsrc; ++j) held = g->gp[g->src[j].peer].resting;
    return held;
}

GS__PRIVATE int gs__ghost_runs(const gs__ghost *g, size_t end[3], int cls[3]);

/* Is the blended state (scratch) within `tol` of the local one: every
   position and quaternion component within tol, every velocity within
   what tol is over a send period (gs__ghost_moved's measure)? */
GS__PRIVATE int gs__ghost_near(const gs__ghost *g, double tol) {
    size_t end[3], lo = 0, i;
    int cls[3], r, nr = gs__ghost_runs(g, end, cls);
    if (g->scratch[0] != g->local[0]) return 0;
    for (r = 0; r < nr; lo = end[r++]) {
        double lim = cls[r] == 2 ? tol * g->d.send_rate : tol;
        for (i = lo; i < end[r]; ++i)
            if (!(fabs(g->scratch[1 + i] - g->local[1 + i]) <= lim)) return 0;
    }
    return 1;
}

/* The paper's ghost update: blend every taken snapshot once with the
   local state (gs__ghost_take took them from the queues). One pass over
   the state after the agent's get_state, then its set_state. No lock is
   held: the weight rules are the user's. Returns the peers whose
   divergence it measured (bit p for peer slot p); *applied says whether
   the agent took the blended state (g->scratch). */
GS__PRIVATE uint32_t gs__ghost_blend(gs__ghost *g, gs__blend_net *bn, int *applied) {
    size_t n = g->n;
    double t_i, num_t = 0.0, den_t = 0.0;
    gs__pass ps;
    uint32_t seen = 0;
    int used;
    *applied = 0;
    gs_agent_get_state(g->agent, g->local, n);
    t_i = g->local[0];
    memset(&ps, 0, sizeof ps);
    ps.w0 = gs__ghost_weigh(g, bn, t_i, g->wq);
    used = ps.w0 < 0.0 ? 0 : gs__ghost_gather(g, bn, t_i, &num_t, &den_t);
    if (used > 0) {
        /* the band applies to the gap to the others (their weighted mean
           time), not to the correction, which is only part of it: otherwise
           two hosts would settle up to (1 + w0 / w) bands apart */
        g->scratch[0] = t_i;
        if (den_t > 0.0)
            g->scratch[0] = gs__time_bound(
                g, t_i, gs__time_correction(g, bn, num_t / den_t, num_t / (ps.w0 + den_t)));
        ps.fade = gs__offset_fade(g, g->scratch[0]);
        ps.finite = g->scratch[0] - g->scratch[0] == 0.0;
        ps.finite = gs__blend_pass(g, &ps);
        seen = gs__ghost_divergence(g);
        if (ps.finite && bn->skip_equal && memcmp(g->scratch, g->local, n * sizeof(double)) == 0) {
            g->stats.blends++;
            g->stats.snapshots_blended += (uint64_t)used;
            g->stats.last_correction = 0.0;
        } else if (ps.finite) {
            double c2 = (ps.corr2[0] + ps.corr2[1]) + (ps.corr2[2] + ps.corr2[3]);
            g->held_corr = n > 1 ? sqrt(c2 / (double)(n - 1)) : 0.0;
            if (bn->near > 0.0 && gs__ghost_near(g, bn->near)) {
                g->held_back = 1 + gs__ghost_held(g, &ps); /* see gs__sync_blend */
                g->stats.blends++;
                g->stats.snapshots_blended += (uint64_t)used;
                g->stats.last_correction = 0.0;
            } else if (gs__blend_apply(g, t_i)) {
                g->stats.blends++;
                g->stats.snapshots_blended += (uint64_t)used;
                g->stats.last_correction = g->held_corr;
                *applied = 1;
                g->agent->hold = gs__ghost_held(g, &ps);
                bn->over = 1;
            }
        }
    }
    gs__ghost_clear(g);
    return seen;
}

/* Any snapshot waiting? Read under the lock by the caller. */
GS__PRIVATE int gs__ghost_pending(const gs__ghost *g) {
    int p, k;
    for (p = 0; p < GS__MAX_PEERS; ++p)
        for (k = 0; g->gp[p].q && k < g->d.queue_size; ++k)
            if (g->gp[p].q[k].used) return 1;
    return 0;
}

/* ========================================================================
   >>sync
   The session clock: each peer's datagrams tell its timeline, the
   simulation time of its ghosts (published at the end of its advance, at
   its target) less their send time brought to our clock by the offset of
   the least-delayed round trip (>>net): est = session time - our clock.
   The session follows the timekeeper, the lowest host id among this host
   and the live peers whose timeline is within GS__SYNC_BAND of ours; a
   peer ahead by more for GS__SYNC_HOLD is a session this host joined late,
   and it takes that timeline at once; one behind by more is a late joiner
   or a host that cannot keep pace, and is not followed.
   The history: a ring of frames, each the world at the start of one
   advance, and a log of the inputs applied since (states set by hand
   between advances; blends, at the dispatch they came). Re-running a frame
   is the advance it recorded: the same follow, target and dispatches.
   ======================================================================== */
#define GS__SYNC_WINDOW 9   /* a peer's timeline: median of its last 9
                               datagrams (one delayed or mis-timed
                               datagram does not move it) */
#define GS__SYNC_BAND 0.1   /* s; timelines closer than this are one */
#define GS__SYNC_HOLD 0.25  /* s; a timeline ahead this long is joined (a
                               round trip or two: a peer's stepped clock
                               looks ahead until the net re-measures the
                               offset) */
#define GS__SYNC_SLEW 0.05  /* s/s; a follower moves its origin at most 5%
                               of the time advanced, so it never skips or
                               repeats a visible step */
#define GS__SYNC_LIVE 0.5   /* s of local clock: a peer heard this recently
                               counts */
#define GS__SYNC_STEP 0.05  /* s; a local clock that moved this much more or
                               less than the seconds advanced was stepped */
#define GS__SYNC_AGENT 11   /* doubles per agent before its state: steps,
                               t_offset, priority, 6 counters, sleeping
                               + 2 hold, rest */
#define GS__SYNC_LEAD 16    /* doubles in a gs__lead */
#define GS__SYNC_RIGID (13 + GS__SYNC_LEAD) /* a_own, 3 spare, target,
                               target_q, lead */
typedef char gs__lead_is_doubles[sizeof(gs__lead) == GS__SYNC_LEAD * sizeof(double) ? 1 : -1];
#define GS__LEAD_AHEAD 0.1  /* s; how far past its last snapshot a peer's
                               probe is carried (gs__sync_carry) */
#define GS__NEAR_SPAN 0.05  /* s; a replay within replay_tolerance is skipped
                               only if it re-runs at most this: a peer's
                               probe is carried on from its last snapshot
                               blended (a skipped one is not), at most
                               GS__LEAD_AHEAD, which two skips in a row and
                               a longer span would pass (then it stops
                               short: 7.4 frames' moves behind at 150 ms
                               each way against 4.9, test_replayprobe) */
#define GS__LEAD_GAIN 0.125 /* of a new spacing in the owner's period: the
                               paper scene's 16, 16, 18 ms give 16.7 +-0.2 */
#define GS__SYNC_NONE UINT64_MAX /* a log entry applied before the advance */
#define GS__SYNC_SPLIT (UINT64_MAX - 1) /* one applied at a blend time */
#define GS__LOG_HEAD 5      /* doubles before an input log entry's values */
#define GS__SPLITS 16       /* blend times an advance may take, and one
                               frame may hold: a set per peer and frame */
#define GS__RERUN_TEST 1    /* a re-run that checks (gs_world_sync_test) */
#define GS__RERUN_BLEND 2   /* a replay: blends, records the frames again */

typedef struct gs__sync_peer {
    uint32_t host;
    double est[GS__SYNC_WINDOW]; /* s; session time - our clock */
    int n, next;
    double heard;       /* s, our clock at the latest datagram */
    double ahead_since; /* s, our clock since it is ahead by a band */
} gs__sync_peer;

typedef struct gs__hframe {
    uint64_t seq;
    double seconds;      /* s; given to the advance */
    double target;       /* s; w->target at its start */
    double target_run;   /* s; the target its dispatches ran to */
    uint64_t dispatches; /* w->dispatches at its start */
    uint64_t log_at;     /* the log's head at its start */
    double split[GS__SPLITS]; /* s, ascending: the advance ran to each of
                                 these times first, and blended there */
    int nsplit;
} gs__hframe;

typedef struct gs__sync {
    gs_sync_desc d;
    int started;         /* the session clock has read its first time */
    double origin;       /* s; session time - local clock */
    double last_now;     /* s; the local clock at the last advance */
    double now;          /* s; the local clock as this advance began:
                            read before the replay, whose own duration is
                            not the session's time moving on */
    double boundary;     /* s; the frame boundary the last advance ran to
                            (sync.frame), session time */
    gs__sync_peer mail[GS__MAX_PEERS]; /* written by the net, under its lock */
    gs__sync_peer peer[GS__MAX_PEERS]; /* taken from mail at each advance */
    gs_sync_stats st;
    int cap;             /* frames in the ring, 0: no history */
    int agents;          /* the agent count the layout was made for */
    size_t stride;       /* doubles per frame */
    size_t room;         /* doubles per frame the ring has room for */
    size_t need;         /* doubles per frame the agents need */
    double *ring;        /* cap + 2 frames: the last two keep the present
                            and a re-run's end (gs_world_sync_test) */
    gs__hframe *frames;  /* cap */
    uint64_t seq;        /* frames recorded (the next one's number) */
    uint64_t valid_from; /* the first frame recorded with this layout */
    double *log;         /* the input log, a ring of doubles */
    uint64_t log_cap, log_head, log_tail; /* head and tail only grow */
    int joined;          /* the origin jumped to a session ahead */
    int replaying;       /* inside a re-run (GS__RERUN_*): the clock rests */
    double fresh[GS__SPLITS]; /* s, ascending: the times of the snapshots
                            taken at this advance (replay mode) */
    int nfresh;
    int at_start;        /* blending before the advance's first step */
    double at_split;     /* s; the blend time being blended at, NAN else */
    uint64_t frame_steps; /* agent steps of the last advance */
    uint64_t replay_seq; /* the frame being re-run */
    /* A replay first probes (see gs__sync_take): */
    int probing;         /* no blend of this re-run changed a state yet */
    int changed;         /* the last world blend changed an agent's state */
    int stopped;         /* the re-run stopped at a blend that changed none */
    int near;            /* ... that moved states within replay_tolerance */
    int near_skips;      /* replays stopped so, in a row */
    int near_ok;         /* the replay probed may stop so (GS__NEAR_SPAN) */
    double stopped_at;   /* s; that blend's time */
    int idle;            /* advances since snapshots were last taken
                            (replay_every) */
    int slow;            /* replay mode: this host is not keeping pace, so
                            snapshots blend at the present (gs__sync_pace) */
} gs__sync;

GS__PRIVATE gs_result gs__sync_advance(gs_world *w, double seconds, gs_advance_report *rep);
GS__PRIVATE void gs__sync_stepped(gs_agent *a);

/* With the world: the layer and the world's two hooks into it. */
GS__PRIVATE gs_result gs__sync_create(gs_world *w, const gs_sync_desc *d) {
    gs__sync *sy = (gs__sync *)gs__alloc(w, sizeof *sy);
    if (!sy) return GS_ERR_NO_MEMORY;
    memset(sy, 0, sizeof *sy);
    sy->d = *d;
    sy->st.timekeeper = w->host_id;
    sy->at_split = NAN;
    w->sync = sy;
    w->hooks.advance = gs__sync_advance;
    w->hooks.stepped = gs__sync_stepped;
    return GS_OK;
}

GS__PRIVATE void gs__sync_destroy(gs_world *w) {
    if (!w->sync) return;
    gs__free(w, w->sync->ring);
    gs__free(w, w->sync);
    w->sync = NULL;
}

GS__PRIVATE int gs__sync_session(const gs_world *w) {
    return w->sync->d.clock == GS_SYNC_CLOCK_SESSION;
}

GS__PRIVATE int gs__sync_replay(const gs_world *w) {
    return w->sync->d.mode == GS_SYNC_REPLAY;
}

/* ---- the history's layout: per agent GS__SYNC_AGENT doubles, what its
   kind keeps beyond its state, its state without the time; then the
   broad phase's two orders (agent indices) ---- */
GS__PRIVATE size_t gs__sync_extra(const gs_agent *a) {
    return gs__as_rigid(a) ? GS__SYNC_RIGID : 0;
}

GS__PRIVATE size_t gs__sync_agent_size(const gs_agent *a) {
    return GS__SYNC_AGENT + gs__sync_extra(a) + a->kind->state_size(a);
}

GS__PRIVATE double gs__u2d(uint64_t u) { double d; memcpy(&d, &u, sizeof d); return d; }
GS__PRIVATE uint64_t gs__d2u(double d) { uint64_t u; memcpy(&u, &d, sizeof u); return u; }

/* Allocates the ring for the agents there are now (create time only: an
   agent created or destroyed). The history starts again. */
/* The history's bytes at most: a world of 30000 bodies would want 285 MB
   for 16 frames; it keeps fewer frames, or none. */
#define GS__SYNC_MAX_BYTES ((size_t)64 << 20)

/* Makes room for frames of `stride` doubles (create time only: an agent
   created or destroyed). The history starts again. The ring grows to twice
   what it needs, so that creating n agents allocates O(log n) times. */
GS__PRIVATE gs_result gs__sync_reserve(gs_world *w, size_t stride) {
    gs__sync *sy = w->sync;
    size_t room, per, fixed, frames, bytes, n = (size_t)w->agent_count;
    int pass;
    char *block = NULL;
    sy->valid_from = sy->seq;
    sy->agents = w->agent_count;
    sy->stride = stride;
    if (sy->d.history_frames <= 0) return GS_OK;
    if (sy->ring && stride <= sy->room) return GS_OK;
    for (pass = 0; pass < 2 && !block; ++pass) {
        size_t most = GS__SYNC_MAX_BYTES / sizeof(double), heads = 2 * GS__LOG_HEAD * (2 * n + 8) + 8;
        /* first twice the need; past the byte cap, the most that two frames
           can have, so that the capped sizes too allocate once */
        room = pass == 0 && stride <= SIZE_MAX / 4 ? 2 * stride
               : most > 64 + 2 * heads ? (most - 64 - 2 * heads) / 8 : 0;
        if (room < stride || room > most) continue;
        /* a frame: its slot, two of its size in the log (a blend of every
           ghost once or twice a frame) and its entries' heads; and two
           slots more (the present and a re-run's end, gs_world_sync_test) */
        per = 3 * room + 2 * GS__LOG_HEAD * (2 * n + 8) + sizeof(gs__hframe) / sizeof(double) + 1;
        fixed = 2 * room + 64;
        if (fixed >= GS__SYNC_MAX_BYTES / sizeof(double)) continue;
        frames = (GS__SYNC_MAX_BYTES / sizeof(double) - fixed) / per;
        if (frames > (size_t)sy->d.history_frames) frames = (size_t)sy->d.history_frames;
        if (frames < 2) continue;
        sy->log_cap = 2 * (uint64_t)frames * (room + GS__LOG_HEAD * (2 * n + 8)) + 64;
        bytes = (frames + 2) * room * sizeof(double) + frames * sizeof(gs__hframe) +
                (size_t)sy->log_cap * sizeof(double);
        block = (char *)gs__alloc(w, bytes);
        if (!block) return gs__fail(w, GS_ERR_NO_MEMORY, "world history: out of memory");
        gs__free(w, sy->ring);
        sy->ring = (double *)block;
        sy->log = sy->ring + (frames + 2) * room;
        sy->frames = (gs__hframe *)(sy->log + sy->log_cap);
        sy->cap = (int)frames;
        sy->room = room;
        sy->log_head = sy->log_tail = 0;
    }
    if (!block) /* too big for any history: the world goes without (its sync
                   stats say 0 frames; replays blend at the present) */
        sy->agents = -1;
    return GS_OK;
}

/* The doubles of a frame for the agents there are now. */
GS__PRIVATE size_t gs__sync_need(const gs_world *w) {
    size_t stride = 2 * (size_t)w->nbodies, part;
    int i;
    for (i = 0; i < w->agent_count; ++i) {
        part = gs__sync_agent_size(w->agents[i]);
        if (part > SIZE_MAX / 2 - stride) return SIZE_MAX / 2;
        stride += part;
    }
    return stride;
}

GS__PRIVATE gs_result gs__sync_relayout(gs_world *w) {
    w->sync->need = gs__sync_need(w);
    return gs__sync_reserve(w, w->sync->need);
}

/* A new agent: its record and, for a body, its places in the broad phase's
   two orders (counted on, not recounted: 30000 bodies in a row). */
GS__PRIVATE gs_result gs__sync_added(gs_world *w, gs_agent *a, gs_agent **out) {
    gs__sync *sy = w->sync;
    size_t part = gs__sync_agent_size(a) + (gs__as_rigid(a) ? 2 : 0);
    gs_result r;
    sy->need = part > SIZE_MAX / 2 - sy->need ? SIZE_MAX / 2 : sy->need + part;
    r = gs__sync_reserve(w, sy->need);
    if (r != GS_OK) {
        gs_agent_destroy(a);
        gs__fail(w, r, "agent create: out of memory for the world history");
        return r;
    }
    *out = a;
    return GS_OK;
}

GS__PRIVATE double *gs__sync_slot(const gs__sync *sy, uint64_t seq) {
    return sy->ring + (size_t)(seq % (uint64_t)sy->cap) * sy->stride;
}

/* One agent into p (what gs__sync_agent_size counts). */
GS__PRIVATE double *gs__sync_save_agent(const gs_agent *a, double *p) {
    const gs__rigid *r = gs__as_rigid(a);
    const uint64_t *st = &a->stats.steps;
    int i;
    p[0] = gs__u2d(a->steps);
    p[1] = a->t_offset;
    p[2] = (double)a->priority;
    for (i = 0; i < 6; ++i) p[3 + i] = gs__u2d(st[i]);
    p[9] = (double)(a->sleeping + 2 * a->hold); /* a held copy replays as held */
    p[10] = a->rest;
    p += GS__SYNC_AGENT;
    if (r) {
        p[0] = r->a_own.x; p[1] = r->a_own.y; p[2] = r->a_own.z;
        p[3] = p[4] = p[5] = 0.0; /* room kept: the layout stays 13 */
        p[6] = r->target.x; p[7] = r->target.y; p[8] = r->target.z;
        p[9] = r->target_q.x; p[10] = r->target_q.y; p[11] = r->target_q.z;
        p[12] = r->target_q.w;
        memcpy(p + 13, &r->lead, sizeof r->lead);
        p += GS__SYNC_RIGID;
    }
    a->kind->get_state(a, p);
    return p + a->kind->state_size(a);
}

/* The agent back from p, exactly: its kind's set_state, then what that
   derives (a rigid body's own acceleration of its last step, a probe's
   target) as it was. Returns the end of its record. */
GS__PRIVATE const double *gs__sync_load_agent(gs_agent *a, const double *p) {
    gs__rigid *r = gs__as_rigid(a);
    uint64_t *st = &a->stats.steps;
    const double *e = p + GS__SYNC_AGENT + gs__sync_extra(a);
    int i;
    a->kind->set_state(a, e); /* a state it gave: its own set_state takes it */
    a->steps = gs__d2u(p[0]);
    a->t_offset = p[1];
    a->priority = (int)p[2];
    for (i = 0; i < 6; ++i) st[i] = gs__d2u(p[3 + i]);
    a->sleeping = ((int)p[9] & 1) != 0;
    a->hold = ((int)p[9] & 2) != 0;
    a->rest = p[10];
    if (r) {
        const double *x = p + GS__SYNC_AGENT;
        r->a_own = gs__v3(x[0], x[1], x[2]);
        r->target = gs__v3(x[6], x[7], x[8]);
        r->target_q = gs__quat(x[9], x[10], x[11], x[12]);
        memcpy(&r->lead, x + 13, sizeof r->lead);
        r->q = gs__quat(e[3], e[4], e[5], e[6]); /* set_state renormalizes */
        gs__sap_update(r);
    }
    return e + a->kind->state_size(a);
}

GS__PRIVATE void gs__sync_save(const gs_world *w, double *p) {
    int i;
    for (i = 0; i < w->agent_count; ++i) p = gs__sync_save_agent(w->agents[i], p);
    for (i = 0; i < w->nbodies; ++i) {
        p[i] = (double)w->bodies[i]->base.index;
        p[w->nbodies + i] = (double)w->near[i]->base.index;
    }
}

/* The broad phase's orders decide the order contacts are summed in, and
   an insertion sort keeps ties as they were: they come back too. */
GS__PRIVATE void gs__sync_load(gs_world *w, const double *p) {
    int i;
    for (i = 0; i < w->agent_count; ++i) p = gs__sync_load_agent(w->agents[i], p);
    for (i = 0; i < w->nbodies; ++i) {
        gs__rigid *b = (gs__rigid *)w->agents[(int)p[i]];
        gs__rigid *n = (gs__rigid *)w->agents[(int)p[w->nbodies + i]];
        w->bodies[i] = b;
        b->sap = i;
        w->near[i] = n;
        n->near = i;
    }
    /* the records and the grid follow the bodies' indices */
    for (i = 0; i < w->nbodies; ++i) gs__grec_load(w, w->bodies[i]);
    if (w->nbodies) gs__grid_rebuild(w);
}

/* ---- the input log: entries [frame, dispatch, agent, n, at, n values]:
   applied after that dispatch, before the frame (GS__SYNC_NONE), or at
   blend time `at` of the frame (GS__SYNC_SPLIT: a replay's blends, which
   a later replay's new blend times would move off their dispatch) ---- */
GS__PRIVATE double gs__log_get(const gs__sync *sy, uint64_t at) {
    return sy->log[at % sy->log_cap];
}

/* Drops the oldest entry; the frames that needed it can no longer re-run. */
GS__PRIVATE void gs__log_drop(gs__sync *sy) {
    sy->log_tail += GS__LOG_HEAD + (uint64_t)gs__log_get(sy, sy->log_tail + 3);
}

GS__PRIVATE void gs__log_put(gs__sync *sy, uint64_t frame, uint64_t dispatch, double at,
                             int agent, const double *v, size_t n) {
    uint64_t need = GS__LOG_HEAD + (uint64_t)n, i;
    if (need > sy->log_cap) { /* too big for any re-run: none is left */
        sy->log_tail = sy->log_head;
        sy->valid_from = sy->seq + 1;
        return;
    }
    while (sy->log_head + need - sy->log_tail > sy->log_cap) gs__log_drop(sy);
    sy->log[sy->log_head % sy->log_cap] = gs__u2d(frame);
    sy->log[(sy->log_head + 1) % sy->log_cap] = gs__u2d(dispatch);
    sy->log[(sy->log_head + 2) % sy->log_cap] = (double)agent;
    sy->log[(sy->log_head + 3) % sy->log_cap] = (double)n;
    sy->log[(sy->log_head + 4) % sy->log_cap] = at;
    for (i = 0; i < n; ++i) sy->log[(sy->log_head + GS__LOG_HEAD + i) % sy->log_cap] = v[i];
    sy->log_head += need;
}

/* A state set by hand between advances: an input of the next frame. */
GS__PRIVATE void gs__sync_log(gs_agent *a, const double *in) {
    gs__sync *sy = a->world->sync;
    if (!sy->cap || a->world->busy || sy->replaying) return;
    gs__log_put(sy, sy->seq, GS__SYNC_NONE, 0.0, a->index, in, gs_agent_state_size(a));
}

/* An adopt_sent publish, at the dispatch it followed (or the advance's
   end, the session clock's: the re-run's last dispatch, nothing stepping
   between): logged without values, since a re-run adopts its own state
   decoded (a function of the state: the same bits where the re-run is the
   run; a replay's corrected state is then what the next publish sends). */
GS__PRIVATE void gs__sync_log_adopt(gs_agent *a) {
    gs__sync *sy = a->world->sync;
    if (!sy->cap || !a->world->busy || sy->replaying || sy->seq == 0) return;
    gs__log_put(sy, sy->seq - 1, a->world->dispatches, 0.0, a->index, NULL, 0);
}

/* A blend, at the dispatch it followed: an input of the frame running
   (in a replay, of the frame re-run). */
GS__PRIVATE void gs__sync_log_blend(gs_agent *a, const double *in) {
    gs__sync *sy = a->world->sync;
    uint64_t frame = sy->replaying ? sy->replay_seq : sy->at_start ? sy->seq : sy->seq - 1;
    if (!sy->cap || !a->world->busy || sy->replaying == GS__RERUN_TEST) return;
    if (!sy->at_start && sy->seq == 0) return;
    gs__log_put(sy, frame,
                sy->at_start ? GS__SYNC_NONE : sy->at_split == sy->at_split ? GS__SYNC_SPLIT
                                                                           : a->world->dispatches,
                sy->at_split == sy->at_split ? sy->at_split : 0.0, a->index, in,
                gs_agent_state_size(a));
}

/* A re-run: applies the entries of frame `frame` logged at `dispatch`,
   in the order they were logged. A replay logs blends of frames past, so
   the log is searched, not read in order (it holds a few dozen entries). */
GS__PRIVATE void gs__sync_apply_log(gs_world *w, uint64_t frame, uint64_t dispatch, double when) {
    gs__sync *sy = w->sync;
    uint64_t at, v;
    for (at = sy->log_tail; at < sy->log_head; at += GS__LOG_HEAD + (uint64_t)gs__log_get(sy, at + 3)) {
        uint64_t f = gs__d2u(gs__log_get(sy, at)), d = gs__d2u(gs__log_get(sy, at + 1));
        int ai = (int)gs__log_get(sy, at + 2);
        size_t n = (size_t)gs__log_get(sy, at + 3), i;
        gs_agent *a;
        if (f != frame || d != dispatch || ai < 0 || ai >= w->agent_count) continue;
        if (d == GS__SYNC_SPLIT && gs__log_get(sy, at + 4) != when) continue;
        a = w->agents[ai];
        if (n == 0 && a->ghost) { /* an adopt_sent publish */
            gs__ghost *g = gs__ghost_of(a);
            double *s = g->local;
            gs_agent_get_state(a, s, g->n);
            gs__ghost_adopt(g, s, w->net, 0);
            continue;
        }
        if (n != gs_agent_state_size(a)) continue;
        /* an entry that wraps around the ring is put together in the
           last slot of the ring (a re-run's end, free until then) */
        v = at + GS__LOG_HEAD;
        if (v % sy->log_cap + n <= sy->log_cap) {
            if (gs__agent_put_state(a, sy->log + v % sy->log_cap) == GS_OK)
                gs__sync_sighted(a);
        } else {
            double *buf = sy->ring + ((size_t)sy->cap + 1) * sy->stride;
            for (i = 0; i < n; ++i) buf[i] = gs__log_get(sy, v + i);
            if (gs__agent_put_state(a, buf) == GS_OK)
                gs__sync_sighted(a);
        }
    }
}

/* Is frame seq still re-runnable (in the ring, its inputs in the log)? */
GS__PRIVATE int gs__sync_have(const gs__sync *sy, uint64_t seq) {
    const gs__hframe *f;
    if (!sy->cap || seq >= sy->seq || seq < sy->valid_from || sy->seq - seq > (uint64_t)sy->cap)
        return 0;
    f = &sy->frames[seq % (uint64_t)sy->cap];
    return f->seq == seq && f->log_at >= sy->log_tail;
}

/* ---- the blend: every ghost of the world at once. Blended one agent at
   a time, as each one steps, the snapshots of one remote moment would land
   at different moments here: a sphere copied onto a cloth not copied yet
   sinks a millimetre into it and is thrown (at metres a second), and the
   cloth it dents throws the next copy too. ---- */

/* Under the net's lock: each live agent's ghost takes what waits for it
   (gs__ghost_take), and bn the peers' host ids. Returns 1 if any took. */
GS__PRIVATE int gs__sync_take_all(gs_world *w, double t, int keep_waiting, gs__blend_net *bn) {
    int i, p, any = 0;
    gs__lock(w->net);
    for (p = 0; p < GS__MAX_PEERS; ++p) bn->host[p] = w->net->peers[p].host;
    for (i = 0; i < w->agent_count; ++i) {
        gs__ghost *g = gs__ghost_of(w->agents[i]);
        if (!g) continue;
        g->ntaken = w->agents[i]->failed ? 0 : gs__ghost_take(g, t, keep_waiting);
        any |= g->ntaken > 0;
    }
    gs__unlock(w->net);
    return any;
}

/* Under the lock again: what the blends measured, for gs_net_peer_stats.
   A peer's divergence is the largest over the world's objects, taken once
   per peer after every ghost has blended (per snapshot, a world blend
   would be O(agents^2)). */
GS__PRIVATE void gs__sync_give_back(gs_world *w, const gs__blend_net *bn, uint32_t seen) {
    int p;
    gs__lock(w->net);
    for (p = 0; p < GS__MAX_PEERS; ++p) {
        if (bn->gapped & ((uint32_t)1 << p)) w->net->peers[p].st.gap = bn->gap[p];
        if (seen & ((uint32_t)1 << p)) w->net->peers[p].st.divergence = gs__peer_divergence(w, p);
    }
    gs__unlock(w->net);
}

/* Every ghost blends the snapshots waiting for it whose time is at most t
   (see gs__ghost_take): taken under the net's lock, blended with it
   released, so that the weight rules run with no lock held; each blend
   applied is an input of the history.
   The world's clock follows its agents back too: when the blends took
   most of them back (a host in step that copies its lead, ahead of it by
   more than the time band), the clock goes back with them, the least of
   their moves. Otherwise they would step on to the clock again from the
   states they took, and the next blend take them back again (or not, as
   each object's snapshot says), all the time: objects a few tens of ms
   apart in time push each other (a sphere resting on the cloth is kicked
   off it). */
GS__PRIVATE void gs__sync_blend(gs_world *w, double t, int keep_waiting) {
    gs__sync *sy = w->sync;
    gs__blend_net bn;
    uint32_t seen = 0;
    int i, back = 0, applied;
    double pull = HUGE_VAL;
    if (!w->net) return;
    memset(&bn, 0, sizeof bn);
    bn.fixed_time = gs__sync_session(w) || gs__sync_replay(w);
    bn.skip_equal = gs__sync_replay(w);
    if (sy->probing && sy->near_ok && sy->replaying == GS__RERUN_BLEND &&
        sy->near_skips < GS_REPLAY_NEAR_SKIPS)
        bn.near = sy->d.replay_tolerance;
    if (!gs__sync_take_all(w, t, keep_waiting, &bn)) return;
    bn.lead = gs__world_lead(w, &bn);
    for (i = 0; i < w->agent_count; ++i) {
        gs__ghost *g = gs__ghost_of(w->agents[i]);
        if (!g || g->ntaken == 0) continue;
        g->pulled = 0.0;
        g->held_back = 0;
        seen |= gs__ghost_blend(g, &bn, &applied);
        if (applied) { /* in replay mode only a state that differs is set */
            sy->changed = 1;
            gs__sync_log_blend(g->agent, g->scratch);
        }
        if (g->pulled > 0.0) {
            back++;
            pull = fmin(pull, g->pulled);
        }
    }
    /* States held back within the tolerance: all of them stay so if every
       ghost's did (the replay then stops at this blend, as for one that
       changed no bit), else they are applied too, in the agents' order:
       a set is blended whole or not at all. */
    for (i = 0; i < w->agent_count; ++i) {
        gs__ghost *g = gs__ghost_of(w->agents[i]);
        if (!g || !g->held_back) continue;
        if (bn.over && gs__blend_apply(g, g->local[0])) {
            g->stats.last_correction = g->held_corr;
            g->agent->hold = g->held_back == 2;
            sy->changed = 1;
            gs__sync_log_blend(g->agent, g->scratch);
            if (g->pulled > 0.0) {
                back++;
                pull = fmin(pull, g->pulled);
            }
        } else if (!bn.over && !sy->near) {
            sy->near = 1;
            sy->near_skips++;
        }
        g->held_back = 0;
    }
    if (2 * back > w->agent_count && pull < HUGE_VAL)
        w->target = w->target - pull > 0.0 ? w->target - pull : 0.0;
    gs__sync_give_back(w, &bn, seen);
}

/* Present mode, after a ghost's agent stepped (a sleeper's: at each run
   of the dispatches): it publishes, and if a snapshot waits for it, every
   ghost of the world blends what waits for it. */
GS__PRIVATE void gs__sync_ghost_stepped(gs_agent *a) {
    gs__ghost *g = gs__ghost_of(a);
    gs_net *net = a->world->net;
    int pending;
    /* on the session clock, ghosts publish at the end of the advance (all
       at the target time: the send time then tells the session's time) */
    if (!gs__sync_session(a->world)) gs__ghost_publish(g, net);
    if (!net) return;
    gs__lock(net);
    g->t_local = gs__agent_time(a);
    pending = gs__ghost_pending(g);
    gs__unlock(net);
    if (pending) gs__sync_blend(a->world, HUGE_VAL, 0);
}

/* ---- the hooks the world calls ---- */

GS__PRIVATE void gs__sync_take(gs_world *w);

/* At the start of an advance: the world as it is (inputs by hand applied)
   becomes a frame of the history; in replay mode, after the snapshots
   waiting were blended into the past (gs__sync_take). */
GS__PRIVATE void gs__sync_begin(gs_world *w, double seconds) {
    gs__sync *sy = w->sync;
    gs__hframe *f;
    int i;
    if (!sy->cap || sy->replaying) return;
    if (sy->agents != w->agent_count) { sy->valid_from = sy->seq + 1; sy->seq++; return; }
    sy->nfresh = 0;
    /* replay_every: the snapshots wait until the k-th advance since the
       last that took some */
    if (sy->d.mode == GS_SYNC_REPLAY && w->net && ++sy->idle >= sy->d.replay_every) {
        gs__sync_take(w);
        if (sy->nfresh > 0) sy->idle = 0;
    }
    f = &sy->frames[sy->seq % (uint64_t)sy->cap];
    f->nsplit = 0;
    for (i = 0; i < sy->nfresh; ++i) /* due in this advance: it runs to them first */
        if (sy->fresh[i] >= w->target) f->split[f->nsplit++] = sy->fresh[i];
    f->seq = sy->seq;
    f->seconds = seconds;
    f->target = w->target;
    f->target_run = w->target + seconds;
    f->dispatches = w->dispatches;
    f->log_at = sy->log_head;
    gs__sync_save(w, gs__sync_slot(sy, sy->seq));
    sy->seq++;
}

/* The median of a peer's recent timeline estimates. */
GS__PRIVATE double gs__sync_median(const gs__sync_peer *pe) {
    double v[GS__SYNC_WINDOW], t;
    int i, j, n = pe->n;
    memcpy(v, pe->est, (size_t)n * sizeof *v);
    for (i = 1; i < n; ++i)
        for (j = i; j > 0 && v[j - 1] > v[j]; --j) { t = v[j]; v[j] = v[j - 1]; v[j - 1] = t; }
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* A peer's timeline: the median of its recent estimates; on a frame grid
   the largest, the least delayed: there every state leaves at or after the
   instant it stands for (gs__ghost_due holds it until then), so a delay on
   the way (a sender's loop or its send thread late on a loaded machine)
   only ever lowers an estimate, as a delay only ever lengthens a round
   trip, and the least delayed is the truest (the clock offset's rule). */
GS__PRIVATE double gs__sync_estimate(const gs__sync *sy, const gs__sync_peer *pe) {
    double e;
    int i;
    if (!(sy->d.frame > 0.0)) return gs__sync_median(pe);
    e = pe->est[0];
    for (i = 1; i < pe->n; ++i) e = fmax(e, pe->est[i]);
    return e;
}

/* Moves the origin toward the timekeeper's timeline, or to a session ahead
   that this host joined late. */
GS__PRIVATE void gs__sync_follow(gs_world *w, double now, double seconds) {
    gs__sync *sy = w->sync;
    double best = sy->origin, ahead = -HUGE_VAL, step;
    uint32_t tk = w->host_id;
    int p;
    if (w->net) {
        gs__lock(w->net);
        memcpy(sy->peer, sy->mail, sizeof sy->peer);
        gs__unlock(w->net);
    }
    for (p = 0; p < GS__MAX_PEERS; ++p) {
        gs__sync_peer *pe = &sy->peer[p], *m = &sy->mail[p];
        double e;
        if (pe->n == 0 || !(now - pe->heard <= GS__SYNC_LIVE)) continue;
        e = gs__sync_estimate(sy, pe);
        if (e > sy->origin + GS__SYNC_BAND) {
            if (!(m->ahead_since <= now)) m->ahead_since = now;
            if (now - m->ahead_since >= GS__SYNC_HOLD && e > ahead) ahead = e;
        } else {
            m->ahead_since = HUGE_VAL;
        }
        if (fabs(e - sy->origin) <= GS__SYNC_BAND && pe->host < tk) {
            tk = pe->host;
            best = e;
        }
    }
    if (ahead > -HUGE_VAL) {
        sy->origin = ahead;
        sy->st.joins++;
        sy->joined = 1;
        for (p = 0; p < GS__MAX_PEERS; ++p) sy->mail[p].ahead_since = HUGE_VAL;
        return;
    }
    sy->st.timekeeper = tk;
    step = GS__SYNC_SLEW * seconds;
    sy->origin += fmax(-step, fmin(step, best - sy->origin));
}

/* After a join: an agent left more than GS__FOLLOW_STEPS of its steps
   behind takes the session's time (as gs__world_follow does), rather than
   buying a step per dt of catching up; blends then bring its state. */
GS__PRIVATE void gs__sync_catch_up(gs_world *w) {
    int i;
    w->sync->joined = 0;
    for (i = 0; i < w->agent_count; ++i) {
        gs_agent *a = w->agents[i];
        double lag = w->target - gs__agent_time(a);
        /* with a frame grid, by whole steps: the agent's times stay on the
           grid of its dt from the session's time 0, where the other
           hosts' agents of that dt step */
        if (lag > GS__FOLLOW_STEPS * a->dt)
            a->t_offset += w->sync->d.frame > 0.0 ? floor(lag / a->dt + 0.5) * a->dt : lag;
    }
}

/* After follow and target += seconds: on the session clock the target is
   the session's time now. It never goes back (the agents are there); a
   target that blending took ahead (every agent moved to a later session
   time) takes the clock with it. */
GS__PRIVATE void gs__sync_target(gs_world *w, double seconds, double before) {
    gs__sync *sy = w->sync;
    double now, want;
    if (sy->replaying) {
        w->target = sy->frames[sy->replay_seq % (uint64_t)sy->cap].target_run;
        return;
    }
    if (gs__sync_session(w)) {
        now = sy->now;
        if (gs__finite(now)) {
            if (!sy->started) {
                sy->started = 1;
                sy->origin = w->target - now;
            } else if (fabs((now - sy->last_now) - seconds) > GS__SYNC_STEP) {
                sy->origin -= (now - sy->last_now) - seconds;
                sy->st.clock_steps++;
            }
            sy->last_now = now;
            gs__sync_follow(w, now, seconds);
            want = now + sy->origin;
            if (sy->d.frame > 0.0) {
                /* to the nearest boundary, not down: a host that wakes a
                   little before one (its offset error, a timer early) runs
                   to it as the host that wakes a little after it does */
                want = floor(want / sy->d.frame + 0.5) * sy->d.frame;
                sy->boundary = want;
            }
            if (w->target > want + GS__SYNC_BAND) {
                sy->origin = w->target - now;
                sy->st.joins++;
            } else {
                w->target = fmax(want, before);
            }
            if (sy->joined) gs__sync_catch_up(w);
            sy->st.origin = sy->origin;
        }
    }
    if (sy->cap && sy->seq > 0 && sy->agents == w->agent_count)
        sy->frames[(sy->seq - 1) % (uint64_t)sy->cap].target_run = w->target;
}

/* Replay mode: a peer's probe, set from its owner's snapshot, tells how
   the owner's application moves it (gs__sync_carry). The owner sets its
   target once a frame and the probe goes there in a step, so that its
   snapshots, taken at the ends of the owner's frames, hold each frame's
   target: the path is sampled once a frame, and read per frame, not per
   second. A snapshot's time is the probe's step nearest the frame's end,
   so the spacing of two is a step more in one frame than in the next
   (the paper scene: 16 or 18 ms for 16.7): the period is smoothed over
   the spacings, and the frame's end is carried on by it from the last
   one, kept within the half step about the snapshot's time that it must
   lie in (gs__agent_done). With the last spacing for the period and the
   snapshot's time for the frame's end, the copy took the owner's next
   input a step early or late in one frame of three (a frame's move of
   the path off, 8 mm at 0.5 m/s). Frames between snapshots are counted
   by the period: a snapshot lost makes one interval two frames. */
GS__PRIVATE void gs__sync_sighted(gs_agent *a) {
    gs__rigid *r = gs__as_rigid(a);
    gs__lead *l;
    double t, k, f, per;
    gs_vec3 d;
    if (!r || !r->probe || r->owner == a->world->host_id || a->world->sync->d.mode != GS_SYNC_REPLAY)
        return;
    l = &r->lead;
    t = gs__agent_time(a);
    if (l->n > 0.0 && !(t > l->t)) return; /* an older one: the path stands */
    f = t;
    if (l->n > 0.0) {
        k = l->n > 1.0 ? fmax(1.0, floor((t - l->t) / l->per + 0.5)) : 1.0;
        d = gs__scale(gs__sub(r->x, l->x), 1.0 / k);
        l->dd = l->n > 1.0 ? gs__scale(gs__sub(d, l->d), 2.0 / (k + l->k)) : gs__v3(0.0, 0.0, 0.0);
        l->d = d;
        per = (t - l->t) / k;
        /* smoothed while the spacings agree within the step they differ
           by (and half a step of room: the first period is one spacing);
           a spacing off by more is a change of the owner's pace (or a
           frame counted wrong across a loss), taken as it is: smoothed
           through those too, the harsh link's p95 went 7.4 -> 12 mm
           (bench/sync_modes) */
        l->per = l->n > 1.0 && fabs(per - l->per) <= 1.5 * a->dt ? l->per + GS__LEAD_GAIN * (per - l->per) : per;
        l->k = k;
        f = fmin(fmax(l->f + k * l->per, t - 0.5 * a->dt), t + 0.5 * a->dt);
    }
    l->n = l->n < 3.0 ? l->n + 1.0 : 3.0;
    l->x = r->x;
    l->t = t;
    l->f = f;
    l->next = f;
    l->j = 0.0;
}

/* Replay mode, after a peer's probe stepped (and after a blend): the input
   its owner gives it next. At each of the owner's frames (a period on from
   its last snapshot) the target is where the path its snapshots trace
   puts the next frame's end: quadratic in frames through the last
   snapshot, carried at most GS__LEAD_AHEAD past it, then held (an outage
   does not send it away). Carried along its velocity instead, it lagged
   the owner's by a frame of the path (3.2 mm p95 on a 1 ms link while it
   pushes, against 0.2 mm: bench/sync_modes); held still, it would stop
   while the cloth it pushes, copied with the probe's speed, runs on into
   it for the latency the replay covers, and the contact would throw the
   sphere lying there. Before two snapshots it goes on along its velocity. */
GS__PRIVATE void gs__sync_carry(gs_agent *a) {
    gs__rigid *r = gs__as_rigid(a);
    gs__lead *l;
    gs_vec3 to;
    double j;
    if (!r || !r->probe || r->owner == a->world->host_id) return;
    l = &r->lead;
    if (!(l->n > 1.0 && l->per > 0.0)) {
        r->target = gs__madd(r->x, r->v, a->dt);
        return;
    }
    if (gs__agent_time(a) < l->next - 0.5 * a->dt) return; /* on to the target */
    l->next += l->per;
    if (l->j * l->per >= GS__LEAD_AHEAD) return;
    l->j += 1.0;
    j = l->j;
    to = gs__madd(gs__madd(l->x, l->d, j), l->dd, 0.5 * j * (j + 1.0));
    if (gs__in_range3(to)) r->target = to;
}

/* The world's hook after a step (a dispatch, gs_agent_step): in a re-run
   the logged inputs of this dispatch; else the agent's ghost publishes and
   (present mode) blends. */
GS__PRIVATE void gs__sync_stepped(gs_agent *a) {
    gs_world *w = a->world;
    gs__sync *sy = w->sync;
    if (sy->replaying) gs__sync_apply_log(w, sy->replay_seq, w->dispatches, 0.0);
    if (sy->d.mode == GS_SYNC_REPLAY) gs__sync_carry(a);
    if (sy->replaying == GS__RERUN_TEST) return;
    if (sy->d.mode != GS_SYNC_REPLAY) {
        if (a->ghost) gs__sync_ghost_stepped(a);
        return;
    }
    if (a->ghost && !sy->replaying && !gs__sync_session(w)) gs__ghost_publish(gs__ghost_of(a), w->net);
}

/* The sleepers' ghosts at each run of the dispatches (they take no steps
   to publish and blend after): as after a step, but no logged inputs are
   theirs (they are applied by dispatch), and in replay mode the session
   clock's publish at the end of the advance covers them. */
GS__PRIVATE void gs__sync_sleepers(gs_world *w) {
    gs__sync *sy = w->sync;
    int i;
    if (sy->replaying || sy->d.mode == GS_SYNC_REPLAY) return;
    for (i = 0; i < w->agent_count; ++i)
        if (w->agents[i]->sleeping && w->agents[i]->ghost) gs__sync_ghost_stepped(w->agents[i]);
}

/* One run of the world's dispatches (gs__world_run), with the sleepers'
   ghosts between its setup and its loop. */
GS__PRIVATE gs_result gs__sync_run_part(gs_world *w, double budget, gs_advance_report *rep) {
    double start = gs__world_run_setup(w, budget);
    gs__sync_sleepers(w);
    return gs__world_run_loop(w, budget, start, rep);
}

/* At the end of an advance: on the session clock every ghost due
   publishes its state at the target; the lag says whether this host
   keeps pace. */
GS__PRIVATE void gs__sync_end(gs_world *w, double seconds, const gs_advance_report *rep) {
    gs__sync *sy = w->sync;
    int i;
    if (sy->replaying) return;
    if (gs__sync_session(w))
        for (i = 0; i < w->agent_count; ++i) {
            gs__ghost *g = gs__ghost_of(w->agents[i]);
            if (g && gs__agent_time(g->agent) + 0.5 * seconds >= g->next_publish) {
                /* on a frame grid the target is a boundary, perhaps still
                   ahead (an application that computes a frame early): the
                   datagram leaves at it, not before, as the peers read
                   this timeline from its time less its send time (the
                   grid is fixed at creation: without one stands_at stays
                   0 and the net's lock is not taken for it) */
                double next = g->next_publish + 1.0 / g->d.send_rate;
                if (sy->d.frame > 0.0) {
                    gs__lock(w->net);
                    g->stands_at = w->target - sy->origin;
                    gs__unlock(w->net);
                }
                gs__ghost_publish_now(g, w->net);
                /* on a frame grid the next one is due a period after this
                   one was, not after the boundary it went at: rounded to
                   the nearest boundary, a 60 Hz ghost on a 5 ms grid then
                   publishes 15 and 20 ms apart, 60 a second (from the
                   boundary, always 15: 67 a second) */
                if (sy->d.frame > 0.0 && next > g->next_publish - 1.0 / g->d.send_rate)
                    g->next_publish = next; /* (still ahead: not after a pause) */
            }
        }
    sy->frame_steps = rep->steps;
    sy->st.session_time = w->target;
    sy->st.lag = w->agent_count ? w->target - rep->t_min : 0.0;
    if (sy->st.lag > sy->st.lag_max) sy->st.lag_max = sy->st.lag;
    if (sy->st.lag > w->tolerance) sy->st.behind++;
}

/* From the net, under its lock: one accepted datagram tells the peer's
   timeline, the mean over its snapshots' times less its send time on our
   clock (clock_offset: ours minus theirs). On a frame grid a snapshot
   stands for its frame's boundary, the session time its datagram left at
   (gs__sync_end), while its time is its agent's last step, up to half a
   step either side of it: taken as is, the 2 ms cloth on a 5 ms grid
   would make the timeline 1 ms early or late by the frame's parity, and
   the least delayed estimate (gs__sync_estimate) would keep the early
   one while one is in the window and drop back when none is, moving a
   follower's frames 1 ms to and fro against the timekeeper's. So the time
   counts as its nearest boundary (an agent within half a frame of its
   target, as every agent whose step is at most a frame is). */
GS__PRIVATE void gs__sync_heard(gs_net *net, int p, const gs_wire_view *v, double now) {
    const gs__peer *pe = &net->peers[p];
    gs__sync_peer *m = &net->world->sync->mail[p];
    double sum = 0.0, send = v->header.send_time + pe->clock_offset;
    double f = net->world->sync->d.frame;
    int i, n = 0;
    if (!pe->clock_known) return;
    for (i = 0; i < v->chunk_count; ++i)
        if (v->chunks[i].index == 0 && !(v->chunks[i].flags & GS_WIRE_CHUNK_ACK)) {
            double t = v->chunks[i].time; /* (an acknowledgement has no time) */
            if (f > 0.0) t = floor(t / f + 0.5) * f;
            sum += t - send;
            n++;
        }
    if (n == 0 || !gs__finite(sum)) return;
    if (m->host != pe->host) {
        memset(m, 0, sizeof *m);
        m->host = pe->host;
        m->ahead_since = HUGE_VAL;
    }
    m->est[m->next] = sum / n;
    m->next = (m->next + 1) % GS__SYNC_WINDOW;
    if (m->n < GS__SYNC_WINDOW) m->n++;
    m->heard = now;
}

GS__PRIVATE int gs__sync_is_fresh(const gs__sync *sy, double t) {
    int i;
    for (i = 0; i < sy->nfresh; ++i)
        if (sy->fresh[i] == t) return 1;
    return 0;
}

/* Every ghost blends the snapshots waiting whose time is at most t (the
   later ones, and those still waiting for chunks, stay in the queues):
   each snapshot at its own time.
   Blended together, a sphere from one frame would land on the cloth of
   the frame before and be thrown. */
GS__PRIVATE void gs__sync_blend_to(gs_world *w, double t) {
    int i;
    w->sync->changed = 0;
    w->sync->at_split = t;
    gs__sync_blend(w, t, 1);
    w->sync->at_split = NAN;
    for (i = 0; i < w->agent_count; ++i) gs__sync_carry(w->agents[i]);
}

/* A frame's dispatches, to its target: first to each of its blend times,
   where every ghost blends what waits for it (the fresh time), or where a
   re-run applies what the log says was blended there. A budget (s, 0 =
   none) covers them all. */
GS__PRIVATE gs_result gs__sync_split_run(gs_world *w, gs__hframe *f, double budget,
                                         gs_advance_report *rep) {
    gs__sync *sy = w->sync;
    double end = w->target, start = budget > 0.0 ? w->clock(w->clock_user) : 0.0, left = 0.0;
    gs_result r, first = GS_OK;
    int i, kept = 0;
    for (i = 0; f && i < f->nsplit; ++i) {
        if (!(f->split[i] < end)) continue; /* past this frame: not run to */
        f->split[kept++] = f->split[i];
        if (budget > 0.0) {
            left = budget - (w->clock(w->clock_user) - start);
            if (left <= 0.0) continue;
        }
        w->target = f->split[i];
        r = gs__sync_run_part(w, left, rep);
        if (first == GS_OK) first = r;
        if (sy->replaying) {
            int k;
            gs__sync_apply_log(w, sy->replay_seq, GS__SYNC_SPLIT, f->split[i]);
            /* as the blend there did (gs__sync_blend_to): a peer's probe
               takes the input its new path gives at once; left to its next
               step, a re-run of a frame an earlier replay blended into was
               not the run (gs_world_sync_test, tests/test_replaynear.c) */
            if (sy->replaying == GS__RERUN_TEST || !gs__sync_is_fresh(sy, f->split[i]))
                for (k = 0; k < w->agent_count; ++k) gs__sync_carry(w->agents[k]);
        }
        if (sy->replaying != GS__RERUN_TEST && gs__sync_is_fresh(sy, f->split[i])) {
            gs__sync_blend_to(w, f->split[i]);
            if (sy->probing && !sy->changed) { /* see gs__sync_replay_from */
                sy->stopped = 1;
                sy->stopped_at = f->split[i];
                kept--; /* the frame runs as it did: no stop there */
                for (++i; i < f->nsplit; ++i) f->split[kept++] = f->split[i];
                f->nsplit = kept;
                w->target = end;
                return first;
            }
            sy->probing = 0;
        }
    }
    if (f) f->nsplit = kept;
    w->target = end;
    if (budget > 0.0) {
        left = budget - (w->clock(w->clock_user) - start);
        if (left <= 0.0) left = 1e-12; /* spent: the run stops at once */
    }
    r = gs__sync_run_part(w, left, rep);
    return first == GS_OK ? r : first;
}

/* An advance's dispatches (gs__sync_advance), to the blend times its frame
   holds first. */
GS__PRIVATE gs_result gs__sync_run(gs_world *w, double budget, gs_advance_report *rep) {
    gs__sync *sy = w->sync;
    gs__hframe *f = NULL;
    if (sy->cap && sy->seq > 0 && sy->agents == w->agent_count && !sy->replaying) {
        f = &sy->frames[(sy->seq - 1) % (uint64_t)sy->cap];
        if (f->seq != sy->seq - 1) f = NULL;
    }
    return gs__sync_split_run(w, f, budget, rep);
}

/* The probes' targets from a record p (the inputs between advances). */
GS__PRIVATE void gs__sync_load_targets(gs_world *w, const double *p) {
    int i;
    for (i = 0; i < w->agent_count; ++i) {
        gs__rigid *r = gs__as_rigid(w->agents[i]);
        /* a peer's probe moves where its blends put it, not by a target */
        if (r && r->probe && r->owner == w->host_id) {
            const double *x = p + GS__SYNC_AGENT;
            r->target = gs__v3(x[6], x[7], x[8]);
            r->target_q = gs__quat(x[9], x[10], x[11], x[12]);
        }
        p += gs__sync_agent_size(w->agents[i]);
    }
}

/* Re-runs frames [from, sy->seq): the advance each recorded. A replay
   (GS__RERUN_BLEND) records each frame again as it now starts. */
GS__PRIVATE uint64_t gs__sync_rerun(gs_world *w, uint64_t from, int how) {
    gs__sync *sy = w->sync;
    uint64_t j, steps = 0;
    int busy = w->busy; /* a replay runs inside an advance */
    sy->replaying = how;
    gs__sync_load(w, gs__sync_slot(sy, from));
    for (j = from; j < sy->seq; ++j) {
        gs__hframe *f = &sy->frames[j % (uint64_t)sy->cap];
        gs_advance_report rep;
        if (j > from) { /* the inputs between advances: probe targets, states by hand */
            gs__sync_load_targets(w, gs__sync_slot(sy, j));
            gs__sync_apply_log(w, j, GS__SYNC_NONE, 0.0);
            if (how == GS__RERUN_BLEND) gs__sync_save(w, gs__sync_slot(sy, j));
        }
        w->target = f->target;
        w->dispatches = f->dispatches;
        sy->replay_seq = j;
        memset(&rep, 0, sizeof rep);
        w->busy = 1;
        gs__world_follow(w, gs__world_follow_target(w));
        gs__sync_target(w, f->seconds, w->target);
        gs__sync_split_run(w, f, 0.0, &rep);
        w->busy = busy;
        steps += rep.steps;
        if (sy->stopped) break;
    }
    sy->replaying = 0;
    return steps;
}

/* Adds t to the ascending list sy->fresh (times within `half` are one).
   Returns 0 when the list is full: blended at another time, a set would
   put its objects where they were at another moment. */
GS__PRIVATE int gs__sync_fresh_add(gs__sync *sy, double t, double half) {
    int k, j;
    for (k = 0; k < sy->nfresh && sy->fresh[k] < t - half; ++k) continue;
    if (k < sy->nfresh && fabs(sy->fresh[k] - t) <= half) return 1;
    if (sy->nfresh == GS__SPLITS) return 0;
    for (j = sy->nfresh++; j > k; --j) sy->fresh[j] = sy->fresh[j - 1];
    sy->fresh[k] = t;
    return 1;
}

GS__PRIVATE void gs__snap_drop(gs__ghost *g, gs__snap *sn) {
    sn->used = 0;
    sn->chunks = 0;
    sn->waited = 0;
    memset(sn->got, 0, (size_t)g->nchunks);
}

/* The newest time (within half a step) at which peer slot p sent a whole
   snapshot of every ghost of the world; -HUGE_VAL if none. */
GS__PRIVATE double gs__sync_whole_set(gs_world *w, int p, double half) {
    double best = -HUGE_VAL;
    int i, q, i2, q2;
    for (i = 0; i < w->agent_count; ++i) {
        gs__ghost *g = gs__ghost_of(w->agents[i]);
        for (q = 0; g && g->gp[p].q && q < g->d.queue_size; ++q) {
            const gs__snap *c = &g->gp[p].q[q];
            int all = 1;
            if (!c->used || c->chunks < g->nchunks || !(c->time > best)) continue;
            for (i2 = 0; all && i2 < w->agent_count; ++i2) {
                gs__ghost *o = gs__ghost_of(w->agents[i2]);
                int has = 0;
                if (!o) continue;
                for (q2 = 0; o->gp[p].q && q2 < o->d.queue_size; ++q2) {
                    const gs__snap *d = &o->gp[p].q[q2];
                    has |= d->used && d->chunks == o->nchunks && fabs(d->time - c->time) <= half;
                }
                all = has;
            }
            if (all) best = c->time;
        }
    }
    return best;
}

/* Replay mode, under the lock: for each peer, the newest whole set of
   snapshots (every ghost, every chunk, one time) is taken; older ones go
   (it supersedes them) and newer ones are held aside for their chunks and
   objects still on the way. Blended a part at a time (a datagram lost, a
   chunk late), a sphere and the cloth under it would come from moments
   frames apart and the contact would throw the sphere (190 mm p95 on a
   50 ms round trip with 2% loss, against 2.8 mm without loss). The ages
   go to 0: a snapshot blends at its own time. Times go to sy->fresh. */
GS__PRIVATE void gs__sync_times(gs_world *w, double half) {
    gs__sync *sy = w->sync;
    int i, p, q;
    gs__lock(w->net);
    for (p = 0; p < GS__MAX_PEERS; ++p) {
        double set = gs__sync_whole_set(w, p, half);
        if (set > -HUGE_VAL && !gs__sync_fresh_add(sy, set, half)) set = HUGE_VAL; /* all go */
        for (i = 0; i < w->agent_count; ++i) {
            gs__ghost *g = gs__ghost_of(w->agents[i]);
            for (q = 0; g && g->gp[p].q && q < g->d.queue_size; ++q) {
                gs__snap *sn = &g->gp[p].q[q];
                if (!sn->used) continue;
                sn->age = 0.0;
                if (set > -HUGE_VAL && fabs(sn->time - set) <= half) sn->waited = 0;
                else if (sn->time < set) gs__snap_drop(g, sn), sy->st.incomplete++;
                else sn->waited = 1; /* held aside this advance */
            }
        }
    }
    gs__unlock(w->net);
}

/* The frame of the history that starts before t (within half a step), the
   latest such; 0 if none is left. */
GS__PRIVATE int gs__sync_frame_of(const gs__sync *sy, double t, double half, uint64_t *out) {
    uint64_t k;
    for (k = 1; k <= (uint64_t)sy->cap && k <= sy->seq; ++k) {
        uint64_t j = sy->seq - k;
        if (!gs__sync_have(sy, j)) return 0;
        if (sy->frames[j % (uint64_t)sy->cap].target <= t + half) {
            *out = j;
            return 1;
        }
    }
    return 0;
}

/* The re-run of a replay, probing first: from the frame before the oldest
   snapshot time, to that time, where every ghost blends. If the blend
   changed no state (every weight of the snapshots 0, as for a leader's own
   objects, or the snapshots equal to the states here), the frames after
   it would run again as they ran: it stops there, the time goes from the
   frame's blend times (so that it re-runs as it ran), and the next
   snapshot time is probed from its own frame. The first blend that
   changes a state runs on to the present. Stopped (sy->stopped) at the
   last, the present stands as it was. */
GS__PRIVATE void gs__sync_replay_from(gs_world *w, double half, double target) {
    gs__sync *sy = w->sync;
    uint64_t j, from = 0;
    int k;
    gs__sync_frame_of(sy, sy->fresh[0], half, &from);
    for (k = 0; k < sy->nfresh && sy->fresh[k] < target; ++k) {
        if (!gs__sync_frame_of(sy, sy->fresh[k], half, &j) || j < from) j = from;
        sy->probing = 1;
        sy->stopped = 0;
        sy->near_ok = target - sy->fresh[k] <= GS__NEAR_SPAN;
        sy->st.replay_steps += gs__sync_rerun(w, j, GS__RERUN_BLEND);
        if (!sy->stopped) break;
        while (k + 1 < sy->nfresh && sy->fresh[k + 1] <= sy->stopped_at) k++;
    }
    sy->probing = 0;
}

/* Replay mode, at the start of an advance: the snapshots waiting get no
   wire age (they blend at their own time), and the oldest one's time is
   when every ghost blends. If it lies in the history, the frames from the
   last one that starts before it are run again with that blend in them
   (gs__sync_replay_from), and the world is at its present again,
   corrected; the inputs of this frame (probe targets now, states set by
   hand since) are applied again. */
GS__PRIVATE void gs__sync_take(gs_world *w) {
    gs__sync *sy = w->sync;
    double *present, half = HUGE_VAL, target = w->target;
    uint64_t from = 0, dispatches = w->dispatches, j;
    int i, k;
    for (i = 0; i < w->agent_count; ++i) half = fmin(half, 0.5 * w->agents[i]->dt);
    gs__sync_times(w, half);
    if (sy->nfresh == 0 || sy->fresh[0] >= w->target) return; /* this advance runs to them */
    if (!gs__sync_frame_of(sy, sy->fresh[0], half, &from) ||
        (sy->seq - from) * sy->frame_steps > (uint64_t)sy->d.replay_budget ||
        (sy->d.replay_reach > 0.0 && target - sy->fresh[0] > sy->d.replay_reach) ||
        sy->slow) {
        sy->st.fallbacks++; /* older than the history, the budget or the reach */
        if (sy->slow) sy->st.slow_fallbacks++;
        sy->nfresh = 0;
        sy->at_start = 1;
        gs__sync_blend(w, HUGE_VAL, 0);
        sy->at_start = 0;
        return;
    }
    for (k = 0; k < sy->nfresh && sy->fresh[k] < w->target; ++k) {
        gs__hframe *f;
        if (!gs__sync_frame_of(sy, sy->fresh[k], half, &j) || j < from) j = from;
        f = &sy->frames[j % (uint64_t)sy->cap];
        if (f->nsplit == GS__SPLITS) continue; /* not reached: at most GS__SPLITS are fresh */
        for (i = f->nsplit; i > 0 && f->split[i - 1] > sy->fresh[k]; --i) f->split[i] = f->split[i - 1];
        f->split[i] = sy->fresh[k];
        f->nsplit++;
    }
    present = sy->ring + (size_t)sy->cap * sy->stride;
    gs__sync_save(w, present);
    sy->near = 0;
    gs__sync_replay_from(w, half, target);
    if (sy->stopped) { /* no blend changed a state: the present stands */
        sy->stopped = 0;
        gs__sync_load(w, present);
        w->target = target;
        sy->st.replays_skipped++;
        if (sy->near) sy->st.replays_near++;
    } else {
        sy->st.replays++;
        sy->near_skips = 0;
    }
    gs__sync_load_targets(w, present);
    gs__sync_apply_log(w, sy->seq, GS__SYNC_NONE, 0.0);
    w->dispatches = dispatches;
}

/* The seconds an advance is given count toward the net's check for a
   missing gs_net_update (see unsent_world). */
GS__PRIVATE void gs__net_advanced(gs_world *w, double seconds) {
    gs_net *net = w->net;
    if (!net) return;
    gs__lock(net);
    net->unsent_world += seconds;
    gs__unlock(net);
}

/* The world's hook for one advance, the walk of a snapshot from the net's
   queues to the next host: gs__sync_begin takes what was received (replay
   mode), rewinds the world to the frame of the history before it, runs
   the frames again to the present with each blend at its snapshot's time
   (gs__sync_rerun), and records the present as a new frame; the world's
   clock then follows its agents and moves on by `seconds` (the session's
   time on the session clock, gs__sync_target); the dispatches step every
   agent to the target (gs__sync_run: present mode blends after the steps,
   gs__sync_stepped), and gs__sync_end publishes (session clock). */
/* Replay mode, at the end of an advance that ran `span` s of simulation:
   whether this host keeps pace. A host starved of CPU advances in ever
   longer spans, each to the time its last one ended at; its peers'
   snapshots then arrive a span old, and re-running that span costs as
   much again as stepping it, so each advance costs twice its span and
   the next one is longer still. An advance over a fifth of replay_reach
   (50 ms at the default, three 60 Hz frames) marks the host as catching
   up: its snapshots blend at the present until an advance spans under a
   tenth (hysteresis, so that it does not flip at every advance). On the
   span, not on a clock, so that it does not depend on how fast the
   machine runs the simulation (a simnet's clock stands still during an
   advance, a session clock on a frame grid reads the frame's instant). */
GS__PRIVATE void gs__sync_pace(gs_world *w, double span) {
    gs__sync *sy = w->sync;
    if (sy->d.mode != GS_SYNC_REPLAY || !(sy->d.replay_reach > 0.0)) return;
    if (span > 0.2 * sy->d.replay_reach) sy->slow = 1;
    else if (span < 0.1 * sy->d.replay_reach) sy->slow = 0;
}

GS__PRIVATE gs_result gs__sync_advance(gs_world *w, double seconds, gs_advance_report *rep) {
    gs_result r;
    double before;
    /* the clock is read before the replay: read after it, a replay's own
       duration counted as the session moving on (the target ran ahead by
       it) and, past GS__SYNC_STEP, as a step of the clock */
    if (gs__sync_session(w))
        w->sync->now = w->sync->d.now ? w->sync->d.now(w->sync->d.now_user) : w->clock(w->clock_user);
    gs__sync_begin(w, seconds);
    /* the follow after the replay, which moves agents */
    gs__world_follow(w, gs__world_follow_target(w));
    before = w->target;
    w->target += seconds;
    gs__net_advanced(w, seconds);
    gs__sync_target(w, seconds, before);
    r = gs__sync_run(w, w->budget, rep);
    gs__sync_end(w, seconds, rep);
    gs__sync_pace(w, w->target - before);
    return r;
}

GS_API gs_result gs_world_sync_stats(const gs_world *w, gs_sync_stats *out) {
    const gs__sync *sy;
    uint64_t k;
    if (!w || !out) return GS_ERR_INVALID_ARG;
    sy = w->sync;
    *out = sy->st;
    out->history = 0;
    for (k = 1; k <= sy->seq && k <= (uint64_t)sy->cap; ++k)
        if (gs__sync_have(sy, sy->seq - k)) out->history++;
        else break;
    return GS_OK;
}

GS_API gs_result gs_world_sync_test(gs_world *w, int frames, int *bad_agent) {
    gs__sync *sy;
    double *present, *rerun, target;
    uint64_t dispatches, from;
    int i;
    gs_result r = gs__world_unlocked(w, "gs_world_sync_test");
    if (r != GS_OK) return r;
    if (!bad_agent) return gs__fail(w, GS_ERR_INVALID_ARG, "gs_world_sync_test: bad_agent is NULL");
    sy = w->sync;
    *bad_agent = -1;
    if (frames < 1 || (uint64_t)frames > sy->seq || !gs__sync_have(sy, sy->seq - (uint64_t)frames))
        return gs__fail(w, GS_ERR_OUT_OF_RANGE,
                        "gs_world_sync_test: %d frames asked, the history holds fewer", frames);
    from = sy->seq - (uint64_t)frames;
    present = sy->ring + (size_t)sy->cap * sy->stride;
    rerun = present + sy->stride;
    target = w->target;
    dispatches = w->dispatches;
    gs__sync_save(w, present);
    sy->st.rerun_steps += gs__sync_rerun(w, from, GS__RERUN_TEST);
    gs__sync_save(w, rerun);
    {
        const double *a = present, *b = rerun;
        for (i = 0; i < w->agent_count && *bad_agent < 0; ++i) {
            size_t n = gs__sync_agent_size(w->agents[i]);
            if (memcmp(a, b, n * sizeof *a) != 0) *bad_agent = i;
            a += n;
            b += n;
        }
    }
    gs__sync_load(w, present);
    w->target = target;
    w->dispatches = dispatches;
    return GS_OK;
}

GS_API gs_result gs_world_next_frame(gs_world *w, double now, double *at) {
    gs__sync *sy;
    double f, next;
    if (!w || !at) return w ? gs__fail(w, GS_ERR_INVALID_ARG, "gs_world_next_frame: at is NULL")
                            : GS_ERR_INVALID_ARG;
    sy = w->sync;
    f = sy->d.frame;
    if (!gs__sync_session(w) || f <= 0.0)
        return gs__fail(w, GS_ERR_INVALID_ARG, "gs_world_next_frame: the world has no frame "
                        "grid (needs sync.clock = GS_SYNC_CLOCK_SESSION and sync.frame > 0)");
    if (!gs__finite(now))
        return gs__fail(w, GS_ERR_NOT_FINITE, "gs_world_next_frame: now is %g", now);
    if (!sy->started) {
        *at = now;
        return GS_OK;
    }
    next = sy->boundary + f;
    if (next - sy->origin < now) next = ceil((now + sy->origin) / f) * f;
    *at = next - sy->origin;
    return GS_OK;
}

/* The simnet's virtual clock of the host replaces the session clock's. */
GS__PRIVATE void gs__sync_set_clock(gs_world *w, gs_clock_fn fn, void *user) {
    w->sync->d.now = fn;
    w->sync->d.now_user = user;
}

/* ========================================================================
   >>wire
   ======================================================================== */
/* The datagram checksum: CRC-32 (IEEE 802.3 / zlib), in >>crc at the end
   of the file, out of the way of its 700 lines of tables. */
GS__PRIVATE uint32_t gs__crc32(const unsigned char *p, size_t n);

GS_API const char *gs_reject_str(gs_reject r) {
    switch (r) {
#define GS__REJECT_CASE(name, text) case name: return text;
        GS__REJECT_LIST(GS__REJECT_CASE)
#undef GS__REJECT_CASE
    default: return "unknown reason";
    }
}

/* Little-endian field access, whatever the host's byte order. */
GS__PRIVATE void gs__put32(unsigned char *p, uint32_t v) {
    p[0] = (unsigned char)v; p[1] = (unsigned char)(v >> 8);
    p[2] = (unsigned char)(v >> 16); p[3] = (unsigned char)(v >> 24);
}
GS__PRIVATE void gs__put16(unsigned char *p, uint16_t v) {
    p[0] = (unsigned char)v; p[1] = (unsigned char)(v >> 8);
}
GS__PRIVATE void gs__put64(unsigned char *p, uint64_t v) {
    gs__put32(p, (uint32_t)v);
    gs__put32(p + 4, (uint32_t)(v >> 32));
}
GS__PRIVATE uint32_t gs__get32(const unsigned char *p) {
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}
GS__PRIVATE uint16_t gs__get16(const unsigned char *p) {
    return (uint16_t)(p[0] | p[1] << 8);
}
GS__PRIVATE_INLINE uint64_t gs__get64(const unsigned char *p) {
    return (uint64_t)gs__get32(p) | (uint64_t)gs__get32(p + 4) << 32;
}
GS__PRIVATE void gs__putf64(unsigned char *p, double v) {
    uint64_t u;
    memcpy(&u, &v, 8);
    gs__put64(p, u);
}
GS__PRIVATE double gs__getf64(const unsigned char *p) {
    uint64_t u = gs__get64(p);
    double v;
    memcpy(&v, &u, 8);
    return v;
}
GS__PRIVATE void gs__putf32(unsigned char *p, float v) {
    uint32_t u;
    memcpy(&u, &v, 4);
    gs__put32(p, u);
}
GS__PRIVATE float gs__getf32(const unsigned char *p) {
    uint32_t u = gs__get32(p);
    float v;
    memcpy(&v, &u, 4);
    return v;
}

/* ---- GS_ENCODING_QUANT: segments of quantized, bit-packed values ---- */

/* Bits appended from the least significant one on, at most 32 at a time
   (v < 2^bits): the accumulator goes out 32 bits at once. */
typedef struct gs__bitw {
    unsigned char *p, *end;
    uint64_t acc;
    int n;
    int over; /* it ran past end */
} gs__bitw;
GS__PRIVATE void gs__bitw_put(gs__bitw *b, uint64_t v, int bits) {
    b->acc |= v << b->n;
    b->n += bits;
    if (b->n >= 32) {
        if (b->end - b->p >= 4) {
            gs__put32(b->p, (uint32_t)b->acc);
            b->p += 4;
        } else {
            b->over = 1;
        }
        b->acc >>= 32;
        b->n -= 32;
    }
}
/* gs__bitw_put's store, on a writer held in locals (o, end, acc, n,
   over): 32 bits out once n reaches 32. */
#define GS__BITS_OUT(o, end, acc, n, over)                                      \
    do {                                                                       \
        if ((n) >= 32) {                                                       \
            if ((end) - (o) >= 4) {                                            \
                gs__put32(o, (uint32_t)(acc));                                 \
                (o) += 4;                                                      \
            } else {                                                           \
                (over) = 1;                                                    \
            }                                                                  \
            (acc) >>= 32;                                                      \
            (n) -= 32;                                                         \
        }                                                                      \
    } while (0)
/* The bits left, padded to a whole byte. */
GS__PRIVATE void gs__bitw_flush(gs__bitw *b) {
    for (; b->n > 0; b->n -= 8, b->acc >>= 8) {
        if (b->p < b->end) *b->p++ = (unsigned char)b->acc; else b->over = 1;
    }
    b->n = 0;
}
typedef struct gs__bitr {
    const unsigned char *p, *end; /* end: of the segment, never read past */
    uint64_t acc;
    int n;
} gs__bitr;
/* Reads bits (<= 32); the caller checked the bytes are there. */
GS__PRIVATE uint32_t gs__bitr_get(gs__bitr *b, int bits) {
    uint32_t v;
    if (b->n < bits && b->end - b->p >= 4) {
        b->acc |= (uint64_t)gs__get32(b->p) << b->n;
        b->p += 4;
        b->n += 32;
    }
    while (b->n < bits) { b->acc |= (uint64_t)*b->p++ << b->n; b->n += 8; }
    v = bits ? (uint32_t)(b->acc & (((uint64_t)1 << bits) - 1)) : 0u;
    b->acc >>= bits;
    b->n -= bits;
    return v;
}

GS__PRIVATE uint64_t gs__zigzag(int64_t v) { return ((uint64_t)v << 1) ^ (uint64_t)(v >> 63); }
GS__PRIVATE int64_t gs__unzigzag(uint64_t u) { return (int64_t)(u >> 1) ^ -(int64_t)(u & 1); }

/* x rounded to the nearest integer (ties to even), for |x| < 2^51: adding
   and taking away 1.5 * 2^52 leaves no fraction bits. Exact IEEE
   arithmetic, the same on every host, and no library call; where doubles
   are evaluated wider (x87, FLT_EVAL_METHOD != 0) the sum is forced
   through memory to be a double. */
GS__PRIVATE int64_t gs__round(double x) {
#if defined(FLT_EVAL_METHOD) && FLT_EVAL_METHOD != 0
    volatile double r = x + 6755399441055744.0;
#else
    double r = x + 6755399441055744.0;
#endif
    return (int64_t)(r - 6755399441055744.0);
}

/* The step a scalar segment is sent at: the one asked for, doubled while
   the values would not fit: |v| / step under 2^51 (exact integers in a
   double, within gs__round's range) and their integers at most 2^32 - 1 apart (32-bit width). Their
   least and largest integers at that step in *lo and *hi (rounding is
   monotonic: the ends of the values give them). */
GS__PRIVATE double gs__quant_step(double step, const double *v, int n, int64_t *lo,
                                  int64_t *hi) {
    /* x < m ? x : m is minsd, which the compiler neither vectorizes nor
       reassociates (a NaN would tell the order), so four ends in two
       vectors here: minpd is the same per lane, and the least and largest
       are the same whatever the order (but for -0 against +0, which the
       rounding and fabs below take alike) */
    double vlo = v[0], vhi = v[0], big;
    int i = 0;
#ifdef GS__MESH_SSE2
    if (n >= 4) {
        __m128d l = _mm_set1_pd(v[0]), h = l, l2 = l, h2 = l;
        double t[2];
        for (; i + 4 <= n; i += 4) {
            __m128d x = _mm_loadu_pd(v + i), y = _mm_loadu_pd(v + i + 2);
            l = _mm_min_pd(x, l);
            h = _mm_max_pd(x, h);
            l2 = _mm_min_pd(y, l2);
            h2 = _mm_max_pd(y, h2);
        }
        _mm_storeu_pd(t, _mm_min_pd(l2, l));
        vlo = t[1] < t[0] ? t[1] : t[0];
        _mm_storeu_pd(t, _mm_max_pd(h2, h));
        vhi = t[1] > t[0] ? t[1] : t[0];
    }
#endif
    for (; i < n; ++i) {
        vlo = v[i] < vlo ? v[i] : vlo;
        vhi = v[i] > vhi ? v[i] : vhi;
    }
    big = fmax(fabs(vlo), fabs(vhi));
    for (;; step *= 2.0) {
        double inv = 1.0 / step;
        if (big * inv >= 2251799813685248.0) continue;
        *lo = gs__round(vlo * inv);
        *hi = gs__round(vhi * inv);
        if (*hi - *lo <= 0xffffffffLL) return step;
    }
}

/* A scalar segment's layout at the step it is sent at (gs__quant_step):
   what gs__quant_put sizes before it writes and gs__quant_put_scalar
   writes. */
typedef struct gs__qlay {
    double step;
    int64_t lo;
    int width;
} gs__qlay;
GS__PRIVATE void gs__quant_lay(const gs_wire_segment *s, const double *v, gs__qlay *l) {
    int64_t hi = 0;
    l->lo = 0;
    l->step = s->count ? gs__quant_step(s->step, v, s->count, &l->lo, &hi) : s->step;
    l->width = 0;
    while (l->width < 32 && (uint64_t)(hi - l->lo) >> l->width) ++l->width;
}

/* A segment's header (see >>wire: kind, count, then a scalar's step,
   width and base, the zigzag of l->lo as a varint, or a quaternion's
   bits; l is read for a scalar only) at out (NULL: not written), whole
   bytes: its size. gs__quant_put sizes a chunk with it before anything
   is packed and the writers write with it, so that the layout is said
   once. */
GS__PRIVATE size_t gs__varint_put(unsigned char *p, uint64_t z);
GS__PRIVATE size_t gs__seg_head(unsigned char *out, const gs_wire_segment *s,
                                const gs__qlay *l) {
    unsigned char b[24];
    unsigned char *o = out ? out : b;
    size_t n = 3;
    o[0] = (unsigned char)s->kind;
    gs__put16(o + 1, (uint16_t)s->count);
    if (s->kind != GS_WIRE_SCALAR) {
        o[n++] = (unsigned char)s->bits;
        return n;
    }
    gs__putf64(o + n, l->step);
    o[n + 8] = (unsigned char)l->width;
    return n + 9 + gs__varint_put(o + n + 9, gs__zigzag(l->lo));
}

/* A scalar segment at w (on a byte) in layout l: header, then the packed
   values. 0 if it ran out of room. Each value is rounded as v * (1 /
   step), a product rather than a quotient: within a unit of the last
   place of v / step, which the error bound (half a step) does not see. */
GS__PRIVATE int gs__quant_put_scalar(gs__bitw *w, const gs_wire_segment *s, const gs__qlay *l,
                                     const double *v) {
    double step = l->step, inv = 1.0 / step;
    int64_t lo = l->lo;
    int i, width = l->width;
    unsigned char h[24];
    size_t hn = gs__seg_head(h, s, l);
    if ((size_t)(w->end - w->p) < hn) {
        w->over = 1;
        return 0;
    }
    memcpy(w->p, h, hn);
    w->p += hn;
    /* the writer's fields in locals: its stores are of bytes, which may
       alias anything, and would make it reload them for every value */
    {
        unsigned char *p = w->p, *end = w->end;
        uint64_t acc = 0;
        int n = 0, over = 0;
        for (i = 0; i < s->count; ++i) {
            acc |= (uint64_t)(gs__round(v[i] * inv) - lo) << n;
            n += width;
            if (n >= 32) {
                if (end - p >= 4) { gs__put32(p, (uint32_t)acc); p += 4; } else over = 1;
                acc >>= 32;
                n -= 32;
            }
        }
        w->p = p; w->acc = acc; w->n = n; w->over |= over;
    }
    gs__bitw_flush(w);
    return !w->over;
}

/* sqrt(2) / (2^bits - 1): a smallest-three component's step. */
GS__PRIVATE double gs__quat_step(int bits) {
    return 1.4142135623730951 / (double)((1u << bits) - 1u);
}

/* A quaternion segment at w (on a byte): header, then each quaternion's
   largest component's index, its sign and the other three. 0 if it ran
   out of room. */
GS__PRIVATE int gs__quant_put_quat(gs__bitw *w, const gs_wire_segment *s, const double *v) {
    double st = gs__quat_step(s->bits), top = (double)((1u << s->bits) - 1u);
    int i, k, big, j;
    unsigned char h[24];
    size_t hn = gs__seg_head(h, s, NULL);
    if ((size_t)(w->end - w->p) < hn) {
        w->over = 1;
        return 0;
    }
    memcpy(w->p, h, hn);
    w->p += hn;
    for (i = 0; i < s->count; i += 4) {
        const double *q = v + i;
        double norm = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
        for (big = 0, k = 1; k < 4; ++k) big = fabs(q[k]) > fabs(q[big]) ? k : big;
        gs__bitw_put(w, (uint64_t)big, 2);
        gs__bitw_put(w, q[big] < 0.0, 1);
        for (k = 0; k < 4; ++k) {
            double c, u;
            if (k == big) continue;
            c = q[k] / norm;
            u = floor((c + 0.7071067811865476) / st + 0.5);
            j = (int)(u < 0.0 ? 0.0 : u > top ? top : u);
            gs__bitw_put(w, (uint64_t)j, s->bits);
        }
    }
    gs__bitw_flush(w);
    return !w->over;
}

/* Are the segments of c fit to encode its values? */
GS__PRIVATE int gs__quant_args_ok(const gs_wire_chunk *c, const double *values) {
    int k, sum = 0, off = 0, i;
    if (c->segment_count < 1 || c->segment_count > GS_WIRE_MAX_SEGMENTS) return 0;
    for (k = 0; k < c->segment_count; ++k) {
        const gs_wire_segment *s = &c->segments[k];
        sum += s->count;
        if (s->kind == GS_WIRE_SCALAR) {
            if (!(s->step >= 1e-12 && s->step <= 1e12)) return 0;
        } else if (s->kind == GS_WIRE_QUATERNION) {
            if (s->bits < 8 || s->bits > 24 || s->count % 4) return 0;
            for (i = off; i < off + s->count; i += 4)
                if (!(fabs(values[i]) + fabs(values[i + 1]) + fabs(values[i + 2]) +
                      fabs(values[i + 3]) > 0.0)) return 0;
        } else {
            return 0;
        }
        off += s->count;
    }
    return sum == c->elements;
}

/* Writes a quantized payload at p (room bytes); its size, or 0 if it does
   not fit. The values are checked finite by the caller. Every field is
   whole bytes and each segment ends on a byte, so the size is known from
   the layouts before a value is written: a chunk that does not fit (the
   datagram is then sent and the chunk tried again in the next) costs no
   packing. */
GS__PRIVATE size_t gs__quant_put(unsigned char *p, size_t room, const gs_wire_chunk *c,
                                 const double *v) {
    gs__bitw w;
    gs__qlay lay[GS_WIRE_MAX_SEGMENTS];
    const double *u = v;
    size_t need = 1;
    int k, ok = 1;
    for (k = 0; k < c->segment_count; ++k) {
        const gs_wire_segment *s = &c->segments[k];
        if (s->kind == GS_WIRE_SCALAR) {
            gs__quant_lay(s, u, &lay[k]);
            need += gs__seg_head(NULL, s, &lay[k]) +
                    ((size_t)s->count * (size_t)lay[k].width + 7) / 8;
        } else {
            need += gs__seg_head(NULL, s, NULL) +
                    ((size_t)(s->count / 4) * (size_t)(3 + 3 * s->bits) + 7) / 8;
        }
        u += s->count;
    }
    if (need > room) return 0;
    p[0] = (unsigned char)c->segment_count;
    w.p = p + 1; w.end = p + room; w.acc = 0; w.n = 0; w.over = 0;
    for (k = 0; k < c->segment_count && ok; ++k) {
        const gs_wire_segment *s = &c->segments[k];
        ok = s->kind == GS_WIRE_SCALAR ? gs__quant_put_scalar(&w, s, &lay[k], v)
                                       : gs__quant_put_quat(&w, s, v);
        v += s->count;
    }
    return ok && !w.over ? (size_t)(w.p - p) : 0;
}

GS__PRIVATE int gs__quant_quats_ok(const gs_wire_segment *s);

/* Reads the segments of a quantized payload (within len bytes) into c,
   checking every length and bound: the values it gives are finite, under
   2^51 * step in size. Its length, or 0 if anything is off. */
GS__PRIVATE size_t gs__quant_parse(gs_wire_chunk *c, const unsigned char *p, size_t len) {
    size_t off = 1, need;
    int k, sum = 0;
    if (len < 1) return 0;
    c->segment_count = p[0];
    if (c->segment_count < 1 || c->segment_count > GS_WIRE_MAX_SEGMENTS) return 0;
    for (k = 0; k < c->segment_count; ++k) {
        gs_wire_segment *s = &c->segments[k];
        if (off + 3 > len) return 0;
        s->kind = (gs_wire_kind)p[off];
        s->count = gs__get16(p + off + 1);
        off += 3;
        s->step = 0.0; s->bits = 0; s->width = 0; s->base = 0;
        if (s->kind == GS_WIRE_SCALAR) {
            uint64_t z = 0;
            int sh = 0;
            if (off + 9 > len) return 0;
            s->step = gs__getf64(p + off);
            s->width = p[off + 8];
            off += 9;
            if (!(s->step >= 1e-12 && s->step <= 1e12) || s->width > 32) return 0;
            do {
                if (off >= len || sh > 56) return 0;
                z |= (uint64_t)(p[off] & 0x7f) << sh;
                sh += 7;
            } while (p[off++] & 0x80);
            s->base = gs__unzigzag(z);
            /* so that |base + q| < 2^51, as the encoder sends */
            if (s->base > 2251795518717952LL || s->base < -2251795518717952LL) return 0;
            need = ((size_t)s->count * (size_t)s->width + 7) / 8;
        } else if (s->kind == GS_WIRE_QUATERNION) {
            if (off + 1 > len) return 0;
            s->bits = p[off++];
            if (s->bits < 8 || s->bits > 24 || s->count % 4) return 0;
            need = ((size_t)(s->count / 4) * (size_t)(3 + 3 * s->bits) + 7) / 8;
        } else {
            return 0;
        }
        if (need > len - off) return 0;
        s->data = p + off;
        off += need;
        if (s->kind == GS_WIRE_QUATERNION && !gs__quant_quats_ok(s)) return 0;
        sum += s->count;
    }
    return sum == c->elements ? off : 0;
}

/* The packed bytes of a parsed segment. */
GS__PRIVATE size_t gs__seg_bytes(const gs_wire_segment *s) {
    return s->kind == GS_WIRE_SCALAR
               ? ((size_t)s->count * (size_t)s->width + 7) / 8
               : ((size_t)(s->count / 4) * (size_t)(3 + 3 * s->bits) + 7) / 8;
}

/* A quaternion's four values from its packed bits. */
GS__PRIVATE void gs__quant_get_quat(gs__bitr *r, int bits, double *out) {
    double st = gs__quat_step(bits), ss = 0.0;
    int big = (int)gs__bitr_get(r, 2), neg = (int)gs__bitr_get(r, 1), k;
    for (k = 0; k < 4; ++k) {
        if (k == big) continue;
        out[k] = (double)gs__bitr_get(r, bits) * st - 0.7071067811865476;
        ss += out[k] * out[k];
    }
    out[big] = ss < 1.0 ? sqrt(1.0 - ss) : 0.0;
    if (neg) out[big] = -out[big];
}

/* Are a segment's quaternions what an encoder sends? The three smaller
   components of a unit quaternion have squares that add up to at most 3/4
   (the largest is at least 1/2); rounded, at most 0.7584 at 8 bits. Past
   0.76 the bits say no rotation (the largest would be made up). */
GS__PRIVATE int gs__quant_quats_ok(const gs_wire_segment *s) {
    gs__bitr r;
    double q[4];
    int i, k;
    r.p = s->data; r.end = s->data + gs__seg_bytes(s); r.acc = 0; r.n = 0;
    for (i = 0; i < s->count; i += 4) {
        double ss = 0.0;
        int big = (int)gs__bitr_get(&r, 2);
        gs__bitr_get(&r, 1);
        for (k = 0; k < 3; ++k) {
            q[k] = (double)gs__bitr_get(&r, s->bits) * gs__quat_step(s->bits) - 0.7071067811865476;
            ss += q[k] * q[k];
        }
        (void)big;
        if (ss > 0.76) return 0;
    }
    return 1;
}

/* Every value of a parsed quantized chunk into out. */
GS__PRIVATE void gs__quant_get(const gs_wire_chunk *c, double *out) {
    int k, i;
    for (k = 0; k < c->segment_count; ++k) {
        const gs_wire_segment *s = &c->segments[k];
        gs__bitr r;
        r.p = s->data; r.end = s->data + gs__seg_bytes(s); r.acc = 0; r.n = 0;
        if (s->kind == GS_WIRE_SCALAR) {
            const unsigned char *p = r.p;
            uint64_t acc = 0, mask = ((uint64_t)1 << s->width) - 1;
            int n = 0, wd = s->width;
            for (i = 0; i < s->count; ++i) {
                if (n < wd) {
                    if (r.end - p >= 4) {
                        acc |= (uint64_t)gs__get32(p) << n;
                        p += 4;
                        n += 32;
                    } else {
                        while (n < wd) { acc |= (uint64_t)*p++ << n; n += 8; }
                    }
                }
                out[i] = (double)(s->base + (int64_t)(acc & mask)) * s->step;
                acc >>= wd;
                n -= wd;
            }
        } else
            for (i = 0; i < s->count; i += 4) gs__quant_get_quat(&r, s->bits, out + i);
        out += s->count;
    }
}

/* Value i of a parsed quantized chunk: its segment decoded up to it. */
GS__PRIVATE double gs__quant_value(const gs_wire_chunk *c, int i) {
    double q[4];
    int k, j;
    for (k = 0; k < c->segment_count; ++k) {
        const gs_wire_segment *s = &c->segments[k];
        gs__bitr r;
        if (i >= s->count) { i -= s->count; continue; }
        r.p = s->data; r.end = s->data + gs__seg_bytes(s); r.acc = 0; r.n = 0;
        if (s->kind == GS_WIRE_SCALAR) {
            uint32_t u = 0;
            for (j = 0; j <= i; ++j) u = gs__bitr_get(&r, s->width);
            return (double)(s->base + (int64_t)u) * s->step;
        }
        for (j = 0; j <= i / 4; ++j) gs__quant_get_quat(&r, s->bits, q);
        return q[i % 4];
    }
    return 0.0;
}
/* ---- GS_WIRE_CHUNK_DELTA and GS_WIRE_CHUNK_ACK ---- */

/* An unsigned LEB128 varint at *p of at most max bytes before end; 0 if
   it is cut short, longer, or not in its fewest bytes (a last byte 0 after
   others: one datagram, one meaning). */
GS__PRIVATE int gs__varint_get(const unsigned char **p, const unsigned char *end, int max,
                               uint64_t *out) {
    uint64_t z = 0;
    int i;
    for (i = 0; i < max && *p < end; ++i) {
        unsigned b = *(*p)++;
        z |= (uint64_t)(b & 0x7f) << (7 * i);
        if (!(b & 0x80)) {
            *out = z;
            return b != 0 || i == 0;
        }
    }
    return 0;
}
GS__PRIVATE size_t gs__varint_put(unsigned char *p, uint64_t z) {
    size_t n = 0;
    for (; z >= 0x80; z >>= 7) p[n++] = (unsigned char)((z & 0x7f) | 0x80);
    p[n++] = (unsigned char)z;
    return n;
}
/* zigzag of a u32 difference read as signed (wraps both ways) */
GS__PRIVATE uint64_t gs__zigzag32(uint32_t d) { return gs__zigzag((int64_t)(int32_t)d); }

/* GS_WIRE_CHUNK_DELTA's Rice coding (coding 2, see >>wire): each value z
   as z >> k in unary (that many 0 bits, then a 1) and its k low bits, or
   past GS__RICE_ESCAPE zeros z in 32 bits. */
#define GS__RICE_ESCAPE 16
#define GS__RICE_MAX_K 24

/* The index of the lowest set bit of v (v != 0). */
GS__PRIVATE int gs__ctz64(uint64_t v) {
#if defined(__GNUC__) || defined(__clang__)
    return __builtin_ctzll(v);
#else
    int n = 0;
    while (!(v & 1u)) { v >>= 1; ++n; }
    return n;
#endif
}

/* A reader of a Rice run that never reads past end (0 bits there, counted
   in zeros), so that gs__rice_bits can tell a parse the bits it took and
   a run that overran, without a count per value. */
typedef struct gs__rice {
    const unsigned char *p, *start, *end;
    uint64_t acc;
    int n;
    size_t zeros; /* bytes of 0 bits taken past end */
} gs__rice;
/* At least 48 bits held after it (an escape's 16 + 32, more than any
   other value takes): a word loaded every few values, not every one. */
GS__PRIVATE_INLINE void gs__rice_fill(gs__rice *r) {
    if (r->n >= 48) return;
    if (r->end - r->p >= 8) { /* whole words: the bytes above n go in again, the same */
        r->acc |= gs__get64(r->p) << r->n;
        r->p += (63 - r->n) >> 3;
        r->n |= 56;
        return;
    }
    while (r->n <= 56) {
        if (r->p < r->end) r->acc |= (uint64_t)*r->p++ << r->n;
        else r->zeros++;
        r->n += 8;
    }
}
/* The next value z; *esc set when it came escaped. */
GS__PRIVATE_INLINE uint64_t gs__rice_get(gs__rice *r, int k, int *esc) {
    uint64_t z;
    int tz;
    gs__rice_fill(r);
    tz = gs__ctz64(r->acc | (uint64_t)1 << GS__RICE_ESCAPE);
    if (tz < GS__RICE_ESCAPE) {
        r->acc >>= tz + 1;
        z = (uint64_t)tz << k | (r->acc & (((uint64_t)1 << k) - 1));
        r->acc >>= k;
        r->n -= tz + 1 + k;
        *esc = 0;
        return z;
    }
    r->acc >>= GS__RICE_ESCAPE;
    z = r->acc & 0xffffffffu;
    r->acc >>= 32;
    r->n -= GS__RICE_ESCAPE + 32;
    *esc = 1;
    return z;
}
GS__PRIVATE void gs__rice_init(gs__rice *r, const unsigned char *p, const unsigned char *end) {
    r->p = r->start = p; r->end = end; r->acc = 0; r->n = 0; r->zeros = 0;
}
/* The bits taken so far: every byte loaded (or 0 past end) less those
   held. */
GS__PRIVATE size_t gs__rice_bits(const gs__rice *r) {
    return 8 * ((size_t)(r->p - r->start) + r->zeros) - (size_t)r->n;
}

/* Walks n values of a Rice run of parameter k (gs__rice_get's codes)
   without making them: what a parse needs, the bits they take. 0 if an
   escape holds a value unary could say (one meaning). In a local copy, so
   that the reader's fields stay in registers. */
GS__PRIVATE int gs__rice_skip(gs__rice *r, int n, int k) {
    gs__rice t = *r;
    int i, tz;
    for (i = 0; i < n; ++i) {
        gs__rice_fill(&t);
        tz = gs__ctz64(t.acc | (uint64_t)1 << GS__RICE_ESCAPE);
        if (tz < GS__RICE_ESCAPE) { /* unary, its 1 and k bits: at most 40 */
            t.acc >>= tz + 1 + k;
            t.n -= tz + 1 + k;
            continue;
        }
        if ((t.acc >> GS__RICE_ESCAPE & 0xffffffffu) >> k < GS__RICE_ESCAPE) return 0;
        t.acc >>= GS__RICE_ESCAPE + 32;
        t.n -= GS__RICE_ESCAPE + 32;
    }
    *r = t;
    return 1;
}

/* gs__rice_skip's walk (its check of escapes) through gs__rice_get, each
   value kept, unzigzagged, in out:
   the receiving net's parse, whose sum then reads them instead of the bits
   (gs__delta_sum). A value is z < 2^32 (an escape's 32 bits; unary's at
   most 2^28), so its difference fits an int32. */
GS__PRIVATE int gs__rice_take(gs__rice *r, int n, int k, int32_t *out) {
    gs__rice t = *r;
    uint64_t z;
    int i, esc;
    for (i = 0; i < n; ++i) {
        z = gs__rice_get(&t, k, &esc);
        if (esc && z >> k < GS__RICE_ESCAPE) return 0; /* as gs__rice_skip */
        out[i] = (int32_t)gs__unzigzag(z);
    }
    *r = t;
    return 1;
}

/* The bits a Rice run of parameter k takes are estimated from the values'
   bit lengths (hist[L]: values of L bits; a value of L > k bits has z >>
   k between 2^(L-k-1) and 2^(L-k) - 1, taken as 3/4 of 2^(L-k); L up to
   32). Rice's best k is near the median's bit length (the mean would
   follow the few large values, which escape anyway): the four about it
   are tried. Each estimate is a whole number of half bits (3/4 of 2^m is
   1.5 at m = 1, and 2^m * 3/4 >= GS__RICE_ESCAPE from m = 5: an escape's
   48 bits), so the estimates are sums over counts of bit lengths (cum[L]:
   the values of fewer than L bits), in integers: four terms a candidate,
   not one per bit length. The bits of the best (the first of the least),
   its k in *k; HUGE_VAL and k 0 when the median is past GS__RICE_MAX_K +
   2. */
GS__PRIVATE double gs__rice_pick(const int *hist, int n, int *k) {
    static const long half[5] = {0, 5, 8, 14, 26}; /* 2 (q + 1) half bits, m = 1 to 4 */
    long cum[34], best = -1;
    int k0, j, m, below = 0;
    cum[0] = 0;
    for (j = 0; j <= 32; ++j) cum[j + 1] = cum[j] + hist[j];
    for (k0 = 0; k0 < 32 && 2 * (below + hist[k0]) < n; ++k0) below += hist[k0];
    *k = 0;
    for (j = k0 > 2 ? k0 - 2 : 0; j <= k0 + 1 && j <= GS__RICE_MAX_K; ++j) {
        /* j <= 24: j + 5 <= 29, every index inside */
        long b = (2 + 2 * (long)j) * cum[j + 1] + 96 * (cum[33] - cum[j + 5]);
        for (m = 1; m <= 4; ++m) b += (half[m] + 2 * (long)j) * hist[j + m];
        if (best < 0 || b < best) { best = b; *k = j; }
    }
    return best < 0 ? HUGE_VAL : (double)best / 2.0;
}

/* GS_WIRE_CHUNK_DELTA's spatial coding (coding 3, see >>wire) predicts
   difference i from the differences before it, in rows of `row` triples,
   the neighbours starting again at `restart` (a section): a section's
   first triple as 0, the rest of its first row as the triple before (l),
   every later one as the median of l, the one a row up (up) and l + up -
   dg, dg the one up-left: LOCO-I's MED, the smaller of l and up when dg is
   at least both, the larger when at most both, else l + up - dg.
   gs__med3 computes it as l + up - dg held between l and up: no branch on
   the data, the same value (|l|, |up|, |dg| < 2^40 here: no overflow).
   The result lies between two earlier differences, so that decoded
   differences grow at most by a residual each (no overflow in int64). */
GS__PRIVATE_INLINE int64_t gs__med3(int64_t l, int64_t up, int64_t dg) {
    int64_t mn = l < up ? l : up, mx = l < up ? up : l, c = l + up - dg;
    return c < mn ? mn : c > mx ? mx : c;
}
/* Where a chunk's spatial neighbours start again: at its second segment
   (a chunk's positions, then its velocities), 0 if one. */
GS__PRIVATE int gs__spatial_restart(const gs_wire_chunk *c) {
    return c->segment_count >= 2 && c->segments[0].count < c->elements ? c->segments[0].count : 0;
}

/* Reads a delta chunk's differences in order (codings 0 to 2). */
typedef struct gs__dread {
    gs__bitr map, val;
    gs__rice rice;
    int coding, width;
} gs__dread;
GS__PRIVATE void gs__dread_init(const gs_wire_chunk *c, gs__dread *d) {
    const unsigned char *q = c->payload + c->delta_data, *end = c->payload + c->payload_bytes;
    size_t bm = ((size_t)c->elements + 7) / 8;
    d->coding = c->delta_coding;
    d->width = c->delta_width;
    d->map.p = q; d->map.end = q + bm; d->map.acc = 0; d->map.n = 0;
    if (d->coding == 0) bm = 0;
    d->val.p = q + bm; d->val.end = end; d->val.acc = 0; d->val.n = 0;
    gs__rice_init(&d->rice, q, end);
}
GS__PRIVATE int64_t gs__dread_next(gs__dread *d) {
    int esc;
    if (d->coding == 2) return gs__unzigzag(gs__rice_get(&d->rice, d->width, &esc));
    if (d->coding == 0) return gs__unzigzag(gs__bitr_get(&d->val, d->width));
    if (!gs__bitr_get(&d->map, 1)) return 0;
    return gs__unzigzag((uint64_t)gs__bitr_get(&d->val, d->width) + 1u);
}

/* Checks a delta payload (within len bytes) and fills c's baseline,
   coding and width: its length, or 0. same_base and same_row: the kind
   byte's bits 2 and 7 (see >>wire); row_before: the chunk before's
   spatial row if c is its next chunk, else 0. keep (room for
   GS_WIRE_QUANT_CHUNK values, or NULL): a Rice run's values, as the walk
   that checks it reads them (gs__rice_take). */
GS__PRIVATE size_t gs__delta_parse(gs_wire_chunk *c, const unsigned char *p, size_t len,
                                   int same_base, int same_row, int row_before,
                                   int32_t *keep) {
    const unsigned char *q = p, *end = p + len;
    uint64_t dist = 0;
    size_t need, bm, i;
    int nz = 0;
    if (c->encoding != GS_ENCODING_QUANT || c->elements == 0 ||
        c->elements > GS_WIRE_QUANT_CHUNK)
        return 0;
    if (same_base) dist = c->sequence - c->baseline; /* checked as the chunk before's */
    else if (!gs__varint_get(&q, end, 5, &dist) || dist < 1 || dist > 0x80000000u)
        return 0;
    if (q >= end) return 0;
    c->delta_skip = (uint8_t)(q - p);
    c->delta_coding = *q >> 6;
    /* Rice's k is at most 24: its bit 5 says predicted */
    c->delta_width = *q & (c->delta_coding >= 2 ? 0x1f : 0x3f);
    if (c->delta_coding >= 2 && (*q & 0x20)) c->flags |= GS_WIRE_CHUNK_PREDICT;
    if (c->delta_width > (c->delta_coding >= 2 ? GS__RICE_MAX_K : 32)) return 0;
    ++q;
    c->delta_row = c->delta_restart = 0;
    if (same_row) { /* kind bit 7: the chunk before's row, restart 0 */
        if (c->delta_coding != 3) return 0;
        c->delta_row = row_before;
    } else if (c->delta_coding == 3) {
        if (end - q < 2 || q[0] < 1 || q[0] > GS_WIRE_SPATIAL_ROW || q[1] >= c->elements)
            return 0;
        /* one meaning: what bit 7 says is not said again */
        if (q[0] == row_before && q[1] == 0) return 0;
        c->delta_row = q[0];
        c->delta_restart = q[1];
        q += 2;
    }
    c->delta_data = (uint8_t)(q - p);
    c->baseline = c->sequence - (uint32_t)dist;
    if (c->delta_coding >= 2) { /* walked: its length is where it ends */
        gs__rice r;
        size_t bits;
        gs__rice_init(&r, q, end);
        if (keep ? !gs__rice_take(&r, c->elements, c->delta_width, keep)
                 : !gs__rice_skip(&r, c->elements, c->delta_width))
            return 0;
        /* a run that overran took 0 bits past end: its bits say so (at the
           end: they only grow) */
        bits = gs__rice_bits(&r);
        if (bits > 8 * (size_t)(end - q)) return 0;
        need = (bits + 7) / 8;
        if (bits % 8 && q[need - 1] >> (bits % 8)) return 0; /* padding 0 */
    } else if (c->delta_coding == 0) {
        need = ((size_t)c->elements * (size_t)c->delta_width + 7) / 8;
    } else {
        bm = ((size_t)c->elements + 7) / 8;
        if (bm > (size_t)(end - q)) return 0;
        for (i = 0; i < bm; ++i) {
            unsigned b = q[i];
            for (; b; b &= b - 1) ++nz;
        }
        /* the padding bits are 0: one datagram, one meaning */
        if (c->elements % 8 && q[bm - 1] >> (c->elements % 8)) return 0;
        need = bm + ((size_t)nz * (size_t)c->delta_width + 7) / 8;
    }
    if (need > (size_t)(end - q)) return 0;
    c->payload_bytes = (uint16_t)((size_t)(q - p) + need);
    return c->payload_bytes;
}

/* Checks an acknowledgement payload (within len bytes): element count
   entries of two varints each, within their ranges. Its length, or 0. */
GS__PRIVATE size_t gs__ack_parse(const gs_wire_chunk *c, const unsigned char *p, size_t len) {
    const unsigned char *q = p, *end = p + len;
    int i;
    if (c->encoding != GS_ENCODING_QUANT || c->elements < 1 || c->elements > GS_WIRE_MAX_ACKS ||
        c->index != 0 || c->count != 1 || c->first != 0 || c->sequence != 0 || c->time != 0.0)
        return 0;
    for (i = 0; i < c->elements; ++i) {
        uint64_t a, b;
        if (!gs__varint_get(&q, end, 5, &a) || !gs__varint_get(&q, end, 5, &b)) return 0;
        if (a >> 33 || b >> 32) return 0;
    }
    return (size_t)(q - p);
}

GS_API int gs_wire_acks(const gs_wire_chunk *c, gs_wire_ack *out, int max) {
    const unsigned char *q, *end;
    uint32_t obj = 0, seq = 0;
    int i;
    if (!c || !out || !(c->flags & GS_WIRE_CHUNK_ACK) || !c->payload) return 0;
    q = c->payload;
    end = q + c->payload_bytes;
    for (i = 0; i < c->elements && i < max; ++i) {
        uint64_t a = 0, b = 0;
        gs__varint_get(&q, end, 5, &a);
        gs__varint_get(&q, end, 5, &b);
        obj += (uint32_t)gs__unzigzag(a >> 1);
        seq += (uint32_t)gs__unzigzag(b);
        out[i].object_id = obj;
        out[i].sequence = seq;
        out[i].refused = (int)(a & 1);
    }
    return i;
}

/* One value of w bits from a packed run at *p (before end), through the
   accumulator: 32 bits at a time while they are there. */
#define GS__UNPACK(z, p, end, acc, n, w, mask)                                  \
    do {                                                                       \
        if ((n) < (w)) {                                                       \
            if ((end) - (p) >= 4) {                                            \
                (acc) |= (uint64_t)gs__get32(p) << (n);                        \
                (p) += 4;                                                      \
                (n) += 32;                                                     \
            } else                                                             \
                while ((n) < (w)) { (acc) |= (uint64_t)*(p)++ << (n); (n) += 8; } \
        }                                                                      \
        (z) = (acc) & (mask);                                                  \
        (acc) >>= (w);                                                         \
        (n) -= (w);                                                            \
    } while (0)


/* A delta chunk's differences added to a baseline's integers bk, into
   out, in one pass, the readers in locals (as gs__quant_get): the
   receiving side's inner loop. vals: a Rice coding's values as the parse
   kept them (gs__delta_parse's keep); NULL: read from the bits here. 0 if
   a spatial coding's difference is past +-(2^31 - 1) (out is then all the
   same filled). */
GS__PRIVATE int gs__delta_sum(const gs_wire_chunk *c, const int32_t *vals, const int64_t *bk,
                              int64_t *out) {
    const unsigned char *q = c->payload + c->delta_data, *end = c->payload + c->payload_bytes,
                        *map = NULL;
    uint64_t acc = 0, mask, z;
    int i, n = 0, w;
    w = c->delta_width;
    mask = ((uint64_t)1 << w) - 1;
    if (c->delta_coding >= 2) {
        int32_t got[GS_WIRE_QUANT_CHUNK];
        if (!vals) { /* not kept by a parse (gs_wire_deltas, or past the net's
                        room): from the bits; a run the parse would refuse
                        leaves out the baseline, and the chunk refused */
            gs__rice r;
            gs__rice_init(&r, q, end);
            if (c->elements > GS_WIRE_QUANT_CHUNK || !gs__rice_take(&r, c->elements, w, got)) {
                for (i = 0; i < c->elements && i < GS_WIRE_QUANT_CHUNK; ++i) out[i] = bk[i];
                return 0;
            }
            vals = got;
        }
        if (c->delta_coding == 2) {
            for (i = 0; i < c->elements; ++i) out[i] = bk[i] + vals[i];
            return 1;
        }
        {
            /* in order, each difference from the residual and the
               differences before it (held in dd), checked, then the
               baseline: one pass. A section's first triple is predicted
               0, its first row (and one) from the left, the rest by the
               median (the cases of gs__med3's comment), each case in a
               loop of its own over its span (as gs__spatial_stat), so
               that no value tests where it is */
            int64_t dd[GS_WIRE_QUANT_CHUNK], x;
            int row3 = 3 * c->delta_row, rs = c->delta_restart, s, lo, hi, a, b;
            uint64_t bad = 0;
            /* one meaning: a spatial coding's differences as the others' */
#define GS__DSUM_PUT(pred)                                                      \
    do {                                                                       \
        x = (int64_t)vals[i] + (pred);                                         \
        dd[i] = x;                                                             \
        bad |= (uint64_t)(x + 2147483647LL) > 4294967294u;                     \
        out[i] = bk[i] + x;                                                    \
    } while (0)
            for (s = 0; s < 2; ++s) {
                lo = s ? rs : 0;
                hi = !s && rs > 0 ? rs : c->elements;
                if (s && rs <= 0) break;
                a = lo + 3 < hi ? lo + 3 : hi;
                b = lo + row3 + 3 < hi ? lo + row3 + 3 : hi;
                for (i = lo; i < a; ++i) GS__DSUM_PUT(0);
                for (; i < b; ++i) GS__DSUM_PUT(dd[i - 3]);
                for (; i < hi; ++i) GS__DSUM_PUT(gs__med3(dd[i - 3], dd[i - row3], dd[i - row3 - 3]));
            }
#undef GS__DSUM_PUT
            return !bad;
        }
    }
    if (c->delta_coding) {
        map = q;
        q += ((size_t)c->elements + 7) / 8;
    }
    for (i = 0; i < c->elements; ++i) {
        if (map && !(map[i >> 3] >> (i & 7) & 1)) { out[i] = bk[i]; continue; }
        GS__UNPACK(z, q, end, acc, n, w, mask);
        out[i] = bk[i] + gs__unzigzag(z + (map != NULL));
    }
    return 1;
}

/* A baseline of 0s: gs_wire_deltas's differences are gs__delta_sum's
   from it. */
static const int64_t gs__zero_k[GS_WIRE_QUANT_CHUNK] = {0};
GS_API void gs_wire_deltas(const gs_wire_chunk *c, int64_t *out) {
    if (!c || !out || !(c->flags & GS_WIRE_CHUNK_DELTA) || !c->payload ||
        c->elements > GS_WIRE_QUANT_CHUNK)
        return;
    (void)gs__delta_sum(c, NULL, gs__zero_k, out);
}

/* The index of the highest set bit of v (v != 0), from the top. */
GS__PRIVATE int gs__clz64(uint64_t v) {
#if defined(__GNUC__) || defined(__clang__)
    return __builtin_clzll(v);
#else
    int n = 0;
    while (!(v >> 63)) { v <<= 1; ++n; }
    return n;
#endif
}
/* The bit length of v < 2^63 (0 for 0): the top bit of 2v + 1, one bit
   scan and no test for 0. 63 ^ rather than 63 - (the same for 0..63): a
   compiler then sees the scan's index itself (bsr), no subtraction. */
GS__PRIVATE_INLINE int gs__bitlen64(uint64_t v) { return 63 ^ gs__clz64(v << 1 | 1u); }

/* What the coding choice (gs__delta_put) reads of n differences, made
   where the differences are (gs__qk_diff, the prediction's pass), not
   again: hist[L], the differences whose zigzag has L bits (33: 33 bits,
   past +-2^31; a zigzag is read in its low 33 bits, which are all of it
   for the differences a choice reads: the others are refused first); mx
   the largest zigzag, which gives the packed codings' widths (the bit
   lengths of mx and of mx - 1; hist[0] the zeros they leave out); and, for
   the spatial coding, its residuals e (NULL: not tried) and their sh. */
typedef struct gs__dstat {
    int hist[34], sh[34];
    uint64_t mx;
    const int64_t *e;
} gs__dstat;
GS__PRIVATE_INLINE void gs__dstat_add(gs__dstat *st, int64_t d) {
    uint64_t z = gs__zigzag(d);
    st->mx = z > st->mx ? z : st->mx;
    st->hist[gs__bitlen64(z & 0x1ffffffffull)]++;
}
/* The sum of the bit lengths a histogram counts: what a Rice run of the
   values costs, near enough to choose between two (33: at least). */
GS__PRIVATE long gs__hist_bits(const int *hist) {
    long b = 0;
    int L;
    for (L = 1; L < 34; ++L) b += (long)L * hist[L];
    return b;
}
/* The spatial coding's (3) residuals of n differences d into e and their
   bit lengths into sh (as gs__dstat's hist), counted as they are made:
   rows of `row` triples, the neighbours starting again at `restart`
   (gs__med3's comment's cases, a section's first triple, its first row and
   the rest, in loops of their own without its tests). The differences are
   within +-2^31, so a residual's zigzag has at most 33 bits (the mask
   keeps the count inside sh whatever it is given). The sum of their bit
   lengths. */
#define GS__SH_ADD(sh, e, i, x)                                                 \
    do {                                                                       \
        int64_t x_ = (x);                                                      \
        (e)[i] = x_;                                                           \
        (sh)[gs__bitlen64(gs__zigzag(x_) & 0x1ffffffffull)]++;                 \
    } while (0)
GS__PRIVATE long gs__spatial_stat(const int64_t *d, int n, int row, int restart, int64_t *e,
                                  int *sh) {
    int s, i, lo, hi, a, b, r3 = 3 * row;
    memset(sh, 0, 34 * sizeof *sh);
    for (s = 0; s < 2; ++s) {
        lo = s ? restart : 0;
        hi = !s && restart > 0 ? restart : n;
        if (s && restart <= 0) break;
        a = lo + 3 < hi ? lo + 3 : hi;
        b = lo + r3 + 3 < hi ? lo + r3 + 3 : hi;
        for (i = lo; i < a; ++i) GS__SH_ADD(sh, e, i, d[i]);
        for (; i < b; ++i) GS__SH_ADD(sh, e, i, d[i] - d[i - 3]);
        for (; i < hi; ++i) GS__SH_ADD(sh, e, i, d[i] - gs__med3(d[i - 3], d[i - r3], d[i - r3 - 3]));
    }
    return gs__hist_bits(sh);
}
#undef GS__SH_ADD

/* st's spatial part (row > 0: the residuals of n differences d into e)
   and the smaller of the plain and the spatial bit sums: what the coding
   choice compares, made once for it and for gs__delta_put. */
GS__PRIVATE long gs__dstat_bits(gs__dstat *st, const int64_t *d, int n, int row, int restart,
                                int64_t *e) {
    long plain = gs__hist_bits(st->hist), sp;
    if (!row) return plain;
    sp = gs__spatial_stat(d, n, row, restart, e, st->sh);
    st->e = e;
    return sp < plain ? sp : plain;
}

/* gs__dstat_bits with the differences' statistics in two parts: st's of
   the first `restart` (a chunk's positions) and tail's of the rest (the
   velocities), added into st here (tail NULL: st holds all, as
   gs__dstat_bits). The spatial residuals of each section are made apart
   (the neighbours start again at restart), tail's into tail->sh and e from
   restart on unless tail_made says they are there already (the plain
   candidate's, which the prediction leaves as they are: its e from
   restart on is then the caller's to copy). */
GS__PRIVATE long gs__dstat_split(gs__dstat *st, gs__dstat *tail, int tail_made, const int64_t *d,
                                 int n, int restart, int row, int64_t *e) {
    long plain, sp;
    int j;
    if (!tail) return gs__dstat_bits(st, d, n, row, restart, e);
    for (j = 0; j < 34; ++j) st->hist[j] += tail->hist[j];
    st->mx = tail->mx > st->mx ? tail->mx : st->mx;
    plain = gs__hist_bits(st->hist);
    if (!row) return plain;
    (void)gs__spatial_stat(d, restart, row, 0, e, st->sh);
    if (!tail_made) (void)gs__spatial_stat(d + restart, n - restart, row, 0, e + restart, tail->sh);
    for (j = 0; j < 34; ++j) st->sh[j] += tail->sh[j];
    st->e = e;
    sp = gs__hist_bits(st->sh);
    return sp < plain ? sp : plain;
}

/* A delta payload in the Rice coding of parameter k at p (room bytes,
   the head of hn bytes first): coding 2, or with row > 0 coding 3 (d
   then the residuals; said is 0 when kind bit 7 says its row and restart).
   Its size, or 0 if it does not fit. */
GS__PRIVATE size_t gs__delta_put_rice(unsigned char *p, size_t room, const gs_wire_chunk *c,
                                      const int64_t *d, const unsigned char *head, size_t hn,
                                      int k, int row, int restart, int said) {
    gs__bitw w;
    unsigned char *o, *end;
    uint64_t acc = 0, low = ((uint64_t)1 << k) - 1;
    int i, n = 0, over = 0;
    size_t at = hn + 1 + (row && said ? 2 : 0);
    if (at > room) return 0;
    memcpy(p, head, hn);
    p[hn] = (unsigned char)(k | (c->flags & GS_WIRE_CHUNK_PREDICT ? 0x20 : 0) | (row ? 3 : 2) << 6);
    if (row && said) {
        p[hn + 1] = (unsigned char)row;
        p[hn + 2] = (unsigned char)restart;
    }
    /* the writer in locals (as gs__quant_put_scalar), n < 32 bits held:
       a value's unary run, its 1 and its k low bits go in as one code of
       q + 1 + k bits when that is at most 32 (k <= 15 always), else in
       two; an escape as 16 zeros and 32 bits. The bits are gs__bitw_put's,
       in its order. */
    o = p + at;
    end = p + room;
    for (i = 0; i < c->elements; ++i) {
        uint64_t z = gs__zigzag(d[i]), q = z >> k;
        int len;
        if (q < GS__RICE_ESCAPE) {
            len = (int)q + 1 + k;
            if (len <= 32) {
                acc |= ((uint64_t)1 << q | (z & low) << (q + 1)) << n;
                n += len;
            } else {
                acc |= (uint64_t)1 << q << n;
                n += (int)q + 1;
                GS__BITS_OUT(o, end, acc, n, over);
                acc |= (z & low) << n;
                n += k;
            }
        } else {
            n += GS__RICE_ESCAPE;
            GS__BITS_OUT(o, end, acc, n, over);
            acc |= (z & 0xffffffffu) << n;
            n += 32;
        }
        GS__BITS_OUT(o, end, acc, n, over);
    }
    w.p = o; w.end = end; w.acc = acc; w.n = n; w.over = over;
    gs__bitw_flush(&w);
    return w.over ? 0 : (size_t)(w.p - p);
}

/* Writes a delta payload at p (room bytes): its size, or 0 if it does not
   fit. The differences are within +-2^31 (checked by the caller); st:
   what the choice reads of them (gs__dstat), NULL to make it here.
   same_row: the row kind bit 7 would say again (the chunk before's, c its
   next chunk; else 0); *row_out the spatial row written (0: another
   coding) and *row_said 0 when bit 7 says it instead. */
GS__PRIVATE size_t gs__delta_put(unsigned char *p, size_t room, const gs_wire_chunk *c,
                                 const int64_t *d, const gs__dstat *st, int same_base,
                                 int same_row, int *row_out, int *row_said) {
    unsigned char head[6];
    size_t hn = same_base ? 0 : gs__varint_put(head, (uint64_t)(uint32_t)(c->sequence - c->baseline));
    size_t need0, need1, need;
    int i, w0 = 0, w1 = 0, coding, wd, rk = 0, row = c->delta_row;
    double rbits;
    int64_t e[GS_WIRE_QUANT_CHUNK];
    gs__dstat own;
    if (row < 1 || row > GS_WIRE_SPATIAL_ROW) row = 0;
    *row_out = 0;
    *row_said = 1;
    if (!st) {
        memset(&own, 0, sizeof own);
        for (i = 0; i < c->elements; ++i) gs__dstat_add(&own, d[i]);
        (void)gs__dstat_bits(&own, d, c->elements, row, gs__spatial_restart(c), e);
        st = &own;
    }
    /* the widths of the OR of the zigzags and of the nonzero ones less 1:
       the bit lengths of the largest, and of it less 1 */
    w0 = gs__bitlen64(st->mx);
    w1 = st->mx ? gs__bitlen64(st->mx - 1) : 0;
    w0 = w0 < 32 ? w0 : 32;
    w1 = w1 < 32 ? w1 : 32;
    need0 = ((size_t)c->elements * (size_t)w0 + 7) / 8;
    need1 = ((size_t)c->elements + 7) / 8 +
            ((size_t)(c->elements - st->hist[0]) * (size_t)w1 + 7) / 8;
    coding = need1 < need0;
    wd = coding ? w1 : w0;
    rbits = gs__rice_pick(st->hist, c->elements, &rk);
    /* spatial, when its residuals (none past a Rice escape's 32 bits)
       and its row and restart (none when bit 7 says them) cost less than
       the rest */
    if (row && st->e && !st->sh[33]) {
        int sk, rs = gs__spatial_restart(c), said = !(row == same_row && rs == 0);
        double sbits = gs__rice_pick(st->sh, c->elements, &sk) / 8.0 + (said ? 2.0 : 0.0);
        if (sbits < (double)(coding ? need1 : need0) && sbits < rbits / 8.0) {
            *row_out = row;
            *row_said = said;
            return gs__delta_put_rice(p, room, c, st->e, head, hn, sk, row, rs, said);
        }
    }
    if ((c->flags & GS_WIRE_CHUNK_PREDICT) || rbits / 8.0 + 1.0 < (double)(coding ? need1 : need0))
        return gs__delta_put_rice(p, room, c, d, head, hn, rk, 0, 0, 1);
    need = hn + 1 + (coding ? need1 : need0);
    if (need > room) return 0;
    memcpy(p, head, hn);
    p[hn] = (unsigned char)(wd | coding << 6);
    /* the writer in locals (as gs__quant_put_scalar); need counts every
       bit, so the 32-bit stores stay inside it */
    {
        unsigned char *o = p + hn + 1;
        uint64_t acc = 0;
        int n = 0;
        if (coding) {
            size_t bm = ((size_t)c->elements + 7) / 8;
            memset(o, 0, bm);
            for (i = 0; i < c->elements; ++i)
                if (d[i]) o[i >> 3] = (unsigned char)(o[i >> 3] | 1u << (i & 7));
            o += bm;
        }
        for (i = 0; i < c->elements; ++i) {
            if (coding && !d[i]) continue;
            acc |= (gs__zigzag(d[i]) - (uint64_t)coding) << n;
            n += wd;
            if (n >= 32) {
                gs__put32(o, (uint32_t)acc);
                o += 4;
                acc >>= 32;
                n -= 32;
            }
        }
        for (; n > 0; n -= 8, acc >>= 8) *o++ = (unsigned char)acc;
    }
    return need;
}


/* ---- the header's fields, by name: nothing else reads or patches them ---- */
GS__PRIVATE unsigned gs__hdr_version(const unsigned char *b) { return b[4]; }
GS__PRIVATE unsigned gs__hdr_flags(const unsigned char *b) { return b[5]; }
GS__PRIVATE void gs__hdr_set_flags(unsigned char *b, unsigned f) { b[5] = (unsigned char)f; }
GS__PRIVATE int gs__hdr_chunks(const unsigned char *b) { return gs__get16(b + 6); }
GS__PRIVATE void gs__hdr_set_chunks(unsigned char *b, int n) { gs__put16(b + 6, (uint16_t)n); }
GS__PRIVATE uint32_t gs__hdr_session(const unsigned char *b) { return gs__get32(b + 8); }
GS__PRIVATE uint32_t gs__hdr_sender(const unsigned char *b) { return gs__get32(b + 12); }
/* The fields that differ per peer: its datagram sequence and the echo. */
GS__PRIVATE void gs__hdr_set_peer(unsigned char *b, uint32_t seq, double echo, double hold) {
    gs__put32(b + 16, seq);
    gs__putf64(b + 32, echo);
    gs__putf64(b + 40, hold);
}

GS_API gs_result gs_wire_begin(unsigned char *buf, size_t cap,
                               const gs_wire_header *h, size_t *size) {
    if (!buf || !h || !size || cap < GS_WIRE_HEADER + 4) return GS_ERR_INVALID_ARG;
    memcpy(buf, "GSIM", 4);
    buf[4] = GS_WIRE_VERSION;
    gs__hdr_set_flags(buf, h->sync & GS_WIRE_FLAG_SYNC);
    gs__hdr_set_chunks(buf, 0);
    gs__put32(buf + 8, h->session);
    gs__put32(buf + 12, h->sender);
    gs__put32(buf + 20, h->run);
    gs__putf64(buf + 24, h->send_time);
    gs__hdr_set_peer(buf, h->sequence, h->echo_time, h->echo_hold);
    *size = GS_WIRE_HEADER;
    return GS_OK;
}

/* A host whose doubles are little-endian IEEE 754 (x86-64, AArch64, the
   usual case) holds f64 values in the wire's own byte order: they go
   in and out by memcpy. Elsewhere, byte by byte. */
#if defined(__BYTE_ORDER__) && defined(__FLOAT_WORD_ORDER__) && \
    __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__ && __FLOAT_WORD_ORDER__ == __ORDER_LITTLE_ENDIAN__
#define GS__WIRE_LE 1
#endif

/* Writes n values at p in the encoding; 0 if one is NaN or infinite, or
   beyond float range in f32 (3.4e38: past it, inf). One loop per encoding,
   with the check folded in. */
GS__PRIVATE int gs__wire_put_values(unsigned char *p, gs_encoding e, const double *v, int n) {
    int i, ok = 1;
    if (e == GS_ENCODING_F32) {
        for (i = 0; i < n; ++i, p += 4) {
            ok &= gs__finite(v[i]) & (fabs(v[i]) <= 3.4028234663852886e38);
            gs__putf32(p, (float)(ok ? v[i] : 0.0));
        }
        return ok;
    }
    for (i = 0; i < n; ++i) ok &= gs__finite(v[i]);
#ifdef GS__WIRE_LE
    memcpy(p, v, (size_t)n * 8);
#else
    for (i = 0; i < n; ++i, p += 8) gs__putf64(p, v[i]);
#endif
    return ok;
}

/* Are n values all finite? A double is NaN or infinite when its exponent
   bits are all ones, and only then does adding one to them carry into the
   sign bit: an AND, an add and an OR a value, which vectorize (v - v ==
   0.0 took a compare and two flag reads each). */
GS__PRIVATE int gs__all_finite(const double *v, int n) {
    uint64_t top = 0;
    int i;
    for (i = 0; i < n; ++i) {
        uint64_t u;
        memcpy(&u, v + i, 8);
        top |= (u & 0x7ff0000000000000ull) + 0x0010000000000000ull;
    }
    return !(top >> 63);
}

/* The quantized payload of c at p, within room bytes: its size in *len.
   GS_ERR_CAPACITY if it does not fit. */
GS__PRIVATE gs_result gs__wire_put_quant(unsigned char *p, size_t room, const gs_wire_chunk *c,
                                         const double *values, size_t *len) {
    if (c->flags & GS_WIRE_CHUNK_REST) { *len = 0; return GS_OK; }
    if (!gs__all_finite(values, c->elements)) return GS_ERR_NOT_FINITE;
    if (!gs__quant_args_ok(c, values)) return GS_ERR_INVALID_ARG;
    *len = gs__quant_put(p, room, c, values);
    return *len ? GS_OK : GS_ERR_CAPACITY;
}

/* The chunk kinds (bits 0-1 of a chunk's first byte) and its flag bits. */
#define GS__KIND_VALUES 0u
#define GS__KIND_DELTA 1u
#define GS__KIND_REST 2u
#define GS__KIND_ACK 3u
#define GS__KIND_TIME 0x04u  /* a time follows; else the previous chunk's */
#define GS__KIND_SPLIT 0x20u /* index, count and first follow; else 0, 1, 0;
                                with GS__KIND_NEXT: the element count */
#define GS__KIND_NEXT 0x40u  /* the next chunk of the chunk before's snapshot */
#define GS__KIND_SAME_BASE 0x04u /* with GS__KIND_NEXT, a delta: the chunk
                                    before's baseline (its distance not said) */
#define GS__KIND_SAME_ROW 0x80u /* with GS__KIND_NEXT, a delta after a
                                   spatial one: coding 3, the chunk
                                   before's row, restart 0 (not said) */

/* The chunk flags of c as its kind (GS_WIRE_CHUNK_*: at most one). */
GS__PRIVATE unsigned gs__chunk_kind(const gs_wire_chunk *c) {
    return c->flags & GS_WIRE_CHUNK_DELTA ? GS__KIND_DELTA
           : c->flags & GS_WIRE_CHUNK_REST ? GS__KIND_REST
           : c->flags & GS_WIRE_CHUNK_ACK  ? GS__KIND_ACK
                                           : GS__KIND_VALUES;
}

/* Does c continue the chunk x says (its object, sequence and time, the
   next index of the same count, from the element after x's last)? Its
   header is then GS__KIND_NEXT's (see >>wire), and only that: encoder
   and decoder ask the same question. */
GS__PRIVATE int gs__chunk_is_next(const gs__wire_ctx *x, const gs_wire_chunk *c) {
    return x->any && c->object_id == x->id && c->sequence == x->seq &&
           memcmp(&c->time, &x->time, sizeof c->time) == 0 && c->count == x->count &&
           (uint32_t)c->index == (uint32_t)x->index + 1u &&
           (uint64_t)c->first == (uint64_t)x->first + x->elements;
}

/* Is delta chunk c, a next chunk, coded against the baseline of the chunk
   before (a delta too)? Its payload then leaves the distance out. */
GS__PRIVATE int gs__chunk_same_base(const gs__wire_ctx *x, const gs_wire_chunk *c) {
    return (c->flags & GS_WIRE_CHUNK_DELTA) && x->delta && c->baseline == x->baseline &&
           gs__chunk_is_next(x, c);
}

/* The header of c at p (at most GS_WIRE_CHUNK_HEADER bytes), coded
   against x; its length. */
GS__PRIVATE size_t gs__chunk_head(unsigned char *p, const gs__wire_ctx *x,
                                  const gs_wire_chunk *c) {
    unsigned kind = gs__chunk_kind(c), b = kind | (unsigned)c->encoding << 3;
    size_t n = 1;
    if (kind == GS__KIND_ACK) { /* the host it is for, and its entries */
        n += gs__varint_put(p + n, c->object_id);
        n += gs__varint_put(p + n, c->elements);
        p[0] = (unsigned char)b;
        return n;
    }
    if (kind != GS__KIND_REST && gs__chunk_is_next(x, c)) {
        b |= GS__KIND_NEXT | (gs__chunk_same_base(x, c) ? GS__KIND_SAME_BASE : 0u);
        if (c->elements != x->elements) {
            b |= GS__KIND_SPLIT;
            n += gs__varint_put(p + n, c->elements);
        }
        p[0] = (unsigned char)b;
        return n;
    }
    n += gs__varint_put(p + n, gs__zigzag32(c->object_id - x->id));
    n += gs__varint_put(p + n, gs__zigzag32(c->sequence - x->seq));
    if (!x->any || memcmp(&c->time, &x->time, sizeof c->time) != 0) {
        b |= GS__KIND_TIME;
        gs__putf64(p + n, c->time);
        n += 8;
    }
    if (c->index || c->count != 1 || c->first) {
        b |= GS__KIND_SPLIT;
        n += gs__varint_put(p + n, c->index);
        n += gs__varint_put(p + n, c->count);
        n += gs__varint_put(p + n, c->first);
    }
    if (kind != GS__KIND_REST) n += gs__varint_put(p + n, c->elements);
    p[0] = (unsigned char)b;
    return n;
}

/* The room left for a chunk's payload after *size bytes and its header of
   hn bytes (the checksum kept free), or an error: a *size that
   gs_wire_begin and gs_wire_add cannot have left (a wild one would wrap
   the room check), a datagram with GS_WIRE_MAX_CHUNKS chunks already or
   no room. */
GS__PRIVATE gs_result gs__wire_room(const unsigned char *buf, size_t cap, const size_t *size,
                                    size_t hn, size_t *room) {
    if (*size < GS_WIRE_HEADER || *size > cap || *size > GS_WIRE_MAX_DATAGRAM)
        return GS_ERR_INVALID_ARG;
    if (gs__hdr_chunks(buf) >= GS_WIRE_MAX_CHUNKS) return GS_ERR_CAPACITY;
    *room = cap < GS_WIRE_MAX_DATAGRAM ? cap : GS_WIRE_MAX_DATAGRAM;
    if (hn + 4 > *room - *size) return GS_ERR_CAPACITY;
    *room -= *size + hn + 4;
    return GS_OK;
}

/* x moved on to chunk c (not an acknowledgement). */
GS__PRIVATE void gs__wire_ctx_move(gs__wire_ctx *x, const gs_wire_chunk *c) {
    x->id = c->object_id;
    x->seq = c->sequence;
    x->time = c->time;
    x->any = 1;
    x->index = c->index;
    x->count = c->count;
    x->first = c->first;
    x->elements = c->elements;
    x->delta = (c->flags & GS_WIRE_CHUNK_DELTA) != 0;
    x->baseline = c->baseline;
    x->row = 0; /* a spatial delta's caller says its row after the move */
}

/* The chunk's header (head, hn bytes; its payload of vs bytes already
   written after it) at *size, the chunk counted and x moved on to it. */
GS__PRIVATE void gs__wire_put_head(unsigned char *buf, size_t *size, gs__wire_ctx *x,
                                   const gs_wire_chunk *c, const unsigned char *head, size_t hn,
                                   size_t vs) {
    memcpy(buf + *size, head, hn);
    *size += hn + vs;
    gs__hdr_set_chunks(buf, gs__hdr_chunks(buf) + 1);
    if (c->flags & GS_WIRE_CHUNK_ACK) return; /* it says no id, sequence or time */
    gs__wire_ctx_move(x, c);
}

GS__PRIVATE int gs__wire_chunk(const unsigned char *buf, size_t end, size_t *off,
                               gs__wire_ctx *x, gs_wire_chunk *c, int32_t *keep,
                               gs_reject *why);

/* The context of the chunk after the size bytes of the datagram in buf,
   read from its chunks (the public calls take no context: tests build
   datagrams a chunk at a time; the net keeps its own). 0 if those bytes
   are not a datagram gs_wire_begin and gs_wire_add can have left. */
GS__PRIVATE int gs__wire_scan(const unsigned char *buf, size_t cap, size_t size,
                              gs__wire_ctx *x) {
    gs_wire_chunk c;
    gs_reject why;
    size_t off = GS_WIRE_HEADER;
    int i, n;
    memset(x, 0, sizeof *x);
    if (size < GS_WIRE_HEADER || size > cap || size > GS_WIRE_MAX_DATAGRAM) return 0;
    n = gs__hdr_chunks(buf);
    for (i = 0; i < n; ++i)
        if (!gs__wire_chunk(buf, size, &off, x, &c, NULL, &why)) return 0;
    return off == size;
}

/* gs_wire_add with the context known. */
GS__PRIVATE gs_result gs__wire_add_in(unsigned char *buf, size_t cap, size_t *size,
                                      gs__wire_ctx *x, const gs_wire_chunk *c,
                                      const double *values) {
    unsigned char head[GS_WIRE_CHUNK_HEADER];
    size_t vs, room, hn;
    gs_result r;
    int rest;
    if (c->encoding != GS_ENCODING_F64 && c->encoding != GS_ENCODING_F32 &&
        c->encoding != GS_ENCODING_QUANT)
        return GS_ERR_INVALID_ARG;
    rest = (c->flags & GS_WIRE_CHUNK_REST) != 0;
    if ((c->flags & ~(unsigned)GS_WIRE_CHUNK_REST) || (rest && (c->elements || c->index)) ||
        c->count == 0 || c->index >= c->count)
        return GS_ERR_INVALID_ARG;
    if (!gs__finite(c->time)) return GS_ERR_NOT_FINITE;
    if (c->time < 0.0 || c->time > GS_WIRE_MAX_TIME) return GS_ERR_INVALID_ARG;
    hn = gs__chunk_head(head, x, c);
    r = gs__wire_room(buf, cap, size, hn, &room);
    if (r != GS_OK) return r;
    if (c->encoding != GS_ENCODING_QUANT && !rest &&
        gs__value_size(c->encoding) * c->elements > room)
        return GS_ERR_CAPACITY;
    /* the values first, checked as they are written: the bytes past *size
       are the caller's scratch until the chunk is counted below */
    if (c->encoding == GS_ENCODING_QUANT) {
        r = gs__wire_put_quant(buf + *size + hn, room, c, values, &vs);
        if (r != GS_OK) return r;
    } else {
        vs = rest ? 0 : gs__value_size(c->encoding) * c->elements;
        if (!gs__wire_put_values(buf + *size + hn, c->encoding, values, rest ? 0 : c->elements))
            return GS_ERR_NOT_FINITE;
    }
    gs__wire_put_head(buf, size, x, c, head, hn, vs);
    return GS_OK;
}

GS_API gs_result gs_wire_add(unsigned char *buf, size_t cap, size_t *size,
                             const gs_wire_chunk *c, const double *values) {
    gs__wire_ctx x;
    if (!buf || !size || !c || (c->elements && !values)) return GS_ERR_INVALID_ARG;
    if (!gs__wire_scan(buf, cap, *size, &x)) return GS_ERR_INVALID_ARG;
    return gs__wire_add_in(buf, cap, size, &x, c, values);
}

/* gs_wire_add_delta with the context known and the differences checked
   within [-2^31, 2^31 - 1] (the net's are, as it makes them); st: what
   the coding choice reads of them, or NULL (gs__delta_put). */
GS__PRIVATE gs_result gs__wire_add_delta_in(unsigned char *buf, size_t cap, size_t *size,
                                            gs__wire_ctx *x, const gs_wire_chunk *c,
                                            const int64_t *diff, const gs__dstat *st) {
    unsigned char head[GS_WIRE_CHUNK_HEADER];
    size_t vs, room, hn;
    uint32_t dist;
    gs_result r;
    int row, said, next;
    if (c->elements == 0 || c->elements > GS_WIRE_QUANT_CHUNK) return GS_ERR_INVALID_ARG;
    dist = c->sequence - c->baseline;
    if (c->encoding != GS_ENCODING_QUANT ||
        (c->flags & ~(unsigned)GS_WIRE_CHUNK_PREDICT) != GS_WIRE_CHUNK_DELTA || dist == 0 ||
        dist > 0x80000000u || c->count == 0 || c->index >= c->count)
        return GS_ERR_INVALID_ARG;
    if (!gs__finite(c->time)) return GS_ERR_NOT_FINITE;
    if (c->time < 0.0 || c->time > GS_WIRE_MAX_TIME) return GS_ERR_INVALID_ARG;
    hn = gs__chunk_head(head, x, c);
    r = gs__wire_room(buf, cap, size, hn, &room);
    if (r != GS_OK) return r;
    next = gs__chunk_is_next(x, c);
    vs = gs__delta_put(buf + *size + hn, room, c, diff, st, gs__chunk_same_base(x, c),
                       next ? x->row : 0, &row, &said);
    if (!vs) return GS_ERR_CAPACITY;
    if (!said) head[0] = (unsigned char)(head[0] | GS__KIND_SAME_ROW);
    gs__wire_put_head(buf, size, x, c, head, hn, vs);
    x->row = row;
    return GS_OK;
}

GS_API gs_result gs_wire_add_delta(unsigned char *buf, size_t cap, size_t *size,
                                   const gs_wire_chunk *c, const int64_t *diff) {
    gs__wire_ctx x;
    int i;
    if (!buf || !size || !c || !diff) return GS_ERR_INVALID_ARG;
    if (!gs__wire_scan(buf, cap, *size, &x)) return GS_ERR_INVALID_ARG;
    for (i = 0; i < c->elements && i < GS_WIRE_QUANT_CHUNK; ++i)
        if (diff[i] < -2147483648LL || diff[i] > 2147483647LL) return GS_ERR_INVALID_ARG;
    return gs__wire_add_delta_in(buf, cap, size, &x, c, diff, NULL);
}

/* gs_wire_add_ack with the context known. */
GS__PRIVATE gs_result gs__wire_add_ack_in(unsigned char *buf, size_t cap, size_t *size,
                                          gs__wire_ctx *x, uint32_t to, const gs_wire_ack *acks,
                                          int n) {
    unsigned char tmp[GS_WIRE_MAX_ACKS * 10], head[GS_WIRE_CHUNK_HEADER];
    uint32_t obj = 0, seq = 0;
    size_t len = 0, room, hn;
    gs_wire_chunk c;
    gs_result r;
    int i;
    if (n < 1 || n > GS_WIRE_MAX_ACKS) return GS_ERR_INVALID_ARG;
    for (i = 0; i < n; ++i) {
        len += gs__varint_put(tmp + len, gs__zigzag32(acks[i].object_id - obj) << 1 |
                                             (uint64_t)(acks[i].refused != 0));
        len += gs__varint_put(tmp + len, gs__zigzag32(acks[i].sequence - seq));
        obj = acks[i].object_id;
        seq = acks[i].sequence;
    }
    memset(&c, 0, sizeof c);
    c.object_id = to;
    c.count = 1;
    c.elements = (uint16_t)n;
    c.encoding = GS_ENCODING_QUANT;
    c.flags = GS_WIRE_CHUNK_ACK;
    hn = gs__chunk_head(head, x, &c);
    r = gs__wire_room(buf, cap, size, hn, &room);
    if (r != GS_OK) return r;
    if (len > room) return GS_ERR_CAPACITY;
    memcpy(buf + *size + hn, tmp, len);
    gs__wire_put_head(buf, size, x, &c, head, hn, len);
    return GS_OK;
}

GS_API gs_result gs_wire_add_ack(unsigned char *buf, size_t cap, size_t *size, uint32_t to,
                                 const gs_wire_ack *acks, int n) {
    gs__wire_ctx x;
    if (!buf || !size || !acks || n < 1 || n > GS_WIRE_MAX_ACKS) return GS_ERR_INVALID_ARG;
    if (!gs__wire_scan(buf, cap, *size, &x)) return GS_ERR_INVALID_ARG;
    return gs__wire_add_ack_in(buf, cap, size, &x, to, acks, n);
}

GS_API size_t gs_wire_end(unsigned char *buf, size_t size) {
    if (!buf) return 0;
    gs__put32(buf + size, gs__crc32(buf, size));
    return size + 4;
}

GS_API double gs_wire_value(const gs_wire_chunk *c, int i) {
    if (c->flags & GS_WIRE_CHUNK_ACK) return 0.0;
    if ((c->flags & GS_WIRE_CHUNK_DELTA) && c->delta_coding == 3) {
        int64_t d[GS_WIRE_QUANT_CHUNK];
        gs_wire_deltas(c, d);
        return (double)d[i];
    }
    if (c->flags & GS_WIRE_CHUNK_DELTA) {
        gs__dread d;
        int64_t v = 0;
        gs__dread_init(c, &d);
        for (; i >= 0; --i) v = gs__dread_next(&d);
        return (double)v;
    }
    if (c->encoding == GS_ENCODING_QUANT) return gs__quant_value(c, i);
    if (c->encoding == GS_ENCODING_F32) return (double)gs__getf32(c->payload + 4 * (size_t)i);
    return gs__getf64(c->payload + 8 * (size_t)i);
}

GS__PRIVATE void gs__wire_get_values(const gs_wire_chunk *c, double *out);
GS_API void gs_wire_values(const gs_wire_chunk *c, double *out) {
    if (c && out && c->elements) gs__wire_get_values(c, out);
}

/* Are a chunk's values all finite? A value is NaN or infinite when its
   exponent bits are all ones (f64: 11 bits in the top two bytes, f32: 8),
   read from the bytes without decoding the number. */
GS__PRIVATE int gs__wire_values_finite(const gs_wire_chunk *c) {
    const unsigned char *p = c->payload;
    int i, bad = 0;
    if (c->encoding == GS_ENCODING_QUANT) return 1; /* finite by construction */
    if (c->encoding == GS_ENCODING_F32) {
        for (i = 0; i < c->elements; ++i, p += 4)
            bad |= ((p[3] & 0x7f) << 1 | p[2] >> 7) == 0xff;
        return !bad;
    }
#ifdef GS__WIRE_LE
    for (i = 0; i < c->elements; ++i, p += 8) { /* whole words: the loop vectorizes */
        uint64_t u;
        memcpy(&u, p, 8);
        bad |= (u & 0x7ff0000000000000ull) == 0x7ff0000000000000ull;
    }
#else
    for (i = 0; i < c->elements; ++i, p += 8)
        bad |= ((p[7] & 0x7f) << 4 | p[6] >> 4) == 0x7ff;
#endif
    return !bad;
}

/* A decoded chunk's values into out (elements doubles). */
GS__PRIVATE void gs__wire_get_values(const gs_wire_chunk *c, double *out) {
    const unsigned char *p = c->payload;
    int i;
    if ((c->flags & GS_WIRE_CHUNK_DELTA) && c->delta_coding == 3) {
        int64_t d[GS_WIRE_QUANT_CHUNK];
        gs_wire_deltas(c, d);
        for (i = 0; i < c->elements; ++i) out[i] = (double)d[i];
        return;
    }
    if (c->flags & (GS_WIRE_CHUNK_DELTA | GS_WIRE_CHUNK_ACK)) {
        gs__dread d;
        if (c->flags & GS_WIRE_CHUNK_DELTA) gs__dread_init(c, &d);
        for (i = 0; i < c->elements; ++i)
            out[i] = c->flags & GS_WIRE_CHUNK_DELTA ? (double)gs__dread_next(&d) : 0.0;
        return;
    }
    if (c->encoding == GS_ENCODING_QUANT) { gs__quant_get(c, out); return; }
    if (c->encoding == GS_ENCODING_F32) {
        for (i = 0; i < c->elements; ++i, p += 4) out[i] = (double)gs__getf32(p);
        return;
    }
#ifdef GS__WIRE_LE
    (void)i;
    memcpy(out, p, (size_t)c->elements * 8);
#else
    for (i = 0; i < c->elements; ++i, p += 8) out[i] = gs__getf64(p);
#endif
}

/* A time the wire carries (s): in [0, GS_WIRE_MAX_TIME], NaN excluded. */
GS__PRIVATE int gs__wire_time_ok(double t) { return t >= 0.0 && t <= GS_WIRE_MAX_TIME; }

/* An unsigned LEB128 varint at *off of at most max bytes before end, at
   most top: 0 if cut short (*off then end), longer, or over. */
GS__PRIVATE int gs__head_varint(const unsigned char *buf, size_t end, size_t *off, int max,
                                uint64_t top, uint64_t *out) {
    const unsigned char *p = buf + *off;
    int ok = gs__varint_get(&p, buf + end, max, out);
    if (!ok && p == buf + end) *off = end;
    if (!ok || *out > top) return 0;
    *off = (size_t)(p - buf);
    return 1;
}

/* The header fields of the chunk at *off (see >>wire), against x. */
GS__PRIVATE int gs__chunk_head_get(const unsigned char *buf, size_t end, size_t *off,
                                   const gs__wire_ctx *x, gs_wire_chunk *c, unsigned *kind) {
    uint64_t id = 0, seq = 0, idx = 0, cnt = 1, first = 0, el = 0;
    unsigned b = buf[(*off)++], k = b & 3u;
    *kind = b;
    c->encoding = (gs_encoding)(b >> 3 & 3u);
    c->flags = k == GS__KIND_DELTA ? GS_WIRE_CHUNK_DELTA : k == GS__KIND_REST ? GS_WIRE_CHUNK_REST
               : k == GS__KIND_ACK ? GS_WIRE_CHUNK_ACK : 0u;
    if (c->encoding == 0) return 0;
    /* bit 7 only in the next chunk after a spatial delta, a delta */
    if ((b & GS__KIND_SAME_ROW) && (!(b & GS__KIND_NEXT) || k != GS__KIND_DELTA || !x->row))
        return 0;
    if (k == GS__KIND_ACK) {
        if (b & (GS__KIND_TIME | GS__KIND_SPLIT | GS__KIND_NEXT) ||
            c->encoding != GS_ENCODING_QUANT ||
            !gs__head_varint(buf, end, off, 5, 0xffffffffu, &id) ||
            !gs__head_varint(buf, end, off, 2, GS_WIRE_MAX_ACKS, &el) || el < 1)
            return 0;
        c->object_id = (uint32_t)id;
        c->sequence = 0;
        c->time = 0.0;
    } else if (b & GS__KIND_NEXT) {
        /* the chunk before's snapshot, its next chunk: only bit 5 (an
           element count of its own) may follow; past the snapshot's last
           chunk or its 2^32 elements, refused */
        if (((b & GS__KIND_SAME_BASE) && (k != GS__KIND_DELTA || !x->delta)) ||
            k == GS__KIND_REST || !x->any ||
            (uint32_t)x->index + 1u >= x->count ||
            (uint64_t)x->first + x->elements > 0xffffffffu)
            return 0;
        el = x->elements;
        if ((b & GS__KIND_SPLIT) &&
            (!gs__head_varint(buf, end, off, 2, 0xffff, &el) || el == x->elements))
            return 0; /* one meaning: the same count is not said again */
        c->object_id = x->id;
        c->sequence = x->seq;
        c->time = x->time;
        if (b & GS__KIND_SAME_BASE) c->baseline = x->baseline;
        idx = (uint64_t)x->index + 1u;
        cnt = x->count;
        first = (uint64_t)x->first + x->elements;
    } else {
        /* zigzag of a 32-bit difference: at most 2^32 - 1, so that a
           varint over it (5 bytes hold 35 bits) cannot wrap onto another
           id or sequence (one datagram, one meaning) */
        if (!gs__head_varint(buf, end, off, 5, 0xffffffffu, &id) ||
            !gs__head_varint(buf, end, off, 5, 0xffffffffu, &seq))
            return 0;
        c->object_id = x->id + (uint32_t)gs__unzigzag(id);
        c->sequence = x->seq + (uint32_t)gs__unzigzag(seq);
        if (b & GS__KIND_TIME) {
            if (*off + 8 > end) { *off = end; return 0; }
            c->time = gs__getf64(buf + *off);
            *off += 8;
            /* one meaning: a time is said only where it changes */
            if (x->any && memcmp(&c->time, &x->time, sizeof c->time) == 0) return 0;
        } else {
            if (!x->any) return 0; /* the first chunk says its time */
            c->time = x->time;
        }
        if ((b & GS__KIND_SPLIT) &&
            (!gs__head_varint(buf, end, off, 3, 0xffff, &idx) ||
             !gs__head_varint(buf, end, off, 3, 0xffff, &cnt) ||
             !gs__head_varint(buf, end, off, 5, 0xffffffffu, &first) || idx >= cnt ||
             (idx == 0 && cnt == 1 && first == 0))) /* one meaning: not split */
            return 0;
        if (k != GS__KIND_REST && !gs__head_varint(buf, end, off, 2, 0xffff, &el)) return 0;
        c->index = (uint16_t)idx;
        c->count = (uint16_t)cnt;
        c->first = (uint32_t)first;
        /* one meaning: a chunk that continues the one before says so */
        if (k != GS__KIND_REST && gs__chunk_is_next(x, c)) return 0;
    }
    c->index = (uint16_t)idx;
    c->count = (uint16_t)cnt;
    c->first = (uint32_t)first;
    c->elements = (uint16_t)el;
    return 1;
}

/* One chunk at *off, coded against x (moved on to it): its header, its
   payload (whose length its contents imply), its values all finite. keep:
   as gs__delta_parse's. */
GS__PRIVATE int gs__wire_chunk(const unsigned char *buf, size_t end, size_t *off,
                               gs__wire_ctx *x, gs_wire_chunk *c, int32_t *keep,
                               gs_reject *why) {
    size_t len, avail;
    unsigned kind, b;
    c->segment_count = 0;
    c->baseline = 0;
    c->delta_coding = c->delta_width = 0;
    c->delta_skip = c->delta_data = 0;
    if (*off >= end) { *why = GS_REJECT_SHORT; return 0; }
    if (!gs__chunk_head_get(buf, end, off, x, c, &b)) {
        /* cut short where the bytes ran out, else inconsistent */
        *why = *off >= end ? GS_REJECT_SHORT : GS_REJECT_LAYOUT;
        return 0;
    }
    kind = b & 3u;
    if ((kind == GS__KIND_DELTA && c->encoding != GS_ENCODING_QUANT) ||
        (kind == GS__KIND_REST && c->index)) { *why = GS_REJECT_LAYOUT; return 0; }
    if (!gs__wire_time_ok(c->time)) { *why = GS_REJECT_TIME; return 0; }
    c->payload = buf + *off;
    avail = end - *off;
    if (kind == GS__KIND_REST) {
        len = 0;
    } else if (kind == GS__KIND_VALUES && c->encoding != GS_ENCODING_QUANT) {
        len = gs__value_size(c->encoding) * c->elements;
        if (len > avail) { *why = GS_REJECT_SHORT; return 0; }
    } else {
        len = kind == GS__KIND_DELTA
                  ? gs__delta_parse(c, c->payload, avail,
                                    (b & GS__KIND_NEXT) && (b & GS__KIND_SAME_BASE),
                                    (b & GS__KIND_SAME_ROW) != 0,
                                    (b & GS__KIND_NEXT) ? x->row : 0, keep)
              : kind == GS__KIND_ACK ? gs__ack_parse(c, c->payload, avail)
                                     : gs__quant_parse(c, c->payload, avail);
        if (!len) { *why = GS_REJECT_LAYOUT; return 0; }
        /* one meaning: the chunk before's baseline is not said again */
        if (kind == GS__KIND_DELTA && !(b & GS__KIND_SAME_BASE) && gs__chunk_same_base(x, c)) {
            *why = GS_REJECT_LAYOUT;
            return 0;
        }
    }
    c->payload_bytes = (uint16_t)len;
    if (!gs__wire_values_finite(c)) { *why = GS_REJECT_NOT_FINITE; return 0; }
    *off += len;
    if (kind != GS__KIND_ACK) gs__wire_ctx_move(x, c);
    if (kind == GS__KIND_DELTA && c->delta_coding == 3) x->row = c->delta_row;
    return 1;
}

/* The checks that need neither the checksum, the key nor the payload:
   size, magic, version. */
GS__PRIVATE int gs__wire_front(const unsigned char *buf, size_t size, gs_reject *why) {
    if (!buf || size < GS_WIRE_HEADER + 4) { *why = GS_REJECT_SHORT; return 0; }
    if (size > GS_WIRE_MAX_DATAGRAM) { *why = GS_REJECT_LAYOUT; return 0; }
    if (memcmp(buf, "GSIM", 4) != 0) { *why = GS_REJECT_MAGIC; return 0; }
    if (gs__hdr_version(buf) == 1 || gs__hdr_version(buf) == 2) {
        *why = GS_REJECT_OLD_VERSION;
        return 0;
    }
    if (gs__hdr_version(buf) != GS_WIRE_VERSION) { *why = GS_REJECT_VERSION; return 0; }
    return 1;
}

/* The header's fields and the chunks in [GS_WIRE_HEADER, end) of a
   datagram in clear (checked or opened); kept (NULL: none) takes its Rice
   values. */
GS__PRIVATE int gs__wire_parse(const unsigned char *buf, size_t end, gs_wire_view *out,
                               gs__kept *kept, gs_reject *why) {
    size_t off = GS_WIRE_HEADER;
    gs__wire_ctx x;
    int i, n = gs__hdr_chunks(buf);
    if (n < 1 || n > GS_WIRE_MAX_CHUNKS) { *why = GS_REJECT_LAYOUT; return 0; }
    out->header.session = gs__get32(buf + 8);
    out->header.sender = gs__get32(buf + 12);
    out->header.sequence = gs__get32(buf + 16);
    out->header.run = gs__get32(buf + 20);
    out->header.send_time = gs__getf64(buf + 24);
    out->header.echo_time = gs__getf64(buf + 32);
    out->header.echo_hold = gs__getf64(buf + 40);
    out->header.sync = gs__hdr_flags(buf) & GS_WIRE_FLAG_SYNC;
    if (!gs__finite(out->header.send_time) || !gs__finite(out->header.echo_time) ||
        !gs__finite(out->header.echo_hold)) { *why = GS_REJECT_NOT_FINITE; return 0; }
    /* both are clocks, which no host lets leave [0, GS_WIRE_MAX_TIME]: a
       send time out there (-1e300) would make an age of any size */
    if (!gs__wire_time_ok(out->header.send_time) || !gs__wire_time_ok(out->header.echo_time)) {
        *why = GS_REJECT_TIME;
        return 0;
    }
    memset(&x, 0, sizeof x);
    if (kept) kept->used = 0;
    for (i = 0; i < n; ++i) {
        gs_wire_chunk *c = &out->chunks[i];
        int32_t *keep = kept && kept->used <= GS__KEPT_VALUES - GS_WIRE_QUANT_CHUNK
                            ? kept->v + kept->used : NULL;
        if (!gs__wire_chunk(buf, end, &off, &x, c, keep, why)) return 0;
        if (kept) kept->at[i] = NULL;
        if (keep && (c->flags & GS_WIRE_CHUNK_DELTA) && c->delta_coding >= 2) {
            kept->at[i] = keep;
            kept->used += c->elements;
        }
    }
    if (off != end) { *why = GS_REJECT_LAYOUT; return 0; }
    out->chunk_count = n;
    return 1;
}

/* 1: decoded into *out; 0: refused for *why (the net's path). */
GS__PRIVATE int gs__wire_decode(const unsigned char *buf, size_t size,
                                gs_wire_view *out, gs__kept *kept, gs_reject *why) {
    size_t end;
    if (!gs__wire_front(buf, size, why)) return 0;
    end = size - 4;
    if (gs__crc32(buf, end) != gs__get32(buf + end)) { *why = GS_REJECT_CHECKSUM; return 0; }
    if (gs__hdr_flags(buf) & ~(unsigned)GS_WIRE_FLAG_SYNC) { /* sealed or unknown */
        *why = GS_REJECT_LAYOUT;
        return 0;
    }
    return gs__wire_parse(buf, end, out, kept, why);
}

GS_API gs_result gs_wire_decode(const unsigned char *buf, size_t size,
                                gs_wire_view *out, gs_reject *why) {
    gs_reject dummy;
    if (!why) why = &dummy;
    if (!out || !buf) { *why = GS_REJECT_SHORT; return GS_ERR_INVALID_ARG; }
    return gs__wire_decode(buf, size, out, NULL, why) ? GS_OK : GS_ERR_REJECTED;
}

/* The nonce of a sealed datagram: run epoch, run salt, counter. */
GS__PRIVATE void gs__wire_nonce(unsigned char *p, uint64_t epoch, uint64_t salt,
                                uint64_t counter) {
    gs__put64(p, epoch);
    gs__put64(p + 8, salt);
    gs__put64(p + 16, counter);
}
GS__PRIVATE void gs__wire_nonce_read(const unsigned char *p, uint64_t *epoch, uint64_t *salt,
                                     uint64_t *counter) {
    *epoch = gs__get64(p);
    *salt = gs__get64(p + 8);
    *counter = gs__get64(p + 16);
}

#ifdef GHOSTSIM_SODIUM
/* Seals a datagram of `size` bytes (header and chunks, no CRC; cap leaves
   room for the trailer): the flag, the chunks encrypted in place, the
   nonce and the tag. Returns the sealed size. */
GS__PRIVATE size_t gs__wire_seal(unsigned char *buf, size_t size, const unsigned char *key,
                                 uint64_t epoch, uint64_t salt, uint64_t counter) {
    unsigned long long taglen = 0;
    /* before: the header is authenticated */
    gs__hdr_set_flags(buf, gs__hdr_flags(buf) | GS_WIRE_FLAG_SEALED);
    gs__wire_nonce(buf + size, epoch, salt, counter);
    crypto_aead_xchacha20poly1305_ietf_encrypt_detached(
        buf + GS_WIRE_HEADER, buf + size + GS_WIRE_NONCE_BYTES, &taglen, buf + GS_WIRE_HEADER,
        (unsigned long long)(size - GS_WIRE_HEADER), buf, GS_WIRE_HEADER, NULL, buf + size, key);
    return size + GS_WIRE_SEAL_TRAILER;
}

/* Authenticates a sealed datagram and decrypts it into out (the header
   copied, then the chunks in clear). 0 if forged, tampered or sealed under
   another key: then out holds nothing of it. */
GS__PRIVATE int gs__wire_open(const unsigned char *buf, size_t size, const unsigned char *key,
                              unsigned char *out) {
    size_t end = size - GS_WIRE_SEAL_TRAILER;
    memcpy(out, buf, GS_WIRE_HEADER);
    return crypto_aead_xchacha20poly1305_ietf_decrypt_detached(
               out + GS_WIRE_HEADER, NULL, buf + GS_WIRE_HEADER,
               (unsigned long long)(end - GS_WIRE_HEADER), buf + end + GS_WIRE_NONCE_BYTES, buf,
               GS_WIRE_HEADER, buf + end, key) == 0;
}
#endif

/* ========================================================================
   >>net
   ======================================================================== */
/* The key and this run's nonce prefix: the wall clock in microseconds
   orders a peer's runs, the random salt keeps nonces apart should the clock
   step back. */
GS__PRIVATE void gs__net_keep_key(gs_net *net, const unsigned char *key) {
#ifdef GHOSTSIM_SODIUM
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    net->guard.keyed = 1;
    memcpy(net->guard.key, key, GS_WIRE_KEY_BYTES);
    net->guard.epoch = (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
    randombytes_buf(&net->guard.salt, sizeof net->guard.salt);
#else
    (void)net;
    (void)key;
#endif
}

GS__PRIVATE void gs__net_forget_key(gs_net *net) {
#ifdef GHOSTSIM_SODIUM
    sodium_memzero(net->guard.key, sizeof net->guard.key);
    sodium_memzero(net->guard.plain, sizeof net->guard.plain);
    sodium_memzero(net->guard.sealed, sizeof net->guard.sealed);
#else
    (void)net;
#endif
}

/* Room in net->order for every ghost of the world (allocated here, at
   attach or create, so that gs_net_update allocates nothing). */
GS__PRIVATE gs_result gs__net_order_room(gs_net *net) {
    gs_world *w = net->world;
    int i, ghosts = 0, cap;
    struct gs__ghost **o;
    for (i = 0; i < w->agent_count; ++i) ghosts += gs__ghost_of(w->agents[i]) != NULL;
    if (ghosts <= net->order_cap) return GS_OK;
    cap = ghosts < 8 ? 16 : 2 * ghosts;
    o = (struct gs__ghost **)gs__alloc(w, (size_t)cap * sizeof *o);
    if (!o) return gs__fail(w, GS_ERR_NO_MEMORY, "net: out of memory for the send order");
    gs__free(w, net->order);
    net->order = o;
    net->order_cap = cap;
    return GS_OK;
}

GS__PRIVATE gs_result gs__ghost_queues(gs__ghost *g) {
    gs_net *net = g->agent->world->net;
    int p;
    if (!net) return GS_OK;
    if (gs__net_order_room(net) != GS_OK) return GS_ERR_NO_MEMORY;
    for (p = 0; p < GS__MAX_PEERS; ++p)
        if (net->peers[p].used) {
            gs_result r = gs__ghost_add_peer(g, p);
            if (r != GS_OK) return r;
        }
    return GS_OK;
}

/* This run's number: different at each start of a peer, so that its peers
   see it started again (its datagram sequence starts again too). Not a
   secret and not an order, only different: the wall clock's seconds, the
   CPU time used so far and where the net lives (which address-space
   randomization moves at each start) mixed together; never 0. */
GS__PRIVATE uint32_t gs__net_run(const gs_net *net) {
    uint64_t x = (uint64_t)time(NULL) ^ (uint64_t)clock() << 24 ^ (uint64_t)(uintptr_t)net;
    x ^= x >> 33;
    x *= 0xff51afd7ed558ccdull; /* the splitmix64 / murmur3 finalizer */
    x ^= x >> 33;
    return (uint32_t)x ? (uint32_t)x : 1u;
}

/* ---- diagnostics: what a user reads when hosts do not meet (see
   gs_peer_health). Counted as datagrams come and go; judged, and the
   text made, only when gs_net_peer_stats is asked. ---- */

GS_API const char *gs_peer_health_str(gs_peer_health h) {
    switch (h) {
#define GS__PEER_HEALTH_CASE(name, text) case name: return text;
        GS__PEER_HEALTH_LIST(GS__PEER_HEALTH_CASE)
#undef GS__PEER_HEALTH_CASE
    default: return "unknown";
    }
}

/* The enum's name of a reason ("GS_REJECT_RANGE"), for the reason text. */
GS__PRIVATE const char *gs__reject_name(gs_reject r) {
    switch (r) {
#define GS__REJECT_NAME(name, text) case name: return #name;
        GS__REJECT_LIST(GS__REJECT_NAME)
#undef GS__REJECT_NAME
    default: return "GS_REJECT_?";
    }
}

GS__PRIVATE void gs__diag_added(gs__peer_diag *d) {
    memset(d, 0, sizeof *d);
    d->added_at = d->sent_at = d->taken_at = d->win_at = -1.0;
}

/* Every `now` the net is given: the steps back, and the time a peer added
   since the last one was added at. A clock that keeps going back counts
   once, until it is past its old reading again. */
GS__PRIVATE void gs__diag_clock(gs_net *net, double now) {
    int p;
    if (net->clock_max < 0.0 || now >= net->clock_max) {
        net->clock_max = now;
        net->clock_behind = 0;
    } else if (now < net->clock_max - GS_CLOCK_SLACK) {
        double back = net->clock_max - now;
        if (!net->clock_behind) {
            net->clock_backwards++;
            net->clock_back_from = net->clock_max;
            net->clock_back_to = now;
        }
        if (now < net->clock_back_to) net->clock_back_to = now;
        net->clock_behind = 1;
        if (back > net->clock_back_max) net->clock_back_max = back;
    }
    if (net->update_now < 0.0) net->update_now = now;
    if (!net->peer_added) return;
    net->peer_added = 0;
    for (p = 0; p < GS__MAX_PEERS; ++p)
        if (net->peers[p].used && net->peers[p].diag.added_at < 0.0)
            net->peers[p].diag.added_at = now;
}

/* Moves a peer's windows on to the one that holds `now` (whole windows of
   GS_PEER_QUIET: the one before is kept only if it ended as this began). */
GS__PRIVATE void gs__diag_roll(gs__peer_diag *d, double now) {
    double k;
    if (d->win_at < 0.0 || now < d->win_at) { /* the first, or a clock back */
        if (d->win_at < 0.0) d->win_at = now;
        return;
    }
    k = floor((now - d->win_at) / GS_PEER_QUIET);
    if (k < 1.0) return;
    if (k < 2.0) d->win[1] = d->win[0];
    else memset(&d->win[1], 0, sizeof d->win[1]);
    memset(&d->win[0], 0, sizeof d->win[0]);
    d->win_at += k * GS_PEER_QUIET;
}

/* An advance of the world by `seconds` (its hook, as the sync layer's):
   the net counts them until its next update. Under the net lock: gs_udp's
   scatter thread updates. */
GS__PRIVATE void gs__diag_taken(gs__peer_diag *d, double now) {
    gs__diag_roll(d, now);
    d->win[0].taken++;
    d->taken_at = now;
}

GS__PRIVATE void gs__mismatch_note(gs_net *net, gs__mismatch what, uint32_t object, long here,
                                   long there, int there_min) {
    net->detail.what = what;
    net->detail.object = object;
    net->detail.here = here;
    net->detail.there = there;
    net->detail.there_min = there_min;
}

/* A chunk that does not fit its object's state: the state sizes (the
   sender's is known exactly from its last chunk, at least from another),
   or the encodings. */
GS__PRIVATE void gs__range_note(gs_net *net, const gs__ghost *g, const gs_wire_chunk *c) {
    if (c->encoding != g->d.encoding) {
        gs__mismatch_note(net, GS__MISMATCH_ENCODING, g->d.object_id, (long)g->d.encoding,
                          (long)c->encoding, 0);
        return;
    }
    gs__mismatch_note(net, GS__MISMATCH_VALUES, g->d.object_id, (long)(g->n - 1),
                      (long)(c->first + c->elements), c->index + 1 < c->count);
}

GS__PRIVATE int gs__peer_slot(const gs_net *net, uint32_t host);

/* A refused datagram, on the window of the peer it names: p, or while the
   sender was not known yet (the session, a checksum: counted among the
   unknown ones) the peer the header names, if it is one. */
GS__PRIVATE void gs__diag_refused(gs_net *net, int p, gs_reject r, const unsigned char *buf,
                                  size_t size, double now) {
    gs__diag_win *win;
    if (p < 0 && buf && size >= GS_WIRE_HEADER && memcmp(buf, "GSIM", 4) == 0 &&
        gs__hdr_version(buf) == GS_WIRE_VERSION) {
        p = gs__peer_slot(net, gs__hdr_sender(buf));
        if (p >= 0 && r == GS_REJECT_CHECKSUM && (gs__hdr_flags(buf) & GS_WIRE_FLAG_SEALED) &&
            !net->guard.keyed)
            net->detail.what = GS__MISMATCH_SEALED;
    }
    if (p < 0) return;
    gs__diag_roll(&net->peers[p].diag, now);
    win = &net->peers[p].diag.win[0];
    if (win->refused++ == 0) {
        win->reasons = 1;
        win->reason = r;
        win->detail = net->detail;
    } else if (r != win->reason) {
        win->reasons = 2;
    }
    if ((r == GS_REJECT_OBJECT || r == GS_REJECT_RANGE) && win->mismatched++ == 0 &&
        win->reason != r) { /* the one to tell, whatever came first */
        win->reason = r;
        win->detail = net->detail;
    }
}

GS__PRIVATE const char *gs__encoding_name(long e) {
    return e == GS_ENCODING_F32 ? "f32" : e == GS_ENCODING_QUANT ? "quant" : "f64";
}

/* What a refusal did not match, as a clause after ": " ("" if nothing). */
GS__PRIVATE void gs__detail_text(const gs__detail *d, char *buf, size_t cap) {
    unsigned long o = (unsigned long)d->object;
    switch (d->what) {
    case GS__MISMATCH_OBJECT:
        snprintf(buf, cap, ": object %lu has no ghost here (every host ghosts the same "
                 "objects under the same ids)", o);
        break;
    case GS__MISMATCH_VALUES:
        snprintf(buf, cap, ": object %lu's state has %ld values here, %s%ld in the datagram "
                 "(another cloth size or kind of object under this id?)", o, d->here,
                 d->there_min ? "at least " : "", d->there);
        break;
    case GS__MISMATCH_ENCODING:
        snprintf(buf, cap, ": object %lu is sent in %s here, in %s in the datagram (its "
                 "ghosts need one encoding)", o, gs__encoding_name(d->here),
                 gs__encoding_name(d->there));
        break;
    case GS__MISMATCH_SESSION:
        snprintf(buf, cap, ": session %ld in the datagram, %ld here (gs_net_desc.session)",
                 d->there, d->here);
        break;
    case GS__MISMATCH_SEALED:
        snprintf(buf, cap, ": sealed under a key, and this net has none (gs_net_desc.key)");
        break;
    default:
        buf[0] = '\0';
    }
}

/* The window that says how the last full GS_PEER_QUIET s went at time t,
   NULL when none does (nothing came in it). */
GS__PRIVATE const gs__diag_win *gs__diag_last(const gs__peer_diag *d, double t) {
    double since = t - d->win_at;
    if (d->win_at < 0.0) return NULL;
    if (since >= 2.0 * GS_PEER_QUIET) return NULL;
    return since >= GS_PEER_QUIET ? &d->win[0] : &d->win[1];
}

GS__PRIVATE int gs__world_ghosts(const gs_world *w) {
    int i, n = 0;
    for (i = 0; i < w->agent_count; ++i) n += w->agents[i]->ghost != NULL;
    return n;
}

/* The sender's sync in a header's flags (GS_WIRE_FLAG_SYNC). */
GS__PRIVATE unsigned gs__net_sync_flags(const gs_world *w) {
    return (gs__sync_session(w) ? GS_WIRE_FLAG_SESSION : 0u) |
           (gs__sync_replay(w) ? GS_WIRE_FLAG_REPLAY : 0u);
}

/* What GS_WIRE_FLAG_SYNC says, for a peer's health reason. */
GS__PRIVATE const char *gs__sync_flags_name(unsigned f) {
    switch (f & GS_WIRE_FLAG_SYNC) {
    case GS_WIRE_FLAG_SESSION: return "the present blend on the session clock";
    case GS_WIRE_FLAG_REPLAY: return "the replay blend on its local clock";
    case GS_WIRE_FLAG_SYNC: return "the replay blend on the session clock";
    default: return "the present blend on its local clock";
    }
}

/* The first health that holds (see gs_peer_health) and its text. */
GS__PRIVATE gs_peer_health gs__peer_judge(const gs_net *net, int p, char *buf, size_t cap) {
    const gs__peer_diag *d = &net->peers[p].diag;
    const gs_world *w = net->world;
    double t = net->clock_max, since_world = net->unsent_world;
    double added = d->added_at >= 0.0 ? fmax(0.0, t - d->added_at) : 0.0;
    double unsent = d->sent_at >= 0.0 ? fmax(0.0, t - d->sent_at) : added;
    double unheard = d->taken_at >= 0.0 ? fmax(0.0, t - d->taken_at) : added;
    const gs__diag_win *win = gs__diag_last(d, t);
    char more[160];
    if (since_world >= GS_PEER_QUIET) {
        snprintf(buf, cap, "nothing sent: gs_net_update has not run for %.1f s of world time "
                 "(%s; call it each frame after gs_world_advance, or gs_net_poll)",
                 since_world, net->updated ? "since its last call" : "never called");
        return GS_PEER_NO_UPDATE;
    }
    if (net->clock_backwards && (net->clock_behind ||
                                 net->clock_max - net->clock_back_from < GS_PEER_QUIET)) {
        snprintf(buf, cap, "the clock went back %.3f s (from %.3f s to %.3f s; %lu time%s so "
                 "far): gs_net_update, gs_net_deliver and gs_net_poll need one clock that only "
                 "moves forward (gs_udp receives at gs_udp_now())",
                 net->clock_back_from - net->clock_back_to, net->clock_back_from,
                 net->clock_back_to, (unsigned long)net->clock_backwards,
                 net->clock_backwards == 1 ? "" : "s");
        return GS_PEER_CLOCK_BACK;
    }
    if (t - net->update_now >= GS_PEER_QUIET) {
        snprintf(buf, cap, "nothing sent: gs_net_update has not run for %.1f s (%s; "
                 "gs_net_deliver has; call it each frame, or gs_net_poll)",
                 t - net->update_now, net->updated ? "since its last call" : "never called");
        return GS_PEER_NO_UPDATE;
    }
    if (net->updated && unsent >= GS_PEER_QUIET) {
        int ghosts = gs__world_ghosts(w);
        if (ghosts == 0)
            snprintf(buf, cap, "nothing sent to this peer for %.1f s: this world has no ghosts "
                     "(gs_ghost_attach or gs_scene_attach_ghosts), so it has nothing to send",
                     unsent);
        else
            snprintf(buf, cap, "nothing sent to this peer for %.1f s, though gs_net_update runs "
                     "and %d ghosts are attached (a bandwidth below one datagram?)", unsent,
                     ghosts);
        return GS_PEER_NOT_SENDING;
    }
    if (win && win->refused > 0 && win->taken == 0) {
        gs__detail_text(&win->detail, more, sizeof more);
        /* the detail's first 90 characters (it names the object and both
           sizes well within them): a bound gcc can see fits the buffer */
        snprintf(buf, cap, "all %lu datagrams from this peer in the last %g s refused%s: %s "
                 "(%s)%.90s", (unsigned long)win->refused, GS_PEER_QUIET,
                 win->reasons > 1 ? ", for more than one reason, the first" : "",
                 gs__reject_name(win->reason), gs_reject_str(win->reason), more);
        return GS_PEER_REFUSED;
    }
    if (unheard >= GS_PEER_QUIET) {
        if (d->taken_at < 0.0)
            snprintf(buf, cap, "nothing received from this peer in the %.1f s since it was "
                     "added: does it run and call gs_net_update (or gs_net_poll), has it added "
                     "this host (%lu) as a peer, and does the link reach it?", unheard,
                     (unsigned long)w->host_id);
        else
            snprintf(buf, cap, "nothing received from this peer for %.1f s: it stopped, or "
                     "stopped updating, or the link is down", unheard);
        return GS_PEER_SILENT;
    }
    if (d->taken_at >= 0.0 && d->sync != gs__net_sync_flags(w)) {
        snprintf(buf, cap, "this peer runs %s, this host %s: hosts that blend at different "
                 "times do not agree while objects move (every host of a session needs the same "
                 "gs_sync_desc mode and clock)", gs__sync_flags_name(d->sync),
                 gs__sync_flags_name(gs__net_sync_flags(w)));
        return GS_PEER_OTHER_MODE;
    }
    if (win && win->mismatched > 0) {
        gs__detail_text(&win->detail, more, sizeof more);
        snprintf(buf, cap, "%lu of the %lu datagrams from this peer in the last %g s refused "
                 "as %s%s", (unsigned long)win->mismatched,
                 (unsigned long)(win->taken + win->refused), GS_PEER_QUIET,
                 gs__reject_name(win->reason), more);
        return GS_PEER_PARTLY_REFUSED;
    }
    if (d->taken_at < 0.0) {
        snprintf(buf, cap, "added %.1f s ago; nothing received from it yet", added);
        return GS_PEER_WAITING;
    }
    buf[0] = '\0';
    return GS_PEER_OK;
}

GS_API gs_net_desc gs_net_desc_default(void) {
    gs_net_desc d;
    memset(&d, 0, sizeof d);
    d.session = 1;
    d.bandwidth = 1e7;
    d.max_peers = GS__MAX_PEERS;
    return d;
}

GS__PRIVATE void gs__net_free(gs_world *w, gs_net *net);

GS_API gs_result gs_net_create(gs_world *w, const gs_net_desc *desc,
                               gs_net **out) {
    gs__check c;
    gs_net_desc d;
    gs_net *net;
    gs_result r = gs__world_unlocked(w, "gs_net_create");
    if (out) *out = NULL;
    if (r != GS_OK) return r;
    c = gs__check_begin(w, "gs_net_create");
    if (!desc || !out) gs__check_fail(&c, GS_ERR_INVALID_ARG, "desc and out are required");
    else if (w->net) gs__check_fail(&c, GS_ERR_INVALID_ARG, "the world has a net already");
    if (c.r != GS_OK) return c.r;
    d = *desc;
    if (d.session == 0) d.session = gs_net_desc_default().session;
    if (d.bandwidth == 0.0) d.bandwidth = gs_net_desc_default().bandwidth;
    if (d.max_peers == 0) d.max_peers = gs_net_desc_default().max_peers;
    /* divided first: a bandwidth near DBL_MAX must not make it inf */
    if (d.max_rate == 0.0 && gs__finite(d.bandwidth))
        d.max_rate = fmax(20000.0, 2.0 * (d.bandwidth / GS_WIRE_MAX_DATAGRAM));
    if (!d.transport.send)
        gs__check_fail(&c, GS_ERR_INVALID_ARG, "transport.send is NULL (fill the transport "
                       "with gs_simnet_transport, gs_udp_transport or your own send)");
    gs__check_positive(&c, "bandwidth", d.bandwidth);
    gs__check_nonneg(&c, "time_window", d.time_window);
    gs__check_int(&c, "max_peers", d.max_peers, 1, GS__MAX_PEERS);
    gs__check_positive(&c, "max_rate", d.max_rate);
#ifndef GHOSTSIM_SODIUM
    if (d.key) gs__check_fail(&c, GS_ERR_UNSUPPORTED, "a key is set, but ghostsim was built "
                              "without GHOSTSIM_SODIUM: no encryption");
#else
    if (d.key && sodium_init() < 0)
        gs__check_fail(&c, GS_ERR_SYSTEM, "key: libsodium failed to initialize");
#endif
    if (c.r != GS_OK) return c.r;
    net = (gs_net *)gs__alloc(w, sizeof *net);
    if (!net) return gs__fail(w, GS_ERR_NO_MEMORY, "gs_net_create: out of memory");
    memset(net, 0, sizeof *net);
    net->world = w;
    net->d = d;
    net->d.key = NULL; /* the copy below is the net's; the caller's may go */
    net->clock_max = -1.0;
    net->update_now = -1.0;
    net->run = gs__net_run(net);
    if (d.key) gs__net_keep_key(net, d.key);
    if (gs__net_order_room(net) != GS_OK) {
        gs__net_forget_key(net);
        gs__free(w, net);
        return GS_ERR_NO_MEMORY;
    }
    w->net = net;
    if (d.transport.attach) { /* last: it may add peers, start threads */
        gs_result r2 = d.transport.attach(d.transport.user, net);
        if (r2 != GS_OK) {
            gs__net_free(w, net);
            return r2;
        }
    }
    *out = net;
    return GS_OK;
}

/* Is the net inside one of its own calls (user code under its lock), or
   is the simnet it joined running? Then it must not be freed. Read under
   the lock: a transport's thread (gs_udp's scatter) may be in an update,
   which holds the lock throughout, so that under it `inside` is this
   thread's own; the thread is stopped by the detach that follows. */
GS__PRIVATE int gs__net_in_use(const gs_net *net) {
    int busy;
    if (!net) return 0;
    gs__lock((gs_net *)net);
    busy = net->inside || net->held;
    gs__unlock((gs_net *)net);
    return busy;
}

/* Refused from a callback, as gs_world_destroy. */
GS_API void gs_net_destroy(gs_net *net) {
    gs_world *w;
    if (!net) return;
    w = net->world;
    if (gs__world_locked(w) || gs__net_in_use(net)) {
        gs__fail(w, GS_ERR_BUSY, "gs_net_destroy: called from a callback of the "
                 "world or the net, or while its simnet runs; refused, nothing freed");
        return;
    }
    if (net->d.transport.detach) net->d.transport.detach(net->d.transport.user, net);
    gs__net_free(w, net);
}

/* Frees a net with its transport detached (or never attached): the
   ghosts' queues, the key, the net. */
GS__PRIVATE void gs__net_free(gs_world *w, gs_net *net) {
    int i, p;
    for (i = 0; i < w->agent_count; ++i) { /* queues belong to peers */
        gs__ghost *g = gs__ghost_of(w->agents[i]);
        for (p = 0; g && p < GS__MAX_PEERS; ++p) {
            gs__free(w, g->gp[p].q);
            g->gp[p].q = g->gp[p].taken = NULL;
        }
    }
    w->net = NULL;
    gs__net_forget_key(net);
    gs__free(w, net->order);
    gs__free(w, net);
}

GS_API gs_net *gs_world_net(const gs_world *w) { return w->net; }

GS_API void gs_net_set_lock(gs_net *net, gs_net_lock lock) {
    if (!net) return;
    if (gs__world_locked(net->world) || net->inside) { /* it may be held now */
        gs__fail(net->world, GS_ERR_BUSY, "gs_net_set_lock: called from a callback; "
                 "the lock stays as it was");
        return;
    }
    net->lock = lock;
}

/* The guard of the calls that change the net: the world's (these belong
   to its thread), then, under the net's lock, the net's own (a send
   callback that calls back). Returns GS_OK with the lock NOT held. */
GS__PRIVATE gs_result gs__net_unlocked(gs_net *net, const char *who) {
    int inside;
    gs_result r;
    if (!net) return GS_ERR_INVALID_ARG;
    r = gs__world_unlocked(net->world, who);
    if (r != GS_OK) return r;
    gs__lock(net);
    inside = net->inside;
    gs__unlock(net);
    return inside ? gs__fail(net->world, GS_ERR_BUSY, "%s: called from a callback the "
                             "net runs (a send)", who)
                  : GS_OK;
}

GS__PRIVATE int gs__peer_slot(const gs_net *net, uint32_t host) {
    int p;
    for (p = 0; p < GS__MAX_PEERS; ++p)
        if (net->peers[p].used && net->peers[p].host == host) return p;
    return -1;
}

/* Frees every ghost's queue for peer slot p (a slot no peer uses). */
GS__PRIVATE void gs__net_drop_queues(gs_world *w, int p) {
    int i;
    for (i = 0; i < w->agent_count; ++i) {
        gs__ghost *g = gs__ghost_of(w->agents[i]);
        if (!g) continue;
        gs__free(w, g->gp[p].q);
        g->gp[p].q = g->gp[p].taken = NULL;
        gs__free(w, g->gp[p].ring);
        g->gp[p].ring = NULL;
    }
}

/* The transport's side of adding a peer: its address kept (or refused). */
GS__PRIVATE gs_result gs__transport_add(gs_net *net, uint32_t host, const char *addr) {
    const gs_transport *t = &net->d.transport;
    if (t->add_peer) return t->add_peer(t->user, host, addr);
    if (addr)
        return gs__fail(net->world, GS_ERR_INVALID_ARG, "gs_net_add_peer: host %lu: this "
                        "net's transport uses no addresses (give NULL, not \"%s\")",
                        (unsigned long)host, addr);
    return GS_OK;
}

GS_API gs_result gs_net_add_peer(gs_net *net, uint32_t host, const char *addr) {
    gs_world *w;
    int p, i, count = 0;
    gs_result r = gs__net_unlocked(net, "gs_net_add_peer");
    if (r != GS_OK) return r;
    w = net->world;
    if (host == 0 || host == w->host_id)
        return gs__fail(w, GS_ERR_INVALID_ARG, "gs_net_add_peer: host %lu is 0 or this host",
                        (unsigned long)host);
    if (gs__peer_slot(net, host) >= 0) return gs__transport_add(net, host, addr);
    for (p = 0; p < GS__MAX_PEERS; ++p) count += net->peers[p].used;
    for (p = 0; p < GS__MAX_PEERS && net->peers[p].used; ++p) {}
    if (p == GS__MAX_PEERS || count >= net->d.max_peers)
        return gs__fail(w, GS_ERR_CAPACITY, "gs_net_add_peer: max_peers (%d) reached",
                        net->d.max_peers);
    /* the address first, then the net: a datagram in between is refused
       as from an unknown sender, never taken from the wrong address */
    r = gs__transport_add(net, host, addr);
    if (r != GS_OK) return r;
    for (i = 0; i < w->agent_count; ++i) {
        gs__ghost *g = gs__ghost_of(w->agents[i]);
        if (g && gs__ghost_add_peer(g, p) != GS_OK) {
            gs__net_drop_queues(w, p); /* the queues made so far go too */
            if (net->d.transport.remove_peer)
                net->d.transport.remove_peer(net->d.transport.user, host);
            return gs__fail(w, GS_ERR_NO_MEMORY, "gs_net_add_peer: out of memory "
                            "for the ghosts' queues of host %lu", (unsigned long)host);
        }
    }
    gs__lock(net);
    memset(&net->peers[p], 0, sizeof net->peers[p]);
    net->peers[p].used = 1;
    net->peers[p].host = host;
    net->peers[p].tokens = -1.0; /* filled on first use */
    gs__diag_added(&net->peers[p].diag);
    net->peer_added = 1;
    gs__unlock(net);
    return GS_OK;
}

GS_API gs_result gs_net_remove_peer(gs_net *net, uint32_t host) {
    gs_world *w;
    int p;
    gs_result r = gs__net_unlocked(net, "gs_net_remove_peer");
    if (r != GS_OK) return r;
    w = net->world;
    p = gs__peer_slot(net, host);
    if (p < 0) return gs__fail(w, GS_ERR_INVALID_ARG, "gs_net_remove_peer: no peer %lu",
                               (unsigned long)host);
    gs__lock(net);
    net->peers[p].used = 0;
    gs__net_drop_queues(w, p);
    gs__unlock(net);
    if (net->d.transport.remove_peer) /* after the net: see add */
        return net->d.transport.remove_peer(net->d.transport.user, host);
    return GS_OK;
}

GS_API gs_result gs_net_peer_stats(const gs_net *net, uint32_t host,
                                   gs_peer_stats *out) {
    int p = net ? gs__peer_slot(net, host) : -1, i;
    if (p < 0 || !out) return GS_ERR_INVALID_ARG;
    gs__lock((gs_net *)net);
    *out = net->peers[p].st;
    out->objects_resting = 0;
    for (i = 0; i < net->world->agent_count; ++i) {
        const gs__ghost *g = gs__ghost_of(net->world->agents[i]);
        out->objects_resting += g && g->gp[p].resting;
    }
    out->health = gs__peer_judge(net, p, out->reason, sizeof out->reason);
    {
        const gs__diag_win *win = gs__diag_last(&net->peers[p].diag, net->clock_max);
        int told = out->health == GS_PEER_REFUSED || out->health == GS_PEER_PARTLY_REFUSED;
        out->refused_reason = told && win ? win->reason : GS_REJECT_COUNT;
    }
    out->clock_backwards = net->clock_backwards;
    out->clock_back_max = net->clock_back_max;
    gs__unlock((gs_net *)net);
    return GS_OK;
}

GS_API gs_result gs_net_unknown_stats(const gs_net *net, gs_unknown_stats *out) {
    int i;
    if (!net || !out) return GS_ERR_INVALID_ARG;
    gs__lock((gs_net *)net);
    memcpy(out->rejected, net->unknown_rejected, sizeof net->unknown_rejected);
    gs__unlock((gs_net *)net);
    out->rejected_total = 0;
    for (i = 0; i < GS_REJECT_COUNT; ++i) out->rejected_total += out->rejected[i];
    return GS_OK;
}

/* Appends a line to the world's diagnosis (cut where it is full). */
GS__PRIVATE GS__PRINTF(2, 3) void gs__diag_line(gs_world *w, const char *fmt, ...) {
    size_t used = strlen(w->diag);
    va_list ap;
    if (used + 2 >= sizeof w->diag) return;
    if (used) w->diag[used++] = '\n';
    va_start(ap, fmt);
    vsnprintf(w->diag + used, sizeof w->diag - used, fmt, ap);
    va_end(ap);
}

GS_API const char *gs_world_diagnose(gs_world *w) {
    gs_net *net;
    int ghosts, peers = 0, p;
    if (!w) return "";
    w->diag[0] = '\0';
    net = w->net;
    ghosts = gs__world_ghosts(w);
    if (!net) {
        if (ghosts)
            gs__diag_line(w, "%d ghost%s and no net: nothing is sent or received "
                          "(gs_net_create)", ghosts,
                          ghosts == 1 ? "" : "s");
        return w->diag;
    }
    gs__lock(net);
    for (p = 0; p < GS__MAX_PEERS; ++p) peers += net->peers[p].used;
    gs__unlock(net);
    if (!peers)
        gs__diag_line(w, "a net and no peers: nothing is sent (gs_net_add_peer, "
                      "or the other worlds' nets on the same simnet)");
    if (!ghosts)
        gs__diag_line(w, "a net and no ghosts: nothing is sent, and every snapshot is refused "
                      "(GS_REJECT_OBJECT) (gs_ghost_attach or gs_scene_attach_ghosts)");
    for (p = 0; p < GS__MAX_PEERS; ++p) {
        gs_peer_stats st;
        uint32_t host;
        gs__lock(net);
        host = net->peers[p].used ? net->peers[p].host : 0;
        gs__unlock(net);
        if (!host || gs_net_peer_stats(net, host, &st) != GS_OK) continue;
        if (st.health != GS_PEER_OK && st.health != GS_PEER_WAITING)
            gs__diag_line(w, "peer %lu: %s: %s", (unsigned long)host, gs_peer_health_str(st.health),
                          st.reason);
    }
    return w->diag;
}

/* ---- sending ---- */

/* The budget: a token bucket of bandwidth bytes/s holding at most 50 ms,
   or the largest due ghost's snapshot if that is more: a bucket smaller
   than a snapshot never lets it go. A clock that goes back refills
   nothing (and drains nothing). */
/* The bytes a peer's budget allows at wall time now. */
GS__PRIVATE double gs__peer_refill(gs_net *net, gs__peer *pe, double now) {
    double cap = 0.05 * net->d.bandwidth;
    if (cap < GS_WIRE_MAX_DATAGRAM) cap = GS_WIRE_MAX_DATAGRAM;
    if (cap < net->burst) cap = net->burst;
    if (pe->tokens < 0.0) { pe->tokens = cap; pe->tokens_at = now; }
    if (now > pe->tokens_at) pe->tokens += (now - pe->tokens_at) * net->d.bandwidth;
    pe->tokens_at = now;
    if (pe->tokens > cap) pe->tokens = cap;
    return pe->tokens;
}

GS__PRIVATE int gs__peer_budget(gs_net *net, gs__peer *pe, size_t bytes, double now) {
    if (gs__peer_refill(net, pe, now) < (double)bytes) return 0;
    pe->tokens -= (double)bytes;
    return 1;
}

/* Starts the datagram in net->buf that every peer gets: the fields that
   differ per peer (sequence, echo) are written by gs__datagram_to_peer. */
GS__PRIVATE void gs__datagram_begin(gs_net *net, double now, size_t *size) {
    gs_wire_header h;
    memset(&h, 0, sizeof h);
    h.session = net->d.session;
    h.sender = net->world->host_id;
    h.run = net->run;
    h.send_time = now;
    h.sync = gs__net_sync_flags(net->world);
    gs_wire_begin(net->buf, sizeof net->buf, &h, size);
    memset(&net->wctx, 0, sizeof net->wctx);
}

/* Room for chunks in net->buf: a sealed datagram's trailer must fit. */
GS__PRIVATE size_t gs__net_cap(const gs_net *net) {
    return net->guard.keyed ? GS_WIRE_MAX_DATAGRAM - (GS_WIRE_SEAL_TRAILER - 4)
                            : GS_WIRE_MAX_DATAGRAM;
}

/* The datagram in net->buf (size bytes, header and chunks) made one
   peer's: its sequence and echo written into the header, then the CRC, or
   sealed in a copy (guard.sealed: sealing encrypts in place, and the next
   peer needs the chunks in clear). Returns where the datagram is and its
   size in *n. */
GS__PRIVATE const unsigned char *gs__datagram_to_peer(gs_net *net, const gs__peer *pe,
                                                      double now, size_t size, size_t *n) {
    unsigned char *b = net->buf;
    gs__hdr_set_peer(b, pe->send_seq, pe->their_send_time,
                     pe->recv_any ? now - pe->their_recv_now : 0.0);
#ifdef GHOSTSIM_SODIUM
    if (net->guard.keyed) {
        memcpy(net->guard.sealed, b, size);
        *n = gs__wire_seal(net->guard.sealed, size, net->guard.key, net->guard.epoch,
                           net->guard.salt, net->guard.counter++);
        return net->guard.sealed;
    }
#endif
    *n = gs_wire_end(b, size);
    return b;
}

/* Sends the datagram being built, if it holds a chunk, to every peer whose
   budget allows it, then starts the next. The chunks were encoded once for
   all peers; only the header's per-peer fields and the CRC (or the seal)
   are done per peer. */
GS__PRIVATE void gs__datagram_flush(gs_net *net, double now, size_t *size) {
    size_t wire = *size + (net->guard.keyed ? GS_WIRE_SEAL_TRAILER : 4), n;
    gs_result r;
    int p;
    if (gs__hdr_chunks(net->buf) == 0) return;
    net->flushes++;
    for (p = 0; p < GS__MAX_PEERS; ++p) {
        gs__peer *pe = &net->peers[p];
        const unsigned char *d;
        if (!pe->used || !gs__peer_budget(net, pe, wire, now)) continue;
        d = gs__datagram_to_peer(net, pe, now, *size, &n);
        r = net->d.transport.send(net->d.transport.user, pe->host, d, n);
        if (r != GS_OK) { /* not sent: the peer sees no gap in the sequence */
            pe->st.send_failures++;
            if (net->send_error == GS_OK) {
                net->send_error = r;
                net->send_error_host = pe->host;
            }
            continue;
        }
        pe->send_seq++;
        pe->st.datagrams_sent++;
        pe->diag.sent_at = now;
        pe->st.bytes_sent += n;
    }
    gs__datagram_begin(net, now, size);
}

/* A ghost's state (after its time) as runs of one kind each: its
   positions, a rigid body's quaternion, velocities. Returns the runs, each
   [previous end, end[i]) of class cls[i]: 0 position, 1 quaternion, 2
   velocity. A custom agent's state is all positions. */
GS__PRIVATE int gs__ghost_runs(const gs__ghost *g, size_t end[3], int cls[3]) {
    const gs_agent *a = g->agent;
    size_t vars = g->n - 1;
    if ((a->kind == &gs__rigid_kind || a->kind == &gs__probe_kind) && vars == 13) {
        end[0] = 3; cls[0] = 0;
        end[1] = 7; cls[1] = 1;
        end[2] = 13; cls[2] = 2;
        return 3;
    }
    if (a->kind->positions && a->kind->positions(a) < vars) {
        end[0] = a->kind->positions(a); cls[0] = 0;
        end[1] = vars; cls[1] = 2;
        return 2;
    }
    end[0] = vars; cls[0] = 0;
    return 1;
}

/* The quantized segments of chunk values [first, first + cnt). */
GS__PRIVATE void gs__ghost_segments(const gs__ghost *g, size_t first, size_t cnt,
                                    gs_wire_chunk *ch) {
    size_t end[3], lo = 0, a, b;
    int cls[3], r, nr = gs__ghost_runs(g, end, cls);
    ch->segment_count = 0;
    for (r = 0; r < nr; lo = end[r++]) {
        gs_wire_segment *s;
        a = first > lo ? first : lo;
        b = first + cnt < end[r] ? first + cnt : end[r];
        if (a >= b) continue;
        s = &ch->segments[ch->segment_count++];
        memset(s, 0, sizeof *s);
        s->kind = cls[r] == 1 ? GS_WIRE_QUATERNION : GS_WIRE_SCALAR;
        s->count = (uint16_t)(b - a);
        s->step = cls[r] == 2 ? g->d.velocity_resolution : g->d.position_resolution;
        s->bits = g->d.orientation_bits;
    }
}

GS__PRIVATE int gs__qk_make(gs_wire_segment *seg, int nseg, const double *v, int64_t *k,
                            int key);
GS__PRIVATE void gs__qk_values(const gs_wire_segment *seg, int nseg, const int64_t *k,
                               double *out);

/* Has the state moved past the rest threshold from ref (the last snapshot
   sent whole, or what a peer predicts of it)? A velocity counts by what it
   moves over one send period; a rigid body's orientation by how far it
   moves the body's bounding sphere's surface (a quaternion component off
   by d turns it by about 2d radians): compared as metres, a sphere of 8 cm
   spinning slowly about the vertical on the paper scene's cloth (its
   surface 0.02 mm a send apart) sent its state 14 times a second. */
GS__PRIVATE int gs__ghost_moved(const gs__ghost *g, const double *ref) {
    size_t end[3], lo = 0, i;
    int cls[3], r, nr = gs__ghost_runs(g, end, cls);
    double thr = g->d.rest_threshold, turn = thr;
    if (!g->sent_any) return 1;
    if (g->agent->kind == &gs__rigid_kind && ((const gs__rigid *)g->agent)->shape.bound > 0.0)
        turn = thr / (2.0 * ((const gs__rigid *)g->agent)->shape.bound);
    for (r = 0; r < nr; lo = end[r++]) {
        double lim = cls[r] == 2 ? thr * g->d.send_rate : cls[r] == 1 ? turn : thr;
        for (i = lo; i < end[r]; ++i)
            if (!(fabs(g->B[1 + i] - ref[1 + i]) <= lim)) return 1;
    }
    return 0;
}

/* rest_extrapolate: values v (a state after its time) carried dt seconds
   of simulation time along their velocities by the kind's dead reckoning,
   in place. Sender and receiver run it on the same values over the same
   simulation times, so they agree on the prediction. 0 if the kind has
   none, or dt or a value came out non-finite or beyond +-GS_MAX_COORD (a
   prediction no state could be: the sender then sends the state). */
GS__PRIVATE int gs__rest_carry(const gs__ghost *g, double *v, double dt) {
    const gs__kind *k = g->agent->kind;
    size_t i;
    if (!k->extrapolate || !(fabs(dt) <= GS_MAX_COORD)) return 0;
    if (dt != 0.0) k->extrapolate(g->agent, v, dt);
    for (i = 0; i + 1 < g->n; ++i)
        if (!(fabs(v[i]) <= GS_MAX_COORD)) return 0;
    return 1;
}

/* rest_extrapolate: state S (time first) as the peers decode it, into out:
   f32 rounded, quantized values as the integers the chunks carry give them
   back (gs__qk_make's steps are gs_wire_add's). A delta chunk reuses its
   baseline's step, which differs only where a chunk's span passed 2^32
   steps (214 km at 0.05 mm); the prediction is then off by that step. */
GS__PRIVATE void gs__ghost_decoded(gs__ghost *g, const double *S, double *out) {
    size_t vars = g->n - 1, i;
    int c;
    out[0] = S[0];
    if (g->d.encoding == GS_ENCODING_F64) {
        memcpy(out + 1, S + 1, vars * sizeof(double));
        return;
    }
    if (g->d.encoding == GS_ENCODING_F32) {
        for (i = 0; i < vars; ++i) out[1 + i] = (double)(float)S[1 + i];
        return;
    }
    for (c = 0; c < g->nchunks; ++c) {
        gs_wire_chunk ch;
        size_t first = (size_t)c * (size_t)g->per_chunk, cnt = (size_t)g->per_chunk;
        if (first + cnt > vars) cnt = vars - first;
        gs__ghost_segments(g, first, cnt, &ch);
        if (gs__qk_make(ch.segments, ch.segment_count, S + 1 + first, g->kbuf, 1))
            gs__qk_values(ch.segments, ch.segment_count, g->kbuf, out + 1 + first);
        else /* not sendable quantized: the peer gets nothing of it */
            memcpy(out + 1 + first, S + 1 + first, cnt * sizeof(double));
    }
}

/* rest_extrapolate: g->pred = the last snapshot sent whole carried to B's
   time; 0 if there is no prediction (the state is then sent). */
GS__PRIVATE int gs__ghost_predict(gs__ghost *g) {
    memcpy(g->pred, g->sent, g->n * sizeof(double));
    g->pred[0] = g->B[0];
    return g->sent_any && gs__rest_carry(g, g->pred + 1, g->B[0] - g->sent[0]);
}

/* ---- delta coding (gs_ghost_desc.delta): the quantized integers ---- */

#define GS__QK_MAX 2251795518717952LL /* 2^51 - 2^32: |integer| a decoder takes */

/* The integers of values v in the segments' layout (see >>wire), into k.
   key: the steps are made as gs_wire_add makes them (a wide span doubles
   one) and written back into seg; else seg's steps are kept (a baseline's).
   0 if an integer leaves the decoder's range or a quaternion is 0. */
GS__PRIVATE int gs__qk_make(gs_wire_segment *seg, int nseg, const double *v, int64_t *k,
                            int key) {
    int s, i, j, ok = 1;
    for (s = 0; s < nseg; ++s) {
        gs_wire_segment *sg = &seg[s];
        if (sg->kind == GS_WIRE_SCALAR) {
            double inv;
            int64_t lo, hi;
            if (key) sg->step = gs__quant_step(sg->step, v, sg->count, &lo, &hi);
            inv = 1.0 / sg->step;
            for (i = 0; i < sg->count; ++i) {
                double x = v[i] * inv;
                if (!(fabs(x) <= (double)GS__QK_MAX)) { ok = 0; k[i] = 0; continue; }
                k[i] = gs__round(x);
            }
        } else {
            double st = gs__quat_step(sg->bits), top = (double)((1u << sg->bits) - 1u);
            for (i = 0; i < sg->count; i += 4) {
                const double *q = v + i;
                double norm = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
                int big = 0, m = 1;
                for (j = 1; j < 4; ++j) big = fabs(q[j]) > fabs(q[big]) ? j : big;
                ok &= norm > 0.0;
                k[i] = big + 4 * (q[big] < 0.0);
                for (j = 0; j < 4; ++j) {
                    double u;
                    if (j == big) continue;
                    u = floor((q[j] / norm + 0.7071067811865476) / st + 0.5);
                    k[i + m++] = (int64_t)(u < 0.0 ? 0.0 : u > top ? top : u);
                }
            }
        }
        v += sg->count;
        k += sg->count;
    }
    return ok;
}

/* gs__qk_make's integers of values v in a baseline's layout seg (its
   steps kept) into k, and in the same pass their differences from the
   baseline's integers bk into d, and (st not NULL) what the coding choice
   reads of them into *st (gs__dstat, its spatial part left 0); tail not
   NULL: the second segment's on into *tail instead (a chunk's velocities,
   which a prediction leaves as they are: gs__send_delta_chunk). 0 if an
   integer leaves the decoder's range, a quaternion is 0 or a difference is
   past +-(2^31 - 1): the chunk then goes whole. */
GS__PRIVATE int gs__qk_diff(gs_wire_segment *seg, int nseg, const double *v, int64_t *k,
                            const int64_t *bk, int64_t *d, gs__dstat *st, gs__dstat *tail) {
    int s, i, n;
    uint64_t bad = 0;
    gs__dstat *to = st;
    if (st) memset(st, 0, sizeof *st);
    if (tail) memset(tail, 0, sizeof *tail);
    for (s = 0; s < nseg; ++s, v += n, k += n, bk += n, d += n) {
        n = seg[s].count;
        if (s == 1 && tail) to = tail;
        if (seg[s].kind == GS_WIRE_SCALAR) {
            double inv = 1.0 / seg[s].step;
            for (i = 0; i < n; ++i) {
                double x = v[i] * inv;
                if (!(fabs(x) <= (double)GS__QK_MAX)) return 0; /* before the conversion */
                k[i] = gs__round(x);
            }
        } else if (!gs__qk_make(&seg[s], 1, v, k, 0)) {
            return 0;
        }
        if (to) { /* the statistics' largest zigzag tells the range, below */
            for (i = 0; i < n; ++i) {
                d[i] = k[i] - bk[i];
                gs__dstat_add(to, d[i]);
            }
            continue;
        }
        for (i = 0; i < n; ++i) {
            d[i] = k[i] - bk[i];
            /* |d| <= 2^31 - 1: d + 2^31 - 1 in [0, 2^32 - 2] */
            bad |= (uint64_t)(d[i] + 2147483647LL) > 4294967294u;
        }
    }
    /* |d| <= 2^31 - 1 is zigzag(d) <= 2^32 - 2 (zigzag(-2^31) = 2^32 - 1) */
    if (st) bad |= st->mx > 4294967294u;
    if (tail) bad |= tail->mx > 4294967294u;
    return !bad;
}

/* The values of integers k in the segments' layout: what a decoder of the
   chunk reads, bit for bit (the same products as gs__quant_get's). */
GS__PRIVATE void gs__qk_values(const gs_wire_segment *seg, int nseg, const int64_t *k,
                               double *out) {
    int s, i, j;
    for (s = 0; s < nseg; ++s) {
        const gs_wire_segment *sg = &seg[s];
        if (sg->kind == GS_WIRE_SCALAR) {
            for (i = 0; i < sg->count; ++i) out[i] = (double)k[i] * sg->step;
        } else {
            double st = gs__quat_step(sg->bits);
            for (i = 0; i < sg->count; i += 4) {
                int big = (int)(k[i] & 3), m = 1;
                double ss = 0.0, *o = out + i;
                for (j = 0; j < 4; ++j) {
                    if (j == big) continue;
                    o[j] = (double)k[i + m++] * st - 0.7071067811865476;
                    ss += o[j] * o[j];
                }
                o[big] = ss < 1.0 ? sqrt(1.0 - ss) : 0.0;
                if (k[i] & 4) o[big] = -o[big];
            }
        }
        out += sg->count;
        k += sg->count;
    }
}

/* Are integers k what an encoder in the segments' layout sends? (A delta
   from a peer is checked: what it decodes to must be a state.) */
GS__PRIVATE int gs__qk_ok(const gs_wire_segment *seg, int nseg, const int64_t *k) {
    int s, i, j;
    for (s = 0; s < nseg; ++s) {
        const gs_wire_segment *sg = &seg[s];
        if (sg->kind == GS_WIRE_SCALAR) {
            for (i = 0; i < sg->count; ++i)
                if (k[i] > GS__QK_MAX || k[i] < -GS__QK_MAX) return 0;
        } else {
            int64_t top = ((int64_t)1 << sg->bits) - 1;
            double st = gs__quat_step(sg->bits);
            for (i = 0; i < sg->count; i += 4) {
                double ss = 0.0;
                if (k[i] < 0 || k[i] > 7) return 0;
                for (j = 1; j < 4; ++j) {
                    double c;
                    if (k[i + j] < 0 || k[i + j] > top) return 0;
                    c = (double)k[i + j] * st - 0.7071067811865476;
                    ss += c * c;
                }
                if (ss > 0.76) return 0; /* as gs__quant_quats_ok */
            }
        }
        k += sg->count;
    }
    return 1;
}

/* The integers of a parsed quantized chunk (whole, not a delta). */
GS__PRIVATE void gs__qk_from_chunk(const gs_wire_chunk *c, int64_t *k) {
    int s, i, j;
    for (s = 0; s < c->segment_count; ++s) {
        const gs_wire_segment *sg = &c->segments[s];
        gs__bitr r;
        r.p = sg->data; r.end = sg->data + gs__seg_bytes(sg); r.acc = 0; r.n = 0;
        if (sg->kind == GS_WIRE_SCALAR) {
            for (i = 0; i < sg->count; ++i) k[i] = sg->base + (int64_t)gs__bitr_get(&r, sg->width);
        } else {
            for (i = 0; i < sg->count; i += 4) {
                int64_t big = gs__bitr_get(&r, 2);
                k[i] = big + 4 * (int64_t)gs__bitr_get(&r, 1);
                for (j = 1; j < 4; ++j) k[i + j] = gs__bitr_get(&r, sg->bits);
            }
        }
        k += sg->count;
    }
}

/* Do two chunks' segments have one layout (a delta needs its baseline's)? */
GS__PRIVATE int gs__seg_same(const gs_wire_segment *a, int na, const gs_wire_segment *b, int nb) {
    int s;
    if (na != nb) return 0;
    for (s = 0; s < na; ++s)
        if (a[s].kind != b[s].kind || a[s].count != b[s].count ||
            (a[s].kind == GS_WIRE_QUATERNION && a[s].bits != b[s].bits))
            return 0;
    return 1;
}

GS__PRIVATE int gs__seq_newer(uint32_t a, uint32_t b);

/* The ring entry holding snapshot seq, or NULL. */
GS__PRIVATE gs__base *gs__ring_find(gs__base *ring, uint32_t seq) {
    int i;
    for (i = 0; i < GS_DELTA_RING; ++i)
        if (ring[i].used && ring[i].seq == seq) return &ring[i];
    return NULL;
}

/* The entry for snapshot seq: the one holding it, a free one, or the
   oldest other than keep (emptied); NULL if every entry is newer than seq
   (a late chunk of a snapshot too old to be a baseline). */
GS__PRIVATE gs__base *gs__ring_slot(gs__base *ring, int nchunks, uint32_t seq,
                                    const gs__base *keep) {
    gs__base *e = gs__ring_find(ring, seq), *oldest = NULL;
    int i;
    if (e) return e;
    for (i = 0; i < GS_DELTA_RING && !e; ++i) {
        if (!ring[i].used) e = &ring[i];
        else if (&ring[i] != keep && (!oldest || gs__seq_newer(oldest->seq, ring[i].seq)))
            oldest = &ring[i];
    }
    if (!e) {
        if (!oldest || gs__seq_newer(oldest->seq, seq)) return NULL;
        e = oldest;
    }
    e->used = 1;
    e->seq = seq;
    e->chunks = 0;
    memset(e->got, 0, (size_t)nchunks);
    return e;
}

/* GS_WIRE_CHUNK_PREDICT (see >>wire): into p, the steps by which baseline
   b's velocities carry its positions [first, first + n) over dt seconds of
   simulation time (0 for every other value; seg: the chunk's segments,
   the baseline's), and in *span (not NULL) the end of the values carried
   (every p[j] from it on is 0). 1 if a position was carried, 0 if none can be (no
   position with a velocity in this range), -1 if b lacks a velocity's
   chunk or a product is past +-2^31 steps or not finite. Sender and
   receiver must agree bit for bit: one product and one quotient in a fixed
   order, each through memory (volatile), so that no compiler keeps more
   precision or fuses the rounding's addition into the product. */
GS__PRIVATE int gs__delta_pred(const gs__ghost *g, const gs__base *b,
                               const gs_wire_segment *seg, int nseg, size_t first, int n,
                               double dt, int64_t *p, size_t *span) {
    size_t end[3], npos, vstart, vars = g->n - 1, e = first, vlo = 1, vhi = 0, per, to = 0;
    int cls[3], nr = gs__ghost_runs(g, end, cls), s, i, t, any = 0;
    double sv = 0.0, xv;
    volatile double f = 0.0, x;
    memset(p, 0, (size_t)n * sizeof *p);
    if (nr < 2 || cls[0] != 0 || cls[nr - 1] != 2) return 0;
    vstart = end[nr - 2]; /* a velocity run follows the positions */
    npos = end[0] < vars - vstart ? end[0] : vars - vstart;
    per = (size_t)g->per_chunk;
    for (s = 0; s < nseg && e < npos; e += seg[s++].count) {
        int fresh = 1; /* f depends on the two steps only: made again when one changes */
        int cnt = (size_t)seg[s].count < npos - e ? seg[s].count : (int)(npos - e);
        if (seg[s].kind != GS_WIRE_SCALAR) continue;
        for (i = 0; i < cnt; ++i) {
            size_t ve = vstart + e + (size_t)i;
            if (ve < vlo || ve >= vhi) { /* the velocity's segment in b */
                size_t c = ve / per, lo = c * per;
                const gs_wire_segment *bs = b->seg + c * GS_WIRE_MAX_SEGMENTS;
                if (!b->got[c]) return -1;
                for (t = 0; t < b->nseg[c] && ve >= lo + bs[t].count; ++t) lo += bs[t].count;
                if (t == b->nseg[c] || bs[t].kind != GS_WIRE_SCALAR) return -1;
                vlo = lo;
                vhi = lo + bs[t].count;
                sv = bs[t].step;
                fresh = 1;
            }
            if (fresh) {
                f = sv * dt;
                f = f / seg[s].step;
                fresh = 0;
            }
            x = (double)b->k[ve] * f;
            xv = x; /* one load of the product rounded */
            if (!(fabs(xv) <= 2147483647.0)) return -1;
            to = e - first + (size_t)i;
            p[to++] = gs__round(xv);
            any = 1;
        }
    }
    if (span) *span = to;
    return any;
}

/* The baseline of a delta ghost's next snapshot: the newest every peer
   acknowledged, which is the oldest of their acknowledgements (the chunks
   are encoded once for all peers), if the ring still holds it. NULL: the
   next goes whole. */
GS__PRIVATE gs__base *gs__delta_base(const gs_net *net, gs__ghost *g) {
    uint32_t oldest = 0;
    int p, any = 0;
    for (p = 0; p < GS__MAX_PEERS; ++p) {
        const struct gs__ghost_peer *gp = &g->gp[p];
        if (!net->peers[p].used) continue;
        if (!gp->acked_known) return NULL;
        if (!any || gs__seq_newer(oldest, gp->acked)) oldest = gp->acked;
        any = 1;
    }
    /* too old: a peer that received every snapshot sent since may have let
       it go (it keeps as many as we do) */
    if (!any || g->b_seq - oldest >= (uint32_t)GS_DELTA_RING) return NULL;
    return gs__ring_find(g->ring, oldest);
}

/* Adds a chunk (values, or differences d for a delta, st what the coding
   choice reads of them) to the datagram, sending it first when full. */
GS__PRIVATE gs_result gs__put_chunk(gs_net *net, double now, size_t *size,
                                    const gs_wire_chunk *ch, const double *v, const int64_t *d,
                                    const gs__dstat *st) {
    int k;
    gs_result r = GS_ERR_CAPACITY;
    for (k = 0; k < 2 && r == GS_ERR_CAPACITY; ++k) {
        if (k) gs__datagram_flush(net, now, size);
        r = d ? gs__wire_add_delta_in(net->buf, gs__net_cap(net), size, &net->wctx, ch, d, st)
              : gs__wire_add_in(net->buf, gs__net_cap(net), size, &net->wctx, ch, v);
    }
    return r;
}

/* One chunk of a delta ghost's snapshot, into ring entry `to`: against
   the baseline's same chunk when the baseline holds it in the same layout
   and every difference fits, else whole. */
GS__PRIVATE void gs__send_delta_chunk(gs_net *net, gs__ghost *g, double now, size_t *size,
                                      gs_wire_chunk *ch, const gs__base *base, gs__base *to,
                                      const double *S) {
    int c = ch->index, nseg = ch->segment_count, delta = 0, usable, row = g->row;
    int restart = gs__spatial_restart(ch);
    size_t first = ch->first;
    const double *v = S + 1 + first;
    int64_t *k = to->k + first, *d = g->kbuf, e[2][GS_WIRE_QUANT_CHUNK];
    gs_wire_segment *ts = to->seg + (size_t)c * GS_WIRE_MAX_SEGMENTS;
    const gs_wire_segment *bs = base ? base->seg + (size_t)c * GS_WIRE_MAX_SEGMENTS : NULL;
    gs__dstat st[2], tail, *use = &st[0];
    gs_result r;
    if (row < 1 || row > GS_WIRE_SPATIAL_ROW) row = 0;
    if (base && base->got[c] && gs__seg_same(bs, base->nseg[c], ch->segments, nseg)) {
        memcpy(ts, bs, (size_t)nseg * sizeof *ts);
        /* the velocities' statistics apart (restart > 0: the second
           segment on), so that a prediction of the positions alone reuses
           them */
        delta = gs__qk_diff(ts, nseg, v, k, base->k + first, d, &st[0],
                            restart > 0 ? &tail : NULL);
    }
    if (delta) {
        /* against the baseline carried along its velocities when that is
           smaller (a drifting or swinging body: its positions then differ
           from the prediction by what its velocity changed); each
           candidate's bits (and its spatial residuals') made once, for
           this choice and gs__delta_put's */
        int64_t *pr = g->kbuf + g->per_chunk;
        size_t span = 0;
        long plain, pred;
        int n = ch->elements;
        ch->flags = GS_WIRE_CHUNK_DELTA;
        ch->delta_row = g->row;
        plain = gs__dstat_split(&st[0], restart > 0 ? &tail : NULL, 0, d, n, restart, row, e[0]);
        if (gs__delta_pred(g, base, ts, nseg, first, n, ch->time - base->time, pr, &span) > 0) {
            /* the prediction carries positions only: when they end before
               the velocities (span <= restart), the differences, the
               statistics and the residuals from there on are the plain
               candidate's, made above */
            int m = restart > 0 && (int)span <= restart ? restart : n, j;
            uint64_t bad = 0;
            memset(&st[1], 0, sizeof st[1]);
            for (j = 0; j < m; ++j) {
                pr[j] = d[j] - pr[j];
                gs__dstat_add(&st[1], pr[j]);
            }
            /* |pr| <= 2^31 - 1, from the largest zigzag (gs__qk_diff's) */
            bad = st[1].mx > 4294967294u;
            if (!bad) { /* else the differences from the baseline go */
                pred = gs__dstat_split(&st[1], m < n ? &tail : NULL, 1, pr, n, restart, row,
                                       e[1]);
                if (pred < plain) {
                    if (m < n) {
                        memcpy(pr + m, d + m, (size_t)(n - m) * sizeof *pr);
                        if (st[1].e) memcpy(e[1] + m, e[0] + m, (size_t)(n - m) * sizeof *pr);
                    }
                    d = pr;
                    use = &st[1];
                    ch->flags |= GS_WIRE_CHUNK_PREDICT;
                }
            }
        }
        ch->baseline = base->seq;
        r = gs__put_chunk(net, now, size, ch, NULL, d, use);
        usable = 1;
    } else {
        memcpy(ts, ch->segments, (size_t)nseg * sizeof *ts);
        usable = gs__qk_make(ts, nseg, v, k, 1);
        r = gs__put_chunk(net, now, size, ch, v, NULL, NULL);
    }
    to->nseg[c] = (unsigned char)nseg;
    to->got[c] = r == GS_OK && usable;
    to->chunks += to->got[c];
}

/* Appends every chunk of state S (the ghost's B, or what its peers
   predict of it) to the datagrams for all peers, as snapshot b_seq at S's
   time, or a heartbeat (rest). */
GS__PRIVATE void gs__send_ghost(gs_net *net, gs__ghost *g, double now, size_t *size,
                                int rest, const double *S) {
    size_t vars = g->n - 1, bytes = 0, before;
    gs__base *base = NULL, *to = NULL;
    int c, p;
    if (g->ring && !rest) {
        base = gs__delta_base(net, g);
        to = gs__ring_slot(g->ring, g->nchunks, g->b_seq, base);
        if (to == base) base = NULL;
        if (to) to->time = S[0];
    }
    for (c = 0; c < (rest ? 1 : g->nchunks); ++c) {
        gs_wire_chunk ch;
        size_t first = (size_t)c * (size_t)g->per_chunk, cnt = (size_t)g->per_chunk;
        if (first + cnt > vars) cnt = vars - first;
        if (rest) cnt = 0;
        ch.object_id = g->d.object_id;
        ch.sequence = g->b_seq;
        ch.time = S[0];
        ch.index = (uint16_t)c;
        ch.count = (uint16_t)g->nchunks;
        ch.first = (uint32_t)first;
        ch.elements = (uint16_t)cnt;
        ch.encoding = g->d.encoding;
        ch.flags = rest ? GS_WIRE_CHUNK_REST : 0;
        ch.segment_count = 0;
        ch.payload = NULL;
        ch.baseline = 0;
        ch.delta_row = 0;
        if (ch.encoding == GS_ENCODING_QUANT && !rest) gs__ghost_segments(g, first, cnt, &ch);
        before = *size;
        if (to) {
            size_t at = *size;
            gs__send_delta_chunk(net, g, now, size, &ch, base, to, S);
            bytes += *size >= at ? *size - at : *size - GS_WIRE_HEADER;
            continue;
        }
        if (gs__wire_add_in(net->buf, gs__net_cap(net), size, &net->wctx, &ch,
                            S + 1 + first) == GS_ERR_CAPACITY) {
            gs__datagram_flush(net, now, size);
            before = *size;
            gs__wire_add_in(net->buf, gs__net_cap(net), size, &net->wctx, &ch, S + 1 + first);
        }
        bytes += *size - before;
    }
    if (!rest) g->wire_bytes = bytes;
    for (p = 0; p < GS__MAX_PEERS; ++p) {
        if (!net->peers[p].used) continue;
        if (rest) net->peers[p].st.heartbeats_sent++;
        else net->peers[p].st.snapshots_sent++;
    }
}

/* The beat grid: a resting ghost's heartbeats go at the multiples of its
   heartbeat period on the net's clock, so that every resting ghost of a
   net (of one heartbeat rate) beats in the same update and their
   heartbeats share one datagram, which goes to every peer: at rest a net
   sends heartbeat_rate datagrams a second, not one per ghost's own phase.
   Returns the first grid instant after now; GS__BEAT_SLACK (of a period)
   takes an instant a rounding short of a grid point for that point. */
#define GS__BEAT_SLACK 1e-6
GS__PRIVATE double gs__beat_next(double now, double hb) {
    return hb * (floor(now / hb + GS__BEAT_SLACK) + 1.0);
}
GS__PRIVATE int gs__beat_due(const gs__ghost *g, double now) {
    double hb = 1.0 / g->d.heartbeat_rate;
    /* a next beat more than a period ahead: the clock went back */
    return now >= g->next_heartbeat - GS__BEAT_SLACK * hb || g->next_heartbeat - now > hb;
}

/* A resting delta ghost whose state is, value for value, the one it
   last sent (every state sent since had those values too), and every peer
   acknowledged that one or a later: each peer holds it whole, so a beat's
   state or a repeat would tell them nothing a heartbeat does not (and
   costs its chunk and an acknowledgement back: 810 resting spheres at 4
   Hz, bench/bandwidth spheres900). The acknowledgement counts however old
   (not gs__delta_base's ring): a peer's last state of the object stays
   until a newer one comes, and every newer one had these values. */
GS__PRIVATE int gs__ghost_still(const gs_net *net, const gs__ghost *g) {
    int p, any = 0;
    if (!g->still || memcmp(g->B + 1, g->sent + 1, (g->n - 1) * sizeof(double)) != 0) return 0;
    for (p = 0; p < GS__MAX_PEERS; ++p) {
        const struct gs__ghost_peer *gp = &g->gp[p];
        if (!net->peers[p].used) continue;
        if (!gp->acked_known || gs__seq_newer(g->still_seq, gp->acked)) return 0;
        any = 1;
    }
    return any;
}

/* Sends a due ghost: its state, or while it rests (send on change) a
   heartbeat on the beat grid, the first two of a rest with the state
   again (a delta ghost's beat: gs__ghost_still). */
GS__PRIVATE void gs__send_due(gs_net *net, gs__ghost *g, double now, size_t *size) {
    double hb = 1.0 / g->d.heartbeat_rate;
    int on_change = g->d.rest_threshold > 0.0, predict = on_change && g->d.rest_extrapolate;
    int moved = !on_change ? 1
              : predict ? !gs__ghost_predict(g) || gs__ghost_moved(g, g->pred)
                        : gs__ghost_moved(g, g->sent);
    g->at_rest = !moved;
    if (!moved) {
        if (!gs__beat_due(g, now)) return;
        g->next_heartbeat = gs__beat_next(now, hb);
        if (g->rest_repeats > 0 && predict) {
            /* the prediction itself, at B's time: a peer that missed the
               snapshot it comes from then predicts as we do from here */
            g->rest_repeats--;
            net->beat_went = 1;
            gs__send_ghost(net, g, now, size, 0, g->pred);
            gs__ghost_decoded(g, g->pred, g->sent);
        } else if (g->d.delta && !predict && gs__ghost_still(net, g)) {
            if (g->rest_repeats > 0) g->rest_repeats--;
            if (net->beat_states) net->beat_went = 1;
            gs__send_ghost(net, g, now, size, 1, g->B);
        } else if (g->rest_repeats > 0 || (net->beat_states && !predict && g->d.delta)) {
            /* after any state went, a beat sends every resting ghost's
               state: the receiver then holds one instant's scene, not
               each object as its own last send left it (a sphere from
               one, the cloth under it from another: they push each other
               apart). Delta ghosts only: against the baseline the peer
               acknowledged a resting state costs a few bytes, whole it
               costs all its values (quant + send on change at rest from
               13.6 to 21.4 kbit/s). A prediction goes on as it is. */
            if (g->rest_repeats > 0) g->rest_repeats--;
            net->beat_went = 1;
            if (memcmp(g->B + 1, g->sent + 1, (g->n - 1) * sizeof(double)) != 0) g->still = 0;
            gs__send_ghost(net, g, now, size, 0, g->B);
        } else {
            gs__send_ghost(net, g, now, size, 1, g->B);
        }
        return;
    }
    gs__send_ghost(net, g, now, size, 0, g->B);
    if (predict) gs__ghost_decoded(g, g->B, g->sent);
    else memcpy(g->sent, g->B, g->n * sizeof(double));
    g->still = 1;
    g->still_seq = g->b_seq;
    if (on_change) net->beat_states = 2;
    g->sent_any = 1;
    g->rest_repeats = 2;
    g->next_heartbeat = gs__beat_next(now, hb);
}

/* Has a ghost a new B to send at wall time now? Its next send further
   ahead than one period means the clock went back since (or one `now`
   was wild, 1e300): due at once, or the ghost would be silent until the
   clock came back there. */
/* A state that stands for a later instant waits for it (within a frame:
   a net on another clock than the session's is never held), so that the
   peers read its time against its send time as the session's. "Later" by
   more than GS__HOLD_EPS: the instant is a boundary less the origin, and
   an update at that boundary reads a clock that reached it by other sums
   (a simnet's frames added up), a rounding unit or so before it; held,
   the state would leave a whole frame late. */
#define GS__HOLD_EPS 1e-9 /* s */
GS__PRIVATE int gs__ghost_due(const gs__ghost *g, double now) {
    double period = 1.0 / g->d.send_rate;
    if (g->stands_at - now > GS__HOLD_EPS && g->stands_at - now <= GS__SYNC_FRAME_MAX) return 0;
    if (g->b_seq == g->sent_seq) return 0;
    /* On a frame grid a new state goes at its instant, whatever the send
       phase: the peers read the session's timeline from its time less its
       send time, and a wall-clock send phase (next_send) beating against
       the grid sent two states in three one or two frames late, for
       150 ms stretches, as long as the peers' window of estimates (four
       processes on loopback: followers a frame behind the timekeeper).
       Its rate is the publishes' (gs__sync_end: send_rate on average). */
    if (g->stands_at > 0.0 && now >= g->stands_at - GS__HOLD_EPS &&
        now - g->stands_at <= GS__SYNC_FRAME_MAX)
        return 1;
    /* a resting ghost's beat goes in its update, whatever its send phase */
    return now >= g->next_send || g->next_send - now > period || (g->at_rest && gs__beat_due(g, now));
}

/* Whether the acknowledgements due go in this update. They are held while
   nothing else would go (at rest, a datagram per received snapshot would
   cost its 52 bytes of header and CRC every frame) and go when a datagram
   goes anyway (the one being built holds a chunk, or one went this
   update), a delta was refused (the peer's deltas are of no use until it
   hears), an ack has waited one heartbeat period of its ghost, or
   GS__ACK_HOLD snapshots of one ghost are held: the peer codes against the
   newest snapshot we acknowledged, so a held ack ages its baseline by up
   to that many snapshots (and a round trip), within the GS_DELTA_RING it
   keeps, past which it would send whole. */
#define GS__ACK_HOLD (GS_DELTA_RING / 4)
GS__PRIVATE int gs__acks_go(gs_net *net, double now) {
    gs_world *w = net->world;
    int p, i, go = gs__hdr_chunks(net->buf) > 0 || net->flushes > 0;
    for (i = 0; i < w->agent_count; ++i) {
        gs__ghost *g = gs__ghost_of(w->agents[i]);
        for (p = 0; g && p < GS__MAX_PEERS; ++p) {
            struct gs__ghost_peer *gp = &g->gp[p];
            if (!net->peers[p].used || !(gp->ack_due || gp->nack_due)) continue;
            if (!gp->ack_waiting) {
                gp->ack_waiting = 1;
                gp->ack_since = now;
            }
            go |= gp->nack_due || gp->acks_held >= GS__ACK_HOLD || now < gp->ack_since ||
                  now - gp->ack_since >= (1.0 - GS__BEAT_SLACK) / g->d.heartbeat_rate;
        }
    }
    return go;
}

/* Acknowledgements to every peer of what we hold whole of its delta
   ghosts' snapshots, or refused, since the last ones (when gs__acks_go):
   one entry per object that has news, in the datagram every peer gets
   (the chunk names the one it is for). A lost one is made good by the
   next snapshot's. */
GS__PRIVATE void gs__send_acks(gs_net *net, double now, size_t *size) {
    gs_wire_ack acks[GS_WIRE_MAX_ACKS];
    gs_world *w = net->world;
    int p, i, n, k;
    if (!gs__acks_go(net, now)) return;
    for (p = 0; p < GS__MAX_PEERS; ++p) {
        if (!net->peers[p].used) continue;
        for (i = 0, n = 0; i <= w->agent_count; ++i) {
            gs__ghost *g = i < w->agent_count ? gs__ghost_of(w->agents[i]) : NULL;
            if (g && (g->gp[p].ack_due || g->gp[p].nack_due)) {
                acks[n].object_id = g->d.object_id;
                acks[n].sequence = g->gp[p].ack_seq;
                acks[n].refused = g->gp[p].nack_due;
                g->gp[p].ack_due = g->gp[p].nack_due = 0;
                g->gp[p].acks_held = g->gp[p].ack_waiting = 0;
                ++n;
            }
            if (n == GS_WIRE_MAX_ACKS || (n && i == w->agent_count)) {
                gs_result r = GS_ERR_CAPACITY;
                for (k = 0; k < 2 && r == GS_ERR_CAPACITY; ++k) {
                    if (k) gs__datagram_flush(net, now, size);
                    r = gs__wire_add_ack_in(net->buf, gs__net_cap(net), size, &net->wctx,
                                            net->peers[p].host, acks, n);
                }
                n = 0;
            }
        }
    }
}

/* Every due ghost is encoded once into datagrams that go to every peer
   (a peer whose budget is spent misses that datagram). */
/* What a ghost's snapshot will take on the wire (bytes): its last one, or
   before any its values at 8 bytes with their chunk headers. */
GS__PRIVATE size_t gs__ghost_estimate(const gs__ghost *g) {
    if (g->wire_bytes) return g->wire_bytes;
    return (size_t)g->nchunks * GS_WIRE_CHUNK_HEADER + (g->n - 1) * 8;
}

/* The bytes datagrams carrying `chunks` bytes of chunks take: each a
   header and a checksum or seal, and a chunk never split (so one datagram
   in two may carry a chunk's worth less: counted as half a datagram's
   room more). */
GS__PRIVATE double gs__wire_cost(const gs_net *net, double chunks) {
    double per = (double)GS_WIRE_HEADER + (net->guard.keyed ? GS_WIRE_SEAL_TRAILER : 4);
    double room = (double)gs__net_cap(net) - per;
    return chunks + per * ceil((chunks + 0.5 * room * (chunks > room)) / room);
}

/* The bytes every peer's budget allows now: the least of them. */
GS__PRIVATE double gs__net_budget(gs_net *net, double now) {
    double least = HUGE_VAL;
    int p;
    for (p = 0; p < GS__MAX_PEERS; ++p)
        if (net->peers[p].used) least = fmin(least, gs__peer_refill(net, &net->peers[p], now));
    return least;
}

/* A ghost's claim on a tight budget: wall time since it was last sent,
   times its importance. */
GS__PRIVATE double gs__ghost_priority(const gs__ghost *g, double now) {
    return (now - g->sent_at) * g->d.importance;
}

/* Sorts the due ghosts by priority, highest first: a heap sort, in place
   (qsort may allocate). */
GS__PRIVATE void gs__sift(struct gs__ghost **o, int root, int n, double now) {
    for (;;) {
        int c = 2 * root + 1;
        struct gs__ghost *t;
        if (c >= n) return;
        if (c + 1 < n && gs__ghost_priority(o[c + 1], now) < gs__ghost_priority(o[c], now)) ++c;
        if (gs__ghost_priority(o[root], now) <= gs__ghost_priority(o[c], now)) return;
        t = o[root]; o[root] = o[c]; o[c] = t;
        root = c;
    }
}
GS__PRIVATE void gs__by_priority(struct gs__ghost **o, int n, double now) {
    int i;
    for (i = n / 2 - 1; i >= 0; --i) gs__sift(o, i, n, now); /* a min-heap ... */
    for (i = n - 1; i > 0; --i) { /* ... emptied from the back: descending */
        struct gs__ghost *t = o[0];
        o[0] = o[i]; o[i] = t;
        gs__sift(o, 0, i, now);
    }
}

GS_API gs_result gs_net_update(gs_net *net, double now) {
    gs_world *w;
    int p, i, peers = 0, n = 0, tight;
    double need = 0.0, budget, spent = 0.0;
    size_t size;
    gs_result err;
    uint32_t err_host;
    if (!net) return GS_ERR_INVALID_ARG;
    if (!gs__finite(now)) return GS_ERR_NOT_FINITE;
    if (!gs__wire_time_ok(now)) return GS_ERR_INVALID_ARG; /* a clock */
    w = net->world;
    gs__lock(net);
    if (net->inside) { /* from its own send callback */
        gs__unlock(net);
        return GS_ERR_BUSY;
    }
    net->inside++;
    net->now = now;
    net->send_error = GS_OK;
    gs__diag_clock(net, now);
    net->updated = 1;
    net->update_now = now;
    net->unsent_world = 0.0;
    net->flushes = 0;
    for (p = 0; p < GS__MAX_PEERS; ++p) peers += net->peers[p].used;
    if (peers) gs__datagram_begin(net, now, &size);
    net->burst = 0.0;
    for (i = 0; i < w->agent_count && n < net->order_cap; ++i) {
        gs__ghost *g = gs__ghost_of(w->agents[i]);
        if (!g || !gs__ghost_due(g, now)) continue;
        net->order[n++] = g;
        need += (double)gs__ghost_estimate(g);
        net->burst = fmax(net->burst, gs__wire_cost(net, (double)gs__ghost_estimate(g)));
    }
    budget = peers ? gs__net_budget(net, now) : HUGE_VAL;
    tight = need > budget;
    if (tight) gs__by_priority(net->order, n, now);
    for (i = 0; i < n; ++i) {
        gs__ghost *g = net->order[i];
        /* a ghost that does not fit waits, its priority grows, and the
           ones after it wait too: were they let through, small ghosts due
           every frame would drain the bucket before it held a large one */
        if (tight) {
            double est = (double)gs__ghost_estimate(g);
            if (gs__wire_cost(net, spent + est) > budget) break;
            spent += est;
        }
        if (peers) gs__send_due(net, g, now, &size);
        g->sent_seq = g->b_seq;
        g->next_send = now + 1.0 / g->d.send_rate;
        g->sent_at = now;
    }
    /* a beat's states went: what moved before it is in them; what moved
       in this update is owed to the next beat */
    if (net->beat_went) net->beat_states = net->beat_states == 2;
    else if (net->beat_states == 2) net->beat_states = 1;
    net->beat_went = 0;
    if (peers) {
        gs__send_acks(net, now, &size);
        gs__datagram_flush(net, now, &size);
    }
    /* read under the lock: another thread's update (gs_udp's scatter)
       may write them as soon as it is released */
    err = net->send_error;
    err_host = net->send_error_host;
    net->inside--;
    gs__unlock(net);
    if (err != GS_OK) {
        gs_peer_stats ps;
        gs_net_peer_stats(net, err_host, &ps);
        return gs__fail(w, err,
                        "gs_net_update: the send callback failed for host %lu (%s); %llu "
                        "datagrams to it have failed, the rest went out",
                        (unsigned long)err_host, gs_result_str(err),
                        (unsigned long long)ps.send_failures);
    }
    return GS_OK;
}

/* ---- receiving ---- */

GS_API gs_result gs_net_poll(gs_net *net, double now) {
    gs_result r;
    if (!net) return GS_ERR_INVALID_ARG;
    if (!gs__finite(now)) return GS_ERR_NOT_FINITE;
    if (!gs__wire_time_ok(now)) return GS_ERR_INVALID_ARG; /* as gs_net_update */
    if (net->d.transport.poll) {
        /* the poll belongs to the world's thread, outside its callbacks
           (a transport's poll is not required to be reentrant) */
        r = gs__net_unlocked(net, "gs_net_poll");
        if (r != GS_OK) return r;
        r = net->d.transport.poll(net->d.transport.user, net, now);
        if (r != GS_OK) return r;
    }
    return net->d.transport.sends_itself ? GS_OK : gs_net_update(net, now);
}

/* Wrap-safe: a is newer than b. */
GS__PRIVATE int gs__seq_newer(uint32_t a, uint32_t b) {
    return (int32_t)(a - b) > 0;
}

/* A peer that started again (a new run number in its header) starts its
   datagram sequence and its clock again: what was known of the old run is
   forgotten (its sequence window, which would take the new run's first
   datagrams for duplicates or too old to tell; the clock offset; the send
   time to echo; snapshots queued from it). A datagram of the run before
   that arrives late is refused (0). A peer that does not say (0) is taken
   as it comes. Under the lock. */
GS__PRIVATE int gs__peer_run(gs_net *net, int p, uint32_t run) {
    gs__peer *pe = &net->peers[p];
    gs_world *w = net->world;
    int i, k;
    if (run == 0 || run == pe->run) return 1;
    if (run == pe->prev_run) return 0;
    if (pe->run != 0) {
        pe->recv_any = 0;
        pe->clock_known = 0;
        pe->their_send_time = 0.0;
        for (i = 0; i < w->agent_count; ++i) {
            gs__ghost *g = gs__ghost_of(w->agents[i]);
            if (g) { /* its sequences start again: no baseline of before */
                g->gp[p].resting = 0;
                g->gp[p].ack_known = g->gp[p].ack_due = g->gp[p].nack_due = 0;
                g->gp[p].acks_held = g->gp[p].ack_waiting = 0;
                for (k = 0; g->gp[p].ring && k < GS_DELTA_RING; ++k) g->gp[p].ring[k].used = 0;
            }
            for (k = 0; g && g->gp[p].q && k <= g->d.queue_size; ++k) {
                g->gp[p].q[k].used = 0;
                g->gp[p].q[k].chunks = 0;
                memset(g->gp[p].q[k].got, 0, (size_t)g->nchunks);
            }
        }
    }
    /* a peer heard first or started again may have none of our states:
       the next ones go whole, resting or not (send on change) */
    for (i = 0; i < w->agent_count; ++i) {
        gs__ghost *g = gs__ghost_of(w->agents[i]);
        if (g) g->sent_any = 0;
        if (g) g->gp[p].acked_known = 0;
    }
    pe->prev_run = pe->run;
    pe->run = run;
    return 1;
}

/* Loss and duplicates from the datagram sequence, with a 64-wide window.
   Returns 0 for a duplicate, 2 for the newest so far, 1 for a late one. */
GS__PRIVATE int gs__peer_sequence(gs__peer *pe, uint32_t seq) {
    if (!pe->recv_any) {
        pe->recv_any = 1;
        pe->recv_top = seq;
        pe->recv_window = 1;
        return 2;
    }
    if (gs__seq_newer(seq, pe->recv_top)) {
        uint32_t ahead = seq - pe->recv_top;
        pe->st.lost += ahead - 1; /* taken back if they come late */
        pe->recv_window = ahead >= 64 ? 0 : pe->recv_window << ahead;
        pe->recv_window |= 1;
        pe->recv_top = seq;
        return 2;
    }
    {
        uint32_t behind = pe->recv_top - seq;
        if (behind >= 64) return 1; /* too old to tell: let it through */
        if (pe->recv_window & ((uint64_t)1 << behind)) return 0;
        pe->recv_window |= (uint64_t)1 << behind;
        if (pe->st.lost) pe->st.lost--;
        return 1;
    }
}

/* Every chunk must name a known object and fit its state; checked before
   anything is queued, so that a datagram counts whole or not at all. The
   ghost of chunk i goes to ghosts[i] for the queueing: each object is
   looked up once (the search is linear in the world's agents), and
   consecutive chunks of one object, as a big snapshot's are, once for all. */
GS__PRIVATE int gs__chunks_fit(gs_net *net, const gs_wire_view *v, double now,
                               gs__ghost **ghosts, gs_reject *why) {
    int i;
    (void)now;
    for (i = 0; i < v->chunk_count; ++i) {
        const gs_wire_chunk *c = &v->chunks[i];
        const gs__ghost *g;
        if (c->flags & GS_WIRE_CHUNK_ACK) { /* its object id is a host's */
            ghosts[i] = NULL;
            continue;
        }
        ghosts[i] = i > 0 && ghosts[i - 1] && c->object_id == v->chunks[i - 1].object_id
                        ? ghosts[i - 1] : gs__ghost_find(net->world, c->object_id);
        g = ghosts[i];
        if (!g) {
            gs__mismatch_note(net, GS__MISMATCH_OBJECT, c->object_id, 0, 0, 0);
            *why = GS_REJECT_OBJECT;
            return 0;
        }
        if (c->flags & GS_WIRE_CHUNK_REST) { /* a heartbeat: no values */
            if (c->count != g->nchunks || c->encoding != g->d.encoding) {
                *why = GS_REJECT_RANGE;
                return 0;
            }
            continue;
        }
        size_t first = (size_t)c->index * (size_t)g->per_chunk;
        size_t want = first < g->n - 1 ? g->n - 1 - first : 0;
        if (want > (size_t)g->per_chunk) want = (size_t)g->per_chunk;
        /* chunk i holds exactly values [i per_chunk, its end): anything else
           would leave part of its range unfilled but marked received */
        if (c->count != g->nchunks || c->encoding != g->d.encoding ||
            c->first != first || c->elements != want) {
            gs__range_note(net, g, c);
            *why = GS_REJECT_RANGE;
            return 0;
        }
        if (net->d.time_window > 0.0 && fabs(c->time - g->t_local) > net->d.time_window) {
            *why = GS_REJECT_TIME;
            return 0;
        }
    }
    return 1;
}

/* The queue slot for snapshot seq from peer p: the one being assembled, or
   a free one, or the oldest (which is dropped and counted). */
GS__PRIVATE gs__snap *gs__snap_slot(gs__ghost *g, int p, const gs_wire_chunk *c,
                                    double age) {
    gs__snap *q = g->gp[p].q, *free_s = NULL, *oldest = NULL;
    int k;
    for (k = 0; k < g->d.queue_size; ++k) {
        gs__snap *s = &q[k];
        if (s->used && s->seq == c->sequence) return s;
        if (!s->used && !free_s) free_s = s;
        if (s->used && (!oldest || gs__seq_newer(oldest->seq, s->seq))) oldest = s;
    }
    if (!free_s) {
        free_s = oldest;
        g->stats.queue_dropped++;
        memset(free_s->got, 0, (size_t)g->nchunks);
    }
    free_s->used = 1;
    free_s->seq = c->sequence;
    free_s->time = c->time;
    free_s->age = age >= 0.0 ? age : 0.0;
    free_s->age_known = age >= 0.0;
    free_s->chunks = 0;
    free_s->waited = 0;
    return free_s;
}

/* A heartbeat: the peer's state still stands as last sent, now at the
   heartbeat's time. It is queued again as a snapshot, so that a follower
   keeps being pulled to a leader at rest (silent, it would drift off on
   its own), once the last values of every chunk are known. */
GS__PRIVATE void gs__heartbeat(gs_net *net, gs__ghost *g, int p, const gs_wire_chunk *c,
                               double age) {
    gs__snap *s, *last = &g->gp[p].q[g->d.queue_size];
    net->peers[p].st.heartbeats_received++;
    if (c->time > net->peers[p].st.last_remote_time) net->peers[p].st.last_remote_time = c->time;
    if (last->chunks < g->nchunks) return;
    s = gs__snap_slot(g, p, c, age);
    if (s->chunks == g->nchunks) return; /* a duplicated heartbeat */
    memcpy(s->data, last->data, (g->n - 1) * sizeof(double));
    /* rest_extrapolate: it stands for the sender's prediction, the last
       values carried to its time as the sender carries them (a prediction
       out of range leaves them as they were: the sender sends its state) */
    if (g->d.rest_extrapolate && !gs__rest_carry(g, s->data, c->time - last->time))
        memcpy(s->data, last->data, (g->n - 1) * sizeof(double));
    memset(s->got, 1, (size_t)g->nchunks);
    s->chunks = g->nchunks;
}

/* A delta chunk's integers (into g->kbuf) from its baseline's, and the
   baseline's segments (into seg, *nseg); 0 if refused: the baseline is not
   held (or the ghost codes no deltas), or the sum leaves its ranges. Then
   it is counted, and the next acknowledgement asks for a whole one. vals:
   its Rice values as the parse kept them (NULL: read from its bits). */
GS__PRIVATE int gs__delta_take(gs_net *net, gs__ghost *g, int p, const gs_wire_chunk *c,
                               const int32_t *vals, gs_wire_segment *seg, int *nseg) {
    const gs__base *b = g->gp[p].ring ? gs__ring_find(g->gp[p].ring, c->baseline) : NULL;
    int i, ok = b && b->got[c->index];
    if (ok) {
        *nseg = b->nseg[c->index];
        memcpy(seg, b->seg + (size_t)c->index * GS_WIRE_MAX_SEGMENTS,
               (size_t)*nseg * sizeof *seg);
        ok = gs__delta_sum(c, vals, b->k + c->first, g->kbuf); /* one pass, checked */
        if (c->flags & GS_WIRE_CHUNK_PREDICT) { /* one meaning: it must carry something */
            int64_t *pr = g->kbuf + g->per_chunk;
            size_t span = 0;
            ok = ok && gs__delta_pred(g, b, seg, *nseg, c->first, c->elements,
                                      c->time - b->time, pr, &span) > 0;
            for (i = 0; i < (int)span && ok; ++i) g->kbuf[i] += pr[i];
        }
        ok = ok && gs__qk_ok(seg, *nseg, g->kbuf);
    }
    if (!ok) {
        net->peers[p].st.rejected[GS_REJECT_BASELINE]++;
        net->peers[p].st.rejected_total++;
        g->gp[p].nack_due = 1;
    }
    return ok;
}

/* A quantized chunk received (k: its integers; NULL: read them from c)
   kept as part of a baseline; a snapshot held whole is acknowledged. */
GS__PRIVATE void gs__ring_keep(gs__ghost *g, int p, const gs_wire_chunk *c, const int64_t *k,
                               const gs_wire_segment *seg, int nseg) {
    struct gs__ghost_peer *gp = &g->gp[p];
    gs__base *e = gs__ring_slot(gp->ring, g->nchunks, c->sequence, NULL);
    if (!e || e->got[c->index]) return;
    e->time = c->time; /* every chunk of a snapshot has its time */
    if (k) memcpy(e->k + c->first, k, (size_t)c->elements * sizeof *k);
    else gs__qk_from_chunk(c, e->k + c->first);
    memcpy(e->seg + (size_t)c->index * GS_WIRE_MAX_SEGMENTS, seg, (size_t)nseg * sizeof *seg);
    e->nseg[c->index] = (unsigned char)nseg;
    e->got[c->index] = 1;
    if (++e->chunks == g->nchunks && (!gp->ack_known || gs__seq_newer(e->seq, gp->ack_seq))) {
        gp->ack_seq = e->seq;
        gp->ack_known = 1;
        gp->ack_due = 1;
        gp->acks_held++;
    }
}

/* A chunk of peer p's ghost g received (vals: as gs__delta_take's). */
GS__PRIVATE void gs__queue_chunk(gs_net *net, gs__ghost *g, int p, const gs_wire_chunk *c,
                                 const int32_t *vals, double age) {
    gs__snap *s, *last = &g->gp[p].q[g->d.queue_size];
    gs_wire_segment seg[GS_WIRE_MAX_SEGMENTS];
    int nseg = 0, delta = (c->flags & GS_WIRE_CHUNK_DELTA) != 0;
    g->gp[p].resting = (c->flags & GS_WIRE_CHUNK_REST) != 0;
    if (g->gp[p].resting) {
        gs__heartbeat(net, g, p, c, age);
        return;
    }
    if (delta && !gs__delta_take(net, g, p, c, vals, seg, &nseg)) return;
    s = gs__snap_slot(g, p, c, age);
    if (s->got[c->index]) return; /* a duplicated chunk */
    if (delta) {
        gs__qk_values(seg, nseg, g->kbuf, s->data + c->first);
    } else {
        gs__wire_get_values(c, s->data + c->first);
        nseg = c->segment_count;
        memcpy(seg, c->segments, (size_t)nseg * sizeof *seg);
    }
    if (g->gp[p].ring && c->encoding == GS_ENCODING_QUANT)
        gs__ring_keep(g, p, c, delta ? g->kbuf : NULL, seg, nseg);
    /* the newest values of each chunk: a late older chunk leaves them */
    if (!last->used || !gs__seq_newer(last->seq, c->sequence)) {
        size_t cnt = c->elements;
        last->used = 1;
        last->seq = c->sequence;
        last->time = c->time; /* what a heartbeat's prediction starts from */
        memcpy(last->data + c->first, s->data + c->first, cnt * sizeof(double));
        if (!last->got[c->index]) last->chunks++;
        last->got[c->index] = 1;
    }
    s->got[c->index] = 1;
    s->chunks++;
    net->peers[p].st.chunks_received++;
    if (c->index == 0) net->peers[p].st.snapshots_received++;
    if (c->time > net->peers[p].st.last_remote_time) net->peers[p].st.last_remote_time = c->time;
}

/* An acknowledgement chunk from peer p: what it holds of our delta
   ghosts' snapshots (chunks for other hosts are skipped). */
GS__PRIVATE void gs__take_acks(gs_net *net, int p, const gs_wire_chunk *c) {
    gs_wire_ack acks[GS_WIRE_MAX_ACKS];
    int i, n;
    if (c->object_id != net->world->host_id) return;
    n = gs_wire_acks(c, acks, GS_WIRE_MAX_ACKS);
    for (i = 0; i < n; ++i) {
        gs__ghost *g = gs__ghost_find(net->world, acks[i].object_id);
        struct gs__ghost_peer *gp;
        if (!g || !g->ring) continue;
        gp = &g->gp[p];
        if (acks[i].refused) gp->acked_known = 0; /* the next goes whole */
        else if (!gp->acked_known || gs__seq_newer(acks[i].sequence, gp->acked)) {
            gp->acked = acks[i].sequence;
            gp->acked_known = 1;
        }
    }
}

GS__PRIVATE gs_result gs__reject(gs_net *net, int p, gs_reject r, gs_reject *why) {
    if (p >= 0) {
        net->peers[p].st.rejected[r]++;
        net->peers[p].st.rejected_total++;
    } else {
        net->unknown_rejected[r]++;
    }
    if (why) *why = r;
    return GS_ERR_REJECTED;
}

/* Round trip from the echo: now - echo_time - the time they held it,
   smoothed as TCP does (7/8 old, 1/8 new). Only the newest datagram counts:
   one held back by reordering echoes an old send time and would make the
   round trip look up to a latency longer.

   The same round trip places their clock against ours, as NTP does: their
   datagram left at send_time on their clock and arrived at `now` on ours,
   so arrival - send time is the offset between the clocks plus the way
   here, which is between 0 and the round trip; taken as half of it, the
   error is at most half a round trip. The round trip with the least delay
   gives the best offset, and the offset does not change while both clocks
   run: the best one is kept (its error bound widened by GS__CLOCK_DRIFT
   per second, so that a fresh one replaces it in time) until a round trip
   with less delay comes, or one whose bounds exclude it (a clock stepped,
   a peer started again). A smoothed or recent round trip would not do:
   when the latency falls, the first datagrams of the fast link would be
   taken for a latency old, the peer's clock for that far ahead, and every
   agent would jump forward (0.1-0.2 s when a 150 ms delay ends, enough
   to throw a sphere off the cloth). */
#define GS__CLOCK_DRIFT 1e-4 /* s/s: 100 ppm, more than crystals drift */
GS__PRIVATE void gs__peer_clock(gs__peer *pe, const gs_wire_header *h, double now) {
    if (h->echo_time > 0.0) {
        double rtt = now - h->echo_time - h->echo_hold;
        if (rtt >= 0.0 && rtt < 60.0) {
            double d = now - h->send_time;
            double half = 0.5 * pe->clock_rtt + GS__CLOCK_DRIFT * (now - pe->clock_at);
            pe->st.rtt = pe->st.rtt > 0.0 ? 0.875 * pe->st.rtt + 0.125 * rtt : rtt;
            if (!pe->clock_known || 0.5 * rtt <= half || pe->clock_offset + half < d - rtt ||
                pe->clock_offset - half > d) {
                pe->clock_known = 1;
                pe->clock_offset = d - 0.5 * rtt;
                pe->clock_rtt = rtt;
                pe->clock_at = now;
            }
        }
    }
    pe->their_send_time = h->send_time;
    pe->their_recv_now = now;
}

/* How long a datagram was on the way (s): its arrival less its send time
   less the clocks' offset. Per datagram, so one held back on the way is as
   old as it is. -1 (unknown) before the first round trip, and for a send
   time more than GS_MAX_AGE off the peer's clock as we know it: a forged
   one, or a clock that stepped and is not read again yet. Believed, it
   would carry the snapshot's time that far (a send time of 0 an hour into
   a session: an hour). */
GS__PRIVATE double gs__datagram_age(const gs__peer *pe, const gs_wire_header *h, double now) {
    double age;
    if (!pe->clock_known) return -1.0;
    age = now - h->send_time - pe->clock_offset;
    if (!(age <= GS_MAX_AGE && age >= -GS_MAX_AGE)) return -1.0;
    return age > 0.0 ? age : 0.0;
}

/* The receive cap: a bucket of max_rate datagrams/s holding a quarter
   second (at least 16). A clock that goes back refills nothing. */
GS__PRIVATE int gs__peer_rate(gs_net *net, gs__peer *pe, double now) {
    gs__peer_guard *g = &pe->guard;
    double cap = 0.25 * net->d.max_rate;
    if (cap < 16.0) cap = 16.0;
    if (!gs__finite(now)) now = g->rate_at;
    if (!g->rate_init) {
        g->rate_init = 1;
        g->rate_tokens = cap;
        g->rate_at = now;
    }
    if (now > g->rate_at) g->rate_tokens += (now - g->rate_at) * net->d.max_rate;
    g->rate_at = now;
    if (g->rate_tokens > cap) g->rate_tokens = cap;
    if (g->rate_tokens < 1.0) return 0;
    g->rate_tokens -= 1.0;
    return 1;
}

/* The replay window of sealed datagrams (RFC 6479's bitmap): is the
   datagram with this nonce new? 2: from a later run of the peer (or the
   first heard), 1: new in the current run, 0: seen already (a duplicate
   or a replay), -1: from an earlier run or older than the window. */
GS__PRIVATE int gs__replay_check(const gs__replay *rp, uint64_t epoch, uint64_t salt,
                                 uint64_t c) {
    if (!rp->known || epoch > rp->epoch) return 2;
    if (epoch < rp->epoch || salt != rp->salt) return -1;
    if (c > rp->top) return 1;
    if (rp->top - c >= (GS__REPLAY_WORDS - 1) * 64) return -1;
    return (rp->bits[(c >> 6) % GS__REPLAY_WORDS] >> (c & 63)) & 1 ? 0 : 1;
}

/* Records an authenticated datagram in the window (order from the check). */
GS__PRIVATE void gs__replay_mark(gs__replay *rp, uint64_t epoch, uint64_t salt, uint64_t c,
                                 int order) {
    if (order == 2) {
        memset(rp, 0, sizeof *rp);
        rp->known = 1;
        rp->epoch = epoch;
        rp->salt = salt;
        rp->top = c;
    } else if (c > rp->top) { /* clear the words the window moves over */
        uint64_t from = rp->top >> 6, to = c >> 6, i;
        if (to - from > GS__REPLAY_WORDS) to = from + GS__REPLAY_WORDS;
        for (i = from + 1; i <= to; ++i) rp->bits[i % GS__REPLAY_WORDS] = 0;
        rp->top = c;
    }
    rp->bits[(c >> 6) % GS__REPLAY_WORDS] |= (uint64_t)1 << (c & 63);
}

/* The session, then the sender: from here on a refusal is the peer's. */
GS__PRIVATE int gs__receive_sender(gs_net *net, uint32_t session, uint32_t sender, int *p,
                                   gs_reject *why) {
    if (session != net->d.session) {
        net->detail.what = GS__MISMATCH_SESSION;
        net->detail.here = (long)net->d.session;
        net->detail.there = (long)session;
        *why = GS_REJECT_SESSION;
        return 0;
    }
    if ((*p = gs__peer_slot(net, sender)) < 0) { *why = GS_REJECT_SENDER; return 0; }
    return 1;
}

/* Any datagram to a keyed net: the cheap checks, the replay window, then
   one authentication and decryption, then the decode into net->view. */
GS__PRIVATE int gs__receive_sealed(gs_net *net, const unsigned char *buf, size_t size, int *p,
                                   gs_reject *why) {
    const unsigned char *nonce = buf + size - GS_WIRE_SEAL_TRAILER;
    uint64_t epoch, salt, counter;
    int order;
    unsigned flags = gs__hdr_flags(buf);
    if (flags & ~(unsigned)(GS_WIRE_FLAG_SEALED | GS_WIRE_FLAG_SYNC)) {
        *why = GS_REJECT_LAYOUT;
        return 0;
    }
    if ((flags & GS_WIRE_FLAG_SEALED) && size < GS_WIRE_HEADER + GS_WIRE_SEAL_TRAILER) {
        *why = GS_REJECT_SHORT;
        return 0;
    }
    if (!gs__receive_sender(net, gs__hdr_session(buf), gs__hdr_sender(buf), p, why)) return 0;
    if (!(flags & GS_WIRE_FLAG_SEALED)) { *why = GS_REJECT_KEY; return 0; }
    gs__wire_nonce_read(nonce, &epoch, &salt, &counter);
    order = gs__replay_check(&net->peers[*p].guard.replay, epoch, salt, counter);
    if (order <= 0) {
        if (order == 0) net->peers[*p].st.duplicates++;
        *why = GS_REJECT_REPLAY;
        return 0;
    }
#ifdef GHOSTSIM_SODIUM
    if (!gs__wire_open(buf, size, net->guard.key, net->guard.plain)) {
        *why = GS_REJECT_AUTH;
        return 0;
    }
#else
    *why = GS_REJECT_KEY; /* not reached: no net is keyed without libsodium */
    return 0;
#endif
    gs__replay_mark(&net->peers[*p].guard.replay, epoch, salt, counter, order);
    if (order == 2) net->peers[*p].recv_any = 0; /* a new run: its sequence starts anew */
    return gs__wire_parse(net->guard.plain, size - GS_WIRE_SEAL_TRAILER, &net->view,
                          &net->kept, why);
}

/* Everything up to a decoded datagram from a known peer (*p, -1 while the
   sender is not known). */
GS__PRIVATE int gs__receive(gs_net *net, const unsigned char *buf, size_t size, int *p,
                            gs_reject *why) {
    if (!gs__wire_front(buf, size, why)) return 0;
    if (net->guard.keyed) return gs__receive_sealed(net, buf, size, p, why);
    if (!gs__wire_decode(buf, size, &net->view, &net->kept, why)) return 0;
    return gs__receive_sender(net, net->view.header.session, net->view.header.sender, p, why);
}

GS__PRIVATE void gs__sync_heard(gs_net *net, int p, const gs_wire_view *v, double now);

/* gs_net_deliver under the net lock. */
GS__PRIVATE gs_result gs__deliver_locked(gs_net *net, const void *data, size_t size, double now,
                                         gs_reject *why) {
    gs_wire_view *v = &net->view;
    gs__ghost *ghosts[GS_WIRE_MAX_CHUNKS];
    gs_reject r = GS_REJECT_SHORT;
    gs_result res = GS_OK;
    int p = -1, i, order;
    net->detail.what = GS__MISMATCH_NONE;
    gs__diag_clock(net, now);
    if (!gs__receive(net, (const unsigned char *)data, size, &p, &r)) {
        res = gs__reject(net, p, r, why);
    } else if (!gs__chunks_fit(net, v, now, ghosts, &r)) {
        res = gs__reject(net, p, r, why);
    } else if (!gs__peer_run(net, p, v->header.run)) {
        res = gs__reject(net, p, GS_REJECT_REPLAY, why);
    } else if ((order = gs__peer_sequence(&net->peers[p], v->header.sequence)) == 0) {
        net->peers[p].st.duplicates++;
        res = gs__reject(net, p, GS_REJECT_DUPLICATE, why);
    } else if (!gs__peer_rate(net, &net->peers[p], now)) {
        res = gs__reject(net, p, GS_REJECT_RATE, why);
    } else {
        gs__peer *pe = &net->peers[p];
        double age;
        if (order == 2) gs__peer_clock(pe, &v->header, now);
        age = gs__datagram_age(pe, &v->header, now);
        pe->st.datagrams_received++;
        pe->st.bytes_received += size;
        pe->st.last_heard = now;
        for (i = 0; i < v->chunk_count; ++i) {
            if (ghosts[i])
                gs__queue_chunk(net, ghosts[i], p, &v->chunks[i], net->kept.at[i], age);
            else gs__take_acks(net, p, &v->chunks[i]);
        }
        gs__sync_heard(net, p, v, now);
        gs__diag_taken(&pe->diag, now);
        pe->diag.sync = v->header.sync;
    }
    if (res == GS_ERR_REJECTED) gs__diag_refused(net, p, r, (const unsigned char *)data, size, now);
    return res;
}

GS_API gs_result gs_net_deliver(gs_net *net, const void *data, size_t size,
                                double now, gs_reject *why) {
    gs_result r;
    if (!net || (!data && size > 0)) return GS_ERR_INVALID_ARG;
    if (!gs__wire_time_ok(now)) /* a clock; NaN included */
        return gs__finite(now) ? GS_ERR_INVALID_ARG : GS_ERR_NOT_FINITE;
    gs__lock(net);
    /* from the send callback (its datagram is the net's buffer): refused,
       not counted */
    r = net->inside ? GS_ERR_BUSY : gs__deliver_locked(net, data, size, now, why);
    gs__unlock(net);
    return r;
}

/* A refusal decided by the transport (the UDP allow-list): counted on the
   peer named `host`, or among the unknown ones. Call under the net lock. */
GS__PRIVATE void gs__net_refuse(gs_net *net, uint32_t host, gs_reject r, double now) {
    int p = gs__peer_slot(net, host);
    gs__reject(net, p, r, NULL);
    net->detail.what = GS__MISMATCH_NONE;
    if (p >= 0) gs__diag_refused(net, p, r, NULL, 0, now);
}

/* ========================================================================
   >>simnet
   ======================================================================== */
#define GS__SIM_MAX_HOSTS 16

typedef struct gs__flight {
    double at;       /* s, virtual delivery time */
    uint64_t order;  /* ties broken by send order: deterministic */
    int to;          /* host slot */
    uint16_t size;
    unsigned char *data;
} gs__flight;

/* A slot's life: handed out by gs_simnet_transport, joined at its net's
   create, gone at its net's destroy (never given again: datagrams still
   in flight to it are dropped). */
enum { GS__SIM_RESERVED, GS__SIM_JOINED, GS__SIM_GONE };

typedef struct gs__sim_host {
    gs_simnet *sim;
    gs_world *world;
    gs_net *net;
    uint32_t host;
    int state;             /* GS__SIM_RESERVED, _JOINED, _GONE */
    int handed;            /* reserved and given out: not to give again
                              (a failed create gives it back) */
    gs_clock_fn prev_clock; /* the world's session clock before it joined */
    void *prev_clock_user;
    double busy_until[GS__SIM_MAX_HOSTS]; /* bandwidth: link free again at */
    gs_sim_clock clock;  /* the host's own clock (rate 1, offset 0 at first) */
} gs__sim_host;

struct gs_simnet {
    gs_allocator alloc;
    uint64_t rng;
    double now;
    int hosts;          /* slots handed out (joined or not) */
    gs__sim_host host[GS__SIM_MAX_HOSTS];
    gs_link_desc link[GS__SIM_MAX_HOSTS][GS__SIM_MAX_HOSTS];
    gs__flight *heap;   /* a binary min-heap on (at, order) */
    unsigned char *pool;
    int *free_slots, nfree;
    int count, cap;
    uint64_t order, dropped, duplicated, delivered;
    int running;        /* inside gs_simnet_run: its hosts are in use */
    char error[256];    /* gs_simnet_error */
};

/* Records a failure on the simnet and returns its code. */
GS__PRIVATE GS__PRINTF(3, 4) gs_result gs__sim_fail(gs_simnet *s, gs_result r,
                                                    const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(s->error, sizeof s->error, fmt, ap);
    va_end(ap);
    return r;
}

GS_API const char *gs_simnet_error(const gs_simnet *s) { return s ? s->error : ""; }

/* xorshift64*: one stream for the whole simnet, so a seed fixes the run. */
GS__PRIVATE double gs__sim_rand(gs_simnet *s) {
    s->rng ^= s->rng >> 12;
    s->rng ^= s->rng << 25;
    s->rng ^= s->rng >> 27;
    return (double)((s->rng * 2685821657736338717ull) >> 11) / 9007199254740992.0;
}

GS_API gs_link_desc gs_link_desc_default(void) {
    gs_link_desc d;
    memset(&d, 0, sizeof d);
    return d;
}

GS_API gs_simnet_desc gs_simnet_desc_default(void) {
    gs_simnet_desc d;
    memset(&d, 0, sizeof d);
    d.seed = 1;
    d.max_in_flight = 16384;
    return d;
}

GS_API gs_sim_clock gs_sim_clock_default(void) {
    gs_sim_clock c;
    memset(&c, 0, sizeof c);
    c.rate = 1.0;
    return c;
}

GS_API gs_result gs_simnet_create(const gs_simnet_desc *desc, gs_simnet **out) {
    gs_simnet_desc d;
    gs_simnet *s;
    size_t bytes;
    int i;
    if (!out) return GS_ERR_INVALID_ARG;
    *out = NULL;
    memset(&d, 0, sizeof d);
    if (desc) d = *desc;
    if (d.seed == 0) d.seed = gs_simnet_desc_default().seed;
    if (d.max_in_flight == 0) d.max_in_flight = gs_simnet_desc_default().max_in_flight;
    if (d.max_in_flight < 1 || d.max_in_flight > (1 << 22)) return GS_ERR_INVALID_ARG;
    if (!d.allocator.alloc != !d.allocator.free) return GS_ERR_INVALID_ARG;
    if (!d.allocator.alloc) { d.allocator.alloc = gs__default_alloc; d.allocator.free = gs__default_free; }
    if (!gs__size((size_t)d.max_in_flight, sizeof(gs__flight) + sizeof(int) + GS_WIRE_MAX_DATAGRAM,
                  sizeof *s, &bytes))
        return GS_ERR_OUT_OF_RANGE;
    s = (gs_simnet *)d.allocator.alloc(bytes, d.allocator.user);
    if (!s) return GS_ERR_NO_MEMORY;
    memset(s, 0, sizeof *s);
    s->alloc = d.allocator;
    s->rng = d.seed;
    s->cap = d.max_in_flight;
    s->heap = (gs__flight *)(s + 1);
    s->free_slots = (int *)(s->heap + s->cap);
    s->pool = (unsigned char *)(s->free_slots + s->cap);
    for (i = 0; i < s->cap; ++i) s->free_slots[i] = s->cap - 1 - i;
    s->nfree = s->cap;
    *out = s;
    return GS_OK;
}

/* From a callback inside gs_simnet_run: ignored (the run goes on in it). */
GS__PRIVATE gs_result gs__sim_dead_send(void *user, uint32_t host, const void *data,
                                        size_t size);

GS_API void gs_simnet_destroy(gs_simnet *s) {
    int i;
    if (!s || s->running) return;
    /* nets that outlive it keep no pointer into it */
    for (i = 0; i < s->hosts; ++i) {
        gs__sim_host *h = &s->host[i];
        if (h->state != GS__SIM_JOINED) continue;
        memset(&h->net->d.transport, 0, sizeof h->net->d.transport);
        h->net->d.transport.send = gs__sim_dead_send;
        gs__sync_set_clock(h->world, h->prev_clock, h->prev_clock_user);
    }
    s->alloc.free(s, s->alloc.user);
}

GS__PRIVATE int gs__flight_less(const gs__flight *a, const gs__flight *b) {
    return a->at < b->at || (a->at == b->at && a->order < b->order);
}

GS__PRIVATE void gs__heap_push(gs_simnet *s, gs__flight f) {
    int i = s->count++;
    while (i > 0) {
        int parent = (i - 1) / 2;
        if (!gs__flight_less(&f, &s->heap[parent])) break;
        s->heap[i] = s->heap[parent];
        i = parent;
    }
    s->heap[i] = f;
}

GS__PRIVATE gs__flight gs__heap_pop(gs_simnet *s) {
    gs__flight top = s->heap[0], last = s->heap[--s->count];
    int i = 0;
    for (;;) {
        int c = 2 * i + 1;
        if (c >= s->count) break;
        if (c + 1 < s->count && gs__flight_less(&s->heap[c + 1], &s->heap[c])) c++;
        if (!gs__flight_less(&s->heap[c], &last)) break;
        s->heap[i] = s->heap[c];
        i = c;
    }
    if (s->count > 0) s->heap[i] = last;
    return top;
}

GS__PRIVATE int gs__sim_slot(const gs_simnet *s, uint32_t host) {
    int i;
    for (i = 0; i < s->hosts; ++i)
        if (s->host[i].state == GS__SIM_JOINED && s->host[i].host == host) return i;
    return -1;
}

GS__PRIVATE int gs__link_cut(const gs_link_desc *l, double now) {
    int i;
    for (i = 0; i < GS_MAX_OUTAGES; ++i)
        if (l->outage_end[i] > l->outage_start[i] && now >= l->outage_start[i] &&
            now < l->outage_end[i])
            return 1;
    return 0;
}

/* One copy onto the wire: bandwidth queueing, latency, jitter, reordering. */
GS__PRIVATE void gs__sim_launch(gs_simnet *s, gs__sim_host *from, int to,
                                const void *data, size_t size) {
    const gs_link_desc *l = &s->link[from - s->host][to];
    gs__flight f;
    double depart = s->now;
    int slot;
    if (s->nfree == 0) { s->dropped++; return; }
    if (l->bandwidth > 0.0) {
        if (from->busy_until[to] > depart) depart = from->busy_until[to];
        from->busy_until[to] = depart + (double)size / l->bandwidth;
        depart = from->busy_until[to];
    }
    f.at = depart + l->latency + l->jitter * gs__sim_rand(s);
    if (l->reorder > 0.0 && gs__sim_rand(s) < l->reorder) f.at += l->latency * gs__sim_rand(s);
    slot = s->free_slots[--s->nfree];
    f.data = s->pool + (size_t)slot * GS_WIRE_MAX_DATAGRAM;
    memcpy(f.data, data, size);
    f.size = (uint16_t)size;
    f.to = to;
    f.order = s->order++;
    gs__heap_push(s, f);
}

GS__PRIVATE gs_result gs__sim_send(void *user, uint32_t host, const void *data, size_t size) {
    gs__sim_host *from = (gs__sim_host *)user;
    gs_simnet *s = from->sim;
    int to = gs__sim_slot(s, host);
    const gs_link_desc *l;
    if (size > GS_WIRE_MAX_DATAGRAM) return GS_ERR_INVALID_ARG;
    if (to < 0) {
        int i;
        for (i = 0; i < s->hosts; ++i) /* a host whose net went: lost on the way */
            if (s->host[i].state == GS__SIM_GONE && s->host[i].host == host) {
                s->dropped++;
                return GS_OK;
            }
        return GS_ERR_INVALID_ARG; /* never on this simnet: a send failure */
    }
    l = &s->link[from - s->host][to];
    if (gs__link_cut(l, s->now) || gs__sim_rand(s) < l->loss) {
        s->dropped++;
        return GS_OK;
    }
    gs__sim_launch(s, from, to, data, size);
    if (l->duplicate > 0.0 && gs__sim_rand(s) < l->duplicate) {
        s->duplicated++;
        gs__sim_launch(s, from, to, data, size);
    }
    return GS_OK;
}

GS__PRIVATE double gs__sim_clock_fn(void *user);

GS__PRIVATE gs_result gs__sim_dead_send(void *user, uint32_t host, const void *data,
                                        size_t size) {
    (void)user;
    (void)host;
    (void)data;
    (void)size;
    return GS_ERR_INVALID_ARG; /* its simnet is destroyed */
}

/* The transport's attach: the host joins, linked both ways to every host
   joined so far. */
GS__PRIVATE gs_result gs__sim_attach(void *user, gs_net *net) {
    gs__sim_host *h = (gs__sim_host *)user;
    gs_simnet *s = h->sim;
    gs_world *w = net->world;
    gs_result r = GS_OK;
    uint32_t had = 0;
    int i, k, slot = (int)(h - s->host);
    if (s->running)
        r = gs__fail(w, GS_ERR_BUSY, "gs_net_create: the simnet is running");
    else if (h->state != GS__SIM_RESERVED)
        r = gs__fail(w, GS_ERR_INVALID_ARG, "gs_net_create: this simnet transport made a "
                     "net already (one gs_simnet_transport per host)");
    else if (gs__sim_slot(s, w->host_id) >= 0)
        r = gs__fail(w, GS_ERR_INVALID_ARG, "gs_net_create: host %lu has joined this simnet "
                     "already", (unsigned long)w->host_id);
    if (r != GS_OK) {
        if (h->state == GS__SIM_RESERVED) h->handed = 0;
        gs__sim_fail(s, r, "%s", gs_world_error(w));
        return r;
    }
    h->world = w;
    h->net = net;
    h->host = w->host_id;
    h->clock = gs_sim_clock_default();
    /* validated by doing, then undone: the hosts before the one that
       refused forget the new host again (unless they had it already) */
    for (i = 0; i < s->hosts; ++i) {
        gs__sim_host *o = &s->host[i];
        if (o->state != GS__SIM_JOINED) continue;
        if (gs__peer_slot(o->net, h->host) >= 0) had |= 1u << i;
        r = gs_net_add_peer(net, o->host, NULL);
        if (r != GS_OK) break;
        r = gs_net_add_peer(o->net, h->host, NULL);
        if (r != GS_OK) { /* its message is on the other world: bring it here */
            gs__fail(w, r, "gs_net_create: simnet host %lu: %s", (unsigned long)o->host,
                     gs_world_error(o->world));
            break;
        }
    }
    if (r != GS_OK) {
        for (k = 0; k < i; ++k)
            if (s->host[k].state == GS__SIM_JOINED && !(had & (1u << k)))
                gs_net_remove_peer(s->host[k].net, h->host);
        h->world = NULL;
        h->net = NULL;
        h->host = 0;
        h->handed = 0;
        gs__sim_fail(s, r, "%s", gs_world_error(w));
        return r;
    }
    for (i = 0; i < s->hosts; ++i) {
        memset(&s->link[i][slot], 0, sizeof(gs_link_desc));
        memset(&s->link[slot][i], 0, sizeof(gs_link_desc));
    }
    h->state = GS__SIM_JOINED;
    h->prev_clock = w->sync->d.now;
    h->prev_clock_user = w->sync->d.now_user;
    gs__sync_set_clock(w, gs__sim_clock_fn, h);
    return GS_OK;
}

/* The transport's detach (the net goes): the host leaves for good. */
GS__PRIVATE void gs__sim_detach(void *user, gs_net *net) {
    gs__sim_host *h = (gs__sim_host *)user;
    (void)net;
    if (h->state != GS__SIM_JOINED) return;
    gs__sync_set_clock(h->world, h->prev_clock, h->prev_clock_user);
    h->state = GS__SIM_GONE; /* h->host stays: what is sent to it is lost */
    h->net = NULL;
    h->world = NULL;
}

GS_API gs_result gs_simnet_transport(gs_simnet *s, gs_transport *out) {
    gs__sim_host *h = NULL;
    int i;
    if (!s) return GS_ERR_INVALID_ARG;
    if (!out) return gs__sim_fail(s, GS_ERR_INVALID_ARG, "gs_simnet_transport: out is NULL");
    memset(out, 0, sizeof *out);
    for (i = 0; i < s->hosts && !h; ++i) /* one given back by a failed create */
        if (s->host[i].state == GS__SIM_RESERVED && !s->host[i].handed) h = &s->host[i];
    if (!h && s->hosts == GS__SIM_MAX_HOSTS)
        return gs__sim_fail(s, GS_ERR_CAPACITY, "gs_simnet_transport: the simnet holds its "
                            "%d hosts already", GS__SIM_MAX_HOSTS);
    if (!h) h = &s->host[s->hosts++];
    memset(h, 0, sizeof *h);
    h->sim = s;
    h->state = GS__SIM_RESERVED;
    h->handed = 1;
    h->clock.rate = 1.0;
    out->user = h;
    out->send = gs__sim_send;
    out->attach = gs__sim_attach;
    out->detach = gs__sim_detach;
    return GS_OK;
}

GS_API gs_result gs_simnet_link(gs_simnet *s, uint32_t a, uint32_t b,
                                const gs_link_desc *desc) {
    int i, j, k;
    if (!s) return GS_ERR_INVALID_ARG;
    if (!desc) return gs__sim_fail(s, GS_ERR_INVALID_ARG, "gs_simnet_link: desc is NULL");
    if (s->running)
        return gs__sim_fail(s, GS_ERR_BUSY, "gs_simnet_link: the simnet is running");
    i = gs__sim_slot(s, a);
    j = gs__sim_slot(s, b);
    if (i < 0 || j < 0)
        return gs__sim_fail(s, GS_ERR_INVALID_ARG, "gs_simnet_link: host %lu has not joined "
                            "this simnet (gs_net_create its world's net on it first; a link names two "
                            "joined hosts)", (unsigned long)(i < 0 ? a : b));
    if (!(desc->latency >= 0.0) || !(desc->jitter >= 0.0) || !(desc->loss >= 0.0) ||
        !(desc->loss <= 1.0) || !(desc->duplicate >= 0.0) || !(desc->duplicate <= 1.0) ||
        !(desc->reorder >= 0.0) || !(desc->reorder <= 1.0) || !(desc->bandwidth >= 0.0) ||
        !gs__finite(desc->latency + desc->jitter + desc->bandwidth))
        return gs__sim_fail(s, GS_ERR_INVALID_ARG, "gs_simnet_link %lu -> %lu: latency %g, "
                            "jitter %g and bandwidth %g must be finite and >= 0; loss %g, "
                            "duplicate %g and reorder %g in [0, 1]", (unsigned long)a,
                            (unsigned long)b, desc->latency, desc->jitter, desc->bandwidth,
                            desc->loss, desc->duplicate, desc->reorder);
    for (k = 0; k < GS_MAX_OUTAGES; ++k)
        if (!gs__finite(desc->outage_start[k]) || !gs__finite(desc->outage_end[k]))
            return gs__sim_fail(s, GS_ERR_NOT_FINITE, "gs_simnet_link %lu -> %lu: outage %d "
                                "is [%g, %g), must be finite", (unsigned long)a,
                                (unsigned long)b, k, desc->outage_start[k], desc->outage_end[k]);
    s->link[i][j] = *desc;
    return GS_OK;
}

/* The simnet's time as host h's clock reads it. */
GS__PRIVATE double gs__sim_host_now(const gs__sim_host *h) {
    const gs_sim_clock *c = &h->clock;
    double t = h->sim->now;
    return c->offset + c->rate * t + (c->step_by != 0.0 && t >= c->step_at ? c->step_by : 0.0);
}

GS__PRIVATE double gs__sim_clock_fn(void *user) {
    return gs__sim_host_now((const gs__sim_host *)user);
}

GS_API gs_result gs_simnet_set_clock(gs_simnet *s, uint32_t host, const gs_sim_clock *clock) {
    gs_sim_clock c;
    int i;
    if (!s) return GS_ERR_INVALID_ARG;
    if (!clock) return gs__sim_fail(s, GS_ERR_INVALID_ARG, "gs_simnet_set_clock: clock is NULL");
    i = gs__sim_slot(s, host);
    if (i < 0)
        return gs__sim_fail(s, GS_ERR_INVALID_ARG, "gs_simnet_set_clock: host %lu has not "
                            "joined this simnet", (unsigned long)host);
    c = *clock;
    if (c.rate == 0.0) c.rate = 1.0;
    if (!gs__finite(c.offset) || !gs__finite(c.rate) || !gs__finite(c.step_at) ||
        !gs__finite(c.step_by))
        return gs__sim_fail(s, GS_ERR_NOT_FINITE, "gs_simnet_set_clock: a field is NaN or "
                            "infinite");
    if (c.rate < 0.0)
        return gs__sim_fail(s, GS_ERR_INVALID_ARG, "gs_simnet_set_clock: rate %g, must be > 0",
                            c.rate);
    s->host[i].clock = c;
    return GS_OK;
}

GS__PRIVATE void gs__sim_deliver_due(gs_simnet *s) {
    while (s->count > 0 && s->heap[0].at <= s->now) {
        gs__flight f = gs__heap_pop(s);
        gs__sim_host *to = &s->host[f.to];
        if (to->state == GS__SIM_JOINED) {
            gs_net_deliver(to->net, f.data, f.size, gs__sim_host_now(to), NULL);
            s->delivered++;
        } else {
            s->dropped++; /* its net went while it flew */
        }
        s->free_slots[s->nfree++] = (int)((f.data - s->pool) / GS_WIRE_MAX_DATAGRAM);
    }
}

GS_API gs_result gs_simnet_run(gs_simnet *s, double seconds, double frame) {
    double end;
    gs_result first = GS_OK;
    int i;
    /* a frame under GS_MIN_DT could leave now + frame == now (no progress) */
    if (!s) return GS_ERR_INVALID_ARG;
    if (!gs__finite(seconds) || seconds < 0.0 || !gs__finite(frame) ||
        !(frame >= GS_MIN_DT) || seconds > GS_WIRE_MAX_TIME - s->now)
        return gs__sim_fail(s, GS_ERR_INVALID_ARG, "gs_simnet_run: seconds %g must be finite, "
                            ">= 0 and end by GS_WIRE_MAX_TIME, frame %g finite and >= "
                            "GS_MIN_DT", seconds, frame);
    if (s->running) /* from a callback of one of its worlds */
        return gs__sim_fail(s, GS_ERR_BUSY, "gs_simnet_run: called from inside its own run");
    s->running = 1;
    for (i = 0; i < s->hosts; ++i)
        if (s->host[i].state == GS__SIM_JOINED) s->host[i].net->held = 1;
    end = s->now + seconds;
    while (s->now < end - 0.5 * frame) {
        s->now += frame;
        for (i = 0; i < s->hosts; ++i) {
            gs_result r;
            if (s->host[i].state != GS__SIM_JOINED) continue;
            r = gs_world_advance(s->host[i].world, frame, NULL);
            if (r != GS_OK && first == GS_OK) {
                first = r;
                gs__sim_fail(s, r, "gs_simnet_run: host %lu at %.6g s: %s",
                             (unsigned long)s->host[i].host, s->now,
                             gs_world_error(s->host[i].world));
            }
            gs_net_update(s->host[i].net, gs__sim_host_now(&s->host[i]));
        }
        gs__sim_deliver_due(s);
    }
    for (i = 0; i < s->hosts; ++i)
        if (s->host[i].state == GS__SIM_JOINED) s->host[i].net->held = 0;
    s->running = 0;
    return first;
}

GS_API double gs_simnet_time(const gs_simnet *s) { return s->now; }

GS_API gs_result gs_simnet_get_stats(const gs_simnet *s, gs_simnet_stats *out) {
    if (!s || !out) return GS_ERR_INVALID_ARG;
    out->dropped = s->dropped;
    out->duplicated = s->duplicated;
    out->delivered = s->delivered;
    return GS_OK;
}

/* ========================================================================
   >>udp
   ======================================================================== */
#ifndef GHOSTSIM_NO_UDP
#if !defined(_WIN32)
#include <arpa/inet.h>
#include <errno.h>
#include <netdb.h>
#include <netinet/in.h>
#include <pthread.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>
#endif

typedef struct gs__udp_peer {
    int used;
    uint32_t host;
    struct sockaddr_storage addr;
    socklen_t len;
} gs__udp_peer;

/* A datagram gs_net_update made, waiting for the net lock to be released
   before it goes out (see gs__udp_send). */
typedef struct gs__udp_out {
    struct sockaddr_storage addr;
    socklen_t len;
    size_t size;
    unsigned char data[GS_WIRE_MAX_DATAGRAM];
} gs__udp_out;
#define GS__UDP_BATCH 16
#define GS__UDP_WAIT 20000 /* us: how long gs_udp_close may wait for the gather thread */
/* s: the scatter thread's tick while ghosts publish */
#define GS__UDP_TICK 0.001
/* s: with no publish for this long, it sleeps up to GS__UDP_IDLE at a time,
   until a publish or gs_net_poll wakes it */
#define GS__UDP_ACTIVE 0.1
#define GS__UDP_IDLE 0.02

struct gs_udp {
    gs_world *world;
    gs_net *net;             /* NULL until its net's attach */
    int fd;
    int threads;
    int stop;
    pthread_t gather, scatter;
    pthread_mutex_t mu;      /* the net lock: queues, peers, stats */
    pthread_mutex_t wake_mu; /* the scatter thread's wake-up */
    pthread_cond_t wake;
    int kick;                /* under wake_mu: do not wait (a publish, a
                                poll, the close) */
    int idle;                /* the scatter thread sleeps long (atomic) */
    pthread_mutex_t send_mu; /* out and out_n; taken after mu, or alone */
    gs__udp_peer peers[GS__MAX_PEERS];
    unsigned char rbuf[GS_WIRE_MAX_DATAGRAM + 64];
    int out_n;               /* datagrams in out (atomic: read under mu) */
    gs__udp_out out[GS__UDP_BATCH];
};

GS_API double gs_udp_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Sends what gs__udp_send queued. Under send_mu. */
GS__PRIVATE void gs__udp_flush_out(gs_udp *u) {
    int i, n = __atomic_load_n(&u->out_n, __ATOMIC_RELAXED);
    for (i = 0; i < n; ++i)
        sendto(u->fd, u->out[i].data, u->out[i].size, 0,
               (const struct sockaddr *)&u->out[i].addr, u->out[i].len);
    __atomic_store_n(&u->out_n, 0, __ATOMIC_RELAXED);
}

GS__PRIVATE void gs__udp_lock(void *user) { pthread_mutex_lock(&((gs_udp *)user)->mu); }

/* Wakes the scatter thread, or keeps it from its next wait. */
GS__PRIVATE void gs__udp_kick(gs_udp *u) {
    pthread_mutex_lock(&u->wake_mu);
    u->kick = 1;
    pthread_cond_signal(&u->wake);
    pthread_mutex_unlock(&u->wake_mu);
}

/* The net lock's release; then what gs_net_update queued goes out, without
   the lock, so that the gather thread never waits on a sendto; and a
   publish wakes the scatter thread if it sleeps long. */
GS__PRIVATE void gs__udp_unlock(void *user) {
    gs_udp *u = (gs_udp *)user;
    int pending = __atomic_load_n(&u->out_n, __ATOMIC_RELAXED) > 0;
    int wake = u->threads && u->net->published && __atomic_load_n(&u->idle, __ATOMIC_RELAXED);
    pthread_mutex_unlock(&u->mu);
    if (pending) {
        pthread_mutex_lock(&u->send_mu);
        gs__udp_flush_out(u);
        pthread_mutex_unlock(&u->send_mu);
    }
    if (wake) gs__udp_kick(u);
}

/* A port in decimal, 0..65535 (getaddrinfo takes "99999" as 34463), or a
   service name for getaddrinfo to look up. */
GS__PRIVATE int gs__udp_port_ok(const char *port) {
    unsigned long v = 0;
    const char *c;
    if (*port < '0' || *port > '9') return 1;
    for (c = port; *c; ++c) {
        if (*c < '0' || *c > '9') return 0;
        v = v * 10 + (unsigned long)(*c - '0');
        if (v > 65535) return 0;
    }
    return 1;
}

/* "HOST:PORT" or "[IPV6]:PORT" to a socket address. */
GS__PRIVATE int gs__udp_resolve(const char *text, struct sockaddr_storage *out,
                                socklen_t *len) {
    char host[256];
    const char *colon, *port;
    struct addrinfo hints, *res = NULL;
    size_t n;
    if (!text) return 0;
    if (text[0] == '[') {
        const char *end = strchr(text, ']');
        if (!end || end[1] != ':') return 0;
        n = (size_t)(end - text - 1);
        if (n >= sizeof host) return 0;
        memcpy(host, text + 1, n);
        port = end + 2;
    } else {
        colon = strrchr(text, ':');
        if (!colon) return 0;
        n = (size_t)(colon - text);
        if (n >= sizeof host) return 0;
        memcpy(host, text, n);
        port = colon + 1;
    }
    host[n] = '\0';
    if (!gs__udp_port_ok(port)) return 0;
    memset(&hints, 0, sizeof hints);
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_DGRAM;
    if (*port == '\0' || getaddrinfo(host, port, &hints, &res) != 0 || !res) return 0;
    memcpy(out, res->ai_addr, res->ai_addrlen);
    *len = (socklen_t)res->ai_addrlen;
    freeaddrinfo(res);
    return 1;
}

/* The transport's send: called by gs_net_update under the net lock. With
   the threads, the datagram is copied out with its address and sent when
   the lock is released (gs__udp_unlock): a sendto on loopback takes
   microseconds, and a gather thread that finds the lock held sleeps on it
   and costs a wake-up per datagram. A full batch (a big update) goes
   out at once. In poll mode nobody else receives: it goes out now. */
GS__PRIVATE gs_result gs__udp_send(void *user, uint32_t host, const void *data,
                                   size_t size) {
    gs_udp *u = (gs_udp *)user;
    int p;
    if (size > GS_WIRE_MAX_DATAGRAM) return GS_ERR_INVALID_ARG;
    for (p = 0; p < GS__MAX_PEERS; ++p)
        if (u->peers[p].used && u->peers[p].host == host) {
            gs__udp_out *o;
            if (!u->threads) {
                ssize_t r = sendto(u->fd, data, size, 0,
                                   (const struct sockaddr *)&u->peers[p].addr, u->peers[p].len);
                return r == (ssize_t)size ? GS_OK : GS_ERR_SYSTEM;
            }
            pthread_mutex_lock(&u->send_mu);
            if (u->out_n == GS__UDP_BATCH) gs__udp_flush_out(u);
            o = &u->out[u->out_n];
            o->addr = u->peers[p].addr;
            o->len = u->peers[p].len;
            o->size = size;
            memcpy(o->data, data, size);
            __atomic_store_n(&u->out_n, u->out_n + 1, __ATOMIC_RELAXED);
            pthread_mutex_unlock(&u->send_mu);
            return GS_OK;
        }
    return GS_ERR_INVALID_ARG;
}

/* An address as (family, address bytes, port), an IPv4-mapped IPv6
   address as its IPv4 address. */
GS__PRIVATE size_t gs__udp_addr_key(const struct sockaddr_storage *a, unsigned char *key) {
    if (a->ss_family == AF_INET) {
        const struct sockaddr_in *v4 = (const struct sockaddr_in *)(const void *)a;
        key[0] = 4;
        memcpy(key + 1, &v4->sin_addr, 4);
        memcpy(key + 5, &v4->sin_port, 2);
        return 7;
    }
    if (a->ss_family == AF_INET6) {
        const struct sockaddr_in6 *v6 = (const struct sockaddr_in6 *)(const void *)a;
        if (IN6_IS_ADDR_V4MAPPED(&v6->sin6_addr)) {
            key[0] = 4;
            memcpy(key + 1, (const unsigned char *)&v6->sin6_addr + 12, 4);
            memcpy(key + 5, &v6->sin6_port, 2);
            return 7;
        }
        key[0] = 6;
        memcpy(key + 1, &v6->sin6_addr, 16);
        memcpy(key + 17, &v6->sin6_port, 2);
        memcpy(key + 19, &v6->sin6_scope_id, sizeof v6->sin6_scope_id);
        return 19 + sizeof v6->sin6_scope_id;
    }
    key[0] = 0;
    return 1;
}

GS__PRIVATE int gs__udp_same_addr(const struct sockaddr_storage *a,
                                  const struct sockaddr_storage *b) {
    unsigned char ka[32], kb[32];
    size_t na = gs__udp_addr_key(a, ka), nb = gs__udp_addr_key(b, kb);
    return ka[0] != 0 && na == nb && memcmp(ka, kb, na) == 0;
}

/* The allow-list: a ghostsim datagram that names a peer of the net as its
   sender but does not come from the address registered for it (or has
   none registered) is refused here and counted on that peer. Everything
   else goes on to the net, which refuses unknown senders. Under u->mu
   (the net lock). */
GS__PRIVATE int gs__udp_from_ok(gs_udp *u, size_t n, const struct sockaddr_storage *from) {
    uint32_t host;
    int p, ok = 1, found = 0;
    if (n < GS_WIRE_HEADER || memcmp(u->rbuf, "GSIM", 4) != 0) return 1;
    host = gs__hdr_sender(u->rbuf);
    for (p = 0; p < GS__MAX_PEERS && !found; ++p)
        if (u->peers[p].used && u->peers[p].host == host) {
            found = 1;
            ok = gs__udp_same_addr(&u->peers[p].addr, from);
        }
    if (!found) ok = gs__peer_slot(u->net, host) < 0;
    if (!ok) gs__net_refuse(u->net, host, GS_REJECT_ADDRESS, gs_udp_now());
    return ok;
}

/* Receives one datagram into u->rbuf and hands it on (flags: 0 waits up
   to the socket's receive timeout, MSG_DONTWAIT not at all). Returns 0
   when nothing came. */
GS__PRIVATE int gs__udp_take(gs_udp *u, int flags) {
    struct sockaddr_storage from;
    socklen_t flen = sizeof from;
    ssize_t n;
    memset(&from, 0, sizeof from);
    n = recvfrom(u->fd, u->rbuf, sizeof u->rbuf, flags, (struct sockaddr *)&from, &flen);
    if (n < 0) return 0;
    pthread_mutex_lock(&u->mu); /* the net lock: one for both */
    if (gs__udp_from_ok(u, (size_t)n, &from))
        gs__deliver_locked(u->net, u->rbuf, (size_t)n, gs_udp_now(), NULL);
    gs__udp_unlock(u);
    return 1;
}

/* Receives what is waiting (at most `max`, without blocking). */
GS__PRIVATE void gs__udp_drain(gs_udp *u, int max) {
    int i;
    for (i = 0; i < max && gs__udp_take(u, MSG_DONTWAIT); ++i) {}
}

/* The paper's gather thread: receive, validate, queue. It sleeps in
   recvfrom itself (the socket's receive timeout, GS__UDP_WAIT, bounds the
   wait so that a stop is seen): one system call per datagram, where
   poll, recvfrom and a last recvfrom that finds nothing made three. */
GS__PRIVATE void *gs__udp_gather(void *arg) {
    gs_udp *u = (gs_udp *)arg;
    while (!__atomic_load_n(&u->stop, __ATOMIC_ACQUIRE)) gs__udp_take(u, 0);
    return NULL;
}

/* Waits on the scatter thread's condition for at most `seconds` (under a
   second), or until a kick. Under wake_mu. */
GS__PRIVATE void gs__udp_wait(gs_udp *u, double seconds) {
    struct timespec until;
    clock_gettime(CLOCK_REALTIME, &until); /* the condition's clock */
    until.tv_nsec += (long)(seconds * 1e9);
    if (until.tv_nsec >= 1000000000) { until.tv_sec++; until.tv_nsec -= 1000000000; }
    pthread_cond_timedwait(&u->wake, &u->wake_mu, &until);
}

/* Has a ghost published since the scatter thread last looked? */
GS__PRIVATE int gs__udp_published(gs_udp *u) {
    int p;
    gs__lock(u->net);
    p = u->net->published;
    u->net->published = 0;
    gs__unlock(u->net);
    return p;
}

/* The paper's scatter thread: sends what is due, every millisecond while
   ghosts publish (as the paper's scatter, woken at each step, would) and
   when woken by gs_net_poll. After GS__UDP_ACTIVE without a publish it
   sleeps up to GS__UDP_IDLE at a time, and the next publish wakes it.
   It sleeps when idle because a tick every millisecond with nothing due
   costs a host that only receives a wake-up a millisecond: bench/transport,
   whose receiving world publishes nothing, keeps 0.73-0.76 of raw UDP's
   rate on a 2-core machine that way, 0.83-0.90 with the sleep. While
   ghosts publish it ticks every millisecond, so that a published state
   waits at most a millisecond for its send; waking only when a publish, a
   held-back B or a poll falls due would save wake-ups, but is not shown
   to hold the fault suite's figures. */
GS__PRIVATE void *gs__udp_scatter(void *arg) {
    gs_udp *u = (gs_udp *)arg;
    double last_publish = gs_udp_now();
    while (!__atomic_load_n(&u->stop, __ATOMIC_ACQUIRE)) {
        double now = gs_udp_now();
        int idle = now - last_publish > GS__UDP_ACTIVE;
        if (idle) { /* said before the last look: a publish after it kicks */
            __atomic_store_n(&u->idle, 1, __ATOMIC_SEQ_CST);
            if (gs__udp_published(u)) {
                idle = 0;
                last_publish = now;
            }
        }
        pthread_mutex_lock(&u->wake_mu);
        if (!u->kick && !__atomic_load_n(&u->stop, __ATOMIC_ACQUIRE))
            gs__udp_wait(u, idle ? GS__UDP_IDLE : GS__UDP_TICK);
        u->kick = 0;
        pthread_mutex_unlock(&u->wake_mu);
        __atomic_store_n(&u->idle, 0, __ATOMIC_RELAXED);
        now = gs_udp_now();
        if (gs__udp_published(u)) last_publish = now;
        gs_net_update(u->net, now);
    }
    return NULL;
}

GS__PRIVATE gs_result gs__udp_socket(gs_udp *u, const gs_udp_desc *d) {
    struct sockaddr_storage addr;
    socklen_t len;
    int rcv = d->rcvbuf ? d->rcvbuf : gs_udp_desc_default().rcvbuf;
    if (!gs__udp_resolve(d->bind, &addr, &len))
        return gs__fail(u->world, GS_ERR_INVALID_ARG, "gs_udp_create: bind address \"%s\" is "
                        "not HOST:PORT or [IPV6]:PORT", d->bind ? d->bind : "(null)");
    u->fd = socket(addr.ss_family, SOCK_DGRAM, 0);
    if (u->fd < 0)
        return gs__fail(u->world, GS_ERR_SYSTEM, "gs_udp_create: socket: %s", strerror(errno));
    setsockopt(u->fd, SOL_SOCKET, SO_RCVBUF, &rcv, sizeof rcv);
    if (d->threads) { /* the gather thread's longest wait (poll mode never waits) */
        struct timeval tv;
        tv.tv_sec = 0;
        tv.tv_usec = GS__UDP_WAIT;
        if (setsockopt(u->fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv) != 0) {
            /* without it the gather thread could wait forever: no close */
            gs_result r = gs__fail(u->world, GS_ERR_SYSTEM, "gs_udp_create: SO_RCVTIMEO: %s",
                                   strerror(errno));
            close(u->fd);
            u->fd = -1;
            return r;
        }
    }
    if (bind(u->fd, (const struct sockaddr *)&addr, len) != 0) {
        gs_result r = gs__fail(u->world, GS_ERR_SYSTEM, "gs_udp_create: bind %s: %s", d->bind,
                               strerror(errno));
        close(u->fd);
        u->fd = -1;
        return r;
    }
    return GS_OK;
}

GS__PRIVATE gs_result gs__udp_start(gs_udp *u) {
    if (pthread_create(&u->gather, NULL, gs__udp_gather, u) != 0)
        return gs__fail(u->world, GS_ERR_SYSTEM, "gs_net_create: gs_udp cannot start the gather thread");
    if (pthread_create(&u->scatter, NULL, gs__udp_scatter, u) != 0) {
        __atomic_store_n(&u->stop, 1, __ATOMIC_RELEASE);
        pthread_join(u->gather, NULL);
        return gs__fail(u->world, GS_ERR_SYSTEM, "gs_net_create: gs_udp cannot start the scatter thread");
    }
    return GS_OK;
}

GS_API gs_udp_desc gs_udp_desc_default(void) {
    gs_udp_desc d;
    memset(&d, 0, sizeof d);
    d.rcvbuf = 4 << 20;
    return d;
}

/* The socket and the mutexes go (the threads are stopped or never ran). */
GS__PRIVATE void gs__udp_free(gs_udp *u) {
    gs_world *w = u->world;
    if (u->fd >= 0) close(u->fd);
    pthread_cond_destroy(&u->wake);
    pthread_mutex_destroy(&u->send_mu);
    pthread_mutex_destroy(&u->wake_mu);
    pthread_mutex_destroy(&u->mu);
    gs__free(w, u);
}

GS_API gs_result gs_udp_create(gs_world *w, const gs_udp_desc *desc, gs_udp **out) {
    gs_udp *u;
    gs_result r;
    if (out) *out = NULL;
    r = gs__world_unlocked(w, "gs_udp_create");
    if (r != GS_OK) return r;
    if (!desc || !out)
        return gs__fail(w, GS_ERR_INVALID_ARG, "gs_udp_create: desc and out are required");
    u = (gs_udp *)gs__alloc(w, sizeof *u);
    if (!u) return gs__fail(w, GS_ERR_NO_MEMORY, "gs_udp_create: out of memory");
    memset(u, 0, sizeof *u);
    u->world = w;
    u->fd = -1;
    u->threads = desc->threads;
    {   /* recursive: the send callback runs under it, and its calls into
           the net (stats; the refused ones see net->inside) take it again */
        pthread_mutexattr_t ma;
        pthread_mutexattr_init(&ma);
        pthread_mutexattr_settype(&ma, PTHREAD_MUTEX_RECURSIVE);
        pthread_mutex_init(&u->mu, &ma);
        pthread_mutexattr_destroy(&ma);
    }
    pthread_mutex_init(&u->wake_mu, NULL);
    pthread_mutex_init(&u->send_mu, NULL);
    pthread_cond_init(&u->wake, NULL);
    r = gs__udp_socket(u, desc);
    if (r != GS_OK) {
        gs__udp_free(u);
        return r;
    }
    *out = u;
    return GS_OK;
}

/* The transport's attach: the net's lock becomes the socket's mutex, and
   the threads start. */
GS__PRIVATE gs_result gs__udp_attach(void *user, gs_net *net) {
    gs_udp *u = (gs_udp *)user;
    gs_net_lock lk;
    gs_result r = GS_OK;
    if (u->net)
        return gs__fail(net->world, GS_ERR_INVALID_ARG, "gs_net_create: this gs_udp has a "
                        "net already (one net per gs_udp)");
    if (net->world != u->world)
        return gs__fail(net->world, GS_ERR_INVALID_ARG, "gs_net_create: this gs_udp was "
                        "made for another world (gs_udp_create's w)");
    lk.lock = gs__udp_lock;
    lk.unlock = gs__udp_unlock;
    lk.user = u;
    u->net = net;
    gs_net_set_lock(net, lk);
    if (u->threads) r = gs__udp_start(u);
    if (r != GS_OK) {
        memset(&net->lock, 0, sizeof net->lock);
        u->net = NULL;
    }
    return r;
}

/* The transport's detach (its net goes): the threads stop, then the
   gs_udp is freed, as the net owns it. */
GS__PRIVATE void gs__udp_detach(void *user, gs_net *net) {
    gs_udp *u = (gs_udp *)user;
    if (u->threads) {
        __atomic_store_n(&u->stop, 1, __ATOMIC_RELEASE);
        gs__udp_kick(u);
        pthread_join(u->gather, NULL);
        pthread_join(u->scatter, NULL);
    }
    memset(&net->lock, 0, sizeof net->lock); /* the mutex goes with u */
    gs__udp_free(u);
}

/* From a callback of its world: refused, as gs_world_destroy (the world
   may be taking the net's snapshots or publishing under its lock). */
GS_API void gs_udp_close(gs_udp *u) {
    gs_world *w;
    if (!u) return;
    w = u->world;
    if (gs__world_locked(w)) {
        gs__fail(w, GS_ERR_BUSY, "gs_udp_close: called from a callback of its world; "
                 "refused, nothing closed");
        return;
    }
    if (u->net) gs_net_destroy(u->net); /* which frees u (its detach) */
    else gs__udp_free(u);
}

/* The transport's add_peer: adds or replaces the peer's address (the net
   adds the peer after it, see gs_net_add_peer). */
GS__PRIVATE gs_result gs__udp_add_peer(void *user, uint32_t host, const char *addr) {
    gs_udp *u = (gs_udp *)user;
    struct sockaddr_storage a;
    socklen_t len;
    int p, slot = -1;
    if (!addr)
        return gs__fail(u->world, GS_ERR_INVALID_ARG, "gs_net_add_peer: host %lu: a gs_udp "
                        "peer needs its address (\"HOST:PORT\" or \"[IPV6]:PORT\"), not NULL",
                        (unsigned long)host);
    if (!gs__udp_resolve(addr, &a, &len))
        return gs__fail(u->world, GS_ERR_INVALID_ARG, "gs_net_add_peer: address \"%s\" is not "
                        "HOST:PORT or [IPV6]:PORT", addr);
    pthread_mutex_lock(&u->mu);
    for (p = 0; p < GS__MAX_PEERS; ++p) {
        if (u->peers[p].used && u->peers[p].host == host) { slot = p; break; }
        if (!u->peers[p].used && slot < 0) slot = p;
    }
    if (slot >= 0) {
        u->peers[slot].host = host;
        u->peers[slot].addr = a;
        u->peers[slot].len = len;
        u->peers[slot].used = 1;
    }
    pthread_mutex_unlock(&u->mu);
    if (slot < 0)
        return gs__fail(u->world, GS_ERR_CAPACITY, "gs_net_add_peer: no room for host %lu",
                        (unsigned long)host);
    return GS_OK;
}

/* The transport's remove_peer: the address goes (after the net's peer). */
GS__PRIVATE gs_result gs__udp_remove_peer(void *user, uint32_t host) {
    gs_udp *u = (gs_udp *)user;
    int p;
    pthread_mutex_lock(&u->mu);
    for (p = 0; p < GS__MAX_PEERS; ++p)
        if (u->peers[p].used && u->peers[p].host == host) u->peers[p].used = 0;
    pthread_mutex_unlock(&u->mu);
    return GS_OK;
}

/* The transport's poll: poll mode receives every waiting datagram; with
   the threads it only wakes the scatter thread. */
GS__PRIVATE gs_result gs__udp_poll(void *user, gs_net *net, double now) {
    gs_udp *u = (gs_udp *)user;
    (void)net;
    (void)now; /* what it receives is delivered at gs_udp_now() */
    if (u->threads) gs__udp_kick(u);
    else gs__udp_drain(u, 4096);
    return GS_OK;
}

GS_API gs_result gs_udp_transport(gs_udp *u, gs_transport *out) {
    if (!u) return GS_ERR_INVALID_ARG;
    if (!out) return gs__fail(u->world, GS_ERR_INVALID_ARG, "gs_udp_transport: out is NULL");
    memset(out, 0, sizeof *out);
    out->user = u;
    out->send = gs__udp_send;
    out->add_peer = gs__udp_add_peer;
    out->remove_peer = gs__udp_remove_peer;
    out->attach = gs__udp_attach;
    out->poll = gs__udp_poll;
    out->detach = gs__udp_detach;
    out->sends_itself = u->threads != 0;
    return GS_OK;
}
#endif /* GHOSTSIM_NO_UDP */

/* ========================================================================
   >>crc
   ======================================================================== */
/* CRC-32 (IEEE 802.3 / zlib: reflected polynomial 0xEDB88320, initial and
   final value 0xffffffff), sliced by 16: sixteen bytes per step through
   sixteen tables. A full datagram takes 0.31 us, against 0.46 sliced by 8
   and 2.27 a byte at a time (the CRC is done once on each side of every
   datagram, and a byte at a time it is the largest part of the library's
   cost per datagram).
   The tables are constants, so that every path (gs_wire_end,
   gs_wire_decode, the net) shares one implementation with nothing to
   build and no global to set. How they were made (tests/test_wire.c
   checks the result against a bitwise CRC):
     table 0: t0[i] = i shifted right 8 times, each time xor 0xEDB88320
              when the bit shifted out was 1 (the byte-at-a-time table)
     table k: tk[i] = (t(k-1)[i] >> 8) ^ t0[t(k-1)[i] & 0xff]  (k = 1..15)
   so that tk[b] is the CRC contribution of byte b followed by k zero
   bytes. */
static const uint32_t gs__crc_table[16][256] = {
    { /* table 0 */
        0x00000000u, 0x77073096u, 0xee0e612cu, 0x990951bau, 0x076dc419u, 0x706af48fu,
        0xe963a535u, 0x9e6495a3u, 0x0edb8832u, 0x79dcb8a4u, 0xe0d5e91eu, 0x97d2d988u,
        0x09b64c2bu, 0x7eb17cbdu, 0xe7b82d07u, 0x90bf1d91u, 0x1db71064u, 0x6ab020f2u,
        0xf3b97148u, 0x84be41deu, 0x1adad47du, 0x6ddde4ebu, 0xf4d4b551u, 0x83d385c7u,
        0x136c9856u, 0x646ba8c0u, 0xfd62f97au, 0x8a65c9ecu, 0x14015c4fu, 0x63066cd9u,
        0xfa0f3d63u, 0x8d080df5u, 0x3b6e20c8u, 0x4c69105eu, 0xd56041e4u, 0xa2677172u,
        0x3c03e4d1u, 0x4b04d447u, 0xd20d85fdu, 0xa50ab56bu, 0x35b5a8fau, 0x42b2986cu,
        0xdbbbc9d6u, 0xacbcf940u, 0x32d86ce3u, 0x45df5c75u, 0xdcd60dcfu, 0xabd13d59u,
        0x26d930acu, 0x51de003au, 0xc8d75180u, 0xbfd06116u, 0x21b4f4b5u, 0x56b3c423u,
        0xcfba9599u, 0xb8bda50fu, 0x2802b89eu, 0x5f058808u, 0xc60cd9b2u, 0xb10be924u,
        0x2f6f7c87u, 0x58684c11u, 0xc1611dabu, 0xb6662d3du, 0x76dc4190u, 0x01db7106u,
        0x98d220bcu, 0xefd5102au, 0x71b18589u, 0x06b6b51fu, 0x9fbfe4a5u, 0xe8b8d433u,
        0x7807c9a2u, 0x0f00f934u, 0x9609a88eu, 0xe10e9818u, 0x7f6a0dbbu, 0x086d3d2du,
        0x91646c97u, 0xe6635c01u, 0x6b6b51f4u, 0x1c6c6162u, 0x856530d8u, 0xf262004eu,
        0x6c0695edu, 0x1b01a57bu, 0x8208f4c1u, 0xf50fc457u, 0x65b0d9c6u, 0x12b7e950u,
        0x8bbeb8eau, 0xfcb9887cu, 0x62dd1ddfu, 0x15da2d49u, 0x8cd37cf3u, 0xfbd44c65u,
        0x4db26158u, 0x3ab551ceu, 0xa3bc0074u, 0xd4bb30e2u, 0x4adfa541u, 0x3dd895d7u,
        0xa4d1c46du, 0xd3d6f4fbu, 0x4369e96au, 0x346ed9fcu, 0xad678846u, 0xda60b8d0u,
        0x44042d73u, 0x33031de5u, 0xaa0a4c5fu, 0xdd0d7cc9u, 0x5005713cu, 0x270241aau,
        0xbe0b1010u, 0xc90c2086u, 0x5768b525u, 0x206f85b3u, 0xb966d409u, 0xce61e49fu,
        0x5edef90eu, 0x29d9c998u, 0xb0d09822u, 0xc7d7a8b4u, 0x59b33d17u, 0x2eb40d81u,
        0xb7bd5c3bu, 0xc0ba6cadu, 0xedb88320u, 0x9abfb3b6u, 0x03b6e20cu, 0x74b1d29au,
        0xead54739u, 0x9dd277afu, 0x04db2615u, 0x73dc1683u, 0xe3630b12u, 0x94643b84u,
        0x0d6d6a3eu, 0x7a6a5aa8u, 0xe40ecf0bu, 0x9309ff9du, 0x0a00ae27u, 0x7d079eb1u,
        0xf00f9344u, 0x8708a3d2u, 0x1e01f268u, 0x6906c2feu, 0xf762575du, 0x806567cbu,
        0x196c3671u, 0x6e6b06e7u, 0xfed41b76u, 0x89d32be0u, 0x10da7a5au, 0x67dd4accu,
        0xf9b9df6fu, 0x8ebeeff9u, 0x17b7be43u, 0x60b08ed5u, 0xd6d6a3e8u, 0xa1d1937eu,
        0x38d8c2c4u, 0x4fdff252u, 0xd1bb67f1u, 0xa6bc5767u, 0x3fb506ddu, 0x48b2364bu,
        0xd80d2bdau, 0xaf0a1b4cu, 0x36034af6u, 0x41047a60u, 0xdf60efc3u, 0xa867df55u,
        0x316e8eefu, 0x4669be79u, 0xcb61b38cu, 0xbc66831au, 0x256fd2a0u, 0x5268e236u,
        0xcc0c7795u, 0xbb0b4703u, 0x220216b9u, 0x5505262fu, 0xc5ba3bbeu, 0xb2bd0b28u,
        0x2bb45a92u, 0x5cb36a04u, 0xc2d7ffa7u, 0xb5d0cf31u, 0x2cd99e8bu, 0x5bdeae1du,
        0x9b64c2b0u, 0xec63f226u, 0x756aa39cu, 0x026d930au, 0x9c0906a9u, 0xeb0e363fu,
        0x72076785u, 0x05005713u, 0x95bf4a82u, 0xe2b87a14u, 0x7bb12baeu, 0x0cb61b38u,
        0x92d28e9bu, 0xe5d5be0du, 0x7cdcefb7u, 0x0bdbdf21u, 0x86d3d2d4u, 0xf1d4e242u,
        0x68ddb3f8u, 0x1fda836eu, 0x81be16cdu, 0xf6b9265bu, 0x6fb077e1u, 0x18b74777u,
        0x88085ae6u, 0xff0f6a70u, 0x66063bcau, 0x11010b5cu, 0x8f659effu, 0xf862ae69u,
        0x616bffd3u, 0x166ccf45u, 0xa00ae278u, 0xd70dd2eeu, 0x4e048354u, 0x3903b3c2u,
        0xa7672661u, 0xd06016f7u, 0x4969474du, 0x3e6e77dbu, 0xaed16a4au, 0xd9d65adcu,
        0x40df0b66u, 0x37d83bf0u, 0xa9bcae53u, 0xdebb9ec5u, 0x47b2cf7fu, 0x30b5ffe9u,
        0xbdbdf21cu, 0xcabac28au, 0x53b39330u, 0x24b4a3a6u, 0xbad03605u, 0xcdd70693u,
        0x54de5729u, 0x23d967bfu, 0xb3667a2eu, 0xc4614ab8u, 0x5d681b02u, 0x2a6f2b94u,
        0xb40bbe37u, 0xc30c8ea1u, 0x5a05df1bu, 0x2d02ef8du,
    },
    { /* table 1 */
        0x00000000u, 0x191b3141u, 0x32366282u, 0x2b2d53c3u, 0x646cc504u, 0x7d77f445u,
        0x565aa786u, 0x4f4196c7u, 0xc8d98a08u, 0xd1c2bb49u, 0xfaefe88au, 0xe3f4d9cbu,
        0xacb54f0cu, 0xb5ae7e4du, 0x9e832d8eu, 0x87981ccfu, 0x4ac21251u, 0x53d92310u,
        0x78f470d3u, 0x61ef4192u, 0x2eaed755u, 0x37b5e614u, 0x1c98b5d7u, 0x05838496u,
        0x821b9859u, 0x9b00a918u, 0xb02dfadbu, 0xa936cb9au, 0xe6775d5du, 0xff6c6c1cu,
        0xd4413fdfu, 0xcd5a0e9eu, 0x958424a2u, 0x8c9f15e3u, 0xa7b24620u, 0xbea97761u,
        0xf1e8e1a6u, 0xe8f3d0e7u, 0xc3de8324u, 0xdac5b265u, 0x5d5daeaau, 0x44469febu,
        0x6f6bcc28u, 0x7670fd69u, 0x39316baeu, 0x202a5aefu, 0x0b07092cu, 0x121c386du,
        0xdf4636f3u, 0xc65d07b2u, 0xed705471u, 0xf46b6530u, 0xbb2af3f7u, 0xa231c2b6u,
        0x891c9175u, 0x9007a034u, 0x179fbcfbu, 0x0e848dbau, 0x25a9de79u, 0x3cb2ef38u,
        0x73f379ffu, 0x6ae848beu, 0x41c51b7du, 0x58de2a3cu, 0xf0794f05u, 0xe9627e44u,
        0xc24f2d87u, 0xdb541cc6u, 0x94158a01u, 0x8d0ebb40u, 0xa623e883u, 0xbf38d9c2u,
        0x38a0c50du, 0x21bbf44cu, 0x0a96a78fu, 0x138d96ceu, 0x5ccc0009u, 0x45d73148u,
        0x6efa628bu, 0x77e153cau, 0xbabb5d54u, 0xa3a06c15u, 0x888d3fd6u, 0x91960e97u,
        0xded79850u, 0xc7cca911u, 0xece1fad2u, 0xf5facb93u, 0x7262d75cu, 0x6b79e61du,
        0x4054b5deu, 0x594f849fu, 0x160e1258u, 0x0f152319u, 0x243870dau, 0x3d23419bu,
        0x65fd6ba7u, 0x7ce65ae6u, 0x57cb0925u, 0x4ed03864u, 0x0191aea3u, 0x188a9fe2u,
        0x33a7cc21u, 0x2abcfd60u, 0xad24e1afu, 0xb43fd0eeu, 0x9f12832du, 0x8609b26cu,
        0xc94824abu, 0xd05315eau, 0xfb7e4629u, 0xe2657768u, 0x2f3f79f6u, 0x362448b7u,
        0x1d091b74u, 0x04122a35u, 0x4b53bcf2u, 0x52488db3u, 0x7965de70u, 0x607eef31u,
        0xe7e6f3feu, 0xfefdc2bfu, 0xd5d0917cu, 0xcccba03du, 0x838a36fau, 0x9a9107bbu,
        0xb1bc5478u, 0xa8a76539u, 0x3b83984bu, 0x2298a90au, 0x09b5fac9u, 0x10aecb88u,
        0x5fef5d4fu, 0x46f46c0eu, 0x6dd93fcdu, 0x74c20e8cu, 0xf35a1243u, 0xea412302u,
        0xc16c70c1u, 0xd8774180u, 0x9736d747u, 0x8e2de606u, 0xa500b5c5u, 0xbc1b8484u,
        0x71418a1au, 0x685abb5bu, 0x4377e898u, 0x5a6cd9d9u, 0x152d4f1eu, 0x0c367e5fu,
        0x271b2d9cu, 0x3e001cddu, 0xb9980012u, 0xa0833153u, 0x8bae6290u, 0x92b553d1u,
        0xddf4c516u, 0xc4eff457u, 0xefc2a794u, 0xf6d996d5u, 0xae07bce9u, 0xb71c8da8u,
        0x9c31de6bu, 0x852aef2au, 0xca6b79edu, 0xd37048acu, 0xf85d1b6fu, 0xe1462a2eu,
        0x66de36e1u, 0x7fc507a0u, 0x54e85463u, 0x4df36522u, 0x02b2f3e5u, 0x1ba9c2a4u,
        0x30849167u, 0x299fa026u, 0xe4c5aeb8u, 0xfdde9ff9u, 0xd6f3cc3au, 0xcfe8fd7bu,
        0x80a96bbcu, 0x99b25afdu, 0xb29f093eu, 0xab84387fu, 0x2c1c24b0u, 0x350715f1u,
        0x1e2a4632u, 0x07317773u, 0x4870e1b4u, 0x516bd0f5u, 0x7a468336u, 0x635db277u,
        0xcbfad74eu, 0xd2e1e60fu, 0xf9ccb5ccu, 0xe0d7848du, 0xaf96124au, 0xb68d230bu,
        0x9da070c8u, 0x84bb4189u, 0x03235d46u, 0x1a386c07u, 0x31153fc4u, 0x280e0e85u,
        0x674f9842u, 0x7e54a903u, 0x5579fac0u, 0x4c62cb81u, 0x8138c51fu, 0x9823f45eu,
        0xb30ea79du, 0xaa1596dcu, 0xe554001bu, 0xfc4f315au, 0xd7626299u, 0xce7953d8u,
        0x49e14f17u, 0x50fa7e56u, 0x7bd72d95u, 0x62cc1cd4u, 0x2d8d8a13u, 0x3496bb52u,
        0x1fbbe891u, 0x06a0d9d0u, 0x5e7ef3ecu, 0x4765c2adu, 0x6c48916eu, 0x7553a02fu,
        0x3a1236e8u, 0x230907a9u, 0x0824546au, 0x113f652bu, 0x96a779e4u, 0x8fbc48a5u,
        0xa4911b66u, 0xbd8a2a27u, 0xf2cbbce0u, 0xebd08da1u, 0xc0fdde62u, 0xd9e6ef23u,
        0x14bce1bdu, 0x0da7d0fcu, 0x268a833fu, 0x3f91b27eu, 0x70d024b9u, 0x69cb15f8u,
        0x42e6463bu, 0x5bfd777au, 0xdc656bb5u, 0xc57e5af4u, 0xee530937u, 0xf7483876u,
        0xb809aeb1u, 0xa1129ff0u, 0x8a3fcc33u, 0x9324fd72u,
    },
    { /* table 2 */
        0x00000000u, 0x01c26a37u, 0x0384d46eu, 0x0246be59u, 0x0709a8dcu, 0x06cbc2ebu,
        0x048d7cb2u, 0x054f1685u, 0x0e1351b8u, 0x0fd13b8fu, 0x0d9785d6u, 0x0c55efe1u,
        0x091af964u, 0x08d89353u, 0x0a9e2d0au, 0x0b5c473du, 0x1c26a370u, 0x1de4c947u,
        0x1fa2771eu, 0x1e601d29u, 0x1b2f0bacu, 0x1aed619bu, 0x18abdfc2u, 0x1969b5f5u,
        0x1235f2c8u, 0x13f798ffu, 0x11b126a6u, 0x10734c91u, 0x153c5a14u, 0x14fe3023u,
        0x16b88e7au, 0x177ae44du, 0x384d46e0u, 0x398f2cd7u, 0x3bc9928eu, 0x3a0bf8b9u,
        0x3f44ee3cu, 0x3e86840bu, 0x3cc03a52u, 0x3d025065u, 0x365e1758u, 0x379c7d6fu,
        0x35dac336u, 0x3418a901u, 0x3157bf84u, 0x3095d5b3u, 0x32d36beau, 0x331101ddu,
        0x246be590u, 0x25a98fa7u, 0x27ef31feu, 0x262d5bc9u, 0x23624d4cu, 0x22a0277bu,
        0x20e69922u, 0x2124f315u, 0x2a78b428u, 0x2bbade1fu, 0x29fc6046u, 0x283e0a71u,
        0x2d711cf4u, 0x2cb376c3u, 0x2ef5c89au, 0x2f37a2adu, 0x709a8dc0u, 0x7158e7f7u,
        0x731e59aeu, 0x72dc3399u, 0x7793251cu, 0x76514f2bu, 0x7417f172u, 0x75d59b45u,
        0x7e89dc78u, 0x7f4bb64fu, 0x7d0d0816u, 0x7ccf6221u, 0x798074a4u, 0x78421e93u,
        0x7a04a0cau, 0x7bc6cafdu, 0x6cbc2eb0u, 0x6d7e4487u, 0x6f38fadeu, 0x6efa90e9u,
        0x6bb5866cu, 0x6a77ec5bu, 0x68315202u, 0x69f33835u, 0x62af7f08u, 0x636d153fu,
        0x612bab66u, 0x60e9c151u, 0x65a6d7d4u, 0x6464bde3u, 0x662203bau, 0x67e0698du,
        0x48d7cb20u, 0x4915a117u, 0x4b531f4eu, 0x4a917579u, 0x4fde63fcu, 0x4e1c09cbu,
        0x4c5ab792u, 0x4d98dda5u, 0x46c49a98u, 0x4706f0afu, 0x45404ef6u, 0x448224c1u,
        0x41cd3244u, 0x400f5873u, 0x4249e62au, 0x438b8c1du, 0x54f16850u, 0x55330267u,
        0x5775bc3eu, 0x56b7d609u, 0x53f8c08cu, 0x523aaabbu, 0x507c14e2u, 0x51be7ed5u,
        0x5ae239e8u, 0x5b2053dfu, 0x5966ed86u, 0x58a487b1u, 0x5deb9134u, 0x5c29fb03u,
        0x5e6f455au, 0x5fad2f6du, 0xe1351b80u, 0xe0f771b7u, 0xe2b1cfeeu, 0xe373a5d9u,
        0xe63cb35cu, 0xe7fed96bu, 0xe5b86732u, 0xe47a0d05u, 0xef264a38u, 0xeee4200fu,
        0xeca29e56u, 0xed60f461u, 0xe82fe2e4u, 0xe9ed88d3u, 0xebab368au, 0xea695cbdu,
        0xfd13b8f0u, 0xfcd1d2c7u, 0xfe976c9eu, 0xff5506a9u, 0xfa1a102cu, 0xfbd87a1bu,
        0xf99ec442u, 0xf85cae75u, 0xf300e948u, 0xf2c2837fu, 0xf0843d26u, 0xf1465711u,
        0xf4094194u, 0xf5cb2ba3u, 0xf78d95fau, 0xf64fffcdu, 0xd9785d60u, 0xd8ba3757u,
        0xdafc890eu, 0xdb3ee339u, 0xde71f5bcu, 0xdfb39f8bu, 0xddf521d2u, 0xdc374be5u,
        0xd76b0cd8u, 0xd6a966efu, 0xd4efd8b6u, 0xd52db281u, 0xd062a404u, 0xd1a0ce33u,
        0xd3e6706au, 0xd2241a5du, 0xc55efe10u, 0xc49c9427u, 0xc6da2a7eu, 0xc7184049u,
        0xc25756ccu, 0xc3953cfbu, 0xc1d382a2u, 0xc011e895u, 0xcb4dafa8u, 0xca8fc59fu,
        0xc8c97bc6u, 0xc90b11f1u, 0xcc440774u, 0xcd866d43u, 0xcfc0d31au, 0xce02b92du,
        0x91af9640u, 0x906dfc77u, 0x922b422eu, 0x93e92819u, 0x96a63e9cu, 0x976454abu,
        0x9522eaf2u, 0x94e080c5u, 0x9fbcc7f8u, 0x9e7eadcfu, 0x9c381396u, 0x9dfa79a1u,
        0x98b56f24u, 0x99770513u, 0x9b31bb4au, 0x9af3d17du, 0x8d893530u, 0x8c4b5f07u,
        0x8e0de15eu, 0x8fcf8b69u, 0x8a809decu, 0x8b42f7dbu, 0x89044982u, 0x88c623b5u,
        0x839a6488u, 0x82580ebfu, 0x801eb0e6u, 0x81dcdad1u, 0x8493cc54u, 0x8551a663u,
        0x8717183au, 0x86d5720du, 0xa9e2d0a0u, 0xa820ba97u, 0xaa6604ceu, 0xaba46ef9u,
        0xaeeb787cu, 0xaf29124bu, 0xad6fac12u, 0xacadc625u, 0xa7f18118u, 0xa633eb2fu,
        0xa4755576u, 0xa5b73f41u, 0xa0f829c4u, 0xa13a43f3u, 0xa37cfdaau, 0xa2be979du,
        0xb5c473d0u, 0xb40619e7u, 0xb640a7beu, 0xb782cd89u, 0xb2cddb0cu, 0xb30fb13bu,
        0xb1490f62u, 0xb08b6555u, 0xbbd72268u, 0xba15485fu, 0xb853f606u, 0xb9919c31u,
        0xbcde8ab4u, 0xbd1ce083u, 0xbf5a5edau, 0xbe9834edu,
    },
    { /* table 3 */
        0x00000000u, 0xb8bc6765u, 0xaa09c88bu, 0x12b5afeeu, 0x8f629757u, 0x37def032u,
        0x256b5fdcu, 0x9dd738b9u, 0xc5b428efu, 0x7d084f8au, 0x6fbde064u, 0xd7018701u,
        0x4ad6bfb8u, 0xf26ad8ddu, 0xe0df7733u, 0x58631056u, 0x5019579fu, 0xe8a530fau,
        0xfa109f14u, 0x42acf871u, 0xdf7bc0c8u, 0x67c7a7adu, 0x75720843u, 0xcdce6f26u,
        0x95ad7f70u, 0x2d111815u, 0x3fa4b7fbu, 0x8718d09eu, 0x1acfe827u, 0xa2738f42u,
        0xb0c620acu, 0x087a47c9u, 0xa032af3eu, 0x188ec85bu, 0x0a3b67b5u, 0xb28700d0u,
        0x2f503869u, 0x97ec5f0cu, 0x8559f0e2u, 0x3de59787u, 0x658687d1u, 0xdd3ae0b4u,
        0xcf8f4f5au, 0x7733283fu, 0xeae41086u, 0x525877e3u, 0x40edd80du, 0xf851bf68u,
        0xf02bf8a1u, 0x48979fc4u, 0x5a22302au, 0xe29e574fu, 0x7f496ff6u, 0xc7f50893u,
        0xd540a77du, 0x6dfcc018u, 0x359fd04eu, 0x8d23b72bu, 0x9f9618c5u, 0x272a7fa0u,
        0xbafd4719u, 0x0241207cu, 0x10f48f92u, 0xa848e8f7u, 0x9b14583du, 0x23a83f58u,
        0x311d90b6u, 0x89a1f7d3u, 0x1476cf6au, 0xaccaa80fu, 0xbe7f07e1u, 0x06c36084u,
        0x5ea070d2u, 0xe61c17b7u, 0xf4a9b859u, 0x4c15df3cu, 0xd1c2e785u, 0x697e80e0u,
        0x7bcb2f0eu, 0xc377486bu, 0xcb0d0fa2u, 0x73b168c7u, 0x6104c729u, 0xd9b8a04cu,
        0x446f98f5u, 0xfcd3ff90u, 0xee66507eu, 0x56da371bu, 0x0eb9274du, 0xb6054028u,
        0xa4b0efc6u, 0x1c0c88a3u, 0x81dbb01au, 0x3967d77fu, 0x2bd27891u, 0x936e1ff4u,
        0x3b26f703u, 0x839a9066u, 0x912f3f88u, 0x299358edu, 0xb4446054u, 0x0cf80731u,
        0x1e4da8dfu, 0xa6f1cfbau, 0xfe92dfecu, 0x462eb889u, 0x549b1767u, 0xec277002u,
        0x71f048bbu, 0xc94c2fdeu, 0xdbf98030u, 0x6345e755u, 0x6b3fa09cu, 0xd383c7f9u,
        0xc1366817u, 0x798a0f72u, 0xe45d37cbu, 0x5ce150aeu, 0x4e54ff40u, 0xf6e89825u,
        0xae8b8873u, 0x1637ef16u, 0x048240f8u, 0xbc3e279du, 0x21e91f24u, 0x99557841u,
        0x8be0d7afu, 0x335cb0cau, 0xed59b63bu, 0x55e5d15eu, 0x47507eb0u, 0xffec19d5u,
        0x623b216cu, 0xda874609u, 0xc832e9e7u, 0x708e8e82u, 0x28ed9ed4u, 0x9051f9b1u,
        0x82e4565fu, 0x3a58313au, 0xa78f0983u, 0x1f336ee6u, 0x0d86c108u, 0xb53aa66du,
        0xbd40e1a4u, 0x05fc86c1u, 0x1749292fu, 0xaff54e4au, 0x322276f3u, 0x8a9e1196u,
        0x982bbe78u, 0x2097d91du, 0x78f4c94bu, 0xc048ae2eu, 0xd2fd01c0u, 0x6a4166a5u,
        0xf7965e1cu, 0x4f2a3979u, 0x5d9f9697u, 0xe523f1f2u, 0x4d6b1905u, 0xf5d77e60u,
        0xe762d18eu, 0x5fdeb6ebu, 0xc2098e52u, 0x7ab5e937u, 0x680046d9u, 0xd0bc21bcu,
        0x88df31eau, 0x3063568fu, 0x22d6f961u, 0x9a6a9e04u, 0x07bda6bdu, 0xbf01c1d8u,
        0xadb46e36u, 0x15080953u, 0x1d724e9au, 0xa5ce29ffu, 0xb77b8611u, 0x0fc7e174u,
        0x9210d9cdu, 0x2aacbea8u, 0x38191146u, 0x80a57623u, 0xd8c66675u, 0x607a0110u,
        0x72cfaefeu, 0xca73c99bu, 0x57a4f122u, 0xef189647u, 0xfdad39a9u, 0x45115eccu,
        0x764dee06u, 0xcef18963u, 0xdc44268du, 0x64f841e8u, 0xf92f7951u, 0x41931e34u,
        0x5326b1dau, 0xeb9ad6bfu, 0xb3f9c6e9u, 0x0b45a18cu, 0x19f00e62u, 0xa14c6907u,
        0x3c9b51beu, 0x842736dbu, 0x96929935u, 0x2e2efe50u, 0x2654b999u, 0x9ee8defcu,
        0x8c5d7112u, 0x34e11677u, 0xa9362eceu, 0x118a49abu, 0x033fe645u, 0xbb838120u,
        0xe3e09176u, 0x5b5cf613u, 0x49e959fdu, 0xf1553e98u, 0x6c820621u, 0xd43e6144u,
        0xc68bceaau, 0x7e37a9cfu, 0xd67f4138u, 0x6ec3265du, 0x7c7689b3u, 0xc4caeed6u,
        0x591dd66fu, 0xe1a1b10au, 0xf3141ee4u, 0x4ba87981u, 0x13cb69d7u, 0xab770eb2u,
        0xb9c2a15cu, 0x017ec639u, 0x9ca9fe80u, 0x241599e5u, 0x36a0360bu, 0x8e1c516eu,
        0x866616a7u, 0x3eda71c2u, 0x2c6fde2cu, 0x94d3b949u, 0x090481f0u, 0xb1b8e695u,
        0xa30d497bu, 0x1bb12e1eu, 0x43d23e48u, 0xfb6e592du, 0xe9dbf6c3u, 0x516791a6u,
        0xccb0a91fu, 0x740cce7au, 0x66b96194u, 0xde0506f1u,
    },
    { /* table 4 */
        0x00000000u, 0x3d6029b0u, 0x7ac05360u, 0x47a07ad0u, 0xf580a6c0u, 0xc8e08f70u,
        0x8f40f5a0u, 0xb220dc10u, 0x30704bc1u, 0x0d106271u, 0x4ab018a1u, 0x77d03111u,
        0xc5f0ed01u, 0xf890c4b1u, 0xbf30be61u, 0x825097d1u, 0x60e09782u, 0x5d80be32u,
        0x1a20c4e2u, 0x2740ed52u, 0x95603142u, 0xa80018f2u, 0xefa06222u, 0xd2c04b92u,
        0x5090dc43u, 0x6df0f5f3u, 0x2a508f23u, 0x1730a693u, 0xa5107a83u, 0x98705333u,
        0xdfd029e3u, 0xe2b00053u, 0xc1c12f04u, 0xfca106b4u, 0xbb017c64u, 0x866155d4u,
        0x344189c4u, 0x0921a074u, 0x4e81daa4u, 0x73e1f314u, 0xf1b164c5u, 0xccd14d75u,
        0x8b7137a5u, 0xb6111e15u, 0x0431c205u, 0x3951ebb5u, 0x7ef19165u, 0x4391b8d5u,
        0xa121b886u, 0x9c419136u, 0xdbe1ebe6u, 0xe681c256u, 0x54a11e46u, 0x69c137f6u,
        0x2e614d26u, 0x13016496u, 0x9151f347u, 0xac31daf7u, 0xeb91a027u, 0xd6f18997u,
        0x64d15587u, 0x59b17c37u, 0x1e1106e7u, 0x23712f57u, 0x58f35849u, 0x659371f9u,
        0x22330b29u, 0x1f532299u, 0xad73fe89u, 0x9013d739u, 0xd7b3ade9u, 0xead38459u,
        0x68831388u, 0x55e33a38u, 0x124340e8u, 0x2f236958u, 0x9d03b548u, 0xa0639cf8u,
        0xe7c3e628u, 0xdaa3cf98u, 0x3813cfcbu, 0x0573e67bu, 0x42d39cabu, 0x7fb3b51bu,
        0xcd93690bu, 0xf0f340bbu, 0xb7533a6bu, 0x8a3313dbu, 0x0863840au, 0x3503adbau,
        0x72a3d76au, 0x4fc3fedau, 0xfde322cau, 0xc0830b7au, 0x872371aau, 0xba43581au,
        0x9932774du, 0xa4525efdu, 0xe3f2242du, 0xde920d9du, 0x6cb2d18du, 0x51d2f83du,
        0x167282edu, 0x2b12ab5du, 0xa9423c8cu, 0x9422153cu, 0xd3826fecu, 0xeee2465cu,
        0x5cc29a4cu, 0x61a2b3fcu, 0x2602c92cu, 0x1b62e09cu, 0xf9d2e0cfu, 0xc4b2c97fu,
        0x8312b3afu, 0xbe729a1fu, 0x0c52460fu, 0x31326fbfu, 0x7692156fu, 0x4bf23cdfu,
        0xc9a2ab0eu, 0xf4c282beu, 0xb362f86eu, 0x8e02d1deu, 0x3c220dceu, 0x0142247eu,
        0x46e25eaeu, 0x7b82771eu, 0xb1e6b092u, 0x8c869922u, 0xcb26e3f2u, 0xf646ca42u,
        0x44661652u, 0x79063fe2u, 0x3ea64532u, 0x03c66c82u, 0x8196fb53u, 0xbcf6d2e3u,
        0xfb56a833u, 0xc6368183u, 0x74165d93u, 0x49767423u, 0x0ed60ef3u, 0x33b62743u,
        0xd1062710u, 0xec660ea0u, 0xabc67470u, 0x96a65dc0u, 0x248681d0u, 0x19e6a860u,
        0x5e46d2b0u, 0x6326fb00u, 0xe1766cd1u, 0xdc164561u, 0x9bb63fb1u, 0xa6d61601u,
        0x14f6ca11u, 0x2996e3a1u, 0x6e369971u, 0x5356b0c1u, 0x70279f96u, 0x4d47b626u,
        0x0ae7ccf6u, 0x3787e546u, 0x85a73956u, 0xb8c710e6u, 0xff676a36u, 0xc2074386u,
        0x4057d457u, 0x7d37fde7u, 0x3a978737u, 0x07f7ae87u, 0xb5d77297u, 0x88b75b27u,
        0xcf1721f7u, 0xf2770847u, 0x10c70814u, 0x2da721a4u, 0x6a075b74u, 0x576772c4u,
        0xe547aed4u, 0xd8278764u, 0x9f87fdb4u, 0xa2e7d404u, 0x20b743d5u, 0x1dd76a65u,
        0x5a7710b5u, 0x67173905u, 0xd537e515u, 0xe857cca5u, 0xaff7b675u, 0x92979fc5u,
        0xe915e8dbu, 0xd475c16bu, 0x93d5bbbbu, 0xaeb5920bu, 0x1c954e1bu, 0x21f567abu,
        0x66551d7bu, 0x5b3534cbu, 0xd965a31au, 0xe4058aaau, 0xa3a5f07au, 0x9ec5d9cau,
        0x2ce505dau, 0x11852c6au, 0x562556bau, 0x6b457f0au, 0x89f57f59u, 0xb49556e9u,
        0xf3352c39u, 0xce550589u, 0x7c75d999u, 0x4115f029u, 0x06b58af9u, 0x3bd5a349u,
        0xb9853498u, 0x84e51d28u, 0xc34567f8u, 0xfe254e48u, 0x4c059258u, 0x7165bbe8u,
        0x36c5c138u, 0x0ba5e888u, 0x28d4c7dfu, 0x15b4ee6fu, 0x521494bfu, 0x6f74bd0fu,
        0xdd54611fu, 0xe03448afu, 0xa794327fu, 0x9af41bcfu, 0x18a48c1eu, 0x25c4a5aeu,
        0x6264df7eu, 0x5f04f6ceu, 0xed242adeu, 0xd044036eu, 0x97e479beu, 0xaa84500eu,
        0x4834505du, 0x755479edu, 0x32f4033du, 0x0f942a8du, 0xbdb4f69du, 0x80d4df2du,
        0xc774a5fdu, 0xfa148c4du, 0x78441b9cu, 0x4524322cu, 0x028448fcu, 0x3fe4614cu,
        0x8dc4bd5cu, 0xb0a494ecu, 0xf704ee3cu, 0xca64c78cu,
    },
    { /* table 5 */
        0x00000000u, 0xcb5cd3a5u, 0x4dc8a10bu, 0x869472aeu, 0x9b914216u, 0x50cd91b3u,
        0xd659e31du, 0x1d0530b8u, 0xec53826du, 0x270f51c8u, 0xa19b2366u, 0x6ac7f0c3u,
        0x77c2c07bu, 0xbc9e13deu, 0x3a0a6170u, 0xf156b2d5u, 0x03d6029bu, 0xc88ad13eu,
        0x4e1ea390u, 0x85427035u, 0x9847408du, 0x531b9328u, 0xd58fe186u, 0x1ed33223u,
        0xef8580f6u, 0x24d95353u, 0xa24d21fdu, 0x6911f258u, 0x7414c2e0u, 0xbf481145u,
        0x39dc63ebu, 0xf280b04eu, 0x07ac0536u, 0xccf0d693u, 0x4a64a43du, 0x81387798u,
        0x9c3d4720u, 0x57619485u, 0xd1f5e62bu, 0x1aa9358eu, 0xebff875bu, 0x20a354feu,
        0xa6372650u, 0x6d6bf5f5u, 0x706ec54du, 0xbb3216e8u, 0x3da66446u, 0xf6fab7e3u,
        0x047a07adu, 0xcf26d408u, 0x49b2a6a6u, 0x82ee7503u, 0x9feb45bbu, 0x54b7961eu,
        0xd223e4b0u, 0x197f3715u, 0xe82985c0u, 0x23755665u, 0xa5e124cbu, 0x6ebdf76eu,
        0x73b8c7d6u, 0xb8e41473u, 0x3e7066ddu, 0xf52cb578u, 0x0f580a6cu, 0xc404d9c9u,
        0x4290ab67u, 0x89cc78c2u, 0x94c9487au, 0x5f959bdfu, 0xd901e971u, 0x125d3ad4u,
        0xe30b8801u, 0x28575ba4u, 0xaec3290au, 0x659ffaafu, 0x789aca17u, 0xb3c619b2u,
        0x35526b1cu, 0xfe0eb8b9u, 0x0c8e08f7u, 0xc7d2db52u, 0x4146a9fcu, 0x8a1a7a59u,
        0x971f4ae1u, 0x5c439944u, 0xdad7ebeau, 0x118b384fu, 0xe0dd8a9au, 0x2b81593fu,
        0xad152b91u, 0x6649f834u, 0x7b4cc88cu, 0xb0101b29u, 0x36846987u, 0xfdd8ba22u,
        0x08f40f5au, 0xc3a8dcffu, 0x453cae51u, 0x8e607df4u, 0x93654d4cu, 0x58399ee9u,
        0xdeadec47u, 0x15f13fe2u, 0xe4a78d37u, 0x2ffb5e92u, 0xa96f2c3cu, 0x6233ff99u,
        0x7f36cf21u, 0xb46a1c84u, 0x32fe6e2au, 0xf9a2bd8fu, 0x0b220dc1u, 0xc07ede64u,
        0x46eaaccau, 0x8db67f6fu, 0x90b34fd7u, 0x5bef9c72u, 0xdd7beedcu, 0x16273d79u,
        0xe7718facu, 0x2c2d5c09u, 0xaab92ea7u, 0x61e5fd02u, 0x7ce0cdbau, 0xb7bc1e1fu,
        0x31286cb1u, 0xfa74bf14u, 0x1eb014d8u, 0xd5ecc77du, 0x5378b5d3u, 0x98246676u,
        0x852156ceu, 0x4e7d856bu, 0xc8e9f7c5u, 0x03b52460u, 0xf2e396b5u, 0x39bf4510u,
        0xbf2b37beu, 0x7477e41bu, 0x6972d4a3u, 0xa22e0706u, 0x24ba75a8u, 0xefe6a60du,
        0x1d661643u, 0xd63ac5e6u, 0x50aeb748u, 0x9bf264edu, 0x86f75455u, 0x4dab87f0u,
        0xcb3ff55eu, 0x006326fbu, 0xf135942eu, 0x3a69478bu, 0xbcfd3525u, 0x77a1e680u,
        0x6aa4d638u, 0xa1f8059du, 0x276c7733u, 0xec30a496u, 0x191c11eeu, 0xd240c24bu,
        0x54d4b0e5u, 0x9f886340u, 0x828d53f8u, 0x49d1805du, 0xcf45f2f3u, 0x04192156u,
        0xf54f9383u, 0x3e134026u, 0xb8873288u, 0x73dbe12du, 0x6eded195u, 0xa5820230u,
        0x2316709eu, 0xe84aa33bu, 0x1aca1375u, 0xd196c0d0u, 0x5702b27eu, 0x9c5e61dbu,
        0x815b5163u, 0x4a0782c6u, 0xcc93f068u, 0x07cf23cdu, 0xf6999118u, 0x3dc542bdu,
        0xbb513013u, 0x700de3b6u, 0x6d08d30eu, 0xa65400abu, 0x20c07205u, 0xeb9ca1a0u,
        0x11e81eb4u, 0xdab4cd11u, 0x5c20bfbfu, 0x977c6c1au, 0x8a795ca2u, 0x41258f07u,
        0xc7b1fda9u, 0x0ced2e0cu, 0xfdbb9cd9u, 0x36e74f7cu, 0xb0733dd2u, 0x7b2fee77u,
        0x662adecfu, 0xad760d6au, 0x2be27fc4u, 0xe0beac61u, 0x123e1c2fu, 0xd962cf8au,
        0x5ff6bd24u, 0x94aa6e81u, 0x89af5e39u, 0x42f38d9cu, 0xc467ff32u, 0x0f3b2c97u,
        0xfe6d9e42u, 0x35314de7u, 0xb3a53f49u, 0x78f9ececu, 0x65fcdc54u, 0xaea00ff1u,
        0x28347d5fu, 0xe368aefau, 0x16441b82u, 0xdd18c827u, 0x5b8cba89u, 0x90d0692cu,
        0x8dd55994u, 0x46898a31u, 0xc01df89fu, 0x0b412b3au, 0xfa1799efu, 0x314b4a4au,
        0xb7df38e4u, 0x7c83eb41u, 0x6186dbf9u, 0xaada085cu, 0x2c4e7af2u, 0xe712a957u,
        0x15921919u, 0xdececabcu, 0x585ab812u, 0x93066bb7u, 0x8e035b0fu, 0x455f88aau,
        0xc3cbfa04u, 0x089729a1u, 0xf9c19b74u, 0x329d48d1u, 0xb4093a7fu, 0x7f55e9dau,
        0x6250d962u, 0xa90c0ac7u, 0x2f987869u, 0xe4c4abccu,
    },
    { /* table 6 */
        0x00000000u, 0xa6770bb4u, 0x979f1129u, 0x31e81a9du, 0xf44f2413u, 0x52382fa7u,
        0x63d0353au, 0xc5a73e8eu, 0x33ef4e67u, 0x959845d3u, 0xa4705f4eu, 0x020754fau,
        0xc7a06a74u, 0x61d761c0u, 0x503f7b5du, 0xf64870e9u, 0x67de9cceu, 0xc1a9977au,
        0xf0418de7u, 0x56368653u, 0x9391b8ddu, 0x35e6b369u, 0x040ea9f4u, 0xa279a240u,
        0x5431d2a9u, 0xf246d91du, 0xc3aec380u, 0x65d9c834u, 0xa07ef6bau, 0x0609fd0eu,
        0x37e1e793u, 0x9196ec27u, 0xcfbd399cu, 0x69ca3228u, 0x582228b5u, 0xfe552301u,
        0x3bf21d8fu, 0x9d85163bu, 0xac6d0ca6u, 0x0a1a0712u, 0xfc5277fbu, 0x5a257c4fu,
        0x6bcd66d2u, 0xcdba6d66u, 0x081d53e8u, 0xae6a585cu, 0x9f8242c1u, 0x39f54975u,
        0xa863a552u, 0x0e14aee6u, 0x3ffcb47bu, 0x998bbfcfu, 0x5c2c8141u, 0xfa5b8af5u,
        0xcbb39068u, 0x6dc49bdcu, 0x9b8ceb35u, 0x3dfbe081u, 0x0c13fa1cu, 0xaa64f1a8u,
        0x6fc3cf26u, 0xc9b4c492u, 0xf85cde0fu, 0x5e2bd5bbu, 0x440b7579u, 0xe27c7ecdu,
        0xd3946450u, 0x75e36fe4u, 0xb044516au, 0x16335adeu, 0x27db4043u, 0x81ac4bf7u,
        0x77e43b1eu, 0xd19330aau, 0xe07b2a37u, 0x460c2183u, 0x83ab1f0du, 0x25dc14b9u,
        0x14340e24u, 0xb2430590u, 0x23d5e9b7u, 0x85a2e203u, 0xb44af89eu, 0x123df32au,
        0xd79acda4u, 0x71edc610u, 0x4005dc8du, 0xe672d739u, 0x103aa7d0u, 0xb64dac64u,
        0x87a5b6f9u, 0x21d2bd4du, 0xe47583c3u, 0x42028877u, 0x73ea92eau, 0xd59d995eu,
        0x8bb64ce5u, 0x2dc14751u, 0x1c295dccu, 0xba5e5678u, 0x7ff968f6u, 0xd98e6342u,
        0xe86679dfu, 0x4e11726bu, 0xb8590282u, 0x1e2e0936u, 0x2fc613abu, 0x89b1181fu,
        0x4c162691u, 0xea612d25u, 0xdb8937b8u, 0x7dfe3c0cu, 0xec68d02bu, 0x4a1fdb9fu,
        0x7bf7c102u, 0xdd80cab6u, 0x1827f438u, 0xbe50ff8cu, 0x8fb8e511u, 0x29cfeea5u,
        0xdf879e4cu, 0x79f095f8u, 0x48188f65u, 0xee6f84d1u, 0x2bc8ba5fu, 0x8dbfb1ebu,
        0xbc57ab76u, 0x1a20a0c2u, 0x8816eaf2u, 0x2e61e146u, 0x1f89fbdbu, 0xb9fef06fu,
        0x7c59cee1u, 0xda2ec555u, 0xebc6dfc8u, 0x4db1d47cu, 0xbbf9a495u, 0x1d8eaf21u,
        0x2c66b5bcu, 0x8a11be08u, 0x4fb68086u, 0xe9c18b32u, 0xd82991afu, 0x7e5e9a1bu,
        0xefc8763cu, 0x49bf7d88u, 0x78576715u, 0xde206ca1u, 0x1b87522fu, 0xbdf0599bu,
        0x8c184306u, 0x2a6f48b2u, 0xdc27385bu, 0x7a5033efu, 0x4bb82972u, 0xedcf22c6u,
        0x28681c48u, 0x8e1f17fcu, 0xbff70d61u, 0x198006d5u, 0x47abd36eu, 0xe1dcd8dau,
        0xd034c247u, 0x7643c9f3u, 0xb3e4f77du, 0x1593fcc9u, 0x247be654u, 0x820cede0u,
        0x74449d09u, 0xd23396bdu, 0xe3db8c20u, 0x45ac8794u, 0x800bb91au, 0x267cb2aeu,
        0x1794a833u, 0xb1e3a387u, 0x20754fa0u, 0x86024414u, 0xb7ea5e89u, 0x119d553du,
        0xd43a6bb3u, 0x724d6007u, 0x43a57a9au, 0xe5d2712eu, 0x139a01c7u, 0xb5ed0a73u,
        0x840510eeu, 0x22721b5au, 0xe7d525d4u, 0x41a22e60u, 0x704a34fdu, 0xd63d3f49u,
        0xcc1d9f8bu, 0x6a6a943fu, 0x5b828ea2u, 0xfdf58516u, 0x3852bb98u, 0x9e25b02cu,
        0xafcdaab1u, 0x09baa105u, 0xfff2d1ecu, 0x5985da58u, 0x686dc0c5u, 0xce1acb71u,
        0x0bbdf5ffu, 0xadcafe4bu, 0x9c22e4d6u, 0x3a55ef62u, 0xabc30345u, 0x0db408f1u,
        0x3c5c126cu, 0x9a2b19d8u, 0x5f8c2756u, 0xf9fb2ce2u, 0xc813367fu, 0x6e643dcbu,
        0x982c4d22u, 0x3e5b4696u, 0x0fb35c0bu, 0xa9c457bfu, 0x6c636931u, 0xca146285u,
        0xfbfc7818u, 0x5d8b73acu, 0x03a0a617u, 0xa5d7ada3u, 0x943fb73eu, 0x3248bc8au,
        0xf7ef8204u, 0x519889b0u, 0x6070932du, 0xc6079899u, 0x304fe870u, 0x9638e3c4u,
        0xa7d0f959u, 0x01a7f2edu, 0xc400cc63u, 0x6277c7d7u, 0x539fdd4au, 0xf5e8d6feu,
        0x647e3ad9u, 0xc209316du, 0xf3e12bf0u, 0x55962044u, 0x90311ecau, 0x3646157eu,
        0x07ae0fe3u, 0xa1d90457u, 0x579174beu, 0xf1e67f0au, 0xc00e6597u, 0x66796e23u,
        0xa3de50adu, 0x05a95b19u, 0x34414184u, 0x92364a30u,
    },
    { /* table 7 */
        0x00000000u, 0xccaa009eu, 0x4225077du, 0x8e8f07e3u, 0x844a0efau, 0x48e00e64u,
        0xc66f0987u, 0x0ac50919u, 0xd3e51bb5u, 0x1f4f1b2bu, 0x91c01cc8u, 0x5d6a1c56u,
        0x57af154fu, 0x9b0515d1u, 0x158a1232u, 0xd92012acu, 0x7cbb312bu, 0xb01131b5u,
        0x3e9e3656u, 0xf23436c8u, 0xf8f13fd1u, 0x345b3f4fu, 0xbad438acu, 0x767e3832u,
        0xaf5e2a9eu, 0x63f42a00u, 0xed7b2de3u, 0x21d12d7du, 0x2b142464u, 0xe7be24fau,
        0x69312319u, 0xa59b2387u, 0xf9766256u, 0x35dc62c8u, 0xbb53652bu, 0x77f965b5u,
        0x7d3c6cacu, 0xb1966c32u, 0x3f196bd1u, 0xf3b36b4fu, 0x2a9379e3u, 0xe639797du,
        0x68b67e9eu, 0xa41c7e00u, 0xaed97719u, 0x62737787u, 0xecfc7064u, 0x205670fau,
        0x85cd537du, 0x496753e3u, 0xc7e85400u, 0x0b42549eu, 0x01875d87u, 0xcd2d5d19u,
        0x43a25afau, 0x8f085a64u, 0x562848c8u, 0x9a824856u, 0x140d4fb5u, 0xd8a74f2bu,
        0xd2624632u, 0x1ec846acu, 0x9047414fu, 0x5ced41d1u, 0x299dc2edu, 0xe537c273u,
        0x6bb8c590u, 0xa712c50eu, 0xadd7cc17u, 0x617dcc89u, 0xeff2cb6au, 0x2358cbf4u,
        0xfa78d958u, 0x36d2d9c6u, 0xb85dde25u, 0x74f7debbu, 0x7e32d7a2u, 0xb298d73cu,
        0x3c17d0dfu, 0xf0bdd041u, 0x5526f3c6u, 0x998cf358u, 0x1703f4bbu, 0xdba9f425u,
        0xd16cfd3cu, 0x1dc6fda2u, 0x9349fa41u, 0x5fe3fadfu, 0x86c3e873u, 0x4a69e8edu,
        0xc4e6ef0eu, 0x084cef90u, 0x0289e689u, 0xce23e617u, 0x40ace1f4u, 0x8c06e16au,
        0xd0eba0bbu, 0x1c41a025u, 0x92cea7c6u, 0x5e64a758u, 0x54a1ae41u, 0x980baedfu,
        0x1684a93cu, 0xda2ea9a2u, 0x030ebb0eu, 0xcfa4bb90u, 0x412bbc73u, 0x8d81bcedu,
        0x8744b5f4u, 0x4beeb56au, 0xc561b289u, 0x09cbb217u, 0xac509190u, 0x60fa910eu,
        0xee7596edu, 0x22df9673u, 0x281a9f6au, 0xe4b09ff4u, 0x6a3f9817u, 0xa6959889u,
        0x7fb58a25u, 0xb31f8abbu, 0x3d908d58u, 0xf13a8dc6u, 0xfbff84dfu, 0x37558441u,
        0xb9da83a2u, 0x7570833cu, 0x533b85dau, 0x9f918544u, 0x111e82a7u, 0xddb48239u,
        0xd7718b20u, 0x1bdb8bbeu, 0x95548c5du, 0x59fe8cc3u, 0x80de9e6fu, 0x4c749ef1u,
        0xc2fb9912u, 0x0e51998cu, 0x04949095u, 0xc83e900bu, 0x46b197e8u, 0x8a1b9776u,
        0x2f80b4f1u, 0xe32ab46fu, 0x6da5b38cu, 0xa10fb312u, 0xabcaba0bu, 0x6760ba95u,
        0xe9efbd76u, 0x2545bde8u, 0xfc65af44u, 0x30cfafdau, 0xbe40a839u, 0x72eaa8a7u,
        0x782fa1beu, 0xb485a120u, 0x3a0aa6c3u, 0xf6a0a65du, 0xaa4de78cu, 0x66e7e712u,
        0xe868e0f1u, 0x24c2e06fu, 0x2e07e976u, 0xe2ade9e8u, 0x6c22ee0bu, 0xa088ee95u,
        0x79a8fc39u, 0xb502fca7u, 0x3b8dfb44u, 0xf727fbdau, 0xfde2f2c3u, 0x3148f25du,
        0xbfc7f5beu, 0x736df520u, 0xd6f6d6a7u, 0x1a5cd639u, 0x94d3d1dau, 0x5879d144u,
        0x52bcd85du, 0x9e16d8c3u, 0x1099df20u, 0xdc33dfbeu, 0x0513cd12u, 0xc9b9cd8cu,
        0x4736ca6fu, 0x8b9ccaf1u, 0x8159c3e8u, 0x4df3c376u, 0xc37cc495u, 0x0fd6c40bu,
        0x7aa64737u, 0xb60c47a9u, 0x3883404au, 0xf42940d4u, 0xfeec49cdu, 0x32464953u,
        0xbcc94eb0u, 0x70634e2eu, 0xa9435c82u, 0x65e95c1cu, 0xeb665bffu, 0x27cc5b61u,
        0x2d095278u, 0xe1a352e6u, 0x6f2c5505u, 0xa386559bu, 0x061d761cu, 0xcab77682u,
        0x44387161u, 0x889271ffu, 0x825778e6u, 0x4efd7878u, 0xc0727f9bu, 0x0cd87f05u,
        0xd5f86da9u, 0x19526d37u, 0x97dd6ad4u, 0x5b776a4au, 0x51b26353u, 0x9d1863cdu,
        0x1397642eu, 0xdf3d64b0u, 0x83d02561u, 0x4f7a25ffu, 0xc1f5221cu, 0x0d5f2282u,
        0x079a2b9bu, 0xcb302b05u, 0x45bf2ce6u, 0x89152c78u, 0x50353ed4u, 0x9c9f3e4au,
        0x121039a9u, 0xdeba3937u, 0xd47f302eu, 0x18d530b0u, 0x965a3753u, 0x5af037cdu,
        0xff6b144au, 0x33c114d4u, 0xbd4e1337u, 0x71e413a9u, 0x7b211ab0u, 0xb78b1a2eu,
        0x39041dcdu, 0xf5ae1d53u, 0x2c8e0fffu, 0xe0240f61u, 0x6eab0882u, 0xa201081cu,
        0xa8c40105u, 0x646e019bu, 0xeae10678u, 0x264b06e6u,
    },
    { /* table 8 */
        0x00000000u, 0x177b1443u, 0x2ef62886u, 0x398d3cc5u, 0x5dec510cu, 0x4a97454fu,
        0x731a798au, 0x64616dc9u, 0xbbd8a218u, 0xaca3b65bu, 0x952e8a9eu, 0x82559eddu,
        0xe634f314u, 0xf14fe757u, 0xc8c2db92u, 0xdfb9cfd1u, 0xacc04271u, 0xbbbb5632u,
        0x82366af7u, 0x954d7eb4u, 0xf12c137du, 0xe657073eu, 0xdfda3bfbu, 0xc8a12fb8u,
        0x1718e069u, 0x0063f42au, 0x39eec8efu, 0x2e95dcacu, 0x4af4b165u, 0x5d8fa526u,
        0x640299e3u, 0x73798da0u, 0x82f182a3u, 0x958a96e0u, 0xac07aa25u, 0xbb7cbe66u,
        0xdf1dd3afu, 0xc866c7ecu, 0xf1ebfb29u, 0xe690ef6au, 0x392920bbu, 0x2e5234f8u,
        0x17df083du, 0x00a41c7eu, 0x64c571b7u, 0x73be65f4u, 0x4a335931u, 0x5d484d72u,
        0x2e31c0d2u, 0x394ad491u, 0x00c7e854u, 0x17bcfc17u, 0x73dd91deu, 0x64a6859du,
        0x5d2bb958u, 0x4a50ad1bu, 0x95e962cau, 0x82927689u, 0xbb1f4a4cu, 0xac645e0fu,
        0xc80533c6u, 0xdf7e2785u, 0xe6f31b40u, 0xf1880f03u, 0xde920307u, 0xc9e91744u,
        0xf0642b81u, 0xe71f3fc2u, 0x837e520bu, 0x94054648u, 0xad887a8du, 0xbaf36eceu,
        0x654aa11fu, 0x7231b55cu, 0x4bbc8999u, 0x5cc79ddau, 0x38a6f013u, 0x2fdde450u,
        0x1650d895u, 0x012bccd6u, 0x72524176u, 0x65295535u, 0x5ca469f0u, 0x4bdf7db3u,
        0x2fbe107au, 0x38c50439u, 0x014838fcu, 0x16332cbfu, 0xc98ae36eu, 0xdef1f72du,
        0xe77ccbe8u, 0xf007dfabu, 0x9466b262u, 0x831da621u, 0xba909ae4u, 0xadeb8ea7u,
        0x5c6381a4u, 0x4b1895e7u, 0x7295a922u, 0x65eebd61u, 0x018fd0a8u, 0x16f4c4ebu,
        0x2f79f82eu, 0x3802ec6du, 0xe7bb23bcu, 0xf0c037ffu, 0xc94d0b3au, 0xde361f79u,
        0xba5772b0u, 0xad2c66f3u, 0x94a15a36u, 0x83da4e75u, 0xf0a3c3d5u, 0xe7d8d796u,
        0xde55eb53u, 0xc92eff10u, 0xad4f92d9u, 0xba34869au, 0x83b9ba5fu, 0x94c2ae1cu,
        0x4b7b61cdu, 0x5c00758eu, 0x658d494bu, 0x72f65d08u, 0x169730c1u, 0x01ec2482u,
        0x38611847u, 0x2f1a0c04u, 0x6655004fu, 0x712e140cu, 0x48a328c9u, 0x5fd83c8au,
        0x3bb95143u, 0x2cc24500u, 0x154f79c5u, 0x02346d86u, 0xdd8da257u, 0xcaf6b614u,
        0xf37b8ad1u, 0xe4009e92u, 0x8061f35bu, 0x971ae718u, 0xae97dbddu, 0xb9eccf9eu,
        0xca95423eu, 0xddee567du, 0xe4636ab8u, 0xf3187efbu, 0x97791332u, 0x80020771u,
        0xb98f3bb4u, 0xaef42ff7u, 0x714de026u, 0x6636f465u, 0x5fbbc8a0u, 0x48c0dce3u,
        0x2ca1b12au, 0x3bdaa569u, 0x025799acu, 0x152c8defu, 0xe4a482ecu, 0xf3df96afu,
        0xca52aa6au, 0xdd29be29u, 0xb948d3e0u, 0xae33c7a3u, 0x97befb66u, 0x80c5ef25u,
        0x5f7c20f4u, 0x480734b7u, 0x718a0872u, 0x66f11c31u, 0x029071f8u, 0x15eb65bbu,
        0x2c66597eu, 0x3b1d4d3du, 0x4864c09du, 0x5f1fd4deu, 0x6692e81bu, 0x71e9fc58u,
        0x15889191u, 0x02f385d2u, 0x3b7eb917u, 0x2c05ad54u, 0xf3bc6285u, 0xe4c776c6u,
        0xdd4a4a03u, 0xca315e40u, 0xae503389u, 0xb92b27cau, 0x80a61b0fu, 0x97dd0f4cu,
        0xb8c70348u, 0xafbc170bu, 0x96312bceu, 0x814a3f8du, 0xe52b5244u, 0xf2504607u,
        0xcbdd7ac2u, 0xdca66e81u, 0x031fa150u, 0x1464b513u, 0x2de989d6u, 0x3a929d95u,
        0x5ef3f05cu, 0x4988e41fu, 0x7005d8dau, 0x677ecc99u, 0x14074139u, 0x037c557au,
        0x3af169bfu, 0x2d8a7dfcu, 0x49eb1035u, 0x5e900476u, 0x671d38b3u, 0x70662cf0u,
        0xafdfe321u, 0xb8a4f762u, 0x8129cba7u, 0x9652dfe4u, 0xf233b22du, 0xe548a66eu,
        0xdcc59aabu, 0xcbbe8ee8u, 0x3a3681ebu, 0x2d4d95a8u, 0x14c0a96du, 0x03bbbd2eu,
        0x67dad0e7u, 0x70a1c4a4u, 0x492cf861u, 0x5e57ec22u, 0x81ee23f3u, 0x969537b0u,
        0xaf180b75u, 0xb8631f36u, 0xdc0272ffu, 0xcb7966bcu, 0xf2f45a79u, 0xe58f4e3au,
        0x96f6c39au, 0x818dd7d9u, 0xb800eb1cu, 0xaf7bff5fu, 0xcb1a9296u, 0xdc6186d5u,
        0xe5ecba10u, 0xf297ae53u, 0x2d2e6182u, 0x3a5575c1u, 0x03d84904u, 0x14a35d47u,
        0x70c2308eu, 0x67b924cdu, 0x5e341808u, 0x494f0c4bu,
    },
    { /* table 9 */
        0x00000000u, 0xefc26b3eu, 0x04f5d03du, 0xeb37bb03u, 0x09eba07au, 0xe629cb44u,
        0x0d1e7047u, 0xe2dc1b79u, 0x13d740f4u, 0xfc152bcau, 0x172290c9u, 0xf8e0fbf7u,
        0x1a3ce08eu, 0xf5fe8bb0u, 0x1ec930b3u, 0xf10b5b8du, 0x27ae81e8u, 0xc86cead6u,
        0x235b51d5u, 0xcc993aebu, 0x2e452192u, 0xc1874aacu, 0x2ab0f1afu, 0xc5729a91u,
        0x3479c11cu, 0xdbbbaa22u, 0x308c1121u, 0xdf4e7a1fu, 0x3d926166u, 0xd2500a58u,
        0x3967b15bu, 0xd6a5da65u, 0x4f5d03d0u, 0xa09f68eeu, 0x4ba8d3edu, 0xa46ab8d3u,
        0x46b6a3aau, 0xa974c894u, 0x42437397u, 0xad8118a9u, 0x5c8a4324u, 0xb348281au,
        0x587f9319u, 0xb7bdf827u, 0x5561e35eu, 0xbaa38860u, 0x51943363u, 0xbe56585du,
        0x68f38238u, 0x8731e906u, 0x6c065205u, 0x83c4393bu, 0x61182242u, 0x8eda497cu,
        0x65edf27fu, 0x8a2f9941u, 0x7b24c2ccu, 0x94e6a9f2u, 0x7fd112f1u, 0x901379cfu,
        0x72cf62b6u, 0x9d0d0988u, 0x763ab28bu, 0x99f8d9b5u, 0x9eba07a0u, 0x71786c9eu,
        0x9a4fd79du, 0x758dbca3u, 0x9751a7dau, 0x7893cce4u, 0x93a477e7u, 0x7c661cd9u,
        0x8d6d4754u, 0x62af2c6au, 0x89989769u, 0x665afc57u, 0x8486e72eu, 0x6b448c10u,
        0x80733713u, 0x6fb15c2du, 0xb9148648u, 0x56d6ed76u, 0xbde15675u, 0x52233d4bu,
        0xb0ff2632u, 0x5f3d4d0cu, 0xb40af60fu, 0x5bc89d31u, 0xaac3c6bcu, 0x4501ad82u,
        0xae361681u, 0x41f47dbfu, 0xa32866c6u, 0x4cea0df8u, 0xa7ddb6fbu, 0x481fddc5u,
        0xd1e70470u, 0x3e256f4eu, 0xd512d44du, 0x3ad0bf73u, 0xd80ca40au, 0x37cecf34u,
        0xdcf97437u, 0x333b1f09u, 0xc2304484u, 0x2df22fbau, 0xc6c594b9u, 0x2907ff87u,
        0xcbdbe4feu, 0x24198fc0u, 0xcf2e34c3u, 0x20ec5ffdu, 0xf6498598u, 0x198beea6u,
        0xf2bc55a5u, 0x1d7e3e9bu, 0xffa225e2u, 0x10604edcu, 0xfb57f5dfu, 0x14959ee1u,
        0xe59ec56cu, 0x0a5cae52u, 0xe16b1551u, 0x0ea97e6fu, 0xec756516u, 0x03b70e28u,
        0xe880b52bu, 0x0742de15u, 0xe6050901u, 0x09c7623fu, 0xe2f0d93cu, 0x0d32b202u,
        0xefeea97bu, 0x002cc245u, 0xeb1b7946u, 0x04d91278u, 0xf5d249f5u, 0x1a1022cbu,
        0xf12799c8u, 0x1ee5f2f6u, 0xfc39e98fu, 0x13fb82b1u, 0xf8cc39b2u, 0x170e528cu,
        0xc1ab88e9u, 0x2e69e3d7u, 0xc55e58d4u, 0x2a9c33eau, 0xc8402893u, 0x278243adu,
        0xccb5f8aeu, 0x23779390u, 0xd27cc81du, 0x3dbea323u, 0xd6891820u, 0x394b731eu,
        0xdb976867u, 0x34550359u, 0xdf62b85au, 0x30a0d364u, 0xa9580ad1u, 0x469a61efu,
        0xadaddaecu, 0x426fb1d2u, 0xa0b3aaabu, 0x4f71c195u, 0xa4467a96u, 0x4b8411a8u,
        0xba8f4a25u, 0x554d211bu, 0xbe7a9a18u, 0x51b8f126u, 0xb364ea5fu, 0x5ca68161u,
        0xb7913a62u, 0x5853515cu, 0x8ef68b39u, 0x6134e007u, 0x8a035b04u, 0x65c1303au,
        0x871d2b43u, 0x68df407du, 0x83e8fb7eu, 0x6c2a9040u, 0x9d21cbcdu, 0x72e3a0f3u,
        0x99d41bf0u, 0x761670ceu, 0x94ca6bb7u, 0x7b080089u, 0x903fbb8au, 0x7ffdd0b4u,
        0x78bf0ea1u, 0x977d659fu, 0x7c4ade9cu, 0x9388b5a2u, 0x7154aedbu, 0x9e96c5e5u,
        0x75a17ee6u, 0x9a6315d8u, 0x6b684e55u, 0x84aa256bu, 0x6f9d9e68u, 0x805ff556u,
        0x6283ee2fu, 0x8d418511u, 0x66763e12u, 0x89b4552cu, 0x5f118f49u, 0xb0d3e477u,
        0x5be45f74u, 0xb426344au, 0x56fa2f33u, 0xb938440du, 0x520fff0eu, 0xbdcd9430u,
        0x4cc6cfbdu, 0xa304a483u, 0x48331f80u, 0xa7f174beu, 0x452d6fc7u, 0xaaef04f9u,
        0x41d8bffau, 0xae1ad4c4u, 0x37e20d71u, 0xd820664fu, 0x3317dd4cu, 0xdcd5b672u,
        0x3e09ad0bu, 0xd1cbc635u, 0x3afc7d36u, 0xd53e1608u, 0x24354d85u, 0xcbf726bbu,
        0x20c09db8u, 0xcf02f686u, 0x2ddeedffu, 0xc21c86c1u, 0x292b3dc2u, 0xc6e956fcu,
        0x104c8c99u, 0xff8ee7a7u, 0x14b95ca4u, 0xfb7b379au, 0x19a72ce3u, 0xf66547ddu,
        0x1d52fcdeu, 0xf29097e0u, 0x039bcc6du, 0xec59a753u, 0x076e1c50u, 0xe8ac776eu,
        0x0a706c17u, 0xe5b20729u, 0x0e85bc2au, 0xe147d714u,
    },
    { /* table 10 */
        0x00000000u, 0xc18edfc0u, 0x586cb9c1u, 0x99e26601u, 0xb0d97382u, 0x7157ac42u,
        0xe8b5ca43u, 0x293b1583u, 0xbac3e145u, 0x7b4d3e85u, 0xe2af5884u, 0x23218744u,
        0x0a1a92c7u, 0xcb944d07u, 0x52762b06u, 0x93f8f4c6u, 0xaef6c4cbu, 0x6f781b0bu,
        0xf69a7d0au, 0x3714a2cau, 0x1e2fb749u, 0xdfa16889u, 0x46430e88u, 0x87cdd148u,
        0x1435258eu, 0xd5bbfa4eu, 0x4c599c4fu, 0x8dd7438fu, 0xa4ec560cu, 0x656289ccu,
        0xfc80efcdu, 0x3d0e300du, 0x869c8fd7u, 0x47125017u, 0xdef03616u, 0x1f7ee9d6u,
        0x3645fc55u, 0xf7cb2395u, 0x6e294594u, 0xafa79a54u, 0x3c5f6e92u, 0xfdd1b152u,
        0x6433d753u, 0xa5bd0893u, 0x8c861d10u, 0x4d08c2d0u, 0xd4eaa4d1u, 0x15647b11u,
        0x286a4b1cu, 0xe9e494dcu, 0x7006f2ddu, 0xb1882d1du, 0x98b3389eu, 0x593de75eu,
        0xc0df815fu, 0x01515e9fu, 0x92a9aa59u, 0x53277599u, 0xcac51398u, 0x0b4bcc58u,
        0x2270d9dbu, 0xe3fe061bu, 0x7a1c601au, 0xbb92bfdau, 0xd64819efu, 0x17c6c62fu,
        0x8e24a02eu, 0x4faa7feeu, 0x66916a6du, 0xa71fb5adu, 0x3efdd3acu, 0xff730c6cu,
        0x6c8bf8aau, 0xad05276au, 0x34e7416bu, 0xf5699eabu, 0xdc528b28u, 0x1ddc54e8u,
        0x843e32e9u, 0x45b0ed29u, 0x78bedd24u, 0xb93002e4u, 0x20d264e5u, 0xe15cbb25u,
        0xc867aea6u, 0x09e97166u, 0x900b1767u, 0x5185c8a7u, 0xc27d3c61u, 0x03f3e3a1u,
        0x9a1185a0u, 0x5b9f5a60u, 0x72a44fe3u, 0xb32a9023u, 0x2ac8f622u, 0xeb4629e2u,
        0x50d49638u, 0x915a49f8u, 0x08b82ff9u, 0xc936f039u, 0xe00de5bau, 0x21833a7au,
        0xb8615c7bu, 0x79ef83bbu, 0xea17777du, 0x2b99a8bdu, 0xb27bcebcu, 0x73f5117cu,
        0x5ace04ffu, 0x9b40db3fu, 0x02a2bd3eu, 0xc32c62feu, 0xfe2252f3u, 0x3fac8d33u,
        0xa64eeb32u, 0x67c034f2u, 0x4efb2171u, 0x8f75feb1u, 0x169798b0u, 0xd7194770u,
        0x44e1b3b6u, 0x856f6c76u, 0x1c8d0a77u, 0xdd03d5b7u, 0xf438c034u, 0x35b61ff4u,
        0xac5479f5u, 0x6ddaa635u, 0x77e1359fu, 0xb66fea5fu, 0x2f8d8c5eu, 0xee03539eu,
        0xc738461du, 0x06b699ddu, 0x9f54ffdcu, 0x5eda201cu, 0xcd22d4dau, 0x0cac0b1au,
        0x954e6d1bu, 0x54c0b2dbu, 0x7dfba758u, 0xbc757898u, 0x25971e99u, 0xe419c159u,
        0xd917f154u, 0x18992e94u, 0x817b4895u, 0x40f59755u, 0x69ce82d6u, 0xa8405d16u,
        0x31a23b17u, 0xf02ce4d7u, 0x63d41011u, 0xa25acfd1u, 0x3bb8a9d0u, 0xfa367610u,
        0xd30d6393u, 0x1283bc53u, 0x8b61da52u, 0x4aef0592u, 0xf17dba48u, 0x30f36588u,
        0xa9110389u, 0x689fdc49u, 0x41a4c9cau, 0x802a160au, 0x19c8700bu, 0xd846afcbu,
        0x4bbe5b0du, 0x8a3084cdu, 0x13d2e2ccu, 0xd25c3d0cu, 0xfb67288fu, 0x3ae9f74fu,
        0xa30b914eu, 0x62854e8eu, 0x5f8b7e83u, 0x9e05a143u, 0x07e7c742u, 0xc6691882u,
        0xef520d01u, 0x2edcd2c1u, 0xb73eb4c0u, 0x76b06b00u, 0xe5489fc6u, 0x24c64006u,
        0xbd242607u, 0x7caaf9c7u, 0x5591ec44u, 0x941f3384u, 0x0dfd5585u, 0xcc738a45u,
        0xa1a92c70u, 0x6027f3b0u, 0xf9c595b1u, 0x384b4a71u, 0x11705ff2u, 0xd0fe8032u,
        0x491ce633u, 0x889239f3u, 0x1b6acd35u, 0xdae412f5u, 0x430674f4u, 0x8288ab34u,
        0xabb3beb7u, 0x6a3d6177u, 0xf3df0776u, 0x3251d8b6u, 0x0f5fe8bbu, 0xced1377bu,
        0x5733517au, 0x96bd8ebau, 0xbf869b39u, 0x7e0844f9u, 0xe7ea22f8u, 0x2664fd38u,
        0xb59c09feu, 0x7412d63eu, 0xedf0b03fu, 0x2c7e6fffu, 0x05457a7cu, 0xc4cba5bcu,
        0x5d29c3bdu, 0x9ca71c7du, 0x2735a3a7u, 0xe6bb7c67u, 0x7f591a66u, 0xbed7c5a6u,
        0x97ecd025u, 0x56620fe5u, 0xcf8069e4u, 0x0e0eb624u, 0x9df642e2u, 0x5c789d22u,
        0xc59afb23u, 0x041424e3u, 0x2d2f3160u, 0xeca1eea0u, 0x754388a1u, 0xb4cd5761u,
        0x89c3676cu, 0x484db8acu, 0xd1afdeadu, 0x1021016du, 0x391a14eeu, 0xf894cb2eu,
        0x6176ad2fu, 0xa0f872efu, 0x33008629u, 0xf28e59e9u, 0x6b6c3fe8u, 0xaae2e028u,
        0x83d9f5abu, 0x42572a6bu, 0xdbb54c6au, 0x1a3b93aau,
    },
    { /* table 11 */
        0x00000000u, 0x9ba54c6fu, 0xec3b9e9fu, 0x779ed2f0u, 0x03063b7fu, 0x98a37710u,
        0xef3da5e0u, 0x7498e98fu, 0x060c76feu, 0x9da93a91u, 0xea37e861u, 0x7192a40eu,
        0x050a4d81u, 0x9eaf01eeu, 0xe931d31eu, 0x72949f71u, 0x0c18edfcu, 0x97bda193u,
        0xe0237363u, 0x7b863f0cu, 0x0f1ed683u, 0x94bb9aecu, 0xe325481cu, 0x78800473u,
        0x0a149b02u, 0x91b1d76du, 0xe62f059du, 0x7d8a49f2u, 0x0912a07du, 0x92b7ec12u,
        0xe5293ee2u, 0x7e8c728du, 0x1831dbf8u, 0x83949797u, 0xf40a4567u, 0x6faf0908u,
        0x1b37e087u, 0x8092ace8u, 0xf70c7e18u, 0x6ca93277u, 0x1e3dad06u, 0x8598e169u,
        0xf2063399u, 0x69a37ff6u, 0x1d3b9679u, 0x869eda16u, 0xf10008e6u, 0x6aa54489u,
        0x14293604u, 0x8f8c7a6bu, 0xf812a89bu, 0x63b7e4f4u, 0x172f0d7bu, 0x8c8a4114u,
        0xfb1493e4u, 0x60b1df8bu, 0x122540fau, 0x89800c95u, 0xfe1ede65u, 0x65bb920au,
        0x11237b85u, 0x8a8637eau, 0xfd18e51au, 0x66bda975u, 0x3063b7f0u, 0xabc6fb9fu,
        0xdc58296fu, 0x47fd6500u, 0x33658c8fu, 0xa8c0c0e0u, 0xdf5e1210u, 0x44fb5e7fu,
        0x366fc10eu, 0xadca8d61u, 0xda545f91u, 0x41f113feu, 0x3569fa71u, 0xaeccb61eu,
        0xd95264eeu, 0x42f72881u, 0x3c7b5a0cu, 0xa7de1663u, 0xd040c493u, 0x4be588fcu,
        0x3f7d6173u, 0xa4d82d1cu, 0xd346ffecu, 0x48e3b383u, 0x3a772cf2u, 0xa1d2609du,
        0xd64cb26du, 0x4de9fe02u, 0x3971178du, 0xa2d45be2u, 0xd54a8912u, 0x4eefc57du,
        0x28526c08u, 0xb3f72067u, 0xc469f297u, 0x5fccbef8u, 0x2b545777u, 0xb0f11b18u,
        0xc76fc9e8u, 0x5cca8587u, 0x2e5e1af6u, 0xb5fb5699u, 0xc2658469u, 0x59c0c806u,
        0x2d582189u, 0xb6fd6de6u, 0xc163bf16u, 0x5ac6f379u, 0x244a81f4u, 0xbfefcd9bu,
        0xc8711f6bu, 0x53d45304u, 0x274cba8bu, 0xbce9f6e4u, 0xcb772414u, 0x50d2687bu,
        0x2246f70au, 0xb9e3bb65u, 0xce7d6995u, 0x55d825fau, 0x2140cc75u, 0xbae5801au,
        0xcd7b52eau, 0x56de1e85u, 0x60c76fe0u, 0xfb62238fu, 0x8cfcf17fu, 0x1759bd10u,
        0x63c1549fu, 0xf86418f0u, 0x8ffaca00u, 0x145f866fu, 0x66cb191eu, 0xfd6e5571u,
        0x8af08781u, 0x1155cbeeu, 0x65cd2261u, 0xfe686e0eu, 0x89f6bcfeu, 0x1253f091u,
        0x6cdf821cu, 0xf77ace73u, 0x80e41c83u, 0x1b4150ecu, 0x6fd9b963u, 0xf47cf50cu,
        0x83e227fcu, 0x18476b93u, 0x6ad3f4e2u, 0xf176b88du, 0x86e86a7du, 0x1d4d2612u,
        0x69d5cf9du, 0xf27083f2u, 0x85ee5102u, 0x1e4b1d6du, 0x78f6b418u, 0xe353f877u,
        0x94cd2a87u, 0x0f6866e8u, 0x7bf08f67u, 0xe055c308u, 0x97cb11f8u, 0x0c6e5d97u,
        0x7efac2e6u, 0xe55f8e89u, 0x92c15c79u, 0x09641016u, 0x7dfcf999u, 0xe659b5f6u,
        0x91c76706u, 0x0a622b69u, 0x74ee59e4u, 0xef4b158bu, 0x98d5c77bu, 0x03708b14u,
        0x77e8629bu, 0xec4d2ef4u, 0x9bd3fc04u, 0x0076b06bu, 0x72e22f1au, 0xe9476375u,
        0x9ed9b185u, 0x057cfdeau, 0x71e41465u, 0xea41580au, 0x9ddf8afau, 0x067ac695u,
        0x50a4d810u, 0xcb01947fu, 0xbc9f468fu, 0x273a0ae0u, 0x53a2e36fu, 0xc807af00u,
        0xbf997df0u, 0x243c319fu, 0x56a8aeeeu, 0xcd0de281u, 0xba933071u, 0x21367c1eu,
        0x55ae9591u, 0xce0bd9feu, 0xb9950b0eu, 0x22304761u, 0x5cbc35ecu, 0xc7197983u,
        0xb087ab73u, 0x2b22e71cu, 0x5fba0e93u, 0xc41f42fcu, 0xb381900cu, 0x2824dc63u,
        0x5ab04312u, 0xc1150f7du, 0xb68bdd8du, 0x2d2e91e2u, 0x59b6786du, 0xc2133402u,
        0xb58de6f2u, 0x2e28aa9du, 0x489503e8u, 0xd3304f87u, 0xa4ae9d77u, 0x3f0bd118u,
        0x4b933897u, 0xd03674f8u, 0xa7a8a608u, 0x3c0dea67u, 0x4e997516u, 0xd53c3979u,
        0xa2a2eb89u, 0x3907a7e6u, 0x4d9f4e69u, 0xd63a0206u, 0xa1a4d0f6u, 0x3a019c99u,
        0x448dee14u, 0xdf28a27bu, 0xa8b6708bu, 0x33133ce4u, 0x478bd56bu, 0xdc2e9904u,
        0xabb04bf4u, 0x3015079bu, 0x428198eau, 0xd924d485u, 0xaeba0675u, 0x351f4a1au,
        0x4187a395u, 0xda22effau, 0xadbc3d0au, 0x36197165u,
    },
    { /* table 12 */
        0x00000000u, 0xdd96d985u, 0x605cb54bu, 0xbdca6cceu, 0xc0b96a96u, 0x1d2fb313u,
        0xa0e5dfddu, 0x7d730658u, 0x5a03d36du, 0x87950ae8u, 0x3a5f6626u, 0xe7c9bfa3u,
        0x9abab9fbu, 0x472c607eu, 0xfae60cb0u, 0x2770d535u, 0xb407a6dau, 0x69917f5fu,
        0xd45b1391u, 0x09cdca14u, 0x74becc4cu, 0xa92815c9u, 0x14e27907u, 0xc974a082u,
        0xee0475b7u, 0x3392ac32u, 0x8e58c0fcu, 0x53ce1979u, 0x2ebd1f21u, 0xf32bc6a4u,
        0x4ee1aa6au, 0x937773efu, 0xb37e4bf5u, 0x6ee89270u, 0xd322febeu, 0x0eb4273bu,
        0x73c72163u, 0xae51f8e6u, 0x139b9428u, 0xce0d4dadu, 0xe97d9898u, 0x34eb411du,
        0x89212dd3u, 0x54b7f456u, 0x29c4f20eu, 0xf4522b8bu, 0x49984745u, 0x940e9ec0u,
        0x0779ed2fu, 0xdaef34aau, 0x67255864u, 0xbab381e1u, 0xc7c087b9u, 0x1a565e3cu,
        0xa79c32f2u, 0x7a0aeb77u, 0x5d7a3e42u, 0x80ece7c7u, 0x3d268b09u, 0xe0b0528cu,
        0x9dc354d4u, 0x40558d51u, 0xfd9fe19fu, 0x2009381au, 0xbd8d91abu, 0x601b482eu,
        0xddd124e0u, 0x0047fd65u, 0x7d34fb3du, 0xa0a222b8u, 0x1d684e76u, 0xc0fe97f3u,
        0xe78e42c6u, 0x3a189b43u, 0x87d2f78du, 0x5a442e08u, 0x27372850u, 0xfaa1f1d5u,
        0x476b9d1bu, 0x9afd449eu, 0x098a3771u, 0xd41ceef4u, 0x69d6823au, 0xb4405bbfu,
        0xc9335de7u, 0x14a58462u, 0xa96fe8acu, 0x74f93129u, 0x5389e41cu, 0x8e1f3d99u,
        0x33d55157u, 0xee4388d2u, 0x93308e8au, 0x4ea6570fu, 0xf36c3bc1u, 0x2efae244u,
        0x0ef3da5eu, 0xd36503dbu, 0x6eaf6f15u, 0xb339b690u, 0xce4ab0c8u, 0x13dc694du,
        0xae160583u, 0x7380dc06u, 0x54f00933u, 0x8966d0b6u, 0x34acbc78u, 0xe93a65fdu,
        0x944963a5u, 0x49dfba20u, 0xf415d6eeu, 0x29830f6bu, 0xbaf47c84u, 0x6762a501u,
        0xdaa8c9cfu, 0x073e104au, 0x7a4d1612u, 0xa7dbcf97u, 0x1a11a359u, 0xc7877adcu,
        0xe0f7afe9u, 0x3d61766cu, 0x80ab1aa2u, 0x5d3dc327u, 0x204ec57fu, 0xfdd81cfau,
        0x40127034u, 0x9d84a9b1u, 0xa06a2517u, 0x7dfcfc92u, 0xc036905cu, 0x1da049d9u,
        0x60d34f81u, 0xbd459604u, 0x008ffacau, 0xdd19234fu, 0xfa69f67au, 0x27ff2fffu,
        0x9a354331u, 0x47a39ab4u, 0x3ad09cecu, 0xe7464569u, 0x5a8c29a7u, 0x871af022u,
        0x146d83cdu, 0xc9fb5a48u, 0x74313686u, 0xa9a7ef03u, 0xd4d4e95bu, 0x094230deu,
        0xb4885c10u, 0x691e8595u, 0x4e6e50a0u, 0x93f88925u, 0x2e32e5ebu, 0xf3a43c6eu,
        0x8ed73a36u, 0x5341e3b3u, 0xee8b8f7du, 0x331d56f8u, 0x13146ee2u, 0xce82b767u,
        0x7348dba9u, 0xaede022cu, 0xd3ad0474u, 0x0e3bddf1u, 0xb3f1b13fu, 0x6e6768bau,
        0x4917bd8fu, 0x9481640au, 0x294b08c4u, 0xf4ddd141u, 0x89aed719u, 0x54380e9cu,
        0xe9f26252u, 0x3464bbd7u, 0xa713c838u, 0x7a8511bdu, 0xc74f7d73u, 0x1ad9a4f6u,
        0x67aaa2aeu, 0xba3c7b2bu, 0x07f617e5u, 0xda60ce60u, 0xfd101b55u, 0x2086c2d0u,
        0x9d4cae1eu, 0x40da779bu, 0x3da971c3u, 0xe03fa846u, 0x5df5c488u, 0x80631d0du,
        0x1de7b4bcu, 0xc0716d39u, 0x7dbb01f7u, 0xa02dd872u, 0xdd5ede2au, 0x00c807afu,
        0xbd026b61u, 0x6094b2e4u, 0x47e467d1u, 0x9a72be54u, 0x27b8d29au, 0xfa2e0b1fu,
        0x875d0d47u, 0x5acbd4c2u, 0xe701b80cu, 0x3a976189u, 0xa9e01266u, 0x7476cbe3u,
        0xc9bca72du, 0x142a7ea8u, 0x695978f0u, 0xb4cfa175u, 0x0905cdbbu, 0xd493143eu,
        0xf3e3c10bu, 0x2e75188eu, 0x93bf7440u, 0x4e29adc5u, 0x335aab9du, 0xeecc7218u,
        0x53061ed6u, 0x8e90c753u, 0xae99ff49u, 0x730f26ccu, 0xcec54a02u, 0x13539387u,
        0x6e2095dfu, 0xb3b64c5au, 0x0e7c2094u, 0xd3eaf911u, 0xf49a2c24u, 0x290cf5a1u,
        0x94c6996fu, 0x495040eau, 0x342346b2u, 0xe9b59f37u, 0x547ff3f9u, 0x89e92a7cu,
        0x1a9e5993u, 0xc7088016u, 0x7ac2ecd8u, 0xa754355du, 0xda273305u, 0x07b1ea80u,
        0xba7b864eu, 0x67ed5fcbu, 0x409d8afeu, 0x9d0b537bu, 0x20c13fb5u, 0xfd57e630u,
        0x8024e068u, 0x5db239edu, 0xe0785523u, 0x3dee8ca6u,
    },
    { /* table 13 */
        0x00000000u, 0x9d0fe176u, 0xe16ec4adu, 0x7c6125dbu, 0x19ac8f1bu, 0x84a36e6du,
        0xf8c24bb6u, 0x65cdaac0u, 0x33591e36u, 0xae56ff40u, 0xd237da9bu, 0x4f383bedu,
        0x2af5912du, 0xb7fa705bu, 0xcb9b5580u, 0x5694b4f6u, 0x66b23c6cu, 0xfbbddd1au,
        0x87dcf8c1u, 0x1ad319b7u, 0x7f1eb377u, 0xe2115201u, 0x9e7077dau, 0x037f96acu,
        0x55eb225au, 0xc8e4c32cu, 0xb485e6f7u, 0x298a0781u, 0x4c47ad41u, 0xd1484c37u,
        0xad2969ecu, 0x3026889au, 0xcd6478d8u, 0x506b99aeu, 0x2c0abc75u, 0xb1055d03u,
        0xd4c8f7c3u, 0x49c716b5u, 0x35a6336eu, 0xa8a9d218u, 0xfe3d66eeu, 0x63328798u,
        0x1f53a243u, 0x825c4335u, 0xe791e9f5u, 0x7a9e0883u, 0x06ff2d58u, 0x9bf0cc2eu,
        0xabd644b4u, 0x36d9a5c2u, 0x4ab88019u, 0xd7b7616fu, 0xb27acbafu, 0x2f752ad9u,
        0x53140f02u, 0xce1bee74u, 0x988f5a82u, 0x0580bbf4u, 0x79e19e2fu, 0xe4ee7f59u,
        0x8123d599u, 0x1c2c34efu, 0x604d1134u, 0xfd42f042u, 0x41b9f7f1u, 0xdcb61687u,
        0xa0d7335cu, 0x3dd8d22au, 0x581578eau, 0xc51a999cu, 0xb97bbc47u, 0x24745d31u,
        0x72e0e9c7u, 0xefef08b1u, 0x938e2d6au, 0x0e81cc1cu, 0x6b4c66dcu, 0xf64387aau,
        0x8a22a271u, 0x172d4307u, 0x270bcb9du, 0xba042aebu, 0xc6650f30u, 0x5b6aee46u,
        0x3ea74486u, 0xa3a8a5f0u, 0xdfc9802bu, 0x42c6615du, 0x1452d5abu, 0x895d34ddu,
        0xf53c1106u, 0x6833f070u, 0x0dfe5ab0u, 0x90f1bbc6u, 0xec909e1du, 0x719f7f6bu,
        0x8cdd8f29u, 0x11d26e5fu, 0x6db34b84u, 0xf0bcaaf2u, 0x95710032u, 0x087ee144u,
        0x741fc49fu, 0xe91025e9u, 0xbf84911fu, 0x228b7069u, 0x5eea55b2u, 0xc3e5b4c4u,
        0xa6281e04u, 0x3b27ff72u, 0x4746daa9u, 0xda493bdfu, 0xea6fb345u, 0x77605233u,
        0x0b0177e8u, 0x960e969eu, 0xf3c33c5eu, 0x6eccdd28u, 0x12adf8f3u, 0x8fa21985u,
        0xd936ad73u, 0x44394c05u, 0x385869deu, 0xa55788a8u, 0xc09a2268u, 0x5d95c31eu,
        0x21f4e6c5u, 0xbcfb07b3u, 0x8373efe2u, 0x1e7c0e94u, 0x621d2b4fu, 0xff12ca39u,
        0x9adf60f9u, 0x07d0818fu, 0x7bb1a454u, 0xe6be4522u, 0xb02af1d4u, 0x2d2510a2u,
        0x51443579u, 0xcc4bd40fu, 0xa9867ecfu, 0x34899fb9u, 0x48e8ba62u, 0xd5e75b14u,
        0xe5c1d38eu, 0x78ce32f8u, 0x04af1723u, 0x99a0f655u, 0xfc6d5c95u, 0x6162bde3u,
        0x1d039838u, 0x800c794eu, 0xd698cdb8u, 0x4b972cceu, 0x37f60915u, 0xaaf9e863u,
        0xcf3442a3u, 0x523ba3d5u, 0x2e5a860eu, 0xb3556778u, 0x4e17973au, 0xd318764cu,
        0xaf795397u, 0x3276b2e1u, 0x57bb1821u, 0xcab4f957u, 0xb6d5dc8cu, 0x2bda3dfau,
        0x7d4e890cu, 0xe041687au, 0x9c204da1u, 0x012facd7u, 0x64e20617u, 0xf9ede761u,
        0x858cc2bau, 0x188323ccu, 0x28a5ab56u, 0xb5aa4a20u, 0xc9cb6ffbu, 0x54c48e8du,
        0x3109244du, 0xac06c53bu, 0xd067e0e0u, 0x4d680196u, 0x1bfcb560u, 0x86f35416u,
        0xfa9271cdu, 0x679d90bbu, 0x02503a7bu, 0x9f5fdb0du, 0xe33efed6u, 0x7e311fa0u,
        0xc2ca1813u, 0x5fc5f965u, 0x23a4dcbeu, 0xbeab3dc8u, 0xdb669708u, 0x4669767eu,
        0x3a0853a5u, 0xa707b2d3u, 0xf1930625u, 0x6c9ce753u, 0x10fdc288u, 0x8df223feu,
        0xe83f893eu, 0x75306848u, 0x09514d93u, 0x945eace5u, 0xa478247fu, 0x3977c509u,
        0x4516e0d2u, 0xd81901a4u, 0xbdd4ab64u, 0x20db4a12u, 0x5cba6fc9u, 0xc1b58ebfu,
        0x97213a49u, 0x0a2edb3fu, 0x764ffee4u, 0xeb401f92u, 0x8e8db552u, 0x13825424u,
        0x6fe371ffu, 0xf2ec9089u, 0x0fae60cbu, 0x92a181bdu, 0xeec0a466u, 0x73cf4510u,
        0x1602efd0u, 0x8b0d0ea6u, 0xf76c2b7du, 0x6a63ca0bu, 0x3cf77efdu, 0xa1f89f8bu,
        0xdd99ba50u, 0x40965b26u, 0x255bf1e6u, 0xb8541090u, 0xc435354bu, 0x593ad43du,
        0x691c5ca7u, 0xf413bdd1u, 0x8872980au, 0x157d797cu, 0x70b0d3bcu, 0xedbf32cau,
        0x91de1711u, 0x0cd1f667u, 0x5a454291u, 0xc74aa3e7u, 0xbb2b863cu, 0x2624674au,
        0x43e9cd8au, 0xdee62cfcu, 0xa2870927u, 0x3f88e851u,
    },
    { /* table 14 */
        0x00000000u, 0xb9fbdbe8u, 0xa886b191u, 0x117d6a79u, 0x8a7c6563u, 0x3387be8bu,
        0x22fad4f2u, 0x9b010f1au, 0xcf89cc87u, 0x7672176fu, 0x670f7d16u, 0xdef4a6feu,
        0x45f5a9e4u, 0xfc0e720cu, 0xed731875u, 0x5488c39du, 0x44629f4fu, 0xfd9944a7u,
        0xece42edeu, 0x551ff536u, 0xce1efa2cu, 0x77e521c4u, 0x66984bbdu, 0xdf639055u,
        0x8beb53c8u, 0x32108820u, 0x236de259u, 0x9a9639b1u, 0x019736abu, 0xb86ced43u,
        0xa911873au, 0x10ea5cd2u, 0x88c53e9eu, 0x313ee576u, 0x20438f0fu, 0x99b854e7u,
        0x02b95bfdu, 0xbb428015u, 0xaa3fea6cu, 0x13c43184u, 0x474cf219u, 0xfeb729f1u,
        0xefca4388u, 0x56319860u, 0xcd30977au, 0x74cb4c92u, 0x65b626ebu, 0xdc4dfd03u,
        0xcca7a1d1u, 0x755c7a39u, 0x64211040u, 0xdddacba8u, 0x46dbc4b2u, 0xff201f5au,
        0xee5d7523u, 0x57a6aecbu, 0x032e6d56u, 0xbad5b6beu, 0xaba8dcc7u, 0x1253072fu,
        0x89520835u, 0x30a9d3ddu, 0x21d4b9a4u, 0x982f624cu, 0xcafb7b7du, 0x7300a095u,
        0x627dcaecu, 0xdb861104u, 0x40871e1eu, 0xf97cc5f6u, 0xe801af8fu, 0x51fa7467u,
        0x0572b7fau, 0xbc896c12u, 0xadf4066bu, 0x140fdd83u, 0x8f0ed299u, 0x36f50971u,
        0x27886308u, 0x9e73b8e0u, 0x8e99e432u, 0x37623fdau, 0x261f55a3u, 0x9fe48e4bu,
        0x04e58151u, 0xbd1e5ab9u, 0xac6330c0u, 0x1598eb28u, 0x411028b5u, 0xf8ebf35du,
        0xe9969924u, 0x506d42ccu, 0xcb6c4dd6u, 0x7297963eu, 0x63eafc47u, 0xda1127afu,
        0x423e45e3u, 0xfbc59e0bu, 0xeab8f472u, 0x53432f9au, 0xc8422080u, 0x71b9fb68u,
        0x60c49111u, 0xd93f4af9u, 0x8db78964u, 0x344c528cu, 0x253138f5u, 0x9ccae31du,
        0x07cbec07u, 0xbe3037efu, 0xaf4d5d96u, 0x16b6867eu, 0x065cdaacu, 0xbfa70144u,
        0xaeda6b3du, 0x1721b0d5u, 0x8c20bfcfu, 0x35db6427u, 0x24a60e5eu, 0x9d5dd5b6u,
        0xc9d5162bu, 0x702ecdc3u, 0x6153a7bau, 0xd8a87c52u, 0x43a97348u, 0xfa52a8a0u,
        0xeb2fc2d9u, 0x52d41931u, 0x4e87f0bbu, 0xf77c2b53u, 0xe601412au, 0x5ffa9ac2u,
        0xc4fb95d8u, 0x7d004e30u, 0x6c7d2449u, 0xd586ffa1u, 0x810e3c3cu, 0x38f5e7d4u,
        0x29888dadu, 0x90735645u, 0x0b72595fu, 0xb28982b7u, 0xa3f4e8ceu, 0x1a0f3326u,
        0x0ae56ff4u, 0xb31eb41cu, 0xa263de65u, 0x1b98058du, 0x80990a97u, 0x3962d17fu,
        0x281fbb06u, 0x91e460eeu, 0xc56ca373u, 0x7c97789bu, 0x6dea12e2u, 0xd411c90au,
        0x4f10c610u, 0xf6eb1df8u, 0xe7967781u, 0x5e6dac69u, 0xc642ce25u, 0x7fb915cdu,
        0x6ec47fb4u, 0xd73fa45cu, 0x4c3eab46u, 0xf5c570aeu, 0xe4b81ad7u, 0x5d43c13fu,
        0x09cb02a2u, 0xb030d94au, 0xa14db333u, 0x18b668dbu, 0x83b767c1u, 0x3a4cbc29u,
        0x2b31d650u, 0x92ca0db8u, 0x8220516au, 0x3bdb8a82u, 0x2aa6e0fbu, 0x935d3b13u,
        0x085c3409u, 0xb1a7efe1u, 0xa0da8598u, 0x19215e70u, 0x4da99dedu, 0xf4524605u,
        0xe52f2c7cu, 0x5cd4f794u, 0xc7d5f88eu, 0x7e2e2366u, 0x6f53491fu, 0xd6a892f7u,
        0x847c8bc6u, 0x3d87502eu, 0x2cfa3a57u, 0x9501e1bfu, 0x0e00eea5u, 0xb7fb354du,
        0xa6865f34u, 0x1f7d84dcu, 0x4bf54741u, 0xf20e9ca9u, 0xe373f6d0u, 0x5a882d38u,
        0xc1892222u, 0x7872f9cau, 0x690f93b3u, 0xd0f4485bu, 0xc01e1489u, 0x79e5cf61u,
        0x6898a518u, 0xd1637ef0u, 0x4a6271eau, 0xf399aa02u, 0xe2e4c07bu, 0x5b1f1b93u,
        0x0f97d80eu, 0xb66c03e6u, 0xa711699fu, 0x1eeab277u, 0x85ebbd6du, 0x3c106685u,
        0x2d6d0cfcu, 0x9496d714u, 0x0cb9b558u, 0xb5426eb0u, 0xa43f04c9u, 0x1dc4df21u,
        0x86c5d03bu, 0x3f3e0bd3u, 0x2e4361aau, 0x97b8ba42u, 0xc33079dfu, 0x7acba237u,
        0x6bb6c84eu, 0xd24d13a6u, 0x494c1cbcu, 0xf0b7c754u, 0xe1caad2du, 0x583176c5u,
        0x48db2a17u, 0xf120f1ffu, 0xe05d9b86u, 0x59a6406eu, 0xc2a74f74u, 0x7b5c949cu,
        0x6a21fee5u, 0xd3da250du, 0x8752e690u, 0x3ea93d78u, 0x2fd45701u, 0x962f8ce9u,
        0x0d2e83f3u, 0xb4d5581bu, 0xa5a83262u, 0x1c53e98au,
    },
    { /* table 15 */
        0x00000000u, 0xae689191u, 0x87a02563u, 0x29c8b4f2u, 0xd4314c87u, 0x7a59dd16u,
        0x539169e4u, 0xfdf9f875u, 0x73139f4fu, 0xdd7b0edeu, 0xf4b3ba2cu, 0x5adb2bbdu,
        0xa722d3c8u, 0x094a4259u, 0x2082f6abu, 0x8eea673au, 0xe6273e9eu, 0x484faf0fu,
        0x61871bfdu, 0xcfef8a6cu, 0x32167219u, 0x9c7ee388u, 0xb5b6577au, 0x1bdec6ebu,
        0x9534a1d1u, 0x3b5c3040u, 0x129484b2u, 0xbcfc1523u, 0x4105ed56u, 0xef6d7cc7u,
        0xc6a5c835u, 0x68cd59a4u, 0x173f7b7du, 0xb957eaecu, 0x909f5e1eu, 0x3ef7cf8fu,
        0xc30e37fau, 0x6d66a66bu, 0x44ae1299u, 0xeac68308u, 0x642ce432u, 0xca4475a3u,
        0xe38cc151u, 0x4de450c0u, 0xb01da8b5u, 0x1e753924u, 0x37bd8dd6u, 0x99d51c47u,
        0xf11845e3u, 0x5f70d472u, 0x76b86080u, 0xd8d0f111u, 0x25290964u, 0x8b4198f5u,
        0xa2892c07u, 0x0ce1bd96u, 0x820bdaacu, 0x2c634b3du, 0x05abffcfu, 0xabc36e5eu,
        0x563a962bu, 0xf85207bau, 0xd19ab348u, 0x7ff222d9u, 0x2e7ef6fau, 0x8016676bu,
        0xa9ded399u, 0x07b64208u, 0xfa4fba7du, 0x54272becu, 0x7def9f1eu, 0xd3870e8fu,
        0x5d6d69b5u, 0xf305f824u, 0xdacd4cd6u, 0x74a5dd47u, 0x895c2532u, 0x2734b4a3u,
        0x0efc0051u, 0xa09491c0u, 0xc859c864u, 0x663159f5u, 0x4ff9ed07u, 0xe1917c96u,
        0x1c6884e3u, 0xb2001572u, 0x9bc8a180u, 0x35a03011u, 0xbb4a572bu, 0x1522c6bau,
        0x3cea7248u, 0x9282e3d9u, 0x6f7b1bacu, 0xc1138a3du, 0xe8db3ecfu, 0x46b3af5eu,
        0x39418d87u, 0x97291c16u, 0xbee1a8e4u, 0x10893975u, 0xed70c100u, 0x43185091u,
        0x6ad0e463u, 0xc4b875f2u, 0x4a5212c8u, 0xe43a8359u, 0xcdf237abu, 0x639aa63au,
        0x9e635e4fu, 0x300bcfdeu, 0x19c37b2cu, 0xb7abeabdu, 0xdf66b319u, 0x710e2288u,
        0x58c6967au, 0xf6ae07ebu, 0x0b57ff9eu, 0xa53f6e0fu, 0x8cf7dafdu, 0x229f4b6cu,
        0xac752c56u, 0x021dbdc7u, 0x2bd50935u, 0x85bd98a4u, 0x784460d1u, 0xd62cf140u,
        0xffe445b2u, 0x518cd423u, 0x5cfdedf4u, 0xf2957c65u, 0xdb5dc897u, 0x75355906u,
        0x88cca173u, 0x26a430e2u, 0x0f6c8410u, 0xa1041581u, 0x2fee72bbu, 0x8186e32au,
        0xa84e57d8u, 0x0626c649u, 0xfbdf3e3cu, 0x55b7afadu, 0x7c7f1b5fu, 0xd2178aceu,
        0xbadad36au, 0x14b242fbu, 0x3d7af609u, 0x93126798u, 0x6eeb9fedu, 0xc0830e7cu,
        0xe94bba8eu, 0x47232b1fu, 0xc9c94c25u, 0x67a1ddb4u, 0x4e696946u, 0xe001f8d7u,
        0x1df800a2u, 0xb3909133u, 0x9a5825c1u, 0x3430b450u, 0x4bc29689u, 0xe5aa0718u,
        0xcc62b3eau, 0x620a227bu, 0x9ff3da0eu, 0x319b4b9fu, 0x1853ff6du, 0xb63b6efcu,
        0x38d109c6u, 0x96b99857u, 0xbf712ca5u, 0x1119bd34u, 0xece04541u, 0x4288d4d0u,
        0x6b406022u, 0xc528f1b3u, 0xade5a817u, 0x038d3986u, 0x2a458d74u, 0x842d1ce5u,
        0x79d4e490u, 0xd7bc7501u, 0xfe74c1f3u, 0x501c5062u, 0xdef63758u, 0x709ea6c9u,
        0x5956123bu, 0xf73e83aau, 0x0ac77bdfu, 0xa4afea4eu, 0x8d675ebcu, 0x230fcf2du,
        0x72831b0eu, 0xdceb8a9fu, 0xf5233e6du, 0x5b4baffcu, 0xa6b25789u, 0x08dac618u,
        0x211272eau, 0x8f7ae37bu, 0x01908441u, 0xaff815d0u, 0x8630a122u, 0x285830b3u,
        0xd5a1c8c6u, 0x7bc95957u, 0x5201eda5u, 0xfc697c34u, 0x94a42590u, 0x3accb401u,
        0x130400f3u, 0xbd6c9162u, 0x40956917u, 0xeefdf886u, 0xc7354c74u, 0x695ddde5u,
        0xe7b7badfu, 0x49df2b4eu, 0x60179fbcu, 0xce7f0e2du, 0x3386f658u, 0x9dee67c9u,
        0xb426d33bu, 0x1a4e42aau, 0x65bc6073u, 0xcbd4f1e2u, 0xe21c4510u, 0x4c74d481u,
        0xb18d2cf4u, 0x1fe5bd65u, 0x362d0997u, 0x98459806u, 0x16afff3cu, 0xb8c76eadu,
        0x910fda5fu, 0x3f674bceu, 0xc29eb3bbu, 0x6cf6222au, 0x453e96d8u, 0xeb560749u,
        0x839b5eedu, 0x2df3cf7cu, 0x043b7b8eu, 0xaa53ea1fu, 0x57aa126au, 0xf9c283fbu,
        0xd00a3709u, 0x7e62a698u, 0xf088c1a2u, 0x5ee05033u, 0x7728e4c1u, 0xd9407550u,
        0x24b98d25u, 0x8ad11cb4u, 0xa319a846u, 0x0d7139d7u,
    },
};

/* The running CRC c over n bytes, one at a time: the tail after the
   16-byte steps. */
GS__PRIVATE uint32_t gs__crc32_tail(uint32_t c, const unsigned char *p, size_t n) {
    size_t i;
    for (i = 0; i < n; ++i) c = gs__crc_table[0][(c ^ p[i]) & 0xffu] ^ (c >> 8);
    return c;
}

/* A little-endian word, whatever the host's byte order or the alignment
   of p (compilers make it one load on little-endian hosts). */
GS__PRIVATE uint32_t gs__crc_word(const unsigned char *p) {
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* On x86 with PCLMULQDQ (carry-less multiply, every x86-64 CPU since
   2010), the CRC of the 16-byte blocks is folded four blocks at a time as
   in Gopal et al., "Fast CRC Computation for Generic Polynomials Using
   PCLMULQDQ Instruction" (Intel, 2009): about 0.05 us a full datagram,
   where the tables take 0.31. Whether the CPU has it is asked each time
   (__builtin_cpu_supports reads what the C runtime found at start-up:
   nothing of ghostsim's to set); without it, or elsewhere, the tables do
   it all. The constants, each a polynomial bit-reflected and shifted left
   by one as the paper's reflected form asks (P = 0x104C11DB7):
     k1 = x^(4*128+32) mod P, k2 = x^(4*128-32) mod P   fold by 64 bytes
     k3 = x^(128+32) mod P,   k4 = x^(128-32) mod P     fold by 16 bytes
     k5 = x^64 mod P                                    64 bits to 32
     mu = x^64 / P (33 bits), P' = P reflected          Barrett reduction
   tests/test_wire.c checks it against a bitwise CRC at every length and
   alignment up to past a datagram. */
#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
#define GS__CRC_CLMUL 1
#include <immintrin.h>

__attribute__((target("pclmul,sse4.1"))) GS__PRIVATE __m128i
gs__crc_fold(__m128i x, __m128i k, const unsigned char *p) {
    __m128i lo = _mm_clmulepi64_si128(x, k, 0x00), hi = _mm_clmulepi64_si128(x, k, 0x11);
    return _mm_xor_si128(_mm_xor_si128(lo, hi), _mm_loadu_si128((const __m128i *)(const void *)p));
}

/* The running CRC c over n bytes, n >= 64 and a multiple of 16. */
__attribute__((target("pclmul,sse4.1"))) GS__PRIVATE uint32_t
gs__crc32_clmul(uint32_t c, const unsigned char *p, size_t n) {
    const __m128i k1k2 = _mm_set_epi64x(0x1c6e41596LL, 0x154442bd4LL);
    const __m128i k3k4 = _mm_set_epi64x(0x0ccaa009eLL, 0x1751997d0LL);
    const __m128i k5 = _mm_set_epi64x(0, 0x163cd6124LL);
    const __m128i mu_p = _mm_set_epi64x(0x1f7011641LL, 0x1db710641LL);
    const __m128i low32 = _mm_setr_epi32(-1, 0, -1, 0);
    __m128i x1 = _mm_loadu_si128((const __m128i *)(const void *)p);
    __m128i x2 = _mm_loadu_si128((const __m128i *)(const void *)(p + 16));
    __m128i x3 = _mm_loadu_si128((const __m128i *)(const void *)(p + 32));
    __m128i x4 = _mm_loadu_si128((const __m128i *)(const void *)(p + 48)), t;
    x1 = _mm_xor_si128(x1, _mm_cvtsi32_si128((int)c));
    for (p += 64, n -= 64; n >= 64; p += 64, n -= 64) { /* four lanes */
        x1 = gs__crc_fold(x1, k1k2, p);
        x2 = gs__crc_fold(x2, k1k2, p + 16);
        x3 = gs__crc_fold(x3, k1k2, p + 32);
        x4 = gs__crc_fold(x4, k1k2, p + 48);
    }
    x1 = _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x1, k3k4, 0x00),
                                     _mm_clmulepi64_si128(x1, k3k4, 0x11)), x2);
    x1 = _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x1, k3k4, 0x00),
                                     _mm_clmulepi64_si128(x1, k3k4, 0x11)), x3);
    x1 = _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x1, k3k4, 0x00),
                                     _mm_clmulepi64_si128(x1, k3k4, 0x11)), x4);
    for (; n >= 16; p += 16, n -= 16) x1 = gs__crc_fold(x1, k3k4, p);
    /* 128 bits to 64, then to 32 */
    x1 = _mm_xor_si128(_mm_srli_si128(x1, 8), _mm_clmulepi64_si128(x1, k3k4, 0x10));
    t = _mm_srli_si128(x1, 4);
    x1 = _mm_xor_si128(_mm_clmulepi64_si128(_mm_and_si128(x1, low32), k5, 0x00), t);
    /* Barrett: the remainder of the 64 bits by P */
    t = _mm_clmulepi64_si128(_mm_and_si128(x1, low32), mu_p, 0x10);
    t = _mm_clmulepi64_si128(_mm_and_si128(t, low32), mu_p, 0x00);
    return (uint32_t)_mm_extract_epi32(_mm_xor_si128(x1, t), 1);
}
#endif

/* Each of the 16 bytes is looked up in the table of the zero bytes that
   follow it within the 16; the running CRC enters with the first word. */
GS__PRIVATE uint32_t gs__crc32(const unsigned char *p, size_t n) {
    const uint32_t (*t)[256] = gs__crc_table;
    uint32_t c = 0xffffffffu;
#ifdef GS__CRC_CLMUL
    if (n >= 64 && __builtin_cpu_supports("pclmul") && __builtin_cpu_supports("sse4.1")) {
        size_t m = n & ~(size_t)15;
        c = gs__crc32_clmul(c, p, m);
        p += m;
        n -= m;
    }
#endif
    for (; n >= 16; p += 16, n -= 16) {
        uint32_t a = c ^ gs__crc_word(p), b = gs__crc_word(p + 4);
        uint32_t d = gs__crc_word(p + 8), e = gs__crc_word(p + 12);
        c = t[15][a & 0xffu] ^ t[14][(a >> 8) & 0xffu] ^ t[13][(a >> 16) & 0xffu] ^
            t[12][a >> 24] ^ t[11][b & 0xffu] ^ t[10][(b >> 8) & 0xffu] ^
            t[9][(b >> 16) & 0xffu] ^ t[8][b >> 24] ^ t[7][d & 0xffu] ^ t[6][(d >> 8) & 0xffu] ^
            t[5][(d >> 16) & 0xffu] ^ t[4][d >> 24] ^ t[3][e & 0xffu] ^ t[2][(e >> 8) & 0xffu] ^
            t[1][(e >> 16) & 0xffu] ^ t[0][e >> 24];
    }
    return gs__crc32_tail(c, p, n) ^ 0xffffffffu;
}

#ifdef __cplusplus
}
#endif
#endif /* GHOSTSIM_IMPLEMENTATION_DONE */
#endif /* GHOSTSIM_IMPLEMENTATION */

/*
------------------------------------------------------------------------------
MIT License

Copyright (c) 2026 the ghostsim authors

Permission is hereby granted, free of charge, to any person obtaining a copy
of this software and associated documentation files (the "Software"), to deal
in the Software without restriction, including without limitation the rights
to use, copy, modify, merge, publish, distribute, sublicense, and/or sell
copies of the Software, and to permit persons to whom the Software is
furnished to do so, subject to the following conditions:

The above copyright notice and this permission notice shall be included in
all copies or substantial portions of the Software.

THE SOFTWARE IS PROVIDED "AS IS", WITHOUT WARRANTY OF ANY KIND, EXPRESS OR
IMPLIED, INCLUDING BUT NOT LIMITED TO THE WARRANTIES OF MERCHANTABILITY,
FITNESS FOR A PARTICULAR PURPOSE AND NONINFRINGEMENT. IN NO EVENT SHALL THE
AUTHORS OR COPYRIGHT HOLDERS BE LIABLE FOR ANY CLAIM, DAMAGES OR OTHER
LIABILITY, WHETHER IN AN ACTION OF CONTRACT, TORT OR OTHERWISE, ARISING FROM,
OUT OF OR IN CONNECTION WITH THE SOFTWARE OR THE USE OR OTHER DEALINGS IN THE
SOFTWARE.
------------------------------------------------------------------------------
*/
