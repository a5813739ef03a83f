"""An exact-geometry reference for ``fog_lens`` (ppm_engine/blender/scenes/fog_lens.py) in
NumPy: a true sphere of clear glass (IOR 1.5) in a box of homogeneous fog (scattering sigma_s,
absorption sigma_a, Henyey-Greenstein anisotropy g) under a point light of radius 0 (P / (4 pi)
W/sr per watt, Cycles' convention), seen through a pinhole.  It shares no code with this
engine's estimators (no export, kernels or film): the camera's projection and the pixel filter
are the exact references' (exact_film.py), the glass's Fresnel choice exact_optics.py's.

What it renders is what the engine and Cycles render with Volume bounces 1 (the scene's): the
light scattered once or twice in the fog, as the camera sees it past the ball (the pixels whose
pixel filter reaches a camera ray through the ball are not rendered: ``render``'s mask):

- **single scattering of the light straight from the lamp** (``direct``): per camera ray the
  integral along it, in the fog, of sigma_s phase I / d^2 times the transmittance from the lamp
  and to the camera, where the ball is not on the segment to the lamp (the glass is opaque to
  next-event estimation); by equiangular quadrature (s = delta + D tan theta: the integrand is
  smooth in theta), on a grid of raster points integrated over the pixel filter: no noise;
- **the volumetric caustic** (single scattering of light through or off the ball, L S+ M):
  rays from the lamp into the cone the ball subtends, through the fog to it (its
  transmittance), reflected or refracted as the Fresnel factor says (one way at random, in
  that proportion) until they leave; each leg in the fog after the ball scatters sigma_s e^(-
  sigma_t u) du of its power at u, a point light of that intensity times the phase function
  towards the camera, splatted (``beams``) at stratified points of the leg;
- **double scattering** (L M S* M: Volume bounces 1 lets a camera path scatter twice, the
  second time towards the lamp): photons from the lamp in every direction, each scattering
  first at an exponential distance in the fog before the ball (with weight the albedo), then
  along the phase function, its legs splatted as the caustic's (through the ball too).  Light
  that met the ball before its first scattering and scatters twice after it needs Volume
  bounces 2 (a camera path's second scattering in a medium would go on to the glass): not
  rendered, by Cycles either.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ppm_engine.tools.bench.exact_caustic_scene import _ball_hits, ball_blocks
from ppm_engine.tools.bench.exact_film import (
    CameraSetup,
    camera_fields,
    camera_rays,
    filtered,
    project,
    splat,
    window_clear,
)
from ppm_engine.tools.bench.exact_optics import cone_dirs, glass_scatter

BATCH = 1 << 16                  # rays per batch
LEG_POINTS = 16                  # stratified points per leg of a ray in the fog
MAX_VERTICES = 8                 # glass vertices a ray follows at most (then its power is left)


@dataclass
class FogSetup(CameraSetup):
    """What the tracer needs of the scene (fog_setup reads it from bpy)."""
    light: np.ndarray            # the point light's position
    intensity: float             # its W/sr (power / (4 pi))
    box: tuple                   # the fog's (lo, hi)
    sigma_s: float
    sigma_a: float
    g: float
    ball: tuple | None           # (centre, radius) or None

    @property
    def sigma_t(self) -> float:
        return self.sigma_s + self.sigma_a


def fog_setup(scene) -> FogSetup:
    """The camera and film of a ``fog_lens`` bpy scene (exact_film.camera_fields), its light and
    ball as placed there (the objects "Point" and "GlassBall": the ball's radius is
    fog_lens.BALL's), the fog fog_lens's."""
    from ppm_engine.blender.scenes import fog_lens as fl
    scene.view_layers[0].update()
    light = scene.objects["Point"]
    ball = scene.objects.get("GlassBall")
    return FogSetup(**camera_fields(scene), light=np.array(light.matrix_world.translation, float),
                    intensity=float(light.data.energy) / (4.0 * math.pi),
                    box=(np.array(fl.FOG_LO, float), np.array(fl.FOG_HI, float)),
                    sigma_s=fl.FOG_SCATTER, sigma_a=fl.FOG_ABSORB, g=0.0,
                    ball=None if ball is None else (np.array(ball.location, float),
                                                    fl.BALL[1]))


# --- geometry ----------------------------------------------------------------------------------
def box_span(s: FogSetup, o, d):
    """(t0, t1): where the lines o + t d (t >= 0) are inside the fog's box (t1 <= t0: never)."""
    lo, hi = s.box
    with np.errstate(divide="ignore", invalid="ignore"):
        a, b = (lo - o) / d, (hi - o) / d
    near = np.nan_to_num(np.minimum(a, b), nan=-np.inf, neginf=-np.inf)
    far = np.nan_to_num(np.maximum(a, b), nan=np.inf, posinf=np.inf)
    return np.maximum(near.max(axis=1), 0.0), far.min(axis=1)


def fog_length(s: FogSetup, p, q):
    """The length inside the fog of each segment p -> q."""
    v = q - p
    dist = np.linalg.norm(v, axis=1)
    t0, t1 = box_span(s, p, v / dist[:, None])
    return np.clip(np.minimum(t1, dist) - t0, 0.0, None)


def ball_hits(s: FogSetup, o, d, inside):
    if s.ball is None:
        return np.full(len(o), np.inf)
    return _ball_hits(o, d, inside, s.ball)


def hg(cos, g: float):
    """Henyey-Greenstein's phase function (per steradian) at the cosine between the direction the
    light travelled and the one it goes on in."""
    k = 1.0 + g * g - 2.0 * g * cos
    return (1.0 - g * g) / (4.0 * np.pi * k * np.sqrt(k))


def hg_dirs(w, g: float, rng):
    """Directions from the phase function about the travel directions w."""
    u1, u2 = rng.random(len(w)), rng.random(len(w))
    if abs(g) < 1e-3:
        c = 1.0 - 2.0 * u1
    else:
        k = (1.0 - g * g) / (1.0 - g + 2.0 * g * u1)
        c = np.clip((1.0 + g * g - k * k) / (2.0 * g), -1.0, 1.0)
    sn, phi = np.sqrt(np.maximum(1.0 - c * c, 0.0)), 2.0 * np.pi * u2
    t = np.where((np.abs(w[:, 0]) > 0.9)[:, None], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0])
    b1 = np.cross(w, t)
    b1 /= np.linalg.norm(b1, axis=1, keepdims=True)
    b2 = np.cross(w, b1)
    return c[:, None] * w + sn[:, None] * (np.cos(phi)[:, None] * b1 + np.sin(phi)[:, None] * b2)


# --- single scattering of the direct light -----------------------------------------------------
def _direct_ray(s: FogSetup, px, py, steps: int):
    """The radiance single scattering of the lamp's direct light brings along the camera rays
    through raster positions (px, py), and whether each meets the ball in the fog."""
    d = camera_rays(s, px, py)
    o = np.broadcast_to(s.eye, d.shape)
    t0, t1 = box_span(s, o, d)
    tb = ball_hits(s, o, d, np.zeros(len(d), bool))
    bad = tb < t1
    t1 = np.minimum(t1, tb)
    delta = ((s.light - o) * d).sum(axis=1)
    D = np.maximum(np.linalg.norm(s.light - o - delta[:, None] * d, axis=1), 1e-9)
    ta, tb_ = np.arctan2(t0 - delta, D), np.arctan2(t1 - delta, D)
    span = np.where(t1 > t0, tb_ - ta, 0.0)
    out = np.zeros(len(d))
    for k in range(steps):
        th = ta + (k + 0.5) / steps * span
        u = delta + D * np.tan(th)
        x = o + u[:, None] * d
        to_l = s.light - x
        dist = np.linalg.norm(to_l, axis=1)
        lhat = to_l / dist[:, None]
        vis = ~ball_blocks(x, lhat, dist, s.ball) if s.ball is not None else True
        tr = np.exp(-s.sigma_t * ((u - t0) + fog_length(s, x, np.broadcast_to(s.light, x.shape))))
        f = s.sigma_s * hg((lhat * d).sum(axis=1), s.g) * s.intensity * tr * vis
        out += f * span / steps / D
    return out, bad


def direct(s: FogSetup, per_pixel: int = 4, steps: int = 64, chunk: int = 1 << 15):
    """(h * w) rows top-down: the single scattering of the lamp's direct light, and (h, w) the
    pixels whose filter reaches no camera ray through the ball (where the reference holds)."""
    r, k = s.filter_width, per_pixel
    pad = math.ceil(r * k)
    gx = (np.arange(-pad, s.width * k + pad) + 0.5) / k
    gy = (np.arange(-pad, s.height * k + pad) + 0.5) / k
    nx = gx.size
    rad, bad = np.empty(gy.size * nx), np.empty(gy.size * nx, bool)
    for i0 in range(0, rad.size, chunk):
        i = np.arange(i0, min(i0 + chunk, rad.size))
        rad[i], bad[i] = _direct_ray(s, gx[i % nx], gy[i // nx], steps)
    clear = window_clear(bad.reshape(gy.size, nx), s, k, pad, 0.5)
    return filtered(s, rad.reshape(gy.size, nx), gx, gy, k), clear


# --- light scattered after the ball, and twice --------------------------------------------------
def _splat_leg(s: FogSetup, acc, p, w, leg, power, rng):
    """Splat the light the legs p + u w (0 <= u < leg) scatter towards the camera."""
    inv_area = 1.0 / s.pixel_area
    for k in range(LEG_POINTS):
        u = (k + rng.random(len(p))) / LEG_POINTS * leg
        y = p + u[:, None] * w
        px, py, to_eye, dist, cos_cam, ok = project(s, y)
        if s.ball is not None:
            ok[ok] &= ~ball_blocks(y[ok], to_eye[ok], dist[ok], s.ball)
        y, to_eye, dist = y[ok], to_eye[ok], dist[ok]
        tr = np.exp(-s.sigma_t * (u[ok] + fog_length(s, y, np.broadcast_to(s.eye, y.shape))))
        J = (power[ok] * s.sigma_s * (leg[ok] / LEG_POINTS) * tr
             * hg((w[ok] * to_eye).sum(axis=1), s.g))
        splat(acc, s, px[ok], py[ok], J * inv_area / (cos_cam[ok] ** 3 * dist ** 2))


def beams(s: FogSetup, acc, p, w, power, rng, first: bool = True):
    """Rays from p along w of ``power`` through the fog and the ball: each leg in the fog (the
    first only with ``first``) splatted, the glass's choice at random by its Fresnel factor."""
    inside = np.zeros(len(p), bool)
    for vertex in range(MAX_VERTICES + 1):
        out = ~inside
        t_box = np.full(len(p), np.inf)
        t_box[out] = box_span(s, p[out], w[out])[1]
        t_ball = ball_hits(s, p, w, inside)
        leg = np.minimum(t_box, t_ball)
        if first or vertex > 0:
            m = out & np.isfinite(leg)
            _splat_leg(s, acc, p[m], w[m], leg[m], power[m], rng)
        hit = t_ball < t_box
        if not hit.any() or vertex == MAX_VERTICES:
            return
        p, w, power, inside, t_ball = p[hit], w[hit], power[hit], inside[hit], t_ball[hit]
        q = p + t_ball[:, None] * w
        power = power * np.where(inside, 1.0, np.exp(-s.sigma_t * fog_length(s, p, q)))
        p = q
        n = (p - s.ball[0]) / s.ball[1]
        w, _, inside = glass_scatter(w, n, inside, rng.random(len(p)))


def caustic(s: FogSetup, acc, rays: int, rng):
    """The volumetric caustic: ``rays`` from the lamp into the ball's cone (beams)."""
    c, r = s.ball
    axis = c - s.light
    dist = np.linalg.norm(axis)
    cos_max = math.sqrt(max(1.0 - (r / dist) ** 2, 0.0))
    omega = 2.0 * math.pi * (1.0 - cos_max)
    for b0 in range(0, rays, BATCH):
        n = min(BATCH, rays - b0)
        w = cone_dirs(axis / dist, cos_max, n, rng)
        p = np.broadcast_to(s.light, w.shape).copy()
        # (the first leg's transmittance: beams' own, whose first leg here is the lamp's)
        beams(s, acc, p, w, np.full(n, s.intensity * omega / rays), rng, first=False)


def double(s: FogSetup, acc, photons: int, rng):
    """Double scattering: ``photons`` from the lamp over the sphere of directions, scattered
    first in the fog before the ball (an exponential distance, weight the albedo), then along the
    phase function (beams)."""
    for b0 in range(0, photons, BATCH):
        n = min(BATCH, photons - b0)
        w = rng.normal(size=(n, 3))
        w /= np.linalg.norm(w, axis=1, keepdims=True)
        o = np.broadcast_to(s.light, w.shape)
        t0, t1 = box_span(s, o, w)
        t_end = np.minimum(t1, ball_hits(s, o, w, np.zeros(n, bool)))
        u = t0 + rng.exponential(1.0 / s.sigma_t, n)       # (the lamp may be outside the fog)
        m = (t1 > t0) & (u < t_end)
        p = o[m] + u[m, None] * w[m]
        power = np.full(m.sum(), 4.0 * math.pi * s.intensity / photons * s.sigma_s / s.sigma_t)
        beams(s, acc, p, hg_dirs(w[m], s.g, rng), power, rng)


def render_for(scene, seconds: float, seed: int = 0):
    """The bench's reference half (references.py): the bpy ``scene`` for ``seconds`` (whole
    batches of BATCH rays into the ball's cone and BATCH photons, at least one): (RGB image
    top-down, the pixels it holds, info)."""
    import time
    t = time.perf_counter()
    s = fog_setup(scene)
    rng = np.random.default_rng(seed)
    img, clear = direct(s)
    n = 0
    caustics, doubles = np.zeros(s.width * s.height), np.zeros(s.width * s.height)
    while n == 0 or time.perf_counter() - t < seconds:
        if s.ball is not None:
            caustic(s, caustics, BATCH, rng)
        double(s, doubles, BATCH, rng)
        n += 1
    img = (img + (caustics + doubles) / n).reshape(s.height, s.width) * s.film_exposure
    rgb = np.repeat(img[..., None], 3, axis=-1).astype(np.float32)
    return rgb, clear, {"photons": 2 * n * BATCH}


def render(s: FogSetup, rays: int = 1 << 20, photons: int = 1 << 20, seed: int = 0):
    """(h, w) radiance rows top-down (the film's exposure applied) and (h, w) the mask of the
    pixels it holds for (their filter reaches no camera ray through the ball)."""
    rng = np.random.default_rng(seed)
    img, clear = direct(s)
    acc = np.zeros(s.width * s.height)
    if s.ball is not None:
        caustic(s, acc, rays, rng)
    double(s, acc, photons, rng)
    img = (img + acc).reshape(s.height, s.width) * s.film_exposure
    return img, clear
