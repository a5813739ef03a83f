"""Pass times and a correctness check on a lent GPU (docs/BENCHMARKS.md, "On a GPU"), without
Blender: the array-built scenes of ppm_engine/oracle/procedural.py and
ppm_engine/oracle/analytic.py.

    python docs/gpu_check.py OUT.json

Per scene, milliseconds per pass (median of 30 after 5 to warm up) with the photons' light
tracing on and off, and the analytic mirror caustic's mean over its caustic region against the
image source after 200 passes with light tracing on (what tests/test_light_tracing.py checks
on the CPU).  The device is the engine's default (a GPU where one is registered)."""
import json
import sys
import time

import numpy as np

from ppm_engine.oracle import analytic as A
from ppm_engine.oracle.procedural import cornell_box
from ppm_engine.render.device import get_device, list_devices
from ppm_engine.render.options import RenderOptions
from ppm_engine.render.renderer import Renderer


def pass_ms(scene, passes=30, warmup=5, **opts) -> dict:
    r = Renderer(scene, RenderOptions(**opts))
    for _ in range(warmup):
        r.iterate()
    times = []
    for _ in range(passes):
        t = time.perf_counter()
        s = r.iterate()
        times.append((time.perf_counter() - t) * 1e3)
    out = {"ms_per_pass": float(np.median(times)), "indirect": s.indirect,
           "light_tracing": s.light_tracing, "nan_dropped": s.nan_dropped,
           "phase_ms": {k: round(v, 4) for k, v in s.phase_ms.items()}}
    r.close()
    return out


def main(path: str) -> None:
    dev = get_device("")
    res = {"device": dev.cl_device.name.strip(),
           "devices": [str(d) for d in list_devices()], "scenes": {}}
    scenes = {"cornell_box_512": cornell_box(512, 512),
              "bulb_box_512": cornell_box(512, 512, bulb=True),
              "mirror_caustic_128": A.mirror_caustic(128)}
    for name, scene in scenes.items():
        extra = {"max_bounces": 1} if name.startswith("mirror") else {}
        for lt in (True, False):
            key = f"{name}, light tracing {'on' if lt else 'off'}"
            res["scenes"][key] = pass_ms(scene, light_tracing=lt, **extra)
            print(key, res["scenes"][key], flush=True)
    W = 32
    ref = A.mirror_caustic_radiance(W)
    region = A.mirror_caustic_only(W) > ref / 3
    r = Renderer(A.mirror_caustic(W), RenderOptions(photons_per_pass=1 << 14, max_bounces=1,
                                                    seed=2))
    for _ in range(200):
        s = r.iterate()
    img = r.image()[..., 0]
    r.close()
    res["mirror_caustic_accuracy"] = {
        "caustic_mean_over_exact": float(img[region].mean() / ref[region].mean()),
        "image_mean_over_exact": float(img.mean() / ref.mean()), "nan_dropped": s.nan_dropped}
    print(res["mirror_caustic_accuracy"], flush=True)
    with open(path, "w") as f:
        json.dump(res, f, indent=1)


if __name__ == "__main__":
    main(sys.argv[1])
