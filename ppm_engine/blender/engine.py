"""The RenderEngine: Blender-facing flags and one-line hand-offs to session.py (final renders
and previews) and blender/viewport.py (the 3D viewport's Rendered shading)."""
import bpy

from ppm_engine.blender import session


class PPMRenderEngine(bpy.types.RenderEngine):
    bl_idname = "PPM"                          # the id stored in scene.render.engine
    bl_label = "Progressive Photon Mapping"    # the name in the render engine menu
    # False: keep Blender's shader nodes (Principled BSDF, Emission, ...) editable in the Shader
    # Editor; the exporter reads those node trees (the default True would hide them)
    bl_use_shading_nodes_custom = False
    # material, world and light previews in the Properties editor: render() with is_preview
    # (session.preview_options: a few passes at the preview's small size)
    bl_use_preview = True
    # the viewport's Material Preview mode stays EEVEE's (Rendered mode is ours: view_draw)
    bl_use_eevee_viewport = True
    # run the compositor and sequencer on our result like the built-in engines
    bl_use_postprocess = True

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.session = session.Session()      # one per engine instance; reusable across renders
        self.viewport = None                  # ViewportDriver (blender/viewport.py) (Rendered mode)

    def __del__(self):
        try:  # Blender may call __del__ on a partly built or already freed instance
            s, v = self.session, self.viewport
        except (AttributeError, ReferenceError):
            return
        s.free()
        if v is not None:
            v.close()

    def render(self, depsgraph):
        self.session.render(self, depsgraph)

    def update_render_passes(self, scene=None, renderlayer=None):
        for name, channels, chan_id, kind in session.render_passes(scene):
            self.register_pass(scene, renderlayer, name, channels, chan_id, kind)

    # -- the 3D viewport in Rendered shading: blender/viewport.py --------------------------------
    def view_update(self, context, depsgraph):
        if self.viewport is None:
            from ppm_engine.blender.viewport import ViewportDriver
            self.viewport = ViewportDriver()
        self.viewport.view_update(self, context, depsgraph)

    def view_draw(self, context, depsgraph):
        if self.viewport is not None:
            self.viewport.view_draw(self, context, depsgraph)


def register():
    bpy.utils.register_class(PPMRenderEngine)


def unregister():
    bpy.utils.unregister_class(PPMRenderEngine)
