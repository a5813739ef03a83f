"""One render on one device: scene upload, BVH, and SPPM passes in the paper's order.

    iterate():  eye pass -> grid over visible points -> photon pass -> hash build -> gather
                -> progressive radius update

Every phase is one kernel (or a few) and one timing label; launches are chained on one
in-order queue without host waits, and the small per-pass statistics are read once at the end.
"""
from __future__ import annotations

import dataclasses
import time

import numpy as np

from .bvh import BVH
from .device import get_device
from .emitters import build_emitters
from .features import defines as feature_defines, scene_features, used_materials
from .film import Film, filter_table
from .materials import MAT_DIFFUSE, kernel_materials
from .options import RenderOptions
from .photon_map import (CNT_ACTIVE, CNT_NAN, CNT_OCCUPIED, CNT_OUTSIDE, CNT_OVERFLOW, CNT_STORED,
                         GRID_DTYPE, N_COUNTERS, PhotonMap)
from .scene_arrays import LIGHT_DTYPE, TEXTURE_DTYPE, SceneArrays


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
        s = f"Pass {self.pass_index}{of} · {_si(self.photons_emitted)} photons"
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


def _round(n: int, wg: int = 64) -> int:
    return max(wg, (n + wg - 1) // wg * wg)


def check_finite(scene: SceneArrays) -> None:
    """Refuse NaN/Inf in the camera, a material or the world with a SceneError naming it."""
    from .errors import SceneError
    for name in ("camera", "materials"):
        a = getattr(scene, name)
        for field in a.dtype.names:
            bad = ~np.isfinite(a[field]).reshape(len(a), -1).all(axis=1)
            if a.dtype[field].kind == "f" and bad.any():
                k = int(np.nonzero(bad)[0][0])
                what = "camera" if name == "camera" else (
                    f"material '{scene.material_names[k]}'" if k < len(scene.material_names)
                    else f"material {k}")
                raise SceneError(f"the {what} has NaN or infinite values in '{field}': fix "
                                 "them and render again")
    if not np.isfinite(scene.world).all():
        raise SceneError("the world colour has NaN or infinite values: fix its strength or colour")


def prepare_scene(scene: SceneArrays) -> tuple[SceneArrays, list[str]]:
    """The scene as the device renders it, and warnings (docs/STABILITY.md):
      * triangles with a NaN/Inf corner are dropped (as the exporter does), NaN/Inf shading
        normals fall back to the geometric normal, lights with NaN/Inf values are dropped;
      * NaN/Inf in the camera, the world or a material is refused with a SceneError;
      * a scene far from the origin (|centre| > 4 x its size) is moved to it, in float64:
        the kernels' ULP-scaled ray offsets and float32 hit points then work at the
        precision of the scene's size, not of its distance (a box 1e5 from the origin).
    The shift depends on the positions only, so the same geometry always gets the same one."""
    check_finite(scene)
    warnings = []
    changes = {}
    good = np.isfinite(scene.positions).all(axis=(1, 2))
    if not good.all():
        warnings.append(f"{int((~good).sum())} triangles with NaN or infinite vertex coordinates "
                        "were skipped")
        changes.update(positions=scene.positions[good], normals=scene.normals[good],
                       uvs=scene.uvs[good], material=scene.material[good],
                       visibility=scene.visibility[good])
    uv = changes.get("uvs", scene.uvs)
    if not np.isfinite(uv).all():
        changes["uvs"] = np.where(np.isfinite(uv), uv, 0.0).astype(np.float32)
    nrm = changes.get("normals", scene.normals)
    if not np.isfinite(nrm).all():
        changes["normals"] = np.where(np.isfinite(nrm), nrm, 0.0).astype(np.float32)
    lights = scene.lights
    lf = [f for f in lights.dtype.names if lights.dtype[f].kind == "f"]
    ok = np.ones(lights.shape[0], bool)
    for f in lf:
        ok &= np.isfinite(lights[f]).reshape(lights.shape[0], -1).all(axis=1) if ok.size else ok
    if not ok.all():
        warnings.append(f"{int((~ok).sum())} lights with NaN or infinite values were skipped")
        changes["lights"] = lights = lights[ok]
    pos = changes.get("positions", scene.positions).reshape(-1, 3).astype(np.float64)
    if pos.shape[0]:
        lo, hi = pos.min(axis=0), pos.max(axis=0)
        centre = np.float32(0.5 * (lo + hi)).astype(np.float64)
        if np.abs(centre).max() > 4 * max(float((hi - lo).max()), 1e-30):
            changes["positions"] = (pos - centre).astype(np.float32).reshape(-1, 3, 3)
            lights = lights.copy()
            lights["position"] = lights["position"].astype(np.float64) - centre
            cam = scene.camera.copy()
            cam["to_world"][0, :, 3] = cam["to_world"][0, :, 3].astype(np.float64) - centre
            changes.update(lights=lights, camera=cam)
    return (scene.replace(**changes) if changes else scene), warnings


def offset_scale(scene: SceneArrays) -> float:
    """A power of two near half the scene's largest extent (1 for the 2 m Cornell box): the
    scale of the absolute ray offsets near the axis planes (kernels/geometry.h offset_ray)."""
    pos = scene.positions.reshape(-1, 3)
    if pos.shape[0] == 0:
        return 1.0
    extent = float((pos.max(axis=0).astype(np.float64) - pos.min(axis=0)).max())
    if not (extent > 0 and np.isfinite(extent)):
        return 1.0
    return float(2.0 ** int(np.clip(np.round(np.log2(extent / 2)), -60, 60)))


class Renderer:
    # initial radius when options.initial_radius == 0: this many pixel footprints at the point
    AUTO_RADIUS_PIXELS = 2.0
    # photon buffer capacity per emitted photon (grows when a pass overflows)
    STORE_FACTOR = 2
    # adaptive sampling (options.noise_threshold > 0): pixels are judged from this many passes
    # on, every ADAPTIVE_EVERY passes
    ADAPTIVE_MIN_PASSES = 32
    ADAPTIVE_EVERY = 8

    def __init__(self, scene: SceneArrays, options: RenderOptions):
        import pyopencl as cl
        self.options = options.validate()
        self.scene = scene
        self.device = dev = get_device(options.device)
        self.queue = dev.queue
        w, h = scene.resolution
        self.width, self.height = w, h
        self.n_pixels = w * h
        t0 = time.perf_counter()

        prepared, self.warnings = prepare_scene(scene)   # NaN/Inf dropped (docs/STABILITY.md)
        self.bvh = BVH(dev, prepared)
        self._upload_scene(scene, prepared)

        self._fetch_kernels()

        self.film = Film(dev, w, h)
        self._allocate_pixels()
        self.counters = dev.buffer(4 * N_COUNTERS, "counters")
        cl.enqueue_fill_buffer(self.queue, self.counters, np.uint32(0), 0, 4 * N_COUNTERS)
        self.photons_per_pass = options.photons_for(self.n_pixels)
        self.photon_map = PhotonMap(dev, self.STORE_FACTOR * self.photons_per_pass,
                                    exact=options.exact_gather)

        self.photons_needed = self._photons_needed()
        self.passes_done = 0
        self.nan_dropped = 0
        self.active_pixels = self.n_pixels
        self.setup_seconds = time.perf_counter() - t0
        self.queue.finish()

    # ------------------------------------------------------------------------------------------
    def _upload_scene(self, scene: SceneArrays, prepared: SceneArrays | None = None):
        """Everything but the BVH: materials, emitters, lights, camera, pixel filter."""
        up = self.device.upload
        self.scene = scene
        if prepared is None:
            prepared, self.warnings = prepare_scene(scene)
        self._prepared = scene = prepared    # the BVH's triangles, moved as the BVH's
        self.kmaterials = kernel_materials(scene.materials)
        self._used = used_materials(scene, self.kmaterials.shape[0])
        self._offset_scale = offset_scale(scene)
        self.emitters = build_emitters(scene, self.kmaterials, self.bvh.leaf_order)
        self.normals = up(scene.normals, "shading normals")
        self.uvs = up(scene.uvs, "UVs")
        self.textures = up(scene.textures if scene.textures.size else np.zeros(1, TEXTURE_DTYPE),
                           "textures")
        self.texels = up(scene.texels if scene.texels.size else np.zeros((1, 4), np.float16),
                         "image textures")
        self.materials = up(self.kmaterials, "materials")
        lights = scene.lights if scene.lights.shape[0] else np.zeros(1, LIGHT_DTYPE)
        self.lights = up(lights, "lights")
        cdf = self.emitters.cdf
        self.cdf = up(cdf if cdf.size else np.zeros(1, np.float32), "emitters")
        em = self.emitters.emissive_leaves
        self.emissive = up(em if em.size else np.zeros(1, np.int32), "emissive triangles")
        self.emitter_info = up(self.emitters.info, "emitters")
        self.camera = up(scene.camera, "camera")
        self.filter_table = up(filter_table(float(scene.camera["filter_width"][0])),
                               "pixel filter")

    def _photons_needed(self) -> bool:
        """Whether photon passes can add anything (else no photon pass, hash or gather runs):
        something emits, paths may bounce (max_bounces > 0), and some surface is diffuse --
        photons are stored, and visible points made, only on diffuse surfaces."""
        diffuse = bool((self.kmaterials["flags"][self._used] & MAT_DIFFUSE).any())
        return bool(self.emitters.info["n_emitters"][0] > 0 and self.options.max_bounces > 0
                    and diffuse)

    def _fetch_kernels(self):
        """The eye and photon passes built for the scene's features (features.py; each feature
        set is built once per device and cached)."""
        self.features = (scene_features(self._prepared, self.kmaterials, self.emitters, self._used)
                         if self.options.specialize else None)
        # (one more build for a scene far from 1 m in size)
        self.defines = {"PPM_OFFSET_SCALE": float(self._offset_scale).hex() + "f",
                        **feature_defines(self.features)}
        P = self.device.programs
        self.k_eye = P.get("eye_pass.cl", self.defines).eye_pass
        self.k_photon = P.get("photon_pass.cl", self.defines).photon_pass

    @staticmethod
    def same_geometry(a: SceneArrays, b: SceneArrays) -> bool:
        """True when the BVH of ``a`` serves ``b`` (same triangles, materials, visibility)."""
        return all(np.array_equal(getattr(a, k), getattr(b, k))
                   for k in ("positions", "material", "visibility"))

    def refit(self, scene: SceneArrays) -> bool:
        """The same triangles moved or deformed (an object's transform, an armature): the BVH is
        refitted over its hierarchy instead of rebuilt, and the scene re-uploaded.  Returns
        False (nothing changed) when the triangle count differs or the refitted tree would be
        too slow (bvh.BVH.refit); then build a new Renderer.  Call reset() afterwards."""
        prepared, warnings = prepare_scene(scene)
        if prepared.n_triangles != self.bvh.n_triangles or not self.bvh.refit(prepared):
            return False
        self.warnings = warnings
        self._upload_scene(scene, prepared)
        self._fetch_kernels()
        return True

    def can_reuse(self, options: RenderOptions, scene: SceneArrays | None = None) -> bool:
        """Whether reset() can serve a render with these options and scene."""
        return (options.device == self.options.device
                and (scene is None or self.same_geometry(self.scene, scene)))

    def reset(self, options: RenderOptions, scene: SceneArrays | None = None):
        """Start a new render on the same device, keeping the BVH and the built programs
        (persistent data): a new film, statistics and photon storage; a new scene whose
        geometry is unchanged (``same_geometry``) re-uploads only what it changed."""
        import pyopencl as cl
        options = options.validate()
        if not self.can_reuse(options, scene):
            raise ValueError("reset() needs the same device and geometry; build a new Renderer")
        old, self.options = self.options, options
        if scene is not None and scene is not self.scene:
            self._upload_scene(scene)
        self._fetch_kernels()
        w, h = self.scene.resolution
        photons = options.photons_for(w * h)
        if ((w, h) != (self.width, self.height) or photons != self.photons_per_pass
                or options.exact_gather != old.exact_gather):
            self.width, self.height, self.n_pixels = w, h, w * h
            self._allocate_pixels()
            self.photons_per_pass = photons
            self.photon_map = PhotonMap(self.device, self.STORE_FACTOR * photons,
                                        exact=options.exact_gather)
        self.film = Film(self.device, w, h)
        cl.enqueue_fill_buffer(self.queue, self.counters, np.uint32(0), 0, 4 * N_COUNTERS)
        self.photons_needed = self._photons_needed()
        self.passes_done = 0
        self.nan_dropped = 0
        self.active_pixels = self.n_pixels
        self.queue.finish()

    def _allocate_pixels(self):
        dev, n = self.device, self.n_pixels
        self.vp_pos = dev.buffer(16 * n, "visible points")
        self.vp_nrm = dev.buffer(16 * n, "visible points")
        self.vp_beta = dev.buffer(16 * n, "visible points")
        self.gathered = dev.buffer(16 * n, "gather results")

    def _scene_args(self):
        b = self.bvh
        return (b.nodes, b.tri_v0, b.tri_e1, b.tri_e2, self.normals, self.materials, self.lights,
                self.cdf, self.emissive, self.emitter_info, self.textures, self.texels, self.uvs)

    # ------------------------------------------------------------------------------------------
    def iterate(self) -> PassStats:
        """Run one SPPM pass."""
        import pyopencl as cl
        t0 = time.perf_counter()
        o, q, n = self.options, self.queue, self.n_pixels
        pass_id = np.uint32(self.passes_done)
        seed = np.uint32(o.seed)
        events = []

        def run(label, kernel, size, *args, local=None):
            ev = kernel(q, (size,), local, *args)
            events.append((label, ev))
            return ev

        cl.enqueue_fill_buffer(q, self.counters, np.uint32(0), 4, 4 * (N_COUNTERS - 1))  # keep NaNs
        run("eye", self.k_eye, _round(n), self.camera, *self._scene_args(), pass_id, seed,
            np.int32(o.max_bounces), np.float32(o.initial_radius),
            np.float32(self.AUTO_RADIUS_PIXELS), self.filter_table, self.film.direct_pass,
            self.film.radius, self.film.radius0,
            self.vp_pos, self.vp_nrm, self.vp_beta, self.counters, self.film.aux_albedo,
            self.film.aux_normal, self.film.active)
        pm = self.photon_map
        events += pm.enqueue_grid(q, self.vp_pos, self.film.radius, n)
        emitted = 0
        if self.photons_needed:
            P = self.photons_per_pass
            run("photon", self.k_photon, _round(P), *self._scene_args(), pass_id, seed,
                np.int32(o.max_bounces), np.uint32(P), pm.grid, np.uint32(pm.capacity),
                pm.ph_pos, pm.ph_flux, self.counters)
            emitted = P
            events += pm.enqueue_build(q, self.counters, self.passes_done, o.seed)
            events += pm.enqueue_gather(q, self.vp_pos, self.vp_nrm, self.film.radius,
                                        self.gathered, n)
            events.append(("update", self.film.update(q, self.vp_pos, self.vp_beta,
                                                      self.gathered, o.alpha)))
        events.append(("update", self.film.add_sample(q, self.gathered, emitted)))
        converge = (o.noise_threshold > 0 and self.passes_done + 1 >= self.ADAPTIVE_MIN_PASSES
                    and (self.passes_done + 1) % self.ADAPTIVE_EVERY == 0)
        if converge:
            events.append(("adaptive", self.film.converge(
                q, o.noise_threshold, self.ADAPTIVE_MIN_PASSES, self.counters, CNT_ACTIVE)))
        counters = np.empty(N_COUNTERS, np.uint32)
        grid = np.empty(1, GRID_DTYPE)
        cl.enqueue_copy(q, counters, self.counters, is_blocking=False)
        cl.enqueue_copy(q, grid, pm.grid, is_blocking=False)
        q.finish()

        self.passes_done += 1
        if converge:
            self.active_pixels = int(counters[CNT_ACTIVE])
        self.nan_dropped = int(counters[CNT_NAN])
        phase_ms: dict[str, float] = {}
        for label, ev in events:
            phase_ms[label] = phase_ms.get(label, 0.0) + (ev.profile.end - ev.profile.start) * 1e-6
        overflow = int(counters[CNT_OVERFLOW])
        stats = PassStats(
            pass_index=self.passes_done, photons_emitted=self.film.photons_emitted,
            photons_stored=min(int(counters[CNT_STORED]), pm.capacity),
            photons_outside=int(counters[CNT_OUTSIDE]), photons_dropped=overflow,
            occupied_entries=int(counters[CNT_OCCUPIED]),
            visible_points=int(grid["valid"][0]), radius_min=float(grid["r_min"][0]),
            radius_max=float(grid["r_max"][0]), nan_dropped=self.nan_dropped,
            seconds=time.perf_counter() - t0, phase_ms=phase_ms,
            active_pixels=self.active_pixels, pixels=n)
        if overflow:     # this pass lost photons (counted); the next one has room
            pm.allocate(2 * pm.capacity)
        return stats

    def image(self) -> np.ndarray:
        """Linear RGBA (h, w, 4) float32 of the render region, row 0 = bottom."""
        ev, out = self.film.resolve()
        ev.wait()
        return out

    def passes(self) -> dict:
        """The extra render passes (Film.aux_passes) of the render region."""
        return self.film.aux_passes()

    def close(self):
        """Release this render's device buffers now (the device and its programs stay)."""
        import pyopencl as cl
        ids = getattr(self.bvh, "sorted_ids", None)
        if ids is not None:                      # a pyopencl Array, not a buffer
            ids.data.release()
            self.bvh.sorted_ids = None
        for obj in (self.bvh, self.film, self.photon_map, self):
            for name, value in list(vars(obj).items()):
                if isinstance(value, cl.MemoryObjectHolder):
                    value.release()
                    setattr(obj, name, None)
