"""Slow, readable NumPy versions of what the kernels do: the test oracle.

Everything here follows the kernels' definitions exactly (same hash, same acceptance rules),
in float64 where the kernels use float32 unless bit-exactness matters (hashing)."""
from __future__ import annotations

import numpy as np

# the gather's acceptance rules (kernels/integrator/gather.cl)
from ppm_engine.render.passes.gather import DISC_HALF_THICKNESS, NORMAL_COS_MIN


# --- rays ------------------------------------------------------------------------------------
def closest_hits(origins, dirs, tmax, tris, chunk=256):
    """Brute force: (t, triangle index) of the closest hit per ray, t = -1 / index -1 on miss."""
    v0 = tris[:, 0].astype(np.float64)
    e1 = tris[:, 1].astype(np.float64) - v0
    e2 = tris[:, 2].astype(np.float64) - v0
    n = origins.shape[0]
    best_t = np.full(n, -1.0)
    best_i = np.full(n, -1, np.int64)
    for s in range(0, n, chunk):
        o = origins[s:s + chunk, None, :].astype(np.float64)
        d = dirs[s:s + chunk, None, :].astype(np.float64)
        p = np.cross(d, e2[None])
        det = np.einsum("rtk,tk->rt", p, e1)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            sv = o - v0[None]
            u = np.einsum("rtk,rtk->rt", sv, p) * inv
            q = np.cross(sv, e1[None])
            v = np.einsum("rtk,rtk->rt", np.broadcast_to(d, q.shape), q) * inv
            t = np.einsum("tk,rtk->rt", e2, q) * inv
            ok = (det != 0) & (u >= 0) & (u <= 1) & (v >= 0) & (u + v <= 1) & (t > 0) & \
                 (t < tmax[s:s + chunk, None])
        t = np.where(ok, t, np.inf)
        i = np.argmin(t, axis=1)
        tt = t[np.arange(t.shape[0]), i]
        hit = np.isfinite(tt)
        best_t[s:s + chunk] = np.where(hit, tt, -1.0)
        best_i[s:s + chunk] = np.where(hit, i, -1)
    return best_t, best_i


# --- the hash (bit-exact with kernels/rng.h and kernels/integrator/hash.h)
# ------------------------------
def pcg_hash(v):
    v = np.asarray(v, np.uint32)
    with np.errstate(over="ignore"):
        state = v * np.uint32(747796405) + np.uint32(2891336453)
        word = ((state >> ((state >> np.uint32(28)) + np.uint32(4))) ^ state) * np.uint32(277803737)
    return (word >> np.uint32(22)) ^ word


def cell_of(p, bmin, inv_cell):
    c = (p.astype(np.float32) - np.asarray(bmin, np.float32)) * np.float32(inv_cell)
    return np.floor(np.clip(c, -1e15, 1e15)).astype(np.int64)


def cell_hash(c, mask):
    c = np.asarray(c, np.int64)
    lo = (c & 0xffffffff).astype(np.uint32)
    hi = ((c >> 32) & 0xffffffff).astype(np.uint32)
    x, y, z = (lo ^ hi).T
    with np.errstate(over="ignore"):
        h = (x * np.uint32(73856093)) ^ (y * np.uint32(19349663)) ^ (z * np.uint32(83492791))
    return pcg_hash(h) & np.uint32(mask)


def hash_counts(ph_pos, bmin, inv_cell, table_size):
    """n per entry: how many photons hash to each entry."""
    h = cell_hash(cell_of(ph_pos, bmin, inv_cell), table_size - 1)
    return np.bincount(h, minlength=table_size).astype(np.uint32)


# --- gather and update ----------------------------------------------------------------------
def gather_exact(vp_pos, vp_nrm, radius, ph_pos, ph_nrm, ph_wi, ph_flux):
    """Range sum over all photons with the kernel's acceptance rules: (phi (n,3), M (n,))."""
    phi = np.zeros((vp_pos.shape[0], 3))
    M = np.zeros(vp_pos.shape[0])
    for i in range(vp_pos.shape[0]):     # test oracle: clarity over speed
        d2 = ((ph_pos - vp_pos[i]) ** 2).sum(axis=1)
        off_plane = np.abs((ph_pos - vp_pos[i]) @ vp_nrm[i])
        ok = ((d2 <= radius[i] ** 2) & (off_plane <= DISC_HALF_THICKNESS * radius[i])
              & (ph_nrm @ vp_nrm[i] >= NORMAL_COS_MIN) & (ph_wi @ vp_nrm[i] > 0))
        M[i] = ok.sum()
        phi[i] = ph_flux[ok].sum(axis=0)
    return phi, M


def ppm_update(alpha, M, phi, N, R, tau):
    """Closed form of the progressive update (kernels/integrator/progressive.cl ppm_update)."""
    M, N, R = (np.asarray(a, np.float64) for a in (M, N, R))
    tau, phi = np.asarray(tau, np.float64), np.asarray(phi, np.float64)
    active = M > 0
    n_new = np.where(active, N + alpha * M, N)
    ratio = np.where(active, n_new / np.where(active, N + M, 1.0), 1.0)
    tau_new = (tau + np.where(active[..., None], phi, 0.0)) * ratio[..., None]
    return n_new, R * np.sqrt(ratio), tau_new


def pack_unit(n):
    """Octahedral packing of unit vectors into uint32 (kernels/geom/geometry.h pack_unit)."""
    n = np.asarray(n, np.float32)
    n = n / np.abs(n).sum(axis=-1, keepdims=True)
    x, y, z = n[..., 0], n[..., 1], n[..., 2]
    ex = np.where(z >= 0, x, (1 - np.abs(y)) * np.copysign(1, x))
    ey = np.where(z >= 0, y, (1 - np.abs(x)) * np.copysign(1, y))
    qx = np.clip(np.rint((ex * 0.5 + 0.5) * 65535), 0, 65535).astype(np.uint32)
    qy = np.clip(np.rint((ey * 0.5 + 0.5) * 65535), 0, 65535).astype(np.uint32)
    return qx | (qy << np.uint32(16))
