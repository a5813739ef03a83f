"""Heterogeneous media (issue 42): a Density driven by nodes is the medium's field, tracked with
null collisions against its majorant (kernels/geom/medium_field.h): the transmittance of a
density ramp against its closed form, fog of a textured density against Cycles per block, the
export of the field and its majorant."""
import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from tests.helpers.cycles_blocks import blocks, compare_blocks
from tests.helpers.volume_scenes import absorption_scene, both, cube, drive_density, fog_room


def test_density_ramp_transmittance_is_its_closed_form(bpy, cycles, render_exr, tmp_path, tiny):
    """Volume Absorption whose density is a linear Gradient Texture along the cube's Generated
    x (0 at its left face, 1 at its right) times a Math node's 3: the wall seen straight through
    1 m of it is exp(-(1 - colour) 3 x) per pixel column, x the column's Generated coordinate,
    and Cycles agrees (before: the unlinked density everywhere)."""
    color = np.array([0.8, 0.5, 0.2])
    scene = absorption_scene(tuple(color), 1.0)
    m = bpy.data.materials["Ink"]
    grad = drive_density(m, "Volume Absorption", "ShaderNodeTexGradient")
    mul = m.node_tree.nodes.new("ShaderNodeMath")
    mul.operation, mul.inputs[1].default_value = "MULTIPLY", 3.0
    m.node_tree.links.new(grad.outputs["Fac"], mul.inputs[0])
    m.node_tree.links.new(mul.outputs[0], m.node_tree.nodes["Volume Absorption"].inputs["Density"])
    ours, ref = both(scene, cycles, render_exr, tmp_path, tiny, samples=64, passes=32)
    # the ortho camera spans 2 m over 32 pixels: the cube's columns 8..23, Generated x at the
    # pixel centres (x + 0.5) / 16; the optical depth of each column (its rows inside the cube
    # averaged) within 5 % of 3 x (1 - colour), Cycles' too
    x = (np.arange(16) + 0.5) / 16.0
    exact = 3.0 * x[:, None] * (1.0 - color)[None, :]
    for img in (ours, ref):
        depth = -np.log(np.maximum(img[10:22, 8:24].mean(axis=0), 1e-6))
        assert np.allclose(depth, exact, rtol=0.05, atol=0.01), (depth[::5], exact[::5])
    compare_blocks(ours, ref, rtol=0.05, atol=2e-3)


def test_emission_driven_by_nodes_is_its_closed_form(bpy, cycles, render_exr, tmp_path, tiny):
    """A cube 1 m deep of an Emission volume (no absorption, no scattering) whose Strength is a
    Gradient Texture along its Generated x times 2, seen straight down against a black world:
    each pixel column's radiance the Strength's integral, 2 x (1 m) x the Color, x the
    column's Generated coordinate, within 3 %, and Cycles agrees per block (before: the
    unlinked Strength everywhere, 1, with a warning)."""
    from tests.helpers.volume_scenes import base_scene, volume_material
    color = np.array([1.0, 0.5, 0.25])
    scene = base_scene(camera=((0, 0, 5), (0, 0, 0), 50.0))
    scene.camera.data.type, scene.camera.data.ortho_scale = "ORTHO", 2.0
    m = volume_material("Glow", "ShaderNodeEmission", Color=(*color, 1), Strength=1.0)
    cube("Glow", m, size=1.0)
    nt = m.node_tree
    grad, mul = nt.nodes.new("ShaderNodeTexGradient"), nt.nodes.new("ShaderNodeMath")
    mul.operation, mul.inputs[1].default_value = "MULTIPLY", 2.0
    nt.links.new(grad.outputs["Fac"], mul.inputs[0])
    nt.links.new(mul.outputs[0], nt.nodes["Emission"].inputs["Strength"])
    ours, ref = both(scene, cycles, render_exr, tmp_path, tiny, samples=64, passes=32)
    x = (np.arange(16) + 0.5) / 16.0                # the cube's columns 8..23 (as above)
    exact = 2.0 * x[:, None] * color[None, :]
    for img in (ours, ref):
        got = img[10:22, 8:24, :3].mean(axis=0)
        assert np.allclose(got, exact, rtol=0.03, atol=0.01), (got[::5], exact[::5])
    compare_blocks(ours, ref, rtol=0.03, atol=2e-3)


@pytest.mark.slow
def test_noise_density_fog_under_a_spot_light_as_cycles(bpy, cycles, render_exr, tmp_path,
                                                        tiny):
    """The fog room's cube with its Density from a Noise Texture through a Color Ramp (wisps
    between 0 and 1.5): the cone of light in patchy fog and the floor lit through it, direct
    light and single scattering, against Cycles per 8 x 8 block: the lit blocks 0.92-1.00 of
    Cycles' (before: uniform fog of the unlinked density, 0.08-2.8 of Cycles').  (Cycles takes
    4 s of a 2-core machine over this fog: the slow tier; test_a_constant_field_renders_as_its_
    homogeneous_medium tracks a field in the default run.)"""
    scene = fog_room(density=1.0)
    m = bpy.data.materials["Fog"]
    nt = m.node_tree
    noise = drive_density(m, "Principled Volume", "ShaderNodeTexNoise", Scale=3.0,
                           Detail=1.0)
    ramp = nt.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].position, ramp.color_ramp.elements[1].position = 0.45, 0.6
    ramp.color_ramp.elements[1].color = (1.5, 1.5, 1.5, 1.0)
    nt.links.new(noise.outputs["Fac"], ramp.inputs["Fac"])
    nt.links.new(ramp.outputs["Color"], nt.nodes["Principled Volume"].inputs["Density"])
    ours, ref = both(scene, cycles, render_exr, tmp_path, tiny, samples=256, passes=128)
    import os
    if os.environ.get("PPM_DEBUG_PASSES"):
        tiny(scene, width=32, height=32, passes=int(os.environ["PPM_DEBUG_PASSES"]), photons=4096)
        ours = render_exr(tmp_path / "ours2.exr")
        r = blocks(ours).mean(-1) / np.maximum(blocks(ref).mean(-1), 1e-6)
        print("RATIO", np.round(r, 3), np.round(blocks(ref).mean(-1), 4))
    compare_blocks(ours, ref, rtol=0.06, atol=0.0015)
    b = blocks(ours).mean(-1)
    assert b[1, 1:3].min() > 0.01


def test_a_constant_field_renders_as_its_homogeneous_medium(bpy, tiny, render_exr, tmp_path):
    """The fog room's cube (glowing a little: Emission Strength 0.05) with a density field that
    is 0.8 everywhere (a Gradient Texture times 0 plus 0.8: a program, tracked with null
    collisions, its emission by collisions, the spot's light by equiangular distances alone)
    against the same fog of constant density 0.8 (closed forms, free-flight distances and
    equiangular sampling under MIS): the same image per 8 x 8 block (the cone's 0.997-1.008,
    the glowing edges' 0.985-1.032 at 256 passes), direct light and single scattering, two
    estimators sharing nothing of the medium's (before: the Density's unlinked 0.1)."""
    from ppm_engine.blender.export import export_scene
    from tests.helpers.cycles_blocks import blocks
    scene = fog_room(density=0.8)
    m = bpy.data.materials["Fog"]
    pv = m.node_tree.nodes["Principled Volume"]
    pv.inputs["Emission Strength"].default_value = 0.05
    c = scene.cycles
    c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = 0
    c.volume_bounces, c.transparent_max_bounces = 0, 8
    tiny(scene, width=32, height=32, passes=256, photons=4096)
    plain = render_exr(tmp_path / "plain.exr")
    grad = drive_density(m, "Principled Volume", "ShaderNodeTexGradient")
    mul, add = m.node_tree.nodes.new("ShaderNodeMath"), m.node_tree.nodes.new("ShaderNodeMath")
    mul.operation, mul.inputs[1].default_value = "MULTIPLY", 0.0
    add.operation, add.inputs[1].default_value = "ADD", 0.8
    m.node_tree.links.new(grad.outputs["Fac"], mul.inputs[0])
    m.node_tree.links.new(mul.outputs[0], add.inputs[0])
    m.node_tree.links.new(add.outputs[0], pv.inputs["Density"])
    pv.inputs["Density"].default_value = 0.1           # (unlinked: what rendered before)
    assert export_scene(bpy.context.evaluated_depsgraph_get()).materials[
        "density_program"].max() > 0
    field = render_exr(tmp_path / "field.exr")
    a, b = blocks(field).mean(-1), blocks(plain).mean(-1)
    lit = b > 0.004
    assert lit.sum() >= 6 and np.all(np.abs(a[lit] / b[lit] - 1) < 0.05), np.round(a / b, 3)


def test_export_of_a_density_field_and_its_majorant(bpy):
    """A Noise Texture on a Principled Volume's Density: no warning, a density program with the
    coefficients per unit density, the object's row bound to the material (a second cube with
    the same material gets its own copy bound to it), and the device's majorant at least the
    largest density (the Noise's Fac stays in [0, 1])."""
    from ppm_engine.blender.export import export_scene
    from ppm_engine.render.device import get_device
    from ppm_engine.render.device_scene import DeviceScene
    scene = fog_room(density=0.7)
    m = bpy.data.materials["Fog"]
    drive_density(m, "Principled Volume", "ShaderNodeTexNoise")
    cube("Fog 2", m, loc=(3, 0, 0), size=1.0)
    arrays = export_scene(bpy.context.evaluated_depsgraph_get())
    assert not [w for w in arrays.warnings if "Density" in w], arrays.warnings
    fields = np.nonzero(arrays.materials["density_program"] > 0)[0]
    assert len(fields) == 2                               # one per object
    rows = arrays.materials[fields]
    assert sorted(rows["volume_object"]) == [1, 2]
    assert np.allclose(rows["scattering"], 0.9)           # colour x density 1 (the field's)
    ds = DeviceScene(get_device(), arrays)
    maj = ds.kmaterials["majorant"][fields]
    assert (maj > 0.5).all() and (maj < 1.6).all(), maj
    del scene


def test_object_rows_are_the_kernels():
    """The objects' rows (arrays.OBJECT_ROWS: the Generated transform after the matrices) are
    the ones kernels/svm/svm_context.h steps by."""
    import re
    from pathlib import Path

    from ppm_engine.scene.arrays import OBJECT_ROWS
    src = (Path(__file__).parents[1] / "kernels/svm/svm_context.h").read_text()
    assert int(re.search(r"#define OBJECT_ROWS (\d+)", src).group(1)) == OBJECT_ROWS


# the bad values of the two tests below: a Gradient's Fac through Math nodes, four cubes in a row
def _through_math(nt, fac, op, value):
    """The output of Math nodes taking ``fac`` to ``fac op value``, or for POWER to value ^ (1 +
    fac) (1e30 ^ (1 + x): inf in float32)."""
    math = nt.nodes.new("ShaderNodeMath")
    math.operation = op
    if op == "POWER":
        math.inputs[0].default_value = value
        add = nt.nodes.new("ShaderNodeMath")
        add.operation, add.inputs[1].default_value = "ADD", 1.0
        nt.links.new(fac, add.inputs[0])
        nt.links.new(add.outputs[0], math.inputs[1])
    else:
        nt.links.new(fac, math.inputs[0])
        math.inputs[1].default_value = value
    return math.outputs[0]


def _cube_row_scene():
    """An orthographic camera 8 m above, looking down on 8 m: cube k at x = -3 + 2 k."""
    from tests.helpers.volume_scenes import base_scene
    scene = base_scene(camera=((0, 0, 8), (0, 0, 0), 50.0))
    scene.camera.data.type, scene.camera.data.ortho_scale = "ORTHO", 8.0
    return scene


def _cube_values(img, W):
    """The four cubes' pixels at the image's middle row (each its centre's mean of RGB)."""
    row = img[W // 2]
    return [row[int(W * (0.5 + (-3 + 2 * k) / 8))].mean() for k in range(4)]


def test_field_binds_are_the_kernels():
    """The density programs' binds past the density (shader_program.FIELD_*) as
    kernels/geom/medium_field.h numbers them."""
    import re
    from pathlib import Path

    from ppm_engine.scene.shader_program import FIELD_DENSITY, FIELD_GLOW, FIELD_TINT
    src = (Path(__file__).parents[1] / "kernels/geom/medium_field.h").read_text()
    for name, value in (("FIELD_GLOW", FIELD_GLOW), ("FIELD_TINT", FIELD_TINT)):
        assert int(re.search(rf"#define {name} (\d+)", src).group(1)) == value
    assert FIELD_DENSITY == 0 and "svm[p + 1].w" in src      # the density: the first bind


def test_bad_density_fields_render_without_nan(bpy, tiny, render_exr, tmp_path):
    """Density fields of 0, 1e6, negative and infinite values (a Gradient through Math nodes,
    as a node graph can make them; Cycles clamps a negative density to 0): the image finite and
    in time, the zero and negative cubes show the lit floor, the huge and infinite ones are dark
    (their majorants 1e6 x 1.25 and the largest coefficient)."""
    from tests.helpers.blender_scenes import add_light
    from tests.helpers.volume_scenes import W, diffuse, plane, volume_material
    scene = _cube_row_scene()
    plane("Floor", diffuse("Grey", (0.6, 0.6, 0.6)), (0, 0, -1.5), size=10.0)
    for k, (name, op, value) in enumerate((("Zero", "MULTIPLY", 0.0),
                                           ("Huge", "MULTIPLY", 1e6),
                                           ("Negative", "SUBTRACT", 3.0),
                                           ("Infinite", "POWER", 1e30))):
        m = volume_material(name, "ShaderNodeVolumeScatter")
        grad = drive_density(m, "Volume Scatter", "ShaderNodeTexGradient")
        nt = m.node_tree
        nt.links.new(_through_math(nt, grad.outputs["Fac"], op, value),
                     nt.nodes["Volume Scatter"].inputs["Density"])
        cube(name, m, loc=(-3 + 2 * k, 0, 0), size=1.5)
    add_light("SUN", "Sun", (0, 0, 0), energy=3.0)
    tiny(scene, width=W, height=W, passes=4, photons=1024)
    img = render_exr(tmp_path / "ours.exr")
    assert np.isfinite(img).all()
    zero, huge, negative, infinite = _cube_values(img, W)
    assert zero > 0.05 and negative > 0.9 * zero, (zero, negative)
    assert huge < 0.2 * zero and infinite < 0.2 * zero, (zero, huge, infinite)


def test_bad_emission_fields_render_without_nan(bpy, tiny, render_exr, tmp_path):
    """Emission volumes whose Strength is driven to negative, huge and infinite values (a
    Gradient through Math nodes): the image finite, a negative Strength emits nothing (Cycles
    emits where the Strength is above 0), a huge one is bright, an infinite one is clamped
    (1e30 per metre) rather than NaN."""
    from tests.helpers.volume_scenes import W, volume_material
    scene = _cube_row_scene()
    for k, (name, op, value) in enumerate((("Plain", "MULTIPLY", 1.0),
                                           ("Negative", "SUBTRACT", 3.0),
                                           ("Huge", "MULTIPLY", 1e6),
                                           ("Infinite", "POWER", 1e30))):
        m = volume_material(name, "ShaderNodeEmission")
        nt = m.node_tree
        grad = nt.nodes.new("ShaderNodeTexGradient")
        nt.links.new(_through_math(nt, grad.outputs["Fac"], op, value),
                     nt.nodes["Emission"].inputs["Strength"])
        cube(name, m, loc=(-3 + 2 * k, 0, 0), size=1.5)
    tiny(scene, width=W, height=W, passes=4, photons=1024)
    img = render_exr(tmp_path / "ours.exr")
    assert np.isfinite(img).all()
    plain, negative, huge, infinite = _cube_values(img, W)
    assert 0.1 < plain < 2.0 and negative == 0.0, (plain, negative)
    assert huge > 1e4 * plain and infinite > 1e20, (plain, huge, infinite)


@pytest.mark.slow
def test_volume_photons_in_a_density_field(bpy, tiny, render_exr, tmp_path):
    """fog_lens's fog box without its ball, albedo 0.6, its density from a Noise Texture (into
    both of its volume nodes), over a grey floor, seen from above: indirect light by photons
    (volume photons stored in the field, gathered with the transmittance by ratio tracking,
    volume_gather.cl beam_tr) as by eye paths, per 8 x 8 block: 0.94-1.04 at 64 and 32 passes,
    0.97-1.02 at 256 and 128 (before: the field's photons neither stored nor gathered: its
    light on the floor missing by photons, 0.69-1.01).  (7 s: the slow tier.)"""
    from ppm_engine.blender.scenes import fog_lens
    from ppm_engine.blender.scenes.cornell_box import lambert, quad
    scene = fog_lens.build(ball=False, resolution=32, fog=(0.6, 0.4))
    m = next(m for m in bpy.data.materials if m.node_tree is not None
             and "Volume Scatter" in m.node_tree.nodes)
    noise = drive_density(m, "Volume Scatter", "ShaderNodeTexNoise", Scale=2.0)
    m.node_tree.links.new(noise.outputs["Fac"],
                          m.node_tree.nodes["Volume Absorption"].inputs["Density"])
    quad(scene, "Floor", [(-3, -3, 0.05), (3, -3, 0.05), (3, 3, 0.05), (-3, 3, 0.05)],
         lambert("Grey", (0.6, 0.6, 0.6)))
    scene.camera.location, scene.camera.rotation_euler = (0.0, -4.5, 3.6), (0.9, 0.0, 0.0)
    images = {}
    for mode, passes in (("PATHS", 128), ("PHOTONS", 64)):
        tiny(scene, width=32, height=32, passes=passes, photons=1 << 14)
        scene.ppm.indirect = mode
        images[mode] = render_exr(tmp_path / f"{mode}.exr").mean(-1)
    a, b = (images[k].reshape(4, 8, 4, 8).mean((1, 3)) for k in ("PHOTONS", "PATHS"))
    assert np.all(np.abs(a / b - 1) < 0.05), np.round(a / b, 3)


def test_overlapping_media_add_up_as_cycles(bpy, cycles, render_exr, tmp_path, tiny):
    """Two Volume Absorption boxes that overlap, seen straight through onto an emissive wall:
    where both are, their absorption adds up, as Cycles' volume stack sums its volumes
    (geom/medium.h media_mix): the wall seen through both (1 m of each, 0.75 m of it in both)
    is exp(-(s1 + s2)), Cycles' too (before: the innermost medium's alone, exp(-(s1 + s2 / 4))
    there)."""
    from tests.helpers.volume_scenes import both, volume_material
    color1, color2 = np.array([0.8, 0.5, 0.2]), np.array([0.3, 0.6, 0.9])
    scene = absorption_scene(tuple(color1), 1.0)           # "Ink": x in [-0.5, 0.5]
    bpy.data.objects["Ink"].location.x = -0.25               # [-0.75, 0.25]
    cube("Ink 2", volume_material("Ink 2", "ShaderNodeVolumeAbsorption",
                                  Color=(*color2, 1), Density=1.0), loc=(0.25, 0, 0.25),
         size=1.0)                                          # (its faces apart from Ink's)
    ours, ref = both(scene, cycles, render_exr, tmp_path, tiny, samples=16, passes=4)
    # 16 pixels per metre over x in [-1, 1]: the overlap x in [-0.25, 0.25] is columns 12..19
    s1, s2 = 1.0 - color1, 1.0 - color2
    for img in (ours, ref):
        assert np.allclose(img[12:20, 13:19].reshape(-1, 3).mean(0), np.exp(-(s1 + s2)),
                           rtol=3e-3)
        assert np.allclose(img[12:20, 6:10].reshape(-1, 3).mean(0), np.exp(-s1), rtol=3e-3)
        assert np.allclose(img[12:20, 22:26].reshape(-1, 3).mean(0), np.exp(-s2), rtol=3e-3)


@pytest.mark.slow
def test_viewport_edits_of_a_field_build_no_kernel(bpy, tiny):
    """The viewport's scene (a ball on a floor) in a fog box whose density is a Noise Texture:
    an edit of the Noise's Scale (a value of the density's program) and one of the fog's
    colour upload data and build no kernel (the density program's ops, stack and the bound's
    program are unchanged), and the image changes."""
    from ppm_engine.blender.export import export_scene
    from ppm_engine.blender.viewport import viewport_options
    from ppm_engine.render.viewport_session import ViewportSession
    from tests.helpers.viewport_scenes import sphere_scene, view
    from tests.helpers.volume_scenes import volume_material
    scene = sphere_scene(bpy, tiny)
    fog = volume_material("Smoke", Density=1.0, Color=(0.9, 0.9, 0.9, 1))
    noise = drive_density(fog, "Principled Volume", "ShaderNodeTexNoise", Scale=2.0)
    cube("Smoke", fog, loc=(0, 0, 1.0), size=2.5)

    def export():
        bpy.context.view_layer.update()
        cam = view(bpy, scene)
        return cam, export_scene(bpy.context.evaluated_depsgraph_get(), camera=cam)
    options, start = viewport_options(scene.ppm)
    s = ViewportSession(options, start)
    try:
        cam, arrays = export()
        assert arrays.materials["density_program"].max() > 0
        s.update_view(cam)
        s.update_scene(arrays)
        assert s.wait(timeout=300), s.status()
        dev = s._device
        for edit in (lambda: setattr(noise.inputs["Scale"], "default_value", 6.0),
                     lambda: setattr(fog.node_tree.nodes["Principled Volume"].inputs["Color"],
                                     "default_value", (0.9, 0.3, 0.1, 1.0))):
            before, builds = s.frame().image.copy(), dev.programs.builds
            edit()
            cam, arrays = export()
            s.update_view(cam)
            s.update_scene(arrays)
            assert s.wait(timeout=300), s.status()
            assert dev.programs.builds == builds, "an edit of the field built a kernel"
            after = s.frame().image
            assert np.abs(after[..., :3] - before[..., :3]).mean() > 0.01 * before[..., :3].mean()
    finally:
        assert s.close(timeout=30)
