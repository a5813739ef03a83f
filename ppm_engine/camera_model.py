"""Cameras as the kernels read them (scene_arrays.CAMERA_DTYPE): a row from the camera's
placement and extent, and the extents of Cycles' perspective and orthographic cameras (sensor
fit)."""
from __future__ import annotations

import numpy as np

from .scene_arrays import CAMERA_DTYPE, CAMERA_PERSP


def make_camera(*, type=CAMERA_PERSP, width, height, to_world, extent, shift=(0.0, 0.0),
                clip=(0.1, 1000.0), region=None, aperture_radius=0.0, focus_distance=10.0,
                aperture_blades=0, aperture_rotation=0.0, aperture_ratio=1.0,
                filter_width=0.0) -> np.ndarray:
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
    cam["filter_width"] = filter_width
    return cam


def perspective_extent(width: int, height: int, lens_mm: float, sensor_mm: float,
                       fit: str = "AUTO", sensor_height_mm: float | None = None,
                       pixel_aspect=(1.0, 1.0)) -> tuple[float, float, float]:
    """Cycles' view plane: (w_ext, h_ext, fit) at distance 1, as Cycles' camera (sensor
    fit AUTO: the larger image side gets the sensor width; tests/test_export.py checks it against Blender's
    projection).

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
