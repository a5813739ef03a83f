"""Homogeneous media (issue 42, first phase): a material's Volume output as a medium inside its
mesh (kernels/geom/medium.h, PPM_VOLUME), against Cycles per block on small scenes, the
transmittance and emission against their closed forms, the export of each volume node, and bad
densities (the sampling functions: test_volume_sampling.py)."""
import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from tests.helpers.blender_scenes import add_light
from tests.helpers.cycles_blocks import blocks, compare_blocks
from tests.helpers.volume_scenes import (
    W,
    absorption_scene,
    base_scene,
    both,
    cube,
    diffuse,
    fog_room,
    plane,
    spot,
    volume_material,
)


def test_fog_cube_under_a_spot_light_shows_the_cone(bpy, cycles, render_exr, tmp_path, tiny):
    """The issue's first scene: a room's floor and wall, a fog cube (Principled Volume, a mesh
    with only a Volume output) under a spot light: the cone of light in the fog, the floor lit
    through it, direct light only (before: an opaque black box)."""
    scene = fog_room()
    ours, ref = both(scene, cycles, render_exr, tmp_path, tiny, samples=256, passes=128)
    compare_blocks(ours, ref, rtol=0.05, atol=0.001)
    b = blocks(ours).mean(-1)          # the cone: the middle columns lit, the sides dark
    assert b[1, 1:3].min() > 0.03 and b[1, [0, 3]].max() < 0.005


def test_absorption_cube_is_beer_lambert_and_cycles(bpy, cycles, render_exr, tmp_path, tiny):
    """Volume Absorption: the wall seen through 1 m of it is exp(-(1 - colour) density) per
    channel, as the closed form and Cycles say; around it the wall is unchanged."""
    color, density = np.array([0.8, 0.5, 0.2]), 2.0
    scene = absorption_scene(tuple(color), density)
    ours, ref = both(scene, cycles, render_exr, tmp_path, tiny, samples=16, passes=4)
    exact = np.exp(-(1.0 - color) * density)
    middle = ours[12:20, 12:20].reshape(-1, 3)
    assert np.allclose(middle, exact, rtol=2e-3), (middle.mean(0), exact)
    assert np.allclose(ours[:3, :3], 1.0, rtol=1e-3)
    assert np.allclose(ref[12:20, 12:20].reshape(-1, 3).mean(0), exact, rtol=2e-3)
    compare_blocks(ours, ref, rtol=0.01, atol=1e-3)


def test_principled_volume_anisotropy_scatters_forward(bpy, cycles, render_exr, tmp_path, tiny):
    """Principled Volume of anisotropy 0.7 between the camera and a point light behind it:
    forward scattering brightens the fog towards the light, as Cycles renders it."""
    scene = base_scene(camera=((0, -6, 0), (1.5708, 0, 0), 35.0))
    fog = volume_material("Haze", Density=0.4, Anisotropy=0.7, Color=(0.8, 0.7, 0.6, 1))
    cube("Haze", fog, size=3.0)
    add_light("POINT", "Back", (0.6, 3.0, 0.4), energy=300.0, shadow_soft_size=0.0)
    ours, ref = both(scene, cycles, render_exr, tmp_path, tiny, samples=256, passes=64)
    compare_blocks(ours, ref, rtol=0.05, atol=0.002)
    b = blocks(ours).mean(-1)
    assert b[1:3, 2].mean() > 1.5 * b[1:3, 0].mean()     # brighter towards the light


def test_glass_box_filled_with_scattering_liquid(bpy, cycles, render_exr, tmp_path, tiny):
    """A glass cube (its surface kept) whose Volume output is a scattering liquid, lit by a
    point light inside it, seen through the glass: the medium entered by refraction, as
    Cycles renders it."""
    scene = base_scene(camera=((0, -6, 1.0), (1.4, 0, 0), 35.0))
    liquid = volume_material("Liquid", "ShaderNodeVolumeScatter",
                             surface="ShaderNodeBsdfGlass", Density=0.6,
                             Color=(0.9, 0.6, 0.3, 1))
    liquid.node_tree.nodes["Glass BSDF"].inputs["Roughness"].default_value = 0.0
    liquid.node_tree.nodes["Glass BSDF"].inputs["IOR"].default_value = 1.33
    cube("Box", liquid, size=2.0)
    add_light("POINT", "Inside", (0, 0, 0), energy=60.0, shadow_soft_size=0.0)
    ours, ref = both(scene, cycles, render_exr, tmp_path, tiny, samples=256, passes=64,
                     bounces=4)
    compare_blocks(ours, ref, rtol=0.12, atol=0.004)
    assert blocks(ours)[1:3, 1:3].mean() > 0.02


def test_camera_inside_fog(bpy, cycles, render_exr, tmp_path, tiny):
    """The camera inside a large fog cube (found by a ray at the start of each path): the fog
    between the camera and a lamp-lit floor glows and dims the floor, as in Cycles."""
    scene = base_scene(camera=((0, -3, 1.0), (1.2, 0, 0), 35.0))
    plane("Floor", diffuse("Grey", (0.6, 0.6, 0.6)), (0, 0, -1), size=12.0)
    fog = volume_material("Room fog", "ShaderNodeVolumeScatter", Density=0.15)
    cube("Room fog", fog, loc=(0, 0, 2), size=10.0)
    add_light("POINT", "Lamp", (0, 1.0, 1.5), energy=400.0, shadow_soft_size=0.0)
    ours, ref = both(scene, cycles, render_exr, tmp_path, tiny, samples=256, passes=64)
    compare_blocks(ours, ref, rtol=0.05, atol=0.002)


# --- export, features, bad input ------------------------------------------------------------------
def _features(arrays):
    from ppm_engine.render.features import scene_features, used_materials
    from ppm_engine.scene.emitters import build_emitters
    from ppm_engine.scene.materials import kernel_materials, kernel_nodes
    kn = kernel_nodes(arrays.shader_nodes)
    km = kernel_materials(arrays.materials, kn)
    order = np.arange(arrays.material.shape[0])
    return km, scene_features(arrays, km, kn, build_emitters(arrays, km, order),
                              used_materials(arrays, km.shape[0]))


def test_export_reads_the_volume_output(bpy):
    """Each volume node into the material's medium record, as Cycles sums its closures (Mix
    Shader weights); a volume-only mesh a transparent boundary, without the 'renders black'
    warning; the scene's kernels get PPM_VOLUME."""
    from ppm_engine.blender.export import export_scene
    from ppm_engine.scene.arrays import NODE_TRANSPARENT
    from ppm_engine.scene.materials import MAT_BOUNDARY, MAT_VOLUME
    base_scene()
    m = volume_material("PV", Density=2.0, Color=(0.5, 0.25, 1.0, 1), Anisotropy=0.3,
                        **{"Absorption Color": (0.25, 0.25, 0.25, 1), "Emission Strength": 3.0,
                           "Emission Color": (1.0, 0.5, 0.0, 1)})
    cube("PV", m)
    sc = volume_material("Mixed", "ShaderNodeVolumeScatter", Density=0.5,
                         Color=(1.0, 0.5, 0.5, 1))
    nt = sc.node_tree
    ab = nt.nodes.new("ShaderNodeVolumeAbsorption")
    ab.inputs["Density"].default_value = 1.0
    ab.inputs["Color"].default_value = (0.5, 0.5, 0.5, 1)
    mix = nt.nodes.new("ShaderNodeMixShader")
    mix.inputs["Fac"].default_value = 0.25
    nt.links.new(nt.nodes["Volume Scatter"].outputs[0], mix.inputs[1])
    nt.links.new(ab.outputs[0], mix.inputs[2])
    nt.links.new(mix.outputs[0], nt.nodes["Material Output"].inputs["Volume"])
    cube("Mixed", sc, loc=(3, 0, 0))
    arrays = export_scene(bpy.context.evaluated_depsgraph_get())
    said = arrays.warnings
    assert not [w for w in said if "black" in w], said
    mats = arrays.materials
    pv = int(np.argmax(mats["volume_emission"].max(axis=1)))
    assert np.allclose(mats["scattering"][pv], [1.0, 0.5, 2.0])
    assert np.allclose(mats["absorption"][pv], [0.5, 0.75, 0.0])
    assert np.allclose(mats["volume_emission"][pv], [3.0, 1.5, 0.0])
    assert mats["anisotropy"][pv] == pytest.approx(0.3)
    mx = next(i for i in range(mats.shape[0]) if i != pv and mats["scattering"][i].max() > 0)
    assert np.allclose(mats["scattering"][mx], 0.75 * 0.5 * np.array([1.0, 0.5, 0.5]))
    assert np.allclose(mats["absorption"][mx], [0.125] * 3)
    nodes = arrays.shader_nodes
    assert (nodes["type"][np.isin(nodes["material"], [pv, mx])] == NODE_TRANSPARENT).all()
    km, f = _features(arrays)
    assert (km["flags"][[pv, mx]] & MAT_VOLUME).all()
    assert (km["flags"][[pv, mx]] & MAT_BOUNDARY).all()       # (no transparent bounce)
    assert {"PPM_VOLUME", "PPM_ABSORPTION", "PPM_TRANSPARENT"} <= f


def test_a_scene_without_volumes_builds_no_volume_code(bpy):
    from ppm_engine.blender.export import export_scene
    base_scene()
    cube("Solid", diffuse("Grey", (0.5, 0.5, 0.5)))
    spot()
    _, f = _features(export_scene(bpy.context.evaluated_depsgraph_get()))
    assert "PPM_VOLUME" not in f and "PPM_ABSORPTION" not in f


def test_textured_density_is_the_media_field(bpy):
    """A Noise Texture on the density: no warning, the medium's field (its coefficients per
    unit density; test_volume_fields.py renders it)."""
    from ppm_engine.blender.export import export_scene
    base_scene()
    m = volume_material("Smoke", Density=0.7)
    noise = m.node_tree.nodes.new("ShaderNodeTexNoise")
    m.node_tree.links.new(noise.outputs["Fac"],
                          m.node_tree.nodes["Principled Volume"].inputs["Density"])
    cube("Smoke", m)
    arrays = export_scene(bpy.context.evaluated_depsgraph_get())
    said = arrays.warnings
    assert not any("Smoke" in w and "Density" in w for w in said), said
    assert arrays.materials["scattering"].max() == pytest.approx(0.5)
    assert arrays.materials["density_program"].max() > 0


def test_bad_densities_render_without_nan(bpy, tiny, render_exr, tmp_path):
    """Densities 0, 1e6, negative and NaN: the last two clamped to 0 with a warning naming the
    material; the image finite, the dense cube dark, the clear one showing the lit floor."""
    from ppm_engine.blender.export import export_scene
    scene = base_scene(camera=((0, 0, 8), (0, 0, 0), 50.0))
    scene.camera.data.type, scene.camera.data.ortho_scale = "ORTHO", 8.0
    plane("Floor", diffuse("Grey", (0.6, 0.6, 0.6)), (0, 0, -1.5), size=10.0)
    for k, (name, dens) in enumerate((("Zero", 0.0), ("Huge", 1e6), ("Negative", -3.0),
                                      ("NotANumber", float("nan")))):
        cube(name, volume_material(name, "ShaderNodeVolumeScatter", Density=dens),
             loc=(-3 + 2 * k, 0, 0), size=1.5)
    add_light("SUN", "Sun", (0, 0, 0), energy=3.0)
    said = export_scene(bpy.context.evaluated_depsgraph_get()).warnings
    assert any("Negative" in w and "Density" in w for w in said), said
    assert any("NotANumber" in w and "Density" in w for w in said), said
    tiny(scene, width=W, height=W, passes=4, photons=1024)
    img = render_exr(tmp_path / "ours.exr")
    assert np.isfinite(img).all()
    row = img[W // 2]
    clear, huge = row[int(W * (0.5 - 3 / 8))], row[int(W * (0.5 - 1 / 8))]
    assert clear.mean() > 0.05 and huge.mean() < 0.2 * clear.mean(), (clear, huge)


def test_volume_emission_added_to_absorption(bpy, cycles, render_exr, tmp_path, tiny):
    """Emission and Volume Absorption through an Add Shader, a cube 1 m deep seen end-on over a
    black world: L = E (1 - exp(-sigma_a)) / sigma_a per channel, as the closed form and Cycles
    say."""
    scene = base_scene(camera=((0, 0, 5), (0, 0, 0), 50.0))
    scene.camera.data.type, scene.camera.data.ortho_scale = "ORTHO", 2.0
    m = volume_material("Glow", "ShaderNodeVolumeAbsorption", Color=(0.2, 0.5, 0.9, 1),
                        Density=1.5)
    nt = m.node_tree
    em = nt.nodes.new("ShaderNodeEmission")
    em.inputs["Color"].default_value = (1.0, 0.6, 0.3, 1)
    em.inputs["Strength"].default_value = 2.0
    add = nt.nodes.new("ShaderNodeAddShader")
    nt.links.new(nt.nodes["Volume Absorption"].outputs[0], add.inputs[0])
    nt.links.new(em.outputs[0], add.inputs[1])
    nt.links.new(add.outputs[0], nt.nodes["Material Output"].inputs["Volume"])
    cube("Glow", m, size=1.0)
    ours, ref = both(scene, cycles, render_exr, tmp_path, tiny, samples=16, passes=2)
    sigma = (1.0 - np.array([0.2, 0.5, 0.9])) * 1.5
    exact = 2.0 * np.array([1.0, 0.6, 0.3]) * (1.0 - np.exp(-sigma)) / sigma
    assert np.allclose(ours[12:20, 12:20].reshape(-1, 3), exact, rtol=1e-3)
    assert np.allclose(ref[12:20, 12:20].reshape(-1, 3).mean(0), exact, rtol=5e-3)
    assert np.abs(ours[:3, :3]).max() == 0.0


def test_principled_volume_blackbody_emission(bpy, cycles, render_exr, tmp_path, tiny):
    """A Principled Volume of density 0 with Blackbody Intensity 0.8 at 2,500 K and a tint, a
    cube 1 m deep seen end-on over a black world: L = tint x sigma mix(1, T^4, 0.8) / pi x the
    black body's colour, per metre, as the closed form and Cycles say (before: not rendered,
    with a warning)."""
    from ppm_engine.scene.spectra import blackbody_rgb
    scene = base_scene(camera=((0, 0, 5), (0, 0, 0), 50.0))
    scene.camera.data.type, scene.camera.data.ortho_scale = "ORTHO", 2.0
    m = volume_material("Fire", Density=0.0, Temperature=2500.0,
                        **{"Blackbody Intensity": 0.8, "Blackbody Tint": (1.0, 0.8, 0.6, 1)})
    cube("Fire", m, size=1.0)
    ours, ref = both(scene, cycles, render_exr, tmp_path, tiny, samples=16, passes=2)
    power = 5.670373e-8 * 1e-6 / np.pi * (1.0 + 0.8 * (2500.0 ** 4 - 1.0))
    exact = np.array([1.0, 0.8, 0.6]) * power * np.array(blackbody_rgb(2500.0))
    assert exact.min() > 0.01
    assert np.allclose(ours[12:20, 12:20].reshape(-1, 3), exact, rtol=1e-3)
    assert np.allclose(ref[12:20, 12:20].reshape(-1, 3).mean(0), exact, rtol=5e-3)


@pytest.mark.parametrize("volume_bounces", [0, pytest.param(2, marks=pytest.mark.slow)])
def test_volume_bounces_and_light_through_fog_onto_the_room(bpy, cycles, render_exr, tmp_path,
                                                            tiny, volume_bounces):
    """The fog room with denser fog and every kind of bounce: the floor lit by what the fog
    scatters onto it (the eye paths' indirect light scatters in media), and with Volume bounces
    2 the fog lit by the floor and by itself, as Cycles renders it (Volume bounces 0: Cycles'
    single scattering).  (Volume bounces 2 in the slow tier: the default run's time; fog_lens's
    caustic, test_volume_photons.py, takes a volume bounce there.)"""
    scene = fog_room(density=0.8)
    cycles(scene, 512, width=W)
    c = scene.cycles
    c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = 4
    c.volume_bounces = volume_bounces
    ref = render_exr(tmp_path / "cycles.exr")
    tiny(scene, width=W, height=W, passes=256, photons=4096)
    ours = render_exr(tmp_path / "ours.exr")
    compare_blocks(ours, ref, rtol=0.06, atol=0.0012)


def test_volume_boundaries_are_no_transparent_bounces(bpy, cycles, render_exr, tmp_path, tiny):
    """Three Volume Absorption slabs before an emissive wall with Transparent Bounces 1: a
    medium's boundary is no transparent bounce (Cycles' volume bounds), so the wall is seen
    through all three, exp(-3 sigma_a d), as in Cycles."""
    scene = absorption_scene((0.5, 0.5, 0.5), 1.0)
    for k in range(2):
        ink = bpy.data.objects["Ink"].copy()
        ink.location = (0, 0, 1.5 + 1.5 * k)
        scene.collection.objects.link(ink)
    scene.camera.location = (0, 0, 8)
    cycles(scene, 16, width=W)
    c = scene.cycles
    c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = 0
    c.volume_bounces, c.transparent_max_bounces = 0, 1
    ref = render_exr(tmp_path / "cycles1.exr")
    tiny(scene, width=W, height=W, passes=2, photons=1024)
    ours = render_exr(tmp_path / "ours1.exr")
    exact = np.exp(-0.5 * 3)
    assert np.allclose(ours[12:20, 12:20], exact, rtol=2e-3), ours[16, 16]
    assert np.allclose(ref[12:20, 12:20].mean(), exact, rtol=5e-3), ref[16, 16]
