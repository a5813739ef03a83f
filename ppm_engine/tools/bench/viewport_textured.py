"""``bench --viewport``: value edits of a 100K-triangle textured scene through the engine's
own view_update (docs/BENCHMARKS.md, "Viewport")."""
from __future__ import annotations

import time

from ppm_engine.tools.bench.viewport_latency import TARGETS, _at_full_resolution, _setup, _stat


def textured_scene(bpy, size, device: str, segments: int = 256, rings: int = 200,
                   image_px: int = 2048):
    """The Cornell box with a UV sphere of ``segments`` x ``rings`` (256 x 200: 101,888
    triangles) whose colour is an ``image_px``-square image (Blender's UV grid) and a point
    light: a 100K-triangle textured scene."""
    _, scene = _setup("cornell_box", size, device)
    img = bpy.data.images.new("Grid", image_px, image_px)
    img.generated_type = 'UV_GRID'
    mat = bpy.data.materials.new("Textured")
    nt = mat.node_tree
    tex = nt.nodes.new("ShaderNodeTexImage")
    tex.image = img
    nt.links.new(tex.outputs["Color"], nt.nodes["Principled BSDF"].inputs["Base Color"])
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.25, location=(0.0, 0.0, 0.3),
                                         segments=segments, ring_count=rings)
    ball = bpy.context.object
    ball.name = "Ball"
    ball.data.materials.append(mat)
    fill = bpy.data.objects.new("Fill", bpy.data.lights.new("Fill", 'POINT'))
    fill.data.energy = 5.0
    fill.location = (0.0, -0.5, 1.5)
    scene.collection.objects.link(fill)
    bpy.context.view_layer.update()
    return scene, ball, mat


def textured_edits(size, moves: int, device: str, rng, progress=print) -> dict:
    """Edits of the 100K-triangle textured scene (textured_scene) through the engine's own
    view_update hand-off (ViewportDriver, on the depsgraph updates Blender reports): each timed
    from view_update's call (Blender's evaluation done) to the first new image.  Each edit
    twice: with the mesh data and images kept across exports, and with them dropped before
    each export (every mesh and image read again, as every edit did before)."""
    import bpy

    from ppm_engine.blender.viewport import ViewportDriver
    scene, ball, mat = textured_scene(bpy, size, device)     # the scene camera (no 3D view)

    class Engine:
        def update_stats(self, *_):
            pass

        def report(self, *_):
            pass

        def tag_redraw(self):
            pass

    drv, eng = ViewportDriver(), Engine()
    drv.view_update(eng, bpy.context, bpy.context.evaluated_depsgraph_get())
    s = drv.session
    if not s.wait(lambda s: s.frame() is not None, timeout=600):
        raise RuntimeError(f"the viewport showed no image: {s.status()}")
    n_tri = int(s._renderer.scene.scene.positions.shape[0]) if s._renderer else 0
    s.wait(lambda s: s.frame().divider == 1 and s.frame().passes >= 2, timeout=600)
    f = s.frame()
    t_full = time.perf_counter()
    s.wait(lambda s: s.frame().passes > f.passes, timeout=600)
    pass_s = time.perf_counter() - t_full
    clock = {}
    drop = [False]

    def handler(_scene, depsgraph):
        if drop[0] and drv.meshes is not None:
            drv.meshes.clear()
            drv.images.clear()
        clock["t0"] = time.perf_counter()
        clock["restarts"] = s.restarts
        e = drv.exports
        drv.view_update(eng, bpy.context, depsgraph)
        clock["export_s"] = time.perf_counter() - clock["t0"] if drv.exports > e else 0.0

    bsdf = mat.node_tree.nodes["Principled BSDF"]
    white = bpy.data.materials["White"].node_tree.nodes["Principled BSDF"]
    light = bpy.data.objects["Fill"]
    edits = {
        "colour": lambda k: setattr(white.inputs["Base Color"], "default_value",
                                    (0.8, 0.8, 0.8, 1) if k % 2 else (0.7, 0.75, 0.8, 1)),
        "roughness": lambda k: setattr(bsdf.inputs["Roughness"], "default_value",
                                       0.2 if k % 2 else 0.6),
        "light": lambda k: setattr(light.data, "energy", light.data.energy * (1.1 if k % 2
                                                                              else 1 / 1.1)),
        # a new place at every move, as a drag (a place seen before may find its casters'
        # spheres kept: casters.caster_tree)
        "transform": lambda k: setattr(ball, "location", (ball.location.x + 0.02, 0.0, 0.3)),
        "lens": lambda k: setattr(scene.camera.data, "lens",
                                  scene.camera.data.lens * (1.02 if k % 2 else 1 / 1.02)),
    }
    out = {"triangles": n_tri, "image_px": 2048, "full_pass_s": pass_s}
    bpy.app.handlers.depsgraph_update_post.append(handler)
    try:
        builds = s._device.programs.builds
        for mode in ("kept", "reread"):
            drop[0] = mode == "reread"
            for name, edit in edits.items():
                progress(f"viewport: 100K textured scene, {name} ({mode})")
                total, export = [], []
                for k in range(moves):
                    _at_full_resolution(s, rng, pass_s)
                    edit(k)
                    bpy.context.view_layer.update()      # view_update in the handler
                    if not s.wait(lambda s: s.frame() is not None
                                  and s.frame().restart > clock["restarts"], timeout=120):
                        raise RuntimeError(f"no new image: {s.status()}")
                    total.append(time.perf_counter() - clock["t0"])
                    export.append(clock["export_s"])
                out[f"{name}_{mode}_s"], out[f"{name}_{mode}_export_s"] = total, export
        out["edit_builds"] = s._device.programs.builds - builds
        out["actions"] = {a: s.actions.count(a) for a in set(s.actions)}
    finally:
        bpy.app.handlers.depsgraph_update_post.remove(handler)
        drv.close()
    out["table"] = format_textured(out)
    return out


def format_textured(d: dict) -> str:
    lines = [f"{d['triangles']:,}-triangle textured scene (the Cornell box with a 256 x 200 "
             f"UV sphere, a {d['image_px']}-square image), through view_update "
             f"(ViewportDriver); one full pass {d['full_pass_s']:.2f} s:", "",
             "| edit | to the first new image, mesh data kept | its export | every mesh and "
             "image read again (before) | its export | target |",
             "|---|---:|---:|---:|---:|---:|"]
    for name in ("colour", "roughness", "light", "transform", "lens"):
        lines.append(f"| {name} | {_stat(d[f'{name}_kept_s'])} | "
                     f"{_stat(d[f'{name}_kept_export_s'])} | {_stat(d[f'{name}_reread_s'])} | "
                     f"{_stat(d[f'{name}_reread_export_s'])} | {TARGETS['material_s']} |")
    lines += ["", f"Kernel builds during these edits: {d['edit_builds']} (actions: "
              + ", ".join(f"{k} {v}" for k, v in sorted(d["actions"].items())) + ")."]
    return "\n".join(lines)
