"""The emitter table the kernels sample, for photon emission and next-event estimation:
scene lights, then emissive triangles, then the world.  Photons leave them in proportion to
power, so dim lights get few photons and lights that cannot contribute are never sampled.
Next-event estimation first chooses the local emitters (lights other than suns, emissive
triangles) or the far ones (suns, the world) by their importance at the shading point, as
Cycles' light tree does (a bound of all the local ones against the far ones' energy), then
picks the far ones by power and the local ones by the light tree, or by power and, where
there are at most eight emissive triangles, among them by the light each gives the shading
point (kernels/light/light_mesh.h pick_emitter_at)."""
from __future__ import annotations

import dataclasses

import numpy as np

from ppm_engine.scene.arrays import (
    LIGHT_AREA_ELLIPSE,
    LIGHT_AREA_RECT,
    LIGHT_POINT,
    LIGHT_SPOT,
    LIGHT_SUN,
    SceneArrays,
)
from ppm_engine.scene.light_tree import (
    LIGHT_TREE_NODE_DTYPE,
    bound_node,
    build_light_tree,
    emitter_bounds,
)
from ppm_engine.scene.materials import MAT_VOLUME, mean_emission, world_medium
from ppm_engine.scene.prep import corner_box
from ppm_engine.scene.shader_program import field_glows

# the emitter table's header (kernels/shared.h EmitterInfo)
EMITTER_INFO_DTYPE = np.dtype([
    ("n_lights", np.int32),
    ("n_emissive", np.int32),
    ("has_world", np.int32),
    ("n_emitters", np.int32),
    ("world", np.float32, 3),
    ("scene_center", np.float32, 3),
    ("scene_radius", np.float32),
    # the scale of the ray offsets (prep.offset_scale; kernels/geom/geometry.h offset_ray)
    ("offset_scale", np.float32),
    ("world_program", np.int32),   # the world's program (SceneArrays.world_shader), 0 = none
    ("world_flags", np.int32),     # WORLD_HIDDEN_CAMERA
    ("map_w", np.int32),           # its importance map (world_map.WorldMap)
    ("map_h", np.int32),
    ("map_mean", np.float32),
    # few emissive triangles: their bounding ball, near which next-event estimation picks among
    # them by their light at the point (kernels/light/light_mesh.h pick_emitter_at); radius 0: never
    ("local_center", np.float32, 3),
    ("local_radius", np.float32),
    # the light tree (light_tree.py) over more than LOCAL_PICK_MAX local emitters: its node
    # count (0: none, the local emitters by their power table) and its members' share of the
    # power, next-event estimation's share of them against the far emitters
    ("n_tree", np.int32),
    ("tree_share", np.float32),
    # the far emitters' (suns', the world's) importance at any point, against the local ones'
    # bound (the scene buffer local_bound; kernels/light/light_mesh.h emitter_local_share), as
    # Cycles' light tree weighs its distant lights: a sun's irradiance, pi x the world's mean
    # radiance (0: no far emitter)
    ("far_energy", np.float32),
    ("n_suns", np.int32),          # suns among the lights
    # the casters' bounding spheres caustic photons are aimed at (casters.py; kernels/light/
    # aim.h), set for the render's options by DeviceScene.set_casters
    ("n_casters", np.int32),
    # (DeviceScene.upload) the used materials with a medium of the volume stack (MAT_VOLUME;
    # none: no ray looks for the media at a camera or a light, shadow_rays.h media_at)
    ("n_media", np.int32),
    ("world_medium", np.int32),    # the world's medium's material (-1: none; the stack's bottom)
    ("n_attributes", np.int32),    # the stride of `attributes` (DeviceScene.upload sets it)
])

# at most this many emissive triangles are picked among locally (kernels/light/light_mesh.h
# LOCAL_PICK_MAX, the size of its arrays)
LOCAL_PICK_MAX = 8


def power_cdf(power: np.ndarray) -> np.ndarray:
    """The CDF (float64, exactly 1 from the last entry with power on) that picks emitters in
    proportion to ``power``; all zeros when nothing has power (kernels/scene.h pick_emitter then
    finds pmf 0)."""
    p = np.asarray(power, np.float64)
    total = p.sum()
    if not total > 0:
        return np.zeros(p.shape[0])
    cdf = np.cumsum(p) / total
    cdf[np.nonzero(p > 0)[0][-1]:] = 1.0      # (entries after the last with power: none)
    return cdf


@dataclasses.dataclass
class Emitters:
    info: np.ndarray          # (1,) EMITTER_INFO_DTYPE
    cdf: np.ndarray           # (n_emitters,) float32, last = 1
    emissive_leaves: np.ndarray  # (n_emissive,) int32 leaf indices of emissive triangles
    power: np.ndarray         # (n_emitters,) float64 scalar power used for selection
    total_power: float
    # next-event estimation picks a local emitter (a light other than a sun, an emissive
    # triangle) or a far one (a sun, the world) by their importance at the point, or with a
    # light tree by power (kernels/light/light_mesh.h emitter_local_share; local_share below),
    # then among them: the local ones by the
    # light tree if there is one, else by the power CDF of them alone (local_cdf), the far ones
    # by the power CDF of them alone (far_cdf); local_bound bounds every local emitter (one
    # light tree node, its energy in Cycles' units: a light's intensity, a triangle's radiance
    # x area)
    local_cdf: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, np.float32))
    far_cdf: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, np.float32))
    local_bound: np.ndarray = dataclasses.field(
        default_factory=lambda: np.zeros(0, LIGHT_TREE_NODE_DTYPE))
    # the light tree (light_tree.py; empty without one): its nodes, each emitter's leaf node
    # (-1: not a member), its members' share of the power (the benchmark's statistics)
    tree: np.ndarray = dataclasses.field(
        default_factory=lambda: np.zeros(0, LIGHT_TREE_NODE_DTYPE))
    emitter_leaf: np.ndarray = dataclasses.field(
        default_factory=lambda: np.zeros(0, np.int32))
    tree_power_share: float = 0.0
    # the tree's emitters in its order and the CDF of their power in that order (a node's
    # emitters are contiguous: light_tree.py)
    tree_emitters: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, np.int32))
    tree_cdf: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, np.float32))
    tree_build_s: float = 0.0


def attach_light_tree(em: Emitters, lights: np.ndarray, tri_corners: np.ndarray,
                      tri_materials: np.ndarray) -> Emitters:
    """The light tree over the local emitters (lights other than suns, the emissive triangles
    whose corners tri_corners are in table order, of materials tri_materials) when there are
    more than LOCAL_PICK_MAX of them; fewer keep the power table and the local pick
    (kernels/light/light_mesh.h).  So do emissive triangles of one material alone, with no light
    among the local emitters (a lamp, a sign, a closed emissive sphere): the tree's bound
    favours the emitters beside a shading point that lies on them, whose light there is
    grazing, and from the inside of the furnace's sphere it left 2.3x the power table's noise
    at equal passes and took 2.5x its time per pass (docs/BENCHMARKS.md, "Settings chosen by
    measurement"); the power table picks such a mesh by area, which is exact inside a sphere and
    what the tree does from afar."""
    import time
    n = int(em.info["n_emitters"][0])
    n_lights = lights.shape[0]
    lo, hi, axis, theta_o, theta_e, member = emitter_bounds(lights, tri_corners)
    index = np.concatenate([np.nonzero(member)[0], n_lights + np.arange(tri_corners.shape[0])])
    power = em.power[index] if n else np.zeros(0)
    keep = power > 0
    # their bound for the pick between local and far emitters, in Cycles' units: a point or
    # spot light's intensity, an area light's power / pi, a two-sided triangle's power / 2 pi
    L = lights[member]
    unit = np.where((L["type"] == LIGHT_AREA_RECT) | (L["type"] == LIGHT_AREA_ELLIPSE),
                    1.0 / np.pi, 0.0)
    point = (L["type"] == LIGHT_POINT) | (L["type"] == LIGHT_SPOT)
    energy = np.concatenate([np.where(point, L["emit"].astype(np.float64).mean(axis=1),
                                      unit * power[:L.shape[0]]),
                             power[L.shape[0]:] / (2 * np.pi)])
    energy = np.where(keep & np.isfinite(energy), energy, 0.0)
    em.local_bound = bound_node(lo[keep], hi[keep], axis[keep], theta_o[keep], theta_e[keep],
                                energy[keep])
    if n == 0 or int(keep.sum()) <= LOCAL_PICK_MAX:
        return em
    n_members = int(member.sum())           # the lights among them come first
    if not keep[:n_members].any() and np.unique(tri_materials[keep[n_members:]]).shape[0] == 1:
        return em
    t0 = time.perf_counter()
    nodes, leaf_of, sorted_index, sorted_energy = build_light_tree(
        lo[keep], hi[keep], axis[keep], theta_o[keep], theta_e[keep], power[keep], index[keep])
    cdf = np.cumsum(sorted_energy)
    em.tree_emitters = sorted_index.astype(np.int32)
    em.tree_cdf = (cdf / cdf[-1]).astype(np.float32)
    emitter_leaf = np.full(n, -1, np.int32)
    emitter_leaf[index[keep]] = leaf_of
    em.tree_power_share = float(em.power[index[keep]].sum() / em.total_power)
    em.info["n_tree"] = nodes.shape[0]
    em.info["tree_share"] = em.tree_power_share if em.info["far_energy"][0] > 0 else 1.0
    em.info["local_radius"] = 0.0        # the tree picks among the emissive triangles too
    em.tree, em.emitter_leaf = nodes, emitter_leaf
    em.tree_build_s = time.perf_counter() - t0
    return em


def local_share(em: Emitters, p, n) -> float:
    """Next-event estimation's probability of the local emitters at point p of normal n
    (kernels/light/light_mesh.h emitter_local_share, in float64: the tests' reference)."""
    from ppm_engine.scene.light_tree import importance, surely_lights
    far = float(em.info["far_energy"][0])
    if not far > 0:
        return 1.0
    if em.info["n_tree"][0] > 0:
        return float(em.info["tree_share"][0])
    loc = float(importance(em.local_bound, p, n)[0])
    if not loc > 0:
        return 0.0
    s = loc / (loc + far)
    if not em.info["has_world"][0]:
        return s
    return 0.5 * s + (0.5 if surely_lights(em.local_bound, p, n)[0] else 0.25)


def scene_bounds(positions: np.ndarray) -> tuple[np.ndarray, float]:
    """Centre and radius of a sphere around every finite triangle corner."""
    p = positions.reshape(-1, 3)
    if not np.isfinite(p).all():
        p = p[np.isfinite(p).all(axis=1)]
    if p.shape[0] == 0:
        return np.zeros(3, np.float32), 1.0
    lo, hi = (a.astype(np.float64) for a in corner_box(p))
    c = 0.5 * (lo + hi)
    r = 0.5 * float(np.linalg.norm(hi - lo))
    return c.astype(np.float32), max(r * 1.01, 1e-6 * max(1.0, float(np.abs(c).max())), 1e-30)


def spot_solid_angle(cos_half: np.ndarray, smooth: np.ndarray) -> np.ndarray:
    """Integral of Cycles' spot attenuation over the sphere (round cone)."""
    t = np.linspace(0.0, 1.0, 257)[None, :]
    c = cos_half[:, None] + (1.0 - cos_half[:, None]) * t
    with np.errstate(divide="ignore", invalid="ignore"):
        x = np.where(smooth[:, None] > 0,
                     np.clip((c - cos_half[:, None]) / smooth[:, None], 0, 1), 1.0)
    att = x * x * (3 - 2 * x)
    # the trapezoid rule (np.trapz is np.trapezoid from NumPy 2 on)
    integral = 0.5 * ((att[:, 1:] + att[:, :-1]) * np.diff(t, axis=1)).sum(axis=1)
    return 2 * np.pi * (1.0 - cos_half) * integral


def light_power(lights: np.ndarray, scene_radius: float) -> np.ndarray:
    emit = lights["emit"].astype(np.float64).mean(axis=1)
    t = lights["type"]
    ax, ay = lights["axis_x"].astype(np.float64), lights["axis_y"].astype(np.float64)
    area = np.linalg.norm(np.cross(ax, ay), axis=1) \
        * np.where(t == LIGHT_AREA_ELLIPSE, np.pi / 4, 1.0)
    p = np.zeros(lights.shape[0])
    p = np.where(t == LIGHT_POINT, 4 * np.pi * emit, p)
    spot = t == LIGHT_SPOT
    if spot.any():
        p[spot] = emit[spot] * spot_solid_angle(lights["spot_cos_half"][spot].astype(np.float64),
                                                lights["spot_smooth"][spot].astype(np.float64))
    p = np.where(t == LIGHT_SUN, emit * np.pi * scene_radius ** 2, p)
    p = np.where((t == LIGHT_AREA_RECT) | (t == LIGHT_AREA_ELLIPSE), np.pi * emit * area, p)
    return np.where(np.isfinite(p) & (p > 0), p, 0.0)


def far_reach(scene: SceneArrays, kmaterials: np.ndarray) -> float:
    """The share of the colour channels in which a sun's or the world's light reaches the
    scene through the world's medium (materials.world_medium): none where it has extinction,
    as Cycles renders light from infinitely far through it (the kernels' transmittance of an
    unbounded segment, per channel); 1 without one."""
    w = world_medium(scene)
    if w < 0 or not kmaterials["flags"][w] & MAT_VOLUME:
        return 1.0
    return float(((kmaterials["absorption"][w] + kmaterials["scattering"][w]) <= 0).mean())


def emits_light(scene: SceneArrays, kmaterials: np.ndarray) -> bool:
    """Whether anything in the scene emits: a light with power, an emissive triangle with area,
    an emitting world (build_emitters' table is not empty).  Needs no BVH, and no scene
    bounds: a sun's power (irradiance x the scene's cross-section) is positive exactly when its
    irradiance is."""
    world = np.nan_to_num(scene.world.astype(np.float64), nan=0.0, posinf=0.0)
    if world.max(initial=0.0) > 0 or scene.world_shader[0] > 0:
        return True                     # (a world's program: its map may be black)
    if (light_power(scene.lights, 1.0) > 0).any():
        return True
    glowing = kmaterials["volume_emission"].max(axis=1) > 0     # (media: MAT_VOLUME only)
    glowing |= field_glows(scene.svm, kmaterials["density_program"])
    if world_medium(scene) >= 0 and glowing[world_medium(scene)]:
        return True                     # an emitting world medium
    if glowing.any():
        m = scene.material[(scene.material >= 0) & (scene.material < glowing.shape[0])]
        if glowing[m].any():
            return True                 # an emitting medium (seen by eye paths only)
    emission = mean_emission(kmaterials, scene.textures, scene.texels).max(axis=1)
    if not (emission > 0).any():
        return False                    # (no emissive material at all: skip the triangles)
    tri = scene.material[(scene.material >= 0) & (scene.material < emission.shape[0])]
    if not (emission[tri] > 0).any():
        return False
    hot = (scene.material >= 0) & (scene.material < emission.shape[0])
    hot[hot] = emission[scene.material[hot]] > 0
    p = scene.positions[hot].astype(np.float64)
    area = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    return bool((np.isfinite(area) & (area > 0)).any())


def build_emitters(scene: SceneArrays, kmaterials: np.ndarray, leaf_order: np.ndarray,
                   world_map=None) -> Emitters:
    """``leaf_order[k]`` = original index of the triangle in BVH leaf k; ``world_map``: the
    importance map of the world's program (world_map.WorldMap), whose power it gives."""
    center, radius = scene_bounds(scene.positions)
    lp = light_power(scene.lights, radius)
    reach = far_reach(scene, kmaterials)
    lp = np.where(scene.lights["type"] == LIGHT_SUN, lp * reach, lp)

    # emissive triangles, in leaf order
    mat_of_leaf = scene.material[leaf_order]
    emission = mean_emission(kmaterials, scene.textures, scene.texels).mean(axis=1)
    leaf_em = emission[mat_of_leaf]
    cand = np.nonzero(leaf_em > 0)[0]
    p = scene.positions[leaf_order[cand]].astype(np.float64)
    tri_area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    tp = 2 * np.pi * leaf_em[cand] * tri_area          # both sides
    keep = np.isfinite(tp) & (tp > 0)
    emissive_leaves, tp = cand[keep].astype(np.int32), tp[keep]

    world = np.maximum(np.nan_to_num(scene.world.astype(np.float64), nan=0.0, posinf=0.0), 0.0)
    wp = 4 * np.pi ** 2 * radius ** 2 * world.mean()
    if world_map is not None:
        wp = np.pi * radius ** 2 * world_map.integral
    wp *= reach
    has_world = bool(wp > 0 and np.isfinite(wp))

    power = np.concatenate([lp, tp, [wp] if has_world else []])
    total = float(power.sum())
    n = power.shape[0]
    cdf = power_cdf(power)
    far = np.concatenate([scene.lights["type"] == LIGHT_SUN, np.zeros(tp.shape[0], bool),
                          [True] if has_world else []])
    # the far emitters' importance (EMITTER_INFO_DTYPE far_energy)
    is_sun = scene.lights["type"] == LIGHT_SUN
    far_energy = scene.lights["emit"][is_sun & (lp > 0)].astype(np.float64).mean(axis=1).sum()
    if has_world:
        far_energy += world_map.integral / 4.0 if world_map is not None else np.pi * world.mean()
    info = np.zeros(1, EMITTER_INFO_DTYPE)
    info["n_lights"] = scene.lights.shape[0]
    info["n_suns"] = int((scene.lights["type"] == LIGHT_SUN).sum())
    info["n_emissive"] = emissive_leaves.shape[0]
    info["has_world"] = int(has_world)
    info["n_emitters"] = n if total > 0 else 0
    info["world"] = world
    info["scene_center"] = center
    info["scene_radius"] = radius
    info["world_flags"] = scene.world_shader[1]
    info["world_medium"] = -1
    if 2 <= emissive_leaves.shape[0] <= LOCAL_PICK_MAX:
        v = scene.positions[leaf_order[emissive_leaves]].reshape(-1, 3).astype(np.float64)
        c = 0.5 * (v.min(axis=0) + v.max(axis=0))
        info["local_center"] = c
        info["local_radius"] = np.linalg.norm(v - c, axis=1).max()
    if world_map is not None:
        info["world_program"] = scene.world_shader[0]
        info["map_w"], info["map_h"] = world_map.width, world_map.height
        info["map_mean"] = world_map.mean
    info["far_energy"] = far_energy if np.isfinite(far_energy) else 0.0
    em = Emitters(info, cdf.astype(np.float32), emissive_leaves, power, total,
                  local_cdf=power_cdf(np.where(far, 0.0, power)).astype(np.float32),
                  far_cdf=power_cdf(np.where(far, power, 0.0)).astype(np.float32))
    return attach_light_tree(em, scene.lights,
                             scene.positions[leaf_order[emissive_leaves]],
                             mat_of_leaf[emissive_leaves])
