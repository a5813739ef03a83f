/* Kernels for tests and micro benchmarks: plain ray queries against the BVH. */
#include "builtins.h"
#include "rng.h"
#include "geom/bvh.h"

/* hits[i] = (t, u, v, as_float(original triangle index or -1)) */
__kernel void trace_rays(SCENE_PARAMS __global const float4 *origins, __global const float4 *dirs,
                         uint mask, int any_hit, __global float4 *hits, uint n) {
    SCENE_LOAD(scene);
    uint i = WORK_ITEM();
    if (i >= n) return;
    float4 o = origins[i], d = dirs[i];
    Hit h = bvh_intersect(scene, o.xyz, d.xyz, d.w, mask, any_hit != 0);
    int tri = h.leaf >= 0 ? (int)as_uint(scene->tri_v0[h.leaf].w) : -1;
    hits[i] = (float4)(h.leaf >= 0 ? h.t : -1.0f, h.u, h.v, as_float(tri));
}

/* sizes of the shared structs, checked against the NumPy dtypes that mirror them */
__kernel void struct_sizes(__global uint *out) {
    out[0] = sizeof(Light);
    out[1] = sizeof(Camera);
    out[2] = sizeof(Material);
    out[3] = sizeof(EmitterInfo);
    out[4] = sizeof(Grid);
    out[5] = sizeof(ShaderNode);
}

/* direct light (the eye pass's estimate: next-event estimation and the BSDF sample with MIS,
 * averaged over n_samples) at given points, as irradiance: a white Lambert closure times pi */
#include "integrator/direct_light.h"
__kernel void direct_light_at(SCENE_PARAMS __global const float4 *points,
                              __global const float4 *nrm, int n_samples, __global float4 *out,
                              uint n) {
    SCENE_LOAD(scene);
    uint i = WORK_ITEM();
    if (i >= n) return;
    uint rng = rng_seed(1u, 0u, i, 9u);
    ShaderData sd;
#if PPM_VOLUME
    sd.media = 0;
#endif
    float3 N = nrm[i].xyz;
    sd.n = 0;
    sd.N = sd.Ng = sd.wi = N;
    sd.backfacing = sd.gather_transmits = sd.continue_glossy = false;
    sd.crossings = scene->light_paths->transparent_max_bounces;
    sd.leaf = -1; /* no triangle: no shadow terminator lift */
    sd.tri = 0u;
    sd.u = sd.v = 0.0f;
    int k = shader_alloc(&sd, CLOSURE_DIFFUSE, (float3)(PPM_PI), N);
    sd.c[k].gather = 1;
    sd.c[k].glossy = 0;
    sd.sw_gather = sd.c[k].sample_weight;
    sd.sw_continue = sd.sw_glossy = 0.0f;
    float3 E = (float3)(0.0f);
    for (int s = 0; s < n_samples; s++)
        E += direct_light(scene, &sd, points[i].xyz, MASK_GATHER, (float3)(1.0f), 0.0f, &rng);
    out[i] = (float4)(E / (float)n_samples, 0.0f);
}

/* next-event estimation's emitter pick at given points (light_mesh.h pick_emitter_at) with
 * n_u stratified numbers: counts[i * n_emitters + e] how often emitter e was picked, pmf[...]
 * the probability the pick returned for it (-1: never picked), table[...] the probability
 * the MIS of a ray that hits it uses (light_mesh.h emitter_pmf_at) */
__kernel void emitter_pick_at(SCENE_PARAMS __global const float4 *points,
                              __global const float4 *nrm, uint n_u, __global uint *counts,
                              __global float *pmf, __global float *table, uint n) {
    SCENE_LOAD(scene);
    uint i = WORK_ITEM();
    if (i >= n) return;
    int m = scene->emitter_info->n_emitters;
    float3 p = points[i].xyz, N = nrm[i].xyz;
    for (int e = 0; e < m; e++) {
        counts[i * m + e] = 0u;
        pmf[i * m + e] = -1.0f;
        table[i * m + e] = emitter_pmf_at(scene, e, p, N);
    }
    for (uint k = 0; k < n_u; k++) {
        float q;
        int e = pick_emitter_at(scene, p, N, ((float)k + 0.5f) / (float)n_u, &q);
        counts[i * m + e]++;
        pmf[i * m + e] = q;
    }
}

/* rng.h's low-discrepancy sets: out[k * n_pass + n] = set `set` of pass first + n for key
 * keys[k] (tests/test_indirect.py) */
__kernel void ld_sets(__global const uint *keys, uint n_keys, uint n_pass, uint first, uint set,
                      __global float4 *out) {
    uint i = WORK_ITEM();
    if (i >= n_keys * n_pass) return;
    out[i] = ld_set(first + i % n_pass, keys[i / n_pass], set);
}

/* kernels/builtins.h's inline builtins (on PoCL; elsewhere the driver's) against NumPy
 * (tests/test_kernels.py): per pair of float4 (x, y), eight float4 */
__kernel void builtins_at(__global const float4 *xs, __global const float4 *ys, uint n,
                          __global float4 *out) {
    uint i = WORK_ITEM();
    if (i >= n) return;
    float4 x4 = xs[i], y4 = ys[i];
    float3 x = x4.xyz, y = y4.xyz;
    __global float4 *o = out + 8 * (size_t)i;
    o[0] = (float4)(fmin(x, y), fmin(x4.w, y4.w));
    o[1] = (float4)(fmax(x, y), fmax(x4.w, y4.w));
    o[2] = (float4)(clamp(x, -1.0f, 1.0f), clamp(x4.w, fmin(y4.w, 0.0f), fmax(y4.w, 0.0f)));
    o[3] = (float4)(mix(x, y, 0.25f), dot(x, y));
    o[4] = (float4)(cross(x, y), length(x));
    o[5] = (float4)(normalize(x), sqrt(fabs(x4.w)));
    o[6] = (float4)(fabs(x), dot(x4, y4));
    o[7] = fmin(x4, y4.x) + fmax(x4, y4) * 0.5f;
}

/* isfinite (builtins.h's where PoCL compiles) of each x: the vector's components (-1 or 0) and
 * the scalar w's (1 or 0) (tests/test_kernels.py) */
__kernel void isfinite_at(__global const float4 *xs, uint n, __global float4 *out) {
    uint i = WORK_ITEM();
    if (i >= n) return;
    float4 x = xs[i];
    int4 v = isfinite(x);
    out[2 * (size_t)i] = (float4)(convert_float3(isfinite(x.xyz)), (float)isfinite(x.w));
    out[2 * (size_t)i + 1] = convert_float4(v);
}

/* geometry.h's sincos_turns at each u: (sin, cos) of 2 pi u (tests/test_kernels.py) */
__kernel void sincos_turns_at(__global const float *us, uint n, __global float2 *out) {
    uint i = WORK_ITEM();
    if (i >= n) return;
    out[i] = sincos_turns(us[i]);
}
