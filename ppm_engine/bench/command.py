"""``python -m ppm_engine bench ...``: the arguments the CLI parsed -> one benchmark run ->
its JSON, plot and markdown blocks (report.py)."""
from __future__ import annotations

import importlib.util
from pathlib import Path

from ..errors import UsageError
from . import curves, glossy, micro, noise, phases, report, shader, skips


def run(args, cmdline: str, progress=print) -> int:
    """Run the benchmark the arguments ask for; outputs go to --json/--plot/--markdown or
    docs/bench/ and docs/BENCHMARKS.md."""
    needed = (("matplotlib",) if args.report else ("OpenEXR", "matplotlib")
              if not (args.micro or args.phases or args.skips or args.shader) else ())
    if args.noise:
        needed = ("OpenEXR",)
    missing = [m for m in needed if importlib.util.find_spec(m) is None]
    if missing:
        raise UsageError(f"the benchmark needs {' and '.join(missing)}: pip install -e "
                         f"\".[bench]\" (or pip install {' '.join(missing)})")
    if args.photons is not None and args.photons < 1:
        raise UsageError("--photons must be at least 1")
    md_path = Path(args.markdown) if args.markdown else report.DOCS / "BENCHMARKS.md"

    def publish(name: str, data: dict, text: str, block: str | None = None) -> int:
        """Print a result, write its JSON (--json or docs/bench/NAME.json) and its markdown
        block (the command line, then ``block`` or ``text``)."""
        data["command"] = cmdline
        print(text)
        report.write_json(data, args.json or report.DOCS / "bench" / f"{name}.json")
        report.replace_block(md_path, name, f"`{cmdline}`\n\n{block or text}")
        return 0

    if args.micro:
        m = micro.run_micro(args.device, quick=args.quick, progress=progress)
        m.update(micro.run_micro_blender(args.device, quick=args.quick, progress=progress))
        m["machine"] = report.machine_info(args.device)
        raw, table = micro.format_micro(m), micro.targets_table(m)
        return publish("micro", m, f"{raw}\n\n{table}", f"```\n{raw}\n```\n\n{table}")
    if args.skips:
        s = skips.run_skips(args.device, quick=args.quick, progress=progress)
        s["machine"] = report.machine_info(args.device)
        return publish("skips", s, skips.format_skips(s))
    if args.glossy:
        from ..blender_io import ensure_registered
        ensure_registered()
        seconds = args.times[0] if args.times else (0.5 if args.quick else 8.0)
        g = glossy.run_glossy(seconds, args.resolution or (24 if args.quick else 96),
                              64 if args.quick else 6000,
                              (0.35, 1.5) if args.quick else glossy.DEFAULT_VALUES,
                              args.device, progress)
        g["machine"] = report.machine_info(args.device)
        return publish("glossy", g, glossy.format_glossy(g))
    if args.noise:
        if args.noise not in curves.SCENES:
            raise UsageError(f"unknown bench scene '{args.noise}'; available: "
                             f"{', '.join(curves.SCENES)}")
        if args.samples < 1 or args.seeds < 2 or args.bounces < 0:
            raise UsageError("--noise needs --samples >= 1, --seeds >= 2 and --bounces >= 0")
        d = noise.run_noise(args.noise, 8 if args.quick else args.samples,
                            2 if args.quick else args.seeds, args.bounces,
                            args.resolution or (16 if args.quick else 128), args.device,
                            progress)
        d["machine"] = report.machine_info(args.device)
        return publish("noise", d, noise.format_noise(d))
    if args.phases or args.shader:
        from ..scenes import EXAMPLES
        name = args.phases or args.shader
        if name not in EXAMPLES:
            raise UsageError(f"unknown scene '{name}'; available: {', '.join(EXAMPLES)}")
        from ..blender_io import ensure_registered
        ensure_registered()
    if args.shader:
        d = shader.run_shader(args.shader, args.resolution or (32 if args.quick else 128),
                              passes=2 if args.quick else args.passes,
                              warmup=1 if args.quick else 2, device=args.device,
                              progress=progress)
        return publish("shader", d, shader.format_shader(d))
    if args.phases:
        res = args.resolution or (32 if args.quick else 256)
        p = phases.run_phases(args.phases, res, passes=2 if args.quick else args.passes,
                              warmup=1 if args.quick else 3, device=args.device,
                              photons=args.photons or (4096 if args.quick else None),
                              progress=progress)
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
        result["ratios"] = curves.ratios(result, result["ratios_at"])
        return _write_curves(result, result.get("command", cmdline), args, md_path, progress,
                             json_out=False)
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
                              args.device, args.photons or q.get("photons"), progress)
    result["command"] = cmdline
    return _write_curves(result, cmdline, args, md_path, progress)


def _write_curves(result: dict, cmdline: str, args, md_path: Path, progress,
                  json_out: bool = True) -> int:
    """The run's JSON, plot and markdown tables (the block starts with the command that
    rendered the figures)."""
    json_path = Path(args.json) if args.json else report.DOCS / "bench" / "bench.json"
    plot_path = Path(args.plot) if args.plot else report.DOCS / "bench" / "error_vs_time.png"
    if json_out:
        report.write_json(result, json_path)
    report.plot(result, plot_path)
    text = (f"`{cmdline}`\n\nReference per scene:\n\n{report.reference_table(result)}\n\n"
            f"Light tracing (the caustic scenes' reference) against Cycles where both converge:"
            f"\n\n{report.light_trace_check_table(result)}\n\n"
            f"Error against time (RMSE over RGB; relative = RMSE / mean of the reference):\n\n"
            f"{report.table(result)}\n\nAt equal time:\n\n{report.ratio_table(result)}")
    print(text)
    report.replace_block(md_path, "curves", text)
    written = f"{json_path}, " if json_out else ""
    progress(f"wrote {written}{plot_path}, {md_path} (the run took {result['total_s']:.0f} s)")
    return 0
