"""Blender I/O shared by the CLI, the benchmark and the tests: the engine registered once,
image output set up by file extension, EXR files read back, and the Cycles settings of a
reference render (the same light transport as ours).  Imports bpy lazily."""
from __future__ import annotations

from pathlib import Path

import numpy as np

# extension -> (file_format, color_depth): 8-bit PNG (through the view transform), 32-bit
# float EXR (linear, exact)
OUTPUT_FORMATS = {
    ".png": ("PNG", "8"),
    ".exr": ("OPEN_EXR", "32"),
}


def ensure_registered() -> None:
    """The engine's classes registered in this Blender (once per process)."""
    from ppm_engine import register
    from ppm_engine.blender.engine import PPMRenderEngine
    if not PPMRenderEngine.is_registered:
        register()


def set_output(scene, path) -> None:
    """Render output to ``path``, its format from the extension (OUTPUT_FORMATS): one RGBA
    image (not a multilayer EXR), the extension kept as given."""
    path = Path(path)
    file_format, depth = OUTPUT_FORMATS[path.suffix.lower()]
    settings = scene.render.image_settings
    if hasattr(settings, "media_type"):     # Blender 5.0: single image, not multilayer
        settings.media_type = "IMAGE"
    settings.file_format = file_format
    settings.color_mode = "RGBA"
    settings.color_depth = depth
    scene.render.use_file_extension = True
    scene.render.filepath = str(path)


# the scene's colour management a PNG goes through (view_settings), kept with a part's metadata
VIEW_SETTINGS = ("view_transform", "look", "exposure", "gamma")


def view_settings(scene) -> dict:
    """The scene's view transform, look, exposure and gamma and its display device."""
    v = scene.view_settings
    return {**{k: getattr(v, k) for k in VIEW_SETTINGS},
            "display_device": scene.display_settings.display_device}


def write_image(rgba: np.ndarray, path, view: dict | None = None) -> None:
    """Write linear RGBA (h, w, 4), row 0 = bottom (a render result's order), as an image whose
    format is the extension's (OUTPUT_FORMATS): what the render writes for the same pixels; a
    PNG through ``view`` (view_settings of the scene rendered), an EXR linear."""
    import bpy
    path = Path(path)
    file_format, depth = OUTPUT_FORMATS[path.suffix.lower()]
    h, w = rgba.shape[:2]
    img = bpy.data.images.new("ppm_merged", w, h, alpha=True, float_buffer=True)
    try:
        img.pixels.foreach_set(np.ascontiguousarray(rgba, np.float32).ravel())
        scene = bpy.data.scenes[0] if bpy.data.scenes else bpy.data.scenes.new("ppm")
        settings = scene.render.image_settings
        if hasattr(settings, "media_type"):
            settings.media_type = "IMAGE"
        settings.file_format, settings.color_mode, settings.color_depth = \
            file_format, "RGBA", depth
        if view:
            scene.display_settings.display_device = view["display_device"]
            for k in VIEW_SETTINGS:
                setattr(scene.view_settings, k, view[k])
        img.save_render(str(path), scene=scene)
    finally:
        bpy.data.images.remove(img)


def read_exr(path) -> np.ndarray:
    """RGBA float32 (h, w, 4) of a single-part EXR, rows top-down (EXR order).  Needs the
    OpenEXR package (the test and bench extras)."""
    import OpenEXR
    with OpenEXR.File(str(path)) as f:
        channels = f.parts[0].channels
        rgba = [v.pixels for v in channels.values() if v.pixels.ndim == 3]
        if not rgba:
            raise ValueError(f"no RGBA layer in {path}: {list(channels)}")
        return np.asarray(rgba[0], dtype=np.float32)


def unbiased_light_paths(scene, bounces: int = 12) -> None:
    """The scene's Light Paths (scene.cycles, which both engines read) for comparisons:
    ``bounces`` of every kind, no clamping, no Filter Glossy, caustics on."""
    c = scene.cycles
    c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = bounces
    c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
    c.blur_glossy = 0.0
    c.caustics_reflective = c.caustics_refractive = True


def cycles_reference(scene, *, samples: int | None = None, seconds: float = 0.0,
                     seed: int = 1, bounces: int = 12) -> None:
    """Cycles with the same light transport as this engine, for comparisons: CPU, ``bounces``
    of every kind, no clamping, no denoising, no adaptive sampling, caustics on, a fixed seed;
    ``samples`` per pixel, or with ``seconds`` a time limit and unlimited samples."""
    if scene.render.engine != "CYCLES":
        scene.render.engine = "CYCLES"
    c = scene.cycles
    c.device = "CPU"
    c.samples = samples if samples is not None else 1 << 24
    c.time_limit = seconds
    c.use_adaptive_sampling = c.use_denoising = False
    unbiased_light_paths(scene, bounces)
    c.seed = seed
    c.use_animated_seed = False
