"""Blender lights -> LIGHT_DTYPE rows in Cycles' units (tests/test_cycles_lights.py
checks each light type against Cycles)."""
from __future__ import annotations

import math

import numpy as np

from ppm_engine.scene.arrays import (
    LIGHT_AREA_ELLIPSE,
    LIGHT_AREA_RECT,
    LIGHT_DTYPE,
    LIGHT_FLAG_SOFT_FALLOFF,
    LIGHT_POINT,
    LIGHT_SPOT,
    LIGHT_SUN,
)


def strength(light) -> np.ndarray:
    """colour x energy x 2^exposure (x blackbody colour when enabled), as Cycles."""
    c = np.array(light.color[:3], np.float64) * light.energy \
        * 2.0 ** getattr(light, "exposure", 0.0)
    if getattr(light, "use_temperature", False) and hasattr(light, "temperature_color"):
        c = c * np.array(light.temperature_color[:3], np.float64)
    return c


def export_light(light, m: np.ndarray, warn) -> np.ndarray:
    row = np.zeros(1, LIGHT_DTYPE)
    S = strength(light)
    cols = m[:3, :3]
    z = -cols[:, 2]
    zn = np.linalg.norm(z)
    row["position"] = m[:3, 3]
    row["direction"] = z / zn if zn > 0 else (0, 0, -1)
    t = light.type
    if t in ('POINT', 'SPOT'):
        row["type"] = LIGHT_POINT if t == 'POINT' else LIGHT_SPOT
        row["emit"] = S / (4 * math.pi)
        r = float(light.shadow_soft_size)
        row["radius"] = r
        if r > 0 and not getattr(light, "normalize", True):
            row["emit"] = S / (4 * math.pi) * (4 * math.pi * r * r)   # L = P/pi: area not divided
        if getattr(light, "use_soft_falloff", False):
            row["flags"] |= LIGHT_FLAG_SOFT_FALLOFF
        if t == 'SPOT':
            half = float(light.spot_size) / 2
            row["spot_cos_half"] = math.cos(half)
            row["spot_smooth"] = (1 - math.cos(half)) * float(light.spot_blend)
            row["axis_x"], row["axis_y"] = cols[:, 0], cols[:, 1]
            row["spot_scale_z"] = 1.0 / zn if zn > 0 else 1.0
    elif t == 'SUN':
        row["type"] = LIGHT_SUN
        row["emit"] = S
        row["radius"] = float(light.angle) / 2
    elif t == 'AREA':
        shape = light.shape
        ellipse = shape in ('DISK', 'ELLIPSE')
        row["type"] = LIGHT_AREA_ELLIPSE if ellipse else LIGHT_AREA_RECT
        sx = float(light.size)
        sy = float(light.size_y) if shape in ('RECTANGLE', 'ELLIPSE') else sx
        ax, ay = cols[:, 0] * sx, cols[:, 1] * sy          # object scale enlarges the light
        row["axis_x"], row["axis_y"] = ax, ay
        area = np.linalg.norm(np.cross(ax, ay)) * (math.pi / 4 if ellipse else 1.0)
        if getattr(light, "normalize", True):
            row["emit"] = S / (math.pi * area) if area > 0 else 0.0
        else:
            row["emit"] = S / math.pi
        if getattr(light, "spread", math.pi) < math.pi - 1e-6:
            warn(f"Light '{light.name}': area light spread is not supported; it is rendered "
                 "with the full 180° spread")
    else:
        warn(f"Light '{light.name}' of type {t} is not supported and is skipped")
        return np.zeros(0, LIGHT_DTYPE)
    return row
