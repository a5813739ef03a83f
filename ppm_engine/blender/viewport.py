"""Blender's side of the viewport: what ``view_update`` and ``view_draw`` do on Blender's thread.

    view_update(context, depsgraph) -> changes(depsgraph.updates) -> export_scene -> session
    view_draw(context, depsgraph)   -> view_camera(...) compared -> session.update_view
                                     -> draw_frame(...) (the only gpu calls) -> header stats

The rendering is ppm_engine.render.viewport_session.ViewportSession's worker thread; nothing here
waits for it.  Everything but ``draw_frame`` runs headless and is tested with real depsgraphs
(tests/test_viewport_blender.py); ``draw_frame`` cannot be (bpy's gpu module refuses every call in
background mode), so it is kept to the few calls Blender's documentation shows for a render
engine's viewport (bpy.types.RenderEngine's example: a GPUTexture of the float image drawn
with draw_texture_2d between bind_display_space_shader and unbind_display_space_shader).
"""
from __future__ import annotations

import sys
import traceback

import numpy as np

from ppm_engine.errors import PPMError

# depsgraph update types -> what changed (the session compares the arrays and does the least
# work: values re-uploaded, the BVH refitted, or rebuilt)
_VALUE_TYPES = {'MATERIAL', 'NODETREE', 'IMAGE', 'TEXTURE', 'LIGHT', 'WORLD', 'CAMERA',
                'SCENE'}


def changes(updates) -> set:
    """What a view_update's ``depsgraph.updates`` changed: a subset of {"values" (materials,
    lights, world, the scene's settings), "transform", "geometry" (meshes, objects added or
    deleted, visibility)}.  Empty: nothing the render depends on (a selection)."""
    out = set()
    for u in updates:
        idt = getattr(u.id, "id_type", "") if u.id is not None else ""
        if idt == 'OBJECT':
            kind = getattr(u.id, "type", "")
            if kind == 'CAMERA':
                continue                           # the view's camera comes from view_draw
            if kind == 'LIGHT':
                out.add("values")                  # its data or its placement: re-uploaded
            elif u.is_updated_geometry:
                out.add("geometry")
            elif u.is_updated_transform:
                out.add("transform")
            elif u.is_updated_shading:
                out.add("values")                  # ray visibility, material slots
        elif idt == 'COLLECTION':
            out.add("geometry")                    # objects linked, unlinked, hidden
        elif idt in _VALUE_TYPES:
            out.add("values")
        elif u.is_updated_geometry or u.is_updated_transform:
            out.add("geometry")                    # mesh, curve, ... data
        elif u.is_updated_shading:
            out.add("values")
    return out


def only_scene(updates) -> bool:
    """Whether the updates are the scene's alone: a selection, an active object, or a change
    of the scene's settings (render settings, ours, Cycles'; settings_key tells them apart,
    and ours go to ViewportSession.update_options)."""
    ups = list(updates)
    return bool(ups) and all(getattr(u.id, "id_type", "") == 'SCENE' for u in ups)


def settings_key(depsgraph) -> tuple:
    """The scene settings an export reads that no other update reports: the frame, the film
    (Cycles' pixel filter, exposure, transparency), the Light Paths, the layer, the world."""
    from ppm_engine.blender.export.camera import film_settings
    from ppm_engine.scene.light_paths import from_cycles
    scene = depsgraph.scene
    return (scene.frame_current, tuple(film_settings(scene).values()),
            from_cycles(getattr(scene, "cycles", None)).tobytes(), depsgraph.view_layer.name,
            scene.world.name if scene.world is not None else None)


def pixel_size(context, scene) -> int:
    """The viewport's Pixel Size (Render Properties > Performance > Viewport: 1x, 2x, 4x, 8x;
    Automatic follows the interface's resolution scale)."""
    v = str(getattr(scene.render, "preview_pixel_size", "AUTO"))
    if v.isdigit():
        return max(int(v), 1)
    prefs = getattr(context, "preferences", None)
    scale = getattr(getattr(prefs, "system", None), "pixel_size", 1.0) if prefs else 1.0
    return max(round(float(scale)), 1)


def view_camera(context, depsgraph):
    """The camera record of the 3D view in ``context`` (its region's size over the Pixel
    Size, its view and projection matrices, the scene's film; the scene camera's depth of
    field when looking through it), or None without a 3D view (then the scene camera
    renders)."""
    from ppm_engine.blender.export.camera import export_camera, film_settings
    from ppm_engine.scene.camera import camera_from_view
    region, rv3d = getattr(context, "region", None), getattr(context, "region_data", None)
    if region is None or rv3d is None or not hasattr(rv3d, "window_matrix"):
        return None
    scene = depsgraph.scene
    ps = pixel_size(context, scene)
    film = film_settings(scene)
    if rv3d.view_perspective == 'CAMERA' and scene.camera is not None \
            and scene.camera.type == 'CAMERA':
        cam = export_camera(scene, depsgraph)     # its depth of field
        film.update({k: float(cam[k][0]) for k in ("aperture_radius", "focus_distance",
                                                   "aperture_rotation", "aperture_ratio")})
        film["aperture_blades"] = int(cam["aperture_blades"][0])
    return camera_from_view(np.array(rv3d.view_matrix), np.array(rv3d.window_matrix),
                            max(region.width // ps, 1), max(region.height // ps, 1), **film)


def viewport_options(settings):
    """RenderOptions for the viewport from ``scene.ppm``: its viewport pass count and time
    limit; (options, start resolution)."""
    from ppm_engine.blender.properties import to_options
    o = to_options(settings)
    return (o.replace(passes=int(settings.viewport_passes),
                      time_limit=float(settings.viewport_time_limit)).validate(),
            int(settings.viewport_start_resolution))


class ViewportDriver:
    """One per viewport engine instance: owns its ViewportSession and the drawn texture."""

    def __init__(self):
        self.session = None
        self.message = None          # an export or settings error, shown in the header
        self.draw_cache: dict = {}
        self.exports = 0
        self.key = None              # settings_key of the last export

    def view_update(self, engine, context, depsgraph) -> None:
        from ppm_engine.blender.export import export_scene
        from ppm_engine.render.viewport_session import ViewportSession
        try:
            options, start = viewport_options(depsgraph.scene.ppm)
            if self.session is not None and self.session.error is not None:
                self.session.close(timeout=0.0)    # it stopped on an error: start afresh
                self.session = None
            first = self.session is None
            if first:
                self.session = ViewportSession(options, start)
            else:
                self.session.update_options(options, start)
            self.session.pause(bool(depsgraph.scene.ppm.viewport_pause))
            key = settings_key(depsgraph)
            if not first and self.message is None and key == self.key:
                ups = depsgraph.updates
                if not changes(ups) or only_scene(ups):
                    return                      # nothing the export reads changed
            camera = view_camera(context, depsgraph)
            arrays = export_scene(depsgraph, camera=camera)
            self.key = key
            self.exports += 1
            self.message = None
            if camera is not None:
                self.session.update_view(camera)
            self.session.update_scene(arrays)
        except PPMError as e:
            self.message = str(e)
        except Exception as e:      # a bug: say it in the header, the traceback in the console
            traceback.print_exc(file=sys.stderr)
            self.message = f"internal error ({type(e).__name__}: {e}); see the console"
        if self.message is not None:
            engine.update_stats("", f"Progressive Photon Mapping: {self.message}")

    def view_draw(self, engine, context, depsgraph) -> None:
        s = self.session
        if s is None:
            return
        try:
            camera = view_camera(context, depsgraph)
            if camera is not None:
                s.update_view(camera)
        except PPMError as e:
            self.message = str(e)
        frame = s.frame()
        if frame is not None:
            draw_frame(engine, depsgraph.scene, frame, context.region.width,
                       context.region.height, self.draw_cache)
        text = self.message or s.error
        engine.update_stats("", f"Progressive Photon Mapping: {text}" if text else s.status())
        if s.busy:
            engine.tag_redraw()             # draw again: the next image is coming

    def close(self) -> None:
        s, self.session = self.session, None
        self.draw_cache.clear()
        if s is not None:
            s.close(timeout=2.0)


def draw_frame(engine, scene, frame, width: int, height: int, cache: dict) -> None:
    """Draw ``frame`` (viewport_session.Frame) over the region (``width`` x ``height`` pixels) with
    Blender's view transform.  The texture is made once per image."""
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
    draw_texture_2d(cache["texture"], (0, 0), width, height)
    engine.unbind_display_space_shader()
    gpu.state.blend_set('NONE')
