"""Two checks of the pool (docs/history/benchmarks-notebook.md, "A caustic
seen through water: the pool"):

    python docs/pool_checks.py bounces [SAMPLES]   # the second floor bounce: reference, Cycles,
                                                   # ours
    python docs/pool_checks.py bound        # ours at 16 and 64 s against a 2 x 120 s reference

``bounces``: flat water under a 20-degree sun (wide enough for Cycles to converge) 50 degrees
high (lower, its light would reach the floor past the water's edge, which the reference
refuses), 32 x 32, Light Paths 5 against 3 bounces with the same seeds, so that the ratio is
the light the second floor bounce adds: by the exact reference (ppm_engine/tools/bench/
exact_pool.py, 2^21 photons), Cycles (SAMPLES, default 8192) and this engine (8 s).
``bound``: the bench's pool at 128 x 128, ours at 16 s and 64 s against the reference's two
seeds of 120 s (its noise taken out), and where the error lies: the share of the squared error
in the brightest tenth of the pixels, and their mean over the reference's there and
elsewhere.  Run it alone on the machine."""
import math
import sys
import tempfile
from pathlib import Path

import numpy as np


def _ours(scene, seconds: float):
    from ppm_engine.tools.bench.curves import ppm_settings, render
    ppm_settings(scene, seconds, 1, "", None)
    return render(scene, Path(tempfile.mkdtemp()) / "ours.exr")[0]


def bounces(samples: int = 8192) -> None:
    import bpy

    from ppm_engine.blender.harness import cycles_reference
    from ppm_engine.blender.scenes import pool
    from ppm_engine.tools.bench import exact_pool
    from ppm_engine.tools.bench.curves import render
    pool.SUN_ELEVATION = 50.0
    means = {}
    for max_bounces in (3, 5):
        scene = pool.build(waves=(), grid=101)
        scene.render.resolution_x = scene.render.resolution_y = 32
        bpy.data.lights["Sun"].angle = math.radians(20.0)
        scene.cycles.max_bounces = max_bounces
        ref, _, _ = exact_pool.render(scene, photons=1 << 21, seed=4, waves=())
        cycles_reference(scene, samples=samples)
        scene.cycles.max_bounces = max_bounces
        cyc = render(scene, Path(tempfile.mkdtemp()) / "cycles.exr")[0]
        means[max_bounces] = [a.mean((0, 1)) for a in (ref, cyc, _ours(scene, 8.0))]
    for i, name in enumerate(("reference", "Cycles", "ours")):
        added = 100.0 * (means[5][i] / means[3][i] - 1.0)
        print(f"{name:9s} the second floor bounce adds (R, G, B) "
              + " / ".join(f"{a:.2f} %" for a in added))


def bound() -> None:
    from ppm_engine.blender.scenes import pool
    from ppm_engine.tools.bench import exact_pool
    scene = pool.build()
    halves = [exact_pool.render(scene, seconds=120.0, seed=seed)[0] for seed in (1001, 2002)]
    ref = 0.5 * (halves[0] + halves[1])
    noise = float(np.sqrt(((halves[0] - halves[1]) ** 2).mean()) / 2)
    bright = ref.mean(-1) > np.percentile(ref.mean(-1), 90)
    for seconds in (16.0, 64.0):
        img = _ours(scene, seconds)
        err = ((img - ref) ** 2).mean(-1)
        rmse = float(np.sqrt(err.mean()))
        print(f"ours at {seconds:g} s: RMSE {rmse:.4f} (corrected for the reference's noise "
              f"{noise:.4f}: {math.sqrt(max(rmse ** 2 - noise ** 2, 0.0)):.4f}); the brightest "
              f"tenth holds {err[bright].sum() / err.sum():.0%} of the squared error, its mean "
              f"{img[bright].mean() / ref[bright].mean():.3f} of the reference's, the rest "
              f"{img[~bright].mean() / ref[~bright].mean():.3f}")


if __name__ == "__main__":
    if len(sys.argv) not in (2, 3) or sys.argv[1] not in ("bounces", "bound"):
        sys.exit(__doc__)
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
    from ppm_engine.blender.harness import ensure_registered
    ensure_registered()
    if sys.argv[1] == "bounces":
        bounces(*map(int, sys.argv[2:]))
    else:
        bound()
