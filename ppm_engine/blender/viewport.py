"""Blender's side of the viewport: what ``view_update`` and ``view_draw`` do on Blender's thread.

    view_update(context, depsgraph) -> changes(depsgraph.updates) -> export_scene -> session
    view_draw(context, depsgraph)   -> view_camera(...) compared -> session.update_view
                                     -> session.display_pass (the shading popover's Render
                                        Pass) -> session.snapshot() -> draw_frame(...)
                                        (viewport_draw.py: the only gpu calls) -> the header
    a timer (ViewportDriver._poll)  -> a redraw tagged when the session has something new

The rendering is ppm_engine.render.viewport_session.ViewportSession's worker thread; nothing here
waits for it.  Everything but ``draw_frame``'s gpu calls runs headless: the driver with real
depsgraphs (tests/test_viewport_blender.py), drawing with a stub of the gpu module and fake
regions (tests/test_viewport_draw.py).  ``draw_frame`` keeps to the few calls Blender's
documentation shows for a render engine's viewport (bpy.types.RenderEngine's example: a
GPUTexture of the float image drawn with draw_texture_2d between bind_display_space_shader and
unbind_display_space_shader).

Redraws: Cycles' session thread tags its engine's redraw at every update (a flag Blender's
window manager reads on each turn of its loop).  A Python thread cannot hold the engine (bpy
structs take no weak references, and a strong one would keep Blender from ever freeing the
engine, so the session would never close), so a timer on Blender's thread looks at the
session every REDRAW_POLL seconds while it renders and tags a redraw once per new version
(an image, a status line, an error); it stops when nothing more is coming and the last
version is drawn or tagged.  view_draw reads the session once (snapshot), so an image or an
error landing while it draws has a newer version and is drawn next.

Errors: printed in full to the console once (a compiler's log included), reported once with
RenderEngine.report as Cycles does from its view_draw (Blender keeps no report list for a
viewport engine: RE_engine_report drops it there; a final render's reports reach the status
bar), and shown by the header's text (Overlays > Text Info) in Blender's 511 bytes, with
what to do.  view_draw never raises: Blender's draw loop would print the traceback at every
redraw and the header would keep its last line.
"""
from __future__ import annotations

import sys
import traceback

import numpy as np

from ppm_engine.blender.viewport_draw import display_pass, draw_frame
from ppm_engine.errors import PPMError

# seconds between two looks at the session while it renders (a timer on Blender's thread)
REDRAW_POLL = 0.02
# Blender's engine text (RenderEngine.text: the header line Overlays > Text Info shows) holds
# 511 bytes of UTF-8; a longer line loses its end
TEXT_BYTES = 511
# where the whole message is
CONSOLE = "full message in the system console"
# what to do, after the first line of an error's message (the message says what is wrong)
EXPORT_HINT = "the viewport renders again at the next change"
SESSION_HINT = "change the scene or reopen Rendered shading to try again"
BUG_HINT = "a bug: please report it with the console's traceback"

# depsgraph update types -> what changed (the session compares the arrays and does the least
# work: values re-uploaded, the BVH refitted, or rebuilt)
_VALUE_TYPES = {'MATERIAL', 'NODETREE', 'IMAGE', 'TEXTURE', 'LIGHT', 'WORLD', 'SCENE'}


def changes(updates, scene_camera: bool = False) -> set:
    """What a view_update's ``depsgraph.updates`` changed: a subset of {"values" (materials,
    lights, world, the scene's settings), "transform", "geometry" (meshes, objects added or
    deleted, visibility), "camera"}.  Empty: nothing the render depends on (a selection).
    A camera's edits count ("camera") only with ``scene_camera``: no 3D view, the export's
    camera is the scene's; else the view's camera comes from view_draw."""
    out = set()
    for u in updates:
        idt = getattr(u.id, "id_type", "") if u.id is not None else ""
        if idt == 'OBJECT':
            kind = getattr(u.id, "type", "")
            if kind == 'CAMERA':
                if scene_camera:
                    out.add("camera")
                continue                           # the view's camera comes from view_draw
            if kind == 'LIGHT':
                out.add("values")                  # its data or its placement: re-uploaded
            elif u.is_updated_geometry:
                out.add("geometry")
            elif u.is_updated_transform:
                out.add("transform")
            elif u.is_updated_shading:
                out.add("values")                  # ray visibility, material slots
        elif idt == 'CAMERA':
            if scene_camera:
                out.add("camera")
            continue    # lens, depth of field: view_draw's camera (no export reads it)
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


def pixel_size(context, scene, engine=None) -> int:
    """The viewport's Pixel Size (Render Properties > Performance > Viewport: 1x, 2x, 4x, 8x;
    Automatic: 2 where the interface's pixel size is over 1.5, else 1), as Blender computes
    it (BKE_render_preview_pixel_size); asked of ``engine`` (RenderEngine.get_preview_pixel_size)
    when given."""
    if engine is not None and hasattr(engine, "get_preview_pixel_size"):
        return max(int(engine.get_preview_pixel_size(scene)), 1)
    v = str(getattr(scene.render, "preview_pixel_size", "AUTO"))
    if v.isdigit():
        return max(int(v), 1)
    prefs = getattr(context, "preferences", None)
    scale = getattr(getattr(prefs, "system", None), "pixel_size", 1.0) if prefs else 1.0
    return 2 if float(scale) > 1.5 else 1


def header_text(message: str, hint: str = "") -> str:
    """The header's line for an error: the message's first line, then ``hint`` (what to do)
    and, when the message has more lines or its line is cut, where the rest is; at most
    TEXT_BYTES bytes of UTF-8, the first line cut to keep the rest."""
    lines = [x.strip() for x in str(message).strip().splitlines() if x.strip()]
    lines = lines or ["unknown error"]

    def line(first: str, cut: bool) -> str:
        tail = ([hint] if hint else []) + ([CONSOLE] if cut or len(lines) > 1 else [])
        return "Progressive Photon Mapping: " + " · ".join([first] + tail)
    text = line(lines[0], False)
    if len(text.encode()) <= TEXT_BYTES:
        return text
    room = TEXT_BYTES - len(line("…", True).encode())
    first = lines[0].encode()[:max(room, 0)].decode("utf-8", "ignore")
    return line(first + "…", True)


def viewport_paused(scene) -> bool:
    """The scene's Pause Viewport (scene.ppm.viewport_pause)."""
    return bool(getattr(getattr(scene, "ppm", None), "viewport_pause", False))


def view_camera(context, depsgraph, engine=None):
    """The camera record of the 3D view in ``context`` (its region's size over the Pixel
    Size, its view and projection matrices, the scene's film; the depth of field of the camera
    it looks through: the view's local camera where it has one, as Cycles' viewport, else the
    scene's), or None without a 3D view (then the scene camera renders)."""
    from ppm_engine.blender.export.camera import export_camera, film_settings
    from ppm_engine.scene.camera import camera_from_view, with_border
    region, rv3d = getattr(context, "region", None), getattr(context, "region_data", None)
    if region is None or rv3d is None or not hasattr(rv3d, "window_matrix"):
        return None
    scene = depsgraph.scene
    ps = pixel_size(context, scene, engine)
    film = film_settings(scene)
    space = getattr(context, "space_data", None)
    through = getattr(scene, "camera", None)
    if getattr(space, "use_local_camera", False) and getattr(space, "camera", None) is not None:
        through = space.camera                    # View > Sidebar > View > Local Camera
    cam = None
    if rv3d.view_perspective == 'CAMERA' and through is not None and through.type == 'CAMERA':
        cam = export_camera(scene, depsgraph, through)    # its depth of field
        film.update({k: float(cam[k][0]) for k in ("aperture_radius", "focus_distance",
                                                   "aperture_rotation", "aperture_ratio")})
        film["aperture_blades"] = int(cam["aperture_blades"][0])
    view = camera_from_view(np.array(rv3d.view_matrix), np.array(rv3d.window_matrix),
                            max(region.width // ps, 1), max(region.height // ps, 1), **film)
    return with_border(view, view_border(space, scene, rv3d, view, cam))


def view_border(space, scene, rv3d, view, cam):
    """The render region of a 3D view as fractions (x0, y0, x1, y1) of its region, or None, as
    Cycles' viewport takes it: outside the camera view the view's own (View > Render Region,
    Ctrl B); looking through the camera (``cam``, its record; ``view``, the view's) the
    scene's Render Region (Output > Format), placed on the camera's frame in the view."""
    if rv3d.view_perspective == 'CAMERA':
        r = scene.render
        if cam is None or not getattr(r, "use_border", False):
            return None
        (xl, xh), (yl, yh) = (
            tuple((float(cam["shift"][0][k]) + s * 0.5 * float(cam["extent"][0][k])
                   - float(view["shift"][0][k])) / float(view["extent"][0][k]) + 0.5
                  for s in (-1.0, 1.0))
            for k in (0, 1))
        return (xl + r.border_min_x * (xh - xl), yl + r.border_min_y * (yh - yl),
                xl + r.border_max_x * (xh - xl), yl + r.border_max_y * (yh - yl))
    if not getattr(space, "use_render_border", False):
        return None
    return (space.render_border_min_x, space.render_border_min_y, space.render_border_max_x,
            space.render_border_max_y)


def viewport_options(settings):
    """RenderOptions for the viewport from ``scene.ppm``: its viewport pass count, time limit
    and denoising; (options, start resolution)."""
    from ppm_engine.blender.properties import denoise_settings, to_options
    o = to_options(settings)
    return (o.replace(passes=int(settings.viewport_passes),
                      time_limit=float(settings.viewport_time_limit),
                      denoise=denoise_settings(settings, viewport=True)).validate(),
            int(settings.viewport_start_resolution))


class ViewportDriver:
    """One per viewport engine instance: owns its ViewportSession and the drawn texture.
    ``timers``: what registers the redraw timer (bpy.app.timers; tests pass their own)."""

    def __init__(self, timers=None):
        self.session = None
        self.message = None          # an export or settings error (view_update), its hint:
        self.message_hint = ""       # shown in the header until an export succeeds
        self.draw_cache: dict = {}
        self.exports = 0
        self.meshes = None           # export.mesh.MeshCache kept across exports
        self.images: dict = {}       # decoded images kept across exports
        self.key = None              # settings_key of the last export
        self.drawn = None            # the session version view_draw last drew
        self._tagged = None          # the version a redraw was last tagged for
        self._engine = None          # the engine whose redraws the timer tags, while it runs
        self._announced = None       # the last error printed and reported
        self._timers = timers
        self._poller = self._poll    # one bound method: the timer API compares identities

    # -- view_update: edits -> an export for the session -----------------------------------------
    def view_update(self, engine, context, depsgraph) -> None:
        from ppm_engine.blender.export import export_scene
        from ppm_engine.blender.export.mesh_cache import MeshCache, forget_changed
        from ppm_engine.render.viewport_session import ViewportSession
        try:
            options, start = viewport_options(depsgraph.scene.ppm)
            if self.session is not None and self.session.error is not None:
                self.session.close(timeout=0.0)    # it stopped on an error: start afresh
                self.session = None
            first = self.session is None
            if first:
                self.session = ViewportSession(options, start)
                self.drawn = self._tagged = None
            else:
                self.session.update_options(options, start)
            self.session.pause(viewport_paused(depsgraph.scene))
            self.session.display_pass(display_pass(context))
            from ppm_engine.blender.export import hidden_in_view
            space = getattr(context, "space_data", None)
            view = space if hasattr(space, "show_object_viewport_mesh") else None
            key = (settings_key(depsgraph), hidden_in_view(depsgraph, view))
            if self.meshes is None:
                self.meshes = MeshCache(None)
            camera = view_camera(context, depsgraph, engine)
            if not first and self.message is None and key == self.key:
                ups = depsgraph.updates
                if not changes(ups, scene_camera=camera is None) or only_scene(ups):
                    self._watch(engine)
                    return                      # nothing the export reads changed
                forget_changed(ups, self.meshes, self.images, _VALUE_TYPES | {'CAMERA'})
            else:                               # a new session, frame, layer, view: afresh
                self.meshes.clear()
                self.images.clear()
            self.session.hold()                 # the processor to the export (until posted)
            try:
                # the engine reports each warning once per export (kept mesh data's too)
                arrays = export_scene(depsgraph, engine, camera=camera, view=view,
                                      meshes=self.meshes, images=self.images)
            except BaseException:
                self.session.hold(False)
                raise
            for w in arrays.warnings:           # (Blender keeps no viewport reports)
                print(f"PPM viewport: {w}", file=sys.stderr)
            self.key = key
            self.exports += 1
            self.message = None
            if camera is not None:
                self.session.update_view(camera)
            self.session.update_scene(arrays)
        except PPMError as e:                   # the message says what is wrong, what to do
            self.message, self.message_hint = str(e), EXPORT_HINT
            self._announce(engine, self.message)
        except Exception as e:                  # a bug
            self.message = f"internal error ({type(e).__name__}: {e})"
            self.message_hint = BUG_HINT
            self._announce(engine, self.message, e)
        if self.message is not None:
            self._stats(engine, header_text(self.message, self.message_hint))
        if self.session is not None:
            self._watch(engine)

    # -- view_draw: the view's camera, the latest image, the header ------------------------------
    def view_draw(self, engine, context, depsgraph) -> None:
        """Never raises (Blender's draw loop would print the traceback at every redraw)."""
        s = self.session
        if s is None:
            return
        try:
            self._view_draw(engine, context, depsgraph, s)
        except Exception as e:                  # a bug in what follows
            message = f"internal error while drawing ({type(e).__name__}: {e})"
            self._announce(engine, message, e)
            self._stats(engine, header_text(message, BUG_HINT))

    def _view_draw(self, engine, context, depsgraph, s) -> None:
        scene = depsgraph.scene
        problem = None                          # (message, hint, exception) of this draw
        try:
            s.pause(viewport_paused(scene))     # as Cycles, read at every redraw too
            s.display_pass(display_pass(context))    # the shading popover's Render Pass
            camera = view_camera(context, depsgraph, engine)
            if camera is not None:
                s.update_view(camera)
        except PPMError as e:                   # a film setting: says what to do
            problem = (str(e), EXPORT_HINT, None)
        except Exception as e:                  # a ValueError of the view's matrices, a bug
            problem = (f"the 3D view's camera could not be read ({type(e).__name__}: {e})",
                       BUG_HINT, e)
        snap = s.snapshot()                     # one read: nothing lands between its parts
        if snap.frame is not None:
            try:
                draw_frame(engine, scene, snap.frame, context.region.width,
                           context.region.height, self.draw_cache)
            except Exception as e:              # a gpu error (no GPU context, memory)
                problem = problem or (
                    f"the image could not be drawn ({type(e).__name__}: {e})", BUG_HINT, e)
        self.drawn = snap.version
        if self.message is not None:
            text = header_text(self.message, self.message_hint)
        elif snap.error is not None:            # the session printed it in full
            self._announce(engine, snap.error, printed=True)
            text = header_text(snap.error, SESSION_HINT)
        elif problem is not None:
            self._announce(engine, problem[0], problem[2])
            text = header_text(problem[0], problem[1])
        else:
            self._announced = None
            text = snap.status
        self._stats(engine, text)
        if snap.busy or s.version != snap.version:
            self._watch(engine)                 # more is coming, or came while drawing

    # -- redraws: a timer on Blender's thread ----------------------------------------------------
    def _timer_api(self):
        if self._timers is None:
            import bpy
            self._timers = bpy.app.timers
        return self._timers

    def _watch(self, engine) -> None:
        """Look at the session every REDRAW_POLL s until nothing more is coming."""
        self._engine = engine
        timers = self._timer_api()
        if not timers.is_registered(self._poller):
            timers.register(self._poller, first_interval=REDRAW_POLL)

    def _poll(self):
        """The timer: tags a redraw once per new session version; the seconds to the next
        look, or None to stop (nothing more coming, the last version drawn or tagged)."""
        s, engine = self.session, self._engine
        if s is None or engine is None:
            self._engine = None
            return None
        try:
            _ = engine.tag_redraw                # ReferenceError once Blender freed the engine
        except ReferenceError:
            self._engine = None
            self.close(unregister=False)
            return None
        try:
            snap = s.snapshot()
            if snap.version != self.drawn and snap.version != self._tagged:
                engine.tag_redraw()
                self._tagged = snap.version
        except Exception:                        # a bug: stop looking, say it once
            traceback.print_exc(file=sys.stderr)
            self._engine = None
            return None
        if not snap.busy:
            self._engine = None
            return None
        return REDRAW_POLL

    # -- errors and the header --------------------------------------------------------------------
    def _announce(self, engine, message: str, exc: BaseException | None = None,
                  printed: bool = False) -> None:
        """An error, once until it changes: printed in full to the console (unless the session
        did), its traceback when it is a bug; reported (RenderEngine.report)."""
        if message == self._announced:
            return
        self._announced = message
        if not printed:
            print(f"PPM viewport: {message}", file=sys.stderr)
            if exc is not None:
                traceback.print_exception(type(exc), exc, exc.__traceback__, file=sys.stderr)
        try:
            engine.report({'ERROR'}, f"Progressive Photon Mapping: {message}")
        except Exception:
            traceback.print_exc(file=sys.stderr)

    @staticmethod
    def _stats(engine, text: str) -> None:
        try:
            engine.update_stats("", text)
        except Exception:
            traceback.print_exc(file=sys.stderr)

    def close(self, unregister: bool = True) -> None:
        s, self.session = self.session, None
        self._engine = None
        self.draw_cache.clear()
        self.meshes = None
        self.images = {}
        if unregister:
            try:
                timers = self._timer_api()
                if timers.is_registered(self._poller):
                    timers.unregister(self._poller)
            except Exception:                    # Blender exiting: its timers are gone
                pass
        if s is not None:
            s.close(timeout=2.0)
