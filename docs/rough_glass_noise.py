"""Light seen through rough glass against Cycles (docs/BENCHMARKS.md, "Rough glass"): a row of
six Principled glass cubes (transmission 1, roughness 0.0, 0.2, ..., 1.0) before a checkered
diffuse wall, an area light in front of them, Cycles' grey world; every other setting Blender's
default (Cycles' Light Paths: Clamp Indirect 10, Filter Glossy 1), 192 x 64 pixels.

    python docs/rough_glass_noise.py [SECONDS] [SEEDS] [REFERENCE_SAMPLES]
    python docs/rough_glass_noise.py 8 3 8192

Printed, per cube (the pixels inside its outline) and for the rest of the image:
- noise per sample: the standard deviation of a pixel over SEEDS renders of 128 samples (our
  passes, Cycles' samples), RMS over the region, ours over Cycles';
- the cost of a sample (wall and CPU milliseconds, from renders of 32 and 288 samples);
- at equal time: each engine renders SECONDS (time limit), seeds alternating between them, and
  the RMSE against a Cycles reference of REFERENCE_SAMPLES samples (kept in the temporary
  folder), relative to the region's mean; and the share of 8 x 8 blocks within 10 % of the
  reference.
Run it alone on the machine: the engines are timed one after the other."""
import math
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROUGH = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)
W, H = 192, 64


def build():
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=12, location=(0, 1.2, 0), rotation=(math.pi / 2, 0, 0))
    wall = bpy.data.materials.new("Wall")
    bpy.context.active_object.data.materials.append(wall)
    t = wall.node_tree
    p = t.nodes["Principled BSDF"]
    chk = t.nodes.new("ShaderNodeTexChecker")
    chk.inputs["Scale"].default_value = 80.0
    chk.inputs["Color1"].default_value = (0.9, 0.9, 0.9, 1)
    chk.inputs["Color2"].default_value = (0.03, 0.03, 0.03, 1)
    t.links.new(chk.outputs["Color"], p.inputs["Base Color"])
    p.inputs["Roughness"].default_value = 1.0
    cubes = []
    for i, r in enumerate(ROUGH):
        bpy.ops.mesh.primitive_cube_add(size=0.4, location=((i - 2.5) * 0.6, 0, 0),
                                        rotation=(0.3, 0.4, 0.0))
        cubes.append(bpy.context.active_object)
        g = bpy.data.materials.new(f"Glass{i}")
        bpy.context.active_object.data.materials.append(g)
        pg = g.node_tree.nodes["Principled BSDF"]
        pg.inputs["Transmission Weight"].default_value = 1.0
        pg.inputs["Roughness"].default_value = r
    lamp = bpy.data.lights.new("Area", "AREA")
    lamp.energy, lamp.size = 150.0, 1.0
    obj = bpy.data.objects.new("Area", lamp)
    obj.location = (0.5, -2.5, 2.0)
    obj.rotation_euler = (math.radians(50), 0, math.radians(10))
    scene.collection.objects.link(obj)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    cam.location, cam.rotation_euler = (0.0, -6.0, 0.0), (math.pi / 2, 0.0, 0.0)
    scene.world = bpy.data.worlds.new("World")           # Cycles' default grey (0.05)
    scene.render.resolution_x, scene.render.resolution_y = W, H
    scene.render.resolution_percentage = 100
    scene.render.dither_intensity = 0.0
    bpy.context.view_layer.update()
    return scene, cubes


def regions(scene, cubes):
    """Per cube the pixels (rows top-down) whose centre lies inside its outline, and the rest."""
    from bpy_extras.object_utils import world_to_camera_view
    yy, xx = np.mgrid[0:H, 0:W]
    px, py = (xx + 0.5) / W, 1.0 - (yy + 0.5) / H
    out = []
    for o in cubes:
        pts = sorted(tuple(world_to_camera_view(scene, scene.camera, o.matrix_world @ v.co))[:2]
                     for v in o.data.vertices)

        def cross(a, b, c):
            return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        hull = []
        for seq in (pts, pts[::-1]):                    # Andrew's monotone chain
            half = []
            for q in seq:
                while len(half) >= 2 and cross(half[-2], half[-1], q) <= 0:
                    half.pop()
                half.append(q)
            hull += half[:-1]
        inside = np.ones_like(px, bool)
        for k in range(len(hull)):
            a, b = hull[k], hull[(k + 1) % len(hull)]
            inside &= (b[0] - a[0]) * (py - a[1]) - (b[1] - a[1]) * (px - a[0]) >= 0
        out.append(inside)
    return out + [~np.any(out, axis=0)]


def cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def render(scene, engine, path, *, samples=0, seconds=0.0, seed=1):
    """(image, wall s, CPU s) of one render: Cycles (CPU, no adaptive sampling, no denoising)
    or ours, ``samples`` per pixel or ``seconds``."""
    import bpy

    from ppm_engine.blender.harness import read_exr, set_output
    if scene.render.engine != engine:
        scene.render.engine = engine
    if engine == "CYCLES":
        c = scene.cycles
        c.device, c.use_adaptive_sampling, c.use_denoising, c.seed = "CPU", False, False, seed
        c.samples, c.time_limit = (samples, 0.0) if samples else (1 << 24, seconds)
    else:
        s = scene.ppm
        s.seed = seed
        s.passes, s.time_limit = (samples, 0.0) if samples else (1_000_000, seconds)
    scene.render.resolution_x, scene.render.resolution_y = W, H
    set_output(scene, path)
    t, c0 = time.perf_counter(), cpu()
    bpy.ops.render.render(write_still=True)
    wall, used = time.perf_counter() - t, cpu() - c0
    return read_exr(path)[..., :3].astype(np.float64), wall, used


def main(seconds: float, seeds: int, ref_samples: int) -> None:
    from ppm_engine.blender.harness import ensure_registered
    ensure_registered()
    scene, cubes = build()
    masks = regions(scene, cubes)
    names = [f"r {r:.1f}" for r in ROUGH] + ["rest"]
    tmp = Path(tempfile.gettempdir())
    ref_path = tmp / f"rough_glass_ref_{ref_samples}.npy"
    if not ref_path.exists():
        ref, wall, _ = render(scene, "CYCLES", tmp / "rough_glass_ref.exr", samples=ref_samples,
                              seed=99)
        print(f"reference: Cycles, {ref_samples} samples, {wall:.0f} s")
        np.save(ref_path, ref)
    ref = np.load(ref_path)
    render(scene, "PPM", tmp / "rough_glass_warm.exr", samples=2)    # (its kernels built)

    def row(label, values, fmt="{:.3f}"):
        print(f"{label:34s}" + " ".join(f"{fmt.format(v):>7s}" for v in values))
    print(f"{'':34s}" + " ".join(f"{n:>7s}" for n in names))
    # noise per sample
    noise = {}
    for engine in ("CYCLES", "PPM"):
        imgs = [render(scene, engine, tmp / "rough_glass.exr", samples=128, seed=s)[0].mean(-1)
                for s in range(1, seeds + 1)]
        var = np.var(imgs, axis=0, ddof=1)
        noise[engine] = np.array([np.sqrt(var[m].mean()) / ref[m].mean() for m in masks])
        row(f"{engine} noise, 128 samples (rel.)", noise[engine])
    row("noise per sample ours / Cycles", noise["PPM"] / noise["CYCLES"])
    # the cost of a sample
    cost = {}
    for engine in ("CYCLES", "PPM"):
        lo = render(scene, engine, tmp / "rough_glass.exr", samples=32)
        hi = render(scene, engine, tmp / "rough_glass.exr", samples=288)
        cost[engine] = ((hi[1] - lo[1]) / 256 * 1e3, (hi[2] - lo[2]) / 256 * 1e3)
        print(f"{engine} ms per sample: wall {cost[engine][0]:.1f}, CPU {cost[engine][1]:.1f}")
    # equal time
    rmse = {e: [] for e in ("CYCLES", "PPM")}
    ok = {e: [] for e in ("CYCLES", "PPM")}
    rb = ref.reshape(H // 8, 8, W // 8, 8, 3).mean(axis=(1, 3))
    for seed in range(1, seeds + 1):
        for engine in ("CYCLES", "PPM"):
            img = render(scene, engine, tmp / "rough_glass.exr", seconds=seconds, seed=seed)[0]
            rmse[engine].append([np.sqrt(((img[m] - ref[m]) ** 2).mean()) / ref[m].mean()
                                 for m in masks])
            b = img.reshape(H // 8, 8, W // 8, 8, 3).mean(axis=(1, 3))
            ok[engine].append((np.abs(b - rb) <= 0.1 * rb).all(axis=-1).mean())
    for engine in ("CYCLES", "PPM"):
        row(f"{engine} RMSE at {seconds:g} s (rel.)", np.mean(rmse[engine], axis=0))
        print(f"{engine} blocks within 10 %: {np.mean(ok[engine]):.3f}")
    row(f"RMSE at {seconds:g} s ours / Cycles",
        np.mean(rmse["PPM"], axis=0) / np.mean(rmse["CYCLES"], axis=0))


if __name__ == "__main__":
    a = sys.argv[1:]
    main(float(a[0]) if a else 8.0, int(a[1]) if len(a) > 1 else 3,
         int(a[2]) if len(a) > 2 else 8192)
