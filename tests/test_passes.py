"""Render passes in the multilayer EXR: the denoising pair (for Blender's Denoise node) and our
diagnostics, with the values they should have."""
import numpy as np
import pytest

OpenEXR = pytest.importorskip("OpenEXR")


def test_denoising_and_debug_passes(bpy, example_blend, tiny, tmp_path):
    bpy.ops.wm.open_mainfile(filepath=str(example_blend("cornell_box")), load_ui=False)
    scene = bpy.context.scene
    tiny(scene, width=24, height=24, passes=3)
    scene.ppm.indirect = 'PHOTONS'          # the photon map's debug passes have photons to show
    scene.render.image_settings.media_type = 'MULTI_LAYER_IMAGE'
    scene.render.filepath = str(tmp_path / "passes.exr")
    assert bpy.ops.render.render(write_still=True) == {'FINISHED'}
    with OpenEXR.File(scene.render.filepath) as f:
        ch = {k: np.asarray(v.pixels) for p in f.parts for k, v in p.channels.items()}
    albedo = ch["ViewLayer.Denoising Albedo"]                     # (h, w, 3), top-down
    normal = np.stack([ch[f"ViewLayer.Denoising Normal.{c}"] for c in "XYZ"], -1)
    radius, photons = ch["ViewLayer.PPM Radius.X"], ch["ViewLayer.PPM Photons.X"]
    assert ch["ViewLayer.Combined"].shape == (24, 24, 4)
    # the left wall is red, the right green, the back wall white: the base colours of the file's
    # own materials, exactly
    def base(name):
        return tuple(bpy.data.materials[name].node_tree.nodes["Principled BSDF"]
                     .inputs["Base Color"].default_value)[:3]
    mid = slice(9, 15)
    np.testing.assert_allclose(np.median(albedo[mid, 1], axis=0), base("Red"), atol=1e-3)
    np.testing.assert_allclose(np.median(albedo[mid, -2], axis=0), base("Green"), atol=1e-3)
    np.testing.assert_allclose(np.median(albedo[mid, 11:13].reshape(-1, 3), axis=0),
                               base("White"), atol=1e-3)
    # unit normals facing the camera; the floor's points up
    lit = np.linalg.norm(normal, axis=-1) > 0
    np.testing.assert_allclose(np.linalg.norm(normal[lit], axis=-1), 1.0, atol=1e-4)
    np.testing.assert_allclose(np.median(normal[-1, 8:16], axis=0), (0, 0, 1), atol=1e-3)
    assert (radius[lit] > 0).all() and (photons[lit] >= 0).all() and photons.max() > 0
