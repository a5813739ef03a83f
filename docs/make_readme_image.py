"""The README's picture: the bulb box rendered by this engine and by Cycles in the same time.

    .venv/bin/python docs/make_readme_image.py [--seconds 45] [--size 320]

Both render the same scene (``python -m ppm_engine example bulb_box``: a Cornell box lit only by
a filament inside a glass bulb) through the same bpy, each with a time limit of ``--seconds``
of rendering (Cycles: the same light transport as ours, ``harness.cycles_reference``, no
denoising; ours: the scene's settings, the passes that fit), on this machine's CPU.  The two
images, through the scene's view transform, go side by side into docs/images/bulb_box_vs_cycles.png.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "images" / "bulb_box_vs_cycles.png"


def render_png(bpy, scene, path: Path) -> float:
    """Render ``scene`` to the PNG ``path`` (its view transform applied); the wall seconds."""
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = str(path)
    t0 = time.perf_counter()
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    return time.perf_counter() - t0


def render_example(bpy, name: str, engine: str, seconds: float, size: int, path: Path,
                   bench_light_paths: bool = False) -> float:
    """The example ``name`` built afresh and rendered by ``engine`` ("PPM": the scene's
    settings, the passes that fit; "CYCLES": harness.cycles_reference) with a time limit of
    ``seconds``, ``size`` pixels square, to the PNG ``path``; the wall seconds.
    ``bench_light_paths``: the benchmark's Light Paths for the scene after the set-up, as the
    bench renders it."""
    from ppm_engine.blender.harness import cycles_reference
    from ppm_engine.blender.scenes import build_example
    scene = build_example(name)
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    if engine == "PPM":
        scene.render.engine = "PPM"
        scene.ppm.passes = 1 << 20
        scene.ppm.time_limit = seconds
    else:
        cycles_reference(scene, seconds=seconds)
    if bench_light_paths:
        from ppm_engine.tools.bench.scenes import set_light_paths
        set_light_paths(scene, name)
    return render_png(bpy, scene, path)


def render_pairs(names, seconds: float, size: int, prefix: str,
                 bench_light_paths: bool = False):
    """Each example of ``names`` rendered by this engine and by Cycles (render_example) into a
    temporary folder: (matplotlib's pyplot, off screen; {(name, engine): the PNG's path})."""
    import bpy

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ppm_engine.blender.harness import ensure_registered

    ensure_registered()
    tmp = Path(tempfile.mkdtemp(prefix=prefix))
    paths = {}
    for name in names:
        for engine in ("PPM", "CYCLES"):
            paths[name, engine] = tmp / f"{name}_{engine}.png"
            wall = render_example(bpy, name, engine, seconds, size, paths[name, engine],
                                  bench_light_paths=bench_light_paths)
            print(f"{name} {engine}: {wall:.1f} s", file=sys.stderr)
    return plt, paths


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=45.0)
    ap.add_argument("--size", type=int, default=320)
    args = ap.parse_args(argv)
    plt, paths = render_pairs(["bulb_box"], args.seconds, args.size, "ppm-readme-")

    fig, axes = plt.subplots(1, 2, figsize=(2 * args.size / 100, args.size / 100 + 0.45),
                             dpi=100)
    titles = {"PPM": f"Progressive Photon Mapping, {args.seconds:.0f} s",
              "CYCLES": f"Cycles, {args.seconds:.0f} s"}
    for ax, engine in zip(axes, ("PPM", "CYCLES")):
        ax.imshow(plt.imread(paths["bulb_box", engine]))
        ax.set_title(titles[engine], fontsize=9)
        ax.axis("off")
    fig.subplots_adjust(left=0.005, right=0.995, bottom=0.005, top=0.92, wspace=0.01)
    fig.savefig(OUT)
    print(f"wrote {OUT}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
