"""A material's Volume output -> its medium (materials.MAT_VOLUME): Volume Absorption, Volume
Scatter, Principled Volume and Emission, through Add and Mix Shader, with constant inputs but
for a Density driven by nodes (a heterogeneous medium: the density's own shader program, which
scales the absorption and scattering at each point, kernels/geom/medium_field.h) (``reader``:
material_nodes' reader of the material, its warnings named after it)."""
from __future__ import annotations

import numpy as np

from ppm_engine.blender.export.shader_graph import Compiler
from ppm_engine.scene.shader_program import (
    FIELD_DENSITY,
    FIELD_GLOW,
    FIELD_TINT,
    PROGRAM_GRID,
    PROGRAM_OBJECT,
    SVM_BLACKBODY,
)
from ppm_engine.scene.spectra import blackbody_rgb

_MAX_DEPTH = 64
DEFAULT_VOLUME = "default volume"     # a Volume object's without a material (Cycles')


def _output_socket(material, socket):
    tree = material.node_tree
    if tree is None:
        return None
    out = tree.get_output_node('CYCLES') or tree.get_output_node('ALL')
    return out.inputs.get(socket) if out is not None else None


_VOLUME_PHASES = ("HENYEY_GREENSTEIN",)


class ConstantInputs:
    """A reader's constant inputs of the Volume output's nodes (material_nodes' reader of a
    material, world.py's of the world): its ``graph`` (shader_graph.Graph) and ``warn``."""

    def value(self, node, name, n=None, default=None):
        """A constant input: a linked one warned about, its unlinked value used."""
        sock = node.inputs.get(name)
        if sock is None or not getattr(sock, "enabled", True):
            return default
        if self.graph.source(sock) is not None:
            self.warn(f"'{name}' of '{node.name}' is driven by a node link this engine does not "
                      "evaluate there; its unlinked value is used")
        v = sock.default_value
        return tuple(v)[:n] if n else float(v)


class _Medium:
    """The homogeneous medium a material's Volume output makes (coefficients per metre, RGB), as
    Cycles sums its volume closures: each closure's coefficients scale with its mix weight."""

    def __init__(self):
        self.absorption = np.zeros(3)
        self.scattering = np.zeros(3)
        self.emission = np.zeros(3)
        self.g_sum = 0.0              # sum of g x the scattering's mean (the mean g below)
        self.g_seen: set = set()
        # a Density driven by nodes: (node, socket, ctx) of the first, which scales the
        # coefficients it multiplies (``fielded``); the others' constant (``plain``)
        self.field = None
        self.fielded = False
        self.plain = False
        self.program = None           # the field's program words (read_volume)
        # blackbody emission through a Volume object's grid (its Temperature Attribute):
        # (weight, node, grid) each, the field program's emission (_glow)
        self.glow: list = []
        # a Color Attribute's grid: (node, grid, Color, its scattering per unit density), _tint
        self.tint = None

    def scatter(self, sigma_s, g):
        sigma_s = np.asarray(sigma_s, np.float64)
        self.scattering += sigma_s
        g = float(np.clip(np.nan_to_num(g), -1.0, 1.0))
        self.g_sum += g * float(sigma_s.mean())
        if sigma_s.max() > 0:
            self.g_seen.add(round(g, 4))

    @property
    def anisotropy(self) -> float:
        m = float(self.scattering.mean())
        return self.g_sum / m if m > 0 else 0.0


def _density(reader, node, name="Density", medium=None, ctx=(), grid=None) -> float:
    """A density input, clamped to >= 0 with a warning where it is negative or not a number, as
    Cycles clamps it; one driven by nodes, or times the Volume object's grid ``grid`` (a
    Principled Volume's Density Attribute), is the medium's field where it is the first or the
    same as the first: 1 here where driven (the field scales the coefficients at each point),
    its value where only the grid varies (the field is the grid); else warned about and its
    unlinked value used."""
    sock = node.inputs.get(name)
    src = reader.graph.source(sock, ctx) if sock is not None else None
    if medium is not None and (src is not None or grid) and getattr(reader, "fields", True):
        key = ((src[0].name, src[1].identifier, tuple(n.name for n in src[2]))
               if src is not None else None, grid)
        if medium.field is None:
            medium.field = (node, sock, ctx, key)
        if medium.field[3] == key:
            medium.fielded = True
            if src is not None:
                return 1.0
        elif src is None:
            medium.plain = True         # another grid: not the field
    elif medium is not None:
        medium.plain = True
    v = reader.value(node, name)
    if v is None:
        return 0.0
    if not np.isfinite(v) or v < 0:
        fixed = 0.0 if (np.isnan(v) or v < 0) else 1e30
        reader.warn(f"the {name} of '{node.name}' is {v}; {fixed:g} is used")
        return fixed
    return float(v)


def _grid(reader, node, name: str) -> str | None:
    """The grid that the node's attribute input ``name`` (Density, Color or Temperature
    Attribute) names, where the Volume object being read has one of that name (reader.grids;
    None for a mesh: Cycles finds no such attribute there and leaves the input as it is)."""
    sock = node.inputs.get(name)
    attr = getattr(sock, "default_value", "") if sock is not None else ""
    return attr if reader.grids is not None and attr and attr in reader.grids else None


# Cycles' Principled Volume's blackbody emission: the Stefan-Boltzmann law, sigma T^4 / pi
# (its sigma in W m^-2 K^-4 and the 1e-6 of Cycles' scale), Blackbody Intensity mixing from 1
_STEFAN_BOLTZMANN = 5.670373e-8 * 1e-6 / np.pi


def _blackbody(reader, node, medium=None, weight=1.0) -> np.ndarray:
    """The Principled Volume's blackbody emission per metre, as Cycles' svm_node_principled_volume
    adds it: Blackbody Tint x sigma mix(1, T^4, Blackbody Intensity) x the black body's colour at
    Temperature T (linear Rec.709, luminance 1: the Blackbody node's, spectra.blackbody_rgb).
    Where the Volume object has the grid its Temperature Attribute names (Cycles multiplies T
    by it), the emission varies from point to point: recorded in ``medium.glow`` for the field
    program (_glow), 0 here."""
    intensity = float(np.nan_to_num(reader.value(node, "Blackbody Intensity") or 0.0))
    if not intensity > 0:
        return np.zeros(3)
    grid = _grid(reader, node, "Temperature Attribute")
    if grid is not None:
        if medium is not None and getattr(reader, "fields", True):
            medium.glow.append(("blackbody", weight, node, grid))
        else:
            reader.warn(f"the blackbody emission of '{node.name}' through the grid '{grid}' "
                        "(its Temperature Attribute) is not rendered here; it is left out")
        return np.zeros(3)
    t = max(float(np.nan_to_num(reader.value(node, "Temperature") or 0.0)), 0.0)
    power = _STEFAN_BOLTZMANN * (1.0 + intensity * (min(t, 1e9) ** 4 - 1.0))
    if not power > 0:
        return np.zeros(3)
    tint = np.maximum(np.nan_to_num(reader.value(node, "Blackbody Tint", 3)), 0.0)
    return tint * power * np.asarray(blackbody_rgb(t))


def _glow(c, reader, medium):
    """The field program's emission per metre (its second bind, 3 floats; kernels/geom/
    medium_field.h medium_point): the sum over medium.glow of an emission closure's Strength x
    Color driven by nodes, and of Cycles' blackbody emission with T = Temperature x max(the
    grid, 0), then max(T, 0) (svm_node_principled_volume); each times its mix weight and the
    object-space density's ``reader.scale``; None: nothing to add."""
    total = None
    scale = float(getattr(reader, "scale", 1.0))
    for kind, weight, node, what in medium.glow:
        if kind == "emission":
            ctx, strength, color = what
            v = c.math("MAXIMUM", c.inp(node, strength, ctx, 1), c.const(0.0, 1))
            e = c.scale(c.inp(node, color, ctx, 3), c.math("MULTIPLY", v,
                                                          c.const(weight * scale, 1)))
        else:
            e = _blackbody_glow(c, reader, node, what, weight * scale)
        if e is None:
            continue
        total = e if total is None else c.combine(
            *(c.math("ADD", c.component(total, k), c.component(e, k)) for k in range(3)))
    return total


def _tint(c, medium):
    """The factor of the field's scattering per point from a Principled Volume's Color
    Attribute grid g (Cycles: Color x g scatters, (1 - Color x g) absorbs, the Absorption Color
    black): g between 0 and 1 / Color per channel, so that the extinction stays the density's
    (the host's coefficients: Color x density scattering, (1 - Color) x density absorbing);
    None where the node is not the field's only scattering."""
    if medium.tint is None:
        return None
    _node, grid, color, own = medium.tint
    if not own.max() > 0 or not np.allclose(own, medium.scattering, rtol=1e-6, atol=0.0):
        return None
    a = c.attribute(grid)
    if a is None:
        return None
    cap = [1.0 / x if x > 1e-6 else 1e6 for x in color]
    return c.combine(*(c.math("MINIMUM", c.math("MAXIMUM", c.component(a, k), c.const(0.0, 1)),
                              c.const(float(cap[k]), 1))
                       for k in range(3)))


def _blackbody_glow(c, reader, node, grid, weight):
    """The Principled Volume's blackbody emission through the grid (_glow), times weight."""
    intensity = float(np.nan_to_num(reader.value(node, "Blackbody Intensity") or 0.0))
    tint = np.maximum(np.nan_to_num(reader.value(node, "Blackbody Tint", 3)), 0.0) * weight
    a = c.attribute(grid)
    if a is None or not tint.max() > 0:
        return None
    a = c.math("MAXIMUM", c.convert(a, 1, "vector"), c.const(0.0, 1))
    t0 = float(np.clip(np.nan_to_num(reader.value(node, "Temperature") or 0.0), 0.0, 1e9))
    t = c.math("MINIMUM", c.math("MULTIPLY", a, c.const(t0, 1)), c.const(1e9, 1))
    t2 = c.math("MULTIPLY", t, t)
    power = c.math("MULTIPLY_ADD", c.math("MULTIPLY", t2, t2),
                   c.const(_STEFAN_BOLTZMANN * intensity, 1),
                   c.const(_STEFAN_BOLTZMANN * (1.0 - intensity), 1))
    bb = c.stacked(3)
    c.ops.append((SVM_BLACKBODY, bb.slot, c.slot(t), 0))
    e = c.scale(bb, power)
    return c.combine(*(c.math("MULTIPLY", c.component(e, k), c.const(float(tint[k]), 1))
                       for k in range(3)))


def _emission(reader, node, ctx, strength: str, color: str, weight: float, medium) -> None:
    """An emission closure in the volume (Cycles: Strength x Color where the Strength is above
    0): constant into medium.emission, or, where either input is driven by nodes (a "flame"
    grid through an Attribute node, a Noise Texture), recorded in medium.glow for the field
    program (_glow)."""
    socks = [node.inputs.get(strength), node.inputs.get(color)]
    if any(k is not None and reader.graph.source(k, ctx) is not None for k in socks) \
            and getattr(reader, "fields", True):
        medium.glow.append(("emission", weight, node, (ctx, strength, color)))
        return
    value = np.nan_to_num(reader.value(node, strength) or 0.0)
    if value > 0:
        medium.emission += weight * value * np.maximum(
            np.nan_to_num(reader.value(node, color, 3)), 0.0)


def _volume_walk(reader, socket, weight: float, medium: _Medium, ctx=(), depth=0):
    """Adds the volume shaders feeding ``socket`` (through Mix and Add Shader) to ``medium``."""
    src = reader.graph.source(socket, ctx)
    if src is None or depth > _MAX_DEPTH or not weight > 0:
        return
    node, _, ctx = src
    kind = node.bl_idname
    if kind == "ShaderNodeAddShader":
        for sock in node.inputs[:2]:
            _volume_walk(reader, sock, weight, medium, ctx, depth + 1)
        return
    if kind == "ShaderNodeMixShader":
        fac = float(np.clip(reader.value(node, "Fac"), 0.0, 1.0))
        _volume_walk(reader, node.inputs[1], weight * (1.0 - fac), medium, ctx, depth + 1)
        _volume_walk(reader, node.inputs[2], weight * fac, medium, ctx, depth + 1)
        return
    if kind == "ShaderNodeVolumeAbsorption":
        color = np.clip(np.nan_to_num(reader.value(node, "Color", 3)), 0.0, 1.0)
        medium.absorption += weight * (1.0 - color) * _density(reader, node, medium=medium,
                                                               ctx=ctx)
        return
    if kind == "ShaderNodeVolumeScatter":
        phase = getattr(node, "phase", "HENYEY_GREENSTEIN")
        if phase not in _VOLUME_PHASES:
            reader.warn(f"the phase function '{phase}' of '{node.name}' is rendered as "
                        "Henyey-Greenstein (its Anisotropy)")
        color = np.maximum(np.nan_to_num(reader.value(node, "Color", 3)), 0.0)
        aniso = reader.value(node, "Anisotropy")
        medium.scatter(weight * color * _density(reader, node, medium=medium, ctx=ctx),
                       aniso or 0.0)
        return
    if kind == "ShaderNodeVolumePrincipled":
        # (Cycles reads the grid where the Density is linked or above 0)
        dens = node.inputs.get("Density")
        grid = (_grid(reader, node, "Density Attribute") if dens is not None and (
            reader.graph.source(dens, ctx) is not None or dens.default_value > 0) else None)
        density = _density(reader, node, medium=medium, ctx=ctx, grid=grid)
        color = np.maximum(np.nan_to_num(reader.value(node, "Color", 3)), 0.0)
        absorbing = np.sqrt(np.maximum(np.nan_to_num(reader.value(node, "Absorption Color", 3)),
                                       0.0))
        tint = _grid(reader, node, "Color Attribute")
        if tint is not None:
            # Cycles' Color times the grid: the field program's scattering per point where the
            # extinction stays the density's (_tint); else its Color alone, said
            if (medium.fielded and medium.field[0] == node and absorbing.max() == 0.0
                    and color.max() <= 1.0 and getattr(reader, "fields", True)):
                medium.tint = (node, tint, color, weight * color * density)
            else:
                reader.warn(f"the grid its Color Attribute names ('{node.name}') is rendered "
                            "only where that node's Density is the volume's field, its "
                            "Absorption Color black and its Color at most 1; its Color is used")
        medium.scatter(weight * color * density, reader.value(node, "Anisotropy") or 0.0)
        medium.absorption += weight * (np.maximum(1.0 - color, 0.0)
                                       * np.maximum(1.0 - absorbing, 0.0) * density)
        _emission(reader, node, ctx, "Emission Strength", "Emission Color", weight, medium)
        medium.emission += weight * _blackbody(reader, node, medium, weight)
        return
    if kind == "ShaderNodeEmission":
        _emission(reader, node, ctx, "Strength", "Color", weight, medium)
        return
    reader.warn(f"the shader '{node.name}' ({node.bl_label}) on the Volume output is not a "
                "volume shader this engine renders; it is left out of the volume")


def _field_program(reader, medium, material) -> bool:
    """The program of the medium's density field (medium.program: a program of one bind, its
    value at the stack slot of bind 0, as the world's; kernels/geom/medium_field.h), read in a
    volume's context: the point, its object's space and Generated coordinates, and a Volume
    object's grids (the Principled Volume's Density times its Density Attribute's grid, the
    grid's float as Cycles reads it: its components' mean); none where the field folds to a
    constant (its value then scales the coefficients).  False: no program (a graph too large,
    too many attributes; warned)."""
    node, sock, ctx, key = medium.field
    c = Compiler(material.name if material is not None else DEFAULT_VOLUME, reader.warn_fn,
                 reader.textures, reader.graph, material, reader.compiler.attributes,
                 reader.compiler.camera)
    grid = key[1]
    v = g = None
    if grid is not None:                 # first: a grid alone is the program's first op
        g = c.attribute(grid)
        if g is None:
            return False
        g = c.convert(g, 1, "vector")
    if key[0] is not None:
        v = c.convert(c.input(node, sock, ctx, 1), 1)
    if v is not None and v.is_const:       # a linked Density folded to a constant: it scales
        d = float(v.const[0])
        d = 0.0 if not np.isfinite(d) or d < 0 else d
        medium.absorption *= d
        medium.scattering *= d
        medium.g_sum *= d
        if g is None:
            return True
        v = None
    if v is None and g is None:          # a constant density, a field for its glow alone
        v = c.const(1.0, 1)
    elif v is None:
        v = g
        c.flags |= PROGRAM_GRID          # its majorants: the grid's voxels per cell
    elif g is not None:
        v = c.math("MULTIPLY", v, g)
    c.binds.append((FIELD_DENSITY, 0, 1, c.slot(v)))
    glow = _glow(c, reader, medium) if medium.glow else None
    if glow is not None:                 # its emission per metre
        c.binds.append((FIELD_GLOW, 0, 3, c.slot(glow)))
    tint = _tint(c, medium)
    if tint is not None:                 # its scattering's colour per point
        c.binds.append((FIELD_TINT, 0, 3, c.slot(tint)))
    c.flags |= PROGRAM_OBJECT          # the object's space: its row exists (export/__init__.py)
    medium.program = c.program()
    if medium.program is None:         # (a graph too large)
        reader.warn("the node graph of its volume's Density is too large to evaluate; the "
                    "Density's unlinked value is used")
    return medium.program is not None


def _constant_medium(reader, sock) -> _Medium:
    """The medium with every Density read as its unlinked value."""
    medium = _Medium()
    medium.field = (None, None, None, ())         # (no link matches it)
    _volume_walk(reader, sock, 1.0, medium)
    medium.field = None
    return medium


def default_volume(reader) -> _Medium | None:
    """Cycles' default volume shader, a Volume object's without a material: a Principled
    Volume of its defaults (colour 0.5, Density 1 times the "density" grid: scattering 0.5 and
    absorption 0.5 per unit density); None where the object has no "density" grid
    (reader.grids: Cycles then renders nothing)."""
    if reader.grids is None or "density" not in reader.grids:
        return None
    medium = _Medium()
    medium.scatter(np.full(3, 0.5), 0.0)
    medium.absorption += 0.5
    medium.field, medium.fielded = (None, None, (), (None, "density")), True
    return medium if _field_program(reader, medium, None) else None


def read_volume(material, reader) -> _Medium | None:
    """The homogeneous medium of the material's Volume output (None: nothing connected), as
    Cycles computes it: Volume Absorption (1 - colour) x density; Volume Scatter colour x
    density, scattering only; Principled Volume colour x density scattering and
    (1 - colour)(1 - sqrt(absorption colour)) x density absorption, its emission colour x
    strength; an Emission node's colour x strength emitted per metre; Add and Mix Shader sum
    them by their weights.  A Density driven by nodes (a Noise Texture) is the medium's field
    (medium.program); other inputs driven by links are warned about and rendered with their
    unlinked values."""
    sock = _output_socket(material, "Volume")
    if reader.graph.source(sock) is None:
        return None
    medium = _Medium()
    _volume_walk(reader, sock, 1.0, medium)
    if medium.fielded and medium.plain:
        # one field scales every density-scaled coefficient: with constant densities beside
        # it, the field is not used (warned) and the constants are read again
        reader.warn(f"its volume mixes a Density driven by nodes ('{medium.field[0].name}') "
                    "with constant ones; the driven one is rendered with its unlinked value")
        medium = _constant_medium(reader, sock)
    elif medium.fielded and not _field_program(reader, medium, material):
        medium = _constant_medium(reader, sock)
    if medium.glow and medium.program is None:
        # an emission driven by nodes or a temperature grid beside a constant density: a
        # field of density 1 (the coefficients as they are) for the emission's program
        medium.field, medium.fielded = (None, None, (), (None, None)), True
        if not _field_program(reader, medium, material):
            medium.glow = []
    if medium.glow and medium.program is None:
        reader.warn("its volume's emission driven by nodes or a temperature grid is left out: "
                    "its program could not be made")
    if len(medium.g_seen) > 1:
        reader.warn("its volume mixes scattering of different anisotropies; their mean, "
                    "weighted by the scattering, is rendered")
    return medium
