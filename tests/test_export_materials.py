"""Blender scene -> SceneArrays: each material kind (Principled, Emission, every BSDF node,
the fallbacks for the rest), Mix and Add Shader weights, an alpha texture, tangents for
anisotropic materials and tangent-space normal maps, material slots, one table entry per
material and empty slots (the helpers are tests/helpers/blender_scenes.py's)."""
import math

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from ppm_engine.scene.arrays import (
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
)
from tests.helpers.blender_scenes import add_plane, export


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
