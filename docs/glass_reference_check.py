"""Could Cycles + MNEE be glass_caustic's independent reference? (docs/BENCHMARKS.md: "References,
and how independent each is")

    python docs/glass_reference_check.py 60

Renders the bench's glass_caustic at 128 x 128 by this engine's light tracer (its reference
today) and by Cycles with shadow caustics (MNEE) on, two halves of SECONDS each with the
bench's seeds, and prints over the pixels light tracing covers and over the caustic: the mean
of Cycles + MNEE over the light tracer's, their RMSE, each one's noise (half the RMSE between
its halves) and the caustic's brightest pixel by each."""
import sys
import tempfile
from pathlib import Path

import numpy as np


def main(seconds: float) -> None:
    from ppm_engine.blender.harness import ensure_registered
    from ppm_engine.tools.bench.curves import REF_SEEDS, Bench
    from ppm_engine.tools.bench.scenes import caustic_mask, set_mnee
    ensure_registered()
    b = Bench(128, "", None, Path(tempfile.mkdtemp()), print, False, False)
    scene = b._scene("glass_caustic")
    lt = [b.reference_half(scene, "LIGHT_TRACE", seconds, s) for s in REF_SEEDS]
    cover = lt[0][1] & lt[1][1]
    set_mnee("glass_caustic", True)
    cy = [b.reference_half(scene, "CYCLES", seconds, s)[0] for s in REF_SEEDS]
    light, mnee = 0.5 * (lt[0][0] + lt[1][0]), 0.5 * (cy[0] + cy[1])
    caustic = caustic_mask(scene, "glass_caustic", 128, 128) & cover

    def rmse(a, c, m):
        return float(np.sqrt(((a - c) ** 2)[m].mean()))
    for label, m in (("covered pixels", cover), ("caustic", caustic)):
        print(f"{label} ({int(m.sum())}): mean MNEE / light tracing "
              f"{mnee[m].mean() / light[m].mean():.4f}, RMSE {rmse(mnee, light, m):.4f}, noise "
              f"light tracing {rmse(lt[0][0], lt[1][0], m) / 2:.4f}, MNEE "
              f"{rmse(cy[0], cy[1], m) / 2:.4f}, brightest {light[m].max():.2f} / "
              f"{mnee[m].max():.2f}", flush=True)


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(float(sys.argv[1]))
