"""LuxCoreRender (the ``pyluxcore`` package: the ``bench`` extra) on the current bpy scene:
its bidirectional path tracer (BIDIRCPU), the benchmark's third estimator for the point light's
caustic in a mirror (issue 15: ours <= 0.5 x its RMSE at 16 s), and its light tracer
(LIGHTCPU), the reference of the bulb box and the mirror caustic (curves.py).  Cycles' path
tracer never finds that caustic and its MNEE only handles refraction; a bidirectional tracer
connects light paths (light -> mirror -> floor) to the camera, so it is the fair competitor
there.

    img, wall, info = render(seconds=16.0, seed=1)   # (h, w, 3) float32, rows top-down
    img, wall, info = render(64.0, 1001, engine=LIGHT_ENGINE)       # the reference's half

The render runs in a child process (``python -m ppm_engine.tools.bench.luxcore``, see ``_child``):
pyluxcore links TBB's malloc proxy, and with it loaded bpy aborts on import and pocl's light
tracer on a free ("free(): invalid pointer").  This process translates the scene and hands the
child plain properties and arrays; so never import pyluxcore beside bpy.

The scene's translation (what is exact, the units) is luxcore_scene.py's.

Film: LuxCore's filter ``width`` is the half-width (blackmanharris.h: the window over
[-width, width]); Cycles' Blackman-Harris of ``filter_width`` w spans [-w, w] with the same
window (film.cpp doubles the width it tabulates over; ppm_engine/render/film.filter_shape), so the
width is passed as it is.  (Light-path splats go through lookup tables, filmsamplesplatter.cpp
and filterdistribution.cpp, that misplace them: 5 tables per axis for 4 steps, so a splat lands
0.025 to 0.225 pixels off, and one whose position in its pixel is 0.6 to 0.75 lands a whole
pixel left of that, on both axes: whatever light paths render, BIDIRCPU's caustic among it,
is smeared by about a third of a pixel (rms); measured below for LIGHTCPU.)  Cycles' box is one
pixel wide whatever the width: LuxCore's BOX of width 0.5.  Cycles' Gaussian over
[-1.5 w, 1.5 w], sigma w / 4: LuxCore's GAUSSIAN of width 1.5 w, alpha 8 / w^2.  The image is
the ``RGB`` output (the radiance groups merged, before any image pipeline), float, LuxCore's
rows bottom-up: flipped to top-down, as the benchmark's EXRs.

Verified (not fitted) at 64x64 against the light tracer and Cycles: LuxCore's PATHCPU on the
translated scenes agrees with the light tracer to 0.1 % in mean (mirror_caustic with a point
light and without the mirror; the Cornell box, where it also matches Cycles' whole image).
BIDIRCPU itself (2.11.2) converges brighter than its own PATHCPU, whatever the filter, sampler,
Russian roulette or normals: +2 % on mirror_caustic's light-traced pixels (+0.4 % on the floor,
up to +7 % low on the back wall; the caustic +1 %), +12 % in the Cornell box.  That bias is part
of its RMSE in the benchmark (``bias_check``).

LIGHTCPU (pathtracer.cpp RenderLightSample, ConnectToEye): paths from the lights, every vertex
that is not specular and not camera-invisible connected to the camera -- what our light tracer
renders: nothing of emitters, mirrors or glass the camera sees (those pixels are left out by
curves.Bench.luxcore_coverage), nor of points that project outside the frame
(``Camera::GetSamplePosition``), so the pixels the filter reaches past the frame's edge are
left out too.  Its film normalises the splats by pixels / light paths
(RADIANCE_PER_SCREEN_NORMALIZED) and the camera's importance by the window's area at unit
distance (perspective.cpp GetPDF): radiance, in the units of the translation.  Path length: 13
vertices (``path.maxdepth``; RenderLightSample stops there), as our light tracer's 12 bounces.
Russian roulette is unbiased (the flux divided by its probability), but a reference need not
trust it: ``path.russianroulette.depth`` is past the path length, so it never plays.  The film
is ``LIGHT_SUPERSAMPLE`` times the scene's resolution along each axis with no filter (each
splat in the one fine pixel it falls in), and ``pixel_filter`` applies Cycles' filter here, by its
integral over each fine pixel: so the splats land where they fall (the tables above put
mirror_caustic's caustic rim 1.7 x the two tracers' noise off ours; with this the RMSE to our light
tracer is their noise's, docs/history/benchmarks-notebook.md, "LuxCore's light tracer as the
reference").  The sampler (SOBOL) renders the same number of light paths a second at 8 x 8 fine
pixels per pixel as at one.

Timing: the budget counts from the session's start (``RenderSession.Start`` preprocesses the
scene and starts the threads) to ``Stop``, polled every 5 ms -- as our ``time_limit`` counts
passes after the scene's preparation and Cycles' after its sync; the wall time returned
includes the translation from bpy, the child process (Python, numpy and pyluxcore start in
~0.25 s), the start and reading the film back (LuxCore's own ``stats.renderengine.time`` and
each phase are in the info).  ``native.threads.count`` is 2 (this machine's cores).  Path
lengths: 13 vertices each way (``path.maxdepth`` / ``light.maxdepth``), 12 bounces as the
benchmark's Cycles and light tracer; Russian roulette and the sampler (SOBOL) are LuxCore's
defaults.
"""
from __future__ import annotations

import importlib.util
import json
import math
import os
import pickle
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from ppm_engine.tools.bench.luxcore_scene import Unsupported, film_size, translate

ENGINE = "BIDIRCPU"
LIGHT_ENGINE = "LIGHTCPU"         # the light tracer: the benchmark's reference (module docstring)
THREADS = 2
MAX_DEPTH = 13                    # path vertices: 12 bounces (harness.cycles_reference's)
# LIGHTCPU's Russian roulette starts at this depth: past MAX_DEPTH, so never (module docstring)
NO_ROULETTE = MAX_DEPTH + 1
# LIGHTCPU's film: this many pixels per pixel along each axis, unfiltered; the pixel filter is
# applied here (``pixel_filter``: LuxCore's own filter tables misplace light splats)
LIGHT_SUPERSAMPLE = 8
POLL_S = 0.005


def unavailable() -> str | None:
    """Why LuxCore cannot render here (None when it can).  Only looks for the package: it is
    imported in the render's own process (``render``)."""
    if importlib.util.find_spec("pyluxcore") is None:
        return "pyluxcore not installed (pip install -e \".[bench]\")"
    return None


# --- the translation --------------------------------------------------------------------------


def film_filter(scene) -> dict:
    """Cycles' pixel filter as LuxCore's (widths: see the module docstring)."""
    cycles = getattr(scene, "cycles", None)
    kind = str(getattr(cycles, "pixel_filter_type", "BLACKMAN_HARRIS"))
    w = max(float(getattr(cycles, "filter_width", 1.5)), 0.01)
    if kind == "BOX":
        return {"film.filter.type": "BOX", "film.filter.width": 0.5}
    if kind == "GAUSSIAN":
        return {"film.filter.type": "GAUSSIAN", "film.filter.width": 1.5 * w,
                "film.filter.gaussian.alpha": 8.0 / (w * w)}
    return {"film.filter.type": "BLACKMANHARRIS", "film.filter.width": w}


def filter_1d(scene):
    """Cycles' pixel filter along one axis: (reach in pixels, f(x) normalised to integral 1).
    Cycles' supports (scene/film.cpp): the box one pixel wide whatever the width, the Gaussian
    over +-1.5 w with sigma w / 4, Blackman-Harris over +-w (the window over twice the width)."""
    cycles = getattr(scene, "cycles", None)
    kind = str(getattr(cycles, "pixel_filter_type", "BLACKMAN_HARRIS"))
    w = max(float(getattr(cycles, "filter_width", 1.5)), 0.01)
    if kind == "BOX":
        return 0.5, lambda x: np.where(np.abs(x) <= 0.5, 1.0, 0.0)
    if kind == "GAUSSIAN":
        norm = (w / 4) * math.sqrt(2 * math.pi) * math.erf(1.5 * math.sqrt(8.0))
        return 1.5 * w, lambda x: np.where(np.abs(x) <= 1.5 * w,
                                           np.exp(-8.0 * (x / w) ** 2) / norm, 0.0)
    a = (0.35875, -0.48829, 0.14128, -0.01168)       # the window's mean over its span: a[0]

    def blackman_harris(x):
        v = 2 * np.pi * (x / (2 * w) + 0.5)
        f = a[0] + a[1] * np.cos(v) + a[2] * np.cos(2 * v) + a[3] * np.cos(3 * v)
        return np.where(np.abs(x) < w, f / (a[0] * 2 * w), 0.0)
    return w, blackman_harris


def pixel_filter(fine: np.ndarray, scene, k: int, steps: int = 16) -> np.ndarray:
    """The scene's pixel filter applied to an unfiltered film of ``k`` x its pixels along each
    axis (rows top-down): pixel (i, j) = sum over the fine pixels (a, b) of w_i(a) w_j(b)
    fine(a, b), w_i(a) the filter's integral over fine pixel a about pixel i's centre (by
    ``steps`` midpoints): each fine pixel being the mean radiance over its area, this is the
    filtered image up to a blur of the fine pixel's width / sqrt(12) (0.036 pixels at k = 8).
    The filter's weight beyond the frame is lost, as LuxCore's and our splats lose it
    (the frame's edge is left out: curves.Bench.luxcore_coverage)."""
    _reach, f = filter_1d(scene)

    def weights(n):
        # fine pixel a spans [a / k, (a + 1) / k) in pixels; the midpoints within it
        x = (np.arange(n * k)[:, None] + (np.arange(steps) + 0.5) / steps) / k
        c = np.arange(n) + 0.5
        return f(x[None, :, :] - c[:, None, None]).mean(-1) / k        # (n, n k)
    h, w = fine.shape[0] // k, fine.shape[1] // k
    wy, wx = weights(h), weights(w)
    return np.einsum("ia,abc,jb->ijc", wy, fine.astype(np.float64), wx,
                     optimize=True).astype(np.float32)


def render_config(scene, seed: int, threads: int = THREADS, engine: str = ENGINE,
                  supersample: int = 1) -> dict:
    """LuxCore's render configuration for the scene's film (module docstring); with
    ``supersample`` > 1 the film has that many pixels per pixel along each axis and no filter
    (``pixel_filter`` applies the scene's)."""
    w, h = film_size(scene)
    k = int(supersample)
    filt = film_filter(scene) if k == 1 else {"film.filter.type": "NONE"}
    cfg = {"renderengine.type": engine, "renderengine.seed": int(seed),
           "native.threads.count": int(threads), "sampler.type": "SOBOL",
           "path.maxdepth": MAX_DEPTH, "light.maxdepth": MAX_DEPTH,
           "film.width": k * w, "film.height": k * h, **filt,
           "film.imagepipelines.0.0.type": "TONEMAP_LINEAR",
           "film.imagepipelines.0.0.scale": 1.0,
           "film.outputs.0.type": "RGB", "film.outputs.0.filename": "luxcore.exr"}
    if engine == LIGHT_ENGINE:
        # a reference: every light path runs its MAX_DEPTH vertices, no roulette to trust
        cfg["path.russianroulette.depth"] = NO_ROULETTE
    return cfg


def render(seconds: float, seed: int, depsgraph=None, threads: int = THREADS,
           engine: str = ENGINE, supersample: int | None = None):
    """Render the current bpy scene (or ``depsgraph``'s) with LuxCore for ``seconds`` of
    rendering: (linear RGB (h, w, 3) float32 rows top-down, wall seconds from the
    translation to the image read back, info).  The render runs in a child process (see
    ``_child``).  ``supersample`` (default: LIGHT_SUPERSAMPLE for LIGHTCPU, else 1): the
    film's pixels per pixel along each axis, unfiltered, then filtered here
    (``pixel_filter``)."""
    import bpy
    t0 = time.perf_counter()
    if depsgraph is None:
        depsgraph = bpy.context.evaluated_depsgraph_get()
    scene = depsgraph.scene
    if supersample is None:
        supersample = LIGHT_SUPERSAMPLE if engine == LIGHT_ENGINE else 1
    tr = translate(depsgraph, supersample)
    if tr.lights == 0:
        raise Unsupported("nothing in the scene emits light")
    job = {"props": tr.props, "meshes": tr.meshes, "objects": tr.objects,
           "config": render_config(scene, seed, threads, engine, supersample),
           "seconds": float(seconds)}
    exposure = max(float(getattr(getattr(scene, "cycles", None), "film_exposure", 1.0)), 0.0)
    t_translated = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="ppm-luxcore-") as tmp:
        job_path, out_path = Path(tmp) / "job.pickle", Path(tmp) / "out.npz"
        with open(job_path, "wb") as f:
            pickle.dump(job, f, protocol=pickle.HIGHEST_PROTOCOL)
        env = dict(os.environ)
        root = str(Path(__file__).resolve().parents[3])
        env["PYTHONPATH"] = root + os.pathsep + env.get("PYTHONPATH", "")
        proc = subprocess.run([sys.executable, "-m", "ppm_engine.tools.bench.luxcore",
                               str(job_path), str(out_path)], env=env, capture_output=True,
                              text=True, timeout=seconds + 120)
        if proc.returncode != 0 or not out_path.is_file():
            raise RuntimeError(f"LuxCore failed (exit {proc.returncode}):\n"
                               f"{proc.stderr.strip()[-3000:]}")
        with np.load(out_path) as out:
            buf, info = out["image"], json.loads(str(out["info"]))
    img = np.ascontiguousarray(buf[::-1]) * np.float32(exposure)     # LuxCore's rows: bottom-up
    if supersample > 1:
        img = pixel_filter(img, scene, supersample)
        info["supersample"] = int(supersample)
    wall = time.perf_counter() - t0
    info.update(translate_s=t_translated - t0, process_s=wall - (t_translated - t0))
    if not np.isfinite(img).all():
        raise RuntimeError("LuxCore returned non-finite pixels")
    return img, wall, info


# --- the child process --------------------------------------------------------------------------
def _properties(lux, values: dict):
    props = lux.Properties()
    for k, v in values.items():
        if isinstance(v, (list, tuple)):
            v = [float(x) for x in v]
        elif isinstance(v, bool):
            pass
        elif isinstance(v, (int, float)):
            v = float(v) if isinstance(v, float) else int(v)
        props.Set(lux.Property(k, v))
    return props


def _child(job: dict):
    """Render one job in this process: (film RGB (h, w, 3) rows bottom-up, info).

    Why a process of its own: pyluxcore's extension links TBB's malloc proxy
    (libtbbmalloc_proxy), which then frees memory that glibc allocated and aborts the process
    ("free(): invalid pointer") once bpy, pyopencl or pocl run beside it; and its import prints
    to stdout.  Its log goes to a buffer, printed on failure; the handler is removed before
    exit (LuxCore logs while Python finalises, where calling back into Python aborts)."""
    import contextlib
    import io
    log: list[str] = []
    with contextlib.redirect_stdout(io.StringIO()):
        import pyluxcore as lux
    lux.Init(lambda text: log.append(text))
    try:
        t0 = time.perf_counter()
        scene = lux.Scene()
        scene.Parse(_properties(lux, job["props"]))
        for name, (v, f, n) in job["meshes"].items():
            scene.DefineMesh(name, list(map(tuple, v.tolist())), list(map(tuple, f.tolist())),
                             None if n is None else list(map(tuple, n.tolist())),
                             None, None, None)
        objects = {}
        for name, o in job["objects"].items():
            objects.update({f"scene.objects.{name}.{k}": v for k, v in o.items()})
        scene.Parse(_properties(lux, objects))
        cfg = job["config"]
        session = lux.RenderSession(lux.RenderConfig(_properties(lux, cfg), scene))
        t1 = time.perf_counter()
        session.Start()
        t_start = time.perf_counter()
        try:
            while True:
                left = job["seconds"] - (time.perf_counter() - t_start)
                if left <= 0:
                    break
                time.sleep(min(POLL_S, left))
            session.UpdateStats()              # (after Stop the statistics read zero)
            t_stop = time.perf_counter()
        finally:
            session.Stop()
        stats = session.GetStats()
        buf = np.zeros((int(cfg["film.height"]), int(cfg["film.width"]), 3), np.float32)
        session.GetFilm().GetOutputFloat(lux.FilmOutputType.RGB, buf)

        def stat(key):
            return float(stats.Get(key).GetValuesString().split()[0])
        info = {"engine": cfg["renderengine.type"], "threads": cfg["native.threads.count"],
                "passes": int(stat("stats.renderengine.pass")),
                "samples": int(stat("stats.renderengine.total.samplecount")),
                "luxcore_render_s": stat("stats.renderengine.time"),
                "rendering_s": t_stop - t_start, "scene_s": t1 - t0, "start_s": t_start - t1,
                "luxcore": lux.Version()}
        return buf, info
    except Exception:
        sys.stderr.write("".join(line if line.endswith("\n") else line + "\n"
                                 for line in log[-40:]))
        raise
    finally:
        lux.SetLogHandler(None)


def main(argv) -> int:
    """``python -m ppm_engine.tools.bench.luxcore JOB.pickle OUT.npz`` (``render`` runs it)."""
    with open(argv[0], "rb") as f:
        job = pickle.load(f)
    buf, info = _child(job)
    np.savez(argv[1], image=buf, info=json.dumps(info))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
