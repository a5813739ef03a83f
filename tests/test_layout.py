"""The package's structure as the README's map draws it: no import cycle, a core that never
imports bpy, the Blender layer on top of it, and the tooling (bench/, packaging.py) that nothing
in the add-on imports.  And the tests' own: helpers shared through tests/helpers/ or
conftest.py's fixtures, never by one test module importing another or by a change to sys.path."""
import ast
from pathlib import Path

PKG = Path(__file__).resolve().parents[1] / "ppm_engine"

# the core: runs in plain Python, without Blender (tests, the CLI's devices command, .npz scenes)
CORE = {"counters", "device", "device.context", "device.program", "device_scene", "errors",
        "features", "film", "materials", "emitters", "bvh", "options", "passes", "passes.eye",
        "passes.gather", "passes.hash_build", "passes.photons", "passes.update", "photon_map",
        "procedural", "analytic", "reference", "renderer", "scene_arrays", "scene_prep",
        "shared_header", "stats", "world_map"}
TOOLING = ("bench", "packaging")


def _modules() -> dict:
    out = {}
    for f in PKG.rglob("*.py"):
        parts = f.relative_to(PKG).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = f
    return out


def _imports(name: str, path: Path, modules: dict) -> set:
    """The package modules ``name`` imports, at module level or inside functions."""
    pkg = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
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
            found |= {a.name for a in node.names if a.name == "bpy"}
    return found


def test_core_modules_exist_and_never_import_bpy():
    modules = _modules()
    assert set(modules) >= CORE, CORE - set(modules)
    for name in CORE:
        assert "bpy" not in _imports(name, modules[name], modules), name


def test_no_import_cycle_and_nothing_imports_the_tooling():
    modules = _modules()
    graph = {m: {d for d in _imports(m, f, modules) if d != "bpy"} for m, f in modules.items()}
    for m, deps in graph.items():
        if not m.startswith(TOOLING):
            assert not {d for d in deps if d.startswith(TOOLING)}, m
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


def test_the_layout_test_sees_imports():
    """The checks above can fail: they see relative, absolute and function-level imports."""
    modules = _modules()
    assert "passes" in _imports("renderer", modules["renderer"], modules)
    assert {"session", "blender_io"} <= _imports("bench.curves", modules["bench.curves"],
                                                 modules)
    assert "bpy" in _imports("engine", modules["engine"], modules)
    assert "renderer" in _imports("session", modules["session"], modules)   # inside a function


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
from ppm_engine.procedural import MeshBuilder
print(sys.path, render, MeshBuilder)
"""
    assert _test_layout_breaches(allowed) == []
