"""Image textures on Base Color and Emission Color: export (8-bit sRGB decoded, float kept,
packed and external images, a missing file warned and magenta), the kernels' lookup against a
NumPy bilinear reference, and a textured scene as bright as Cycles renders it."""
import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from ppm_engine.camera_model import make_camera
from ppm_engine.export import export_scene
from ppm_engine.export.textures import srgb_to_linear
from ppm_engine.options import RenderOptions
from ppm_engine.procedural import MeshBuilder, look_at
from ppm_engine.renderer import Renderer
from ppm_engine.scene_arrays import (
    CAMERA_ORTHO,
    TEX_CLIP,
    TEX_FLAG_CLOSEST,
    TEX_FLAG_SRGB,
    TEX_REPEAT,
    TEXTURE_DTYPE,
)

# a 4 x 2 image, rows bottom-up (Blender's order), values on the 8-bit grid
PIXELS = np.array([[[0.0, 0.2, 0.4, 1], [1.0, 0.0, 0.0, 1], [0.0, 1.0, 0.0, 1],
                    [0.0, 0.0, 1.0, 1]],
                   [[1.0, 1.0, 1.0, 1], [0.5, 0.5, 0.5, 1], [0.2, 0.6, 0.8, 1],
                    [0.8, 0.4, 0.1, 1]]], np.float32)
PIXELS = np.round(PIXELS * 255) / 255


def _scene_with_texture(socket="Base Color", float_image=False, packed=False, path=None,
                        extension="REPEAT", interpolation="Linear"):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
    cam.location = (0, 0, 3)
    scene.collection.objects.link(cam)
    scene.camera = cam
    img = bpy.data.images.new("Tex", 4, 2, float_buffer=float_image)
    img.pixels.foreach_set(PIXELS.ravel())
    if packed:
        img.pack()
    if path is not None:
        img.filepath = str(path)
        img.source = 'FILE'
    m = bpy.data.materials.new("Textured")
    t = m.node_tree
    p = t.nodes["Principled BSDF"]
    node = t.nodes.new("ShaderNodeTexImage")
    node.image, node.extension, node.interpolation = img, extension, interpolation
    t.links.new(node.outputs["Color"], p.inputs[socket])
    if socket == "Emission Color":
        p.inputs["Emission Strength"].default_value = 3.0
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    bpy.context.active_object.data.materials.append(m)
    return scene, img


def _export():
    return export_scene(bpy.context.evaluated_depsgraph_get())


def test_srgb_image_on_base_color_is_kept_encoded_and_flagged():
    _scene_with_texture()
    a = _export()
    (mat,) = a.nodes_of("Textured")
    assert mat["color_texture"] == 1 and tuple(mat["color"]) == (1, 1, 1)
    t = a.textures[0]
    assert (t["width"], t["height"], t["offset"]) == (4, 2, 0)
    assert t["flags"] == TEX_REPEAT | TEX_FLAG_SRGB          # decoded by the kernel
    got = a.texels.astype(np.float32).reshape(2, 4, 4)
    np.testing.assert_allclose(got, PIXELS, atol=2.5e-4)      # every byte value survives
    assert srgb_to_linear(np.float32(0.5)) == pytest.approx(0.21404, abs=1e-5)


def test_float_image_on_emission_is_linear_and_modes_are_kept():
    _scene_with_texture("Emission Color", float_image=True, extension="CLIP",
                        interpolation="Closest")
    a = _export()
    (mat,) = a.nodes_of("Textured")
    assert mat["emission_texture"] == 1 and mat["color_texture"] == 0
    np.testing.assert_allclose(mat["emission"], 3.0)                  # strength x white
    assert a.textures[0]["flags"] == TEX_CLIP | TEX_FLAG_CLOSEST
    np.testing.assert_allclose(a.texels.astype(np.float32).reshape(2, 4, 4), PIXELS, rtol=1e-3)


def test_packed_image_reads_like_a_generated_one():
    _scene_with_texture(packed=True)
    a = _export()
    np.testing.assert_allclose(a.texels.astype(np.float32).reshape(2, 4, 4), PIXELS, atol=2.5e-4)
    assert a.textures[0]["flags"] & TEX_FLAG_SRGB


def test_external_image_file_and_a_missing_one(tmp_path):
    _scene, img = _scene_with_texture()
    png = tmp_path / "tex.png"
    img.filepath_raw = str(png)
    img.file_format = 'PNG'
    img.save()
    ext = bpy.data.images.load(str(png))
    bpy.data.materials["Textured"].node_tree.nodes["Image Texture"].image = ext
    a = _export()
    np.testing.assert_allclose(a.texels.astype(np.float32).reshape(2, 4, 4), PIXELS, atol=2.5e-4)
    gone = bpy.data.images.load(str(png))
    gone.filepath = str(tmp_path / "no-such-file.png")
    gone.reload()
    bpy.data.materials["Textured"].node_tree.nodes["Image Texture"].image = gone
    a = _export()
    assert any("Textured" in w and "no-such-file.png" in w and "magenta" in w
               for w in a.warnings), a.warnings
    (mat,) = a.nodes_of("Textured")
    assert mat["color_texture"] == 0 and tuple(mat["color"]) == (1, 0, 1)


def _bilinear(tex, uv):
    """NumPy reference of kernels/textures.h texture_rgb (REPEAT, Linear)."""
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
    r = Renderer(scene, RenderOptions(photons_per_pass=64, max_bounces=0))
    assert "PPM_TEXTURES" in r.features
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
    scene, _img = _scene_with_texture()
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
    ours = render_exr(tmp_path / "ours.exr")
    # 4 x 4 pixel blocks: each lies inside one checker tile (8 x 8 pixels), so a texture
    # flipped or turned would swap the colours of whole blocks
    q = lambda a: a.reshape(8, 4, 8, 4, 3).mean(axis=(1, 3))
    assert np.ptp(q(ref)[..., 0]) > 0.2                            # the checker really shows
    np.testing.assert_allclose(q(ours), q(ref), rtol=0.03, atol=0.003)


# --- the Image Texture node in shader programs, per pixel against Cycles (the harness of
# test_shader_nodes.py: one plane per case, image A's colour one value per pixel) -----------

def _harness():
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from test_shader_nodes import _compare
    return _compare


def _small_image(name, w, h, seed, float_buffer=True, alpha=False):
    """A w x h image of random values (Non-Color floats, or 8-bit sRGB), made once a scene."""
    img = bpy.data.images.get(name)
    if img is None:
        rng = np.random.default_rng(seed)
        v = rng.random((h, w, 4)).astype(np.float16).astype(np.float32)
        if not float_buffer:
            v = np.round(v * 255) / 255
        if not alpha:
            v[..., 3] = 1.0
        img = bpy.data.images.new(name, w, h, float_buffer=float_buffer, alpha=True)
        if float_buffer:
            img.colorspace_settings.name = "Non-Color"
        img.pixels.foreach_set(v.ravel())
    return img


def _spread(i, s, o):
    """Image A's colour (one random value per pixel, in [0, 1]) times s plus o."""
    return i.node("ShaderNodeVectorMath", [(0, i.A)], operation="MULTIPLY_ADD",
                  in_1=(s, s, s), in_2=(o, o, o)).outputs[0]


def _tex(image, vector=None, out="Color", **props):
    """A case: an Image Texture of ``image()`` with ``props``, its Vector from ``vector(i)``
    (None: the UV map), output ``out``."""
    def build(i):
        n = i.node("ShaderNodeTexImage", **props)
        n.image = image()
        if vector is not None:
            i.t.links.new(vector(i), n.inputs["Vector"])
        return n.outputs[out]
    return build


def test_cubic_every_extension_as_cycles(render_direct, tmp_path):
    """Cubic (and Smart) interpolation: a 5 x 3 texture read at random points of [-1, 2]^2, so
    the 4 x 4 B-spline and every extension mode's borders show."""
    img = lambda: _small_image("Small", 5, 3, 7)
    srgb = lambda: _small_image("Bytes", 4, 3, 8, float_buffer=False)
    alpha = lambda: _small_image("Alpha", 3, 4, 9, alpha=True)
    wide = lambda i: _spread(i, 3.0, -1.0)
    cases = {f"cubic {e}": _tex(img, wide, interpolation="Cubic", extension=e)
             for e in ("REPEAT", "EXTEND", "CLIP", "MIRROR")}
    cases.update({
        "smart repeat": _tex(img, wide, interpolation="Smart"),
        "cubic 8-bit sRGB": _tex(srgb, wide, interpolation="Cubic", extension="MIRROR"),
        "cubic alpha clip": _tex(alpha, wide, "Alpha", interpolation="Cubic", extension="CLIP"),
        "linear mirror": _tex(img, wide, interpolation="Linear", extension="MIRROR"),
    })
    _harness()(list(cases.values()), render_direct, tmp_path, list(cases))


def _tilted(normal, case):
    """``case`` on a plane whose object-space normal is ``normal``: the mesh turned by a
    rotation taking +z to it and the object by its inverse (the plane still faces the camera,
    one input per pixel)."""
    from mathutils import Vector

    def build(i):
        obj = bpy.context.active_object
        q = Vector((0.0, 0.0, 1.0)).rotation_difference(Vector(normal).normalized())
        obj.data.transform(q.to_matrix().to_4x4())
        obj.rotation_mode = "QUATERNION"
        obj.rotation_quaternion = q.inverted()
        return case(i)
    return build


BOX_NORMALS = {"+x": (0.9, 0.3, 0.2), "-x": (-0.9, 0.3, -0.2), "+y": (0.2, 0.9, 0.3),
               "-y": (0.3, -0.9, 0.2), "+z": (0.3, 0.2, 0.9), "-z": (-0.2, 0.3, -0.9),
               "x-y": (0.6, -0.5, 0.1), "y-z": (0.1, 0.6, -0.5), "x-z": (-0.6, 0.1, 0.5),
               "corner": (0.55, 0.5, 0.45), "-corner": (-0.5, -0.55, -0.45)}


def test_box_sphere_and_tube_projections_as_cycles(render_direct, tmp_path):
    """Box projection: the object-space normal picks or blends the three planar projections
    (every face and sign with Projection Blend 0; each blend zone, edges and corner, with 0.4);
    Sphere and Tube projections of random points in the unit box."""
    img = lambda: _small_image("Small", 5, 3, 7)
    unit = lambda i: _spread(i, 1.0, 0.0)
    cases = {}
    for blend in (0.0, 0.4):
        for name, n in BOX_NORMALS.items():
            if blend == 0.0 and len(name) > 2:
                continue
            cases[f"box {name} blend {blend}"] = _tilted(n, _tex(
                img, unit, projection="BOX", projection_blend=blend, interpolation="Linear"))
    cases["box cubic clip"] = _tilted(BOX_NORMALS["corner"], _tex(
        img, lambda i: _spread(i, 1.4, -0.2), projection="BOX", projection_blend=0.7,
        interpolation="Cubic", extension="CLIP"))
    cases["sphere"] = _tex(img, unit, projection="SPHERE")
    cases["tube"] = _tex(img, unit, projection="TUBE", interpolation="Cubic")
    cases["sphere alpha"] = _tex(lambda: _small_image("Alpha", 3, 4, 9, alpha=True), unit,
                                 "Alpha", projection="SPHERE")
    _harness()(list(cases.values()), render_direct, tmp_path, list(cases))


def _udim(folder, missing=1011):
    """A UDIM image of tiles 1001 and 1002 (4 x 4 float files) and tile ``missing`` (if any),
    whose file is deleted after Blender found it."""
    import os
    img = bpy.data.images.get("udim")
    if img is not None:
        return img
    tiles = (1001, 1002) + ((missing,) if missing else ())
    for k, tile in enumerate(tiles):
        t = _small_image(f"tile{tile}", 4, 4, 20 + k)
        t.filepath_raw = str(folder / f"udim.{tile}.exr")
        t.file_format = "OPEN_EXR"
        t.save()
    img = bpy.data.images.load(str(folder / "udim.1001.exr"))
    img.name = "udim"
    img.source = "TILED"
    img.colorspace_settings.name = "Non-Color"
    assert sorted(t.number for t in img.tiles) == list(tiles)
    if missing:
        os.remove(folder / f"udim.{missing}.exr")
    return img


def test_udim_tiles_as_cycles(render_direct, tmp_path):
    """A UDIM image: each tile its own texture, chosen by the UV's integer parts (1001 + u +
    10 v, truncated); a tile without a file and a tile not in the image are magenta, as in
    Cycles; a plane whose UVs span tiles 1001 and 1002, read with Closest (one texel a pixel)."""
    img = lambda: _udim(tmp_path)

    def span(me):                                   # u in [0, 2]: both tiles across the plane
        uv = np.empty(2 * len(me.loops), np.float32)
        me.uv_layers.active.data.foreach_get("uv", uv)
        uv[0::2] *= 2.0
        me.uv_layers.active.data.foreach_set("uv", uv)

    plane = _tex(img, interpolation="Closest")
    plane.mesh = span
    cases = {"uv spans 1001-1002": plane,
             "tiles 1001-1012": _tex(img, lambda i: _spread(i, 2.0, 0.0)),
             "negative, cubic": _tex(img, lambda i: _spread(i, 3.0, -1.0),
                                     interpolation="Cubic", extension="EXTEND"),
             "box reads 1001": _tilted(BOX_NORMALS["corner"], _tex(
                 img, lambda i: _spread(i, 1.0, 0.0), projection="BOX", projection_blend=0.3))}
    _harness()(list(cases.values()), render_direct, tmp_path, list(cases))
    warnings = _export().warnings
    assert any("tile 1011" in w and "udim.1011.exr" in w and "magenta" in w
               for w in warnings), warnings


def test_udim_tiles_packed_and_a_corrupt_tile(tmp_path):
    """Packed tiles are read from their packed data (the files gone); a tile file that is not
    an image is warned about (magenta), never an error."""
    _scene_with_texture()
    img = _udim(tmp_path, missing=None)
    img.pack()
    for tile in (1001, 1002):
        (tmp_path / f"udim.{tile}.exr").unlink()
    bpy.data.materials["Textured"].node_tree.nodes["Image Texture"].image = img
    a = _export()
    assert not a.warnings, a.warnings
    got = a.texels.astype(np.float32).reshape(-1, 4, 4, 4)
    for k, tile in enumerate((1001, 1002)):
        want = np.empty(64, np.float32)
        bpy.data.images[f"tile{tile}"].pixels.foreach_get(want)
        np.testing.assert_allclose(got[k], want.reshape(4, 4, 4), atol=1e-3)
    t = _small_image("tile1001", 4, 4, 20)
    t.filepath_raw = str(tmp_path / "bad.1001.exr")
    t.save()
    bad = bpy.data.images.load(str(tmp_path / "bad.1001.exr"))
    bad.source = "TILED"
    (tmp_path / "bad.1001.exr").write_bytes(b"not an image")
    bpy.data.materials["Textured"].node_tree.nodes["Image Texture"].image = bad
    a = _export()
    assert any("tile 1001" in w and "bad.1001.exr" in w and "magenta" in w
               for w in a.warnings), a.warnings


def test_box_projection_on_a_turned_sphere_as_cycles(render_direct, tmp_path):
    """Box projection on a flat-shaded ico sphere, turned and seen at an angle, Projection
    Blend 0 (left) and 0.5 (right): the Vector is a constant point, so each face shows the
    texture at one point of the projection(s) its object-space normal picks; every pixel inside
    a face (its 3 x 3 neighbourhood one colour in Cycles' image) agrees within 1e-3."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    img = _small_image("Small", 5, 3, 7)
    for k, blend in enumerate((0.0, 0.5)):
        bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=1, radius=1.0,
                                              location=(2.4 * k - 1.2, 0.0, 0.0))
        obj = bpy.context.active_object
        obj.rotation_euler = (0.4, 0.9, 0.3)
        m = bpy.data.materials.new(f"box{k}")
        t = m.node_tree
        t.nodes.remove(t.nodes["Principled BSDF"])
        n = t.nodes.new("ShaderNodeTexImage")
        n.image, n.projection, n.projection_blend, n.interpolation = img, "BOX", blend, "Linear"
        xyz = t.nodes.new("ShaderNodeCombineXYZ")
        for c, v in zip(xyz.inputs, (0.37, 0.61, 0.23)):
            c.default_value = v
        t.links.new(xyz.outputs[0], n.inputs["Vector"])
        em = t.nodes.new("ShaderNodeEmission")
        t.links.new(n.outputs["Color"], em.inputs["Color"])
        t.links.new(em.outputs[0], t.nodes["Material Output"].inputs["Surface"])
        obj.data.materials.append(m)
    cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
    cam.data.type, cam.data.ortho_scale = "ORTHO", 5.0
    cam.location = (2.0, -6.0, 3.0)                     # looking at the origin
    cam.rotation_euler = (-cam.location).to_track_quat("-Z", "Y").to_euler()
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.world = bpy.data.worlds.new("W")
    scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0, 0, 0, 1)
    W = 96
    ours, ref = render_direct(scene, tmp_path, W, W, 4, 2)
    win = np.lib.stride_tricks.sliding_window_view(ref, (3, 3), axis=(0, 1))
    inside = np.zeros(ref.shape[:2], bool)
    inside[1:-1, 1:-1] = (np.ptp(win.reshape(W - 2, W - 2, 3, 9), axis=-1).max(-1) < 1e-5) \
        & (ref[1:-1, 1:-1].max(-1) > 0)
    half = W // 2
    for side, least in ((slice(0, half), 3), (slice(half, W), 6)):   # the faces' values
        faces = np.unique(np.round(ref[:, side][inside[:, side]], 4), axis=0)
        assert len(faces) >= least and inside[:, side].sum() > 250
    err = np.abs(ours - ref)[inside].max()
    assert err <= 1e-3, err


def _alpha_image(name, float_buffer):
    """A 3 x 4 image of random colours and alphas in a colour space (not data): Cycles' Color
    carries its alpha (associated)."""
    img = bpy.data.images.get(name)
    if img is None:
        rng = np.random.default_rng(11)
        v = rng.random((4, 3, 4)).astype(np.float32)
        v[0, 0, 3], v[1, 1, 3] = 0.0, 1.0
        if float_buffer:
            v[..., :3] *= v[..., 3:]                  # Blender's float buffers are associated
        else:
            v = np.round(v * 255) / 255
        img = bpy.data.images.new(name, 3, 4, float_buffer=float_buffer, alpha=True)
        img.pixels.foreach_set(v.ravel())
    return img


def _with_alpha_linked(case):
    """``case``'s Color with its node's Alpha output linked too (to a branch that adds 0):
    Cycles then divides the colour by the alpha."""
    def build(i):
        color = case(i)
        zero = i.node("ShaderNodeMath", [(0, color.node.outputs["Alpha"])],
                      operation="LESS_THAN", in_1=-1.0)
        one = i.node("ShaderNodeMath", [(1, zero.outputs[0])], operation="SUBTRACT", in_0=1.0)
        return i.node("ShaderNodeVectorMath", [(0, color), (3, one.outputs[0])],
                      operation="SCALE").outputs[0]
    return build


def test_alpha_association_as_cycles(render_direct, tmp_path):
    """An image with partial alpha: the Color output carries the alpha (Cycles stores images
    associated: float buffers as Blender holds them, 8-bit ones multiplied in their bytes, a
    generated image or a PNG file), and is divided by the interpolated alpha where the Alpha
    output is linked."""
    def png():                                  # the 8-bit image as an external PNG file
        img = bpy.data.images.get("png")
        if img is None:
            src = _alpha_image("8-bit", False)
            src.filepath_raw, src.file_format = str(tmp_path / "alpha.png"), "PNG"
            src.save()
            img = bpy.data.images.load(str(tmp_path / "alpha.png"))
            img.name = "png"
        return img
    wide = lambda i: _spread(i, 3.0, -1.0)
    cases = {}
    for kind, fb in (("float", True), ("8-bit", False), ("png", None)):
        img = png if fb is None else (lambda fb=fb, kind=kind: _alpha_image(kind, fb))
        for interp in ("Closest", "Linear", "Cubic"):
            cases[f"{kind} {interp}"] = _tex(img, wide, interpolation=interp)
            cases[f"{kind} {interp} alpha linked"] = _with_alpha_linked(
                _tex(img, wide, interpolation=interp))
    _harness()(list(cases.values()), render_direct, tmp_path, list(cases))


def test_environment_projections_as_cycles(render_direct, tmp_path):
    """The Environment Texture at random directions: equirectangular and mirror ball."""
    img = lambda: _small_image("Small", 5, 3, 7)

    def env(projection, interpolation):
        def build(i):
            n = i.node("ShaderNodeTexEnvironment", projection=projection,
                       interpolation=interpolation)
            n.image = img()
            i.t.links.new(_spread(i, 2.0, -1.0), n.inputs["Vector"])
            return n.outputs["Color"]
        return build
    cases = {f"{p} {k}": env(p, k) for p in ("EQUIRECTANGULAR", "MIRROR_BALL")
             for k in ("Linear", "Cubic")}
    _harness()(list(cases.values()), render_direct, tmp_path, list(cases))
