"""Issue 25's glossy metal lit by a small light: a ball of metal and dielectric squares, their
roughness from a noise texture (0.05-0.35), and a polished metal ball (roughness 0.1), over a
checker floor, lit by Blender's default light (a 1000 W point light of radius 0.1 m) in a black
world.  The benchmark's ``glossy_metal``: the light users see in a glossy reflection (the
light's highlight, the lit floor, the balls' own caustics on the floor seen again in the
metal), which path tracing renders well and photons alone render grainy.  Cycles' Light Paths
as every bench scene sets them (12 bounces, no clamping: cornell_box.camera_world_render)."""
from __future__ import annotations

import math

import bpy

from ppm_engine.blender.scenes.cornell_box import (
    camera_world_render,
    new_scene,
    principled,
    quad,
    sphere,
)

LIGHT_POS = (1.6, -1.2, 2.4)
LIGHT_POWER = 1000.0             # W: Blender's default light
LIGHT_RADIUS = 0.1               # m: Blender's default light
ROUGHNESS_RANGE = (0.05, 0.35)   # the squares' roughness, from a noise texture


def _node(nodes, kind, location, **inputs):
    n = nodes.new(kind)
    n.location = location
    for k, v in inputs.items():
        n.inputs[k].default_value = v
    return n


def squares_material(name="Squares"):
    """Principled: metal (gold) and dielectric (blue, its IOR 1.5) squares by a checker of the
    generated coordinates, both with the noise texture's roughness."""
    m = bpy.data.materials.new(name)
    nodes, links = m.node_tree.nodes, m.node_tree.links
    p = nodes["Principled BSDF"]
    coords = _node(nodes, "ShaderNodeTexCoord", (-900, 0))
    checker = _node(nodes, "ShaderNodeTexChecker", (-600, 200), Scale=6.0,
                    Color1=(1.0, 1.0, 1.0, 1.0), Color2=(0.0, 0.0, 0.0, 1.0))
    noise = _node(nodes, "ShaderNodeTexNoise", (-600, -200), Scale=4.0, Detail=2.0)
    rough = _node(nodes, "ShaderNodeMapRange", (-350, -200))
    rough.inputs["To Min"].default_value, rough.inputs["To Max"].default_value = ROUGHNESS_RANGE
    rough.inputs["From Min"].default_value, rough.inputs["From Max"].default_value = 0.3, 0.7
    color = _node(nodes, "ShaderNodeMix", (-350, 200))
    color.data_type = 'RGBA'
    color.inputs["A"].default_value = (0.1, 0.25, 0.7, 1.0)      # the dielectric's
    color.inputs["B"].default_value = (1.0, 0.78, 0.34, 1.0)     # the metal's (gold)
    links.new(coords.outputs["Generated"], checker.inputs["Vector"])
    links.new(coords.outputs["Generated"], noise.inputs["Vector"])
    links.new(checker.outputs["Fac"], p.inputs["Metallic"])
    links.new(checker.outputs["Fac"], color.inputs["Factor"])
    links.new(color.outputs["Result"], p.inputs["Base Color"])
    links.new(noise.outputs["Fac"], rough.inputs["Value"])
    links.new(rough.outputs["Result"], p.inputs["Roughness"])
    return m


def checker_floor(name="Checker"):
    """Principled (its defaults: roughness 0.5, specular 0.5) with a grey checker."""
    m = bpy.data.materials.new(name)
    nodes, links = m.node_tree.nodes, m.node_tree.links
    checker = _node(nodes, "ShaderNodeTexChecker", (-400, 200), Scale=8.0,
                    Color1=(0.8, 0.8, 0.8, 1.0), Color2=(0.15, 0.15, 0.15, 1.0))
    links.new(checker.outputs["Color"], nodes["Principled BSDF"].inputs["Base Color"])
    return m


def build(scene=None):
    """Build the glossy metal scene (module docstring); returns the scene."""
    scene = new_scene(scene)
    sphere(scene, "Squares", (-0.35, 0.3, 0.55), 0.55, squares_material(), 96, 48)
    sphere(scene, "Polished", (0.65, -0.2, 0.3), 0.3,
           principled("Polished", {"Base Color": (0.9, 0.9, 0.92), "Metallic": 1.0,
                                   "Roughness": 0.1}), 64, 32)
    quad(scene, "Floor", [(-4, -4, 0), (4, -4, 0), (4, 4, 0), (-4, 4, 0)], checker_floor())
    data = bpy.data.lights.new("Light", 'POINT')
    data.energy, data.shadow_soft_size = LIGHT_POWER, LIGHT_RADIUS
    light = bpy.data.objects.new("Light", data)
    light.location = LIGHT_POS
    scene.collection.objects.link(light)
    camera_world_render(scene, location=(0.0, -3.2, 1.5),
                        rotation=(math.radians(72), 0.0, 0.0), resolution=128)
    return scene
