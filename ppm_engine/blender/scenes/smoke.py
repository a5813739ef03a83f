"""``smoke``: a cube of smoke on the ground under a sun and a sky (issue 42), built with bpy
from nothing, as a user makes one.  The smoke: a 2 m cube (a mesh with only a Volume output)
whose Principled Volume Density comes from a Noise Texture at its default vector (Generated
coordinates: the cube's box mapped to 0..1) through a clamped Map Range that keeps the noise's
upper part (NOISE_RANGE to 0..SMOKE_DENSITY): puffs and wisps with clear air between them.  The
ground: a floor of the default Principled BSDF.  The light: a sun (SUN_STRENGTH, Blender's
default angle) and a Sky Texture world (Blender's default model, multiple scattering, its sun
at the sun's direction, its sun disc off: the sun is the lamp's).  The camera looks down on the
cube, the sky out of view (it lights the scene; the floor fills the frame).  Cycles' default
Light Paths (Volume bounces 0: single scattering), which both engines read from
``scene.cycles``.  The benchmark's "smoke" (its reference: Cycles' long render).

This engine renders a linked Density with the input's unlinked value today (a warning names
the material): the measurement waits for heterogeneous media (docs/VOLUMES.md)."""
from __future__ import annotations

import math

import bpy

from ppm_engine.blender.scenes.cornell_box import box, camera_world_render, new_scene, quad
from ppm_engine.blender.scenes.sun_cone import default_light_paths, principled_default

RESOLUTION = 128
SMOKE_LO, SMOKE_HI = (-1.0, -1.0, 0.05), (1.0, 1.0, 2.05)     # off the floor: no shared face
NOISE_SCALE, NOISE_DETAIL = 3.0, 4.0
NOISE_RANGE = (0.5, 0.7)                       # the Noise Texture's Fac mapped to 0..density
SMOKE_DENSITY, SMOKE_COLOR = 10.0, (0.8, 0.8, 0.8)
FLOOR_HALF = 15.0                              # m: to the frame's edge
SUN_STRENGTH = 3.0                             # W/m^2
SUN_ELEVATION, SUN_AZIMUTH = math.radians(35.0), math.radians(60.0)
SKY_STRENGTH = 0.05                            # the world's Background strength
CAMERA = ((0.0, -3.0, 3.8), (math.radians(47.0), 0.0, 0.0))


def smoke_material(name="Smoke"):
    """A material with only a Volume output: Principled Volume (colour SMOKE_COLOR), its
    Density from Noise Texture -> Map Range (clamped)."""
    m = bpy.data.materials.new(name)
    nt = m.node_tree
    nt.nodes.remove(nt.nodes["Principled BSDF"])
    noise = nt.nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = NOISE_SCALE
    noise.inputs["Detail"].default_value = NOISE_DETAIL
    ramp = nt.nodes.new("ShaderNodeMapRange")
    ramp.clamp = True
    ramp.inputs["From Min"].default_value, ramp.inputs["From Max"].default_value = NOISE_RANGE
    ramp.inputs["To Min"].default_value, ramp.inputs["To Max"].default_value = 0.0, SMOKE_DENSITY
    v = nt.nodes.new("ShaderNodeVolumePrincipled")
    v.inputs["Color"].default_value = (*SMOKE_COLOR, 1.0)
    nt.links.new(noise.outputs["Fac"], ramp.inputs["Value"])
    nt.links.new(ramp.outputs["Result"], v.inputs["Density"])
    nt.links.new(v.outputs["Volume"], nt.nodes["Material Output"].inputs["Volume"])
    return m


def sky_world(scene):
    """The world: a Sky Texture (Blender's default model) into the Background, its sun where
    the lamp's is and without its disc."""
    nt = scene.world.node_tree
    sky = nt.nodes.new("ShaderNodeTexSky")
    sky.sun_disc = False
    sky.sun_elevation = SUN_ELEVATION
    # the sky's sun lies at (-cos e sin r, cos e cos r, sin e) for rotation r; the lamp's,
    # turned by SUN_AZIMUTH about z, at (sin a cos e, -cos a cos e, sin e): r = a + pi
    sky.sun_rotation = SUN_AZIMUTH + math.pi
    bg = nt.nodes["Background"]
    bg.inputs["Strength"].default_value = SKY_STRENGTH
    nt.links.new(sky.outputs["Color"], bg.inputs["Color"])


def build(scene=None, resolution=RESOLUTION):
    """Build the smoke cube (module docstring); returns the scene."""
    scene = new_scene(scene)
    h = FLOOR_HALF
    quad(scene, "Floor", [(-h, -h, 0), (h, -h, 0), (h, h, 0), (-h, h, 0)],
         principled_default("Floor"))
    box(scene, "Smoke", SMOKE_LO, SMOKE_HI, smoke_material())
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = SUN_STRENGTH
    sun.rotation_euler = (0.5 * math.pi - SUN_ELEVATION, 0.0, SUN_AZIMUTH)
    scene.collection.objects.link(sun)
    camera_world_render(scene, *CAMERA, resolution)
    sky_world(scene)
    default_light_paths(scene)
    return scene
