"""The camera and the film of the exact-geometry references (exact_caustic.py, exact_pool.py), in
NumPy: a bpy scene's pinhole camera and frame as they trace them (``camera_fields``), world points
to raster positions and back (``project``, ``camera_rays``), Cycles' Blackman-Harris pixel filter
and the splat through it, and the pixels whose filter window a mask leaves clear.  ``s`` is a
reference's Setup: anything with the camera fields (eye, axes, frame, width, height, clip,
filter_width)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# the Blackman-Harris window's coefficients (Cycles' film: the filter spans twice the scene's
# filter width, so half its span is the width); its mean over the span is A0
BH = (0.35875, -0.48829, 0.14128, -0.01168)


@dataclass
class CameraSetup:
    """The camera and film every exact reference traces (camera_fields reads them from bpy);
    each reference's setup adds its scene's light and geometry."""
    eye: np.ndarray              # camera position (3,)
    axes: np.ndarray             # (3, 3), columns: the camera's x, y, z in world space
    frame: tuple                 # (x_left, x_right, y_bottom, y_top) on the plane at depth 1
    width: int
    height: int
    clip: tuple                  # (start, end) depth
    filter_width: float          # the scene's, in pixels: the filter reaches this far
    film_exposure: float

    @property
    def pixel_area(self) -> float:
        """A pixel's area on the image plane at depth 1."""
        x0, x1, y0, y1 = self.frame
        return (x1 - x0) * (y1 - y0) / (self.width * self.height)


def camera_fields(scene) -> dict:
    """The camera, frame and film of a bpy scene as the exact references trace them
    (CameraSetup's fields); refuses what they do
    not model: a lens, a border, another pixel filter."""
    cam = scene.camera
    if cam is None or cam.data.type != 'PERSP':
        raise ValueError("the exact reference renders through a perspective (pinhole) camera")
    if cam.data.dof.use_dof:
        raise ValueError("the exact reference renders through a pinhole: turn depth of field off")
    m = np.array(cam.matrix_world, float)
    axes = m[:3, :3] / np.linalg.norm(m[:3, :3], axis=0)
    corners = np.array([tuple(v) for v in cam.data.view_frame(scene=scene)], float)
    unit = corners[:, :2] / -corners[:, 2:3]          # the frame projected to depth 1
    frame = (unit[:, 0].min(), unit[:, 0].max(), unit[:, 1].min(), unit[:, 1].max())
    r = scene.render
    if r.use_border:
        raise ValueError("the exact reference renders the whole frame: turn the border off")
    c = scene.cycles
    if c.pixel_filter_type != 'BLACKMAN_HARRIS':
        raise ValueError("the exact reference implements Cycles' Blackman-Harris filter only")
    return {"eye": m[:3, 3].copy(), "axes": axes, "frame": frame,
            "width": int(r.resolution_x * r.resolution_percentage / 100),
            "height": int(r.resolution_y * r.resolution_percentage / 100),
            "clip": (cam.data.clip_start, cam.data.clip_end),
            "filter_width": float(c.filter_width), "film_exposure": float(c.film_exposure)}


# --- the pixel filter ------------------------------------------------------------------------
def filter_1d(x, width: float):
    """Cycles' Blackman-Harris pixel filter in one dimension, normalised (integral 1 over pixel
    units): zero beyond ``width`` pixels from the centre (the window spans 2 x width)."""
    x = np.asarray(x, float)
    span = 2.0 * width
    c = np.cos(2.0 * np.pi * (x / span + 0.5))
    # cos 2v and cos 3v from cos v (one cosine: the splat evaluates this per photon and pixel)
    f = BH[0] + BH[1] * c + BH[2] * (2.0 * c * c - 1.0) + BH[3] * c * (4.0 * c * c - 3.0)
    return np.where(np.abs(x) < width, f / (BH[0] * span), 0.0)


def splat(acc: np.ndarray, s, px, py, value) -> None:
    """Add ``value`` at raster positions (px, py) (pixels, y down) to ``acc`` (h * w, rows top-
    down) through the pixel filter: pixel (i, j) gets f(px - i - 1/2) f(py - j - 1/2)."""
    reach, w, h = s.filter_width, s.width, s.height
    n = math.floor(2.0 * reach) + 1           # pixels per axis the filter can reach
    i0 = np.ceil(px - 0.5 - reach).astype(np.int64)
    j0 = np.ceil(py - 0.5 - reach).astype(np.int64)
    wx = [filter_1d(px - (i0 + a + 0.5), reach) for a in range(n)]
    wy = [filter_1d(py - (j0 + b + 0.5), reach) for b in range(n)]
    for b in range(n):
        j = j0 + b
        for a in range(n):
            i = i0 + a
            ok = (i >= 0) & (i < w) & (j >= 0) & (j < h)
            acc += np.bincount((j * w + i)[ok], (value * wx[a] * wy[b])[ok], minlength=w * h)


# --- the camera's projection ----------------------------------------------------------------
def project(s, p):
    """Raster positions (px, py; pixels, y down), unit directions to the eye, distances and
    cosines at the camera of world points p; ``ok`` where p is in front, inside the clip range
    and close enough to the frame for the filter to reach a pixel."""
    v = p - s.eye
    local = v @ np.linalg.inv(s.axes).T      # the matrix's inverse: its float32 axes are not
                                             # exactly orthonormal
    depth = -local[:, 2]
    dist = np.linalg.norm(v, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        xc, yc = local[:, 0] / depth, local[:, 1] / depth
    x0, x1, y0, y1 = s.frame
    px = (xc - x0) / (x1 - x0) * s.width
    py = (y1 - yc) / (y1 - y0) * s.height
    r = s.filter_width
    ok = ((depth > s.clip[0]) & (depth < s.clip[1]) & (px > -r) & (px < s.width + r)
          & (py > -r) & (py < s.height + r))
    return px, py, -v / dist[:, None], dist, depth / dist, ok


def camera_rays(s, px, py):
    """Unit world directions of the camera rays through raster positions (px, py)."""
    x0, x1, y0, y1 = s.frame
    local = np.stack([x0 + px / s.width * (x1 - x0), y1 - py / s.height * (y1 - y0),
                      -np.ones_like(px)], -1)
    d = local @ s.axes.T
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def jump_cells(kind) -> np.ndarray:
    """Flat indices of a 2-D grid's cells to refine where ``kind`` (what each cell's centre
    sees) changes: the cells on either side of a change and their neighbours (an edge that
    only clips a cell's corner changes nothing between centres next to it but does between its
    neighbours)."""
    jump = np.zeros(kind.shape, bool)
    dx = kind[:, 1:] != kind[:, :-1]
    jump[:, 1:] |= dx
    jump[:, :-1] |= dx
    dy = kind[1:] != kind[:-1]
    jump[1:] |= dy
    jump[:-1] |= dy
    near = jump.copy()
    near[1:] |= jump[:-1]
    near[:-1] |= jump[1:]
    grown = near.copy()
    grown[:, 1:] |= near[:, :-1]
    grown[:, :-1] |= near[:, 1:]
    return np.flatnonzero(grown)


def filtered(s, values, gx, gy, k: int) -> np.ndarray:
    """(h * w), rows top-down: the pixels' filter integrals of ``values`` given on the grid of
    raster points gx (columns) x gy (rows), ``k`` per pixel and axis (cell area 1 / k^2).
    Pixel i's weight of the column at x is f(x - i - 1/2) / k (the same for rows), so a pixel
    is sum f(x) f(y) v / k^2: two matrix products instead of a splat per point."""
    r = s.filter_width
    fx = filter_1d(gx[None, :] - (np.arange(s.width)[:, None] + 0.5), r) / k
    fy = filter_1d(gy[None, :] - (np.arange(s.height)[:, None] + 0.5), r) / k
    return (fy @ values @ fx.T).ravel()


def window_clear(bad, s, k: int, pad: int, offset: float) -> np.ndarray:
    """(h, w) bool, rows top-down: the pixels whose filter window (the points strictly within
    the filter's reach of the pixel centre) holds no ``bad`` point of a grid whose point (row,
    column) m lies at raster (m - pad + offset) / k, by an integral image."""
    r = s.filter_width
    cum = np.zeros((bad.shape[0] + 1, bad.shape[1] + 1), np.int64)
    cum[1:, 1:] = bad.astype(np.int64).cumsum(0).cumsum(1)

    def span(n):       # |(m - pad + offset) / k - (i + 1/2)| < r
        c = np.arange(n) + 0.5
        lo = np.floor((c - r) * k - offset).astype(np.int64) + 1 + pad
        hi = np.ceil((c + r) * k - offset).astype(np.int64) - 1 + pad
        return lo, hi + 1
    xl, xh = span(s.width)
    yl, yh = span(s.height)
    count = (cum[yh][:, xh] - cum[yl][:, xh] - cum[yh][:, xl] + cum[yl][:, xl])
    return count == 0
