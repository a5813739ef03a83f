"""Shared fixtures: the engine registered once in this process, a session temp folder, the
example .blend files, the PoCL device key, tiny render settings, a CLI runner and the
exporter's empty scene with a camera."""
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

# Blender's user config/scripts/extensions go to a throw-away folder, not ~/.config/blender
# (set before anything imports bpy; subprocesses inherit it).
os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="ppm-blender-user-"))

# tiny renders: every image test stays well under a second per render on a 2-core CPU
TINY = dict(width=24, height=24, passes=3, photons_per_pass=4096)


@pytest.fixture(scope="session")
def bpy():
    """bpy with the PPM engine registered (once per test session)."""
    bpy = pytest.importorskip("bpy")
    import ppm_engine
    from ppm_engine.blender.engine import PPMRenderEngine
    from ppm_engine.blender.harness import ensure_registered
    ensure_registered()
    yield bpy
    if PPMRenderEngine.is_registered:
        ppm_engine.unregister()


@pytest.fixture(scope="session")
def session_dir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("ppm")


@pytest.fixture(scope="session")
def pocl_key() -> str:
    """The key of the PoCL CPU device (the device every test renders on)."""
    pytest.importorskip("pyopencl")
    from ppm_engine.render.device import list_devices
    for d in list_devices():
        if "portable computing language" in d.platform.lower() or "pocl" in d.platform.lower():
            return d.key
    pytest.skip("the PoCL CPU device is not installed")


@pytest.fixture(scope="session")
def example_blend(bpy, session_dir):
    """example_blend(name) -> path of the example scene saved as .blend (built once)."""
    made = {}

    def get(name: str) -> Path:
        if name not in made:
            from ppm_engine.blender.scenes import save_example
            path = session_dir / f"{name}.blend"
            save_example(name, str(path))
            assert path.is_file()
            made[name] = path
        return made[name]
    return get


@pytest.fixture
def empty():
    """The exporter's tests (test_export*.py): factory settings, no objects but a camera,
    64 x 48 pixels; the scene."""
    bpy = pytest.importorskip("bpy")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.render.resolution_x, scene.render.resolution_y = 64, 48
    return scene


@pytest.fixture(scope="session")
def tiny(pocl_key):
    """tiny(scene, **kw): tiny, deterministic render settings on the PoCL device."""
    return lambda scene, **kw: configure_tiny(scene, pocl_key, **kw)


@pytest.fixture(scope="session")
def exr():
    """Namespace with .set_output(scene, path) and .read(path)."""
    import types
    return types.SimpleNamespace(set_output=set_exr_output, read=read_exr)


@pytest.fixture(scope="session")
def cli():
    """cli(*args) runs ``python -m ppm_engine ARGS`` in a fresh process."""
    return run_cli


@pytest.fixture
def cli_here(bpy):
    """cli_here(*args) runs ``python -m ppm_engine ARGS`` in this process (tools/cli.py main,
    its output captured), for the benchmark's long quick runs: the kernels this process built
    serve them, where a fresh process compiles every program again (PoCL's disk cache keeps
    the binaries, not the front end's work).  A CompletedProcess as run_cli's; the scene the
    run leaves is reset after it."""
    import contextlib
    import io

    def run(*args, timeout=None):
        from ppm_engine.tools.cli import main
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = main([str(a) for a in args])
            except SystemExit as e:
                code = e.code if isinstance(e.code, int) else 1
        bpy.ops.wm.read_factory_settings(use_empty=True)
        return subprocess.CompletedProcess(args, code, out.getvalue(), err.getvalue())
    return run


def configure_tiny(scene, pocl_key: str, *, width=TINY["width"], height=TINY["height"],
                   passes=TINY["passes"], photons=TINY["photons_per_pass"],
                   specialize=False) -> None:
    """Tiny, deterministic render settings on the PoCL device.  Kernels of every feature by
    default (scene.ppm.specialize off): the same image as the scene's own kernels
    (test_skips.py checks it), from one build shared by every scene of the test run instead of a
    build per feature set, which is most of a cold run's time; the tests of specialisation (the
    skips, the viewport's builds per edit) ask for the scene's own."""
    if scene.render.engine != "PPM":
        scene.render.engine = "PPM"
    assert scene.render.engine == "PPM"
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    scene.render.use_border = False
    scene.render.dither_intensity = 0.0
    scene.ppm.passes = passes
    scene.ppm.photons_per_pass = photons
    scene.ppm.time_limit = 0.0
    scene.ppm.device = pocl_key
    scene.ppm.specialize = specialize


def set_exr_output(scene, path: Path) -> None:
    """32-bit EXR output to ``path`` (the extension must be .exr)."""
    from ppm_engine.blender.harness import set_output
    assert Path(path).suffix == ".exr", path
    set_output(scene, path)


def read_exr(path: Path):
    """RGBA float32 (h, w, 4) of a single-part EXR, rows top-down (EXR order)."""
    pytest.importorskip("OpenEXR")
    from ppm_engine.blender.harness import read_exr as read
    return read(path)


def run_cli(*args, timeout=600):
    """``python -m ppm_engine ARGS`` in a fresh process; returns the CompletedProcess."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    return subprocess.run([sys.executable, "-m", "ppm_engine", *map(str, args)], cwd=REPO,
                          env=env, capture_output=True, text=True, timeout=timeout,
                          stdin=subprocess.DEVNULL)


def cycles_settings(scene, samples: int, width: int = 32) -> None:
    """Cycles with the same light transport as ours (harness.cycles_reference), ``samples``
    per pixel, a square image ``width`` pixels wide."""
    from ppm_engine.blender.harness import cycles_reference
    cycles_reference(scene, samples=samples, seed=1)
    scene.render.resolution_x = scene.render.resolution_y = width
    scene.render.resolution_percentage = 100


@pytest.fixture(scope="session")
def cycles():
    """cycles(scene, samples, width=32): configure the scene for a Cycles comparison render."""
    return cycles_settings


@pytest.fixture(scope="session")
def render_exr(bpy, exr):
    """render_exr(path) -> RGB float32 (h, w, 3) of the current scene, top-down, finite."""
    import numpy as np

    def render(path):
        scene = bpy.context.scene
        exr.set_output(scene, path)
        assert bpy.ops.render.render(write_still=True) == {'FINISHED'}
        img = exr.read(path)
        assert np.isfinite(img).all()
        return img[..., :3]
    return render


@pytest.fixture(scope="session")
def render_direct(cycles, tiny, render_exr):
    """render_direct(scene, folder, width, height, samples, passes, photons=64) -> (ours,
    Cycles' RGB): the scene without bounces (direct light and what the camera sees), by Cycles
    at ``samples`` per pixel and by this engine in ``passes`` passes, width x height."""
    def run(scene, folder, width, height, samples, passes, photons=64):
        cycles(scene, samples, width=width)
        scene.render.resolution_y = height
        scene.cycles.max_bounces = 0
        ref = render_exr(folder / "cycles.exr")
        tiny(scene, width=width, height=height, passes=passes, photons=photons)
        return render_exr(folder / "ours.exr"), ref
    return run


# --- test tiers ---------------------------------------------------------------------------------
# (markers in pytest.ini; tests/README.md has the commands)
#   blender  needs the bpy module: any test using the `bpy` fixture, directly or through another
#   cycles   renders a Cycles reference in the test: it calls the `cycles` or `render_direct`
#            fixture, harness.cycles_reference or cycles_settings, or sets the engine to
#            CYCLES, in its body or in a function of its module that it calls
#   bench, gpu, slow: marked where they are (the benchmark's tooling; the tests to run on a lent
#            GPU, on every OpenCL device; the long variants)
_CYCLES_CALLS = {"cycles", "render_direct", "cycles_reference", "cycles_settings"}


def _renders_cycles(module) -> set:
    """The names of the functions of a test module that render with Cycles, directly or through
    the module's other functions."""
    import ast
    import inspect
    try:
        tree = ast.parse(inspect.getsource(module))
    except (OSError, TypeError):
        return set()
    calls, direct = {}, set()
    for fn in ast.walk(tree):
        if not isinstance(fn, ast.FunctionDef):
            continue
        names = set()
        for node in ast.walk(fn):
            if isinstance(node, ast.Call):
                f = node.func
                names.add(f.id if isinstance(f, ast.Name) else
                          f.attr if isinstance(f, ast.Attribute) else "")
            elif (isinstance(node, ast.Assign) and isinstance(node.value, ast.Constant)
                  and node.value.value == "CYCLES"):
                direct.add(fn.name)
        calls[fn.name] = names
        if names & _CYCLES_CALLS:
            direct.add(fn.name)
    found, grew = set(direct), True
    while grew:
        grew = False
        for name, names in calls.items():
            if name not in found and names & found:
                found.add(name)
                grew = True
    return found


QUICK_SKIPS = ("cycles", "bench", "package")


def pytest_addoption(parser):
    parser.addoption("--quick", action="store_true",
                     help="the edit-test loop: the default run without the tests that render "
                          f"Cycles references, run the benchmark or build packages "
                          f"({', '.join(QUICK_SKIPS)}); about a minute with a warm kernel cache")


# --- the order files are handed to the two processes (pytest.ini: --dist loadfile, and
# --no-loadscope-reorder, which keeps this order) -------------------------------------------------
# Each process takes the next file when it is nearly done with its own.  xdist's own order (most
# tests first) left the files of few but long tests to the end, where one process ran them
# while the other had finished.  These go first, longest first; while the first of them
# compiles the kernels of every feature, the next ones (the kernel sources alone, the wheel's
# process, which builds its own, the viewport's scene's own kernels) need none of them, so the
# two processes do not compile the same programs at once; the benchmark's quick run (kernels of
# every feature in its own process) comes after, when PoCL's disk cache holds them.  The others
# follow in xdist's order.
FIRST = ("test_exact_pool.py", "test_kernel_sources.py", "test_wheel.py", "test_viewport.py",
         "test_bench.py", "test_e2e.py", "test_indirect.py", "test_accuracy.py")


def _file_order(items) -> None:
    """Sort ``items`` by file: FIRST's files in its order, then the rest by their number of
    tests, most first (ties by name); each file's tests keep their order."""
    counts = {}
    for item in items:
        name = item.nodeid.split("::")[0].rsplit("/", 1)[-1]
        counts[name] = counts.get(name, 0) + 1
    rank = {f: i for i, f in enumerate(FIRST)}
    key = {f: (0, rank[f], "") if f in rank else (1, -n, f) for f, n in counts.items()}
    items.sort(key=lambda i: key[i.nodeid.split("::")[0].rsplit("/", 1)[-1]])


def pytest_collection_modifyitems(config, items):
    _file_order(items)
    seen = {}
    for item in items:
        module = getattr(item, "module", None)
        if module is not None and module not in seen:
            seen[module] = _renders_cycles(module)
        fixtures = set(getattr(item, "fixturenames", ()))
        if "bpy" in fixtures:
            item.add_marker(pytest.mark.blender)
        fn = getattr(item, "originalname", item.name)
        if fixtures & {"cycles", "render_direct"} or fn in seen.get(module, ()):
            item.add_marker(pytest.mark.cycles)
    if config.getoption("--quick"):
        skipped = [i for i in items if any(i.get_closest_marker(m) for m in QUICK_SKIPS)]
        if skipped:
            config.hook.pytest_deselected(items=skipped)
            items[:] = [i for i in items if i not in set(skipped)]
