"""Per-pixel SPPM accumulators on the device and their resolve to a linear RGBA image.

FILM_BUFFERS lists the film's per-pixel buffers once.  kernels/shared.h gets it as the X-macro
FILM_DATA (ppm_engine/tools/shared_header.py), from which kernels/integrator/pass_state.h makes
the kernels' film parameters (``film_NAME``) and the struct every kernel reads them from
(``const Film *film``); Launch binds them by name from ``Film.args``.  A new per-pixel buffer
is one row here."""
from __future__ import annotations

import dataclasses

import numpy as np

from ppm_engine.scene.arrays import FILTER_BLACKMAN_HARRIS, FILTER_BOX, FILTER_GAUSSIAN


def has_fp64(device) -> bool:
    """Whether the OpenCL device does double precision (cl_khr_fp64)."""
    d = device.cl_device
    if "cl_khr_fp64" in d.extensions:
        return True
    try:
        return bool(d.double_fp_config)
    except Exception:       # devices without doubles may refuse the query
        return False


@dataclasses.dataclass(frozen=True)
class PassBuffer:
    """One buffer of a pass's state (FILM_BUFFERS, passes/eye.py VP_BUFFERS, photon_map.py
    PHOTON_BUFFERS)."""
    name: str             # the struct's field (film->name) and, prefixed, the kernels' parameter
    element: np.dtype     # one element as the kernels read it (its C type: shared_header)
    bytes: int            # bytes per pixel where a film or the visible points allocate it (a
                          # sum of 32 bytes: a double4, or a float4 and its compensation)
    what: str             # what it holds (the allocation's label, the header's comment)
    fill: int | None = 0  # the uint32 a new film clears it to; None: not cleared


_F4 = np.dtype((np.float32, 4))
_F, _U = np.dtype(np.float32), np.dtype(np.uint32)

# The film's per-pixel buffers, in the kernels' parameter order (film_NAME).
FILM_BUFFERS = (
    PassBuffer("direct_pass", _F4, 16, "this pass's sample (rgb, 1; eye_pass.cl)"),
    PassBuffer("direct", _F4, 32, "sum of the direct samples (rgb, count)"),
    PassBuffer("photon_sum", _F4, 32, "S = sum of Phi / R^2"),
    PassBuffer("nstat", _F, 4, "N, the photons gathered"),
    PassBuffer("radius", _F, 4, "R, the gather radius"),
    PassBuffer("radius0", _F, 4, "the initial radius"),
    PassBuffer("moments", _F4, 32,
               "(sum y, sum y^2, photons while active, passes) of samples y"),
    PassBuffer("active", _U, 4, "1 while the pixel is sampled (adaptive sampling)", fill=1),
    PassBuffer("error", _F, 4, "estimated error (adaptive sampling)", fill=None),
    PassBuffer("aux_albedo", _F4, 16, "denoising albedo (sum, count)"),
    PassBuffer("aux_normal", _F4, 16, "denoising normal (sum, count)"),
    PassBuffer("transparency", _F, 4, "sum of the passes' transparency (transparent film)"),
    PassBuffer("lt_pass", _F, 12, "light tracing: this pass's splats (rgb)"),
    PassBuffer("lt_sum", _F4, 32, "light tracing: sum of the passes' splats"),
    PassBuffer("image", _F4, 16, "the resolved image (film_resolve)", fill=None),
)
# allocated only for a render that connects photons to the camera (enable_light_tracing)
_LIGHT_TRACING = ("lt_pass", "lt_sum")


class Film:
    """Per pixel: the sums direct (rgb, sample count) and S = sum of Phi_i / R_i^2 (the paper's
    tau / R^2), N and R, the moments of its per-pass samples (for its own photon count and its
    noise) and whether it is still sampled; photons emitted in all on the host (a Python int).

    The sums are 32 bytes per pixel: double4 where the device has cl_khr_fp64, else a float4
    sum and its Neumaier compensation (``fp64=False`` forces that path;
    kernels/integrator/progressive.cl). A float32 sum would lose ~1e-5 of a constant pixel in
    2,000 passes and ~1e-4 in 10,000 (docs/STABILITY.md).  The eye pass writes each pass's sample to
    ``direct_pass``; the progressive update (passes/update.py) adds it to the sums.

    A pixel's photon term is (S / pi + its light tracing's sum) / the photons emitted while it
    was active, so a pixel that adaptive sampling stopped keeps its value while the others go
    on."""

    def __init__(self, device, width: int, height: int, fp64: bool | None = None):
        self.device = device
        self.width, self.height = width, height
        self.fp64 = has_fp64(device) if fp64 is None else bool(fp64)
        self.n_pixels = width * height
        # FILM_BUFFERS, each an attribute of its name (the light tracing's below)
        self._allocate(b for b in FILM_BUFFERS if b.name not in _LIGHT_TRACING)
        # the photons' light tracing (photon_pass.cl connect_camera): this pass's splats (rgb
        # per pixel, float atomics) and their sum over the passes the pixel was active in (its
        # photon count is the photon term's, moments.z).  44 bytes per pixel (87 MiB at
        # 1920 x 1080), allocated only for a render that connects photons to the camera
        # (enable_light_tracing): most scenes have no photon pass at all
        self.light_tracing = False
        self.lt_pass = self.lt_sum = device.buffer(16, "film (light tracing: none)")
        self.exposure = 1.0           # Cycles' film exposure (the camera's; Renderer sets it)
        self.photons_emitted = 0      # Python int: exact at any count
        self.prog = device.programs.get("integrator/progressive.cl",
                                        {"PPM_FP64": True} if self.fp64 else {})

    def _allocate(self, rows) -> None:
        """Each of the FILM_BUFFERS ``rows`` allocated as the attribute of its name, per pixel,
        and filled where its row says (in order on the queue: no wait)."""
        import pyopencl as cl
        n, dev = self.n_pixels, self.device
        for b in rows:
            buf = dev.buffer(b.bytes * n, f"film ({b.what})")
            setattr(self, b.name, buf)
            if b.fill is not None:
                cl.enqueue_fill_buffer(dev.queue, buf, np.uint32(b.fill), 0, b.bytes * n)

    @property
    def args(self) -> dict:
        """The film's buffers by the kernels' parameter names (film_NAME; FILM_BUFFERS)."""
        return {f"film_{b.name}": getattr(self, b.name) for b in FILM_BUFFERS}

    def enable_light_tracing(self) -> None:
        """Allocate (zeroed) the light tracing's per-pixel buffers: the render connects its
        photons to the camera (Renderer.lt_kappa > 0)."""
        if self.light_tracing:
            return
        self._allocate(b for b in FILM_BUFFERS if b.name in _LIGHT_TRACING)
        self.light_tracing = True

    def disable_light_tracing(self) -> None:
        """Leave the light tracing's sums out of the image from now on and free them (the
        render stopped connecting photons to the camera: Renderer.iterate)."""
        if self.light_tracing:
            self.light_tracing = False
            self.lt_pass = self.lt_sum = self.device.buffer(16, "film (light tracing: none)")

    def resolve(self, wait_for=None):
        """Enqueue the resolve; returns (event, host array (h, w, 4) float32, row 0 = bottom)."""
        import pyopencl as cl
        q = self.device.queue
        n = self.n_pixels
        ev = self.prog.launch("film_resolve", "resolve")(
            q, n, wait_for=wait_for, **self.args, lt=np.uint32(self.light_tracing),
            exposure=np.float32(self.exposure), n=np.uint32(n))
        out = np.empty((self.height, self.width, 4), np.float32)
        ev2 = cl.enqueue_copy(q, out, self.image, wait_for=[ev], is_blocking=False)
        return ev2, out

    def aux_passes(self) -> dict:
        """The extra render passes, (h, w, channels) float32, row 0 = bottom: "Denoising
        Albedo" (mean), "Denoising Normal" (unit mean), "PPM Radius" (R), "PPM Photons" (N)."""
        return aux_passes(self.read("aux_albedo", np.float32, 4),
                          self.read("aux_normal", np.float32, 4), self.read("radius"),
                          self.read("nstat"))

    def read(self, name: str, dtype=np.float32, channels: int = 1) -> np.ndarray:
        import pyopencl as cl
        out = np.empty((self.height, self.width, channels) if channels > 1
                       else (self.height, self.width), dtype)
        cl.enqueue_copy(self.device.queue, out, getattr(self, name))
        return out

    def read_sum(self, name: str) -> np.ndarray:
        """The value of a float4 sum (``direct``, ``photon_sum``, ``lt_sum``, ``moments``): float64
        (h, w, 4); ``lt_sum`` is zeros where the render traces no light to the camera."""
        if name == "lt_sum" and not self.light_tracing:
            return np.zeros((self.height, self.width, 4))
        if self.fp64:
            return self.read(name, np.float64, 4)
        raw = self.read(name, np.float32, 8).reshape(self.height, self.width, 2, 4)
        return raw.astype(np.float64).sum(axis=2)


FILTER_TABLE_SIZE = 256

# the splat's filter table (filter_density): samples over [-reach, reach]
FILTER_SAMPLES = 257


def aux_passes(albedo, normal, radius, photons) -> dict:
    """The extra render passes, (h, w, channels) float32, from the film's sums (a Film's, or
    merged parts', parts.Part): "Denoising Albedo" the mean albedo (its sum over its weight,
    channel 3), "Denoising Normal" the mean normal made unit, "PPM Radius" and "PPM Photons"
    as they are ((h, w) or (h, w, 1))."""
    out = {}
    for name, a in (("Denoising Albedo", albedo), ("Denoising Normal", normal)):
        with np.errstate(invalid="ignore", divide="ignore"):
            v = np.where(a[..., 3:] > 0, a[..., :3] / a[..., 3:], 0.0)
            if name == "Denoising Normal":
                length = np.linalg.norm(v, axis=-1, keepdims=True)
                v = np.where(length > 0, v / length, 0.0)
        out[name] = v.astype(np.float32)
    for name, a in (("PPM Radius", radius), ("PPM Photons", photons)):
        out[name] = (a if a.ndim == 3 else a[..., None]).astype(np.float32)
    return out


def filter_density(width: float, kind: int) -> tuple[np.ndarray, float]:
    """The pixel filter's 1D density (integral 1, pixel units) sampled at FILTER_SAMPLES points
    over [-reach, reach], and reach: the filter the eye pass samples (film.filter_shape)."""
    x, f = filter_shape(width, kind, FILTER_SAMPLES)
    area = 0.5 * float(((f[1:] + f[:-1]) * np.diff(x)).sum())     # the trapezoid rule
    return (f / area).astype(np.float32), float(x[-1])


def filter_shape(width: float, kind: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Cycles' pixel filter (scene/film.cpp) in pixel units: n offsets x over its support and
    its unnormalised weights f there.  Supports as Cycles': the box +-width/2 (Blender's Cycles
    passes width 1 for the box), the Gaussian +-1.5 width with sigma width/4, Blackman-Harris
    +-width.  Blackman-Harris of width <= 0 (files from before the filter type): the one-pixel
    box."""
    if kind == FILTER_BOX or width <= 0:
        w = width if kind == FILTER_BOX and width > 0 else 1.0
        return np.linspace(-0.5 * w, 0.5 * w, n), np.ones(n)
    reach = 1.5 * width if kind == FILTER_GAUSSIAN else width
    x = np.linspace(-reach, reach, n)
    if kind == FILTER_GAUSSIAN:
        return x, np.exp(-8.0 * (x / width) ** 2)
    v = 2 * np.pi * (x / (2 * width) + 0.5)
    f = 0.35875 - 0.48829 * np.cos(v) + 0.14128 * np.cos(2 * v) - 0.01168 * np.cos(3 * v)
    return x, np.maximum(f, 0.0)


def filter_table(width: float, kind: int = FILTER_BLACKMAN_HARRIS) -> np.ndarray:
    """Inverse CDF of the pixel filter (filter_shape), sampled at FILTER_TABLE_SIZE uniform u;
    the eye pass jitters each axis with it."""
    u = (np.arange(FILTER_TABLE_SIZE) + 0.5) / FILTER_TABLE_SIZE
    x, f = filter_shape(width, kind, 4097)
    cdf = np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(x))])
    cdf /= cdf[-1]
    return np.interp(u, cdf, x).astype(np.float32)
