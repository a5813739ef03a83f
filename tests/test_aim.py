"""Caustic photons aimed at the casters (kernels/light/aim.h, ppm_engine/scene/casters.py): the
same light arrives as from photons emitted as all are, for every kind of emitter; an emitter
with no caster in reach emits no caustic photon; a moved caster moves the aim with no build."""
import numpy as np
import pyopencl as cl
import pytest

from ppm_engine.oracle.procedural import MeshBuilder, look_at
from ppm_engine.render.counters import N_COUNTERS, Counter
from ppm_engine.render.renderer import Renderer
from ppm_engine.scene.arrays import (
    LIGHT_AREA_RECT,
    LIGHT_POINT,
    LIGHT_SPOT,
    LIGHT_SUN,
)
from ppm_engine.scene.camera import make_camera, perspective_extent
from ppm_engine.scene.casters import caster_spheres
from tests.helpers.procedural_scenes import light
from tests.helpers.renders import every_feature

BALL = (0.0, 0.0, 0.5)


def ball_scene(lights=None, world=(0, 0, 0), emissive=False, ball=BALL, W=16):
    """A white floor (4 x 4 m), a glass ball of radius 0.5 on it, seen from the front."""
    mb = MeshBuilder()
    white = mb.material("white", (0.7, 0.7, 0.7))
    mb.quad((-2, -2, 0), (4, 0, 0), (0, 4, 0), white)
    mb.sphere(ball, 0.5, mb.material("glass", (1, 1, 1), transmission=1.0, roughness=0.0), 24, 12)
    if emissive:      # a small two-sided emitter beside the ball
        mb.quad((-1.3, -0.2, 0.6), (0, 0.4, 0), (0, 0, 0.4),
                mb.material("lamp", (0, 0, 0), emission=(40.0, 40.0, 40.0)))
    ext = perspective_extent(W, W, 35.0, 36.0)
    cam = make_camera(width=W, height=W, to_world=look_at((0, -5, 3), (0, 0, 0.3)),
                      extent=ext[:2], clip=(0.1, 100))
    return mb.build(camera=cam, lights=lights, world=world)


EMITTERS = {
    "point": dict(lights=light(LIGHT_POINT, position=(-1.2, 0, 0.9), emit=(50, 50, 50))),
    "sphere": dict(lights=light(LIGHT_POINT, position=(-1.2, 0, 0.9), emit=(50, 50, 50),
                                radius=0.15)),
    # a spot whose cone takes in the ball and much more
    "spot": dict(lights=light(LIGHT_SPOT, position=(-1.2, 0, 0.9), emit=(50, 50, 50),
                              direction=(np.cos(0.4), 0.0, -np.sin(0.4)), axis_x=(0, 1, 0),
                              axis_y=(np.sin(0.4), 0, np.cos(0.4)), spot_scale_z=1.0,
                              spot_cos_half=np.cos(np.radians(50)), spot_smooth=0.05)),
    # a narrow spot on the ball's edge: its cone, the smaller, is sampled, where it meets the
    # ball's (uniform emission does as well there)
    "spot_edge": dict(lights=light(LIGHT_SPOT, position=(-1.2, 0, 0.9), emit=(50, 50, 50),
                                   direction=(np.cos(0.75), 0.0, -np.sin(0.75)),
                                   axis_x=(0, 1, 0), axis_y=(np.sin(0.75), 0, np.cos(0.75)),
                                   spot_scale_z=1.0, spot_cos_half=np.cos(np.radians(12)),
                                   spot_smooth=0.05)),
    "area": dict(lights=light(LIGHT_AREA_RECT, position=(0.2, 0, 1.6), emit=(20, 20, 20),
                              axis_x=(0.5, 0, 0), axis_y=(0, 0.5, 0))),
    "sun": dict(lights=light(LIGHT_SUN, emit=(3, 3, 3), direction=(0.3, 0.1, -0.95),
                             radius=0.01)),
    "world": dict(world=(0.5, 0.5, 0.5)),
    "mesh": dict(emissive=True),
}


def caustic_flux(scene, aimed: bool, passes: int, photons: int, seed=0):
    """Per pass: the flux of the caustic photons stored on the floor per emitted photon, in the
    floor's halves x < 0 and x >= 0 (photons outside the camera's view stored too), and the
    Renderer's last stats."""
    r = Renderer(scene, every_feature(seed=seed, indirect="paths", light_tracing=False,
                                      skip_unseen_photons=False, photons_per_pass=photons,
                                      skip_unaimed_caustics=aimed))
    out = []
    for _ in range(passes):
        st = r.iterate()
        n = st.photons_stored
        pos, flux = np.empty((max(n, 1), 4), np.float32), np.empty((max(n, 1), 4), np.float32)
        cl.enqueue_copy(r.queue, pos, r.photon_map.ph_pos)
        cl.enqueue_copy(r.queue, flux, r.photon_map.ph_flux)
        pos, flux = pos[:n], flux[:n]
        floor = np.abs(pos[:, 2]) < 1e-3
        half = (pos[:, 0] >= 0).astype(int)
        out.append(np.bincount(half[floor], flux[floor, :3].mean(axis=1), minlength=2)
                   / r.photon_count)
    r.close()
    return np.array(out), st


@pytest.mark.parametrize("kind", sorted(EMITTERS))
def test_aimed_photons_bring_the_light_emission_as_all_photons_brings(kind):
    scene = ball_scene(**EMITTERS[kind])
    aimed, st_a = caustic_flux(scene, True, 10, 1 << 15)     # aims 1/16 of them
    plain, st_p = caustic_flux(scene, False, 10, 1 << 15)
    ma, mp = aimed.mean(axis=0), plain.mean(axis=0)
    se = np.sqrt(aimed.var(axis=0, ddof=1) / aimed.shape[0]
                 + plain.var(axis=0, ddof=1) / plain.shape[0])
    assert mp.sum() > 0, "the ball makes no caustic on the floor"
    big = mp > 0.05 * mp.sum()       # the halves the caustic reaches
    assert big.any()
    # (se from 10 passes each: 5 of them allow for its own error)
    assert np.all(np.abs(ma - mp)[big] <= 5 * se[big]), (kind, ma, mp, se)
    if kind == "spot_edge":
        return
    # aiming: most caustic photons reach the ball, and far fewer without it
    assert st_a.caster_fraction > 0.3, st_a.caster_fraction
    assert st_a.caster_fraction > 3 * st_p.caster_fraction, (st_a.caster_fraction,
                                                             st_p.caster_fraction)
    # the noise per photon emitted (variance x photons): aimed ones far less noisy
    va = aimed.var(axis=0, ddof=1)[big].sum() * st_a.photons_emitted
    vp = plain.var(axis=0, ddof=1)[big].sum() * st_p.photons_emitted
    assert va < 0.3 * vp, (va, vp)


def test_an_emitter_with_no_caster_in_reach_emits_no_caustic_photon():
    # an area light facing away from the ball (it lights the floor beside it only)
    lamp = light(LIGHT_AREA_RECT, position=(1.5, 0, 1.0), emit=(20, 20, 20),
                 direction=(0.8, 0, -0.6), axis_x=(0.24, 0, 0.32), axis_y=(0, 0.3, 0))
    scene = ball_scene(lights=lamp)
    r = Renderer(scene, every_feature(indirect="paths", skip_unseen_photons=False,
                                      photons_per_pass=4096))
    assert r.casters == 1 and r.photons_needed
    assert r.scene.caster_reach.tolist() == [0.0]
    st = r.iterate()
    counters = np.empty(N_COUNTERS, np.uint32)
    cl.enqueue_copy(r.queue, counters, r.counters)
    assert counters[Counter.CASTER] == 0 and st.photons_stored == 0
    assert st.caster_fraction == 0.0
    assert r.image()[..., :3].max() > 0          # the floor is lit
    r.close()


def test_a_moved_caster_moves_the_aim_without_a_build(monkeypatch):
    from ppm_engine.scene import casters
    lamp = EMITTERS["point"]["lights"]
    r = Renderer(ball_scene(lights=lamp), every_feature(indirect="paths", photons_per_pass=4096))
    r.iterate()
    before = r.scene.caster_spheres.copy()
    builds = r.device.programs.builds
    moved = ball_scene(lights=lamp, ball=(0.4, 0.3, 0.5))
    splits = []
    split = casters._Corners.split
    monkeypatch.setattr(casters._Corners, "split", lambda *a: splits.append(1) or split(*a))
    assert r.refit(moved)
    r.reset(r.options, moved)
    st = r.iterate()
    after = r.scene.caster_spheres
    np.testing.assert_allclose(after[0, :3] - before[0, :3], (0.4, 0.3, 0.0), atol=1e-4)
    # the casters' tree of splits kept (a refit, as the BVH's): no split sorted again, the
    # spheres those of the moved triangles, as a fresh build's
    assert splits == []
    corners = moved.positions.reshape(-1, 3, 3)[moved.material == 1]
    monkeypatch.setattr(casters, "_SPHERES", {})
    fresh, _ = caster_spheres(corners, np.ones(corners.shape[0], np.float32))
    assert splits and np.array_equal(after, fresh)
    assert st.caster_fraction > 0.5
    assert r.device.programs.builds == builds, "moving the caster built a kernel"
    r.close()


def test_caster_spheres_split_apart_casters_and_keep_a_ball_whole():
    scene = ball_scene()
    corners = scene.positions.reshape(-1, 3, 3)[scene.material == 1] - np.array(BALL)
    s, w = caster_spheres(corners, np.ones(corners.shape[0], np.float32))
    assert s.shape == (1, 4) and abs(s[0, 3] - 0.5) < 0.01 and w.tolist() == [1.0]
    two = np.concatenate([corners, corners + np.array([5.0, 0, 0])])
    s, _ = caster_spheres(two, np.ones(two.shape[0], np.float32))
    assert s.shape[0] == 2 and np.all(s[:, 3] < 0.51)
    # nine balls on a grid: nine spheres (the tree's cuts at the gaps between them)
    grid = np.concatenate([corners + np.array([6.0 * i, 6.0 * j, 0]) for i in (-1, 0, 1)
                           for j in (-1, 0, 1)])
    s9, _ = caster_spheres(grid, np.ones(grid.shape[0], np.float32))
    assert s9.shape[0] == 9 and np.all(s9[:, 3] < 0.51)
    # every caster triangle's corners lie inside a sphere
    inside = np.linalg.norm(two.reshape(-1, 3)[:, None, :] - s[None, :, :3], axis=2) \
        <= s[None, :, 3]
    assert inside.any(axis=1).all()


def test_a_refitted_caster_tree_follows_moves_and_asks_a_build_when_stretched():
    from ppm_engine.scene.casters import CasterTree
    scene = ball_scene()
    ball = scene.positions.reshape(-1, 3, 3)[scene.material == 1]
    two = np.concatenate([ball, ball + np.array([5.0, 0, 0], np.float32)])
    w = np.ones(two.shape[0], np.float32)
    tree = CasterTree(two, w)
    assert tree.result[0].shape[0] == 2
    # one ball moved: the same cut, its sphere moved, as a fresh tree's
    moved = np.concatenate([ball, ball + np.array([5.0, 1.0, 0.5], np.float32)])
    refit = tree.refit(moved, w)
    assert refit is not None and np.array_equal(refit.result[0], CasterTree(moved, w).result[0])
    # the second ball's triangles scattered over both: its clusters stretched, build afresh
    mixed = moved.copy()
    mixed[ball.shape[0]::2] -= np.array([5.0, 1.0, 0.5], np.float32)
    assert tree.refit(mixed, w) is None
    assert tree.refit(moved, np.r_[w[:-1], 0.0].astype(np.float32)) is None   # other casters


def test_learned_weights_leave_a_caster_out_of_view_few_photons_and_the_image_unbiased():
    """Two glass balls, one in view and one behind the camera, whose caustic lands out of
    view: after a few passes the second gets few photons (its photons store nothing near
    what the camera sees), and the caustic in view is the one uniform photons bring."""
    mb = MeshBuilder()
    white = mb.material("white", (0.7, 0.7, 0.7))
    mb.quad((-2, -9, 0), (4, 0, 0), (0, 11, 0), white)
    glass = mb.material("glass", (1, 1, 1), transmission=1.0, roughness=0.0)
    mb.sphere(BALL, 0.5, glass, 24, 12)
    mb.sphere((0, -7.5, 0.5), 0.5, glass, 24, 12)
    cam = make_camera(width=16, height=16, to_world=look_at((0, -4.5, 2.5), (0, 0.5, 0.3)),
                      extent=perspective_extent(16, 16, 35.0, 36.0)[:2], clip=(0.1, 100))
    lamp = light(LIGHT_POINT, position=(0, -3.2, 1.6), emit=(100, 100, 100))
    scene = mb.build(camera=cam, lights=lamp)

    def run(aimed, photons):
        r = Renderer(scene, every_feature(indirect="paths", light_tracing=False, seed=1,
                                          photons_per_pass=photons,
                                          skip_unaimed_caustics=aimed))
        sums = []
        for _ in range(10):
            st = r.iterate()
            flux = np.empty((max(st.photons_stored, 1), 4), np.float32)
            cl.enqueue_copy(r.queue, flux, r.photon_map.ph_flux)
            sums.append(flux[:st.photons_stored, :3].sum() / r.photon_count)
        weights = r.scene.caster_weights.copy() if aimed else None
        spheres = r.scene.caster_spheres.copy()
        r.close()
        return np.array(sums), weights, spheres

    aimed, w, spheres = run(True, 1 << 16)                   # aims 1/16 of them
    plain, _, _ = run(False, 1 << 16)
    assert spheres.shape[0] == 2
    near = int(np.argmax(spheres[:, 1]))          # the ball in view (y = 0, not -7.5)
    assert w[near] == 1.0 and w[1 - near] < 0.1, w
    se = np.sqrt(aimed.var(ddof=1) / 10 + plain.var(ddof=1) / 10)
    assert abs(aimed.mean() - plain.mean()) <= 5 * se, (aimed.mean(), plain.mean(), se)
    # the in-view caustic from a sixteenth of the photons, less noisy
    assert aimed.std() < plain.std()


def test_the_stats_line_says_the_share_that_reaches_a_caster_and_the_bench_reads_it():
    from ppm_engine.tools.bench.scoring import stats_info
    r = Renderer(ball_scene(**EMITTERS["point"]), every_feature(indirect="paths"))
    st = r.iterate()
    r.close()
    # automatic: a sixteenth of the photons, at least AIMED_PHOTONS_MIN, nearly all on the ball
    assert st.photons_emitted == 1024 and st.caster_fraction > 0.95
    info = stats_info(st.line())
    assert info["indirect"] == "paths"
    assert abs(info["caster_fraction"] - st.caster_fraction) < 0.01
    assert "caster_fraction" not in stats_info("Pass 3 · 16.4K photons · r 0.1–0.2")
