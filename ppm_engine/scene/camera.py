"""Cameras as the kernels read them (CAMERA_DTYPE, kernels/shared.h Camera): a row from the
camera's placement, extent and film (pixel filter, transparency, exposure), and the extents of
Cycles' perspective and orthographic cameras (sensor fit)."""
from __future__ import annotations

import numpy as np

CAMERA_PERSP = 0
CAMERA_ORTHO = 1

CAMERA_DTYPE = np.dtype([
    ("type", np.int32),               # CAMERA_PERSP | CAMERA_ORTHO
    ("width", np.int32),              # full frame in pixels (resolution percentage applied)
    ("height", np.int32),
    ("region", np.int32, 4),          # x0, y0, w, h of the rendered rectangle (border), pixels,
                                      # y up
    ("to_world", np.float32, (3, 4)), # camera-to-world rows, scale removed; camera looks down -Z
    ("extent", np.float32, 2),        # w_ext, h_ext: view-plane size at distance 1 (ortho: in
                                      # units)
    ("shift", np.float32, 2),         # shift_x * fit, shift_y * fit
    ("clip", np.float32, 2),          # clip_start, clip_end (planar depth)
    ("aperture_radius", np.float32),  # 0 = pinhole
    ("focus_distance", np.float32),
    ("aperture_blades", np.int32),
    ("aperture_rotation", np.float32),
    ("aperture_ratio", np.float32),
    ("filter_width", np.float32),     # pixel filter width (pixels); Blackman-Harris with 0: a
                                      # one-pixel box (film.filter_table)
    ("filter_type", np.int32),        # FILTER_BLACKMAN_HARRIS | FILTER_BOX | FILTER_GAUSSIAN
    ("film_transparent", np.int32),   # FILM_TRANSPARENT (| FILM_TRANSPARENT_GLASS): camera rays
                                      # that reach the world make alpha, not radiance
    ("glass_roughness", np.float32),  # transparent glass: the largest roughness that stays clear
    ("exposure", np.float32),         # Cycles' film exposure: the image's scale
])
# Cycles' pixel filters (scene.cycles.pixel_filter_type); 0 is what files before the field meant
FILTER_BLACKMAN_HARRIS, FILTER_BOX, FILTER_GAUSSIAN = 0, 1, 2
FILM_TRANSPARENT, FILM_TRANSPARENT_GLASS = 1, 2


def make_camera(*, type=CAMERA_PERSP, width, height, to_world, extent, shift=(0.0, 0.0),
                clip=(0.1, 1000.0), region=None, aperture_radius=0.0, focus_distance=10.0,
                aperture_blades=0, aperture_rotation=0.0, aperture_ratio=1.0,
                filter_width=0.0, filter_type=FILTER_BLACKMAN_HARRIS, film_transparent=0,
                glass_roughness=0.1, exposure=1.0) -> np.ndarray:
    """One CAMERA_DTYPE record (used by the exporter, tests and scripted scenes)."""
    cam = np.zeros(1, CAMERA_DTYPE)
    cam["type"] = type
    cam["width"], cam["height"] = width, height
    cam["region"] = region if region is not None else (0, 0, width, height)
    cam["to_world"] = np.asarray(to_world, np.float32)[:3, :4]
    cam["extent"], cam["shift"], cam["clip"] = extent, shift, clip
    cam["aperture_radius"], cam["focus_distance"] = aperture_radius, focus_distance
    cam["aperture_blades"], cam["aperture_rotation"] = aperture_blades, aperture_rotation
    cam["aperture_ratio"] = aperture_ratio
    cam["filter_width"], cam["filter_type"] = filter_width, filter_type
    cam["film_transparent"], cam["glass_roughness"] = film_transparent, glass_roughness
    cam["exposure"] = exposure
    return cam


def perspective_extent(width: int, height: int, lens_mm: float, sensor_mm: float,
                       fit: str = "AUTO", sensor_height_mm: float | None = None,
                       pixel_aspect=(1.0, 1.0)) -> tuple[float, float, float]:
    """Cycles' view plane: (w_ext, h_ext, fit) at distance 1, as Cycles' camera (sensor
    fit AUTO: the larger image side gets the sensor width; tests/test_export_camera.py checks it
    against Blender's projection).

    ``fit`` is the fitted dimension's extent; the camera shift is ``shift * fit``."""
    return _fit_extent(width, height, None, lens_mm, sensor_mm, fit, sensor_height_mm, pixel_aspect)


def ortho_extent(width: int, height: int, ortho_scale: float, fit: str = "AUTO",
                 pixel_aspect=(1.0, 1.0)) -> tuple[float, float, float]:
    """Orthographic view plane: (w_ext, h_ext, fit) in scene units."""
    return _fit_extent(width, height, ortho_scale, None, None, fit, None, pixel_aspect)


def _fit_extent(width, height, ortho_scale, lens_mm, sensor_mm, fit, sensor_height_mm,
                pixel_aspect):
    xr, yr = width * pixel_aspect[0], height * pixel_aspect[1]
    horizontal = (xr > yr) if fit == "AUTO" else (fit == "HORIZONTAL")
    if ortho_scale is not None:
        f = ortho_scale
    else:
        sensor = sensor_mm if (fit == "AUTO" or fit == "HORIZONTAL") else sensor_height_mm
        f = sensor / lens_mm
    if horizontal:
        return f, f * yr / xr, f
    return f * xr / yr, f, f


def camera_from_view(view_matrix, window_matrix, width: int, height: int,
                     **film) -> np.ndarray:
    """The camera record of a 3D viewport: its view matrix (world to view, as
    RegionView3D.view_matrix) and OpenGL projection (RegionView3D.window_matrix), both 4 x 4,
    for a ``width`` x ``height`` region.  Perspective and orthographic projections, with
    Blender's off-centre frustum (a camera view's shift, the zoomed camera frame) as the
    shift; the clipping planes from the projection.  ``film``: make_camera's film fields (pixel
    filter, transparency, exposure) and depth of field.

    For a perspective P, a point at distance 1 ahead maps x = (u + P[0,2]) / P[0,0] for u in
    [-1, 1] across the region: extent 2 / P[0,0], shift P[0,2] / P[0,0]; orthographic,
    x = (u - P[0,3]) / P[0,0]."""
    v = np.asarray(view_matrix, np.float64).reshape(4, 4)
    p = np.asarray(window_matrix, np.float64).reshape(4, 4)
    if not (np.isfinite(v).all() and np.isfinite(p).all()) or p[0, 0] == 0 or p[1, 1] == 0:
        raise ValueError("the view's matrices are not invertible")
    to_world = np.linalg.inv(v)
    cols = to_world[:3, :3]
    to_world[:3, :3] = cols / np.maximum(np.linalg.norm(cols, axis=0, keepdims=True), 1e-30)
    extent = (2.0 / p[0, 0], 2.0 / p[1, 1])
    perspective = p[3, 3] == 0.0
    if perspective:
        shift = (p[0, 2] / p[0, 0], p[1, 2] / p[1, 1])
        a, b = p[2, 2], p[2, 3]
        clip = (b / (a - 1.0), b / (a + 1.0))
        kind = CAMERA_PERSP
    else:
        shift = (-p[0, 3] / p[0, 0], -p[1, 3] / p[1, 1])
        a, b = p[2, 2], p[2, 3]
        clip = ((b + 1.0) / a, (b - 1.0) / a)
        kind = CAMERA_ORTHO
    width, height = max(int(width), 1), max(int(height), 1)
    return make_camera(type=kind, width=width, height=height, to_world=to_world[:3],
                       extent=extent, shift=shift, clip=clip, **film)


def scaled_camera(camera: np.ndarray, divider: int) -> np.ndarray:
    """The same view at 1/``divider`` of the resolution (the viewport's first passes): the
    frame divided, rounded up, and the region (a render region) the pixels that cover it; the
    view plane unchanged."""
    if divider <= 1:
        return camera
    cam = camera.copy()
    w, h = int(camera["width"][0]), int(camera["height"][0])
    cam["width"], cam["height"] = -(-w // divider), -(-h // divider)
    x0, y0, rw, rh = (int(v) for v in camera["region"][0])
    x1, y1 = -(-(x0 + rw) // divider), -(-(y0 + rh) // divider)
    x0, y0 = x0 // divider, y0 // divider
    cam["region"] = (x0, y0, max(x1 - x0, 1), max(y1 - y0, 1))
    return cam


def region_fraction(camera: np.ndarray) -> tuple:
    """The rendered region of ``camera`` as fractions (x0, y0, w, h) of its frame: where the
    viewport draws the image."""
    w, h = int(camera["width"][0]), int(camera["height"][0])
    x0, y0, rw, rh = (int(v) for v in camera["region"][0])
    return (x0 / w, y0 / h, rw / w, rh / h)


def with_border(camera: np.ndarray, border) -> np.ndarray:
    """``camera`` rendering only ``border`` (x0, y0, x1, y1 as fractions of its frame, y up:
    Blender's render region), at least one pixel; ``camera`` itself for None."""
    if border is None:
        return camera
    w, h = int(camera["width"][0]), int(camera["height"][0])
    b = np.clip(np.asarray(border, np.float64), 0.0, 1.0)
    x0, y0 = int(b[0] * w), int(b[1] * h)
    x1, y1 = max(int(b[2] * w), x0 + 1), max(int(b[3] * h), y0 + 1)
    x0, y0 = min(x0, w - 1), min(y0, h - 1)
    cam = camera.copy()
    cam["region"] = (x0, y0, min(x1, w) - x0, min(y1, h) - y0)
    return cam
