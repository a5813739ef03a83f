"""The RenderEngine: Blender-facing flags and one-line hand-offs to session.py."""
import bpy

from . import session


class PPMRenderEngine(bpy.types.RenderEngine):
    bl_idname = "PPM"                          # the id stored in scene.render.engine
    bl_label = "Progressive Photon Mapping"    # the name in the render engine menu
    # False: keep Blender's shader nodes (Principled BSDF, Emission, ...) editable in the Shader
    # Editor; the exporter reads those node trees (the default True would hide them)
    bl_use_shading_nodes_custom = False
    # no material/light/world preview renders (the previews would need a fast path of their own)
    bl_use_preview = False
    # run the compositor and sequencer on our result like the built-in engines
    bl_use_postprocess = True

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.session = session.Session()      # one per engine instance; reusable across renders

    def __del__(self):
        try:  # Blender may call __del__ on a partly built or already freed instance
            s = self.session
        except (AttributeError, ReferenceError):
            return
        s.free()

    def render(self, depsgraph):
        self.session.render(self, depsgraph)

    def update_render_passes(self, scene=None, renderlayer=None):
        for name, channels, chan_id, kind in session.RENDER_PASSES:
            self.register_pass(scene, renderlayer, name, channels, chan_id, kind)


def register():
    bpy.utils.register_class(PPMRenderEngine)


def unregister():
    bpy.utils.unregister_class(PPMRenderEngine)
