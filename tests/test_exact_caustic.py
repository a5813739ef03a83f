"""The exact-geometry reference of point_caustic (ppm_engine/tools/bench/exact_caustic.py): its
pixel filter, camera and dielectric against closed forms, its light-traced direct light against the
closed form of a point light on a Lambertian plane and against its own closed form (which
renders the direct light since 2026-11-27), the split of the light between the two, and the
point light's intensity convention (P / (4 pi) W/sr per watt) against Cycles."""
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

W = 32                # the tests' image: 32 x 32 of the bench's 128 x 128 frame


def _scene(width=W):
    return square(point_caustic(), width)


def test_shares_no_code_with_the_engine():
    """Independent of the estimators it checks: of this package it (with its exact_caustic_scene,
    exact_film and exact_optics) imports only the scene's constants (ppm_engine/blender/scenes/
    caustics.py), nothing of the export, kernels, film or light tracer."""
    import ast
    from pathlib import Path
    imported = set()
    for module in (ec, ecc, ecs, ef, eo):
        for node in ast.walk(ast.parse(Path(module.__file__).read_text())):
            if isinstance(node, ast.Import):
                imported |= {a.name for a in node.names}
            elif isinstance(node, ast.ImportFrom):
                imported.add("." * node.level + (node.module or ""))
    own = {f"ppm_engine.tools.bench.{m}" for m in ("exact_caustic_camera", "exact_caustic_scene",
                                                    "exact_film", "exact_optics")}
    assert imported - own == {"__future__", "math", "time", "dataclasses", "numpy",
                              "ppm_engine.blender.scenes.caustics"}, imported


# --- the pixel filter ------------------------------------------------------------------------
def test_filter_is_cycles_blackman_harris_normalised():
    """Cycles' window over twice the filter width (film.cpp: width *= 2 for Blackman-Harris),
    divided by its integral: a0 x span."""
    dx = 3.0 / 30000
    x = -1.5 + (np.arange(30000) + 0.5) * dx             # midpoints
    assert ef.filter_1d(x, 1.5).sum() * dx == pytest.approx(1.0, abs=1e-6)
    # the centre: the window's sum of coefficients (1) over a0 x 3 px
    assert ef.filter_1d(0.0, 1.5) == pytest.approx(1.0 / (0.35875 * 3.0), rel=1e-9)
    assert ef.filter_1d(1.5, 1.5) == 0.0 and ef.filter_1d(-1.6, 1.5) == 0.0
    assert ef.filter_1d(1.4999, 1.5) < 1e-4          # the window ends at (nearly) zero
    assert ef.filter_1d(0.7, 1.5) == pytest.approx(ef.filter_1d(-0.7, 1.5))


def test_constant_radiance_splats_to_a_constant_image():
    """A constant field (contributions on a regular grid of raster points, 1 per unit area)
    gives every pixel the filter can fully reach the same value, 1."""
    s = ecs.setup_of(_scene(16))
    k = 16                                      # points per pixel and axis
    g = (np.arange(-3 * k, (s.width + 3) * k) + 0.5) / k
    px, py = (a.ravel() for a in np.meshgrid(g, g))
    acc = np.zeros(s.width * s.height)
    ef.splat(acc, s, px, py, np.full(px.size, 1.0 / (k * k)))
    img = acc.reshape(s.height, s.width)
    assert np.abs(img - 1.0).max() < 1e-6
    # a single splat: the 3 x 3 pixels whose centres are within the filter's reach, each
    # weighted by the filter at its offset
    acc[:] = 0
    ef.splat(acc, s, np.array([7.3]), np.array([8.9]), np.array([2.0]))
    img = acc.reshape(s.height, s.width)
    assert (img > 0).sum() == 9 and (img[7:10, 6:9] > 0).all()
    assert img[9, 6] == pytest.approx(
        2.0 * ef.filter_1d(7.3 - 6.5, 1.5) * ef.filter_1d(8.9 - 9.5, 1.5))


# --- the camera ------------------------------------------------------------------------------
def test_projection_inverts_camera_rays():
    s = ecs.setup_of(_scene())
    rng = np.random.default_rng(0)
    px, py = rng.random(100) * W, rng.random(100) * W
    d = ef.camera_rays(s, px, py)
    p = s.eye + rng.uniform(0.5, 5.0, (100, 1)) * d
    qx, qy, to_eye, dist, cos_cam, ok = ef.project(s, p)
    assert ok.all()
    np.testing.assert_allclose(qx, px, atol=1e-9)
    np.testing.assert_allclose(qy, py, atol=1e-9)
    np.testing.assert_allclose(to_eye, -d, atol=1e-12)
    np.testing.assert_allclose(dist, np.linalg.norm(p - s.eye, axis=1), rtol=1e-12)
    np.testing.assert_allclose(cos_cam, -d @ s.axes[:, 2], rtol=1e-6)
    # the camera looks down at the stage: row 0 (top) sees farther than the last row
    top, bottom = ef.camera_rays(s, np.array([W / 2, W / 2]), np.array([0.5, W - 0.5]))
    assert top[2] > bottom[2]


def test_coverage_leaves_out_the_ball_and_its_rim():
    s = ecs.setup_of(_scene())
    cover = ecs.coverage(s)
    px, py, *_ = ef.project(s, np.array([BALL[0]]))
    i, j = int(px[0]), int(py[0])
    assert not cover[j, i] and not cover[j, i + 2]
    assert 0.6 * W * W < cover.sum() < 0.95 * W * W
    # every pixel within the filter's reach of an uncovered centre that sees the ball is out
    d = ef.camera_rays(s, *(a.ravel() + 0.5 for a in np.meshgrid(np.arange(W), np.arange(W))))
    no = np.zeros(W * W, bool)
    _, hit = ecs.first_hit(np.broadcast_to(s.eye, d.shape), d, no, no, s.ball)
    ball = (hit == ecs.BALL_ID).reshape(W, W)
    near = np.zeros_like(ball)
    for dj in (-1, 0, 1):
        for di in (-1, 0, 1):
            near |= np.roll(np.roll(ball, dj, 0), di, 1)
    assert not (cover & near).any()


# --- the glass -------------------------------------------------------------------------------
def _fresnel_snell(theta_i, n):
    """Fresnel's reflectance from the angles (the textbook form, independent of eo.fresnel)."""
    theta_t = np.arcsin(np.sin(theta_i) / n)
    rs = np.sin(theta_i - theta_t) ** 2 / np.sin(theta_i + theta_t) ** 2
    rp = np.tan(theta_i - theta_t) ** 2 / np.tan(theta_i + theta_t) ** 2
    return 0.5 * (rs + rp)


def test_fresnel_and_refraction():
    th = np.radians([10.0, 30.0, 60.0, 85.0])
    f, cos_t = eo.fresnel(np.cos(th), 1.0 / eo.IOR)
    np.testing.assert_allclose(f, _fresnel_snell(th, eo.IOR), rtol=1e-9)
    np.testing.assert_allclose(cos_t, np.cos(np.arcsin(np.sin(th) / eo.IOR)), rtol=1e-12)
    assert eo.fresnel(np.array([1.0]), 1.0 / 1.5)[0][0] == pytest.approx(0.04)
    # from inside, beyond the critical angle: total internal reflection
    assert eo.fresnel(np.cos(np.radians([45.0])), 1.5)[0][0] == 1.0
    # Snell's law of the refracted direction
    d = np.array([[np.sin(th[1]), 0.0, -np.cos(th[1])]])
    n = np.array([[0.0, 0.0, 1.0]])
    out, refl, inside = eo.glass_scatter(d, n, np.array([False]), np.array([0.99]))
    assert not refl[0] and inside[0]
    assert out[0, 0] == pytest.approx(np.sin(th[1]) / eo.IOR) and out[0, 1] == 0.0


def test_glass_ball_conserves_energy():
    """A parallel beam on the ball (no floor, no camera): every photon leaves it (no absorption,
    no ray lost inside), a share of the Fresnel reflectance averaged over the ball's disk at the
    first surface, and T^2 R^k after k internal reflections (R at the inner surface is the
    outer one's: the chord meets it at the refraction angle)."""
    rng = np.random.default_rng(7)
    n = 200_000
    c, r = np.asarray(BALL[0]), BALL[1]
    rho, phi = r * np.sqrt(rng.random(n)), 2 * np.pi * rng.random(n)
    o = np.stack([np.full(n, -5.0), c[1] + rho * np.cos(phi), c[2] + rho * np.sin(phi)], 1)
    d = np.tile([1.0, 0.0, 0.0], (n, 1))
    inside = np.zeros(n, bool)
    left = np.zeros(n, bool)
    exits_after = np.full(n, -1)
    alive = np.ones(n, bool)
    for bounce in range(32):
        idx = np.flatnonzero(alive)
        t = ecs._ball_hits(o[idx], d[idx], inside[idx], BALL)
        t = np.where(left[idx] & ~inside[idx], np.inf, t)
        gone = ~np.isfinite(t)
        exits_after[idx[gone]] = bounce
        alive[idx[gone]] = False
        idx = idx[~gone]
        p = o[idx] + t[~gone, None] * d[idx]
        new_d, _, new_in = eo.glass_scatter(d[idx], (p - c) / r, inside[idx], rng.random(idx.size))
        o[idx], d[idx], inside[idx], left[idx] = p, new_d, new_in, True
    assert not alive.any()                      # all light leaves: nothing lost, none absorbed
    # the weight of an incidence angle over the disk: 2 sin cos
    th = (np.arange(20000) + 0.5) / 20000 * np.pi / 2
    wgt = 2 * np.sin(th) * np.cos(th) * (np.pi / 2 / 20000)
    rf = _fresnel_snell(th, eo.IOR)
    for k, share in ((1, np.sum(wgt * rf)), (2, np.sum(wgt * (1 - rf) ** 2)),
                     (3, np.sum(wgt * (1 - rf) ** 2 * rf))):
        got = np.mean(exits_after == k)
        assert got == pytest.approx(share, abs=4 * math.sqrt(share / n)), (k, got, share)
    assert np.sum(wgt * rf) == pytest.approx(0.0918, abs=5e-4)  # n = 1.5's diffuse reflectance


def _flux_bsdf_cos(a, b, alpha, inside):
    """The rough dielectric for photons written out in full (Walter et al. 2007; the flux's
    form, without radiance's eta^2), times |cos| of the outgoing direction: f*(a -> b) |b.n|
    for a photon from direction a (unit, towards where it came from) leaving along b, at a
    surface with normal +z, the photon outside (above) or inside (below); GGX of ``alpha``,
    Smith's height-correlated G2, the exact Fresnel factor."""
    nf = np.array([0.0, 0.0, -1.0 if inside else 1.0])
    eta_a, eta_b_t = (eo.IOR, 1.0) if inside else (1.0, eo.IOR)
    ca, cb = a @ nf, b @ nf
    refl = cb > 0
    eta_p = np.where(refl, 1.0, eta_b_t / eta_a)        # eta of b's side over a's
    m = np.where(refl[:, None], a + b, a + eta_p[:, None] * b)
    m /= np.linalg.norm(m, axis=1, keepdims=True)
    m *= np.where(m @ nf < 0, -1.0, 1.0)[:, None]       # towards a's side
    cm = m @ nf
    d = alpha ** 2 / (np.pi * (cm * cm * (alpha ** 2 - 1.0) + 1.0) ** 2)

    def lam(c):
        return 0.5 * (np.sqrt(1.0 + alpha ** 2 * (1.0 - c * c) / (c * c)) - 1.0)
    g2 = 1.0 / (1.0 + lam(ca) + lam(np.abs(cb)))
    am, bm = m @ a, np.einsum("ij,ij->i", b, m)
    th_i = np.arccos(np.clip(am, 0.0, 1.0))
    s_t = np.sin(th_i) * eta_a / eta_b_t
    th_t = np.arcsin(np.clip(s_t, 0.0, 1.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        rs = np.sin(th_i - th_t) ** 2 / np.sin(th_i + th_t) ** 2
        rp = np.tan(th_i - th_t) ** 2 / np.tan(th_i + th_t) ** 2
    f = np.where(s_t >= 1.0, 1.0, np.nan_to_num(0.5 * (rs + rp), nan=(eta_a - eta_b_t) ** 2
                                                 / (eta_a + eta_b_t) ** 2))
    fr = f * d * g2 / (4.0 * ca)
    ft = (1.0 - f) * d * g2 * np.abs(bm * am) / (ca * (bm + am / eta_p) ** 2)
    ok = (am > 0) & np.where(refl, bm > 0, bm < 0)
    return np.where(ok, np.where(refl, fr, ft), 0.0)


@pytest.mark.parametrize("inside", [False, True])
@pytest.mark.parametrize("cos_a", [0.9, 0.5])
def test_rough_glass_scatter_is_the_bsdf(inside, cos_a):
    """rough_glass_scatter against the BSDF written out in full (_flux_bsdf_cos): the photons'
    weights summed over 16 x 16 bins of the sphere of directions (cos theta, phi) are the
    BSDF's integral over each bin by quadrature, within their noise, and so is the total (the
    albedo: below 1, single-scattering GGX loses some)."""
    rng = np.random.default_rng(3)
    alpha, n = 0.4 ** 2, 1 << 20
    a = np.array([math.sqrt(1 - cos_a ** 2), 0.0, -cos_a if inside else cos_a])
    d = np.tile(-a, (n, 1))
    normal = np.tile([0.0, 0.0, 1.0], (n, 1))
    out, refl, now_inside, w = eo.rough_glass_scatter(d, normal, np.full(n, inside),
                                                      rng.random(n), alpha, rng)
    assert np.all(now_inside == np.where(refl, inside, not inside))
    assert np.all(np.where(refl, out[:, 2] * a[2] > 0, out[:, 2] * a[2] < 0) | (w == 0))
    k, sub = 16, 24
    cb = np.clip(((out[:, 2] + 1) / 2 * k).astype(int), 0, k - 1)
    pb = np.clip((np.mod(np.arctan2(out[:, 1], out[:, 0]), 2 * np.pi) / (2 * np.pi) * k)
                 .astype(int), 0, k - 1)
    got = np.bincount(cb * k + pb, w, minlength=k * k) / n
    got2 = np.bincount(cb * k + pb, w * w, minlength=k * k) / n
    c = (np.arange(k * sub) + 0.5) / (k * sub) * 2 - 1
    p = (np.arange(k * sub) + 0.5) / (k * sub) * 2 * np.pi
    C, P = np.meshgrid(c, p, indexing="ij")
    sn = np.sqrt(1 - C ** 2)
    b = np.stack([sn * np.cos(P), sn * np.sin(P), C], -1).reshape(-1, 3)
    val = _flux_bsdf_cos(a, b, alpha, inside) * (2 / (k * sub)) * (2 * np.pi / (k * sub))
    want = val.reshape(k, sub, k, sub).sum(axis=(1, 3)).ravel()
    sigma = np.sqrt(np.maximum(got2 - got * got, 0) / n) + 1e-4 * want.max()
    assert got.sum() == pytest.approx(want.sum(), rel=0.005)
    assert 0.9 < want.sum() < 1.0
    assert np.all(np.abs(got - want) < 5 * sigma + 0.02 * want), \
        np.abs(got - want).max()


# --- the light -------------------------------------------------------------------------------
def direct_closed_form(scene, m=8):
    """Direct light only, per pixel, from the closed form: L = albedo / pi x I cos / d^2 at the
    floor or wall point a camera ray meets (0 in the ball's shadow), I = P / (4 pi), averaged
    over the pixel with Cycles' filter on an m x m grid of sub-pixel offsets.  (image (h, w),
    penumbra: pixels whose offsets disagree on the light's visibility; built here from bpy's
    camera frame, not with exact_caustic's camera code.)"""
    cam = scene.camera
    mw = np.array(cam.matrix_world)
    frame = np.array([tuple(v) for v in cam.data.view_frame(scene=scene)])  # tr, br, bl, tl
    tr, br, bl, tl = frame / -frame[:, 2:3]
    w = h = scene.render.resolution_x
    fw = scene.cycles.filter_width
    u = -fw + (np.arange(m) + 0.5) * (2 * fw / m)
    f = 0.35875 - 0.48829 * np.cos(2 * np.pi * (u / (2 * fw) + 0.5)) \
        + 0.14128 * np.cos(4 * np.pi * (u / (2 * fw) + 0.5)) \
        - 0.01168 * np.cos(6 * np.pi * (u / (2 * fw) + 0.5))
    g = np.outer(f, f) / np.outer(f, f).sum()
    x = (np.arange(w)[:, None] + 0.5 + u[None, :]) / w           # (w, m) across, 0..1
    y = (np.arange(h)[:, None] + 0.5 + u[None, :]) / h           # (h, m) down, 0..1
    xs, ys = x[None, None, :, :], y[:, :, None, None]            # (h, m, w, m)
    top = tl + xs[..., None] * (tr - tl)
    bottom = bl + xs[..., None] * (br - bl)
    local = top + ys[..., None] * (bottom - top)
    d = local @ mw[:3, :3].T
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    o = mw[:3, 3]
    light = np.array(bpy.data.objects["Point"].matrix_world.translation)
    intensity = bpy.data.objects["Point"].data.energy / (4 * np.pi)
    with np.errstate(divide="ignore", invalid="ignore"):
        tf = -o[2] / d[..., 2]
        tw = (2.0 - o[1]) / d[..., 1]
    t = np.where((tf > 0) & (tf < np.where(tw > 0, tw, np.inf)), tf, tw)
    p = o + t[..., None] * d
    normal = np.where((t == tf)[..., None], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0])
    to_light = light - p
    dist = np.linalg.norm(to_light, axis=-1)
    cos_l = np.einsum("...i,...i->...", to_light, normal) / dist
    # the ball's shadow: the segment to the light meets the sphere
    c, r = np.asarray(BALL[0]), BALL[1]
    ul = to_light / dist[..., None]
    oc = p - c
    b = np.einsum("...i,...i->...", ul, oc)
    disc = b * b - (np.einsum("...i,...i->...", oc, oc) - r * r)
    lit = ~((disc > 0) & (-b + np.sqrt(np.maximum(disc, 0)) > 0))
    L = FLOOR[0] / np.pi * intensity * np.maximum(cos_l, 0) / dist ** 2 * lit
    img = np.einsum("hawb,ab->hw", L, g)
    frac = lit.mean(axis=(1, 3))
    return img, (frac > 0) & (frac < 1)


@pytest.fixture(scope="module")
def traced_direct():
    """The direct light alone (no bounces), light-traced as before the closed form took it
    over: 16 renders of 2^17 photons (seeds 100 to 115), (16, h, w), and the coverage."""
    scene = _scene()
    parts = []
    for seed in range(100, 116):
        img, cover, info = ec.render(scene, photons=1 << 17, seed=seed, max_bounces=0,
                                     direct="traced", ball=False)
        assert info["photons"] == 1 << 17 and info["max_bounces"] == 0
        assert info["direct"] == "traced" and info["connections"] > 0
        parts.append(img[..., 0].astype(np.float64))
    return np.array(parts), cover


def test_direct_light_is_the_closed_form(traced_direct):
    """With no bounces, the light-traced floor and wall as the closed form of a point light on
    a Lambertian plane: the mean within 0.5 %, every 8x8 block within 5 % at 2^21 photons (the
    blocks near the camera and far from the light get the fewest photons; 2^25 photons give a
    mean of 0.9991 x the closed form and every block within 1 %), the ball's shadow included;
    the pixels on its penumbra left out."""
    scene = _scene()
    parts, cover = traced_direct
    img = parts.mean(axis=0)[..., None]
    ref, penumbra = direct_closed_form(scene)
    px = cover & ~penumbra & (ref > 0.05)
    assert px.sum() > 0.5 * W * W
    assert img[..., 0][px].mean() == pytest.approx(ref[px].mean(), rel=0.005)

    def blocks(x):
        return np.where(px, x, 0.0).reshape(W // 8, 8, W // 8, 8).sum(axis=(1, 3))
    full = blocks(np.ones((W, W))) >= 16
    ratio = blocks(img[..., 0]) / np.maximum(blocks(ref), 1e-12)
    assert full.sum() >= 12 and np.abs(ratio[full] - 1).max() < 0.05, ratio
    # the umbra: no direct light in it (but for the filter's last 1e-5 of its weight, beyond
    # the closed form's outermost sub-pixel offsets)
    dark = cover & ~penumbra & (ref == 0)
    assert dark.sum() >= 3 and img[dark].max() < 1e-5 * ref[px].mean()


def test_closed_form_direct_is_the_light_traced_direct(traced_direct):
    """exact_caustic's closed form of the direct light (what it now renders instead of light
    tracing it) is the light-traced direct light within the latter's noise (its spread over 16
    renders of 2^17 photons): every 8x8 block of covered pixels and the mean over them, the
    ball's shadow and its edge included.  Each block's mean over the 16 is 0.3 % to 1.6 %
    noisy; the blocks are at most 1.9 noise from the closed form (RMS 1.1), the mean 1.1 noise
    (of 0.17 %)."""
    scene = _scene()
    parts, cover = traced_direct
    s = ecs.setup_of(scene)
    closed = ec.direct_light(s).reshape(W, W) * s.power[0] * s.film_exposure
    assert closed.shape == cover.shape and closed[cover].min() >= 0.0
    k = parts.shape[0]

    def blocks(x):
        return np.where(cover, x, 0.0).reshape(*x.shape[:-2], W // 8, 8, W // 8, 8).sum(
            axis=(-3, -1))
    full = blocks(np.ones((W, W))) >= 16
    assert full.sum() >= 12
    traced = blocks(parts)[:, full]                         # (16, blocks)
    ref = blocks(closed)[full]
    sd = traced.std(axis=0, ddof=1) / math.sqrt(k)
    assert (sd / ref).max() < 0.03 and (sd / ref).min() > 0.001, sd / ref
    z = (traced.mean(axis=0) - ref) / sd
    assert np.abs(z).max() < 3.5 and math.sqrt(np.mean(z ** 2)) < 1.5, z
    means = parts[:, cover].mean(axis=1)
    sd_mean = means.std(ddof=1) / math.sqrt(k)
    assert sd_mean < 0.003 * closed[cover].mean()
    assert abs(means.mean() - closed[cover].mean()) < 3.0 * sd_mean, (means, closed[cover].mean())


def test_direct_light_is_the_tests_closed_form():
    """exact_caustic's closed form against this file's (which builds the camera rays from bpy's
    frame, not with exact_caustic's camera code, on a 48 x 48 grid over each pixel's filter):
    the mean over the covered pixels within 1e-4 (1.5e-5), each pixel off its penumbra within
    0.5 % (0.29 %: this file's grid, unrefined, at the floor's corner with the wall)."""
    scene = _scene()
    s = ecs.setup_of(scene)
    closed = ec.direct_light(s).reshape(W, W) * s.power[0]
    cover = ecs.coverage(s)
    ref, penumbra = direct_closed_form(scene, 48)
    assert closed[cover].mean() == pytest.approx(ref[cover].mean(), rel=1e-4)
    px = cover & ~penumbra & (ref > 0.05)
    assert px.sum() > 0.5 * W * W
    assert np.abs(closed[px] / ref[px] - 1).max() < 0.005


def test_direct_light_grid_converges():
    """The closed form's grid: 8 x 8 cells per pixel, each refined 16 x 16 where the light
    jumps, is within 5.2e-4 (of 0.53 on average; RMS 5e-5) of 24 x 24 refined 24 x 24 at every
    covered pixel (16 x 16 refined 16 x 16: 1.6e-4); unrefined, the same grid is 5.8e-3 off at
    the shadow's edge."""
    s = ecs.setup_of(_scene())
    cover = ecs.coverage(s)
    power = s.power[0]
    default = ec.direct_light(s) * power
    fine = ec.direct_light(s, 24, 24) * power
    coarse = ec.direct_light(s, ec.DIRECT_GRID, 1) * power
    c = cover.ravel()
    assert fine[c].mean() == pytest.approx(0.532, abs=0.001)
    assert np.abs(default - fine)[c].max() < 7e-4
    assert np.abs(coarse - fine)[c].max() > 3e-3


def test_point_light_intensity_is_cycles(render_exr, cycles, tmp_path):
    """Cycles' point light of P watts radiates P / (4 pi) W/sr: its direct light on the stage
    (no bounces) is the closed form with that intensity, within 1 % (a factor of pi or 4 off
    would show as 3x-12x)."""
    scene = _scene()
    cycles(scene, 64, W)
    scene.cycles.max_bounces = 0
    got = render_exr(tmp_path / "cycles.exr")
    ref, penumbra = direct_closed_form(scene)
    cover = ecs.coverage(ecs.setup_of(scene))
    px = cover & ~penumbra & (ref > 0.05)
    assert px.sum() > 0.5 * W * W
    assert got[..., 0][px].mean() == pytest.approx(ref[px].mean(), rel=0.01)
    assert np.abs(got[..., 0][px] / ref[px] - 1).max() < 0.05


def test_split_and_stratified_emission_are_unbiased():
    """The closed-form direct light plus light tracing of the rest renders what light tracing
    of it all does; and the rest, with the cone-and-half-space emission, what uniform emission
    over every direction does: the mean over the covered pixels and over the caustic's
    brightest pixels.  At 2^20 photons the mean over the covered pixels (0.641) is 0.11 %
    noisy with the split, 0.2 % light-traced; the rest's (0.108) 0.7 % stratified, 0.9 % not
    (over six seeds)."""
    scene = _scene()
    s = ecs.setup_of(scene)
    closed = ec.direct_light(s).reshape(W, W) * s.power[0]
    a, cover, info = ec.render(scene, photons=1 << 20, seed=5, ball=False)
    assert info["direct"] == "closed"
    traced, _, _ = ec.render(scene, photons=1 << 20, seed=6, direct="traced", ball=False)
    assert a[cover].mean() == pytest.approx(0.641, abs=0.003)
    assert a[cover].mean() == pytest.approx(traced[cover].mean(), rel=0.007)
    b, _, _ = ec.render(scene, photons=1 << 20, seed=7, stratified=False, ball=False)
    rest_a, rest_b = a[..., 0] - closed, b[..., 0] - closed
    assert rest_a[cover].mean() == pytest.approx(0.108, abs=0.004)
    assert rest_a[cover].mean() == pytest.approx(rest_b[cover].mean(), rel=0.035)
    focus = a[..., 0] > np.quantile(a[..., 0][cover], 0.99)
    assert a[focus].mean() == pytest.approx(b[focus].mean(), rel=0.1)
