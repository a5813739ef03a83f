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

/* direct light (the eye pass's estimate: next-event estimation and the BSDF sample with MIS,
 * averaged over n_samples) at given points */
#include "direct_light.h"
__kernel void direct_light(SCENE_ARGS, __global const float4 *points, __global const float4 *nrm,
                           int n_samples, __global float4 *out, uint n) {
    uint i = get_global_id(0);
    if (i >= n) return;
    uint rng = rng_seed(1u, 0u, i, 9u);
    float3 E = (float3)(0.0f);
    for (int k = 0; k < n_samples; k++)
        E += direct_lighting(points[i].xyz, nrm[i].xyz, nrm[i].xyz, SCENE_PASS, &rng);
    out[i] = (float4)(E / (float)n_samples, 0.0f);
}
