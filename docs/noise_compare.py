"""One render's pixel noise and time per pass, for example scenes, at equal passes, from one
or more checkouts of the package (docs/history/benchmarks-notebook.md: "The furnace and
the light tree"):

    python docs/noise_compare.py PASSES SCENE[,SCENE...] [ROOT ...]
    git worktree add /tmp/before COMMIT
    python docs/noise_compare.py 64 furnace,many_lights,bulb_box /tmp/before .

Each scene renders at 64 x 64 through the Renderer of each ROOT (default: this checkout),
seeds 1 and 2, PASSES passes after a first one that builds the kernels.  Printed: the noise
(RMS of the two images' difference over sqrt(2): one render's noise per pixel; it takes no
reference, so it sees no bias), the milliseconds per pass, their product noise x sqrt(ms),
which is the noise at equal time up to a constant, and the image's mean.  Run it alone on
the machine: the roots are timed one after the other."""
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

RESOLUTION = 64


def measure(passes: int, scenes: list[str]) -> None:
    import bpy

    from ppm_engine.blender.export import export_scene
    from ppm_engine.blender.scenes import build_example
    from ppm_engine.render.options import RenderOptions
    from ppm_engine.render.renderer import Renderer
    for name in scenes:
        scene = build_example(name)
        scene.render.resolution_x = scene.render.resolution_y = RESOLUTION
        bpy.context.view_layer.update()
        arrays = export_scene(bpy.context.evaluated_depsgraph_get())
        images, times = [], []
        for seed in (1, 2):
            r = Renderer(arrays, RenderOptions(seed=seed))
            r.iterate()
            t = time.perf_counter()
            for _ in range(passes):
                r.iterate()
            times.append((time.perf_counter() - t) / passes)
            images.append(r.image()[..., :3].astype(np.float64))
            r.close()
        noise = float(np.sqrt(np.mean((images[0] - images[1]) ** 2) / 2))
        ms = float(np.mean(times)) * 1e3
        print(f"{name}: noise {noise:.5f}, {ms:.1f} ms per pass, noise x sqrt(ms) "
              f"{noise * np.sqrt(ms):.5f}, mean {images[0].mean():.4f}", flush=True)


def main(argv: list[str]) -> None:
    if len(argv) < 2:
        sys.exit(__doc__)
    passes, scenes = int(argv[0]), argv[1].split(",")
    if len(argv) == 2:
        measure(passes, scenes)
        return
    for root in argv[2:]:
        print(f"# {Path(root).resolve()}", flush=True)
        code = (f"import sys; sys.path.insert(0, {str(Path(root).resolve())!r}); "
                f"sys.path.insert(1, {str(Path(__file__).resolve().parent)!r}); "
                f"import noise_compare; noise_compare.measure({passes}, {scenes!r})")
        subprocess.run([sys.executable, "-c", code], check=True)


if __name__ == "__main__":
    main(sys.argv[1:])
