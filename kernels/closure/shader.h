#ifndef PPM_SHADER_H
#define PPM_SHADER_H
#include "geom/bvh.h"
#include "closure/shader_bsdf.h"
#include "svm/shader_inputs.h"

/* The shader: a hit's closures from its material's BSDF nodes (arrays.SHADER_NODE_DTYPE,
 * weights already propagated through Mix and Add Shader nodes), each node set up as Cycles sets
 * it up (shader_bsdf.h; kernel/svm/closure.h there; docs/SHADING.md lists what differs), then
 * each closure marked for the gather or for the path (LightPaths.gather_roughness).  One set of
 * functions samples and evaluates the mixture for every pass. */

/* (LightPaths.gather_roughness, ShaderData.gather_rough: microfacet lobes at least this rough,
 * sqrt of alpha, hold visible points and photons like diffuse ones; smoother ones are followed
 * by the eye path; RenderOptions.gather_roughness) */

/* The sample weights of the gathered and the followed closures, and what they hold */
inline void shader_sums(ShaderData *sd) {
    sd->sw_gather = sd->sw_continue = sd->sw_glossy = 0.0f;
    sd->gather_transmits = sd->continue_glossy = false;
    for (int k = 0; k < sd->n; k++) {
        const Closure *c = &sd->c[k];
        bool micro = c->type >= CLOSURE_GGX_REFLECT && c->type <= CLOSURE_GGX_GLASS;
        if (c->gather) {
            sd->sw_gather += c->sample_weight;
            sd->gather_transmits |= c->type == CLOSURE_TRANSLUCENT || c->type == CLOSURE_GGX_GLASS
                                    || c->type == CLOSURE_GGX_REFRACT;
        } else {
            sd->sw_continue += c->sample_weight;
            if (c->glossy) sd->sw_glossy += c->sample_weight;
            sd->continue_glossy |= micro && !microfacet_singular(c);
        }
    }
}

/* Each closure marked for the gather or for the path by its roughness, and the sums */
inline void shader_classify(ShaderData *sd) {
    for (int k = 0; k < sd->n; k++) {
        Closure *c = &sd->c[k];
        bool micro = c->type >= CLOSURE_GGX_REFLECT && c->type <= CLOSURE_GGX_GLASS;
        c->gather = c->type == CLOSURE_TRANSPARENT
                        ? 0
                        : !micro
                              || (!microfacet_singular(c)
                                  && microfacet_rough(c) >= sd->gather_rough);
        /* a glossy reflection rough enough that next-event estimation through it serves (as
         * Cycles' does): its light is the eye paths', not a caustic's */
        c->glossy = !c->gather && c->type == CLOSURE_GGX_REFLECT && !microfacet_singular(c)
                    && microfacet_rough(c) >= sd->caustic_rough;
    }
    shader_sums(sd);
}

/* Closures at a hit at barycentrics (u, v) of the surface s (its material, triangle, position
 * and stored normals: bvh.h surface_at), reached by the ray `path` (path_state.h) after a last
 * segment of length path_length, wi towards the viewer, the ray's footprint fp there (the Bump
 * node's, svm_bump.h). */
inline void shader_setup(const Scene *scene, ShaderData *sd, const Surface *s, float u, float v,
                         uint path, float path_length, float3 wi, Footprint fp) {
    int mat = s->material;
    uint tri = s->tri;
    float3 P = s->p, ng = s->ng, ns = s->ns;
    sd->n = 0;
    sd->emission = sd->transparent = sd->holdout = (float3)(0.0f);
    sd->wi = wi;
    sd->crossings = max(scene->light_paths->transparent_max_bounces
                            - (int)path_count(path, PATH_TRANSPARENT_DEPTH),
                        0);
    sd->gather_rough = scene->light_paths->gather_roughness;
    sd->caustic_rough = filter_glossy_caustic_roughness(scene->light_paths);
    sd->backfacing = dot(wi, ng) < 0.0f;
    sd->leaf = s->leaf;
    sd->tri = tri;
    sd->u = u;
    sd->v = v;
    sd->Ng = sd->backfacing ? -ng : ng;
    sd->N = sd->backfacing ? -ns : ns;
    Material m = scene->materials[mat];
#if PPM_SHADER
    if (m.flags & MAT_LAMBERT) {
#else
    {                                   /* every material is one Lambert closure */
#endif
        /* the short path for the commonest material: what the loop below makes of it */
        __global const ShaderNode *nd = scene->shader_nodes + m.node_first;
        sd->emission = F3(nd->emission) * nd->weight
                       * texture_tint(scene, nd->emission_texture, tri, u, v);
        int k = shader_alloc(sd, CLOSURE_DIFFUSE, lambert_weight(scene, nd, tri, u, v), sd->N);
        sd->sw_gather = k >= 0 ? sd->c[k].sample_weight : 0.0f;
        if (k >= 0) sd->c[k].gather = 1;
        sd->sw_continue = sd->sw_glossy = 0.0f;
        sd->gather_transmits = sd->continue_glossy = false;
        return;
    }
    float3 tangent = surface_tangent(scene, tri, u, v, sd->N);
    MATERIAL_PROGRAM(m, stack, P, path, path_length, sd->N, sd->Ng, wi, sd->backfacing, fp);
    for (int i = 0; i < m.node_count; i++) {
        MATERIAL_NODE(nd, m, i, stack);
        if (!(nd->weight > 0.0f)) continue;
        float3 color = F3(nd->color) * texture_tint(scene, nd->color_texture, tri, u, v);
        float3 emission = F3(nd->emission) * texture_tint(scene, nd->emission_texture, tri, u, v);
        if (nd->type == NODE_PRINCIPLED) {
            float alpha = clamp(nd->alpha * texture_alpha(scene, nd->alpha_texture, tri, u, v),
                                0.0f, 1.0f);
            principled_setup(sd, nd, fmax(color, 0.0f), alpha, emission, tangent,
                             scene->shading_tables);
        } else {
            bsdf_node_setup(sd, nd, color, emission, tangent, scene->shading_tables);
        }
    }
    shader_classify(sd);
}

/* Filter Glossy at a blurred vertex (path_state.h filter_glossy_alpha): every microfacet lobe
 * at least alpha rough along both axes, as Cycles' bsdf_blur; its weight, sample weight and
 * energy compensation stay as set up for its own roughness (Cycles does not compute them
 * again either), and the lobes are marked again by their new roughness. */
inline void shader_blur(ShaderData *sd, float alpha) {
    bool changed = false;
    for (int k = 0; k < sd->n; k++) {
        Closure *c = &sd->c[k];
        if (c->type < CLOSURE_GGX_REFLECT || c->type > CLOSURE_GGX_GLASS) continue;
        if (!(c->alpha_x < alpha || c->alpha_y < alpha)) continue;
        c->alpha_x = fmax(c->alpha_x, alpha);
        c->alpha_y = fmax(c->alpha_y, alpha);
        changed = true;
    }
    if (changed) shader_classify(sd);
}

/* An upper bound of the mixture's density (shader_eval's over all the closures) over every
 * direction: 1 / pi for a diffuse closure, Heitz's visible-normal density's peak, G1(wi)
 * D(N) / (4 cos), for a rough reflection, none for the others (sheen, rough refraction:
 * INFINITY); a singular or transparent closure has no density in any direction a photon
 * comes from.  Filter Glossy keeps no photon at a visible point whose bound is below it. */
inline float shader_pdf_bound(const ShaderData *sd) {
    float sum = 0.0f, sum_sw = 0.0f;
    for (int k = 0; k < sd->n; k++) {
        const Closure *c = &sd->c[k];
        sum_sw += c->sample_weight;
        float b = INFINITY;
        if (c->type == CLOSURE_DIFFUSE || c->type == CLOSURE_OREN_NAYAR
            || c->type == CLOSURE_TRANSLUCENT) {
            b = 1.0f / PPM_PI;
        } else if (c->type == CLOSURE_TRANSPARENT
                   || (c->type >= CLOSURE_GGX_REFLECT && c->type <= CLOSURE_GGX_GLASS
                       && microfacet_singular(c))) {
            b = 0.0f;
        } else if (c->type == CLOSURE_GGX_REFLECT) {
            float cos_i = dot(c->N, sd->wi), a = fmin(c->alpha_x, c->alpha_y);
            b = cos_i > 0.0f ? 1.0f
                                   / ((1.0f + ggx_lambda(a * a, cos_i)) * 4.0f * cos_i * PPM_PI
                                      * c->alpha_x * c->alpha_y)
                             : 0.0f;
        }
        if (c->sample_weight > 0.0f) sum += b * c->sample_weight;
    }
    return sum_sw > 0.0f ? sum / sum_sw : 0.0f;
}

/* the sample weight of the followed closures that are not glossy (MASK_SPECULAR: a caustic's) */
inline float shader_sw_specular(const ShaderData *sd) {
    return fmax(sd->sw_continue - sd->sw_glossy, 0.0f);
}

/* which closures a mixture function looks at: the gather's, the followed ones (MASK_CONTINUE),
 * and of these the glossy ones (whose light eye paths count) or the others (caustics') */
#define MASK_GATHER 1
#define MASK_CONTINUE 2
#define MASK_ALL 3
#define MASK_GLOSSY 4
#define MASK_SPECULAR 8
inline bool closure_in(const Closure *c, int mask) {
    if (c->gather) return (mask & MASK_GATHER) != 0;
    return (mask & (MASK_CONTINUE | (c->glossy ? MASK_GLOSSY : MASK_SPECULAR))) != 0;
}

/* Sum of weight x eval (f cos) over the closures in mask, for light from wo; *pdf: the
 * density shader_sample gives wo (Veach's one-sample model). */
/* Cycles' bump shadowing term (learnt from its bsdf.h: Conty Estevez et al.'s microfacet-based
 * term), for a closure whose normal differs from the smooth normal sd->N (a Normal input):
 * directions on the wrong side of the smooth surface get nothing when evaluated (sampled:
 * diffuse closures only), and diffuse closures are softened near their terminator by a GGX
 * shadowing of the normals' deviation. */
inline float bump_shadowing(const ShaderData *sd, const Closure *c, float3 wo, bool is_eval) {
    if (all(isequal(c->N, sd->N))) return 1.0f;
    float cos_si = dot(sd->N, wo), cos_sn = dot(sd->N, c->N), cos_ni = dot(c->N, wo);
    bool diffuse = c->type >= CLOSURE_DIFFUSE && c->type <= CLOSURE_SHEEN;
    if (cos_si * cos_sn * cos_ni < 0.0f && (is_eval || diffuse)) return 0.0f;
    if (!diffuse) return 1.0f;
    float ci = fabs(cos_si), cd = fabs(cos_sn);
    if (cd >= 1.0f || ci >= 1.0f) return 1.0f;
    if (ci < 1e-6f) return 0.0f;
    float a2 = clamp(0.125f * (1.0f / (cd * cd) - 1.0f), 0.0f, 1.0f);
    return 2.0f / (1.0f + sqrt(1.0f + a2 * (1.0f - ci * ci) / (ci * ci)));    /* 1/(1+lambda) */
}

/* whether closure c's f cos / cos (the gather's estimate's factor) is one constant, albedo / pi:
 * a Lambert closure on the smooth normal (a driven normal's cosine and bump shadowing vary with
 * the direction) */
inline bool closure_lambert(const ShaderData *sd, const Closure *c) {
    return c->type == CLOSURE_DIFFUSE && all(isequal(c->N, sd->N));
}

/* the sum of the gather's closures' weights (their albedo where all are Lambert), and in
 * *lambert whether they all are (closure_lambert) */
inline float3 gather_albedo(const ShaderData *sd, bool *lambert) {
    float3 albedo = (float3)(0.0f);
    *lambert = true;
    for (int k = 0; k < sd->n; k++) {
        if (!sd->c[k].gather) continue;
        albedo += sd->c[k].weight;
        *lambert &= closure_lambert(sd, &sd->c[k]);
    }
    return albedo;
}

/* closure c's f cos at wo with its bump shadowing; *p its density (0 where shadowed); light: for
 * next-event estimation (microfacet_eval) */
inline float3 closure_eval_bumped(const ShaderData *sd, const Closure *c, float3 wo, bool light,
                                  float *p) {
    float3 e = closure_eval(c, sd->wi, wo, light, p);
    float b = bump_shadowing(sd, c, wo, true);
    if (b == 0.0f) *p = 0.0f;
    return e * b;
}

/* the kind of bounce (path_state.h JOIN_*) closure c makes towards wo */
inline uint closure_join_kind(const ShaderData *sd, const Closure *c, float3 wo) {
    bool diffuse = c->type >= CLOSURE_DIFFUSE && c->type <= CLOSURE_SHEEN;
    if (dot(wo, sd->Ng) < 0.0f) return diffuse ? JOIN_DIFFUSE_TRANSMIT : JOIN_GLOSSY_TRANSMIT;
    return diffuse ? JOIN_DIFFUSE : JOIN_GLOSSY;
}

/* Reflective / Refractive Caustics off (path_state.h path_caustic_off) at a surface a ray from
 * a diffuse bounce reached: its glossy reflections (its refractions) are not made, as Cycles
 * makes them: a Principled glass loses that part (its tint is zero), a Glass BSDF only when
 * both are off.  For eye paths (the caller knows the ray came from a diffuse bounce). */
inline void shader_caustics_off(ShaderData *sd, __global const LightPaths *lp) {
    bool refl = (lp->flags & LP_CAUSTICS_REFLECTIVE) != 0;
    bool refr = (lp->flags & LP_CAUSTICS_REFRACTIVE) != 0;
    if (refl && refr) return;
    for (int k = 0; k < sd->n; k++) {
        Closure *c = &sd->c[k];
        if ((c->type == CLOSURE_GGX_REFLECT && !refl) || (c->type == CLOSURE_GGX_REFRACT && !refr)
            || (c->type == CLOSURE_GGX_GLASS && !refl && !refr)) {
            c->weight = (float3)(0.0f);
            c->sample_weight = 0.0f;
        } else if (c->type == CLOSURE_GGX_GLASS && c->fresnel == FRESNEL_SCHLICK_IOR) {
            if (!refl) c->refl_tint = (float3)(0.0f);
            if (!refr) c->trans_tint = (float3)(0.0f);
        }
    }
    shader_sums(sd);
}

/* shader_eval of the closures in mask whose bounce towards wo is of the kinds given (JOIN_*:
 * the Light Paths limits, path_state.h path_join); the density still that of all in mask */
inline float3 shader_eval_kinds(const ShaderData *sd, float3 wo, int mask, uint kinds, float *pdf) {
    float3 f = (float3)(0.0f);
    float sum_pdf = 0.0f, sum_sw = 0.0f;
    for (int k = 0; k < sd->n; k++) {
        const Closure *c = &sd->c[k];
        if (!closure_in(c, mask)) continue;
        sum_sw += c->sample_weight;
        if (kinds != JOIN_ALL && !(closure_join_kind(sd, c, wo) & kinds)) continue;
        float p;
        float3 e = closure_eval_bumped(sd, c, wo, false, &p);
        if (p != 0.0f) {
            f += c->weight * e;
            sum_pdf += p * c->sample_weight;
        }
    }
    *pdf = sum_sw > 0.0f ? sum_pdf / sum_sw : 0.0f;
    return f;
}

/* shader_eval for next-event estimation's light from wo (light: microfacet_eval), or for a
 * sampled direction */
inline float3 shader_eval_as(const ShaderData *sd, float3 wo, int mask, bool light, float *pdf) {
    float3 f = (float3)(0.0f);
    float sum_pdf = 0.0f, sum_sw = 0.0f;
    for (int k = 0; k < sd->n; k++) {
        const Closure *c = &sd->c[k];
        if (!closure_in(c, mask)) continue;
        float p;
        float3 e = closure_eval_bumped(sd, c, wo, light, &p);
        if (p != 0.0f) {
            f += c->weight * e;
            sum_pdf += p * c->sample_weight;
        }
        sum_sw += c->sample_weight;
    }
    *pdf = sum_sw > 0.0f ? sum_pdf / sum_sw : 0.0f;
    return f;
}

/* The density at wo of a sample of the closures in mis_mask, for a sample of those in mask
 * (a subset) whose density over them was pdf_mask: the closures of mis_mask outside mask
 * evaluated at wo, those of mask as pdf_mask has them.  Re-evaluating the sampled closure
 * instead would lose its own density where its bump shadowing evaluates it to 0 (a driven
 * normal's lobe below the smooth surface, which sampling keeps): Cycles' one-sample MIS keeps
 * it (surface_shader_bsdf_sample_closure), and without it the sample's emitter was weighed
 * to nothing against next-event estimation, which finds nothing there. */
inline float shader_mis_pdf(const ShaderData *sd, float3 wo, int mask, int mis_mask,
                            float pdf_mask) {
    float sw_mask = 0.0f, sw_all = 0.0f, sum_pdf = 0.0f;
    for (int k = 0; k < sd->n; k++) {
        const Closure *c = &sd->c[k];
        if (!closure_in(c, mis_mask)) continue;
        sw_all += c->sample_weight;
        if (closure_in(c, mask)) {
            sw_mask += c->sample_weight;
            continue;
        }
        float p;
        closure_eval_bumped(sd, c, wo, false, &p);
        if (p != 0.0f) sum_pdf += p * c->sample_weight;
    }
    return sw_all > 0.0f ? (pdf_mask * sw_mask + sum_pdf) / sw_all : 0.0f;
}

inline float3 shader_eval(const ShaderData *sd, float3 wo, int mask, float *pdf) {
    return shader_eval_as(sd, wo, mask, false, pdf);
}

typedef struct {
    float3 wo;
    float3 weight;       /* f cos / pdf of the mixture: the path's throughput factor */
    float pdf;           /* the mixture's density (INFINITY: a singular lobe) */
    float eta;           /* relative index crossed (1 unless refracted) */
    float roughness2;    /* the sampled lobe's alpha_x alpha_y (transparent glass) */
    int label;
} BsdfSample;

/* The visibility class of the ray a sampled bounce makes (path_state.h's ray types; as in
 * Cycles, a transmission is a transmission ray even when diffuse). */
inline uint bounce_visibility(int label) {
    return (label & LABEL_TRANSMIT)  ? VIS_TRANSMISSION
           : (label & LABEL_DIFFUSE) ? VIS_DIFFUSE
                                     : VIS_GLOSSY;
}

/* A direction from the closures in mask, picked in proportion to their sample weights. */
/* closure c's adjoint factor for light from sd->wi to wo (1 for camera paths: adjoint null) */
inline float3 closure_adjoint(const ShaderData *sd, const Closure *c, float3 wo,
                              __global const float *adjoint) {
#if PPM_MICROFACET
    if (adjoint != 0 && c->type >= CLOSURE_GGX_REFLECT && c->type <= CLOSURE_GGX_GLASS)
        return microfacet_adjoint(c, sd->wi, wo, adjoint);
#endif
    return (float3)(1.0f);
}

/* shader_sample, and shader_sample_light: light's paths (photons), whose throughput is the
 * adjoint of the camera's (closure_adjoint; adjoint: the shading tables) */
inline bool shader_sample_with(const ShaderData *sd, int mask, float3 rand, BsdfSample *s,
                               __global const float *adjoint) {
    if (sd->n == 1) {                       /* one closure: no pick, no mixture */
        const Closure *c = &sd->c[0];
        if (!closure_in(c, mask)) return false;
        float3 eval;
        float pdf;
        s->label = closure_sample(c, sd->Ng, sd->wi, rand, &eval, &s->wo, &pdf, &s->eta);
        if (s->label == LABEL_NONE || !(pdf > 0.0f)) return false;
        if (!(s->label & LABEL_TRANSMIT)) eval *= bump_shadowing(sd, c, s->wo, false);
        s->roughness2 = c->alpha_x * c->alpha_y;
        s->pdf = (s->label & LABEL_SINGULAR) ? INFINITY : pdf;
        s->weight = c->weight * eval * closure_adjoint(sd, c, s->wo, adjoint) / pdf;
        return true;
    }
    float sum_sw = 0.0f;
    for (int k = 0; k < sd->n; k++)
        if (closure_in(&sd->c[k], mask)) sum_sw += sd->c[k].sample_weight;
    if (!(sum_sw > 0.0f)) return false;
    float r = rand.z * sum_sw, partial = 0.0f;
    int pick = -1, last = -1;
    for (int k = 0; k < sd->n; k++) {
        const Closure *c = &sd->c[k];
        if (!closure_in(c, mask)) continue;
        last = k;
        if (pick < 0 && r < partial + c->sample_weight) {
            pick = k;
            rand.z = clamp((r - partial) / c->sample_weight, 0.0f, 0.99999994f);
        }
        partial += c->sample_weight;
    }
    if (pick < 0) {                  /* r rounded up to the sum */
        pick = last;
        rand.z = 0.99999994f;
    }
    const Closure *c = &sd->c[pick];
    float3 eval;
    float pdf;
    s->label = closure_sample(c, sd->Ng, sd->wi, rand, &eval, &s->wo, &pdf, &s->eta);
    if (s->label == LABEL_NONE || !(pdf > 0.0f)) return false;
    if (!(s->label & LABEL_TRANSMIT)) eval *= bump_shadowing(sd, c, s->wo, false);
    s->roughness2 = c->alpha_x * c->alpha_y;
    if (s->label & LABEL_SINGULAR) {
        s->pdf = INFINITY;
        s->weight = c->weight * eval * (sum_sw / (pdf * c->sample_weight));
        return true;
    }
    float3 f = c->weight * eval * closure_adjoint(sd, c, s->wo, adjoint);
    float sum_pdf = pdf * c->sample_weight;
    for (int k = 0; k < sd->n; k++) {
        const Closure *o = &sd->c[k];
        if (k == pick || !closure_in(o, mask)) continue;
        float p;
        float3 e = closure_eval_bumped(sd, o, s->wo, false, &p);
        if (p != 0.0f) {
            f += o->weight * e * closure_adjoint(sd, o, s->wo, adjoint);
            sum_pdf += p * o->sample_weight;
        }
    }
    s->pdf = sum_pdf / sum_sw;
    s->weight = f / s->pdf;
    return true;
}

inline bool shader_sample(const ShaderData *sd, int mask, float3 rand, BsdfSample *s) {
    return shader_sample_with(sd, mask, rand, s, (__global const float *)0);
}

inline bool shader_sample_light(const ShaderData *sd, int mask, float3 rand, BsdfSample *s,
                                TABLES_ARG) {
    return shader_sample_with(sd, mask, rand, s, shading_tables);
}

/* Shading normals for light (Veach's thesis, 5.3): a light path arriving along d that leaves
 * along wo carries |d.N| |wo.Ng| / (|d.Ng| |wo.N|) on top of the sample's weight (N the shading
 * normal, Ng the surface's), so that it transports what a camera path through the same vertex
 * finds; 0 where a cosine is (photon_pass.cl, light_trace.cl). */
inline float shading_adjoint(float3 d, float3 wo, float3 N, float3 Ng) {
    float c_ng = fabs(dot(d, Ng)), o_n = fabs(dot(wo, N));
    return o_n > 0.0f && c_ng > 0.0f ? fabs(dot(d, N)) * fabs(dot(wo, Ng)) / (c_ng * o_n) : 0.0f;
}
#endif
