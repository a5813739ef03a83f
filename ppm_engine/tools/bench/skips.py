"""``python -m ppm_engine bench --skips``: what each "skip what a scene doesn't need" saves,
measured side by side with and without the skip in one run (docs/BENCHMARKS.md, "Skips").

Each row renders or sets up the same scene twice, alternating the two variants so that the
machine's load affects both alike, and reports medians.  The variants "without" switch the
skip off through the engine's public settings: RenderOptions.specialize,
skip_unneeded_photon_pass, skip_unseen_photons and skip_blind_light_tracing, persistent data
off, no noise threshold,
an object shown instead of hidden, the photon pass and gather built up front (their properties
read before the first pass).
"""
from __future__ import annotations

import time

import numpy as np

from ppm_engine.blender import session
from ppm_engine.blender.harness import ensure_registered
from ppm_engine.oracle.procedural import MeshBuilder, cornell_box, look_at
from ppm_engine.render.options import RenderOptions
from ppm_engine.render.renderer import Renderer
from ppm_engine.scene.arrays import LIGHT_DTYPE, LIGHT_POINT
from ppm_engine.scene.camera import make_camera, perspective_extent


def _median_pass_ms(renderers: dict, passes: int, warmup: int = 3) -> dict:
    """Median wall time of a pass per renderer, passes interleaved."""
    for r in renderers.values():
        for _ in range(warmup):
            r.iterate()
    times = {k: [] for k in renderers}
    for _ in range(passes):
        for k, r in renderers.items():
            t = time.perf_counter()
            r.iterate()
            times[k].append((time.perf_counter() - t) * 1e3)
    return {k: float(np.median(v)) for k, v in times.items()}


def _row(name, scene, with_, without, unit, note) -> dict:
    return {"skip": name, "scene": scene, "with": with_, "without": without, "unit": unit,
            "saving": 1.0 - with_ / without if without > 0 else 0.0, "note": note}


def specialisation(res: int, passes: int, device: str) -> list[dict]:
    """Kernels built for the scene's features vs every feature compiled in."""
    rows = []
    mb = MeshBuilder()                       # a diffuse room lit by one point light
    white = mb.material("white", (0.7, 0.7, 0.7))
    mb.box((-1, -1, 0), (1, 1, 2), white, inward=True)
    mb.box((-0.4, -0.2, 0), (0.2, 0.4, 0.8), white)
    light = np.zeros(1, LIGHT_DTYPE)
    light["type"], light["emit"], light["position"] = LIGHT_POINT, 8.0, (0, 0, 1.6)
    cam = make_camera(width=res, height=res, to_world=look_at((0, -0.95, 1), (0, 0, 0.8)),
                      extent=perspective_extent(res, res, 20, 36)[:2], clip=(0.01, 100))
    point_room = mb.build(camera=cam, lights=light)
    for label, scene in (("Cornell box (diffuse, mesh light)", cornell_box(res, res)),
                         ("diffuse room, one point light", point_room)):
        rs = {sp: Renderer(scene, RenderOptions(specialize=sp, device=device, seed=1))
              for sp in (True, False)}
        ms = _median_pass_ms(rs, passes)
        feats = ", ".join(sorted(f.replace("PPM_", "").lower() for f in rs[True].features))
        for r in rs.values():
            r.close()
        rows.append(_row("kernel specialisation", f"{label} {res}x{res}", ms[True], ms[False],
                         "ms per pass", f"features: {feats}"))
    return rows


def dark_scene(res: int, device: str) -> dict:
    """A scene that emits nothing: the emission check vs building the renderer and passes."""
    scene = cornell_box(res, res, light_radiance=0.0)
    t = time.perf_counter()
    for _ in range(10):
        dark = session.emits_nothing(scene)
    skip_ms = (time.perf_counter() - t) * 100
    assert dark
    t = time.perf_counter()
    r = Renderer(scene, RenderOptions(device=device, passes=16))
    for _ in range(16):
        r.iterate()
    r.image()
    r.close()
    full_ms = (time.perf_counter() - t) * 1e3
    return _row("nothing emits: black image, no device work", f"Cornell box, lamp off, "
                f"{res}x{res}", skip_ms, full_ms, "ms to the image",
                "without: build the renderer (BVH, buffers) and run 16 passes")


def _photon_pass_skip(scene, passes: int, device: str, **opts) -> dict:
    """Median ms per pass with the unneeded photon pass skipped ("skip") and run anyway
    ("run": the passes run and add nothing)."""
    rs = {k: Renderer(scene, RenderOptions(device=device, seed=1,
                                           skip_unneeded_photon_pass=(k == "skip"), **opts))
          for k in ("skip", "run")}
    ms = _median_pass_ms(rs, passes)
    for r in rs.values():
        r.close()
    return ms


def no_photon_pass(res: int, passes: int, device: str) -> dict:
    """max_bounces = 0: no photon pass, hash or gather vs running them anyway."""
    scene = cornell_box(res, res)
    ms = _photon_pass_skip(scene, passes, device, max_bounces=0, indirect="photons")
    return _row("no photon pass (direct light only, or no diffuse surface)",
                f"Cornell box, max bounces 0, {res}x{res}", ms["skip"], ms["run"], "ms per pass",
                "without: photon pass, hash build and gather run")


def no_caustic_photons(res: int, passes: int, device: str) -> dict:
    """Indirect light by eye paths in a scene without mirrors, glass or smooth glossy lobes:
    no photon can be a caustic one, so no photon pass, hash or gather vs running them."""
    scene = cornell_box(res, res)
    ms = _photon_pass_skip(scene, passes, device, indirect="paths")
    return _row("no caustic photons (indirect light by paths, no mirror or glass)",
                f"Cornell box, {res}x{res}", ms["skip"], ms["run"], "ms per pass",
                "without: photon pass (each photon ends at its first hit), hash build and "
                "gather run")


def photons_outside(res: int, passes: int, device: str) -> dict:
    """Photons outside the visible points' grid are not stored or hashed vs a grid over the
    whole scene (every photon stored)."""
    scene = cornell_box(res, res)
    cam = scene.camera.copy()                # looking into one corner: most photons unseen
    cam["to_world"] = look_at((0.5, 0.5, 0.5), (1.0, 1.0, 0.0))[:3]
    scene = scene.replace(camera=cam)
    rs = {k: Renderer(scene, RenderOptions(device=device, seed=1, indirect="photons",
                                           skip_unseen_photons=(k == "skip")))
          for k in ("skip", "all")}                 # "all": a grid over the whole scene
    ms = _median_pass_ms(rs, passes)
    stats = {k: r.iterate() for k, r in rs.items()}
    hash_gather = {k: s.phase_ms.get("hash", 0) + s.phase_ms.get("gather", 0)
                   for k, s in stats.items()}
    s = stats["skip"]
    share = s.photons_outside / max(s.photons_outside + s.photons_stored, 1)
    for r in rs.values():
        r.close()
    row = _row("photons nobody looks at are not stored", f"Cornell box seen into a corner, "
               f"{res}x{res}", ms["skip"], ms["all"], "ms per pass",
               f"{100 * share:.0f} % of the photons land outside the grid; hash + gather "
               f"{hash_gather['skip']:.2f} ms vs {hash_gather['all']:.2f} ms storing all")
    return row


def adaptive(res: int, threshold: float, device: str, max_passes: int = 2000) -> dict:
    """Time to converge with a noise threshold vs the same passes on every pixel."""
    scene = cornell_box(res, res)
    r = Renderer(scene, RenderOptions(device=device, seed=1, noise_threshold=threshold))
    t = time.perf_counter()
    for _ in range(max_passes):
        s = r.iterate()
        if s.converged:
            break
    with_s = time.perf_counter() - t
    passes = r.passes_done
    r.close()
    r = Renderer(scene, RenderOptions(device=device, seed=1))
    t = time.perf_counter()
    for _ in range(passes):
        r.iterate()
    without_s = time.perf_counter() - t
    r.close()
    done = "all pixels converged" if s.converged else \
        f"{100 * (1 - s.active_pixels / s.pixels):.0f} % of the pixels converged"
    return _row(f"converged pixels (noise threshold {threshold:g})", f"Cornell box {res}x{res}",
                with_s * 1e3, without_s * 1e3, "ms for the passes",
                f"{passes} passes, {done}; without: the same passes on every pixel")


def persistent(device: str, quick: bool) -> list[dict]:
    """Setup time of a re-render with Blender's persistent data: unchanged scene, settings
    changed, an object moved (refit), against a render without persistent data."""
    import tempfile

    import bpy

    from ppm_engine.blender.scenes import build_example
    ensure_registered()
    scene = build_example("bulb_box")
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=4 if quick else 8, radius=0.25,
                                          location=(-0.5, 0.3, 0.25))
    ball = bpy.context.active_object
    n_tris = len(ball.data.polygons)
    scene.render.engine = "PPM"
    scene.render.resolution_x = scene.render.resolution_y = 32
    scene.ppm.passes, scene.ppm.time_limit = 1, 0.0
    if device:
        scene.ppm.device = device
    log = session.renders

    def setup(change=None):
        if change:
            change()
        bpy.ops.render.render(write_still=False)
        return log[-1]["setup_s"] * 1e3
    with tempfile.TemporaryDirectory():
        scene.render.use_persistent_data = False
        setup()                                      # programs built, caches warm
        fresh = float(np.median([setup() for _ in range(3)]))
        scene.render.use_persistent_data = True
        setup()
        same = float(np.median([setup() for _ in range(3)]))

        def settings():
            scene.ppm.alpha = 0.71 if scene.ppm.alpha != 0.71 else 0.7
        changed = float(np.median([setup(settings) for _ in range(3)]))

        def move():
            ball.location.x += 0.01
        moved = float(np.median([setup(move) for _ in range(3)]))
        refit = bool(log[-1]["bvh_refit"])
        scene.render.use_persistent_data = False
    label = f"bulb box + a {n_tris:,}-triangle ball, setup before the first pass"
    return [
        _row("re-render, nothing changed (persistent data)", label, same, fresh, "ms",
             "no export, no BVH, no kernel build; without: persistent data off"),
        _row("re-render, engine settings changed", label, changed, fresh, "ms",
             "no export, no BVH"),
        _row("re-render, an object moved", label, moved, fresh, "ms",
             f"export, BVH {'refit' if refit else 'rebuilt'}, no kernel build"),
    ]


def hidden_object(device: str, quick: bool) -> dict:
    """An object hidden from the render (hide_render) costs nothing: the setup of a render
    (export, BVH, upload) with a heavy object hidden vs shown, through bpy.ops.render.render
    (the render depsgraph is what honours hide_render)."""
    import bpy

    from ppm_engine.blender.scenes import build_example
    ensure_registered()
    scene = build_example("cornell_box")
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=5 if quick else 8, radius=0.2,
                                          location=(0, 0, 1))
    obj = bpy.context.active_object
    n = len(obj.data.polygons)
    scene.render.engine = "PPM"
    scene.render.resolution_x = scene.render.resolution_y = 32
    scene.render.use_persistent_data = False
    scene.ppm.passes, scene.ppm.time_limit = 1, 0.0
    if device:
        scene.ppm.device = device

    def setup_ms():
        bpy.ops.render.render(write_still=False)
        return session.renders[-1]["setup_s"] * 1e3
    times = {True: [], False: []}
    setup_ms()                                  # programs built
    for _ in range(3):
        for hidden in (True, False):
            obj.hide_render = hidden
            times[hidden].append(setup_ms())
    with_, without = float(np.median(times[True])), float(np.median(times[False]))
    return _row("objects hidden from the render", f"Cornell box + a {n:,}-triangle ball, "
                "setup before the first pass", with_, without, "ms",
                "the ball hidden (hide_render) vs shown; disabled collections and ray-visibility "
                "flags are honoured at export and in the kernels")


# a new scene's setup and first pass with pocl's kernel cache empty, in a child process, then
# the photon pass and the gather built as they were before they were built on first use (up
# front, in the same process state: what the eager setup added); argv: device, resolution
_COLD_SETUP = """
import sys, time
from ppm_engine.render.options import RenderOptions
from ppm_engine.oracle.procedural import cornell_box
from ppm_engine.render.renderer import Renderer
device, res = sys.argv[1], int(sys.argv[2])
t = time.perf_counter()
r = Renderer(cornell_box(res, res), RenderOptions(device=device))
r.iterate()
t1 = time.perf_counter()
r.photons, r.gather
print(t1 - t, time.perf_counter() - t1, r.path_indirect, r.photons_needed)
"""


def lazy_builds(res: int, device: str, quick: bool) -> dict:
    """Kernels a scene never runs are never built: the Cornell box, lit by eye paths with no
    caustic possible, needs no photon pass or gather.  The time from a new Renderer to its first
    pass with the kernel cache empty (a child process each, its own empty POCL_CACHE_DIR), and
    the time building those two up front added (measured in the same process after the first
    pass: a cold setup varies by seconds from run to run, more than the builds cost)."""
    import os
    import subprocess
    import sys
    import tempfile
    from pathlib import Path
    setup, builds = [], []
    for _ in range(1 if quick else 3):
        with tempfile.TemporaryDirectory(prefix="ppm-pocl-cache-") as cache:
            env = dict(os.environ, POCL_CACHE_DIR=cache, PYOPENCL_NO_CACHE="1",
                       PYTHONPATH=str(Path(__file__).resolve().parents[3]))
            out = subprocess.run([sys.executable, "-c", _COLD_SETUP, device, str(res)],
                                 env=env, capture_output=True, text=True, timeout=600)
            if out.returncode != 0:
                raise RuntimeError(f"the cold setup's child failed: {out.stderr[-2000:]}")
            first, built, paths, photons = out.stdout.split()[-4:]
            if paths != "True" or photons != "False":
                raise RuntimeError("the Cornell box no longer renders by eye paths alone: "
                                   "this row would measure nothing")
            setup.append(float(first))
            builds.append(float(built))
    with_ = float(np.median(setup))
    return _row("kernels a scene never runs are not built", f"Cornell box (eye paths, no "
                f"caustic), {res}x{res}, a new scene with the kernel cache empty",
                with_, with_ + float(np.median(builds)), "s to the first pass",
                "without: the photon pass and the gather built up front (their build time, "
                "measured after the first pass, added)")


def blind_light_tracing(res: int, passes: int, device: str) -> dict:
    """The photons' light tracing stops after the first pass where no pixel sees what it
    renders (a pool's floor seen only through its water) vs connecting every photon on."""
    import bpy

    from ppm_engine.blender.export import export_scene
    from ppm_engine.blender.scenes import pool
    pool.build(grid=pool.grid_for(res))
    scene = bpy.context.scene
    scene.render.resolution_x = scene.render.resolution_y = res
    arrays = export_scene(bpy.context.evaluated_depsgraph_get())
    rs = {k: Renderer(arrays, RenderOptions(device=device, seed=1,
                                            skip_blind_light_tracing=(k == "skip")))
          for k in ("skip", "all")}
    ms = _median_pass_ms(rs, passes)
    on = {k: r.lt_kappa > 0 for k, r in rs.items()}
    for r in rs.values():
        r.close()
    return _row("photons' light tracing where no pixel sees what it renders",
                f"pool (its floor seen through the water) {res}x{res}", ms["skip"], ms["all"],
                "ms per pass", f"light tracing after the first pass: {on['skip']} vs "
                f"{on['all']}")


def run_skips(device: str = "", quick: bool = False, progress=print) -> dict:
    res = 32 if quick else 128
    passes = 3 if quick else 15
    rows = []
    progress("skips: kernel specialisation")
    rows += specialisation(res, passes, device)
    progress("skips: a scene that emits nothing")
    rows.append(dark_scene(res, device))
    progress("skips: no photon pass")
    rows.append(no_photon_pass(res, passes, device))
    rows.append(no_caustic_photons(res, passes, device))
    progress("skips: kernels a scene never runs")
    rows.append(lazy_builds(res, device, quick))
    progress("skips: photons outside the visible points")
    rows.append(photons_outside(res, passes, device))
    progress("skips: light tracing nobody sees")
    rows.append(blind_light_tracing(res, passes, device))
    progress("skips: adaptive sampling")
    rows.append(adaptive(16 if quick else 64, 0.05 if quick else 0.02, device,
                         max_passes=64 if quick else 2000))
    progress("skips: persistent data")
    rows += persistent(device, quick)
    progress("skips: hidden objects")
    rows.append(hidden_object(device, quick))
    return {"rows": rows}


def format_skips(result: dict) -> str:
    lines = ["| skip | scene | with | without | saving | notes |", "|---|---|---:|---:|---:|---|"]
    for r in result["rows"]:
        lines.append(f"| {r['skip']} | {r['scene']} | {r['with']:.3g} {r['unit']} | "
                     f"{r['without']:.3g} {r['unit']} | {100 * r['saving']:.0f} % | {r['note']} |")
    return "\n".join(lines)
