"""The bpy scene as LuxCoreRender scene properties and meshes, for the benchmark's LuxCore
curve (luxcore.py renders them in a process of its own).  The scene is translated from bpy,
not written per scene, and only where the translation is exact (anything else raises
``Unsupported``):

- meshes: every visible geometry instance of the evaluated depsgraph (objects hidden in render
  or not shown are skipped), triangulated (loop triangles), in world space (matrix_world;
  normals by its inverse transpose, the winding reversed by a mirroring matrix), with the corner
  normals (smooth shading as Cycles interpolates it); one LuxCore object per material slot;
  ``visible_camera`` off -> ``camerainvisible``.
- materials (node values only, nothing linked): Diffuse BSDF (roughness 0) and the Lambertian
  Principled (metallic 0, transmission 0, Specular IOR Level 0) -> ``matte`` kd = base colour;
  Principled metallic 1 roughness 0 and Glossy BSDF roughness 0 -> ``mirror`` kr = colour
  (exact for white, as the benchmark's mirror: Cycles' F82 metal is then 1 at every angle);
  Principled transmission 1 roughness 0 (Specular IOR Level 0.5) -> ``glass`` kt = base colour,
  kr = specular tint, interior IOR = IOR; Glass BSDF roughness 0 -> ``glass`` kr = kt = colour;
  Emission -> ``matte`` kd 0 with ``emission`` = colour, ``emission.gain`` = strength (also a
  Principled's emission).  No material: Cycles' default grey (0.8) diffuse.
- lights: point (an emissive icosphere when it has a radius), spot, rectangular/elliptic area
  lights; the world's constant background.  Sun lights are refused.
- camera: perspective; Blender's view frame (sensor fit, pixel aspect, shift) at unit depth
  becomes LuxCore's screen window (``camera_props``; LuxCore's field of view spans the frame's
  *longer* side), moved down one pixel (LuxCore's film sits one row high); clipping, depth of
  field.
- film: Cycles' pixel filter (``scene.cycles.pixel_filter_type`` / ``filter_width``; Cycles'
  defaults, Blackman-Harris 1.5 px, without Cycles), no tone mapping, Cycles' film exposure.

Units (the conversion, derived from both renderers' sources, not fitted):

- Cycles' point light of power P (colour c, exposure e: S = c P 2^e) has radiant intensity
  S / (4 pi) W/sr in every direction (ppm_engine/blender/export/lights.py, as Cycles); with a radius
  r it is a sphere of radiance L = S / (4 pi * pi r^2), power S.  LuxCore's point light with
  ``power`` 0 (so ``efficency`` and ``normalizebycolor`` play no part) has emittedFactor =
  gain x color and intensity emittedFactor / (4 pi) (pointlight.cpp Illuminate/Emit): so
  **gain = S, color = 1** -- the same number as Blender's Watts.  With a radius, not LuxCore's
  ``sphere`` light (same units, spherelight.cpp: L = emittedFactor / (4 pi r^2 pi)): BIDIRCPU
  renders it 30 % too bright (its MIS pdfs disagree; PATHCPU and LIGHTCPU agree with its point
  light), so an emissive icosphere (1280 triangles) of radiance S / (pi A_mesh), power S.
  (Without "normalize" Cycles' sphere keeps L = S / pi: S x 4 pi r^2 in place of S.)
- LuxCore's spot light, unlike its point light, has intensity gain x falloff(theta) /
  cos(theta) (spotlight.cpp Illuminate: emittedFactor x falloff / |cos| at directPdfW = d^2): so
  **gain = S / (4 pi)** on the axis.  Its falloff (((cos - cos_max) / (cos_start - cos_max))^4)
  is not Cycles' smoothstep, the 1 / cos has no Cycles counterpart (+3.5 % at 15 degrees off
  the axis) and it has no radius: the cone's edge angles are matched, the rest is approximate
  (glass_caustic: the mean over the light tracer's pixels 1.2 % under it).
- Emission (mesh lights): Cycles' Emission strength is the radiance itself (Strength 1 = 1
  W/(m^2 sr)); LuxCore's material emission with power 0 is colour x gain (material.cpp
  GetEmittedRadiance): **emission = colour, gain = strength**.  Cycles' mesh lights emit from
  both sides and LuxCore's from the front only, so every emissive triangle gets a reversed
  twin a hair (1e-5 of the mesh's size) behind it.
- Cycles' area light of power P, area A: L = S / (pi A) from its front (S / pi without
  "normalize"): an emissive quad (or 64-gon of the same area for disk/ellipse) with that
  radiance.  Unlike Cycles', it blocks light from behind.
- World: the Background's colour x strength is the radiance of LuxCore's ``constantinfinite``
  light (gain x color).
- Emitters inside glass: LuxCore's glass is physical (radiance leaving glass of IOR n is 1 / n^2
  of what it was inside), Cycles' sharp glass passes radiance through unscaled: an emitter
  enclosed by a closed glass mesh gets its emission x n^2 (``enclosed_emission``: exact, the
  bulb box's filament; without it LuxCore renders that room 0.444 as bright).
- Smooth-shaded emitters: LuxCore emits about the shading normal, Cycles the same radiance
  every way from the surface: a black emitter (Emission) goes flat (its normals only steer its
  emission: the bulb box's filament was 0.12 % dim with them); one that also reflects is
  refused.
"""
from __future__ import annotations

import math

import numpy as np

DEFAULT_GREY = (0.8, 0.8, 0.8)    # Cycles' surface without a material
SPHERE_SUBDIVISIONS = 3           # a sphere light's icosphere: 1280 triangles, area 0.995 x
EPS = 1e-6


class Unsupported(ValueError):
    """Something in the scene has no exact LuxCore counterpart in this translation."""


class Translation:
    """LuxCore scene properties (name -> value) and meshes (name -> vertices, triangles,
    normals) of one bpy scene."""

    def __init__(self):
        self.props: dict[str, object] = {}
        self.meshes: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray | None]] = {}
        self.objects: dict[str, dict] = {}
        self.lights = 0
        # for enclosed_emission: each emitter's points (N, 3) with the property holding its
        # gain (a light's) or its material and objects (a mesh's); each glass mesh and its IOR
        self.emitters: list[tuple[np.ndarray, str | None, str | None, list[str]]] = []
        self.glass: list[tuple[np.ndarray, float, str]] = []

    def set(self, prefix: str, **values) -> None:
        for k, v in values.items():
            self.props[f"{prefix}.{k}"] = v

    def add_mesh(self, name, positions, normals, material, camera_invisible=False):
        """``positions`` / ``normals`` (T, 3, 3) world space: one LuxCore object."""
        t = positions.shape[0]
        self.meshes[name] = (positions.reshape(-1, 3), np.arange(3 * t).reshape(t, 3),
                             None if normals is None else normals.reshape(-1, 3))
        self.objects[name] = {"shape": name, "material": material,
                              "camerainvisible": bool(camera_invisible)}


def _rgb(v) -> list[float]:
    return [float(x) for x in tuple(v)[:3]]


def _input(node, name, default=None):
    """A node input's value (colours as RGB); a linked input has no constant value."""
    sock = node.inputs.get(name)
    if sock is None:
        if default is None:
            raise Unsupported(f"node '{node.name}' has no input '{name}'")
        return default
    if sock.is_linked:
        raise Unsupported(f"node '{node.name}': input '{name}' is linked (only constant values "
                          "translate)")
    v = sock.default_value
    try:
        return _rgb(v) if len(v) >= 3 else [float(x) for x in v]
    except TypeError:
        return float(v)


def material_props(mat) -> tuple[dict, list[float] | None]:
    """(LuxCore material properties without the prefix, emitted radiance RGB or None)."""
    if mat is None or mat.node_tree is None:
        return {"type": "matte", "kd": list(DEFAULT_GREY) if mat is None
                else _rgb(mat.diffuse_color)}, None
    out = mat.node_tree.get_output_node('CYCLES')
    surf = out.inputs["Surface"] if out is not None else None
    if surf is None or not surf.is_linked:
        return {"type": "matte", "kd": [0.0, 0.0, 0.0]}, None     # Cycles: black
    node = surf.links[0].from_node
    kind = node.bl_idname
    emission = None
    if kind == "ShaderNodeEmission":
        c, s = np.array(_input(node, "Color")), _input(node, "Strength")
        return {"type": "matte", "kd": [0.0, 0.0, 0.0]}, (c * s).tolist()
    if kind == "ShaderNodeBsdfDiffuse":
        if _input(node, "Roughness") > EPS:
            raise Unsupported(f"material '{mat.name}': Oren-Nayar diffuse (roughness > 0)")
        return {"type": "matte", "kd": _input(node, "Color")}, None
    if kind == "ShaderNodeBsdfGlossy":
        if _input(node, "Roughness") > EPS:
            raise Unsupported(f"material '{mat.name}': rough glossy")
        return {"type": "mirror", "kr": _input(node, "Color")}, None
    if kind == "ShaderNodeBsdfGlass":
        if _input(node, "Roughness") > EPS:
            raise Unsupported(f"material '{mat.name}': rough glass")
        c = _input(node, "Color")
        return {"type": "glass", "kr": c, "kt": c, "interiorior": _input(node, "IOR"),
                "exteriorior": 1.0, "cauchyb": 0.0}, None
    if kind != "ShaderNodeBsdfPrincipled":
        raise Unsupported(f"material '{mat.name}': {kind} is not translated")
    g = lambda name, default=None: _input(node, name, default)
    strength = g("Emission Strength", 0.0)
    if strength > 0:
        emission = (np.array(g("Emission Color")) * strength).tolist()
    for layer in ("Coat Weight", "Sheen Weight", "Subsurface Weight"):
        if g(layer, 0.0) > EPS:
            raise Unsupported(f"material '{mat.name}': Principled {layer} > 0")
    if g("Alpha", 1.0) < 1 - EPS:
        raise Unsupported(f"material '{mat.name}': Principled alpha < 1")
    base, metallic, rough = g("Base Color"), g("Metallic"), g("Roughness")
    trans = g("Transmission Weight", 0.0)
    if metallic >= 1 - EPS and rough <= EPS:
        return {"type": "mirror", "kr": base}, emission
    if metallic <= EPS and trans >= 1 - EPS and rough <= EPS:
        if abs(g("Specular IOR Level", 0.5) - 0.5) > EPS:
            raise Unsupported(f"material '{mat.name}': glass with Specular IOR Level != 0.5")
        return {"type": "glass", "kr": g("Specular Tint", [1.0, 1.0, 1.0]), "kt": base,
                "interiorior": g("IOR"), "exteriorior": 1.0, "cauchyb": 0.0}, emission
    if metallic <= EPS and trans <= EPS and g("Specular IOR Level", 0.5) <= EPS:
        return {"type": "matte", "kd": base}, emission
    raise Unsupported(f"material '{mat.name}': Principled metallic {metallic:g}, transmission "
                      f"{trans:g}, roughness {rough:g}, Specular IOR Level "
                      f"{g('Specular IOR Level', 0.5):g} has no exact LuxCore counterpart here")


def mesh_arrays(obj, m: np.ndarray):
    """World-space triangle soup of an evaluated object: (positions (T, 3, 3), corner normals
    (T, 3, 3), material slot (T,)), or None without triangles."""
    try:
        me = obj.to_mesh()
    except RuntimeError:
        return None
    try:
        if me is None:
            return None
        me.calc_loop_triangles()
        t = len(me.loop_triangles)
        if t == 0:
            return None
        co = np.empty(3 * len(me.vertices), np.float64)
        me.vertices.foreach_get("co", co)
        tv = np.empty(3 * t, np.int64)
        me.loop_triangles.foreach_get("vertices", tv)
        tl = np.empty(3 * t, np.int64)
        me.loop_triangles.foreach_get("loops", tl)
        slot = np.empty(t, np.int64)
        me.loop_triangles.foreach_get("material_index", slot)
        cn = np.empty(3 * len(me.loops), np.float64)
        me.corner_normals.foreach_get("vector", cn)
    finally:
        obj.to_mesh_clear()
    m3 = m[:3, :3]
    p = (co.reshape(-1, 3)[tv] @ m3.T + m[:3, 3]).reshape(t, 3, 3)
    n = cn.reshape(-1, 3)[tl] @ np.linalg.inv(m3)        # rows: (M^-T n)^T = n^T M^-1
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
    n = n.reshape(t, 3, 3)
    if np.linalg.det(m3) < 0:                            # mirrored: keep the winding's side
        p, n = p[:, [0, 2, 1]], n[:, [0, 2, 1]]
    return p, n, slot


def _emissive_twin(p, n):
    """Reversed copies a hair behind each triangle: LuxCore's mesh lights emit from the
    front only, Cycles' from both sides."""
    size = float(np.linalg.norm(p.reshape(-1, 3).max(0) - p.reshape(-1, 3).min(0)))
    g = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    g /= np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-30)
    return ((p - 1e-5 * max(size, 1e-3) * g[:, None, :])[:, [0, 2, 1]],
            None if n is None else -n[:, [0, 2, 1]])


def _flat(p, n) -> bool:
    """Whether the corner normals (T, 3, 3) are the triangles' own (flat shading)."""
    g = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    g /= np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-30)
    return bool((np.einsum("tck,tk->tc", n, g) > 1 - 1e-6).all())


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
    """A Blender light in LuxCore's units (see the module docstring)."""
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
            # an emissive icosphere, not LuxCore's sphere light (biased in BIDIRCPU: module
            # docstring); radiance S / (pi A) makes its power S, as Cycles' sphere
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


def world_props(tr: Translation, world) -> None:
    """A constant background -> ``constantinfinite`` (nothing for black)."""
    if world is None:
        return
    if world.node_tree is None:
        c = np.array(world.color[:3], np.float64)
    else:
        out = world.node_tree.get_output_node('CYCLES')
        surf = out.inputs["Surface"] if out is not None else None
        if surf is None or not surf.is_linked:
            return
        node = surf.links[0].from_node
        if node.bl_idname != "ShaderNodeBackground":
            raise Unsupported(f"world '{world.name}': {node.bl_idname} is not translated")
        c = np.array(_input(node, "Color")) * _input(node, "Strength")
    if c.max() > 0:
        tr.set("scene.lights.world", type="constantinfinite", color=[1.0, 1.0, 1.0],
               gain=c.tolist())
        tr.lights += 1


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


def film_size(scene) -> tuple[int, int]:
    r = scene.render
    if r.use_border:
        raise Unsupported("render border: not translated")
    pct = r.resolution_percentage / 100.0
    return max(int(r.resolution_x * pct), 1), max(int(r.resolution_y * pct), 1)


def camera_props(scene, depsgraph, supersample: int = 1) -> dict:
    """The camera: LookAt from the camera's matrix (up = its +y), and Blender's view frame at
    unit depth as the screen window, with fieldofview = 2 atan(t), t the half-extent of the
    frame's longer side (LuxCore's field of view spans the longer side: projective.cpp's
    automatic window is [-1, 1] along it; an explicit window is in units of tan(fov / 2)).
    ``supersample``: LuxCore's film has that many pixels per pixel of the scene's along each
    axis (the window is the same; its one-row shift is one of the film's rows)."""
    cam_obj = scene.camera
    if cam_obj is None or cam_obj.type != 'CAMERA':
        raise Unsupported("the scene has no camera")
    cam = cam_obj.evaluated_get(depsgraph)
    if cam.data.type != 'PERSP':
        raise Unsupported(f"camera '{cam_obj.name}': only perspective cameras are translated")
    m = np.array(cam.matrix_world, np.float64)
    m3 = m[:3, :3] / np.maximum(np.linalg.norm(m[:3, :3], axis=0, keepdims=True), 1e-30)
    o = m[:3, 3]
    frame = np.array([tuple(v) for v in cam.data.view_frame(scene=scene)])   # tr, br, bl, tl
    uv = frame[:, :2] / -frame[:, 2:3]                   # at unit depth
    x0, x1 = float(uv[:, 0].min()), float(uv[:, 0].max())
    y0, y1 = float(uv[:, 1].min()), float(uv[:, 1].max())
    t = max(x1 - x0, y1 - y0) / 2
    # LuxCore maps film row y to raster row height - y - 1 (perspective.cpp InitRay; its light
    # splats invert the same map): its image lies one pixel too high.  The window moves down by
    # one pixel to put it back (measured: the lowest RMSE against the light-traced reference
    # at no shift, instead of at one row, with this)
    _w, h = film_size(scene)
    dy = (y1 - y0) / (h * supersample)
    y0, y1 = y0 - dy, y1 - dy
    props = {"scene.camera.type": "perspective",
             "scene.camera.lookat.orig": o.tolist(),
             "scene.camera.lookat.target": (o - m3[:, 2]).tolist(),
             "scene.camera.up": m3[:, 1].tolist(),
             "scene.camera.fieldofview": math.degrees(2 * math.atan(t)),
             "scene.camera.screenwindow": [x0 / t, x1 / t, y0 / t, y1 / t],
             "scene.camera.cliphither": float(cam.data.clip_start),
             "scene.camera.clipyon": float(cam.data.clip_end)}
    dof = cam.data.dof
    if dof.use_dof:
        if dof.focus_object is not None:
            target = np.array(dof.focus_object.evaluated_get(depsgraph).matrix_world.translation)
            focus = float((target - o) @ -m3[:, 2])
        else:
            focus = float(dof.focus_distance)
        props["scene.camera.lensradius"] = cam.data.lens * 1e-3 / (
            2 * max(float(dof.aperture_fstop), 1e-6))
        props["scene.camera.focaldistance"] = max(focus, 1e-6)
    return props


def translate(depsgraph, supersample: int = 1) -> Translation:
    """The depsgraph's scene as LuxCore properties and meshes (module docstring), for a film of
    ``supersample`` x the scene's resolution along each axis."""
    scene = depsgraph.scene
    tr = Translation()
    tr.props.update(camera_props(scene, depsgraph, supersample))
    materials: dict[object, str] = {}

    def material(mat) -> str:
        key = mat.name if mat is not None else None
        if key not in materials:
            name = f"mat{len(materials)}"
            props, emission = material_props(mat)
            tr.set(f"scene.materials.{name}", **props)
            if emission is not None and max(emission) > 0:
                tr.set(f"scene.materials.{name}", emission=[1.0, 1.0, 1.0],
                       **{"emission.gain": emission})
            materials[key] = name
        return materials[key]

    for k, inst in enumerate(depsgraph.object_instances):
        obj = inst.object
        if obj.original.hide_render or not inst.show_self:
            continue
        m = np.array(inst.matrix_world, np.float64)
        if obj.type == 'LIGHT':
            light_props(tr, obj, m, f"l{k}")
            continue
        if obj.type not in ('MESH', 'CURVE', 'SURFACE', 'META', 'FONT'):
            continue
        arrays = mesh_arrays(obj, m)
        if arrays is None:
            continue
        p, n, slot = arrays
        slots = [s.material for s in obj.material_slots]
        hidden = not getattr(obj, "visible_camera", True)
        for sl in np.unique(slot):
            mat = slots[sl] if 0 <= sl < len(slots) else None
            name = material(mat)
            sel = slot == sl
            ps, ns = p[sel], n[sel]
            emits = f"scene.materials.{name}.emission" in tr.props
            if emits and not _flat(ps, ns):
                # LuxCore emits about the shading normal (trianglelight.cpp Emit: the hit
                # point's frame), Cycles the same radiance every way from the surface: for a
                # black emitter only emission uses the normals, so it goes flat (the bulb box's
                # smooth filament); one that also reflects would change
                if max(tr.props.get(f"scene.materials.{name}.kd", [0.0])) > 0:
                    raise Unsupported(f"object '{obj.name}': a smooth-shaded emitter that also "
                                      "reflects (LuxCore emits about the shading normal)")
                ns = None
            tr.add_mesh(f"o{k}_{sl}", ps, ns, name, hidden)
            if tr.props[f"scene.materials.{name}.type"] == "glass":
                ior = float(tr.props[f"scene.materials.{name}.interiorior"])
                tr.glass.append((ps, ior, f"o{k}_{sl}"))
            if emits:
                tp, tn = _emissive_twin(ps, ns)
                tr.add_mesh(f"o{k}_{sl}_back", tp, tn, name, hidden)
                tr.emitters.append((ps.mean(1), None, name,
                                    [f"o{k}_{sl}", f"o{k}_{sl}_back"]))
                tr.lights += 1
    world_props(tr, scene.world)
    enclosed_emission(tr, np.array(scene.camera.matrix_world.translation))
    return tr
