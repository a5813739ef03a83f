/* Data-parallel BVH build (ppm_engine/render/bvh.py): Morton codes -> pyopencl RadixSort (host
 * side)
 * -> a hierarchy, by PLOC (the default, below) or Karras' LBVH ("Maximizing Parallelism in the
 * Construction of BVHs, Octrees, and k-d Trees", HPG 2012) -> bottom-up boxes -> packed nodes
 * and leaf-ordered triangles (layout in bvh.h). */
#include "builtins.h"
#include "geom/geometry.h"

/* an empty slot among a 4-wide node's sources (bvh.py BVH4_EMPTY: INT_MIN, never ~k) */
#define BVH4_EMPTY (-2147483647 - 1)

inline uint expand_bits(uint v) {
    v = (v * 0x00010001u) & 0xFF0000FFu;
    v = (v * 0x00000101u) & 0x0F00F00Fu;
    v = (v * 0x00000011u) & 0xC30C30C3u;
    v = (v * 0x00000005u) & 0x49249249u;
    return v;
}

__kernel void morton_codes(__global const float *pos, uint n, float4 cmin, float4 cscale,
                           __global uint *codes, __global uint *ids) {
    uint i = WORK_ITEM();
    if (i >= n) return;
    __global const float *p = pos + 9 * (size_t)i;
    float3 c = ((float3)(p[0], p[1], p[2]) + (float3)(p[3], p[4], p[5])
                + (float3)(p[6], p[7], p[8]))
               * (1.0f / 3.0f);
    float3 q = clamp((c - cmin.xyz) * cscale.xyz, 0.0f, 1023.0f);
    if (!isfinite(q.x) || !isfinite(q.y) || !isfinite(q.z)) q = (float3)(0.0f);
    uint3 qi = convert_uint3(q);
    codes[i] = (expand_bits(qi.x) << 2) | (expand_bits(qi.y) << 1) | expand_bits(qi.z);
    ids[i] = i;
}

/* length of the common prefix of keys i and j, ties broken by the index (Karras' delta) */
inline int prefix(__global const uint *codes, int n, int i, int j) {
    if (j < 0 || j >= n) return -1;
    uint a = codes[i], b = codes[j];
    if (a == b) return 32 + (int)clz((uint)(i ^ j));
    return (int)clz(a ^ b);
}

/* internal node i of n-1; children >= 0 internal, < 0 leaf ~k */
__kernel void build_hierarchy(__global const uint *codes, int n, __global int *left,
                              __global int *right, __global int *parent_int,
                              __global int *parent_leaf) {
    int i = WORK_ITEM();
    if (i >= n - 1) return;
    int d = prefix(codes, n, i, i + 1) - prefix(codes, n, i, i - 1) > 0 ? 1 : -1;
    int dmin = prefix(codes, n, i, i - d);
    int lmax = 2;
    while (prefix(codes, n, i, i + lmax * d) > dmin) lmax *= 2;
    int l = 0;
    for (int t = lmax / 2; t >= 1; t /= 2)
        if (prefix(codes, n, i, i + (l + t) * d) > dmin) l += t;
    int j = i + l * d;
    int dnode = prefix(codes, n, i, j);
    int s = 0, t = l;
    do {
        t = (t + 1) >> 1;
        if (prefix(codes, n, i, i + (s + t) * d) > dnode) s += t;
    } while (t > 1);
    int gamma = i + s * d + min(d, 0);
    int lc = (min(i, j) == gamma) ? ~gamma : gamma;
    int rc = (max(i, j) == gamma + 1) ? ~(gamma + 1) : gamma + 1;
    left[i] = lc;
    right[i] = rc;
    if (lc < 0) parent_leaf[~lc] = i;
    else parent_int[lc] = i;
    if (rc < 0) parent_leaf[~rc] = i;
    else parent_int[rc] = i;
    if (i == 0) parent_int[0] = -1;
}

/* Leaf boxes, then up the tree: the second child to arrive at a node computes its box
 * (an atomic counter per node; the first arrival stops). */
__kernel void
bottom_up_boxes(__global const float *pos, __global const uint *sorted_ids, int n,
                __global const int *left, __global const int *right, __global const int *parent_int,
                __global const int *parent_leaf, __global volatile float4 *leaf_min,
                __global volatile float4 *leaf_max, __global volatile float4 *node_min,
                __global volatile float4 *node_max, __global volatile uint *arrivals) {
    int k = WORK_ITEM();
    if (k >= n) return;
    __global const float *p = pos + 9 * (size_t)sorted_ids[k];
    float3 a = (float3)(p[0], p[1], p[2]), b = (float3)(p[3], p[4], p[5]),
           c = (float3)(p[6], p[7], p[8]);
    leaf_min[k] = (float4)(fmin(a, fmin(b, c)), 0.0f);
    leaf_max[k] = (float4)(fmax(a, fmax(b, c)), 0.0f);
    int node = parent_leaf[k];
    while (node >= 0) {
        mem_fence(CLK_GLOBAL_MEM_FENCE);
        if (atomic_inc(&arrivals[node]) == 0u) return;
        mem_fence(CLK_GLOBAL_MEM_FENCE);
        int l = left[node], r = right[node];
        float4 lmin = l < 0 ? leaf_min[~l] : node_min[l], lmax = l < 0 ? leaf_max[~l] : node_max[l];
        float4 rmin = r < 0 ? leaf_min[~r] : node_min[r], rmax = r < 0 ? leaf_max[~r] : node_max[r];
        node_min[node] = fmin(lmin, rmin);
        node_max[node] = fmax(lmax, rmax);
        node = parent_int[node];
    }
}

/* The 4-wide nodes (layout in bvh.h) from the binary tree's boxes: node i's four children are
 * the binary tree's nodes src[i] (>= 0 internal, < 0 leaf ~k, BVH4_EMPTY none), chosen by
 * collapse4 in bvh.py; child[i] their references in the 4-wide tree.  An empty slot gets an
 * inverted box (min +inf, max -inf), which no ray's slabs meet. */
__kernel void pack_nodes4(int m, __global const int4 *src, __global const int4 *child,
                          __global const float4 *leaf_min, __global const float4 *leaf_max,
                          __global const float4 *node_min, __global const float4 *node_max,
                          __global float4 *nodes) {
    int i = WORK_ITEM();
    if (i >= m) return;
    int s[4];
    vstore4(src[i], 0, s);
    float lo[3][4], hi[3][4];
    for (int k = 0; k < 4; k++) {
        float4 a = (float4)(INFINITY), b = (float4)(-INFINITY);
        if (s[k] != BVH4_EMPTY) {
            a = s[k] < 0 ? leaf_min[~s[k]] : node_min[s[k]];
            b = s[k] < 0 ? leaf_max[~s[k]] : node_max[s[k]];
        }
        lo[0][k] = a.x, lo[1][k] = a.y, lo[2][k] = a.z;
        hi[0][k] = b.x, hi[1][k] = b.y, hi[2][k] = b.z;
    }
    __global float4 *nd = nodes + BVH_NODE * (size_t)i;
    for (int a = 0; a < 3; a++) {
        nd[2 * a] = vload4(0, lo[a]);
        nd[2 * a + 1] = vload4(0, hi[a]);
    }
    nd[6] = as_float4(child[i]);
}

__kernel void reorder_triangles(__global const float *pos, __global const uint *sorted_ids,
                                __global const int *material, __global const uint *visibility,
                                int n, __global float4 *tri_v0, __global float4 *tri_e1,
                                __global float4 *tri_e2) {
    int k = WORK_ITEM();
    if (k >= n) return;
    uint t = sorted_ids[k];
    __global const float *p = pos + 9 * (size_t)t;
    float3 a = (float3)(p[0], p[1], p[2]), b = (float3)(p[3], p[4], p[5]),
           c = (float3)(p[6], p[7], p[8]);
    tri_v0[k] = (float4)(a, as_float(t));
    tri_e1[k] = (float4)(b - a, as_float(visibility[t]));
    tri_e2[k] = (float4)(c - a, as_float(material[t]));
}

/* --- PLOC: Parallel Locally-Ordered Clustering (Meister & Bittner, "Parallel Locally-Ordered
 * Clustering for Bounding Volume Hierarchy Construction", TVCG 2018) ------------------------
 * The clusters start as the Morton-sorted leaves.  Each round, every cluster finds the cluster
 * within PLOC_RADIUS places of it (in Morton order) whose union box has the smallest surface
 * area; mutual nearest neighbours merge into a new node; the survivors are compacted (a
 * pyopencl scan on the host side) in order.  Near-SAH trees, built data-parallel: the Karras
 * hierarchy above splits by Morton bits only and its boxes overlap badly around large
 * triangles (a Cornell box: 17.9 nodes visited per ray against 10.5 for a SAH tree).
 * Nodes are numbered from n - 2 down, so the last merge -- the root -- is node 0, and the
 * left/right/parent arrays mean what build_hierarchy's do (bottom_up_boxes, refit). */
#ifndef PLOC_RADIUS
#define PLOC_RADIUS 16
#endif

inline float box_area(float4 lo, float4 hi) {
    float4 d = fmax(hi - lo, (float4)(0.0f));
    return 2.0f * (d.x * d.y + d.y * d.z + d.z * d.x);
}

__kernel void ploc_init(__global const float *pos, __global const uint *sorted_ids, int n,
                        __global float4 *cl_min, __global float4 *cl_max, __global int *cl_id) {
    int k = WORK_ITEM();
    if (k >= n) return;
    __global const float *p = pos + 9 * (size_t)sorted_ids[k];
    float3 a = (float3)(p[0], p[1], p[2]), b = (float3)(p[3], p[4], p[5]),
           c = (float3)(p[6], p[7], p[8]);
    float3 lo = fmin(a, fmin(b, c)), hi = fmax(a, fmax(b, c));
    /* a NaN corner (scenes are cleaned before, but stay safe) must not poison the areas */
    cl_min[k] = (float4)(select(lo, (float3)(0.0f), isnan(lo)), 0.0f);
    cl_max[k] = (float4)(select(hi, (float3)(0.0f), isnan(hi)), 0.0f);
    cl_id[k] = ~k;
}

/* nn[i]: the cluster j != i, |i - j| <= PLOC_RADIUS, with the smallest union area; a tie keeps
 * the first j found (ascending), which is the pair with the smaller (min, max) index -- a
 * strict order on pairs, so the globally best pair is always mutual and every round merges */
__kernel void ploc_nearest(__global const float4 *cl_min, __global const float4 *cl_max, int m,
                           __global int *nn) {
    int i = WORK_ITEM();
    if (i >= m) return;
    float4 lo = cl_min[i], hi = cl_max[i];
    float best = INFINITY;
    int bj = -1;
    int j0 = max(i - PLOC_RADIUS, 0), j1 = min(i + PLOC_RADIUS, m - 1);
    for (int j = j0; j <= j1; j++) {
        if (j == i) continue;
        float a = box_area(fmin(lo, cl_min[j]), fmax(hi, cl_max[j]));
        if (a < best) {
            best = a;
            bj = j;
        }
    }
    nn[i] = bj;
}

__kernel void ploc_merge(__global float4 *cl_min, __global float4 *cl_max, __global int *cl_id,
                         __global const int *nn, int m, __global int *node_counter,
                         __global int *left, __global int *right, __global int *parent_int,
                         __global int *parent_leaf, __global uint *valid) {
    int i = WORK_ITEM();
    if (i >= m) return;
    int j = nn[i];
    uint keep = 1u;
    if (j >= 0 && nn[j] == i) {
        if (i < j) {
            int node = atomic_dec(node_counter) - 1;        /* n - 2, n - 3, ..., 0 (root) */
            int a = cl_id[i], b = cl_id[j];
            left[node] = a;
            right[node] = b;
            if (a < 0) parent_leaf[~a] = node;
            else parent_int[a] = node;
            if (b < 0) parent_leaf[~b] = node;
            else parent_int[b] = node;
            if (node == 0) parent_int[0] = -1;
            cl_min[i] = fmin(cl_min[i], cl_min[j]);
            cl_max[i] = fmax(cl_max[i], cl_max[j]);
            cl_id[i] = node;
        } else {
            keep = 0u;                                       /* merged into cluster j */
        }
    }
    valid[i] = keep;
}

/* the surviving clusters, in order, at their scanned positions */
__kernel void ploc_compact(__global const float4 *cl_min, __global const float4 *cl_max,
                           __global const int *cl_id, __global const uint *valid,
                           __global const uint *position, int m, __global float4 *out_min,
                           __global float4 *out_max, __global int *out_id) {
    int i = WORK_ITEM();
    if (i >= m || !valid[i]) return;
    uint k = position[i];
    out_min[k] = cl_min[i];
    out_max[k] = cl_max[i];
    out_id[k] = cl_id[i];
}
