"""Issue 25's outdoor set-up: a diffuse ball, a rough metal ball (Principled, roughness 0.25)
and a clear glass ball on a floor, lit by an HDRI whose sun is in the image (a 256 x 128 float
image made here and packed: a sky gradient with a bright cloud, a brown ground, and a sun of
2 x 2 texels at 46 degrees, 20,000 times the sky).  The benchmark's "hdri_sun": the light a
user's HDRI brings, which the world's importance map must find (ppm_engine/render/world_map.py), and
the sun's caustic through the glass ball (the world's photons)."""
from __future__ import annotations

import math

import bpy

import numpy as np

from ppm_engine.blender.scenes.cornell_box import (
    camera_world_render,
    new_scene,
    principled,
    quad,
    sphere,
)

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


def build(scene=None):
    """Build the outdoor scene (module docstring); returns the scene."""
    scene = new_scene(scene)
    sphere(scene, "Diffuse", (-0.9, 0.3, 0.4), 0.4,
           principled("Diffuse", {"Base Color": (0.8, 0.8, 0.8), "Roughness": 1.0,
                                   "Specular IOR Level": 0.0}), 64, 32)
    sphere(scene, "Metal", (0.0, 0.5, 0.45), 0.45,
           principled("Metal", {"Base Color": (0.9, 0.9, 0.9), "Metallic": 1.0,
                                 "Roughness": 0.25}), 64, 32)
    sphere(scene, "Glass", (0.9, 0.0, 0.4), 0.4,
           principled("Glass", {"Transmission Weight": 1.0, "Roughness": 0.0}), 64, 32)
    # Principled at roughness 0.8 with its default specular layer
    quad(scene, "Floor", [(-6, -6, 0), (6, -6, 0), (6, 6, 0), (-6, 6, 0)],
         principled("Floor", {"Base Color": (0.5, 0.5, 0.5), "Roughness": 0.8}))
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
