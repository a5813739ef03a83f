"""Value nodes against Cycles, per pixel: Math, Vector Math and Mix (every operation and blend
mode), the colour and converter nodes, ramps, curves, Mapping, Fresnel and Layer Weight, Map
Range on vectors, Blackbody and Wavelength.  Each case is a plane whose material wires the
node's output into an Emission shader (a float's two signs apart, a colour plus 8: emission
stays positive); the node's inputs come from two float images of random values read with
Closest interpolation, one texel per pixel under an orthographic camera, so every pixel sees
one set of inputs whatever its samples.  A family of cases (every Math operation, every blend
mode, ...) is a grid of planes rendered once by Cycles and once by this engine (no bounces) in
the same test; every pixel agrees within 1e-3.  The harness is tests/helpers/shader_grid.py
(test_shader_inputs.py, test_shader_textures.py, test_image_texture_node.py and test_sky.py
use it too)."""
import pytest

bpy = pytest.importorskip("bpy")

from tests.helpers.shader_grid import compare_cases

MATH_OPS = [e.identifier for e in bpy.types.ShaderNodeMath.bl_rna.properties["operation"]
            .enum_items] if bpy else []
VMATH_OPS = [e.identifier for e in bpy.types.ShaderNodeVectorMath.bl_rna
             .properties["operation"].enum_items] if bpy else []
BLENDS = [e.identifier for e in bpy.types.ShaderNodeMix.bl_rna.properties["blend_type"]
          .enum_items] if bpy else []


def test_math_every_operation_as_cycles(render_direct, tmp_path):
    def case(op, clamp=False):
        return lambda i: i.node("ShaderNodeMath", [(0, i.s), (1, i.y), (2, i.z)], operation=op,
                                use_clamp=clamp).outputs[0]
    cases = [case(op) for op in MATH_OPS] + [case("SINE", True), case("SUBTRACT", True)]
    compare_cases(cases, render_direct, tmp_path, MATH_OPS + ["SINE clamp", "SUBTRACT clamp"])


def test_vector_math_every_operation_as_cycles(render_direct, tmp_path):
    def case(op):
        def build(i):
            n = i.node("ShaderNodeVectorMath", [(0, i.A), (1, i.B), (2, i.A)], operation=op)
            n.inputs[3].default_value = 0.7          # Scale (REFRACT's index)
            value = op in ("DOT_PRODUCT", "DISTANCE", "LENGTH")
            return n.outputs["Value" if value else "Vector"]
        return build
    compare_cases([case(op) for op in VMATH_OPS], render_direct, tmp_path, VMATH_OPS)


def test_mix_every_blend_mode_as_cycles(render_direct, tmp_path):
    def case(blend, clamp_factor=True, clamp_result=False, fac=None):
        def build(i):
            n = i.node("ShaderNodeMix", data_type="RGBA", blend_type=blend,
                       clamp_factor=clamp_factor, clamp_result=clamp_result)
            i.t.links.new(i.A, n.inputs[6])
            i.t.links.new(i.B, n.inputs[7])
            i.t.links.new(fac or i.z, n.inputs[0])
            return n.outputs[2]
        return build
    cases = [case(b) for b in BLENDS]
    names = list(BLENDS)
    cases += [case("MULTIPLY", clamp_result=True), case("ADD", clamp_result=True)]
    names += ["MULTIPLY clamp", "ADD clamp"]
    compare_cases(cases, render_direct, tmp_path, names)


def test_mix_float_vector_and_legacy_as_cycles(render_direct, tmp_path):
    def flt(i):
        n = i.node("ShaderNodeMix", data_type="FLOAT", clamp_factor=False)
        i.t.links.new(i.s, n.inputs[0])
        i.t.links.new(i.x, n.inputs[2])
        i.t.links.new(i.y, n.inputs[3])
        return n.outputs[0]

    def vec(i, uniform=True):
        n = i.node("ShaderNodeMix", data_type="VECTOR",
                   factor_mode="UNIFORM" if uniform else "NON_UNIFORM")
        i.t.links.new(i.z if uniform else i.B, n.inputs[0 if uniform else 1])
        i.t.links.new(i.A, n.inputs[4])
        i.t.links.new(i.B, n.inputs[5])
        return n.outputs[1]

    def legacy(blend, clamp):
        def build(i):
            n = i.node("ShaderNodeMixRGB", [(0, i.s), (1, i.A), (2, i.B)], blend_type=blend,
                       use_clamp=clamp)
            return n.outputs[0]
        return build
    cases = [flt, vec, lambda i: vec(i, False), legacy("MIX", False), legacy("OVERLAY", True),
             legacy("SUBTRACT", False)]
    compare_cases(cases, render_direct, tmp_path,
                  ["float", "vector", "vector non-uniform", "legacy mix", "legacy overlay clamp",
                   "legacy subtract"])


def test_color_and_converter_nodes_as_cycles(render_direct, tmp_path):
    def sep(mode, k):
        return lambda i: i.node("ShaderNodeSeparateColor", [(0, i.A)], mode=mode).outputs[k]

    def comb(mode):
        return lambda i: i.node("ShaderNodeCombineColor", [(0, i.x), (1, i.y), (2, i.z)],
                                mode=mode).outputs[0]

    def map_range(kind, clamp):
        return lambda i: i.node("ShaderNodeMapRange", [(0, i.s)], interpolation_type=kind,
                                clamp=clamp, in_1=-1.0, in_2=1.5, in_3=0.2, in_4=3.0,
                                in_5=3.0).outputs[0]

    cases = {
        "separate HSV": sep("HSV", 0), "separate HSL s": sep("HSL", 1),
        "separate RGB": sep("RGB", 2),
        "combine HSV": comb("HSV"), "combine HSL": comb("HSL"), "combine RGB": comb("RGB"),
        "invert": lambda i: i.node("ShaderNodeInvert", [(0, i.x), (1, i.A)]).outputs[0],
        "gamma": lambda i: i.node("ShaderNodeGamma", [(0, i.A), (1, i.s)]).outputs[0],
        "bright contrast": lambda i: i.node("ShaderNodeBrightContrast",
                                            [(0, i.A), (1, i.s), (2, i.y)]).outputs[0],
        "rgb to bw": lambda i: i.node("ShaderNodeRGBToBW", [(0, i.A)]).outputs[0],
        "colour to float": lambda i: i.node("ShaderNodeMath", [(0, i.A), (1, i.B)],
                                            operation="ADD").outputs[0],
        "clamp minmax": lambda i: i.node("ShaderNodeClamp", [(0, i.s), (1, i.x)],
                                         in_2=0.6).outputs[0],
        "clamp range": lambda i: i.node("ShaderNodeClamp", [(0, i.s), (1, i.x), (2, i.y)],
                                        clamp_type="RANGE").outputs[0],
        "map range linear": map_range("LINEAR", False),
        "map range clamp": map_range("LINEAR", True),
        "map range stepped": map_range("STEPPED", True),
        "map range smoothstep": map_range("SMOOTHSTEP", False),
        "map range smootherstep": map_range("SMOOTHERSTEP", False),
        "hue saturation": lambda i: i.node("ShaderNodeHueSaturation",
                                           [("Hue", i.x), ("Saturation", i.y), ("Color", i.A)],
                                           ).outputs[0],
        "separate xyz": lambda i: i.node("ShaderNodeSeparateXYZ", [(0, i.A)]).outputs[1],
        "combine xyz": lambda i: i.node("ShaderNodeCombineXYZ",
                                        [(0, i.s), (1, i.x), (2, i.y)]).outputs[0],
    }
    compare_cases(list(cases.values()), render_direct, tmp_path, list(cases))


def test_ramps_curves_and_mapping_as_cycles(render_direct, tmp_path):
    def ramp(interp, out="Color"):
        def build(i):
            n = i.node("ShaderNodeValToRGB", [(0, i.x)])
            r = n.color_ramp
            r.interpolation = interp
            r.elements[0].color = (0.1, 0.5, 0.9, 0.2)
            r.elements[1].position = 0.7
            e = r.elements.new(0.3)
            e.color = (1.0, 0.2, 0.0, 1.0)
            return n.outputs[out]
        return build

    def ramp_at_stop(i):
        """A constant ramp read just below and above its stop at 1/4: Cycles bakes 257 entries
        at i / 256 (a table of 256 at i / 255 gave the first colour up to 64 / 255)."""
        n = i.node("ShaderNodeValToRGB", [(0, _map_range(i, 0.2451, 0.2551))])
        r = n.color_ramp
        r.interpolation = "CONSTANT"
        r.elements[0].color = (0.1, 0.5, 0.9, 1.0)
        r.elements[1].position = 0.25
        r.elements[1].color = (1.0, 0.2, 0.0, 1.0)
        return n.outputs["Color"]

    def curve(kind):
        def build(i):
            n = i.node(kind, [(1, i.A if kind != "ShaderNodeFloatCurve" else i.x)])
            c = n.mapping.curves[0]
            c.points.new(0.4, 0.8)
            n.mapping.update()
            return n.outputs[0]
        return build

    def mapping(kind):
        def build(i):
            n = i.node("ShaderNodeMapping", [(0, i.A)], vector_type=kind)
            for name, v in (("Location", (0.3, -0.2, 0.5)), ("Rotation", (0.4, 1.1, -0.7)),
                            ("Scale", (1.5, 0.5, 2.0))):
                if name in n.inputs:
                    n.inputs[name].default_value = v
            return n.outputs[0]
        return build
    cases = {"ramp linear": ramp("LINEAR"), "ramp constant": ramp("CONSTANT"),
             "ramp constant at its stop": ramp_at_stop,
             "ramp alpha": ramp("LINEAR", "Alpha"), "float curve": curve("ShaderNodeFloatCurve"),
             "rgb curves": curve("ShaderNodeRGBCurve"),
             "vector curves": curve("ShaderNodeVectorCurve"),
             **{f"mapping {k.lower()}": mapping(k) for k in ("POINT", "TEXTURE", "VECTOR",
                                                              "NORMAL")},
             "fresnel": lambda i: i.node("ShaderNodeFresnel", [(0, i.s)]).outputs[0],
             "layer weight fresnel": lambda i: i.node("ShaderNodeLayerWeight",
                                                      [(0, i.x)]).outputs[0],
             "layer weight facing": lambda i: i.node("ShaderNodeLayerWeight",
                                                     [(0, i.x)]).outputs[1]}
    compare_cases(list(cases.values()), render_direct, tmp_path, list(cases))


def test_map_range_vector_as_cycles(render_direct, tmp_path):
    """Map Range in vector mode: every interpolation, clamped or not, a reversed range."""
    def case(kind, clamp, reverse=False):
        def build(i):
            n = i.node("ShaderNodeMapRange", data_type="FLOAT_VECTOR", interpolation_type=kind,
                       clamp=clamp)
            i.t.links.new(i.A, n.inputs["Vector"])
            fmin, fmax = ((0.9, 0.8, 0.7), (0.1, 0.3, 0.2)) if reverse else \
                ((0.1, 0.2, -0.1), (0.8, 0.7, 1.2))
            for name, v in (("From_Min_FLOAT3", fmin), ("From_Max_FLOAT3", fmax),
                            ("To_Min_FLOAT3", (-1.0, 0.5, 2.0)),
                            ("To_Max_FLOAT3", (2.0, -0.5, 3.0)),
                            ("Steps_FLOAT3", (3.0, 4.0, 5.0))):
                next(s for s in n.inputs if s.identifier == name).default_value = v
            return n.outputs["Vector"]
        return build
    cases = {f"{k.lower()}{' clamp' if c else ''}{' reversed' if r else ''}": case(k, c, r)
             for k in ("LINEAR", "STEPPED", "SMOOTHSTEP", "SMOOTHERSTEP")
             for c in (False, True) for r in (False, True)}
    compare_cases(list(cases.values()), render_direct, tmp_path, list(cases))


def _map_range(i, lo, hi):
    """The input x (0..1 per pixel) mapped linearly to [lo, hi]."""
    return i.node("ShaderNodeMapRange", [(0, i.x)], in_3=lo, in_4=hi).outputs[0]


def _spectral(idname, linked=None, value=None):
    """A Blackbody or Wavelength node on a linked input (x mapped to the range ``linked``) or a
    constant (folded at export), emitted as it is (never negative: no offset)."""
    def build(i):
        n = i.node(idname)
        if linked is not None:
            i.t.links.new(_map_range(i, *linked), n.inputs[0])
        else:
            n.inputs[0].default_value = value
        return n.outputs[0]
    build.offset = 0.0
    return build


def test_blackbody_as_cycles(render_direct, tmp_path):
    """Blackbody: temperatures from links (per pixel, across every interval of Cycles' fit,
    below 800 K and above 12000 K) and constants (folded at export), within 1e-3 of the
    colour (relative above 1)."""
    ranges = [(300.0, 1000.0), (900.0, 2000.0), (1800.0, 3500.0), (3200.0, 7000.0),
              (6000.0, 13000.0), (11000.0, 40000.0)]
    temps = [500.0, 799.0, 800.0, 965.0, 1200.0, 1500.0, 3000.0, 6500.0, 11999.0, 12000.0,
             20000.0, 0.0, -50.0]
    cases = {f"linked {a:g}-{b:g} K": _spectral("ShaderNodeBlackbody", (a, b))
             for a, b in ranges}
    cases.update({f"{t:g} K": _spectral("ShaderNodeBlackbody", value=t) for t in temps})
    compare_cases(list(cases.values()), render_direct, tmp_path, list(cases))


def test_wavelength_as_cycles(render_direct, tmp_path):
    """Wavelength: wavelengths from links (per pixel, 360-800 nm: the extrapolated step below
    380 nm and the zeros outside included) and constants (folded at export)."""
    ranges = [(360.0, 480.0), (470.0, 590.0), (580.0, 700.0), (690.0, 800.0), (300.0, 900.0)]
    waves = [200.0, 374.9, 377.5, 380.0, 432.1, 500.0, 555.5, 610.0, 700.0, 779.9, 780.0,
             1000.0]
    cases = {f"linked {a:g}-{b:g} nm": _spectral("ShaderNodeWavelength", (a, b))
             for a, b in ranges}
    cases.update({f"{w:g} nm": _spectral("ShaderNodeWavelength", value=w) for w in waves})
    compare_cases(list(cases.values()), render_direct, tmp_path, list(cases))
