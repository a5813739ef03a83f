"""The package's structure as docs/ARCHITECTURE.md draws it: one folder per layer, each layer
importing only the layers below it, no import cycle, bpy only in the Blender layer and the
tooling, and nothing in the add-on importing the tooling.

    errors.py   the errors a user can act on, imported by every layer
    scene/      the scene model (SceneArrays, materials, lights, camera): no device, no bpy
    render/     the renderer on an OpenCL device: imports scene/
    oracle/     NumPy references and analytic scenes for tests and the bench: scene/, render/
    blender/    the Blender layer (the only add-on code that imports bpy): scene/, render/
    tools/      CLI, bench, packaging, generated headers: anything; nothing imports it
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
