"""The bpy scene's lights in LuxCore's units (luxcore_scene.py's docstring has the conversion):
point lights (an emissive icosphere when they have a radius), spots, area lights as emissive
quads or 64-gons; and the emission of emitters enclosed by glass, raised by IOR^2 (LuxCore's
glass is physical, Cycles' sharp glass passes radiance through unscaled)."""
from __future__ import annotations

import math

import numpy as np

from ppm_engine.tools.bench.luxcore_nodes import Translation, Unsupported

SPHERE_SUBDIVISIONS = 3           # a sphere light's icosphere: 1280 triangles, area 0.995 x


def icosphere(subdivisions: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit icosphere: (vertices (V, 3), outward counter-clockwise triangles (F, 3))."""
    t = (1 + 5 ** 0.5) / 2
    v = np.array([(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
                  (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)],
                 np.float64)
    f = np.array([(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9),
                  (5, 11, 4), (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2),
                  (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10),
                  (8, 6, 7), (9, 8, 1)], np.int64)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    for _ in range(subdivisions):
        edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
        unique, inverse = np.unique(edges, axis=0, return_inverse=True)
        mid = v[unique[:, 0]] + v[unique[:, 1]]
        v = np.concatenate([v, mid / np.linalg.norm(mid, axis=1, keepdims=True)])
        ab, bc, ca = (len(v) - len(unique) + inverse.reshape(3, -1))
        a, b, c = f.T
        f = np.concatenate([np.stack(x, axis=1) for x in
                            ((a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca))])
    return v, f


def light_props(tr: Translation, obj, m: np.ndarray, name: str) -> None:
    """A Blender light in LuxCore's units (luxcore_scene.py's docstring)."""
    light = obj.data
    s = (np.array(light.color[:3], np.float64) * light.energy
         * 2.0 ** getattr(light, "exposure", 0.0))
    if getattr(light, "use_temperature", False) and hasattr(light, "temperature_color"):
        s = s * np.array(light.temperature_color[:3], np.float64)
    pos = m[:3, 3].tolist()
    z = -m[:3, 2] / max(np.linalg.norm(m[:3, 2]), 1e-30)          # lights shine along -z
    normalize = getattr(light, "normalize", True)
    prefix = f"scene.lights.{name}"
    if light.type in ('POINT', 'SPOT'):
        r = float(light.shadow_soft_size)
        gain = s * (4 * math.pi * r * r if (r > 0 and not normalize) else 1.0)
        if light.type == 'POINT' and r > 0:
            # an emissive icosphere, not LuxCore's sphere light (biased in BIDIRCPU:
            # luxcore_scene.py's docstring); radiance S / (pi A) makes its power S, as Cycles'
            # sphere
            v, f = icosphere(SPHERE_SUBDIVISIONS)
            p = m[:3, 3] + r * v[f]
            area = 0.5 * float(np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]),
                                              axis=1).sum())
            mat = f"{name}_mat"
            radiance = gain / (math.pi * area)
            tr.set(f"scene.materials.{mat}", type="matte", kd=[0.0, 0.0, 0.0],
                   emission=[1.0, 1.0, 1.0], **{"emission.gain": radiance.tolist()})
            tr.add_mesh(name, p, None, mat,
                        camera_invisible=not getattr(obj, "visible_camera", True))
            tr.emitters.append((p.mean(1), None, mat, [name]))
        elif light.type == 'POINT':
            tr.set(prefix, type="point", position=pos, color=[1.0, 1.0, 1.0],
                   gain=gain.tolist(), power=0.0)
            tr.emitters.append((m[None, :3, 3], f"{prefix}.gain", None, []))
        else:
            half = float(light.spot_size) / 2
            cos_half = math.cos(half)
            start = math.acos(min(cos_half + (1 - cos_half) * float(light.spot_blend), 1.0))
            tr.set(prefix, type="spot", position=pos, target=(m[:3, 3] + z).tolist(),
                   color=[1.0, 1.0, 1.0], gain=(gain / (4 * math.pi)).tolist(), power=0.0,
                   coneangle=math.degrees(half), conedeltaangle=math.degrees(half - start))
            tr.emitters.append((m[None, :3, 3], f"{prefix}.gain", None, []))
        tr.lights += 1
        return
    if light.type == 'AREA':
        if getattr(light, "spread", math.pi) < math.pi - 1e-6:
            raise Unsupported(f"light '{obj.name}': area light spread < 180 degrees")
        sx = float(light.size)
        sy = float(light.size_y) if light.shape in ('RECTANGLE', 'ELLIPSE') else sx
        ax, ay = m[:3, 0] * sx, m[:3, 1] * sy
        ellipse = light.shape in ('DISK', 'ELLIPSE')
        area = float(np.linalg.norm(np.cross(ax, ay))) * (math.pi / 4 if ellipse else 1.0)
        if area <= 0:
            return
        radiance = s / (math.pi * area) if normalize else s / math.pi
        c = m[:3, 3]
        if ellipse:          # a 64-gon of the ellipse's area, fanned from the centre
            k = 64
            a = 2 * math.pi * np.arange(k + 1) / k
            scale = math.sqrt((math.pi / 4) / (0.5 * k * math.sin(2 * math.pi / k)))
            ring = c + scale * (np.cos(a)[:, None] * ax + np.sin(a)[:, None] * ay)
            p = np.stack([np.repeat(c[None], k, 0), ring[:-1], ring[1:]], axis=1)
        else:
            q = [c + 0.5 * (i * ax + j * ay) for i, j in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
            p = np.array([[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        g = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        if float(np.mean(g @ z)) < 0:                    # emit along the light's -z
            p = p[:, [0, 2, 1]]
        mat = f"{name}_mat"
        tr.set(f"scene.materials.{mat}", type="matte", kd=[0.0, 0.0, 0.0],
               emission=[1.0, 1.0, 1.0], **{"emission.gain": radiance.tolist()})
        tr.add_mesh(name, p, None, mat, camera_invisible=not getattr(obj, "visible_camera", True))
        tr.emitters.append((p.mean(1), None, mat, [name]))
        tr.lights += 1
        return
    raise Unsupported(f"light '{obj.name}': {light.type} lights are not translated")


def _closed(tris: np.ndarray) -> bool:
    """Whether a triangle soup (T, 3, 3) is a closed surface: every edge shared by exactly two
    triangles (vertices matched to 1e-6 of the mesh's size)."""
    pts = tris.reshape(-1, 3)
    size = max(float(np.ptp(pts, axis=0).max()), 1e-12)
    _, vid = np.unique(np.round(pts / (1e-6 * size)), axis=0, return_inverse=True)
    vid = vid.reshape(-1, 3)
    edges = np.sort(np.concatenate([vid[:, [0, 1]], vid[:, [1, 2]], vid[:, [2, 0]]]), axis=1)
    _, count = np.unique(edges, axis=0, return_counts=True)
    return bool((count == 2).all())


def inside(points: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Whether each point (N, 3) lies inside the closed triangle mesh ``tris`` (T, 3, 3): the
    parity of a ray's crossings (Moeller-Trumbore), along a direction no axis-aligned face or
    edge contains."""
    d = np.array([0.5253, 0.6177, 0.5851])
    d /= np.linalg.norm(d)
    v0, e1, e2 = tris[:, 0], tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
    pv = np.cross(d, e2)
    det = np.einsum("tk,tk->t", e1, pv)
    ok = np.abs(det) > 1e-300
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    out = np.empty(len(points), bool)
    for a in range(0, len(points), 256):           # (256, T, 3) at a time
        tv = points[a:a + 256, None, :] - v0[None]
        u = np.einsum("ptk,tk->pt", tv, pv) * inv
        qv = np.cross(tv, e1[None])
        v = (qv @ d) * inv
        t = np.einsum("ptk,tk->pt", qv, e2) * inv
        hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
        out[a:a + 256] = hit.sum(1) % 2 == 1
    return out


def enclosed_emission(tr: Translation, camera: np.ndarray) -> None:
    """Emitters inside glass: their emission x IOR^2 per glass mesh that encloses them.

    Light leaving glass of IOR n spreads over n^2 times the solid angle, and LuxCore's glass
    says so: its eye paths carry eta^2 through every refraction and its light paths keep the
    flux (glass.cpp EvalSpecularTransmission), so radiance out of the glass is 1 / n^2 of
    radiance in it.  Cycles' sharp glass (and this engine, its adjoint in the photons:
    kernels/integrator/light_trace.cl) passes radiance through unscaled.  For light from outside
    that enters a closed glass object and leaves it again the two agree; light emitted inside one
    leaves once more than it enters, so LuxCore renders it 1 / n^2 as bright (measured: the
    bulb box's filament in its glass bulb, 0.444 of the light tracer's everywhere).  Raising
    the emission by n^2 puts it back exactly.  An emitter partly inside a glass mesh, or the
    camera inside one, has no such single factor: Unsupported.  Glass meshes that are not
    closed enclose nothing."""
    glass = [g for g in tr.glass if _closed(g[0])]
    if not glass or not tr.emitters:
        return
    for tris, _ior, _name in glass:
        if inside(camera[None], tris)[0]:
            raise Unsupported("the camera is inside a glass object")
    for k, (points, gain_key, mat, objects) in enumerate(tr.emitters):
        factor = 1.0
        for tris, ior, name in glass:
            if name in objects:          # (glass that glows: its own surface)
                continue
            ins = inside(points, tris)
            if ins.all():
                factor *= ior * ior
            elif ins.any():
                raise Unsupported("an emitter lies partly inside a glass object")
        if factor == 1.0:
            continue
        if gain_key is not None:
            tr.props[gain_key] = (np.asarray(tr.props[gain_key]) * factor).tolist()
            continue
        # the emitter's own copy of its material (another object may share it outside glass)
        src, dst = f"scene.materials.{mat}.", f"scene.materials.{mat}_in{k}."
        for key in [key for key in tr.props if key.startswith(src)]:
            tr.props[dst + key[len(src):]] = tr.props[key]
        tr.props[dst + "emission.gain"] = (np.asarray(tr.props[src + "emission.gain"])
                                           * factor).tolist()
        for name in objects:
            tr.objects[name]["material"] = f"{mat}_in{k}"
