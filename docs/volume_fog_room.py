"""The fog room against Cycles at equal time (docs/VOLUMES.md, "Measured against Cycles"): a
floor, a back wall and a 3 m cube of fog (Principled Volume, density 0.8, colour 0.9) under a
spot light, Cycles' default Light Paths, 48 x 48 pixels; the RMSE of this engine and of Cycles
after ``seconds`` each against a long Cycles render.

    python docs/volume_fog_room.py 8192 4 16
"""
import sys
import tempfile
import time
from pathlib import Path

import bpy

import numpy as np

from ppm_engine.blender.harness import cycles_reference, ensure_registered, read_exr, set_output
from ppm_engine.render.device import list_devices

W = 48


def _material(name, volume=None, color=(0.6, 0.6, 0.6)):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    bsdf = nt.nodes["Principled BSDF"]
    if volume is None:
        bsdf.inputs["Base Color"].default_value = (*color, 1)
        bsdf.inputs["Roughness"].default_value = 1.0
        bsdf.inputs["Specular IOR Level"].default_value = 0.0
        return m
    nt.nodes.remove(bsdf)
    v = nt.nodes.new("ShaderNodeVolumePrincipled")
    v.inputs["Density"].default_value = volume
    v.inputs["Color"].default_value = (0.9, 0.9, 0.9, 1)
    nt.links.new(v.outputs[0], nt.nodes["Material Output"].inputs["Volume"])
    return m


def fog_room():
    """The scene of tests/test_volumes.py fog_room (density 0.8), Cycles' default Light Paths."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.world = bpy.data.worlds.new("W")
    scene.world.use_nodes = True
    scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0, 0, 0, 1)
    cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
    cam.location, cam.rotation_euler, cam.data.lens = (0, -6, 1.5), (1.35, 0, 0), 35.0
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.render.dither_intensity = 0.0
    scene.cycles.pixel_filter_type, scene.cycles.filter_width = "BOX", 1.0
    scene.render.filter_size = 0.0
    grey = _material("Grey")
    for loc, rot in (((0, 0, -1.2), (0, 0, 0)), ((0, 3, 2), (1.5708, 0, 0))):
        bpy.ops.mesh.primitive_plane_add(size=8.0, location=loc, rotation=rot)
        bpy.context.active_object.data.materials.append(grey)
    bpy.ops.mesh.primitive_cube_add(size=3.0, location=(0, 0, 0.6))
    bpy.context.active_object.data.materials.append(_material("Fog", volume=0.8))
    spot = bpy.data.lights.new("Spot", "SPOT")
    spot.energy, spot.spot_size, spot.shadow_soft_size = 800.0, 0.6, 0.0
    obj = bpy.data.objects.new("Spot", spot)
    obj.location = (0, 0, 3.5)
    scene.collection.objects.link(obj)
    scene.render.resolution_x = scene.render.resolution_y = W
    scene.render.resolution_percentage = 100
    return scene


def _render(scene, path):
    set_output(scene, path)
    t = time.time()
    assert bpy.ops.render.render(write_still=True) == {'FINISHED'}
    return read_exr(path)[..., :3], time.time() - t


def cycles(samples=None, seconds=0.0, seed=1):
    scene = fog_room()
    cycles_reference(scene, samples=samples, seconds=seconds, seed=seed)
    c = scene.cycles
    c.max_bounces, c.diffuse_bounces, c.glossy_bounces, c.transmission_bounces = 12, 4, 4, 12
    c.volume_bounces, c.transparent_max_bounces = 0, 8
    scene.render.resolution_x = scene.render.resolution_y = W
    return _render(scene, str(Path(tempfile.gettempdir()) / "fog_cycles.exr"))


def ours(seconds):
    scene = fog_room()
    scene.render.engine = "PPM"
    key = next(d.key for d in list_devices() if "pocl" in d.platform.lower()
               or "portable" in d.platform.lower())
    scene.ppm.device, scene.ppm.passes, scene.ppm.time_limit = key, 1 << 20, seconds
    return _render(scene, str(Path(tempfile.gettempdir()) / "fog_ours.exr"))


def main(ref_samples: int, times: list[float]) -> None:
    ensure_registered()
    ref, t = cycles(samples=ref_samples, seed=7)
    print(f"reference: Cycles {ref_samples} samples, {t:.0f} s, mean {ref.mean():.5f}")
    ours(1.0)                                   # (the kernels' build)
    for s in times:
        o, to = ours(s)
        c, tc = cycles(seconds=s, seed=3)
        rm = [float(np.sqrt(((a - ref) ** 2).mean())) for a in (o, c)]
        print(f"{s:g} s: this engine RMSE {rm[0]:.5f} (mean {o.mean():.5f}, {to:.1f} s), "
              f"Cycles {rm[1]:.5f} (mean {c.mean():.5f}, {tc:.1f} s): {rm[0] / rm[1]:.2f}x")


if __name__ == "__main__":
    main(int(sys.argv[1]), [float(x) for x in sys.argv[2:]] or [4.0, 16.0])
