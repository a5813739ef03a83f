"""Material node trees -> MATERIAL_DTYPE rows and their BSDF nodes (SHADER_NODE_DTYPE).

The Surface output is walked from the Cycles material output: Mix Shader and Add Shader nodes
fold into each BSDF node's weight (as Cycles propagates them into its closures), reroutes and
muted nodes pass through, and each BSDF node's inputs are read as constants; an Image Texture
on a colour input (Base Color, Color, Emission Color) or its Alpha on Principled's Alpha
becomes a texture of the node (textures.py).  Anything else linked into an input is warned
about once and its unlinked value used; a shader node this engine has no closure for is warned
about and rendered as the nearest one.  The Volume output's absorption (Volume Absorption, the
absorbing part of Principled Volume) -> the row's absorption coefficient."""
from __future__ import annotations

import numpy as np

from ..scene_arrays import (MATERIAL_DTYPE, NODE_DIFFUSE, NODE_EMISSION, NODE_FLAG_CONDUCTOR,
                            NODE_FLAG_MULTI_GGX, NODE_GLASS, NODE_GLOSSY, NODE_HOLDOUT,
                            NODE_METALLIC, NODE_PRINCIPLED, NODE_REFRACTION, NODE_SHEEN,
                            NODE_TRANSLUCENT, NODE_TRANSPARENT, SHADER_NODE_DTYPE,
                            anisotropic_nodes, shader_node)

DEFAULT_NAME = "(default grey)"
_MAX_DEPTH = 64

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
_UNSUPPORTED_INPUTS = {"Normal": "normal maps and bump come with the node graphs; the surface's "
                                 "own normal is used",
                       "Coat Normal": "normal maps and bump come with the node graphs; the "
                                      "surface's own normal is used",
                       "Tangent": "tangents come with the node graphs; Cycles' default, the "
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


def _from(socket):
    """The node feeding ``socket`` through reroutes and muted nodes, or None."""
    for _ in range(_MAX_DEPTH):
        if socket is None or not socket.is_linked:
            return None
        link = socket.links[0]
        if not link.is_valid or link.is_muted:
            return None
        node = link.from_node
        if node.bl_idname == "NodeReroute":
            socket = node.inputs[0]
        elif node.mute:
            # a muted node passes its first input of the output's type through
            socket = next((s for s in node.inputs if s.type == link.from_socket.type), None)
        else:
            return node
    return None


class _Reader:
    """Reads one material's BSDF nodes, warning once per problem."""

    def __init__(self, material, warn, textures):
        self.name = material.name
        self.warn_fn = warn
        self.textures = textures
        self.said = set()

    def warn(self, text):
        if text not in self.said:
            self.said.add(text)
            self.warn_fn(f"Material '{self.name}': {text}")

    def value(self, node, name, n=None, default=None):
        sock = node.inputs.get(name)
        if sock is None or not getattr(sock, "enabled", True):
            return default
        if sock.is_linked and _from(sock) is not None:
            self.warn(f"'{name}' of '{node.name}' is driven by a node link this engine does not "
                      "evaluate; its unlinked value is used")
        v = sock.default_value
        return tuple(v)[:n] if n else float(v)

    def color(self, node, name, row, field, texture_field, default=(0.8, 0.8, 0.8)):
        """A colour input: an Image Texture becomes the node's texture (white constant)."""
        sock = node.inputs.get(name)
        if self.textures is not None and sock is not None:
            tex, constant = self.textures.from_socket(sock, name, self.name)
            if tex:
                row[field], row[texture_field] = (1.0, 1.0, 1.0), tex
                return
            if constant is not None:
                row[field] = constant
                return
        row[field] = self.value(node, name, 3, default)

    def distribution(self, node, row):
        d = getattr(node, "distribution", "GGX")
        rough = self.value(node, "Roughness", default=0.0) or 0.0
        if d in ("BECKMANN", "ASHIKHMIN_SHIRLEY") and rough > 0.0:
            self.warn(f"'{node.name}' uses the {d.replace('_', '-').title()} distribution; "
                      "this engine renders GGX")
        row["flags"] = NODE_FLAG_MULTI_GGX if d == "MULTI_GGX" else 0

    def unsupported_inputs(self, node):
        for name, what in _UNSUPPORTED_INPUTS.items():
            sock = node.inputs.get(name)
            if sock is not None and sock.is_linked and _from(sock) is not None:
                self.warn(f"'{name}' of '{node.name}' is not evaluated ({what})")

    # --- one BSDF node ------------------------------------------------------------------------
    def node_row(self, node, weight: float) -> dict | None:
        kind = node.bl_idname
        row = shader_node(NODE_DIFFUSE)
        make = _READERS.get(kind)
        if make is None:
            return self.fallback(node, weight)
        make(self, node, row)
        row["weight"] = weight
        self.unsupported_inputs(node)
        return row

    def fallback(self, node, weight):
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
            return dict(type=NODE_DIFFUSE, color=(0.8, 0.8, 0.8), weight=weight)
        self.warn(f"'{node.name}' ({node.bl_label}) renders as {near}")
        row = shader_node(NODE_DIFFUSE)
        if kind == "ShaderNodeBsdfRayPortal":
            row["type"] = NODE_TRANSPARENT
            self.color(node, "Color", row, "color", "color_texture", (1.0, 1.0, 1.0))
        elif kind == "ShaderNodeBackground":
            row["type"] = NODE_EMISSION
            row["emission"] = (np.asarray(self.value(node, "Color", 3, (1, 1, 1)), np.float32)
                               * (self.value(node, "Strength", default=1.0) or 0.0))
        else:
            self.color(node, "Color", row, "color", "color_texture")
        row["weight"] = weight
        return row

    # --- the tree -----------------------------------------------------------------------------
    def walk(self, socket, weight: float, out: list, depth: int = 0) -> None:
        node = _from(socket)
        if node is None or weight <= 0.0:
            return
        if depth > _MAX_DEPTH:
            self.warn("its shader tree is too deep; the rest is not rendered")
            return
        kind = node.bl_idname
        if kind == "ShaderNodeMixShader":
            fac = self.value(node, "Fac", default=None)
            if fac is None:
                fac = float(node.inputs[0].default_value)
                if node.inputs[0].is_linked:
                    self.warn(f"the factor of '{node.name}' is driven by a node link this engine "
                              "does not evaluate; its unlinked value is used")
            fac = min(max(fac, 0.0), 1.0)
            self.walk(node.inputs[1], weight * (1.0 - fac), out, depth + 1)
            self.walk(node.inputs[2], weight * fac, out, depth + 1)
        elif kind == "ShaderNodeAddShader":
            self.walk(node.inputs[0], weight, out, depth + 1)
            self.walk(node.inputs[1], weight, out, depth + 1)
        elif kind == "ShaderNodeGroup":
            self.warn(f"the node group '{node.name}' on the surface is not evaluated (node groups "
                      "come with the node graphs); it renders as grey diffuse")
            out.append(dict(type=NODE_DIFFUSE, color=(0.8, 0.8, 0.8), weight=weight))
        else:
            row = self.node_row(node, weight)
            if row is not None:
                out.append(row)


def _principled(r: _Reader, node, row):
    row["type"] = NODE_PRINCIPLED
    r.color(node, "Base Color", row, "color", "color_texture")
    for name, field in _PRINCIPLED_SCALARS.items():
        v = r.value(node, name)
        if v is not None:
            row[field] = v
    for name, field in _PRINCIPLED_COLORS.items():
        v = r.value(node, name, 3)
        if v is not None:
            row[field] = v
    alpha = node.inputs.get("Alpha")
    tex, _ = (r.textures.from_socket(alpha, "Alpha", r.name, output="Alpha")
              if r.textures is not None and alpha is not None else (0, None))
    if tex:
        row["alpha"], row["alpha_texture"] = 1.0, tex
    else:
        row["alpha"] = r.value(node, "Alpha", default=1.0)
    strength = r.value(node, "Emission Strength", default=0.0) or 0.0
    if strength:
        r.color(node, "Emission Color", row, "emission", "emission_texture", (1.0, 1.0, 1.0))
        row["emission"] *= strength
    else:
        row["emission"] = 0.0
    r.distribution(node, row)
    if (r.value(node, "Subsurface Weight", default=0.0) or 0.0) > 0.0:
        r.warn("subsurface scattering renders as diffuse (its radius and scale are ignored)")
    if (r.value(node, "Thin Film Thickness", default=0.0) or 0.0) > 0.1:
        r.warn("thin-film iridescence is not rendered")


def _simple(kind, color_default=(0.8, 0.8, 0.8)):
    def read(r: _Reader, node, row):
        row["type"] = kind
        r.color(node, "Color", row, "color", "color_texture", color_default)
        if kind in (NODE_DIFFUSE, NODE_SHEEN, NODE_GLOSSY, NODE_GLASS, NODE_REFRACTION):
            row["roughness"] = r.value(node, "Roughness", default=0.0)
        if kind in (NODE_GLASS, NODE_REFRACTION):
            row["ior"] = r.value(node, "IOR", default=1.5)
        if kind == NODE_GLOSSY:
            row["anisotropic"] = r.value(node, "Anisotropy", default=0.0)
            row["anisotropic_rotation"] = r.value(node, "Rotation", default=0.0)
        if kind in (NODE_GLOSSY, NODE_GLASS, NODE_REFRACTION):
            r.distribution(node, row)
        if kind == NODE_SHEEN and getattr(node, "distribution", "MICROFIBER") != "MICROFIBER":
            r.warn(f"'{node.name}' uses the Ashikhmin sheen; this engine renders Microfiber")
        if kind == NODE_GLASS and (r.value(node, "Thin Film Thickness", default=0.0) or 0) > 0.1:
            r.warn("thin-film iridescence is not rendered")
    return read


def _metallic(r: _Reader, node, row):
    row["type"] = NODE_METALLIC
    row["roughness"] = r.value(node, "Roughness", default=0.5)
    row["anisotropic"] = r.value(node, "Anisotropy", default=0.0)
    row["anisotropic_rotation"] = r.value(node, "Rotation", default=0.0)
    r.distribution(node, row)
    if getattr(node, "fresnel_type", "F82") == "PHYSICAL_CONDUCTOR":
        row["flags"] |= NODE_FLAG_CONDUCTOR
        row["color"] = r.value(node, "IOR", 3, (2.757, 2.513, 2.231))
        row["edge_tint"] = r.value(node, "Extinction", 3, (3.867, 3.404, 3.009))
    else:
        r.color(node, "Base Color", row, "color", "color_texture")
        row["edge_tint"] = r.value(node, "Edge Tint", 3, (1.0, 1.0, 1.0))


def _emission(r: _Reader, node, row):
    row["type"] = NODE_EMISSION
    strength = r.value(node, "Strength", default=1.0) or 0.0
    r.color(node, "Color", row, "emission", "emission_texture", (1.0, 1.0, 1.0))
    row["emission"] *= strength
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


def read_absorption(material, reader: _Reader) -> tuple:
    """The absorption coefficient (per metre, RGB) of the material's Volume output, as Cycles
    computes it: Volume Absorption (1 - colour) x density; Principled Volume the absorbing part
    of its extinction, (1 - colour)(1 - sqrt(absorption colour)) x density.  Scattering is not
    rendered (a warning says so); the medium applies inside glass (entered by refraction)."""
    node = _from(_output_socket(material, "Volume"))
    if node is None:
        return (0.0, 0.0, 0.0)
    kind = node.bl_idname
    if kind == "ShaderNodeVolumeAbsorption":
        color = np.maximum(reader.value(node, "Color", 3), 0.0)
        density = max(reader.value(node, "Density"), 0.0)
        return tuple((1.0 - color) * density)
    if kind == "ShaderNodeVolumePrincipled":
        color = np.asarray(reader.value(node, "Color", 3), np.float64)
        density = max(reader.value(node, "Density"), 0.0)
        absorbing = np.sqrt(np.maximum(reader.value(node, "Absorption Color", 3), 0.0))
        if density > 0 and color.max() > 0:
            reader.warn("the Principled Volume scatters light, which this engine does not "
                        "render: only its absorption is used")
        return tuple(np.maximum(1.0 - color, 0.0) * np.maximum(1.0 - absorbing, 0.0) * density)
    reader.warn(f"the volume shader '{node.name}' is not rendered (this engine renders Volume "
                "Absorption and Principled Volume's absorption); the inside is clear")
    return (0.0, 0.0, 0.0)


def read_material(material, warn, textures=None) -> tuple[np.ndarray, list]:
    """(MATERIAL_DTYPE row, its BSDF nodes as SHADER_NODE_DTYPE rows or dicts)."""
    reader = _Reader(material, warn, textures)
    row = np.zeros(1, MATERIAL_DTYPE)
    row["absorption"] = read_absorption(material, reader)
    nodes: list = []
    surface = _output_socket(material)
    if _from(surface) is None:
        reader.warn("no shader is connected to the material output; it renders black, as in "
                    "Cycles")
        return row, nodes
    reader.walk(surface, 1.0, nodes)
    return row, nodes


class MaterialTable:
    """Materials deduplicated by (full) name; index 0 is the default grey diffuse."""

    def __init__(self, warn, textures=None):
        self.warn = warn
        self.textures = textures          # textures.TextureTable (None: textures not read)
        row, nodes = default_row()
        self.rows = [row]
        self.nodes = [nodes]
        self.names = [DEFAULT_NAME]
        self._index = {}

    def index(self, material) -> int:
        if material is None:
            return 0
        key = material.name_full
        if key not in self._index:
            self._index[key] = len(self.rows)
            row, nodes = read_material(material, self.warn, self.textures)
            self.rows.append(row)
            self.nodes.append(nodes)
            self.names.append(material.name)
        return self._index[key]

    def slot_map(self, obj) -> np.ndarray:
        """Global material index for each of the object's slots (at least one entry)."""
        slots = [self.index(s.material) if s is not None else 0 for s in obj.material_slots]
        return np.array(slots or [0], np.int32)

    def anisotropic(self, slots: np.ndarray) -> bool:
        """Whether a material of these (global) slots is anisotropic: it needs tangents."""
        for k in set(int(i) for i in slots):
            rows = [shader_node(**n) if isinstance(n, dict) else n for n in self.nodes[k]]
            if rows and anisotropic_nodes(np.concatenate(rows)).any():
                return True
        return False

    def array(self) -> np.ndarray:
        return np.concatenate(self.rows)

    def node_array(self) -> np.ndarray:
        """Every material's BSDF nodes, ordered by material."""
        rows = []
        for k, nodes in enumerate(self.nodes):
            for n in nodes:
                if isinstance(n, dict):
                    n = shader_node(**n)
                n = n.copy()
                n["material"] = k
                rows.append(n)
        return np.concatenate(rows) if rows else np.zeros(0, SHADER_NODE_DTYPE)
