/* equal_time.h - divergence between two hosts at equal simulation time,
   shared by bench/sync_modes and bench/bandwidth (header-only, C99 and
   C++11, every function static; include it after ghostsim.h and
   bench_util.h).

   The project measures divergence at equal simulation time: a comparison
   at equal wall time mixes the hosts' clock gap into it, and one against
   the latest snapshot mixes in the snapshot's age. So each host keeps, at
   the end of every frame, its reference time (the time of one of its
   agents, the same agent on every host) and its objects' positions: a
   mesh's particles first (mesh_n of them, 0 without a mesh), then one
   point per body. The divergence of host a's frame ka from host b is b's
   samples interpolated linearly to a's time (exact when b sampled at that
   time, so equal copies give exactly 0), the largest over the objects of
   the RMS distance over the mesh's particles or the distance of a body.

     et_samples s;  et_alloc(&s, frames, points, mesh_n)  ...  et_free(&s)
     gs_vec3 *row = et_push(&s, t)   the next frame's points (NULL: full)
     double d = et_diverge_at(&a, ka, &b)   -1 when b did not sample
                                            around a's time
     double e = et_equal_at(&a, ka, &b)     the same at a time b sampled
                                            too, -1 else (bitwise checks) */
#ifndef BENCH_EQUAL_TIME_H
#define BENCH_EQUAL_TIME_H

#include <math.h>
#include <stdlib.h>

typedef struct et_samples {
    double *t;   /* cap: the reference time of each frame kept */
    gs_vec3 *p;  /* cap x points */
    int points, mesh_n, frames, cap;
} et_samples;

/* 0, or -1 when out of memory (et_free is safe either way). */
BU__UNUSED static int et_alloc(et_samples *s, int cap, int points, int mesh_n)
{
    s->points = points;
    s->mesh_n = mesh_n;
    s->cap = cap;
    s->frames = 0;
    s->t = (double *)calloc((size_t)cap, sizeof *s->t);
    s->p = (gs_vec3 *)calloc((size_t)cap * (size_t)points, sizeof *s->p);
    return s->t && s->p ? 0 : -1;
}

BU__UNUSED static void et_free(et_samples *s)
{
    free(s->t);
    free(s->p);
    s->t = NULL;
    s->p = NULL;
}

/* Frame k's points. */
BU__UNUSED static gs_vec3 *et_row(const et_samples *s, int k)
{
    return s->p + (size_t)k * (size_t)s->points;
}

/* A new frame at reference time t: its points to fill, NULL when full. */
BU__UNUSED static gs_vec3 *et_push(et_samples *s, double t)
{
    if (s->frames >= s->cap) return NULL;
    s->t[s->frames] = t;
    return et_row(s, s->frames++);
}

BU__UNUSED static double et_dist(gs_vec3 a, gs_vec3 b)
{
    double x = a.x - b.x, y = a.y - b.y, z = a.z - b.z;
    return sqrt(x * x + y * y + z * z);
}

/* Host a's frame ka against host b at a's time (see the top); exact: only
   where b sampled a's time itself (-1 else). Frames must be kept in time
   order. */
BU__UNUSED static double et_diverge_(const et_samples *a, int ka, const et_samples *b, int exact)
{
    double t = a->t[ka], f, sum = 0.0, worst = 0.0;
    const gs_vec3 *pa = et_row(a, ka), *lo_p, *hi_p;
    int lo = 0, hi = b->frames - 1, i, m;
    if (b->frames < 2 || t < b->t[0] || t > b->t[hi]) return -1.0;
    while (hi - lo > 1) {
        m = (lo + hi) / 2;
        if (b->t[m] <= t) lo = m;
        else hi = m;
    }
    if (b->t[hi] == t) lo = hi;
    if (b->t[lo] == t) hi = lo;
    else if (exact) return -1.0;
    f = hi == lo ? 0.0 : (t - b->t[lo]) / (b->t[hi] - b->t[lo]);
    lo_p = et_row(b, lo);
    hi_p = et_row(b, hi);
    for (i = 0; i < a->points; ++i) {
        gs_vec3 q;
        double d;
        q.x = lo_p[i].x + (hi_p[i].x - lo_p[i].x) * f;
        q.y = lo_p[i].y + (hi_p[i].y - lo_p[i].y) * f;
        q.z = lo_p[i].z + (hi_p[i].z - lo_p[i].z) * f;
        d = et_dist(pa[i], q);
        if (i < a->mesh_n) sum += d * d;
        else if (d > worst) worst = d;
    }
    if (a->mesh_n > 0 && sqrt(sum / a->mesh_n) > worst) worst = sqrt(sum / a->mesh_n);
    return worst;
}

BU__UNUSED static double et_diverge_at(const et_samples *a, int ka, const et_samples *b)
{
    return et_diverge_(a, ka, b, 0);
}

/* As et_diverge_at, but only at a time b sampled too: -1 when b's frames
   lie either side of a's time. Whether two copies are bitwise equal is
   told only there: b's samples interpolated across the step it ended
   short of a's time (a host whose target fell just below a step boundary
   at a frame's end) differ from a's by what the scene moves in the
   interpolation's error even when the copies are equal bit for bit at
   every time both reach (4 hosts at rest on the harsh link: 8.9e-7 m,
   docs/sync-notes.md, 2026-12-05). */
BU__UNUSED static double et_equal_at(const et_samples *a, int ka, const et_samples *b)
{
    return et_diverge_(a, ka, b, 1);
}

#endif
