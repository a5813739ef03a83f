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


def scene_features(scene, **opts) -> frozenset:
    """The features a Renderer of ``scene`` (RenderOptions ``opts``, by default the scene's own
    kernels) builds its kernels for (Renderer._start's kernel_defines), without building them:
    each feature set is a kernel build of its own, a second or more even unlaunched
    (tests/test_skips.py test_specialised_kernels_are_separate_programs checks that a
    Renderer's are these)."""
    from ppm_engine.render.device import get_device
    from ppm_engine.render.device_scene import DeviceScene
    o = RenderOptions(**opts)
    dev = get_device(o.device)
    with dev.lock:       # (a world's map baked by the shared program of every node)
        return DeviceScene(dev, scene, specialize=False).kernel_defines(o.specialize,
                                                                         o.editable)[0]
