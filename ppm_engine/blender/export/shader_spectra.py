"""The Blackbody and Wavelength nodes of a shader program (kernels/svm/svm_color.h runs them), as
Cycles evaluates them; a constant input folds at export into the same float32 colour
(ppm_engine/scene/spectra.py).  fn(compiler, node, output socket, group context) -> Val."""
from __future__ import annotations

from ppm_engine.blender.export.shader_values import Val
from ppm_engine.scene.shader_program import SVM_BLACKBODY, SVM_WAVELENGTH
from ppm_engine.scene.spectra import blackbody_rgb, wavelength_rgb


def _working_space(c, node) -> None:
    """Warns when the blend file's working colour space is not linear Rec.709 (these colours
    are computed in it, as the rest of the engine's colour arithmetic)."""
    import bpy
    cs = getattr(bpy.data, "colorspace", None)
    space = getattr(cs, "working_space_interop_id", "lin_rec709_scene") or "lin_rec709_scene"
    if space != "lin_rec709_scene":
        c.warn(f"'{node.name}' gives linear Rec.709, not the working colour space "
               f"'{cs.working_space}'")


def _spectral(op: int, socket: str, fold):
    def compile_node(c, node, out, ctx):
        _working_space(c, node)
        v = c.inp(node, socket, ctx, 1)
        if v.is_const:
            return c.const(fold(v.const[0]), 3)
        s, o = c.slot(v), c.alloc(3)
        c.ops.append((op, o, s, 0))
        return Val(3, slot=o)
    return compile_node


SPECTRAL_NODES = {
    "ShaderNodeBlackbody": _spectral(SVM_BLACKBODY, "Temperature", blackbody_rgb),
    "ShaderNodeWavelength": _spectral(SVM_WAVELENGTH, "Wavelength", wavelength_rgb),
}
