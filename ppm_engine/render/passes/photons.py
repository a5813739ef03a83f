"""The photon pass (kernels/integrator/photon_pass.cl): photons leave the emitters in proportion to
their power and are stored at diffuse hits after the first, inside this pass's grid."""
from __future__ import annotations

import numpy as np

from ppm_engine.render.device import SHADING_GROUP
from ppm_engine.render.device.program import in_pieces
from ppm_engine.render.film import FILM_BUFFERS

# the photon pass's mode bits (kernels/integrator/photon_pass.cl PHOTONS_*)
PHOTONS_CAUSTIC = 1     # only photons whose first scattering is a caster's live on
PHOTONS_AIMED = 2       # emitted toward the casters (kernels/light/aim.h)


class PhotonPass:
    def __init__(self, scene, program, photon_map, counters):
        """``scene``: the DeviceScene; ``program``: photon_pass.cl built for its features."""
        self.scene, self.photon_map, self.counters = scene, photon_map, counters
        self.kernel = program.launch("photon_pass", "photon")

    def enqueue(self, q, pass_index: int, options, n_photons: int, caustics_only: bool = False,
                pilot: bool = False, film=None, lt_kappa: float = 0.0, interrupt=None,
                piece: int = 1 << 15) -> list | None:
        """``caustics_only``: only photons whose first scattering is caustic live on (indirect
        light by eye paths), emitted toward the casters (DeviceScene.set_casters) unless
        ``options.skip_unaimed_caustics`` is off; ``pilot``: photons emitted as all are, only
        counted at their first scattering (Counter.CAUSTIC), none stored.
        ``lt_kappa`` > 0 (with ``film``): every stored photon is also connected to the camera
        and splatted into film.lt_pass, weighted against the merge
        (kernels/integrator/photon_pass.cl connect_camera; Renderer.light_tracing_kappa).
        ``interrupt``: as EyePass.enqueue's, over ranges of about ``piece`` photons."""
        def launch(count, start):
            return self._launch(q, count, start, pass_index, options, n_photons,
                                caustics_only, pilot, film, lt_kappa)
        return in_pieces(launch, n_photons, piece, interrupt, self.kernel.label)

    def _launch(self, q, count: int, start: int, pass_index: int, options, n_photons: int,
                caustics_only: bool, pilot: bool, film, lt_kappa: float):
        pm = self.photon_map
        lt = film is not None and lt_kappa > 0 and not pilot
        # the film's buffers, read only where light tracing is on: any buffer stands for them
        # without a film
        film_args = film.args if film is not None else dict.fromkeys(
            (f"film_{b.name}" for b in FILM_BUFFERS), pm.ph_pos)
        return self.kernel(
            q, count, SHADING_GROUP, offset=start, **self.scene.args, **film_args, **pm.args,
            pass_index=np.uint32(pass_index), seed=np.uint32(options.seed),
            n_photons=np.uint32(n_photons), capacity=np.uint32(0 if pilot else pm.capacity),
            counters=self.counters, mode=np.uint32(
                (PHOTONS_CAUSTIC if caustics_only or pilot else 0)
                | (PHOTONS_AIMED if caustics_only and not pilot and options.skip_unaimed_caustics
                   else 0)),
            lt_filter=self.scene.filter_density, lt_reach=np.float32(self.scene.filter_reach),
            lt_kappa=np.float32(lt_kappa if lt else 0.0))
