"""The viewport's Blender side: the view's camera from Blender's own matrices, the depsgraph
updates of real edits and what they change, the engine's view_update hand-off (ViewportDriver),
previews and the engine's flags.  The session itself: test_viewport.py."""
import types

import numpy as np
import pytest

from tests.helpers.viewport_scenes import PASSES, sphere_scene, view


# --- the view's camera -----------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["PERSP", "ORTHO"])
def test_camera_from_blender_s_projection_is_the_exported_camera(bpy, empty, kind):
    """What a 3D view looking through the camera gives view_draw (its projection and view
    matrices) makes exactly the camera record the final render's exporter makes: extent, shift,
    clipping, placement; also with a lens shift and an off-square region."""
    from ppm_engine.blender.export.camera import export_camera
    scene = empty
    cam = scene.camera
    cam.data.type = kind
    cam.data.lens, cam.data.ortho_scale = 35.0, 3.0
    cam.data.shift_x, cam.data.shift_y = 0.1, -0.05
    cam.data.clip_start, cam.data.clip_end = 0.2, 70.0
    cam.location = (1.0, -4.0, 2.0)
    cam.rotation_euler = (1.2, 0.1, 0.3)
    bpy.context.view_layer.update()
    want = export_camera(scene, bpy.context.evaluated_depsgraph_get())
    got = view(bpy, scene, 64, 48)
    for field in ("type", "width", "height", "region", "to_world", "extent", "shift", "clip",
                  "filter_width", "exposure"):
        np.testing.assert_allclose(got[field], want[field], rtol=2e-5, atol=2e-6,
                                   err_msg=field)


def test_reduced_levels_keep_the_view_and_the_divider_follows_cycles_start_pixels():
    from ppm_engine.render.viewport_session import divider_for
    from ppm_engine.scene.camera import make_camera, scaled_camera
    assert divider_for(1280, 720, 64) == 16          # 80 x 45: about 64^2 pixels
    assert divider_for(64, 48, 16) == 4
    assert divider_for(40, 30, 64) == 1
    cam = make_camera(width=1280, height=720, to_world=np.eye(4)[:3], extent=(1.0, 0.5625))
    small = scaled_camera(cam, 16)
    assert (small["width"][0], small["height"][0]) == (80, 45)
    assert tuple(small["region"][0]) == (0, 0, 80, 45)
    assert np.array_equal(small["extent"], cam["extent"])


# --- depsgraph updates -> what changed ----------------------------------------------------------
def test_depsgraph_updates_of_real_edits(bpy, tiny):
    """The view_update classification on the updates Blender reports for each edit (captured
    with a depsgraph_update_post handler, the same ViewLayer depsgraph's updates)."""
    from ppm_engine.blender.viewport import changes
    scene = sphere_scene(bpy, tiny)
    seen = []

    def handler(_scene, depsgraph):
        seen.append(changes(depsgraph.updates))
    bpy.app.handlers.depsgraph_update_post.append(handler)
    try:
        def edit(f):
            seen.clear()
            f()
            bpy.context.view_layer.update()
            return set().union(*seen) if seen else set()
        ball = bpy.data.objects["Ball"]
        bsdf = bpy.data.materials["Ball"].node_tree.nodes["Principled BSDF"]
        assert edit(lambda: setattr(bsdf.inputs["Base Color"], "default_value",
                                    (0.1, 0.2, 0.8, 1.0))) == {"values"}
        assert edit(lambda: setattr(bsdf.inputs["Roughness"], "default_value", 0.1)) \
            == {"values"}
        assert edit(lambda: setattr(ball, "location", (0.3, 0.0, 0.6))) == {"transform"}
        assert edit(lambda: setattr(bpy.data.lights["Lamp"], "energy", 400.0)) == {"values"}
        assert edit(lambda: setattr(bpy.data.objects["Lamp"], "location", (1, -1, 3))) \
            == {"values"}
        bg = scene.world.node_tree.nodes["Background"]
        assert edit(lambda: setattr(bg.inputs["Strength"], "default_value", 2.0)) == {"values"}
        assert "geometry" in edit(lambda: bpy.ops.mesh.primitive_cube_add(size=0.3))
        assert "geometry" in edit(lambda: bpy.data.objects.remove(bpy.data.objects["Cube"]))
        assert edit(lambda: setattr(scene.camera, "location", (0, -6, 2))) == set()  # view_draw
        # a lens or depth-of-field change: view_draw's camera too (camera space is read when
        # the programs run), the camera-only path, no export
        assert edit(lambda: setattr(scene.camera.data, "lens", 35.0)) == set()
        assert edit(lambda: setattr(scene.camera.data.dof, "aperture_fstop", 2.0)) == set()
    finally:
        bpy.app.handlers.depsgraph_update_post.remove(handler)


# --- the engine's hand-offs -----------------------------------------------------------------
def test_previews_render_few_passes_with_the_viewport_s_kernels():
    from ppm_engine.blender.session import PREVIEW_ICON_PASSES, PREVIEW_PASSES, preview_options
    from ppm_engine.render.options import RenderOptions
    o = RenderOptions(passes=64)
    assert preview_options(o, 96, 96).passes == PREVIEW_ICON_PASSES
    assert preview_options(o, 200, 200).passes == PREVIEW_PASSES
    assert preview_options(o, 200, 200).editable is True
    assert preview_options(RenderOptions(passes=2), 32, 32).passes == 2


def test_engine_flags_for_the_viewport_and_previews(bpy):
    from ppm_engine.blender.engine import PPMRenderEngine
    assert PPMRenderEngine.bl_use_preview is True
    assert PPMRenderEngine.bl_use_eevee_viewport is True        # Material Preview stays EEVEE
    assert PPMRenderEngine.bl_use_shading_nodes_custom is False
    assert callable(PPMRenderEngine.view_update) and callable(PPMRenderEngine.view_draw)


def test_the_render_pass_of_a_3d_view_offers_the_final_render_s_passes(bpy):
    """The shading popover's Render Pass under this engine (as Cycles' View3DShading.cycles
    .render_pass): Combined and every pass a final render writes, read from a real 3D view."""
    from ppm_engine.blender.session import NOISY_PASS, RENDER_PASSES
    from ppm_engine.blender.ui import PPM_VIEW3D_PT_shading_render_pass as panel
    from ppm_engine.blender.viewport_draw import display_pass
    from ppm_engine.render.viewport_frame import DISPLAY_PASSES
    assert set(DISPLAY_PASSES) == {name for name, *_ in (*RENDER_PASSES, NOISY_PASS)}
    space = next(sp for screen in bpy.data.screens for area in screen.areas
                 for sp in area.spaces if sp.type == 'VIEW_3D')
    items = space.shading.ppm.bl_rna.properties["render_pass"].enum_items
    assert [i.name for i in items] == list(DISPLAY_PASSES)
    assert space.shading.ppm.render_pass == 'COMBINED'
    assert display_pass(types.SimpleNamespace(space_data=space)) == "Combined"
    for item in items:
        space.shading.ppm.render_pass = item.identifier
        assert display_pass(types.SimpleNamespace(space_data=space)) == item.name
    space.shading.ppm.render_pass = 'COMBINED'
    assert display_pass(types.SimpleNamespace(space_data=None)) == "Combined"   # no 3D view
    assert (panel.bl_parent_id, panel.bl_region_type) == ('VIEW3D_PT_shading', 'HEADER')
    assert hasattr(bpy.types, "PPM_VIEW3D_PT_shading_render_pass")          # registered

    def poll(engine, kind):
        ctx = types.SimpleNamespace(engine=engine, space_data=types.SimpleNamespace(
            shading=types.SimpleNamespace(type=kind)))
        return panel.poll(ctx)
    assert poll("PPM", 'RENDERED') and not poll("PPM", 'SOLID') and not poll("CYCLES", 'RENDERED')


def test_view_update_exports_on_edits_only_and_says_what_is_wrong(bpy, tiny, capsys):
    """The engine's view_update hand-off (ViewportDriver) on the real depsgraph updates of
    edits (a depsgraph_update_post handler stands in for Blender's call; without a 3D view the
    scene camera renders).  The header's text and the reports are recorded (redraws are
    test_viewport_draw.py's)."""
    from ppm_engine.blender.viewport import EXPORT_HINT, ViewportDriver
    scene = sphere_scene(bpy, tiny)
    header, reports = [], []

    class Engine:
        def update_stats(self, _stats, info):
            header.append(info)

        def report(self, kind, message):
            reports.append((set(kind), message))

        def tag_redraw(self):
            pass

    drv, eng = ViewportDriver(), Engine()

    def handler(_scene, depsgraph):
        drv.view_update(eng, bpy.context, depsgraph)
    try:
        drv.view_update(eng, bpy.context, bpy.context.evaluated_depsgraph_get())
        s = drv.session
        assert drv.exports == 1 and s.wait(timeout=300), s.status()
        bpy.app.handlers.depsgraph_update_post.append(handler)

        def edit(f):
            f()
            bpy.context.view_layer.update()
            assert s.wait(timeout=300), s.status()

        def setting(f):
            """A Python-defined setting (ours, Cycles'): bpy headless reports no depsgraph
            update for it, so view_update is called as Blender calls it on a redraw."""
            f()
            drv.view_update(eng, bpy.context, bpy.context.evaluated_depsgraph_get())
            assert s.wait(timeout=300), s.status()
        edit(lambda: bpy.data.objects["Ball"].select_set(True))       # a selection: nothing
        assert drv.exports == 1 and s.actions == ["new"]
        setting(lambda: setattr(scene.ppm, "viewport_passes", PASSES + 1))   # more: go on
        assert drv.exports == 1 and s.actions == ["new"] and s.frame().passes == PASSES + 1
        bsdf = bpy.data.materials["Ball"].node_tree.nodes["Principled BSDF"]
        edit(lambda: setattr(bsdf.inputs["Base Color"], "default_value", (0.9, 0.1, 0.1, 1)))
        assert drv.exports == 2 and s.actions == ["new", "upload"]
        setting(lambda: setattr(scene.cycles, "film_exposure", 2.0))   # the film: re-export
        assert drv.exports == 3 and s.actions[-1] == "upload"
        # without a 3D view the scene camera renders: its lens is exported and rendered
        edit(lambda: setattr(scene.camera.data, "lens", 35.0))
        assert drv.exports == 4 and s.actions[-1] == "upload"
        from ppm_engine.blender.export import export_scene
        fresh = export_scene(bpy.context.evaluated_depsgraph_get()).camera
        assert s._scene.camera.tobytes() == fresh.tobytes()
        assert not header                                             # no error so far
        cam = scene.camera
        edit(lambda: bpy.data.objects.remove(cam))                     # no camera, no 3D view
        assert drv.message is not None and "camera" in drv.message
        assert header[-1].startswith("Progressive Photon Mapping: ") and "camera" in header[-1]
        assert header[-1].endswith(EXPORT_HINT)                       # and what to do
        assert len(reports) == 1 and reports[0][0] == {'ERROR'} and "camera" in reports[0][1]
        assert drv.message in capsys.readouterr().err                 # in the console
        assert s.frame() is not None                                  # the last image stays
        new_cam = bpy.data.objects.new("Camera2", bpy.data.cameras.new("Camera2"))
        new_cam.location, new_cam.rotation_euler = (0.0, -3.6, 1.4), (np.radians(78), 0, 0)
        scene.collection.objects.link(new_cam)
        edit(lambda: setattr(scene, "camera", new_cam))               # fixed: renders again
        assert drv.message is None and drv.exports == 5 and s.error is None
        bad = view(bpy, scene)
        bad["to_world"][0, 0, 0] = np.nan                             # the worker fails...
        s.update_view(bad)
        s.wait(timeout=60)
        assert s.error is not None and not s.busy
        drv.view_update(eng, bpy.context, bpy.context.evaluated_depsgraph_get())
        assert drv.session is not s and drv.exports == 6              # ...and starts afresh
        assert drv.session.wait(timeout=300) and drv.session.error is None
        assert drv.session.frame() is not None
    finally:
        if handler in bpy.app.handlers.depsgraph_update_post:
            bpy.app.handlers.depsgraph_update_post.remove(handler)
        drv.close()
    assert drv.session is None


def _same_arrays(a, b) -> None:
    import dataclasses
    for f in dataclasses.fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, np.ndarray):
            assert np.array_equal(x, y), f.name
        elif f.name != "warnings":
            assert x == y, f.name


def test_value_edits_read_no_mesh_again_and_export_as_afresh(bpy, tiny, monkeypatch):
    """The driver keeps the mesh data across exports: a material colour, a light, a transform
    read no mesh again; a mesh's own edit reads that mesh only; an added object reads them
    all.  Every export equals a fresh one (same arrays: the same image)."""
    from ppm_engine.blender.export import export_scene, mesh
    from ppm_engine.blender.viewport import ViewportDriver
    sphere_scene(bpy, tiny)
    floor = bpy.data.objects["Floor"].data          # a NaN corner: a warning from the mesh
    pos = np.zeros(3 * len(floor.vertices), np.float32)
    floor.attributes["position"].data.foreach_get("vector", pos)
    pos[0] = np.nan
    floor.attributes["position"].data.foreach_set("vector", pos)
    bpy.context.view_layer.update()
    reads, reports = [], []
    read_mesh = mesh.read_mesh
    monkeypatch.setattr(mesh, "read_mesh", lambda m: reads.append(m.name) or read_mesh(m))

    class Engine:
        def update_stats(self, _stats, info):
            pass

        def report(self, kind, message):
            reports.append(message)

        def tag_redraw(self):
            pass

    drv, eng = ViewportDriver(), Engine()
    sent = []

    def handler(_scene, depsgraph):
        drv.view_update(eng, bpy.context, depsgraph)
    try:
        drv.view_update(eng, bpy.context, bpy.context.evaluated_depsgraph_get())
        s = drv.session
        assert s.wait(timeout=300), s.status()            # the first scene applied
        real = s.update_scene
        monkeypatch.setattr(s, "update_scene", lambda a: sent.append(a) or real(a))
        assert sorted(reads) == ["Plane", "Sphere"]
        bpy.app.handlers.depsgraph_update_post.append(handler)

        def edit(f, action):
            reads.clear()
            reports.clear()
            f()
            bpy.context.view_layer.update()
            assert s.wait(timeout=300), s.status()
            assert s.actions[-1] == action
            # the floor's warning at every export, once, though its mesh data was kept
            said = [w for w in sent[-1].warnings if "Floor" in w and "NaN" in w]
            assert len(said) == 1 and [m for m in reports if "Floor" in m] == said
            got = list(reads)
            reads.clear()
            _same_arrays(sent[-1], export_scene(bpy.context.evaluated_depsgraph_get()))
            return got
        bsdf = bpy.data.materials["Ball"].node_tree.nodes["Principled BSDF"]
        assert edit(lambda: setattr(bsdf.inputs["Base Color"], "default_value",
                                    (0.9, 0.1, 0.1, 1)), "upload") == []
        assert edit(lambda: setattr(bpy.data.lights["Lamp"], "energy", 300.0), "upload") == []
        ball = bpy.data.objects["Ball"]
        assert edit(lambda: setattr(ball, "location", (0.3, 0.0, 0.6)), "refit") == []

        def deform():
            ball.data.vertices[0].co.z += 0.05
            ball.data.update()
        assert edit(deform, "refit") == ["Sphere"]                  # that mesh only
        assert sorted(edit(lambda: bpy.ops.mesh.primitive_cube_add(size=0.3,
                                                                   location=(1, 0, 0.15)),
                           "rebuild")) == ["Cube", "Plane", "Sphere"]   # added: afresh
        assert drv.exports == 6
    finally:
        if handler in bpy.app.handlers.depsgraph_update_post:
            bpy.app.handlers.depsgraph_update_post.remove(handler)
        drv.close()


def test_decoded_images_are_kept_until_an_image_changes(bpy, tiny, monkeypatch):
    """Exports with the driver's kept images read an image once; an edit of the image
    (its colour space) drops it, a material edit does not; the arrays equal a fresh export's."""
    from ppm_engine.blender.export import export_scene
    from ppm_engine.blender.export.mesh_cache import MeshCache, forget_changed
    from ppm_engine.blender.export.textures import TextureTable
    from ppm_engine.blender.viewport import _VALUE_TYPES
    sphere_scene(bpy, tiny)
    img = bpy.data.images.new("Grid", 16, 16)
    img.generated_type = 'UV_GRID'
    nt = bpy.data.materials["Ball"].node_tree
    tex = nt.nodes.new("ShaderNodeTexImage")
    tex.image = img
    nt.links.new(tex.outputs["Color"], nt.nodes["Principled BSDF"].inputs["Base Color"])
    bpy.context.view_layer.update()
    reads = []
    read = TextureTable._read
    monkeypatch.setattr(TextureTable, "_read",
                        lambda self, image, *a: reads.append(image.name) or read(self, image, *a))
    meshes, images, seen = MeshCache(None), {}, []

    def handler(_scene, depsgraph):
        seen.append(depsgraph.updates)
        forget_changed(depsgraph.updates, meshes, images, _VALUE_TYPES)

    def export():
        dg = bpy.context.evaluated_depsgraph_get()
        got = export_scene(dg, meshes=meshes, images=images)
        n = len(reads)
        _same_arrays(got, export_scene(dg))
        del reads[n:]                                  # the fresh export's read
        return got
    bpy.app.handlers.depsgraph_update_post.append(handler)
    try:
        export()
        assert reads == ["Grid"]
        bsdf = nt.nodes["Principled BSDF"]
        bsdf.inputs["Roughness"].default_value = 0.2
        bpy.context.view_layer.update()
        export()
        assert reads == ["Grid"]                       # a material edit: not read again
        img.colorspace_settings.name = "Non-Color"
        bpy.context.view_layer.update()
        assert seen
        export()
        assert reads == ["Grid", "Grid"]               # the image edited: read again
        # what reading it warned (a colour space read as sRGB) is said by every export
        img.colorspace_settings.name = "Rec.2020"
        bpy.context.view_layer.update()
        for k in range(2):
            warned = [w for w in export().warnings if "Rec.2020" in w]
            assert len(warned) == 1 and reads == ["Grid"] * 3, (k, reads)   # read once
            bsdf.inputs["Roughness"].default_value = 0.3 + 0.1 * k
            bpy.context.view_layer.update()
    finally:
        bpy.app.handlers.depsgraph_update_post.remove(handler)
