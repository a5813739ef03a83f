"""The stochastic spatial hash: the grid over the visible points, the table build and the
gather (kernels/hash_build.cl, kernels/gather.cl).  The renderer chains these after the photon
pass; tests drive them with synthetic photons."""
from __future__ import annotations

import numpy as np

# mirrors kernels/types.h Grid
GRID_DTYPE = np.dtype([
    ("bmin", np.float32, 3), ("bmax", np.float32, 3), ("cell_size", np.float32),
    ("inv_cell_size", np.float32), ("r_max", np.float32), ("r_min", np.float32),
    ("valid", np.uint32), ("pad", np.uint32),
])

# counters shared by the passes (kernels/photon_pass.cl CNT_*, hash_build.cl [4], the film's
# adaptive sampling [5]; [7] is the hash build's prefetch sink, never read)
CNT_NAN, CNT_STORED, CNT_OUTSIDE, CNT_OVERFLOW, CNT_OCCUPIED, CNT_ACTIVE = range(6)
N_COUNTERS = 8


def _round(n: int, wg: int = 64) -> int:
    return max(wg, (n + wg - 1) // wg * wg)


def next_pow2(n: int) -> int:
    return 1 << max(4, int(n - 1).bit_length())


class PhotonMap:
    # cell size / r_max.  Measured (docs/BENCHMARKS.md): on a CPU the gather is ~1 % of a
    # pass, so small cells (few photons per entry, up to 5 cells per axis) cost nothing and
    # bring the stochastic map's error down to the exact gather's: 2.0 (8 cells) gave 12
    # photons/entry and 30 % more error in the Cornell box, 0.5 gives ~1.4 and matches it.
    CELL_SCALE = 0.5

    def __init__(self, device, capacity: int, exact: bool = False):
        """``exact``: the reference mode -- photons sorted by entry (pyopencl RadixSort), every
        photon gathered -- instead of one stochastic photon per entry."""
        self.device = device
        self.exact = exact
        defines = {"PPM_INT64_ATOMICS": True} if device.int64_atomics else {}
        # photons per work-item of the build (kernels/hash_build.cl PPM_BUILD_BATCH)
        self.build_batch = 8 if device.info.type == "CPU" else 1
        hp = device.programs.get("hash_build.cl",
                                 {**defines, "PPM_BUILD_BATCH": self.build_batch})
        self.k_bounds_init, self.k_bounds, self.k_grid = hp.bounds_init, hp.vp_bounds, hp.grid_setup
        self.k_clear, self.k_hash = hp.clear_table, hp.hash_build
        self.k_pick = None if device.int64_atomics else hp.hash_pick
        gp = device.programs.get("gather.cl", defines)
        self.k_gather, self.k_gather_exact = gp.gather, gp.gather_exact
        self.k_exact_keys, self.k_exact_ranges = hp.exact_keys, hp.exact_ranges
        self.bounds = device.buffer(4 * 16, "grid bounds")
        self.grid = device.buffer(GRID_DTYPE.itemsize, "grid")
        self.allocate(capacity)

    def allocate(self, capacity: int):
        """Photon storage for ``capacity`` photons and a table of the next power of two."""
        dev = self.device
        self.capacity = int(capacity)
        self.ph_pos = dev.buffer(16 * self.capacity, "photon map")
        self.ph_flux = dev.buffer(16 * self.capacity, "photon map")
        self.table_size = next_pow2(self.capacity)
        self.table = dev.buffer(16 * self.table_size, "hash table")   # layout: kernels/hash.h
        if self.exact:
            self.sort_keys = dev.buffer(4 * self.capacity, "photon sort keys")
            self.sort_ids = dev.buffer(4 * self.capacity, "photon sort keys")
            self.ranges = dev.buffer(8 * self.table_size, "photon ranges")

    # -- phases (each returns the list of (label, event) it enqueued) ------------------------------
    def enqueue_grid(self, q, vp_pos, radius, n: int):
        """Grid over the valid visible points, bounds expanded by each one's radius."""
        return [("grid", self.k_bounds_init(q, (1,), None, self.bounds)),
                ("grid", self.k_bounds(q, (_round(n),), (64,), vp_pos, radius, np.uint32(n),
                                       self.bounds)),
                ("grid", self.k_grid(q, (1,), None, self.bounds, np.float32(self.CELL_SCALE),
                                     self.grid))]

    def enqueue_build(self, q, counters, pass_id: int, seed: int):
        """Table from the photons the photon pass stored (count in counters[CNT_STORED])."""
        if self.exact:
            return self._enqueue_build_exact(q, counters)
        mask = np.uint32(self.table_size - 1)
        cap = np.uint32(self.capacity)
        ev = [("hash", self.k_clear(q, (_round(self.table_size),), None, self.table,
                                    np.uint32(self.table_size))),
              ("hash", self.k_hash(q, (_round(-(-self.capacity // self.build_batch)),), None,
                                   self.ph_pos, counters, cap, self.grid, mask,
                                   np.uint32(pass_id), np.uint32(seed), self.table))]
        if self.k_pick is not None:
            ev.append(("hash", self.k_pick(q, (_round(self.capacity),), None, self.ph_pos,
                                           counters, cap, self.grid, mask, np.uint32(pass_id),
                                           np.uint32(seed), self.table)))
        return ev

    def _enqueue_build_exact(self, q, counters):
        import pyopencl as cl
        import pyopencl.array as cla
        mask = np.uint32(self.table_size - 1)
        cap = self.capacity
        ev = [("hash", self.k_exact_keys(q, (_round(cap),), None, self.ph_pos, counters,
                                         np.uint32(cap), self.grid, mask, self.sort_keys,
                                         self.sort_ids))]
        keys = cla.Array(q, (cap,), np.uint32, data=self.sort_keys)
        ids = cla.Array(q, (cap,), np.uint32, data=self.sort_ids)
        (skeys, sids), sort_ev = self.device.radix_sort_uint_pairs()(
            keys, ids, key_bits=int(self.table_size).bit_length())
        ev.append(("hash", sort_ev))
        self._sorted = (skeys, sids)                 # keep alive until the gather ran
        ev.append(("hash", cl.enqueue_fill_buffer(q, self.ranges, np.uint32(0), 0,
                                                  8 * self.table_size)))
        ev.append(("hash", self.k_exact_ranges(q, (_round(cap),), None, skeys.data,
                                               np.uint32(cap), mask, self.ranges)))
        return ev

    def enqueue_gather(self, q, vp_pos, vp_nrm, radius, gathered, n: int):
        """gathered[i] = (sum of n x flux, sum of n) over accepted entries."""
        if self.exact:
            return [("gather", self.k_gather_exact(
                q, (_round(n),), None, vp_pos, vp_nrm, radius, self.grid, self.ranges,
                self._sorted[1].data, np.uint32(self.table_size - 1), self.ph_pos, self.ph_flux,
                gathered, np.uint32(n)))]
        return [("gather", self.k_gather(q, (_round(n),), None, vp_pos, vp_nrm, radius, self.grid,
                                         self.table, np.uint32(self.table_size - 1),
                                         self.ph_pos, self.ph_flux, gathered, np.uint32(n)))]

    # -- host views (tests, statistics) ------------------------------------------------------------
    def read_grid(self) -> np.ndarray:
        import pyopencl as cl
        g = np.empty(1, GRID_DTYPE)
        cl.enqueue_copy(self.device.queue, g, self.grid)
        return g[0]

    def read_table(self):
        """(counts, photon index per entry)."""
        import pyopencl as cl
        t = np.empty((self.table_size, 4), np.uint32)
        cl.enqueue_copy(self.device.queue, t, self.table)
        return t[:, 0].copy(), t[:, 3 if self.k_pick is not None else 2].copy()
