"""The noise of point_caustic's exact-geometry reference (docs/history/benchmarks-notebook.md, "Its
direct light in closed form"), as the benchmark measures it: two halves of ``seconds`` each (seeds
1001 and 2002, 128x128, ``exact_caustic.render`` as ``Curves.exact`` calls it), RMSE between them /
2 over the pixels both cover and over the caustic mask, and the mean over the covered pixels.

    python docs/exact_reference_noise.py 32            # as it renders now
    python docs/exact_reference_noise.py 32 --before   # as before 2026-11-27

``--before`` light-traces the direct light too and sends a quarter of the photons into the
ball's cone, which is what the reference did until the direct light took its closed form.  The
mean's own noise is the halves' difference pooled over 16x16 blocks (blocks more than a
filter's reach apart are nearly independent)."""
import sys

import bpy

import numpy as np

from ppm_engine.blender.scenes import build_example
from ppm_engine.tools.bench import exact_caustic
from ppm_engine.tools.bench.curves import REF_SEEDS, errors
from ppm_engine.tools.bench.scenes import caustic_mask


def main(seconds: float, before: bool) -> None:
    name, res = "point_caustic", 128
    scene = build_example(name)
    scene.render.resolution_x = scene.render.resolution_y = res
    scene.render.resolution_percentage = 100
    bpy.context.view_layer.update()
    if before:
        exact_caustic.BALL_SHARE = 0.25
    keep = np.ones((res, res), bool)
    cmask = caustic_mask(scene, name, res, res)
    halves, photons = [], []
    for seed in REF_SEEDS:
        img, cover, info = exact_caustic.render(bpy.context.scene, seed=seed, seconds=seconds,
                                                direct="traced" if before else "closed")
        keep &= cover
        cmask &= cover
        halves.append(img)
        photons.append(info["photons"])
    ref = 0.5 * (halves[0] + halves[1])
    noise = errors(halves[0], halves[1], keep)["rmse"] / 2
    noise_c = errors(halves[0], halves[1], cmask)["rmse"] / 2

    def blocks(x):
        return np.where(keep, x, 0.0).reshape(res // 16, 16, res // 16, 16).sum(axis=(1, 3))
    diff = blocks(halves[0][..., 0]) - blocks(halves[1][..., 0])
    sd_mean = np.sqrt(np.sum((diff / 2) ** 2)) / keep.sum()
    print(f"{'before' if before else 'now'}, 2 x {seconds:g} s: photons "
          f"{photons[0] / 1e6:.1f}M + {photons[1] / 1e6:.1f}M; {keep.sum()} pixels: mean "
          f"{ref[keep].mean():.5f} +- {sd_mean:.5f}, noise {noise:.5f}; {cmask.sum()} caustic "
          f"pixels: mean {ref[cmask].mean():.5f}, noise {noise_c:.5f}")


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if a != "--before"]
    main(float(args[0]) if args else 32.0, "--before" in sys.argv[1:])
