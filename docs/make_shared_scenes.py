"""The real scenes of ../shared/scenes beside Cycles: block agreement and a side-by-side image.

    .venv/bin/python docs/make_shared_scenes.py --label after          # render with this checkout
    .venv/bin/python docs/make_shared_scenes.py --figure before after  # the image, the table

Each scene (a .blend made from public models, not part of the repository) is rendered by this
engine (128 x 128, --passes passes) and by Cycles (--spp samples per pixel, cached: the
reference is independent of the engine measured), both through the same bpy.  A block is 8 x 8
pixels; it "shows the model" when the model covers at least half of it (a transparent-film
Cycles render with the ground plane hidden gives the coverage), and it agrees when the mean of
its pixels (over RGB) lies within 10 % of Cycles'.  The share of agreeing model blocks is the
figure (issue 14's measure: the ground plane is left out, it hides a wrong model).  Renders are
cached as .npy under --cache, one file per scene and label, so a figure can put renders of two
checkouts side by side (render "before" with the older checkout's own copy of this script).
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
SCENES = ("cornell_original", "cornell_glass", "glass_vase_flowers", "lights_punctual_lamp",
          "glam_velvet_sofa", "sheen_chair")
BLOCK = 8


def _open(path: Path, size: int):
    import bpy
    bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False, use_scripts=False)
    scene = bpy.context.scene
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = False
    return bpy, scene


def _render(bpy, scene, out: Path) -> np.ndarray:
    from ppm_engine.blender.harness import read_exr, set_output
    set_output(scene, out)
    bpy.ops.render.render(write_still=True)
    return read_exr(out)


def render_ours(path: Path, size: int, passes: int) -> np.ndarray:
    """This engine's image with the Light Paths Cycles' reference renders with
    (harness.unbiased_light_paths, which cycles_reference sets): both engines read
    scene.cycles, so the scene's own (Cycles' defaults: 4 diffuse bounces, Clamp Indirect 10)
    would compare a clamped, shorter transport with the reference's."""
    from ppm_engine.blender.harness import ensure_registered, unbiased_light_paths
    ensure_registered()
    bpy, scene = _open(path, size)
    unbiased_light_paths(scene)
    scene.render.engine = "PPM"
    scene.ppm.passes = passes
    scene.ppm.time_limit = 0.0
    with tempfile.TemporaryDirectory() as tmp:
        return _render(bpy, scene, Path(tmp) / "ours.exr")[..., :3]


def render_cycles(path: Path, size: int, spp: int, mask: bool = False) -> np.ndarray:
    """Cycles' image, or with ``mask`` the model's coverage (alpha with the ground hidden)."""
    from ppm_engine.blender.harness import cycles_reference
    bpy, scene = _open(path, size)
    cycles_reference(scene, samples=16 if mask else spp)
    if mask:
        scene.render.film_transparent = True
        for obj in scene.objects:
            if obj.name.startswith("Ground"):
                obj.hide_render = True
    with tempfile.TemporaryDirectory() as tmp:
        img = _render(bpy, scene, Path(tmp) / "cycles.exr")
    return img[..., 3] if mask else img[..., :3]


def blocks(img: np.ndarray) -> np.ndarray:
    h, w = img.shape[:2]
    img = img.reshape(h // BLOCK, BLOCK, w // BLOCK, BLOCK, -1)
    return img.mean(axis=(1, 3, 4))


def agreement(ours: np.ndarray, ref: np.ndarray, cover: np.ndarray) -> float:
    """Share of the model's blocks whose mean lies within 10 % of Cycles'."""
    a, b, m = blocks(ours), blocks(ref), blocks(cover[..., None]) >= 0.5
    ok = np.abs(a - b) <= 0.1 * np.abs(b)
    return float(ok[m].mean()) if m.any() else float("nan")


def _cached(cache: Path, name: str, make):
    f = cache / f"{name}.npy"
    if not f.exists():
        np.save(f, make())
    return np.load(f)


def figure(cache: Path, labels: list[str], out: Path) -> dict:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    table = {}
    cols = labels + ["cycles"]
    fig, ax = plt.subplots(len(SCENES), len(cols), figsize=(2.2 * len(cols), 2.3 * len(SCENES)))
    for r, name in enumerate(SCENES):
        ref, cover = np.load(cache / f"{name}.cycles.npy"), np.load(cache / f"{name}.mask.npy")
        scale = max(float(np.percentile(ref, 99)), 1e-6)
        for c, label in enumerate(cols):
            f = cache / f"{name}.{label}.npy"
            a = ax[r, c]
            a.axis("off")
            if not f.exists():
                continue
            img = np.load(f)
            if label == "cycles":
                title = "Cycles"
            else:
                share = agreement(img, ref, cover)
                table.setdefault(name, {})[label] = share
                title = f"{label}: {100 * share:.0f} % blocks"
            a.imshow(np.clip(img / scale, 0, 1) ** (1 / 2.2))
            a.set_title((f"{name}\n" if c == 0 else "") + title, fontsize=7)
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    return table


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scenes", type=Path, default=ROOT.parent / "shared" / "scenes")
    p.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "ppm_shared")
    p.add_argument("--size", type=int, default=128)
    p.add_argument("--passes", type=int, default=64)
    p.add_argument("--spp", type=int, default=512)
    p.add_argument("--label", help="render this checkout's images under this label")
    p.add_argument("--only", nargs="*", default=list(SCENES))
    p.add_argument("--figure", nargs="*", help="labels to put beside Cycles")
    p.add_argument("--out", type=Path, default=ROOT / "docs" / "images" / "shared_scenes.png")
    a = p.parse_args(argv)
    a.cache.mkdir(parents=True, exist_ok=True)
    for name in a.only:
        path = a.scenes / name / f"{name}.blend"
        if not path.exists():
            print(f"{path}: not found (the shared scenes are outside the repository)",
                  file=sys.stderr)
            return 2
        _cached(a.cache, f"{name}.cycles", lambda p=path: render_cycles(p, a.size, a.spp))
        _cached(a.cache, f"{name}.mask",
                lambda p=path: render_cycles(p, a.size, a.spp, mask=True))
        if a.label:
            img = render_ours(path, a.size, a.passes)
            np.save(a.cache / f"{name}.{a.label}.npy", img)
            ref, cover = (np.load(a.cache / f"{name}.{k}.npy") for k in ("cycles", "mask"))
            print(f"{name}: {100 * agreement(img, ref, cover):.0f} % of the model's blocks "
                  "within 10 % of Cycles", flush=True)
    if a.figure:
        print(json.dumps(figure(a.cache, a.figure, a.out), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
