"""Compute the GGX shading tables (ppm_engine/scene/shading_tables.py) again with the closures'
own sampling code on an OpenCL device (kernels/closure/precompute.cl), into the package data:
``python -m ppm_engine.tools.make_shading_tables`` (about 12 minutes on 2 cores; the sheen
table, measured from Cycles' renders by docs/make_sheen_table.py, is kept)."""
from __future__ import annotations

import numpy as np
import pyopencl as cl

from ppm_engine.render.device import get_device
from ppm_engine.scene import shading_tables as st


def compute(device, names=None, samples: int | None = None) -> dict:
    """The GGX tables ``names`` (all when None) computed on ``device`` (device.get_device),
    with ``samples`` per cell (SAMPLES when None)."""
    prog = device.programs.get("closure/precompute.cl")
    out = {}
    for name in names or st.KINDS:
        shape = st.LAYOUT[name][1]
        nz, ny, nx = (1,) * (3 - len(shape)) + shape
        if name.endswith("Eavg"):          # [z][rough]: the mu axis is averaged over
            nz, ny, nx = (shape[0] if len(shape) == 2 else 1), 1, shape[-1]
        n = nx * ny * nz
        buf = cl.Buffer(device.context, cl.mem_flags.WRITE_ONLY, 4 * n)
        prog.ggx_table(device.queue, (-(-n // 64) * 64,), None, np.int32(st.KINDS[name]),
                       np.int32(nx), np.int32(ny), np.int32(nz),
                       np.uint32(samples or st.SAMPLES[name]), buf)
        a = np.empty(n, np.float32)
        cl.enqueue_copy(device.queue, a, buf)
        out[name] = a.reshape(shape)
    return out


def main() -> None:
    """Compute the GGX tables again into the package data (the sheen table is kept)."""
    dev = get_device("")
    tables = st.unpack(st.load()) if st.DATA.is_file() else {}
    tables.update(compute(dev))
    st.DATA.parent.mkdir(exist_ok=True)
    np.savez_compressed(st.DATA, **tables)
    print(f"wrote {st.DATA}")


if __name__ == "__main__":
    main()
