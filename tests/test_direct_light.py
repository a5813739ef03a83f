"""The eye pass's direct light at chosen points against exact answers, through debug.cl's
kernels (no Blender needed): a lamp that must not shadow itself at grazing angles, the pick
among few emissive triangles (its frequencies and both pmfs), one sample's spread beside a lamp
and above a large emitter, a mesh light through a transparent surface and one that casts no
shadow.  Where the answer is a mean, the tolerance comes from the estimates' own spread (the
standard error over independent samples)."""
import numpy as np
import pytest

from ppm_engine.oracle.procedural import MeshBuilder, look_at
from ppm_engine.render.device import SHADING_GROUP
from ppm_engine.render.renderer import Renderer
from ppm_engine.scene.arrays import CAMERA_ORTHO, LIGHT_POINT
from ppm_engine.scene.camera import make_camera
from ppm_engine.scene.emitters import local_share
from tests.helpers.debug_kernels import emitter_picks
from tests.helpers.procedural_scenes import light
from tests.helpers.renders import every_feature


def direct_light(scene, pts, nrm, samples):
    """The eye pass's direct-light estimate (debug.cl direct_light_at: NEE + BSDF sample with MIS,
    averaged over ``samples``) at points pts with normals nrm, (n, 4) float32 each."""
    import pyopencl as cl
    r = Renderer(scene, every_feature(max_bounces=0))
    dev, n = r.device, len(pts)
    out = cl.Buffer(dev.context, cl.mem_flags.READ_WRITE, 16 * n)
    k = dev.programs.get("test/debug.cl").launch("direct_light_at", "test")
    k(dev.queue, n, SHADING_GROUP, **r.scene.args, points=dev.upload(pts, "p"),
      nrm=dev.upload(nrm, "n"), n_samples=np.int32(samples), out=out, n=np.uint32(n))
    got = np.empty((n, 4), np.float32)
    cl.enqueue_copy(dev.queue, got, out)
    r.close()
    return got


@pytest.mark.slow
def test_grazing_emitter_does_not_shadow_itself():
    """A ceiling point 2-65 cm beside a lamp hanging 1 cm below the ceiling sees the lamp's
    top at grazing angles; next-event estimation must not let the lamp shadow itself (the
    shadow ray is built from its offset origin).  Reference: quadrature over the lamp.  The
    ray offsets (~1e-4 of 1 cm) leave a bias of about 1 %, allowed for."""
    from ppm_engine.oracle.procedural import cornell_box
    ys = np.array([0.27, 0.3, 0.4, 0.6, 0.9])
    copies = 16                                   # independent estimates per point
    pts = np.array([[0.1, y, 2.0, 0] for y in np.repeat(ys, copies)], np.float32)
    nrm = np.tile(np.float32([0, 0, -1, 0]), (len(pts), 1))
    got = direct_light(cornell_box(8, 8), pts, nrm, 20000)
    est = got[:, 0].reshape(len(ys), copies)
    g = (np.arange(1000) + 0.5) / 1000 * 0.5 - 0.25
    X, Y = np.meshgrid(g, g)
    for y, e in zip(ys, est):
        v = np.stack([X - 0.1, Y - y, np.full_like(X, -0.01)], -1)
        d2 = (v ** 2).sum(-1)
        cos = 0.01 / np.sqrt(d2)
        ref = (15.0 * cos * cos / d2).sum() * (0.5 / 1000) ** 2
        se = e.std(ddof=1) / np.sqrt(copies)
        assert abs(e.mean() - ref) < 4 * se + 0.015 * ref, (y, e.mean(), ref, se)


def test_few_emissive_triangles_are_picked_by_their_light_at_the_point():
    """Next-event estimation among few emissive triangles (light_mesh.h pick_emitter_at): the
    local emitters (the point light, the triangles) take their share against the world
    (emitter_local_share: emitters.local_share), the group its power share
    among them; within it a triangle is picked with probability
    (1 - d) I_j / sum I + d g_j / sum g, I_j its unoccluded irradiance at the point (mean
    radiance times the integral of cos over it, negative below the horizon, clamped at 0), g_j
    its power, d = 1/4 (the power pick alone where no triangle lights the point, and beyond
    twice the triangles' bounding ball, where their light is in proportion to power).  Checked
    against the pick's frequencies over stratified numbers, the pmf it returns, the pmf the MIS
    of a ray that hits the triangle uses, and I_j by Monte Carlo over each triangle's area."""
    mb = MeshBuilder()
    grey = mb.material("grey", (0.5, 0.5, 0.5))
    les = (4.0, 9.0, 2.0)
    lamps = [mb.material(f"lamp{k}", (0, 0, 0), emission=(le,) * 3) for k, le in enumerate(les)]
    mb.quad((0, 0, 0), (3, 0, 0), (0, 3, 0), grey)
    tris = np.array([[[-1.0, -0.5, 1.0], [-0.2, -0.5, 1.1], [-0.6, 0.4, 0.9]],
                     [[0.3, 0.2, 0.4], [0.8, 0.1, 0.5], [0.5, 0.6, 0.45]],
                     [[-0.5, 1.0, -0.3], [0.5, 1.2, -0.2], [0.0, 1.5, 0.6]]])
    for t, m in zip(tris, lamps):
        mb.add(t[None], m)
    cam = make_camera(type=CAMERA_ORTHO, width=4, height=4,
                      to_world=look_at((0, 0, 5), (0, 0, 0), up=(0, 1, 0)), extent=(2, 2),
                      clip=(0.01, 100))
    pt = light(LIGHT_POINT, emit=(3.0,) * 3, position=(2, 2, 3))
    scene = mb.build(camera=cam, lights=pt, world=(0.2, 0.2, 0.2))
    pts = np.float32([[0, 0, 0, 0], [0.5, 0.3, 0.02, 0], [-0.3, 0.8, 0.01, 0], [0.6, 0.3, 0.7, 0],
                      [-0.6, -0.2, 1.3, 0], [2.9, -2.9, 0.0, 0]])
    nrm = np.float32([[0, 0, 1, 0], [0, 0, 1, 0], [0, 0.6, 0.8, 0], [0, 0, -1, 0], [0, 0, 1, 0],
                      [0, 0, 1, 0]])
    r = Renderer(scene, every_feature(max_bounces=0))
    n, n_u = len(pts), 200000
    em = r.scene.emitters
    m, first = int(em.info["n_emitters"][0]), int(em.info["n_lights"][0])
    assert (m, first, int(em.info["n_emissive"][0])) == (5, 1, 3)
    got = emitter_picks(r, pts, nrm, n_u)
    r.close()
    g = np.diff(np.concatenate([[0.0], em.local_cdf.astype(np.float64)]))
    assert g[-1] == 0 and g.sum() == pytest.approx(1.0)      # (the world: a far emitter)
    far_energy = float(em.info["far_energy"][0])
    assert far_energy == pytest.approx(np.pi * 0.2)
    # the triangles' bounding ball (corners' box centre, farthest corner), within twice which
    # the pick is local
    c = 0.5 * (tris.reshape(-1, 3).min(0) + tris.reshape(-1, 3).max(0))
    R = np.linalg.norm(tris.reshape(-1, 3) - c, axis=1).max()
    assert em.info["local_center"][0] == pytest.approx(c, abs=1e-6)
    assert em.info["local_radius"][0] == pytest.approx(R, rel=1e-6)
    near = np.linalg.norm(pts[:, :3] - c, axis=1) < 2 * R
    assert list(near) == [True] * 5 + [False]
    order = r.scene.bvh.leaf_order[em.emissive_leaves]     # the triangles in the table's order
    lamp_of = order - 2                                     # (the floor is triangles 0 and 1)
    rng = np.random.default_rng(5)
    u = rng.random((400000, 2))
    u[u.sum(1) > 1] = 1 - u[u.sum(1) > 1]
    for i in range(n):
        p, nv = pts[i, :3].astype(np.float64), nrm[i, :3].astype(np.float64)
        imp = []
        for j in lamp_of:
            a, b, c = tris[j]
            q = a + u[:, :1] * (b - a) + u[:, 1:] * (c - a)
            v = q - p
            d2 = (v * v).sum(1)
            nt = np.cross(b - a, c - a)
            area = 0.5 * np.linalg.norm(nt)
            cos_l = np.abs(v @ nt) / np.linalg.norm(nt) / np.sqrt(d2)
            cos_r = v @ nv / np.sqrt(d2)
            imp.append(les[j] * max((cos_r * cos_l / d2).mean() * area, 0.0))
        imp, gj = np.array(imp), g[first:first + 3]
        local = local_share(em, p, nv)
        want = local * g
        share = 0.75 * imp / imp.sum() + 0.25 * gj / gj.sum() if imp.sum() > 0 and near[i] \
            else gj / gj.sum()
        want[first:first + 3] = local * gj.sum() * share
        want[-1] = 1.0 - local
        freq = got["counts"][i] / n_u
        assert freq.sum() == pytest.approx(1.0)
        assert freq == pytest.approx(want, rel=0.01, abs=2e-5), (i, freq, want)
        assert got["table"][i] == pytest.approx(want, rel=0.01, abs=2e-5), i
        picked = got["counts"][i] > 0
        assert got["pmf"][i][picked] == pytest.approx(got["table"][i][picked], rel=1e-5), i
    # the point below the second triangle, facing down: the others only by their power share;
    # above all three, facing up: none gives it light, the power pick alone; far from them
    # (beyond twice their bounding ball) the power pick
    assert got["table"][3][1:4].argmax() == list(lamp_of).index(1)
    for k in (4, 5):                  # among the local emitters, by power alone
        t = got["table"][k].astype(np.float64)
        assert t[:-1] / t[:-1].sum() == pytest.approx(g[:-1], rel=1e-5)


def test_direct_light_beside_a_lamp_picks_the_near_triangle():
    """The ceiling beside the Cornell box's lamp (two triangles, 1 cm below it): picked by
    power, the far triangle is taken half the time and one sample's spread was about the mean
    (0.96-1.16 of it measured); by the irradiance each gives the point (pick_emitter_at) it is
    0.5-0.65.  The mean is test_grazing_emitter_does_not_shadow_itself's."""
    from ppm_engine.oracle.procedural import cornell_box
    ys, n = np.array([0.255, 0.27, 0.3]), 4096
    pts = np.array([[0.1, y, 2.0, 0] for y in np.repeat(ys, n)], np.float32)
    nrm = np.tile(np.float32([0, 0, -1, 0]), (len(pts), 1))
    est = direct_light(cornell_box(8, 8), pts, nrm, 1)[:, 0].reshape(len(ys), n)
    rel = est.std(axis=1) / est.mean(axis=1)
    assert (rel < 0.75).all(), rel


def test_a_mesh_light_through_a_transparent_surface_lights_as_much():
    """A 1 m square lamp (radiance 10, 1 m above the point) seen through a Transparent BSDF of
    colour 0.5 halfway: irradiance 0.5 pi Le F (F: the point-to-parallel-square form factor).
    Next-event estimation and the BSDF sample both cross the veil; the sample's MIS weight
    must use next-event estimation's density from the shading point, not from the veil where
    the ray goes on (that made it 26 % bright)."""
    from ppm_engine.scene.arrays import NODE_TRANSPARENT
    mb = MeshBuilder()
    lamp = mb.material("lamp", (0, 0, 0), emission=(10.0,) * 3)
    veil = mb.shader("veil", [dict(type=NODE_TRANSPARENT, color=(0.5, 0.5, 0.5))])
    mb.quad((0, 0, 1), (0, 0.5, 0), (0.5, 0, 0), lamp)          # faces down
    mb.quad((0, 0, 0.5), (2, 0, 0), (0, 2, 0), veil)
    cam = make_camera(type=CAMERA_ORTHO, width=4, height=4,
                      to_world=look_at((0, 0, 5), (0, 0, 0), up=(0, 1, 0)), extent=(2, 2),
                      clip=(0.01, 100))
    n = 64
    pts = np.tile(np.float32([0, 0, 0, 0]), (n, 1))
    nrm = np.tile(np.float32([0, 0, 1, 0]), (n, 1))
    got = direct_light(mb.build(camera=cam), pts, nrm, 4000)[:, 0]
    X = 0.5                                   # a corner's rectangle, 0.5 x 0.5 at height 1
    corner = 2 * X / np.hypot(1, X) * np.arctan(X / np.hypot(1, X)) / (2 * np.pi)
    ref = 0.5 * np.pi * 10.0 * 4 * corner
    se = got.std(ddof=1) / np.sqrt(n)
    assert abs(got.mean() - ref) < 4 * se + 0.003 * ref, (got.mean() / ref, se / ref)


def test_direct_light_beside_a_large_emitter_has_bounded_variance():
    """The ceiling 1 cm above the Cornell box's lamp (0.5 m square, radiance 15, both sides
    emit): irradiance pi Le F with F the point-to-parallel-rectangle form factor (closed form).
    Next-event estimation alone has a per-sample spread of ~(a/h) times the mean here (1/d^2
    near the lamp's centre); with solid-angle sampling of the lamp and MIS with the BSDF sample
    (direct_light.h direct_light) one sample's standard deviation stays well below the mean."""
    from ppm_engine.oracle.procedural import cornell_box
    n = 8192
    pts = np.tile(np.float32([0.0, 0.0, 2.0, 0]), (n, 1))          # above the lamp's centre
    pts[:, 0] = np.linspace(-0.1, 0.1, n)                            # (it is at z = 1.99)
    nrm = np.tile(np.float32([0, 0, -1, 0]), (n, 1))
    got = direct_light(cornell_box(8, 8), pts, nrm, 1)
    h = 0.01

    def corner(a, b):        # form factor to an a x b rectangle with a corner above the point
        X, Y = a / h, b / h
        return (X / np.hypot(1, X) * np.arctan(Y / np.hypot(1, X))
                + Y / np.hypot(1, Y) * np.arctan(X / np.hypot(1, Y))) / (2 * np.pi)
    x = pts[:, 0].astype(np.float64)
    F = corner(0.25 - x, 0.25) * 2 + corner(0.25 + x, 0.25) * 2
    ref = np.pi * 15.0 * F
    e = got[:, 0] / ref                      # per-sample estimate over the exact value
    assert np.isfinite(e).all()
    se = e.std(ddof=1) / np.sqrt(n)
    assert abs(e.mean() - 1) < 4 * se + 0.01, (e.mean(), se)
    # solid-angle sampling of the lamp's triangles (light_mesh.h spherical_triangle): 0.27 measured
    # (area sampling with MIS: 0.9)
    assert e.std() < 0.4, e.std()


def test_an_emitter_that_casts_no_shadow_lights_as_much():
    """A mesh light with shadow visibility off is still found by the BSDF sample (a diffuse
    ray), so NEE + MIS give the same direct light as with the flag on."""
    from ppm_engine.oracle.procedural import cornell_box
    from ppm_engine.scene.arrays import VIS_SHADOW
    scene = cornell_box(8, 8)
    emits = np.zeros(scene.materials.shape[0])
    np.maximum.at(emits, scene.shader_nodes["material"], scene.shader_nodes["emission"].max(axis=1))
    lamp = emits[scene.material] > 0
    vis = scene.visibility.copy()
    vis[lamp] &= ~np.uint32(VIS_SHADOW)
    n = 4096
    pts = np.tile(np.float32([0.0, 0.0, 1.99 - 0.05, 0]), (n, 1))    # 5 cm under the lamp
    pts[:, 0] = np.linspace(-0.3, 0.3, n)
    nrm = np.tile(np.float32([0, 0, 1, 0]), (n, 1))                    # facing it
    a, b = (direct_light(s, pts, nrm, 64)[:, 0].astype(np.float64)
            for s in (scene, scene.replace(visibility=vis)))
    assert a.mean() > 1.0
    assert abs(b.mean() / a.mean() - 1) < 0.01, (a.mean(), b.mean())
