"""What the viewport draws, on Blender's thread: the pass the 3D view shows (its shading
popover's Render Pass) and ``draw_frame``, the viewport's only gpu calls.  No bpy import: the
gpu module is imported when draw_frame runs (tests stub it: tests/helpers/viewport_stubs.py)."""
from __future__ import annotations

import numpy as np

from ppm_engine.render.viewport_frame import display_pass_named


def display_pass(context) -> str:
    """The pass the 3D view in ``context`` shows (its shading popover's Render Pass,
    View3DShading.ppm.render_pass: blender/properties.py), by its
    viewport_frame.DISPLAY_PASSES name; Combined without a 3D view."""
    shading = getattr(getattr(context, "space_data", None), "shading", None)
    return display_pass_named(getattr(getattr(shading, "ppm", None), "render_pass", ""))


def draw_frame(engine, scene, frame, width: int, height: int, cache: dict) -> None:
    """Draw ``frame`` (viewport_session.Frame) over the region (``width`` x ``height`` pixels) with
    Blender's view transform.  The texture is made once per image, a half-float one: the
    session published the image in its range (viewport_session.display_image)."""
    import gpu
    from gpu_extras.presets import draw_texture_2d
    if cache.get("generation") != frame.generation:
        h, w = frame.image.shape[:2]
        pixels = gpu.types.Buffer('FLOAT', w * h * 4,
                                  np.ascontiguousarray(frame.image, np.float32).ravel())
        cache["texture"] = gpu.types.GPUTexture((w, h), format='RGBA16F', data=pixels)
        cache["generation"] = frame.generation
    gpu.state.blend_set('ALPHA_PREMULT')
    engine.bind_display_space_shader(scene)
    x, y, w, h = frame.region                  # a render region: its place in the region
    draw_texture_2d(cache["texture"], (round(x * width), round(y * height)),
                    round(w * width), round(h * height))
    engine.unbind_display_space_shader()
    gpu.state.blend_set('NONE')
