"""Photon guides on and off at equal time (docs/BENCHMARKS.md, "Photon guides"):

    python docs/guide_compare.py LIGHT REF_PASSES [SECONDS ...]
    python docs/guide_compare.py point 600 2 8

LIGHT is ``point``, ``sphere``, ``spot`` or ``area``: procedural.gap_room at 48 x 48, a room lit
through a 0.4 m window by that light outside; or ``inside``: the same room with its point light
moved inside (every photon useful: where guides can only cost); or ``closeup``: that lit room
seen through a 200 mm lens, a 0.4 m patch of floor in a corner (a close-up of a small part of a
large lit scene: most photons land where the camera does not look).  Photons carry all the light
(indirect="photons"), 50K per pass.  The reference is REF_PASSES passes with guides off and
seed 99 (the plain estimator, so it favours the unguided renders if anything); each setting
renders SECONDS after a first pass that builds its kernels, seeds 1 and 2, and the mean RMSE
over every pixel is printed with the passes.  Run it alone on the machine."""
import sys
import time

import numpy as np

from ppm_engine.oracle.procedural import gap_room, look_at
from ppm_engine.render.options import RenderOptions
from ppm_engine.render.renderer import Renderer
from ppm_engine.scene.camera import make_camera, perspective_extent


def render(scene, guided: bool, seed: int, seconds: float = 0.0, passes: int = 0):
    r = Renderer(scene, RenderOptions(passes=1_000_000, photons_per_pass=50_000,
                                      indirect="photons", skip_unguided_photons=guided,
                                      seed=seed))
    try:
        r.iterate()
        t, n = time.perf_counter(), 1
        while (seconds and time.perf_counter() - t < seconds) or n < passes:
            r.iterate()
            n += 1
        return r.image()[..., :3].copy(), n
    finally:
        r.close()


def main(argv) -> int:
    light, ref_passes, times = argv[0], int(argv[1]), [float(s) for s in argv[2:]] or [2.0, 8.0]
    scene = gap_room(48, 48, "point" if light in ("inside", "closeup") else light)
    if light in ("inside", "closeup"):
        lights = scene.lights.copy()
        lights["position"] = (0.0, 0.5, 2.0)
        scene = scene.replace(lights=lights)
    if light == "closeup":
        cam = make_camera(width=48, height=48, extent=perspective_extent(48, 48, 200.0, 36.0)[:2],
                          to_world=look_at((-1.0, 1.0, 1.5), (-1.7, 1.7, 0.0)), clip=(0.05, 100))
        scene = scene.replace(camera=cam)
    ref, _ = render(scene, False, 99, passes=ref_passes)
    print(f"{light}: reference {ref_passes} passes, mean {ref.mean():.5f}")
    for seconds in times:
        for guided in (False, True):
            errs, passes = [], []
            for seed in (1, 2):
                img, n = render(scene, guided, seed, seconds=seconds)
                errs.append(float(np.sqrt(((img - ref) ** 2).mean())))
                passes.append(n)
            print(f"  {seconds:g} s  guides {'on ' if guided else 'off'}  RMSE "
                  f"{np.mean(errs):.5f} (rel {np.mean(errs) / ref.mean():.3f})  passes {passes}",
                  flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
