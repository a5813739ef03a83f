"""The input nodes of a shader program: what a shading point is (Value, RGB, Texture
Coordinate, UV Map, Attribute, Color Attribute, Geometry) and its frame (Normal Map), each as
Cycles evaluates it; fn(compiler, node, output socket, group context) -> Val, using the
compiler's methods only (shader_graph.Compiler)."""
from __future__ import annotations

import numpy as np

from ppm_engine.blender.export.shader_values import Val, width
from ppm_engine.scene.shader_program import (
    GEOM_BACKFACING,
    GEOM_INCOMING,
    GEOM_LIGHT_PATH,
    GEOM_NORMAL,
    GEOM_OBJECT,
    GEOM_OBJECT_ALPHA,
    GEOM_OBJECT_COLOR,
    GEOM_OBJECT_INDEX,
    GEOM_OBJECT_LOCATION,
    GEOM_OBJECT_RANDOM,
    GEOM_POSITION,
    GEOM_REFLECTION,
    GEOM_TRUE_NORMAL,
    GEOM_UV,
    GEOM_WINDOW,
    LIGHT_PATH_OUTPUTS,
    MAPPING_CAMERA,
    MAPPING_OBJECT,
    MAPPING_TYPES,
    NORMAL_MAP_SPACES,
    PROGRAM_OBJECT,
    PROGRAM_TANGENTS,
    SVM_GEOMETRY,
    SVM_MAPPING,
    SVM_NORMAL_MAP,
    f2i,
)


def _value(c, node, out, ctx):
    return c.const(float(out.default_value), 1)


def _rgb(c, node, out, ctx):
    return c.const(tuple(out.default_value)[:3], 3)


def _transform(c, v: Val, m, kind: int) -> Val:
    """An SVM_MAPPING op: ``v`` by the rows of the 3x4 (or 4x4) matrix ``m`` as a point (kind
    0), a direction (2) or a normal (3: normalised); the MAPPING_OBJECT kinds use the shading
    object's own matrices (point, direction, normal to object space, then to world)."""
    s, o = c.slot(v), c.alloc(3)
    c.ops.append((SVM_MAPPING, o, s, kind))
    rows = np.zeros((3, 4)) if m is None else np.asarray(m, np.float64)[:3]
    for r in range(3):
        c.ops.append(tuple(f2i(float(x)) for x in rows[r]))
    if kind in MAPPING_OBJECT.values():
        c.flags |= PROGRAM_OBJECT
    return Val(3, slot=o)


def _to_camera(c, v: Val, to_camera: bool, kind: int, node) -> Val:
    """``v`` (a point, direction or normal: MAPPING_TYPES ``kind``) from world to camera space
    or back, by the render camera the program reads when it runs (MAPPING_CAMERA), so that a
    viewport's view that moves leaves the program as it is; without a camera (a material
    exported alone) camera space is world space, said in a warning."""
    if c.camera is None:
        c.warn(f"'{node.name}': no camera; camera space is world space")
        return v
    obj = {MAPPING_TYPES[k]: i for i, k in enumerate(("POINT", "VECTOR", "NORMAL"))}[kind]
    first = MAPPING_CAMERA["TO_CAMERA_POINT" if to_camera else "FROM_CAMERA_POINT"]
    return _transform(c, v, None, first + obj)


def _vector_transform(c, node, out, ctx):
    """Vector Transform between world, object and camera space, as Cycles chains them."""
    v = c.inp(node, "Vector", ctx, 3)
    kind = MAPPING_TYPES.get(node.vector_type, MAPPING_TYPES["POINT"])   # (no TEXTURE here)
    frm, to = node.convert_from, node.convert_to
    obj = {MAPPING_TYPES[k]: i for i, k in enumerate(("POINT", "VECTOR", "NORMAL"))}[kind]
    if frm == "WORLD" and to == "CAMERA":
        v = _to_camera(c, v, True, kind, node)
    elif frm == "WORLD" and to == "OBJECT":
        v = _transform(c, v, None, MAPPING_OBJECT["TO_OBJECT_POINT"] + obj)
    elif frm == "CAMERA" and to in ("WORLD", "OBJECT"):
        v = _to_camera(c, v, False, kind, node)
        if to == "OBJECT":
            v = _transform(c, v, None, MAPPING_OBJECT["TO_OBJECT_POINT"] + obj)
    elif frm == "OBJECT" and to in ("WORLD", "CAMERA"):
        v = _transform(c, v, None, MAPPING_OBJECT["TO_WORLD_POINT"] + obj)
        if to == "CAMERA":
            v = _to_camera(c, v, True, kind, node)
    return v


def _tex_coord(c, node, out, ctx):
    world = c.world                           # a world's: Generated = Object = the direction
    if out.name == "Generated" or (world and out.name == "Object"):
        return c.generated()
    if world and out.name == "Normal":
        return c.geometry(GEOM_NORMAL)
    if out.name == "Camera":
        return _to_camera(c, c.geometry(GEOM_POSITION), True, MAPPING_TYPES["POINT"], node)
    if out.name == "Object":
        if getattr(node, "object", None) is None:
            return c.geometry(GEOM_OBJECT)
        # another object's space: the position by that object's inverse matrix, a constant
        inv = np.linalg.inv(np.array(node.object.matrix_world, np.float64))
        return _transform(c, c.geometry(GEOM_POSITION), inv, 0)
    if out.name == "Normal":                    # the shading normal in object space
        return _transform(c, c.geometry(GEOM_NORMAL, moved=True), None,
                          MAPPING_OBJECT["TO_OBJECT_NORMAL"])
    what = {"UV": GEOM_UV, "Reflection": GEOM_REFLECTION,
            "Window": None if world else GEOM_WINDOW}.get(out.name)
    if what is None:
        c.warn(f"'{node.name}': the {out.name} texture coordinate is not evaluated yet; the UV "
               "map is used")
        what = GEOM_UV
    return c.geometry(what)


def _named_uv_map(c, node, name: str) -> None:
    """Warns when a node names a UV map other than the one exported (the mesh's rendered map,
    export/mesh.py render_uv_layer) on a mesh that uses the material and has both."""
    if not name or c.datablock is None:
        return
    key = ("uv name", name)
    if key in c.memo:
        return
    c.memo[key] = True
    import bpy

    from ppm_engine.blender.export.mesh import render_uv_layer
    for me in bpy.data.meshes:
        active = render_uv_layer(me)
        if (active is not None and active.name != name and name in me.uv_layers
                and c.datablock.name in me.materials):
            c.warn(f"'{node.name}' names the UV map '{name}' of mesh '{me.name}'; this engine "
                   f"reads the UV map it renders, '{active.name}'")
            return


def _attribute_output(c, node, out, name: str):
    """An attribute node's output: Color/Vector the attribute, Fac its average, Alpha its
    alpha, as Cycles' attribute node; 0 where it cannot be read."""
    if out.name == "Alpha":
        v = c.attribute(name, alpha=True)
    else:
        v = c.attribute(name)
        if v is not None and out.name in ("Fac", "Factor"):
            v = c.convert(v, 1, "vector")
    return v if v is not None else c.const(0.0, width(out.type))


def _attribute(c, node, out, ctx):
    """Attribute node: a mesh attribute by name (Geometry type); the object, instancer and
    view-layer types read no mesh data (warned, 0)."""
    if getattr(node, "attribute_type", "GEOMETRY") != "GEOMETRY":
        c.warn(f"'{node.name}' reads an {node.attribute_type.lower().replace('_', ' ')} "
               "attribute, which this engine does not evaluate (0)")
        return c.const(0.0, width(out.type))
    return _attribute_output(c, node, out, node.attribute_name)


def _color_attribute(c, node, out, ctx):
    """Color Attribute node: a colour attribute by name, or the mesh's default colour attribute
    when none is named ("" here; export resolves it per mesh)."""
    return _attribute_output(c, node, out, getattr(node, "layer_name", ""))


def _uv_map(c, node, out, ctx):
    _named_uv_map(c, node, getattr(node, "uv_map", ""))
    return c.geometry(GEOM_UV)


def _normal_map(c, node, out, ctx):
    """Cycles' Normal Map: a colour to a shading normal (kernels/svm/svm.h svm_normal_map); the
    tangent space's frame from the UV map's MikkTSpace tangents (SceneArrays.uv_tangents)."""
    space = NORMAL_MAP_SPACES.get(node.space, 0)
    if node.space in ("OBJECT", "BLENDER_OBJECT"):
        c.flags |= PROGRAM_OBJECT             # the object's matrices (svm_normal_map)
    if space == 0:
        _named_uv_map(c, node, getattr(node, "uv_map", ""))
        c.flags |= PROGRAM_TANGENTS
    col, strength = c.inp(node, "Color", ctx, 3), c.inp(node, "Strength", ctx, 1)
    sc, ss = c.slot(col), c.slot(strength)
    o = c.alloc(3)
    c.ops.append((SVM_NORMAL_MAP, o, sc, ss))
    c.ops.append((space, 0, 0, 0))
    return Val(3, slot=o)


def _object_info(c, node, out, ctx):
    """Object Info: the shading object's location, colour, alpha, pass index and random number
    (SceneArrays.objects); the material's pass index a constant."""
    if out.name == "Material Index":
        return c.const(float(getattr(c.datablock, "pass_index", 0)), 1)
    what = {"Location": GEOM_OBJECT_LOCATION, "Color": GEOM_OBJECT_COLOR,
            "Alpha": GEOM_OBJECT_ALPHA, "Object Index": GEOM_OBJECT_INDEX,
            "Random": GEOM_OBJECT_RANDOM}.get(out.name)
    if what is None:
        c.warn(f"'{node.name}': the Object Info output {out.name} is not evaluated (0)")
        return c.const(0.0, width(out.type))
    return c.geometry(what)


def _light_path(c, node, out, ctx):
    """Light Path: the type and bounces of the ray that reached the point
    (kernels/integrator/path_state.h; photons' rays are never camera rays)."""
    if out.name not in LIGHT_PATH_OUTPUTS:
        c.warn(f"'{node.name}': the Light Path output {out.name} is not evaluated (0)")
        return c.const(0.0, width(out.type))
    s = c.alloc(1)
    c.ops.append((SVM_GEOMETRY, s, GEOM_LIGHT_PATH, LIGHT_PATH_OUTPUTS.index(out.name)))
    return Val(1, slot=s)


def _geometry_node(c, node, out, ctx):
    what = {"Position": GEOM_POSITION, "Normal": GEOM_NORMAL, "True Normal": GEOM_TRUE_NORMAL,
            "Incoming": GEOM_INCOMING, "Backfacing": GEOM_BACKFACING}.get(out.name)
    if what is None:
        c.warn(f"'{node.name}': the Geometry output {out.name} is not evaluated yet (0)")
        return c.const(0.0, width(out.type))
    return c.geometry(what)


INPUT_NODES = {
    "ShaderNodeValue": _value, "ShaderNodeRGB": _rgb,
    "ShaderNodeTexCoord": _tex_coord, "ShaderNodeUVMap": _uv_map,
    "ShaderNodeAttribute": _attribute, "ShaderNodeVertexColor": _color_attribute,
    "ShaderNodeNewGeometry": _geometry_node, "ShaderNodeNormalMap": _normal_map,
    "ShaderNodeObjectInfo": _object_info, "ShaderNodeLightPath": _light_path,
    "ShaderNodeVectorTransform": _vector_transform,
}
