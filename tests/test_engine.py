"""The Blender layer through bpy: registration, settings, renders through bpy.ops.render.render,
and the session's result handling (cancel, errors) with a stand-in engine."""
import sys
import types

import numpy as np
import pytest

from ppm_engine.errors import SceneError
from ppm_engine.render.options import LIMITS, SettingsError


def _open(bpy, path):
    bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False)
    return bpy.context.scene


def _render_exr(bpy, scene, exr, path):
    exr.set_output(scene, path)
    assert scene.render.engine == "PPM"
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    assert path.is_file()
    return exr.read(path)


# --- registration and settings -------------------------------------------------------------------
def test_engine_is_registered_and_selectable(bpy):
    scene = bpy.context.scene
    scene.render.engine = "PPM"
    assert scene.render.engine == "PPM"
    # the engine menu is dynamic: the error message of a bad id lists every registered engine
    with pytest.raises(TypeError, match="'PPM'"):
        scene.render.engine = "NO_SUCH_ENGINE"
    from ppm_engine.blender.engine import PPMRenderEngine
    assert PPMRenderEngine.bl_label == "Progressive Photon Mapping"
    assert PPMRenderEngine.bl_use_shading_nodes_custom is False


def test_settings_carry_the_limits(bpy):
    props = bpy.types.Scene.bl_rna.properties["ppm"].fixed_type.bl_rna.properties
    for name, (lo, hi, default, desc) in LIMITS.items():
        p = props[name]
        assert p.description == desc
        assert p.name
        assert p.hard_min == pytest.approx(lo) and p.hard_max == pytest.approx(hi), name
        assert p.default == pytest.approx(default), name
    assert "exact_gather" not in props


def test_photon_count_is_automatic_until_one_is_typed(bpy):
    from ppm_engine.blender.properties import to_options
    scene = bpy.data.scenes.new("photon-count")
    try:
        s = scene.ppm
        assert s.auto_photons is True and s.photons_per_pass == 1 << 18   # the paper's 512^2
        assert to_options(s).photons_per_pass is None                    # automatic
        s.photons_per_pass = 5000                       # typed (UI or Python): that count
        assert s.auto_photons is False and to_options(s).photons_per_pass == 5000
        s.auto_photons = True
        assert to_options(s).photons_per_pass is None and s.photons_per_pass == 5000
    finally:
        bpy.data.scenes.remove(scene)


def test_a_file_from_before_the_automatic_photon_count_keeps_its_count(bpy, session_dir):
    """A file whose scene stored only Photons per Pass (saved before Automatic existed) opens
    with that count in force; a file that stored neither keeps the automatic count."""
    from ppm_engine.blender.properties import to_options
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    name = scene.name
    scene.ppm["photons_per_pass"] = 5000          # as an older version stored it (no callback)
    bpy.data.scenes.new("untouched")
    path = session_dir / "old_photons.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False)
    old = bpy.data.scenes[name]
    assert old.ppm.auto_photons is False and to_options(old.ppm).photons_per_pass == 5000
    assert bpy.data.scenes["untouched"].ppm.auto_photons is True


def test_device_enum_lists_default_and_pocl(bpy, pocl_key):
    from ppm_engine.blender.properties import refresh_devices
    keys = [item[0] for item in refresh_devices()]
    assert keys[0] == "DEFAULT" and pocl_key in keys
    scene = bpy.context.scene
    scene.ppm.device = pocl_key
    assert scene.ppm.device == pocl_key
    scene.ppm.device = "DEFAULT"
    from ppm_engine.blender.properties import to_options
    assert to_options(scene.ppm).device == ""


def test_panels_opt_in_and_out(bpy):
    import ppm_engine
    from ppm_engine.blender import ui
    extra = [getattr(bpy.types, name) for name in ui.EXTRA_BUILTIN_PANELS]
    assert len(extra) == 11
    for panel in extra + [bpy.types.RENDER_PT_format, bpy.types.RENDER_PT_color_management]:
        assert "PPM" in panel.COMPAT_ENGINES, panel
    # Cycles' film and Light Paths panels only (not its Fast GI): the other Cycles panels
    # (which share one base class) are not this engine's
    assert "PPM" in bpy.types.CYCLES_RENDER_PT_film_pixel_filter.COMPAT_ENGINES
    assert "PPM" in bpy.types.CYCLES_RENDER_PT_light_paths_clamping.COMPAT_ENGINES
    for name in ("CYCLES_RENDER_PT_sampling", "CYCLES_RENDER_PT_light_paths_fast_gi",
                 "CYCLES_MATERIAL_PT_surface"):
        assert "PPM" not in getattr(bpy.types, name).COMPAT_ENGINES, name
    assert "CYCLES" in bpy.types.CYCLES_RENDER_PT_film.COMPAT_ENGINES
    assert all(cls.is_registered for cls in ui.CLASSES)
    ppm_engine.unregister()
    try:
        assert not hasattr(bpy.types.Scene, "ppm")
        for panel in extra + [bpy.types.RENDER_PT_format]:
            assert "PPM" not in panel.COMPAT_ENGINES, panel
        assert "BLENDER_EEVEE" in bpy.types.EEVEE_MATERIAL_PT_surface.COMPAT_ENGINES
    finally:
        ppm_engine.register()
    assert "PPM" in bpy.types.DATA_PT_EEVEE_light.COMPAT_ENGINES


def test_invalid_settings_are_refused(bpy, example_blend, tiny, exr, session_dir):
    from ppm_engine.blender.properties import to_options
    scene = _open(bpy, example_blend("cornell_box"))
    tiny(scene)
    scene.ppm.alpha = 1.0        # inside the property's range, refused by RenderOptions.validate
    with pytest.raises(SettingsError, match="alpha"):
        to_options(scene.ppm)
    exr.set_output(scene, session_dir / "refused.exr")
    with pytest.raises(RuntimeError, match="alpha"):
        bpy.ops.render.render(write_still=True)
    assert not (session_dir / "refused.exr").exists()


# --- renders -----------------------------------------------------------------------------------
def test_cornell_box_renders_to_exr(bpy, example_blend, tiny, exr, session_dir):
    scene = _open(bpy, example_blend("cornell_box"))
    tiny(scene, width=32, height=24)
    img = _render_exr(bpy, scene, exr, session_dir / "cornell.exr")
    assert img.shape == (24, 32, 4)
    assert np.isfinite(img).all()
    assert img[..., :3].mean() > 1e-3           # lit, not black
    assert np.allclose(img[..., 3], 1.0)        # closed box: every pixel hits something


def test_border_render_writes_the_border_rectangle(bpy, example_blend, tiny, exr, session_dir):
    scene = _open(bpy, example_blend("cornell_box"))
    tiny(scene, width=32, height=32)
    r = scene.render
    r.use_border, r.use_crop_to_border = True, True
    r.border_min_x, r.border_max_x = 0.25, 0.75     # 8..24
    r.border_min_y, r.border_max_y = 0.0, 0.5       # 0..16
    img = _render_exr(bpy, scene, exr, session_dir / "border.exr")
    assert img.shape == (16, 16, 4)
    assert np.isfinite(img).all() and img[..., :3].mean() > 1e-3


def _dark_scene(bpy, path):
    """A camera looking at a grey plane, no lights, black world."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location = (0.0, 0.0, 4.0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    mesh = bpy.data.meshes.new("Plane")
    mesh.from_pydata([(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)], [], [(0, 1, 2, 3)])
    scene.collection.objects.link(bpy.data.objects.new("Plane", mesh))
    world = bpy.data.worlds.new("Black")
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0, 0, 0, 1)
    scene.world = world
    bpy.ops.wm.save_as_mainfile(filepath=str(path))


def test_scene_without_light_renders_black_with_a_warning_and_no_device_work(
        bpy, tiny, exr, session_dir, monkeypatch, capfd):
    from ppm_engine.blender import session
    from ppm_engine.render import renderer
    _dark_scene(bpy, session_dir / "dark.blend")
    scene = _open(bpy, session_dir / "dark.blend")
    tiny(scene)
    out = session_dir / "dark.exr"
    exr.set_output(scene, out)

    def no_device(*args, **kwargs):
        raise AssertionError("a scene that emits nothing built a Renderer")
    monkeypatch.setattr(renderer.Renderer, "__init__", no_device)
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    assert "emits no light" in capfd.readouterr().out      # report({'WARNING'}) reaches the log
    assert session.renders[-1]["dark"] is True
    img = exr.read(out)
    assert np.isfinite(img).all() and img.shape[:2] == (24, 24)          # conftest TINY
    assert np.abs(img[..., :3]).max() == 0 and (img[..., 3] == 1).all()


# --- the session's result handling, with a stand-in engine ----------------------------------------
class _Rect:
    def __init__(self, n):
        self.data = np.zeros(n, np.float32)

    def foreach_set(self, a):
        assert a.dtype == np.float32 and a.ndim == 1 and a.size == self.data.size
        self.data[:] = a


class _Result:
    def __init__(self, w, h):
        self.resolution_x, self.resolution_y = w, h
        self.rect = _Rect(w * h * 4)
        self.merged = None
        combined = types.SimpleNamespace(rect=self.rect)
        self.layers = [types.SimpleNamespace(passes={"Combined": combined})]


class _Engine:
    """Records what the session does with begin/update/end_result and reports."""
    resolution_x = resolution_y = 24

    def __init__(self, break_after=None):
        self.break_after = break_after
        self.session = None
        self.results, self.ended, self.reports, self.stats = [], [], [], []

    def begin_result(self, x, y, w, h, layer="", view=""):
        self.results.append(_Result(min(w, self.resolution_x), min(h, self.resolution_y)))
        return self.results[-1]

    def update_result(self, result):
        result.merged = result.rect.data.copy()

    def end_result(self, result, cancel=False, highlight=False, do_merge_results=False):
        self.ended.append(result)

    def test_break(self):
        r = self.session.renderer
        return self.break_after is not None and r is not None and r.passes_done >= self.break_after

    def update_progress(self, f):
        assert 0.0 <= f <= 1.0

    def update_stats(self, stats, info):
        self.stats.append(info)

    def report(self, kind, message):
        self.reports.append((set(kind), message))


@pytest.fixture
def fake_render(bpy, pocl_key, monkeypatch):
    """fake_render(engine, export=..., passes=...) runs Session.render on a procedural scene."""
    from ppm_engine.blender import session as session_mod
    from ppm_engine.oracle.procedural import cornell_box

    def run(engine, export=None, passes=4):
        export = export or (lambda depsgraph, engine=None: cornell_box(24, 24))
        monkeypatch.setitem(sys.modules, "ppm_engine.blender.export",
                            types.SimpleNamespace(export_scene=export))
        settings = types.SimpleNamespace(passes=passes, time_limit=0.0, photons_per_pass=4096,
                                         auto_photons=False, noise_threshold=0.0,
                                         initial_radius=0.0, alpha=0.7, max_bounces=8, seed=0,
                                         indirect="AUTO", light_tracing=True, path_filter=True,
                                         specialize=True,
                                         device=pocl_key, devices="")
        depsgraph = types.SimpleNamespace(
            view_layer=types.SimpleNamespace(name="ViewLayer"),
            scene=types.SimpleNamespace(ppm=settings,
                                        render=types.SimpleNamespace(use_persistent_data=False)))
        engine.session = session_mod.Session()
        engine.session.render(engine, depsgraph)
        return engine
    return run


def _renderer_mean(pocl_key, passes):
    """The mean RGB of the fake_render scene after ``passes`` passes, by the Renderer alone."""
    from ppm_engine.oracle.procedural import cornell_box
    from ppm_engine.render.options import RenderOptions
    from ppm_engine.render.renderer import Renderer
    r = Renderer(cornell_box(24, 24), RenderOptions(photons_per_pass=4096, max_bounces=8,
                                                    seed=0, device=pocl_key))
    for _ in range(passes):
        r.iterate()
    mean = float(r.image()[..., :3].mean())
    r.close()
    return mean


def _merged_mean(result):
    return float(result.merged.reshape(-1, 4)[:, :3].mean())


# the session's image against the Renderer's after as many passes: the same estimator and seed,
# only the photon slots differ (the photon pass's atomics): <= 1.5 % apart in mean at 24 x 24,
# while the images after 1, 2 and 3 passes are 5 % and 11 % apart (the radius' bias shrinks)
SAME_IMAGE = 0.03


def test_session_writes_every_pass_and_ends_the_result(fake_render, pocl_key):
    e = fake_render(_Engine(), passes=3)
    assert len(e.results) == 1 and e.ended == e.results and not e.reports
    merged = e.results[0].merged
    assert merged is not None and np.isfinite(merged).all()
    assert _merged_mean(e.results[0]) == pytest.approx(_renderer_mean(pocl_key, 3), rel=SAME_IMAGE)
    assert any("Pass 3/3" in s for s in e.stats)
    assert e.session.renderer is None             # device buffers released


def test_cancelled_render_keeps_its_image(fake_render, pocl_key):
    e = fake_render(_Engine(break_after=2), passes=50)
    assert not e.reports and e.ended == e.results
    assert e.results[0].merged is not None        # the two passes done: their image
    assert _merged_mean(e.results[0]) == pytest.approx(_renderer_mean(pocl_key, 2), rel=SAME_IMAGE)
    assert any("Cancelled after pass 2" in s for s in e.stats)


def test_scene_error_is_reported_and_a_result_still_ends(fake_render):
    def export(depsgraph, engine=None):
        raise SceneError("the scene has no camera: add one")
    e = fake_render(_Engine(), export=export)
    assert e.reports == [({"ERROR"}, "the scene has no camera: add one")]
    assert len(e.results) == 1 and e.ended == e.results


def test_internal_error_keeps_rendered_passes(fake_render, monkeypatch, capsys, pocl_key):
    from ppm_engine.render.renderer import Renderer
    one_pass = _renderer_mean(pocl_key, 1)
    real = Renderer.iterate

    def iterate(self):
        if self.passes_done >= 1:
            raise ZeroDivisionError("boom")
        return real(self)
    monkeypatch.setattr(Renderer, "iterate", iterate)
    e = fake_render(_Engine(), passes=5)
    (kind, message), = e.reports
    assert kind == {"ERROR"} and "internal error" in message and "boom" in message
    assert e.ended == e.results                   # the pass before the error: its image
    assert _merged_mean(e.results[0]) == pytest.approx(one_pass, rel=SAME_IMAGE)
    assert "Traceback" in capsys.readouterr().err
