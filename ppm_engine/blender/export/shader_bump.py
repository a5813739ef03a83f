"""The Bump node in a shader program, as Cycles compiles it (learnt from its SVM compiler's
refine_bump_nodes and BumpNode): the Height sub-graph is compiled three times, at the shading
point and with every position-dependent input moved by the filter width times one of the ray
footprint's two offsets (Compiler.bump, Compiler.geometry), and one SVM_BUMP op makes the
normal from the three heights (kernels/svm/svm_bump.h); fn(compiler, node, output socket, group
context) -> Val."""
from __future__ import annotations

from ppm_engine.blender.export.shader_values import ShadingNormal, Val
from ppm_engine.scene.shader_program import PROGRAM_BUMP, SVM_BUMP, f2i


def _normal_in(c, node, ctx):
    """The Bump's Normal input: None where it is unlinked or reads the shading normal (the
    kernel's default), else its value."""
    sock = node.inputs.get("Normal")
    if sock is None or c.constants_only or c.graph.source(sock, ctx) is None:
        return None
    v = c.input(node, sock, ctx, 3)
    return None if v.is_const and not any(v.const) else v


def _bump(c, node, out, ctx):
    """Cycles' Bump: a constant Height folds to the input normal (no program); Distance and
    Strength may be driven, Filter Width is the socket's value (Cycles' too: linked, warned),
    Invert negates the distance.  Distance is in world units, as Cycles' Bump node (its object
    space is only for displacement turned into bump, which this engine does not render)."""
    height = node.inputs["Height"]
    n_in = _normal_in(c, node, ctx)
    hc = c.input(node, height, ctx, 1)
    if hc.is_const:
        return n_in if n_in is not None else ShadingNormal()
    fw_sock = node.inputs.get("Filter Width")
    fw = 0.1 if fw_sock is None else float(fw_sock.default_value)
    if fw_sock is not None and c.graph.source(fw_sock, ctx) is not None:
        c.warn(f"'{node.name}': its Filter Width is linked; its unlinked value {fw:g} is "
               "used (as Cycles)")
    outer = c.bump
    heights = [hc]
    try:
        for k in (1, 2):
            c.bump = (k, fw)
            heights.append(c.input(node, height, ctx, 1))
    finally:
        c.bump = outer
    distance = c.inp(node, "Distance", ctx, 1)
    strength = c.inp(node, "Strength", ctx, 1)
    s_n = -1 if n_in is None else c.slot(n_in)
    s_h = [c.slot(h) for h in heights]
    s_d, s_s = c.slot(distance), c.slot(strength)
    o = c.alloc(3)
    c.flags |= PROGRAM_BUMP
    c.ops.append((SVM_BUMP, o, s_n, s_d))
    c.ops.append((s_h[0], s_h[1], s_h[2], s_s))
    c.ops.append((int(bool(node.invert)), f2i(fw), 0, 0))
    return Val(3, slot=o)


BUMP_NODES = {"ShaderNodeBump": _bump}
