"""The majorants of heterogeneous media (kernels/geom/medium_field.h): each medium's density
program bounded over its object's box on the device (kernels/light/world_map.cl medium_bound:
the program the world's map is baked with, one build of every node for every scene), padded; a
density that is a Volume object's grid itself by the grid's largest voxel, on the host."""
from __future__ import annotations

import numpy as np

from ppm_engine.scene.shader_program import (
    SVM_IMAGE,
    grid_density,
    ops_define,
    ops_used,
    stack_used,
)
from ppm_engine.scene.voxels import grid_maximum

BOUND_CELLS = 32          # the box's cells per axis: one density sample each
BOUND_PADDING = 1.25      # the bound over the largest sample (a peak between samples)


def bound_defines(svm: np.ndarray, programs) -> dict:
    """-D flags of world_map.cl's medium_bound for these density programs."""
    ops = ops_used(svm, programs)
    return {"PPM_SPECIALIZED": True, "PPM_SVM": True, "PPM_VOLUME": True,
            "PPM_ABSORPTION": True, "PPM_SVM_OPS": ops_define(ops),
            "PPM_SVM_STACK": max(stack_used(svm, programs), 1),
            **({"PPM_TEXTURES": True} if ops & (1 << SVM_IMAGE) else {})}


def media_boxes(positions: np.ndarray, material: np.ndarray, kmaterials: np.ndarray) -> dict:
    """{material: (lo, hi)} of the world-space box of the triangles of each material whose
    medium has a density program."""
    out = {}
    for k in np.nonzero(kmaterials["density_program"] > 0)[0]:
        tri = positions[material == k]
        if tri.size:
            p = tri.reshape(-1, 3)
            out[int(k)] = (p.min(axis=0), p.max(axis=0))
    return out


def bound_media(device, args: dict, svm: np.ndarray, kmaterials: np.ndarray,
                boxes: dict, specialize: bool = True, seed: int = 0) -> None:
    """Sets kmaterials["majorant"] of every medium in ``boxes`` (material -> its box): the
    largest density of BOUND_CELLS^3 samples over the box times BOUND_PADDING (0: a clear
    medium); ``args``: the scene's buffers (device_scene.SCENE_BUFFERS)."""
    import pyopencl as cl
    if not boxes:
        return
    programs = [int(kmaterials["density_program"][k]) for k in boxes]
    prog = device.programs.get("light/world_map.cl",
                               bound_defines(svm, programs) if specialize else {})
    kernel = prog.launch("medium_bound", "medium bound")
    out = device.buffer(4, "medium bound")
    q = device.queue
    n = BOUND_CELLS
    for k, (lo, hi) in boxes.items():
        zero = np.zeros(1, np.uint32)
        cl.enqueue_copy(q, out, zero)
        kernel(q, n ** 3, **args, mat=np.int32(k), lo=np.array([*lo, 0], np.float32),
               hi=np.array([*hi, 0], np.float32), n=np.int32(n), seed=np.uint32(seed + k),
               out=out)
        cl.enqueue_copy(q, zero, out).wait()
        top = float(zero.view(np.float32)[0])
        kmaterials["majorant"][k] = top * BOUND_PADDING if np.isfinite(top) else 1e30
    out.release()


def grid_majorants(svm: np.ndarray, kmaterials: np.ndarray, objects: np.ndarray,
                   voxels: np.ndarray, boxes: dict) -> None:
    """Sets kmaterials["majorant"] of every medium in ``boxes`` whose density is its Volume
    object's grid itself (shader_program.PROGRAM_GRID) to that grid's largest voxel (trilinear
    interpolation never exceeds it: exact, where samples of the box could miss a thin peak),
    and takes it out of ``boxes``."""
    for k in list(boxes):
        a = grid_density(svm, int(kmaterials["density_program"][k]))
        o = int(kmaterials["volume_object"][k])
        top = grid_maximum(voxels, objects, o, a) if a is not None and o >= 0 else None
        if top is not None:
            kmaterials["majorant"][k] = top
            del boxes[k]
