"""The viewport's drawing, headless: draw_frame against a stub of Blender's gpu module, view_draw
and its redraws driven by a simulated window-manager loop (a fake engine and region, a stand-in
for bpy.app.timers), its errors, and the session's pause.  Where the rendering itself does not
matter, the session runs a stand-in Renderer that renders nothing (no kernel build) and passes
only when the test lets it, so each interleaving is forced, not hoped for
(tests/helpers/viewport_stubs.py).  The view's camera and pixel size: test_viewport_camera.py;
the session with real scenes: test_viewport.py."""
import dataclasses
import types

import numpy as np
import pytest

from tests.helpers.viewport_stubs import (
    Engine,
    H,
    W,
    context_stub,
    driver_for,
    loop,
    released,
    scene_stub,
    stub_gpu,
    stub_sessions,
)


@pytest.fixture
def gpu(monkeypatch):
    """The gpu module's stub (viewport_stubs.stub_gpu): the list of its calls."""
    return stub_gpu(monkeypatch)


@pytest.fixture
def sessions(monkeypatch):
    """make(passes, start, paused, gate, value) -> (ViewportSession, Script) on the stand-in
    Renderer (viewport_stubs.stub_sessions); every session closed at the end."""
    make, made = stub_sessions(monkeypatch)
    yield make
    for s, sc in made:
        sc.gate = None
        assert s.close(timeout=5)


# --- draw_frame ---------------------------------------------------------------------------------
def test_draw_frame_makes_one_half_float_texture_per_image_and_draws_it_in_order(gpu):
    """The calls of Blender's RenderEngine example, in its order: the texture of the float
    image (a FLOAT buffer of w h 4 values, RGBA16F, the frame's size, rows bottom-up as
    published), premultiplied blending around the display shader's bind and unbind, the
    texture stretched over the region; the same image drawn again makes no new texture."""
    from ppm_engine.blender.viewport import draw_frame
    from ppm_engine.render.viewport_session import Frame
    rng = np.random.default_rng(1)
    image = rng.random((12, 16, 4), dtype=np.float32)
    frame = Frame(image, W, H, 4, 1, generation=7, restart=1)
    engine, scene, cache = Engine(gpu), object(), {}
    draw_frame(engine, scene, frame, W, H, cache)
    tex = cache["texture"]
    assert gpu == [("Buffer", "FLOAT", 16 * 12 * 4, 16 * 12 * 4),
                   ("GPUTexture", (16, 12), "RGBA16F"),
                   ("blend_set", "ALPHA_PREMULT"), ("bind_display_space_shader", scene),
                   ("draw_texture_2d", tex, (0, 0), W, H), ("unbind_display_space_shader",),
                   ("blend_set", "NONE")]
    np.testing.assert_array_equal(tex.data.data, image.ravel())
    gpu.clear()
    draw_frame(engine, scene, frame, W, H, cache)           # the same image: no new texture
    assert [c[0] for c in gpu] == ["blend_set", "bind_display_space_shader",
                                   "draw_texture_2d", "unbind_display_space_shader",
                                   "blend_set"]
    draw_frame(engine, scene, dataclasses.replace(frame, generation=8), W, H, cache)
    assert cache["texture"] is not tex


def test_images_reach_the_half_float_texture_clamped_and_without_nan(sessions, gpu):
    """A caustic's focus over 65504 (half float's largest) would be Inf in the RGBA16F
    texture, a NaN a black or white hole: the session publishes its images as Cycles
    converts its display pixels (float4_to_half4_display: NaN and negatives 0, at most
    65504), so the texture's values are all finite."""
    from ppm_engine.blender.viewport import draw_frame
    for value, want in ((1e6, 65504.0), (np.inf, 65504.0), (np.nan, 0.0), (-3.0, 0.0),
                        (1234.5, 1234.5)):
        s, _sc = sessions(passes=1, gate=False, value=value)
        assert s.wait(timeout=10) and s.frame() is not None, s.status()
        gpu.clear()
        cache = {}
        draw_frame(Engine(gpu), None, s.frame(), W, H, cache)
        data = cache["texture"].data.data
        assert np.isfinite(data.astype(np.float16)).all(), value
        np.testing.assert_array_equal(data.reshape(H, W, 4)[..., 0], want)
        np.testing.assert_array_equal(data.reshape(H, W, 4)[..., 1:], 0.5)


# --- view_draw ----------------------------------------------------------------------------------
def test_view_draw_draws_the_latest_image_over_the_region_and_says_the_status(sessions, gpu):
    s, sc = sessions(passes=1)
    released(s, sc)
    assert s.wait(timeout=10)
    drv, timers = driver_for(s)
    engine = Engine(gpu)
    drv.view_draw(engine, context_stub(width=80, height=60), types.SimpleNamespace(
        scene=scene_stub()))
    assert [c[0] for c in gpu] == ["Buffer", "GPUTexture", "blend_set",
                                   "bind_display_space_shader", "draw_texture_2d",
                                   "unbind_display_space_shader", "blend_set"]
    assert gpu[4][3:] == (80, 60)                              # stretched over the region
    assert engine.stats == [s.status()] and "done" in engine.stats[0]
    assert engine.tags == 0 and not timers.fns and not engine.reports   # nothing more coming


def test_the_render_pass_chosen_in_the_shading_popover_is_drawn_with_no_restart(sessions, gpu):
    """The 3D view's Render Pass (shading.ppm.render_pass), read at every view_draw as Cycles
    reads its own: the image so far shown again as that pass (a value in R, G and B, alpha 1;
    the normal's negative part 0 in the display's range), the status line naming it; no pass
    run, no restart."""
    from ppm_engine.render.viewport_frame import display_pass_named
    s, sc = sessions(passes=1)
    released(s, sc)
    assert s.wait(timeout=10)
    drv, timers = driver_for(s)
    engine, dg = Engine(gpu), types.SimpleNamespace(scene=scene_stub())
    n, restarts = len(sc.passes), s.restarts
    shown = {"PPM_RADIUS": (0.125, 0.125, 0.125, 1.0), "PPM_PHOTONS": (7.0, 7.0, 7.0, 1.0),
             "DENOISING_ALBEDO": (0.25, 0.5, 0.75, 1.0), "DENOISING_NORMAL": (0.0, 0.0, 0.8, 1.0),
             "NOISY_IMAGE": (0.5, 0.5, 0.5, 0.5), "COMBINED": (0.5, 0.5, 0.5, 0.5)}
    for render_pass, want in shown.items():
        ctx = context_stub(render_pass=render_pass)
        drv.view_draw(engine, ctx, dg)
        assert s.wait(timeout=10)
        loop(drv, engine, ctx, dg, timers)
        data = drv.draw_cache["texture"].data.data.reshape(H, W, 4)
        np.testing.assert_allclose(data[0, 0], want, rtol=1e-6, err_msg=render_pass)
        name = display_pass_named(render_pass)
        assert s.frame().display == name
        assert engine.stats[-1].endswith(f" · {name}") == (name != "Combined")
    assert len(sc.passes) == n and s.restarts == restarts          # nothing rendered again
    with pytest.raises(ValueError):
        s.display_pass("Depth")


def test_the_last_image_landing_while_view_draw_draws_is_drawn(sessions, gpu, monkeypatch):
    """view_draw read the image, then asked whether more were coming: the last pass landing
    in between left the final image undrawn (nothing tagged another redraw).  Forced here:
    the last pass lands inside draw_frame of the redraw the previous one asked for."""
    import ppm_engine.blender.viewport as viewport
    s, sc = sessions(passes=2)
    released(s, sc)
    drv, timers = driver_for(s)
    engine, ctx, dg = Engine(gpu), context_stub(), types.SimpleNamespace(scene=scene_stub())
    drawn, land = [], []
    real = viewport.draw_frame

    def draw_frame(engine, scene, frame, *args):
        drawn.append(frame.generation)
        if land:
            land.pop()()
        real(engine, scene, frame, *args)
    monkeypatch.setattr(viewport, "draw_frame", draw_frame)
    drv.view_draw(engine, ctx, dg)                       # image 1; more is coming
    assert drawn == [1] and s.busy
    engine.flag = False                                  # the redraw it asked for, now:
    land.append(lambda: released(s, sc))                 # the last pass lands while it draws
    drv.view_draw(engine, ctx, dg)
    assert not s.busy and s.frame().generation == 2
    loop(drv, engine, ctx, dg, timers)
    assert drawn[-1] == 2, drawn                         # the final image was drawn
    assert "done" in engine.stats[-1]
    assert not timers.fns                                # and nothing polls any more


def test_an_error_landing_while_view_draw_runs_is_shown(sessions, gpu):
    """The same race for an error: it lands after view_draw chose its text (here inside
    update_stats), the session is no longer busy, and the header kept its old line."""
    from ppm_engine.errors import DeviceError
    s, sc = sessions(passes=3)
    released(s, sc)
    drv, timers = driver_for(s)
    engine, ctx, dg = Engine(gpu), context_stub(), types.SimpleNamespace(scene=scene_stub())
    drv.view_draw(engine, ctx, dg)
    engine.flag = False

    def fail():
        sc.pass_error = DeviceError("the OpenCL device ran out of memory: close other programs")
        sc.gate.release()
        assert s.wait(lambda s: s.error is not None, timeout=10)
    engine.on_stats = fail
    drv.view_draw(engine, ctx, dg)
    assert s.error is not None and not s.busy
    loop(drv, engine, ctx, dg, timers)
    assert "ran out of memory" in engine.stats[-1], engine.stats[-1]
    assert engine.stats[-1].startswith("Progressive Photon Mapping: ")


def test_redraws_are_tagged_once_per_new_image_not_on_every_loop_turn(sessions, gpu,
                                                                      monkeypatch):
    """While the session renders, a redraw is tagged when it has a new image (or status), not
    at every turn of Blender's loop (the region redrawn from scratch each turn took the CPU
    the passes need): 6 images 20 turns apart, each drawn once."""
    import ppm_engine.blender.viewport as viewport
    s, sc = sessions(passes=6)
    drv, timers = driver_for(s)
    engine, ctx, dg = Engine(gpu), context_stub(), types.SimpleNamespace(scene=scene_stub())
    drawn = []
    real = viewport.draw_frame
    monkeypatch.setattr(viewport, "draw_frame",
                        lambda e, sc_, f, *a: (drawn.append(f.generation), real(e, sc_, f, *a)))
    drv.view_draw(engine, ctx, dg)                        # the first draw: no image yet
    for _ in range(6):
        released(s, sc)
        loop(drv, engine, ctx, dg, timers, turns=20)
    assert s.wait(timeout=10) and not s.busy
    loop(drv, engine, ctx, dg, timers)
    assert drawn == [1, 2, 3, 4, 5, 6], drawn            # each image drawn, once
    assert engine.tags <= 7, engine.tags                 # (and the status before the first)
    assert "done" in engine.stats[-1] and not timers.fns


def test_a_view_draw_after_the_engine_was_freed_stops_polling(sessions, gpu):
    """Blender invalidates a freed engine's Python object (ReferenceError on any access): the
    timer then closes the session, so nothing keeps rendering for a viewport that is gone."""
    s, sc = sessions(passes=3)
    released(s, sc)
    drv, timers = driver_for(s)

    class Freed(Engine):
        def __getattribute__(self, name):
            if name == "tag_redraw" and object.__getattribute__(self, "freed"):
                raise ReferenceError("StructRNA of type PPMRenderEngine has been removed")
            return object.__getattribute__(self, name)
    engine = Freed(gpu)
    engine.freed = False
    drv.view_draw(engine, context_stub(), types.SimpleNamespace(scene=scene_stub()))
    assert timers.fns and s.busy
    engine.freed = True
    timers.run()
    assert not timers.fns and drv.session is None
    assert s.wait(lambda s: not s._thread.is_alive(), timeout=10)


# --- errors -------------------------------------------------------------------------------------
LOG = ("OpenCL build of kernels/integrator/eye_pass.cl failed on 'cpu' (options -I/x "
       "-DPPM_FEATURES=7):\n"
       "eye_pass.cl:12:3: error: use of undeclared identifier 'shade'\n"
       "eye_pass.cl:40:1: error: expected '}'")


def test_a_kernel_build_error_prints_its_log_reports_once_and_says_what_to_do(sessions, gpu,
                                                                               capsys):
    """The compiler's log in the console (it was only in the header, cut at Blender's 511
    bytes); one report however many redraws (as Cycles: once per new error); the header: the
    first line, what to do, where the rest is, within the 511 bytes."""
    from ppm_engine.blender.viewport import CONSOLE, SESSION_HINT, TEXT_BYTES
    from ppm_engine.errors import KernelBuildError
    s, sc = sessions(passes=2, gate=False)
    assert s.wait(timeout=10)
    sc.build_error = KernelBuildError(LOG)                  # the next Renderer fails to build
    s.update_options(s._options.replace(device="another"))  # a new device: a new Renderer
    assert s.wait(timeout=10) and s.error is not None
    err = capsys.readouterr().err
    assert "use of undeclared identifier 'shade'" in err and "expected '}'" in err
    drv, _timers = driver_for(s)
    engine, ctx, dg = Engine(gpu), context_stub(), types.SimpleNamespace(scene=scene_stub())
    for _ in range(3):
        drv.view_draw(engine, ctx, dg)
    assert len(engine.reports) == 1 and engine.reports[0][0] == {'ERROR'}
    assert "undeclared identifier" in engine.reports[0][1]
    text = engine.stats[-1]
    assert text.startswith("Progressive Photon Mapping: OpenCL build of kernels/")
    assert SESSION_HINT in text and CONSOLE in text and len(text.encode()) <= TEXT_BYTES
    assert capsys.readouterr().err.count("undeclared") == 0      # printed once, by the session


def test_the_header_keeps_the_hint_within_blender_s_buffer():
    from ppm_engine.blender.viewport import CONSOLE, TEXT_BYTES, header_text
    short = header_text("the scene has no camera: add one", "do this")
    assert short == "Progressive Photon Mapping: the scene has no camera: add one · do this"
    long = header_text("é" * 2000 + "\nmore", "do this")
    assert len(long.encode()) <= TEXT_BYTES and long.endswith(f"… · do this · {CONSOLE}")


def test_view_draw_catches_every_error_and_says_it_once(sessions, gpu, capsys):
    """A ValueError from the view's matrices (a degenerate projection) and an error of the gpu
    module escaped view_draw (only PPMError was caught): each is now in the header, its
    traceback in the console once, no exception out of view_draw; drawing resumes after."""
    s, sc = sessions(passes=1)
    released(s, sc)
    assert s.wait(timeout=10)
    drv, _timers = driver_for(s)
    engine, dg = Engine(gpu), types.SimpleNamespace(scene=scene_stub())
    flat = types.SimpleNamespace(view_matrix=np.eye(4), window_matrix=np.zeros((4, 4)),
                                 view_perspective='PERSP')
    for _ in range(2):
        drv.view_draw(engine, context_stub(flat), dg)
    assert "the 3D view's camera could not be read (ValueError" in engine.stats[-1]
    assert capsys.readouterr().err.count("Traceback") == 1
    assert len(engine.reports) == 1
    gpu.GPUTexture.fail = SystemError("GPU functions for drawing are not available")
    drv.draw_cache.clear()                                   # a texture to make again
    drv.view_draw(engine, context_stub(), dg)
    assert "the image could not be drawn (SystemError" in engine.stats[-1]
    assert "Traceback" in capsys.readouterr().err and len(engine.reports) == 2
    gpu.GPUTexture.fail = None
    drv.view_draw(engine, context_stub(), dg)
    assert "done" in engine.stats[-1] and "draw_texture_2d" in [c[0] for c in gpu]


# --- pause ------------------------------------------------------------------------------------
def test_a_session_opened_paused_renders_its_first_image_and_says_paused(sessions):
    """Pause Viewport on when the viewport opens: the session built its renderer and waited,
    the header stuck at "Building the scene's BVH and kernels".  Now the first image comes
    (the reduced levels, then one pass at full resolution), the header says it is paused
    (Cycles: "Rendering Paused"), and resuming goes on to the pass count."""
    s, sc = sessions(passes=3, start=16, paused=True, gate=False)
    assert s.wait(timeout=10), s.status()
    f = s.frame()
    assert f is not None and (f.divider, f.passes) == (1, 1)
    assert sc.passes == [(16, 12), (32, 24), (64, 48)]       # 1/4, 1/2, then full resolution
    assert s.status().startswith("Rendering Paused · ") and not s.busy
    assert "paus" in sc.built_status[0]                      # said while it was building
    s.pause(False)
    assert s.wait(timeout=10) and s.frame().passes == 3 and "Paused" not in s.status()


def test_view_draw_reads_the_pause_setting_as_cycles_does(sessions, gpu):
    s, _sc = sessions(passes=3, gate=False)
    assert s.wait(timeout=10)
    drv, _timers = driver_for(s)
    engine = Engine(gpu)
    drv.view_draw(engine, context_stub(), types.SimpleNamespace(scene=scene_stub(paused=True)))
    assert s._paused and engine.stats[-1].startswith("Rendering Paused")
