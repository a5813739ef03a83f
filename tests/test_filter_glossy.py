"""Filter Glossy (Render > Light Paths > Caustics, scene.cycles.blur_glossy) as Cycles applies it
(kernels/integrator/path_state.h): a camera path whose bounces so far include one of density
below the setting meets every glossy lobe at least as rough as sqrt(1 - pdf / setting) / 2
(alpha), and the light paths photons carried through such a lobe are the eye paths'.  The
scene: the benchmark's sun-lit cone (ppm_engine/blender/scenes/sun_cone.py: a default
Principled cone, a sun of strength 3, Cycles' default Light Paths), on a floor of polished
metal (Principled, Metallic 1, Roughness 0.2), whose reflection of the sun lights the cone from
below; per 8 x 8 block against Cycles with the same settings."""
import numpy as np
import pytest

from tests.helpers.cycles_blocks import blocks

W = 48


def _scene(bpy, filter_glossy):
    from ppm_engine.blender.scenes import sun_cone
    scene = sun_cone.build()
    floor = bpy.data.materials["Floor"].node_tree.nodes["Principled BSDF"]
    floor.inputs["Metallic"].default_value = 1.0
    floor.inputs["Roughness"].default_value = 0.2
    scene.cycles.blur_glossy = filter_glossy
    return scene


def _render(bpy, scene, engine, render_exr, path, tiny, samples):
    """The scene by Cycles (``samples`` per pixel) or by this engine (as many passes), its own
    Light Paths kept (the Cycles defaults the builder set, Filter Glossy as given)."""
    scene.render.resolution_x = scene.render.resolution_y = W
    if engine == "CYCLES":
        scene.render.engine = "CYCLES"
        c = scene.cycles
        c.device, c.samples, c.seed = "CPU", samples, 1
        c.use_adaptive_sampling = c.use_denoising = False
    else:
        tiny(scene, width=W, height=W, passes=samples, photons=1 << 12)
    return render_exr(path)


@pytest.mark.parametrize("filter_glossy", [1.0, 0.0])
def test_filter_glossy_as_cycles(bpy, tiny, render_exr, tmp_path, filter_glossy):
    """Every block within 8 % (plus 0.004 for the dark ones) of Cycles' (256 samples) at 96
    passes, with Filter Glossy 1 (Cycles' default) and 0 (off: the sharp reflection, which
    photons bring; the same image as before Filter Glossy was applied).  Before, the render
    with 1 was the one with 0, where Cycles' filtered cone is lit from below more evenly: a
    block of the cone's dark side at 0.74 of Cycles' (2.2 x the tolerance; 0.15 x after)."""
    scene = _scene(bpy, filter_glossy)
    ref = _render(bpy, scene, "CYCLES", render_exr, tmp_path / "cycles.exr", tiny, 256)
    ours = _render(bpy, scene, "PPM", render_exr, tmp_path / "ours.exr", tiny, 96)
    a, b = blocks(ours).mean(-1), blocks(ref).mean(-1)
    bad = np.abs(a - b) > 0.08 * b + 0.004
    assert not bad.any(), f"ours / Cycles per block:\n{np.round(a / np.maximum(b, 1e-6), 3)}"


def test_photon_passes_wait_for_photons_that_reach_the_image(bpy):
    """Renderer.photons_due: a glass ball's caustic on a diffuse floor (point_caustic) under
    Filter Glossy 1 is the eye paths' light (a camera path leaves the floor with a density of at
    most 1 / pi), so with none of the caustic photons reaching the image (Counter.USED) they are
    emitted only in passes 1, 2, 4, 8, 16 (counting from 1) and every 16th (every pass with the
    skip off);
    without Filter Glossy they are used from the first pass on, and every pass emits them."""
    from ppm_engine.blender.export import export_scene
    from ppm_engine.blender.scenes import build_example
    from ppm_engine.render.options import RenderOptions
    from ppm_engine.render.renderer import Renderer
    emitted, used = {}, {}
    scene = build_example("point_caustic")
    scene.render.resolution_x = scene.render.resolution_y = 16
    for fg, skip in ((1.0, True), (1.0, False), (0.0, True)):
        scene.cycles.blur_glossy = fg
        bpy.context.view_layer.update()
        r = Renderer(export_scene(bpy.context.evaluated_depsgraph_get()),
                     RenderOptions(seed=1, specialize=False, indirect="paths",
                                   skip_unused_photons=skip))
        try:
            counts = [r.iterate().photons_emitted for _ in range(17)]
            assert r.photons_needed and r.path_indirect
            emitted[fg, skip] = [i for i, (a, b) in enumerate(zip([0, *counts], counts)) if b > a]
            used[fg, skip] = r.photons_used / r.film.photons_emitted
        finally:
            r.close()
    assert used[1.0, True] == used[1.0, False] == 0
    assert used[0.0, True] > 100 * Renderer.PHOTONS_USED_MIN
    assert emitted[1.0, True] == [0, 1, 3, 7, 15]
    assert emitted[1.0, False] == emitted[0.0, True] == list(range(17))
