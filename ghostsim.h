/* ghostsim.h - v0.1.0 - collaborative interactive physics in one C header

   Several people on several hosts push and pull one shared physical scene.
   Every host runs the whole simulation; ghost objects blend each host's state
   with the states its peers send, weighted by rules the user supplies
   (Dequidt, Grisoni, Chaillou: "Collaborative Interactive Physical
   Simulation"). Nobody freezes when the network is slow or gone.

   GETTING THE IMPLEMENTATION
       In exactly one C or C++ file:
           #define GHOSTSIM_IMPLEMENTATION
           #include "ghostsim.h"
       Every other file includes the header alone. The implementation needs
       POSIX (clock_gettime, sockets, pthreads) and asks for it itself; if
       that file includes a system header before this one, compile it with
       -D_POSIX_C_SOURCE=200809L (or -std=gnu99, or as C++). Link with
       $(pkg-config --libs ccd) -lm -lpthread.

   QUICK START
       gs_world *w;
       gs_agent *cloth;
       gs_world_desc wd = {0};
       gs_cloth_desc cd = {0};
       if (gs_world_create(&wd, &w) != GS_OK) return 1;
       cd.nx = 16; cd.ny = 16;                   // particles per side
       cd.width = 1.0; cd.height = 1.0;          // metres
       cd.pin_corners = GS_CORNER_ALL;           // hang it by its 4 corners
       cd.solver.integrator = GS_INTEGRATOR_IMPLICIT_EULER;
       if (gs_cloth_create(w, &cd, &cloth) != GS_OK) {
           fprintf(stderr, "%s\n", gs_world_error(w));
           return 1;
       }
       for (int frame = 0; frame < 120; ++frame)
           gs_world_advance(w, 1.0 / 60.0, NULL);  // one frame of 1/60 s
       const gs_vec3 *x = gs_mesh_positions(cloth); // draw these
       gs_world_destroy(w);

   CONCEPTS
       world      Owns agents and the scheduler. Belongs to one thread.
       agent      One simulated object: its own dt, integrator, state and
                  simulation time t = steps * dt (+ whatever ghost blending
                  moved it by). Spring-mass meshes and cloths are agents; so
                  are user agents built from a gs_custom_desc.
       scheduler  N+1 FIFO priority queues (the paper's Q_0..Q_N). The most
                  urgent runnable agent steps next; aging keeps low queues
                  from starving; an agent that leads the slowest agent by
                  more than the world's tolerance is held back. Each agent's
                  behaviour rule moves its priority when it is activated.
       state      A flat array of doubles: [t, then the agent's variables].
                  This is what ghosts blend between hosts.
       contact    Penalty forces between agents (gs_material): each agent
                  computes the force on itself from the other agent's state
                  brought to its own simulation time.
       ghost      Wraps an agent under an object id shared by all hosts:
                  publishes its state, blends the snapshots peers send with
                  the paper's weighted mean (gs_weight_fn rules).
       snapshot   One agent's state at one simulation time, on the wire in
                  chunks of at most one datagram (wire format v1).
       transport  What carries datagrams: gs_simnet (simulated, seeded),
                  gs_udp (POSIX), or your send callback + gs_net_deliver.

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
       a failed call changes nothing. Calling into a world from a callback
       that runs inside its own gs_world_advance() returns GS_ERR_BUSY.
       Out of memory is GS_ERR_NO_MEMORY, never abort().

   NUMBERS
       SI units throughout: seconds, metres, kilograms, newtons. No NaN or
       infinity ever leaves an agent: a step that would produce one (or a
       speed above solver.max_speed) is undone and reported as
       GS_ERR_UNSTABLE; the agent keeps its last finite state.

   THREADS
       A world and everything in it belongs to the thread that calls into
       it. Two worlds on two threads share nothing. The library has no
       global mutable state. gs_udp (threads = 1) runs a gather thread
       (receive, validate, queue) and a scatter thread (send what is due);
       they touch only the net's peers, queues, published states and
       statistics, under one mutex that the world thread also takes when a
       ghost publishes or blends. gs_net_deliver, gs_net_update and the
       stats calls are safe from any thread; everything else (adding and
       removing peers included) belongs to the world's thread.

   REVISION HISTORY
       0.1.0 (2026-11-23)  world, scheduler, spring-mass agents, integrators,
                           rigid bodies, probes, contacts, the paper's scene,
                           ghosts, wire format v1, simnet, POSIX UDP.

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

/* ========================================================================
   >>result
   Negative codes are errors. The list makes both the enum and the strings.
   ======================================================================== */
#define GS__RESULT_LIST(X)                                                     \
    X(GS_OK, 0, "ok")                                                          \
    X(GS_ERR_INVALID_ARG, -1, "invalid argument")                              \
    X(GS_ERR_NOT_FINITE, -2, "a number is NaN or infinite")                    \
    X(GS_ERR_OUT_OF_RANGE, -3, "an index or count is out of range")            \
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
} gs_world_desc;

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
   joined afterwards. NULL is ignored. */
GS_API void gs_world_destroy(gs_world *w);

/* Moves the target time on by `seconds` (>= 0) and runs agent steps, most
   urgent first, until every agent is within half its dt of the target or the
   wall-clock budget is spent. An agent whose step fails keeps its state and
   stops advancing for the rest of this call; the others go on.
   report may be NULL. Returns GS_OK, GS_ERR_INVALID_ARG (negative seconds),
   GS_ERR_NOT_FINITE (NaN or infinite seconds), GS_ERR_BUSY (called from inside an advance), or the
   first error an agent's step returned (every other agent still advanced). */
GS_API gs_result gs_world_advance(gs_world *w, double seconds,
                                  gs_advance_report *report);

/* The target time reached by the advance calls so far, in seconds. When
   ghost blending has moved every agent past it (a host that joins late takes
   the others' time), the next advance starts from the slowest agent. */
GS_API double gs_world_time(const gs_world *w);

/* The detail of the last failed call on this world ("" if none). The text
   stays valid until the next call on the world. */
GS_API const char *gs_world_error(const gs_world *w);

GS_API uint32_t gs_world_host_id(const gs_world *w);
GS_API int gs_world_agent_count(const gs_world *w);
/* The i-th agent in creation order, or NULL if i is out of range. */
GS_API gs_agent *gs_world_agent(const gs_world *w, int i);

GS_API gs_vec3 gs_world_gravity(const gs_world *w);
/* Any finite vector, zero included. */
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

/* How an agent steps. Zero fields take the defaults written beside them. */
typedef struct gs_solver_desc {
    double dt;               /* s; default 0.001 */
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
} gs_solver_desc;

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
GS_API double gs_agent_dt(const gs_agent *a);
GS_API gs_world *gs_agent_world(const gs_agent *a);
/* "mesh", "cloth", "rigid", "probe" or "custom". */
GS_API const char *gs_agent_kind(const gs_agent *a);

/* Number of doubles in the state vector, time included. */
GS_API size_t gs_agent_state_size(const gs_agent *a);
/* Writes [t, variables...] into out, which holds n doubles.
   GS_ERR_SIZE_MISMATCH unless n == gs_agent_state_size(a). */
GS_API gs_result gs_agent_get_state(const gs_agent *a, double *out, size_t n);
/* Sets the state, time included. Every number must be finite; on error
   nothing changes. */
GS_API gs_result gs_agent_set_state(gs_agent *a, const double *in, size_t n);

/* Steps the agent once by its dt, outside the scheduler (for tools and
   tests). GS_ERR_BUSY inside an advance. */
GS_API gs_result gs_agent_step(gs_agent *a);
/* The result of the agent's last step. */
GS_API gs_result gs_agent_result(const gs_agent *a);

GS_API int gs_agent_priority(const gs_agent *a);
/* Moves the agent to another queue; clamped to 0..N. Allowed from inside the
   agent's own step or behaviour rule: it takes effect when it is queued
   again. */
GS_API void gs_agent_set_priority(gs_agent *a, int priority);
/* Replaces the behaviour rule; NULL restores gs_behaviour_default. */
GS_API void gs_agent_set_behaviour(gs_agent *a, gs_behaviour_fn fn,
                                   void *user);
GS_API gs_agent_stats gs_agent_get_stats(const gs_agent *a);
/* Removes the agent from its world and frees it. GS_ERR_BUSY inside an
   advance. */
GS_API gs_result gs_agent_destroy(gs_agent *a);

/* A user agent. Its variables live in user memory; ghostsim keeps its time
   and schedules it like any other. */
typedef struct gs_custom_desc {
    double dt;          /* s; required, > 0 */
    size_t state_size;  /* doubles, excluding time; may be 0 */
    /* Advances by dt seconds from time t. Returning an error leaves the
       agent's time unchanged; the callback should leave its state too. */
    gs_result (*step)(void *user, double t, double dt);
    void (*get_state)(const void *user, double *out);  /* state_size */
    gs_result (*set_state)(void *user, const double *in);
    void *user;
} gs_custom_desc;

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

typedef struct gs_mesh_desc {
    int particle_count;        /* >= 1 */
    const gs_vec3 *positions;  /* m; particle_count of them, required */
    const gs_vec3 *velocities; /* m/s; NULL = at rest */
    const double *masses;      /* kg each, > 0; NULL = mass / count */
    double mass;               /* kg in all when masses is NULL; default 1 */
    int spring_count;
    const gs_spring *springs;
    int pin_count;
    const int *pins;           /* particles held where they are */
    double air_damping;        /* 1/s; force -m * air_damping * v */
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
    int nx, ny;          /* particles along u and v; each >= 2 */
    double width, height; /* m along u and v; default 1 x 1 */
    gs_vec3 origin;      /* m; where particle (0,0) is; default 0 */
    gs_vec3 axis_u;      /* direction of rows; default +x */
    gs_vec3 axis_v;      /* direction of columns; default +z (the cloth
                            lies flat under y-up gravity) */
    double mass;         /* kg in all; default 1 */
    int springs;         /* GS_SPRINGS_* mask; default all */
    double stretch_stiffness; /* N/m, structural; default 1000 */
    double shear_stiffness;   /* N/m; default stretch / 10 */
    double bend_stiffness;    /* N/m; default stretch / 100 */
    double spring_damping;    /* N s/m on every spring; default 0.02 */
    double air_damping;       /* 1/s; default 0.1 */
    int pin_corners;     /* GS_CORNER_* mask */
    int pin_count;       /* more pins, as particle index i + nx * j */
    const int *pins;
    double particle_radius; /* m, for contacts; default half the smaller
                               spacing between particles */
    gs_material material;      /* contacts; zero fields take defaults */
    gs_solver_desc solver;
} gs_cloth_desc;

GS_API gs_mesh_desc gs_mesh_desc_default(void);
GS_API gs_cloth_desc gs_cloth_desc_default(void);

/* Creates a spring-mass agent. Errors name the bad field in
   gs_world_error(w): GS_ERR_INVALID_ARG, GS_ERR_NOT_FINITE,
   GS_ERR_OUT_OF_RANGE (a spring or pin index), GS_ERR_NO_MEMORY. */
GS_API gs_result gs_mesh_create(gs_world *w, const gs_mesh_desc *desc,
                                gs_agent **out);
/* Creates a cloth: an nx x ny grid of particles, mass spread evenly. */
GS_API gs_result gs_cloth_create(gs_world *w, const gs_cloth_desc *desc,
                                 gs_agent **out);

/* For spring-mass agents (NULL / 0 for any other kind). */
GS_API int gs_mesh_particle_count(const gs_agent *a);
GS_API int gs_mesh_spring_count(const gs_agent *a);
GS_API const gs_vec3 *gs_mesh_positions(const gs_agent *a);
GS_API const gs_vec3 *gs_mesh_velocities(const gs_agent *a);
/* Kinetic energy and potential energy (springs plus gravity, relative to
   the origin), in joules. Either pointer may be NULL. */
GS_API gs_result gs_mesh_energy(const gs_agent *a, double *kinetic,
                                double *potential);
/* The largest stable step of the agent's explicit integrator, in seconds,
   from the bound omega_max^2 <= max_i (sum of k over i's springs, those to
   free particles counted twice) / m_i (Gershgorin) and the damping rate
   likewise; +inf for implicit Euler. */
GS_API double gs_mesh_stable_dt(const gs_agent *a);
/* Moves a pinned particle (the application drags a corner) to pos, in
   metres. GS_ERR_INVALID_ARG if the agent is not a spring-mass agent or the
   particle is not pinned, GS_ERR_OUT_OF_RANGE for a bad index,
   GS_ERR_NOT_FINITE for a non-finite position; the mesh is unchanged then. */
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

typedef struct gs_shape_desc {
    gs_shape_type type;
    double radius;          /* m, sphere */
    gs_vec3 half_extents;   /* m, box */
    const gs_vec3 *points;  /* m, hull, in body coordinates; the body's
                               origin becomes the hull's centre of mass */
    int point_count;
} gs_shape_desc;

typedef struct gs_rigid_desc {
    gs_shape_desc shape;
    double density;        /* kg/m^3; default 1000 */
    double mass;           /* kg; > 0 overrides density */
    gs_vec3 inertia;       /* kg m^2, principal moments in body axes;
                              default from shape and mass */
    gs_vec3 position;      /* m */
    gs_quat orientation;   /* default identity; normalized on create */
    gs_vec3 velocity;      /* m/s */
    gs_vec3 angular_velocity; /* rad/s, world frame */
    gs_material material;
    int continuous;        /* 1: substep so that the body never moves more
                              than a quarter of its smallest size per
                              substep (stops tunnelling of fast bodies) */
    gs_solver_desc solver; /* symplectic Euler (default), Verlet or RK4;
                              substeps keep contact stiffness stable */
    double rolling;        /* m, >= 0; rolling resistance: at each contact
                              a torque of up to rolling * N (N the normal
                              force) against the body's spin relative to
                              what it touches, about axes in the contact
                              plane (rolling / radius is the usual
                              coefficient). Without it a ball that rolls
                              off onto the ground rolls for ever. Default 0 */
} gs_rigid_desc;

/* A kinematic body the application moves: nothing pushes it back. */
typedef struct gs_probe_desc {
    gs_shape_desc shape;
    gs_vec3 position;      /* m */
    gs_quat orientation;   /* default identity */
    gs_material material;
    double dt;             /* s; default 0.001 */
    double max_speed;      /* m/s it may move at to reach its target;
                              default 10 */
    uint32_t owner;        /* host that drives it; default this world's */
} gs_probe_desc;

GS_API gs_rigid_desc gs_rigid_desc_default(void);
GS_API gs_probe_desc gs_probe_desc_default(void);
GS_API gs_material gs_material_default(void);

/* Creates a rigid body. Errors name the field: a degenerate hull (fewer
   than 4 points, all in one plane), a size <= 0, a negative density (0 is
   the default 1000 kg/m^3), NaN. */
GS_API gs_result gs_rigid_create(gs_world *w, const gs_rigid_desc *desc,
                                 gs_agent **out);
GS_API gs_result gs_probe_create(gs_world *w, const gs_probe_desc *desc,
                                 gs_agent **out);

/* Where the probe should be; it moves there over its next steps at no more
   than max_speed. */
GS_API gs_result gs_probe_set_target(gs_agent *probe, gs_vec3 position,
                                     gs_quat orientation);

/* For rigid bodies and probes (zero for other kinds). */
GS_API gs_vec3 gs_rigid_position(const gs_agent *a);
GS_API gs_quat gs_rigid_orientation(const gs_agent *a);
GS_API gs_vec3 gs_rigid_velocity(const gs_agent *a);
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

/* The exact or libccd answer for two shapes at two poses: returns 1 and
   fills *c when they overlap, 0 when apart. Every output is finite: where
   libccd returns a non-finite direction (touching or coincident shapes) the
   answer falls back to the direction between the centres. */
GS_API int gs_collide_shapes(const gs_shape_desc *a, gs_vec3 pa, gs_quat qa,
                             const gs_shape_desc *b, gs_vec3 pb, gs_quat qb,
                             gs_contact *c);

/* A ground plane y = height that every body meets. */
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

typedef struct gs_scene_desc {
    int cloth_n;          /* particles per side; default 16 */
    double cloth_size;    /* m; default 1 */
    int sphere_count;     /* 0..GS_SCENE_MAX_SPHERES, taken as given (0 =
                             none); gs_scene_desc_default() says 3 */
    double sphere_radius; /* m; default 0.08 */
    int probe_count;      /* 0..GS_SCENE_MAX_PROBES, taken as given;
                             gs_scene_desc_default() says 1 */
    uint32_t seed;        /* sphere placement; default 1 */
    gs_integrator cloth_integrator; /* default implicit Euler */
    double dt;            /* s for every agent; default 0.002 */
} gs_scene_desc;

typedef struct gs_scene {
    gs_agent *cloth;
    gs_agent *spheres[GS_SCENE_MAX_SPHERES];
    gs_agent *probes[GS_SCENE_MAX_PROBES];
    int sphere_count, probe_count;
    gs_scene_desc desc;   /* with defaults applied */
} gs_scene;

GS_API gs_scene_desc gs_scene_desc_default(void);
/* Builds the scene in w (ground on at y = -1.5 m): cloth in the plane
   y = 0 centred on the origin, spheres above it, probes above the cloth.
   Probe i is owned by host i + 1. */
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
                        estimate: half the round trip plus queueing) */
    uint32_t host;   /* the sending host (this host for the local state) */
    uint32_t lead;   /* the host whose x_comp is x_max; but hosts within the
                        ghost's time deadband of it are in step, a tie, and
                        the lowest id among them leads */
    uint32_t owner;  /* the object's owner, 0 if shared */
    int local;       /* 1 for the local state */
    int local_owns;  /* 1 if this host owns the object */
} gs_weight_in;

/* A weight rule: any finite value >= 0. A negative, NaN or infinite weight
   counts as 0 (and is counted); if every weight is 0 the local state stands. */
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

typedef enum gs_encoding {
    GS_ENCODING_DEFAULT = 0, /* f64 */
    GS_ENCODING_F64,
    GS_ENCODING_F32,         /* half the bytes; ~1e-7 relative rounding */
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
    gs_weight_fn weight;   /* default gs_weight_exp at 1/s */
    void *weight_user;
    uint32_t owner;        /* owning host (probes); 0 = shared */
    double send_rate;      /* Hz of wall time; default 60 */
    gs_encoding encoding;  /* default f64 */
    int queue_size;        /* snapshots kept per peer; default 8. When full
                              the oldest goes (and is counted) */
    gs_catchup catchup;    /* default none */
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
} gs_ghost_desc;

GS_API gs_ghost_desc gs_ghost_desc_default(void);
/* Wraps an agent in a ghost. GS_ERR_INVALID_ARG for object id 0 or one
   already used in this world, a bad rate, encoding or queue size. */
GS_API gs_result gs_ghost_attach(gs_agent *a, const gs_ghost_desc *desc);
GS_API gs_result gs_ghost_detach(gs_agent *a);

/* Per ghost counters. */
typedef struct gs_ghost_stats {
    uint64_t blends;          /* blends that used at least one snapshot */
    uint64_t snapshots_blended;
    uint64_t queue_dropped;   /* snapshots pushed out of a full queue */
    uint64_t bad_weights;     /* weights that were negative, NaN or inf */
    double last_correction;   /* m (RMS over the state) the last blend moved */
} gs_ghost_stats;
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
   its owner puts it). On an error no ghost is left on the scene. */
GS_API gs_result gs_scene_attach_ghosts(gs_scene *sc, const gs_ghost_desc *shared);

/* ========================================================================
   >>wire
   Wire format v1, little-endian. A datagram (at most GS_WIRE_MAX_DATAGRAM
   bytes) is a header, whole chunks, and a CRC-32 of everything before it:
     header (48 B): magic "GSIM", version u8 = 1, flags u8, chunk count u16,
       session u32, sender host u32, datagram sequence u32, reserved u32,
       send time f64 (s, sender's clock), echo time f64 (the latest send time
       received from the destination), echo hold f64 (s it was held since)
     chunk (32 B + payload): object id u32, snapshot sequence u32,
       simulation time f64, chunk index u16, chunk count u16, first element
       u32 (of the state after its time), element count u16, encoding u8,
       reserved u8; then count values as f64 or f32.
   A snapshot too big for one datagram is cut into chunks that each stand
   alone: a lost chunk leaves its range unblended, the rest still counts.
   A chunk carries at most GS_WIRE_CHUNK_ROOM bytes of values, so that a
   datagram holding one chunk can always be sealed.

   Flags: bit 0 (GS_WIRE_FLAG_SEALED) says the datagram is sealed; every
   other bit is 0. A sealed datagram (sent when the net has a key, see
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
#define GS_WIRE_VERSION 1
#define GS_WIRE_MAX_DATAGRAM 1200
#define GS_WIRE_HEADER 48
#define GS_WIRE_CHUNK_HEADER 32
#define GS_WIRE_MAX_CHUNKS 64 /* chunks one datagram may carry */
#define GS_WIRE_FLAG_SEALED 0x01
#define GS_WIRE_KEY_BYTES 32
#define GS_WIRE_NONCE_BYTES 24
#define GS_WIRE_TAG_BYTES 16
#define GS_WIRE_SEAL_TRAILER (GS_WIRE_NONCE_BYTES + GS_WIRE_TAG_BYTES) /* 40 */
/* bytes of values in one chunk at most (1080: 135 f64 or 270 f32) */
#define GS_WIRE_CHUNK_ROOM (GS_WIRE_MAX_DATAGRAM - GS_WIRE_HEADER - \
                            GS_WIRE_CHUNK_HEADER - GS_WIRE_SEAL_TRAILER)

typedef struct gs_wire_header {
    uint32_t session, sender, sequence;
    double send_time, echo_time, echo_hold; /* s */
} gs_wire_header;

typedef struct gs_wire_chunk {
    uint32_t object_id, sequence;
    double time;                  /* s, the snapshot's simulation time */
    uint16_t index, count;        /* this chunk of how many */
    uint32_t first;               /* element of the state after the time */
    uint16_t elements;
    gs_encoding encoding;
    const unsigned char *payload; /* decode only: into the datagram */
} gs_wire_chunk;

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
    X(GS_REJECT_TIME, "simulation time negative, non-finite or off window")    \
    X(GS_REJECT_DUPLICATE, "a datagram already received")                      \
    X(GS_REJECT_ADDRESS,                                                       \
      "from an address other than the one registered for its sender")          \
    X(GS_REJECT_KEY, "in clear, but this net has a key: only sealed ones go")  \
    X(GS_REJECT_AUTH,                                                          \
      "authentication failed: forged, tampered or under another key")          \
    X(GS_REJECT_REPLAY,                                                        \
      "replayed: seen already, older than the replay window, or from an "      \
      "earlier run of its sender")                                             \
    X(GS_REJECT_RATE, "over the sender's cap of datagrams per second")

typedef enum gs_reject {
#define GS__REJECT_ENUM(name, text) name,
    GS__REJECT_LIST(GS__REJECT_ENUM)
#undef GS__REJECT_ENUM
    GS_REJECT_COUNT
} gs_reject;

GS_API const char *gs_reject_str(gs_reject r);

/* Starts a datagram in buf (cap >= GS_WIRE_HEADER + 4). */
GS_API gs_result gs_wire_begin(unsigned char *buf, size_t cap,
                               const gs_wire_header *h, size_t *size);
/* Appends a chunk of `c->elements` values. GS_ERR_CAPACITY if it does not
   fit in cap (leave room for the 4-byte checksum), GS_ERR_NOT_FINITE for a
   NaN or infinite value, or one beyond float range in f32 (never sent). */
GS_API gs_result gs_wire_add(unsigned char *buf, size_t cap, size_t *size,
                             const gs_wire_chunk *c, const double *values);
/* Writes the chunk count and the checksum; returns the datagram size. */
GS_API size_t gs_wire_end(unsigned char *buf, size_t size);
/* Checks everything that needs no knowledge of the objects: size, magic,
   version, flags, checksum, chunk layout, encodings, finite numbers and
   times. Returns 1 and fills *out, or 0 and *why. Datagrams in clear
   only: a sealed one fails the checksum here (its trailer is no CRC), or
   if the CRC matched by chance its flag is a GS_REJECT_LAYOUT; only a net
   with the key opens it. */
GS_API int gs_wire_decode(const unsigned char *buf, size_t size,
                          gs_wire_view *out, gs_reject *why);
/* Value i of a decoded chunk. */
GS_API double gs_wire_value(const gs_wire_chunk *c, int i);

/* ========================================================================
   >>net
   The network side of a world: peers, sending within a rate and a
   bandwidth budget, receiving through validation into the ghosts' queues.
   It rides on a transport: the simulated network, POSIX UDP, or yours.
   ======================================================================== */
typedef struct gs_net gs_net;

/* Sends one datagram to a peer host; it may be dropped on the way. */
typedef gs_result (*gs_send_fn)(void *user, uint32_t host, const void *data,
                                size_t size);

typedef struct gs_net_desc {
    uint32_t session;   /* datagrams of other sessions are refused; default 1 */
    gs_send_fn send;    /* required */
    void *send_user;
    double bandwidth;   /* bytes/s to each peer at most; default 1e7 */
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

/* Per peer statistics. */
typedef struct gs_peer_stats {
    uint64_t datagrams_sent, datagrams_received;
    uint64_t bytes_sent, bytes_received;
    uint64_t snapshots_sent, snapshots_received; /* chunks 0 of snapshots */
    uint64_t chunks_received;
    uint64_t lost;          /* datagrams missing from the sequence */
    uint64_t duplicates;
    uint64_t rejected[GS_REJECT_COUNT]; /* by reason */
    uint64_t rejected_total;
    double last_remote_time; /* s; newest simulation time received */
    double gap;              /* s; last_remote_time - local time then */
    double rtt;              /* s; latest round-trip estimate, 0 unknown */
    double divergence;       /* m; the largest over the objects of the RMS
                                distance between an object's local position
                                values and the peer's latest snapshot of it
                                (brought to local time when extrapolating) */
} gs_peer_stats;

GS_API gs_result gs_net_create(gs_world *w, const gs_net_desc *desc,
                               gs_net **out);
GS_API void gs_net_destroy(gs_net *net);
GS_API gs_result gs_net_add_peer(gs_net *net, uint32_t host);
GS_API gs_result gs_net_remove_peer(gs_net *net, uint32_t host);
/* Sends what is due at wall time `now` (s): each ghost's latest state at its
   rate, within each peer's bandwidth. */
GS_API gs_result gs_net_update(gs_net *net, double now);
/* Hands a received datagram to ghostsim. Returns GS_OK when it was queued,
   GS_ERR_REJECTED (reason in *why, may be NULL) when refused; refused
   datagrams are counted and never blended, and nothing is ever sent back.
   The checks, cheapest first: size, magic, version; without a key the CRC
   and the decode (as gs_wire_decode: a sealed datagram fails the CRC);
   the session and the sender (a peer: until here a refusal counts among
   the unknown ones, from here on the peer's); with a key, the seal flag
   (GS_REJECT_KEY if in clear), the replay window, then one authentication
   and decryption, then the decode; then the objects and ranges, the
   sequence (duplicates) and the peer's rate cap (max_rate: only datagrams
   that passed everything count against it, so forgeries cannot starve a
   peer).
   Memory: nothing is allocated here. A net is one fixed struct (12 KB; a
   gs_udp adds 4 KB and its socket's rcvbuf in the kernel), and each ghost
   keeps queue_size snapshots per peer (queue_size * (48 + 8 * state
   values + chunks) bytes, allocated when the ghost or the peer is added;
   a full queue drops its oldest), whatever arrives. */
GS_API gs_result gs_net_deliver(gs_net *net, const void *data, size_t size,
                                double now, gs_reject *why);
GS_API gs_result gs_net_peer_stats(const gs_net *net, uint32_t host,
                                   gs_peer_stats *out);
/* Datagrams refused before their sender was known (bad magic, checksum,
   unknown sender...), by reason. */
GS_API gs_result gs_net_unknown_stats(const gs_net *net,
                                      uint64_t rejected[GS_REJECT_COUNT]);
GS_API gs_net *gs_world_net(const gs_world *w);

/* Optional lock around the queues, for transports that deliver from another
   thread (the UDP gather thread sets it). */
typedef struct gs_net_lock {
    void (*lock)(void *user);
    void (*unlock)(void *user);
    void *user;
} gs_net_lock;
GS_API void gs_net_set_lock(gs_net *net, gs_net_lock lock);

/* ========================================================================
   >>simnet
   Several worlds in one process on a virtual clock. Each directed link has
   latency, jitter, loss, duplication, reordering, a bandwidth cap and outage
   windows, all drawn from one seed: the same seed gives the same run.
   ======================================================================== */
typedef struct gs_simnet gs_simnet;

#define GS_MAX_OUTAGES 4
typedef struct gs_link_desc {
    double latency;    /* s, one way */
    double jitter;     /* s; uniform in [0, jitter] added */
    double loss;       /* probability a datagram is lost */
    double duplicate;  /* probability it arrives twice */
    double reorder;    /* probability it is held back by up to a latency */
    double bandwidth;  /* bytes/s; 0 = unlimited */
    double outage_start[GS_MAX_OUTAGES]; /* s of virtual time; the link is */
    double outage_end[GS_MAX_OUTAGES];   /* cut in [start, end) */
} gs_link_desc;

typedef struct gs_simnet_desc {
    uint64_t seed;        /* default 1 */
    int max_in_flight;    /* datagrams on the wire at once; default 16384 */
    gs_allocator allocator;
} gs_simnet_desc;

GS_API gs_result gs_simnet_create(const gs_simnet_desc *desc, gs_simnet **out);
/* Destroys the simnet (not the worlds or their nets). */
GS_API void gs_simnet_destroy(gs_simnet *sim);
/* Joins a world: creates its net on the simnet's transport (desc.send is
   ignored) and links it both ways to every world joined so far with a
   perfect link. */
GS_API gs_result gs_simnet_join(gs_simnet *sim, gs_world *w,
                                const gs_net_desc *desc, gs_net **out);
/* Sets the link from host a to host b (one direction). */
GS_API gs_result gs_simnet_link(gs_simnet *sim, uint32_t a, uint32_t b,
                                const gs_link_desc *desc);
/* Runs every world for `seconds` of virtual time in frames of `frame`
   seconds: each frame advances each world, sends what is due and delivers
   what has arrived. */
GS_API gs_result gs_simnet_run(gs_simnet *sim, double seconds, double frame);
GS_API double gs_simnet_time(const gs_simnet *sim);
/* Datagrams the simnet dropped (loss, outage, full), duplicated, delivered. */
GS_API void gs_simnet_counts(const gs_simnet *sim, uint64_t *dropped,
                             uint64_t *duplicated, uint64_t *delivered);

/* ========================================================================
   >>udp
   POSIX UDP (left out by GHOSTSIM_NO_UDP): the paper's gather thread
   (receive, validate, queue) and scatter thread (send what is due), or
   no threads at all: call gs_udp_poll from your loop.
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
    const char *bind;      /* "HOST:PORT", "[v6]:PORT"; required */
    int threads;           /* 1: gather and scatter threads; 0: poll mode */
    int rcvbuf;            /* bytes; default 4 MiB */
    gs_net_desc net;       /* session, bandwidth...; send is ignored */
} gs_udp_desc;

GS_API gs_result gs_udp_open(gs_world *w, const gs_udp_desc *desc,
                             gs_udp **out);
/* Joins the threads, closes the socket, frees everything. */
GS_API void gs_udp_close(gs_udp *u);
GS_API gs_net *gs_udp_net(gs_udp *u);
/* Adds or replaces a peer's address ("HOST:PORT", IPv4 or IPv6): from
   then on, datagrams that name this host as their sender are taken from
   this address only. */
GS_API gs_result gs_udp_add_peer(gs_udp *u, uint32_t host, const char *addr);
GS_API gs_result gs_udp_remove_peer(gs_udp *u, uint32_t host);
/* Poll mode: receives every waiting datagram and sends what is due at wall
   time now. In thread mode it only wakes the scatter thread. */
GS_API gs_result gs_udp_poll(gs_udp *u, double now);
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
#else
#define GS__PRIVATE static
#define GS__PRINTF(f, a)
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
};

struct gs_world {
    gs_allocator alloc;
    uint32_t host_id;
    int queue_count;
    double tolerance;
    int aging_limit;
    double budget;
    gs_vec3 gravity;
    gs_clock_fn clock;
    void *clock_user;
    double target;       /* s */
    int busy;            /* inside gs_world_advance */
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
                                  sorted by the low end of their sweep on x
                                  (the order contacts are summed in) */
    int nbodies, bodies_cap;
    struct gs__rigid **near;   /* the same sorted by x - bound (searched) */
    struct gs__rigid **wide;   /* bodies with a sweep over wide_at */
    int nwide;
    struct gs__rigid **cand;   /* the answer to a query (bodies_cap) */
    struct gs__rigid **grid;   /* a uniform grid of the bodies not wide:
                                  2 * bodies_cap hashed cells */
    double cell;         /* m; its cell size, 0 when unused */
    double wide_at;      /* m; a sweep over this makes a body wide */
    double bound_max;    /* m; the largest bound of a body not wide */
    double speed_max;    /* m/s; the largest speed of a body not wide (not
                            a probe: contacts do not carry those on) */
    int nmeshes;         /* spring-mass agents (contacts loop over them) */
    int ground;          /* a plane y = ground_height */
    double ground_height;
    gs_material ground_material;
    gs__queue queues[GS_MAX_QUEUES];
    char error[256];
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

GS_API gs_world_desc gs_world_desc_default(void) {
    gs_world_desc d;
    memset(&d, 0, sizeof d);
    d.host_id = 1;
    d.queue_count = 8;
    d.tolerance = 0.01;
    d.aging_limit = 64;
    d.gravity = gs__v3(0.0, -9.81, 0.0);
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
    return d;
}

GS__PRIVATE gs_result gs__world_check(const gs_world_desc *d) {
    gs__check c = gs__check_begin(NULL, "gs_world_create");
    gs__check_int(&c, "queue_count", d->queue_count, 1, GS_MAX_QUEUES);
    gs__check_nonneg(&c, "tolerance", d->tolerance);
    gs__check_int(&c, "aging_limit", d->aging_limit, 1, 1L << 30);
    gs__check_nonneg(&c, "budget", d->budget);
    gs__check_vec(&c, "gravity", d->gravity);
    if (!d->allocator.alloc != !d->allocator.free)
        gs__check_fail(&c, GS_ERR_INVALID_ARG,
                       "allocator needs both alloc and free, or neither");
    return c.r;
}

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
    w->gravity = d.gravity;
    w->clock = d.clock ? d.clock : gs__default_clock;
    w->clock_user = d.clock ? d.clock_user : NULL;
    *out = w;
    return GS_OK;
}

struct gs__ghost;
GS__PRIVATE void gs__ghost_free(struct gs__ghost *g);

GS_API void gs_world_destroy(gs_world *w) {
    int i;
    if (!w) return;
    GS_ASSERT(!w->busy && "gs_world_destroy inside gs_world_advance");
    gs_net_destroy(w->net);
    for (i = 0; i < w->agent_count; ++i) {
        if (w->agents[i]->ghost) gs__ghost_free((struct gs__ghost *)w->agents[i]->ghost);
        gs__free(w, w->agents[i]);
    }
    gs__free(w, w->agents);
    gs__free(w, w->span_lo);
    gs__free(w, w->bodies);
    w->alloc.free(w, w->alloc.user);
}

/* Adds a new agent to the world's list, growing it as needed (create time
   only: the step loop never allocates). */
GS__PRIVATE gs_result gs__world_add(gs_world *w, gs_agent *a) {
    if (w->agent_count == w->agent_cap) {
        int cap = w->agent_cap ? 2 * w->agent_cap : 8;
        gs_agent **list = (gs_agent **)gs__alloc(w, (size_t)cap * sizeof *list);
        gs_agent **heaps = (gs_agent **)gs__alloc(w, 2 * (size_t)cap * sizeof *heaps);
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
        w->agent_cap = cap;
    }
    a->index = w->agent_count;
    w->agents[w->agent_count++] = a;
    return GS_OK;
}

GS_API double gs_world_time(const gs_world *w) { return w->target; }
GS_API const char *gs_world_error(const gs_world *w) { return w->error; }
GS_API uint32_t gs_world_host_id(const gs_world *w) { return w->host_id; }
GS_API int gs_world_agent_count(const gs_world *w) { return w->agent_count; }

GS_API gs_agent *gs_world_agent(const gs_world *w, int i) {
    return (i >= 0 && i < w->agent_count) ? w->agents[i] : NULL;
}

GS_API gs_vec3 gs_world_gravity(const gs_world *w) { return w->gravity; }

GS_API gs_result gs_world_set_gravity(gs_world *w, gs_vec3 g) {
    if (!gs__finite3(g))
        return gs__fail(w, GS_ERR_NOT_FINITE,
                        "gs_world_set_gravity: gravity must be finite");
    w->gravity = g;
    return GS_OK;
}

GS_API gs_result gs_world_set_budget(gs_world *w, double seconds) {
    gs__check c = gs__check_begin(w, "gs_world_set_budget");
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
   change of a time, where a scan at every dispatch made a frame O(n^2).
   They hold exactly the agents gs__time_span counts (the ones not failed)
   and each one's time as gs__agent_time computes it, so the span is the
   same, bit for bit. ---- */
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
        if (a->failed) continue;
        a->span_t = gs__agent_time(a);
        gs__span_put(w->span_lo, w->span_n, a, 0);
        gs__span_put(w->span_hi, w->span_n, a, 1);
        w->span_n++;
    }
    for (hi = 0; hi < 2; ++hi)
        for (i = w->span_n / 2 - 1; i >= 0; --i) gs__span_down(w, hi, i);
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

/* A failed agent leaves the span. */
GS__PRIVATE void gs__span_remove(gs_agent *a) {
    gs_world *w = a->world;
    int hi;
    if (a->span_lo < 0) return;
    gs__span_failed(a);
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

/* The span from the heaps: what gs__time_span would find. */
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

/* Slowest and fastest simulation time of the agents still live. */
GS__PRIVATE void gs__time_span(const gs_world *w, double *t_min,
                               double *t_max) {
    double lo = HUGE_VAL, hi = -HUGE_VAL;
    int i;
    for (i = 0; i < w->agent_count; ++i) {
        const gs_agent *a = w->agents[i];
        double t;
        if (a->failed) continue;
        t = gs__agent_time(a);
        if (t < lo) lo = t;
        if (t > hi) hi = t;
    }
    if (lo > hi) lo = hi = w->target;
    *t_min = lo;
    *t_max = hi;
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

GS__PRIVATE void gs__ghost_after_step(gs_agent *a);
GS__PRIVATE void gs__world_blend(gs_world *w);

/* One step; then the agent's ghost, if any, publishes and blends. */
GS__PRIVATE gs_result gs__agent_step(gs_agent *a) {
    gs_result r = a->kind->step(a, a->dt);
    a->result = r;
    if (r == GS_OK) {
        a->steps++;
        a->stats.steps++;
        if (a->ghost) gs__ghost_after_step(a);
    }
    return r;
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
    gs__span_update(a);
    if (r != GS_OK) {
        a->failed = 1;
        gs__span_remove(a);
        rep->failed_agents++;
        if (*first_error == GS_OK) *first_error = r;
        return 1;
    }
    rep->steps++;
    if (!gs__agent_done(a)) gs__queue_push(w, a);
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
GS__PRIVATE void gs__world_follow(gs_world *w) {
    double dt_max = 0.0;
    int i;
    for (i = 0; i < w->agent_count; ++i) {
        w->agents[i]->failed = 0;
        if (w->agents[i]->dt > dt_max) dt_max = w->agents[i]->dt;
    }
    if (w->agent_count == 0) return;
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
        if (2 * leading > w->agent_count) {
            w->target = lead_min;
            /* an agent left more than GS__FOLLOW_STEPS of its steps behind
               takes the clock's time instead: a time from the network (a
               late joiner an hour on, a datagram that says 1e6 s) must not
               buy a step per dt of catching up */
            for (i = 0; i < w->agent_count; ++i) {
                gs_agent *a = w->agents[i];
                double lag = w->target - gs__agent_time(a);
                if (lag > GS__FOLLOW_STEPS * a->dt) a->t_offset += lag;
            }
        }
    }
}

GS_API gs_result gs_world_advance(gs_world *w, double seconds,
                                  gs_advance_report *report) {
    gs_advance_report rep;
    gs_result first_error = GS_OK;
    double start = 0.0;
    memset(&rep, 0, sizeof rep);
    if (w->busy)
        return gs__fail(w, GS_ERR_BUSY, "gs_world_advance: already advancing");
    if (!gs__finite(seconds) || seconds < 0.0)
        return gs__fail(w, gs__finite(seconds) ? GS_ERR_INVALID_ARG
                                               : GS_ERR_NOT_FINITE,
                        "gs_world_advance: seconds is %g, must be finite and "
                        ">= 0", seconds);
    w->busy = 1;
    gs__world_follow(w);
    w->target += seconds;
    gs__sap_refresh(w);
    if (w->budget > 0.0) start = w->clock(w->clock_user);
    gs__queue_all(w);
    gs__span_build(w);
    rep.reached = 1;
    for (;;) {
        if (w->budget > 0.0 && w->clock(w->clock_user) - start >= w->budget) {
            rep.reached = 0;
            break;
        }
        if (!gs__dispatch(w, &first_error, &rep)) break;
    }
    if (rep.failed_agents) rep.reached = 0;
    gs__unqueue_all(w);
    rep.target = w->target;
    gs__time_span(w, &rep.t_min, &rep.t_max);
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
    return d;
}

GS__PRIVATE void gs__check_solver(gs__check *c, const gs_solver_desc *d) {
    gs__check_positive(c, "solver.dt", d->dt);
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
GS_API gs_agent_stats gs_agent_get_stats(const gs_agent *a) {
    return a->stats;
}

GS_API size_t gs_agent_state_size(const gs_agent *a) {
    return 1 + a->kind->state_size(a);
}

GS_API gs_result gs_agent_get_state(const gs_agent *a, double *out,
                                    size_t n) {
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
    a->t_offset = in[0] - (double)a->steps * a->dt;
    gs__span_update(a);
    return GS_OK;
}

GS_API gs_result gs_agent_set_state(gs_agent *a, const double *in, size_t n) {
    size_t i;
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
    return gs__agent_put_state(a, in);
}

GS_API gs_result gs_agent_step(gs_agent *a) {
    if (a->world->busy)
        return gs__fail(a->world, GS_ERR_BUSY,
                        "gs_agent_step: the world is advancing");
    return gs__agent_step(a);
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
    gs_world *w = a->world;
    int i;
    if (w->busy)
        return gs__fail(w, GS_ERR_BUSY,
                        "gs_agent_destroy: the world is advancing");
    if (a->ghost) gs_ghost_detach(a);
    gs__agent_unlink(a);
    for (i = a->index + 1; i < w->agent_count; ++i) {
        w->agents[i - 1] = w->agents[i];
        w->agents[i - 1]->index = i - 1;
    }
    w->agent_count--;
    gs__free(w, a);
    return GS_OK;
}

/* ---- custom agents: the user's own state behind the same interface ---- */
typedef struct gs__custom {
    gs_agent base;
    gs_custom_desc d;
    double *scratch; /* state_size doubles, for hashing */
} gs__custom;

GS__PRIVATE gs_result gs__custom_step(gs_agent *a, double dt) {
    gs__custom *c = (gs__custom *)a;
    return c->d.step(c->d.user, gs__agent_time(a), dt);
}
GS__PRIVATE size_t gs__custom_state_size(const gs_agent *a) {
    return ((const gs__custom *)a)->d.state_size;
}
GS__PRIVATE void gs__custom_get_state(const gs_agent *a, double *out) {
    const gs__custom *c = (const gs__custom *)a;
    if (c->d.state_size) c->d.get_state(c->d.user, out);
}
GS__PRIVATE gs_result gs__custom_set_state(gs_agent *a, const double *in) {
    gs__custom *c = (gs__custom *)a;
    return c->d.state_size ? c->d.set_state(c->d.user, in) : GS_OK;
}
/* Hashes the user's state through a scratch copy made at create time. */
GS__PRIVATE uint64_t gs__custom_hash(const gs_agent *a, uint64_t h) {
    const gs__custom *c = (const gs__custom *)a;
    if (c->d.state_size == 0) return h;
    c->d.get_state(c->d.user, c->scratch);
    return gs__fnv(h, c->scratch, c->d.state_size * sizeof(double));
}

static const gs__kind gs__custom_kind = {
    "custom", gs__custom_step, gs__custom_state_size, gs__custom_get_state,
    gs__custom_set_state, gs__custom_hash, NULL, NULL};

GS__PRIVATE gs_result gs__world_unlocked(gs_world *w, const char *who) {
    if (!w) return GS_ERR_INVALID_ARG;
    if (w->busy)
        return gs__fail(w, GS_ERR_BUSY, "%s: the world is advancing", who);
    return GS_OK;
}

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

GS_API gs_result gs_custom_create(gs_world *w, const gs_custom_desc *desc,
                                  gs_agent **out) {
    gs__check c;
    gs__custom *a;
    gs_result r = gs__create_begin(w, desc, out, "gs_custom_create");
    if (r != GS_OK) return r;
    c = gs__check_begin(w, "gs_custom_create");
    gs__check_positive(&c, "dt", desc->dt);
    if (!desc->step) gs__check_fail(&c, GS_ERR_INVALID_ARG, "step is NULL");
    if (desc->state_size && (!desc->get_state || !desc->set_state))
        gs__check_fail(&c, GS_ERR_INVALID_ARG,
                       "state_size is %lu but get_state or set_state is NULL",
                       (unsigned long)desc->state_size);
    if (c.r != GS_OK) return c.r;
    a = (gs__custom *)gs__alloc(w, sizeof *a + desc->state_size *
                                                      sizeof(double));
    if (!a)
        return gs__fail(w, GS_ERR_NO_MEMORY, "gs_custom_create: out of memory");
    r = gs__agent_init(w, &a->base, &gs__custom_kind, desc->dt);
    if (r != GS_OK) {
        gs__free(w, a);
        return r;
    }
    a->d = *desc;
    a->scratch = (double *)(a + 1);
    *out = &a->base;
    return GS_OK;
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

typedef struct gs__mesh {
    gs_agent base;
    int n, ns, npins;
    gs_vec3 *x, *v;   /* the state */
    gs_vec3 *xn, *vn; /* the next state */
    gs_vec3 *x0, *v0; /* the state before a substepped step, to undo it */
    gs_vec3 *acc;     /* accelerations */
    gs_vec3 *tx, *tv, *sx, *sv; /* RK4 stages, Verlet half-step velocity */
    double *mass, *inv_mass; /* kg, 1/kg (0 for pinned particles) */
    gs__spring *springs;
    int *pins;
    unsigned char *pinned;
    double air;       /* 1/s */
    gs_solver_desc solver;
    double stable_dt; /* s; the explicit integrator's bound */
    double stable_dt_contact; /* s; the same with a contact on every particle */
    /* contacts */
    gs_vec3 *ext;     /* N; contact force on each particle this substep */
    gs_vec3 *cn;      /* implicit Euler: contact normal per particle, */
    double *ck, *cc;  /* its stiffness (N/m) and damping (N s/m), 0 = none */
    int ext_active;   /* ext holds a non-zero force */
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

GS__PRIVATE void *gs__carve(gs__carver *cv, size_t bytes) {
    void *p = cv->base ? (void *)(cv->base + cv->used) : NULL;
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
    m->ext = (gs_vec3 *)gs__carve(cv, v3);
    m->mass = (double *)gs__carve(cv, n * sizeof(double));
    m->inv_mass = (double *)gs__carve(cv, n * sizeof(double));
    m->springs = (gs__spring *)gs__carve(cv, (size_t)m->ns * sizeof(gs__spring));
    m->pins = (int *)gs__carve(cv, (size_t)m->npins * sizeof(int));
    m->pinned = (unsigned char *)gs__carve(cv, n);
    if (it != GS_INTEGRATOR_IMPLICIT_EULER &&
        m->solver.stability != GS_STABILITY_UNCHECKED) {
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
    if (it == GS_INTEGRATOR_IMPLICIT_EULER) {
        m->jac = (double *)gs__carve(cv, (size_t)m->ns * 6 * sizeof(double));
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
    for (i = 0; i < m->ns; ++i) {
        const gs__spring *s = &m->springs[i];
        gs_vec3 d = gs__sub(x[s->b], x[s->a]), u, fv;
        double l = gs__len(d), f;
        if (!(l > 0.0)) continue; /* coincident ends: no direction */
        u = gs__scale(d, 1.0 / l);
        f = s->k * (l - s->rest) + s->c * gs__dot(gs__sub(v[s->b], v[s->a]), u);
        fv = gs__scale(u, f);
        acc[s->a] = gs__madd(acc[s->a], fv, im[s->a]);
        acc[s->b] = gs__madd(acc[s->b], fv, -im[s->b]);
    }
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

GS__PRIVATE void gs__int_symplectic_euler(gs__mesh *m, double h) {
    int i;
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

/* ---- stepping ---- */

/* Finite positions and no particle faster than max_speed: anything else
   means the step blew up. */
GS__PRIVATE int gs__mesh_sane(const gs__mesh *m) {
    double vmax2 = m->solver.max_speed * m->solver.max_speed, sum = 0.0;
    int i;
    for (i = 0; i < m->n; ++i) {
        if (!(gs__dot(m->vn[i], m->vn[i]) <= vmax2)) return 0;
        sum += m->xn[i].x + m->xn[i].y + m->xn[i].z;
    }
    return gs__finite(sum);
}

GS__PRIVATE void gs__mesh_contacts(gs__mesh *m, double t);
GS__PRIVATE void gs__mesh_update_bounds(gs__mesh *m);

/* One integrator step of h seconds starting at simulation time t0. */
GS__PRIVATE gs_result gs__mesh_substep(gs__mesh *m, double t0, double h) {
    gs_vec3 *t;
    int i;
    gs__mesh_contacts(m, t0);
    switch (m->solver.integrator) {
    case GS_INTEGRATOR_EXPLICIT_EULER: gs__int_explicit_euler(m, h); break;
    case GS_INTEGRATOR_VERLET: gs__int_verlet(m, h); break;
    case GS_INTEGRATOR_RK4: gs__int_rk4(m, h); break;
    case GS_INTEGRATOR_IMPLICIT_EULER: gs__int_implicit_euler(m, h); break;
    default: gs__int_symplectic_euler(m, h); break;
    }
    for (i = 0; i < m->npins; ++i) {
        m->xn[m->pins[i]] = m->x[m->pins[i]];
        m->vn[m->pins[i]] = gs__v3(0.0, 0.0, 0.0);
    }
    if (!gs__mesh_sane(m))
        return gs__fail(m->base.world, GS_ERR_UNSTABLE,
                        "%s agent %d: a step of %g s blew up (non-finite "
                        "state or a speed over %g m/s); state kept",
                        m->base.kind->name, m->base.index, h,
                        m->solver.max_speed);
    t = m->x; m->x = m->xn; m->xn = t;
    t = m->v; m->v = m->vn; m->vn = t;
    gs__mesh_update_bounds(m);
    return GS_OK;
}

/* How many substeps a step of dt needs to stay under the stability bound. */
GS__PRIVATE int gs__world_has_contacts(const gs_world *w);

GS__PRIVATE gs_result gs__mesh_plan(gs__mesh *m, double dt, int *n_sub) {
    double lim = (gs__world_has_contacts(m->base.world) ? m->stable_dt_contact
                                                        : m->stable_dt) *
                 m->solver.safety, k;
    *n_sub = 1;
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

GS__PRIVATE gs_result gs__mesh_step(gs_agent *a, double dt) {
    gs__mesh *m = (gs__mesh *)a;
    size_t bytes = (size_t)m->n * sizeof(gs_vec3);
    int n_sub, i;
    gs_result r = gs__mesh_plan(m, dt, &n_sub);
    if (r != GS_OK) return r;
    if (n_sub > 1) {
        memcpy(m->x0, m->x, bytes);
        memcpy(m->v0, m->v, bytes);
    }
    for (i = 0; i < n_sub; ++i) {
        r = gs__mesh_substep(m, gs__agent_time(a) + i * (dt / n_sub), dt / n_sub);
        if (r == GS_OK) continue;
        if (i > 0) {
            memcpy(m->x, m->x0, bytes);
            memcpy(m->v, m->v0, bytes);
            gs__mesh_update_bounds(m); /* the broad phase must see the undone state */
        }
        return r;
    }
    a->stats.substeps += (uint64_t)n_sub;
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

/* Dead reckoning: positions move along the velocities that follow them. */
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
    for (i = 0; i < m->n; ++i) m->acc[i] = gs__v3(contact_k, contact_c, 0.0);
    for (i = 0; i < m->ns; ++i) { /* acc as scratch: x = sum k, y = sum c */
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
    r = gs__agent_init(w, &m->base, kind, solver->dt);
    if (r != GS_OK) {
        gs__free(w, m);
        return r;
    }
    w->nmeshes++;
    *out = m;
    return GS_OK;
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
    for (i = 0; i < m->n; ++i) {
        m->inv_mass[i] = m->pinned[i] ? 0.0 : 1.0 / m->mass[i];
        if (m->pinned[i]) m->v[i] = gs__v3(0.0, 0.0, 0.0);
    }
    m->stable_dt = gs__mesh_bound(m, 0.0, 0.0);
    m->stable_dt_contact = gs__mesh_bound(m, m->mat.stiffness, m->mat.damping);
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
        if (d->velocities && !gs__finite3(d->velocities[i]))
            gs__check_item(c, GS_ERR_NOT_FINITE, "velocities", i, "", NAN,
                           "must be finite");
        if (d->masses && !gs__finite(d->masses[i]))
            gs__check_item(c, GS_ERR_NOT_FINITE, "masses", i, "", d->masses[i],
                           "must be finite");
        if (d->masses && gs__finite(d->masses[i]) && d->masses[i] <= 0.0)
            gs__check_item(c, GS_ERR_INVALID_ARG, "masses", i, "", d->masses[i],
                           "must be > 0");
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

GS__PRIVATE gs_result gs__mesh_check(gs_world *w, const gs_mesh_desc *d) {
    gs__check c = gs__check_begin(w, "gs_mesh_create");
    gs__check_mesh_particles(&c, d);
    gs__check_positive(&c, "mass", d->mass);
    gs__check_int(&c, "spring_count", d->spring_count, 0, 1L << 26);
    if (c.r == GS_OK) gs__check_mesh_springs(&c, d);
    if (c.r == GS_OK) gs__check_pins(&c, d->pins, d->pin_count, d->particle_count);
    gs__check_nonneg(&c, "air_damping", d->air_damping);
    gs__check_positive(&c, "particle_radius", d->particle_radius);
    gs__check_material(&c, &d->material);
    gs__check_solver(&c, &d->solver);
    return c.r;
}

GS_API gs_result gs_mesh_create(gs_world *w, const gs_mesh_desc *desc,
                                gs_agent **out) {
    gs_mesh_desc d;
    gs__mesh *m;
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
    *out = &m->base;
    return GS_OK;
}

/* ---- the cloth generator ---- */
GS_API gs_cloth_desc gs_cloth_desc_default(void) {
    gs_cloth_desc d;
    memset(&d, 0, sizeof d);
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
    gs__check_positive(&c, "width", d->width);
    gs__check_positive(&c, "height", d->height);
    gs__check_vec(&c, "origin", d->origin);
    gs__check_axes(&c, d->axis_u, d->axis_v);
    gs__check_positive(&c, "mass", d->mass);
    gs__check_int(&c, "springs", d->springs, 1, 7);
    gs__check_positive(&c, "stretch_stiffness", d->stretch_stiffness);
    gs__check_positive(&c, "shear_stiffness", d->shear_stiffness);
    gs__check_positive(&c, "bend_stiffness", d->bend_stiffness);
    gs__check_nonneg(&c, "spring_damping", d->spring_damping);
    gs__check_nonneg(&c, "air_damping", d->air_damping);
    gs__check_int(&c, "pin_corners", d->pin_corners, 0, GS_CORNER_ALL);
    if (c.r == GS_OK) gs__check_pins(&c, d->pins, d->pin_count, d->nx * d->ny);
    gs__check_positive(&c, "particle_radius", d->particle_radius);
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

/* Springs from every particle to the one (di, dj) away, where it exists. */
GS__PRIVATE int gs__cloth_link(gs__mesh *m, int k, int nx, int ny, int di,
                               int dj, double stiffness, double damping) {
    int i, j;
    for (j = 0; j < ny; ++j)
        for (i = 0; i < nx; ++i) {
            gs__spring *s;
            if (i + di < 0 || i + di >= nx || j + dj >= ny) continue;
            s = &m->springs[k++];
            s->a = i + nx * j;
            s->b = (i + di) + nx * (j + dj);
            s->rest = 0.0; /* the distance at creation */
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
    if (d->springs & GS_SPRINGS_STRUCTURAL) {
        k = gs__cloth_link(m, k, d->nx, d->ny, 1, 0, d->stretch_stiffness, c);
        k = gs__cloth_link(m, k, d->nx, d->ny, 0, 1, d->stretch_stiffness, c);
    }
    if (d->springs & GS_SPRINGS_SHEAR) {
        k = gs__cloth_link(m, k, d->nx, d->ny, 1, 1, d->shear_stiffness, c);
        k = gs__cloth_link(m, k, d->nx, d->ny, -1, 1, d->shear_stiffness, c);
    }
    if (d->springs & GS_SPRINGS_BEND) {
        k = gs__cloth_link(m, k, d->nx, d->ny, 2, 0, d->bend_stiffness, c);
        k = gs__cloth_link(m, k, d->nx, d->ny, 0, 2, d->bend_stiffness, c);
    }
    GS_ASSERT(k == m->ns);
    m->air = d->air_damping;
    m->radius = d->particle_radius;
    m->mat = d->material;
}

GS_API gs_result gs_cloth_create(gs_world *w, const gs_cloth_desc *desc,
                                 gs_agent **out) {
    gs_cloth_desc d;
    gs__mesh *m;
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
    for (corner = 0; corner < 4; ++corner)
        if (d.pin_corners & (1 << corner))
            pins[npins++] = (corner & 1 ? d.nx - 1 : 0) +
                            d.nx * (corner & 2 ? d.ny - 1 : 0);
    /* corners first, then the user's pins; duplicates merge */
    gs__mesh_finish(m, pins, npins);
    if (d.pin_count > 0) {
        int i;
        for (i = 0; i < d.pin_count; ++i)
            if (!m->pinned[d.pins[i]]) {
                m->pinned[d.pins[i]] = 1;
                m->pins[m->npins++] = d.pins[i];
                m->inv_mass[d.pins[i]] = 0.0;
            }
        m->stable_dt = gs__mesh_bound(m, 0.0, 0.0);
        m->stable_dt_contact = gs__mesh_bound(m, m->mat.stiffness, m->mat.damping);
    }
    *out = &m->base;
    return GS_OK;
}

/* ---- accessors ---- */
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
    if (!a) return GS_ERR_INVALID_ARG;
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
    m->x[particle] = pos;
    gs__mesh_update_bounds(m);
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

GS__PRIVATE gs_quat gs__quat_normalize(gs_quat q) {
    double n = sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
    if (!(n > 0.0)) return gs__quat(0.0, 0.0, 0.0, 1.0);
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
    gs_vec3 v[GS_MAX_HULL_POINTS];
    gs_vec3 fn[2 * GS_MAX_HULL_POINTS];
    double fd[2 * GS_MAX_HULL_POINTS];
    double bound;       /* m; radius of a sphere about the origin holding it */
    double size;        /* m; its smallest extent */
    double volume;      /* m^3 */
    gs__sym3 inertia;   /* about the origin, for density 1 */
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

/* Validates a shape desc and builds the collision shape. */
GS__PRIVATE void gs__shape_build(gs__check *c, const gs_shape_desc *d,
                                 gs__shape *s) {
    int i;
    memset(s, 0, sizeof *s);
    s->type = d->type;
    if (d->type == GS_SHAPE_SPHERE) {
        gs__check_positive(c, "shape.radius", d->radius);
        if (c->r != GS_OK) return;
        s->radius = s->bound = d->radius;
        s->size = 2.0 * d->radius;
        s->volume = 4.0 / 3.0 * 3.14159265358979323846 * pow(d->radius, 3.0);
        s->inertia.xx = s->inertia.yy = s->inertia.zz =
            0.4 * s->volume * d->radius * d->radius;
    } else if (d->type == GS_SHAPE_BOX) {
        gs__check_positive(c, "shape.half_extents.x", d->half_extents.x);
        gs__check_positive(c, "shape.half_extents.y", d->half_extents.y);
        gs__check_positive(c, "shape.half_extents.z", d->half_extents.z);
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

typedef struct gs__rigid {
    gs_agent base;
    gs__shape shape;
    int probe;                 /* kinematic: moved by the application */
    double mass, inv_mass;     /* kg, 1/kg (0 for a probe) */
    gs__sym3 inertia_body, inv_inertia_body;
    gs_vec3 x, v, w;           /* m, m/s, rad/s (world) */
    gs_vec3 v_prev, w_prev;    /* at the start of the last step */
    int sap;                   /* index in world->bodies */
    int near;                  /* index in world->near */
    int wide;                  /* index in world->wide, -1 if not wide */
    double speed;              /* m/s, |v| when the broad phase last saw it
                                  (0 for a probe) */
    double near_key;           /* m; x - bound, the sort key of near */
    int64_t cell[3];           /* its cell in world->grid, if in_grid */
    int in_grid;
    struct gs__rigid *gnext, *gprev; /* in its grid bucket */
    double sweep;              /* m; half-width on x: bound + 0.1 s of travel
                                  (contacts look up to 0.1 s ahead or back) */
    double key;                /* m; x - sweep, the sort key */
    gs_quat q;
    gs_vec3 force, torque;     /* contact sums for the current substep */
    double k_sum, c_sum;       /* N/m, N s/m of the contacts touching it */
    double reach2;             /* 1/kg: 1/m + bound^2 / smallest inertia,
                                  how hard a contact at the surface moves it */
    gs_material mat;
    gs_solver_desc solver;
    int continuous;
    double stable_dt;          /* s; contact spring-damper bound */
    double rolling;            /* m; rolling resistance lever arm */
    double i_min;              /* kg m^2; smallest principal inertia */
    gs_vec3 target;            /* probe */
    gs_quat target_q;
    double max_speed;          /* probe, m/s */
    uint32_t owner;
} gs__rigid;

GS__PRIVATE gs_result gs__sap_add(gs_world *w, gs__rigid *r);
GS__PRIVATE void gs__sap_update(gs__rigid *r);
GS__PRIVATE void gs__sap_remove(gs_world *w, gs__rigid *r);

GS__PRIVATE gs__rigid *gs__as_rigid(const gs_agent *a);

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
    gs__check_vec(c, "position", d->position);
    gs__check_quat(c, "orientation", d->orientation);
    gs__check_vec(c, "velocity", d->velocity);
    gs__check_vec(c, "angular_velocity", d->angular_velocity);
    gs__check_material(c, &d->material);
    gs__check_nonneg(c, "rolling", d->rolling);
    gs__check_solver(c, &d->solver);
    if (c->r == GS_OK && d->solver.integrator == GS_INTEGRATOR_IMPLICIT_EULER)
        gs__check_fail(c, GS_ERR_INVALID_ARG,
                       "solver.integrator: implicit Euler is for spring-mass "
                       "agents; rigid bodies substep under stiff contact");
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

GS__PRIVATE void gs__rigid_contacts(gs__rigid *r, double t);

/* The stable step under the contacts found now: a spring-damper with the
   summed stiffness and damping acting on 1 / reach2 kg (gs__mesh_bound's
   rule with omega^2 = k reach2, gamma = c reach2). */
GS__PRIVATE double gs__rigid_bound(const gs__rigid *r) {
    double w2 = r->k_sum * r->reach2, g = r->c_sum * r->reach2;
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

GS__PRIVATE int gs__rigid_sane(const gs__rigid *r) {
    double vmax = r->solver.max_speed;
    return gs__finite3(r->x) && gs__finite(r->q.x + r->q.y + r->q.z + r->q.w) &&
           gs__dot(r->v, r->v) <= vmax * vmax &&
           gs__dot(r->w, r->w) * r->shape.bound * r->shape.bound <= vmax * vmax;
}

GS__PRIVATE gs_result gs__rigid_step(gs_agent *a, double dt) {
    gs__rigid *r = (gs__rigid *)a;
    gs_vec3 x0 = r->x, v0 = r->v, w0 = r->w;
    gs_quat q0 = r->q;
    int n_sub, i;
    gs_result res;
    r->v_prev = v0;
    r->w_prev = w0;
    gs__rigid_contacts(r, gs__agent_time(a));
    res = gs__rigid_plan(r, dt, &n_sub);
    if (res != GS_OK) return res;
    for (i = 0; i < n_sub; ++i) {
        if (i > 0) gs__rigid_contacts(r, gs__agent_time(a) + i * (dt / n_sub));
        gs__rigid_integrate(r, dt / n_sub);
        if (gs__rigid_sane(r)) continue;
        r->x = x0; r->v = v0; r->w = w0; r->q = q0;
        r->v_prev = v0; r->w_prev = w0;
        return gs__fail(a->world, GS_ERR_UNSTABLE,
                        "rigid agent %d: a step of %g s blew up (non-finite "
                        "state or a speed over %g m/s); state kept",
                        a->index, dt / n_sub, r->solver.max_speed);
    }
    a->stats.substeps += (uint64_t)n_sub;
    gs__sap_update(r);
    return GS_OK;
}

/* A probe moves toward its target at no more than max_speed. */
GS__PRIVATE gs_result gs__probe_step(gs_agent *a, double dt) {
    gs__rigid *r = (gs__rigid *)a;
    gs_vec3 d = gs__sub(r->target, r->x);
    double dist = gs__len(d), reach = r->max_speed * dt;
    if (dist > reach) d = gs__scale(d, reach / dist);
    r->v = gs__scale(d, 1.0 / dt);
    r->x = gs__add(r->x, d);
    r->q = r->target_q;
    r->w = gs__v3(0.0, 0.0, 0.0);
    a->stats.substeps++;
    gs__sap_update(r);
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
    if (!(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w > 1e-12))
        return gs__fail(a->world, GS_ERR_INVALID_ARG,
                        "gs_agent_set_state: the orientation quaternion is zero");
    r->x = gs__v3(in[0], in[1], in[2]);
    r->q = gs__quat_normalize(q);
    r->v = r->v_prev = gs__v3(in[7], in[8], in[9]);
    r->w = r->w_prev = gs__v3(in[10], in[11], in[12]);
    if (r->probe) {
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
    *out = &r->base;
    return GS_OK;
}

GS_API gs_result gs_rigid_create(gs_world *w, const gs_rigid_desc *desc,
                                 gs_agent **out) {
    gs_rigid_desc d;
    gs__rigid *r;
    gs__check c;
    gs_result res = gs__create_begin(w, desc, out, "gs_rigid_create");
    if (res != GS_OK) return res;
    d = gs__rigid_defaults(desc);
    r = (gs__rigid *)gs__alloc(w, sizeof *r);
    if (!r) return gs__fail(w, GS_ERR_NO_MEMORY, "gs_rigid_create: out of memory");
    memset(r, 0, sizeof *r);
    c = gs__check_begin(w, "gs_rigid_create");
    gs__rigid_check(&c, &d, &r->shape);
    if (c.r == GS_OK) c.r = gs__agent_init(w, &r->base, &gs__rigid_kind, d.solver.dt);
    if (c.r != GS_OK) {
        gs__free(w, r);
        return c.r;
    }
    gs__rigid_mass(r, &d);
    r->x = d.position;
    r->q = gs__quat_normalize(d.orientation);
    r->v = r->v_prev = d.velocity;
    r->w = r->w_prev = d.angular_velocity;
    r->mat = d.material;
    r->solver = d.solver;
    r->continuous = d.continuous;
    r->reach2 = gs__rigid_reach2(r);
    r->i_min = gs__rigid_i_min(r);
    r->rolling = d.rolling;
    r->k_sum = r->mat.stiffness;
    r->c_sum = r->mat.damping;
    r->stable_dt = gs__rigid_bound(r);
    r->k_sum = r->c_sum = 0.0;
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
    r = (gs__rigid *)gs__alloc(w, sizeof *r);
    if (!r) return gs__fail(w, GS_ERR_NO_MEMORY, "gs_probe_create: out of memory");
    memset(r, 0, sizeof *r);
    c = gs__check_begin(w, "gs_probe_create");
    gs__shape_build(&c, &d.shape, &r->shape);
    gs__check_vec(&c, "position", d.position);
    gs__check_quat(&c, "orientation", d.orientation);
    gs__check_material(&c, &d.material);
    gs__check_positive(&c, "dt", d.dt);
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
    if (!a) return GS_ERR_INVALID_ARG;
    if (!r || !r->probe)
        return gs__fail(a->world, GS_ERR_INVALID_ARG,
                        "gs_probe_set_target: agent %d is a %s, not a probe", a->index,
                        a->kind->name);
    if (!gs__finite3(position) || !gs__finite(orientation.x) ||
        !gs__finite(orientation.y) || !gs__finite(orientation.z) ||
        !gs__finite(orientation.w))
        return gs__fail(a->world, GS_ERR_NOT_FINITE,
                        "gs_probe_set_target: the pose must be finite");
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
   so that a box rests on a face); MPR alone for spheres against hulls. Penalty forces: each
   agent computes the forces on itself from the other agent's current state,
   whatever that agent's simulation time.
   ======================================================================== */
/* ---- broad phase: sweep and prune on x ----
   Two lists of the same bodies, kept sorted by bubbling a body that moved
   to its place (a step moves it little, so this is about O(1)):
   - bodies, by the low end of the sweep, bound + 0.1 s of travel: the order
     in which contacts are summed, so that forces keep their last bits;
   - near, by x - bound: what a query searches. Travel is added at the
     query, for the lag the scheduler allows now (its tolerance and a step,
     not 0.1 s: gs__lag_bound), so a falling pile does not make every
     query span the world.
   A body whose sweep is over wide_at (a wall, a floor, a body moving fast)
   is listed apart and left out of bound_max and speed_max, which stretch
   the search: one wall used to stretch every query over the whole world.
   A body's query looks in a uniform grid of the bodies not wide (a range
   on x, a mesh's, searches near). Either gathers candidates, adds the wide
   ones, then puts them in the order of bodies. */
GS__PRIVATE void gs__sap_swap(gs__rigid **list, int i, int j, int near) {
    struct gs__rigid *t = list[i];
    list[i] = list[j];
    list[j] = t;
    if (near) {
        list[i]->near = i;
        list[j]->near = j;
    } else {
        list[i]->sap = i;
        list[j]->sap = j;
    }
}

GS__PRIVATE double gs__sap_key(const gs__rigid *b, int near) {
    return near ? b->near_key : b->key;
}

/* Moves r to its place in one list (near: by near_key, else by key). */
GS__PRIVATE void gs__sap_bubble(gs__rigid **list, int n, gs__rigid *r, int near) {
    int i = near ? r->near : r->sap;
    double k = gs__sap_key(r, near);
    while (i > 0 && gs__sap_key(list[i - 1], near) > k) { gs__sap_swap(list, i - 1, i, near); --i; }
    while (i + 1 < n && gs__sap_key(list[i + 1], near) < k) { gs__sap_swap(list, i, i + 1, near); ++i; }
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
GS__PRIVATE int64_t gs__grid_coord(const gs_world *w, double x) {
    double c = floor(x / w->cell);
    if (!(c >= -GS__GRID_SPAN)) c = -GS__GRID_SPAN; /* and NaN */
    if (c > GS__GRID_SPAN) c = GS__GRID_SPAN;
    return (int64_t)c;
}

GS__PRIVATE size_t gs__grid_bucket(const gs_world *w, const int64_t c[3]) {
    uint64_t h = (uint64_t)c[0] * 73856093u ^ (uint64_t)c[1] * 19349663u ^ (uint64_t)c[2] * 83492791u;
    return (size_t)(h % (2 * (uint64_t)w->bodies_cap));
}

GS__PRIVATE void gs__grid_unlink(gs_world *w, gs__rigid *r) {
    if (!r->in_grid) return;
    if (r->gprev) r->gprev->gnext = r->gnext;
    else w->grid[gs__grid_bucket(w, r->cell)] = r->gnext;
    if (r->gnext) r->gnext->gprev = r->gprev;
    r->in_grid = 0;
}

/* Keeps r in the cell of its centre, or out of the grid if it is wide. */
GS__PRIVATE void gs__grid_place(gs_world *w, gs__rigid *r) {
    int64_t c[3];
    size_t b;
    if (w->cell <= 0.0 || r->wide >= 0) {
        gs__grid_unlink(w, r);
        return;
    }
    c[0] = gs__grid_coord(w, r->x.x);
    c[1] = gs__grid_coord(w, r->x.y);
    c[2] = gs__grid_coord(w, r->x.z);
    if (r->in_grid && c[0] == r->cell[0] && c[1] == r->cell[1] && c[2] == r->cell[2]) return;
    gs__grid_unlink(w, r);
    memcpy(r->cell, c, sizeof c);
    b = gs__grid_bucket(w, c);
    r->gprev = NULL;
    r->gnext = w->grid[b];
    if (r->gnext) r->gnext->gprev = r;
    w->grid[b] = r;
    r->in_grid = 1;
}

/* Every body again (a new cell size, a bigger table). */
GS__PRIVATE void gs__grid_rebuild(gs_world *w) {
    int i;
    memset(w->grid, 0, 2 * (size_t)w->bodies_cap * sizeof *w->grid);
    for (i = 0; i < w->nbodies; ++i) w->bodies[i]->in_grid = 0;
    for (i = 0; i < w->nbodies; ++i) gs__grid_place(w, w->bodies[i]);
}

GS__PRIVATE void gs__sap_update(gs__rigid *r) {
    gs_world *w = r->base.world;
    double v = gs__len(r->v);
    r->sweep = r->shape.bound + 0.1 * v;
    r->key = r->x.x - r->sweep;
    r->speed = r->probe ? 0.0 : v;
    r->near_key = r->x.x - r->shape.bound;
    gs__sap_classify(w, r);
    gs__sap_bubble(w->bodies, w->nbodies, r, 0);
    gs__sap_bubble(w->near, w->nbodies, r, 1);
    gs__grid_place(w, r);
}

GS__PRIVATE gs_result gs__sap_add(gs_world *w, gs__rigid *r) {
    if (w->nbodies == w->bodies_cap) {
        int cap = w->bodies_cap ? 2 * w->bodies_cap : 16;
        struct gs__rigid **list = (struct gs__rigid **)gs__alloc(w, 6 * (size_t)cap * sizeof *list);
        if (!list) return gs__fail(w, GS_ERR_NO_MEMORY, "broad phase: out of memory");
        if (w->nbodies) {
            memcpy(list, w->bodies, (size_t)w->nbodies * sizeof *list);
            memcpy(list + cap, w->near, (size_t)w->nbodies * sizeof *list);
        }
        if (w->nwide) memcpy(list + 2 * cap, w->wide, (size_t)w->nwide * sizeof *list);
        gs__free(w, w->bodies);
        w->bodies = list;
        w->near = list + cap;
        w->wide = list + 2 * cap;
        w->cand = list + 3 * cap;
        w->grid = list + 4 * cap;
        w->bodies_cap = cap;
        gs__grid_rebuild(w);
    }
    r->sap = r->near = w->nbodies;
    r->wide = -1;
    r->in_grid = 0;
    w->bodies[w->nbodies] = w->near[w->nbodies] = r;
    w->nbodies++;
    gs__sap_update(r);
    return GS_OK;
}

GS__PRIVATE void gs__sap_remove(gs_world *w, gs__rigid *r) {
    int i;
    gs__grid_unlink(w, r);
    if (r->wide >= 0) {
        w->wide[r->wide] = w->wide[--w->nwide];
        w->wide[r->wide]->wide = r->wide;
    }
    for (i = r->sap + 1; i < w->nbodies; ++i) {
        w->bodies[i - 1] = w->bodies[i];
        w->bodies[i - 1]->sap = i - 1;
    }
    for (i = r->near + 1; i < w->nbodies; ++i) {
        w->near[i - 1] = w->near[i];
        w->near[i - 1]->near = i - 1;
    }
    w->nbodies--;
}

/* Takes an agent out of the contact bookkeeping before it is destroyed. */
GS__PRIVATE void gs__agent_unlink(gs_agent *a) {
    gs__rigid *r = gs__as_rigid(a);
    if (r) gs__sap_remove(a->world, r);
    else if (gs__as_mesh(a)) a->world->nmeshes--;
}

/* At each advance: wide means a sweep over 4 times the mean body bound,
   and bound_max and speed_max are those of the others, exactly (updates
   only ever raise them). */
GS__PRIVATE void gs__sap_refresh(gs_world *w) {
    double mean = 0.0;
    int i;
    for (i = 0; i < w->nbodies; ++i) mean += w->bodies[i]->shape.bound;
    w->wide_at = w->nbodies ? 4.0 * mean / (double)w->nbodies : 0.0;
    w->bound_max = w->speed_max = 0.0;
    w->nwide = 0;
    for (i = 0; i < w->nbodies; ++i) w->bodies[i]->wide = -1;
    for (i = 0; i < w->nbodies; ++i) gs__sap_classify(w, w->bodies[i]);
    /* a query of a body not wide reaches about 2 bound_max: two cells a side */
    w->cell = 4.0 * w->bound_max;
    if (w->nbodies) gs__grid_rebuild(w);
}

/* How far o reaches from its centre on any axis when its state is taken
   up to lag seconds from its time (m), with a slack for rounding. */
GS__PRIVATE double gs__sap_reach(const gs__rigid *o, double lag) {
    return (o->shape.bound + o->speed * lag) * (1.0 + 1e-9) + 1e-12;
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
        if (w->near[mid]->near_key < lo) a = mid + 1;
        else b = mid;
    }
    return a;
}

/* The candidates in the order of bodies (a query finds few). */
GS__PRIVATE void gs__sap_order(gs_world *w, int n) {
    int i, j;
    for (i = 1; i < n; ++i) {
        gs__rigid *r = w->cand[i];
        for (j = i; j > 0 && w->cand[j - 1]->sap > r->sap; --j) w->cand[j] = w->cand[j - 1];
        w->cand[j] = r;
    }
}

/* Every body that may meet [lo, hi] on x when taken up to lag seconds from
   its time, into w->cand in the order of bodies. Returns how many. */
GS__PRIVATE int gs__sap_query(gs_world *w, double lo, double hi, double lag) {
    double top = hi + w->speed_max * lag;
    int n = 0, i;
    top += 1e-9 * (1.0 + fabs(top));
    for (i = 0; i < w->nwide; ++i)
        if (gs__sap_meets(w->wide[i], lo, hi, lag)) w->cand[n++] = w->wide[i];
    for (i = gs__sap_first(w, lo, lag); i < w->nbodies && w->near[i]->near_key <= top; ++i)
        if (w->near[i]->wide < 0 && gs__sap_meets(w->near[i], lo, hi, lag)) w->cand[n++] = w->near[i];
    gs__sap_order(w, n);
    return n;
}

/* The bodies that may touch r when taken up to lag seconds from their
   time, into w->cand in the order of bodies: the wide ones, and those of
   the cells within reach of r (any body not wide is within bound_max +
   speed_max lag of its cell's reach). A reach of many cells takes the list
   search instead. Returns how many. */
#define GS__GRID_MAX_CELLS 64
GS__PRIVATE int gs__sap_query_near(gs_world *w, const gs__rigid *r, double lag) {
    double lo = r->x.x - r->shape.bound, hi = r->x.x + r->shape.bound;
    double reach = (r->shape.bound + w->bound_max + w->speed_max * lag) * (1.0 + 1e-9) + 1e-12;
    int64_t a[3], b[3], c[3];
    int n = 0, i;
    if (w->cell <= 0.0 || !(reach < 0.5 * GS__GRID_MAX_CELLS * w->cell))
        return gs__sap_query(w, lo, hi, lag);
    a[0] = gs__grid_coord(w, r->x.x - reach); b[0] = gs__grid_coord(w, r->x.x + reach);
    a[1] = gs__grid_coord(w, r->x.y - reach); b[1] = gs__grid_coord(w, r->x.y + reach);
    a[2] = gs__grid_coord(w, r->x.z - reach); b[2] = gs__grid_coord(w, r->x.z + reach);
    if ((b[0] - a[0] + 1) * (b[1] - a[1] + 1) * (b[2] - a[2] + 1) > GS__GRID_MAX_CELLS)
        return gs__sap_query(w, lo, hi, lag);
    for (i = 0; i < w->nwide; ++i)
        if (gs__sap_meets(w->wide[i], lo, hi, lag)) w->cand[n++] = w->wide[i];
    for (c[0] = a[0]; c[0] <= b[0]; ++c[0])
        for (c[1] = a[1]; c[1] <= b[1]; ++c[1])
            for (c[2] = a[2]; c[2] <= b[2]; ++c[2]) {
                gs__rigid *o;
                for (o = w->grid[gs__grid_bucket(w, c)]; o; o = o->gnext)
                    if (o->cell[0] == c[0] && o->cell[1] == c[1] && o->cell[2] == c[2] &&
                        gs__sap_meets(o, lo, hi, lag))
                        w->cand[n++] = o;
            }
    gs__sap_order(w, n);
    return n;
}

/* Can o touch r at a lag of o's time up to lag (s)? A contact needs
   |r - (o + v_o lag)| < both bounds, so on each axis the centres must be
   within both bounds and o's travel (x is the query's). */
GS__PRIVATE int gs__sweeps_meet(const gs__rigid *r, const gs__rigid *o, double lag) {
    double reach = gs__sap_reach(o, lag) + r->shape.bound * (1.0 + 1e-9);
    return fabs(r->x.y - o->x.y) <= reach && fabs(r->x.z - o->x.z) <= reach;
}

typedef struct gs__body {
    const gs__shape *s;
    gs_vec3 p;
    gs_quat q;
} gs__body;

GS__PRIVATE int gs__sphere_sphere(gs_vec3 ca, double ra, gs_vec3 cb, double rb,
                                  gs_contact *c) {
    gs_vec3 d = gs__sub(ca, cb);
    double l = gs__len(d), depth = ra + rb - l;
    if (!(depth > 0.0)) return 0;
    c->normal = l > 1e-12 * (ra + rb) ? gs__scale(d, 1.0 / l) : gs__v3(0.0, 1.0, 0.0);
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
   then to +y; a non-finite depth counts as touching. */
GS__PRIVATE int gs__mpr(const gs__body *a, const gs__body *b, gs_contact *c) {
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
        if (!(ln > 1e-12)) { n = gs__v3(0.0, 1.0, 0.0); ln = 1.0; }
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
                              gs_contact *out, int max) {
    gs_contact m;
    double eps, top_b, bottom_a;
    int i, n = 0;
    if (!gs__mpr(a, b, &m)) return 0;
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

/* All contacts between two bodies, normals from b to a. */
GS__PRIVATE int gs__collide(const gs__body *a, const gs__body *b,
                            gs_contact *out, int max) {
    gs_shape_type ta = a->s->type, tb = b->s->type;
    int n;
    if (ta == GS_SHAPE_SPHERE && tb == GS_SHAPE_SPHERE)
        return gs__sphere_sphere(a->p, a->s->radius, b->p, b->s->radius, out);
    if (ta == GS_SHAPE_SPHERE && tb == GS_SHAPE_BOX)
        return gs__sphere_box(a->p, a->s->radius, b, out);
    if (ta == GS_SHAPE_BOX && tb == GS_SHAPE_SPHERE) {
        n = gs__sphere_box(b->p, b->s->radius, a, out);
        if (n) out->normal = gs__scale(out->normal, -1.0);
        return n;
    }
    if (ta == GS_SHAPE_SPHERE || tb == GS_SHAPE_SPHERE) return gs__mpr(a, b, out);
    return gs__poly_poly(a, b, out, max);
}

GS__PRIVATE gs__body gs__body_of(const gs__rigid *r) {
    gs__body b;
    b.s = &r->shape;
    b.p = r->x;
    b.q = r->q;
    return b;
}

GS_API int gs_collide_shapes(const gs_shape_desc *a, gs_vec3 pa, gs_quat qa,
                             const gs_shape_desc *b, gs_vec3 pb, gs_quat qb,
                             gs_contact *c) {
    gs__shape sa, sb;
    gs__body ba, bb;
    gs_contact all[2 * GS_MAX_HULL_POINTS];
    gs__check chk = gs__check_begin(NULL, "gs_collide_shapes");
    int n, i, deepest = 0;
    gs__shape_build(&chk, a, &sa);
    gs__shape_build(&chk, b, &sb);
    if (chk.r != GS_OK || !c || !gs__finite3(pa) || !gs__finite3(pb)) return 0;
    ba.s = &sa; ba.p = pa; ba.q = gs__quat_normalize(gs__orientation_default(qa));
    bb.s = &sb; bb.p = pb; bb.q = gs__quat_normalize(gs__orientation_default(qb));
    n = gs__collide(&ba, &bb, all, 2 * GS_MAX_HULL_POINTS);
    for (i = 1; i < n; ++i)
        if (all[i].depth > all[deepest].depth) deepest = i;
    if (n) *c = all[deepest];
    return n > 0;
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
   `centre`; normal from body to particle. */
GS__PRIVATE int gs__particle_contact(gs_vec3 x, double rp, const gs__rigid *r,
                                     gs_vec3 centre, gs_contact *c) {
    gs__body b = gs__body_of(r), pb;
    gs__shape ps;
    b.p = centre;
    if (gs__dot(gs__sub(x, centre), gs__sub(x, centre)) >=
        (rp + r->shape.bound) * (rp + r->shape.bound))
        return 0;
    if (r->shape.type == GS_SHAPE_SPHERE)
        return gs__sphere_sphere(x, rp, centre, r->shape.radius, c);
    if (r->shape.type == GS_SHAPE_BOX) return gs__sphere_box(x, rp, &b, c);
    ps.type = GS_SHAPE_SPHERE; /* only type and radius are read */
    ps.radius = rp;
    pb.s = &ps; pb.p = x; pb.q = gs__quat(0.0, 0.0, 0.0, 1.0);
    return gs__mpr(&pb, &b, c);
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
   for ever (measured; at a fifth and below it stops cleanly). */
#define GS__ROLL_K 0.1
GS__PRIVATE gs_vec3 gs__rolling_torque(const gs__rigid *r, gs_vec3 normal, double fn,
                                       gs_vec3 w_rel) {
    gs_vec3 wt = gs__madd(w_rel, normal, -gs__dot(w_rel, normal));
    double spin = gs__len(wt), most;
    if (!(r->rolling > 0.0) || !(fn > 0.0) || !(spin > 0.0)) return gs__v3(0.0, 0.0, 0.0);
    most = fmin(r->rolling * fn, GS__ROLL_K * r->i_min * spin / r->base.dt);
    return gs__scale(wt, -most / spin);
}

GS__PRIVATE void gs__rigid_apply(gs__rigid *r, const gs_contact *c,
                                 gs_vec3 vrel, gs_vec3 w_other,
                                 const gs_material *other, double other_reach2) {
    double slope = gs__friction_slope(r->reach2, other_reach2, r->base.dt);
    gs_vec3 f = gs__penalty(c, vrel, &r->mat, other, slope);
    r->k_sum += 0.5 * (r->mat.stiffness + other->stiffness);
    r->c_sum += 0.5 * (r->mat.damping + other->damping) + slope;
    r->force = gs__add(r->force, f);
    r->torque = gs__add(r->torque, gs__cross(gs__sub(c->point, r->x), f));
    r->torque = gs__add(r->torque, gs__rolling_torque(r, c->normal, gs__dot(f, c->normal),
                                                      gs__sub(r->w, w_other)));
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
            gs__rigid_apply(r, &c, gs__point_velocity(r, c.point), gs__v3(0.0, 0.0, 0.0),
                            &w->ground_material, 0.0);
        return;
    }
    for (i = 0; i < r->shape.nv; ++i) {
        c.point = gs__add(r->x, gs__rotate(r->q, r->shape.v[i]));
        c.depth = w->ground_height - c.point.y;
        if (c.depth > 0.0)
            gs__rigid_apply(r, &c, gs__point_velocity(r, c.point), gs__v3(0.0, 0.0, 0.0),
                            &w->ground_material, 0.0);
    }
}

/* o is taken where it is at r's time t: its position carried along its
   velocity, and its velocities interpolated along the change of its last
   step. Were o's velocity taken as it stands, a body that has already
   stepped would offer the velocity this very contact gave it, and the
   damping would not be equal and opposite: momentum would leak. */
GS__PRIVATE void gs__rigid_vs_rigid(gs__rigid *r, const gs__rigid *o, double t) {
    gs_contact cs[2 * GS_MAX_HULL_POINTS];
    gs__body a = gs__body_of(r), b = gs__body_of(o);
    double reach = r->shape.bound + o->shape.bound;
    double lag = fmax(-0.1, fmin(0.1, t - gs__agent_time(&o->base)));
    double f;
    gs_vec3 ov, ow;
    int n, i;
    if (!o->probe) b.p = gs__madd(o->x, o->v, lag);
    if (gs__dot(gs__sub(r->x, b.p), gs__sub(r->x, b.p)) >= reach * reach) return;
    f = o->probe ? 0.0 : fmax(-1.0, fmin(1.0, lag / o->base.dt));
    ov = gs__madd(o->v, gs__sub(o->v, o->v_prev), f);
    ow = gs__madd(o->w, gs__sub(o->w, o->w_prev), f);
    n = gs__collide(&a, &b, cs, 2 * GS_MAX_HULL_POINTS);
    for (i = 0; i < n; ++i) {
        gs_vec3 vo = gs__add(ov, gs__cross(ow, gs__sub(cs[i].point, b.p)));
        gs__rigid_apply(r, &cs[i], gs__sub(gs__point_velocity(r, cs[i].point), vo), ow,
                        &o->mat, o->probe ? 0.0 : o->reach2);
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
GS__PRIVATE void gs__rigid_vs_mesh(gs__rigid *r, const gs_agent *m, double t) {
    const gs_vec3 *x = NULL, *v = NULL;
    const gs_material *mat = NULL;
    gs_vec3 lo, hi;
    double rp = 0.0, reach, slope, lag = fmax(-0.1, fmin(0.1, t - gs__agent_time(m)));
    int n = gs__mesh_info(m, &x, &v, &rp, &mat), i;
    gs__mesh_bounds(m, &lo, &hi);
    reach = r->shape.bound + rp + fabs(lag) * r->solver.max_speed;
    if (r->x.x + reach < lo.x || r->x.x - reach > hi.x || r->x.y + reach < lo.y ||
        r->x.y - reach > hi.y || r->x.z + reach < lo.z || r->x.z - reach > hi.z)
        return;
    for (i = 0; i < n; ++i) {
        gs_contact c;
        gs_vec3 f;
        if (!gs__particle_contact(gs__madd(x[i], v[i], lag), rp, r, r->x, &c)) continue;
        slope = gs__friction_slope(r->reach2, 1.0 / gs__mesh_mass(m, i), r->base.dt);
        f = gs__penalty(&c, gs__sub(v[i], gs__point_velocity(r, c.point)), mat, &r->mat, slope);
        r->k_sum += 0.5 * (r->mat.stiffness + mat->stiffness);
        r->c_sum += 0.5 * (r->mat.damping + mat->damping) + slope;
        r->force = gs__sub(r->force, f);
        r->torque = gs__sub(r->torque, gs__cross(gs__sub(c.point, r->x), f));
        r->torque = gs__add(r->torque, gs__rolling_torque(r, c.normal, gs__dot(f, c.normal), r->w));
    }
}

/* Contact forces on r at its simulation time t. */
GS__PRIVATE void gs__rigid_contacts(gs__rigid *r, double t) {
    gs_world *w = r->base.world;
    int i;
    double lag = gs__lag_bound(w, t, 0.1);
    int n = gs__sap_query_near(w, r, lag);
    r->force = r->torque = gs__v3(0.0, 0.0, 0.0);
    r->k_sum = r->c_sum = 0.0;
    if (w->ground) gs__rigid_ground(r);
    for (i = 0; i < n; ++i)
        if (w->cand[i] != r && gs__sweeps_meet(r, w->cand[i], lag)) gs__rigid_vs_rigid(r, w->cand[i], t);
    for (i = 0; w->nmeshes > 0 && i < w->agent_count; ++i)
        if (gs__mesh_info(w->agents[i], NULL, NULL, NULL, NULL)) gs__rigid_vs_mesh(r, w->agents[i], t);
}

GS_API gs_result gs_world_set_ground(gs_world *w, int enabled, double height,
                                     gs_material material) {
    gs__check c = gs__check_begin(w, "gs_world_set_ground");
    material = gs__material_defaults(material);
    gs__check_finite(&c, "height", height);
    gs__check_material(&c, &material);
    if (c.r != GS_OK) return c.r;
    w->ground = enabled != 0;
    w->ground_height = height;
    w->ground_material = material;
    return GS_OK;
}

/* ---- contacts of a mesh's particles ---- */
GS__PRIVATE void gs__mesh_update_bounds(gs__mesh *m) {
    gs_vec3 lo = m->x[0], hi = m->x[0], r;
    int i;
    for (i = 1; i < m->n; ++i) {
        lo = gs__v3(fmin(lo.x, m->x[i].x), fmin(lo.y, m->x[i].y), fmin(lo.z, m->x[i].z));
        hi = gs__v3(fmax(hi.x, m->x[i].x), fmax(hi.y, m->x[i].y), fmax(hi.z, m->x[i].z));
    }
    r = gs__v3(m->radius, m->radius, m->radius);
    m->lo = gs__sub(lo, r);
    m->hi = gs__add(hi, r);
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
    m->ext[i] = gs__add(m->ext[i], f);
    m->ext_active = 1;
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
GS__PRIVATE void gs__mesh_vs_rigid(gs__mesh *m, const gs__rigid *r, double t) {
    double reach = r->shape.bound;
    double lag = fmax(-0.1, fmin(0.1, t - gs__agent_time(&r->base)));
    gs_vec3 centre = r->probe ? r->x : gs__madd(r->x, r->v, lag);
    int i;
    if (centre.x + reach < m->lo.x || centre.x - reach > m->hi.x ||
        centre.y + reach < m->lo.y || centre.y - reach > m->hi.y ||
        centre.z + reach < m->lo.z || centre.z - reach > m->hi.z)
        return;
    for (i = 0; i < m->n; ++i) {
        gs_contact c;
        if (m->pinned[i] || !gs__particle_contact(m->x[i], m->radius, r, centre, &c)) continue;
        gs__mesh_touch(m, i, &c, gs__point_velocity(r, c.point), &r->mat,
                       r->probe ? 0.0 : r->reach2);
    }
}

/* Contact forces on every particle from the ground and from the current
   state of every rigid body and probe. Costs nothing in a world without
   them. */
GS__PRIVATE void gs__mesh_contacts(gs__mesh *m, double t) {
    gs_world *w = m->base.world;
    int i, n;
    if (m->ext_active) {
        memset(m->ext, 0, (size_t)m->n * sizeof *m->ext);
        if (m->ck) memset(m->ck, 0, (size_t)m->n * sizeof *m->ck);
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
GS_API gs_scene_desc gs_scene_desc_default(void) {
    gs_scene_desc d;
    memset(&d, 0, sizeof d);
    d.cloth_n = 16;
    d.cloth_size = 1.0;
    d.sphere_count = 3;
    d.sphere_radius = 0.08;
    d.probe_count = 1;
    d.seed = 1;
    d.cloth_integrator = GS_INTEGRATOR_IMPLICIT_EULER;
    d.dt = 0.002;
    return d;
}

GS__PRIVATE gs_scene_desc gs__scene_defaults(const gs_scene_desc *in) {
    gs_scene_desc def = gs_scene_desc_default(), d = in ? *in : def;
    if (d.cloth_n == 0) d.cloth_n = def.cloth_n;
    if (d.cloth_size == 0.0) d.cloth_size = def.cloth_size;
    if (d.sphere_radius == 0.0) d.sphere_radius = def.sphere_radius;
    if (d.seed == 0) d.seed = def.seed;
    if (d.cloth_integrator == GS_INTEGRATOR_DEFAULT) d.cloth_integrator = def.cloth_integrator;
    if (d.dt == 0.0) d.dt = def.dt;
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
   stepping on its own against the others and the implicit cloth, were
   kicked up again and again (0.3 m/s after 15 s, measured); at 20 the
   scene comes to rest (its kinetic energy falls 10x every 2 s), and only a
   scene that comes to rest lets the hosts' copies meet. */
/* Rolling resistance of the scene's spheres: 4 mm, a coefficient of 0.05
   on a 8 cm sphere (a ball on cloth or carpet). A sphere a probe throws
   onto the ground otherwise rolls for ever, and on the cloth the spheres
   creep for tens of seconds before they rest. */
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
        rd.solver.dt = d->dt;
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
GS__PRIVATE gs_result gs__scene_settle(gs_agent *cloth) {
    int i, steps = (int)(3.0 / cloth->dt);
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
    int first;
    if (!w || !out) return GS_ERR_INVALID_ARG;
    memset(out, 0, sizeof *out);
    out->desc = gs__scene_defaults(desc);
    gs__check_int(&c, "cloth_n", out->desc.cloth_n, 2, 4096);
    gs__check_positive(&c, "cloth_size", out->desc.cloth_size);
    gs__check_int(&c, "sphere_count", out->desc.sphere_count, 0, GS_SCENE_MAX_SPHERES);
    gs__check_positive(&c, "sphere_radius", out->desc.sphere_radius);
    gs__check_int(&c, "probe_count", out->desc.probe_count, 0, GS_SCENE_MAX_PROBES);
    gs__check_positive(&c, "dt", out->desc.dt);
    if (c.r != GS_OK) return c.r;
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
    r = gs_cloth_create(w, &cd, &out->cloth);
    if (r == GS_OK) r = gs__scene_settle(out->cloth);
    if (r == GS_OK) r = gs__scene_bodies(w, out);
    if (r != GS_OK) { /* leave the world as it was */
        while (w->agent_count > first) gs_agent_destroy(w->agents[w->agent_count - 1]);
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
    uint32_t seq;
    double time;        /* s, remote simulation time */
    double age;         /* s, estimated one-way delay when it came */
    int age_known;      /* 0 before the first round trip to the peer: the
                           age is taken as 0, so the time is a lower bound */
    int chunks;         /* chunks received */
    unsigned char *got; /* per chunk index */
    double *data;       /* the state after its time; valid where got */
} gs__snap;

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
    gs__snap *q[GS__MAX_PEERS]; /* queue_size snapshots per peer slot */
    double *local, *scratch;
    double *offset, *offset_next; /* render offsets; a blend writes the next
                                     ones and swaps only if it is applied */
    double *wq;           /* weight of each queued snapshot in a blend */
    struct gs__src *src;  /* the queued snapshots of a blend, in order */
    int nsrc;
    double offset_t;      /* s; simulation time the offset was last set */
    double t_local;       /* s; the agent's time after its last step, for
                             the receiving side (written under the lock) */
    double divergence[GS__MAX_PEERS];
    double newest[GS__MAX_PEERS];  /* s; the latest remote time that told
                                      the peer's clock, -HUGE_VAL at first */
    double lead[GS__MAX_PEERS];    /* s; how far each peer's clock is ahead
                                      of ours (see gs__peer_lead) */
    double lead_at[GS__MAX_PEERS]; /* s; local time of its last sample,
                                      -HUGE_VAL before the first */
    gs_ghost_stats stats;
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

typedef struct gs__peer {
    int used;
    uint32_t host;
    gs_peer_stats st;
    uint32_t send_seq;        /* our next datagram sequence to them */
    uint32_t recv_top;        /* highest datagram sequence received */
    uint64_t recv_window;     /* bit i: recv_top - i received */
    int recv_any;
    double their_send_time;   /* echo: their latest send time, and */
    double their_recv_now;    /* our clock when it came */
    double tokens;            /* bytes the budget allows now */
    double tokens_at;         /* s, wall time of the last refill */
    gs__peer_guard guard;     /* replay window, receive cap (>>net) */
} gs__peer;

struct gs_net {
    gs_world *world;
    gs_net_desc d;
    gs__peer peers[GS__MAX_PEERS];
    uint64_t unknown_rejected[GS_REJECT_COUNT];
    gs_net_lock lock;
    double now;               /* s, wall time of the last update/deliver */
    unsigned char buf[GS_WIRE_MAX_DATAGRAM];
    gs_wire_view view;        /* decode scratch (too big for the stack) */
    gs__net_guard guard;      /* key, nonces, opened datagram (>>net) */
};

GS__PRIVATE void gs__lock(gs_net *net) {
    if (net && net->lock.lock) net->lock.lock(net->lock.user);
}
GS__PRIVATE void gs__unlock(gs_net *net) {
    if (net && net->lock.unlock) net->lock.unlock(net->lock.user);
}

GS_API gs_ghost_desc gs_ghost_desc_default(void) {
    gs_ghost_desc d;
    memset(&d, 0, sizeof d);
    d.weight = gs_weight_exp;
    d.send_rate = 60.0;
    d.encoding = GS_ENCODING_F64;
    d.queue_size = 8;
    d.smoothing = 0.1;
    d.catchup = GS_CATCHUP_NONE;
    return d;
}

GS__PRIVATE size_t gs__value_size(gs_encoding e) {
    return e == GS_ENCODING_F32 ? 4 : 8;
}

/* A ghost's queue for one peer slot: queue_size snapshots. */
GS__PRIVATE gs__snap *gs__snaps_new(gs_world *w, const gs__ghost *g) {
    size_t qs = (size_t)g->d.queue_size, vars = g->n - 1, i;
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

GS__PRIVATE gs__ghost *gs__ghost_of(const gs_agent *a);
GS__PRIVATE gs_result gs__ghost_add_peer(gs__ghost *g, int slot) {
    gs_world *w = g->agent->world;
    if (g->q[slot]) return GS_OK;
    g->q[slot] = gs__snaps_new(w, g);
    return g->q[slot] ? GS_OK : gs__fail(w, GS_ERR_NO_MEMORY, "ghost: out of memory for a peer queue");
}

GS__PRIVATE void gs__ghost_free(gs__ghost *g) {
    gs_world *w = g->agent->world;
    int i;
    for (i = 0; i < GS__MAX_PEERS; ++i) gs__free(w, g->q[i]);
    gs__free(w, g);
}

GS__PRIVATE gs__ghost *gs__ghost_of(const gs_agent *a) {
    return (gs__ghost *)a->ghost;
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
    return c.r;
}

GS__PRIVATE gs_result gs__ghost_queues(gs__ghost *g);

GS_API gs_result gs_ghost_attach(gs_agent *a, const gs_ghost_desc *desc) {
    gs_world *w = a->world;
    gs_ghost_desc d;
    gs__ghost *g;
    size_t n = gs_agent_state_size(a), vars = n - 1, bytes;
    int i;
    gs_result r = gs__world_unlocked(w, "gs_ghost_attach");
    if (r != GS_OK) return r;
    if (!desc) return gs__fail(w, GS_ERR_INVALID_ARG, "gs_ghost_attach: desc is NULL");
    if (a->ghost) return gs__fail(w, GS_ERR_INVALID_ARG, "gs_ghost_attach: the agent has a ghost");
    d = gs__ghost_defaults(desc);
    r = gs__ghost_check(w, &d);
    if (r != GS_OK) return r;
    bytes = sizeof *g + (size_t)GS__MAX_PEERS * (size_t)d.queue_size * sizeof(gs__src) +
            (5 * n + (size_t)GS__MAX_PEERS * (size_t)d.queue_size) * sizeof(double);
    g = (gs__ghost *)gs__alloc(w, bytes);
    if (!g) return gs__fail(w, GS_ERR_NO_MEMORY, "gs_ghost_attach: out of memory");
    memset(g, 0, bytes);
    g->agent = a;
    g->d = d;
    g->n = n;
    g->per_chunk = (int)(GS_WIRE_CHUNK_ROOM / gs__value_size(d.encoding));
    g->nchunks = vars ? (int)((vars + (size_t)g->per_chunk - 1) / (size_t)g->per_chunk) : 1;
    g->src = (gs__src *)(g + 1);
    g->B = (double *)(g->src + (size_t)GS__MAX_PEERS * (size_t)d.queue_size);
    g->local = g->B + n;
    g->scratch = g->local + n;
    g->offset = g->scratch + n;
    g->offset_next = g->offset + n;
    g->wq = g->offset_next + n;
    gs_agent_get_state(a, g->B, n);
    g->b_seq = 1;
    g->t_local = g->B[0];
    for (i = 0; i < GS__MAX_PEERS; ++i) g->newest[i] = g->lead_at[i] = -HUGE_VAL;
    a->ghost = g;
    r = gs__ghost_queues(g);
    if (r != GS_OK) {
        a->ghost = NULL;
        gs__ghost_free(g);
    }
    return r;
}

GS_API gs_result gs_ghost_detach(gs_agent *a) {
    gs_result r = gs__world_unlocked(a->world, "gs_ghost_detach");
    gs__ghost *g = gs__ghost_of(a);
    if (r != GS_OK) return r;
    if (!g) return GS_OK;
    gs__lock(a->world->net);
    a->ghost = NULL;
    gs__unlock(a->world->net);
    gs__ghost_free(g);
    return GS_OK;
}

GS_API gs_result gs_ghost_get_stats(const gs_agent *a, gs_ghost_stats *out) {
    const gs__ghost *g = gs__ghost_of(a);
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
    const gs__ghost *g = gs__ghost_of(a);
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

GS_API gs_result gs_scene_attach_ghosts(gs_scene *sc, const gs_ghost_desc *shared) {
    gs_ghost_desc gd = shared ? *shared : gs_ghost_desc_default();
    gs_result r = GS_OK;
    int i;
    if (!sc || !sc->cloth) return GS_ERR_INVALID_ARG;
    if (gs__scene_has_ghost(sc))
        return gs__fail(sc->cloth->world, GS_ERR_INVALID_ARG,
                        "gs_scene_attach_ghosts: an agent of the scene has a ghost already");
    gd.owner = 0;
    gd.object_id = 1;
    r = gs_ghost_attach(sc->cloth, &gd);
    for (i = 0; r == GS_OK && i < sc->sphere_count; ++i) {
        gd.object_id = 100 + (uint32_t)i;
        r = gs_ghost_attach(sc->spheres[i], &gd);
    }
    gd.weight = gs_weight_owner;
    gd.weight_user = NULL;
    gd.catchup = GS_CATCHUP_NONE;
    for (i = 0; r == GS_OK && i < sc->probe_count; ++i) {
        gd.object_id = 200 + (uint32_t)i;
        gd.owner = (uint32_t)i + 1;
        r = gs_ghost_attach(sc->probes[i], &gd);
    }
    if (r != GS_OK) { /* the error message stays with the world */
        gs_ghost_detach(sc->cloth);
        for (i = 0; i < sc->sphere_count; ++i) gs_ghost_detach(sc->spheres[i]);
        for (i = 0; i < sc->probe_count; ++i) gs_ghost_detach(sc->probes[i]);
    }
    return r;
}

/* After a step: the latest state goes to B at the ghost's rate (simulation
   time stands in for wall time here: the world keeps pace with it). */
GS__PRIVATE void gs__ghost_publish(gs__ghost *g, gs_net *net) {
    double t = gs__agent_time(g->agent);
    if (t < g->next_publish && g->next_publish - t < 1.0 / g->d.send_rate) return;
    gs__lock(net);
    gs_agent_get_state(g->agent, g->B, g->n);
    g->b_seq++;
    gs__unlock(net);
    g->next_publish = t + 1.0 / g->d.send_rate;
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
    return in;
}

/* Dead reckoning: the snapshot carried to the local time along its
   velocities, in place (it is blended once, then dropped). Missing chunks
   take the local values first: the kind's extrapolation reads them. */
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
    k->extrapolate(g->agent, s->data, t_i - s->time);
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

/* The largest x_comp of a blend (the local state's is 0), and the lead:
   the lowest host id within the time band of it. */
GS__PRIVATE double gs__ghost_lead(const gs__ghost *g, double t_i, uint32_t *lead) {
    const gs_world *wd = g->agent->world;
    double x_max = 0.0, band = gs__time_band(g);
    int p, k;
    for (p = 0; p < GS__MAX_PEERS; ++p)
        for (k = 0; g->q[p] && k < g->d.queue_size; ++k)
            if (g->q[p][k].used) x_max = fmax(x_max, gs__snap_xcomp(g, &g->q[p][k], t_i));
    *lead = x_max <= band ? wd->host_id : 0;
    for (p = 0; p < GS__MAX_PEERS; ++p)
        for (k = 0; g->q[p] && k < g->d.queue_size; ++k) {
            uint32_t h = wd->net->peers[p].host;
            if (g->q[p][k].used && gs__snap_xcomp(g, &g->q[p][k], t_i) >= x_max - band &&
                (*lead == 0 || h < *lead))
                *lead = h;
        }
    return x_max;
}

/* The weight of the local state and of every queued snapshot. Returns the
   local weight; all weights are scaled so that the largest is 1. */
GS__PRIVATE double gs__ghost_weigh(gs__ghost *g, double t_i, double *wq) {
    gs_world *wd = g->agent->world;
    gs_weight_in in0 = gs__weight_in(g, wd->host_id, 0.0, 0.0, 1);
    double x_max, w0, wmax;
    uint32_t lead;
    int p, k, m = 0;
    x_max = gs__ghost_lead(g, t_i, &lead);
    in0.x_max = x_max;
    in0.lead = lead;
    wmax = w0 = gs__sane_weight(g, g->d.weight(&in0, g->d.weight_user));
    for (p = 0; p < GS__MAX_PEERS; ++p)
        for (k = 0; g->q[p] && k < g->d.queue_size; ++k) {
            const gs__snap *s = &g->q[p][k];
            gs_weight_in in;
            if (!s->used) continue;
            in = gs__weight_in(g, wd->net->peers[p].host, s->time - t_i, s->age, 0);
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

GS__PRIVATE void gs__ghost_clear(gs__ghost *g) {
    int p, k;
    for (p = 0; p < GS__MAX_PEERS; ++p)
        for (k = 0; g->q[p] && k < g->d.queue_size; ++k) {
            gs__snap *s = &g->q[p][k];
            if (!s->used) continue;
            s->used = 0;
            s->chunks = 0;
            memset(s->got, 0, (size_t)g->nchunks);
        }
}

/* The peer's divergence: the largest over the world's objects of the
   latest distance to that peer's snapshot of it. */
GS__PRIVATE double gs__peer_divergence(const gs_world *w, int p) {
    double worst = 0.0;
    int i;
    for (i = 0; i < w->agent_count; ++i) {
        const gs__ghost *o = gs__ghost_of(w->agents[i]);
        if (o && o->divergence[p] > worst) worst = o->divergence[p];
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
    if (s->time < g->newest[p] && s->time > g->newest[p] - 1.0) return 0;
    for (k = 0; k < g->d.queue_size; ++k)
        if (g->q[p][k].used && g->q[p][k].time > s->time) return 0;
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
    fall = g->lead_at[p] == -HUGE_VAL ? HUGE_VAL : GS__LEAD_FALL * fabs(t_i - g->lead_at[p]);
    if (x > g->lead[p] - fall) g->lead[p] = x;
    else g->lead[p] -= fall;
    g->lead_at[p] = t_i;
    return g->lead[p];
}

/* Lists every queued snapshot with its weight in g->src, in queue order,
   and sums the blended time; fills the per-peer gap. Returns the number of
   snapshots. */
GS__PRIVATE int gs__ghost_gather(gs__ghost *g, double t_i, double *num_t,
                                 double *den_t) {
    gs_net *net = g->agent->world->net;
    int p, k, m = 0;
    for (p = 0; p < GS__MAX_PEERS; ++p) {
        double newest = g->newest[p];
        for (k = 0; g->q[p] && k < g->d.queue_size; ++k) {
            gs__snap *s = &g->q[p][k];
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
            net->peers[p].st.gap = s->time - t_i;
            if (gs__snap_tells_time(g, p, s, t_i)) {
                *num_t += src->w * gs__peer_lead(g, p, tq - t_i, t_i);
                *den_t += src->w;
                newest = s->time;
            }
        }
        g->newest[p] = newest;
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
        g->divergence[q->peer] = q->counted ? sqrt(3.0 * q->d2 / (double)q->counted) : 0.0;
        seen |= (uint32_t)1 << q->peer;
    }
    return seen;
}

/* Simulation time is blended only past the deadband (by default the world's
   tolerance). Hosts in step
   differ by less, and there the correction is mostly the error of the age
   estimate (half a round trip, quantized to when datagrams are sent and
   read): applied at every blend it would push the time on, and the agent
   would skip steps to stay on its world's clock. A host far behind (one
   that joins late) is pulled to the others at once. */
GS__PRIVATE double gs__time_correction(const gs__ghost *g, double gap, double dt) {
    return fabs(gap) > gs__time_band(g) ? dt : 0.0;
}

/* Applies a blended state (scratch) that the pass found finite: the kind
   may still refuse it (a zero quaternion), and then nothing moves. */
GS__PRIVATE int gs__blend_apply(gs__ghost *g, double t_i) {
    double *t;
    int e;
    if (gs__agent_put_state(g->agent, g->scratch) != GS_OK) return 0;
    for (e = 0; e < GS__MAX_PEERS; ++e) g->lead[e] -= g->scratch[0] - t_i;
    t = g->offset; /* the next offsets are now the offsets */
    g->offset = g->offset_next;
    g->offset_next = t;
    g->offset_t = g->scratch[0];
    return 1;
}

/* The paper's ghost update, after a step: blend every queued snapshot once
   with the local state, then empty the queues. One pass over the state
   after the agent's get_state, then its set_state. Returns the peers whose
   divergence it measured (bit p for peer slot p). */
GS__PRIVATE uint32_t gs__ghost_blend(gs__ghost *g, gs_net *net) {
    size_t n = g->n;
    double t_i, num_t = 0.0, den_t = 0.0;
    gs__pass ps;
    uint32_t seen = 0;
    int used;
    gs__lock(net);
    gs_agent_get_state(g->agent, g->local, n);
    t_i = g->local[0];
    memset(&ps, 0, sizeof ps);
    ps.w0 = gs__ghost_weigh(g, t_i, g->wq);
    used = ps.w0 < 0.0 ? 0 : gs__ghost_gather(g, t_i, &num_t, &den_t);
    if (used > 0) {
        /* the band applies to the gap to the others (their weighted mean
           time), not to the correction, which is only part of it: otherwise
           two hosts would settle up to (1 + w0 / w) bands apart */
        g->scratch[0] = t_i;
        if (den_t > 0.0)
            g->scratch[0] += gs__time_correction(g, num_t / den_t, num_t / (ps.w0 + den_t));
        ps.fade = gs__offset_fade(g, g->scratch[0]);
        ps.finite = g->scratch[0] - g->scratch[0] == 0.0;
        ps.finite = gs__blend_pass(g, &ps);
        seen = gs__ghost_divergence(g);
        if (ps.finite && gs__blend_apply(g, t_i)) {
            double c2 = (ps.corr2[0] + ps.corr2[1]) + (ps.corr2[2] + ps.corr2[3]);
            g->stats.blends++;
            g->stats.snapshots_blended += (uint64_t)used;
            g->stats.last_correction = n > 1 ? sqrt(c2 / (double)(n - 1)) : 0.0;
        }
    }
    gs__ghost_clear(g);
    gs__unlock(net);
    return seen;
}

/* Any snapshot waiting? Read under the lock by the caller. */
GS__PRIVATE int gs__ghost_pending(const gs__ghost *g) {
    int p, k;
    for (p = 0; p < GS__MAX_PEERS; ++p)
        for (k = 0; g->q[p] && k < g->d.queue_size; ++k)
            if (g->q[p][k].used) return 1;
    return 0;
}

/* After a step: publish, and if a snapshot waits for this ghost, every
   ghost of the world blends what waits for it, at once (gs__world_blend).
   Blended one agent at a time, as each one steps, the snapshots of one
   remote moment landed at different moments here: a sphere copied onto a
   cloth that was not copied yet sank a millimetre into it and was thrown
   at 4 m/s, and the cloth it dented threw the next copy too (measured
   between two ghostpeer processes, for seconds on end). */
GS__PRIVATE void gs__ghost_after_step(gs_agent *a) {
    gs__ghost *g = gs__ghost_of(a);
    gs_net *net = a->world->net;
    int pending;
    gs__ghost_publish(g, net);
    if (!net) return;
    gs__lock(net);
    g->t_local = gs__agent_time(a);
    pending = gs__ghost_pending(g);
    gs__unlock(net);
    if (pending) gs__world_blend(a->world);
}

/* A peer's divergence is the largest over the world's objects: taken once
   per peer after every ghost has blended (per snapshot, it made a world
   blend O(agents^2)). */
GS__PRIVATE void gs__world_blend(gs_world *w) {
    uint32_t seen = 0;
    int i, pending;
    if (!w->net) return;
    for (i = 0; i < w->agent_count; ++i) {
        gs__ghost *g = gs__ghost_of(w->agents[i]);
        if (!g || w->agents[i]->failed) continue;
        gs__lock(w->net);
        pending = gs__ghost_pending(g);
        gs__unlock(w->net);
        if (pending) seen |= gs__ghost_blend(g, w->net);
    }
    if (!seen) return;
    gs__lock(w->net);
    for (i = 0; i < GS__MAX_PEERS; ++i)
        if (seen & ((uint32_t)1 << i)) w->net->peers[i].st.divergence = gs__peer_divergence(w, i);
    gs__unlock(w->net);
}

/* ========================================================================
   >>wire
   ======================================================================== */
/* CRC-32 (IEEE 802.3, reflected 0xEDB88320) */
static const uint32_t gs__crc_table[256] = {
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
};

GS__PRIVATE uint32_t gs__crc32(const unsigned char *p, size_t n) {
    uint32_t c = 0xffffffffu;
    size_t i;
    for (i = 0; i < n; ++i) c = gs__crc_table[(c ^ p[i]) & 0xffu] ^ (c >> 8);
    return c ^ 0xffffffffu;
}

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
GS__PRIVATE uint64_t gs__get64(const unsigned char *p) {
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

GS_API gs_result gs_wire_begin(unsigned char *buf, size_t cap,
                               const gs_wire_header *h, size_t *size) {
    if (!buf || !h || !size || cap < GS_WIRE_HEADER + 4) return GS_ERR_INVALID_ARG;
    memcpy(buf, "GSIM", 4);
    buf[4] = GS_WIRE_VERSION;
    buf[5] = 0;
    gs__put16(buf + 6, 0);
    gs__put32(buf + 8, h->session);
    gs__put32(buf + 12, h->sender);
    gs__put32(buf + 16, h->sequence);
    gs__put32(buf + 20, 0);
    gs__putf64(buf + 24, h->send_time);
    gs__putf64(buf + 32, h->echo_time);
    gs__putf64(buf + 40, h->echo_hold);
    *size = GS_WIRE_HEADER;
    return GS_OK;
}

GS_API gs_result gs_wire_add(unsigned char *buf, size_t cap, size_t *size,
                             const gs_wire_chunk *c, const double *values) {
    size_t vs, need;
    unsigned char *p;
    int i;
    if (!buf || !size || !c || (c->elements && !values)) return GS_ERR_INVALID_ARG;
    if (c->encoding != GS_ENCODING_F64 && c->encoding != GS_ENCODING_F32)
        return GS_ERR_INVALID_ARG;
    if (gs__get16(buf + 6) >= GS_WIRE_MAX_CHUNKS) return GS_ERR_CAPACITY;
    vs = gs__value_size(c->encoding);
    need = GS_WIRE_CHUNK_HEADER + vs * c->elements;
    if (*size + need + 4 > cap || *size + need + 4 > GS_WIRE_MAX_DATAGRAM) return GS_ERR_CAPACITY;
    if (!gs__finite(c->time)) return GS_ERR_NOT_FINITE;
    for (i = 0; i < c->elements; ++i) /* f32 holds up to 3.4e38: past it, inf */
        if (!gs__finite(values[i]) ||
            (c->encoding == GS_ENCODING_F32 && fabs(values[i]) > 3.4028234663852886e38))
            return GS_ERR_NOT_FINITE;
    p = buf + *size;
    gs__put32(p, c->object_id);
    gs__put32(p + 4, c->sequence);
    gs__putf64(p + 8, c->time);
    gs__put16(p + 16, c->index);
    gs__put16(p + 18, c->count);
    gs__put32(p + 20, c->first);
    gs__put16(p + 24, c->elements);
    p[26] = (unsigned char)c->encoding;
    p[27] = 0;
    gs__put32(p + 28, 0);
    p += GS_WIRE_CHUNK_HEADER;
    for (i = 0; i < c->elements; ++i, p += vs) {
        if (c->encoding == GS_ENCODING_F32) gs__putf32(p, (float)values[i]);
        else gs__putf64(p, values[i]);
    }
    *size += need;
    gs__put16(buf + 6, (uint16_t)(gs__get16(buf + 6) + 1));
    return GS_OK;
}

GS_API size_t gs_wire_end(unsigned char *buf, size_t size) {
    gs__put32(buf + size, gs__crc32(buf, size));
    return size + 4;
}

GS_API double gs_wire_value(const gs_wire_chunk *c, int i) {
    if (c->encoding == GS_ENCODING_F32) return (double)gs__getf32(c->payload + 4 * (size_t)i);
    return gs__getf64(c->payload + 8 * (size_t)i);
}

/* One chunk at *off: its header, its length, its values all finite. */
GS__PRIVATE int gs__wire_chunk(const unsigned char *buf, size_t end, size_t *off,
                               gs_wire_chunk *c, gs_reject *why) {
    const unsigned char *p = buf + *off;
    size_t len;
    int i;
    if (*off + GS_WIRE_CHUNK_HEADER > end) { *why = GS_REJECT_SHORT; return 0; }
    c->object_id = gs__get32(p);
    c->sequence = gs__get32(p + 4);
    c->time = gs__getf64(p + 8);
    c->index = gs__get16(p + 16);
    c->count = gs__get16(p + 18);
    c->first = gs__get32(p + 20);
    c->elements = gs__get16(p + 24);
    c->encoding = (gs_encoding)p[26];
    if ((c->encoding != GS_ENCODING_F64 && c->encoding != GS_ENCODING_F32) ||
        c->count == 0 || c->index >= c->count) { *why = GS_REJECT_LAYOUT; return 0; }
    len = gs__value_size(c->encoding) * c->elements;
    if (*off + GS_WIRE_CHUNK_HEADER + len > end) { *why = GS_REJECT_SHORT; return 0; }
    if (!gs__finite(c->time) || c->time < 0.0) { *why = GS_REJECT_TIME; return 0; }
    c->payload = p + GS_WIRE_CHUNK_HEADER;
    for (i = 0; i < c->elements; ++i)
        if (!gs__finite(gs_wire_value(c, i))) { *why = GS_REJECT_NOT_FINITE; return 0; }
    *off += GS_WIRE_CHUNK_HEADER + len;
    return 1;
}

/* The checks that need neither the checksum, the key nor the payload:
   size, magic, version. */
GS__PRIVATE int gs__wire_front(const unsigned char *buf, size_t size, gs_reject *why) {
    if (!buf || size < GS_WIRE_HEADER + 4) { *why = GS_REJECT_SHORT; return 0; }
    if (size > GS_WIRE_MAX_DATAGRAM) { *why = GS_REJECT_LAYOUT; return 0; }
    if (memcmp(buf, "GSIM", 4) != 0) { *why = GS_REJECT_MAGIC; return 0; }
    if (buf[4] != GS_WIRE_VERSION) { *why = GS_REJECT_VERSION; return 0; }
    return 1;
}

/* The header's fields and the chunks in [GS_WIRE_HEADER, end) of a
   datagram in clear (checked or opened). */
GS__PRIVATE int gs__wire_parse(const unsigned char *buf, size_t end, gs_wire_view *out,
                               gs_reject *why) {
    size_t off = GS_WIRE_HEADER;
    int i, n = gs__get16(buf + 6);
    if (n < 1 || n > GS_WIRE_MAX_CHUNKS) { *why = GS_REJECT_LAYOUT; return 0; }
    out->header.session = gs__get32(buf + 8);
    out->header.sender = gs__get32(buf + 12);
    out->header.sequence = gs__get32(buf + 16);
    out->header.send_time = gs__getf64(buf + 24);
    out->header.echo_time = gs__getf64(buf + 32);
    out->header.echo_hold = gs__getf64(buf + 40);
    if (!gs__finite(out->header.send_time) || !gs__finite(out->header.echo_time) ||
        !gs__finite(out->header.echo_hold)) { *why = GS_REJECT_NOT_FINITE; return 0; }
    for (i = 0; i < n; ++i)
        if (!gs__wire_chunk(buf, end, &off, &out->chunks[i], why)) return 0;
    if (off != end) { *why = GS_REJECT_LAYOUT; return 0; }
    out->chunk_count = n;
    return 1;
}

GS_API int gs_wire_decode(const unsigned char *buf, size_t size,
                          gs_wire_view *out, gs_reject *why) {
    gs_reject dummy;
    size_t end;
    if (!why) why = &dummy;
    if (!out) { *why = GS_REJECT_SHORT; return 0; }
    if (!gs__wire_front(buf, size, why)) return 0;
    end = size - 4;
    if (gs__crc32(buf, end) != gs__get32(buf + end)) { *why = GS_REJECT_CHECKSUM; return 0; }
    if (buf[5] != 0) { *why = GS_REJECT_LAYOUT; return 0; } /* sealed or unknown */
    return gs__wire_parse(buf, end, out, why);
}

/* The nonce of a sealed datagram: run epoch, run salt, counter. */
GS__PRIVATE void gs__wire_nonce(unsigned char *p, uint64_t epoch, uint64_t salt,
                                uint64_t counter) {
    gs__put64(p, epoch);
    gs__put64(p + 8, salt);
    gs__put64(p + 16, counter);
}

#ifdef GHOSTSIM_SODIUM
/* Seals a datagram of `size` bytes (header and chunks, no CRC; cap leaves
   room for the trailer): the flag, the chunks encrypted in place, the
   nonce and the tag. Returns the sealed size. */
GS__PRIVATE size_t gs__wire_seal(unsigned char *buf, size_t size, const unsigned char *key,
                                 uint64_t epoch, uint64_t salt, uint64_t counter) {
    unsigned long long taglen = 0;
    buf[5] |= GS_WIRE_FLAG_SEALED; /* before: the header is authenticated */
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
#else
    (void)net;
#endif
}

GS__PRIVATE gs_result gs__ghost_queues(gs__ghost *g) {
    gs_net *net = g->agent->world->net;
    int p;
    if (!net) return GS_OK;
    for (p = 0; p < GS__MAX_PEERS; ++p)
        if (net->peers[p].used) {
            gs_result r = gs__ghost_add_peer(g, p);
            if (r != GS_OK) return r;
        }
    return GS_OK;
}

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
    if (d.session == 0) d.session = 1;
    if (d.bandwidth == 0.0) d.bandwidth = 1e7;
    if (d.max_peers == 0) d.max_peers = GS__MAX_PEERS;
    if (d.max_rate == 0.0 && gs__finite(d.bandwidth))
        d.max_rate = fmax(20000.0, 2.0 * d.bandwidth / GS_WIRE_MAX_DATAGRAM);
    if (!d.send) gs__check_fail(&c, GS_ERR_INVALID_ARG, "send is NULL");
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
    if (d.key) gs__net_keep_key(net, d.key);
    w->net = net;
    *out = net;
    return GS_OK;
}

GS_API void gs_net_destroy(gs_net *net) {
    gs_world *w;
    int i, p;
    if (!net) return;
    w = net->world;
    for (i = 0; i < w->agent_count; ++i) { /* queues belong to peers */
        gs__ghost *g = gs__ghost_of(w->agents[i]);
        for (p = 0; g && p < GS__MAX_PEERS; ++p) {
            gs__free(w, g->q[p]);
            g->q[p] = NULL;
        }
    }
    w->net = NULL;
    gs__net_forget_key(net);
    gs__free(w, net);
}

GS_API gs_net *gs_world_net(const gs_world *w) { return w->net; }

GS_API void gs_net_set_lock(gs_net *net, gs_net_lock lock) { net->lock = lock; }

GS__PRIVATE int gs__peer_slot(const gs_net *net, uint32_t host) {
    int p;
    for (p = 0; p < GS__MAX_PEERS; ++p)
        if (net->peers[p].used && net->peers[p].host == host) return p;
    return -1;
}

GS_API gs_result gs_net_add_peer(gs_net *net, uint32_t host) {
    gs_world *w = net->world;
    int p, i, count = 0;
    if (host == 0 || host == w->host_id)
        return gs__fail(w, GS_ERR_INVALID_ARG, "gs_net_add_peer: host %lu is 0 or this host",
                        (unsigned long)host);
    if (gs__peer_slot(net, host) >= 0) return GS_OK;
    for (p = 0; p < GS__MAX_PEERS; ++p) count += net->peers[p].used;
    for (p = 0; p < GS__MAX_PEERS && net->peers[p].used; ++p) {}
    if (p == GS__MAX_PEERS || count >= net->d.max_peers)
        return gs__fail(w, GS_ERR_CAPACITY, "gs_net_add_peer: max_peers (%d) reached",
                        net->d.max_peers);
    for (i = 0; i < w->agent_count; ++i) {
        gs__ghost *g = gs__ghost_of(w->agents[i]);
        if (g && gs__ghost_add_peer(g, p) != GS_OK) return GS_ERR_NO_MEMORY;
    }
    gs__lock(net);
    memset(&net->peers[p], 0, sizeof net->peers[p]);
    net->peers[p].used = 1;
    net->peers[p].host = host;
    net->peers[p].tokens = -1.0; /* filled on first use */
    gs__unlock(net);
    return GS_OK;
}

GS_API gs_result gs_net_remove_peer(gs_net *net, uint32_t host) {
    gs_world *w = net->world;
    int p = gs__peer_slot(net, host), i;
    if (p < 0) return gs__fail(w, GS_ERR_INVALID_ARG, "gs_net_remove_peer: no peer %lu",
                               (unsigned long)host);
    gs__lock(net);
    net->peers[p].used = 0;
    for (i = 0; i < w->agent_count; ++i) {
        gs__ghost *g = gs__ghost_of(w->agents[i]);
        if (!g) continue;
        gs__free(w, g->q[p]);
        g->q[p] = NULL;
    }
    gs__unlock(net);
    return GS_OK;
}

GS_API gs_result gs_net_peer_stats(const gs_net *net, uint32_t host,
                                   gs_peer_stats *out) {
    int p = gs__peer_slot(net, host);
    if (p < 0 || !out) return GS_ERR_INVALID_ARG;
    gs__lock((gs_net *)net);
    *out = net->peers[p].st;
    gs__unlock((gs_net *)net);
    return GS_OK;
}

GS_API gs_result gs_net_unknown_stats(const gs_net *net,
                                      uint64_t rejected[GS_REJECT_COUNT]) {
    gs__lock((gs_net *)net);
    memcpy(rejected, net->unknown_rejected, sizeof net->unknown_rejected);
    gs__unlock((gs_net *)net);
    return GS_OK;
}

/* ---- sending ---- */

/* The budget: a token bucket of bandwidth bytes/s holding at most 50 ms. */
GS__PRIVATE int gs__peer_budget(gs_net *net, gs__peer *pe, size_t bytes, double now) {
    double cap = 0.05 * net->d.bandwidth;
    if (cap < GS_WIRE_MAX_DATAGRAM) cap = GS_WIRE_MAX_DATAGRAM;
    if (pe->tokens < 0.0) { pe->tokens = cap; pe->tokens_at = now; }
    pe->tokens += (now - pe->tokens_at) * net->d.bandwidth;
    pe->tokens_at = now;
    if (pe->tokens > cap) pe->tokens = cap;
    if (pe->tokens < (double)bytes) return 0;
    pe->tokens -= (double)bytes;
    return 1;
}

GS__PRIVATE void gs__datagram_begin(gs_net *net, gs__peer *pe, double now, size_t *size) {
    gs_wire_header h;
    h.session = net->d.session;
    h.sender = net->world->host_id;
    h.sequence = pe->send_seq;
    h.send_time = now;
    h.echo_time = pe->their_send_time;
    h.echo_hold = pe->recv_any ? now - pe->their_recv_now : 0.0;
    gs_wire_begin(net->buf, sizeof net->buf, &h, size);
}

/* Room for chunks in net->buf: a sealed datagram's trailer must fit. */
GS__PRIVATE size_t gs__net_cap(const gs_net *net) {
    return net->guard.keyed ? GS_WIRE_MAX_DATAGRAM - (GS_WIRE_SEAL_TRAILER - 4)
                            : GS_WIRE_MAX_DATAGRAM;
}

/* Ends the datagram in net->buf: the CRC, or sealed. */
GS__PRIVATE size_t gs__datagram_end(gs_net *net, size_t size) {
#ifdef GHOSTSIM_SODIUM
    if (net->guard.keyed)
        return gs__wire_seal(net->buf, size, net->guard.key, net->guard.epoch, net->guard.salt,
                             net->guard.counter++);
#endif
    return gs_wire_end(net->buf, size);
}

/* Sends the datagram being built if it holds a chunk and the budget allows. */
GS__PRIVATE void gs__datagram_flush(gs_net *net, gs__peer *pe, double now, size_t *size) {
    size_t n;
    if (gs__get16(net->buf + 6) == 0) return;
    n = *size + (net->guard.keyed ? GS_WIRE_SEAL_TRAILER : 4);
    if (gs__peer_budget(net, pe, n, now)) {
        n = gs__datagram_end(net, *size);
        pe->send_seq++;
        pe->st.datagrams_sent++;
        pe->st.bytes_sent += n;
        net->d.send(net->d.send_user, pe->host, net->buf, n);
    }
    gs__datagram_begin(net, pe, now, size);
}

/* Appends every chunk of a ghost's B to the datagrams for one peer. */
GS__PRIVATE void gs__send_ghost(gs_net *net, gs__peer *pe, const gs__ghost *g,
                                double now, size_t *size) {
    size_t vars = g->n - 1;
    int c;
    for (c = 0; c < g->nchunks; ++c) {
        gs_wire_chunk ch;
        size_t first = (size_t)c * (size_t)g->per_chunk, cnt = (size_t)g->per_chunk;
        if (first + cnt > vars) cnt = vars - first;
        ch.object_id = g->d.object_id;
        ch.sequence = g->b_seq;
        ch.time = g->B[0];
        ch.index = (uint16_t)c;
        ch.count = (uint16_t)g->nchunks;
        ch.first = (uint32_t)first;
        ch.elements = (uint16_t)cnt;
        ch.encoding = g->d.encoding;
        ch.payload = NULL;
        if (gs_wire_add(net->buf, gs__net_cap(net), size, &ch, g->B + 1 + first) ==
            GS_ERR_CAPACITY) {
            gs__datagram_flush(net, pe, now, size);
            gs_wire_add(net->buf, gs__net_cap(net), size, &ch, g->B + 1 + first);
        }
    }
    pe->st.snapshots_sent++;
}

GS_API gs_result gs_net_update(gs_net *net, double now) {
    gs_world *w = net->world;
    int p, i;
    if (!gs__finite(now)) return GS_ERR_NOT_FINITE;
    gs__lock(net);
    net->now = now;
    for (p = 0; p < GS__MAX_PEERS; ++p) {
        gs__peer *pe = &net->peers[p];
        size_t size;
        if (!pe->used) continue;
        gs__datagram_begin(net, pe, now, &size);
        for (i = 0; i < w->agent_count; ++i) {
            gs__ghost *g = gs__ghost_of(w->agents[i]);
            if (g && now >= g->next_send && g->b_seq != g->sent_seq)
                gs__send_ghost(net, pe, g, now, &size);
        }
        gs__datagram_flush(net, pe, now, &size);
    }
    for (i = 0; i < w->agent_count; ++i) {
        gs__ghost *g = gs__ghost_of(w->agents[i]);
        if (!g || now < g->next_send || g->b_seq == g->sent_seq) continue;
        g->sent_seq = g->b_seq;
        g->next_send = now + 1.0 / g->d.send_rate;
    }
    gs__unlock(net);
    return GS_OK;
}

/* ---- receiving ---- */

/* Wrap-safe: a is newer than b. */
GS__PRIVATE int gs__seq_newer(uint32_t a, uint32_t b) {
    return (int32_t)(a - b) > 0;
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
   anything is queued, so that a datagram counts whole or not at all. */
GS__PRIVATE int gs__chunks_fit(gs_net *net, const gs_wire_view *v, double now,
                               gs_reject *why) {
    int i;
    (void)now;
    for (i = 0; i < v->chunk_count; ++i) {
        const gs_wire_chunk *c = &v->chunks[i];
        const gs__ghost *g = gs__ghost_find(net->world, c->object_id);
        if (!g) { *why = GS_REJECT_OBJECT; return 0; }
        size_t first = (size_t)c->index * (size_t)g->per_chunk;
        size_t want = first < g->n - 1 ? g->n - 1 - first : 0;
        if (want > (size_t)g->per_chunk) want = (size_t)g->per_chunk;
        /* chunk i holds exactly values [i per_chunk, its end): anything else
           would leave part of its range unfilled but marked received */
        if (c->count != g->nchunks || c->encoding != g->d.encoding ||
            c->first != first || c->elements != want) {
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
    gs__snap *q = g->q[p], *free_s = NULL, *oldest = NULL;
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
    return free_s;
}

GS__PRIVATE void gs__queue_chunk(gs_net *net, int p, const gs_wire_chunk *c, double age) {
    gs__ghost *g = gs__ghost_find(net->world, c->object_id);
    gs__snap *s = gs__snap_slot(g, p, c, age);
    int i;
    if (s->got[c->index]) return; /* a duplicated chunk */
    for (i = 0; i < c->elements; ++i) s->data[c->first + (uint32_t)i] = gs_wire_value(c, i);
    s->got[c->index] = 1;
    s->chunks++;
    net->peers[p].st.chunks_received++;
    if (c->index == 0) net->peers[p].st.snapshots_received++;
    if (c->time > net->peers[p].st.last_remote_time) net->peers[p].st.last_remote_time = c->time;
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
   round trip, and every snapshot's age, look up to a latency longer. */
GS__PRIVATE void gs__peer_clock(gs__peer *pe, const gs_wire_header *h, double now) {
    if (h->echo_time > 0.0) {
        double rtt = now - h->echo_time - h->echo_hold;
        if (rtt >= 0.0 && rtt < 60.0)
            pe->st.rtt = pe->st.rtt > 0.0 ? 0.875 * pe->st.rtt + 0.125 * rtt : rtt;
    }
    pe->their_send_time = h->send_time;
    pe->their_recv_now = now;
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
    if (session != net->d.session) { *why = GS_REJECT_SESSION; return 0; }
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
    if (buf[5] & ~GS_WIRE_FLAG_SEALED) { *why = GS_REJECT_LAYOUT; return 0; }
    if ((buf[5] & GS_WIRE_FLAG_SEALED) && size < GS_WIRE_HEADER + GS_WIRE_SEAL_TRAILER) {
        *why = GS_REJECT_SHORT;
        return 0;
    }
    if (!gs__receive_sender(net, gs__get32(buf + 8), gs__get32(buf + 12), p, why)) return 0;
    if (!(buf[5] & GS_WIRE_FLAG_SEALED)) { *why = GS_REJECT_KEY; return 0; }
    epoch = gs__get64(nonce);
    salt = gs__get64(nonce + 8);
    counter = gs__get64(nonce + 16);
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
    return gs__wire_parse(net->guard.plain, size - GS_WIRE_SEAL_TRAILER, &net->view, why);
}

/* Everything up to a decoded datagram from a known peer (*p, -1 while the
   sender is not known). */
GS__PRIVATE int gs__receive(gs_net *net, const unsigned char *buf, size_t size, int *p,
                            gs_reject *why) {
    if (!gs__wire_front(buf, size, why)) return 0;
    if (net->guard.keyed) return gs__receive_sealed(net, buf, size, p, why);
    if (!gs_wire_decode(buf, size, &net->view, why)) return 0;
    return gs__receive_sender(net, net->view.header.session, net->view.header.sender, p, why);
}

/* gs_net_deliver under the net lock. */
GS__PRIVATE gs_result gs__deliver_locked(gs_net *net, const void *data, size_t size, double now,
                                         gs_reject *why) {
    gs_wire_view *v = &net->view;
    gs_reject r = GS_REJECT_SHORT;
    gs_result res = GS_OK;
    int p = -1, i, order;
    if (!gs__receive(net, (const unsigned char *)data, size, &p, &r)) {
        res = gs__reject(net, p, r, why);
    } else if (!gs__chunks_fit(net, v, now, &r)) {
        res = gs__reject(net, p, r, why);
    } else if ((order = gs__peer_sequence(&net->peers[p], v->header.sequence)) == 0) {
        net->peers[p].st.duplicates++;
        res = gs__reject(net, p, GS_REJECT_DUPLICATE, why);
    } else if (!gs__peer_rate(net, &net->peers[p], now)) {
        res = gs__reject(net, p, GS_REJECT_RATE, why);
    } else {
        gs__peer *pe = &net->peers[p];
        /* as known before this datagram; -1: no round trip yet */
        double age = pe->st.rtt > 0.0 ? 0.5 * pe->st.rtt : -1.0;
        if (order == 2) gs__peer_clock(pe, &v->header, now);
        pe->st.datagrams_received++;
        pe->st.bytes_received += size;
        for (i = 0; i < v->chunk_count; ++i) gs__queue_chunk(net, p, &v->chunks[i], age);
    }
    return res;
}

GS_API gs_result gs_net_deliver(gs_net *net, const void *data, size_t size,
                                double now, gs_reject *why) {
    gs_result r;
    gs__lock(net);
    r = gs__deliver_locked(net, data, size, now, why);
    gs__unlock(net);
    return r;
}

/* A refusal decided by the transport (the UDP allow-list): counted on the
   peer named `host`, or among the unknown ones. Call under the net lock. */
GS__PRIVATE void gs__net_refuse(gs_net *net, uint32_t host, gs_reject r) {
    gs__reject(net, gs__peer_slot(net, host), r, NULL);
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

typedef struct gs__sim_host {
    gs_simnet *sim;
    gs_world *world;
    gs_net *net;
    uint32_t host;
    double busy_until[GS__SIM_MAX_HOSTS]; /* bandwidth: link free again at */
} gs__sim_host;

struct gs_simnet {
    gs_allocator alloc;
    uint64_t rng;
    double now;
    int hosts;
    gs__sim_host host[GS__SIM_MAX_HOSTS];
    gs_link_desc link[GS__SIM_MAX_HOSTS][GS__SIM_MAX_HOSTS];
    gs__flight *heap;   /* a binary min-heap on (at, order) */
    unsigned char *pool;
    int *free_slots, nfree;
    int count, cap;
    uint64_t order, dropped, duplicated, delivered;
};

/* xorshift64*: one stream for the whole simnet, so a seed fixes the run. */
GS__PRIVATE double gs__sim_rand(gs_simnet *s) {
    s->rng ^= s->rng >> 12;
    s->rng ^= s->rng << 25;
    s->rng ^= s->rng >> 27;
    return (double)((s->rng * 2685821657736338717ull) >> 11) / 9007199254740992.0;
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
    if (d.seed == 0) d.seed = 1;
    if (d.max_in_flight == 0) d.max_in_flight = 16384;
    if (d.max_in_flight < 1 || d.max_in_flight > (1 << 22)) return GS_ERR_INVALID_ARG;
    if (!d.allocator.alloc != !d.allocator.free) return GS_ERR_INVALID_ARG;
    if (!d.allocator.alloc) { d.allocator.alloc = gs__default_alloc; d.allocator.free = gs__default_free; }
    bytes = sizeof *s + (size_t)d.max_in_flight * (sizeof(gs__flight) + sizeof(int) + GS_WIRE_MAX_DATAGRAM);
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

GS_API void gs_simnet_destroy(gs_simnet *s) {
    if (s) s->alloc.free(s, s->alloc.user);
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
        if (s->host[i].host == host) return i;
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
    if (to < 0 || size > GS_WIRE_MAX_DATAGRAM) return GS_ERR_INVALID_ARG;
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

GS_API gs_result gs_simnet_join(gs_simnet *s, gs_world *w, const gs_net_desc *desc,
                                gs_net **out) {
    gs_net_desc d;
    gs__sim_host *h;
    gs_result r;
    int i;
    if (!s || !w || !out) return GS_ERR_INVALID_ARG;
    *out = NULL;
    if (s->hosts == GS__SIM_MAX_HOSTS || gs__sim_slot(s, w->host_id) >= 0)
        return gs__fail(w, GS_ERR_INVALID_ARG, "gs_simnet_join: host %lu already joined or "
                        "the simnet is full", (unsigned long)w->host_id);
    memset(&d, 0, sizeof d);
    if (desc) d = *desc;
    h = &s->host[s->hosts];
    memset(h, 0, sizeof *h);
    h->sim = s;
    h->world = w;
    h->host = w->host_id;
    d.send = gs__sim_send;
    d.send_user = h;
    r = gs_net_create(w, &d, &h->net);
    if (r != GS_OK) return r;
    for (i = 0; i < s->hosts; ++i) {
        memset(&s->link[i][s->hosts], 0, sizeof(gs_link_desc));
        memset(&s->link[s->hosts][i], 0, sizeof(gs_link_desc));
        if (gs_net_add_peer(h->net, s->host[i].host) != GS_OK ||
            gs_net_add_peer(s->host[i].net, h->host) != GS_OK) {
            gs_net_destroy(h->net);
            return GS_ERR_NO_MEMORY;
        }
    }
    s->hosts++;
    *out = h->net;
    return GS_OK;
}

GS_API gs_result gs_simnet_link(gs_simnet *s, uint32_t a, uint32_t b,
                                const gs_link_desc *desc) {
    int i = gs__sim_slot(s, a), j = gs__sim_slot(s, b), k;
    if (i < 0 || j < 0 || !desc) return GS_ERR_INVALID_ARG;
    if (!(desc->latency >= 0.0) || !(desc->jitter >= 0.0) || !(desc->loss >= 0.0) ||
        !(desc->loss <= 1.0) || !(desc->duplicate >= 0.0) || !(desc->duplicate <= 1.0) ||
        !(desc->reorder >= 0.0) || !(desc->reorder <= 1.0) || !(desc->bandwidth >= 0.0) ||
        !gs__finite(desc->latency + desc->jitter + desc->bandwidth))
        return GS_ERR_INVALID_ARG;
    for (k = 0; k < GS_MAX_OUTAGES; ++k)
        if (!gs__finite(desc->outage_start[k]) || !gs__finite(desc->outage_end[k]))
            return GS_ERR_NOT_FINITE;
    s->link[i][j] = *desc;
    return GS_OK;
}

GS__PRIVATE void gs__sim_deliver_due(gs_simnet *s) {
    while (s->count > 0 && s->heap[0].at <= s->now) {
        gs__flight f = gs__heap_pop(s);
        gs__sim_host *to = &s->host[f.to];
        gs_net_deliver(to->net, f.data, f.size, s->now, NULL);
        s->free_slots[s->nfree++] = (int)((f.data - s->pool) / GS_WIRE_MAX_DATAGRAM);
        s->delivered++;
    }
}

GS_API gs_result gs_simnet_run(gs_simnet *s, double seconds, double frame) {
    double end;
    gs_result first = GS_OK;
    int i;
    if (!s || !gs__finite(seconds) || seconds < 0.0 || !gs__finite(frame) || frame <= 0.0)
        return GS_ERR_INVALID_ARG;
    end = s->now + seconds;
    while (s->now < end - 0.5 * frame) {
        s->now += frame;
        for (i = 0; i < s->hosts; ++i) {
            gs_result r = gs_world_advance(s->host[i].world, frame, NULL);
            if (r != GS_OK && first == GS_OK) first = r;
            gs_net_update(s->host[i].net, s->now);
        }
        gs__sim_deliver_due(s);
    }
    return first;
}

GS_API double gs_simnet_time(const gs_simnet *s) { return s->now; }

GS_API void gs_simnet_counts(const gs_simnet *s, uint64_t *dropped,
                             uint64_t *duplicated, uint64_t *delivered) {
    if (dropped) *dropped = s->dropped;
    if (duplicated) *duplicated = s->duplicated;
    if (delivered) *delivered = s->delivered;
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
#include <poll.h>
#include <pthread.h>
#include <sys/socket.h>
#include <unistd.h>
#endif

typedef struct gs__udp_peer {
    int used;
    uint32_t host;
    struct sockaddr_storage addr;
    socklen_t len;
} gs__udp_peer;

struct gs_udp {
    gs_world *world;
    gs_net *net;
    int fd;
    int threads;
    int stop;
    pthread_t gather, scatter;
    pthread_mutex_t mu;      /* the net lock: queues, peers, stats */
    pthread_mutex_t wake_mu; /* the scatter thread's wake-up */
    pthread_cond_t wake;
    gs__udp_peer peers[GS__MAX_PEERS];
    unsigned char rbuf[GS_WIRE_MAX_DATAGRAM + 64];
};

GS_API double gs_udp_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

GS__PRIVATE void gs__udp_lock(void *user) { pthread_mutex_lock(&((gs_udp *)user)->mu); }
GS__PRIVATE void gs__udp_unlock(void *user) { pthread_mutex_unlock(&((gs_udp *)user)->mu); }

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
    memset(&hints, 0, sizeof hints);
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_DGRAM;
    if (*port == '\0' || getaddrinfo(host, port, &hints, &res) != 0 || !res) return 0;
    memcpy(out, res->ai_addr, res->ai_addrlen);
    *len = (socklen_t)res->ai_addrlen;
    freeaddrinfo(res);
    return 1;
}

/* The transport's send: called by gs_net_update under the net lock. */
GS__PRIVATE gs_result gs__udp_send(void *user, uint32_t host, const void *data,
                                   size_t size) {
    gs_udp *u = (gs_udp *)user;
    int p;
    for (p = 0; p < GS__MAX_PEERS; ++p)
        if (u->peers[p].used && u->peers[p].host == host) {
            ssize_t r = sendto(u->fd, data, size, 0, (const struct sockaddr *)&u->peers[p].addr,
                               u->peers[p].len);
            return r == (ssize_t)size ? GS_OK : GS_ERR_SYSTEM;
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
    host = gs__get32(u->rbuf + 12);
    for (p = 0; p < GS__MAX_PEERS && !found; ++p)
        if (u->peers[p].used && u->peers[p].host == host) {
            found = 1;
            ok = gs__udp_same_addr(&u->peers[p].addr, from);
        }
    if (!found) ok = gs__peer_slot(u->net, host) < 0;
    if (!ok) gs__net_refuse(u->net, host, GS_REJECT_ADDRESS);
    return ok;
}

/* Receives what is waiting (at most `max`, without blocking). */
GS__PRIVATE void gs__udp_drain(gs_udp *u, int max) {
    int i;
    for (i = 0; i < max; ++i) {
        struct sockaddr_storage from;
        socklen_t flen = sizeof from;
        ssize_t n;
        memset(&from, 0, sizeof from);
        n = recvfrom(u->fd, u->rbuf, sizeof u->rbuf, MSG_DONTWAIT, (struct sockaddr *)&from, &flen);
        if (n < 0) break;
        pthread_mutex_lock(&u->mu); /* the net lock: one for both */
        if (gs__udp_from_ok(u, (size_t)n, &from))
            gs__deliver_locked(u->net, u->rbuf, (size_t)n, gs_udp_now(), NULL);
        pthread_mutex_unlock(&u->mu);
    }
}

/* The paper's gather thread: receive, validate, queue. */
GS__PRIVATE void *gs__udp_gather(void *arg) {
    gs_udp *u = (gs_udp *)arg;
    while (!__atomic_load_n(&u->stop, __ATOMIC_ACQUIRE)) {
        struct pollfd pfd;
        pfd.fd = u->fd;
        pfd.events = POLLIN;
        pfd.revents = 0;
        if (poll(&pfd, 1, 20) > 0) gs__udp_drain(u, 256);
    }
    return NULL;
}

/* The paper's scatter thread: sends what is due, every millisecond or when
   woken by gs_udp_poll. */
GS__PRIVATE void *gs__udp_scatter(void *arg) {
    gs_udp *u = (gs_udp *)arg;
    while (!__atomic_load_n(&u->stop, __ATOMIC_ACQUIRE)) {
        struct timespec until;
        clock_gettime(CLOCK_REALTIME, &until);
        until.tv_nsec += 1000000;
        if (until.tv_nsec >= 1000000000) { until.tv_sec++; until.tv_nsec -= 1000000000; }
        pthread_mutex_lock(&u->wake_mu);
        if (!__atomic_load_n(&u->stop, __ATOMIC_ACQUIRE))
            pthread_cond_timedwait(&u->wake, &u->wake_mu, &until);
        pthread_mutex_unlock(&u->wake_mu);
        gs_net_update(u->net, gs_udp_now());
    }
    return NULL;
}

GS__PRIVATE gs_result gs__udp_socket(gs_udp *u, const gs_udp_desc *d) {
    struct sockaddr_storage addr;
    socklen_t len;
    int rcv = d->rcvbuf ? d->rcvbuf : 4 << 20;
    if (!gs__udp_resolve(d->bind, &addr, &len))
        return gs__fail(u->world, GS_ERR_INVALID_ARG, "gs_udp_open: bind address \"%s\" is "
                        "not HOST:PORT or [IPV6]:PORT", d->bind ? d->bind : "(null)");
    u->fd = socket(addr.ss_family, SOCK_DGRAM, 0);
    if (u->fd < 0)
        return gs__fail(u->world, GS_ERR_SYSTEM, "gs_udp_open: socket: %s", strerror(errno));
    setsockopt(u->fd, SOL_SOCKET, SO_RCVBUF, &rcv, sizeof rcv);
    if (bind(u->fd, (const struct sockaddr *)&addr, len) != 0) {
        gs_result r = gs__fail(u->world, GS_ERR_SYSTEM, "gs_udp_open: bind %s: %s", d->bind,
                               strerror(errno));
        close(u->fd);
        u->fd = -1;
        return r;
    }
    return GS_OK;
}

GS__PRIVATE gs_result gs__udp_start(gs_udp *u) {
    if (pthread_create(&u->gather, NULL, gs__udp_gather, u) != 0)
        return gs__fail(u->world, GS_ERR_SYSTEM, "gs_udp_open: cannot start the gather thread");
    if (pthread_create(&u->scatter, NULL, gs__udp_scatter, u) != 0) {
        __atomic_store_n(&u->stop, 1, __ATOMIC_RELEASE);
        pthread_join(u->gather, NULL);
        return gs__fail(u->world, GS_ERR_SYSTEM, "gs_udp_open: cannot start the scatter thread");
    }
    return GS_OK;
}

GS_API gs_result gs_udp_open(gs_world *w, const gs_udp_desc *desc, gs_udp **out) {
    gs_net_desc nd;
    gs_net_lock lk;
    gs_udp *u;
    gs_result r;
    if (!w || !desc || !out) return GS_ERR_INVALID_ARG;
    *out = NULL;
    u = (gs_udp *)gs__alloc(w, sizeof *u);
    if (!u) return gs__fail(w, GS_ERR_NO_MEMORY, "gs_udp_open: out of memory");
    memset(u, 0, sizeof *u);
    u->world = w;
    u->threads = desc->threads;
    pthread_mutex_init(&u->mu, NULL);
    pthread_mutex_init(&u->wake_mu, NULL);
    pthread_cond_init(&u->wake, NULL);
    r = gs__udp_socket(u, desc);
    nd = desc->net;
    nd.send = gs__udp_send;
    nd.send_user = u;
    if (r == GS_OK) r = gs_net_create(w, &nd, &u->net);
    if (r == GS_OK) {
        lk.lock = gs__udp_lock;
        lk.unlock = gs__udp_unlock;
        lk.user = u;
        gs_net_set_lock(u->net, lk);
        if (u->threads) r = gs__udp_start(u);
    }
    if (r != GS_OK) {
        if (u->net) gs_net_destroy(u->net);
        if (u->fd > 0) close(u->fd);
        pthread_cond_destroy(&u->wake);
        pthread_mutex_destroy(&u->wake_mu);
        pthread_mutex_destroy(&u->mu);
        gs__free(w, u);
        return r;
    }
    *out = u;
    return GS_OK;
}

GS_API void gs_udp_close(gs_udp *u) {
    gs_world *w;
    if (!u) return;
    w = u->world;
    if (u->threads) {
        __atomic_store_n(&u->stop, 1, __ATOMIC_RELEASE);
        pthread_mutex_lock(&u->wake_mu);
        pthread_cond_signal(&u->wake);
        pthread_mutex_unlock(&u->wake_mu);
        pthread_join(u->gather, NULL);
        pthread_join(u->scatter, NULL);
    }
    gs_net_destroy(u->net);
    close(u->fd);
    pthread_cond_destroy(&u->wake);
    pthread_mutex_destroy(&u->wake_mu);
    pthread_mutex_destroy(&u->mu);
    gs__free(w, u);
}

GS_API gs_net *gs_udp_net(gs_udp *u) { return u->net; }

GS_API gs_result gs_udp_add_peer(gs_udp *u, uint32_t host, const char *addr) {
    struct sockaddr_storage a;
    socklen_t len;
    int p, slot = -1, was_new = 0;
    gs_result r;
    if (!gs__udp_resolve(addr, &a, &len))
        return gs__fail(u->world, GS_ERR_INVALID_ARG, "gs_udp_add_peer: address \"%s\" is not "
                        "HOST:PORT or [IPV6]:PORT", addr ? addr : "(null)");
    /* the address first, then the net: a datagram in between is refused
       as from an unknown sender, never taken from the wrong address */
    pthread_mutex_lock(&u->mu);
    for (p = 0; p < GS__MAX_PEERS; ++p) {
        if (u->peers[p].used && u->peers[p].host == host) { slot = p; break; }
        if (!u->peers[p].used && slot < 0) slot = p;
    }
    if (slot >= 0 && !u->peers[slot].used) {
        u->peers[slot].host = host;
        u->peers[slot].addr = a;
        u->peers[slot].len = len;
        u->peers[slot].used = 1;
        was_new = 1;
    } else if (slot >= 0) {
        u->peers[slot].addr = a;
        u->peers[slot].len = len;
    }
    pthread_mutex_unlock(&u->mu);
    if (slot < 0)
        return gs__fail(u->world, GS_ERR_CAPACITY, "gs_udp_add_peer: no room for host %lu",
                        (unsigned long)host);
    r = gs_net_add_peer(u->net, host);
    if (r != GS_OK && was_new) {
        pthread_mutex_lock(&u->mu);
        u->peers[slot].used = 0;
        pthread_mutex_unlock(&u->mu);
    }
    return r;
}

GS_API gs_result gs_udp_remove_peer(gs_udp *u, uint32_t host) {
    gs_result r = gs_net_remove_peer(u->net, host); /* the net first: see add */
    int p;
    pthread_mutex_lock(&u->mu);
    for (p = 0; p < GS__MAX_PEERS; ++p)
        if (u->peers[p].used && u->peers[p].host == host) u->peers[p].used = 0;
    pthread_mutex_unlock(&u->mu);
    return r;
}

GS_API gs_result gs_udp_poll(gs_udp *u, double now) {
    if (!gs__finite(now)) return GS_ERR_NOT_FINITE;
    if (u->threads) {
        pthread_mutex_lock(&u->wake_mu);
        pthread_cond_signal(&u->wake);
        pthread_mutex_unlock(&u->wake_mu);
        return GS_OK;
    }
    gs__udp_drain(u, 4096);
    return gs_net_update(u->net, now);
}
#endif /* GHOSTSIM_NO_UDP */

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
