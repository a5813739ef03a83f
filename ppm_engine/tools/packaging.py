"""Build the installable extension zip(s) with Blender's own extension tool.

    python -m ppm_engine package [-o dist] [--platforms linux-x64,windows-x64,macos-arm64,macos-x64]
                                 [--no-denoise]

(Tooling, not part of the add-on: blender_manifest.toml's build excludes leave this module and
the bench subpackage out of the zip.)

Stages the add-on (root __init__.py, blender_manifest.toml, ppm_engine/, kernels/), downloads
the wheels it needs for each platform with pip (pyopencl and what it imports; the PoCL CPU
device for Linux, the only platform it has wheels for -- macOS brings its own OpenCL, Windows
needs a GPU driver's; Intel Open Image Denoise's pyoidn with cffi and pycparser, unless
``--no-denoise``), writes ``platforms`` and ``wheels`` into the staged manifest, then runs
``blender_ext.py validate`` and ``build --split-platforms``: one zip per platform.
numpy is not bundled: Blender ships it.
"""
from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from ppm_engine.errors import PPMError, UsageError

ROOT = Path(__file__).resolve().parents[2]

# pip --platform tags per Blender platform (pip takes several and picks what exists)
PIP_PLATFORMS = {
    "linux-x64": ["manylinux_2_28_x86_64", "manylinux_2_27_x86_64", "manylinux_2_17_x86_64",
                  "manylinux2014_x86_64"],
    "windows-x64": ["win_amd64"],
    "macos-arm64": ["macosx_11_0_arm64"],
    "macos-x64": ["macosx_10_14_x86_64", "macosx_10_9_x86_64"],
}
# pyopencl and what it (and its RadixSort, which the BVH build uses) imports; numpy is Blender's
WHEELS = ["pyopencl", "pytools", "platformdirs", "siphash24", "typing_extensions", "mako",
          "markupsafe"]
WHEELS_LINUX = ["pocl-binary-distribution"]
# Intel Open Image Denoise for the Denoise options (ppm_engine/render/denoise.py): pyoidn holds
# the OIDN library for each platform (Linux x64, Windows x64, macOS x64 and arm64; no Linux
# arm64), and imports cffi (compiled per platform; Blender does not ship it) and pycparser.
# pyoidn's macOS wheels are tagged 10.15 (x64) and 12.0 (arm64), newer than the tags above:
# their tags are added for these wheels alone.  Without them (package --no-denoise) the zips
# are 50-90 MB smaller and the Denoise options say that OIDN is missing.
WHEELS_DENOISE = ["pyoidn", "cffi", "pycparser"]
PIP_PLATFORMS_DENOISE = {"macos-arm64": ["macosx_12_0_arm64"],
                         "macos-x64": ["macosx_10_15_x86_64"]}


class PackageError(PPMError):
    """The zip could not be built (the message says which step failed and why)."""


def blender_ext_tool() -> Path:
    """Blender's extension tool (blender_ext.py) inside the installed bpy wheel."""
    import importlib.util
    spec = importlib.util.find_spec("bpy")
    if spec is None or spec.origin is None:
        raise PackageError("the bpy module is not installed: pip install bpy==5.0.1")
    base = Path(spec.origin).parent
    found = sorted(base.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    if not found:
        raise PackageError(f"Blender's extension tool (blender_ext.py) was not found under {base}")
    return found[-1]


def stage(dest: Path) -> None:
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    shutil.copy2(ROOT / "__init__.py", dest / "__init__.py")
    shutil.copy2(ROOT / "blender_manifest.toml", dest / "blender_manifest.toml")
    shutil.copytree(ROOT / "ppm_engine", dest / "ppm_engine", ignore=ignore)
    shutil.copytree(ROOT / "kernels", dest / "kernels", ignore=ignore)


def download_wheels(platform: str, dest: Path, cache: Path | None = None,
                    denoise: bool = True) -> list[Path]:
    """The platform's wheels (cp311), from pip, into dest; returns their paths.  ``denoise``:
    with OIDN's (WHEELS_DENOISE)."""
    names = WHEELS + (WHEELS_LINUX if platform.startswith("linux") else [])
    target = cache / platform if cache else dest
    target.mkdir(parents=True, exist_ok=True)
    cmd = [sys.executable, "-m", "pip", "download", "--quiet", "--no-deps",
           "--only-binary=:all:", "--python-version", "3.11", "--implementation", "cp",
           "--dest", str(target)]
    tags = PIP_PLATFORMS[platform]
    runs = [(names, tags)]
    if denoise:
        runs.append((WHEELS_DENOISE, tags + PIP_PLATFORMS_DENOISE.get(platform, [])))
        names = names + WHEELS_DENOISE
    for run_names, run_tags in runs:
        platform_args = [arg for tag in run_tags for arg in ("--platform", tag)]
        proc = subprocess.run(cmd + platform_args + run_names, capture_output=True, text=True)
        if proc.returncode != 0:
            raise PackageError(f"pip could not download the {platform} wheels: "
                               f"{proc.stderr.strip().splitlines()[-1] if proc.stderr else ''}")
    wheels = []
    for name in names:
        key = name.replace("-", "_").lower()
        match = sorted(p for p in target.glob("*.whl") if p.name.lower().startswith(key + "-"))
        if not match:
            raise PackageError(f"no {platform} wheel of {name} was downloaded")
        wheels.append(match[-1])
    if cache:
        dest.mkdir(parents=True, exist_ok=True)
        wheels = [Path(shutil.copy2(w, dest / w.name)) for w in wheels]
    return wheels


def write_manifest(stage_dir: Path, platforms: list[str], wheels: list[Path]) -> None:
    """Add ``platforms`` and ``wheels`` as top-level keys (before the first table)."""
    path = stage_dir / "blender_manifest.toml"
    text = path.read_text()
    lines = [f"platforms = [{', '.join(repr(p).replace(chr(39), chr(34)) for p in platforms)}]",
             "wheels = ["] + [f'  "./wheels/{w.name}",' for w in wheels] + ["]", ""]
    head, sep, tail = text.partition("\n[")
    path.write_text(head.rstrip() + "\n\n" + "\n".join(lines) + (sep + tail if sep else ""))


def run_tool(*args) -> str:
    proc = subprocess.run([sys.executable, str(blender_ext_tool()), *map(str, args)],
                          capture_output=True, text=True)
    out = proc.stdout + proc.stderr
    if proc.returncode != 0 or "FATAL_ERROR" in out or "\nERROR" in out or out.startswith("ERROR"):
        raise PackageError(f"blender_ext.py {args[0]} failed:\n{out.strip()}")
    return out


def build(output: Path, platforms: list[str] | None = None, cache: Path | None = None,
          log=print, wheels: bool = True, denoise: bool = True) -> list[Path]:
    """The extension zips in ``output``, one per platform (default: all of PIP_PLATFORMS);
    ``cache`` keeps downloaded wheels between builds.  ``wheels=False`` builds one zip of the
    add-on alone, without downloading anything (what the default tests check);
    ``denoise=False`` leaves OIDN's wheels out (WHEELS_DENOISE)."""
    platforms = list(platforms or PIP_PLATFORMS)
    unknown = [p for p in platforms if p not in PIP_PLATFORMS]
    if unknown:
        raise UsageError(f"unknown platform {unknown[0]}; known: {', '.join(PIP_PLATFORMS)}")
    output = output.resolve()
    output.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="ppm-ext-") as tmp:
        stage_dir = Path(tmp) / "ppm_engine_ext"
        stage_dir.mkdir()
        stage(stage_dir)
        found = []
        if wheels:
            for p in platforms:
                log(f"downloading the {p} wheels")
                found += download_wheels(p, stage_dir / "wheels", cache, denoise)
            write_manifest(stage_dir, platforms, sorted(set(found), key=lambda w: w.name))
        run_tool("validate", stage_dir)
        before = set(output.glob("*.zip"))
        run_tool("build", "--source-dir", stage_dir, "--output-dir", output,
                 *(["--split-platforms"] if wheels else []))
        zips = sorted(set(output.glob("*.zip")) - before) or sorted(output.glob("*.zip"))
        for z in zips:
            run_tool("validate", z)
            log(f"built {z} ({z.stat().st_size / 2**20:.1f} MiB)")
        return zips
