"""The package's structure as the README's map draws it: no import cycle, a core that never
imports bpy, the Blender layer on top of it, and the tooling (bench/, packaging.py) that nothing
in the add-on imports."""
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
