"""Blender scene -> SceneArrays: each light type (point, spot, sun, area), their units, cones
and axes, colour temperature, unnormalized power and ray visibility.  export() and
add_light() are tests/helpers/blender_scenes.py's (test_export_materials.py,
test_export_geometry.py and test_export_camera.py use them too); the ``empty`` scene is
conftest.py's."""
import math

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from ppm_engine.scene.arrays import (
    LIGHT_AREA_ELLIPSE,
    LIGHT_AREA_RECT,
    LIGHT_FLAG_SOFT_FALLOFF,
    LIGHT_POINT,
    LIGHT_SPOT,
    LIGHT_SUN,
)
from tests.helpers.blender_scenes import add_light, export


# --- lights -------------------------------------------------------------------------------------
def test_point_light_cycles_units(empty):
    add_light('POINT', energy=100.0, color=(1, 0.5, 0.25), shadow_soft_size=0.2, exposure=1.0)
    L = export().lights
    assert L.shape == (1,) and L["type"][0] == LIGHT_POINT
    np.testing.assert_allclose(L["emit"][0], np.array([1, 0.5, 0.25]) * 200 / (4 * np.pi),
                               rtol=1e-6)
    assert L["radius"][0] == pytest.approx(0.2) and L["flags"][0] & LIGHT_FLAG_SOFT_FALLOFF
    np.testing.assert_allclose(L["position"][0], (0, 0, 3))


def test_spot_light_cone(empty):
    o = add_light('SPOT', energy=50.0, spot_size=math.radians(60), spot_blend=0.25)
    o.rotation_euler = (math.radians(90), 0, 0)            # points along +y
    L = export().lights[0]
    assert L["type"] == LIGHT_SPOT
    np.testing.assert_allclose(L["emit"], 50 / (4 * np.pi), rtol=1e-6)
    assert L["spot_cos_half"] == pytest.approx(math.cos(math.radians(30)))
    assert L["spot_smooth"] == pytest.approx((1 - math.cos(math.radians(30))) * 0.25)
    np.testing.assert_allclose(L["direction"], (0, 1, 0), atol=1e-6)
    assert L["spot_scale_z"] == pytest.approx(1.0)


def test_sun_light(empty):
    o = add_light('SUN', energy=3.0, angle=math.radians(2))
    o.rotation_euler = (math.radians(30), 0, 0)
    L = export().lights[0]
    assert L["type"] == LIGHT_SUN and L["radius"] == pytest.approx(math.radians(1))
    np.testing.assert_allclose(L["emit"], 3.0, rtol=1e-6)
    np.testing.assert_allclose(L["direction"],
                               (0, math.sin(math.radians(30)), -math.cos(math.radians(30))),
                               atol=1e-6)


@pytest.mark.parametrize("shape,sx,sy,area,kind", [
    ('SQUARE', 2.0, None, 4.0, LIGHT_AREA_RECT),
    ('RECTANGLE', 2.0, 1.0, 2.0, LIGHT_AREA_RECT),
    ('DISK', 2.0, None, math.pi, LIGHT_AREA_ELLIPSE),
    ('ELLIPSE', 2.0, 1.0, math.pi / 2, LIGHT_AREA_ELLIPSE)])
def test_area_light_radiance(empty, shape, sx, sy, area, kind):
    props = dict(energy=50.0, shape=shape, size=sx)
    if sy is not None:
        props["size_y"] = sy
    o = add_light('AREA', **props)
    o.scale = (1.0, 1.5, 1.0)                               # object scale enlarges the light
    L = export().lights[0]
    assert L["type"] == kind
    np.testing.assert_allclose(L["emit"], 50 / (np.pi * area * 1.5), rtol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(L["axis_y"]), (sy or sx) * 1.5, rtol=1e-6)
    np.testing.assert_allclose(L["direction"], (0, 0, -1), atol=1e-7)


def test_unnormalized_lights_keep_the_documented_meaning(empty):
    add_light('POINT', "P", energy=100.0, shadow_soft_size=0.5, normalize=False,
              use_soft_falloff=False)
    add_light('POINT', "P0", energy=100.0, shadow_soft_size=0.0, normalize=False)
    add_light('AREA', "A", energy=50.0, shape='RECTANGLE', size=2.0, size_y=1.0, normalize=False)
    lights = export().lights
    by_radius = {float(l["radius"]): l for l in lights if l["type"] == LIGHT_POINT}
    # sphere radiance L = P/pi (area not divided) <=> intensity I = L * pi r^2 = P r^2
    np.testing.assert_allclose(by_radius[0.5]["emit"], 100 * 0.25, rtol=1e-6)
    assert by_radius[0.5]["flags"] & LIGHT_FLAG_SOFT_FALLOFF == 0
    np.testing.assert_allclose(by_radius[0.0]["emit"], 100 / (4 * np.pi), rtol=1e-6)
    area = lights[lights["type"] == LIGHT_AREA_RECT][0]
    np.testing.assert_allclose(area["emit"], 50 / np.pi, rtol=1e-6)


def test_spot_axes_follow_the_scaled_frame(empty):
    o = add_light('SPOT', energy=10.0, loc=(1, 2, 3))
    o.scale = (2, 3, 4)
    L = export().lights[0]
    np.testing.assert_allclose(L["axis_x"], (2, 0, 0), atol=1e-6)
    np.testing.assert_allclose(L["axis_y"], (0, 3, 0), atol=1e-6)
    assert L["spot_scale_z"] == pytest.approx(0.25)
    np.testing.assert_allclose(L["direction"], (0, 0, -1), atol=1e-7)
    np.testing.assert_allclose(L["position"], (1, 2, 3), atol=1e-6)


def test_light_temperature_and_zero_strength(empty):
    o = add_light('POINT', "T", energy=40.0, use_temperature=True, temperature=3000.0)
    add_light('POINT', "Off", energy=0.0, loc=(5, 0, 0))
    lights = export().lights
    assert lights.shape == (2,)                      # zero-strength lights are still exported
    tc = np.array(o.data.temperature_color[:3])
    assert not np.allclose(tc, 1.0)                  # 3000 K is reddish
    np.testing.assert_allclose(lights[0]["emit"], 40 / (4 * np.pi) * tc, rtol=1e-5)
    np.testing.assert_allclose(lights[1]["emit"], 0.0)


def test_light_ray_visibility_flags(empty):
    """Blender makes lights invisible to camera rays by default (Cycles then does not show
    them); glossy and transmission rays see them unless turned off."""
    from ppm_engine.scene.arrays import LIGHT_HIDDEN_SHIFT, VIS_CAMERA, VIS_GLOSSY, VIS_TRANSMISSION
    add_light('POINT', "Default")
    o = add_light('AREA', "Shown", loc=(1, 0, 3))
    o.visible_camera, o.visible_glossy = True, False
    lights = export().lights
    hidden = {int(l["type"]): int(l["flags"]) >> LIGHT_HIDDEN_SHIFT for l in lights}
    assert hidden[LIGHT_POINT] == VIS_CAMERA
    assert hidden[LIGHT_AREA_RECT] == VIS_GLOSSY
    assert not any(h & VIS_TRANSMISSION for h in hidden.values())
