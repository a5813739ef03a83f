"""A sun-lit cone on a glossy floor, as a user makes one: a cone of the default Principled BSDF
(roughness 0.5, its glossy layer over a diffuse base) standing on a floor of the default
Principled BSDF, one sun (strength 3, Blender's default angle), a black world, and Cycles'
default Light Paths (4 diffuse and 4 glossy bounces, Clamp Indirect 10, Filter Glossy 1), which
both engines read from ``scene.cycles``.  The benchmark's "sun_cone": the floor's glossy
reflection of the sun reaches the cone, and the cone's the floor, as light a path tracer finds
through a glossy bounce after a diffuse one, which Filter Glossy blurs (docs/SHADING.md,
"Light Paths")."""
from __future__ import annotations

import math

import bpy

import bmesh

from ppm_engine.blender.scenes.cornell_box import _link, camera_world_render, new_scene, quad

SUN_STRENGTH = 3.0                    # W/m^2
SUN_ROTATION = (math.radians(55), 0.0, math.radians(75))   # 35 degrees above the horizon
CONE_RADIUS, CONE_HEIGHT, CONE_SIDES = 0.6, 1.4, 32


def default_light_paths(scene) -> None:
    """Cycles' Light Paths as a new file has them (light_paths.CYCLES_DEFAULTS)."""
    from ppm_engine.scene.light_paths import CYCLES_DEFAULTS
    c = scene.cycles
    for name, value in CYCLES_DEFAULTS.items():
        setattr(c, name, value)


def principled_default(name):
    """A material of the default Principled BSDF, nothing changed."""
    return bpy.data.materials.new(name)


def cone(scene, name, material):
    """A flat-shaded cone standing on the floor at the origin (bmesh: no operator context)."""
    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    bmesh.ops.create_cone(bm, cap_ends=True, segments=CONE_SIDES, radius1=CONE_RADIUS,
                          radius2=0.0, depth=CONE_HEIGHT)
    bmesh.ops.translate(bm, verts=bm.verts, vec=(0.0, 0.0, CONE_HEIGHT / 2))
    bm.to_mesh(mesh)
    bm.free()
    return _link(scene, name, mesh, material)


def build(scene=None):
    """Build the sun-lit cone (module docstring); returns the scene."""
    scene = new_scene(scene)
    quad(scene, "Floor", [(-8, -8, 0), (8, -8, 0), (8, 8, 0), (-8, 8, 0)],
         principled_default("Floor"))
    cone(scene, "Cone", principled_default("Cone"))
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = SUN_STRENGTH
    sun.rotation_euler = SUN_ROTATION
    scene.collection.objects.link(sun)
    camera_world_render(scene, location=(0.0, -3.6, 1.6), rotation=(math.radians(72), 0.0, 0.0))
    default_light_paths(scene)
    return scene
