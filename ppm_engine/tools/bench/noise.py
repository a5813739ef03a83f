"""``python -m ppm_engine bench --noise SCENE``: noise per sample, ours against Cycles at the same
number of samples per pixel (our passes, Cycles' samples), apart from the speed at which each
takes them.  The error-against-time run (curves.py) mixes both; this one says which of the two
a gap comes from.

Every render of the scene (one of the bench's, 128x128) is repeated with ``seeds`` seeds; a
pixel's noise is the standard deviation of its value over the seeds (unbiased, no reference
needed: both estimators are unbiased where they are compared), and the figure is its root mean
square over the image, also split into the pixels brighter than 1 (emitters and the edges of
their images: anti-aliasing there dominates a scene with a visible lamp) and the rest.  With
``bounces`` 0 only direct light counts (both engines' bounce limits), which isolates the pixel
sampling and next-event estimation; ``diffuse_bounces`` (Light Paths > Diffuse, both engines)
limits only the diffuse bounces, to tell the noise of each order of diffuse interreflection
apart where glass needs the other bounces (docs/BENCHMARKS.md, lifted_caustic).
"""
from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

BRIGHT = 1.0          # radiance above which a pixel counts as an emitter or its edge


def run_noise(scene_name: str, passes: int = 550, seeds: int = 4, bounces: int = 12,
              resolution: int = 128, device: str = "", progress=print,
              diffuse_bounces: int | None = None) -> dict:
    from ppm_engine.blender.harness import cycles_reference, ensure_registered, unbiased_light_paths
    from ppm_engine.tools.bench.curves import Bench, ppm_settings, render
    from ppm_engine.tools.bench.scenes import set_light_paths
    ensure_registered()
    if seeds < 2:
        raise ValueError("the noise needs at least two seeds")
    out = {"scene": scene_name, "passes": passes, "seeds": seeds, "bounces": bounces,
           "diffuse_bounces": diffuse_bounces, "resolution": resolution,
           "bright_above": BRIGHT, "engines": {}}
    with tempfile.TemporaryDirectory(prefix="ppm-noise-") as tmp:
        b = Bench(resolution, device, None, Path(tmp), progress)
        scene = b._scene(scene_name)
        images, walls = {}, {}
        for engine in ("PPM", "CYCLES"):
            imgs, wall = [], []
            for seed in range(1, seeds + 1):
                if engine == "CYCLES":
                    cycles_reference(scene, samples=passes, seed=seed, bounces=bounces)
                else:
                    ppm_settings(scene, 0, seed, device, None)
                    scene.ppm.passes = passes
                    scene.ppm.time_limit = 0
                    unbiased_light_paths(scene, bounces)
                set_light_paths(scene, scene_name)        # the scene's own clamp
                if diffuse_bounces is not None:
                    scene.cycles.diffuse_bounces = diffuse_bounces
                img, w, _info = render(scene, Path(tmp) / f"{engine}_{seed}.exr")
                imgs.append(img)
                wall.append(w)
            images[engine], walls[engine] = np.asarray(imgs, np.float64), wall
            progress(f"[noise] {scene_name} {engine}: {seeds} x {passes} samples, "
                     f"{np.mean(wall):.1f} s each")
    # the pixel classes from both engines' means together (the same pixels for both)
    mean = 0.5 * (images["PPM"].mean(axis=0) + images["CYCLES"].mean(axis=0)).mean(axis=-1)
    bright = mean > BRIGHT
    for engine, imgs in images.items():
        var = imgs.var(axis=0, ddof=1).mean(axis=-1)           # per pixel, over the seeds
        n = var.size
        out["engines"][engine] = {
            "noise_rms": float(np.sqrt(var.mean())),
            "noise_rms_bright": float(np.sqrt(var[bright].sum() / n)),
            "noise_rms_rest": float(np.sqrt(var[~bright].sum() / n)),
            # the typical pixel's (a few fireflies among four seeds rule the RMS)
            "noise_median": float(np.sqrt(np.median(var))),
            "mean": float(imgs.mean()), "wall_s": float(np.mean(walls[engine])),
            "samples_per_s": passes / float(np.mean(walls[engine]))}
    out["bright_pixels"] = int(bright.sum())
    o, c = out["engines"]["PPM"], out["engines"]["CYCLES"]
    out["ratio_noise"] = o["noise_rms"] / c["noise_rms"]
    out["ratio_noise_median"] = o["noise_median"] / c["noise_median"]
    out["ratio_speed"] = o["samples_per_s"] / c["samples_per_s"]
    # the error ratio at equal time these imply: noise per sample x sqrt(time per sample)
    out["implied_equal_time_ratio"] = out["ratio_noise"] / np.sqrt(out["ratio_speed"])
    return out


def format_noise(d: dict) -> str:
    diffuse = d.get("diffuse_bounces")
    lines = [f"{d['scene']}, {d['resolution']}x{d['resolution']}, {d['passes']} samples per "
             f"pixel, {d['bounces']} bounces"
             + (f" ({diffuse} diffuse)" if diffuse is not None else "")
             + f", {d['seeds']} seeds (noise: RMS over pixels of the "
             f"standard deviation over seeds; bright: the {d['bright_pixels']} pixels above "
             f"{d['bright_above']:g})",
             "", "| engine | noise | bright pixels' share | the rest's | median pixel's | mean "
             "| s per render | samples/s |", "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for name, e in d["engines"].items():
        label = "ours" if name == "PPM" else "Cycles"
        lines.append(f"| {label} | {e['noise_rms']:.5f} | {e['noise_rms_bright']:.5f} | "
                     f"{e['noise_rms_rest']:.5f} | {e['noise_median']:.5f} | {e['mean']:.4f} | "
                     f"{e['wall_s']:.2f} | "
                     f"{e['samples_per_s']:.1f} |")
    lines.append(f"\nours/Cycles: noise per sample {d['ratio_noise']:.3f} (median pixel's "
                 f"{d['ratio_noise_median']:.3f}), samples per second "
                 f"{d['ratio_speed']:.3f}, so RMSE at equal time about "
                 f"{d['implied_equal_time_ratio']:.3f}")
    return "\n".join(lines)
