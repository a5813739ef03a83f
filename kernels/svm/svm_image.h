#ifndef PPM_SVM_IMAGE_H
#define PPM_SVM_IMAGE_H
/* The Image Texture and Environment Texture nodes of a shader program (kernels/svm/svm.h runs
 * them; ppm_engine/scene/shader_program.py SVM_IMAGE has the layout, export/shader_images.py
 * compiles them).  The projections and the UDIM tile choice are Cycles' (learnt from its
 * kernel/svm/image.h, util/math.h and kernel/camera/projection.h: map_to_sphere, map_to_tube,
 * the box's blend zones, the mirror ball); IMAGE_* (shared.h) the projection. */
#include "shared.h"
#include "svm/textures.h"
#include "svm/svm_util.h"

/* texture tex (1-based; 0: an image that could not be read, or a UDIM tile that does not
 * exist: Cycles' magenta) at uv.  Texels hold colours times alpha (associated, as Cycles
 * stores them): Cycles' Color output as is, or divided by the alpha where the node's Alpha
 * output is linked (unassociate); then an 8-bit sRGB image's colour decoded. */
inline float4 svm_image_lookup(const Scene *scene, int tex, float2 uv, int unassociate) {
    if (tex <= 0) return (float4)(1.0f, 0.0f, 1.0f, 1.0f);
    float4 c = texture_rgba_encoded(scene, tex, uv);
    if (unassociate && c.w != 0.0f && c.w != 1.0f) c.xyz /= c.w;
    if (scene->textures[tex - 1].flags & TEX_FLAG_SRGB) c.xyz = srgb_to_linear(c.xyz);
    return c;
}

/* the sphere and tube projections of a point of the [0, 1] box (recentred to [-1, 1]) */
inline float2 image_sphere_uv(float3 co) {
    co = 2.0f * co - 1.0f;
    float l = dot(co, co);
    if (!(l > 0.0f)) return (float2)(0.0f);
    float u = (co.x == 0.0f && co.y == 0.0f) ? 0.0f : 0.5f - atan2(co.x, co.y) * (0.5f / PPM_PI);
    return (float2)(u, 1.0f - acos(clamp(co.z / sqrt(l), -1.0f, 1.0f)) * (1.0f / PPM_PI));
}
inline float2 image_tube_uv(float3 co) {
    co = 2.0f * co - 1.0f;
    float r = sqrt(co.x * co.x + co.y * co.y);
    if (!(r > 0.0f)) return (float2)(0.0f);
    return (float2)(0.5f - 0.5f * atan2(co.x / r, co.y / r) * (1.0f / PPM_PI),
                    0.5f * (co.z + 1.0f));
}

/* the mirror ball (Cycles' direction_to_mirrorball): the ball's normal halfway between the
 * direction d and the view along -y, its x and z as the image's u and v */
inline float2 image_mirror_ball_uv(float3 d) {
    float3 h = d - (float3)(0.0f, 1.0f, 0.0f);
    float l = length(h);
    if (l > 0.0f) h /= l;
    return (float2)(0.5f * (h.x + 1.0f), 0.5f * (h.z + 1.0f));
}

/* the weights of the box's three planar projections (x, y, z faces) for object-space normal N
 * and Projection Blend b: one face where a component dominates by the factor 1 + b, else a
 * blend of two faces across the edge between them, or of all three near the corner */
inline float3 image_box_weights(float3 N, float b) {
    float3 a = fabs(N);
    float s = a.x + a.y + a.z;
    if (!(s > 0.0f)) return (float3)(1.0f, 0.0f, 0.0f);
    a /= s;
    float k = 0.5f * (1.0f + b), lo = 1.0f - k, off = 0.5f * (1.0f - b);
    if (a.x > k * (a.x + a.y) && a.x > k * (a.x + a.z)) return (float3)(1.0f, 0.0f, 0.0f);
    if (a.y > k * (a.x + a.y) && a.y > k * (a.y + a.z)) return (float3)(0.0f, 1.0f, 0.0f);
    if (a.z > k * (a.x + a.z) && a.z > k * (a.y + a.z)) return (float3)(0.0f, 0.0f, 1.0f);
    if (!(b > 0.0f)) return (float3)(1.0f, 0.0f, 0.0f);        /* no face fits: the x face */
    if (a.z < lo * (a.x + a.y)) {                               /* the x-y edge */
        float t = clamp((a.x / (a.x + a.y) - off) / b, 0.0f, 1.0f);
        return (float3)(t, 1.0f - t, 0.0f);
    }
    if (a.x < lo * (a.y + a.z)) {                               /* y-z */
        float t = clamp((a.y / (a.y + a.z) - off) / b, 0.0f, 1.0f);
        return (float3)(0.0f, t, 1.0f - t);
    }
    if (a.y < lo * (a.x + a.z)) {                               /* x-z */
        float t = clamp((a.x / (a.x + a.z) - off) / b, 0.0f, 1.0f);
        return (float3)(t, 0.0f, 1.0f - t);
    }
    return ((2.0f - k) * a + (k - 1.0f)) / (2.0f * k - 1.0f);  /* the corner: all three */
}

/* SVM_IMAGE: w = (op, colour slot, alpha slot, vector slot), then (texture, unassociate,
 * projection, tile words), (blend bits, normal slot, 0, 0) and the UDIM tiles two a word
 * (tile, texture, tile, texture); returns the next op's word */
inline int svm_image(const Scene *scene, int4 w, int i, float *stack) {
    __global const int4 *svm = scene->svm;
    int4 e = svm[i], f = svm[i + 1];
    int next = i + 2 + e.w;
    float4 c = (float4)(1.0f);
#if PPM_TEXTURES
    float3 co = svm_get3(stack, w.w);
    int tex = e.x;
    if (e.z == IMAGE_BOX) {
        float3 N = svm_get3(stack, f.y);
        float3 wt = image_box_weights(N, as_float(f.x));
        c = (float4)(0.0f);
        if (wt.x > 0.0f)
            c += wt.x
                 * svm_image_lookup(scene, tex, (float2)(N.x < 0.0f ? 1.0f - co.y : co.y, co.z),
                                    e.y);
        if (wt.y > 0.0f)
            c += wt.y
                 * svm_image_lookup(scene, tex, (float2)(N.y > 0.0f ? 1.0f - co.x : co.x, co.z),
                                    e.y);
        if (wt.z > 0.0f)
            c += wt.z
                 * svm_image_lookup(scene, tex, (float2)(N.z > 0.0f ? 1.0f - co.y : co.y, co.x),
                                    e.y);
    } else {
        float2 uv = e.z == IMAGE_EQUIRECTANGULAR ? direction_to_equirect(svm_safe_normalize(co))
                    : e.z == IMAGE_MIRROR_BALL   ? image_mirror_ball_uv(svm_safe_normalize(co))
                    : e.z == IMAGE_SPHERE        ? image_sphere_uv(co)
                    : e.z == IMAGE_TUBE          ? image_tube_uv(co)
                                                 : co.xy;
        if (e.w > 0) {                  /* UDIM: the tile 1001 + u + 10 v, uv within it */
            tex = 0;
            float u = isfinite(uv.x) ? clamp(uv.x, -1.0f, 16.0f) : -1.0f;
            float v = isfinite(uv.y) ? clamp(uv.y, -1.0f, 1.0e6f) : -1.0f;
            int tx = (int)u, ty = (int)v;        /* truncated, as Cycles: (-1, 0) is tile 1001 */
            if (tx >= 0 && ty >= 0 && tx < 10) {
                int tile = 1001 + 10 * ty + tx;
                for (int k = i + 2; k < next; k++) {
                    int4 t = svm[k];
                    if (t.x == tile || t.z == tile) {
                        tex = t.x == tile ? t.y : t.w;
                        uv -= (float2)((float)tx, (float)ty);
                        break;
                    }
                }
            }
        }
        c = svm_image_lookup(scene, tex, uv, e.y);
    }
#endif
    svm_put3(stack, w.y, c.xyz);
    stack[w.z] = c.w;
    return next;
}
#endif
