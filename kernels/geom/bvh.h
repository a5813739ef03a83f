#ifndef PPM_BVH_H
#define PPM_BVH_H
#include "geom/geometry.h"
#include "scene.h"

/* Triangles in BVH leaf order, three float4 each (bvh_build.cl, reorder_triangles):
 *   v0 = (p0, as_float(original triangle index)), e1 = (p1 - p0, as_float(visibility bits)),
 *   e2 = (p2 - p0, as_float(material index)).
 * Nodes: 4 float4 per internal node, both children's boxes stored in the parent:
 *   (lmin, as_float(left)), (lmax, as_float(right)), (rmin, 0), (rmax, 0);
 * child >= 0 is an internal node, child < 0 is the leaf ~child (one triangle per leaf). */
#define BVH_STACK 64
/* min and max of the slabs' distances by compares (finite: fmin's NaN rule not needed) */
#define BVH_MIN(a, b) ((a) < (b) ? (a) : (b))
#define BVH_MAX(a, b) ((a) > (b) ? (a) : (b))

typedef struct {
    float t, u, v;
    int leaf;         /* index into the leaf-ordered triangle arrays, -1 = miss */
} Hit;

/* Moeller-Trumbore; returns t in (tmin, tmax) or -1 */
inline float tri_hit(float3 o, float3 d, float3 v0, float3 e1, float3 e2, float tmax, float *u,
                     float *v) {
    float3 p = cross(d, e2);
    float det = dot(e1, p);
    if (det == 0.0f || !isfinite(det)) return -1.0f;
    float inv = 1.0f / det;
    float3 s = o - v0;
    float uu = dot(s, p) * inv;
    if (uu < 0.0f || uu > 1.0f) return -1.0f;
    float3 q = cross(s, e1);
    float vv = dot(d, q) * inv;
    if (vv < 0.0f || uu + vv > 1.0f) return -1.0f;
    float t = dot(e2, q) * inv;
    if (!(t > 0.0f && t < tmax)) return -1.0f;
    *u = uu;
    *v = vv;
    return t;
}

inline void leaf_test(__global const float4 *tri_v0, __global const float4 *tri_e1,
                      __global const float4 *tri_e2, int k, float3 o, float3 d, uint mask,
                      Hit *hit) {
    float4 e1 = tri_e1[k];
    if ((as_uint(e1.w) & mask) == 0u) return;
    float4 v0 = tri_v0[k], e2 = tri_e2[k];
    float u, v;
    float t = tri_hit(o, d, v0.xyz, e1.xyz, e2.xyz, hit->t, &u, &v);
    if (t > 0.0f) {
        hit->t = t;
        hit->u = u;
        hit->v = v;
        hit->leaf = k;
    }
}

/* Closest hit along o + t d, 0 < t < tmax, among triangles whose visibility has a bit of mask.
 * With any_hit set it returns at the first hit (shadow rays).  The slabs are computed as
 * bound * inv_d - o * inv_d (one multiply-add per plane): 1.5x the rays per second of
 * (bound - o) * inv_d on PoCL (docs/BENCHMARKS.md).  A zero direction component becomes
 * +-2^-64 (inv_d finite, 2^64): with an infinite inv_d, bound * inf - o * inf is inf - inf =
 * NaN and an axis-parallel ray (an orthographic camera's) would miss flat boxes.  The BVH's
 * arrays are read from the scene once, into locals: the loop stores to private memory (the
 * stack, the hit), which a compiler cannot tell apart from the Scene struct the pointer
 * reaches, so a field read in the loop would be read again at every node. */
inline Hit bvh_intersect(const Scene *scene, float3 o, float3 d, float tmax, uint mask,
                         bool any_hit) {
    __global const float4 *nodes = scene->nodes, *tri_v0 = scene->tri_v0, *tri_e1 = scene->tri_e1,
                          *tri_e2 = scene->tri_e2;
    Hit hit;
    hit.t = tmax;
    hit.u = 0.0f;
    hit.v = 0.0f;
    hit.leaf = -1;
    float3 tiny = (float3)(5.421011e-20f);        /* 2^-64 */
    float3 inv_d = 1.0f / select(d, copysign(tiny, d), isless(fabs(d), tiny));
    float3 ood = o * inv_d;
    int stack[BVH_STACK];
    int sp = 0, node = 0;
    for (;;) {
        __global const float4 *nd = nodes + 4 * node;
        float4 a = nd[0], b = nd[1], c = nd[2], e = nd[3];
        int left = as_int(a.w), right = as_int(b.w);
        float3 l0 = a.xyz * inv_d - ood, l1 = b.xyz * inv_d - ood;
        float3 r0 = c.xyz * inv_d - ood, r1 = e.xyz * inv_d - ood;
        /* (compares: the slabs are finite, as inv_d is; fmin's NaN rule costs a compare and
         * a blend per lane on PoCL: 5 % of the fog room's pass) */
        float3 lmn = BVH_MIN(l0, l1), lmx = BVH_MAX(l0, l1), rmn = BVH_MIN(r0, r1),
               rmx = BVH_MAX(r0, r1);
        float tl = BVH_MAX(BVH_MAX(lmn.x, lmn.y), BVH_MAX(lmn.z, 0.0f));
        float tr = BVH_MAX(BVH_MAX(rmn.x, rmn.y), BVH_MAX(rmn.z, 0.0f));
        bool hl = tl <= BVH_MIN(BVH_MIN(lmx.x, lmx.y), BVH_MIN(lmx.z, hit.t));
        bool hr = tr <= BVH_MIN(BVH_MIN(rmx.x, rmx.y), BVH_MIN(rmx.z, hit.t));
        if (hl && left < 0) {
            leaf_test(tri_v0, tri_e1, tri_e2, ~left, o, d, mask, &hit);
            if (any_hit && hit.leaf >= 0) return hit;
            hl = false;
        }
        if (hr && right < 0) {
            leaf_test(tri_v0, tri_e1, tri_e2, ~right, o, d, mask, &hit);
            if (any_hit && hit.leaf >= 0) return hit;
            hr = false;
        }
        if (hl && hr) {
            bool left_first = tl <= tr;
            stack[sp] = left_first ? right : left;
            sp += sp < BVH_STACK - 1 ? 1 : 0;    /* full: the last slot is overwritten */
            node = left_first ? left : right;
        } else if (hl | hr) {
            node = hl ? left : right;
        } else {
            if (sp == 0) break;
            node = stack[--sp];
        }
    }
    return hit;
}

/* Surface data at a hit, from the leaf-ordered triangles and per-original-triangle normals. */
typedef struct {
    float3 p;        /* position from barycentrics (more precise than o + t d) */
    float3 ng;       /* unit geometric normal, as stored (not flipped) */
    float3 ns;       /* unit shading normal, flipped to the side of ng */
    int material;
    uint tri;        /* original triangle index */
    int leaf;        /* its index in the leaf-ordered arrays (-1: none) */
} Surface;

inline Surface surface_at(const Scene *scene, Hit h) {
    Surface s;
    float4 v0 = scene->tri_v0[h.leaf], e1 = scene->tri_e1[h.leaf], e2 = scene->tri_e2[h.leaf];
    s.p = v0.xyz + h.u * e1.xyz + h.v * e2.xyz;
    float3 ng = cross(e1.xyz, e2.xyz);
    float len = length(ng);
    s.ng = len > 0.0f ? ng / len : (float3)(0.0f, 0.0f, 1.0f);
    s.tri = as_uint(v0.w);
    s.leaf = h.leaf;
    s.material = as_int(e2.w);
    __global const float *n = scene->normals + 9 * (size_t)s.tri;
    float w = 1.0f - h.u - h.v;
    float3 ns = w * (float3)(n[0], n[1], n[2]) + h.u * (float3)(n[3], n[4], n[5])
                + h.v * (float3)(n[6], n[7], n[8]);
    float nl = length(ns);
    ns = (nl > 0.0f && isfinite(nl)) ? ns / nl : s.ng;
    s.ns = dot(ns, s.ng) < 0.0f ? -ns : ns;
    return s;
}

/* The shadow terminator (Hanika, "Hacking the Shadow Terminator", Ray Tracing Gems II; Cycles'
 * object setting Shadow Terminator > Geometry Offset): a smooth-shaded low-poly mesh lit near
 * its terminator shadows itself along its faces' edges, where the smooth surface its normals
 * describe would not.  The point at barycentrics (u, v) of triangle leaf (original index tri)
 * lifted onto that smooth surface: the barycentric mix of its projections onto the tangent
 * planes at the three corners (Phong tessellation), towards side (the side the point is seen
 * from); zero where the surface there is not convex or the corners' normals agree. */
inline float3 terminator_lift(const Scene *scene, int leaf, uint tri, float u, float v,
                              float3 side) {
    if (leaf < 0) return (float3)(0.0f);
    __global const float *n = scene->normals + 9 * (size_t)tri;
    float3 na = (float3)(n[0], n[1], n[2]), nb = (float3)(n[3], n[4], n[5]),
           nc = (float3)(n[6], n[7], n[8]);
    if (all(isequal(na, nb)) && all(isequal(na, nc))) return (float3)(0.0f);     /* flat */
    float3 a = scene->tri_v0[leaf].xyz;
    float3 b = a + scene->tri_e1[leaf].xyz, c = a + scene->tri_e2[leaf].xyz;
    float w = 1.0f - u - v;
    float3 p = w * a + u * b + v * c;
    float3 lift = w * dot(a - p, na) * na + u * dot(b - p, nb) * nb + v * dot(c - p, nc) * nc;
    return dot(lift, side) > 0.0f && all(isfinite(lift)) ? lift : (float3)(0.0f);
}
#endif
