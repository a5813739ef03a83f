/* Kernels for tests/test_volumes.py: the media's sampling functions (kernels/geom/medium.h) on
 * their own, as the eye pass calls them. */
#include "builtins.h"
#include "geom/medium.h"
#include "geom/majorant_grid.h"
#include "rng.h"

/* n directions from the Henyey-Greenstein phase function of anisotropy g around +z: xyz the
 * direction, w the density hg_sample gives it */
__kernel void hg_samples(float g, uint seed, __global float4 *out, uint n) {
    uint i = WORK_ITEM();
    if (i >= n) return;
    uint rng = rng_seed(seed, 0u, i, 12u);
    float u1 = rnd(&rng), u2 = rnd(&rng), pdf;
    float3 w = hg_sample((float3)(0.0f, 0.0f, 1.0f), g, u1, u2, &pdf);
    out[i] = (float4)(w, pdf);
}

/* the phase function at n cosines */
__kernel void hg_eval(float g, __global const float *cosines, __global float *out, uint n) {
    uint i = WORK_ITEM();
    if (i >= n) return;
    out[i] = hg_phase(cosines[i], g);
}

/* n equiangular distances on [t0, t] along the z axis from the origin towards c: x the
 * distance, y its density from equiangular_sample, z from equiangular_pdf */
__kernel void equiangular_samples(float4 c, float t0, float t, uint seed, __global float4 *out,
                                  uint n) {
    uint i = WORK_ITEM();
    if (i >= n) return;
    uint rng = rng_seed(seed, 0u, i, 13u);
    float3 o = (float3)(0.0f), d = (float3)(0.0f, 0.0f, 1.0f);
    float pdf, s = equiangular_sample(o, d, t0, t, c.xyz, rnd(&rng), &pdf);
    out[i] = (float4)(s, pdf, equiangular_pdf(o, d, t0, t, c.xyz, s), 0.0f);
}

/* the stretches of the majorant walks (geom/majorant_grid.h) of n segments (o: xyz, its
 * length t in w; d) through the grid at g (empty: none), at most k each: (end, bound), the
 * rest (-1, -1); `top` the box's bound */
__kernel void majorant_walks(__global const float *g, int has_grid, __global const float4 *o,
                             __global const float4 *d, float top, int k, __global float2 *out,
                             uint n) {
    uint i = WORK_ITEM();
    if (i >= n) return;
    float t = o[i].w;
    MajorantWalk w = majorant_walk(has_grid ? g : 0, o[i].xyz, d[i].xyz, t);
    float s = 0.0f;
    for (int j = 0; j < k; j++) {
        float bound = -1.0f, end = s < t ? majorant_stretch(&w, s, top, &bound) : -1.0f;
        out[i * k + j] = (float2)(end, bound);
        if (end >= 0.0f) s = end;
    }
}
