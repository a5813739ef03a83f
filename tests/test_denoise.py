"""Denoising through Intel Open Image Denoise (ppm_engine/render/denoise.py): a final render's
Denoise (scene.ppm.denoise, Cycles' input passes, prefilter and quality), the noisy image kept in
the Noisy Image pass, the option off leaving the render as it was, and a clear message where
OIDN cannot be loaded."""
import sys

import numpy as np
import pytest

OpenEXR = pytest.importorskip("OpenEXR")

W = 32


def _oidn_or_skip():
    from ppm_engine.render import denoise
    message = denoise.unavailable()
    if message is not None:
        pytest.skip(message)


def _render_layers(bpy, scene, path):
    """Every channel of the scene's render in a multilayer EXR: name -> (h, w[, c]), top-down."""
    scene.render.image_settings.media_type = 'MULTI_LAYER_IMAGE'
    scene.render.filepath = str(path)
    assert bpy.ops.render.render(write_still=True) == {'FINISHED'}
    with OpenEXR.File(str(path)) as f:
        return {k: np.asarray(v.pixels) for p in f.parts for k, v in p.channels.items()}


def _cornell(bpy, example_blend, tiny, passes):
    """The example Cornell box (diffuse: eye paths alone, the same image on every run), W x W."""
    bpy.ops.wm.open_mainfile(filepath=str(example_blend("cornell_box")), load_ui=False)
    scene = bpy.context.scene
    tiny(scene, width=W, height=W, passes=passes)
    return scene


def test_denoised_render_is_nearer_a_long_render(bpy, example_blend, tiny, tmp_path, pocl_key):
    """Four passes of the Cornell box, denoised (albedo and normal, prefiltered: Cycles'
    defaults), against 128 passes of the same scene: the denoised image is much nearer than
    the noisy one (RMSE of the display range, values clipped at 1 as the light's pixels are,
    measured 0.076 -> 0.040), keeps the image's mean within 2 %, and the noisy image is the
    Noisy Image pass."""
    _oidn_or_skip()
    from ppm_engine.blender.export import export_scene
    from ppm_engine.render.renderer import Renderer
    from tests.helpers.renders import every_feature
    scene = _cornell(bpy, example_blend, tiny, passes=4)
    scene.ppm.denoise = True
    ch = _render_layers(bpy, scene, tmp_path / "denoised.exr")
    denoised, noisy = ch["ViewLayer.Combined"], ch["ViewLayer.Noisy Image"]
    r = Renderer(export_scene(bpy.context.evaluated_depsgraph_get()),
                 every_feature(device=pocl_key))
    for _ in range(128):
        r.iterate()
    ref = r.image()[::-1]                     # row 0 at the top, as the EXR
    r.close()
    err = lambda img: float(np.sqrt(((np.minimum(img[..., :3], 1.0)
                                      - np.minimum(ref[..., :3], 1.0)) ** 2).mean()))
    assert err(denoised) < 0.65 * err(noisy), (err(denoised), err(noisy))
    assert denoised[..., :3].mean() == pytest.approx(noisy[..., :3].mean(), rel=0.02)
    np.testing.assert_array_equal(denoised[..., 3], noisy[..., 3])      # alpha as rendered


def test_denoise_off_renders_as_before(bpy, example_blend, tiny, tmp_path):
    """Off (the default): no Noisy Image pass, and the image is bit for bit the one a denoised
    render keeps as its Noisy Image (eye paths alone: the same image on every run)."""
    _oidn_or_skip()
    scene = _cornell(bpy, example_blend, tiny, passes=2)
    assert not scene.ppm.denoise
    off = _render_layers(bpy, scene, tmp_path / "off.exr")
    assert "ViewLayer.Noisy Image" not in off
    scene.ppm.denoise = True
    on = _render_layers(bpy, scene, tmp_path / "on.exr")
    np.testing.assert_array_equal(off["ViewLayer.Combined"], on["ViewLayer.Noisy Image"])
    assert not np.array_equal(off["ViewLayer.Combined"], on["ViewLayer.Combined"])


def test_without_oidn_a_render_says_so_and_keeps_its_image(bpy, example_blend, tiny, tmp_path,
                                                          monkeypatch, capfd):
    """pyoidn not importable: the render finishes with the noisy image and a warning that
    says why and how to install it; no traceback."""
    from ppm_engine.render import denoise
    monkeypatch.setitem(sys.modules, "pyoidn", None)          # import pyoidn: ImportError
    monkeypatch.setattr(denoise, "_state", {})
    message = denoise.unavailable()
    assert message is not None and "pyoidn package is not installed" in message
    assert "pip install pyoidn" in message
    with pytest.raises(denoise.DenoiserUnavailable):
        denoise.denoise(np.zeros((4, 4, 4), np.float32))
    scene = _cornell(bpy, example_blend, tiny, passes=2)
    scene.ppm.denoise = True
    ch = _render_layers(bpy, scene, tmp_path / "no_oidn.exr")
    np.testing.assert_array_equal(ch["ViewLayer.Combined"], ch["ViewLayer.Noisy Image"])
    out = capfd.readouterr()
    assert "Not denoised: Intel Open Image Denoise could not be loaded" in out.out + out.err
    assert "Traceback" not in out.out + out.err


def test_a_library_that_fails_to_load_is_a_message(monkeypatch, tmp_path):
    """A pyoidn whose library cannot be loaded (another platform's wheel, a missing system
    library) is reported with the loader's words, as is a CPU OIDN does not support."""
    from ppm_engine.render import denoise
    fake = tmp_path / "pyoidn.py"
    fake.write_text("raise OSError('libOpenImageDenoise.so.2: cannot open shared object file')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "pyoidn", raising=False)
    monkeypatch.setattr(denoise, "_state", {})
    message = denoise.unavailable()
    assert message.startswith("Intel Open Image Denoise could not be loaded (OSError: "
                              "libOpenImageDenoise.so.2: cannot open shared object file)")
    assert "pip install" in message


def test_settings_follow_cycles(bpy):
    """Cycles' denoising settings of the scene (input passes, prefilter, quality; the
    viewport's Start Sample and its own three) are what the denoiser is given; Cycles' toggles
    are not ours (scene.ppm.denoise, viewport_denoise: off by default)."""
    from ppm_engine.blender.properties import denoise_settings, to_options
    from ppm_engine.render.denoise import DenoiseSettings
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    s, c = scene.ppm, scene.cycles
    assert c.use_denoising and not s.denoise and not s.viewport_denoise
    assert to_options(s).denoise is None and denoise_settings(s, viewport=True) is None
    s.denoise = s.viewport_denoise = True
    c.denoising_input_passes, c.denoising_prefilter, c.denoising_quality = \
        'RGB_ALBEDO', 'FAST', 'BALANCED'
    c.preview_denoising_start_sample = 8
    assert to_options(s).denoise == DenoiseSettings("rgb_albedo", "fast", "balanced", 1)
    v = denoise_settings(s, viewport=True)
    assert v.start == 8 and (v.input_passes, v.prefilter, v.quality) == (
        str(c.preview_denoising_input_passes).lower(), str(c.preview_denoising_prefilter).lower(),
        str(c.preview_denoising_quality).lower())


def test_cli_denoise_in_process(bpy, example_blend, pocl_key, tmp_path, capsys):
    """``render --denoise`` (tools/cli.py main, in this process: a fresh one is
    test_cli.py's slow test_render_denoised): the file's Denoise replaced, the progress saying
    so after the last pass, the image written."""
    _oidn_or_skip()
    from ppm_engine.tools.cli import main
    out = tmp_path / "denoised.exr"
    assert main(["render", example_blend("cornell_box"), "-o", out, "--passes", "2",
                 "--photons", "4096", "--resolution", "24x16", "--device", pocl_key,
                 "--denoise"]) == 0
    assert "Denoising after pass 2" in capsys.readouterr().err
    assert bpy.context.scene.ppm.denoise and out.is_file()


def test_denoise_panels_sit_where_cycles_has_them(bpy):
    """Render Properties → Sampling → Denoise and Sampling → Viewport → Denoise, the toggle in
    each header (ours), Cycles' settings below."""
    from ppm_engine.blender import ui
    assert bpy.types.PPM_PT_sampling_denoise.bl_parent_id == "PPM_PT_sampling"
    assert bpy.types.PPM_PT_sampling_viewport_denoise.bl_parent_id == "PPM_PT_sampling_viewport"
    assert (ui.PPM_PT_sampling_denoise.OWN, ui.PPM_PT_sampling_viewport_denoise.OWN) == (
        "denoise", "viewport_denoise")
    c = bpy.context.scene.cycles
    for cls in (ui.PPM_PT_sampling_denoise, ui.PPM_PT_sampling_viewport_denoise):
        for name in ("input_passes", "prefilter", "quality"):
            assert hasattr(c, cls.PREFIX + name), cls.PREFIX + name
