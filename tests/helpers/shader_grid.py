"""The shader nodes' harness against Cycles, per pixel (test_shader_nodes.py and the tests of
inputs, textures, the Image Texture node and the sky): each case is a plane whose material
wires the node's output into an Emission shader; the node's inputs come from two float images of
random values read with Closest interpolation, one texel per pixel under an orthographic
camera.  A family of cases is a grid of planes rendered once by Cycles and once by this engine
(no bounces); every pixel agrees within 1e-3."""
import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

T = 8                     # texels (and pixels) per side of one case's plane
OFFSET = 8.0              # added to every output: emission stays positive


def random_image(name, seed, lo=0.0, hi=1.0):
    """A T x T Non-Color float image of random values in [lo, hi) (half-float exact)."""
    rng = np.random.default_rng(seed)
    v = (lo + (hi - lo) * rng.random((T, T, 4))).astype(np.float16).astype(np.float32)
    v[..., 3] = 1.0
    img = bpy.data.images.new(name, T, T, float_buffer=True, alpha=True)
    img.colorspace_settings.name = "Non-Color"
    img.pixels.foreach_set(v.ravel())
    return img


class Inputs:
    """Sockets of one material: colours A and B (images), floats x, y, z (B's channels), s
    (4x - 2: signed)."""

    def __init__(self, tree, images):
        self.t = tree
        ta, tb = (tree.nodes.new("ShaderNodeTexImage") for _ in range(2))
        for node, img in zip((ta, tb), images):
            node.image, node.interpolation = img, "Closest"
        sep = tree.nodes.new("ShaderNodeSeparateColor")
        tree.links.new(tb.outputs["Color"], sep.inputs[0])
        self.A, self.B = ta.outputs["Color"], tb.outputs["Color"]
        self.x, self.y, self.z = sep.outputs
        s = tree.nodes.new("ShaderNodeMath")
        s.operation = "MULTIPLY_ADD"
        tree.links.new(self.x, s.inputs[0])
        s.inputs[1].default_value, s.inputs[2].default_value = 4.0, -2.0
        self.s = s.outputs[0]

    def node(self, idname, links=(), **props):
        """A new node: props set, links (input index or name, socket) made."""
        n = self.t.nodes.new(idname)
        for k, v in props.items():
            if k.startswith("in_"):
                n.inputs[int(k[3:])].default_value = v
            else:
                setattr(n, k, v)
        for i, sock in links:
            target = n.inputs[i] if isinstance(i, int) else next(
                s for s in n.inputs if s.name == i and s.enabled)
            self.t.links.new(sock, target)
        return n


def emit(tree, out, offset=OFFSET):
    """out -> Emission -> the material output: a float v as (max(v, 0), max(-v, 0), OFFSET)
    (both signs, each positive), a colour or vector plus ``offset`` (every case's stays above
    -offset; 0 for a colour that is never negative: the comparison's tolerance then is the
    colour's own)."""
    em = tree.nodes.new("ShaderNodeEmission")
    if out.type == "VALUE":
        pos, neg, inv = (tree.nodes.new("ShaderNodeMath") for _ in range(3))
        pos.operation = neg.operation = "MAXIMUM"
        inv.operation = "MULTIPLY"
        tree.links.new(out, pos.inputs[0])
        tree.links.new(out, inv.inputs[0])
        inv.inputs[1].default_value = -1.0
        tree.links.new(inv.outputs[0], neg.inputs[0])
        pos.inputs[1].default_value = neg.inputs[1].default_value = 0.0
        comb = tree.nodes.new("ShaderNodeCombineXYZ")
        tree.links.new(pos.outputs[0], comb.inputs[0])
        tree.links.new(neg.outputs[0], comb.inputs[1])
        comb.inputs[2].default_value = OFFSET
        result = comb.outputs[0]
    else:
        add = tree.nodes.new("ShaderNodeVectorMath")
        add.operation = "ADD"
        tree.links.new(out, add.inputs[0])
        add.inputs[1].default_value = (offset,) * 3
        result = add.outputs[0]
    tree.links.new(result, em.inputs["Color"])
    tree.links.new(em.outputs[0], tree.nodes["Material Output"].inputs["Surface"])


def ortho_view(scene, width: float):
    """An orthographic camera looking down at the planes (``width`` across), a black world, one
    sample per pixel's box filter, no dither: each pixel sees one set of inputs."""
    cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
    cam.data.type, cam.data.ortho_scale = "ORTHO", width
    cam.location = (0.0, 0.0, 5.0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.world = bpy.data.worlds.new("W")
    scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0, 0, 0, 1)
    scene.render.dither_intensity = 0.0
    scene.cycles.pixel_filter_type, scene.cycles.filter_width = "BOX", 1.0
    scene.render.filter_size = 0.0


def case_grid(cases):
    """A scene of one plane per case (case(inputs) -> output socket), in rows of 8."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    images = (random_image("A", 1), random_image("B", 2))
    cols = min(len(cases), 8)
    rows = -(-len(cases) // cols)
    for k, case in enumerate(cases):
        r, c = divmod(k, cols)
        loc = (2 * c - cols + 1, rows - 1 - 2 * r, 0)
        setup = getattr(case, "mesh", None)      # a case may give its plane T x T faces
        if setup is None:
            bpy.ops.mesh.primitive_plane_add(size=2, location=loc)
        else:
            bpy.ops.mesh.primitive_grid_add(x_subdivisions=T, y_subdivisions=T, size=2,
                                            location=loc)
            setup(bpy.context.active_object.data)
        obj = bpy.context.active_object          # a case may turn or mirror its plane
        obj.rotation_euler = (getattr(case, "rx", 0.0), 0.0, getattr(case, "rz", 0.0))
        obj.scale.x = getattr(case, "sx", 1.0)
        obj.color = getattr(case, "ocolor", (1.0, 1.0, 1.0, 1.0))
        obj.pass_index = getattr(case, "pindex", 0)
        mat = bpy.data.materials.new(f"case{k}")
        t = mat.node_tree
        t.nodes.remove(t.nodes["Principled BSDF"])
        emit(t, case(Inputs(t, images)), getattr(case, "offset", OFFSET))
        bpy.context.active_object.data.materials.append(mat)
    ortho_view(scene, 2.0 * cols)
    return scene, cols * T, rows * T


def compare_cases(cases, render_direct, tmp_path, names):
    """The grid of ``cases`` rendered by Cycles and by this engine: every pixel of every case
    (named by ``names``) within 1e-3 (relative above 1)."""
    scene, w, h = case_grid(cases)
    ours, ref = render_direct(scene, tmp_path, w, h, 4, 2)
    err = np.abs(ours - ref)
    cols = w // T
    bad = []
    for k, name in enumerate(names):
        r, c = divmod(k, cols)
        e = err[r * T:(r + 1) * T, c * T:(c + 1) * T]
        if not (e.max() <= 1e-3 * max(1.0, float(np.abs(ref[r * T:(r + 1) * T,
                                                           c * T:(c + 1) * T]).max()))):
            bad.append((name, float(e.max())))
    assert not bad, f"cases differing from Cycles (max abs error): {bad}"
    # the inputs vary per pixel: a case that ignored them would be caught above
    assert np.ptp(ref[:T, :T]) > 1e-2
