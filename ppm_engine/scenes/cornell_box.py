"""The Cornell box and the paper's bulb box, built with bpy.

Box: x, y in [-1, 1], z in [0, 2], open towards -y where the camera is.  Walls are Lambertian
(Principled with roughness 1 and no specular layer, so Cycles renders them as pure Lambert
too).  Cornell box: an emissive quad under the ceiling.  Bulb box: no ceiling light; the only
light is a small emissive sphere inside a clear glass sphere hanging under the ceiling, and a
glass ball lies on the floor, so every wall is lit through glass."""
from __future__ import annotations

import bpy

WHITE = (0.73, 0.73, 0.73)
RED = (0.63, 0.065, 0.05)
GREEN = (0.14, 0.45, 0.091)
LAMP_RADIANCE = 15.0
FILAMENT_RADIANCE = 80.0


def _lambert(name, color):
    m = bpy.data.materials.new(name)
    p = m.node_tree.nodes["Principled BSDF"]
    p.inputs["Base Color"].default_value = (*color, 1.0)
    p.inputs["Roughness"].default_value = 1.0
    p.inputs["Specular IOR Level"].default_value = 0.0
    return m


def _glass(name, ior=1.5):
    m = bpy.data.materials.new(name)
    p = m.node_tree.nodes["Principled BSDF"]
    p.inputs["Base Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    p.inputs["Roughness"].default_value = 0.0
    p.inputs["Transmission Weight"].default_value = 1.0
    p.inputs["IOR"].default_value = ior
    return m


def _emission(name, radiance):
    m = bpy.data.materials.new(name)
    tree = m.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    e = tree.nodes.new("ShaderNodeEmission")
    e.inputs["Strength"].default_value = radiance
    tree.links.new(e.outputs["Emission"], tree.nodes["Material Output"].inputs["Surface"])
    return m


def _quad(name, corners, material):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(c) for c in corners], [], [(0, 1, 2, 3)])
    mesh.materials.append(material)
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def _box(name, lo, hi, material):
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    v = [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0),
         (x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)]
    f = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(v, [], f)
    mesh.materials.append(material)
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def _sphere(name, center, radius, material, segments=32, rings=16):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=segments, ring_count=rings, radius=radius,
                                         location=center)
    obj = bpy.context.active_object
    obj.name = obj.data.name = name
    obj.data.materials.append(material)
    obj.data.shade_smooth()
    return obj


def build(bulb: bool = False):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    white, red, green = _lambert("White", WHITE), _lambert("Red", RED), _lambert("Green", GREEN)
    _quad("Floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], white)
    _quad("Ceiling", [(-1, -1, 2), (-1, 1, 2), (1, 1, 2), (1, -1, 2)], white)
    _quad("Back", [(-1, 1, 0), (1, 1, 0), (1, 1, 2), (-1, 1, 2)], white)
    _quad("Left", [(-1, -1, 0), (-1, 1, 0), (-1, 1, 2), (-1, -1, 2)], red)
    _quad("Right", [(1, -1, 0), (1, -1, 2), (1, 1, 2), (1, 1, 0)], green)
    if bulb:
        glass = _glass("Glass")
        _sphere("Filament", (0, 0, 1.6), 0.05, _emission("Filament", FILAMENT_RADIANCE), 16, 8)
        _sphere("Bulb", (0, 0, 1.6), 0.15, glass)
        _sphere("GlassBall", (0.3, 0.2, 0.3), 0.3, glass)
    else:
        _quad("Lamp", [(-0.25, -0.25, 1.99), (-0.25, 0.25, 1.99), (0.25, 0.25, 1.99),
                       (0.25, -0.25, 1.99)], _emission("Lamp", LAMP_RADIANCE))
        _box("TallBox", (-0.6, -0.1, 0.0), (-0.1, 0.5, 1.2), white)
        _box("ShortBox", (0.15, -0.5, 0.0), (0.65, 0.0, 0.6), white)

    cam_data = bpy.data.cameras.new("Camera")
    cam_data.lens, cam_data.sensor_width = 35.0, 36.0
    cam = bpy.data.objects.new("Camera", cam_data)
    scene.collection.objects.link(cam)
    cam.location = (0.0, -2.9, 1.0)
    cam.rotation_euler = (1.5707963267948966, 0.0, 0.0)      # looks along +y
    scene.camera = cam

    world = bpy.data.worlds.new("World")
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0, 0, 0, 1)
    scene.world = world
    r = scene.render
    r.resolution_x = r.resolution_y = 256
    r.resolution_percentage = 100
    r.dither_intensity = 0.0
    r.film_transparent = False
    scene.frame_set(1)
    return scene
