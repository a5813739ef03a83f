"""The world: a constant background radiance = colour x strength (Cycles units), or, when the
Background's Color or Strength comes from a node graph (an HDRI through an Environment
Texture, Mapping, Math, ...), that graph compiled into a shader program (shader_graph.Compiler)
whose one bound value is colour x strength (kernels/svm/svm.h svm_world).  Its Volume output:
a homogeneous medium filling the space outside every object (world_medium), read as a
material's (material_volume.py)."""
from __future__ import annotations

import numpy as np

from ppm_engine.blender.export.material_volume import ConstantInputs, read_volume
from ppm_engine.blender.export.shader_graph import Compiler, Graph
from ppm_engine.scene.arrays import MATERIAL_DTYPE, WORLD_HIDDEN_CAMERA, WORLD_MAP_MANUAL

_SHADERS = ("ShaderNodeBackground", "ShaderNodeEmission")   # identical for a world in Cycles


class WorldCompiler(Compiler):
    """The compiler with a world's coordinates (Generated and Object: the ray's direction) and
    its warnings named by the world."""
    world = True
    owner = "World"

    def __init__(self, name, warn, textures, graph):
        super().__init__(name, warn, textures, graph)
        self.env_sizes: list = []


def export_world(world, warn, textures=None, base: int = 0):
    """(radiance (3,) float32, program words or None, world_shader (4,) int32): the program is
    to be placed at word ``base`` of SceneArrays.svm."""
    shader = np.zeros(4, np.int32)
    if world is None:
        return np.zeros(3, np.float32), None, shader
    vis = getattr(world, "cycles_visibility", None)
    if vis is not None and not getattr(vis, "camera", True):
        shader[1] |= WORLD_HIDDEN_CAMERA
    approx = np.array(world.color[:3], np.float32)          # the world's viewport colour
    tree = world.node_tree
    if tree is None:
        return approx, None, shader
    out = tree.get_output_node('CYCLES') or tree.get_output_node('ALL')
    sock = out.inputs.get("Surface") if out is not None else None
    graph = Graph(warn)
    src = graph.source(sock) if sock is not None else None
    if src is None:
        return np.zeros(3, np.float32), None, shader       # Cycles: no surface = black
    node, _, ctx = src
    if node.bl_idname not in _SHADERS:
        warn(f"World '{world.name}': only a Background shader is supported, not "
             f"'{node.name}' ({node.bl_label}); the world is its viewport colour")
        return approx, None, shader
    color, strength = node.inputs["Color"], node.inputs["Strength"]
    const = (np.array(color.default_value[:3], np.float64)
             * float(strength.default_value)).astype(np.float32)
    if textures is None or (graph.source(color, ctx) is None
                            and graph.source(strength, ctx) is None):
        return const, None, shader
    c = WorldCompiler(world.name, warn, textures, graph)
    v = c.scale(c.inp(node, "Color", ctx, 3), c.inp(node, "Strength", ctx, 1))
    lacking = [t for t in c.said if "not evaluated" in t or "could not be read" in t]
    if lacking:                          # a Sky Texture, Light Path, ...: not this sky at all
        warn(f"World '{world.name}': a node of its graph is not evaluated (above); the world "
             "is approximated by its viewport colour")
        return approx, None, shader
    if v.is_const:                                      # folded to a constant
        return np.array(v.const[:3], np.float32), None, shader
    c.binds.append((0, 0, 3, c.slot(v)))      # the radiance: svm_world reads bind 0's slots
    words = c.program()
    if words is None:                         # (program() refuses an overflowing stack)
        warn(f"World '{world.name}': its node graph needs more values than a shader program "
             "holds; its unlinked colour and strength are used")
        return const, None, shader
    shader[0] = base
    cw = getattr(world, "cycles", None)
    if cw is not None and getattr(cw, "sampling_method", "AUTOMATIC") == "MANUAL":
        res = int(getattr(cw, "sample_map_resolution", 1024))
        shader[1] |= WORLD_MAP_MANUAL
        shader[2], shader[3] = res, max(res // 2, 1)
    elif c.env_sizes:
        shader[2] = max(s[0] for s in c.env_sizes)
        shader[3] = max(s[1] for s in c.env_sizes)
    return const, words, shader


class _VolumeReader(ConstantInputs):
    """material_volume's reader of the world's Volume output, its warnings named by the world:
    no grids, and no density field (a Density driven by nodes is warned about and read as its
    unlinked value: the world's medium is homogeneous)."""
    grids = None
    fields = False

    def __init__(self, world, warn):
        self.graph = Graph(warn)
        self.warn = WorldCompiler(world.name, warn, None, self.graph).warn


def world_medium(world, warn) -> np.ndarray | None:
    """The world's Volume output as a MATERIAL_DTYPE row (1,) (its homogeneous medium, summed
    as a material's: material_volume.read_volume), or None where nothing is connected.  Cycles
    fills the space outside every object with it: the bottom of every volume stack, a mesh's
    medium inside it added to it (materials.kernel_materials), and a ray that leaves the scene
    through it goes on forever (no background, no sun where it has extinction)."""
    if world is None or world.node_tree is None:
        return None
    medium = read_volume(world, _VolumeReader(world, warn))
    if medium is None:
        return None
    row = np.zeros(1, MATERIAL_DTYPE)
    row["absorption"] = medium.absorption
    row["scattering"] = medium.scattering
    row["anisotropy"] = medium.anisotropy
    row["volume_emission"] = medium.emission
    return row
