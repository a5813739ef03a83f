#ifndef PPM_SHADER_INPUTS_H
#define PPM_SHADER_INPUTS_H
#include "closure/shader_data.h"

/* What a material's BSDF nodes read at a shading point before they become closures
 * (kernels/closure/shader.h): the inputs its shader program drives, the Normal inputs, the tangent;
 * and what is asked of a material without its closures: the transparency shadow rays see and the
 * emission light samples see. */

/* alphas of a roughness with Cycles' anisotropy (aspect sqrt(1 - 0.9 aniso)) */
inline float2 aniso_alphas(float roughness, float aniso, bool tangent) {
    float a = roughness * roughness;
    if (!(aniso > 0.0f) || !tangent) return (float2)(a, a);
    float aspect = sqrt(1.0f - 0.9f * aniso);
    return (float2)(a / aspect, a * aspect);
}

/* the tangent rotated by rotation x 2 pi about N, made orthogonal to N */
inline float3 rotate_tangent(float3 T, float3 N, float rotation) {
    if (rotation != 0.0f) {
        float a = rotation * 2.0f * PPM_PI, c = cos(a), s = sin(a);
        T = c * T + s * cross(N, T) + (1.0f - c) * dot(N, T) * N;
    }
    return T;
}

/* Material m's shader program run at a shading point of the enclosing function's `scene`,
 * triangle `tri` at barycentrics (`u`, `v`) (position P, normals, view and footprint fp as
 * svm_context_base and svm_context_fill take them), into the private array `stack`; and node
 * i of m with the inputs its program drives written in.  Without shader programs in the build
 * (PPM_SVM 0) they read the buffer's rows. */
#if PPM_SVM
#define MATERIAL_PROGRAM(m, stack, P, path, len, N, Ng, I, back, fp)                     \
    float stack[PPM_SVM_STACK];                                                          \
    if ((m).program > 0) {                                                               \
        SvmContext cx_ = svm_context_base((float2)(0.0f), P, path, len, N, Ng, I, back); \
        svm_context_fill(&cx_, scene, (m).program, tri, u, v, fp);                       \
        svm_eval(scene, (m).program, stack, &cx_);                                       \
    }
#define MATERIAL_NODE(nd, m, i, stack)                                             \
    ShaderNode nd##_row = scene->shader_nodes[(m).node_first + (i)];               \
    if ((m).program > 0) svm_bind(scene->svm, (m).program, (i), &nd##_row, stack); \
    NODE_PTR nd = &nd##_row
#else
#define MATERIAL_PROGRAM(m, stack, P, path, len, N, Ng, I, back, fp) const float *stack = 0
#define MATERIAL_NODE(nd, m, i, stack) NODE_PTR nd = scene->shader_nodes + (m).node_first + (i)
#endif

/* Cycles' ensure_valid_specular_reflection (learnt from its bsdf_util.h): N raised towards Ng
 * just enough that the mirror reflection of I lies above the surface */
inline float3 valid_reflection_normal(float3 Ng, float3 I, float3 N) {
    float3 R = 2.0f * dot(N, I) * N - I;
    float Iz = dot(I, Ng), t = fmin(0.9f * Iz, 0.01f);
    if (dot(Ng, R) >= t) return N;
    float3 X = N - dot(N, Ng) * Ng;
    float lx = length(X);
    X = lx > 0.0f ? X / lx : N;
    float Ix = dot(I, X), a = Ix * Ix + Iz * Iz, b = 2.0f * (a + Iz * t), c = sqr(t + Iz);
    float d = sqrt(fmax(b * b - 4.0f * a * c, 0.0f));
    float nz2 = a > 0.0f ? 0.25f * (Ix < 0.0f ? b + d : b - d) / a : 1.0f;
    return sqrt(fmax(1.0f - nz2, 0.0f)) * X + sqrt(fmax(nz2, 0.0f)) * Ng;
}

/* A node's Normal or Coat Normal input: the driven normal, or the shading normal where it is
 * unlinked (0) */
inline float3 node_normal(const ShaderData *sd, float3 n) {
    float l = dot(n, n);
    if (!(l > 0.0f) || !isfinite(l)) return sd->N;
    return n * rsqrt(l);
}

/* The normal of a microfacet or translucent closure (Cycles'
 * maybe_ensure_valid_specular_reflection, applied to these and not to diffuse or sheen ones): N
 * raised towards Ng until the mirror reflection of the view lies above the surface, wherever N is
 * not the face's own (a smooth-shaded mesh's interpolated normal as much as a driven one), unless
 * the node's material has Cycles' Bump Map Correction off (flags: NODE_FLAG_*).  On a
 * smooth-shaded low-poly mesh seen at grazing angles the interpolated normal can face away from
 * the view while the face does not: unlifted, a rough glass closure there sampled nothing (dark
 * rims along a glass cylinder's silhouettes, 0.77 of Cycles) */
inline float3 specular_normal(const ShaderData *sd, float3 N, uint flags) {
    if ((flags & NODE_FLAG_NO_BUMP_CORRECTION) || all(isequal(N, sd->Ng))) return N;
    return valid_reflection_normal(sd->Ng, sd->wi, N);
}

/* the weight of the one Lambert closure of a MAT_LAMBERT material's node */
inline float3 lambert_weight(const Scene *scene, __global const ShaderNode *nd, uint tri, float u,
                             float v) {
    return fmax(F3(nd->color) * texture_tint(scene, nd->color_texture, tri, u, v), 0.0f)
           * nd->weight;
}

/* The default tangent of anisotropic closures at barycentrics (u, v) of triangle tri: the
 * exported radial tangent (arrays.SceneArrays.tangents) made orthogonal to N, as Cycles'
 * Tangent node; 0 without anisotropy (PPM_ANISOTROPY) */
inline float3 surface_tangent(const Scene *scene, uint tri, float u, float v, float3 N) {
#if PPM_ANISOTROPY
    __global const float *t = scene->tangents + 9 * (size_t)tri;
    float w = 1.0f - u - v;
    float3 r = w * (float3)(t[0], t[1], t[2]) + u * (float3)(t[3], t[4], t[5])
               + v * (float3)(t[6], t[7], t[8]);
    float3 c = cross(r, N);
    float l = length(c);
    return l > 1e-12f ? cross(N, c / l) : (float3)(0.0f);
#else
    return (float3)(0.0f);
#endif
}

/* The transparency (1 - alpha) of material mat at a surface point, without the closures: what
 * shadow rays are let through (Principled Alpha, Transparent BSDF; view-independent). */
inline float3 material_transparency(const Scene *scene, int mat, uint tri, float u, float v,
                                    float3 P) {
    float3 T = (float3)(0.0f);
    Material m = scene->materials[mat];
    float3 z = (float3)(0.0f);            /* (no view direction or normal for a shadow ray) */
    MATERIAL_PROGRAM(m, stack, P, PATH_SHADOW, 0.0f, z, z, z, false, NO_FOOTPRINT);
    for (int i = 0; i < m.node_count; i++) {
        MATERIAL_NODE(nd, m, i, stack);
        if (!(nd->weight > 0.0f)) continue;
        if (nd->type == NODE_PRINCIPLED) {
            float a = clamp(nd->alpha * texture_alpha(scene, nd->alpha_texture, tri, u, v), 0.0f,
                            1.0f);
            T += (float3)(nd->weight * (1.0f - a));
        } else if (nd->type == NODE_TRANSPARENT) {
            T += fmax(F3(nd->color) * texture_tint(scene, nd->color_texture, tri, u, v)
                          * nd->weight,
                      (float3)(0.0f));
        }
    }
    return T;
}

/* The radiance material m emits at a surface point, as the emitter table and the light
 * samples see it: its constant emission times its emission texture, or, when its shader program
 * drives an emission (PROGRAM_EMISSION), the emission nodes evaluated there (the Principled's
 * under its alpha; the view-dependent sheen and coat left out, as materials.node_emission). */
inline float3 material_emission(const Scene *scene, __global const Material *m, uint tri, float u,
                                float v, float3 P) {
#if PPM_SVM
    if (m->program > 0 && (scene->svm[m->program].w & PROGRAM_EMISSION)) {
        Material mm = *m;
        float3 z = (float3)(0.0f);
        MATERIAL_PROGRAM(mm, stack, P, 0u, 0.0f, z, z, z, false, NO_FOOTPRINT);
        float3 E = (float3)(0.0f);
        for (int i = 0; i < mm.node_count; i++) {
            MATERIAL_NODE(nd, mm, i, stack);
            if (!(nd->weight > 0.0f) || (nd->type != NODE_EMISSION && nd->type != NODE_PRINCIPLED))
                continue;
            float3 e = fmax(F3(nd->emission), 0.0f) * nd->weight
                       * texture_tint(scene, nd->emission_texture, tri, u, v);
            if (nd->type == NODE_PRINCIPLED)
                e *= clamp(nd->alpha * texture_alpha(scene, nd->alpha_texture, tri, u, v), 0.0f,
                           1.0f);
            E += e;
        }
        return E;
    }
#endif
    return F3(m->emission) * texture_tint(scene, m->emission_tex, tri, u, v);
}

#endif
