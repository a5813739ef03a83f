/* The majorant of a heterogeneous medium (geom/medium_field.h; ppm_engine/render/medium_bound.py):
 * its density program evaluated at one jittered point of each of n^3 cells of its object's box,
 * the largest value kept (atomic_max on the bits: densities are >= 0, whose bits order as the
 * floats do), as Cycles bounds a procedural volume's density by evaluating its shader over a
 * grid.  Tracking stays unbiased where the density exceeds the bound (weighted null
 * collisions); the bound sets how many tentative collisions a segment takes. */
#include "builtins.h"
#include "rng.h"
#include "svm/svm.h"
#include "geom/medium_field.h"

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
