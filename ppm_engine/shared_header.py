"""kernels/shared.h: what the Python host and the OpenCL kernels must agree on, generated from
the Python tables so that each value is written once.

    python -m ppm_engine.shared_header           # writes kernels/shared.h again
    python -m ppm_engine.shared_header --check   # exit 1 when it is stale

The header holds, each with the table it comes from: the kernels' feature flags and build
parameters (``#ifndef`` defaults: a program built without ``-D`` flags has every feature), the
``#define`` families of codes and flags (visibility bits, light and node types, material flags,
counters, shader program op codes and their option codes, the shading tables' offsets...), the
structs that mirror the NumPy dtypes field for field (the dtypes' field comments come along),
and the scene's buffers as one X-macro list (``SCENE_DATA``, device_scene.SCENE_BUFFERS).

Kernel code uses these names and never repeats a number of theirs; what only the kernels use
(closure types, sample labels, the Light Path node's bits) stays in the kernel headers."""
from __future__ import annotations

import argparse
import inspect
import re
import sys
import textwrap
from pathlib import Path

import numpy as np

HEADER = "shared.h"
WIDTH = 100                # the kernels' line length (kernels/.clang-format)

_C_TYPES = {np.dtype(np.int32): "int", np.dtype(np.uint32): "uint",
            np.dtype(np.float32): "float"}


def c_float(x: float) -> str:
    """A float32 literal that C reads back as exactly np.float32(x): the shortest decimal that
    identifies it, with the f suffix."""
    v = np.float32(x)
    if v == 0 or 1e-4 <= abs(v) < 1e7:
        s = np.format_float_positional(v, unique=True, trim="0")
    else:
        mant, exp = np.format_float_scientific(v, unique=True, trim="-").split("e")
        s = f"{mant}e{int(exp)}"
    return s + "f"


def _comment(text: str, indent: str = "", width: int = WIDTH) -> list[str]:
    """``text`` as a C comment of lines at most ``width`` long."""
    lines = textwrap.wrap(text, width - len(indent) - 3)
    if len(lines) == 1 and len(lines[0]) + len(indent) + 6 <= width:
        return [f"{indent}/* {lines[0]} */"]
    lines = textwrap.wrap(text, width - len(indent) - 6)
    return ([f"{indent}/* {lines[0]}"] + [f"{indent} * {line}" for line in lines[1:-1]]
            + [f"{indent} * {lines[-1]} */"] if len(lines) > 1 else [f"{indent}/* {lines[0]} */"])


def _family(comment: str, items, suffix: str = "") -> list[str]:
    lines = _comment(comment)
    lines += [f"#define {name} {int(value)}{suffix}" for name, value in items]
    return lines


def _prefixed(prefix: str, table) -> list[tuple[str, int]]:
    """(PREFIX_NAME, value) for a dict of names, or a tuple of names (their index)."""
    pairs = table.items() if isinstance(table, dict) else ((n, i) for i, n in enumerate(table))
    return [(prefix + name.upper().replace(" ", "_"), v) for name, v in pairs]


def _constants(module, prefix: str, exclude=()) -> list[tuple[str, int]]:
    """The module's int constants whose names start with prefix, in the order written."""
    return [(k, v) for k, v in vars(module).items()
            if k.startswith(prefix) and k not in exclude and isinstance(v, int)
            and not isinstance(v, bool)]


# --- structs from dtypes ---------------------------------------------------------------------
def _field_comments(module, name: str) -> dict[str, str]:
    """The comments of the fields of dtype ``name`` in its module's source: a field line's
    trailing comment and the comment lines aligned under it (its continuation), and the comment
    lines above a field at its indentation."""
    src = inspect.getsource(module)
    start = src.index(f"{name} = np.dtype([")
    block = src[start:src.index("])", start)].splitlines()[1:]
    comments: dict[str, str] = {}
    pending: list[str] = []
    last, last_col = None, -1
    for line in block:
        field = re.match(r"\s*\(\s*[\"'](\w+)[\"']", line)
        hash_col = line.find("#")
        text = line[hash_col + 1:].strip() if hash_col >= 0 else ""
        if field:
            last, last_col = field[1], hash_col
            note = " ".join(pending + ([text] if text else []))
            if note:
                comments[last] = note
            pending = []
        elif text and last is not None and hash_col == last_col:
            comments[last] = f"{comments[last]} {text}"      # continues the line above's
        elif text:
            pending.append(text)
    return comments


def _struct(ctype: str, dtype: np.dtype, origin: str, comments: dict[str, str]) -> list[str]:
    lines = [f"/* mirrors {origin} */", "typedef struct {"]
    for fname in dtype.names:
        ft, _off = dtype.fields[fname][:2]
        base, shape = (ft.subdtype if ft.subdtype else (ft, ()))
        count = int(np.prod(shape)) if shape else 0
        decl = f"    {_C_TYPES[np.dtype(base)]} {fname}{f'[{count}]' if count else ''};"
        note = comments.get(fname)
        inline = f"{decl}{' ' * max(1, 28 - len(decl))}/* {note} */" if note else decl
        lines += [inline] if len(inline) <= WIDTH else _comment(note, "    ") + [decl]
    lines.append(f"}} {ctype};")
    return lines


# --- the header ----------------------------------------------------------------------------
def generate() -> str:
    """The text of kernels/shared.h from the Python tables."""
    from . import camera_model, counters, emitters, features, materials, photon_map
    from . import scene_arrays as sa
    from . import shader_program as sp
    from . import shading_tables as st
    from .film import FILTER_TABLE_SIZE
    from .options import RenderOptions
    from .passes import gather, hash_build

    out = ["/* GENERATED by `python -m ppm_engine.shared_header` from the Python tables each "
           "section names:",
           " * edit them and run it again (tests/test_shared_header.py fails while this file is "
           "stale).",
           " * Its layout is the generator's: the formatter (kernels/.clang-format) leaves it. */",
           "/* clang-format off */",
           "#ifndef PPM_SHARED_H", "#define PPM_SHARED_H", ""]

    # feature flags: a program built without PPM_SPECIALIZED has every feature
    out += ["/* --- the kernels' feature flags (ppm_engine/features.py FEATURES): built with",
            " * -D PPM_SPECIALIZED and a -D per feature the scene has; 0 or 1 each, tested",
            " * with #if or in plain conditions whose dead branch the compiler drops. */",
            "#ifndef PPM_SPECIALIZED", "#define PPM_ALL_FEATURES 1", "#else",
            "#define PPM_ALL_FEATURES 0", "#endif"]
    for name, what in features.FEATURES.items():
        out += _comment(f"{name}: {what}") + [f"#ifndef {name}",
                                                f"#define {name} PPM_ALL_FEATURES", "#endif"]
    out += ["", "/* --- build parameters: the scene's values by -D, else these defaults */",
            "/* the most closures a material makes (ppm_engine/materials.py MAX_CLOSURES) */",
            "#ifndef PPM_MAX_CLOSURES", f"#define PPM_MAX_CLOSURES {materials.MAX_CLOSURES}",
            "#endif",
            "/* floats of a shader program's stack (ppm_engine/shader_program.py MAX_STACK) */",
            "#ifndef PPM_SVM_STACK", f"#define PPM_SVM_STACK {sp.MAX_STACK}", "#endif",
            "/* microfacet lobes at least this rough (sqrt of alpha) hold visible points and "
            "photons",
            " * (ppm_engine/options.py RenderOptions.gather_roughness) */",
            "#ifndef PPM_GATHER_ROUGHNESS",
            f"#define PPM_GATHER_ROUGHNESS {c_float(RenderOptions.gather_roughness)}", "#endif",
            ""]

    fam = []
    fam += [_family("triangle and ray visibility bits (ppm_engine/scene_arrays.py VIS_*)",
                    _constants(sa, "VIS_", ("VIS_ALL",)), "u")]
    fam += [_family("light types (scene_arrays.py LIGHT_*)",
                    [(k, v) for k, v in _constants(sa, "LIGHT_") if "FLAG" not in k
                     and "SHIFT" not in k]),
            _family("light flags (scene_arrays.py)", [("LIGHT_FLAG_SOFT_FALLOFF",
                                                       sa.LIGHT_FLAG_SOFT_FALLOFF)], "u"),
            _family("a light hidden from rays of type VIS_x has VIS_x << this in its flags",
                    [("LIGHT_HIDDEN_SHIFT", sa.LIGHT_HIDDEN_SHIFT)]),
            _family("the world's flags (scene_arrays.py)",
                    [("WORLD_HIDDEN_CAMERA", sa.WORLD_HIDDEN_CAMERA)]),
            _family("camera types and film flags (ppm_engine/camera_model.py)",
                    _constants(camera_model, "CAMERA_") + _constants(camera_model, "FILM_")),
            _family("material flags (ppm_engine/materials.py MAT_*)",
                    _constants(materials, "MAT_"), "u"),
            _family("BSDF node types (scene_arrays.py NODE_*)",
                    [(k, v) for k, v in _constants(sa, "NODE_") if "FLAG" not in k]),
            _family("BSDF node flags (scene_arrays.py NODE_FLAG_*)",
                    _constants(sa, "NODE_FLAG_"), "u"),
            _family("image texture extension modes and flags (scene_arrays.py TEX_*)",
                    _constants(sa, "TEX_"), "u"),
            _family("counters the passes share (ppm_engine/counters.py Counter)",
                    [("CNT_" + c.name, c.value) for c in counters.Counter]
                    + [("N_COUNTERS", counters.N_COUNTERS)]),
            _family("emissive triangles picked among locally at most "
                    "(ppm_engine/emitters.py LOCAL_PICK_MAX)",
                    [("LOCAL_PICK_MAX", emitters.LOCAL_PICK_MAX)]),
            _family("entries of the pixel filter's table (ppm_engine/film.py FILTER_TABLE_SIZE)",
                    [("FILTER_TABLE_SIZE", FILTER_TABLE_SIZE)]),
            _family("offsets of the shading tables in their buffer "
                    "(ppm_engine/shading_tables.py LAYOUT, SIZE)",
                    [("TAB_" + k.upper(), off) for k, (off, _) in st.LAYOUT.items()]
                    + [("TAB_SIZE", st.SIZE)]),
            _family("the tables precompute.cl computes (shading_tables.py KINDS)",
                    _prefixed("KIND_", st.KINDS)),
            _family("shader program op codes (ppm_engine/shader_program.py SVM_*; < 64: "
                    "PPM_SVM_OPS is a bitmask)", _constants(sp, "SVM_")),
            _family("shader program header flags (shader_program.py PROGRAM_*)",
                    _constants(sp, "PROGRAM_")),
            _family("what SVM_GEOMETRY reads (shader_program.py GEOM_*; GEOM_ATTRIBUTE + k, "
                    "GEOM_ATTRIBUTE_ALPHA + k for attribute k)", _constants(sp, "GEOM_")),
            _family("mesh attributes a scene's programs may read at most "
                    "(shader_program.py MAX_ATTRIBUTES)", [("MAX_ATTRIBUTES",
                                                            sp.MAX_ATTRIBUTES)]),
            _family("Light Path node outputs (shader_program.py LIGHT_PATH_OUTPUTS)",
                    _prefixed("LIGHT_PATH_", [n.replace("Is ", "").replace(" Ray", "")
                                              for n in sp.LIGHT_PATH_OUTPUTS])),
            _family("colour conversions of SVM_COLOR_CONVERT (shader_program.py COLOR_*)",
                    _constants(sp, "COLOR_")),
            _family("SVM_MIX flags (shader_program.py MIXF_*)", _constants(sp, "MIXF_")),
            _family("SVM_TABLE modes and size (shader_program.py TABLE_*)",
                    _constants(sp, "TABLE_")),
            _family("Math node operations (shader_program.py MATH_OPS)",
                    _prefixed("MATH_", sp.MATH_OPS)),
            _family("Vector Math node operations (shader_program.py VMATH_OPS)",
                    _prefixed("VMATH_", sp.VMATH_OPS)),
            _family("Mix node blend types (shader_program.py MIX_OPS)",
                    _prefixed("MIX_", sp.MIX_OPS)),
            _family("Map Range types (shader_program.py MAP_RANGE_TYPES)",
                    _prefixed("MAP_RANGE_", sp.MAP_RANGE_TYPES)),
            _family("Mapping and Vector Transform kinds (shader_program.py MAPPING_TYPES, "
                    "MAPPING_OBJECT)", _prefixed("MAPPING_", sp.MAPPING_TYPES)
                    + _prefixed("MAPPING_", sp.MAPPING_OBJECT)),
            _family("Clamp types (shader_program.py CLAMP_TYPES)",
                    _prefixed("CLAMP_", sp.CLAMP_TYPES)),
            _family("Normal Map spaces (shader_program.py NORMAL_MAP_SPACES)",
                    _prefixed("NORMAL_MAP_", sp.NORMAL_MAP_SPACES)),
            _family("image projections (shader_program.py IMAGE_PROJECTIONS)",
                    _prefixed("IMAGE_", sp.IMAGE_PROJECTIONS)),
            _family("Sky Texture types (shader_program.py SKY_TYPES)",
                    _prefixed("SKY_", sp.SKY_TYPES)),
            _family("Gradient Texture types (shader_program.py GRADIENT_TYPES)",
                    _prefixed("GRADIENT_", sp.GRADIENT_TYPES)),
            _family("Noise Texture types (shader_program.py NOISE_TYPES)",
                    _prefixed("NOISE_", sp.NOISE_TYPES)),
            _family("Wave Texture types, directions and profiles (shader_program.py WAVE_*)",
                    _prefixed("WAVE_TYPE_", sp.WAVE_TYPES) + _prefixed("WAVE_BANDS_", sp.WAVE_BANDS)
                    + _prefixed("WAVE_RINGS_", sp.WAVE_RINGS)
                    + _prefixed("WAVE_PROFILE_", sp.WAVE_PROFILES)),
            _family("Voronoi Texture features and metrics (shader_program.py VORONOI_*)",
                    _prefixed("VORONOI_", sp.VORONOI_FEATURES)
                    + _prefixed("VORONOI_", sp.VORONOI_METRICS)),
            _family("the gather's region and cells (ppm_engine/passes/gather.py)",
                    [("MAX_CELLS_PER_AXIS", gather.MAX_CELLS_PER_AXIS)]),
            _family("the visible points' bounds reduction's work-group "
                    "(ppm_engine/passes/hash_build.py HashBuild.BOUNDS_GROUP)",
                    [("BOUNDS_WG", hash_build.HashBuild.BOUNDS_GROUP)])]
    for f in fam:
        out += f + [""]
    floats = [("photons on a surface facing another way are not a visible point's: the "
               "least cosine between their normals (ppm_engine/passes/gather.py)",
               "NORMAL_COS_MIN", gather.NORMAL_COS_MIN),
              ("the gather region's half thickness off the tangent plane, times r "
               "(passes/gather.py)", "DISC_HALF_THICKNESS", gather.DISC_HALF_THICKNESS),
              ("a microfacet lobe is singular below this alpha_x alpha_y "
               "(ppm_engine/materials.py SINGULAR_ALPHA2)", "ROUGHNESS_SQ_THRESH",
               materials.SINGULAR_ALPHA2),
              ("closures of a smaller sample weight are not made (materials.py "
               "CLOSURE_WEIGHT_CUTOFF, as Cycles')", "CLOSURE_WEIGHT_CUTOFF",
               materials.CLOSURE_WEIGHT_CUTOFF)]
    for what, name, value in floats:
        out += _comment(what) + [f"#define {name} {c_float(value)}"]
    out += [""]

    structs = [("Light", sa.LIGHT_DTYPE, sa, "LIGHT_DTYPE"),
               ("Camera", camera_model.CAMERA_DTYPE, camera_model, "CAMERA_DTYPE"),
               ("Material", materials.KMATERIAL_DTYPE, materials, "KMATERIAL_DTYPE"),
               ("ShaderNode", sa.SHADER_NODE_DTYPE, sa, "SHADER_NODE_DTYPE"),
               ("EmitterInfo", emitters.EMITTER_INFO_DTYPE, emitters, "EMITTER_INFO_DTYPE"),
               ("Texture", sa.TEXTURE_DTYPE, sa, "TEXTURE_DTYPE"),
               ("Grid", photon_map.GRID_DTYPE, photon_map, "GRID_DTYPE")]
    out += ["/* --- structs: each mirrors a NumPy dtype field for field; only 4-byte scalars and "
            "arrays",
            " * of them, so there is no padding (tests/test_shared_header.py checks every field's "
            "offset",
            " * on the device) */"]
    for ctype, dtype, module, name in structs:
        origin = f"ppm_engine/{module.__name__.rsplit('.', 1)[-1]}.py {name}"
        out += _struct(ctype, dtype, origin, _field_comments(module, name)) + [""]
    out += _scene_data({dtype: ctype for ctype, dtype, _, _ in structs}) + ["", "#endif"]
    return "\n".join(out) + "\n"


def _scene_data(struct_types: dict) -> list[str]:
    """The scene's buffers as the X-macro SCENE_DATA(X): X(element type, name) for each."""
    from .device_scene import SCENE_BUFFERS
    vector = {np.dtype((np.float32, 4)): "float4", np.dtype((np.int32, 4)): "int4",
              np.dtype(np.float16): "half"}
    rows = []
    for b in SCENE_BUFFERS:
        ctype = struct_types.get(b.element) or vector.get(b.element) or _C_TYPES[b.element]
        rows.append((f"X({ctype}, {b.name})", b.what))
    width = max(len(x) for x, _ in rows) + 1
    lines = _comment("--- the scene's buffers (ppm_engine/device_scene.py SCENE_BUFFERS), in the "
                     "kernels' parameter order: X(element type, name); kernels/scene.h makes "
                     "the kernels' parameters and the Scene struct of them") + \
        ["#define SCENE_DATA(X) \\"]
    for k, (x, what) in enumerate(rows):
        end = " \\" if k < len(rows) - 1 else ""
        line = f"    {x:<{width}}/* {what} */"
        lines.append(line + end if len(line + end) <= WIDTH else f"    {x}{end}")
    return lines


def path() -> Path:
    from .device import kernel_dir
    return kernel_dir() / HEADER


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m ppm_engine.shared_header",
                                description="write kernels/shared.h from the Python tables")
    p.add_argument("--check", action="store_true",
                   help="exit 1 when kernels/shared.h differs from what the tables give")
    args = p.parse_args(argv)
    text, target = generate(), path()
    if args.check:
        current = target.read_text() if target.is_file() else ""
        if current != text:
            print(f"{target} is stale: run python -m ppm_engine.shared_header", file=sys.stderr)
            return 1
        return 0
    target.write_text(text)
    print(f"wrote {target}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
