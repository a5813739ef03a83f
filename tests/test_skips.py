"""Skip what a scene doesn't need (docs/BENCHMARKS.md "Skips"): each skip happens, and the
image is the same as without it where the skip must not change it."""
import numpy as np
import pytest

from ppm_engine.oracle import analytic
from ppm_engine.oracle.procedural import MeshBuilder, cornell_box, look_at
from ppm_engine.render.device import get_device
from ppm_engine.render.device_scene import DeviceScene
from ppm_engine.render.options import RenderOptions
from ppm_engine.render.passes import ProgressiveUpdate
from ppm_engine.render.renderer import Renderer
from ppm_engine.scene.arrays import (
    LIGHT_AREA_RECT,
    LIGHT_DTYPE,
    LIGHT_HIDDEN_SHIFT,
    LIGHT_POINT,
    LIGHT_SUN,
    NODE_DIFFUSE,
    NODE_PRINCIPLED,
    NODE_SHEEN,
    NODE_TRANSLUCENT,
    VIS_CAMERA,
    VIS_GLOSSY,
    VIS_TRANSMISSION,
)
from ppm_engine.scene.camera import make_camera, perspective_extent
from tests.helpers.procedural_scenes import room
from tests.helpers.renders import scene_features


def _light(kind, emit, position=(0, 0, 1.5), direction=(0, 0, -1), radius=0.0, size=0.3,
           hidden=0):
    L = np.zeros(1, LIGHT_DTYPE)
    L["type"], L["emit"], L["position"], L["direction"] = kind, emit, position, direction
    L["radius"] = radius
    L["axis_x"], L["axis_y"] = (size, 0, 0), (0, size, 0)
    L["flags"] = hidden << LIGHT_HIDDEN_SHIFT
    return L


def _features(scene):
    return scene_features(scene, indirect="photons", photons_per_pass=256)


def test_features_follow_the_scene():
    point = _light(LIGHT_POINT, (10, 10, 10))
    assert _features(room(point)) == {"PPM_LIGHT_POINT"}
    # glass and a mirror are not one Lambert closure (the shader's full path), and have no
    # closure a visible point evaluates (the gather does not shade)
    assert _features(room(point, glass=True)) == {"PPM_LIGHT_POINT", "PPM_MICROFACET",
                                                   "PPM_SHADER"}
    assert _features(room(point, mirror=True)) == {"PPM_LIGHT_POINT", "PPM_MICROFACET",
                                                    "PPM_SHADER"}
    assert _features(room(point, aperture=0.05)) == {"PPM_LIGHT_POINT", "PPM_DOF"}
    assert _features(room(point, world=(0.2, 0.2, 0.2))) == {"PPM_LIGHT_POINT", "PPM_WORLD"}
    sun = _light(LIGHT_SUN, (3, 3, 3), direction=(0.3, 0.2, -1))
    assert _features(room(sun)) == {"PPM_LIGHT_SUN"}
    area = _light(LIGHT_AREA_RECT, (5, 5, 5))
    assert _features(room(area)) == {"PPM_LIGHT_AREA", "PPM_LIGHTS_SEEN"}
    hidden = VIS_CAMERA | VIS_GLOSSY | VIS_TRANSMISSION
    assert _features(room(_light(LIGHT_AREA_RECT, (5, 5, 5), hidden=hidden))) == {"PPM_LIGHT_AREA"}
    sphere = _light(LIGHT_POINT, (10, 10, 10), radius=0.1)
    assert _features(room(sphere)) == {"PPM_LIGHT_POINT", "PPM_LIGHTS_SEEN"}
    # a zero-power light needs no code: it is never sampled
    both = np.concatenate([point, _light(LIGHT_SUN, (0, 0, 0))])
    assert _features(room(both)) == {"PPM_LIGHT_POINT"}
    assert _features(cornell_box(8, 8)) == {"PPM_EMISSIVE"}
    assert _features(cornell_box(8, 8, bulb=True)) == {"PPM_EMISSIVE", "PPM_MICROFACET",
                                                       "PPM_SHADER"}


def _materials_room(**node):
    """The room with a sphere of one BSDF node's material, lit by a point light."""
    mb = MeshBuilder()
    white = mb.material("white", (0.7, 0.7, 0.7))
    mb.quad((0, 0, 0), (1, 0, 0), (0, 1, 0), white)
    mb.sphere((0.3, 0.2, 0.3), 0.3, mb.shader("s", [node]), 16, 8)
    ext = perspective_extent(20, 20, 35.0, 36.0)
    cam = make_camera(width=20, height=20, to_world=look_at((0, -2.9, 1), (0, 0, 0.5)),
                      extent=ext[:2], clip=(0.1, 100))
    return mb.build(camera=cam, lights=_light(LIGHT_POINT, (10, 10, 10)))


def test_closure_features_follow_the_materials():
    """Each closure's code is compiled only for scenes whose materials make it; a plastic (a
    rough specular layer over diffuse) is shaded by the gather, a mirror is not."""
    base = {"PPM_LIGHT_POINT"}
    f = lambda **n: _features(_materials_room(**n)) - base
    assert f(type=NODE_DIFFUSE) == set()                        # one Lambert: the short path
    assert f(type=NODE_DIFFUSE, roughness=0.5) == {"PPM_SHADER", "PPM_GATHER_SHADE",
                                                   "PPM_OREN_NAYAR"}
    assert f(type=NODE_SHEEN) == {"PPM_SHADER", "PPM_GATHER_SHADE", "PPM_SHEEN"}
    assert f(type=NODE_TRANSLUCENT) == {"PPM_SHADER", "PPM_GATHER_SHADE", "PPM_TRANSLUCENT"}
    assert f(type=NODE_PRINCIPLED) == {"PPM_SHADER", "PPM_GATHER_SHADE", "PPM_MICROFACET"}
    assert f(type=NODE_PRINCIPLED, alpha=0.5) == {"PPM_SHADER", "PPM_GATHER_SHADE",
                                                  "PPM_MICROFACET", "PPM_TRANSPARENT"}
    assert f(type=NODE_PRINCIPLED, metallic=1.0, roughness=0.0) == {"PPM_SHADER",
                                                                    "PPM_MICROFACET"}


def test_specialised_kernels_are_separate_programs():
    a = Renderer(cornell_box(8, 8), RenderOptions(indirect="photons", photons_per_pass=256))
    b = Renderer(cornell_box(8, 8, bulb=True),
                 RenderOptions(indirect="photons", photons_per_pass=256))
    c = Renderer(cornell_box(8, 8),
                 RenderOptions(indirect="photons", photons_per_pass=256, specialize=False))
    assert a.features != b.features and c.features is None
    assert (a.features, b.features) == (_features(cornell_box(8, 8)),
                                        _features(cornell_box(8, 8, bulb=True)))
    assert len({r.eye.kernel.kernel.program.int_ptr for r in (a, b, c)}) == 3
    for r in (a, b, c):
        r.close()


def test_roughness_settings_share_the_kernels():
    """RenderOptions.gather_roughness and caustic_roughness reach the kernels in the Light Paths
    record (light_paths.with_roughness), not as -D flags: a render with other values builds
    no program (each value built its own eye, photon and gather programs before)."""
    o = dict(indirect="photons", photons_per_pass=256, specialize=False)
    a = Renderer(cornell_box(8, 8), RenderOptions(**o))
    a.iterate()
    programs = a.device.programs
    builds = programs.builds
    b = Renderer(cornell_box(8, 8), RenderOptions(**o, gather_roughness=0.35,
                                                  caustic_roughness=0.2))
    b.iterate()
    assert programs.builds == builds
    assert b.eye.kernel.kernel.program.int_ptr == a.eye.kernel.kernel.program.int_ptr
    lp = b.scene.light_paths[0]
    assert (lp["gather_roughness"], lp["caustic_roughness"]) == (np.float32(0.35),
                                                                 np.float32(0.2))
    for r in (a, b):
        r.close()


SCENES = {
    "cornell": lambda: cornell_box(20, 20),
    "bulb": lambda: cornell_box(20, 20, bulb=True),
    "point_glass_mirror": lambda: room(_light(LIGHT_POINT, (10, 10, 10), radius=0.05),
                                       glass=True, mirror=True),
    "sun_dof": lambda: room(_light(LIGHT_SUN, (3, 3, 3), direction=(0.3, 0.2, -1)),
                            aperture=0.05),
    "area_world": lambda: room(_light(LIGHT_AREA_RECT, (5, 5, 5)), world=(0.1, 0.1, 0.2)),
    "mirror_caustic": lambda: analytic.mirror_caustic(16),
    "plastic_sheen": lambda: _materials_room(type=NODE_PRINCIPLED, sheen_weight=1.0,
                                             alpha=0.8, diffuse_roughness=0.5),
}


# each scene builds programs of its own (2-4 s each in a cold run): the default run keeps the
# four whose feature sets cover the others' between them (the Cornell box's emissive mesh
# light, the bulb's and the mirror's are in the slow tier; the command-line renders of
# test_e2e.py render the Cornell box and the bulb box with their own kernels, the Cornell box
# against Cycles)
SLOW_SCENES = {"cornell", "bulb", "mirror_caustic"}


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n in SLOW_SCENES
                                  else n for n in SCENES])
def test_specialised_kernels_render_the_same_image(name):
    """Specialisation removes code the scene cannot reach and nothing else: with the same seed
    the random streams are the same, so the images agree to float rounding.  (The exact gather:
    the stochastic map keeps one photon per entry by a key tied to the photon's slot, and the
    photon pass fills the slots in whatever order its atomics run.)"""
    scene = SCENES[name]()
    imgs = []
    for specialize in (True, False):
        r = Renderer(scene, RenderOptions(indirect="photons", photons_per_pass=2048, seed=4,
                                          specialize=specialize, exact_gather=True))
        for _ in range(4):
            s = r.iterate()
        assert s.nan_dropped == 0
        imgs.append(r.image())
        r.close()
    assert imgs[0][..., :3].mean() > 0
    np.testing.assert_allclose(imgs[0], imgs[1], rtol=1e-4, atol=1e-6)


def _phases(scene, passes=2, **opts):
    r = Renderer(scene, RenderOptions(indirect="photons", photons_per_pass=1024, **opts))
    stats = [r.iterate() for _ in range(passes)]
    img = r.image()
    r.close()
    return stats[-1], img


def test_no_photon_pass_without_bounces_or_diffuse_surfaces():
    s, _ = _phases(cornell_box(16, 16), max_bounces=0)        # direct light only
    # (nor the grid over the visible points: only photons use it)
    assert set(s.phase_ms) == {"eye", "update"} and s.photons_emitted == 0
    mb = MeshBuilder()                                        # only a mirror and glass
    mb.quad((0, 0, 0), (1, 0, 0), (0, 1, 0),
            mb.material("mirror", (0.9, 0.9, 0.9), metallic=1.0, roughness=0.0))
    mb.sphere((0, 0, 0.5), 0.3, mb.material("glass", (1, 1, 1), transmission=1.0,
                                            roughness=0.0), 12, 6)
    cam = make_camera(width=16, height=16, to_world=look_at((0, -3, 2), (0, 0, 0)),
                      extent=perspective_extent(16, 16, 35, 36)[:2])
    s, img = _phases(mb.build(camera=cam, lights=_light(LIGHT_POINT, (10, 10, 10)),
                              world=(0.1, 0.1, 0.1)))
    assert set(s.phase_ms) == {"eye", "update"} and s.visible_points == 0
    assert img[..., :3].mean() > 0                            # the world, seen in the mirror
    s, _ = _phases(cornell_box(16, 16))                      # the normal case has them all
    assert set(s.phase_ms) == {"eye", "grid", "photon", "hash", "gather", "update"}


def test_no_photon_storage_or_light_tracing_film_where_no_photon_pass_runs():
    """Photon storage (ppm_engine/render/photon_map.py: 2 x the photons per pass, and the hash
    table) and the light tracing's film buffers (44 bytes per pixel) are allocated only by a
    render that traces photons: at 1920 x 1080 that is 305 MiB a Cornell box lit by eye paths no
    longer holds (docs/history/benchmarks-notebook.md, "Memory and time per pass at 1920x1080").
    The same box by eye paths (no caustics: no photon pass) and by the paper's photons: the device's
    byte count differs by those buffers (the eye paths' own, the path space filter's, left out)."""
    dev = get_device(RenderOptions().device)
    grown = {}
    for indirect in ("paths", "photons"):
        before = dev.allocated
        r = Renderer(cornell_box(32, 32), RenderOptions(indirect=indirect, path_filter=False))
        try:
            s = r.iterate()
            grown[indirect] = dev.allocated - before
            traced = indirect == "photons"
            assert r.photons_needed == traced and ("photon" in s.phase_ms) == traced
            assert (r.photon_map.capacity >= 2 * r.photons_per_pass) == traced
            assert r.film.light_tracing == traced
            store = 40 * 2 * r.photons_per_pass + 16 * 2 * r.photons_per_pass
        finally:
            r.close()
    assert grown["photons"] - grown["paths"] >= store + 44 * 32 * 32, grown


def test_photons_nobody_sees_are_not_stored():
    """Photons landing outside the visible points' grid are counted, not stored or hashed."""
    scene = room(_light(LIGHT_POINT, (30, 30, 30), position=(0, 0, 0.5)))
    cam = scene.camera.copy()                                # look at one corner of the floor
    cam["to_world"] = look_at((0.6, 0.6, 0.6), (0.8, 0.8, 0.0))[:3]
    s, _ = _phases(scene.replace(camera=cam))
    assert s.photons_outside > 2 * s.photons_stored > 0


def test_lights_without_power_are_never_sampled():
    """A zero-power light takes no photons and no light samples: the image is exactly the one
    without it (same random streams)."""
    point = _light(LIGHT_POINT, (10, 10, 10))
    dark = np.concatenate([_light(LIGHT_SUN, (0, 0, 0)), point, _light(LIGHT_AREA_RECT, (0, 0, 0))])
    a = _phases(room(point), passes=3, seed=2, exact_gather=True)[1]
    b = _phases(room(dark), passes=3, seed=2, exact_gather=True)[1]
    assert a[..., :3].mean() > 0
    np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-7)


def test_adaptive_sampling_stops_converged_pixels_and_keeps_their_value():
    scene = cornell_box(24, 24)
    r = Renderer(scene, RenderOptions(indirect="photons", photons_per_pass=4096, seed=3,
                                      noise_threshold=0.03))
    active, imgs = [], []
    for _ in range(400):
        s = r.iterate()
        active.append(s.active_pixels)
        imgs.append((r.image(), r.film.read("active").astype(bool)))
        if s.converged:
            break
    active = np.array(active)
    # none before 32 passes
    assert (active[:ProgressiveUpdate.ADAPTIVE_MIN_PASSES - 1] == 24 * 24).all()
    assert (np.diff(active) <= 0).all() and active[-1] < 0.5 * 24 * 24     # most stop
    assert "% converged" in s.line(400)
    # a pixel that stopped keeps its value; the still active ones keep changing
    (img_a, act_a), (img_b, act_b) = imgs[-9], imgs[-1]
    stopped = ~act_a
    # no pixel that gathers photons stopped with a large radius (its bias is not noise)
    R, R0, N = (r.film.read(k) for k in ("radius", "radius0", "nstat"))
    small = R[~act_b] <= ProgressiveUpdate.ADAPTIVE_MAX_RADIUS * R0[~act_b]
    assert ((N[~act_b] == 0) | small).all()
    assert stopped.any() and act_b.sum() <= act_a.sum()
    np.testing.assert_array_equal(img_a[stopped], img_b[stopped])
    # and the image is the non-adaptive one within noise (stopping pixels adds no bias)
    full = Renderer(scene, RenderOptions(indirect="photons", photons_per_pass=4096, seed=4))
    for _ in range(len(active)):
        full.iterate()
    ref = full.image()[..., :3]
    assert img_b[..., :3].mean() == pytest.approx(ref.mean(), rel=0.02)
    r.close()
    full.close()


def test_noise_threshold_off_samples_every_pixel_every_pass():
    r = Renderer(cornell_box(16, 16), RenderOptions(indirect="photons", photons_per_pass=1024))
    for _ in range(40):
        s = r.iterate()
        assert s.active_pixels == 256 and not s.converged and "adaptive" not in s.phase_ms
    r.close()


def test_render_ends_when_every_pixel_converged(bpy, example_blend, tiny, render_exr, tmp_path):
    from ppm_engine.blender import session
    bpy.ops.wm.open_mainfile(filepath=str(example_blend("cornell_box")), load_ui=False)
    scene = bpy.context.scene
    tiny(scene, width=16, height=16, passes=100000)
    scene.ppm.noise_threshold = 0.5                  # loose: everything converges quickly
    img = render_exr(tmp_path / "adaptive.exr")
    assert ProgressiveUpdate.ADAPTIVE_MIN_PASSES <= session.renders[-1]["passes"] < 1000
    assert np.isfinite(img).all() and img[..., :3].mean() > 0


def test_a_nan_world_is_refused_before_the_dark_scene_check():
    from ppm_engine.blender.session import emits_nothing
    from ppm_engine.errors import SceneError
    scene = cornell_box(8, 8, light_radiance=0.0)
    assert emits_nothing(scene)
    with pytest.raises(SceneError, match="world"):
        emits_nothing(scene.replace(world=np.float32([np.nan, 0, 0])))


def test_skip_switches_of_the_benchmark_change_the_work_not_the_image():
    """RenderOptions.skip_unneeded_photon_pass / skip_unseen_photons off (bench --skips measures
    each skip against them): the work the skip saves is done, and the image stays the same."""
    scene = cornell_box(16, 16)
    on, img_on = _phases(scene, max_bounces=0)
    off, img_off = _phases(scene, max_bounces=0, skip_unneeded_photon_pass=False)
    assert "photon" not in on.phase_ms and {"photon", "hash", "gather"} <= set(off.phase_ms)
    assert off.photons_emitted == 2 * 1024 and off.photons_stored == 0   # no bounce: none kept
    np.testing.assert_array_equal(img_on, img_off)       # the eye pass's streams are the same
    corner = scene.camera.copy()                        # looking into one corner of the box
    corner["to_world"] = look_at((0.5, 0.5, 0.5), (1.0, 1.0, 0.0))[:3]
    scene = scene.replace(camera=corner)
    seen, _ = _phases(scene, seed=2)
    every, _ = _phases(scene, seed=2, skip_unseen_photons=False)
    assert seen.photons_outside > 0 and every.photons_outside == 0
    # the grid over the whole scene stores the photons the visible points' grid turned away
    # (each photon pass's count varies by Russian roulette: 25 % margin)
    total = seen.photons_stored + seen.photons_outside
    assert every.photons_stored == pytest.approx(total, rel=0.25)
    assert every.photons_stored > 2 * seen.photons_stored


def test_every_feature_build_reads_the_attribute_stride_at_run_time():
    """Scenes with different numbers of mesh attributes share the kernels of every feature (the
    stride is EmitterInfo.n_attributes, read when the programs run); only a specialised build
    sizes its arrays by the scene's stride (before, -D PPM_ATTRIBUTES made a build of every
    feature per stride: two in a cold test run)."""
    base = cornell_box(4, 4)
    for k in (1, 3):
        scene = base.replace(attributes=np.zeros((base.n_triangles, 3, k, 4), np.float32))
        dev = get_device()
        with dev.lock:
            ds = DeviceScene(dev, scene, specialize=False)
            assert int(ds.emitters.info["n_attributes"][0]) == k
            assert "PPM_ATTRIBUTES" not in ds.kernel_defines(False)[1]
            assert ds.kernel_defines(True)[1]["PPM_ATTRIBUTES"] == k
