"""The furnace: the inside of a closed sphere (radius 1 m) whose surface is Lambertian with
albedo ``ALBEDO`` and emits ``EMISSION`` (W/(m^2 sr), white), the camera at its centre.  Every
point sees the same radiance, L = EMISSION / (1 - ALBEDO) (the emission plus its
inter-reflections to every order): a closed form, the benchmark's independent reference for
pure diffuse inter-reflection (``python -m ppm_engine bench``)."""
from __future__ import annotations

import math

import bpy

from ppm_engine.blender.scenes.cornell_box import camera_world_render, new_scene, sphere

ALBEDO = 0.5
EMISSION = 0.5


def radiance() -> float:
    """The furnace's radiance everywhere (every bounce)."""
    return EMISSION / (1.0 - ALBEDO)


def build(scene=None):
    """Build the furnace (see the module docstring); returns the scene."""
    scene = new_scene(scene)
    m = bpy.data.materials.new("Furnace")
    t = m.node_tree
    t.nodes.remove(t.nodes["Principled BSDF"])
    diffuse, em, add = (t.nodes.new(n) for n in ("ShaderNodeBsdfDiffuse", "ShaderNodeEmission",
                                                  "ShaderNodeAddShader"))
    diffuse.inputs["Color"].default_value = (ALBEDO, ALBEDO, ALBEDO, 1.0)
    diffuse.inputs["Roughness"].default_value = 0.0
    em.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    em.inputs["Strength"].default_value = EMISSION
    t.links.new(diffuse.outputs[0], add.inputs[0])
    t.links.new(em.outputs[0], add.inputs[1])
    t.links.new(add.outputs[0], t.nodes["Material Output"].inputs["Surface"])
    # flat-shaded: the closed form holds for any closed surface, with its geometric normals
    sphere(scene, "Furnace", (0.0, 0.0, 0.0), 1.0, m, 64, 32).data.shade_flat()
    camera_world_render(scene, location=(0.0, 0.0, 0.0), rotation=(math.pi / 2, 0.0, 0.3))
    return scene
