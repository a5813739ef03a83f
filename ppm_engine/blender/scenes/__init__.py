"""Example scenes built with bpy from nothing (no binary files in the repository).

    from ppm_engine.blender.scenes import EXAMPLES, build_example, save_example
    scene = EXAMPLES["cornell_box"]()        # resets the current file, returns the scene
    save_example("bulb_box", "bulb_box.blend")

Each builder takes an optional ``scene``: None resets the file (empty factory settings) and
builds into its scene; a given scene is emptied and reused.  The render engine is left as it
is.  The geometry matches ``ppm_engine.oracle.procedural.cornell_box`` (the arrays version used by
the core tests and the benchmark)."""
from __future__ import annotations

from ppm_engine.blender.scenes import (
    bulb_box,
    caustics,
    cornell_box,
    fog_lens,
    fog_room,
    furnace,
    many_lights,
    metal,
    outdoor,
    pool,
    smoke,
    sun_cone,
)

EXAMPLES = {
    "cornell_box": cornell_box.build,
    "bulb_box": bulb_box.build,
    "glass_caustic": caustics.glass_caustic,     # also the benchmark's caustic scenes
    "point_caustic": caustics.point_caustic,     # the hard one: a radius-0 point light
    "rough_caustic": caustics.rough_caustic,     # the same through rough glass
    "far_caustic": caustics.far_caustic,         # a bigger ball, the light 3.5 m away
    "lifted_caustic": caustics.lifted_caustic,   # far_caustic's ball off the floor
    "mirror_caustic": caustics.mirror_caustic,
    "clamped_caustic": caustics.clamped_caustic,  # a metal ball's caustic under a clamp
    "pool_caustic": pool.build,                  # the sun's caustic seen through water
    "furnace": furnace.build,                    # the benchmark's closed-form scene
    "many_lights": many_lights.build,            # the benchmark's many-light scene
    "hdri_sun": outdoor.build,                   # an HDRI with its sun in the image
    "glossy_metal": metal.build,                 # glossy metal under Blender's default light
    "sun_cone": sun_cone.build,                  # a sun-lit cone on a glossy floor
    "fog_lens": fog_lens.build,                  # a glass ball in fog: a volumetric caustic
    "fog_room": fog_room.build,                  # homogeneous fog under a spot light
    "smoke": smoke.build,                        # noise-textured smoke under a sun and a sky
}


def build_example(name: str, scene=None):
    """Build an example scene (replacing the current file's content); returns the scene."""
    try:
        builder = EXAMPLES[name]
    except KeyError:
        raise KeyError(f"unknown example '{name}'; examples: {', '.join(EXAMPLES)}") from None
    return builder(scene)


def save_example(name: str, path) -> None:
    """Build an example and save it as a .blend file at ``path``."""
    import bpy
    build_example(name)
    bpy.ops.wm.save_as_mainfile(filepath=str(path), check_existing=False)
