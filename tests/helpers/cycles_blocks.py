"""A Blender scene rendered by Cycles and by this engine in the same test, compared per 8 x 8
block (the materials' and the worlds' tests)."""
import numpy as np

W = 48          # image size: 6 x 6 blocks of 8 x 8 pixels


def render_both(scene, cycles, render_exr, tmp_path, tiny, *, samples, passes, bounces,
                photons):
    """(ours, Cycles') RGB of ``scene``, W x W: Cycles at ``samples`` per pixel and this engine
    in ``passes`` passes of ``photons`` photons, both with ``bounces`` bounces."""
    cycles(scene, samples, width=W)
    c = scene.cycles
    c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = bounces
    c.transparent_max_bounces = max(bounces, 8)
    ref = render_exr(tmp_path / "cycles.exr")
    tiny(scene, width=W, height=W, passes=passes, photons=photons)
    ours = render_exr(tmp_path / "ours.exr")
    return ours, ref


def blocks(img):
    """The means of an RGB image's 8 x 8 blocks (its sides multiples of 8: W x W here)."""
    h, w = img.shape[:2]
    return img.reshape(h // 8, 8, w // 8, 8, 3).mean(axis=(1, 3))


def compare_blocks(ours, ref, rtol, atol):
    """Every 8 x 8 block of ours within rtol (relative) + atol of Cycles' (ref)."""
    a, b = blocks(ours), blocks(ref)
    bad = np.abs(a - b) > rtol * np.abs(b) + atol
    assert not bad.any(), (f"{bad.any(-1).sum()} of {bad.shape[0] * bad.shape[1]} blocks "
                           f"differ; worst ratio {np.max(a / np.maximum(b, 1e-6)):.3f} / "
                           f"{np.min(a / np.maximum(b, 1e-6)):.3f}")
