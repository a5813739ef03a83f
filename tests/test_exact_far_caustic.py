"""far_caustic's exact-geometry reference (ppm_engine/tools/bench/exact_caustic.py): the geometry
read from the bpy scene (the bigger ball, the farther light) rather than point_caustic's
constants, what it refuses, a ray through the centre of the 0.5 m ball against a hand
computation, the stratified emission's cone about that ball, and the focus landing in the
image, inside the bench's caustic pixels."""
import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from ppm_engine.blender.scenes.caustics import (
    BALL,
    FAR_BALL,
    FAR_POS,
    FLOOR,
    LIFTED_BALL,
    far_caustic,
    lifted_caustic,
    point_caustic,
)
from ppm_engine.tools.bench import exact_caustic as ec
from ppm_engine.tools.bench import exact_caustic_camera as ecc
from ppm_engine.tools.bench import exact_caustic_scene as ecs
from ppm_engine.tools.bench import exact_film as ef
from ppm_engine.tools.bench.scenes import CAUSTIC_MASKS, caustic_mask
from tests.helpers.blender_scenes import square


def _scene(build=far_caustic, width=16):
    return square(build(), width)


def test_setup_reads_the_ball_and_the_light_from_the_scene():
    """far_caustic's Setup has its ball (centre, radius: caustics.FAR_BALL exactly, though bpy
    keeps float32) and its light 3.5 m from the ball's centre, whose ball subtends 0.5 % of
    the light's sphere of directions; point_caustic's Setup still has caustics.BALL exactly."""
    s = ecs.setup_of(_scene())
    assert np.array_equal(s.ball_center, FAR_BALL[0]) and s.ball_radius == FAR_BALL[1] == 0.5
    assert s.ball[1] == 0.5 and s.ball[0] is s.ball_center
    np.testing.assert_allclose(s.light, FAR_POS, atol=1e-6)
    dist = np.linalg.norm(s.light - s.ball_center)
    assert dist == pytest.approx(3.5, abs=0.005)
    share = (1.0 - np.sqrt(1.0 - (s.ball_radius / dist) ** 2)) / 2.0
    assert share == pytest.approx(0.0051, abs=0.0002)
    p = ecs.setup_of(_scene(point_caustic))
    assert np.array_equal(p.ball_center, BALL[0]) and p.ball_radius == BALL[1]


def test_setup_refuses_what_the_reference_does_not_model():
    """A light on the stage's side of x = -2 (the stratified emission sends photons into x > 0
    only), a ball that is no sphere (scaled along one axis) or sunk into the floor, a light of
    non-zero radius: refused.  A light moved elsewhere the reference models is read as it is."""
    scene = _scene()
    light, ball = bpy.data.objects["Point"], bpy.data.objects["GlassBall"]

    def setup():
        bpy.context.view_layer.update()
        return ecs.setup_of(scene)
    light.location = (-2.5, 0.5, 2.0)
    np.testing.assert_allclose(setup().light, (-2.5, 0.5, 2.0), atol=1e-6)
    light.location = (-1.0, 0.0, 2.3)
    with pytest.raises(ValueError, match="x <= -2"):
        setup()
    light.location = FAR_POS
    ball.scale = (1.0, 1.0, 1.2)
    with pytest.raises(ValueError, match="sphere"):
        setup()
    ball.scale = (1.0, 1.0, 1.0)
    ball.location = (0.0, 0.0, 0.3)
    with pytest.raises(ValueError, match="rest on or above the floor"):
        setup()
    ball.location = FAR_BALL[0]
    assert setup().ball_radius == 0.5
    light.data.shadow_soft_size = 0.1
    with pytest.raises(ValueError, match="radius 0"):
        setup()


def test_ray_through_the_centre_of_the_far_ball_is_the_hand_computation():
    """As point_caustic's (tests/test_exact_caustic_camera.py), for the 0.5 m ball: the camera
    ray through its centre meets it head-on, 0.96^2 through it and 0.04^2 again per return
    trip along the line (normal incidence: the radius does not enter), then the floor point
    behind it, lit by the light 3.5 m away, computed here by hand."""
    s = ecs.setup_of(_scene())
    c = np.asarray(FAR_BALL[0], float)
    px, py, *_ = ef.project(s, c[None])
    det, (_, _, ew), _ = ecc.chains(s, px, py, ecc.Textures(s, 10), np.random.default_rng(0))
    u = (c - s.eye) / np.linalg.norm(c - s.eye)
    x = s.eye + (-s.eye[2] / u[2]) * u                 # the floor (z = 0) behind the ball
    assert abs(x[0]) < 2 and abs(x[1]) < 2
    to_l = s.light - x
    # the segment to the light passes the ball: lit
    a = np.clip(np.dot(c - x, to_l) / np.dot(to_l, to_l), 0.0, 1.0)
    assert np.linalg.norm(x + a * to_l - c) > FAR_BALL[1]
    e = to_l[2] / np.linalg.norm(to_l) / (4 * np.pi * np.dot(to_l, to_l))
    through = sum(0.04 ** k for k in range(0, 11, 2))
    assert det[0] == pytest.approx(FLOOR[0] / np.pi * e * 0.96 ** 2 * through, rel=1e-6)
    assert ew.sum() == pytest.approx(FLOOR[0] / np.pi * 0.96 ** 2 * through, rel=1e-6)


def test_stratified_emission_s_cone_is_the_far_ball():
    """The cone of the stratified emission is the 0.5 m ball's from 3.5 m: every cone photon
    meets the ball (but a few grazing its rim) and no other does, and the flux that meets it
    is the same stratified as sent uniformly over every direction (1 / (4 pi) W/sr per watt
    over the cone: 0.51 % of the light's power)."""
    s = ecs.setup_of(_scene())
    rng = np.random.default_rng(4)
    n = 1 << 19
    want = (1.0 - np.sqrt(1.0 - (0.5 / np.linalg.norm(s.light - s.ball_center)) ** 2)) / 2.0
    for stratified in (True, False):
        o, d, w = ec.emit(s, n, rng, stratified)
        no = np.zeros(n, bool)
        _, hit = ecs.first_hit(o, d, no, no, s.ball)
        ball = hit == ecs.BALL_ID
        if stratified:
            cone = np.arange(n) < round(ec.BALL_SHARE * n)
            assert ball[cone].mean() > 1 - 1e-4 and not ball[~cone & (w > 0)].any()
            assert w[ball].sum() / n == pytest.approx(want, rel=1e-4)
        else:
            # binomial: 0.0051 of 2^19 photons, 1.9 % noise
            assert w[ball].sum() / n == pytest.approx(want, rel=0.08)


def test_focus_lands_in_the_image_and_in_the_caustic_pixels():
    """The reference renders every pixel; its brightest is the caustic's focus on the floor,
    where the ray from the light through the ball's centre meets it (x = 0.83: the bench's
    caustic disk's centre), well inside the frame and among the caustic pixels; the image is
    exposed as point_caustic's (mean about 0.6)."""
    scene = _scene(width=32)
    s = ecs.setup_of(scene)
    img, cover, info = ec.render(scene, photons=1 << 18, seed=2, ball_grid=8)
    y = img[..., 0]
    assert cover.all() and np.isfinite(img).all() and info["ball_points"] > 0
    assert 0.4 < y.mean() < 0.8
    j, i = np.unravel_index(np.argmax(y), y.shape)
    centre = np.asarray(CAUSTIC_MASKS["far_caustic"]["center"])
    assert centre == pytest.approx([0.8333, 0.0, 0.0], abs=1e-3)
    px, py, *_ = ef.project(s, centre[None])
    assert 4 < px[0] < 28 and 4 < py[0] < 28
    assert abs(i + 0.5 - px[0]) <= 2 and abs(j + 0.5 - py[0]) <= 2
    assert y[j, i] > 5 * y.mean()
    assert caustic_mask(scene, "far_caustic", 32, 32)[j, i]


def test_lifted_caustic_is_far_caustic_with_the_ball_off_the_floor():
    """lifted_caustic (the bench's point light through a ball where Cycles' MNEE converges):
    the reference reads its ball 0.1 m above the floor and the same light; the bench's caustic
    disk is centred where the ray from the light through the ball's centre meets the floor
    (x = 1.06), in the frame, beyond the ball's shadow on the camera's side."""
    scene = _scene(lifted_caustic, 32)
    s = ecs.setup_of(scene)
    assert np.array_equal(s.ball_center, LIFTED_BALL[0]) and s.ball_radius == 0.5
    assert s.ball_center[2] - s.ball_radius == pytest.approx(0.1)
    np.testing.assert_allclose(s.light, FAR_POS, atol=1e-6)
    centre = np.asarray(CAUSTIC_MASKS["lifted_caustic"]["center"])
    assert centre == pytest.approx([3.0 * 0.6 / 1.7, 0.0, 0.0], abs=1e-3)
    px, py, *_ = ef.project(s, centre[None])
    assert 4 < px[0] < 28 and 4 < py[0] < 28
    assert caustic_mask(scene, "lifted_caustic", 32, 32).sum() > 20

