"""Denoising through Intel Open Image Denoise (OIDN), as Cycles' OIDN denoiser: the noisy image
with the render's albedo and normal (Film.aux_passes: "Denoising Albedo", "Denoising Normal")
as auxiliary images, prefiltered or not, at a chosen quality.  No bpy here.

OIDN comes from the ``pyoidn`` package (an optional dependency: ``pip install ".[denoise]"``;
the extension zip bundles its wheel, docs/USAGE.md "Denoising").  It is imported on first use;
where it cannot be loaded (not installed, no library for this platform, a CPU it does not
support), ``load()`` raises DenoiserUnavailable, whose message says why and what to do, and
callers render on without denoising.

Cycles' settings (scene.cycles denoising_input_passes, denoising_prefilter, denoising_quality,
and their preview_ twins for the viewport) map onto DenoiseSettings one to one:
  input passes  "rgb" (the colour alone), "rgb_albedo", "rgb_albedo_normal";
  prefilter     "none" (the auxiliary images are taken as noise-free), "fast" (OIDN denoises
                them with the colour, cleanAux off), "accurate" (each is denoised by its own
                filter first, then taken as noise-free: Cycles' default);
  quality       "high", "balanced", "fast" (OIDN's filter qualities).
"""
from __future__ import annotations

import dataclasses
import threading

import numpy as np

from ppm_engine.errors import PPMError

INPUT_PASSES = ("rgb", "rgb_albedo", "rgb_albedo_normal")
PREFILTERS = ("none", "fast", "accurate")
QUALITIES = ("high", "balanced", "fast")


class DenoiserUnavailable(PPMError):
    """OIDN could not be loaded: the message says why and how to get it."""


@dataclasses.dataclass(frozen=True)
class DenoiseSettings:
    """How to denoise (Cycles' names, lower case).  ``start``: the viewport denoises from this
    pass on (Cycles' Start Sample); a final render denoises its last image."""
    input_passes: str = "rgb_albedo_normal"
    prefilter: str = "accurate"
    quality: str = "high"
    start: int = 1

    def problem(self) -> str | None:
        """What is wrong with these settings (RenderOptions.validate raises it), or None."""
        for name, allowed in (("input_passes", INPUT_PASSES), ("prefilter", PREFILTERS),
                              ("quality", QUALITIES)):
            if getattr(self, name) not in allowed:
                return (f"denoising {name} = {getattr(self, name)!r} must be one of "
                        f"{', '.join(allowed)}")
        if isinstance(self.start, bool) or not isinstance(self.start, int) or self.start < 1:
            return f"denoising start = {self.start!r} must be a whole number of passes, 1 or more"
        return None


INSTALL_HINT = ("install it with pip install pyoidn (or the engine's extra: pip install "
                "\"ppm-engine[denoise]\"); the Blender extension bundles it for Linux x64, "
                "Windows x64 and macOS")

_lock = threading.Lock()
_state: dict = {}        # "module", "device" once loaded; "error" once loading failed


def load():
    """The pyoidn module with a committed CPU device, loaded once per process; raises
    DenoiserUnavailable (the reason, the install hint) where it cannot be."""
    with _lock:
        if "error" in _state:
            raise DenoiserUnavailable(_state["error"])
        if "module" in _state:
            return _state["module"]
        try:
            import pyoidn
            if not pyoidn.Device.is_cpu_available():
                raise RuntimeError("this CPU is not supported by OIDN (it needs SSE4.1 on x86 "
                                   "or an ARM64 CPU)")
            device = pyoidn.Device(pyoidn.OIDN_DEVICE_TYPE_CPU)
            device.commit()
            error = device.get_error()
            if error:
                raise RuntimeError(error)
        except Exception as e:     # ImportError, OSError from the library, OIDN's own errors
            reason = ("the pyoidn package is not installed" if isinstance(e, ImportError)
                      and getattr(e, "name", "") == "pyoidn" else f"{type(e).__name__}: {e}")
            _state["error"] = (f"Intel Open Image Denoise could not be loaded ({reason}): "
                               f"{INSTALL_HINT}")
            raise DenoiserUnavailable(_state["error"]) from None
        _state["module"], _state["device"] = pyoidn, device
        return pyoidn


def unavailable() -> str | None:
    """None where OIDN loads, else the message saying why not."""
    try:
        load()
    except DenoiserUnavailable as e:
        return str(e)
    return None


def _run(oidn, images: dict, output: np.ndarray, *, hdr: bool, clean_aux: bool,
         quality: str) -> None:
    """One OIDN "RT" filter over ``images`` (name -> float32 (h, w, 3), C-contiguous) into
    ``output``."""
    device = _state["device"]
    flt = oidn.Filter(device, oidn.OIDN_FILTER_TYPE_RT)
    try:
        for name, img in images.items():
            flt.set_image(name, img, oidn.OIDN_FORMAT_FLOAT3)
        flt.set_image(oidn.OIDN_IMAGE_OUTPUT, output, oidn.OIDN_FORMAT_FLOAT3)
        if "color" in images:
            flt.set_bool("hdr", hdr)
            flt.set_bool("cleanAux", clean_aux)
        flt.set_quality({"high": oidn.OIDN_QUALITY_HIGH, "balanced": oidn.OIDN_QUALITY_BALANCED,
                         "fast": oidn.OIDN_QUALITY_FAST}[quality])
        flt.commit()
        flt.execute()
        error = device.get_error()
        if error:
            raise PPMError(f"Intel Open Image Denoise failed: {error}")
    finally:
        flt.release()


def _rgb(a) -> np.ndarray:
    """float32 (h, w, 3), C-contiguous, finite (NaN and infinities 0)."""
    a = np.ascontiguousarray(np.asarray(a, np.float32)[..., :3])
    return np.nan_to_num(a, nan=0.0, posinf=0.0, neginf=0.0)


def denoise(image: np.ndarray, albedo: np.ndarray | None = None,
            normal: np.ndarray | None = None,
            settings: DenoiseSettings | None = None) -> np.ndarray:
    """The denoised copy of ``image`` (h, w, 3 or 4) float32: its colour through OIDN with
    the auxiliary images ``settings.input_passes`` asks for (albedo, normal: (h, w, 3), as
    Film.aux_passes gives them), its alpha unchanged.  Raises DenoiserUnavailable where OIDN
    cannot be loaded."""
    s = settings or DenoiseSettings()
    if s.problem() is not None:
        raise ValueError(s.problem())
    oidn = load()
    color = np.fmax(_rgb(image), np.float32(0.0))     # HDR input: non-negative
    aux = {}
    if s.input_passes != "rgb" and albedo is not None:
        aux[oidn.OIDN_IMAGE_ALBEDO] = np.clip(_rgb(albedo), 0.0, 1.0)
    if s.input_passes == "rgb_albedo_normal" and normal is not None and aux:
        aux[oidn.OIDN_IMAGE_NORMAL] = np.clip(_rgb(normal), -1.0, 1.0)
    with _lock:
        if s.prefilter == "accurate":
            for name in list(aux):
                out = np.empty_like(aux[name])
                _run(oidn, {name: aux[name]}, out, hdr=False, clean_aux=False,
                     quality=s.quality)
                aux[name] = out
        result = np.empty_like(color)
        _run(oidn, {oidn.OIDN_IMAGE_COLOR: color, **aux}, result, hdr=True,
             clean_aux=s.prefilter != "fast", quality=s.quality)
    out = np.array(image, np.float32, copy=True)
    out[..., :3] = result
    return out
