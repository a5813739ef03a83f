"""Blender depsgraph -> SceneArrays.  The only code that reads Blender scene data.

    arrays = export_scene(depsgraph, engine)     # engine optional: warnings are also reported

Everything is read with attribute-API ``foreach_get`` into buffers of the stored dtype
(a Python loop over a million vertices would take seconds); the per-object work is a handful of
NumPy calls, never a loop over vertices or triangles.  Mesh data is read once per evaluated mesh
and transformed per instance.
"""
from __future__ import annotations

import numpy as np

from ppm_engine.blender.export.camera import export_camera
from ppm_engine.blender.export.lights import export_light
from ppm_engine.blender.export.material_table import MaterialTable
from ppm_engine.blender.export.mesh import GEOMETRY_TYPES, transform_part
from ppm_engine.blender.export.mesh_cache import MeshCache
from ppm_engine.blender.export.objects import object_row
from ppm_engine.blender.export.textures import TextureTable
from ppm_engine.blender.export.volume_object import export_volume
from ppm_engine.blender.export.world import export_world, world_medium
from ppm_engine.errors import SceneError
from ppm_engine.scene.arrays import (
    LIGHT_DTYPE,
    LIGHT_HIDDEN_SHIFT,
    OBJECT_ROWS,
    TERMINATOR_OFFSET,
    VIS_CAMERA,
    VIS_DIFFUSE,
    VIS_GLOSSY,
    VIS_SHADOW,
    VIS_TRANSMISSION,
    WORLD_MEDIUM,
    SceneArrays,
)
from ppm_engine.scene.light_paths import from_cycles
from ppm_engine.scene.shader_program import (
    PROGRAM_ATTRIBUTES,
    PROGRAM_GENERATED,
    PROGRAM_OBJECT,
    PROGRAM_TANGENTS,
)
from ppm_engine.scene.voxels import GRID_ROW, VoxelTable

__all__ = ["Warnings", "export_scene"]

_VIS_FLAGS = (("visible_camera", VIS_CAMERA), ("visible_diffuse", VIS_DIFFUSE),
              ("visible_glossy", VIS_GLOSSY), ("visible_transmission", VIS_TRANSMISSION),
              ("visible_shadow", VIS_SHADOW))


class Warnings(list):
    """Collects each warning once; forwards it to the engine's report when there is one."""

    def __init__(self, engine=None):
        super().__init__()
        self.engine = engine

    def __call__(self, msg: str):
        if msg in self:
            return
        self.append(msg)
        if self.engine is not None:
            self.engine.report({'WARNING'}, msg)


# geometry that has no surface of triangles, which this engine does not render yet (Cycles
# renders each): said per object (docs/USAGE.md, "What is not rendered")
NOT_RENDERED = {
    'CURVES': "hair curves are not rendered yet (convert them to a mesh: Curves to Mesh)",
    'POINTCLOUD': "a point cloud is not rendered yet (instance a mesh on its points)",
}


def warn_smoke_domain(obj, warn) -> None:
    """A warning where the mesh is a smoke or fire simulation's domain (a Fluid modifier's gas
    domain), whose grids Cycles renders as a volume and this engine does not read."""
    for md in getattr(obj, "modifiers", ()):
        if md.type == 'FLUID' and getattr(md, "fluid_type", "") == 'DOMAIN' and getattr(
                getattr(md, "domain_settings", None), "domain_type", "") == 'GAS':
            warn(f"Object '{obj.name}': the smoke simulation of its Fluid domain is not read "
                 "(its material fills the domain's mesh); its grids baked to OpenVDB and "
                 "loaded as a Volume object are")


def warn_particle_hair(obj, warn) -> None:
    """A warning per hair particle system of ``obj`` shown as strands (not rendered yet)."""
    for ps in getattr(obj, "particle_systems", ()):
        st = ps.settings
        if st.type == 'HAIR' and st.render_type == 'PATH':
            warn(f"Object '{obj.name}': the hair particles '{ps.name}' are not rendered yet "
                 "(Render As Object or Collection instances are)")


def in_view(inst, view) -> bool:
    """Whether the object instance ``inst`` shows in the 3D view ``view`` (SpaceView3D)."""
    owner = inst.parent if inst.is_instance and inst.parent is not None else inst.object
    return bool(getattr(owner, "original", owner).visible_in_viewport_get(view))


def hidden_in_view(depsgraph, view) -> tuple:
    """The names of the view layer's objects that ``view`` hides (a viewport's export key)."""
    if view is None or not hasattr(view, "show_object_viewport_mesh"):
        return ()
    return tuple(sorted(o.name for o in depsgraph.view_layer.objects
                        if not o.visible_in_viewport_get(view)))


def export_scene(depsgraph, engine=None, camera=None, view=None, meshes=None,
                 images=None) -> SceneArrays:
    """Everything the core needs from one evaluated depsgraph (render or viewport).

    ``camera``: a CAMERA_DTYPE record to render with instead of the scene camera's (the
    viewport's view, camera.camera_from_view); the scene then needs no camera.
    ``view``: a 3D view (SpaceView3D) whose visibility applies, as in Cycles' viewport: only
    the objects visible in it (its local view, local collections and object-type visibility,
    Object.visible_in_viewport_get; an instance by its instancer's).
    ``meshes``: a MeshCache kept across exports (the viewport's: the caller forgets what
    changed), else one for this export; ``images``: a dict of decoded images kept across
    exports likewise (TextureTable's ``decoded``; the caller clears it when an image changes).
    Raises SceneError when the scene cannot be rendered (no/invalid camera, empty border)."""
    scene = depsgraph.scene
    warn = Warnings(engine)
    if scene.render.use_motion_blur and view is None:     # (no viewport has motion blur)
        warn("Motion blur (Render Properties > Motion Blur) is not rendered yet: each frame "
             "renders at its own time")
    textures = TextureTable(warn, decoded=images)
    materials = MaterialTable(warn, textures)
    if camera is None:
        camera = export_camera(scene, depsgraph)
        cm = np.array(scene.camera.evaluated_get(depsgraph).matrix_world, np.float64)
        cm[:3, :3] /= np.maximum(np.linalg.norm(cm[:3, :3], axis=0, keepdims=True), 1e-30)
    else:
        cm = np.eye(4)
        cm[:3] = camera["to_world"][0]
    # Cycles' camera space: the camera's placement without its scale (as the camera's rays),
    # its z flipped (+z ahead)
    materials.camera = cm @ np.diag((1.0, 1.0, -1.0, 1.0))
    keep = meshes is not None
    if keep:
        meshes.warn = warn
        meshes.begin()
    else:
        meshes = MeshCache(warn)
    parts, lights = [], []
    uv_tangents = generated = False
    objects = []                            # rows of the objects whose programs read them
    voxels = VoxelTable()                   # the Volume objects' grids
    volumes: dict = {}                      # ... by volume: read, and where they lie in voxels
    bases = []                              # the parts as made (MeshCache.part)
    for inst in depsgraph.object_instances:
        obj = inst.object
        if view is not None and not in_view(inst, view):
            continue
        kind = obj.type
        if kind == 'LIGHT':
            m = np.array(inst.matrix_world, dtype=np.float64)    # copy inside the loop
            row = export_light(obj.data, m, warn)
            for attr, bit in (("visible_camera", VIS_CAMERA), ("visible_glossy", VIS_GLOSSY),
                              ("visible_transmission", VIS_TRANSMISSION)):
                if not getattr(obj, attr, True):      # the light seen directly or in a mirror
                    row["flags"] |= np.uint32(bit << LIGHT_HIDDEN_SHIFT)
            lights.append(row)
        elif kind == 'VOLUME':
            if inst.show_self:
                part = _volume(obj, inst, materials, warn, objects, voxels, volumes)
                if part is not None:
                    parts.append(part)
                    bases.append(part)
        elif kind in GEOMETRY_TYPES:
            if not inst.show_self:          # e.g. particle instancer hidden for render
                continue
            m = np.array(inst.matrix_world, dtype=np.float64)    # copy inside the loop
            if any(getattr(md, "use_adaptive_subdivision", False) for md in obj.modifiers
                   if md.type == 'SUBSURF'):
                warn(f"Object '{obj.name}': adaptive subdivision renders at the modifier's "
                     "render levels here (Cycles dices it per pixel)")
            mesh = meshes.get(obj)
            if kind == 'MESH':
                warn_particle_hair(obj, warn)
                warn_smoke_domain(obj, warn)
            if mesh is None or mesh.n_triangles == 0:
                if kind in NOT_RENDERED:        # no surface to render: said, not dropped silently
                    warn(f"Object '{obj.name}': {NOT_RENDERED[kind]}")
                continue
            slots = materials.slot_map(obj)
            # the object's row of ``objects`` where its programs read object data (a
            # heterogeneous medium's field reads its space: bound to it)
            k_obj = len(objects) if materials.reads(slots, PROGRAM_OBJECT) else -1
            slots = materials.bind_volumes(slots, k_obj)
            mapped = materials.reads(slots, PROGRAM_TANGENTS)
            gen = materials.reads(slots, PROGRAM_GENERATED)
            reads_attrs = materials.reads(slots, PROGRAM_ATTRIBUTES)
            vis, term, aniso = visibility_bits(obj), terminator_offset(obj), \
                materials.anisotropic(slots)

            def make(obj=obj, mesh=mesh, m=m, slots=slots, vis=vis, term=term, aniso=aniso,
                     mapped=mapped, gen=gen, reads_attrs=reads_attrs):
                attrs = (meshes.attributes(obj, materials.attributes) if reads_attrs
                         else None)
                # meshes.warn: what it warns is kept with the part (said by every export)
                return transform_part(mesh, m, slots, vis, obj.name, meshes.warn, tangents=aniso,
                                      uv_tangents=meshes.uv_tangents(obj) if mapped else None,
                                      generated=gen, attributes=attrs, terminator=term)
            # the world-space part: kept across exports with the mesh (a value edit moves
            # nothing), one per placement, slots, flags and attribute names
            base = meshes.part(obj, (m.tobytes(), slots.tobytes(), vis, obj.name, aniso,
                                     mapped, gen, tuple(materials.attributes) if reads_attrs
                                     else None, term), make)
            bases.append(base)
            parts.append(dict(base))
            uv_tangents |= mapped
            generated |= gen
            if k_obj >= 0:
                objects.append(object_row(obj, m, inst, mesh.texspace))
            parts[-1]["object"] = np.full(parts[-1]["positions"].shape[0], k_obj, np.int32)
    if keep:
        meshes.prune()
    else:
        meshes.clear()
    svm = materials.svm()
    world, world_program, world_shader = export_world(scene.world, warn, textures, svm.shape[0])
    if world_program is not None:
        svm = np.concatenate([svm, world_program])
    mats, names = materials.array(), tuple(materials.names)
    fog = world_medium(scene.world, warn)      # the world's Volume: the materials' last row
    if fog is not None:
        mats, names = np.concatenate([mats, fog]), names + (f"World '{scene.world.name}'",)
        world_shader[1] |= WORLD_MEDIUM

    light_arr = np.concatenate(lights) if lights else np.zeros(0, LIGHT_DTYPE)
    cat_key = (tuple(bases), len(materials.attributes), uv_tangents, generated,
               tuple(int(p["object"][0]) if len(p["object"]) else -1 for p in parts))
    if parts and meshes.concatenated(cat_key) is not None:
        cat = dict(meshes.concatenated(cat_key))    # nothing moved: the same arrays
    elif parts:
        k_attr = len(materials.attributes)          # the parts read fewer names: zero-padded
        for part in parts:
            a = part["attributes"]
            part["attributes"] = np.concatenate(
                [a, np.zeros(a.shape[:2] + (k_attr - a.shape[2], 4), np.float32)], axis=2)
        cat = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
        if not cat["tangents"].any():              # no anisotropic material: no tangents
            cat["tangents"] = np.zeros((0, 3, 3), np.float32)
        if not uv_tangents:                        # no tangent-space normal map
            cat["uv_tangents"] = np.zeros((0, 3, 4), np.float32)
        if not k_attr:                             # no mesh attribute read
            cat["attributes"] = np.zeros((0, 3, 0, 4), np.float32)
        if not objects:                            # no object data read
            cat["object"] = np.zeros(0, np.int32)
        if not generated:                          # no Generated coordinates read
            cat["generated"] = np.zeros((0, 3, 3), np.float32)
        if (cat["terminator"] == np.float32(TERMINATOR_OFFSET)).all():   # every one the default
            cat["terminator"] = np.zeros(0, np.float32)
        if keep:
            meshes.keep_concatenated(cat_key, cat)
    else:
        cat = dict(positions=np.zeros((0, 3, 3), np.float32),
                   normals=np.zeros((0, 3, 3), np.float32),
                   uvs=np.zeros((0, 3, 2), np.float32), material=np.zeros(0, np.int32),
                   visibility=np.zeros(0, np.uint32))
    tex_table, texels = textures.arrays()
    light_paths = from_cycles(getattr(scene, "cycles", None))    # Light Paths (SceneError)
    try:
        return SceneArrays(**cat, materials=mats,
                           shader_nodes=materials.node_array(), lights=light_arr, camera=camera,
                           world=world, material_names=names,
                           warnings=tuple(warn), textures=tex_table, texels=texels,
                           objects=(np.stack(objects) if objects
                                    else np.zeros((0, OBJECT_ROWS, 4), np.float32)),
                           svm=svm, world_shader=world_shader, light_paths=light_paths,
                           voxels=voxels.array())
    except ValueError as e:
        raise SceneError(f"the exported scene is inconsistent: {e}") from e


def _volume(obj, inst, materials, warn, objects: list, voxels, volumes: dict) -> dict | None:
    """The part of a Volume object (export/volume_object.py: the box around the grids its
    material's density reads, that material's medium inside, bound to the object's new row
    of ``objects``), or None (nothing rendered).  Its grids are added to ``voxels`` once per
    volume (``volumes``: what this export read and placed; instances share them)."""
    m = np.array(inst.matrix_world, dtype=np.float64)
    made = export_volume(obj, m, materials, warn, volumes)
    if made is None:
        return None
    k_mat, key, box, grids, texspace = made
    if ("placed",) + key not in volumes:
        try:
            volumes[("placed",) + key] = voxels.add(grids)
        except ValueError as e:             # (beyond what the kernels can address)
            warn(f"Object '{obj.name}': its grids are not rendered ({e})")
            return None
    k_obj = len(objects)
    slots = materials.bind_volumes(np.array([k_mat], np.int32), k_obj)
    part = transform_part(box, m, slots, visibility_bits(obj), obj.name, warn)
    row = object_row(obj, m, inst, texspace)
    row[GRID_ROW, 1:3] = volumes[("placed",) + key]
    objects.append(row)
    part["object"] = np.full(part["positions"].shape[0], k_obj, np.int32)
    return part


def terminator_offset(obj) -> float:
    """The object's Shadow Terminator > Geometry Offset (Object Properties > Shading, which
    Cycles reads; kernels/geom/bvh.h terminator_lift), 0-1."""
    v = getattr(obj, "shadow_terminator_geometry_offset", TERMINATOR_OFFSET)
    try:
        v = float(v)
    except (TypeError, ValueError):
        return TERMINATOR_OFFSET
    return min(max(v, 0.0), 1.0) if np.isfinite(v) else TERMINATOR_OFFSET


def visibility_bits(obj) -> int:
    """VIS_* bits from the object's ray-visibility flags (Object Properties > Visibility)."""
    bits = 0
    for flag, bit in _VIS_FLAGS:
        if getattr(obj, flag, True):
            bits |= bit
    return bits
