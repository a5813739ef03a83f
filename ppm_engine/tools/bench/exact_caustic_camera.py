"""The camera's side of point_caustic's, rough_caustic's and far_caustic's exact-geometry reference
(exact_caustic.py): what the pixels that see the glass ball see through it or in it, so that the
reference renders every pixel.

Light tracing cannot render those pixels: a photon's path reaches the camera through the ball
only along a specular chain whose end on the floor no connection can find.  So the camera's side
is traced instead, the way Cycles' camera paths see it:

- the ball's image is integrated over the pixel filter on a grid of ``BALL_GRID`` x ``BALL_GRID``
  points per pixel over the raster box the ball's points fill (exact_film.filtered, as the
  direct light's grid), refined to ``BALL_REFINE`` x ``BALL_REFINE`` points per cell where what
  the cells see changes (the silhouette; the floor, the wall, the void and the shadow as the
  ray reflected off the ball and the one through it see them; the rough ball's highlights);
- a camera ray that meets the ball follows the specular chain through the true sphere: at each
  vertex both the reflected and the refracted ray go on, each with its weight (the Fresnel
  factor and its complement: ``glass_split``, the expectation of the light tracer's random
  choice taken exactly; on rough glass about one microfacet normal drawn among the visible
  ones, weights F G2 / G1 and (1 - F) G2 / G1).  A ray that leaves the ball outwards never meets
  it again (it is convex), so the chain is a comb: one ray inside, one leaving per vertex.
  Branches under ``PRUNE`` of the camera ray's weight are dropped (at most that share of a
  point's value);
- a branch that reaches the floor or the wall at x sees L = albedo / pi x E(x): the direct
  irradiance in closed form (exact_caustic_scene.direct_irradiance: the point light past the
  ball, which is opaque to the shadow ray as to Cycles') plus the irradiance of the light
  tracer's own photons at x (caustics through or off the ball, interreflections), which no
  camera path can sample from a point light: their flux binned into irradiance textures on the
  floor's top and the wall's front (``Textures``, ``TEXTURE_BINS`` bins per metre: 1 cm, a
  fraction of a pixel's footprint there; seen through the ball the footprints are larger
  still).  A bin's mean irradiance stands for every point of it: the textures' bias, which
  tests/test_exact_caustic_camera.py and the bench's notes measure by halving the bins;
- the void beyond the stage is the black world; the light, of radius 0, is never hit (as in
  Cycles: its image in the smooth ball is a point Cycles cannot render either);
- on rough glass each vertex also estimates the point light's next event: the kernel
  ``rough_glass_eval`` towards the light, when the shadow ray leaves the ball outwards (the
  glass is opaque to it otherwise): the light's highlight on the ball and through it.  The
  whole chain is traced in the light tracer's form of the glass's kernel (the camera ray as a
  photon): that form differs from the radiance form by a factor eta^2 per crossing, which a
  chain that comes out of the ball again cancels, and a next event inside it makes up.

Bounce limits are counted as for the light tracer's connections (exact_caustic.py): the
chain's vertices before x scatter, x is where the camera path's next-event estimation is (its
direct light), or, for a photon landing at x as its vertex b, the photon's vertices 1..b
scatter too (b >= 1; its vertex 0 is the next event): j chain vertices and b of the photon's
count j + b bounces against max_bounces, and per kind (glossy: a reflection off the glass,
transmission: a refraction) the chain's and the photon's together against the kind's limit.
So the textures keep a layer per chain kind: reflected once off the ball (glossy 1) and through
it after k internal reflections (glossy k, transmission 2), each with the photons that chain
may see.
"""
from __future__ import annotations

import math

import numpy as np

from ppm_engine.blender.scenes.caustics import FLOOR
from ppm_engine.tools.bench.exact_caustic_scene import (
    BALL_ID,
    FLOOR_HALF,
    FLOOR_ID,
    WALL_TOP,
    Setup,
    direct_irradiance,
    first_hit,
    stage_normals,
)
from ppm_engine.tools.bench.exact_film import camera_rays, filtered, jump_cells
from ppm_engine.tools.bench.exact_optics import glass_split, rough_glass_eval

TEXTURE_BINS = 100               # irradiance texture bins per metre (1 cm)
BALL_GRID = 32                   # chain points per pixel and axis over the ball's image
BALL_REFINE = 4                  # points per cell and axis where what a cell sees changes
PRUNE = 1e-6                     # branches below this weight are dropped


# --- the photons' irradiance textures --------------------------------------------------------
class Textures:
    """The light tracer's photons' flux on the floor's top and the wall's front, in square bins
    of 1 / ``bins`` m, per kind of camera chain that may see it (the module docstring): layer 0
    the chain reflected off the ball, layer 1 + k the chain through it after k internal
    reflections.  Deposits are kept per photon and summed once per batch (``flush``)."""

    def __init__(self, s: Setup, bins: int = TEXTURE_BINS):
        self.s = s
        self.nx = round(2.0 * FLOOR_HALF * bins)
        self.nz = round(WALL_TOP * bins)
        self.n_floor = self.nx * self.nx
        self.n = self.n_floor + self.nx * self.nz
        self.k_max = max(s.max_bounces - 2, -1)         # internal reflections a chain may have
        self.layers = 2 + self.k_max
        self.acc = np.zeros(self.layers * self.n)
        self.area = np.concatenate([np.full(self.n_floor, (2 * FLOOR_HALF / self.nx) ** 2),
                                    np.full(self.n - self.n_floor,
                                            2 * FLOOR_HALF / self.nx * WALL_TOP / self.nz)])
        self.photons = 0
        self._pending: list = []

    def bin_of(self, p, hit):
        """The bins of points p on the floor (hit FLOOR_ID) or the wall (WALL_ID)."""
        ix = np.clip(((p[:, 0] + FLOOR_HALF) / (2 * FLOOR_HALF) * self.nx).astype(np.int64),
                     0, self.nx - 1)
        iy = np.clip(((p[:, 1] + FLOOR_HALF) / (2 * FLOOR_HALF) * self.nx).astype(np.int64),
                     0, self.nx - 1)
        iz = np.clip((p[:, 2] / WALL_TOP * self.nz).astype(np.int64), 0, self.nz - 1)
        return np.where(hit == FLOOR_ID, iy * self.nx + ix, self.n_floor + iz * self.nx + ix)

    def deposit(self, p, hit, front, w, vertex: int, counts) -> None:
        """Photons of weights w landing at p (the photon's vertex ``vertex``, its kinds'
        counts of vertices 1..vertex: diffuse, glossy, transmission), on the front (the floor's
        top, the wall's front) where ``front``: each joins the layers whose chains it may be
        seen by within the bounce limits."""
        s = self.s
        g, t = counts[:, 1], counts[:, 2]
        b = self._bins_front(p, hit, front)
        ok = front & (vertex + 1 <= s.max_bounces) & (g + 1 <= s.glossy_bounces)
        self._pending.append((b[ok], w[ok]))
        # through the ball: k internal reflections, every k up to the deposit's own limit
        k = np.minimum(s.max_bounces - vertex - 2, s.glossy_bounces - g)
        ok = front & (k >= 0) & (t + 2 <= s.transmission_bounces)
        self._pending.append(((1 + np.minimum(k[ok], self.k_max)) * self.n + b[ok], w[ok]))

    def _bins_front(self, p, hit, front):
        return np.where(front, self.bin_of(p, hit), 0)

    def flush(self, photons: int) -> None:
        """Add the pending deposits, of a batch of ``photons``."""
        if self._pending:
            idx = np.concatenate([i for i, _ in self._pending])
            w = np.concatenate([x for _, x in self._pending])
            self.acc += np.bincount(idx, w, minlength=self.acc.size)
        self._pending = []
        self.photons += photons

    def irradiance(self) -> np.ndarray:
        """(layers, bins) per watt: each chain kind's irradiance of the photons it may see
        (layer 1 + k: the deposits allowed k or more internal reflections)."""
        e = self.acc.reshape(self.layers, self.n) / (max(self.photons, 1) * self.area)
        e[1:] = np.cumsum(e[1:][::-1], axis=0)[::-1]
        return e


# --- the camera's chains through the ball ----------------------------------------------------
def _stage_kind(hit, lit):
    return np.where(hit < 0, 0, 2 * hit + 1 + lit)


def chains(s: Setup, px, py, tex: Textures, rng, closed: bool = True):
    """The chains of camera rays through raster positions (px, py) that first meet the ball
    (the module docstring).  (deterministic radiance per point: the direct light at the
    chains' ends (``closed``) and the rough ball's next events; the ends' texture lookups:
    point, flat texture index and weight (albedo / pi x the branch's weight); what each point
    sees, for the refinement), per watt of the light's power."""
    a = float(FLOOR[0])
    n = px.size
    d = camera_rays(s, px, py)
    o = np.broadcast_to(s.eye, d.shape)
    no = np.zeros(n, bool)
    t, hit = first_hit(o, d, no, no, s.ball)
    depth = t * (d @ -s.axes[:, 2])
    pt = np.flatnonzero((hit == BALL_ID) & (depth > s.clip[0]) & (depth < s.clip[1]))
    kind = np.zeros(n, np.int64)
    kind[pt] = 1
    det = np.zeros(n)
    ends = []
    d, p = d[pt], s.eye + t[pt, None] * d[pt]
    w = np.ones(pt.size)
    inside = np.zeros(pt.size, bool)
    g = np.zeros(pt.size, np.int64)
    tr = np.zeros(pt.size, np.int64)
    centre, radius = s.ball
    alpha = s.roughness ** 2
    for j in range(1, s.max_bounces + 2):
        if pt.size == 0:
            break
        nrm = (p - centre) / radius
        if alpha > 0.0:
            # the next event at this vertex: j - 1 scattering vertices before it
            to_l = s.light - p
            dist = np.linalg.norm(to_l, axis=1)
            u = to_l / dist[:, None]
            vis = np.einsum("ij,ij->i", u, nrm) > 0
            val = w * rough_glass_eval(-d, u, nrm, alpha) / (4.0 * np.pi * dist ** 2)
            val = np.where(vis, val, 0.0)
            det += np.bincount(pt, val, minlength=n)
            if j == 1:              # the highlight off the ball: refined where it changes
                kind[pt] = kind[pt] * 64 + np.clip(np.log(np.maximum(val, 1e-30)) / np.log(4.0)
                                                   + 40, 0, 63).astype(np.int64)
        if j > s.max_bounces:
            break
        rd, rw, td, tw = glass_split(d, nrm, inside, alpha, rng)
        out = []                    # (points, origins, directions, weights, glossy, transm.)
        stay = []
        for nd, nw, dg, dt, now_in in ((rd, rw, 1, 0, inside), (td, tw, 0, 1, ~inside)):
            gg, tt = g + dg, tr + dt
            ok = ((w * nw > PRUNE) & (gg <= s.glossy_bounces) & (tt <= s.transmission_bounces))
            branch = (pt[ok], p[ok], nd[ok], (w * nw)[ok], gg[ok], tt[ok])
            sel_out, sel_in = ~now_in[ok], now_in[ok]
            out.append(tuple(x[sel_out] for x in branch))
            stay.append(tuple(x[sel_in] for x in branch))
        for bp, bo, bd, bw, bg, bt in out:          # leaving the ball: to the stage or the void
            th, hh = first_hit(bo, bd, np.zeros(bp.size, bool), np.ones(bp.size, bool), s.ball)
            on = hh >= 0
            x, normal = stage_normals(bo[on] + th[on, None] * bd[on], hh[on])
            front = np.einsum("ij,ij->i", bd[on], normal) < 0
            normal *= np.where(front, 1.0, -1.0)[:, None]
            e, lit = direct_irradiance(s, x, normal)
            if closed:
                det += np.bincount(bp[on], a / np.pi * bw[on] * e, minlength=n)
            layer = np.where(bt[on] == 0, 0, 1 + bg[on])
            keep = front & (layer < tex.layers)
            ends.append((bp[on][keep], layer[keep] * tex.n + tex.bin_of(x[keep], hh[on][keep]),
                         a / np.pi * bw[on][keep]))
            if j <= 2 and not alpha > 0.0:      # what the reflected and the first way out see
                sk = np.zeros(bp.size, np.int64)
                sk[on] = _stage_kind(hh[on], lit)
                kind[bp] = kind[bp] * 8 + sk
        ip, io, idr, iw, ig, it = (np.concatenate(x) for x in zip(*stay, strict=True))
        th, _ = first_hit(io, idr, np.ones(ip.size, bool), np.ones(ip.size, bool), s.ball)
        good = np.isfinite(th)
        pt, d, w, g, tr = ip[good], idr[good], iw[good], ig[good], it[good]
        p = io[good] + th[good, None] * idr[good]
        inside = np.ones(pt.size, bool)
    if ends:
        ep, ei, ew = (np.concatenate(x) for x in zip(*ends, strict=True))
    else:
        ep, ei, ew = np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    return det, (ep, ei, ew), kind


class BallView:
    """The ball's pixels (the module docstring): the grid over the raster box the ball's
    points fill, its chains traced once (before the photons: they depend on none), then
    ``image`` with the textures' irradiance once the photons are traced.  Per watt."""

    def __init__(self, s: Setup, tex: Textures, rng, closed: bool = True,
                 per_pixel: int = BALL_GRID, refine: int = BALL_REFINE, chunk: int = 1 << 16):
        self.s, self.tex, self.k = s, tex, per_pixel
        k, r = per_pixel, s.filter_width
        # the box: where a coarse grid's rays meet the ball, and the filter's reach around it
        c = 4
        cx = (np.arange(-c * 2, (s.width + 2) * c) + 0.5) / c
        cy = (np.arange(-c * 2, (s.height + 2) * c) + 0.5) / c
        gxx, gyy = np.meshgrid(cx, cy)
        d = camera_rays(s, gxx.ravel(), gyy.ravel())
        no = np.zeros(d.shape[0], bool)
        _, hit = first_hit(np.broadcast_to(s.eye, d.shape), d, no, no, s.ball)
        ball = hit == BALL_ID
        self.points = 0
        if not ball.any():
            self.gx = self.gy = np.zeros(0)
            self.det = np.zeros((0, 0))
            self.ends = (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0))
            return
        m = math.ceil(r) + 2
        x0, x1 = math.floor(gxx.ravel()[ball].min()) - m, math.ceil(gxx.ravel()[ball].max()) + m
        y0, y1 = math.floor(gyy.ravel()[ball].min()) - m, math.ceil(gyy.ravel()[ball].max()) + m
        self.gx = (np.arange(x0 * k, x1 * k) + 0.5) / k
        self.gy = (np.arange(y0 * k, y1 * k) + 0.5) / k
        nx = self.gx.size
        size = self.gy.size * nx
        det = np.zeros(size)
        kind = np.zeros(size, np.int64)
        ends = []
        for i0 in range(0, size, chunk):
            i = np.arange(i0, min(i0 + chunk, size))
            dd, (ep, ei, ew), kd = chains(s, self.gx[i % nx], self.gy[i // nx], tex, rng, closed)
            det[i], kind[i] = dd, kd
            ends.append((i[ep], ei, ew))
        cells = jump_cells(kind.reshape(self.gy.size, nx))
        sub = ((np.arange(refine) + 0.5) / refine - 0.5) / k
        ox, oy = (v.ravel() for v in np.meshgrid(sub, sub))
        per = max(chunk // ox.size, 1)
        refined = np.zeros(size, bool)
        refined[cells] = True
        keep_ends = [(p[~refined[p]], i[~refined[p]], w[~refined[p]]) for p, i, w in ends]
        for c0 in range(0, cells.size, per):
            cc = cells[c0:c0 + per]
            px = (self.gx[cc % nx][:, None] + ox).ravel()
            py = (self.gy[cc // nx][:, None] + oy).ravel()
            dd, (ep, ei, ew), _ = chains(s, px, py, tex, rng, closed)
            owner = cc[np.arange(px.size) // ox.size]
            det[cc] = dd.reshape(cc.size, ox.size).mean(axis=1)
            keep_ends.append((owner[ep], ei, ew / ox.size))
        self.points = size + cells.size * ox.size
        self.det = det.reshape(self.gy.size, nx)
        self.ends = tuple(np.concatenate(x) for x in zip(*keep_ends, strict=True))

    def image(self) -> np.ndarray:
        """(h * w) rows top-down, per watt: the filter integrals of what the ball's points
        see, with the textures' irradiance as it stands."""
        if self.gx.size == 0:
            return np.zeros(self.s.width * self.s.height)
        cell, idx, w = self.ends
        e = self.tex.irradiance().ravel()
        v = self.det.ravel() + np.bincount(cell, w * e[idx], minlength=self.det.size)
        return filtered(self.s, v.reshape(self.det.shape), self.gx, self.gy, self.k)
