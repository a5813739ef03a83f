"""Scenes with exact answers, as SceneArrays, and their answers in float64 NumPy.

Used by the accuracy tests (tests/test_accuracy.py), docs/ACCURACY.md and the benchmark.
Each reference is computed independently of the kernels: image sources for the mirror, Snell +
Fresnel + the ray-tube Jacobian for the slab."""
from __future__ import annotations

import numpy as np

from ppm_engine.oracle.procedural import MeshBuilder, look_at
from ppm_engine.scene.arrays import CAMERA_ORTHO, LIGHT_DTYPE, LIGHT_POINT
from ppm_engine.scene.camera import make_camera

ALBEDO = 0.5


def _point_light(P, pos):
    L = np.zeros(1, LIGHT_DTYPE)
    L["type"], L["emit"] = LIGHT_POINT, P / (4 * np.pi)
    L["position"], L["direction"] = pos, (0, 0, -1)
    return L


def _floor_camera(W, x0, x1, y0, y1, height=3.0):
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    return make_camera(type=CAMERA_ORTHO, width=W, height=W,
                       to_world=look_at((cx, cy, height), (cx, cy, 0), up=(0, 1, 0)),
                       extent=(x1 - x0, y1 - y0), clip=(0.01, 100))


def pixel_floor_points(W, x0, x1, y0, y1):
    """Floor (x, y) at the pixel centres, row 0 = bottom (smallest y)."""
    xs = x0 + (np.arange(W) + 0.5) / W * (x1 - x0)
    ys = y0 + (np.arange(W) + 0.5) / W * (y1 - y0)
    return np.meshgrid(xs, ys)


# --- mirror caustic ---------------------------------------------------------------------------
MIRROR = dict(P=100.0, light=(0.0, 0.0, 1.0), mirror_x=0.5, view=(-1.0, 0.4, -0.7, 0.7))


def mirror_caustic(W=32):
    """A point light 1 m above a diffuse floor beside a vertical mirror (x = 0.5, facing -x).
    Render with max_bounces=1: direct light plus exactly the light the mirror reflects."""
    c = MIRROR
    mb = MeshBuilder()
    floor = mb.material("floor", (ALBEDO,) * 3)
    mirror = mb.material("mirror", (1, 1, 1), metallic=1.0, roughness=0.0)
    mb.quad((0, 0, 0), (20, 0, 0), (0, 20, 0), floor)
    mb.quad((c["mirror_x"], 0, 0.75), (0, 0, 0.75), (0, 1.0, 0), mirror)
    return mb.build(camera=_floor_camera(W, *c["view"]), lights=_point_light(c["P"], c["light"]))


def mirror_caustic_radiance(W=32, supersample=4):
    """Exact floor radiance: albedo/pi (I h/d^3 + I h/d'^3), d' to the image source
    (the mirror covers every reflected path for the floor in view)."""
    c = MIRROR
    I, (lx, ly, h) = c["P"] / (4 * np.pi), c["light"]
    image_x = 2 * c["mirror_x"] - lx
    acc = 0.0
    x0, x1, y0, y1 = c["view"]
    px, py = (x1 - x0) / W, (y1 - y0) / W
    for i in range(supersample):
        for j in range(supersample):
            x, y = pixel_floor_points(W, *c["view"])
            x = x + ((i + 0.5) / supersample - 0.5) * px
            y = y + ((j + 0.5) / supersample - 0.5) * py
            d = np.sqrt((x - lx) ** 2 + (y - ly) ** 2 + h * h)
            dm = np.sqrt((x - image_x) ** 2 + (y - ly) ** 2 + h * h)
            acc = acc + ALBEDO / np.pi * (I * h / d ** 3 + I * h / dm ** 3)
    return acc / supersample ** 2


def mirror_caustic_only(W=32):
    """The reflected (caustic) part alone, for the caustic error."""
    c = MIRROR
    I, (lx, ly, h) = c["P"] / (4 * np.pi), c["light"]
    x, y = pixel_floor_points(W, *c["view"])
    dm = np.sqrt((x - (2 * c["mirror_x"] - lx)) ** 2 + (y - ly) ** 2 + h * h)
    return ALBEDO / np.pi * I * h / dm ** 3


# --- glass slab --------------------------------------------------------------------------------
SLAB = dict(P=100.0, light=(0.0, 0.0, 1.5), ior=1.5, bottom=0.3, thickness=0.4,
            view=(-0.8, 0.8, -0.8, 0.8))


def glass_slab(W=24, absorption=(0.0, 0.0, 0.0)):
    """A point light above a glass slab over a diffuse floor.  Render with max_bounces=4: the
    light reaches the floor only by refraction through both faces, the camera sees the floor
    through both faces (Cycles counts four bounces: the camera's two refractions, the floor's
    and the light's refraction out of the slab; the one into it reaches the light), and no
    path with an internal reflection (two more bounces at least) or light back from the floor
    (two more) is in.
    ``absorption``: the glass's absorption coefficient per metre, RGB."""
    c = SLAB
    mb = MeshBuilder()
    floor = mb.material("floor", (ALBEDO,) * 3)
    glass = mb.material("glass", (1, 1, 1), transmission=1.0, roughness=0.0, ior=c["ior"],
                        absorption=absorption)
    mb.quad((0, 0, 0), (20, 0, 0), (0, 20, 0), floor)
    b, t = c["bottom"], c["thickness"]
    mb.box((-3, -3, b), (3, 3, b + t), glass)
    return mb.build(camera=_floor_camera(W, *c["view"], height=1.0),
                    lights=_point_light(c["P"], c["light"]))


def fresnel(cos_i, eta):
    """Unpolarised Fresnel reflectance, eta = n_t / n_i (float64)."""
    sin2_t = (1 - cos_i ** 2) / eta ** 2
    cos_t = np.sqrt(np.maximum(0.0, 1 - sin2_t))
    rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    return np.where(sin2_t >= 1, 1.0, 0.5 * (rs ** 2 + rp ** 2))


def glass_slab_radiance(W=24, absorption=(0.0, 0.0, 0.0)):
    """Floor radiance seen through the slab, float64: for each floor distance rho from below
    the light, the incidence angle theta solves rho = (h_above + h_below) tan(theta) +
    t tan(theta_t); E = I T(theta) sin(theta) dtheta / (rho drho) (power per floor area in a
    ray tube), T = (1 - F_top)(1 - F_bottom); the camera looks straight down through both faces:
    another (1 - F0)^2.  With ``absorption`` sigma (RGB, per metre), Beer-Lambert along both
    paths inside the slab: exp(-sigma t / cos(theta_t)) for the light, exp(-sigma t) for the
    camera's; returns (W, W, 3) then, else (W, W)."""
    c = SLAB
    n, b, t = c["ior"], c["bottom"], c["thickness"]
    lx, ly, lz = c["light"]
    I = c["P"] / (4 * np.pi)
    h_above, h_below = lz - (b + t), b

    def rho_of(theta):
        st = np.sin(theta) / n
        return (h_above + h_below) * np.tan(theta) + t * st / np.sqrt(1 - st * st)

    theta = np.linspace(0, np.radians(89.0), 200001)
    rho_tab = rho_of(theta)
    x, y = pixel_floor_points(W, *c["view"])
    rho = np.hypot(x - lx, y - ly)
    th = np.interp(rho, rho_tab, theta)
    dth = 1e-6
    th_lo = np.maximum(th - dth, 0)
    drho = (rho_of(th + dth) - rho_of(th_lo)) / (th + dth - th_lo)
    cos_i = np.cos(th)
    cos_t = np.sqrt(1 - (np.sin(th) / n) ** 2)
    T = (1 - fresnel(cos_i, n)) * (1 - fresnel(cos_t, 1 / n))
    with np.errstate(invalid="ignore", divide="ignore"):
        E = np.where(rho > 1e-9, I * T * np.sin(th) / (rho * drho),
                     I * T / ((h_above + h_below + t / n) ** 2))   # on axis: the limit
    T_cam = (1 - fresnel(np.ones(1), n)[0]) ** 2
    L = T_cam * ALBEDO / np.pi * E
    sigma = np.asarray(absorption, np.float64)
    if not sigma.any():
        return L
    return L[..., None] * np.exp(-sigma * t / cos_t[..., None]) * np.exp(-sigma * t)
