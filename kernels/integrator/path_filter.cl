/* Path space filtering (Keller, Dahm and Binder 2016, "Path Space Filtering"): the eye pass
 * records, per pixel whose eye path went on from a Lambert second vertex x2
 * (indirect_paths.h PathRecord), x2, its path state, the light the path found past x2 over its
 * weight (v: an estimate of the irradiance at x2 over pi) and the weight (w).  Here the records
 * are grouped by grid cell (cell size and offset: this pass's, ppm_engine/render/passes/
 * path_filter.py), x2's orientation (pf_fingerprint) and path state;
 * each pixel then gets w times its group's mean v instead of its own.  Each v is an unbiased
 * estimate of its own x2's value, so the mean's bias is the irradiance's change across a cell:
 * the cells shrink over the passes (Knaus & Zwicker's schedule) and their offset moves each
 * pass, so the render converges to the unfiltered image's limit.  pf_slot: the entry each
 * record's group got (PF_NONE: the table's probe ran out, the pixel keeps its own v). */
#include "builtins.h"
#include "rng.h"
#include "types.h"
#include "geom/geometry.h"
#ifdef PPM_INT64_ATOMICS
#pragma OPENCL EXTENSION cl_khr_int64_base_atomics : enable
#endif

#define PF_NONE 0xffffffffu
/* a table entry (passes/path_filter.py): the sum of its records' v (words 0-5: three 64-bit
 * sums of v in fixed point, with 64-bit atomics, so that the sum is exact and the same in any
 * order of the work-items, the image the same from run to run; else words 0-2, floats), its
 * fingerprint (word 6; 0: free) and its records (word 7) */
#define PF_WORDS 8
#define PF_FP 6
#define PF_COUNT 7
#ifdef PPM_INT64_ATOMICS
#define PF_FIXED 16777216.0f /* 2^24 */
/* the largest v summed (2^14: 2^25 records of it fit a sum); a record past it keeps its own */
#define PF_VMAX 16384.0f
#else
#define PF_VMAX INFINITY
#endif
#define PF_PROBES 64

/* the surface's orientation in bins of the octahedral map of its normal (as packed, geometry.h
 * pack_unit), PF_NORMAL_BINS per axis, moved by this pass's jitter: a flat surface's records
 * share one, a curved one's are grouped with those of a like normal */
#define PF_NORMAL_BINS 8.0f

/* the record's group: a 32-bit fingerprint of its cell, orientation and path state (never 0);
 * grid: this pass's cell offset (xyz) and size (w), jitter: its normal bins' offset (xy) */
inline uint pf_fingerprint(float4 pos, float4 v, float4 grid, float4 jitter) {
    float3 c = floor((pos.xyz - grid.xyz) * (1.0f / grid.w));
    int3 ci = convert_int3(clamp(c, (float3)(-1.0e9f), (float3)(1.0e9f)));
    uint q = as_uint(v.w);
    float2 e = (float2)((float)(q & 0xffffu), (float)(q >> 16)) * (1.0f / 65535.0f);
    int2 nb = convert_int2(floor(e * PF_NORMAL_BINS + jitter.xy));
    uint h = pcg_hash((uint)ci.x * 73856093u
                      ^ pcg_hash((uint)ci.y * 19349663u ^ pcg_hash((uint)ci.z * 83492791u)));
    h = pcg_hash(h ^ (uint)nb.x * 2246822519u ^ (uint)nb.y * 3266489917u);
    return pcg_hash(h ^ pcg_hash(as_uint(pos.w))) | 1u;
}

/* every stride-th record's x2 and path state into pos (w: its path state; NaN x: none) and its
 * v into v, for the first pass's choices (passes/path_filter.py) */
__kernel void pf_sample(__global const float4 *pf_pos, __global const float4 *pf_v,
                        __global const float4 *pf_w, uint n, uint stride, __global float4 *pos,
                        __global float4 *v) {
    uint i = WORK_ITEM();
    if (i >= n) return;
    uint k = i * stride;
    pos[i] = pf_w[k].w > 0.0f ? pf_pos[k] : (float4)(NAN, 0.0f, 0.0f, 0.0f);
    v[i] = pf_v[k];
}

__kernel void pf_insert(__global const float4 *pf_pos, __global const float4 *pf_v,
                        __global const float4 *pf_w, uint n, float4 grid, float4 jitter,
                        __global uint *table, uint mask, __global uint *pf_slot) {
    uint id = WORK_ITEM();
    if (id >= n) return;
    if (!(pf_w[id].w > 0.0f)) return;
    float4 v = pf_v[id];
    if (!(max3(v.xyz) <= PF_VMAX)) {
        pf_slot[id] = PF_NONE;
        return;
    }
    uint fp = pf_fingerprint(pf_pos[id], v, grid, jitter);
    uint h = pcg_hash(fp ^ 0x9e3779b9u) & mask;
    uint slot = PF_NONE;
    for (int k = 0; k < PF_PROBES; k++, h = (h + 1u) & mask) {
        uint old = atomic_cmpxchg(&table[PF_WORDS * h + PF_FP], 0u, fp);
        if (old == 0u || old == fp) {
            slot = h;
            break;
        }
    }
    pf_slot[id] = slot;
    if (slot == PF_NONE) return;
    __global uint *e = table + PF_WORDS * slot;
    atomic_inc(&e[PF_COUNT]);
#ifdef PPM_INT64_ATOMICS
    __global ulong *s = (__global ulong *)e;
    atom_add(&s[0], convert_ulong_sat_rte(v.x * PF_FIXED));
    atom_add(&s[1], convert_ulong_sat_rte(v.y * PF_FIXED));
    atom_add(&s[2], convert_ulong_sat_rte(v.z * PF_FIXED));
#else
    atomic_add_float((volatile __global float *)&e[0], v.x);
    atomic_add_float((volatile __global float *)&e[1], v.y);
    atomic_add_float((volatile __global float *)&e[2], v.z);
#endif
}

__kernel void pf_resolve(__global const float4 *pf_v, __global const float4 *pf_w,
                         __global const uint *pf_slot, __global const uint *table,
                         __global float4 *direct_pass, uint n, uint own) {
    uint id = WORK_ITEM();
    if (id >= n) return;
    float4 w = pf_w[id];
    if (!(w.w > 0.0f)) return;
    uint slot = own ? PF_NONE : pf_slot[id]; /* own: the filter is off (each its own v) */
    float3 m = pf_v[id].xyz;
    if (slot != PF_NONE) {
        __global const uint *e = table + PF_WORDS * slot;
#ifdef PPM_INT64_ATOMICS
        __global const ulong *s = (__global const ulong *)e;
        m = (float3)((float)s[0], (float)s[1], (float)s[2]) * (1.0f / PF_FIXED);
#else
        m = (float3)(as_float(e[0]), as_float(e[1]), as_float(e[2]));
#endif
        m *= 1.0f / (float)e[PF_COUNT];
    }
    float3 add = w.xyz * m;
    if (isfinite(add.x) && isfinite(add.y) && isfinite(add.z))
        direct_pass[id] += (float4)(add, 0.0f);
}
