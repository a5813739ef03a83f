"""Scenes with exact answers, rendered by the whole engine (no Blender needed): the furnace,
point (soft falloff too), spot, area and sun lights over a diffuse plane, the world, and lights
seen by the camera.  The direct light at chosen points: test_direct_light.py.  The scenes
the two share and the render are tests/helpers/ (procedural_scenes.py, renders.py).

Tolerances come from the estimator's own spread: several independent renders (seeds) give the
standard error of the mean."""


import numpy as np
import pytest

from ppm_engine.oracle.procedural import MeshBuilder, look_at
from ppm_engine.scene.arrays import (
    CAMERA_ORTHO,
    LIGHT_AREA_ELLIPSE,
    LIGHT_AREA_RECT,
    LIGHT_DTYPE,
    LIGHT_FLAG_SOFT_FALLOFF,
    LIGHT_POINT,
    LIGHT_SPOT,
    LIGHT_SUN,
)
from ppm_engine.scene.camera import make_camera
from tests.helpers.procedural_scenes import furnace_scene, light
from tests.helpers.renders import render


def mean_and_se(values):
    v = np.asarray(values, np.float64)
    return v.mean(axis=0), v.std(axis=0, ddof=1) / np.sqrt(v.shape[0])


def assert_matches(scene, ref, passes, seeds=12, rel_bias=0.005, **opts):
    """Compare a mean image over independent seeds with a reference.  Per pixel, z is
    t-distributed with seeds-1 degrees of freedom: a few pixels past 3.5 are expected, a
    systematic error makes many (and the image mean, tested at 4 se, catches small ones)."""
    imgs = [render(scene, passes, seed=s, **opts)[..., 0] for s in range(seeds)]
    m, se = mean_and_se(imgs)
    z = (m - ref) / (se + rel_bias * ref + 1e-9)
    assert (np.abs(z) > 3.5).mean() < 0.03 and np.abs(z).max() < 10, np.abs(z).max()
    tot, tot_se = mean_and_se([i.mean() for i in imgs])
    assert abs(tot - ref.mean()) <= 4 * tot_se + rel_bias * ref.mean(), (tot, ref.mean(), tot_se)
    assert (se < 0.1 * ref + 1e-6).all(), se.max()   # sharp enough to mean something


# --- furnace -----------------------------------------------------------------------------------
@pytest.mark.gpu
@pytest.mark.parametrize("indirect", ["photons", "paths"])
@pytest.mark.parametrize("rho", [0.3, 0.7])
def test_furnace_radiance_is_le_over_one_minus_rho(rho, indirect):
    """Energy conservation, Russian roulette, emission units, photon flux and the density
    estimate (or the eye paths' MIS of emission and next-event estimation) together: inside a
    closed sphere of albedo rho and emission Le, L = Le/(1-rho)."""
    Le = 1.0
    scene = furnace_scene(rho, Le)
    means = [render(scene, 40, seed=s, photons_per_pass=1 << 13, max_bounces=64,
                    indirect=indirect)[..., :3].mean()
             for s in range(4)]
    m, se = mean_and_se(means)
    expected = Le / (1 - rho)
    assert abs(m - expected) < 4 * se + 0.005 * expected, (m, expected, se)


# --- point, spot and area lights over a diffuse plane ---------------------------------------------
def plane_scene(light, albedo=0.5, W=16, half=2.0, cam_height=10.0):
    """A large diffuse plane z=0 seen from straight above by an orthographic camera that
    covers [-half, half]^2; photons leave the plane and never come back (no indirect light)."""
    mb = MeshBuilder()
    m = mb.material("plane", (albedo,) * 3)
    mb.quad((0, 0, 0), (50, 0, 0), (0, 50, 0), m)
    cam = make_camera(type=CAMERA_ORTHO, width=W, height=W,
                      to_world=look_at((0, 0, cam_height), (0, 0, 0), up=(0, 1, 0)),
                      extent=(2 * half, 2 * half), clip=(0.1, 100))
    return mb.build(camera=cam, lights=light)


def pixel_centers(W, half):
    c = (np.arange(W) + 0.5) / W * 2 * half - half
    x, y = np.meshgrid(c, c)          # row 0 = bottom = smallest y
    return x, y


def supersample(f, W, half, n=6):
    """Mean of f over each pixel (the renderer jitters inside the pixel)."""
    acc = 0.0
    for i in range(n):
        for j in range(n):
            x, y = pixel_centers(W, half)
            px = 2 * half / W
            acc = acc + f(x + ((i + 0.5) / n - 0.5) * px, y + ((j + 0.5) / n - 0.5) * px)
    return acc / n ** 2


def test_point_light_irradiance():
    P, h, albedo = 100.0, 1.5, 0.5
    I = P / (4 * np.pi)
    scene = plane_scene(light(LIGHT_POINT, emit=(I,) * 3, position=(0.3, -0.2, h)), albedo)
    img = render(scene, 400, photons_per_pass=64)[..., 0]   # jitter noise ~5 %/sqrt(400)

    def L(x, y):
        d2 = (x - 0.3) ** 2 + (y + 0.2) ** 2 + h ** 2
        return albedo / np.pi * I * h / d2 ** 1.5
    ref = supersample(L, 16, 2.0)
    np.testing.assert_allclose(img, ref, rtol=0.012)
    assert img.mean() == pytest.approx(ref.mean(), rel=2e-3)


def disk_irradiance(p, n, center, radius, L, towards, k=400):
    """Float64 quadrature of the irradiance at p (normal n) from a disk of radiance L."""
    t = np.cross(towards, [0, 0, 1.0] if abs(towards[2]) < 0.9 else [1.0, 0, 0])
    t /= np.linalg.norm(t)
    b = np.cross(towards, t)
    r = (np.arange(k) + 0.5) / k * radius
    phi = (np.arange(k) + 0.5) / k * 2 * np.pi
    R, PH = np.meshgrid(r, phi)
    q = center + (R * np.cos(PH))[..., None] * t + (R * np.sin(PH))[..., None] * b
    v = q - p
    d2 = (v ** 2).sum(-1)
    w = v / np.sqrt(d2)[..., None]
    cos_s = np.clip(w @ n, 0, None)
    cos_l = np.clip(-(w @ towards), 0, None)
    dA = R * (radius / k) * (2 * np.pi / k)
    return (L * cos_s * cos_l / d2 * dA).sum()


def test_point_light_soft_falloff_matches_cycles_disk_model():
    """Cycles' soft falloff: a disk facing the shading point; on axis E = P/(4 pi (d^2+r^2))."""
    P, h, r, albedo = 100.0, 1.0, 0.5, 0.5
    I = P / (4 * np.pi)
    W, half = 16, 1.0
    scene = plane_scene(light(LIGHT_POINT, emit=(I,) * 3, position=(0, 0, h), radius=r,
                              flags=LIGHT_FLAG_SOFT_FALLOFF), albedo, W=W, half=half,
                        cam_height=0.4)           # below the light, which the camera would see
    x, y = pixel_centers(W, half)
    ref = np.zeros((W, W))
    for j in range(W):
        for i in range(W):
            p = np.array([x[j, i], y[j, i], 0.0])
            towards = p - np.array([0, 0, h])
            towards /= np.linalg.norm(towards)
            ref[j, i] = albedo / np.pi * disk_irradiance(p, np.array([0, 0, 1.0]),
                                                       np.array([0, 0, h]), r,
                                                       I / (np.pi * r * r), towards)
    # on axis the closed form
    on_axis = disk_irradiance(np.zeros(3), np.array([0, 0, 1.0]), np.array([0, 0, h]), r,
                              I / (np.pi * r * r), np.array([0, 0, -1.0]))
    assert on_axis == pytest.approx(P / (4 * np.pi * (h * h + r * r)), rel=1e-3)
    assert_matches(scene, ref, 30, photons_per_pass=64)


def test_spot_cone_attenuation():
    """Inside the cone a spot equals a point light of the same power (Cycles); the blend is a
    smoothstep in cos(theta)."""
    P, h, albedo = 100.0, 1.0, 0.5
    I = P / (4 * np.pi)
    size, blend = np.radians(90.0), 0.5
    ch = np.cos(size / 2)
    scene = plane_scene(light(LIGHT_SPOT, emit=(I,) * 3, position=(0, 0, h),
                              axis_x=(1, 0, 0), axis_y=(0, 1, 0), spot_scale_z=1.0,
                              spot_cos_half=ch, spot_smooth=(1 - ch) * blend), albedo)
    img = render(scene, 400, photons_per_pass=64)[..., 0]

    def L(x, y):
        d2 = x ** 2 + y ** 2 + h ** 2
        c = h / np.sqrt(d2)
        t = np.clip((c - ch) / ((1 - ch) * blend), 0, 1)
        return albedo / np.pi * I * h / d2 ** 1.5 * np.where(c > ch, t * t * (3 - 2 * t), 0)
    ref = supersample(L, 16, 2.0, n=12)
    np.testing.assert_allclose(img, ref, atol=0.01 * ref.max(), rtol=0.01)


@pytest.mark.parametrize("shape", [LIGHT_AREA_RECT, LIGHT_AREA_ELLIPSE])
def test_area_light_irradiance(shape):
    """A one-sided area light facing down; reference by float64 quadrature."""
    P, h, albedo = 50.0, 1.0, 0.5
    sx, sy = 1.0, 0.5
    area = sx * sy * (np.pi / 4 if shape == LIGHT_AREA_ELLIPSE else 1.0)
    Lr = P / (np.pi * area)
    W, half = 16, 1.0
    scene = plane_scene(light(shape, emit=(Lr,) * 3, position=(0, 0, h), axis_x=(sx, 0, 0),
                              axis_y=(0, sy, 0)), albedo, W=W, half=half)
    x, y = pixel_centers(W, half)
    k = 200
    u = ((np.arange(k) + 0.5) / k - 0.5)
    U, V = np.meshgrid(u * sx, u * sy)
    inside = np.ones_like(U, bool) if shape == LIGHT_AREA_RECT else \
        (U / (sx / 2)) ** 2 + (V / (sy / 2)) ** 2 <= 1
    dA = sx * sy / k ** 2
    ref = np.zeros((W, W))
    for j in range(W):
        for i in range(W):
            v = np.stack([U - x[j, i], V - y[j, i], np.full_like(U, h)], -1)
            d2 = (v ** 2).sum(-1)
            cos = h / np.sqrt(d2)
            ref[j, i] = albedo / np.pi * (Lr * cos * cos / d2 * dA * inside).sum()
    assert_matches(scene, ref, 30, photons_per_pass=64)


@pytest.mark.parametrize("angle", [0.0, np.radians(10.0)])
def test_sun_irradiance(angle):
    """Sun strength is the irradiance on a surface facing it, whatever its angle: E cos(theta)."""
    E, albedo = 3.0, 0.5
    d = np.array([0.3, 0.0, -1.0])
    d /= np.linalg.norm(d)
    scene = plane_scene(light(LIGHT_SUN, emit=(E,) * 3, direction=d, radius=angle / 2), albedo, W=8)
    ref = np.full((8, 8), albedo / np.pi * E * -d[2])
    if angle == 0.0:
        np.testing.assert_allclose(render(scene, 2, photons_per_pass=64)[..., 0], ref, rtol=1e-4)
    else:
        assert_matches(scene, ref, 20, photons_per_pass=64, rel_bias=0.002)


def test_world_lights_open_plane():
    """A diffuse plane under a uniform world of radiance Lw: L = albedo * Lw."""
    Lw, albedo = 0.8, 0.6
    scene = plane_scene(np.zeros(0, LIGHT_DTYPE), albedo, W=8).replace(
        world=np.array([Lw, Lw, Lw], np.float32))
    assert_matches(scene, np.full((8, 8), albedo * Lw), 20, photons_per_pass=256)


def test_lights_are_seen_by_the_camera_like_in_cycles():
    """Looking up at a one-sided area light and a sphere light: their radiance, L = P/(pi A)
    for the area light (front only) and I/(pi r^2) for the sphere."""
    P = 40.0
    area = light(LIGHT_AREA_RECT, emit=(P / np.pi,) * 3, position=(-1, 0, 5), axis_x=(1, 0, 0),
                 axis_y=(0, 1, 0))                              # 1 x 1, faces down
    back = light(LIGHT_AREA_RECT, emit=(5.0,) * 3, position=(1, 0, 5), axis_x=(1, 0, 0),
                 axis_y=(0, 1, 0), direction=(0, 0, 1))         # faces away: invisible
    I, r = P / (4 * np.pi), 0.5
    sphere = light(LIGHT_POINT, emit=(I,) * 3, position=(0, 1.5, 5), radius=r)
    mb = MeshBuilder()
    cam = make_camera(type=CAMERA_ORTHO, width=8, height=8,
                      to_world=look_at((0, 0, 0), (0, 0, 1), up=(0, 1, 0)), extent=(4, 4),
                      clip=(0.01, 100))
    scene = mb.build(camera=cam, lights=np.concatenate([area, back, sphere]))
    img = render(scene, 1, photons_per_pass=16)[..., 0]
    # ortho camera looking up +z with up +y: image x = -world x
    assert img[3, 5] == pytest.approx(P / np.pi, rel=1e-6)      # world (-1, 0): the area light
    assert img[3, 2] == 0.0                                      # world (+1, 0): its back
    assert img[6, 3] == pytest.approx(I / (np.pi * r * r), rel=1e-6)
    assert img[0, 0] == 0.0
