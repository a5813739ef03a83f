"""Light tracing (ppm_engine/render/light_tracer.py, kernels/integrator/light_trace.cl), the
benchmark's independent reference for the caustic scenes: the same image as Cycles where both
converge (the Cornell box, per 8x8 block), the pixels it cannot render left out, and the pixel
filter's density."""
import numpy as np
import pytest

bpy = pytest.importorskip("bpy")


def _example(name, width):
    from ppm_engine.blender.export import export_scene
    from ppm_engine.blender.harness import ensure_registered
    from ppm_engine.blender.scenes import build_example
    from tests.helpers.blender_scenes import square
    ensure_registered()
    scene = square(build_example(name), width)
    return scene, export_scene(bpy.context.evaluated_depsgraph_get())


def test_light_tracing_is_cycles_on_the_cornell_box(cycles, render_exr, tmp_path):
    """Light tracing and Cycles (1024 samples) agree per 8x8 block within their noise on every
    block light tracing covers; the blocks that see the lamp are not covered."""
    from ppm_engine.render.light_tracer import LightTracer
    W = 32
    scene, arrays = _example("cornell_box", W)
    lt = LightTracer(arrays, photons=1 << 16, seed=3)
    lt.trace(24)
    img, cover = lt.image()[::-1], lt.coverage()[::-1]
    lt.close()
    cycles(scene, 1024, W)
    ref = render_exr(tmp_path / "cycles.exr")

    def blocks(x):
        return x.reshape(W // 8, 8, W // 8, 8, -1).mean(axis=(1, 3, 4))
    covered = blocks(cover[..., None].astype(np.float32)) == 1.0
    assert 0.6 * covered.size < covered.sum() < covered.size       # the lamp's blocks are not
    ratio = blocks(img) / blocks(ref)
    assert np.abs(ratio[covered] - 1).max() < 0.05, ratio
    assert img[cover].mean() == pytest.approx(ref[cover].mean(), rel=0.01)
    # the lamp itself (an emitter seen directly) is what it does not render
    assert not cover[:4].all()


@pytest.mark.parametrize("kind, width", [(0, 1.5), (1, 1.0), (2, 1.5), (0, 0.0)])
def test_filter_density_integrates_to_one(kind, width):
    from ppm_engine.render.film import FILTER_SAMPLES, filter_density
    f, reach = filter_density(width, kind)
    x = np.linspace(-reach, reach, FILTER_SAMPLES)
    assert np.trapz(f, x) == pytest.approx(1.0, rel=1e-3)
    assert reach == pytest.approx({0: width or 0.5, 1: 0.5, 2: 1.5 * width}[kind])
    # the film's jitter table samples the same filter: its spread matches the density's
    from ppm_engine.render.film import filter_table
    t = filter_table(width, kind)
    assert t.var() == pytest.approx(np.trapz(f * x * x, x), rel=0.03)


def test_depth_of_field_is_refused():
    from ppm_engine.oracle.procedural import cornell_box
    from ppm_engine.render.light_tracer import LightTracer
    s = cornell_box(8, 8)
    cam = s.camera.copy()
    cam["aperture_radius"] = 0.01
    with pytest.raises(ValueError, match="pinhole"):
        LightTracer(s.replace(camera=cam))
