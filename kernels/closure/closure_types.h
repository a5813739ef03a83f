#ifndef PPM_CLOSURE_TYPES_H
#define PPM_CLOSURE_TYPES_H
#include "closure/fresnel.h"
#include "shared.h"

/* A closure: one weighted BSDF lobe at a shading point, in the shape Cycles uses (a type, an
 * RGB weight and its parameters).  The shader (kernels/closure/shader.h) builds a short list of
 * them from the material's BSDF nodes; kernels/closure/closure.h samples and evaluates each.
 * Directions follow Cycles: wi points to the viewer (or where a photon came from), wo to the light
 * (or where a photon goes); N faces wi.  eval returns f x |cos(N, wo)| without the weight. */
#define CLOSURE_NONE 0
#define CLOSURE_DIFFUSE 1          /* Lambert */
#define CLOSURE_OREN_NAYAR \
    2       /* energy-preserving Oren-Nayar (Fujii; OpenPBR's multiple
                                      scattering term) */
#define CLOSURE_TRANSLUCENT 3      /* Lambert transmission */
#define CLOSURE_SHEEN 4            /* Zeltner et al. 2022's microfiber sheen (an LTC) */
#define CLOSURE_GGX_REFLECT 5      /* GGX reflection */
#define CLOSURE_GGX_REFRACT 6      /* GGX refraction only (Refraction BSDF) */
#define CLOSURE_GGX_GLASS 7        /* GGX reflection and refraction */
#define CLOSURE_TRANSPARENT 8      /* straight through */

/* Fresnel of a microfacet closure */
#define FRESNEL_NONE 0             /* 1 (refraction only: 0 under total internal reflection) */
#define FRESNEL_DIELECTRIC 1       /* the real dielectric Fresnel */
#define FRESNEL_SCHLICK_IOR 2 /* the real Fresnel remapped to [f0, f90] (Principled, Glass) */
#define FRESNEL_F82 3 /* F82-tint (Principled metal, Metallic BSDF) */
#define FRESNEL_CONDUCTOR 4 /* complex index n + i k (Metallic BSDF, physical) */

/* what a sampled direction is (the ray type that follows, MIS) */
#define LABEL_NONE 0
#define LABEL_REFLECT 1
#define LABEL_TRANSMIT 2
#define LABEL_DIFFUSE 4
#define LABEL_GLOSSY 8
#define LABEL_SINGULAR 16
#define LABEL_TRANSPARENT 32

/* (ROUGHNESS_SQ_THRESH, the alpha_x alpha_y below which a microfacet lobe is a perfect mirror
 * or a smooth refraction, and CLOSURE_WEIGHT_CUTOFF are shared.h's: the host's node features
 * use them too) */

typedef struct {
    float3 weight; /* RGB weight (energy compensation included) */
    float3 N; /* normal, on the side of wi */
    float3 T; /* microfacet: tangent (anisotropy); sheen: its frame's X (towards wi) */
    float3 f0; /* Fresnel f0 (Schlick-IOR, F82) or conductor n; Oren-Nayar: the
                            multiple scattering term */
    float3 f90; /* Schlick-IOR f90, F82 B, conductor k */
    float3 refl_tint; /* Schlick-IOR: tints of reflection and transmission */
    float3 trans_tint;
    float sample_weight; /* probability of being sampled, up to the sum over the closures */
    float alpha_x, alpha_y;
    float ior; /* microfacet: relative index (1 / ior from the back);
                            Oren-Nayar: A; sheen: the LTC's a */
    float energy_scale; /* microfacet: 1 / E (multiple scattering); Oren-Nayar: B; sheen: b */
    float3 fss; /* microfacet with multiple scattering: the Fresnel's average (its
                            darkening); x < 0: none (microfacet_adjoint) */
    int type;
    int fresnel;
    int gather; /* 1: the visible point's gather evaluates it; 0: paths continue */
    int glossy; /* a closure paths continue through whose light eye paths count (next-event
                   estimation there: LightPaths.caustic_roughness); 0: gathered, or a caustic's */
} Closure;
#endif
