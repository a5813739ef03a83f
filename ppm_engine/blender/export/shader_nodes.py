"""The value nodes of a shader program, each compiled as Cycles evaluates it (kernels/svm/svm.h and
svm_nodes.h run them): Mapping, Math, Vector Math, Mix, the colour and converter nodes, ramps
and curves, Fresnel, Layer Weight (the input nodes: shader_inputs.py; the image nodes:
shader_images.py).  Each is fn(compiler, node, output socket, group context) -> Val, using
the compiler's methods only (shader_graph.Compiler), so this module does not import the
compiler."""
from __future__ import annotations

import numpy as np

from ppm_engine.blender.export.shader_values import Val, width
from ppm_engine.scene.shader_program import (
    CLAMP_TYPES,
    COLOR_HSL_TO_RGB,
    COLOR_HSV_TO_RGB,
    COLOR_RGB_TO_HSL,
    COLOR_RGB_TO_HSV,
    MAP_RANGE_TYPES,
    MAPPING_TYPES,
    MATH,
    MIX,
    MIXF_CLAMP_FACTOR,
    MIXF_CLAMP_RESULT,
    MIXF_SCALAR,
    MIXF_VECTOR_FACTOR,
    SVM_BRIGHT_CONTRAST,
    SVM_CLAMP,
    SVM_COLOR_CONVERT,
    SVM_FRESNEL,
    SVM_GAMMA,
    SVM_HSV,
    SVM_INVERT,
    SVM_LAYER_WEIGHT,
    SVM_MAP_RANGE,
    SVM_MAPPING,
    SVM_MIX,
    SVM_RGB_TO_BW,
    SVM_TABLE,
    SVM_VECTOR_MATH,
    TABLE_RGB,
    TABLE_SCALAR,
    TABLE_SIZE,
    TABLE_VECTOR,
    VMATH,
    f2i,
)


def _rotate(c, v: Val, angles: Val, inverse: bool) -> Val:
    """``v`` rotated by the XYZ Euler ``angles`` (Cycles' euler_to_transform: x, then y, then z),
    or by its inverse (z, y, x with the angles negated), in Math ops."""
    axes = (2, 1, 0) if inverse else (0, 1, 2)
    comps = [c.component(v, k) for k in range(3)]
    for axis in axes:
        a = c.component(angles, axis)
        if inverse:
            a = c.math("MULTIPLY", a, c.const(-1.0, 1))
        cos, sin = c.math("COSINE", a, a), c.math("SINE", a, a)
        i, j = [k for k in range(3) if k != axis]
        if axis == 1:                       # about y: z, x (right-handed order)
            i, j = j, i
        ci, cj = comps[i], comps[j]
        comps[i] = c.math("SUBTRACT", c.math("MULTIPLY", ci, cos), c.math("MULTIPLY", cj, sin))
        comps[j] = c.math("ADD", c.math("MULTIPLY", ci, sin), c.math("MULTIPLY", cj, cos))
    return c.combine(*comps)


def _vmath(c, op: str, a: Val, b: Val) -> Val:
    sa, sb, sz = c.slot(a), c.slot(b), c.slot(c.const(0.0, 3))
    vo, fo = c.alloc(3), c.alloc(1)
    c.ops.append((SVM_VECTOR_MATH, vo, sa, sb))
    c.ops.append((sz, VMATH[op], fo, c.slot(c.const(1.0, 1))))
    return Val(3, slot=vo)


def _mapping_driven(c, t: int, vec: Val, loc: Val, rot: Val, scale: Val) -> Val:
    """Mapping with linked Location, Rotation or Scale, in ops (Cycles' svm_mapping)."""
    if t == 1:                                  # texture: the inverse of point
        v = _rotate(c, _vmath(c, "SUBTRACT", vec, loc), rot, True)
        return _vmath(c, "DIVIDE", v, scale)
    if t == 3:                                  # normal
        v = _rotate(c, _vmath(c, "DIVIDE", vec, scale), rot, False)
        return _vmath(c, "NORMALIZE", v, v)
    v = _rotate(c, _vmath(c, "MULTIPLY", vec, scale), rot, False)
    return _vmath(c, "ADD", v, loc) if t == 0 else v


def _mapping(c, node, out, ctx):
    from mathutils import Euler, Matrix, Vector
    vec = c.inp(node, "Vector", ctx, 3)
    t = MAPPING_TYPES.get(node.vector_type, 0)
    parts, vals = {}, {}
    for name in ("Location", "Rotation", "Scale"):
        sock = node.inputs.get(name)
        if sock is None or not sock.enabled:
            parts[name] = (0.0, 0.0, 0.0) if name != "Scale" else (1.0, 1.0, 1.0)
            vals[name] = c.const(parts[name], 3)
            continue
        vals[name] = c.input(node, sock, ctx, 3)
        parts[name] = vals[name].const
    if any(p is None for p in parts.values()):
        return _mapping_driven(c, t, vec, vals["Location"], vals["Rotation"], vals["Scale"])
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


def _math(c, node, out, ctx):
    vals = [c.input(node, s, ctx, 1) for s in node.inputs[:3]]
    if node.operation not in MATH:
        c.warn(f"'{node.name}': the math operation {node.operation} is not evaluated; 0 is used")
        return c.const(0.0, 1)
    return c.math(node.operation, vals[0], vals[1], vals[2], node.use_clamp)


def _vector_math(c, node, out, ctx):
    if node.operation not in VMATH:
        c.warn(f"'{node.name}': the vector math operation {node.operation} is not evaluated; 0 "
               "is used")
        return c.const(0.0, width(out.type))
    a, b, cc = (c.input(node, node.inputs[i], ctx, 3) for i in range(3))
    scale = c.input(node, node.inputs[3], ctx, 1)
    sa, sb, sc, ss = c.slot(a), c.slot(b), c.slot(cc), c.slot(scale)
    vo, fo = c.alloc(3), c.alloc(1)
    c.ops.append((SVM_VECTOR_MATH, vo, sa, sb))
    c.ops.append((sc, VMATH[node.operation], fo, ss))
    return Val(3, slot=vo) if out.type == "VECTOR" else Val(1, slot=fo)


def _mix(c, node, out, ctx):
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


def _separate_xyz(c, node, out, ctx):
    v = c.inp(node, 0, ctx, 3)
    return c.component(v, "XYZ".index(out.name))


def _combine_xyz(c, node, out, ctx):
    return c.combine(*(c.input(node, node.inputs[k], ctx, 1) for k in range(3)))


_COLOR_MODES = {"HSV": (COLOR_RGB_TO_HSV, COLOR_HSV_TO_RGB),
                "HSL": (COLOR_RGB_TO_HSL, COLOR_HSL_TO_RGB)}


def _separate_color(c, node, out, ctx):
    v = c.inp(node, 0, ctx, 3)
    mode = getattr(node, "mode", "RGB")
    if mode in _COLOR_MODES:
        key = c.node_key("sepcol", node, ctx)
        if key not in c.memo:
            s, o = c.slot(v), c.alloc(3)
            c.ops.append((SVM_COLOR_CONVERT, o, s, _COLOR_MODES[mode][0]))
            c.memo[key] = Val(3, slot=o)
        v = c.memo[key]
    k = [s.identifier for s in node.outputs].index(out.identifier)
    return c.component(v, min(k, 2))


def _combine_color(c, node, out, ctx):
    v = c.combine(*(c.input(node, node.inputs[k], ctx, 1) for k in range(3)))
    mode = getattr(node, "mode", "RGB")
    if mode in _COLOR_MODES:
        s, o = c.slot(v), c.alloc(3)
        c.ops.append((SVM_COLOR_CONVERT, o, s, _COLOR_MODES[mode][1]))
        return Val(3, slot=o)
    return v


def _unary(op, n_out=3):
    def f(c, node, out, ctx):
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


def _bright_contrast(c, node, out, ctx):
    col, br, co = (c.inp(node, k, ctx, n) for k, n in (("Color", 3), ("Brightness|Bright", 1),
                                                        ("Contrast", 1)))
    s = (c.slot(col), c.slot(br), c.slot(co))
    o = c.alloc(3)
    c.ops.append((SVM_BRIGHT_CONTRAST, o, s[0], s[1]))
    c.ops.append((s[2], 0, 0, 0))
    return Val(3, slot=o)


def _hsv(c, node, out, ctx):
    h, s, v, fac = (c.inp(node, k, ctx, 1) for k in ("Hue", "Saturation", "Value", "Factor|Fac"))
    col = c.inp(node, "Color", ctx, 3)
    sl = [c.slot(x) for x in (col, fac, h, s, v)]
    o = c.alloc(3)
    c.ops.append((SVM_HSV, o, sl[0], sl[1]))
    c.ops.append((sl[2], sl[3], sl[4], 0))
    return Val(3, slot=o)


def _clamp(c, node, out, ctx):
    v, lo, hi = (c.inp(node, k, ctx, 1) for k in ("Value", "Min", "Max"))
    t = CLAMP_TYPES.get(node.clamp_type, CLAMP_TYPES["MINMAX"])
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


def _map_range(c, node, out, ctx):
    """Map Range; in vector mode each component mapped by its own ranges and steps."""
    vector = node.data_type == "FLOAT_VECTOR"
    names = ("Vector" if vector else "Value", "From Min", "From Max", "To Min", "To Max",
             "Steps")
    vals = [c.inp(node, k, ctx, 3 if vector else 1) for k in names]
    kind = (MAP_RANGE_TYPES.get(node.interpolation_type, 0), int(node.clamp), 0, 0)
    comps = []
    for k in range(3 if vector else 1):
        s = [c.slot(c.component(x, k) if vector else x) for x in vals]
        o = c.alloc(1)
        c.ops.append((SVM_MAP_RANGE, o, s[0], s[1]))
        c.ops.append((s[2], s[3], s[4], s[5]))
        c.ops.append(kind)
        comps.append(Val(1, slot=o))
    return c.combine(*comps) if vector else comps[0]


def _table(c, node, out, ctx):
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


def _layer_weight(c, node, out, ctx):
    blend = c.inp(node, "Blend", ctx, 1)
    key = c.node_key("layer", node, ctx)
    if key not in c.memo:
        s, o = c.slot(blend), c.alloc(2)
        c.ops.append((SVM_LAYER_WEIGHT, o, s, o + 1))
        c.memo[key] = o
    o = c.memo[key]
    return Val(1, slot=o if out.name == "Fresnel" else o + 1)


VALUE_NODES = {
    "ShaderNodeMapping": _mapping,
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
    "ShaderNodeLayerWeight": _layer_weight,
}
