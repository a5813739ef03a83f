"""The paper's bulb box: the Cornell room lit only by a light bulb.

No ceiling light and no boxes.  A small emissive sphere (the filament, radius 0.05 m, Emission
strength ``FILAMENT_RADIANCE``) sits inside a clear glass sphere (radius 0.15 m, IOR 1.5)
hanging 0.4 m under the ceiling centre, and a glass ball (radius 0.3 m) lies on the floor.
Every wall is lit through glass only, so direct light (shadow rays) cannot reach it: caustic
paths that photon mapping handles and path tracing finds hard.

Filament power = pi * 4 pi r^2 * L = 0.0987 * L W: ``FILAMENT_RADIANCE`` = 120 gives 11.8 W,
the Cornell box lamp's power, so both rooms are lit alike."""
from __future__ import annotations

from ppm_engine.blender.scenes.cornell_box import (
    camera_world_render,
    emission,
    glass,
    new_scene,
    room,
    sphere,
)

FILAMENT_RADIANCE = 120.0
BULB_CENTER = (0.0, 0.0, 1.6)
BALL_CENTER = (0.3, 0.2, 0.3)


def build(scene=None):
    """Build the bulb box (see the module docstring); returns the scene."""
    scene = new_scene(scene)
    room(scene)
    clear = glass("Glass")
    sphere(scene, "Filament", BULB_CENTER, 0.05, emission("Filament", FILAMENT_RADIANCE), 16, 8)
    sphere(scene, "Bulb", BULB_CENTER, 0.15, clear, 32, 16)
    sphere(scene, "GlassBall", BALL_CENTER, 0.3, clear, 32, 16)
    camera_world_render(scene)
    return scene
