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


def grid_maximum(voxels: np.ndarray, objects: np.ndarray, obj: int, attribute: int) -> float | None:
    """The largest value (of a float grid; of a vector grid its components' mean, as a float
    reads it) the grids of object ``obj`` hold for program attribute ``attribute``, at least 0
    (None: no such grid): the bound of a density that is the grid's value (trilinear
    interpolation never exceeds its voxels)."""
    top = None
    for g in object_grids(voxels, objects[obj]):
        if g["attribute"] != attribute:
            continue
        v = voxels[g["offset"]:g["offset"] + int(np.prod(g["dims"])) * g["channels"]]
        if g["channels"] > 1:
            v = v.reshape(-1, g["channels"]).mean(axis=1)
        m = float(v.max()) if v.size else 0.0
        top = max(top or 0.0, m if np.isfinite(m) else 1e30, 0.0)
    return top
