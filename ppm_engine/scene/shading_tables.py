"""The shading tables the closures read (kernels/closure/shading_tables.h states the same layout;
tests/test_closures.py checks the two agree): GGX albedos for the compensation of multiple
scattering, the Fresnel albedos of the Principled BSDF's layering, the sheen's LTC fit.

They ship as package data (data/shading_tables.npz).  The GGX tables are computed with the
closures' own sampling code (kernels/closure/precompute.cl), as expectations that Cycles defines the
same way (docs/SHADING.md); ``python -m ppm_engine.tools.make_shading_tables`` computes them
again.
The sheen table is measured from Cycles' own renders of its Sheen BSDF
(docs/make_sheen_table.py): Cycles fits it to a volumetric fibre model, which has no closed
form to compute it from.
"""
from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[1] / "data" / "shading_tables.npz"

# name: (offset in the buffer, shape as stored: slowest axis first, the x axis last)
LAYOUT = {
    "ggx_E": (0, (32, 32)),                  # [mu][rough]
    "ggx_Eavg": (1024, (32,)),               # [rough]
    "glass_E": (1056, (16, 16, 16)),         # [z][mu][rough]
    "glass_Eavg": (5152, (16, 16)),          # [z][rough]
    "glass_inv_E": (5408, (16, 16, 16)),
    "glass_inv_Eavg": (9504, (16, 16)),
    "schlick_ior_s": (9760, (16, 16, 16)),
    "schlick_s": (13856, (16, 16, 16)),
    "sheen": (17952, (3, 32, 32)),           # [a, b, albedo][rough][mu]
}
SIZE = 21024
# kernels/closure/precompute.cl KIND_* for the GGX tables, and the samples per cell used for the
# shipped tables
KINDS = {"ggx_E": 0, "ggx_Eavg": 1, "glass_E": 2, "glass_Eavg": 3, "glass_inv_E": 4,
         "glass_inv_Eavg": 5, "schlick_ior_s": 6, "schlick_s": 7}
SAMPLES = {"ggx_E": 1 << 20, "ggx_Eavg": 1 << 22, "glass_E": 1 << 18, "glass_Eavg": 1 << 22,
           "glass_inv_E": 1 << 18, "glass_inv_Eavg": 1 << 22, "schlick_ior_s": 1 << 18,
           "schlick_s": 1 << 18}


@functools.lru_cache(maxsize=1)
def load() -> np.ndarray:
    """The tables as one float32 buffer of SIZE (read-only)."""
    with np.load(DATA) as z:
        out = pack({k: z[k] for k in z.files})
    out.setflags(write=False)
    return out


def pack(tables: dict) -> np.ndarray:
    buf = np.zeros(SIZE, np.float32)
    for name, (off, shape) in LAYOUT.items():
        if name in tables:
            a = np.asarray(tables[name], np.float32)
            if a.shape != shape:
                raise ValueError(f"shading table {name}: shape {a.shape}, expected {shape}")
            buf[off:off + a.size] = a.ravel()
    return buf


def unpack(buf: np.ndarray) -> dict:
    return {name: np.asarray(buf[off:off + int(np.prod(shape))]).reshape(shape)
            for name, (off, shape) in LAYOUT.items()}
