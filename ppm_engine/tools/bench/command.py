"""``python -m ppm_engine bench ...``: the benchmark's own arguments (the core CLI hands them
over unparsed) -> one benchmark run -> its JSON, plot and markdown blocks (report.py), in the
folder --out names: by default the checkout's docs/ when run from a checkout, else
./ppm_bench."""
from __future__ import annotations

import argparse
import importlib.util
from pathlib import Path

from ppm_engine.errors import UsageError
from ppm_engine.tools.bench import (
    curves,
    digest,
    glossy,
    micro,
    noise,
    phases,
    report,
    scoring,
    shader,
    skips,
)

# where a run from an installed package (no checkout beside it) writes, in the current folder
DEFAULT_OUT = "ppm_bench"


def build_parser(prog: str = "python -m ppm_engine bench") -> argparse.ArgumentParser:
    b = argparse.ArgumentParser(
        prog=prog, description="Benchmark: error against time against Cycles (and LuxCore on "
        "the mirror caustic), or --micro, --phases, --skips, --noise ... (docs/BENCHMARKS.md)")
    b.add_argument("--times", type=float, nargs="+", metavar="S",
                   help="time budgets in seconds (default 2 4 8 16 32)")
    b.add_argument("--resolution", type=int, metavar="N", help="square image size (default 128; "
                   "--phases: 256)")
    b.add_argument("--scenes", nargs="+", metavar="NAME", help="scenes (default: all of them)")
    b.add_argument("--ref-seconds", type=float, metavar="S",
                   help="seconds per reference half (default 2 x the longest budget)")
    b.add_argument("--photons", type=int, help="photons per pass (default: the engine's)")
    b.add_argument("--light-tracing-kappa", type=float, metavar="K",
                   help="the photons' light tracing against the merge: the balance heuristic's "
                        "kappa for this run (default options.LIGHT_TRACING_KAPPA; for choosing "
                        "it by measurement)")
    b.add_argument("--device", default="", help="OpenCL device for our engine")
    b.add_argument("--quick", action="store_true", help="tiny sizes (seconds): what CI runs")
    b.add_argument("--micro", action="store_true", help="the micro benchmarks instead")
    b.add_argument("--strategies", action="store_true",
                   help="what each strategy (camera paths, the merge, light tracing) brings to "
                        "the photon scenes' images (--scenes, --times: one budget)")
    b.add_argument("--denoise", action="store_true",
                   help="denoised RMSE against the reference: ours through OIDN beside Cycles "
                        "with its OIDN at equal time (--times, default 4 16; --scenes; "
                        "bench/denoise.py)")
    b.add_argument("--viewport", action="store_true",
                   help="the viewport's latencies (camera move, material edit, transform, second "
                        "open), kernel builds per edit, cold starts per scene and memory per "
                        "session (bench/viewport_latency.py)")
    b.add_argument("--skips", action="store_true",
                   help="what each skip of work a scene does not need saves, with and without")
    b.add_argument("--phases", metavar="SCENE", help="per-phase breakdown of a pass of SCENE")
    b.add_argument("--light-tracing", choices=("on", "off"), default="on",
                   help="--phases: with or without the photons' light tracing (default on)")
    b.add_argument("--glossy", action="store_true",
                   help="which glossy lobes to gather: error at equal time per gather roughness "
                        "(the budget: --times S, default 8)")
    b.add_argument("--glossy-setting", choices=tuple(glossy.SETTINGS), default="gather_roughness",
                   help="--glossy: the setting measured (default gather_roughness; "
                        "caustic_roughness: which glossy reflections' light eye paths carry)")
    b.add_argument("--glossy-light", choices=glossy.LIGHTS, default="area",
                   help="--glossy: the spheres under the area light or a 2 cm point light")
    b.add_argument("--shader", metavar="SCENE",
                   help="what the shader programs cost per pass of SCENE (its colours computed "
                        "by a node graph against the same constants)")
    b.add_argument("--noise", metavar="SCENE",
                   help="noise per sample of a bench scene, ours against Cycles at the same "
                        "samples per pixel (--samples, --seeds, --bounces), and each one's "
                        "samples per second")
    b.add_argument("--samples", type=int, default=550,
                   help="--noise: samples (our passes) per pixel (default 550)")
    b.add_argument("--seeds", type=int, default=4, help="--noise: seeds per engine (default 4)")
    b.add_argument("--bounces", type=int, default=12,
                   help="--noise: bounces for both engines (0: direct light only; default 12)")
    b.add_argument("--diffuse-bounces", type=int, default=None,
                   help="--noise: Light Paths > Diffuse for both engines (default: the scene's)")
    b.add_argument("--report", metavar="JSON",
                   help="write the tables and plot again from a run's JSON (no rendering): "
                        "the same figures, the current report's layout and targets")
    b.add_argument("--passes", type=int, default=8,
                   help="--phases, --shader: timed passes (default 8)")
    b.add_argument("--digest", action="store_true",
                   help="a fingerprint of the images (every example scene and a material zoo, "
                        "each indirect-light mode): SHA-256 per image, to show a change keeps "
                        "every pixel (run with POCL_MAX_PTHREAD_COUNT=1; bench/digest.py)")
    b.add_argument("--compare", metavar="JSON",
                   help="--digest: compare with an earlier digest's JSON (exit 1 if one differs)")
    b.add_argument("--out", metavar="DIR",
                   help="folder of the outputs: BENCHMARKS.md (the tables, each in its "
                        "<!-- bench:NAME --> block), bench/NAME.json and the plot (default: "
                        f"the checkout's docs/ when run from a checkout, else ./{DEFAULT_OUT})")
    b.add_argument("--json", metavar="PATH", help="JSON output (default OUT/bench/bench.json, "
                   "micro.json, phases.json ...)")
    b.add_argument("--plot", metavar="PATH", help="plot (default OUT/bench/error_vs_time.png)")
    b.add_argument("--markdown", metavar="PATH", help="markdown file whose <!-- bench:NAME --> "
                   "block gets the tables (default OUT/BENCHMARKS.md; the "
                   "error-against-time run's: OUT/bench/full_run.md)")
    return b


def output_dir(out: str | None) -> Path:
    """The folder the outputs go to: ``out``, else the checkout's docs/ (the package run from
    a checkout, with docs/BENCHMARKS.md beside it), else DEFAULT_OUT in the current folder."""
    if out:
        return Path(out)
    if (report.DOCS / "BENCHMARKS.md").is_file():
        return report.DOCS
    return Path.cwd() / DEFAULT_OUT


def main(argv: list[str], cmdline: str, progress=print) -> int:
    """Parse the benchmark's arguments and run it (argparse exits 2 on bad arguments)."""
    return run(build_parser().parse_args(argv), cmdline, progress)


def run(args, cmdline: str, progress=print) -> int:
    """Run the benchmark the arguments ask for; outputs go to --json/--plot/--markdown or the
    output folder's bench/ and BENCHMARKS.md (output_dir)."""
    needed = (("matplotlib",) if args.report else ("OpenEXR", "matplotlib")
              if not (args.micro or args.phases or args.skips or args.shader or args.digest
                      or args.strategies or args.viewport)
              else ())
    if args.noise:
        needed = ("OpenEXR",)
    missing = [m for m in needed if importlib.util.find_spec(m) is None]
    if missing:
        raise UsageError(f"the benchmark needs {' and '.join(missing)}: pip install -e "
                         f"\".[bench]\" (or pip install {' '.join(missing)})")
    if args.photons is not None and args.photons < 1:
        raise UsageError("--photons must be at least 1")
    if args.light_tracing_kappa is not None:
        if not args.light_tracing_kappa > 0:
            raise UsageError("--light-tracing-kappa must be above 0 (the Light Tracing setting "
                             "turns it off)")
        # the renders run in this process (bpy's engine drives a Renderer)
        from ppm_engine.render import renderer
        renderer.LIGHT_TRACING_KAPPA = float(args.light_tracing_kappa)
    out = output_dir(args.out)
    md_path = Path(args.markdown) if args.markdown else out / "BENCHMARKS.md"

    def publish(name: str, data: dict, text: str, block: str | None = None) -> int:
        """Print a result, write its JSON (--json or OUT/bench/NAME.json) and its markdown
        block (the command line, then ``block`` or ``text``)."""
        data["command"] = cmdline
        print(text)
        json_path = args.json or out / "bench" / f"{name}.json"
        report.write_json(data, json_path)
        report.replace_block(md_path, name, f"`{cmdline}`\n\n{block or text}")
        progress(f"wrote {json_path}, {md_path}")
        return 0

    if args.digest:
        from ppm_engine.blender.harness import ensure_registered
        ensure_registered()
        d = digest.run_digest(args.device, progress=progress)
        json_path = args.json or out / "bench" / "digest.json"
        report.write_json(d, json_path)
        progress(f"wrote {json_path}")
        if args.compare:
            text, n_differ = digest.compare(d, args.compare)
            print(text)
            return 1 if n_differ else 0
        return 0
    if args.micro:
        m = micro.run_micro(args.device, quick=args.quick, progress=progress)
        m.update(micro.run_micro_blender(args.device, quick=args.quick, progress=progress))
        m["machine"] = report.machine_info(args.device)
        raw, table = micro.format_micro(m), micro.targets_table(m)
        return publish("micro", m, f"{raw}\n\n{table}", f"```\n{raw}\n```\n\n{table}")
    if args.strategies:
        from ppm_engine.tools.bench import strategies
        st = strategies.run_strategies(
            args.times[0] if args.times else (0.5 if args.quick else 8.0),
            args.resolution or (16 if args.quick else 128), args.scenes or strategies.SCENES,
            args.device, progress)
        st["machine"] = report.machine_info(args.device)
        return publish("strategies", st, strategies.format_strategies(st))
    if args.denoise:
        from ppm_engine.tools.bench import denoise
        d = denoise.run_denoise(
            tuple(args.times) if args.times else ((0.25,) if args.quick else denoise.TIMES),
            args.resolution or (16 if args.quick else 128),
            tuple(args.scenes) if args.scenes else (("cornell_box",) if args.quick
                                                    else denoise.SCENES),
            args.ref_seconds or (0.5 if args.quick else None), args.device, progress,
            quick=args.quick)
        d["machine"] = report.machine_info(args.device)
        return publish("denoise", d, denoise.format_denoise(d))
    if args.viewport:
        from ppm_engine.tools.bench import viewport_latency as viewport
        from ppm_engine.tools.bench import viewport_textured
        v = viewport.run_viewport(args.device, quick=args.quick, progress=progress,
                                  textured=viewport_textured.textured_edits)
        v["machine"] = report.machine_info(args.device)
        return publish("viewport", v, viewport.format_viewport(v))
    if args.skips:
        s = skips.run_skips(args.device, quick=args.quick, progress=progress)
        s["machine"] = report.machine_info(args.device)
        return publish("skips", s, skips.format_skips(s))
    if args.glossy:
        from ppm_engine.blender.harness import ensure_registered
        ensure_registered()
        seconds = args.times[0] if args.times else (0.5 if args.quick else 8.0)
        g = glossy.run_glossy(seconds, args.resolution or (24 if args.quick else 96),
                              64 if args.quick else 6000,
                              (0.35, 1.5) if args.quick
                              else glossy.SETTINGS[args.glossy_setting],
                              args.device, progress, args.glossy_setting, args.glossy_light)
        g["machine"] = report.machine_info(args.device)
        return publish("glossy", g, glossy.format_glossy(g))
    if args.noise:
        if args.noise not in (*curves.SCENES, "glossy"):
            raise UsageError(f"unknown bench scene '{args.noise}'; available: "
                             f"{', '.join(curves.SCENES)}, glossy (--glossy's spheres)")
        if (args.samples < 1 or args.seeds < 2 or args.bounces < 0
                or (args.diffuse_bounces is not None and args.diffuse_bounces < 0)):
            raise UsageError("--noise needs --samples >= 1, --seeds >= 2, --bounces >= 0 and "
                             "--diffuse-bounces >= 0")
        d = noise.run_noise(args.noise, 8 if args.quick else args.samples,
                            2 if args.quick else args.seeds, args.bounces,
                            args.resolution or (16 if args.quick else 128), args.device,
                            progress, diffuse_bounces=args.diffuse_bounces)
        d["machine"] = report.machine_info(args.device)
        return publish("noise", d, noise.format_noise(d))
    if args.phases or args.shader:
        from ppm_engine.blender.scenes import EXAMPLES
        name = args.phases or args.shader
        if name not in EXAMPLES:
            raise UsageError(f"unknown scene '{name}'; available: {', '.join(EXAMPLES)}")
        from ppm_engine.blender.harness import ensure_registered
        ensure_registered()
    if args.shader:
        d = shader.run_shader(args.shader, args.resolution or (32 if args.quick else 128),
                              passes=2 if args.quick else args.passes,
                              warmup=1 if args.quick else 2, device=args.device,
                              progress=progress, specialize=not args.quick)
        return publish("shader", d, shader.format_shader(d))
    if args.phases:
        res = args.resolution or (32 if args.quick else 256)
        p = phases.run_phases(args.phases, res, passes=2 if args.quick else args.passes,
                              warmup=1 if args.quick else 3, device=args.device,
                              photons=args.photons or (4096 if args.quick else None),
                              progress=progress, light_tracing=args.light_tracing == "on")
        return publish("phases", p, phases.format_phases(p))
    if args.report:
        import json
        try:
            result = json.loads(Path(args.report).read_text())
        except (OSError, ValueError) as e:
            raise UsageError(f"cannot read the benchmark JSON {args.report}: {e}") from None
        result = report.from_json(result)
        if "scenes" not in result or "ratios_at" not in result:
            raise UsageError(f"{args.report} is not the JSON of a 'python -m ppm_engine bench' "
                             "run")
        result["ratios"] = scoring.ratios(result, result["ratios_at"])
        return _write_curves(result, result.get("command", cmdline), args, out, md_path,
                             progress, json_out=False)
    q = curves.QUICK if args.quick else {}
    times = tuple(args.times) if args.times else q.get("times", curves.DEFAULT_TIMES)
    if any(t <= 0 for t in times):
        raise UsageError("--times must be positive")
    res = args.resolution or q.get("resolution", curves.DEFAULT_RESOLUTION)
    scenes = tuple(args.scenes) if args.scenes else curves.SCENES
    unknown = [s for s in scenes if s not in curves.REFERENCE_ENGINE]
    if unknown:
        raise UsageError(f"unknown bench scene(s) {', '.join(unknown)}; available: "
                         f"{', '.join(curves.SCENES)}")
    result = curves.run_bench(times, res, scenes, args.ref_seconds or q.get("ref_seconds"),
                              args.device, args.photons or q.get("photons"), progress,
                              warm_up=not args.quick, quick=args.quick)
    result["command"] = cmdline
    return _write_curves(result, cmdline, args, out, md_path, progress)


FULL_RUN_HEAD = ("# The benchmark's full run\n\nEvery table of the last error-against-time run, "
                 "written by `python -m ppm_engine bench` (the summary: "
                 "[BENCHMARKS.md](../BENCHMARKS.md)).\n\n")


def _write_curves(result: dict, cmdline: str, args, out: Path, md_path: Path, progress,
                  json_out: bool = True) -> int:
    """The run's JSON, plot and markdown tables (the block starts with the command that
    rendered the figures)."""
    json_path = Path(args.json) if args.json else out / "bench" / "bench.json"
    plot_path = Path(args.plot) if args.plot else out / "bench" / "error_vs_time.png"
    if json_out:
        report.write_json(result, json_path)
    report.plot(result, plot_path)
    text = (f"`{cmdline}`\n\nReference per scene:\n\n{report.reference_table(result)}\n\n"
            f"This engine's light tracer (glass_caustic's reference, and the bulb box's and "
            f"mirror_caustic's without pyluxcore) against Cycles where both converge, on "
            f"point_caustic's mesh ball against the exact sphere's reference, and against "
            f"LuxCore's light tracer where that is the reference:"
            f"\n\n{report.light_trace_check_table(result)}\n\n"
            f"Error against time (RMSE over RGB; relative = RMSE / mean of the reference):\n\n"
            f"{report.table(result)}\n\nAt equal time:\n\n{report.ratio_table(result)}\n\n"
            f"Light trees (next-event estimation among many emitters):\n\n"
            f"{report.light_tree_table(result)}")
    print(text)
    # the full run's tables go to their own page (bench/full_run.md) unless --markdown names a
    # file: BENCHMARKS.md keeps the summary and links there
    if not args.markdown:
        md_path = out / "bench" / "full_run.md"
        if not md_path.is_file():
            md_path.parent.mkdir(parents=True, exist_ok=True)
            md_path.write_text(FULL_RUN_HEAD)
    report.replace_block(md_path, "curves", text)
    written = f"{json_path}, " if json_out else ""
    progress(f"wrote {written}{plot_path}, {md_path} (the run took {result['total_s']:.0f} s)")
    return 0
