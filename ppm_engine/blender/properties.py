"""Scene.ppm: the engine's settings, one property per RenderOptions field (exact_gather is a
debug switch of the core and is not exposed).  Names, descriptions and limits come from
``options.LIMITS`` so the UI, the CLI and the core refuse the same values."""
import sys
import zlib

import bpy
from bpy.props import (
    BoolProperty,
    EnumProperty,
    FloatProperty,
    IntProperty,
    PointerProperty,
    StringProperty,
)

from ppm_engine.render.denoise import DenoiseSettings
from ppm_engine.render.options import (
    AUTO_PHOTONS_MAX,
    AUTO_PHOTONS_MIN,
    LIMITS,
    VIEWPORT_LIMITS,
    RenderOptions,
)
from ppm_engine.render.viewport_frame import DISPLAY_PASSES, display_pass_id

DEFAULT_DEVICE = "DEFAULT"

# Dynamic EnumProperty items must stay referenced from Python while Blender uses them, or the
# UI shows garbage strings: the list lives here and is rebuilt only by refresh_devices().
_device_items: list[tuple[str, str, str, int]] | None = None


def device_enum_value(key: str) -> int:
    """A stable enum value per device key (a dynamic enum stores the integer in the .blend, so
    it must not depend on the order in which OpenCL lists the devices)."""
    return 0 if key == DEFAULT_DEVICE else (zlib.crc32(key.encode()) & 0x7FFFFFFF) or 1


def refresh_devices() -> list[tuple[str, str, str, int]]:
    """Re-list the OpenCL devices (imports pyopencl; called lazily, never at add-on import)."""
    global _device_items
    items = [(DEFAULT_DEVICE, "Default", "A GPU if one is present, else the PoCL CPU device", 0)]
    try:
        from ppm_engine.render.device import list_devices
        devices = list_devices()
    except Exception as e:  # no OpenCL platform, a broken driver: DEFAULT only (the render says)
        print(f"PPM: could not list OpenCL devices: {e}", file=sys.stderr)
        devices = []
    for d in devices:
        items.append((d.key, f"{d.name} ({d.type})", f"{d.name} on {d.platform}",
                      device_enum_value(d.key)))
    _device_items = items
    return items


def device_items() -> list[tuple[str, str, str, int]]:
    """The device enum's items (listed once: refresh_devices)."""
    return _device_items if _device_items is not None else refresh_devices()


def _device_items_cb(self, context):
    return device_items()


def _int(name: str, **kw):
    lo, hi, default, desc = LIMITS[name] if name in LIMITS else VIEWPORT_LIMITS[name]
    return IntProperty(name=kw.pop("label"), description=desc, min=lo, max=hi, default=default,
                       **kw)


def _float(name: str, **kw):
    lo, hi, default, desc = LIMITS[name] if name in LIMITS else VIEWPORT_LIMITS[name]
    return FloatProperty(name=kw.pop("label"), description=desc, min=lo, max=hi, default=default,
                         **kw)


def _photons_set_by_hand(self, context):
    """Typing a photon count (in the UI or from Python) means that count: automatic off."""
    if self.auto_photons:
        self.auto_photons = False


def _update_render_passes(self, context):
    """Denoise adds the Noisy Image pass: the compositor's Render Layers node shows it at once
    (as Cycles' Denoise does)."""
    view_layer = getattr(context, "view_layer", None)
    if view_layer is not None:
        view_layer.update_render_passes()


class PPMSettings(bpy.types.PropertyGroup):
    passes: _int("passes", label="Passes", soft_max=4096)
    time_limit: _float("time_limit", label="Time Limit", subtype="TIME_ABSOLUTE",
                       unit="TIME_ABSOLUTE", soft_max=3600.0, step=100)
    auto_photons: BoolProperty(
        name="Automatic Photon Count",
        description=(f"Emit one photon per pixel of the image each pass (the paper's 512x512 "
                     f"photons at 512x512 pixels), at least {AUTO_PHOTONS_MIN:,} and at most "
                     f"{AUTO_PHOTONS_MAX:,}; off: Photons per Pass. Setting Photons per Pass "
                     f"turns it off"),
        default=True,
    )
    photons_per_pass: _int("photons_per_pass", label="Photons per Pass", soft_min=1024,
                           soft_max=1 << 22, update=_photons_set_by_hand)
    initial_radius: _float("initial_radius", label="Initial Radius", subtype="DISTANCE",
                           soft_max=10.0, precision=4)
    # validate() wants 0 < alpha < 1; the soft limits keep the slider inside that
    alpha: _float("alpha", label="Alpha", subtype="FACTOR", soft_min=0.01, soft_max=0.99)
    seed: _int("seed", label="Seed")
    noise_threshold: _float("noise_threshold", label="Noise Threshold", soft_max=0.1,
                            precision=4, step=0.1)
    indirect: EnumProperty(
        name="Indirect Light",
        description="How indirect light is estimated",
        items=(
            ("AUTO", "Automatic", "Per scene from a pilot of photons: Photons when most light "
             "first meets a mirror, glass or a smooth glossy surface (a bulb inside glass, a "
             "room lit through windows), Paths otherwise; the choice shows in the stats line", 0),
            ("PHOTONS", "Photons", "The paper's progressive photon mapping: every bounce of "
             "indirect light from the photon map", 1),
            ("PATHS", "Paths + Caustic Photons", "Eye paths continue through diffuse bounces "
             "with next-event estimation; photons only for caustics (light whose first "
             "bounce is a mirror, glass or a smooth glossy surface)", 2),
        ),
        default="AUTO",
    )
    light_tracing: BoolProperty(
        name="Light Tracing",
        description="Connect every stored photon to the camera as well and weigh the two ways "
                    "of finding the same light against each other: sharp caustics seen "
                    "directly (a point light's focus through glass). Pinhole cameras only; off "
                    "with depth of field",
        default=True,
    )
    path_filter: BoolProperty(
        name="Path Filter",
        description="With eye paths for the indirect light: average the light each path finds "
                    "past its second bounce with that of the paths whose second bounce lands "
                    "near it (on a diffuse surface facing the same way), over cells that shrink "
                    "pass by pass. Less noise in light that bounced twice or more, at the cost of "
                    "a blur that fades as the render goes on",
        default=True,
    )
    viewport_passes: _int("viewport_passes", label="Viewport Passes", soft_max=4096)
    viewport_time_limit: _float("viewport_time_limit", label="Viewport Time Limit",
                                subtype="TIME_ABSOLUTE", unit="TIME_ABSOLUTE", soft_max=3600.0,
                                step=100)
    viewport_start_resolution: _int("viewport_start_resolution", label="Start Pixels",
                                    soft_max=1024)
    viewport_pause: BoolProperty(
        name="Pause Viewport",
        description="Stop refining the viewport's Rendered shading (it keeps its image)",
        default=False,
    )
    denoise: BoolProperty(
        name="Denoise",
        description="Denoise the final render's image with Intel Open Image Denoise, guided by "
                    "its albedo and normal; the noisy image stays in the Noisy Image pass. Input "
                    "passes, prefilter and quality are Cycles' denoising settings",
        default=False,
        update=_update_render_passes,
    )
    viewport_denoise: BoolProperty(
        name="Viewport Denoise",
        description="Denoise the viewport's Rendered shading with Intel Open Image Denoise "
                    "from Cycles' viewport Start Sample on (the pass count), with Cycles' "
                    "viewport input passes, prefilter and quality",
        default=False,
    )
    specialize: BoolProperty(
        name="Kernels for the Scene",
        description="Build the kernels for the features this scene uses (no glass code "
                    "without glass, only its light types): faster passes, and a scene with "
                    "other features builds its own kernels (seconds on a CPU, then cached on "
                    "disk). Off: one build with every feature, shared by every scene; the "
                    "same image",
        default=True,
    )
    device: EnumProperty(
        name="Device",
        description="OpenCL device that renders (Default: a GPU if present, else the PoCL CPU "
                    "device)",
        items=_device_items_cb,
    )
    devices: StringProperty(
        name="Devices",
        description="The OpenCL devices ticked in the Device panel, one key a line: two or "
                    "more render the image together (each its share of the passes)",
        default="",
        options={'HIDDEN'},
    )


def denoise_settings(settings, viewport: bool = False) -> DenoiseSettings | None:
    """How the render (or the viewport) denoises: None when ``scene.ppm``'s Denoise (Viewport
    Denoise) is off; else Cycles' denoising settings of the scene where they have a meaning for
    OIDN (input passes, prefilter, quality; the viewport's Start Sample), the defaults without
    the Cycles add-on.  Cycles' own Denoise toggles and its choice of denoiser (OptiX) are not
    read: Cycles' toggle is on in every new scene, and would change what every existing scene
    renders."""
    if not getattr(settings, "viewport_denoise" if viewport else "denoise", False):
        return None
    cycles = getattr(getattr(settings, "id_data", None), "cycles", None)
    if cycles is None:
        return DenoiseSettings()
    prefix = "preview_denoising_" if viewport else "denoising_"
    get = lambda name, default: str(getattr(cycles, prefix + name, default)).lower()
    return DenoiseSettings(
        input_passes=get("input_passes", "RGB_ALBEDO_NORMAL"),
        prefilter=get("prefilter", "ACCURATE"),
        quality=get("quality", "HIGH"),
        start=max(int(getattr(cycles, "preview_denoising_start_sample", 1)), 1) if viewport
        else 1)


def to_options(settings) -> RenderOptions:
    """RenderOptions from ``scene.ppm``, validated (raises options.SettingsError)."""
    device = settings.device  # '' when the stored device is no longer listed
    return RenderOptions(
        passes=int(settings.passes),
        time_limit=float(settings.time_limit),
        photons_per_pass=None if settings.auto_photons else int(settings.photons_per_pass),
        initial_radius=float(settings.initial_radius),
        alpha=float(settings.alpha),
        seed=int(settings.seed),
        noise_threshold=float(settings.noise_threshold),
        indirect=str(settings.indirect).lower(),
        light_tracing=bool(settings.light_tracing),
        path_filter=bool(settings.path_filter),
        specialize=bool(settings.specialize),
        device="" if device in ("", DEFAULT_DEVICE) else device,
        devices=ticked_devices(settings),
        denoise=denoise_settings(settings),
    ).validate()


def ticked_devices(settings) -> tuple[str, ...]:
    """The device keys ticked in the Device panel (scene.ppm.devices)."""
    return tuple(k for k in settings.devices.split("\n") if k)


def tick_device(settings, key: str, on: bool) -> None:
    """Tick or untick device ``key`` in the Device panel's list."""
    keys = [k for k in ticked_devices(settings) if k != key]
    settings.devices = "\n".join([*keys, key] if on else keys)


@bpy.app.handlers.persistent
def keep_typed_photon_counts(*_args):
    """A file saved before the automatic photon count existed stored only Photons per Pass: if
    it set one, that count stays in force (load_post)."""
    for scene in bpy.data.scenes:
        s = getattr(scene, "ppm", None)
        if s is not None and not s.is_property_set("auto_photons") \
                and s.is_property_set("photons_per_pass"):
            s.auto_photons = False


# the viewport's Render Pass items (viewport_frame.DISPLAY_PASSES): kept referenced, as every
# EnumProperty's items must stay while Blender uses them
DISPLAY_PASS_ITEMS = tuple((display_pass_id(name), name, f"Show the {name} render pass")
                           for name in DISPLAY_PASSES)


class PPMViewShadingSettings(bpy.types.PropertyGroup):
    """View3DShading.ppm: what a 3D view in Rendered shading shows under this engine (Cycles
    keeps its own in View3DShading.cycles)."""
    render_pass: EnumProperty(name="Render Pass", items=DISPLAY_PASS_ITEMS, default="COMBINED",
                              description="Render pass to show in the 3D Viewport")


def register():
    bpy.utils.register_class(PPMSettings)
    bpy.types.Scene.ppm = PointerProperty(type=PPMSettings, name="Progressive Photon Mapping")
    bpy.utils.register_class(PPMViewShadingSettings)
    bpy.types.View3DShading.ppm = PointerProperty(type=PPMViewShadingSettings,
                                                  name="Progressive Photon Mapping")
    if keep_typed_photon_counts not in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.append(keep_typed_photon_counts)


def unregister():
    if keep_typed_photon_counts in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(keep_typed_photon_counts)
    del bpy.types.View3DShading.ppm
    bpy.utils.unregister_class(PPMViewShadingSettings)
    del bpy.types.Scene.ppm
    bpy.utils.unregister_class(PPMSettings)
