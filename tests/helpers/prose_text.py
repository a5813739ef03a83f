"""The prose tests/test_prose.py reads: which files (README.md, tests/README.md, docs/**/*.md
but docs/history/, and the code's comments and docstrings), and their lines of prose: Markdown
line by line, Python's comments and docstrings (tokenize), OpenCL C's comments."""
import io
import re
import tokenize
from pathlib import Path

C_NOISE = re.compile(r'/\*.*?(?:\*/|\Z)|//[^\n]*|"(?:\\.|[^"\\\n])*"', re.S)


def strip_c(text: str, strings: bool = True) -> str:
    """C source with comments and (``strings``) string literals blanked (newlines kept)."""
    def blank(m):
        t = m.group()
        if t.startswith('"'):
            return '""' if strings else t
        return "\n" * t.count("\n") if t.startswith("/*") else ""
    return C_NOISE.sub(blank, text)


def prose_files(root: Path) -> list:
    """The files whose prose is checked (repository-relative paths)."""
    out = [p for p in ("README.md", "tests/README.md") if (root / p).exists()]
    out += [p.relative_to(root).as_posix() for p in sorted((root / "docs").rglob("*.md"))
            if "history" not in p.relative_to(root / "docs").parts]
    out += [p.relative_to(root).as_posix() for p in sorted((root / "ppm_engine").rglob("*.py"))]
    out += [p.relative_to(root).as_posix() for p in sorted((root / "tests").glob("*.py"))]
    out += [p.relative_to(root).as_posix() for p in sorted((root / "docs").rglob("*.py"))]
    out += [p.relative_to(root).as_posix() for p in sorted(root.glob("*.py"))]
    for pat in ("*.h", "*.cl"):
        out += [p.relative_to(root).as_posix() for p in sorted((root / "kernels").rglob(pat))]
    return out


def prose_lines(root: Path, path: str):
    """(line number, text) of the prose in one file: every line of Markdown, the comments and
    docstrings of Python, the comments of OpenCL C (comment markers blanked)."""
    text = (root / path).read_text(errors="replace")
    if path.endswith(".md"):
        return list(enumerate(text.split("\n"), 1))
    if path.endswith(".py"):
        return _python_prose(text)
    return _c_prose(text)


def _python_prose(text: str):
    """Comments, and docstrings: a string that opens a module or the indented body of a def or
    class (the logical line before it started with def, class or async)."""
    out = []
    first_kw, kw, at_start, after_indent = None, None, True, False
    for tok in tokenize.generate_tokens(io.StringIO(text).readline):
        if tok.type == tokenize.COMMENT:
            out.append((tok.start[0], re.sub(r"^#+", lambda m: " " * len(m.group()), tok.string)))
            continue
        if tok.type in (tokenize.NL, tokenize.ENCODING):
            continue
        if tok.type == tokenize.STRING and (at_start or (after_indent and kw in (
                "def", "class", "async"))):
            out += [(tok.start[0] + i, s) for i, s in enumerate(tok.string.split("\n"))]
        at_start = False
        after_indent = tok.type == tokenize.INDENT
        if tok.type == tokenize.NEWLINE:
            kw, first_kw = first_kw, None
        elif first_kw is None and tok.type not in (tokenize.INDENT, tokenize.DEDENT):
            first_kw = tok.string
    return out


def _c_prose(text: str):
    out = []
    for m in re.finditer(r"/\*.*?\*/|//[^\n]*", text, re.S):
        line = text.count("\n", 0, m.start()) + 1
        for i, s in enumerate(m.group(0).split("\n")):
            s = re.sub(r"^(\s*)(/\*+|//+|\*(?!/))", lambda g: " " * len(g.group()), s)
            out.append((line + i, s.replace("*/", "  ")))
    return out


# a sentence ends at ". " before a capital, a blank line, a table cell, a list item or heading
