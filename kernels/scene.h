#ifndef PPM_SCENE_H
#define PPM_SCENE_H
#include "types.h"

/* The scene as one value in the kernels.  SCENE_DATA (shared.h, generated from
 * ppm_engine/render/device_scene.py SCENE_BUFFERS) lists the scene's buffers once; from it come
 *   - SCENE_PARAMS, the parameters of every kernel that reads the scene (first in its list;
 *     the host binds them by name, device/program.py Launch),
 *   - Scene, one struct of __global pointers, and SCENE_LOAD(scene), which fills one from the
 *     parameters at the kernel's entry: OpenCL 1.2 cannot pass pointers inside a struct
 *     argument, so a private struct built at entry is what every helper takes
 *     (`const Scene *scene`), as Cycles' OpenCL kernels took their KernelGlobals.
 * A new buffer is one row of SCENE_BUFFERS; nothing here changes. */
#define SCENE_FIELD(T, name) __global const T *name;
typedef struct {
    SCENE_DATA(SCENE_FIELD)
} Scene;

#define SCENE_PARAM(T, name) __global const T *name,
#define SCENE_PARAMS SCENE_DATA(SCENE_PARAM)

#define SCENE_VALUE(T, name) name,
#define SCENE_LOAD(scene)                                  \
    const Scene scene##_value = {SCENE_DATA(SCENE_VALUE)}; \
    const Scene *scene = &scene##_value

/* The probability of emitter e in the power table (its step of the cdf) */
inline float emitter_pmf(__global const float *cdf, int e) {
    return cdf[e] - (e > 0 ? cdf[e - 1] : 0.0f);
}

/* Emitter chosen in proportion to its power (cdf built by ppm_engine/scene/emitters.py): the lights
 * first, then the emissive triangles, then the world. */
inline int pick_emitter(__global const float *cdf, int n, float u, float *pmf) {
    int lo = 0, hi = n - 1;
    while (lo < hi) {
        int mid = (lo + hi) >> 1;
        if (u < cdf[mid]) hi = mid;
        else lo = mid + 1;
    }
    *pmf = emitter_pmf(cdf, lo);
    return lo;
}
#endif
