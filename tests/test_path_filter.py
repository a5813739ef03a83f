"""Path space filtering (ppm_engine/render/passes/path_filter.py, kernels/integrator/
path_filter.cl): the groups' means against NumPy, the first cell size's definition, when it turns
itself off, and renders with and without it (the same image, less noise; records only where the
second vertex is Lambert)."""
import types

import numpy as np
import pytest

pytest.importorskip("pyopencl")
import pyopencl as cl

from ppm_engine.oracle.procedural import MeshBuilder, cornell_box, look_at
from ppm_engine.render.device import get_device
from ppm_engine.render.options import RenderOptions, global_radius_scale
from ppm_engine.render.passes import Iteration, PassContext
from ppm_engine.render.passes.path_filter import PathFilter, cell_for, roulette_only
from ppm_engine.render.renderer import Renderer
from ppm_engine.scene.arrays import CAMERA_PERSP
from ppm_engine.scene.camera import make_camera
from tests.helpers.device_buffers import DEVICES, read
from tests.helpers.renders import every_feature


@pytest.fixture(params=DEVICES, scope="module")
def device(request):
    return get_device(request.param)


def _groups(pos, vw, cell, off, jitter, states):
    """NumPy's grouping as path_filter.cl's pf_fingerprint: the cell in float32 as the kernel
    computes it, the normal's octahedral bins, the path state."""
    inv = np.float32(1) / np.float32(cell)
    c = np.floor((pos[:, :3] - off.astype(np.float32)) * inv).astype(np.int64)
    q = vw.view(np.uint32)
    e = np.c_[q & 0xFFFF, q >> 16].astype(np.float32) * np.float32(1 / 65535)
    nb = np.floor(e * np.float32(8) + jitter.astype(np.float32)).astype(np.int64)
    return np.c_[c, nb, states]


@pytest.mark.gpu
def test_each_record_gets_its_group_s_mean(device):
    """Records on a floor and a wall, two path states, two normals' bins, some not made: each
    pixel's sample gains w x the mean v of the records in its cell, bins and state, as NumPy
    groups them (every kernel on every device, tests/helpers/device_buffers.py).  A record past
    the fixed-point sums' range (v over 2^14, with 64-bit atomics) keeps its own v, out of its
    group's mean."""
    rng = np.random.default_rng(3)
    n = 4096
    floor = rng.random(n) < 0.6
    pos = np.zeros((n, 4), np.float32)
    pos[:, :3] = np.where(floor[:, None], np.c_[rng.random((n, 2)) * 2, np.zeros(n)],
                          np.c_[np.zeros(n), rng.random((n, 2)) * 2]).astype(np.float32)
    states = rng.choice(np.array([3, 0x40001], np.uint32), n)
    pos[:, 3] = states.view(np.float32)
    packed = np.where(floor, rng.choice(np.array([32768 | 32768 << 16, 40000 | 32768 << 16],
                                                 np.uint32), n),
                      np.uint32(65535 | 32768 << 16)).astype(np.uint32)
    v = np.c_[rng.random((n, 3)), packed.view(np.float32)].astype(np.float32)
    w = np.c_[rng.random((n, 3)) + 0.1, (rng.random(n) < 0.9)].astype(np.float32)
    v[7, :3], w[7, 3] = (3e4, 1.0, 2.0), 1.0                   # past PF_VMAX
    own = np.zeros(n, bool)
    own[7] = device.int64_atomics
    film = types.SimpleNamespace(direct_pass=cl.Buffer(device.context, cl.mem_flags.READ_WRITE,
                                                       16 * n), radius=None)
    cl.enqueue_fill_buffer(device.queue, film.direct_pass, np.float32(0), 0, 16 * n)
    pf = PathFilter(PassContext(device, film=film), n)
    for buf, host in ((pf.pos, pos), (pf.v, v), (pf.w, w)):
        cl.enqueue_copy(device.queue, buf, host)
    pf.cell0 = 0.3
    o = RenderOptions(seed=5)
    pf.enqueue(device.queue, Iteration(3, o))
    got = read(device, film.direct_pass, (n, 4), np.float32)
    # this pass's cell and offsets, as PathFilter.enqueue draws them
    cell = 0.3 * global_radius_scale(3, o.alpha)
    u = np.random.default_rng([o.seed, 3, 0x5046]).random(5)
    key = _groups(pos, v[:, 3], np.float32(cell), u[:3] * cell, u[3:5], states)
    ok = (w[:, 3] > 0) & ~own
    _, group = np.unique(key[ok], axis=0, return_inverse=True)
    group = group.ravel()
    sums = np.zeros((group.max() + 1, 3))
    np.add.at(sums, group, v[ok, :3])
    mean = sums / np.bincount(group)[:, None]
    want = np.zeros((n, 3))
    want[ok] = w[ok, :3] * mean[group]
    want[own] = w[own, :3] * v[own, :3]
    assert np.bincount(group).max() > 5                 # groups of several records
    np.testing.assert_allclose(got[:, :3], want, rtol=2e-5, atol=1e-7)
    assert not got[:, 3].any()                         # the sample count is the eye pass's


def test_the_first_cell_is_the_smallest_whose_groups_hold_enough():
    """cell_for: the ladder's step (a factor sqrt 2) below the answer holds fewer than asked,
    the answer at least as many; path states are groups of their own."""
    rng = np.random.default_rng(1)
    p = np.c_[rng.random((5000, 2)) * 4, np.zeros(5000)]
    state = rng.integers(0, 2, 5000).astype(np.uint32)

    def mean(c):
        k = np.c_[np.floor((p - p.min(axis=0)) / c), state]
        return len(p) / len(np.unique(k, axis=0))
    for records in (4.0, 16.0, 64.0):
        c = cell_for(p, state, records)
        assert mean(c) >= records > mean(c / np.sqrt(2)), (records, c)
    assert cell_for(p[:1], state[:1], 4.0) is None


def _filtered(scene, passes, seed, on):
    r = Renderer(scene, every_feature(indirect="paths", seed=seed, path_filter=on))
    try:
        made = 0
        for _ in range(passes):
            assert r.iterate().nan_dropped == 0
            if on:
                made = max(made, int((read(r.device, r.path_filter.w, (r.n_pixels, 4),
                                           np.float32)[:, 3] > 0).sum()))
        return r.image()[..., :3].astype(np.float64), made
    finally:
        r.close()


def test_the_filter_keeps_the_image_and_lowers_its_noise():
    """The Cornell box by eye paths, 48 x 48 over 96 passes, two seeds each, with and without the
    filter: the same image (each 8 x 8 block's mean of the two seeds within four standard
    deviations of the difference, as the seeds' spread gives them, plus 0.2 %: the filter's bias,
    shrinking with its cells, is below that; measured at most 2.6 deviations apart, and 8.4
    with cells 8 times as large), and
    the two seeds' images closer with it (the light of two and more bounces averaged over its
    groups): measured 0.81 of the difference without."""
    scene = cornell_box(48, 48)
    imgs = {on: [_filtered(scene, 96, s, on) for s in (1, 2)] for on in (False, True)}
    assert all(made > 48 * 48 // 2 for _, made in imgs[True])    # most pixels made one

    def blocks(i):
        return i.mean(axis=2).reshape(6, 8, 6, 8).mean(axis=(1, 3))
    mean = {on: blocks(sum(i for i, _ in imgs[on]) / 2) for on in imgs}
    # a block's mean of two seeds: the spread of its two seeds' block means over 2
    sd2 = sum((blocks(imgs[on][0][0]) - blocks(imgs[on][1][0])) ** 2 / 4 for on in imgs)
    sigma = np.sqrt(np.mean(sd2))                    # pooled over the blocks
    ref, got = mean[False], mean[True]
    lit = ref > 0.05 * ref.max()
    assert (np.abs(got - ref)[lit] < 4 * sigma + 0.002 * ref[lit]).all(), (got / ref, sigma)
    noise = {on: np.sqrt(((imgs[on][0][0] - imgs[on][1][0]) ** 2).mean()) for on in imgs}
    assert noise[True] < 0.9 * noise[False], noise


def test_no_record_where_the_second_vertex_is_not_lambert():
    """A box of rough metal lit by a lamp: no eye path's second vertex is Lambert, so no record
    is made and the filter changes nothing (the same image bit for bit)."""
    mb = MeshBuilder()
    metal = mb.material("metal", base=(0.8, 0.8, 0.8), metallic=1.0, roughness=0.7)
    lamp = mb.material("lamp", (0, 0, 0), emission=(10, 10, 10))
    mb.box((-1, -1, 0), (1, 1, 2), metal, inward=True)
    mb.quad((0, 0, 1.99), (0, 0.25, 0), (0.25, 0, 0), lamp)
    cam = make_camera(type=CAMERA_PERSP, width=16, height=16, extent=(0.5, 0.5),
                      to_world=look_at((0, -0.9, 1), (0, 0, 0.8)))
    (a, _), (b, made) = (_filtered(mb.build(camera=cam), 8, 1, on) for on in (False, True))
    assert made == 0 and a.mean() > 0.05
    np.testing.assert_array_equal(a, b)


def test_a_furnace_s_few_values_turn_the_filter_off():
    """roulette_only: records whose light past x2 falls on a handful of values (a furnace's: how
    many bounces the roulette let the path live) turn the filter off; values spread as a lit
    room's (and zeros, paths that left the scene) or too few records to judge keep it."""
    rng = np.random.default_rng(2)
    levels = 0.5 * 0.7 ** rng.integers(0, 12, 2000) * (1 + 0.001 * rng.random(2000))
    assert roulette_only(np.repeat(levels[:, None], 3, axis=1))
    spread = np.r_[rng.lognormal(0.0, 1.0, 2000), np.zeros(3000)]
    assert not roulette_only(np.repeat(spread[:, None], 3, axis=1))
    assert not roulette_only(np.repeat(levels[:200, None], 3, axis=1))


def test_the_filter_stops_once_its_cells_hold_two_records():
    """PathFilter.wanted: a pass filters while its cells (shrinking with alpha) still hold
    RECORDS_MIN records a group on average; from some 13,000 passes on (alpha 0.7) the
    unfiltered estimator goes on alone, and a filter turned off by its first pass never
    filters."""
    o = RenderOptions()
    f = types.SimpleNamespace(active=True, CELL_RECORDS=PathFilter.CELL_RECORDS,
                              RECORDS_MIN=PathFilter.RECORDS_MIN)
    assert PathFilter.wanted(f, Iteration(1000, o))
    assert not PathFilter.wanted(f, Iteration(20000, o))
    f.active = False
    assert not PathFilter.wanted(f, Iteration(0, o))
