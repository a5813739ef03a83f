"""Nodes that read the shading point, the object, the camera or the path, against Cycles per
pixel (the harness of tests/helpers/shader_grid.py: one plane per case, inputs from two images
read with Closest interpolation, every pixel within 1e-3): Normal Map, Texture Coordinate and
Geometry, Attribute and Color Attribute, Object Info, Light Path, Vector Transform, Mapping
with linked inputs, and the Window coordinates under perspective and orthographic cameras."""
import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from tests.helpers.shader_grid import Inputs, T, compare_cases, emit, ortho_view


def test_normal_map_as_cycles(render_direct, tmp_path):
    """The Normal Map node's output (tangent space from the UV map's tangents on planes turned,
    mirrored and seen from the back; world and Blender's spaces; object space on planes turned
    and mirrored, through the object's inverse transpose)."""
    import math

    def nmap(space="TANGENT", strength=1.0, **plane):
        def build(i):
            n = i.node("ShaderNodeNormalMap", [("Color", i.A)], space=space)
            n.inputs["Strength"].default_value = strength
            return n.outputs[0]
        for k, v in plane.items():
            setattr(build, k, v)
        return build
    cases = {"tangent": nmap(), "tangent turned": nmap(rz=math.pi / 2),
             "tangent mirrored": nmap(sx=-1.0), "tangent back": nmap(rx=math.pi),
             "tangent 0.4": nmap(strength=0.4), "tangent 1.7": nmap(strength=1.7),
             "world": nmap("WORLD"), "world 0.5": nmap("WORLD", 0.5),
             "blender world": nmap("BLENDER_WORLD"), "object": nmap("OBJECT"),
             "blender object": nmap("BLENDER_OBJECT"),
             "blender world back": nmap("BLENDER_WORLD", rx=math.pi),
             # (turned by quarter turns: the planes keep to their squares of the grid)
             "object turned": nmap("OBJECT", rz=math.pi / 2),
             "object mirrored": nmap("OBJECT", sx=-1.0),
             "object back": nmap("OBJECT", rx=math.pi),
             "blender object turned": nmap("BLENDER_OBJECT", rz=-math.pi / 2),
             "object turned 0.6": nmap("OBJECT", 0.6, rz=math.pi)}
    compare_cases(list(cases.values()), render_direct, tmp_path, list(cases))


def test_coordinates_and_geometry_as_cycles(render_direct, tmp_path):
    """Texture Coordinate (Generated on planes turned, mirrored and seen from the back; UV) and
    Geometry (normal, true normal, incoming, backfacing) outputs.  Coordinates that vary inside
    a pixel are snapped to the pixel's (1/T steps: one value per pixel whatever its samples)."""
    import math

    def out(idname, name, **plane):
        def build(i):
            o = i.node(idname).outputs[name]
            if name in ("Generated", "UV", "Position"):   # (z: 0 or 1/2, off a step edge)
                o = i.node("ShaderNodeVectorMath", [(0, o)], operation="ADD",
                           in_1=(0.0, 0.0, 0.5 / T)).outputs[0]
                snap = i.node("ShaderNodeVectorMath", [(0, o)], operation="SNAP")
                snap.inputs[1].default_value = ((2.0 if name == "Position" else 1.0) / T,) * 3
                o = snap.outputs[0]
            return o
        for k, v in plane.items():
            setattr(build, k, v)
        return build
    tc, geo = "ShaderNodeTexCoord", "ShaderNodeNewGeometry"
    cases = {"generated": out(tc, "Generated"),
             "generated turned": out(tc, "Generated", rz=math.pi / 2),
             "generated mirrored": out(tc, "Generated", sx=-1.0),
             "generated back": out(tc, "Generated", rx=math.pi), "uv": out(tc, "UV", rz=math.pi),
             "reflection": out(tc, "Reflection"), "reflection back": out(tc, "Reflection",
                                                                          rx=math.pi),
             "position": out(geo, "Position"), "position mirrored": out(geo, "Position", sx=-1.0),
             "normal": out(geo, "Normal", rx=math.pi), "true normal": out(geo, "True Normal"),
             "incoming": out(geo, "Incoming"), "backfacing": out(geo, "Backfacing", rx=math.pi)}
    compare_cases(list(cases.values()), render_direct, tmp_path, list(cases))


def _attributes(me):
    """Per-face random colours (float and byte, the byte one the default colour attribute) and
    the vertices' x as a float on points."""
    rng = np.random.default_rng(5)
    for name, kind in (("fc", "FLOAT_COLOR"), ("bc", "BYTE_COLOR")):
        a = me.attributes.new(name, kind, "FACE")
        a.data.foreach_set("color", rng.random(4 * len(me.polygons)).astype(np.float32))
    me.attributes.default_color_name = "bc"
    px = me.attributes.new("px", "FLOAT", "POINT")
    co = np.empty(3 * len(me.vertices), np.float32)
    me.vertices.foreach_get("co", co)
    px.data.foreach_set("value", co[0::3])


def test_attributes_as_cycles(render_direct, tmp_path):
    """Attribute and Color Attribute nodes: face colours (float, byte: the default colour
    attribute), their Fac and Alpha, a point float interpolated (stepped per pixel: one value
    per pixel whatever its samples), an attribute the mesh lacks (0)."""
    def attr(name, out="Color", idname="ShaderNodeAttribute", step=False):
        def build(i):
            n = i.node(idname)
            if idname == "ShaderNodeAttribute":
                n.attribute_name = name
            else:
                n.layer_name = name
            o = n.outputs[out]
            if step:                               # floor((x + 1) T / 2) per pixel
                o = i.node("ShaderNodeMath", [(0, o)], operation="MULTIPLY_ADD",
                           in_1=T / 2, in_2=T / 2).outputs[0]
                o = i.node("ShaderNodeMath", [(0, o)], operation="FLOOR").outputs[0]
            return o
        build.mesh = _attributes
        return build
    cases = {"float colour": attr("fc"), "float colour fac": attr("fc", "Fac"),
             "alpha": attr("fc", "Alpha"), "byte colour": attr("bc"),
             "default colour": attr("", idname="ShaderNodeVertexColor"),
             "default alpha": attr("", "Alpha", idname="ShaderNodeVertexColor"),
             "point float": attr("px", "Fac", step=True), "missing": attr("nope")}
    compare_cases(list(cases.values()), render_direct, tmp_path, list(cases))


def test_object_info_and_object_coordinates_as_cycles(render_direct, tmp_path):
    """Object Info (location, colour, alpha, pass index, random, the material's pass index) of
    planes with their own colour and index, and Texture Coordinate's Object output (the plane's
    own space, turned and mirrored), stepped per pixel."""
    import math

    def info(name, **plane):
        def build(i):
            n = i.node("ShaderNodeObjectInfo")
            if name == "Material Index":
                next(m for m in bpy.data.materials if m.node_tree == i.t).pass_index = 3
            return n.outputs[name]
        plane.setdefault("ocolor", (0.3, 0.6, 0.9, 0.4))
        plane.setdefault("pindex", 7)
        for k, v in plane.items():
            setattr(build, k, v)
        return build

    def obj_coords(**plane):
        def build(i):
            n = i.node("ShaderNodeTexCoord")
            o = i.node("ShaderNodeVectorMath", [(0, n.outputs["Object"])], operation="ADD",
                       in_1=(0.0, 0.0, 0.5 / T)).outputs[0]
            snap = i.node("ShaderNodeVectorMath", [(0, o)], operation="SNAP")
            snap.inputs[1].default_value = (2.0 / T,) * 3
            return snap.outputs[0]
        for k, v in plane.items():
            setattr(build, k, v)
        return build
    cases = {"location": info("Location"), "colour": info("Color"), "alpha": info("Alpha"),
             "index": info("Object Index"), "random": info("Random"),
             "random 2": info("Random"), "material index": info("Material Index"),
             "object": obj_coords(), "object turned": obj_coords(rz=math.pi / 2),
             "object mirrored": obj_coords(sx=-1.0)}
    compare_cases(list(cases.values()), render_direct, tmp_path, list(cases))


def test_light_path_as_cycles(cycles, render_exr, tmp_path, tiny):
    """Light Path outputs (three per case as an emission's RGB) on a plane the camera sees and
    on the same plane seen only in a mirror (a glossy, singular reflection one bounce deep),
    under an orthographic camera: every pixel away from the planes' edges as Cycles."""
    import math
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    cases = [("Is Camera Ray", "Is Shadow Ray", "Is Diffuse Ray"),
             ("Is Glossy Ray", "Is Singular Ray", "Is Reflection Ray"),
             ("Is Transmission Ray", "Ray Depth", "Glossy Depth"),
             ("Ray Length", "Transparent Depth", "Transmission Depth")]
    mirror = bpy.data.materials.new("mirror")
    g = mirror.node_tree.nodes.new("ShaderNodeBsdfAnisotropic")
    g.inputs["Roughness"].default_value = 0.0
    g.inputs["Color"].default_value = (1, 1, 1, 1)
    mirror.node_tree.links.new(g.outputs[0],
                               mirror.node_tree.nodes["Material Output"].inputs["Surface"])
    for k, outs in enumerate(cases):
        mat = bpy.data.materials.new(f"path{k}")
        t = mat.node_tree
        t.nodes.remove(t.nodes["Principled BSDF"])
        lp, comb, em = (t.nodes.new(n) for n in ("ShaderNodeLightPath", "ShaderNodeCombineXYZ",
                                                  "ShaderNodeEmission"))
        for i, name in enumerate(outs):
            t.links.new(lp.outputs[name], comb.inputs[i])
        t.links.new(comb.outputs[0], em.inputs["Color"])
        t.links.new(em.outputs[0], t.nodes["Material Output"].inputs["Surface"])
        y = 7 - 2 * k
        for x, z, rx, m, seen in ((-1, 0, 0, mat, True), (1, 0, 0, mirror, True),
                                  (1, 1, math.pi, mat, False)):
            bpy.ops.mesh.primitive_plane_add(size=2, location=(x, y - 4, z),
                                             rotation=(rx, 0, 0))
            obj = bpy.context.active_object
            obj.data.materials.append(m)
            obj.visible_camera = seen
    ortho_view(scene, 8.0)
    w, h = 4 * T, 8 * T
    cycles(scene, 4, width=w)
    scene.render.resolution_y = h
    ref = render_exr(tmp_path / "cycles.exr")
    tiny(scene, width=w, height=h, passes=2, photons=64)
    scene.cycles.max_bounces = 4
    ours = render_exr(tmp_path / "ours.exr")
    inner = np.zeros((h, w), bool)                  # each plane's pixels, two from its edges
    for r in range(4):
        for c in range(2):
            inner[r * 2 * T + 2:(r + 1) * 2 * T - 2, c * 2 * T + 2:(c + 1) * 2 * T - 2] = True
    err = np.abs(ours - ref).max(axis=2)
    assert err[inner].max() <= 1e-3, (err[inner].max(), ref[inner].reshape(-1, 3)[:: T * T])
    # the cases differ: a constant or ignored path state would be caught
    assert ref[inner][:, 0].max() - ref[inner][:, 0].min() > 0.5


def test_vector_transform_and_camera_coordinates_as_cycles(render_direct, tmp_path):
    """Vector Transform between world, object and camera space for points, vectors and normals
    (planes turned and mirrored: their own matrices), and Texture Coordinate's Camera output
    (stepped per pixel)."""
    import math

    def vt(frm, to, kind, **plane):
        def build(i):
            return i.node("ShaderNodeVectorTransform", [(0, i.A)], convert_from=frm,
                          convert_to=to, vector_type=kind).outputs[0]
        for k, v in plane.items():
            setattr(build, k, v)
        return build

    def camera(i):
        o = i.node("ShaderNodeTexCoord").outputs["Camera"]
        o = i.node("ShaderNodeVectorMath", [(0, o)], operation="ADD",
                   in_1=(0.0, 0.0, 0.5 / T)).outputs[0]
        snap = i.node("ShaderNodeVectorMath", [(0, o)], operation="SNAP")
        snap.inputs[1].default_value = (2.0 / T,) * 3
        return snap.outputs[0]
    cases = {}
    for kind in ("POINT", "VECTOR", "NORMAL"):
        for frm, to in (("WORLD", "CAMERA"), ("CAMERA", "WORLD"), ("WORLD", "OBJECT"),
                        ("OBJECT", "WORLD"), ("OBJECT", "CAMERA"), ("CAMERA", "OBJECT")):
            cases[f"{kind.lower()} {frm.lower()} to {to.lower()}"] = vt(
                frm, to, kind, rz=math.pi / 2, sx=-1.0)
    cases["camera coordinates"] = camera
    compare_cases(list(cases.values()), render_direct, tmp_path, list(cases))


def test_mapping_with_linked_inputs_as_cycles(render_direct, tmp_path):
    """Mapping of every type whose Location, Rotation and Scale come from links (per-pixel
    values), and Texture Coordinate's Normal output (object space, on turned planes)."""
    import math

    def mapping(kind):
        def build(i):
            rot = i.node("ShaderNodeVectorMath", [(0, i.B)], operation="SCALE")
            rot.inputs[3].default_value = 3.0                 # angles up to 3 radians
            n = i.node("ShaderNodeMapping", [(0, i.A), ("Rotation", rot.outputs[0])],
                       vector_type=kind)
            if "Location" in n.inputs and n.inputs["Location"].enabled:
                i.t.links.new(i.B, n.inputs["Location"])
            if "Scale" in n.inputs:
                sc = i.node("ShaderNodeVectorMath", [(0, i.A)], operation="ADD",
                            in_1=(0.5, -0.3, 0.8))
                i.t.links.new(sc.outputs[0], n.inputs["Scale"])
            return n.outputs[0]
        return build

    def normal(**plane):
        def build(i):
            return i.node("ShaderNodeTexCoord").outputs["Normal"]
        for k, v in plane.items():
            setattr(build, k, v)
        return build
    cases = {f"mapping {k.lower()}": mapping(k) for k in ("POINT", "TEXTURE", "VECTOR", "NORMAL")}
    cases.update({"normal coordinate": normal(rz=math.pi / 2, sx=-1.0),
                  "normal coordinate back": normal(rx=math.pi)})
    compare_cases(list(cases.values()), render_direct, tmp_path, list(cases))


def _window_scene(kind, res, fit="AUTO", shift=(0.0, 0.0)):
    """A large plane filling the view of a turned camera of ``kind`` (PERSP or ORTHO, sensor
    fit, shift) at resolution ``res``; its emission: the Window coordinates x, y snapped to
    the pixel they fall in (floor(x W) / W: one value per pixel whatever its samples) and z as
    it is."""
    import math
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    ortho_view(scene, 1.0)
    cam = scene.camera
    cam.data.type, cam.data.sensor_fit = kind, fit
    cam.data.shift_x, cam.data.shift_y = shift
    cam.data.lens, cam.data.ortho_scale = 30.0, 7.0
    cam.location, cam.rotation_euler = (0.5, -6.0, 5.0), (math.radians(50), 0.0, 0.2)
    bpy.ops.mesh.primitive_plane_add(size=400.0)
    mat = bpy.data.materials.new("window")
    t = mat.node_tree
    t.nodes.remove(t.nodes["Principled BSDF"])
    i = Inputs.__new__(Inputs)
    i.t = t
    sep = i.node("ShaderNodeSeparateXYZ", [(0, i.node("ShaderNodeTexCoord").outputs["Window"])])
    comb = i.node("ShaderNodeCombineXYZ", [(2, sep.outputs[2])])
    for k, n in enumerate(res):
        m = i.node("ShaderNodeMath", [(0, sep.outputs[k])], operation="MULTIPLY", in_1=float(n))
        f = i.node("ShaderNodeMath", [(0, m.outputs[0])], operation="FLOOR")
        d = i.node("ShaderNodeMath", [(0, f.outputs[0])], operation="DIVIDE", in_1=float(n))
        t.links.new(d.outputs[0], comb.inputs[k])
    emit(t, comb.outputs[0], 0.0)
    bpy.context.active_object.data.materials.append(mat)
    return scene


@pytest.mark.parametrize("kind, res, fit, shift", [
    ("PERSP", (24, 16), "AUTO", (0.1, -0.05)), ("PERSP", (16, 24), "VERTICAL", (0.0, 0.08)),
    ("PERSP", (24, 16), "VERTICAL", (-0.1, 0.0)), ("ORTHO", (24, 16), "AUTO", (0.05, 0.1)),
    ("ORTHO", (16, 24), "HORIZONTAL", (0.0, -0.1))])
def test_window_coordinates_as_cycles(render_direct, tmp_path, kind, res, fit, shift):
    """Texture Coordinate's Window output under perspective and orthographic cameras, sensor
    fits, shifts and non-square images: every pixel's (snapped) x and y and the 0 z as
    Cycles'.  A projection off by more than ~1/16 pixel moves samples into the next step."""
    scene = _window_scene(kind, res, fit, shift)
    w, h = res
    ours, ref = render_direct(scene, tmp_path, w, h, 4, 2)
    err = np.abs(ours - ref).max()
    assert err <= 1e-3, (err, ref[::4, ::4, 0], ours[::4, ::4, 0])
    # the image's steps, bottom-left pixel (0, 0) to top-right: Cycles' y is up
    exp_x = (np.arange(w) / w)[None, :].repeat(h, 0)
    exp_y = ((h - 1 - np.arange(h)) / h)[:, None].repeat(w, 1)
    np.testing.assert_allclose(ref[..., 0], exp_x, atol=1e-6)
    np.testing.assert_allclose(ref[..., 1], exp_y, atol=1e-6)


@pytest.mark.parametrize("render_level", [2, 0])
def test_normal_map_on_the_reported_icosphere_as_cycles(render_level, cycles, render_exr, tiny,
                                                         tmp_path):
    """The Normal Map's output (as an emission colour, N / 2 + 1/2) on the reported
    icosphere: subdivided at render level 2 (viewport level 1), its tangent space from the
    UV map's tangents, which Cycles computes by MikkTSpace on the triangles of the mesh it
    renders (on the quads, up to ~1 degree apart around the irregular vertices: 27 % of
    the pixels off by more than 2e-3, 1 % by more than 0.014); and not subdivided (render
    level 0), where the frame's normal, the corners' normals interpolated and not
    normalised as in Cycles, is up to 7 % short inside the triangles (its tilts were too
    small: 90 % of the pixels off by more than 2e-3).  Samples at the pixels' centres (a
    0.01-pixel filter): 99 % of the sphere's pixels within 2e-3 (its silhouette's hit or
    miss the rest)."""
    from tests.helpers.normal_maps import look_at, normal_mapped_icosphere
    ob, t, nm = normal_mapped_icosphere(tmp_path / "tilts.png", tilt=0.8, smooth=True)
    ob.modifiers["Subdivision"].render_levels = render_level
    t.nodes.remove(t.nodes["Principled BSDF"])
    half = t.nodes.new("ShaderNodeVectorMath")
    half.operation = "MULTIPLY_ADD"
    half.inputs[1].default_value = half.inputs[2].default_value = (0.5, 0.5, 0.5)
    em = t.nodes.new("ShaderNodeEmission")
    t.links.new(nm.outputs["Normal"], half.inputs[0])
    t.links.new(half.outputs[0], em.inputs["Color"])
    t.links.new(em.outputs[0], t.nodes["Material Output"].inputs["Surface"])
    scene = bpy.context.scene
    look_at(scene, (2.5, -3.0, 1.5), ortho_scale=2.1)
    cycles(scene, 4, width=40)
    scene.cycles.max_bounces = 0
    scene.cycles.pixel_filter_type, scene.cycles.filter_width = "GAUSSIAN", 0.01
    ref = render_exr(tmp_path / "cycles.exr")
    tiny(scene, width=40, height=40, passes=4)
    ours = render_exr(tmp_path / "ours.exr")
    sphere = ref.max(-1) > 0.0
    assert sphere.sum() > 900                       # the sphere fills most of the frame
    d = np.abs(ours - ref).max(-1)[sphere]
    assert np.percentile(d, 99) <= 2e-3, (np.percentile(d, [50, 90, 99]), (d > 2e-3).mean())


def test_camera_space_follows_a_moved_view():
    """Texture Coordinate's Camera output and Vector Transform to and from camera space read
    the camera when the program runs: a render whose camera alone is replaced (the viewport's
    view orbiting: Renderer.reset with scene.replace(camera=...)) shades as a new export with
    that camera.  They were constants of the exported programs, stale until the next edit."""
    from ppm_engine.blender.export import export_scene
    from ppm_engine.render.renderer import Renderer
    from ppm_engine.scene.camera import CAMERA_DTYPE
    from tests.helpers.renders import every_feature
    from tests.helpers.shader_grid import case_grid

    def coords(i):
        return i.node("ShaderNodeTexCoord").outputs["Camera"]

    def normal_to_camera(i):
        return i.node("ShaderNodeVectorTransform", [(0, i.A)], convert_from="WORLD",
                      convert_to="CAMERA", vector_type="NORMAL").outputs[0]

    def point_from_camera(i):
        return i.node("ShaderNodeVectorTransform", [(0, i.A)], convert_from="CAMERA",
                      convert_to="WORLD", vector_type="POINT").outputs[0]
    scene, w, h = case_grid([coords, normal_to_camera, point_from_camera])
    scene.render.resolution_x, scene.render.resolution_y = w, h
    scene.render.resolution_percentage = 100
    depsgraph = bpy.context.evaluated_depsgraph_get()
    first = export_scene(depsgraph)
    moved = np.array(first.camera, CAMERA_DTYPE)
    a = 0.3                                   # turned about the view axis, and moved sideways
    turn = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    m = moved["to_world"][0].astype(np.float64)
    m[:, :3] = m[:, :3] @ turn
    m[:, 3] += (0.4, -0.2, 0.1)
    moved["to_world"][0] = m

    def image(r):
        for _ in range(2):
            r.iterate()
        return r.image()[..., :3].copy()

    opts = every_feature(passes=2, seed=3)
    r = Renderer(first, opts)
    before = image(r)
    r.reset(opts, first.replace(camera=moved))
    orbited = image(r)
    r.close()
    r = Renderer(export_scene(depsgraph, camera=moved), opts)
    fresh = image(r)
    r.close()
    np.testing.assert_allclose(orbited, fresh, atol=1e-5)
    assert np.abs(orbited - before).max() > 0.1
