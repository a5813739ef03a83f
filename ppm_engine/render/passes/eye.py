"""The eye pass (kernels/integrator/eye_pass.cl): one jittered camera ray per pixel through the
closures paths follow to a hit whose closures the gather evaluates, where it stores a visible point
and adds direct light."""
from __future__ import annotations

import numpy as np

from ppm_engine.render.device import SHADING_GROUP
from ppm_engine.render.device.program import in_pieces


class VisiblePoints:
    """Per pixel, 64 bytes, what the gather needs (kernels/integrator/gather.cl): position (w: 0
    none, 1 a visible point, 2 one whose closures transmit), shading normal, the path weight (the
    photon term's factor), and the hit it shades again (barycentrics, BVH leaf, the view direction
    packed; leaf -1 for a Lambert point, whose constant f is in the path weight); and 16 bytes
    of the gather's result."""
    BYTES = 64

    def __init__(self, device, n: int):
        self.n = n
        self.pos = device.buffer(16 * n, "visible points")
        self.nrm = device.buffer(16 * n, "visible points")
        self.beta = device.buffer(16 * n, "visible points")
        self.shade = device.buffer(16 * n, "visible points")
        self.gathered = device.buffer(16 * n, "gather results")


class EyePass:
    # initial radius when options.initial_radius == 0: this many pixel footprints at the point
    AUTO_RADIUS_PIXELS = 2.0

    def __init__(self, scene, program, film, vps: VisiblePoints, counters):
        """``scene``: the DeviceScene; ``program``: eye_pass.cl built for its features."""
        self.scene, self.film, self.vps, self.counters = scene, film, vps, counters
        self.kernel = program.launch("eye_pass", "eye")

    def enqueue(self, q, pass_index: int, options, path_indirect: bool = False,
                lt_kappa: float = 0.0, interrupt=None, piece: int = 1 << 15) -> list | None:
        """``path_indirect``: indirect light by eye paths (kernels/integrator/indirect_paths.h);
        ``lt_kappa`` > 0: the photons' light tracing is on,
        and a visible point the camera sees directly weighs its merge against it (eye_pass.cl,
        camera_connect.h merge_factor).

        ``interrupt``: a function asked between launches over consecutive ranges of about
        ``piece`` pixels, each waited for (device.program.in_pieces); when it returns True the
        pass stops there and None is returned (the viewport: a new view is waiting, this
        pass's work is dropped)."""
        def launch(count, start):
            return self._launch(q, count, start, pass_index, options, path_indirect, lt_kappa)
        return in_pieces(launch, self.vps.n, piece, interrupt, self.kernel.label)

    def _launch(self, q, count: int, start: int, pass_index: int, options, path_indirect: bool,
                lt_kappa: float):
        f, v = self.film, self.vps
        return self.kernel(
            q, count, SHADING_GROUP, offset=start, **self.scene.args,
            pass_index=np.uint32(pass_index),
            seed=np.uint32(options.seed), initial_radius=np.float32(options.initial_radius),
            auto_radius_pixels=np.float32(self.AUTO_RADIUS_PIXELS),
            filter_table=self.scene.filter_table, direct=f.direct_pass, radius=f.radius,
            radius0=f.radius0, vp_pos=v.pos, vp_nrm=v.nrm, vp_beta=v.beta, vp_shade=v.shade,
            counters=self.counters, aux_albedo=f.aux_albedo, aux_normal=f.aux_normal,
            active=f.active, transparency=f.transparency,
            path_indirect=np.uint32(path_indirect), lt_kappa=np.float32(lt_kappa))
