"""The viewport's images (ViewportSession's Frame and Snapshot), the range its display texture
holds, and the reduced resolutions its first passes run at.  No bpy, no device."""
from __future__ import annotations

import dataclasses

import numpy as np

# the largest finite value of a half float: the display texture is RGBA16F
HALF_MAX = 65504.0


def display_image(image: np.ndarray) -> np.ndarray:
    """A new float32 copy of ``image`` in the range of the viewport's half-float texture, as
    Cycles converts its display pixels (util/half.h float4_to_half4_display): NaN and negative
    values 0, values over 65504 (and +Inf) 65504, where the texture would hold Inf or NaN."""
    out = np.fmax(np.asarray(image, np.float32), np.float32(0.0))   # fmax: NaN -> 0
    np.minimum(out, np.float32(HALF_MAX), out=out)
    return out


# the passes the viewport can show (its shading popover's Render Pass, as Cycles'): Combined
# (denoised with Viewport Denoise on) and the final render's other passes, by their names
# there (blender/session.py RENDER_PASSES and NOISY_PASS; Film.aux_passes)
DISPLAY_PASSES = ("Combined", "Denoising Albedo", "Denoising Normal", "PPM Radius",
                  "PPM Photons", "Noisy Image")
# the passes the renderer's image is (the others come from Renderer.passes)
IMAGE_PASSES = ("Combined", "Noisy Image")


def display_pass_id(name: str) -> str:
    """A display pass's identifier (the Render Pass enum's): its name in capitals, spaces as
    underscores (as Cycles' DENOISING_ALBEDO)."""
    return name.upper().replace(" ", "_")


def display_pass_named(identifier: str) -> str:
    """The DISPLAY_PASSES name of an identifier (display_pass_id); Combined for another."""
    return next((n for n in DISPLAY_PASSES if display_pass_id(n) == identifier), "Combined")


def pass_image(name: str, image: np.ndarray, aux: dict | None) -> np.ndarray:
    """The RGBA (h, w, 4) image the viewport shows for the display pass ``name``: the
    renderer's ``image`` for Combined and Noisy Image, else the pass of ``aux``
    (Renderer.passes) as Cycles' viewport shows one: its channels in R, G, B (a value in all
    three), alpha 1."""
    if name in IMAGE_PASSES:
        return image
    if name not in DISPLAY_PASSES:
        raise ValueError(f"no display pass {name!r}: one of {', '.join(DISPLAY_PASSES)}")
    a = np.asarray(aux[name], np.float32)
    out = np.ones(a.shape[:2] + (4,), np.float32)
    out[..., :3] = a if a.shape[-1] == 3 else a[..., :1]
    return out


@dataclasses.dataclass(frozen=True)
class Frame:
    """An image of the viewport: linear RGBA (h, w, 4) float32, row 0 at the bottom, at
    1/``divider`` of the region's ``width`` x ``height`` (draw it stretched over the region);
    in the display texture's range (display_image: no NaN, nothing above 65504)."""
    image: np.ndarray
    width: int
    height: int
    divider: int
    passes: int            # passes accumulated in it (at its resolution)
    generation: int        # grows with every new image
    restart: int           # the restart it belongs to (ViewportSession.restarts)
    # where it goes: fractions (x0, y0, w, h) of the region (a render region: a part of it)
    region: tuple = (0.0, 0.0, 1.0, 1.0)
    display: str = "Combined"       # the pass it shows (DISPLAY_PASSES)


@dataclasses.dataclass(frozen=True)
class Snapshot:
    """What the viewport shows, read at one instant (ViewportSession.snapshot)."""
    frame: Frame | None    # the latest image
    status: str            # the header's line
    error: str | None      # the full message of the error that stopped the session
    busy: bool             # more images (or a new status) are coming
    version: int           # grows with every change of frame, status or error


def divider_for(width: int, height: int, start_resolution: int) -> int:
    """Cycles' viewport start: the smallest power of two d with (w / d) (h / d) at most
    ``start_resolution`` squared (1 when the region is that small already; 0 or less: 1)."""
    if start_resolution <= 0:
        return 1
    d = 1
    while (width / d) * (height / d) > start_resolution * start_resolution and d < 1 << 12:
        d *= 2
    return d
