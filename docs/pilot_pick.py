"""Could Automatic pick the estimator of indirect light by a pilot's measured error per second?
(docs/BENCHMARKS.md: "Settings chosen by measurement")

    python docs/pilot_pick.py 8,32 cornell_box,furnace,point_caustic,glossy_metal

For each example scene at 128 x 128 and each pilot length K (passes), both estimators (eye
paths with caustic photons, and the paper's photons) render K passes twice (seeds 11 and 12,
after an untimed pass that builds the kernels).  From the pair: one K-pass render's noise per
pixel (the mean squared difference over 2), its seconds, and for the photons their bias from
the two estimators' means (their squared difference less both noises: the eye paths are
unbiased).  Printed per scene and K: each estimator's noise and ms per pass, and what a pick
would predict at 4 and 16 s:

- "fixed": the paths' error falling as 1/T, the photons' (noise + bias) as T^-2/3 (SPPM's
  asymptotic rate for alpha 2/3) and as T^-0.8;
- "fitted" (two or more K): each estimator's own rate, from its noise at the first two K.

The bench's run says which is right: on the Cornell box the photons are ahead at 4 and 16 s,
everywhere else here the paths are (or they tie).  Run it alone on the machine: it times."""
import math
import sys
import time

import numpy as np

RESOLUTION = 128


def pilot(arrays, indirect: str, passes: int):
    from ppm_engine.render.options import RenderOptions
    from ppm_engine.render.renderer import Renderer
    images, seconds = [], []
    for seed in (11, 12):
        o = RenderOptions(seed=seed, indirect=indirect)
        r = Renderer(arrays, o)
        r.iterate()                     # the kernels' build
        r.reset(o)
        t = time.perf_counter()
        for _ in range(passes):
            r.iterate()
        seconds.append(time.perf_counter() - t)
        images.append(r.image()[..., :3].astype(np.float64))
        r.close()
    noise = float(np.mean((images[0] - images[1]) ** 2) / 2)
    return noise, float(np.mean(seconds)), 0.5 * (images[0] + images[1])


def main(ks: list[int], scenes: list[str]) -> None:
    import bpy

    from ppm_engine.blender.export import export_scene
    from ppm_engine.blender.scenes import build_example
    for name in scenes:
        scene = build_example(name)
        scene.render.resolution_x = scene.render.resolution_y = RESOLUTION
        bpy.context.view_layer.update()
        arrays = export_scene(bpy.context.evaluated_depsgraph_get())
        runs = {k: {ind: pilot(arrays, ind, k) for ind in ("paths", "photons")} for k in ks}
        rate = {}
        if len(ks) > 1:
            a, b = runs[ks[0]], runs[ks[1]]
            for ind in ("paths", "photons"):
                rate[ind] = math.log(a[ind][0] / b[ind][0]) / math.log(b[ind][1] / a[ind][1])
        for k, run in runs.items():
            (vp, sp, mp), (vq, sq, mq) = run["paths"], run["photons"]
            # (each mean is of two renders: half a render's noise each)
            bias2 = max(float(np.mean((mp - mq) ** 2)) - (vp + vq) / 2, 0.0)
            print(f"{name}, K = {k}: paths noise {vp:.3g} ({sp / k * 1e3:.1f} ms per pass), "
                  f"photons noise {vq:.3g} ({sq / k * 1e3:.1f} ms), photons' bias^2 "
                  f"{bias2:.3g}" + (f"; rates paths {rate['paths']:.2f}, photons "
                                   f"{rate['photons']:.2f}" if rate else ""), flush=True)
            for budget in (4.0, 16.0):
                picks = []
                for label, ex_p, ex_q in (("fixed 2/3", 1.0, 2 / 3), ("fixed 0.8", 1.0, 0.8),
                                          *((("fitted", rate["paths"], rate["photons"]),)
                                            if rate else ())):
                    e_p = vp * (sp / budget) ** ex_p
                    e_q = (vq + bias2) * (sq / budget) ** ex_q
                    picks.append(f"{label}: paths {math.sqrt(e_p):.4g}, photons "
                                 f"{math.sqrt(e_q):.4g} -> {'photons' if e_q < e_p else 'paths'}")
                print(f"   at {budget:g} s: " + "; ".join(picks), flush=True)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main([int(k) for k in sys.argv[1].split(",")], sys.argv[2].split(","))
