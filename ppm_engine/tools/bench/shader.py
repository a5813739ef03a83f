"""``python -m ppm_engine bench --shader SCENE``: what the shader programs cost per pass.

The example scene is rendered twice through the Renderer, passes interleaved so that both see
the same machine: once as built (constant materials: no program, the kernels without the
interpreter) and once with every Principled BSDF's Base Color routed through a small node graph
that computes the same colour at run time (Mix, factor Backfacing x 0 from a Geometry node:
three ops per hit that cannot fold).  The images must agree in the mean (their noise differs:
a material with a program leaves the Lambert short path, whose random numbers differ); the
difference in each phase's time is the cost of the program and of the general shader path it
takes, also given per pixel (eye, gather) and per photon."""
from __future__ import annotations

import time

import numpy as np


def drive_base_colors(bpy) -> int:
    """Every Principled BSDF's Base Color through Mix(A = its colour, factor = Backfacing x 0);
    returns how many materials changed."""
    n = 0
    for mat in bpy.data.materials:
        tree = mat.node_tree
        if tree is None:
            continue
        for p in [x for x in tree.nodes if x.bl_idname == "ShaderNodeBsdfPrincipled"]:
            sock = p.inputs["Base Color"]
            if sock.is_linked:
                continue
            geo, mul = tree.nodes.new("ShaderNodeNewGeometry"), tree.nodes.new("ShaderNodeMath")
            mul.operation, mul.inputs[1].default_value = "MULTIPLY", 0.0
            mix = tree.nodes.new("ShaderNodeMix")
            mix.data_type = "RGBA"
            mix.inputs[6].default_value = tuple(sock.default_value)
            mix.inputs[7].default_value = (1.0, 0.0, 1.0, 1.0)
            tree.links.new(geo.outputs["Backfacing"], mul.inputs[0])
            tree.links.new(mul.outputs[0], mix.inputs[0])
            tree.links.new(mix.outputs[2], sock)
            n += 1
    return n


def run_shader(scene_name: str, resolution: int = 128, passes: int = 8, warmup: int = 2,
               device: str = "", progress=print, specialize: bool = True) -> dict:
    """The scene with constant Base Colors against the same colours from shader programs,
    passes interleaved.  ``specialize``: each with its own kernels (what the figures are
    about: a plain material builds no interpreter); off for --quick, which checks the tooling
    and the image with the kernels of every feature that other renders share."""
    import bpy

    from ppm_engine.blender.export import export_scene
    from ppm_engine.blender.scenes import build_example
    from ppm_engine.render.options import RenderOptions
    from ppm_engine.render.renderer import Renderer
    scene = build_example(scene_name)
    scene.render.resolution_x = scene.render.resolution_y = resolution
    scene.render.resolution_percentage = 100
    plain = export_scene(bpy.context.evaluated_depsgraph_get())
    changed = drive_base_colors(bpy)
    driven = export_scene(bpy.context.evaluated_depsgraph_get())
    # the paper's passes (every phase has hits to shade: eye, photons, gather)
    opts = RenderOptions(device=device, seed=7, indirect="photons", specialize=specialize)
    renderers = {"constant": Renderer(plain, opts), "program": Renderer(driven, opts)}
    progress(f"shader: {scene_name} {resolution}x{resolution}, {changed} materials driven, "
             f"{renderers['program'].photons_per_pass} photons per pass, {warmup} warm-up + "
             f"{passes} timed passes each, interleaved")
    stats = {k: [] for k in renderers}
    wall = dict.fromkeys(renderers, 0.0)
    for i in range(warmup + passes):
        for k, r in renderers.items():
            t = time.perf_counter()
            s = r.iterate()
            if i >= warmup:
                wall[k] += time.perf_counter() - t
                stats[k].append(s)
    images = {k: r.image() for k, r in renderers.items()}
    for r in renderers.values():
        r.close()
    labels = ("eye", "photon", "gather")
    ms = {k: {lab: float(np.mean([s.phase_ms.get(lab, 0.0) for s in v])) for lab in labels}
          for k, v in stats.items()}
    ratio = float(np.mean(images["program"]) / max(float(np.mean(images["constant"])), 1e-30))
    pixels, photons = resolution * resolution, renderers["program"].photons_per_pass
    delta = {lab: ms["program"][lab] - ms["constant"][lab] for lab in labels}
    return {"scene": scene_name, "resolution": resolution, "passes": passes,
            "device": renderers["program"].device.info.name, "materials_driven": changed,
            "phase_ms": ms, "wall_ms": {k: 1e3 * v / passes for k, v in wall.items()},
            "delta_ms": delta, "image_mean_ratio": ratio,
            "ns_per_pixel_eye": 1e6 * delta["eye"] / pixels,
            "ns_per_pixel_gather": 1e6 * delta["gather"] / pixels,
            "ns_per_photon": 1e6 * delta["photon"] / photons}


def format_shader(d: dict) -> str:
    lines = [f"{d['scene']} {d['resolution']}x{d['resolution']}, mean of {d['passes']} passes "
             f"each, interleaved ({d['device']}); {d['materials_driven']} materials' Base Color "
             "computed by a shader program instead of a constant",
             "| phase | constant (ms) | program (ms) | difference |", "|---|---:|---:|---:|"]
    for lab, v in d["phase_ms"]["constant"].items():
        w = d["phase_ms"]["program"][lab]
        lines.append(f"| {lab} | {v:.2f} | {w:.2f} | {100 * (w - v) / max(v, 1e-9):+.1f} % |")
    c, p = d["wall_ms"]["constant"], d["wall_ms"]["program"]
    lines.append(f"| pass (wall) | {c:.2f} | {p:.2f} | {100 * (p - c) / max(c, 1e-9):+.1f} % |")
    lines.append(f"\nper hit: eye {d['ns_per_pixel_eye']:.0f} ns per pixel, gather "
                 f"{d['ns_per_pixel_gather']:.0f} ns per pixel, photons "
                 f"{d['ns_per_photon']:.0f} ns per photon; mean of the image with programs / "
                 f"without: {d['image_mean_ratio']:.4f}")
    return "\n".join(lines)
