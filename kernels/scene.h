#ifndef PPM_SCENE_H
#define PPM_SCENE_H
#include "bvh.h"
#include "rng.h"
#include "shader.h"

/* Everything a pass kernel needs to see the scene: BVH, shading normals, materials with their
 * BSDF nodes and the shading tables, emitters, textures and UVs (ppm_engine/device_scene.py
 * binds them by these names). */
#define SCENE_ARGS BVH_ARGS, __global const float *normals, SHADING_ARGS, \
    __global const Light *lights, __global const float *emitter_cdf, __global const int *emissive, \
    __global const EmitterInfo *emitter_info, __global const float *world_map
#define SCENE_PASS BVH_PASS, normals, SHADING_PASS, lights, emitter_cdf, emissive, emitter_info, world_map

/* The probability of emitter e in the power table (its step of the cdf) */
inline float emitter_pmf(__global const float *cdf, int e) {
    return cdf[e] - (e > 0 ? cdf[e - 1] : 0.0f);
}

/* Emitter chosen in proportion to its power (cdf built by ppm_engine/emitters.py): the lights
 * first, then the emissive triangles, then the world. */
inline int pick_emitter(__global const float *cdf, int n, float u, float *pmf) {
    int lo = 0, hi = n - 1;
    while (lo < hi) {
        int mid = (lo + hi) >> 1;
        if (u < cdf[mid]) hi = mid; else lo = mid + 1;
    }
    *pmf = emitter_pmf(cdf, lo);
    return lo;
}
#endif
