"""``point_caustic``, ``rough_caustic`` and ``far_caustic`` as their exact-geometry reference
(exact_caustic.py) sees them, in NumPy: the scene as ppm_engine/blender/scenes/caustics.py defines
it (a true sphere, two finite planes, a point light), the Setup read from the bpy scene (camera,
film, light, bounce limits, the glass's roughness, and the geometry: the ball's centre and
radius, the light's position; what the reference does not model is refused), the rays' first
hits, the ball's shadow, a point's direct irradiance (``direct_irradiance``), and the pixels
that see only the floor and the wall directly (``coverage``: a region of the bench's tables,
no longer the reference's limit: exact_caustic_camera.py renders the ball's pixels)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ppm_engine.blender.scenes.caustics import FLOOR
from ppm_engine.tools.bench.exact_film import (
    CameraSetup,
    camera_fields,
    camera_rays,
    window_clear,
)
from ppm_engine.tools.bench.exact_optics import IOR

FLOOR_HALF = 2.0                 # the floor: z = 0, |x|, |y| <= 2
WALL_Y, WALL_TOP = 2.0, 2.5      # the back wall: y = 2, |x| <= 2, 0 <= z <= 2.5
EPS = 1e-9                       # hit distances at or below it are the surface a ray left
PLACES = 6                       # the ball read from bpy, rounded to the micrometre
SPHERE_TOL = 1e-4                # the ball's vertices' spread of distance to its centre, relative

FLOOR_ID, WALL_ID, BALL_ID = 0, 1, 2


# --- the scene -------------------------------------------------------------------------------
@dataclass
class Setup(CameraSetup):
    """What the tracer needs of the bpy scene."""
    light: np.ndarray            # position (3,)
    power: np.ndarray            # RGB watts (colour x energy x 2^exposure)
    max_bounces: int
    diffuse_bounces: int
    glossy_bounces: int
    transmission_bounces: int
    ball_center: np.ndarray      # the glass ball's centre (3,)
    ball_radius: float
    roughness: float = 0.0       # the glass's (Principled Roughness; alpha = its square)

    @property
    def ball(self) -> tuple:
        """(centre, radius): what the geometry's functions take."""
        return self.ball_center, self.ball_radius


def setup_of(scene, max_bounces: int | None = None) -> Setup:
    """The camera, film, light, ball and bounce limits of a ``point_caustic``,
    ``rough_caustic`` or ``far_caustic`` bpy scene: its geometry read from it (the point light's
    position, the ball's centre and radius: ``light_and_ball``; the stage is the module's
    constants).  ``max_bounces`` overrides all of the scene's bounce limits."""
    scene.view_layers[0].update()       # the objects' matrix_world after a script's edits
    if len(set(FLOOR)) != 1:
        raise ValueError("the exact reference traces one channel: the stage must be grey")
    camera = camera_fields(scene)
    c = scene.cycles
    light, pos, center, radius = light_and_ball(scene)
    power = (np.array(light.data.color, float) * light.data.energy
             * 2.0 ** getattr(light.data, "exposure", 0.0))
    roughness = glass_roughness(scene)
    limits = [c.max_bounces, c.diffuse_bounces, c.glossy_bounces, c.transmission_bounces]
    if max_bounces is not None:
        limits = [max_bounces] * 4
    return Setup(**camera, light=pos, power=power, max_bounces=int(limits[0]),
                 diffuse_bounces=int(limits[1]), glossy_bounces=int(limits[2]),
                 transmission_bounces=int(limits[3]), ball_center=center, ball_radius=radius,
                 roughness=roughness)


def _read(values) -> np.ndarray:
    """The ball's coordinates read from bpy (float32) rounded to the micrometre: caustics.py's
    constants exactly (0.3 is stored as 0.30000001), which the reference traced before it read
    the ball from bpy.  (The light's position is bpy's as it stands, as it always was.)"""
    return np.array([round(float(v), PLACES) for v in values])


def light_and_ball(scene):
    """(the light object, its position, the ball's centre, its radius) of the bpy scene, and
    the geometry the reference models, or ValueError: one point light of radius 0; the object
    'GlassBall' a sphere (its vertices, in world space, all at one distance from its origin:
    the reference traces the true sphere through them) resting on or above the floor, clear
    of the stage's edges and the wall (a ray inside it meets only it); the light above the
    floor, in front of the wall, at x <= -2 (no geometry on its far side: the stratified
    emission sends photons into x > 0 only)."""
    lights = [o for o in scene.objects if o.type == 'LIGHT' and not o.hide_render]
    if len(lights) != 1 or lights[0].data.type != 'POINT' or lights[0].data.shadow_soft_size:
        raise ValueError("the exact reference renders one point light of radius 0")
    light = lights[0]
    pos = np.array(light.matrix_world.translation, float)
    ball = next((o for o in scene.objects if o.name.startswith("GlassBall")), None)
    if ball is None or ball.type != 'MESH' or not ball.data.vertices:
        raise ValueError("the exact reference needs the glass ball 'GlassBall', a mesh")
    m = np.array(ball.matrix_world)
    co = np.empty(3 * len(ball.data.vertices))
    ball.data.vertices.foreach_get("co", co)
    world = co.reshape(-1, 3) @ m[:3, :3].T
    dist = np.linalg.norm(world, axis=1)
    if dist.max() - dist.min() > SPHERE_TOL * dist.max():
        raise ValueError("the exact reference traces a sphere: 'GlassBall''s vertices are not "
                         "all at one distance from its origin")
    center, radius = _read(m[:3, 3]), round(float(dist.max()), PLACES)
    if (center[2] < radius or np.abs(center[:2]).max() + radius > FLOOR_HALF
            or center[1] + radius > WALL_Y or center[2] + radius > WALL_TOP):
        raise ValueError(f"the ball (centre {tuple(center)}, radius {radius}) must rest on or "
                         "above the floor, clear of its edges and the wall")
    if not (pos[0] <= -FLOOR_HALF and pos[2] > 0.0 and pos[1] < WALL_Y):
        raise ValueError(f"the point light at {tuple(pos)} must stand at x <= {-FLOOR_HALF}, "
                         "above the floor and in front of the wall")
    return light, pos, center, radius


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


# --- geometry --------------------------------------------------------------------------------
def _ball_hits(o, d, inside, ball):
    """Distance along unit rays to the ball (centre, radius: Setup.ball): the far root for rays
    inside it, else the near root (inf where none)."""
    center, radius = np.asarray(ball[0], float), ball[1]
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


def first_hit(o, d, inside, left_ball, ball):
    """(distance, surface id) of the first hit along unit rays, with the ball (centre, radius:
    Setup.ball); id -1 where nothing is hit.
    A ray inside the ball meets only the ball (the floor touches it at one point); a ray that
    left the ball outwards never meets it again (it is convex)."""
    tf, tw = _plane_hits(o, d)
    tb = _ball_hits(o, d, inside, ball)
    tb = np.where(left_ball & ~inside, np.inf, tb)
    tf = np.where(inside, np.inf, tf)
    tw = np.where(inside, np.inf, tw)
    t = np.stack([tf, tw, tb])
    k = np.argmin(t, axis=0)
    tmin = t[k, np.arange(t.shape[1])]
    return tmin, np.where(np.isfinite(tmin), k, -1)


def ball_blocks(p, u, dist, ball):
    """Whether the ball (centre, radius: Setup.ball) cuts the segments from p along unit u of
    length dist."""
    center, radius = np.asarray(ball[0], float), ball[1]
    oc = p - center
    b = np.einsum("ij,ij->i", u, oc)
    disc = b * b - (np.einsum("ij,ij->i", oc, oc) - radius * radius)
    s = np.sqrt(np.maximum(disc, 0.0))
    return (disc > 0) & (-b + s > EPS) & (-b - s < dist)


def stage_normals(p, hit):
    """The floor's or the wall's front normals (+z, -y) at points p on them, and p put exactly
    on the surface."""
    p = p.copy()
    normal = np.zeros_like(p)
    normal[hit == FLOOR_ID, 2] = 1.0
    normal[hit == WALL_ID, 1] = -1.0
    p[hit == FLOOR_ID, 2] = 0.0
    p[hit == WALL_ID, 1] = WALL_Y
    return p, normal


def direct_irradiance(s: Setup, p, normal):
    """The point light's irradiance (per watt of its power: I = 1 / (4 pi) W/sr) at points p
    of the floor or the wall, on the side of unit normals ``normal``: I cos / d^2, 0 where the
    ball is on the segment to the light (the glass is opaque to it, as to Cycles' shadow rays)
    or the light is behind.  Only the ball can shadow: the light stands above the floor and in
    front of the wall, so neither plane meets the segment from a point of the other to it.
    (irradiance, lit)."""
    to_light = s.light - p
    dist = np.linalg.norm(to_light, axis=1)
    u = to_light / dist[:, None]
    cos_l = np.einsum("ij,ij->i", u, normal)
    lit = cos_l > 0
    lit[lit] = ~ball_blocks(p[lit], u[lit], dist[lit], s.ball)
    return np.where(lit, cos_l / (4.0 * np.pi * dist ** 2), 0.0), lit


# --- the pixels that see only the stage --------------------------------------------------------
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
    _, hit = first_hit(o, d, no, no, s.ball)
    bad = ~((hit == FLOOR_ID) | (hit == WALL_ID))
    return window_clear(bad.reshape(gy.shape), s, k, pad, 0.5)
