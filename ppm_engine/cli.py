"""Command line: render a .blend headless, list OpenCL devices, write the example scenes.

    python -m ppm_engine render SCENE.blend -o OUT.png|OUT.exr [--passes N] [--time-limit S]
                                [--resolution WxH] [--device NAME] [--photons N] [--seed N]
                                [--noise-threshold T] [--frame N | --frames A-B]
    python -m ppm_engine devices
    python -m ppm_engine example NAME OUT.blend
    python -m ppm_engine bench [--quick] [--times S ...] [--resolution N] [--micro]
                               [--phases SCENE] [--skips] (docs/BENCHMARKS.md)

The .blend is treated as untrusted: it is opened without running its embedded scripts.
Errors print one line on stderr and exit with 1 (failed) or 2 (bad arguments or settings).
"""
import argparse
import importlib.util
import sys
import time
from pathlib import Path

from .errors import PPMError
from .options import LIMITS, RenderOptions, SettingsError

PROG = "ppm_engine"
EXIT_FAILED = 1
EXIT_USAGE = 2

# extension -> (file_format, color_depth)
OUTPUT_FORMATS = {
    ".png": ("PNG", "8"),
    ".exr": ("OPEN_EXR", "32"),
}

# zstd (Blender >= 3.0 compression), gzip (older compression), plain
_BLEND_MAGIC = (b"BLENDER", b"\x28\xb5\x2f\xfd", b"\x1f\x8b")


class CLIError(Exception):
    def __init__(self, message: str, code: int = EXIT_FAILED):
        super().__init__(message)
        self.code = code


def _say(message: str) -> None:
    print(f"{PROG}: {message}", file=sys.stderr, flush=True)


# ------------------------------------------------------------------------------------------------
def _parse_resolution(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WxH such as 640x480, got '{text}'") from None
    if not (4 <= w <= 65536 and 4 <= h <= 65536):
        raise argparse.ArgumentTypeError(f"resolution {w}x{h} is outside 4..65536 per side")
    return w, h


def _parse_frames(text: str) -> tuple[int, int]:
    try:
        a, b = (int(v) for v in text.split("-", 1)) if "-" in text[1:] else (int(text),) * 2
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a frame range such as 1-24, got '{text}'") \
            from None
    if b < a:
        raise argparse.ArgumentTypeError(f"frame range {a}-{b} ends before it starts")
    return a, b


def _build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=PROG, description="Progressive Photon Mapping for Blender")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    r = sub.add_parser("render", help="render a .blend with the PPM engine")
    r.add_argument("scene", help="the .blend file (its scripts are never run)")
    r.add_argument("-o", "--output", required=True, help="output image, .png (8-bit) or .exr (32-bit float)")
    r.add_argument("--passes", type=int, help="number of SPPM passes")
    r.add_argument("--time-limit", type=float, help="stop after this many seconds (0 = no limit)")
    r.add_argument("--resolution", type=_parse_resolution, metavar="WxH", help="image size (at 100%%)")
    r.add_argument("--device", help="OpenCL device: a key from 'devices', part of its name, or DEFAULT")
    r.add_argument("--photons", type=int, help="photons per pass (default: the file's setting, "
                   "normally automatic: one per pixel)")
    r.add_argument("--seed", type=int, help="random seed")
    fr = r.add_mutually_exclusive_group()
    fr.add_argument("-f", "--frame", type=int, metavar="N",
                    help="the frame to render (default: the file's current frame)")
    fr.add_argument("--frames", type=_parse_frames, metavar="A-B",
                    help="render frames A to B (an animation); '#' in the output path is the "
                         "frame number (out_####.png), else _#### goes before the extension")
    r.add_argument("--noise-threshold", type=float, metavar="T",
                   help="adaptive sampling: stop pixels whose noise is below T (0 = off)")

    sub.add_parser("devices", help="list the OpenCL devices")

    e = sub.add_parser("example", help="write an example scene")
    e.add_argument("name", help="example name")
    e.add_argument("output", help="the .blend to write")

    b = sub.add_parser("bench", help="benchmark: error against time vs Cycles, --micro, --phases")
    b.add_argument("--times", type=float, nargs="+", metavar="S",
                   help="time budgets in seconds (default 2 4 8 16 32)")
    b.add_argument("--resolution", type=int, metavar="N", help="square image size (default 128; "
                   "--phases: 256)")
    b.add_argument("--scenes", nargs="+", metavar="NAME", help="scenes (default: all four)")
    b.add_argument("--ref-seconds", type=float, metavar="S",
                   help="seconds per reference half (default 2 x the longest budget)")
    b.add_argument("--photons", type=int, help="photons per pass (default: the engine's)")
    b.add_argument("--device", default="", help="OpenCL device for our engine")
    b.add_argument("--quick", action="store_true", help="tiny sizes (seconds): what CI runs")
    b.add_argument("--micro", action="store_true", help="the micro benchmarks instead")
    b.add_argument("--skips", action="store_true",
                   help="what each skip of work a scene does not need saves, with and without")
    b.add_argument("--phases", metavar="SCENE", help="per-phase breakdown of a pass of SCENE")
    b.add_argument("--passes", type=int, default=8, help="--phases: timed passes (default 8)")
    b.add_argument("--json", metavar="PATH", help="JSON output (default docs/bench/bench.json, "
                   "micro.json or phases.json)")
    b.add_argument("--plot", metavar="PATH", help="plot (default docs/bench/error_vs_time.png)")
    b.add_argument("--markdown", metavar="PATH", help="markdown file whose <!-- bench:NAME --> "
                   "block gets the tables (default docs/BENCHMARKS.md)")
    return p


def main(argv=None) -> int:
    args = _build_parser().parse_args(argv)
    try:
        return {"render": cmd_render, "devices": cmd_devices, "example": cmd_example,
                "bench": cmd_bench}[args.command](args)
    except CLIError as e:
        _say(f"error: {e}")
        return e.code
    except SettingsError as e:
        _say(f"error: {e}")
        return EXIT_USAGE
    except PPMError as e:
        _say(f"error: {e}")
        return EXIT_FAILED


# ------------------------------------------------------------------------------------------------
def cmd_devices(args) -> int:
    from .device import list_devices
    devices = list_devices()
    if not devices:
        raise CLIError("no OpenCL device found: install a GPU OpenCL driver or the PoCL CPU "
                       "device (pip install pocl-binary-distribution)")
    for d in devices:
        print(f"{d.key}\t{d.type}\t{d.name} ({d.platform})")
    return 0


def cmd_example(args) -> int:
    out = Path(args.output).resolve()
    if out.suffix.lower() != ".blend":
        raise CLIError(f"the example is saved as a .blend, got '{args.output}'", EXIT_USAGE)
    if not out.parent.is_dir():
        raise CLIError(f"output folder does not exist: {out.parent}")
    from .scenes import EXAMPLES, save_example
    if args.name not in EXAMPLES:
        raise CLIError(f"unknown example '{args.name}'; available: {', '.join(EXAMPLES)}", EXIT_USAGE)
    _ensure_registered()
    save_example(args.name, str(out))
    _say(f"wrote {out}")
    return 0


def cmd_render(args) -> int:
    src = Path(args.scene)
    if not src.is_file():
        raise CLIError(f"scene file not found: {src}")
    with open(src, "rb") as f:
        head = f.read(8)
    if not head.startswith(_BLEND_MAGIC):
        raise CLIError(f"not a .blend file: {src}")
    out = Path(args.output).resolve()
    if out.suffix.lower() not in OUTPUT_FORMATS:
        raise CLIError(f"unsupported output format '{out.suffix or out.name}': use .png or .exr",
                       EXIT_USAGE)
    if not out.parent.is_dir():
        raise CLIError(f"output folder does not exist: {out.parent}")
    overrides = {name: value for name, value in (
        ("passes", args.passes), ("time_limit", args.time_limit),
        ("photons_per_pass", args.photons), ("seed", args.seed),
        ("noise_threshold", args.noise_threshold)) if value is not None}
    RenderOptions().replace(**overrides).validate()      # refuse bad values before loading Blender

    import bpy
    _ensure_registered()
    try:
        # never use_scripts=True: the file is untrusted and its scripts stay off
        bpy.ops.wm.open_mainfile(filepath=str(src.resolve()), load_ui=False)
    except RuntimeError as e:
        raise CLIError(f"cannot open {src}: {_blender_message(e)}") from None
    scene = bpy.context.scene
    if scene.render.engine != "PPM":      # setting it again would drop a persistent engine
        scene.render.engine = "PPM"
    if scene.render.engine != "PPM":      # BLENDER_NOTES section 9: never render another engine
        raise CLIError("could not select the PPM render engine in the loaded file")

    _apply_settings(scene, overrides, args.device)
    if args.resolution:
        scene.render.resolution_x, scene.render.resolution_y = args.resolution
        scene.render.resolution_percentage = 100
    from . import session
    tty = sys.stderr.isatty()

    def listener(text):                 # "[#####     ]  50 % Pass 32/64 · ..." per pass
        f = session.progress_fraction
        line = f"[{'#' * int(20 * f):<20}] {100 * f:3.0f} % {text}"
        if tty:                         # one line, redrawn
            print(f"\r{PROG}: {line}\033[K", end="", file=sys.stderr, flush=True)
        else:
            _say(line)
    session.progress_listeners.append(listener)
    t0 = time.perf_counter()
    try:
        if args.frames:                     # blender -b FILE -E PPM -s A -e B -a
            scene.frame_start, scene.frame_end = args.frames
            _set_output(scene, _frame_pattern(out))
            bpy.ops.render.render(animation=True)
            written = [Path(scene.render.frame_path(frame=f))
                       for f in range(args.frames[0], args.frames[1] + 1)]
        else:                               # blender -b FILE -E PPM -f N
            scene.frame_set(args.frame if args.frame is not None else scene.frame_current)
            _set_output(scene, out)
            if "#" in out.name:             # write_still does not expand '#': frame_path does
                scene.render.filepath = scene.render.frame_path(frame=scene.frame_current)
            bpy.ops.render.render(write_still=True)
            written = [Path(scene.render.filepath)]
    except RuntimeError as e:
        raise CLIError(f"render failed: {_blender_message(e)}") from None
    finally:
        session.progress_listeners.remove(listener)
        if tty:
            print(file=sys.stderr)
    missing = [str(p) for p in written if not p.is_file()]
    if missing:
        raise CLIError(f"render finished but {', '.join(missing)} was not written")
    _say(f"wrote {', '.join(str(p) for p in written)} in {time.perf_counter() - t0:.1f} s")
    return 0


def _frame_pattern(out: Path) -> Path:
    """The output path of an animation: '#' runs are the frame number; without any, _####
    goes before the extension (out.png -> out_0001.png)."""
    if "#" in out.name:
        return out
    return out.with_name(f"{out.stem}_####{out.suffix}")


_DOCS = Path(__file__).resolve().parents[1] / "docs"


def _replace_block(path: Path, name: str, text: str) -> None:
    """Put ``text`` between <!-- bench:NAME --> and <!-- /bench:NAME --> in ``path`` (the block
    is appended when the file or the markers do not exist yet)."""
    begin, end = f"<!-- bench:{name} -->", f"<!-- /bench:{name} -->"
    block = f"{begin}\n{text.strip()}\n{end}"
    old = path.read_text() if path.is_file() else ""
    if begin in old and end in old:
        head, rest = old.split(begin, 1)
        new = head + block + rest.split(end, 1)[1]
    else:
        new = (old.rstrip() + "\n\n" if old.strip() else "") + block + "\n"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(new)


def cmd_bench(args) -> int:
    """python -m ppm_engine bench [--quick] [--micro | --phases SCENE] ..."""
    from . import bench
    needed = ("OpenEXR", "matplotlib") if not (args.micro or args.phases or args.skips) else ()
    missing = [m for m in needed if importlib.util.find_spec(m) is None]
    if missing:
        raise CLIError(f"the benchmark needs {' and '.join(missing)}: pip install -e \".[bench]\" "
                       f"(or pip install {' '.join(missing)})", EXIT_USAGE)
    cmdline = "python -m ppm_engine " + " ".join(sys.argv[1:]) if sys.argv[1:] else "python -m ppm_engine bench"
    progress = lambda text: _say(text)  # noqa: E731
    md_path = Path(args.markdown) if args.markdown else _DOCS / "BENCHMARKS.md"
    if args.photons is not None and args.photons < 1:
        raise CLIError("--photons must be at least 1", EXIT_USAGE)

    def publish(name: str, data: dict, text: str, block: str | None = None) -> int:
        """Print a result, write its JSON (--json or docs/bench/NAME.json) and its markdown
        block (the command line, then ``block`` or ``text``)."""
        print(text)
        bench.write_json(data, args.json or _DOCS / "bench" / f"{name}.json")
        _replace_block(md_path, name, f"`{cmdline}`\n\n{block or text}")
        return 0
    if args.micro:
        from . import bench_micro
        m = bench_micro.run_micro(args.device, quick=args.quick, progress=progress)
        _ensure_registered()
        m.update(bench_micro.run_micro_blender(args.device, quick=args.quick, progress=progress))
        m["machine"] = bench.machine_info(args.device)
        m["command"] = cmdline
        raw, table = bench_micro.format_micro(m), bench_micro.targets_table(m)
        return publish("micro", m, f"{raw}\n\n{table}", f"```\n{raw}\n```\n\n{table}")
    if args.skips:
        from . import bench_skips
        _ensure_registered()
        s = bench_skips.run_skips(args.device, quick=args.quick, progress=progress)
        s["machine"] = bench.machine_info(args.device)
        s["command"] = cmdline
        return publish("skips", s, bench_skips.format_skips(s))
    if args.phases:
        from .scenes import EXAMPLES
        if args.phases not in EXAMPLES:
            raise CLIError(f"unknown scene '{args.phases}'; available: {', '.join(EXAMPLES)}",
                           EXIT_USAGE)
        _ensure_registered()
        res = args.resolution or (32 if args.quick else 256)
        p = bench.run_phases(args.phases, res, passes=2 if args.quick else args.passes,
                             warmup=1 if args.quick else 3, device=args.device,
                             photons=args.photons or (4096 if args.quick else None),
                             progress=progress)
        p["command"] = cmdline
        return publish("phases", p, bench.format_phases(p))
    q = bench.QUICK if args.quick else {}
    times = tuple(args.times) if args.times else q.get("times", bench.DEFAULT_TIMES)
    if any(t <= 0 for t in times):
        raise CLIError("--times must be positive", EXIT_USAGE)
    res = args.resolution or q.get("resolution", bench.DEFAULT_RESOLUTION)
    scenes = tuple(args.scenes) if args.scenes else bench.SCENES
    unknown = [s for s in scenes if s not in bench.REFERENCE_ENGINE]
    if unknown:
        raise CLIError(f"unknown bench scene(s) {', '.join(unknown)}; available: "
                       f"{', '.join(bench.SCENES)}", EXIT_USAGE)
    result = bench.run_bench(times, res, scenes, args.ref_seconds or q.get("ref_seconds"),
                             args.device, args.photons or q.get("photons"), progress)
    result["command"] = cmdline
    json_path = Path(args.json) if args.json else _DOCS / "bench" / "bench.json"
    plot_path = Path(args.plot) if args.plot else _DOCS / "bench" / "error_vs_time.png"
    bench.write_json(result, json_path)
    bench.plot(result, plot_path)
    text = (f"`{cmdline}`\n\nReference per scene:\n\n{bench.reference_table(result)}\n\n"
            f"Error against time (RMSE over RGB; relative = RMSE / mean of the reference):\n\n"
            f"{bench.table(result)}\n\nAt equal time:\n\n{bench.ratio_table(result)}")
    print(text)
    _replace_block(md_path, "curves", text)
    _say(f"wrote {json_path}, {plot_path}, {md_path} in {result['total_s']:.0f} s")
    return 0


# ------------------------------------------------------------------------------------------------
def _ensure_registered() -> None:
    from . import register
    from .engine import PPMRenderEngine
    if not PPMRenderEngine.is_registered:
        register()


def _blender_message(e: Exception) -> str:
    text = " ".join(str(e).split())
    return text[len("Error: "):] if text.startswith("Error: ") else text


def _apply_settings(scene, overrides: dict, device: str | None) -> None:
    """Validate the file's settings with the overrides, then store the overrides in scene.ppm.
    (Validation comes first: Blender would silently clamp an out-of-range assignment.)"""
    from .properties import DEFAULT_DEVICE, refresh_devices
    settings = scene.ppm
    stored = {name: getattr(settings, name) for name in LIMITS}
    if settings.auto_photons:
        stored["photons_per_pass"] = None
    RenderOptions(**stored).replace(**overrides).validate()
    for name, value in overrides.items():
        setattr(settings, name, value)
    if device is not None:
        settings.device = _resolve_device(device, refresh_devices(), DEFAULT_DEVICE)


def _resolve_device(name: str, items, default_key: str) -> str:
    """A device key from a key, a case-insensitive part of a device name, or DEFAULT."""
    if name.upper() == default_key:
        return default_key
    keys = [item[0] for item in items if item[0] != default_key]
    if name in keys:
        return name
    low = name.lower()
    match = [item[0] for item in items if item[0] != default_key
             and (low in item[1].lower() or low in item[2].lower())]
    if not match:
        listed = ", ".join(f"'{k}'" for k in keys) or "none"
        raise CLIError(f"no OpenCL device matches '{name}'; available: {listed}", EXIT_USAGE)
    return match[0]


def _set_output(scene, out: Path) -> None:
    file_format, depth = OUTPUT_FORMATS[out.suffix.lower()]
    settings = scene.render.image_settings
    if hasattr(settings, "media_type"):     # Blender 5.0: single image, not multilayer
        settings.media_type = "IMAGE"
    settings.file_format = file_format
    settings.color_mode = "RGBA"
    settings.color_depth = depth
    scene.render.use_file_extension = True
    scene.render.filepath = str(out)
