"""A SceneArrays rendered by the whole engine, without Blender."""
import numpy as np

from ppm_engine.render.options import RenderOptions
from ppm_engine.render.renderer import Renderer


def render(scene, passes, seed=0, **opts):
    """The image of ``scene`` after ``passes`` passes (finite, no NaN dropped), with kernels of
    every feature unless ``opts`` say otherwise (the same image: tests/conftest.py
    configure_tiny)."""
    r = Renderer(scene, RenderOptions(seed=seed, **{"specialize": False, **opts}))
    for _ in range(passes):
        stats = r.iterate()
    img = r.image()
    assert np.isfinite(img).all() and stats.nan_dropped == 0
    r.close()
    return img
