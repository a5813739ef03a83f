"""Stand-ins for headless viewport tests (test_viewport_draw.py, test_viewport_camera.py):
Blender's gpu module, a RenderEngine's viewport calls, bpy.app.timers, a region and its
context, a turn of Blender's main loop, and a Renderer that renders nothing (no kernel build)
and passes only when a test lets it."""
import dataclasses
import sys
import threading
import types

import numpy as np

W, H = 64, 48                          # the fake region


def stub_gpu(monkeypatch) -> list:
    """A stub of Blender's gpu module and gpu_extras.presets that records every call, in order,
    in the returned list (draw_frame imports them when it runs); its GPUTexture.fail, when set,
    is raised by the next texture made."""

    class Calls(list):
        pass
    calls = Calls()

    class Buffer:
        def __init__(self, fmt, size, data):
            self.data = np.array(data, np.float32)
            calls.append(("Buffer", fmt, size, len(self.data)))

    class GPUTexture:
        fail = None

        def __init__(self, size, format, data):
            if GPUTexture.fail is not None:
                raise GPUTexture.fail
            self.size, self.format, self.data = size, format, data
            calls.append(("GPUTexture", tuple(size), format))

    mod = types.ModuleType("gpu")
    mod.types = types.SimpleNamespace(Buffer=Buffer, GPUTexture=GPUTexture)
    mod.state = types.SimpleNamespace(blend_set=lambda mode: calls.append(("blend_set", mode)))
    presets = types.ModuleType("gpu_extras.presets")
    presets.draw_texture_2d = lambda tex, pos, w, h: calls.append(
        ("draw_texture_2d", tex, tuple(pos), w, h))
    extras = types.ModuleType("gpu_extras")
    extras.presets = presets
    monkeypatch.setitem(sys.modules, "gpu", mod)
    monkeypatch.setitem(sys.modules, "gpu_extras", extras)
    monkeypatch.setitem(sys.modules, "gpu_extras.presets", presets)
    calls.GPUTexture = GPUTexture
    return calls



class Engine:
    """A RenderEngine's viewport calls: redraws tagged (a flag the loop below reads, as Blender's
    window manager reads RE_ENGINE_DO_DRAW), the header's text, reports, the display shader."""

    def __init__(self, calls=None):
        self.calls = calls if calls is not None else []
        self.tags, self.flag = 0, False
        self.stats, self.reports = [], []
        self.on_stats = None                  # a hook: runs inside the next update_stats

    def tag_redraw(self):
        self.tags += 1
        self.flag = True

    def update_stats(self, stats, info):
        hook, self.on_stats = self.on_stats, None
        if hook is not None:
            hook()
        self.stats.append(info)

    def report(self, kind, message):
        self.reports.append((set(kind), message))

    def bind_display_space_shader(self, scene):
        self.calls.append(("bind_display_space_shader", scene))

    def unbind_display_space_shader(self):
        self.calls.append(("unbind_display_space_shader",))


class Timers:
    """bpy.app.timers' API: functions registered by identity, each run returns the seconds to
    its next run or None to stop (intervals are not simulated: each loop turn runs them)."""

    def __init__(self):
        self.fns = []

    def register(self, fn, first_interval=0.0):
        self.fns.append(fn)

    def is_registered(self, fn):
        return any(f is fn for f in self.fns)

    def unregister(self, fn):
        self.fns = [f for f in self.fns if f is not fn]

    def run(self):
        for fn in list(self.fns):
            if fn() is None:
                self.unregister(fn)


def scene_stub(paused=False):
    render = types.SimpleNamespace(preview_pixel_size="1", film_transparent=False)
    return types.SimpleNamespace(ppm=types.SimpleNamespace(viewport_pause=paused), render=render)


def context_stub(rv3d=None, width=W, height=H, ui_pixel_size=1.0, render_pass=None):
    """A context of a fake region; with ``render_pass`` its 3D view's (shading.ppm's)."""
    shading = types.SimpleNamespace(ppm=types.SimpleNamespace(render_pass=render_pass))
    return types.SimpleNamespace(
        region=types.SimpleNamespace(width=width, height=height), region_data=rv3d,
        preferences=types.SimpleNamespace(system=types.SimpleNamespace(pixel_size=ui_pixel_size)),
        space_data=types.SimpleNamespace(shading=shading) if render_pass else None)


def loop(driver, engine, context, depsgraph, timers, turns=20):
    """Turns of Blender's main loop: timers run, then the region redraws if a redraw was tagged."""
    for _ in range(turns):
        timers.run()
        if engine.flag:
            engine.flag = False
            driver.view_draw(engine, context, depsgraph)



@dataclasses.dataclass(frozen=True)
class Arrays:
    """The part of SceneArrays the session reads."""
    camera: np.ndarray

    def replace(self, **kw):
        return dataclasses.replace(self, **kw)


class Script:
    """What the stand-in Renderers do: ``gate`` (a semaphore: one release, one pass; None: no
    waiting), the image's value, errors to raise at build or at the next pass, and a record
    of the passes run (their resolution) and of the session's status at each build."""

    def __init__(self, gate=True, value=0.5):
        self.gate = threading.Semaphore(0) if gate else None
        self.value = value
        self.build_error = self.pass_error = None
        self.passes, self.built_status = [], []
        self.session = None


class FakeRenderer:
    script: Script = None

    def __init__(self, scene, options):
        sc = FakeRenderer.script
        sc.built_status.append(sc.session.status())
        if sc.build_error is not None:
            raise sc.build_error
        self.options, self.warnings, self.passes_done = options, [], 0
        self._level(scene)

    def _level(self, scene):
        self.width, self.height = int(scene.camera["width"][0]), int(scene.camera["height"][0])

    def reset(self, options, scene=None):
        self.options, self.passes_done = options, 0
        if scene is not None:
            self._level(scene)

    def can_reuse(self, options, scene):
        return True

    def refit(self, scene):
        return True

    def iterate(self, interrupt=None):
        sc = FakeRenderer.script
        if sc.gate is not None and not sc.gate.acquire(timeout=0.05):
            return None                                # not let through yet: as a dropped pass
        if sc.pass_error is not None:
            raise sc.pass_error
        self.passes_done += 1
        sc.passes.append((self.width, self.height))
        return types.SimpleNamespace(converged=False,
                                     line=lambda n, t, limit: f"pass {self.passes_done}/{n}")

    def image(self):
        value = FakeRenderer.script.value
        img = np.full((self.height, self.width, 4), 0.5, np.float32)
        img[..., 0] = value
        return img

    def passes(self):
        """The other passes (Renderer.passes), each one value."""
        values = {"Denoising Albedo": (0.25, 0.5, 0.75), "Denoising Normal": (0.0, -0.6, 0.8),
                  "PPM Radius": (0.125,), "PPM Photons": (7.0,)}
        return {name: np.full((self.height, self.width, len(v)), v, np.float32)
                for name, v in values.items()}

    def close(self):
        pass


def stub_sessions(monkeypatch):
    """(make, made): make(passes, start, paused, gate, value) -> (ViewportSession, Script), a
    session on a 64 x 48 view with the stand-in Renderer and device (patched in with
    ``monkeypatch``); made: every (session, script) made, for the caller to close."""
    import ppm_engine.render.device as device
    import ppm_engine.render.renderer as renderer
    from ppm_engine.render.options import RenderOptions
    from ppm_engine.render.viewport_session import ViewportSession
    from ppm_engine.scene.camera import make_camera
    dev = types.SimpleNamespace(programs=types.SimpleNamespace(listeners=[], builds=0),
                                lock=threading.RLock())
    monkeypatch.setattr(device, "get_device", lambda name: dev)
    monkeypatch.setattr(renderer, "Renderer", FakeRenderer)
    made = []

    def make(passes=2, start=0, paused=False, gate=True, value=0.5):
        sc = Script(gate, value)
        FakeRenderer.script = sc
        s = ViewportSession(RenderOptions(passes=passes), start)
        sc.session = s
        made.append((s, sc))
        s.pause(paused)
        cam = make_camera(width=W, height=H, to_world=np.eye(4)[:3], extent=(1.0, 0.75))
        s.update_view(cam)
        s.update_scene(Arrays(cam))
        return s, sc

    return make, made


def released(s, sc, n=1):
    """Let ``n`` passes through and wait until their images are out."""
    gen = s.frame().generation if s.frame() is not None else 0
    for _ in range(n):
        sc.gate.release()
    assert s.wait(lambda s: s.frame() is not None and s.frame().generation >= gen + n,
                  timeout=10), s.status()


def driver_for(s):
    """(ViewportDriver of session ``s``, its Timers)."""
    from ppm_engine.blender.viewport import ViewportDriver
    timers = Timers()
    drv = ViewportDriver(timers=timers)
    drv.session = s
    return drv, timers

