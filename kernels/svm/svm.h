#ifndef PPM_SVM_H
#define PPM_SVM_H
#include "scene.h"
#include "geom/camera.h"
#include "integrator/path_state.h"
#include "svm/textures.h"
#include "svm/svm_types.h"
#include "svm/svm_util.h"
#include "svm/svm_context.h"
#include "svm/svm_bump.h"
#include "svm/svm_color.h"
#include "svm/svm_nodes.h"
#include "svm/svm_textures.h"
#include "svm/svm_image.h"
#include "svm/svm_sky.h"

/* The shader program interpreter (ppm_engine/scene/shader_program.py has the layout; the exporter's
 * export/shader_graph.py compiles a material's node graph into it): value nodes evaluated into a
 * private stack of floats, then the BSDF nodes' inputs read from it (svm_bind).  Built only for
 * scenes with a program (PPM_SVM), with the op codes the scene's programs use (PPM_SVM_OPS,
 * svm_types.h) and the stack they need (PPM_SVM_STACK floats). */

/* The context of a shading point of triangle tri at barycentrics (u, v) for the program at word
 * p, completed from cx = svm_context_base(...) (N and Ng on the viewer's side, I towards the
 * viewer; all 0 where no direction is known: shadow rays, emitter samples): the per-corner
 * data only where the program reads them, their changes over the footprint fp where it has a
 * Bump node (svm_bump.h). */
inline void svm_context_fill(SvmContext *cx, const Scene *scene, int p, uint tri, float u, float v,
                             Footprint fp) {
    __global const int4 *svm = scene->svm;
    if (SVM_HAS(SVM_GEOMETRY) && p > 0 && (svm[p].w & PROGRAM_WINDOW))
        cx->window = camera_window(scene->camera, cx->P);
    if (SVM_HAS(SVM_NORMAL_MAP) && p > 0 && (svm[p].w & PROGRAM_TANGENTS)) {
        __global const float4 *t = scene->uv_tangents + 3 * (size_t)tri;
        __global const float *n = scene->normals + 9 * (size_t)tri;
        float w = 1.0f - u - v;
        cx->tangent = w * t[0] + u * t[1] + v * t[2];
        float l = length(w * (float3)(n[0], n[1], n[2]) + u * (float3)(n[3], n[4], n[5])
                         + v * (float3)(n[6], n[7], n[8]));
        cx->normal_len = l > 0.0f && isfinite(l) ? l : 1.0f;
    }
    svm_corner_data(cx, scene, p, tri, u, v, cx->P);
#if SVM_HAS_BUMP
    if (p > 0 && (svm[p].w & PROGRAM_BUMP) && fp.r > 0.0f)
        svm_footprint_offsets(cx, scene, p, tri, u, v, fp);
#endif
}

/* Runs the value ops of the program at word p into stack */
inline void svm_eval(const Scene *scene, int p, float *stack, const SvmContext *ctx) {
    __global const int4 *svm = scene->svm;
    int4 h = svm[p];
    int i = p + 1 + h.x, end = p + h.y;
    while (i < end) {
        int4 w = svm[i++];
        int op = w.x;
        if (op == SVM_END) return;
        if (SVM_HAS(SVM_CONST) && op == SVM_CONST) {
            float4 c = as_float4(svm[i++]);
            stack[w.y] = c.x;
            if (w.z > 1) {
                stack[w.y + 1] = c.y;
                stack[w.y + 2] = c.z;
            }
        } else if (SVM_HAS(SVM_GEOMETRY) && op == SVM_GEOMETRY) {
            /* GEOM_*; at the Bump's offset k = 1, 2: what + k GEOM_BUMP_OFFSET, w.w its width */
            int what = w.z % GEOM_BUMP_OFFSET;
            float3 v = what == GEOM_UV                ? (float3)(ctx->uv, 0.0f)
                       : what == GEOM_NORMAL          ? ctx->N
                       : what == GEOM_TRUE_NORMAL     ? ctx->Ng
                       : what == GEOM_INCOMING        ? ctx->I
                       : what == GEOM_GENERATED       ? ctx->generated
                       : what == GEOM_REFLECTION      ? 2.0f * dot(ctx->N, ctx->I) * ctx->N - ctx->I
                       : what == GEOM_POSITION        ? ctx->P
                       : what == GEOM_OBJECT          ? ctx->P_object
                       : what == GEOM_WINDOW          ? ctx->window
                       : what == GEOM_OBJECT_LOCATION ? ctx->object[0].xyz
                       : what == GEOM_OBJECT_COLOR    ? ctx->object[1].xyz
                                                      : (float3)(ctx->backfacing);
            float4 x = (float4)(v, 0.0f);
            if (what >= GEOM_ATTRIBUTE)                   /* mesh attribute k */
                x = ctx->attr[min((what - GEOM_ATTRIBUTE) & (MAX_ATTRIBUTES - 1),
                                  PPM_ATTRIBUTES - 1)];
            if (what >= GEOM_ATTRIBUTE_ALPHA) x.x = x.w;
#if SVM_HAS_BUMP
            if (w.z >= GEOM_BUMP_OFFSET)
                x = svm_bump_input(ctx, what, w.z / GEOM_BUMP_OFFSET - 1, as_float(w.w), x);
#endif
            if (what == GEOM_LIGHT_PATH) {                /* Light Path output w.w */
                stack[w.y] = path_output(ctx->path, ctx->path_length, w.w);
            } else if (what == GEOM_BACKFACING
                       || (what >= GEOM_OBJECT_ALPHA && what <= GEOM_OBJECT_RANDOM)
                       || what >= GEOM_ATTRIBUTE_ALPHA) {
                stack[w.y] = what == GEOM_BACKFACING      ? ctx->backfacing
                             : what == GEOM_OBJECT_ALPHA  ? ctx->object[1].w
                             : what == GEOM_OBJECT_INDEX  ? ctx->object[0].w
                             : what == GEOM_OBJECT_RANDOM ? ctx->object[2].x
                                                          : x.x;
            } else {
                svm_put3(stack, w.y, x.xyz);
            }
        } else if (SVM_HAS(SVM_IMAGE) && op == SVM_IMAGE) {
            i = svm_image(scene, w, i, stack);                        /* svm_image.h */
        } else if (SVM_HAS(SVM_MAPPING) && op == SVM_MAPPING) {
            float4 r0 = as_float4(svm[i]), r1 = as_float4(svm[i + 1]), r2 = as_float4(svm[i + 2]);
            i += 3;
            int t = w.w;
            if (t >= MAPPING_TO_CAMERA_POINT) {
                /* the camera's space, read now (a moved view needs no new program): Cycles'
                 * camera-to-world is to_world's rows with the z axis flipped (+z ahead), a
                 * rotation and a move, so normals go as directions */
                __global const float *m = scene->camera->to_world;
                float3 X = (float3)(m[0], m[4], m[8]), Y = (float3)(m[1], m[5], m[9]);
                float3 Z = -(float3)(m[2], m[6], m[10]), T = (float3)(m[3], m[7], m[11]);
                if (t < MAPPING_FROM_CAMERA_POINT) {       /* world to camera: R^T (p - T) */
                    r0 = (float4)(X, -dot(X, T));
                    r1 = (float4)(Y, -dot(Y, T));
                    r2 = (float4)(Z, -dot(Z, T));
                } else {                                  /* camera to world: R p + T */
                    r0 = (float4)(X.x, Y.x, Z.x, T.x);
                    r1 = (float4)(X.y, Y.y, Z.y, T.y);
                    r2 = (float4)(X.z, Y.z, Z.z, T.z);
                }
                int k = (t - MAPPING_TO_CAMERA_POINT) % 3;
                t = k == 0 ? MAPPING_POINT : k == 1 ? MAPPING_VECTOR : MAPPING_NORMAL;
            }
#if SVM_OBJECT_MATRICES
            else if (t >= MAPPING_TO_OBJECT_POINT) {     /* the object's own matrices */
                bool to_object = t < MAPPING_TO_WORLD_POINT;
                const float4 *m = to_object ? ctx->to_object : ctx->to_world;
                const float4 *n = to_object ? ctx->to_world : ctx->to_object;
                bool normal = t == MAPPING_TO_OBJECT_NORMAL || t == MAPPING_TO_WORLD_NORMAL;
                r0 = normal ? (float4)(n[0].x, n[1].x, n[2].x, 0.0f) : m[0];
                r1 = normal ? (float4)(n[0].y, n[1].y, n[2].y, 0.0f) : m[1];
                r2 = normal ? (float4)(n[0].z, n[1].z, n[2].z, 0.0f) : m[2];
                t = t == MAPPING_TO_OBJECT_POINT || t == MAPPING_TO_WORLD_POINT ? MAPPING_POINT
                    : t == MAPPING_TO_OBJECT_VECTOR || t == MAPPING_TO_WORLD_VECTOR
                        ? MAPPING_VECTOR
                        : MAPPING_NORMAL;
            }
#endif
            float4 v = (float4)(svm_get3(stack, w.z), t == MAPPING_POINT ? 1.0f : 0.0f);
            if (t == MAPPING_TEXTURE) v.w = 1.0f;
            float3 o = (float3)(dot(r0, v), dot(r1, v), dot(r2, v));
            if (t == MAPPING_NORMAL) o = svm_safe_normalize(o);
            svm_put3(stack, w.y, o);
        } else if (SVM_HAS(SVM_MATH) && op == SVM_MATH) {
            int4 e = svm[i++];
            float r = svm_math(e.y, stack[w.z], stack[w.w], stack[e.x]);
            stack[w.y] = e.z ? clamp(r, 0.0f, 1.0f) : r;
        } else if (SVM_HAS(SVM_VECTOR_MATH) && op == SVM_VECTOR_MATH) {
            int4 e = svm[i++];
            float value;
            float3 r = svm_vector_math(e.y, svm_get3(stack, w.z), svm_get3(stack, w.w),
                                       svm_get3(stack, e.x), stack[e.w], &value);
            svm_put3(stack, w.y, r);
            stack[e.z] = value;
        } else if (SVM_HAS(SVM_MIX) && op == SVM_MIX) {
            int4 e = svm[i++];
            int flags = e.z;
            if (flags & MIXF_SCALAR) {
                float t = stack[e.x];
                if (flags & MIXF_CLAMP_FACTOR) t = clamp(t, 0.0f, 1.0f);
                stack[w.y] = mix(stack[w.z], stack[w.w], t);
            } else if (flags & MIXF_VECTOR_FACTOR) {
                float3 t = svm_get3(stack, e.x);
                if (flags & MIXF_CLAMP_FACTOR) t = clamp(t, 0.0f, 1.0f);
                svm_put3(stack, w.y, mix(svm_get3(stack, w.z), svm_get3(stack, w.w), t));
            } else {
                float t = stack[e.x];
                if (flags & MIXF_CLAMP_FACTOR) t = clamp(t, 0.0f, 1.0f);
                float3 r = svm_mix_color(e.y, t, svm_get3(stack, w.z), svm_get3(stack, w.w));
                if (flags & MIXF_CLAMP_RESULT) r = clamp(r, 0.0f, 1.0f);
                svm_put3(stack, w.y, r);
            }
        } else if (SVM_HAS(SVM_COMBINE) && op == SVM_COMBINE) {
            int z = svm[i++].x;
            float3 r = (float3)(stack[w.z], stack[w.w], stack[z]);
            svm_put3(stack, w.y, r);
        } else if (SVM_HAS(SVM_COLOR_CONVERT) && op == SVM_COLOR_CONVERT) {
            float3 c = svm_get3(stack, w.z);
            c = w.w == COLOR_RGB_TO_HSV   ? rgb_to_hsv(c)
                : w.w == COLOR_HSV_TO_RGB ? hsv_to_rgb(c)
                : w.w == COLOR_RGB_TO_HSL ? rgb_to_hsl(c)
                                          : hsl_to_rgb(c);
            svm_put3(stack, w.y, c);
        } else if (SVM_HAS(SVM_INVERT) && op == SVM_INVERT) {
            float3 c = svm_get3(stack, w.w);
            svm_put3(stack, w.y, mix(c, 1.0f - c, stack[w.z]));
        } else if (SVM_HAS(SVM_GAMMA) && op == SVM_GAMMA) {
            float3 c = svm_get3(stack, w.z);
            float g = stack[w.w];
            if (g == 0.0f) c = (float3)(1.0f);
            if (c.x > 0.0f) c.x = pow(c.x, g);
            if (c.y > 0.0f) c.y = pow(c.y, g);
            if (c.z > 0.0f) c.z = pow(c.z, g);
            svm_put3(stack, w.y, c);
        } else if (SVM_HAS(SVM_BRIGHT_CONTRAST) && op == SVM_BRIGHT_CONTRAST) {
            float contrast = stack[svm[i++].x], bright = stack[w.w];
            float a = 1.0f + contrast, b = bright - contrast * 0.5f;
            svm_put3(stack, w.y, fmax(a * svm_get3(stack, w.z) + b, 0.0f));
        } else if (SVM_HAS(SVM_RGB_TO_BW) && op == SVM_RGB_TO_BW) {
            stack[w.y] = dot(svm_get3(stack, w.z), (float3)(0.2126729f, 0.7151522f, 0.0721750f));
        } else if (SVM_HAS(SVM_CLAMP) && op == SVM_CLAMP) {
            int4 e = svm[i++];
            float lo = stack[w.w], hi = stack[e.x];
            if (e.y == CLAMP_RANGE && lo > hi) {
                float t = lo;
                lo = hi;
                hi = t;
            }
            stack[w.y] = fmin(fmax(stack[w.z], lo), hi);
        } else if (SVM_HAS(SVM_MAP_RANGE) && op == SVM_MAP_RANGE) {
            int4 e = svm[i], f = svm[i + 1];
            i += 2;
            stack[w.y] = svm_map_range(f.x, f.y != 0, stack[w.z], stack[w.w], stack[e.x],
                                       stack[e.y], stack[e.z], stack[e.w]);
        } else if (SVM_HAS(SVM_TABLE) && op == SVM_TABLE) {
            int4 e = svm[i], g = svm[i + 1];
            __global const int4 *t = svm + i + 2;
            i += 2 + w.w;
            float lo = as_float(e.z), hi = as_float(e.w), fac = stack[g.x];
            if (e.x == TABLE_SCALAR) {                      /* ramp, float curve */
                float4 r = svm_table(t, w.w, stack[w.z], lo, hi, e.y);
                svm_put3(stack, w.y, r.xyz);
                if (fac != 1.0f) stack[w.y] = mix(stack[w.z], r.x, fac);
            } else {                                        /* RGB, vector curves */
                float3 c = svm_get3(stack, w.z);
                float3 r = (float3)(svm_table(t, w.w, c.x, lo, hi, 1).x,
                                    svm_table(t, w.w, c.y, lo, hi, 1).y,
                                    svm_table(t, w.w, c.z, lo, hi, 1).z);
                svm_put3(stack, w.y, mix(c, r, fac));
            }
        } else if (SVM_HAS(SVM_HSV) && op == SVM_HSV) {
            int4 e = svm[i++];
            float3 c = svm_get3(stack, w.z), hsv = rgb_to_hsv(c);
            hsv.x = hsv.x + stack[e.x] + 0.5f;
            hsv.x -= floor(hsv.x);
            hsv.y = clamp(hsv.y * stack[e.y], 0.0f, 1.0f);
            hsv.z *= stack[e.z];
            float3 r = mix(c, hsv_to_rgb(hsv), stack[w.w]);
            svm_put3(stack, w.y, fmax(r, 0.0f));
        } else if (SVM_HAS(SVM_FRESNEL) && op == SVM_FRESNEL) {
            float eta = fmax(stack[w.z], 1e-5f);
            eta = ctx->backfacing > 0.0f ? 1.0f / eta : eta;
            stack[w.y] = svm_fresnel_cos(dot(ctx->I, ctx->N), eta);
        } else if (SVM_HAS(SVM_LAYER_WEIGHT) && op == SVM_LAYER_WEIGHT) {
            float blend = stack[w.z], c = dot(ctx->I, ctx->N);
            float eta = fmax(1.0f - blend, 1e-5f);
            stack[w.y] = svm_fresnel_cos(c, ctx->backfacing > 0.0f ? eta : 1.0f / eta);
            float f = fabs(c);
            if (blend != 0.5f) {
                float b = clamp(blend, 0.0f, 1.0f - 1e-5f);
                f = pow(f, b < 0.5f ? 2.0f * b : 0.5f / (1.0f - b));
            }
            stack[w.w] = 1.0f - f;
        } else if (SVM_HAS(SVM_NORMAL_MAP) && op == SVM_NORMAL_MAP) {
            int space = svm[i++].x;
            svm_put3(stack, w.y, svm_normal_map(ctx, space, svm_get3(stack, w.z), stack[w.w]));
        } else if (SVM_HAS(SVM_BLACKBODY) && op == SVM_BLACKBODY) {
            svm_put3(stack, w.y, svm_blackbody(stack[w.z]));
        } else if (SVM_HAS(SVM_WAVELENGTH) && op == SVM_WAVELENGTH) {
            svm_put3(stack, w.y, svm_wavelength(stack[w.z]));
#if SVM_HAS_BUMP
        } else if (op == SVM_BUMP) {
            int4 e = svm[i], f = svm[i + 1];
            i += 2;
            float3 n_in = w.z >= 0 ? svm_get3(stack, w.z) : ctx->N;
            svm_put3(stack, w.y,
                     svm_bump_normal(ctx, n_in, stack[e.x], stack[e.y], stack[e.z], stack[e.w],
                                     stack[w.w], f.x != 0, as_float(f.y)));
#endif
        } else if (op >= SVM_TEX_CHECKER && op <= SVM_TEX_LAST) {
            i = svm_texture(op, w, svm, i, stack);
            if (i < 0) return;
        } else if (SVM_HAS(SVM_TEX_SKY) && op == SVM_TEX_SKY) {
            i = svm_sky(w, svm, i, stack);
        } else {
            return;                           /* an op this build lacks: stop safely */
        }
    }
}

/* The inputs of BSDF node `node` (counted in its material) that the program drives, written
 * into the node's private copy (as floats: SHADER_NODE_DTYPE's word layout) */
inline void svm_bind(__global const int4 *svm, int p, int node, ShaderNode *nd,
                     const float *stack) {
    int n_binds = svm[p].x;
    float *words = (float *)nd;
    for (int k = 0; k < n_binds; k++) {
        int4 b = svm[p + 1 + k];
        if (b.x != node) continue;
        for (int c = 0; c < b.z; c++) {
            float v = stack[b.w + c];
            words[b.y + c] = isfinite(v) ? v : 0.0f;
        }
    }
}
/* The radiance of the world's program at word p along direction d (Cycles' background shader
 * data: P = d, N = Ng = I = -d; export/world.py binds colour x strength as its one input; no
 * object, no mesh attributes) */
inline float3 svm_world(const Scene *scene, int p, float3 d) {
    SvmContext cx = svm_context_base((float2)(0.0f), d, 0u, 0.0f, -d, -d, -d, false);
    cx.generated = d;
    float stack[PPM_SVM_STACK];
    svm_eval(scene, p, stack, &cx);
    float3 L = svm_get3(stack, scene->svm[p + 1].w);
    return (isfinite(L.x) && isfinite(L.y) && isfinite(L.z)) ? L : (float3)(0.0f);
}
#endif
