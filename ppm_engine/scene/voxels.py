"""Volume objects' grids as the kernels read them (SceneArrays.voxels; kernels/geom/volume_grid.h).

One float32 array holds every grid: per grid a header of VOXEL_HEADER floats, then its voxels,
padded to a multiple of VOXEL_HEADER floats (so that a grid starts at a multiple of it, and an
object's first grid is named by a float that is exact up to 2^24 x 64 bytes).  The header:

    words 0-11   three rows of the affine map from the object's space to the grid's index
                 space (voxel centres at integers, 0 at the first voxel stored)
    words 12-14  its size in voxels (nx, ny, nz)
    word 15      the shader-program attribute it fills (k: GEOM_ATTRIBUTE + k) + 16 x its
                 channels (1: a float grid, read as (f, f, f, 1); 3: a vector grid, (x, y, z, 1))

then nx x ny x nz x channels floats, x slowest, the channels fastest.  An object's grids lie
one after another; its row of SceneArrays.objects holds (random, first, count, 0) in row 5: the
first grid's offset / VOXEL_HEADER and how many (export/objects.py object_row)."""
from __future__ import annotations

import dataclasses

import numpy as np

VOXEL_HEADER = 16         # floats of a grid's header (kernels/geom/volume_grid.h VOXEL_HEADER)
GRID_ROW = 5              # the objects' row holding (random, first grid, grid count, 0)
MAX_GRID_OFFSET = 1 << 24   # first / VOXEL_HEADER is a float: exact below this


@dataclasses.dataclass(frozen=True)
class VoxelGrid:
    """One grid to pack: ``values`` (nx, ny, nz) or (nx, ny, nz, 3) float32, ``to_index`` the
    (3, 4) object-to-index map, ``attribute`` the program attribute k it fills."""
    values: np.ndarray
    to_index: np.ndarray
    attribute: int

    @property
    def channels(self) -> int:
        return 1 if self.values.ndim == 3 else int(self.values.shape[3])


def _padded(n: int) -> int:
    return -(-n // VOXEL_HEADER) * VOXEL_HEADER


class VoxelTable:
    """Grids packed as they come (export): ``add`` returns (first, count) for the object's row."""

    def __init__(self):
        self.chunks: list[np.ndarray] = []
        self.size = 0

    def add(self, grids: list[VoxelGrid]) -> tuple[int, int]:
        first = self.size // VOXEL_HEADER
        for g in grids:
            if g.channels not in (1, 3) or g.values.ndim not in (3, 4):
                raise ValueError("a grid holds 1 or 3 channels")
            head = np.zeros(VOXEL_HEADER, np.float32)
            head[:12] = np.asarray(g.to_index, np.float32).reshape(12)
            head[12:15] = g.values.shape[:3]
            head[15] = g.attribute + 16 * g.channels
            data = np.ascontiguousarray(g.values, np.float32).reshape(-1)
            tail = np.zeros(_padded(data.size) - data.size, np.float32)
            self.chunks += [head, data, tail]
            self.size += VOXEL_HEADER + _padded(data.size)
        if self.size // VOXEL_HEADER >= MAX_GRID_OFFSET:
            raise ValueError("the Volume objects' grids exceed 1 GiB")
        return first, len(grids)

    def array(self) -> np.ndarray:
        return np.concatenate(self.chunks) if self.chunks else np.zeros(0, np.float32)


def object_grids(voxels: np.ndarray, row: np.ndarray) -> list[dict]:
    """The grids of one object (its (OBJECT_ROWS, 4) row): dicts of offset (of the voxels),
    dims, attribute, channels, to_index.  Raises ValueError where the row or a header is not
    consistent with ``voxels``."""
    first, count = row[GRID_ROW, 1], row[GRID_ROW, 2]
    if not (first >= 0 and count >= 0 and first == int(first) and count == int(count)):
        raise ValueError("an object's grids are not named by whole numbers")
    out, at = [], int(first) * VOXEL_HEADER
    for _ in range(int(count)):
        if at + VOXEL_HEADER > voxels.size:
            raise ValueError("an object's grid lies outside the voxels")
        head = voxels[at:at + VOXEL_HEADER]
        dims = head[12:15]
        word = head[15]
        if not (np.isfinite(head).all() and (dims >= 1).all() and (dims == np.floor(dims)).all()
                and word >= 16 and word == int(word)):
            raise ValueError("a grid's header is not valid")
        k, c = int(word) % 16, int(word) // 16
        n = int(np.prod(dims.astype(np.int64))) * c
        if c not in (1, 3) or at + VOXEL_HEADER + n > voxels.size:
            raise ValueError("a grid's voxels lie outside the voxels")
        out.append(dict(offset=at + VOXEL_HEADER, dims=tuple(int(d) for d in dims), attribute=k,
                        channels=c, to_index=head[:12].reshape(3, 4)))
        at += VOXEL_HEADER + _padded(n)
    return out


def check_objects(object: np.ndarray, objects: np.ndarray, volume_object: np.ndarray, t: int,
                  rows: int, voxels: np.ndarray) -> None:
    """SceneArrays' objects checked (ValueError): ``object`` int32 (T,) or (0,) rows of
    ``objects``, float32 (O, rows, 4), which the materials' ``volume_object`` (1-based, 0: none)
    name too; ``voxels`` float32 of whole headers holding every object's grids."""
    if object.dtype != np.int32 or object.shape not in ((0,), (t,)) \
            or objects.dtype != np.float32 or objects.ndim != 3 \
            or objects.shape[1:] != (rows, 4) \
            or (object.size and (object.min() < -1 or object.max() >= objects.shape[0])) \
            or not np.isin(volume_object, range(objects.shape[0] + 1)).all():
        raise ValueError("SceneArrays.object/objects: expected int32 (T,) rows of a float32 "
                         f"(O, {rows}, 4) table (and materials' volume_object)")
    if voxels.dtype != np.float32 or voxels.ndim != 1 or voxels.size % VOXEL_HEADER:
        raise ValueError(f"SceneArrays.voxels: expected float32 (16 N,), got "
                         f"{voxels.dtype}{voxels.shape}")
    for row in objects:
        try:
            object_grids(voxels, row)
        except ValueError as e:
            raise ValueError(f"SceneArrays.voxels: {e}") from e


def _axis_maxima(grid: np.ndarray, first: list, last: list) -> np.ndarray:
    """(n, n, n) the largest voxel of grid[first[0][i]:last[0][i] + 1, first[1][j]..., ...] for
    each (i, j, k), the ranges per axis given as (n,) arrays (0 where a range misses the grid),
    at least 0: one axis at a time."""
    out = grid
    for a in range(3):
        d = grid.shape[a]
        parts = []
        for f, x in zip(first[a].astype(np.int64), last[a].astype(np.int64)):
            f, x = max(f, 0), min(x, d - 1)
            sl = [slice(None)] * 3
            sl[a] = slice(f, x + 1) if f <= x else slice(0, 1)
            part = out[tuple(sl)].max(axis=a, keepdims=True)
            parts.append(part if f <= x else np.zeros_like(part))
        out = np.concatenate(parts, axis=a)
    return np.maximum(out, 0.0)


def max_pyramid(values: np.ndarray) -> list[np.ndarray]:
    """Levels of maxima over blocks of 2^L voxels per axis (level 0 the voxels; a level's odd
    end padded with -inf), down to one block."""
    levels = [values]
    while max(levels[-1].shape) > 1:
        v = levels[-1]
        pad = [(0, s % 2) for s in v.shape]
        v = np.pad(v, pad, constant_values=-np.inf)
        s = v.shape
        levels.append(v.reshape(s[0] // 2, 2, s[1] // 2, 2, s[2] // 2, 2).max(axis=(1, 3, 5)))
    return levels


def grid_cell_maxima(voxels: np.ndarray, objects: np.ndarray, obj: int, attribute: int,
                     lo, hi, n: int) -> np.ndarray | None:
    """(n, n, n), z slowest: for each cell of the world box [lo, hi] cut n times per axis, the
    largest voxel (of a vector grid its components' mean, as a float reads it) that trilinear
    interpolation reads anywhere in it, from the grids of object ``obj`` filling program
    attribute ``attribute``, or a little more: 0 where the cell is outside them; a bound of
    such a density over the cell that misses no voxel's peak (None: no such grid).  The cell's
    corners mapped to the grid's index space bound the voxels it reads (a box around them
    where the grid is turned): where the grid is not turned against the world, the largest of
    them exactly (one axis at a time); where it is, read from a pyramid of maxima at the level
    where that box spans at most two blocks per axis (the blocks read reach at most twice the
    box's size past it)."""
    row = objects[obj]
    world_to_object = np.vstack([row[:3].astype(np.float64), [0.0, 0.0, 0.0, 1.0]])
    edges = [np.linspace(lo[a], hi[a], n + 1) for a in range(3)]
    out = None
    for g in object_grids(voxels, row):
        if g["attribute"] != attribute:
            continue
        dims = g["dims"]
        v = voxels[g["offset"]:g["offset"] + int(np.prod(dims)) * g["channels"]]
        v = v.reshape(*dims, g["channels"]).mean(axis=3) if g["channels"] > 1 \
            else v.reshape(dims)
        m = g["to_index"].astype(np.float64) @ world_to_object      # world -> index, (3, 4)
        # each index axis a's least and largest over a cell: per world axis w the smaller and
        # larger of its two faces' terms m[a, w] x, summed over the axes
        low, high = [], []
        for a in range(3):
            t = [m[a, w] * edges[w] for w in range(3)]
            low.append([np.minimum(x[:-1], x[1:]) for x in t])
            high.append([np.maximum(x[:-1], x[1:]) for x in t])
        grid = np.nan_to_num(v, nan=0.0, posinf=1e30).astype(np.float32)
        if (np.abs(m[:, :3] - np.diag(np.diag(m[:, :3]))) <= 1e-6 * np.abs(m[:, :3]).max()).all():
            # not turned: index axis a's range by world axis a (the others' tiny terms at
            # their extremes), the largest voxel of each cell's reach exactly, axis by axis
            first = [np.floor(m[a, 3] + low[a][a] + sum(low[a][w].min() for w in range(3)
                                                         if w != a)) for a in range(3)]
            last = [np.floor(m[a, 3] + high[a][a] + sum(high[a][w].max() for w in range(3)
                                                          if w != a)) + 1 for a in range(3)]
            best = _axis_maxima(grid, first, last).transpose(2, 1, 0)   # z slowest
            out = best if out is None else np.maximum(out, best)
            continue
        # turned: the range of every cell (x slowest here)
        first = [np.floor(m[a, 3] + low[a][0][:, None, None] + low[a][1][None, :, None]
                          + low[a][2][None, None, :]) for a in range(3)]
        last = [np.floor(m[a, 3] + high[a][0][:, None, None] + high[a][1][None, :, None]
                         + high[a][2][None, None, :]) + 1 for a in range(3)]
        inside = np.ones((n, n, n), bool)
        for a in range(3):
            inside &= (last[a] >= 0) & (first[a] <= dims[a] - 1)
        first = [np.clip(f, 0, d - 1).astype(np.int64) for f, d in zip(first, dims)]
        last = [np.clip(x, 0, d - 1).astype(np.int64) for x, d in zip(last, dims)]
        span = np.max([x - f for f, x in zip(first, last)], axis=0)
        level = np.ceil(np.log2(span + 1.0)).astype(np.int64)
        pyramid = max_pyramid(grid)
        best = np.zeros((n, n, n), np.float32)
        for lv in np.unique(level[inside]):
            sel = inside & (level == lv)
            p = pyramid[min(lv, len(pyramid) - 1)]
            b0 = [f[sel] >> lv for f in first]
            b1 = [x[sel] >> lv for x in last]
            top = np.full(b0[0].shape, -np.inf, np.float32)
            for cx in (b0[0], b1[0]):
                for cy in (b0[1], b1[1]):
                    for cz in (b0[2], b1[2]):
                        top = np.maximum(top, p[np.minimum(cx, p.shape[0] - 1),
                                                np.minimum(cy, p.shape[1] - 1),
                                                np.minimum(cz, p.shape[2] - 1)])
            best[sel] = np.maximum(top, 0.0)
        # (cells x slowest above: z slowest for the grid)
        best = best.transpose(2, 1, 0)
        out = best if out is None else np.maximum(out, best)
    return out
