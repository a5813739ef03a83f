"""How a viewport pass's image reaches the display (ViewportSession's FramePublisher), and the
viewport's denoising on a thread of its own (with Viewport Denoise on): OIDN on the CPU takes
far longer than a pass of a small viewport (1.5 s for 640 x 360 at Balanced on a loaded 2-core
machine), so the worker never waits for it: it posts the image of a pass and goes on, the
thread denoises the latest image posted (one waiting at most: a newer one replaces it) and
hands it back.  No bpy; the device only through the session's renderer, under its lock."""
from __future__ import annotations

import dataclasses
import sys
import threading
import time
import traceback

import numpy as np

from ppm_engine.render.viewport_frame import (
    DISPLAY_PASSES,
    IMAGE_PASSES,
    Frame,
    display_image,
    pass_image,
)
from ppm_engine.scene.camera import region_fraction

NOT_LOADED = " · Not denoised: Open Image Denoise could not be loaded (console)"


@dataclasses.dataclass(frozen=True)
class DenoiseJob:
    """One image to denoise: the renderer's (h, w, 4), its albedo and normal, the settings,
    and where it belongs (the restart, its passes, the region's size)."""
    image: np.ndarray
    albedo: np.ndarray
    normal: np.ndarray
    settings: object            # DenoiseSettings
    restart: int
    passes: int
    size: tuple[int, int]


class ViewportDenoiser:
    """``post(job)`` and ``busy`` are called with ``cond`` held (the session's lock); the
    thread calls ``done(job, image, note)`` with it held too, ``note`` the status line's
    ending (" · Denoised", or why not).  ``closing()`` (under the lock) ends the thread."""

    def __init__(self, cond: threading.Condition, done, closing):
        self._cond, self._done, self._closing = cond, done, closing
        self._job: DenoiseJob | None = None
        self._running = False
        self._warned = False              # OIDN's load failure printed once
        self._thread: threading.Thread | None = None

    @property
    def busy(self) -> bool:
        """An image waits or is being denoised."""
        return self._job is not None or self._running

    def post(self, job: DenoiseJob) -> None:
        self._job = job
        if self._thread is None:
            self._thread = threading.Thread(target=self._loop, name="PPM viewport denoiser",
                                            daemon=True)
            self._thread.start()
        self._cond.notify_all()

    def join(self, timeout: float) -> None:
        """Wait for the thread after closing (a denoise in progress ends by itself)."""
        t = self._thread
        if t is not None and threading.current_thread() is not t:
            t.join(timeout)

    def _loop(self) -> None:
        from ppm_engine.render.denoise import DenoiserUnavailable, denoise
        while True:
            with self._cond:
                while self._job is None and not self._closing():
                    self._cond.wait()
                if self._closing():
                    return
                job, self._job = self._job, None
                self._running = True
            note = " · Denoised"
            try:
                image = denoise(job.image, job.albedo, job.normal, job.settings)
            except DenoiserUnavailable as e:
                image, note = job.image, NOT_LOADED
                if not self._warned:
                    self._warned = True
                    print(f"PPM viewport: {e}", file=sys.stderr)
            except Exception as e:       # a bug or OIDN's own error: the image as rendered
                image, note = job.image, f" · Not denoised: {type(e).__name__} (console)"
                traceback.print_exc(file=sys.stderr)
            with self._cond:
                self._running = False
                self._done(job, image, note)
                self._cond.notify_all()


class FramePublisher:
    """ViewportSession's publishing of a pass's image (its worker's state: the renderer, the
    options, the lock, the frame and status line; the denoiser), and of the pass it shows."""

    def display_pass(self, name: str) -> None:
        """Show the pass ``name`` (viewport_frame.DISPLAY_PASSES; the shading popover's Render
        Pass): the image so far is shown again as that pass, with no restart."""
        if name not in DISPLAY_PASSES:
            raise ValueError(f"no display pass {name!r}: one of {', '.join(DISPLAY_PASSES)}")
        with self._cond:
            if name != (self._new_display or self._display):
                self._new_display = name
                self._cond.notify_all()

    def _show_display(self) -> None:
        """(The worker, after a take) the display pass chosen since, shown from now on: the
        image so far again as that pass (after a restart, the next pass's)."""
        with self._cond:
            shown, self._new_display = self._new_display, None
            if shown is not None:
                self._display = shown
        try:
            if shown is not None and self._renderer is not None and self._frame is not None \
                    and self._renderer.passes_done > 0:
                self._publish(None)
        finally:
            with self._cond:
                self._applying = False

    def _publish(self, stats) -> bool:
        """The renderer's image so far as the new frame, with its status line (``stats`` of
        the pass just run; None: the last pass's line again, after a change of the denoising
        alone).  From the denoising's start pass on, at full resolution, the image goes to the
        denoiser's thread instead (ViewportDenoiser), which shows it when denoised: when
        that thread is idle, or always for the render's last image, so that denoising never
        holds the passes up nor a view change.  Returns whether the render is done."""
        r, o = self._renderer, self._options
        d = o.denoise
        with self._cond:
            show = self._display
        denoised = (d is not None and show == "Combined" and self._divider == 1
                    and r.passes_done >= d.start)
        with self._device.lock:
            image = r.image()
            aux = r.passes() if denoised or show not in IMAGE_PASSES else None
        elapsed = time.perf_counter() - self._restart_time
        w, h = int(self._camera["width"][0]), int(self._camera["height"][0])
        with self._cond:
            full_done = self._done
            if stats is not None:
                if self._divider > 1:
                    self._status_base = (f"Pass 1 at 1/{self._divider} resolution · "
                                         f"{r.width} x {r.height}")
                else:
                    self._status_base = stats.line(o.passes, elapsed, o.time_limit)
                limit = o.time_limit > 0 and elapsed >= o.time_limit
                full_done = self._divider == 1 and (r.passes_done >= o.passes or limit
                                                    or stats.converged)
                if full_done:
                    self._done = True
                    self._status_base += " · done"
            post = denoised and (full_done or not self._denoiser.busy)
            note = (f" · Denoising from pass {d.start}" if d is not None and not denoised
                    and show == "Combined" and self._divider == 1 else "")
            if show != "Combined":
                note += f" · {show}"
            # the image as rendered, unless it goes to the denoiser (the last image stays up
            # meanwhile, when it shows the same pass)
            if not denoised or self._frame is None or self._frame.display != show:
                if self.first_pass_seconds is None:
                    self.first_pass_seconds = time.perf_counter() - self._t_created
                gen = self._frame.generation + 1 if self._frame is not None else 1
                self._frame = Frame(display_image(pass_image(show, image, aux)), w, h,
                                    self._divider, r.passes_done, gen, self.restarts,
                                    region_fraction(self._camera), show)
            if not denoised:
                self._status = self._status_base + note
            else:
                self._status = self._status_base + self._denoise_note
            if post:        # (under the lock: nobody sees the render done and no job waiting)
                self._denoiser.post(DenoiseJob(image, aux["Denoising Albedo"],
                                               aux["Denoising Normal"], d, self.restarts,
                                               r.passes_done, (w, h)))
            self._version += 1
            self._cond.notify_all()
        return full_done

    def _denoised(self, job: DenoiseJob, image: np.ndarray, note: str) -> None:
        """The denoiser's image (under the lock), shown if the render it belongs to is still
        the one rendering with the same denoising."""
        self._denoise_note = note
        if job.restart == self.restarts and job.settings == self._options.denoise \
                and self._display == "Combined":
            gen = self._frame.generation + 1 if self._frame is not None else 1
            self._frame = Frame(display_image(image), *job.size, 1, job.passes, gen,
                                job.restart, region_fraction(self._camera))
            self._status = self._status_base + note
            self._version += 1
            if self.first_pass_seconds is None:
                self.first_pass_seconds = time.perf_counter() - self._t_created

