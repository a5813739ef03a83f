/* Kernels for tests/test_closures.py: the shader of one material at a point at the origin with
 * normal +z (no texture), sampled and evaluated through the same functions every pass uses. */
#include "builtins.h"
#include "closure/shader.h"
#include "rng.h"

inline void test_setup(const Scene *scene, ShaderData *sd, int mat, float4 wi) {
    Surface s;
    s.p = (float3)(0.0f);
    s.ng = s.ns = (float3)(0.0f, 0.0f, 1.0f);
    s.material = mat;
    s.tri = 0u;
    s.leaf = -1;
    shader_setup(scene, sd, &s, 0.0f, 0.0f, PATH_CAMERA, 1.0f, normalize(wi.xyz), NO_FOOTPRINT);
}

/* n samples of the material's closures in mask: wo (w = the mixture pdf, INFINITY for a
 * singular lobe, 0 when no direction) and the throughput weight (w = the label) */
__kernel void shade_sample(SCENE_PARAMS int mat, float4 wi, int mask, uint seed,
                           __global float4 *out_wo, __global float4 *out_weight, uint n) {
    SCENE_LOAD(scene);
    uint i = WORK_ITEM();
    if (i >= n) return;
    ShaderData sd;
    test_setup(scene, &sd, mat, wi);
    uint rng = rng_seed(seed, 0u, i, 11u);
    float3 rand = (float3)(rnd(&rng), rnd(&rng), rnd(&rng));
    BsdfSample b;
    if (!shader_sample(&sd, mask, rand, &b)) {
        out_wo[i] = (float4)(0.0f);
        out_weight[i] = (float4)(0.0f);
        return;
    }
    out_wo[i] = (float4)(b.wo, b.pdf);
    out_weight[i] = (float4)(b.weight, (float)b.label);
}

/* the mixture's f cos (xyz) and pdf (w) for directions wo */
__kernel void shade_eval(SCENE_PARAMS int mat, float4 wi, int mask, __global const float4 *wo,
                         __global float4 *out, uint n) {
    SCENE_LOAD(scene);
    uint i = WORK_ITEM();
    if (i >= n) return;
    ShaderData sd;
    test_setup(scene, &sd, mat, wi);
    float pdf;
    float3 f = shader_eval(&sd, normalize(wo[i].xyz), mask, &pdf);
    out[i] = (float4)(f, pdf);
}

/* the closures made: per closure (type, gather, sample weight, glossy) and (weight, 0); and the
 * emission, transparency (rows n_max, n_max + 1) */
__kernel void shade_closures(SCENE_PARAMS int mat, float4 wi, __global float4 *out_info,
                             __global float4 *out_weight, int n_max) {
    SCENE_LOAD(scene);
    if (WORK_ITEM() != 0) return;
    ShaderData sd;
    test_setup(scene, &sd, mat, wi);
    for (int k = 0; k < n_max; k++) {
        bool ok = k < sd.n;
        out_info[k] = ok ? (float4)((float)sd.c[k].type, (float)sd.c[k].gather,
                                    sd.c[k].sample_weight, (float)sd.c[k].glossy)
                         : (float4)(-1.0f);
        out_weight[k] = ok ? (float4)(sd.c[k].weight, 0.0f) : (float4)(0.0f);
    }
    out_weight[n_max] = (float4)(sd.emission, 0.0f);
    out_weight[n_max + 1] = (float4)(sd.transparent, 0.0f);
}
