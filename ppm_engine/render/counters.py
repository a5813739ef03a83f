"""The device counters the passes share: one uint32 each, in one buffer.  The kernels' CNT_*
indices are generated from this table (kernels/shared.h, ppm_engine/tools/shared_header.py)."""
from __future__ import annotations

import enum

from ppm_engine.scene.casters import MAX_CASTERS


class Counter(enum.IntEnum):
    NAN = 0         # NaN/Inf samples and photons dropped by the kernel guards, whole render
    STORED = 1      # photons this pass stored (may exceed the buffer: see OVERFLOW)
    OUTSIDE = 2     # photons this pass that landed outside the visible points' grid
    OVERFLOW = 3    # photons this pass that did not fit the photon buffer
    OCCUPIED = 4    # hash entries holding at least one photon
    ACTIVE = 5      # pixels still sampled (adaptive sampling)
    SINK = 6        # the hash build's prefetch sink (never read)
    CAUSTIC = 7     # a pilot's photons whose first scattering was a followed closure (caustics)
    DIFFUSE_FIRST = 8   # a pilot's photons whose first scattering was by the gather's closures
    SEEN = 9        # the first pass's visible points the camera sees directly, where the
                    # photons' light tracing can render (counted only with it on)
    CASTER = 10     # caustic photons this pass whose first scattering was a caster's (its
                    # caustic closures: photon_pass.cl), the rest of those emitted wasted
    USED = 11       # photons this pass whose light reached the image: merged at a visible
                    # point (a non-zero term) or connected to the camera (Renderer.photons_due)
    VSTORED = 12    # volume photons this pass stored (kernels/integrator/volume_photons.h; may
                    # exceed their buffer: PhotonMap.allocate_volume)
    CASTER_STATS = 13   # the first of two per caster (MAX_CASTERS): the photons this pass aimed
                        # at it, and the photons they stored (Renderer.learn_caster_weights)


N_COUNTERS = len(Counter) - 1 + 2 * MAX_CASTERS
# reset before every pass; Counter.NAN accumulates over the render
PER_PASS = range(Counter.STORED, N_COUNTERS)
