"""A pool under the sun (the benchmark's ``pool_caustic``: issue 25's caustic seen through
glass): a 9 x 9 m sheet of water with waves over a tiled floor 1.5 m below it, lit by a sun lamp
of Blender's default angle (0.53 degrees) low in the sky, seen from above through the water.

The sun's light refracts through the waves into a network of caustic lines on the floor, and the
camera sees that floor through the same waves: light from a small source, then a diffuse
surface, then a refracting surface towards the camera (the path no camera ray can find by next-
event estimation, and which a path tracer finds only when a bounce off the floor happens to
leave through the water into the sun's half-degree).

- The water's surface is the height field ``height`` (a sum of ``WAVES``, ripples of 30-60 cm
  and a few millimetres), meshed on a ``GRID`` x ``GRID`` grid, smooth shaded; its material is
  clear glass of IOR ``WATER_IOR`` (Principled, Transmission Weight 1, Roughness 0).  There is
  no water body: clear water absorbs nothing, so only its surface matters.
- The floor is Lambertian, ``FLOOR`` (a pale blue-green), 4.6 m across: all of it is lit
  through the water (none by sunlight passing beside the water's edge).
- The sun (``SUN_STRENGTH`` W/m^2, angle Blender's default) shines from the -x side at
  ``SUN_ELEVATION``: low, so its caustic is sharp (the waves focus its refracted light about
  three times as strongly as they bend the camera's nearly vertical view, which does not fold).
  No camera ray reflected off the water meets it (the exact reference, ppm_engine/tools/bench/
  exact_pool.py, checks that no glint is missing from it).
- The world is black, the Light Paths 12 bounces of every kind (cornell_box.camera_world_render).

The geometry is the module's constants, which the exact reference reads too.
"""
from __future__ import annotations

import math

import bpy

import numpy as np

from ppm_engine.blender.scenes.cornell_box import (
    camera_world_render,
    glass,
    grid_mesh,
    lambert,
    new_scene,
    quad,
)

RESOLUTION = 128
HALF = 4.5                      # the water: |x|, |y| <= HALF
FLOOR_HALF = 2.3                # the floor: |x|, |y| <= FLOOR_HALF (the sun reaches all of it
                                # through the water, none past its edge)
DEPTH = 1.5                     # the floor at z = -DEPTH; the water's mean surface at z = 0
GRID = 601                      # vertices per side of the water's mesh (1.5 cm apart)
SMALL_GRID = 151                # (6 cm apart) for images of at most SMALL_IMAGE pixels across
SMALL_IMAGE = 32
WATER_IOR = 1.33
FLOOR = (0.35, 0.6, 0.65)
# (amplitude m, wavelength m, direction of travel in degrees from +x, phase)
WAVES = ((0.0050, 0.60, 170.0, 0.0), (0.0032, 0.48, 205.0, 1.3), (0.0020, 0.38, 140.0, 2.1),
         (0.0012, 0.30, 10.0, 4.0))
SUN_STRENGTH = 4.0              # W/m^2 (Cycles' sun: irradiance, perpendicular to its rays)
SUN_ELEVATION = 35.0            # degrees above the horizon
SUN_AZIMUTH = 190.0             # degrees from +x of the direction towards the sun (-x side)
CAMERA = dict(location=(0.0, -0.75, 3.5), rotation=(math.radians(12.0), 0.0, 0.0))
LENS = 50.0                     # mm, on the 36 mm sensor


def wave_vectors(waves=WAVES):
    """(amplitudes, wave vectors (k, 2), phases) of ``waves``."""
    a = np.array([w[0] for w in waves], float)
    k = np.array([2.0 * np.pi / w[1] * np.array([math.cos(math.radians(w[2])),
                                                  math.sin(math.radians(w[2]))])
                  for w in waves], float).reshape(-1, 2)
    phase = np.array([w[3] for w in waves], float)
    return a, k, phase


def height(x, y, waves=WAVES):
    """The water's height z at (x, y) and its gradient (dz/dx, dz/dy), float64 arrays."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    h = np.zeros(np.broadcast(x, y).shape)
    hx, hy = np.zeros_like(h), np.zeros_like(h)
    for a, k, ph in zip(*wave_vectors(waves)):
        arg = k[0] * x + k[1] * y + ph
        h += a * np.sin(arg)
        c = a * np.cos(arg)
        hx += c * k[0]
        hy += c * k[1]
    return h, hx, hy


def sun_direction() -> np.ndarray:
    """The unit direction towards the sun."""
    el, az = math.radians(SUN_ELEVATION), math.radians(SUN_AZIMUTH)
    return np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])


def water_mesh(name: str, waves=WAVES, grid: int = GRID):
    """The water's surface: ``grid`` x ``grid`` vertices on the height field, quads, smooth."""
    t = np.linspace(-HALF, HALF, grid)
    x, y = np.meshgrid(t, t)                          # rows along y
    mesh = grid_mesh(name, np.stack([x, y, height(x, y, waves)[0]], -1))
    mesh.shade_smooth()
    return mesh


def grid_for(resolution: int) -> int:
    """The water's mesh for an image ``resolution`` pixels across: GRID, or SMALL_GRID for the
    benchmark's quick run (16 x 16), whose pixels are 8 times the size."""
    return SMALL_GRID if resolution <= SMALL_IMAGE else GRID


def build(scene=None, waves=WAVES, grid: int = GRID):
    """Build the pool (module docstring); ``waves`` () makes the water flat, ``grid`` its mesh's
    vertices per side.  Returns the scene."""
    scene = new_scene(scene)
    mesh = water_mesh("Water", waves, grid)
    mesh.materials.append(glass("Water", WATER_IOR))
    water = bpy.data.objects.new("Water", mesh)
    scene.collection.objects.link(water)
    f = FLOOR_HALF
    quad(scene, "Floor", [(-f, -f, -DEPTH), (f, -f, -DEPTH), (f, f, -DEPTH), (-f, f, -DEPTH)],
         lambert("Tiles", FLOOR))
    sun = bpy.data.lights.new("Sun", "SUN")
    sun.energy = SUN_STRENGTH                         # the angle stays Blender's default
    obj = bpy.data.objects.new("Sun", sun)
    scene.collection.objects.link(obj)
    d = sun_direction()
    # a light shines along its local -z: rotate +z onto the direction towards the sun
    obj.rotation_euler = (0.0, math.acos(d[2]), math.atan2(d[1], d[0]))
    camera_world_render(scene, resolution=RESOLUTION, **CAMERA)
    scene.camera.data.lens = LENS
    return scene
