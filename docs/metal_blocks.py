"""glossy_metal's error split between its polished ball's highlight and the rest, ours against
Cycles at equal time or at equal samples (docs/history/benchmarks-notebook.md: "Glossy metal
lit by a small light"):

    python docs/metal_blocks.py time 8 3          # 8 s per render, seeds 1-3
    python docs/metal_blocks.py samples 256 3     # 256 samples (passes) per render

The reference is the benchmark's (Cycles, two halves of REF_SECONDS each: environment,
default 240), rendered once and kept in the temporary folder by settings_compare.py.  Printed
per render: the RMSE over the image, over the 16 x 16 block of the highlight (rows 64-79,
columns 80-95 from the top at 128 x 128) and over the rest, the block's sum against the
reference's, and the wall time; then the means.  Run it alone on the machine."""
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

BLOCK = (slice(64, 80), slice(80, 96))


def main(mode: str, amount: float, seeds: int) -> None:
    from settings_compare import reference  # (docs/: the benchmark's reference, cached)

    from ppm_engine.blender.harness import cycles_reference, ensure_registered
    from ppm_engine.blender.scenes import metal
    from ppm_engine.tools.bench.curves import ppm_settings, render
    ensure_registered()
    folder = Path(tempfile.gettempdir())
    _scene, ref, _keep = reference("glossy_metal", folder,
                                   float(os.environ.get("REF_SECONDS", 240)))
    block = np.zeros(ref.shape[:2], bool)
    block[BLOCK] = True

    def rmse(img, mask=None):
        e = ((img - ref) ** 2).mean(-1)
        return float(np.sqrt(e.mean() if mask is None else e[mask].mean()))

    for engine in ("cycles", "ours"):
        rows = []
        for seed in range(1, seeds + 1):
            scene = metal.build()
            if engine == "cycles":
                cycles_reference(scene, seed=seed, **({"seconds": amount} if mode == "time"
                                                       else {"samples": int(amount)}))
            else:
                ppm_settings(scene, amount if mode == "time" else 0.0, seed, "", None)
                if mode != "time":
                    scene.ppm.passes, scene.ppm.time_limit = int(amount), 0.0
            img, wall, info = render(scene, folder / f"ppm_metal_blocks_{engine}.exr")
            rows.append((rmse(img), rmse(img, block), rmse(img, ~block), wall))
            print(f"{engine} seed {seed}: all {rows[-1][0]:.4f}, highlight {rows[-1][1]:.3f}, "
                  f"rest {rows[-1][2]:.4f}, block sum {img[BLOCK].mean(-1).sum():.1f} "
                  f"(reference {ref[BLOCK].mean(-1).sum():.1f}), wall {wall:.1f} s"
                  + (f", {info['passes']} passes" if "passes" in info else ""), flush=True)
        m = np.mean(rows, axis=0)
        print(f"{engine} mean: all {m[0]:.4f}, highlight {m[1]:.3f}, rest {m[2]:.4f}",
              flush=True)


if __name__ == "__main__":
    if len(sys.argv) != 4 or sys.argv[1] not in ("time", "samples"):
        sys.exit(__doc__)
    main(sys.argv[1], float(sys.argv[2]), int(sys.argv[3]))
