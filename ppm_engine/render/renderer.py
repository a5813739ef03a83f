"""One render on one device.  ``iterate()`` runs one SPPM pass, in the paper's order (Hachisuka
& Jensen 2010; passes/__init__.py):

    eye pass -> grid over the visible points -> photon pass -> hash build -> gather
    -> radius update -> add sample (-> converge)

Every pass is a small object owning its kernels and timing labels; launches are chained on one
in-order queue without host waits, and the small per-pass statistics are read once at the end.
"""
from __future__ import annotations

import functools
import time

import numpy as np

from ppm_engine.render.counters import N_COUNTERS, PER_PASS, Counter
from ppm_engine.render.device import get_device
from ppm_engine.render.device_scene import DeviceScene
from ppm_engine.render.film import Film
from ppm_engine.render.options import (
    AUTO_PHOTONS_CAUSTIC_FRACTION,
    LIGHT_TRACING_KAPPA,
    RenderOptions,
)
from ppm_engine.render.passes import (
    AddSample,
    Converge,
    EyePass,
    Gather,
    GridSetup,
    HashBuild,
    Iteration,
    PassContext,
    PhotonPass,
    RadiusUpdate,
    VisiblePoints,
)
from ppm_engine.render.passes.path_filter import PathFilter
from ppm_engine.render.passes.photons import caustic_fraction
from ppm_engine.render.passes.volume import VolumeGather
from ppm_engine.render.photon_map import GRID_DTYPE, PhotonMap
from ppm_engine.render.stats import PassStats, phase_times
from ppm_engine.scene.arrays import SceneArrays
from ppm_engine.scene.casters import caustic_roughness
from ppm_engine.scene.guide import GUIDE_BINS
from ppm_engine.scene.light_paths import with_max_bounces, with_roughness


def _locked(method):
    """Run ``method`` holding the device's lock: renderers in other threads (the viewport's
    worker, a final render, a preview) share the device's queue and kernel objects."""
    @functools.wraps(method)
    def run(self, *args, **kwargs):
        with self.device.lock:
            return method(self, *args, **kwargs)
    return run


class Renderer:
    # photon buffer capacity per emitted photon (grows when a pass overflows)
    STORE_FACTOR = 2

    def __init__(self, scene: SceneArrays, options: RenderOptions):
        self.options = options.validate()
        self.device = dev = get_device(options.device)
        self.queue = dev.queue
        t0 = time.perf_counter()
        with dev.lock:
            self.scene = DeviceScene(dev, scene, options.specialize)
            self.counters = dev.buffer(4 * N_COUNTERS, "counters")
            self._pilot = None      # (settings it depends on, caustic fraction): kept by reset()
            self._start(options, new_pixels=True)
        self.setup_seconds = time.perf_counter() - t0

    @property
    def warnings(self) -> list[str]:
        """What the device copy of the scene dropped (prep.prepare_scene)."""
        return self.scene.warnings

    @property
    def bvh(self):
        return self.scene.bvh

    # ------------------------------------------------------------------------------------------
    def _start(self, options: RenderOptions, new_pixels: bool) -> None:
        """A new render from pass 0: kernels for the scene's features, a new film and
        statistics; pixel and photon storage when ``new_pixels`` (size or photon count
        changed)."""
        import pyopencl as cl
        dev, o = self.device, options
        # the global radius schedule: a pass is a function of its index alone (nothing learned
        # from the passes before: guides, casters' weights, photon skips, light tracing's stop)
        # and runs in any order (iterate's pass_index); render/parts.py adds ranges up
        self.independent = o.radius_schedule == "global"
        self.features, self.defines = self.scene.kernel_defines(o.specialize, o.editable)
        w, h = self.scene.scene.resolution
        if new_pixels:
            self.width, self.height, self.n_pixels = w, h, w * h
            self.photons_per_pass = o.photons_for(self.n_pixels)
            self.vps = VisiblePoints(dev, self.n_pixels)
            # storage for photons only once a pass needs it (below): a scene lit by eye paths
            # alone never allocates it (222 MiB at 1920 x 1080)
            self.photon_map = PhotonMap(dev, 0, exact=o.exact_gather)
        self.film = Film(dev, w, h)
        self.film.exposure = float(self.scene.scene.camera["exposure"][0])
        cl.enqueue_fill_buffer(self.queue, self.counters, np.uint32(0), 0, 4 * N_COUNTERS)
        # the photon guides (ppm_engine/scene/guide.py): nothing learned at a new render's start
        guides = self.scene.guides
        guides.reset()
        self.scene.upload_guides()
        size = 4 * max(len(guides), 1) * GUIDE_BINS
        if getattr(self, "guide_stats", None) is None or self.guide_stats.size != size:
            self.guide_stats = dev.buffer(size, "photon guides' counts")
        cl.enqueue_fill_buffer(self.queue, self.guide_stats, np.uint32(0), 0, size)
        self.context = ctx = PassContext(dev, self.scene, self.defines, film=self.film,
                                         vps=self.vps, photon_map=self.photon_map,
                                         counters=self.counters, guide_stats=self.guide_stats)
        self.eye = EyePass(ctx)
        # the photon pass and the gather are built when first used: a scene whose indirect
        # light is all eye paths never compiles them (half of a new scene's kernel builds)
        self._photon_pass = self._gather = None
        self.grid_setup = GridSetup(ctx, cover=None if o.skip_unseen_photons
                                    else self.scene.bounds())
        self.hash_build = HashBuild(ctx)
        self.radius_update, self.add_sample = RadiusUpdate(ctx), AddSample(ctx)
        self.converge = Converge(ctx)
        lp = with_max_bounces(self.scene.scene.light_paths, o.max_bounces)
        self.scene.set_light_paths(with_roughness(lp, o.gather_roughness, o.caustic_roughness))
        useful = self.scene.photons_useful()
        self.caustic_roughness = caustic_roughness(self.scene.light_paths, o.caustic_roughness)
        caustics = self.scene.caustics_possible(o.gather_roughness, self.caustic_roughness)
        self.path_indirect, self.caustic_fraction = self._choose_indirect(o, useful, caustics)
        useful = useful and (caustics or not self.path_indirect)
        self.photons_needed = useful or not o.skip_unneeded_photon_pass
        # caustic photons aimed at the casters (a pilot's photons are not)
        self.casters = (self.scene.set_casters(o.gather_roughness, self.caustic_roughness)
                        if self.photons_needed and self.path_indirect else 0)
        self.caster_counts = np.zeros((self.casters, 2))   # learn_caster_weights' sums
        self.aimed = bool(self.casters) and o.skip_unaimed_caustics
        # where photons carry the light, those of the point, spot and area lights guided
        # where they are stored (caustic photons have their aim)
        self.guided = (self.photons_needed and not self.path_indirect and len(guides) > 0
                       and o.skip_unguided_photons and not self.independent)
        # this render's photons per pass: fewer where they are aimed (each costs more)
        self.photon_count = (o.aimed_photons_for(self.n_pixels, self.scene.caster_share)
                             if self.aimed else self.photons_per_pass)
        store = self.STORE_FACTOR * self.photon_count
        if self.photons_needed and self.photon_map.capacity < store:
            self.photon_map.allocate(store)
        # photons stored in media, gathered along the camera's segments (passes/volume.py)
        self.volume = VolumeGather.for_render(ctx, o, store) if self.photons_needed else None
        if (lt_kappa := self.light_tracing_kappa(o)) > 0:
            self.film.enable_light_tracing()
        self.lt_kappa, self.passes_done = lt_kappa, 0
        self.path_filter = self.eye.records = PathFilter.renew(     # (passes/path_filter.py)
            getattr(self, "path_filter", None), ctx, self.n_pixels,
            o.path_filter and self.path_indirect)
        self.pass_indices: list[int] = []   # the passes this film holds, in the order run
        self.photons_used = 0     # Counter.USED over the render's passes (photons_due)
        self.nan_dropped = 0
        self.active_pixels = self.n_pixels
        self.queue.finish()

    @property
    def photons(self) -> PhotonPass:
        """The photon pass (photon_pass.cl for the scene's features), built on first use."""
        self._photon_pass = self._photon_pass or PhotonPass(self.context)
        return self._photon_pass

    @property
    def gather(self) -> Gather:
        """The gather (gather.cl for the scene's features), built on first use."""
        self._gather = self._gather or Gather(self.context)
        return self._gather

    def light_tracing_kappa(self, o: RenderOptions) -> float:
        """The photons' light tracing (photon_pass.cl connect_camera): its MIS factor kappa, or
        0 where it is off: when asked not to, with no photon pass, or through a lens (light
        tracing connects to a pinhole)."""
        pinhole = float(self.scene.scene.camera["aperture_radius"][0]) <= 0.0
        return LIGHT_TRACING_KAPPA if o.light_tracing and self.photons_needed and pinhole else 0.0

    # photons of the pilot that measures the share of caustic first scatterings
    PILOT_PHOTONS = 1 << 16

    def _choose_indirect(self, o: RenderOptions, photons_useful: bool,
                         caustics_possible: bool) -> tuple[bool, float | None]:
        """(indirect light by eye paths?, the pilot's caustic fraction or None): options.indirect,
        or for "auto" eye paths unless most of the light's first scatterings are caustic ones
        (a bulb inside glass: eye paths would find almost nothing, every photon is caustic).
        ``photons_useful``, ``caustics_possible``: the DeviceScene's answers for ``o``."""
        if o.indirect != "auto":
            return o.indirect == "paths", None
        if not caustics_possible:
            return True, 0.0
        if not photons_useful:
            return True, None
        key = (o.gather_roughness, self.caustic_roughness, self.scene.light_paths.tobytes(),
               o.seed)
        if self._pilot is None or self._pilot[0] != key:    # a re-render of the same scene
            self._pilot = (key, self.caustic_fraction_pilot(o))   # keeps its pilot
        f = self._pilot[1]
        return f <= AUTO_PHOTONS_CAUSTIC_FRACTION, f

    def caustic_fraction_pilot(self, o: RenderOptions) -> float:
        """passes/photons.py caustic_fraction of PILOT_PHOTONS photons."""
        return caustic_fraction(self.context, o, self.PILOT_PHOTONS)

    @_locked
    def refit(self, scene: SceneArrays) -> bool:
        """The same triangles moved or deformed (an object's transform, an armature): the BVH is
        refitted over its hierarchy instead of rebuilt, and the scene re-uploaded.  Returns
        False (nothing changed) when the triangle count differs or the refitted tree would be
        too slow (bvh.BVH.refit); then build a new Renderer.  Call reset() afterwards."""
        self._pilot = None                       # the caustic fraction may have moved too
        return self.scene.refit(scene)

    def can_reuse(self, options: RenderOptions, scene: SceneArrays | None = None) -> bool:
        """Whether reset() can serve a render with these options and scene."""
        return (options.device == self.options.device
                and (scene is None or DeviceScene.same_geometry(self.scene.scene, scene)))

    @_locked
    def reset(self, options: RenderOptions, scene: SceneArrays | None = None):
        """Start a new render on the same device, keeping the BVH and the built programs
        (persistent data): a new film, statistics and photon storage; a new scene whose
        geometry is unchanged (``DeviceScene.same_geometry``) re-uploads only what it changed."""
        options = options.validate()
        if not self.can_reuse(options, scene):
            raise ValueError("reset() needs the same device and geometry; build a new Renderer")
        old, self.options = self.options, options
        if scene is not None and scene is not self.scene.scene:
            if self.scene.scene.differs_only_in_camera(scene):
                self.scene.set_camera(scene)     # the viewport's view moved: the camera only
            else:
                self.scene.upload(scene)
                self._pilot = None               # materials or lights may differ
        w, h = self.scene.scene.resolution
        self._start(options, new_pixels=(
            (w, h) != (self.width, self.height)
            or options.photons_for(w * h) != self.photons_per_pass
            or options.exact_gather != old.exact_gather))

    # ------------------------------------------------------------------------------------------
    # an interruptible pass (iterate's ``interrupt``) splits its eye and photon passes into
    # launches of about this many pixels or photons (2-core CPU: ~50 ms of the Cornell box's)
    INTERRUPT_PIXELS = 1 << 15

    @_locked
    def iterate(self, interrupt=None, pass_index: int | None = None) -> PassStats | None:
        """Run one SPPM pass.  ``interrupt``: a function asked between pieces of a large eye
        pass or photon pass (INTERRUPT_PIXELS each); when it returns True the pass is dropped
        unfinished and None returned, and the render must be reset before the next pass (the
        viewport: a new view is waiting).  ``pass_index``: which pass this is (default
        passes_done), where passes are independent only (a pass range, a device's share)."""
        import pyopencl as cl
        t0 = time.perf_counter()
        o, q = self.options, self.queue
        if pass_index is not None and not self.independent:
            raise ValueError("passes run out of order with radius_schedule 'global' only")
        pass_index = self.passes_done if pass_index is None else pass_index
        film = self.film
        # this pass's counters (Counter.NAN counts over the whole render)
        cl.enqueue_fill_buffer(q, self.counters, np.uint32(0), 4 * PER_PASS.start,
                               4 * len(PER_PASS))
        photons = self.photons_due(pass_index)
        it = Iteration(pass_index, o, photons=self.photon_count if photons else 0,
                       path_indirect=self.path_indirect, lt_kappa=self.lt_kappa,
                       interrupt=interrupt, piece=self.INTERRUPT_PIXELS, guided=self.guided,
                       volume_photons=self.volume is not None)
        events = self.eye.enqueue(q, it)
        if events is None:
            q.finish()
            return None
        if photons:
            # the grid over the visible points: only photons use it
            events += self.grid_setup.enqueue(q, it)
            photon_events = self.photons.enqueue(q, it)
            if photon_events is None:
                q.finish()
                return None
            events += photon_events
            events += self.hash_build.enqueue(q, it)
            events += self.gather.enqueue(q, it)
            events += self.volume.enqueue(q, it) if self.volume else []
            events += self.radius_update.enqueue(q, it)
        events += self.add_sample.enqueue(q, it)
        converge = self.converge.due(it)
        if converge:
            events += self.converge.enqueue(q, it)
        counters = np.empty(N_COUNTERS, np.uint32)
        grid = np.zeros(1, GRID_DTYPE)     # no grid this pass (no photons): no visible points
        cl.enqueue_copy(q, counters, self.counters, is_blocking=False)    # counted, no radii
        if photons:
            cl.enqueue_copy(q, grid, self.photon_map.grid, is_blocking=False)
        q.finish()
        if (pass_index == 0 and self.lt_kappa > 0 and counters[Counter.SEEN] == 0
                and o.skip_blind_light_tracing and not self.independent):
            # no pixel sees a surface the photons' light tracing renders (a pool's floor seen
            # only through its water): every connection to the camera is blocked, so it stops,
            # and the merge keeps the whole weight (as with light tracing off)
            self.lt_kappa = 0.0
            if not self.volume:           # (whose gather adds to the same splats)
                film.disable_light_tracing()
        self.passes_done += 1
        self.pass_indices.append(pass_index)
        if photons:
            self.photons_used += int(counters[Counter.USED])
            if self.volume:
                self.volume.grow(counters)
            if self.aimed and not self.independent:
                self.learn_caster_weights(counters)
            if self.guided:        # (never where passes are independent)
                self.learn_guides()
        return self._stats(counters, grid, events, converge, time.perf_counter() - t0, photons)

    # photons_due: below this share of the photons emitted reaching the image (Counter.USED)
    # few passes run them (measured: sun_cone 1.2e-5, glossy_metal 6e-3, the caustics 0.35-3.7)
    PHOTONS_USED_MIN = 1e-3

    def photons_due(self, pass_index: int) -> bool:
        """Whether pass ``pass_index`` runs the photon pass, grid, hash and gather: every pass,
        but where fewer than PHOTONS_USED_MIN of the photons reach the image (Filter Glossy hands
        most to the eye paths) only passes 1, 2, 4, 8, 16 and every 16th, counting from 1 (when
        casters and guides learn; every pass where passes are independent); the film divides
        by the photons emitted, so no bias."""
        if not self.photons_needed:
            return False
        n = pass_index + 1
        if (not self.options.skip_unused_photons or self.independent or (n & (n - 1)) == 0
                or n % 16 == 0):
            return True
        return self.photons_used >= self.PHOTONS_USED_MIN * self.film.photons_emitted

    # learn_caster_weights: a caster's yield starts as this many photons' worth of its material's
    # weight (casters.py) at the mean yield; no weight falls below this share of the largest
    LEARN_PRIOR = 64
    LEARN_FLOOR = 0.02

    def learn_caster_weights(self, counters: np.ndarray) -> None:
        """The casters' weights from what the photons aimed at each stored so far (per photon
        aimed: its yield), after passes 1, 2, 4, 8, 16 and every 16th: photons go where they
        are stored near what the camera sees (the grid over the visible points), not to a
        mirror whose light lands out of view, nor to a floor's faint specular layer whose
        photons mostly end there.  Each pass's photons carry the density they were drawn with,
        so the image stays unbiased; no weight drops below LEARN_FLOOR of the largest, so
        every caster keeps photons."""
        k = self.casters
        first = Counter.CASTER_STATS
        self.caster_counts += counters[first:first + 2 * k].reshape(k, 2)
        n = self.passes_done
        sent, stored = self.caster_counts.T
        if (n & (n - 1) and n % 16) or not stored.sum() > 0:
            return
        static = self.scene.caster_static / max(float(self.scene.caster_static.max()), 1e-30)
        prior = self.LEARN_PRIOR * static * (stored.sum() / sent.sum())
        y = (stored + prior) / (sent + self.LEARN_PRIOR)
        self.scene.set_caster_weights(np.maximum(y / y.max(), self.LEARN_FLOOR))

    def learn_guides(self) -> None:
        """The guided lights' bins from the stores counted per bin (ppm_engine/scene/guide.py),
        after passes 1, 2, 4, 8, 16 and every 16th, as learn_caster_weights: each pass's
        photons carry the density they were drawn with, so the image stays unbiased."""
        import pyopencl as cl
        guides, em = self.scene.guides, self.scene.emitters
        total = float(em.power.sum())
        if not total > 0:
            return
        guides.count_sent(self.photon_count, em.power / total)
        n = self.passes_done
        if n & (n - 1) and n % 16:
            return
        stored = np.empty(len(guides) * GUIDE_BINS, np.uint32)
        cl.enqueue_copy(self.queue, stored, self.guide_stats)
        if guides.learn(stored):
            self.scene.upload_guides()

    def _stats(self, counters, grid, events, converged: bool, seconds: float,
               photons: bool) -> PassStats:
        if converged:
            self.active_pixels = int(counters[Counter.ACTIVE])
        self.nan_dropped = int(counters[Counter.NAN])
        pm = self.photon_map
        overflow = int(counters[Counter.OVERFLOW])
        stats = PassStats(
            pass_index=self.passes_done, photons_emitted=self.film.photons_emitted,
            photons_stored=min(int(counters[Counter.STORED]), pm.capacity),
            photons_outside=int(counters[Counter.OUTSIDE]), photons_dropped=overflow,
            occupied_entries=int(counters[Counter.OCCUPIED]),
            visible_points=int(grid["valid"][0]), radius_min=float(grid["r_min"][0]),
            radius_max=float(grid["r_max"][0]), nan_dropped=self.nan_dropped,
            seconds=seconds, phase_ms=phase_times(events), active_pixels=self.active_pixels,
            pixels=self.n_pixels, indirect="paths" if self.path_indirect else "photons",
            caustic_fraction=self.caustic_fraction, light_tracing=self.lt_kappa > 0,
            caster_fraction=(int(counters[Counter.CASTER]) / self.photon_count
                             if photons and self.path_indirect else None))
        if overflow:     # this pass lost photons (counted); the next one has room
            pm.allocate(2 * pm.capacity)
        return stats

    # ------------------------------------------------------------------------------------------
    @_locked
    def image(self) -> np.ndarray:
        """Linear RGBA (h, w, 4) float32 of the render region, row 0 = bottom."""
        ev, out = self.film.resolve()
        ev.wait()
        return out

    @_locked
    def passes(self) -> dict:
        """The extra render passes (Film.aux_passes) of the render region."""
        return self.film.aux_passes()

    def _holders(self):
        """(owner's dict, name, buffer) of every device buffer this render holds."""
        import pyopencl as cl
        for obj in (self.bvh, self.scene, self.scene.args, self.film, self.photon_map, self.vps,
                    self, self.volume or {}, self.path_filter or {}):
            items = obj if isinstance(obj, dict) else vars(obj)
            for name, value in list(items.items()):
                if isinstance(value, cl.MemoryObjectHolder):
                    yield items, name, value

    @_locked
    def device_bytes(self) -> int:
        """Bytes of the device buffers this render holds now (the BVH's sorted ids, kept
        between refits, included)."""
        seen, total = set(), 0
        for _, _, buf in self._holders():
            if id(buf) not in seen and buf.int_ptr:
                seen.add(id(buf))
                total += buf.size
        ids = getattr(self.bvh, "sorted_ids", None)
        return total + (ids.nbytes if ids is not None else 0)

    @_locked
    def close(self):
        """Release this render's device buffers now (the device and its programs stay)."""
        ids = getattr(self.bvh, "sorted_ids", None)
        if ids is not None:                      # a pyopencl Array, not a buffer
            ids.data.release()
            self.bvh.sorted_ids = None
        self.photon_map.sorted = None
        released = set()
        for items, name, value in self._holders():
            if id(value) not in released:        # the BVH's buffers are scene args too
                released.add(id(value))
                value.release()
            items[name] = None
