"""The Blackbody and Wavelength nodes' colours for constant folding at export: the arithmetic of
kernels/svm/svm_color.h in float32, on the tables read from that header (the blackbody fit Cycles
renders, the CIE 1931 colour matching functions), so that the data live in one place."""
from __future__ import annotations

import re
from functools import cache

import numpy as np

from ppm_engine.render.device.program import kernel_dir

_F32 = np.float32


@cache
def _table(name: str) -> np.ndarray:
    """The float32 values of the ``__constant float NAME[...] = {...}`` array in svm_color.h."""
    src = re.sub(r"/\*.*?\*/", "", (kernel_dir() / "svm" / "svm_color.h").read_text(), flags=re.S)
    m = re.search(r"__constant float " + name + r"\[[^\]]*\]\s*=\s*\{([^}]*)\}", src)
    if m is None:
        raise ValueError(f"kernels/svm/svm_color.h has no table {name}")
    return np.array([float(x.rstrip("f")) for x in m.group(1).replace("\n", " ").split(",")
                     if x.strip()], _F32)


@cache
def _xyz_to_rec709() -> np.ndarray:
    src = (kernel_dir() / "svm" / "svm_color.h").read_text()
    rows = [re.search(r"#define XYZ_TO_REC709_" + c + r" \(float3\)\(([^)]*)\)", src).group(1)
            for c in "RGB"]
    return np.array([[float(x.strip().rstrip("f")) for x in r.split(",")] for r in rows], _F32)


def blackbody_rgb(t: float) -> tuple[float, float, float]:
    """kernels/svm/svm_color.h svm_blackbody: temperature (K) -> linear Rec.709, clamped at 0."""
    t = _F32(t)
    if t >= _F32(12000.0):
        c = _table("BLACKBODY_ABOVE")
    elif t < _F32(800.0):
        c = _table("BLACKBODY_BELOW")
    else:                                       # (NaN: interval 0, NaN, then 0 as fmax)
        i = int(np.count_nonzero(t >= _table("BLACKBODY_FROM")[1:]))
        f = _table("BLACKBODY_FIT")[10 * i:10 * i + 10]
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
    cie = _table("CIE_1931")
    a, b = cie[3 * i:3 * i + 3], cie[3 * i + 3:3 * i + 6]
    xyz = a + (b - a) * t
    c = (_xyz_to_rec709() @ xyz).astype(_F32) * (_F32(1.0) / _F32(2.52))
    return tuple(float(v) for v in np.fmax(c, _F32(0.0)))
