"""Several OpenCL devices on one image (ppm_engine/render/multi_device.py): PoCL's CPU device
twice (two contexts on it, "KEY#1") stands for two devices; their passes interleave and their
films merge into the image of one device's run, to float rounding."""
import types

import numpy as np
import pytest

from ppm_engine.oracle.procedural import cornell_box
from ppm_engine.render.multi_device import MultiRenderer
from ppm_engine.render.options import RenderOptions
from ppm_engine.render.parts import Part
from ppm_engine.render.renderer import Renderer

W = 24


def _options(pocl_key, **kw):
    return RenderOptions(**{"specialize": False, "radius_schedule": "global",
                            "photons_per_pass": 4096, "indirect": "photons", "passes": 8,
                            "device": pocl_key, **kw})


def test_two_contexts_of_one_device_render_one_image(pocl_key):
    """8 passes taken by two devices as each is free (each its own first pass, then as it is
    free), merged: the image of 8 passes on one device, to float rounding; each pass counted
    once."""
    scene = cornell_box(W, W)
    r = Renderer(scene, _options(pocl_key))
    for _ in range(8):
        r.iterate()
    one = Part.of(r)
    r.close()
    m = MultiRenderer(scene, _options(pocl_key, radius_schedule="pixel"),
                      [pocl_key, f"{pocl_key}#1"])
    try:
        assert m.renderers[0].device is not m.renderers[1].device
        assert m.renderers[0].independent          # the global schedule whatever was asked
        part = m.run()
        assert min(m.passes_by_device) >= 1 and sum(m.passes_by_device) == 8
        assert part.passes.tolist() == list(range(8))
        np.testing.assert_allclose(part.image(), one.image(), rtol=1e-6, atol=1e-6)
        assert m.iterate() is None                 # all passes done
    finally:
        m.close()


def test_a_slow_device_stops_taking_passes(pocl_key):
    """Load balancing by pass time: a device whose pass takes longer than the fastest one
    needs for all the passes left takes no more."""
    m = MultiRenderer.__new__(MultiRenderer)
    m.pass_list, m._next, m.pass_seconds = list(range(10)), 7, [0.01, 0.5]
    m._first_taken, m._taking = [True, True], {0, 1}
    m._lock, m._stop = __import__("threading").Lock(), __import__("threading").Event()
    assert m._take(1) is None                      # 0.5 s > 3 passes x 0.01 s
    assert m._take(0) == 7
    assert m._taking == {0}
    m.pass_seconds = [0.9, 0.1]       # the one still taking passes slowed down: it goes on,
    assert m._take(0) == 8            # the stopped one's time does not count
    m._taking, m.pass_seconds, m._next = {0, 1}, [0.01, 0.02], 5
    assert m._take(1) == 5                         # 0.02 s < 5 passes x 0.01 s
    m._first_taken, m._next = [False, False], 2       # a device's first pass is its own
    assert m._take(0) == 0 and m._take(0) == 2 and m._take(1) == 1


class _Layout:
    """A stand-in for a panel's layout: records the operators drawn."""
    def __init__(self, ops):
        self.ops, self.use_property_split = ops, False

    def column(self, **kw):
        return self

    def prop(self, *a, **kw):
        pass

    def label(self, **kw):
        self.ops.append(("label", kw["text"]))

    def operator(self, idname, **kw):
        op = types.SimpleNamespace()
        self.ops.append((idname, kw["text"], kw["icon"], op))
        return op


def test_device_panel_ticks_devices_and_they_render_together(bpy, example_blend, pocl_key,
                                                              tiny, exr, tmp_path):
    """The Device panel lists each OpenCL device with a checkbox (its operator ticks it);
    two ticked render the image together through Blender's render (Session): the image of
    the same passes on one device (batch.render_split)."""
    from ppm_engine.blender.batch import render_split
    from ppm_engine.blender.properties import to_options
    from ppm_engine.blender.ui import PPM_PT_device
    blend = example_blend("cornell_box")
    bpy.ops.wm.open_mainfile(filepath=str(blend), load_ui=False)
    scene = bpy.context.scene
    tiny(scene, width=W, height=W, passes=6, photons=4096, specialize=True)
    ops = []
    PPM_PT_device.draw(types.SimpleNamespace(layout=_Layout(ops)), bpy.context)
    boxes = [o for o in ops if o[0] == "ppm.tick_device"]
    assert any(o[3].key == pocl_key and o[2] == 'CHECKBOX_DEHLT' and o[3].on for o in boxes)
    assert bpy.ops.ppm.tick_device(key=pocl_key, on=True) == {'FINISHED'}
    bpy.ops.ppm.tick_device(key=f"{pocl_key}#1", on=True)
    assert to_options(scene.ppm).devices == (pocl_key, f"{pocl_key}#1")
    ops.clear()
    PPM_PT_device.draw(types.SimpleNamespace(layout=_Layout(ops)), bpy.context)
    assert any(o[0] == "ppm.tick_device" and o[3].key == pocl_key and o[2] == 'CHECKBOX_HLT'
               for o in ops) and any(o[0] == "label" for o in ops)
    exr.set_output(scene, tmp_path / "two.exr")
    assert bpy.ops.render.render(write_still=True) == {'FINISHED'}
    two = exr.read(tmp_path / "two.exr")
    render_split(blend, tmp_path / "one.exr", {"photons_per_pass": 4096, "passes": 6},
                 device=pocl_key, resolution=(W, W))
    one = exr.read(tmp_path / "one.exr")
    assert one[..., :3].mean() > 0.1
    np.testing.assert_allclose(two, one, rtol=1e-5, atol=1e-6)


def test_two_devices_render_the_cornell_box_as_cycles(bpy, example_blend, pocl_key, tiny,
                                                      cycles, render_exr, tmp_path):
    """The Cornell box (the example .blend) on two devices with the global radius schedule, 60
    passes, against Cycles at 256 samples, 32 x 32: the mean within 5 %, every bright 8 x 8
    block within 15 % (tests/test_e2e.py's bounds for one device and the paper's schedule)."""
    w = 32
    bpy.ops.wm.open_mainfile(filepath=str(example_blend("cornell_box")), load_ui=False)
    scene = bpy.context.scene
    cycles(scene, 256, w)
    ref = render_exr(tmp_path / "cycles.exr")
    tiny(scene, width=w, height=w, passes=60, photons=1 << 13)
    scene.ppm.devices = f"{pocl_key}\n{pocl_key}#1"
    ours = render_exr(tmp_path / "two.exr")
    assert ours.mean() == pytest.approx(ref.mean(), rel=0.05)
    b_ours = ours.reshape(4, 8, 4, 8, 3).mean(axis=(1, 3))
    b_ref = ref.reshape(4, 8, 4, 8, 3).mean(axis=(1, 3))
    bright = b_ref > 0.05
    ratio = b_ours[bright] / b_ref[bright]
    print(f"blocks against Cycles: {ratio.min():.3f} .. {ratio.max():.3f}")
    assert np.abs(ratio - 1).max() < 0.15
