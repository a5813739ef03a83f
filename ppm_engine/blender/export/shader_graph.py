"""A material's node graph -> a shader program (ppm_engine/scene/shader_program.py,
kernels/svm/svm.h).

``Graph`` resolves links as Cycles' compiler sees them: through reroutes, muted nodes (their
internal links), node groups (inlined: a group's Group Output leads into its tree, its Group
Input back out to the group node's inputs) and invalid or muted links, or links to or from an
unavailable socket (the input's own value).
``Compiler`` turns the value nodes feeding a BSDF input into ops: every output is compiled once
per group context (a shared sub-graph is evaluated once), unlinked inputs are constants, an op
whose inputs are all constant folds to a constant where the arithmetic is simple (Math,
conversions, the structural nodes), and a node the interpreter lacks is warned about once with
its output's default value.
"""
from __future__ import annotations

import numpy as np

from ppm_engine.blender.export.shader_bump import BUMP_NODES
from ppm_engine.blender.export.shader_images import IMAGE_NODES
from ppm_engine.blender.export.shader_inputs import INPUT_NODES
from ppm_engine.blender.export.shader_nodes import VALUE_NODES
from ppm_engine.blender.export.shader_spectra import SPECTRAL_NODES
from ppm_engine.blender.export.shader_textures import TEXTURE_NODES
from ppm_engine.blender.export.shader_values import ShadingNormal, Val, width
from ppm_engine.blender.export.sky import SKY_NODES
from ppm_engine.scene.shader_program import (
    BOUND,
    FIELD_WORD,
    GEOM_ATTRIBUTE,
    GEOM_ATTRIBUTE_ALPHA,
    GEOM_BACKFACING,
    GEOM_BUMP_OFFSET,
    GEOM_GENERATED,
    GEOM_NORMAL,
    GEOM_OBJECT,
    GEOM_OBJECT_ALPHA,
    GEOM_OBJECT_INDEX,
    GEOM_OBJECT_RANDOM,
    GEOM_POSITION,
    GEOM_UV,
    GEOM_WINDOW,
    MATH,
    MAX_ATTRIBUTES,
    MAX_STACK,
    PROGRAM_ATTRIBUTES,
    PROGRAM_EMISSION,
    PROGRAM_GENERATED,
    PROGRAM_OBJECT,
    PROGRAM_WINDOW,
    SVM_COMBINE,
    SVM_CONST,
    SVM_END,
    SVM_GEOMETRY,
    SVM_MATH,
    SVM_RGB_TO_BW,
    f2i,
    fold_math,
)

_MAX_DEPTH = 256
# Cycles' luminance weights for colour -> float (linear Rec. 709, Blender's default scene space)
LUMA = (0.2126729, 0.7151522, 0.0721750)


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
            if not link.is_valid or link.is_muted or not socket.enabled \
                    or not link.from_socket.enabled:      # (Cycles: unavailable sockets)
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
    world = False                         # a world's graph (export/world.py WorldCompiler)
    owner = "Material"                    # what its warnings name

    def __init__(self, material: str, warn, textures, graph: Graph, datablock=None,
                 attributes: list | None = None, camera=None):
        self.material = material
        self.camera = camera              # 4x4 camera-to-world, Cycles' camera space (+z ahead)
        self.attributes = attributes      # the scene's attribute names (their index: k)
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
        self.bump = None                  # (offset 1 or 2, filter width): a Bump node's
        #                                   Height compiled at that offset (export/shader_bump.py)

    def warn(self, text):
        if text not in self.said:
            self.said.add(text)
            self.warn_fn(f"{self.owner} '{self.material}': {text}")

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
        """``v`` on the stack (a constant is loaded once: programs have no branches, and no op
        writes a slot it did not allocate)."""
        if not v.is_const:
            return v.slot
        key = ("const", v.n, v.const)
        if key in self.memo:
            return self.memo[key]
        s = self.memo[key] = self.alloc(v.n)
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

    def stacked(self, n: int) -> Val:
        """``n`` new stack slots as a value (an op's output)."""
        return Val(n, slot=self.alloc(n))

    def geometry(self, what: int, n: int | None = None, moved: bool = False) -> Val:
        """A property of the shading point (shader_program GEOM_*); the position-dependent ones
        (and the normal where ``moved``: the Texture Coordinate's) at the Bump node's offset
        where its Height is being compiled (``self.bump``)."""
        n = n or (1 if what in (GEOM_BACKFACING, GEOM_OBJECT_ALPHA, GEOM_OBJECT_INDEX,
                                GEOM_OBJECT_RANDOM) else 3)
        if GEOM_OBJECT <= what <= GEOM_OBJECT_RANDOM:
            self.flags |= PROGRAM_OBJECT
        if what == GEOM_WINDOW:
            self.flags |= PROGRAM_WINDOW
        s = self.alloc(n)
        if self.bump is not None and (moved or what in (GEOM_UV, GEOM_GENERATED, GEOM_POSITION,
                                                        GEOM_OBJECT) or what >= GEOM_ATTRIBUTE):
            k, fw = self.bump
            self.ops.append((SVM_GEOMETRY, s, what + GEOM_BUMP_OFFSET * k, f2i(fw)))
        else:
            self.ops.append((SVM_GEOMETRY, s, what, 0))
        return Val(n, slot=s)

    def generated(self) -> Val:
        """The Generated texture coordinates (0..1 over the mesh's texture space)."""
        self.flags |= PROGRAM_GENERATED
        return self.geometry(GEOM_GENERATED)

    def attribute(self, name: str, alpha: bool = False) -> Val | None:
        """Mesh attribute ``name`` (its colour/vector, or its alpha) at the shading point; None
        when the scene reads too many attributes already (warned)."""
        names = self.attributes if self.attributes is not None else []
        if name not in names:
            if len(names) >= MAX_ATTRIBUTES:
                self.warn(f"more than {MAX_ATTRIBUTES} mesh attributes are read in the scene; "
                          f"'{name}' is not evaluated (0)")
                return None
            names.append(name)
        self.flags |= PROGRAM_ATTRIBUTES
        k = names.index(name)
        if alpha:
            return self.geometry(GEOM_ATTRIBUTE_ALPHA + k, 1)
        return self.geometry(GEOM_ATTRIBUTE + k)

    def texture_vector(self, node, ctx) -> Val:
        """A texture node's Vector input: what is linked to it, else the Generated
        coordinates (Cycles' default for procedural textures)."""
        sock = node.inputs.get("Vector")
        if sock is not None and self.graph.source(sock, ctx) is not None:
            return self.input(node, sock, ctx, 3)
        return self.generated()

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
        n = n or width(socket.type)
        src = None if self.constants_only else self.graph.source(socket, ctx)
        if src is None:
            return self._default(socket, n)
        from_node, out, fctx = src
        v = self.output(from_node, out, fctx)
        if isinstance(v, ShadingNormal) and not getattr(socket, "hide_value", False):
            v = self.geometry(GEOM_NORMAL)        # not a Normal input: the normal itself
        return self.convert(v, n, "vector" if out.type == "VECTOR" else "")

    def _default(self, socket, n) -> Val:
        dv = getattr(socket, "default_value", 0.0)
        try:
            v = tuple(dv)[:3]
        except TypeError:
            v = (float(dv),)
        return self.convert(self.const(v, len(v)), n)

    def node_key(self, kind, node, ctx) -> tuple:
        """The memo key of a node's compiled value: one per group context and Bump offset
        (constants are shared by every offset: loaded once, unaffected by it)."""
        return (kind, tuple(g.as_pointer() for g in ctx), node.as_pointer(), self.bump)

    def output(self, node, out, ctx) -> Val:
        """``out`` of ``node``, compiled once per group context and Bump offset."""
        key = self.node_key(("output", out.identifier), node, ctx)
        if key in self.memo:
            return self.memo[key]
        if key in self.visiting:
            self.warn(f"its node graph has a cycle through '{node.name}'; the cycle is cut there "
                      "(its output is 0)")
            return self.const(0.0, width(out.type))
        self.visiting.add(key)
        try:
            fn = NODES.get(node.bl_idname)
            if fn is None:
                self.warn(f"the node '{node.name}' ({node.bl_label}) is not evaluated by this "
                          "engine; its output's default value is used")
                v = self._default(out, width(out.type))
            else:
                try:
                    v = fn(self, node, out, ctx)
                except (KeyError, AttributeError, TypeError, ValueError, IndexError) as e:
                    # a node this reader does not know in this form (another Blender version)
                    self.warn(f"the node '{node.name}' ({node.bl_label}) could not be read "
                              f"({e}); its output's default value is used")
                    v = self._default(out, width(out.type))
            if v is None or out.type == "SHADER":
                v = self.const(0.0, width(out.type))
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


# every node type a program evaluates: bl_idname -> fn(compiler, node, output, ctx) -> Val
NODES = {**INPUT_NODES, **VALUE_NODES, **IMAGE_NODES, **TEXTURE_NODES, **SPECTRAL_NODES,
         **BUMP_NODES, **SKY_NODES}
