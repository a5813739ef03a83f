#ifndef PPM_SVM_UTIL_H
#define PPM_SVM_UTIL_H
#include "geom/geometry.h"

/* What the shader program's nodes share: the stack's vectors, a safe normalisation, Cycles'
 * dielectric Fresnel, the equirectangular projection and the baked tables' lookup. */

inline float3 svm_safe_normalize(float3 a) {
    float l = length(a);
    return l != 0.0f ? a / l : (float3)(0.0f);
}
inline float3 svm_get3(const float *s, int k) { return (float3)(s[k], s[k + 1], s[k + 2]); }
inline void svm_put3(float *s, int k, float3 v) {
    s[k] = v.x;
    s[k + 1] = v.y;
    s[k + 2] = v.z;
}

/* Cycles' fresnel_dielectric_cos: the Fresnel reflectance at cosine c for relative index eta
 * (1 under total internal reflection) */
inline float svm_fresnel_cos(float c, float eta) {
    c = fabs(c);
    float g2 = eta * eta - 1.0f + c * c;
    if (!(g2 > 0.0f)) return 1.0f;
    float g = sqrt(g2), A = (g - c) / (g + c), B = (c * (g + c) - 1.0f) / (c * (g - c) + 1.0f);
    return 0.5f * A * A * (1.0f + B * B);
}

/* Cycles' equirectangular projection (learnt from its direction_to_equirectangular): +X at
 * u = 0.5, +Y at u = 0.25, the zenith at v = 1 */
inline float2 direction_to_equirect(float3 d) {
    if (!(dot(d, d) > 0.0f)) return (float2)(0.0f);
    return (float2)(0.5f - atan2(d.y, d.x) * (0.5f / PPM_PI),
                    1.0f - acos(clamp(d.z / length(d), -1.0f, 1.0f)) * (1.0f / PPM_PI));
}
inline float3 equirect_to_direction(float u, float v) {
    float phi = PPM_PI * (1.0f - 2.0f * u), theta = PPM_PI * (1.0f - v);
    return (float3)(sin(theta) * cos(phi), sin(theta) * sin(phi), cos(theta));
}

/* a baked ramp or curve at x in [lo, hi] (linear between entries, or the entry below) */
inline float4 svm_table(__global const int4 *t, int n, float x, float lo, float hi, int interp) {
    float f = hi > lo ? (x - lo) / (hi - lo) : 0.0f;
    f = clamp(isfinite(f) ? f : 0.0f, 0.0f, 1.0f) * (float)(n - 1);
    int i = min((int)f, n - 1);
    float4 a = as_float4(t[i]);
    if (!interp || i >= n - 1) return a;
    return mix(a, as_float4(t[i + 1]), f - (float)i);
}
#endif
