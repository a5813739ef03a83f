"""The closures (kernels/closure/closure.h, microfacet.h, shader.h) on their own: sampling agrees
with evaluation (the sampled directions' histogram against the pdf, chi-square; each sample's weight
equal to f cos / pdf), white furnaces (a closure's albedo by its own samples), the Principled
BSDF's layering, and the shading tables (layout, known values, a recomputation)."""
import math
import re
from pathlib import Path

import numpy as np
import pytest

cl = pytest.importorskip("pyopencl")

from ppm_engine.render.device_scene import placeholders
from ppm_engine.scene import shading_tables as st
from ppm_engine.scene.arrays import (
    MATERIAL_DTYPE,
    NODE_DIFFUSE,
    NODE_FLAG_CONDUCTOR,
    NODE_GLASS,
    NODE_GLOSSY,
    NODE_METALLIC,
    NODE_PRINCIPLED,
    NODE_REFRACTION,
    NODE_SHEEN,
    NODE_TRANSLUCENT,
    NODE_TRANSPARENT,
    shader_node,
)
from ppm_engine.scene.light_paths import GATHER_ROUGHNESS, engine_defaults, with_roughness
from ppm_engine.scene.materials import kernel_materials, kernel_nodes
from ppm_engine.tools import make_shading_tables

KERNELS = Path(__file__).resolve().parents[1] / "kernels"
MASK_ALL = 3
CLOSURE_NAMES = {1: "diffuse", 2: "oren_nayar", 3: "translucent", 4: "sheen", 5: "ggx_reflect",
                 6: "ggx_refract", 7: "ggx_glass", 8: "transparent"}


@pytest.fixture(scope="module")
def device(pocl_key):
    from ppm_engine.render.device import get_device
    return get_device(pocl_key)


class Shading:
    """Materials of BSDF nodes on the device, and the closure_test.cl kernels on them."""

    def __init__(self, device, materials, defines=None, light_paths=None):
        self.device = device
        rows = []
        for k, nodes in enumerate(materials):
            rows += [shader_node(material=k, **n) for n in nodes]
        nodes = kernel_nodes(np.concatenate(rows))
        kmat = kernel_materials(np.zeros(len(materials), MATERIAL_DTYPE), nodes)
        up = device.upload
        tangent = np.tile(np.float32([1, 0, 0]), 3)       # the surface's tangent: +x
        # the materials at a point at the origin (closure_test.cl); no texture, no program
        self.args = placeholders(device, materials=up(kmat, "m"), shader_nodes=up(nodes, "n"),
                                 shading_tables=up(st.load(), "t"),
                                 uvs=up(np.zeros(6, np.float32), "uv"),
                                 tangents=up(tangent, "tangents"),
                                 **({} if light_paths is None else
                                    {"light_paths": up(light_paths, "light paths")}))
        self.prog = device.programs.get("test/closure_test.cl", defines)

    def sample(self, mat, wi, n, seed=1, mask=MASK_ALL):
        q = self.device.queue
        wo = cl.Buffer(self.device.context, cl.mem_flags.WRITE_ONLY, 16 * n)
        w = cl.Buffer(self.device.context, cl.mem_flags.WRITE_ONLY, 16 * n)
        self.prog.launch("shade_sample", "test")(
            q, n, 64, **self.args, mat=np.int32(mat), wi=np.float32([*wi, 0]),
            mask=np.int32(mask), seed=np.uint32(seed), out_wo=wo, out_weight=w, n=np.uint32(n))
        a, b = np.empty((n, 4), np.float32), np.empty((n, 4), np.float32)
        cl.enqueue_copy(q, a, wo)
        cl.enqueue_copy(q, b, w)
        return a, b

    def eval(self, mat, wi, wo, mask=MASK_ALL):
        q = self.device.queue
        n = len(wo)
        wo4 = np.zeros((n, 4), np.float32)
        wo4[:, :3] = wo
        out = cl.Buffer(self.device.context, cl.mem_flags.WRITE_ONLY, 16 * n)
        self.prog.launch("shade_eval", "test")(
            q, n, 64, **self.args, mat=np.int32(mat), wi=np.float32([*wi, 0]),
            mask=np.int32(mask), wo=self.device.upload(wo4, "wo"), out=out, n=np.uint32(n))
        r = np.empty((n, 4), np.float32)
        cl.enqueue_copy(q, r, out)
        return r

    def closures(self, mat, wi, n_max=16):
        q = self.device.queue
        info = cl.Buffer(self.device.context, cl.mem_flags.WRITE_ONLY, 16 * n_max)
        wgt = cl.Buffer(self.device.context, cl.mem_flags.WRITE_ONLY, 16 * (n_max + 2))
        self.prog.launch("shade_closures", "test")(
            q, 1, 1, **self.args, mat=np.int32(mat), wi=np.float32([*wi, 0]), out_info=info,
            out_weight=wgt, n_max=np.int32(n_max))
        a, b = np.empty((n_max, 4), np.float32), np.empty((n_max + 2, 4), np.float32)
        cl.enqueue_copy(q, a, info)
        cl.enqueue_copy(q, b, wgt)
        k = a[:, 0] >= 0
        return [dict(type=CLOSURE_NAMES[int(t)], gather=bool(g), sample_weight=float(sw),
                     glossy=bool(gl), weight=w[:3])
                for (t, g, sw, gl), w in zip(a[k], b[:n_max][k])]


def view(cos_theta):
    return (math.sqrt(1 - cos_theta ** 2), 0.0, cos_theta)


# --- the tables ---------------------------------------------------------------------------------
def test_table_layout_matches_the_kernel_header():
    text = (KERNELS / "shared.h").read_text()
    defs = dict(re.findall(r"#define TAB_(\w+) (\d+)", text))
    names = {"GGX_E": "ggx_E", "GGX_EAVG": "ggx_Eavg", "GLASS_E": "glass_E",
             "GLASS_EAVG": "glass_Eavg", "GLASS_INV_E": "glass_inv_E",
             "GLASS_INV_EAVG": "glass_inv_Eavg", "SCHLICK_IOR_S": "schlick_ior_s",
             "SCHLICK_S": "schlick_s", "SHEEN": "sheen"}
    assert {names[k]: int(v) for k, v in defs.items() if k != "SIZE"} == \
        {k: off for k, (off, _) in st.LAYOUT.items()}
    assert int(defs["SIZE"]) == st.SIZE == max(o + int(np.prod(s)) for o, s in st.LAYOUT.values())


def _lerp_mu(table, mu):
    return np.interp(mu, np.linspace(0, 1, table.shape[0]), table)


def test_ggx_albedo_table_known_values():
    """Single-scattering GGX albedo E(mu, roughness) by numerical quadrature
    (docs/SHADING.md): E(1, 1) = 0.3069, E(0.5, 1) = 0.4507, E(1, 0.5) = 0.9158; Eavg(1) = 0.409;
    a smooth surface keeps all its energy."""
    t = st.unpack(st.load())
    E = t["ggx_E"]                                  # [mu][rough]
    assert E[-1, -1] == pytest.approx(0.3069, abs=2e-3)
    assert _lerp_mu(E[:, -1], 0.5) == pytest.approx(0.4507, abs=3e-3)
    assert np.interp(0.5, np.linspace(0, 1, 32), E[-1]) == pytest.approx(0.9158, abs=6e-3)
    assert t["ggx_Eavg"][-1] == pytest.approx(0.409, abs=3e-3)
    assert E[:, 0] == pytest.approx(1.0, abs=1e-6)
    # smooth glass: reflection + refraction is all the light, whatever the angle and index
    assert t["glass_E"][:, :, 0] == pytest.approx(1.0, abs=1e-3)
    assert t["glass_inv_E"][:, :, 0] == pytest.approx(1.0, abs=1e-3)
    assert ((t["ggx_E"] > 0) & (t["ggx_E"] <= 1)).all()


@pytest.mark.slow
def test_shipped_ggx_tables_match_a_recomputation(device):
    """The tables in the package data are what kernels/closure/precompute.cl computes (fewer samples
    here: within their noise).  Slow (4.5 s of a cold default run): the tables change only with
    precompute.cl or the tool (ppm_engine/tools/make_shading_tables.py); the default run checks
    the shipped tables' known values by quadrature above."""
    fresh = make_shading_tables.compute(device, ["ggx_E", "glass_E", "schlick_ior_s"],
                                        samples=1 << 12)
    shipped = st.unpack(st.load())
    for name, a in fresh.items():
        np.testing.assert_allclose(a, shipped[name], atol=6e-3, err_msg=name)


# --- sampling against evaluation ----------------------------------------------------------------
MATERIALS = {
    "lambert": [dict(type=NODE_DIFFUSE, color=(0.7, 0.5, 0.3))],
    "oren_nayar": [dict(type=NODE_DIFFUSE, color=(0.8, 0.8, 0.8), roughness=0.8)],
    "translucent": [dict(type=NODE_TRANSLUCENT, color=(0.6, 0.6, 0.6))],
    "sheen": [dict(type=NODE_SHEEN, color=(1, 1, 1), roughness=0.4)],
    "glossy_ggx": [dict(type=NODE_GLOSSY, color=(1, 1, 1), roughness=0.3, flags=0)],
    "glossy_multi": [dict(type=NODE_GLOSSY, color=(0.9, 0.6, 0.3), roughness=0.6)],
    "metal_f82": [dict(type=NODE_METALLIC, roughness=0.4)],
    "conductor": [dict(type=NODE_METALLIC, roughness=0.5, flags=NODE_FLAG_CONDUCTOR | 1,
                       color=(0.2, 0.9, 1.1), edge_tint=(3.9, 2.4, 2.2))],
    "glass_rough": [dict(type=NODE_GLASS, roughness=0.4, ior=1.5)],
    "glass_rough_back": [dict(type=NODE_GLASS, roughness=0.35, ior=1 / 1.45)],
    "refraction": [dict(type=NODE_REFRACTION, roughness=0.5, ior=1.33)],
    "principled": [dict(type=NODE_PRINCIPLED, color=(0.8, 0.2, 0.1))],
    "principled_layers": [dict(type=NODE_PRINCIPLED, color=(0.5, 0.6, 0.7), metallic=0.3,
                               roughness=0.35, coat_weight=0.6, coat_roughness=0.2,
                               sheen_weight=0.5, sheen_tint=(1, 0.8, 0.6),
                               diffuse_roughness=0.5)],
    "principled_glass": [dict(type=NODE_PRINCIPLED, color=(0.9, 0.9, 0.7), transmission=1.0,
                              roughness=0.3)],
    "glossy_aniso": [dict(type=NODE_GLOSSY, roughness=0.5, anisotropic=0.8, flags=0,
                          anisotropic_rotation=0.1)],
    "principled_aniso": [dict(type=NODE_PRINCIPLED, metallic=1.0, roughness=0.5,
                              anisotropic=0.7)],
    "mix": [dict(type=NODE_DIFFUSE, color=(0.9, 0.9, 0.9), weight=0.4),
            dict(type=NODE_GLOSSY, color=(1, 1, 1), roughness=0.2, weight=0.6)],
}


@pytest.fixture(scope="module")
def shading(device):
    return Shading(device, list(MATERIALS.values()))


def _mat(name):
    return list(MATERIALS).index(name)


def _sphere_grid(n_cos=24, n_phi=24, sub=12):
    """Bins over the sphere in (cos theta, phi) and sub x sub quadrature points each."""
    c = (np.arange(n_cos * sub) + 0.5) / (n_cos * sub) * 2 - 1
    p = (np.arange(n_phi * sub) + 0.5) / (n_phi * sub) * 2 * np.pi
    C, P = np.meshgrid(c, p, indexing="ij")
    s = np.sqrt(1 - C ** 2)
    dirs = np.stack([s * np.cos(P), s * np.sin(P), C], -1).reshape(-1, 3)
    d_omega = (2 / (n_cos * sub)) * (2 * np.pi / (n_phi * sub))
    return dirs, d_omega


def _chi2_sf(x, k):
    """P(chi-square with k degrees of freedom > x): the regularised upper incomplete gamma."""
    a, z = k / 2.0, x / 2.0
    if z < a + 1:                                    # series for P, then 1 - P
        term = total = 1.0 / a
        for n in range(1, 1000):
            term *= z / (a + n)
            total += term
            if term < total * 1e-15:
                break
        return max(0.0, 1.0 - total * math.exp(-z + a * math.log(z) - math.lgamma(a)))
    b, c, d = z + 1 - a, 1e300, 1 / (z + 1 - a)      # continued fraction for Q (Lentz)
    h = d
    for i in range(1, 1000):
        an = -i * (i - a)
        b += 2
        d = an * d + b
        d = 1 / d if abs(d) > 1e-300 else 1e300
        c = b + an / c if abs(c) > 1e-300 else b + an * 1e300
        h *= d * c
        if abs(d * c - 1) < 1e-15:
            break
    return math.exp(-z + a * math.log(z) - math.lgamma(a)) * h


@pytest.mark.parametrize("name", list(MATERIALS))
@pytest.mark.parametrize("cos_view", [0.85, 0.35])
def test_sampled_directions_follow_the_pdf(shading, name, cos_view):
    """Chi-square of the sampled directions (24 x 24 bins in cos theta, phi) against the
    pdf integrated over each bin, and every sample's weight equal to f cos / pdf evaluated
    again at its direction."""
    if name == "sheen" and not (st.unpack(st.load())["sheen"][2] > 0).any():
        pytest.skip("no sheen table")
    wi = view(cos_view)
    n = 1 << 18
    wo, w = shading.sample(_mat(name), wi, n)
    ok = wo[:, 3] > 0
    assert ok.mean() > 0.5
    assert np.isfinite(wo[ok, 3]).all()            # no singular lobe here
    again = shading.eval(_mat(name), wi, wo[ok, :3])
    np.testing.assert_allclose(again[:, 3], wo[ok, 3], rtol=2e-3, atol=1e-6)
    np.testing.assert_allclose(w[ok, :3], again[:, :3] / again[:, 3:4], rtol=3e-3, atol=1e-6)
    # histogram against the integrated pdf
    n_cos = n_phi = 24
    cosb = np.clip(((wo[ok, 2] + 1) / 2 * n_cos).astype(int), 0, n_cos - 1)
    phib = np.clip((np.mod(np.arctan2(wo[ok, 1], wo[ok, 0]), 2 * np.pi) / (2 * np.pi)
                    * n_phi).astype(int), 0, n_phi - 1)
    observed = np.bincount(cosb * n_phi + phib, minlength=n_cos * n_phi).astype(float)
    dirs, d_omega = _sphere_grid(n_cos, n_phi)
    pdf = shading.eval(_mat(name), wi, dirs)[:, 3].reshape(n_cos, 12, n_phi, 12)
    expected = pdf.sum(axis=(1, 3)).ravel() * d_omega * n
    assert expected.sum() == pytest.approx(ok.sum(), rel=0.02)     # the pdf's mass: P(sample)
    keep = expected > 20
    assert observed[~keep].sum() <= max(100, 0.01 * n)           # nothing where the pdf is not
    chi2 = float(((observed[keep] - expected[keep]) ** 2 / expected[keep]).sum())
    p = _chi2_sf(chi2, int(keep.sum()) - 1)
    assert p > 1e-4, (chi2, int(keep.sum()))


def test_smooth_glass_picks_reflection_by_fresnel(device):
    """A smooth glass closure: two directions only, reflection with probability F (the Glass
    BSDF's Fresnel), the refracted one by Snell's law; the weight of each is 1 (R / P(R))."""
    s = Shading(device, [[dict(type=NODE_GLASS, roughness=0.0, ior=1.5)]])
    cos_i = 0.6
    wi = view(cos_i)
    wo, w = s.sample(0, wi, 20000)
    assert np.isinf(wo[:, 3]).all()
    refl = wo[:, 2] > 0
    sin_t = math.sqrt(1 - cos_i ** 2) / 1.5
    cos_t = math.sqrt(1 - sin_t ** 2)
    rs = (cos_i - 1.5 * cos_t) / (cos_i + 1.5 * cos_t)
    rp = (1.5 * cos_i - cos_t) / (1.5 * cos_i + cos_t)
    F = 0.5 * (rs * rs + rp * rp)
    assert refl.mean() == pytest.approx(F, abs=4 * math.sqrt(F * (1 - F) / 20000))
    np.testing.assert_allclose(wo[refl, :3], np.broadcast_to([-wi[0], 0, cos_i], (refl.sum(), 3)),
                               atol=1e-5)
    np.testing.assert_allclose(wo[~refl, :3],
                               np.broadcast_to([-sin_t, 0, -cos_t], ((~refl).sum(), 3)), atol=1e-5)
    np.testing.assert_allclose(w[:, :3], 1.0, rtol=1e-5)


# --- white furnaces: a closure's albedo by its own samples --------------------------------------
def _albedo(shading, mat, cos_view, n=1 << 18):
    _wo, w = shading.sample(mat, view(cos_view), n)
    return w[:, :3].sum(axis=0) / n


@pytest.mark.parametrize("rough", [0.1, 0.4, 0.7, 1.0])
def test_multiscatter_white_metal_keeps_all_energy(device, rough):
    """Multiscatter GGX (Cycles' albedo scaling) on a white metal: albedo 1 at every angle and
    roughness (to the table's accuracy); single-scatter GGX loses E(mu, r) of it."""
    s = Shading(device, [[dict(type=NODE_METALLIC, color=(1, 1, 1), edge_tint=(1, 1, 1),
                               roughness=rough)],
                         [dict(type=NODE_GLOSSY, color=(1, 1, 1), roughness=rough, flags=0)]])
    t = st.unpack(st.load())["ggx_E"]
    for c in (0.95, 0.5, 0.2):
        assert _albedo(s, 0, c) == pytest.approx(1.0, abs=0.012)
        E = _table2(t, rough, c)
        assert _albedo(s, 1, c)[0] == pytest.approx(E, rel=0.01, abs=0.004)


def _table2(t, x, y):
    """Cycles' 2-D lookup (x fastest) of a [y][x] table, in NumPy."""
    ny, nx = t.shape
    xs = np.linspace(0, 1, nx)
    rows = np.array([np.interp(x, xs, r) for r in t])
    return float(np.interp(y, np.linspace(0, 1, ny), rows))


@pytest.mark.parametrize("name,nodes,expect", [
    ("lambert", [dict(type=NODE_DIFFUSE, color=(1, 1, 1))], 1.0),
    ("oren_nayar", [dict(type=NODE_DIFFUSE, color=(1, 1, 1), roughness=1.0)], 1.0),
    ("dielectric_over_white", [dict(type=NODE_PRINCIPLED, color=(1, 1, 1), roughness=0.4)], 1.0),
    ("coat_over_white", [dict(type=NODE_PRINCIPLED, color=(1, 1, 1), roughness=0.6,
                              coat_weight=1.0, coat_roughness=0.2)], 1.0),
    ("glass_multi", [dict(type=NODE_GLASS, roughness=0.5, ior=1.5)], 1.0),
    ("principled_glass", [dict(type=NODE_PRINCIPLED, color=(1, 1, 1), transmission=1.0,
                               roughness=0.5)], 1.0),
    ("transparent", [dict(type=NODE_TRANSPARENT, color=(1, 1, 1))], 1.0),
])
def test_white_furnace_per_closure(device, name, nodes, expect):
    """Energy-conserving configurations reflect + transmit all the light (docs/SHADING.md:
    the layering's albedo scaling keeps a white Principled at 1 within ~1 % of table error)."""
    s = Shading(device, [nodes])
    for c in (0.9, 0.5, 0.25):
        assert _albedo(s, 0, c) == pytest.approx(expect, abs=0.015), c


# --- the Principled BSDF's layers ---------------------------------------------------------------
def test_principled_layers_as_cycles_orders_them(device):
    """Alpha first (transparent 1 - alpha), then sheen, coat, metal, glass, the specular
    layer and the diffuse base; metal and glass are mixes (weights metallic, (1 - M) T), the
    base closures scaled by the layers above."""
    s = Shading(device, [[dict(type=NODE_PRINCIPLED, color=(0.5, 0.5, 0.5), alpha=0.75,
                               sheen_weight=0.5, coat_weight=0.5, metallic=0.4,
                               transmission=0.5, roughness=0.3)]])
    got = s.closures(0, view(0.8))
    assert [c["type"] for c in got] == ["transparent", "sheen", "ggx_reflect", "ggx_reflect",
                                        "ggx_glass", "ggx_reflect", "diffuse"]
    np.testing.assert_allclose(got[0]["weight"], 0.25, rtol=1e-6)
    w_metal, w_glass = got[3]["weight"][0], got[4]["weight"][0]
    # metal M w, glass (1 - M) T w (before their own energy compensation, about 1 here)
    assert w_glass / w_metal == pytest.approx((1 - 0.4) * 0.5 / 0.4, rel=0.05)


@pytest.mark.parametrize("caustic_roughness", [None, 0.2])
def test_closures_split_into_gathered_glossy_and_caustic(device, caustic_roughness):
    """Whose each closure's light is (kernels/closure/shader.h): diffuse closures and lobes at least
    LightPaths.gather_roughness (0.7) rough are gathered; the followed glossy reflections at
    least LightPaths.caustic_roughness rough (here 0.2; by default the gather's roughness:
    none) are the eye paths' (next-event estimation through them,
    kernels/integrator/indirect_paths.h); mirrors, smoother reflections and every refraction
    below the gather's roughness make caustic photons."""
    mats = [[dict(type=NODE_PRINCIPLED, metallic=1.0, roughness=0.3)],
            [dict(type=NODE_PRINCIPLED, metallic=1.0, roughness=0.1)],
            [dict(type=NODE_PRINCIPLED, metallic=1.0, roughness=0.8)],
            [dict(type=NODE_PRINCIPLED, transmission=1.0, roughness=0.3)],
            [dict(type=NODE_PRINCIPLED, color=(0.5, 0.5, 0.5), roughness=0.5, coat_weight=1.0,
                  coat_roughness=0.05)],
            [dict(type=NODE_GLOSSY, roughness=0.2)]]
    lp = None if caustic_roughness is None else with_roughness(
        engine_defaults(), GATHER_ROUGHNESS, caustic_roughness)
    s = Shading(device, mats, light_paths=lp)
    got = [[(c["type"], c["gather"], c["glossy"]) for c in s.closures(m, view(0.8))]
           for m in range(len(mats))]
    g = caustic_roughness is not None
    assert got == [[("ggx_reflect", False, g)],
                   [("ggx_reflect", False, False)],
                   [("ggx_reflect", True, False)],
                   [("ggx_glass", False, False)],
                   [("ggx_reflect", False, False), ("ggx_reflect", False, g),
                    ("diffuse", True, False)],
                   [("ggx_reflect", False, g)]]


def test_ior_level_zero_leaves_plain_lambert(device):
    """Specular IOR Level 0: no specular layer, the Principled is Lambert(base) exactly."""
    s = Shading(device, [[dict(type=NODE_PRINCIPLED, color=(0.6, 0.4, 0.2),
                               specular_ior_level=0.0)]])
    got = s.closures(0, view(0.7))
    assert [c["type"] for c in got] == ["diffuse"]
    np.testing.assert_allclose(got[0]["weight"], (0.6, 0.4, 0.2), rtol=1e-6)


def test_mix_weights_scale_closures(device):
    s = Shading(device, [MATERIALS["mix"]])
    got = s.closures(0, view(0.7))
    assert [c["type"] for c in got] == ["diffuse", "ggx_reflect"]
    np.testing.assert_allclose(got[0]["weight"], 0.36, rtol=1e-6)


def test_anisotropy_stretches_the_lobe_as_cycles_defines_it(device):
    """At normal incidence, tangent +x: the Principled BSDF's anisotropy 0.8 stretches the lobe
    along the tangent (alpha_x = alpha / sqrt(1 - 0.9 x 0.8)), the Glossy BSDF's across it
    (alpha_x = alpha (1 - 0.8), alpha_y = alpha / (1 - 0.8)); rotation 0.25 turns the tangent
    to +y; no anisotropy is round."""
    s = Shading(device, [[dict(type=NODE_PRINCIPLED, metallic=1.0, roughness=0.4,
                               anisotropic=0.8)],
                         [dict(type=NODE_PRINCIPLED, metallic=1.0, roughness=0.4,
                               anisotropic=0.8, anisotropic_rotation=0.25)],
                         [dict(type=NODE_GLOSSY, roughness=0.4, anisotropic=0.8, flags=0)],
                         [dict(type=NODE_GLOSSY, roughness=0.4, flags=0)]])
    spread = []
    for mat in range(4):
        wo, _ = s.sample(mat, (0.0, 0.0, 1.0), 1 << 16)
        ok = wo[:, 3] > 0
        spread.append(np.abs(wo[ok, 0]).mean() / np.abs(wo[ok, 1]).mean())
    principled, rotated, glossy, round_ = spread
    assert principled > 1.5 and rotated < 1 / 1.5 and glossy < 1 / 3
    assert round_ == pytest.approx(1.0, abs=0.03)
