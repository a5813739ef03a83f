#ifndef PPM_FRESNEL_H
#define PPM_FRESNEL_H
#include "geom/geometry.h"

/* Fresnel models of the closures (kernels/closure/closure.h), as Cycles defines them
 * (docs/SHADING.md: the models and their sources). */

inline float sqr(float x) { return x * x; }
inline float3 sat3(float3 c) { return clamp(c, 0.0f, 1.0f); }
inline float avg3(float3 c) { return (c.x + c.y + c.z) * (1.0f / 3.0f); }

/* reflectance at normal incidence of a dielectric interface of relative index ior, and back */
inline float f0_from_ior(float ior) { return sqr((ior - 1.0f) / (ior + 1.0f)); }
inline float ior_from_f0(float f0) {
    float s = sqrt(clamp(f0, 0.0f, 0.99f));
    return (1.0f + s) / (1.0f - s);
}

/* Unpolarised reflectance of a dielectric interface for light arriving at cos_i (> 0) from the
 * side of relative index eta = n_transmitted / n_incident.  *cos_t is set to the cosine of the
 * refracted direction (negative: it points into the surface); total internal reflection
 * returns 1 and leaves *cos_t alone. */
inline float fresnel_dielectric(float cos_i, float eta, float *cos_t) {
    float e = eta * eta - (1.0f - cos_i * cos_i);
    if (e <= 0.0f) return 1.0f;
    cos_i = fabs(cos_i);
    float ct = -sqrt(e) / eta;
    *cos_t = ct;
    float rs = (cos_i + eta * ct) / (cos_i - eta * ct);
    float rp = (ct + eta * cos_i) / (eta * cos_i - ct);
    return 0.5f * (rs * rs + rp * rp);
}

/* the refracted direction of wi (pointing away from the surface, on the side of n) through a
 * surface of normal n, given the refracted cosine (negative) and 1 / eta */
inline float3 refract_dir(float3 wi, float3 n, float cos_t, float inv_eta) {
    return (inv_eta * dot(n, wi) + cos_t) * n - inv_eta * wi;
}

/* Average of 2 cos F over the hemisphere (Kulla & Conty 2017's fit) */
inline float fresnel_dielectric_fss(float eta) {
    if (eta < 1.0f) return 0.997118f + eta * (0.1014f - eta * (0.965241f + eta * 0.130607f));
    return (eta - 1.0f) / (4.08567f + 1.00071f * eta);
}

/* F82-tint (Kutz et al., "Novel aspects of the Adobe Standard Material"): Schlick's curve from
 * F0 with a cos (1 - cos)^6 dip whose size B makes F(acos 1/7) = Schlick x tint. */
inline float3 fresnel_f82_b(float3 f0, float3 tint) {
    const float f = 6.0f / 7.0f, f5 = f * f * f * f * f;
    return mix(f0, (float3)(1.0f), f5) * (7.0f / (f5 * f)) * ((float3)(1.0f) - tint);
}
inline float3 fresnel_f82(float cos_i, float3 f0, float3 b) {
    float s = clamp(1.0f - cos_i, 0.0f, 1.0f), s5 = s * s * s * s * s;
    return sat3(mix(f0, (float3)(1.0f), s5) - b * (cos_i * s5 * s));
}
inline float3 fresnel_f82_fss(float3 f0, float3 b) {
    return mix(f0, (float3)(1.0f), 1.0f / 21.0f) - b * (1.0f / 126.0f);
}
/* B of the classic F82 model, from the reflectance at acos(1/7) */
inline float3 fresnel_f82_b_from_f82(float3 f0, float3 f82) {
    const float f = 6.0f / 7.0f, f5 = f * f * f * f * f;
    return (7.0f / (f5 * f)) * (mix(f0, (float3)(1.0f), f5) - f82);
}

/* Reflectance of a conductor of complex index n + i k (per channel) from air, unpolarised
 * (Born & Wolf 14.4.1). */
inline float fresnel_conductor1(float cos_i, float n, float k) {
    float c2 = cos_i * cos_i, s2 = 1.0f - c2;
    float t1 = n * n - k * k - s2, t2 = sqrt(t1 * t1 + 4.0f * n * n * k * k);
    float a2 = fmax(0.5f * (t2 + t1), 0.0f), a = sqrt(a2);
    float rs = (t2 + c2 - 2.0f * a * cos_i) / (t2 + c2 + 2.0f * a * cos_i);
    float rp = rs * (c2 * t2 + s2 * s2 - 2.0f * a * cos_i * s2)
               / (c2 * t2 + s2 * s2 + 2.0f * a * cos_i * s2);
    float r = 0.5f * (rs + rp);
    return isfinite(r) ? clamp(r, 0.0f, 1.0f) : 1.0f;
}
inline float3 fresnel_conductor(float cos_i, float3 n, float3 k) {
    return (float3)(fresnel_conductor1(cos_i, n.x, k.x), fresnel_conductor1(cos_i, n.y, k.y),
                    fresnel_conductor1(cos_i, n.z, k.z));
}
#endif
