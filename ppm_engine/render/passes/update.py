"""The progressive update (kernels/integrator/progressive.cl, Hachisuka & Jensen 2009): N and R per
pixel from this pass's gather, the photon sum S = sum of Phi / R^2, and the end of a pass: its
direct sample into the film's sums and its whole sample into the per-pixel moments (each pixel's own
photon count and noise); adaptive sampling stops pixels whose noise is low enough."""
from __future__ import annotations

import numpy as np

from ppm_engine.render.options import RADIUS_SCHEDULES
from ppm_engine.render.passes.eye import VP_BUFFERS


class ProgressiveUpdate:
    # adaptive sampling (options.noise_threshold > 0): pixels are judged from this many passes
    # on, every ADAPTIVE_EVERY passes
    ADAPTIVE_MIN_PASSES = 32
    ADAPTIVE_EVERY = 8
    # a pixel with photons stops only once its radius has shrunk to this fraction of the initial
    # one: the per-pass spread cannot see the radius' bias (a blurred caustic or contact shadow
    # is smooth, not noisy), so a pixel must not stop while it is large
    ADAPTIVE_MAX_RADIUS = 0.5

    def __init__(self, device, film):
        self.film = film
        p = film.prog
        self.k_update = p.launch("film_update", "update")
        self.k_add = p.launch("film_add_sample", "update")
        self.k_error = p.launch("film_error", "adaptive")
        self.k_converge = p.launch("film_converge", "adaptive")

    def update(self, q, vps, alpha: float, schedule: str = "pixel") -> list:
        """S from this pass's gather (``vps``: passes/eye.py VisiblePoints, its gathered), N and R
        for the next by ``schedule`` (a RenderOptions.radius_schedule); leaves this pass's photon
        term in vps.gathered for add_sample."""
        f = self.film
        return [("update", self.k_update(q, f.n_pixels, **f.args, **vps.args,
                                         alpha=np.float32(alpha),
                                         schedule=np.uint32(RADIUS_SCHEDULES.index(schedule)),
                                         n=np.uint32(f.n_pixels)))]

    def add_sample(self, q, vps=None, photons: int = 0, light_traced: bool = False) -> list:
        """This pass's direct sample (film.direct_pass) into the sums, and the pass's sample
        (direct + the photon term in vps.gathered over ``photons`` emitted) into the moments,
        for active pixels; ``light_traced``: also the photons' light tracing of this pass
        (film.lt_pass, cleared for the next) into its sum.  Without ``vps`` (no photons) any
        buffer stands for the visible points', which are not read."""
        f = self.film
        f.photons_emitted += photons
        vp_args = vps.args if vps is not None else dict.fromkeys(
            (f"vp_{b.name}" for b in VP_BUFFERS), f.direct_pass)
        return [("update", self.k_add(q, f.n_pixels, **f.args, **vp_args,
                                      photons=np.uint32(photons),
                                      lt=np.uint32(light_traced and photons > 0),
                                      n=np.uint32(f.n_pixels)))]

    def due(self, passes_done: int, threshold: float) -> bool:
        """Whether adaptive sampling judges the pixels after pass ``passes_done``."""
        return (threshold > 0 and passes_done >= self.ADAPTIVE_MIN_PASSES
                and passes_done % self.ADAPTIVE_EVERY == 0)

    def converge(self, q, threshold: float, counters) -> list:
        """Pixels whose 3x3 neighbourhood's estimated error is at most ``threshold`` stop being
        sampled; counters[Counter.ACTIVE] += the pixels still active."""
        f = self.film
        e1 = self.k_error(q, f.n_pixels, **f.args, max_radius=np.float32(self.ADAPTIVE_MAX_RADIUS),
                          min_passes=np.uint32(self.ADAPTIVE_MIN_PASSES), n=np.uint32(f.n_pixels))
        e2 = self.k_converge(q, f.n_pixels, wait_for=[e1], **f.args, width=np.int32(f.width),
                             height=np.int32(f.height), threshold=np.float32(threshold),
                             counters=counters)
        return [("adaptive", e1), ("adaptive", e2)]

