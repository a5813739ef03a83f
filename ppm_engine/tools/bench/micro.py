"""Micro benchmarks of the kernels (``python -m ppm_engine bench --micro``).

Each figure is the median of several timed runs after warm-up runs (PoCL compiles a kernel the
first time it is enqueued with a new work-group size), timed with OpenCL profiling events
(device time) unless it says wall.
"""
from __future__ import annotations

import math
import time

import numpy as np

from ppm_engine.blender import session
from ppm_engine.blender.harness import ensure_registered
from ppm_engine.oracle.procedural import MeshBuilder, cornell_box, look_at
from ppm_engine.oracle.reference import pack_unit
from ppm_engine.render.bvh import BVH
from ppm_engine.render.counters import N_COUNTERS, Counter
from ppm_engine.render.device import get_device
from ppm_engine.render.device_scene import placeholders
from ppm_engine.render.options import RenderOptions
from ppm_engine.render.passes import (
    Gather,
    GridSetup,
    HashBuild,
    Iteration,
    PassContext,
    VisiblePoints,
    unshaded,
)
from ppm_engine.render.photon_map import GRID_DTYPE, PhotonMap
from ppm_engine.render.renderer import Renderer
from ppm_engine.scene.camera import make_camera

PAPER = {
    "hash_build_200k_ms": (2.5, "Radeon HD 4850 (paper)"),
    "kdtree_build_200k_ms": (9.0, "Zhou et al. 2008 kd-tree, GeForce (paper's comparison)"),
}


def _events_ms(events) -> float:
    return sum((e.profile.end - e.profile.start) * 1e-6 for e in events)


def _median(f, repeat=7, warmup=2):
    for _ in range(warmup):
        f()
    return float(np.median([f() for _ in range(repeat)]))


def _synthetic_photons(device, n, n_vp, rng):
    """n photons and n_vp visible points on the floor of a 2x2 room (the Cornell box floor
    density at 256x256), through the real kernels' buffers: their PassContext, the grid set up."""
    import pyopencl as cl
    pm = PhotonMap(device, n)
    q = device.queue
    pos = np.zeros((n, 4), np.float32)
    pos[:, :2] = rng.uniform(-1, 1, (n, 2))
    pos.view(np.uint32)[:, 3] = pack_unit(np.array([[0, 0, 1.0]]))[0]
    flux = np.ones((n, 4), np.float32)
    flux.view(np.uint32)[:, 3] = pack_unit(np.array([[0, 0, 1.0]]))[0]
    cl.enqueue_copy(q, pm.ph_pos, pos)
    cl.enqueue_copy(q, pm.ph_flux, flux)
    counters = np.zeros(N_COUNTERS, np.uint32)
    counters[Counter.STORED] = n
    cbuf = device.upload(counters, "counters")
    vp = np.zeros((n_vp, 4), np.float32)
    vp[:, :2] = rng.uniform(-1, 1, (n_vp, 2))
    vp[:, 3] = 1
    vp_pos = device.upload(vp, "visible points")
    vp_nrm = device.upload(np.tile(np.float32([0, 0, 1, 0]), (n_vp, 1)), "visible points")
    # radius: ~1.5 pixels of a 256x256 view of the 2 m floor
    radius = device.upload(np.full(n_vp, 1.5 * 2.0 / 256, np.float32), "radius")
    gathered = device.buffer(16 * n_vp, "gathered")
    vps = VisiblePoints(device, n_vp, pos=vp_pos, nrm=vp_nrm, beta=vp_nrm,
                        shade=unshaded(device, n_vp), gathered=gathered)
    ctx = PassContext(device, vps=vps, photon_map=pm, counters=cbuf, radius=radius)
    GridSetup(ctx).enqueue(q, Iteration(0, RenderOptions()))
    q.finish()
    return ctx


def hash_and_gather(device, n_photons: int, n_vp: int = 65536, seed=0) -> dict:
    rng = np.random.default_rng(seed)
    ctx = _synthetic_photons(device, n_photons, n_vp, rng)
    pm, counters = ctx.photon_map, ctx.counters
    hb, gather_pass = HashBuild(ctx), Gather(ctx)
    options = RenderOptions(seed=0)
    import pyopencl as cl
    q = device.queue
    it = iter(range(10 ** 9))

    def build():
        cl.enqueue_fill_buffer(q, counters, np.uint32(0), 4 * Counter.OCCUPIED, 4)
        evs = hb.enqueue(q, Iteration(next(it), options))
        q.finish()
        return _events_ms([e for _, e in evs])

    def gather():
        evs = gather_pass.enqueue(q, Iteration(0, options))
        q.finish()
        return _events_ms([e for _, e in evs])

    build_ms = _median(build)
    gather_ms = _median(gather)
    c = np.empty(N_COUNTERS, np.uint32)
    cl.enqueue_copy(q, c, counters)
    g = np.empty(1, GRID_DTYPE)
    cl.enqueue_copy(q, g, pm.grid)
    return {"photons": n_photons, "hash_build_ms": build_ms,
            "hash_build_ns_per_photon": build_ms * 1e6 / n_photons,
            "gather_ms": gather_ms, "gather_ns_per_vp": gather_ms * 1e6 / n_vp,
            "visible_points": n_vp, "table_size": pm.table_size,
            "photons_per_entry": n_photons / max(int(c[Counter.OCCUPIED]), 1)}


def tracing(device, width=256, photons=1 << 18) -> dict:
    """Eye rays and photons per second in the Cornell box (device time of the passes), with
    the paper's photons for all indirect light (Automatic would trace eye paths there and no
    photon at all: no caustic in the box)."""
    r = Renderer(cornell_box(width, width), RenderOptions(photons_per_pass=photons,
                                                          device=device.info.key,
                                                          indirect="photons"))
    for _ in range(2):
        r.iterate()
    eye, ph = [], []
    for _ in range(5):
        s = r.iterate()
        eye.append(s.phase_ms["eye"])
        ph.append(s.phase_ms["photon"])
    r.close()
    return {"eye_rays_per_s": width * width / (np.median(eye) * 1e-3),
            "photons_per_s": photons / (np.median(ph) * 1e-3),
            "eye_pass_ms": float(np.median(eye)), "photon_pass_ms": float(np.median(ph))}


def _rays_per_second(device, bvh, n=1 << 16) -> float:
    """Closest-hit rays per second (device time) of random rays from inside the unit sphere."""
    rng = np.random.default_rng(0)
    o = np.zeros((n, 4), np.float32)
    o[:, :3] = rng.uniform(-0.5, 0.5, (n, 3))
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    dd = np.zeros((n, 4), np.float32)
    dd[:, :3], dd[:, 3] = d, 1e30
    ob, db = device.upload(o, "rays"), device.upload(dd, "rays")
    hits = device.buffer(16 * n, "hits")
    k = device.programs.get("test/debug.cl").launch("trace_rays", "bench")
    scene = placeholders(device, **bvh.args)

    def once():
        ev = k(device.queue, n, None, **scene, origins=ob, dirs=db, mask=np.uint32(0xFFFFFFFF),
               any_hit=np.int32(0), hits=hits, n=np.uint32(n))
        ev.wait()
        return n / ((ev.profile.end - ev.profile.start) * 1e-9)
    return _median(once, repeat=5, warmup=1)


def bvh_build(device, n_tris: int) -> dict:
    """Build time (wall) and closest-hit rays per second of both builders on a sphere."""
    mb = MeshBuilder()
    m = mb.material("m")
    seg = int(np.sqrt(n_tris / 2))
    mb.sphere((0, 0, 0), 1.0, m, 2 * seg, max(seg // 2, 2))
    scene = mb.build(camera=make_camera(width=8, height=8, to_world=look_at((0, -3, 0), (0, 0, 0)),
                                        extent=(1, 1)))
    out = {"triangles": scene.n_triangles}
    for method in ("ploc", "lbvh"):
        built = []

        def once(built=built, method=method):
            t = time.perf_counter()
            built.append(BVH(device, scene, method=method))
            return (time.perf_counter() - t) * 1e3
        out[f"{method}_build_ms_wall"] = _median(once, repeat=3, warmup=1)
        out[f"{method}_cost"] = built[-1].cost
        out[f"{method}_rays_per_s"] = _rays_per_second(device, built[-1])
    out["bvh_build_ms_wall"] = out["ploc_build_ms_wall"]
    return out


def run_micro(device_name: str = "", quick: bool = False, progress=print) -> dict:
    device = get_device(device_name)
    out = {"device": device.info.name, "platform": device.info.platform, "paper": PAPER}
    sizes = [20_000] if quick else [200_000, 1_000_000]
    out["hash"] = []
    for n in sizes:
        progress(f"hash build + gather, {n} photons")
        out["hash"].append(hash_and_gather(device, n, n_vp=4096 if quick else 65536))
    progress("eye and photon tracing (Cornell box)")
    out["tracing"] = tracing(device, 32 if quick else 256, 1 << 12 if quick else 1 << 18)
    out["bvh"] = []
    for n in ([2_000] if quick else [100_000, 1_000_000]):
        progress(f"BVH build, {n} triangles")
        out["bvh"].append(bvh_build(device, n))
    return out


def format_micro(m: dict) -> str:
    lines = [f"device: {m['device']} ({m['platform']})"]
    for h in m["hash"]:
        lines.append(f"hash build {h['photons']:>9,} photons: {h['hash_build_ms']:8.3f} ms "
                     f"({h['hash_build_ns_per_photon']:.1f} ns/photon, "
                     f"{h['photons_per_entry']:.2f} photons/entry)   "
                     f"gather: {h['gather_ns_per_vp']:.1f} ns per visible point")
    lines.append(f"paper: 200K-photon hash build {PAPER['hash_build_200k_ms'][0]} ms on "
                 f"{PAPER['hash_build_200k_ms'][1]}; kd-tree {PAPER['kdtree_build_200k_ms'][0]} ms")
    t = m["tracing"]
    lines.append(f"eye rays: {t['eye_rays_per_s']:.3g}/s   photons traced: "
                 f"{t['photons_per_s']:.3g}/s")
    for b in m["bvh"]:
        lines.append(f"BVH build {b['triangles']:>9,} triangles: PLOC "
                     f"{b['ploc_build_ms_wall']:.1f} ms (wall, {b['ploc_rays_per_s']:.3g} rays/s), "
                     "LBVH "
                     f"{b['lbvh_build_ms_wall']:.1f} ms ({b['lbvh_rays_per_s']:.3g} rays/s)")
    if "export" in m:
        e = m["export"]
        lines.append(f"export_scene {e['triangles']:>9,} triangles: {e['export_s_wall']:.3f} s "
                     "(wall)")
    if "first_image" in m:
        f = m["first_image"]
        lines.append(f"render() to first image ({f['scene']}, warm caches): "
                     f"{f['first_image_s']:.3f} s (wall; export + setup {f['setup_s']:.3f} s)")
    return "\n".join(lines)


# --- through Blender (bpy) ----------------------------------------------------------------------
PAPER_TARGETS = {
    # issue 4's targets on this CPU (2 cores, PoCL)
    "hash_build_200k_ms": 2.5,
    "gather_ns_per_vp": 50.0,
    "export_1m_triangles_s": 0.2,
    "first_image_s": 1.5,
}


def _big_mesh(n_side: int):
    """A flat n_side x n_side vertex grid: 2 (n_side - 1)^2 triangles, built with foreach_set."""
    from ppm_engine.blender.scenes.cornell_box import grid_mesh
    xs = np.linspace(-1.0, 1.0, n_side, dtype=np.float32)
    X, Y = np.meshgrid(xs, xs)
    return grid_mesh("Big", np.stack([X, Y, np.zeros_like(X)], -1))


def export_big_mesh(n_triangles: int = 1_000_000, repeat: int = 3) -> dict:
    """Wall time of ppm_engine.blender.export.export_scene for one mesh of ~n_triangles (plus a
    camera and a light) in an otherwise empty file; median of ``repeat`` after one warm-up."""
    import bpy

    from ppm_engine.blender.export import export_scene
    from ppm_engine.blender.scenes.cornell_box import lambert, new_scene
    scene = new_scene(None)
    mesh = _big_mesh(round(math.sqrt(n_triangles / 2)) + 1)
    mesh.materials.append(lambert("Grey", (0.5, 0.5, 0.5)))
    obj = bpy.data.objects.new("Big", mesh)
    scene.collection.objects.link(obj)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location = (0.0, 0.0, 3.0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    light = bpy.data.objects.new("Light", bpy.data.lights.new("Light", 'POINT'))
    light.location = (0.0, 0.0, 2.0)
    scene.collection.objects.link(light)
    scene.render.resolution_x = scene.render.resolution_y = 64
    depsgraph = bpy.context.evaluated_depsgraph_get()
    arrays = export_scene(depsgraph)
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        arrays = export_scene(depsgraph)
        times.append(time.perf_counter() - t)
    return {"triangles": int(arrays.n_triangles), "export_s_wall": float(np.median(times)),
            "export_s_all": [float(t) for t in times]}


def first_image(scene_name: str = "bulb_box", device: str = "", repeat: int = 3) -> dict:
    """Wall time from the bpy.ops.render.render call to the first image written into the
    render result (session.listening's callbacks run right after that write), with warm kernel
    caches: one full render first, then ``repeat`` renders, median.  Default settings of the
    example (256x256, 2^18 photons per pass), 2 passes per render; no file is written."""
    import bpy

    from ppm_engine.blender.properties import to_options
    from ppm_engine.blender.scenes import build_example
    ensure_registered()
    scene = build_example(scene_name)
    scene.render.engine = "PPM"
    scene.ppm.passes = 2
    scene.ppm.time_limit = 0.0
    if device:
        scene.ppm.device = device
    firsts, setups = [], []
    for k in range(repeat + 1):
        stamp = []
        t0 = time.perf_counter()
        with session.listening(lambda text, fraction, stamp=stamp:
                               stamp.append(time.perf_counter())):
            bpy.ops.render.render(write_still=False)
        if k == 0:
            continue                    # warm-up: programs built, caches filled
        firsts.append(stamp[0] - t0)
        setups.append(session.renders[-1]["setup_s"])
    return {"scene": scene_name, "resolution": [scene.render.resolution_x,
                                                scene.render.resolution_y],
            "photons_per_pass": to_options(scene.ppm).photons_for(
                scene.render.resolution_x * scene.render.resolution_y),
            "first_image_s": float(np.median(firsts)), "first_image_s_all": firsts,
            "setup_s": float(np.median(setups)) if setups else None}


def run_micro_blender(device_name: str = "", quick: bool = False, progress=print) -> dict:
    """The micro figures that need Blender: export of a big mesh and time to the first image."""
    out = {}
    n = 20_000 if quick else 1_000_000
    progress(f"export_scene of a {n}-triangle mesh")
    out["export"] = export_big_mesh(n, repeat=1 if quick else 3)
    progress("time from render() to the first image (bulb box, warm caches)")
    out["first_image"] = first_image("bulb_box", device_name, repeat=1 if quick else 3)
    return out


def targets_table(m: dict) -> str:
    """Markdown: our figures against the issue's targets and the paper's."""
    rows = ["| figure | ours | target | met | paper |", "|---|---:|---:|---|---|"]
    h200 = next((h for h in m["hash"] if h["photons"] == 200_000), m["hash"][0])
    t = PAPER_TARGETS

    def row(label, value, target, unit, paper="–"):
        met = "yes" if value <= target else f"no ({value / target:.1f}x over)"
        rows.append(f"| {label} | {value:.3g} {unit} | ≤ {target:g} {unit} | {met} | {paper} |")
    row(f"hash build, {h200['photons']:,} photons", h200["hash_build_ms"],
        t["hash_build_200k_ms"], "ms",
        f"{PAPER['hash_build_200k_ms'][0]} ms ({PAPER['hash_build_200k_ms'][1]}); kd-tree "
        f"{PAPER['kdtree_build_200k_ms'][0]} ms")
    row(f"gather per visible point ({h200['visible_points']:,} points)", h200["gather_ns_per_vp"],
        t["gather_ns_per_vp"], "ns")
    if "export" in m:
        e = m["export"]
        row(f"export_scene, {e['triangles']:,} triangles (wall)", e["export_s_wall"],
            t["export_1m_triangles_s"], "s")
    if "first_image" in m:
        f = m["first_image"]
        row(f"render() to first image, {f['scene']} {f['resolution'][0]}x{f['resolution'][1]} "
            f"(wall, warm caches)", f["first_image_s"], t["first_image_s"], "s")
    return "\n".join(rows)
