"""Blender scene -> SceneArrays: geometry and instancing (transforms, collection and geometry
nodes instances, linked duplicates read once, mirrored objects, text and curves), smooth and
flat normals, UVs, NaN vertices dropped, visibility flags, and the render depsgraph (objects and
lights hidden from the render, warnings reported); the helpers are
tests/helpers/blender_scenes.py's."""
import math

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from ppm_engine.blender.export import export_scene
from ppm_engine.scene.arrays import LIGHT_POINT, VIS_CAMERA, VIS_SHADOW
from tests.helpers.blender_scenes import add_light, add_plane, export


# --- geometry -----------------------------------------------------------------------------------
def test_transform_instancing_and_normals(empty):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=8, ring_count=4, radius=1.0)
    src = bpy.context.active_object
    src.data.shade_smooth()
    coll = bpy.data.collections.new("Inst")
    bpy.context.scene.collection.children.link(coll)
    bpy.context.scene.collection.objects.unlink(src)
    coll.objects.link(src)
    bpy.context.view_layer.layer_collection.children["Inst"].exclude = True
    for i in range(3):
        e = bpy.data.objects.new(f"E{i}", None)
        e.instance_type = 'COLLECTION'
        e.instance_collection = coll
        e.location = (10 * i, 0, 0)
        e.scale = (2, 2, 2)
        bpy.context.scene.collection.objects.link(e)
    s = export()
    n_one = 8 * 2 + 8 * 2 * 2                 # two triangle fans + two quad rings of 8
    assert s.n_triangles == 3 * n_one
    c = s.positions.mean(axis=1)
    for i in range(3):
        mine = np.abs(c[:, 0] - 10 * i) < 5
        assert mine.sum() == n_one
        r = np.linalg.norm(s.positions[mine] - (10 * i, 0, 0), axis=2)
        np.testing.assert_allclose(r, 2.0, rtol=1e-5)            # scaled by 2
        # smooth (angle-weighted vertex) normals: unit length, within a few degrees of radial
        d = s.positions[mine] - (10 * i, 0, 0)
        d /= np.linalg.norm(d, axis=2, keepdims=True)
        np.testing.assert_allclose(np.linalg.norm(s.normals[mine], axis=2), 1.0, rtol=1e-5)
        assert ((s.normals[mine] * d).sum(2) > 0.99).all()
        assert len({tuple(n) for n in s.normals[mine].reshape(-1, 3).round(4)}) > 8   # not flat


def test_flat_normals_follow_faces(empty):
    o = add_plane(size=2.0)
    o.rotation_euler = (math.radians(90), 0, 0)
    s = export()
    np.testing.assert_allclose(s.normals.reshape(-1, 3),
                               np.tile([0, -1, 0], (6, 1))[:s.n_triangles * 3], atol=1e-6)


def test_nan_vertices_are_dropped_with_a_warning(empty):
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=4, y_subdivisions=4, size=2)
    o = bpy.context.active_object
    o.name = "Broken"
    before = export()
    pos = np.zeros(3 * len(o.data.vertices), np.float32)
    o.data.attributes["position"].data.foreach_get("vector", pos)
    corner = pos[:3].copy()
    using = np.isclose(before.positions, corner).all(axis=2).any(axis=1).sum()
    assert 1 <= using <= 2
    pos[0] = np.nan
    o.data.attributes["position"].data.foreach_set("vector", pos)
    s = export()
    assert s.n_triangles == before.n_triangles - using and np.isfinite(s.positions).all()
    assert any("Broken" in w and "NaN" in w for w in s.warnings)


def test_warnings_of_kept_mesh_data_are_reported_by_every_export_that_uses_it(empty):
    """The viewport's exports keep the mesh data (MeshCache): what reading it warned (NaN
    vertices, a normal map without a UV map) is said again by every export from the cache,
    once each, to the engine's report too."""
    from ppm_engine.blender.export.mesh_cache import MeshCache
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=4, y_subdivisions=4, size=2)
    o = bpy.context.active_object
    o.name = "Broken"
    pos = np.zeros(3 * len(o.data.vertices), np.float32)
    o.data.attributes["position"].data.foreach_get("vector", pos)
    pos[0] = np.nan
    o.data.attributes["position"].data.foreach_set("vector", pos)
    p = add_plane("Bumpy", loc=(3, 0, 0))
    p.data.name = "Bumpy"
    p.data.uv_layers.remove(p.data.uv_layers[0])
    m = bpy.data.materials.new("nm")
    nm = m.node_tree.nodes.new("ShaderNodeNormalMap")
    m.node_tree.links.new(nm.outputs[0], m.node_tree.nodes["Principled BSDF"].inputs["Normal"])
    p.data.materials.append(m)
    bpy.context.view_layer.update()

    class Engine:
        def report(self, kind, message):
            reports.append(message)
    meshes, reports = MeshCache(None), []
    for k in range(3):
        if k == 2:
            p.location = (3, 1, 0)                  # a transform: the other part is kept
            bpy.context.view_layer.update()
        reports.clear()
        s = export_scene(bpy.context.evaluated_depsgraph_get(), Engine(), meshes=meshes)
        said = [w for w in s.warnings if "Broken" in w or "Bumpy" in w]
        assert sorted(said) == sorted(reports) and len(said) == 2, (k, s.warnings)
        assert any("Broken" in w and "NaN" in w for w in said)
        assert any("Bumpy" in w and "UV map" in w for w in said)
    assert meshes.reads == 2                         # read once


def test_adaptive_subdivision_renders_the_modifier_levels_with_a_warning(empty):
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=1)
    o = bpy.context.active_object
    o.name = "Diced"
    mod = o.modifiers.new("Subdivision", "SUBSURF")
    mod.levels = mod.render_levels = 1
    assert export().n_triangles == 20 * 3 * 2          # 3 quads per triangle, 2 triangles each
    assert not any("adaptive" in w for w in export().warnings)
    mod.use_adaptive_subdivision = True
    s = export()
    assert s.n_triangles == 120
    assert any("Diced" in w and "adaptive subdivision" in w for w in s.warnings)


def test_what_is_not_rendered_yet_is_said_per_object(empty, tmp_path):
    """Hair curves, a point cloud, hair particles and motion blur are not rendered yet, and a
    Volume object without grids renders nothing: each export says so, naming the object
    (before: silently nothing)."""
    add_plane()
    vol = bpy.data.objects.new("Smoke", bpy.data.volumes.new("Smoke"))
    hair = bpy.data.objects.new("Fur", bpy.data.hair_curves.new("Fur"))
    points = bpy.data.objects.new("Dust", bpy.data.pointclouds.new("Dust"))
    for o in (vol, hair, points):
        bpy.context.scene.collection.objects.link(o)
    bpy.ops.mesh.primitive_cube_add()
    bpy.context.active_object.name = "Shaggy"
    bpy.ops.object.particle_system_add()
    bpy.context.active_object.particle_systems[0].settings.type = 'HAIR'
    s = export()
    said = "\n".join(s.warnings)
    for name, words in (("Smoke", "no grids"), ("Fur", "hair curves"),
                        ("Dust", "point cloud"), ("Shaggy", "hair particles")):
        assert any(name in w and words in w for w in s.warnings), said
    assert s.n_triangles == 2 + 12 and "Motion blur" not in said
    bpy.context.scene.render.use_motion_blur = True
    assert any("Motion blur" in w for w in export().warnings)


def test_final_renders_read_the_render_levels_in_object_and_edit_mode(empty, tiny, render_exr,
                                                                     monkeypatch, tmp_path):
    """A Subdivision Surface modifier at viewport level 1 and render level 2: a final render
    (F12, and python -m ppm_engine render, which runs the same operator: the render
    depsgraph) exports level 2, the viewport's depsgraph level 1.  The same with the object
    in Edit Mode, whose evaluated data is then the edit mesh's wrapper, without the corner
    arrays (read through to_mesh(), as Cycles does; the export failed on it), the tangents
    of its normal map the same."""
    import ppm_engine.blender.export as export_package
    seen = []
    real = export_package.export_scene

    def recorded(depsgraph, *args, **kw):
        seen.append(real(depsgraph, *args, **kw))
        return seen[-1]
    monkeypatch.setattr(export_package, "export_scene", recorded)
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=1)       # 20 triangles
    o = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    mod = o.modifiers.new("Subdivision", "SUBSURF")
    mod.levels, mod.render_levels = 1, 2                        # 3 quads a triangle, 4 a quad
    m = bpy.data.materials.new("nm")
    nm = m.node_tree.nodes.new("ShaderNodeNormalMap")
    m.node_tree.links.new(nm.outputs[0], m.node_tree.nodes["Principled BSDF"].inputs["Normal"])
    o.data.materials.append(m)
    tiny(empty, width=8, height=8, passes=1)                    # (no light: nothing renders)
    render_exr(tmp_path / "object_mode.exr")
    final = seen[-1]
    assert final.n_triangles == 20 * 3 * 4 * 2 and final.uv_tangents.shape[0] == 480
    assert export().n_triangles == 20 * 3 * 2
    bpy.ops.object.mode_set(mode="EDIT")
    render_exr(tmp_path / "edit_mode.exr")
    edited = seen[-1]
    np.testing.assert_array_equal(edited.positions, final.positions)
    np.testing.assert_array_equal(edited.uv_tangents, final.uv_tangents)
    assert export().n_triangles == 20 * 3 * 2
    bpy.ops.object.mode_set(mode="OBJECT")


def test_visibility_flags(empty):
    a = add_plane("Seen")
    b = add_plane("NoShadow", loc=(5, 0, 0))
    b.visible_shadow = False
    c = add_plane("NoCamera", loc=(10, 0, 0))
    c.visible_camera = False
    s = export()
    cx = s.positions[:, :, 0].mean(1)
    vis = {name: s.visibility[np.abs(cx - x) < 2] for name, x in
           (("Seen", 0), ("NoShadow", 5), ("NoCamera", 10))}
    assert (vis["Seen"] & VIS_SHADOW).all() and (vis["Seen"] & VIS_CAMERA).all()
    assert not (vis["NoShadow"] & VIS_SHADOW).any() and (vis["NoShadow"] & VIS_CAMERA).all()
    assert not (vis["NoCamera"] & VIS_CAMERA).any()
    assert a.visible_camera      # (hide_render is honoured by the render depsgraph: test_e2e.py)


def test_uvs_follow_the_corners(empty):
    add_plane(size=2.0)                               # primitive plane: uv = (x + 1) / 2
    s = export()
    np.testing.assert_allclose(s.uvs, (s.positions[:, :, :2] + 1) / 2, atol=1e-6)


def _two_uv_maps(plane):
    """A second UV map on the plane, u and v swapped and mirrored, selected for editing while
    the first stays the one rendered (the camera icon)."""
    me = plane.data
    me.uv_layers.new(name="Second")
    first, second = me.uv_layers["UVMap"], me.uv_layers["Second"]
    uv = np.empty(2 * len(first.data), np.float32)
    first.data.foreach_get("uv", uv)
    uv = uv.reshape(-1, 2)
    second.data.foreach_set("uv", np.stack([1.0 - uv[:, 1], uv[:, 0]], -1).ravel())
    me.uv_layers.active = me.uv_layers["Second"]
    me.uv_layers["UVMap"].active_render = True
    return uv


def test_uvs_and_tangents_of_the_rendered_uv_map(empty):
    """Cycles reads the UV map marked for rendering (active_render, its ATTR_STD_UV) where a
    node names none, not the one selected for editing: the UVs and the Normal Map's tangents
    both come from it."""
    plane = add_plane()
    first = _two_uv_maps(plane)
    m = bpy.data.materials.new("nm")
    t = m.node_tree
    nm = t.nodes.new("ShaderNodeNormalMap")
    t.links.new(nm.outputs[0], t.nodes["Principled BSDF"].inputs["Normal"])
    plane.data.materials.append(m)
    s = export()
    loops = np.array([lt.loops[:] for lt in plane.data.loop_triangles]).ravel()
    np.testing.assert_allclose(s.uvs.reshape(-1, 2), first[loops], atol=1e-6)
    # the first map's u runs along +x: so does its tangent (the second's along -y)
    assert (s.uv_tangents[..., 0] > 0.99).all(), s.uv_tangents[0]


def test_tangents_of_a_mesh_with_ngons(empty):
    """A cylinder's caps are n-gons: Cycles computes the Normal Map's tangents on the
    triangles it renders; Blender's calc_tangents on the mesh itself refuses n-gons ("only
    tris/quads": the map was not applied, with a warning).  Unit tangents at every corner,
    in the corner's tangent plane."""
    bpy.ops.mesh.primitive_cylinder_add(vertices=8)
    o = bpy.context.active_object
    m = bpy.data.materials.new("nm")
    nm = m.node_tree.nodes.new("ShaderNodeNormalMap")
    m.node_tree.links.new(nm.outputs[0], m.node_tree.nodes["Principled BSDF"].inputs["Normal"])
    o.data.materials.append(m)
    meshes = len(bpy.data.meshes)
    s = export()
    assert not s.warnings, s.warnings
    assert len(bpy.data.meshes) == meshes        # (no datablock added, even for a while)
    t = s.uv_tangents[..., :3]
    np.testing.assert_allclose(np.linalg.norm(t, axis=-1), 1.0, atol=1e-5)
    np.testing.assert_allclose((t * s.normals).sum(-1), 0.0, atol=1e-5)
    assert set(np.unique(s.uv_tangents[..., 3])) <= {-1.0, 1.0}


def test_the_rendered_uv_map_as_cycles(empty, cycles, render_exr, tiny, tmp_path):
    """The same choice against Cycles: a plane emitting its UV coordinates (u, v, 0), seen
    from above, per pixel."""
    plane = add_plane()
    _two_uv_maps(plane)
    m = bpy.data.materials.new("uv")
    t = m.node_tree
    t.nodes.remove(t.nodes["Principled BSDF"])
    tc, em = t.nodes.new("ShaderNodeTexCoord"), t.nodes.new("ShaderNodeEmission")
    t.links.new(tc.outputs["UV"], em.inputs["Color"])
    t.links.new(em.outputs[0], t.nodes["Material Output"].inputs["Surface"])
    plane.data.materials.append(m)
    cam = empty.camera
    cam.data.type, cam.data.ortho_scale = "ORTHO", 2.0
    cam.location, cam.rotation_euler = (0.0, 0.0, 3.0), (0.0, 0.0, 0.0)
    cycles(empty, 64, width=8)
    empty.cycles.pixel_filter_type, empty.cycles.filter_width = "BOX", 1.0
    ref = render_exr(tmp_path / "cycles.exr")
    tiny(empty, width=8, height=8, passes=64)
    ours = render_exr(tmp_path / "ours.exr")
    assert np.abs(ours - ref).max() < 0.03, np.abs(ours - ref).max()   # the other map: 0.7


def test_mirrored_instance_keeps_normals_and_winding(empty):
    o = add_plane(size=2.0)
    o.scale = (-1, 1, 1)
    s = export()
    np.testing.assert_allclose(s.normals.reshape(-1, 3), np.tile([0, 0, 1], (s.n_triangles * 3, 1)),
                               atol=1e-6)
    p = s.positions.astype(np.float64)
    ng = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    assert (ng[:, 2] > 0).all()                       # winding agrees with the shading normal


def test_linked_duplicates_read_the_mesh_once(empty, monkeypatch):
    import ppm_engine.blender.export.mesh as mesh_mod
    calls = []
    real = mesh_mod.read_mesh
    monkeypatch.setattr(mesh_mod, "read_mesh", lambda m: calls.append(m.name) or real(m))
    bpy.ops.mesh.primitive_cube_add(size=2.0)
    src = bpy.context.active_object
    for i in range(1, 40):
        d = src.copy()                                # linked duplicate: same mesh datablock
        d.location = (3 * i, 0, 0)
        d.rotation_euler = (0, 0, 0.1 * i)
        bpy.context.scene.collection.objects.link(d)
    s = export()
    assert s.n_triangles == 40 * 12 and len(calls) == 1
    for i in (0, 17, 39):                             # each copy is a rotated 2 m cube at 3 i
        mine = np.abs(s.positions.mean(1)[:, 0] - 3 * i) < 1.5
        local = s.positions[mine].reshape(-1, 3) - (3 * i, 0, 0)
        rz = np.array([[np.cos(0.1 * i), np.sin(0.1 * i)], [-np.sin(0.1 * i), np.cos(0.1 * i)]])
        back = local[:, :2] @ rz.T                    # undo the rotation
        np.testing.assert_allclose(np.abs(back), 1.0, atol=1e-5)
        np.testing.assert_allclose(np.abs(local[:, 2]), 1.0, atol=1e-6)


def test_geometry_nodes_instances(empty):
    bpy.ops.mesh.primitive_plane_add()
    host = bpy.context.active_object
    host.name = "GNHost"
    tree = bpy.data.node_groups.new("GN", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out='INPUT', socket_type='NodeSocketGeometry')
    tree.interface.new_socket("Geometry", in_out='OUTPUT', socket_type='NodeSocketGeometry')
    out = tree.nodes.new("NodeGroupOutput")
    line = tree.nodes.new("GeometryNodeMeshLine")
    line.inputs["Count"].default_value = 5
    line.inputs["Offset"].default_value = (2.0, 0.0, 0.0)
    cube = tree.nodes.new("GeometryNodeMeshCube")
    inst = tree.nodes.new("GeometryNodeInstanceOnPoints")
    tree.links.new(line.outputs["Mesh"], inst.inputs["Points"])
    tree.links.new(cube.outputs["Mesh"], inst.inputs["Instance"])
    tree.links.new(inst.outputs["Instances"], out.inputs[0])
    mod = host.modifiers.new("GN", 'NODES')
    mod.node_group = tree
    s = export()
    assert s.n_triangles == 5 * 12
    centres = np.unique(s.positions.reshape(-1, 12, 3, 3).mean(axis=(1, 2)).round(4), axis=0)
    np.testing.assert_allclose(centres, [(2 * i, 0, 0) for i in range(5)], atol=1e-5)


def test_text_and_curve_objects_become_triangles(empty):
    txt = bpy.data.objects.new("Txt", bpy.data.curves.new("Txt", 'FONT'))
    txt.data.body = "Hi"
    bpy.context.scene.collection.objects.link(txt)
    cu = bpy.data.curves.new("Tube", 'CURVE')
    cu.bevel_depth = 0.1
    sp = cu.splines.new('POLY')
    sp.points.add(1)
    sp.points[1].co = (0, 0, 2, 1)
    tube = bpy.data.objects.new("Tube", cu)
    tube.location = (5, 0, 0)
    bpy.context.scene.collection.objects.link(tube)
    s = export()
    cx = s.positions[:, :, 0].mean(1)
    assert (cx < 3).sum() > 10 and (cx > 4).sum() > 10 and np.isfinite(s.normals).all()
    np.testing.assert_allclose(np.linalg.norm(s.normals, axis=2), 1.0, rtol=1e-5)


# --- the real render depsgraph ------------------------------------------------------------------
class _Probe(bpy.types.RenderEngine):
    """Test-only engine: exports the render depsgraph, writes a black result."""
    bl_idname = "PPM_EXPORT_PROBE"
    bl_label = "export probe"
    result = None

    def render(self, depsgraph):
        try:
            type(self).result = export_scene(depsgraph, self)
        finally:
            r = self.begin_result(0, 0, self.resolution_x, self.resolution_y)
            self.end_result(r)


@pytest.fixture
def probe(empty):
    bpy.utils.register_class(_Probe)
    empty.render.engine = _Probe.bl_idname
    empty.render.resolution_x = empty.render.resolution_y = 8
    _Probe.result = None

    def run():
        bpy.ops.render.render()
        assert _Probe.result is not None
        return _Probe.result
    yield run
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.utils.unregister_class(_Probe)


def test_render_depsgraph_honours_hide_render_and_reports(probe, capfd):
    add_plane("Shown")
    h = add_plane("Hidden", loc=(5, 0, 0))
    h.hide_render = True
    v = add_plane("ViewportHidden", loc=(10, 0, 0))
    v.hide_viewport = True                            # still rendered
    add_light('POINT', "Lamp")
    off = add_light('SUN', "OffLamp")
    off.hide_render = True
    toon = bpy.data.materials.new("ToonProbe")
    t = toon.node_tree
    t.nodes.remove(t.nodes["Principled BSDF"])
    t.links.new(t.nodes.new("ShaderNodeBsdfToon").outputs[0],
                t.nodes["Material Output"].inputs["Surface"])
    bpy.data.objects["Shown"].data.materials.append(toon)
    s = probe()
    cx = np.sort(np.unique(s.positions[:, :, 0].mean(1).round(3)))
    assert s.n_triangles == 4 and set(np.round(cx / 5).astype(int)) == {0, 2}
    assert s.lights.shape == (1,) and s.lights[0]["type"] == LIGHT_POINT
    assert any("ToonProbe" in w for w in s.warnings)
    assert "Warning: Material 'ToonProbe'" in "".join(capfd.readouterr())
