#ifndef PPM_GUIDE_H
#define PPM_GUIDE_H
#include "geom/geometry.h"
#include "scene.h"

/* Photon guides (ppm_engine/scene/guide.py): a guided light's directions in GUIDE_ROWS x
 * GUIDE_COLS bins of equal solid angle in its frame (make_frame around its axis: a point
 * light's world z, a spot's or an area light's direction), rows equal steps of the cosine to
 * the axis from zmin to 1, columns equal steps of the azimuth.  The scene's guide buffer holds
 * per guided light zmin, the share of photons in the light's own distribution ("native", 1
 * until something was learned), two spare floats and the CDF of the bins' learned weights. */

inline __global const float *guide_of(const Scene *scene, int light) {
    int s = scene->guide_slot[light];
    return s >= 0 ? scene->guide + s * GUIDE_STRIDE : (__global const float *)0;
}

/* the bin holding direction d (its cosine to the axis at least zmin) */
inline int guide_bin(float3 axis, float zmin, float3 d) {
    float3 t, b;
    make_frame(axis, &t, &b);
    float z = dot(d, axis);
    int row = (int)((z - zmin) / (1.0f - zmin) * (float)GUIDE_ROWS);
    float turns = atan2(dot(d, b), dot(d, t)) * (0.5f / PPM_PI);
    if (turns < 0.0f) turns += 1.0f;
    int col = (int)(turns * (float)GUIDE_COLS);
    return clamp(row, 0, GUIDE_ROWS - 1) * GUIDE_COLS + clamp(col, 0, GUIDE_COLS - 1);
}

/* the learned part's density (per steradian) at bin k */
inline float guide_density(__global const float *g, int k) {
    __global const float *cdf = g + 4;
    float w = cdf[k] - (k > 0 ? cdf[k - 1] : 0.0f);
    return w * ((float)GUIDE_BINS / (2.0f * PPM_PI * (1.0f - g[0])));
}

/* a direction from the learned bins (u0 picks the bin, u1 u2 place it inside) */
inline float3 guide_sample(__global const float *g, float3 axis, float u0, float u1, float u2) {
    __global const float *cdf = g + 4;
    int lo = 0, hi = GUIDE_BINS - 1;
    while (lo < hi) {
        int mid = (lo + hi) >> 1;
        if (u0 < cdf[mid]) hi = mid;
        else lo = mid + 1;
    }
    float zmin = g[0];
    int row = lo / GUIDE_COLS, col = lo - row * GUIDE_COLS;
    float z = zmin + (1.0f - zmin) * ((float)row + u1) * (1.0f / (float)GUIDE_ROWS);
    z = clamp(z, -1.0f, 1.0f);
    float s = sqrt(fmax(0.0f, 1.0f - z * z));
    float2 sc = sincos_turns(((float)col + u2) * (1.0f / (float)GUIDE_COLS));
    return normalize(to_world_frame((float3)(s * sc.y, s * sc.x, z), axis));
}

/* The mixture's density at d: the native share times the light's own density pn, plus the
 * rest times the learned bins', *bin the bin of d */
inline float guide_mixture(__global const float *g, float3 axis, float3 d, float pn, int *bin) {
    float zmin = g[0], native = g[1];
    if (dot(d, axis) < zmin) {
        *bin = -1;
        return native * pn;
    }
    *bin = guide_bin(axis, zmin, d);
    return native * pn + (1.0f - native) * guide_density(g, *bin);
}
#endif
