"""The camera's side of the pool's exact-geometry reference (exact_pool.py, whose docstring has
the method): camera rays through a raster grid traced through the water to the floor
(``CameraMap``), inverted by geometry to find every raster position that sees a floor point."""
from __future__ import annotations

import math

import numpy as np

from ppm_engine.blender.scenes import pool
from ppm_engine.tools.bench.exact_film import camera_rays, window_clear
from ppm_engine.tools.bench.exact_pool_water import crossing, normal, refract_in

SUPERSAMPLE = 6                 # camera-map points per pixel and axis
GLINT_MARGIN = math.radians(0.5)


# --- the camera's side -----------------------------------------------------------------------
class CameraMap:
    """Camera rays through a raster grid, traced through the water to the floor, and the grid's
    triangles binned by their floor triangles, to find every raster position that sees a floor
    point (exact_pool.py's docstring); ``s`` an exact_pool.Setup."""

    def __init__(self, s, supersample: int = SUPERSAMPLE):
        self.s = s
        k = supersample
        reach = s.filter_width
        pad = math.ceil(reach * k) + 1
        gx = (np.arange(-pad, s.width * k + pad + 1)) / k
        gy = (np.arange(-pad, s.height * k + pad + 1)) / k
        px, py = np.meshgrid(gx, gy)                 # rows: y
        shape = px.shape
        d = camera_rays(s, px.ravel(), py.ravel())
        o = np.broadcast_to(s.eye, d.shape).copy()
        t = crossing(o, d, np.zeros(len(d), bool), s.waves, np.zeros(len(d), bool))
        ok = np.isfinite(t)
        p = o + np.where(ok, t, 0.0)[:, None] * d
        nrm = normal(p[:, 0], p[:, 1], s.waves)
        reflected = d - 2.0 * np.einsum("ij,ij->i", d, nrm)[:, None] * nrm
        near = reflected[ok] @ s.sun
        limit = math.cos(math.acos(s.cos_half) + GLINT_MARGIN)
        if near.size and near.max() > limit:
            raise ValueError("the camera sees the sun reflected in the water: the exact pool "
                             "renders no glint")
        with np.errstate(divide="ignore", invalid="ignore"):
            dt, tau = refract_in(d, nrm, pool.WATER_IOR)
        tau = tau / pool.WATER_IOR ** 2              # radiance leaving the water
        with np.errstate(divide="ignore", invalid="ignore"):
            tf = (-pool.DEPTH - p[:, 2]) / dt[:, 2]
        x = p[:, :2] + tf[:, None] * dt[:, :2]
        ok &= ((tf > 0) & (np.abs(x[:, 0]) <= pool.FLOOR_HALF)
               & (np.abs(x[:, 1]) <= pool.FLOOR_HALF))
        # a refracted ray that met the surface again would need more than this map
        back = crossing(p, dt, np.ones(len(d), bool), s.waves, np.ones(len(d), bool))
        ok &= ~(np.isfinite(back) & (back < tf))
        self.valid = ok.reshape(shape)
        self.coverage = window_clear(~self.valid, s, k, pad, 0.0)
        # two triangles per grid cell, where all three corners are valid
        idx = np.arange(shape[0] * shape[1]).reshape(shape)
        a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
        c, e = idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
        tri = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, e], 1)])
        tri = tri[ok[tri].all(1)]
        P = np.stack([px.ravel(), py.ravel()], 1)[tri]          # (m, 3, 2) raster
        X = x[tri]                                              # (m, 3, 2) floor
        ex1, ex2 = X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]
        det = ex1[:, 0] * ex2[:, 1] - ex1[:, 1] * ex2[:, 0]
        keep = np.abs(det) > 1e-18
        tri, P, X, ex1, ex2, det = tri[keep], P[keep], X[keep], ex1[keep], ex2[keep], det[keep]
        ep1, ep2 = P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]
        det_p = ep1[:, 0] * ep2[:, 1] - ep1[:, 1] * ep2[:, 0]
        area_p = np.abs(det_p)
        # where the waves fold the camera's view, triangles turn over: there one floor point is
        # seen at several raster positions, and |dp/dx| grows without bound at the fold's line
        # (exact, but the splats' variance grows with it)
        turned = np.sign(det_p) != np.sign(det)
        self.folded = int(min(turned.sum(), (~turned).sum()))
        self.jacobian = area_p / np.abs(det)                    # raster px^2 per floor m^2
        self.inv = np.stack([ex2[:, 1], -ex2[:, 0], -ex1[:, 1], ex1[:, 0]], 1) / det[:, None]
        self.X0, self.P0, self.ep1, self.ep2 = X[:, 0], P[:, 0], ep1, ep2
        self.tau = tau[tri]                                     # (m, 3)
        self.triangles = len(tri)
        # bins over the floor, about two triangles across
        lo, hi = X.reshape(-1, 2).min(0), X.reshape(-1, 2).max(0)
        self.floor_lo, self.floor_hi = lo, hi
        size = 2.0 * float(np.median(np.linalg.norm(ex1, axis=1)))
        nb = np.maximum(np.ceil((hi - lo) / size).astype(np.int64), 1)
        self.lo, self.size, self.nb = lo, size, nb
        bmin = np.clip(((X.min(1) - lo) / size).astype(np.int64), 0, nb - 1)
        bmax = np.clip(((X.max(1) - lo) / size).astype(np.int64), 0, nb - 1)
        span = bmax - bmin + 1
        count = span[:, 0] * span[:, 1]
        owner = np.repeat(np.arange(len(tri)), count)
        local = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
        bx = bmin[owner, 0] + local % span[owner, 0]
        by = bmin[owner, 1] + local // span[owner, 0]
        bins = by * nb[0] + bx
        order = np.argsort(bins, kind="stable")
        self.bin_tris = owner[order]
        self.bin_start = np.searchsorted(bins[order], np.arange(nb[0] * nb[1] + 1))

    def locate(self, x):
        """Every (photon index, raster px, py, weight) where the camera sees floor points x
        (n, 2): weight = the transmission into the camera (radiance times (1 - F) / IOR^2) x
        |dp/dx| (raster pixels^2 per floor m^2)."""
        b = np.floor((x - self.lo) / self.size).astype(np.int64)
        inb = (b >= 0).all(1) & (b < self.nb).all(1)
        pid = np.nonzero(inb)[0]
        bid = b[pid, 1] * self.nb[0] + b[pid, 0]
        start, end = self.bin_start[bid], self.bin_start[bid + 1]
        cnt = end - start
        rep = np.repeat(pid, cnt)
        local = np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt)
        cand = self.bin_tris[np.repeat(start, cnt) + local]
        q = x[rep] - self.X0[cand]
        inv = self.inv[cand]
        l1 = inv[:, 0] * q[:, 0] + inv[:, 1] * q[:, 1]
        l2 = inv[:, 2] * q[:, 0] + inv[:, 3] * q[:, 1]
        hit = (l1 >= 0.0) & (l2 >= 0.0) & (l1 + l2 <= 1.0)
        rep, cand, l1, l2 = rep[hit], cand[hit], l1[hit], l2[hit]
        p = self.P0[cand] + l1[:, None] * self.ep1[cand] + l2[:, None] * self.ep2[cand]
        tau = self.tau[cand]
        t = (1.0 - l1 - l2) * tau[:, 0] + l1 * tau[:, 1] + l2 * tau[:, 2]
        return rep, p[:, 0], p[:, 1], t * self.jacobian[cand]
