"""The two estimators of indirect light (RenderOptions.indirect): the paper's photons for every
bounce, and eye paths with photons for caustics only (kernels/integrator/indirect_paths.h).  They
split the light paths differently, so on the same scene they must agree (no path counted twice or
missed), and "auto" must choose by the scene's share of caustic first scatterings."""
import numpy as np
import pytest

from ppm_engine.oracle import analytic
from ppm_engine.oracle.procedural import MeshBuilder, cornell_box, look_at
from ppm_engine.render.options import RenderOptions, SettingsError
from ppm_engine.render.renderer import Renderer
from ppm_engine.scene.arrays import CAMERA_PERSP
from ppm_engine.scene.camera import make_camera, perspective_extent
from tests.helpers.procedural_scenes import furnace_scene
from tests.helpers.renders import every_feature, render


def renders(scene, passes, seeds, **opts):
    out = []
    for seed in seeds:
        r = Renderer(scene, every_feature(seed=seed, **opts))
        for _ in range(passes):
            stats = r.iterate()
        assert stats.nan_dropped == 0
        img = r.image()[..., :3]
        assert np.isfinite(img).all()
        out.append(img)
        r.close()
    return np.asarray(out, np.float64)


def blocks(imgs, b):
    n, h, w, c = imgs.shape
    return imgs.reshape(n, h // b, b, w // b, b, c).mean(axis=(2, 4, 5))


def assert_agree(scene, passes, bias, seeds=4, block=4, **opts):
    """Photons and paths on the same scene: per block of block x block pixels, the two means
    over independent seeds within 4 standard errors plus ``bias`` (relative: the photon
    map's radius blurs what paths render sharp)."""
    a = blocks(renders(scene, passes, range(seeds), indirect="photons", **opts), block)
    b = blocks(renders(scene, passes, range(10, 10 + seeds), indirect="paths", **opts), block)
    ma, mb = a.mean(axis=0), b.mean(axis=0)
    se = np.sqrt(a.var(axis=0, ddof=1) / seeds + b.var(axis=0, ddof=1) / seeds)
    tol = 4 * se + bias * np.maximum(ma, mb) + 1e-4
    assert (np.abs(ma - mb) <= tol).mean() >= 0.95, np.abs(ma - mb).max()
    assert abs(ma.mean() - mb.mean()) <= 0.02 * ma.mean(), (ma.mean(), mb.mean())
    return ma, mb


def test_paths_and_photons_agree_where_light_comes_through_glass():
    """The bulb box: every photon's first scattering is the bulb's glass (all caustic), the
    paths' next-event estimation is blocked by the glass; indirect light by either estimator
    is the same image."""
    scene = cornell_box(16, 16, bulb=True)
    assert_agree(scene, 48, bias=0.08, max_bounces=6)


def box_with_ball(W=16, radius=0.35, **ball):
    """The Cornell box's walls and ceiling lamp with a ball on the floor, of the material
    MeshBuilder.material makes of ``ball`` (default: clear glass, the ball's caustic under it
    and diffuse inter-reflection, a third of the image)."""
    mb = MeshBuilder()
    white = mb.material("white", (0.73, 0.73, 0.73))
    red = mb.material("red", (0.63, 0.065, 0.05))
    ball = mb.material("ball", **(ball or dict(base=(1, 1, 1), transmission=1.0,
                                                 roughness=0.0, ior=1.5)))
    lamp = mb.material("lamp", (0, 0, 0), emission=(15.0,) * 3)
    mb.quad((0, 0, 0), (1, 0, 0), (0, 1, 0), white)
    mb.quad((0, 0, 2), (0, 1, 0), (1, 0, 0), white)
    mb.quad((0, 1, 1), (0, 0, 1), (1, 0, 0), white)
    mb.quad((-1, 0, 1), (0, 0, 1), (0, 1, 0), red)
    mb.quad((1, 0, 1), (0, 1, 0), (0, 0, 1), white)
    mb.quad((0, 0, 1.99), (0, 0.4, 0), (0.4, 0, 0), lamp)
    mb.sphere((0.2, 0.1, radius), radius, ball, 24, 12)
    ext = perspective_extent(W, W, 35.0, 36.0)
    cam = make_camera(type=CAMERA_PERSP, width=W, height=W,
                      to_world=look_at((0, -2.9, 1), (0, 0, 1)), extent=ext[:2], clip=(0.1, 100))
    return mb.build(camera=cam)


def light_traced(scene):
    """(image, coverage) of ``scene`` by light tracing (unbiased, no photon map, no eye
    paths), 32 bounces: the reference over the pixels it renders.  2.6M photons: 20 passes
    moved the tests' departures by at most 0.06 % of the mean and 0.1 % per quarter against
    10 (the box with the metal ball: 0.65 % against 0.71 % at caustic_roughness 0.2)."""
    from ppm_engine.render.light_tracer import LightTracer
    lt = LightTracer(scene, photons=1 << 18, seed=3, max_bounces=32, specialize=False)
    try:
        lt.trace(10)
        return lt.image().astype(np.float64), lt.coverage()
    finally:
        lt.close()


def assert_matches_light_tracing(img, ref, cover, mean_tol, quarter_tol=0.03, what=""):
    """``img`` (16 x 16) against light tracing over the covered pixels: in the mean within
    ``mean_tol``, per quarter of the image within ``quarter_tol`` (relative)."""
    assert abs(img[cover].mean() / ref[cover].mean() - 1.0) < mean_tol, what
    for rows in (slice(0, 8), slice(8, 16)):
        for cols in (slice(0, 8), slice(8, 16)):
            c = cover[rows, cols]
            ratio = img[rows, cols][c].mean() / ref[rows, cols][c].mean()
            assert abs(ratio - 1.0) < quarter_tol, (what, rows, cols, ratio)


def test_both_match_light_tracing_in_a_box_with_a_glass_ball():
    """Both kinds of light at once: the box's inter-reflection is the paths' in one mode and
    the photons' in the other, the ball's caustic (and the light that comes back through the
    ball) the photons' in both.  Against light tracing (unbiased, no photon map, no eye paths)
    over the pixels it renders: counting a path twice or never shows.  Eye paths are unbiased
    (1 %); the photons' radius at 16x16 pixels still darkens the corners (5 %)."""
    scene = box_with_ball()
    ref, cover = light_traced(scene)
    assert cover.mean() > 0.7
    # two seeds each (measured: paths 0.12 % off in the mean, at most 0.38 % per quarter;
    # photons 0.56 %; with four: 0.28 %, 0.73 %, 0.66 %)
    paths = renders(scene, 100, range(2), indirect="paths", max_bounces=32).mean(axis=0)
    # in the mean and per quarter of the image (the caustic is in the lower half)
    assert_matches_light_tracing(paths, ref, cover, 0.01)
    photons = renders(scene, 100, range(2), indirect="photons", max_bounces=32).mean(axis=0)
    assert abs(photons[cover].mean() / ref[cover].mean() - 1.0) < 0.05
    # the scene has both: the auto mode's pilot sees some caustic first scatterings
    r = Renderer(scene, every_feature())
    try:
        assert 0.0 < r.caustic_fraction < 0.5 and r.path_indirect
    finally:
        r.close()


def test_glossy_light_is_counted_once_by_either_estimator():
    """Light whose first scattering is a rough glossy reflection: the eye paths' (next-event
    estimation through the metal, RenderOptions.caustic_roughness 0.2) or the caustic photons'
    (caustic_roughness 1.0: every followed lobe makes caustics).  Both render the box with a
    rough metal ball (0.35, white) as light tracing does over the pixels it renders: a path
    counted twice or never shows in the mean (eye paths: 1 %) and per quarter of the image."""
    scene = box_with_ball(radius=0.45, base=(0.95, 0.95, 0.95), metallic=1.0, roughness=0.35)
    ref, cover = light_traced(scene)
    assert cover.mean() > 0.6
    # (at 0.2 the scene makes no caustics; the photon pass runs all the same, so that a photon
    # whose first scattering is the metal's would show if it were stored)
    # (the run's shared build of every feature for both: the roughness settings are the Light
    # Paths record's, no kernel flag)
    for cr, tol in ((0.2, 0.01), (1.0, 0.015)):
        paths = renders(scene, 100, range(4), indirect="paths", max_bounces=32,
                        caustic_roughness=cr, skip_unneeded_photon_pass=False).mean(axis=0)
        assert_matches_light_tracing(paths, ref, cover, tol, what=f"caustic_roughness {cr}")
    # where the ball's light is the eye paths', it makes no caustics: no photon pass
    for cr, photon_pass in ((0.2, False), (1.0, True)):
        r = Renderer(scene, every_feature(indirect="paths", caustic_roughness=cr))
        try:
            assert ("photon" in r.iterate().phase_ms) == photon_pass
        finally:
            r.close()


def test_paths_and_photons_agree_beside_a_mirror():
    """A point light beside a mirror over a floor, several bounces: the mirror's caustic is the
    photons' in both modes, the floor's inter-reflection (floor, mirror, floor) the paths'
    in one and the photons' in the other."""
    scene = analytic.mirror_caustic(W=16)
    assert_agree(scene, 48, bias=0.06, max_bounces=4)


def test_auto_chooses_paths_without_caustics():
    """A diffuse Cornell box: no closure makes caustics, so paths, and no photon pass at all."""
    r = Renderer(cornell_box(16, 16), every_feature())
    try:
        assert r.path_indirect and r.caustic_fraction == 0.0 and not r.photons_needed
        stats = r.iterate()
        assert stats.photons_emitted == 0 and stats.indirect == "paths"
        assert "paths" in stats.line() and "photons" not in stats.line()
    finally:
        r.close()


def test_auto_chooses_photons_for_a_bulb_in_glass():
    """Every photon leaves the bulb through its glass: the pilot measures a caustic fraction
    near 1 and auto keeps the paper's photons for all indirect light."""
    r = Renderer(cornell_box(16, 16, bulb=True), every_feature())
    try:
        assert r.caustic_fraction > 0.95 and not r.path_indirect and r.photons_needed
        assert r.iterate().indirect == "photons"
    finally:
        r.close()


def test_auto_chooses_paths_beside_a_mirror():
    """Most of the point light's photons meet the floor first: paths, with caustic photons for
    the mirror's caustic (the pilot's fraction is the mirror's share of the light)."""
    r = Renderer(analytic.mirror_caustic(W=16), every_feature())
    try:
        assert 0.0 < r.caustic_fraction < 0.5 and r.path_indirect and r.photons_needed
        stats = r.iterate()
        assert stats.photons_stored > 0 and "caustic photons" in stats.line()
    finally:
        r.close()


def test_mirror_caustic_by_paths_matches_the_closed_form():
    """The mirror's caustic through the caustic photons alone (max_bounces 1: direct light by
    the eye paths, the reflected light by photons), against the analytic radiance."""
    W = 16
    scene = analytic.mirror_caustic(W=W)
    ref = analytic.mirror_caustic_radiance(W=W)
    imgs = renders(scene, 64, range(4), indirect="paths", max_bounces=1)[..., 0]
    m = imgs.mean(axis=0)
    assert abs(m.mean() - ref.mean()) <= 0.02 * ref.mean(), (m.mean(), ref.mean())


def test_indirect_setting_is_validated():
    with pytest.raises(SettingsError, match="indirect"):
        RenderOptions(indirect="bidirectional").validate()
    for mode in ("auto", "photons", "paths"):
        RenderOptions(indirect=mode).validate()


def _sobol_directions():
    """Dimensions 1-3 of the Sobol sequence from Joe & Kuo's primitive polynomials (degree s,
    coefficients a) and initial numbers m: direction number i of each, bits reversed."""
    out = []
    for s, a, m in ((1, 0, [1]), (2, 1, [1, 3]), (3, 1, [1, 3, 1])):
        m = list(m)
        for k in range(s, 32):
            x = m[k - s] ^ (m[k - s] << s)
            for j in range(1, s):
                if (a >> (s - 1 - j)) & 1:
                    x ^= m[k - j] << j
            m.append(x)
        out.append([int(f"{m[i] << (31 - i):032b}"[::-1], 2) for i in range(32)])
    return out


def _ld_sets(keys, passes, first_pass=0, set_index=0):
    import pyopencl as cl

    from ppm_engine.render.device.context import get_device
    dev = get_device("")
    keys = np.asarray(keys, np.uint32)
    out = np.empty((len(keys) * passes, 4), np.float32)
    mf = cl.mem_flags
    kb = cl.Buffer(dev.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=keys)
    ob = cl.Buffer(dev.context, mf.WRITE_ONLY, out.nbytes)
    dev.programs.get("test/debug.cl").ld_sets(dev.queue, (out.shape[0],), None, kb,
                                         np.uint32(len(keys)), np.uint32(passes),
                                         np.uint32(first_pass), np.uint32(set_index), ob)
    cl.enqueue_copy(dev.queue, out, ob)
    return out.reshape(len(keys), passes, 4)


# t of each pair of a set's dimensions (Joe & Kuo's numbers, up to 2^10 points)
T_VALUES = {(0, 1): 0, (0, 2): 1, (1, 2): 1, (0, 3): 2, (1, 3): 2, (2, 3): 2}


@pytest.mark.gpu
def test_low_discrepancy_sets():
    """rng.h's ld_set: its direction numbers are Joe & Kuo's; a pixel's first 2^m passes (and
    any aligned run of 2^m, also past the 16 shuffled bits) put one point in each of 2^m equal
    cells of every dimension, the first two dimensions form a (0, m, 2)-net (one point in
    every elementary box of area 2^-m), the other pairs (t, m, 2)-nets with t <= 2; over pixels
    each pass's numbers are uniform and two sets are independent."""
    import re
    from pathlib import Path
    text = (Path(__file__).parents[1] / "kernels" / "rng.h").read_text()
    body = text[text.index("SOBOL_V[3][32] = {"):]
    table = [int(v, 16) for v in re.findall(r"0x([0-9a-f]{8})u", body[:body.index("};")])]
    assert table == [v for row in _sobol_directions() for v in row]
    keys = (np.arange(1, 9, dtype=np.uint64) * 2654435761 % 2 ** 32).astype(np.uint32)
    for first in (0, 1 << 16):
        pts = _ld_sets(keys, 1024, first)
        for m in (2, 5, 8, 10):
            n = 1 << m
            for block in range(0, 1024, n)[:2]:
                for p in pts[:, block:block + n]:
                    for d in range(4):
                        assert len(set((p[:, d] * n).astype(int))) == n, (first, m, d)
                    for (d0, d1), t in T_VALUES.items():   # (t, m, 2)-nets
                        for la in range(m - t + 1):
                            cells = set(zip((p[:, d0] * (1 << la)).astype(int),
                                            (p[:, d1] * (1 << (m - t - la))).astype(int)))
                            assert len(cells) == n >> t, (first, m, d0, d1, la)
    # over 4096 pixels, pass 5: uniform in each dimension; sets 0 and 1 uncorrelated
    many = (np.arange(4096, dtype=np.uint64) * 2246822519 % 2 ** 32).astype(np.uint32)
    a = _ld_sets(many, 8, 0, 0)[:, 5]
    b = _ld_sets(many, 8, 0, 1)[:, 5]
    for d in range(4):
        counts = np.bincount((a[:, d] * 16).astype(int), minlength=16)
        chi2 = ((counts - 256) ** 2 / 256).sum()
        assert chi2 < 45, (d, chi2)                  # 15 degrees of freedom: p < 1e-4
        assert abs(np.corrcoef(a[:, d], b[:, d])[0, 1]) < 0.07
    assert abs(np.corrcoef(a[:, 0], a[:, 1])[0, 1]) < 0.07


@pytest.mark.gpu
def test_roulette_survival_keeps_the_furnace_s_noise_low_between_powers_of_two():
    """The eye paths' Russian roulette (indirect_paths.h): a bounce survives with up to the
    square root of its albedo (at most INDIRECT_RR_Q), not with the albedo itself as Cycles'
    rule settles at.  In a furnace all noise is the roulette's; at 44 passes (between powers
    of two, where the roulette's one Sobol number covers [0, 1) least evenly) the error
    against the closed form, 16 x 16, albedo 0.5, is 0.0047-0.0053 with this rule and
    0.0069-0.0077 with Cycles' (seeds 0-2); the mean stays the closed form."""
    rho = 0.5
    scene = furnace_scene(rho, 1.0)
    expected = 1.0 / (1.0 - rho)
    imgs = [render(scene, 44, seed=s, max_bounces=64, indirect="paths")[..., :3] / expected
            for s in range(3)]
    err = float(np.mean([np.sqrt(np.mean((i - 1.0) ** 2)) for i in imgs]))
    assert err < 0.006, err
    assert abs(float(np.mean(imgs)) - 1.0) < 0.004


def test_a_re_render_keeps_its_pilot(monkeypatch):
    """Persistent data: a re-render of the same scene with the same settings reuses the pilot's
    fraction (no device work before its first pass); another seed or a new scene measures
    again."""
    scene = analytic.mirror_caustic(W=16)
    r = Renderer(scene, every_feature())
    try:
        f = r.caustic_fraction
        calls = []
        real = r.caustic_fraction_pilot
        monkeypatch.setattr(r, "caustic_fraction_pilot", lambda o: calls.append(o) or real(o))
        r.reset(every_feature())
        assert r.caustic_fraction == f and calls == []
        r.reset(every_feature(seed=5))
        assert len(calls) == 1 and abs(r.caustic_fraction - f) < 0.02
        r.reset(every_feature(seed=5), scene.replace(lights=scene.lights.copy()))
        assert len(calls) == 2
    finally:
        r.close()
