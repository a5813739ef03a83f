"""One binary per kernel whatever the launch's size (docs/BENCHMARKS.md, "Viewport"): the
Cornell box by photons at 64 x 64, then at 512 x 512, with PoCL's kernel cache empty; prints
each first pass's seconds and the binaries PoCL compiled.

    POCL_CACHE_DIR=$(mktemp -d) python docs/grid_compile_check.py

Before launches of 65,536 items or more ran as rows (ppm_engine/render/device/program.py grid),
PoCL compiled every kernel again for the large grid: the 512 x 512 render's first pass paid it."""
import os
import sys
import time

from ppm_engine.oracle.procedural import cornell_box
from ppm_engine.render.options import RenderOptions
from ppm_engine.render.renderer import Renderer


def main() -> int:
    cache = os.environ.get("POCL_CACHE_DIR")
    if not cache:
        print("set POCL_CACHE_DIR to an empty folder", file=sys.stderr)
        return 2
    for w, photons in ((64, 1 << 12), (512, 1 << 17)):
        r = Renderer(cornell_box(w, w), RenderOptions(indirect="photons",
                                                      photons_per_pass=photons))
        t = time.perf_counter()
        r.iterate()
        print(f"{w} x {w}: first pass {time.perf_counter() - t:.1f} s")
        r.close()
    n = sum(f.endswith(".so") for _, _, fs in os.walk(cache) for f in fs)
    print(f"binaries compiled: {n}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
