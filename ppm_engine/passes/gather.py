"""The gather (kernels/gather.cl): each visible point reads the cells its disc overlaps, one
photon per cell (the entry's photon stands for its n photons), or every photon of the entry in
the exact reference mode."""
from __future__ import annotations

import numpy as np


class Gather:
    def __init__(self, device, photon_map):
        self.photon_map = photon_map
        defines = {"PPM_INT64_ATOMICS": True} if device.int64_atomics else {}
        p = device.programs.get("gather.cl", defines)
        self.k_gather = p.launch("gather", "gather")
        self.k_exact = p.launch("gather_exact", "gather")

    def enqueue(self, q, vp_pos, vp_nrm, radius, gathered, n: int) -> list:
        """gathered[i] = (sum of n x flux, sum of n) over the accepted entries."""
        pm = self.photon_map
        common = dict(vp_pos=vp_pos, vp_nrm=vp_nrm, radius=radius, grid=pm.grid,
                      table_mask=pm.table_mask, ph_pos=pm.ph_pos, ph_flux=pm.ph_flux,
                      gathered=gathered, n=np.uint32(n))
        if pm.exact:
            ev = self.k_exact(q, n, **common, ranges=pm.ranges, sorted_ids=pm.sorted[1].data)
        else:
            ev = self.k_gather(q, n, **common, table=pm.table)
        return [("gather", ev)]
