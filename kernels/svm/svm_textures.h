#ifndef PPM_SVM_TEXTURES_H
#define PPM_SVM_TEXTURES_H
#include "shared.h"
#include "svm/svm_types.h"
#include "svm/svm_util.h"
#include "svm/svm_noise.h"
#include "svm/svm_voronoi.h"

/* Cycles' procedural texture nodes as shader program ops (SVM_TEX_*: svm.h; layouts in
 * ppm_engine/scene/shader_program.py), learnt from its kernel/svm/checker.h, gradient.h,
 * white_noise.h, noisetex.h, magic.h, wave.h and brick.h and written here for OpenCL. */

/* A float input: its stack slot, or (slot -1) the constant whose bits are in `value` */
inline float tex_in(const float *stack, int slot, int value) {
    return slot >= 0 ? stack[slot] : as_float(value);
}

inline float4 tex_in4(const float *stack, int4 slots, int4 values) {
    return (float4)(tex_in(stack, slots.x, values.x), tex_in(stack, slots.y, values.y),
                    tex_in(stack, slots.z, values.z), tex_in(stack, slots.w, values.w));
}

inline void tex_out(float *stack, int slot, float v) {
    if (slot >= 0) stack[slot] = v;
}
inline void tex_out3(float *stack, int slot, float3 v) {
    if (slot >= 0) svm_put3(stack, slot, v);
}

/* Checker: 1 on the cells whose integer coordinates' parities agree, else 0 */
inline float tex_checker(float3 p) {
    p = (p + 0.000001f) * 0.999999f;         /* off the cell borders of unit coordinates */
    int xi = abs((int)floor(p.x)), yi = abs((int)floor(p.y)), zi = abs((int)floor(p.z));
    return ((xi % 2 == yi % 2) == (zi % 2)) ? 1.0f : 0.0f;
}

/* Gradient (GRADIENT_*), unclamped */
inline float tex_gradient(float3 p, int type) {
    switch (type) {
    case GRADIENT_LINEAR: return p.x;
    case GRADIENT_QUADRATIC: {
        float r = fmax(p.x, 0.0f);
        return r * r;
    }
    case GRADIENT_EASING: {
        float r = clamp(p.x, 0.0f, 1.0f), t = r * r;
        return 3.0f * t - 2.0f * t * r;
    }
    case GRADIENT_DIAGONAL: return (p.x + p.y) * 0.5f;
    case GRADIENT_RADIAL: return atan2(p.y, p.x) / (2.0f * M_PI_F) + 0.5f;
    default: {                             /* GRADIENT_QUADRATIC_SPHERE, GRADIENT_SPHERICAL */
        float r = fmax(0.999999f - sqrt(dot(p, p)), 0.0f);
        return type == GRADIENT_QUADRATIC_SPHERE ? r * r : r;
    }
    }
}

/* Magic: sines and cosines folded `depth` times */
inline float3 tex_magic(float3 p, float scale, int depth, float dist) {
    const float twopi = 2.0f * M_PI_F;
    float px = fmod(p.x, twopi), py = fmod(p.y, twopi), pz = fmod(p.z, twopi);
    float x = sin((px + py + pz) * 5.0f * scale);
    float y = cos((-px + py - pz) * 5.0f * scale);
    float z = -cos((-px - py + pz) * 5.0f * scale);
    if (depth > 0) {
        x *= dist;
        y *= dist;
        z *= dist;
        y = -cos(x - y + z) * dist;
        if (depth > 1) x = cos(x - y - z) * dist;
        if (depth > 2) z = sin(-x - y - z) * dist;
        if (depth > 3) x = -cos(-x + y - z) * dist;
        if (depth > 4) y = -sin(-x + y + z) * dist;
        if (depth > 5) y = -cos(-x + y + z) * dist;
        if (depth > 6) x = cos(x + y + z) * dist;
        if (depth > 7) z = sin(x + y - z) * dist;
        if (depth > 8) x = -cos(-x - y + z) * dist;
        if (depth > 9) y = -sin(x - y + z) * dist;
    }
    if (dist != 0.0f) {
        dist *= 2.0f;
        x /= dist;
        y /= dist;
        z /= dist;
    }
    return (float3)(0.5f - x, 0.5f - y, 0.5f - z);
}

/* Wave: bands or rings, distorted by fBm noise; opt = (WAVE_TYPE_*, WAVE_BANDS_*,
 * WAVE_RINGS_*, WAVE_PROFILE_*) */
inline float tex_wave(int4 opt, float3 p, float dist, float detail, float dscale, float drough,
                      float phase) {
    p = (p + 0.000001f) * 0.999999f;
    float n;
    if (opt.x == WAVE_TYPE_BANDS) {
        n = opt.y == WAVE_BANDS_X   ? p.x * 20.0f
            : opt.y == WAVE_BANDS_Y ? p.y * 20.0f
            : opt.y == WAVE_BANDS_Z ? p.z * 20.0f
                                    : (p.x + p.y + p.z) * 10.0f;
    } else {
        float3 r = p;
        if (opt.z == WAVE_RINGS_X) r.x = 0.0f;
        else if (opt.z == WAVE_RINGS_Y) r.y = 0.0f;
        else if (opt.z == WAVE_RINGS_Z) r.z = 0.0f;
        n = sqrt(dot(r, r)) * 20.0f;
    }
    n += phase;
    if (dist != 0.0f) {
        float4 q = (float4)(p * dscale, 0.0f);
        detail = fmin(detail, 15.0f);        /* (Cycles' bound for every other detail) */
        n += dist * (tex_fbm(3, q, detail, drough, 2.0f, true) * 2.0f - 1.0f);
    }
    if (opt.w == WAVE_PROFILE_SIN) return 0.5f + 0.5f * sin(n - M_PI_2_F);
    n /= 2.0f * M_PI_F;
    if (opt.w == WAVE_PROFILE_SAW) return n - floor(n);
    return fabs(n - floor(n + 0.5f)) * 2.0f;
}

/* Brick: (tint, mortar) at p */
inline float tex_brick_noise(uint n) {
    n = (n + 1013u) & 0x7fffffffu;
    n = (n >> 13) ^ n;
    uint nn = (n * (n * n * 60493u + 19990303u) + 1376312589u) & 0x7fffffffu;
    return 0.5f * ((float)nn / 1073741824.0f);
}

inline float2 tex_brick(float3 p, float4 f, float width, float height, int4 opt) {
    float msize = f.y, msmooth = f.z, bias = f.w, offset = 0.0f;
    float offset_amount = as_float(opt.z), squash = as_float(opt.w);
    int row = (int)floor(p.y / height);
    if (opt.x && opt.y) {
        width *= (row % opt.y) ? 1.0f : squash;
        offset = (row % opt.x) ? 0.0f : width * offset_amount;
    }
    int brick = (int)floor((p.x + offset) / width);
    float x = (p.x + offset) - width * brick, y = p.y - height * row;
    float tint = clamp(tex_brick_noise(((uint)row << 16) + (uint)(brick & 0xffff)) + bias, 0.0f,
                       1.0f);
    float d = fmin(fmin(x, y), fmin(width - x, height - y)), mortar;
    if (d >= msize) {
        mortar = 0.0f;
    } else if (msmooth == 0.0f) {
        mortar = 1.0f;
    } else {
        d = (1.0f - d / msize) / msmooth;
        float dd = d * d;
        mortar = d <= 0.0f ? 0.0f : d >= 1.0f ? 1.0f : 3.0f * dd - 2.0f * dd * d;
    }
    return (float2)(tint, mortar);
}

/* The Noise Texture: p holds (x, y, z, w) already scaled */
inline float tex_noise(int dim, int type, float4 p, float4 a, float4 b, bool normalize,
                       float3 *color, bool want_color) {
    float detail = clamp(a.z, 0.0f, 15.0f), rough = fmax(a.w, 0.0f);
    float lacun = b.x, offset = b.y, gain = b.z, dist = b.w;
    if (dist != 0.0f) {
        float4 d = (float4)(0.0f);
        d.x = tex_snoise(dim, p + tex_seed_offset(dim, 0.0f)) * dist;
        if (dim >= 2) d.y = tex_snoise(dim, p + tex_seed_offset(dim, 1.0f)) * dist;
        if (dim >= 3) d.z = tex_snoise(dim, p + tex_seed_offset(dim, 2.0f)) * dist;
        if (dim >= 4) d.w = tex_snoise(dim, p + tex_seed_offset(dim, 3.0f)) * dist;
        p += d;
    }
    float value = tex_noise_select(dim, type, p, detail, rough, lacun, offset, gain, normalize);
    if (want_color) {
        float seed = (float)dim;                  /* the seeds after the distortion's */
        *color = (float3)(value,
                          tex_noise_select(dim, type, p + tex_seed_offset(dim, seed), detail, rough,
                                           lacun, offset, gain, normalize),
                          tex_noise_select(dim, type, p + tex_seed_offset(dim, seed + 1.0f), detail,
                                           rough, lacun, offset, gain, normalize));
    }
    return value;
}

/* Runs texture op `op` whose first word is w and whose parameters start at word i; returns
 * the index of the next op's word */
inline int svm_texture(int op, int4 w, __global const int4 *svm, int i, float *stack) {
    float3 co = w.w >= 0 ? svm_get3(stack, w.w) : (float3)(0.0f);   /* -1: no vector (1D) */
    if (SVM_HAS(SVM_TEX_CHECKER) && op == SVM_TEX_CHECKER) {
        int4 e = svm[i];
        float f = tex_checker(co * tex_in(stack, e.z, e.w));
        tex_out3(stack, w.y, svm_get3(stack, f == 1.0f ? e.x : e.y));
        tex_out(stack, w.z, f);
        return i + 1;
    }
    if (SVM_HAS(SVM_TEX_GRADIENT) && op == SVM_TEX_GRADIENT) {
        float f = clamp(tex_gradient(co, svm[i].x), 0.0f, 1.0f);
        tex_out3(stack, w.y, (float3)(f));
        tex_out(stack, w.z, f);
        return i + 1;
    }
    if (SVM_HAS(SVM_TEX_WHITE_NOISE) && op == SVM_TEX_WHITE_NOISE) {
        int4 e = svm[i];
        int dim = e.x;
        float wv = tex_in(stack, e.y, e.z);
        float4 k = dim == 1   ? (float4)(wv, 0.0f, 0.0f, 0.0f)
                   : dim == 2 ? (float4)(co.xy, 0.0f, 0.0f)
                              : (float4)(co, dim == 4 ? wv : 0.0f);
        tex_out(stack, w.y, tex_hashf(dim, k));
        if (w.z >= 0) svm_put3(stack, w.z, tex_hashf3(dim, k));
        return i + 1;
    }
    if (SVM_HAS(SVM_TEX_NOISE) && op == SVM_TEX_NOISE) {
        float4 a = tex_in4(stack, svm[i], svm[i + 2]), b = tex_in4(stack, svm[i + 1], svm[i + 3]);
        int4 opt = svm[i + 4];
        int dim = opt.x;
        float3 v = co * a.y;
        float wv = a.x * a.y;
        float4 p = dim == 1   ? (float4)(wv, 0.0f, 0.0f, 0.0f)
                   : dim == 2 ? (float4)(v.xy, 0.0f, 0.0f)
                              : (float4)(v, dim == 4 ? wv : 0.0f);
        float3 color;
        float f = tex_noise(dim, opt.y, p, a, b, opt.z != 0, &color, w.z >= 0);
        tex_out(stack, w.y, f);
        tex_out3(stack, w.z, color);
        return i + 5;
    }
    if (SVM_HAS(SVM_TEX_MAGIC) && op == SVM_TEX_MAGIC) {
        float4 a = tex_in4(stack, svm[i], svm[i + 1]);
        float3 c = tex_magic(co, a.x, svm[i + 2].x, a.y);
        tex_out3(stack, w.y, c);
        tex_out(stack, w.z, (c.x + c.y + c.z) * (1.0f / 3.0f));
        return i + 3;
    }
    if (SVM_HAS(SVM_TEX_WAVE) && op == SVM_TEX_WAVE) {
        float4 a = tex_in4(stack, svm[i], svm[i + 2]), b = tex_in4(stack, svm[i + 1], svm[i + 3]);
        float f = tex_wave(svm[i + 4], co * a.x, a.y, a.z, a.w, b.x, b.y);
        tex_out3(stack, w.y, (float3)(f));
        tex_out(stack, w.z, f);
        return i + 5;
    }
    if (SVM_HAS(SVM_TEX_BRICK) && op == SVM_TEX_BRICK) {
        float4 a = tex_in4(stack, svm[i], svm[i + 2]), b = tex_in4(stack, svm[i + 1], svm[i + 3]);
        int4 cols = svm[i + 4];
        float2 tm = tex_brick(co * a.x, a, b.x, b.y, svm[i + 5]);
        float3 c1 = svm_get3(stack, cols.x);
        if (tm.y != 1.0f) c1 = (1.0f - tm.x) * c1 + tm.x * svm_get3(stack, cols.y);
        tex_out3(stack, w.y, c1 * (1.0f - tm.y) + svm_get3(stack, cols.z) * tm.y);
        tex_out(stack, w.z, tm.y);
        return i + 6;
    }
    if (SVM_HAS(SVM_TEX_VORONOI) && op == SVM_TEX_VORONOI) {
        float4 a = tex_in4(stack, svm[i], svm[i + 2]), b = tex_in4(stack, svm[i + 1], svm[i + 3]);
        int4 opt = svm[i + 4], outs = svm[i + 5];
        TexVoronoi v = {a.y, a.z, a.w, b.x, b.y, b.z, b.w, 0.0f, opt.x, opt.y, opt.z, opt.w};
        float4 p = (float4)(co, a.x);
        if (opt.x == 1) p = (float4)(a.x, 0.0f, 0.0f, 0.0f);
        float dist, wo, radius;
        float3 color, pos;
        tex_voronoi(v, p, &dist, &color, &pos, &wo, &radius);
        tex_out(stack, w.y, dist);
        tex_out3(stack, w.z, color);
        tex_out3(stack, outs.x, pos);
        tex_out(stack, outs.y, wo);
        tex_out(stack, outs.z, radius);
        return i + 6;
    }
    return -1;                                   /* an op this build lacks */
}
#endif
