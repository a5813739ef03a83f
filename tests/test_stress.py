"""Stress: numerical extremes, hostile geometry, light-transport traps and device limits
(docs/STABILITY.md lists every case).  Every render asserts: finite image, no NaN/Inf dropped by
the kernel guards (``nan_dropped == 0``) on well-formed scenes, radii positive.  Small sizes
here; ``-m slow`` runs the long variants."""
import numpy as np
import pytest

pytest.importorskip("pyopencl")
import pyopencl as cl

from ppm_engine.errors import DeviceError
from ppm_engine.oracle import reference as ref
from ppm_engine.oracle.procedural import MeshBuilder, cornell_box, look_at
from ppm_engine.render import passes as ps
from ppm_engine.render.counters import N_COUNTERS, Counter
from ppm_engine.render.device import get_device
from ppm_engine.render.options import RenderOptions
from ppm_engine.render.photon_map import PhotonMap
from ppm_engine.render.renderer import Renderer
from ppm_engine.scene.arrays import CAMERA_PERSP, LIGHT_DTYPE, LIGHT_POINT, LIGHT_SPOT, LIGHT_SUN
from ppm_engine.scene.camera import make_camera, perspective_extent
from ppm_engine.scene.prep import prepare_scene
from tests.helpers.renders import every_feature


@pytest.fixture(scope="module")
def device(pocl_key):
    return get_device(pocl_key)


def render(scene, passes=8, photons=4096, well_formed=True, **opts):
    """(image rgb (h, w, 3), list of PassStats, radius (h, w)) after ``passes`` passes."""
    r = Renderer(scene, every_feature(photons_per_pass=photons, seed=opts.pop("seed", 1), **opts))
    try:
        stats = [r.iterate() for _ in range(passes)]
        img = r.image()[..., :3]
        radius = r.film.read("radius")
    finally:
        r.close()
    assert np.isfinite(img).all() and (img >= 0).all()
    assert np.isfinite(radius).all() and (radius >= 0).all()
    if well_formed:
        assert stats[-1].nan_dropped == 0
    return img, stats, radius


def blocks(img, n=4):
    h, w = img.shape[:2]
    return img.mean(-1)[: h // n * n, : w // n * n].reshape(n, h // n, n, w // n).mean(axis=(1, 3))


def camera(w, h, eye, target, lens=35.0):
    ext = perspective_extent(w, h, lens, 36.0)
    return make_camera(type=CAMERA_PERSP, width=w, height=h, to_world=look_at(eye, target),
                       extent=ext[:2], clip=(1e-4, 1e9))


def point_light(pos, power, radius=0.0, kind=LIGHT_POINT, direction=(0, 0, -1), spot_deg=180):
    lt = np.zeros(1, LIGHT_DTYPE)
    lt["type"], lt["position"], lt["direction"] = kind, pos, direction
    lt["emit"] = np.float64(power) / (4 * np.pi)
    lt["radius"] = radius
    if kind == LIGHT_SPOT:
        half = np.radians(spot_deg) / 2
        lt["spot_cos_half"] = np.cos(half)
        lt["axis_x"], lt["axis_y"] = (1, 0, 0), (0, 1, 0)
        lt["spot_scale_z"] = 1.0
    return lt


def floor_scene(w=16, h=16, lights=None, extra=None, world=(0, 0, 0)):
    """A grey 4 x 4 m floor under a camera 2 m up looking down at 45 degrees."""
    mb = MeshBuilder()
    grey = mb.material("grey", (0.5, 0.5, 0.5))
    mb.quad((0, 0, 0), (2, 0, 0), (0, 2, 0), grey)
    if extra is not None:
        extra(mb)
    cam = camera(w, h, (0, -2, 2), (0, 0, 0))
    return mb.build(camera=cam, lights=lights, world=world)


# ------------------------------------------------------------------------------------------------
# Long runs
def _long_run(passes, check_every):
    # the scene's own kernels: 2,000 launches of each, where the kernels of every feature cost
    # more per launch than the scene's own build
    r = Renderer(cornell_box(4, 4), RenderOptions(photons_per_pass=256, seed=2,
                                                  indirect="photons"))
    prev_r = prev_n = None
    means = {}
    try:
        for p in range(1, passes + 1):
            s = r.iterate()
            if p % check_every == 0:
                R, N = r.film.read("radius"), r.film.read("nstat")
                assert np.isfinite(R).all() and (R > 0).all(), p
                assert np.isfinite(N).all() and (N >= 0).all(), p
                if prev_r is not None:
                    assert (prev_r >= R).all() and (prev_n <= N).all(), p   # never grow / shrink
                prev_r, prev_n = R, N
                means[p] = r.image()[..., :3].mean()
        assert s.nan_dropped == 0 and s.photons_emitted == passes * 256
        img = r.image()[..., :3]
        assert np.isfinite(img).all()
    finally:
        r.close()
    return means


def test_long_run_radii_shrink_and_counts_stay_finite():
    means = _long_run(2000, 250)
    m = np.array(list(means.values()))
    # converging, not drifting or collapsing: the second half of the run agrees with itself
    assert np.abs(m[len(m) // 2:] / m[-1] - 1).max() < 0.05, m


@pytest.mark.slow
def test_long_run_20000_passes():
    means = _long_run(20000, 1000)
    m = np.array(list(means.values()))
    assert np.abs(m[len(m) // 2:] / m[-1] - 1).max() < 0.02, m


# ------------------------------------------------------------------------------------------------
# Scale and position
def _transformed_cornell(scale, offset, w=24):
    s = cornell_box(w, w)
    pos = (s.positions.astype(np.float64) * scale + offset).astype(np.float32)
    cam = s.camera.copy()
    cam["to_world"][0, :, 3] = cam["to_world"][0, :, 3].astype(np.float64) * scale + offset
    cam["clip"] = (0.1 * scale, 100 * scale)
    return s.replace(positions=pos, camera=cam)


@pytest.mark.parametrize("scale,offset", [(1e-3, 0.0), (1e4, 0.0), (1.0, 1e5),
                                          (1.0, -1e5), (1e-3, 30.0)])
def test_scale_and_translation_give_the_same_image(scale, offset):
    """Radiance does not depend on units or on where the scene stands: the same image, within
    the noise measured between two seeds of the untouched scene."""
    base, _, _ = render(_transformed_cornell(1.0, 0.0), passes=16, photons=8192, seed=1)
    other_seed, _, _ = render(_transformed_cornell(1.0, 0.0), passes=16, photons=8192, seed=7)
    moved, _, _ = render(_transformed_cornell(scale, offset), passes=16, photons=8192, seed=1)
    d = lambda x, y: float(np.sqrt(np.mean((blocks(x) - blocks(y)) ** 2)))
    noise = d(other_seed, base)          # what two seeds of the same scene differ by
    assert noise > 0
    # an independent realisation differs by ~noise (+-25 % over 16 blocks); 2x is > 3 sigma
    assert d(moved, base) < 2 * noise, (d(moved, base), noise)
    assert moved.mean() == pytest.approx(base.mean(), rel=0.03)


def test_far_scene_is_recentred_in_float64():
    s = _transformed_cornell(1.0, 1e5)
    moved, warnings = prepare_scene(s)
    assert warnings == []
    assert np.abs(moved.positions).max() < 10            # near the origin, where float32 is fine
    a, b = moved.positions.astype(np.float64), s.positions.astype(np.float64)
    np.testing.assert_allclose(a - a.mean(axis=(0, 1)), b - b.mean(axis=(0, 1)), atol=1e-2)


# ------------------------------------------------------------------------------------------------
# Hash extremes (kernel level, against the brute-force reference)
def _map(device, ph, vp, radius, exact=False, wi=None):
    n_ph, n_vp = ph.shape[0], vp.shape[0]
    pm = PhotonMap(device, max(n_ph, 1), exact=exact)
    q = device.queue
    pos4, flux4 = np.zeros((max(n_ph, 1), 4), np.float32), np.zeros((max(n_ph, 1), 4), np.float32)
    pos4[:n_ph, :3] = ph
    flux4[:n_ph, :3] = 1.0
    up = np.tile([0.0, 0.0, 1.0], (n_ph, 1))
    wi = np.tile([0.0, 0.0, 1.0], (n_ph, 1)) if wi is None else wi
    if n_ph:
        pos4.view(np.uint32)[:n_ph, 3] = ref.pack_unit(up)
        flux4.view(np.uint32)[:n_ph, 3] = ref.pack_unit(wi)
    cl.enqueue_copy(q, pm.ph_pos, pos4)
    cl.enqueue_copy(q, pm.ph_flux, flux4)
    mk = lambda a: cl.Buffer(device.context, cl.mem_flags.READ_WRITE | cl.mem_flags.COPY_HOST_PTR,
                             hostbuf=np.ascontiguousarray(a))
    counters = np.zeros(N_COUNTERS, np.uint32)
    counters[Counter.STORED] = n_ph
    counters = mk(counters)
    vp_pos = mk(np.c_[vp, np.ones(n_vp)].astype(np.float32))
    vp_nrm = mk(np.tile([0, 0, 1, 0], (n_vp, 1)).astype(np.float32))
    rad = mk(np.asarray(radius, np.float32))
    gathered = cl.Buffer(device.context, cl.mem_flags.READ_WRITE, 16 * n_vp)
    vps = ps.VisiblePoints(device, n_vp, pos=vp_pos, nrm=vp_nrm, beta=vp_nrm,
                           shade=ps.unshaded(device, n_vp), gathered=gathered)
    ctx = ps.PassContext(device, vps=vps, photon_map=pm, counters=counters, radius=rad)
    it = ps.Iteration(0, RenderOptions(seed=3))
    for p in (ps.GridSetup(ctx), ps.HashBuild(ctx), ps.Gather(ctx)):
        p.enqueue(q, it)
    got = np.empty((n_vp, 4), np.float32)
    cl.enqueue_copy(q, got, gathered)
    M_ref = ref.gather_exact(vp, np.tile([0, 0, 1.0], (n_vp, 1)), np.asarray(radius, np.float32),
                             ph, up, wi, np.ones((n_ph, 3)))[1] if n_ph else np.zeros(n_vp)
    return pm, got, M_ref


def test_every_photon_in_one_cell(device):
    ph = np.c_[np.random.default_rng(0).uniform(-1e-6, 1e-6, (5000, 2)), np.zeros(5000)]
    vp = np.array([[0.0, 0.0, 0.0], [0.005, 0.0, 0.0], [1.0, 1.0, 0.0]])
    for exact in (False, True):
        _pm, got, M_ref = _map(device, ph, vp, [0.01, 0.01, 0.01], exact=exact)
        assert np.isfinite(got).all()
        assert M_ref.tolist() == [5000, 5000, 0]
        # the exact map finds all; the stochastic one counts the entry's n for its one photon
        np.testing.assert_array_equal(got[:, 3], M_ref)
        np.testing.assert_allclose(got[:2, 0], 5000, rtol=1e-5)


def test_grid_with_more_than_2_to_the_31_cells(device):
    """Visible points 10 km apart with 1 mm radii: ~10^14 cells; cell indices go through 64-bit
    integers and unsigned hashing, the distance test tells colliding cells apart."""
    rng = np.random.default_rng(1)
    vp = np.c_[rng.uniform(-5e3, 5e3, (200, 2)), np.zeros(200)]
    vp[:2, :2] = [[-5e3, -5e3], [5e3, 5e3]]
    ph = np.repeat(vp, 20, axis=0) + np.c_[rng.normal(0, 5e-4, (4000, 2)), np.zeros(4000)]
    # float32 spacing at 5 km is 0.5 mm: the reference sees the positions the device sees
    vp, ph = vp.astype(np.float32).astype(np.float64), ph.astype(np.float32).astype(np.float64)
    radius = np.full(200, 1e-3)
    pm, got, M_ref = _map(device, ph, vp, radius, exact=True)
    g = pm.read_grid()
    cells = ((np.ravel(g["bmax"])[:3] - np.ravel(g["bmin"])[:3])
             * float(np.ravel(g["inv_cell_size"])[0]))
    assert np.prod(np.maximum(cells[:2], 1)) > 2 ** 31
    assert M_ref.sum() > 1000
    assert (got[:, 3] == M_ref).mean() > 0.98            # float rounding at the radius only
    _, got_s, _ = _map(device, ph, vp, radius)          # stochastic: unbiased in the sum
    assert np.isfinite(got_s).all()
    assert got_s[:, 3].sum() == pytest.approx(M_ref.sum(), rel=0.15)


def test_negative_coordinates_and_photons_outside_the_grid(device):
    rng = np.random.default_rng(2)
    vp = np.c_[rng.uniform(-3, -1, (300, 2)), np.full(300, -7.0)]
    ph = np.c_[rng.uniform(-4, 0, (20000, 2)), np.full(20000, -7.0)]   # a third outside
    _pm, got, M_ref = _map(device, ph, vp, np.full(300, 0.05), exact=True)
    assert M_ref.sum() > 1000
    assert (got[:, 3] == M_ref).mean() > 0.99


def test_empty_photon_map(device):
    vp = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    for exact in (False, True):
        _, got, _ = _map(device, np.zeros((0, 3)), vp, [0.1, 0.1], exact=exact)
        assert (got == 0).all()


def test_no_photon_reaches_anything():
    """A spot light aimed at the sky: every photon escapes, the map stays empty every pass."""
    lt = point_light((0, 0, 1), 100.0, kind=LIGHT_SPOT, direction=(0, 0, 1), spot_deg=30)
    img, stats, radius = render(floor_scene(lights=lt), passes=4)
    assert all(s.photons_stored == 0 for s in stats)
    assert img.max() == 0.0
    assert (radius > 0).sum() >= stats[-1].visible_points      # every visible point keeps R0


@pytest.mark.parametrize("r0", [1e-30, 1e-20, 1e-12])
def test_radius_that_underflows(r0):
    """R^2 underflows float32 (1e-30, 1e-20) or 1/R^2 is huge: no NaN/Inf enters the film."""
    _img, _stats, radius = render(cornell_box(8, 8), passes=4, initial_radius=r0)
    assert (radius > 0).all() and (radius <= r0).all()


# ------------------------------------------------------------------------------------------------
# Geometry
def test_degenerate_duplicate_and_non_manifold_geometry():
    base, _, _ = render(cornell_box(16, 16), passes=8)

    s = cornell_box(16, 16)
    p = s.positions
    k = p.shape[0]
    zero_area = np.stack([p[:, 0], p[:, 0], p[:, 0]], 1)                  # points
    line = np.stack([p[:, 0], p[:, 1], 2 * p[:, 1] - p[:, 0]], 1)         # collinear
    fin = np.array([[[0, 0, 0.5], [0, 0.3, 0.5], [0.2, 0.1, 0.9]],        # a non-manifold fan:
                    [[0, 0, 0.5], [0, 0.3, 0.5], [-0.2, 0.1, 0.9]],       # three faces on one edge
                    [[0, 0, 0.5], [0, 0.3, 0.5], [0.0, 0.1, 0.1]]], np.float32)
    add = np.concatenate([zero_area, line, p[:2], fin]).astype(np.float32)  # p[:2]: the floor again
    n_add = add.shape[0]
    extra_n = np.concatenate([np.zeros((2 * k, 3, 3)), s.normals[:2],
                              np.tile([0, 1.0, 0], (3, 3, 1))])
    s2 = s.replace(positions=np.concatenate([p, add]),
                   normals=np.concatenate([s.normals, extra_n.astype(np.float32)]),
                   uvs=np.zeros((p.shape[0] + n_add, 3, 2), np.float32),
                   material=np.concatenate([s.material, np.zeros(n_add, np.int32)]),
                   visibility=np.concatenate([s.visibility, np.full(n_add, s.visibility[0])]))
    img, _, _ = render(s2, passes=8)
    # the degenerate triangles and the doubled floor change nothing; the fin only shades locally
    assert img.mean() == pytest.approx(base.mean(), rel=0.05)


def test_inverted_normals_render_the_same():
    """Shading is two-sided: flipping every triangle's winding and normals changes nothing."""
    s = cornell_box(16, 16)
    flipped = s.replace(positions=s.positions[:, ::-1].copy(), normals=-s.normals[:, ::-1])
    a, _, _ = render(s, passes=16, photons=8192)
    b, _, _ = render(flipped, passes=16, photons=8192)
    assert b.mean() == pytest.approx(a.mean(), rel=0.03)
    assert np.abs(blocks(a) - blocks(b)).max() < 0.1 * blocks(a).max()


def test_nan_and_inf_vertices_are_skipped_with_a_warning():
    s = cornell_box(16, 16)
    p = s.positions.copy()
    p[3, 1, 2] = np.nan
    p[7, 0, 0] = np.inf
    moved, warnings = prepare_scene(s.replace(positions=p))
    assert moved.positions.shape[0] == p.shape[0] - 2
    assert any("2 triangles" in w and "NaN" in w for w in warnings)
    r = Renderer(s.replace(positions=p), every_feature(photons_per_pass=1024))
    try:
        assert r.warnings == warnings
        st = r.iterate()
        assert st.nan_dropped == 0 and np.isfinite(r.image()).all()
    finally:
        r.close()


def test_camera_inside_a_closed_object():
    """The camera inside a closed, lit box (a furnace): the inside walls, no leak, no NaN."""
    mb = MeshBuilder()
    wall = mb.material("wall", (0.5, 0.5, 0.5), emission=(1.0, 1.0, 1.0))
    mb.box((-1, -1, -1), (1, 1, 1), wall, inward=True)
    s = mb.build(camera=camera(8, 8, (0, 0, 0), (1, 0.2, 0.1)))
    img, _, _ = render(s, passes=32, photons=4096)
    # Le / (1 - rho) = 2 everywhere
    assert img.mean() == pytest.approx(2.0, rel=0.03)


# ------------------------------------------------------------------------------------------------
# Light transport traps
def _glass_ball(ior, transmission=1.0):
    def add(mb):
        g = mb.material("glass", (1, 1, 1), transmission=transmission, roughness=0.0, ior=ior)
        mb.sphere((0, 0, 0.5), 0.4, g, 32, 16)
    return add


def test_glass_of_ior_one_is_invisible():
    """IOR 1.0: no refraction, no reflection; the image equals the scene without the ball."""
    lt = point_light((0.5, -0.5, 2.0), 200.0)
    without, _, _ = render(floor_scene(lights=lt), passes=16, photons=8192)
    with_ball, _, _ = render(floor_scene(lights=lt, extra=_glass_ball(1.0)), passes=16,
                             photons=8192)
    assert with_ball.mean() == pytest.approx(without.mean(), rel=0.03)
    assert np.abs(blocks(with_ball) - blocks(without)).max() < 0.06 * blocks(without).max()


@pytest.mark.parametrize("ior", [1.0001, 1.5, 3.0])
def test_glass_iors_and_total_internal_reflection(ior):
    """IOR 3 traps most light by total internal reflection: bounded bounces, finite image."""
    lt = point_light((0.5, -0.5, 2.0), 200.0)
    img, stats, _ = render(floor_scene(lights=lt, extra=_glass_ball(ior)), passes=4,
                           max_bounces=64)
    assert img.mean() > 0 and stats[-1].photons_stored > 0


def test_camera_inside_glass_with_a_light_enclosed():
    """A point light inside a closed glass sphere, the camera inside a second one: every path
    crosses glass; total internal reflection loops end at max_bounces."""
    def add(mb):
        g = mb.material("glass", (1, 1, 1), transmission=1.0, roughness=0.0, ior=1.5)
        mb.sphere((0, 0, 1.0), 0.3, g, 32, 16)
        mb.sphere((0, -2, 2), 0.2, g, 32, 16)
    img, stats, _ = render(floor_scene(lights=point_light((0, 0, 1.0), 100.0), extra=add),
                           passes=8)
    assert img.mean() > 0 and stats[-1].photons_stored > 0


def test_zero_power_and_huge_lights_scale_linearly():
    zero, _stats0, _ = render(floor_scene(lights=point_light((0, 0, 1.5), 0.0)), passes=4)
    assert zero.max() == 0.0
    a, _, _ = render(floor_scene(lights=point_light((0, 0, 1.5), 100.0)), passes=4, seed=5)
    b, _stats, _ = render(floor_scene(lights=point_light((0, 0, 1.5), 1e9)), passes=4, seed=5)
    np.testing.assert_allclose(b / 1e7, a, rtol=1e-3, atol=1e-6 * a.max())


@pytest.mark.parametrize("indirect", ["photons", "paths"])
def test_light_inside_a_closed_box_does_not_leak(indirect):
    """A lamp in a closed diffuse box above the floor: outside, the box and the floor stay
    black (photons on the inside of a wall must not be gathered on its outside: the gather's
    normal test; eye paths must not cross the walls, which have no thickness)."""
    def add(mb):
        w = mb.material("box", (0.8, 0.8, 0.8))
        mb.box((-0.5, -0.5, 0.2), (0.5, 0.5, 1.2), w)
    # (photons every pass: none reaches the image, so by default few would, Renderer.photons_due)
    img, stats, _ = render(floor_scene(lights=point_light((0, 0, 0.7), 1000.0), extra=add),
                           passes=8, indirect=indirect, skip_unused_photons=False)
    if indirect == "photons":
        assert stats[-1].photons_stored > 0     # photons bounce around inside
    assert img.max() == 0.0


def test_tiny_light_and_grazing_sun():
    tiny, _, _ = render(floor_scene(lights=point_light((0, 0, 1.0), 100.0, radius=1e-6)),
                        passes=4)
    point, _, _ = render(floor_scene(lights=point_light((0, 0, 1.0), 100.0)), passes=4)
    assert tiny.mean() == pytest.approx(point.mean(), rel=0.02)
    for elevation in (1e-4, 0.5):       # degrees above the horizon
        sun = np.zeros(1, LIGHT_DTYPE)
        sun["type"], sun["emit"] = LIGHT_SUN, 3.0
        e = np.radians(elevation)
        sun["direction"] = (0, -np.cos(e), -np.sin(e))
        sun["radius"] = np.radians(0.25)
        img, _, _ = render(floor_scene(lights=sun), passes=4)
        # radiance rho / pi * E sin(elevation), at most that of the disk's top edge
        top = 3.0 * np.sin(e + sun["radius"][0]) * 0.5 / np.pi
        assert 0 < img.mean() <= 1.1 * top, (elevation, img.mean(), top)


@pytest.mark.parametrize("bounces", [0, 1, 1000])
def test_max_bounces_extremes(bounces):
    img, stats, _ = render(cornell_box(16, 16, bulb=True), passes=4, max_bounces=bounces)
    if bounces == 0:          # no photons and no specular chains: the bulb is inside glass
        assert all(s.photons_stored == 0 for s in stats)
    else:
        assert img.mean() > 0


@pytest.mark.parametrize("indirect", ["photons", "paths"])
def test_one_by_one_image(indirect):
    s = cornell_box(1, 1)
    img, stats, _ = render(s, passes=8, indirect=indirect)
    assert img.shape == (1, 1, 3) and img.mean() > 0
    # the photon grid counts the visible points; eye paths without caustics build none
    assert stats[-1].visible_points == (1 if indirect == "photons" else 0)


# ------------------------------------------------------------------------------------------------
# Device limits
def test_photons_per_pass_over_the_device_limit_is_refused_with_a_message(pocl_key, monkeypatch):
    dev = get_device(pocl_key)
    monkeypatch.setattr(dev, "max_alloc", 1 << 20)        # a device that allows 1 MiB buffers
    # (the paper's photons: a box lit by eye paths would allocate no photon storage at all)
    with pytest.raises(DeviceError, match=r"photons per pass|MAX_MEM_ALLOC_SIZE"):
        Renderer(cornell_box(8, 8), every_feature(photons_per_pass=1 << 16, device=pocl_key,
                                                  indirect="photons"))
    r = Renderer(cornell_box(8, 8), every_feature(photons_per_pass=1 << 16, device=pocl_key))
    assert not r.photons_needed and r.photon_map.capacity == 0
    r.close()
    monkeypatch.undo()
    r = Renderer(cornell_box(8, 8), every_feature(photons_per_pass=1 << 10, device=pocl_key))
    assert np.isfinite(r.iterate().radius_max)       # the device is still usable
    r.close()


def test_buffer_over_max_alloc_is_a_clear_error(device):
    with pytest.raises(DeviceError, match="MAX_MEM_ALLOC_SIZE"):
        device.buffer(device.max_alloc + 16, "a test buffer")
    with pytest.raises(DeviceError, match="MAX_MEM_ALLOC_SIZE"):
        device.check_alloc(device.max_alloc + 1, "an upload")
