"""The checker behind tests/test_prose.py.  Prose tells the truth: every file, kernel function and
Python name that the README, docs/ and the comments and docstrings of the code name exists, as the
files on disk stand when the test runs (no list of names here: a file moved or a function renamed
fails this test until the prose that names it follows).  No bpy, no OpenCL, nothing imported:
Markdown is read line by line, Python with ``tokenize`` (comments, docstrings) and ``ast`` (what a
module or class defines), OpenCL C with regular expressions (comments, and what a file defines and
includes).

The prose: README.md (and the README of tests/, when there is one), docs/**/*.md but a history
folder (a dated record of what was true then), and the comments and docstrings of
ppm_engine/**/*.py, tests/*.py, docs/**/*.py, the add-on's top-level *.py and kernels/**/*.h,
*.cl.

What counts as a name (``check_line``):

* a file: a token ending in .py, .h, .cl or .md.  A bare name (``options.py``) passes when a
  file of that name exists anywhere in the repository; a path with a folder (``kernels/rng.h``,
  ``tests/conftest.py``) must exist relative to the repository's root, kernels/, ppm_engine/,
  or the folder of the file that names it or a folder above that.  A folder of ours
  (``ppm_engine/data/``) must exist the same way.
* a kernel function: a kernel file then an identifier (``kernels/rng.h ld_set``, in backticks
  or not).  The identifier counts when it is snake_case or upper case or defined in some kernel
  file (so ``rng.h and ...`` is prose, not a name); it must be defined (function, macro,
  struct, typedef, enum constant) in that file or one it includes.
* a Python name: a dotted name that starts with ``ppm_engine``, or with a class defined in
  ppm_engine (``Renderer.iterate``), or, in backticks, with a module's last name
  (``options.LIMITS``; unticked, ``film`` and ``stats`` are words and variables).  What follows
  must be a submodule or defined in that module (def, class, assignment, import) or class
  (its body, ``self.x =`` in a method, a base class; a base from outside ppm_engine may
  define anything); a module's last name may also be a variable holding an instance of one of
  its classes (``stats.phase_ms``).

What is exempt (``exempt`` in ``check_line``), to name other projects' sources:

* a path whose first folder is no folder's name here: Cycles' kernel/svm/svm.h, util/hash.h;
* a bare file name or a short module reference that does not resolve, in a sentence that
  names Cycles, Blender, pbrt, LuxCore or Mitsuba (its bsdf.h, LuxCore's stats.x).
  Never a path starting with a folder of ours (kernels/, ppm_engine/, docs/, tests/).
"""
import ast
import os
import re
from pathlib import Path

from tests.helpers.prose_text import strip_c

ROOT = Path(__file__).resolve().parents[2]

# folders that are not the project's sources: environments, caches, build outputs
SKIP_DIRS = {".git", ".venv", "venv", "build", "dist", "out", "__pycache__", ".pytest_cache",
             "node_modules"}
# our top-level folders: a path starting with one of these is always checked
OURS = ("kernels/", "ppm_engine/", "docs/", "tests/")
# a dotted name ending in one of these is a file name, not Python (bulb_box.png)
FILE_EXTENSIONS = {"py", "h", "cl", "md", "png", "jpg", "exr", "json", "npz", "npy", "txt",
                   "toml", "zip", "blend", "csv", "html", "whl", "ini", "cfg", "log", "cpp"}
# a sentence naming one of these may name that project's files (Cycles' bsdf.h): its bare
# file names and short module references that do not resolve here are exempt
OUTSIDE_PROJECTS = re.compile(r"\b(Cycles|Blender|pbrt|LuxCore|Mitsuba)\b", re.I)

EXT = r"(?:py|h|cl|md)"
# a file path or bare name: path segments of word characters, dots and dashes, then .ext;
# not part of a longer token (a URL, a dotted module name, a longer path)
PATH_RE = re.compile(r"(?<![\w./\\:-])((?:[\w.-]+/)*[\w-]+\." + EXT + r")(?![\w/-]|\.\w)")
# a folder of ours: ppm_engine/data/, docs/
DIR_RE = re.compile(r"(?<![\w./-])((?:" + "|".join(map(re.escape, OURS)) + r")(?:[\w-]+/)*)"
                    r"(?![\w.*-])")
# a kernel file followed by an identifier, backticks around either or both
KFUNC_RE = re.compile(r"(?<![\w./-])((?:[\w-]+/)*[\w-]+\.(?:h|cl))`?\s+`?([A-Za-z_]\w*)"
                      r"(?![\w.*/-]|\.\w)")
DOTTED_RE = re.compile(r"(?<![\w.])([A-Za-z_]\w*(?:\.[A-Za-z_]\w*)+)(?![\w])")
BACKTICKED_RE = re.compile(r"`+([^`\n]+)`+")


# --- the repository as it stands -------------------------------------------------------------

class Repo:
    """The files on disk under ``root``; the kernels' definitions and includes; ppm_engine's
    modules and classes, read with ``ast``."""

    def __init__(self, root: Path):
        self.root = root
        self.files = set()                         # "kernels/rng.h", ...
        self.dirs = {""}
        for dirpath, dirnames, filenames in os.walk(root):
            dirnames[:] = [d for d in dirnames
                           if d not in SKIP_DIRS and not d.endswith(".egg-info")]
            rel = Path(dirpath).relative_to(root).as_posix()
            rel = "" if rel == "." else rel
            self.dirs.add(rel)
            self.files.update(f"{rel}/{f}".lstrip("/") for f in filenames)
        self.basenames = {f.rpartition("/")[2] for f in self.files}
        self.dir_names = {d.rpartition("/")[2] for d in self.dirs}
        self._defs = {}
        self.modules = {}                          # "device.program" -> its .py file
        for f in self.files:
            if f.startswith("ppm_engine/") and f.endswith(".py"):
                parts = f[len("ppm_engine/"):-3].split("/")
                if parts[-1] == "__init__":
                    parts = parts[:-1]
                self.modules[".".join(parts)] = f
        self.short = {}                            # "program" -> {"device.program"}
        for m in self.modules:
            if m:
                self.short.setdefault(m.rpartition(".")[2], set()).add(m)
        self._py, self._names = {}, {}
        self.classes = {}                          # "Renderer" -> [(module, ClassDef)]
        for m, f in self.modules.items():
            for node in self.py(f).body:
                if isinstance(node, ast.ClassDef):
                    self.classes.setdefault(node.name, []).append((m, node))
        kernel_defs = set()
        for f in self.files:
            if f.startswith("kernels/") and f.endswith((".h", ".cl")):
                kernel_defs |= self.kernel_defs(f)[0]
        self.kernel_symbols = kernel_defs

    # paths

    def resolve(self, name: str, mentioned_in: str) -> bool:
        """Whether the path ``name`` (a file, or a folder ending in "/") named in the file
        ``mentioned_in`` exists."""
        name = name.removeprefix("./")
        if "/" not in name.rstrip("/"):
            return name.rstrip("/") in self.basenames or name.rstrip("/") in self.dirs
        if any(p in self.files or p.rstrip("/") in self.dirs
               for p in _candidates(name, mentioned_in)):
            return True
        # a path's tail inside a layer (``passes/eye.py``, ``export/``): some file or folder
        # ends with it; a path that starts at one of our top folders must be whole
        if name.startswith(OURS):
            return False
        tail = "/" + name.rstrip("/")
        return any(f.endswith(tail) for f in self.files) or any(
            d.endswith(tail) for d in self.dirs)

    def find(self, name: str, mentioned_in: str):
        """The repository path of the kernel file ``name``, or None (a bare name: the one file
        of that name under kernels/)."""
        if "/" not in name:
            hits = [f for f in self.files if f.startswith("kernels/")
                    and f.rpartition("/")[2] == name]
            return hits[0] if len(hits) == 1 else None
        return next((p for p in _candidates(name, mentioned_in) if p in self.files), None)

    # kernels

    def kernel_defs(self, path: str):
        """(names defined at file scope, files included) of a kernel source."""
        if path in self._defs:
            return self._defs[path]
        text = (self.root / path).read_text(errors="replace")
        names = set()
        includes = re.findall(r'^\s*#\s*include\s+"([^"]+)"', strip_c(text, strings=False),
                              re.M)
        body_lines = []
        opens = {}         # macros that open a block (VOR_LOOP(...) { ... } closed by the caller)
        skip = []          # per open #if: whether we are past its first branch (#else, #elif)
        for line in strip_c(text).replace("\\\n", " ").split("\n"):
            s = line.strip()
            if s.startswith("#"):
                d = re.match(r"#\s*(\w+)\s*(\w*)", s) or re.match("()()", "")
                if d.group(1) in ("if", "ifdef", "ifndef"):
                    skip.append(False)
                elif d.group(1) in ("else", "elif") and skip:
                    skip[-1] = True
                elif d.group(1) == "endif" and skip:
                    skip.pop()
                elif d.group(1) == "define" and d.group(2):
                    names.add(d.group(2))
                    opens[d.group(2)] = s.count("{") - s.count("}")
                body_lines.append("")
            else:                     # the first branch of each #if: braces balance there
                body_lines.append("" if any(skip) else line)
        body = "\n".join(body_lines)
        # walk the tokens: identifiers followed by "(" at brace and paren depth 0 are functions
        # (and top-level macro uses); struct/enum/union tags; a name after "}" at depth 0
        # (typedef struct {...} Name;) or before ";" in a typedef; enum constants
        toks = re.findall(r"[A-Za-z_]\w*|[{}();,=]", body)
        depth = paren = 0
        enum_depth = None
        prev = ""
        typedef = False
        for i, t in enumerate(toks):
            nxt = toks[i + 1] if i + 1 < len(toks) else ""
            if t == "{":
                if prev in ("enum",) or (i >= 2 and toks[i - 2] == "enum"):
                    enum_depth = depth + 1
                depth += 1
            elif t == "}":
                depth -= 1
                if enum_depth is not None and depth < enum_depth:
                    enum_depth = None
            elif t == "(":
                paren += 1
            elif t == ")":
                paren -= 1
            elif t == ";":
                if depth == 0:
                    if typedef and re.match(r"[A-Za-z_]", prev):
                        names.add(prev)
                    typedef = False
            elif re.match(r"[A-Za-z_]", t):
                depth += opens.get(t, 0)
                if t == "typedef" and depth == 0:
                    typedef = True
                if depth == 0 and paren == 0 and nxt == "(":
                    names.add(t)
                if prev in ("struct", "enum", "union"):
                    names.add(t)
                if depth == 0 and prev == "}" and nxt in (";", ","):
                    names.add(t)
                if enum_depth == depth and prev in ("{", ",") and depth:
                    names.add(t)
            prev = t
        self._defs[path] = (names, includes)
        return self._defs[path]

    def kernel_defines(self, path: str, name: str) -> bool:
        """Whether ``name`` is defined in the kernel file ``path`` or a file it includes."""
        seen, todo = set(), [path]
        while todo:
            p = todo.pop()
            if p in seen or p not in self.files:
                continue
            seen.add(p)
            names, includes = self.kernel_defs(p)
            if name in names:
                return True
            for inc in includes:       # relative to the including file, else to kernels/
                here = f"{p.rpartition('/')[0]}/{inc}"
                todo.append(here if here in self.files else f"kernels/{inc}")
        return False

    # Python

    def py(self, path: str) -> ast.Module:
        if path not in self._py:
            self._py[path] = ast.parse((self.root / path).read_text())
        return self._py[path]

    def module_has(self, module: str, attr: str) -> bool:
        if f"{module}.{attr}".strip(".") in self.modules:
            return True
        if module not in self._names:
            self._names[module] = _scope_names(self.py(self.modules[module]).body)
        return attr in self._names[module]

    def class_has(self, cls: str, attr: str, _seen=None, outside_bases=True) -> bool:
        """Whether the class ``cls`` (of ppm_engine) or a base defines ``attr``; with
        ``outside_bases``, a base from outside ppm_engine may define anything."""
        _seen = _seen or set()
        if cls in _seen:
            return False
        _seen.add(cls)
        for _, node in self.classes.get(cls, ()):
            if id(node) not in self._names:
                self._names[id(node)] = _class_names(node)
            if attr in self._names[id(node)]:
                return True
            for b in node.bases:
                base = b.id if isinstance(b, ast.Name) else (
                    b.attr if isinstance(b, ast.Attribute) else None)
                if base is None or base in ("object", "Exception"):
                    continue
                if base not in self.classes:
                    if outside_bases:     # inherits from outside ppm_engine: anything may be
                        return True
                elif self.class_has(base, attr, _seen, outside_bases):
                    return True
        return False

    def python_ref(self, dotted: str, backticked: bool):
        """None when ``dotted`` is not a reference to ppm_engine; else whether it resolves."""
        parts = dotted.split(".")
        if parts[0] == "ppm_engine":
            parts = parts[1:]
            if not parts:
                return None
            module = ""
        elif parts[0] in self.classes:
            return self.class_has(parts[0], parts[1])
        elif parts[0] in BLENDER_DATA:
            return None
        elif backticked and parts[0] in self.short:
            # a module's last name alone is also how a variable holding one of its classes'
            # instances is named (``stats.phase_ms``): a class of that module may define it
            return any(self._walk(m, parts[1:]) or any(
                self.class_has(c, parts[1], outside_bases=False) for c, defs in self.classes.items()
                for mod, _ in defs if mod == m) for m in sorted(self.short[parts[0]]))
        else:
            return None
        return self._walk(module, parts)

    def is_short_ref(self, dotted: str) -> bool:
        """Whether ``dotted`` starts with a module's last name alone (film.x, stats.x)."""
        first = dotted.partition(".")[0]
        return first in self.short and first not in self.classes and first != "ppm_engine"

    def _walk(self, module: str, rest: list) -> bool:
        """Whether the names ``rest`` resolve from the module ``module``: submodules, then one
        attribute of the module, then (if a class of ppm_engine) one of the class."""
        while rest and f"{module}.{rest[0]}".strip(".") in self.modules:
            module = f"{module}.{rest[0]}".strip(".")
            rest = rest[1:]
        if not rest:
            return True
        if not self.module_has(module, rest[0]):
            return False
        if len(rest) > 1 and rest[0] in self.classes:
            return self.class_has(rest[0], rest[1])
        return True


# Blender's data that shares a name with a module of ours: ``scene.ppm`` is bpy's Scene
BLENDER_DATA = {"scene"}


def _candidates(name: str, mentioned_in: str) -> list:
    """Where a path with a folder named in ``mentioned_in`` may be: under the root, kernels/,
    ppm_engine/, the mentioning file's folder or a folder above it."""
    bases = ["", "kernels", "ppm_engine"]
    folder = mentioned_in.rpartition("/")[0]
    while folder:
        bases.append(folder)
        folder = folder.rpartition("/")[0]
    return [f"{b}/{name}".lstrip("/") for b in bases]


def _scope_names(body: list) -> set:
    """The names a module or class body binds: def, class, assignment, import (also inside
    if/try/with/for blocks, not inside functions)."""
    names = set()
    todo = list(body)
    while todo:
        node = todo.pop()
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            names |= {e.id for t in targets for e in ast.walk(t) if isinstance(e, ast.Name)}
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names |= {(a.asname or a.name).split(".")[0] for a in node.names}
        elif isinstance(node, (ast.If, ast.Try, ast.With, ast.For, ast.While)):
            for field in ("body", "orelse", "finalbody", "handlers"):
                todo += getattr(node, field, [])
        elif isinstance(node, ast.ExceptHandler):
            todo += node.body
    return names


def _class_names(node: ast.ClassDef) -> set:
    """What a class defines: its body's names and the ``self.x`` its methods assign."""
    names = _scope_names(node.body)
    for n in ast.walk(node):
        if isinstance(n, ast.Attribute) and isinstance(n.ctx, ast.Store) \
                and isinstance(n.value, ast.Name) and n.value.id == "self":
            names.add(n.attr)
    return names


# --- prose -----------------------------------------------------------------------------------

SENTENCE_END = re.compile(r"(?<=[\w)\]'\"`*])\.\s+(?=[A-Z`(*])|\n\s*\n|\||\n\s*(?:[-*#]+|\d+\.)\s")


def check_prose(repo: "Repo", path: str, lines) -> list:
    """The names in the prose ``lines`` ((line number, text), in order) of ``path`` that do not
    resolve, as "path:line: what"."""
    lines = list(lines)
    text, starts, prev = "", [], None
    for n, s in lines:                        # lines not in sequence: separate paragraphs
        text += "\n\n" if prev is not None and n != prev + 1 else ""
        starts.append(len(text))
        text += s + "\n"
        prev = n
    ends = [(m.start(), m.end()) for m in SENTENCE_END.finditer(text)]

    def outside(at: int) -> bool:
        """Whether the sentence around ``at`` names another project."""
        a = max((e for s, e in ends if e <= at), default=0)
        b = min((s for s, e in ends if s >= at), default=len(text))
        return bool(OUTSIDE_PROJECTS.search(text, a, b))

    return [f"{path}:{n}: {b}" for (n, s), at in zip(lines, starts)
            for b in check_line(repo, path, s, lambda col, at=at: outside(at + col))]


def check_line(repo: "Repo", path: str, line: str, outside=None) -> list:
    """The names in one line of prose in ``path`` that do not resolve. ``outside(col)``: whether
    the sentence around column ``col`` names another project (default: the line does)."""
    if outside is None:
        outside = lambda col: bool(OUTSIDE_PROJECTS.search(line))
    bad = []

    def exempt(name: str, col: int) -> bool:
        """An unresolved path that names another project's file."""
        if name.startswith(OURS):
            return False
        if "/" in name.rstrip("/") and name.split("/")[0] not in repo.dir_names:
            return True                        # a tree none of ours: Cycles' kernel/svm/svm.h
        return outside(col)

    kernel_files = set()
    for m in KFUNC_RE.finditer(line):
        f, ident = m.group(1), m.group(2)
        if not ("_" in ident.strip("_") or ident.isupper() or ident in repo.kernel_symbols):
            continue                           # a word: "svm.h and ..."
        if ident.isupper() and len(ident) < 3:
            continue
        found = repo.find(f, path)
        if found is None:
            kernel_files.add(m.start(1))
            if not exempt(f, m.start(1)):
                bad.append(f"{f} {ident}: no such kernel file")
        elif not repo.kernel_defines(found, ident):
            bad.append(f"{f} {ident}: not defined in {found} nor the files it includes")
    for m in PATH_RE.finditer(line):
        name = m.group(1)
        if m.start(1) in kernel_files or repo.resolve(name, path) or exempt(name, m.start(1)):
            continue
        bad.append(f"{name}: no such file")
    for m in DIR_RE.finditer(line):
        if not repo.resolve(m.group(1), path):
            bad.append(f"{m.group(1)}: no such folder")
    ticked = set()
    for m in BACKTICKED_RE.finditer(line):
        ticked |= {m.start(1) + d.start(1) for d in DOTTED_RE.finditer(m.group(1))}
    for d in DOTTED_RE.finditer(line):
        dotted = d.group(1)
        if dotted.rpartition(".")[2] in FILE_EXTENSIONS:
            continue                           # bulb_box.png, bench.json: a file, not Python
        ok = repo.python_ref(dotted, d.start(1) in ticked)
        if ok is False and not (repo.is_short_ref(dotted) and outside(d.start(1))):
            bad.append(f"{dotted}: not defined in ppm_engine")
    return bad
