"""Settings against each other at equal time on one scene (docs/BENCHMARKS.md: "Settings chosen
by measurement"), each against the benchmark's independent reference:

    python docs/settings_compare.py SCENE SECONDS SEEDS NAME=OPTIONS [NAME=OPTIONS ...]
    python docs/settings_compare.py point_caustic 8 3 pixel="" global="radius_schedule='global'"
    python docs/settings_compare.py glossy:point 8 3 default=""

SCENE is a benchmark scene (128 x 128; its reference as the benchmark renders it:
ppm_engine.tools.bench.curves.REFERENCE_ENGINE, two seeds of REF_SECONDS each (environment, default
60), over the pixels the reference covers), or ``glossy:area`` / ``glossy:point``: the
spheres of ``bench --glossy`` at 96 x 96 against Cycles at 6000 samples.  The reference is
rendered once and kept in the temporary folder.  OPTIONS are RenderOptions keyword arguments
(Python syntax, empty for the defaults); every setting renders SECONDS after a first pass
that builds its kernels, with seeds 1 .. SEEDS, through the Renderer.  Printed: the RMSE per
seed and its mean, the passes, and the mean brightness over the reference's.  Run it alone on
the machine: the settings are timed one after the other."""
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def reference(name: str, folder: Path, ref_seconds: float):
    """(scene, reference image top-down, pixels compared) for SCENE."""
    import bpy

    from ppm_engine.tools.bench import curves, glossy
    path = folder / f"ppm_settings_{name.replace(':', '_')}_ref.npz"
    if name.startswith("glossy:"):
        light = name.split(":")[1]
        if not path.exists():
            glossy.build_scene(96, light)
            ref = glossy._cycles(bpy.context.scene, str(folder / "ppm_settings_cycles.exr"),
                                 samples=6000, seed=77)
            np.savez(path, ref=ref, keep=np.ones(ref.shape[:2], bool))
        scene = glossy.build_scene(96, light)
    else:
        b = curves.Bench(128, "", None, folder, print)
        scene = b._scene(name)
        if not path.exists():
            keep = ~curves.excluded_pixels(scene, name, 128, 128)
            halves = []
            for seed in curves.REF_SEEDS:
                img, cover = b.reference_half(scene, curves.REFERENCE_ENGINE[name],
                                              ref_seconds, seed)
                if cover is not None:
                    keep &= cover
                halves.append(img)
            np.savez(path, ref=0.5 * (halves[0] + halves[1]), keep=keep)
            scene = b._scene(name)
    d = np.load(path)
    return scene, d["ref"], d["keep"]


def main(name: str, seconds: float, seeds: int, settings: list[str]) -> None:
    import bpy

    from ppm_engine.blender.export import export_scene
    from ppm_engine.blender.harness import ensure_registered, unbiased_light_paths
    from ppm_engine.render.options import RenderOptions
    from ppm_engine.render.renderer import Renderer
    ensure_registered()
    folder = Path(tempfile.gettempdir())
    scene, ref, keep = reference(name, folder, float(os.environ.get("REF_SECONDS", 60)))
    if name.startswith("glossy:"):
        unbiased_light_paths(scene)
    arrays = export_scene(bpy.context.evaluated_depsgraph_get())
    for setting in settings:
        label, _, text = setting.partition("=")
        kw = eval(f"dict({text})")
        errs, means, passes = [], [], []
        for seed in range(1, seeds + 1):
            r = Renderer(arrays, RenderOptions(**{"seed": seed, **kw}))
            r.iterate()
            t0, n = time.perf_counter(), 1
            while time.perf_counter() - t0 < seconds:
                r.iterate()
                n += 1
            img = r.image()[::-1, :, :3]
            r.close()
            errs.append(float(np.sqrt(((img - ref)[keep] ** 2).mean())))
            means.append(float(img[keep].mean() / ref[keep].mean()))
            passes.append(n)
        print(f"{name} {label}: RMSE {np.mean(errs):.5f} (seeds: "
              + ", ".join(f"{e:.5f}" for e in errs)
              + f"), passes {np.mean(passes):.0f}, mean / reference {np.mean(means):.4f}",
              flush=True)


if __name__ == "__main__":
    if len(sys.argv) < 5:
        sys.exit(__doc__)
    main(sys.argv[1], float(sys.argv[2]), int(sys.argv[3]), sys.argv[4:])
