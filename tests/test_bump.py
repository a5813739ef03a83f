"""The Bump node against Cycles, rendered by both engines in the same test.

- Linear heights (a Math of the Object coordinates: the finite differences over the ray
  footprint are exact whatever the footprint, so every pixel of a plane has one bumped normal):
  diffuse planes under a sun without size, direct light only, strengths 1 and 0.5, Invert, a
  driven Distance, a Normal Map feeding the Bump, a Bump feeding a Bump, a turned plane, the
  Generated and UV coordinates, a mesh attribute, a plane seen from behind; compared per pixel
  (1e-3 relative: the only difference left is float rounding).
- A Noise Texture's height seen through a perspective camera: compared per 8 x 8 block.
- A height varying within a few pixels across a wide Filter Width: the footprint's radius and
  orientation, compared per column, orthographic, in perspective and seen in a mirror.
- A height of the Texture Coordinate's Normal on a smooth sphere (the smooth normal at the
  offsets), and an Image Texture's height map: compared per 8 x 8 block.
- A constant height folds to the input normal: no program at all; the Displacement output is
  warned about.
"""
import math

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from tests.helpers.blender_scenes import add_camera

T = 8                       # pixels per side of one plane (orthographic view)
SUN = (math.radians(50.0), 0.0, math.radians(30.0))


def _diffuse(mat):
    """A white diffuse BSDF (0.8) into the output: (tree, its BSDF node)."""
    t = mat.node_tree
    t.nodes.remove(t.nodes["Principled BSDF"])
    d = t.nodes.new("ShaderNodeBsdfDiffuse")
    d.inputs["Color"].default_value = (0.8, 0.8, 0.8, 1.0)
    t.links.new(d.outputs[0], t.nodes["Material Output"].inputs["Surface"])
    return t, d


def _node(t, idname, links=(), **props):
    n = t.nodes.new(idname)
    for k, v in props.items():
        if k in n.inputs:
            n.inputs[k].default_value = v
        else:
            setattr(n, k, v)
    for name, sock in links:
        t.links.new(sock, n.inputs[name])
    return n


def _linear_height(t, coord="Object", a=0.9, b=-0.6):
    """h = a x + b y of a texture coordinate (exactly linear over a plane)."""
    tc = t.nodes.new("ShaderNodeTexCoord")
    sep = _node(t, "ShaderNodeSeparateXYZ", [("Vector", tc.outputs[coord])])
    m = _node(t, "ShaderNodeMath", [(0, sep.outputs[0])], operation="MULTIPLY")
    m.inputs[1].default_value = a
    h = _node(t, "ShaderNodeMath", [(0, sep.outputs[1]), (2, m.outputs[0])],
              operation="MULTIPLY_ADD")
    h.inputs[1].default_value = b
    return h.outputs[0]


def _bump(t, height, normal=None, **props):
    links = [("Height", height)] + ([("Normal", normal)] if normal is not None else [])
    return _node(t, "ShaderNodeBump", links, **props)


def _case(strength=1.0, invert=False, distance=0.5, coord="Object"):
    def build(t, d):
        b = _bump(t, _linear_height(t, coord), Strength=strength, Distance=distance,
                  invert=invert)
        t.links.new(b.outputs[0], d.inputs["Normal"])
    return build


def _attribute(t, d):
    """A mesh attribute's height (linear over the triangle)."""
    at = _node(t, "ShaderNodeAttribute", attribute_name="height")
    b = _bump(t, at.outputs["Fac"], Distance=0.5)
    t.links.new(b.outputs[0], d.inputs["Normal"])


def _driven_distance(t, d):
    """Distance from a Math node (a program value) and Filter Width 0.3."""
    v = _node(t, "ShaderNodeMath", operation="MULTIPLY")
    v.inputs[0].default_value, v.inputs[1].default_value = 0.35, 2.0
    b = _bump(t, _linear_height(t), Strength=0.8, **{"Filter Width": 0.3})
    t.links.new(v.outputs[0], b.inputs["Distance"])
    t.links.new(b.outputs[0], d.inputs["Normal"])


def _normal_map_into_bump(t, d):
    """A tangent-space Normal Map of a constant colour feeding the Bump's Normal."""
    rgb = _node(t, "ShaderNodeRGB")
    rgb.outputs[0].default_value = (0.7, 0.35, 0.85, 1.0)
    nm = _node(t, "ShaderNodeNormalMap", [("Color", rgb.outputs[0])], Strength=0.8)
    b = _bump(t, _linear_height(t), nm.outputs[0], Distance=0.4)
    t.links.new(b.outputs[0], d.inputs["Normal"])


def _bump_into_bump(t, d):
    """A Bump on the Generated coordinates feeding a Bump on the Object coordinates."""
    b1 = _bump(t, _linear_height(t, "Generated", 0.3, 0.8), Distance=0.6)
    b2 = _bump(t, _linear_height(t, "Object", -0.5, 0.2), b1.outputs[0], Distance=0.7,
               Strength=0.7)
    t.links.new(b2.outputs[0], d.inputs["Normal"])


LINEAR = {
    "strength 1": _case(), "strength 0.5": _case(0.5), "invert": _case(invert=True),
    "invert 0.5": _case(0.5, True), "generated": _case(coord="Generated", distance=0.3),
    "uv": _case(coord="UV", distance=1.5), "driven distance": _driven_distance,
    "normal map": _normal_map_into_bump, "bump into bump": _bump_into_bump,
    "turned": _case(0.9, distance=0.8), "attribute": _attribute,
    "back": _case(0.8, distance=0.6),      # (last: its triangle reaches into the next square)
}


def _sun_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy, sun.data.angle = 3.0, 0.0
    sun.rotation_euler = SUN
    scene.collection.objects.link(sun)
    scene.world = bpy.data.worlds.new("W")
    scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0, 0, 0, 1)
    scene.render.dither_intensity = 0.0
    scene.cycles.pixel_filter_type, scene.cycles.filter_width = "BOX", 1.0
    scene.render.filter_size = 0.0
    return scene


def _triangle(name, location):
    """One triangle covering the square [-1, 1]^2 around ``location`` (a plane's two triangles
    would share a diagonal that Cycles' shadow rays from samples exactly on it can find: black
    samples there, bump or no bump), with a UV map (0..1 over the square)."""
    me = bpy.data.meshes.new(name)
    me.from_pydata([(-1, -1, 0), (3, -1, 0), (-1, 3, 0)], [], [(0, 1, 2)])
    uv = me.uv_layers.new(name="UVMap")
    uv.data.foreach_set("uv", [0.0, 0.0, 2.0, 0.0, 0.0, 2.0])
    a = me.attributes.new("height", "FLOAT", "POINT")     # 0.4 x - 0.7 y: linear
    a.data.foreach_set("value", [0.3, 1.9, -2.5])
    obj = bpy.data.objects.new(name, me)
    obj.location = location
    bpy.context.scene.collection.objects.link(obj)
    return obj


def test_bump_linear_height_per_pixel_as_cycles(render_direct, tmp_path):
    scene = _sun_scene()
    names = list(LINEAR)
    cols = 5
    rows = -(-len(names) // cols)
    for k, name in enumerate(names):
        r, c = divmod(k, cols)
        obj = _triangle(name, (4 * c - 2 * cols + 2, 2 * rows - 2 - 4 * r, 0))
        if name in ("turned", "back"):    # a rotated, scaled object: Object space differs
            obj.rotation_euler = (0.0, 0.0, 0.7) if name == "turned" else (math.pi, 0.0, 0.0)
            obj.scale = (1.5, 1.5, 1.0)       # ("back": seen from behind)
        mat = bpy.data.materials.new(name)
        LINEAR[name](*_diffuse(mat))
        obj.data.materials.append(mat)
    add_camera(scene, ortho_width=4.0 * cols)
    ours, ref = render_direct(scene, tmp_path, cols * 2 * T,
                             rows * 2 * T, 4, 2)
    flat = 0.8 / math.pi * 3.0 * math.cos(SUN[0])       # the unbumped plane
    bad = []
    for k, name in enumerate(names):
        r, c = divmod(k, cols)
        y, x = (2 * r + 1) * T - T // 2, (2 * c + 1) * T - T // 2      # the square's pixels
        a, b = ours[y:y + T, x:x + T], ref[y:y + T, x:x + T]
        # each case tilts the normal: Cycles' plane differs from the flat one
        assert abs(float(b.mean()) - flat) > 0.02 * flat, name
        if not np.abs(a - b).max() <= 1e-3 * float(b.max()):
            bad.append((name, float(np.abs(a - b).max()), float(b.mean()), float(a.mean())))
    assert not bad, f"planes differing from Cycles (max abs error, Cycles', ours): {bad}"


def test_bump_noise_height_per_block_as_cycles(render_direct, tmp_path):
    """A Noise Texture's height (on the default Generated coordinates) through a perspective
    camera: the heights at the footprint's offsets, the perspective differential.  Both images
    average the same shading over 16 different positions in each pixel (Cycles' sampler, this
    engine's R2 jitter): they differ by a fraction of the shading's variation inside a pixel,
    measured 0.2 % per pixel and 0.012 % per 8 x 8 block at most; asserted within 1 % and
    0.1 % (the bumps change the blocks by 16 %).  To first order the bumped normal of a
    smooth height does not depend on the footprint: test_bump_footprint_... checks that."""
    scene = _sun_scene()
    bpy.ops.mesh.primitive_plane_add(size=6)
    mat = bpy.data.materials.new("noise")
    t, d = _diffuse(mat)
    noise = _node(t, "ShaderNodeTexNoise", Scale=0.8, Detail=2.0)
    b = _bump(t, noise.outputs["Fac"], Distance=1.0)
    t.links.new(b.outputs[0], d.inputs["Normal"])
    bpy.context.active_object.data.materials.append(mat)
    add_camera(scene, location=(0.0, -2.5, 3.5), rotation=(math.radians(35.0), 0.0, 0.0))
    ours, ref = render_direct(scene, tmp_path, 32, 32, 16, 16)
    blocks = [x.reshape(4, 8, 4, 8, 3).mean(axis=(1, 3)) for x in (ours, ref)]
    flat = 0.8 / math.pi * 3.0 * math.cos(SUN[0])
    assert np.ptp(blocks[1]) > 0.1 * flat          # the bumps show
    err = np.abs(blocks[0] - blocks[1]) / blocks[1]
    assert err.max() < 1e-3, f"worst block {err.max():.5f}"
    px = np.abs(ours - ref) / ref
    assert px.max() < 0.01, f"worst pixel {px.max():.4f}"


@pytest.mark.parametrize("view", ["ortho", "perspective"])
def test_bump_footprint_per_column_as_cycles(view, render_direct, tmp_path):
    """A height varying within a few pixels, differenced over a wide Filter Width (8: one period
    of the height across the footprint's offsets): the normal then depends on the footprint's
    radius (one pixel, orthographic; perspective: the camera's angular pixel at the distance
    from the camera, the ray starting on a near clipping plane two thirds of the way), its
    orientation (Cycles' pair around Ng) and the filter width, each by tens of %.  The height
    varies along x only: columns compared (32 pixels each, 16 samples a pixel), within 1 %
    (measured 0.4 %; orthographic, a footprint 30 % too large, or turned by 90 degrees, is 19 %
    and 39 % off; in perspective, leaving out the radius the ray has at the clipping plane
    66 %)."""
    scene = _sun_scene()
    _triangle("fine", (0, 0, 0))
    mat = bpy.data.materials.new("fine")
    t, d = _diffuse(mat)
    tc = t.nodes.new("ShaderNodeTexCoord")
    sep = _node(t, "ShaderNodeSeparateXYZ", [("Vector", tc.outputs["Object"])])
    k = _node(t, "ShaderNodeMath", [(0, sep.outputs[0])], operation="MULTIPLY")
    k.inputs[1].default_value = 2.0 * math.pi / 0.5           # a period of 8 pixels
    sin = _node(t, "ShaderNodeMath", [(0, k.outputs[0])], operation="SINE")
    b = _bump(t, sin.outputs[0], Distance=0.06, **{"Filter Width": 8.0})
    t.links.new(b.outputs[0], d.inputs["Normal"])
    bpy.data.objects["fine"].data.materials.append(mat)
    if view == "ortho":
        add_camera(scene, ortho_width=2.0)
    else:
        add_camera(scene, location=(0.0, 0.0, 3.0))
        scene.camera.data.lens, scene.camera.data.clip_start = 55.0, 2.0
    ours, ref = render_direct(scene, tmp_path, 32, 32, 16, 16)
    cols = [x.mean(axis=(0, 2)) for x in (ours, ref)]
    flat = 0.8 / math.pi * 3.0 * math.cos(SUN[0])
    assert np.ptp(cols[1]) > 0.2 * flat                  # the bumps show (29 %)
    err = np.abs(cols[0] - cols[1]) / cols[1]
    assert err.max() < 0.01, f"worst column {err.max():.4f}: {cols[0]} {cols[1]}"


def test_bump_footprint_after_a_mirror_per_column_as_cycles(cycles, render_exr, tmp_path, tiny):
    """Seen in a mirror, a surface's footprint is the camera's angular pixel times the whole
    path's length (Cycles' bounces keep the camera ray's dD): a perspective view of a mirror
    reflecting an emitting triangle whose colour is the cosine of its bumped normal with a fixed
    direction (the Bump's output on a non-BSDF input), the height varying within a few pixels
    across a wide Filter Width, as test_bump_footprint_...; columns within 1 % (measured
    0.13 %; with the last segment's length alone 15 % off)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.world = bpy.data.worlds.new("W")
    scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0, 0, 0, 1)
    scene.render.dither_intensity = 0.0
    scene.cycles.pixel_filter_type, scene.cycles.filter_width = "BOX", 1.0
    scene.render.filter_size = 0.0
    bpy.ops.mesh.primitive_plane_add(size=8)
    mirror = bpy.data.materials.new("mirror")
    t = mirror.node_tree
    t.nodes.remove(t.nodes["Principled BSDF"])
    g = _node(t, "ShaderNodeBsdfGlossy", Roughness=0.0)
    g.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    t.links.new(g.outputs[0], t.nodes["Material Output"].inputs["Surface"])
    bpy.context.active_object.data.materials.append(mirror)
    obj = _triangle("seen", (0.0, 2.0, 2.0))
    obj.rotation_euler, obj.scale = (math.radians(135.0), 0.0, 0.0), (2.5, 2.5, 1.0)
    mat = bpy.data.materials.new("seen")
    t = mat.node_tree
    t.nodes.remove(t.nodes["Principled BSDF"])
    tc = t.nodes.new("ShaderNodeTexCoord")
    sep = _node(t, "ShaderNodeSeparateXYZ", [("Vector", tc.outputs["Object"])])
    k = _node(t, "ShaderNodeMath", [(0, sep.outputs[0])], operation="MULTIPLY")
    k.inputs[1].default_value = 2.0 * math.pi / 0.93          # about 8 pixels a period
    sin = _node(t, "ShaderNodeMath", [(0, k.outputs[0])], operation="SINE")
    b = _bump(t, sin.outputs[0], Distance=0.25, **{"Filter Width": 8.0})
    dot = _node(t, "ShaderNodeVectorMath", [(0, b.outputs[0])], operation="DOT_PRODUCT")
    dot.inputs[1].default_value = (0.6, -0.5, -0.62)
    shade = _node(t, "ShaderNodeMath", [(0, dot.outputs["Value"])], operation="MULTIPLY_ADD")
    shade.inputs[1].default_value = shade.inputs[2].default_value = 0.5
    em = _node(t, "ShaderNodeEmission", [("Strength", shade.outputs[0])])
    em.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    t.links.new(em.outputs[0], t.nodes["Material Output"].inputs["Surface"])
    obj.data.materials.append(mat)
    add_camera(scene, location=(0.0, -2.0, 2.0), rotation=(math.radians(45.0), 0.0, 0.0))
    scene.camera.data.lens = 55.0
    cycles(scene, 16, width=32)
    c = scene.cycles
    c.max_bounces = c.glossy_bounces = 1
    ref = render_exr(tmp_path / "cycles.exr")
    tiny(scene, width=32, height=32, passes=16, photons=64)
    ours = render_exr(tmp_path / "ours.exr")
    cols = [x.mean(axis=(0, 2)) for x in (ours, ref)]
    err = np.abs(cols[0] - cols[1]) / cols[1]
    assert np.ptp(cols[1]) > 0.2 * cols[1].mean()        # the bumps show (31 %)
    assert err.max() < 0.01, f"worst column {err.max():.4f}: {cols[0]} {cols[1]}"


def test_bump_image_height_per_block_as_cycles(render_direct, tmp_path):
    """A height map: an Image Texture (8 x 8 random texels, Linear, Non-Color) on the UV map, 4
    pixels a texel: the image op compiled at each offset.  Per 8 x 8 block within 0.5 %
    (measured 0.12 %) and per pixel within 6 % (measured 4.4 %, in the pixels where the bilinear
    slopes change, at the texels' centres: the two engines' sample positions there)."""
    scene = _sun_scene()
    obj = _triangle("map", (0.0, 0.0, 0.0))
    rng = np.random.default_rng(7)
    px = np.ones((8, 8, 4), np.float32)
    px[..., :3] = rng.random((8, 8, 1))
    img = bpy.data.images.new("height", 8, 8, float_buffer=True)
    img.colorspace_settings.name = "Non-Color"
    img.pixels.foreach_set(px.ravel())
    mat = bpy.data.materials.new("map")
    t, d = _diffuse(mat)
    tex = _node(t, "ShaderNodeTexImage", image=img, interpolation="Linear")
    b = _bump(t, tex.outputs["Color"], Distance=0.08)
    t.links.new(b.outputs[0], d.inputs["Normal"])
    obj.data.materials.append(mat)
    add_camera(scene, ortho_width=2.0)
    ours, ref = render_direct(scene, tmp_path, 32, 32, 16, 16)
    blocks = [x.reshape(4, 8, 4, 8, 3).mean(axis=(1, 3)) for x in (ours, ref)]
    err = np.abs(blocks[0] - blocks[1]) / blocks[1]
    px_err = np.abs(ours - ref) / ref
    assert np.ptp(blocks[1]) > 0.1 * blocks[1].mean()          # the bumps show (14 %)
    assert err.max() < 5e-3, f"worst block {err.max():.5f}"
    assert px_err.max() < 0.06, f"worst pixel {px_err.max():.4f}"


def test_bump_texture_coordinate_normal_per_block_as_cycles(render_direct, tmp_path):
    """A height read from the Texture Coordinate's Normal on a smooth sphere, seen from above
    (no silhouette in view): at the offsets Cycles interpolates the smooth normal there (were
    it not moved, the height would not change: 16 % off per block, 31 % per pixel).  Per 8 x 8
    block within 0.5 % and per pixel within 3 % (measured 0.04 % and 1.4 %: the shading varies
    more within a pixel here than on the Noise plane)."""
    scene = _sun_scene()
    bpy.ops.mesh.primitive_uv_sphere_add(segments=24, ring_count=12, radius=1.0)
    bpy.ops.object.shade_smooth()
    mat = bpy.data.materials.new("normal")
    t, d = _diffuse(mat)
    tc = t.nodes.new("ShaderNodeTexCoord")
    wave = _node(t, "ShaderNodeTexWave", [("Vector", tc.outputs["Normal"])], Scale=0.15)
    b = _bump(t, wave.outputs["Fac"], Distance=0.1)
    t.links.new(b.outputs[0], d.inputs["Normal"])
    bpy.context.active_object.data.materials.append(mat)
    add_camera(scene, ortho_width=0.8)
    ours, ref = render_direct(scene, tmp_path, 32, 32, 16, 16)
    blocks = [x.reshape(4, 8, 4, 8, 3).mean(axis=(1, 3)) for x in (ours, ref)]
    err = np.abs(blocks[0] - blocks[1]) / blocks[1]
    px = np.abs(ours - ref) / ref
    assert err.max() < 5e-3, f"worst block {err.max():.5f}"
    assert px.max() < 0.03, f"worst pixel {px.max():.4f}"


def test_bump_constant_height_folds():
    """A Bump whose height is constant (unlinked, or a Value) gives its input normal: no program
    where nothing else is driven, and a Normal Map's normal through it."""
    from ppm_engine.blender.export.material_nodes import read_material
    bpy.ops.wm.read_factory_settings(use_empty=True)
    warnings = []
    mat = bpy.data.materials.new("const")
    t, d = _diffuse(mat)
    v = _node(t, "ShaderNodeValue")
    v.outputs[0].default_value = 0.3
    b = _bump(t, v.outputs[0], Distance=0.5)
    t.links.new(b.outputs[0], d.inputs["Normal"])
    _row, nodes, program = read_material(mat, warnings.append)
    assert program is None and not warnings
    assert not np.any(nodes[0]["normal"]) and nodes[0]["bound"] == 0
    # with a Normal Map on its Normal, the Bump is the Normal Map
    nm = _node(t, "ShaderNodeNormalMap", space="WORLD")
    t.links.new(nm.outputs[0], b.inputs["Normal"])
    _row, nodes, program = read_material(mat, warnings.append)
    assert program is not None
    ops = _ops(program)
    assert "normal_map" in ops and "bump" not in ops


def _ops(program):
    """The op names of a program (its words as read_material returns them)."""
    from ppm_engine.scene.shader_program import OP_EXTRA, OP_NAMES, SVM_END, SVM_TABLE
    n_binds, n_words = int(program[0, 0]), int(program[0, 1])
    i, names = 1 + n_binds, []
    while i < n_words and int(program[i, 0]) != SVM_END:
        op = int(program[i, 0])
        names.append(OP_NAMES[op])
        i += 1 + OP_EXTRA.get(op, 0) + (int(program[i, 3]) if op == SVM_TABLE else 0)
    return names


def test_displacement_output_is_warned():
    """The material output's Displacement is not rendered: one warning naming the material."""
    from ppm_engine.blender.export.material_nodes import read_material
    bpy.ops.wm.read_factory_settings(use_empty=True)
    mat = bpy.data.materials.new("displaced")
    t, _d = _diffuse(mat)
    noise = t.nodes.new("ShaderNodeTexNoise")
    disp = _node(t, "ShaderNodeDisplacement", [("Height", noise.outputs["Fac"])])
    t.links.new(disp.outputs[0], t.nodes["Material Output"].inputs["Displacement"])
    warnings = []
    _row, _nodes, program = read_material(mat, warnings.append)
    assert program is None
    assert len(warnings) == 1 and "Displacement" in warnings[0] and "displaced" in warnings[0]
