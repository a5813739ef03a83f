"""Material node trees -> MATERIAL_DTYPE rows, their BSDF nodes (SHADER_NODE_DTYPE) and their
shader programs (shader_graph.py).

The Surface output is walked from the Cycles material output: Mix Shader and Add Shader nodes
fold into each BSDF node's weight (as Cycles propagates them into its closures), through
reroutes, muted nodes and node groups.  Each BSDF input is a constant, an Image Texture on the
UV map (a colour input's texture, or its Alpha on Principled's Alpha: the short path of
textures.py), or whatever the value nodes feeding it compute: the shader program drives it (a
linked Mix Shader factor drives the weights).  A shader node this engine has no closure for is
warned about and rendered as the nearest one.  The Volume output (Volume Absorption, Volume
Scatter, Principled Volume, Emission, through Add and Mix Shader; constant inputs) -> the row's
homogeneous medium (absorption, scattering, anisotropy, emission); a material with only a
Volume output gets a transparent surface (the medium's boundary)."""
from __future__ import annotations

import sys

import numpy as np

from ppm_engine.blender.export.material_volume import (
    DEFAULT_VOLUME,
    ConstantInputs,
    default_volume,
    read_volume,
)
from ppm_engine.blender.export.shader_graph import Compiler, Graph
from ppm_engine.scene.arrays import (
    MATERIAL_DTYPE,
    NODE_DIFFUSE,
    NODE_EMISSION,
    NODE_FLAG_CONDUCTOR,
    NODE_FLAG_MULTI_GGX,
    NODE_FLAG_NO_BUMP_CORRECTION,
    NODE_FLAG_VOLUME_BOUNDARY,
    NODE_GLASS,
    NODE_GLOSSY,
    NODE_HOLDOUT,
    NODE_METALLIC,
    NODE_PRINCIPLED,
    NODE_REFRACTION,
    NODE_SHEEN,
    NODE_TRANSLUCENT,
    NODE_TRANSPARENT,
    shader_node,
)
from ppm_engine.scene.shader_program import MAX_STACK

DEFAULT_NAME = "(default grey)"
_MAX_DEPTH = 64
_RECURSION = 20000                # Python frames while a node graph compiles (a chain of nodes)

# Principled BSDF input -> node field (scalars)
_PRINCIPLED_SCALARS = {
    "Metallic": "metallic", "Roughness": "roughness", "IOR": "ior",
    "Transmission Weight": "transmission", "Specular IOR Level": "specular_ior_level",
    "Anisotropic": "anisotropic", "Anisotropic Rotation": "anisotropic_rotation",
    "Coat Weight": "coat_weight", "Coat Roughness": "coat_roughness", "Coat IOR": "coat_ior",
    "Sheen Weight": "sheen_weight", "Sheen Roughness": "sheen_roughness",
    "Subsurface Weight": "subsurface_weight", "Diffuse Roughness": "diffuse_roughness",
}
_PRINCIPLED_COLORS = {"Specular Tint": "edge_tint", "Coat Tint": "coat_tint",
                      "Sheen Tint": "sheen_tint"}
# inputs read nowhere else that change the image when linked (warned about)
_UNSUPPORTED_INPUTS = {"Tangent": "tangents come with the node graphs; Cycles' default, the "
                                  "radial tangent around the object's Z axis, is used"}


def default_row() -> tuple[np.ndarray, list]:
    """Grey (0.8) Lambertian diffuse, Cycles' default surface: empty slots, missing materials."""
    return np.zeros(1, MATERIAL_DTYPE), [dict(type=NODE_DIFFUSE, color=(0.8, 0.8, 0.8))]


def _output_socket(material, socket="Surface"):
    tree = material.node_tree
    if tree is None:
        return None
    out = tree.get_output_node('CYCLES') or tree.get_output_node('ALL')
    return out.inputs.get(socket) if out is not None else None


class _Reader(ConstantInputs):
    """Reads one material's BSDF nodes, warning once per problem; inputs driven by value nodes
    are compiled into the material's shader program (shader_graph.Compiler); the Volume
    output's constant inputs (ConstantInputs.value)."""

    def __init__(self, material, warn, textures, attributes=None, camera=None):
        self.name = material.name if material is not None else DEFAULT_VOLUME
        self.warn_fn = warn
        self.textures = textures
        self.graph = Graph(warn)
        self.compiler = Compiler(self.name, warn, textures, self.graph, material, attributes,
                                 camera)
        self.grids = None                 # a Volume object's grid names (material_volume.py)
        self.said = self.compiler.said
        self.ctx = ()                     # group nodes around the node being read
        self.index = 0                    # the node's index among the material's BSDF nodes

    def warn(self, text):
        self.compiler.warn(text)

    def val(self, node, name, n=1):
        """The input's value in the program (constant or stack slots), None when absent."""
        sock = next((s for s in node.inputs if s.name == name and s.enabled), None)
        return None if sock is None else self.compiler.input(node, sock, self.ctx, n)

    def may_exceed(self, node, name, limit: float) -> bool:
        """Whether the input is above ``limit``, or driven (any value is possible)."""
        v = self.val(node, name)
        return v is not None and (not v.is_const or v.const[0] > limit)

    def field(self, row, node, name, field, default=None):
        v = self.val(node, name, 3 if row.dtype[field].shape else 1)
        if v is None:
            if default is not None:
                row[field] = default
            return
        self.compiler.bind(row, self.index, field, v)

    def color(self, node, name, row, field, texture_field, default=(0.8, 0.8, 0.8), scale=None):
        """A colour input: an Image Texture on the UV map becomes the node's texture (white
        constant), anything else the program's; ``scale`` (a Val) multiplies it."""
        sock = next((s for s in node.inputs if s.name == name and s.enabled), None)
        if sock is None:
            row[field] = default
            return
        if self.textures is not None and not self.ctx:
            tex, _constant = self.textures.from_socket(sock, name, self.name)
            if tex and (scale is None or scale.is_const):
                row[field], row[texture_field] = (1.0, 1.0, 1.0), tex
                if scale is not None:
                    row[field] = np.asarray(row[field]) * scale.const[0]
                return
        v = self.compiler.input(node, sock, self.ctx, 3)
        if scale is not None:
            v = self.compiler.scale(v, scale)
        self.compiler.bind(row, self.index, field, v)
        if field == "emission" and not v.is_const:
            # the emitter table's estimate of driven emission (as Cycles': white, times a
            # constant strength); the kernels evaluate the program where they sample it
            s = scale.const[0] if scale is not None and scale.is_const else 1.0
            row[field] = (abs(s),) * 3

    def distribution(self, node, row):
        d = getattr(node, "distribution", "GGX")
        r = self.val(node, "Roughness")
        rough = r.const[0] if r is not None and r.is_const else 1.0
        if d in ("BECKMANN", "ASHIKHMIN_SHIRLEY") and rough > 0.0:
            self.warn(f"'{node.name}' uses the {d.replace('_', '-').title()} distribution; "
                      "this engine renders GGX")
        row["flags"] = NODE_FLAG_MULTI_GGX if d == "MULTI_GGX" else 0

    def unsupported_inputs(self, node):
        for name, what in _UNSUPPORTED_INPUTS.items():
            sock = node.inputs.get(name)
            if sock is not None and self.graph.source(sock, self.ctx) is not None:
                self.warn(f"'{name}' of '{node.name}' is not evaluated ({what})")

    # --- one BSDF node ------------------------------------------------------------------------
    def node_row(self, node, weight, out: list):
        kind = node.bl_idname
        row = shader_node(NODE_DIFFUSE)
        self.index = len(out)
        make = _READERS.get(kind)
        if make is None:
            self.fallback(node, row)
        else:
            make(self, node, row)
            self.unsupported_inputs(node)
            for name, field in (("Normal", "normal"), ("Coat Normal", "coat_normal")):
                if self.graph.source(node.inputs.get(name), self.ctx) is not None:
                    self.field(row, node, name, field)   # unlinked: 0, the surface's normal
        self.compiler.bind(row, self.index, "weight", weight)
        out.append(row)

    def fallback(self, node, row):
        """Shader nodes without a closure here: the nearest one, warned about."""
        kind = node.bl_idname
        near = {"ShaderNodeSubsurfaceScattering": "Diffuse BSDF (subsurface scattering is "
                                                  "rendered as diffuse)",
                "ShaderNodeBsdfToon": "Diffuse BSDF", "ShaderNodeBsdfHair": "Diffuse BSDF",
                "ShaderNodeBsdfHairPrincipled": "Diffuse BSDF",
                "ShaderNodeBsdfRayPortal": "Transparent BSDF",
                "ShaderNodeBackground": "Emission"}.get(kind)
        if near is None:
            self.warn(f"the shader node '{node.name}' ({node.bl_label}) has no counterpart in "
                      "this engine; it renders as grey diffuse")
            row["color"] = (0.8, 0.8, 0.8)
            return
        self.warn(f"'{node.name}' ({node.bl_label}) renders as {near}")
        if kind == "ShaderNodeBsdfRayPortal":
            row["type"] = NODE_TRANSPARENT
            self.color(node, "Color", row, "color", "color_texture", (1.0, 1.0, 1.0))
        elif kind == "ShaderNodeBackground":
            _emission(self, node, row)
        else:
            self.color(node, "Color", row, "color", "color_texture")

    # --- the tree -----------------------------------------------------------------------------
    def walk(self, socket, weight, out: list, ctx=(), depth: int = 0) -> None:
        src = self.graph.source(socket, ctx)
        if src is None or (weight.is_const and weight.const[0] <= 0.0):
            return
        node, _, ctx = src
        if depth > _MAX_DEPTH:
            self.warn("its shader tree is too deep; the rest is not rendered")
            return
        c = self.compiler
        kind = node.bl_idname
        if kind == "ShaderNodeMixShader":
            fac = c.math("ADD", c.input(node, node.inputs[0], ctx, 1), c.const(0.0, 1),
                         clamp=True)
            self.walk(node.inputs[1], c.math("MULTIPLY", weight,
                                             c.math("SUBTRACT", c.const(1.0, 1), fac)),
                      out, ctx, depth + 1)
            self.walk(node.inputs[2], c.math("MULTIPLY", weight, fac), out, ctx, depth + 1)
        elif kind == "ShaderNodeAddShader":
            self.walk(node.inputs[0], weight, out, ctx, depth + 1)
            self.walk(node.inputs[1], weight, out, ctx, depth + 1)
        else:
            self.ctx = ctx
            self.node_row(node, weight, out)
            self.ctx = ()


def _thin_film(r: _Reader, node):
    if r.may_exceed(node, "Thin Film Thickness", 0.1):
        r.warn("thin-film iridescence is not rendered")


def _principled(r: _Reader, node, row):
    row["type"] = NODE_PRINCIPLED
    r.color(node, "Base Color", row, "color", "color_texture")
    for name, field in _PRINCIPLED_SCALARS.items():
        r.field(row, node, name, field)
    for name, field in _PRINCIPLED_COLORS.items():
        r.field(row, node, name, field)
    alpha = node.inputs.get("Alpha")
    tex, _ = (r.textures.from_socket(alpha, "Alpha", r.name, output="Alpha")
              if r.textures is not None and alpha is not None and not r.ctx else (0, None))
    if tex:
        row["alpha"], row["alpha_texture"] = 1.0, tex
    else:
        r.field(row, node, "Alpha", "alpha", 1.0)
    strength = r.val(node, "Emission Strength") or r.compiler.const(0.0, 1)
    if not strength.is_const or strength.const[0] != 0.0:
        r.color(node, "Emission Color", row, "emission", "emission_texture", (1.0, 1.0, 1.0),
                scale=strength)
    else:
        row["emission"] = 0.0
    r.distribution(node, row)
    if r.may_exceed(node, "Subsurface Weight", 0.0):
        r.warn("subsurface scattering renders as diffuse (its radius and scale are ignored)")
    _thin_film(r, node)


def _simple(kind, color_default=(0.8, 0.8, 0.8)):
    def read(r: _Reader, node, row):
        row["type"] = kind
        r.color(node, "Color", row, "color", "color_texture", color_default)
        if kind in (NODE_DIFFUSE, NODE_SHEEN, NODE_GLOSSY, NODE_GLASS, NODE_REFRACTION):
            r.field(row, node, "Roughness", "roughness", 0.0)
        if kind in (NODE_GLASS, NODE_REFRACTION):
            r.field(row, node, "IOR", "ior", 1.5)
        if kind == NODE_GLOSSY:
            r.field(row, node, "Anisotropy", "anisotropic", 0.0)
            r.field(row, node, "Rotation", "anisotropic_rotation", 0.0)
        if kind in (NODE_GLOSSY, NODE_GLASS, NODE_REFRACTION):
            r.distribution(node, row)
        if kind == NODE_SHEEN and getattr(node, "distribution", "MICROFIBER") != "MICROFIBER":
            r.warn(f"'{node.name}' uses the Ashikhmin sheen; this engine renders Microfiber")
        if kind == NODE_GLASS:
            _thin_film(r, node)
    return read


def _metallic(r: _Reader, node, row):
    row["type"] = NODE_METALLIC
    r.field(row, node, "Roughness", "roughness", 0.5)
    r.field(row, node, "Anisotropy", "anisotropic", 0.0)
    r.field(row, node, "Rotation", "anisotropic_rotation", 0.0)
    r.distribution(node, row)
    if getattr(node, "fresnel_type", "F82") == "PHYSICAL_CONDUCTOR":
        row["flags"] |= NODE_FLAG_CONDUCTOR
        r.field(row, node, "IOR", "color", (2.757, 2.513, 2.231))
        r.field(row, node, "Extinction", "edge_tint", (3.867, 3.404, 3.009))
    else:
        r.color(node, "Base Color", row, "color", "color_texture")
        r.field(row, node, "Edge Tint", "edge_tint", (1.0, 1.0, 1.0))


def _emission(r: _Reader, node, row):
    row["type"] = NODE_EMISSION
    strength = r.val(node, "Strength") or r.compiler.const(1.0, 1)
    r.color(node, "Color", row, "emission", "emission_texture", (1.0, 1.0, 1.0),
            scale=strength)
    row["color"] = 0.0


def _holdout(r: _Reader, node, row):
    row["type"] = NODE_HOLDOUT


_READERS = {
    "ShaderNodeBsdfPrincipled": _principled,
    "ShaderNodeBsdfDiffuse": _simple(NODE_DIFFUSE),
    "ShaderNodeBsdfAnisotropic": _simple(NODE_GLOSSY),
    "ShaderNodeBsdfGlossy": _simple(NODE_GLOSSY),
    "ShaderNodeBsdfMetallic": _metallic,
    "ShaderNodeBsdfGlass": _simple(NODE_GLASS, (1.0, 1.0, 1.0)),
    "ShaderNodeBsdfRefraction": _simple(NODE_REFRACTION, (1.0, 1.0, 1.0)),
    "ShaderNodeBsdfTranslucent": _simple(NODE_TRANSLUCENT),
    "ShaderNodeBsdfTransparent": _simple(NODE_TRANSPARENT, (1.0, 1.0, 1.0)),
    "ShaderNodeBsdfSheen": _simple(NODE_SHEEN),
    "ShaderNodeBsdfVelvet": _simple(NODE_SHEEN),
    "ShaderNodeEmission": _emission,
    "ShaderNodeHoldout": _holdout,
}


def read_material(material, warn, textures=None, attributes: list | None = None,
                  camera=None, volume: list | None = None) -> tuple[np.ndarray, list,
                                                                     np.ndarray | None]:
    """(MATERIAL_DTYPE row, its BSDF nodes as SHADER_NODE_DTYPE rows or dicts, its shader
    program's words or None); ``attributes``: the scene's list of mesh attribute names read by
    programs, extended with this material's; ``camera``: the camera-to-world matrix of the
    camera space nodes read (Cycles' camera space, +z ahead); ``volume``: the program of its
    medium's density field is appended to it (a heterogeneous medium), if any."""
    reader = _Reader(material, warn, textures, attributes, camera)
    medium = read_volume(material, reader)
    row = _medium_row(medium)
    if medium is not None and medium.program is not None and volume is not None:
        volume.append(medium.program)
    nodes: list = []
    surface = _output_socket(material)
    if reader.graph.source(surface) is None:
        if medium is not None:
            # only a Volume output: the surface is a transparent boundary (as Cycles passes
            # through it), the medium inside
            nodes.append(dict(type=NODE_TRANSPARENT, color=(1.0, 1.0, 1.0),
                              flags=NODE_FLAG_VOLUME_BOUNDARY))
            return row, nodes, None
        reader.warn("no shader is connected to the material output; it renders black, as in "
                    "Cycles")
        return row, nodes, None
    if reader.graph.source(_output_socket(material, "Displacement")) is not None:
        reader.warn("its Displacement output is not rendered (Cycles renders it as bump "
                    "mapping or displacement; a Bump node on the BSDF's Normal is rendered)")
    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, _RECURSION))     # a long chain of nodes compiles deep
    try:
        reader.walk(surface, reader.compiler.const(1.0, 1), nodes)
    except RecursionError:
        reader.compiler.overflow = True
    finally:
        sys.setrecursionlimit(limit)
    if reader.compiler.overflow:          # a graph too large: the BSDFs' unlinked inputs
        reader.warn(f"its node graph needs more than {MAX_STACK} values at once; the graph is "
                    "not evaluated (its unlinked inputs are used)")
        reader = _Reader(material, lambda text: None, textures)
        reader.compiler.constants_only = True
        nodes = []
        reader.walk(surface, reader.compiler.const(1.0, 1), nodes)
    if not bump_map_correction(material):
        for n in nodes:                 # (rows from node_row)
            n["flags"] |= NODE_FLAG_NO_BUMP_CORRECTION
    return row, nodes, reader.compiler.program()


def read_volume_object(material, warn, textures=None, attributes: list | None = None,
                       camera=None, grids: tuple = (), scale: float = 1.0) -> tuple | None:
    """(MATERIAL_DTYPE row, its BSDF nodes, its density program or None) of ``material`` on a
    Volume object whose grids are named ``grids``, or None where its volume renders nothing (no
    Volume output; a default volume without a "density" grid): its Volume output alone, as
    Cycles renders a volume's material (its surface the medium's transparent boundary, a
    Principled Volume's Density times its Density Attribute's grid), Cycles' default volume
    where ``material`` is None (material_volume.default_volume); the coefficients times
    ``scale`` (Cycles' object-space density: 1 / the object's scale)."""
    reader = _Reader(material, warn, textures, attributes, camera)
    reader.grids = frozenset(grids)
    reader.scale = scale                  # (a grid's blackbody emission: material_volume._glow)
    medium = read_volume(material, reader) if material is not None else default_volume(reader)
    if medium is None:
        return None
    row = _medium_row(medium)
    for what in ("absorption", "scattering", "volume_emission"):
        row[what] *= scale
    return (row, [dict(type=NODE_TRANSPARENT, color=(1.0, 1.0, 1.0),
                                       flags=NODE_FLAG_VOLUME_BOUNDARY)], medium.program)


def _medium_row(medium) -> np.ndarray:
    """A MATERIAL_DTYPE row of a material's medium (read_volume; None: no volume)."""
    row = np.zeros(1, MATERIAL_DTYPE)
    if medium is not None:
        row["absorption"] = medium.absorption
        row["scattering"] = medium.scattering
        row["anisotropy"] = medium.anisotropy
        row["volume_emission"] = medium.emission
    return row


def bump_map_correction(material) -> bool:
    """Cycles' Bump Map Correction of the material (Material > Settings, on by default):
    whether the normals of its glossy, glass and translucent closures are raised towards the face
    where the view's mirror reflection about them would go below it."""
    return bool(getattr(getattr(material, "cycles", None), "use_bump_map_correction", True))
