"""The scene on one device: the prepared arrays (scene/prep.py), the BVH, and the materials,
emitters, lights, textures, camera and pixel filter as buffers; the feature flags the passes'
kernels are specialised with (features.py); and ``args``, the scene's buffers by name.

SCENE_BUFFERS lists those buffers once.  kernels/shared.h gets it as the X-macro SCENE_DATA
(ppm_engine/tools/shared_header.py), from which kernels/scene.h makes the kernels' scene parameters
and the one struct every helper reads them from (``const Scene *scene``); Launch binds them by
name from ``args``.  A new buffer is one row here and its source in ``DeviceScene.upload``."""
from __future__ import annotations

import dataclasses

import numpy as np

from ppm_engine.render.bvh import BVH
from ppm_engine.render.features import VALUE_FEATURES, scene_features, used_materials
from ppm_engine.render.features import defines as feature_defines
from ppm_engine.render.film import filter_density, filter_table
from ppm_engine.render.medium_bound import bound_media, grid_majorants, media_boxes, pack_grids
from ppm_engine.render.world_map import bake, build_map, map_size
from ppm_engine.scene.arrays import (
    LIGHT_DTYPE,
    LIGHT_SUN,
    SHADER_NODE_DTYPE,
    TERMINATOR_OFFSET,
    TEXTURE_DTYPE,
    WORLD_MAP_MANUAL,
    SceneArrays,
)
from ppm_engine.scene.camera import CAMERA_DTYPE
from ppm_engine.scene.casters import caster_reach, caster_tree, caustic_cdf, material_weights
from ppm_engine.scene.emitters import EMITTER_INFO_DTYPE, build_emitters
from ppm_engine.scene.guide import Guides
from ppm_engine.scene.light_paths import LIGHT_PATHS_DTYPE, engine_defaults
from ppm_engine.scene.light_tree import LIGHT_TREE_NODE_DTYPE
from ppm_engine.scene.materials import (
    KMATERIAL_DTYPE,
    MAT_GATHER,
    MAT_VOLUME,
    follow_capable,
    kernel_materials,
    kernel_nodes,
    max_closures,
    world_medium,
)
from ppm_engine.scene.prep import corner_box, offset_scale, prepare_scene
from ppm_engine.scene.shader_program import ops_define, ops_used, stack_used
from ppm_engine.scene.shading_tables import load as shading_tables

_F4, _I4 = np.dtype((np.float32, 4)), np.dtype((np.int32, 4))


@dataclasses.dataclass(frozen=True)
class SceneBuffer:
    name: str             # the kernels' parameter and field name (scene->name)
    element: np.dtype     # one element as the kernels read it (its C type: shared_header)
    what: str             # what it holds (the upload's label, the header's comment)
    fill: int = 0         # the value of the one element that stands for an empty array
    default: object = None  # or a function making that element (a struct's defaults)


# The scene's buffers, in the kernels' parameter order.
SCENE_BUFFERS = (
    SceneBuffer("nodes", _F4, "BVH nodes, 4-wide (kernels/geom/bvh.h)"),
    SceneBuffer("tri_v0", _F4, "triangles in BVH leaf order: p0, original index"),
    SceneBuffer("tri_e1", _F4, "triangles: p1 - p0, visibility bits"),
    SceneBuffer("tri_e2", _F4, "triangles: p2 - p0, material"),
    SceneBuffer("normals", np.dtype(np.float32), "shading normals (3 corners per triangle)"),
    SceneBuffer("materials", KMATERIAL_DTYPE, "materials"),
    SceneBuffer("shader_nodes", SHADER_NODE_DTYPE, "shader nodes"),
    SceneBuffer("shading_tables", np.dtype(np.float32), "shading tables"),
    SceneBuffer("textures", TEXTURE_DTYPE, "textures"),
    SceneBuffer("texels", np.dtype(np.float16), "image textures (RGBA texels)"),
    SceneBuffer("uvs", np.dtype(np.float32), "UVs (3 corners per triangle)"),
    SceneBuffer("tangents", np.dtype(np.float32), "tangents (3 corners per triangle)"),
    SceneBuffer("svm", _I4, "shader programs"),
    SceneBuffer("uv_tangents", _F4, "UV tangents (3 corners per triangle)"),
    SceneBuffer("generated", np.dtype(np.float32), "Generated coordinates"),
    SceneBuffer("terminator", np.dtype(np.float32),
                "triangles' objects' Shadow Terminator Geometry Offset"),
    SceneBuffer("attributes", _F4, "mesh attributes"),
    SceneBuffer("tri_object", np.dtype(np.int32), "triangles' objects", fill=-1),
    SceneBuffer("objects", _F4, "objects"),
    SceneBuffer("voxels", np.dtype(np.float32), "Volume objects' grids (scene/voxels.py)"),
    SceneBuffer("camera", CAMERA_DTYPE, "camera"),
    SceneBuffer("light_paths", LIGHT_PATHS_DTYPE, "Light Paths settings",
                default=engine_defaults),
    SceneBuffer("lights", LIGHT_DTYPE, "lights"),
    SceneBuffer("emitter_cdf", np.dtype(np.float32), "emitter table (power CDF)"),
    SceneBuffer("emissive", np.dtype(np.int32), "emissive triangles' BVH leaves"),
    SceneBuffer("emitter_info", EMITTER_INFO_DTYPE, "emitter table header"),
    SceneBuffer("light_tree", LIGHT_TREE_NODE_DTYPE, "light tree (ppm_engine/scene/light_tree.py)"),
    SceneBuffer("emitter_leaf", np.dtype(np.int32), "each emitter's light tree leaf", fill=-1),
    SceneBuffer("local_cdf", np.dtype(np.float32),
                "power CDF of the local emitters (lights but suns, emissive triangles)"),
    SceneBuffer("far_cdf", np.dtype(np.float32), "power CDF of the far emitters (suns, the world)"),
    SceneBuffer("local_bound", LIGHT_TREE_NODE_DTYPE, "a light tree node bounding the local ones"),
    SceneBuffer("tree_emitters", np.dtype(np.int32), "the light tree's emitters in its order"),
    SceneBuffer("tree_cdf", np.dtype(np.float32), "their power's CDF in that order"),
    SceneBuffer("world_map", np.dtype(np.float32), "world importance map"),
    SceneBuffer("casters", _F4, "casters' bounding spheres (ppm_engine/scene/casters.py)"),
    SceneBuffer("caster_weight", np.dtype(np.float32), "casters' weights"),
    SceneBuffer("caustic_cdf", np.dtype(np.float32),
                "emitter table's CDF for aimed caustic photons (power toward the casters)"),
    SceneBuffer("guide", np.dtype(np.float32),
                "photon guides: each guided light's directions (ppm_engine/scene/guide.py)"),
    SceneBuffer("guide_slot", np.dtype(np.int32), "each light's photon guide (-1: none)",
                fill=-1),
)


_ROWS = {b.name: b for b in SCENE_BUFFERS}


def _one(b: SceneBuffer) -> np.ndarray:
    """One element of ``b``'s fill value: what stands for an empty array (OpenCL has no empty
    buffer) or a buffer a kernel is run without."""
    if b.default is not None:
        return b.default()
    a = np.zeros(1, b.element)
    if b.fill:
        a[...] = b.fill
    return a


def _as_elements(array: np.ndarray, b: SceneBuffer) -> np.ndarray:
    """``array`` checked to hold elements of ``b`` (its dtype the element's base type, its last
    axis the vector's length), or one element (``_one``) for an empty one."""
    a = np.ascontiguousarray(array)
    base, shape = b.element.base, b.element.shape
    if a.dtype != base or (shape and a.shape[-len(shape):] != shape):
        raise TypeError(f"scene buffer {b.name}: {a.dtype}{a.shape} is not made of {b.element}")
    return a if a.size else _one(b)


def placeholders(device, **given) -> dict:
    """The scene's buffers by name for kernels run without a DeviceScene (tests, the world
    map's bake, a gather with nothing to shade): ``given`` ones (device buffers), and for the
    rest one element each of their fill value."""
    unknown = set(given) - {b.name for b in SCENE_BUFFERS}
    if unknown:
        raise TypeError(f"not scene buffers: {sorted(unknown)}")
    return {b.name: given[b.name] if b.name in given else device.upload(_one(b), b.what)
            for b in SCENE_BUFFERS}


class DeviceScene:
    def __init__(self, device, scene: SceneArrays, specialize: bool = True):
        self.device = device
        self.specialize = specialize   # the world map's bake built for the world's own nodes
        prepared, self.warnings = prepare_scene(scene)   # NaN/Inf dropped (docs/STABILITY.md)
        self.bvh = BVH(device, prepared)
        self._caster_tree = None         # set_casters' CasterTree, kept by refits
        self.upload(scene, prepared)

    def upload(self, scene: SceneArrays, prepared: SceneArrays | None = None) -> None:
        """Everything but the BVH: materials, emitters, lights, camera, pixel filter."""
        self.scene = scene
        if prepared is None:
            prepared, self.warnings = prepare_scene(scene)
        self.prepared = prepared = prepared    # the BVH's triangles, moved as the BVH's
        self.knodes = kernel_nodes(prepared.shader_nodes)
        self.kmaterials = kernel_materials(prepared.materials, self.knodes,
                                           world_medium(prepared), prepared.svm)
        self.used_materials = used_materials(prepared, self.kmaterials.shape[0])
        self.offset_scale = offset_scale(prepared)
        b = self.bvh
        # each scene buffer's source (SCENE_BUFFERS): the BVH's are on the device already;
        # the scene's own arrays (never written to) again the same: their buffers kept (an
        # edit's export hands on what did not change: the image's texels, a value edit's mesh)
        args = self._upload(
            reuse=True, **b.args, normals=prepared.normals, materials=self.kmaterials,
            shader_nodes=self.knodes, shading_tables=shading_tables(), textures=prepared.textures,
            texels=prepared.texels, uvs=prepared.uvs, tangents=prepared.tangents,
            svm=prepared.svm, uv_tangents=prepared.uv_tangents, generated=prepared.generated,
            attributes=prepared.attributes, tri_object=prepared.object, objects=prepared.objects,
            voxels=prepared.voxels,
            terminator=(prepared.terminator if prepared.terminator.size else
                        np.full(prepared.n_triangles, TERMINATOR_OFFSET, np.float32)),
            camera=prepared.camera, light_paths=prepared.light_paths)
        # heterogeneous media: their majorants bounded with the shading buffers, their grids
        # after the Volume objects' (a density that is a grid by its voxels, on the host)
        boxes = media_boxes(prepared.positions, prepared.material, self.kmaterials)
        if boxes:
            grids = grid_majorants(prepared.svm, self.kmaterials, prepared.objects,
                                   prepared.voxels, boxes)
            grids.update(bound_media(self.device, placeholders(self.device, **args),
                                     prepared.svm, self.kmaterials, boxes, self.specialize))
            words = pack_grids(self.kmaterials, grids, prepared.voxels.size)
            args.update(self._upload(materials=self.kmaterials, **(
                {"voxels": np.concatenate([prepared.voxels, words])} if words.size else {})))
        # the world's map is baked with the shading buffers; the emitter table needs its power
        self.world_map = self._world_map(prepared, args)
        self.emitters = em = build_emitters(prepared, self.kmaterials, self.bvh.leaf_order,
                                            self.world_map)
        em.info["offset_scale"] = self.offset_scale
        em.info["n_media"] = int(((self.kmaterials["flags"][self.used_materials] & MAT_VOLUME)
                                  != 0).sum())
        em.info["world_medium"] = self.world_medium()
        em.info["n_attributes"] = prepared.attributes.shape[2]
        args.update(self._upload(
            lights=prepared.lights, emitter_cdf=em.cdf, emissive=em.emissive_leaves,
            emitter_info=em.info, light_tree=em.tree, emitter_leaf=em.emitter_leaf,
            local_cdf=em.local_cdf, far_cdf=em.far_cdf, local_bound=em.local_bound,
            tree_emitters=em.tree_emitters, tree_cdf=em.tree_cdf,
            world_map=(self.world_map.buffer if self.world_map is not None
                       else np.zeros(0, np.float32)),
            casters=np.zeros((0, 4), np.float32), caster_weight=np.zeros(0, np.float32),
            caustic_cdf=np.zeros(0, np.float32)))
        # the lights whose photons a render may guide (Renderer.learn_guides)
        self.guides = Guides(prepared.lights, em.power)
        args.update(self._upload(guide=self.guides.table(), guide_slot=self.guides.slot))
        self._casters_key = None         # set_casters' options: none for a new upload
        self.args = {b.name: args[b.name] for b in SCENE_BUFFERS}
        self.camera = args["camera"]
        self.light_paths = prepared.light_paths
        self._upload_filter(prepared.camera)

    def set_casters(self, gather_roughness: float, caustic_roughness: float) -> int:
        """The casters caustic photons are aimed at for these options (casters.py: the surfaces
        whose closures follow_capable finds, as bounding spheres), their weights and the
        emitters' CDF by power toward them, uploaded with the emitter table's header (its
        n_casters).  Nothing is built: a moved caster (refit) or another roughness needs only
        this.  Returns the number of spheres."""
        key = (gather_roughness, caustic_roughness, int(self.light_paths["flags"][0]))
        if key == self._casters_key:
            if not np.array_equal(self.caster_weights, self.caster_static):
                self.set_caster_weights(self.caster_static)     # a new render's start
            return int(self.emitters.info["n_casters"][0])
        p, em = self.prepared, self.emitters
        mw = material_weights(self.knodes, self.kmaterials.shape[0], gather_roughness,
                              caustic_roughness, key[2])
        m = p.material
        ok = (m >= 0) & (m < mw.shape[0])
        tri_w = np.zeros(m.shape[0], np.float32)
        tri_w[ok] = mw[m[ok]]
        corners = p.positions.reshape(-1, 3, 3)
        # the same triangles moved (refit): the tree of their splits kept, its cut chosen at
        # the new positions; else (or when that tree got too loose) the tree built
        tree = (self._caster_tree.refit(corners, tri_w) if self._caster_tree is not None
                else None)
        self._caster_tree = tree = tree or caster_tree(corners, tri_w)
        self.caster_spheres, self.caster_static = (a.copy() for a in tree.result)
        em.info["n_casters"] = self.caster_spheres.shape[0]
        # the emissive triangles' corners in the emitter table's order, for caster_reach at
        # every change of weights
        self._emissive_corners = p.positions.reshape(-1, 3, 3)[
            self.bvh.leaf_order[em.emissive_leaves]]
        self.args.update(self._upload(casters=self.caster_spheres, emitter_info=em.info))
        self.set_caster_weights(self.caster_static)
        self._casters_key = key
        return self.caster_spheres.shape[0]

    def set_caster_weights(self, weights: np.ndarray) -> None:
        """Other weights for the casters of set_casters (Renderer.learn_caster_weights: what
        the photons aimed at each stored), uploaded with the emitters' CDF toward them."""
        p, em = self.prepared, self.emitters
        self.caster_weights = w = np.asarray(weights, np.float32)
        self.caster_reach = caster_reach(p.lights, self._emissive_corners,
                                         bool(em.info["has_world"][0]),
                                         float(em.info["scene_radius"][0]), self.caster_spheres, w)
        # the share of uniform photons that would reach a caster (weighted)
        total = float(em.power.sum())
        self.caster_share = (float(np.minimum(self.caster_reach, 1.0) @ em.power) / total
                             if total > 0 else 0.0)
        self.args.update(self._upload(caster_weight=w,
                                      caustic_cdf=caustic_cdf(em.power, self.caster_reach)))

    def upload_guides(self) -> None:
        """The photon guides' table again (Renderer.learn_guides, or a new render's reset)."""
        self.args.update(self._upload(guide=self.guides.table()))

    def set_camera(self, scene: SceneArrays) -> None:
        """``scene`` is the current one with another camera (the viewport's view; its other
        arrays the same): only the camera is uploaded, and the pixel filter when the film's
        filter changed.  prepare_scene's shift of a far-from-origin scene is applied to it
        too."""
        from ppm_engine.scene.prep import check_camera
        cam = np.array(scene.camera, copy=True)
        check_camera(cam)
        old_t = self.scene.camera["to_world"][0, :, 3].astype(np.float64)
        shift = np.float32(old_t - self.prepared.camera["to_world"][0, :, 3])  # 0: not moved
        cam["to_world"][0, :, 3] = cam["to_world"][0, :, 3].astype(np.float64) - shift
        filter_changed = any(cam[f][0] != self.prepared.camera[f][0]
                             for f in ("filter_width", "filter_type"))
        self.scene = scene
        self.prepared = self.prepared.replace(camera=cam)
        self.args["camera"] = self.camera = self.device.upload(
            _as_elements(cam, _ROWS["camera"]), _ROWS["camera"].what)
        if filter_changed:
            self._upload_filter(cam)

    def _upload_filter(self, cam: np.ndarray) -> None:
        """The pixel filter's table, and its density for the photons' light tracing
        (camera_connect.h), from the camera's film."""
        width, kind = float(cam["filter_width"][0]), int(cam["filter_type"][0])
        self.filter_table = self.device.upload(filter_table(width, kind), "pixel filter")
        density, self.filter_reach = filter_density(width, kind)
        self.filter_density = self.device.upload(density, "pixel filter density")

    def _upload(self, reuse: bool = False, **sources) -> dict:
        """Scene buffers by name (SCENE_BUFFERS) from arrays, or device buffers as they are.
        ``reuse``: an array that is the very one uploaded under its name by the last such
        call keeps its buffer (only for arrays nobody writes to)."""
        rows, out = {b.name: b for b in SCENE_BUFFERS}, {}
        kept = getattr(self, "_kept", {})
        for name, a in sources.items():
            if not isinstance(a, np.ndarray):
                out[name] = a
            elif reuse and name in kept and kept[name][0] is a:
                out[name] = kept[name][1]
            else:
                out[name] = self.device.upload(_as_elements(a, rows[name]), rows[name].what)
        if reuse:
            self._kept = {n: (a, out[n]) for n, a in sources.items() if isinstance(a, np.ndarray)}
        return out

    def _world_map(self, prepared: SceneArrays, args: dict):
        """The world program's importance map baked on the device, or None (a constant
        world)."""
        ws = prepared.world_shader
        if ws[0] <= 0:
            return None
        w, h = map_size(int(ws[2]), int(ws[3]), bool(ws[1] & WORLD_MAP_MANUAL))
        return build_map(bake(self.device, placeholders(self.device, **args), prepared.svm,
                              int(ws[0]), w, h, self.specialize))

    def kernel_defines(self, specialize: bool,
                       editable: bool = False) -> tuple[frozenset | None, dict]:
        """(features, -D flags) of the eye and photon passes: the scene's features, or every
        feature (None) unspecialised (the roughness from which lobes are gathered is the Light
        Paths record's, light_paths.with_roughness: no flag).
        ``editable``: the scene's features and every one an edit of values can switch on
        (features.VALUE_FEATURES), the longest closure list, the shader programs' stack
        rounded up to a power of two: what a value edit changes needs no build.
        (The ray offsets' scale is the scene's EmitterInfo.offset_scale, not a flag: scenes of
        any size share their programs.)"""
        features = (scene_features(self.prepared, self.kmaterials, self.knodes, self.emitters,
                                   self.used_materials) if specialize else None)
        if features is not None and editable:
            features = features | VALUE_FEATURES
        svm = {}
        if features is not None and "PPM_SVM" in features:
            starts = [*self.kmaterials["program"][self.used_materials],
                      *self.kmaterials["density_program"][self.used_materials],
                      int(self.emitters.info["world_program"][0])]
            stack = max(stack_used(self.prepared.svm, starts), 1)
            if editable:
                stack = max(1 << (stack - 1).bit_length(), 16)
            svm = {"PPM_SVM_OPS": ops_define(ops_used(self.prepared.svm, starts)),
                   "PPM_SVM_STACK": stack}
        # room for the mesh attributes: a specialised build's is the scene's stride of
        # `attributes`; every feature's has room for any scene's (EmitterInfo.n_attributes)
        if features is not None and self.prepared.attributes.shape[2]:
            svm["PPM_ATTRIBUTES"] = self.prepared.attributes.shape[2]
        return features, {**feature_defines(features, None if editable else
                                            max_closures(self.knodes, self.used_materials)),
                          **svm}

    def set_light_paths(self, lp: np.ndarray) -> None:
        """The Light Paths record the kernels read from now on (a render's: the scene's, with
        RenderOptions.max_bounces in force, light_paths.with_max_bounces, and its roughness
        settings, with_roughness)."""
        if lp.tobytes() != self.light_paths.tobytes():
            self.light_paths = lp
            self.args["light_paths"] = self.device.upload(
                _as_elements(lp, _ROWS["light_paths"]), _ROWS["light_paths"].what)

    def photons_useful(self) -> bool:
        """Whether photon passes can add anything: something emits, paths may bounce (the
        visible point's own bounce is a diffuse, glossy or transmission one), and some surface
        has a closure the gather evaluates (photons are stored, and visible points made, only
        there)."""
        lp = self.light_paths[0]
        bounce = lp["max_bounces"] > 0 and max(lp["diffuse_bounces"], lp["glossy_bounces"],
                                               lp["transmission_bounces"]) > 0
        diffuse = bool((self.kmaterials["flags"][self.used_materials] & MAT_GATHER).any())
        # or volume photons (passes/volume.py): a scattering medium and Volume bounces
        media = lp["volume_bounces"] > 0 and self.media_box() is not None
        return bool(self.emitters.info["n_emitters"][0] > 0 and bounce and (diffuse or media))

    def media_box(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The box (lo, hi) around the triangles of the used scattering media, or None; with a
        scattering world medium, around every triangle, light and the camera, grown by the
        medium's mean free path (at most the box's size): the world's medium fills all space,
        its photons are gathered in there (volume_gather.cl clips the camera's segments to
        it)."""
        p, km = self.prepared, self.kmaterials
        scatters = (km["flags"] & MAT_VOLUME != 0) & (km["scattering"].max(axis=1) > 0)
        w = self.world_medium()
        if w >= 0 and scatters[w]:
            lamps = p.lights["position"][p.lights["type"] != LIGHT_SUN]
            pts = np.concatenate([p.positions.reshape(-1, 3), lamps,
                                  p.camera["to_world"][:, :, 3]]).astype(np.float64)
            lo, hi = pts.min(axis=0), pts.max(axis=0)
            sigma_t = float((km["absorption"][w] + km["scattering"][w]).min())
            grow = min(1.0 / sigma_t if sigma_t > 0 else np.inf, float((hi - lo).max()))
            return lo - grow, hi + grow
        tris = p.positions[scatters[p.material]]
        if not len(tris):
            return None
        pts = tris.reshape(-1, 3)
        return pts.min(axis=0).astype(np.float64), pts.max(axis=0).astype(np.float64)

    def world_medium(self) -> int:
        """The material row of the world's medium where it has one (materials.world_medium and
        MAT_VOLUME: a density above 0), else -1 (kernels/integrator/shadow_rays.h media_at)."""
        w = world_medium(self.prepared)
        return w if w >= 0 and self.kmaterials["flags"][w] & MAT_VOLUME else -1

    def has_media(self) -> bool:
        """Whether some used material has a medium of the volume stack (materials.MAT_VOLUME)."""
        return bool(self.emitters.info["n_media"][0] > 0)

    def caustics_possible(self, gather_roughness: float, caustic_roughness: float = 0.7) -> bool:
        """Whether some surface has a closure that makes caustics (materials.follow_capable):
        the only place a caustic photon (photon_pass.cl, caustics_only) can start."""
        used = np.isin(self.knodes["material"], self.used_materials)
        return bool(follow_capable(self.knodes[used], gather_roughness, caustic_roughness).any())

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The prepared scene's bounding box (float32 corners, w = 0)."""
        pos = self.prepared.positions.reshape(-1, 3)
        lo, hi = np.zeros(4, np.float32), np.zeros(4, np.float32)
        if pos.shape[0]:
            lo[:3], hi[:3] = corner_box(pos)
        return lo, hi

    @staticmethod
    def same_geometry(a: SceneArrays, b: SceneArrays) -> bool:
        """True when the BVH of ``a`` serves ``b`` (same triangles, materials, visibility)."""
        return all(getattr(a, k) is getattr(b, k) or np.array_equal(getattr(a, k), getattr(b, k))
                   for k in ("positions", "material", "visibility"))

    def refit(self, scene: SceneArrays) -> bool:
        """The same triangles moved or deformed: the BVH refitted over its hierarchy and the
        scene re-uploaded.  False (nothing changed) when the triangle count differs or the
        refitted tree would be too slow (bvh.BVH.refit)."""
        prepared, warnings = prepare_scene(scene)
        if prepared.n_triangles != self.bvh.n_triangles or not self.bvh.refit(prepared):
            return False
        self.warnings = warnings
        self.upload(scene, prepared)
        return True

    def buffers(self) -> list:
        """The device buffers this object owns (BVH's included), for release."""
        return [*self.args.values(), self.filter_table, self.filter_density]
