"""Render settings shared by the Blender properties, the CLI and the core (no bpy here).

``RenderOptions.validate()`` refuses bad values with a message a user can act on; nothing is
clamped silently.  ``properties.py`` exposes the same fields (and the same limits, from
``LIMITS``) on ``scene.ppm``.
"""
from __future__ import annotations

import dataclasses
import math

from ppm_engine.errors import PPMError
from ppm_engine.render.denoise import DenoiseSettings
from ppm_engine.scene.light_paths import CAUSTIC_ROUGHNESS, GATHER_ROUGHNESS, MAX_BOUNCES_LIMIT


class SettingsError(PPMError, ValueError):
    """A setting a user gave is outside what the engine accepts."""


# name: (min, max, default, description) -- the single source of the limits.
LIMITS = {
    "passes": (1, 1_000_000, 64, "Maximum number of SPPM passes (eye pass, photon pass, gather)"),
    "time_limit": (0.0, 1e7, 0.0, "Stop after this many seconds (0 = no limit)"),
    "photons_per_pass": (1, 1 << 26, 1 << 18,
                         "Photons emitted per pass when the automatic count is off (the paper "
                         "uses 512x512 = 262144)"),
    "initial_radius": (0.0, 1e9, 0.0,
                       "Initial gather radius in scene units (0 = automatic, from the pixel "
                       "footprint at each visible point)"),
    "alpha": (0.0, 1.0, 0.7,
              "Fraction of new photons kept per pass; smaller shrinks the radius faster"),
    "seed": (0, 2**31 - 1, 0, "Random seed"),
    "noise_threshold": (0.0, 1.0, 0.0,
                        "Stop sampling a pixel once its estimated noise is below this (as Cycles' "
                        "adaptive sampling; 0 = off); the render ends when every pixel has"),
}

# The viewport's own settings (Rendered shading in the 3D view;
# ppm_engine/render/viewport_session.py), as Cycles' viewport samples: name: (min, max, default,
# description)
VIEWPORT_LIMITS = {
    "viewport_passes": (1, 1_000_000, 1024,
                        "Passes of the viewport's Rendered shading (as Cycles' viewport "
                        "samples); it refines until then and stops"),
    "viewport_time_limit": (0.0, 1e7, 0.0,
                            "Stop refining the viewport after this many seconds (0 = no "
                            "limit)"),
    "viewport_start_resolution": (8, 16384, 64,
                                  "After every change the viewport's first pass renders about "
                                  "this many pixels squared, then the resolution doubles each "
                                  "pass up to full (Cycles' Start Pixels)"),
}

# The automatic photon count (RenderOptions.photons_per_pass = None, the default): one photon
# per pixel of the render region per pass -- the paper's 512^2 photons at 512 x 512 pixels --
# within these bounds.  Chosen from the error-against-time curves (docs/BENCHMARKS.md, "Settings
# chosen by measurement"): at a fixed budget the error is flat between 1/2 and 1 photon per pixel
# per pass and grows on both sides (2^18 photons per pass at 128 x 128 pixels: 3x the Cornell box's
# error at 16 s), because the eye pass (direct light, anti-aliasing, the radius shrinking) and the
# photon pass must progress together.
AUTO_PHOTONS_MIN, AUTO_PHOTONS_MAX = 1 << 12, 1 << 22
# Caustic photons aimed at the casters (kernels/light/aim.h) nearly all reach one and go on
# through the glass, where one emitted as all photons are mostly lands on a diffuse surface and
# ends: each costs some ten times as much.  A render aims this share of its photon count per
# pass (automatic or set; or the share of uniform photons that would reach a caster, if
# larger), at least AIMED_PHOTONS_MIN: the eye pass and the photons progress together
# (docs/BENCHMARKS.md, "Settings chosen by measurement").
AIMED_PHOTONS_SHARE = 1 / 16
AIMED_PHOTONS_MIN = 1 << 10

# How indirect light is estimated (RenderOptions.indirect):
#   "photons": the paper's SPPM, every bounce of indirect light from the photon map;
#   "paths": eye paths continue from the visible points through diffuse bounces with next-event
#            estimation (kernels/integrator/indirect_paths.h), photons only for caustics (the light
# paths
#            whose first scattering is by a mirror, glass or a smooth glossy lobe);
#   "auto": per scene, from a pilot of photons (Renderer.caustic_fraction): "photons" when most
#           of the light's first scatterings are caustic ones (a bulb inside glass, a room lit
#           through windows), "paths" otherwise.
INDIRECT_MODES = ("auto", "photons", "paths")
# Light tracing against the merge (RenderOptions.light_tracing): the balance heuristic with the
# merge's density kappa pi r^2 p_E (camera_connect.h merge_factor); kappa 1 is VCM's.  Chosen by
# measurement (docs/BENCHMARKS.md, "Settings chosen by measurement")
LIGHT_TRACING_KAPPA = 0.1
# How each pixel's gather radius shrinks over the passes (RenderOptions.radius_schedule,
# kernels/integrator/progressive.cl film_update):
#   "pixel": the paper's (Hachisuka & Jensen 2009), from the photons the pixel gathered;
#   "global": Knaus & Zwicker 2011 (VCM's), R_k^2 = R_1^2 prod (j + alpha) / (j + 1), the same
#             sequence for every pixel, independent of the samples (so any sampler may place the
#             camera rays); R_1 each pass's own visible point's footprint.  Every pass is then
#             a function of its index alone (Renderer.independent): ranges of passes render
#             apart, on other devices or machines, and their films add up exactly
#             (ppm_engine/render/parts.py).
# Their index is film_update's `schedule` (RADIUS_PIXEL, RADIUS_GLOBAL).
RADIUS_SCHEDULES = ("pixel", "global")
# the global schedule's default alpha (RenderOptions.global_alpha): at 0.7 (the per-pixel
# statistics' alpha) its radii shrank too slowly, 1.7-2x the per-pixel schedule's error on
# glass_caustic; docs/BENCHMARKS.md, "Passes rendered apart"
GLOBAL_ALPHA = 0.3


def global_radius_scale(pass_index: int, alpha: float) -> float:
    """RenderOptions.radius_schedule "global" (Knaus & Zwicker 2011): pass ``pass_index``'s
    (from 0) radius over the initial one, sqrt(prod_{j<k} (j + alpha) / (j + 1)) for the k-th
    pass (k = pass_index + 1), = sqrt(Gamma(k + alpha) / (Gamma(1 + alpha) Gamma(k + 1))),
    ~ k^((alpha - 1) / 2): a function of the pass's index alone, computed in float64 from the
    same formula wherever the pass runs (passes/eye.py: the eye pass multiplies its visible
    point's footprint radius by it)."""
    k = pass_index + 1
    return math.exp(0.5 * (math.lgamma(k + alpha) - math.lgamma(1.0 + alpha)
                           - math.lgamma(k + 1.0)))


# "auto" chooses "photons" above this fraction of caustic first scatterings (docs/BENCHMARKS.md,
# "Settings chosen by measurement")
AUTO_PHOTONS_CAUSTIC_FRACTION = 0.5


@dataclasses.dataclass
class RenderOptions:
    passes: int = LIMITS["passes"][2]
    time_limit: float = LIMITS["time_limit"][2]
    photons_per_pass: int | None = None   # None: automatic (photons_for)
    initial_radius: float = LIMITS["initial_radius"][2]
    alpha: float = LIMITS["alpha"][2]
    # None: the scene's Light Paths (SceneArrays.light_paths: its Cycles settings); a number:
    # every bounce limit (total and per kind, not the transparent one) for this render, for
    # tests, analytic scenes and the benchmark (light_paths.with_max_bounces)
    max_bounces: int | None = None
    seed: int = LIMITS["seed"][2]
    noise_threshold: float = LIMITS["noise_threshold"][2]
    device: str = ""               # OpenCL device name (substring); "" = default choice
    indirect: str = "auto"         # INDIRECT_MODES
    exact_gather: bool = False     # reference mode: gather every photon, not the stochastic map
    # microfacet lobes at least this rough hold visible points and photons (the gather evaluates
    # them); smoother ones are followed by the eye path.  Chosen by measurement (docs/BENCHMARKS.md,
    # "Materials and shader programs"); a setting to measure with, not in the UI.  Both roughness
    # settings reach the kernels in the Light Paths record (light_paths.with_roughness), not as
    # -D flags: changing them builds nothing.
    gather_roughness: float = GATHER_ROUGHNESS
    # followed glossy reflections at least this rough are the eye paths' (next-event estimation
    # through them, as Cycles), smoother ones (and refractions below gather_roughness) make
    # caustic photons.  The default, gather_roughness's, leaves every followed lobe to caustic
    # photons: measured, eye paths through glossy lobes were no better at equal time on four
    # scenes (docs/BENCHMARKS.md, "Settings chosen by measurement"); a setting to measure with, not
    # in the UI.  With Filter Glossy above 1 / pi every glossy reflection that is not singular is
    # the eye paths' whatever this says (casters.caustic_roughness).
    caustic_roughness: float = CAUSTIC_ROUGHNESS
    # Skips of work a scene does not need, each on by default; off only to measure what it saves
    # (python -m ppm_engine bench --skips) and in the tests that check it changes nothing.
    specialize: bool = True        # kernels built for the scene's features (False: every feature)
    # with specialize: also every feature an edit of values can switch on (features.
    # VALUE_FEATURES), the closure list at its longest: the viewport's and the previews' kernels
    editable: bool = False
    skip_unneeded_photon_pass: bool = True   # False: photon pass, hash and gather run even when
                                             # they cannot add anything
    skip_unseen_photons: bool = True   # False: the photon grid covers the whole scene, so photons
                                       # outside the visible points' bounds are stored too
    skip_blind_light_tracing: bool = True   # False: photons are connected to the camera even
                                            # where no pixel sees what that renders
    skip_unaimed_caustics: bool = True   # False: caustic photons leave the emitters as all
                                         # photons do, not aimed at the casters (kernels/light/
                                         # aim.h), so most miss them and are dropped
    skip_unused_photons: bool = True   # False: a photon pass every pass even while almost
                                       # no photon reaches the image (Renderer.photons_due)
    skip_unguided_photons: bool = True   # False: photons of point, spot and area lights
                                         # keep the light's own directions, not guided toward
                                         # where they were stored (ppm_engine/scene/guide.py)
    # path space filtering (passes/path_filter.py): with eye paths for the indirect light, the
    # light past a path's second vertex averaged over the paths whose second vertices share a
    # cell (the cells shrink over the passes); False: each path's own
    path_filter: bool = True
    # the photons' second strategy: each stored photon also connected to the camera (light
    # tracing), combined with the merge by MIS (kernels/integrator/photon_pass.cl connect_camera);
    # for a pinhole camera only
    light_tracing: bool = True
    # RADIUS_SCHEDULES; a setting to measure with (docs/BENCHMARKS.md, "Settings chosen by
    # measurement"); the global one wherever passes are split (ranges, devices, Dask)
    radius_schedule: str = "pixel"
    # the global schedule's alpha (Knaus & Zwicker's: R_k^2 ~ k^(alpha - 1)); ``alpha`` is the
    # per-pixel statistics' (the share of new photons kept).  Chosen by measurement
    # (docs/BENCHMARKS.md, "Passes rendered apart"); not in the UI
    global_alpha: float = GLOBAL_ALPHA
    # more than one: these OpenCL devices (names or keys, as ``device``) render the image
    # together, each its share of the passes (render/multi_device.py MultiRenderer; the global
    # schedule, whatever radius_schedule says); ``device`` is then not read
    devices: tuple = ()
    # the image denoised through Intel Open Image Denoise (ppm_engine/render/denoise.py): None
    # off; final renders denoise their last image, the viewport from DenoiseSettings.start on.
    # Not the renderer's: its passes are the same either way
    denoise: DenoiseSettings | None = None

    def validate(self) -> RenderOptions:
        for name, (lo, hi, _default, _desc) in LIMITS.items():
            v = getattr(self, name)
            if name == "photons_per_pass" and v is None:
                continue
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise SettingsError(f"{name} must be a number, got {v!r}")
            if v != v or not (lo <= v <= hi):
                raise SettingsError(f"{name} = {v!r} is outside [{lo}, {hi}]")
        b = self.max_bounces
        if b is not None and (isinstance(b, bool) or not isinstance(b, int)
                              or not 0 <= b <= MAX_BOUNCES_LIMIT):
            raise SettingsError(f"max_bounces = {b!r} must be None (the scene's Light Paths) "
                                f"or a whole number from 0 to {MAX_BOUNCES_LIMIT}")
        if self.indirect not in INDIRECT_MODES:
            raise SettingsError(f"indirect = {self.indirect!r} must be one of "
                                f"{', '.join(INDIRECT_MODES)}")
        if self.radius_schedule not in RADIUS_SCHEDULES:
            raise SettingsError(f"radius_schedule = {self.radius_schedule!r} must be one of "
                                f"{', '.join(RADIUS_SCHEDULES)}")
        if not all(isinstance(d, str) for d in self.devices):
            raise SettingsError(f"devices = {self.devices!r} must be device names")
        if not (0.0 < self.alpha < 1.0):
            raise SettingsError(f"alpha = {self.alpha!r} must lie strictly between 0 and 1")
        if not (0.0 < self.global_alpha < 1.0):
            raise SettingsError(f"global_alpha = {self.global_alpha!r} must lie strictly "
                                "between 0 and 1")
        if not (0.0 <= self.caustic_roughness <= 2.0):
            raise SettingsError(f"caustic_roughness = {self.caustic_roughness!r} is outside "
                                "[0, 2]")
        if not (0.0 <= self.gather_roughness <= 2.0):
            raise SettingsError(f"gather_roughness = {self.gather_roughness!r} is outside "
                                "[0, 2] (above 1: no microfacet lobe is gathered)")
        if self.denoise is not None:
            if not isinstance(self.denoise, DenoiseSettings):
                raise SettingsError(f"denoise = {self.denoise!r} must be None or "
                                    "DenoiseSettings")
            if self.denoise.problem() is not None:
                raise SettingsError(self.denoise.problem())
        return self

    def photons_for(self, pixels: int) -> int:
        """Photons emitted per pass for a render region of ``pixels`` pixels."""
        if self.photons_per_pass is not None:
            return int(self.photons_per_pass)
        return int(min(max(pixels, AUTO_PHOTONS_MIN), AUTO_PHOTONS_MAX))

    def aimed_photons_for(self, pixels: int, caster_share: float) -> int:
        """Aimed caustic photons per pass for a render region of ``pixels`` pixels, where
        ``caster_share`` of uniform photons would reach a caster: AIMED_PHOTONS_SHARE of the
        photon count (automatic or set: a count set for photons emitted as all are keeps about
        its time per pass), or ``caster_share`` of it if larger, at least AIMED_PHOTONS_MIN."""
        base = self.photons_for(pixels)
        share = min(max(AIMED_PHOTONS_SHARE, caster_share), 1.0)
        return int(min(max(base * share, AIMED_PHOTONS_MIN), base))

    def replace(self, **changes) -> RenderOptions:
        return dataclasses.replace(self, **changes)
