"""Run time against error: this engine and Cycles on the same scenes (``python -m ppm_engine
bench``; the micro benchmarks are micro.py, the per-phase breakdown phases.py, the skips
skips.py).

For every scene (built by script in bpy, ppm_engine.blender.scenes) and time budget, the scene is
rendered through ``bpy.ops.render.render`` to a 32-bit EXR in a temporary folder and read back
with the OpenEXR package:

- ours: ``scene.ppm.time_limit`` = budget, passes unlimited (1e6), everything else default;
- Cycles: CPU, ``scene.cycles.time_limit`` = budget, samples unlimited, adaptive sampling and
  denoising off, the bounce settings of ``harness.cycles_reference``;
- Cycles + MNEE (caustic scenes only): the same with shadow caustics on (the glass ball or the
  mirror ``cycles.is_caustics_caster``, floor and wall ``is_caustics_receiver``, the light
  ``cycles.is_caustics_light``).
- LuxCore BIDIR (``LUXCORE_SCENES``, when the ``pyluxcore`` package is installed; otherwise the
  JSON says why under ``"luxcore"``): LuxCoreRender's bidirectional path tracer on the scene
  translated from bpy, in a process of its own (luxcore.py), 2 threads, the budget as its
  rendering time.  MNEE handles refraction only, so for the point light's caustic in a mirror
  (issue 15) the bidirectional tracer is the competitor: ours <= 0.5 x its RMSE
  (``TARGETS_LUXCORE``).  LuxCore 2.11's BIDIRCPU converges about 2 % bright on that scene
  (``bias_check``; luxcore.py says where): part of its RMSE is that bias.

Reference per scene: two independent long renders ("halves", different seeds from the timed
renders and from each other), averaged.  Its own noise is RMSE(half_a, half_b) / 2, and
``rmse_corrected`` takes it out of every error.  The estimator that renders it is never the
one measured, and independent of it but on glass_caustic (``REFERENCE_ENGINE``):

- the furnace: the closed form (scenes/furnace.py: L = E / (1 - albedo) everywhere);
- the Cornell box, many_lights, hdri_sun, glossy_metal, sun_cone, fog_room and smoke: Cycles
  (path tracing converges there; on hdri_sun but for the sun's glint and caustic in the glass
  ball, where its reference's noise is most of its own error, and on glossy_metal but for the
  metal's caustics on the floor, which Cycles finds only through the light's 0.1 m; sun_cone
  and the two volume scenes with Cycles' default Light Paths, Filter Glossy and Volume bounces
  0 among them: scenes.LIGHT_PATHS);
- clamped_caustic (a metal ball's glossy caustic under a radius-0 point light, Clamp Direct
  and Indirect 100): Cycles with the same clamp (scenes.LIGHT_PATHS, every render of the scene
  and its reference alike): the clamped image is the one both engines converge to, and Cycles'
  clamped samples are bounded, so its long render converges;
- point_caustic (the glass ball under a radius-0 point light), rough_caustic (the same ball of
  rough glass, GGX roughness 0.1) and far_caustic (a 0.5 m ball, the light 3.5 m away): the
  exact-geometry reference (exact_caustic.py, "EXACT"): in NumPy on the true sphere and the two
  finite planes, the direct light in closed form and the rest by light tracing, sharing no code
  with this engine (independent of its light tracing, one of its own strategies: issue 25).  It
  renders every pixel, the ball's by the camera's chains through the true sphere
  (exact_caustic_camera.py): errors over the whole image, and the ball's pixels (``regions``).
  Cycles with MNEE is no reference there: its focus's brightest pixel is 5.9 where light tracing
  and this engine agree on 32 and 29 (docs/history/benchmarks-notebook.md, "The hard caustic").
  Each half computes the closed form and the chains, then whole batches of photons for the rest;
- fog_lens (a glass ball in fog under a radius-0 point light: the volumetric caustic): the
  exact-geometry reference exact_fog.py ("EXACT_FOG"): in NumPy on the true sphere and box,
  the direct light's single scattering by quadrature, the light through the ball and the
  second scattering by rays splatted along their legs in the fog; the pixels that see the ball
  are left out.  No camera path finds the caustic (Cycles renders none);
- pool_caustic (the sun's caustic on a pool's floor, seen through the waves that make it):
  the exact-geometry reference exact_pool.py ("EXACT_POOL"): in NumPy on the true height field,
  sun photons splatted into every raster position that sees where they land (the camera's
  view through the waves mapped once and inverted by geometry); no light tracing of this
  engine's could render it (no camera connection passes through sharp glass).  Cycles with
  MNEE (a sun, one refracting surface) is its competitor;
- bulb_box and mirror_caustic: LuxCoreRender's light tracer (LIGHTCPU, luxcore.py,
  "LUXCORE_LIGHT"), where Cycles converges slowly (bulb box) or never (a point light's caustic
  in a mirror): light paths connected to the camera, unbiased, no Russian roulette, on the
  scene translated from bpy (luxcore_scene.py), code nobody here wrote, so it stays independent
  of this engine's light tracing.  Each half renders for the reference budget; without
  pyluxcore (the ``bench`` extra; CI installs the ``test`` one) this engine's light tracer
  renders them instead and the JSON says why (``reference["fallback"]``).  It agrees with this
  engine's light tracer within their noise on both (docs/BENCHMARKS.md, "References, and how
  independent each is");
- glass_caustic: this engine's light tracer (ppm_engine/render/light_tracer.py, "LIGHT_TRACE":
  photons connected to the camera, unbiased, no photon map, no radius), although light
  tracing is one of the engine's own strategies: LuxCore has no spot light that matches
  Cycles' (its falloff is not Cycles' smoothstep, it divides by the cosine off the axis and has
  no radius: luxcore_scene.py), and on this scene LIGHTCPU is 1.4 % under the light tracer over
  the covered pixels, its RMSE to it 11 x their noise (7 x in the caustic, whose focus the
  radius-0 spot sharpens; the caustic's mean 0.4 % over).  A reference that far off would
  weigh in every curve's error.

Light tracing, of any kind, renders what the camera sees of surfaces it can evaluate:
where a light-traced reference is used (bulb_box, mirror_caustic, glass_caustic), pixels that
see an emitter or a mirror, glass or smooth glossy surface, or nothing (and their neighbours
within the pixel filter's reach) are left out of that scene's figures (``LightTracer.coverage``;
LuxCore's also the frame's edge, ``Bench.luxcore_coverage``), and the tables say how many
pixels are counted.  The exact references (the three glass balls', the pool's) and
Cycles' count every pixel.  This engine's light tracer is cross-checked in every run
(``light_trace_check``: the means of the two over the covered pixels, and their RMSE
against both references' noise): with Cycles on the Cornell box, on point_caustic, where
it renders the scene's 48 x 24 mesh ball, with the exact sphere, and with LuxCore's light
tracer where that is the reference (both also over the caustic pixels, and the brightest pixel
of the focus: how far the mesh's caustic is from the sphere's).  The JSON also records the
mean brightness of Cycles' longest render over each reference's (``bias_check``).

At the equal-time budget (``EQUAL_TIME``, the targets' point) ours and Cycles are rendered
with three seeds (``EQUAL_TIME_SEEDS``) and the targets compare the mean RMSEs: one render's
RMSE varies by about 3 % from seed to seed, as much as a target's margin.

How the renders are scored (errors, fireflies, the ratios to the targets): scoring.py; the
references' renderers: references.py.
"""
from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

from ppm_engine.blender import session
from ppm_engine.blender.harness import cycles_reference, ensure_registered, read_exr, set_output
from ppm_engine.blender.scenes import build_example, furnace, pool
from ppm_engine.tools.bench import luxcore
from ppm_engine.tools.bench.references import References
from ppm_engine.tools.bench.report import machine_info
from ppm_engine.tools.bench.scenes import (
    CAUSTIC_MASKS,
    LIGHT_PATHS,
    caustic_mask,
    excluded_pixels,
    light_tree_stats,
    set_light_paths,
    set_mnee,
)
from ppm_engine.tools.bench.scoring import (
    FIREFLY_MARGIN,
    brightest,
    errors,
    fireflies,
    ratios,
    stats_info,
)

DEFAULT_TIMES = (2.0, 4.0, 8.0, 16.0, 32.0)
DEFAULT_RESOLUTION = 128
SCENES = ("cornell_box", "furnace", "bulb_box", "glass_caustic", "point_caustic",
          "rough_caustic", "far_caustic", "lifted_caustic", "mirror_caustic", "pool_caustic",
          "many_lights", "hdri_sun", "glossy_metal", "clamped_caustic", "sun_cone", "fog_lens",
          "fog_room", "smoke")
# the caustics of mirrors and glass: Cycles + MNEE is measured too
CAUSTIC_SCENES = ("glass_caustic", "point_caustic", "rough_caustic", "far_caustic",
                  "lifted_caustic", "mirror_caustic", "pool_caustic")
# scenes whose light photons carry (caustics, a bulb in glass, a metal ball's glossy caustic):
# the merge alone is measured too
MERGE_SCENES = (*CAUSTIC_SCENES, "bulb_box", "clamped_caustic")
# reference engine per scene (see the module docstring)
REFERENCE_ENGINE = {"cornell_box": "CYCLES", "furnace": "ANALYTIC", "bulb_box": "LUXCORE_LIGHT",
                    "glass_caustic": "LIGHT_TRACE", "point_caustic": "EXACT",
                    "rough_caustic": "EXACT", "far_caustic": "EXACT", "lifted_caustic": "EXACT",
                    "mirror_caustic": "LUXCORE_LIGHT", "pool_caustic": "EXACT_POOL",
                    "many_lights": "CYCLES", "hdri_sun": "CYCLES", "glossy_metal": "CYCLES",
                    "clamped_caustic": "CYCLES", "sun_cone": "CYCLES", "fog_lens": "EXACT_FOG",
                    "fog_room": "CYCLES", "smoke": "CYCLES"}
REF_SEEDS = (1001, 2002)
# reference seconds per half over the run's (2 x its longest budget): LuxCore's light tracer is the
# noisiest per second (at 2 x 32 s its noise, 0.0098, was most of our 0.0105 on the mirror caustic,
# and the ratio to LuxCore's BIDIR the reference's: docs/history/benchmarks-notebook.md); per scene
# (its entry wins over its engine's) on glossy_metal, whose Cycles reference is slowest where it
# matters most (the metal's caustics on the floor, the light's highlight; 2 x 240 s: noise 0.024),
# and far_caustic, whose big ball's camera chains took most of 2 x 32 s (noise 0.027, ours 0.033),
# and clamped_caustic, whose wall Cycles' clamped samples reach rarely, and the volume scenes
# (Cycles the reference: at 2 x 32 s its noise is half Cycles' at 16 s, pulling ratios to 1)
REF_TIME_FACTOR = {"LUXCORE_LIGHT": 4.0, "EXACT_POOL": 4.0, "glossy_metal": 4.0, "far_caustic": 4.0,
                   "lifted_caustic": 4.0, "clamped_caustic": 4.0, "fog_room": 4.0, "smoke": 4.0}
EQUAL_TIME = 16.0
# scenes with LuxCore's bidirectional path tracer as a curve (issue 15: the point light's caustic
# in a mirror, which no Cycles estimator samples; its target: scoring.TARGETS_LUXCORE)
LUXCORE_SCENES = ("mirror_caustic",)
# at the equal-time budget, the curves the targets compare are rendered with these seeds and
# the ratio is that of the mean RMSEs ("image_rmse_mean"): seed to seed a render's RMSE varies
# by about 3 % (the Cornell box at 16 s), as much as a target's margin
EQUAL_TIME_SEEDS = (1, 2, 3)
WARM_UP_SECONDS = 0.25     # per scene and setting, before the timed curves (run_scene)
SEEDED_CURVES = ("ours", "cycles")
QUICK = dict(times=(0.125, 0.25), resolution=16, ref_seconds=0.5, photons=1 << 13)


# --- rendering through bpy --------------------------------------------------------------------
def ppm_settings(scene, seconds: float, seed: int, device: str, photons: int | None,
                 indirect: str = "AUTO", light_tracing: bool = True,
                 specialize: bool = True) -> None:
    """``specialize`` off (--quick): kernels of every feature, the build every scene shares."""
    if scene.render.engine != "PPM":
        scene.render.engine = "PPM"
    s = scene.ppm
    s.indirect = indirect
    s.light_tracing = light_tracing
    s.passes = 1_000_000
    s.time_limit = seconds
    s.seed = seed
    s.specialize = specialize
    if photons:
        s.photons_per_pass = photons
    if device:
        s.device = device


def render(scene, path) -> tuple[np.ndarray, float, dict]:
    """Render the scene to an EXR at ``path``; (RGB image, wall seconds, extra info)."""
    import bpy
    set_output(scene, path)
    info = {}
    passes = []
    t = time.perf_counter()
    with session.listening(lambda text, fraction: passes.append(text)):
        bpy.ops.render.render(write_still=True)
    wall = time.perf_counter() - t
    if scene.render.engine == "PPM":
        info["passes"] = len(passes)
        # the estimator of indirect light the render used, as its stats line shows it
        info.update(stats_info(passes[-1] if passes else ""))
    img = read_exr(path)[..., :3]
    if not np.isfinite(img).all():
        raise RuntimeError(f"non-finite pixels in {path}")
    return img, wall, info


class Bench(References):
    def __init__(self, resolution: int, device: str, photons: int | None, folder: Path,
                 progress=print, warm_up: bool = True, quick: bool = False):
        self.res = resolution
        self.warm_up = warm_up
        self.quick = quick             # --quick: the references' budgets not scaled up
        self.device = device
        self.photons = photons
        self.folder = folder
        self.progress = progress
        self.count = 0
        self.name = ""                 # the scene _scene built last

    def _scene(self, name):
        import bpy
        self.name = name
        if name == "glossy":        # the glossy spheres of --glossy (glossy.py), for --noise
            from ppm_engine.tools.bench.glossy import build_scene
            return build_scene(self.res)
        if name == "pool_caustic":     # its water meshed as finely as the image needs
            scene = pool.build(grid=pool.grid_for(self.res))
        else:
            scene = build_example(name)
        scene.render.resolution_x = scene.render.resolution_y = self.res
        scene.render.resolution_percentage = 100
        bpy.context.view_layer.update()
        return scene

    def shot(self, scene, engine: str, seconds: float, seed: int, indirect: str = "AUTO",
             light_tracing: bool = True):
        self.count += 1
        if engine == "PPM":
            ppm_settings(scene, seconds, seed, self.device, self.photons, indirect,
                         light_tracing, specialize=not self.quick)
        else:
            cycles_reference(scene, seconds=seconds, seed=seed)
        set_light_paths(scene, self.name)
        return render(scene, self.folder / f"r{self.count:04d}.exr")

    def reference_half(self, scene, engine: str, seconds: float, seed: int):
        """One half of the current scene's reference by ``engine`` (REFERENCE_ENGINE's): (RGB
        image top-down, the pixels it covers top-down, or None where it renders them all)."""
        if engine == "ANALYTIC":                # the furnace's closed form: no noise
            return np.full((self.res, self.res, 3), furnace.radiance(), np.float32), None
        if engine in ("LIGHT_TRACE", "EXACT", "EXACT_POOL", "EXACT_FOG", "LUXCORE_LIGHT"):
            render = {"LIGHT_TRACE": self.light_traced, "EXACT": self.exact,
                      "EXACT_POOL": self.exact_pool, "EXACT_FOG": self.exact_fog,
                      "LUXCORE_LIGHT": self.luxcore_light}[engine]
            img, _wall, _info, cover = render(seconds, seed)
            return img, cover
        return self.shot(scene, engine, seconds, seed)[0], None

    def run_scene(self, name: str, times, ref_seconds: float, equal_time: float | None = None
                  ) -> dict:
        scene = self._scene(name)
        w = h = self.res
        keep = ~excluded_pixels(scene, name, w, h)
        cmask = caustic_mask(scene, name, w, h) & keep
        out = {"resolution": [w, h], "caustic_mask_pixels": int(cmask.sum()),
               "excluded_pixels": int((~keep).sum())}
        out["caustic_mask"] = CAUSTIC_MASKS[name]["note"]
        out["light_paths"] = LIGHT_PATHS.get(name, {})      # beyond 12 bounces, no clamping

        # reference: two independent halves
        ref_engine = REFERENCE_ENGINE[name]
        fallback = None
        if ref_engine == "LUXCORE_LIGHT":
            fallback = luxcore.unavailable()
            if fallback is not None:       # (CI installs no pyluxcore: the test extra)
                ref_engine = "LIGHT_TRACE"
                self.progress(f"[{name}] reference: LuxCore's light tracer unavailable "
                              f"({fallback}), this engine's light tracer instead")
        factor = REF_TIME_FACTOR.get(name, REF_TIME_FACTOR.get(ref_engine, 1.0))
        ref_half = ref_seconds * (1.0 if self.quick else factor)
        halves = []
        for seed in REF_SEEDS:
            self.progress(f"[{name}] reference half (seed {seed}): {ref_engine}, "
                          f"{ref_half:g} s")
            img, cover = self.reference_half(scene, ref_engine, ref_half, seed)
            if cover is not None:
                keep &= cover
                cmask &= cover
            halves.append(img)
        out["excluded_pixels"] = int((~keep).sum())
        out["caustic_mask_pixels"] = int(cmask.sum())
        ref = 0.5 * (halves[0] + halves[1])
        noise_all = errors(halves[0], halves[1], keep)["rmse"] / 2
        noise_c = errors(halves[0], halves[1], cmask)["rmse"] / 2 if cmask.any() else float("nan")
        # the reference's range of brightness: no render's pixel should leave it (issue 25: no
        # firefly that Cycles does not have)
        ref_range = max(brightest(half, keep) for half in halves)
        ceiling = FIREFLY_MARGIN * ref_range
        out["reference"] = {
            "engine": ref_engine, "seeds": list(REF_SEEDS),
            "brightest": brightest(ref, keep), "brightest_half": ref_range,
            "firefly_ceiling": ceiling,
            "seconds_per_half": 0.0 if ref_engine == "ANALYTIC" else ref_half,
            "mean": float(ref[keep].mean()),
            "caustic_mean": float(ref[cmask].mean()) if cmask.any() else float("nan"),
            "noise_rmse": noise_all, "noise_rel_rmse": noise_all / float(ref[keep].mean()),
            "noise_rmse_caustic": noise_c,
        }
        if fallback is not None:
            out["reference"]["fallback"] = {"engine": REFERENCE_ENGINE[name],
                                            "reason": fallback}
        # regions beside the whole image (references.regions: the exact sphere's ball pixels)
        regions, region_noise, out["regions"] = self.regions(scene, ref_engine, keep, halves)
        out["pixels_counted"] = int(keep.sum())
        np.save(self.folder / f"{name}_reference.npy", ref)
        # the light tracer cross-checked (references.light_trace_check), not under a clamp:
        # light tracing renders the unclamped image, and applies no Filter Glossy
        c = scene.cycles
        clamped = c.sample_clamp_direct > 0 or c.sample_clamp_indirect > 0 or c.blur_glossy > 0
        if ref_engine in ("CYCLES", "EXACT", "LUXCORE_LIGHT") and not clamped:
            self.progress(f"[{name}] light-tracing check, {ref_seconds:g} s")
            out["light_trace_check"] = self.light_trace_check(ref_engine, ref, halves, keep,
                                                              cmask, ref_seconds,
                                                              REF_SEEDS[0] + 7)

        # "ours": the default (the estimator of indirect light chosen per scene);
        # "ours_photons": the paper's photons for all indirect light, in the same run;
        # "ours_merge": the default without the photons' light tracing (the merge alone), where
        # photons carry light; (engine, MNEE, indirect light, light tracing)
        curves = {"ours": ("PPM", False, "AUTO", True),
                  "ours_photons": ("PPM", False, "PHOTONS", True),
                  "cycles": ("CYCLES", False, "", True)}
        if name in MERGE_SCENES:
            curves["ours_merge"] = ("PPM", False, "AUTO", False)
        if name in CAUSTIC_SCENES:
            curves["cycles_mnee"] = ("CYCLES", True, "", True)
        # LuxCore renders through luxcore.render, not bpy's render (engine "LUXCORE" below)
        if name in LUXCORE_SCENES:
            reason = luxcore.unavailable()
            if reason is None:
                curves["luxcore_bidir"] = ("LUXCORE", False, "", True)
            else:
                out["luxcore"] = reason
                self.progress(f"[{name}] LuxCore BIDIR skipped: {reason}")
        out["curves"] = {}
        # one untimed short render of each of our settings first: the kernels a scene needs are
        # built (or read from the disk cache) on first use, inside the first pass, and the
        # curve rendered first would pay for them (mirror_caustic at 4 s: 112 passes where the
        # next curve, as fast per pass, got 232)
        for indirect in ("AUTO", "PHOTONS") if self.warm_up else ():
            self.shot(scene, "PPM", WARM_UP_SECONDS, 1, indirect)
        for curve, (engine, mnee, indirect, lt) in curves.items():
            if name in CAUSTIC_SCENES:
                set_mnee(name, mnee)
            rows = []
            for budget in times:
                if engine == "LUXCORE":
                    img, wall, info = luxcore.render(budget, 1)
                else:
                    img, wall, info = self.shot(scene, engine, budget, 1, indirect or "AUTO", lt)
                row = {"seconds": budget, "wall_s": wall, **info,
                       "image": errors(img, ref, keep, noise_all),
                       "caustic": errors(img, ref, cmask, noise_c if cmask.any() else 0.0),
                       **{k: errors(img, ref, m, region_noise[k]) for k, m in regions.items()},
                       "mean_over_reference": float(img[keep].mean() / ref[keep].mean()),
                       **fireflies(img, keep, ceiling)}
                if budget == equal_time and curve in SEEDED_CURVES:
                    # the targets' ratio: mean RMSE over seeds (one render's RMSE varies by a
                    # few percent from seed to seed)
                    per_seed = [row["image"]["rmse"]]
                    flies = [fireflies(img, keep, ceiling)]
                    passes = [info.get("passes")]       # (ours: on a loaded machine they vary)
                    for seed in EQUAL_TIME_SEEDS[1:]:
                        img2, _, info2 = self.shot(scene, engine, budget, seed,
                                                   indirect or "AUTO", lt)
                        per_seed.append(errors(img2, ref, keep, noise_all)["rmse"])
                        passes.append(info2.get("passes"))
                        flies.append(fireflies(img2, keep, ceiling))
                    row["seeds"] = list(EQUAL_TIME_SEEDS)
                    row["image_rmse_seeds"] = per_seed
                    if engine == "PPM":
                        row["passes_seeds"] = passes
                    row["brightest_seeds"] = [f["brightest"] for f in flies]
                    row["over_reference_range_seeds"] = [f["over_reference_range"] for f in flies]
                    row["image_rmse_mean"] = float(np.mean(per_seed))
                rows.append(row)
                what = ("whole image" if row["image"]["pixels"] == w * h
                        else f"{row['image']['pixels']} px")
                self.progress(f"[{name}] {curve:11s} {budget:6.2f} s: RMSE ({what}) "
                              f"{row['image']['rmse']:.4g} (rel {row['image']['rel_rmse']:.3f}), "
                              "caustic RMSE "
                              f"{row['caustic']['rmse']:.4g}, wall {wall:.1f} s"
                              + (f", {info['passes']} passes" if "passes" in info else "")
                              + (f", mean RMSE of seeds {row['seeds']}: "
                                 f"{row['image_rmse_mean']:.4g}" if "seeds" in row else "")
                              + (f" (passes {row['passes_seeds']})" if "passes_seeds" in row
                                 else ""))
            out["curves"][curve] = rows
        if name in CAUSTIC_SCENES:
            set_mnee(name, False)
        tree = light_tree_stats(scene, self.device)
        if tree is not None:
            out["light_tree"] = tree
        last = out["curves"]["cycles"][-1]
        out["bias_check"] = {"cycles_longest_mean_over_reference": last["mean_over_reference"],
                             "ours_longest_mean_over_reference":
                                 out["curves"]["ours"][-1]["mean_over_reference"]}
        if "luxcore_bidir" in out["curves"]:
            out["bias_check"]["luxcore_longest_mean_over_reference"] = \
                out["curves"]["luxcore_bidir"][-1]["mean_over_reference"]
        return out


def run_bench(times=DEFAULT_TIMES, resolution=DEFAULT_RESOLUTION, scenes=SCENES,
              ref_seconds: float | None = None, device: str = "", photons: int | None = None,
              progress=print, warm_up: bool = True, quick: bool = False) -> dict:
    """The error-against-time run; ``warm_up``: each scene's settings rendered once, untimed,
    before its curves (off for --quick, whose budgets time nothing); ``quick``: every
    reference half gets ``ref_seconds`` (no REF_TIME_FACTOR)."""
    import bpy  # noqa: F401 -- fail early without Blender
    ensure_registered()
    times = tuple(float(t) for t in times)
    if ref_seconds is None:
        ref_seconds = max(2.0 * max(times), 1.0)
    result = {"times": list(times), "resolution": resolution, "equal_time": EQUAL_TIME,
              "ref_seconds_per_half": ref_seconds, "machine": machine_info(device),
              "photons_per_pass": photons or "automatic (one per pixel)",
              "started": time.strftime("%Y-%m-%d %H:%M:%S"), "scenes": {}}
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="ppm-bench-") as tmp:
        b = Bench(resolution, device, photons, Path(tmp), progress, warm_up, quick)
        eq = EQUAL_TIME if EQUAL_TIME in times else times[-1]
        for name in scenes:
            result["scenes"][name] = b.run_scene(name, times, ref_seconds, eq)
    result["total_s"] = time.perf_counter() - t0
    result["ratios_at"] = eq
    result["ratios"] = ratios(result, eq)
    return result
