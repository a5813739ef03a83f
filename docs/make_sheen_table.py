"""Measure the sheen table (ppm_engine/scene/shading_tables.py, "sheen") from Cycles' own renders.

Cycles' Sheen BSDF (Microfiber; the Principled BSDF's sheen) is Zeltner, Burley & Chiang 2022's
linearly transformed cosine: for a view at cos mu and a roughness r it is the cosine lobe
transformed by a(mu, r) and b(mu, r), scaled by an albedo(mu, r), the three read from a 32 x 32
table with linear interpolation.  Cycles fits that table to a volumetric fibre model that has
no closed form, so this script measures it from Cycles' renders (in the bpy module the tests
use), which are exact for it:

- albedo: flat quads of the Sheen BSDF, seen orthographically at cos mu, under a white world
  that only the BSDF sample can find (world light sampling off): every camera sample carries
  exactly the albedo (the LTC is sampled exactly, eval / pdf = 1);
- a, b: the same quads lit only by a sun without size (direct light only), from three
  directions: each pixel is albedo x the LTC's value for the sun's direction, solved for a, b.

The quads are placed at the table's nodes (cos mu = i / 31, roughness j / 31), where the table's
interpolation returns its entries unchanged; the two node values no quad can show (cos mu = 0:
a quad seen edge-on; roughness 0: Cycles clamps it to 1e-3) are solved from the values half a
cell, and 1e-3 / (1/31) of a cell, inside, which interpolate linearly between the nodes.

Run: python docs/make_sheen_table.py   (writes the sheen table into the package data)
"""
from __future__ import annotations

import math
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

N = 32
SUNS = [np.array(v, float) / np.linalg.norm(v) for v in
        ((0.0, -1.0, 1.0), (0.8, -0.6, 0.6), (0.0, -math.sin(1.35), math.cos(1.35)))]
WIDTH, GAP, HEIGHT = 1.0, 0.5, 40.0          # quad size and spacing, scene units
R_MIN = 1e-3                                  # Cycles clamps the sheen roughness to this


def _mu_values():
    mu = np.arange(N) / (N - 1)
    mu[0] = 0.5 / (N - 1)
    return mu


def _scene(roughness: float, sun=None):
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    c = scene.cycles
    c.device = "CPU"
    c.samples = 1
    c.use_adaptive_sampling = c.use_denoising = False
    c.pixel_filter_type = "BOX"
    c.filter_width = 0.01
    c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
    c.blur_glossy = 0.0
    c.max_bounces = c.diffuse_bounces = c.glossy_bounces = 0 if sun is not None else 1
    world = bpy.data.worlds.new("w")
    scene.world = world
    world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (1, 1, 1, 1)
    bg.inputs["Strength"].default_value = 0.0 if sun is not None else 1.0
    world.cycles.sampling_method = "NONE"       # the white world: only the BSDF sample finds it
    mat = bpy.data.materials.new("sheen")
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    sh = nt.nodes.new("ShaderNodeBsdfSheen")
    sh.distribution = "MICROFIBER"
    sh.inputs["Color"].default_value = (1, 1, 1, 1)
    sh.inputs["Roughness"].default_value = roughness
    nt.links.new(sh.outputs[0], out.inputs["Surface"])
    mus = _mu_values()
    total = N * WIDTH + (N - 1) * GAP
    for i, mu in enumerate(mus):
        theta = math.acos(mu)
        bpy.ops.mesh.primitive_plane_add(size=1.0)
        q = bpy.context.active_object
        q.scale = (WIDTH, HEIGHT, 1.0)
        q.location = (-total / 2 + WIDTH / 2 + i * (WIDTH + GAP), 0.0, 0.0)
        q.rotation_euler = (theta, 0.0, 0.0)          # normal (0, -sin, cos): tilted towards -y
        q.data.materials.append(mat)
        for flag in ("visible_diffuse", "visible_glossy", "visible_transmission",
                     "visible_volume_scatter", "visible_shadow"):
            setattr(q, flag, False)
    cam = bpy.data.cameras.new("cam")
    cam.type = "ORTHO"
    cam.ortho_scale = total + 2.0
    co = bpy.data.objects.new("cam", cam)
    co.location = (0.0, 0.0, 50.0)
    scene.collection.objects.link(co)
    scene.camera = co
    scene.render.resolution_x, scene.render.resolution_y = 1600, 1000
    scene.render.resolution_percentage = 100
    if sun is not None:
        ld = bpy.data.lights.new("sun", "SUN")
        ld.energy = 1.0
        ld.angle = 0.0
        lo = bpy.data.objects.new("sun", ld)
        # the light shines along its -Z: point -Z away from the sun direction
        from mathutils import Vector
        lo.rotation_euler = Vector(tuple(-sun)).to_track_quat("-Z", "Y").to_euler()
        scene.collection.objects.link(lo)
    return scene, total


def _render(roughness: float, sun=None) -> np.ndarray:
    """The value seen at the centre of each quad (N,)."""
    import bpy

    from ppm_engine.blender.harness import read_exr, set_output
    scene, total = _scene(roughness, sun)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "s.exr"
        set_output(scene, path)
        bpy.ops.render.render(write_still=True)
        img = read_exr(path)[..., 0]                  # rows top-down
    h, w = img.shape
    scale = total + 2.0                               # horizontal extent in scene units
    vals = np.empty(N)
    for i in range(N):
        x = -total / 2 + WIDTH / 2 + i * (WIDTH + GAP)
        col = int((x / scale + 0.5) * w)
        block = img[h // 2 - 1:h // 2 + 2, col - 1:col + 2]
        if np.ptp(block) > 1e-4 * max(abs(block).max(), 1e-30):
            raise RuntimeError(f"quad {i} is not uniform at its centre: {block}")
        vals[i] = block[1, 1]
    return vals


def _frames():
    """Each quad's LTC frame (T towards the view, B, N) in world space."""
    frames = []
    view = np.array([0.0, 0.0, 1.0])
    for mu in _mu_values():
        th = math.acos(mu)
        n = np.array([0.0, -math.sin(th), math.cos(th)])
        b = np.cross(n, view)
        b = b / np.linalg.norm(b) if np.linalg.norm(b) > 1e-9 else np.array([1.0, 0, 0])
        t = np.cross(b, n)
        frames.append((t, b, n))
    return frames


def _ltc(a, b, lo):
    l2 = (a * lo[0] + b * lo[2]) ** 2 + (a * lo[1]) ** 2 + lo[2] ** 2
    return max(lo[2], 0.0) * (a / l2) ** 2 / math.pi


def _fit(values, locals_) -> tuple[float, float]:
    """(a, b) with _ltc(a, b, lo_k) = values_k, in relative terms (Gauss-Newton from starting
    points over the range of a: a small a is a lobe folded towards grazing)."""
    def resid(a, b):
        return np.array([_ltc(a, b, lo) / v - 1 for lo, v in zip(locals_, values)])
    best, best_err = (1.0, 0.0), float("inf")
    for a0 in np.geomspace(0.003, 10, 12):
        for b0 in (-1.0, -0.1, 0.0, 0.1, 1.0):
            a, b = a0, b0
            for _ in range(200):
                r = resid(a, b)
                e = 1e-7 * max(abs(a), 1e-3)
                J = np.stack([(resid(a + e, b) - resid(a - e, b)) / (2 * e),
                              (resid(a, b + e) - resid(a, b - e)) / (2 * e)], 1)
                step = np.linalg.lstsq(J, -r, rcond=None)[0]
                a, b = a + step[0], b + step[1]
                if not np.isfinite([a, b]).all() or np.abs(step).max() < 1e-12:
                    break
            err = float((resid(a, b) ** 2).sum()) if np.isfinite([a, b]).all() else np.inf
            if err < best_err:
                best, best_err = (a, b), err
    return best


def measure() -> np.ndarray:
    """(3, 32, 32): a, b, albedo as [rough][mu], at the sampled positions (not yet solved for
    the edge nodes)."""
    frames = _frames()
    out = np.zeros((3, N, N))
    for j in range(N):
        r = max(j / (N - 1), R_MIN)
        albedo = _render(r)
        lit = [_render(r, s) for s in SUNS]
        for i, (t, b, n) in enumerate(frames):
            out[2, j, i] = albedo[i]
            if albedo[i] < 1e-5:
                continue
            locs = [np.array([s @ t, s @ b, s @ n]) for s in SUNS]
            vals = [lit[k][i] / albedo[i] for k in range(len(SUNS))]
            a, b = _fit(vals, locs)
            # (a, b) and (-a, -b) give the same values; Cycles samples the lobe with a > 0
            out[0, j, i], out[1, j, i] = (a, b) if a > 0 else (-a, -b)
        print(f"roughness {r:.4f}: albedo {albedo.min():.4f}..{albedo.max():.4f}", flush=True)
    return out


def solve_edges(m: np.ndarray) -> np.ndarray:
    """Node values from the measured ones: cos mu = 0 from half a cell in (it interpolates
    linearly between two nodes); the albedo at roughness 0 likewise from R_MIN (there is
    nearly no sheen there: clamped at 0).  Where the albedo is below 1e-4 the lobe's a and b
    shape nothing visible and cannot be fitted (values of ~1e-6): they are those of the next
    cell up in cos mu (or roughness), so that the table's interpolation stays smooth."""
    t = R_MIN * (N - 1)                               # position of R_MIN in cells
    fit = m[2] >= 1e-4
    out = m.copy()
    for j in range(N - 1, -1, -1):                    # a, b where they could not be fitted
        for i in range(N - 1, -1, -1):
            if not fit[j, i]:
                src = (j, i + 1) if i + 1 < N and fit[j, i + 1] else (
                    (j + 1, i) if j + 1 < N and fit[j + 1, i] else None)
                if src is not None:
                    out[:2, j, i] = out[:2, src[0], src[1]]
                    fit[j, i] = True
    ab = out[:2].copy()
    ok = m[2, 1:, 0] >= 1e-4
    ab[:, 1:, 0] = np.where(ok, 2 * out[:2, 1:, 0] - out[:2, 1:, 1], out[:2, 1:, 1])
    out[:2] = ab
    out[2, 1:, 0] = np.maximum(2 * m[2, 1:, 0] - m[2, 1:, 1], 0.0)
    out[2, 0, 1:] = (m[2, 0, 1:] - t * m[2, 1, 1:]) / (1 - t)
    # the corner: bilinear weights (1-t)/2, t/2 on (r0, mu0/mu1), (r1, mu0/mu1)
    w00, w01, w10, w11 = (1 - t) / 2, (1 - t) / 2, t / 2, t / 2
    out[2, 0, 0] = (m[2, 0, 0] - w01 * out[2, 0, 1] - w10 * out[2, 1, 0]
                    - w11 * out[2, 1, 1]) / w00
    out[2, 0] = np.maximum(out[2, 0], 0.0)
    out[:2, 0] = out[:2, 1]
    return out


def main():
    from ppm_engine.scene import shading_tables as st
    raw = measure()
    np.save(Path(tempfile.gettempdir()) / "sheen_measured.npy", raw)
    table = solve_edges(raw)
    tables = st.unpack(st.load()) if st.DATA.is_file() else {}
    tables = {k: np.array(v) for k, v in tables.items()}
    tables["sheen"] = table.astype(np.float32)
    np.savez_compressed(st.DATA, **tables)
    print(f"wrote the sheen table into {st.DATA}")


if __name__ == "__main__":
    main()
