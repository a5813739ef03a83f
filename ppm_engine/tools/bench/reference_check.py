"""Two light tracers on one benchmark scene, before one becomes the other's reference: LuxCore's
LIGHTCPU (``LUXCORE_LIGHT``, luxcore.py) and this engine's (``LIGHT_TRACE``,
ppm_engine/render/light_tracer.py), each rendered with two seeds, and how far apart they are
against their own noise (docs/history/benchmarks-notebook.md, "LuxCore's light tracer as the
reference").

    python -m ppm_engine.tools.bench.reference_check render SCENE LUXCORE_LIGHT --seconds 60 \
        --out DIR
    python -m ppm_engine.tools.bench.reference_check render SCENE LIGHT_TRACE --seconds 60 \
        --out DIR
    python -m ppm_engine.tools.bench.reference_check compare SCENE --out DIR

``render`` writes each seed's image (DIR/SCENE_ENGINE_SEED.npy, top-down) and the masks
(DIR/SCENE_ENGINE_masks.npz: the engine's coverage, the benchmark's kept and caustic pixels);
``compare`` prints the figures (``agreement``) as JSON.  One engine per command keeps each
command a few minutes long; both render the same scene the benchmark builds (curves.Bench).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
from pathlib import Path

import numpy as np

ENGINES = ("LUXCORE_LIGHT", "LIGHT_TRACE")
SEEDS = (1001, 2002)               # the benchmark's reference seeds (curves.REF_SEEDS)


def _rmse(a, b, pixels) -> float:
    d = (a - b)[pixels].astype(np.float64)
    return float(np.sqrt(np.mean(d * d))) if pixels.any() else float("nan")


def agreement(a: tuple, b: tuple, pixels: np.ndarray, caustic: np.ndarray) -> dict:
    """Two estimators' halves ``a`` = (a0, a1) and ``b`` = (b0, b1) over ``pixels`` and the
    ``caustic`` pixels: each one's mean (of its two halves' average) and noise (the RMSE of its
    average from the expectation, estimated as RMSE(half 0, half 1) / 2), the RMSE between the
    two averages, and what their noise alone would make it: sqrt(noise_a^2 + noise_b^2).  Two
    unbiased estimators give an RMSE within a few percent of that (more pixels, less spread)."""
    out = {}
    for region, m in (("image", pixels), ("caustic", caustic)):
        if not m.any():
            out[region] = {"pixels": 0}
            continue
        ma, mb = 0.5 * (a[0] + a[1]), 0.5 * (b[0] + b[1])
        na, nb = _rmse(a[0], a[1], m) / 2, _rmse(b[0], b[1], m) / 2
        r = {"pixels": int(m.sum()), "mean_a": float(ma[m].mean()),
             "mean_b": float(mb[m].mean()), "noise_a": na, "noise_b": nb,
             "rmse": _rmse(ma, mb, m), "rmse_from_noise": math.hypot(na, nb)}
        r["mean_a_over_b"] = r["mean_a"] / r["mean_b"]
        r["rmse_over_noise"] = r["rmse"] / r["rmse_from_noise"]
        # the means' own spread: each half's mean differs from their average by this much
        r["mean_noise_a"] = abs(float(a[0][m].mean() - a[1][m].mean())) / 2
        r["mean_noise_b"] = abs(float(b[0][m].mean() - b[1][m].mean())) / 2
        out[region] = r
    return out


def render(scene_name: str, engine: str, seconds: float, resolution: int, folder: Path,
           seeds=SEEDS, device: str = "") -> None:
    from ppm_engine.blender.harness import ensure_registered
    from ppm_engine.tools.bench.curves import Bench
    from ppm_engine.tools.bench.scenes import caustic_mask, excluded_pixels
    ensure_registered()
    folder.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="ppm-refcheck-") as tmp:
        b = Bench(resolution, device, None, Path(tmp), progress=print)
        scene = b._scene(scene_name)
        w = h = resolution
        keep = ~excluded_pixels(scene, scene_name, w, h)
        cmask = caustic_mask(scene, scene_name, w, h) & keep
        run = b.luxcore_light if engine == "LUXCORE_LIGHT" else b.light_traced
        for seed in seeds:
            img, wall, info, cover = run(seconds, seed)
            np.save(folder / f"{scene_name}_{engine}_{seed}.npy", img)
            print(f"{scene_name} {engine} seed {seed}: {wall:.1f} s wall, {info}", flush=True)
        np.savez(folder / f"{scene_name}_{engine}_masks.npz", coverage=cover, keep=keep,
                 caustic=cmask)


def compare(scene_name: str, folder: Path, seeds=SEEDS) -> dict:
    masks = {e: np.load(folder / f"{scene_name}_{e}_masks.npz") for e in ENGINES}
    # the pixels both render (LuxCore's leave out the frame's edge: curves.Bench)
    pixels = masks[ENGINES[0]]["keep"] & np.logical_and.reduce(
        [m["coverage"] for m in masks.values()])
    cmask = masks[ENGINES[0]]["caustic"] & pixels
    halves = {e: tuple(np.load(folder / f"{scene_name}_{e}_{s}.npy") for s in seeds)
              for e in ENGINES}
    out = agreement(halves["LUXCORE_LIGHT"], halves["LIGHT_TRACE"], pixels, cmask)
    return {"scene": scene_name, "a": "LUXCORE_LIGHT", "b": "LIGHT_TRACE", **out}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m ppm_engine.tools.bench.reference_check",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("action", choices=("render", "compare"))
    p.add_argument("scene")
    p.add_argument("engine", nargs="?", choices=ENGINES)
    p.add_argument("--seconds", type=float, default=60.0, help="per seed (default 60)")
    p.add_argument("--resolution", type=int, default=128)
    p.add_argument("--device", default="", help="OpenCL device of our light tracer")
    p.add_argument("--out", type=Path, required=True, metavar="DIR")
    a = p.parse_args(argv)
    if a.action == "render":
        if a.engine is None:
            p.error("render: name the engine (LUXCORE_LIGHT or LIGHT_TRACE)")
        render(a.scene, a.engine, a.seconds, a.resolution, a.out, device=a.device)
    else:
        print(json.dumps(compare(a.scene, a.out), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
