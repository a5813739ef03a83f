"""The shading tables the closures read (kernels/shading_tables.h states the same layout;
tests/test_closures.py checks the two agree): GGX albedos for the compensation of multiple
scattering, the Fresnel albedos of the Principled BSDF's layering, the sheen's LTC fit.

They ship as package data (data/shading_tables.npz).  The GGX tables are computed here with
the closures' own sampling code (kernels/precompute.cl), as expectations that Cycles defines
the same way (docs/SHADING.md); ``python -m ppm_engine.shading_tables`` computes them again.
The sheen table is measured from Cycles' own renders of its Sheen BSDF
(docs/make_sheen_table.py): Cycles fits it to a volumetric fibre model, which has no closed
form to compute it from.
"""
from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parent / "data" / "shading_tables.npz"

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
# kernels/precompute.cl KIND_* for the GGX tables, and the samples per cell used for the
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


def compute(device, names=None, samples: int | None = None) -> dict:
    """The GGX tables ``names`` (all when None) computed on ``device`` (device.get_device),
    with ``samples`` per cell (SAMPLES when None)."""
    import pyopencl as cl
    prog = device.programs.get("precompute.cl")
    out = {}
    for name in names or KINDS:
        shape = LAYOUT[name][1]
        nz, ny, nx = (1,) * (3 - len(shape)) + shape
        if name.endswith("Eavg"):          # [z][rough]: the mu axis is averaged over
            nz, ny, nx = (shape[0] if len(shape) == 2 else 1), 1, shape[-1]
        n = nx * ny * nz
        buf = cl.Buffer(device.context, cl.mem_flags.WRITE_ONLY, 4 * n)
        prog.ggx_table(device.queue, (-(-n // 64) * 64,), None, np.int32(KINDS[name]),
                       np.int32(nx), np.int32(ny), np.int32(nz),
                       np.uint32(samples or SAMPLES[name]), buf)
        a = np.empty(n, np.float32)
        cl.enqueue_copy(device.queue, a, buf)
        out[name] = a.reshape(shape)
    return out


def main() -> None:
    """Compute the GGX tables again into the package data (the sheen table is kept)."""
    from .device import get_device
    dev = get_device("")
    tables = unpack(load()) if DATA.is_file() else {}
    tables.update(compute(dev))
    DATA.parent.mkdir(exist_ok=True)
    np.savez_compressed(DATA, **tables)
    print(f"wrote {DATA}")


if __name__ == "__main__":
    main()
