"""Per-pixel SPPM accumulators on the device and their resolve to a linear RGBA image."""
from __future__ import annotations

import numpy as np


class Film:
    """direct (rgb sum, sample count), tau (rgb), N, R per pixel; photons emitted (host, exact)."""

    def __init__(self, device, width: int, height: int):
        import pyopencl as cl
        self.device = device
        self.width, self.height = width, height
        n = self.n_pixels = width * height
        self.direct = device.buffer(16 * n, "film (direct light)")
        self.tau = device.buffer(16 * n, "film (tau)")
        self.nstat = device.buffer(4 * n, "film (N)")
        self.radius = device.buffer(4 * n, "film (radius)")
        self.image_buf = device.buffer(16 * n, "film (image)")
        self.aux_albedo = device.buffer(16 * n, "film (albedo)")
        self.aux_normal = device.buffer(16 * n, "film (normal)")
        for b, size in ((self.direct, 16), (self.tau, 16), (self.nstat, 4), (self.radius, 4),
                        (self.aux_albedo, 16), (self.aux_normal, 16)):
            cl.enqueue_fill_buffer(device.queue, b, np.uint32(0), 0, size * n)
        self.photons_emitted = 0      # Python int: exact at any count
        self.prog = device.programs.get("progressive.cl")

    def resolve(self, wait_for=None):
        """Enqueue the resolve; returns (event, host array (h, w, 4) float32, row 0 = bottom)."""
        import pyopencl as cl
        q = self.device.queue
        inv = 1.0 / (np.pi * self.photons_emitted) if self.photons_emitted else 0.0
        n = self.n_pixels
        ev = self.prog.film_resolve(q, (_round(n),), None, self.direct, self.tau, self.radius,
                                    np.float32(inv), self.image_buf, np.uint32(n),
                                    wait_for=wait_for)
        out = np.empty((self.height, self.width, 4), np.float32)
        ev2 = cl.enqueue_copy(q, out, self.image_buf, wait_for=[ev], is_blocking=False)
        return ev2, out

    def aux_passes(self) -> dict:
        """Extra render passes, (h, w, c) float32, row 0 = bottom: 'Denoising Albedo' and
        'Denoising Normal' (averaged over the passes whose camera ray found a diffuse surface),
        'PPM Radius' (current gather radius) and 'PPM Photons' (the progressive count N)."""
        albedo = self.read("aux_albedo", channels=4)
        normal = self.read("aux_normal", channels=4)
        with np.errstate(invalid="ignore", divide="ignore"):
            a = np.where(albedo[..., 3:] > 0, albedo[..., :3] / albedo[..., 3:], 0.0)
            nrm = normal[..., :3]
            length = np.linalg.norm(nrm, axis=-1, keepdims=True)
            nrm = np.where(length > 0, nrm / length, 0.0)
        return {"Denoising Albedo": a.astype(np.float32),
                "Denoising Normal": nrm.astype(np.float32),
                "PPM Radius": self.read("radius")[..., None],
                "PPM Photons": self.read("nstat")[..., None]}

    def read(self, name: str, dtype=np.float32, channels: int = 1) -> np.ndarray:
        import pyopencl as cl
        out = np.empty((self.height, self.width, channels) if channels > 1
                       else (self.height, self.width), dtype)
        cl.enqueue_copy(self.device.queue, out, getattr(self, name))
        return out


def _round(n: int, wg: int = 64) -> int:
    return max(wg, (n + wg - 1) // wg * wg)


FILTER_TABLE_SIZE = 256


def filter_table(width: float) -> np.ndarray:
    """Inverse CDF of Cycles' Blackman-Harris pixel filter (scene/film.cpp: the function is
    evaluated with its width doubled, so its support is +-width pixels), sampled at
    FILTER_TABLE_SIZE uniform u; the eye pass jitters each axis with it.  width <= 0: the box
    filter (offsets uniform in the pixel)."""
    u = (np.arange(FILTER_TABLE_SIZE) + 0.5) / FILTER_TABLE_SIZE
    if width <= 0:
        return (u - 0.5).astype(np.float32)
    x = np.linspace(-width, width, 4097)
    v = 2 * np.pi * (x / (2 * width) + 0.5)
    f = 0.35875 - 0.48829 * np.cos(v) + 0.14128 * np.cos(2 * v) - 0.01168 * np.cos(3 * v)
    cdf = np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(x))])
    cdf /= cdf[-1]
    return np.interp(u, cdf, x).astype(np.float32)
