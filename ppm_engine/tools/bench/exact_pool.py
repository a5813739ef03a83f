"""An exact-geometry reference for the benchmark's ``pool_caustic``
(ppm_engine/blender/scenes/pool.py) in NumPy: the water's true height field (the engine sees it
meshed), the floor, the sun, the pinhole camera.  It shares no code with this engine's estimators
(no export, kernels, film or light tracer), so it stays independent of the engine's light tracing
and photons.

What no camera-side connection can do here is connect a floor point to the camera through the
waves: the refracted path from the camera to a given floor point is a root of a non-linear
system, with one, two or three solutions where the waves fold the view.  So the camera's side is
mapped once, forwards, and inverted by geometry (``CameraMap``):

- camera rays through a grid of ``SUPERSAMPLE`` x ``SUPERSAMPLE`` points per pixel (and over the
  pixel filter's reach beyond the frame) are traced through the water to the floor; each grid
  triangle maps to a floor triangle;
- a photon that lands on the floor at x is seen at every raster position p whose ray reaches x:
  every grid triangle whose floor triangle contains x (found through a uniform grid of bins),
  at p interpolated in it.  Its weight there is the floor's radiance towards the camera times
  |dp/dx| (the triangle's raster area over its floor area): the pixel integral of radiance,
  written over the floor instead of the film.  Folds (several p for one x) are counted in full;
  the map is exact at the grid's points and linear between them (``SUPERSAMPLE`` 6 and 12 agree
  within the reference's noise).

The light transport, as Cycles renders it with the bench's settings:

- the sun: Cycles' (its strength the irradiance perpendicular to its rays, its directions
  uniform within the cone of half its angle); photons leave from a horizontal rectangle above
  the water that every ray to the floor crosses, each with its share of the flux through it;
- the water's surface reflects and refracts with the exact unpolarised Fresnel factor (clear
  glass of IOR 1.33, Principled Transmission 1): a sun photon enters with its flux times
  (1 - F) (what the surface reflects goes to the black sky); under the surface a photon going
  up is reflected with its flux times F (total internal reflection beyond 48.8 degrees) and
  what leaves goes to the sky; the camera sees the floor through the surface with radiance
  times (1 - F) / IOR^2 (radiance leaving a denser medium);
- the floor is Lambertian (``pool.FLOOR``, per channel): every photon landing on it is splatted
  (through Cycles' Blackman-Harris filter, exact_film.splat) and bounces on, cosine-
  distributed, its flux times the albedo;
- bounce limits are Cycles' Light Paths: a splat at the photon's vertex j (0 = its refraction
  into the water) is the Cycles path camera, refraction into the water, the photon's vertices
  j..0 in reverse, then the sun (hit by the ray leaving vertex 0): its scattering vertices per
  kind (diffuse: the floor; glossy: the surface's reflection; transmission: its refractions)
  and in all are held to the scene's limits.  With 12 of each (the scene's) the fifth floor
  vertex is the last.

Sunlight that reaches the floor past the water's edge is refused (``render`` raises): that path
(then reflected down by the water's underside) came out 2-3 % of the image dimmer here than in
Cycles and this engine, which agreed, and was not resolved (docs/history/benchmarks-notebook.md, the
pool).  The bench's pool has none: its floor is lit only through the water.

``render`` returns the image (RGB, rows top-down, as the bench's EXRs read), the coverage (the
pixels whose filter footprint sees only the floor through the water) and what it did.

This module has the Setup from bpy and the light's side (emission, tracing, ``render``); the
height field and the crossings are exact_pool_water.py's, the camera map exact_pool_camera.py's,
the camera, the pixel filter and the scattering exact_film.py's and exact_optics.py's.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ppm_engine.blender.scenes import pool
from ppm_engine.tools.bench.exact_film import CameraSetup, camera_fields, splat
from ppm_engine.tools.bench.exact_optics import cone_dirs, cosine_dirs, fresnel
from ppm_engine.tools.bench.exact_pool_camera import SUPERSAMPLE, CameraMap
from ppm_engine.tools.bench.exact_pool_water import bounds, crossing, normal, refract_in

BATCH = 1 << 17
NEAR_SHARE = 0.75               # photons starting where the light to the floor in view crosses
NEAR_MARGIN = 0.3               # m, around that rectangle


@dataclass
class Setup(CameraSetup):
    """What the tracer needs of the bpy scene (exact_film's camera and filter fields)."""
    sun: np.ndarray                # unit direction towards the sun
    cos_half: float                # cosine of half the sun's angle
    irradiance: np.ndarray         # RGB W/m^2 (colour x strength x 2^exposure)
    albedo: np.ndarray             # RGB, the floor's
    max_bounces: int
    diffuse_bounces: int
    glossy_bounces: int
    transmission_bounces: int
    waves: tuple


def _principled_constant(obj, want: dict) -> dict:
    mat = obj.active_material
    nodes = mat.node_tree.nodes if mat is not None and mat.node_tree is not None else []
    p = next((n for n in nodes if n.bl_idname == "ShaderNodeBsdfPrincipled"), None)
    if p is None:
        raise ValueError(f"the exact pool needs a Principled BSDF on '{obj.name}'")
    linked = [k for k in want if p.inputs[k].is_linked]
    if linked:
        raise ValueError(f"the exact pool needs constant inputs on '{obj.name}', not {linked}")
    return {k: p.inputs[k].default_value for k in want}


def setup_of(scene, waves=pool.WAVES) -> Setup:
    """The camera, film, sun, materials and bounce limits of a ``pool_caustic`` bpy scene,
    checked against the module's geometry (``waves`` () for flat water)."""
    scene.view_layers[0].update()
    camera = camera_fields(scene)
    c = scene.cycles
    lights = [o for o in scene.objects if o.type == 'LIGHT' and not o.hide_render]
    if len(lights) != 1 or lights[0].data.type != 'SUN':
        raise ValueError("the exact pool renders one sun lamp")
    sun = lights[0]
    towards = np.array(sun.matrix_world.to_3x3().col[2], float)
    towards /= np.linalg.norm(towards)
    if not np.allclose(towards, pool.sun_direction(), atol=1e-5):
        raise ValueError("the sun does not shine from pool.sun_direction()")
    irradiance = (np.array(sun.data.color, float) * sun.data.energy
                  * 2.0 ** getattr(sun.data, "exposure", 0.0))
    water = scene.objects.get("Water")
    floor = scene.objects.get("Floor")
    if water is None or floor is None:
        raise ValueError("the exact pool needs the objects 'Water' and 'Floor'")
    g = _principled_constant(water, {"Transmission Weight": 1, "IOR": 1, "Roughness": 1,
                                     "Base Color": 1})
    if (g["Transmission Weight"] != 1.0 or abs(g["IOR"] - pool.WATER_IOR) > 1e-6
            or g["Roughness"] != 0.0 or tuple(g["Base Color"])[:3] != (1.0, 1.0, 1.0)):
        raise ValueError(f"the exact pool models clear water of IOR {pool.WATER_IOR}")
    f = _principled_constant(floor, {"Base Color": 1, "Metallic": 1, "Roughness": 1,
                                     "Specular IOR Level": 1, "Transmission Weight": 1})
    if (f["Metallic"] != 0.0 or f["Roughness"] != 1.0 or f["Specular IOR Level"] != 0.0
            or f["Transmission Weight"] != 0.0):
        raise ValueError("the exact pool models a Lambertian floor")
    # the water's mesh must be the height field the reference traces
    co = np.empty(3 * len(water.data.vertices))
    water.data.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)[:: max(1, len(water.data.vertices) // 997)]
    mw = np.array(water.matrix_world, float)
    co = co @ mw[:3, :3].T + mw[:3, 3]
    if np.abs(co[:, 2] - pool.height(co[:, 0], co[:, 1], waves)[0]).max() > 1e-5:
        raise ValueError("the water's mesh is not the height field of the given waves")
    return Setup(**camera,
                 sun=towards, cos_half=math.cos(0.5 * sun.data.angle), irradiance=irradiance,
                 albedo=np.array(f["Base Color"][:3], float), max_bounces=int(c.max_bounces),
                 diffuse_bounces=int(c.diffuse_bounces), glossy_bounces=int(c.glossy_bounces),
                 transmission_bounces=int(c.transmission_bounces), waves=tuple(waves))

# --- the light's side ------------------------------------------------------------------------
def emit(s: Setup, n: int, rng, near):
    """n sun photons: (origins on a horizontal rectangle above the water, unit directions,
    flux per photon (n,) per unit of the sun's irradiance).  Stratified: ``NEAR_SHARE`` of them
    start in ``near`` ((lo, hi) corners), where the light to the floor the camera sees crosses,
    the rest over the whole rectangle less ``near``; each carries its stratum's share."""
    amp, _ = bounds(s.waves)
    d = -cone_dirs(s.sun, s.cos_half, n, rng)
    top = amp + 1e-3
    # every ray to the floor crosses z = top within the floor shifted back along the unrefracted
    # direction and the floor itself (refraction only steepens a ray)
    shift = -(pool.DEPTH + top) * s.sun[:2] / s.sun[2]
    margin = 0.05 + (pool.DEPTH + top) * math.tan(math.acos(s.cos_half)) * 2.0
    f = pool.FLOOR_HALF
    lo = np.minimum(-f, -f - shift) - margin
    hi = np.maximum(f, f - shift) + margin
    n_lo, n_hi = np.maximum(near[0], lo), np.minimum(near[1], hi)
    area, area_near = float(np.prod(hi - lo)), float(np.prod(n_hi - n_lo))
    k = round(NEAR_SHARE * n)
    xy = np.concatenate([n_lo + rng.random((k, 2)) * (n_hi - n_lo),
                         lo + rng.random((n - k, 2)) * (hi - lo)])
    inside = ((xy[k:] >= n_lo) & (xy[k:] <= n_hi)).all(1) & (k > 0)
    share = np.concatenate([np.full(k, area_near / max(k, 1)),
                            np.where(inside, 0.0, area / max(n - k, 1))])
    o = np.concatenate([xy, np.full((n, 1), top)], 1)
    return o, d, -d[:, 2] * share


def near_rectangle(s: Setup, cmap: CameraMap):
    """Where on the photons' starting plane the sun's light to the floor the camera sees
    crosses (with a margin for the waves' deflection): the flat water's refraction traced back
    from the corners of the floor the camera map reaches."""
    amp, slope = bounds(s.waves)
    top = amp + 1e-3
    d = -s.sun
    dt, _ = refract_in(d[None], np.array([[0.0, 0.0, 1.0]]), pool.WATER_IOR)
    back = top * d[:2] / -d[2] + pool.DEPTH * dt[0, :2] / -dt[0, 2]
    margin = NEAR_MARGIN + 2.0 * slope * pool.DEPTH
    return cmap.floor_lo - back - margin, cmap.floor_hi - back + margin


def trace(s: Setup, cmap: CameraMap, n: int, rng, acc: np.ndarray) -> dict:
    """Trace n sun photons and splat every floor vertex into ``acc`` (3, h * w), per unit of
    the sun's irradiance.  Counts of what happened."""
    o, d, flux = emit(s, n, rng, near_rectangle(s, cmap))
    w = flux[:, None] * np.ones(3)
    stats = {"photons": n, "entered": 0, "floor_hits": 0, "splats": 0, "beside_water": 0}
    t = crossing(o, d, np.zeros(n, bool), s.waves, np.zeros(n, bool))
    hit = np.isfinite(t)
    stats["entered"] = int(hit.sum())
    # photons that miss the water: those landing on the floor past its edge are counted (render
    # refuses them), the rest meet nothing
    miss = ~hit
    x = o[miss, :2] + ((-pool.DEPTH - o[miss, 2]) / d[miss, 2])[:, None] * d[miss, :2]
    stats["beside_water"] = int((np.abs(x) <= pool.FLOOR_HALF).all(1).sum())
    o, d, w, t = o[hit], d[hit], w[hit], t[hit]
    o = o + t[:, None] * d
    nrm = normal(o[:, 0], o[:, 1], s.waves)
    d, tr = refract_in(d, nrm, pool.WATER_IOR)
    w *= tr[:, None]
    on_surface = np.ones(len(o), bool)
    # per photon: counts of its vertices so far per kind (diffuse, glossy, transmission); its
    # vertex 0 is the refraction into the water
    kinds = np.zeros((len(o), 3), np.int64)
    kinds[:, 2] = 1
    limits = np.array([s.diffuse_bounces, s.glossy_bounces, s.transmission_bounces])
    a = s.albedo / np.pi
    while o.shape[0]:
        # the next event: the surface (from below) or, going down, the floor
        t = crossing(o, d, np.ones(len(o), bool), s.waves, on_surface)
        with np.errstate(divide="ignore", invalid="ignore"):
            tf = np.where(d[:, 2] < 0, (-pool.DEPTH - o[:, 2]) / d[:, 2], np.inf)
        at_floor = np.isfinite(tf) & (tf < t)
        at_surf = np.isfinite(t) & ~at_floor
        p = o + np.where(at_floor, tf, np.where(at_surf, t, 0.0))[:, None] * d
        at_floor &= (np.abs(p[:, 0]) <= pool.FLOOR_HALF) & (np.abs(p[:, 1]) <= pool.FLOOR_HALF)
        # the floor: splat where the camera path it closes is within the limits
        f = np.nonzero(at_floor)[0]
        stats["floor_hits"] += f.size
        cam = kinds[f] + np.array([1, 0, 1])                 # this vertex, the camera's entry
        total = cam.sum(1)
        ok = (total <= s.max_bounces) & (cam <= limits).all(1)
        g = f[ok]
        if g.size:
            rep, px, py, wt = cmap.locate(p[g, :2])
            stats["splats"] += rep.size
            for ch in range(3):
                splat(acc[ch], s, px, py, w[g[rep], ch] * a[ch] * wt)
        # bounce on from the floor: cosine up, the flux times the albedo
        up = np.tile([0.0, 0.0, 1.0], (f.size, 1))
        d[f] = cosine_dirs(up, rng)
        w[f] *= s.albedo
        kinds[f, 0] += 1
        # the surface from below: reflect with F (what leaves goes to the sky)
        u = np.nonzero(at_surf)[0]
        nu = normal(p[u, 0], p[u, 1], s.waves)
        cos_i = np.einsum("ij,ij->i", d[u], nu)
        fr, _ = fresnel(np.abs(cos_i), pool.WATER_IOR)
        w[u] *= fr[:, None]
        d[u] = d[u] - 2.0 * cos_i[:, None] * nu
        kinds[u, 1] += 1
        on_surface = at_surf.copy()
        # a photon goes on while a later splat can still be within the limits: the next floor
        # vertex adds itself and the camera's entry, and after a floor a reflection before it
        nxt = kinds.sum(1) + 2 + at_floor
        alive = (at_floor | at_surf) & (nxt <= s.max_bounces) & (w.max(1) > 0.0)
        o, d, w, kinds = p[alive], d[alive], w[alive], kinds[alive]
        on_surface = on_surface[alive]
    return stats


def render(scene, photons: int = 0, seed: int = 0, batch: int = BATCH, seconds: float = 0.0,
           waves=pool.WAVES, supersample: int = SUPERSAMPLE):
    """Render the ``pool_caustic`` bpy scene by ``photons`` sun photons (in batches of
    ``batch``), or with ``seconds`` whole batches until that time (the camera map's included)
    is spent.  (image (h, w, 3) float32 top-down, coverage (h, w) bool top-down, info)."""
    if photons <= 0 and seconds <= 0:
        raise ValueError("give a photon count or a time")
    t0 = time.perf_counter()
    s = setup_of(scene, waves)
    rng = np.random.default_rng(seed)
    cmap = CameraMap(s, supersample)
    map_seconds = time.perf_counter() - t0
    acc = np.zeros((3, s.width * s.height))
    done, batches = 0, 0
    stats = {"entered": 0, "floor_hits": 0, "splats": 0}
    while True:
        n = batch if seconds > 0 else min(batch, photons - done)
        st = trace(s, cmap, n, rng, acc)
        if st["beside_water"]:
            # sunlight on the floor past the water's edge, then reflected down by the water's
            # underside, came out 2-3 % of the image dimmer here than in Cycles and this engine
            # (docs/history/benchmarks-notebook.md, the pool): that path is not rendered
            raise ValueError("sunlight reaches the floor past the water's edge: the exact pool "
                             "renders a floor lit only through the water")
        done += n
        batches += 1
        for key in stats:
            stats[key] += st[key]
        if (seconds > 0 and time.perf_counter() - t0 >= seconds) or \
                (seconds <= 0 and done >= photons):
            break
    # each batch's fluxes are its own share (area / n): the batches' mean
    img = (acc / batches).T.reshape(s.height, s.width, 3) * s.irradiance * s.film_exposure
    info = {"photons": done, "batches": batches, "seconds": time.perf_counter() - t0,
            "map_seconds": map_seconds, "triangles": cmap.triangles,
            "folded_triangles": cmap.folded, **stats}
    return img.astype(np.float32), cmap.coverage, info
