"""Render-properties panels for scene.ppm, and the built-in panels the engine reuses."""
import bpy

from ppm_engine.blender.properties import (
    DEFAULT_DEVICE,
    device_items,
    tick_device,
    ticked_devices,
)

ENGINE_ID = "PPM"

# Built-in panels that are EEVEE-only but draw exactly what this engine reads (node-based
# material and world surfaces, the material slot list, the full light settings).  Every panel
# marked 'BLENDER_RENDER' (Blender's marker for external engines) is added as well.
EXTRA_BUILTIN_PANELS = (
    "EEVEE_MATERIAL_PT_surface",
    "EEVEE_MATERIAL_PT_context_material",
    "DATA_PT_EEVEE_light",
    "EEVEE_WORLD_PT_surface",
    # Cycles' film (exposure, pixel filter, transparency): the engine renders Cycles' film
    # settings (export/camera.py film_settings); absent without the Cycles add-on
    "CYCLES_RENDER_PT_film",
    "CYCLES_RENDER_PT_film_pixel_filter",
    "CYCLES_RENDER_PT_film_transparency",
    # Cycles' Light Paths: bounces, clamping, caustics (ppm_engine/scene/light_paths.py); not its
    # Fast GI, which the engine does not approximate
    "CYCLES_RENDER_PT_light_paths",
    "CYCLES_RENDER_PT_light_paths_max_bounces",
    "CYCLES_RENDER_PT_light_paths_clamping",
    "CYCLES_RENDER_PT_light_paths_caustics",
)


class PPMPanel:
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"
    COMPAT_ENGINES = {ENGINE_ID}   # noqa: RUF012 -- Blender reads it from the class, never mutated

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES


def _draw_props(layout, settings, names):
    layout.use_property_split = True
    layout.use_property_decorate = False
    col = layout.column()
    for name in names:
        col.prop(settings, name)
    return col


class PPM_PT_sampling(PPMPanel, bpy.types.Panel):
    bl_label = "Sampling"

    def draw(self, context):
        _draw_props(self.layout, context.scene.ppm,
                    ("passes", "time_limit", "noise_threshold", "seed"))


class PPM_PT_sampling_viewport(PPMPanel, bpy.types.Panel):
    bl_label = "Viewport"
    bl_parent_id = "PPM_PT_sampling"

    def draw(self, context):
        _draw_props(self.layout, context.scene.ppm,
                    ("viewport_passes", "viewport_time_limit", "viewport_start_resolution",
                     "viewport_pause"))
        self.layout.prop(context.scene.render, "preview_pixel_size", text="Pixel Size")


class DenoisePanel(PPMPanel):
    """Denoise, as Cycles' Sampling > Render (Viewport) > Denoise: the toggle in the header
    (ours: scene.ppm's OWN), below it Cycles' settings that OIDN reads (PREFIX...;
    properties.denoise_settings) where the Cycles add-on is enabled."""
    bl_label = "Denoise"
    bl_options = {'DEFAULT_CLOSED'}   # noqa: RUF012 -- Blender reads it from the class
    OWN, PREFIX = "denoise", "denoising_"

    def draw_header(self, context):
        self.layout.prop(context.scene.ppm, self.OWN, text="")

    def draw(self, context):
        cycles = getattr(context.scene, "cycles", None)
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        col = layout.column()
        col.active = getattr(context.scene.ppm, self.OWN)
        if cycles is None:
            col.label(text="Intel Open Image Denoise, albedo and normal, prefiltered")
            return
        if self.PREFIX == "preview_denoising_":
            col.prop(cycles, "preview_denoising_start_sample", text="Start Pass")
        for name, text in (("input_passes", "Passes"), ("prefilter", "Prefilter"),
                           ("quality", "Quality")):
            col.prop(cycles, self.PREFIX + name, text=text)


class PPM_PT_sampling_denoise(DenoisePanel, bpy.types.Panel):
    """The final render's Denoise: its last image."""
    bl_parent_id = "PPM_PT_sampling"


class PPM_PT_sampling_viewport_denoise(DenoisePanel, bpy.types.Panel):
    """The viewport's Denoise: from Start Pass on."""
    bl_parent_id = "PPM_PT_sampling_viewport"
    OWN, PREFIX = "viewport_denoise", "preview_denoising_"


class PPM_PT_photons(PPMPanel, bpy.types.Panel):
    bl_label = "Photons"

    def draw(self, context):
        settings = context.scene.ppm
        col = _draw_props(self.layout, settings, ("auto_photons",))
        row = col.row()
        row.active = not settings.auto_photons
        row.prop(settings, "photons_per_pass")
        _draw_props(self.layout, settings, ("indirect", "path_filter", "light_tracing",
                                            "initial_radius", "alpha"))


class PPM_PT_device(PPMPanel, bpy.types.Panel):
    bl_label = "Device"

    def draw(self, context):
        settings = context.scene.ppm
        ticked = set(ticked_devices(settings))
        col = _draw_props(self.layout, settings, ("device",))
        col.active = len(ticked) < 2
        # every OpenCL device with a checkbox, as Cycles' device list: two or more ticked
        # render the image together (render/multi_device.py), each its share of the passes
        box = self.layout.column(heading="Render On", align=True)
        for key, name, _desc, _value in device_items():
            if key == DEFAULT_DEVICE:
                continue
            op = box.operator(PPM_OT_tick_device.bl_idname, text=name, emboss=False,
                              icon='CHECKBOX_HLT' if key in ticked else 'CHECKBOX_DEHLT')
            op.key, op.on = key, key not in ticked
        if len(ticked) >= 2:
            box.label(text="Passes split across the devices (global radius schedule)")
        _draw_props(self.layout, settings, ("specialize",))


class PPM_OT_tick_device(bpy.types.Operator):
    """Tick or untick an OpenCL device: two or more ticked render the image together"""
    bl_idname = "ppm.tick_device"
    bl_label = "Use Device"
    bl_options = {'UNDO', 'INTERNAL'}  # noqa: RUF012 -- read by Blender, never mutated

    key: bpy.props.StringProperty()
    on: bpy.props.BoolProperty(default=True)

    def execute(self, context):
        tick_device(context.scene.ppm, self.key, self.on)
        return {'FINISHED'}


class PPM_VIEW3D_PT_shading_render_pass(bpy.types.Panel):
    """The 3D view's shading popover in Rendered shading: the pass the viewport shows, as
    Cycles' Render Pass (CYCLES_VIEW3D_PT_shading_render_pass)."""
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'HEADER'
    bl_parent_id = 'VIEW3D_PT_shading'
    bl_label = "Render Pass"
    COMPAT_ENGINES = {ENGINE_ID}   # noqa: RUF012 -- Blender reads it from the class

    @classmethod
    def poll(cls, context):
        return (context.engine in cls.COMPAT_ENGINES
                and context.space_data.shading.type == 'RENDERED')

    def draw(self, context):
        self.layout.prop(context.space_data.shading.ppm, "render_pass", text="")


CLASSES = (PPM_PT_sampling, PPM_PT_sampling_viewport, PPM_PT_sampling_viewport_denoise,
           PPM_PT_sampling_denoise, PPM_PT_photons, PPM_PT_device, PPM_OT_tick_device,
           PPM_VIEW3D_PT_shading_render_pass)


def _all_subclasses(cls):
    for sub in cls.__subclasses__():
        yield sub
        yield from _all_subclasses(sub)


def builtin_panels():
    """The registered built-in panels this engine shows: every Panel whose COMPAT_ENGINES
    contains 'BLENDER_RENDER', plus EXTRA_BUILTIN_PANELS."""
    panels = [p for p in set(_all_subclasses(bpy.types.Panel))
              if "BLENDER_RENDER" in getattr(p, "COMPAT_ENGINES", ())]
    panels += [getattr(bpy.types, name) for name in EXTRA_BUILTIN_PANELS
               if hasattr(bpy.types, name)]
    return panels


def _own_engines(panel) -> set:
    """The panel's own COMPAT_ENGINES: a set shared with its base class (every Cycles panel
    shares CyclesButtonsPanel's) is copied onto the panel first, so only this panel changes."""
    if "COMPAT_ENGINES" not in vars(panel):
        panel.COMPAT_ENGINES = set(panel.COMPAT_ENGINES)
    return panel.COMPAT_ENGINES


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    for panel in builtin_panels():
        _own_engines(panel).add(ENGINE_ID)


def unregister():
    for panel in builtin_panels():
        _own_engines(panel).discard(ENGINE_ID)
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
