"""Re-renders with Blender's persistent data: skip what did not change (export, BVH, programs)
and never reuse what did."""
import pytest


def test_persistent_data_reuses_only_what_did_not_change(bpy, example_blend, tiny, render_exr,
                                                         tmp_path):
    from ppm_engine.blender import session
    bpy.ops.wm.open_mainfile(filepath=str(example_blend("cornell_box")), load_ui=False)
    scene = bpy.context.scene
    tiny(scene, width=16, height=16, passes=4)
    scene.render.use_persistent_data = True
    log = session.renders
    log.clear()

    first = render_exr(tmp_path / "a.exr")
    again = render_exr(tmp_path / "b.exr")
    assert log[0] == {**log[0], "persistent": True, "exported": True, "bvh_built": True}
    assert log[1]["exported"] is False and log[1]["bvh_built"] is False       # nothing changed
    assert log[1]["passes"] == 4                                 # a new film, not 4 more passes
    assert again.mean() == pytest.approx(first.mean(), rel=0.03)               # the same image

    lamp = bpy.data.materials["Lamp"].node_tree.nodes["Emission"].inputs["Strength"]
    lamp.default_value *= 2                                                     # shading only
    brighter = render_exr(tmp_path / "c.exr")
    assert log[2]["exported"] is True and log[2]["bvh_built"] is False
    assert brighter.mean() == pytest.approx(2 * first.mean(), rel=0.02)        # not the old one

    scene.ppm.passes = 5                                   # our settings: no re-export at all
    render_exr(tmp_path / "d.exr")
    assert log[3]["exported"] is False and log[3]["bvh_built"] is False
    assert log[3]["passes"] == 5

    bpy.data.objects["TallBox"].location.x += 0.1          # moved: the same triangles, refitted
    moved = render_exr(tmp_path / "e.exr")
    assert log[4]["exported"] is True and log[4]["bvh_refit"] is True
    assert log[4]["bvh_built"] is False

    scene.render.use_persistent_data = False               # the same scene, built from scratch
    fresh = render_exr(tmp_path / "f.exr")
    assert log[5] == {**log[5], "persistent": False, "exported": True, "bvh_built": True}
    assert moved.mean() == pytest.approx(fresh.mean(), rel=0.03)

    scene.render.use_persistent_data = True
    render_exr(tmp_path / "g.exr")
    bpy.data.objects["TallBox"].location.x += 5.0          # far out of the box: refit too slow
    render_exr(tmp_path / "h.exr")
    assert log[7]["bvh_refit"] is False and log[7]["bvh_built"] is True
    bpy.ops.mesh.primitive_cube_add(size=0.2, location=(0, 0, 1))   # new triangles: rebuild
    render_exr(tmp_path / "i.exr")
    assert log[8]["bvh_built"] is True



def test_animation_with_persistent_data_refits_per_frame(bpy, example_blend, tiny, tmp_path):
    """render(animation=True) over frames where an object moves: every frame is rendered and
    written (Blender's '#' numbering), the BVH is built once and refitted for the others."""
    from ppm_engine.blender import session
    bpy.ops.wm.open_mainfile(filepath=str(example_blend("cornell_box")), load_ui=False)
    scene = bpy.context.scene
    tiny(scene, width=16, height=16, passes=2)
    box = bpy.data.objects["TallBox"]
    box.keyframe_insert("location", frame=1)
    box.location.x += 0.2
    box.keyframe_insert("location", frame=3)
    scene.frame_start, scene.frame_end = 1, 3
    scene.render.use_persistent_data = True
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = str(tmp_path / "frame_####")
    session.renders.clear()
    assert bpy.ops.render.render(animation=True) == {"FINISHED"}
    assert [(tmp_path / f"frame_{f:04d}.png").is_file() for f in (1, 2, 3)] == [True] * 3
    log = list(session.renders)
    assert len(log) == 3 and log[0]["bvh_built"] and not log[0]["bvh_refit"]
    assert all(entry["bvh_refit"] and not entry["bvh_built"] for entry in log[1:])
