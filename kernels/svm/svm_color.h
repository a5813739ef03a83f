#ifndef PPM_SVM_COLOR_H
#define PPM_SVM_COLOR_H

/* The Blackbody and Wavelength nodes as Cycles evaluates them (learnt from its kernel/svm
 * blackbody.h, wavelength.h and math_util.h; the tables below are data, read also by
 * ppm_engine/scene/spectra.py to fold constant inputs at export, so they live only here). */

/* Cycles' Blackbody fit: the colour of a black body at T kelvin in linear Rec.709 with
 * luminance 1 (Planck's law through the CIE 1931 observer), fitted piecewise by
 * r, g = a / T + b T + c and b = ((a T + b) T + c) T + d on seven intervals of [800, 12000) K;
 * constant outside.  Its coefficients are Cycles' own (kernel/tables.h, Apache-2.0): the colour
 * computed here from first principles (5 nm CIE data) differs from the fit by up to 1.2e-3,
 * and Cycles renders the fit.  Rows: r (a, b, c), g (a, b, c), b (a, b, c, d). */
#define BLACKBODY_INTERVALS 7
/* clang-format off */
__constant float BLACKBODY_FROM[BLACKBODY_INTERVALS] = {
    800.0f, 965.0f, 1167.0f, 1449.0f, 1902.0f, 3315.0f, 6365.0f};
__constant float BLACKBODY_FIT[BLACKBODY_INTERVALS * 10] = {
    /* from 800 K */
    1.61919106e+03f, -2.05010916e-03f, 5.02995757e+00f,
    -4.88999748e+02f, 6.04330754e-04f, -7.55807526e-02f,
    5.96945309e-11f, -4.85742887e-08f, -9.70622247e-05f, -4.07936148e-03f,
    /* from 965 K */
    2.48845471e+03f, -1.11330907e-03f, 3.22621544e+00f,
    -7.55994277e+02f, 3.16730098e-04f, 4.78306139e-01f,
    2.40430366e-11f, 5.55021075e-08f, -1.98503712e-04f, 2.89312858e-02f,
    /* from 1167 K */
    3.34143193e+03f, -4.86551192e-04f, 1.76486769e+00f,
    -1.02363977e+03f, 1.20223470e-04f, 9.36662319e-01f,
    -1.40949732e-11f, 1.89878968e-07f, -3.56632824e-04f, 9.10767778e-02f,
    /* from 1449 K */
    4.09461742e+03f, -1.27446582e-04f, 7.25731635e-01f,
    -1.26571316e+03f, 4.87340896e-06f, 1.27054498e+00f,
    -3.61460868e-11f, 2.84822009e-07f, -4.93211319e-04f, 1.56723440e-01f,
    /* from 1902 K */
    4.67028036e+03f, 2.91258199e-05f, 1.26703442e-01f,
    -1.42529332e+03f, -4.01150431e-05f, 1.43972784e+00f,
    -1.97075738e-11f, 1.75359352e-07f, -2.50542825e-04f, -2.22783266e-02f,
    /* from 3315 K */
    4.59509185e+03f, 2.87495649e-05f, 1.50345020e-01f,
    -1.17554822e+03f, -2.16378048e-05f, 1.30408023e+00f,
    -1.61997957e-13f, -1.64216008e-08f, 3.86216271e-04f, -7.38077418e-01f,
    /* from 6365 K */
    3.78717450e+03f, 9.35907826e-06f, 3.99075871e-01f,
    -5.00799571e+02f, -4.59832026e-06f, 1.09098763e+00f,
    6.72650283e-13f, -2.73078809e-08f, 4.24098264e-04f, -7.52335691e-01f};
__constant float BLACKBODY_BELOW[3] = {5.413294490189271f, -0.20319390035873933f,
                                       -0.0822535242887164f};      /* T < 800 K */
__constant float BLACKBODY_ABOVE[3] = {0.8262954810464208f, 0.9945080501520986f,
                                       1.566307710274283f};        /* T >= 12000 K */

/* The CIE 1931 2-degree standard observer's colour matching functions x, y, z from 380 to
 * 780 nm in 5 nm steps, to four decimals (CIE 15 / ISO 11664-1 tabulated data, as Cycles'
 * table holds them). */
__constant float CIE_1931[81 * 3] = {
    /* 380 */ 0.0014f, 0.0000f, 0.0065f, 0.0022f, 0.0001f, 0.0105f, 0.0042f, 0.0001f, 0.0201f,
    /* 395 */ 0.0076f, 0.0002f, 0.0362f, 0.0143f, 0.0004f, 0.0679f, 0.0232f, 0.0006f, 0.1102f,
    /* 410 */ 0.0435f, 0.0012f, 0.2074f, 0.0776f, 0.0022f, 0.3713f, 0.1344f, 0.0040f, 0.6456f,
    /* 425 */ 0.2148f, 0.0073f, 1.0391f, 0.2839f, 0.0116f, 1.3856f, 0.3285f, 0.0168f, 1.6230f,
    /* 440 */ 0.3483f, 0.0230f, 1.7471f, 0.3481f, 0.0298f, 1.7826f, 0.3362f, 0.0380f, 1.7721f,
    /* 455 */ 0.3187f, 0.0480f, 1.7441f, 0.2908f, 0.0600f, 1.6692f, 0.2511f, 0.0739f, 1.5281f,
    /* 470 */ 0.1954f, 0.0910f, 1.2876f, 0.1421f, 0.1126f, 1.0419f, 0.0956f, 0.1390f, 0.8130f,
    /* 485 */ 0.0580f, 0.1693f, 0.6162f, 0.0320f, 0.2080f, 0.4652f, 0.0147f, 0.2586f, 0.3533f,
    /* 500 */ 0.0049f, 0.3230f, 0.2720f, 0.0024f, 0.4073f, 0.2123f, 0.0093f, 0.5030f, 0.1582f,
    /* 515 */ 0.0291f, 0.6082f, 0.1117f, 0.0633f, 0.7100f, 0.0782f, 0.1096f, 0.7932f, 0.0573f,
    /* 530 */ 0.1655f, 0.8620f, 0.0422f, 0.2257f, 0.9149f, 0.0298f, 0.2904f, 0.9540f, 0.0203f,
    /* 545 */ 0.3597f, 0.9803f, 0.0134f, 0.4334f, 0.9950f, 0.0087f, 0.5121f, 1.0000f, 0.0057f,
    /* 560 */ 0.5945f, 0.9950f, 0.0039f, 0.6784f, 0.9786f, 0.0027f, 0.7621f, 0.9520f, 0.0021f,
    /* 575 */ 0.8425f, 0.9154f, 0.0018f, 0.9163f, 0.8700f, 0.0017f, 0.9786f, 0.8163f, 0.0014f,
    /* 590 */ 1.0263f, 0.7570f, 0.0011f, 1.0567f, 0.6949f, 0.0010f, 1.0622f, 0.6310f, 0.0008f,
    /* 605 */ 1.0456f, 0.5668f, 0.0006f, 1.0026f, 0.5030f, 0.0003f, 0.9384f, 0.4412f, 0.0002f,
    /* 620 */ 0.8544f, 0.3810f, 0.0002f, 0.7514f, 0.3210f, 0.0001f, 0.6424f, 0.2650f, 0.0000f,
    /* 635 */ 0.5419f, 0.2170f, 0.0000f, 0.4479f, 0.1750f, 0.0000f, 0.3608f, 0.1382f, 0.0000f,
    /* 650 */ 0.2835f, 0.1070f, 0.0000f, 0.2187f, 0.0816f, 0.0000f, 0.1649f, 0.0610f, 0.0000f,
    /* 665 */ 0.1212f, 0.0446f, 0.0000f, 0.0874f, 0.0320f, 0.0000f, 0.0636f, 0.0232f, 0.0000f,
    /* 680 */ 0.0468f, 0.0170f, 0.0000f, 0.0329f, 0.0119f, 0.0000f, 0.0227f, 0.0082f, 0.0000f,
    /* 695 */ 0.0158f, 0.0057f, 0.0000f, 0.0114f, 0.0041f, 0.0000f, 0.0081f, 0.0029f, 0.0000f,
    /* 710 */ 0.0058f, 0.0021f, 0.0000f, 0.0041f, 0.0015f, 0.0000f, 0.0029f, 0.0010f, 0.0000f,
    /* 725 */ 0.0020f, 0.0007f, 0.0000f, 0.0014f, 0.0005f, 0.0000f, 0.0010f, 0.0004f, 0.0000f,
    /* 740 */ 0.0007f, 0.0002f, 0.0000f, 0.0005f, 0.0002f, 0.0000f, 0.0003f, 0.0001f, 0.0000f,
    /* 755 */ 0.0002f, 0.0001f, 0.0000f, 0.0002f, 0.0001f, 0.0000f, 0.0001f, 0.0000f, 0.0000f,
    /* 770 */ 0.0001f, 0.0000f, 0.0000f, 0.0001f, 0.0000f, 0.0000f, 0.0000f, 0.0000f, 0.0000f};
/* clang-format on */

/* CIE XYZ (D65) to linear Rec.709: the matrix of Blender's colour configuration ("Linear
 * Rec.709" from "Linear CIE-XYZ D65"), what Cycles' xyz_to_rgb is in Blender's default
 * scene-linear space */
#define XYZ_TO_REC709_R (float3)(3.2409699f, -1.5373832f, -0.4986108f)
#define XYZ_TO_REC709_G (float3)(-0.9692436f, 1.8759675f, 0.0415551f)
#define XYZ_TO_REC709_B (float3)(0.0556301f, -0.2039770f, 1.0569715f)

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
