"""Casters: the surfaces that can start a caustic (a mirror, glass, a smooth glossy lobe:
materials.follow_capable), as a few bounding spheres, and each emitter's power toward them.

With indirect light by eye paths, a photon lives on only when its first scattering is by one of
these closures (kernels/integrator/photon_pass.cl), so caustic photons are aimed at the spheres
(kernels/light/aim.h) and the emitters picked by the power they send toward them
(``caustic_cdf``).  Both only move samples where they count: every photon's flux is divided
by the density it was drawn with, so the image's expectation is the same as without aiming
(tests/test_aim.py)."""
from __future__ import annotations

import hashlib
import threading

import numpy as np

from ppm_engine.scene.arrays import (
    LIGHT_AREA_ELLIPSE,
    LIGHT_AREA_RECT,
    LIGHT_SUN,
    NODE_GLASS,
    NODE_GLOSSY,
    NODE_METALLIC,
    NODE_PRINCIPLED,
    NODE_REFRACTION,
)
from ppm_engine.scene.emitters import power_cdf
from ppm_engine.scene.light_paths import LP_CAUSTICS_REFLECTIVE, LP_CAUSTICS_REFRACTIVE
from ppm_engine.scene.materials import SINGULAR_ROUGHNESS, _principled_parts, follow_capable

# the most spheres: every aimed photon loops over them three times (aim.h)
MAX_CASTERS = 32
# a cluster is cut in two (where its two parts' boxes are smallest, up to SPLIT_DEPTH times)
# only where its parts' best spheres, their r^2 summed (the solid angle they subtend from
# afar), come to less than this share of its own: a ball stays one sphere (its halves' spheres
# sum to 2.5 times its r^2), balls apart become one each
SPLIT_GAIN = 0.8
SPLIT_DEPTH = 5             # 2^5 = MAX_CASTERS spheres at most
# a caster whose only caustic closure is a dielectric's specular layer or a coat sends on a
# few percent of what reaches it: its weight (glass, metal, a glossy BSDF: 1)
LAYER_WEIGHT = 0.1


def caustic_roughness(lp: np.ndarray, setting: float) -> float:
    """The roughness from which a glossy reflection a path follows is the eye paths' light and
    not the caustic photons' (RenderOptions.caustic_roughness, ``setting``), for a scene's Light
    Paths record ``lp``: with Filter Glossy above 1 / pi every one that is not singular
    (kernels/integrator/path_state.h filter_glossy_caustic_roughness says why), so only mirrors,
    glass and refractions start a caustic."""
    diffuse_pdf = np.float32(1.0 / np.pi)   # the kernels' FILTER_GLOSSY_DIFFUSE_PDF
    return SINGULAR_ROUGHNESS if lp["filter_glossy"][0] > diffuse_pdf else setting


def material_weights(knodes: np.ndarray, n_materials: int, gather_roughness: float,
                     caustic_roughness: float, lp_flags: int) -> np.ndarray:
    """(n_materials,) float32: each material's caster weight, 0 for one that starts no
    caustic; none at all when the Light Paths turn both kinds of caustics off."""
    out = np.zeros(n_materials, np.float32)
    if not lp_flags & (LP_CAUSTICS_REFLECTIVE | LP_CAUSTICS_REFRACTIVE) or not knodes.size:
        return out
    capable = follow_capable(knodes, gather_roughness, caustic_roughness)
    t = knodes["type"]
    w = np.where(np.isin(t, (NODE_GLASS, NODE_REFRACTION, NODE_GLOSSY, NODE_METALLIC)), 1.0, 0.0)
    p = t == NODE_PRINCIPLED
    if p.any():
        parts = _principled_parts(knodes[p])
        w[p] = np.where(parts["glass"] | parts["metal"], 1.0, LAYER_WEIGHT)
    w = np.where(capable, w, 0.0)
    m = knodes["material"]
    ok = (m >= 0) & (m < n_materials)
    np.maximum.at(out, m[ok], w[ok].astype(np.float32))
    return out


class CasterTree:
    """caster_spheres' tree of splits over the triangles of weight > 0 (_Corners.split, SPLIT_DEPTH
    levels) and its cut at some positions: ``result`` (spheres, weights).  A refit (the same
    triangles moved: DeviceScene.refit) keeps the tree, so the casters follow a moved object
    without its splits' sorts: each cluster's sphere at the new positions and the cut chosen
    again by the same rule; refit() says build afresh when the tree got worse than that
    (REFIT_MAX_COST), as the BVH's refit does."""

    # a refitted tree serves while its leaves' summed r^2 stays within this factor of the
    # built one's (an object moved across another's clusters stretches them)
    REFIT_MAX_COST = 1.5

    def __init__(self, corners: np.ndarray, weight: np.ndarray):
        sel = np.nonzero(weight > 0)[0]
        # the nodes, depth first: (first, end) of their triangles in ``order`` (each node's a
        # range: its leaves' in turn), child a, child b (-1: a leaf)
        self.nodes: list = []
        leaves: list = []
        if sel.size:
            self._grow(_Corners(corners, sel), np.arange(sel.size), SPLIT_DEPTH, leaves, 0)
        self.sel, self.n_triangles = sel, weight.shape[0]
        self.order = sel[np.concatenate(leaves)] if leaves else sel
        self.result, self.leaf_cost = self._cut(corners, weight)
        self.built_leaf_cost = self.leaf_cost

    def _grow(self, tri, idx: np.ndarray, depth: int, leaves: list, first: int) -> int:
        k = len(self.nodes)
        self.nodes.append([first, first + idx.size, -1, -1])
        if depth > 0 and idx.size >= 2:
            a, b = tri.split(idx)
            self.nodes[k][2] = self._grow(tri, a, depth - 1, leaves, first)
            self.nodes[k][3] = self._grow(tri, b, depth - 1, leaves, first + a.size)
        else:
            leaves.append(idx)
        return k

    def _cut(self, corners: np.ndarray, weight: np.ndarray):
        """((spheres, weights) of the best cut at these positions, the leaves' summed r^2)"""
        if not self.nodes:
            return (np.zeros((0, 4), np.float32), np.zeros(0, np.float32)), 0.0
        tri = corners[self.order].astype(np.float64)
        xyz = [np.ascontiguousarray(tri[..., a]) for a in range(3)]      # (T, 3) each
        w = weight[self.order]

        def sphere(first, end):
            """A bounding sphere of the triangles first..end: its box's centre, the farthest
            corner."""
            v = [a[first:end] for a in xyz]
            c = 0.5 * (np.array([a.min() for a in v]) + np.array([a.max() for a in v]))
            x, y, z = (a - c[k] for k, a in enumerate(v))
            return c, float(np.sqrt((x * x + y * y + z * z).max()))
        sph = [sphere(first, end) for first, end, _, _ in self.nodes]

        def best(k):
            """(summed r^2, [nodes]) of the best cut below node k"""
            (_, r), (_, _, a, b) = sph[k], self.nodes[k]
            if a < 0:
                return r * r, [k]
            (ca, la), (cb, lb) = best(a), best(b)
            return (ca + cb, la + lb) if ca + cb < SPLIT_GAIN * r * r else (r * r, [k])

        done = best(0)[1]
        spheres = np.zeros((len(done), 4), np.float32)
        weights = np.zeros(len(done), np.float32)
        for j, k in enumerate(done):
            c, r = sph[k]
            # a margin for float32 and the ray offsets: a triangle's edge stays inside
            spheres[j, :3], spheres[j, 3] = c, r * (1.0 + 1e-4) + 1e-6 * (1.0 + np.abs(c).max())
            weights[j] = w[self.nodes[k][0]:self.nodes[k][1]].max()
        leaves = sum(sph[k][1] ** 2 for k, (_, _, a, _) in enumerate(self.nodes) if a < 0)
        return (spheres, weights), float(leaves)

    def refit(self, corners: np.ndarray, weight: np.ndarray) -> CasterTree | None:
        """This tree's cut for the same triangles at new positions (and weights): a new
        CasterTree sharing the splits, or None (build afresh) when other triangles have
        weight > 0 or the leaves' summed r^2 grew past REFIT_MAX_COST x the built tree's."""
        sel = np.nonzero(weight > 0)[0]
        if weight.shape[0] != self.n_triangles or not np.array_equal(sel, self.sel):
            return None
        out = object.__new__(CasterTree)
        out.sel, out.order, out.nodes = self.sel, self.order, self.nodes
        out.n_triangles = self.n_triangles
        out.built_leaf_cost = self.built_leaf_cost
        out.result, out.leaf_cost = out._cut(corners, weight)
        if not out.leaf_cost <= self.REFIT_MAX_COST * self.built_leaf_cost:
            return None
        return out


class _Corners:
    """The boxes and centroids of the triangles ``sel`` of ``corners`` in float64, per axis
    (contiguous: the splits' sorts and scans run along rows)."""

    def __init__(self, corners: np.ndarray, sel: np.ndarray):
        tri = corners[sel].astype(np.float64)
        self.lo = np.ascontiguousarray(tri.min(axis=1).T)                   # (3, T)
        self.hi = np.ascontiguousarray(tri.max(axis=1).T)
        self.centroid = np.ascontiguousarray(tri.mean(axis=1).T)

    def split(self, idx: np.ndarray):
        """Triangles ``idx`` in two, by their centroids along an axis, where the two parts'
        boxes' diagonals squared, each times its triangles, sum least (every cut along every
        axis): at the gap between two objects rather than through one."""
        def diagonal2(lo, hi):
            d = hi - lo
            return d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
        best = None
        for axis in range(3):
            order = idx[np.argsort(self.centroid[axis, idx], kind="stable")]
            lo, hi = self.lo[:, order], self.hi[:, order]
            lo_a = np.minimum.accumulate(lo, axis=1)
            hi_a = np.maximum.accumulate(hi, axis=1)
            lo_b = np.minimum.accumulate(lo[:, ::-1], axis=1)[:, ::-1]
            hi_b = np.maximum.accumulate(hi[:, ::-1], axis=1)[:, ::-1]
            n = np.arange(1, order.size)
            cost = (n * diagonal2(lo_a[:, :-1], hi_a[:, :-1])
                    + n[::-1] * diagonal2(lo_b[:, 1:], hi_b[:, 1:]))
            k = int(np.argmin(cost))
            if best is None or cost[k] < best[0]:
                best = (cost[k], order[:k + 1], order[k + 1:])
        return best[1], best[2]


# caster_tree's last trees by their input's digest: a scene rendered again (F12 once more,
# the viewport's restarts, a benchmark's curves) finds its spheres at once (a build: 0.3-0.4 s
# for the 100K-triangle ball of bench --viewport's textured scene, its refit 0.02 s)
_SPHERES: dict = {}
_SPHERES_KEPT = 4
_SPHERES_LOCK = threading.Lock()


def caster_tree(corners: np.ndarray, weight: np.ndarray) -> CasterTree:
    """The CasterTree of the triangles ``corners`` (T, 3, 3) of weight > 0 (treat it as
    read-only); the last few are kept by the digest of their input."""
    c, w = np.ascontiguousarray(corners), np.ascontiguousarray(weight)
    h = hashlib.blake2b(digest_size=16)
    for a in (c, w):
        h.update(str((a.dtype.str, a.shape)).encode())
        h.update(a.data)
    key = h.digest()
    with _SPHERES_LOCK:
        hit = _SPHERES.get(key)
    if hit is None:
        hit = CasterTree(c, w)
        with _SPHERES_LOCK:
            _SPHERES[key] = hit
            while len(_SPHERES) > _SPHERES_KEPT:
                del _SPHERES[next(iter(_SPHERES))]
    return hit


def caster_spheres(corners: np.ndarray, weight: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(spheres (k, 4) float32: centre, radius; weights (k,) float32) over the triangles
    ``corners`` (T, 3, 3) of weight > 0: the cut through their tree of splits (_Corners.split,
    SPLIT_DEPTH levels, so at most MAX_CASTERS spheres) whose spheres' summed r^2 is least, a
    cluster kept whole unless its parts' come to less than SPLIT_GAIN of its own; each
    sphere's weight its triangles' largest (CasterTree)."""
    spheres, weights = caster_tree(corners, weight).result
    return spheres.copy(), weights.copy()


def _solid_angle(dist: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """The solid angle of a sphere of ``radius`` from ``dist`` away (4 pi from inside)."""
    x = np.clip((radius / np.maximum(dist, 1e-30)) ** 2, 0.0, 1.0)
    omega = 2.0 * np.pi * x / (1.0 + np.sqrt(1.0 - x))
    return np.where(dist > radius, omega, 4.0 * np.pi)


def caster_reach(lights: np.ndarray, emissive_corners: np.ndarray, has_world: bool,
                 scene_radius: float, spheres: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Per emitter (the lights, the emissive triangles, the world: the emitter table's order),
    about the share of its photons that aimed emission sends toward the casters, weighted:
    sum over casters of weight x (its solid angle over the sphere's, from anywhere on the
    emitter: the emitter's size taken off the distance; its disc over the scene's for a sun
    or the world), each term at most its weight.  0 only where no caster can be reached: every
    one wholly behind a one-sided area light."""
    n = lights.shape[0] + emissive_corners.shape[0] + int(has_world)
    out = np.zeros(n, np.float64)
    if not spheres.shape[0]:
        return out
    c, r, w = spheres[:, :3].astype(np.float64), spheres[:, 3].astype(np.float64), weights
    disc = np.minimum((r / max(scene_radius, 1e-30)) ** 2, 1.0)
    if lights.shape[0]:
        pos = lights["position"].astype(np.float64)
        size = lights["radius"].astype(np.float64)
        area = np.isin(lights["type"], (LIGHT_AREA_RECT, LIGHT_AREA_ELLIPSE))
        half = 0.5 * np.sqrt((lights["axis_x"].astype(np.float64) ** 2).sum(axis=1)
                             + (lights["axis_y"].astype(np.float64) ** 2).sum(axis=1))
        size = np.where(area, half, size)
        to = c[None, :, :] - pos[:, None, :]
        dist = np.sqrt((to ** 2).sum(axis=2)) - size[:, None]
        share = np.minimum(_solid_angle(dist, r[None, :]) / (4.0 * np.pi), 1.0)
        front = (to * lights["direction"].astype(np.float64)[:, None, :]).sum(axis=2) >= -r
        share = np.where(area[:, None] & ~front, 0.0, share)
        sun = lights["type"] == LIGHT_SUN
        share[sun] = disc[None, :]
        out[:lights.shape[0]] = (share * w[None, :]).sum(axis=1)
    if emissive_corners.shape[0]:
        tri = emissive_corners.astype(np.float64)
        centre = tri.mean(axis=1)
        size = np.sqrt(((tri - centre[:, None, :]) ** 2).sum(axis=2)).max(axis=1)
        k0 = lights.shape[0]
        for s in range(0, tri.shape[0], 4096):      # bounded memory: 4096 x MAX_CASTERS
            to = c[None, :, :] - centre[s:s + 4096, None, :]
            dist = np.sqrt((to ** 2).sum(axis=2)) - size[s:s + 4096, None]
            share = np.minimum(_solid_angle(dist, r[None, :]) / (4.0 * np.pi), 1.0)
            out[k0 + s:k0 + s + share.shape[0]] = (share * w[None, :]).sum(axis=1)
    if has_world:
        out[-1] = float((disc * w).sum())
    return out


def caustic_cdf(power: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """The emitter table's CDF for aimed photons: power x reach (all zeros when nothing
    reaches a caster: then no caustic photon is emitted)."""
    return power_cdf(np.asarray(power, np.float64) * reach).astype(np.float32)
