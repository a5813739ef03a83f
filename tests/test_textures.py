"""Image textures on Base Color and Emission Color: export (8-bit sRGB decoded, float kept,
packed and external images, a missing file warned and magenta), the kernels' lookup against a
NumPy bilinear reference, and a textured scene as bright as Cycles renders it.  The Image
Texture node's options: test_image_texture_node.py (the textured scene and the export are
tests/helpers/blender_scenes.py's)."""


import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from ppm_engine.blender.export.textures import srgb_to_linear
from ppm_engine.oracle.procedural import MeshBuilder, look_at
from ppm_engine.render.options import RenderOptions
from ppm_engine.render.renderer import Renderer
from ppm_engine.scene.arrays import (
    CAMERA_ORTHO,
    TEX_CLIP,
    TEX_FLAG_CLOSEST,
    TEX_FLAG_SRGB,
    TEX_REPEAT,
    TEXTURE_DTYPE,
)
from ppm_engine.scene.camera import make_camera
from tests.helpers.blender_scenes import PIXELS, export, scene_with_texture
from tests.helpers.renders import every_feature


def test_srgb_image_on_base_color_is_kept_encoded_and_flagged():
    scene_with_texture()
    a = export()
    (mat,) = a.nodes_of("Textured")
    assert mat["color_texture"] == 1 and tuple(mat["color"]) == (1, 1, 1)
    t = a.textures[0]
    assert (t["width"], t["height"], t["offset"]) == (4, 2, 0)
    assert t["flags"] == TEX_REPEAT | TEX_FLAG_SRGB          # decoded by the kernel
    got = a.texels.astype(np.float32).reshape(2, 4, 4)
    np.testing.assert_allclose(got, PIXELS, atol=2.5e-4)      # every byte value survives
    assert srgb_to_linear(np.float32(0.5)) == pytest.approx(0.21404, abs=1e-5)


def test_float_image_on_emission_is_linear_and_modes_are_kept():
    scene_with_texture("Emission Color", float_image=True, extension="CLIP",
                       interpolation="Closest")
    a = export()
    (mat,) = a.nodes_of("Textured")
    assert mat["emission_texture"] == 1 and mat["color_texture"] == 0
    np.testing.assert_allclose(mat["emission"], 3.0)                  # strength x white
    assert a.textures[0]["flags"] == TEX_CLIP | TEX_FLAG_CLOSEST
    np.testing.assert_allclose(a.texels.astype(np.float32).reshape(2, 4, 4), PIXELS, rtol=1e-3)


def test_packed_image_reads_like_a_generated_one():
    scene_with_texture(packed=True)
    a = export()
    np.testing.assert_allclose(a.texels.astype(np.float32).reshape(2, 4, 4), PIXELS, atol=2.5e-4)
    assert a.textures[0]["flags"] & TEX_FLAG_SRGB


def test_external_image_file_and_a_missing_one(tmp_path):
    _scene, img = scene_with_texture()
    png = tmp_path / "tex.png"
    img.filepath_raw = str(png)
    img.file_format = 'PNG'
    img.save()
    ext = bpy.data.images.load(str(png))
    bpy.data.materials["Textured"].node_tree.nodes["Image Texture"].image = ext
    a = export()
    np.testing.assert_allclose(a.texels.astype(np.float32).reshape(2, 4, 4), PIXELS, atol=2.5e-4)
    gone = bpy.data.images.load(str(png))
    gone.filepath = str(tmp_path / "no-such-file.png")
    gone.reload()
    bpy.data.materials["Textured"].node_tree.nodes["Image Texture"].image = gone
    a = export()
    assert any("Textured" in w and "no-such-file.png" in w and "magenta" in w
               for w in a.warnings), a.warnings
    (mat,) = a.nodes_of("Textured")
    assert mat["color_texture"] == 0 and tuple(mat["color"]) == (1, 0, 1)


def _bilinear(tex, uv):
    """NumPy reference of kernels/svm/textures.h texture_rgb (REPEAT, Linear)."""
    h, w = tex.shape[:2]
    x, y = uv[..., 0] * w - 0.5, uv[..., 1] * h - 0.5
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    ax, ay = (x - x0)[..., None], (y - y0)[..., None]

    def at(i, j):
        return tex[j % h, i % w]
    return ((1 - ay) * ((1 - ax) * at(x0, y0) + ax * at(x0 + 1, y0))
            + ay * ((1 - ax) * at(x0, y0 + 1) + ax * at(x0 + 1, y0 + 1)))


def test_kernel_lookup_equals_bilinear_reference():
    """An emissive textured quad seen by an orthographic camera with a box filter: each pixel
    is the mean of the texture over the pixel (UV tiling 1.5 x 1.5 to exercise REPEAT);
    checked against the NumPy bilinear lookup averaged over the same pixel."""
    W = 12
    rng = np.random.default_rng(0)
    tex = rng.uniform(0, 1, (3, 5, 4)).astype(np.float16)
    mb = MeshBuilder()
    m = mb.material("tex", (0, 0, 0), emission=(2, 2, 2))
    mb.quad((0, 0, 0), (1, 0, 0), (0, 1, 0), m)
    cam = make_camera(type=CAMERA_ORTHO, width=W, height=W,
                      to_world=look_at((0, 0, 3), (0, 0, 0), up=(0, 1, 0)), extent=(2, 2))
    scene = mb.build(camera=cam)
    # corners (-1,-1), (1,-1), (1,1) and (-1,-1), (1,1), (-1,1) -> uv = 0.75 (p + 1)
    uv = 0.75 * (scene.positions[..., :2] + 1)
    nodes = scene.shader_nodes.copy()
    nodes["emission_texture"] = 1
    tx = np.zeros(1, TEXTURE_DTYPE)
    tx["width"], tx["height"] = 5, 3
    scene = scene.replace(uvs=uv.astype(np.float32), shader_nodes=nodes, textures=tx,
                          texels=tex.reshape(-1, 4))
    spec = Renderer(scene, RenderOptions(photons_per_pass=64, max_bounces=0))
    assert "PPM_TEXTURES" in spec.features
    spec.close()
    # rendered by the kernels of every feature (every_feature): the scene's own would be a
    # kernel build of their own, for the same image
    r = Renderer(scene, every_feature(photons_per_pass=64, max_bounces=0))
    for _ in range(256):
        r.iterate()
    img = r.image()[..., :3]
    r.close()
    # reference: 16 x 16 sub-samples per pixel, pixel (i, j) covers x in [-1 + 2i/W, ...]
    s = (np.arange(16) + 0.5) / 16
    px = (np.arange(W)[:, None] + s[None, :]).ravel() / W * 2 - 1           # (W*16,)
    X, Y = np.meshgrid(px, px)
    ref = _bilinear(tex[..., :3].astype(np.float64), np.stack([0.75 * (X + 1), 0.75 * (Y + 1)], -1))
    ref = 2.0 * ref.reshape(W, 16, W, 16, 3).mean(axis=(1, 3))
    np.testing.assert_allclose(img, ref, rtol=0.02, atol=0.01)


def test_textured_scene_as_bright_as_cycles(cycles, render_exr, tmp_path):
    """A plane with an 8-bit sRGB texture on its base colour, lit by a sun, and a textured
    emissive panel: our image agrees with Cycles' per quarter of the image (UV orientation,
    sRGB decoding, the emission texture as a light)."""
    scene, _img = scene_with_texture()
    big = bpy.data.images.new("Checker", 64, 64)
    yy, xx = np.mgrid[0:64, 0:64]
    check = (((xx // 16) + (yy // 16)) % 2).astype(np.float32)
    rgba = np.stack([0.2 + 0.7 * check, 0.9 - 0.6 * check, 0.5 * np.ones_like(check),
                     np.ones_like(check)], -1)
    big.pixels.foreach_set(rgba.ravel())
    bpy.data.materials["Textured"].node_tree.nodes["Image Texture"].image = big
    p = bpy.data.materials["Textured"].node_tree.nodes["Principled BSDF"]
    p.inputs["Roughness"].default_value = 1.0
    p.inputs["Specular IOR Level"].default_value = 0.0
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
    sun.data.energy, sun.data.angle = 3.0, 0.0
    scene.collection.objects.link(sun)
    cam = scene.camera
    cam.data.type, cam.data.ortho_scale = 'ORTHO', 2.0
    world = bpy.data.worlds.new("W")
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0, 0, 0, 1)
    scene.world = world
    scene.render.dither_intensity = 0.0
    cycles(scene, 256, width=32)
    ref = render_exr(tmp_path / "cycles.exr")
    scene.render.engine = "PPM"
    scene.ppm.passes, scene.ppm.photons_per_pass = 128, 1024
    scene.ppm.specialize = False          # the kernels every test shares (conftest.configure_tiny)
    ours = render_exr(tmp_path / "ours.exr")
    # 4 x 4 pixel blocks: each lies inside one checker tile (8 x 8 pixels), so a texture
    # flipped or turned would swap the colours of whole blocks
    q = lambda a: a.reshape(8, 4, 8, 4, 3).mean(axis=(1, 3))
    assert np.ptp(q(ref)[..., 0]) > 0.2                            # the checker really shows
    np.testing.assert_allclose(q(ours), q(ref), rtol=0.03, atol=0.003)
