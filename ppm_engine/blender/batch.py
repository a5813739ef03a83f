"""Render .blend files headless through the bpy module, as ``blender -b SCENE.blend -E PPM -f N``
does (``-s A -e B -a`` for a frame range): what ``python -m ppm_engine render`` runs once its
arguments are parsed.

The .blend is treated as untrusted: it is opened without running its embedded scripts."""
from __future__ import annotations

import sys
from pathlib import Path

from ppm_engine.blender.harness import OUTPUT_FORMATS, ensure_registered, set_output
from ppm_engine.errors import PPMError, UsageError
from ppm_engine.render.options import LIMITS, RenderOptions

# zstd (Blender >= 3.0 compression), gzip (older compression), plain
_BLEND_MAGIC = (b"BLENDER", b"\x28\xb5\x2f\xfd", b"\x1f\x8b")


def check_paths(scene_file: Path, output: Path) -> None:
    """Refuse a missing or non-.blend scene, an unknown output format or a missing folder
    before Blender loads anything."""
    if not scene_file.is_file():
        raise PPMError(f"scene file not found: {scene_file}")
    with open(scene_file, "rb") as f:
        head = f.read(8)
    if not head.startswith(_BLEND_MAGIC):
        raise PPMError(f"not a .blend file: {scene_file}")
    if output.suffix.lower() not in OUTPUT_FORMATS:
        raise UsageError(f"unsupported output format '{output.suffix or output.name}': use "
                         ".png or .exr")
    if not output.parent.is_dir():
        raise PPMError(f"output folder does not exist: {output.parent}")


def open_scene(scene_file: Path):
    """The engine registered and ``scene_file`` loaded, its scene returned; PPMError naming the
    file where Blender cannot open it.  Never with use_scripts=True: the file is untrusted and
    its scripts stay off."""
    import bpy
    ensure_registered()
    try:
        bpy.ops.wm.open_mainfile(filepath=str(scene_file.resolve()), load_ui=False)
    except RuntimeError as e:
        raise PPMError(f"cannot open {scene_file}: {blender_message(e)}") from None
    return bpy.context.scene


def render_file(scene_file: Path, output: Path, overrides: dict, *, device: str | None = None,
                resolution: tuple[int, int] | None = None, frame: int | None = None,
                frames: tuple[int, int] | None = None, progress=None,
                denoise: bool | None = None) -> list[Path]:
    """Render ``scene_file`` with this engine to ``output`` (one frame, ``frame`` or the
    file's current one; or the range ``frames``, '#' in the name being the frame number, else
    _#### before the extension); ``overrides`` are RenderOptions fields that replace the
    file's settings; ``denoise`` replaces the file's Denoise (scene.ppm.denoise).
    ``progress(text, fraction)`` is told about every pass.  Returns the files written."""
    check_paths(scene_file, output)
    RenderOptions().replace(**overrides).validate()    # refuse bad values before loading Blender
    import bpy
    scene = open_scene(scene_file)
    if scene.render.engine != "PPM":      # setting it again would drop a persistent engine
        scene.render.engine = "PPM"
    if scene.render.engine != "PPM":      # never render with another engine by mistake
        raise PPMError("could not select the PPM render engine in the loaded file")
    apply_settings(scene, overrides, device)
    if denoise is not None:
        scene.ppm.denoise = bool(denoise)
    if resolution:
        scene.render.resolution_x, scene.render.resolution_y = resolution
        scene.render.resolution_percentage = 100
    from ppm_engine.blender import session
    with session.listening(progress or (lambda text, fraction: None)):
        try:
            if frames:                     # blender -b FILE -E PPM -s A -e B -a
                scene.frame_start, scene.frame_end = frames
                set_output(scene, frame_pattern(output))
                bpy.ops.render.render(animation=True)
                written = [Path(scene.render.frame_path(frame=f))
                           for f in range(frames[0], frames[1] + 1)]
            else:                          # blender -b FILE -E PPM -f N
                scene.frame_set(frame if frame is not None else scene.frame_current)
                set_output(scene, output)
                if "#" in output.name:     # write_still does not expand '#': frame_path does
                    scene.render.filepath = scene.render.frame_path(frame=scene.frame_current)
                bpy.ops.render.render(write_still=True)
                written = [Path(scene.render.filepath)]
        except RuntimeError as e:
            raise PPMError(f"render failed: {blender_message(e)}") from None
    missing = [str(p) for p in written if not p.is_file()]
    if missing:
        raise PPMError(f"render finished but {', '.join(missing)} was not written")
    return written


def frame_pattern(out: Path) -> Path:
    """The output path of an animation: '#' runs are the frame number; without any, _####
    goes before the extension (out.png -> out_0001.png)."""
    if "#" in out.name:
        return out
    return out.with_name(f"{out.stem}_####{out.suffix}")


def blender_message(e: Exception) -> str:
    text = " ".join(str(e).split())
    return text[len("Error: "):] if text.startswith("Error: ") else text


def apply_settings(scene, overrides: dict, device: str | None) -> None:
    """Validate the file's settings with the overrides, then store the overrides in scene.ppm.
    (Validation comes first: Blender would silently clamp an out-of-range assignment.)"""
    from ppm_engine.blender.properties import DEFAULT_DEVICE, refresh_devices
    settings = scene.ppm
    stored = {name: getattr(settings, name) for name in LIMITS}
    stored["indirect"] = str(settings.indirect).lower()
    stored["light_tracing"] = bool(settings.light_tracing)
    stored["path_filter"] = bool(settings.path_filter)
    if settings.auto_photons:
        stored["photons_per_pass"] = None
    RenderOptions(**stored).replace(**overrides).validate()
    for name, value in overrides.items():
        setattr(settings, name, value.upper() if name == "indirect" else value)
    if device is not None and "," in device:      # several devices render together
        from ppm_engine.blender.properties import tick_device
        settings.devices = ""
        for name in device.split(","):
            tick_device(settings, resolve_device(name.strip(), refresh_devices(),
                                                 DEFAULT_DEVICE), True)
    elif device is not None:
        settings.device = resolve_device(device, refresh_devices(), DEFAULT_DEVICE)
        settings.devices = ""


def resolve_device(name: str, items, default_key: str) -> str:
    """A device key from a key, a case-insensitive part of a device name, or DEFAULT; a
    suffix "#N" (another context on the same device: device/context.py get_device) is kept."""
    base, sep, tail = name.rpartition("#")
    if sep and tail.isdigit() and base:
        return f"{resolve_device(base, items, default_key)}#{tail}"
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
        raise UsageError(f"no OpenCL device matches '{name}'; available: {listed}")
    return match[0]


def progress_bar(prog: str, stream=None):
    """A ``progress(text, fraction)`` that draws "[#####     ]  50 % Pass 32/64 · ..." on
    ``stream`` (sys.stderr as it is when called: a default bound at import would keep a stream
    redirected then): one line redrawn on a terminal, a line per pass otherwise."""
    stream = sys.stderr if stream is None else stream
    tty = stream.isatty()

    def show(text: str, fraction: float) -> None:
        line = f"[{'#' * int(20 * fraction):<20}] {100 * fraction:3.0f} % {text}"
        if tty:
            print(f"\r{prog}: {line}\033[K", end="", file=stream, flush=True)
        else:
            print(f"{prog}: {line}", file=stream, flush=True)
    show.tty = tty
    return show



# outputs of a split render (render_split): a part to merge later, or the merged image
SPLIT_OUTPUTS = (".npz", ".exr", ".png")


def render_split(scene_file: Path, output: Path, overrides: dict, *,
                 device: str | None = None, resolution: tuple[int, int] | None = None,
                 frame: int | None = None, pass_range: tuple[int, int] | None = None,
                 run=None, progress=None) -> Path:
    """Render passes of ``scene_file`` as independent passes (the global radius schedule;
    ppm_engine/render/parts.py): ``pass_range`` (first, last), counted from 1, or 1 to the
    file's pass count; written to ``output``: a .npz part (merge it with the other ranges:
    ``python -m ppm_engine merge``) or the image of these passes (.exr, .png).  ``run(scene,
    options, passes, progress)`` renders the pass indices and returns their Part (default one
    device: parts.render_range; the CLI's --devices and --dask give others).  ``progress(text,
    fraction)`` after every pass.  Returns the file written."""
    from ppm_engine.render import parts
    if not scene_file.is_file():
        raise PPMError(f"scene file not found: {scene_file}")
    if output.suffix.lower() not in SPLIT_OUTPUTS:
        raise UsageError(f"unsupported output '{output.suffix or output.name}' for passes "
                         "rendered apart: a part (.npz) or an image (.exr, .png)")
    check_paths(scene_file, output.with_suffix(".exr"))
    overrides = {**overrides, "radius_schedule": "global"}
    if overrides.get("time_limit"):
        raise UsageError("a time limit cannot split passes: give the passes (--passes, "
                         "--pass-range)")
    parts.check_splittable(RenderOptions().replace(**overrides).validate())
    import bpy
    scene = open_scene(scene_file)
    apply_settings(scene, {k: v for k, v in overrides.items() if k != "radius_schedule"},
                   device)
    if resolution:
        scene.render.resolution_x, scene.render.resolution_y = resolution
        scene.render.resolution_percentage = 100
    if frame is not None:
        scene.frame_set(frame)
    from ppm_engine.blender.export import export_scene
    from ppm_engine.blender.properties import to_options
    options = to_options(scene.ppm).replace(radius_schedule="global", time_limit=0.0)
    parts.check_splittable(options)
    first, last = pass_range or (1, options.passes)
    arrays = export_scene(bpy.context.evaluated_depsgraph_get())
    say = progress or (lambda text, fraction: None)

    def told(done, total, stats=None):
        say(f"Pass {done}/{total} of {first}-{last}", done / total)
    if run is None and len(options.devices) > 1:
        from ppm_engine.render.multi_device import render_devices

        def run(scene, options, passes, progress):
            return render_devices(scene, options, passes, options.devices, progress)
    part = (run or parts.render_range)(arrays, options, range(first - 1, last), told)
    from ppm_engine.blender.harness import view_settings, write_image
    part.meta["view"] = view_settings(scene)     # a merged PNG's colour management
    if output.suffix.lower() == ".npz":
        part.save(output)
    else:
        write_image(part.image(), output, part.meta["view"])
    return output


def merge_files(inputs: list[Path], output: Path) -> tuple[Path, str]:
    """Merge the parts ``inputs`` (render_split's .npz) into ``output``: an image (.exr, .png)
    or a part (.npz).  Returns (the file, the passes merged as text)."""
    from ppm_engine.render import parts
    if output.suffix.lower() not in SPLIT_OUTPUTS:
        raise UsageError(f"unsupported output '{output.suffix or output.name}': an image "
                         "(.exr, .png) or a part (.npz)")
    if not output.parent.is_dir():
        raise PPMError(f"output folder does not exist: {output.parent}")
    merged = parts.merge([parts.Part.load(p) for p in inputs], names=[p.name for p in inputs])
    if output.suffix.lower() == ".npz":
        merged.save(output)
    else:
        from ppm_engine.blender.harness import write_image
        write_image(merged.image(), output, merged.meta.get("view"))
    return output, parts.format_ranges(merged.ranges)
