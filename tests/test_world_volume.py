"""The world's Volume output (issue 42): a homogeneous medium filling the space outside every
object, as Cycles renders it (the bottom of every volume stack; a mesh's medium inside it added
to it; a ray that leaves the scene through it goes on forever, so neither the background nor a
sun reaches the scene through it where it has extinction), against Cycles per 8 x 8 block."""
import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from tests.helpers.blender_scenes import add_light, add_plane, export, light_world_camera
from tests.helpers.cycles_blocks import blocks, compare_blocks

W = 32


def world_volume(scene, kind="ShaderNodeVolumePrincipled", **inputs):
    """A ``kind`` node with ``inputs`` on the scene's world's Volume output."""
    nt = scene.world.node_tree
    v = nt.nodes.new(kind)
    for k, val in inputs.items():
        v.inputs[k].default_value = val
    nt.links.new(v.outputs[0], nt.nodes["World Output"].inputs["Volume"])


def material(name, kind, output="Surface", **inputs):
    """A material whose ``output`` is one ``kind`` node with ``inputs``."""
    m = bpy.data.materials.new(name)
    nt = m.node_tree
    nt.nodes.remove(nt.nodes["Principled BSDF"])
    n = nt.nodes.new(kind)
    for k, val in inputs.items():
        n.inputs[k].default_value = val
    nt.links.new(n.outputs[0], nt.nodes["Material Output"].inputs[output])
    return m


def fog_field(world_density=0.08):
    """An open scene in world fog (Principled Volume): a grey floor, a grey box on it, a
    cube of denser fog (Volume Scatter) inside the world's, a point light above them."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    light_world_camera(scene, light=None, world=0.0, camera=((0, -6, 1.2), (1.4, 0, 0), 35.0))
    world_volume(scene, Density=world_density, Color=(0.9, 0.9, 0.9, 1))
    grey = material("Grey", "ShaderNodeBsdfDiffuse", Color=(0.6, 0.6, 0.6, 1))
    add_plane("Floor", grey, (0, 0, -1), size=16.0)
    bpy.ops.mesh.primitive_cube_add(size=0.8, location=(-1.0, 0.3, -0.6))
    bpy.context.active_object.data.materials.append(grey)
    bpy.ops.mesh.primitive_cube_add(size=1.4, location=(0.9, 0.0, 0.0))
    bpy.context.active_object.data.materials.append(
        material("Mist", "ShaderNodeVolumeScatter", "Volume", Density=0.5))
    add_light("POINT", "Lamp", (0, -0.5, 2.0), energy=400.0, shadow_soft_size=0.0)
    return scene


def render(scene, cycles, render_exr, tmp_path, tiny, samples, passes):
    """(ours, Cycles') W x W RGB, direct light and single scattering (no bounce)."""
    cycles(scene, samples, width=W)
    c = scene.cycles
    c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = 0
    c.volume_bounces = 0
    ref = render_exr(tmp_path / "cycles.exr")
    tiny(scene, width=W, height=W, passes=passes, photons=4096)
    return render_exr(tmp_path / "ours.exr"), ref


def test_world_fog_with_a_nested_fog_cube_under_a_point_light(bpy, cycles, render_exr, tmp_path,
                                                               tiny):
    """World fog around a floor, a box and a cube of denser fog under a point light: the fog
    glows around the lamp and dims the floor, the cube's fog is the world's plus its own, as
    Cycles renders it (before: no world fog, the sky black and the floor too bright)."""
    scene = fog_field()
    ours, ref = render(scene, cycles, render_exr, tmp_path, tiny, samples=256, passes=64)
    compare_blocks(ours, ref, rtol=0.05, atol=0.002)
    assert blocks(ours)[0].mean() > 0.01            # (the fog above the horizon glows)


@pytest.mark.slow
@pytest.mark.parametrize("indirect", ["PATHS", "PHOTONS"])
def test_world_fog_with_bounces(bpy, cycles, render_exr, tmp_path, tiny, indirect):
    """The same scene with 4 bounces of every kind and Volume bounces 2: the fog lit by the
    floor and by itself, by eye paths or by volume photons (gathered in the scene's box grown
    by the fog's mean free path: the sky's blocks were 0.83-0.93 of Cycles' in the box alone)."""
    scene = fog_field()
    cycles(scene, 512, width=W)
    c = scene.cycles
    c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = 4
    c.volume_bounces = 2
    ref = render_exr(tmp_path / "cycles.exr")
    tiny(scene, width=W, height=W, passes=128, photons=4096)
    scene.ppm.indirect = indirect
    compare_blocks(render_exr(tmp_path / "ours.exr"), ref, rtol=0.03, atol=0.002)


def test_background_and_sun_through_world_absorption(bpy, cycles, render_exr, tmp_path, tiny):
    """Volume Absorption on the world absorbing blue only, a grey sky and a sun over a floor: a
    ray leaving the scene through it crosses an unbounded medium, so no blue comes from the sky
    or the sun, red and green undimmed (Cycles' transmittance to infinity, per channel)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    light_world_camera(scene, light=None, world=0.5, camera=((0, -6, 1.0), (1.45, 0, 0), 35.0))
    world_volume(scene, "ShaderNodeVolumeAbsorption", Density=0.3, Color=(1.0, 1.0, 0.5, 1))
    add_plane("Floor", material("Grey", "ShaderNodeBsdfDiffuse", Color=(0.6, 0.6, 0.6, 1)),
              (0, 0, -1), size=40.0)
    sun = add_light("SUN", "Sun", (0, 0, 5), energy=2.0)
    sun.rotation_euler = (0.5, 0.2, 0)
    ours, ref = render(scene, cycles, render_exr, tmp_path, tiny, samples=64, passes=16)
    compare_blocks(ours, ref, rtol=0.03, atol=0.002)
    assert np.abs(ours[..., 2]).max() == 0.0
    assert np.allclose(ours[:4, :, :2], 0.5, rtol=1e-3)          # the sky's red and green


def _kernel_view(arrays):
    """(kernel materials, feature flags) of exported arrays, as DeviceScene makes them."""
    from ppm_engine.render.features import scene_features, used_materials
    from ppm_engine.scene.emitters import build_emitters
    from ppm_engine.scene.materials import kernel_materials, kernel_nodes, world_medium
    kn = kernel_nodes(arrays.shader_nodes)
    km = kernel_materials(arrays.materials, kn, world_medium(arrays))
    order = np.arange(arrays.material.shape[0])
    return km, scene_features(arrays, km, kn, build_emitters(arrays, km, order),
                              used_materials(arrays, km.shape[0]))


def test_world_volume_export_and_features(bpy):
    """The world's Volume output: the materials' last row, flagged in world_shader, a medium of
    its own (the kernels sum it with every medium above it on the stack, as Cycles: geom/
    medium.h media_mix), every other material's medium record its own, and the scene's
    kernels get PPM_VOLUME; a density of 0: none."""
    from ppm_engine.scene.arrays import WORLD_MEDIUM
    from ppm_engine.scene.materials import MAT_VOLUME, world_medium
    scene = fog_field(world_density=0.2)
    arrays = export()
    assert arrays.world_shader[1] & WORLD_MEDIUM
    w = world_medium(arrays)
    assert w == arrays.materials.shape[0] - 1 and "World" in arrays.material_names[w]
    assert np.allclose(arrays.materials["scattering"][w], 0.9 * 0.2)
    assert np.allclose(arrays.materials["absorption"][w], 0.1 * 0.2)
    km, f = _kernel_view(arrays)
    assert km["flags"][w] & MAT_VOLUME and "PPM_VOLUME" in f
    mist = arrays.material_names.index("Mist")
    assert np.allclose(km["scattering"][mist], 0.8 * 0.5)       # (its own: the stack sums)
    assert np.allclose(km["scattering"][w], 0.9 * 0.2)
    scene.world.node_tree.nodes["Principled Volume"].inputs["Density"].default_value = 0.0
    bpy.data.objects.remove(bpy.data.objects["Cube.001"])                # (the Mist cube)
    km, f = _kernel_view(export())
    assert not (km["flags"] & MAT_VOLUME).any()
    assert "PPM_VOLUME" not in f and "PPM_ABSORPTION" not in f
