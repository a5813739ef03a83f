"""The extension zip, built with Blender's own tool: it holds the add-on and its kernels and no
benchmark, packaging, test or docs code; and (slow: downloads the wheels, starts Blender twice)
it installs and renders in a fresh Blender (bpy) process with its bundled pyopencl and PoCL,
not the test environment's, and denoises with its bundled Intel Open Image Denoise."""
import os
import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path

import pytest

pytestmark = pytest.mark.package

pytest.importorskip("bpy")
REPO = Path(__file__).resolve().parents[1]


def run_py(code, env, timeout=600):
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], env=env, cwd=env["HOME"],
                          capture_output=True, text=True, timeout=timeout,
                          stdin=subprocess.DEVNULL)


def test_zip_holds_the_add_on_and_no_tooling(tmp_path):
    from ppm_engine.tools.packaging import build
    (zip_path,) = build(tmp_path / "dist", wheels=False, log=lambda *a: None)
    names = set(zipfile.ZipFile(zip_path).namelist())
    assert {"__init__.py", "blender_manifest.toml", "ppm_engine/__init__.py",
            "ppm_engine/blender/engine.py", "ppm_engine/render/passes/eye.py"} <= names
    kernels = {p.relative_to(REPO).as_posix() for p in (REPO / "kernels").rglob("*")
               if p.suffix in (".cl", ".h")}
    shipped = {k for k in kernels if not k.startswith("kernels/test/")}  # test-only kernels
    assert shipped and shipped <= names and not kernels - shipped & names
    modules = {n for n in names if n.endswith(".py")}
    source = {p.relative_to(REPO).as_posix() for p in (REPO / "ppm_engine").rglob("*.py")}
    tooling = {n for n in source if n.startswith("ppm_engine/tools/bench/")
               or n == "ppm_engine/tools/packaging.py"}
    assert tooling and not tooling & names                      # the benchmark, the packager
    assert modules == source - tooling | {"__init__.py"}        # and nothing else is left out
    assert not any(n.startswith(("tests/", "docs/", ".ci/")) for n in names)


@pytest.mark.slow
def test_linux_zip_installs_enables_and_renders(tmp_path):
    from ppm_engine.tools.packaging import blender_ext_tool, build
    cache = os.environ.get("PPM_WHEEL_CACHE")        # optional, to save downloads locally
    zips = build(tmp_path / "dist", ["linux-x64"], cache=Path(cache) if cache else None,
                 log=lambda *a: None)
    assert len(zips) == 1 and zips[0].name.endswith("linux_x64.zip")
    user = tmp_path / "blender-user"
    repo = user / "extensions" / "user_default"
    repo.mkdir(parents=True)
    proc = subprocess.run([sys.executable, str(blender_ext_tool()), "install-files",
                           "--local-dir", str(repo), str(zips[0])], capture_output=True, text=True)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0 and "ERROR" not in out, out
    assert (repo / "ppm_engine" / "kernels" / "integrator" / "gather.cl").is_file()

    home = tmp_path / "home"
    home.mkdir()
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
    env.update(BLENDER_USER_RESOURCES=str(user), HOME=str(home))
    enable = """
        import bpy
        assert bpy.ops.preferences.addon_enable(
            module="bl_ext.user_default.ppm_engine") == {'FINISHED'}
        bpy.ops.wm.save_userpref()
        print("ENABLED")
    """
    p1 = run_py(enable, env)
    assert "ENABLED" in p1.stdout, p1.stdout + p1.stderr
    # a fresh process: the wheels' site-packages now exist before import, so they win
    render = f"""
        import bpy, numpy as np
        assert bpy.ops.preferences.addon_enable(
            module="bl_ext.user_default.ppm_engine") == {{'FINISHED'}}
        import pyopencl
        print("PYOPENCL", pyopencl.__file__)
        import bl_ext.user_default.ppm_engine.ppm_engine as ext
        print("ENGINE", ext.__file__)
        bpy.ops.wm.read_factory_settings(use_empty=False)
        assert bpy.ops.preferences.addon_enable(
            module="bl_ext.user_default.ppm_engine") == {{'FINISHED'}}
        sc = bpy.context.scene
        sc.render.engine = "PPM"
        assert sc.render.engine == "PPM"
        sc.render.resolution_x = sc.render.resolution_y = 8
        sc.ppm.passes, sc.ppm.photons_per_pass = 2, 1024
        s = sc.render.image_settings
        s.media_type, s.file_format, s.color_depth = "IMAGE", "OPEN_EXR", "32"
        sc.render.filepath = r"{tmp_path / 'frame.exr'}"
        assert bpy.ops.render.render(write_still=True) == {{'FINISHED'}}
        img = bpy.data.images.load(sc.render.filepath)
        px = np.empty(len(img.pixels), np.float32)
        img.pixels.foreach_get(px)
        assert np.isfinite(px).all() and px.reshape(-1, 4)[:, :3].mean() > 0
        print("RENDERED", px.reshape(-1, 4)[:, :3].mean())
        # denoised by the bundled Intel Open Image Denoise (pyoidn, cffi)
        sc.ppm.denoise = True
        assert bpy.ops.render.render(write_still=True) == {{'FINISHED'}}
        import pyoidn
        print("PYOIDN", pyoidn.__file__)
        from bl_ext.user_default.ppm_engine.ppm_engine.render.denoise import unavailable
        assert unavailable() is None, unavailable()
        print("DENOISED")
    """
    p2 = run_py(render, env)
    out = p2.stdout + p2.stderr
    assert "RENDERED" in p2.stdout, out
    pyopencl_path = next(line for line in p2.stdout.splitlines() if line.startswith("PYOPENCL"))
    assert str(user) in pyopencl_path and ".local" in pyopencl_path, pyopencl_path
    assert "DENOISED" in p2.stdout and "Not denoised" not in out, out
    pyoidn_path = next(line for line in p2.stdout.splitlines() if line.startswith("PYOIDN"))
    assert str(user) in pyoidn_path and ".local" in pyoidn_path, pyoidn_path
    engine_path = next(line for line in p2.stdout.splitlines() if line.startswith("ENGINE"))
    assert str(repo) in engine_path, engine_path
