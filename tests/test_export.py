"""Blender scene -> SceneArrays: each light type, material kind, camera type and instancing."""
import math

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")
from mathutils import Vector

from ppm_engine.errors import SceneError
from ppm_engine.export import export_scene
from ppm_engine.scene_arrays import (
    CAMERA_ORTHO,
    FILM_TRANSPARENT,
    FILM_TRANSPARENT_GLASS,
    FILTER_BLACKMAN_HARRIS,
    FILTER_BOX,
    FILTER_GAUSSIAN,
    LIGHT_AREA_ELLIPSE,
    LIGHT_AREA_RECT,
    LIGHT_FLAG_SOFT_FALLOFF,
    LIGHT_POINT,
    LIGHT_SPOT,
    LIGHT_SUN,
    NODE_DIFFUSE,
    NODE_EMISSION,
    NODE_FLAG_CONDUCTOR,
    NODE_GLASS,
    NODE_GLOSSY,
    NODE_HOLDOUT,
    NODE_METALLIC,
    NODE_PRINCIPLED,
    NODE_REFRACTION,
    NODE_SHEEN,
    NODE_TRANSLUCENT,
    NODE_TRANSPARENT,
    VIS_CAMERA,
    VIS_SHADOW,
    SceneArrays,
)


@pytest.fixture
def empty():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.render.resolution_x, scene.render.resolution_y = 64, 48
    return scene


def export():
    return export_scene(bpy.context.evaluated_depsgraph_get())


def add_light(kind, name="L", loc=(0, 0, 3), **props):
    data = bpy.data.lights.new(name, kind)
    for k, v in props.items():
        setattr(data, k, v)
    obj = bpy.data.objects.new(name, data)
    obj.location = loc
    bpy.context.scene.collection.objects.link(obj)
    return obj


def add_plane(name="Plane", material=None, loc=(0, 0, 0), size=2.0):
    bpy.ops.mesh.primitive_plane_add(size=size, location=loc)
    obj = bpy.context.active_object
    obj.name = name
    if material is not None:
        obj.data.materials.append(material)
    return obj


# --- lights -------------------------------------------------------------------------------------
def test_point_light_cycles_units(empty):
    add_light('POINT', energy=100.0, color=(1, 0.5, 0.25), shadow_soft_size=0.2, exposure=1.0)
    L = export().lights
    assert L.shape == (1,) and L["type"][0] == LIGHT_POINT
    np.testing.assert_allclose(L["emit"][0], np.array([1, 0.5, 0.25]) * 200 / (4 * np.pi),
                               rtol=1e-6)
    assert L["radius"][0] == pytest.approx(0.2) and L["flags"][0] & LIGHT_FLAG_SOFT_FALLOFF
    np.testing.assert_allclose(L["position"][0], (0, 0, 3))


def test_spot_light_cone(empty):
    o = add_light('SPOT', energy=50.0, spot_size=math.radians(60), spot_blend=0.25)
    o.rotation_euler = (math.radians(90), 0, 0)            # points along +y
    L = export().lights[0]
    assert L["type"] == LIGHT_SPOT
    np.testing.assert_allclose(L["emit"], 50 / (4 * np.pi), rtol=1e-6)
    assert L["spot_cos_half"] == pytest.approx(math.cos(math.radians(30)))
    assert L["spot_smooth"] == pytest.approx((1 - math.cos(math.radians(30))) * 0.25)
    np.testing.assert_allclose(L["direction"], (0, 1, 0), atol=1e-6)
    assert L["spot_scale_z"] == pytest.approx(1.0)


def test_sun_light(empty):
    o = add_light('SUN', energy=3.0, angle=math.radians(2))
    o.rotation_euler = (math.radians(30), 0, 0)
    L = export().lights[0]
    assert L["type"] == LIGHT_SUN and L["radius"] == pytest.approx(math.radians(1))
    np.testing.assert_allclose(L["emit"], 3.0, rtol=1e-6)
    np.testing.assert_allclose(L["direction"],
                               (0, math.sin(math.radians(30)), -math.cos(math.radians(30))),
                               atol=1e-6)


@pytest.mark.parametrize("shape,sx,sy,area,kind", [
    ('SQUARE', 2.0, None, 4.0, LIGHT_AREA_RECT),
    ('RECTANGLE', 2.0, 1.0, 2.0, LIGHT_AREA_RECT),
    ('DISK', 2.0, None, math.pi, LIGHT_AREA_ELLIPSE),
    ('ELLIPSE', 2.0, 1.0, math.pi / 2, LIGHT_AREA_ELLIPSE)])
def test_area_light_radiance(empty, shape, sx, sy, area, kind):
    props = dict(energy=50.0, shape=shape, size=sx)
    if sy is not None:
        props["size_y"] = sy
    o = add_light('AREA', **props)
    o.scale = (1.0, 1.5, 1.0)                               # object scale enlarges the light
    L = export().lights[0]
    assert L["type"] == kind
    np.testing.assert_allclose(L["emit"], 50 / (np.pi * area * 1.5), rtol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(L["axis_y"]), (sy or sx) * 1.5, rtol=1e-6)
    np.testing.assert_allclose(L["direction"], (0, 0, -1), atol=1e-7)


# --- materials ----------------------------------------------------------------------------------
def test_principled_emission_and_fallback_materials(empty):
    p = bpy.data.materials.new("Gold")
    n = p.node_tree.nodes["Principled BSDF"]
    n.inputs["Base Color"].default_value = (0.9, 0.6, 0.2, 1)
    n.inputs["Metallic"].default_value = 1.0
    n.inputs["Roughness"].default_value = 0.1
    n.inputs["Emission Color"].default_value = (1, 0, 0, 1)
    n.inputs["Emission Strength"].default_value = 2.0
    e = bpy.data.materials.new("Glow")
    t = e.node_tree
    t.nodes.remove(t.nodes["Principled BSDF"])
    em = t.nodes.new("ShaderNodeEmission")
    em.inputs["Strength"].default_value = 5.0
    em.inputs["Color"].default_value = (0.5, 1, 1, 1)
    t.links.new(em.outputs[0], t.nodes["Material Output"].inputs["Surface"])
    d = bpy.data.materials.new("Toon")
    t = d.node_tree
    t.nodes.remove(t.nodes["Principled BSDF"])
    tn = t.nodes.new("ShaderNodeBsdfToon")
    t.links.new(tn.outputs[0], t.nodes["Material Output"].inputs["Surface"])
    for i, m in enumerate((p, e, d)):
        add_plane(f"P{i}", m, loc=(3 * i, 0, 0))
    s = export()
    (g,) = s.nodes_of("Gold")
    assert g["type"] == NODE_PRINCIPLED
    np.testing.assert_allclose(g["color"], (0.9, 0.6, 0.2), rtol=1e-6)
    assert g["metallic"] == 1.0 and g["roughness"] == pytest.approx(0.1)
    np.testing.assert_allclose(g["emission"], (2, 0, 0))
    (glow,) = s.nodes_of("Glow")
    assert glow["type"] == NODE_EMISSION
    np.testing.assert_allclose(glow["emission"], (2.5, 5, 5))
    (toon,) = s.nodes_of("Toon")
    assert toon["type"] == NODE_DIFFUSE
    np.testing.assert_allclose(toon["color"], 0.8)
    assert sum("Toon" in w for w in s.warnings) == 1
    # per-triangle material follows the object
    for i, name in enumerate(("Gold", "Glow", "Toon")):
        tris = np.abs(s.positions[:, :, 0].mean(1) - 3 * i) < 1.5
        assert (np.array(s.material_names)[s.material[tris]] == name).all()


def _node_material(name, build):
    """A material whose surface is what build(tree, output_socket) links into it."""
    m = bpy.data.materials.new(name)
    t = m.node_tree
    t.nodes.remove(t.nodes["Principled BSDF"])
    build(t, t.nodes["Material Output"].inputs["Surface"])
    return m


def test_mix_and_add_shaders_fold_into_node_weights(empty):
    """Mix Shader weights (1 - fac, fac) and Add Shader sums propagate into every BSDF node's
    weight, through reroutes and nested mixes, as Cycles propagates them into closures."""
    def build(t, out):
        d = t.nodes.new("ShaderNodeBsdfDiffuse")
        d.inputs["Color"].default_value = (0.2, 0.4, 0.6, 1)
        d.inputs["Roughness"].default_value = 0.3
        g = t.nodes.new("ShaderNodeBsdfAnisotropic")
        g.inputs["Roughness"].default_value = 0.25
        g.distribution = "GGX"
        e = t.nodes.new("ShaderNodeEmission")
        e.inputs["Strength"].default_value = 4.0
        mix = t.nodes.new("ShaderNodeMixShader")
        mix.inputs[0].default_value = 0.3
        add = t.nodes.new("ShaderNodeAddShader")
        r = t.nodes.new("NodeReroute")
        t.links.new(d.outputs[0], mix.inputs[1])
        t.links.new(g.outputs[0], r.inputs[0])
        t.links.new(r.outputs[0], mix.inputs[2])
        t.links.new(mix.outputs[0], add.inputs[0])
        t.links.new(e.outputs[0], add.inputs[1])
        t.links.new(add.outputs[0], out)
    add_plane("P", _node_material("Mixed", build))
    s = export()
    nodes = s.nodes_of("Mixed")
    assert [int(n["type"]) for n in nodes] == [NODE_DIFFUSE, NODE_GLOSSY, NODE_EMISSION]
    np.testing.assert_allclose(nodes["weight"], (0.7, 0.3, 1.0), rtol=1e-6)
    np.testing.assert_allclose(nodes[0]["color"], (0.2, 0.4, 0.6), rtol=1e-6)
    assert nodes[0]["roughness"] == pytest.approx(0.3)
    assert nodes[1]["roughness"] == pytest.approx(0.25) and nodes[1]["flags"] == 0
    np.testing.assert_allclose(nodes[2]["emission"], 4.0)
    assert not [w for w in s.warnings if "Mixed" in w]


def test_every_bsdf_node_is_read(empty):
    kinds = {}

    def one(idname, **inputs):
        def build(t, out):
            n = t.nodes.new(idname)
            for k, v in inputs.items():
                if k == "fresnel_type":
                    n.fresnel_type = v
                else:
                    n.inputs[k].default_value = v
            t.links.new(n.outputs[0], out)
        return build
    specs = {
        "Glass": (one("ShaderNodeBsdfGlass", IOR=1.33, Roughness=0.2), NODE_GLASS),
        "Refr": (one("ShaderNodeBsdfRefraction", IOR=1.2, Roughness=0.0), NODE_REFRACTION),
        "Transl": (one("ShaderNodeBsdfTranslucent"), NODE_TRANSLUCENT),
        "Transp": (one("ShaderNodeBsdfTransparent"), NODE_TRANSPARENT),
        "Sheen": (one("ShaderNodeBsdfSheen", Roughness=0.3), NODE_SHEEN),
        "Hold": (one("ShaderNodeHoldout"), NODE_HOLDOUT),
        "Metal": (one("ShaderNodeBsdfMetallic", fresnel_type="PHYSICAL_CONDUCTOR"), NODE_METALLIC),
        "F82": (one("ShaderNodeBsdfMetallic"), NODE_METALLIC),
        "SSS": (one("ShaderNodeSubsurfaceScattering"), NODE_DIFFUSE),
    }
    for i, (name, (build, kind)) in enumerate(specs.items()):
        add_plane(name, _node_material(name, build), loc=(3 * i, 0, 0))
        kinds[name] = kind
    s = export()
    for name, kind in kinds.items():
        (n,) = s.nodes_of(name)
        assert n["type"] == kind, name
    assert s.nodes_of("Glass")[0]["ior"] == pytest.approx(1.33)
    assert s.nodes_of("Refr")[0]["ior"] == pytest.approx(1.2)
    metal = s.nodes_of("Metal")[0]
    assert metal["flags"] & NODE_FLAG_CONDUCTOR
    np.testing.assert_allclose(metal["color"], (2.757, 2.513, 2.231), rtol=1e-3)   # n
    np.testing.assert_allclose(metal["edge_tint"], (3.867, 3.404, 3.009), rtol=1e-3)  # k
    f82 = s.nodes_of("F82")[0]
    assert not f82["flags"] & NODE_FLAG_CONDUCTOR
    np.testing.assert_allclose(f82["edge_tint"], (0.695, 0.726, 0.77), rtol=1e-3)
    assert sum("SSS" in w and "diffuse" in w for w in s.warnings) == 1


def test_principled_alpha_from_an_image_alpha(empty):
    img = bpy.data.images.new("A", 2, 2, alpha=True)
    img.pixels = [1, 1, 1, 0.25] * 4
    m = bpy.data.materials.new("Leaf")
    t = m.node_tree
    tex = t.nodes.new("ShaderNodeTexImage")
    tex.image = img
    t.links.new(tex.outputs["Alpha"], t.nodes["Principled BSDF"].inputs["Alpha"])
    add_plane("P", m)
    s = export()
    (n,) = s.nodes_of("Leaf")
    assert n["alpha_texture"] == 1 and n["alpha"] == 1.0 and n["color_texture"] == 0
    np.testing.assert_allclose(s.texels[:, 3].astype(np.float32), 0.25, atol=1e-3)


def test_anisotropic_materials_get_radial_tangents(empty):
    """Tangents only when a material is anisotropic: Cycles' radial tangent around the
    object's Z axis, (-(g.y - 1/2), g.x - 1/2, 0) of the Generated coordinates, in world space
    (here an object rotated 90 degrees about Z); none otherwise."""
    plain = bpy.data.materials.new("Plain")
    add_plane("A", plain)
    s = export()
    assert s.tangents.shape == (0, 3, 3)
    aniso = bpy.data.materials.new("Brushed")
    _principled = aniso.node_tree.nodes["Principled BSDF"]
    _principled.inputs["Anisotropic"].default_value = 0.5
    b = add_plane("B", aniso, loc=(5, 0, 0))
    b.rotation_euler = (0, 0, math.pi / 2)
    s = export()
    assert s.tangents.shape == s.positions.shape
    mine = s.material == s.material_names.index("Brushed")
    assert not s.tangents[~mine].any()
    # the corners in the plane's own space are (+-1, +-1, 0), Generated (0 or 1): g - 1/2 is
    # (+-1/2, +-1/2) and the tangent (-y, x) / 2 of it, turned with the object: horizontal,
    # at right angles to the corner's radius from the object's centre, of length sqrt(1/2)
    t = s.tangents[mine].reshape(-1, 3)
    p = (s.positions[mine].reshape(-1, 3) - (5, 0, 0))
    np.testing.assert_allclose(t[:, 2], 0, atol=1e-6)
    np.testing.assert_allclose(np.einsum("ij,ij->i", t, p), 0, atol=1e-5)   # around Z
    np.testing.assert_allclose(np.linalg.norm(t, axis=1), np.sqrt(0.5), rtol=1e-5)


def test_material_slots_and_out_of_range_index(empty):
    a, b = bpy.data.materials.new("A"), bpy.data.materials.new("B")
    bpy.ops.mesh.primitive_cube_add()
    cube = bpy.context.active_object
    cube.data.materials.append(a)
    cube.data.materials.append(b)
    idx = np.zeros(6, np.int32)
    idx[1], idx[2] = 1, 5                      # 5 > slot count: clamped to the last slot
    cube.data.attributes["material_index"].data.foreach_set("value", idx) \
        if "material_index" in cube.data.attributes else \
        cube.data.attributes.new("material_index", 'INT', 'FACE').data.foreach_set("value", idx)
    s = export()
    names = np.array(s.material_names)[s.material]
    assert (names == "A").sum() == 8 and (names == "B").sum() == 4


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


# --- camera -------------------------------------------------------------------------------------
def _ray_dir(cam, px, py):
    c = cam[0]
    xc = (px / c["width"] - 0.5) * c["extent"][0] + c["shift"][0]
    yc = (py / c["height"] - 0.5) * c["extent"][1] + c["shift"][1]
    m = c["to_world"].astype(np.float64)
    return m[:, :3] @ np.array([xc, yc, -1.0]), m[:, 3]


@pytest.mark.parametrize("fit,shift,aspect,pct", [('AUTO', (0, 0), (1, 1), 100),
                                                  ('VERTICAL', (0.1, -0.2), (1, 1), 50),
                                                  ('HORIZONTAL', (0, 0.3), (2, 1), 100)])
def test_perspective_camera_matches_blender_projection(empty, fit, shift, aspect, pct):
    from bpy_extras.object_utils import world_to_camera_view
    scene = empty
    cam = scene.camera
    cam.location = (1, -6, 2)
    cam.rotation_euler = (math.radians(80), math.radians(5), math.radians(10))
    cam.data.lens, cam.data.sensor_fit = 42.0, fit
    cam.data.shift_x, cam.data.shift_y = shift
    scene.render.pixel_aspect_x, scene.render.pixel_aspect_y = aspect
    scene.render.resolution_percentage = pct
    s = export()
    W, H = s.camera["width"][0], s.camera["height"][0]
    assert (int(64 * pct / 100), int(48 * pct / 100)) == (W, H)
    rng = np.random.default_rng(0)
    for _ in range(20):
        p = Vector(rng.uniform(-2, 2, 3))
        ndc = world_to_camera_view(scene, cam, p)
        d, o = _ray_dir(s.camera, ndc.x * W, ndc.y * H)
        v = np.array(p) - o
        cosang = v @ d / np.linalg.norm(v) / np.linalg.norm(d)
        assert cosang == pytest.approx(1.0, abs=1e-6)


def test_ortho_camera_and_border(empty):
    scene = empty
    scene.camera.data.type = 'ORTHO'
    scene.camera.data.ortho_scale = 4.0
    scene.render.use_border = True
    scene.render.border_min_x, scene.render.border_max_x = 0.25, 0.8
    scene.render.border_min_y, scene.render.border_max_y = 0.1, 0.55
    s = export()
    c = s.camera[0]
    assert c["type"] == CAMERA_ORTHO
    np.testing.assert_allclose(c["extent"], (4.0, 3.0))
    assert tuple(c["region"]) == (16, 4, int(0.8 * 64) - 16, int(0.55 * 48) - 4)
    assert s.resolution == (c["region"][2], c["region"][3])


@pytest.mark.parametrize("kind, width, expect", [
    ("BLACKMAN_HARRIS", 2.0, (FILTER_BLACKMAN_HARRIS, 2.0)),
    ("GAUSSIAN", 0.8, (FILTER_GAUSSIAN, 0.8)),
    ("BOX", 3.0, (FILTER_BOX, 1.0)),        # Blender's Cycles: the box is one pixel wide
])
def test_film_settings_are_cycles_film(empty, kind, width, expect):
    """The pixel filter, film exposure and transparency come from the scene's Cycles film
    settings (not EEVEE's render.filter_size)."""
    scene = empty
    scene.render.filter_size = 0.25          # EEVEE's: not read
    scene.cycles.pixel_filter_type, scene.cycles.filter_width = kind, width
    scene.cycles.film_exposure = 1.7
    scene.render.film_transparent = True
    scene.cycles.film_transparent_glass = True
    scene.cycles.film_transparent_roughness = 0.25
    c = export().camera[0]
    assert (int(c["filter_type"]), float(c["filter_width"])) == pytest.approx(expect)
    assert c["exposure"] == pytest.approx(1.7)
    assert c["film_transparent"] == FILM_TRANSPARENT | FILM_TRANSPARENT_GLASS
    assert c["glass_roughness"] == pytest.approx(0.25)
    scene.cycles.film_transparent_glass = False
    assert export().camera[0]["film_transparent"] == FILM_TRANSPARENT
    scene.render.film_transparent = False
    assert export().camera[0]["film_transparent"] == 0


def test_film_settings_not_a_number_are_refused():
    """A film exposure or filter width that is not a number: a SceneError naming the setting."""
    from types import SimpleNamespace

    from ppm_engine.export.camera import film_settings
    for name in ("film_exposure", "filter_width"):
        cycles = SimpleNamespace(**{name: float("nan")})
        with pytest.raises(SceneError, match=name.replace("_", " ")):
            film_settings(SimpleNamespace(cycles=cycles,
                                          render=SimpleNamespace(film_transparent=False)))


def test_film_settings_without_cycles_are_its_defaults():
    """Without the Cycles add-on (no scene.cycles): Cycles' defaults."""
    from types import SimpleNamespace

    from ppm_engine.export.camera import film_settings
    f = film_settings(SimpleNamespace(render=SimpleNamespace(film_transparent=False)))
    assert f == dict(filter_type=FILTER_BLACKMAN_HARRIS, filter_width=1.5, film_transparent=0,
                     glass_roughness=pytest.approx(0.1), exposure=1.0)


def test_no_camera_is_a_scene_error(empty):
    e = bpy.data.objects.new("Empty", None)
    empty.collection.objects.link(e)
    empty.camera = e
    with pytest.raises(SceneError, match="not a camera"):
        export()


def test_world_colour_and_npz_round_trip(empty, tmp_path):
    w = bpy.data.worlds.new("W")
    bg = w.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.2, 0.4, 0.6, 1)
    bg.inputs["Strength"].default_value = 2.0
    empty.world = w
    add_plane()
    add_light('POINT')
    s = export()
    np.testing.assert_allclose(s.world, (0.4, 0.8, 1.2), rtol=1e-6)
    s.save(tmp_path / "s.npz")
    t = SceneArrays.load(tmp_path / "s.npz")
    for name in ("positions", "normals", "uvs", "material", "visibility", "materials", "lights",
                 "camera", "world"):
        assert np.array_equal(getattr(s, name), getattr(t, name))


# --- more lights --------------------------------------------------------------------------------
def test_unnormalized_lights_keep_the_documented_meaning(empty):
    add_light('POINT', "P", energy=100.0, shadow_soft_size=0.5, normalize=False,
              use_soft_falloff=False)
    add_light('POINT', "P0", energy=100.0, shadow_soft_size=0.0, normalize=False)
    add_light('AREA', "A", energy=50.0, shape='RECTANGLE', size=2.0, size_y=1.0, normalize=False)
    lights = export().lights
    by_radius = {float(l["radius"]): l for l in lights if l["type"] == LIGHT_POINT}
    # sphere radiance L = P/pi (area not divided) <=> intensity I = L * pi r^2 = P r^2
    np.testing.assert_allclose(by_radius[0.5]["emit"], 100 * 0.25, rtol=1e-6)
    assert by_radius[0.5]["flags"] & LIGHT_FLAG_SOFT_FALLOFF == 0
    np.testing.assert_allclose(by_radius[0.0]["emit"], 100 / (4 * np.pi), rtol=1e-6)
    area = lights[lights["type"] == LIGHT_AREA_RECT][0]
    np.testing.assert_allclose(area["emit"], 50 / np.pi, rtol=1e-6)


def test_spot_axes_follow_the_scaled_frame(empty):
    o = add_light('SPOT', energy=10.0, loc=(1, 2, 3))
    o.scale = (2, 3, 4)
    L = export().lights[0]
    np.testing.assert_allclose(L["axis_x"], (2, 0, 0), atol=1e-6)
    np.testing.assert_allclose(L["axis_y"], (0, 3, 0), atol=1e-6)
    assert L["spot_scale_z"] == pytest.approx(0.25)
    np.testing.assert_allclose(L["direction"], (0, 0, -1), atol=1e-7)
    np.testing.assert_allclose(L["position"], (1, 2, 3), atol=1e-6)


def test_light_temperature_and_zero_strength(empty):
    o = add_light('POINT', "T", energy=40.0, use_temperature=True, temperature=3000.0)
    add_light('POINT', "Off", energy=0.0, loc=(5, 0, 0))
    lights = export().lights
    assert lights.shape == (2,)                      # zero-strength lights are still exported
    tc = np.array(o.data.temperature_color[:3])
    assert not np.allclose(tc, 1.0)                  # 3000 K is reddish
    np.testing.assert_allclose(lights[0]["emit"], 40 / (4 * np.pi) * tc, rtol=1e-5)
    np.testing.assert_allclose(lights[1]["emit"], 0.0)


# --- more materials -----------------------------------------------------------------------------
def test_glass_linked_input_dedup_and_empty_slots(empty):
    g = bpy.data.materials.new("Glass")
    n = g.node_tree.nodes["Principled BSDF"]
    n.inputs["Transmission Weight"].default_value = 1.0
    n.inputs["IOR"].default_value = 1.33
    n.inputs["Roughness"].default_value = 0.0
    tex = g.node_tree.nodes.new("ShaderNodeAmbientOcclusion")
    g.node_tree.links.new(tex.outputs["Color"], n.inputs["Base Color"])
    a = add_plane("A", g)
    add_plane("B", g, loc=(3, 0, 0))                  # same material: one table entry
    c = add_plane("C", loc=(6, 0, 0))
    c.data.materials.append(None)                     # empty slot -> default grey
    s = export()
    assert s.material_names.count("Glass") == 1 and s.materials.shape[0] == 2
    (m,) = s.nodes_of("Glass")
    assert m["transmission"] == 1.0 and m["ior"] == pytest.approx(1.33) and m["roughness"] == 0.0
    # a node the engine does not evaluate: its output's default value, warned once
    np.testing.assert_allclose(m["color"], tuple(tex.outputs["Color"].default_value)[:3])
    assert sum("Glass" in w and tex.name in w for w in s.warnings) == 1
    cx = s.positions[:, :, 0].mean(1)
    assert (s.material[cx > 5] == 0).all() and (s.material[cx < 5] == 1).all()
    (d,) = s.nodes_of(0)                              # Cycles' default surface: grey diffuse
    assert d["type"] == NODE_DIFFUSE
    np.testing.assert_allclose(d["color"], 0.8)
    assert a.name == "A"


def test_uvs_follow_the_corners(empty):
    add_plane(size=2.0)                               # primitive plane: uv = (x + 1) / 2
    s = export()
    np.testing.assert_allclose(s.uvs, (s.positions[:, :, :2] + 1) / 2, atol=1e-6)


# --- more geometry ------------------------------------------------------------------------------
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
    import ppm_engine.export.mesh as mesh_mod
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


# --- more camera --------------------------------------------------------------------------------
def test_ortho_rays_match_blender_projection(empty):
    from bpy_extras.object_utils import world_to_camera_view
    scene = empty
    cam = scene.camera
    cam.data.type, cam.data.ortho_scale = 'ORTHO', 5.0
    cam.data.shift_x, cam.data.sensor_fit = 0.15, 'VERTICAL'
    cam.location, cam.rotation_euler = (0, -8, 1), (math.radians(85), 0, math.radians(-5))
    cam.scale = (1.5, 0.5, 2.0)                       # camera scale is ignored by rays
    s = export()
    c = s.camera[0]
    m = c["to_world"].astype(np.float64)
    np.testing.assert_allclose(np.linalg.norm(m[:, :3], axis=0), 1.0, rtol=1e-6)
    rng = np.random.default_rng(1)
    for _ in range(10):
        p = Vector(rng.uniform(-2, 2, 3))
        ndc = world_to_camera_view(scene, cam, p)
        xc = (ndc.x - 0.5) * c["extent"][0] + c["shift"][0]
        yc = (ndc.y - 0.5) * c["extent"][1] + c["shift"][1]
        local = m[:, :3].T @ (np.array(p) - m[:, 3])  # point in camera space
        np.testing.assert_allclose(local[:2], (xc, yc), atol=1e-5)


def test_depth_of_field(empty):
    cam = empty.camera
    cam.data.lens = 50.0
    dof = cam.data.dof
    dof.use_dof, dof.aperture_fstop = True, 2.0
    dof.aperture_blades, dof.aperture_rotation, dof.aperture_ratio = 6, 0.3, 1.5
    target = bpy.data.objects.new("Target", None)
    target.location = (1.0, 0.5, -5.0)                # camera at the origin looks down -Z
    empty.collection.objects.link(target)
    dof.focus_object = target
    c = export().camera[0]
    assert c["aperture_radius"] == pytest.approx(0.05 / 4)
    assert c["focus_distance"] == pytest.approx(5.0)
    assert c["aperture_blades"] == 6 and c["aperture_rotation"] == pytest.approx(0.3)
    assert c["aperture_ratio"] == pytest.approx(1.5)
    dof.focus_object, dof.focus_distance = None, 3.5
    cam.data.type = 'ORTHO'
    c = export().camera[0]
    assert c["aperture_radius"] == pytest.approx(0.25) and c["focus_distance"] == pytest.approx(3.5)


def test_panoramic_camera_and_empty_border_are_scene_errors(empty):
    empty.render.use_border = True
    empty.render.border_min_x = empty.render.border_max_x = 0.5
    with pytest.raises(SceneError, match="border"):
        export()
    empty.render.use_border = False
    empty.camera.data.type = 'PANO'
    with pytest.raises(SceneError, match="not supported"):
        export()


def test_world_fallbacks(empty):
    assert empty.world is None
    np.testing.assert_array_equal(export().world, 0)
    w = bpy.data.worlds.new("Odd")
    t = w.node_tree
    d = t.nodes.new("ShaderNodeBsdfDiffuse")
    t.links.new(d.outputs[0], t.nodes["World Output"].inputs["Surface"])
    w.color = (0.1, 0.2, 0.3)
    empty.world = w
    s = export()
    np.testing.assert_allclose(s.world, (0.1, 0.2, 0.3), rtol=1e-6)
    assert any("Odd" in m for m in s.warnings)


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


def test_light_ray_visibility_flags(empty):
    """Blender makes lights invisible to camera rays by default (Cycles then does not show
    them); glossy and transmission rays see them unless turned off."""
    from ppm_engine.scene_arrays import LIGHT_HIDDEN_SHIFT, VIS_CAMERA, VIS_GLOSSY, VIS_TRANSMISSION
    add_light('POINT', "Default")
    o = add_light('AREA', "Shown", loc=(1, 0, 3))
    o.visible_camera, o.visible_glossy = True, False
    lights = export().lights
    hidden = {int(l["type"]): int(l["flags"]) >> LIGHT_HIDDEN_SHIFT for l in lights}
    assert hidden[LIGHT_POINT] == VIS_CAMERA
    assert hidden[LIGHT_AREA_RECT] == VIS_GLOSSY
    assert not any(h & VIS_TRANSMISSION for h in hidden.values())


def test_uv_tangents_only_for_tangent_space_normal_maps(empty):
    """The UV map's MikkTSpace tangents are exported (direction by the world matrix, sign flipped
    by a mirror) only when a material has a tangent-space Normal Map."""
    bpy.ops.mesh.primitive_plane_add(size=2)
    s = export()
    assert s.uv_tangents.shape == (0, 3, 4)
    mat = bpy.data.materials.new("bumpy")
    t = mat.node_tree
    nm = t.nodes.new("ShaderNodeNormalMap")
    t.links.new(nm.outputs[0], t.nodes["Principled BSDF"].inputs["Normal"])
    bpy.ops.mesh.primitive_plane_add(size=2, location=(3, 0, 0))
    obj = bpy.context.active_object
    obj.data.materials.append(mat)
    obj.rotation_euler.z, obj.scale.x = math.pi / 6, -2.0
    s = export()
    assert s.uv_tangents.shape == s.positions.shape[:2] + (4,)
    mine = s.material == s.material_names.index("bumpy")
    assert mine.any() and not s.uv_tangents[~mine].any()
    me = obj.data
    me.calc_tangents()
    t0 = np.array(me.loops[0].tangent)
    m3 = np.array(obj.matrix_world)[:3, :3]
    want = m3 @ t0
    want /= np.linalg.norm(want)
    got = s.uv_tangents[mine][..., :3].reshape(-1, 3)
    assert np.isclose(np.abs(got @ want), 1.0, atol=1e-5).all()      # one tangent everywhere
    np.testing.assert_allclose(s.uv_tangents[mine][..., 3], -me.loops[0].bitangent_sign)
