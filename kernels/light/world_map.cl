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
/* The density of a heterogeneous medium (geom/medium_field.h) at the points of an m^3 lattice
 * over its object's box, corners included (x fastest): ppm_engine/render/medium_bound.py bounds
 * each cell of its majorant grid (geom/majorant_grid.h) by the lattice points on and in it, as
 * Cycles bounds a procedural volume's density by evaluating its shader over a grid. */
__kernel void medium_lattice(SCENE_PARAMS int mat, float4 lo, float4 hi, int m,
                             __global float *out) {
    SCENE_LOAD(scene);
    int id = WORK_ITEM();
    if (id >= m * m * m) return;
    float3 c = (float3)((float)(id % m), (float)((id / m) % m), (float)(id / (m * m)));
    out[id] = medium_density(scene, mat, lo.xyz + c / (float)(m - 1) * (hi.xyz - lo.xyz));
}

/* Tests (tests/test_majorant_grid.py): the transmittance of n segments (o: xyz, its length in
 * w; d) through medium mat's field, the mean of `reps` estimates by medium_transmittance (x),
 * by ratio tracking at the box's majorant (y) and by the telescoping sum from one sample over
 * the whole segment (w: the debiasing terms' work), and by 4096 regular steps (z) */
__kernel void medium_transmittance_test(SCENE_PARAMS int mat, __global const float4 *o,
                                        __global const float4 *d, uint seed, int reps, int n,
                                        __global float4 *out) {
    SCENE_LOAD(scene);
    int id = WORK_ITEM();
    if (id >= n) return;
    Mix x = mix_extinction(scene, mat, (float3)(0.0f));
    float3 p = o[id].xyz, v = d[id].xyz;
    float t = o[id].w, mu = mix_majorant(scene, &x), tau = 0.0f;
    float4 r = (float4)(0.0f);
    for (int k = 0; k < reps; k++) {
        uint rng = rng_seed(seed, (uint)k, (uint)id, 13u);
        r.x += medium_transmittance(scene, &x, p, v, t, &rng).x;
        r.y += ratio_piece(scene, &x, p, v, 0.0f, t, mu, &rng).x;
        r.w += telescope_piece(scene, &x, p, v, 0.0f, t, 1, &rng).x;
    }
    int steps = 4096;
    for (int i = 0; i < steps; i++)
        tau += medium_density(scene, mat, p + ((float)i + 0.5f) / (float)steps * t * v);
    r.xyw /= (float)reps;
    r.z = exp(-tau / (float)steps * t * (x.unit_a.x + x.unit_s.x));
    out[id] = r;
}
#endif
