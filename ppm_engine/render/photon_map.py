"""The photon map's storage: this pass's photons, the grid over the visible points and the
stochastic spatial hash table (layout: kernels/integrator/hash.h), with host views for tests and
statistics.  The passes that fill and read it: passes/photons.py, passes/hash_build.py,
passes/gather.py.

PHOTON_BUFFERS lists the buffers the photon pass writes and the gather reads: kernels/shared.h
gets them as the X-macro PHOTON_DATA, from which kernels/integrator/pass_state.h makes the
kernels' parameters (``ph_NAME``) and the struct ``Photons`` (``const Photons *photons``);
Launch binds them by name from ``PhotonMap.args``."""
from __future__ import annotations

import numpy as np

from ppm_engine.render.film import PassBuffer

# the stochastic hash's grid, written on the device by grid_setup (kernels/integrator/hash_build.cl)
GRID_DTYPE = np.dtype([
    ("bmin", np.float32, 3),
    ("bmax", np.float32, 3),
    ("cell_size", np.float32),
    ("inv_cell_size", np.float32),
    ("r_max", np.float32),
    ("r_min", np.float32),
    ("valid", np.uint32),         # the visible points of this pass
    ("pad", np.uint32),
])


# The photons' buffers, in the kernels' parameter order (ph_NAME; PhotonMap.args).
PHOTON_BUFFERS = (
    PassBuffer("grid", GRID_DTYPE, 0, "the grid over this pass's visible points"),
    PassBuffer("pos", np.dtype((np.float32, 4)), 0, "position; w: the normal packed"),
    PassBuffer("flux", np.dtype((np.float32, 4)), 0, "flux; w: where it came from, packed"),
    PassBuffer("path", np.dtype((np.uint32, 2)), 0,
               "its bounces (path_state.h), the radiance over its flux (the clamp)"),
    # the volume photons (kernels/integrator/volume_photons.h), allocated by allocate_volume
    PassBuffer("vgrid", GRID_DTYPE, 0, "the volume photons' grid (passes/volume.py)"),
    PassBuffer("vpos", np.dtype((np.float32, 4)), 0, "a volume photon's position"),
    PassBuffer("vflux", np.dtype((np.float32, 4)), 0, "its flux; w: where it came from, packed"),
    PassBuffer("vpath", np.dtype(np.uint32), 0, "its bounces (path_state.h)"),
)


def next_pow2(n: int) -> int:
    return 1 << max(4, int(n - 1).bit_length())


class PhotonMap:
    def __init__(self, device, capacity: int, exact: bool = False):
        """``exact``: the reference mode -- photons sorted by entry (pyopencl RadixSort), every
        photon gathered -- instead of one stochastic photon per entry."""
        self.device = device
        self.exact = exact
        self.bounds = device.buffer(4 * 16, "grid bounds")
        self.grid = device.buffer(GRID_DTYPE.itemsize, "grid")
        self.sorted = None           # exact mode: (keys, ids) of the last build, for the gather
        self.allocate(capacity)
        self.allocate_volume(0)

    def allocate_volume(self, capacity: int):
        """Storage for ``capacity`` volume photons (none: placeholders) and their hash table
        (passes/volume.py VolumeGather)."""
        dev = self.device
        self.vcapacity = int(capacity)
        self.vgrid = dev.buffer(GRID_DTYPE.itemsize, "volume photons' grid")
        self.ph_vpos = dev.buffer(16 * self.vcapacity, "volume photons")
        self.ph_vflux = dev.buffer(16 * self.vcapacity, "volume photons")
        self.ph_vpath = dev.buffer(4 * self.vcapacity, "volume photons")
        self.vtable_size = next_pow2(self.vcapacity) if capacity else 16
        self.vtable = dev.buffer(16 * self.vtable_size, "volume photons' hash table")

    def allocate(self, capacity: int):
        """Photon storage for ``capacity`` photons and a table of the next power of two."""
        dev = self.device
        self.capacity = int(capacity)
        self.ph_pos = dev.buffer(16 * self.capacity, "photon map")
        self.ph_flux = dev.buffer(16 * self.capacity, "photon map")
        # the photon's bounces as the Light Paths limits count them
        # (kernels/integrator/path_state.h) and the radiance its light path carries over its flux
        # (the clamp; kernels/integrator/gather.cl); zero: no bounce, no clamp, what photons written
        # by hand (tests, benchmarks) stand for
        self.ph_path = dev.buffer(8 * self.capacity, "photon map")
        import pyopencl as cl
        cl.enqueue_fill_buffer(dev.queue, self.ph_path, np.uint32(0), 0, 8 * self.capacity)
        self.table_size = next_pow2(self.capacity)
        self.table = dev.buffer(16 * self.table_size, "hash table")   # layout:
                                                                      # kernels/integrator/hash.h
        if self.exact:
            self.sort_keys = dev.buffer(4 * self.capacity, "photon sort keys")
            self.sort_ids = dev.buffer(4 * self.capacity, "photon sort keys")
            self.ranges = dev.buffer(8 * self.table_size, "photon ranges")

    @property
    def args(self) -> dict:
        """The photons' buffers by the kernels' parameter names (ph_NAME; PHOTON_BUFFERS), each
        the attribute ph_NAME (the grid: ``grid``)."""
        grids = {"grid": self.grid, "vgrid": self.vgrid}
        return {f"ph_{b.name}": grids[b.name] if b.name in grids else getattr(self, f"ph_{b.name}")
                for b in PHOTON_BUFFERS}

    @property
    def table_mask(self) -> np.uint32:
        return np.uint32(self.table_size - 1)

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
        # the index: word 3 by the 32-bit fallback's pick, word 2 under 64-bit atom_max
        return t[:, 0].copy(), t[:, 2 if self.device.int64_atomics else 3].copy()

