"""``pip install .`` (not editable) gives a working engine: the wheel carries every subpackage and
the OpenCL sources as package data, and renders from a fresh virtual environment that has no
source tree on its path."""
import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.package


def _run(args, cwd, timeout=600):
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
    return subprocess.run([str(a) for a in args], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=timeout, stdin=subprocess.DEVNULL)


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The wheel pip builds from a copy of what the build reads (setuptools writes build/ and
    *.egg-info/ next to the sources: not into the checkout)."""
    out = tmp_path_factory.mktemp("wheel")
    src = out / "src"
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    for name in ("ppm_engine", "kernels"):
        shutil.copytree(REPO / name, src / name, ignore=ignore)
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(REPO / name, src / name)
    p = _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q",
              "-w", out, src], cwd=out)
    assert p.returncode == 0, p.stdout + p.stderr
    (whl,) = out.glob("ppm_engine-*.whl")
    return whl


def test_wheel_holds_every_subpackage_and_the_kernels(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    for init in (REPO / "ppm_engine").rglob("__init__.py"):
        rel = init.relative_to(REPO).as_posix()
        assert rel in names, f"{rel} is missing from the wheel (pyproject.toml packages)"
    kernels = sorted(p.relative_to(REPO / "kernels").as_posix()
                     for p in (REPO / "kernels").rglob("*") if p.suffix in (".cl", ".h"))
    shipped = [k for k in kernels if not k.startswith("test/")]     # test-only kernels stay out
    assert shipped and all(f"ppm_engine/kernels/{k}" in names for k in shipped)
    assert not any(n.startswith("ppm_engine/kernels/test/") for n in names)
    assert "ppm_engine/data/shading_tables.npz" in names         # the closures' tables
    assert not any(n.startswith(("tests/", "docs/", "kernels/")) for n in names)


def test_wheel_installs_into_a_fresh_venv_and_renders(wheel, tmp_path):
    """The user's flow after ``pip install .``: write the example scene and render it with the
    CLI, from a folder that is not the repository.  The fresh venv sees this environment's
    dependencies (bpy, numpy, pyopencl, PoCL) through a .pth file, not its packages."""
    venv = tmp_path / "venv"
    p = _run([sys.executable, "-m", "venv", "--without-pip", venv], cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    py = venv / "bin" / "python"
    site = Path(_run([py, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                     cwd=tmp_path).stdout.strip())
    (site / "deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    p = _run([sys.executable, "-m", "pip", "--python", py, "install", "--no-deps", "-q", wheel],
             cwd=tmp_path)
    assert p.returncode == 0, p.stdout + p.stderr
    where = _run([py, "-c", "import ppm_engine.render.device as d; print(d.__file__); "
                  "print(d.kernel_dir())"], cwd=tmp_path)
    assert where.returncode == 0, where.stderr
    module, kernels = where.stdout.split()
    assert Path(module).is_relative_to(site) and Path(kernels) == site / "ppm_engine" / "kernels"
    blend, png = tmp_path / "box.blend", tmp_path / "box.png"
    p = _run([py, "-m", "ppm_engine", "example", "cornell_box", blend], cwd=tmp_path)
    assert p.returncode == 0 and blend.is_file(), p.stderr
    p = _run([py, "-m", "ppm_engine", "render", blend, "-o", png, "--resolution", "16x16",
              "--passes", "2", "--photons", "1024"], cwd=tmp_path)
    assert p.returncode == 0 and png.is_file(), p.stderr
    import numpy as np
    from PIL import Image
    img = np.asarray(Image.open(png), np.float32)[..., :3]
    assert img.shape == (16, 16, 3)
    # the kernels really ran: the box's red wall on the left, its green wall on the right (the
    # PNG went through AgX, which desaturates: 3.5x and 1.7x at this size)
    left, right = img[6:10, :2].mean(axis=(0, 1)), img[6:10, -2:].mean(axis=(0, 1))
    assert left[0] > 1.4 * left[1] and right[1] > 1.4 * right[0], (left, right)
