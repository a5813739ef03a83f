"""A material's node graph -> a shader program (ppm_engine/shader_program.py, kernels/svm.h).

``Graph`` resolves links as Cycles' compiler sees them: through reroutes, muted nodes (their
internal links), node groups (inlined: a group's Group Output leads into its tree, its Group
Input back out to the group node's inputs) and invalid or muted links (the input's own value).
``Compiler`` turns the value nodes feeding a BSDF input into ops: every output is compiled once
per group context (a shared sub-graph is evaluated once), unlinked inputs are constants, an op
whose inputs are all constant folds to a constant where the arithmetic is simple (Math,
conversions, the structural nodes), and a node the interpreter lacks is warned about once with
its output's default value.
"""
from __future__ import annotations

import numpy as np

from ..scene_arrays import BOUND
from ..shader_program import (COLOR_HSL_TO_RGB, COLOR_HSV_TO_RGB, COLOR_RGB_TO_HSL,
                              COLOR_RGB_TO_HSV, FIELD_WORD, GEOM_BACKFACING, GEOM_GENERATED,
                              GEOM_INCOMING, PROGRAM_GENERATED,
                              GEOM_NORMAL, GEOM_TRUE_NORMAL, GEOM_UV, MAP_RANGE_TYPES,
                              MAPPING_TYPES, MATH, MAX_STACK, MIX, MIXF_CLAMP_FACTOR,
                              NORMAL_MAP_SPACES, PROGRAM_TANGENTS, SVM_NORMAL_MAP,
                              MIXF_CLAMP_RESULT, MIXF_SCALAR, MIXF_VECTOR_FACTOR,
                              PROGRAM_EMISSION, SVM_BRIGHT_CONTRAST, SVM_CLAMP, SVM_COLOR_CONVERT,
                              SVM_COMBINE, SVM_CONST, SVM_END, SVM_FRESNEL, SVM_GAMMA,
                              SVM_GEOMETRY, SVM_HSV, SVM_IMAGE, SVM_INVERT, SVM_LAYER_WEIGHT,
                              SVM_MAP_RANGE, SVM_MAPPING, SVM_MATH, SVM_MIX, SVM_RGB_TO_BW,
                              SVM_TABLE, SVM_VECTOR_MATH, TABLE_RGB, TABLE_SCALAR, TABLE_SIZE,
                              TABLE_VECTOR, VMATH, f2i, fold_math)

_MAX_DEPTH = 256
# Cycles' luminance weights for colour -> float (linear Rec. 709, Blender's default scene space)
LUMA = (0.2126729, 0.7151522, 0.0721750)


class Val:
    """A value in the program: a constant (tuple of floats) or stack slots; n = 1 or 3."""
    __slots__ = ("const", "slot", "n")

    def __init__(self, n, const=None, slot=None):
        self.n, self.const, self.slot = n, const, slot

    @property
    def is_const(self):
        return self.const is not None

    def __repr__(self):
        return f"Val({self.n}, {self.const if self.is_const else 'slot %d' % self.slot})"


def _n(socket_type: str) -> int:
    return 3 if socket_type in ("RGBA", "VECTOR") else 1


class Graph:
    """Link resolution through reroutes, muted nodes and groups; ``ctx`` is the tuple of group
    nodes entered."""

    def __init__(self, warn):
        self.warn = warn

    def source(self, socket, ctx=()):
        """(node, output socket, ctx) feeding the input ``socket`` in ``ctx``, or None."""
        for _ in range(_MAX_DEPTH):
            if socket is None or not socket.is_linked:
                return None
            link = socket.links[0]
            if not link.is_valid or link.is_muted:
                return None
            node, out = link.from_node, link.from_socket
            kind = node.bl_idname
            if kind == "NodeReroute":
                socket = node.inputs[0]
            elif node.mute:
                socket = next((l.from_socket for l in node.internal_links
                               if l.to_socket == out), None)
            elif kind == "NodeGroupInput":
                if not ctx:
                    return None
                group = ctx[-1]
                socket = next((s for s in group.inputs if s.identifier == out.identifier), None)
                ctx = ctx[:-1]
            elif kind == "ShaderNodeGroup":
                tree = node.node_tree
                gout = None if tree is None else next(
                    (n for n in tree.nodes if n.bl_idname == "NodeGroupOutput"
                     and n.is_active_output), None) or next(
                    (n for n in tree.nodes if n.bl_idname == "NodeGroupOutput"), None)
                if gout is None or len(ctx) > 32:
                    return None
                socket = next((s for s in gout.inputs if s.identifier == out.identifier), None)
                ctx = ctx + (node,)
            else:
                return node, out, ctx
        return None


class Compiler:
    """Compiles one material's value nodes; ``binds`` and ``ops`` become its program."""

    def __init__(self, material: str, warn, textures, graph: Graph, datablock=None):
        self.material = material
        self.datablock = datablock        # the bpy material (which meshes use it: UV names)
        self.warn_fn = warn
        self.textures = textures
        self.graph = graph
        self.ops: list[tuple] = []
        self.binds: list[tuple] = []
        self.flags = 0
        self.top = 0
        self.memo: dict = {}
        self.visiting: set = set()
        self.said: set = set()
        self.overflow = False
        self.constants_only = False       # every linked input read as its unlinked value

    def warn(self, text):
        if text not in self.said:
            self.said.add(text)
            self.warn_fn(f"Material '{self.material}': {text}")

    # --- values -----------------------------------------------------------------------------
    def alloc(self, n: int) -> int:
        s = self.top
        self.top += n
        if self.top > MAX_STACK:
            self.overflow = True
        return s

    def const(self, v, n) -> Val:
        v = tuple(float(x) for x in (v if isinstance(v, tuple) else (v,)))
        return Val(n, const=v[:n] if len(v) >= n else v * n)

    def slot(self, v: Val) -> int:
        """``v`` on the stack (a constant is loaded once per use)."""
        if not v.is_const:
            return v.slot
        s = self.alloc(v.n)
        c = list(v.const) + [0.0] * (4 - v.n)
        self.ops.append((SVM_CONST, s, v.n, 0))
        self.ops.append(tuple(f2i(x) for x in c[:4]))
        return s

    def convert(self, v: Val, n: int, to_type: str = "") -> Val:
        """Implicit socket conversion as Cycles': colour -> float by luminance, vector ->
        float by average, float -> colour/vector by copies."""
        if v.n == n:
            return v
        if n == 3:
            if v.is_const:
                return Val(3, const=v.const * 3)
            return self.combine(v, v, v)
        weights = (1 / 3, 1 / 3, 1 / 3) if to_type == "vector" else LUMA
        if v.is_const:
            return Val(1, const=(sum(w * x for w, x in zip(weights, v.const)),))
        if to_type == "vector":
            t = self.math("ADD", Val(1, slot=v.slot), Val(1, slot=v.slot + 1))
            t = self.math("ADD", t, Val(1, slot=v.slot + 2))
            return self.math("MULTIPLY", t, self.const(1.0 / 3.0, 1))
        s = self.alloc(1)
        self.ops.append((SVM_RGB_TO_BW, s, v.slot, 0))
        return Val(1, slot=s)

    def combine(self, x: Val, y: Val, z: Val) -> Val:
        if x.is_const and y.is_const and z.is_const:
            return Val(3, const=(x.const[0], y.const[0], z.const[0]))
        a, b, c = self.slot(x), self.slot(y), self.slot(z)
        out = self.alloc(3)
        self.ops.append((SVM_COMBINE, out, a, b))
        self.ops.append((c, 0, 0, 0))
        return Val(3, slot=out)

    def component(self, v: Val, k: int) -> Val:
        return Val(1, const=(v.const[k],)) if v.is_const else Val(1, slot=v.slot + k)

    def math(self, op: str, a: Val, b: Val, c: Val | None = None, clamp=False) -> Val:
        c = c or Val(1, const=(0.0,))
        if a.is_const and b.is_const and c.is_const:
            return Val(1, const=(fold_math(op, a.const[0], b.const[0], c.const[0], clamp),))
        sa, sb, sc = self.slot(a), self.slot(b), self.slot(c)
        out = self.alloc(1)
        self.ops.append((SVM_MATH, out, sa, sb))
        self.ops.append((sc, MATH[op], int(bool(clamp)), 0))
        return Val(1, slot=out)

    def scale(self, v: Val, s: Val) -> Val:
        """A colour times a float."""
        if s.is_const and s.const[0] == 1.0:
            return v
        if v.is_const and s.is_const:
            return Val(3, const=tuple(x * s.const[0] for x in v.const))
        return self.combine(*(self.math("MULTIPLY", self.component(v, k), s) for k in range(3)))

    # --- sockets ------------------------------------------------------------------------------
    def input(self, node, socket, ctx, n: int | None = None) -> Val:
        """The value of input ``socket`` of ``node`` (in group context ``ctx``) as n floats."""
        n = n or _n(socket.type)
        src = None if self.constants_only else self.graph.source(socket, ctx)
        if src is None:
            return self._default(socket, n)
        from_node, out, fctx = src
        v = self.output(from_node, out, fctx)
        return self.convert(v, n, "vector" if out.type == "VECTOR" else "")

    def _default(self, socket, n) -> Val:
        dv = getattr(socket, "default_value", 0.0)
        try:
            v = tuple(dv)[:3]
        except TypeError:
            v = (float(dv),)
        return self.convert(self.const(v, len(v)), n)

    def output(self, node, out, ctx) -> Val:
        key = (tuple(g.as_pointer() for g in ctx), node.as_pointer(), out.identifier)
        if key in self.memo:
            return self.memo[key]
        if key in self.visiting:
            self.warn(f"its node graph has a cycle through '{node.name}'; the cycle is cut there "
                      "(its output is 0)")
            return self.const(0.0, _n(out.type))
        self.visiting.add(key)
        try:
            fn = NODES.get(node.bl_idname)
            if fn is None:
                self.warn(f"the node '{node.name}' ({node.bl_label}) is not evaluated by this "
                          "engine; its output's default value is used")
                v = self._default(out, _n(out.type))
            else:
                try:
                    v = fn(self, node, out, ctx)
                except (KeyError, AttributeError, TypeError, ValueError, IndexError) as e:
                    # a node this reader does not know in this form (another Blender version)
                    self.warn(f"the node '{node.name}' ({node.bl_label}) could not be read "
                              f"({e}); its output's default value is used")
                    v = self._default(out, _n(out.type))
            if v is None or out.type == "SHADER":
                v = self.const(0.0, _n(out.type))
        finally:
            self.visiting.discard(key)
        self.memo[key] = v
        return v

    def inp(self, node, name_or_index, ctx, n=None) -> Val:
        """An enabled input by index or by name (the first enabled one; "A|B": either name,
        for sockets Blender versions name differently)."""
        if isinstance(name_or_index, int):
            sock = node.inputs[name_or_index]
        else:
            names = name_or_index.split("|")
            sock = next((s for s in node.inputs if s.name in names and s.enabled), None) \
                or next((s for s in node.inputs if s.name in names), None)
            if sock is None:
                raise KeyError(f"'{node.name}' has no input {name_or_index}")
        return self.input(node, sock, ctx, n)

    # --- binding BSDF inputs ----------------------------------------------------------------
    def bind(self, row, node_index: int, field: str, v: Val) -> None:
        """A BSDF node's field from ``v``: a constant goes into the row, anything else is bound
        to its stack slots (the row keeps its constant for nothing but the export's bounds)."""
        n = 3 if row.dtype[field].shape else 1
        v = self.convert(v, n)
        if v.is_const:
            row[field] = v.const if n == 3 else v.const[0]
            return
        self.binds.append((node_index, FIELD_WORD[field], n, v.slot))
        row["bound"] |= BOUND[field]
        if field in ("emission", "weight"):
            self.flags |= PROGRAM_EMISSION

    def program(self) -> np.ndarray | None:
        """The int4 words of the program (None: no input is driven by the graph)."""
        if not self.binds:
            return None
        if self.overflow:
            return None
        words = [(len(self.binds), 0, self.top, self.flags)] + list(self.binds) \
            + list(self.ops) + [(SVM_END, 0, 0, 0)]
        words[0] = (len(self.binds), len(words), self.top, self.flags)
        return np.array(words, np.int32)


# --- nodes --------------------------------------------------------------------------------------
def _value(c: Compiler, node, out, ctx):
    return c.const(float(out.default_value), 1)


def _rgb(c: Compiler, node, out, ctx):
    return c.const(tuple(out.default_value)[:3], 3)


def _geometry(what):
    def f(c: Compiler, node, out, ctx):
        s = c.alloc(3)
        c.ops.append((SVM_GEOMETRY, s, what, 0))
        return Val(3, slot=s) if what != GEOM_BACKFACING else Val(1, slot=s)
    return f


def generated(c: Compiler) -> Val:
    """The Generated texture coordinates (0..1 over the mesh's texture space)."""
    c.flags |= PROGRAM_GENERATED
    return _geometry(GEOM_GENERATED)(c, None, None, ())


def texture_vector(c: Compiler, node, ctx) -> Val:
    """A texture node's Vector input: what is linked to it, else the Generated coordinates
    (Cycles' default for procedural textures)."""
    sock = node.inputs.get("Vector")
    if sock is not None and c.graph.source(sock, ctx) is not None:
        return c.input(node, sock, ctx, 3)
    return generated(c)


def _tex_coord(c: Compiler, node, out, ctx):
    if out.name == "Generated":
        return generated(c)
    what = {"UV": GEOM_UV, "Normal": GEOM_NORMAL}.get(out.name)
    if out.name == "Normal":
        c.warn(f"'{node.name}': the Normal coordinate is in world space here (Cycles: object "
               "space)")
    if what is None:
        c.warn(f"'{node.name}': the {out.name} texture coordinate is not evaluated yet; the UV "
               "map is used")
        what = GEOM_UV
    return _geometry(what)(c, node, out, ctx)


def _named_uv_map(c: Compiler, node, name: str) -> None:
    """Warns when a node names a UV map other than the one exported (the mesh's active map)
    on a mesh that uses the material and has both."""
    if not name or c.datablock is None:
        return
    key = ("uv name", name)
    if key in c.memo:
        return
    c.memo[key] = True
    import bpy
    for me in bpy.data.meshes:
        active = me.uv_layers.active
        if (active is not None and active.name != name and name in me.uv_layers
                and c.datablock.name in me.materials):
            c.warn(f"'{node.name}' names the UV map '{name}' of mesh '{me.name}'; this engine "
                   f"reads its active UV map '{active.name}'")
            return


def _uv_map(c: Compiler, node, out, ctx):
    _named_uv_map(c, node, getattr(node, "uv_map", ""))
    return _geometry(GEOM_UV)(c, node, out, ctx)


def _normal_map(c: Compiler, node, out, ctx):
    """Cycles' Normal Map: a colour to a shading normal (kernels/svm.h svm_normal_map); the
    tangent space's frame from the UV map's MikkTSpace tangents (SceneArrays.uv_tangents)."""
    space = NORMAL_MAP_SPACES.get(node.space, 0)
    if node.space in ("OBJECT", "BLENDER_OBJECT"):
        c.warn(f"'{node.name}' maps normals in object space; this engine takes them as world "
               "space (exact for objects that are not rotated)")
    if space == 0:
        _named_uv_map(c, node, getattr(node, "uv_map", ""))
        c.flags |= PROGRAM_TANGENTS
    col, strength = c.inp(node, "Color", ctx, 3), c.inp(node, "Strength", ctx, 1)
    sc, ss = c.slot(col), c.slot(strength)
    o = c.alloc(3)
    c.ops.append((SVM_NORMAL_MAP, o, sc, ss))
    c.ops.append((space, 0, 0, 0))
    return Val(3, slot=o)


def _geometry_node(c: Compiler, node, out, ctx):
    what = {"Normal": GEOM_NORMAL, "True Normal": GEOM_TRUE_NORMAL, "Incoming": GEOM_INCOMING,
            "Backfacing": GEOM_BACKFACING}.get(out.name)
    if what is None:
        c.warn(f"'{node.name}': the Geometry output {out.name} is not evaluated yet (0)")
        return c.const(0.0, _n(out.type))
    return _geometry(what)(c, node, out, ctx)


def _image(c: Compiler, node, out, ctx):
    if c.textures is None:
        return c.const(1.0, _n(out.type))
    tex, missing = c.textures.image_index(node, c.material)
    if not tex:
        return c.const(missing if out.name == "Color" else (1.0,), _n(out.type))
    if getattr(node, "projection", "FLAT") != "FLAT":
        c.warn(f"'{node.name}' uses {node.projection.title()} projection; this engine projects "
               "Flat")
    vec = node.inputs.get("Vector")
    v = c.input(node, vec, ctx, 3) if vec.is_linked else _geometry(GEOM_UV)(c, node, out, ctx)
    key = ("image", tuple(g.as_pointer() for g in ctx), node.as_pointer())
    if key not in c.memo:
        sv = c.slot(v)
        col, alpha = c.alloc(3), c.alloc(1)
        c.ops.append((SVM_IMAGE, col, alpha, sv))
        c.ops.append((tex, int(c.textures.premultiplied(node, tex)), 0, 0))
        c.memo[key] = (col, alpha)
    col, alpha = c.memo[key]
    return Val(3, slot=col) if out.name == "Color" else Val(1, slot=alpha)


def _mapping(c: Compiler, node, out, ctx):
    from mathutils import Euler, Matrix, Vector
    vec = c.inp(node, "Vector", ctx, 3)
    parts = {}
    for name in ("Location", "Rotation", "Scale"):
        sock = node.inputs.get(name)
        if sock is None or not sock.enabled:
            parts[name] = (0.0, 0.0, 0.0) if name != "Scale" else (1.0, 1.0, 1.0)
            continue
        v = c.input(node, sock, ctx, 3)
        if not v.is_const:
            c.warn(f"the {name} of '{node.name}' is driven by a node link this engine does not "
                   "evaluate; its unlinked value is used")
            v = c._default(sock, 3)
        parts[name] = v.const
    t = MAPPING_TYPES.get(node.vector_type, 0)
    rot = Euler(parts["Rotation"], "XYZ").to_matrix()
    s = parts["Scale"]
    loc = parts["Location"]
    if t == 1:                                  # texture: the inverse of point
        safe = [1.0 / x if x != 0.0 else 0.0 for x in s]
        m3 = Matrix.Diagonal(safe) @ rot.transposed()
        trans = -(m3 @ Vector(loc))
    elif t == 3:                                # normal: rotation over scale, normalised
        safe = [1.0 / x if x != 0.0 else 0.0 for x in s]
        m3 = rot @ Matrix.Diagonal(safe)
        trans = (0.0, 0.0, 0.0)
    else:
        m3 = rot @ Matrix.Diagonal(s)
        trans = loc if t == 0 else (0.0, 0.0, 0.0)
    sv = c.slot(vec)
    o = c.alloc(3)
    c.ops.append((SVM_MAPPING, o, sv, t))
    for r in range(3):
        c.ops.append(tuple(f2i(x) for x in (m3[r][0], m3[r][1], m3[r][2], trans[r])))
    return Val(3, slot=o)


def _math(c: Compiler, node, out, ctx):
    vals = [c.input(node, s, ctx, 1) for s in node.inputs[:3]]
    if node.operation not in MATH:
        c.warn(f"'{node.name}': the math operation {node.operation} is not evaluated; 0 is used")
        return c.const(0.0, 1)
    return c.math(node.operation, vals[0], vals[1], vals[2], node.use_clamp)


def _vector_math(c: Compiler, node, out, ctx):
    if node.operation not in VMATH:
        c.warn(f"'{node.name}': the vector math operation {node.operation} is not evaluated; 0 "
               "is used")
        return c.const(0.0, _n(out.type))
    a, b, cc = (c.input(node, node.inputs[i], ctx, 3) for i in range(3))
    scale = c.input(node, node.inputs[3], ctx, 1)
    sa, sb, sc, ss = c.slot(a), c.slot(b), c.slot(cc), c.slot(scale)
    vo, fo = c.alloc(3), c.alloc(1)
    c.ops.append((SVM_VECTOR_MATH, vo, sa, sb))
    c.ops.append((sc, VMATH[node.operation], fo, ss))
    return Val(3, slot=vo) if out.type == "VECTOR" else Val(1, slot=fo)


def _mix(c: Compiler, node, out, ctx):
    """The Mix node (float, vector, colour) and the legacy MixRGB."""
    legacy = node.bl_idname == "ShaderNodeMixRGB"
    dtype = "RGBA" if legacy else node.data_type
    if dtype not in ("FLOAT", "VECTOR", "RGBA"):
        c.warn(f"'{node.name}' mixes {dtype.lower()} values, which this engine does not "
               "evaluate; A is used")
        dtype = "RGBA"
    n = 1 if dtype == "FLOAT" else 3
    if legacy:
        fac, a, b = (c.input(node, node.inputs[i], ctx, k) for i, k in ((0, 1), (1, 3), (2, 3)))
        blend, flags = node.blend_type, MIXF_CLAMP_FACTOR | (
            MIXF_CLAMP_RESULT if node.use_clamp else 0)
    else:
        en = [s for s in node.inputs if s.enabled]
        fsock = next(s for s in en if s.name == "Factor")
        fac = c.input(node, fsock, ctx, 3 if fsock.type == "VECTOR" else 1)
        a = c.input(node, next(s for s in en if s.name == "A"), ctx, n)
        b = c.input(node, next(s for s in en if s.name == "B"), ctx, n)
        blend = node.blend_type if dtype == "RGBA" else "MIX"
        flags = (MIXF_CLAMP_FACTOR if node.clamp_factor else 0) | (
            MIXF_CLAMP_RESULT if dtype == "RGBA" and node.clamp_result else 0)
        if fac.n == 3:
            flags |= MIXF_VECTOR_FACTOR
    if n == 1:
        flags |= MIXF_SCALAR
    if fac.is_const and blend == "MIX" and not flags & MIXF_VECTOR_FACTOR:
        t = fac.const[0]
        if flags & MIXF_CLAMP_FACTOR:
            t = min(max(t, 0.0), 1.0)
        if t == 0.0 and not flags & MIXF_CLAMP_RESULT:
            return a
        if t == 1.0 and not flags & MIXF_CLAMP_RESULT:
            return b
    sf, sa, sb = c.slot(fac), c.slot(a), c.slot(b)
    o = c.alloc(n)
    c.ops.append((SVM_MIX, o, sa, sb))
    c.ops.append((sf, MIX[blend], flags, 0))
    return Val(n, slot=o)


def _separate_xyz(c: Compiler, node, out, ctx):
    v = c.inp(node, 0, ctx, 3)
    return c.component(v, "XYZ".index(out.name))


def _combine_xyz(c: Compiler, node, out, ctx):
    return c.combine(*(c.input(node, node.inputs[k], ctx, 1) for k in range(3)))


_COLOR_MODES = {"HSV": (COLOR_RGB_TO_HSV, COLOR_HSV_TO_RGB),
                "HSL": (COLOR_RGB_TO_HSL, COLOR_HSL_TO_RGB)}


def _separate_color(c: Compiler, node, out, ctx):
    v = c.inp(node, 0, ctx, 3)
    mode = getattr(node, "mode", "RGB")
    if mode in _COLOR_MODES:
        key = ("sepcol", tuple(g.as_pointer() for g in ctx), node.as_pointer())
        if key not in c.memo:
            s, o = c.slot(v), c.alloc(3)
            c.ops.append((SVM_COLOR_CONVERT, o, s, _COLOR_MODES[mode][0]))
            c.memo[key] = Val(3, slot=o)
        v = c.memo[key]
    k = [s.identifier for s in node.outputs].index(out.identifier)
    return c.component(v, min(k, 2))


def _combine_color(c: Compiler, node, out, ctx):
    v = c.combine(*(c.input(node, node.inputs[k], ctx, 1) for k in range(3)))
    mode = getattr(node, "mode", "RGB")
    if mode in _COLOR_MODES:
        s, o = c.slot(v), c.alloc(3)
        c.ops.append((SVM_COLOR_CONVERT, o, s, _COLOR_MODES[mode][1]))
        return Val(3, slot=o)
    return v


def _unary(op, n_out=3):
    def f(c: Compiler, node, out, ctx):
        if op == SVM_INVERT:
            a, b = c.inp(node, "Factor|Fac", ctx, 1), c.inp(node, "Color", ctx, 3)
        elif op == SVM_GAMMA:
            a, b = c.inp(node, "Color", ctx, 3), c.inp(node, "Gamma", ctx, 1)
        elif op == SVM_RGB_TO_BW:
            return c.convert(c.inp(node, "Color", ctx, 3), 1)
        elif op == SVM_FRESNEL:
            a, b = c.inp(node, "IOR", ctx, 1), c.const(0.0, 1)
        sa, sb = c.slot(a), c.slot(b)
        o = c.alloc(n_out)
        c.ops.append((op, o, sa, sb) if op != SVM_FRESNEL else (op, o, sa, 0))
        return Val(n_out, slot=o)
    return f


def _bright_contrast(c: Compiler, node, out, ctx):
    col, br, co = (c.inp(node, k, ctx, n) for k, n in (("Color", 3), ("Brightness|Bright", 1),
                                                        ("Contrast", 1)))
    s = (c.slot(col), c.slot(br), c.slot(co))
    o = c.alloc(3)
    c.ops.append((SVM_BRIGHT_CONTRAST, o, s[0], s[1]))
    c.ops.append((s[2], 0, 0, 0))
    return Val(3, slot=o)


def _hsv(c: Compiler, node, out, ctx):
    h, s, v, fac = (c.inp(node, k, ctx, 1) for k in ("Hue", "Saturation", "Value", "Factor|Fac"))
    col = c.inp(node, "Color", ctx, 3)
    sl = [c.slot(x) for x in (col, fac, h, s, v)]
    o = c.alloc(3)
    c.ops.append((SVM_HSV, o, sl[0], sl[1]))
    c.ops.append((sl[2], sl[3], sl[4], 0))
    return Val(3, slot=o)


def _clamp(c: Compiler, node, out, ctx):
    v, lo, hi = (c.inp(node, k, ctx, 1) for k in ("Value", "Min", "Max"))
    t = 1 if node.clamp_type == "RANGE" else 0
    if v.is_const and lo.is_const and hi.is_const:
        a, b = lo.const[0], hi.const[0]
        if t == 1 and a > b:
            a, b = b, a
        return c.const(min(max(v.const[0], a), b), 1)
    s = (c.slot(v), c.slot(lo), c.slot(hi))
    o = c.alloc(1)
    c.ops.append((SVM_CLAMP, o, s[0], s[1]))
    c.ops.append((s[2], t, 0, 0))
    return Val(1, slot=o)


def _map_range(c: Compiler, node, out, ctx):
    if node.data_type != "FLOAT":
        c.warn(f"'{node.name}' maps vectors, which this engine does not evaluate yet; its "
               "input is passed through")
        return c.convert(c.inp(node, "Vector", ctx, 3), _n(out.type))
    names = ("Value", "From Min", "From Max", "To Min", "To Max", "Steps")
    vals = [c.inp(node, k, ctx, 1) for k in names]
    s = [c.slot(x) for x in vals]
    o = c.alloc(1)
    c.ops.append((SVM_MAP_RANGE, o, s[0], s[1]))
    c.ops.append((s[2], s[3], s[4], s[5]))
    c.ops.append((MAP_RANGE_TYPES.get(node.interpolation_type, 0), int(node.clamp), 0, 0))
    return Val(1, slot=o)


def _table(c: Compiler, node, out, ctx):
    """Color Ramp and the curves, baked into TABLE_SIZE entries by Blender's own evaluation
    (as Cycles bakes them)."""
    xs = np.linspace(0.0, 1.0, TABLE_SIZE)
    kind = node.bl_idname
    if kind == "ShaderNodeValToRGB":
        ramp = node.color_ramp
        table = np.array([tuple(ramp.evaluate(float(x))) for x in xs], np.float32)
        x = c.inp(node, "Factor|Fac", ctx, 1)
        mode, lo, hi = TABLE_SCALAR, 0.0, 1.0
        interp = 0 if ramp.interpolation == "CONSTANT" else 1
        n_out = 3 if out.name == "Color" else 1
        if out.name == "Alpha":
            table = np.repeat(table[:, 3:4], 4, axis=1)
        fac = None
    else:
        mp = node.mapping
        mp.update()
        lo, hi = mp.clip_min_x, mp.clip_max_x
        if kind == "ShaderNodeFloatCurve":
            xs = np.linspace(lo, hi, TABLE_SIZE)
            table = np.array([(mp.evaluate(mp.curves[0], float(t)),) * 4 for t in xs], np.float32)
            x, mode, n_out = c.inp(node, "Value", ctx, 1), TABLE_SCALAR, 1
        else:
            xs = np.linspace(lo, hi, TABLE_SIZE)
            rgb = kind == "ShaderNodeRGBCurve"
            cols = []
            for k in range(3):
                curve = mp.curves[k]
                if rgb:   # the combined curve (index 3) applies before each channel's
                    cols.append([mp.evaluate(curve, mp.evaluate(mp.curves[3], float(t)))
                                 for t in xs])
                else:
                    cols.append([mp.evaluate(curve, float(t)) for t in xs])
            table = np.stack(cols + [np.ones(TABLE_SIZE)], axis=1).astype(np.float32)
            x = c.inp(node, "Color" if rgb else "Vector", ctx, 3)
            mode, n_out = TABLE_RGB if rgb else TABLE_VECTOR, 3
        interp = 1
        fac = c.inp(node, "Factor|Fac", ctx, 1)
    sx = c.slot(x)
    sf = c.slot(fac) if fac is not None else c.slot(c.const(1.0, 1))
    o = c.alloc(3)
    c.ops.append((SVM_TABLE, o, sx, TABLE_SIZE))
    c.ops.append((mode, interp, f2i(lo), f2i(hi)))
    c.ops.append((sf, 0, 0, 0))
    for row in table:
        c.ops.append(tuple(f2i(v) for v in row))
    return Val(n_out, slot=o) if n_out == 3 else Val(1, slot=o)


def _layer_weight(c: Compiler, node, out, ctx):
    blend = c.inp(node, "Blend", ctx, 1)
    key = ("layer", tuple(g.as_pointer() for g in ctx), node.as_pointer())
    if key not in c.memo:
        s, o = c.slot(blend), c.alloc(2)
        c.ops.append((SVM_LAYER_WEIGHT, o, s, o + 1))
        c.memo[key] = o
    o = c.memo[key]
    return Val(1, slot=o if out.name == "Fresnel" else o + 1)


NODES = {
    "ShaderNodeValue": _value, "ShaderNodeRGB": _rgb,
    "ShaderNodeTexCoord": _tex_coord, "ShaderNodeUVMap": _uv_map,
    "ShaderNodeNewGeometry": _geometry_node,
    "ShaderNodeTexImage": _image, "ShaderNodeMapping": _mapping,
    "ShaderNodeMath": _math, "ShaderNodeVectorMath": _vector_math,
    "ShaderNodeMix": _mix, "ShaderNodeMixRGB": _mix,
    "ShaderNodeSeparateXYZ": _separate_xyz, "ShaderNodeCombineXYZ": _combine_xyz,
    "ShaderNodeSeparateColor": _separate_color, "ShaderNodeCombineColor": _combine_color,
    "ShaderNodeInvert": _unary(SVM_INVERT), "ShaderNodeGamma": _unary(SVM_GAMMA),
    "ShaderNodeRGBToBW": _unary(SVM_RGB_TO_BW, 1), "ShaderNodeFresnel": _unary(SVM_FRESNEL, 1),
    "ShaderNodeBrightContrast": _bright_contrast, "ShaderNodeHueSaturation": _hsv,
    "ShaderNodeClamp": _clamp, "ShaderNodeMapRange": _map_range,
    "ShaderNodeValToRGB": _table, "ShaderNodeRGBCurve": _table,
    "ShaderNodeVectorCurve": _table, "ShaderNodeFloatCurve": _table,
    "ShaderNodeLayerWeight": _layer_weight, "ShaderNodeNormalMap": _normal_map,
}
