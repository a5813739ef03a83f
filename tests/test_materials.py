"""Materials against Cycles, rendered by both engines in the same test (Filter Glossy 0, no
clamping, no denoising: harness.cycles_reference): a sphere of each material under an area
light and a constant world, on a grey floor, per 8 x 8 block (mean within 3 %), direct light
only and full transport (one material's inputs come from a node graph: the shader program); and
white furnaces (the sphere alone in a white world), whose mean must match Cycles' within 1 %."""
import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from tests.helpers.blender_scenes import light_world_camera
from tests.helpers.cycles_blocks import blocks, compare_blocks, render_both


def _principled(mat, **inputs):
    p = mat.node_tree.nodes["Principled BSDF"]
    for k, v in inputs.items():
        p.inputs[k].default_value = (*v, 1.0) if isinstance(v, tuple) and len(v) == 3 else v
    return p


def _replace(mat, idname, **inputs):
    t = mat.node_tree
    t.nodes.remove(t.nodes["Principled BSDF"])
    n = t.nodes.new(idname)
    for k, v in inputs.items():
        if k == "distribution":
            n.distribution = v
        elif k == "fresnel_type":
            n.fresnel_type = v
        else:
            n.inputs[k].default_value = (*v, 1.0) if isinstance(v, tuple) and len(v) == 3 else v
    t.links.new(n.outputs[0], t.nodes["Material Output"].inputs["Surface"])
    return n


def _mix(mat, fac, a, b):
    """A Mix Shader of factor fac over nodes a and b ((idname, inputs)); fac None: an Add
    Shader."""
    t = mat.node_tree
    t.nodes.remove(t.nodes["Principled BSDF"])
    na = t.nodes.new(a[0])
    nb = t.nodes.new(b[0])
    for n, spec in ((na, a[1]), (nb, b[1])):
        for k, v in spec.items():
            n.inputs[k].default_value = (*v, 1.0) if isinstance(v, tuple) and len(v) == 3 else v
    if fac is None:
        m = t.nodes.new("ShaderNodeAddShader")
        t.links.new(na.outputs[0], m.inputs[0])
        t.links.new(nb.outputs[0], m.inputs[1])
    else:
        m = t.nodes.new("ShaderNodeMixShader")
        m.inputs[0].default_value = fac
        t.links.new(na.outputs[0], m.inputs[1])
        t.links.new(nb.outputs[0], m.inputs[2])
    t.links.new(m.outputs[0], t.nodes["Material Output"].inputs["Surface"])


def _tinted_glass(mat):
    _principled(mat, **{"Transmission Weight": 1.0, "Roughness": 0.0})
    t = mat.node_tree
    v = t.nodes.new("ShaderNodeVolumeAbsorption")
    v.inputs["Color"].default_value = (0.3, 0.6, 0.9, 1)
    v.inputs["Density"].default_value = 1.5
    t.links.new(v.outputs[0], t.nodes["Material Output"].inputs["Volume"])


def _node_graph(mat):
    """A Principled whose inputs come from value nodes (the shader program): metal where the
    UV's u > 0.5, roughness from the normal's height, colour through a Color Ramp of the facing
    weight, and a Mix Shader with a glossy coat by Layer Weight's Fresnel."""
    t = mat.node_tree
    p = t.nodes["Principled BSDF"]
    uv = t.nodes.new("ShaderNodeTexCoord")
    sep = t.nodes.new("ShaderNodeSeparateXYZ")
    t.links.new(uv.outputs["UV"], sep.inputs[0])
    gt = t.nodes.new("ShaderNodeMath")
    gt.operation, gt.inputs[1].default_value = "GREATER_THAN", 0.5
    t.links.new(sep.outputs[0], gt.inputs[0])
    t.links.new(gt.outputs[0], p.inputs["Metallic"])
    geo = t.nodes.new("ShaderNodeNewGeometry")
    nz = t.nodes.new("ShaderNodeSeparateXYZ")
    t.links.new(geo.outputs["Normal"], nz.inputs[0])
    rng = t.nodes.new("ShaderNodeMapRange")
    rng.inputs["From Min"].default_value, rng.inputs["To Min"].default_value = -1.0, 0.15
    rng.inputs["To Max"].default_value = 0.8
    t.links.new(nz.outputs[2], rng.inputs["Value"])
    t.links.new(rng.outputs[0], p.inputs["Roughness"])
    lw = t.nodes.new("ShaderNodeLayerWeight")
    ramp = t.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].color = (0.8, 0.3, 0.1, 1.0)
    ramp.color_ramp.elements[1].color = (0.1, 0.3, 0.8, 1.0)
    t.links.new(lw.outputs["Facing"], ramp.inputs[0])
    t.links.new(ramp.outputs[0], p.inputs["Base Color"])
    glossy = t.nodes.new("ShaderNodeBsdfAnisotropic")
    glossy.inputs["Roughness"].default_value = 0.3
    mix = t.nodes.new("ShaderNodeMixShader")
    t.links.new(lw.outputs["Fresnel"], mix.inputs[0])
    t.links.new(p.outputs[0], mix.inputs[1])
    t.links.new(glossy.outputs[0], mix.inputs[2])
    t.links.new(mix.outputs[0], t.nodes["Material Output"].inputs["Surface"])


def _normal_mapped(mat):
    """A glossy plastic whose Normal comes from a tangent-space Normal Map of a wavy height
    field (a float image, Non-Color): the UV map's tangents and the driven normal shade it."""
    n = 64
    y, x = np.mgrid[0:n, 0:n] / n
    gx, gy = 0.6 * np.cos(6 * np.pi * x), 0.4 * np.cos(4 * np.pi * y)
    nrm = np.stack([-gx, -gy, np.ones_like(gx)], -1)
    nrm /= np.linalg.norm(nrm, axis=-1, keepdims=True)
    px = np.concatenate([0.5 * nrm + 0.5, np.ones((n, n, 1))], -1).astype(np.float32)
    img = bpy.data.images.new("waves", n, n, float_buffer=True)
    img.colorspace_settings.name = "Non-Color"
    img.pixels.foreach_set(px.ravel())
    _principled(mat, **{"Base Color": (0.7, 0.5, 0.2), "Roughness": 0.35})
    t = mat.node_tree
    tex, nm = t.nodes.new("ShaderNodeTexImage"), t.nodes.new("ShaderNodeNormalMap")
    tex.image = img
    t.links.new(tex.outputs["Color"], nm.inputs["Color"])
    t.links.new(nm.outputs[0], t.nodes["Principled BSDF"].inputs["Normal"])


def _object_normal_mapped(mat):
    """A glossy plastic whose Normal comes from an object-space Normal Map: the object-space
    normal tilted along the object's X (Texture Coordinate Normal + (0.5, 0, 0), as a colour);
    the sphere is turned (``rotation``), so object space is not world space."""
    _principled(mat, **{"Base Color": (0.3, 0.6, 0.4), "Roughness": 0.3})
    t = mat.node_tree
    tc, add, col = (t.nodes.new(n) for n in ("ShaderNodeTexCoord", "ShaderNodeVectorMath",
                                              "ShaderNodeVectorMath"))
    add.operation = "NORMALIZE"
    tilt = t.nodes.new("ShaderNodeVectorMath")
    tilt.operation = "ADD"
    tilt.inputs[1].default_value = (0.5, 0.0, 0.0)
    t.links.new(tc.outputs["Normal"], tilt.inputs[0])
    t.links.new(tilt.outputs[0], add.inputs[0])
    col.operation = "MULTIPLY_ADD"
    col.inputs[1].default_value = col.inputs[2].default_value = (0.5, 0.5, 0.5)
    t.links.new(add.outputs[0], col.inputs[0])
    nm = t.nodes.new("ShaderNodeNormalMap")
    nm.space = "OBJECT"
    t.links.new(col.outputs[0], nm.inputs["Color"])
    t.links.new(nm.outputs[0], t.nodes["Principled BSDF"].inputs["Normal"])


_object_normal_mapped.rotation = (0.7, 0.4, 1.9)


def _bumped(mat, diffuse=False):
    """A rough plastic (or a diffuse BSDF) whose Normal comes from a Bump node on a Noise
    Texture's height (on the Object coordinates): the heights at the ray footprint's offsets on
    a smooth sphere, seen in perspective; in full transport the gather shades its visible
    points again with them (the diffuse one's f is no constant: the bumped normal's cosine)."""
    if diffuse:
        _replace(mat, "ShaderNodeBsdfDiffuse", Color=(0.3, 0.5, 0.7))
    else:
        _principled(mat, **{"Base Color": (0.3, 0.5, 0.7), "Roughness": 0.8})
    t = mat.node_tree
    tc, noise = t.nodes.new("ShaderNodeTexCoord"), t.nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 4.0
    bump = t.nodes.new("ShaderNodeBump")
    bump.inputs["Distance"].default_value = 0.3
    t.links.new(tc.outputs["Object"], noise.inputs["Vector"])
    t.links.new(noise.outputs["Fac"], bump.inputs["Height"])
    bsdf = next(n for n in t.nodes if n.type in ("BSDF_PRINCIPLED", "BSDF_DIFFUSE"))
    t.links.new(bump.outputs[0], bsdf.inputs["Normal"])


MATERIALS = {
    "plastic": lambda m: _principled(m, **{"Base Color": (0.7, 0.2, 0.1), "Roughness": 0.3}),
    "rough_metal": lambda m: _principled(m, **{"Base Color": (0.9, 0.6, 0.3), "Metallic": 1.0,
                                               "Roughness": 0.45}),
    "aniso_metal": lambda m: _principled(m, **{"Base Color": (0.9, 0.9, 0.9), "Metallic": 1.0,
                                               "Roughness": 0.4, "Anisotropic": 0.8}),
    "glossy_metal": lambda m: _principled(m, **{"Base Color": (0.8, 0.8, 0.85),
                                                "Metallic": 1.0, "Roughness": 0.15}),
    "rough_glass": lambda m: _principled(m, **{"Transmission Weight": 1.0, "Roughness": 0.3}),
    "tinted_glass": _tinted_glass,
    "coat": lambda m: _principled(m, **{"Base Color": (0.6, 0.05, 0.05), "Roughness": 0.6,
                                        "Coat Weight": 1.0, "Coat Roughness": 0.05}),
    "sheen": lambda m: _principled(m, **{"Base Color": (0.05, 0.05, 0.2), "Sheen Weight": 1.0,
                                         "Sheen Tint": (1.0, 0.6, 0.3), "Roughness": 0.8}),
    "oren_nayar": lambda m: _replace(m, "ShaderNodeBsdfDiffuse", Color=(0.6, 0.6, 0.3),
                                     Roughness=0.8),
    "conductor": lambda m: _replace(m, "ShaderNodeBsdfMetallic", Roughness=0.3,
                                    fresnel_type="PHYSICAL_CONDUCTOR"),
    "mix": lambda m: _mix(m, 0.5, ("ShaderNodeBsdfDiffuse", {"Color": (0.2, 0.5, 0.2)}),
                          ("ShaderNodeBsdfAnisotropic", {"Roughness": 0.25})),
    "glossy": lambda m: _replace(m, "ShaderNodeBsdfAnisotropic", Roughness=0.25),
    "add": lambda m: _mix(m, None, ("ShaderNodeBsdfDiffuse", {"Color": (0.3, 0.1, 0.1)}),
                          ("ShaderNodeBsdfAnisotropic", {"Roughness": 0.3,
                                                         "Color": (0.5, 0.5, 0.5)})),
    "alpha": lambda m: _principled(m, **{"Base Color": (0.2, 0.3, 0.8), "Alpha": 0.5}),
    "translucent": lambda m: _replace(m, "ShaderNodeBsdfTranslucent", Color=(0.8, 0.7, 0.5)),
    "node_graph": _node_graph,
    "normal_map": _normal_mapped,
    "object_normal_map": _object_normal_mapped,
    "bump": _bumped,
    "bump_diffuse": lambda m: _bumped(m, diffuse=True),
}
DEFAULT_DIRECT = {"plastic", "mix", "node_graph", "normal_map", "bump"}  # the rest: -m slow
# known departures, kept as tests that must fail until fixed (docs/SHADING.md)
_TILTED = ("a driven normal tilted ~27 deg on a turned sphere, full transport: fireflies on the "
           "floor in front of it (its glossy light), 2 of 36 blocks up to 9.5 % above Cycles "
           "(the direct light passes since the diffuse closure takes the driven normal as it "
           "is, as Cycles')")
KNOWN_DIRECT: dict = {}
# (rough glass in full transport, 14 s of a cold default run, is under -m slow: the default run
# keeps tests/test_rough_glass.py's views through rough glass and its exact caustic)
DEFAULT_FULL = {"sheen"}
KNOWN_FULL = {"object_normal_map": _TILTED}


def _scene(material: str, floor: bool, world: float, light: bool):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=0.5)
    sphere = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    mat = bpy.data.materials.new(material)
    MATERIALS[material](mat)
    sphere.rotation_euler = getattr(MATERIALS[material], "rotation", (0.0, 0.0, 0.0))
    sphere.data.materials.append(mat)
    if floor:
        bpy.ops.mesh.primitive_plane_add(size=8, location=(0, 0, -0.5))
        g = bpy.data.materials.new("Floor")
        _principled(g, **{"Base Color": (0.5, 0.5, 0.5), "Roughness": 1.0,
                          "Specular IOR Level": 0.0})
        bpy.context.active_object.data.materials.append(g)
    light_world_camera(scene, light=((40.0, 1.0), (1.2, -1.0, 2.0), (0.5, 0.45, 0.0))
                       if light else None, world=world,
                       camera=((0.0, -3.2, 0.9), (1.32, 0.0, 0.0), 60))
    return scene


def _cases(default, known=None):
    known = known or {}
    return [pytest.param(m, marks=(() if m in default else (pytest.mark.slow,))
                         + ((pytest.mark.xfail(strict=True, reason=known[m]),)
                            if m in known else ()))
            for m in MATERIALS]


@pytest.mark.parametrize("material", _cases(DEFAULT_DIRECT, KNOWN_DIRECT))
def test_direct_light_per_block_as_cycles(material, cycles, render_exr, tmp_path, tiny):
    """Direct light only (no bounce): the closures' evaluation with next-event estimation and
    the BSDF sample, per 8 x 8 block within 3 %."""
    scene = _scene(material, floor=True, world=0.1, light=True)
    ours, ref = render_both(scene, cycles, render_exr, tmp_path, tiny, samples=1024, passes=512,
                            bounces=0, photons=1024)
    compare_blocks(ours, ref, 0.03, 0.002)


@pytest.mark.parametrize("material", _cases(DEFAULT_FULL, KNOWN_FULL))
def test_full_transport_per_block_as_cycles(material, cycles, render_exr, tmp_path, tiny):
    """All bounces (photons for the light between the sphere and the floor, caustics under
    glass), per 8 x 8 block within 3 %."""
    scene = _scene(material, floor=True, world=0.1, light=True)
    long = material not in DEFAULT_FULL       # -m slow: twice the samples, less noise
    ours, ref = render_both(scene, cycles, render_exr, tmp_path, tiny,
                            samples=4096 if long else 2048, passes=768 if long else 384,
                            bounces=8, photons=16384)
    compare_blocks(ours, ref, 0.03, 0.004)


FURNACE = {
    "rough_metal": "rough_metal", "rough_glass": "rough_glass", "coat": "coat",
    "sheen": "sheen", "plastic": "plastic", "oren_nayar": "oren_nayar",
    "conductor": "conductor", "glossy_metal": "glossy_metal",
}


@pytest.mark.parametrize("material", [pytest.param(m, marks=() if m == "coat"
                                                   else pytest.mark.slow) for m in FURNACE])
def test_white_furnace_as_cycles(material, cycles, render_exr, tmp_path, tiny):
    """The sphere alone in a white world (strength 1): what it reflects and transmits, as
    Cycles renders it, within 1 % over the sphere."""
    scene = _scene(material, floor=False, world=1.0, light=False)
    scene.camera.location = (0.0, -3.2, 0.0)
    scene.camera.rotation_euler = (1.5707963, 0.0, 0.0)
    scene.camera.data.lens = 150                      # the sphere fills the image
    ours, ref = render_both(scene, cycles, render_exr, tmp_path, tiny, samples=512, passes=128,
                            bounces=8, photons=4096)
    assert ref.mean() == pytest.approx(ours.mean(), rel=0.01)
    compare_blocks(ours, ref, 0.03, 0.003)


def _caustic_scene(floor_material):
    """A glass ball above a floor of the given material, lit by a small area light above: the
    ball focuses a caustic onto the floor."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=0.4,
                                         location=(0, 0, 0.6))
    bpy.ops.object.shade_smooth()
    glass = bpy.data.materials.new("Glass")
    _principled(glass, **{"Transmission Weight": 1.0, "Roughness": 0.0})
    bpy.context.active_object.data.materials.append(glass)
    bpy.ops.mesh.primitive_plane_add(size=6, location=(0, 0, 0))
    floor = bpy.data.materials.new("Floor")
    MATERIALS[floor_material](floor)
    bpy.context.active_object.data.materials.append(floor)
    light_world_camera(scene, light=((60.0, 0.25), (0.0, 0.0, 2.4), (0.0, 0.0, 0.0)),
                       world=0.0, camera=((0.0, -2.6, 1.7), (0.95, 0.0, 0.0), 50))
    return scene


@pytest.mark.parametrize("floor", ["rough_metal", pytest.param("plastic", marks=pytest.mark.slow)])
def test_caustic_on_a_glossy_floor_where_cycles_shows_it(floor, cycles, render_exr, tmp_path,
                                                         tiny):
    """A glass ball's caustic on a rough metal floor (0.45: a lobe the eye path follows, so the
    caustic is path-traced through the glass to the lamp, no photon is gathered) and on a plastic
    floor (a glossy layer over diffuse): where Cycles shows it and as bright (within 10 %; over ten
    seeds our two blocks move by 10-13 % at 256 passes, their mean 1.5 % above Cycles',
    docs/history/benchmarks-notebook.md, "The eye pass's numbers"), the floor around it as
    Cycles'."""
    scene = _caustic_scene(floor)
    ours, ref = render_both(scene, cycles, render_exr, tmp_path, tiny, samples=2048, passes=256,
                            bounces=8, photons=16384)
    a, b = blocks(ours).mean(-1), blocks(ref).mean(-1)
    # the caustic: the two blocks under the ball, inside its shadow (rows 16-24 of the image),
    # several times brighter than the shadow beside them
    caustic, shadow = b[2, 2:4], b[1, 2:4]
    assert caustic.min() > 3 * shadow.max(), b
    assert a[2, 2:4].sum() == pytest.approx(caustic.sum(), rel=0.10)
    np.testing.assert_allclose(a[1:], b[1:], rtol=0.1, atol=0.01)
