"""Photons guided toward what the camera sees: a learned distribution of directions per light.

Photons leave a light in its own distribution (a point light: every direction alike; an area
light: by the cosine), so a light outside a room lit through a small window, or a lamp over a
large scene of which the camera sees a corner, sends most of them where no visible point is:
they land outside the grid over the visible points and are dropped.  Each guided light keeps a
map of GUIDE_ROWS x GUIDE_COLS bins of directions in its frame (rows equal steps of the cosine
to its axis from ``zmin`` to 1, columns equal steps of the azimuth: every bin the same solid
angle), and the photon pass counts, per bin, the photons stored in the grid
(kernels/light/guide.h, photon_pass.cl).  From those counts ``guide_weights`` makes each bin's
weight its native share times its yield (stores per photon sent there), with a prior, and a
photon then takes its direction from that map with probability 1 - GUIDE_NATIVE or from the
light's own distribution otherwise; its flux is divided by the mixture's density, so the image
is the same in expectation (Peter & Pietrek 1998, "Importance driven construction of photon
maps"; the visibility of photon paths of Hachisuka & Jensen 2011 at the grain of a light's
directions).  The native share bounds a photon's flux at 1 / GUIDE_NATIVE of its native flux.

Guided: point lights (and spheres), round spots, rectangle and disc area lights, the most
powerful MAX_GUIDED of them.  Suns, the world and emissive meshes keep their own
distribution."""
from __future__ import annotations

import math

import numpy as np

from ppm_engine.scene.arrays import LIGHT_AREA_ELLIPSE, LIGHT_AREA_RECT, LIGHT_POINT, LIGHT_SPOT

GUIDE_ROWS = 16
GUIDE_COLS = 32
GUIDE_BINS = GUIDE_ROWS * GUIDE_COLS
# floats per guided light in the scene's `guide` buffer: zmin, the native share, two spare,
# then the bins' CDF
GUIDE_STRIDE = GUIDE_BINS + 4
MAX_GUIDED = 16
# the share of a guided light's photons that keep its own distribution (defensive sampling)
GUIDE_NATIVE = 0.3
# a bin's yield starts as this many photons' worth of the light's mean yield; no weight falls
# below GUIDE_FLOOR of the largest (times its native share)
GUIDE_PRIOR = 32.0
GUIDE_FLOOR = 0.01

_POINT, _SPOT = LIGHT_POINT, LIGHT_SPOT
_AREAS = (LIGHT_AREA_RECT, LIGHT_AREA_ELLIPSE)


def spot_cone_cos(light) -> float:
    """The cosine of the cone a spot's photons are drawn in (light_types.h spot_sample_cos),
    or None where its frame is scaled unevenly (its cone not round: not guided)."""
    sx = float(np.linalg.norm(light["axis_x"][:3])) * float(light["spot_scale_z"])
    sy = float(np.linalg.norm(light["axis_y"][:3])) * float(light["spot_scale_z"])
    if abs(sx - 1.0) < 1e-4 and abs(sy - 1.0) < 1e-4:
        return float(light["spot_cos_half"])
    return None


def _zmin(light) -> float | None:
    t = int(light["type"])
    if t == _POINT:
        return -1.0
    if t == _SPOT:
        return spot_cone_cos(light)
    if t in _AREAS:
        return 0.0
    return None


def native_mass(light, zmin: float, sub: int = 8) -> np.ndarray:
    """(GUIDE_BINS,) the share of the light's emitted power in each bin, by its own
    distribution: uniform for points and spheres, the cosine for area lights, a spot's
    smoothstep falloff over its cone."""
    t = int(light["type"])
    rows = zmin + (1.0 - zmin) * np.arange(GUIDE_ROWS + 1) / GUIDE_ROWS
    if t in _AREAS:
        row = (rows[1:] ** 2 - rows[:-1] ** 2)
    elif t == _SPOT:
        # the falloff is a function of the cosine to the axis (a round cone): averaged over
        # sub-steps of each row
        z = rows[:-1, None] + (rows[1:] - rows[:-1])[:, None] * (np.arange(sub) + 0.5) / sub
        smooth = float(light["spot_smooth"])
        c0 = float(light["spot_cos_half"])
        if smooth > 0:
            s = np.clip((z - c0) / smooth, 0.0, 1.0)
            att = s * s * (3.0 - 2.0 * s)
        else:
            att = (z > c0).astype(np.float64)
        row = att.mean(axis=1)
    else:
        row = np.ones(GUIDE_ROWS)
    m = np.repeat(row / GUIDE_COLS, GUIDE_COLS)
    total = m.sum()
    return m / total if total > 0 else m


class Guides:
    """The guided lights of a scene and what their photon counts taught so far."""

    def __init__(self, lights: np.ndarray, power: np.ndarray):
        """``lights``: the scene's LIGHT_DTYPE rows; ``power``: the emitter table's power of
        each (its first rows are the lights')."""
        n = lights.shape[0]
        self.slot = np.full(max(n, 1), -1, np.int32)
        order = np.argsort(-power[:n], kind="stable") if n else np.zeros(0, int)
        chosen = []
        for i in order:
            if len(chosen) == MAX_GUIDED or not power[i] > 0:
                break
            z = _zmin(lights[i])
            if z is not None and z < 1.0:
                chosen.append((int(i), z))
        self.lights = np.array([i for i, _ in chosen], np.int64)
        self.zmin = np.array([z for _, z in chosen], np.float64)
        self.slot[self.lights] = np.arange(len(chosen), dtype=np.int32)
        self.mass = np.array([native_mass(lights[i], z) for i, z in chosen]).reshape(
            len(chosen), GUIDE_BINS)
        self.reset()

    def __len__(self) -> int:
        return self.lights.size

    def reset(self) -> None:
        """A new render: nothing learned, every photon in its light's own distribution."""
        k = len(self)
        self.native = np.ones(k)
        self.cdf_weights = self.mass.copy()
        self.sent = np.zeros((k, GUIDE_BINS))     # photons expected into each bin so far
        self.stored_seen = np.zeros((k, GUIDE_BINS))

    def table(self) -> np.ndarray:
        """The scene's `guide` buffer: per guided light zmin, its native share, two spare,
        the CDF of its bins' weights."""
        k = len(self)
        t = np.zeros((max(k, 1), GUIDE_STRIDE), np.float32)
        for s in range(k):
            t[s, 0] = self.zmin[s]
            t[s, 1] = self.native[s]
            w = self.cdf_weights[s]
            c = np.cumsum(w)
            t[s, 4:] = c / c[-1] if c[-1] > 0 else (np.arange(GUIDE_BINS) + 1) / GUIDE_BINS
            t[s, -1] = 1.0
        return t.reshape(-1)

    def mixture(self) -> np.ndarray:
        """(k, GUIDE_BINS) the share of a light's photons that fall in each bin now."""
        g = self.cdf_weights / np.maximum(self.cdf_weights.sum(axis=1, keepdims=True), 1e-300)
        a = self.native[:, None]
        return a * self.mass + (1.0 - a) * g

    def count_sent(self, photons: int, pmf: np.ndarray) -> None:
        """A pass emitted ``photons`` by the pick ``pmf`` (per emitter): the photons expected
        in each bin (the kernels count only the stores)."""
        if len(self):
            self.sent += photons * pmf[self.lights][:, None] * self.mixture()

    def learn(self, stored: np.ndarray) -> bool:
        """``stored``: (k, GUIDE_BINS) the stores counted per bin since the render began.  The
        bins' weights become native share times yield (with the prior); returns whether
        anything was learned (some light stored photons)."""
        k = len(self)
        if not k:
            return False
        stored = np.asarray(stored, np.float64).reshape(k, GUIDE_BINS)
        changed = False
        for s in range(k):
            st, se = stored[s], self.sent[s]
            if not st.sum() > 0 or not se.sum() > 0:
                continue
            mean = st.sum() / se.sum()
            y = (st + GUIDE_PRIOR * mean * self.mass[s] * GUIDE_BINS) / (
                se + GUIDE_PRIOR * self.mass[s] * GUIDE_BINS)
            w = self.mass[s] * y
            w = np.maximum(w, GUIDE_FLOOR * w.max() * (self.mass[s] > 0))
            self.cdf_weights[s] = w
            self.native[s] = GUIDE_NATIVE
            changed = True
        return changed


def bin_solid_angle(zmin: float) -> float:
    return 2.0 * math.pi * (1.0 - zmin) / GUIDE_BINS
