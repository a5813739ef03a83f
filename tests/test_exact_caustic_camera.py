"""The camera's side of point_caustic's exact-geometry reference (ppm_engine/tools/bench/
exact_caustic_camera.py), which renders the pixels that see the glass ball: the chain's Fresnel
split against its weights' sum and the random choice it replaces, the rough glass's kernel
against its sampler, a ray through the ball's centre against a hand computation, the photons'
irradiance textures against the closed-form direct light, the ball's image integrated over the
pixel filter against brute-force supersampling, and every pixel covered."""
import math

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from ppm_engine.blender.scenes.caustics import BALL, FLOOR, point_caustic
from ppm_engine.tools.bench import exact_caustic as ec
from ppm_engine.tools.bench import exact_caustic_camera as ecc
from ppm_engine.tools.bench import exact_caustic_scene as ecs
from ppm_engine.tools.bench import exact_film as ef
from ppm_engine.tools.bench import exact_optics as eo
from tests.helpers.blender_scenes import square


def _scene(width=16):
    return square(point_caustic(), width)


def _dirs(n, rng):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


# --- the glass's split ------------------------------------------------------------------------
def test_smooth_split_weights_are_fresnel_and_sum_to_one():
    """Smooth glass: reflected F, refracted 1 - F (the textbook Fresnel at the angle), summing
    to 1; from inside beyond the critical angle all of it reflected."""
    rng = np.random.default_rng(1)
    n = _dirs(1000, rng)
    d = -_dirs(1000, rng)
    d *= np.where(np.einsum("ij,ij->i", d, n) < 0, 1.0, -1.0)[:, None]   # arriving from outside
    for inside in (False, True):
        dd = -d if inside else d
        r, wr, t, wt = eo.glass_split(dd, n, np.full(1000, inside), 0.0)
        np.testing.assert_allclose(wr + wt, 1.0, atol=1e-12)
        cos_i = np.abs(np.einsum("ij,ij->i", dd, n))
        f, _ = eo.fresnel(cos_i, eo.IOR if inside else 1.0 / eo.IOR)
        np.testing.assert_allclose(wr, f, atol=1e-12)
        # the reflected ray keeps its side, the refracted one crosses (where any light does)
        side = np.sign(np.einsum("ij,ij->i", dd, n))
        assert np.all(np.sign(np.einsum("ij,ij->i", r, n)) == -side)
        cross = wt > 0
        assert np.all(np.sign(np.einsum("ij,ij->i", t, n))[cross] == side[cross])
        if inside:
            tir = np.sqrt(1 - cos_i ** 2) * eo.IOR > 1
            assert tir.any() and np.all(wt[tir] == 0) and np.all(wr[tir] == 1)
    # normal incidence: ((n - 1) / (n + 1))^2
    _, wr, _, _ = eo.glass_split(np.array([[0.0, 0.0, -1.0]]), np.array([[0.0, 0.0, 1.0]]),
                                 np.array([False]), 0.0)
    assert wr[0] == pytest.approx(0.04, abs=1e-12)


@pytest.mark.parametrize("inside", [False, True])
def test_rough_split_is_the_random_choice_and_eval_its_kernel(inside):
    """Rough glass (alpha 0.16): the split's weights summed per direction bin are what
    rough_glass_scatter's random choice gives (the same kernel, its expectation over the choice
    taken exactly), and rough_glass_eval, integrated over the bins by quadrature, is that
    kernel too (the test of the sampler against the BSDF written out: test_exact_caustic.py)."""
    rng = np.random.default_rng(5)
    alpha, n, cos_a = 0.4 ** 2, 1 << 19, 0.7
    a = np.array([math.sqrt(1 - cos_a ** 2), 0.0, -cos_a if inside else cos_a])
    d = np.tile(-a, (n, 1))
    normal = np.tile([0.0, 0.0, 1.0], (n, 1))
    flag = np.full(n, inside)
    k = 8

    def bins(out, w):
        cb = np.clip(((out[:, 2] + 1) / 2 * k).astype(int), 0, k - 1)
        pb = np.clip((np.mod(np.arctan2(out[:, 1], out[:, 0]), 2 * np.pi) / (2 * np.pi) * k)
                     .astype(int), 0, k - 1)
        return np.bincount(cb * k + pb, w, minlength=k * k) / n
    r, wr, t, wt = eo.glass_split(d, normal, flag, alpha, rng)
    split = bins(r, wr) + bins(t, wt)
    out, _, _, w = eo.rough_glass_scatter(d, normal, flag, rng.random(n), alpha, rng)
    chosen = bins(out, w)
    sub = 48
    c = (np.arange(k * sub) + 0.5) / (k * sub) * 2 - 1
    p = (np.arange(k * sub) + 0.5) / (k * sub) * 2 * np.pi
    C, P = np.meshgrid(c, p, indexing="ij")
    sn = np.sqrt(1 - C ** 2)
    b = np.stack([sn * np.cos(P), sn * np.sin(P), C], -1).reshape(-1, 3)
    val = eo.rough_glass_eval(np.tile(a, (b.shape[0], 1)), b, np.tile([0.0, 0.0, 1.0],
                                                                      (b.shape[0], 1)), alpha)
    quad = (val * (2 / (k * sub)) * (2 * np.pi / (k * sub))).reshape(k, sub, k, sub).sum((1, 3))
    quad = quad.ravel()
    assert split.sum() == pytest.approx(chosen.sum(), rel=0.003)
    assert split.sum() == pytest.approx(quad.sum(), rel=0.01)
    big = quad > 0.01 * quad.max()
    assert np.all(np.abs(split - chosen)[big] < 0.03 * quad[big] + 3e-3 * quad.max())
    assert np.all(np.abs(split - quad)[big] < 0.05 * quad[big] + 3e-3 * quad.max())


# --- the chains -------------------------------------------------------------------------------
def _segment_meets_ball(p, q):
    c, r = np.asarray(BALL[0]), BALL[1]
    u = q - p
    s = np.clip(np.dot(c - p, u) / np.dot(u, u), 0.0, 1.0)
    return np.linalg.norm(p + s * u - c) < r


def test_ray_through_the_centre_is_the_hand_computation():
    """The camera ray through the ball's centre meets it head-on: 0.04 reflected back (into the
    black void above the camera), 0.96^2 through, then 0.04^2 again per return trip along the
    same line: radiance albedo / pi x E x 0.96^2 (1 + 0.04^2 + ... up to the bounce limit),
    E the point light's irradiance (1 / (4 pi) W/sr per watt) at the floor point on the line,
    computed here by hand; with no photons traced the textures add nothing."""
    s = ecs.setup_of(_scene())
    px, py, *_ = ef.project(s, np.array([BALL[0]]))
    tex = ecc.Textures(s, 10)
    det, (_, _, ew), _ = ecc.chains(s, px, py, tex, np.random.default_rng(0))
    eye, c = s.eye, np.asarray(BALL[0])
    u = (c - eye) / np.linalg.norm(c - eye)
    x = eye + (-eye[2] / u[2]) * u                   # the floor (z = 0) behind the ball
    assert abs(x[0]) < 2 and abs(x[1]) < 2
    to_l = s.light - x
    e = to_l[2] / np.linalg.norm(to_l) / (4 * np.pi * np.dot(to_l, to_l))
    if _segment_meets_ball(x, s.light):
        e = 0.0
    # k internal reflections: through (k = 0, 2, 4, ...) within 12 bounces (k + 2 <= 12)
    through = sum(0.04 ** k for k in range(0, 11, 2))
    want = FLOOR[0] / np.pi * e * 0.96 ** 2 * through
    assert det[0] == pytest.approx(want, rel=1e-6)
    assert e > 0                                     # (the point is lit: a real check)
    # one texture lookup per way out to the floor, each of weight albedo / pi x its share
    np.testing.assert_allclose(np.sort(ew)[::-1][:2],
                               FLOOR[0] / np.pi * 0.96 ** 2 * np.array([1.0, 0.04 ** 2]),
                               rtol=1e-6)
    assert ew.sum() == pytest.approx(FLOOR[0] / np.pi * 0.96 ** 2 * through, rel=1e-6)


# --- the irradiance textures ------------------------------------------------------------------
def test_textures_are_the_closed_form_direct_light():
    """The direct light's photons (their first hits, past the ball) binned into textures give
    the closed-form irradiance: every 10 cm bin of the floor and the wall away from the
    shadow's edge within its noise (4.5 sigma), and the mean within 0.5 %; halving the bins
    changes nothing but the binning (the 2 x 2 sums of the fine bins are the coarse ones)."""
    s = ecs.setup_of(_scene())
    rng = np.random.default_rng(2)
    coarse, fine = ecc.Textures(s, 10), ecc.Textures(s, 20)
    for _ in range(4):
        o, d, w = ec.emit(s, 1 << 20, rng, stratified=False)
        no = np.zeros(d.shape[0], bool)
        t, hit = ecs.first_hit(o, d, no, no, s.ball)
        on = (hit == ecs.FLOOR_ID) | (hit == ecs.WALL_ID)
        p, normal = ecs.stage_normals(o[on] + t[on, None] * d[on], hit[on])
        front = np.einsum("ij,ij->i", d[on], normal) < 0
        zero = np.zeros((p.shape[0], 3), np.int64)
        for tex in (coarse, fine):
            tex.deposit(p, hit[on], front, w[on], 0, zero)
            tex.flush(d.shape[0])
    got = coarse.irradiance()
    assert np.allclose(got[1:], got[0])        # a first hit: allowed by every chain kind
    f = fine.irradiance()[0] * fine.area
    fl = f[:fine.n_floor].reshape(80, 80).reshape(40, 2, 40, 2).sum((1, 3)).ravel()
    wl = f[fine.n_floor:].reshape(50, 80).reshape(25, 2, 40, 2).sum((1, 3)).ravel()
    np.testing.assert_allclose(np.concatenate([fl, wl]), got[0] * coarse.area, rtol=1e-9)
    # the closed form over each bin (8 x 8 points)
    m = 8
    off = (np.arange(m) + 0.5) / m * 0.1
    ox, oy = (v.ravel() for v in np.meshgrid(off, off))
    iy, ix = np.divmod(np.arange(1600), 40)
    floor = np.stack([(-2 + ix * 0.1)[:, None] + ox, (-2 + iy * 0.1)[:, None] + oy,
                      np.zeros((1600, m * m))], -1).reshape(-1, 3)
    iz, jx = np.divmod(np.arange(1000), 40)
    wall = np.stack([(-2 + jx * 0.1)[:, None] + ox, np.full((1000, m * m), 2.0),
                     (iz * 0.1)[:, None] + oy], -1).reshape(-1, 3)
    ef_, lf = ecs.direct_irradiance(s, floor, np.tile([0.0, 0.0, 1.0], (floor.shape[0], 1)))
    ew_, lw = ecs.direct_irradiance(s, wall, np.tile([0.0, -1.0, 0.0], (wall.shape[0], 1)))
    want = np.concatenate([ef_.reshape(1600, -1).mean(1), ew_.reshape(1000, -1).mean(1)])
    edge = np.concatenate([np.ptp(lf.reshape(1600, -1).astype(int), 1),
                           np.ptp(lw.reshape(1000, -1).astype(int), 1)])
    # each bin off the shadow's edge: every photon weighs 1 (uniform emission, per watt), so a
    # bin's count is Poisson
    clean = edge == 0
    g, area, n_ph = got[0], coarse.area, coarse.photons
    sigma = np.sqrt(np.maximum(g * area * n_ph, 1.0)) / (n_ph * area)
    assert clean.sum() > 2000
    assert np.all(np.abs(g - want)[clean] < 4.5 * sigma[clean])
    assert g[clean].mean() == pytest.approx(want[clean].mean(), rel=0.005)


# --- the ball's image over the pixel filter ---------------------------------------------------
def test_ball_and_stage_integrate_the_filter_as_brute_force():
    """The direct light's grid (the stage seen directly) plus the ball's (the chains' direct
    light at their ends: no photons traced) against brute force: every pixel as the filter's
    weights over a jittered grid of 40 x 40 points per pixel through the same radiance
    functions, no refinement, no box.  Within 1.5 % of the image's mean at every pixel (the
    brute force's own edge noise) and 0.2 % over the ball's pixels together."""
    s = ecs.setup_of(_scene())
    tex = ecc.Textures(s, 10)
    grid = ec.direct_light(s).reshape(s.height, s.width)
    ball = ecc.BallView(s, tex, np.random.default_rng(0), per_pixel=16).image()
    got = grid + ball.reshape(s.height, s.width)
    rng = np.random.default_rng(3)
    k, pad = 40, 2
    g = (np.arange(-pad * k, (s.width + pad) * k) + rng.random((s.width + 2 * pad) * k)) / k
    px, py = (v.ravel() for v in np.meshgrid(g, g))
    v = ec._direct_radiance(s, px, py)[0] + ecc.chains(s, px, py, tex, rng)[0]
    want = ef.filtered(s, v.reshape(g.size, g.size), g, g, k).reshape(s.height, s.width)
    sees = ball.reshape(s.height, s.width) > 0
    assert 10 < sees.sum() < 0.5 * sees.size
    assert np.abs(got - want).max() < 0.015 * want.mean()
    assert got[sees].sum() == pytest.approx(want[sees].sum(), rel=0.002)


def test_every_pixel_is_rendered():
    """The reference's coverage is every pixel now; the pixels that see the ball get light
    (through it and in it), and without ``ball`` the old coverage comes back."""
    scene = _scene()
    img, cover, info = ec.render(scene, photons=1 << 16, seed=1, ball_grid=8)
    assert cover.all() and np.isfinite(img).all() and info["ball_points"] > 0
    s = ecs.setup_of(scene)
    stage = ecs.coverage(s)
    assert (~stage).sum() > 10 and img[~stage][:, 0].mean() > 0.05 * img[stage][:, 0].mean()
    _, old, info = ec.render(scene, photons=1 << 16, seed=1, ball=False)
    assert (old == stage).all() and info["ball_points"] == 0


@pytest.mark.slow
def test_halving_the_texture_bins_changes_less_than_the_noise():
    """The textures' bias (a bin's mean irradiance for each of its points): the same photons
    binned at 2 cm, 1 cm (the default) and 5 mm give ball pixels whose differences are small
    beside the reference's own noise there (two seeds), and shrink as the bins do: the bias
    at 1 cm is within its noise (32 x 32, 2^22 photons)."""
    scene = _scene(32)
    s = ecs.setup_of(scene)
    ball = ~ecs.coverage(s)
    imgs = {b: ec.render(scene, photons=1 << 22, seed=4, texture_bins=b)[0][..., 0]
            for b in (50, 100, 200)}
    other = ec.render(scene, photons=1 << 22, seed=5)[0][..., 0]
    noise = np.sqrt(np.mean((imgs[100] - other)[ball] ** 2)) / 2

    def rms(a, b):
        return np.sqrt(np.mean((a - b)[ball] ** 2))
    coarse, fine = rms(imgs[50], imgs[100]), rms(imgs[100], imgs[200])
    assert fine < noise and coarse < 2 * noise, (coarse, fine, noise)
    assert abs(np.mean((imgs[100] - imgs[200])[ball])) < 0.2 * noise
