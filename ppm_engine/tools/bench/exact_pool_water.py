"""The water of the pool's exact-geometry reference (exact_pool.py), in NumPy: its true height
field (ppm_engine/blender/scenes/pool.py's waves, which the engine sees meshed), where rays first
cross it (bracketed, then Newton's method kept inside the bracket), and the refraction into it with
the exact Fresnel factor."""
from __future__ import annotations

import functools

import numpy as np

from ppm_engine.blender.scenes import pool
from ppm_engine.tools.bench.exact_optics import fresnel

NEWTON = 8                      # Newton steps to a surface crossing
MARCH = 32                      # steps through the waves' slab for a ray that may cross twice
EPS = 1e-7                      # m: a ray leaving the surface starts this far along


# --- the height field ------------------------------------------------------------------------
@functools.lru_cache(maxsize=8)
def _waves(waves):
    """(amplitudes (m,), wave vectors (m, 2), phases (m,)) of a waves tuple."""
    return pool.wave_vectors(waves)


def bounds(waves):
    """(the largest height, the largest slope) of the sum of ``waves``."""
    a, k, _ = pool.wave_vectors(waves)
    return float(np.abs(a).sum()), float((np.abs(a) * np.linalg.norm(k, axis=1)).sum())


def normal(x, y, waves):
    """Unit upward normals of the height field at (x, y)."""
    _, hx, hy = pool.height(x, y, waves)
    n = np.stack([-hx, -hy, np.ones_like(hx)], -1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def crossing(o, d, below, waves, on_surface):
    """Distances along rays o + t d (unit d) to where they first cross the water's surface
    inside the patch, from below it (``below``) or above; inf where they do not.  Rays that
    leave the surface (``on_surface``) start EPS along."""
    n = o.shape[0]
    t_hit = np.full(n, np.inf)
    if n == 0:
        return t_hit
    amp, slope = bounds(waves)
    if amp == 0.0:                                   # flat water: the plane z = 0
        with np.errstate(divide="ignore", invalid="ignore"):
            t = -o[:, 2] / d[:, 2]
        t_hit = np.where((t > EPS) & ~on_surface, t, np.inf)
    else:
        side = np.where(below, -1.0, 1.0)
        dz = d[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            ta, tb = (amp - o[:, 2]) / dz, (-amp - o[:, 2]) / dz
        t0 = np.maximum(np.minimum(ta, tb), 0.0)
        t0 = np.where(on_surface, EPS, t0)
        t1 = np.maximum(ta, tb)
        live = np.isfinite(t1) & (t1 > t0)

        a_, k_, ph_ = _waves(waves)

        def g(i, t, grad=False):                     # > 0 on the ray's starting side
            p = o[i] + t[:, None] * d[i]
            arg = p[:, :1] * k_[:, 0] + p[:, 1:2] * k_[:, 1] + ph_
            val = side[i] * (p[:, 2] - np.sin(arg) @ a_)
            if not grad:
                return val
            c = np.cos(arg) * a_
            slope = d[i, 2] - (c @ k_[:, 0]) * d[i, 0] - (c @ k_[:, 1]) * d[i, 1]
            return val, side[i] * slope

        dxy = np.linalg.norm(d[:, :2], axis=1)
        steep = np.abs(dz) > 2.0 * slope * dxy       # g monotonic: one crossing at most
        lo, hi = np.zeros(n), np.zeros(n)
        found = np.zeros(n, bool)
        i = np.nonzero(live & steep)[0]
        if i.size:
            ok = g(i, t1[i]) <= 0.0
            i = i[ok]
            lo[i], hi[i], found[i] = t0[i], t1[i], True
        i = np.nonzero(live & ~steep)[0]
        if i.size:                                   # march to the first sign change
            prev = t0[i].copy()
            todo = np.arange(i.size)                 # the rays still marching
            for step in range(1, MARCH + 1):
                t = t0[i] + (t1[i] - t0[i]) * (step / MARCH)
                c = todo[g(i[todo], t[todo]) <= 0.0]
                lo[i[c]], hi[i[c]], found[i[c]] = prev[c], t[c], True
                todo = np.setdiff1d(todo, c, assume_unique=True)
                if todo.size == 0:
                    break
                prev = t
        i = np.nonzero(found)[0]
        a, b = lo[i], hi[i]
        # Newton's method kept inside the bracket g(a) > 0 >= g(b), which every step narrows;
        # a step that leaves it bisects instead; a ray stops where |g| <= 1e-12
        t = 0.5 * (a + b)
        act = np.arange(i.size)                      # the rays not there yet
        for _ in range(NEWTON):
            val, dg = g(i[act], t[act], True)
            live = np.abs(val) > 1e-12
            act, val, dg = act[live], val[live], dg[live]
            if act.size == 0:
                break
            pos = val > 0.0
            a[act], b[act] = np.where(pos, t[act], a[act]), np.where(pos, b[act], t[act])
            with np.errstate(divide="ignore", invalid="ignore"):
                step = t[act] - val / dg
            t[act] = np.where((step >= a[act]) & (step <= b[act]), step,
                              0.5 * (a[act] + b[act]))
        val = g(i, t)
        bad = np.abs(val) > 1e-10
        if bad.any():                                # the rare slow one: bisection
            a, b = a[bad], b[bad]
            for _ in range(48):
                m = 0.5 * (a + b)
                pos = g(i[bad], m) > 0.0
                a, b = np.where(pos, m, a), np.where(pos, b, m)
            t[bad] = b
        t_hit[i] = t
    p = o + np.where(np.isfinite(t_hit), t_hit, 0.0)[:, None] * d
    inside = (np.abs(p[:, 0]) <= pool.HALF) & (np.abs(p[:, 1]) <= pool.HALF)
    return np.where(inside, t_hit, np.inf)


def refract_in(d, nrm, ior):
    """Rays from the air through the surface (upward normals): (new directions, 1 - F)."""
    cos_i = -np.einsum("ij,ij->i", d, nrm)
    eta = 1.0 / ior
    f, cos_t = fresnel(cos_i, eta)
    t = eta * d + (eta * cos_i - cos_t)[:, None] * nrm
    return t / np.linalg.norm(t, axis=1, keepdims=True), 1.0 - f
