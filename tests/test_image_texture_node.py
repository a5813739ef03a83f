"""The Image Texture node in shader programs, per pixel against Cycles (the harness of
tests/helpers/shader_grid.py: one plane per case, image A's colour one value per
pixel): cubic and Smart interpolation with every extension, box, sphere and tube projections
(box on a turned sphere too), UDIM tiles (a tile without a file and one not in the image
magenta), alpha association and the Environment Texture's projections; and UDIM tiles packed
or unreadable at export.  The scene and export helpers are tests/helpers/blender_scenes.py's
(test_textures.py uses them too)."""
import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from tests.helpers.blender_scenes import export, scene_with_texture
from tests.helpers.shader_grid import compare_cases


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
    compare_cases(list(cases.values()), render_direct, tmp_path, list(cases))


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
    compare_cases(list(cases.values()), render_direct, tmp_path, list(cases))


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
    compare_cases(list(cases.values()), render_direct, tmp_path, list(cases))
    warnings = export().warnings
    assert any("tile 1011" in w and "udim.1011.exr" in w and "magenta" in w
               for w in warnings), warnings


def test_udim_tiles_packed_and_a_corrupt_tile(tmp_path):
    """Packed tiles are read from their packed data (the files gone); a tile file that is not
    an image is warned about (magenta), never an error."""
    scene_with_texture()
    img = _udim(tmp_path, missing=None)
    img.pack()
    for tile in (1001, 1002):
        (tmp_path / f"udim.{tile}.exr").unlink()
    bpy.data.materials["Textured"].node_tree.nodes["Image Texture"].image = img
    a = export()
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
    a = export()
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
    compare_cases(list(cases.values()), render_direct, tmp_path, list(cases))


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
    compare_cases(list(cases.values()), render_direct, tmp_path, list(cases))
