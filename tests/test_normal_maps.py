"""Tangent-space normal maps on subdivided meshes against Cycles, per block: an icosphere
subdivided by its modifier (render levels, or Cycles' adaptive dicing) reading a grid of tilted
normals; and the scene reported from outside (tests/helpers/normal_maps.py), its direct light
in a grey world and under a point light, and the whole scene (Cycles' clamping, 32 bounces)."""
import math

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from tests.helpers.cycles_blocks import compare_blocks, render_both


def _subdivided_normal_mapped(adaptive: bool):
    """An icosphere with a Subdivision Surface modifier (render levels 2, or Cycles' adaptive
    subdivision), smooth metal (roughness 0.16) whose normal is a tangent-space Normal Map
    reading a grid of tilted normals through the UV map (Closest: the tiles' edges stay
    sharp), lit by a small point light and a checkered world (the tilts show everywhere)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=2, radius=1.0)
    ob = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    mod = ob.modifiers.new("Subdivision", "SUBSURF")
    mod.levels = mod.render_levels = 1 if adaptive else 2
    mod.use_adaptive_subdivision = adaptive
    m = bpy.data.materials.new("NormalMapped")
    ob.data.materials.append(m)
    t = m.node_tree
    p = t.nodes["Principled BSDF"]
    p.inputs["Metallic"].default_value, p.inputs["Roughness"].default_value = 1.0, 0.16
    n = 64
    y, x = np.mgrid[0:n, 0:n]
    cell = ((x // 8) + (y // 8)) % 4
    tilt = np.stack([np.select([cell == 0, cell == 2], [0.4, -0.4], 0.0),
                     np.select([cell == 1, cell == 3], [0.4, -0.4], 0.0)], -1)
    rgb = np.concatenate([tilt, np.sqrt(1.0 - (tilt ** 2).sum(-1))[..., None]], -1) * 0.5 + 0.5
    img = bpy.data.images.new("Grid", n, n, float_buffer=True)
    img.colorspace_settings.name = "Non-Color"
    img.pixels.foreach_set(np.concatenate([rgb, np.ones((n, n, 1))], -1).astype(np.float32)
                           .ravel())
    tex = t.nodes.new("ShaderNodeTexImage")
    tex.image, tex.interpolation = img, "Closest"
    nm = t.nodes.new("ShaderNodeNormalMap")
    t.links.new(tex.outputs["Color"], nm.inputs["Color"])
    t.links.new(nm.outputs["Normal"], p.inputs["Normal"])
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    cam.location, cam.rotation_euler = (0.0, -4.0, 0.0), (math.pi / 2, 0.0, 0.0)
    light = bpy.data.objects.new("Point", bpy.data.lights.new("Point", "POINT"))
    light.data.energy, light.data.shadow_soft_size = 300.0, 0.05
    light.location = (2.0, -3.0, 2.0)
    scene.collection.objects.link(light)
    world = bpy.data.worlds.new("Checker")
    scene.world = world
    wt = world.node_tree
    coord, chk = wt.nodes.new("ShaderNodeTexCoord"), wt.nodes.new("ShaderNodeTexChecker")
    chk.inputs["Scale"].default_value = 3.0
    wt.links.new(coord.outputs["Generated"], chk.inputs["Vector"])
    wt.links.new(chk.outputs["Color"], wt.nodes["Background"].inputs["Color"])
    return scene


@pytest.mark.parametrize("adaptive", [
    False,
    pytest.param(True, marks=(pytest.mark.slow, pytest.mark.xfail(
        strict=True, reason="Cycles dices an adaptively subdivided mesh itself (the limit "
                            "surface, finer than the modifier's levels); this engine renders "
                            "the modifier's levels: 10 % off in a block (docs/SHADING.md)")))])
def test_normal_map_on_a_subdivided_mesh_per_block_as_cycles(adaptive, cycles, render_exr,
                                                             tmp_path, tiny):
    """A tangent-space normal map on a mesh subdivided by its modifier, per 16 x 16 block
    within 4 % of Cycles: the tangents (MikkTSpace) of the subdivided mesh's UV map."""
    scene = _subdivided_normal_mapped(adaptive)
    w = 64
    cycles(scene, 256, width=w)
    ref = render_exr(tmp_path / "cycles.exr")
    tiny(scene, width=w, height=w, passes=256, photons=4096)
    ours = render_exr(tmp_path / "ours.exr")
    a, b = (im.reshape(4, 16, 4, 16, 3).mean(axis=(1, 3)).mean(-1) for im in (ours, ref))
    assert (np.abs(a - b) <= 0.04 * b + 0.002).all(), np.round(a / b, 3)


def _reported_normal_map(lights: str, diffuse: bool, folder):
    """The reported scene (tests/helpers/normal_maps.py: the subdivided icosphere, its
    tangent-space normal map of tilted tiles from a Non-Color PNG through Texture Coordinate
    > UV), its normal driving a Principled BSDF of metallic 0.95 and roughness 0.16 (or a
    Diffuse BSDF), seen from close by; lit by a grey world ("world"), a point light of radius
    0 and 1000 W ("point") or both ("both")."""
    from tests.helpers.normal_maps import normal_mapped_icosphere, point_light, reported_camera
    _, t, nm = normal_mapped_icosphere(folder / "tiles.png", n=256, tilt=0.5, tiles=16)
    scene = bpy.context.scene
    p = t.nodes["Principled BSDF"]
    p.inputs["Metallic"].default_value, p.inputs["Roughness"].default_value = 0.95, 0.16
    if diffuse:
        p = t.nodes.new("ShaderNodeBsdfDiffuse")
        t.links.new(p.outputs[0], t.nodes["Material Output"].inputs["Surface"])
    t.links.new(nm.outputs["Normal"], p.inputs["Normal"])
    reported_camera(scene)
    if lights in ("world", "both"):
        scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (
            0.05, 0.05, 0.05, 1.0)
    if lights in ("point", "both"):
        point_light(scene, (2.0, -3.0, 2.0))
    return scene


@pytest.mark.parametrize("lights, diffuse", [("world", False), ("point", True)])
def test_normal_mapped_icosphere_direct_light_per_block_as_cycles(lights, diffuse, cycles,
                                                                 render_exr, tmp_path, tiny):
    """Direct light on the reported normal-mapped icosphere, per 8 x 8 block within 3 % of
    Cycles.  The metal in the grey world: a glossy lobe's samples under the smooth surface
    (which a driven normal's lobe reaches) were weighed against a density without their own
    (7 of 36 blocks off, up to 16 % dark where the tiles tilt away).  The diffuse surface
    under the point light: its driven normal was raised for reflection as the glossy
    closures' is, where Cycles takes it as it is for diffuse ones (6 of 36 blocks off, up to
    1.24 times Cycles' near the lit silhouette)."""
    scene = _reported_normal_map(lights, diffuse, tmp_path)
    ours, ref = render_both(scene, cycles, render_exr, tmp_path, tiny, samples=128,
                            passes=64, bounces=0, photons=1024)
    compare_blocks(ours, ref, 0.03, 0.0005)             # (the world's light: 0.02-0.05)


@pytest.mark.slow
def test_reported_normal_mapped_icosphere_per_block_as_cycles(cycles, render_exr, tmp_path,
                                                              tiny):
    """The reported scene whole: the metal in the grey world under the point light, Cycles'
    clamping 100 (direct and indirect) and 32 bounces, per 8 x 8 block within 5 % of Cycles
    (the blocks of the point light's tiny highlights move by ~1.5 % between Cycles' seeds at
    1024 samples)."""
    scene = _reported_normal_map("both", False, tmp_path)
    cycles(scene, 1024, width=48)
    c = scene.cycles
    c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = 32
    c.sample_clamp_direct = c.sample_clamp_indirect = 100.0      # (this engine's too)
    ref = render_exr(tmp_path / "cycles.exr")
    tiny(scene, width=48, height=48, passes=512, photons=4096)
    compare_blocks(render_exr(tmp_path / "ours.exr"), ref, 0.05, 0.001)
