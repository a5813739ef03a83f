#ifndef PPM_MICROFACET_H
#define PPM_MICROFACET_H
#include "closure/closure_types.h"
#include "closure/shading_tables.h"

/* GGX microfacet closures as Cycles defines them (docs/SHADING.md): Walter et al. 2007's BSDF
 * with the height-correlated Smith term, sampled by Heitz 2018's visible normals; reflection
 * and refraction chosen in proportion to the Fresnel terms; multiple scattering compensated by
 * scaling with 1 / E (the single-scattering albedo, shading_tables.h) and Kulla & Conty's
 * coloured Fresnel term. */

/* Smith's Lambda from alpha^2 tan^2 */
inline float ggx_lambda_t2(float a2t2) { return 0.5f * (sqrt(1.0f + a2t2) - 1.0f); }
inline float ggx_lambda(float alpha2, float cos_n) {
    return ggx_lambda_t2(alpha2 * fmax(1.0f / (cos_n * cos_n) - 1.0f, 0.0f));
}
inline float ggx_lambda_aniso(float ax, float ay, float3 v) {
    return ggx_lambda_t2((sqr(ax * v.x) + sqr(ay * v.y)) / (v.z * v.z));
}
inline float ggx_d(float alpha2, float cos_nh) {
    float c2 = fmin(cos_nh * cos_nh, 1.0f);
    return alpha2 / (PPM_PI * sqr(1.0f - c2 + alpha2 * c2));
}
inline float ggx_d_aniso(float ax, float ay, float3 h) {
    h /= (float3)(ax, ay, 1.0f);
    float l2 = dot(h, h);
    return 1.0f / (PPM_PI * ax * ay * l2 * l2);
}

/* a visible normal for view v (local frame, v.z > 0), Heitz 2018 */
inline float3 ggx_sample_vndf(float3 v, float ax, float ay, float u1, float u2) {
    float3 vh = normalize((float3)(ax * v.x, ay * v.y, v.z));
    float lensq = vh.x * vh.x + vh.y * vh.y;
    float3 t1 = lensq > 1e-7f ? (float3)(-vh.y, vh.x, 0.0f) * rsqrt(lensq)
                              : (float3)(1.0f, 0.0f, 0.0f);
    float3 t2 = lensq > 1e-7f ? cross(vh, t1) : (float3)(0.0f, 1.0f, 0.0f);
    float2 t = sample_disk(u1, u2);
    t.y = mix(sqrt(fmax(0.0f, 1.0f - t.x * t.x)), t.y, 0.5f * (1.0f + vh.z));
    float3 h = t.x * t1 + t.y * t2 + sqrt(fmax(0.0f, 1.0f - t.x * t.x - t.y * t.y)) * vh;
    return normalize((float3)(ax * h.x, ay * h.y, fmax(0.0f, h.z)));
}

inline bool microfacet_singular(const Closure *c) {
    return c->alpha_x * c->alpha_y <= ROUGHNESS_SQ_THRESH;
}

/* the tangent frame of c (x along its tangent when anisotropic) */
inline void microfacet_frame(const Closure *c, float3 *x, float3 *y) {
    if (c->alpha_x == c->alpha_y) {
        make_frame(c->N, x, y);
    } else {
        *y = normalize(cross(c->N, c->T));
        *x = cross(*y, c->N);
    }
}

/* reflectance R and transmittance T of c at cos_hi; *cos_ho the refracted cosine */
inline void microfacet_fresnel(const Closure *c, float cos_hi, float *cos_ho, float3 *R,
                               float3 *T) {
    bool has_r = c->type != CLOSURE_GGX_REFRACT, has_t = c->type != CLOSURE_GGX_REFLECT;
    float ct = 0.0f;
    if (c->fresnel == FRESNEL_DIELECTRIC) {
        float F = fresnel_dielectric(cos_hi, c->ior, &ct);
        *R = (float3)(F);
        *T = (float3)(1.0f - F);
    } else if (c->fresnel == FRESNEL_SCHLICK_IOR) {
        float F_real = fresnel_dielectric(cos_hi, c->ior, &ct), F0_real = f0_from_ior(c->ior);
        float s = clamp((F_real - F0_real) / (1.0f - F0_real), 0.0f, 1.0f);
        float3 F = mix(c->f0, c->f90, s);
        *R = F * c->refl_tint;
        *T = ((float3)(1.0f) - F) * c->trans_tint;
    } else if (c->fresnel == FRESNEL_F82) {
        *R = fresnel_f82(cos_hi, c->f0, c->f90);
        *T = (float3)(0.0f);
    } else if (c->fresnel == FRESNEL_CONDUCTOR) {
        *R = fresnel_conductor(cos_hi, c->f0, c->f90);
        *T = (float3)(0.0f);
    } else {
        *R = *T = (float3)(1.0f);
        if (has_t && fresnel_dielectric(cos_hi, c->ior, &ct) == 1.0f) *T = (float3)(0.0f);
    }
    *cos_ho = ct;
    if (!has_r) *R = (float3)(0.0f);
    if (!has_t) *T = (float3)(0.0f);
}

/* D, Lambda(wi), Lambda(wo) at half vector h */
inline void microfacet_terms(const Closure *c, float3 h, float3 wi, float3 wo, bool refract,
                             float *D, float *li, float *lo) {
    float cos_ni = dot(c->N, wi), cos_no = dot(c->N, wo), cos_nh = dot(c->N, h);
    if (c->alpha_x == c->alpha_y || refract) {
        float a2 = c->alpha_x * c->alpha_y;
        *D = ggx_d(a2, cos_nh);
        *li = ggx_lambda(a2, cos_ni);
        *lo = ggx_lambda(a2, cos_no);
    } else {
        float3 x, y;
        microfacet_frame(c, &x, &y);
        *D = ggx_d_aniso(c->alpha_x, c->alpha_y, (float3)(dot(x, h), dot(y, h), cos_nh));
        *li = ggx_lambda_aniso(c->alpha_x, c->alpha_y, (float3)(dot(x, wi), dot(y, wi), cos_ni));
        *lo = ggx_lambda_aniso(c->alpha_x, c->alpha_y, (float3)(dot(x, wo), dot(y, wo), cos_no));
    }
}

/* f cos(N, wo) of c for the view wi and light from wo; *pdf the density microfacet_sample gives
 * wo.  Next-event estimation (light) evaluates as Cycles does: a refraction whose half vector
 * lies on the wrong side of wi or wo, which no microfacet can make and sampling never gives,
 * still has a value and a density (its terms depend on the half vector's line only).  Cycles'
 * light sampling finds that light and its BSDF sampling does not, so its image has it (MIS
 * weighs it by the density that sampling never realises): seen from inside rough glass, light
 * leaves through the surface where it could not, strongest at grazing views and high
 * roughness (a glass cube's faces towards a lamp, roughness 1: 2.5 x with it, as Cycles;
 * docs/SHADING.md "Rough glass").  Every other use (a sampled direction's density, photons,
 * the gather, light tracing) keeps eval equal to what sampling can produce. */
inline float3 microfacet_eval(const Closure *c, float3 wi, float3 wo, bool light, float *pdf) {
    *pdf = 0.0f;
    bool has_r = c->type != CLOSURE_GGX_REFRACT, has_t = c->type != CLOSURE_GGX_REFLECT;
    float cos_ni = dot(c->N, wi), cos_no = dot(c->N, wo);
    bool refract = cos_no < 0.0f;
    if (cos_ni <= 0.0f || microfacet_singular(c) || (refract && !has_t) || (!refract && !has_r))
        return (float3)(0.0f);
    float3 h = refract ? -(c->ior * wo + wi) : wi + wo;
    float len_h = length(h);
    if (!(len_h > 0.0f)) return (float3)(0.0f);
    float inv_len = 1.0f / len_h;
    h *= inv_len;
    /* a refraction no microfacet can make (wi and wo on the same side of h, once h faces N):
     * no density, but for light (above) */
    if (refract && !light) {
        float side = dot(h, c->N) < 0.0f ? -1.0f : 1.0f;
        if (side * dot(h, wi) <= 0.0f || side * dot(h, wo) >= 0.0f) return (float3)(0.0f);
    }
    float cos_hi = dot(h, wi), cos_ho;
    float3 R, T;
    microfacet_fresnel(c, cos_hi, &cos_ho, &R, &T);
    float sum = avg3(R + T);
    if (!(sum > 0.0f)) return (float3)(0.0f);
    float D, li, lo;
    microfacet_terms(c, h, wi, wo, refract, &D, &li, &lo);
    float common = D / cos_ni
                   * (refract ? sqr(c->ior * inv_len) * fabs(cos_hi * dot(h, wo)) : 0.25f);
    float pr = avg3(R) / sum;
    *pdf = common * (refract ? 1.0f - pr : pr) / (1.0f + li);
    return (refract ? T : R) * (common / (1.0f + li + lo) * c->energy_scale);
}

/* Samples wo for view wi (rand: three uniforms); ng the geometric normal on wi's side.
 * Singular lobes return eval and pdf as the discrete choice's weight and probability. */
inline int microfacet_sample(const Closure *c, float3 ng, float3 wi, float3 rand, float3 *eval,
                             float3 *wo, float *pdf, float *eta) {
    float cos_ni = dot(c->N, wi);
    if (cos_ni <= 0.0f) return LABEL_NONE;
    bool singular = microfacet_singular(c);
    float3 h = c->N, li3 = (float3)(0.0f), lh = (float3)(0.0f, 0.0f, 1.0f);
    if (!singular) {
        float3 x, y;
        microfacet_frame(c, &x, &y);
        li3 = (float3)(dot(x, wi), dot(y, wi), cos_ni);
        lh = ggx_sample_vndf(li3, c->alpha_x, c->alpha_y, rand.x, rand.y);
        h = lh.x * x + lh.y * y + lh.z * c->N;
    }
    float cos_hi = dot(h, wi), cos_ho;
    float3 R, T;
    microfacet_fresnel(c, cos_hi, &cos_ho, &R, &T);
    float sum = avg3(R + T);
    if (!(sum > 0.0f)) return LABEL_NONE;
    float pr = avg3(R) / sum;
    bool refract = rand.z >= pr;
    *wo = refract ? refract_dir(wi, h, cos_ho, 1.0f / c->ior) : 2.0f * cos_hi * h - wi;
    float cos_no = dot(c->N, *wo);
    if ((dot(ng, *wo) < 0.0f) != refract || (cos_no < 0.0f) != refract) return LABEL_NONE;
    *eval = refract ? T : R;
    *pdf = refract ? 1.0f - pr : pr;
    singular = singular || (refract && fabs(c->ior - 1.0f) < 1e-4f);
    if (!singular) {
        float D, li, lo;
        microfacet_terms(c, h, wi, *wo, refract, &D, &li, &lo);
        float common = D / cos_ni
                       * (refract ? fabs(cos_hi * cos_ho) / sqr(cos_ho + cos_hi / c->ior) : 0.25f);
        *pdf *= common / (1.0f + li);
        *eval *= common / (1.0f + li + lo);
    }
    *eval *= c->energy_scale;
    *eta = refract ? c->ior : 1.0f;
    return (refract ? LABEL_TRANSMIT : LABEL_REFLECT) | (singular ? LABEL_SINGULAR : LABEL_GLOSSY);
}

/* --- set-up (after type, N, T, alphas, ior and the Fresnel fields are filled in) ------------ */

inline float microfacet_rough(const Closure *c) { return sqrt(sqrt(c->alpha_x * c->alpha_y)); }

/* The albedo of c's Fresnel for the view wi (not including its weight): the layering and the
 * sample weights use it.  Tables for the generalised Schlick and F82 models, else the Fresnel
 * term at the view angle (a smooth surface). */
inline float3 microfacet_albedo(const Closure *c, float3 wi, bool reflection, bool transmission,
                                TABLES_ARG) {
    float cos_ni = dot(wi, c->N), ct;
    float3 R, T;
    microfacet_fresnel(c, cos_ni, &ct, &R, &T);
    if (!reflection) R = (float3)(0.0f);
    if (!transmission) T = (float3)(0.0f);
    if (max3(R) > 0.0f) {
        float rough = microfacet_rough(c);
        if (c->fresnel == FRESNEL_SCHLICK_IOR) {
            float z = sqrt(fabs((c->ior - 1.0f) / (c->ior + 1.0f)));
            float s = table_3d(shading_tables, TAB_SCHLICK_IOR_S, rough, cos_ni, z, 16, 16, 16);
            R = mix(c->f0, c->f90, s) * c->refl_tint;
        } else if (c->fresnel == FRESNEL_F82) {
            float s = table_3d(shading_tables, TAB_SCHLICK_S, rough, cos_ni, 0.5f, 16, 16, 16);
            R = mix(c->f0, (float3)(1.0f), s);
        } else if (c->fresnel == FRESNEL_DIELECTRIC && c->ior > 1.0f) {
            float z = sqrt(fabs((c->ior - 1.0f) / (c->ior + 1.0f)));
            float s = table_3d(shading_tables, TAB_SCHLICK_IOR_S, rough, cos_ni, z, 16, 16, 16);
            R = (float3)(mix(f0_from_ior(c->ior), 1.0f, s));
        }
    }
    return R + T;
}

/* Multiple scattering (Kulla & Conty, as Cycles): the single-scattering albedo E of c seen at
 * cosine mu, from the side of its normal (back: from the other side, where the relative index
 * is 1 / ior), and *Eavg, its average over the hemisphere. */
inline float microfacet_E(const Closure *c, float mu, bool back, float *Eavg, TABLES_ARG) {
    float rough = microfacet_rough(c), E;
    if (c->type == CLOSURE_GGX_REFLECT) {
        E = table_2d(shading_tables, TAB_GGX_E, rough, mu, 32, 32);
        *Eavg = table_1d(shading_tables, TAB_GGX_EAVG, rough, 32);
    } else {
        bool inv = (c->ior < 1.0f) != back;
        float ior = c->ior < 1.0f ? 1.0f / c->ior : c->ior,
              z = sqrt(fabs((ior - 1.0f) / (ior + 1.0f)));
        E = table_3d(shading_tables, inv ? TAB_GLASS_INV_E : TAB_GLASS_E, rough, mu, z, 16, 16, 16);
        *Eavg = table_2d(shading_tables, inv ? TAB_GLASS_INV_EAVG : TAB_GLASS_EAVG, rough, z, 16,
                         16);
    }
    return fmax(E, 1e-3f);
}

/* Kulla & Conty's multiple-scattering Fresnel for an average Fresnel fss and an average
 * single-scattering albedo Eavg */
inline float3 microfacet_fms(float3 fss, float Eavg) {
    return fss * Eavg / ((float3)(1.0f) - fss * (1.0f - Eavg));
}

/* The factor multiple scattering puts on c's single scattering for a view at cosine mu: 1 / E,
 * darkened for a coloured average Fresnel fss (1 + fms (1 - E) / E) */
inline float3 microfacet_compensation(const Closure *c, float3 fss, float mu, bool back,
                                      TABLES_ARG) {
    float Eavg, E = microfacet_E(c, mu, back, &Eavg, shading_tables);
    return (float3)(1.0f) + microfacet_fms(fss, Eavg) * ((1.0f - E) / E);
}

/* Multiple scattering: scale by 1 / E(view) and darken by Kulla & Conty's term for a coloured
 * average Fresnel fss. */
inline void microfacet_preserve_energy(Closure *c, float3 wi, float3 fss, TABLES_ARG) {
    if (microfacet_singular(c)) return;          /* a smooth lobe keeps all: E = 1 */
    float Eavg, E = microfacet_E(c, dot(wi, c->N), false, &Eavg, shading_tables);
    c->energy_scale = 1.0f / E;
    c->fss = fss;
    if (fss.x != 1.0f || fss.y != 1.0f || fss.z != 1.0f) {
        float3 darkening = E + microfacet_fms(fss, Eavg) * (1.0f - E); /* the compensation x E */
        c->weight *= darkening;
        c->sample_weight *= avg3(darkening);
    }
}

/* The adjoint of multiple scattering for light going from wi to wo (photons): the compensation
 * depends on the view, so c set up for the view wi is not reciprocal; a camera path that meets
 * the same two directions comes from wo and uses the compensation for wo.  The factor that turns
 * c's f(wi, wo) into that one (1 without multiple scattering).  Rough glass from inside keeps a
 * third more than from outside: without it, photons through rough glass lost half of their
 * light against camera paths (docs/SHADING.md). */
inline float3 microfacet_adjoint(const Closure *c, float3 wi, float3 wo, TABLES_ARG) {
    if (c->fss.x < 0.0f || microfacet_singular(c)) return (float3)(1.0f);
    float mu_o = dot(wo, c->N);
    bool back = mu_o < 0.0f;
    return microfacet_compensation(c, c->fss, fabs(mu_o), back, shading_tables)
           / microfacet_compensation(c, c->fss, dot(wi, c->N), false, shading_tables);
}
#endif
