"""Example scenes built with bpy from nothing (no binary files in the repository).

    save_example("bulb_box", "bulb_box.blend")

The geometry matches ``ppm_engine.procedural.cornell_box`` (the arrays version used by the
core tests and the benchmark)."""
from __future__ import annotations

from . import cornell_box as _cornell_box

EXAMPLES = {
    "cornell_box": lambda: _cornell_box.build(bulb=False),
    "bulb_box": lambda: _cornell_box.build(bulb=True),
}


def build_example(name: str):
    """Replace the current file's content with an example scene; returns the scene."""
    try:
        builder = EXAMPLES[name]
    except KeyError:
        raise KeyError(f"unknown example '{name}'; examples: {', '.join(EXAMPLES)}") from None
    return builder()


def save_example(name: str, path) -> None:
    import bpy
    build_example(name)
    bpy.ops.wm.save_as_mainfile(filepath=str(path), check_existing=False)
