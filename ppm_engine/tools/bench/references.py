"""The reference renderers of the error-against-time run (curves.py, whose docstring says which
scene has which reference and why): this engine's light tracer, LuxCore's (LIGHTCPU) with the
pixels it covers, and the exact-geometry references of point_caustic, rough_caustic and far_caustic
(exact_caustic.py: every pixel, the ball's too), of the pool (exact_pool.py) and of fog_lens
(exact_fog.py), as the methods of
``References``, which curves.Bench extends, with the regions scored beside the whole image and
the cross-check of this engine's light tracer against the reference."""
from __future__ import annotations

import time

import numpy as np

from ppm_engine.tools.bench import exact_caustic, exact_pool, luxcore

LIGHT_TRACE_PHOTONS = 1 << 17      # photons per light-tracing pass


class References:
    """curves.Bench's reference renderers (they use its ``device``)."""

    def light_traced(self, seconds: float, seed: int):
        """A light-traced image of the current scene for ``seconds`` (whole passes): (RGB image
        top-down, wall seconds, info, coverage top-down)."""
        import bpy

        from ppm_engine.blender.export import export_scene
        from ppm_engine.render.light_tracer import LightTracer
        t = time.perf_counter()
        lt = LightTracer(export_scene(bpy.context.evaluated_depsgraph_get()),
                         photons=LIGHT_TRACE_PHOTONS, seed=seed, device=self.device,
                         specialize=not self.quick)
        try:
            while True:
                lt.trace(1)
                if time.perf_counter() - t >= seconds:
                    break
            img, cover = lt.image()[::-1].copy(), lt.coverage()[::-1].copy()
        finally:
            lt.close()
        info = {"passes": lt.passes, "photons": lt.passes * lt.photons}
        return img, time.perf_counter() - t, info, cover

    def luxcore_coverage(self) -> np.ndarray:
        """What LuxCore's light tracer renders of the current scene, top-down: what ours does
        (``LightTracer.coverage``: the pixels whose camera ray first meets a non-emitting
        surface with only evaluable closures, eroded by the filter's reach), less the pixels
        whose filter reaches past the frame: LuxCore connects only points that project inside
        the frame (``Camera::GetSamplePosition``), so those miss what lies just outside (the
        outermost row 18 % dark at Blackman-Harris 1.5).  Only a mask: nothing is traced."""
        import bpy

        from ppm_engine.blender.export import export_scene
        from ppm_engine.render.light_tracer import LightTracer
        # (every feature's build, which every scene shares: nothing is traced)
        lt = LightTracer(export_scene(bpy.context.evaluated_depsgraph_get()), photons=1,
                         device=self.device, specialize=False)
        try:
            cover, reach = lt.coverage()[::-1].copy(), lt.reach
        finally:
            lt.close()
        h, w = cover.shape
        y, x = np.mgrid[0:h, 0:w]
        edge = np.minimum(np.minimum(x, w - 1 - x), np.minimum(y, h - 1 - y)) + 0.5
        return cover & (edge >= reach)

    def luxcore_light(self, seconds: float, seed: int):
        """The current scene by LuxCore's light tracer (LIGHTCPU, luxcore.py) for ``seconds``:
        (RGB image top-down, wall seconds, info, coverage top-down).  LIGHTCPU renders what our
        light tracer does (light-path vertices connected to the camera; nothing for emitters,
        mirrors or glass the camera sees), so the same coverage masks it, and the frame's
        edge (``luxcore_coverage``)."""
        img, wall, info = luxcore.render(seconds, seed, engine=luxcore.LIGHT_ENGINE)
        return img, wall, info, self.luxcore_coverage()

    def exact(self, seconds: float, seed: int):
        """point_caustic, rough_caustic or far_caustic by the exact-geometry reference
        (exact_caustic.py) for
        ``seconds`` (whole batches): (RGB image top-down, wall seconds, info, coverage top-down:
        every pixel)."""
        import bpy
        t = time.perf_counter()
        img, cover, info = exact_caustic.render(bpy.context.scene, seed=seed, seconds=seconds)
        return img, time.perf_counter() - t, {"photons": info["photons"]}, cover

    def light_trace_check(self, ref_engine: str, ref, halves, keep, cmask, seconds: float,
                          seed: int) -> dict:
        """This engine's light tracer against the reference (``ref``, the mean of ``halves``)
        over the pixels both render: with Cycles where both converge, on point_caustic the mesh
        ball's light tracing against the exact sphere's, and where LuxCore's light tracer is the
        reference, against that; on those two also over the caustic (``cmask``) and at its
        focus."""
        from ppm_engine.tools.bench.scoring import errors
        lt, _, info, cover = self.light_traced(seconds, seed)
        both = cover & keep
        check = {
            "reference": ref_engine, "seconds": seconds, **info,
            "pixels": int(both.sum()),
            "mean_over_reference": float(lt[both].mean() / ref[both].mean()),
            "rmse": errors(lt, ref, both)["rmse"],
            "reference_noise_rmse": errors(halves[0], halves[1], both)["rmse"] / 2}
        if ref_engine in ("EXACT", "LUXCORE_LIGHT") and (cmask & cover).any():
            # the caustic: where the 48 x 24 mesh's focus differs from the sphere's (on
            # point_caustic), where the two light tracers differ (LuxCore's)
            c = cmask & cover
            focus = np.unravel_index(int(np.argmax(np.where(c, ref[..., 0], -1.0))), c.shape)
            check.update({
                "caustic_pixels": int(c.sum()),
                "caustic_mean_over_reference": float(lt[c].mean() / ref[c].mean()),
                "caustic_rmse": errors(lt, ref, c)["rmse"],
                "caustic_reference_noise_rmse": errors(halves[0], halves[1], c)["rmse"] / 2,
                "focus_pixel": [int(focus[0]), int(focus[1])],
                "focus_reference": float(ref[focus].mean()),
                "focus_light_trace": float(lt[focus].mean())})
        return check

    def regions(self, scene, engine: str, keep, halves):
        """Regions scored beside the whole image: on the exact sphere's scenes ("EXACT") the
        pixels that see the glass ball (through it or in it), which only that reference
        renders; on the scenes of scenes.REGIONS theirs (the fog room's: where its error
        lies).  (masks, their reference noise (RMSE of the halves / 2), what the JSON
        records)."""
        from ppm_engine.tools.bench.exact_caustic_scene import coverage, setup_of
        from ppm_engine.tools.bench.scenes import REGIONS
        from ppm_engine.tools.bench.scoring import errors
        masks = {"ball": ~coverage(setup_of(scene)) & keep} if engine == "EXACT" else {}
        if self.name in REGIONS:
            h, w = keep.shape
            masks.update({k: m & keep for k, m in REGIONS[self.name](scene, w, h).items()})
        noise = {k: errors(halves[0], halves[1], m)["rmse"] / 2 if m.any() else 0.0
                 for k, m in masks.items()}
        return masks, noise, {k: {"pixels": int(m.sum()), "noise_rmse": noise[k]}
                              for k, m in masks.items()}

    def exact_fog(self, seconds: float, seed: int):
        """fog_lens by its exact-geometry reference (exact_fog.py) for ``seconds`` (whole
        batches): (RGB image top-down, wall seconds, info, coverage top-down: the pixels whose
        filter reaches no camera ray through the ball)."""
        import bpy

        from ppm_engine.tools.bench import exact_fog
        t = time.perf_counter()
        img, cover, info = exact_fog.render_for(bpy.context.scene, seconds, seed)
        return img, time.perf_counter() - t, info, cover

    def exact_pool(self, seconds: float, seed: int):
        """pool_caustic by its exact-geometry reference (exact_pool.py) for ``seconds`` (whole
        batches): (RGB image top-down, wall seconds, info, coverage top-down)."""
        import bpy
        t = time.perf_counter()
        img, cover, info = exact_pool.render(bpy.context.scene, seed=seed, seconds=seconds)
        return img, time.perf_counter() - t, {"photons": info["photons"]}, cover
