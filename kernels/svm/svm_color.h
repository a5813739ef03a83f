#ifndef PPM_SVM_COLOR_H
#define PPM_SVM_COLOR_H

/* The Blackbody and Wavelength nodes as Cycles evaluates them (learnt from its kernel/svm
 * blackbody.h, wavelength.h and math_util.h).  Their tables (Cycles' blackbody fit, the CIE 1931
 * colour matching functions, the XYZ to Rec.709 matrix) are written once in
 * ppm_engine/scene/spectra.py, which folds constant inputs at export with the same arithmetic, and
 * generated from there into shared_color.h. */
#include "shared_color.h"

/* Blackbody node: temperature t (K) -> linear Rec.709 (Blender's default scene space),
 * negative components clamped to 0 */
inline float3 svm_blackbody(float t) {
    float3 c;
    if (t >= 12000.0f) {
        c = (float3)(BLACKBODY_ABOVE[0], BLACKBODY_ABOVE[1], BLACKBODY_ABOVE[2]);
    } else if (t < 800.0f) {
        c = (float3)(BLACKBODY_BELOW[0], BLACKBODY_BELOW[1], BLACKBODY_BELOW[2]);
    } else {
        int i = 0;
        for (int k = 1; k < BLACKBODY_INTERVALS; k++)
            if (t >= BLACKBODY_FROM[k]) i = k;
        __constant const float *f = BLACKBODY_FIT + 10 * i;
        float inv = 1.0f / t;
        c = (float3)(f[0] * inv + f[1] * t + f[2], f[3] * inv + f[4] * t + f[5],
                     ((f[6] * t + f[7]) * t + f[8]) * t + f[9]);
    }
    return fmax(c, (float3)(0.0f));
}

/* Wavelength node: lambda (nm) -> the colour matching functions interpolated linearly between
 * the 5 nm entries (as Cycles: the entry index truncated towards zero, so that 375-380 nm
 * extrapolates the first step; 0 from 780 nm on and below 375 nm), to linear Rec.709, scaled
 * by Cycles' 1 / 2.52, negative components clamped to 0 */
inline float3 svm_wavelength(float lambda) {
    float x = (lambda - 380.0f) * 0.2f;
    if (!(x > -1.0f && x < 80.0f)) return (float3)(0.0f);
    int i = (int)x;                       /* truncation: -1 < x < 0 gives entry 0 */
    float t = x - (float)i;
    __constant const float *a = CIE_1931 + 3 * i;
    float3 xyz = mix((float3)(a[0], a[1], a[2]), (float3)(a[3], a[4], a[5]), t);
    float3 c = (float3)(dot(XYZ_TO_REC709_R, xyz), dot(XYZ_TO_REC709_G, xyz),
                        dot(XYZ_TO_REC709_B, xyz))
               * (1.0f / 2.52f);
    return fmax(c, (float3)(0.0f));
}
#endif
