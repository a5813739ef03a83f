"""Every Blender light type, in a simple diffuse scene, as bright as Cycles renders it (within
1 %): our light units and light sampling against Cycles' exact direct lighting."""
import math

import numpy as np
import pytest

W = 32


def scene_with(bpy, kind, **props):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    floor = bpy.data.materials.new("Floor")
    p = floor.node_tree.nodes["Principled BSDF"]
    p.inputs["Base Color"].default_value = (0.5, 0.5, 0.5, 1)
    p.inputs["Roughness"].default_value = 1.0
    p.inputs["Specular IOR Level"].default_value = 0.0
    bpy.ops.mesh.primitive_plane_add(size=20)
    bpy.context.active_object.data.materials.append(floor)
    cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
    cam.data.type, cam.data.ortho_scale = 'ORTHO', 6.0
    cam.location = (0.3, -0.2, 2.0)                 # below the lights: they stay out of view
    scene.collection.objects.link(cam)
    scene.camera = cam
    world = bpy.data.worlds.new("W")
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0, 0, 0, 1)
    scene.world = world
    if kind == "WORLD":
        world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.4, 0.5, 0.6, 1)
    elif kind == "MESH":
        bpy.ops.mesh.primitive_plane_add(size=1.0, location=(0.5, 0.0, 3.0))
        lamp = bpy.context.active_object
        m = bpy.data.materials.new("Lamp")
        t = m.node_tree
        t.nodes.remove(t.nodes["Principled BSDF"])
        e = t.nodes.new("ShaderNodeEmission")
        e.inputs["Strength"].default_value = 20.0
        t.links.new(e.outputs[0], t.nodes["Material Output"].inputs["Surface"])
        lamp.data.materials.append(m)
    else:
        data = bpy.data.lights.new("L", kind)
        for k, v in props.items():
            setattr(data, k, v)
        obj = bpy.data.objects.new("L", data)
        obj.location = (0.5, 0.0, 3.0)
        if kind == 'SUN':
            obj.rotation_euler = (math.radians(25), 0, 0)
        if kind == 'SPOT':
            obj.rotation_euler = (math.radians(10), 0, 0)
        scene.collection.objects.link(obj)
    scene.render.dither_intensity = 0.0
    return scene


CASES = {
    "point": ('POINT', dict(energy=100.0, shadow_soft_size=0.0)),
    "point_soft": ('POINT', dict(energy=100.0, shadow_soft_size=0.5)),
    "spot": ('SPOT', dict(energy=200.0, spot_size=math.radians(70), spot_blend=0.3)),
    "sun": ('SUN', dict(energy=2.0, angle=math.radians(5))),
    "area_square": ('AREA', dict(energy=100.0, shape='SQUARE', size=1.0)),
    "area_rectangle": ('AREA', dict(energy=100.0, shape='RECTANGLE', size=1.5, size_y=0.5)),
    "area_disk": ('AREA', dict(energy=100.0, shape='DISK', size=1.0)),
    "area_ellipse": ('AREA', dict(energy=100.0, shape='ELLIPSE', size=1.5, size_y=0.5)),
    "emissive_mesh": ("MESH", {}),
    "world": ("WORLD", {}),
}


@pytest.mark.parametrize("case", list(CASES))
def test_light_type_as_bright_as_cycles(bpy, tiny, cycles, render_exr, tmp_path, case):
    kind, props = CASES[case]
    scene = scene_with(bpy, kind, **props)
    cycles(scene, 512, W)
    ref = render_exr(tmp_path / "cycles.exr")
    tiny(scene, width=W, height=W, passes=128, photons=256)
    ours = render_exr(tmp_path / "ppm.exr")
    assert ref.mean() > 1e-3
    assert ours.mean() == pytest.approx(ref.mean(), rel=0.01), (ours.mean(), ref.mean())
    # and the shape of the light on the floor (4x4 blocks)
    bo, br = (im.mean(-1).reshape(4, 8, 4, 8).mean(axis=(1, 3)) for im in (ours, ref))
    lit = br > 0.05 * br.max()
    assert np.abs(bo[lit] / br[lit] - 1).max() < 0.06
