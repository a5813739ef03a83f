"""Shader programs: a material's node graph as a short list of instructions the kernels run at
every hit (kernels/svm/svm.h; the design Cycles calls SVM).  The exporter
(export/shader_graph.py) compiles each material's graph; this module holds what the exporter,
the core and the kernels share: the op codes, the encoding, the BSDF node fields a program may
drive, and the ops' arithmetic for constant folding (the same formulas as kernels/svm/svm_nodes.h).

A program is a run of int4 words in ``SceneArrays.svm``; a material names its first word
(MATERIAL_DTYPE ``program``, 0 = none: word 0 is never a program).  Layout::

    header       (n_binds, n_words, stack_floats, flags)
    n_binds x    (node, field_word, n_components, stack_slot)   a BSDF node's input from the stack
    ops ...      (op, a, b, c) [+ parameter words], then (SVM_END, 0, 0, 0)

The stack is private floats; a colour or vector takes three consecutive slots.  ``node`` counts
the material's BSDF nodes from 0, ``field_word`` is the float's index in SHADER_NODE_DTYPE.
"""
from __future__ import annotations

import math

import numpy as np

from ppm_engine.scene.arrays import SHADER_NODE_DTYPE

# --- op codes (kernels/svm/svm.h SVM_*) -----------------------------------------------------------
SVM_END = 0
SVM_CONST = 1          # (op, slot, n, 0) + (x, y, z, w) as float bits
SVM_GEOMETRY = 2       # (op, slot, what, 0): GEOM_*
SVM_IMAGE = 3          # (op, color_slot, alpha_slot, vector_slot) + (texture, unassociate,
#                        IMAGE_PROJECTIONS, n) + (blend bits, normal slot, 0, 0) + n words of
#                        UDIM tiles (tile, texture, tile, texture) (kernels/svm/svm_image.h)
SVM_MAPPING = 4        # (op, out, vector, type) + 3 words: the 3x4 matrix rows (float bits)
SVM_MATH = 5           # (op, out, a, b) + (c, MATH_*, clamp, 0)
SVM_VECTOR_MATH = 6    # (op, out_vector, a, b) + (c, VMATH_*, out_value, scale)
SVM_MIX = 7            # (op, out, a, b) + (fac, MIX_*, flags, 0); flags MIXF_*
SVM_COMBINE = 8        # (op, out, x, y) + (z, 0, 0, 0): three floats into a vector
SVM_COLOR_CONVERT = 9  # (op, out, in, mode): COLOR_RGB_TO_HSV ... (Separate/Combine Color)
SVM_INVERT = 10        # (op, out, fac, color)
SVM_GAMMA = 11         # (op, out, color, gamma)
SVM_BRIGHT_CONTRAST = 12  # (op, out, color, bright) + (contrast, 0, 0, 0)
SVM_RGB_TO_BW = 13     # (op, out, color, 0)
SVM_CLAMP = 14         # (op, out, value, min) + (max, type, 0, 0)
SVM_MAP_RANGE = 15     # (op, out, value, from_min) + (from_max, to_min, to_max, steps)
#                        + (type, clamp, 0, 0)
SVM_TABLE = 16         # (op, out, in, n) + (mode, interp, 0, 0) + n words (r, g, b, a): ramps,
#                        curves
SVM_HSV = 17           # (op, out, color, fac) + (hue, saturation, value, 0)
SVM_FRESNEL = 18       # (op, out, ior, 0)
SVM_LAYER_WEIGHT = 19  # (op, out_fresnel, blend, out_facing)
SVM_NORMAL_MAP = 20    # (op, out, color, strength) + (NORMAL_MAP_SPACES, 0, 0, 0)
# Procedural textures (kernels/svm/svm_textures.h).  An output slot of -1 is not written (the
# output is not linked); a float input is a pair of words at the same position in a "slots"
# and a "values" word: its stack slot, or -1 and its constant's float bits.
SVM_TEX_CHECKER = 21   # (op, color, fac, vector) + (color1, color2, scale slot, scale)
SVM_TEX_GRADIENT = 22  # (op, color, fac, vector) + (GRADIENT_TYPES, 0, 0, 0)
SVM_TEX_WHITE_NOISE = 23  # (op, value, color, vector) + (dimensions, w slot, w, 0)
SVM_TEX_NOISE = 24     # (op, fac, color, vector) + slots (w, scale, detail, roughness),
#                        (lacunarity, offset, gain, distortion) + their values
#                        + (dimensions, NOISE_TYPES, normalize, 0)
SVM_TEX_MAGIC = 25     # (op, color, fac, vector) + slots (scale, distortion) + values
#                        + (depth, 0, 0, 0)
SVM_TEX_WAVE = 26      # (op, color, fac, vector) + slots (scale, distortion, detail,
#                        detail scale), (detail roughness, phase) + values
#                        + (WAVE_TYPES, bands direction, rings direction, profile)
SVM_TEX_BRICK = 27     # (op, color, fac, vector) + slots (scale, mortar size, mortar smooth,
#                        bias), (brick width, row height) + values + (color1, color2, mortar, 0)
#                        + (offset frequency, squash frequency, offset, squash)
SVM_TEX_VORONOI = 28   # (op, distance, color, vector) + slots (w, scale, detail, roughness),
#                        (lacunarity, smoothness, exponent, randomness) + values
#                        + (dimensions, VORONOI_FEATURES, VORONOI_METRICS, normalize)
#                        + (position, w out, radius, 0)
SVM_TEX_LAST = 28
SVM_BLACKBODY = 29     # (op, out, temperature, 0): kernels/svm/svm_color.h
SVM_WAVELENGTH = 30    # (op, out, wavelength, 0)
SVM_BUMP = 31          # (op, out, normal (-1: the shading normal), distance)
#                        + (height at the centre, at offset 1, at offset 2, strength)
#                        + (invert, filter width, 0, 0): the Bump node (kernels/svm/svm_bump.h)
# (32-34: free)
SVM_TEX_SKY = 35       # (op, color, vector, SKY_*) + (n, 0, 0, 0) + n words of float
#                        parameters (kernels/svm/svm_sky.h; export/sky.py)
SVM_OPS = 36           # op codes stay < 64 (PPM_SVM_OPS is a bitmask in a ulong)

OP_NAMES = ("end", "const", "geometry", "image", "mapping", "math", "vector_math", "mix",
            "combine", "color_convert", "invert", "gamma", "bright_contrast", "rgb_to_bw",
            "clamp", "map_range", "table", "hsv", "fresnel", "layer_weight", "normal_map",
            "tex_checker", "tex_gradient", "tex_white_noise", "tex_noise", "tex_magic",
            "tex_wave", "tex_brick", "tex_voronoi", "blackbody", "wavelength", "bump", "(32)",
            "(33)", "(34)", "tex_sky")
# parameter words after each op's first word
OP_EXTRA = {SVM_CONST: 1, SVM_IMAGE: 2, SVM_MAPPING: 3, SVM_MATH: 1, SVM_VECTOR_MATH: 1,
            SVM_MIX: 1, SVM_COMBINE: 1, SVM_BRIGHT_CONTRAST: 1, SVM_CLAMP: 1, SVM_MAP_RANGE: 2,
            SVM_HSV: 1, SVM_TABLE: 2, SVM_NORMAL_MAP: 1,   # (+ a table's entries, op_words)
            SVM_TEX_CHECKER: 1, SVM_TEX_GRADIENT: 1, SVM_TEX_WHITE_NOISE: 1, SVM_TEX_NOISE: 5,
            SVM_TEX_MAGIC: 3, SVM_TEX_WAVE: 5, SVM_TEX_BRICK: 6, SVM_TEX_VORONOI: 6,
            SVM_BUMP: 2, SVM_TEX_SKY: 1}   # (a sky's n parameter words follow)
SKY_TYPES = {"PREETHAM": 0, "HOSEK_WILKIE": 1, "SINGLE_SCATTERING": 2,
             "MULTIPLE_SCATTERING": 2}     # kernels/svm/svm_sky.h SKY_*
assert len(OP_NAMES) == SVM_OPS <= 64
# an Image Texture's projection (and the Environment Texture's equirectangular one)
IMAGE_PROJECTIONS = {"FLAT": 0, "EQUIRECTANGULAR": 1, "BOX": 2, "SPHERE": 3, "TUBE": 4,
                     "MIRROR_BALL": 5}

GEOM_UV = 0            # (u, v, 0) of the render UV map
GEOM_NORMAL = 1        # shading normal (world, facing the viewer)
GEOM_TRUE_NORMAL = 2
GEOM_INCOMING = 3      # towards the viewer
GEOM_BACKFACING = 4    # 1 when the ray hit the back
GEOM_GENERATED = 5     # Generated coordinates (SceneArrays.generated)
GEOM_REFLECTION = 6    # the view direction mirrored about the shading normal (world)
GEOM_POSITION = 7      # the shading point (world)
GEOM_OBJECT = 8        # the shading point in its object's space (SceneArrays.objects)
GEOM_OBJECT_LOCATION = 9
GEOM_OBJECT_COLOR = 10
GEOM_OBJECT_ALPHA = 11     # (one float, as the three below)
GEOM_OBJECT_INDEX = 12     # the object's pass index
GEOM_OBJECT_RANDOM = 13
GEOM_LIGHT_PATH = 14   # (op, slot, GEOM_LIGHT_PATH, output): one float
                       # (kernels/integrator/path_state.h)
LIGHT_PATH_OUTPUTS = ("Is Camera Ray", "Is Shadow Ray", "Is Diffuse Ray", "Is Glossy Ray",
                      "Is Singular Ray", "Is Reflection Ray", "Is Transmission Ray",
                      "Is Volume Scatter Ray", "Ray Length", "Ray Depth", "Diffuse Depth",
                      "Glossy Depth", "Transparent Depth", "Transmission Depth", "Portal Depth")
GEOM_WINDOW = 15       # the point projected into the camera's frame: (0..1, 0..1, 0)
GEOM_ATTRIBUTE = 16    # + k: attribute k's colour or vector (SceneArrays.attributes)
GEOM_ATTRIBUTE_ALPHA = 24  # + k: attribute k's alpha
MAX_ATTRIBUTES = 8     # distinct mesh attributes a scene's programs may read
# what | GEOM_BUMP_OFFSET * k, with the op's last word the filter width's float bits: a
# position-dependent input at the Bump node's offset k = 1, 2 (kernels/svm/svm_bump.h)
GEOM_BUMP_OFFSET = 256

COLOR_RGB_TO_HSV, COLOR_HSV_TO_RGB, COLOR_RGB_TO_HSL, COLOR_HSL_TO_RGB = 0, 1, 2, 3

MIXF_CLAMP_FACTOR, MIXF_CLAMP_RESULT, MIXF_SCALAR, MIXF_VECTOR_FACTOR = 1, 2, 4, 8
TABLE_SCALAR, TABLE_RGB, TABLE_VECTOR = 0, 1, 2   # ramp/float curve, RGB curves, vector curves
TABLE_SIZE = 257     # entries of a baked ramp or curve: Cycles' RAMP_TABLE_SIZE + 1, at i / 256

# Math node operations (Blender's enum names; kernels/svm/svm_nodes.h MATH_*)
MATH_OPS = ("ADD", "SUBTRACT", "MULTIPLY", "DIVIDE", "MULTIPLY_ADD", "POWER", "LOGARITHM",
            "SQRT", "INVERSE_SQRT", "ABSOLUTE", "EXPONENT", "MINIMUM", "MAXIMUM", "LESS_THAN",
            "GREATER_THAN", "SIGN", "COMPARE", "SMOOTH_MIN", "SMOOTH_MAX", "ROUND", "FLOOR",
            "CEIL", "TRUNC", "FRACT", "MODULO", "FLOORED_MODULO", "WRAP", "SNAP", "PINGPONG",
            "SINE", "COSINE", "TANGENT", "ARCSINE", "ARCCOSINE", "ARCTANGENT", "ARCTAN2", "SINH",
            "COSH", "TANH", "RADIANS", "DEGREES")
MATH = {name: i for i, name in enumerate(MATH_OPS)}
VMATH_OPS = ("ADD", "SUBTRACT", "MULTIPLY", "DIVIDE", "MULTIPLY_ADD", "CROSS_PRODUCT", "PROJECT",
             "REFLECT", "REFRACT", "FACEFORWARD", "DOT_PRODUCT", "DISTANCE", "LENGTH", "SCALE",
             "NORMALIZE", "ABSOLUTE", "POWER", "SIGN", "MINIMUM", "MAXIMUM", "FLOOR", "CEIL",
             "FRACTION", "MODULO", "WRAP", "SNAP", "SINE", "COSINE", "TANGENT")
VMATH = {name: i for i, name in enumerate(VMATH_OPS)}
MIX_OPS = ("MIX", "ADD", "MULTIPLY", "SUBTRACT", "SCREEN", "DIVIDE", "DIFFERENCE", "EXCLUSION",
           "DARKEN", "LIGHTEN", "OVERLAY", "DODGE", "BURN", "HUE", "SATURATION", "VALUE",
           "COLOR", "SOFT_LIGHT", "LINEAR_LIGHT")
MIX = {name: i for i, name in enumerate(MIX_OPS)}
MAP_RANGE_TYPES = {"LINEAR": 0, "STEPPED": 1, "SMOOTHSTEP": 2, "SMOOTHERSTEP": 3}
MAPPING_TYPES = {"POINT": 0, "TEXTURE": 1, "VECTOR": 2, "NORMAL": 3}
# SVM_MAPPING's kinds past MAPPING_TYPES: by the shading object's own matrices (kernels/svm/svm.h),
# a point, a direction or a normal into the object's space or out of it to the world
MAPPING_OBJECT = {"TO_OBJECT_POINT": 4, "TO_OBJECT_VECTOR": 5, "TO_OBJECT_NORMAL": 6,
                  "TO_WORLD_POINT": 7, "TO_WORLD_VECTOR": 8, "TO_WORLD_NORMAL": 9}
# and by the camera's (Cycles' camera space: the render camera's placement, +z ahead), read from
# the scene's camera when the program runs: a viewport's view that moves needs no new program
MAPPING_CAMERA = {"TO_CAMERA_POINT": 10, "TO_CAMERA_VECTOR": 11, "TO_CAMERA_NORMAL": 12,
                  "FROM_CAMERA_POINT": 13, "FROM_CAMERA_VECTOR": 14, "FROM_CAMERA_NORMAL": 15}
CLAMP_TYPES = {"MINMAX": 0, "RANGE": 1}
NORMAL_MAP_SPACES = {"TANGENT": 0, "OBJECT": 1, "WORLD": 2, "BLENDER_OBJECT": 3,
                     "BLENDER_WORLD": 4}
# texture node options (Blender's enum names; kernels/svm/svm_textures.h)
GRADIENT_TYPES = {"LINEAR": 0, "QUADRATIC": 1, "EASING": 2, "DIAGONAL": 3, "RADIAL": 4,
                  "QUADRATIC_SPHERE": 5, "SPHERICAL": 6}
NOISE_TYPES = {"FBM": 0, "MULTIFRACTAL": 1, "HYBRID_MULTIFRACTAL": 2, "RIDGED_MULTIFRACTAL": 3,
               "HETERO_TERRAIN": 4}
WAVE_TYPES = {"BANDS": 0, "RINGS": 1}
WAVE_BANDS = {"X": 0, "Y": 1, "Z": 2, "DIAGONAL": 3}
WAVE_RINGS = {"X": 0, "Y": 1, "Z": 2, "SPHERICAL": 3}
WAVE_PROFILES = {"SIN": 0, "SAW": 1, "TRI": 2}
VORONOI_FEATURES = {"F1": 0, "F2": 1, "SMOOTH_F1": 2, "DISTANCE_TO_EDGE": 3,
                    "N_SPHERE_RADIUS": 4}
VORONOI_METRICS = {"EUCLIDEAN": 0, "MANHATTAN": 1, "CHEBYCHEV": 2, "MINKOWSKI": 3}

# BSDF node inputs a shader program may drive: bit i of a node's ``bound`` is BINDABLE[i]
BINDABLE = ("weight", "color", "edge_tint", "emission", "coat_tint", "sheen_tint", "roughness",
            "metallic", "ior", "alpha", "transmission", "specular_ior_level", "anisotropic",
            "anisotropic_rotation", "coat_weight", "coat_roughness", "coat_ior", "sheen_weight",
            "sheen_roughness", "subsurface_weight", "diffuse_roughness", "normal", "coat_normal")
BOUND = {name: 1 << i for i, name in enumerate(BINDABLE)}
# the BSDF node fields a program may drive, as float word indexes
FIELD_WORD = {name: SHADER_NODE_DTYPE.fields[name][1] // 4 for name in BINDABLE}

PROGRAM_EMISSION = 1   # header flags: the program drives an emission input (or a weight)
PROGRAM_TANGENTS = 2   # a tangent-space Normal Map reads the UV map's tangents (uv_tangents)
PROGRAM_GENERATED = 4  # Generated coordinates are read (SceneArrays.generated)
PROGRAM_ATTRIBUTES = 8  # mesh attributes are read (SceneArrays.attributes)
PROGRAM_OBJECT = 16    # the object's data are read (SceneArrays.object, objects)
PROGRAM_WINDOW = 32    # the Window coordinates are read (the camera's projection)
PROGRAM_BUMP = 64      # a Bump node reads the footprint's offsets (kernels/svm/svm_bump.h)
# a medium's density program that is its Volume object's grid of attribute k itself: its first
# op reads GEOM_ATTRIBUTE + k (its majorants are that grid's voxels: render/medium_bound.py)
PROGRAM_GRID = 128
MAX_STACK = 256        # floats of stack a program may use (kernels: PPM_SVM_STACK, the most a
                       # scene's programs use)


def f2i(x: float) -> int:
    """A float's bits as an int32 (parameters share the program's int words)."""
    return int(np.array([x], np.float32).view(np.int32)[0])


def ops_used(svm: np.ndarray, starts) -> int:
    """Bitmask of the op codes in the programs starting at ``starts`` (-D PPM_SVM_OPS)."""
    mask = 0
    for p in starts:
        p = int(p)
        if p <= 0:
            continue
        n_binds, n_words = int(svm[p, 0]), int(svm[p, 1])
        i, end = p + 1 + n_binds, p + n_words
        while i < end:
            op = int(svm[i, 0])
            if op == SVM_END:
                break
            if not 0 < op < SVM_OPS:
                raise ValueError(f"shader program at word {p}: unknown op {op} at word {i}")
            mask |= 1 << op
            i += op_words(svm, i)
    return mask


def op_words(svm: np.ndarray, i: int) -> int:
    """Words of the op at word ``i``: its first, its parameters, and the entries of a table,
    an image's UDIM tiles or a sky's parameters."""
    op = int(svm[i, 0])
    tail = (int(svm[i, 3]) if op == SVM_TABLE else int(svm[i + 1, 3]) if op == SVM_IMAGE
            else int(svm[i + 1, 0]) if op == SVM_TEX_SKY else 0)
    return 1 + OP_EXTRA.get(op, 0) + tail


def ops_define(mask: int) -> str:
    """The -D PPM_SVM_OPS value of an ops_used mask: a ulong literal (op codes up to 63)."""
    return f"{mask:#x}UL"


def attributes_read(svm: np.ndarray, p: int) -> list[int]:
    """The attributes k (GEOM_ATTRIBUTE + k, GEOM_ATTRIBUTE_ALPHA + k) the program at word p
    reads, in the order it reads them."""
    out: list[int] = []
    n_binds, n_words = int(svm[p, 0]), int(svm[p, 1])
    i, end = p + 1 + n_binds, p + n_words
    while i < end and int(svm[i, 0]) != SVM_END:
        what = int(svm[i, 2]) % GEOM_BUMP_OFFSET
        if int(svm[i, 0]) == SVM_GEOMETRY and what >= GEOM_ATTRIBUTE:
            k = (what - GEOM_ATTRIBUTE) % MAX_ATTRIBUTES
            if k not in out:
                out.append(k)
        i += op_words(svm, i)
    return out


def grid_density(svm: np.ndarray, p: int) -> int | None:
    """The attribute k whose grid the density program at word p is (PROGRAM_GRID), else None."""
    if p <= 0 or not int(svm[p, 3]) & PROGRAM_GRID:
        return None
    first = svm[p + 1 + int(svm[p, 0])]
    if int(first[0]) != SVM_GEOMETRY or not 0 <= int(first[2]) - GEOM_ATTRIBUTE < MAX_ATTRIBUTES:
        return None
    return int(first[2]) - GEOM_ATTRIBUTE


FIELD_DENSITY, FIELD_GLOW, FIELD_TINT = 0, 1, 2   # a density program's binds (their first word)


def field_glows(svm: np.ndarray, programs: np.ndarray) -> np.ndarray:
    """Per density program word (0: none), whether it also gives the medium's emission (a bind
    FIELD_GLOW: export/material_volume.py _glow)."""
    out = np.zeros(np.shape(programs), bool)
    for i, p in enumerate(np.asarray(programs, np.int64).ravel()):
        if 0 < p < svm.shape[0]:
            out.flat[i] = any(int(svm[p + 1 + b, 0]) == FIELD_GLOW for b in range(int(svm[p, 0]))
                              if p + 1 + b < svm.shape[0])
    return out


def stack_used(svm: np.ndarray, starts) -> int:
    return max([int(svm[int(p), 2]) for p in starts if int(p) > 0] or [0])


# --- the ops' arithmetic, for constant folding (float32 like the kernels) --------------------
def _safe_div(a, b):
    return a / b if b != 0.0 else 0.0


def _fmod(a, b):
    return math.fmod(a, b) if b != 0.0 else 0.0


def _pow(a, b):
    if a < 0.0 and b != float(int(b)):
        return 0.0
    if a == 0.0 and b < 0.0:
        return 0.0
    try:
        return math.pow(a, b)
    except OverflowError:
        return math.inf


def _wrap(v, hi, lo):
    r = hi - lo
    return v - r * math.floor((v - lo) / r) if r != 0.0 else lo


def _smoothmin(a, b, c):
    if c != 0.0:
        h = max(c - abs(a - b), 0.0) / c
        return min(a, b) - h * h * h * c * (1.0 / 6.0)
    return min(a, b)


def _pingpong(a, b):
    if b == 0.0:
        return 0.0
    x = (a - b) / (b * 2.0)
    return abs((x - math.floor(x)) * b * 2.0 - b)


def _guard(f):
    def g(*args):
        try:
            return f(*args)
        except (ValueError, OverflowError, ZeroDivisionError):
            return 0.0
    return g


MATH_FN = {
    "ADD": lambda a, b, c: a + b, "SUBTRACT": lambda a, b, c: a - b,
    "MULTIPLY": lambda a, b, c: a * b, "DIVIDE": lambda a, b, c: _safe_div(a, b),
    "MULTIPLY_ADD": lambda a, b, c: a * b + c, "POWER": lambda a, b, c: _pow(a, b),
    "LOGARITHM": lambda a, b, c: (math.log(a) / math.log(b)
                                  if a > 0.0 and b > 0.0 and b != 1.0 else 0.0),
    "SQRT": lambda a, b, c: math.sqrt(a) if a > 0.0 else 0.0,
    "INVERSE_SQRT": lambda a, b, c: 1.0 / math.sqrt(a) if a > 0.0 else 0.0,
    "ABSOLUTE": lambda a, b, c: abs(a), "EXPONENT": lambda a, b, c: math.exp(a),
    "MINIMUM": lambda a, b, c: min(a, b), "MAXIMUM": lambda a, b, c: max(a, b),
    "LESS_THAN": lambda a, b, c: float(a < b), "GREATER_THAN": lambda a, b, c: float(a > b),
    "SIGN": lambda a, b, c: 0.0 if a == 0.0 else math.copysign(1.0, a),
    "COMPARE": lambda a, b, c: float(a == b or abs(a - b) <= max(c, 1.1920929e-7)),
    "SMOOTH_MIN": lambda a, b, c: _smoothmin(a, b, c),
    "SMOOTH_MAX": lambda a, b, c: -_smoothmin(-a, -b, c),
    "ROUND": lambda a, b, c: math.floor(a + 0.5), "FLOOR": lambda a, b, c: math.floor(a),
    "CEIL": lambda a, b, c: math.ceil(a), "TRUNC": lambda a, b, c: float(math.trunc(a)),
    "FRACT": lambda a, b, c: a - math.floor(a), "MODULO": lambda a, b, c: _fmod(a, b),
    "FLOORED_MODULO": lambda a, b, c: a - math.floor(a / b) * b if b != 0.0 else 0.0,
    "WRAP": lambda a, b, c: _wrap(a, b, c),
    "SNAP": lambda a, b, c: math.floor(_safe_div(a, b)) * b,
    "PINGPONG": lambda a, b, c: _pingpong(a, b),
    "SINE": lambda a, b, c: math.sin(a), "COSINE": lambda a, b, c: math.cos(a),
    "TANGENT": lambda a, b, c: math.tan(a),
    "ARCSINE": lambda a, b, c: math.asin(min(max(a, -1.0), 1.0)),
    "ARCCOSINE": lambda a, b, c: math.acos(min(max(a, -1.0), 1.0)),
    "ARCTANGENT": lambda a, b, c: math.atan(a),
    "ARCTAN2": lambda a, b, c: 0.0 if a == 0.0 and b == 0.0 else math.atan2(a, b),
    "SINH": lambda a, b, c: math.sinh(a), "COSH": lambda a, b, c: math.cosh(a),
    "TANH": lambda a, b, c: math.tanh(a), "RADIANS": lambda a, b, c: math.radians(a),
    "DEGREES": lambda a, b, c: math.degrees(a),
}
MATH_FN = {k: _guard(f) for k, f in MATH_FN.items()}
assert set(MATH_FN) == set(MATH_OPS)


def fold_math(op: str, a: float, b: float, c: float, clamp: bool) -> float:
    r = float(np.float32(MATH_FN[op](float(a), float(b), float(c))))
    return min(max(r, 0.0), 1.0) if clamp else r
