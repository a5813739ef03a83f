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

This module has the meshes, the camera and ``translate``; the materials, the world and the
``Translation`` are luxcore_nodes.py's, the lights and the emitters inside glass
luxcore_lights.py's.
"""
from __future__ import annotations

import math

import numpy as np

from ppm_engine.tools.bench.luxcore_lights import enclosed_emission, light_props
from ppm_engine.tools.bench.luxcore_nodes import (
    Translation,
    Unsupported,
    material_props,
    world_props,
)


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
