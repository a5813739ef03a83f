"""Principled parameters (scene_arrays.MATERIAL_DTYPE) -> the lobes the kernels sample.

The kernels know three lobes: Lambert, a perfect mirror and a smooth dielectric.  Departures
from Cycles' Principled BSDF, on purpose and documented: metals rougher than
``SPECULAR_ROUGHNESS`` are treated as diffuse with the base colour; glass of any roughness is
smooth; the dielectric specular layer on top of diffuse (Specular IOR Level) is not modelled.
"""
from __future__ import annotations

import numpy as np

from .scene_arrays import TEX_FLAG_SRGB

# mirrors kernels/types.h Material
KMATERIAL_DTYPE = np.dtype([
    ("diffuse", np.float32, 3),
    ("specular", np.float32, 3),
    ("transmit", np.float32, 3),
    ("emission", np.float32, 3),
    ("ior", np.float32),
    ("p_metal", np.float32),
    ("p_glass", np.float32),
    ("flags", np.uint32),
    ("diffuse_tex", np.int32),
    ("emission_tex", np.int32),
    ("absorption", np.float32, 3),
])
MAT_EMISSIVE = 1
MAT_DIFFUSE = 2

SPECULAR_ROUGHNESS = 0.2


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
            rgb = np.where(rgb <= 0.04045, rgb / 12.92, ((np.minimum(rgb, 1) + 0.055) / 1.055) ** 2.4)
        em[k] *= rgb.mean(axis=0)
    return em


def kernel_materials(materials: np.ndarray) -> np.ndarray:
    m = materials
    base = np.clip(np.nan_to_num(m["base_color"], nan=0.0), 0.0, 1.0)
    metallic = np.clip(np.nan_to_num(m["metallic"], nan=0.0), 0.0, 1.0)
    transmission = np.clip(np.nan_to_num(m["transmission"], nan=0.0), 0.0, 1.0)
    rough = np.nan_to_num(m["roughness"], nan=0.5)
    emission = np.maximum(np.nan_to_num(m["emission"], nan=0.0, posinf=0.0), 0.0)
    ior = np.nan_to_num(m["ior"], nan=1.5)
    ior = np.where(np.abs(ior - 1.0) < 1e-4, 1.0001, np.clip(ior, 1e-3, 1e3))

    mirror_metal = rough < SPECULAR_ROUGHNESS
    p_metal = np.where(mirror_metal, metallic, 0.0)
    p_glass = (1.0 - metallic) * transmission
    p_diffuse = 1.0 - p_metal - p_glass

    k = np.zeros(m.shape[0], KMATERIAL_DTYPE)
    k["diffuse"] = base
    k["specular"] = base
    k["transmit"] = base
    k["emission"] = emission
    k["ior"] = ior
    k["p_metal"] = p_metal
    k["p_glass"] = p_glass
    flags = np.zeros(m.shape[0], np.uint32)
    flags |= np.where(emission.max(axis=1) > 0, MAT_EMISSIVE, 0).astype(np.uint32)
    flags |= np.where((p_diffuse > 1e-6) & (base.max(axis=1) > 0), MAT_DIFFUSE, 0).astype(np.uint32)
    k["flags"] = flags
    k["diffuse_tex"] = m["base_color_texture"]
    k["emission_tex"] = m["emission_texture"]
    # inside glass only: the medium is entered and left by refraction
    sigma = np.nan_to_num(m["absorption"], nan=0.0, posinf=0.0).clip(0.0, 1e30)
    k["absorption"] = np.where(p_glass[:, None] > 0, sigma, 0.0)
    return k
