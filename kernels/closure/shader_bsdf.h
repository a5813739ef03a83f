#ifndef PPM_SHADER_BSDF_H
#define PPM_SHADER_BSDF_H
#include "svm/shader_inputs.h"

/* The closures each BSDF node of a material makes (arrays.SHADER_NODE_DTYPE, its inputs
 * read by shader_inputs.h), set up as Cycles sets them up (kernel/svm/closure.h there;
 * docs/SHADING.md lists what differs): the Principled BSDF's layers, and the other BSDF nodes.
 * shader.h's shader_setup calls them for every node of a hit's material. */

inline void principled_setup(ShaderData *sd, NODE_PTR nd, float3 base, float alpha, float3 emission,
                             float3 tangent, TABLES_ARG) {
    float w1 = nd->weight;
    float3 w = (float3)(w1), N = node_normal(sd, F3(nd->normal)),
           Nv = specular_normal(sd, N, nd->flags), cbase = fmin(base, (float3)(1.0f));
    float ior = fmax(nd->ior, 1e-5f), rough = clamp(nd->roughness, 0.0f, 1.0f);
    float metallic = clamp(nd->metallic, 0.0f, 1.0f);
    float3 spec_tint = fmax(F3(nd->edge_tint), (float3)(0.0f));
    float tw = clamp(nd->transmission, 0.0f, 1.0f), ss = clamp(nd->subsurface_weight, 0.0f, 1.0f);
    float coat = fmax(nd->coat_weight, 0.0f), sheen = fmax(nd->sheen_weight, 0.0f);
    bool multi = (nd->flags & NODE_FLAG_MULTI_GGX) != 0;
    bool has_t = dot(tangent, tangent) > 0.0f;
    float2 al = aniso_alphas(rough, clamp(nd->anisotropic, 0.0f, 1.0f), has_t);
    float3 T = has_t ? rotate_tangent(tangent, N, nd->anisotropic_rotation) : (float3)(0.0f);
    if (alpha < 1.0f) {
        shader_transparent(sd, w * (1.0f - alpha));
        w *= alpha;
    }
    if (sheen > CLOSURE_WEIGHT_CUTOFF) {
        /* (Cycles: between the Normal and the Coat Normal by the coat's weight) */
        float3 Nc = node_normal(sd, F3(nd->coat_normal)), Ns = N,
               tint = fmax(F3(nd->sheen_tint), (float3)(0.0f));
        if (coat > 0.0f && any(Nc != N)) {
            Ns = mix(N, Nc, fmin(coat, 1.0f));
            float ls = dot(Ns, Ns);
            Ns = ls > 0.0f ? Ns * rsqrt(ls) : sd->N;
        }
        int k = shader_sheen(sd, sheen * tint * w, Ns, clamp(nd->sheen_roughness, 0.0f, 1.0f),
                             shading_tables);
        if (k >= 0) w = layering_weight(sd->c[k].weight, w);
    }
    if (PPM_MICROFACET && coat > CLOSURE_WEIGHT_CUTOFF) {
        float cr = clamp(nd->coat_roughness, 0.0f, 1.0f), cior = fmax(nd->coat_ior, 1.0f);
        float3 Nc = specular_normal(sd, node_normal(sd, F3(nd->coat_normal)), nd->flags);
        int k = shader_microfacet(sd, CLOSURE_GGX_REFLECT, coat * w, Nc, cr * cr, cr * cr, cior);
        if (k >= 0) {
            Closure *c = &sd->c[k];
            c->fresnel = FRESNEL_DIELECTRIC;
            microfacet_sample_weight(sd, k, shading_tables);
            microfacet_preserve_energy(c, sd->wi, (float3)(fresnel_dielectric_fss(cior)),
                                       shading_tables);
            w = layering_weight(c->weight
                                    * microfacet_albedo(c, sd->wi, true, false, shading_tables),
                                w);
        }
        float3 tint = fmax(F3(nd->coat_tint), (float3)(0.0f));
        if (tint.x != 1.0f || tint.y != 1.0f || tint.z != 1.0f) {
            float cos_ni = dot(sd->wi, Nc);
            float cos_nt = sqrt(1.0f - sqr(1.0f / cior) * (1.0f - cos_ni * cos_ni));
            w *= mix((float3)(1.0f), pow(tint, 1.0f / cos_nt), coat);
        }
    }
    sd->emission += emission * w;
    if (PPM_MICROFACET && metallic > CLOSURE_WEIGHT_CUTOFF) {
        int k = shader_microfacet(sd, CLOSURE_GGX_REFLECT, metallic * w, Nv, al.x, al.y, 1.0f);
        if (k >= 0) {
            sd->c[k].T = T;
            f82_setup(sd, k, cbase, fmin(spec_tint, (float3)(1.0f)), multi, shading_tables);
        }
        w *= 1.0f - metallic;
    }
    if (PPM_MICROFACET && tw > CLOSURE_WEIGHT_CUTOFF) {
        int k = shader_microfacet(sd, CLOSURE_GGX_GLASS, tw * w, Nv, rough * rough, rough * rough,
                                  sd->backfacing ? 1.0f / ior : ior);
        if (k >= 0)
            schlick_ior_setup(sd, k, f0_from_ior(ior) * spec_tint, (float3)(1.0f), sqrt(cbase),
                              multi, shading_tables);
        w *= 1.0f - tw;
    }
    float eta = ior, f0 = f0_from_ior(eta);
    if (nd->specular_ior_level != 0.5f) {
        f0 *= 2.0f * fmax(nd->specular_ior_level, 0.0f);
        eta = ior_from_f0(f0);
        if (ior < 1.0f) eta = 1.0f / eta;
    }
    if (PPM_MICROFACET && eta != 1.0f) {
        int k = shader_microfacet(sd, CLOSURE_GGX_REFLECT, w, Nv, al.x, al.y, eta);
        if (k >= 0) {
            sd->c[k].T = T;
            schlick_ior_setup(sd, k, f0 * spec_tint, (float3)(1.0f), (float3)(0.0f), multi,
                              shading_tables);
            w = layering_weight(sd->c[k].weight
                                    * microfacet_albedo(&sd->c[k], sd->wi, true, false,
                                                        shading_tables),
                                w);
        }
    }
    /* subsurface scattering renders as diffuse with the (clamped) base colour */
    float3 wd = cbase * ss * w + base * (1.0f - ss) * w;
    shader_diffuse(sd, wd, N, clamp(nd->diffuse_roughness, 0.0f, 1.0f), base);
}

/* the BSDF nodes other than the Principled */
inline void bsdf_node_setup(ShaderData *sd, NODE_PTR nd, float3 color, float3 emission,
                            float3 tangent, TABLES_ARG) {
    float w1 = nd->weight, rough = clamp(nd->roughness, 0.0f, 1.0f);
    float3 N = node_normal(sd, F3(nd->normal)), Nv = specular_normal(sd, N, nd->flags),
           w = (float3)(w1);
    bool multi = (nd->flags & NODE_FLAG_MULTI_GGX) != 0, has_t = dot(tangent, tangent) > 0.0f;
    int t = nd->type;
    if (t == NODE_DIFFUSE) {
        shader_diffuse(sd, color * w1, N, nd->roughness < 1e-5f ? 0.0f : rough, color);
    } else if (t == NODE_TRANSLUCENT) {
        if (PPM_TRANSLUCENT) shader_alloc(sd, CLOSURE_TRANSLUCENT, color * w1, Nv);
    } else if (t == NODE_TRANSPARENT) {
        shader_transparent(sd, color * w1);
    } else if (t == NODE_SHEEN) {
        shader_sheen(sd, color * w1, N, rough, shading_tables);
    } else if (t == NODE_EMISSION) {
        sd->emission += emission * w1;
    } else if (t == NODE_HOLDOUT) {
        sd->holdout += w;
    } else if (t == NODE_GLOSSY) {                 /* Glossy BSDF: anisotropy in [-1, 1] */
        float a = rough * rough, an = clamp(nd->anisotropic, -0.99f, 0.99f), ax = a, ay = a;
        if (has_t && fabs(an) > 1e-4f) {
            ax = an < 0.0f ? a / (1.0f + an) : a * (1.0f - an);
            ay = an < 0.0f ? a * (1.0f + an) : a / (1.0f - an);
        }
        int k = shader_microfacet(sd, CLOSURE_GGX_REFLECT, color * w1, Nv, ax, ay, 1.0f);
        if (k >= 0) {
            sd->c[k].T = has_t ? rotate_tangent(tangent, Nv, nd->anisotropic_rotation)
                               : (float3)(0.0f);
            if (multi)
                microfacet_preserve_energy(&sd->c[k], sd->wi, fmax(color, 0.0f), shading_tables);
        }
    } else if (t == NODE_METALLIC) {
        float2 al = aniso_alphas(rough, clamp(nd->anisotropic, 0.0f, 1.0f), has_t);
        int k = shader_microfacet(sd, CLOSURE_GGX_REFLECT, w, Nv, al.x, al.y, 1.0f);
        if (k < 0) return;
        Closure *c = &sd->c[k];
        c->T = has_t ? rotate_tangent(tangent, N, nd->anisotropic_rotation) : (float3)(0.0f);
        if (nd->flags & NODE_FLAG_CONDUCTOR) {
            float3 n = fmax(color, 0.0f), kk = fmax(F3(nd->edge_tint), (float3)(0.0f));
            c->fresnel = FRESNEL_CONDUCTOR;
            c->f0 = n;
            c->f90 = kk;
            microfacet_sample_weight(sd, k, shading_tables);
            float3 F0 = fresnel_conductor(1.0f, n, kk), F82 = fresnel_conductor(1.0f / 7.0f, n, kk);
            if (multi)
                microfacet_preserve_energy(c, sd->wi,
                                           sat3(fresnel_f82_fss(F0,
                                                                fresnel_f82_b_from_f82(F0, F82))),
                                           shading_tables);
        } else {
            f82_setup(sd, k, sat3(color), sat3(F3(nd->edge_tint)), multi, shading_tables);
        }
    } else if (t == NODE_GLASS || t == NODE_REFRACTION) {
        float ior = fmax(nd->ior, 1e-5f);
        bool glass = t == NODE_GLASS;
        int k = shader_microfacet(sd, glass ? CLOSURE_GGX_GLASS : CLOSURE_GGX_REFRACT,
                                  glass ? w : color * w1, Nv, rough * rough, rough * rough,
                                  sd->backfacing ? 1.0f / ior : ior);
        if (k >= 0 && glass) {
            float3 c3 = fmax(color, 0.0f);
            schlick_ior_setup(sd, k, (float3)(f0_from_ior(ior)), c3, c3, multi, shading_tables);
        }
    }
}
#endif
