#ifndef PPM_CLOSURE_H
#define PPM_CLOSURE_H
#include "closure/microfacet.h"

/* The closures' sample and eval, one dispatch for every pass (eye, photons, direct light, the
 * gather).  The diffuse-like closures are here; the microfacet ones in microfacet.h.  Closure
 * types a program never makes compile away (PPM_MICROFACET, PPM_SHEEN, PPM_OREN_NAYAR,
 * PPM_TRANSLUCENT, PPM_TRANSPARENT: shared.h). */

/* --- Oren-Nayar: Fujii's improved model with OpenPBR's energy-preserving multiple scattering ---
 * */
inline float oren_nayar_g(float c) {
    if (c < 1e-6f) return (0.5f * PPM_PI - 2.0f / 3.0f) - c;
    float s = sqrt(fmax(0.0f, 1.0f - c * c)), th = acos(clamp(c, -1.0f, 1.0f));
    return s * (th - 2.0f / 3.0f - s * c) + 2.0f / 3.0f * (s / c) * (1.0f - s * s * s);
}

/* A (ior) and B (energy_scale) from the roughness, and the multiple scattering term (f0) for
 * the colour and the view wi */
inline void oren_nayar_setup(Closure *c, float roughness, float3 color, float3 wi) {
    float sigma = clamp(roughness, 0.0f, 1.0f);
    float a = 1.0f / (PPM_PI + sigma * (0.5f * PPM_PI - 2.0f / 3.0f)), b = sigma * a;
    c->ior = a;
    c->energy_scale = b;
    float3 albedo = sat3(color);
    float eavg = a * PPM_PI + ((2.0f * PPM_PI - 5.6f) / 3.0f) * b;
    float3 ems = (1.0f / PPM_PI) * albedo * albedo * (eavg / (1.0f - eavg))
                 / ((float3)(1.0f) - albedo * (1.0f - eavg));
    float ev = a * PPM_PI + b * oren_nayar_g(fmax(dot(c->N, wi), 0.0f));
    c->f0 = ems * (1.0f - ev);
}

inline float3 oren_nayar_intensity(const Closure *c, float3 wi, float3 wo) {
    float nl = fmax(dot(c->N, wo), 0.0f), a = c->ior, b = c->energy_scale;
    if (b <= 0.0f) return (float3)(nl / PPM_PI);
    float nv = fmax(dot(c->N, wi), 0.0f), t = dot(wo, wi) - nl * nv;
    if (t > 0.0f) t /= fmax(nl, nv) + FLT_MIN;
    float el = a * PPM_PI + b * oren_nayar_g(nl);
    return nl * ((float3)(a + b * t) + c->f0 * (1.0f - el));
}

/* --- sheen (Zeltner, Burley & Chiang 2022): an LTC of a cosine lobe, a and b in ior and
 * energy_scale, its frame (T, cross(N, T), N) with T towards the view ---------------------- */
inline float sheen_value(const Closure *c, float3 lo) {
    float a = c->ior, b = c->energy_scale;
    float l2 = sqr(a * lo.x + b * lo.z) + sqr(a * lo.y) + sqr(lo.z);
    return (1.0f / PPM_PI) * fmax(lo.z, 0.0f) * sqr(a / l2);
}
inline float3 sheen_local(const Closure *c, float3 w) {
    float3 y = cross(c->N, c->T);
    return (float3)(dot(w, c->T), dot(w, y), dot(w, c->N));
}

/* f cos(N, wo) of closure c (without its weight); *pdf: the density c samples wo with; light:
 * for next-event estimation (microfacet_eval) */
inline float3 closure_eval(const Closure *c, float3 wi, float3 wo, bool light, float *pdf) {
    *pdf = 0.0f;
    int t = c->type;
    if (t == CLOSURE_DIFFUSE) {
        float v = fmax(dot(c->N, wo), 0.0f) * (1.0f / PPM_PI);
        *pdf = v;
        return (float3)(v);
    }
    if (PPM_OREN_NAYAR && t == CLOSURE_OREN_NAYAR) {
        float cno = dot(c->N, wo);
        if (cno <= 0.0f) return (float3)(0.0f);
        *pdf = cno * (1.0f / PPM_PI);
        return oren_nayar_intensity(c, wi, wo);
    }
    if (PPM_TRANSLUCENT && t == CLOSURE_TRANSLUCENT) {
        float v = fmax(-dot(c->N, wo), 0.0f) * (1.0f / PPM_PI);
        *pdf = v;
        return (float3)(v);
    }
    if (PPM_SHEEN && t == CLOSURE_SHEEN) {
        float v = sheen_value(c, sheen_local(c, wo));
        *pdf = v;
        return (float3)(v);
    }
    if (PPM_MICROFACET && t >= CLOSURE_GGX_REFLECT && t <= CLOSURE_GGX_GLASS)
        return microfacet_eval(c, wi, wo, light, pdf);
    return (float3)(0.0f);        /* transparent and singular lobes: sampled only */
}

/* Samples wo for closure c and view wi (ng: the geometric normal on wi's side; rand: three
 * uniforms).  Returns the label (LABEL_NONE: no direction); *eval and *pdf as closure_eval
 * gives them (a singular lobe: its discrete weight and probability); *eta the relative index
 * crossed (1 unless refracted). */
inline int closure_sample(const Closure *c, float3 ng, float3 wi, float3 rand, float3 *eval,
                          float3 *wo, float *pdf, float *eta) {
    *eta = 1.0f;
    *pdf = 0.0f;
    int t = c->type;
    if (PPM_MICROFACET && t >= CLOSURE_GGX_REFLECT && t <= CLOSURE_GGX_GLASS)
        return microfacet_sample(c, ng, wi, rand, eval, wo, pdf, eta);
    if (PPM_TRANSPARENT && t == CLOSURE_TRANSPARENT) {
        *wo = -wi;
        *eval = (float3)(1.0f);
        *pdf = 1.0f;
        return LABEL_TRANSMIT | LABEL_TRANSPARENT | LABEL_SINGULAR;
    }
    if (PPM_SHEEN && t == CLOSURE_SHEEN) {
        float2 d = sample_disk(rand.x, rand.y);
        float dz = sqrt(fmax(0.0f, 1.0f - dot(d, d)));
        float3 lo = normalize((float3)(d.x - dz * c->energy_scale, d.y, dz * c->ior));
        *wo = lo.x * c->T + lo.y * cross(c->N, c->T) + lo.z * c->N;
        if (dot(ng, *wo) <= 0.0f) return LABEL_NONE;
        float v = sheen_value(c, lo);
        *pdf = v;
        *eval = (float3)(v);
        return v > 0.0f ? LABEL_REFLECT | LABEL_DIFFUSE : LABEL_NONE;
    }
    bool translucent = PPM_TRANSLUCENT && t == CLOSURE_TRANSLUCENT;
    *wo = sample_cosine_hemisphere(translucent ? -c->N : c->N, rand.x, rand.y);
    if ((dot(ng, *wo) > 0.0f) == translucent) return LABEL_NONE;
    float v = fabs(dot(c->N, *wo)) * (1.0f / PPM_PI);
    *pdf = v;
    *eval = PPM_OREN_NAYAR && t == CLOSURE_OREN_NAYAR ? oren_nayar_intensity(c, wi, *wo)
                                                      : (float3)(v);
    if (!(v > 0.0f)) return LABEL_NONE;
    return (translucent ? LABEL_TRANSMIT : LABEL_REFLECT) | LABEL_DIFFUSE;
}
#endif
