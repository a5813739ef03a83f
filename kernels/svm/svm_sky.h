#ifndef PPM_SVM_SKY_H
#define PPM_SVM_SKY_H
/* Cycles' Sky Texture (SVM_TEX_SKY; export/sky.py precomputes what Cycles precomputes, learnt
 * from its kernel/svm/sky.h and scene/shader_nodes.cpp SkyTextureNode, written here for OpenCL).
 * Layout: (op, out, vector, SKY_*) + (n, 0, 0, 0) + n words of float parameters:
 *   SKY_PREETHAM:     sun phi, sun theta, zenith Y, x, y (the Perez normalisation folded in),
 *                     then the Perez coefficients A..E of Y, x and y (20 floats);
 *   SKY_HOSEK_WILKIE: sun phi, sun theta, the X, Y, Z radiances, then the 9 distribution
 *                     parameters of X, Y and Z (32 floats);
 *   SKY_SINGLE_SCATTERING (and the multiple scattering sky, which shares it): the sun disc's
 *                     XYZ at its bottom and top edge (6), sun elevation, rotation, angular
 *                     diameter (< 0: no disc), intensity, -(earth intersection angle), the LUT's
 *                     width and height, then its XYZ texels (3 floats each, row 0 at the
 *                     nadir). */
#include "shared.h"
#include "svm/svm_util.h"

/* XYZ (D65) -> scene linear Rec.709: Blender's OCIO config (Cycles' xyz_to_rgb), clamped at 0 */
inline float3 sky_xyz_to_rgb(float3 c) {
    return fmax((float3)(3.2409699f * c.x - 1.5373832f * c.y - 0.4986108f * c.z,
                         -0.9692436f * c.x + 1.8759675f * c.y + 0.0415551f * c.z,
                         0.0556301f * c.x - 0.2039770f * c.y + 1.0569715f * c.z),
                0.0f);
}

/* Hosek & Wilkie, "An Analytic Model for Full Spectral Sky-Dome Radiance" (2012): the
 * distribution of one channel with parameters c[0..8] */
inline float sky_hosek_channel(__global const float *c, float cos_theta, float gamma,
                               float cos_gamma) {
    float mie = (1.0f + cos_gamma * cos_gamma)
                / pow(1.0f + c[8] * c[8] - 2.0f * c[8] * cos_gamma, 1.5f);
    return (1.0f + c[0] * exp(c[1] / (cos_theta + 0.01f)))
           * (c[2] + c[3] * exp(c[4] * gamma) + c[5] * cos_gamma * cos_gamma + c[6] * mie
              + c[7] * sqrt(cos_theta));
}

/* the angle gamma between direction d (theta: its polar angle) and the sun, and the clamped
 * cos theta, as Cycles' Preetham and Hosek-Wilkie skies take them */
inline float sky_sun_angle(float3 d, __global const float *p, float *cos_theta) {
    float theta = acos(clamp(d.z, -1.0f, 1.0f));          /* (Cycles: the vector as given) */
    float phi = 0.5f * PPM_PI - atan2(d.y, d.x);
    float cos_psi = sin(p[1]) * sin(theta) * cos(p[0] - phi) + cos(p[1]) * cos(theta);
    *cos_theta = cos(fmin(theta, 0.5f * PPM_PI - 0.001f));
    return acos(clamp(cos_psi, -1.0f, 1.0f));
}

inline float3 sky_hosek(float3 d, __global const float *p) {
    float ct, gamma = sky_sun_angle(d, p, &ct), cg = cos(gamma);
    float3 xyz = (float3)(p[2] * sky_hosek_channel(p + 5, ct, gamma, cg),
                          p[3] * sky_hosek_channel(p + 14, ct, gamma, cg),
                          p[4] * sky_hosek_channel(p + 23, ct, gamma, cg));
    return sky_xyz_to_rgb(xyz) * (2.0f * PPM_PI / 683.0f);
}

/* Preetham, Shirley & Smits, "A Practical Analytic Model for Daylight" (1999): Perez et al.'s
 * distribution with coefficients p[0..4] */
inline float sky_perez(__global const float *p, float cos_theta, float gamma, float cos_gamma) {
    return (1.0f + p[0] * exp(p[1] / cos_theta))
           * (1.0f + p[2] * exp(p[3] * gamma) + p[4] * cos_gamma * cos_gamma);
}

inline float3 sky_preetham(float3 d, __global const float *p) {
    float ct, gamma = sky_sun_angle(d, p, &ct), cg = cos(gamma);
    float Y = p[2] * sky_perez(p + 5, ct, gamma, cg);
    float x = p[3] * sky_perez(p + 10, ct, gamma, cg);
    float y = p[4] * sky_perez(p + 15, ct, gamma, cg);
    float X = y != 0.0f ? x / y * Y : 0.0f;
    float Z = (y != 0.0f && Y != 0.0f) ? (1.0f - x - y) / y * Y : 0.0f;
    return sky_xyz_to_rgb((float3)(X, Y, Z));
}

/* a texel of the LUT at column i, row j (clamped: Cycles' EXTEND) */
inline float3 sky_texel(__global const float *lut, int w, int h, int i, int j) {
    __global const float *t = lut + 3 * ((size_t)clamp(j, 0, h - 1) * w + clamp(i, 0, w - 1));
    return (float3)(t[0], t[1], t[2]);
}

/* the LUT at (u, v) in [0, 1], bilinear between texel centres (Cycles' Linear) */
inline float3 sky_lut(__global const float *lut, int w, int h, float u, float v) {
    float x = u * (float)w - 0.5f, y = v * (float)h - 0.5f;
    float fx = floor(x), fy = floor(y), ax = x - fx, ay = y - fy;
    int i = (int)fx, j = (int)fy;
    float3 a = mix(sky_texel(lut, w, h, i, j), sky_texel(lut, w, h, i + 1, j), ax);
    float3 b = mix(sky_texel(lut, w, h, i, j + 1), sky_texel(lut, w, h, i + 1, j + 1), ax);
    return mix(a, b, ay);
}

/* Cycles' single-scattering (Nishita) sky: the precomputed LUT and the sun disc */
inline float3 sky_single(float3 d, __global const float *p) {
    float sun_el = p[6], sun_rot = p[7], diameter = p[8], intensity = p[9], earth = p[10];
    int w = (int)p[11], h = (int)p[12];
    float theta = acos(clamp(d.z, -1.0f, 1.0f)), phi = atan2(d.y, d.x);
    float st = sun_el - 0.5f * PPM_PI, sp = sun_rot - 0.5f * PPM_PI;
    float3 sun = (float3)(sin(st) * cos(sp), sin(st) * sin(sp), cos(st));
    float angle = 2.0f * atan2(length(d - sun), length(d + sun));
    float half_d = 0.5f * diameter, el = 0.5f * PPM_PI - theta;
    float3 xyz = (float3)(0.0f);
    if (diameter >= 0.0f && angle < half_d && el > earth) {
        float t = (el - sun_el) / diameter + 0.5f, r = angle / half_d;
        float limb = 1.0f - 0.6f * (1.0f - sqrt(1.0f - r * r));      /* limb darkening */
        float3 lo = (float3)(p[0], p[1], p[2]), hi = (float3)(p[3], p[4], p[5]);
        xyz = (lo + (hi - lo) * t) * intensity * limb;
    }
    float u = (-phi - 0.5f * PPM_PI + sun_rot) * (0.5f / PPM_PI);
    u -= floor(u);
    float v = copysign(sqrt(fabs(el) * (2.0f / PPM_PI)), el) * 0.5f + 0.5f;
    xyz += sky_lut(p + 13, w, h, u, v);
    return sky_xyz_to_rgb(xyz);
}

/* Runs the op whose first word is w and whose parameter count word is at i; returns the index
 * of the next op's word */
inline int svm_sky(int4 w, __global const int4 *svm, int i, float *stack) {
    int n = svm[i].x;
    __global const float *p = (__global const float *)(svm + i + 1);
    float3 d = svm_get3(stack, w.z);
    float3 rgb = w.w == SKY_PREETHAM       ? sky_preetham(d, p)
                 : w.w == SKY_HOSEK_WILKIE ? sky_hosek(d, p)
                                           : sky_single(d, p);
    svm_put3(stack, w.y, rgb);
    return i + 1 + n;
}
#endif
