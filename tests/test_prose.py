"""Prose tells the truth: every file, kernel function and Python name that the README, docs/
and the comments and docstrings of the code name exists, as the files on disk stand when the
test runs (tests/helpers/prose.py: what counts as a name, and what is exempt)."""
import ast
import re
import time
from functools import lru_cache

from tests.helpers.prose import ROOT, Repo, check_prose
from tests.helpers.prose_text import prose_files, prose_lines


@lru_cache(maxsize=1)
def repo() -> Repo:
    return Repo(ROOT)


# --- tests -----------------------------------------------------------------------------------

def test_prose_names_only_what_exists():
    t0 = time.perf_counter()
    r = repo()
    bad = []
    for path in prose_files(ROOT):
        bad += check_prose(r, path, prose_lines(ROOT, path))
    print(f"{len(prose_files(ROOT))} files checked in {time.perf_counter() - t0:.2f} s")
    assert not bad, "names in prose that do not exist:\n" + "\n".join(bad)


def _real_names(r: Repo) -> dict:
    """Names that exist today, found on disk (so that these tests survive files moving): a
    kernel file and a function it defines, a module with a class and one of its methods."""
    rng = r.find("rng.h", "")
    fn = sorted(n for n in r.kernel_defs(rng)[0] if n.islower() and "_" in n)[0]
    module, node = r.classes["RenderOptions"][0]
    method = sorted(n.name for n in node.body if isinstance(n, ast.FunctionDef))[0]
    return dict(rng=rng, fn=fn, module=module, file=r.modules[module], method=method)


def _check(r: Repo, lines: list) -> list:
    """The checker on made-up prose in docs/, each string a paragraph of its own (a string with
    newlines: lines of one paragraph)."""
    numbered, n = [], 1
    for text in lines:
        for s in text.split("\n"):
            numbered.append((n, s))
            n += 1
        n += 1
    return check_prose(r, "docs/MADE_UP.md", numbered)


def test_the_checker_finds_stale_names():
    r = repo()
    k = _real_names(r)
    stale = {"kernels/no_such_file.h": "see `kernels/no_such_file.h` for the lights",
             "no_such_function": f"the cone (`{k['rng']} no_such_function`) is sampled",
             "gone.h": "the lamp's pick (gone.h)",
             "RenderOptions.no_such_method": "its settings (`RenderOptions.no_such_method`)",
             f"ppm_engine.{k['module']}.NoSuchClass": f"`ppm_engine.{k['module']}.NoSuchClass`",
             "ppm_engine/no_such_folder/": "the modules in ppm_engine/no_such_folder/",
             # a sentence after the one that names Cycles is ours again
             "lights.h direct_lighting": "As Cycles does.  The lamp (lights.h direct_lighting)",
             # the stale names this test was written to find
             "kernels/integrator/path_state.h path_within":
                 "(kernels/integrator/path_state.h path_within)"}
    bad = _check(r, list(stale.values()))
    for name in stale:
        assert [b for b in bad if name in b], (name, bad)
    assert len(bad) == len(stale), bad
    assert all(re.match(r"docs/MADE_UP\.md:\d+: ", b) for b in bad), bad


def test_the_checker_passes_true_prose():
    r = repo()
    k = _real_names(r)
    rng_base = k["rng"].rpartition("/")[2]
    true = [f"the sequence (`{k['rng']} {k['fn']}`) and {rng_base} {k['fn']}; {rng_base} and "
            f"{k['file']}, ppm_engine/data/ and docs/",
            f"`ppm_engine.{k['module']}.RenderOptions`, `RenderOptions.{k['method']}` and "
            f"RenderOptions.{k['method']}; `{k['module'].rpartition('.')[2]}.RenderOptions`",
            # other projects' sources: a folder none of ours, a sentence naming the project
            "Cycles' kernel/svm/svm.h and intern/cycles/kernel/light/light.h",
            "Cycles' textures (learnt from its kernel/svm/checker.h,\ngradient.h and brick.h)",
            "the filter is LuxCore's (blackmanharris.h)",
            # words after a kernel file are not names; file names with other extensions neither
            f"{rng_base} and the rest, in {rng_base} for kernels; bulb_box.png and bench.json"]
    assert _check(r, true) == []
