"""The volume photons' gather (kernels/integrator/volume_gather.cl): photons stored where they
scattered in media (kernels/integrator/volume_photons.h) gathered along the camera's segments
in media by the beam radiance estimate, each pass with a radius of the global schedule (Knaus &
Zwicker 2011, as RenderOptions.radius_schedule "global" for the surfaces: the photons' radius
over the initial one is options.global_radius_scale of the pass's index), so the estimate is
consistent.  Runs after the photon pass: the hash over this pass's volume photons (the
surfaces' hash_build.cl, cells of twice the radius over the media's box) and the gather into
the film's photon splats (film.lt_pass)."""
from __future__ import annotations

import numpy as np

from ppm_engine.render.counters import N_COUNTERS, Counter
from ppm_engine.render.device import SHADING_GROUP
from ppm_engine.render.options import global_radius_scale
from ppm_engine.render.passes.context import Iteration, PassContext
from ppm_engine.render.passes.hash_build import SpatialHash
from ppm_engine.render.photon_map import GRID_DTYPE

# the camera's segments in media an eye path keeps for the gather (eye_pass.cl), per pixel: 64
# bytes each (253 MiB at 1920 x 1080); two serve a camera ray through fog and a glass in it
VOLUME_SEGMENTS = 2
# the initial radius where options.initial_radius is 0: this many pixel footprints at the
# media's box (initial_radius)
VOLUME_RADIUS_PIXELS = 1.5


def initial_radius(scene, options) -> float:
    """The volume photons' first radius: options.initial_radius, or VOLUME_RADIUS_PIXELS pixel
    footprints at the distance from the camera to the media's box centre plus a quarter of
    its diagonal (a camera inside the fog sees most of it farther than its centre)."""
    if options.initial_radius > 0:
        return float(options.initial_radius)
    box = scene.media_box()
    cam = scene.prepared.camera[0]
    pixel = float(cam["extent"][0]) / max(int(cam["width"]), 1)
    if box is None:
        return pixel
    lo, hi = box
    centre, diag = 0.5 * (lo + hi), float(np.linalg.norm(hi - lo))
    dist = 1.0 if cam["type"] != 0 else (
        float(np.linalg.norm(centre - cam["to_world"][:, 3])) + 0.25 * diag)
    return VOLUME_RADIUS_PIXELS * pixel * dist


# the bits marking the blocks of cells near a volume photon (volume_gather.cl volume_mark; a
# power of two, hashed): 128 KiB
VOLUME_MARK_BITS = 1 << 20


class VolumeGather(SpatialHash):
    MARK_BITS = VOLUME_MARK_BITS
    def __init__(self, ctx: PassContext, options):
        """The hash build and volume_gather.cl; the grid over the media's box."""
        super().__init__(ctx)
        self.k_clear = self.program.launch("clear_table", "volume")
        self.k_hash = self.program.launch("hash_build", "volume")
        self.k_pick = (None if ctx.device.int64_atomics
                       else self.program.launch("hash_pick", "volume"))
        # (without a heterogeneous medium the gather reads no shader program: a small build;
        # with one, every feature's, as the passes' programs of every feature)
        fields = (ctx.scene.kmaterials["density_program"] > 0).any()
        defines = {"PPM_VOLUME": True,
                   **({} if fields else {"PPM_SPECIALIZED": True, "PPM_ABSORPTION": True}),
                   **({"PPM_INT64_ATOMICS": True} if ctx.device.int64_atomics else {})}
        p = ctx.device.programs.get("integrator/volume_gather.cl", defines)
        self.k_gather = p.launch("volume_gather", "volume")
        self.k_mark = p.launch("volume_mark", "volume")
        # the blocks of cells near a photon (volume_gather.cl VOLUME_MARK_BITS)
        self.marks = ctx.device.buffer(self.MARK_BITS // 8, "volume photons' marks")
        self.r0 = initial_radius(ctx.scene, options)
        self.box = ctx.scene.media_box()
        self.grid = np.zeros(1, GRID_DTYPE)

    def radius(self, it: Iteration) -> float:
        """This pass's radius: the global schedule's (options.global_alpha)."""
        return self.r0 * global_radius_scale(it.pass_index, it.options.global_alpha)

    def enqueue(self, q, it: Iteration) -> list:
        import pyopencl as cl
        c = self.ctx
        pm = c.photon_map
        r = self.radius(it)
        g = self.grid
        if self.box is not None:
            cell = 2.0 * r
            g["bmin"], g["bmax"] = self.box[0] - r, self.box[1] + r
            g["cell_size"], g["inv_cell_size"] = cell, 1.0 / cell
            g["r_max"] = g["r_min"] = r
            g["valid"] = 1
        common = dict(ph_pos=pm.ph_vpos, counters=c.counters, capacity=np.uint32(pm.vcapacity),
                      grid=pm.vgrid, table_mask=np.uint32(pm.vtable_size - 1),
                      pass_index=np.uint32(it.pass_index), seed=np.uint32(it.options.seed),
                      table=pm.vtable, stored=np.uint32(Counter.VSTORED),
                      occupied_at=np.uint32(N_COUNTERS))
        ev = [("volume", cl.enqueue_copy(q, pm.vgrid, g, is_blocking=False)),
              ("volume", self.k_clear(q, pm.vtable_size, table=pm.vtable,
                                      n=np.uint32(pm.vtable_size))),
              ("volume", self.k_hash(q, -(-pm.vcapacity // self.batch), **common))]
        if self.k_pick is not None:
            ev.append(("volume", self.k_pick(q, pm.vcapacity, **common)))
        ev.append(("volume", cl.enqueue_fill_buffer(q, self.marks, np.uint32(0), 0,
                                                    self.MARK_BITS // 8)))
        ev.append(("volume", self.k_mark(q, pm.vcapacity, ph_pos=pm.ph_vpos, counters=c.counters,
                                         capacity=np.uint32(pm.vcapacity), grid=pm.vgrid,
                                         radius=np.float32(r), marks=self.marks)))
        ev.append(("volume", self.k_gather(
            q, c.vps.n, SHADING_GROUP, **c.scene.args, **c.film.args, **c.vps.args, **pm.args,
            table=pm.vtable, table_mask=np.uint32(pm.vtable_size - 1), radius=np.float32(r),
            marks=self.marks, n=np.uint32(c.vps.n), counters=c.counters)))
        return ev

    @classmethod
    def for_render(cls, ctx: PassContext, options, capacity: int) -> VolumeGather | None:
        """The gather of a render with photons (None where no volume photon can count: no
        scattering medium, or Volume bounces 0, where a camera path goes on past no scattering
        in a medium but to find emitters, path_state.h path_join_volume), its storage set up:
        ``capacity`` volume photons, the camera's segments, the film's photon splats."""
        scene = ctx.scene
        if scene.media_box() is None or int(scene.light_paths["volume_bounces"][0]) < 1:
            return None
        if ctx.photon_map.vcapacity < capacity:
            ctx.photon_map.allocate_volume(capacity)
        ctx.vps.allocate_segments(VOLUME_SEGMENTS)
        ctx.film.enable_light_tracing()
        return cls(ctx, options)

    def grow(self, counters: np.ndarray) -> None:
        """After a pass whose volume photons did not all fit: room for twice as many."""
        pm = self.ctx.photon_map
        if int(counters[Counter.VSTORED]) > pm.vcapacity:
            pm.allocate_volume(2 * pm.vcapacity)
