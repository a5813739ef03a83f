"""The stochastic spatial hash build (kernels/integrator/hash_build.cl, Hachisuka & Jensen 2010):
the grid over this pass's visible points, then a table in which each entry counts its photons and
keeps one, chosen uniformly (or, in the exact reference mode, the photons sorted by entry): two
passes, GridSetup before the photon pass and HashBuild after it."""
from __future__ import annotations

import numpy as np

from ppm_engine.render.counters import Counter
from ppm_engine.render.passes.context import Iteration, PassContext

_EMPTY_LO = np.array([np.inf, np.inf, np.inf, 0], np.float32)
_EMPTY_HI = np.array([-np.inf, -np.inf, -np.inf, 0], np.float32)


class SpatialHash:
    """What the hash's two passes share: hash_build.cl, built once for the device, and the
    grid's settings."""
    # cell size / r_max.  Measured (docs/BENCHMARKS.md, "Micro benchmarks"): on a CPU the gather is
    # ~1 % of a pass, so small cells (few photons per entry, up to 5 cells per axis) cost nothing
    # and bring the stochastic map's error down to the exact gather's: 2.0 (8 cells) gave 12
    # photons/entry and 30 % more error in the Cornell box, 0.5 gives ~1.4 and matches it.
    CELL_SCALE = 0.5
    # work-group of the visible points' bounds reduction (kernels/integrator/hash_build.cl
    # vp_bounds)
    BOUNDS_GROUP = 64

    def __init__(self, ctx: PassContext):
        self.ctx = ctx
        device = ctx.device
        defines = {"PPM_INT64_ATOMICS": True} if device.int64_atomics else {}
        # photons per work-item of the build (kernels/integrator/hash_build.cl PPM_BUILD_BATCH)
        self.batch = 8 if device.info.type == "CPU" else 1
        self.program = device.programs.get("integrator/hash_build.cl",
                                           {**defines, "PPM_BUILD_BATCH": self.batch})


class GridSetup(SpatialHash):
    def __init__(self, ctx: PassContext, *, cover=None, cell_scale: float = SpatialHash.CELL_SCALE):
        """``cover``: a box (lo, hi) the grid must cover as well (RenderOptions
        .skip_unseen_photons off: the whole scene, so that every photon is stored)."""
        super().__init__(ctx)
        self.cover, self.cell_scale = cover, cell_scale
        p = self.program
        self.k_bounds_init = p.launch("bounds_init", "grid")
        self.k_bounds = p.launch("vp_bounds", "grid")
        self.k_grid = p.launch("grid_setup", "grid")

    def enqueue(self, q, it: Iteration) -> list:
        """The grid over the valid visible points (``ctx.vps``), bounds expanded by each one's
        radius (``ctx.radius``), and over ``cover``."""
        c = self.ctx
        pm, n = c.photon_map, c.vps.n
        lo, hi = self.cover if self.cover is not None else (_EMPTY_LO, _EMPTY_HI)
        return [(k.label, ev) for k, ev in (
            (self.k_bounds_init, self.k_bounds_init(q, 1, 1, bounds=pm.bounds, init_lo=lo,
                                                    init_hi=hi)),
            (self.k_bounds, self.k_bounds(q, n, self.BOUNDS_GROUP, vp_pos=c.vps.pos,
                                          radius=c.radius, n=np.uint32(n), bounds=pm.bounds)),
            (self.k_grid, self.k_grid(q, 1, 1, bounds=pm.bounds,
                                      cell_scale=np.float32(self.cell_scale), grid=pm.grid)))]


class HashBuild(SpatialHash):
    def __init__(self, ctx: PassContext):
        super().__init__(ctx)
        p = self.program
        self.k_clear = p.launch("clear_table", "hash")
        self.k_hash = p.launch("hash_build", "hash")
        self.k_pick = None if ctx.device.int64_atomics else p.launch("hash_pick", "hash")
        self.k_exact_keys = p.launch("exact_keys", "hash")
        self.k_exact_ranges = p.launch("exact_ranges", "hash")

    def enqueue(self, q, it: Iteration) -> list:
        """The table from the photons the photon pass stored (count: Counter.STORED) in the
        grid GridSetup set up."""
        pm = self.ctx.photon_map
        if pm.exact:
            return self._build_exact(q)
        common = dict(ph_pos=pm.ph_pos, counters=self.ctx.counters,
                      capacity=np.uint32(pm.capacity), grid=pm.grid, table_mask=pm.table_mask,
                      pass_index=np.uint32(it.pass_index), seed=np.uint32(it.options.seed),
                      table=pm.table, stored=np.uint32(Counter.STORED),
                      occupied_at=np.uint32(Counter.OCCUPIED))
        ev = [(self.k_clear.label, self.k_clear(q, pm.table_size, table=pm.table,
                                                n=np.uint32(pm.table_size))),
              (self.k_hash.label, self.k_hash(q, -(-pm.capacity // self.batch), **common))]
        if self.k_pick is not None:          # 32-bit atomics: the winner writes its index
            ev.append((self.k_pick.label, self.k_pick(q, pm.capacity, **common)))
        return ev

    def _build_exact(self, q) -> list:
        import pyopencl as cl
        import pyopencl.array as cla
        pm = self.ctx.photon_map
        cap = pm.capacity
        ev = [("hash", self.k_exact_keys(q, cap, ph_pos=pm.ph_pos, counters=self.ctx.counters,
                                         capacity=np.uint32(cap), grid=pm.grid,
                                         table_mask=pm.table_mask, keys=pm.sort_keys,
                                         ids=pm.sort_ids))]
        keys = cla.Array(q, (cap,), np.uint32, data=pm.sort_keys)
        ids = cla.Array(q, (cap,), np.uint32, data=pm.sort_ids)
        (skeys, sids), sort_ev = self.ctx.device.radix_sort_uint_pairs()(
            keys, ids, key_bits=int(pm.table_size).bit_length())
        ev.append(("hash", sort_ev))
        pm.sorted = (skeys, sids)                 # kept alive until the gather ran
        ev.append(("hash", cl.enqueue_fill_buffer(q, pm.ranges, np.uint32(0), 0,
                                                  8 * pm.table_size)))
        ev.append(("hash", self.k_exact_ranges(q, cap, sorted_keys=skeys.data,
                                               capacity=np.uint32(cap),
                                               table_mask=pm.table_mask, ranges=pm.ranges)))
        return ev
