"""The volume bench scenes rendered by this engine and by Cycles in the same time, side by side.

    .venv/bin/python docs/make_volume_images.py [--seconds 16] [--size 160]

Each of fog_lens (a glass ball in fog under a point light: the volumetric caustic), fog_room
(homogeneous fog under a spot light) and smoke (a Noise Texture's density under a sun and a
sky) is built as the benchmark builds it (``python -m ppm_engine example NAME``, the bench's
Light Paths for the scene) and rendered through the same bpy with a time limit of
``--seconds`` each (Cycles: ``harness.cycles_reference``, no denoising; ours: the scene's
settings).  The images, through the scene's view transform, go into
docs/images/volumes_vs_cycles.png, a row per scene.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from make_readme_image import render_pairs

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "images" / "volumes_vs_cycles.png"
SCENES = ("fog_lens", "fog_room", "smoke")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=16.0)
    ap.add_argument("--size", type=int, default=160)
    args = ap.parse_args(argv)
    plt, paths = render_pairs(SCENES, args.seconds, args.size, "ppm-volumes-",
                              bench_light_paths=True)

    s = args.size / 100
    fig, axes = plt.subplots(len(SCENES), 2, figsize=(2 * s, len(SCENES) * (s + 0.3)), dpi=100)
    for row, name in zip(axes, SCENES):
        for ax, engine in zip(row, ("PPM", "CYCLES")):
            ax.imshow(plt.imread(paths[name, engine]))
            label = "PPM" if engine == "PPM" else "Cycles"
            ax.set_title(f"{name}, {label}, {args.seconds:.0f} s", fontsize=7)
            ax.axis("off")
    fig.subplots_adjust(left=0.005, right=0.995, bottom=0.005, top=0.95, wspace=0.01,
                        hspace=0.15)
    fig.savefig(OUT)
    print(f"wrote {OUT}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
