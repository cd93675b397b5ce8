/* bench/physics.cc - ghostsim's physics against what users would pick
   instead, in one run, as ratios of time per step at the same dt:
     cloth    ghostsim spring-mass cloth (symplectic Euler with its automatic
              substeps, and implicit Euler) against Bullet soft bodies of the
              same grid and the same links: the classic position-based
              btSoftBody (btSoftBodyHelpers::CreatePatch, 1 and 10 position
              iterations) and the deformable world's mass-spring force
              (btDeformableMassSpringForce, implicit, the same k and damping);
     spheres  a pile of rigid spheres falling into a box onto the ground:
              ghostsim (penalty contacts) against ODE (dWorldQuickStep, its
              iterative LCP, and dWorldStep, its exact LCP, on the smallest
              pile) with contact softness set from the same stiffness and
              damping.

   usage: build/bench/physics [--quick] [--out FILE.json]

   Method: every engine builds its scene, is warmed up, and then the engines
   take turns running batches of the same number of steps (so they are at
   the same simulated moment); each batch is timed with the monotonic clock.
   Per engine, the median batch time per step; the ratios (other / ghostsim,
   > 1 means ghostsim is faster) are medians of per-batch ratios, which
   a shared machine's noise disturbs least. After the run every engine's
   result is checked for sanity (cloth sag and stretch; pile height,
   overlap, escapes), so that a fast engine that does less shows it. */
#define GHOSTSIM_IMPLEMENTATION
#include "ghostsim.h"
#include "bench/bench_util.h"

/* Bullet's and ODE's headers are not warning-free under -Wextra -Wpedantic. */
#if defined(__GNUC__)
#pragma GCC diagnostic push
#if defined(__clang__)
#pragma GCC diagnostic ignored "-Wunknown-warning-option"
#endif
#pragma GCC diagnostic ignored "-Wpedantic"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wunused-variable"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wunused-but-set-variable"
#pragma GCC diagnostic ignored "-Woverloaded-virtual"
#pragma GCC diagnostic ignored "-Wreorder"
#pragma GCC diagnostic ignored "-Wdeprecated-copy"
#pragma GCC diagnostic ignored "-Wclass-memaccess"
#endif
#include <btBulletDynamicsCommon.h>
#include <BulletSoftBody/btDeformableBodySolver.h>
#include <BulletSoftBody/btDeformableGravityForce.h>
#include <BulletSoftBody/btDeformableMassSpringForce.h>
#include <BulletSoftBody/btDeformableMultiBodyConstraintSolver.h>
#include <BulletSoftBody/btDeformableMultiBodyDynamicsWorld.h>
#include <BulletSoftBody/btSoftBodyHelpers.h>
#include <BulletSoftBody/btSoftBodyRigidBodyCollisionConfiguration.h>
#include <BulletSoftBody/btSoftRigidDynamicsWorld.h>
#include <ode/ode.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <string.h>

/* An agent's counters by value (gs_agent_get_stats fills an out-pointer). */
static gs_agent_stats agent_stats(const gs_agent *a) {
    gs_agent_stats st;
    memset(&st, 0, sizeof st);
    gs_agent_get_stats(a, &st);
    return st;
}

static const double DT = 0.001;          /* s, every engine */
static const double K_STRETCH = 1000.0;  /* N/m, structural and shear */
static const double K_BEND = 10.0;       /* N/m */
static const double SPRING_DAMPING = 0.02; /* N s/m along a spring */
static const double CLOTH_MASS = 1.0;    /* kg */

/* ---- a timed engine ------------------------------------------------------- */

struct engine {
    std::string name;
    std::vector<double> batch; /* s per step, one per batch */
    virtual ~engine() {}
    virtual void step() = 0;
    /* k steps of DT; an engine whose application would take them in
       fewer calls (ghostsim's pile: one advance per display frame) says so */
    virtual void steps(int k) {
        for (int i = 0; i < k; ++i) step();
    }
    double run(int steps_) {
        double t0 = bu_now();
        steps(steps_);
        double s = (bu_now() - t0) / steps_;
        batch.push_back(s);
        return s;
    }
};

static double median(std::vector<double> v) {
    if (v.empty()) return NAN;
    return bu_median(&v[0], (int)v.size());
}

/* ---- cloth ------------------------------------------------------------------ */

struct cloth_engine : engine {
    int n;
    explicit cloth_engine(int n_) : n(n_) {}
    virtual gs_vec3 pos(int i) const = 0; /* particle i + n * j */
    /* sag of the centre particle (m, positive down) */
    double sag() const { return -pos((n / 2) * n + n / 2).y; }
    /* the largest relative stretch of a structural link */
    double max_stretch() const {
        double rest = 1.0 / (n - 1), worst = 0.0;
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                gs_vec3 a = pos(i + n * j);
                for (int d = 0; d < 2; ++d) {
                    int ii = i + (d == 0), jj = j + (d == 1);
                    if (ii >= n || jj >= n) continue;
                    gs_vec3 b = pos(ii + n * jj);
                    double l = sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) +
                                    (a.z - b.z) * (a.z - b.z));
                    worst = std::max(worst, l / rest - 1.0);
                }
            }
        return worst;
    }
    virtual std::string note() const = 0;
};

struct gs_cloth_engine : cloth_engine {
    gs_world *w;
    gs_agent *cloth;
    gs_integrator integ;
    gs_cloth_engine(int n_, gs_integrator integ_) : cloth_engine(n_), w(NULL), cloth(NULL),
                                                    integ(integ_) {
        name = integ == GS_INTEGRATOR_IMPLICIT_EULER ? "ghostsim implicit Euler"
               : integ == GS_INTEGRATOR_XPBD         ? "ghostsim XPBD"
                                                      : "ghostsim symplectic Euler";
        gs_world_desc wd = gs_world_desc_default();
        gs_cloth_desc cd = gs_cloth_desc_default();
        if (gs_world_create(&wd, &w) != GS_OK) abort();
        cd.nx = cd.ny = n;
        cd.width = cd.height = 1.0;
        cd.mass = CLOTH_MASS;
        cd.stretch_stiffness = K_STRETCH;
        cd.shear_stiffness = K_STRETCH;
        cd.bend_stiffness = K_BEND;
        cd.spring_damping = SPRING_DAMPING;
        cd.pin_corners = GS_CORNER_ALL;
        cd.solver.dt = DT;
        cd.solver.integrator = integ;
        if (gs_cloth_create(w, &cd, &cloth) != GS_OK) {
            fprintf(stderr, "physics: %s\n", gs_world_error(w));
            abort();
        }
    }
    ~gs_cloth_engine() { gs_world_destroy(w); }
    void step() { gs_world_advance(w, DT, NULL); }
    gs_vec3 pos(int i) const { return gs_mesh_positions(cloth)[i]; }
    double substeps_per_step() const {
        gs_agent_stats st = agent_stats(cloth);
        return st.steps ? (double)st.substeps / (double)st.steps : 0.0;
    }
    int springs() const { return gs_mesh_spring_count(cloth); }
    /* ns per spring per substep at `us` microseconds per step */
    double ns_per_spring(double us) const { return 1e3 * us / substeps_per_step() / springs(); }
    std::string note() const {
        char b[256];
        if (integ == GS_INTEGRATOR_IMPLICIT_EULER)
            snprintf(b, sizeof b, "backward Euler, springs linearized, conjugate gradient to 1e-6; "
                                  "%d springs", springs());
        else if (integ == GS_INTEGRATOR_XPBD)
            snprintf(b, sizeof b, "XPBD small steps: %.2f substeps per step of one pass over the "
                                  "springs (compliance 1/k, the same N/m); %d springs",
                     substeps_per_step(), springs());
        else
            snprintf(b, sizeof b, "explicit, %.2f substeps per step to stay under its "
                                  "stability bound (stable dt %.3g ms); %d springs",
                     substeps_per_step(), 1e3 * gs_mesh_stable_dt(cloth), springs());
        return b;
    }
};

/* Adds ghostsim's links to a patch that has the structural ones: both
   diagonals of every cell (shear) and the neighbours two away (bend). */
static void add_shear_bend(btSoftBody *sb, int n, btSoftBody::Material *shear,
                           btSoftBody::Material *bend) {
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            int k = i + n * j;
            if (i + 1 < n && j + 1 < n) {
                sb->appendLink(k, k + 1 + n, shear);
                sb->appendLink(k + 1, k + n, shear);
            }
            if (i + 2 < n) {
                sb->appendLink(k, k + 2, bend);
                sb->m_links[sb->m_links.size() - 1].m_bbending = -1; /* a 1-bit signed field: nonzero */
            }
            if (j + 2 < n) {
                sb->appendLink(k, k + 2 * n, bend);
                sb->m_links[sb->m_links.size() - 1].m_bbending = -1; /* a 1-bit signed field: nonzero */
            }
        }
}

/* Bullet's classic soft body: position-based links (kLST in [0, 1], not N/m),
   piterations position solver passes per step. */
struct bullet_pbd_engine : cloth_engine {
    btSoftBodyRigidBodyCollisionConfiguration *cc;
    btCollisionDispatcher *disp;
    btDbvtBroadphase *bp;
    btSequentialImpulseConstraintSolver *solver;
    btSoftRigidDynamicsWorld *world;
    btSoftBody *sb;
    int iters;
    bullet_pbd_engine(int n_, int iters_) : cloth_engine(n_), iters(iters_) {
        char b[64];
        snprintf(b, sizeof b, "Bullet soft body, %d position iteration%s", iters,
                 iters > 1 ? "s" : "");
        name = b;
        cc = new btSoftBodyRigidBodyCollisionConfiguration();
        disp = new btCollisionDispatcher(cc);
        bp = new btDbvtBroadphase();
        solver = new btSequentialImpulseConstraintSolver();
        world = new btSoftRigidDynamicsWorld(disp, bp, solver, cc);
        world->setGravity(btVector3(0, -9.81f, 0));
        btSoftBodyWorldInfo &wi = world->getWorldInfo();
        wi.m_gravity = btVector3(0, -9.81f, 0);
        wi.m_sparsesdf.Initialize();
        sb = btSoftBodyHelpers::CreatePatch(wi, btVector3(0, 0, 0), btVector3(1, 0, 0),
                                            btVector3(0, 0, 1), btVector3(1, 0, 1), n, n,
                                            1 + 2 + 4 + 8, false);
        btSoftBody::Material *shear = sb->appendMaterial();
        btSoftBody::Material *bend = sb->appendMaterial();
        sb->m_materials[0]->m_kLST = 1.0f;           /* structural */
        shear->m_kLST = 1.0f;                         /* k_shear = k_stretch */
        bend->m_kLST = (btScalar)(K_BEND / K_STRETCH); /* the same ratio */
        add_shear_bend(sb, n, shear, bend);
        sb->m_cfg.piterations = iters;
        sb->setTotalMass((btScalar)CLOTH_MASS);
        world->addSoftBody(sb);
    }
    ~bullet_pbd_engine() {
        world->removeSoftBody(sb);
        delete sb;
        delete world;
        delete solver;
        delete bp;
        delete disp;
        delete cc;
    }
    void step() { world->stepSimulation((btScalar)DT, 1, (btScalar)DT); }
    gs_vec3 pos(int i) const {
        const btVector3 &x = sb->m_nodes[i].m_x;
        gs_vec3 v = {x.x(), x.y(), x.z()};
        return v;
    }
    std::string note() const {
        char b[256];
        snprintf(b, sizeof b, "position-based: each link projected toward its rest length "
                              "(kLST 1 / 1 / %.2g, no N/m), %d pass%s per step, float; %d links",
                 K_BEND / K_STRETCH, iters, iters > 1 ? "es" : "", sb->m_links.size());
        return b;
    }
};

/* Bullet's deformable world with a mass-spring force: the same k (N/m) and
   damping (N s/m) as ghostsim. Its default scheme is explicit in the spring
   forces (implicit only in damping, one CG solve), so at a fine grid it is
   unstable at 1 ms; it takes `sub` substeps, the count ghostsim's own
   stability bound gives. (Its Newton mode, setImplicit(true), left the
   cloth motionless in our runs, so it is not used.) */
struct bullet_spring_engine : cloth_engine {
    btSoftBodyRigidBodyCollisionConfiguration *cc;
    btCollisionDispatcher *disp;
    btDbvtBroadphase *bp;
    btDeformableBodySolver *dsolver;
    btDeformableMultiBodyConstraintSolver *solver;
    btDeformableMultiBodyDynamicsWorld *world;
    btSoftBody *sb;
    btDeformableMassSpringForce *spring;
    btDeformableGravityForce *gravity;
    int sub;
    bullet_spring_engine(int n_, int sub_) : cloth_engine(n_), sub(sub_) {
        name = "Bullet deformable mass-spring";
        cc = new btSoftBodyRigidBodyCollisionConfiguration();
        disp = new btCollisionDispatcher(cc);
        bp = new btDbvtBroadphase();
        dsolver = new btDeformableBodySolver();
        solver = new btDeformableMultiBodyConstraintSolver();
        solver->setDeformableSolver(dsolver);
        world = new btDeformableMultiBodyDynamicsWorld(disp, bp, solver, cc, dsolver);
        btVector3 g(0, -9.81f, 0);
        world->setGravity(g);
        btSoftBodyWorldInfo &wi = world->getWorldInfo();
        wi.m_gravity = g;
        wi.m_sparsesdf.Initialize();
        sb = btSoftBodyHelpers::CreatePatch(wi, btVector3(0, 0, 0), btVector3(1, 0, 0),
                                            btVector3(0, 0, 1), btVector3(1, 0, 1), n, n,
                                            1 + 2 + 4 + 8, false);
        btSoftBody::Material *m = sb->m_materials[0];
        add_shear_bend(sb, n, m, m);
        sb->setTotalMass((btScalar)CLOTH_MASS);
        sb->m_cfg.collisions = 0;
        world->addSoftBody(sb);
        spring = new btDeformableMassSpringForce((btScalar)K_STRETCH, (btScalar)SPRING_DAMPING,
                                                 true, K_BEND);
        world->addForce(sb, spring);
        gravity = new btDeformableGravityForce(g);
        world->addForce(sb, gravity);
    }
    ~bullet_spring_engine() {
        world->removeSoftBody(sb);
        delete sb;
        delete world;
        delete spring;
        delete gravity;
        delete solver;
        delete dsolver;
        delete bp;
        delete disp;
        delete cc;
    }
    void step() { world->stepSimulation((btScalar)DT, sub, (btScalar)(DT / sub)); }
    gs_vec3 pos(int i) const {
        const btVector3 &x = sb->m_nodes[i].m_x;
        gs_vec3 v = {x.x(), x.y(), x.z()};
        return v;
    }
    std::string note() const {
        char b[256];
        snprintf(b, sizeof b, "the same springs in N/m and N s/m; explicit in spring forces, "
                              "implicit damping (a CG solve), %d substep%s per step (ghostsim's "
                              "bound), float; %d links",
                 sub, sub > 1 ? "s" : "", sb->m_links.size());
        return b;
    }
};

/* RMS distance between two cloths' particles (m). */
static double cloth_rms(const cloth_engine *a, const cloth_engine *b) {
    double s = 0.0;
    int n = a->n * a->n;
    for (int i = 0; i < n; ++i) {
        gs_vec3 p = a->pos(i), q = b->pos(i);
        s += (p.x - q.x) * (p.x - q.x) + (p.y - q.y) * (p.y - q.y) + (p.z - q.z) * (p.z - q.z);
    }
    return sqrt(s / n);
}

/* ---- spheres ------------------------------------------------------------------ */

static const double R = 0.05;          /* m, sphere radius */
static const double SPACING = 0.12;    /* m, lattice at the start */
static const double K_CONTACT = 1e5;   /* N/m */
static const double C_CONTACT = 100.0; /* N s/m */
static const double MU = 0.5;
/* DT steps per ghostsim advance: 16 (60 Hz); PHYSICS_PILE_FRAME=1 gives
   the drive before 2026-12-06 (an advance per step), for comparison */
static int pile_frame_steps() {
    const char *e = getenv("PHYSICS_PILE_FRAME");
    int f = e ? atoi(e) : 16;
    return f < 1 ? 1 : f > 1000 ? 1000 : f;
}

struct pile_layout {
    int count, side;
    double half;             /* m, inner half-width of the box */
    double height;           /* m, wall height */
    std::vector<gs_vec3> start;
};

static pile_layout make_layout(int count) {
    pile_layout L;
    uint32_t rng = 12345;
    L.count = count;
    L.side = (int)ceil(cbrt((double)count) - 1e-9);
    L.half = 0.5 * (L.side - 1) * SPACING + R + 0.03;
    L.height = L.side * SPACING + 0.4;
    for (int k = 0; k < count; ++k) {
        int i = k % L.side, j = (k / L.side) % L.side, l = k / (L.side * L.side);
        gs_vec3 p;
        rng = rng * 1664525u + 1013904223u;
        double jx = ((rng >> 8) / 16777216.0 - 0.5) * 0.01;
        rng = rng * 1664525u + 1013904223u;
        double jz = ((rng >> 8) / 16777216.0 - 0.5) * 0.01;
        p.x = (i - 0.5 * (L.side - 1)) * SPACING + jx;
        p.z = (j - 0.5 * (L.side - 1)) * SPACING + jz;
        p.y = R + 0.05 + l * SPACING;
        L.start.push_back(p);
    }
    return L;
}

struct pile_engine : engine {
    pile_layout L;
    explicit pile_engine(const pile_layout &l) : L(l) {}
    virtual gs_vec3 pos(int i) const = 0;
    virtual std::string note() const = 0;
    double mean_height() const {
        double s = 0.0;
        for (int i = 0; i < L.count; ++i) s += pos(i).y;
        return s / L.count;
    }
    /* the deepest overlap between two spheres or a sphere and the ground (m) */
    double max_overlap() const {
        double worst = 0.0;
        for (int i = 0; i < L.count; ++i) {
            gs_vec3 a = pos(i);
            worst = std::max(worst, R - a.y);
            for (int j = i + 1; j < L.count; ++j) {
                gs_vec3 b = pos(j);
                double d = sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) +
                                (a.z - b.z) * (a.z - b.z));
                worst = std::max(worst, 2 * R - d);
            }
        }
        return worst;
    }
    int escaped() const {
        int e = 0;
        for (int i = 0; i < L.count; ++i) {
            gs_vec3 a = pos(i);
            if (fabs(a.x) > L.half + R || fabs(a.z) > L.half + R || a.y < 0.0) e++;
        }
        return e;
    }
};

struct gs_pile_engine : pile_engine {
    gs_world *w;
    std::vector<gs_agent *> balls;
    explicit gs_pile_engine(const pile_layout &l) : pile_engine(l), w(NULL) {
        name = "ghostsim";
        gs_world_desc wd = gs_world_desc_default();
        gs_material m;
        m.stiffness = K_CONTACT;
        m.damping = C_CONTACT;
        m.friction = MU;
        if (gs_world_create(&wd, &w) != GS_OK) abort();
        gs_world_set_ground(w, 1, 0.0, m);
        for (int s = 0; s < 4; ++s) { /* the box: four kinematic walls */
            gs_probe_desc pd = gs_probe_desc_default();
            gs_agent *wall;
            double off = L.half + 0.05;
            pd.shape.type = GS_SHAPE_BOX;
            pd.shape.half_extents.x = s < 2 ? 0.05 : off + 0.05;
            pd.shape.half_extents.y = 0.5 * L.height;
            pd.shape.half_extents.z = s < 2 ? off + 0.05 : 0.05;
            pd.position.x = s == 0 ? -off : s == 1 ? off : 0.0;
            pd.position.y = 0.5 * L.height;
            pd.position.z = s == 2 ? -off : s == 3 ? off : 0.0;
            pd.material = m;
            pd.dt = DT;
            if (gs_probe_create(w, &pd, &wall) != GS_OK) {
                fprintf(stderr, "physics: %s\n", gs_world_error(w));
                abort();
            }
        }
        for (int i = 0; i < L.count; ++i) {
            gs_rigid_desc rd = gs_rigid_desc_default();
            gs_agent *a;
            rd.shape.type = GS_SHAPE_SPHERE;
            rd.shape.radius = R;
            rd.density = 1000.0;
            rd.position = L.start[i];
            rd.material = m;
            rd.solver.dt = DT;
            if (gs_rigid_create(w, &rd, &a) != GS_OK) {
                fprintf(stderr, "physics: %s\n", gs_world_error(w));
                abort();
            }
            balls.push_back(a);
        }
    }
    ~gs_pile_engine() { gs_world_destroy(w); }
    void step() { gs_world_advance(w, DT, NULL); }
    /* An application advances the world once per display frame (60 Hz:
       16 steps of 1 ms), and the world history (16 frames by default)
       records once per advance, so the bench does too; one advance per
       1 ms step made every step pay a whole-world history copy that an
       application pays once a frame. The results are the same bits either
       way (docs/performance-notes.md, 2026-12-06). */
    void steps(int k) {
        const int frame = pile_frame_steps();
        for (int guard = 0; k > 0 && guard < 1000000; ++guard) {
            int f = k < frame ? k : frame;
            gs_world_advance(w, f * DT, NULL);
            k -= f;
        }
    }
    gs_vec3 pos(int i) const { return gs_rigid_position(balls[i]); }
    double substeps_per_step() const {
        double s = 0.0, n = 0.0;
        for (size_t i = 0; i < balls.size(); ++i) {
            gs_agent_stats st = agent_stats(balls[i]);
            s += (double)st.substeps;
            n += (double)st.steps;
        }
        return n > 0 ? s / n : 0.0;
    }
    std::string note() const {
        char b[256];
        snprintf(b, sizeof b, "penalty spring-damper contacts (no solver), exact sphere paths, "
                              "sweep-and-prune; %.2f substeps per step on average for contact "
                              "stability; every sphere an agent of the scheduler",
                 substeps_per_step());
        return b;
    }
};

struct ode_pile_engine : pile_engine {
    dWorldID world;
    dSpaceID space;
    dJointGroupID contacts;
    std::vector<dBodyID> bodies;
    bool quick;
    long contact_count, steps_taken;
    ode_pile_engine(const pile_layout &l, bool quick_) : pile_engine(l), quick(quick_),
                                                          contact_count(0), steps_taken(0) {
        name = quick ? "ODE dWorldQuickStep (20 iterations)" : "ODE dWorldStep (exact LCP)";
        world = dWorldCreate();
        dWorldSetGravity(world, 0, -9.81, 0);
        dWorldSetQuickStepNumIterations(world, 20);
        space = dHashSpaceCreate(0);
        contacts = dJointGroupCreate(0);
        dCreatePlane(space, 0, 1, 0, 0);
        double off = L.half + 0.05;
        for (int s = 0; s < 4; ++s) {
            dGeomID g = dCreateBox(space, s < 2 ? 0.1 : 2 * off + 0.1, L.height,
                                   s < 2 ? 2 * off + 0.1 : 0.1);
            dGeomSetPosition(g, s == 0 ? -off : s == 1 ? off : 0.0, 0.5 * L.height,
                             s == 2 ? -off : s == 3 ? off : 0.0);
        }
        for (int i = 0; i < L.count; ++i) {
            dBodyID b = dBodyCreate(world);
            dMass m;
            dMassSetSphere(&m, 1000.0, R);
            dBodySetMass(b, &m);
            dBodySetPosition(b, L.start[i].x, L.start[i].y, L.start[i].z);
            dGeomID g = dCreateSphere(space, R);
            dGeomSetBody(g, b);
            bodies.push_back(b);
        }
    }
    ~ode_pile_engine() {
        dJointGroupDestroy(contacts);
        dSpaceDestroy(space);
        dWorldDestroy(world);
    }
    static void near_cb(void *data, dGeomID a, dGeomID b) {
        ode_pile_engine *e = (ode_pile_engine *)data;
        dBodyID ba = dGeomGetBody(a), bb = dGeomGetBody(b);
        if (!ba && !bb) return;
        dContact c[4];
        int n = dCollide(a, b, 4, &c[0].geom, sizeof(dContact));
        /* ERP and CFM of a spring-damper k, c at step h (ODE manual) */
        double erp = DT * K_CONTACT / (DT * K_CONTACT + C_CONTACT);
        double cfm = 1.0 / (DT * K_CONTACT + C_CONTACT);
        for (int i = 0; i < n; ++i) {
            c[i].surface.mode = dContactSoftERP | dContactSoftCFM | dContactApprox1;
            c[i].surface.mu = MU;
            c[i].surface.soft_erp = erp;
            c[i].surface.soft_cfm = cfm;
            dJointID j = dJointCreateContact(e->world, e->contacts, &c[i]);
            dJointAttach(j, ba, bb);
        }
        e->contact_count += n;
    }
    void step() {
        dSpaceCollide(space, this, near_cb);
        if (quick) dWorldQuickStep(world, DT);
        else dWorldStep(world, DT);
        dJointGroupEmpty(contacts);
        steps_taken++;
    }
    gs_vec3 pos(int i) const {
        const dReal *p = dBodyGetPosition(bodies[i]);
        gs_vec3 v = {p[0], p[1], p[2]};
        return v;
    }
    std::string note() const {
        char b[256];
        snprintf(b, sizeof b, "%s: contact joints solved as constraints (soft ERP/CFM from the "
                              "same k and c), up to 4 contacts per pair, hash space; %.1f "
                              "contacts per step on average",
                 quick ? "iterative projected Gauss-Seidel LCP, 20 iterations"
                       : "Dantzig LCP on the full constraint matrix (cubic in contacts)",
                 steps_taken ? (double)contact_count / steps_taken : 0.0);
        return b;
    }
};

/* ---- the side-by-side runner -------------------------------------------------- */

/* Warm-up, then `batches` rounds in which each engine runs `per` steps. */
static void race(std::vector<engine *> &es, int warm, int batches, int per) {
    for (size_t k = 0; k < es.size(); ++k)
        for (int i = 0; i < warm; ++i) es[k]->step();
    for (int b = 0; b < batches; ++b)
        for (size_t k = 0; k < es.size(); ++k) es[(k + b) % es.size()]->run(per);
}

/* median over batches of other / reference (time per step) */
/* The exponent e of cost ~ n^e, a least-squares line through (log n,
   log cost) over every size: one size's noise moves it less than a line
   through the two ends would. */
static double fit_exponent(const std::vector<double> &n, const std::vector<double> &cost) {
    double sx = 0, sy = 0, sxx = 0, sxy = 0, m = (double)n.size();
    for (size_t i = 0; i < n.size(); ++i) {
        double x = log(n[i]), y = log(cost[i]);
        sx += x; sy += y; sxx += x * x; sxy += x * y;
    }
    return n.size() > 1 ? (m * sxy - sx * sy) / (m * sxx - sx * sx) : NAN;
}

static double ratio(const engine *other, const engine *ref) {
    std::vector<double> r;
    for (size_t b = 0; b < other->batch.size() && b < ref->batch.size(); ++b)
        r.push_back(other->batch[b] / ref->batch[b]);
    return median(r);
}

/* Steps per batch so that the reference engine's batch takes about `target`
   seconds (at least 1, at most 1000). */
static int steps_for(engine *ref, double target) {
    double t0 = bu_now();
    int n = 0;
    while (bu_now() - t0 < 0.01 && n < 1000) { ref->step(); n++; }
    double per = (bu_now() - t0) / n;
    int s = (int)(target / per);
    return s < 1 ? 1 : s > 1000 ? 1000 : s;
}

struct row {
    std::string scene, engine, note;
    int size;
    double us_per_step, ratio_to_ghostsim;
    double check1, check2, rms, t_check;
    int check3;
    bool ok; /* the engine's result is sane (it did not blow up) */
};

/* ghostsim alone, 16x16 .. 128x128 (quick: to 64x64): the cost of one
   spring in one substep, symplectic Euler and XPBD, in the thread's CPU
   time (median of 7 batches of about 20 ms each, after 20 warm-up steps). */
struct spring_cost { int n; double symp, xpbd; };
static double ns_per_spring_substep(int n, gs_integrator integ) {
    gs_cloth_engine e(n, integ);
    std::vector<double> b;
    for (int i = 0; i < 20; ++i) e.step();
    gs_agent_stats s0 = agent_stats(e.cloth);
    int per = 1;
    for (double t0 = bu_cpu_now(); bu_cpu_now() - t0 < 0.02; ++per) e.step();
    for (int k = 0; k < 7; ++k) {
        gs_agent_stats a = agent_stats(e.cloth);
        double t0 = bu_cpu_now();
        for (int i = 0; i < per; ++i) e.step();
        gs_agent_stats z = agent_stats(e.cloth);
        b.push_back(1e9 * (bu_cpu_now() - t0) / (double)(z.substeps - a.substeps) / e.springs());
    }
    (void)s0;
    return median(b);
}

static std::vector<spring_cost> spring_cost_table(bool quick) {
    std::vector<spring_cost> out;
    fprintf(stderr, "\nghostsim alone: ns per spring per substep (thread CPU time)\n%5s %9s %12s %8s\n",
            "n", "springs", "symplectic", "XPBD");
    for (int n = 16; n <= (quick ? 64 : 128); n *= 2) {
        spring_cost c;
        c.n = n;
        c.symp = ns_per_spring_substep(n, GS_INTEGRATOR_SYMPLECTIC_EULER);
        c.xpbd = ns_per_spring_substep(n, GS_INTEGRATOR_XPBD);
        fprintf(stderr, "%5d %9d %12.2f %8.2f\n", n, gs__cloth_spring_count(n, n, 7), c.symp,
                c.xpbd);
        out.push_back(c);
    }
    return out;
}

/* A cloth that stretched by more than 100% or left the neighbourhood blew up:
   its time per step means nothing. */
static bool cloth_sane(double sag, double stretch) {
    return std::isfinite(sag) && std::isfinite(stretch) && fabs(sag) < 10.0 && stretch < 1.0;
}

int main(int argc, char **argv) {
    bu_args args;
    int pa = bu_parse_args(argc, argv, "physics", &args);
    if (pa) return pa > 0 ? 0 : 2;
    dInitODE2(0);
    const bool quick = args.quick != 0;
    std::vector<int> cloth_sizes, pile_sizes;
    /* PHYSICS_SCENES=spheres runs the piles alone (to measure contacts
       without the cloth part's minutes) */
    const bool cloth = !getenv("PHYSICS_SCENES") || strcmp(getenv("PHYSICS_SCENES"), "spheres") != 0;
    if (cloth) {
        cloth_sizes.push_back(16);
        cloth_sizes.push_back(32);
        if (!quick) cloth_sizes.push_back(64);
    }
    pile_sizes.push_back(27);
    pile_sizes.push_back(125);
    if (!quick) { /* the sizes of issue 17's target: ahead of ODE at 1000 and 4000 */
        pile_sizes.push_back(343);
        pile_sizes.push_back(1000);
        pile_sizes.push_back(4096);
    }
    const int batches = quick ? 7 : 25;
    const double batch_s = quick ? 0.02 : 0.1;
    std::vector<row> rows;
    /* headline ratios per size, for the plots and the summary */
    std::vector<double> cx, r_pbd1, r_pbd10, r_spring, r_impl, px, r_ode, p_gs, p_ode;
    std::vector<double> x_pbd1, x_pbd10, x_spring, ns_symp, ns_xpbd;

    fprintf(stderr, "physics: dt = %g ms for every engine; %d batches per size; "
                    "ratio = other / ghostsim time per step (> 1: ghostsim faster)\n",
            DT * 1e3, batches);
    fprintf(stderr, "\ncloth (pinned at 4 corners, 1 kg, k %g / %g / %g N/m, %g N s/m)\n", K_STRETCH,
            K_STRETCH, K_BEND, SPRING_DAMPING);
    fprintf(stderr, "%5s  %-40s %11s %9s %9s %9s %10s\n", "n", "engine", "us/step", "ratio",
            "sag m", "stretch", "rms to gs");
    for (size_t si = 0; si < cloth_sizes.size(); ++si) {
        int n = cloth_sizes[si];
        std::vector<engine *> es;
        gs_cloth_engine *ref = new gs_cloth_engine(n, GS_INTEGRATOR_SYMPLECTIC_EULER);
        es.push_back(ref);
        es.push_back(new gs_cloth_engine(n, GS_INTEGRATOR_IMPLICIT_EULER));
        es.push_back(new bullet_pbd_engine(n, 1));
        es.push_back(new bullet_pbd_engine(n, 10));
        es.push_back(new bullet_spring_engine(
            n, (int)ceil(DT / (0.9 * gs_mesh_stable_dt(ref->cloth)) - 1e-9)));
        gs_cloth_engine *xpbd = new gs_cloth_engine(n, GS_INTEGRATOR_XPBD);
        es.push_back(xpbd);
        int per = steps_for(ref, batch_s / 4);
        race(es, quick ? 100 : 300, batches, per);
        cx.push_back(n * n);
        for (size_t k = 0; k < es.size(); ++k) {
            cloth_engine *c = (cloth_engine *)es[k];
            row r;
            r.scene = "cloth";
            r.engine = c->name;
            r.note = c->note();
            r.size = n;
            r.us_per_step = 1e6 * median(c->batch);
            r.ratio_to_ghostsim = ratio(c, ref);
            r.check1 = c->sag();
            r.check2 = c->max_stretch();
            r.rms = cloth_rms(c, ref);
            r.t_check = gs_agent_time(ref->cloth);
            r.check3 = 0;
            r.ok = cloth_sane(r.check1, r.check2);
            if (!r.ok) {
                r.ratio_to_ghostsim = NAN;
                r.note = "BLEW UP (stretch over 100% or far off): its time per step is not "
                         "comparable; " + r.note;
            }
            rows.push_back(r);
            fprintf(stderr, "%5d  %-40s %11.1f %9.3f %9.4g %8.1f%% %9.1fmm%s\n", n,
                    r.engine.c_str(), r.us_per_step, r.ratio_to_ghostsim, r.check1,
                    100 * r.check2, 1e3 * r.rms, r.ok ? "" : "  BLEW UP");
        }
        {
            size_t base = rows.size() - es.size();
            r_impl.push_back(rows[base + 1].ratio_to_ghostsim);
            r_pbd1.push_back(rows[base + 2].ratio_to_ghostsim);
            r_pbd10.push_back(rows[base + 3].ratio_to_ghostsim);
            r_spring.push_back(rows[base + 4].ratio_to_ghostsim);
            x_pbd1.push_back(ratio(es[2], xpbd));
            x_pbd10.push_back(ratio(es[3], xpbd));
            x_spring.push_back(ratio(es[4], xpbd));
            ns_symp.push_back(ref->ns_per_spring(rows[base].us_per_step));
            ns_xpbd.push_back(xpbd->ns_per_spring(rows[base + 5].us_per_step));
            fprintf(stderr, "       per spring per substep: symplectic %.2f ns, XPBD %.2f ns; "
                            "Bullet / ghostsim XPBD: PBD 1 pass %.3f, PBD 10 passes %.3f, "
                            "mass-spring %.3f\n",
                    ns_symp.back(), ns_xpbd.back(), x_pbd1.back(), x_pbd10.back(),
                    x_spring.back());
        }
        for (size_t k = 0; k < es.size(); ++k) fprintf(stderr, "       %s: %s\n",
                                                       es[k]->name.c_str(),
                                                       ((cloth_engine *)es[k])->note().c_str());
        for (size_t k = 0; k < es.size(); ++k) delete es[k];
    }

    std::vector<spring_cost> costs;
    if (cloth) costs = spring_cost_table(quick);

    fprintf(stderr, "\nsphere pile (r %g m, 1000 kg/m^3, contacts k %g N/m, c %g N s/m, mu %g, "
                    "in a box on the ground)\n", R, K_CONTACT, C_CONTACT, MU);
    fprintf(stderr, "%5s  %-40s %11s %9s %9s %9s %4s\n", "n", "engine", "us/step", "ratio",
            "height m", "overlap", "out");
    for (size_t si = 0; si < pile_sizes.size(); ++si) {
        int n = pile_sizes[si];
        pile_layout L = make_layout(n);
        std::vector<engine *> es;
        gs_pile_engine *ref = new gs_pile_engine(L);
        es.push_back(ref);
        es.push_back(new ode_pile_engine(L, true));
        if (si == 0) es.push_back(new ode_pile_engine(L, false));
        /* the pile forms while it is timed: batches cover 1 s (quick 0.5 s)
           of simulated time from the drop */
        int total = quick ? 500 : 1000;
        int per = total / batches;
        race(es, 0, batches, per);
        px.push_back(n);
        for (size_t k = 0; k < es.size(); ++k) {
            pile_engine *p = (pile_engine *)es[k];
            row r;
            r.scene = "spheres";
            r.engine = p->name;
            r.note = p->note();
            r.size = n;
            r.us_per_step = 1e6 * median(p->batch);
            r.ratio_to_ghostsim = ratio(p, ref);
            r.check1 = p->mean_height();
            r.check2 = p->max_overlap();
            r.check3 = p->escaped();
            r.rms = 0.0;
            r.t_check = gs_world_time(ref->w);
            r.ok = std::isfinite(r.check1) && fabs(r.check1) < 10.0;
            rows.push_back(r);
            fprintf(stderr, "%5d  %-40s %11.1f %9.3f %9.4f %8.1fmm %4d\n", n, r.engine.c_str(),
                    r.us_per_step, r.ratio_to_ghostsim, r.check1, 1e3 * r.check2, r.check3);
        }
        r_ode.push_back(ratio(es[1], ref));
        p_gs.push_back(rows[rows.size() - es.size()].us_per_step);
        p_ode.push_back(rows[rows.size() - es.size() + 1].us_per_step);
        for (size_t k = 0; k < es.size(); ++k) fprintf(stderr, "       %s: %s\n",
                                                       es[k]->name.c_str(),
                                                       ((pile_engine *)es[k])->note().c_str());
        for (size_t k = 0; k < es.size(); ++k) delete es[k];
    }
    dCloseODE();

    const char *what_cloth =
        "Like for like: Bullet's deformable mass-spring force has the same springs (N/m, N s/m) "
        "and, given the same substeps as ghostsim's stability bound, follows the same trajectory "
        "(see rms to ghostsim); it is explicit in spring forces like ghostsim's symplectic Euler "
        "but adds a CG solve for damping and a collision-tree refit per substep, in float. "
        "ghostsim symplectic Euler substeps by itself when the grid is fine (its bound falls as "
        "1/sqrt(k/m)); its implicit Euler pays a CG solve per step but never substeps. Bullet's "
        "classic soft body projects link lengths (kLST is a fraction, not N/m) in float, 1 "
        "position pass by default: cheaper and unconditionally stable, but a different, softer "
        "material whose stiffness depends on the pass count and dt; with 10 passes it holds "
        "length better at several times the cost.";
    const char *what_pile =
        "ghostsim: penalty spring-dampers (no constraint solver), each sphere its own agent with "
        "its own substeps, exact sphere-sphere/sphere-box/ground paths, sweep-and-prune; "
        "resting overlap is m g / k per contact. ODE: contacts are constraint rows solved by "
        "an LCP each step (QuickStep: 20 Gauss-Seidel iterations, linear in contacts; dWorldStep: "
        "Dantzig, cubic), softened with ERP/CFM from the same k and c; stable at much larger dt "
        "than penalty contacts, so per simulated second it can take fewer steps; auto-disable "
        "(sleeping) left off.";
    fprintf(stderr, "\nwhat each does more or less:\n  cloth: %s\n  spheres: %s\n", what_cloth,
            what_pile);

    bu_json *j = bu_json_open(args.out);
    if (!j) return 1;
    bu_json_obj_begin(j, NULL);
    bu_json_header(j, "physics", quick);
    bu_json_str(j, "method",
                "Each engine builds the scene, is warmed up (cloth), then the engines take turns "
                "running batches of the same number of steps at dt = 1 ms, so they are at the "
                "same simulated moment; per engine the median batch time per step; ratio = "
                "other / ghostsim symplectic (cloth) or ghostsim (spheres) time per step, the "
                "median of per-batch ratios (> 1: ghostsim faster). Checks after the run: cloth "
                "sag of the centre particle, the largest structural stretch and the RMS distance "
                "to ghostsim symplectic's particles at the end; pile mean height, "
                "deepest overlap and spheres outside the box.");
    bu_json_num(j, "dt_s", DT);
    bu_json_int(j, "batches", batches);
    bu_json_arr_begin(j, "results");
    for (size_t i = 0; i < rows.size(); ++i) {
        const row &r = rows[i];
        bu_json_obj_begin(j, NULL);
        bu_json_str(j, "scene", r.scene.c_str());
        bu_json_str(j, "engine", r.engine.c_str());
        bu_json_int(j, r.scene == "cloth" ? "n_per_side" : "spheres", r.size);
        bu_json_num(j, "us_per_step", r.us_per_step);
        bu_json_bool(j, "sane", r.ok);
        bu_json_num(j, "ratio_to_ghostsim", r.ratio_to_ghostsim);
        bu_json_num(j, "checked_at_sim_s", r.t_check);
        if (r.scene == "cloth") {
            bu_json_num(j, "centre_sag_m", r.check1);
            bu_json_num(j, "max_structural_stretch", r.check2);
            bu_json_num(j, "rms_distance_to_ghostsim_symplectic_m", r.rms);
        } else {
            bu_json_num(j, "mean_height_m", r.check1);
            bu_json_num(j, "max_overlap_m", r.check2);
            bu_json_int(j, "escaped", r.check3);
        }
        bu_json_str(j, "note", r.note.c_str());
        bu_json_obj_end(j);
    }
    for (size_t i = 0; i < costs.size(); ++i) {
        bu_json_obj_begin(j, NULL);
        bu_json_str(j, "scene", "cloth_cost");
        bu_json_int(j, "n_per_side", costs[i].n);
        bu_json_num(j, "symplectic_ns_per_spring_substep", costs[i].symp);
        bu_json_num(j, "xpbd_ns_per_spring_substep", costs[i].xpbd);
        bu_json_obj_end(j);
    }
    bu_json_arr_end(j);
    bu_json_obj_begin(j, "summary");
    {
        char key[96];
        for (size_t i = 0; i < cloth_sizes.size(); ++i) {
            snprintf(key, sizeof key, "cloth%d_bullet_pbd1_over_ghostsim", cloth_sizes[i]);
            bu_json_num(j, key, r_pbd1[i]);
            snprintf(key, sizeof key, "cloth%d_bullet_pbd10_over_ghostsim", cloth_sizes[i]);
            bu_json_num(j, key, r_pbd10[i]);
            snprintf(key, sizeof key, "cloth%d_bullet_massspring_over_ghostsim", cloth_sizes[i]);
            bu_json_num(j, key, r_spring[i]);
            snprintf(key, sizeof key, "cloth%d_ghostsim_implicit_over_symplectic", cloth_sizes[i]);
            bu_json_num(j, key, r_impl[i]);
            snprintf(key, sizeof key, "cloth%d_bullet_pbd1_over_ghostsim_xpbd", cloth_sizes[i]);
            bu_json_num(j, key, x_pbd1[i]);
            snprintf(key, sizeof key, "cloth%d_bullet_pbd10_over_ghostsim_xpbd", cloth_sizes[i]);
            bu_json_num(j, key, x_pbd10[i]);
            snprintf(key, sizeof key, "cloth%d_bullet_massspring_over_ghostsim_xpbd", cloth_sizes[i]);
            bu_json_num(j, key, x_spring[i]);
            snprintf(key, sizeof key, "cloth%d_symplectic_ns_per_spring_substep", cloth_sizes[i]);
            bu_json_num(j, key, ns_symp[i]);
            snprintf(key, sizeof key, "cloth%d_xpbd_ns_per_spring_substep", cloth_sizes[i]);
            bu_json_num(j, key, ns_xpbd[i]);
        }
        if (cloth) {
            size_t last = cloth_sizes.size() - 1;
            char t[160];
            snprintf(t, sizeof t, "symplectic Euler <= 3 ns per spring per substep at %dx%d",
                     cloth_sizes[last], cloth_sizes[last]);
            bu_json_str(j, "target_ns", t);
            bu_json_bool(j, "target_met_ns", ns_symp[last] <= 3.0);
            snprintf(t, sizeof t, "XPBD >= 3x faster than Bullet PBD 10 passes at %dx%d",
                     cloth_sizes[last], cloth_sizes[last]);
            bu_json_str(j, "target_xpbd", t);
            bu_json_bool(j, "target_met_xpbd", x_pbd10[last] >= 3.0);
        }
        for (size_t i = 0; i < pile_sizes.size(); ++i) {
            snprintf(key, sizeof key, "pile%d_ode_quickstep_over_ghostsim", pile_sizes[i]);
            bu_json_num(j, key, r_ode[i]);
        }
        /* cost ~ n^e: the least-squares fit over every size (the target),
           and the line between the smallest and the largest pile */
        size_t last = px.size() - 1;
        double span = log(px[last] / px[0]);
        double e_gs = fit_exponent(px, p_gs), e_ode = fit_exponent(px, p_ode);
        bu_json_num(j, "pile_cost_exponent_ghostsim", e_gs);
        bu_json_num(j, "pile_cost_exponent_ode_quickstep", e_ode);
        bu_json_num(j, "pile_cost_exponent_ends_ghostsim", log(p_gs[last] / p_gs[0]) / span);
        bu_json_num(j, "pile_cost_exponent_ends_ode_quickstep", log(p_ode[last] / p_ode[0]) / span);
        {
            bool ahead = !quick, big = false;
            for (size_t i = 0; i < pile_sizes.size(); ++i)
                if (pile_sizes[i] >= 1000) {
                    big = true;
                    if (!(r_ode[i] > 1.0)) ahead = false;
                }
            ahead = ahead && big;
            bu_json_str(j, "target_pile", "ahead of ODE QuickStep at 1000 and 4096 spheres, "
                                          "cost exponent <= 1.1 (full run)");
            bu_json_bool(j, "target_met_pile", ahead && e_gs <= 1.1);
            fprintf(stderr, "\npile cost ~ n^e from %g to %g spheres (least squares over %d sizes; "
                            "ends only): ghostsim e = %.2f (%.2f), ODE QuickStep e = %.2f (%.2f)\n",
                    px[0], px[last], (int)px.size(), e_gs, log(p_gs[last] / p_gs[0]) / span, e_ode,
                    log(p_ode[last] / p_ode[0]) / span);
            fprintf(stderr, "target: ghostsim e <= 1.1: %s (e = %.2f%s)\n",
                    quick ? "not judged" : e_gs <= 1.1 ? "met" : "MISSED", e_gs,
                    quick ? ": a --quick run has no large piles" : "");
            for (size_t i = 0; i < pile_sizes.size(); ++i)
                if (pile_sizes[i] >= 1000)
                    fprintf(stderr, "target: ahead of ODE QuickStep at %d spheres: %s "
                                    "(ODE / ghostsim = %.2f)\n",
                            pile_sizes[i], r_ode[i] > 1.0 ? "met" : "MISSED", r_ode[i]);
            if (!big)
                fprintf(stderr, "target: ahead of ODE QuickStep at 1000 and 4096 spheres: "
                                "not measured (--quick)\n");
        }
    }
    bu_json_str(j, "cloth_note", what_cloth);
    bu_json_str(j, "spheres_note", what_pile);
    bu_json_obj_end(j);
    bu_json_arr_begin(j, "plots");
    {
        const char *names[4] = {"Bullet PBD 1 pass", "Bullet PBD 10 passes",
                                "Bullet mass-spring (same substeps)", "ghostsim implicit Euler"};
        const double *c0 = cx.empty() ? NULL : &cx[0];
        const double *xs[4] = {c0, c0, c0, c0};
        const double *ys[4] = {cloth ? &r_pbd1[0] : NULL, cloth ? &r_pbd10[0] : NULL,
                               cloth ? &r_spring[0] : NULL, cloth ? &r_impl[0] : NULL};
        int ns[4] = {(int)cx.size(), (int)cx.size(), (int)cx.size(), (int)cx.size()};
        if (cloth)
            bu_json_plot(j, "Cloth: time per step relative to ghostsim symplectic Euler",
                         "particles", "time / ghostsim time", 1, 4, names, xs, ys, ns);
        const char *pn[1] = {"ODE QuickStep"};
        const double *pxs[1] = {&px[0]};
        const double *pys[1] = {&r_ode[0]};
        int pns[1] = {(int)px.size()};
        bu_json_plot(j, "Sphere pile: ODE time per step relative to ghostsim", "spheres",
                     "ODE time / ghostsim time", 1, 1, pn, pxs, pys, pns);
    }
    bu_json_arr_end(j);
    bu_json_obj_end(j);
    if (bu_json_close(j) != 0) return 1;
    fprintf(stderr, "physics: wrote %s\n", args.out);
    return 0;
}
