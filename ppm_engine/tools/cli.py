"""Command line: argument parsing and dispatch.

    python -m ppm_engine render SCENE.blend -o OUT.png|OUT.exr [--passes N] [--time-limit S]
                                [--resolution WxH] [--device NAME] [--photons N] [--seed N]
                                [--noise-threshold T] [--indirect auto|photons|paths]
                                [--light-tracing on|off] [--path-filter on|off] [--denoise]
                                [--frame N | --frames A-B]
                                [--pass-range A-B] [--dask tcp://HOST:PORT | local:N]
    python -m ppm_engine render SCENE.blend --pass-range A-B -o PART.npz
    python -m ppm_engine merge PART.npz [PART.npz ...] -o OUT.exr|OUT.png|OUT.npz
    python -m ppm_engine devices
    python -m ppm_engine example NAME OUT.blend
    python -m ppm_engine package [-o dist] [--platforms linux-x64,...] [--no-denoise]
    python -m ppm_engine bench [--quick] [--times S ...] [--out DIR] [--micro]
                               [--phases SCENE] [--skips] [--noise SCENE] ... (its own
                               arguments: ppm_engine/tools/bench/command.py; docs/BENCHMARKS.md)

Rendering a .blend is batch.py (its scripts are never run), the benchmark is the bench
subpackage and the extension zips are packaging.py; the last two are not part of the extension
zip, and their commands say so there.  Errors print one line on stderr and exit with 1 (failed)
or 2 (bad arguments or settings).
"""
import argparse
import sys
import time
from pathlib import Path

from ppm_engine.errors import PPMError, UsageError
from ppm_engine.render.options import INDIRECT_MODES, SettingsError

PROG = "ppm_engine"
EXIT_FAILED = 1
EXIT_USAGE = 2


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


def _parse_pass_range(text: str) -> tuple[int, int]:
    try:
        a, b = (int(v) for v in text.split("-", 1))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a pass range such as 1001-2000, got "
                                         f"'{text}'") from None
    if a < 1 or b < a:
        raise argparse.ArgumentTypeError(f"pass range {a}-{b}: passes count from 1 and the "
                                         "range must not end before it starts")
    return a, b


def _build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=PROG, description="Progressive Photon Mapping for Blender")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    r = sub.add_parser("render", help="render a .blend with the PPM engine")
    r.add_argument("scene", help="the .blend file (its scripts are never run)")
    r.add_argument("-o", "--output", required=True,
                   help="output image, .png (8-bit) or .exr (32-bit float)")
    r.add_argument("--passes", type=int, help="number of SPPM passes")
    r.add_argument("--time-limit", type=float, help="stop after this many seconds (0 = no limit)")
    r.add_argument("--resolution", type=_parse_resolution, metavar="WxH",
                   help="image size (at 100%%)")
    r.add_argument("--device",
                   help="OpenCL device: a key from 'devices', part of its name, or DEFAULT; "
                        "several separated by commas render the image together")
    r.add_argument("--photons", type=int, help="photons per pass (default: the file's setting, "
                   "normally automatic: one per pixel)")
    r.add_argument("--seed", type=int, help="random seed")
    r.add_argument("--indirect", choices=INDIRECT_MODES,
                   help="indirect light: photons (the paper's SPPM), paths (eye paths, photons "
                        "for caustics only) or auto (per scene; default: the file's setting)")
    r.add_argument("--light-tracing", choices=("on", "off"),
                   help="connect the photons to the camera too, weighed against their gather "
                        "(sharp caustics seen directly; default: the file's setting, normally "
                        "on)")
    r.add_argument("--path-filter", choices=("on", "off"),
                   help="with eye paths for the indirect light, average the light past each "
                        "path's second bounce over neighbouring paths (default: the file's "
                        "setting, normally on)")
    r.add_argument("--denoise", action="store_true",
                   help="denoise the image with Intel Open Image Denoise (albedo and normal, "
                        "the file's Cycles denoising settings; default: the file's Denoise)")
    fr = r.add_mutually_exclusive_group()
    fr.add_argument("-f", "--frame", type=int, metavar="N",
                    help="the frame to render (default: the file's current frame)")
    fr.add_argument("--frames", type=_parse_frames, metavar="A-B",
                    help="render frames A to B (an animation); '#' in the output path is the "
                         "frame number (out_####.png), else _#### goes before the extension")
    r.add_argument("--noise-threshold", type=float, metavar="T",
                   help="adaptive sampling: stop pixels whose noise is below T (0 = off)")
    r.add_argument("--pass-range", type=_parse_pass_range, metavar="A-B",
                   help="render passes A to B (from 1) with the global radius schedule, whose "
                        "passes are independent; -o PART.npz writes a part for 'merge'")
    r.add_argument("--dask", metavar="ADDRESS",
                   help="split the passes into tasks on a Dask cluster: tcp://HOST:PORT of its "
                        "scheduler, or local:N for N workers on this machine (needs the "
                        "'distributed' package)")
    r.add_argument("--task-passes", type=int, metavar="N",
                   help="--dask: passes per task (default: the passes over 4 tasks per "
                        "worker)")

    m = sub.add_parser("merge", help="merge parts rendered with --pass-range into one image")
    m.add_argument("parts", nargs="+", help="the parts (.npz) of one render")
    m.add_argument("-o", "--output", required=True,
                   help="the image (.exr, .png) or a merged part (.npz)")

    sub.add_parser("devices", help="list the OpenCL devices")

    e = sub.add_parser("example", help="write an example scene")
    e.add_argument("name", help="example name")
    e.add_argument("output", help="the .blend to write")

    k = sub.add_parser("package", help="build the extension zips with Blender's extension tool")
    k.add_argument("-o", "--output", default="dist", help="output folder (default dist)")
    k.add_argument("--platforms", default=None,
                   help="comma-separated Blender platforms (default: linux-x64,windows-x64,"
                        "macos-arm64,macos-x64)")
    k.add_argument("--wheel-cache", default=None, help="folder to keep downloaded wheels in")
    k.add_argument("--no-denoise", action="store_true",
                   help="leave Intel Open Image Denoise's wheels out (50-90 MB a zip): the "
                        "Denoise options then say that it is missing")

    # the benchmark parses its own arguments (ppm_engine/tools/bench/command.py): main() hands them
    # over before this parser sees them; this entry lists the command in --help
    sub.add_parser("bench", add_help=False,
                   help="benchmark: error against time vs Cycles, --micro, --phases ... "
                        "(python -m ppm_engine bench --help)")
    return p


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else [str(a) for a in argv]
    try:
        if argv[:1] == ["bench"]:
            return cmd_bench(argv[1:])
        args = _build_parser().parse_args(argv)
        return {"render": cmd_render, "devices": cmd_devices, "example": cmd_example,
                "package": cmd_package, "merge": cmd_merge}[args.command](args)
    except (UsageError, SettingsError) as e:
        _say(f"error: {e}")
        return EXIT_USAGE
    except PPMError as e:
        _say(f"error: {e}")
        return EXIT_FAILED


# ------------------------------------------------------------------------------------------------
def cmd_devices(args) -> int:
    from ppm_engine.render.device import list_devices
    devices = list_devices()
    if not devices:
        raise PPMError("no OpenCL device found: install a GPU OpenCL driver or the PoCL CPU "
                       "device (pip install pocl-binary-distribution)")
    for d in devices:
        print(f"{d.key}\t{d.type}\t{d.name} ({d.platform})")
    return 0


def cmd_example(args) -> int:
    out = Path(args.output).resolve()
    if out.suffix.lower() != ".blend":
        raise UsageError(f"the example is saved as a .blend, got '{args.output}'")
    if not out.parent.is_dir():
        raise PPMError(f"output folder does not exist: {out.parent}")
    from ppm_engine.blender.scenes import EXAMPLES, save_example
    if args.name not in EXAMPLES:
        raise UsageError(f"unknown example '{args.name}'; available: {', '.join(EXAMPLES)}")
    from ppm_engine.blender.harness import ensure_registered
    ensure_registered()
    save_example(args.name, str(out))
    _say(f"wrote {out}")
    return 0


def cmd_render(args) -> int:
    from ppm_engine.blender.batch import progress_bar, render_file
    overrides = {name: value for name, value in (
        ("passes", args.passes), ("time_limit", args.time_limit),
        ("photons_per_pass", args.photons), ("seed", args.seed),
        ("noise_threshold", args.noise_threshold), ("indirect", args.indirect),
        ("light_tracing", None if args.light_tracing is None else args.light_tracing == "on"),
        ("path_filter", None if args.path_filter is None else args.path_filter == "on"))
        if value is not None}
    if args.denoise:                 # say it now, not after the render
        from ppm_engine.render.denoise import unavailable
        message = unavailable()
        if message is not None:
            raise PPMError(f"--denoise: {message}")
    bar = progress_bar(PROG)
    t0 = time.perf_counter()
    output = Path(args.output).resolve()
    if args.pass_range or args.dask or output.suffix.lower() == ".npz":
        return _render_split(args, overrides, output, bar, t0)
    if args.task_passes is not None:
        raise UsageError("--task-passes goes with --dask")
    try:
        written = render_file(Path(args.scene), Path(args.output).resolve(), overrides,
                              device=args.device, resolution=args.resolution, frame=args.frame,
                              frames=args.frames, progress=bar,
                              denoise=True if args.denoise else None)
    finally:
        if bar.tty:
            print(file=sys.stderr)
    _say(f"wrote {', '.join(str(p) for p in written)} in {time.perf_counter() - t0:.1f} s")
    return 0


def _render_split(args, overrides: dict, output: Path, bar, t0: float) -> int:
    """render --pass-range / --dask / -o PART.npz: independent passes (batch.render_split)."""
    from ppm_engine.blender.batch import render_split
    if args.frames:
        raise UsageError("--frames renders an animation frame by frame; passes split across "
                         "renders are of one frame (--frame N)")
    if args.denoise:
        raise UsageError("--denoise denoises a whole frame's image: passes split across renders "
                         "are merged noisy (python -m ppm_engine merge)")
    run = None
    if args.dask:
        from ppm_engine.render.cluster import dask_runner
        run = dask_runner(args.dask, task_passes=args.task_passes, log=_say, device=args.device)
    elif args.task_passes is not None:
        raise UsageError("--task-passes goes with --dask")
    try:
        written = render_split(Path(args.scene), output, overrides, device=args.device,
                               resolution=args.resolution, frame=args.frame,
                               pass_range=args.pass_range, run=run, progress=bar)
    finally:
        if bar.tty:
            print(file=sys.stderr)
    _say(f"wrote {written} in {time.perf_counter() - t0:.1f} s")
    return 0


def cmd_merge(args) -> int:
    from ppm_engine.blender.batch import merge_files
    written, passes = merge_files([Path(p) for p in args.parts], Path(args.output).resolve())
    _say(f"merged passes {passes} into {written}")
    return 0


def _tool(module: str, what: str):
    """A subpackage or module the extension zip leaves out (bench, packaging)."""
    import importlib
    try:
        return importlib.import_module(f"{__package__}.{module}")
    except ModuleNotFoundError as e:
        if e.name and e.name.startswith(f"{__package__}.{module}"):
            raise UsageError(f"{what} is not part of this installation (the Blender extension "
                             "leaves it out): run it from a clone of the repository "
                             "(pip install -e \".[bench]\")") from None
        raise


def cmd_package(args) -> int:
    packaging = _tool("packaging", "the extension packager")
    platforms = args.platforms.split(",") if args.platforms else None
    zips = packaging.build(Path(args.output), platforms,
                           cache=Path(args.wheel_cache) if args.wheel_cache else None, log=_say,
                           denoise=not args.no_denoise)
    for z in zips:
        print(z)
    return 0


def cmd_bench(argv: list[str]) -> int:
    """python -m ppm_engine bench [--quick] [--micro | --phases SCENE | --skips] ... (the
    benchmark's own parser: ppm_engine/tools/bench/command.py)"""
    command = _tool("bench.command", "the benchmark")
    cmdline = " ".join(["python -m ppm_engine bench", *argv])
    return command.main(argv, cmdline, progress=_say)
