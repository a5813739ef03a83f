"""A city block at night: grey buildings on a grey ground, lit by hundreds of small lights --
street lamps (point lights of radius 5 cm along the streets), spots over the doors, lit
windows (area lights on the facades) -- and a neon sign, a ribbon of a few thousand emissive
triangles, under a faint sky.  The benchmark's many-light scene (``python -m ppm_engine
bench``): next-event estimation must find, among ~600 emitters and ~3000 emissive triangles,
the few that light each point (the light tree, ppm_engine/scene/light_tree.py)."""
from __future__ import annotations

import math

import bpy

import numpy as np

from ppm_engine.blender.scenes.cornell_box import (
    box,
    camera_world_render,
    emission,
    lambert,
    new_scene,
)

SEED = 7
N_STREET = 16          # street lamps along each of the 4 streets x 2 sides
SIGN_SEGMENTS = 1500   # the neon ribbon's quads (2 triangles each)


def _light(scene, name, kind, location, energy, color=(1.0, 0.85, 0.6), **kw):
    data = bpy.data.lights.new(name, kind)
    data.energy, data.color = energy, color
    for k, v in kw.items():
        setattr(data, k, v)
    ob = bpy.data.objects.new(name, data)
    ob.location = location
    scene.collection.objects.link(ob)
    return ob


def _sign(scene, material):
    """A ribbon along a rose curve 2 cm before a facade: SIGN_SEGMENTS quads, 0.04 m wide."""
    t = np.linspace(0.0, 2.0 * math.pi, SIGN_SEGMENTS + 1)
    r = 0.9 * np.cos(3.0 * t)
    x, z = 1.0 + r * np.cos(t), 2.0 + r * np.sin(t)
    y = np.full_like(x, -1.02)
    centre = np.stack([x, y, z], 1)
    tangent = np.gradient(centre, axis=0)
    side = np.cross(tangent, [0.0, 1.0, 0.0])
    side /= np.maximum(np.linalg.norm(side, axis=1, keepdims=True), 1e-9)
    a, b = centre - 0.02 * side, centre + 0.02 * side
    verts = np.concatenate([a, b])
    n = SIGN_SEGMENTS + 1
    faces = [(i, i + 1, n + i + 1, n + i) for i in range(SIGN_SEGMENTS)]
    mesh = bpy.data.meshes.new("Neon")
    mesh.from_pydata(verts.tolist(), [], faces)
    mesh.materials.append(material)
    ob = bpy.data.objects.new("Neon", mesh)
    scene.collection.objects.link(ob)
    return ob


def build(scene=None):
    """Build the city block (module docstring); returns the scene."""
    rng = np.random.default_rng(SEED)
    scene = new_scene(scene)
    grey, ground = lambert("Facade", (0.5, 0.5, 0.5)), lambert("Ground", (0.3, 0.3, 0.3))
    box(scene, "Ground", (-12.0, -12.0, -0.1), (12.0, 12.0, 0.0), ground)
    # buildings: a 3 x 3 grid of blocks, 4 m wide, streets 2 m wide between them
    for i in range(3):
        for j in range(3):
            x0, y0 = -7.0 + 6.0 * i, -1.0 + 6.0 * j
            h = 3.0 + 5.0 * rng.random()
            box(scene, f"Block{i}{j}", (x0, y0, 0.0), (x0 + 4.0, y0 + 4.0, h), grey)
    # street lamps: both sides of the streets x = -2, 4 and y = -2, 4 (the grid's gaps)
    k = 0
    for s in (-2.0, 4.0):
        for u in np.linspace(-9.0, 11.0, N_STREET):
            for off in (-0.8, 0.8):
                _light(scene, f"Lamp{k}", 'POINT', (s + off, u, 2.5), 20.0 + 20 * rng.random(),
                       shadow_soft_size=0.05)
                _light(scene, f"LampX{k}", 'POINT', (u, s + off, 2.5), 20.0 + 20 * rng.random(),
                       shadow_soft_size=0.05)
                k += 1
    # spots over the doors, pointing down (a spot's -Z, unrotated); lit windows on the facades
    # facing the streets
    for n in range(60):
        x, y = rng.uniform(-8, 10), rng.choice([-1.02, 2.98, 4.98])
        _light(scene, f"Spot{n}", 'SPOT', (x, y, 2.2), 30.0, spot_size=math.radians(70),
               spot_blend=0.3, shadow_soft_size=0.02)
    for n in range(120):
        x, z = rng.uniform(-7, 9), rng.uniform(1.0, 3.0)
        # facing the street (an area light emits along its -Z)
        y, rot = (-1.01, -math.pi / 2) if n % 2 else (3.01, math.pi / 2)
        win = _light(scene, f"Window{n}", 'AREA', (x, y, z), 8.0 * rng.random() + 2.0,
                     color=(0.9, 0.95, 1.0), size=0.6, size_y=0.8, shape='RECTANGLE')
        win.rotation_euler = (rot, 0.0, 0.0)
    neon = emission("Neon", 6.0)
    neon.node_tree.nodes["Emission"].inputs["Color"].default_value = (1.0, 0.07, 0.1, 1.0)
    _sign(scene, neon)
    camera_world_render(scene, location=(1.0, -9.0, 6.0),
                        rotation=(math.radians(62), 0.0, 0.0))
    scene.camera.data.lens = 22.0
    bg = scene.world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.02, 0.025, 0.04, 1.0)
    return scene
