"""An exact-geometry reference for the benchmark's ``point_caustic`` and ``rough_caustic`` scenes
in NumPy, on the scene as ppm_engine/blender/scenes/caustics.py defines it (a true sphere, two
finite planes, a point light): the direct light in closed form, the rest by light tracing.  It
shares no code with this engine's estimators (no export, kernels, film or light tracer): the
reference stays independent once light tracing is one of the engine's own strategies (issue 25).
Where the engine sees a 192 x 96 smooth-shaded mesh, this sees the sphere.

The light transport, as Cycles renders the scene with the bench's settings:

- the point light (radius 0) radiates P / (4 pi) W/sr per watt of its power P in every
  direction: Cycles' convention (tests/test_exact_caustic.py checks it against a Cycles render);
- the floor and the back wall are Lambertian (albedo FLOOR, both sides); the glass is a smooth
  dielectric (IOR 1.5) which reflects or refracts as the exact unpolarised Fresnel factor says
  (chosen at random in that proportion, as Cycles' sharp glass samples it), with no absorption;
- rough glass (``rough_caustic``: the ball's Principled Roughness r > 0, the GGX distribution,
  alpha = r^2) is the microfacet dielectric of Walter et al. 2007 with Smith's height-correlated
  shadowing, which Cycles' GGX glass also is: a microfacet normal sampled among those visible
  from where the photon came from (Heitz 2018), reflection or refraction about it with its
  Fresnel probability, the photon's flux times G2 / G1 (``rough_glass_scatter``; tests/
  test_exact_caustic.py checks it against a brute-force integral of the BSDF written out in
  full).  Cycles' Multiscatter GGX adds an energy compensation this does not model, so the
  reference asks for GGX;
- the direct light (what the floor and the wall the camera sees receive straight from the light,
  past the ball: the glass is opaque to the shadow ray, as to Cycles') is the closed form of a point
  light on a Lambertian plane, integrated over each pixel's filter on a fixed grid
  (``direct_light``): no noise.  Light tracing rendered it too until 2026-11-27, which made most of
  the reference's noise over the whole image (docs/history/benchmarks-notebook.md, "Its direct light
  in closed form");
- every other photon hitting the floor or the wall is connected to the pinhole camera, unless
  the ball is on the segment (the glass is opaque to that connection too), and splatted into
  the pixels through Cycles' Blackman-Harris pixel filter: those that went through or off the
  glass at their first diffuse hit and later ones, the others (the direct light's) from their
  second on;
- then it bounces on: a cosine-distributed direction, kept with probability = albedo (Russian
  roulette: the photon's weight never changes at a surface);
- bounce limits are Cycles' Light Paths (scene.cycles): a connection at the photon's vertex b
  (0 = where it first lands) is the Cycles path of b bounces from the camera, whose scattering
  vertices are the photon's 1..b (the camera path does next-event estimation at the photon's
  vertex 0, which scatters nothing): b <= max_bounces, and per kind (diffuse: the floor and
  the wall; glossy: the glass's reflection; transmission: its refraction) no more of them
  among 1..b than the kind's limit.  The scene sets all of them to 12 (cornell_box.
  camera_world_render), so only max_bounces binds, and hardly: in this open scene each bounce
  adds less than half of the light the one before did, 0.2 % of the mean from the 5th to the
  12th vertex, about 1e-5 beyond.

Emission is stratified (exactly, not approximately): no geometry lies at x < -2, the light's x,
so photons leave into x > 0 only; a share of them (``BALL_SHARE``) go uniformly into the cone
the ball subtends, which makes the caustic much less noisy, and the rest uniformly into the
half space less that cone; each carries its stratum's flux (intensity x solid angle / count).
Strata are unbiased for any integrand over the directions, so for the light tracer's share of
the light with the direct light taken out as well (tests/test_exact_caustic.py checks both).
The cone, 0.8 % of the half space's solid angle, took a quarter of the photons while light
tracing rendered the direct light; without it 5 % is the better share.  A cone photon costs
about 3.7 times one of the rest (its vertices on the glass, and a splat where it lands, which
the rest no longer make), so 5 % traces 1.5 times the photons a second; per photon a quarter
is 10 % less noisy over the caustic and 12 % more over the image, so at equal time 5 % leaves
27 % less noise over the image and 9 % less over the caustic (128 x 128, 2^22 photons per
render, five seeds).

``render`` returns the image (RGB, rows top-down, as the bench's EXRs read), the coverage (the
pixels light tracing renders: those whose filter footprint sees only the floor or the wall
directly, not the ball and not the void) and an info dict.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ppm_engine.blender.scenes.caustics import BALL, FLOOR, SPOT_POS

IOR = 1.5                        # the ball's glass (scenes.cornell_box.glass's default)
FLOOR_HALF = 2.0                 # the floor: z = 0, |x|, |y| <= 2
WALL_Y, WALL_TOP = 2.0, 2.5      # the back wall: y = 2, |x| <= 2, 0 <= z <= 2.5
BALL_SHARE = 0.05                # photons sent into the cone of the ball (see the docstring)
BATCH = 1 << 18
DIRECT_GRID = 8                  # the direct light's cells per pixel and axis
DIRECT_REFINE = 16               # points per cell and axis where the direct light jumps
EPS = 1e-9                       # hit distances at or below it are the surface a ray left

# the Blackman-Harris window's coefficients (Cycles' film: the filter spans twice the scene's
# filter width, so half its span is the width); its mean over the span is A0
BH = (0.35875, -0.48829, 0.14128, -0.01168)

FLOOR_ID, WALL_ID, BALL_ID = 0, 1, 2


# --- the scene -------------------------------------------------------------------------------
@dataclass
class Setup:
    """What the tracer needs of the bpy scene."""
    eye: np.ndarray              # camera position (3,)
    axes: np.ndarray             # (3, 3), columns: the camera's x, y, z in world space
    frame: tuple                 # (x_left, x_right, y_bottom, y_top) on the plane at depth 1
    width: int
    height: int
    clip: tuple                  # (start, end) depth
    filter_width: float          # the scene's, in pixels: the filter reaches this far
    film_exposure: float
    light: np.ndarray            # position (3,)
    power: np.ndarray            # RGB watts (colour x energy x 2^exposure)
    max_bounces: int
    diffuse_bounces: int
    glossy_bounces: int
    transmission_bounces: int
    roughness: float = 0.0       # the glass's (Principled Roughness; alpha = its square)

    @property
    def pixel_area(self) -> float:
        """A pixel's area on the image plane at depth 1."""
        x0, x1, y0, y1 = self.frame
        return (x1 - x0) * (y1 - y0) / (self.width * self.height)


def camera_fields(scene) -> dict:
    """The camera, frame and film of a bpy scene as the exact references trace them (Setup's
    eye, axes, frame, width, height, clip, filter_width, film_exposure); refuses what they do
    not model: a lens, a border, another pixel filter."""
    cam = scene.camera
    if cam is None or cam.data.type != 'PERSP':
        raise ValueError("the exact reference renders through a perspective (pinhole) camera")
    if cam.data.dof.use_dof:
        raise ValueError("the exact reference renders through a pinhole: turn depth of field off")
    m = np.array(cam.matrix_world, float)
    axes = m[:3, :3] / np.linalg.norm(m[:3, :3], axis=0)
    corners = np.array([tuple(v) for v in cam.data.view_frame(scene=scene)], float)
    unit = corners[:, :2] / -corners[:, 2:3]          # the frame projected to depth 1
    frame = (unit[:, 0].min(), unit[:, 0].max(), unit[:, 1].min(), unit[:, 1].max())
    r = scene.render
    if r.use_border:
        raise ValueError("the exact reference renders the whole frame: turn the border off")
    c = scene.cycles
    if c.pixel_filter_type != 'BLACKMAN_HARRIS':
        raise ValueError("the exact reference implements Cycles' Blackman-Harris filter only")
    return {"eye": m[:3, 3].copy(), "axes": axes, "frame": frame,
            "width": int(r.resolution_x * r.resolution_percentage / 100),
            "height": int(r.resolution_y * r.resolution_percentage / 100),
            "clip": (cam.data.clip_start, cam.data.clip_end),
            "filter_width": float(c.filter_width), "film_exposure": float(c.film_exposure)}


def setup_of(scene, max_bounces: int | None = None) -> Setup:
    """The camera, film, light and bounce limits of a ``point_caustic`` bpy scene (its geometry
    is the module's constants; the light must stand where caustics.point_caustic puts it).
    ``max_bounces`` overrides all of the scene's bounce limits."""
    scene.view_layers[0].update()       # the objects' matrix_world after a script's edits
    if len(set(FLOOR)) != 1:
        raise ValueError("the exact reference traces one channel: the stage must be grey")
    camera = camera_fields(scene)
    c = scene.cycles
    lights = [o for o in scene.objects if o.type == 'LIGHT' and not o.hide_render]
    if len(lights) != 1 or lights[0].data.type != 'POINT' or lights[0].data.shadow_soft_size:
        raise ValueError("the exact reference renders one point light of radius 0")
    light = lights[0]
    pos = np.array(light.matrix_world.translation, float)
    if not np.allclose(pos, SPOT_POS):
        raise ValueError(f"the point light is at {tuple(pos)}, not at point_caustic's {SPOT_POS}")
    power = (np.array(light.data.color, float) * light.data.energy
             * 2.0 ** getattr(light.data, "exposure", 0.0))
    roughness = glass_roughness(scene)
    limits = [c.max_bounces, c.diffuse_bounces, c.glossy_bounces, c.transmission_bounces]
    if max_bounces is not None:
        limits = [max_bounces] * 4
    return Setup(**camera, light=pos, power=power, max_bounces=int(limits[0]),
                 diffuse_bounces=int(limits[1]), glossy_bounces=int(limits[2]),
                 transmission_bounces=int(limits[3]), roughness=roughness)


def glass_roughness(scene) -> float:
    """The ball's roughness: its material must be the clear glass the reference models (a
    Principled BSDF straight into the output, Transmission Weight 1, IOR 1.5, white, constant
    inputs), rough only with the single-scattering GGX distribution (Cycles' Multiscatter GGX
    adds an energy compensation this does not model)."""
    ball = next((o for o in scene.objects if o.name.startswith("GlassBall")), None)
    mat = ball.active_material if ball is not None else None
    nodes = mat.node_tree.nodes if mat is not None and mat.node_tree is not None else []
    p = next((n for n in nodes if n.bl_idname == "ShaderNodeBsdfPrincipled"), None)
    if p is None:
        raise ValueError("the exact reference needs the ball 'GlassBall' with a Principled BSDF")
    used = [k for k in ("Roughness", "Transmission Weight", "IOR", "Base Color")
            if p.inputs[k].is_linked]
    if used:
        raise ValueError(f"the exact reference needs constant glass inputs, not linked {used}")
    if (p.inputs["Transmission Weight"].default_value != 1.0
            or abs(p.inputs["IOR"].default_value - IOR) > 1e-6
            or tuple(p.inputs["Base Color"].default_value)[:3] != (1.0, 1.0, 1.0)):
        raise ValueError(f"the exact reference models clear white glass of IOR {IOR}")
    r = float(p.inputs["Roughness"].default_value)
    if r > 0.0 and p.distribution != 'GGX':
        raise ValueError("the exact reference models rough glass with the GGX distribution, "
                         f"not {p.distribution}")
    return r


# --- the pixel filter ------------------------------------------------------------------------
def filter_1d(x, width: float):
    """Cycles' Blackman-Harris pixel filter in one dimension, normalised (integral 1 over pixel
    units): zero beyond ``width`` pixels from the centre (the window spans 2 x width)."""
    x = np.asarray(x, float)
    span = 2.0 * width
    c = np.cos(2.0 * np.pi * (x / span + 0.5))
    # cos 2v and cos 3v from cos v (one cosine: the splat evaluates this per photon and pixel)
    f = BH[0] + BH[1] * c + BH[2] * (2.0 * c * c - 1.0) + BH[3] * c * (4.0 * c * c - 3.0)
    return np.where(np.abs(x) < width, f / (BH[0] * span), 0.0)


def splat(acc: np.ndarray, s: Setup, px, py, value) -> None:
    """Add ``value`` at raster positions (px, py) (pixels, y down) to ``acc`` (h * w, rows top-
    down) through the pixel filter: pixel (i, j) gets f(px - i - 1/2) f(py - j - 1/2)."""
    reach, w, h = s.filter_width, s.width, s.height
    n = math.floor(2.0 * reach) + 1           # pixels per axis the filter can reach
    i0 = np.ceil(px - 0.5 - reach).astype(np.int64)
    j0 = np.ceil(py - 0.5 - reach).astype(np.int64)
    wx = [filter_1d(px - (i0 + a + 0.5), reach) for a in range(n)]
    wy = [filter_1d(py - (j0 + b + 0.5), reach) for b in range(n)]
    for b in range(n):
        j = j0 + b
        for a in range(n):
            i = i0 + a
            ok = (i >= 0) & (i < w) & (j >= 0) & (j < h)
            acc += np.bincount((j * w + i)[ok], (value * wx[a] * wy[b])[ok], minlength=w * h)


# --- geometry --------------------------------------------------------------------------------
def _ball_hits(o, d, inside):
    """Distance along unit rays to the ball: the far root for rays inside it, else the near root
    (inf where none)."""
    center, radius = np.asarray(BALL[0], float), BALL[1]
    oc = o - center
    b = np.einsum("ij,ij->i", d, oc)
    disc = b * b - (np.einsum("ij,ij->i", oc, oc) - radius * radius)
    s = np.sqrt(np.maximum(disc, 0.0))
    t = np.where(inside, -b + s, -b - s)
    return np.where((disc > 0) & (t > EPS), t, np.inf)


def _plane_hits(o, d):
    """Distances to the floor and to the back wall (inf where a ray misses them)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        tf = -o[:, 2] / d[:, 2]
        tw = (WALL_Y - o[:, 1]) / d[:, 1]
    pf = o + tf[:, None] * d
    pw = o + tw[:, None] * d
    tf = np.where((tf > EPS) & (np.abs(pf[:, 0]) <= FLOOR_HALF)
                  & (np.abs(pf[:, 1]) <= FLOOR_HALF), tf, np.inf)
    tw = np.where((tw > EPS) & (np.abs(pw[:, 0]) <= FLOOR_HALF) & (pw[:, 2] >= 0.0)
                  & (pw[:, 2] <= WALL_TOP), tw, np.inf)
    return tf, tw


def first_hit(o, d, inside, left_ball):
    """(distance, surface id) of the first hit along unit rays; id -1 where nothing is hit.
    A ray inside the ball meets only the ball (the floor touches it at one point); a ray that
    left the ball outwards never meets it again (it is convex)."""
    tf, tw = _plane_hits(o, d)
    tb = _ball_hits(o, d, inside)
    tb = np.where(left_ball & ~inside, np.inf, tb)
    tf = np.where(inside, np.inf, tf)
    tw = np.where(inside, np.inf, tw)
    t = np.stack([tf, tw, tb])
    k = np.argmin(t, axis=0)
    tmin = t[k, np.arange(t.shape[1])]
    return tmin, np.where(np.isfinite(tmin), k, -1)


def _ball_blocks(p, u, dist):
    """Whether the ball cuts the segments from p along unit u of length dist."""
    center, radius = np.asarray(BALL[0], float), BALL[1]
    oc = p - center
    b = np.einsum("ij,ij->i", u, oc)
    disc = b * b - (np.einsum("ij,ij->i", oc, oc) - radius * radius)
    s = np.sqrt(np.maximum(disc, 0.0))
    return (disc > 0) & (-b + s > EPS) & (-b - s < dist)


def fresnel(cos_i, eta):
    """Exact unpolarised dielectric Fresnel reflectance for the incidence cosine (> 0) and
    eta = n_incident / n_transmitted; 1 under total internal reflection.  Also cos_t."""
    sin2_t = eta * eta * (1.0 - cos_i * cos_i)
    cos_t = np.sqrt(np.maximum(1.0 - sin2_t, 0.0))
    rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    return np.where(sin2_t >= 1.0, 1.0, 0.5 * (rs * rs + rp * rp)), cos_t


def glass_scatter(d, n, inside, u):
    """Reflect or refract unit directions d at the ball (outward normals n) with the Fresnel
    probability; u uniform in [0, 1).  (new directions, reflected?, inside afterwards)."""
    cos_o = -np.einsum("ij,ij->i", d, n)              # > 0 from outside
    nf = np.where((cos_o > 0)[:, None], n, -n)         # the normal on the incident side
    cos_i = np.abs(cos_o)
    eta = np.where(inside, IOR, 1.0 / IOR)
    f, cos_t = fresnel(cos_i, eta)
    refl = u < f
    r = d + 2.0 * cos_i[:, None] * nf
    t = eta[:, None] * d + (eta * cos_i - cos_t)[:, None] * nf
    out = np.where(refl[:, None], r, t)
    out /= np.linalg.norm(out, axis=1, keepdims=True)
    return out, refl, np.where(refl, inside, ~inside)


def _frame(n):
    """Two unit tangents completing each unit normal (rows) to an orthonormal frame (Duff et
    al.'s branchless construction)."""
    sign = np.where(n[:, 2] >= 0, 1.0, -1.0)
    a = -1.0 / (sign + n[:, 2])
    b = n[:, 0] * n[:, 1] * a
    t = np.stack([1.0 + sign * n[:, 0] ** 2 * a, sign * b, -sign * n[:, 0]], 1)
    bt = np.stack([b, sign + n[:, 1] ** 2 * a, -n[:, 1]], 1)
    return t, bt


def smith_lambda(cos, alpha):
    """Smith's Lambda of the isotropic GGX distribution (alpha: roughness squared) for
    directions at |cos| to the macro normal."""
    c2 = np.maximum(cos * cos, 1e-300)
    tan2 = np.maximum(1.0 - c2, 0.0) / c2
    return 0.5 * (np.sqrt(1.0 + alpha * alpha * tan2) - 1.0)


def ggx_visible_normals(wl, alpha, u1, u2):
    """Microfacet normals (local frame, z the macro normal) distributed as the GGX
    distribution's normals visible from the local directions wl (z > 0): Heitz 2018, "Sampling
    the GGX distribution of visible normals" (stretch, sample the projected hemisphere,
    unstretch)."""
    vh = np.stack([alpha * wl[:, 0], alpha * wl[:, 1], wl[:, 2]], 1)
    vh /= np.linalg.norm(vh, axis=1, keepdims=True)
    lensq = vh[:, 0] ** 2 + vh[:, 1] ** 2
    inv = np.where(lensq > 0, 1.0 / np.sqrt(np.maximum(lensq, 1e-300)), 0.0)
    t1 = np.where((lensq > 0)[:, None],
                  np.stack([-vh[:, 1] * inv, vh[:, 0] * inv, np.zeros_like(lensq)], 1),
                  np.array([1.0, 0.0, 0.0]))
    t2 = np.cross(vh, t1)
    r, phi = np.sqrt(u1), 2.0 * np.pi * u2
    p1, p2 = r * np.cos(phi), r * np.sin(phi)
    s = 0.5 * (1.0 + vh[:, 2])
    p2 = (1.0 - s) * np.sqrt(np.maximum(1.0 - p1 * p1, 0.0)) + s * p2
    nh = (p1[:, None] * t1 + p2[:, None] * t2
          + np.sqrt(np.maximum(1.0 - p1 * p1 - p2 * p2, 0.0))[:, None] * vh)
    m = np.stack([alpha * nh[:, 0], alpha * nh[:, 1], np.maximum(nh[:, 2], 0.0)], 1)
    return m / np.linalg.norm(m, axis=1, keepdims=True)


def rough_glass_scatter(d, n, inside, u, alpha, rng):
    """A rough dielectric (GGX of ``alpha``, Smith height-correlated shadowing, exact Fresnel,
    no multiple-scattering compensation) for photons along unit d at the ball (outward normals
    n): a microfacet normal visible from where the photon came from (Heitz 2018), then
    reflection or refraction about it with the Fresnel probability.  The photon's flux is
    multiplied by G2(i, o) / G1(i), the estimator's weight for flux (no eta^2: photons carry
    flux, not radiance); directions on the wrong side of the macro surface get weight 0.
    (new directions, reflected?, inside afterwards, weights)."""
    wi = -d
    cos_o = np.einsum("ij,ij->i", wi, n)
    nf = np.where((cos_o > 0)[:, None], n, -n)         # the normal on the incident side
    t, b = _frame(nf)
    wl = np.stack([np.einsum("ij,ij->i", wi, t), np.einsum("ij,ij->i", wi, b),
                   np.abs(cos_o)], 1)
    ml = ggx_visible_normals(wl, alpha, rng.random(d.shape[0]), rng.random(d.shape[0]))
    m = ml[:, :1] * t + ml[:, 1:2] * b + ml[:, 2:3] * nf
    cos_im = np.maximum(np.einsum("ij,ij->i", wi, m), 0.0)
    eta = np.where(inside, IOR, 1.0 / IOR)
    f, cos_t = fresnel(cos_im, eta)
    refl = u < f
    r = 2.0 * cos_im[:, None] * m - wi
    tr = -eta[:, None] * wi + (eta * cos_im - cos_t)[:, None] * m
    out = np.where(refl[:, None], r, tr)
    out /= np.linalg.norm(out, axis=1, keepdims=True)
    cos_out = np.einsum("ij,ij->i", out, nf)
    valid = np.where(refl, cos_out > 0, cos_out < 0)
    li, lo = smith_lambda(np.abs(cos_o), alpha), smith_lambda(np.abs(cos_out), alpha)
    weight = np.where(valid, (1.0 + li) / (1.0 + li + lo), 0.0)
    return out, refl, np.where(refl, inside, ~inside), weight


def cosine_dirs(n, rng):
    """Cosine-distributed unit directions about the unit normals n (rows)."""
    k = n.shape[0]
    u1, u2 = rng.random(k), rng.random(k)
    r, phi = np.sqrt(u1), 2.0 * np.pi * u2
    local = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(np.maximum(1.0 - u1, 0.0))], 1)
    t, bt = _frame(n)
    return local[:, :1] * t + local[:, 1:2] * bt + local[:, 2:3] * n


# --- the camera ------------------------------------------------------------------------------
def project(s: Setup, p):
    """Raster positions (px, py; pixels, y down), unit directions to the eye, distances and
    cosines at the camera of world points p; ``ok`` where p is in front, inside the clip range
    and close enough to the frame for the filter to reach a pixel."""
    v = p - s.eye
    local = v @ np.linalg.inv(s.axes).T      # the matrix's inverse: its float32 axes are not
                                             # exactly orthonormal
    depth = -local[:, 2]
    dist = np.linalg.norm(v, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        xc, yc = local[:, 0] / depth, local[:, 1] / depth
    x0, x1, y0, y1 = s.frame
    px = (xc - x0) / (x1 - x0) * s.width
    py = (y1 - yc) / (y1 - y0) * s.height
    r = s.filter_width
    ok = ((depth > s.clip[0]) & (depth < s.clip[1]) & (px > -r) & (px < s.width + r)
          & (py > -r) & (py < s.height + r))
    return px, py, -v / dist[:, None], dist, depth / dist, ok


def camera_rays(s: Setup, px, py):
    """Unit world directions of the camera rays through raster positions (px, py)."""
    x0, x1, y0, y1 = s.frame
    local = np.stack([x0 + px / s.width * (x1 - x0), y1 - py / s.height * (y1 - y0),
                      -np.ones_like(px)], -1)
    d = local @ s.axes.T
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def coverage(s: Setup, supersample: int = 8) -> np.ndarray:
    """(h, w) bool, rows top-down: the pixels whose filter footprint (every point within the
    filter's reach of the pixel centre, sampled ``supersample`` times per pixel) sees the floor
    or the wall directly; not the ball, not the void beyond the stage."""
    r, k = s.filter_width, supersample
    pad = math.ceil(r * k) + 1
    ix = np.arange(-pad, s.width * k + pad)
    iy = np.arange(-pad, s.height * k + pad)
    gx, gy = np.meshgrid((ix + 0.5) / k, (iy + 0.5) / k)
    d = camera_rays(s, gx.ravel(), gy.ravel())
    o = np.broadcast_to(s.eye, d.shape)
    no = np.zeros(d.shape[0], bool)
    _, hit = first_hit(o, d, no, no)
    bad = ~((hit == FLOOR_ID) | (hit == WALL_ID))
    return window_clear(bad.reshape(gy.shape), s, k, pad, 0.5)


def window_clear(bad, s, k: int, pad: int, offset: float) -> np.ndarray:
    """(h, w) bool, rows top-down: the pixels whose filter window (the points strictly within
    the filter's reach of the pixel centre) holds no ``bad`` point of a grid whose point (row,
    column) m lies at raster (m - pad + offset) / k, by an integral image."""
    r = s.filter_width
    cum = np.zeros((bad.shape[0] + 1, bad.shape[1] + 1), np.int64)
    cum[1:, 1:] = bad.astype(np.int64).cumsum(0).cumsum(1)

    def span(n):       # |(m - pad + offset) / k - (i + 1/2)| < r
        c = np.arange(n) + 0.5
        lo = np.floor((c - r) * k - offset).astype(np.int64) + 1 + pad
        hi = np.ceil((c + r) * k - offset).astype(np.int64) - 1 + pad
        return lo, hi + 1
    xl, xh = span(s.width)
    yl, yh = span(s.height)
    count = (cum[yh][:, xh] - cum[yl][:, xh] - cum[yh][:, xl] + cum[yl][:, xl])
    return count == 0


# --- the direct light, in closed form -------------------------------------------------------
def _direct_radiance(s: Setup, px, py):
    """The direct radiance (per watt of the light's power) the camera sees through raster
    positions (px, py), and what it sees there: 2 x (surface id + 1) + lit, whose changes
    between neighbouring positions mark the edges of the integrand (2 to 5: the floor or the
    wall)."""
    a = float(FLOOR[0])
    d = camera_rays(s, px, py)
    o = np.broadcast_to(s.eye, d.shape)
    no = np.zeros(d.shape[0], bool)
    t, hit = first_hit(o, d, no, no)
    depth = t * (d @ -s.axes[:, 2])
    stage = ((hit == FLOOR_ID) | (hit == WALL_ID)) & (depth > s.clip[0]) & (depth < s.clip[1])
    p, hd = s.eye + t[stage, None] * d[stage], hit[stage]
    normal = np.zeros_like(p)
    normal[hd == FLOOR_ID, 2] = 1.0
    normal[hd == WALL_ID, 1] = -1.0
    p[hd == FLOOR_ID, 2] = 0.0                      # exactly on the surface
    p[hd == WALL_ID, 1] = WALL_Y
    # the side the camera sees (both sides are Lambertian)
    normal *= np.where(np.einsum("ij,ij->i", d[stage], normal) < 0, 1.0, -1.0)[:, None]
    to_light = s.light - p
    dist = np.linalg.norm(to_light, axis=1)
    u = to_light / dist[:, None]
    cos_l = np.einsum("ij,ij->i", u, normal)
    # only the ball can shadow: the light stands above the floor and in front of the wall, so
    # neither plane meets the segment from a point of the other to it
    lit = (cos_l > 0) & ~_ball_blocks(p, u, dist)
    radiance = np.zeros(d.shape[0])
    radiance[stage] = np.where(lit, a / np.pi / (4.0 * np.pi) * cos_l / dist ** 2, 0.0)
    kind = 2 * (hit + 1)
    kind[stage] += lit
    return radiance, kind


def direct_light(s: Setup, per_pixel: int = DIRECT_GRID, refine: int = DIRECT_REFINE,
                 chunk: int = 1 << 18) -> np.ndarray:
    """(h * w) rows top-down, per watt of the light's power: the direct light of the floor and
    the wall as the camera sees them, L = albedo / pi x I cos / d^2 (I = 1 / (4 pi) W/sr per
    watt), 0 where the ball is on the segment to the light (the glass is opaque to it, as to
    Cycles' shadow rays: the light through it is the caustic, which light tracing renders) or
    where a camera ray sees the ball or nothing.  Each pixel integrates it over the pixel
    filter on a fixed grid of ``per_pixel`` x ``per_pixel`` cells per pixel (weights f at the
    cell's centre / per_pixel^2: the splat's normalisation), so the image has no noise.  A cell
    takes L at its centre, or where L jumps on the stage (the shadow's edge, the floor's corner
    with the wall: what a cell or a neighbour sees differs from the next cell's) the mean of
    ``refine`` x ``refine`` points in it: a grid's error at a jump only falls as 1 /
    points per axis, and most where the edge runs along the grid
    (tests/test_exact_caustic.py bounds what is left).  ``chunk`` points at a time."""
    r, k = s.filter_width, per_pixel
    pad = math.ceil(r * k)
    gx = (np.arange(-pad, s.width * k + pad) + 0.5) / k
    gy = (np.arange(-pad, s.height * k + pad) + 0.5) / k
    nx = gx.size
    radiance = np.empty(gy.size * nx)
    kind = np.empty(gy.size * nx, np.int64)
    for i0 in range(0, radiance.size, chunk):
        i = np.arange(i0, min(i0 + chunk, radiance.size))
        radiance[i], kind[i] = _direct_radiance(s, gx[i % nx], gy[i // nx])
    radiance, kind = radiance.reshape(gy.size, nx), kind.reshape(gy.size, nx)
    # the cells on either side of a change, and their neighbours: an edge that only clips a
    # cell's corner changes nothing between centres next to it but does between its neighbours.
    # Only changes on the stage: pixels whose filter sees the ball or the void are not covered
    # (light tracing does not render them), so their edges are left at the grid's precision
    on_stage = (kind >= 2) & (kind <= 5)
    jump = np.zeros(kind.shape, bool)
    dx = (kind[:, 1:] != kind[:, :-1]) & on_stage[:, 1:] & on_stage[:, :-1]
    jump[:, 1:] |= dx
    jump[:, :-1] |= dx
    dy = (kind[1:] != kind[:-1]) & on_stage[1:] & on_stage[:-1]
    jump[1:] |= dy
    jump[:-1] |= dy
    near = jump.copy()
    near[1:] |= jump[:-1]
    near[:-1] |= jump[1:]
    grown = near.copy()
    grown[:, 1:] |= near[:, :-1]
    grown[:, :-1] |= near[:, 1:]
    cells = np.flatnonzero(grown)
    sub = ((np.arange(refine) + 0.5) / refine - 0.5) / k
    ox, oy = (a.ravel() for a in np.meshgrid(sub, sub))
    per = max(chunk // ox.size, 1)
    flat = radiance.ravel()
    for c0 in range(0, cells.size, per):
        c = cells[c0:c0 + per]
        px = (gx[c % nx][:, None] + ox).ravel()
        py = (gy[c // nx][:, None] + oy).ravel()
        flat[c] = _direct_radiance(s, px, py)[0].reshape(c.size, ox.size).mean(axis=1)
    # pixel i's weight of the grid column at x: f(x - i - 1/2) / k (the same for rows), so a
    # pixel is sum f(x) f(y) L / k^2: two matrix products instead of a splat per point
    fx = filter_1d(gx[None, :] - (np.arange(s.width)[:, None] + 0.5), r) / k
    fy = filter_1d(gy[None, :] - (np.arange(s.height)[:, None] + 0.5), r) / k
    return (fy @ radiance @ fx.T).ravel()


# --- light tracing ---------------------------------------------------------------------------
def _cone_dirs(axis, cos_max, k, rng):
    """k unit directions uniform in the cone of half-angle acos(cos_max) about ``axis``."""
    cz = 1.0 - rng.random(k) * (1.0 - cos_max)
    sz = np.sqrt(np.maximum(1.0 - cz * cz, 0.0))
    phi = 2.0 * np.pi * rng.random(k)
    a = np.asarray(axis, float)
    t = np.cross(a, [0.0, 0.0, 1.0] if abs(a[2]) < 0.9 else [1.0, 0.0, 0.0])
    t /= np.linalg.norm(t)
    b = np.cross(a, t)
    return (sz * np.cos(phi))[:, None] * t + (sz * np.sin(phi))[:, None] * b + cz[:, None] * a


def emit(s: Setup, n: int, rng, stratified: bool = True):
    """n photons from the light: (origins, unit directions, weights), per watt of the light's
    power: a weight is intensity / (pdf of the direction x the photon's share of n), so that the
    mean over the n photons of a weighted quantity estimates its integral over the light's
    directions.  Unstratified: uniform over the whole sphere of directions."""
    intensity = 1.0 / (4.0 * np.pi)                    # W/sr per watt (Cycles' point light)
    o = np.broadcast_to(s.light, (n, 3))
    if not stratified:
        z = 1.0 - 2.0 * rng.random(n)
        phi = 2.0 * np.pi * rng.random(n)
        r = np.sqrt(np.maximum(1.0 - z * z, 0.0))
        d = np.stack([r * np.cos(phi), r * np.sin(phi), z], 1)
        return o, d, np.full(n, intensity * 4.0 * np.pi)
    if s.light[0] > -FLOOR_HALF:
        raise ValueError("stratified emission needs all geometry on the light's +x side")
    to_ball = np.asarray(BALL[0], float) - s.light
    dist = np.linalg.norm(to_ball)
    axis, cos_max = to_ball / dist, math.sqrt(1.0 - (BALL[1] / dist) ** 2)
    omega_cone = 2.0 * np.pi * (1.0 - cos_max)
    n_cone = round(BALL_SHARE * n)
    n_rest = n - n_cone
    d_cone = _cone_dirs(axis, cos_max, n_cone, rng)
    # the rest: uniform over the half space x > 0; those that fall in the cone are the cone's
    # stratum's, weight 0 here
    x = rng.random(n_rest)
    phi = 2.0 * np.pi * rng.random(n_rest)
    r = np.sqrt(np.maximum(1.0 - x * x, 0.0))
    d_rest = np.stack([x, r * np.cos(phi), r * np.sin(phi)], 1)
    in_cone = d_rest @ axis > cos_max
    w_rest = np.where(in_cone, 0.0, intensity * 2.0 * np.pi * n / n_rest)
    w = np.concatenate([np.full(n_cone, intensity * omega_cone * n / max(n_cone, 1)), w_rest])
    return o, np.concatenate([d_cone, d_rest]), w


def trace(s: Setup, n: int, rng, acc: np.ndarray, stratified: bool = True,
          direct: bool = False) -> dict:
    """Trace n photons (per watt of the light's power) and add their connections to the camera
    to ``acc`` (h * w).  ``direct``: also where a photon first lands, which is the direct
    light (otherwise ``direct_light``'s); those photons bounce on all the same.  Counts of what
    happened."""
    a = float(FLOOR[0])          # grey (setup_of checks): one channel, times the light's RGB
    o, d, w = emit(s, n, rng, stratified)
    keep = w > 0
    o, d, w = o[keep], d[keep], w[keep]
    k = o.shape[0]
    inside = np.zeros(k, bool)
    left_ball = np.zeros(k, bool)
    counts = np.zeros((k, 3), np.int64)                 # diffuse, glossy, transmission
    limits = np.array([s.diffuse_bounces, s.glossy_bounces, s.transmission_bounces])
    stats = {"photons": n, "connections": 0, "ball_hits": 0}
    inv_area = 1.0 / s.pixel_area
    for vertex in range(s.max_bounces + 1):
        if o.shape[0] == 0:
            break
        t, hit = first_hit(o, d, inside, left_ball)
        alive = hit >= 0
        o, d, w, t, hit = o[alive], d[alive], w[alive], t[alive], hit[alive]
        inside, counts = inside[alive], counts[alive]
        p = o + t[:, None] * d
        diffuse = hit != BALL_ID
        # this vertex's kind counts from the photon's vertex 1 on (module docstring)
        first = vertex == 0

        # -- the floor and the wall: connect to the camera, then bounce diffusely
        pd, dd, wd, cd = p[diffuse], d[diffuse], w[diffuse], counts[diffuse]
        hd = hit[diffuse]
        if not first:
            cd = cd + np.array([1, 0, 0])
        within = (cd <= limits).all(axis=1)
        normal = np.zeros_like(pd)
        normal[hd == FLOOR_ID, 2] = 1.0
        normal[hd == WALL_ID, 1] = -1.0
        pd[hd == FLOOR_ID, 2] = 0.0                    # exactly on the surface
        pd[hd == WALL_ID, 1] = WALL_Y
        facing = np.where((np.einsum("ij,ij->i", dd, normal) < 0)[:, None], normal, -normal)
        # a diffuse hit at vertex 0 came straight from the light, past the ball: the direct
        # light, in closed form unless asked for here
        if direct or not first:
            px, py, to_eye, dist, cos_cam, ok = project(s, pd)
            cos_surf = np.einsum("ij,ij->i", to_eye, facing)
            ok &= within & (cos_surf > 0)
            # only the ball can hide a point of the stage from the camera, which stands in
            # front of the wall and above the floor
            ok[ok] &= ~_ball_blocks(pd[ok], to_eye[ok], dist[ok])
            value = (wd[ok] * (a / np.pi) * cos_surf[ok] * inv_area
                     / (cos_cam[ok] ** 3 * dist[ok] ** 2))
            splat(acc, s, px[ok], py[ok], value)
            stats["connections"] += int(ok.sum())
        go = within & (rng.random(pd.shape[0]) < a)     # Russian roulette: survive = albedo
        od, new_d = pd[go], cosine_dirs(facing[go], rng)
        wd, cd = wd[go], cd[go]

        # -- the glass: reflect or refract
        g = ~diffuse
        stats["ball_hits"] += int(g.sum())
        pg, dg, wg, cg, ig = p[g], d[g], w[g], counts[g], inside[g]
        n_out = (pg - np.asarray(BALL[0], float)) / BALL[1]
        if s.roughness > 0.0:
            new_g, refl, ig2, wgl = rough_glass_scatter(dg, n_out, ig, rng.random(pg.shape[0]),
                                                        s.roughness ** 2, rng)
            wg = wg * wgl
        else:
            new_g, refl, ig2 = glass_scatter(dg, n_out, ig, rng.random(pg.shape[0]))
        if not first:
            cg = cg + np.where(refl[:, None], [0, 1, 0], [0, 0, 1])
        stay = (cg <= limits).all(axis=1) & (wg > 0)
        pg = pg[stay]
        pg_dir, wg, cg, ig2 = new_g[stay], wg[stay], cg[stay], ig2[stay]

        o = np.concatenate([od, pg])
        d = np.concatenate([new_d, pg_dir])
        w = np.concatenate([wd, wg])
        counts = np.concatenate([cd, cg])
        inside = np.concatenate([np.zeros(od.shape[0], bool), ig2])
        left_ball = np.concatenate([np.zeros(od.shape[0], bool), np.ones(pg.shape[0], bool)])
    return stats


def render(scene, photons: int = 0, seed: int = 0, batch: int = BATCH, seconds: float = 0.0,
           max_bounces: int | None = None, stratified: bool = True, direct: str = "closed"):
    """Render the ``point_caustic`` bpy scene: the direct light in closed form
    (``direct_light``; ``direct="traced"``: light-traced as the rest) and the rest light-traced
    by ``photons`` photons (in batches of ``batch``), or with ``seconds`` whole batches until
    that time (the closed form's included) is spent.  (image (h, w, 3) float32 top-down,
    coverage (h, w) bool top-down, info)."""
    if direct not in ("closed", "traced"):
        raise ValueError(f"direct is 'closed' or 'traced', not {direct!r}")
    if photons <= 0 and seconds <= 0:
        raise ValueError("give a photon count or a time")
    s = setup_of(scene, max_bounces)
    rng = np.random.default_rng(seed)
    acc = np.zeros(s.width * s.height)
    t0 = time.perf_counter()
    closed = direct_light(s) if direct == "closed" else np.zeros_like(acc)
    direct_seconds = time.perf_counter() - t0
    done, stats = 0, {"connections": 0, "ball_hits": 0}
    while True:
        n = batch if seconds > 0 else min(batch, photons - done)
        st = trace(s, n, rng, acc, stratified, direct == "traced")
        done += n
        for key in stats:
            stats[key] += st[key]
        if (seconds > 0 and time.perf_counter() - t0 >= seconds) or \
                (seconds <= 0 and done >= photons):
            break
    acc = acc / done + closed
    image = (acc.reshape(s.height, s.width)[..., None] * s.power * s.film_exposure)
    image = image.astype(np.float32)
    info = {"photons": done, "batches": -(-done // batch), "seconds": time.perf_counter() - t0,
            "max_bounces": s.max_bounces, "direct": direct, "direct_seconds": direct_seconds,
            **stats}
    return image, coverage(s), info
