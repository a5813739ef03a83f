"""The statistics of one SPPM pass, and the line a user reads in Blender's status bar and in the
CLI's progress bar."""
from __future__ import annotations

import dataclasses


def phase_times(events) -> dict[str, float]:
    """Device milliseconds per timing label of a pass's (label, event) pairs."""
    ms: dict[str, float] = {}
    for label, ev in events:
        ms[label] = ms.get(label, 0.0) + (ev.profile.end - ev.profile.start) * 1e-6
    return ms


@dataclasses.dataclass
class PassStats:
    pass_index: int            # passes done, 1-based
    photons_emitted: int       # total so far
    photons_stored: int        # this pass
    photons_outside: int       # this pass: landed outside the visible points' grid
    photons_dropped: int       # this pass: did not fit the photon buffer (it grows next pass)
    occupied_entries: int      # hash entries holding at least one photon (stochastic map)
    visible_points: int
    radius_min: float
    radius_max: float
    nan_dropped: int           # total NaN/Inf contributions dropped by the kernel guards
    seconds: float             # wall time of this pass
    phase_ms: dict             # device time per phase
    active_pixels: int = 0     # pixels still sampled (adaptive sampling: 0 = all converged)
    pixels: int = 0
    indirect: str = ""         # the estimator of indirect light (options.INDIRECT_MODES, chosen)
    caustic_fraction: float | None = None   # the pilot's share of caustic first scatterings
    light_tracing: bool = False  # the photons are also connected to the camera (photon_pass.cl)
    # caustic photons only: this pass's share of them whose first scattering was a caster's
    # (aimed at the casters: most; emitted as all photons are: the casters' share of the light)
    caster_fraction: float | None = None

    @property
    def converged(self) -> bool:
        """Adaptive sampling stopped every pixel: more passes would change nothing."""
        return self.pixels > 0 and self.active_pixels == 0

    @property
    def photons_per_entry(self) -> float:
        """Mean photons per occupied entry: the stochastic map's variance grows with it."""
        return self.photons_stored / self.occupied_entries if self.occupied_entries else 0.0

    def line(self, passes: int | None = None, elapsed: float | None = None,
             time_limit: float = 0.0) -> str:
        """The stats a user reads: "Pass 12/64 · 3.1M photons · r 0.012–0.034 · 2.4 s · 18 s
        left" (remaining time from the pass rate, or the time limit if that comes first)."""
        of = f"/{passes}" if passes else ""
        s = f"Pass {self.pass_index}{of}"
        if self.indirect == "paths":
            # path-traced indirect light; photons (if any) only for caustics
            s += " · paths"
            if self.photons_emitted:
                s += f" + {_si(self.photons_emitted)} caustic photons"
        else:
            s += f" · {_si(self.photons_emitted)} photons"
        if self.light_tracing and self.photons_emitted:
            s += " + light tracing"
        if self.caster_fraction is not None and self.photons_emitted:
            s += f" · {100 * self.caster_fraction:.3g} % reach a caster"
        if self.radius_max > 0:
            s += f" · r {self.radius_min:.3g}–{self.radius_max:.3g}"
        if elapsed is not None:
            s += f" · {elapsed:.1f} s"
            left = []
            if passes and self.pass_index:
                left.append(elapsed / self.pass_index * (passes - self.pass_index))
            if time_limit > 0:
                left.append(max(time_limit - elapsed, 0.0))
            if left:
                s += f" · {min(left):.0f} s left"
        if self.pixels and self.active_pixels < self.pixels:
            s += f" · {100 * (1 - self.active_pixels / self.pixels):.0f} % converged"
        if self.nan_dropped:
            s += f" · {self.nan_dropped} NaN/Inf dropped"
        return s


def _si(n: float) -> str:
    for unit, div in (("G", 1e9), ("M", 1e6), ("K", 1e3)):
        if n >= div:
            return f"{n / div:.1f}{unit}"
    return str(int(n))
