"""``python -m ppm_engine bench --digest [--compare OLD.json]``: a fingerprint of the images the
engine renders, to show that a change meant to keep every pixel (a refactoring, a formatting)
keeps it: render with the old code, then with the new, and compare.

Each example scene (the benchmark's five) and a material zoo (the Cornell box with a node-graph
material on every surface: procedural textures, a ramp, Mix, Math, the Light Path node, a Bump,
coat and sheen; a Sky Texture world) is exported once at 32x32 and rendered through the
Renderer for 4 passes of 4,096 photons, seed 3, with each indirect-light mode, unspecialised
kernels and the exact gather; the digest is the SHA-256 of each image (and of its extra passes)
and of the exported arrays.

The photon pass stores photons in the order its atomic counter hands out slots, which depends on
how the device schedules work-items: only with PoCL on one thread (its own variable,
``POCL_MAX_PTHREAD_COUNT=1``, set before the command) is that order, and so every image that
gathers photons, the same from run to run.  The JSON records whether it was set; ``--compare``
says which images can differ without it."""
from __future__ import annotations

import dataclasses
import hashlib
import json
import os
from pathlib import Path

import numpy as np

RESOLUTION = 32
PASSES = 4
CONFIGS = {"auto": {}, "photons": {"indirect": "photons"}, "paths": {"indirect": "paths"},
           "unspecialised": {"specialize": False},
           "exact": {"exact_gather": True, "indirect": "photons"}}
SCENES = ("cornell_box", "bulb_box", "glass_caustic", "mirror_caustic", "furnace", "zoo")


def _sha(*arrays) -> str:
    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()[:16]


def material_zoo(bpy):
    """The Cornell box with one node-graph material on every surface but the lamp and a Sky
    Texture world (the shader program interpreter's commonest ops at every hit)."""
    from ppm_engine.blender.scenes import build_example
    scene = build_example("cornell_box")
    m = bpy.data.materials.new("zoo")
    nt = m.node_tree
    p = nt.nodes["Principled BSDF"]
    n = {k: nt.nodes.new(f"ShaderNode{k}") for k in ("TexCoord", "TexNoise", "TexVoronoi",
                                                       "ValToRGB", "Bump", "Mix", "Math",
                                                       "LightPath")}
    n["Mix"].data_type, n["Math"].operation = "RGBA", "SINE"
    links = ((n["TexCoord"].outputs["Object"], n["TexNoise"].inputs["Vector"]),
             (n["TexCoord"].outputs["Generated"], n["TexVoronoi"].inputs["Vector"]),
             (n["TexNoise"].outputs["Fac"], n["ValToRGB"].inputs["Fac"]),
             (n["ValToRGB"].outputs["Color"], n["Mix"].inputs[6]),
             (n["TexVoronoi"].outputs["Color"], n["Mix"].inputs[7]),
             (n["LightPath"].outputs["Is Camera Ray"], n["Math"].inputs[0]),
             (n["Math"].outputs[0], n["Mix"].inputs[0]),
             (n["Mix"].outputs[2], p.inputs["Base Color"]),
             (n["TexNoise"].outputs["Fac"], n["Bump"].inputs["Height"]),
             (n["Bump"].outputs["Normal"], p.inputs["Normal"]))
    for a, b in links:
        nt.links.new(a, b)
    p.inputs["Roughness"].default_value = 0.3
    p.inputs["Coat Weight"].default_value = 0.3
    p.inputs["Sheen Weight"].default_value = 0.2
    for o in scene.objects:
        if o.type == "MESH" and o.data.materials and not any(
                s.material is not None and s.material.name.lower().startswith(("light", "lamp"))
                for s in o.material_slots):
            o.data.materials[0] = m
    world = scene.world or bpy.data.worlds.new("World")
    scene.world = world
    sky = world.node_tree.nodes.new("ShaderNodeTexSky")
    bg = world.node_tree.nodes["Background"]
    world.node_tree.links.new(sky.outputs["Color"], bg.inputs["Color"])
    bg.inputs["Strength"].default_value = 0.05
    return scene


def _export(bpy, name: str):
    from ppm_engine.blender.export import export_scene
    from ppm_engine.blender.scenes import build_example
    scene = material_zoo(bpy) if name == "zoo" else build_example(name)
    scene.render.resolution_x = scene.render.resolution_y = RESOLUTION
    scene.render.resolution_percentage = 100
    return export_scene(bpy.context.evaluated_depsgraph_get())


def run_digest(device: str = "", scenes=SCENES, configs=tuple(CONFIGS), progress=print) -> dict:
    """{"images": {"scene/config": digest, "scene/config/passes": ..., "scene/arrays": ...},
    "single_thread": whether PoCL ran on one thread}."""
    import bpy

    from ppm_engine.render.options import RenderOptions
    from ppm_engine.render.renderer import Renderer
    out = {}
    for name in scenes:
        arrays = _export(bpy, name)
        out[f"{name}/arrays"] = _sha(*(getattr(arrays, f.name)
                                       for f in dataclasses.fields(arrays)
                                       if isinstance(getattr(arrays, f.name), np.ndarray)))
        for cfg in configs:
            r = Renderer(arrays, RenderOptions(device=device, photons_per_pass=4096, seed=3,
                                               **CONFIGS[cfg]))
            for _ in range(PASSES):
                r.iterate()
            aux = r.passes()
            out[f"{name}/{cfg}"] = _sha(r.image())
            out[f"{name}/{cfg}/passes"] = _sha(*(aux[k] for k in sorted(aux)))
            progress(f"digest {name} {cfg}: {out[f'{name}/{cfg}']}")
            r.close()
    return {"images": out, "single_thread": os.environ.get("POCL_MAX_PTHREAD_COUNT") == "1",
            "resolution": RESOLUTION, "passes": PASSES}


def compare(new: dict, old_path: str) -> tuple[str, int]:
    """The report of the differences from the digest at ``old_path``, and how many images
    differ."""
    old = json.loads(Path(old_path).read_text())
    a, b = old["images"], new["images"]
    differ = sorted(k for k in set(a) | set(b) if a.get(k) != b.get(k))
    lines = [f"{len(b) - len(differ)} of {len(b)} digests as in {old_path}"]
    lines += [f"  differs: {k}" for k in differ]
    if not (old.get("single_thread") and new.get("single_thread")) and differ:
        lines.append("  (a run without POCL_MAX_PTHREAD_COUNT=1: the images that gather "
                     "photons may differ by the photons' order alone)")
    return "\n".join(lines), len(differ)
