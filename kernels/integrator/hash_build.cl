/* Stochastic spatial hash (Hachisuka & Jensen 2010): each entry keeps ONE photon chosen
 * uniformly among the n that hash to it, plus n.  Departure from the paper: the choice is
 * made by the largest random key (atom_max on (key << 32) | index, or a two-pass 32-bit
 * fallback) instead of the unsynchronised last writer, which is biased whenever the order of
 * writes correlates with position.  No lists, no sorting.
 *
 * Also here: the grid over this pass's visible points (bounds expanded by each point's
 * radius), computed on the device so no host round trip sits between the passes. */
#include "builtins.h"
#include "integrator/hash.h"
#include "shared.h"
#include "geom/geometry.h"

/* floats as order-preserving uints, for atomic min/max */
inline uint f2o(float f) {
    uint u = as_uint(f);
    return (u & 0x80000000u) ? ~u : (u | 0x80000000u);
}
inline float o2f(uint u) { return as_float((u & 0x80000000u) ? (u & 0x7fffffffu) : ~u); }

/* bounds[0..2] min, [3..5] max, [6] r_max, [7] r_min (ordered uints), [8] count */
__kernel void bounds_init(__global uint *bounds, float4 init_lo, float4 init_hi) {
    float lo[3] = {init_lo.x, init_lo.y, init_lo.z}, hi[3] = {init_hi.x, init_hi.y, init_hi.z};
    for (int k = 0; k < 3; k++) {
        bounds[k] = f2o(lo[k]);
        bounds[3 + k] = f2o(hi[k]);
    }
    bounds[6] = 0u;
    bounds[7] = 0xffffffffu;
    bounds[8] = 0u;
}

__kernel __attribute__((reqd_work_group_size(BOUNDS_WG, 1, 1))) void
vp_bounds(__global const float4 *vp_pos, __global const float *radius, uint n,
          __global uint *bounds) {
    __local uint lmin[3][BOUNDS_WG], lmax[3][BOUNDS_WG], lr[BOUNDS_WG], lrmin[BOUNDS_WG],
        lc[BOUNDS_WG];
    uint id = WORK_ITEM(), l = get_local_id(0);
    float4 p = id < n ? vp_pos[id] : (float4)(0.0f);
    bool ok = id < n && p.w > 0.0f;
    float r = ok ? radius[id] : 0.0f;
    lmin[0][l] = ok ? f2o(p.x - r) : 0xffffffffu;
    lmax[0][l] = ok ? f2o(p.x + r) : 0u;
    lmin[1][l] = ok ? f2o(p.y - r) : 0xffffffffu;
    lmax[1][l] = ok ? f2o(p.y + r) : 0u;
    lmin[2][l] = ok ? f2o(p.z - r) : 0xffffffffu;
    lmax[2][l] = ok ? f2o(p.z + r) : 0u;
    lr[l] = ok ? f2o(r) : 0u;
    lrmin[l] = ok ? f2o(r) : 0xffffffffu;
    lc[l] = ok ? 1u : 0u;
    barrier(CLK_LOCAL_MEM_FENCE);
    for (uint s = BOUNDS_WG / 2; s > 0; s >>= 1) {
        if (l < s) {
            for (int k = 0; k < 3; k++) {
                lmin[k][l] = min(lmin[k][l], lmin[k][l + s]);
                lmax[k][l] = max(lmax[k][l], lmax[k][l + s]);
            }
            lr[l] = max(lr[l], lr[l + s]);
            lrmin[l] = min(lrmin[l], lrmin[l + s]);
            lc[l] += lc[l + s];
        }
        barrier(CLK_LOCAL_MEM_FENCE);
    }
    if (l == 0 && lc[0] > 0u) {
        for (int k = 0; k < 3; k++) {
            atomic_min(&bounds[k], lmin[k][0]);
            atomic_max(&bounds[3 + k], lmax[k][0]);
        }
        atomic_max(&bounds[6], lr[0]);
        atomic_min(&bounds[7], lrmin[0]);
        atomic_add(&bounds[8], lc[0]);
    }
}

/* cell size = cell_scale * r_max (>= 0.5: a query sphere overlaps at most 5 cells per axis);
 * 2 -> at most 8 cells, the paper's 1 -> 27, the default 0.5 -> ~27 typical, 125 at most. */
__kernel void grid_setup(__global const uint *bounds, float cell_scale, __global Grid *grid) {
    Grid g;
    g.valid = bounds[8];
    for (int k = 0; k < 3; k++) {
        g.bmin[k] = o2f(bounds[k]);
        g.bmax[k] = o2f(bounds[3 + k]);
    }
    g.r_max = g.valid ? o2f(bounds[6]) : 0.0f;
    g.r_min = g.valid ? o2f(bounds[7]) : 0.0f;
    float cs = fmax(fmax(cell_scale, 0.5f) * g.r_max, FLT_MIN);
    g.cell_size = cs;
    g.inv_cell_size = 1.0f / cs;
    g.pad = 0u;
    if (!g.valid)
        for (int k = 0; k < 3; k++) {
            g.bmin[k] = 0.0f;
            g.bmax[k] = 0.0f;
        }
    *grid = g;
}

__kernel void clear_table(__global ulong2 *table, uint n) {
    uint i = WORK_ITEM();
    if (i >= n) return;
    table[i] = (ulong2)(0UL);
}

/* A photon's random key in its entry: a hash of its position's bits, not of the slot the photon
 * pass gave it (an atomic counter whose order follows the threads' scheduling), so the photon
 * kept is the same whatever runs beside the render (a viewport, another process) and the same
 * seed gives the same image.  Independent of the photon's flux: the pick stays uniform. */
inline uint photon_key(uint seed, uint pass, float4 p) {
    uint id = pcg_hash(as_uint(p.x)
                       ^ pcg_hash(as_uint(p.y) ^ pcg_hash(as_uint(p.z) ^ pcg_hash(as_uint(p.w)))));
    return rng_seed(seed, pass, id, 3u) | 1u;
}

/* Photons per work-item (passes/hash_build.py HashBuild.batch: 8 on CPUs, 1 on GPUs).  An atomic on
 * x86 is a full barrier, so one photon after another waits for each entry's cache miss in turn; a
 * work-item first hashes its batch and touches the entries with plain loads (misses overlap),
 * then does the atomics on lines already in cache: 1.4-1.5x faster on a 2-core CPU (200K and 1M
 * photons, docs/BENCHMARKS.md). */
#ifndef PPM_BUILD_BATCH
#define PPM_BUILD_BATCH 1
#endif

/* (stored, occupied: the counters of the photons' count and of the entries they occupy:
 * CNT_STORED and CNT_OCCUPIED, or the volume photons' CNT_VSTORED and none, N_COUNTERS) */
__kernel void hash_build(__global const float4 *ph_pos, __global uint *counters, uint capacity,
                         __global const Grid *grid, uint table_mask, uint pass_index, uint seed,
                         __global ulong *table, uint stored, uint occupied_at) {
    uint n = min(counters[stored], capacity);
    uint i0 = WORK_ITEM() * PPM_BUILD_BATCH;
    if (i0 >= n) return;
    Grid g = *grid;
    uint m = min((uint)PPM_BUILD_BATCH, n - i0);
    uint hs[PPM_BUILD_BATCH];
#if PPM_BUILD_BATCH > 1
    uint touch = 0u;
#endif
    uint keys[PPM_BUILD_BATCH];
    for (uint k = 0; k < m; k++) {
        float4 p = ph_pos[i0 + k];
        hs[k] = cell_hash(cell_of(p.xyz, &g), table_mask);
        keys[k] = photon_key(seed, pass_index, p);
#if PPM_BUILD_BATCH > 1
        touch += ((volatile __global const uint *)table)[4 * hs[k]];     /* prefetch */
#endif
    }
    uint occupied = 0u;
    for (uint k = 0; k < m; k++) {
        uint h = hs[k], i = i0 + k;
        if (atomic_inc(&ENTRY_COUNT(table, h)) == 0u) occupied++;
        uint key = keys[k];
#ifdef PPM_INT64_ATOMICS
        atom_max(&table[2 * h + 1], ((ulong)key << 32) | (ulong)i);
#else
        atomic_max(&((__global uint *)table)[4 * h + 2], key);
#endif
    }
    if (occupied && occupied_at < N_COUNTERS) atomic_add(&counters[occupied_at], occupied);
#if PPM_BUILD_BATCH > 1
    if (touch == 0xffffffffu) counters[CNT_SINK] = 0u; /* keeps the loads; practically never true */
#endif
}

#ifndef PPM_INT64_ATOMICS
/* second pass of the 32-bit fallback: the photon whose key won writes its index */
__kernel void hash_pick(__global const float4 *ph_pos, __global const uint *counters, uint capacity,
                        __global const Grid *grid, uint table_mask, uint pass_index, uint seed,
                        __global ulong *table, uint stored, uint occupied_at) {
    uint i = WORK_ITEM();
    if (i >= min(counters[stored], capacity)) return;
    Grid g = *grid;
    float4 p = ph_pos[i];
    uint h = cell_hash(cell_of(p.xyz, &g), table_mask);
    __global uint *t32 = (__global uint *)table;
    if (t32[4 * h + 2] == photon_key(seed, pass_index, p)) t32[4 * h + 3] = i;
}
#endif

/* --- exact photon map (debug / reference mode): photons sorted by entry, every photon of the
 * entry gathered.  Slots past the stored count get the sentinel key table_size. */
__kernel void exact_keys(__global const float4 *ph_pos, __global const uint *counters,
                         uint capacity, __global const Grid *grid, uint table_mask,
                         __global uint *keys, __global uint *ids) {
    uint i = WORK_ITEM();
    if (i >= capacity) return;
    Grid g = *grid;
    keys[i] = i < min(counters[CNT_STORED], capacity)
                  ? cell_hash(cell_of(ph_pos[i].xyz, &g), table_mask)
                  : table_mask + 1u;
    ids[i] = i;
}

/* ranges[2h], ranges[2h+1] = first and one-past-last sorted position of entry h (cleared to 0) */
__kernel void exact_ranges(__global const uint *sorted_keys, uint capacity, uint table_mask,
                           __global uint *ranges) {
    uint i = WORK_ITEM();
    if (i >= capacity) return;
    uint k = sorted_keys[i];
    if (k > table_mask) return;
    if (i == 0u || sorted_keys[i - 1] != k) ranges[2 * k] = i;
    if (i + 1u == capacity || sorted_keys[i + 1] != k) ranges[2 * k + 1] = i + 1u;
}
