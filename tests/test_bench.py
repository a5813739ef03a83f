"""``python -m ppm_engine bench --quick`` (what CI runs of the benchmark): the error-against-
time run, the micro benchmarks and the phase breakdown run end to end and write well-formed
JSON, the plot and the markdown tables.  The full run is not part of CI (docs/BENCHMARKS.md)."""
import importlib.util
import json
import math
import re

import numpy as np
import pytest

from ppm_engine.tools.bench.curves import CAUSTIC_SCENES, MERGE_SCENES, QUICK, SCENES
from ppm_engine.tools.bench.scoring import FIREFLY_MARGIN, brightest, fireflies

pytest.importorskip("OpenEXR")
pytest.importorskip("matplotlib")

pytestmark = pytest.mark.bench


def _finite_numbers(obj):
    if isinstance(obj, dict):
        for v in obj.values():
            yield from _finite_numbers(v)
    elif isinstance(obj, list):
        for v in obj:
            yield from _finite_numbers(v)
    elif isinstance(obj, float):
        yield obj


def test_firefly_check_counts_the_pixels_brighter_than_the_reference_s_range():
    img = np.zeros((4, 5, 3), np.float32)
    img[1, 2] = (10.0, 0.0, 0.0)            # luminance 2.126
    img[3, 4] = (0.0, 0.0, 100.0)           # luminance 7.22, outside the pixels measured
    img[0, 0] = (1.0, 1.0, 1.0)             # luminance 1
    pixels = np.ones((4, 5), bool)
    pixels[3, 4] = False
    assert brightest(img, pixels) == pytest.approx(2.126)
    assert fireflies(img, pixels, 1.5) == {"brightest": pytest.approx(2.126),
                                           "over_reference_range": 1}
    assert fireflies(img, pixels, 0.5)["over_reference_range"] == 2
    assert fireflies(img, np.ones((4, 5), bool), 2.2)["over_reference_range"] == 1
    assert math.isnan(brightest(img, np.zeros((4, 5), bool)))


# the default tier's quick run: the JSON, plot and tables, the ratios and the firefly check,
# with a Cycles reference and its light-tracing check (the bulb box renders in test_e2e.py);
# the slow tier runs every reference and check (the exact sphere's, MNEE's and the merge's
# curves, the closed form's, LuxCore's light tracer or its fallback, the photons' curve): the
# ten below, and all eighteen
QUICK_SCENES = ("cornell_box",)
CHECK_SCENES = ("cornell_box", "furnace", "bulb_box", "glass_caustic", "point_caustic",
                "rough_caustic", "mirror_caustic", "pool_caustic", "many_lights", "fog_lens")


def test_bench_quick_writes_json_plot_and_table(cli_here, tmp_path):
    _quick_bench(cli_here, tmp_path, QUICK_SCENES)


@pytest.mark.slow
def test_bench_quick_checks_every_kind_of_reference(cli, tmp_path):
    _quick_bench(cli, tmp_path, CHECK_SCENES)


@pytest.mark.slow
def test_bench_quick_renders_every_bench_scene(cli, tmp_path):
    assert set(QUICK_SCENES) < set(CHECK_SCENES) < set(SCENES)
    _quick_bench(cli, tmp_path, SCENES)


def _quick_bench(cli, tmp_path, scenes):
    md = tmp_path / "B.md"
    md.write_text("# head\n\n<!-- bench:curves -->\nold\n<!-- /bench:curves -->\n\ntail\n")
    p = cli("bench", "--quick", "--json", tmp_path / "b.json", "--plot", tmp_path / "p.png",
            "--markdown", md, *(("--scenes", *scenes) if scenes != SCENES else ()),
            timeout=900)
    assert p.returncode == 0, p.stderr
    res = json.loads((tmp_path / "b.json").read_text())
    luxcore_installed = importlib.util.find_spec("pyluxcore") is not None
    assert list(res["scenes"]) == list(scenes)
    assert set(SCENES) == {"cornell_box", "furnace", "bulb_box", "glass_caustic",
                           "point_caustic", "rough_caustic", "far_caustic", "lifted_caustic",
                           "mirror_caustic",
                           "pool_caustic", "many_lights", "hdri_sun", "glossy_metal",
                           "clamped_caustic", "sun_cone", "fog_lens", "fog_room", "smoke"}
    if "many_lights" in scenes:
        tree = res["scenes"]["many_lights"]["light_tree"]
        assert tree["emitters"] == 308 + 2 * 1500 and tree["nodes"] == 2 * tree["emitters"] - 1
        assert 0 < tree["share"] <= 1 and tree["bytes"] > 64 * tree["nodes"]
    for name, s in res["scenes"].items():
        curves = {"ours", "ours_photons", "cycles"} | (
            {"cycles_mnee"} if name in CAUSTIC_SCENES else set()) | (
            {"ours_merge"} if name in MERGE_SCENES else set())
        if name == "mirror_caustic":          # LuxCore's curve where pyluxcore is installed
            if luxcore_installed:
                curves.add("luxcore_bidir")
            else:
                assert "pyluxcore" in s["luxcore"]
        assert set(s["curves"]) == curves
        ref = s["reference"]
        for rows in s["curves"].values():
            assert [r["seconds"] for r in rows] == res["times"]
            for r in rows:
                e = r["image"]
                assert e["rmse"] > 0 and e["pixels"] > 0        # no render equals the reference
                # the derived figures follow from the measured ones
                assert e["rel_rmse"] == pytest.approx(e["rmse"] / ref["mean"], rel=1e-6)
                assert e["rmse_corrected"] == pytest.approx(
                    math.sqrt(max(e["rmse"] ** 2 - ref["noise_rmse"] ** 2, 0.0)), abs=1e-9)
                assert r["wall_s"] >= r["seconds"] * 0.5
        # two halves rendered with different seeds differ: the reference has measured noise
        # (the furnace's is its closed form: none)
        assert (ref["noise_rmse"] > 0) == (name != "furnace") and ref["mean"] > 0
        assert ref["noise_rel_rmse"] == pytest.approx(ref["noise_rmse"] / ref["mean"], rel=1e-6)
        # the references agree with each other: Cycles' longest render is no more than a few
        # tens of percent off ours in mean, even at 16x16 and one second (but in the pool,
        # whose caustic Cycles' paths find only by chance: there its mean is its fireflies')
        if name != "pool_caustic":
            assert 0.7 < s["bias_check"]["cycles_longest_mean_over_reference"] < 1.3
        ours = s["curves"]["ours"]
        assert ours[-1]["passes"] >= ours[0]["passes"] >= 1
        # the estimator each render used, from its stats line: the default's choice per scene
        # (no caustic in the furnace or the Cornell box: paths; the bulb in glass and the pool's
        # floor under water: photons), and the paper's photons in the curve that forces them
        assert {r["indirect"] for r in ours} == {
            "photons" if name in ("bulb_box", "pool_caustic") else "paths"}
        assert {r["indirect"] for r in s["curves"]["ours_photons"]} == {"photons"}
        # references independent of the engine measured: Cycles, the closed form, the exact
        # sphere, LuxCore's light tracer (which, as light tracing, leaves out the pixels it
        # cannot render), or this engine's light tracer where LuxCore's spot differs
        # (glass_caustic) or pyluxcore is not installed (the JSON says so)
        engine = {"cornell_box": "CYCLES", "furnace": "ANALYTIC", "many_lights": "CYCLES",
                  "hdri_sun": "CYCLES", "glossy_metal": "CYCLES", "clamped_caustic": "CYCLES",
                  "sun_cone": "CYCLES", "fog_room": "CYCLES", "smoke": "CYCLES",
                  "point_caustic": "EXACT",
                  "rough_caustic": "EXACT", "far_caustic": "EXACT",
                  "pool_caustic": "EXACT_POOL"}.get(name, "LIGHT_TRACE")
        if name in ("bulb_box", "mirror_caustic"):
            if luxcore_installed:
                engine = "LUXCORE_LIGHT"
                assert "fallback" not in ref
            else:
                assert ref["fallback"]["engine"] == "LUXCORE_LIGHT"
                assert "pyluxcore" in ref["fallback"]["reason"]
        assert ref["engine"] == engine
        if name == "furnace":
            assert ref["mean"] == pytest.approx(1.0)        # E / (1 - albedo) = 0.5 / 0.5
        elif name in ("point_caustic", "rough_caustic", "far_caustic"):
            # the exact reference renders every pixel, the ball's too: none left out
            assert s["excluded_pixels"] == 0
        elif name not in ("cornell_box", "many_lights", "hdri_sun", "glossy_metal",
                          "clamped_caustic", "sun_cone", "fog_room", "smoke",
                          "pool_caustic"):
            # (Cycles' leave none out, nor does the pool's, which sees the floor in every pixel)
            # (the light tracer's leave out what it cannot render: at 16 x 16 the filter's
            # reach is a large share)
            assert 0 < s["excluded_pixels"] < 0.75 * 256
    check = res["scenes"]["cornell_box"]["light_trace_check"]
    assert check["passes"] >= 1 and 0.7 < check["mean_over_reference"] < 1.3
    assert check["reference"] == "CYCLES" and "caustic_rmse" not in check
    if "point_caustic" in scenes:
        # point_caustic: the mesh ball's light tracing against the exact sphere's reference
        check = res["scenes"]["point_caustic"]["light_trace_check"]
        assert check["reference"] == "EXACT" and check["passes"] >= 1
        assert 0.9 < check["mean_over_reference"] < 1.1
        if "caustic_pixels" in check:   # (at 16 x 16 the mesh's coverage may leave it none)
            assert check["caustic_pixels"] > 0 and check["focus_reference"] > 0
        assert res["scenes"]["point_caustic"]["reference"]["seconds_per_half"] == \
            QUICK["ref_seconds"]
    # this engine's light tracer against LuxCore's, where that is the reference
    for name in {"bulb_box", "mirror_caustic"} & set(scenes):
        check = res["scenes"][name].get("light_trace_check")
        assert (check is not None) == luxcore_installed
        if check:
            assert check["reference"] == "LUXCORE_LIGHT" and check["passes"] >= 1
            assert 0.8 < check["mean_over_reference"] < 1.25
    if "glass_caustic" in scenes:
        assert "light_trace_check" not in res["scenes"]["glass_caustic"]
    if "clamped_caustic" in scenes:
        # rendered with its clamp, every curve and its reference; no light-tracing check (light
        # tracing renders the unclamped image)
        s = res["scenes"]["clamped_caustic"]
        assert s["light_paths"] == {"sample_clamp_direct": 100.0, "sample_clamp_indirect": 100.0}
        assert "light_trace_check" not in s
    if "pool_caustic" in scenes:
        # the pool: no light tracing renders a floor seen through water
        assert "light_trace_check" not in res["scenes"]["pool_caustic"]
        # (the quick run gives every reference the same second; REF_TIME_FACTOR is the full
        # run's)
        assert res["scenes"]["pool_caustic"]["reference"]["seconds_per_half"] == \
            QUICK["ref_seconds"]
    assert all(math.isfinite(x) for x in _finite_numbers(res))
    assert set(res["ratios"]["cornell_box"]) >= {"image_rmse", "target", "met"}
    eq = res["ratios_at"]
    for name, r in res["ratios"].items():          # ours / Cycles at the equal-time budget
        c = res["scenes"][name]["curves"]
        at = res["times"].index(eq)
        assert r["image_rmse"] == pytest.approx(
            c["ours"][at]["image"]["rmse"] / c["cycles"][at]["image"]["rmse"], rel=1e-6)
        # the targets' ratio: the mean RMSE over the seeds of ours and Cycles at that budget
        o, cy = c["ours"][at], c["cycles"][at]
        assert o["seeds"] == cy["seeds"] == [1, 2, 3]
        assert len(set(o["image_rmse_seeds"])) == 3
        assert o["image_rmse_seeds"][0] == o["image"]["rmse"]
        assert o["passes_seeds"][0] == o["passes"] and min(o["passes_seeds"]) >= 1
        assert "passes_seeds" not in cy
        assert r["image_rmse_seeds"] == pytest.approx(
            np.mean(o["image_rmse_seeds"]) / np.mean(cy["image_rmse_seeds"]), rel=1e-6)
        assert "seeds" not in c["ours"][0] and "seeds" not in c["ours_photons"][at]
        if "target" in r:
            assert r["met"] == (r["image_rmse_seeds"] <= r["target"])
        elif "target_best_peer" in r:     # ahead of the better of Cycles and Cycles + MNEE
            best = min(c["cycles"][at]["image"]["rmse"], c["cycles_mnee"][at]["image"]["rmse"])
            assert r["image_rmse_vs_best_peer"] == pytest.approx(
                c["ours"][at]["image"]["rmse"] / best, rel=1e-6)
            assert r["met"] == (r["image_rmse_vs_best_peer"] <= r["target_best_peer"])
        elif "target_mnee" in r:
            assert r["met"] == (r["image_rmse_vs_mnee"] <= r["target_mnee"])
        # the firefly check: the brightest pixels of ours and Cycles at that budget (over the
        # seeds) against the reference's range (the brighter half's brightest pixel)
        ref, b = res["scenes"][name]["reference"], r["brightest"]
        assert 0 < ref["brightest"] <= ref["brightest_half"] == b["reference_range"]
        ceiling = b["firefly_ceiling"]
        assert ceiling == ref["firefly_ceiling"] == pytest.approx(
            FIREFLY_MARGIN * ref["brightest_half"])
        assert b["ours"] == max(o["brightest_seeds"]) >= o["brightest"] > 0
        assert b["cycles"] == max(cy["brightest_seeds"]) >= cy["brightest"] > 0
        assert b["ours_over_range"] == sum(o["over_reference_range_seeds"])
        assert (b["ours_over_range"] > 0) == (b["ours"] > ceiling)
        assert (b["cycles_over_range"] > 0) == (b["cycles"] > ceiling)
        assert r["no_firefly"] == (b["ours"] <= max(ceiling, b["cycles"]))
    if "glass_caustic" in scenes:
        assert "target_mnee" in res["ratios"]["glass_caustic"]
    if "rough_caustic" in scenes:
        assert "target_best_peer" in res["ratios"]["rough_caustic"]
    assert (tmp_path / "p.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    text = md.read_text()
    assert text.startswith("# head") and text.rstrip().endswith("tail") and "old" not in text
    assert "| cornell_box |" in text and "RMSE ours/Cycles" in text
    # the tables again from the JSON alone: the same block, headed by the run's command
    md2 = tmp_path / "B2.md"
    md2.write_text("<!-- bench:curves -->\n<!-- /bench:curves -->\n")
    p = cli("bench", "--report", tmp_path / "b.json", "--plot", tmp_path / "p2.png",
            "--markdown", md2)
    assert p.returncode == 0, p.stderr
    block = text[text.index("<!-- bench:curves -->"):text.index("<!-- /bench:curves -->")]
    assert md2.read_text().startswith(block)
    # without --markdown the full run's tables go to their own page, not into BENCHMARKS.md
    p = cli("bench", "--report", tmp_path / "b.json", "--out", tmp_path / "o")
    assert p.returncode == 0, p.stderr
    full = (tmp_path / "o" / "bench" / "full_run.md").read_text()
    assert full.startswith("# The benchmark's full run") and block in full
    assert not (tmp_path / "o" / "BENCHMARKS.md").exists()
    p = cli("bench", "--report", tmp_path / "p.png")
    assert p.returncode == 2 and "cannot read the benchmark JSON" in p.stderr


@pytest.mark.slow             # tooling: 20 s of the default run
def test_bench_micro_and_phases_quick(cli, tmp_path):
    md = tmp_path / "B.md"
    p = cli("bench", "--micro", "--quick", "--json", tmp_path / "m.json", "--markdown", md)
    assert p.returncode == 0, p.stderr
    m = json.loads((tmp_path / "m.json").read_text())
    text = md.read_text()
    assert "<!-- bench:micro -->" in text and "hash build" in text and "paper" in text
    assert all(math.isfinite(x) and x >= 0 for x in _finite_numbers(m))
    for h in m["hash"]:               # every occupied entry holds at least one photon
        assert h["photons_per_entry"] >= 1 and h["hash_build_ms"] > 0 and h["gather_ms"] > 0
        assert h["hash_build_ns_per_photon"] == pytest.approx(
            h["hash_build_ms"] * 1e6 / h["photons"], rel=1e-9)
    p = cli("bench", "--phases", "bulb_box", "--quick", "--json", tmp_path / "ph.json",
            "--markdown", md)
    assert p.returncode == 0, p.stderr
    ph = json.loads((tmp_path / "ph.json").read_text())
    assert set(ph["phase_ms"]) == {"eye", "grid", "photon", "hash", "gather", "update"}
    assert ph["device_ms"] == pytest.approx(sum(ph["phase_ms"].values()))
    assert "<!-- bench:phases -->" in md.read_text()


@pytest.mark.slow             # tooling: 19 s of the default run
def test_bench_strategies_quick(cli, tmp_path):
    """``bench --strategies``: each photon scene's image split by strategy; the shares add up
    to the whole, and the photons' light tracing brings part of the mirror's caustic (not all:
    the merge has its side of the balance heuristic)."""
    md = tmp_path / "B.md"
    p = cli("bench", "--strategies", "--quick", "--scenes", "mirror_caustic", "point_caustic",
            "--json", tmp_path / "st.json", "--markdown", md)
    assert p.returncode == 0, p.stderr
    st = json.loads((tmp_path / "st.json").read_text())
    assert set(st["scenes"]) == {"mirror_caustic", "point_caustic"}
    assert "<!-- bench:strategies -->" in md.read_text()
    for row in st["scenes"].values():
        assert row["light_tracing"] and row["passes"] >= 1
        for region in ("image", "caustic"):
            r = row[region]
            assert r["camera paths"] + r["merge"] + r["light tracing"] == pytest.approx(1.0)
            assert 0 < r["light tracing"] < 1 and 0 < r["merge"] < 1
    assert 0.05 < st["scenes"]["mirror_caustic"]["caustic"][
        "light tracing of the photons' light"] < 0.999


@pytest.mark.slow             # tooling: a fresh process with Blender
def test_bench_denoise_quick(cli, tmp_path):
    """``bench --denoise``: ours and Cycles, noisy and denoised (the Noisy Image pass of one
    render each), against the reference, in the JSON and the markdown block."""
    from ppm_engine.render.denoise import unavailable
    if unavailable() is not None:
        pytest.skip(unavailable())
    md = tmp_path / "B.md"
    p = cli("bench", "--denoise", "--quick", "--json", tmp_path / "d.json", "--markdown", md)
    assert p.returncode == 0, p.stderr
    d = json.loads((tmp_path / "d.json").read_text())
    assert "<!-- bench:denoise -->" in md.read_text()
    (e,) = d["scenes"]["cornell_box"]["budgets"]
    for engine in ("ours", "cycles"):
        assert 0 < e[engine]["noisy"] < 1 and 0 < e[engine]["denoised"] < 1
        assert e[engine]["noisy"] != e[engine]["denoised"]
    assert e["ours"]["denoise_s"] > 0


@pytest.mark.slow             # tooling: 15-19 s of the default run (the skips: test_skips.py)
def test_bench_skips_quick(cli, tmp_path):
    md = tmp_path / "B.md"
    p = cli("bench", "--skips", "--quick", "--json", tmp_path / "s.json", "--markdown", md)
    assert p.returncode == 0, p.stderr
    rows = json.loads((tmp_path / "s.json").read_text())["rows"]
    skips = {r["skip"] for r in rows}
    for word in ("specialisation", "emits", "photon pass", "photons nobody", "converged",
                 "nothing changed", "settings", "moved", "hidden", "never runs",
                 "no pixel sees"):
        assert any(word in k for k in skips), word
    assert all(r["with"] >= 0 and r["without"] > 0 for r in rows)
    assert all(r["saving"] == pytest.approx(1 - r["with"] / r["without"]) for r in rows)
    outside = next(r for r in rows if "photons nobody" in r["skip"])
    share = int(re.match(r"(\d+) % of the photons land outside", outside["note"])[1])
    assert share > 50                  # the corner view: most photons are not stored
    dark = next(r for r in rows if "emits" in r["skip"])
    assert dark["with"] < 0.1 * dark["without"]          # no device work at all
    lazy = next(r for r in rows if "never runs" in r["skip"])
    assert lazy["without"] > lazy["with"] > 0            # the two builds cost something
    blind = next(r for r in rows if "no pixel sees" in r["skip"])
    assert blind["note"] == "light tracing after the first pass: False vs True"
    assert "<!-- bench:skips -->" in md.read_text()


@pytest.mark.slow             # tooling: 15 s of the default run
def test_bench_glossy_quick(cli, tmp_path):
    """bench --glossy: ours per gather roughness (two seeds) and Cycles at the same budget,
    against a longer Cycles render; the table follows from the JSON."""
    md = tmp_path / "B.md"
    p = cli("bench", "--glossy", "--quick", "--json", tmp_path / "g.json", "--markdown", md)
    assert p.returncode == 0, p.stderr
    g = json.loads((tmp_path / "g.json").read_text())
    assert [r["gather_roughness"] for r in g["ours"]] == [0.35, 1.5]
    assert g["cycles"] > 0 and g["mean"] > 0
    for r in g["ours"]:
        assert len(r["rmse"]) == 2 and all(0 < e < 2 * g["mean"] for e in r["rmse"])
        assert all(n >= 2 for n in r["passes"])
    text = md.read_text()
    assert "<!-- bench:glossy -->" in text
    for r in g["ours"]:
        assert f"| {r['gather_roughness']:g} | {r['rmse'][0]:.4f}, {r['rmse'][1]:.4f} |" in text


def test_bench_noise_quick(cli, tmp_path):
    """bench --noise: both engines at the same samples per pixel over two seeds; the two see the
    same image (means within a few percent even at 16x16 and 8 samples), the noise splits into
    the bright pixels' and the rest's, and the ratios follow from the figures."""
    md = tmp_path / "B.md"
    p = cli("bench", "--noise", "cornell_box", "--quick", "--json", tmp_path / "n.json",
            "--markdown", md)
    assert p.returncode == 0, p.stderr
    d = json.loads((tmp_path / "n.json").read_text())
    assert (d["passes"], d["seeds"], d["resolution"]) == (8, 2, 16)
    o, c = d["engines"]["PPM"], d["engines"]["CYCLES"]
    assert o["mean"] == pytest.approx(c["mean"], rel=0.1)
    for e in (o, c):
        assert e["noise_rms"] > 0
        assert e["noise_rms"] ** 2 == pytest.approx(
            e["noise_rms_bright"] ** 2 + e["noise_rms_rest"] ** 2, rel=1e-6)
    assert d["ratio_noise"] == pytest.approx(o["noise_rms"] / c["noise_rms"], rel=1e-6)
    assert d["implied_equal_time_ratio"] == pytest.approx(
        d["ratio_noise"] / math.sqrt(o["samples_per_s"] / c["samples_per_s"]), rel=1e-6)
    assert "<!-- bench:noise -->" in md.read_text()


def test_bench_refuses_bad_arguments(cli):
    p = cli("bench", "--scenes", "no_such_scene", "--quick")
    assert p.returncode == 2 and "no_such_scene" in p.stderr and "cornell_box" in p.stderr
    p = cli("bench", "--noise", "no_such_scene", "--quick")
    assert p.returncode == 2 and "no_such_scene" in p.stderr
    p = cli("bench", "--noise", "furnace", "--seeds", "1")
    assert p.returncode == 2 and "--seeds" in p.stderr
    p = cli("bench", "--times", "0", "--quick")
    assert p.returncode == 2 and "positive" in p.stderr


def test_bench_shader_quick(cli_here, tmp_path):
    """bench --shader: the same scene with its colours from a shader program renders the same
    image in the mean (its noise differs: the Lambert short path draws other random numbers;
    the means of 2 passes of 32 x 32 pixels agree within 0.2 %, a lost or wrong colour moves
    them by far more than 3 %); the cost per phase and per hit follow from the times."""
    md = tmp_path / "B.md"
    p = cli_here("bench", "--shader", "cornell_box", "--quick", "--json", tmp_path / "s.json",
                 "--markdown", md)
    assert p.returncode == 0, p.stderr
    d = json.loads((tmp_path / "s.json").read_text())
    assert d["materials_driven"] >= 3 and abs(d["image_mean_ratio"] - 1.0) < 0.03
    for lab in ("eye", "photon", "gather"):
        assert d["phase_ms"]["constant"][lab] > 0 and d["phase_ms"]["program"][lab] > 0
        assert d["delta_ms"][lab] == pytest.approx(
            d["phase_ms"]["program"][lab] - d["phase_ms"]["constant"][lab], rel=1e-9)
    assert d["ns_per_pixel_eye"] == pytest.approx(
        d["delta_ms"]["eye"] * 1e6 / d["resolution"] ** 2, rel=1e-9)
    assert "<!-- bench:shader -->" in md.read_text()


def test_bench_arguments_are_the_bench_s_and_its_outputs_go_where_pointed(cli, tmp_path,
                                                                         monkeypatch):
    """The benchmark parses its own arguments (the core CLI hands them over): its --help lists
    them, a wrong one is refused with exit 2; outputs go to --out, else the checkout's docs/
    when run from a checkout, else ./ppm_bench (an installed package has no docs/)."""
    p = cli("bench", "--help")
    assert p.returncode == 0 and "--out DIR" in p.stdout and "--noise SCENE" in p.stdout
    p = cli("bench", "--no-such-flag")
    assert p.returncode == 2 and "unrecognized arguments: --no-such-flag" in p.stderr
    from ppm_engine.tools.bench import command, report
    assert command.output_dir(str(tmp_path / "x")) == tmp_path / "x"
    assert command.output_dir(None) == report.DOCS            # this checkout
    monkeypatch.setattr(report, "DOCS", tmp_path / "no_checkout" / "docs")
    monkeypatch.chdir(tmp_path)
    assert command.output_dir(None) == tmp_path / command.DEFAULT_OUT


def test_digest_is_the_same_for_the_same_code_and_compare_finds_a_change(bpy, tmp_path):
    """bench --digest's fingerprint: two renders of a scene lit by eye paths alone (no photon
    order involved) give the same digests, and compare() names a digest that changed."""
    import json

    from ppm_engine.tools.bench import digest
    runs = [digest.run_digest(scenes=("cornell_box",), configs=("paths",),
                              progress=lambda *a: None) for _ in range(2)]
    assert runs[0]["images"] == runs[1]["images"] and len(runs[0]["images"]) == 3
    path = tmp_path / "old.json"
    path.write_text(json.dumps(runs[0]))
    assert digest.compare(runs[1], str(path))[1] == 0
    runs[1]["images"]["cornell_box/paths"] = "0" * 16
    text, n = digest.compare(runs[1], str(path))
    assert n == 1 and "differs: cornell_box/paths" in text
