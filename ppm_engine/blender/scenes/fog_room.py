"""``fog_room``: a room of homogeneous fog under a spot light (issue 42), built with bpy from
nothing.  A grey floor and back wall (Lambertian: Principled, Roughness 1, Specular IOR Level
0), a 3 m cube of fog floating above the floor (a mesh with only a Volume output: Principled
Volume, density FOG_DENSITY, colour FOG_COLOR), a spot light of radius 0 above it pointing
down, a black world, and Cycles' default Light Paths (Volume bounces 0: single scattering; 4
diffuse bounces, Clamp Indirect 10), which both engines read from ``scene.cycles``.  What the
camera sees: the cone of light in the fog, the pool of light on the floor through it, the
floor and wall lit by what the fog scatters onto them.  The scene of tests/test_volumes.py
fog_room, denser; the benchmark's "fog_room" (its reference: Cycles' long render)."""
from __future__ import annotations

import bpy

from ppm_engine.blender.scenes.cornell_box import (
    box,
    camera_world_render,
    lambert,
    new_scene,
    quad,
)
from ppm_engine.blender.scenes.sun_cone import default_light_paths

RESOLUTION = 128
GREY = (0.6, 0.6, 0.6)
FLOOR_Z, HALF = -1.2, 4.0                       # an 8 x 8 m floor
WALL_Y, WALL_Z = 3.0, (-2.0, 6.0)               # an 8 x 8 m wall, its foot below the floor
FOG_LO, FOG_HI = (-1.5, -1.5, -0.9), (1.5, 1.5, 2.1)
FOG_DENSITY, FOG_COLOR = 0.8, (0.9, 0.9, 0.9)
SPOT_POS, SPOT_POWER, SPOT_SIZE = (0.0, 0.0, 3.5), 800.0, 0.6   # W (Cycles units); cone, rad
CAMERA = ((0.0, -6.0, 1.5), (1.35, 0.0, 0.0))
LENS = 35.0                                     # mm, on a 36 mm sensor


def fog_material(name="Fog", density=FOG_DENSITY, color=FOG_COLOR):
    """A material with only a Volume output: a Principled Volume of ``density`` and
    ``color`` (its other inputs Blender's defaults)."""
    m = bpy.data.materials.new(name)
    nt = m.node_tree
    nt.nodes.remove(nt.nodes["Principled BSDF"])
    v = nt.nodes.new("ShaderNodeVolumePrincipled")
    v.inputs["Density"].default_value = density
    v.inputs["Color"].default_value = (*color, 1.0)
    nt.links.new(v.outputs["Volume"], nt.nodes["Material Output"].inputs["Volume"])
    return m


def build(scene=None, resolution=RESOLUTION, density=FOG_DENSITY):
    """Build the fog room (module docstring); returns the scene."""
    scene = new_scene(scene)
    grey = lambert("Grey", GREY)
    h, z = HALF, FLOOR_Z
    quad(scene, "Floor", [(-h, -h, z), (h, -h, z), (h, h, z), (-h, h, z)], grey)
    z0, z1 = WALL_Z
    quad(scene, "Wall", [(-h, WALL_Y, z0), (h, WALL_Y, z0), (h, WALL_Y, z1), (-h, WALL_Y, z1)],
         grey)
    box(scene, "Fog", FOG_LO, FOG_HI, fog_material(density=density))
    data = bpy.data.lights.new("Spot", "SPOT")
    data.energy, data.spot_size, data.shadow_soft_size = SPOT_POWER, SPOT_SIZE, 0.0
    spot = bpy.data.objects.new("Spot", data)
    spot.location = SPOT_POS                    # (pointing down: no rotation)
    scene.collection.objects.link(spot)
    camera_world_render(scene, *CAMERA, resolution)
    scene.camera.data.lens = LENS
    default_light_paths(scene)
    return scene
