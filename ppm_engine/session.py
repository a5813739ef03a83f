"""One render of one view layer: export -> Renderer -> SPPM passes until the pass count, the
time limit or a cancel -> the render result, with progress and stats after every pass.

The render result is always begun and ended, also on errors (Blender can crash saving a frame
whose engine wrote no result), and whatever was rendered stays in it.
"""
import sys
import time
import traceback

import numpy as np

from .errors import PPMError

# Callables ``f(text)`` called after every pass with a one-line progress text such as
# "Pass 12/64 · 3.1M photons · 2.4 s".  The CLI adds one that prints to stderr, because
# update_stats() shows nothing in background mode.
progress_listeners: list = []

# With quick passes the image is written at most this often (seconds); the last pass always is.
WRITE_INTERVAL = 0.25


def _si(n: float) -> str:
    for unit, div in (("G", 1e9), ("M", 1e6), ("K", 1e3)):
        if n >= div:
            return f"{n / div:.1f}{unit}"
    return str(int(n))


class Session:
    """Owns the Renderer of one engine instance.  Today every render builds a fresh one and
    frees it at the end; persistent data can later keep ``self.renderer`` between renders."""

    def __init__(self):
        self.renderer = None
        self.written_passes = 0     # passes of the current renderer whose image is in the result

    def free(self) -> None:
        r, self.renderer = self.renderer, None
        if r is not None:
            r.close()

    # ----------------------------------------------------------------------------------------
    def render(self, engine, depsgraph) -> None:
        layer = depsgraph.view_layer.name
        result = None
        error = None
        try:
            from .export import export_scene
            from .properties import to_options
            from .renderer import Renderer

            engine.update_stats("", "Exporting scene")
            options = to_options(depsgraph.scene.ppm)
            arrays = export_scene(depsgraph, engine)
            w, h = arrays.resolution
            # coordinates are relative to the border rectangle (BLENDER_NOTES section 1)
            result = engine.begin_result(0, 0, w, h, layer=layer)
            if (result.resolution_x, result.resolution_y) != (w, h):
                raise PPMError(f"internal error: the exported render region is {w}x{h} but "
                               f"Blender's render result is {result.resolution_x}x"
                               f"{result.resolution_y}")
            engine.update_stats("", "Building kernels, uploading scene, building BVH")
            self.free()
            self.renderer = Renderer(arrays, options)
            self.written_passes = 0
            self._passes(engine, result, options)
        except PPMError as e:
            error = str(e)
        except Exception as e:  # a bug: say so briefly, keep the traceback for the console
            traceback.print_exc(file=sys.stderr)
            error = (f"Progressive Photon Mapping failed with an internal error "
                     f"({type(e).__name__}: {e}); the traceback is in the console")
        finally:
            try:
                if result is None:  # no region yet: Blender clamps this to the border rectangle
                    result = engine.begin_result(0, 0, engine.resolution_x, engine.resolution_y,
                                                 layer=layer)
                elif self.renderer is not None and self.renderer.passes_done > self.written_passes:
                    self._write(engine, result)   # passes finished but not yet shown
            except Exception:
                traceback.print_exc(file=sys.stderr)
            finally:
                if result is not None:
                    engine.end_result(result)
                self.free()
        if error is not None:
            engine.report({'ERROR'}, error)

    # ----------------------------------------------------------------------------------------
    def _passes(self, engine, result, options) -> None:
        """Run passes until the pass count, the time limit or a cancel; show their image."""
        r = self.renderer
        start = time.perf_counter()
        last_write = float("-inf")   # the first pass is always shown
        cancelled = False
        while r.passes_done < options.passes:
            elapsed = time.perf_counter() - start
            if options.time_limit > 0 and elapsed >= options.time_limit:
                break
            if engine.test_break():
                cancelled = True
                break
            stats = r.iterate()
            now = time.perf_counter()
            elapsed = now - start
            done = r.passes_done
            if now - last_write >= WRITE_INTERVAL or done >= options.passes or (
                    options.time_limit > 0 and elapsed >= options.time_limit):
                self._write(engine, result)
                last_write = now
            progress = done / options.passes
            if options.time_limit > 0:
                progress = max(progress, elapsed / options.time_limit)
            engine.update_progress(min(progress, 1.0))
            text = (f"Pass {done}/{options.passes} · {_si(stats.photons_emitted)} photons · "
                    f"{elapsed:.1f} s")
            engine.update_stats("", text)
            for listener in progress_listeners:
                listener(text)
        if r.passes_done > self.written_passes:
            self._write(engine, result)
        if cancelled:
            engine.update_stats("", f"Cancelled after pass {r.passes_done}")

    def _write(self, engine, result) -> None:
        img = np.ascontiguousarray(self.renderer.image(), dtype=np.float32)
        result.layers[0].passes["Combined"].rect.foreach_set(img.ravel())
        engine.update_result(result)
        self.written_passes = self.renderer.passes_done
