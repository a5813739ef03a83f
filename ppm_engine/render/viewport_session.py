"""The viewport's render session: the same core as a final render, driven by edits.  No bpy here.

    s = ViewportSession(options)                  # starts the worker thread
    s.update_scene(export_scene(depsgraph, camera=cam))   # Blender's view_update, on any edit
    s.update_view(cam)                            # view_draw: the view's camera record
    snap = s.snapshot()                           # the latest image (Frame), status, error, busy
    s.close()                                     # the viewport closed: frees the device memory

One worker thread owns the Renderer and every OpenCL call of the session; Blender's thread only
posts what changed (a scene, a view, options) and reads the latest image, under one lock, so the
UI never waits for a pass or a kernel build.  The worker compares what it is given with what it
renders and does the least that serves:

    the view moved or zoomed   -> the camera record uploaded alone, accumulation restarted
    the region resized         -> the same after RESIZE_DEBOUNCE s without a further resize
    materials, lights, world   -> the scene re-uploaded, the BVH kept (Renderer.reset)
    the same triangles moved   -> the BVH refitted (Renderer.refit)
    other geometry changes     -> a new BVH (a new Renderer; the programs stay built)

The viewport's kernels are built "editable" (RenderOptions.editable): the scene's features and
every feature an edit of values can switch on (features.VALUE_FEATURES).  The shader programs
and parameters are data, so no value edit (a colour, a roughness, a light's power, the world's
strength, a lobe switched on by a value) builds a kernel.  A scene that gains a structural
feature (its first image texture or node program, new mesh attributes) builds in this thread
while the last image stays up; the status line names it.

After every restart the first passes run at reduced resolution, as Cycles' viewport: the divider
is the smallest power of two that brings the region to about ``start_resolution`` squared
pixels, halved each pass down to 1; then passes accumulate at full resolution until the pass
count or the time limit (the viewport's own settings).

Paused (the scene's Pause Viewport), the worker still applies what is posted but renders no
pass, with one exception: until an image at full resolution exists (a new session's first
image, or a restart's reduced levels when the pause came), so a viewport opened paused shows
its scene and says "Rendering Paused" (Cycles' word) instead of looking hung.  Cycles itself
prepares the scene and then waits, its display empty, under the same status.

With denoising on (RenderOptions.denoise, the scene's Viewport Denoise), each image at full
resolution from the start pass on (Cycles' Start Sample) is shown through OIDN with the
render's albedo and normal (denoise.py), and the status line says "Denoised" (before the start
pass: "Denoising from pass N"); switching the denoising alone shows the image so far again,
without a restart.

Every change of what the viewport shows (an image, the status line, an error) increments
``version``; ``snapshot()`` reads all of it at one instant, so a reader that compares versions
cannot miss the last image or an error landing while it draws.
"""
from __future__ import annotations

import sys
import threading
import time
import traceback

import numpy as np

from ppm_engine.errors import PPMError
from ppm_engine.render.options import RenderOptions
from ppm_engine.render.viewport_denoiser import FramePublisher, ViewportDenoiser
from ppm_engine.render.viewport_frame import Frame, Snapshot, divider_for
from ppm_engine.render.viewport_hold import ExportHold
from ppm_engine.scene.camera import scaled_camera

# seconds a new region size must stay before it is rendered (dragging a window's edge)
RESIZE_DEBOUNCE = 0.15

# the viewport's kernels (ViewportSession's ``kernels``) as RenderOptions
KERNELS = {"editable": dict(specialize=True, editable=True),
           "scene": dict(specialize=True, editable=False),
           "all": dict(specialize=False, editable=False)}

# what the worker did with a scene or view change (ViewportSession.actions, newest last)
ACTIONS = ("new", "camera", "upload", "refit", "rebuild")

class ViewportSession(FramePublisher, ExportHold):
    def __init__(self, options: RenderOptions, start_resolution: int = 64,
                 kernels: str = "editable"):
        """``kernels``: "editable" (the scene's features and every one a value edit can switch
        on), or for the benchmark's comparison of cold starts "scene" (a final render's: edits
        may build) and "all" (every feature compiled in)."""
        if kernels not in KERNELS:
            raise ValueError(f"kernels must be one of {', '.join(KERNELS)}")
        self._cond = threading.Condition()
        self._kernels = KERNELS[kernels]
        self._options = options.replace(**self._kernels).validate()
        self._start_resolution = int(start_resolution)
        # what Blender's thread posted and the worker has not taken yet
        self._new_scene = None
        self._new_camera = None
        self._new_options = None
        self._resized_at = 0.0
        self._posted_camera = None          # the last camera posted (update_view compares)
        self._paused = False
        self._display, self._new_display = "Combined", None   # the pass shown, one chosen
        self._closing = False
        self._version = 0                   # grows with every change of what the viewport shows
        self._applying = False              # the worker took posted changes, not yet applied
        # the worker's state (read under the lock by frame(), status(), busy)
        self._frame: Frame | None = None
        self._status = "Waiting for the scene"
        self._status_base = ""             # the last pass's line, before the denoising's note
        # the viewport's denoising (_publish), and how the last denoised image's line ends
        self._denoiser = ViewportDenoiser(self._cond, self._denoised, lambda: self._closing)
        self._denoise_note = " · Denoised"
        self._error: str | None = None
        self._done = False
        self.restarts = 0
        self.actions: list[str] = []        # ACTIONS, one per scene or view change applied
        self.first_pass_seconds: float | None = None   # from the first scene to the first image
        self.setup_seconds: float | None = None        # of the first Renderer (builds included)
        self._t_created = time.perf_counter()
        self._renderer = None
        self._device = None
        self._device_name = None
        self._scene = None             # the scene at full resolution with the view's camera
        self._camera = None
        self._view_camera = False      # whether _camera is a posted view's (else the scene's)
        self._divider = 1
        self._restart_time = 0.0
        self._dropped = False          # the last pass was dropped unfinished (iterate None)
        self._thread = threading.Thread(target=self._run, name="PPM viewport", daemon=True)
        self._thread.start()

    # -- Blender's side: post what changed, read the latest image ---------------------------------
    def update_scene(self, arrays) -> None:
        """A new export of the scene (any edit).  Its camera is replaced by the view's when
        update_view has posted one."""
        with self._cond:
            self._hold_until = 0.0
            self._new_scene = arrays
            self._done = False
            self._cond.notify_all()

    def update_view(self, camera: np.ndarray) -> bool:
        """The view's camera record at full region size (camera.camera_from_view).
        Returns whether it differs from the last one posted (then accumulation restarts)."""
        camera = np.array(camera, copy=True)
        with self._cond:
            old = self._posted_camera
            if old is not None and old.tobytes() == camera.tobytes():
                return False
            if old is not None and (int(old["width"][0]), int(old["height"][0])) != (
                    int(camera["width"][0]), int(camera["height"][0])):
                self._resized_at = time.perf_counter()
            self._posted_camera = self._new_camera = camera
            self._done = False
            self._cond.notify_all()
            return True

    def update_options(self, options: RenderOptions, start_resolution: int | None = None) -> None:
        """New settings (passes, time limit, seed, photons...): rendering restarts when they
        change what is rendered, and resumes when only the pass count or time limit grew."""
        options = options.replace(**self._kernels).validate()
        with self._cond:
            if start_resolution is not None:
                self._start_resolution = int(start_resolution)
            if options != self._options or self._new_options is not None:
                self._new_options = options
                self._done = False
                self._cond.notify_all()

    def pause(self, paused: bool = True) -> None:
        """Pause (the scene's Pause Viewport) or resume.  Paused, no pass runs once an image at
        full resolution exists (a new session still renders its first one)."""
        with self._cond:
            if self._paused != bool(paused):
                self._paused = bool(paused)
                self._version += 1                    # the status line says it
            self._cond.notify_all()

    def frame(self) -> Frame | None:
        """The latest image, or None before the first pass."""
        with self._cond:
            return self._frame

    def status(self) -> str:
        """The line for the viewport's header (also the error, when the session failed)."""
        with self._cond:
            return self._status_line()

    @property
    def error(self) -> str | None:
        with self._cond:
            return self._error

    @property
    def busy(self) -> bool:
        """Whether more images (or another status line) are coming: something posted and not
        yet applied, or a scene whose passes are neither done nor paused."""
        with self._cond:
            return self._busy()

    @property
    def version(self) -> int:
        """Grows with every change of the frame, the status line or the error."""
        with self._cond:
            return self._version

    def snapshot(self) -> Snapshot:
        """The frame, status line, error, busy and version at one instant: whoever draws the
        frame and then asks busy separately can miss the last image or an error landing in
        between; a snapshot's version tells whether anything changed since."""
        with self._cond:
            return Snapshot(self._frame, self._status_line(), self._error, self._busy(),
                            self._version)

    # (these four under the lock)
    def _held(self) -> bool:
        """Paused with an image at full resolution to show: no pass runs."""
        return self._paused and self._frame is not None and self._frame.divider == 1

    def _idle(self) -> bool:
        """Nothing to render until something is posted or the pause ends."""
        return self._done or self._held()

    def _busy(self) -> bool:
        if not self._thread.is_alive() or self._error is not None or self._closing:
            return False
        return (self._new_scene is not None or self._new_camera is not None
                or self._new_options is not None or self._applying or self._new_display is not None
                or self._denoiser.busy
                or (self._scene is not None and not self._idle()))

    def _status_line(self) -> str:
        if self._error is None and self._paused:
            if self._held():
                return f"Rendering Paused · {self._status}"
            return f"Rendering the first image, then pausing · {self._status}"
        return self._status

    def wait(self, predicate=None, timeout: float = 60.0) -> bool:
        """Block until ``predicate(self)`` holds (default: nothing more to render), the session
        failed or ``timeout`` passed; returns whether the predicate holds.  (Tests and the
        benchmark; Blender's thread never waits.)"""
        predicate = predicate or (lambda s: not s.busy)
        end = time.perf_counter() + timeout
        with self._cond:
            while True:
                if predicate(self) or self._error is not None or not self._thread.is_alive():
                    return bool(predicate(self))
                left = end - time.perf_counter()
                if left <= 0:
                    return False
                self._cond.wait(min(left, 0.05))

    def close(self, timeout: float = 5.0) -> bool:
        """Stop the worker; it frees the session's device memory.  Returns whether the worker
        ended within ``timeout`` (a kernel build in progress ends by itself, then frees)."""
        with self._cond:
            self._closing = True
            self._cond.notify_all()
        if threading.current_thread() is not self._thread:
            self._thread.join(timeout)
        self._denoiser.join(timeout)
        return not self._thread.is_alive()

    # -- the worker -----------------------------------------------------------------------------
    def _set_status(self, text: str) -> None:
        with self._cond:
            self._status = text
            self._version += 1
            self._cond.notify_all()

    def _posted(self) -> bool:
        """Whether a change waits (a pass in progress is then dropped: the image it would make
        is already out of date).  A resize still settling does not count."""
        with self._cond:
            return (self._new_scene is not None or self._new_options is not None
                    or (self._export_held() and self._frame is not None)
                    or (self._new_camera is not None
                        and time.perf_counter() >= self._resized_at + RESIZE_DEBOUNCE))

    def _take(self):
        """Wait for work; returns (scene, camera, options) posted since the last take (each None
        if not), or None to stop.  A resize waits until RESIZE_DEBOUNCE s passed without
        another."""
        with self._cond:
            while not self._closing:
                posted = (self._new_scene is not None or self._new_camera is not None
                          or self._new_options is not None or self._new_display is not None)
                settle = self._resized_at + RESIZE_DEBOUNCE - time.perf_counter()
                if self._new_camera is not None and settle > 0 and self._frame is not None:
                    self._cond.wait(settle)            # still resizing: keep the last image
                    continue
                if not posted and self._hold_wait():
                    continue
                if posted or not (self._idle() or self._renderer is None):
                    taken = (self._new_scene, self._new_camera, self._new_options)
                    self._new_scene = self._new_camera = self._new_options = None
                    self._applying = any(x is not None for x in (*taken, self._new_display))
                    return taken
                self._cond.wait()
            return None

    def _run(self) -> None:
        from ppm_engine.render.device import get_device
        try:
            self._device = get_device(self._options.device)
            self._device_name = self._options.device
            self._device.programs.listeners.append(self._on_build)
            while True:
                taken = self._take()
                if taken is None:
                    break
                scene, camera, options = taken
                if scene is not None or camera is not None or options is not None:
                    try:
                        self._apply(scene, camera, options)
                    finally:
                        with self._cond:
                            self._applying = False
                self._show_display()
                with self._cond:
                    idle = self._idle() or self._closing
                if self._renderer is not None and not idle:
                    self._pass()
        except PPMError as e:     # the full message (a compiler's log) for the console
            print(f"PPM viewport: {e}", file=sys.stderr)
            self._fail(str(e))
        except Exception as e:   # a bug: the header says so, the console has the traceback
            traceback.print_exc(file=sys.stderr)
            self._fail(f"internal error ({type(e).__name__}: {e}); the traceback is in the "
                       "console")
        finally:
            dev = self._device
            if dev is not None and self._on_build in dev.programs.listeners:
                dev.programs.listeners.remove(self._on_build)
            self._free()
            with self._cond:
                self._cond.notify_all()

    def _fail(self, message: str) -> None:
        with self._cond:
            self._error = message
            self._status = f"Progressive Photon Mapping: {message}"
            self._version += 1
            self._cond.notify_all()

    def _on_build(self, label: str, done: bool) -> None:
        if threading.current_thread() is self._thread and not done:
            n = self._device.programs.builds
            self._set_status(f"Compiling kernels: {label} ({n} built so far; the last image "
                             "stays up)")

    def _free(self) -> None:
        r, self._renderer = self._renderer, None
        if r is not None:
            with self._device.lock:
                r.close()

    def _level_scene(self):
        """The scene at this pass's resolution."""
        return self._scene.replace(camera=scaled_camera(self._camera, self._divider))

    def _apply(self, scene, camera, options) -> None:
        """Bring the Renderer up to the posted changes and restart the accumulation."""
        from ppm_engine.render.renderer import Renderer
        dropped, self._dropped = self._dropped, False
        if options is not None and scene is None and camera is None \
                and self._renderer is not None and not dropped \
                and options.replace(passes=self._options.passes,
                                    time_limit=self._options.time_limit,
                                    denoise=self._options.denoise) == self._options:
            # only the pass count, the time limit or the denoising: go on
            denoise_changed = options.denoise != self._options.denoise
            self._options = options
            elapsed = time.perf_counter() - self._restart_time
            with self._cond:
                self._done = self._divider == 1 and (
                    self._renderer.passes_done >= options.passes
                    or 0 < options.time_limit <= elapsed)
            if denoise_changed and self._frame is not None and self._divider == 1:
                self._publish(None)             # the image so far, denoised or not
            return
        if options is not None:
            self._options = options
        if camera is not None:
            self._camera, self._view_camera = camera, True
        if scene is not None:
            if not self._view_camera:                  # no view posted: the scene's camera
                self._camera = np.array(scene.camera, copy=True)
            self._scene = scene.replace(camera=self._camera)
        elif camera is not None and self._scene is not None:
            self._scene = self._scene.replace(camera=self._camera)
        if self._scene is None:
            return                                     # a view before any scene
        w, h = int(self._camera["width"][0]), int(self._camera["height"][0])
        with self._cond:
            start = self._start_resolution
        self._divider = divider_for(w, h, start)
        level = self._level_scene()
        o, r = self._options, self._renderer
        if r is not None and o.device != r.options.device:     # another device chosen
            self._free()
            r = None
        if o.device != self._device_name:
            from ppm_engine.render.device import get_device
            self._device.programs.listeners.remove(self._on_build)
            self._device = get_device(o.device)
            self._device.programs.listeners.append(self._on_build)
            self._device_name = o.device
        with self._device.lock:
            if r is None:
                self._set_status("Building the scene's BVH and kernels")
                t0 = time.perf_counter()
                self._renderer = Renderer(level, o)
                if self.setup_seconds is None:
                    self.setup_seconds = time.perf_counter() - t0
                action = "new"
            elif scene is None:
                r.reset(o, level)                      # the camera (and options) only
                action = "camera"
            elif r.can_reuse(o, level):
                r.reset(o, level)                      # materials, lights, world: no BVH work
                action = "upload"
            elif r.refit(level):
                r.reset(o)                             # the same triangles moved
                action = "refit"
            else:
                self._free()
                self._set_status("Building the scene's BVH")
                self._renderer = Renderer(level, o)
                action = "rebuild"
        for w in self._renderer.warnings if action in ("new", "rebuild", "refit") else ():
            print(f"PPM viewport: {w}", file=sys.stderr)
        with self._cond:
            self.actions.append(action)
            del self.actions[:-256]
            self.restarts += 1
            self._done = False
            self._cond.notify_all()
        self._restart_time = time.perf_counter()

    def _pass(self) -> None:
        """One pass at the current level, its image published; then the next level or done."""
        r, o = self._renderer, self._options
        with self._device.lock:
            stats = r.iterate(interrupt=self._posted)
            if stats is None:                          # dropped for a newer view or edit:
                self._dropped = True                   # the next change restarts for sure
                return
        full_done = self._publish(stats)
        with self._cond:
            restarted = (self._new_scene is not None or self._new_camera is not None
                         or self._new_options is not None)
        if restarted or full_done or self._divider == 1:
            return
        self._divider //= 2                            # the next, finer level
        with self._device.lock:
            r.reset(o, self._level_scene())
