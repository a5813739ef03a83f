"""The benchmark's outputs: the machine it ran on, JSON, the error-against-time plot, markdown
tables, and the ``<!-- bench:NAME -->`` blocks it writes into docs/BENCHMARKS.md."""
from __future__ import annotations

import json
import math
import os
import platform
from pathlib import Path

DOCS = Path(__file__).resolve().parents[3] / "docs"


def machine_info(device_name: str = "") -> dict:
    cpu = platform.processor() or ""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    info = {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version()}
    try:
        import bpy
        info["blender"] = bpy.app.version_string
    except ImportError:
        pass
    try:
        import pyopencl as cl

        from ppm_engine.render.device import get_device
        dev = get_device(device_name)
        info["opencl_device"] = dev.info.name
        info["opencl_platform"] = dev.info.platform
        info["pyopencl"] = cl.VERSION_TEXT
        for p in cl.get_platforms():
            if p.name == dev.info.platform:
                info["opencl_platform_version"] = p.version
    except Exception as e:
        info["opencl_error"] = str(e)
    return info


def plot(result: dict, path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    names = list(result["scenes"])
    fig, axes = plt.subplots(2, len(names), figsize=(4 * len(names), 7), squeeze=False)
    style = {"ours": ("C0", "o", "ours (default)"),
             "ours_photons": ("C3", "x", "ours, paper's photons"), "cycles": ("C1", "s", "Cycles"),
             "ours_merge": ("C5", "v", "ours without light tracing"),
             "cycles_mnee": ("C2", "^", "Cycles + MNEE"),
             "luxcore_bidir": ("C4", "D", "LuxCore BIDIR")}
    for j, name in enumerate(names):
        s = result["scenes"][name]
        for i, region in enumerate(("image", "caustic")):
            ax = axes[i][j]
            for curve, rows in s["curves"].items():
                c, mk, label = style[curve]
                x = [r["seconds"] for r in rows]
                y = [r[region]["rmse"] for r in rows]
                ax.loglog(x, y, color=c, marker=mk, label=label)
            noise = s["reference"]["noise_rmse" if region == "image" else "noise_rmse_caustic"]
            if noise == noise and noise > 0:
                ax.axhline(noise, color="gray", ls=":", lw=1, label="reference noise")
            ax.set_title(f"{name}: {_region_name(s) if region == 'image' else 'caustic pixels'}",
                         fontsize=9)
            ax.set_xlabel("render time (s)")
            ax.set_ylabel("RMSE vs reference")
            ax.grid(True, which="both", alpha=0.3)
            if i == 0 and j == 0:
                ax.legend(fontsize=7)
    fig.suptitle(f"Error against time, {result['resolution']}x{result['resolution']}, "
                 f"{result['machine'].get('cpu', '')}", fontsize=10)
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    plt.close(fig)


def _region_name(s: dict) -> str:
    """What a scene's "image" errors are over: the whole image, or the pixels its reference
    renders (light-traced references leave out what the camera sees of glass and mirrors)."""
    w, h = s["resolution"]
    n = s["curves"]["ours"][0]["image"]["pixels"] if s["curves"].get("ours") else w * h
    return "whole image" if n == w * h else f"{n} of {w * h} pixels"


def table(result: dict) -> str:
    """Markdown: one row per scene and budget, RMSE (relative) per curve and region; "image"
    is every pixel unless the pixels column says fewer."""
    lines = ["| scene | pixels | time (s) | ours RMSE (rel) | paper's photons RMSE (rel) "
             "| ours without light tracing RMSE (rel) "
             "| Cycles RMSE (rel) | Cycles+MNEE RMSE (rel) | LuxCore BIDIR RMSE (rel) "
             "| ours caustic RMSE (rel) | Cycles caustic RMSE (rel) | Cycles+MNEE caustic (rel) "
             "| LuxCore BIDIR caustic (rel) | ours passes |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]

    def cell(row, region):
        if row is None:
            return "–"
        e = row[region]
        return f"{e['rmse']:.4f} ({e['rel_rmse']:.3f})"
    for name, s in result["scenes"].items():
        c = s["curves"]
        for k, budget in enumerate(result["times"]):
            o, cy = c["ours"][k], c["cycles"][k]
            m = c["cycles_mnee"][k] if "cycles_mnee" in c else None
            p = c["ours_photons"][k] if "ours_photons" in c else None
            g = c["ours_merge"][k] if "ours_merge" in c else None
            x = c["luxcore_bidir"][k] if "luxcore_bidir" in c else None
            lines.append(f"| {name} | {_region_name(s)} | {budget:g} | {cell(o, 'image')} | "
                         f"{cell(p, 'image')} | "
                         f"{cell(g, 'image')} | "
                         f"{cell(cy, 'image')} | {cell(m, 'image')} | {cell(x, 'image')} | "
                         f"{cell(o, 'caustic')} | {cell(cy, 'caustic')} | "
                         f"{cell(m, 'caustic')} | {cell(x, 'caustic')} | "
                         f"{o.get('passes', '–')} |")
    return "\n".join(lines)


def reference_table(result: dict) -> str:
    lines = ["| scene | reference engine | independent | pixels it renders | s per half | mean "
             "| reference noise RMSE (rel) | caustic pixels | caustic noise RMSE "
             "| Cycles longest mean / ref | ours longest mean / ref |",
             "|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    for name, s in result["scenes"].items():
        r, b = s["reference"], s["bias_check"]
        # this engine's light tracer: one of its strategies since light tracing joined the
        # photons (kernels/integrator/photon_pass.cl connect_camera)
        independent = {"PPM": "no (ours)", "LIGHT_TRACE": "no (our light tracer)"}.get(
            r["engine"], "yes")
        lines.append(f"| {name} | {r['engine']} | {independent} | {_region_name(s)} | "
                     f"{r['seconds_per_half']:g} | "
                     f"{r['mean']:.4f} | "
                     f"{r['noise_rmse']:.4f} ({r['noise_rel_rmse']:.3f}) | "
                     f"{s['caustic_mask_pixels']} | {r['noise_rmse_caustic']:.4f} | "
                     f"{b['cycles_longest_mean_over_reference']:.3f} | "
                     f"{b['ours_longest_mean_over_reference']:.3f} |")
    for name, s in result["scenes"].items():        # a reference rendered by its stand-in
        f = s["reference"].get("fallback")
        if f:
            lines.append(f"\n{name}: {s['reference']['engine']} in place of {f['engine']} "
                         f"({f['reason']}).")
    return "\n".join(lines)


def light_trace_check_table(result: dict) -> str:
    """This engine's light tracer against Cycles where both converge, against the exact
    sphere's reference on point_caustic, and against LuxCore's light tracer where that is the
    reference (curves.Bench.run_scene)."""
    lines = ["| scene | reference | light tracing s | photons | pixels | mean LT / reference "
             "| RMSE LT - ref | reference noise RMSE | caustic: mean LT / ref "
             "| caustic RMSE (ref noise) | focus pixel LT / ref |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for name, s in result["scenes"].items():
        c = s.get("light_trace_check")
        if c:
            caustic = ((f"{c['caustic_mean_over_reference']:.4f} | {c['caustic_rmse']:.4f} "
                        f"({c['caustic_reference_noise_rmse']:.4f}) | "
                        f"{c['focus_light_trace']:.2f} / {c['focus_reference']:.2f}")
                       if "caustic_rmse" in c else "– | – | –")
            lines.append(f"| {name} | {c.get('reference', 'CYCLES')} | {c['seconds']:g} | "
                         f"{c['photons']:.3g} | {c['pixels']} | "
                         f"{c['mean_over_reference']:.4f} | {c['rmse']:.4f} | "
                         f"{c['reference_noise_rmse']:.4f} | {caustic} |")
    return "\n".join(lines)


def light_tree_table(result: dict) -> str:
    """The light trees of the scenes that have one (scenes.light_tree_stats)."""
    lines = ["| scene | emitters in the tree | nodes | device bytes | build s "
             "| their power share |", "|---|---:|---:|---:|---:|---:|"]
    for name, s in result["scenes"].items():
        t = s.get("light_tree")
        if t:
            lines.append(f"| {name} | {t['emitters']} | {t['nodes']} | {t['bytes']} | "
                         f"{t['build_s']:.4f} | {t['share']:.3f} |")
    return "\n".join(lines) if len(lines) > 2 else "(no scene of this run has a light tree)"


def ratio_table(result: dict) -> str:
    eq = result["ratios_at"]
    lines = [f"| scene | ours: indirect light | pixels | RMSE ours/Cycles at {eq:g} s "
             "| mean of seeds | corrected for ref. noise | caustic pixels | ours/(Cycles+MNEE) "
             "| ours/LuxCore BIDIR (caustic pixels) | paper's photons/Cycles | target | met "
             "| brightest pixel: ours / Cycles / reference's range (pixels over 1.1 x the "
             "range: ours, Cycles) | no firefly |",
             "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---|"]
    for name, r in result["ratios"].items():
        mn = f"{r['image_rmse_vs_mnee']:.3f}" if "image_rmse_vs_mnee" in r else "–"
        lx = (f"{r['image_rmse_vs_luxcore']:.3f} ({r['caustic_rmse_vs_luxcore']:.3f})"
              if "image_rmse_vs_luxcore" in r else "–")
        tgt = (f"≤ {r['target']:g}" if "target" in r else
               f"≤ {r['target_mnee']:g} (vs MNEE)" if "target_mnee" in r else
               f"≤ {r['target_best_peer']:g} (vs the best of Cycles, Cycles+MNEE: "
               f"{r['image_rmse_vs_best_peer']:.3f})" if "target_best_peer" in r else
               f"≤ {r['target_luxcore']:g} (vs LuxCore BIDIR)" if "target_luxcore" in r else "–")
        met = ("yes" if r["met"] else "no") if "met" in r else "–"
        ph = f"{r['photons_image_rmse']:.3f}" if "photons_image_rmse" in r else "–"
        sd = (f"{r['image_rmse_seeds']:.3f} ({len(r['seeds'])})" if "image_rmse_seeds" in r
              else "–")
        region = _region_name(result["scenes"][name])
        how = r.get("indirect", "photons") + (
            f" ({100 * r['caster_fraction']:.3g} % of caustic photons reach a caster)"
            if "caster_fraction" in r else "")
        lines.append(f"| {name} | {how} | {region} | "
                     f"{r['image_rmse']:.3f} | {sd} | "
                     f"{r['image_rmse_corrected']:.3f} | {r['caustic_rmse']:.3f} | {mn} | {lx} | "
                     f"{ph} | {tgt} | {met} | {_brightest(r)} | "
                     f"{('yes' if r['no_firefly'] else 'no') if 'no_firefly' in r else '–'} |")
    lines += flat_peer_lines(result)
    # LuxCore's curve: its converged brightness (a bias raises its RMSE) or why it is missing
    for name, s in result["scenes"].items():
        b = s.get("bias_check", {}).get("luxcore_longest_mean_over_reference")
        if b is not None:
            lines.append(f"\nLuxCore BIDIR on {name}: its longest render's mean / reference "
                         f"{b:.3f}.")
        if isinstance(s.get("luxcore"), str):
            lines.append(f"\nLuxCore BIDIR on {name} skipped: {s['luxcore']}.")
    return "\n".join(lines)


PEER_NAMES = {"cycles": "Cycles", "cycles_mnee": "Cycles + MNEE",
              "luxcore_bidir": "LuxCore BIDIR"}


def flat_peer_lines(result: dict) -> list:
    """A sentence per peer whose error is flat with time (scoring.flat_peers): a bias, which a
    ratio at one budget compares with our noise: not a speed-up; and when ours crosses it."""
    out = []
    times = result["times"]
    for name, r in result["ratios"].items():
        for curve, p in r.get("peers", {}).items():
            if not p["flat"]:
                continue
            t = p["ours_crosses_at"]
            when = (f"ours is below it from the shortest budget ({times[0]:g} s)"
                    if t is not None and t <= times[0] else
                    f"ours crosses it at {t:.3g} s" if t is not None else
                    f"ours stays above it up to {times[-1]:g} s")
            out.append(f"\n{name}: {PEER_NAMES.get(curve, curve)}'s error is flat with time "
                       f"(log-log slope {p['slope']:+.2f} from {times[0]:g} to {times[-1]:g} s, "
                       f"RMSE {p['plateau']:.4f} over the {_region_name(result['scenes'][name])}"
                       f"): bias, which a ratio against it compares with our noise, not a "
                       f"speed-up; {when}.")
    return out


def _brightest(r: dict) -> str:
    """The firefly check's cell (scoring.ratios: "brightest")."""
    b = r.get("brightest")
    if not b:
        return "–"
    return (f"{b['ours']:.3g} / {b['cycles']:.3g} / {b['reference_range']:.3g} "
            f"({b['ours_over_range']}, {b['cycles_over_range']})")


def _finite_json(obj):
    """NaN -> None so that the JSON is standard (json.dumps would write NaN)."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _finite_json(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite_json(v) for v in obj]
    return obj


def from_json(obj):
    """The inverse of _finite_json: null -> NaN (write_json stores every NaN as null)."""
    if obj is None:
        return float("nan")
    if isinstance(obj, dict):
        return {k: from_json(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [from_json(v) for v in obj]
    return obj


def write_json(result: dict, path) -> None:
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w") as f:
        json.dump(_finite_json(result), f, indent=1, allow_nan=False)


def replace_block(path: Path, name: str, text: str) -> None:
    """Put ``text`` between <!-- bench:NAME --> and <!-- /bench:NAME --> in ``path`` (the block
    is appended when the file or the markers do not exist yet)."""
    begin, end = f"<!-- bench:{name} -->", f"<!-- /bench:{name} -->"
    block = f"{begin}\n{text.strip()}\n{end}"
    old = path.read_text() if path.is_file() else ""
    if begin in old and end in old:
        head, rest = old.split(begin, 1)
        new = head + block + rest.split(end, 1)[1]
    else:
        new = (old.rstrip() + "\n\n" if old.strip() else "") + block + "\n"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(new)
