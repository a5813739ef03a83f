"""The eye pass (kernels/integrator/eye_pass.cl): one jittered camera ray per pixel through the
closures paths follow to a hit whose closures the gather evaluates, where it stores a visible point
and adds direct light.

VP_BUFFERS lists the visible points' buffers once: kernels/shared.h gets them as the X-macro
VP_DATA, from which kernels/integrator/pass_state.h makes the kernels' parameters (``vp_NAME``)
and the struct ``VisiblePoints`` (``const VisiblePoints *vps``); Launch binds them by name from
``VisiblePoints.args``."""
from __future__ import annotations

import numpy as np

from ppm_engine.render.device import SHADING_GROUP
from ppm_engine.render.device.program import in_pieces
from ppm_engine.render.film import PassBuffer
from ppm_engine.render.options import global_radius_scale
from ppm_engine.render.passes.context import Iteration, PassContext

_F4 = np.dtype((np.float32, 4))

# The visible points' buffers, in the kernels' parameter order (vp_NAME).
VP_BUFFERS = (
    PassBuffer("pos", _F4, 16, "position; w: 0 none, 1 a visible point, 2 one that transmits"),
    PassBuffer("nrm", _F4, 16, "the surface's normal; w: the path (path_state.h), as bits"),
    PassBuffer("beta", _F4, 16, "the path weight (the photon term's factor); w: the footprint"),
    PassBuffer("shade", _F4, 16, "the hit shaded again: u, v, BVH leaf (-1: Lambert), wi packed"),
    PassBuffer("gathered", _F4, 16, "the gather's result: (sum of flux x f, photons)"),
    # allocated for volume photons only (allocate_segments; passes/volume.py VOLUME_SEGMENTS)
    PassBuffer("segments", _F4, 0, "media segments: (o, t), (d, field), (weight, path), "
               "(sigma_t, g)"),
)


class VisiblePoints:
    """Per pixel, 64 bytes, what the gather needs (kernels/integrator/gather.cl): position (w: 0
    none, 1 a visible point, 2 one whose closures transmit), shading normal, the path weight (the
    photon term's factor), and the hit it shades again (barycentrics, BVH leaf, the view direction
    packed; leaf -1 for a Lambert point, whose constant f is in the path weight); and 16 bytes
    of the gather's result.  ``given``: device buffers to use for some of VP_BUFFERS (kernel
    tests), the others allocated."""
    BYTES = 64

    def __init__(self, device, n: int, **given):
        unknown = set(given) - {b.name for b in VP_BUFFERS}
        if unknown:
            raise TypeError(f"not visible points' buffers: {sorted(unknown)}")
        self.n = n
        for b in VP_BUFFERS:
            setattr(self, b.name, given[b.name] if b.name in given else
                    device.buffer(b.bytes * n, "gather results" if b.name == "gathered"
                                  else "visible points"))
        self.device = device

    def allocate_segments(self, per_pixel: int) -> None:
        """The camera's segments in media, ``per_pixel`` of 64 bytes per pixel (the eye pass
        keeps them for the volume photons' gather, passes/volume.py)."""
        if getattr(self, "segment_count", 0) != per_pixel:
            self.segments = self.device.buffer(64 * per_pixel * self.n, "camera's segments")
            self.segment_count = per_pixel

    @property
    def args(self) -> dict:
        """The buffers by the kernels' parameter names (vp_NAME; VP_BUFFERS)."""
        return {f"vp_{b.name}": getattr(self, b.name) for b in VP_BUFFERS}


class EyePass:
    # initial radius when options.initial_radius == 0: this many pixel footprints at the point
    AUTO_RADIUS_PIXELS = 2.0

    def __init__(self, ctx: PassContext):
        """eye_pass.cl built for the scene's features (``ctx.defines``)."""
        self.ctx = ctx
        self.kernel = ctx.device.programs.get("integrator/eye_pass.cl", ctx.defines).launch(
            "eye_pass", "eye")
        # the path space filter (passes/path_filter.py PathFilter), which the pass runs after
        # its eye paths where they bring the indirect light, or None
        self.records = None

    def enqueue(self, q, it: Iteration) -> list | None:
        """``it.path_indirect``: indirect light by eye paths
        (kernels/integrator/indirect_paths.h); ``it.lt_kappa`` > 0: the photons' light tracing
        is on, and a visible point the camera sees directly weighs its merge against it
        (eye_pass.cl, camera_connect.h merge_factor).

        ``it.interrupt``: a function asked between launches over consecutive ranges of about
        ``it.piece`` pixels, each waited for (device.program.in_pieces); when it returns True
        the pass stops there and None is returned (the viewport: a new view is waiting, this
        pass's work is dropped)."""
        records = self._records(it)
        if records is not None:
            records.prepare(q, self, it)
            records = self._records(it)       # (pass 0's records may have turned it off)

        def launch(count, start):
            return self.launch(q, count, start, it, records)
        events = in_pieces(launch, self.ctx.vps.n, it.piece, it.interrupt, self.kernel.label)
        if events is not None and records is not None:
            events += records.enqueue(q, it)    # the path space filter (passes/path_filter.py)
        return events

    def _records(self, it: Iteration):
        """The path space filter this pass records for: where eye paths bring the indirect
        light and the filter is on for this pass (PathFilter.wanted: not turned off by its first
        pass, its cells not shrunk past use)."""
        r = self.records
        return r if r is not None and it.path_indirect and r.wanted(it) else None

    def launch(self, q, count: int, start: int, it: Iteration, records=None):
        """One launch of the eye pass over ``count`` pixels from ``start``; ``records``: the
        path space filter it records for (_records), or None."""
        c, o = self.ctx, it.options
        return self.kernel(
            q, count, SHADING_GROUP, offset=start, **c.scene.args, **c.film.args,
            **c.vps.args, pass_index=np.uint32(it.pass_index), seed=np.uint32(o.seed),
            initial_radius=np.float32(o.initial_radius),
            auto_radius_pixels=np.float32(self.AUTO_RADIUS_PIXELS),
            radius_scale=np.float32(global_radius_scale(it.pass_index, o.global_alpha)
                                    if o.radius_schedule == "global" else 0.0),
            filter_table=c.scene.filter_table, counters=c.counters,
            path_indirect=np.uint32(it.path_indirect), lt_kappa=np.float32(it.lt_kappa),
            volume_photons=np.uint32(it.volume_photons),
            **(records.eye_args if records is not None
               else dict(path_filter=np.uint32(0), pf_pos=c.vps.pos, pf_v=c.vps.pos,
                         pf_w=c.vps.pos)))
