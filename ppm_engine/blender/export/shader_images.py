"""The image nodes of a shader program (kernels/svm/svm_image.h runs them): the Image Texture with
its interpolations (the texture table's flags, export/textures.py), its Flat, Box (with
Projection Blend), Sphere and Tube projections and UDIM tiles, and the Environment Texture
(equirectangular, mirror ball), each as Cycles evaluates it.  fn(compiler, node, output
socket, group context) -> Val, like the other value nodes (shader_nodes.py)."""
from __future__ import annotations

from ppm_engine.blender.export.shader_inputs import _transform
from ppm_engine.blender.export.shader_values import Val, width
from ppm_engine.scene.shader_program import GEOM_NORMAL, GEOM_UV, IMAGE_PROJECTIONS, SVM_IMAGE, f2i

BOX = IMAGE_PROJECTIONS["BOX"]


def _tiled(node, projection: int) -> bool:
    """Whether the node reads a UDIM image by tiles (Cycles' box projection reads tile 1001
    only: its coordinates lie in that tile)."""
    return node.image.source == "TILED" and projection != BOX


def _no_image(c, node, out, projection: int):
    """The constant an image node gives without its image (no table: 1; missing: magenta), or
    None when its image (or a UDIM image's tiles) is in the texture table."""
    if c.textures is None:
        return c.const(1.0, width(out.type))
    if node.image is not None and _tiled(node, projection):
        return None
    tex, missing = c.textures.image_index(node, c.material)
    if not tex:
        return c.const(missing if out.name == "Color" else (1.0,), width(out.type))
    return None


def _image(c, node, out, ctx):
    projection = IMAGE_PROJECTIONS.get(getattr(node, "projection", "FLAT"), 0)
    if (v := _no_image(c, node, out, projection)) is not None:
        return v
    vec = node.inputs.get("Vector")
    v = c.input(node, vec, ctx, 3) if c.graph.source(vec, ctx) is not None else \
        c.geometry(GEOM_UV)
    return _image_op(c, node, out, ctx, v, projection)


def _image_op(c, node, out, ctx, v, projection: int):
    """The op of an image node's texture at vector ``v`` (shader_program IMAGE_PROJECTIONS)."""
    key = c.node_key("image", node, ctx)
    if key not in c.memo:
        tiles, tex = [], 0
        if _tiled(node, projection):
            tiles = c.textures.tiles(node, c.material)
        else:
            tex, _ = c.textures.image_index(node, c.material)
        texs = [t for _, t in tiles if t] if tiles else [tex]
        unassociate = any(c.textures.unassociates(node, t) for t in texs if t)
        sv, normal, blend = c.slot(v), 0, 0.0
        if projection == BOX:          # the shading normal in object space (a world's: as is)
            n = c.geometry(GEOM_NORMAL)
            normal = c.slot(n if c.world else _transform(c, n, None, 6))
            blend = float(node.projection_blend)
        col, alpha = c.alloc(3), c.alloc(1)
        pairs = tiles + [(0, 0)] * (len(tiles) % 2)
        words = [(pairs[k][0], pairs[k][1], pairs[k + 1][0], pairs[k + 1][1])
                 for k in range(0, len(pairs), 2)]
        c.ops.append((SVM_IMAGE, col, alpha, sv))
        c.ops.append((tex, int(unassociate), projection, len(words)))
        c.ops.append((f2i(blend), normal, 0, 0))
        c.ops.extend(words)
        c.memo[key] = (col, alpha)
    col, alpha = c.memo[key]
    return Val(3, slot=col) if out.name == "Color" else Val(1, slot=alpha)


def _environment(c, node, out, ctx):
    """Cycles' Environment Texture: the image at the equirectangular or mirror ball (u, v) of
    its Vector (normalised; unlinked: the position, for a world the ray's direction)."""
    projection = IMAGE_PROJECTIONS.get(getattr(node, "projection", "EQUIRECTANGULAR"), 1)
    if (v := _no_image(c, node, out, projection)) is not None:
        return v
    sizes = getattr(c, "env_sizes", None)
    if sizes is not None:
        sizes.append(tuple(node.image.size))
    vec = node.inputs.get("Vector")
    v = c.input(node, vec, ctx, 3) if c.graph.source(vec, ctx) is not None else c.generated()
    return _image_op(c, node, out, ctx, v, projection)


IMAGE_NODES = {"ShaderNodeTexImage": _image, "ShaderNodeTexEnvironment": _environment}
