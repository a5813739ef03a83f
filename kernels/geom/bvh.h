#ifndef PPM_BVH_H
#define PPM_BVH_H
#include "geom/geometry.h"
#include "scene.h"

/* Triangles in BVH leaf order, three float4 each (bvh_build.cl, reorder_triangles):
 *   v0 = (p0, as_float(original triangle index)), e1 = (p1 - p0, as_float(visibility bits)),
 *   e2 = (p2 - p0, as_float(material index)).
 * Nodes: 4-wide (ppm_engine/render/bvh.py collapses the binary tree the build makes), BVH_NODE
 * (7, geometry.h) float4 each: the four children's boxes by axis, (xmin, xmax, ymin, ymax,
 * zmin, zmax), one child per lane, then the children as_int4: > 0 an internal node, < 0 the
 * leaf ~k (one triangle per leaf), 0 no child (its box inverted: the root is no one's child).
 * A ray tests the four boxes at once in the vector lanes (Embree's layout; Wald et al.,
 * "Getting Rid of Packets", 2008). */
#define BVH_STACK 64
/* min and max of the slabs' distances by compares (finite: fmin's NaN rule not needed) */
#define BVH_MIN(a, b) ((a) < (b) ? (a) : (b))
#define BVH_MAX(a, b) ((a) > (b) ? (a) : (b))
/* bvh_intersect's steps: a leaf child met (c < 0) tested; entries (t, c) ordered by t; an
 * entry stacked (its t below INFINITY, which marks the lanes not met) */
#define BVH_LEAF(c)                                                \
    if ((c) < 0) {                                                 \
        leaf_test(tri_v0, tri_e1, tri_e2, ~(c), o, d, mask, &hit); \
        if (any_hit && hit.leaf >= 0) return hit;                  \
    }
#define BVH_CSWAP(ta, ca, tb, cb) \
    if ((tb) < (ta)) {            \
        float t_ = ta;            \
        int c_ = ca;              \
        ta = tb;                  \
        ca = cb;                  \
        tb = t_;                  \
        cb = c_;                  \
    }
/* A full stack's top entry is replaced (the pushes of a node go farthest first, so the nearest
 * stays; the one replaced may lose a hit: a tree unbalanced past BVH_STACK / 3 levels) */
#define BVH_PUSH(t, c)                   \
    if ((t) < INFINITY) {                \
        int k_ = min(sp, BVH_STACK - 1); \
        stack[k_] = c;                   \
        stack_t[k_] = t;                 \
        sp = k_ + 1;                     \
    }

typedef struct {
    float t, u, v;
    int leaf;         /* index into the leaf-ordered triangle arrays, -1 = miss */
} Hit;

/* Moeller-Trumbore; returns t in (0, tmax) or -1.  With ties set (tmax is a hit's), also t ==
 * tmax where the ray leaves the triangle's front side (det < 0: d . (e1 x e2) > 0): of two
 * coincident faces (a glass block resting on a floor, two boxes stacked) met at the same t the
 * one the ray leaves comes first, as the ray must leave one object before it meets what
 * touches it from outside, in whichever order the traversal tests them (where rounding gives
 * the two different t, the nearer one wins, as it must). */
inline float tri_hit(float3 o, float3 d, float3 v0, float3 e1, float3 e2, float tmax, bool ties,
                     float *u, float *v) {
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
    if (!(t > 0.0f && (t < tmax || (ties && t == tmax && det < 0.0f)))) return -1.0f;
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
    float t = tri_hit(o, d, v0.xyz, e1.xyz, e2.xyz, hit->t, hit->leaf >= 0, &u, &v);
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
 * (bound - o) * inv_d on PoCL (docs/BENCHMARKS.md), the near plane of each axis picked once
 * per ray by the direction's sign.  A zero direction component becomes +-2^-64 (inv_d finite,
 * 2^64): with an infinite inv_d, bound * inf - o * inf is inf - inf = NaN and an axis-parallel
 * ray (an orthographic camera's) would miss flat boxes.  The leaves a node's boxes meet are
 * tested at once; its internal children are visited nearest first, the others stacked with
 * their entry distances (a stacked node farther than the closest hit found since is
 * skipped).  The BVH's arrays are read from the scene once, into locals: the loop stores to
 * private memory (the stack, the hit), which a compiler cannot tell apart from the Scene
 * struct the pointer reaches, so a field read in the loop would be read again at every node. */
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
    /* the near and far planes' rows of a node by the direction's signs */
    int nx = inv_d.x < 0.0f ? 1 : 0, ny = inv_d.y < 0.0f ? 3 : 2, nz = inv_d.z < 0.0f ? 5 : 4;
    float4 ix = (float4)(inv_d.x), iy = (float4)(inv_d.y), iz = (float4)(inv_d.z);
    float4 ox = (float4)(ood.x), oy = (float4)(ood.y), oz = (float4)(ood.z);
    int stack[BVH_STACK];
    float stack_t[BVH_STACK];
    int sp = 0, node = 0;
    for (;;) {
        __global const float4 *nd = nodes + BVH_NODE * node;
        float4 tn = BVH_MAX(BVH_MAX(nd[nx] * ix - ox, nd[ny] * iy - oy),
                            BVH_MAX(nd[nz] * iz - oz, (float4)(0.0f)));
        float4 tf = BVH_MIN(BVH_MIN(nd[nx ^ 1] * ix - ox, nd[ny ^ 1] * iy - oy),
                            BVH_MIN(nd[nz ^ 1] * iz - oz, (float4)(hit.t)));
        int4 child = as_int4(nd[6]) & (tn <= tf); /* (masks, not select: a call on PoCL) */
        /* the leaves met first: their hits shorten what the internal children may be */
        BVH_LEAF(child.s0);
        BVH_LEAF(child.s1);
        BVH_LEAF(child.s2);
        BVH_LEAF(child.s3);
        /* the internal children met before the closest hit: one goes on; of more, the
         * nearest goes on and the others are stacked farthest first (a sorting network on
         * their entry distances) */
        int4 inner = child > 0 && tn <= (float4)(hit.t);
        int met = -(inner.s0 + inner.s1 + inner.s2 + inner.s3);
        if (met == 1) {
            node = inner.s0 ? child.s0 : inner.s1 ? child.s1 : inner.s2 ? child.s2 : child.s3;
            continue;
        }
        if (met > 1) {
            /* (a met child's entry at most FLT_MAX: INFINITY marks the lanes not met) */
            float4 tk = as_float4((as_int4(BVH_MIN(tn, (float4)(FLT_MAX))) & inner)
                                  | (as_int4((float4)(INFINITY)) & ~inner));
            float t0 = tk.s0, t1 = tk.s1, t2 = tk.s2, t3 = tk.s3;
            int c0 = child.s0, c1 = child.s1, c2 = child.s2, c3 = child.s3;
            BVH_CSWAP(t0, c0, t1, c1);
            BVH_CSWAP(t2, c2, t3, c3);
            BVH_CSWAP(t0, c0, t2, c2);
            BVH_CSWAP(t1, c1, t3, c3);
            BVH_CSWAP(t1, c1, t2, c2);
            BVH_PUSH(t3, c3);
            BVH_PUSH(t2, c2);
            BVH_PUSH(t1, c1);
            node = c0;
            continue;
        }
        for (;;) {
            if (sp == 0) return hit;
            --sp;
            if (stack_t[sp] <= hit.t) break;
        }
        node = stack[sp];
    }
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
