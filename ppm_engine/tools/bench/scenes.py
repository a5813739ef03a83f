"""The benchmark's data about its scenes (ppm_engine.blender.scenes builds them): per scene, the
floor region counted as "caustic pixels" (caustic_mask below: a world-space disk on the floor, or
the set of floor points that see the light's mirror image through the mirror rectangle, exact;
pixels whose camera ray meets one of the listed spheres first are left out), the objects
Cycles' shadow caustics (MNEE) needs flagged, the Light Paths settings a scene renders with in
every engine (LIGHT_PATHS: its clamp, or Cycles' defaults), and the light tree the renderer
builds for a scene (light_tree_stats)."""
from __future__ import annotations

import numpy as np

from ppm_engine.blender.scenes.bulb_box import BALL_CENTER, BULB_CENTER
from ppm_engine.blender.scenes.caustics import (
    BALL,
    CLAMP,
    FAR_BALL,
    FAR_POS,
    LIFTED_BALL,
    LIGHT_RADIUS,
    POINT_POS,
    mirror_corners,
    mirror_image,
)
from ppm_engine.scene.light_paths import CYCLES_DEFAULTS

# scene name -> caustic mask description (caustic_mask)
CAUSTIC_MASKS = {
    # the Cornell box has no caustic: the whole floor counts (its indirect light)
    "cornell_box": {"kind": "disk", "center": (0.0, 0.0, 0.0), "radius": 1.5,
                    "occluders": [], "note": "the floor (no caustic in this scene)"},
    # the furnace: no caustic, no floor; every pixel counts
    "furnace": {"kind": "all", "occluders": [], "note": "every pixel (no caustic)"},
    # the city at night: no caustic; every pixel counts
    "many_lights": {"kind": "all", "occluders": [], "note": "every pixel (no caustic)"},
    # the pool: every pixel is the caustic, seen through the water
    "pool_caustic": {"kind": "all", "occluders": [], "note": "every pixel (the floor's caustic, "
                                                            "seen through the water)"},
    # the HDRI's sun: every pixel (the glass ball's caustic is among them)
    "hdri_sun": {"kind": "all", "occluders": [], "note": "every pixel"},
    # the glossy metal: every pixel (the light's highlights, the floor's light in the metal)
    "glossy_metal": {"kind": "all", "occluders": [], "note": "every pixel"},
    # the lens in fog: every pixel its exact reference renders (not through the ball); the cone
    # of light below the ball among them
    "fog_lens": {"kind": "all", "occluders": [], "note": "every pixel past the ball (the "
                 "volumetric caustic below it among them)"},
    # the sun-lit cone: every pixel (the floor's glossy light on the cone among them)
    "sun_cone": {"kind": "all", "occluders": [], "note": "every pixel"},
    # the fog room and the smoke: every pixel (the cone of light in the fog, the smoke's puffs)
    "fog_room": {"kind": "all", "occluders": [], "note": "every pixel"},
    "smoke": {"kind": "all", "occluders": [], "note": "every pixel"},
    # the metal ball's caustic under a clamp: the wall and the floor beyond the lit pool are
    # lit by the ball alone; every pixel counts
    "clamped_caustic": {"kind": "all", "occluders": [],
                        "note": "every pixel (the wall and the floor beyond the pool: the "
                                "ball's caustic)"},
    # the floor beside and under the glass ball, where its caustic falls
    "bulb_box": {"kind": "disk", "center": (BALL_CENTER[0] + 0.07, BALL_CENTER[1] + 0.05, 0.0),
                 "radius": 0.45, "occluders": [(BALL_CENTER, 0.3), (BULB_CENTER, 0.15)],
                 "note": "floor within 0.45 m of the point below the bulb-to-ball line, "
                         "not hidden by the ball"},
    "glass_caustic": {"kind": "disk", "center": (0.43, 0.0, 0.0), "radius": 0.35,
                      "occluders": [BALL],
                      "note": "floor within 0.35 m of where the ray from the spot through the "
                              "ball centre meets the floor, not hidden by the ball"},
    "mirror_caustic": {"kind": "mirror", "light": POINT_POS, "light_radius": LIGHT_RADIUS,
                       "corners": None, "occluders": [],
                       "note": "floor points that see the light's mirror image through the "
                               "mirror (the reflected patch, exact)"},
}

# the point light stands where the spot does: the same floor
CAUSTIC_MASKS["point_caustic"] = dict(
    CAUSTIC_MASKS["glass_caustic"],
    note="floor within 0.35 m of where the ray from the point light through the ball centre "
         "meets the floor, not hidden by the ball")
CAUSTIC_MASKS["rough_caustic"] = dict(
    CAUSTIC_MASKS["point_caustic"],
    note="point_caustic's floor (the same ball, of rough glass)")
# far_caustic: the floor within 0.5 m of where the ray from the light through the centre of the
# bigger ball meets it (x = 0.83), which holds 93 % of the flux refracted twice onto the floor
# (point_caustic's 0.35 m disk: 94 %)
_far_axis = np.subtract(FAR_BALL[0], FAR_POS)
CAUSTIC_MASKS["far_caustic"] = {
    "kind": "disk", "center": tuple(np.add(FAR_POS, -FAR_POS[2] / _far_axis[2] * _far_axis)),
    "radius": 0.5, "occluders": [FAR_BALL],
    "note": "floor within 0.5 m of where the ray from the point light through the ball centre "
            "meets the floor, not hidden by the ball"}
# lifted_caustic: the floor within 0.7 m of where the ray from the light through the lifted
# ball's centre meets it (x = 1.06; the disc past the focus is wider than far_caustic's)
_lifted_axis = np.subtract(LIFTED_BALL[0], FAR_POS)
CAUSTIC_MASKS["lifted_caustic"] = {
    "kind": "disk",
    "center": tuple(np.add(FAR_POS, -FAR_POS[2] / _lifted_axis[2] * _lifted_axis)),
    "radius": 0.7, "occluders": [LIFTED_BALL],
    "note": "floor within 0.7 m of where the ray from the point light through the ball centre "
            "meets the floor, not hidden by the ball"}
CAUSTIC_MASKS["mirror_caustic"]["corners"] = mirror_corners().tolist()
CAUSTIC_MASKS["mirror_caustic"]["light_image"] = mirror_image(POINT_POS).tolist()

# objects Cycles' shadow caustics (MNEE) uses, per scene: (casters, receivers, lights)
MNEE_OBJECTS = {
    "glass_caustic": (["GlassBall"], ["Floor", "Back"], ["Spot"]),
    "point_caustic": (["GlassBall"], ["Floor", "Back"], ["Point"]),
    "rough_caustic": (["GlassBall"], ["Floor", "Back"], ["Point"]),
    "far_caustic": (["GlassBall"], ["Floor", "Back"], ["Point"]),
    "lifted_caustic": (["GlassBall"], ["Floor", "Back"], ["Point"]),
    "mirror_caustic": (["Mirror"], ["Floor", "Back"], ["Point"]),
    "pool_caustic": (["Water"], ["Floor"], ["Sun"]),
}

# Light Paths settings (scene.cycles, which both engines read) a scene renders with, in our
# renders, Cycles' and the Cycles reference's alike, over harness.cycles_reference's (12
# bounces of every kind, no clamping): clamped_caustic's clamp, as its builder sets it (a
# clamped image's fair reference is Cycles' long render with the same clamp)
LIGHT_PATHS = {
    "clamped_caustic": {"sample_clamp_direct": CLAMP, "sample_clamp_indirect": CLAMP},
    # a user's new file: 4 diffuse and 4 glossy bounces, Clamp Indirect 10, Filter Glossy 1
    "sun_cone": dict(CYCLES_DEFAULTS),
    # the same (Volume bounces 0: single scattering), as the volume scenes' builders set them
    "fog_room": dict(CYCLES_DEFAULTS),
    "smoke": dict(CYCLES_DEFAULTS),
}


def set_light_paths(scene, name: str) -> None:
    """The scene's own Light Paths settings (LIGHT_PATHS), after a render's set-up."""
    for k, v in LIGHT_PATHS.get(name, {}).items():
        setattr(scene.cycles, k, v)


# --- images and masks -------------------------------------------------------------------------
def camera_rays(scene, w: int, h: int):
    """(origin (3,), directions (h, w, 3)) through the pixel centres, rows top-down."""
    cam = scene.camera
    m = np.array(cam.matrix_world)
    frame = np.array([tuple(v) for v in cam.data.view_frame(scene=scene)])  # tr, br, bl, tl
    tr, br, bl, tl = frame
    u = (np.arange(w) + 0.5) / w
    v = (np.arange(h) + 0.5) / h
    top = tl[None, :] + u[:, None] * (tr - tl)[None, :]
    bottom = bl[None, :] + u[:, None] * (br - bl)[None, :]
    local = top[None, :, :] + v[:, None, None] * (bottom - top)[None, :, :]   # (h, w, 3)
    d = local @ m[:3, :3].T
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    return m[:3, 3].copy(), d


def sphere_hit_t(o, d, center, radius):
    """Nearest positive hit distance of rays o + t d with a sphere (inf where none)."""
    oc = o - np.asarray(center, float)
    b = d @ oc
    c = oc @ oc - radius * radius
    disc = b * b - c
    s = np.sqrt(np.maximum(disc, 0.0))
    t0, t1 = -b - s, -b + s
    t = np.where(t0 > 1e-6, t0, np.where(t1 > 1e-6, t1, np.inf))
    return np.where(disc > 0, t, np.inf)


def caustic_mask(scene, name: str, w: int, h: int) -> np.ndarray:
    """Boolean (h, w): the scene's caustic pixels (scenes.CAUSTIC_MASKS), top-down."""
    spec = CAUSTIC_MASKS[name]
    if spec["kind"] == "all":
        return np.ones((h, w), bool)
    o, d = camera_rays(scene, w, h)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_floor = np.where(d[..., 2] < 0, -o[2] / d[..., 2], np.inf)
    p = o + t_floor[..., None] * d
    mask = np.isfinite(t_floor) & (np.abs(p[..., 0]) <= 2) & (np.abs(p[..., 1]) <= 2)
    for center, radius in spec["occluders"]:
        mask &= sphere_hit_t(o, d, center, radius) > t_floor
    if spec["kind"] == "disk":
        c = np.asarray(spec["center"], float)
        mask &= np.hypot(p[..., 0] - c[0], p[..., 1] - c[1]) <= spec["radius"]
    else:           # floor points whose segment to the light's mirror image crosses the mirror
        corners = np.asarray(spec["corners"], float)
        img = np.asarray(spec["light_image"], float)
        n = np.cross(corners[1] - corners[0], corners[2] - corners[0])
        n /= np.linalg.norm(n)
        seg = img - p
        with np.errstate(divide="ignore", invalid="ignore"):
            s = ((corners[0] - p) @ n) / (seg @ n)
        q = p + s[..., None] * seg
        inside = (s > 0) & (s < 1)
        for k in range(4):
            a, b = corners[k], corners[(k + 1) % 4]
            inside &= (np.cross(b - a, q - a) @ n) >= 0
        # ... and the mirror does not hide the point from the camera
        with np.errstate(divide="ignore", invalid="ignore"):
            tm = ((corners[0] - o) @ n) / (d @ n)
        qm = o + tm[..., None] * d
        hidden = (tm > 0) & (tm < t_floor)
        for k in range(4):
            a, b = corners[k], corners[(k + 1) % 4]
            hidden &= (np.cross(b - a, qm - a) @ n) >= 0
        mask &= inside & ~hidden
    return mask


def fog_room_regions(scene, w: int, h: int) -> dict:
    """fog_room's pixels by what they see, top-down (references.regions): "pool" the floor's
    pool of light under the spot's cone (seen through the cone's foot), "cone" the cone of lit
    fog elsewhere, "fog" the fog outside the cone (lit by no light of its own: single
    scattering), "room" the floor and wall seen past no fog (lit by what the fog and the pool
    send them).  A partition of the image, from the geometry (fog_room.py's constants)."""
    from ppm_engine.blender.scenes import fog_room as fr
    o, d = camera_rays(scene, w, h)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_floor = np.where(d[..., 2] < 0, (fr.FLOOR_Z - o[2]) / d[..., 2], np.inf)
        t_wall = np.where(d[..., 1] > 0, (fr.WALL_Y - o[1]) / d[..., 1], np.inf)
        t0, t1 = (np.asarray(fr.FOG_LO) - o) / d, (np.asarray(fr.FOG_HI) - o) / d
    t_in = np.maximum(np.minimum(t0, t1).max(-1), 0.0)
    t_out = np.maximum(t0, t1).min(-1)
    fog = t_out > t_in
    floor = t_floor < t_wall
    p = o + np.where(floor, t_floor, t_wall)[..., None] * d
    half = 0.5 * fr.SPOT_SIZE
    # the pool: the cone's foot on the floor, a pixel's margin for the filter
    pool = floor & (np.hypot(p[..., 0], p[..., 1])
                    < (fr.SPOT_POS[2] - fr.FLOOR_Z) * np.tan(half) + 0.05)
    # the cone: a point of the ray's way through the fog within the spot's half angle
    s = np.linspace(0.0, 1.0, 64, dtype=np.float32)[:, None]
    cone = np.zeros((h, w), bool)
    for y in range(h):
        pts = o + (t_in[y] + s * (t_out[y] - t_in[y]))[..., None] * d[y]     # (64, w, 3)
        v = pts - np.asarray(fr.SPOT_POS)
        cone[y] = (-v[..., 2] > np.cos(half) * np.linalg.norm(v, axis=-1)).any(0)
    cone &= fog & ~pool
    return {"pool": pool, "cone": cone, "fog": fog & ~cone & ~pool, "room": ~fog & ~pool}


# scene name -> its regions scored beside the whole image (references.regions)
REGIONS = {"fog_room": fog_room_regions}


def excluded_pixels(scene, name: str, w: int, h: int) -> np.ndarray:
    """Pixels left out of every figure: those that see the bulb of the bulb box."""
    if name != "bulb_box":
        return np.zeros((h, w), bool)
    o, d = camera_rays(scene, w, h)
    # the bulb's radius is 0.15; a pixel margin keeps its anti-aliased edge out too
    return np.isfinite(sphere_hit_t(o, d, BULB_CENTER, 0.15 + 1.5 * 2.0 / w))


def set_mnee(name: str, on: bool) -> None:
    """Cycles' shadow caustics flags on the scene's casters, receivers and light."""
    import bpy
    casters, receivers, lights = MNEE_OBJECTS[name]
    for n in casters:
        bpy.data.objects[n].cycles.is_caustics_caster = on
    for n in receivers:
        bpy.data.objects[n].cycles.is_caustics_receiver = on
    for n in lights:
        bpy.data.objects[n].data.cycles.is_caustics_light = on


def light_tree_stats(scene, device: str) -> dict | None:
    """The light tree of the scene as the renderer builds it (ppm_engine/scene/light_tree.py): its
    emitters, nodes, bytes on the device (nodes, each emitter's leaf, the far CDF) and build
    time; None when the scene has none (LOCAL_PICK_MAX emitters or fewer).  The scene on the
    device as a Renderer uploads it (DeviceScene), no kernel built."""
    import bpy

    from ppm_engine.blender.export import export_scene
    from ppm_engine.render.device import get_device
    from ppm_engine.render.device_scene import DeviceScene
    dev = get_device(device)
    with dev.lock:
        em = DeviceScene(dev, export_scene(bpy.context.evaluated_depsgraph_get())).emitters
    if em.tree.shape[0] == 0:
        return None
    return {"emitters": int((em.emitter_leaf >= 0).sum()), "nodes": int(em.tree.shape[0]),
            "bytes": int(em.tree.nbytes + em.emitter_leaf.nbytes + em.far_cdf.nbytes),
            "build_s": float(em.tree_build_s), "share": em.tree_power_share}
