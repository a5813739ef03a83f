"""The package's structure as docs/ARCHITECTURE.md draws it: one folder per layer, each layer
importing only the layers below it, no import cycle, bpy only in the Blender layer and the
tooling, and nothing in the add-on importing the tooling.

    errors.py   the errors a user can act on, imported by every layer
    scene/      the scene model (SceneArrays, materials, lights, camera): no device, no bpy
    render/     the renderer on an OpenCL device: imports scene/
    oracle/     NumPy references and analytic scenes for tests and the bench: scene/, render/
    blender/    the Blender layer (the only add-on code that imports bpy): scene/, render/
    tools/      CLI, bench, packaging, generated headers: anything; nothing imports it

And the tests' own: helpers shared through tests/helpers/ or conftest.py's fixtures, never by
one test module importing another or by a change to sys.path.
"""
import ast
from pathlib import Path

PKG = Path(__file__).resolve().parents[1] / "ppm_engine"

# what each layer may import (its own modules, and the layers below it)
ALLOWED = {
    "errors": {"errors"},
    "scene": {"errors", "scene"},
    "render": {"errors", "scene", "render"},
    "oracle": {"errors", "scene", "render", "oracle"},
    "blender": {"errors", "scene", "render", "blender"},
    "tools": {"errors", "scene", "render", "oracle", "blender", "tools"},
    # the entry points: registration hands off to the Blender layer, python -m to the CLI
    "__init__": {"blender"},
    "__main__": {"tools"},
}
LAYERS = {"scene", "render", "oracle", "blender", "tools"}
TOP_MODULES = {"__init__", "__main__", "errors"}
NO_BPY = {"errors", "scene", "render", "oracle"}


def _modules(pkg: Path = PKG) -> dict:
    out = {}
    for f in pkg.rglob("*.py"):
        parts = f.relative_to(pkg).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" and len(parts) > 1 else parts)
        out[name] = f
    return out


def _layer(name: str) -> str:
    return name.split(".")[0]


def _imports(name: str, source: str, modules: dict) -> set:
    """The package modules ``name`` imports (and "bpy"), at module level or inside functions,
    absolute or relative."""
    path = modules.get(name)
    is_package = path is not None and Path(path).name == "__init__.py" and name != "__init__"
    pkg = name if is_package else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg.split(".") if pkg else []
                base = base[:len(base) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            elif (node.module or "").startswith("ppm_engine"):
                target = node.module[len("ppm_engine."):] if "." in node.module else ""
            else:
                continue
            for a in node.names:      # a submodule, else a name from the module itself
                sub = f"{target}.{a.name}".strip(".")
                cand = sub if sub in modules else target
                if cand in modules and cand != name:
                    found.add(cand)
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name == "bpy" or a.name.startswith("bpy."):
                    found.add("bpy")
                elif a.name.startswith("ppm_engine."):
                    found.add(a.name[len("ppm_engine."):])
    return found


def layer_violations(modules: dict, sources: dict) -> list[str]:
    """Every import that breaks the layers: ``modules`` maps a dotted name (relative to the
    package) to anything, ``sources`` the same names to their source text."""
    bad = []
    for name, src in sources.items():
        layer = _layer(name)
        if layer not in ALLOWED:
            bad.append(f"{name}: not in a layer's folder ({sorted(LAYERS)}) nor a top module")
            continue
        for dep in sorted(_imports(name, src, modules)):
            if dep == "bpy":
                if layer in NO_BPY:
                    bad.append(f"{name} imports bpy")
            elif _layer(dep) not in ALLOWED[layer]:
                bad.append(f"{name} ({layer}) imports {dep} ({_layer(dep)})")
    return bad


def test_every_module_sits_in_a_layer_folder():
    """The top of the package holds only the entry points and the errors; every other module
    is in a layer's folder (a new module at the top fails here)."""
    top = {n for n, f in _modules().items() if f.parent == PKG}
    assert top <= TOP_MODULES | LAYERS, top - TOP_MODULES - LAYERS
    folders = {d.name for d in PKG.iterdir() if d.is_dir() and d.name != "__pycache__"}
    assert folders == LAYERS | {"data"}, folders
    for layer in LAYERS:
        assert (PKG / layer / "__init__.py").read_text().startswith('"""'), layer


def test_each_layer_imports_only_the_layers_below_it():
    """Every module, by its folder: the core (scene/, render/, oracle/, errors) never imports
    bpy, and no layer imports one above it (nothing but tools/ imports tools/)."""
    modules = _modules()
    sources = {n: f.read_text() for n, f in modules.items()}
    assert layer_violations(modules, sources) == []


def test_no_import_cycle():
    modules = _modules()
    graph = {m: {d for d in _imports(m, f.read_text(), modules) if d != "bpy"}
             for m, f in modules.items()}
    # a package's __init__ re-exporting its own submodules is not a cycle
    graph = {m: {d for d in deps if not d.startswith(m + ".")} for m, deps in graph.items()}
    state = {}

    def visit(m, path):
        state[m] = "open"
        for d in graph[m]:
            assert state.get(d) != "open", " -> ".join(path + [m, d])
            if d not in state:
                visit(d, path + [m])
        state[m] = "done"
    for m in graph:
        if m not in state:
            visit(m, [])


def test_the_layout_test_sees_imports_and_can_fail():
    """The checks above can fail: they see relative, absolute and function-level imports, and
    flag an import that runs up the layers and bpy in the core."""
    modules = _modules()
    sources = {n: f.read_text() for n, f in modules.items()}
    assert "render.passes" in _imports("render.renderer", sources["render.renderer"], modules)
    assert {"blender.session", "blender.harness"} <= _imports(
        "tools.bench.curves", sources["tools.bench.curves"], modules)
    assert "bpy" in _imports("blender.engine", sources["blender.engine"], modules)
    # inside a function
    assert "render.renderer" in _imports("blender.session", sources["blender.session"], modules)
    broken = {
        "scene.arrays": "from ppm_engine.render import renderer\n",         # up a layer
        "render.film": "def f():\n    import bpy\n",                        # bpy in the core
        "render.bvh": "from ..passes import gather\nfrom ...tools import cli\n",  # relative
        "oracle.reference": "from ppm_engine.blender.session import Session\n",
        "stray": "x = 1\n",                                                 # not in a layer
    }
    found = layer_violations(modules, broken)
    assert len(found) == 5, found
    assert any("render.bvh (render) imports tools.cli" in f for f in found), found


# --- the tests' layout --------------------------------------------------------------------------
TESTS = Path(__file__).resolve().parent
_SYS_PATH_CHANGES = {"insert", "append", "extend", "remove", "pop", "clear", "reverse", "sort"}


def _test_layout_breaches(source: str) -> list:
    """What in a file under tests/ breaks the tests' layout: a change to sys.path (a method that
    changes it, an assignment, ``from sys import path``) or an import of a test module or of
    conftest.py (``import test_x``, ``from test_x import``, ``from tests.test_x import``,
    ``from . import test_x``, importlib.import_module("test_x")), at module level or in a
    function.  Helpers more than one module uses live in tests/helpers/, fixtures in
    conftest.py."""
    def sys_path(node):
        return (isinstance(node, ast.Attribute) and node.attr == "path"
                and isinstance(node.value, ast.Name) and node.value.id == "sys")

    def a_test_module(dotted):
        return any(p.startswith("test_") or p == "conftest" for p in dotted.split("."))

    found = []
    for node in ast.walk(ast.parse(source)):
        line = getattr(node, "lineno", 0)
        if isinstance(node, ast.Call):
            f = node.func
            if (isinstance(f, ast.Attribute) and sys_path(f.value)
                    and f.attr in _SYS_PATH_CHANGES):
                found.append(f"{line}: sys.path.{f.attr}()")
            elif ((getattr(f, "attr", None) or getattr(f, "id", None)) in ("import_module",
                                                                         "__import__")
                  and node.args and isinstance(node.args[0], ast.Constant)
                  and a_test_module(str(node.args[0].value))):
                found.append(f"{line}: imports {node.args[0].value}")
        elif isinstance(node, (ast.Assign, ast.AugAssign, ast.AnnAssign, ast.Delete)):
            targets = getattr(node, "targets", None) or [node.target]
            if any(sys_path(t) or (isinstance(t, ast.Subscript) and sys_path(t.value))
                   for t in targets):
                found.append(f"{line}: sys.path changed")
        elif isinstance(node, ast.Import):
            found += [f"{line}: import {a.name}" for a in node.names if a_test_module(a.name)]
        elif isinstance(node, ast.ImportFrom):
            module = node.module or ""
            if module == "sys" and any(a.name == "path" for a in node.names):
                found.append(f"{line}: from sys import path")
            names = [a.name for a in node.names] if module in ("", "tests") else []
            if a_test_module(module) or any(a_test_module(n) for n in names):
                found.append(f"{line}: from {'.' * node.level}{module} import "
                             f"{', '.join(a.name for a in node.names)}")
    return sorted(found, key=lambda b: int(b.partition(":")[0]))   # ast.walk: by depth


def test_tests_share_helpers_through_the_helpers_package_not_sys_path():
    """No file under tests/ changes sys.path or imports a test module: what more than one test
    module uses is in tests/helpers/ (``from tests.helpers.X import name``: pytest.ini's
    ``pythonpath = ..`` puts the repository root on sys.path) or a fixture of conftest.py."""
    files = sorted(TESTS.rglob("*.py"))
    assert TESTS / "helpers" / "__init__.py" in files and TESTS / "conftest.py" in files
    breaches = {str(f.relative_to(TESTS)): b for f in files
                if (b := _test_layout_breaches(f.read_text()))}
    assert not breaches, breaches


def test_the_tests_layout_check_sees_breaches():
    """The check above can fail: it sees sys.path changed by a method, an assignment or an
    augmented one, and test modules (conftest.py too) imported in every form, in functions too;
    reading sys.path and importing tests.helpers are allowed."""
    source = """
import sys
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.append("..")
sys.path += [".."]
sys.path[:0] = [".."]
from test_analytic import light
import test_export
from tests.test_materials import W
from tests import test_skips
from . import test_bump


def helper():
    import importlib
    from conftest import TINY
    return importlib.import_module("test_sky"), TINY
"""
    assert _test_layout_breaches(source) == [
        "4: sys.path.insert()", "5: sys.path.append()", "6: sys.path changed",
        "7: sys.path changed", "8: from test_analytic import light", "9: import test_export",
        "10: from tests.test_materials import W", "11: from tests import test_skips",
        "12: from . import test_bump", "17: from conftest import TINY", "18: imports test_sky"]
    allowed = """
import sys
from tests.helpers.renders import render
from ppm_engine.oracle.procedural import MeshBuilder
print(sys.path, render, MeshBuilder)
"""
    assert _test_layout_breaches(allowed) == []


# --- no long source file --------------------------------------------------------------------------
ROOT = PKG.parent
MAX_LINES = 450
LINE_RULE_FOLDERS = ("ppm_engine", "kernels", "tests", "docs")


def _long_files(root: Path, limit: int = MAX_LINES) -> dict:
    """{path from root: lines} of the .py, .h and .cl files under the rule's folders that are
    longer than ``limit`` lines."""
    out = {}
    for folder in LINE_RULE_FOLDERS:
        for f in sorted((root / folder).rglob("*")):
            if f.suffix in (".py", ".h", ".cl") and f.is_file():
                lines = len(f.read_text().splitlines())
                if lines > limit:
                    out[f.relative_to(root).as_posix()] = lines
    return out


def test_no_source_file_is_over_450_lines():
    """Every Python module, kernel source and test, generated headers included (their
    generator, shared_header.py, writes several), at most MAX_LINES lines: a longer one is
    split by what its parts do."""
    assert not _long_files(ROOT), _long_files(ROOT)


def test_the_line_rule_sees_long_files(tmp_path):
    """The rule above can fail: it counts lines in every folder it names, at any depth, and only
    in source files."""
    for name, lines in (("kernels/long.cl", MAX_LINES + 1), ("kernels/short.h", MAX_LINES),
                        ("tests/data/deep.py", 500), ("docs/notes.md", 500),
                        ("elsewhere/long.py", 500)):
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text("x\n" * lines)
    assert _long_files(tmp_path) == {"kernels/long.cl": MAX_LINES + 1, "tests/data/deep.py": 500}
