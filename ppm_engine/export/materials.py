"""Principled BSDF and Emission node trees -> MATERIAL_DTYPE rows (image textures on the base
and emission colours: textures.py); the Volume output's absorption (Volume Absorption, the
absorbing part of Principled Volume) -> the row's absorption coefficient."""
from __future__ import annotations

import numpy as np

from ..scene_arrays import MATERIAL_DTYPE

DEFAULT_NAME = "(default grey)"


def _value(node, name, warn, mat_name, n=None):
    sock = node.inputs.get(name)
    if sock is None:
        return None
    if sock.is_linked:
        warn(f"Material '{mat_name}': '{name}' is driven by a node link this engine does not "
             "evaluate; its unlinked value is used")
    v = sock.default_value
    return tuple(v)[:n] if n else float(v)


def _surface_node(material, socket="Surface"):
    """The shader node linked to the Cycles material output's ``socket`` (through reroutes)."""
    tree = material.node_tree
    if tree is None:
        return None
    out = tree.get_output_node('CYCLES') or tree.get_output_node('ALL')
    if out is None:
        return None
    sock = out.inputs.get(socket)
    if sock is None or not sock.is_linked:
        return None
    node = sock.links[0].from_node
    for _ in range(64):                       # follow reroutes (bounded: no cycles possible)
        if node.bl_idname != "NodeReroute" or not node.inputs[0].is_linked:
            break
        node = node.inputs[0].links[0].from_node
    return node


def default_row() -> np.ndarray:
    """Grey (0.8) Lambertian diffuse: empty slots, missing and unsupported materials."""
    row = np.zeros(1, MATERIAL_DTYPE)
    row["base_color"], row["roughness"], row["ior"] = 0.8, 1.0, 1.5
    return row


def _color(node, socket_name, warn, mat_name, textures, field_row, texture_field):
    """A colour input: an Image Texture node's texture (the colour becomes white and the texture
    multiplies it) or the socket's value.  Returns the RGB to use."""
    if textures is not None:
        tex, constant = textures.from_socket(node.inputs.get(socket_name), socket_name, mat_name)
        if tex:
            field_row[texture_field] = tex
            return (1.0, 1.0, 1.0)
        if constant is not None:
            return constant
    return _value(node, socket_name, warn, mat_name, 3)


def read_absorption(material, warn) -> tuple:
    """The absorption coefficient (per metre, RGB) of the material's Volume output, as Cycles
    computes it: Volume Absorption (1 - colour) x density; Principled Volume the absorbing part
    of its extinction, (1 - colour)(1 - sqrt(absorption colour)) x density.  Scattering is not
    rendered (a warning says so); the medium applies inside glass (entered by refraction)."""
    node = _surface_node(material, "Volume")
    if node is None:
        return (0.0, 0.0, 0.0)
    name, kind = material.name, node.bl_idname
    if kind == "ShaderNodeVolumeAbsorption":
        color = np.maximum(_value(node, "Color", warn, name, 3), 0.0)
        density = max(_value(node, "Density", warn, name), 0.0)
        return tuple((1.0 - color) * density)
    if kind == "ShaderNodeVolumePrincipled":
        color = np.asarray(_value(node, "Color", warn, name, 3), np.float64)
        density = max(_value(node, "Density", warn, name), 0.0)
        absorbing = np.sqrt(np.maximum(_value(node, "Absorption Color", warn, name, 3), 0.0))
        if density > 0 and color.max() > 0:
            warn(f"Material '{name}': the Principled Volume scatters light, which this engine "
                 "does not render: only its absorption is used")
        return tuple(np.maximum(1.0 - color, 0.0) * np.maximum(1.0 - absorbing, 0.0) * density)
    warn(f"Material '{name}': the volume shader '{node.name}' is not rendered (this engine "
         "renders Volume Absorption and Principled Volume's absorption); the inside is clear")
    return (0.0, 0.0, 0.0)


def read_material(material, warn, textures=None) -> np.ndarray:
    row = default_row()
    row["absorption"] = read_absorption(material, warn)
    node = _surface_node(material)
    name = material.name
    kind = node.bl_idname if node is not None else None
    if kind == "ShaderNodeBsdfPrincipled":
        row["base_color"] = _color(node, "Base Color", warn, name, textures, row,
                                   "base_color_texture")
        row["metallic"] = _value(node, "Metallic", warn, name)
        row["roughness"] = _value(node, "Roughness", warn, name)
        tw = _value(node, "Transmission Weight", warn, name)
        row["transmission"] = tw if tw is not None else 0.0
        row["ior"] = _value(node, "IOR", warn, name)
        es = _value(node, "Emission Strength", warn, name) or 0.0
        ec = (_color(node, "Emission Color", warn, name, textures if es else None, row,
                     "emission_texture") or (0.0, 0.0, 0.0))
        row["emission"] = np.asarray(ec, np.float32) * es
    elif kind == "ShaderNodeEmission":
        s = _value(node, "Strength", warn, name)
        c = _color(node, "Color", warn, name, textures if s else None, row, "emission_texture")
        row["base_color"] = 0.0
        row["emission"] = np.asarray(c, np.float32) * s
    else:
        what = f"a '{node.name}' node" if node is not None else "no shader connected to the output"
        warn(f"Material '{name}' has {what}; this engine renders Principled BSDF and Emission "
             "shaders only, so it is rendered as grey diffuse")
    return row


class MaterialTable:
    """Materials deduplicated by (full) name; index 0 is the default grey diffuse."""

    def __init__(self, warn, textures=None):
        self.warn = warn
        self.textures = textures          # textures.TextureTable (None: textures not read)
        self.rows = [default_row()]
        self.names = [DEFAULT_NAME]
        self._index = {}

    def index(self, material) -> int:
        if material is None:
            return 0
        key = material.name_full
        if key not in self._index:
            self._index[key] = len(self.rows)
            self.rows.append(read_material(material, self.warn, self.textures))
            self.names.append(material.name)
        return self._index[key]

    def slot_map(self, obj) -> np.ndarray:
        """Global material index for each of the object's slots (at least one entry)."""
        slots = [self.index(s.material) if s is not None else 0 for s in obj.material_slots]
        return np.array(slots or [0], np.int32)

    def array(self) -> np.ndarray:
        return np.concatenate(self.rows)
