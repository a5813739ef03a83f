"""Issue 25's outdoor set-up: a diffuse ball, a rough metal ball (Principled, roughness 0.25)
and a clear glass ball on a floor, lit by an HDRI whose sun is in the image (a 256 x 128 float
image made here and packed: a sky gradient with a bright cloud, a brown ground, and a sun of
2 x 2 texels at 46 degrees, 20,000 times the sky).  The benchmark's "hdri_sun": the light a
user's HDRI brings, which the world's importance map must find (ppm_engine/world_map.py) and
which eye paths carry through the glass and the metal (kernels/indirect_paths.h)."""
from __future__ import annotations

import math

import bpy

import numpy as np

from .cornell_box import camera_world_render, lambert, new_scene

SKY_W, SKY_H = 256, 128
SUN_TEXELS = (slice(96, 98), slice(40, 42))     # rows from the bottom, columns
SUN_RADIANCE = (20000.0, 18000.0, 15000.0)


def sky_pixels() -> np.ndarray:
    """(SKY_H, SKY_W, 4) float32 RGBA, rows bottom-up (Blender's order)."""
    v, u = np.mgrid[0:SKY_H, 0:SKY_W]
    el = (v + 0.5) / SKY_H * np.pi - np.pi / 2
    az = (u + 0.5) / SKY_W * 2 * np.pi
    s = np.sin(el)
    sky = np.stack([0.35 + 0.25 * s, 0.5 + 0.3 * s, 0.9 + 0.3 * s], -1)
    sky *= (0.6 + 0.2 * (np.cos(3 * az) + 1))[..., None]
    ground = np.broadcast_to(np.array([0.25, 0.2, 0.15]), sky.shape)
    img = np.where((el > 0)[..., None], sky, ground)
    img = img + 3.0 * np.exp(-(((az - 2.0) / 0.15) ** 2 + ((el - 0.5) / 0.1) ** 2))[..., None]
    img[SUN_TEXELS] = SUN_RADIANCE
    return np.concatenate([img, np.ones((SKY_H, SKY_W, 1))], -1).astype(np.float32)


def _ball(scene, name, location, radius, inputs):
    mesh = bpy.data.meshes.new(name)
    ob = bpy.data.objects.new(name, mesh)
    scene.collection.objects.link(ob)
    import bmesh
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=64, v_segments=32, radius=radius)
    bm.to_mesh(mesh)
    bm.free()
    for p in mesh.polygons:
        p.use_smooth = True
    ob.location = location
    m = bpy.data.materials.new(name)
    node = m.node_tree.nodes["Principled BSDF"]
    for k, v in inputs.items():
        node.inputs[k].default_value = (*v, 1.0) if isinstance(v, tuple) else v
    mesh.materials.append(m)
    return ob


def build(scene=None):
    """Build the outdoor scene (module docstring); returns the scene."""
    scene = new_scene(scene)
    _ball(scene, "Diffuse", (-0.9, 0.3, 0.4), 0.4, {"Base Color": (0.8, 0.8, 0.8),
                                                     "Roughness": 1.0,
                                                     "Specular IOR Level": 0.0})
    _ball(scene, "Metal", (0.0, 0.5, 0.45), 0.45, {"Base Color": (0.9, 0.9, 0.9),
                                                   "Metallic": 1.0, "Roughness": 0.25})
    _ball(scene, "Glass", (0.9, 0.0, 0.4), 0.4, {"Transmission Weight": 1.0, "Roughness": 0.0})
    mesh = bpy.data.meshes.new("Floor")
    mesh.from_pydata([(-6, -6, 0), (6, -6, 0), (6, 6, 0), (-6, 6, 0)], [], [(0, 1, 2, 3)])
    floor = bpy.data.objects.new("Floor", mesh)
    scene.collection.objects.link(floor)
    m = lambert("Floor", (0.5, 0.5, 0.5))
    p = m.node_tree.nodes["Principled BSDF"]
    p.inputs["Roughness"].default_value = 0.8
    p.inputs["Specular IOR Level"].default_value = 0.5     # Principled's default layer
    mesh.materials.append(m)
    camera_world_render(scene, location=(0.0, -4.0, 1.8),
                        rotation=(math.radians(70), 0.0, 0.0))
    world = scene.world
    tree = world.node_tree
    env = tree.nodes.new("ShaderNodeTexEnvironment")
    img = bpy.data.images.new("Sky", SKY_W, SKY_H, float_buffer=True)
    img.pixels.foreach_set(sky_pixels().ravel())
    img.pack()
    env.image = img
    tree.links.new(env.outputs["Color"], tree.nodes["Background"].inputs["Color"])
    tree.nodes["Background"].inputs["Strength"].default_value = 1.0
    return scene
