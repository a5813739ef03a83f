#ifndef PPM_SVM_CONTEXT_H
#define PPM_SVM_CONTEXT_H
#include "scene.h"
#include "svm/textures.h"
#include "svm/svm_types.h"
#include "svm/svm_util.h"

/* The shading point as a shader program reads it: its context, built per hit from the scene's
 * per-corner arrays (svm.h svm_context_fill puts it together), and the Normal Map node, which
 * reads the context's frame. */

/* The ray footprint at a shading point, for the Bump node: the triangle's edges dP/du and dP/dv
 * (world; barycentrics as surface_at's), the radius of Cycles' compact ray differential there
 * (0: none, the Bump gives its input normal), and the smooth normal (unnormalised, as
 * interpolated at the point) with its changes along u and v.  kernels/svm/svm_bump.h has how
 * callers get the radius. */
typedef struct {
    float3 dpdu, dpdv;
    float r;
    float3 n, dndu, dndv;
} Footprint;

inline Footprint footprint(float3 dpdu, float3 dpdv, float r) {
    Footprint f;
    f.dpdu = dpdu;
    f.dpdv = dpdv;
    f.r = r;
    f.n = f.dndu = f.dndv = (float3)(0.0f);
    return f;
}
#define NO_FOOTPRINT footprint((float3)(0.0f), (float3)(0.0f), 0.0f)

/* the footprint of radius r at barycentrics (u, v) of triangle tri (original index) at BVH
 * leaf `leaf` (its edges), from the triangle's corner normals */
inline Footprint footprint_at(const Scene *scene, uint tri, int leaf, float u, float v, float r) {
    Footprint f = footprint(scene->tri_e1[leaf].xyz, scene->tri_e2[leaf].xyz, r);
    if (!SVM_FOOTPRINT) return f;
    __global const float *c = scene->normals + 9 * (size_t)tri;
    float3 n0 = (float3)(c[0], c[1], c[2]), n1 = (float3)(c[3], c[4], c[5]),
           n2 = (float3)(c[6], c[7], c[8]);
    f.n = (1.0f - u - v) * n0 + u * n1 + v * n2;
    f.dndu = n1 - n0;
    f.dndv = n2 - n0;
    return f;
}

/* the float4 rows of an object in scene->objects (ppm_engine/scene/arrays.py OBJECT_ROWS,
 * export/objects.py object_row): its inverse matrix, (location, pass index), colour, random
 * number, world matrix, and the scale and offset of its Generated coordinates (a volume's) */
#define OBJECT_ROWS 11

/* what a program may read of the shading point */
typedef struct {
    float2 uv;
    float3 N;            /* shading normal, on the viewer's side */
    float3 Ng;
    float3 I;            /* towards the viewer (0 for shadow rays and emitter samples) */
    float backfacing;
    float4 tangent;      /* the UV map's tangent (world) and bitangent sign; 0 when not read */
    float normal_len;    /* the length of the corners' normals interpolated (1 when not read) */
    float3 generated;    /* Generated coordinates (0..1 over the mesh's texture space) */
    float3 P;            /* the position (world) */
    uint path;           /* the ray that reached the point (path_state.h) */
    float path_length;   /* its last segment's length */
    float3 P_object;     /* the position in the object's space */
    float3 window;       /* the camera's Window coordinates (0 where not read) */
    float4 object[3];    /* the object's (location, pass index), colour, (random, 0, 0, 0) */
#if SVM_OBJECT_MATRICES
    float4 to_object[3], to_world[3];   /* its inverse and world matrices (Vector Transform) */
#endif
    float4 attr[PPM_ATTRIBUTES];  /* the mesh attributes programs read, at the point */
#if SVM_HAS_BUMP
    /* what the position-dependent inputs change by over the footprint's two offsets dP[k]
     * (Cycles' dPdx, dPdy): the Bump node's height is evaluated at P + width x dP[k] */
    float3 dP[2], dP_object[2], dgenerated[2];
    float3 n_smooth, dn[2];  /* the smooth normal (unnormalised, on N's side), its changes */
    float2 duv[2];
    float4 dattr[2][PPM_ATTRIBUTES];
#endif
} SvmContext;

/* A context with what every shading point has, and the defaults of the rest: no tangent, no
 * Generated coordinates, no object (its space the world's), no mesh attributes */
inline SvmContext svm_context_base(float2 uv, float3 P, uint path, float path_length, float3 N,
                                   float3 Ng, float3 I, bool backfacing) {
    SvmContext cx;
    cx.uv = uv;
    cx.N = N;
    cx.Ng = Ng;
    cx.I = I;
    cx.backfacing = backfacing ? 1.0f : 0.0f;
    cx.tangent = (float4)(0.0f);
    cx.normal_len = 1.0f;
    cx.generated = (float3)(0.0f);
    cx.P = cx.P_object = P;
    cx.window = (float3)(0.0f);
    cx.path = path;
    cx.path_length = path_length;
    for (int r = 0; r < 3; r++) {
        cx.object[r] = (float4)(0.0f);
#if SVM_OBJECT_MATRICES
        cx.to_object[r] = cx.to_world[r] = (float4)(r == 0, r == 1, r == 2, 0.0f);
#endif
    }
    for (int k = 0; k < PPM_ATTRIBUTES; k++) cx.attr[k] = (float4)(0.0f);
#if SVM_HAS_BUMP
    cx.n_smooth = (float3)(0.0f);
    for (int d = 0; d < 2; d++) {
        cx.dP[d] = cx.dP_object[d] = cx.dgenerated[d] = cx.dn[d] = (float3)(0.0f);
        cx.duv[d] = (float2)(0.0f);
        for (int k = 0; k < PPM_ATTRIBUTES; k++) cx.dattr[d][k] = (float4)(0.0f);
    }
#endif
    return cx;
}

/* The per-corner data of the context at barycentrics (u, v) and position P, where the program
 * at word p reads them: the UV map (always), Generated coordinates, the object's data, mesh
 * attributes. */
inline void svm_corner_data(SvmContext *cx, const Scene *scene, int p, uint tri, float u, float v,
                            float3 P) {
    __global const int4 *svm = scene->svm;
    cx->uv = surface_uv(scene->uvs, tri, u, v);
    float w = 1.0f - u - v;
    if (SVM_HAS(SVM_GEOMETRY) && p > 0 && (svm[p].w & PROGRAM_GENERATED)) {
        __global const float *g = scene->generated + 9 * (size_t)tri;
        cx->generated = w * (float3)(g[0], g[1], g[2]) + u * (float3)(g[3], g[4], g[5])
                        + v * (float3)(g[6], g[7], g[8]);
    }
    if (SVM_HAS(SVM_GEOMETRY) && p > 0 && (svm[p].w & PROGRAM_OBJECT)
        && scene->tri_object[tri] >= 0) {
        __global const float4 *o = scene->objects + OBJECT_ROWS * (size_t)scene->tri_object[tri];
        float4 h = (float4)(P, 1.0f);
        cx->P_object = (float3)(dot(o[0], h), dot(o[1], h), dot(o[2], h));
        cx->object[0] = o[3];
        cx->object[1] = o[4];
        cx->object[2] = o[5];
#if SVM_OBJECT_MATRICES
        for (int r = 0; r < 3; r++) {
            cx->to_object[r] = o[r];
            cx->to_world[r] = o[6 + r];
        }
#endif
    }
    if (SVM_HAS(SVM_GEOMETRY) && p > 0 && (svm[p].w & PROGRAM_ATTRIBUTES)) {
        const int stride = scene->emitter_info->n_attributes;   /* per corner */
        for (int k = 0; k < PPM_ATTRIBUTES && k < stride; k++) {
            __global const float4 *a = scene->attributes + 3 * stride * (size_t)tri + k;
            cx->attr[k] = w * a[0] + u * a[stride] + v * a[2 * stride];
        }
    }
}

/* Cycles' Normal Map node (learnt from its svm_node_normal_map): the colour's tangent-space
 * normal (NORMAL_MAP_TANGENT) in the frame of the UV tangent, the interpolated normal and their
 * bitangent, as Cycles unnormalised (the corners' tangents, normals and bitangent signs
 * interpolated: a low-poly mesh's normal is shorter inside its triangles, the map tilts it
 * further), the strength applied in tangent space; or a world-space normal (the other spaces:
 * object and world, Blender's object and world with y and z negated; object space through
 * the object's inverse transpose) interpolated from N by the strength.  On the
 * viewer's side; N itself where the result is degenerate or no tangent exists. */
inline float3 svm_normal_map(const SvmContext *cx, int space, float3 color, float strength) {
    float3 c = 2.0f * color - 1.0f, N;
    bool back = cx->backfacing > 0.0f;
    if (space == NORMAL_MAP_TANGENT) {
        float3 T = cx->tangent.xyz;
        if (!(dot(T, T) > 0.0f)) return cx->N;
        float3 n = (back ? -cx->N : cx->N) * cx->normal_len;
        c.x *= strength;
        c.y *= strength;
        c.z = mix(1.0f, c.z, clamp(strength, 0.0f, 1.0f));
        float3 B = cx->tangent.w * cross(n, T);
        N = svm_safe_normalize(c.x * T + c.y * B + c.z * n);
    } else {
        if (space == NORMAL_MAP_BLENDER_OBJECT || space == NORMAL_MAP_BLENDER_WORLD) c.yz = -c.yz;
        N = svm_safe_normalize(c);
#if SVM_OBJECT_MATRICES
        /* object space: to world by the inverse transpose of the object's matrix */
        if (space == NORMAL_MAP_OBJECT || space == NORMAL_MAP_BLENDER_OBJECT)
            N = svm_safe_normalize(N.x * cx->to_object[0].xyz + N.y * cx->to_object[1].xyz
                                   + N.z * cx->to_object[2].xyz);
#endif
    }
    if (back) N = -N;
    if (space != NORMAL_MAP_TANGENT && strength != 1.0f)
        N = svm_safe_normalize(cx->N + (N - cx->N) * fmax(strength, 0.0f));
    return (dot(N, N) > 0.0f && all(isfinite(N))) ? N : cx->N;
}
#endif
