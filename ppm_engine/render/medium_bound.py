"""The majorants of heterogeneous media (kernels/geom/medium_field.h): each medium's density
program bounded over each cell of a grid over its object's box (kernels/geom/majorant_grid.h),
from its values at a lattice of points evaluated on the device (kernels/light/world_map.cl
medium_lattice: the program the world's map is baked with, one build of every node for every
scene), padded; a density that is a Volume object's grid itself by its voxels, on the host."""
from __future__ import annotations

import numpy as np

from ppm_engine.scene.shader_program import (
    SVM_IMAGE,
    grid_density,
    ops_define,
    ops_used,
    stack_used,
)
from ppm_engine.scene.voxels import grid_cell_maxima

GRID_CELLS = 32           # the majorant grid's cells per axis
CELL_STEPS = 2            # lattice steps per cell edge: (2 x 32 + 1)^3 density samples a medium
BOUND_PADDING = 1.25      # a cell's bound over its largest sample (a peak between samples)
GRID_FLOOR = 1.0 / 64.0   # the least cell bound, of the box's: a density the lattice missed
                          # there is still tracked without bias (weighted null collisions)
MAJORANT_HEADER = 16      # floats before a grid's bounds (geom/majorant_grid.h)


def bound_defines(svm: np.ndarray, programs) -> dict:
    """-D flags of world_map.cl's medium_lattice for these density programs."""
    ops = ops_used(svm, programs)
    return {"PPM_SPECIALIZED": True, "PPM_SVM": True, "PPM_VOLUME": True,
            "PPM_ABSORPTION": True, "PPM_SVM_OPS": ops_define(ops),
            "PPM_SVM_STACK": max(stack_used(svm, programs), 1),
            **({"PPM_TEXTURES": True} if ops & (1 << SVM_IMAGE) else {})}


def media_boxes(positions: np.ndarray, material: np.ndarray, kmaterials: np.ndarray) -> dict:
    """{material: (lo, hi)} of the world-space box of the triangles of each material whose
    medium has a density program, widened by a ten-thousandth of its size (a flat one too)."""
    out = {}
    for k in np.nonzero(kmaterials["density_program"] > 0)[0]:
        tri = positions[material == k]
        if tri.size:
            p = tri.reshape(-1, 3).astype(np.float64)
            lo, hi = p.min(axis=0), p.max(axis=0)
            pad = 1e-4 * float((hi - lo).max()) + 1e-6
            out[int(k)] = (lo - pad, hi + pad)
    return out


def cell_bounds(lattice: np.ndarray, steps: int = CELL_STEPS) -> np.ndarray:
    """(n, n, n) the largest of the lattice's values on and in each cell: ``lattice`` (m, m, m)
    with m = n steps + 1, z slowest."""
    w = np.lib.stride_tricks.sliding_window_view(lattice, (steps + 1,) * 3)
    return w[::steps, ::steps, ::steps].max(axis=(3, 4, 5))


def majorant_grid(lo, hi, cells: np.ndarray, clear: float = -1.0) -> np.ndarray:
    """The float32 words of a majorant grid (geom/majorant_grid.h) of (n, n, n) ``cells``
    (z slowest) over the box [lo, hi], padded to a multiple of MAJORANT_HEADER; ``clear``: the
    bound of a cell where no sample found density (-1: none)."""
    n = cells.shape[0]
    head = np.zeros(MAJORANT_HEADER, np.float32)
    head[0:3], head[3] = lo, n
    head[4:7] = n / (np.asarray(hi, np.float64) - np.asarray(lo, np.float64))
    head[7] = clear
    out = np.zeros(-(-(MAJORANT_HEADER + n ** 3) // MAJORANT_HEADER) * MAJORANT_HEADER,
                   np.float32)
    out[:MAJORANT_HEADER] = head
    out[MAJORANT_HEADER:MAJORANT_HEADER + n ** 3] = cells.reshape(-1)
    return out


def pack_grids(kmaterials: np.ndarray, grids: dict, first: int) -> np.ndarray:
    """The words of the majorant grids ``grids`` ({material: (lo, hi, cells, clear)}, as
    bound_media and grid_majorants give them), which go into the voxels buffer at ``first`` (a
    multiple of MAJORANT_HEADER): sets each material's "majorant" (its largest cell) and
    "majorant_grid"."""
    chunks = []
    for k, (lo, hi, cells, clear) in grids.items():
        kmaterials["majorant"][k] = float(cells.max())
        kmaterials["majorant_grid"][k] = first + 1
        chunks.append(majorant_grid(lo, hi, cells, clear))
        first += chunks[-1].size
    return np.concatenate(chunks) if chunks else np.zeros(0, np.float32)


def bound_media(device, args: dict, svm: np.ndarray, kmaterials: np.ndarray,
                boxes: dict, specialize: bool = True) -> dict:
    """The majorant grids of every medium in ``boxes`` (material -> its box), for pack_grids:
    each cell's bound the largest density of the lattice points on and in it times
    BOUND_PADDING, at least GRID_FLOOR of the box's (0 for all: a clear medium), the clear
    bound that floor; ``args``: the scene's buffers (device_scene.SCENE_BUFFERS)."""
    import pyopencl as cl
    if not boxes:
        return {}
    programs = [int(kmaterials["density_program"][k]) for k in boxes]
    prog = device.programs.get("light/world_map.cl",
                               bound_defines(svm, programs) if specialize else {})
    kernel = prog.launch("medium_lattice", "medium lattice")
    m = GRID_CELLS * CELL_STEPS + 1
    out = device.buffer(4 * m ** 3, "medium lattice")
    lattice = np.empty((m, m, m), np.float32)
    grids = {}
    for k, (lo, hi) in boxes.items():
        kernel(device.queue, m ** 3, **args, mat=np.int32(k), lo=np.array([*lo, 0], np.float32),
               hi=np.array([*hi, 0], np.float32), m=np.int32(m), out=out)
        cl.enqueue_copy(device.queue, lattice, out).wait()
        cells = np.nan_to_num(cell_bounds(lattice), nan=0.0, posinf=1e30) * BOUND_PADDING
        cells = np.minimum(cells, 1e30)
        floor = np.float32(float(cells.max()) * GRID_FLOOR)
        grids[k] = (lo, hi, np.maximum(cells, floor).astype(np.float32), floor)
    out.release()
    return grids


def grid_majorants(svm: np.ndarray, kmaterials: np.ndarray, objects: np.ndarray,
                   voxels: np.ndarray, boxes: dict) -> dict:
    """The majorant grids, for pack_grids, of every medium in ``boxes`` whose density is its
    Volume object's grid itself (shader_program.PROGRAM_GRID): each cell's bound the largest
    voxel it reads, or a little more (scene/voxels.py grid_cell_maxima: no voxel's peak
    missed, where samples could miss one; 0 in the clear air of a simulation's box, which
    tracking then skips); takes those media out of ``boxes``."""
    grids = {}
    for k in list(boxes):
        a = grid_density(svm, int(kmaterials["density_program"][k]))
        o = int(kmaterials["volume_object"][k])
        lo, hi = boxes[k]
        cells = grid_cell_maxima(voxels, objects, o, a, lo, hi, GRID_CELLS) \
            if a is not None and o >= 0 else None
        if cells is not None:
            grids[k] = (lo, hi, np.minimum(cells, 1e30).astype(np.float32), 0.0)
            del boxes[k]
    return grids
