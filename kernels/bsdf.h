#ifndef PPM_BSDF_H
#define PPM_BSDF_H
#include "geometry.h"
#include "rng.h"

/* The material model (ppm_engine/materials.py derives it from the Principled BSDF):
 * a mixture of a Lambert lobe, a perfect mirror (metal) and a smooth dielectric (glass with
 * Fresnel).  A lobe is chosen with probability equal to its mixture weight, so the weights
 * cancel and each lobe carries only its own tint. */
#define LOBE_ABSORBED 0
#define LOBE_DIFFUSE 1
#define LOBE_MIRROR 2
#define LOBE_GLASS_REFLECT 3
#define LOBE_GLASS_TRANSMIT 4

inline float fresnel_dielectric(float cos_i, float eta) {
    /* eta = n_t / n_i; cos_i > 0 on the incident side */
    float sin2_t = (1.0f - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.0f) return 1.0f;
    float cos_t = sqrt(1.0f - sin2_t);
    float rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    float rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    return 0.5f * (rs * rs + rp * rp);
}

inline int choose_lobe(__global const Material *m, float u) {
#if PPM_SPECULAR
    if (u < m->p_metal) return LOBE_MIRROR;
    if (u < m->p_metal + m->p_glass) return LOBE_GLASS_REFLECT;   /* resolved by Fresnel */
#endif
    return (m->flags & MAT_DIFFUSE) ? LOBE_DIFFUSE : LOBE_ABSORBED;
}

inline float3 reflect3(float3 d, float3 n) { return d - 2.0f * dot(d, n) * n; }

/* Scatter a ray arriving along d off a specular lobe (tint: the base colour texture's factor at
 * the hit).  ng, ns: the surface's normals as stored
 * (ns on the side of ng).  Updates *d, *weight and returns the lobe taken; *leave_n is the
 * geometric normal on the side the new ray leaves to (for offset_ray).
 * Refraction follows Cycles' convention: camera paths (radiance_mode) carry no
 * (eta_i/eta_t)^2 radiance compression, and photons carry the matching (eta_i/eta_t)^2 on their
 * flux, so both estimators agree with Cycles -- also for an emitter inside glass, where the
 * physical convention would be eta^2 darker than Cycles.  For paths that start and end in air
 * the factors cancel and the conventions agree.  *measure is that factor (1 for camera paths and
 * reflections): a change of measure, not a loss, which Russian roulette must not act on. */
inline int scatter_specular(int lobe, __global const Material *m, float3 tint, float3 ng,
                            float3 ns, float u, bool radiance_mode, float3 *d, float3 *weight,
                            float3 *leave_n, float *measure) {
    *measure = 1.0f;
    bool front = dot(*d, ng) < 0.0f;           /* arriving on the side ng points to */
    float3 n = front ? ns : -ns;               /* shading normal facing the incoming ray */
    float3 ngf = front ? ng : -ng;
    if (lobe == LOBE_MIRROR) {
        float3 r = reflect3(*d, n);
        if (dot(r, ngf) <= 0.0f) r = reflect3(*d, ngf);
        *d = normalize(r);
        *weight *= F3(m->specular) * tint;
        *leave_n = ngf;
        return LOBE_MIRROR;
    }
#if !PPM_GLASS
    return LOBE_ABSORBED;            /* never reached: no material of the scene has glass */
#else
    /* smooth dielectric: ng points outside the object */
    float eta = front ? m->ior : 1.0f / m->ior;
    float cos_i = clamp(-dot(*d, n), 0.0f, 1.0f);
    float F = fresnel_dielectric(cos_i, eta);
    if (u < F) {
        float3 r = reflect3(*d, n);
        if (dot(r, ngf) <= 0.0f) r = reflect3(*d, ngf);
        *d = normalize(r);
        *leave_n = ngf;
        return LOBE_GLASS_REFLECT;
    }
    float sin2_t = (1.0f - cos_i * cos_i) / (eta * eta);
    float cos_t = sqrt(fmax(0.0f, 1.0f - sin2_t));
    float3 t = *d / eta + (cos_i / eta - cos_t) * n;
    if (dot(t, ngf) >= 0.0f) t = *d;           /* shading normal bent it back: pass straight */
    *d = normalize(t);
    *weight *= F3(m->transmit) * tint;
    if (!radiance_mode) {
        *measure = 1.0f / (eta * eta);
        *weight *= *measure;
    }
    *leave_n = -ngf;
    return LOBE_GLASS_TRANSMIT;
#endif
}
#endif
