"""``python -m ppm_engine bench --viewport``: the look-dev loop's latencies and memory
(docs/BENCHMARKS.md, "Viewport").

A ViewportSession renders an example scene (the Cornell box) through a view of its camera at
1280 x 720, as Blender's Rendered shading would, and every change is timed from the moment
Blender's thread would post it (view_draw's camera, view_update's export included) to the first
image of the restarted accumulation:

    camera move     the view orbits while the session refines at full resolution (the pass in
                    progress is dropped); and while dragging (every move restarts the levels)
    material edit   a wall's colour and the boxes' roughness: export, upload, zero builds
    transform       the tall box moved: export, refit

(An edit's clock starts after Blender's own depsgraph evaluation, where view_update would be
called: the export is ours and counted.)
    second open     a session opened again on the same scene in the same process
    cold start      per scene in a fresh process with an empty kernel cache, by program; the
                    viewport's build (every feature) against the scene's own (specialised)

Memory: the process's resident memory and the device bytes a session allocates, after 50
open-render-close cycles.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

SIZE, QUICK_SIZE = (1280, 720), (320, 180)
COLD_SCENES = ("cornell_box", "bulb_box", "glossy_metal")
TARGETS = {"camera_s": 0.15, "material_s": 0.3, "transform_s": 0.3, "second_open_s": 1.0}


def _rss() -> int:
    """The process's resident bytes, after the C heap returned its free memory (glibc's
    malloc_trim; PoCL's buffers are host memory)."""
    import contextlib
    import ctypes
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def _setup(name: str, size, device: str):
    """The example scene in bpy, its viewport options and a camera view of it."""
    import bpy

    from ppm_engine.blender.harness import ensure_registered
    from ppm_engine.blender.scenes import build_example
    ensure_registered()
    scene = build_example(name)
    scene.render.engine = "PPM"
    scene.render.resolution_x, scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.ppm.device = device or "DEFAULT"
    scene.ppm.viewport_passes = 100000
    bpy.context.view_layer.update()
    return bpy, scene


def view(bpy, scene, size, orbit: float = 0.0):
    """The camera record of a 3D view through the scene camera (Blender's projection of it),
    turned ``orbit`` radians about the world's z axis."""
    from ppm_engine.blender.export.camera import film_settings
    from ppm_engine.scene.camera import camera_from_view
    dg = bpy.context.evaluated_depsgraph_get()
    cam = scene.camera.evaluated_get(dg)
    proj = np.array(cam.calc_matrix_camera(dg, x=size[0], y=size[1]))
    c, s = np.cos(orbit), np.sin(orbit)
    rot = np.eye(4)
    rot[:2, :2] = ((c, -s), (s, c))
    to_world = rot @ np.array(cam.matrix_world.normalized())
    return camera_from_view(np.linalg.inv(to_world), proj, *size, **film_settings(scene))


def _export(bpy, camera):
    from ppm_engine.blender.export import export_scene
    return export_scene(bpy.context.evaluated_depsgraph_get(), camera=camera)


def _restart_latency(s, post) -> float:
    """Seconds from ``post()`` (the change handed over, export included) to the first image
    of the accumulation it restarts."""
    restarts = s.restarts
    t0 = time.perf_counter()
    post()
    if not s.wait(lambda s: s.frame() is not None and s.frame().restart > restarts,
                  timeout=120):
        raise RuntimeError(f"the viewport showed no new image: {s.status()}")
    return time.perf_counter() - t0


def _at_full_resolution(s, rng, pass_s: float) -> None:
    """Wait for the first full-resolution image, then a random part of a pass (a change then
    arrives while a full pass is in progress)."""
    s.wait(lambda s: s.frame() is not None and s.frame().divider == 1, timeout=300)
    time.sleep(float(rng.uniform(0.1, 0.9)) * pass_s)


def run_viewport(device: str = "", quick: bool = False, progress=print,
                 textured=None) -> dict:
    """``textured``: viewport_textured.textured_edits (passed in: it imports this module)."""
    from ppm_engine.blender.viewport import viewport_options
    from ppm_engine.render.viewport_session import ViewportSession
    size = QUICK_SIZE if quick else SIZE
    moves = 3 if quick else 8
    bpy, scene = _setup("cornell_box", size, device)
    options, start = viewport_options(scene.ppm)
    rng = np.random.default_rng(1)
    out = {"scene": "cornell_box", "size": list(size), "start_resolution": start}

    # first open in this process (programs from the disk cache), then a second one
    progress("viewport: opening the Cornell box")
    rss0 = _rss()
    timings = {}
    for key in ("first_open_s", "second_open_s"):
        t0 = time.perf_counter()
        s = ViewportSession(options, start)
        cam = view(bpy, scene, size)
        s.update_view(cam)
        s.update_scene(_export(bpy, cam))
        if not s.wait(lambda s: s.frame() is not None, timeout=600):
            raise RuntimeError(f"the viewport showed no image: {s.status()}")
        timings[key] = time.perf_counter() - t0
        if key == "first_open_s":
            s.close(timeout=60)
    out.update(timings)
    dev = s._device
    # a full-resolution pass's time (the moves arrive in the middle of one)
    s.wait(lambda s: s.frame().divider == 1 and s.frame().passes >= 2, timeout=600)
    f = s.frame()
    t_full = time.perf_counter()
    s.wait(lambda s: s.frame().passes > f.passes, timeout=600)
    out["full_pass_s"] = pass_s = time.perf_counter() - t_full
    out["rss_session_mb"] = (_rss() - rss0) / 2**20
    with dev.lock:
        out["device_mb_per_session"] = s._renderer.device_bytes() / 2**20
    builds = dev.programs.builds

    progress("viewport: camera moves")
    refining, dragging = [], []
    for k in range(moves):
        _at_full_resolution(s, rng, pass_s)
        refining.append(_restart_latency(
            s, lambda k=k: s.update_view(view(bpy, scene, size, 0.02 * (k + 1)))))
    for k in range(moves):                         # a drag: the next move 50 ms later
        time.sleep(0.05)
        dragging.append(_restart_latency(
            s, lambda k=k: s.update_view(view(bpy, scene, size, -0.01 * (k + 1)))))
    out["camera_refining_s"], out["camera_dragging_s"] = refining, dragging
    out["first_level"] = list(s.frame().image.shape[1::-1])

    progress("viewport: material edits")
    red = bpy.data.materials["Red"].node_tree.nodes["Principled BSDF"]
    material, rough = [], []
    for k in range(moves):
        _at_full_resolution(s, rng, pass_s)

        red.inputs["Base Color"].default_value = ((0.6, 0.05, 0.05, 1.0) if k % 2
                                                  else (0.2, 0.3, 0.7, 1.0))
        bpy.context.view_layer.update()       # Blender's own evaluation, before view_update
        material.append(_restart_latency(s, lambda: s.update_scene(_export(bpy, cam))))
    white = bpy.data.materials["White"].node_tree.nodes["Principled BSDF"]
    for k in range(moves):
        _at_full_resolution(s, rng, pass_s)

        white.inputs["Roughness"].default_value = 0.2 if k % 2 == 0 else 1.0
        bpy.context.view_layer.update()
        rough.append(_restart_latency(s, lambda: s.update_scene(_export(bpy, cam))))
    out["material_s"], out["roughness_s"] = material, rough

    progress("viewport: transforms")
    box = bpy.data.objects["TallBox"]
    x0 = box.location.x
    transform = []
    for k in range(moves):
        _at_full_resolution(s, rng, pass_s)

        box.location.x = x0 + (0.05 if k % 2 == 0 else 0.0)
        bpy.context.view_layer.update()
        transform.append(_restart_latency(s, lambda: s.update_scene(_export(bpy, cam))))
    out["transform_s"] = transform
    out["edit_builds"] = dev.programs.builds - builds
    out["actions"] = {a: s.actions.count(a) for a in set(s.actions)}
    s.close(timeout=60)
    out["rss_closed_mb"] = (_rss() - rss0) / 2**20

    progress("viewport: 50 open-render-close cycles")
    arrays = _export(bpy, cam)
    mem = {}
    for k in range(1, 51):
        s = ViewportSession(options.replace(passes=1), start)
        s.update_view(cam)
        s.update_scene(arrays)
        s.wait(timeout=600)
        s.close(timeout=60)
        if k in (1, 10, 20, 30, 40, 50):
            mem[str(k)] = (_rss() - rss0) / 2**20
    out["rss_after_cycles_mb"] = mem

    progress("viewport: camera moves on the bulb box (photons)")
    out["photon_scene"] = photon_camera_moves(size, moves, device, rng)

    progress("viewport: previews")
    out["previews"] = previews(bpy, device)

    progress("viewport: edits of a 100K-triangle textured scene")
    if textured is not None:
        out["textured"] = textured(size, moves, device, rng, progress)

    progress("viewport: cold starts (fresh processes, empty kernel cache)")
    out["cold"] = [cold_start(name, device, quick=quick, kernels=k)
                   for name in (COLD_SCENES[:1] if quick else COLD_SCENES)
                   for k in ("editable", "scene", "all")]
    return out


def photon_camera_moves(size, moves: int, device: str, rng) -> dict:
    """Camera moves while the bulb box refines at full resolution: its passes are photon
    passes (and eye passes), each launched in pieces."""
    from ppm_engine.blender.viewport import viewport_options
    from ppm_engine.render.viewport_session import ViewportSession
    bpy, scene = _setup("bulb_box", size, device)
    options, start = viewport_options(scene.ppm)
    s = ViewportSession(options, start)
    try:
        cam = view(bpy, scene, size)
        s.update_view(cam)
        s.update_scene(_export(bpy, cam))
        s.wait(lambda s: s.frame() is not None and s.frame().divider == 1
               and s.frame().passes >= 2, timeout=900)
        f = s.frame()
        t = time.perf_counter()
        s.wait(lambda s: s.frame().passes > f.passes, timeout=900)
        pass_s = time.perf_counter() - t
        lat = []
        for k in range(moves):
            _at_full_resolution(s, rng, pass_s)
            lat.append(_restart_latency(
                s, lambda k=k: s.update_view(view(bpy, scene, size, 0.02 * (k + 1)))))
        return {"scene": "bulb_box", "full_pass_s": pass_s, "camera_refining_s": lat,
                "stats": s.status()}
    finally:
        s.close(timeout=60)


def previews(bpy, device: str) -> list[dict]:
    """A material preview's cost: the glossy_metal example (balls on a floor under a small
    light, as Blender's material preview scene) rendered by a final render's Session path's
    preview options at an icon's sizes and the Preview panel's, kernels warm (its editable
    build done first, at 16 px)."""
    from ppm_engine.blender.export import export_scene
    from ppm_engine.blender.properties import to_options
    from ppm_engine.blender.scenes import build_example
    from ppm_engine.blender.session import preview_options
    from ppm_engine.render.renderer import Renderer
    scene = build_example("glossy_metal")
    scene.render.engine = "PPM"
    scene.ppm.device = device or "DEFAULT"
    rows = []
    for size in (16, 32, 96, 256):
        scene.render.resolution_x = scene.render.resolution_y = size
        bpy.context.view_layer.update()
        t0 = time.perf_counter()
        options = preview_options(to_options(scene.ppm), size, size)
        r = Renderer(export_scene(bpy.context.evaluated_depsgraph_get()), options)
        for _ in range(options.passes):
            r.iterate()
        r.image()
        r.close()
        rows.append({"size": size, "passes": options.passes,
                     "seconds": time.perf_counter() - t0})
    return rows[1:]                             # the first one built the kernels


def cold_start(name: str, device: str = "", quick: bool = False,
               kernels: str = "editable") -> dict:
    """A fresh process with an empty PoCL kernel cache opens a viewport on example ``name``:
    seconds to its first image, and each build's seconds.  ``kernels``: the viewport's
    ("editable"), the scene's own as a final render builds them ("scene"), or every feature
    ("all"; viewport_session.KERNELS)."""
    with tempfile.TemporaryDirectory(prefix="ppm-cold-") as cache:
        env = dict(os.environ, POCL_CACHE_DIR=cache, PYOPENCL_NO_CACHE="1")
        code = ("import json, sys; "
                "from ppm_engine.tools.bench.viewport_latency import _cold_child; "
                f"print('RESULT' + json.dumps(_cold_child({name!r}, {device!r}, {quick!r}, "
                f"{kernels!r})))")
        p = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                           text=True, timeout=1800)
    for line in p.stdout.splitlines():
        if line.startswith("RESULT"):
            return json.loads(line[len("RESULT"):])
    raise RuntimeError(f"the cold-start process failed:\n{p.stdout[-2000:]}{p.stderr[-4000:]}")


def _cold_child(name: str, device: str, quick: bool, kernels: str) -> dict:
    """(In the fresh process.)  Besides the programs' builds, the time of the BVH's first
    build (its kernels and pyopencl's sort and scan) and of every kernel's first launch, each
    waited for: PoCL compiles a kernel for its work-group size when it is first launched, which
    a program's build does not include."""
    from ppm_engine.blender.viewport import viewport_options
    from ppm_engine.render import bvh
    from ppm_engine.render import viewport_session as viewport
    from ppm_engine.render.device import get_device
    from ppm_engine.render.device.program import Launch
    size = QUICK_SIZE if quick else SIZE
    bpy, scene = _setup(name, size, device)
    options, start = viewport_options(scene.ppm)
    dev = get_device(options.device)
    builds, began = [], {}

    def listen(label, done):
        if not done:
            began[label] = time.perf_counter()
        else:
            builds.append((label, time.perf_counter() - began.pop(label)))
    dev.programs.listeners.append(listen)
    launches, bvh_s = {}, []
    call, init = Launch.__call__, bvh.BVH.__init__

    def first_launch(self, queue, *args, **kwargs):
        name = self.kernel.function_name
        if name in launches:
            return call(self, queue, *args, **kwargs)
        queue.finish()
        t = time.perf_counter()
        ev = call(self, queue, *args, **kwargs)
        ev.wait()
        launches[name] = time.perf_counter() - t
        return ev

    def timed_bvh(self, *args, **kwargs):
        t = time.perf_counter()
        init(self, *args, **kwargs)
        bvh_s.append(time.perf_counter() - t)
    Launch.__call__, bvh.BVH.__init__ = first_launch, timed_bvh
    t0 = time.perf_counter()
    s = viewport.ViewportSession(options, start, kernels=kernels)
    cam = view(bpy, scene, size)
    s.update_view(cam)
    s.update_scene(_export(bpy, cam))
    s.wait(lambda s: s.frame() is not None, timeout=1800)
    first = time.perf_counter() - t0
    s.wait(lambda s: s.frame() is not None and s.frame().divider == 1, timeout=1800)
    full = time.perf_counter() - t0
    s.close(timeout=60)
    return {"scene": name, "kernels": kernels, "first_image_s": first,
            "first_full_image_s": full, "builds": builds,
            "build_s": sum(b for _, b in builds), "bvh_s": sum(bvh_s),
            "first_launches": sorted(launches.items(), key=lambda kv: -kv[1])}


def _stat(v: list) -> str:
    return f"{np.median(v):.3f} (max {max(v):.3f})"


def format_viewport(d: dict) -> str:
    w, h = d["size"]
    lw, lh = d["first_level"]
    lines = [
        f"Cornell box viewport, {w} x {h}, start pixels {d['start_resolution']} (first image "
        f"{lw} x {lh}); one full-resolution pass {d['full_pass_s']:.2f} s on this device",
        "",
        "| change | seconds to the first new image, median (max) | target |",
        "|---|---:|---:|",
        f"| camera move, while refining at full resolution | {_stat(d['camera_refining_s'])} "
        f"| {TARGETS['camera_s']} |",
        f"| camera move, dragging (every 50 ms) | {_stat(d['camera_dragging_s'])} "
        f"| {TARGETS['camera_s']} |",
        f"| material colour (export + upload) | {_stat(d['material_s'])} "
        f"| {TARGETS['material_s']} |",
        f"| material roughness (export + upload) | {_stat(d['roughness_s'])} "
        f"| {TARGETS['material_s']} |",
        f"| mesh transform (export + refit) | {_stat(d['transform_s'])} "
        f"| {TARGETS['transform_s']} |",
        f"| camera move, the bulb box refining (photons; its full pass "
        f"{d['photon_scene']['full_pass_s']:.2f} s) | "
        f"{_stat(d['photon_scene']['camera_refining_s'])} | {TARGETS['camera_s']} |",
        f"| second open of the scene in this process | {d['second_open_s']:.3f} "
        f"| {TARGETS['second_open_s']} |",
        f"| first open in this process (kernels from the disk cache) | "
        f"{d['first_open_s']:.3f} | |",
        "",
        f"Kernel builds during all the edits above: {d['edit_builds']} "
        f"(actions: {', '.join(f'{k} {v}' for k, v in sorted(d['actions'].items()))}).",
        "",
        f"Memory: a session at full resolution holds {d['device_mb_per_session']:.1f} MiB of "
        f"device buffers (PoCL's are host memory); the process had grown "
        f"{d['rss_session_mb']:.0f} MiB with it open (the kernels compiled in it included) and "
        f"{d['rss_closed_mb']:.0f} MiB after it closed; after N open-render-close cycles: "
        + ", ".join(f"{k}: {v:.0f}" for k, v in d["rss_after_cycles_mb"].items()) + " MiB.",
        "",
        "Previews (export, setup and passes, kernels warm): "
        + ", ".join(f"{p['size']} px {p['passes']} passes {p['seconds']:.2f} s"
                    for p in d["previews"]) + ".",
        "",
        "Cold start (a fresh process, an empty PoCL kernel cache):",
        "",
        "| scene | kernels | first image s | first full image s | program builds s | "
        "BVH's first build s | slowest first launches s |",
        "|---|---|---:|---:|---:|---:|---|",
    ]
    for c in d["cold"]:
        slow = c["first_launches"][:3]
        lines.append(f"| {c['scene']} | {c['kernels']} | "
                     f"{c['first_image_s']:.1f} | {c['first_full_image_s']:.1f} | "
                     f"{c['build_s']:.1f} | {c['bvh_s']:.1f} | "
                     f"{', '.join(f'{k} {v:.1f}' for k, v in slow)} |")
    if "textured" in d:
        lines += ["", d["textured"]["table"]]
    return "\n".join(lines)
