"""``python -m ppm_engine bench --strategies``: what each strategy contributes to a scene's image
(docs/BENCHMARKS.md, "What each strategy brings").  Each scene renders for a time budget with the
default settings; the film's sums say how much of the image each strategy brought:

- camera paths: direct light, emitters seen, and (with eye paths) the diffuse indirect light;
- the merge: photons gathered at visible points, weighted by their side of the balance
  heuristic where the camera sees the point directly (kernels/integrator/eye_pass.cl);
- light tracing: the photons connected to the camera (kernels/integrator/photon_pass.cl
connect_camera).

Over the whole image and over the scene's caustic pixels (bench/scenes.py), as shares of the
mean; and, for the photons' light alone, the light tracing's share (its MIS weights' share of
the paths both can render, plus what only it renders)."""
from __future__ import annotations

import time

import numpy as np

from ppm_engine.render.options import RenderOptions
from ppm_engine.render.renderer import Renderer
from ppm_engine.tools.bench.scenes import caustic_mask

SCENES = ("point_caustic", "rough_caustic", "glass_caustic", "mirror_caustic", "bulb_box")
SHARE_KEY = "light tracing of the photons' light"


def shares(renderer: Renderer) -> dict:
    """Per pixel (h, w, rgb mean) the three parts of the image from the film's sums."""
    f = renderer.film
    direct = f.read_sum("direct")
    moments = f.read_sum("moments")
    photons = np.maximum(moments[..., 2:3], 1.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        camera = np.where(direct[..., 3:] > 0, direct[..., :3] / direct[..., 3:], 0.0)
    merge = f.read_sum("photon_sum")[..., :3] / (np.pi * photons)
    lt = f.read_sum("lt_sum")[..., :3] / photons
    return {k: v.mean(axis=-1) * f.exposure for k, v in
            (("camera paths", camera), ("merge", merge), ("light tracing", lt))}


def run_strategies(seconds: float, resolution: int, scenes=SCENES, device: str = "",
                   progress=print) -> dict:
    import bpy

    from ppm_engine.blender.export import export_scene
    from ppm_engine.blender.harness import ensure_registered
    from ppm_engine.blender.scenes import build_example
    ensure_registered()
    out = {"seconds": seconds, "resolution": resolution, "scenes": {}}
    for name in scenes:
        scene = build_example(name)
        scene.render.resolution_x = scene.render.resolution_y = resolution
        scene.render.resolution_percentage = 100
        bpy.context.view_layer.update()
        r = Renderer(export_scene(bpy.context.evaluated_depsgraph_get()),
                     RenderOptions(device=device, seed=1))
        t = time.perf_counter()
        while time.perf_counter() - t < seconds:
            s = r.iterate()
        parts = shares(r)
        mask = caustic_mask(scene, name, resolution, resolution)[::-1]    # row 0 = bottom
        row = {"passes": s.pass_index, "indirect": s.indirect, "light_tracing": s.light_tracing}
        for region, m in (("image", np.ones_like(mask)), ("caustic", mask)):
            total = sum(p[m].mean() for p in parts.values())
            row[region] = {k: float(p[m].mean() / total) if total > 0 else 0.0
                           for k, p in parts.items()}
            photo = parts["merge"][m].mean() + parts["light tracing"][m].mean()
            row[region][SHARE_KEY] = (
                float(parts["light tracing"][m].mean() / photo) if photo > 0 else 0.0)
        out["scenes"][name] = row
        r.close()
        progress(f"[{name}] {s.pass_index} passes: " + "; ".join(
            f"{region}: " + ", ".join(f"{k} {v:.3f}" for k, v in row[region].items())
            for region in ("image", "caustic")))
    return out


def format_strategies(res: dict) -> str:
    lines = [f"What each strategy brings, {res['resolution']}x{res['resolution']}, "
             f"{res['seconds']:g} s (shares of the mean)", "",
             "| scene | region | camera paths | merge | light tracing "
             "| light tracing of the photons' light |", "|---|---|---:|---:|---:|---:|"]
    for name, row in res["scenes"].items():
        for region in ("image", "caustic"):
            r = row[region]
            lines.append(f"| {name} | {region} | {r['camera paths']:.3f} | {r['merge']:.3f} | "
                         f"{r['light tracing']:.3f} | {r[SHARE_KEY]:.3f} |")
    return "\n".join(lines)
