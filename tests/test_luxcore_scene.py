"""What the LuxCore translation does beyond the unit conversions, without pyluxcore (bpy and
NumPy only, so CI runs it): emitters inside glass get IOR^2 (LuxCore's glass is physical,
Cycles' passes radiance unscaled), smooth black emitters go flat, and the pixel filter that
LIGHTCPU's unfiltered, supersampled film goes through (ppm_engine/tools/bench/luxcore.py)."""
import types

import numpy as np
import pytest


def _translate(bpy, name):
    from ppm_engine.blender.scenes import build_example
    from ppm_engine.tools.bench import luxcore_scene
    build_example(name)
    bpy.context.view_layer.update()
    return luxcore_scene.translate(bpy.context.evaluated_depsgraph_get())


def test_an_emitter_inside_glass_gets_ior_squared_and_goes_flat(bpy):
    """The bulb box's filament sits in a glass bulb of IOR 1.5: its emission x 2.25 on its own
    copy of the material; the glass ball on the floor does not enclose it; the filament's
    smooth normals are dropped (LuxCore would emit about them)."""
    from ppm_engine.blender.scenes.bulb_box import FILAMENT_RADIANCE
    tr = _translate(bpy, "bulb_box")
    assert len(tr.glass) == 2 and all(ior == 1.5 for _, ior, _ in tr.glass)
    filament = [n for n, o in tr.objects.items() if o["material"].endswith("_in0")]
    assert len(filament) == 2                      # the mesh and its reversed twin
    mat = tr.objects[filament[0]]["material"]
    gain = tr.props[f"scene.materials.{mat}.emission.gain"]
    assert gain == pytest.approx([2.25 * FILAMENT_RADIANCE] * 3)
    src = mat[:-len("_in0")]
    assert tr.props[f"scene.materials.{src}.emission.gain"] == pytest.approx(
        [FILAMENT_RADIANCE] * 3)
    assert all(tr.meshes[n][2] is None for n in filament)
    # the glass ball's mesh keeps its smooth normals
    assert all(tr.meshes[name][2] is not None for _, _, name in tr.glass)


def test_lights_outside_glass_keep_their_gain(bpy):
    from ppm_engine.blender.scenes.caustics import SPOT_POWER
    tr = _translate(bpy, "point_caustic")
    assert len(tr.glass) == 1
    light = next(k for k in tr.props if k.startswith("scene.lights.") and k.endswith(".gain"))
    assert tr.props[light] == pytest.approx([SPOT_POWER] * 3)


def test_inside_a_closed_mesh():
    from ppm_engine.tools.bench import luxcore_lights
    v, f = luxcore_lights.icosphere(2)
    tris = v[f]
    assert luxcore_lights._closed(tris) and not luxcore_lights._closed(tris[1:])
    pts = np.array([[0.0, 0.0, 0.0], [0.5, 0.3, -0.2], [1.5, 0.0, 0.0], [0.0, 0.0, -2.0]])
    assert luxcore_lights.inside(pts, tris).tolist() == [True, True, False, False]


def test_pixel_filter_of_a_supersampled_film():
    """Cycles' Blackman-Harris 1.5 px from a film of 8 x 8 fine pixels per pixel: a constant
    stays itself where the filter stays inside the frame, and one fine pixel's light reaches the
    pixels within the filter's reach of it, each by the filter (exact_film's, written apart)
    at their distance, over the fine pixel's area."""
    from ppm_engine.tools.bench import exact_film, luxcore
    scene = types.SimpleNamespace(cycles=types.SimpleNamespace(
        pixel_filter_type="BLACKMAN_HARRIS", filter_width=1.5))
    k, n = 8, 12
    out = luxcore.pixel_filter(np.ones((k * n, k * n, 3), np.float32), scene, k)
    assert out.shape == (n, n, 3)
    assert np.allclose(out[1:-1, 1:-1], 1.0, atol=1e-6) and (out[0] < 0.95).all()
    fine = np.zeros((k * n, k * n, 3), np.float32)
    fine[5 * k + 3, 6 * k + 4] = 1.0               # in pixel (5, 6), its centre at (x, y):
    x, y = 6 + 4.5 / k, 5 + 3.5 / k
    out = luxcore.pixel_filter(fine, scene, k)[..., 0]
    c = np.arange(n) + 0.5
    f = exact_film.filter_1d
    expect = np.outer(f(y - c, 1.5), f(x - c, 1.5)) / (k * k)
    assert np.abs(out - expect).max() < 0.01 * expect.max()
    assert (out > 0).sum() == 9 and out[5, 6] == out.max()   # 3 x 3 within 1.5 px
