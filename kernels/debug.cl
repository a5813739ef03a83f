/* Kernels for tests and micro benchmarks: plain ray queries against the BVH. */
#include "bvh.h"

/* hits[i] = (t, u, v, as_float(original triangle index or -1)) */
__kernel void trace_rays(BVH_ARGS, __global const float4 *origins, __global const float4 *dirs,
                         uint mask, int any_hit, __global float4 *hits, uint n) {
    uint i = get_global_id(0);
    if (i >= n) return;
    float4 o = origins[i], d = dirs[i];
    Hit h = bvh_intersect(o.xyz, d.xyz, d.w, mask, any_hit != 0, BVH_PASS);
    int tri = h.leaf >= 0 ? (int)as_uint(tri_v0[h.leaf].w) : -1;
    hits[i] = (float4)(h.leaf >= 0 ? h.t : -1.0f, h.u, h.v, as_float(tri));
}

/* sizes of the shared structs, checked against the NumPy dtypes that mirror them */
__kernel void struct_sizes(__global uint *out) {
    out[0] = sizeof(Light);
    out[1] = sizeof(Camera);
    out[2] = sizeof(Material);
    out[3] = sizeof(EmitterInfo);
    out[4] = sizeof(Grid);
}
