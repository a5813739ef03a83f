"""``python -m ppm_engine bench --glossy``: where glossy lobes should hold visible points
(RenderOptions.gather_roughness; docs/BENCHMARKS.md, "Materials and shader programs"), and with
``--glossy-setting caustic_roughness`` which glossy reflections' light is the eye paths' rather
than caustic photons' (RenderOptions.caustic_roughness; "Settings chosen by
measurement").

A scene of glossy materials (a mirror-like metal at roughness 0.15, a plastic at 0.3, a coated
red, a rough metal at 0.45, rough glass at 0.3) on a glossy floor under an area light (or, with
``--glossy-light point``, a point light of radius 2 cm in its place: the glossy metal under a
small light users bring), rendered by Cycles for a long time (the reference: path tracing
converges on this scene) and, for each value of the setting, by this engine for the same
budget with two seeds; Cycles at the budget for comparison.  Ours renders through the
engine's public core (the exported SceneArrays, a Renderer with the setting, passes until the
budget), Cycles through bpy.
"""
from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

from ppm_engine.blender.harness import cycles_reference, read_exr, set_output
from ppm_engine.render.options import RenderOptions
from ppm_engine.render.renderer import Renderer

DEFAULT_VALUES = (0.2, 0.35, 0.5, 0.7, 1.5)
# the settings --glossy measures (RenderOptions fields) and the values each is measured at
SETTINGS = {"gather_roughness": DEFAULT_VALUES,
            "caustic_roughness": (0.1, 0.2, 0.3, 0.45, 0.7)}
LIGHTS = ("area", "point")
_SPHERES = (  # name, location, Principled inputs
    ("glossy_metal", (-1.1, 0.3), {"Base Color": (0.8, 0.8, 0.85), "Metallic": 1.0,
                                   "Roughness": 0.15}),
    ("plastic", (0.0, 0.6), {"Base Color": (0.7, 0.2, 0.1), "Roughness": 0.3}),
    ("rough_metal", (1.1, 0.3), {"Base Color": (0.9, 0.6, 0.3), "Metallic": 1.0,
                                 "Roughness": 0.45}),
    ("coat", (-0.55, -0.6), {"Base Color": (0.6, 0.05, 0.05), "Roughness": 0.6,
                             "Coat Weight": 1.0, "Coat Roughness": 0.05}),
    ("rough_glass", (0.6, -0.7), {"Transmission Weight": 1.0, "Roughness": 0.3}),
)


def _principled(mat, inputs):
    p = mat.node_tree.nodes["Principled BSDF"]
    for k, v in inputs.items():
        p.inputs[k].default_value = (*v, 1.0) if isinstance(v, tuple) else v


def build_scene(res: int, light_kind: str = "area"):
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    for name, (x, y), inputs in _SPHERES:
        bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=0.45,
                                             location=(x, y, 0))
        bpy.ops.object.shade_smooth()
        m = bpy.data.materials.new(name)
        _principled(m, inputs)
        bpy.context.active_object.data.materials.append(m)
    bpy.ops.mesh.primitive_plane_add(size=10, location=(0, 0, -0.45))
    floor = bpy.data.materials.new("Floor")
    _principled(floor, {"Base Color": (0.5, 0.5, 0.5), "Roughness": 0.6})
    bpy.context.active_object.data.materials.append(floor)
    if light_kind == "point":
        light = bpy.data.lights.new("Area", "POINT")
        light.energy, light.shadow_soft_size = 80.0, 0.02
    else:
        light = bpy.data.lights.new("Area", "AREA")
        light.energy, light.size = 80.0, 0.6
    lo = bpy.data.objects.new("Area", light)
    lo.location, lo.rotation_euler = (1.5, -1.0, 2.5), (0.4, 0.5, 0.0)
    scene.collection.objects.link(lo)
    world = bpy.data.worlds.new("World")
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.05, 0.05, 0.06, 1)
    scene.world = world
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location, cam.rotation_euler = (0, -4.2, 1.6), (1.22, 0, 0)
    cam.data.lens = 40
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.render.resolution_x = scene.render.resolution_y = res
    scene.render.resolution_percentage = 100
    scene.render.dither_intensity = 0.0
    bpy.context.view_layer.update()
    return scene


def _cycles(scene, path, **kw) -> np.ndarray:
    import bpy
    cycles_reference(scene, **kw)
    set_output(scene, path)
    bpy.ops.render.render(write_still=True)
    return read_exr(path)[..., :3]


def _ours(arrays, options: RenderOptions, seconds: float) -> tuple[np.ndarray, int]:
    """Passes for ``seconds`` after a first one that builds the kernels (a build is not what
    the budget measures: each gather roughness has programs of its own)."""
    r = Renderer(arrays, options)
    r.iterate()
    t0 = time.perf_counter()
    passes = 1
    while time.perf_counter() - t0 < seconds:
        r.iterate()
        passes += 1
    img = r.image()[::-1, :, :3]            # rows bottom-up -> top-down, as the EXRs
    r.close()
    return img, passes


def run_glossy(seconds: float, res: int, ref_samples: int, values=DEFAULT_VALUES,
               device: str = "", progress=print, setting: str = "gather_roughness",
               light: str = "area") -> dict:
    import bpy

    from ppm_engine.blender.export import export_scene
    if setting not in SETTINGS or light not in LIGHTS:
        raise ValueError(f"setting {setting!r} or light {light!r} unknown")
    scene = build_scene(res, light)
    folder = Path(tempfile.mkdtemp(prefix="ppm-glossy-"))
    t = time.perf_counter()
    ref = _cycles(scene, folder / "ref.exr", samples=ref_samples)
    ref_s = time.perf_counter() - t
    progress(f"glossy: reference ({ref_samples} samples) in {ref_s:.0f} s")
    rmse = lambda img: float(np.sqrt(np.mean((img - ref).astype(np.float64) ** 2)))
    out = {"seconds": seconds, "resolution": res, "reference_samples": ref_samples,
           "setting": setting, "light": light,
           "reference_seconds": ref_s, "mean": float(ref.mean())}
    out["cycles"] = rmse(_cycles(scene, folder / "cycles.exr", seconds=seconds))
    arrays = export_scene(bpy.context.evaluated_depsgraph_get())
    rows = []
    for v in values:
        errs, passes = [], []
        for seed in (1, 2):
            img, n = _ours(arrays, RenderOptions(**{setting: v}, seed=seed, device=device),
                           seconds)
            errs.append(rmse(img))
            passes.append(n)
        rows.append({setting: v, "rmse": errs, "passes": passes})
        progress(f"glossy: {setting} {v}: RMSE {np.mean(errs):.4f}")
    out["ours"] = rows
    return out


def format_glossy(res: dict) -> str:
    setting = res.get("setting", "gather_roughness")
    lines = [f"{res['resolution']}x{res['resolution']}, {res.get('light', 'area')} light, "
             f"{res['seconds']:g} s each; reference: "
             f"Cycles, {res['reference_samples']} samples (mean {res['mean']:.4f}); Cycles at "
             f"{res['seconds']:g} s: RMSE {res['cycles']:.4f}", "",
             f"| {setting.replace('_', ' ')} (sqrt alpha) | RMSE, seeds 1 and 2 | mean | / Cycles "
             "| passes |",
             "|---:|---:|---:|---:|---:|"]
    for r in res["ours"]:
        m = float(np.mean(r["rmse"]))
        lines.append(f"| {r[setting]:g} | {r['rmse'][0]:.4f}, {r['rmse'][1]:.4f} | "
                     f"{m:.4f} | {m / res['cycles']:.2f} | {r['passes'][0]} |")
    return "\n".join(lines)
