"""kernels/shared.h, shared_features.h, shared_svm.h and shared_color.h, generated from the Python
tables (ppm_engine/tools/shared_header.py): the files are current, their float literals are the
tables' float32 values exactly, every struct field sits on the device
where its dtype puts it, no kernel file defines again a name the headers define, and the feature
flags the host sets are the header's."""
import re
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest

from ppm_engine.tools import shared_header

KERNELS = Path(__file__).resolve().parents[1] / "kernels"
KERNEL_FILES = sorted(f for f in KERNELS.rglob("*") if f.suffix in (".h", ".cl"))
GENERATED = (shared_header.HEADER, shared_header.FEATURES_HEADER, shared_header.SVM_HEADER,
             shared_header.COLOR_HEADER)
PKG = Path(__file__).resolve().parents[1] / "ppm_engine"


def test_the_headers_are_current():
    """Fails after a change to a Python table until `python -m ppm_engine.tools.shared_header`
    ran."""
    generated = shared_header.generate_all()
    assert set(generated) == set(GENERATED)
    for name, text in generated.items():
        assert (KERNELS / name).read_text() == text, \
            f"kernels/{name} is stale: run python -m ppm_engine.tools.shared_header"


def test_the_check_fails_on_a_stale_header(tmp_path, monkeypatch):
    for name, text in shared_header.generate_all().items():
        (tmp_path / name).write_text(text)
    stale = tmp_path / shared_header.SVM_HEADER
    stale.write_text(stale.read_text().replace("#define MATH_SINE 29", "#define MATH_SINE 30"))
    monkeypatch.setattr(shared_header, "folder", lambda: tmp_path)
    assert shared_header.main(["--check"]) == 1
    assert shared_header.main([]) == 0 and shared_header.main(["--check"]) == 0
    assert "#define MATH_SINE 29" in stale.read_text()


def test_float_literals_read_back_exactly():
    for x in (0.7, 0.25, 2e-10, 1e-5, 3.0, 1e9, -0.1, 0.0, 1 / 3):
        lit = shared_header.c_float(x)
        assert lit.endswith("f") and np.float32(lit[:-1]) == np.float32(x), lit


def _c_float32(literal: str) -> np.float32:
    """The float32 a C compiler makes of a decimal literal: the nearest to its exact value (ties
    to even), not through a double."""
    q = Fraction(literal.rstrip("f"))
    a = np.float32(float(q))
    near = (a, np.nextafter(a, np.float32(np.inf)), np.nextafter(a, np.float32(-np.inf)))
    return min(near, key=lambda c: (abs(Fraction(float(c)) - q), int(c.view(np.uint32)) & 1))


def test_the_colour_tables_are_spectras_float32_values():
    """kernels/shared_color.h's arrays and matrix, read as the OpenCL compiler reads them, are
    bit for bit ppm_engine/scene/spectra.py's tables (the kernel and the export's folding agree)."""
    from ppm_engine.scene import spectra
    text = re.sub(r"/\*.*?\*/", "", (KERNELS / shared_header.COLOR_HEADER).read_text(), flags=re.S)
    literal = r"-?[\d.]+(?:e-?\d+)?f"
    tables = {"XYZ_TO_REC709": [_c_float32(x) for c in "RGB" for x in re.findall(
        literal, re.search(rf"#define XYZ_TO_REC709_{c} (.*)", text)[1])]}
    for name, body in re.findall(r"__constant float (\w+)\[[^\]]*\] = \{([^}]*)\}", text):
        tables[name] = [_c_float32(x) for x in re.findall(literal, body)]
    names = ("BLACKBODY_FROM", "BLACKBODY_FIT", "BLACKBODY_BELOW", "BLACKBODY_ABOVE", "CIE_1931",
             "XYZ_TO_REC709")
    assert set(tables) == set(names)
    for name in names:
        want = getattr(spectra, name).ravel()
        assert want.dtype == np.float32
        got = np.array(tables[name], np.float32)
        assert np.array_equal(got.view(np.uint32), want.view(np.uint32)), name
    assert f"#define BLACKBODY_INTERVALS {len(spectra.BLACKBODY_FROM)}" in text


def _structs():
    from ppm_engine.render import photon_map
    from ppm_engine.scene import arrays as scene_arrays
    from ppm_engine.scene import camera as camera_model
    from ppm_engine.scene import emitters, materials
    return {"Light": scene_arrays.LIGHT_DTYPE, "Camera": camera_model.CAMERA_DTYPE,
            "Material": materials.KMATERIAL_DTYPE, "ShaderNode": scene_arrays.SHADER_NODE_DTYPE,
            "EmitterInfo": emitters.EMITTER_INFO_DTYPE, "Texture": scene_arrays.TEXTURE_DTYPE,
            "Grid": photon_map.GRID_DTYPE}


def _devices():
    try:
        from ppm_engine.render.device import list_devices
        return [d.key for d in list_devices()]
    except Exception:            # no pyopencl or no platform: the test skips below
        return [None]


@pytest.mark.gpu
@pytest.mark.parametrize("key", _devices())
def test_every_struct_field_has_its_dtype_offset_on_the_device(key):
    """offsetof and sizeof of every field of every shared struct, compiled by each device's own
    compiler, against the NumPy dtype (the kernels read the host's bytes as these structs)."""
    cl = pytest.importorskip("pyopencl")
    if key is None:
        pytest.skip("no OpenCL device")
    from ppm_engine.render.device import get_device, kernel_dir
    dev = get_device(key)
    rows = [(s, f) for s, dt in _structs().items() for f in ("", *dt.names)]
    # (a field's offset as the distance of its address from its struct's: OpenCL C has no
    # offsetof)
    body = "\n".join(f"    out[{i}] = (uint)((char *)&v{s}.{f} - (char *)&v{s});" if f else
                     f"    {s} v{s};\n    out[{i}] = sizeof({s});"
                     for i, (s, f) in enumerate(rows))
    src = f'#include "shared.h"\n__kernel void layout(__global uint *out) {{\n{body}\n}}\n'
    prog = cl.Program(dev.context, src).build(options=[f"-I{kernel_dir()}"])
    out = cl.Buffer(dev.context, cl.mem_flags.WRITE_ONLY, 4 * len(rows))
    prog.layout(dev.queue, (1,), None, out)
    got = np.empty(len(rows), np.uint32)
    cl.enqueue_copy(dev.queue, got, out)
    structs = _structs()
    want = [structs[s].itemsize if not f else structs[s].fields[f][1] for s, f in rows]
    assert dict(zip(rows, got.tolist())) == dict(zip(rows, want))


def _defines(text: str) -> set:
    return set(re.findall(r"^\s*#\s*define\s+(\w+)", text, re.M))


def test_no_kernel_file_defines_a_shared_name_again():
    shared = set().union(*(_defines((KERNELS / name).read_text()) for name in GENERATED))
    for f in KERNEL_FILES:
        if f.name not in GENERATED:
            again = _defines(f.read_text()) & shared
            assert not again, f"{f.name} defines {sorted(again)}, which shared.h defines"


def test_the_features_the_host_sets_are_the_kernels_flags():
    """Every PPM_* flag the host adds to a feature set (features.py, materials.py, world_map.py)
    is in features.FEATURES, and every one of those is tested somewhere in the kernels."""
    from ppm_engine.render.features import FEATURES
    used = set()
    for name in ("render/features.py", "scene/materials.py", "render/world_map.py"):
        text = (PKG / name).read_text()
        used |= set(re.findall(r"add\(\"(PPM_\w+)\"\)", text))
        used |= set(re.findall(r"\"(PPM_\w+)\": True", text))
        used |= {n for tup in re.findall(r"update\(\(([^)]*)\)\)", text)
                 for n in re.findall(r"\"(PPM_\w+)\"", tup)}
    used -= {"PPM_SPECIALIZED"}
    assert used and used <= set(FEATURES), used - set(FEATURES)
    kernels = "\n".join(f.read_text() for f in KERNEL_FILES if f.name not in GENERATED)
    assert not [f for f in FEATURES if not re.search(rf"\b{f}\b", kernels)]


def test_switches_over_shared_codes_name_them():
    """A switch of the kernels picks by a shared.h name (MATH_*, MIX_*, NOISE_*...), never by
    a bare number that would silently mean another operation when a Python table changes."""
    bare = [f"{f.name}: {m[0]}" for f in KERNEL_FILES
            for m in re.finditer(r"\bcase\s+-?\d+\s*:", f.read_text())]
    assert not bare, bare
