"""Render settings shared by the Blender properties, the CLI and the core (no bpy here).

``RenderOptions.validate()`` refuses bad values with a message a user can act on; nothing is
clamped silently.  ``properties.py`` exposes the same fields (and the same limits, from
``LIMITS``) on ``scene.ppm``.
"""
from __future__ import annotations

import dataclasses

from .errors import PPMError


class SettingsError(PPMError, ValueError):
    """A setting a user gave is outside what the engine accepts."""


# name: (min, max, default, description) -- the single source of the limits.
LIMITS = {
    "passes": (1, 1_000_000, 64, "Maximum number of SPPM passes (eye pass, photon pass, gather)"),
    "time_limit": (0.0, 1e7, 0.0, "Stop after this many seconds (0 = no limit)"),
    "photons_per_pass": (1, 1 << 26, 1 << 18,
                         "Photons emitted per pass (the paper uses 512x512 = 262144)"),
    "initial_radius": (0.0, 1e9, 0.0,
                       "Initial gather radius in scene units (0 = automatic, from the pixel "
                       "footprint at each visible point)"),
    "alpha": (0.0, 1.0, 0.7,
              "Fraction of new photons kept per pass; smaller shrinks the radius faster"),
    "max_bounces": (0, 1024, 12, "Maximum bounces of eye and photon paths"),
    "seed": (0, 2**31 - 1, 0, "Random seed"),
}


@dataclasses.dataclass
class RenderOptions:
    passes: int = LIMITS["passes"][2]
    time_limit: float = LIMITS["time_limit"][2]
    photons_per_pass: int = LIMITS["photons_per_pass"][2]
    initial_radius: float = LIMITS["initial_radius"][2]
    alpha: float = LIMITS["alpha"][2]
    max_bounces: int = LIMITS["max_bounces"][2]
    seed: int = LIMITS["seed"][2]
    device: str = ""               # OpenCL device name (substring); "" = default choice
    exact_gather: bool = False     # debug/reference mode: gather every photon, not the stochastic map

    def validate(self) -> "RenderOptions":
        for name, (lo, hi, _default, _desc) in LIMITS.items():
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise SettingsError(f"{name} must be a number, got {v!r}")
            if v != v or not (lo <= v <= hi):
                raise SettingsError(f"{name} = {v!r} is outside [{lo}, {hi}]")
        if not (0.0 < self.alpha < 1.0):
            raise SettingsError(f"alpha = {self.alpha!r} must lie strictly between 0 and 1")
        return self

    def replace(self, **changes) -> "RenderOptions":
        return dataclasses.replace(self, **changes)
