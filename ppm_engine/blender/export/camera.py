"""The scene camera -> CAMERA_DTYPE, exactly Cycles' rays (sensor fit, shift,
clipping, depth of field; tests/test_export_camera.py checks the projection against
Blender's own)."""
from __future__ import annotations

import numpy as np

from ppm_engine.errors import SceneError
from ppm_engine.scene.arrays import (
    CAMERA_ORTHO,
    CAMERA_PERSP,
    FILM_TRANSPARENT,
    FILM_TRANSPARENT_GLASS,
    FILTER_BLACKMAN_HARRIS,
    FILTER_BOX,
    FILTER_GAUSSIAN,
)
from ppm_engine.scene.camera import make_camera, ortho_extent, perspective_extent


def render_size(render) -> tuple[int, int]:
    pct = render.resolution_percentage / 100.0
    return max(int(render.resolution_x * pct), 1), max(int(render.resolution_y * pct), 1)


def export_camera(scene, depsgraph, camera_object=None) -> np.ndarray:
    """The camera record of ``camera_object`` (a 3D view's local camera), by default the
    scene's active camera; SceneError where there is none or it is not a camera."""
    cam_obj = camera_object if camera_object is not None else scene.camera
    if cam_obj is None:
        raise SceneError("the scene has no active camera: add a camera and make it active "
                         "(Scene Properties > Camera)")
    if cam_obj.type != 'CAMERA':
        raise SceneError(f"the active camera '{cam_obj.name}' is a {cam_obj.type.lower()}, not "
                         "a camera: choose a camera object in Scene Properties > Camera")
    cam_eval = cam_obj.evaluated_get(depsgraph)
    cam = cam_eval.data
    render = scene.render
    W, H = render_size(render)
    aspect = (render.pixel_aspect_x, render.pixel_aspect_y)
    if cam.type == 'PERSP':
        w_ext, h_ext, fit = perspective_extent(W, H, cam.lens, cam.sensor_width, cam.sensor_fit,
                                               cam.sensor_height, aspect)
        ctype = CAMERA_PERSP
    elif cam.type == 'ORTHO':
        w_ext, h_ext, fit = ortho_extent(W, H, cam.ortho_scale, cam.sensor_fit, aspect)
        ctype = CAMERA_ORTHO
    else:
        raise SceneError(f"camera '{cam_obj.name}': panoramic cameras are not supported; "
                         "use a perspective or orthographic camera")
    m = np.array(cam_eval.matrix_world, dtype=np.float64)
    cols = m[:3, :3]
    m[:3, :3] = cols / np.maximum(np.linalg.norm(cols, axis=0, keepdims=True), 1e-30)

    region = (0, 0, W, H)
    if render.use_border:
        x0, x1 = int(render.border_min_x * W), int(render.border_max_x * W)
        y0, y1 = int(render.border_min_y * H), int(render.border_max_y * H)
        if x1 <= x0 or y1 <= y0:
            raise SceneError("the render border is empty: widen it or turn border rendering off")
        region = (x0, y0, x1 - x0, y1 - y0)

    dof = cam.dof
    aperture, focus, blades, rotation, ratio = 0.0, 10.0, 0, 0.0, 1.0
    if dof.use_dof:
        fstop = max(float(dof.aperture_fstop), 1e-6)
        aperture = (cam.lens * 1e-3 / (2 * fstop)) if ctype == CAMERA_PERSP else 1 / (2 * fstop)
        if dof.focus_object is not None:
            target = np.array(dof.focus_object.evaluated_get(depsgraph).matrix_world.translation,
                              np.float64)
            focus = float(-(target - m[:3, 3]) @ m[:3, 2])       # along the view axis
        else:
            focus = float(dof.focus_distance)
        focus = max(focus, 1e-6)
        blades, rotation = int(dof.aperture_blades), float(dof.aperture_rotation)
        ratio = float(dof.aperture_ratio)
    return make_camera(type=ctype, width=W, height=H, to_world=m[:3], extent=(w_ext, h_ext),
                       shift=(cam.shift_x * fit, cam.shift_y * fit),
                       clip=(cam.clip_start, cam.clip_end), region=region,
                       aperture_radius=aperture, focus_distance=focus, aperture_blades=blades,
                       aperture_rotation=rotation, aperture_ratio=ratio,
                       **film_settings(scene))


# Cycles' film settings when the Cycles add-on (scene.cycles) is absent: its defaults
CYCLES_FILM_DEFAULTS = {"pixel_filter_type": "BLACKMAN_HARRIS", "filter_width": 1.5,
                        "film_exposure": 1.0, "film_transparent_glass": False,
                        "film_transparent_roughness": 0.1}
_FILTERS = {"BLACKMAN_HARRIS": FILTER_BLACKMAN_HARRIS, "BOX": FILTER_BOX,
            "GAUSSIAN": FILTER_GAUSSIAN}


def film_settings(scene) -> dict:
    """The film as Cycles renders it: the pixel filter, transparency and exposure of the
    scene's Cycles film settings (Render Properties > Film), Cycles' defaults without them;
    the transparent film is Blender's own render.film_transparent."""
    cycles = getattr(scene, "cycles", None)

    def get(name):
        value = getattr(cycles, name, None) if cycles is not None else None
        return CYCLES_FILM_DEFAULTS[name] if value is None else value

    for name in ("filter_width", "film_exposure", "film_transparent_roughness"):
        if not np.isfinite(float(get(name))):
            raise SceneError(f"the film's {name.replace('_', ' ')} is not a number: set it in "
                             "Render Properties > Film")
    kind = _FILTERS.get(str(get("pixel_filter_type")), FILTER_BLACKMAN_HARRIS)
    # Blender's Cycles renders the box one pixel wide, whatever the width (it hides it)
    width = 1.0 if kind == FILTER_BOX else max(float(get("filter_width")), 0.01)
    transparent = 0
    if scene.render.film_transparent:
        transparent = FILM_TRANSPARENT | (FILM_TRANSPARENT_GLASS
                                          if get("film_transparent_glass") else 0)
    return dict(filter_type=kind, filter_width=width, film_transparent=transparent,
                glass_roughness=float(get("film_transparent_roughness")),
                exposure=max(float(get("film_exposure")), 0.0))
