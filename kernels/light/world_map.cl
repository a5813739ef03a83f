/* Shader programs baked on the device: the world's importance map (ppm_engine/render/world_map.py:
 * the radiance of the world's shader program at the centre of each texel of a w x h lat-long map,
 * Cycles' equirectangular directions, row 0 at the nadir, as Cycles bakes its background map;
 * the texels near a sun disc averaged over sub x sub points), and heterogeneous media's
 * majorants (below).  One program of every node serves every scene (specialize off). */
#include "builtins.h"
#include "svm/svm.h"
#include "light/world_map.h"
#include "rng.h"
#include "geom/medium_field.h"

__kernel void world_bake(SCENE_PARAMS int program, int w, int h, float4 sun, int sub,
                         __global float4 *out) {
    SCENE_LOAD(scene);
    int id = WORK_ITEM();
    if (id >= w * h) return;
    int i = id / w, j = id % w;
    float3 d = equirect_to_direction(((float)j + 0.5f) / (float)w, ((float)i + 0.5f) / (float)h);
    float3 L = (float3)(0.0f);
    if (sub > 1 && dot(d, sun.xyz) > sun.w) {
        /* a texel near a sun disc (a sky's, world_map.sun_hint): the mean of sub x sub points
         * of it, so that the map sees a disc smaller than a texel */
        for (int a = 0; a < sub; a++)
            for (int b = 0; b < sub; b++) {
                float3 e = equirect_to_direction(((float)j + ((float)b + 0.5f) / (float)sub) / w,
                                                 ((float)i + ((float)a + 0.5f) / (float)sub) / h);
                L += svm_world(scene, program, e);
            }
        L /= (float)(sub * sub);
    } else {
        L = svm_world(scene, program, d);
    }
    out[id] = (float4)(L, 0.0f);
}

/* Tests (tests/test_world.py): n directions sampled from the map with their densities, and the
 * density world_map_pdf gives each (float4: direction, pdf; and the pdf again) */
__kernel void world_sample_test(__global const float *map, int w, int h, float mean, uint seed,
                                int n, __global float4 *dirs, __global float *pdf_again) {
    int id = WORK_ITEM();
    if (id >= n) return;
    uint rng = rng_seed(seed, 0u, (uint)id, 7u);
    float3 wi;
    float pdf;
    if (!world_map_sample(w, h, mean, map, rnd(&rng), rnd(&rng), &wi, &pdf)) pdf = 0.0f;
    dirs[id] = (float4)(wi, pdf);
    pdf_again[id] = world_map_pdf(wi, w, h, mean, map);
}

#if PPM_VOLUME
/* The majorant of a heterogeneous medium (geom/medium_field.h; ppm_engine/render/medium_bound.py):
 * its density program evaluated at one jittered point of each of n^3 cells of its object's box,
 * the largest value kept (atomic_max on the bits: densities are >= 0, whose bits order as the
 * floats do), as Cycles bounds a procedural volume's density by evaluating its shader over a
 * grid.  Tracking stays unbiased where the density exceeds the bound (weighted null
 * collisions); the bound sets how many tentative collisions a segment takes. */
__kernel void medium_bound(SCENE_PARAMS int mat, float4 lo, float4 hi, int n, uint seed,
                           __global uint *out) {
    SCENE_LOAD(scene);
    int id = WORK_ITEM();
    if (id >= n * n * n) return;
    uint rng = rng_seed(seed, 0u, (uint)id, 11u);
    float3 c = (float3)((float)(id % n), (float)((id / n) % n), (float)(id / (n * n)));
    float3 u = (c + (float3)(rnd(&rng), rnd(&rng), rnd(&rng))) / (float)n;
    float d = medium_density(scene, mat, lo.xyz + u * (hi.xyz - lo.xyz));
    atomic_max(out, as_uint(d));
}
#endif
