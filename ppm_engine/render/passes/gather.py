"""The gather (kernels/integrator/gather.cl): each visible point reads the cells its disc overlaps,
one photon per cell (the entry's photon stands for its n photons), or every photon of the entry in
the exact reference mode; each photon weighted by the point's BSDF for its direction."""
from __future__ import annotations

import numpy as np

from ppm_engine.render.device import SHADING_GROUP
from ppm_engine.render.device_scene import placeholders
from ppm_engine.render.passes.context import Iteration, PassContext

# photons on a surface facing another way (thin walls, corners) are not a visible point's: the
# least cosine between their normals (kernels/integrator/gather.cl, reference.py)
NORMAL_COS_MIN = 0.5
# the gather region is a disc: photons farther than this x r from the visible point's tangent
# plane are not its own (kernels/integrator/gather.cl says why)
DISC_HALF_THICKNESS = 0.25
# cells per axis a gather visits at most (the grid keeps cell >= r_max / 2: 5)
MAX_CELLS_PER_AXIS = 5

# the flags that change the gather: its shading of a visible point (the rest, lights, camera,
# ray offsets, are the eye and photon passes'); fewer programs to build
_SHADING_DEFINES = {"PPM_SPECIALIZED", "PPM_SHADER", "PPM_GATHER_SHADE", "PPM_MICROFACET",
                    "PPM_SHEEN", "PPM_OREN_NAYAR", "PPM_TRANSLUCENT", "PPM_TRANSPARENT",
                    "PPM_TEXTURES", "PPM_ANISOTROPY", "PPM_MAX_CLOSURES",
                    "PPM_SVM", "PPM_SVM_OPS", "PPM_SVM_STACK", "PPM_ATTRIBUTES"}


def gather_defines(defines: dict | None) -> dict:
    """The scene's kernel flags the gather needs: none but PPM_SPECIALIZED when no visible
    point is shaded (PPM_GATHER_SHADE), else its shading ones."""
    defines = defines or {}
    if defines.get("PPM_SPECIALIZED") and not defines.get("PPM_GATHER_SHADE"):
        return {"PPM_SPECIALIZED": True}
    return {k: v for k, v in defines.items() if k in _SHADING_DEFINES}


def unshaded(device, n: int):
    """The shade buffer (passes/eye.py VP_BUFFERS) of n visible points with no hit to shade:
    their f is 1, so the gather sums plain flux (kernel tests, micro benchmarks)."""
    shade = np.zeros((n, 4), np.float32)
    shade.view(np.int32)[:, 2] = -1
    return device.upload(shade, "visible points")


class Gather:
    def __init__(self, ctx: PassContext):
        """gather.cl for ``ctx.scene``'s shading (the gather shades its visible points again,
        by ``ctx.defines``, DeviceScene.kernel_defines); without a scene (kernel tests, micro
        benchmarks) every visible point's f is 1: a plain flux sum."""
        self.ctx = ctx
        device = ctx.device
        defines = {**gather_defines(ctx.defines),
                   **({"PPM_INT64_ATOMICS": True} if device.int64_atomics else {})}
        p = device.programs.get("integrator/gather.cl", defines)
        self.k_gather = p.launch("gather", "gather")
        self.k_exact = p.launch("gather_exact", "gather")
        self.scene_args = ctx.scene.args if ctx.scene is not None else placeholders(device)

    def enqueue(self, q, it: Iteration) -> list:
        """vps.gathered[i] = (sum of n x flux x f, sum of n) over the accepted entries, f the
        visible point's BSDF for the photon's direction, for each of ``ctx.vps``
        (passes/eye.py VisiblePoints: their buffers bound by name) within its radius
        (``ctx.radius``: the film's).  vps.beta's w: the visible points' ray footprints (Bump
        nodes)."""
        c = self.ctx
        pm, vps = c.photon_map, c.vps
        common = dict(**self.scene_args, **vps.args, **pm.args, radius=c.radius,
                      table_mask=pm.table_mask, n=np.uint32(vps.n), counters=c.counters)
        if pm.exact:
            ev = self.k_exact(q, vps.n, SHADING_GROUP, **common, ranges=pm.ranges,
                              sorted_ids=pm.sorted[1].data)
        else:
            ev = self.k_gather(q, vps.n, SHADING_GROUP, **common, table=pm.table)
        return [("gather", ev)]
