"""The film as Cycles' film settings make it, against Cycles rendering the same scene in the
test: the pixel filter (box, Gaussian, Blackman-Harris from scene.cycles), the transparent film
(alpha from camera rays that reach the world, through transparent surfaces and transparent
glass; holdouts) and the film exposure."""
import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

W = 24                    # pixels per side


def _checker_scene(filter_type, width):
    """An orthographic view of an emissive checkerboard (squares 2.6 pixels wide, edges cutting
    pixels at every phase), a black world: a pixel's value is the checker seen through the
    pixel filter alone."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=4.0)
    plane = bpy.context.active_object
    mat = bpy.data.materials.new("checker")
    t = mat.node_tree
    t.nodes.remove(t.nodes["Principled BSDF"])
    coord = t.nodes.new("ShaderNodeTexCoord")
    chk = t.nodes.new("ShaderNodeTexChecker")
    chk.inputs["Scale"].default_value = 1.0
    chk.inputs["Color1"].default_value = (1.0, 1.0, 1.0, 1.0)
    chk.inputs["Color2"].default_value = (0.0, 0.0, 0.0, 1.0)
    scale = t.nodes.new("ShaderNodeVectorMath")
    scale.operation = "SCALE"
    scale.inputs["Scale"].default_value = W / 4.0 / 2.6      # squares 2.6 pixels wide
    t.links.new(coord.outputs["Object"], scale.inputs[0])
    t.links.new(scale.outputs[0], chk.inputs["Vector"])
    em = t.nodes.new("ShaderNodeEmission")
    t.links.new(chk.outputs["Color"], em.inputs["Color"])
    t.links.new(em.outputs[0], t.nodes["Material Output"].inputs["Surface"])
    plane.data.materials.append(mat)
    cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
    cam.data.type, cam.data.ortho_scale = "ORTHO", 4.0
    cam.location = (0.013, 0.029, 5.0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.world = bpy.data.worlds.new("W")
    scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0, 0, 0, 1)
    scene.render.dither_intensity = 0.0
    scene.cycles.pixel_filter_type, scene.cycles.filter_width = filter_type, width
    return scene


def _render(scene, exr, path) -> np.ndarray:
    exr.set_output(scene, path)
    assert bpy.ops.render.render(write_still=True) == {'FINISHED'}
    img = exr.read(path)
    assert np.isfinite(img).all()
    return img


def _both(scene, cycles, tiny, exr, tmp_path, samples, photons=64):
    cycles(scene, samples, width=W)
    scene.cycles.max_bounces = 0
    ref = _render(scene, exr, tmp_path / "cycles.exr")
    tiny(scene, width=W, height=W, passes=samples, photons=photons)
    return _render(scene, exr, tmp_path / "ours.exr"), ref


@pytest.mark.parametrize("filter_type, width", [("BOX", 1.5), ("GAUSSIAN", 1.5),
                                                ("BLACKMAN_HARRIS", 2.0)])
def test_pixel_filter_as_cycles(bpy, cycles, tiny, exr, tmp_path, filter_type, width):
    """Each pixel filter blurs a checkerboard as Cycles' does: per pixel within the two
    renders' noise (256 samples), while the filters differ from each other by far more."""
    scene = _checker_scene(filter_type, width)
    ours, ref = _both(scene, cycles, tiny, exr, tmp_path, 256)
    err = np.abs(ours[..., :3] - ref[..., :3])
    assert err.mean() < 0.01 and err.max() < 0.08, (err.mean(), err.max())
    # the filter shows: Cycles with another filter is far from ours
    scene.render.engine = "CYCLES"
    scene.cycles.pixel_filter_type = "BLACKMAN_HARRIS" if filter_type == "BOX" else "BOX"
    other = _render(scene, exr, tmp_path / "other.exr")
    apart = np.abs(ours[..., :3] - other[..., :3]).mean()
    assert apart > max(0.03, 5 * err.mean()), (apart, err.mean())


def test_box_filter_is_one_pixel_whatever_the_width(bpy, cycles, tiny, exr, tmp_path):
    """Blender's Cycles renders the box filter one pixel wide (the width is hidden for it)."""
    scene = _checker_scene("BOX", 3.0)
    ours, ref = _both(scene, cycles, tiny, exr, tmp_path, 64)
    assert np.abs(ours[..., :3] - ref[..., :3]).mean() < 0.015


SPHERE = (-1.2, 1.3, 0.3)      # over the empty world: seen through it, the world


def _lit_scene(world=(0.6, 0.7, 0.8)):
    """A perspective view of a diffuse plane partly covering the frame, a plane half
    transparent (Mix of Transparent and Diffuse), a holdout square and a glass sphere, lit by
    a coloured world."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene

    def mat(name, build):
        m = bpy.data.materials.new(name)
        t = m.node_tree
        out = t.nodes["Material Output"].inputs["Surface"]
        t.nodes.remove(t.nodes["Principled BSDF"])
        t.links.new(build(t), out)
        return m

    def diffuse(t):
        d = t.nodes.new("ShaderNodeBsdfDiffuse")
        d.inputs["Color"].default_value = (0.8, 0.5, 0.3, 1.0)
        return d.outputs[0]

    def half(t):
        mix = t.nodes.new("ShaderNodeMixShader")
        mix.inputs[0].default_value = 0.4
        t.links.new(t.nodes.new("ShaderNodeBsdfTransparent").outputs[0], mix.inputs[1])
        t.links.new(diffuse(t), mix.inputs[2])
        return mix.outputs[0]

    def holdout(t):
        return t.nodes.new("ShaderNodeHoldout").outputs[0]

    def glass(t):
        g = t.nodes.new("ShaderNodeBsdfGlass")
        g.inputs["Roughness"].default_value = 0.0
        g.inputs["IOR"].default_value = 1.45
        return g.outputs[0]

    for loc, size, m in (((-1.2, 0.0, 0.0), 1.6, mat("diffuse", diffuse)),
                         ((0.9, 0.9, 0.0), 1.4, mat("half", half)),
                         ((0.9, -0.9, 0.0), 1.0, mat("holdout", holdout))):
        bpy.ops.mesh.primitive_plane_add(size=size, location=loc)
        bpy.context.active_object.data.materials.append(m)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.6, location=SPHERE, segments=48,
                                         ring_count=24)
    bpy.ops.object.shade_smooth()
    bpy.context.active_object.data.materials.append(mat("glass", glass))
    cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
    cam.location = (0.0, 0.0, 6.0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.world = bpy.data.worlds.new("W")
    scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (*world, 1.0)
    scene.render.dither_intensity = 0.0
    scene.render.film_transparent = True
    scene.cycles.pixel_filter_type = "BOX"
    return scene


@pytest.mark.parametrize("glass", [False, True])
def test_transparent_film_alpha_as_cycles(bpy, cycles, tiny, exr, tmp_path, glass):
    """Transparent film: the world seen by camera rays (directly, through the Transparent BSDF,
    and through sharp glass when Transparent Glass is on) is alpha, not colour; a holdout is
    alpha 0 - as Cycles' alpha, per pixel within the renders' noise."""
    scene = _lit_scene()
    scene.cycles.film_transparent_glass = glass
    scene.cycles.film_transparent_roughness = 0.1
    cycles(scene, 128, width=W)
    ref = _render(scene, exr, tmp_path / "cycles.exr")
    tiny(scene, width=W, height=W, passes=128, photons=256)
    ours = _render(scene, exr, tmp_path / "ours.exr")
    a, b = ours[..., 3], ref[..., 3]
    assert np.abs(a - b).mean() < 0.01 and np.abs(a - b).max() < 0.2, np.abs(a - b).max()
    # the film is really transparent: world pixels 0, the half plane ~0.6, the diffuse plane 1
    assert (b < 0.01).mean() > 0.2 and (b > 0.99).mean() > 0.1
    assert np.isclose(b, 0.4, atol=0.03).sum() >= 9       # the Mix: 0.6 Transparent
    # the glass sphere's centre: through the sphere, clear only with transparent glass
    # (its Fresnel reflection stays opaque)
    from bpy_extras.object_utils import world_to_camera_view
    from mathutils import Vector
    v = world_to_camera_view(scene, scene.camera, Vector(SPHERE))
    x, y = int(v.x * W), int((1.0 - v.y) * W)         # rows top-down
    centre = b[y - 1:y + 1, x - 1:x + 1]
    assert (centre.mean() < 0.3) if glass else (centre.mean() > 0.99), centre
    # the world is not seen in colour where the film is clear (premultiplied, as Cycles)
    clear = b < 0.01
    assert np.abs(ours[..., :3][clear]).max() < 1e-6


def test_film_exposure_scales_the_image(bpy, tiny, exr, tmp_path):
    """Cycles' film exposure multiplies the rendered colour (not alpha)."""
    scene = _checker_scene("BOX", 1.0)
    tiny(scene, width=8, height=8, passes=2, photons=64)
    one = _render(scene, exr, tmp_path / "one.exr")
    scene.cycles.film_exposure = 2.5
    two = _render(scene, exr, tmp_path / "two.exr")
    np.testing.assert_allclose(two[..., :3], 2.5 * one[..., :3], rtol=1e-5, atol=1e-7)
    np.testing.assert_array_equal(two[..., 3], one[..., 3])
    assert one[..., :3].max() > 0.5
