"""Seven caustic scenes (example scenes, and the benchmark's: ``python -m ppm_engine bench``),
built with bpy from nothing.

All stand on the same stage: a 4 x 4 m white Lambertian floor (z = 0, x, y in [-2, 2]) and a
back wall at y = 2, black world, the camera at the front looking down at the middle.  Lights
are small spheres (radius ``LIGHT_RADIUS``) kept out of view and invisible to camera rays
(lights are not visible to our camera rays; Cycles would show them).

- ``glass_caustic``: a clear glass ball (radius 0.3 m, IOR 1.5) on the floor, lit by a spot
  light above and to the left, aimed at the ball: the ball focuses the light to a bright
  caustic on the floor to the ball's right.
- ``point_caustic``: the same ball (finer: 192 x 96 faces) lit by a point light of radius 0
  where the spot was, of the spot's intensity: the hard case users bring (no camera path can
  find such a light, so the caustic is all photons', light paths' or Cycles' MNEE's), its
  focus as sharp as the ball makes it.
- ``rough_caustic``: point_caustic with the ball's glass rough (Roughness
  ``ROUGH_CAUSTIC_ROUGHNESS``, the single-scattering GGX distribution): the focus spreads into a
  soft-edged spot, which camera paths can reach only by next-event estimation through the
  glass's lobe.
- ``far_caustic``: the hard case an outside review used: a bigger clear glass ball (radius
  0.5 m, the same 192 x 96 faces) on the floor, lit by a point light of radius 0 3.5 m from its
  centre, up and to the left (``FAR_POS``): the ball subtends 0.5 % of the light's sphere of
  directions, so its caustic (a sharp focus on the floor to the ball's right, around x = 0.83
  m where the ray from the light through the ball's centre meets it) gets few uniform photons;
  ``FAR_POWER`` exposes the image as point_caustic's (mean 0.57 against 0.59).
- ``lifted_caustic``: far_caustic with the ball lifted 0.1 m off the floor (``LIFTED_BALL``):
  far_caustic's focus lies on the floor, a point where the refracted paths to a floor point
  form a ring, which Cycles' MNEE (one path per sample, found from the straight line) misses
  (its error flat with time, its focus a quarter of the exact one's); here the floor is 0.27 m
  past the focus, the caustic a spread disc MNEE converges on, as in an outside review's set-up.
- ``mirror_caustic``: a point light and a perfect planar mirror (Principled metallic 1,
  roughness 0, base colour 1), a 0.8 x 0.6 m rectangle tilted towards the floor, which
  reflects the light onto a bright patch of floor in front of it.
- ``clamped_caustic``: a polished metal ball (Principled metallic 1, roughness
  ``CLAMPED_ROUGHNESS``) under a point light of radius 0 in a black lamp shade open below: the
  floor under the shade is lit, the back wall (and the floor around the pool) only by the ball's
  glossy reflection of the light, a caustic path tracing finds through next-event estimation at
  the ball after a diffuse bounce, rarely and bright.  Its Light Paths clamp (Clamp Direct and
  Indirect ``CLAMP``): Cycles' image is the clamped one, a smooth and dim wall (the benchmark
  renders both engines with the scene's own clamp: ``ppm_engine/tools/bench/scenes.py``
  LIGHT_PATHS).

The benchmark's data about them (caustic pixels, MNEE flags) is in ppm_engine/tools/bench/scenes.py.
"""
from __future__ import annotations

import math

import bpy

import numpy as np

from ppm_engine.blender.scenes.cornell_box import (
    camera_world_render,
    glass,
    lambert,
    new_scene,
    principled,
    quad,
    sphere,
)

RESOLUTION = 128
LIGHT_RADIUS = 0.02
FLOOR = (0.8, 0.8, 0.8)

# glass_caustic
BALL = ((0.0, 0.0, 0.3), 0.3)                    # centre, radius
SPOT_POS = (-2.0, 0.0, 1.7)
SPOT_POWER = 300.0                               # W (Cycles units)
SPOT_SIZE = math.radians(30.0)
# point_caustic's ball: fine enough that its focus is the true sphere's within the exact reference's
# noise (docs/history/benchmarks-notebook.md: the 48 x 24 ball dims the focus 3 %, ten times the
# noise; 192 x 96 leaves a sixth of that), since its reference is the exact sphere
POINT_BALL_SEGMENTS = (192, 96)

# far_caustic: a ball of radius 0.5 m on the floor, the point light 3.5 m from its centre
FAR_BALL = ((0.0, 0.0, 0.5), 0.5)                # centre, radius
FAR_POS = (-3.0, 0.0, 2.3)
FAR_POWER = 600.0                                # W

# lifted_caustic: far_caustic's ball with its centre 0.6 m above the floor (the light's focus
# through it about 0.95 m from the centre, the floor 1.22 m along the ray through it)
LIFTED_BALL = ((0.0, 0.0, 0.6), 0.5)

# rough_caustic: point_caustic's ball of rough glass (GGX, the exact reference's model)
ROUGH_CAUSTIC_ROUGHNESS = 0.1

# mirror_caustic
POINT_POS = (-0.6, 0.3, 1.2)
POINT_POWER = 100.0                              # W
MIRROR_CENTER = np.array([0.8, 0.3, 0.7])
MIRROR_NORMAL = np.array([-1.0, 0.0, -0.45]) / np.linalg.norm([-1.0, 0.0, -0.45])
MIRROR_SIZE = (0.8, 0.6)                         # along y, along the tilted vertical

# clamped_caustic: the ball on the floor, the light 0.6 m above its top inside a shade (an open
# box, black inside and out) whose sides reach 0.35 m below the light: the cone it leaves open
# (half-angle 30 degrees) holds the ball (22 degrees) and a square pool of floor, never the
# back wall
CLAMPED_BALL = ((0.0, 0.8, 0.35), 0.35)
CLAMPED_ROUGHNESS = 0.16
CLAMPED_POS = (0.0, 0.8, 1.3)
CLAMPED_POWER = 1000.0                           # W
CLAMPED_SHADE = ((-0.2, 0.6, 0.95), (0.2, 1.0, 1.45))   # its corners (lo, hi)
CLAMP = 100.0                                    # Clamp Direct and Clamp Indirect


def mirror_corners() -> np.ndarray:
    """The mirror's four corners (counter-clockwise seen from the side it faces)."""
    n = MIRROR_NORMAL
    u = np.array([0.0, 1.0, 0.0])                # horizontal edge
    v = np.cross(n, u)                           # in the plane, going up
    if v[2] < 0:
        v = -v
    hu, hv = MIRROR_SIZE[0] / 2, MIRROR_SIZE[1] / 2
    c = MIRROR_CENTER
    corners = np.array([c - hu * u - hv * v, c + hu * u - hv * v, c + hu * u + hv * v,
                        c - hu * u + hv * v])
    e1, e2 = corners[1] - corners[0], corners[2] - corners[0]
    if np.dot(np.cross(e1, e2), n) < 0:
        corners = corners[::-1].copy()
    return corners


def mirror_image(p) -> np.ndarray:
    p = np.asarray(p, float)
    return p - 2.0 * np.dot(p - MIRROR_CENTER, MIRROR_NORMAL) * MIRROR_NORMAL


def _stage(scene, target=(0.2, 0.2, 0.25)):
    """The floor and back wall, the camera at the front looking at ``target``."""
    white = lambert("Floor", FLOOR)
    quad(scene, "Floor", [(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)], white)
    quad(scene, "Back", [(-2, 2, 0), (2, 2, 0), (2, 2, 2.5), (-2, 2, 2.5)], white)
    eye = np.array([0.1, -2.8, 1.7])
    d = np.asarray(target, float) - eye
    camera_world_render(scene, tuple(eye),
                        (math.atan2(math.hypot(d[0], d[1]), -d[2]), 0.0,
                         math.atan2(d[0], d[1]) * -1.0), RESOLUTION)


def _light(scene, name, kind, location, power, direction=None):
    data = bpy.data.lights.new(name, kind)
    data.energy = power
    data.shadow_soft_size = LIGHT_RADIUS
    data.color = (1.0, 1.0, 1.0)
    obj = bpy.data.objects.new(name, data)
    obj.location = location
    if direction is not None:      # a light looks along its local -z
        d = np.asarray(direction, float) / np.linalg.norm(direction)
        obj.rotation_euler = (math.acos(-d[2]), 0.0, math.atan2(-d[0], d[1]))
    obj.visible_camera = False
    scene.collection.objects.link(obj)
    return obj


def _glass_ball(scene=None, segments=48, rings=24, ball=BALL):
    """The stage with a glass ball (centre, radius) on its floor (glass_caustic,
    point_caustic; far_caustic's bigger ball)."""
    scene = new_scene(scene)
    _stage(scene)
    center, radius = ball
    sphere(scene, "GlassBall", center, radius, glass("Glass"), segments, rings)
    return scene


def glass_caustic(scene=None):
    """A glass ball on the floor under a spot light (see the module docstring)."""
    scene = _glass_ball(scene)
    spot = _light(scene, "Spot", 'SPOT', SPOT_POS, SPOT_POWER,
                  direction=np.subtract(BALL[0], SPOT_POS))
    spot.data.spot_size = SPOT_SIZE
    spot.data.spot_blend = 0.1
    return scene


def point_caustic(scene=None):
    """The glass ball on the floor under a point light of radius 0 (see the module
    docstring)."""
    scene = _glass_ball(scene, *POINT_BALL_SEGMENTS)
    point = _light(scene, "Point", 'POINT', SPOT_POS, SPOT_POWER)
    point.data.shadow_soft_size = 0.0
    return scene


def far_caustic(scene=None):
    """The bigger glass ball under a point light of radius 0 3.5 m away (see the module
    docstring)."""
    scene = _glass_ball(scene, *POINT_BALL_SEGMENTS, ball=FAR_BALL)
    point = _light(scene, "Point", 'POINT', FAR_POS, FAR_POWER)
    point.data.shadow_soft_size = 0.0
    return scene


def lifted_caustic(scene=None):
    """far_caustic with the ball lifted off the floor (see the module docstring)."""
    scene = _glass_ball(scene, *POINT_BALL_SEGMENTS, ball=LIFTED_BALL)
    point = _light(scene, "Point", 'POINT', FAR_POS, FAR_POWER)
    point.data.shadow_soft_size = 0.0
    return scene


def rough_caustic(scene=None):
    """point_caustic with rough glass (see the module docstring)."""
    scene = point_caustic(scene)
    ball = next(o for o in scene.objects if o.name.startswith("GlassBall"))
    p = ball.active_material.node_tree.nodes["Principled BSDF"]
    p.inputs["Roughness"].default_value = ROUGH_CAUSTIC_ROUGHNESS
    p.distribution = 'GGX'
    return scene


def mirror_caustic(scene=None):
    """A point light and a tilted planar mirror (see the module docstring)."""
    scene = new_scene(scene)
    _stage(scene)
    m = principled("Mirror", {"Base Color": (1.0, 1.0, 1.0), "Metallic": 1.0, "Roughness": 0.0})
    quad(scene, "Mirror", [tuple(c) for c in mirror_corners()], m)
    _light(scene, "Point", 'POINT', POINT_POS, POINT_POWER)
    return scene


def clamped_caustic(scene=None):
    """A polished metal ball under a point light of radius 0 in a lamp shade, Clamp Direct and
    Indirect ``CLAMP`` (see the module docstring)."""
    scene = new_scene(scene)
    _stage(scene, target=(0.0, 1.2, 0.6))
    center, radius = CLAMPED_BALL
    sphere(scene, "MetalBall", center, radius,
           principled("Metal", {"Base Color": (0.9, 0.9, 0.9), "Metallic": 1.0,
                                "Roughness": CLAMPED_ROUGHNESS}), 64, 32)
    (x0, y0, z0), (x1, y1, z1) = CLAMPED_SHADE
    black = lambert("Shade", (0.0, 0.0, 0.0))
    for name, corners in (("ShadeTop", [(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)]),
                          ("ShadeFront", [(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)]),
                          ("ShadeBack", [(x0, y1, z0), (x0, y1, z1), (x1, y1, z1), (x1, y1, z0)]),
                          ("ShadeLeft", [(x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0)]),
                          ("ShadeRight", [(x1, y0, z0), (x1, y1, z0), (x1, y1, z1),
                                          (x1, y0, z1)])):
        quad(scene, name, corners, black)
    point = _light(scene, "Point", 'POINT', CLAMPED_POS, CLAMPED_POWER)
    point.data.shadow_soft_size = 0.0
    c = scene.cycles
    c.sample_clamp_direct = c.sample_clamp_indirect = CLAMP
    return scene
