"""Blender Volume objects (OpenVDB grids: smoke and fire simulations, imported .vdb files,
geometry-nodes volumes) -> the grids their material's density reads, dense (scene/voxels.py), and
the box that bounds them (docs/VOLUMES.md, "Volume objects").

The route, as in Blender 5.0's ``bpy`` module: the evaluated volume's grids are written to a
temporary .vdb file (``Volume.grids.save``), read back by Blender's bundled ``openvdb`` Python
module, and copied dense into NumPy over each grid's active voxels (``copyToArray``), the grid's
transform mapping index space to the object's.  As Cycles builds a volume's bounds from the
active voxels of the grids its shader reads (values at most Volume > Render > Clipping left
out), padded by a voxel for trilinear interpolation, the box here is those voxels' box padded
so; a grid larger than VOXEL_BUDGET voxels is averaged by blocks (said in a warning).  The file
is read as untrusted data: a grid of another type, a transform that is not affine, a box too
sparse to read densely, NaN voxels are each said and left out."""
from __future__ import annotations

import contextlib
import glob
import importlib.util
import os
import sys
import tempfile

import numpy as np

from ppm_engine.blender.export.mesh import LocalMesh
from ppm_engine.scene.voxels import VoxelGrid

VOXEL_BUDGET = 256 ** 3    # voxels (times channels) kept per object; larger grids averaged
_SLAB_LIMIT = 4 * VOXEL_BUDGET   # floats of one slab read while averaging: a sparser grid is
#                                  refused (two voxels far apart would make a huge box)
_READ_ERRORS = (RuntimeError, OSError, ValueError, TypeError, KeyError, IndexError,
                AttributeError, MemoryError, OverflowError)
_CHANNELS = {"FloatGrid": 1, "DoubleGrid": 1, "Vec3SGrid": 3, "Vec3DGrid": 3}


def openvdb_module():
    """Blender's bundled ``openvdb`` module, or None: importable inside Blender; beside the
    ``bpy`` module it lies in bpy.utils.resource_path('LOCAL')/python/lib/python3.X/
    site-packages (lib/site-packages on Windows), loaded from there."""
    if "openvdb" in sys.modules:
        return sys.modules["openvdb"]
    with contextlib.suppress(ImportError):
        import openvdb
        return openvdb
    import bpy
    base = os.path.join(bpy.utils.resource_path('LOCAL'), "python", "lib")
    found = sorted(glob.glob(os.path.join(base, "python3*", "site-packages", "openvdb*")) +
                   glob.glob(os.path.join(base, "site-packages", "openvdb*")))
    for path in found:
        spec = importlib.util.spec_from_file_location("openvdb", path)
        if spec is None or spec.loader is None:
            continue
        try:
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
        except ImportError:
            continue
        sys.modules["openvdb"] = module
        return module
    return None


def grid_names(obj) -> tuple:
    """The names of the evaluated Volume object's grids (loaded if they were not)."""
    grids = obj.data.grids
    with contextlib.suppress(*_READ_ERRORS):
        if not grids.is_loaded:
            grids.load()
    return tuple(g.name for g in grids)


def _affine(transform) -> np.ndarray | None:
    """The (4, 4) index-to-object matrix of an openvdb Transform, None if not affine."""
    linear = transform.isLinear
    if not (linear() if callable(linear) else linear):
        return None
    p0 = np.array(transform.indexToWorld((0.0, 0.0, 0.0)), np.float64)
    m = np.eye(4)
    m[:3, 3] = p0
    for i in range(3):
        e = [0.0, 0.0, 0.0]
        e[i] = 1.0
        m[:3, i] = np.array(transform.indexToWorld(tuple(e)), np.float64) - p0
    return m if np.isfinite(m).all() and abs(np.linalg.det(m[:3, :3])) > 1e-30 else None


def _dense(grid, lo, dims, f: int, channels: int) -> np.ndarray:
    """The grid's values over the voxels lo .. lo + dims - 1, averaged in blocks of f^3 (f = 1:
    as they are), float32 (nx, ny, nz[, 3])."""
    tail = (3,) if channels == 3 else ()
    if f == 1:
        a = np.zeros(tuple(dims) + tail, np.float32)
        grid.copyToArray(a, ijk=tuple(int(x) for x in lo))
        return a
    n = [-(-int(d) // f) for d in dims]
    out = np.zeros(tuple(n) + tail, np.float32)
    slab = np.zeros((f, n[1] * f, n[2] * f) + tail, np.float32)
    for i in range(n[0]):
        slab[...] = 0.0
        grid.copyToArray(slab, ijk=(int(lo[0]) + i * f, int(lo[1]), int(lo[2])))
        out[i] = slab.reshape((1, f, n[1], f, n[2], f) + tail).mean(axis=(0, 1, 3, 5))
    return out


def read_grids(obj, names: tuple, warn, clipping: float = 0.0) -> list:
    """[(name, values (nx, ny, nz[, 3]) float32, index-to-object (4, 4), box (lo, hi) in that
    index space)] of the evaluated Volume object's grids named ``names``, as this engine keeps
    them (averaged over blocks beyond VOXEL_BUDGET voxels in all); [] where none can be read
    (each problem warned about, naming the object)."""
    who = f"Object '{obj.name}'"
    ovdb = openvdb_module()
    if ovdb is None:
        warn(f"{who}: its grids cannot be read (Blender's openvdb module was not found); the "
             "volume is not rendered")
        return []
    fd, path = tempfile.mkstemp(suffix=".vdb", prefix="ppm_volume_")
    os.close(fd)
    grids = []
    try:
        if not obj.data.grids.save(path):
            raise OSError(obj.data.grids.error_message or "the grids were not written")
        for name in names:
            g = ovdb.read(path, name)
            kind = type(g).__name__
            if kind not in _CHANNELS:
                warn(f"{who}: its grid '{name}' ({kind}) is not a float or vector grid; it is "
                     "not read")
                continue
            m = _affine(g.transform)
            lo, hi = (np.array(c, np.int64) for c in g.evalActiveVoxelBoundingBox())
            if m is None or g.activeVoxelCount() == 0 or (hi < lo).any():
                warn(f"{who}: its grid '{name}' is empty or not affine; it is not read")
                continue
            grids.append((name, g, m, lo, hi - lo + 1, _CHANNELS[kind]))
    except _READ_ERRORS as e:
        warn(f"{who}: its grids could not be read ({e}); the volume is not rendered")
        return []
    finally:
        with contextlib.suppress(OSError):
            os.remove(path)
    total = sum(int(np.prod(d, dtype=np.float64)) * c for *_, d, c in grids)
    f = 1
    while total / f ** 3 > VOXEL_BUDGET:
        f += 1
    if f > 1:
        warn(f"{who}: its grids ({total:,} voxels) are averaged over blocks of {f}^3 voxels, "
             f"to the {VOXEL_BUDGET:,} voxels this engine keeps per object")
    out = []
    for name, g, m, lo, dims, c in grids:
        slab = f * (-(-int(dims[1]) // f) * f) * (-(-int(dims[2]) // f) * f) * c
        if f > 1 and slab > _SLAB_LIMIT:
            warn(f"{who}: its grid '{name}' spans {' x '.join(map(str, dims))} voxels, too sparse "
                 "to read densely; it is not read")
            continue
        try:
            a = _dense(g, lo, dims, f, c)
        except _READ_ERRORS as e:
            warn(f"{who}: its grid '{name}' could not be read ({e}); it is not read")
            continue
        if not np.isfinite(a).all():
            warn(f"{who}: its grid '{name}' holds NaN or infinite values; they are read as 0 "
                 "(NaN) and +-1e30")
            a = np.nan_to_num(a, nan=0.0, posinf=1e30, neginf=-1e30)
        # index i' of the values: voxel lo + f i' + (f - 1) / 2 of the grid
        to_obj = m @ np.array([[f, 0, 0, lo[0] + (f - 1) / 2], [0, f, 0, lo[1] + (f - 1) / 2],
                               [0, 0, f, lo[2] + (f - 1) / 2], [0, 0, 0, 1]], np.float64)
        live = np.abs(a) > clipping if c == 1 else (np.abs(a) > clipping).any(axis=3)
        if not live.any():
            warn(f"{who}: its grid '{name}' holds no value above the volume's Clipping; it "
                 "bounds nothing")
            continue
        idx = np.nonzero(live)
        box = (np.array([i.min() for i in idx]) - 1.0, np.array([i.max() for i in idx]) + 1.0)
        out.append((name, a, to_obj, box))
    return out


def box_mesh(lo: np.ndarray, hi: np.ndarray) -> LocalMesh:
    """The closed box lo..hi (object space) as 12 outward-wound triangles."""
    c = np.array([[(hi if (k >> a) & 1 else lo)[a] for a in range(3)] for k in range(8)],
                 np.float32)
    quads = ((0, 2, 6, 4), (1, 5, 7, 3), (0, 4, 5, 1), (2, 3, 7, 6), (0, 1, 3, 2), (4, 6, 7, 5))
    tris = np.array([t for q in quads for t in ((q[0], q[2], q[1]), (q[0], q[3], q[2]))])
    p = c[tris]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return LocalMesh(p, np.repeat(n[:, None], 3, axis=1).astype(np.float32),
                     np.zeros((12, 3, 2), np.float32), np.zeros(12, np.int32))


def density_scale(obj, m: np.ndarray) -> float:
    """Cycles' object-space density of a volume (Volume > Render > Space 'Object', the
    default): its coefficients over the length of the object's matrix times the unit diagonal
    (a volume scaled up keeps its look); 1 in world space."""
    if getattr(getattr(obj.data, "render", None), "space", "OBJECT") != "OBJECT":
        return 1.0
    d = np.linalg.norm(m[:3, :3] @ (np.ones(3) / np.sqrt(3.0)))
    return float(1.0 / d) if d > 1e-30 and np.isfinite(d) else 1.0


def export_volume(obj, m: np.ndarray, materials, warn, read: dict):
    """(material row, key, box LocalMesh (object space), [VoxelGrid], texture space (location,
    size)) of an evaluated Volume object placed by ``m``, or None where nothing is rendered (as
    in Cycles: no grids, or none its material's density reads; warned where the grids could
    not be read).  ``materials``: the export's MaterialTable; ``read``: the grids read so far
    in this export, by ``key`` (the volume's data and the grids' names: its instances read
    them once)."""
    names = grid_names(obj)
    if not names:
        msg = getattr(obj.data.grids, "error_message", "")
        warn(f"Object '{obj.name}': the volume has no grids{f' ({msg})' if msg else ''}; "
             "nothing is rendered")
        return None
    # its first material whose volume reads its grids (an empty slot: Cycles' default volume)
    scale = density_scale(obj, m)
    mats = [s.material for s in obj.material_slots] or [None]
    made = next((v for v in (materials.volume_index(mat, names, scale) for mat in mats)
                 if v is not None), None)
    if made is None:
        return None
    k_mat, wanted = made
    key = (obj.data.as_pointer(), obj.data.name, wanted)
    if key not in read:
        read[key] = _grids(obj, wanted, materials.attributes, warn)
    return (k_mat, key, *read[key]) if read[key] is not None else None


def _grids(obj, names: tuple, attributes: list, warn) -> tuple | None:
    """(box LocalMesh, [VoxelGrid], texture space) of the grids ``names`` of a Volume object,
    filling the program attributes of those names (``attributes``: the scene's), or None."""
    clipping = float(getattr(getattr(obj.data, "render", None), "clipping", 0.0) or 0.0)
    grids = read_grids(obj, names, warn, max(clipping, 0.0))
    if not grids:
        return None
    corners = []
    for _name, _a, to_obj, (lo, hi) in grids:
        c = np.array([[(hi if (k >> a) & 1 else lo)[a] for a in range(3)] + [1.0]
                      for k in range(8)])
        corners.append((c @ to_obj.T)[:, :3])
    pts = np.concatenate(corners)
    packed = [VoxelGrid(a, np.linalg.inv(to_obj)[:3], attributes.index(name))
              for name, a, to_obj, _box in grids]
    # Generated coordinates: 0..1 over the volume's bounds (Cycles' generated transform)
    bb = np.array([tuple(v) for v in obj.bound_box], np.float64)
    lo, hi = bb.min(axis=0), bb.max(axis=0)
    return box_mesh(pts.min(axis=0), pts.max(axis=0)), packed, (0.5 * (lo + hi), 0.5 * (hi - lo))
