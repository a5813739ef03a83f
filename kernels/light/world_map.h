#ifndef PPM_WORLD_MAP_H
#define PPM_WORLD_MAP_H
#include "svm/svm_util.h"

/* The world's importance map (layout: world.h), sampled and evaluated: a w x h map whose
 * values have mean `mean`. */
/* index k with cdf[k] <= x < cdf[k + 1] among n intervals, and x's place in it */
inline int cdf_find(__global const float *cdf, int n, float x, float *t) {
    int lo = 0, hi = n - 1;
    while (lo < hi) {
        int mid = (lo + hi + 1) >> 1;
        if (cdf[mid] <= x) lo = mid;
        else hi = mid - 1;
    }
    float a = cdf[lo], b = cdf[lo + 1];
    *t = b > a ? clamp((x - a) / (b - a), 0.0f, 1.0f) : 0.5f;
    return lo;
}

/* the map's density of direction d over solid angle */
inline float world_map_pdf(float3 d, int w, int h, float mean, __global const float *map) {
    float2 uv = direction_to_equirect(d);
    float s = sin(PPM_PI * clamp(uv.y, 0.0f, 1.0f));
    if (!(s > 0.0f) || !(mean > 0.0f)) return 0.0f;
    int j = clamp((int)floor(uv.x * (float)w), 0, w - 1);
    int i = clamp((int)floor(uv.y * (float)h), 0, h - 1);
    float f = map[(h + 1) + h * (w + 1) + i * w + j];
    return f / (mean * 2.0f * PPM_PI * PPM_PI * s);
}

/* a direction from the map: wi and its density over solid angle */
inline bool world_map_sample(int w, int h, float mean, __global const float *map, float u1,
                             float u2, float3 *wi, float *pdf) {
    float tv, tu;
    int i = cdf_find(map, h, u1, &tv);
    int j = cdf_find(map + (h + 1) + i * (w + 1), w, u2, &tu);
    float u = ((float)j + tu) / (float)w, v = ((float)i + tv) / (float)h;
    *wi = equirect_to_direction(u, v);
    float s = sin(PPM_PI * v);
    float f = map[(h + 1) + h * (w + 1) + i * w + j];
    *pdf = s > 0.0f && mean > 0.0f ? f / (mean * 2.0f * PPM_PI * PPM_PI * s) : 0.0f;
    return *pdf > 0.0f;
}

#endif
