"""The scene's materials (arrays.MATERIAL_DTYPE and SHADER_NODE_DTYPE) as the kernels read
them: one header per material (its nodes, its constant emission for the emitter table, what a
pass must know before shading a hit) and the BSDF nodes with every input made finite; and what
the nodes need of the kernels (features.py), e.g. the most closures one material can make.

The closures themselves are made at each hit by kernels/closure/shader.h, as Cycles makes them.
"""
from __future__ import annotations

import numpy as np

from ppm_engine.scene.arrays import (
    NODE_DIFFUSE,
    NODE_EMISSION,
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
    SHADER_NODE_DTYPE,
    TEX_FLAG_SRGB,
    WORLD_MEDIUM,
)
from ppm_engine.scene.shader_program import BOUND, field_glows

# what a pass needs of a material before it shades a hit (kernels/shared.h Material)
KMATERIAL_DTYPE = np.dtype([
    ("emission", np.float32, 3),   # emitted radiance of its emission closures, before textures
    ("flags", np.uint32),          # MAT_*
    ("emission_tex", np.int32),    # 1-based texture of the emission (kernels/svm/textures.h), 0 =
                                   # none
    ("node_first", np.int32),      # its BSDF nodes: shader_nodes[node_first, + node_count)
    ("node_count", np.int32),
    ("absorption", np.float32, 3),  # absorption inside per metre (kernels/geom/medium.h)
    ("program", np.int32),         # first word of its shader program in svm (kernels/svm/svm.h),
                                   # 0 = none
    ("scattering", np.float32, 3),  # scattering inside per metre (MAT_VOLUME only)
    ("anisotropy", np.float32),    # its Henyey-Greenstein g, in (-1, 1)
    ("volume_emission", np.float32, 3),  # radiance emitted per metre inside (MAT_VOLUME only)
    ("density_program", np.int32),  # its medium's density program (geom/medium_field.h), 0 = none
    ("majorant", np.float32),      # the density's bound over its object (DeviceScene)
    ("volume_object", np.int32),   # the objects row its density reads, -1 = none
    ("majorant_grid", np.int32),   # bounds per cell at voxels[it - 1] (majorant_grid.h), 0 = none
])
MAT_EMISSIVE = 1          # constant emission > 0: an emitter
MAT_GATHER = 2            # some closure can hold a visible point and photons
MAT_TRANSPARENT = 4       # partly transparent: shadow rays pass
MAT_LAMBERT = 8           # one node making one Lambert closure: the shader's short path
# a medium inside that scatters or emits, or one entered through a transparent surface (a mesh
# whose material has only a Volume output): the volume stack's (kernels/geom/medium.h, PPM_VOLUME)
MAT_VOLUME = 16
# a medium's boundary alone (a material with only a Volume output): crossing it is no
# transparent bounce (Cycles' volume bounds), counted apart up to VOLUME_BOUNDS_MAX
MAT_BOUNDARY = 32
# the largest coefficient a medium keeps (a density of 1e30 per metre is opaque at 1e-28 m)
MAX_COEFFICIENT = 1e30

# a microfacet lobe with alpha_x alpha_y below this is a perfect mirror or a smooth refraction
# (Cycles' BSDF_ROUGHNESS_SQ_THRESH: roughness below ~0.0038): it can only be followed, never
# evaluated (kernels/shared.h ROUGHNESS_SQ_THRESH)
SINGULAR_ALPHA2 = 2e-10
SINGULAR_ROUGHNESS = SINGULAR_ALPHA2 ** 0.25
# closures whose sample weight is below this are not made (Cycles' CLOSURE_WEIGHT_CUTOFF); the
# node inputs that make no closure below it (kernels/closure/shader.h)
CLOSURE_WEIGHT_CUTOFF = 1e-5
# closures of one material beyond this are dropped (kernels/closure/shader_data.h PPM_MAX_CLOSURES)
MAX_CLOSURES = 16

_FLOAT_DEFAULTS = {"weight": 0.0, "alpha": 1.0, "ior": 1.5, "coat_ior": 1.5,
                   "specular_ior_level": 0.5}


def kernel_nodes(nodes: np.ndarray) -> np.ndarray:
    """The nodes with NaN and infinite inputs replaced (defaults for IORs and alpha, 0 else)
    and negative mix weights dropped: the kernels never see a non-finite input."""
    k = nodes.copy()
    for name in SHADER_NODE_DTYPE.names:
        if k.dtype[name].base.kind == "f":
            d = _FLOAT_DEFAULTS.get(name, 0.0)
            k[name] = np.nan_to_num(k[name], nan=d, posinf=d if name != "emission" else 0.0,
                                    neginf=d if name != "emission" else 0.0)
    k["weight"] = np.maximum(k["weight"], 0.0)
    return k


def anisotropic_nodes(nodes: np.ndarray) -> np.ndarray:
    """Per node: whether it is (or its program may make it) anisotropic: it needs tangents."""
    t = nodes["type"]
    a = nodes["anisotropic"]
    a = np.where((nodes["bound"] & BOUND["anisotropic"]) != 0, 1.0, a)
    return ((t == NODE_GLOSSY) & (np.abs(a) > 1e-4)) | (
        np.isin(t, (NODE_PRINCIPLED, NODE_METALLIC)) & (a > 0))


def bound(n: np.ndarray, field: str) -> np.ndarray:
    """Per node: whether its shader program drives ``field`` (any value is possible)."""
    return (n["bound"] & BOUND[field]) != 0


def _principled_parts(n: np.ndarray) -> dict:
    """Which closures each Principled node can make (boolean arrays; an input the program
    drives can take any value)."""
    ior, level = n["ior"], n["specular_ior_level"]
    rough = np.clip(n["roughness"], 0, 1)
    b = {f: bound(n, f) for f in ("metallic", "transmission", "ior", "specular_ior_level",
                                  "sheen_weight", "coat_weight", "alpha", "roughness",
                                  "coat_roughness")}
    return {
        "sheen": (n["sheen_weight"] > CLOSURE_WEIGHT_CUTOFF) | b["sheen_weight"],
        "coat": (n["coat_weight"] > CLOSURE_WEIGHT_CUTOFF) | b["coat_weight"],
        "metal": (np.clip(n["metallic"], 0, 1) > CLOSURE_WEIGHT_CUTOFF) | b["metallic"],
        "glass": (np.clip(n["transmission"], 0, 1) > CLOSURE_WEIGHT_CUTOFF) | b["transmission"],
        "specular": ((level > 0) | b["specular_ior_level"]) & ((ior != 1.0) | b["ior"]),
        "diffuse": ((np.clip(n["metallic"], 0, 1) < 1) | b["metallic"])
                   & ((np.clip(n["transmission"], 0, 1) < 1) | b["transmission"]),
        "transparent": (n["alpha"] < 1) | (n["alpha_texture"] > 0) | b["alpha"],
        "rough": (rough > SINGULAR_ROUGHNESS) | b["roughness"],
        "rough_coat": (np.clip(n["coat_roughness"], 0, 1) > SINGULAR_ROUGHNESS)
                      | b["coat_roughness"],
    }


def closures_per_node(nodes: np.ndarray) -> np.ndarray:
    """The most closures each node can make at a hit."""
    count = np.ones(nodes.shape[0], np.int64)
    count[np.isin(nodes["type"], (NODE_EMISSION, NODE_HOLDOUT))] = 0
    p = nodes["type"] == NODE_PRINCIPLED
    if p.any():
        parts = _principled_parts(nodes[p])
        count[p] = sum(parts[k].astype(np.int64) for k in
                       ("sheen", "coat", "metal", "glass", "specular", "transparent")) + 1
    return count


def max_closures(nodes: np.ndarray, used: np.ndarray | None = None) -> int:
    """The most closures a material (of ``used``, all when None) can make, 1..MAX_CLOSURES."""
    if not nodes.size:
        return 1
    sel = np.ones(nodes.shape[0], bool) if used is None else np.isin(nodes["material"], used)
    if not sel.any():
        return 1
    per = np.bincount(nodes["material"][sel], weights=closures_per_node(nodes[sel]))
    return int(min(max(per.max(), 1), MAX_CLOSURES))


def gather_capable(nodes: np.ndarray) -> np.ndarray:
    """Per node: whether it can make a closure that is not singular (one the gather, or
    next-event estimation, can evaluate)."""
    t = nodes["type"]
    out = np.isin(t, (NODE_DIFFUSE, NODE_TRANSLUCENT, NODE_SHEEN))
    rough = (np.clip(nodes["roughness"], 0, 1) > SINGULAR_ROUGHNESS) | bound(nodes, "roughness")
    out |= np.isin(t, (NODE_GLOSSY, NODE_METALLIC, NODE_GLASS, NODE_REFRACTION)) & rough
    p = t == NODE_PRINCIPLED
    if p.any():
        parts = _principled_parts(nodes[p])
        out[p] = (parts["diffuse"] | parts["sheen"] | (parts["coat"] & parts["rough_coat"])
                  | ((parts["metal"] | parts["glass"] | parts["specular"]) & parts["rough"]))
    return out & (nodes["weight"] > 0)


def follow_capable(nodes: np.ndarray, gather_roughness: float,
                   caustic_roughness: float = 0.7) -> np.ndarray:
    """Per node: whether it can make a closure that makes caustics (kernels/closure/shader.h): glass
    or a refraction smoother than ``gather_roughness``, a glossy reflection smoother than
    ``caustic_roughness`` (rougher ones eye paths follow are the eye paths' light) and than
    ``gather_roughness``.  Transparency is no scattering and does not count."""
    t = nodes["type"]
    rough = np.clip(nodes["roughness"], 0, 1)
    driven = bound(nodes, "roughness")
    refracts = (rough < gather_roughness) | driven
    reflects = (rough < min(caustic_roughness, gather_roughness)) | driven
    out = ((np.isin(t, (NODE_GLOSSY, NODE_METALLIC)) & reflects)
           | (np.isin(t, (NODE_GLASS, NODE_REFRACTION)) & refracts))
    p = t == NODE_PRINCIPLED
    if p.any():
        parts = _principled_parts(nodes[p])
        n = nodes[p]
        out[p] = (parts["glass"] & refracts[p]) \
            | ((parts["metal"] | parts["specular"]) & reflects[p]) \
            | (parts["coat"] & ((np.clip(n["coat_roughness"], 0, 1)
                                 < min(caustic_roughness, gather_roughness))
                                | bound(n, "coat_roughness")))
    return out & (nodes["weight"] > 0)


def lambert_node(nodes: np.ndarray) -> np.ndarray:
    """Per node: whether it makes exactly one Lambert closure (weight colour x mix weight) and
    at most emission: a Diffuse BSDF of roughness 0, a Principled BSDF with nothing but its
    diffuse base (no specular layer, metal, glass, coat, sheen, subsurface, transparency)."""
    t = nodes["type"]
    out = (t == NODE_DIFFUSE) & (nodes["roughness"] < CLOSURE_WEIGHT_CUTOFF) \
        & ~bound(nodes, "roughness")
    p = t == NODE_PRINCIPLED
    if p.any():
        parts = _principled_parts(nodes[p])
        n = nodes[p]
        out[p] = ~(parts["sheen"] | parts["coat"] | parts["metal"] | parts["glass"]
                   | parts["specular"] | parts["transparent"]) \
            & (n["subsurface_weight"] <= 0) & (n["diffuse_roughness"] < CLOSURE_WEIGHT_CUTOFF) \
            & ~bound(n, "subsurface_weight") & ~bound(n, "diffuse_roughness")
    return out & ~nodes["normal"].any(axis=1)      # (the short path shades with N)


def node_features(nodes: np.ndarray) -> set:
    """The closure features (features.FEATURES) these nodes need."""
    f = set()
    if not nodes.size:
        return f
    nodes = nodes[nodes["weight"] > 0]
    t = nodes["type"]
    p = nodes[t == NODE_PRINCIPLED]
    parts = _principled_parts(p) if p.size else None
    if np.isin(t, (NODE_GLOSSY, NODE_METALLIC, NODE_GLASS, NODE_REFRACTION)).any() or (
            parts is not None and (parts["coat"] | parts["metal"] | parts["glass"]
                                   | parts["specular"]).any()):
        f.add("PPM_MICROFACET")
    if (t == NODE_SHEEN).any() or (parts is not None and parts["sheen"].any()):
        f.add("PPM_SHEEN")
    rough_diffuse = ((t == NODE_DIFFUSE) & ((nodes["roughness"] >= CLOSURE_WEIGHT_CUTOFF)
                                            | bound(nodes, "roughness"))).any() or (
        parts is not None and (((p["diffuse_roughness"] >= CLOSURE_WEIGHT_CUTOFF)
                                | bound(p, "diffuse_roughness")) & parts["diffuse"]).any())
    if rough_diffuse:
        f.add("PPM_OREN_NAYAR")
    if (t == NODE_TRANSLUCENT).any():
        f.add("PPM_TRANSLUCENT")
    if (t == NODE_TRANSPARENT).any() or (parts is not None and parts["transparent"].any()):
        f.add("PPM_TRANSPARENT")
    if (nodes["color_texture"] > 0).any() or (nodes["emission_texture"] > 0).any() \
            or (nodes["alpha_texture"] > 0).any():
        f.add("PPM_TEXTURES")
    return f


def node_emission(nodes: np.ndarray) -> np.ndarray:
    """(K, 3) each node's constant emitted radiance: Emission nodes, and the Principled's
    emission under its alpha (the sheen and coat above it depend on the view: left out)."""
    em = np.maximum(nodes["emission"].astype(np.float64), 0.0) * nodes["weight"][:, None]
    t = nodes["type"]
    alpha = np.where(t == NODE_PRINCIPLED, np.clip(nodes["alpha"], 0, 1), 1.0)
    keep = np.isin(t, (NODE_PRINCIPLED, NODE_EMISSION))
    return np.where(keep[:, None], em * alpha[:, None], 0.0)


def world_medium(scene) -> int:
    """The row of the world's medium in ``scene.materials`` (SceneArrays: its last, with
    WORLD_MEDIUM), -1 where the world has no Volume output."""
    return scene.materials.shape[0] - 1 if int(scene.world_shader[1]) & WORLD_MEDIUM else -1


def kernel_materials(materials: np.ndarray, nodes: np.ndarray, world: int = -1,
                     svm: np.ndarray | None = None) -> np.ndarray:
    """KMATERIAL_DTYPE rows for the scene's materials; ``nodes`` as kernel_nodes returns
    them (ordered by material); ``world``: the row of the world's medium (world_medium), -1
    none; ``svm`` the shader programs (a medium whose field program gives its emission is
    live without constant coefficients)."""
    m = materials.shape[0]
    k = np.zeros(m, KMATERIAL_DTYPE)
    owner = nodes["material"]
    k["node_first"] = np.searchsorted(owner, np.arange(m), side="left")
    k["node_count"] = np.searchsorted(owner, np.arange(m), side="right") - k["node_first"]
    em = np.zeros((m, 3))
    np.add.at(em, owner, node_emission(nodes))
    k["emission"] = em
    # the emission texture of the material's first textured emitting node
    tex = np.where((nodes["emission_texture"] > 0) & (node_emission(nodes).max(axis=1) > 0),
                   nodes["emission_texture"], 0)
    first_tex = np.zeros(m, np.int32)
    for i in np.nonzero(tex)[0][::-1]:
        first_tex[owner[i]] = tex[i]
    k["emission_tex"] = first_tex
    flags = np.where(em.max(axis=1) > 0, MAT_EMISSIVE, 0).astype(np.uint32)
    gather = np.zeros(m, bool)
    np.logical_or.at(gather, owner, gather_capable(nodes))
    flags |= np.where(gather, MAT_GATHER, 0).astype(np.uint32)
    t = nodes["type"]
    transp = (t == NODE_TRANSPARENT) & (nodes["weight"] > 0)
    pr = t == NODE_PRINCIPLED
    transp[pr] |= _principled_parts(nodes[pr])["transparent"] & (nodes["weight"][pr] > 0)
    tr = np.zeros(m, bool)
    np.logical_or.at(tr, owner, transp)
    flags |= np.where(tr, MAT_TRANSPARENT, 0).astype(np.uint32)
    one = k["node_count"] == 1
    first = nodes[np.minimum(k["node_first"], max(nodes.shape[0] - 1, 0))] if nodes.size \
        else None
    if first is not None:
        flags |= np.where(one & lambert_node(first), MAT_LAMBERT, 0).astype(np.uint32)
    # the medium inside: entered and left by refraction, so only materials that refract
    refracts = np.isin(t, (NODE_GLASS, NODE_REFRACTION)) | (
        pr & ((nodes["transmission"] > 0) | bound(nodes, "transmission")))
    glass = np.zeros(m, bool)
    np.logical_or.at(glass, owner, refracts & (nodes["weight"] > 0))
    sigma = np.nan_to_num(materials["absorption"], nan=0.0, posinf=0.0).clip(0.0, 1e30)
    k["absorption"] = np.where(glass[:, None], sigma, 0.0)
    # media entered through a transparent surface: the volume stack's (MAT_VOLUME), as are
    # glass's that scatter or emit; absorbing glass alone stays PPM_ABSORPTION's
    def coeff(name):
        return np.nan_to_num(materials[name].astype(np.float64), nan=0.0,
                             posinf=MAX_COEFFICIENT).clip(0.0, MAX_COEFFICIENT)
    sigma_a, sigma_s, em = coeff("absorption"), coeff("scattering"), coeff("volume_emission")
    field = materials["density_program"] > 0          # a heterogeneous medium: the stack's
    glows = (field_glows(svm, materials["density_program"]) if svm is not None
             else np.zeros(m, bool))
    live = (sigma_a.max(axis=1) > 0) | (sigma_s.max(axis=1) > 0) | (em.max(axis=1) > 0) | glows
    volume = live & ((tr & ~glass) | (glass & ((sigma_s.max(axis=1) > 0)
                                               | (em.max(axis=1) > 0) | field)))
    k["density_program"] = np.where(volume, materials["density_program"], 0)
    k["volume_object"] = np.where(volume & field, materials["volume_object"] - 1, -1)
    k["absorption"] = np.where(volume[:, None], sigma_a, k["absorption"])
    k["scattering"] = np.where(volume[:, None], sigma_s, 0.0)
    k["volume_emission"] = np.where(volume[:, None], em, 0.0)
    k["anisotropy"] = np.where(volume, np.clip(np.nan_to_num(materials["anisotropy"]),
                                               -0.999, 0.999), 0.0)
    flags |= np.where(volume, MAT_VOLUME, 0).astype(np.uint32)
    plain = np.ones(m, bool)
    np.logical_and.at(plain, owner, (nodes["flags"] & NODE_FLAG_VOLUME_BOUNDARY) != 0)
    flags |= np.where(volume & plain & (k["node_count"] > 0), MAT_BOUNDARY, 0).astype(np.uint32)
    k["flags"] = flags
    if world >= 0:
        _add_world_medium(k, world, sigma_a[world], sigma_s[world], em[world],
                          float(np.clip(np.nan_to_num(materials["anisotropy"][world]), -0.999,
                                        0.999)))
    # a material with a shader program never takes the Lambert short path (it skips programs)
    k["program"] = materials["program"]
    k["flags"] &= np.where(k["program"] > 0, ~np.uint32(MAT_LAMBERT), ~np.uint32(0)).astype(
        np.uint32)
    return k


def _add_world_medium(k: np.ndarray, world: int, sigma_a, sigma_s, em, g: float) -> None:
    """The world's medium's own row (``world``): a medium of the volume stack (MAT_VOLUME), at
    the stack's bottom, which the kernels sum with every medium above it as Cycles' volume stack
    sums the world's volume under every object's (kernels/geom/medium.h media_mix)."""
    k[world]["absorption"] = np.minimum(sigma_a, MAX_COEFFICIENT)
    k[world]["scattering"] = np.minimum(sigma_s, MAX_COEFFICIENT)
    k[world]["volume_emission"] = np.minimum(em, MAX_COEFFICIENT)
    k[world]["anisotropy"] = g
    if max(sigma_a.max(), sigma_s.max(), em.max()) > 0:
        k["flags"][world] |= MAT_VOLUME


def mean_emission(kmaterials: np.ndarray, textures: np.ndarray, texels: np.ndarray) -> np.ndarray:
    """(M, 3) float64: each material's emitted radiance averaged over its emission texture (the
    emitter table's power weights; the kernels use the texture per point)."""
    em = kmaterials["emission"].astype(np.float64)
    tex = kmaterials["emission_tex"]
    for k in np.nonzero(tex > 0)[0]:
        t = textures[tex[k] - 1]
        n = int(t["width"]) * int(t["height"])
        rgb = np.nan_to_num(texels[int(t["offset"]):int(t["offset"]) + n, :3].astype(np.float64),
                            nan=0.0, posinf=0.0).clip(0)
        if int(t["flags"]) & TEX_FLAG_SRGB:
            rgb = np.where(rgb <= 0.04045, rgb / 12.92,
                           ((np.minimum(rgb, 1) + 0.055) / 1.055) ** 2.4)
        em[k] *= rgb.mean(axis=0)
    return em
