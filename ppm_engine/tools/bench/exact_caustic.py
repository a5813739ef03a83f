"""An exact-geometry reference for the benchmark's ``point_caustic``, ``rough_caustic`` and
``far_caustic`` scenes in NumPy, on the scene as ppm_engine/blender/scenes/caustics.py defines it
(a true sphere, two finite planes, a point light; the ball and the light where the bpy scene has
them: exact_caustic_scene.setup_of): the direct light in closed form, the rest by light tracing.
It shares no code with this engine's estimators (no export, kernels, film or light tracer): the
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

Emission is stratified (exactly, not approximately): no geometry lies at x < -2 and the light
stands at x <= -2 (setup_of refuses it elsewhere), so photons leave into x > 0 only; a share of
them (``BALL_SHARE``) go uniformly into the cone the ball subtends, which makes the caustic much
less noisy, and the rest uniformly into the half space less that cone; each carries its stratum's
flux (intensity x solid angle / count). Strata are unbiased for any integrand over the directions,
so for the light tracer's share of the light with the direct light taken out as well
(tests/test_exact_caustic.py checks both). The cone (point_caustic's: 0.8 % of the half space's
solid angle; far_caustic's 1 %) took a quarter of the photons while light tracing rendered the
direct light; without it 5 % is the better share.  A cone photon costs about 3.7 times one of the
rest (its vertices on the glass, and a splat where it lands, which the rest no longer make), so 5 %
traces 1.5 times the photons a second; per photon a quarter is 10 % less noisy over the caustic and
12 % more over the image, so at equal time 5 % leaves 27 % less noise over the image and 9 % less
over the caustic (128 x 128, 2^22 photons per render, five seeds).

``render`` returns the image (RGB, rows top-down, as the bench's EXRs read), the coverage (the
pixels light tracing renders: those whose filter footprint sees only the floor or the wall
directly, not the ball and not the void) and an info dict.

This module has the light transport (the direct light, emission, tracing, ``render``); the
scene's geometry and its Setup from bpy are exact_caustic_scene.py's, the camera and the pixel
filter exact_film.py's, the glass's scattering and the direction sampling exact_optics.py's
(the last two shared with exact_pool.py).
"""
from __future__ import annotations

import math
import time

import numpy as np

from ppm_engine.blender.scenes.caustics import FLOOR
from ppm_engine.tools.bench.exact_caustic_camera import TEXTURE_BINS, BallView, Textures
from ppm_engine.tools.bench.exact_caustic_scene import (
    BALL_ID,
    FLOOR_HALF,
    FLOOR_ID,
    WALL_ID,
    WALL_Y,
    Setup,
    ball_blocks,
    coverage,
    direct_irradiance,
    first_hit,
    setup_of,
    stage_normals,
)
from ppm_engine.tools.bench.exact_film import camera_rays, filtered, jump_cells, project, splat
from ppm_engine.tools.bench.exact_optics import (
    cone_dirs,
    cosine_dirs,
    glass_scatter,
    rough_glass_scatter,
)

BALL_SHARE = 0.05                # photons sent into the cone of the ball (see the docstring)
BATCH = 1 << 18
DIRECT_GRID = 8                  # the direct light's cells per pixel and axis
DIRECT_REFINE = 16               # points per cell and axis where the direct light jumps


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
    t, hit = first_hit(o, d, no, no, s.ball)
    depth = t * (d @ -s.axes[:, 2])
    stage = ((hit == FLOOR_ID) | (hit == WALL_ID)) & (depth > s.clip[0]) & (depth < s.clip[1])
    p, normal = stage_normals(s.eye + t[stage, None] * d[stage], hit[stage])
    # the side the camera sees (both sides are Lambertian)
    normal *= np.where(np.einsum("ij,ij->i", d[stage], normal) < 0, 1.0, -1.0)[:, None]
    irradiance, lit = direct_irradiance(s, p, normal)
    radiance = np.zeros(d.shape[0])
    radiance[stage] = a / np.pi * irradiance
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
    takes L at its centre, or where L jumps (the shadow's edge, the floor's corner with the
    wall, the ball's silhouette, the stage's edges on the void: what a cell or a neighbour sees
    differs from the next cell's) the mean of
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
    # every change refined: the ball's silhouette and the stage's edges too, since every pixel
    # is rendered (exact_caustic_camera.py renders what the ball's points see)
    cells = jump_cells(kind)
    sub = ((np.arange(refine) + 0.5) / refine - 0.5) / k
    ox, oy = (a.ravel() for a in np.meshgrid(sub, sub))
    per = max(chunk // ox.size, 1)
    flat = radiance.ravel()
    for c0 in range(0, cells.size, per):
        c = cells[c0:c0 + per]
        px = (gx[c % nx][:, None] + ox).ravel()
        py = (gy[c // nx][:, None] + oy).ravel()
        flat[c] = _direct_radiance(s, px, py)[0].reshape(c.size, ox.size).mean(axis=1)
    return filtered(s, radiance, gx, gy, k)
# --- light tracing ---------------------------------------------------------------------------
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
    to_ball = s.ball_center - s.light
    dist = np.linalg.norm(to_ball)
    axis, cos_max = to_ball / dist, math.sqrt(1.0 - (s.ball_radius / dist) ** 2)
    omega_cone = 2.0 * np.pi * (1.0 - cos_max)
    n_cone = round(BALL_SHARE * n)
    n_rest = n - n_cone
    d_cone = cone_dirs(axis, cos_max, n_cone, rng)
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
          direct: bool = False, tex: Textures | None = None) -> dict:
    """Trace n photons (per watt of the light's power) and add their connections to the camera
    to ``acc`` (h * w), and where they land to the irradiance textures ``tex``, if any (what
    the camera sees through the ball: exact_caustic_camera.py).  ``direct``: also where a
    photon first lands, which is the direct light (otherwise ``direct_light``'s); those photons
    bounce on all the same.  Counts of what happened."""
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
        t, hit = first_hit(o, d, inside, left_ball, s.ball)
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
        front = np.einsum("ij,ij->i", dd, normal) < 0
        facing = np.where(front[:, None], normal, -normal)
        # a diffuse hit at vertex 0 came straight from the light, past the ball: the direct
        # light, in closed form unless asked for here
        if tex is not None and (direct or not first):
            tex.deposit(pd, hd, front & within, wd, vertex, cd)
        if direct or not first:
            px, py, to_eye, dist, cos_cam, ok = project(s, pd)
            cos_surf = np.einsum("ij,ij->i", to_eye, facing)
            ok &= within & (cos_surf > 0)
            # only the ball can hide a point of the stage from the camera, which stands in
            # front of the wall and above the floor
            ok[ok] &= ~ball_blocks(pd[ok], to_eye[ok], dist[ok], s.ball)
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
        n_out = (pg - s.ball_center) / s.ball_radius
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
    if tex is not None:
        tex.flush(n)
    return stats


def render(scene, photons: int = 0, seed: int = 0, batch: int = BATCH, seconds: float = 0.0,
           max_bounces: int | None = None, stratified: bool = True, direct: str = "closed",
           ball: bool = True, texture_bins: int = TEXTURE_BINS, ball_grid: int | None = None):
    """Render a ``point_caustic``, ``rough_caustic`` or ``far_caustic`` bpy scene (its ball and
    light read from it: exact_caustic_scene.setup_of): the direct light in closed form
    (``direct_light``; ``direct="traced"``: light-traced as the rest), the rest light-traced
    by ``photons`` photons (in batches of ``batch``), or with ``seconds`` whole batches until
    that time (the closed form's and the ball's chains included) is spent, and (``ball``) what
    the pixels that see the ball see through it and in it (exact_caustic_camera.BallView: its
    chains traced before the photons, the photons' irradiance in textures of ``texture_bins``
    bins per metre, ``ball_grid`` points per pixel and axis).  (image (h, w, 3) float32
    top-down, coverage (h, w) bool top-down: every pixel, or without ``ball`` those that see
    only the floor and the wall, info)."""
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
    tex = view = None
    if ball:
        tex = Textures(s, texture_bins)
        # the chains' own random numbers (rough glass), apart from the photons'
        extra = {} if ball_grid is None else {"per_pixel": ball_grid}
        view = BallView(s, tex, np.random.default_rng([seed, 1]), direct == "closed", **extra)
    ball_seconds = time.perf_counter() - t0 - direct_seconds
    done, stats = 0, {"connections": 0, "ball_hits": 0}
    while True:
        n = batch if seconds > 0 else min(batch, photons - done)
        st = trace(s, n, rng, acc, stratified, direct == "traced", tex)
        done += n
        for key in stats:
            stats[key] += st[key]
        if (seconds > 0 and time.perf_counter() - t0 >= seconds) or \
                (seconds <= 0 and done >= photons):
            break
    acc = acc / done + closed
    if view is not None:
        acc = acc + view.image()
    image = (acc.reshape(s.height, s.width)[..., None] * s.power * s.film_exposure)
    image = image.astype(np.float32)
    info = {"photons": done, "batches": -(-done // batch), "seconds": time.perf_counter() - t0,
            "max_bounces": s.max_bounces, "direct": direct, "direct_seconds": direct_seconds,
            "ball": ball, "ball_seconds": ball_seconds,
            "ball_points": view.points if view is not None else 0,
            "texture_bins": texture_bins if ball else 0, **stats}
    cover = np.ones((s.height, s.width), bool) if ball else coverage(s)
    return image, cover, info
