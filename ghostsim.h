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
       POSIX (clock_gettime): compile that file with -D_POSIX_C_SOURCE=200809L,
       -std=gnu99 or as C++. Link with -lm (and later with libccd).

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

   OPTIONS (macros)
       macro                    where            default
       GHOSTSIM_IMPLEMENTATION  one .c file      off: declarations only
       GHOSTSIM_STATIC          before include   off: functions are extern
       GS_MALLOC(sz, ctx)       implementation   malloc(sz)  (define both
       GS_FREE(p, ctx)          implementation   free(p)      or neither)
       GS_ASSERT(c)             implementation   assert(c)
       GS_MAX_QUEUES            implementation   64: most priority queues
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
       global mutable state.

   REVISION HISTORY
       0.1.0 (2026-11-23)  world, scheduler, spring-mass agents, integrators.

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
    X(GS_ERR_CAPACITY, -8, "a fixed capacity is exhausted")

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

/* Destroys the world and every agent in it. NULL is ignored. */
GS_API void gs_world_destroy(gs_world *w);

/* Moves the target time on by `seconds` (>= 0) and runs agent steps, most
   urgent first, until every agent is within half its dt of the target or the
   wall-clock budget is spent. An agent whose step fails keeps its state and
   stops advancing for the rest of this call; the others go on.
   report may be NULL. Returns GS_OK, GS_ERR_INVALID_ARG (negative or
   non-finite seconds), GS_ERR_BUSY (called from inside an advance), or the
   first error an agent's step returned (every other agent still advanced). */
GS_API gs_result gs_world_advance(gs_world *w, double seconds,
                                  gs_advance_report *report);

/* The target time reached by the advance calls so far, in seconds. */
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
    double safety;           /* fraction of the stability bound used when
                                substepping, (0, 1]; default 0.9 */
    double cg_tolerance;     /* implicit Euler: relative residual; 1e-6 */
    int cg_max_iterations;   /* implicit Euler: default 200 */
    double max_speed;        /* m/s; a faster particle means the step blew
                                up and is undone; default 1e4 */
} gs_solver_desc;

GS_API gs_solver_desc gs_solver_desc_default(void);

/* Simulation time in seconds: steps * dt plus what set_state moved it by. */
GS_API double gs_agent_time(const gs_agent *a);
GS_API double gs_agent_dt(const gs_agent *a);
GS_API gs_world *gs_agent_world(const gs_agent *a);
/* "mesh", "cloth" or "custom". */
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
    double stretch_stiffness; /* N/m, structural; default 2000 */
    double shear_stiffness;   /* N/m; default stretch / 10 */
    double bend_stiffness;    /* N/m; default stretch / 100 */
    double spring_damping;    /* N s/m on every spring; default 0.02 */
    double air_damping;       /* 1/s; default 0.1 */
    int pin_corners;     /* GS_CORNER_* mask */
    int pin_count;       /* more pins, as particle index i + nx * j */
    const int *pins;
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
/* Moves a pinned particle (the application drags a corner). */
GS_API gs_result gs_mesh_move_pin(gs_agent *a, int particle, gs_vec3 pos);

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
    gs_agent_stats stats;
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
    uint64_t dispatches;
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

GS_API void gs_world_destroy(gs_world *w) {
    int i;
    if (!w) return;
    GS_ASSERT(!w->busy && "gs_world_destroy inside gs_world_advance");
    for (i = 0; i < w->agent_count; ++i) gs__free(w, w->agents[i]);
    gs__free(w, w->agents);
    w->alloc.free(w, w->alloc.user);
}

/* Adds a new agent to the world's list, growing it as needed (create time
   only: the step loop never allocates). */
GS__PRIVATE gs_result gs__world_add(gs_world *w, gs_agent *a) {
    if (w->agent_count == w->agent_cap) {
        int cap = w->agent_cap ? 2 * w->agent_cap : 8;
        gs_agent **list = (gs_agent **)gs__alloc(w, (size_t)cap * sizeof *list);
        if (!list) return gs__fail(w, GS_ERR_NO_MEMORY, "agent list: out of memory");
        if (w->agent_count)
            memcpy(list, w->agents, (size_t)w->agent_count * sizeof *list);
        gs__free(w, w->agents);
        w->agents = list;
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

GS__PRIVATE gs_result gs__agent_step(gs_agent *a) {
    gs_result r = a->kind->step(a, a->dt);
    a->result = r;
    if (r == GS_OK) {
        a->steps++;
        a->stats.steps++;
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
    gs__time_span(w, &t_min, &t_max);
    a = gs__pick(w, t_min);
    if (!a) return 0;
    gs__activate(w, a, t_min, t_max);
    w->dispatches++;
    r = gs__agent_step(a);
    if (r != GS_OK) {
        a->failed = 1;
        rep->failed_agents++;
        if (*first_error == GS_OK) *first_error = r;
        return 1;
    }
    rep->steps++;
    if (!gs__agent_done(a)) gs__queue_push(w, a);
    return 1;
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
    w->target += seconds;
    if (w->budget > 0.0) start = w->clock(w->clock_user);
    gs__queue_all(w);
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

GS_API gs_result gs_agent_set_state(gs_agent *a, const double *in, size_t n) {
    size_t i;
    gs_result r;
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
    r = a->kind->set_state(a, in + 1);
    if (r != GS_OK) return r;
    a->t_offset = in[0] - (double)a->steps * a->dt;
    return GS_OK;
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

GS_API gs_result gs_agent_destroy(gs_agent *a) {
    gs_world *w = a->world;
    int i;
    if (w->busy)
        return gs__fail(w, GS_ERR_BUSY,
                        "gs_agent_destroy: the world is advancing");
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
    gs__custom_set_state, gs__custom_hash};

GS__PRIVATE gs_result gs__world_unlocked(gs_world *w, const char *who) {
    if (!w) return GS_ERR_INVALID_ARG;
    if (w->busy)
        return gs__fail(w, GS_ERR_BUSY, "%s: the world is advancing", who);
    return GS_OK;
}

GS_API gs_result gs_custom_create(gs_world *w, const gs_custom_desc *desc,
                                  gs_agent **out) {
    gs__check c;
    gs__custom *a;
    gs_result r = gs__world_unlocked(w, "gs_custom_create");
    if (r != GS_OK) return r;
    c = gs__check_begin(w, "gs_custom_create");
    if (!out || !desc)
        gs__check_fail(&c, GS_ERR_INVALID_ARG, "desc and out are required");
    if (out) *out = NULL;
    if (c.r != GS_OK) return c.r;
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

GS__PRIVATE gs_result gs__mesh_substep(gs__mesh *m, double h) {
    gs_vec3 *t;
    int i;
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
    return GS_OK;
}

/* How many substeps a step of dt needs to stay under the stability bound. */
GS__PRIVATE gs_result gs__mesh_plan(gs__mesh *m, double dt, int *n_sub) {
    double lim = m->stable_dt * m->solver.safety, k;
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
        r = gs__mesh_substep(m, dt / n_sub);
        if (r == GS_OK) continue;
        if (i > 0) {
            memcpy(m->x, m->x0, bytes);
            memcpy(m->v, m->v0, bytes);
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
    return GS_OK;
}

GS__PRIVATE uint64_t gs__mesh_hash(const gs_agent *a, uint64_t h) {
    const gs__mesh *m = (const gs__mesh *)a;
    h = gs__fnv(h, m->x, (size_t)m->n * sizeof(gs_vec3));
    return gs__fnv(h, m->v, (size_t)m->n * sizeof(gs_vec3));
}

static const gs__kind gs__mesh_kind = {
    "mesh", gs__mesh_step, gs__mesh_state_size, gs__mesh_get_state,
    gs__mesh_set_state, gs__mesh_hash};
static const gs__kind gs__cloth_kind = {
    "cloth", gs__mesh_step, gs__mesh_state_size, gs__mesh_get_state,
    gs__mesh_set_state, gs__mesh_hash};

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
GS__PRIVATE double gs__mesh_bound(gs__mesh *m) {
    double w2 = 0.0, g = 0.0, h;
    int i;
    if (m->solver.integrator == GS_INTEGRATOR_IMPLICIT_EULER) return HUGE_VAL;
    for (i = 0; i < m->n; ++i) m->acc[i] = gs__v3(0.0, 0.0, 0.0);
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
    m->stable_dt = gs__mesh_bound(m);
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
    gs__check_solver(&c, &d->solver);
    return c.r;
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
        m->stable_dt = gs__mesh_bound(m);
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
    if (!m) return GS_ERR_INVALID_ARG;
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
    if (!m) return GS_ERR_INVALID_ARG;
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
    return GS_OK;
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
