"""The viewport's session (Rendered shading): the bpy-free ViewportSession driven with exports of
real scenes: its first image, each kind of edit (uploads with no kernel build, refits, rebuilds,
camera restarts), resizes, pause, errors, memory over many sessions, a final render beside it, a
device change, and its passes in pieces.  Blender's side (the view's camera, depsgraph updates,
the engine's hand-offs): test_viewport_blender.py.  What cannot run headless: draw_frame's gpu
calls (docs/ARCHITECTURE.md, "The viewport")."""
import time

import numpy as np
import pytest

from tests.helpers.viewport_scenes import PASSES, H, W, sphere_scene, view


def _export(bpy, scene, camera=None):
    from ppm_engine.blender.export import export_scene
    return export_scene(bpy.context.evaluated_depsgraph_get(), camera=camera)


def _options(scene):
    from ppm_engine.blender.viewport import viewport_options
    return viewport_options(scene.ppm)


@pytest.fixture
def lookdev(bpy, tiny):
    """(scene, session) with the first image refined to the end."""
    from ppm_engine.render.viewport_session import ViewportSession
    scene = sphere_scene(bpy, tiny)
    options, start = _options(scene)
    s = ViewportSession(options, start)
    cam = view(bpy, scene)
    s.update_view(cam)
    s.update_scene(_export(bpy, scene, cam))
    assert s.wait(timeout=300), s.status()
    yield scene, s
    assert s.close(timeout=30)


def _fresh(bpy, scene, camera):
    """The edited scene rendered by a session of its own: what the edited viewport must show."""
    from ppm_engine.render.viewport_session import ViewportSession
    options, start = _options(scene)
    s = ViewportSession(options, start)
    try:
        s.update_view(camera)
        s.update_scene(_export(bpy, scene, camera))
        assert s.wait(timeout=300), s.status()
        return s.frame().image
    finally:
        s.close(timeout=30)


def _rel(a, b) -> float:
    """Relative difference of two images' 8 x 6-block means."""
    def blocks(x):
        h, w = x.shape[:2]
        return x[..., :3].reshape(6, h // 6, 8, w // 8, 3).mean(axis=(1, 3))
    ba, bb = blocks(a), blocks(b)
    return float(np.abs(ba - bb).mean() / max(bb.mean(), 1e-9))


# --- the session ------------------------------------------------------------------------------
def test_first_image_refines_from_reduced_to_full_resolution(bpy, lookdev):
    scene, s = lookdev
    f = s.frame()
    assert (f.width, f.height, f.divider, f.passes) == (W, H, 1, PASSES)
    assert f.image.shape == (H, W, 4) and np.isfinite(f.image).all()
    assert f.generation == 2 + PASSES           # 16x12, 32x24, then the full passes
    assert s.actions == ["new"] and not s.busy
    assert "done" in s.status() and s.first_pass_seconds is not None
    # the same scene, specialised kernels, the final render's Renderer: the same image
    from ppm_engine.render.renderer import Renderer
    options, _ = _options(scene)
    r = Renderer(_export(bpy, scene, view(bpy, scene)), options.replace(specialize=True))
    for _ in range(PASSES):
        r.iterate()
    final = r.image()
    r.close()
    assert _rel(f.image, final) < 0.03


def _changed(a, b) -> float:
    """Mean absolute per-pixel difference of two images, relative to the second's mean."""
    return float(np.abs(a[..., :3] - b[..., :3]).mean() / max(b[..., :3].mean(), 1e-9))


def _edit_and_check(bpy, scene, s, edit, action, changed=0.02):
    """Apply ``edit`` to the Blender scene, hand the new export to the running session, wait:
    no kernel built, ``action`` done, the image's pixels changed by more than ``changed`` and
    the image equal to a fresh session's of the edited scene."""
    dev = s._device
    before, builds = s.frame().image, dev.programs.builds
    n_actions = len(s.actions)
    edit()
    bpy.context.view_layer.update()
    cam = view(bpy, scene)
    s.update_view(cam)
    s.update_scene(_export(bpy, scene, cam))
    assert s.wait(timeout=300), s.status()
    assert dev.programs.builds == builds, "an edit built a kernel"
    assert s.actions[n_actions:] == [action]
    after = s.frame().image
    assert _changed(after, before) > changed
    assert _rel(after, _fresh(bpy, scene, cam)) < 0.02
    assert dev.programs.builds == builds
    return before, after


def test_material_colour_edit_uploads_with_no_kernel_build(bpy, lookdev):
    scene, s = lookdev
    bsdf = bpy.data.materials["Ball"].node_tree.nodes["Principled BSDF"]
    before, after = _edit_and_check(
        bpy, scene, s, lambda: setattr(bsdf.inputs["Base Color"], "default_value",
                                       (0.05, 0.1, 0.8, 1.0)), "upload")
    assert after[..., 2].mean() / after[..., 0].mean() > \
        1.2 * before[..., 2].mean() / before[..., 0].mean()          # bluer


def test_roughness_and_metal_edits_upload_with_no_kernel_build(bpy, lookdev):
    """Roughness, and a value that switches a lobe on (Metallic 0 -> 1): still data."""
    scene, s = lookdev
    bsdf = bpy.data.materials["Ball"].node_tree.nodes["Principled BSDF"]

    def metal():
        bsdf.inputs["Metallic"].default_value = 1.0
        bsdf.inputs["Roughness"].default_value = 0.05
    _edit_and_check(bpy, scene, s, metal, "upload")
    _edit_and_check(bpy, scene, s, lambda: setattr(bsdf.inputs["Roughness"], "default_value",
                                                   0.6), "upload")


def test_light_power_and_world_strength_edits(bpy, lookdev):
    scene, s = lookdev
    before, after = _edit_and_check(
        bpy, scene, s, lambda: setattr(bpy.data.lights["Lamp"], "energy", 800.0), "upload")
    assert after[..., :3].mean() > 1.5 * before[..., :3].mean()
    bg = scene.world.node_tree.nodes["Background"].inputs["Strength"]
    before, after = _edit_and_check(bpy, scene, s, lambda: setattr(bg, "default_value", 0.0),
                                    "upload")
    assert after[..., :3].mean() < before[..., :3].mean()
    # a light of zero power, then on again: its type's code stays in the kernels
    _edit_and_check(bpy, scene, s, lambda: setattr(bpy.data.lights["Lamp"], "energy", 0.0),
                    "upload")
    _edit_and_check(bpy, scene, s, lambda: setattr(bpy.data.lights["Lamp"], "energy", 300.0),
                    "upload")


def test_transform_refits_and_objects_added_or_deleted_rebuild(bpy, lookdev):
    scene, s = lookdev
    ball = bpy.data.objects["Ball"]
    # the ball's specular layer starts caustics: its sphere is where caustic photons are aimed
    r = s._renderer
    assert r.path_indirect and r.casters == 1
    aim = r.scene.caster_spheres.copy()
    _edit_and_check(bpy, scene, s, lambda: setattr(ball, "location", (0.4, 0.0, 0.6)), "refit")
    # the aim moved with the ball, with no kernel build (above)
    moved = s._renderer.scene.caster_spheres
    np.testing.assert_allclose(moved[:, :3] - aim[:, :3], [(0.4, 0.0, 0.0)], atol=1e-3)

    def add():
        bpy.ops.mesh.primitive_cube_add(size=0.8, location=(-1.2, 0.5, 0.4))
        bpy.context.object.data.materials.append(bpy.data.materials["Grey"])
    _edit_and_check(bpy, scene, s, add, "rebuild")
    _edit_and_check(bpy, scene, s, lambda: bpy.data.objects.remove(bpy.data.objects["Cube"]),
                    "rebuild")


def test_lens_change_and_camera_move_restart_with_the_camera_only(bpy, lookdev):
    scene, s = lookdev
    dev = s._device
    builds, restarts = dev.programs.builds, s.restarts
    scene.camera.data.lens = 35.0
    bpy.context.view_layer.update()
    cam = view(bpy, scene)
    assert s.update_view(cam) is True
    assert s.update_view(cam) is False                     # the same view: nothing restarts
    first = s.wait(lambda s: s.frame().restart > restarts, timeout=60)
    assert first and s.frame().divider == 4                # the first image: reduced
    assert s.wait(timeout=300)
    assert s.actions[-1] == "camera" and s.restarts == restarts + 1
    assert _rel(s.frame().image, _fresh(bpy, scene, cam)) < 0.02
    assert dev.programs.builds == builds


def test_each_render_pass_shows_the_final_render_s_pass_with_no_restart(bpy, lookdev):
    """The shading popover's Render Pass: the image so far as each pass a final render writes
    (Renderer.passes, in the display's range), then Combined again; nothing rendered anew."""
    from ppm_engine.render.viewport_frame import DISPLAY_PASSES, display_image, pass_image
    _scene, s = lookdev
    combined, restarts, passes = s.frame().image, s.restarts, s.frame().passes
    aux = s._renderer.passes()
    for name in (*DISPLAY_PASSES[1:], "Combined"):
        s.display_pass(name)
        assert s.wait(lambda s, n=name: s.frame().display == n and not s.busy, timeout=60)
        want = display_image(pass_image(name, combined, aux))    # Combined: as it was
        np.testing.assert_array_equal(s.frame().image, want, err_msg=name)
        assert (s.frame().passes, s.frame().divider, s.restarts) == (passes, 1, restarts)
    assert aux["PPM Photons"].max() > 0 and np.ptp(aux["Denoising Normal"]) > 0.5


def test_resizes_are_debounced_and_render_at_the_new_size(bpy, lookdev):
    from ppm_engine.render import viewport_session as viewport
    scene, s = lookdev
    restarts = s.restarts
    for w, h in ((50, 40), (56, 44), (72, 54)):           # dragging the region's edge
        s.update_view(view(bpy, scene, w, h))
        time.sleep(viewport.RESIZE_DEBOUNCE / 10)
    assert s.wait(timeout=300), s.status()
    assert s.restarts == restarts + 1                      # only the last size was rendered
    f = s.frame()
    assert (f.width, f.height, f.image.shape[:2], f.divider) == (72, 54, (54, 72), 1)


def test_pause_holds_the_image_and_resume_goes_on(bpy, lookdev):
    scene, s = lookdev
    o, start = _options(scene)
    s.pause(True)
    s.update_options(o.replace(passes=PASSES + 3), start)   # more passes asked while paused
    time.sleep(0.5)
    assert not s.busy and s.frame().passes == PASSES        # paused: no pass ran
    s.pause(False)
    assert s.wait(timeout=300)
    assert s.frame().passes == PASSES + 3 and s.actions == ["new"]   # went on, no restart


def test_viewport_denoising_from_its_start_pass(bpy, lookdev):
    """Viewport Denoise (Cycles' Start Sample): passes before the start show the image as
    rendered and say "Denoising from pass N"; from it on the image is denoised (albedo and
    normal, prefiltered) and the status says "Denoised".  Switching the denoising (on, off,
    its start) re-shows the image so far without a restart."""
    from ppm_engine.render.denoise import DenoiseSettings, unavailable
    if unavailable() is not None:
        pytest.skip(unavailable())
    scene, s = lookdev
    o, start = _options(scene)
    assert o.denoise is None and "Denois" not in s.status()

    def roughness(img):     # the mean absolute Laplacian: the pixel-to-pixel noise
        x = img[..., :3]
        return float(np.abs(4 * x[1:-1, 1:-1] - x[:-2, 1:-1] - x[2:, 1:-1] - x[1:-1, :-2]
                            - x[1:-1, 2:]).mean())
    s.update_options(o.replace(passes=PASSES + 2, denoise=DenoiseSettings(start=PASSES + 2)),
                     start)
    assert s.wait(timeout=300) and s.frame().passes == PASSES + 2
    assert "· done · Denoised" in s.status(), s.status()
    denoised, gen = s.frame().image, s.frame().generation
    s.update_options(o.replace(passes=PASSES + 2), start)                  # off
    assert s.wait(timeout=300) and s.frame().generation == gen + 1
    raw = s.frame().image
    assert s.frame().passes == PASSES + 2 and "Denois" not in s.status(), s.status()
    assert roughness(denoised) < 0.5 * roughness(raw), (roughness(denoised), roughness(raw))
    assert denoised[..., :3].mean() == pytest.approx(raw[..., :3].mean(), rel=0.03)
    s.update_options(o.replace(passes=PASSES + 2, denoise=DenoiseSettings(start=100)), start)
    assert s.wait(timeout=300) and s.frame().generation == gen + 2
    assert s.status().endswith("· done · Denoising from pass 100"), s.status()
    np.testing.assert_array_equal(s.frame().image, raw)
    assert s.actions == ["new"]                           # never restarted


def test_a_viewport_opened_paused_shows_its_first_image_and_says_so(bpy, tiny):
    """Pause Viewport on when Rendered shading opens: the session built its renderer and
    waited, the status stuck at building.  The first image comes (the reduced levels, then one
    pass at full resolution), the status says "Rendering Paused" (Cycles' words) and no more
    passes run; resuming goes on to the pass count."""
    from ppm_engine.render.viewport_session import ViewportSession
    scene = sphere_scene(bpy, tiny)
    options, start = _options(scene)
    s = ViewportSession(options, start)
    try:
        s.pause(True)
        cam = view(bpy, scene)
        s.update_view(cam)
        s.update_scene(_export(bpy, scene, cam))
        assert s.wait(timeout=300), s.status()
        f = s.frame()
        assert f is not None and (f.width, f.height, f.divider, f.passes) == (W, H, 1, 1)
        assert f.generation == 3 and s.status().startswith("Rendering Paused · ")
        time.sleep(0.3)
        assert s.frame().generation == 3 and not s.busy            # held
        s.pause(False)
        assert s.wait(timeout=300) and s.frame().passes == PASSES
        assert s.actions == ["new"]                                 # went on, no restart
    finally:
        assert s.close(timeout=30)


def test_errors_show_in_the_status_and_close_frees_the_device_memory(bpy, lookdev):
    scene, s = lookdev
    bad = view(bpy, scene)
    bad["to_world"][0, 0, 0] = np.nan
    s.update_view(bad)
    s.wait(timeout=60)
    assert s.error is not None and "NaN" in s.error and "NaN" in s.status()
    assert not s.busy and s.frame() is not None            # the last image stays
    assert s.close(timeout=30)
    assert s._renderer is None


def test_fifty_restarts_and_closed_sessions_do_not_grow_memory(bpy, tiny):
    """Open a session, render its first pass, close it; 50 times: the process's memory settles
    (PoCL's buffers are host memory) and every session frees its renderer."""
    from ppm_engine.render.viewport_session import ViewportSession
    scene = sphere_scene(bpy, tiny)
    options, start = _options(scene)
    cam = view(bpy, scene)
    arrays = _export(bpy, scene, cam)

    def rss() -> int:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * 4096

    sizes = []
    for k in range(50):
        s = ViewportSession(options.replace(passes=1), start)
        s.update_view(cam)
        s.update_scene(arrays)
        assert s.wait(timeout=120), s.status()
        assert s.close(timeout=30) and s._renderer is None
        if k in (9, 49):
            sizes.append(rss())
    assert sizes[1] - sizes[0] < 24 * 2**20, [x / 2**20 for x in sizes]


def test_a_final_render_while_the_viewport_renders(bpy, lookdev, tmp_path, exr):
    """The viewport's worker and a final render (F12) share the device: both finish, and the
    final image is the one rendered with no viewport running."""
    scene, s = lookdev
    o, start = _options(scene)
    s.update_options(o.replace(passes=40), start)            # keep the worker busy
    scene.render.use_persistent_data = False
    exr.set_output(scene, tmp_path / "a.exr")
    assert bpy.ops.render.render(write_still=True) == {'FINISHED'}
    assert s.busy or s.frame().passes > PASSES
    during = exr.read(tmp_path / "a.exr")
    s.pause(True)
    s.wait(timeout=300)
    exr.set_output(scene, tmp_path / "b.exr")
    assert bpy.ops.render.render(write_still=True) == {'FINISHED'}
    alone = exr.read(tmp_path / "b.exr")
    assert np.array_equal(during, alone)


def test_choosing_another_device_starts_a_new_renderer(bpy, lookdev):
    """The Device setting changed while the viewport runs ("Default" is the PoCL device here):
    a new Renderer on it, the same image."""
    scene, s = lookdev
    o, start = _options(scene)
    before = s.frame().image
    s.update_options(o.replace(device=""), start)
    assert s.wait(timeout=300), s.status()
    assert s.error is None and s.actions == ["new", "new"]
    assert _rel(s.frame().image, before) < 0.02


def test_the_scene_s_own_kernels_would_build_on_the_same_edit(bpy, tiny):
    """What the zero-build assertions guard against: with a final render's kernels (the
    scene's features only) switching the ball to metal builds new programs."""
    from ppm_engine.render.viewport_session import ViewportSession
    scene = sphere_scene(bpy, tiny)
    options, start = _options(scene)
    s = ViewportSession(options, start, kernels="scene")
    try:
        cam = view(bpy, scene)
        s.update_view(cam)
        s.update_scene(_export(bpy, scene, cam))
        assert s.wait(timeout=300), s.status()
        builds = s._device.programs.builds
        bsdf = bpy.data.materials["Ball"].node_tree.nodes["Principled BSDF"]
        bsdf.inputs["Metallic"].default_value = 1.0
        bsdf.inputs["Roughness"].default_value = 0.05
        bpy.context.view_layer.update()
        s.update_scene(_export(bpy, scene, cam))
        assert s.wait(timeout=300), s.status()
        assert s._device.programs.builds > builds
    finally:
        s.close(timeout=30)


def test_pieces_of_a_pass_render_the_same_and_an_interrupt_drops_the_pass(pocl_key):
    """Renderer.iterate(interrupt=...): an eye pass launched in pieces makes the very image of
    whole launches (eye paths: deterministic); a photon pass in pieces traces and stores the
    same photons (its stochastic hash keeps one photon per cell in whichever order threads
    come, so only the count is exact).  An interrupt drops the pass (None, no pass counted),
    and a reset then renders as a fresh renderer would."""
    from ppm_engine.oracle.procedural import cornell_box
    from ppm_engine.render.options import RenderOptions
    from ppm_engine.render.renderer import Renderer
    scene = cornell_box(48, 48)
    asked = []

    def never():
        asked.append(1)
        return False

    o = RenderOptions(device=pocl_key, indirect="paths", seed=3)   # no caustic: no photons
    whole, pieces = Renderer(scene, o), Renderer(scene, o)
    pieces.INTERRUPT_PIXELS = 512                        # 4 eye pieces of 576 pixels
    for _ in range(3):
        whole.iterate()
        assert pieces.iterate(interrupt=never) is not None
    assert len(asked) == 3 * 3
    assert np.array_equal(whole.image(), pieces.image())
    assert pieces.iterate(interrupt=lambda: True) is None and pieces.passes_done == 3
    pieces.reset(o)
    whole.reset(o)
    for _ in range(2):
        whole.iterate()
        pieces.iterate(interrupt=never)
    assert np.array_equal(whole.image(), pieces.image())
    whole.close()
    pieces.close()

    o = RenderOptions(device=pocl_key, indirect="photons", photons_per_pass=8192, seed=3)
    whole, pieces = Renderer(scene, o), Renderer(scene, o)
    pieces.INTERRUPT_PIXELS = 512                        # and 16 photon pieces
    asked.clear()
    for _ in range(3):
        a, b = whole.iterate(), pieces.iterate(interrupt=never)
        assert a.photons_stored == b.photons_stored > 1000
    assert len(asked) == 3 * (3 + 15)
    assert _rel(pieces.image(), whole.image()) < 0.05
    assert pieces.iterate(interrupt=lambda: True) is None and pieces.passes_done == 3
    whole.close()
    pieces.close()


def test_an_export_holds_the_passes_until_it_is_posted(bpy, lookdev):
    """hold (the driver's, before an export on Blender's thread): the pass in progress is
    dropped and none runs until the export is posted; released with nothing posted, the
    accumulation restarts (the dropped pass is not in it)."""
    scene, s = lookdev
    o, start = _options(scene)
    s.update_options(o.replace(passes=PASSES + 40), start)
    assert s.wait(lambda s: s.frame().passes > PASSES, timeout=60)
    s.hold()
    time.sleep(0.1)
    held = s.frame().passes
    time.sleep(0.4)
    assert s.frame().passes == held and s.busy               # held: no pass ran
    s.hold(False)                                             # nothing posted: goes on
    assert s.wait(lambda s: s.frame().passes > held, timeout=60)   # (restarted if dropped)
    s.hold()
    time.sleep(0.1)
    restarts = s.restarts
    s.update_scene(_export(bpy, scene, view(bpy, scene)))    # posted: renders at once
    assert s.wait(lambda s: s.restarts > restarts and s.frame().restart > restarts,
                  timeout=60)
    assert s.actions[-1] == "upload"
    s.update_options(o, start)
