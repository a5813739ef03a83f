"""Cycles' procedural texture nodes in the shader programs (kernels/svm/svm_textures.h runs them;
shader_program.py has the layouts): Checker, Gradient, White Noise, Noise, Magic, Wave, Brick
and Voronoi, every option as Cycles compiles it (its scene/shader_nodes.cpp).

A node is compiled once per group context into one op writing every output that is linked
(an output nothing reads gets slot -1, and the kernel skips it: the Noise Texture's Color
triples its cost).  A float input is passed as Cycles passes it: a linked input's stack slot,
else its constant (no stack slot, no op).  The node's hidden texture mapping is applied before
the texture as Cycles applies it.

The compile functions take the Compiler (shader_graph.py) and use only its methods, so this
module does not import shader_graph (which imports it).
"""
from __future__ import annotations

from ppm_engine.scene.shader_program import (
    GRADIENT_TYPES,
    NOISE_TYPES,
    SVM_MAPPING,
    SVM_TEX_BRICK,
    SVM_TEX_CHECKER,
    SVM_TEX_GRADIENT,
    SVM_TEX_MAGIC,
    SVM_TEX_NOISE,
    SVM_TEX_VORONOI,
    SVM_TEX_WAVE,
    SVM_TEX_WHITE_NOISE,
    VORONOI_FEATURES,
    VORONOI_METRICS,
    WAVE_BANDS,
    WAVE_PROFILES,
    WAVE_RINGS,
    WAVE_TYPES,
    f2i,
)

_N_OUT = {"RGBA": 3, "VECTOR": 3}


def _option(c, node, prop: str, table: dict):
    """A node option's code; an unknown value (another Blender version) is warned about and
    the first option used."""
    value = getattr(node, prop)
    if value not in table:
        c.warn(f"'{node.name}': the {prop.replace('_', ' ')} {value} is not evaluated by this "
               f"engine; {next(iter(table))} is used")
        return next(iter(table.values()))
    return table[value]


def _dimensions(node, prop: str) -> int:
    return int(getattr(node, prop)[0])


def _params(c, vals) -> list:
    """Float inputs in words of four: the stack slots (-1 for a constant), then the constants'
    bits (kernels/svm/svm_textures.h tex_in4)."""
    vals = list(vals) + [c.const(0.0, 1)] * (-len(vals) % 4)
    slots = [-1 if v.is_const else v.slot for v in vals]
    bits = [f2i(v.const[0]) if v.is_const else 0 for v in vals]
    return [tuple(w[k:k + 4]) for w in (slots, bits) for k in range(0, len(vals), 4)]


def _mapping_identity(tm) -> bool:
    return (tuple(tm.translation) == (0.0, 0.0, 0.0) and tuple(tm.rotation) == (0.0, 0.0, 0.0)
            and tuple(tm.scale) == (1.0, 1.0, 1.0)
            and (tm.mapping_x, tm.mapping_y, tm.mapping_z) == ("X", "Y", "Z")
            and not (tm.use_min or tm.use_max))


def _texture_mapping(c, node, v):
    """The node's texture mapping (Cycles' TextureMapping::compute_transform) applied to the
    vector v, when it is not the identity."""
    tm = getattr(node, "texture_mapping", None)
    if tm is None or _mapping_identity(tm):
        return v
    from mathutils import Euler, Matrix
    if tm.use_min or tm.use_max:
        c.warn(f"'{node.name}': the texture mapping's Min/Max clamp is not evaluated by this "
               "engine")
    kind = tm.vector_type
    scale = list(tm.scale)
    if kind in ("TEXTURE", "NORMAL"):           # kept invertible
        scale = [s if abs(s) >= 1e-5 else (-1e-5 if s < 0.0 else 1e-5) for s in scale]
    rs = Euler(tuple(tm.rotation), "XYZ").to_matrix().to_4x4() @ Matrix.Diagonal(
        scale + [1.0])
    if kind in ("POINT", "TEXTURE"):
        m = Matrix.Translation(tuple(tm.translation)) @ rs
        if kind == "TEXTURE":
            m = m.inverted_safe()
    elif kind == "NORMAL":
        m = rs.inverted_safe().transposed()
    else:
        m = rs
    axes = Matrix.Diagonal((0.0, 0.0, 0.0, 1.0))   # which input axis feeds each axis
    for row, axis in enumerate((tm.mapping_x, tm.mapping_y, tm.mapping_z)):
        if axis in ("X", "Y", "Z"):
            axes[row]["XYZ".index(axis)] = 1.0
    m = m @ axes
    sv = c.slot(v)
    out = c.stacked(3)
    c.ops.append((SVM_MAPPING, out.slot, sv, 3 if kind == "NORMAL" else 0))
    for r in range(3):
        c.ops.append(tuple(f2i(m[r][k]) for k in range(4)))
    return out


def _vector(c, node, ctx) -> int:
    """The stack slot of the texture's (mapped) Vector input."""
    return c.slot(_texture_mapping(c, node, c.texture_vector(node, ctx)))


def _texture(build):
    """A compile function: ``build(c, node, ctx)`` -> ((op, vector slot), parameter words),
    run once per node and group context.  The outputs linked get stack slots, the first two
    go into the op's word, the others into the parameter word given as "outputs"."""
    def compile_node(c, node, out, ctx):
        key = c.node_key("texture", node, ctx)
        if key not in c.memo:
            op, params = build(c, node, ctx)
            outs, slots = {}, []
            for o in node.outputs:
                if o.enabled and (o.is_linked or o.identifier == out.identifier):
                    outs[o.identifier] = c.stacked(_N_OUT.get(o.type, 1))
                slots.append(outs[o.identifier].slot if o.identifier in outs else -1)
            c.memo[key] = outs
            c.ops.append((op[0], slots[0], slots[1], op[1]))
            for word in params:
                c.ops.append(tuple(slots[2:5]) + (0,) if word == "outputs" else word)
        outs = c.memo[key]
        if out.identifier not in outs:
            return c.const(0.0, _N_OUT.get(out.type, 1))
        return outs[out.identifier]
    return compile_node


@_texture
def _checker(c, node, ctx):
    c1, c2 = c.inp(node, "Color1", ctx, 3), c.inp(node, "Color2", ctx, 3)
    scale = _params(c, [c.inp(node, "Scale", ctx, 1)])
    vec = _vector(c, node, ctx)
    return (SVM_TEX_CHECKER, vec), [(c.slot(c1), c.slot(c2), scale[0][0], scale[1][0])]


@_texture
def _gradient(c, node, ctx):
    kind = _option(c, node, "gradient_type", GRADIENT_TYPES)
    return (SVM_TEX_GRADIENT, _vector(c, node, ctx)), [(kind, 0, 0, 0)]


@_texture
def _white_noise(c, node, ctx):
    dims = _dimensions(node, "noise_dimensions")
    w = _params(c, [c.inp(node, "W", ctx, 1)])
    vec = c.slot(c.inp(node, "Vector", ctx, 3)) if dims > 1 else -1
    return (SVM_TEX_WHITE_NOISE, vec), [(dims, w[0][0], w[1][0], 0)]


@_texture
def _noise(c, node, ctx):
    dims = _dimensions(node, "noise_dimensions")
    kind = _option(c, node, "noise_type", NOISE_TYPES)
    names = ("W", "Scale", "Detail", "Roughness", "Lacunarity", "Offset", "Gain", "Distortion")
    params = _params(c, [c.inp(node, k, ctx, 1) for k in names])
    vec = _vector(c, node, ctx) if dims > 1 else -1
    return (SVM_TEX_NOISE, vec), params + [(dims, kind, int(bool(node.normalize)), 0)]


@_texture
def _magic(c, node, ctx):
    params = _params(c, [c.inp(node, k, ctx, 1) for k in ("Scale", "Distortion")])
    return (SVM_TEX_MAGIC, _vector(c, node, ctx)), params + [(int(node.turbulence_depth), 0, 0,
                                                               0)]


@_texture
def _wave(c, node, ctx):
    opt = (_option(c, node, "wave_type", WAVE_TYPES),
           _option(c, node, "bands_direction", WAVE_BANDS),
           _option(c, node, "rings_direction", WAVE_RINGS),
           _option(c, node, "wave_profile", WAVE_PROFILES))
    names = ("Scale", "Distortion", "Detail", "Detail Scale", "Detail Roughness", "Phase Offset")
    params = _params(c, [c.inp(node, k, ctx, 1) for k in names])
    return (SVM_TEX_WAVE, _vector(c, node, ctx)), params + [opt]


@_texture
def _brick(c, node, ctx):
    cols = [c.inp(node, k, ctx, 3) for k in ("Color1", "Color2", "Mortar")]
    names = ("Scale", "Mortar Size", "Mortar Smooth", "Bias", "Brick Width", "Row Height")
    params = _params(c, [c.inp(node, k, ctx, 1) for k in names])
    vec = _vector(c, node, ctx)
    cols = tuple(c.slot(v) for v in cols)
    return (SVM_TEX_BRICK, vec), params + [cols + (0,), (
        int(node.offset_frequency), int(node.squash_frequency), f2i(node.offset),
        f2i(node.squash))]


@_texture
def _voronoi(c, node, ctx):
    dims = _dimensions(node, "voronoi_dimensions")
    opt = (dims, _option(c, node, "feature", VORONOI_FEATURES),
           _option(c, node, "distance", VORONOI_METRICS), int(bool(node.normalize)))
    names = ("W", "Scale", "Detail", "Roughness", "Lacunarity", "Smoothness", "Exponent",
             "Randomness")
    params = _params(c, [c.inp(node, k, ctx, 1) for k in names])
    vec = _vector(c, node, ctx) if dims > 1 else -1
    return (SVM_TEX_VORONOI, vec), params + [opt, "outputs"]


TEXTURE_NODES = {
    "ShaderNodeTexChecker": _checker, "ShaderNodeTexGradient": _gradient,
    "ShaderNodeTexWhiteNoise": _white_noise, "ShaderNodeTexNoise": _noise,
    "ShaderNodeTexMagic": _magic, "ShaderNodeTexWave": _wave, "ShaderNodeTexBrick": _brick,
    "ShaderNodeTexVoronoi": _voronoi,
}
