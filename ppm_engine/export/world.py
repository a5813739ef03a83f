"""The world: a constant background radiance = colour x strength (Cycles units)."""
from __future__ import annotations

import numpy as np

_SHADERS = ("ShaderNodeBackground", "ShaderNodeEmission")   # identical for a world in Cycles


def export_world(world, warn) -> np.ndarray:
    if world is None:
        return np.zeros(3, np.float32)
    approx = np.array(world.color[:3], np.float32)          # the world's viewport colour
    tree = world.node_tree
    if tree is None:
        return approx
    out = tree.get_output_node('CYCLES') or tree.get_output_node('ALL')
    sock = out.inputs.get("Surface") if out is not None else None
    if sock is None or not sock.is_linked:
        return np.zeros(3, np.float32)                      # Cycles: no surface = black
    node = sock.links[0].from_node
    if node.bl_idname not in _SHADERS:
        warn(f"World '{world.name}': only a Background shader is supported; the world is "
             "approximated by its viewport colour")
        return approx
    color, strength = node.inputs["Color"], node.inputs["Strength"]
    if color.is_linked or strength.is_linked:
        warn(f"World '{world.name}': textures on the background are not evaluated; its "
             "unlinked colour and strength are used")
    return (np.array(color.default_value[:3], np.float64)
            * float(strength.default_value)).astype(np.float32)
