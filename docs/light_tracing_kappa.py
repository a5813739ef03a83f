"""How the light tracing's kappa was chosen (docs/BENCHMARKS.md, "Settings chosen by measurement"):
one scene's RMSE at equal time for several values of kappa, against a light-traced reference.

    python docs/light_tracing_kappa.py point_caustic 8 0.01,0.03,0.1,0.3,1

The reference (two seeds of 60 s of ppm_engine.render.light_tracer, 128x128, over the pixels it
covers) is rendered once per scene and kept in the temporary folder; each kappa then renders
``seconds`` with the default settings (Renderer, seed 1).  Light tracing is unbiased, so it
ranks the values fairly, though it is not independent of the strategy being tuned; the
benchmark's own references are (docs/BENCHMARKS.md)."""
import os
import sys
import tempfile
import time

import bpy

import numpy as np

from ppm_engine.blender.export import export_scene
from ppm_engine.blender.harness import ensure_registered
from ppm_engine.blender.scenes import build_example
from ppm_engine.render import renderer as R
from ppm_engine.render.light_tracer import LightTracer
from ppm_engine.render.options import RenderOptions
from ppm_engine.tools.bench.scenes import caustic_mask


def main(name: str, seconds: float, kappas: list[float], ref_seconds: float = 60.0) -> None:
    ensure_registered()
    scene = build_example(name)
    scene.render.resolution_x = scene.render.resolution_y = 128
    bpy.context.view_layer.update()
    arrays = export_scene(bpy.context.evaluated_depsgraph_get())
    path = os.path.join(tempfile.gettempdir(), f"ppm_kappa_{name}_ref.npz")
    if not os.path.exists(path):
        halves = []
        for seed in (11, 12):
            lt = LightTracer(arrays, photons=1 << 17, seed=seed)
            t = time.time()
            while time.time() - t < ref_seconds:
                lt.trace(1)
            halves.append(lt.image())
            cover = lt.coverage()
            lt.close()
        np.savez(path, a=halves[0], b=halves[1], cov=cover)
    z = np.load(path)
    ref, cov = 0.5 * (z["a"] + z["b"]), z["cov"]
    cm = caustic_mask(scene, name, 128, 128)[::-1] & cov
    noise = np.sqrt(np.mean((z["a"] - z["b"])[cov] ** 2)) / 2
    print(f"{name}: reference mean {ref[cov].mean():.4f}, noise RMSE {noise:.4f}")
    for k in kappas:
        R.LIGHT_TRACING_KAPPA = k
        r = R.Renderer(arrays, RenderOptions(passes=1_000_000, time_limit=1e6, seed=1,
                                             light_tracing=k > 0))
        t, n = time.time(), 0
        while time.time() - t < seconds:
            r.iterate()
            n += 1
        e = r.image()[..., :3] - ref
        r.close()
        print(f"kappa {k:g}: {n} passes, RMSE {np.sqrt(np.mean(e[cov] ** 2)):.4f}, "
              f"caustic RMSE {np.sqrt(np.mean(e[cm] ** 2)):.4f}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1], float(sys.argv[2]), [float(k) for k in sys.argv[3].split(",")])
