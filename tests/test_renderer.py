"""The renderer as a whole, without Blender: settings, statistics, buffers, edge cases."""
import re

import numpy as np
import pytest

from ppm_engine.errors import DeviceError
from ppm_engine.oracle.procedural import MeshBuilder, cornell_box, look_at
from ppm_engine.render.options import RenderOptions, SettingsError
from ppm_engine.render.renderer import Renderer
from ppm_engine.scene.arrays import NODE_PRINCIPLED, SceneArrays
from ppm_engine.scene.camera import make_camera
from tests.helpers.renders import every_feature


@pytest.mark.parametrize("bad", [dict(passes=-1), dict(passes=0), dict(alpha=0.0),
                                 dict(alpha=1.0), dict(alpha=1.5), dict(photons_per_pass=0),
                                 dict(time_limit=-1.0), dict(max_bounces=-2),
                                 dict(initial_radius=float("nan")), dict(passes="ten")])
def test_invalid_settings_are_refused_with_the_name(bad):
    with pytest.raises(SettingsError, match=next(iter(bad))):
        RenderOptions(**bad).validate()


def test_automatic_photon_count_is_one_per_pixel_within_bounds():
    from ppm_engine.render.options import AUTO_PHOTONS_MAX, AUTO_PHOTONS_MIN
    auto = every_feature()
    assert auto.photons_per_pass is None
    assert auto.photons_for(512 * 512) == 1 << 18          # the paper's count at 512 x 512
    assert auto.photons_for(128 * 128) == 128 * 128
    assert auto.photons_for(1) == AUTO_PHOTONS_MIN
    assert auto.photons_for(8192 * 8192) == AUTO_PHOTONS_MAX
    assert every_feature(photons_per_pass=777).photons_for(128 * 128) == 777
    # 6400 pixels: 6400 photons a pass (the paper's photons: a diffuse box has no caustics)
    r = Renderer(cornell_box(80, 80), auto.replace(indirect="photons"))
    s = r.iterate()
    assert r.photons_per_pass == 6400 and s.photons_emitted == 6400
    r.reset(every_feature(photons_per_pass=1000, indirect="photons"))
    assert r.iterate().photons_emitted == 1000
    r.close()


def test_unknown_device_lists_the_available_ones():
    with pytest.raises(DeviceError, match="available"):
        Renderer(cornell_box(8, 8), every_feature(device="no-such-device-xyz"))


def test_cornell_box_statistics_and_monotone_radii():
    r = Renderer(cornell_box(32, 32), every_feature(photons_per_pass=1 << 13, seed=3,
                                                    indirect="photons"))
    radii = []
    for _ in range(8):
        s = r.iterate()
        radii.append(r.film.read("radius"))
        assert s.photons_stored > 0 and s.photons_dropped == 0 and s.nan_dropped == 0
        assert 0 < s.occupied_entries <= s.photons_stored and s.photons_per_entry >= 1
        assert 0 < s.radius_min <= s.radius_max
        assert s.visible_points > 0.8 * 32 * 32
        assert set(s.phase_ms) == {"eye", "grid", "photon", "hash", "gather", "update"}
    radii = np.array(radii)
    grown = (np.diff(radii, axis=0) > 0) & (radii[:-1] > 0)   # 0 = no visible point yet
    assert not grown.any()                                  # radii never grow
    assert (radii[-1] < radii[0]).mean() > 0.8            # and shrink where photons arrive
    assert s.photons_emitted == 8 * (1 << 13)
    img = r.image()
    assert img.shape == (32, 32, 4) and np.isfinite(img).all() and (img[..., 3] == 1).all()
    assert img[..., :3].mean() > 0.05
    # the status line states these statistics: its numbers, read back
    line = re.fullmatch(r"Pass (\d+)/(\d+) · ([\d.]+)([KMG]?) photons \+ light tracing"
                        r" · r ([\d.e+-]+)–([\d.e+-]+) · ([\d.]+) s · (\d+) s left",
                        s.line(64, 1.25))
    assert line, s.line(64, 1.25)
    assert (int(line[1]), int(line[2])) == (s.pass_index, 64)
    shown = float(line[3]) * {"": 1, "K": 1e3, "M": 1e6, "G": 1e9}[line[4]]
    assert shown == pytest.approx(s.photons_emitted, rel=1e-3)          # 3 significant digits
    assert float(line[5]) == pytest.approx(s.radius_min, rel=5e-3)
    assert float(line[6]) == pytest.approx(s.radius_max, rel=5e-3)
    assert float(line[7]) == pytest.approx(1.25, abs=0.051)
    assert int(line[8]) == round(1.25 / 8 * (64 - 8))                   # at the pass rate
    left = re.search(r"· (\d+) s left$", s.line(64, 1.25, time_limit=2.0))
    assert int(left[1]) == round(2.0 - 1.25)                             # the limit comes first


def test_photon_buffer_overflow_is_counted_then_grows():
    class Tight(Renderer):
        STORE_FACTOR = 0.05
    r = Tight(cornell_box(16, 16), every_feature(photons_per_pass=1 << 12, indirect="photons"))
    cap = r.photon_map.capacity
    s1 = r.iterate()
    assert s1.photons_dropped > 0 and s1.photons_stored == cap
    assert r.photon_map.capacity == 2 * cap                # doubled for the next pass
    for _ in range(10):                                     # until everything fits
        s = r.iterate()
        if s.photons_dropped == 0:
            break
    assert s.photons_dropped == 0 and s.photons_stored > cap
    assert r.photon_map.capacity >= s.photons_stored
    assert np.isfinite(r.image()).all()


def test_empty_scene_shows_the_world():
    scene = MeshBuilder().build(
        camera=make_camera(width=8, height=8, to_world=look_at((0, 0, 0), (1, 0, 0)),
                           extent=(1, 1)), world=(0.25, 0.5, 1.0))
    r = Renderer(scene, every_feature(photons_per_pass=1000))
    r.iterate()
    np.testing.assert_allclose(r.image()[..., :3], np.broadcast_to([0.25, 0.5, 1.0], (8, 8, 3)),
                               rtol=1e-6)


def test_scene_arrays_round_trip(tmp_path):
    s = cornell_box(8, 8, bulb=True)
    s.save(tmp_path / "s.npz")
    t = SceneArrays.load(tmp_path / "s.npz")
    for name in ("positions", "normals", "material", "materials", "camera", "world"):
        assert np.array_equal(getattr(s, name), getattr(t, name))
    assert t.material_names == s.material_names


def test_stochastic_hash_and_exact_gather_converge_to_the_same_image():
    """Same scene: the stochastic map only adds noise (the paper's claim).  Luminance of 3x3
    pixel blocks over 8 seeds per mode (single pixels with few photons give unreliable
    variance estimates from 8 seeds).  The image means may differ slightly because noisier
    photon counts shrink radii a little more slowly (the update is convex in M): that is the
    1 % term, and it vanishes as the radii shrink."""
    scene = cornell_box(12, 12)
    stats = {}

    def blocks(img):
        return img.reshape(4, 3, 4, 3).mean(axis=(1, 3))

    for exact in (False, True):
        imgs, photon_terms = [], []
        for seed in range(8):
            r = Renderer(scene, every_feature(photons_per_pass=1 << 12, seed=seed,
                                              indirect="photons", exact_gather=exact))
            for _ in range(25):
                r.iterate()
            imgs.append(blocks(r.image()[..., :3].mean(axis=-1)))
            # the photon term alone (film_resolve's S / (pi photons)): the eye pass's part is
            # the same in both modes for a seed, and its anti-aliasing noise would hide the
            # photon term's
            S, m = r.film.read_sum("photon_sum"), r.film.read_sum("moments")
            photon_terms.append(blocks(S[..., :3].mean(axis=-1) / (np.pi * m[..., 2])))
            r.close()
        stats[exact] = (np.mean(imgs, axis=0), np.std(imgs, axis=0, ddof=1) / np.sqrt(8),
                        np.std([i.mean() for i in imgs], ddof=1) / np.sqrt(8),
                        np.std(photon_terms, axis=0, ddof=1).mean())
    (a, sa, ta, pa), (b, sb, tb, pb) = stats[False], stats[True]
    assert abs(a.mean() - b.mean()) < 0.01 * b.mean() + 4 * np.hypot(ta, tb)
    z = (a - b) / np.hypot(sa, sb)
    assert np.abs(z).max() < 5, z
    assert pa > pb, (pa, pb)          # the stochastic map is the noisier one (~1.3x here)


def test_kernel_build_failure_carries_the_compiler_log():
    from ppm_engine.errors import KernelBuildError
    from ppm_engine.render.device import get_device
    dev = get_device()
    with pytest.raises(KernelBuildError) as e:
        dev.programs.get("integrator/gather.cl", {"PPM_INT64_ATOMICS": True, "uint": "float"})
    msg = str(e.value)
    assert "kernels/integrator/gather.cl" in msg and "error:" in msg     # the compiler log itself


def test_pixel_filter_table_samples_cycles_blackman_harris():
    """The eye pass's jitter table is the inverse CDF of Cycles' Blackman-Harris filter
    (support +-width pixels); width 0 is the box filter."""
    from ppm_engine.render.film import filter_table
    box = filter_table(0.0)
    assert box.min() > -0.5 and box.max() < 0.5
    assert np.allclose(np.diff(box), 1 / len(box), atol=1e-6)          # uniform in the pixel
    w = 1.5
    t = filter_table(w)
    # thin tails: u = 0.5/256 at 0.75 w
    assert -w < t.min() < -0.7 * w and 0.7 * w < t.max() < w
    assert np.all(np.diff(t) > 0) and abs(t.mean()) < 1e-6
    # the table's samples have the filter's variance
    x = np.linspace(-w, w, 20001)
    v = 2 * np.pi * (x / (2 * w) + 0.5)
    f = 0.35875 - 0.48829 * np.cos(v) + 0.14128 * np.cos(2 * v) - 0.01168 * np.cos(3 * v)
    var = (f * x * x).sum() / f.sum()
    assert t.var() == pytest.approx(var, rel=0.02)


def test_scene_arrays_from_before_the_shader_nodes(tmp_path):
    """A .npz written before the BSDF nodes (one Principled's inputs per material, no
    absorption) loads as one Principled node per material without its specular layer (the
    model it was rendered with) and no absorption."""
    s = cornell_box(8, 8)
    s.save(tmp_path / "new.npz")
    with np.load(tmp_path / "new.npz") as z:
        arrays = {k: z[k] for k in z.files if k != "shader_nodes"}
    old_dt = [("base_color", np.float32, 3), ("emission", np.float32, 3),
              ("metallic", np.float32), ("roughness", np.float32), ("transmission", np.float32),
              ("ior", np.float32), ("base_color_texture", np.int32),
              ("emission_texture", np.int32)]
    old = np.zeros(s.materials.shape[0], old_dt)
    for k in range(old.shape[0]):
        (n,) = s.nodes_of(k)
        old[k] = (n["color"], n["emission"], n["metallic"], n["roughness"], n["transmission"],
                  n["ior"], 0, 0)
    arrays["materials"] = old
    np.savez(tmp_path / "old.npz", **arrays)
    t = SceneArrays.load(tmp_path / "old.npz")
    assert t.materials.dtype == s.materials.dtype and (t.materials["absorption"] == 0).all()
    assert (t.shader_nodes["type"] == NODE_PRINCIPLED).all()
    assert (t.shader_nodes["specular_ior_level"] == 0).all()
    for f in ("material", "color", "emission", "metallic", "roughness", "transmission", "ior"):
        np.testing.assert_array_equal(t.shader_nodes[f], s.shader_nodes[f])


def test_scene_arrays_from_before_the_film_settings(tmp_path):
    """A .npz whose camera has no film fields loads with the film it was rendered with:
    exposure 1, opaque, Blackman-Harris of its width (0: the one-pixel box)."""
    s = cornell_box(8, 8)
    s.save(tmp_path / "new.npz")
    with np.load(tmp_path / "new.npz") as z:
        arrays = {k: z[k] for k in z.files}
    old = [f for f in arrays["camera"].dtype.names
           if f not in ("filter_type", "film_transparent", "glass_roughness", "exposure")]
    arrays["camera"] = np.ascontiguousarray(arrays["camera"][old])
    np.savez(tmp_path / "old.npz", **arrays)
    c = SceneArrays.load(tmp_path / "old.npz").camera[0]
    assert c["exposure"] == 1.0 and c["film_transparent"] == 0 and c["filter_type"] == 0
    assert c["filter_width"] == s.camera[0]["filter_width"]
