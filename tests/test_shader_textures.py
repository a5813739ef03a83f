"""Procedural texture nodes against Cycles, per pixel (the harness of tests/helpers/shader_grid.py:
one plane per case, inputs from two images read with Closest interpolation, every pixel within
1e-3): Checker, Gradient, White Noise, Noise, Magic, Wave, Brick and Voronoi with their options
and several input values.  A texture's Vector comes from image A, spread over several cells
(a coordinate that varied inside a pixel would not give one value per pixel); linked float
inputs come from image B.  And the compiler's side: a scene without textures builds no texture
code."""
from pathlib import Path

import pytest

bpy = pytest.importorskip("bpy")

from tests.helpers.shader_grid import compare_cases


def spread(i, s=4.0, o=0.0):
    """Image A's colour (in [0, 1]) times s plus o, per component."""
    return i.node("ShaderNodeVectorMath", [(0, i.A)], operation="MULTIPLY_ADD",
                  in_1=(s, s, s), in_2=(o, o, o)).outputs[0]


def case(idname, out, vector=spread, links=(), inputs=None, **props):
    """A case: texture node ``idname`` with ``props`` set, its Vector from ``vector(i)`` (None:
    unlinked), the links ``(input name, lambda i: socket)`` made, the unlinked ``inputs``
    (name: value) set; returns the output ``out`` (by identifier)."""
    def build(i):
        n = i.node(idname, **props)
        for name, value in (inputs or {}).items():
            next(s for s in n.inputs if s.name == name).default_value = value
        vec = next((s for s in n.inputs if s.name == "Vector" and s.enabled), None)
        if vector is not None and vec is not None:
            i.t.links.new(vector(i), vec)
        for name, src in links:
            i.t.links.new(src(i), next(s for s in n.inputs if s.name == name and s.enabled))
        return next(s for s in n.outputs if s.identifier == out)
    return build


def run(cases: dict, render_direct, tmp_path):
    compare_cases(list(cases.values()), render_direct, tmp_path, list(cases))


X = ("Scale", lambda i: i.x)


def test_checker_gradient_and_white_noise_as_cycles(render_direct, tmp_path):
    chk, grad, white = "ShaderNodeTexChecker", "ShaderNodeTexGradient", "ShaderNodeTexWhiteNoise"
    cases = {
        "checker color": case(chk, "Color", inputs={"Color1": (0.9, 0.2, 0.1, 1.0)}),
        "checker fac": case(chk, "Fac"),
        "checker scale 2.5": case(chk, "Fac", inputs={"Scale": 2.5}),
        "checker negative": case(chk, "Fac", vector=lambda i: spread(i, 6.0, -3.0)),
        "checker linked": case(chk, "Color", links=[("Color2", lambda i: i.B),
                                                    ("Scale", lambda i: i.s)]),
    }
    for kind in ("LINEAR", "QUADRATIC", "EASING", "DIAGONAL", "SPHERICAL", "QUADRATIC_SPHERE",
                 "RADIAL"):
        cases[f"gradient {kind.lower()}"] = case(grad, "Fac", gradient_type=kind,
                                                 vector=lambda i: spread(i, 2.4, -1.2))
    cases["gradient color"] = case(grad, "Color", gradient_type="EASING",
                                   vector=lambda i: spread(i, 2.0, -0.5))
    for d in ("1D", "2D", "3D", "4D"):
        w = [("W", lambda i: i.s)] if d in ("1D", "4D") else []
        cases[f"white noise {d}"] = case(white, "Value", vector=lambda i: i.A, links=w,
                                         noise_dimensions=d)
        cases[f"white noise {d} color"] = case(white, "Color", vector=lambda i: i.B, links=w,
                                               noise_dimensions=d)
    cases["white noise unlinked"] = case(white, "Color", vector=None)
    run(cases, render_direct, tmp_path)


def test_noise_fbm_as_cycles(render_direct, tmp_path):
    noise = "ShaderNodeTexNoise"
    cases = {
        "default fac": case(noise, "Fac"),
        "default color": case(noise, "Color"),
        "detail 0": case(noise, "Fac", inputs={"Detail": 0.0}),
        "detail 4.6": case(noise, "Fac", inputs={"Detail": 4.6, "Scale": 2.0}),
        "detail 15": case(noise, "Color", inputs={"Detail": 15.0, "Scale": 1.5}),
        "roughness 0.85": case(noise, "Fac", inputs={"Roughness": 0.85, "Detail": 6.0}),
        "roughness linked": case(noise, "Fac", links=[("Roughness", lambda i: i.y),
                                                      ("Detail", lambda i: i.z)]),
        "lacunarity 3.3": case(noise, "Fac", inputs={"Lacunarity": 3.3, "Detail": 3.0}),
        "scale linked": case(noise, "Color", links=[X]),
        "distortion 0.7": case(noise, "Fac", inputs={"Distortion": 0.7}),
        "distortion color": case(noise, "Color", inputs={"Distortion": 2.5, "Detail": 1.5}),
        "not normalized": case(noise, "Fac", normalize=False, inputs={"Detail": 3.5}),
        "negative coordinates": case(noise, "Color", vector=lambda i: spread(i, 8.0, -4.0)),
    }
    for d in ("1D", "2D", "4D"):
        w = [("W", lambda i: i.s)] if d in ("1D", "4D") else []
        cases[f"{d} fac"] = case(noise, "Fac", noise_dimensions=d, links=w,
                                 inputs={"Distortion": 0.4, "Detail": 2.5})
        cases[f"{d} color"] = case(noise, "Color", noise_dimensions=d, links=w)
    run(cases, render_direct, tmp_path)


def test_noise_types_as_cycles(render_direct, tmp_path):
    noise = "ShaderNodeTexNoise"
    cases = {}
    for kind in ("MULTIFRACTAL", "RIDGED_MULTIFRACTAL", "HYBRID_MULTIFRACTAL", "HETERO_TERRAIN"):
        k = kind.lower()
        cases[k] = case(noise, "Fac", noise_type=kind, inputs={"Scale": 1.5})
        cases[f"{k} detail 3.4"] = case(noise, "Fac", noise_type=kind,
                                        inputs={"Detail": 3.4, "Offset": 0.6, "Gain": 1.7,
                                                "Roughness": 0.7, "Scale": 2.0})
        cases[f"{k} 2D color"] = case(noise, "Color", noise_type=kind, noise_dimensions="2D",
                                      inputs={"Offset": 1.1, "Detail": 4.0})
        links = [("W", lambda i: i.s), ("Detail", lambda i: i.z)]    # (the inputs it has)
        links += [("Offset", lambda i: i.x)] if kind != "MULTIFRACTAL" else []
        links += [("Gain", lambda i: i.y)] if kind in ("RIDGED_MULTIFRACTAL",
                                                       "HYBRID_MULTIFRACTAL") else []
        cases[f"{k} 4D linked"] = case(noise, "Fac", noise_type=kind, noise_dimensions="4D",
                                       links=links)
    run(cases, render_direct, tmp_path)


def test_magic_wave_and_brick_as_cycles(render_direct, tmp_path):
    magic, wave, brick = "ShaderNodeTexMagic", "ShaderNodeTexWave", "ShaderNodeTexBrick"
    cases = {f"magic depth {d}": case(magic, "Color", turbulence_depth=d,
                                      inputs={"Distortion": 1.3, "Scale": 1.5})
             for d in (0, 1, 2, 4, 7, 10)}
    cases["magic fac"] = case(magic, "Fac", links=[("Distortion", lambda i: i.s)])
    cases["magic distortion 0"] = case(magic, "Color", turbulence_depth=0,
                                       inputs={"Distortion": 0.0})
    for kind, direction in (("BANDS", "X"), ("BANDS", "Y"), ("BANDS", "Z"), ("BANDS", "DIAGONAL"),
                            ("RINGS", "X"), ("RINGS", "Y"), ("RINGS", "Z"),
                            ("RINGS", "SPHERICAL")):
        prop = "bands_direction" if kind == "BANDS" else "rings_direction"
        cases[f"wave {kind.lower()} {direction.lower()}"] = case(
            wave, "Fac", wave_type=kind, **{prop: direction}, inputs={"Scale": 1.3})
    for profile in ("SAW", "TRI"):
        cases[f"wave {profile.lower()}"] = case(wave, "Color", wave_profile=profile,
                                                inputs={"Phase Offset": 0.8, "Scale": 0.8})
    cases["wave distortion"] = case(wave, "Fac", inputs={"Distortion": 3.0, "Detail": 3.3,
                                                         "Detail Scale": 2.0, "Scale": 1.2})
    cases["wave distortion linked"] = case(
        wave, "Fac", wave_type="RINGS", links=[("Distortion", lambda i: i.s),
                                               ("Detail Roughness", lambda i: i.y)],
        inputs={"Scale": 1.1})
    cases.update({
        "brick color": case(brick, "Color", inputs={"Mortar Size": 0.06}),
        "brick fac": case(brick, "Fac", inputs={"Mortar Size": 0.08, "Mortar Smooth": 0.0}),
        "brick smooth": case(brick, "Fac", inputs={"Mortar Size": 0.1, "Mortar Smooth": 0.6}),
        "brick offset squash": case(brick, "Color", offset=0.3, offset_frequency=3, squash=1.6,
                                    squash_frequency=2, inputs={"Bias": 0.3, "Scale": 3.0}),
        "brick linked": case(brick, "Color", links=[("Color1", lambda i: i.B),
                                                    ("Brick Width", lambda i: i.x),
                                                    ("Row Height", lambda i: i.y)],
                             vector=lambda i: spread(i, 2.0, -1.0)),
        "brick bias": case(brick, "Color", inputs={"Bias": -0.6, "Scale": 2.0}),
    })
    run(cases, render_direct, tmp_path)


def test_voronoi_as_cycles(render_direct, tmp_path):
    vor = "ShaderNodeTexVoronoi"
    cases = {
        "f1 distance": case(vor, "Distance"),
        "f1 color": case(vor, "Color"),
        "f1 position": case(vor, "Position"),
        "f1 randomness": case(vor, "Distance", links=[("Randomness", lambda i: i.x)]),
        "f1 detail 2.5": case(vor, "Color", inputs={"Detail": 2.5, "Scale": 2.0}),
        "f1 normalize": case(vor, "Distance", normalize=True, inputs={"Detail": 1.6}),
        "f2": case(vor, "Distance", feature="F2"),
        "f2 color": case(vor, "Color", feature="F2", distance="MANHATTAN"),
        "smooth f1": case(vor, "Distance", feature="SMOOTH_F1",
                          links=[("Smoothness", lambda i: i.y)]),
        "smooth f1 color": case(vor, "Color", feature="SMOOTH_F1"),
        "smooth f1 position": case(vor, "Position", feature="SMOOTH_F1",
                                   inputs={"Detail": 1.3}),
        "edge": case(vor, "Distance", feature="DISTANCE_TO_EDGE"),
        "edge detail": case(vor, "Distance", feature="DISTANCE_TO_EDGE", normalize=True,
                            inputs={"Detail": 2.7, "Roughness": 0.7}),
        "radius": case(vor, "Radius", feature="N_SPHERE_RADIUS"),
        "chebychev": case(vor, "Distance", distance="CHEBYCHEV"),
        "minkowski": case(vor, "Distance", distance="MINKOWSKI", inputs={"Exponent": 1.7}),
    }
    for d in ("1D", "2D", "4D"):
        w = [("W", lambda i: i.s)] if d in ("1D", "4D") else []
        cases[f"{d} distance"] = case(vor, "Distance", voronoi_dimensions=d, links=w,
                                      distance="MINKOWSKI", inputs={"Exponent": 0.8})
        cases[f"{d} color"] = case(vor, "Color", voronoi_dimensions=d, links=w,
                                   feature="F2", inputs={"Detail": 1.5})
        if d != "1D":                                 # (1D: the position is W)
            cases[f"{d} position"] = case(vor, "Position", voronoi_dimensions=d, links=w)
        if d != "2D":                                 # (2D: W is 0)
            cases[f"{d} w"] = case(vor, "W", voronoi_dimensions=d, links=w,
                                   feature="SMOOTH_F1")
        cases[f"{d} edge"] = case(vor, "Distance", voronoi_dimensions=d, links=w,
                                  feature="DISTANCE_TO_EDGE")
        cases[f"{d} radius"] = case(vor, "Radius", voronoi_dimensions=d, links=w,
                                    feature="N_SPHERE_RADIUS")
    run(cases, render_direct, tmp_path)


def test_texture_mapping_as_cycles(render_direct, tmp_path):
    """The texture node's own (hidden) mapping, as Cycles applies it before the texture."""
    def mapped(kind, axes=("X", "Y", "Z")):
        def build(i):
            n = case("ShaderNodeTexNoise", "Color")(i).node
            tm = n.texture_mapping
            tm.vector_type = kind
            tm.translation, tm.rotation, tm.scale = (0.3, -0.2, 0.5), (0.4, 1.1, -0.7), (
                1.5, 0.5, 2.0)
            tm.mapping_x, tm.mapping_y, tm.mapping_z = axes
            return n.outputs["Color"]
        return build
    cases = {f"mapping {k.lower()}": mapped(k) for k in ("POINT", "TEXTURE", "VECTOR",
                                                           "NORMAL")}
    cases["mapping axes"] = mapped("POINT", ("Z", "NONE", "X"))
    run(cases, render_direct, tmp_path)


def test_no_texture_code_without_textures():
    """A scene whose programs use no texture node sets no texture op bit (its kernels are
    built without texture code); one texture sets its own bit only.  The op codes are the
    kernels' (svm.h)."""
    import re

    import numpy as np

    from ppm_engine.blender.export.material_nodes import read_material
    from ppm_engine.scene import shader_program as sp
    from ppm_engine.scene.shader_program import (
        OP_EXTRA,
        SVM_TEX_CHECKER,
        SVM_TEX_LAST,
        SVM_TEX_NOISE,
        ops_used,
    )
    tex_bits = sum(1 << op for op in range(SVM_TEX_CHECKER, SVM_TEX_LAST + 1))
    assert SVM_TEX_LAST <= 30 and all(op in OP_EXTRA for op in
                                      range(SVM_TEX_CHECKER, SVM_TEX_LAST + 1))
    header = (Path(__file__).resolve().parents[1] / "kernels" / "shared_svm.h").read_text()
    defines = dict(re.findall(r"#define (SVM_TEX_\w+) (\d+)", header))
    # (the procedural textures, SVM_TEX_LAST and the Sky Texture's SVM_TEX_SKY)
    assert len(defines) == SVM_TEX_LAST - SVM_TEX_CHECKER + 3
    assert all(getattr(sp, k) == int(v) for k, v in defines.items())

    def mask(mat):
        warnings = []
        program = read_material(mat, warnings.append)[2]
        assert program is not None and not warnings
        return ops_used(np.concatenate([np.zeros((1, 4), np.int32), program]), [1])

    bpy.ops.wm.read_factory_settings(use_empty=True)
    mat = bpy.data.materials.new("Plain")
    t = mat.node_tree
    geo, m = t.nodes.new("ShaderNodeNewGeometry"), t.nodes.new("ShaderNodeMath")
    t.links.new(geo.outputs["Backfacing"], m.inputs[0])
    t.links.new(m.outputs[0], t.nodes["Principled BSDF"].inputs["Roughness"])
    assert mask(mat) and not mask(mat) & tex_bits
    noise = t.nodes.new("ShaderNodeTexNoise")
    t.links.new(noise.outputs["Fac"], m.inputs[1])
    assert mask(mat) & tex_bits == 1 << SVM_TEX_NOISE
