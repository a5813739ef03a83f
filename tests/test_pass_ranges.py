"""Passes rendered apart and merged (ppm_engine/render/parts.py): with the global radius
schedule every pass is a function of its index alone, so ranges of passes rendered by other
renderers (other devices, machines, Dask workers) add up to the film of one run, to float
rounding on the same device."""
import math

import numpy as np
import pytest

from ppm_engine.oracle.procedural import cornell_box
from ppm_engine.render.options import GLOBAL_ALPHA, RenderOptions, global_radius_scale
from ppm_engine.render.parts import Part, PartError, merge
from ppm_engine.render.renderer import Renderer

pytestmark = pytest.mark.usefixtures("pocl_key")

W = 24


def _options(**kw):
    """Kernels of every feature (the build the other tests share), photons for every bounce
    (no pilot), the global schedule."""
    return RenderOptions(**{"specialize": False, "radius_schedule": "global",
                            "photons_per_pass": 4096, "indirect": "photons", **kw})


def _part(scene, passes, **kw):
    r = Renderer(scene, _options(**kw))
    try:
        for i in passes:
            r.iterate(pass_index=i)
        return Part.of(r), r
    finally:
        r.close()


def test_global_radius_scale_is_knaus_and_zwickers_sequence():
    alpha = 0.7
    r2 = 1.0
    for i in range(200):
        assert global_radius_scale(i, alpha) == pytest.approx(math.sqrt(r2), rel=1e-12)
        r2 *= (i + 1 + alpha) / (i + 2)                 # R_{k+1}^2 = R_k^2 (k + alpha) / (k + 1)
    k = 10 ** 6                                          # ~ k^((alpha - 1) / 2)
    assert global_radius_scale(k - 1, alpha) * k ** ((1 - alpha) / 2) == pytest.approx(
        math.gamma(1 + alpha) ** -0.5, rel=1e-5)


@pytest.mark.parametrize("bulb", [False, True], ids=["cornell", "bulb"])
def test_merged_halves_equal_one_run(bulb):
    """Passes 1-3 and 4-6 rendered by two renderers (the second never saw passes 1-3), merged
    in either order, give the film of one run of passes 1-6: every sum to float rounding (the
    photons' light tracing splats with float atomics), the image to 1e-6 of its value; the
    host's resolve is the device's.  The bulb box's light reaches the walls only as caustic
    photons through its glass; each pass's radius is that pass's own (radius0 x the
    sequence's term, 0 where the pass has no visible point)."""
    scene = cornell_box(W, W, bulb=bulb)
    r = Renderer(scene, _options())
    for _ in range(6):
        r.iterate()
    one, image = Part.of(r), r.image()
    radius, radius0 = r.film.read("radius"), r.film.read("radius0")
    r.close()
    seen = radius > 0
    assert seen.mean() > 0.9
    np.testing.assert_allclose(radius[seen], radius0[seen] * np.float32(
        global_radius_scale(5, GLOBAL_ALPHA)), rtol=1e-6)
    np.testing.assert_allclose(one.image(), image, rtol=1e-6, atol=1e-6)
    first, _ = _part(scene, range(3))
    second, _ = _part(scene, range(3, 6))
    merged = merge([second, first])
    assert merged.passes.tolist() == list(range(6))
    assert merged.photons_emitted == one.photons_emitted
    for name, total in one.sums.items():
        np.testing.assert_allclose(merged.sums[name], total, rtol=1e-6,
                                   atol=1e-6 * max(np.abs(total).max(), 1e-30), err_msg=name)
    np.testing.assert_allclose(merged.image(), image, rtol=1e-6, atol=1e-6)


def test_a_range_rendered_again_is_the_same():
    """Seeds per pass: passes 3-4 rendered twice by two renderers give the same sums, bit for
    bit but for the light tracing's splats and the moments that count them (float atomics: to
    float rounding)."""
    scene = cornell_box(W, W)
    a, _ = _part(scene, range(2, 4))
    b, _ = _part(scene, range(2, 4))
    for name in a.sums:
        if name in ("lt_sum", "moments"):
            np.testing.assert_allclose(a.sums[name], b.sums[name], rtol=1e-6)
        else:
            np.testing.assert_array_equal(a.sums[name], b.sums[name], err_msg=name)


def test_parts_refuse_what_is_not_one_render(tmp_path):
    """Parts are saved and loaded whole; merge refuses another scene, other settings and a pass
    held twice (naming the files and the passes, counted from 1)."""
    scene = cornell_box(W, W)
    a, _ = _part(scene, range(0, 2))
    a.save(tmp_path / "a.npz")
    back = Part.load(tmp_path / "a.npz")
    assert back.meta == a.meta and back.photons_emitted == a.photons_emitted
    np.testing.assert_array_equal(back.sums["photon_sum"], a.sums["photon_sum"])
    b, _ = _part(scene, range(1, 3))
    with pytest.raises(PartError, match=r"a\.npz and b\.npz both hold passes 2"):
        merge([back, b], names=["a.npz", "b.npz"])
    c, _ = _part(scene, range(2, 3), seed=5)
    with pytest.raises(PartError, match="option seed"):
        merge([a, c])
    d, _ = _part(cornell_box(W, W, light_radiance=10.0), range(2, 3))
    with pytest.raises(PartError, match="the scene"):
        merge([a, d])
    (tmp_path / "junk.npz").write_bytes(b"not a part")
    with pytest.raises(PartError, match="not a part"):
        Part.load(tmp_path / "junk.npz")


def test_passes_out_of_order_need_the_global_schedule():
    r = Renderer(cornell_box(8, 8), _options(radius_schedule="pixel"))
    try:
        with pytest.raises(ValueError, match="global"):
            r.iterate(pass_index=3)
    finally:
        r.close()


def test_cli_ranges_merge_into_one_run(bpy, cli, example_blend, pocl_key, exr, tmp_path):
    """`render --pass-range 1-2 -o a.npz` (a fresh process) and passes 3-4 (batch.render_split
    here), merged by `merge a.npz b.npz -o m.exr`, are the image of passes 1-4 in one run
    (to float rounding); merging a part twice names the passes both hold, on stderr, exit 1."""
    from ppm_engine.blender.batch import render_split
    blend = example_blend("cornell_box")
    common = ["--resolution", f"{W}x{W}", "--photons", "4096", "--device", pocl_key]
    proc = cli("render", blend, "--pass-range", "1-2", "-o", tmp_path / "a.npz", *common)
    assert proc.returncode == 0, proc.stderr
    over = {"photons_per_pass": 4096}
    for name, passes in (("b.npz", (3, 4)), ("full.exr", (1, 4))):
        render_split(blend, tmp_path / name, over, device=pocl_key, resolution=(W, W),
                     pass_range=passes)
    proc = cli("merge", tmp_path / "a.npz", tmp_path / "b.npz", "-o", tmp_path / "m.exr")
    assert proc.returncode == 0 and "merged passes 1-4" in proc.stderr, proc.stderr
    merged, full = exr.read(tmp_path / "m.exr"), exr.read(tmp_path / "full.exr")
    assert full[..., :3].mean() > 0.1
    np.testing.assert_allclose(merged, full, rtol=1e-5, atol=1e-6)
    # a PNG through the scene's view transform, kept with the parts: as the whole run's
    from ppm_engine.blender.batch import merge_files
    render_split(blend, tmp_path / "full.png", over, device=pocl_key, resolution=(W, W),
                 pass_range=(1, 4))
    merge_files([tmp_path / "a.npz", tmp_path / "b.npz"], tmp_path / "m.png")
    png = [np.array(bpy.data.images.load(str(tmp_path / n)).pixels[:]) for n in ("m.png",
                                                                             "full.png")]
    assert png[0].mean() > 0.1 and np.abs(png[0] - png[1]).max() <= 1 / 255
    proc = cli("merge", tmp_path / "a.npz", tmp_path / "a.npz", "-o", tmp_path / "x.exr")
    assert proc.returncode == 1 and "Traceback" not in proc.stderr
    assert "a.npz and a.npz both hold passes 1-2" in proc.stderr


@pytest.mark.parametrize("args, words", [
    (["--pass-range", "5-2"], "must not end before it starts"),
    (["--pass-range", "1-4", "--time-limit", "3"], "time limit cannot split"),
    (["--pass-range", "1-4", "--noise-threshold", "0.1"], "adaptive sampling"),
    (["--pass-range", "1-4", "--frames", "1-2"], "--frames"),
])
def test_cli_refuses_what_cannot_split(cli, example_blend, tmp_path, args, words):
    proc = cli("render", example_blend("cornell_box"), "-o", tmp_path / "p.npz", *args)
    assert proc.returncode == 2 and words in proc.stderr and "Traceback" not in proc.stderr
