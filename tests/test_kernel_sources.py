"""The kernel sources' shape: every header compiles on its own (it includes what it uses, with
every feature and with none), and no helper function takes more than 12 parameters once the
preprocessor has expanded its macros (the scene reaches helpers as one `const Scene *`)."""
import re
from pathlib import Path

import numpy as np
import pytest

KERNELS = Path(__file__).resolve().parents[1] / "kernels"
KERNEL_FILES = sorted(f for f in KERNELS.rglob("*") if f.suffix in (".h", ".cl"))
MAX_PARAMS = 12


def _strip(text: str) -> str:
    """The source without comments (strings do not occur in kernel code)."""
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    return re.sub(r"//[^\n]*", " ", text)


def _macros(text: str) -> dict:
    """Object-like macros: name -> body (continued lines joined)."""
    text = _strip(text).replace("\\\n", " ")
    return {m[1]: m[2].strip() for m in re.finditer(r"^\s*#\s*define\s+(\w+)(?!\()\s*(.*)$",
                                                     text, re.M)}


def _split(params: str) -> list[str]:
    out, depth, cur = [], 0, ""
    for ch in params:
        depth += ch == "("
        depth -= ch == ")"
        if ch == "," and depth == 0:
            out.append(cur)
            cur = ""
        else:
            cur += ch
    out.append(cur)
    return [p.strip() for p in out if p.strip() and p.strip() != "void"]


def helper_params(text: str, macros: dict) -> dict:
    """{helper function: its parameters after macro expansion} for the inline functions of a
    source; a parameter that is a function-like macro's call stays one entry ending in '('."""
    code = _strip(text)
    code = re.sub(r"^\s*#.*?(?<!\\)$", " ", code, flags=re.M | re.S)   # directives
    found = {}
    for m in re.finditer(r"\binline\b[^;{}()]*?\b(\w+)\s*\(([^{};]*?)\)\s*\{", code):
        params = _split(m[2])
        expanded, seen = [], 0
        while params:
            p = params.pop(0)
            if p in macros and seen < 64:          # a macro that stands for parameters
                params = _split(macros[p]) + params
                seen += 1
            else:
                expanded.append(p)
        found[m[1]] = expanded
    return found


def test_the_parameter_count_sees_through_macros():
    src = ("#define ARGS int a, \\\n    int b\n#define MORE ARGS, int c\n"
           "inline void f(MORE, int d) {}\n")
    assert helper_params(src, _macros(src)) == {"f": ["int a", "int b", "int c", "int d"]}


def test_no_helper_takes_more_than_twelve_parameters():
    sources = {f.name: f.read_text() for f in KERNEL_FILES}
    macros = {}
    for text in sources.values():
        macros.update(_macros(text))
    too_many = {}
    for name, text in sources.items():
        for fn, params in helper_params(text, macros).items():
            if len(params) > MAX_PARAMS:
                too_many[f"{name} {fn}"] = len(params)
    assert not too_many, too_many


# as a program includes them: their path from kernels/ (the one -I folder)
HEADERS = sorted(f.relative_to(KERNELS).as_posix() for f in KERNELS.rglob("*.h"))


@pytest.fixture(scope="module")
def device(pocl_key):
    from ppm_engine.render.device import get_device
    return get_device(pocl_key)


def _has_branches_off(text: str) -> bool:
    """Whether a header has code that only a build without features compiles: an #else or
    #elif, or a negated #if / #ifndef that is not its include guard (features are tested as
    ``#if PPM_X``, so a build with every feature compiles everything else)."""
    lines = [ln.strip() for ln in text.splitlines() if ln.strip().startswith("#")]
    guards = {ln.split()[1] for ln in lines if ln.startswith("#define") and ln.endswith("_H")
              and len(ln.split()) == 2}
    for ln in lines:
        words = ln.replace("#", "# ", 1).split()
        directive = words[1] if len(words) > 1 else ""
        if directive in ("else", "elif") or ln.startswith("#if !") or (
                directive == "ifndef" and len(words) > 2 and words[2] not in guards):
            return True
    return False


def test_branch_detection_sees_what_only_a_build_without_features_compiles():
    assert not _has_branches_off("#ifndef A_H\n#define A_H\n#if PPM_X\nx\n#endif\n#endif\n")
    assert _has_branches_off("#ifndef A_H\n#define A_H\n#if PPM_X\nx\n#else\ny\n#endif\n")
    assert _has_branches_off("#if !PPM_TRANSPARENT\ny\n#endif\n")
    assert _has_branches_off("#ifndef PPM_SVM_OPS\n#define PPM_SVM_OPS 0\n#endif\n")
    assert _has_branches_off((KERNELS / "shared_features.h").read_text())


@pytest.mark.parametrize("header", HEADERS)
def test_every_header_compiles_alone(device, header):
    """The header first and alone in a program, built with every feature (every ``#if PPM_X``
    branch) and, where it has code only a build without features compiles (an ``#else``, a
    negated test), with none (a specialised build): it includes what it uses, wherever it is
    included from."""
    cl = pytest.importorskip("pyopencl")
    from ppm_engine.render.device import kernel_dir
    src = f'#include "{header}"\n__kernel void probe(__global int *out) {{ out[0] = 0; }}\n'
    builds = [[], ["-DPPM_SPECIALIZED"]]
    if not _has_branches_off((KERNELS / header).read_text()):
        builds = builds[:1]
    for defines in builds:
        try:
            # (nothing runs: no optimisation, a third of the build's time)
            cl.Program(device.context, src).build(options=[f"-I{kernel_dir()}",
                                                           "-cl-opt-disable", *defines])
        except cl.RuntimeError as e:
            pytest.fail(f"{header} alone ({' '.join(defines) or 'every feature'}):\n{e}")


def _clang_format():
    import shutil
    import sys
    return (shutil.which("clang-format", path=str(Path(sys.executable).parent))
            or shutil.which("clang-format"))


def test_kernels_are_formatted():
    """Every kernel file as kernels/.clang-format formats it (clang-format from the test extra;
    format one with `clang-format -i --style=file kernels/NAME`)."""
    import subprocess
    exe = _clang_format()
    if exe is None:
        pytest.skip("clang-format is not installed (pip install -e \".[test]\")")
    files = [str(f) for f in KERNEL_FILES]
    proc = subprocess.run([exe, "--dry-run", "-Werror", "--style=file", *files],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]


def test_every_program_includes_the_inline_builtins_first():
    """kernels/builtins.h names PoCL's out-of-line builtins by macros for inline overloads: a
    program that includes anything before it would call the library's in the code before."""
    for f in sorted(KERNELS.rglob("*.cl")):
        first = re.search(r'^#include\s+"([^"]+)"', f.read_text(), re.M)
        assert first and first.group(1) == "builtins.h", f.name


def test_kernels_take_their_index_from_work_item():
    """Every kernel's index is WORK_ITEM() (kernels/builtins.h), which a launch split into rows
    (program.grid) keeps right; get_global_id(0) alone would read the first row's ids only."""
    used = [str(f.relative_to(KERNELS)) for f in KERNEL_FILES if "get_global_id" in f.read_text()]
    assert used == ["builtins.h"], used


def test_large_launches_run_as_rows_under_pocl_s_small_grid_limit(device):
    """program.grid: under SMALL_GRID items one row, else rows of whole groups each under it (a
    small grid in every dimension: one binary per kernel); a launch of 200,001 items through
    Launch reaches every index once (a kernel writing f(its index))."""
    from ppm_engine.render.device.program import SMALL_GRID, grid
    assert grid(1) == ((64,), (64,)) and grid(SMALL_GRID - 64) == ((SMALL_GRID - 64,), (64,))
    (w, h), local = grid(SMALL_GRID)
    assert local == (64, 1) and w % 64 == 0 and w < SMALL_GRID and h == 2
    (w, h), _ = grid(10 ** 7, 16)
    assert w % 16 == 0 and w < SMALL_GRID and w * h >= 10 ** 7 > w * (h - 1)
    import pyopencl as cl
    n = 200_001
    u = np.random.default_rng(2).random(n).astype(np.float32)
    us = cl.Buffer(device.context, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR,
                   hostbuf=u)
    out = cl.Buffer(device.context, cl.mem_flags.READ_WRITE, 8 * (n + 64))
    cl.enqueue_fill_buffer(device.queue, out, np.float32(7.0), 0, 8 * (n + 64))
    run = device.programs.get("test/debug.cl").launch("sincos_turns_at", "test")
    run(device.queue, n, us=us, n=np.uint32(n), out=out).wait()
    got = np.empty((n + 64, 2), np.float32)
    cl.enqueue_copy(device.queue, got, out).wait()
    a = 2 * np.pi * u.astype(np.float64)
    assert np.abs(got[:n, 0] - np.sin(a)).max() < 2e-7
    assert np.abs(got[:n, 1] - np.cos(a)).max() < 2e-7
    assert (got[n:] == 7.0).all()
