"""Blender scene -> SceneArrays: each camera type (perspective and orthographic rays against
Blender's projection, the border, depth of field, the cameras refused), the Cycles film settings,
and the world colour with its fallbacks and the .npz round trip; the helpers are
tests/helpers/blender_scenes.py's."""
import math

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")
from mathutils import Vector

from ppm_engine.errors import SceneError
from ppm_engine.scene.arrays import (
    CAMERA_ORTHO,
    FILM_TRANSPARENT,
    FILM_TRANSPARENT_GLASS,
    FILTER_BLACKMAN_HARRIS,
    FILTER_BOX,
    FILTER_GAUSSIAN,
    SceneArrays,
)
from tests.helpers.blender_scenes import add_light, add_plane, export


# --- camera -------------------------------------------------------------------------------------
def _ray_dir(cam, px, py):
    c = cam[0]
    xc = (px / c["width"] - 0.5) * c["extent"][0] + c["shift"][0]
    yc = (py / c["height"] - 0.5) * c["extent"][1] + c["shift"][1]
    m = c["to_world"].astype(np.float64)
    return m[:, :3] @ np.array([xc, yc, -1.0]), m[:, 3]


@pytest.mark.parametrize("fit,shift,aspect,pct", [('AUTO', (0, 0), (1, 1), 100),
                                                  ('VERTICAL', (0.1, -0.2), (1, 1), 50),
                                                  ('HORIZONTAL', (0, 0.3), (2, 1), 100)])
def test_perspective_camera_matches_blender_projection(empty, fit, shift, aspect, pct):
    from bpy_extras.object_utils import world_to_camera_view
    scene = empty
    cam = scene.camera
    cam.location = (1, -6, 2)
    cam.rotation_euler = (math.radians(80), math.radians(5), math.radians(10))
    cam.data.lens, cam.data.sensor_fit = 42.0, fit
    cam.data.shift_x, cam.data.shift_y = shift
    scene.render.pixel_aspect_x, scene.render.pixel_aspect_y = aspect
    scene.render.resolution_percentage = pct
    s = export()
    W, H = s.camera["width"][0], s.camera["height"][0]
    assert (int(64 * pct / 100), int(48 * pct / 100)) == (W, H)
    rng = np.random.default_rng(0)
    for _ in range(20):
        p = Vector(rng.uniform(-2, 2, 3))
        ndc = world_to_camera_view(scene, cam, p)
        d, o = _ray_dir(s.camera, ndc.x * W, ndc.y * H)
        v = np.array(p) - o
        cosang = v @ d / np.linalg.norm(v) / np.linalg.norm(d)
        assert cosang == pytest.approx(1.0, abs=1e-6)


def test_ortho_camera_and_border(empty):
    scene = empty
    scene.camera.data.type = 'ORTHO'
    scene.camera.data.ortho_scale = 4.0
    scene.render.use_border = True
    scene.render.border_min_x, scene.render.border_max_x = 0.25, 0.8
    scene.render.border_min_y, scene.render.border_max_y = 0.1, 0.55
    s = export()
    c = s.camera[0]
    assert c["type"] == CAMERA_ORTHO
    np.testing.assert_allclose(c["extent"], (4.0, 3.0))
    assert tuple(c["region"]) == (16, 4, int(0.8 * 64) - 16, int(0.55 * 48) - 4)
    assert s.resolution == (c["region"][2], c["region"][3])


@pytest.mark.parametrize("kind, width, expect", [
    ("BLACKMAN_HARRIS", 2.0, (FILTER_BLACKMAN_HARRIS, 2.0)),
    ("GAUSSIAN", 0.8, (FILTER_GAUSSIAN, 0.8)),
    ("BOX", 3.0, (FILTER_BOX, 1.0)),        # Blender's Cycles: the box is one pixel wide
])
def test_film_settings_are_cycles_film(empty, kind, width, expect):
    """The pixel filter, film exposure and transparency come from the scene's Cycles film
    settings (not EEVEE's render.filter_size)."""
    scene = empty
    scene.render.filter_size = 0.25          # EEVEE's: not read
    scene.cycles.pixel_filter_type, scene.cycles.filter_width = kind, width
    scene.cycles.film_exposure = 1.7
    scene.render.film_transparent = True
    scene.cycles.film_transparent_glass = True
    scene.cycles.film_transparent_roughness = 0.25
    c = export().camera[0]
    assert (int(c["filter_type"]), float(c["filter_width"])) == pytest.approx(expect)
    assert c["exposure"] == pytest.approx(1.7)
    assert c["film_transparent"] == FILM_TRANSPARENT | FILM_TRANSPARENT_GLASS
    assert c["glass_roughness"] == pytest.approx(0.25)
    scene.cycles.film_transparent_glass = False
    assert export().camera[0]["film_transparent"] == FILM_TRANSPARENT
    scene.render.film_transparent = False
    assert export().camera[0]["film_transparent"] == 0


def test_film_settings_not_a_number_are_refused():
    """A film exposure or filter width that is not a number: a SceneError naming the setting."""
    from types import SimpleNamespace

    from ppm_engine.blender.export.camera import film_settings
    for name in ("film_exposure", "filter_width"):
        cycles = SimpleNamespace(**{name: float("nan")})
        with pytest.raises(SceneError, match=name.replace("_", " ")):
            film_settings(SimpleNamespace(cycles=cycles,
                                          render=SimpleNamespace(film_transparent=False)))


def test_film_settings_without_cycles_are_its_defaults():
    """Without the Cycles add-on (no scene.cycles): Cycles' defaults."""
    from types import SimpleNamespace

    from ppm_engine.blender.export.camera import film_settings
    f = film_settings(SimpleNamespace(render=SimpleNamespace(film_transparent=False)))
    assert f == dict(filter_type=FILTER_BLACKMAN_HARRIS, filter_width=1.5, film_transparent=0,
                     glass_roughness=pytest.approx(0.1), exposure=1.0)


def test_no_camera_is_a_scene_error(empty):
    e = bpy.data.objects.new("Empty", None)
    empty.collection.objects.link(e)
    empty.camera = e
    with pytest.raises(SceneError, match="not a camera"):
        export()


def test_world_colour_and_npz_round_trip(empty, tmp_path):
    w = bpy.data.worlds.new("W")
    bg = w.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.2, 0.4, 0.6, 1)
    bg.inputs["Strength"].default_value = 2.0
    empty.world = w
    add_plane()
    add_light('POINT')
    s = export()
    np.testing.assert_allclose(s.world, (0.4, 0.8, 1.2), rtol=1e-6)
    s.save(tmp_path / "s.npz")
    t = SceneArrays.load(tmp_path / "s.npz")
    for name in ("positions", "normals", "uvs", "material", "visibility", "materials", "lights",
                 "camera", "world"):
        assert np.array_equal(getattr(s, name), getattr(t, name))


def test_ortho_rays_match_blender_projection(empty):
    from bpy_extras.object_utils import world_to_camera_view
    scene = empty
    cam = scene.camera
    cam.data.type, cam.data.ortho_scale = 'ORTHO', 5.0
    cam.data.shift_x, cam.data.sensor_fit = 0.15, 'VERTICAL'
    cam.location, cam.rotation_euler = (0, -8, 1), (math.radians(85), 0, math.radians(-5))
    cam.scale = (1.5, 0.5, 2.0)                       # camera scale is ignored by rays
    s = export()
    c = s.camera[0]
    m = c["to_world"].astype(np.float64)
    np.testing.assert_allclose(np.linalg.norm(m[:, :3], axis=0), 1.0, rtol=1e-6)
    rng = np.random.default_rng(1)
    for _ in range(10):
        p = Vector(rng.uniform(-2, 2, 3))
        ndc = world_to_camera_view(scene, cam, p)
        xc = (ndc.x - 0.5) * c["extent"][0] + c["shift"][0]
        yc = (ndc.y - 0.5) * c["extent"][1] + c["shift"][1]
        local = m[:, :3].T @ (np.array(p) - m[:, 3])  # point in camera space
        np.testing.assert_allclose(local[:2], (xc, yc), atol=1e-5)


def test_depth_of_field(empty):
    cam = empty.camera
    cam.data.lens = 50.0
    dof = cam.data.dof
    dof.use_dof, dof.aperture_fstop = True, 2.0
    dof.aperture_blades, dof.aperture_rotation, dof.aperture_ratio = 6, 0.3, 1.5
    target = bpy.data.objects.new("Target", None)
    target.location = (1.0, 0.5, -5.0)                # camera at the origin looks down -Z
    empty.collection.objects.link(target)
    dof.focus_object = target
    c = export().camera[0]
    assert c["aperture_radius"] == pytest.approx(0.05 / 4)
    assert c["focus_distance"] == pytest.approx(5.0)
    assert c["aperture_blades"] == 6 and c["aperture_rotation"] == pytest.approx(0.3)
    assert c["aperture_ratio"] == pytest.approx(1.5)
    dof.focus_object, dof.focus_distance = None, 3.5
    cam.data.type = 'ORTHO'
    c = export().camera[0]
    assert c["aperture_radius"] == pytest.approx(0.25) and c["focus_distance"] == pytest.approx(3.5)


def test_panoramic_camera_and_empty_border_are_scene_errors(empty):
    empty.render.use_border = True
    empty.render.border_min_x = empty.render.border_max_x = 0.5
    with pytest.raises(SceneError, match="border"):
        export()
    empty.render.use_border = False
    empty.camera.data.type = 'PANO'
    with pytest.raises(SceneError, match="not supported"):
        export()


def test_world_fallbacks(empty):
    assert empty.world is None
    np.testing.assert_array_equal(export().world, 0)
    w = bpy.data.worlds.new("Odd")
    t = w.node_tree
    d = t.nodes.new("ShaderNodeBsdfDiffuse")
    t.links.new(d.outputs[0], t.nodes["World Output"].inputs["Surface"])
    w.color = (0.1, 0.2, 0.3)
    empty.world = w
    s = export()
    np.testing.assert_allclose(s.world, (0.1, 0.2, 0.3), rtol=1e-6)
    assert any("Odd" in m for m in s.warnings)
