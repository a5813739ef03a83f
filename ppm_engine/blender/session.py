"""One render of one view layer: export -> Renderer -> SPPM passes until the pass count, the
time limit or a cancel -> the render result, with progress and stats after every pass.

The render result is always begun and ended, also on errors (Blender can crash saving a frame
whose engine wrote no result), and whatever was rendered stays in it.
"""
import collections
import collections.abc
import contextlib
import sys
import time
import traceback

import numpy as np

from ppm_engine.errors import PPMError

# With quick passes the image is written at most this often (seconds); the last pass always is.
WRITE_INTERVAL = 0.25


# Material, world and light previews (RenderEngine.is_preview): icons (the longer side at most
# PREVIEW_ICON_SIZE pixels) render PREVIEW_ICON_PASSES passes, the Preview panel's larger image
# PREVIEW_PASSES; both with the viewport's "editable" kernels (RenderOptions.editable): a
# preview of another material's values builds nothing.
PREVIEW_ICON_SIZE, PREVIEW_ICON_PASSES, PREVIEW_PASSES = 96, 8, 32


def preview_options(options, width: int, height: int):
    """The options of a preview render of ``width`` x ``height`` pixels."""
    passes = PREVIEW_ICON_PASSES if max(width, height) <= PREVIEW_ICON_SIZE else PREVIEW_PASSES
    return options.replace(passes=min(options.passes, passes), specialize=True,
                           editable=True).validate()


# Render passes besides Combined: (name, channels, channel ids, type).  The denoising pair lets
# Blender's compositor Denoise node work on our renders; the last two are diagnostics.
RENDER_PASSES = (
    ("Combined", 4, "RGBA", 'COLOR'),
    ("Denoising Albedo", 3, "RGB", 'COLOR'),
    ("Denoising Normal", 3, "XYZ", 'VECTOR'),
    ("PPM Radius", 1, "X", 'VALUE'),
    ("PPM Photons", 1, "X", 'VALUE'),
)
# with Denoise on (scene.ppm.denoise), the image before denoising, as Cycles keeps it
NOISY_PASS = ("Noisy Image", 4, "RGBA", 'COLOR')


def render_passes(scene) -> tuple:
    """The render passes of ``scene``: RENDER_PASSES, and NOISY_PASS when it denoises."""
    ppm = getattr(scene, "ppm", None) if scene is not None else None
    return RENDER_PASSES + ((NOISY_PASS,) if getattr(ppm, "denoise", False) else ())


# --- what renders tell the code that drives them (the CLI, the benchmark, tests) ---------------
_listeners: list = []


@contextlib.contextmanager
def listening(callback):
    """Within the block, ``callback(text, fraction)`` is called after every pass of every
    render: a one-line progress text such as "Pass 12/64 · 3.1M photons · 2.4 s" and the
    render's progress in [0, 1].  (update_stats() shows nothing in background mode: the CLI
    draws its progress bar from this.)"""
    _listeners.append(callback)
    try:
        yield
    finally:
        _listeners.remove(callback)


class RenderRecords(collections.abc.Sequence):
    """One record per render, the last 64, oldest first: what it reused ("persistent",
    "exported", "bvh_built", "bvh_refit", "dark"), "setup_s" (export and setup before the first
    pass) and "passes" (passes run)."""

    def __init__(self, keep: int = 64):
        self._records = collections.deque(maxlen=keep)

    def __getitem__(self, k):
        return self._records[k]

    def __len__(self) -> int:
        return len(self._records)

    def clear(self) -> None:
        self._records.clear()

    def _add(self, record: dict) -> None:
        self._records.append(record)


renders = RenderRecords()


# depsgraph update types that change what we export (measured in bpy 5.0: with persistent
# data and nothing changed, every object still reports a shading update and the scene
# collection a geometry update, so those flags alone mean nothing)
_EXPORTED_TYPES = {'MATERIAL', 'LIGHT', 'WORLD', 'CAMERA', 'NODETREE', 'IMAGE', 'TEXTURE'}


def _scene_changed(depsgraph) -> bool:
    for u in depsgraph.updates:
        t = getattr(u.id, "id_type", "") if u.id is not None else ""
        if t in _EXPORTED_TYPES:
            return True
        if t == 'OBJECT' and (u.is_updated_transform or u.is_updated_geometry):
            return True
        if t not in ('OBJECT', 'SCENE', 'COLLECTION') and u.is_updated_geometry:
            return True        # mesh, curve... data
    return False


def _render_key(depsgraph) -> tuple:
    """What the depsgraph does not report and the export depends on: frame, resolution,
    border, Cycles' film settings (pixel filter, transparency, exposure) and Light Paths, layer,
    camera.  (Our settings are not in it: changing them re-renders without re-export.)"""
    from ppm_engine.blender.export.camera import film_settings
    from ppm_engine.scene.light_paths import from_cycles
    scene, r = depsgraph.scene, depsgraph.scene.render
    return (scene.frame_current, r.resolution_x, r.resolution_y,
            r.resolution_percentage, r.pixel_aspect_x, r.pixel_aspect_y, r.use_border,
            r.border_min_x, r.border_max_x, r.border_min_y, r.border_max_y,
            tuple(film_settings(scene).values()),
            from_cycles(getattr(scene, "cycles", None)).tobytes(),
            depsgraph.view_layer.name, scene.camera.name if scene.camera else None)


def emits_nothing(arrays) -> bool:
    """No light with power, no emissive triangle, a black world: the image is black.  (NaN in
    the camera, the world or a material is refused first, as the renderer would.)"""
    from ppm_engine.scene.emitters import emits_light
    from ppm_engine.scene.materials import kernel_materials, kernel_nodes, world_medium
    from ppm_engine.scene.prep import check_finite
    check_finite(arrays)
    return not emits_light(arrays, kernel_materials(arrays.materials,
                                                    kernel_nodes(arrays.shader_nodes),
                                                    world_medium(arrays), arrays.svm))


class Session:
    """Owns the Renderer of one engine instance.  Without persistent data every render builds
    a fresh one and frees it at the end.  With Blender's persistent data
    (render.use_persistent_data) the Renderer stays: an unchanged scene re-renders without
    re-export, BVH build or program build (also when only our settings changed); changed
    lights, materials or camera keep the BVH; moved or deformed geometry with the same
    triangles refits it; other geometry changes build anew.  A scene that emits nothing gets a
    black image and a warning, with no device work at all."""

    def __init__(self):
        self.renderer = None
        self.arrays = None
        self.dark = None            # emits_nothing(self.arrays)
        self.key = None
        self.written_passes = 0     # passes of the current renderer whose image is in the result

    def _prepare(self, engine, depsgraph, options):
        """The SceneArrays and a Renderer ready for pass 1 (None for a scene that emits
        nothing), reusing what persistent data may."""
        from ppm_engine.blender.export import export_scene
        from ppm_engine.render.renderer import Renderer
        persistent = bool(depsgraph.scene.render.use_persistent_data)
        key = _render_key(depsgraph) if persistent else None
        log = {"persistent": persistent, "exported": True, "bvh_built": False,
               "bvh_refit": False, "dark": False}
        t0 = time.perf_counter()
        if persistent and self.arrays is not None and key == self.key \
                and not _scene_changed(depsgraph):
            arrays = self.arrays
            log["exported"] = False
        else:
            engine.update_stats("", "Exporting scene")
            arrays = export_scene(depsgraph, engine)
        r = self.renderer
        if arrays is self.arrays and self.dark is not None:
            dark = self.dark
        else:
            dark = self.dark = emits_nothing(arrays)
        if not dark and len(options.devices) > 1:
            # several devices (the Device panel's ticked list): a MultiRenderer each time,
            # not kept (persistent data keeps one device's Renderer)
            from ppm_engine.render.multi_device import MultiRenderer
            engine.update_stats("", "Building kernels on every device, uploading the scene")
            self.free()
            self.renderer = MultiRenderer(arrays, options, options.devices)
            log["bvh_built"] = True
            persistent, key = False, None
        elif dark:
            engine.report({'WARNING'}, "The scene emits no light (no light with power, no "
                                       "emissive material, a black world): the image is black")
            self.free()
            log["dark"] = True
        elif persistent and r is not None and r.can_reuse(options, arrays):
            r.reset(options, None if arrays is self.arrays else arrays)
        elif persistent and r is not None and options.device == r.options.device \
                and r.refit(arrays):
            log["bvh_refit"] = True
            r.reset(options)
        else:
            engine.update_stats("", "Building kernels, uploading scene, building BVH")
            self.free()
            self.renderer = Renderer(arrays, options)
            log["bvh_built"] = True
            for w in self.renderer.warnings:     # what the device copy of the scene dropped
                engine.report({'WARNING'}, w)
        self.arrays, self.key, self.dark = arrays, key, dark
        log["setup_s"] = time.perf_counter() - t0
        renders._add(log)
        return arrays

    def free(self) -> None:
        r, self.renderer, self.arrays, self.key = self.renderer, None, None, None
        self.dark = None
        if r is not None:
            r.close()

    # ----------------------------------------------------------------------------------------
    def render(self, engine, depsgraph) -> None:
        layer = depsgraph.view_layer.name
        result = None
        error = None
        try:
            from ppm_engine.blender.properties import to_options

            options = to_options(depsgraph.scene.ppm)
            if getattr(engine, "is_preview", False):
                options = preview_options(options, engine.resolution_x, engine.resolution_y)
            arrays = self._prepare(engine, depsgraph, options)
            w, h = arrays.resolution
            # coordinates are relative to the border rectangle (Blender clamps the result to it)
            result = engine.begin_result(0, 0, w, h, layer=layer)
            if (result.resolution_x, result.resolution_y) != (w, h):
                raise PPMError(f"internal error: the exported render region is {w}x{h} but "
                               f"Blender's render result is {result.resolution_x}x"
                               f"{result.resolution_y}")
            self.written_passes = 0
            if self.renderer is None:         # emits nothing: black, no device work
                self._write_black(engine, result, w, h)
            else:
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
                if error is not None or not depsgraph.scene.render.use_persistent_data:
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
            if stats is None:            # several devices: every pass already done
                break
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
            text = stats.line(options.passes, elapsed, options.time_limit)
            engine.update_stats("", text)
            for listener in tuple(_listeners):
                listener(text, min(progress, 1.0))
            if stats.converged:          # adaptive sampling: every pixel below the threshold
                break
        if options.denoise is not None and not cancelled:
            text = f"Denoising after pass {r.passes_done}"
            engine.update_stats("", text)
            for listener in tuple(_listeners):
                listener(text, 1.0)
            self._write(engine, result, options.denoise)
        elif r.passes_done > self.written_passes:
            self._write(engine, result)
        if renders:
            renders[-1]["passes"] = r.passes_done
        if cancelled:
            engine.update_stats("", f"Cancelled after pass {r.passes_done}")

    def _write_black(self, engine, result, w: int, h: int) -> None:
        """Combined black and opaque; the other passes zero."""
        for name, channels, *_ in (*RENDER_PASSES, NOISY_PASS):
            p = result.layers[0].passes.get(name)
            if p is None:
                continue
            a = np.zeros((w * h, channels), np.float32)
            if name == "Combined":
                a[:, 3] = 1.0
            p.rect.foreach_set(a.ravel())
        engine.update_result(result)
        engine.update_progress(1.0)
        engine.update_stats("", "The scene emits no light: black image")

    def _write(self, engine, result, denoise=None) -> None:
        """The image so far into the result; with ``denoise`` (DenoiseSettings) the Combined
        pass denoised (denoise.py) and the image as rendered in Noisy Image.  Where OIDN cannot
        be loaded, a warning says why and the image stays as rendered."""
        passes = result.layers[0].passes
        img = np.ascontiguousarray(self.renderer.image(), dtype=np.float32)
        extra = [name for name, *_ in RENDER_PASSES[1:] if passes.get(name) is not None]
        aux = self.renderer.passes() if extra or denoise is not None else {}
        noisy = passes.get(NOISY_PASS[0])
        if noisy is not None:
            noisy.rect.foreach_set(img.ravel())
        if denoise is not None:
            from ppm_engine.render.denoise import DenoiserUnavailable
            from ppm_engine.render.denoise import denoise as run_denoiser
            try:
                img = run_denoiser(img, aux["Denoising Albedo"], aux["Denoising Normal"],
                                   denoise)
            except DenoiserUnavailable as e:
                engine.report({'WARNING'}, f"Not denoised: {e}")
        passes["Combined"].rect.foreach_set(img.ravel())
        for name in extra:
            passes[name].rect.foreach_set(np.ascontiguousarray(aux[name], np.float32).ravel())
        engine.update_result(result)
        self.written_passes = self.renderer.passes_done
