"""What node trees give the bpy scene's LuxCore translation (luxcore_scene.py, whose docstring
says what translates and how): a material's properties and emission, the world's constant
background, from constant node values only; and the ``Translation`` the pieces are collected
in, with ``Unsupported`` for anything that has no exact LuxCore counterpart."""
from __future__ import annotations

import numpy as np

DEFAULT_GREY = (0.8, 0.8, 0.8)    # Cycles' surface without a material
EPS = 1e-6


class Unsupported(ValueError):
    """Something in the scene has no exact LuxCore counterpart in this translation."""


class Translation:
    """LuxCore scene properties (name -> value) and meshes (name -> vertices, triangles,
    normals) of one bpy scene."""

    def __init__(self):
        self.props: dict[str, object] = {}
        self.meshes: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray | None]] = {}
        self.objects: dict[str, dict] = {}
        self.lights = 0
        # for enclosed_emission: each emitter's points (N, 3) with the property holding its
        # gain (a light's) or its material and objects (a mesh's); each glass mesh and its IOR
        self.emitters: list[tuple[np.ndarray, str | None, str | None, list[str]]] = []
        self.glass: list[tuple[np.ndarray, float, str]] = []

    def set(self, prefix: str, **values) -> None:
        for k, v in values.items():
            self.props[f"{prefix}.{k}"] = v

    def add_mesh(self, name, positions, normals, material, camera_invisible=False):
        """``positions`` / ``normals`` (T, 3, 3) world space: one LuxCore object."""
        t = positions.shape[0]
        self.meshes[name] = (positions.reshape(-1, 3), np.arange(3 * t).reshape(t, 3),
                             None if normals is None else normals.reshape(-1, 3))
        self.objects[name] = {"shape": name, "material": material,
                              "camerainvisible": bool(camera_invisible)}


def _rgb(v) -> list[float]:
    return [float(x) for x in tuple(v)[:3]]


def _input(node, name, default=None):
    """A node input's value (colours as RGB); a linked input has no constant value."""
    sock = node.inputs.get(name)
    if sock is None:
        if default is None:
            raise Unsupported(f"node '{node.name}' has no input '{name}'")
        return default
    if sock.is_linked:
        raise Unsupported(f"node '{node.name}': input '{name}' is linked (only constant values "
                          "translate)")
    v = sock.default_value
    try:
        return _rgb(v) if len(v) >= 3 else [float(x) for x in v]
    except TypeError:
        return float(v)


def material_props(mat) -> tuple[dict, list[float] | None]:
    """(LuxCore material properties without the prefix, emitted radiance RGB or None)."""
    if mat is None or mat.node_tree is None:
        return {"type": "matte", "kd": list(DEFAULT_GREY) if mat is None
                else _rgb(mat.diffuse_color)}, None
    out = mat.node_tree.get_output_node('CYCLES')
    surf = out.inputs["Surface"] if out is not None else None
    if surf is None or not surf.is_linked:
        return {"type": "matte", "kd": [0.0, 0.0, 0.0]}, None     # Cycles: black
    node = surf.links[0].from_node
    kind = node.bl_idname
    emission = None
    if kind == "ShaderNodeEmission":
        c, s = np.array(_input(node, "Color")), _input(node, "Strength")
        return {"type": "matte", "kd": [0.0, 0.0, 0.0]}, (c * s).tolist()
    if kind == "ShaderNodeBsdfDiffuse":
        if _input(node, "Roughness") > EPS:
            raise Unsupported(f"material '{mat.name}': Oren-Nayar diffuse (roughness > 0)")
        return {"type": "matte", "kd": _input(node, "Color")}, None
    if kind == "ShaderNodeBsdfGlossy":
        if _input(node, "Roughness") > EPS:
            raise Unsupported(f"material '{mat.name}': rough glossy")
        return {"type": "mirror", "kr": _input(node, "Color")}, None
    if kind == "ShaderNodeBsdfGlass":
        if _input(node, "Roughness") > EPS:
            raise Unsupported(f"material '{mat.name}': rough glass")
        c = _input(node, "Color")
        return {"type": "glass", "kr": c, "kt": c, "interiorior": _input(node, "IOR"),
                "exteriorior": 1.0, "cauchyb": 0.0}, None
    if kind != "ShaderNodeBsdfPrincipled":
        raise Unsupported(f"material '{mat.name}': {kind} is not translated")
    g = lambda name, default=None: _input(node, name, default)
    strength = g("Emission Strength", 0.0)
    if strength > 0:
        emission = (np.array(g("Emission Color")) * strength).tolist()
    for layer in ("Coat Weight", "Sheen Weight", "Subsurface Weight"):
        if g(layer, 0.0) > EPS:
            raise Unsupported(f"material '{mat.name}': Principled {layer} > 0")
    if g("Alpha", 1.0) < 1 - EPS:
        raise Unsupported(f"material '{mat.name}': Principled alpha < 1")
    base, metallic, rough = g("Base Color"), g("Metallic"), g("Roughness")
    trans = g("Transmission Weight", 0.0)
    if metallic >= 1 - EPS and rough <= EPS:
        return {"type": "mirror", "kr": base}, emission
    if metallic <= EPS and trans >= 1 - EPS and rough <= EPS:
        if abs(g("Specular IOR Level", 0.5) - 0.5) > EPS:
            raise Unsupported(f"material '{mat.name}': glass with Specular IOR Level != 0.5")
        return {"type": "glass", "kr": g("Specular Tint", [1.0, 1.0, 1.0]), "kt": base,
                "interiorior": g("IOR"), "exteriorior": 1.0, "cauchyb": 0.0}, emission
    if metallic <= EPS and trans <= EPS and g("Specular IOR Level", 0.5) <= EPS:
        return {"type": "matte", "kd": base}, emission
    raise Unsupported(f"material '{mat.name}': Principled metallic {metallic:g}, transmission "
                      f"{trans:g}, roughness {rough:g}, Specular IOR Level "
                      f"{g('Specular IOR Level', 0.5):g} has no exact LuxCore counterpart here")


def world_props(tr: Translation, world) -> None:
    """A constant background -> ``constantinfinite`` (nothing for black)."""
    if world is None:
        return
    if world.node_tree is None:
        c = np.array(world.color[:3], np.float64)
    else:
        out = world.node_tree.get_output_node('CYCLES')
        surf = out.inputs["Surface"] if out is not None else None
        if surf is None or not surf.is_linked:
            return
        node = surf.links[0].from_node
        if node.bl_idname != "ShaderNodeBackground":
            raise Unsupported(f"world '{world.name}': {node.bl_idname} is not translated")
        c = np.array(_input(node, "Color")) * _input(node, "Strength")
    if c.max() > 0:
        tr.set("scene.lights.world", type="constantinfinite", color=[1.0, 1.0, 1.0],
               gain=c.tolist())
        tr.lights += 1
