"""The photon pass (kernels/integrator/photon_pass.cl): photons leave the emitters in proportion to
their power and are stored at diffuse hits after the first, inside this pass's grid."""
from __future__ import annotations

import numpy as np

from ppm_engine.render.counters import N_COUNTERS, Counter
from ppm_engine.render.device import SHADING_GROUP
from ppm_engine.render.device.program import in_pieces
from ppm_engine.render.film import FILM_BUFFERS
from ppm_engine.render.passes.context import Iteration, PassContext

# the photon pass's mode bits (kernels/integrator/photon_pass.cl PHOTONS_*)
PHOTONS_CAUSTIC = 1     # only photons whose first scattering is a caster's live on
PHOTONS_AIMED = 2       # emitted toward the casters (kernels/light/aim.h)
PHOTONS_GUIDED = 4      # guided lights' directions from their learned bins (kernels/light/guide.h)


class PhotonPass:
    def __init__(self, ctx: PassContext, *, pilot: bool = False):
        """photon_pass.cl built for the scene's features (``ctx.defines``).  ``pilot``: photons
        emitted as all are, only counted at their first scattering (Counter.CAUSTIC), none
        stored (Renderer.caustic_fraction_pilot)."""
        self.ctx, self.pilot = ctx, pilot
        self.kernel = ctx.device.programs.get("integrator/photon_pass.cl", ctx.defines).launch(
            "photon_pass", "photon")

    def enqueue(self, q, it: Iteration) -> list | None:
        """``it.photons`` photons.  ``it.path_indirect``: only photons whose first scattering is
        caustic live on (indirect light by eye paths), emitted toward the casters
        (DeviceScene.set_casters) unless ``options.skip_unaimed_caustics`` is off.
        ``it.lt_kappa`` > 0 (with a film): every stored photon is also connected to the camera
        and splatted into film.lt_pass, weighted against the merge
        (kernels/integrator/photon_pass.cl connect_camera; Renderer.light_tracing_kappa).
        ``it.interrupt``: as EyePass.enqueue's, over ranges of about ``it.piece`` photons."""
        def launch(count, start):
            return self._launch(q, count, start, it)
        return in_pieces(launch, it.photons, it.piece, it.interrupt, self.kernel.label)

    def _launch(self, q, count: int, start: int, it: Iteration):
        c, o, pilot = self.ctx, it.options, self.pilot
        pm, film = c.photon_map, None if pilot else c.film
        caustics_only = it.path_indirect and not pilot
        lt = film is not None and it.lt_kappa > 0
        # the film's buffers, read only where light tracing is on: any buffer stands for them
        # without a film
        film_args = film.args if film is not None else dict.fromkeys(
            (f"film_{b.name}" for b in FILM_BUFFERS), pm.ph_pos)
        return self.kernel(
            q, count, SHADING_GROUP, offset=start, **c.scene.args, **film_args, **pm.args,
            pass_index=np.uint32(it.pass_index), seed=np.uint32(o.seed),
            n_photons=np.uint32(it.photons), capacity=np.uint32(0 if pilot else pm.capacity),
            counters=c.counters, mode=np.uint32(
                (PHOTONS_CAUSTIC if caustics_only or pilot else 0)
                | (PHOTONS_AIMED if caustics_only and o.skip_unaimed_caustics else 0)
                | (PHOTONS_GUIDED if it.guided and not pilot else 0)),
            guide_stats=c.guide_stats if c.guide_stats is not None else c.counters,
            lt_filter=c.scene.filter_density, lt_reach=np.float32(c.scene.filter_reach),
            lt_kappa=np.float32(it.lt_kappa if lt else 0.0),
            vcapacity=np.uint32(pm.vcapacity if it.volume_photons and not pilot else 0))


def caustic_fraction(ctx: PassContext, options, photons: int) -> float:
    """The share of the light's first scatterings that are by a closure eye paths follow (a
    mirror, glass, a smooth glossy lobe) rather than by the gather's closures, from ``photons``
    photons classified at their first hit and counted in ``ctx.counters`` (photon_pass.cl with
    capacity 0; photons that escape or meet a black surface count for neither): the pilot of
    Renderer.caustic_fraction_pilot."""
    import pyopencl as cl
    q = ctx.device.queue
    first = slice(Counter.CAUSTIC, Counter.DIFFUSE_FIRST + 1)
    cl.enqueue_fill_buffer(q, ctx.counters, np.uint32(0), 4 * first.start,
                           4 * (first.stop - first.start))
    PhotonPass(ctx, pilot=True).enqueue(q, Iteration(0x7FFFFFFF, options, photons=photons))
    counters = np.empty(N_COUNTERS, np.uint32)
    cl.enqueue_copy(q, counters, ctx.counters)
    cl.enqueue_fill_buffer(q, ctx.counters, np.uint32(0), 4 * first.start,
                           4 * (first.stop - first.start))
    q.finish()
    caustic, diffuse = int(counters[Counter.CAUSTIC]), int(counters[Counter.DIFFUSE_FIRST])
    return caustic / (caustic + diffuse) if caustic + diffuse else 0.0
