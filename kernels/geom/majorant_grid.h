#ifndef PPM_MAJORANT_GRID_H
#define PPM_MAJORANT_GRID_H
#include "geom/geometry.h"

/* A heterogeneous medium's majorant grid (ppm_engine/render/medium_bound.py): the bound of its
 * density over each of n^3 cells of its object's world box, so that null-collision tracking
 * (geom/medium_field.h) takes tentative collisions at the rate of the cell it is in, where one
 * bound over the whole box made the clear air between a smoke's puffs as costly as the
 * densest puff (as PBRT-v4's majorant grids and Cycles' volume octree).  In scene->voxels at
 * Material.majorant_grid - 1 (0: none): a header of MAJORANT_HEADER floats (the box's low corner,
 * n, the cells per metre on each axis, the least bound: a cell where no sample found density,
 * then zeros), then the n^3 bounds, x fastest.
 *
 * A segment's walk: the stretches of the segment o + s d (0 <= s < t) over which the bound is
 * one number: the cells the segment crosses in order (a 3D DDA), and before and after the box
 * (float round-off at its faces) the medium's bound over the whole box. */
#define MAJORANT_HEADER 16

typedef struct {
    __global const float *cells; /* 0: no grid, the segment one stretch */
    float3 next, delta;          /* where the walk crosses into the next cell on each axis */
    int3 cell, step;
    int n;
    float in, out, t; /* the box's stretch [in, out) of the segment [0, t) */
    float clear;      /* the grid's least bound (-1: none) */
} MajorantWalk;

/* a walk along the segment o + s d (0 <= s < t) through the grid whose header is at h (0:
 * none) */
inline MajorantWalk majorant_walk(__global const float *h, float3 o, float3 d, float t) {
    MajorantWalk w;
    w.cells = 0;
    w.t = t;
    w.in = w.out = t;
    w.clear = -1.0f;
    if (!h) return w;
    float3 lo = vload3(0, h), per = vload3(1, h + 1);
    int n = (int)h[3];
    /* the box [lo, lo + n / per) along the ray (slabs) */
    float3 a = (lo - o) / d, b = (lo + (float)n / per - o) / d;
    float3 near = fmin(a, b), far = fmax(a, b);
    float s0 = fmax(fmax(near.x, near.y), fmax(near.z, 0.0f));
    float s1 = fmin(fmin(far.x, far.y), fmin(far.z, t));
    if (!(s0 < s1)) return w; /* misses the box (NaN too): one stretch */
    w.cells = h + MAJORANT_HEADER;
    w.clear = h[7];
    w.n = n;
    w.in = s0;
    w.out = s1;
    float3 p = (o + s0 * d - lo) * per; /* grid coordinates, cells of 1 */
    w.cell = min(max(convert_int3_rtn(p), (int3)(0)), (int3)(n - 1));
    float3 v = d * per; /* cells per metre of the ray */
    w.step = select((int3)(-1), (int3)(1), isgreaterequal(v, (float3)(0.0f)));
    float3 edge = convert_float3(w.cell + max(w.step, (int3)(0)));
    w.next = select(s0 + (edge - p) / v, (float3)(INFINITY), isequal(v, (float3)(0.0f)));
    w.delta = fabs(1.0f / v);
    return w;
}

/* The stretch of walk w that starts at s: its end (> s, or s where nothing is left: s >= t),
 * *bound the density's bound over it (`top`, the box's, outside the grid); the walk moves on
 * to the next. */
inline float majorant_stretch(MajorantWalk *w, float s, float top, float *bound) {
    *bound = top;
    if (s < w->in) return w->in;
    if (!w->cells || !(s < w->out)) return w->t;
    float3 x = w->next;
    int axis = x.x <= x.y && x.x <= x.z ? 0 : (x.y <= x.z ? 1 : 2);
    float end = fmin(axis == 0 ? x.x : (axis == 1 ? x.y : x.z), w->out);
    *bound = w->cells[(w->cell.z * w->n + w->cell.y) * w->n + w->cell.x];
    /* into the next cell: the grid left (the rest outside the box) where it runs out */
    int c;
    if (axis == 0) {
        c = w->cell.x += w->step.x;
        w->next.x += w->delta.x;
    } else if (axis == 1) {
        c = w->cell.y += w->step.y;
        w->next.y += w->delta.y;
    } else {
        c = w->cell.z += w->step.z;
        w->next.z += w->delta.z;
    }
    if (c < 0 || c >= w->n) w->out = end;
    return fmax(end, s);
}
#endif
