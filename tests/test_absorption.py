"""Tinted glass and coloured liquids: a material's Volume output absorbs inside the mesh
(Beer-Lambert along rays and photons), as Cycles renders it.  The analytic check against an
absorbing slab is in test_accuracy.py."""
import numpy as np
import pytest

W = 32


def _glass(bpy, name, volume=None, **inputs):
    """Clear glass whose Volume output is a ``volume`` node ('ShaderNodeVolumeAbsorption' or
    'ShaderNodeVolumePrincipled') with the given inputs."""
    from ppm_engine.blender.scenes.cornell_box import glass
    m = glass(name)
    if volume:
        nodes, links = m.node_tree.nodes, m.node_tree.links
        v = nodes.new(volume)
        for key, value in inputs.items():
            v.inputs[key].default_value = value
        links.new(v.outputs[0], nodes["Material Output"].inputs["Volume"])
    return m


def test_volume_output_is_exported_as_cycles_defines_it(bpy):
    from ppm_engine.blender.export import export_scene
    from ppm_engine.blender.scenes.cornell_box import box, camera_world_render, new_scene
    scene = new_scene(None)
    camera_world_render(scene)
    mats = [_glass(bpy, "Clear"),
            _glass(bpy, "Absorb", "ShaderNodeVolumeAbsorption",
                   Color=(0.2, 0.5, 1.0, 1.0), Density=3.0),
            _glass(bpy, "Principled", "ShaderNodeVolumePrincipled", Color=(0.0, 0.0, 0.0, 1.0),
                   **{"Absorption Color": (0.25, 0.64, 1.0, 1.0), "Density": 2.0}),
            _glass(bpy, "Smoke", "ShaderNodeVolumePrincipled", Density=1.0),
            _glass(bpy, "Scatter", "ShaderNodeVolumeScatter")]
    for k, m in enumerate(mats):
        box(scene, m.name, (k, 0, 0), (k + 0.5, 0.5, 0.5), m)
    arrays = export_scene(bpy.context.evaluated_depsgraph_get())
    sigma = {n: arrays.materials["absorption"][k] for k, n in enumerate(arrays.material_names)}
    np.testing.assert_allclose(sigma["Clear"], 0.0)
    np.testing.assert_allclose(sigma["Absorb"], (2.4, 1.5, 0.0), rtol=1e-6)
    # (1 - colour)(1 - sqrt(absorption colour)) x density
    np.testing.assert_allclose(sigma["Principled"], (1.0, 0.4, 0.0), rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(sigma["Smoke"], 0.5 * (1 - np.sqrt(0.0)), rtol=1e-6)
    np.testing.assert_allclose(sigma["Scatter"], 0.0)
    # their scattering is rendered too (tests/test_volumes.py): exported, not warned about
    scatter = {n: arrays.materials["scattering"][k] for k, n in enumerate(arrays.material_names)}
    np.testing.assert_allclose(scatter["Smoke"], 0.5, rtol=1e-6)
    np.testing.assert_allclose(scatter["Scatter"], 0.8, rtol=1e-6)
    np.testing.assert_allclose(scatter["Absorb"], 0.0)
    warned = " ".join(arrays.warnings)
    assert not [n for n in mats if f"'{n.name}'" in warned], warned


def _tinted_block(bpy, nested=False):
    """A 0.5 m glass cube with blue-green absorption on a white floor under an area light: the
    cube's shadow is a tinted caustic, its body tinted by its thickness.  ``nested``: the cube
    is clear glass holding a 0.4 m cube of the tinted medium (a liquid in a glass: two media
    deep)."""
    from ppm_engine.blender.scenes.cornell_box import (
        box,
        camera_world_render,
        lambert,
        new_scene,
        quad,
    )
    scene = new_scene(None)
    quad(scene, "Floor", [(-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0)],
         lambert("Floor", (0.8, 0.8, 0.8)))
    tinted = _glass(bpy, "Tinted", "ShaderNodeVolumeAbsorption", Color=(0.1, 0.6, 0.8, 1.0),
                    Density=4.0 if not nested else 5.0)
    if nested:
        box(scene, "Glass", (-0.25, -0.25, 0.0), (0.25, 0.25, 0.5), _glass(bpy, "Clear"))
        box(scene, "Liquid", (-0.2, -0.2, 0.05), (0.2, 0.2, 0.45), tinted)
    else:
        box(scene, "Block", (-0.25, -0.25, 0.0), (0.25, 0.25, 0.5), tinted)
    data = bpy.data.lights.new("Lamp", 'AREA')
    data.size, data.energy = 1.0, 200.0
    lamp = bpy.data.objects.new("Lamp", data)
    lamp.location = (0.3, -0.2, 2.0)
    scene.collection.objects.link(lamp)
    camera_world_render(scene, (0.0, -1.3, 1.0), (np.radians(58), 0.0, 0.0), W)
    return scene


@pytest.mark.parametrize("nested", [False, True], ids=["tinted glass", "liquid in a glass"])
def test_tinted_glass_as_cycles_renders_it(bpy, tiny, cycles, render_exr, tmp_path, nested):
    scene = _tinted_block(bpy, nested)
    cycles(scene, 1024, W)
    ref = render_exr(tmp_path / "cycles.exr")
    tiny(scene, width=W, height=W, passes=96, photons=1 << 15)
    ours = render_exr(tmp_path / "ours.exr")
    # the whole image, per channel (the block's red is absorbed: red and blue differ)
    np.testing.assert_allclose(ours.mean(axis=(0, 1)), ref.mean(axis=(0, 1)), rtol=0.03)
    # the pixels Cycles shows tinted (the block and its coloured shadow): the same colour
    tinted = ref[..., 2] > 1.25 * ref[..., 0]
    assert tinted.sum() > 40
    np.testing.assert_allclose(ours[tinted].mean(axis=0), ref[tinted].mean(axis=0), rtol=0.06)
    # 8 x 8 blocks over the lit image
    b = lambda im: im.reshape(W // 8, 8, W // 8, 8, 3).mean(axis=(1, 3))
    lit = b(ref).mean(axis=-1) > 0.05 * ref.mean()
    assert np.abs(b(ours) - b(ref))[lit].max() < 0.06 * b(ref)[lit].max(), \
        (b(ours)[..., 0], b(ref)[..., 0])
