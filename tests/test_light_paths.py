"""Cycles' Light Paths settings (ppm_engine/scene/light_paths.py): read from scene.cycles, Cycles'
defaults without it, refused when out of range, and each honoured as Cycles honours it, in
image pairs: the same scene rendered by Cycles and by this engine with the same setting, per
block."""
import numpy as np
import pytest

from ppm_engine.render.options import RenderOptions, SettingsError
from ppm_engine.scene.light_paths import (
    CYCLES_DEFAULTS,
    LIGHT_PATHS_DTYPE,
    LightPathsError,
    engine_defaults,
    from_cycles,
    make_light_paths,
    with_max_bounces,
)


def test_cycles_defaults_and_the_engines_own():
    lp = make_light_paths()[0]
    assert (lp["max_bounces"], lp["diffuse_bounces"], lp["glossy_bounces"],
            lp["transmission_bounces"], lp["volume_bounces"],
            lp["transparent_max_bounces"]) == (12, 4, 4, 12, 0, 8)
    # Cycles compares a sample's r + g + b with three times the setting
    assert lp["clamp_direct"] == 0.0 and lp["clamp_indirect"] == pytest.approx(30.0)
    own = engine_defaults()[0]            # a scene with no Cycles settings: unbiased, 12 each
    assert own["diffuse_bounces"] == own["glossy_bounces"] == 12
    assert own["clamp_indirect"] == 0.0 and own["filter_glossy"] == 0.0
    assert from_cycles(None).tobytes() == make_light_paths().tobytes()


def test_settings_out_of_range_are_refused_by_name():
    for kw, name in ((dict(diffuse_bounces=-1), "Diffuse"), (dict(max_bounces=2000), "Total"),
                     (dict(transparent_max_bounces=1.5), "Transparent"),
                     (dict(sample_clamp_indirect=float("nan")), "Clamp Indirect"),
                     (dict(sample_clamp_direct=-3.0), "Clamp Direct")):
        with pytest.raises(LightPathsError, match=name):
            make_light_paths(**kw)
    with pytest.raises(SettingsError):
        RenderOptions(max_bounces=-1).validate()
    with pytest.raises(SettingsError):
        RenderOptions(max_bounces=True).validate()


def test_a_loaded_record_out_of_range_is_refused(tmp_path):
    from ppm_engine.oracle.procedural import cornell_box
    scene = cornell_box(4, 4)
    bad = scene.light_paths.copy()
    bad["glossy_bounces"] = -5
    with pytest.raises(LightPathsError, match="Glossy"):
        scene.replace(light_paths=bad)
    path = tmp_path / "s.npz"
    scene.replace(light_paths=make_light_paths(diffuse_bounces=2)).save(path)
    from ppm_engine.scene.arrays import SceneArrays
    assert SceneArrays.load(path).light_paths["diffuse_bounces"][0] == 2


def test_max_bounces_option_overrides_every_kind_but_transparency():
    lp = with_max_bounces(make_light_paths(transparent_max_bounces=3), 2)[0]
    assert [lp[k] for k in ("max_bounces", "diffuse_bounces", "glossy_bounces",
                            "transmission_bounces", "volume_bounces")] == [2] * 5
    assert lp["transparent_max_bounces"] == 3
    assert with_max_bounces(engine_defaults(), None).tobytes() == engine_defaults().tobytes()


def test_export_reads_scene_cycles(empty):
    from ppm_engine.blender.export import export_scene
    c = empty.cycles
    c.max_bounces, c.diffuse_bounces, c.glossy_bounces = 7, 2, 3
    c.transmission_bounces, c.transparent_max_bounces = 5, 6
    c.sample_clamp_direct, c.sample_clamp_indirect = 2.0, 0.0
    c.caustics_refractive = False
    bpy = pytest.importorskip("bpy")
    bpy.ops.mesh.primitive_plane_add()
    lp = export_scene(bpy.context.evaluated_depsgraph_get()).light_paths[0]
    assert [int(lp[k]) for k in ("max_bounces", "diffuse_bounces", "glossy_bounces",
                                 "transmission_bounces", "transparent_max_bounces")] == \
        [7, 2, 3, 5, 6]
    assert lp["clamp_direct"] == pytest.approx(6.0) and lp["clamp_indirect"] == 0.0
    assert lp["flags"] == 1                          # reflective caustics only
    assert LIGHT_PATHS_DTYPE.names[0] == "max_bounces" and set(CYCLES_DEFAULTS) >= {
        "max_bounces", "sample_clamp_indirect"}


# --- image pairs against Cycles -----------------------------------------------------------------
W = 24                  # pixels per side; blocks of 8 x 8


def _room(bpy, *, mirror=True, glass=True, planes=0):
    """A Cornell room lit by a 1 x 1 m lamp in its ceiling: a mirror box on the left, a glass
    ball on the right (caustic on the floor), ``planes`` half-transparent planes before the
    back wall; no world light.  Cycles' Light Paths as Cycles renders them unbiased (12 each,
    no clamping); each test sets the one it checks."""
    from ppm_engine.blender.harness import unbiased_light_paths
    from ppm_engine.blender.scenes import cornell_box as cb
    scene = cb.new_scene()
    cb.room(scene)
    cb.quad(scene, "Lamp", [(-0.5, -0.5, 1.99), (-0.5, 0.5, 1.99), (0.5, 0.5, 1.99),
                            (0.5, -0.5, 1.99)], cb.emission("Lamp", 4.0))
    if mirror:
        m = bpy.data.materials.new("Mirror")
        p = m.node_tree.nodes["Principled BSDF"]
        p.inputs["Metallic"].default_value = 1.0
        p.inputs["Roughness"].default_value = 0.0
        p.inputs["Base Color"].default_value = (0.9, 0.9, 0.9, 1.0)
        cb.box(scene, "MirrorBox", (-0.8, -0.2, 0.0), (-0.2, 0.6, 1.1), m)
    if glass:
        cb.sphere(scene, "Ball", (0.45, -0.1, 0.45), 0.4, cb.glass("Glass"))
    if planes:
        t = bpy.data.materials.new("Veil")
        tree = t.node_tree
        tree.nodes.remove(tree.nodes["Principled BSDF"])
        mix, tr, df = (tree.nodes.new(n) for n in ("ShaderNodeMixShader",
                                                   "ShaderNodeBsdfTransparent",
                                                   "ShaderNodeBsdfDiffuse"))
        mix.inputs["Fac"].default_value = 0.2
        tree.links.new(tr.outputs[0], mix.inputs[1])
        tree.links.new(df.outputs[0], mix.inputs[2])
        tree.links.new(mix.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
        for k in range(planes):
            y = 0.9 - 0.05 * k
            cb.quad(scene, f"Veil{k}", [(-1, y, 0.0), (1, y, 0.0), (1, y, 2.0), (-1, y, 2.0)], t)
    cb.camera_world_render(scene, resolution=W)
    unbiased_light_paths(scene)
    return scene


def _pair(bpy, scene, tmp_path, render_exr, tiny, *, samples, passes, photons=1 << 12):
    """(ours, Cycles') RGB of the scene as its Light Paths stand."""
    from ppm_engine.blender.harness import cycles_reference
    c = scene.cycles
    keep = {k: getattr(c, k) for k in CYCLES_DEFAULTS}
    cycles_reference(scene, samples=samples, seed=1)
    for k, v in keep.items():                 # the reference's bounces are the test's own
        setattr(c, k, v)
    ref = render_exr(tmp_path / "cycles.exr")
    tiny(scene, width=W, height=W, passes=passes, photons=photons)
    return render_exr(tmp_path / "ours.exr"), ref


def _setting_agrees(bpy, tmp_path, render_exr, tiny, settings, indirect, rtol):
    """The room with Cycles' Light Paths `settings` and this engine's `indirect` light, per
    block within rtol of Cycles with the same settings."""
    scene = _room(bpy)
    for k, v in settings.items():
        setattr(scene.cycles, k, v)
    scene.ppm.indirect = indirect
    ours, ref = _pair(bpy, scene, tmp_path, render_exr, tiny, samples=1024, passes=256)
    _agree(ours, ref, rtol)


def _blocks(img):
    return img.reshape(W // 8, 8, W // 8, 8, 3).mean(axis=(1, 3)).mean(axis=-1)


def _agree(ours, ref, rtol, atol=0.003):
    a, b = _blocks(ours), _blocks(ref)
    bad = np.abs(a - b) > rtol * b + atol
    assert not bad.any(), f"blocks ours / Cycles:\n{np.round(a / np.maximum(b, 1e-6), 3)}"


# name: (Cycles settings, this engine's indirect light).  Each setting changes Cycles' image by
# 3 to 11 times the tests' 6 % in some block (measured by rendering Cycles with and
# without it), so a limit ignored or counted otherwise fails.
SETTINGS = {
    "diffuse_0": (dict(diffuse_bounces=0), "AUTO"),
    "diffuse_1": (dict(diffuse_bounces=1), "AUTO"),
    "diffuse_1_photons": (dict(diffuse_bounces=1), "PHOTONS"),
    "glossy_0": (dict(glossy_bounces=0), "AUTO"),
    "glossy_1_photons": (dict(glossy_bounces=1), "PHOTONS"),
    "transmission_1": (dict(transmission_bounces=1), "AUTO"),
    "total_1": (dict(max_bounces=1), "AUTO"),
    "total_2_diffuse_1": (dict(max_bounces=2, diffuse_bounces=1), "PHOTONS"),
}


@pytest.mark.parametrize("name", [pytest.param(n, marks=() if n in ("diffuse_1_photons",
                                                                    "total_1")
                                                else pytest.mark.slow) for n in SETTINGS])
def test_bounce_limits_as_cycles(name, bpy, tmp_path, render_exr, tiny):
    """Each bounce limit against Cycles with the same limit, per 8 x 8 block within 6 %: the
    mirror box (glossy), the glass ball and its caustic (transmission: photons joined to eye
    paths), the room's diffuse light (eye paths, or photons), the total."""
    _setting_agrees(bpy, tmp_path, render_exr, tiny, *SETTINGS[name], 0.06)


@pytest.mark.slow
def test_transparent_limit_as_cycles(bpy, tmp_path, render_exr, tiny):
    """Three half-transparent veils before the back wall with Transparent 2: the wall behind
    the third is not shaded (Cycles ends the path at the surface after its last crossing),
    and shadow rays cross fewer veils."""
    scene = _room(bpy, mirror=False, glass=False, planes=3)
    scene.cycles.transparent_max_bounces = 2
    ours, ref = _pair(bpy, scene, tmp_path, render_exr, tiny, samples=1024, passes=256)
    _agree(ours, ref, 0.06)


# Clamp Indirect 0.3 darkens Cycles' blocks by up to 36 % (the caustic under the ball, the
# corners), Clamp Direct 0.3 the lamp and the ceiling by up to 86 %: each far beyond the 7 %.
CLAMPS = {
    "indirect_paths": (dict(sample_clamp_indirect=0.3), "AUTO"),
    "indirect_photons": (dict(sample_clamp_indirect=0.3), "PHOTONS"),
    "direct": (dict(sample_clamp_direct=0.3), "AUTO"),
}


@pytest.mark.parametrize("name", [pytest.param(n, marks=() if n == "indirect_photons"
                                                else pytest.mark.slow) for n in CLAMPS])
def test_clamping_as_cycles(name, bpy, tmp_path, render_exr, tiny):
    """Clamp Direct and Clamp Indirect against Cycles with the same clamp, per 8 x 8 block
    within 7 %: eye-path samples are clamped as Cycles clamps its samples; a photon as the
    camera path that finds its light would be (its radiance, the visible point's sample weight,
    and next-event estimation's density at the light's first scattering:
    kernels/integrator/gather.cl), which matches Cycles' clamped mean without being its sample for
    sample."""
    _setting_agrees(bpy, tmp_path, render_exr, tiny, *CLAMPS[name], 0.07)


# Refractive Caustics off takes Cycles' caustic under the ball down to 55 %, Reflective off the
# light the mirror box throws to 69-82 %, both together to 49-87 %: beyond the 6 % everywhere.
CAUSTICS = {
    "refractive_off": (dict(caustics_refractive=False), "AUTO"),
    "reflective_off": (dict(caustics_reflective=False), "AUTO"),
    "both_off_photons": (dict(caustics_reflective=False, caustics_refractive=False), "PHOTONS"),
}


@pytest.mark.parametrize("name", [pytest.param(n, marks=() if n == "refractive_off"
                                                else pytest.mark.slow) for n in CAUSTICS])
def test_caustics_toggles_as_cycles(name, bpy, tmp_path, render_exr, tiny):
    """Reflective and Refractive Caustics off against Cycles, per 8 x 8 block within 6 %: a
    glossy reflection or transmission right after a diffuse bounce is not made, by the eye
    paths (shader.h shader_caustics_off) nor by photons (path_state.h path_caustic_off)."""
    _setting_agrees(bpy, tmp_path, render_exr, tiny, *CAUSTICS[name], 0.06)


# The bench's clamped_caustic at 24 x 24: a polished metal ball (roughness 0.16) under a
# radius-0 point light in a lamp shade, the wall and the floor around the lit pool lit only by
# the ball's glossy reflection.  Cycles finds that light by next-event estimation at the ball
# after a diffuse bounce, in rare bright samples, so Clamp Indirect 100 takes Cycles' image from
# a mean of 0.77 to 0.46 (the wall's blocks to 0.45-0.6 of their light); the photons that carry
# it are clamped as those samples would be (photon_pass.cl, gather.cl), or it stays at 1.3-4 x
# Cycles' in every block of the wall and the floor beside the pool.  Clamp off, the control:
# Cycles' samples of that light are fireflies (its blocks move by 40 % at 2048 samples), so a
# long reference and the mean of what the ball does not cover (its highlight of the point
# light is one subpixel spot for both engines).
CLAMPED_CAUSTIC = {100.0: dict(samples=2048, passes=128, rtol=0.12, atol=0.015, mean=0.04,
                               ball=True),
                   0.0: dict(samples=16384, passes=512, rtol=0.3, atol=0.02, mean=0.06,
                             ball=False)}


@pytest.mark.parametrize("clamp", [100.0, pytest.param(0.0, marks=pytest.mark.slow)])
def test_glossy_caustic_clamped_as_cycles(clamp, bpy, tmp_path, render_exr, tiny):
    """A glossy caustic of a point light under Clamp Direct and Indirect 100 (and, as the
    control, unclamped) against Cycles with the same clamp: the image's mean and every 8 x 8
    block's (unclamped, without the ball's pixels)."""
    from ppm_engine.blender.harness import cycles_reference
    from ppm_engine.blender.scenes import build_example
    from ppm_engine.blender.scenes.caustics import CLAMPED_BALL
    from ppm_engine.tools.bench.scenes import camera_rays, sphere_hit_t
    from tests.helpers.blender_scenes import square
    k = CLAMPED_CAUSTIC[clamp]
    scene = square(build_example("clamped_caustic"), W)
    o, d = camera_rays(scene, W, W)
    rest = ~np.isfinite(sphere_hit_t(o, d, *CLAMPED_BALL)) | k["ball"]   # the pixels compared

    def clamped():
        scene.cycles.sample_clamp_direct = scene.cycles.sample_clamp_indirect = clamp

    cycles_reference(scene, samples=k["samples"], seed=1)
    clamped()
    ref = render_exr(tmp_path / "cycles.exr")
    tiny(scene, width=W, height=W, passes=k["passes"], photons=1 << 12)
    clamped()
    ours = render_exr(tmp_path / "ours.exr")
    a, b = ours[rest].mean(), ref[rest].mean()
    assert abs(a / b - 1.0) < k["mean"], f"mean ours {a:.4f}, Cycles {b:.4f}"
    w = rest[..., None].astype(np.float64)

    def blocks(img):
        s = (img * w).reshape(W // 8, 8, W // 8, 8, 3).sum(axis=(1, 3)).mean(axis=-1)
        return s / w.reshape(W // 8, 8, W // 8, 8).sum(axis=(1, 3))
    a, b = blocks(ours), blocks(ref)
    bad = np.abs(a - b) > k["rtol"] * b + k["atol"]
    assert not bad.any(), f"blocks ours / Cycles:\n{np.round(a / np.maximum(b, 1e-6), 3)}"
