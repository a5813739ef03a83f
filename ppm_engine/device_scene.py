"""The scene on one device: the prepared arrays (scene_prep.py), the BVH, and the materials,
emitters, lights, textures, camera and pixel filter as buffers; the feature flags the passes'
kernels are specialised with (features.py); and ``args``, the scene arguments every pass kernel
takes (kernels/scene.h SCENE_ARGS), by name."""
from __future__ import annotations

import numpy as np

from .bvh import BVH
from .emitters import build_emitters
from .features import defines as feature_defines, scene_features, used_materials
from .film import filter_table
from .materials import (MAT_GATHER, follow_capable, kernel_materials, kernel_nodes,
                        max_closures)
from .shader_program import ops_define, ops_used, stack_used
from .shading_tables import load as shading_tables
from .scene_arrays import LIGHT_DTYPE, TEXTURE_DTYPE, SceneArrays
from .scene_prep import offset_scale, prepare_scene
from .world_map import bake, build_map, map_size


class DeviceScene:
    def __init__(self, device, scene: SceneArrays):
        self.device = device
        prepared, self.warnings = prepare_scene(scene)   # NaN/Inf dropped (docs/STABILITY.md)
        self.bvh = BVH(device, prepared)
        self.upload(scene, prepared)

    def upload(self, scene: SceneArrays, prepared: SceneArrays | None = None) -> None:
        """Everything but the BVH: materials, emitters, lights, camera, pixel filter."""
        up = self.device.upload
        self.scene = scene
        if prepared is None:
            prepared, self.warnings = prepare_scene(scene)
        self.prepared = prepared = prepared    # the BVH's triangles, moved as the BVH's
        self.knodes = kernel_nodes(prepared.shader_nodes)
        self.kmaterials = kernel_materials(prepared.materials, self.knodes)
        self.used_materials = used_materials(prepared, self.kmaterials.shape[0])
        self.offset_scale = offset_scale(prepared)
        b = self.bvh
        lights = prepared.lights if prepared.lights.shape[0] else np.zeros(1, LIGHT_DTYPE)
        # names and order: kernels/scene.h SCENE_ARGS (the BVH's own: kernels/bvh.h BVH_ARGS)
        args = dict(
            nodes=b.nodes, tri_v0=b.tri_v0, tri_e1=b.tri_e1, tri_e2=b.tri_e2,
            normals=up(prepared.normals, "shading normals"),
            # kernels/shader_data.h SHADING_ARGS
            materials=up(self.kmaterials, "materials"),
            shader_nodes=up(self.knodes if self.knodes.size else np.zeros(1, self.knodes.dtype),
                            "shader nodes"),
            shading_tables=up(shading_tables(), "shading tables"),
            textures=up(prepared.textures if prepared.textures.size
                        else np.zeros(1, TEXTURE_DTYPE), "textures"),
            texels=up(prepared.texels if prepared.texels.size
                      else np.zeros((1, 4), np.float16), "image textures"),
            uvs=up(prepared.uvs, "UVs"),
            tangents=up(prepared.tangents if prepared.tangents.size
                        else np.zeros(9, np.float32), "tangents"),
            svm=up(prepared.svm, "shader programs"),
            uv_tangents=up(prepared.uv_tangents if prepared.uv_tangents.size
                           else np.zeros(4, np.float32), "UV tangents"),
            generated=up(prepared.generated if prepared.generated.size
                         else np.zeros(3, np.float32), "Generated coordinates"),
            attributes=up(prepared.attributes if prepared.attributes.size
                          else np.zeros(4, np.float32), "mesh attributes"),
            tri_object=up(prepared.object if prepared.object.size else np.full(1, -1, np.int32),
                          "triangles' objects"),
            objects=up(prepared.objects if prepared.objects.size else np.zeros(4, np.float32),
                       "objects"),
            camera=up(prepared.camera, "camera"))
        self.world_map = self._world_map(prepared, args)
        self.emitters = em = build_emitters(prepared, self.kmaterials, self.bvh.leaf_order,
                                            self.world_map)
        em.info["offset_scale"] = self.offset_scale
        self.args = dict(
            args,
            lights=up(lights, "lights"),
            emitter_cdf=up(em.cdf if em.cdf.size else np.zeros(1, np.float32), "emitters"),
            emissive=up(em.emissive_leaves if em.emissive_leaves.size else np.zeros(1, np.int32),
                        "emissive triangles"),
            emitter_info=up(em.info, "emitters"),
            world_map=up(self.world_map.buffer if self.world_map is not None
                         else np.zeros(4, np.float32), "world map"))
        self.camera = args["camera"]
        self.filter_table = up(filter_table(float(prepared.camera["filter_width"][0]),
                                             int(prepared.camera["filter_type"][0])),
                               "pixel filter")

    def _world_map(self, prepared: SceneArrays, args: dict):
        """The world program's importance map baked on the device, or None (a constant
        world)."""
        ws = prepared.world_shader
        if ws[0] <= 0:
            return None
        w, h = map_size(int(ws[2]), int(ws[3]))
        return build_map(bake(self.device, args, prepared.svm, int(ws[0]), w, h))

    def kernel_defines(self, specialize: bool, gather_roughness: float = 0.7
                       ) -> tuple[frozenset | None, dict]:
        """(features, -D flags) of the eye and photon passes: the scene's features, or every
        feature (None) unspecialised; the roughness from which lobes are gathered either way.
        (The ray offsets' scale is the scene's EmitterInfo.offset_scale, not a flag: scenes of
        any size share their programs.)"""
        features = (scene_features(self.prepared, self.kmaterials, self.knodes, self.emitters,
                                   self.used_materials) if specialize else None)
        svm = {}
        if features is not None and "PPM_SVM" in features:
            starts = [*self.kmaterials["program"][self.used_materials],
                      int(self.emitters.info["world_program"][0])]
            svm = {"PPM_SVM_OPS": ops_define(ops_used(self.prepared.svm, starts)),
                   "PPM_SVM_STACK": max(stack_used(self.prepared.svm, starts), 1)}
        if self.prepared.attributes.shape[2]:     # the stride of `attributes`, always exact
            svm["PPM_ATTRIBUTES"] = self.prepared.attributes.shape[2]
        return features, {"PPM_GATHER_ROUGHNESS": float(gather_roughness).hex() + "f",
                          **feature_defines(features, max_closures(self.knodes,
                                                                   self.used_materials)),
                          **svm}

    def photons_useful(self, max_bounces: int) -> bool:
        """Whether photon passes can add anything: something emits, paths may bounce, and some
        surface has a closure the gather evaluates (photons are stored, and visible points
        made, only there)."""
        diffuse = bool((self.kmaterials["flags"][self.used_materials] & MAT_GATHER).any())
        return bool(self.emitters.info["n_emitters"][0] > 0 and max_bounces > 0 and diffuse)

    def caustics_possible(self, gather_roughness: float) -> bool:
        """Whether some surface has a closure eye paths follow (materials.follow_capable): the
        only place a caustic photon (photon_pass.cl, caustics_only) can start."""
        used = np.isin(self.knodes["material"], self.used_materials)
        return bool(follow_capable(self.knodes[used], gather_roughness).any())

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The prepared scene's bounding box (float32 corners, w = 0)."""
        pos = self.prepared.positions.reshape(-1, 3)
        lo, hi = np.zeros(4, np.float32), np.zeros(4, np.float32)
        if pos.shape[0]:
            lo[:3], hi[:3] = pos.min(axis=0), pos.max(axis=0)
        return lo, hi

    @staticmethod
    def same_geometry(a: SceneArrays, b: SceneArrays) -> bool:
        """True when the BVH of ``a`` serves ``b`` (same triangles, materials, visibility)."""
        return all(np.array_equal(getattr(a, k), getattr(b, k))
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
        return [*self.args.values(), self.filter_table]
