#ifndef PPM_SHADER_DATA_H
#define PPM_SHADER_DATA_H
#include "closure/closure.h"
#include "svm/textures.h"
#include "svm/svm.h"
#include "geom/medium.h"

/* The closures at one shading point (kernels/closure/shader.h fills it in from the material's BSDF
 * nodes), with the emission, transparency and holdout that are not lobes.  At most
 * PPM_MAX_CLOSURES closures: the most the scene's materials can make (-D from
 * ppm_engine/scene/materials.py), its MAX_CLOSURES in a program built for every feature. */
typedef struct {
    Closure c[PPM_MAX_CLOSURES];
    int n;
    float3 emission;      /* radiance emitted towards wi */
    float3 transparent;   /* weight of the transparent closure: 1 - alpha */
    float3 holdout;
    float3 N;             /* shading normal, on wi's side */
    float3 Ng;            /* geometric normal, on wi's side */
    float3 wi;
    float sw_gather;      /* sample weights of the gather's closures and of the others */
    float sw_continue;
    float sw_glossy;      /* of the followed closures whose light eye paths count (glossy) */
    bool backfacing;      /* wi is behind the stored geometric normal */
    bool gather_transmits;/* a gather closure transmits (light from behind counts) */
    bool continue_glossy; /* a closure the path follows can be evaluated (next-event estimation
                             there); singular ones cannot */
    int crossings;        /* transparent surfaces a ray sampled here may still cross (the Light
                             Paths' transparent limit less the path's crossings) */
    float gather_rough;   /* microfacet lobes this rough are gathered (LightPaths) */
    float caustic_rough;  /* followed glossy reflections this rough are the eye paths' light
                             (path_state.h filter_glossy_caustic_roughness) */
    int leaf;             /* the point's triangle (bvh.h Surface) and barycentrics: the shadow */
    uint tri;             /* terminator's lift (bvh.h terminator_lift) */
    float u, v;
#if PPM_VOLUME
    const Media *media;   /* the media the point is in (its shadow rays' transmittance); 0: none.
                             Set by the pass after shader_setup, which leaves it alone */
#endif
} ShaderData;

/* the BSDF node the setup functions read: a private copy with the program's inputs written in
 * (kernels/svm/svm.h) when the scene has shader programs, else the buffer's row */
#if PPM_SVM
#define NODE_PTR const ShaderNode *
#else
#define NODE_PTR __global const ShaderNode *
#endif

/* A new closure of weight w (negative parts dropped), or -1 when its weight is below the
 * cutoff or the list is full (as Cycles' bsdf_alloc). */
inline int shader_alloc(ShaderData *sd, int type, float3 w, float3 N) {
    w = fmax(w, (float3)(0.0f));
    float sw = fabs(avg3(w));
    if (!(sw >= CLOSURE_WEIGHT_CUTOFF) || sd->n >= PPM_MAX_CLOSURES) return -1;
    Closure *c = &sd->c[sd->n];
    c->type = type;
    c->weight = w;
    c->sample_weight = sw;
    c->N = N;
    c->T = (float3)(0.0f);
    c->f0 = c->f90 = c->refl_tint = c->trans_tint = (float3)(1.0f);
    c->alpha_x = c->alpha_y = 0.0f;
    c->ior = 1.0f;
    c->energy_scale = 1.0f;
    c->fss = (float3)(-1.0f);
    c->fresnel = FRESNEL_NONE;
    c->gather = 0;
    c->glossy = 0;
    return sd->n++;
}

/* Cycles' weight of the layers below a layer of albedo a over total weight w */
inline float3 layering_weight(float3 a, float3 w) {
    float3 r = select(a / w, (float3)(0.0f), isequal(w, (float3)(0.0f)));
    return w * clamp(1.0f - max3(r), 0.0f, 1.0f);
}

inline void shader_transparent(ShaderData *sd, float3 w) {
#if !PPM_TRANSPARENT
    return;                              /* no material of the scene is transparent */
#endif
    if (!(fabs(avg3(w)) >= CLOSURE_WEIGHT_CUTOFF)) return;
    sd->transparent += w;
    for (int k = 0; k < sd->n; k++) {
        if (sd->c[k].type == CLOSURE_TRANSPARENT) {
            sd->c[k].weight += w;
            sd->c[k].sample_weight += fabs(avg3(w));
            return;
        }
    }
    shader_alloc(sd, CLOSURE_TRANSPARENT, w, sd->N);
}

/* A microfacet closure of the given alphas; the Fresnel fields are the caller's */
inline int shader_microfacet(ShaderData *sd, int type, float3 w, float3 N, float ax, float ay,
                             float ior) {
    if (!PPM_MICROFACET) return -1;
    int k = shader_alloc(sd, type, w, N);
    if (k < 0) return k;
    Closure *c = &sd->c[k];
    c->alpha_x = clamp(ax, 0.0f, 1.0f);
    c->alpha_y = type == CLOSURE_GGX_REFLECT ? clamp(ay, 0.0f, 1.0f) : c->alpha_x;
    c->ior = ior;
    return k;
}

/* the sample weight scaled by the Fresnel albedo (Cycles: the closure's expected share; for a
 * smooth lobe the Fresnel term at the view, which its table row holds) */
inline void microfacet_sample_weight(ShaderData *sd, int k, TABLES_ARG) {
    Closure *c = &sd->c[k];
    float3 a;
    if (microfacet_singular(c)) {
        float ct;
        float3 T;
        microfacet_fresnel(c, dot(sd->wi, c->N), &ct, &a, &T);
        a += T;
    } else {
        a = microfacet_albedo(c, sd->wi, true, true, shading_tables);
    }
    c->sample_weight *= avg3(a);
}

/* the generalised-Schlick closure of the Principled and Glass BSDFs: the real Fresnel
 * remapped to [f0, 1] */
inline void schlick_ior_setup(ShaderData *sd, int k, float3 f0, float3 refl, float3 trans,
                              bool multi, TABLES_ARG) {
    Closure *c = &sd->c[k];
    c->fresnel = FRESNEL_SCHLICK_IOR;
    c->f0 = sat3(f0);
    c->f90 = (float3)(1.0f);
    c->refl_tint = refl;
    c->trans_tint = trans;
    microfacet_sample_weight(sd, k, shading_tables);
    if (!multi) return;
    float3 fss = trans;
    if (!(max3(trans) > 0.0f)) {
        float F0 = f0_from_ior(c->ior);
        float s = clamp((fresnel_dielectric_fss(c->ior) - F0) / (1.0f - F0), 0.0f, 1.0f);
        fss = refl * mix(c->f0, c->f90, s);
    }
    microfacet_preserve_energy(c, sd->wi, fss, shading_tables);
}

/* the F82-tint metal of the Principled and Metallic BSDFs */
inline void f82_setup(ShaderData *sd, int k, float3 f0, float3 tint, bool multi, TABLES_ARG) {
    Closure *c = &sd->c[k];
    c->fresnel = FRESNEL_F82;
    c->f0 = f0;
    c->f90 = (tint.x == 1.0f && tint.y == 1.0f && tint.z == 1.0f) ? (float3)(0.0f)
                                                                  : fresnel_f82_b(f0, tint);
    microfacet_sample_weight(sd, k, shading_tables);
    if (multi)
        microfacet_preserve_energy(c, sd->wi, fresnel_f82_fss(c->f0, c->f90), shading_tables);
}

inline void shader_diffuse(ShaderData *sd, float3 w, float3 N, float roughness, float3 color) {
    if (PPM_OREN_NAYAR && roughness >= CLOSURE_WEIGHT_CUTOFF) {
        int k = shader_alloc(sd, CLOSURE_OREN_NAYAR, w, N);
        if (k >= 0) oren_nayar_setup(&sd->c[k], roughness, color, sd->wi);
        return;
    }
    shader_alloc(sd, CLOSURE_DIFFUSE, w, N);
}

/* The microfiber sheen: its LTC and albedo from the table at (cos, roughness); the albedo
 * scales the weight.  Returns the closure, or -1 (an invalid LTC is dropped, as Cycles). */
inline int shader_sheen(ShaderData *sd, float3 w, float3 N, float roughness, TABLES_ARG) {
    if (!PPM_SHEEN) return -1;
    int k = shader_alloc(sd, CLOSURE_SHEEN, w, N);
    if (k < 0) return k;
    Closure *c = &sd->c[k];
    float r = clamp(roughness, 1e-3f, 1.0f), cos_ni = dot(N, sd->wi);
    float3 t = cross(N, sd->wi);
    float tl = length(t);
    float3 x, y;
    if (!(tl > 1e-7f)) {                 /* wi along N: any frame */
        make_frame(N, &x, &y);
    } else {
        y = t / tl;
        x = cross(y, N);
    }
    c->T = x;
    c->ior = table_2d(shading_tables, TAB_SHEEN, cos_ni, r, 32, 32);
    c->energy_scale = table_2d(shading_tables, TAB_SHEEN + 1024, cos_ni, r, 32, 32);
    float albedo = table_2d(shading_tables, TAB_SHEEN + 2048, cos_ni, r, 32, 32);
    if (fabs(c->ior) < 1e-5f || albedo < 1e-5f) {
        sd->n--;
        return -1;
    }
    c->weight *= albedo;
    c->sample_weight *= albedo;
    return k;
}
#endif
