#ifndef PPM_TEXTURES_H
#define PPM_TEXTURES_H
#include "scene.h"

/* Image textures (ppm_engine/blender/export/textures.py): texels of all textures one after another
 * as half4 linear RGBA, rows bottom-up (v = 0 is the first row); UVs per triangle corner.  The
 * lookups compile to a constant 1 when no material of the scene has a texture (PPM_TEXTURES).
 * The Texture struct and the TEX_* codes are shared.h's. */

inline float3 srgb_to_linear(float3 c) {
    c = clamp(c, 0.0f, 1.0f);
    return select(pow((c + 0.055f) * (1.0f / 1.055f), (float3)(2.4f)), c * (1.0f / 12.92f),
                  islessequal(c, (float3)(0.04045f)));
}

/* texel column/row for an integer coordinate under the extension mode; -1 outside (CLIP) */
inline int tex_wrap(int i, int n, uint mode) {
    if (mode == TEX_EXTEND) return clamp(i, 0, n - 1);
    if (mode == TEX_CLIP) return (i < 0 || i >= n) ? -1 : i;
    if (mode == TEX_MIRROR) {
        int m = i % (2 * n);
        m = m < 0 ? m + 2 * n : m;
        return m < n ? m : 2 * n - 1 - m;
    }
    int m = i % n;
    return m < 0 ? m + n : m;
}

inline float4 tex_fetch(__global const half *texels, const Texture *t, int x, int y) {
    int ix = tex_wrap(x, t->width, t->flags & 15u), iy = tex_wrap(y, t->height, t->flags & 15u);
    if (ix < 0 || iy < 0) return (float4)(0.0f);
    return vload_half4((size_t)t->offset + (size_t)iy * (size_t)t->width + (size_t)ix, texels);
}

/* the uniform cubic B-spline's four weights for the texels at i - 1 .. i + 2 of a point a
 * fraction t past texel centre i (Cycles' cubic interpolation: the B-spline, not Catmull-Rom;
 * non-negative, summing to 1) */
inline float4 tex_bspline(float t) {
    float s = 1.0f - t, t2 = t * t, t3 = t2 * t;
    return (float4)(s * s * s, 3.0f * t3 - 6.0f * t2 + 4.0f,
                    -3.0f * t3 + 3.0f * t2 + 3.0f * t + 1.0f, t3)
           * (1.0f / 6.0f);
}

inline float4 tex_row4(__global const half *texels, const Texture *t, int x0, int y, float4 w) {
    return w.x * tex_fetch(texels, t, x0 - 1, y) + w.y * tex_fetch(texels, t, x0, y)
           + w.z * tex_fetch(texels, t, x0 + 1, y) + w.w * tex_fetch(texels, t, x0 + 2, y);
}

/* RGBA of texture tex1 (1-based) at uv as stored (sRGB-encoded colour for TEX_FLAG_SRGB):
 * bilinear between texel centres (as Cycles' 'Linear' interpolation), the nearest texel
 * ('Closest') or the bicubic B-spline over 4 x 4 texels ('Cubic', 'Smart'), each texel read
 * through the extension mode (CLIP: 0 outside) */
inline float4 texture_rgba_encoded(const Scene *scene, int tex1, float2 uv) {
    __global const half *texels = scene->texels;
    Texture t = scene->textures[tex1 - 1];
    float x = uv.x * (float)t.width, y = uv.y * (float)t.height;
    x = isfinite(x) ? clamp(x, -1.0e9f, 1.0e9f) : 0.0f;     /* int conversions stay defined */
    y = isfinite(y) ? clamp(y, -1.0e9f, 1.0e9f) : 0.0f;
    if (t.flags & TEX_FLAG_CLOSEST) return tex_fetch(texels, &t, (int)floor(x), (int)floor(y));
    x -= 0.5f;
    y -= 0.5f;
    float fx = floor(x), fy = floor(y), ax = x - fx, ay = y - fy;
    int x0 = (int)fx, y0 = (int)fy;
    if (t.flags & TEX_FLAG_CUBIC) {
        float4 wx = tex_bspline(ax), wy = tex_bspline(ay);
        return wy.x * tex_row4(texels, &t, x0, y0 - 1, wx) + wy.y * tex_row4(texels, &t, x0, y0, wx)
               + wy.z * tex_row4(texels, &t, x0, y0 + 1, wx)
               + wy.w * tex_row4(texels, &t, x0, y0 + 2, wx);
    }
    float4 a = mix(tex_fetch(texels, &t, x0, y0), tex_fetch(texels, &t, x0 + 1, y0), ax);
    float4 b = mix(tex_fetch(texels, &t, x0, y0 + 1), tex_fetch(texels, &t, x0 + 1, y0 + 1), ax);
    return mix(a, b, ay);
}

/* linear RGB and alpha: sRGB texels decoded after the interpolation, as Cycles does for 8-bit
 * sRGB images */
inline float4 texture_rgba(const Scene *scene, int tex1, float2 uv) {
    float4 c = texture_rgba_encoded(scene, tex1, uv);
    if (scene->textures[tex1 - 1].flags & TEX_FLAG_SRGB) c.xyz = srgb_to_linear(c.xyz);
    return c;
}
inline float3 texture_rgb(const Scene *scene, int tex1, float2 uv) {
    return texture_rgba(scene, tex1, uv).xyz;
}

/* UV at barycentrics (u, v) of original triangle tri (p = p0 + u (p1 - p0) + v (p2 - p0)) */
inline float2 surface_uv(__global const float *uvs, uint tri, float u, float v) {
    __global const float *a = uvs + 6 * (size_t)tri;
    float w = 1.0f - u - v;
    return (float2)(w * a[0] + u * a[2] + v * a[4], w * a[1] + u * a[3] + v * a[5]);
}

/* the factor a texture tex1 (a BSDF node's colour or emission texture) puts on its input at a
 * surface point: the texture at the point's UV, 1 without a texture */
inline float3 texture_tint(const Scene *scene, int tex1, uint tri, float u, float v) {
#if PPM_TEXTURES
    if (tex1 > 0) return texture_rgb(scene, tex1, surface_uv(scene->uvs, tri, u, v));
#endif
    return (float3)(1.0f);
}

/* the alpha channel of texture tex1 at a surface point (an Image Texture's Alpha output on a
 * BSDF's Alpha input), 1 without a texture */
inline float texture_alpha(const Scene *scene, int tex1, uint tri, float u, float v) {
#if PPM_TEXTURES
    if (tex1 > 0)
        return clamp(texture_rgba(scene, tex1, surface_uv(scene->uvs, tri, u, v)).w, 0.0f, 1.0f);
#endif
    return 1.0f;
}
#endif
