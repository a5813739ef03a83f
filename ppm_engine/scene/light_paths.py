"""Cycles' Light Paths settings as this engine honours them (no bpy here).

A scene carries them (``SceneArrays.light_paths``, exported from ``scene.cycles``, Cycles'
defaults without the add-on); ``RenderOptions.max_bounces`` overrides every bounce limit for
tests and analytic scenes.  The kernels read one LIGHT_PATHS_DTYPE record (kernels/shared.h
LightPaths, the scene buffer ``light_paths``).  What each setting means for a photon mapper is
in docs/SHADING.md, "Light Paths":

- bounce limits count the bounces of the whole light path, eye and photon parts together, as
  Cycles counts them from the camera (kernels/integrator/path_state.h path_limit, path_join);
- clamping scales each contribution whose path-traced sample would exceed the limit, as
  Cycles' film does per sample (photons: the sample a camera path would make of the same light
  path, kernels/integrator/path_state.h);
- the caustics toggles remove a glossy or refractive scattering right after a diffuse one;
- Filter Glossy blurs, as Cycles does, the glossy lobes a camera path meets after a bounce of
  low density, and the light through them is the eye paths', not the photons'
  (kernels/integrator/path_state.h).
"""
from __future__ import annotations

import numpy as np

from ppm_engine.errors import SceneError

# the caustics toggles (LightPaths.flags)
LP_CAUSTICS_REFLECTIVE = 1
LP_CAUSTICS_REFRACTIVE = 2

LIGHT_PATHS_DTYPE = np.dtype([
    ("max_bounces", np.int32),            # Total: bounces of any kind
    ("diffuse_bounces", np.int32),
    ("glossy_bounces", np.int32),         # glossy and singular reflections
    ("transmission_bounces", np.int32),   # transmissions (glass, translucency)
    ("volume_bounces", np.int32),         # scatterings in media an eye path may take
    ("transparent_max_bounces", np.int32),  # transparent surfaces a path crosses
    ("clamp_direct", np.float32),         # Cycles' limit on a sample's r + g + b (3 x the
                                          # setting; 0: off): light with no bounce
    ("clamp_indirect", np.float32),       # the same for light with one bounce or more
    ("filter_glossy", np.float32),        # Filter Glossy (Cycles' blur_glossy; 0: off)
    ("flags", np.uint32),                 # LP_CAUSTICS_REFLECTIVE | LP_CAUSTICS_REFRACTIVE
    # the render's split of the closures (RenderOptions.gather_roughness, caustic_roughness;
    # with_roughness): runtime values, so that a new setting builds no kernel
    ("gather_roughness", np.float32),     # microfacet lobes this rough (sqrt alpha) are gathered
    ("caustic_roughness", np.float32),    # followed glossy lobes this rough are the eye paths'
])

# the engine's defaults of RenderOptions.gather_roughness and caustic_roughness (a record made
# without a render, and a file written before the fields existed, holds them)
GATHER_ROUGHNESS = 0.7
CAUSTIC_ROUGHNESS = 0.7

BOUNCE_FIELDS = ("max_bounces", "diffuse_bounces", "glossy_bounces", "transmission_bounces",
                 "volume_bounces", "transparent_max_bounces")

# Cycles' Light Paths defaults (scene.cycles of a new file, Blender 5.0)
CYCLES_DEFAULTS = {"max_bounces": 12, "diffuse_bounces": 4, "glossy_bounces": 4,
                   "transmission_bounces": 12, "volume_bounces": 0,
                   "transparent_max_bounces": 8, "sample_clamp_direct": 0.0,
                   "sample_clamp_indirect": 10.0, "blur_glossy": 1.0,
                   "caustics_reflective": True, "caustics_refractive": True}
# A scene that carries no Cycles settings (made by hand or by a script, or saved before the
# engine read them): the engine's own defaults, as before it read them: 12 bounces of every
# kind, no clamping (an unbiased image), Cycles' transparent limit
ENGINE_DEFAULTS = {**CYCLES_DEFAULTS, "diffuse_bounces": 12, "glossy_bounces": 12,
                   "sample_clamp_indirect": 0.0, "blur_glossy": 0.0}
MAX_BOUNCES_LIMIT = 1024      # Cycles' hard maximum of every bounce setting


class LightPathsError(SceneError, ValueError):
    """A Light Paths setting outside what Cycles accepts (a hand-edited or hostile file): the
    message names the setting (Render Properties > Light Paths)."""


def make_light_paths(**settings) -> np.ndarray:
    """One LIGHT_PATHS_DTYPE record from Cycles' setting names (scene.cycles), Cycles' defaults
    for those not given; raises LightPathsError naming a setting that is out of range."""
    unknown = set(settings) - set(CYCLES_DEFAULTS)
    if unknown:
        raise TypeError(f"not Light Paths settings: {sorted(unknown)}")
    s = {**CYCLES_DEFAULTS, **settings}
    lp = np.zeros(1, LIGHT_PATHS_DTYPE)
    for name in BOUNCE_FIELDS:
        v = s[name]
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) \
                or not 0 <= v <= MAX_BOUNCES_LIMIT:
            raise LightPathsError(f"Light Paths: {_label(name)} = {v!r} must be a whole number "
                                  f"from 0 to {MAX_BOUNCES_LIMIT}")
        lp[name] = v
    for name, field in (("sample_clamp_direct", "clamp_direct"),
                        ("sample_clamp_indirect", "clamp_indirect")):
        v = float(s[name])
        if not (v >= 0.0) or not np.isfinite(v):
            raise LightPathsError(f"Light Paths: {_label(name)} = {s[name]!r} must be a number "
                                  "of 0 (off) or more")
        lp[field] = 3.0 * v            # Cycles compares r + g + b with 3 x the setting
    v = float(s["blur_glossy"])
    if not (v >= 0.0) or not np.isfinite(v):
        raise LightPathsError(f"Light Paths: Filter Glossy = {s['blur_glossy']!r} must be a "
                              "number of 0 or more")
    lp["filter_glossy"] = v
    lp["gather_roughness"], lp["caustic_roughness"] = GATHER_ROUGHNESS, CAUSTIC_ROUGHNESS
    lp["flags"] = ((LP_CAUSTICS_REFLECTIVE if s["caustics_reflective"] else 0)
                   | (LP_CAUSTICS_REFRACTIVE if s["caustics_refractive"] else 0))
    return lp


def check_light_paths(lp: np.ndarray) -> None:
    """Raises LightPathsError when a record (a loaded file's) holds a value no setting gives."""
    r = lp[0]
    for name in BOUNCE_FIELDS:
        if not 0 <= int(r[name]) <= MAX_BOUNCES_LIMIT:
            raise LightPathsError(f"Light Paths: {_label(name)} = {int(r[name])} is outside "
                                  f"0 to {MAX_BOUNCES_LIMIT}")
    for name in ("clamp_direct", "clamp_indirect", "filter_glossy", "gather_roughness",
                 "caustic_roughness"):
        v = float(r[name])
        if not (np.isfinite(v) and v >= 0.0):
            raise LightPathsError(f"Light Paths: {name.replace('_', ' ')} = {v!r} must be a "
                                  "number of 0 or more")


def _label(name: str) -> str:
    return {"max_bounces": "Total", "transparent_max_bounces": "Transparent",
            "sample_clamp_direct": "Clamp Direct",
            "sample_clamp_indirect": "Clamp Indirect"}.get(
                name, name.replace("_bounces", "").title())


def engine_defaults() -> np.ndarray:
    """The record of a scene that carries no Cycles settings (ENGINE_DEFAULTS)."""
    return make_light_paths(**ENGINE_DEFAULTS)


def from_cycles(cycles) -> np.ndarray:
    """The record of a scene's Cycles settings (``scene.cycles``; None: the add-on is absent,
    Cycles' defaults)."""
    if cycles is None:
        return make_light_paths()
    got = {}
    for name, default in CYCLES_DEFAULTS.items():
        v = getattr(cycles, name, None)
        got[name] = default if v is None else type(default)(v)
    return make_light_paths(**got)


def with_max_bounces(lp: np.ndarray, bounces: int | None) -> np.ndarray:
    """``lp`` with every bounce limit but the transparent one set to ``bounces`` (the override
    of RenderOptions.max_bounces), or ``lp`` itself for None."""
    if bounces is None:
        return lp
    out = lp.copy()
    for name in BOUNCE_FIELDS[:-1]:
        out[name] = bounces
    return out


def with_roughness(lp: np.ndarray, gather_roughness: float,
                   caustic_roughness: float) -> np.ndarray:
    """``lp`` with a render's split of the closures (RenderOptions.gather_roughness and
    caustic_roughness): which lobes are gathered, which followed ones are the eye paths'."""
    out = lp.copy()
    out["gather_roughness"], out["caustic_roughness"] = gather_roughness, caustic_roughness
    return out


def describe(lp: np.ndarray) -> str:
    """One line for logs and the render's stats."""
    r = lp[0]
    clamp = ", ".join(f"clamp {k} {r['clamp_' + k] / 3:g}" for k in ("direct", "indirect")
                      if r["clamp_" + k] > 0)
    return (f"bounces {r['max_bounces']} (diffuse {r['diffuse_bounces']}, glossy "
            f"{r['glossy_bounces']}, transmission {r['transmission_bounces']}, transparent "
            f"{r['transparent_max_bounces']})" + (f", {clamp}" if clamp else ""))
