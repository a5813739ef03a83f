#ifndef PPM_VOLUME_GRID_H
#define PPM_VOLUME_GRID_H
#include "rng.h"
#include "scene.h"
#include "svm/svm_types.h"

/* Volume objects' grids (OpenVDB grids exported dense, ppm_engine/scene/voxels.py): each one
 * a header of VOXEL_HEADER floats (the object-to-index map's three rows, its size in voxels,
 * the program attribute it fills + 16 x its channels), then its voxels (x slowest, the
 * channels fastest), padded to a multiple of VOXEL_HEADER floats; an object's grids one after
 * another, named by its row 5: (random, first / VOXEL_HEADER, count, 0).  A grid is read as
 * Cycles reads a volume attribute: trilinear between the voxel centres (integer index
 * coordinates), 0 outside; a float grid as (f, f, f, 1), a vector grid as (x, y, z, 1). */
#define VOXEL_HEADER 16

/* the grid whose header is at g at index coordinates x, trilinear; with rng, one of the eight
 * voxels drawn with its trilinear weight as its probability (Cycles' stochastic
 * interpolation: a function of the value is then the trilinear mix of the function's values) */
inline float4 grid_sample(__global const float *g, float3 x, uint *rng) {
    float4 d = vload4(3, g);
    int nx = (int)d.x, ny = (int)d.y, nz = (int)d.z, c = (int)d.w / 16;
    float4 out = (float4)(0.0f, 0.0f, 0.0f, 1.0f);
    if (!(x.x > -1.0f && x.y > -1.0f && x.z > -1.0f && x.x < (float)nx && x.y < (float)ny
          && x.z < (float)nz))
        return out; /* (NaN too) */
    float3 f = floor(x), t = x - f;
    int3 i0 = convert_int3(f);
    __global const float *v = g + VOXEL_HEADER;
    if (rng) {
        int3 i = i0
                 + convert_int3(isless((float3)(1.0f) - t, (float3)(rnd(rng), rnd(rng), rnd(rng)))
                                & (int3)(1));
        if (i.x < 0 || i.y < 0 || i.z < 0 || i.x >= nx || i.y >= ny || i.z >= nz) return out;
        size_t at = (((size_t)i.x * ny + i.y) * nz + i.z) * c;
        out.xyz = c == 3 ? (float3)(v[at], v[at + 1], v[at + 2]) : (float3)(v[at]);
        return out;
    }
    for (int k = 0; k < 8; k++) {
        int3 o = (int3)(k & 1, (k >> 1) & 1, k >> 2), i = i0 + o;
        if (i.x < 0 || i.y < 0 || i.z < 0 || i.x >= nx || i.y >= ny || i.z >= nz) continue;
        float w = (o.x ? t.x : 1.0f - t.x) * (o.y ? t.y : 1.0f - t.y) * (o.z ? t.z : 1.0f - t.z);
        size_t at = (((size_t)i.x * ny + i.y) * nz + i.z) * c;
        out.xyz += w * (c == 3 ? (float3)(v[at], v[at + 1], v[at + 2]) : (float3)(v[at]));
    }
    return out;
}

/* The attributes an object's grids fill at P_object (its space), into attr[k] for the grid of
 * program attribute k (o: its rows in scene->objects; rng: grid_sample's) */
inline void grid_attributes(const Scene *scene, __global const float4 *o, float3 P_object,
                            float4 *attr, uint *rng) {
    int n = (int)o[5].z;
    __global const float *g = scene->voxels + VOXEL_HEADER * (size_t)o[5].y;
    float4 h = (float4)(P_object, 1.0f);
    for (int j = 0; j < n; j++) {
        float4 d = vload4(3, g);
        int k = (int)d.w % 16, c = (int)d.w / 16;
        float3 x = (float3)(dot(vload4(0, g), h), dot(vload4(1, g), h), dot(vload4(2, g), h));
        if (k < PPM_ATTRIBUTES) attr[k] = grid_sample(g, x, rng);
        size_t n_vox = (size_t)d.x * (size_t)d.y * (size_t)d.z * (size_t)c;
        g += VOXEL_HEADER + (n_vox + VOXEL_HEADER - 1) / VOXEL_HEADER * VOXEL_HEADER;
    }
}
#endif
