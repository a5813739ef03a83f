"""Photons in media (issue 42, second phase; docs/VOLUMES.md): the volumetric caustic of a glass
ball in fog under a point light against the exact NumPy reference (tools/bench/exact_fog.py)
per block, the reference against Cycles where Cycles converges (the fog without the ball), the
fog's light by photons against eye paths, and the split of the volumetric caustic between the
photons and the eye paths (no light counted twice)."""
import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from ppm_engine.blender.scenes import fog_lens
from ppm_engine.blender.scenes.cornell_box import lambert, quad

W = 32
B = 4                     # block size: 8 x 8 blocks


def block_means(img):
    return img.reshape(W // B, B, W // B, B).mean(axis=(1, 3))


def ours(scene, tiny, render_exr, path, passes, photons=1 << 14, indirect="AUTO"):
    """This engine's image (grey: the scene is), W x W."""
    tiny(scene, width=W, height=W, passes=passes, photons=photons)
    scene.ppm.indirect = indirect
    return render_exr(path).mean(-1)


def reference(scene, rays=1 << 15, photons=1 << 14):
    from ppm_engine.tools.bench.exact_fog import fog_setup, render
    return render(fog_setup(scene), rays=rays, photons=photons, seed=1)


def test_volumetric_caustic_matches_the_exact_reference(bpy, tiny, render_exr, tmp_path):
    """fog_lens at 32 x 32 (its ball 48 x 24 faces), the default Paths + Caustic Photons: the
    cone the ball focuses into the fog below it, per 4 x 4 block against the exact single and
    double scattering, where the reference holds (the blocks whose pixels' filters see no
    camera ray through the ball) (before: the cone missing, its 8 x 8 pixels at 0.50 of the
    reference)."""
    scene = fog_lens.build(ball=True, segments=(48, 24), resolution=W)
    ref, clear = reference(scene)
    img = ours(scene, tiny, render_exr, tmp_path / "ours.exr", passes=64, indirect="PATHS")
    a, b = block_means(img), block_means(ref)
    ok = (block_means(clear.astype(float)) == 1) & (b > 0.02)
    ratio = np.where(ok, a / b, np.nan)
    shown = np.array2string(ratio, precision=3)
    cone = a[5:7, 3:5].sum() / b[5:7, 3:5].sum()  # 8 x 8 pixels below the ball: the cone
    assert abs(cone - 1) < 0.05 and np.all(ok[5:7, 3:5]), (cone, shown)
    ratio[5:7, 3:5] = np.nan                        # (its 4 x 4 blocks' noise: 5-12 %)
    assert np.nanmax(np.abs(ratio[b > 0.05] - 1)) < 0.06, shown    # (dimmer ones: 7 %)
    assert abs(a[ok].sum() / b[ok].sum() - 1) < 0.02, shown


def test_the_reference_is_cycles_without_the_ball(bpy, cycles, render_exr, tmp_path):
    """The reference's direct light and double scattering against Cycles (Volume bounces 1,
    the fog alone: Cycles converges), per 8 x 8 block."""
    scene = fog_lens.build(ball=False, resolution=W)
    ref, _ = reference(scene, photons=1 << 16)
    cycles(scene, 256, width=W)
    scene.cycles.volume_bounces = 1
    cyc = render_exr(tmp_path / "cycles.exr").mean(-1)
    a = cyc.reshape(4, 8, 4, 8).mean((1, 3))
    b = ref.reshape(4, 8, 4, 8).mean((1, 3))
    assert np.all(np.abs(a / b - 1) < 0.03), np.round(a / b, 3)


def test_fog_light_on_a_floor_by_photons_is_the_eye_paths(bpy, tiny, render_exr, tmp_path):
    """Denser fog (albedo 0.6) and its lamp over a grey floor, seen from above: with indirect
    light by photons (the fog's light on the floor and its second scattering by photons
    scattered in it) as with eye paths, per 8 x 8 block (before: 11-25 % darker by photons,
    the light the fog scatters onto the floor missing).  (The floor reaches past the fog
    and the image: at a floor's edge the photons' gather is darker by its radius' bias.)"""
    scene = fog_lens.build(ball=False, resolution=W, fog=(0.3, 0.2))
    quad(scene, "Floor", [(-3, -3, 0.05), (3, -3, 0.05), (3, 3, 0.05), (-3, 3, 0.05)],
         lambert("Grey", (0.6, 0.6, 0.6)))
    scene.camera.location, scene.camera.rotation_euler = (0.0, -4.5, 3.6), (0.9, 0.0, 0.0)
    paths = ours(scene, tiny, render_exr, tmp_path / "paths.exr", passes=128, indirect="PATHS")
    photons = ours(scene, tiny, render_exr, tmp_path / "photons.exr", passes=64,
                   indirect="PHOTONS")
    a = photons.reshape(4, 8, 4, 8).mean((1, 3))
    b = paths.reshape(4, 8, 4, 8).mean((1, 3))
    assert np.all(np.abs(a / b - 1) < 0.05), np.round(a / b, 3)


def test_caustic_of_a_sphere_light_is_counted_once(bpy, tiny, render_exr, tmp_path):
    """fog_lens with a lamp of radius 5 cm, which a camera path scattered in the fog can find
    through the ball: with Paths + Caustic Photons the volume photons carry that light (L S+ M)
    and the eye paths leave it (eye_pass.cl vchain); with Photons the eye paths find only the
    lamp itself.  Both images agree per block, the cone's too (counted twice: x 2 there)."""
    scene = fog_lens.build(ball=True, segments=(48, 24), resolution=W)
    scene.objects["Point"].data.shadow_soft_size = 0.05
    paths = ours(scene, tiny, render_exr, tmp_path / "paths.exr", passes=48, indirect="PATHS")
    photons = ours(scene, tiny, render_exr, tmp_path / "photons.exr", passes=48,
                   indirect="PHOTONS")
    a, b = block_means(paths), block_means(photons)
    lit = (b > 0.02) & (b < 2.0)
    assert np.all(np.abs(a[lit] / b[lit] - 1) < 0.1), np.round(np.where(lit, a / b, np.nan), 3)
    cone = (slice(5, 7), slice(3, 5))
    assert np.all(np.abs(a[cone] / b[cone] - 1) < 0.1), a[cone] / b[cone]


def test_light_tracing_crosses_fog(bpy, pocl_key):
    """The photons' light tracing on in a scene with media (its connections to the camera through
    the fog's transmittance, photon_pass.cl connect_camera; before: off with media): the
    ball's caustic on a floor in denser fog, by photons, with and without it, per 8 x 8 block
    (0.99-1.02)."""
    from ppm_engine.blender.export import export_scene
    from ppm_engine.render.options import RenderOptions
    from ppm_engine.render.renderer import Renderer
    scene = fog_lens.build(ball=True, segments=(48, 24), resolution=W, fog=(0.3, 0.2))
    quad(scene, "Floor", [(-3, -3, 0.05), (3, -3, 0.05), (3, 3, 0.05), (-3, 3, 0.05)],
         lambert("Grey", (0.6, 0.6, 0.6)))
    scene.camera.location, scene.camera.rotation_euler = (0.0, -4.5, 3.6), (0.9, 0.0, 0.0)
    arrays = export_scene(bpy.context.evaluated_depsgraph_get())
    images = []
    for lt in (False, True):
        r = Renderer(arrays, RenderOptions(device=pocl_key, photons_per_pass=1 << 13,
                                           indirect="photons", light_tracing=lt,
                                           specialize=False))
        try:
            assert (r.lt_kappa > 0) == lt
            for _ in range(32):
                r.iterate()
            images.append(r.image()[..., :3].mean(-1).reshape(4, 8, 4, 8).mean((1, 3)))
        finally:
            r.close()
    ratio = images[1] / images[0]
    assert np.all(np.abs(ratio - 1) < 0.03), np.round(ratio, 3)


def test_volume_photons_merge_across_pass_ranges(bpy, pocl_key):
    """The global radius schedule makes a pass's volume photons and radius a function of its
    index alone: passes 1-3 and 4-6 rendered apart and merged (ppm_engine/render/parts.py) give
    one run's image, the volume photons' splats with it (light tracing off: before, a part
    without the photons' light tracing left those splats out)."""
    from ppm_engine.blender.export import export_scene
    from ppm_engine.render.options import RenderOptions
    from ppm_engine.render.parts import Part, merge
    from ppm_engine.render.renderer import Renderer
    fog_lens.build(ball=True, segments=(24, 12), resolution=16)
    arrays = export_scene(bpy.context.evaluated_depsgraph_get())

    def part(passes):
        r = Renderer(arrays, RenderOptions(device=pocl_key, photons_per_pass=1 << 12,
                                           indirect="photons", light_tracing=False,
                                           radius_schedule="global", specialize=False))
        try:
            for i in passes:
                r.iterate(pass_index=i)
            return Part.of(r), r.image()
        finally:
            r.close()
    one, image = part(range(6))
    merged = merge([part(range(3, 6))[0], part(range(3))[0]])
    np.testing.assert_allclose(one.image(), image, rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(merged.image(), image, rtol=1e-5, atol=1e-7)
