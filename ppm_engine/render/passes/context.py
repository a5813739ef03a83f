"""The one shape of every pass: built on a ``PassContext`` (the device and one render's buffers),
run by ``enqueue(q, it)`` with an ``Iteration`` (one SPPM pass's settings), which returns the
launches as (timing label, event) pairs, or None where ``it.interrupt`` stopped the pass."""
from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any


@dataclasses.dataclass(frozen=True)
class PassContext:
    """What the passes of one render are built on; a pass reads the buffers at ``enqueue``, so
    a photon map that grows (PhotonMap.allocate) needs no new pass.  Kernel tests and micro
    benchmarks give only what their passes read: without ``scene`` the gather sums plain flux,
    without ``film`` (or ``vps``) a pass that does not read them binds any buffer instead."""
    device: Any
    scene: Any = None              # the DeviceScene
    defines: dict | None = None    # its kernel flags (DeviceScene.kernel_defines)
    film: Any = None               # the Film
    vps: Any = None                # the VisiblePoints (passes/eye.py)
    photon_map: Any = None         # the PhotonMap
    counters: Any = None           # the counters' buffer (ppm_engine/render/counters.py)
    radius: Any = None             # each visible point's radius: the film's unless given
    guide_stats: Any = None        # the photon guides' stores per bin (Renderer.learn_guides)

    def __post_init__(self):
        if self.radius is None and self.film is not None:
            object.__setattr__(self, "radius", self.film.radius)


@dataclasses.dataclass(frozen=True)
class Iteration:
    """One SPPM pass's settings, the same for every pass of it (each reads what it needs)."""
    pass_index: int
    options: Any                   # the RenderOptions (seed, radii, alpha, noise threshold ...)
    photons: int = 0               # photons emitted this pass (0: no photon pass)
    path_indirect: bool = False    # indirect light by eye paths: photons only for caustics
    lt_kappa: float = 0.0          # > 0: the photons' light tracing is on (its MIS factor)
    guided: bool = False           # the guided lights' photons from their learned bins
    volume_photons: bool = False   # photons stored in media, gathered along the camera's
                                   # segments (passes/volume.py)
    # asked between launches of about ``piece`` pixels or photons (device.program.in_pieces);
    # True stops the pass there
    interrupt: Callable[[], bool] | None = None
    piece: int = 1 << 15
