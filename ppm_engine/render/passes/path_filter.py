"""Path space filtering of the eye paths' light past their second vertex
(kernels/integrator/path_filter.cl; Keller, Dahm and Binder 2016, "Path Space Filtering"): after
the eye pass, the records it made (kernels/integrator/indirect_paths.h PathRecord) are grouped by
grid cell, orientation and path state, and each pixel gets its group's mean in place of its own
estimate of what its path found past its second vertex.

The cell's size: from the first pass's records, the smallest of a ladder of sizes (steps of
sqrt 2) at which their groups hold CELL_RECORDS records on average (their own spread: no scene
scale to guess; a subsample of at most SAMPLE records stands for them, its sizes scaled by the
square root of its share, as records lie on surfaces), then shrunk pass by pass as the photons'
radii are (Knaus & Zwicker's schedule with the render's alpha, options.global_radius_scale),
with a random offset each pass."""
from __future__ import annotations

import dataclasses

import numpy as np

from ppm_engine.render.device.program import in_pieces
from ppm_engine.render.options import global_radius_scale
from ppm_engine.render.passes.context import Iteration, PassContext

PF_WORDS = 8          # a table entry's words (path_filter.cl)
# roulette_only: the share of the records on their LEVELS_TOP most common values that makes a
# scene's noise the roulette's (measured on the first pass: the furnace 0.50 at 128 x 128 and
# 0.58 at 16 x 16, the tests' coarse furnace 0.30-0.35; lifted_caustic 0.18, the Cornell box 0.08
# at 128 x 128)
LEVELS_TOP, LEVELS_SHARE, LEVELS_RECORDS = 16, 0.25, 256


def cell_for(pos: np.ndarray, state: np.ndarray, records: float) -> float | None:
    """The smallest cell size of the ladder at which the records (positions ``pos``, path states
    ``state``) fall into groups (cell, state) of ``records`` on average; None without two."""
    if len(pos) < 2:
        return None
    p = pos.astype(np.float64)
    lo = p.min(axis=0)
    extent = float(np.max(p.max(axis=0) - lo))
    if not extent > 0 or not np.isfinite(extent):
        return None
    _, state = np.unique(state, return_inverse=True)

    def mean_records(c: float) -> float:
        cells = np.floor((p - lo) / c).astype(np.int64)          # < 2^21 a side (the ladder)
        key = (cells[:, 0] << 42) | (cells[:, 1] << 21) | cells[:, 2]
        return len(p) / len(np.unique(key ^ (state * -7046029254386353131)))  # (mixed)

    # the ladder extent * 2^(-k/2), k = 0 .. 40: the last k whose groups hold enough (the mean
    # falls as the cells shrink); bisection
    lo_k, hi_k = 0, 40                      # mean_records(lo_k) >= records is the invariant
    if mean_records(extent * 2.0 ** (-hi_k / 2)) >= records:
        return extent * 2.0 ** (-hi_k / 2)
    while hi_k - lo_k > 1:
        mid = (lo_k + hi_k) // 2
        if mean_records(extent * 2.0 ** (-mid / 2)) >= records:
            lo_k = mid
        else:
            hi_k = mid
    return extent * 2.0 ** (-lo_k / 2)


def roulette_only(v: np.ndarray) -> bool:
    """Whether the records' values ``v`` (rows of rgb) that are not zero fall on so few values
    (to 1 %) that their noise is all the Russian roulette's: LEVELS_TOP of them hold LEVELS_SHARE
    of the records, judged from LEVELS_RECORDS records on (fewer: no).  A white furnace, lit the
    same everywhere, is such a scene: a path's light past x2 depends on how long it lives alone,
    and the pixel's own roulette number, low-discrepancy over the passes, removes that noise
    faster than the filter's average over other pixels' paths (the bench's furnace at 4 s:
    error 0.0025 without, 0.0054 with)."""
    s = np.asarray(v, np.float64).sum(axis=1)
    s = s[np.isfinite(s) & (s > 0)]
    if len(s) < LEVELS_RECORDS:
        return False
    _, count = np.unique(np.round(np.log(s) / np.log(1.01)), return_counts=True)
    return np.sort(count)[::-1][:LEVELS_TOP].sum() >= LEVELS_SHARE * len(s)


class PathFilter:
    # the records per group the first pass's cell size aims at
    CELL_RECORDS = 32.0
    # records the first pass's choice reads back at most
    SAMPLE = 1 << 14
    # the filter stops once its cells have shrunk to hold this many records a group on average
    # (the first pass's CELL_RECORDS times the area's shrink): past it, it would average little
    # and fill its table; the passes after are the unfiltered estimator's (with alpha 0.7 from
    # some 13,000 passes on: 4.4 a group at 1,000)
    RECORDS_MIN = 2.0

    def __init__(self, ctx: PassContext, n: int):
        dev = ctx.device
        self.ctx, self.n = ctx, int(n)
        self.pos = dev.buffer(16 * self.n, "path filter records")
        self.v = dev.buffer(16 * self.n, "path filter records")
        self.w = dev.buffer(16 * self.n, "path filter records")
        self.slot = dev.buffer(4 * self.n, "path filter records")
        # a group per CELL_RECORDS records at the first pass, more as the cells shrink, at most
        # one per RECORDS_MIN (then the filter stops): as many entries as pixels keeps the
        # table at most half full (a probe that runs out leaves a record its own value)
        self.table_size = 1 << max(4, int(self.n - 1).bit_length())
        self.table = dev.buffer(4 * PF_WORDS * self.table_size, "path filter table")
        self.stride = max(1, -(-self.n // self.SAMPLE))
        self.sampled = dev.buffer(16 * -(-self.n // self.stride), "path filter records")
        self.sampled_v = dev.buffer(16 * -(-self.n // self.stride), "path filter records")
        p = dev.programs.get("integrator/path_filter.cl",
                             {"PPM_INT64_ATOMICS": True} if dev.int64_atomics else {})
        self.k_insert = p.launch("pf_insert", "filter")
        self.k_resolve = p.launch("pf_resolve", "filter")
        self.k_sample = p.launch("pf_sample", "filter")
        self.cell0 = None    # the first pass's cell size (None: not chosen yet)
        self.active = True   # False: roulette_only found the filter of no use in this render

    @classmethod
    def renew(cls, old: PathFilter | None, ctx: PassContext, n: int, on: bool
              ) -> PathFilter | None:
        """The filter for a new render of ``n`` pixels on ``ctx``: None where it has none
        (``on`` false: no eye paths for the indirect light, or RenderOptions.path_filter off),
        else ``old`` (its buffers) where it has as many pixels, with a new choice of cell
        size."""
        if not on:
            return None
        if old is None or old.n != n or old.ctx.device is not ctx.device:
            return cls(ctx, n)
        old.ctx, old.cell0, old.active = ctx, None, True
        return old

    def wanted(self, it: Iteration) -> bool:
        """Whether pass ``it`` filters: the filter on (``active``) and its cells not yet shrunk
        below RECORDS_MIN records a group (a function of the pass's index alone, as the
        cells)."""
        s = global_radius_scale(it.pass_index, it.options.alpha)
        return self.active and s * s * self.CELL_RECORDS >= self.RECORDS_MIN

    @property
    def eye_args(self) -> dict:
        """The eye pass's arguments for its records."""
        return dict(path_filter=np.uint32(1), pf_pos=self.pos, pf_v=self.v, pf_w=self.w)

    def prepare(self, q, eye, it: Iteration) -> None:
        """Before the pass's eye pass: where passes are independent (a pass range, a device's
        share) and this render starts past pass 0, the cell size comes from pass 0's records as
        it would on a render that runs it: an eye pass of pass 0 first, only for them."""
        if self.cell0 is None and it.pass_index != 0 and it.options.radius_schedule == "global":
            it0 = dataclasses.replace(it, pass_index=0, interrupt=None)
            in_pieces(lambda count, start: eye.launch(q, count, start, it0, self), self.n,
                      it.piece, None, "eye")
            self.cell0 = self._choose_cell(q)

    def _choose_cell(self, q) -> float | None:
        import pyopencl as cl
        m = -(-self.n // self.stride)
        self.k_sample(q, m, pf_pos=self.pos, pf_v=self.v, pf_w=self.w, n=np.uint32(m),
                      stride=np.uint32(self.stride), pos=self.sampled, v=self.sampled_v)
        pos, v = np.empty((m, 4), np.float32), np.empty((m, 4), np.float32)
        cl.enqueue_copy(q, pos, self.sampled)
        cl.enqueue_copy(q, v, self.sampled_v)
        ok = np.isfinite(pos[:, 0])
        self.active = not roulette_only(v[ok, :3])
        c = cell_for(pos[ok, :3], pos[ok, 3].view(np.uint32), self.CELL_RECORDS)
        # the subsample's share of the records, on surfaces: sizes by its square root
        return None if c is None else c / np.sqrt(self.stride)

    def enqueue(self, q, it: Iteration) -> list:
        """After the eye pass: each record's group mean into its pixel's sample (film
        direct_pass), or its own value where the filter is off (roulette_only, ``wanted``)."""
        import pyopencl as cl
        o = it.options
        if self.cell0 is None:
            self.cell0 = self._choose_cell(q)     # (None: too few records yet, the next pass)
        if self.cell0 is None or not self.active:     # (the eye pass asked wanted())
            return [(self.k_resolve.label, self.k_resolve(
                q, self.n, pf_v=self.v, pf_w=self.w, pf_slot=self.slot, table=self.table,
                direct_pass=self.ctx.film.direct_pass, n=np.uint32(self.n), own=np.uint32(1)))]
        cell = self.cell0 * global_radius_scale(it.pass_index, o.alpha)
        rng = np.random.default_rng([o.seed, it.pass_index, 0x5046])
        u = rng.random(5)
        grid = np.array([*(u[:3] * cell), cell], np.float32)
        jitter = np.array([u[3], u[4], 0, 0], np.float32)
        n = np.uint32(self.n)
        clear = cl.enqueue_fill_buffer(q, self.table, np.uint32(0), 0, self.table.size)
        return [("filter", clear)] + [(k.label, ev) for k, ev in (
            (self.k_insert, self.k_insert(q, self.n, pf_pos=self.pos, pf_v=self.v, pf_w=self.w,
                                          n=n, grid=grid, jitter=jitter, table=self.table,
                                          mask=np.uint32(self.table_size - 1),
                                          pf_slot=self.slot)),
            (self.k_resolve, self.k_resolve(q, self.n, pf_v=self.v, pf_w=self.w,
                                            pf_slot=self.slot, table=self.table,
                                            direct_pass=self.ctx.film.direct_pass, n=n,
                                            own=np.uint32(0))))]
