"""The contract between the Blender export and the bpy-free core.

``SceneArrays`` holds everything a render needs as immutable NumPy arrays in world space and in
physical units (Cycles' conventions already applied by the exporter).  The core never reads
Blender; tests, the CLI and the benchmark can build a ``SceneArrays`` by hand or load one from
``.npz``.

Structured dtypes contain only 4-byte scalars (and fixed arrays of them) so that the C structs
generated from them (``kernels/shared.h``, ppm_engine/tools/shared_header.py) have no padding
(tests/test_shared_header.py checks every field's offset on the device).
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from ppm_engine.scene.camera import (  # noqa: F401 (re-exported)
    CAMERA_DTYPE,
    CAMERA_ORTHO,
    CAMERA_PERSP,
    FILM_TRANSPARENT,
    FILM_TRANSPARENT_GLASS,
    FILTER_BLACKMAN_HARRIS,
    FILTER_BOX,
    FILTER_GAUSSIAN,
)
from ppm_engine.scene.light_paths import (
    CAUSTIC_ROUGHNESS,
    GATHER_ROUGHNESS,
    LIGHT_PATHS_DTYPE,
    check_light_paths,
    engine_defaults,
)
from ppm_engine.scene.voxels import check_objects

# --- triangle visibility bits (Blender's Object.visible_* ray flags) -------------------------
VIS_CAMERA = 1
VIS_DIFFUSE = 2
VIS_GLOSSY = 4
VIS_TRANSMISSION = 8
VIS_SHADOW = 16
VIS_ALL = VIS_CAMERA | VIS_DIFFUSE | VIS_GLOSSY | VIS_TRANSMISSION | VIS_SHADOW

# --- light types --------------------------------------------------------------------------------
LIGHT_POINT = 0
LIGHT_SPOT = 1
LIGHT_SUN = 2
LIGHT_AREA_RECT = 3      # SQUARE and RECTANGLE
LIGHT_AREA_ELLIPSE = 4   # DISK and ELLIPSE

LIGHT_FLAG_SOFT_FALLOFF = 1   # point/spot with radius > 0: Cycles' "soft falloff" disk model
# flags bit (VIS_x << LIGHT_HIDDEN_SHIFT): the light is not seen by rays of type VIS_x (the
# light object's visible_camera / visible_glossy / visible_transmission off)
LIGHT_HIDDEN_SHIFT = 8
WORLD_HIDDEN_CAMERA = 1       # world_shader[1]: the world's Ray Visibility > Camera off
WORLD_MAP_MANUAL = 2          # world_shader[1]: [2:4] the map's size (Cycles' Sampling: Manual)
WORLD_MEDIUM = 4              # world_shader[1]: the last material is the world's Volume medium

OBJECT_ROWS = 11    # float4 rows of one object as programs read it (export/objects.py)

# A material: its BSDF nodes are rows of ``SceneArrays.shader_nodes`` (material = its index);
# what belongs to the material as a whole is here.
MATERIAL_DTYPE = np.dtype([
    # the material's Volume output, its medium (export/material_volume.py): absorption per metre
    # (RGB; entered and left by refraction or at a volume's transparent boundary)
    ("absorption", np.float32, 3),
    ("program", np.int32),    # first word of its shader program in SceneArrays.svm, 0 = none
    # scattering per metre (RGB), the Henyey-Greenstein anisotropy g, radiance emitted per metre
    ("scattering", np.float32, 3),
    ("anisotropy", np.float32),
    ("volume_emission", np.float32, 3),
    # a heterogeneous medium: the first word of its density's program (a Density driven by
    # nodes), scaling absorption and scattering (0: none); the 1-based row of ``objects`` whose
    # space it reads (0: none)
    ("density_program", np.int32),
    ("volume_object", np.int32),
])

# BSDF node types (kernels/shared.h NODE_*)
NODE_PRINCIPLED = 0
NODE_DIFFUSE = 1
NODE_GLOSSY = 2         # Glossy BSDF (GGX or Multiscatter GGX; anisotropy in [-1, 1])
NODE_METALLIC = 3       # Metallic BSDF (F82 tint, or a physical conductor)
NODE_GLASS = 4
NODE_REFRACTION = 5
NODE_TRANSLUCENT = 6
NODE_TRANSPARENT = 7
NODE_SHEEN = 8
NODE_EMISSION = 9
NODE_HOLDOUT = 10
NODE_TYPES = ("principled", "diffuse", "glossy", "metallic", "glass", "refraction", "translucent",
              "transparent", "sheen", "emission", "holdout")
NODE_FLAG_MULTI_GGX = 1     # multiple scattering compensated ("Multiscatter GGX")
NODE_FLAG_CONDUCTOR = 2     # Metallic BSDF, Physical Conductor: color = n, edge_tint = k
# its material has Cycles' Bump Map Correction off (Material > Settings): its glossy normals are
# not raised for valid reflections (kernels/svm/shader_inputs.h specular_normal)
NODE_FLAG_NO_BUMP_CORRECTION = 4
# the transparent surface of a material with only a Volume output (its medium's boundary: no
# transparent bounce, as Cycles; materials.MAT_BOUNDARY)
NODE_FLAG_VOLUME_BOUNDARY = 8


# One BSDF node of a material, its inputs constant (textures: 1-based into ``textures``, the
# texture's value multiplies the input), the Mix and Add Shaders to the output folded into
# ``weight``.  Fields a node type has no input for are ignored.
SHADER_NODE_DTYPE = np.dtype([
    ("material", np.int32),
    ("type", np.int32),                 # NODE_*
    ("flags", np.uint32),               # NODE_FLAG_*
    ("weight", np.float32),             # mix weight
    ("color", np.float32, 3),           # Base Color / Color (linear RGB); conductor: n
    ("edge_tint", np.float32, 3),       # Principled Specular Tint, Metallic Edge Tint; conductor: k
    ("emission", np.float32, 3),        # emission colour x strength, W/(m^2 sr)
    ("coat_tint", np.float32, 3),
    ("sheen_tint", np.float32, 3),
    ("roughness", np.float32),
    ("metallic", np.float32),
    ("ior", np.float32),
    ("alpha", np.float32),
    ("transmission", np.float32),       # Principled "Transmission Weight"
    ("specular_ior_level", np.float32),
    ("anisotropic", np.float32),
    ("anisotropic_rotation", np.float32),
    ("coat_weight", np.float32),
    ("coat_roughness", np.float32),
    ("coat_ior", np.float32),
    ("sheen_weight", np.float32),
    ("sheen_roughness", np.float32),
    ("subsurface_weight", np.float32),
    ("diffuse_roughness", np.float32),
    ("color_texture", np.int32),        # 1-based textures multiplying color, emission, alpha
    ("emission_texture", np.int32),
    ("alpha_texture", np.int32),        # the texture's alpha channel multiplies ``alpha``
    ("bound", np.uint32),               # inputs its program drives (shader_program.BOUND)
    # the Normal and Coat Normal inputs (world space, on the viewer's side as Cycles' N): zero
    # when unlinked, the surface's shading normal then
    ("normal", np.float32, 3),
    ("coat_normal", np.float32, 3),
])


# Blender 4.x/5.0's defaults of the inputs that differ from shader_node's base values, per type
_NODE_DEFAULTS = {
    NODE_PRINCIPLED: dict(roughness=0.5, flags=NODE_FLAG_MULTI_GGX),
    NODE_GLOSSY: dict(roughness=0.5, flags=NODE_FLAG_MULTI_GGX),
    NODE_METALLIC: dict(roughness=0.5, flags=NODE_FLAG_MULTI_GGX, color=(0.617, 0.577, 0.54),
                        edge_tint=(0.695, 0.726, 0.77)),
    NODE_GLASS: dict(color=1.0, flags=NODE_FLAG_MULTI_GGX),
    NODE_REFRACTION: dict(color=1.0, ior=1.45),
    NODE_TRANSPARENT: dict(color=1.0),
    NODE_SHEEN: dict(roughness=0.5),
    NODE_EMISSION: dict(color=1.0),
}


def shader_node(type: int, material: int = 0, weight: float = 1.0, **inputs) -> np.ndarray:
    """One SHADER_NODE_DTYPE row with Blender's defaults for the inputs not given (each node
    as it is added in Blender 4.x/5.0)."""
    n = np.zeros(1, SHADER_NODE_DTYPE)
    n["material"], n["type"], n["weight"] = material, type, weight
    n["color"] = 0.8
    n["edge_tint"] = n["coat_tint"] = n["sheen_tint"] = 1.0
    n["ior"] = 1.5
    n["alpha"] = 1.0
    n["specular_ior_level"] = 0.5
    n["coat_roughness"] = 0.03
    n["coat_ior"] = 1.5
    n["sheen_roughness"] = 0.5
    for k, v in {**_NODE_DEFAULTS.get(type, {}), **inputs}.items():
        n[k] = v
    return n


# The material fields of files written before the shader nodes (a Principled BSDF's inputs);
# SceneArrays.load turns them into one Principled node each, without its specular layer (the
# model those files were rendered with).
_LEGACY_MATERIAL_FIELDS = ("base_color", "emission", "metallic", "roughness", "transmission",
                           "ior", "base_color_texture", "emission_texture")


def legacy_nodes(materials: np.ndarray) -> np.ndarray:
    rows = []
    for i, m in enumerate(materials):
        rows.append(shader_node(
            NODE_PRINCIPLED, i, color=m["base_color"], emission=m["emission"],
            metallic=m["metallic"], roughness=m["roughness"], transmission=m["transmission"],
            ior=m["ior"], specular_ior_level=0.0, color_texture=m["base_color_texture"],
            emission_texture=m["emission_texture"]))
    return np.concatenate(rows) if rows else np.zeros(0, SHADER_NODE_DTYPE)


# Image textures: texels of every texture one after another in ``SceneArrays.texels``, (N, 4)
# float16 RGBA (linear, or sRGB-encoded with TEX_FLAG_SRGB), rows bottom-up as Blender stores
# them (v = 0 is the bottom row).
TEX_REPEAT, TEX_EXTEND, TEX_CLIP, TEX_MIRROR = 0, 1, 2, 3     # Image Texture node "extension"
TEX_FLAG_CLOSEST = 16                                          # interpolation 'Closest'
# texels hold sRGB-encoded values, decoded after interpolation (8-bit sRGB images, as Cycles'
# byte textures: so our image matches Cycles' at texel edges)
TEX_FLAG_SRGB = 32
TEX_FLAG_CUBIC = 64                 # interpolation 'Cubic' or 'Smart' (Cycles' cubic B-spline)
TEXTURE_DTYPE = np.dtype([
    ("offset", np.int32),             # first texel in ``texels``
    ("width", np.int32),
    ("height", np.int32),
    ("flags", np.uint32),             # TEX_REPEAT.. | TEX_FLAG_CLOSEST, _CUBIC, _SRGB
])

TERMINATOR_OFFSET = 0.1   # Cycles' default Shadow Terminator > Geometry Offset (SceneArrays)

# ``emit`` depends on the type: POINT/SPOT radiant intensity in W/sr (Cycles: P/(4 pi)),
# SUN irradiance in W/m^2 on a surface facing it, AREA radiance in W/(m^2 sr).
LIGHT_DTYPE = np.dtype([
    ("type", np.int32),
    ("flags", np.uint32),
    ("emit", np.float32, 3),
    ("position", np.float32, 3),      # world position (sun: unused)
    ("direction", np.float32, 3),     # unit vector the light points along (object -Z)
    ("axis_x", np.float32, 3),        # AREA: edge vector along X (size x scale); SPOT: X column
    ("axis_y", np.float32, 3),        # AREA: full edge vector along Y; SPOT: scaled Y column
    ("radius", np.float32),           # POINT/SPOT: sphere radius; SUN: half its angle (rad)
    ("spot_cos_half", np.float32),    # SPOT: cos(spot_size / 2)
    ("spot_smooth", np.float32),      # SPOT: (1 - cos(spot_size / 2)) * spot_blend
    ("spot_scale_z", np.float32),     # SPOT: 1 / |scaled Z column| (the cone's scaled frame)
])

# fields whose default is not zero (files written before the field existed)
_FIELD_DEFAULTS = {"exposure": 1.0,      # the camera's
                   "gather_roughness": GATHER_ROUGHNESS,     # the Light Paths'
                   "caustic_roughness": CAUSTIC_ROUGHNESS}


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.ascontiguousarray(a)
    a.setflags(write=False)
    return a


@dataclasses.dataclass(frozen=True)
class SceneArrays:
    """World-space triangles, materials, lights, camera and world of one frame."""

    positions: np.ndarray          # (T, 3, 3) float32 triangle corners
    normals: np.ndarray            # (T, 3, 3) float32 shading normals per corner (unit)
    uvs: np.ndarray                # (T, 3, 2) float32
    material: np.ndarray           # (T,) int32 index into ``materials``
    visibility: np.ndarray         # (T,) uint32 VIS_* bits
    materials: np.ndarray          # (M,) MATERIAL_DTYPE, M >= 1
    shader_nodes: np.ndarray       # (K,) SHADER_NODE_DTYPE, ordered by material
    lights: np.ndarray             # (L,) LIGHT_DTYPE
    camera: np.ndarray             # (1,) CAMERA_DTYPE
    world: np.ndarray              # (3,) float32 background radiance (colour x strength)
    material_names: tuple = ()
    warnings: tuple = ()
    textures: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, TEXTURE_DTYPE))
    texels: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 4), np.float16))
    # (T, 3, 3) float32 per-corner tangent directions, or (0, 3, 3) when no material is
    # anisotropic: the default tangent of anisotropic closures, Cycles' radial tangent around
    # the object's Z axis (kernels/closure/shader.h makes it orthogonal to the normal)
    tangents: np.ndarray = dataclasses.field(
        default_factory=lambda: np.zeros((0, 3, 3), np.float32))
    # (T, 3, 4) float32 per-corner tangents of the UV map (Blender's MikkTSpace: direction and
    # bitangent sign), or (0, 3, 4) when no material has a tangent-space Normal Map
    uv_tangents: np.ndarray = dataclasses.field(
        default_factory=lambda: np.zeros((0, 3, 4), np.float32))
    # (T, 3, 3) float32 Generated texture coordinates at the corners, or (0, 3, 3) when no
    # material reads them
    generated: np.ndarray = dataclasses.field(
        default_factory=lambda: np.zeros((0, 3, 3), np.float32))
    # (T, 3, K, 4) float32: the K mesh attributes shader programs read, at the corners (K = 0:
    # none; shader_program GEOM_ATTRIBUTE)
    attributes: np.ndarray = dataclasses.field(
        default_factory=lambda: np.zeros((0, 3, 0, 4), np.float32))
    # (T,) int32 the object of each triangle (a row of ``objects``, -1: none), (0,) when no
    # program reads object data; (O, OBJECT_ROWS, 4) float32 the objects (export/objects.py)
    object: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, np.int32))
    objects: np.ndarray = dataclasses.field(
        default_factory=lambda: np.zeros((0, OBJECT_ROWS, 4), np.float32))
    # (16 N,) float32 the Volume objects' grids, headers and voxels (scene/voxels.py)
    voxels: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, np.float32))
    # (T,) float32 each triangle's object's Shadow Terminator > Geometry Offset (Cycles' object
    # setting; kernels/geom/bvh.h terminator_lift), or (0,) when every object has the default
    terminator: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, np.float32))
    # (W, 4) int32 shader programs (ppm_engine/scene/shader_program.py); word 0 is never one
    svm: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((1, 4), np.int32))
    # (4,) int32 the world's node graph: its program's first word in ``svm`` (0: the constant
    # ``world``), flags (WORLD_*), the largest Environment Texture's width and height (0: none;
    # the importance map's automatic resolution, world_map.map_size), or with WORLD_MAP_MANUAL
    # the map's own size (Cycles' World > Settings > Sampling: Manual, Map Resolution)
    world_shader: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(4, np.int32))
    # (1,) LIGHT_PATHS_DTYPE: the scene's Light Paths settings (bounces, clamping, caustics;
    # light_paths.py), from its Cycles settings; the engine's defaults for a scene without
    light_paths: np.ndarray = dataclasses.field(default_factory=engine_defaults)

    def __post_init__(self):
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if isinstance(v, np.ndarray):
                object.__setattr__(self, f.name, _frozen(v))
            elif isinstance(v, list):
                object.__setattr__(self, f.name, tuple(v))
        self.validate()

    # ------------------------------------------------------------------------------------------
    @property
    def n_triangles(self) -> int:
        return int(self.positions.shape[0])

    @property
    def resolution(self) -> tuple[int, int]:
        """(w, h) of the rendered region."""
        r = self.camera["region"][0]
        return int(r[2]), int(r[3])

    def validate(self) -> None:
        t = self.positions.shape[0]
        expect = {
            "positions": ((t, 3, 3), np.float32),
            "normals": ((t, 3, 3), np.float32),
            "uvs": ((t, 3, 2), np.float32),
            "material": ((t,), np.int32),
            "visibility": ((t,), np.uint32),
            "world": ((3,), np.float32),
        }
        for name, (shape, dtype) in expect.items():
            a = getattr(self, name)
            if a.shape != shape or a.dtype != dtype:
                raise ValueError(f"SceneArrays.{name}: expected {dtype.__name__}{shape}, "
                                 f"got {a.dtype}{a.shape}")
        for name, dt in (("materials", MATERIAL_DTYPE), ("shader_nodes", SHADER_NODE_DTYPE),
                         ("lights", LIGHT_DTYPE), ("camera", CAMERA_DTYPE),
                         ("light_paths", LIGHT_PATHS_DTYPE)):
            a = getattr(self, name)
            if a.dtype != dt or a.ndim != 1:
                raise ValueError(f"SceneArrays.{name}: expected a 1-D array of its dtype")
        if self.camera.shape != (1,):
            raise ValueError("SceneArrays.camera must hold exactly one camera")
        if self.light_paths.shape != (1,):
            raise ValueError("SceneArrays.light_paths must hold exactly one record")
        check_light_paths(self.light_paths)
        if self.materials.shape[0] < 1:
            raise ValueError("SceneArrays.materials must hold at least one material")
        check_objects(self.object, self.objects, self.materials["volume_object"], t,
                      OBJECT_ROWS, self.voxels)
        at = self.attributes
        if at.dtype != np.float32 or at.ndim != 4 or at.shape[1] != 3 or at.shape[3] != 4 \
                or at.shape[0] not in (0, t) or (at.shape[0] == 0) != (at.shape[2] == 0):
            raise ValueError(f"SceneArrays.attributes: expected float32 (T, 3, K, 4) or "
                             f"(0, 3, 0, 4), got {at.dtype}{at.shape}")
        tm = self.terminator
        if tm.dtype != np.float32 or tm.shape not in ((0,), (t,)):
            raise ValueError(f"SceneArrays.terminator: expected float32 (0,) or ({t},), got "
                             f"{tm.dtype}{tm.shape}")
        for name, k in (("tangents", 3), ("uv_tangents", 4), ("generated", 3)):
            a = getattr(self, name)
            if a.dtype != np.float32 or a.shape not in ((0, 3, k), (t, 3, k)):
                raise ValueError(f"SceneArrays.{name}: expected float32 (0, 3, {k}) or "
                                 f"({t}, 3, {k}), got {a.dtype}{a.shape}")
        if self.svm.dtype != np.int32 or self.svm.ndim != 2 or self.svm.shape[1] != 4 \
                or not ((m_p := np.stack([self.materials["program"], self.materials[
                    "density_program"]])) >= 0).all() or (m_p >= self.svm.shape[0]).any():
            raise ValueError("SceneArrays.svm: expected int32 (W, 4) holding every program")
        ws = self.world_shader
        if ws.dtype != np.int32 or ws.shape != (4,) or not 0 <= ws[0] < self.svm.shape[0]:
            raise ValueError("SceneArrays.world_shader: expected int32 (4,) naming a program")
        if self.textures.dtype != TEXTURE_DTYPE or self.textures.ndim != 1:
            raise ValueError("SceneArrays.textures: expected a 1-D array of TEXTURE_DTYPE")
        if self.texels.dtype != np.float16 or self.texels.ndim != 2 or self.texels.shape[1] != 4:
            raise ValueError("SceneArrays.texels: expected float16 (N, 4)")
        tx = self.textures
        if tx.size and ((tx["width"] < 1).any() or (tx["height"] < 1).any()
                        or (tx["offset"] < 0).any()
                        or (tx["offset"].astype(np.int64) + tx["width"].astype(np.int64)
                            * tx["height"] > self.texels.shape[0]).any()):
            raise ValueError("SceneArrays.textures: a texture lies outside the texels")
        nodes = self.shader_nodes
        for field in ("color_texture", "emission_texture", "alpha_texture"):
            k = nodes[field]
            if k.size and (k.min() < 0 or k.max() > tx.shape[0]):
                raise ValueError(f"SceneArrays.shader_nodes['{field}'] names a missing texture")
        m = nodes["material"]
        if m.size and (m.min() < 0 or m.max() >= self.materials.shape[0]
                       or (np.diff(m) < 0).any()):
            raise ValueError("SceneArrays.shader_nodes: material indexes outside the material "
                             "table or out of order")
        if t and (self.material.min() < 0 or self.material.max() >= self.materials.shape[0]):
            raise ValueError("SceneArrays.material indexes outside the material table")
        w, h = self.resolution
        if w < 1 or h < 1:
            raise ValueError(f"render region is empty ({w}x{h})")

    # ------------------------------------------------------------------------------------------
    def save(self, path: str | Path) -> None:
        arrays = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)
                  if isinstance(getattr(self, f.name), np.ndarray)}
        np.savez_compressed(path, **arrays,
                            material_names=np.array(self.material_names, dtype=str),
                            warnings=np.array(self.warnings, dtype=str))

    @classmethod
    def load(cls, path: str | Path) -> SceneArrays:
        with np.load(path, allow_pickle=False) as z:
            kw = {k: z[k] for k in z.files}
        mats = kw.get("materials")
        if "shader_nodes" not in kw and mats is not None and mats.dtype.names \
                and set(_LEGACY_MATERIAL_FIELDS) <= set(mats.dtype.names):
            kw["shader_nodes"] = legacy_nodes(mats)
            kw["materials"] = _with_fields(mats, MATERIAL_DTYPE)
        # files written before a field existed: the missing fields are zero (their default)
        for name, dt in (("materials", MATERIAL_DTYPE), ("lights", LIGHT_DTYPE),
                         ("camera", CAMERA_DTYPE), ("shader_nodes", SHADER_NODE_DTYPE),
                         ("light_paths", LIGHT_PATHS_DTYPE)):
            a = kw.get(name)
            if a is not None and a.dtype.names and a.dtype != dt \
                    and set(a.dtype.names) < set(dt.names):
                kw[name] = _with_fields(a, dt)
        if kw.get("objects", np.zeros((0, OBJECT_ROWS, 4))).shape[1:2] < (OBJECT_ROWS,):
            kw["objects"] = np.pad(kw["objects"], ((0, 0), (0, 2), (0, 0)))   # (9 rows before)
        kw["material_names"] = tuple(str(s) for s in kw.get("material_names", ()))
        kw["warnings"] = tuple(str(s) for s in kw.get("warnings", ()))
        return cls(**kw)

    def replace(self, **changes) -> SceneArrays:
        return dataclasses.replace(self, **changes)

    def differs_only_in_camera(self, other: SceneArrays) -> bool:
        """Whether ``other`` holds this scene's very arrays (the same objects) but the camera:
        ``replace(camera=...)`` made it (the viewport's view changes)."""
        return all(getattr(self, f.name) is getattr(other, f.name)
                   for f in dataclasses.fields(self) if f.name != "camera")

    def nodes_of(self, material: int | str) -> np.ndarray:
        """The BSDF nodes of a material (its index or name)."""
        k = self.material_names.index(material) if isinstance(material, str) else material
        return self.shader_nodes[self.shader_nodes["material"] == k]


def _with_fields(a: np.ndarray, dt: np.dtype) -> np.ndarray:
    """``a`` as dtype ``dt``: the fields both have copied, the others their default (zero but
    for _FIELD_DEFAULTS)."""
    new = np.zeros(a.shape, dt)
    for field in set(dt.names) - set(a.dtype.names):
        if field in _FIELD_DEFAULTS:
            new[field] = _FIELD_DEFAULTS[field]
    for field in set(a.dtype.names) & set(dt.names):
        new[field] = a[field]
    return new
