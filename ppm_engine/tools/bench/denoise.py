"""``python -m ppm_engine bench --denoise``: denoised renders against the reference, ours through
Intel Open Image Denoise (scene.ppm.denoise: ppm_engine/render/denoise.py) beside Cycles with
its own OIDN at the same time budget (docs/BENCHMARKS.md, "Denoising").

Each scene's reference is the error-against-time run's (curves.Bench: two independent halves,
averaged; its pixels and its noise).  At each budget, ours renders once with Denoise on and
Cycles once with ``use_denoising`` (denoiser OPENIMAGEDENOISE, Cycles' default input passes,
prefilter and quality: albedo and normal, accurate, high), each to a multilayer EXR whose Noisy
Image pass is the image before denoising: so the noisy and the denoised RMSE of one render.
Both denoise after their time limit (ours: its last pass; Cycles: its last sample), outside
the budget; the seconds our denoiser took are in the JSON (``denoise_s``).  Photon-mapping
noise (blotches the size of the gather radius) is not what OIDN was trained on: this measures
what it does with it."""
from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path

import numpy as np

from ppm_engine.tools.bench.scoring import errors

SCENES = ("cornell_box", "furnace", "bulb_box", "rough_caustic", "mirror_caustic",
          "glossy_metal", "hdri_sun")
TIMES = (4.0, 16.0)


def _layers(path) -> dict:
    """RGB of each pass of a multilayer EXR (top-down): name -> (h, w, 3)."""
    import OpenEXR
    with OpenEXR.File(str(path)) as f:
        ch = {k: np.asarray(v.pixels) for p in f.parts for k, v in p.channels.items()}
    return {k.split(".", 1)[1]: v[..., :3] for k, v in ch.items()
            if k.endswith(("Combined", "Noisy Image"))}


def _shot(bench, scene, engine: str, seconds: float, seed: int) -> tuple[dict, float]:
    """One render of ``scene`` by ``engine`` with denoising on: ({"noisy", "denoised"}: RGB,
    wall seconds)."""
    import bpy

    from ppm_engine.blender.harness import cycles_reference
    from ppm_engine.tools.bench.curves import ppm_settings
    from ppm_engine.tools.bench.scenes import set_light_paths
    bench.count += 1
    if engine == "PPM":
        ppm_settings(scene, seconds, seed, bench.device, bench.photons,
                     specialize=not bench.quick)
        scene.ppm.denoise = True
    else:
        cycles_reference(scene, seconds=seconds, seed=seed)
        c = scene.cycles
        c.use_denoising, c.denoiser = True, "OPENIMAGEDENOISE"
        scene.view_layers[0].cycles.use_denoising = True
    set_light_paths(scene, bench.name)
    s = scene.render.image_settings
    s.media_type, s.file_format, s.color_depth = "MULTI_LAYER_IMAGE", "OPEN_EXR_MULTILAYER", "32"
    path = bench.folder / f"d{bench.count:04d}.exr"
    scene.render.filepath = str(path)
    t = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    wall = time.perf_counter() - t
    if engine == "PPM":
        scene.ppm.denoise = False
    else:
        scene.cycles.use_denoising = False
    layers = _layers(path)
    return {"noisy": layers["Noisy Image"], "denoised": layers["Combined"]}, wall


def run_denoise(times=TIMES, resolution: int = 128, scenes=SCENES,
                ref_seconds: float | None = None, device: str = "", progress=print,
                quick: bool = False) -> dict:
    """Per scene and budget: ours and Cycles, noisy and denoised, RMSE against the
    reference."""
    import bpy  # noqa: F401 -- fail early without Blender

    from ppm_engine.blender.harness import ensure_registered
    from ppm_engine.render.denoise import DenoiserUnavailable, denoise, load
    from ppm_engine.tools.bench.curves import REF_SEEDS, REF_TIME_FACTOR, REFERENCE_ENGINE, Bench
    from ppm_engine.tools.bench.scenes import excluded_pixels
    ensure_registered()
    try:
        load()
    except DenoiserUnavailable as e:
        from ppm_engine.errors import UsageError
        raise UsageError(f"--denoise: {e}") from None
    times = tuple(float(t) for t in times)
    ref_seconds = ref_seconds or max(2.0 * max(times), 1.0)
    out = {"times": list(times), "resolution": resolution, "ref_seconds_per_half": ref_seconds,
           "started": time.strftime("%Y-%m-%d %H:%M:%S"), "scenes": {}}
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="ppm-bench-denoise-") as tmp:
        b = Bench(resolution, device, None, Path(tmp), progress, warm_up=False, quick=quick)
        for name in scenes:
            scene = b._scene(name)
            keep = ~excluded_pixels(scene, name, resolution, resolution)
            ref_engine = REFERENCE_ENGINE[name]
            if ref_engine == "LUXCORE_LIGHT":
                from ppm_engine.tools.bench import luxcore
                if luxcore.unavailable() is not None:
                    ref_engine = "LIGHT_TRACE"
            factor = REF_TIME_FACTOR.get(name, REF_TIME_FACTOR.get(ref_engine, 1.0))
            half_s = ref_seconds * (1.0 if quick else factor)
            halves = []
            for seed in REF_SEEDS:
                progress(f"[{name}] reference half (seed {seed}): {ref_engine}, {half_s:g} s")
                img, cover = b.reference_half(scene, ref_engine, half_s, seed)
                if cover is not None:
                    keep &= cover
                halves.append(img)
            ref = 0.5 * (halves[0] + halves[1])
            noise = errors(halves[0], halves[1], keep)["rmse"] / 2
            row = {"reference": ref_engine, "reference_noise_rmse": noise,
                   "reference_mean": float(ref[keep].mean()), "pixels": int(keep.sum()),
                   "budgets": []}
            if not quick:                          # kernels built before the timed renders
                _shot(b, scene, "PPM", 0.25, 1)
            for budget in times:
                entry = {"seconds": budget}
                for engine, key in (("PPM", "ours"), ("CYCLES", "cycles")):
                    imgs, wall = _shot(b, scene, engine, budget, 1)
                    entry[key] = {k: errors(v, ref, keep, noise)["rmse"]
                                  for k, v in imgs.items()}
                    entry[key]["wall_s"] = wall
                    if engine == "PPM":            # what our denoiser alone costs here
                        aux = np.full_like(imgs["noisy"], 0.5)
                        t = time.perf_counter()
                        denoise(imgs["noisy"], aux, aux)
                        entry[key]["denoise_s"] = time.perf_counter() - t
                    progress(f"[{name}] {key:6s} {budget:g} s: RMSE noisy "
                             f"{entry[key]['noisy']:.4g}, denoised {entry[key]['denoised']:.4g}"
                             f" (wall {wall:.1f} s)")
                row["budgets"].append(entry)
            out["scenes"][name] = row
    out["total_s"] = time.perf_counter() - t0
    return out


def format_denoise(res: dict) -> str:
    """The table: RMSE noisy and denoised, ours and Cycles', and the ratio of the denoised
    ones, raw and with the reference's own noise taken out (sqrt(RMSE^2 - noise^2): denoised
    errors come near that noise)."""
    corr = lambda rmse, noise: math.sqrt(max(rmse * rmse - noise * noise, 0.0))
    lines = [f"Denoised RMSE against the reference, {res['resolution']}x{res['resolution']} "
             "(ours: OIDN through the Denoise option; Cycles: its OIDN; both with albedo and "
             "normal, prefilter accurate, quality high)", "",
             "| scene | reference (noise RMSE) | time (s) | ours noisy | ours denoised "
             "| Cycles noisy | Cycles denoised | denoised ours / Cycles | corrected for ref. "
             "noise | ours: denoised / noisy | Cycles: denoised / noisy |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for name, row in res["scenes"].items():
        n = row["reference_noise_rmse"]
        for e in row["budgets"]:
            o, c = e["ours"], e["cycles"]
            cc = corr(c["denoised"], n)
            lines.append(
                f"| {name} | {row['reference']} ({n:.4f}) | {e['seconds']:g} | "
                f"{o['noisy']:.4f} | {o['denoised']:.4f} | {c['noisy']:.4f} | "
                f"{c['denoised']:.4f} | **{o['denoised'] / c['denoised']:.2f}** | "
                f"{corr(o['denoised'], n) / cc if cc > 0 else float('nan'):.2f} | "
                f"{o['denoised'] / o['noisy']:.2f} | {c['denoised'] / c['noisy']:.2f} |")
    return "\n".join(lines)
