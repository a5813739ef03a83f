"""Accuracy against exact answers: caustics through a mirror and a glass slab, and the error
falling as passes grow (issue: accurate, and proven so).  docs/ACCURACY.md has the numbers."""
import numpy as np
import pytest

from ppm_engine import analytic as A
from ppm_engine.options import RenderOptions
from ppm_engine.renderer import Renderer


def progressive(scene, checkpoints, max_bounces, photons=1 << 15, seed=0):
    """Images at the given pass counts, one render."""
    r = Renderer(scene, RenderOptions(photons_per_pass=photons, max_bounces=max_bounces,
                                      seed=seed))
    out = {}
    for k in range(1, max(checkpoints) + 1):
        s = r.iterate()
        if k in checkpoints:
            out[k] = r.image()[..., 0]
    assert s.nan_dropped == 0 and all(np.isfinite(v).all() for v in out.values())
    r.close()
    return out


def rel_rmse(img, ref):
    return np.sqrt(((img - ref) ** 2).mean()) / ref.mean()


def slope(passes, errors):
    return np.polyfit(np.log(passes), np.log(errors), 1)[0]


def test_mirror_caustic_matches_the_image_source():
    """Path tracing cannot render this (a point light seen in a perfect mirror); photons must,
    within 2 % in the caustic: light reaching the floor only through the mirror."""
    W = 32
    ref = A.mirror_caustic_radiance(W)
    caustic = A.mirror_caustic_only(W)
    imgs = progressive(A.mirror_caustic(W), (25, 100, 400), max_bounces=1)
    img = imgs[400]
    assert img.mean() == pytest.approx(ref.mean(), rel=0.005)
    # the caustic region: where the mirror's light is at least a third of the total
    region = caustic > ref / 3
    assert region.sum() > 100
    assert img[region].mean() == pytest.approx(ref[region].mean(), rel=0.02)
    assert rel_rmse(img[region], ref[region]) < 0.03
    errs = [rel_rmse(imgs[k], ref) for k in (25, 100, 400)]
    assert errs[0] > errs[1] > errs[2] and slope((25, 100, 400), errs) < -0.25, errs


def test_glass_slab_matches_snell_and_fresnel():
    """A point light above a glass slab: the floor is lit only through both faces; the answer
    is an independent float64 computation (Snell, Fresnel, ray-tube Jacobian)."""
    W = 24
    ref = A.glass_slab_radiance(W)
    imgs = progressive(A.glass_slab(W), (25, 100, 400), max_bounces=2)
    img = imgs[400]
    assert img.mean() == pytest.approx(ref.mean(), rel=0.01)
    # the falloff: centre vs rim of the view within 3 %
    c = slice(W // 2 - 3, W // 2 + 3)
    assert img[c, c].mean() == pytest.approx(ref[c, c].mean(), rel=0.03)
    rim = np.ones((W, W), bool)
    rim[3:-3, 3:-3] = False
    assert img[rim].mean() == pytest.approx(ref[rim].mean(), rel=0.03)
    errs = [rel_rmse(imgs[k], ref) for k in (25, 100, 400)]
    assert errs[0] > errs[1] > errs[2] and slope((25, 100, 400), errs) < -0.25, errs


@pytest.mark.slow
def test_mirror_caustic_converges_over_thousands_of_passes():
    """Long version (python -m pytest -m slow tests/test_accuracy.py): error keeps falling to
    1000+ passes; at 1000 passes it is well below its value at 100."""
    W = 32
    ref = A.mirror_caustic_radiance(W)
    marks = (10, 30, 100, 300, 1000, 2000)
    imgs = progressive(A.mirror_caustic(W), marks, max_bounces=1)
    errs = [rel_rmse(imgs[k], ref) for k in marks]
    assert all(a > b for a, b in zip(errs, errs[1:])), errs
    assert errs[4] < 0.5 * errs[2] and slope(marks, errs) < -0.3
