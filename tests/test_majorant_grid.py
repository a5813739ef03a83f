"""Majorant grids of heterogeneous media (kernels/geom/majorant_grid.h, render/medium_bound.py)
and the transmittance through a field (kernels/geom/medium_field.h medium_transmittance): the
cells' bounds from the density lattice against brute force, the walk's stretches along a segment
against the cell each point of it lies in, a Noise fog's grid against a finer lattice, and the
transmittance's estimators against a fine sum."""
import numpy as np
import pytest

from ppm_engine.render.medium_bound import (
    BOUND_PADDING,
    MAJORANT_HEADER,
    cell_bounds,
    majorant_grid,
)


def test_cell_bounds_are_the_largest_lattice_value_on_each_cell():
    rng = np.random.default_rng(3)
    n, steps = 3, 2
    lattice = rng.random((n * steps + 1,) * 3).astype(np.float32)
    got = cell_bounds(lattice, steps)
    for z in range(n):
        for y in range(n):
            for x in range(n):
                block = lattice[z * steps:(z + 1) * steps + 1, y * steps:(y + 1) * steps + 1,
                                x * steps:(x + 1) * steps + 1]
                assert got[z, y, x] == block.max()


def _trilinear(v: np.ndarray, x: np.ndarray) -> np.ndarray:
    """A grid's values at index coordinates x (k, 3), trilinear between voxel centres, 0
    outside (kernels/geom/volume_grid.h grid_sample, brute force)."""
    f = np.floor(x)
    t = x - f
    i0 = f.astype(int)
    out = np.zeros(len(x))
    for corner in range(8):
        o = np.array([corner & 1, (corner >> 1) & 1, corner >> 2])
        i = i0 + o
        ok = ((i >= 0) & (i < np.array(v.shape))).all(axis=1)
        w = np.prod(np.where(o, t, 1 - t), axis=1)
        out[ok] += w[ok] * v[i[ok, 0], i[ok, 1], i[ok, 2]]
    return out


@pytest.mark.parametrize("turned", [False, True])
def test_grid_cell_maxima_bound_the_grid_in_each_cell(turned):
    """A Volume object's grid (scene/voxels.py grid_cell_maxima), its object turned or not and
    the grid larger than the box: every trilinear sample of the grid (500 random points per
    cell) at most its cell's bound; straight, each bound the largest voxel of the cell's reach
    exactly, turned no larger than the voxels within twice the reach's box around it (aligned
    blocks of a pyramid of maxima); the cells that read only a clear part of the grid 0."""
    from ppm_engine.scene.voxels import VoxelGrid, VoxelTable, grid_cell_maxima
    rng = np.random.default_rng(7)
    v = rng.random((12, 10, 9)).astype(np.float32) ** 4
    v[:, :, :5] = 0.0                                    # clear air under the smoke
    table = VoxelTable()
    to_index = np.array([[6.0, 0, 0, 5.5], [0, 5.0, 0, 4.5], [0, 0, 4.0, 4.0]])  # 1/6 m voxels
    first, count = table.add([VoxelGrid(v, to_index, 2)])
    voxels = np.concatenate(table.chunks)
    row = np.zeros((11, 4), np.float32)
    c, s_ = np.cos(0.5), np.sin(0.5)
    rot = np.array([[c, -s_, 0], [s_, c, 0], [0, 0, 1.0]]) if turned else np.eye(3)
    row[:3, :3], row[5] = rot, (0.0, first, count, 0.0)   # world -> object
    objects = row[None]
    lo, hi, n = np.array([-0.8, -0.7, -0.9]), np.array([0.9, 0.8, 1.1]), 4
    cells = grid_cell_maxima(voxels, objects, 0, 2, lo, hi, n)
    assert cells.shape == (n, n, n)
    world_to_index = to_index[:, :3] @ rot
    size = (hi - lo) / n
    for cz in range(n):
        for cy in range(n):
            for cx in range(n):
                p = lo + (np.array([cx, cy, cz]) + rng.random((500, 3))) * size
                got = _trilinear(v, p @ world_to_index.T + to_index[:, 3])
                assert got.max() <= cells[cz, cy, cx] + 1e-6
                a = (lo + np.array([cx, cy, cz]) * size) @ world_to_index.T + to_index[:, 3]
                b = (lo + (np.array([cx, cy, cz]) + 1) * size) @ world_to_index.T \
                    + to_index[:, 3]
                i0 = np.floor(np.minimum(a, b)).astype(int)
                i1 = np.floor(np.maximum(a, b)).astype(int) + 1
                if not turned:       # straight: the largest voxel of the reach, exactly
                    j0, j1 = i0, i1
                else:                # turned: within twice the corners' box around it
                    grow = 2 * (i1 - i0) + 1
                    j0, j1 = i0 - grow, i1 + grow
                j0 = np.clip(j0, 0, np.array(v.shape) - 1)
                j1 = np.clip(j1, 0, np.array(v.shape) - 1)
                near = v[j0[0]:j1[0] + 1, j0[1]:j1[1] + 1, j0[2]:j1[2] + 1]
                if turned:
                    assert cells[cz, cy, cx] <= near.max()
                else:
                    assert cells[cz, cy, cx] == near.max()
    if not turned:
        assert (cells[0] == 0).all()    # the cells below z = -0.4 m read only clear voxels
    assert (cells[1:] > 0).all()


def _cell_of(grid: np.ndarray, p: np.ndarray, top: float) -> float:
    """The bound the grid holds at point p (brute force: the box's where p is outside)."""
    lo, n, per = grid[0:3].astype(np.float64), int(grid[3]), grid[4:7].astype(np.float64)
    c = np.floor((p - lo) * per).astype(int)
    if (c < 0).any() or (c >= n).any():
        return top
    return float(grid[MAJORANT_HEADER + (c[2] * n + c[1]) * n + c[0]])


def test_walk_stretches_are_the_cells_the_segment_crosses():
    """Segments from inside, outside and through the box, along axes and skew: the stretches
    tile [0, t) in order, and every point of a stretch (64 per segment, away from the cells'
    faces) lies in a cell whose bound is the stretch's (the box's outside it)."""
    from ppm_engine.render.device import get_device
    device = get_device()
    prog = device.programs.get("test/volume_test.cl")
    rng = np.random.default_rng(5)
    n, lo, hi, top = 4, np.array([-1.0, 0.5, 2.0]), np.array([1.0, 1.5, 4.0]), 9.0
    cells = rng.random((n, n, n)).astype(np.float32) + 0.1 * np.arange(n ** 3).reshape(n, n, n)
    grid = majorant_grid(lo, hi, cells)
    starts = np.concatenate([rng.uniform(lo - 1, hi + 1, (40, 3)),
                             np.tile((lo + hi) / 2, (8, 1))])
    dirs = rng.normal(size=starts.shape)
    dirs[40:46] = np.concatenate([np.eye(3), -np.eye(3)])      # along the axes, both ways
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    t = rng.uniform(0.5, 6.0, len(starts))
    k = 3 * n + 4
    o4 = np.concatenate([starts, t[:, None]], axis=1).astype(np.float32)
    d4 = np.concatenate([dirs, np.zeros((len(dirs), 1))], axis=1).astype(np.float32)
    out = np.zeros((len(starts), k, 2), np.float32)
    import pyopencl as cl
    bufs = [device.upload(a, "test") for a in (grid, o4, d4)]
    ob = device.buffer(out.nbytes, "test")
    prog.majorant_walks(device.queue, (len(starts),), None, bufs[0], np.int32(1), bufs[1],
                        bufs[2], np.float32(top), np.int32(k), ob, np.uint32(len(starts)))
    cl.enqueue_copy(device.queue, out, ob).wait()
    for i in range(len(starts)):
        rows = out[i][out[i, :, 0] >= 0]
        ends = rows[:, 0].astype(np.float64)
        assert np.isclose(ends[-1], t[i], rtol=1e-5) and (np.diff(ends) >= 0).all(), rows
        begins = np.concatenate([[0.0], ends[:-1]])
        for s in np.linspace(0, t[i], 64, endpoint=False) + t[i] / 128:
            j = np.searchsorted(ends, s, side="right")
            if j >= len(rows) or min(s - begins[j], ends[j] - s) < 1e-4:
                continue                                       # on a face: either cell's
            assert rows[j, 1] == _cell_of(grid, starts[i] + s * dirs[i], top), (i, s, rows)
    # without a grid: one stretch, the box's bound
    prog.majorant_walks(device.queue, (len(starts),), None, bufs[0], np.int32(0), bufs[1],
                        bufs[2], np.float32(top), np.int32(k), ob, np.uint32(len(starts)))
    cl.enqueue_copy(device.queue, out, ob).wait()
    assert np.allclose(out[:, 0, 0], t) and (out[:, 0, 1] == top).all()
    assert (out[:, 1:, 0] == -1).all()


@pytest.fixture(scope="module")
def noise_fog(bpy):
    """The fog room's cube (3 m, density 0.7) with a Noise Texture on its Density (as
    tests/test_volume_fields.py's export test: the same build), on the device: (DeviceScene,
    its field's material, world_map.cl built for its density program as the bound builds it)."""
    from ppm_engine.blender.export import export_scene
    from ppm_engine.render.device import get_device
    from ppm_engine.render.device_scene import DeviceScene
    from ppm_engine.render.medium_bound import bound_defines
    from tests.helpers.volume_scenes import drive_density, fog_room
    scene = fog_room(density=0.7)
    drive_density(bpy.data.materials["Fog"], "Principled Volume", "ShaderNodeTexNoise")
    ds = DeviceScene(get_device(), export_scene(bpy.context.evaluated_depsgraph_get()))
    k = int(np.nonzero(ds.kmaterials["density_program"] > 0)[0][0])
    prog = ds.device.programs.get("light/world_map.cl", bound_defines(
        ds.prepared.svm, [int(ds.kmaterials["density_program"][k])]))
    yield ds, k, prog
    del scene


def _grid_words(ds, k):
    import pyopencl as cl
    at = int(ds.kmaterials["majorant_grid"][k]) - 1
    words = np.empty(ds.args["voxels"].size // 4, np.float32)
    cl.enqueue_copy(ds.device.queue, words, ds.args["voxels"]).wait()
    return at, words


def test_noise_field_grid_bounds_its_cells(noise_fog):
    """The grid of the Noise fog (after the Volume objects' grids in the voxels buffer): every
    density of a lattice twice as fine as the bound's at most its cell's bound, each bound at
    most BOUND_PADDING times the fine lattice's largest in its cell (a sample's bound, not the
    box's: before, one number bounded the whole box), the box's bound the largest."""
    import pyopencl as cl

    from ppm_engine.render import medium_bound as mb
    ds, k, prog = noise_fog
    at, words = _grid_words(ds, k)
    assert at >= ds.prepared.voxels.size and at % MAJORANT_HEADER == 0
    n = int(words[at + 3])
    cells = words[at + MAJORANT_HEADER:at + MAJORANT_HEADER + n ** 3].reshape(n, n, n)
    lo, per = words[at:at + 3].astype(np.float64), words[at + 4:at + 7].astype(np.float64)
    hi = lo + n / per
    # the fine lattice: the bound's kernel at 2 x its steps over the same box
    m = 2 * n * mb.CELL_STEPS + 1
    out = ds.device.buffer(4 * m ** 3, "test")
    prog.launch("medium_lattice", "test")(
        ds.device.queue, m ** 3, **ds.args, mat=np.int32(k),
        lo=np.array([*lo, 0], np.float32), hi=np.array([*hi, 0], np.float32), m=np.int32(m),
        out=out)
    fine = np.empty((m, m, m), np.float32)
    cl.enqueue_copy(ds.device.queue, fine, out).wait()
    # each fine point's cell (z, y, x), its faces' points in both cells
    idx = np.arange(m) / (2 * mb.CELL_STEPS)
    c_lo = np.clip(np.ceil(idx - 1).astype(int), 0, n - 1)
    c_hi = np.clip(np.floor(idx).astype(int), 0, n - 1)
    for cz in (c_lo, c_hi):
        for cy in (c_lo, c_hi):
            for cx in (c_lo, c_hi):
                bound = cells[cz[:, None, None], cy[None, :, None], cx[None, None, :]]
                assert (fine <= bound * 1.0001).all()
    top = mb.cell_bounds(fine, 2 * mb.CELL_STEPS) * BOUND_PADDING
    assert (cells <= np.maximum(top, cells.max() * mb.GRID_FLOOR) * 1.0001).all()
    assert cells.max() == ds.kmaterials["majorant"][k] and cells.min() < 0.8 * cells.max()


REPS = 1000


def test_field_transmittance_is_unbiased(noise_fog):
    """The transmittance of 64 segments through the Noise fog (each a chord of its cube
    between two random points): the telescoping estimator's mean over REPS estimates and ratio
    tracking's (at the box's bound) both the fine sum's exp(-tau), their mean error over the
    segments within 4 standard errors and each within 8, and one estimate's spread a fifth of
    ratio tracking's or less (what it is for: 0.033 against 0.31); the same for the telescoping
    sum from one sample over each whole segment, whose debiasing terms do the work (without
    them its mean is 0.0043 too bright, 23 standard errors; the default one's 0.0014, 11)."""
    import pyopencl as cl
    ds, k, prog = noise_fog
    rng = np.random.default_rng(11)
    n, lo, hi = 64, np.array([-1.5, -1.5, -0.9]), np.array([1.5, 1.5, 2.1])
    a, b = rng.uniform(lo, hi, (n, 3)), rng.uniform(lo, hi, (n, 3))
    d = b - a
    t = np.linalg.norm(d, axis=1)
    d /= t[:, None]
    o4 = np.concatenate([a, t[:, None]], axis=1).astype(np.float32)
    d4 = np.concatenate([d, np.zeros((n, 1))], axis=1).astype(np.float32)
    res = {}
    for reps, seed in ((REPS, 3), (1, 5)):
        out = ds.device.buffer(16 * n, "test")
        prog.launch("medium_transmittance_test", "test")(
            ds.device.queue, n, **ds.args, mat=np.int32(k), o=ds.device.upload(o4, "test"),
            d=ds.device.upload(d4, "test"), seed=np.uint32(seed), reps=np.int32(reps),
            n=np.int32(n), out=out)
        r = np.empty((n, 4), np.float32)
        cl.enqueue_copy(ds.device.queue, r, out).wait()
        res[reps] = r
    mean, one = res[REPS], res[1]
    exact = mean[:, 2]
    assert (exact > 0.05).sum() > 32 and (exact < 0.8).sum() > 16, exact
    # the spread of one estimate: from the 2000-estimate mean's neighbours (one seed's single
    # estimates against the exact value over the 64 segments)
    sd_tele = np.sqrt(np.mean((one[:, 0] - exact) ** 2))
    sd_ratio = np.sqrt(np.mean((one[:, 1] - exact) ** 2))
    sd_one = np.sqrt(np.mean((one[:, 3] - exact) ** 2))
    assert sd_tele < 0.2 * sd_ratio, (sd_tele, sd_ratio)
    for j, sd in ((0, sd_tele), (1, sd_ratio), (3, sd_one)):
        err = mean[:, j] - exact          # (the telescoping sum's spread has a long tail)
        assert abs(err.mean()) < 4 * sd / np.sqrt(REPS * n), (j, err.mean(), sd)
        assert np.abs(err).max() < 8 * sd / np.sqrt(REPS), (j, np.abs(err).max(), sd)
