"""Micro benchmarks of the kernels (``python -m ppm_engine bench --micro``).

Each figure is the median of several timed runs after warm-up runs (PoCL compiles a kernel the
first time it is enqueued with a new work-group size), timed with OpenCL profiling events
(device time) unless it says wall.
"""
from __future__ import annotations

import time

import numpy as np

from .bvh import BVH
from .device import get_device
from .options import RenderOptions
from .photon_map import GRID_DTYPE, N_COUNTERS, PhotonMap
from .procedural import MeshBuilder, cornell_box, look_at
from .renderer import Renderer
from .scene_arrays import make_camera

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
    density at 256x256), through the real kernels' buffers."""
    import pyopencl as cl
    from .reference import pack_unit
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
    counters[1] = n
    cbuf = device.upload(counters, "counters")
    vp = np.zeros((n_vp, 4), np.float32)
    vp[:, :2] = rng.uniform(-1, 1, (n_vp, 2))
    vp[:, 3] = 1
    vp_pos = device.upload(vp, "visible points")
    vp_nrm = device.upload(np.tile(np.float32([0, 0, 1, 0]), (n_vp, 1)), "visible points")
    # radius: ~1.5 pixels of a 256x256 view of the 2 m floor
    radius = device.upload(np.full(n_vp, 1.5 * 2.0 / 256, np.float32), "radius")
    gathered = device.buffer(16 * n_vp, "gathered")
    pm.enqueue_grid(q, vp_pos, radius, n_vp)
    q.finish()
    return pm, cbuf, (vp_pos, vp_nrm, radius, gathered)


def hash_and_gather(device, n_photons: int, n_vp: int = 65536, seed=0) -> dict:
    rng = np.random.default_rng(seed)
    pm, counters, (vp_pos, vp_nrm, radius, gathered) = _synthetic_photons(device, n_photons,
                                                                          n_vp, rng)
    q = device.queue
    it = iter(range(10 ** 9))

    def build():
        evs = pm.enqueue_build(q, counters, next(it), 0)
        q.finish()
        return _events_ms([e for _, e in evs])

    def gather():
        evs = pm.enqueue_gather(q, vp_pos, vp_nrm, radius, gathered, n_vp)
        q.finish()
        return _events_ms([e for _, e in evs])

    build_ms = _median(build)
    gather_ms = _median(gather)
    import pyopencl as cl
    c = np.empty(N_COUNTERS, np.uint32)
    cl.enqueue_copy(q, c, counters)
    g = np.empty(1, GRID_DTYPE)
    cl.enqueue_copy(q, g, pm.grid)
    return {"photons": n_photons, "hash_build_ms": build_ms,
            "hash_build_ns_per_photon": build_ms * 1e6 / n_photons,
            "gather_ms": gather_ms, "gather_ns_per_vp": gather_ms * 1e6 / n_vp,
            "visible_points": n_vp, "table_size": pm.table_size,
            "photons_per_entry": n_photons / max(int(c[4]), 1)}


def tracing(device, width=256, photons=1 << 18) -> dict:
    """Eye rays and photons per second in the Cornell box (device time of the passes)."""
    r = Renderer(cornell_box(width, width), RenderOptions(photons_per_pass=photons,
                                                          device=device.info.key))
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


def bvh_build(device, n_tris: int) -> dict:
    mb = MeshBuilder()
    m = mb.material("m")
    seg = int(np.sqrt(n_tris / 2))
    mb.sphere((0, 0, 0), 1.0, m, 2 * seg, max(seg // 2, 2))
    scene = mb.build(camera=make_camera(width=8, height=8, to_world=look_at((0, -3, 0), (0, 0, 0)),
                                        extent=(1, 1)))

    def once():
        t = time.perf_counter()
        BVH(device, scene)
        return (time.perf_counter() - t) * 1e3
    return {"triangles": scene.n_triangles, "bvh_build_ms_wall": _median(once, repeat=3, warmup=1)}


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
        lines.append(f"BVH build {b['triangles']:>9,} triangles: {b['bvh_build_ms_wall']:.1f} ms (wall)")
    return "\n".join(lines)
