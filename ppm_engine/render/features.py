"""Which features a scene needs, as -D flags for the eye and photon passes (FEATURES).

The programs are cached per device by (file, defines), so each feature set is built once; a
scene without microfacet lobes runs kernels without their code (likewise sheen, Oren-Nayar,
translucency, transparency), its closure lists as long as its materials need, a scene lit by one
point light kernels with no sun, area, mesh-light or world sampling (docs/BENCHMARKS.md,
"Skips").
"""
from __future__ import annotations

import numpy as np

from ppm_engine.scene.arrays import (
    LIGHT_AREA_ELLIPSE,
    LIGHT_AREA_RECT,
    LIGHT_HIDDEN_SHIFT,
    LIGHT_POINT,
    LIGHT_SPOT,
    LIGHT_SUN,
    VIS_CAMERA,
    VIS_GLOSSY,
    VIS_TRANSMISSION,
    SceneArrays,
)
from ppm_engine.scene.materials import (
    MAT_GATHER,
    MAT_LAMBERT,
    MAT_VOLUME,
    anisotropic_nodes,
    node_features,
    world_medium,
)
from ppm_engine.scene.shader_program import SVM_IMAGE, ops_used

# The kernels' feature flags (kernels/shared.h, generated from this table): each compiles the
# code of one feature; a program built without -D PPM_SPECIALIZED has them all.
FEATURES = {
    "PPM_SHADER": "a material that is not one Lambert closure (else shader.h's short path only)",
    "PPM_GATHER_SHADE": "a visible point whose closures are not one Lambert (the gather shades "
                        "it)",
    "PPM_MICROFACET": "GGX lobes (metals, glass, specular layers, coats)",
    "PPM_SHEEN": "sheen",
    "PPM_OREN_NAYAR": "rough diffuse",
    "PPM_TRANSLUCENT": "translucency",
    "PPM_TRANSPARENT": "alpha, Transparent BSDF",
    "PPM_ANISOTROPY": "anisotropic lobes (the surface's tangents)",
    "PPM_LIGHT_POINT": "point and spot lights",
    "PPM_LIGHT_SUN": "sun lights",
    "PPM_LIGHT_AREA": "area lights",
    "PPM_EMISSIVE": "emissive triangles (and their MIS)",
    "PPM_WORLD": "an emitting world",
    "PPM_WORLD_MAP": "the world's shader program, importance-sampled by its map (world.h)",
    "PPM_LIGHTS_SEEN": "lights seen by camera and specular rays",
    "PPM_DOF": "depth of field",
    "PPM_TEXTURES": "image textures",
    "PPM_ABSORPTION": "glass with absorption inside (medium.h)",
    "PPM_VOLUME": "homogeneous media: the volume stack, distance sampling, the phase function "
                  "(medium.h; with PPM_ABSORPTION)",
    "PPM_SVM": "shader programs (svm.h; with PPM_SVM_OPS and PPM_SVM_STACK)",
}


# The features an edit of values can switch on: a colour, a roughness, a layer's weight, alpha,
# a light's power or type, an emission's or the world's strength, the camera's f-stop.  Kernels
# built "editable" (RenderOptions.editable: the viewport's, the previews') keep them all, so
# such an edit never builds.  The others follow the structure of the scene's node graphs (image
# textures, shader programs, the world's program): adding such a node may build.
VALUE_FEATURES = frozenset(FEATURES) - {"PPM_TEXTURES", "PPM_SVM", "PPM_WORLD_MAP"}


def used_materials(scene: SceneArrays, n_materials: int) -> np.ndarray:
    """Indices of the materials some triangle uses (a bincount: no sort of the triangles), and
    the world's medium (materials.world_medium), which fills the space outside them."""
    m = scene.material
    m = m[(m >= 0) & (m < n_materials)] if m.size else m
    used = np.nonzero(np.bincount(m, minlength=n_materials))[0] if m.size else \
        np.zeros(0, np.int64)
    w = world_medium(scene)
    return np.append(used, w) if 0 <= w < n_materials else used


def scene_features(scene: SceneArrays, kmaterials: np.ndarray, knodes: np.ndarray, emitters,
                   used: np.ndarray | None = None) -> frozenset:
    """The features (FEATURES) that ``scene`` uses.

    ``kmaterials`` and ``knodes`` are the kernel materials and BSDF nodes (materials.py) and
    ``emitters`` the emitter table (emitters.build_emitters): a light of zero power is never
    sampled, so its type needs no code; only materials some triangle uses count."""
    if used is None:
        used = used_materials(scene, kmaterials.shape[0])
    m = kmaterials[used]
    f = node_features(knodes[np.isin(knodes["material"], used)])
    not_lambert = (m["flags"] & MAT_LAMBERT) == 0
    if not_lambert.any():
        f.add("PPM_SHADER")
    if (not_lambert & ((m["flags"] & MAT_GATHER) != 0)).any():
        f.add("PPM_GATHER_SHADE")          # a visible point's f may need its closures
    fg = float(scene.light_paths["filter_glossy"][0]) if scene.light_paths is not None else 0.0
    if 0.0 < fg <= 1.001 / np.pi:
        # Filter Glossy at most 1 / pi: a diffuse point gathers the photons from the directions
        # a camera path takes with at least that density, which the gather asks its closures
        # (kernels/integrator/path_state.h); above it a diffuse point gathers none
        f.add("PPM_GATHER_SHADE")
    lights = scene.lights
    n_lights = lights.shape[0]
    live = emitters.power[:n_lights] > 0 if int(emitters.info["n_emitters"][0]) else \
        np.zeros(n_lights, bool)
    t = lights["type"]
    if (live & ((t == LIGHT_POINT) | (t == LIGHT_SPOT))).any():
        f.add("PPM_LIGHT_POINT")
    if (live & (t == LIGHT_SUN)).any():
        f.add("PPM_LIGHT_SUN")
    area = (t == LIGHT_AREA_RECT) | (t == LIGHT_AREA_ELLIPSE)
    if (live & area).any():
        f.add("PPM_LIGHT_AREA")
    if int(emitters.info["n_emissive"][0]):
        f.add("PPM_EMISSIVE")        # (emission seen by camera rays needs no flag)
    if int(emitters.info["has_world"][0]):
        f.add("PPM_WORLD")
    world_program = int(emitters.info["world_program"][0])
    if world_program > 0:                  # (a world seen by rays: its program, even if black)
        f.update(("PPM_WORLD_MAP", "PPM_SVM"))
        if ops_used(scene.svm, [world_program]) & (1 << SVM_IMAGE):
            f.add("PPM_TEXTURES")
    # lights a camera or specular ray can see: area lights, point lights with a radius
    # (kernels/integrator/direct_light.h lights_seen), unless hidden from every ray type that looks
    # for them
    hidden_all = (VIS_CAMERA | VIS_GLOSSY | VIS_TRANSMISSION) << LIGHT_HIDDEN_SHIFT
    shown = (lights["flags"] & np.uint32(hidden_all)) != hidden_all
    # seen by rays: area lights, points with a radius, suns with an angle (light_types.h)
    visible = area | (((t == LIGHT_POINT) | (t == LIGHT_SUN)) & (lights["radius"] > 0))
    if (live & visible & shown).any():
        f.add("PPM_LIGHTS_SEEN")
    if float(scene.camera["aperture_radius"][0]) > 0:
        f.add("PPM_DOF")
    if (m["emission_tex"] > 0).any():
        f.add("PPM_TEXTURES")
    if scene.tangents.shape[0] and anisotropic_nodes(
            knodes[np.isin(knodes["material"], used)]).any():
        f.add("PPM_ANISOTROPY")
    if (m["absorption"] > 0).any():       # (kernel_materials keeps it on glass only)
        f.add("PPM_ABSORPTION")
    if ((m["flags"] & MAT_VOLUME) != 0).any():
        f.update(("PPM_VOLUME", "PPM_ABSORPTION"))    # (the media's plumbing is absorption's)
    programs = np.concatenate([m["program"], m["density_program"]])  # (media's density)
    if (programs > 0).any():
        f.add("PPM_SVM")
        if ops_used(scene.svm, programs) & (1 << SVM_IMAGE):
            f.add("PPM_TEXTURES")
    return frozenset(f)


def defines(features, closures: int | None = None) -> dict:
    """-D flags for a feature set; ``None``: every feature (unspecialised kernels).
    ``closures``: the most closures a material of the scene makes (materials.max_closures)."""
    if features is None:
        return {}
    return {"PPM_SPECIALIZED": True, **dict.fromkeys(features, True),
            **({"PPM_MAX_CLOSURES": int(closures)} if closures else {})}
