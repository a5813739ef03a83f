"""``python -m ppm_engine``: devices, render to PNG/EXR, examples and its error messages (each
command in a fresh process, as a user runs it)."""
import re
import struct

import numpy as np
import pytest

RENDER_TINY = ("--passes", "2", "--photons", "4096", "--resolution", "24x16")


def _one_clear_line(proc, *words):
    """A failure: non-zero exit, no traceback, one 'ppm_engine: error: ...' line naming words."""
    assert proc.returncode not in (0, None), proc.stderr
    assert "Traceback" not in proc.stderr, proc.stderr
    lines = [l for l in proc.stderr.splitlines() if l.startswith("ppm_engine: error:")]
    assert len(lines) == 1, proc.stderr
    for w in words:
        assert w.lower() in lines[0].lower(), lines[0]
    return lines[0]


def _png_size(path):
    with open(path, "rb") as f:
        head = f.read(24)
    assert head[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", head[16:24])


def test_devices_lists_the_pocl_device(cli, pocl_key):
    proc = cli("devices")
    assert proc.returncode == 0, proc.stderr
    assert any(line.split("\t")[0] == pocl_key for line in proc.stdout.splitlines()), proc.stdout


@pytest.mark.parametrize("ext", ["png", "exr"])
def test_render_cornell_box(cli, example_blend, pocl_key, exr, tmp_path, ext):
    out = tmp_path / f"cornell.{ext}"
    proc = cli("render", example_blend("cornell_box"), "-o", out, *RENDER_TINY,
               "--device", pocl_key, "--seed", "3", "--light-tracing", "off")
    assert proc.returncode == 0, proc.stderr
    assert out.is_file()
    # a progress line per pass on stderr, with a bar as long as the percentage it shows
    bars = re.findall(r"\[(#*) *\] +(\d+) % Pass (\d+)/2", proc.stderr)
    assert [int(b[2]) for b in bars] == [1, 2], proc.stderr
    assert [int(b[1]) for b in bars] == [50, 100]
    assert all(len(b[0]) == 20 * int(b[1]) // 100 for b in bars)
    if ext == "png":
        assert _png_size(out) == (24, 16)
    else:
        img = exr.read(out)
        assert img.shape == (16, 24, 4)
        assert np.isfinite(img).all() and img[..., :3].mean() > 1e-3


def _animated_blend(bpy, path):
    """The Cornell box with its tall box sliding 0.3 m over frames 1-3, persistent data on."""
    bpy.ops.wm.open_mainfile(filepath=str(path[0]), load_ui=False)
    box = bpy.data.objects["TallBox"]
    for frame, dx in ((1, 0.0), (3, 0.3)):
        box.location.x = box.location.x + dx if frame == 3 else box.location.x
        box.keyframe_insert("location", frame=frame)
    bpy.context.scene.render.use_persistent_data = True
    bpy.ops.wm.save_as_mainfile(filepath=str(path[1]))


def test_render_animation_and_frame_numbers(bpy, cli, example_blend, exr, tmp_path):
    blend = tmp_path / "animated.blend"
    _animated_blend(bpy, (example_blend("cornell_box"), blend))
    proc = cli("render", blend, "-o", tmp_path / "anim_##.exr", "--frames", "1-3", "--passes",
               "24", "--photons", "4096", "--resolution", "24x16")
    assert proc.returncode == 0, proc.stderr
    imgs = [exr.read(tmp_path / f"anim_{f:02d}.exr") for f in (1, 2, 3)]
    assert all(np.isfinite(i).all() and i[..., :3].mean() > 1e-3 for i in imgs)
    # the box moves on: frame 3 is farther from frame 1 than frame 2 is
    assert np.abs(imgs[0] - imgs[2]).mean() > np.abs(imgs[0] - imgs[1]).mean() > 0
    proc = cli("render", blend, "-o", tmp_path / "still.png", "--frames", "2-2", *RENDER_TINY)
    assert proc.returncode == 0 and (tmp_path / "still_0002.png").is_file(), proc.stderr
    proc = cli("render", blend, "-o", tmp_path / "one_###.png", "-f", "3", *RENDER_TINY)
    assert proc.returncode == 0 and (tmp_path / "one_003.png").is_file(), proc.stderr
    proc = cli("render", blend, "-o", tmp_path / "x.png", "--frames", "5-2")
    assert proc.returncode == 2 and "ends before it starts" in proc.stderr


def test_render_device_by_name_part(cli, example_blend, tmp_path):
    out = tmp_path / "default.png"
    proc = cli("render", example_blend("cornell_box"), "-o", out, *RENDER_TINY, "--device",
               "DEFAULT")
    assert proc.returncode == 0, proc.stderr
    assert out.is_file()


def test_missing_blend_file(cli, tmp_path):
    proc = cli("render", tmp_path / "nope.blend", "-o", tmp_path / "x.png")
    _one_clear_line(proc, "not found", "nope.blend")


def test_not_a_blend_file(cli, tmp_path):
    fake = tmp_path / "fake.blend"
    fake.write_text("hello")
    proc = cli("render", fake, "-o", tmp_path / "x.png")
    _one_clear_line(proc, "not a .blend")


@pytest.mark.parametrize("args, words", [
    (("--passes", "0"), ("passes",)),
    (("--photons", "-5"), ("photons_per_pass",)),
    (("--time-limit", "-1"), ("time_limit",)),
    (("--device", "no-such-device"), ("no-such-device", "available")),
])
def test_invalid_settings_are_refused(cli, example_blend, tmp_path, args, words):
    out = tmp_path / "x.png"
    proc = cli("render", example_blend("cornell_box"), "-o", out, *args)
    assert proc.returncode == 2
    _one_clear_line(proc, *words)
    assert not out.exists()


def test_unsupported_output_format(cli, example_blend, tmp_path):
    proc = cli("render", example_blend("cornell_box"), "-o", tmp_path / "x.jpg")
    assert proc.returncode == 2
    _one_clear_line(proc, ".png", ".exr")


def test_engine_error_becomes_one_line(bpy, cli, tmp_path):
    """A scene the engine refuses (its camera is an Empty): the engine's ERROR report, no
    traceback."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    cam = bpy.data.objects.new("NotACamera", None)
    scene.collection.objects.link(cam)
    scene.camera = cam
    path = tmp_path / "empty_camera.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    proc = cli("render", path, "-o", tmp_path / "x.png", *RENDER_TINY)
    assert proc.returncode == 1
    _one_clear_line(proc, "render failed")


def test_example_command(cli, tmp_path):
    out = tmp_path / "bulb.blend"
    proc = cli("example", "bulb_box", out)
    assert proc.returncode == 0, proc.stderr
    assert out.stat().st_size > 1000
    proc = cli("example", "no_such_scene", tmp_path / "x.blend")
    assert proc.returncode == 2
    _one_clear_line(proc, "no_such_scene", "cornell_box")


@pytest.mark.slow
def test_render_denoised(cli, example_blend, pocl_key, exr, tmp_path):
    """--denoise: the image through OIDN, the progress saying so after the last pass (8 s: the
    default run has it in-process, tests/test_denoise.py test_cli_denoise_in_process)."""
    from ppm_engine.render.denoise import unavailable
    if unavailable() is not None:
        pytest.skip(unavailable())
    out = tmp_path / "denoised.exr"
    proc = cli("render", example_blend("cornell_box"), "-o", out, *RENDER_TINY,
               "--device", pocl_key, "--denoise")
    assert proc.returncode == 0, proc.stderr
    assert "Denoising after pass 2" in proc.stderr
    img = exr.read(out)
    assert img.shape == (16, 24, 4) and np.isfinite(img).all() and img[..., :3].mean() > 1e-3


def test_denoise_without_oidn_is_one_line(cli, example_blend, tmp_path, monkeypatch):
    """--denoise where OIDN cannot be loaded (here a pyoidn whose library is missing): one
    line that says why and how to install it, before Blender loads the file."""
    (tmp_path / "pyoidn.py").write_text(
        "raise OSError('libOpenImageDenoise.so.2: cannot open shared object file')\n")
    monkeypatch.setenv("PYTHONPATH", str(tmp_path))
    out = tmp_path / "x.png"
    proc = cli("render", example_blend("cornell_box"), "-o", out, "--denoise")
    assert proc.returncode == 1
    _one_clear_line(proc, "--denoise", "Open Image Denoise could not be loaded",
                    "libOpenImageDenoise.so.2", "pip install")
    assert not out.exists()
