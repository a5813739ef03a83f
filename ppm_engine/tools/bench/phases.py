"""``python -m ppm_engine bench --phases SCENE``: where a pass spends its time, per phase (the
timing labels of the pass objects, ppm_engine/render/passes)."""
from __future__ import annotations

import numpy as np


def run_phases(scene_name: str, resolution: int = 256, passes: int = 8, warmup: int = 3,
               device: str = "", photons: int | None = None, progress=print,
               light_tracing: bool = True) -> dict:
    """Mean device time per phase of a pass (after ``warmup`` passes) for an example scene,
    exported from bpy and run through the Renderer directly, and the device memory the render
    allocated (its scene, film, visible points, photon map and passes: Device.allocated's
    growth over the render).  ``light_tracing``: RenderOptions.light_tracing."""
    import bpy

    from ppm_engine.blender.export import export_scene
    from ppm_engine.blender.scenes import build_example
    from ppm_engine.render.options import RenderOptions
    from ppm_engine.render.renderer import Renderer
    scene = build_example(scene_name)
    scene.render.resolution_x = scene.render.resolution_y = resolution
    scene.render.resolution_percentage = 100
    depsgraph = bpy.context.evaluated_depsgraph_get()
    arrays = export_scene(depsgraph)
    opts = RenderOptions(device=device, photons_per_pass=photons or None,
                         light_tracing=light_tracing)
    from ppm_engine.render.device import get_device
    dev = get_device(device)
    before = dev.allocated
    r = Renderer(arrays, opts)
    progress(f"phases: {scene_name} {resolution}x{resolution}, {r.photons_per_pass} photons "
             f"per pass, {warmup} warm-up + {passes} timed passes on {r.device.info.name}")
    for _ in range(warmup):
        r.iterate()
    rows = [r.iterate() for _ in range(passes)]
    allocated = dev.allocated - before
    light_traced = r.lt_kappa > 0
    r.close()
    labels = ["eye", "filter", "grid", "photon", "hash", "gather", "update", "adaptive"]
    mean = {k: float(np.mean([s.phase_ms.get(k, 0.0) for s in rows])) for k in labels
            if any(k in s.phase_ms for s in rows)}
    total = sum(mean.values())
    return {"scene": scene_name, "resolution": resolution, "passes": passes, "warmup": warmup,
            "photons_per_pass": r.photons_per_pass, "device": r.device.info.name,
            "phase_ms": mean, "device_ms": total, "device_bytes": allocated,
            "light_tracing": light_traced,
            "wall_ms": float(np.mean([s.seconds for s in rows]) * 1e3),
            "photons_stored": float(np.mean([s.photons_stored for s in rows])),
            "photons_per_entry": float(np.mean([s.photons_per_entry for s in rows])),
            "visible_points": float(np.mean([s.visible_points for s in rows]))}


def format_phases(p: dict) -> str:
    lines = [f"{p['scene']} {p['resolution']}x{p['resolution']}, {p['photons_per_pass']} photons "
             f"per pass, mean of {p['passes']} passes after {p['warmup']} warm-up "
             f"({p['device']})",
             "| phase | ms | share |", "|---|---:|---:|"]
    for k, v in p["phase_ms"].items():
        lines.append(f"| {k} | {v:.2f} | {100 * v / p['device_ms']:.1f} % |")
    lines.append(f"| all (device) | {p['device_ms']:.2f} | 100 % |")
    lines.append(f"| pass (wall) | {p['wall_ms']:.2f} | |")
    if "device_bytes" in p:
        lines.append(f"\ndevice memory allocated by the render: {p['device_bytes'] / 2**20:.1f} "
                     f"MiB; light tracing {'on' if p['light_tracing'] else 'off'}")
    lines.append(f"\nvisible points {p['visible_points']:.0f}, photons stored "
                 f"{p['photons_stored']:.0f}, photons per occupied entry "
                 f"{p['photons_per_entry']:.2f}")
    return "\n".join(lines)
