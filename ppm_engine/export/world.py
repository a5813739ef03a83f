"""The world: a constant background colour x strength."""
from __future__ import annotations

import numpy as np


def export_world(world, warn) -> np.ndarray:
    if world is None:
        return np.zeros(3, np.float32)
    tree = world.node_tree
    if tree is None:
        return np.array(world.color[:3], np.float32)
    out = tree.get_output_node('CYCLES') or tree.get_output_node('ALL')
    sock = out.inputs.get("Surface") if out is not None else None
    if sock is None or not sock.is_linked:
        return np.zeros(3, np.float32)
    node = sock.links[0].from_node
    if node.bl_idname != "ShaderNodeBackground":
        warn(f"World '{world.name}': only a Background shader is supported; the world is black")
        return np.zeros(3, np.float32)
    color, strength = node.inputs["Color"], node.inputs["Strength"]
    if color.is_linked or strength.is_linked:
        warn(f"World '{world.name}': textures on the background are not evaluated; its "
             "unlinked colour is used")
    return (np.array(color.default_value[:3], np.float32) * float(strength.default_value)).astype(np.float32)
