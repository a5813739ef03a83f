"""The Blackbody and Wavelength nodes' colours: the tables kernels/svm/svm_color.h evaluates them
from (the blackbody fit Cycles renders, the CIE 1931 colour matching functions, the XYZ to Rec.709
matrix), written here once (ppm_engine/tools/shared_header.py generates kernels/shared_color.h from
them), and the same arithmetic in float32 for constant folding at export."""
from __future__ import annotations

import numpy as np

_F32 = np.float32

# Cycles' Blackbody fit: the colour of a black body at T kelvin in linear Rec.709 with luminance 1
# (Planck's law through the CIE 1931 observer), fitted piecewise by r, g = a / T + b T + c and
# b = ((a T + b) T + c) T + d on seven intervals of [800, 12000) K; constant outside.  Its
# coefficients are Cycles' own (kernel/tables.h, Apache-2.0): the colour computed from first
# principles (5 nm CIE data) differs from the fit by up to 1.2e-3, and Cycles renders the fit.
BLACKBODY_FROM = np.array([800.0, 965.0, 1167.0, 1449.0, 1902.0, 3315.0, 6365.0], _F32)
BLACKBODY_FIT = np.array([         # per interval, rows r (a, b, c), g (a, b, c), b (a, b, c, d)
    1.61919106e+03, -2.05010916e-03, 5.02995757e+00,    # from 800 K
    -4.88999748e+02, 6.04330754e-04, -7.55807526e-02,
    5.96945309e-11, -4.85742887e-08, -9.70622247e-05, -4.07936148e-03,
    2.48845471e+03, -1.11330907e-03, 3.22621544e+00,    # from 965 K
    -7.55994277e+02, 3.16730098e-04, 4.78306139e-01,
    2.40430366e-11, 5.55021075e-08, -1.98503712e-04, 2.89312858e-02,
    3.34143193e+03, -4.86551192e-04, 1.76486769e+00,    # from 1167 K
    -1.02363977e+03, 1.20223470e-04, 9.36662319e-01,
    -1.40949732e-11, 1.89878968e-07, -3.56632824e-04, 9.10767778e-02,
    4.09461742e+03, -1.27446582e-04, 7.25731635e-01,    # from 1449 K
    -1.26571316e+03, 4.87340896e-06, 1.27054498e+00,
    -3.61460868e-11, 2.84822009e-07, -4.93211319e-04, 1.56723440e-01,
    4.67028036e+03, 2.91258199e-05, 1.26703442e-01,     # from 1902 K
    -1.42529332e+03, -4.01150431e-05, 1.43972784e+00,
    -1.97075738e-11, 1.75359352e-07, -2.50542825e-04, -2.22783266e-02,
    4.59509185e+03, 2.87495649e-05, 1.50345020e-01,     # from 3315 K
    -1.17554822e+03, -2.16378048e-05, 1.30408023e+00,
    -1.61997957e-13, -1.64216008e-08, 3.86216271e-04, -7.38077418e-01,
    3.78717450e+03, 9.35907826e-06, 3.99075871e-01,     # from 6365 K
    -5.00799571e+02, -4.59832026e-06, 1.09098763e+00,
    6.72650283e-13, -2.73078809e-08, 4.24098264e-04, -7.52335691e-01], _F32)
BLACKBODY_BELOW = np.array([5.413294490189271, -0.20319390035873933, -0.0822535242887164],
                           _F32)                                   # T < 800 K
BLACKBODY_ABOVE = np.array([0.8262954810464208, 0.9945080501520986, 1.566307710274283],
                           _F32)                                   # T >= 12000 K

# The CIE 1931 2-degree standard observer's colour matching functions x, y, z from 380 to 780 nm
# in 5 nm steps, to four decimals (CIE 15 / ISO 11664-1 tabulated data, as Cycles' table holds
# them); three wavelengths a row.
CIE_1931 = np.array([
    0.0014, 0.0000, 0.0065, 0.0022, 0.0001, 0.0105, 0.0042, 0.0001, 0.0201,   # 380
    0.0076, 0.0002, 0.0362, 0.0143, 0.0004, 0.0679, 0.0232, 0.0006, 0.1102,   # 395
    0.0435, 0.0012, 0.2074, 0.0776, 0.0022, 0.3713, 0.1344, 0.0040, 0.6456,   # 410
    0.2148, 0.0073, 1.0391, 0.2839, 0.0116, 1.3856, 0.3285, 0.0168, 1.6230,   # 425
    0.3483, 0.0230, 1.7471, 0.3481, 0.0298, 1.7826, 0.3362, 0.0380, 1.7721,   # 440
    0.3187, 0.0480, 1.7441, 0.2908, 0.0600, 1.6692, 0.2511, 0.0739, 1.5281,   # 455
    0.1954, 0.0910, 1.2876, 0.1421, 0.1126, 1.0419, 0.0956, 0.1390, 0.8130,   # 470
    0.0580, 0.1693, 0.6162, 0.0320, 0.2080, 0.4652, 0.0147, 0.2586, 0.3533,   # 485
    0.0049, 0.3230, 0.2720, 0.0024, 0.4073, 0.2123, 0.0093, 0.5030, 0.1582,   # 500
    0.0291, 0.6082, 0.1117, 0.0633, 0.7100, 0.0782, 0.1096, 0.7932, 0.0573,   # 515
    0.1655, 0.8620, 0.0422, 0.2257, 0.9149, 0.0298, 0.2904, 0.9540, 0.0203,   # 530
    0.3597, 0.9803, 0.0134, 0.4334, 0.9950, 0.0087, 0.5121, 1.0000, 0.0057,   # 545
    0.5945, 0.9950, 0.0039, 0.6784, 0.9786, 0.0027, 0.7621, 0.9520, 0.0021,   # 560
    0.8425, 0.9154, 0.0018, 0.9163, 0.8700, 0.0017, 0.9786, 0.8163, 0.0014,   # 575
    1.0263, 0.7570, 0.0011, 1.0567, 0.6949, 0.0010, 1.0622, 0.6310, 0.0008,   # 590
    1.0456, 0.5668, 0.0006, 1.0026, 0.5030, 0.0003, 0.9384, 0.4412, 0.0002,   # 605
    0.8544, 0.3810, 0.0002, 0.7514, 0.3210, 0.0001, 0.6424, 0.2650, 0.0000,   # 620
    0.5419, 0.2170, 0.0000, 0.4479, 0.1750, 0.0000, 0.3608, 0.1382, 0.0000,   # 635
    0.2835, 0.1070, 0.0000, 0.2187, 0.0816, 0.0000, 0.1649, 0.0610, 0.0000,   # 650
    0.1212, 0.0446, 0.0000, 0.0874, 0.0320, 0.0000, 0.0636, 0.0232, 0.0000,   # 665
    0.0468, 0.0170, 0.0000, 0.0329, 0.0119, 0.0000, 0.0227, 0.0082, 0.0000,   # 680
    0.0158, 0.0057, 0.0000, 0.0114, 0.0041, 0.0000, 0.0081, 0.0029, 0.0000,   # 695
    0.0058, 0.0021, 0.0000, 0.0041, 0.0015, 0.0000, 0.0029, 0.0010, 0.0000,   # 710
    0.0020, 0.0007, 0.0000, 0.0014, 0.0005, 0.0000, 0.0010, 0.0004, 0.0000,   # 725
    0.0007, 0.0002, 0.0000, 0.0005, 0.0002, 0.0000, 0.0003, 0.0001, 0.0000,   # 740
    0.0002, 0.0001, 0.0000, 0.0002, 0.0001, 0.0000, 0.0001, 0.0000, 0.0000,   # 755
    0.0001, 0.0000, 0.0000, 0.0001, 0.0000, 0.0000, 0.0000, 0.0000, 0.0000,   # 770
], _F32)

# CIE XYZ (D65) to linear Rec.709: the matrix of Blender's colour configuration ("Linear Rec.709"
# from "Linear CIE-XYZ D65"), what Cycles' xyz_to_rgb is in Blender's default scene-linear space
XYZ_TO_REC709 = np.array([[3.2409699, -1.5373832, -0.4986108],
                          [-0.9692436, 1.8759675, 0.0415551],
                          [0.0556301, -0.2039770, 1.0569715]], _F32)


def blackbody_rgb(t: float) -> tuple[float, float, float]:
    """kernels/svm/svm_color.h svm_blackbody: temperature (K) -> linear Rec.709, clamped at 0."""
    t = _F32(t)
    if t >= _F32(12000.0):
        c = BLACKBODY_ABOVE
    elif t < _F32(800.0):
        c = BLACKBODY_BELOW
    else:                                       # (NaN: interval 0, NaN, then 0 as fmax)
        i = int(np.count_nonzero(t >= BLACKBODY_FROM[1:]))
        f = BLACKBODY_FIT[10 * i:10 * i + 10]
        inv = _F32(1.0) / t
        c = np.array([f[0] * inv + f[1] * t + f[2], f[3] * inv + f[4] * t + f[5],
                      ((f[6] * t + f[7]) * t + f[8]) * t + f[9]], _F32)
    return tuple(float(x) for x in np.fmax(c, _F32(0.0)))


def wavelength_rgb(nm: float) -> tuple[float, float, float]:
    """kernels/svm/svm_color.h svm_wavelength: wavelength (nm) -> linear Rec.709, clamped at 0."""
    x = (_F32(nm) - _F32(380.0)) * _F32(0.2)
    if not (x > -1.0 and x < 80.0):
        return (0.0, 0.0, 0.0)
    i = int(x)                                  # truncation towards zero, as the kernel
    t = x - _F32(i)
    a, b = CIE_1931[3 * i:3 * i + 3], CIE_1931[3 * i + 3:3 * i + 6]
    xyz = a + (b - a) * t
    c = (XYZ_TO_REC709 @ xyz).astype(_F32) * (_F32(1.0) / _F32(2.52))
    return tuple(float(v) for v in np.fmax(c, _F32(0.0)))
