"""The progressive update (kernels/integrator/progressive.cl, Hachisuka & Jensen 2009): N and R per
pixel from this pass's gather, the photon sum S = sum of Phi / R^2, and the end of a pass: its
direct sample into the film's sums and its whole sample into the per-pixel moments (each pixel's own
photon count and noise); adaptive sampling stops pixels whose noise is low enough.  Three passes:
RadiusUpdate, AddSample and Converge."""
from __future__ import annotations

import numpy as np

from ppm_engine.render.options import RADIUS_SCHEDULES
from ppm_engine.render.passes.context import Iteration, PassContext
from ppm_engine.render.passes.eye import VP_BUFFERS


class ProgressiveUpdate:
    """What the progressive update's three passes share (RadiusUpdate, AddSample, Converge):
    the film, whose program (progressive.cl) holds their kernels, and adaptive sampling's
    settings."""
    # adaptive sampling (options.noise_threshold > 0): pixels are judged from this many passes
    # on, every ADAPTIVE_EVERY passes
    ADAPTIVE_MIN_PASSES = 32
    ADAPTIVE_EVERY = 8
    # a pixel with photons stops only once its radius has shrunk to this fraction of the initial
    # one: the per-pass spread cannot see the radius' bias (a blurred caustic or contact shadow
    # is smooth, not noisy), so a pixel must not stop while it is large
    ADAPTIVE_MAX_RADIUS = 0.5

    def __init__(self, ctx: PassContext):
        self.ctx, self.film = ctx, ctx.film


class RadiusUpdate(ProgressiveUpdate):
    def __init__(self, ctx: PassContext):
        super().__init__(ctx)
        self.kernel = self.film.prog.launch("film_update", "update")

    def enqueue(self, q, it: Iteration) -> list:
        """S from this pass's gather (``ctx.vps``: passes/eye.py VisiblePoints, its gathered),
        N and R for the next by ``options.radius_schedule`` (its alpha); leaves this pass's
        photon term in vps.gathered for AddSample."""
        f, o = self.film, it.options
        return [("update", self.kernel(q, f.n_pixels, **f.args, **self.ctx.vps.args,
                                       alpha=np.float32(o.alpha),
                                       schedule=np.uint32(RADIUS_SCHEDULES.index(
                                           o.radius_schedule)),
                                       n=np.uint32(f.n_pixels)))]


class AddSample(ProgressiveUpdate):
    def __init__(self, ctx: PassContext):
        super().__init__(ctx)
        self.kernel = self.film.prog.launch("film_add_sample", "update")

    def enqueue(self, q, it: Iteration) -> list:
        """This pass's direct sample (film.direct_pass) into the sums, and the pass's sample
        (direct + the photon term in vps.gathered over ``it.photons`` emitted) into the moments,
        for active pixels; with ``it.lt_kappa`` > 0 also the photons' light tracing of this pass
        (film.lt_pass, cleared for the next) into its sum.  Without ``ctx.vps`` (no photons) any
        buffer stands for the visible points', which are not read."""
        f, vps, photons = self.film, self.ctx.vps, it.photons
        f.photons_emitted += photons
        vp_args = vps.args if vps is not None else dict.fromkeys(
            (f"vp_{b.name}" for b in VP_BUFFERS), f.direct_pass)
        return [("update", self.kernel(q, f.n_pixels, **f.args, **vp_args,
                                       photons=np.uint32(photons),
                                       lt=np.uint32((it.lt_kappa > 0 or it.volume_photons)
                                                    and photons > 0),
                                       n=np.uint32(f.n_pixels)))]


class Converge(ProgressiveUpdate):
    def __init__(self, ctx: PassContext):
        super().__init__(ctx)
        p = self.film.prog
        self.k_error = p.launch("film_error", "adaptive")
        self.k_converge = p.launch("film_converge", "adaptive")

    def due(self, it: Iteration) -> bool:
        """Whether adaptive sampling judges the pixels after this pass (``options
        .noise_threshold`` > 0)."""
        done = it.pass_index + 1
        return (it.options.noise_threshold > 0 and done >= self.ADAPTIVE_MIN_PASSES
                and done % self.ADAPTIVE_EVERY == 0)

    def enqueue(self, q, it: Iteration) -> list:
        """Pixels whose 3x3 neighbourhood's estimated error is at most ``options
        .noise_threshold`` stop being sampled; counters[Counter.ACTIVE] += the pixels still
        active."""
        f = self.film
        e1 = self.k_error(q, f.n_pixels, **f.args, max_radius=np.float32(self.ADAPTIVE_MAX_RADIUS),
                          min_passes=np.uint32(self.ADAPTIVE_MIN_PASSES), n=np.uint32(f.n_pixels))
        e2 = self.k_converge(q, f.n_pixels, wait_for=[e1], **f.args, width=np.int32(f.width),
                             height=np.int32(f.height),
                             threshold=np.float32(it.options.noise_threshold),
                             counters=self.ctx.counters)
        return [("adaptive", e1), ("adaptive", e2)]
