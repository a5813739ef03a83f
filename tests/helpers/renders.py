"""A SceneArrays rendered by the whole engine, without Blender."""
import numpy as np

from ppm_engine.render.options import RenderOptions
from ppm_engine.render.renderer import Renderer


def every_feature(**kw) -> RenderOptions:
    """RenderOptions with kernels of every feature unless ``kw`` says otherwise: the same image
    as the scene's own kernels (tests/test_skips.py checks it), from the one build every test of
    the run shares, where each scene's own features would build its own programs (most of a cold
    test run's time)."""
    return RenderOptions(**{"specialize": False, **kw})


def render(scene, passes, seed=0, **opts):
    """The image of ``scene`` after ``passes`` passes (finite, no NaN dropped), with kernels of
    every feature unless ``opts`` say otherwise (every_feature)."""
    r = Renderer(scene, every_feature(seed=seed, **opts))
    for _ in range(passes):
        stats = r.iterate()
    img = r.image()
    assert np.isfinite(img).all() and stats.nan_dropped == 0
    r.close()
    return img
