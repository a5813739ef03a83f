/* Gather: each visible point reads the 8 cells its sphere can overlap (cell = 2 r_max), each
 * DISTINCT hash entry once (two cells can share an entry), one photon fetch per entry.  The
 * entry's photon stands for all n photons of the entry (flux x n): unbiased, since every
 * photon of the entry is chosen with probability 1/n and only accepted within the radius. */
#include "hash.h"
#include "geometry.h"

/* photons on a surface facing another way (thin walls, corners) are not this point's */
#define NORMAL_COS_MIN 0.5f

__kernel void gather(__global const float4 *vp_pos, __global const float4 *vp_nrm,
                     __global const float *radius, __global const Grid *grid,
                     __global const ulong *table, uint table_mask,
                     __global const float4 *ph_pos, __global const float4 *ph_flux,
                     __global float4 *gathered, uint n) {
    uint id = get_global_id(0);
    if (id >= n) return;
    float4 vp = vp_pos[id];
    Grid g = *grid;
    if (vp.w <= 0.0f || g.valid == 0u) { gathered[id] = (float4)(0.0f); return; }
    float3 x = vp.xyz, nrm = vp_nrm[id].xyz;
    float r = radius[id], r2 = r * r;
    long3 base = convert_long3(floor(clamp((x - F3(g.bmin)) * g.inv_cell_size - 0.5f,
                                           -1.0e15f, 1.0e15f)));
    uint h[8];
#pragma unroll
    for (int k = 0; k < 8; k++)
        h[k] = cell_hash(base + (long3)(k & 1, (k >> 1) & 1, (k >> 2) & 1), table_mask);
    float3 phi = (float3)(0.0f);
    float M = 0.0f;
#pragma unroll
    for (int k = 0; k < 8; k++) {
        bool dup = false;
        for (int j = 0; j < k; j++) dup |= (h[j] == h[k]);
        uint cnt = dup ? 0u : ENTRY_COUNT(table, h[k]);
        if (cnt == 0u) continue;
        uint pi = ENTRY_INDEX(table, h[k]);
        float4 pp = ph_pos[pi];
        float3 dd = pp.xyz - x;
        if (dot(dd, dd) > r2) continue;
        if (dot(unpack_unit(as_uint(pp.w)), nrm) < NORMAL_COS_MIN) continue;
        float4 pf = ph_flux[pi];
        if (dot(unpack_unit(as_uint(pf.w)), nrm) <= 0.0f) continue;
        M += (float)cnt;
        phi += (float)cnt * pf.xyz;
    }
    gathered[id] = (float4)(phi, M);
}

/* Exact gather (reference mode): every photon of every distinct entry the sphere overlaps. */
__kernel void gather_exact(__global const float4 *vp_pos, __global const float4 *vp_nrm,
                           __global const float *radius, __global const Grid *grid,
                           __global const uint *ranges, __global const uint *sorted_ids,
                           uint table_mask, __global const float4 *ph_pos,
                           __global const float4 *ph_flux, __global float4 *gathered, uint n) {
    uint id = get_global_id(0);
    if (id >= n) return;
    float4 vp = vp_pos[id];
    Grid g = *grid;
    if (vp.w <= 0.0f || g.valid == 0u) { gathered[id] = (float4)(0.0f); return; }
    float3 x = vp.xyz, nrm = vp_nrm[id].xyz;
    float r = radius[id], r2 = r * r;
    long3 base = convert_long3(floor(clamp((x - F3(g.bmin)) * g.inv_cell_size - 0.5f,
                                           -1.0e15f, 1.0e15f)));
    uint h[8];
    for (int k = 0; k < 8; k++)
        h[k] = cell_hash(base + (long3)(k & 1, (k >> 1) & 1, (k >> 2) & 1), table_mask);
    float3 phi = (float3)(0.0f);
    float M = 0.0f;
    for (int k = 0; k < 8; k++) {
        bool dup = false;
        for (int j = 0; j < k; j++) dup |= (h[j] == h[k]);
        if (dup) continue;
        uint end = ranges[2 * h[k] + 1];
        for (uint s = ranges[2 * h[k]]; s < end; s++) {
            uint pi = sorted_ids[s];
            float4 pp = ph_pos[pi];
            float3 dd = pp.xyz - x;
            if (dot(dd, dd) > r2) continue;
            if (dot(unpack_unit(as_uint(pp.w)), nrm) < NORMAL_COS_MIN) continue;
            float4 pf = ph_flux[pi];
            if (dot(unpack_unit(as_uint(pf.w)), nrm) <= 0.0f) continue;
            M += 1.0f;
            phi += pf.xyz;
        }
    }
    gathered[id] = (float4)(phi, M);
}
