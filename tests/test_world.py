"""World node trees against Cycles: an HDRI (a float image made here: a coloured sky gradient
and a bright sun-like spot) through Texture Coordinate, Mapping and an Environment Texture,
lighting a diffuse sphere on a plane per 8 x 8 block (direct light only and full transport),
and seen by the camera per pixel; the importance map's sampling against its density; and a
constant world rendered exactly as the kernels without world programs render it."""
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from tests.helpers.blender_scenes import light_world_camera
from tests.helpers.cycles_blocks import compare_blocks, render_both
from tests.helpers.procedural_scenes import room

SUN = (0.3, 0.75)   # the spot's (u, v): above the horizon, to the side


def _hdri(w=64, h=32):
    """A float image, rows bottom-up: sky blue above, brown below, a bright spot at SUN."""
    v, u = (np.mgrid[0:h, 0:w] + 0.5) / np.array([h, w])[:, None, None]
    up = np.clip((v - 0.5) * 2, 0, 1)[..., None]
    px = up * np.array([0.25, 0.45, 0.9]) + (1 - up) * np.array([0.35, 0.25, 0.15])
    px = px * (0.6 + 0.4 * np.cos(2 * np.pi * u))[..., None]
    spot = (np.abs(u - SUN[0]) < 2.0 / w) & (np.abs(v - SUN[1]) < 1.5 / h)
    px[spot] = (60.0, 50.0, 35.0)
    rgba = np.concatenate([px, np.ones((h, w, 1))], -1).astype(np.float32)
    img = bpy.data.images.new("sky", w, h, float_buffer=True)
    img.pixels.foreach_set(rgba.ravel())
    img.pack()
    return img


def _world(scene, rotation=0.0, strength=1.0):
    world = scene.world = bpy.data.worlds.new("HDRI")
    t = world.node_tree
    bg = t.nodes["Background"]
    bg.inputs["Strength"].default_value = strength
    tc, mp = t.nodes.new("ShaderNodeTexCoord"), t.nodes.new("ShaderNodeMapping")
    env = t.nodes.new("ShaderNodeTexEnvironment")
    env.image = _hdri()
    mp.inputs["Rotation"].default_value = (0.0, 0.0, rotation)
    t.links.new(tc.outputs["Generated"], mp.inputs["Vector"])
    t.links.new(mp.outputs["Vector"], env.inputs["Vector"])
    t.links.new(env.outputs["Color"], bg.inputs["Color"])
    return world


def _camera(scene, location, rotation, lens):
    """The camera and the pixel filter of tests/test_materials.py (light_world_camera)."""
    light_world_camera(scene, light=None, world=0.0, camera=(location, rotation, lens))


def _diffuse(name, color):
    mat = bpy.data.materials.new(name)
    t = mat.node_tree
    t.nodes.remove(t.nodes["Principled BSDF"])
    d = t.nodes.new("ShaderNodeBsdfDiffuse")
    d.inputs["Color"].default_value = (*color, 1.0)
    t.links.new(d.outputs[0], t.nodes["Material Output"].inputs["Surface"])
    return mat


def _sphere_scene(wall=False):
    """The sphere on a floor; ``wall``: a white wall behind the camera, out of view, that
    lights the scene by reflection (photons that leave the world outside the disc over what
    the camera sees must still reach it)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=0.5)
    bpy.ops.object.shade_smooth()
    bpy.context.active_object.data.materials.append(_diffuse("Ball", (0.8, 0.8, 0.8)))
    bpy.ops.mesh.primitive_plane_add(size=8, location=(0, 0, -0.5))
    bpy.context.active_object.data.materials.append(_diffuse("Floor", (0.5, 0.5, 0.5)))
    if wall:
        bpy.ops.mesh.primitive_plane_add(size=8, location=(0, -6, 3.5), rotation=(-1.5708, 0, 0))
        bpy.context.active_object.data.materials.append(_diffuse("Wall", (0.9, 0.9, 0.9)))
    _camera(scene, (0.0, -3.2, 0.9), (1.32, 0.0, 0.0), 60)
    _world(scene, rotation=0.7)
    return scene


def test_hdri_direct_light_per_block_as_cycles(cycles, render_exr, tmp_path, tiny):
    """Direct light only: the map's next-event estimation with MIS against the BSDF sample."""
    scene = _sphere_scene()
    ours, ref = render_both(scene, cycles, render_exr, tmp_path, tiny, samples=1024, passes=256,
                            bounces=0, photons=1024)
    compare_blocks(ours, ref, 0.04, 0.003)


# 22-38 s each on 2 cores: the slow tier (the HDRI's direct light and background per block
# against Cycles are the default run's)
@pytest.mark.slow
@pytest.mark.parametrize("wall", [False, True])
def test_hdri_full_transport_per_block_as_cycles(wall, cycles, render_exr, tmp_path, tiny):
    """All bounces: photons emitted from the map light the floor under the sphere (and, with
    the wall, the light it reflects onto the sphere's front)."""
    scene = _sphere_scene(wall)
    ours, ref = render_both(scene, cycles, render_exr, tmp_path, tiny, samples=4096, passes=1024,
                            bounces=4, photons=65536)
    compare_blocks(ours, ref, 0.07, 0.004)


def test_background_per_pixel_as_cycles(cycles, render_exr, tmp_path, tiny):
    """The camera sees the HDRI through the Mapping's rotation (and its Strength), per pixel."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    _camera(scene, (0.0, 0.0, 0.0), (2.3, 0.0, -1.35), 18)
    _world(scene, rotation=1.1, strength=1.5)
    ours, ref = render_both(scene, cycles, render_exr, tmp_path, tiny, samples=512, passes=512,
                            bounces=0, photons=256)
    assert ref.max() > 20.0              # the spot is in view
    np.testing.assert_allclose(ours, ref, rtol=0.03, atol=0.01)


def _map_device():
    from ppm_engine.render.device import get_device
    from ppm_engine.render.world_map import build_map
    v, u = (np.mgrid[0:16, 0:32] + 0.5) / np.array([16, 32])[:, None, None]
    rgb = np.stack([1 + np.cos(2 * np.pi * u), v, 0.2 * np.ones_like(u)], -1)
    rgb[11, 9] = (80.0, 60.0, 40.0)                            # a sun
    rgb[3, 20] = 0.0                                           # and a black texel
    return get_device(), build_map(rgb)


def test_map_sampling_follows_the_map_and_its_density_integrates_to_one():
    """Directions sampled from the CDF on the device fall in each texel in proportion to the
    map (chi-square), carry the density world_map_pdf gives them (and the NumPy mirror), and
    that density integrates to 1 over the sphere."""
    import pyopencl as cl

    from ppm_engine.render.world_map import direction_to_uv, map_pdf
    dev, m = _map_device()
    n = 1 << 18
    prog = dev.programs.get("light/world_map.cl", {})
    dirs, again = dev.buffer(16 * n, "dirs"), dev.buffer(4 * n, "pdf")
    prog.launch("world_sample_test", "test")(
        dev.queue, n, map=dev.upload(m.buffer, "map"), w=np.int32(m.width),
        h=np.int32(m.height), mean=np.float32(m.mean), seed=np.uint32(3), n=np.int32(n),
        dirs=dirs, pdf_again=again)
    d, p2 = np.empty((n, 4), np.float32), np.empty(n, np.float32)
    cl.enqueue_copy(dev.queue, d, dirs)
    cl.enqueue_copy(dev.queue, p2, again).wait()
    assert (d[:, 3] > 0).all()
    # (a direction on a texel's edge may round into its neighbour)
    assert np.isclose(d[:, 3], p2, rtol=1e-3).mean() > 0.999
    p3 = map_pdf(m, d[:, :3].astype(np.float64))
    assert np.isclose(d[:, 3], p3, rtol=1e-3).mean() > 0.999
    uv = direction_to_uv(d[:, :3].astype(np.float64))
    j = np.clip((uv[:, 0] * m.width).astype(int), 0, m.width - 1)
    i = np.clip((uv[:, 1] * m.height).astype(int), 0, m.height - 1)
    counts = np.bincount(i * m.width + j, minlength=m.f.size)
    expect = n * m.f.ravel() / m.f.sum()
    assert counts[expect == 0].sum() == 0
    live = expect > 5
    chi2 = (((counts[live] - expect[live]) ** 2) / expect[live]).sum()
    assert chi2 < live.sum() + 5 * np.sqrt(2 * live.sum()), chi2
    rng = np.random.default_rng(1)
    z = rng.uniform(-1, 1, 1 << 21)
    phi = rng.uniform(0, 2 * np.pi, z.size)
    s = np.sqrt(1 - z * z)
    u = np.stack([s * np.cos(phi), s * np.sin(phi), z], -1)
    np.testing.assert_allclose(map_pdf(m, u).mean() * 4 * np.pi, 1.0, rtol=0.01)


def test_baked_map_is_the_image_at_its_texel_centres(bpy):
    """Without Mapping, a map of the image's resolution (World > Settings > Sampling: Manual,
    Map Resolution 64) evaluates the world at the image's texel centres: its values are the
    image's mean x sin(theta), row 0 at the nadir; and the world's power in the emitter table
    is pi R^2 2 pi^2 mean(f).  Automatic: the image's size is what the export reports, and
    the map is 16 x 16 texels per image texel (world_map.map_size)."""
    from ppm_engine.blender.export import export_scene
    from ppm_engine.render.device import get_device
    from ppm_engine.render.device_scene import DeviceScene
    from ppm_engine.render.world_map import map_size
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    _camera(scene, (0.0, -3.0, 0.0), (1.5, 0.0, 0.0), 50)
    _world(scene)
    bpy.ops.mesh.primitive_plane_add(size=1)
    arrays = export_scene(bpy.context.evaluated_depsgraph_get())
    assert arrays.world_shader[0] > 0 and tuple(arrays.world_shader[2:]) == (64, 32)
    assert map_size(64, 32) == (1024, 512)
    scene.world.cycles.sampling_method = "MANUAL"
    scene.world.cycles.sample_map_resolution = 64
    arrays = export_scene(bpy.context.evaluated_depsgraph_get())
    assert tuple(arrays.world_shader[2:]) == (64, 32)
    # baked by the program of every node (specialize off, as the tests' renders): one build
    # that every world of a run shares, where the world's own nodes would build one per world
    dev = get_device()
    before = {k for k in dev.programs._programs if k[0] == "light/world_map.cl"}
    ds = DeviceScene(dev, arrays, specialize=False)
    added = {k for k in dev.programs._programs if k[0] == "light/world_map.cl"} - before
    assert added <= {("light/world_map.cl", ())}
    assert ("light/world_map.cl", ()) in dev.programs._programs
    assert (ds.world_map.width, ds.world_map.height) == (64, 32)
    img = np.array(bpy.data.images["sky"].pixels[:], np.float32).reshape(32, 64, 4)[..., :3]
    sin = np.sin(np.pi * (np.arange(32) + 0.5) / 32)[:, None]
    np.testing.assert_allclose(ds.world_map.f, img.mean(-1) * sin, rtol=2e-3, atol=1e-5)
    em = ds.emitters
    R = float(em.info["scene_radius"][0])
    np.testing.assert_allclose(em.power[-1], np.pi * R * R * 2 * np.pi ** 2 * ds.world_map.mean,
                               rtol=1e-6)


def test_map_size_follows_cycles_automatic_and_manual_settings():
    """The importance map's size: an Environment Texture's image oversampled ENV_OVERSAMPLING
    times within [ENV_MIN_WIDTH, ENV_MAX_WIDTH] (its aspect kept), a world without one at
    DEFAULT_WIDTH, and Manual's Map Resolution as given (res x res / 2)."""
    from ppm_engine.render.world_map import map_size
    assert map_size(0, 0) == (512, 256)
    assert map_size(64, 32) == (1024, 512)
    assert map_size(512, 256) == (2048, 1024)
    assert map_size(2048, 1024) == (4096, 2048)
    assert map_size(8192, 4096) == (4096, 2048)
    assert map_size(1000, 1000) == (4000, 4000)
    assert map_size(256, 128, manual=True) == (256, 128)


def _sun_sample_spread(bpy, manual_resolution: int = 0):
    """A floor lit by an HDRI whose sun is 2 x 2 texels of a 64 x 32 image (linear
    interpolation), direct light only, 96 passes at 16 x 16: the largest single pass's sample
    over the floor's pixels and their mean (every pass's sample recovered from the running
    mean)."""
    from ppm_engine.blender.export import export_scene
    from ppm_engine.blender.harness import unbiased_light_paths
    from ppm_engine.render.renderer import Renderer
    from tests.helpers.renders import every_feature
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=20)
    bpy.context.active_object.data.materials.append(_diffuse("Floor", (0.5, 0.5, 0.5)))
    _camera(scene, (0.0, -1.0, 2.0), (0.5, 0.0, 0.0), 50)
    world = scene.world = bpy.data.worlds.new("Sun")
    t = world.node_tree
    env = t.nodes.new("ShaderNodeTexEnvironment")
    w, h = 64, 32
    px = np.full((h, w, 4), 0.2, np.float32)
    px[24:26, 10:12, :3] = 4000.0                     # 56 degrees up
    px[..., 3] = 1.0
    img = bpy.data.images.new("sun", w, h, float_buffer=True)
    img.pixels.foreach_set(px.ravel())
    img.pack()
    env.image = img
    t.links.new(env.outputs["Color"], t.nodes["Background"].inputs["Color"])
    if manual_resolution:
        world.cycles.sampling_method = "MANUAL"
        world.cycles.sample_map_resolution = manual_resolution
    scene.render.resolution_x = scene.render.resolution_y = 16
    unbiased_light_paths(scene, 0)
    r = Renderer(export_scene(bpy.context.evaluated_depsgraph_get()),
                 every_feature(max_bounces=0, seed=2))
    try:
        total, samples = np.zeros((16, 16)), []
        for k in range(1, 97):
            r.iterate()
            now = r.image()[..., :3].mean(-1).astype(np.float64) * k
            samples.append(now - total)
            total = now
    finally:
        r.close()
    samples = np.asarray(samples)
    return samples.max(), samples.mean()


def test_an_hdri_sun_lights_a_floor_without_fireflies(bpy):
    """The map's texels are the radiance at their centres; linear interpolation spreads the
    sun's texels over half a texel around them.  At one map texel per image texel (Manual 64)
    that spread has the dark sky's density, and the diffuse sample that finds it is a
    firefly hundreds of times the mean; the automatic map (16 texels per image texel here)
    follows the spread, and no pass's sample exceeds a few times the mean."""
    peak, mean = _sun_sample_spread(bpy)
    assert mean > 1.0 and peak < 4.0 * mean, (peak, mean)
    peak_1x, mean_1x = _sun_sample_spread(bpy, manual_resolution=64)
    assert abs(mean_1x / mean - 1.0) < 0.1 and peak_1x > 50.0 * mean_1x, (peak_1x, mean_1x)


def test_constant_world_renders_as_before():
    """A constant world keeps its path: the specialised kernels (no world program code) render
    the stored image, and the kernels with every feature (world programs compiled in, none in
    the scene) the same image.  The image was rendered before world programs existed (commit
    6f8d7a4, same seed) and again when photons took the adjoint of shading normals and the
    gather's disc the face's plane (docs/SHADING.md "Photons on smooth-shaded meshes"): only
    the 16 x 8 glass sphere and its caustic changed then, the image's mean by 0.05 %; and again
    when the photons were also light-traced to the camera (kernels/integrator/photon_pass.cl
    connect_camera): the photons' noise in four passes changed, the mean by 0.16 %; and again
    when the eye pass drew its camera positions and choices from the pixel's Sobol sets
    (kernels/integrator/eye_pass.cl): four passes' samples changed, the mean by 0.6 %."""
    from ppm_engine.render.options import RenderOptions
    from ppm_engine.render.renderer import Renderer
    before = np.load(Path(__file__).parent / "data" / "constant_world.npy")
    scene = room(None, glass=True, world=(0.3, 0.4, 0.5))
    for specialize in (True, False):
        r = Renderer(scene, RenderOptions(photons_per_pass=2048, seed=4, specialize=specialize,
                                          exact_gather=True, indirect="photons"))
        if specialize:
            assert "PPM_WORLD_MAP" not in r.features and "PPM_SVM" not in r.features
        for _ in range(4):
            r.iterate()
        np.testing.assert_allclose(r.image(), before, rtol=1e-5, atol=1e-6)
        r.close()


def test_world_hidden_from_camera_and_an_unsupported_node(render_exr, tmp_path, tiny):
    """Ray Visibility > Camera off: the camera sees black where the world was, the sphere is
    still lit by it.  An IES Texture (not evaluated): a warning naming it, the world's viewport
    colour instead."""
    scene = _sphere_scene()
    scene.world.cycles_visibility.camera = False
    tiny(scene, width=16, height=16, passes=4, photons=1024)
    img = render_exr(tmp_path / "hidden.exr")
    assert img[0].max() == 0.0 and img[-1].mean() > 0.05        # sky black, floor lit
    t = scene.world.node_tree
    ies = t.nodes.new("ShaderNodeTexIES")
    t.links.new(ies.outputs["Fac"], t.nodes["Background"].inputs["Strength"])
    from ppm_engine.blender.export import export_scene
    arrays = export_scene(bpy.context.evaluated_depsgraph_get())
    assert any("IES Texture" in w for w in arrays.warnings), arrays.warnings
    scene.world.cycles_visibility.camera = True
    scene.world.color = (0.2, 0.3, 0.4)
    img = render_exr(tmp_path / "sky.exr")
    np.testing.assert_allclose(img[0].mean(axis=0), (0.2, 0.3, 0.4), rtol=1e-3)


def test_specialised_kernels_render_the_same_hdri_image(bpy):
    """The world program's code with every feature compiled in renders the specialised
    kernels' image (same seed: the same random streams)."""
    from ppm_engine.blender.export import export_scene
    from ppm_engine.render.options import RenderOptions
    from ppm_engine.render.renderer import Renderer
    scene = _sphere_scene()
    scene.render.resolution_x = scene.render.resolution_y = 16
    arrays = export_scene(bpy.context.evaluated_depsgraph_get())
    imgs = []
    for specialize in (True, False):
        r = Renderer(arrays, RenderOptions(photons_per_pass=2048, seed=4, specialize=specialize,
                                           exact_gather=True))
        if specialize:
            assert {"PPM_WORLD_MAP", "PPM_SVM", "PPM_TEXTURES"} <= r.features
        for _ in range(3):
            assert r.iterate().nan_dropped == 0
        imgs.append(r.image())
        r.close()
    assert imgs[0][..., :3].mean() > 0.1
    np.testing.assert_allclose(imgs[0], imgs[1], rtol=1e-4, atol=1e-6)


def _sky_world(scene, **props):
    """A Sky Texture world (its Vector unlinked: the ray's direction)."""
    world = scene.world = bpy.data.worlds.new("Sky")
    t = world.node_tree
    sky = t.nodes.new("ShaderNodeTexSky")
    for key, v in props.items():
        setattr(sky, key, v)
    t.links.new(sky.outputs["Color"], t.nodes["Background"].inputs["Color"])
    return world


def test_preetham_sky_direct_light_per_block_as_cycles(cycles, render_exr, tmp_path, tiny):
    """A Preetham sky (a low sun to the side) lights the sphere and floor and is seen behind
    them: the world map bakes the sky's program, its next-event estimation with MIS against
    the BSDF sample gives Cycles' image per 8 x 8 block within 4 %."""
    scene = _sphere_scene()
    _sky_world(scene, sky_type="PREETHAM", sun_direction=(0.6, -0.5, 0.35), turbidity=3.0)
    ours, ref = render_both(scene, cycles, render_exr, tmp_path, tiny, samples=1024, passes=256,
                            bounces=0, photons=1024)
    assert ref.max() > 0.3
    compare_blocks(ours, ref, 0.04, 0.003)


@pytest.mark.parametrize("model", ["SINGLE_SCATTERING", "MULTIPLE_SCATTERING"])
def test_sun_disc_sky_direct_light_per_block_as_cycles(model, cycles, render_exr, tmp_path,
                                                       tiny):
    """A scattering sky with its sun disc (a bigger sun than the real one, still about a
    texel of the importance map): the map's texels near the disc are baked as their mean
    (world_map.sun_hint), so next-event estimation finds the sun: Cycles' image per 8 x 8
    block within 4 %."""
    scene = _sphere_scene()
    world = _sky_world(scene, sky_type=model, sun_elevation=0.7, sun_rotation=2.2,
                       sun_size=0.02)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.02
    ours, ref = render_both(scene, cycles, render_exr, tmp_path, tiny, samples=1024, passes=256,
                            bounces=0, photons=1024)
    assert ref.max() > 0.3
    compare_blocks(ours, ref, 0.04, 0.003)


@pytest.mark.slow
def test_sun_disc_sky_full_transport_per_block_as_cycles(cycles, render_exr, tmp_path, tiny):
    """All bounces under a multiple-scattering sky with its sun disc: photons leave the map's
    supersampled texels around the disc (the floor's light under and beside the sphere)."""
    scene = _sphere_scene()
    world = _sky_world(scene, sky_type="MULTIPLE_SCATTERING", sun_elevation=0.7,
                       sun_rotation=2.2, sun_size=0.02)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.02
    ours, ref = render_both(scene, cycles, render_exr, tmp_path, tiny, samples=4096, passes=1024,
                            bounces=4, photons=65536)
    compare_blocks(ours, ref, 0.07, 0.004)
