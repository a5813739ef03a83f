"""SceneArrays built without Blender: one light record, the furnace (a closed emissive sphere)
and a small room (a floor and a wall, glass and a mirror on demand)."""
import numpy as np

from ppm_engine.oracle.procedural import MeshBuilder, look_at
from ppm_engine.scene.arrays import LIGHT_DTYPE
from ppm_engine.scene.camera import make_camera, perspective_extent


def light(type, **kw):
    """One light record of ``type``, pointing down, fields from kw."""
    L = np.zeros(1, LIGHT_DTYPE)
    L["type"] = type
    L["direction"] = (0, 0, -1)
    for k, v in kw.items():
        L[k] = v
    return L


def furnace_scene(rho, Le, W=16):
    """The furnace: a closed sphere of albedo rho and emission Le seen from inside, W x W."""
    mb = MeshBuilder()
    m = mb.material("furnace", (rho,) * 3, emission=(Le,) * 3)
    mb.sphere((0, 0, 0), 1.0, m, 24, 12, smooth=False, inward=True)
    ext = perspective_extent(W, W, 20, 36)
    cam = make_camera(width=W, height=W, to_world=look_at((0, 0, 0), (1, 0.2, 0.1)),
                      extent=ext[:2], clip=(0.01, 100))
    return mb.build(camera=cam)


def room(lights=None, glass=False, mirror=False, world=(0, 0, 0), aperture=0.0, W=20):
    """A white floor and wall (a glass sphere, a mirror on demand), ``lights`` and a constant
    ``world``, seen W x W through a lens of radius ``aperture``."""
    mb = MeshBuilder()
    white = mb.material("white", (0.7, 0.7, 0.7))
    mb.quad((0, 0, 0), (1, 0, 0), (0, 1, 0), white)
    mb.quad((0, 1, 1), (0, 0, 1), (1, 0, 0), white)
    if glass:
        mb.sphere((0.3, 0.2, 0.3), 0.3, mb.material("glass", (1, 1, 1), transmission=1.0,
                                                    roughness=0.0), 16, 8)
    if mirror:
        mb.quad((-0.5, 0.5, 0.5), (0.3, 0, 0), (0, 0, 0.3),
                mb.material("mirror", (0.9, 0.9, 0.9), metallic=1.0, roughness=0.0))
    ext = perspective_extent(W, W, 35.0, 36.0)
    cam = make_camera(width=W, height=W, to_world=look_at((0, -2.9, 1), (0, 0, 0.5)),
                      extent=ext[:2], clip=(0.1, 100), aperture_radius=aperture,
                      focus_distance=3.0)
    return mb.build(camera=cam, lights=lights, world=world)
