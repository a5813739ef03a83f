"""The scene as the device renders it (host side, NumPy): what cannot be rendered is dropped or
refused, and a scene far from the origin is moved to it (docs/STABILITY.md).  The Renderer
uploads the result (device_scene.py); the session calls check_finite before deciding a scene is
dark."""
from __future__ import annotations

import numpy as np

from ppm_engine.errors import SceneError
from ppm_engine.scene.arrays import TERMINATOR_OFFSET, SceneArrays


def check_camera(camera: np.ndarray) -> None:
    """Refuse NaN/Inf in a camera record with a SceneError."""
    for field in camera.dtype.names:
        if camera.dtype[field].base.kind == "f" and not np.isfinite(camera[field]).all():
            raise SceneError(f"the camera has NaN or infinite values in '{field}': fix them and "
                             "render again")


def check_finite(scene: SceneArrays) -> None:
    """Refuse NaN/Inf in the camera, a material (its BSDF nodes' inputs included) or the world
    with a SceneError naming it."""
    check_camera(scene.camera)
    for name in ("materials", "shader_nodes"):
        a = getattr(scene, name)
        for field in a.dtype.names:
            if a.dtype[field].base.kind != "f":
                continue
            bad = ~np.isfinite(a[field]).reshape(len(a), -1).all(axis=1)
            if bad.any():
                k = int(np.nonzero(bad)[0][0])
                if name == "shader_nodes":
                    k = int(a["material"][k])
                what = (f"material '{scene.material_names[k]}'"
                        if k < len(scene.material_names) else f"material {k}")
                raise SceneError(f"the {what} has NaN or infinite values in '{field}': fix "
                                 "them and render again")
    if not np.isfinite(scene.world).all():
        raise SceneError("the world colour has NaN or infinite values: fix its strength or colour")


def corner_box(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) of the rows of ``points`` (..., 3), in its dtype: the minimum and maximum of
    each coordinate, reduced column by column (NumPy's min(axis=0) over rows of three is ~10x
    slower: 8 ms for a 100K-triangle mesh's corners).  Empty: (+inf, -inf)."""
    p = points.reshape(-1, 3)
    if not p.shape[0]:
        return np.full(3, np.inf, p.dtype), np.full(3, -np.inf, p.dtype)
    return (np.array([p[:, k].min() for k in range(3)], p.dtype),
            np.array([p[:, k].max() for k in range(3)], p.dtype))


def finite_triangles(positions: np.ndarray, owner: str = "") -> tuple[np.ndarray | None, str]:
    """Triangles (n, 3, 3) whose corners are all finite: (mask, warning), or (None, "") when all
    are.  Both the exporter (per object, naming it as ``owner``) and prepare_scene (any scene)
    drop the others with this warning."""
    good = np.isfinite(positions).all(axis=(1, 2))
    if good.all():
        return None, ""
    prefix = f"{owner}: " if owner else ""
    return good, (f"{prefix}{int((~good).sum())} triangles with NaN or infinite vertex "
                  "coordinates were skipped")


def prepare_scene(scene: SceneArrays) -> tuple[SceneArrays, list[str]]:
    """The scene as the device renders it, and warnings (docs/STABILITY.md):
      * triangles with a NaN/Inf corner are dropped (as the exporter does), NaN/Inf shading
        normals fall back to the geometric normal, lights with NaN/Inf values are dropped;
      * NaN/Inf in the camera, the world or a material is refused with a SceneError;
      * a scene far from the origin (|centre| > 4 x its size) is moved to it, in float64:
        the kernels' ULP-scaled ray offsets and float32 hit points then work at the
        precision of the scene's size, not of its distance (a box 1e5 from the origin).
    The shift depends on the positions only, so the same geometry always gets the same one."""
    check_finite(scene)
    warnings = []
    changes = {}
    good, warning = finite_triangles(scene.positions)
    if good is not None:
        warnings.append(warning)
        changes.update(positions=scene.positions[good], normals=scene.normals[good],
                       uvs=scene.uvs[good], material=scene.material[good],
                       visibility=scene.visibility[good])
        for name in ("tangents", "uv_tangents", "generated", "attributes", "object",
                     "terminator"):
            if getattr(scene, name).shape[0]:
                changes[name] = getattr(scene, name)[good]
    for name in ("tangents", "uv_tangents", "generated", "attributes", "object"):
        tg = changes.get(name, getattr(scene, name))
        if not np.isfinite(tg).all():
            changes[name] = np.where(np.isfinite(tg), tg, 0.0).astype(np.float32)
    tm = changes.get("terminator", scene.terminator)
    if not (np.isfinite(tm) & (tm >= 0) & (tm <= 1)).all():
        changes["terminator"] = np.clip(np.nan_to_num(tm, nan=TERMINATOR_OFFSET), 0.0,
                                        1.0).astype(np.float32)
    uv = changes.get("uvs", scene.uvs)
    if not np.isfinite(uv).all():
        changes["uvs"] = np.where(np.isfinite(uv), uv, 0.0).astype(np.float32)
    nrm = changes.get("normals", scene.normals)
    if not np.isfinite(nrm).all():
        changes["normals"] = np.where(np.isfinite(nrm), nrm, 0.0).astype(np.float32)
    lights = scene.lights
    lf = [f for f in lights.dtype.names if lights.dtype[f].kind == "f"]
    ok = np.ones(lights.shape[0], bool)
    for f in lf:
        ok &= np.isfinite(lights[f]).reshape(lights.shape[0], -1).all(axis=1) if ok.size else ok
    if not ok.all():
        warnings.append(f"{int((~ok).sum())} lights with NaN or infinite values were skipped")
        changes["lights"] = lights = lights[ok]
    pos = changes.get("positions", scene.positions).reshape(-1, 3)
    if pos.shape[0]:
        lo, hi = (a.astype(np.float64) for a in corner_box(pos))
        centre = np.float32(0.5 * (lo + hi)).astype(np.float64)
        if np.abs(centre).max() > 4 * max(float((hi - lo).max()), 1e-30):
            changes["positions"] = (pos.astype(np.float64) - centre).astype(
                np.float32).reshape(-1, 3, 3)
            lights = lights.copy()
            lights["position"] = lights["position"].astype(np.float64) - centre
            cam = scene.camera.copy()
            cam["to_world"][0, :, 3] = cam["to_world"][0, :, 3].astype(np.float64) - centre
            changes.update(lights=lights, camera=cam)
    return (scene.replace(**changes) if changes else scene), warnings


def offset_scale(scene: SceneArrays) -> float:
    """A power of two near half the scene's largest extent (1 for the 2 m Cornell box): the
    scale of the absolute ray offsets near the axis planes (kernels/geom/geometry.h offset_ray)."""
    pos = scene.positions.reshape(-1, 3)
    if pos.shape[0] == 0:
        return 1.0
    lo, hi = corner_box(pos)
    extent = float((hi.astype(np.float64) - lo).max())
    if not (extent > 0 and np.isfinite(extent)):
        return 1.0
    return float(2.0 ** int(np.clip(np.round(np.log2(extent / 2)), -60, 60)))
