"""How the error-against-time run (curves.py) scores its renders, and the targets it checks.

Errors: RMSE over RGB (linear radiance) against the reference, over the whole image and over
the scene's caustic pixels (scenes.CAUSTIC_MASKS), and the relative RMSE = RMSE / mean of
the reference over the same pixels.  ``rmse_corrected`` = sqrt(max(RMSE^2 - ref_noise^2, 0))
removes the reference's own (independent) noise from the expected squared error.  In the bulb
box the pixels that see the bulb (the filament and its glass, radiance ~120) are left out of
both: their anti-aliased edges would dominate every figure.

Fireflies (issue 25: "no firefly that Cycles does not have"): every render records its
brightest pixel (luminance) and how many pixels are brighter than FIREFLY_MARGIN x the
reference's range (the brighter of its two halves' brightest pixels); at the equal-time budget
a scene has no firefly of ours when our brightest pixel over the seeds is within that ceiling
or no brighter than Cycles' brightest at the same time (``ratios``: "no_firefly").

A peer whose error is flat with time has converged to a bias, and a ratio against it compares
that bias with our noise: it is not a speed-up.  ``flat_peers`` says which peer curves are flat
(their RMSE falls with a log-log slope above ``FLAT_SLOPE`` from the shortest budget to the
longest, where noise alone falls with slope -1/2), their plateau (the longest budget's RMSE)
and the budget at which our error crosses it, if it does within the run (interpolated log-log
between budgets).

At the equal-time budget ``ratios`` gives ours over Cycles (and over Cycles + MNEE, LuxCore's
BIDIR and the best peer where the run has those curves) and whether each scene meets its target
(``TARGETS``, ``TARGETS_MNEE``, ``TARGETS_LUXCORE``, ``TARGETS_BEST_PEER``).
"""
from __future__ import annotations

import itertools
import math
import re

import numpy as np

# ours / Cycles, EQUAL_TIME (issue 25's targets: the furnace at half Cycles' error)
TARGETS = {"bulb_box": 0.25, "cornell_box": 1.0, "furnace": 0.5, "many_lights": 1.0,
           "hdri_sun": 1.0, "glossy_metal": 1.0, "clamped_caustic": 1.0, "sun_cone": 1.0,
           # issue 42's volume scenes
           "fog_room": 1.0, "smoke": 1.0}
# ours / (Cycles with MNEE), EQUAL_TIME: the point light's caustic through a glass ball
# (a spot light here: a point light whose power goes towards the ball)
TARGETS_MNEE = {"glass_caustic": 1.0, "point_caustic": 1.0,
                # a point light's caustic where MNEE converges (the floor past the focus): an
                # outside review's target, at most half its error at 16 s
                "lifted_caustic": 0.5}
# ours / LuxCore BIDIR, EQUAL_TIME, on the scenes with its curve (curves.LUXCORE_SCENES; issue
# 25: at most 0.3 of its error)
TARGETS_LUXCORE = {"mirror_caustic": 0.3}
# issue 25's new scenes: ahead of the best peer that renders them, ours / the lower of Cycles'
# and Cycles + MNEE's RMSE at EQUAL_TIME
TARGETS_BEST_PEER = {"rough_caustic": 1.0, "pool_caustic": 1.0}


# a peer's RMSE whose log-log slope against time is above this is flat: a bias (noise: -1/2)
FLAT_SLOPE = -0.15
PEERS = ("cycles", "cycles_mnee", "luxcore_bidir")


# --- errors ----------------------------------------------------------------------------------
def errors(img, ref, pixels, ref_noise=0.0) -> dict:
    """RMSE over RGB, relative RMSE (RMSE / mean of ref) and the noise-corrected RMSE."""
    if not pixels.any():
        return {"rmse": float("nan"), "rel_rmse": float("nan"), "rmse_corrected": float("nan"),
                "pixels": 0}
    diff = (img - ref)[pixels]
    rmse = float(np.sqrt(np.mean(diff.astype(np.float64) ** 2)))
    mean = float(np.mean(ref[pixels]))
    corr = math.sqrt(max(rmse * rmse - ref_noise * ref_noise, 0.0))
    return {"rmse": rmse, "rel_rmse": rmse / mean if mean > 0 else float("nan"),
            "rmse_corrected": corr, "pixels": int(pixels.sum())}


# --- fireflies -------------------------------------------------------------------------------
# Rec. 709 luminance of linear RGB: what "the brightest pixel" is measured by
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
# a firefly: a pixel brighter than this many times the reference's range (the brighter of its
# two halves' brightest pixels).  The brightest pixels of the references and of Cycles' and our
# renders at equal time differ by 1-2 % among themselves where nothing is wrong (the Cornell
# box's light, seen directly: 10.7 to 10.8), so the check looks past that
FIREFLY_MARGIN = 1.1


def brightest(img, pixels) -> float:
    """The luminance of the brightest of ``pixels`` (NaN where there is none)."""
    return float((img[..., :3] @ LUMINANCE)[pixels].max()) if pixels.any() else float("nan")


def fireflies(img, pixels, ceiling: float) -> dict:
    """Issue 25's firefly check of one render: its brightest pixel and how many of ``pixels``
    are brighter than ``ceiling`` (FIREFLY_MARGIN x the reference's range: the brighter of its
    two halves' brightest pixels, each half a render of its own with its own noise)."""
    lum = img[..., :3] @ LUMINANCE
    return {"brightest": brightest(img, pixels),
            "over_reference_range": int(((lum > ceiling) & pixels).sum())}


# --- flat errors: a peer's bias --------------------------------------------------------------
def _crossing(rows, level):
    """The budget (log-log interpolated) at which the rows' image RMSE first falls to
    ``level``; None if it stays above it."""
    pts = [(r["seconds"], r["image"]["rmse"]) for r in rows]
    if not pts or pts[0][1] <= level:
        return pts[0][0] if pts else None
    for (t0, e0), (t1, e1) in itertools.pairwise(pts):
        if e1 <= level < e0:
            f = math.log(e0 / level) / math.log(e0 / e1)
            return float(math.exp(math.log(t0) + f * math.log(t1 / t0)))
    return None


def flat_peers(scene: dict) -> dict:
    """Per peer curve of a scene's run (at least two budgets): the log-log slope of its image
    RMSE against time, whether it is flat (a bias: slope above FLAT_SLOPE), its plateau (the
    longest budget's RMSE) and when ours crosses that plateau (None: not within the run)."""
    out = {}
    ours = scene["curves"].get("ours", [])
    for curve in PEERS:
        rows = scene["curves"].get(curve, [])
        if len(rows) < 2:
            continue
        (t0, e0), (t1, e1) = ((rows[i]["seconds"], rows[i]["image"]["rmse"]) for i in (0, -1))
        if not (e0 > 0 and e1 > 0 and t1 > t0):
            continue
        slope = math.log(e1 / e0) / math.log(t1 / t0)
        flat = slope > FLAT_SLOPE
        out[curve] = {"slope": slope, "flat": bool(flat), "plateau": e1,
                      "ours_crosses_at": _crossing(ours, e1) if flat else None}
    return out


# --- the targets -----------------------------------------------------------------------------
def _at(rows, seconds):
    for r in rows:
        if abs(r["seconds"] - seconds) < 1e-9:
            return r
    return None


def ratios(result: dict, seconds: float) -> dict:
    """RMSE ours / Cycles at the given budget, per scene (whole image and caustic pixels), and
    ours / Cycles + MNEE and ours / LuxCore BIDIR where the run has those curves."""
    out = {}
    for name, s in result["scenes"].items():
        o, c = _at(s["curves"]["ours"], seconds), _at(s["curves"]["cycles"], seconds)
        if o is None or c is None:
            continue
        r = {}
        for region in ("image", "caustic"):
            for key in ("rmse", "rmse_corrected"):
                a, b = o[region][key], c[region][key]
                r[f"{region}_{key}"] = a / b if b > 0 else float("nan")
        m = _at(s["curves"].get("cycles_mnee", []), seconds)
        if m is not None:
            r["image_rmse_vs_mnee"] = o["image"]["rmse"] / m["image"]["rmse"]
            r["caustic_rmse_vs_mnee"] = o["caustic"]["rmse"] / m["caustic"]["rmse"]
        if m is not None or name in TARGETS_BEST_PEER:
            best = min(c["image"]["rmse"], m["image"]["rmse"] if m is not None else math.inf)
            r["image_rmse_vs_best_peer"] = o["image"]["rmse"] / best
        x = _at(s["curves"].get("luxcore_bidir", []), seconds)
        if x is not None:
            r["image_rmse_vs_luxcore"] = o["image"]["rmse"] / x["image"]["rmse"]
            r["caustic_rmse_vs_luxcore"] = o["caustic"]["rmse"] / x["caustic"]["rmse"]
        if "image_rmse_mean" in o and "image_rmse_mean" in c:
            r["image_rmse_seeds"] = o["image_rmse_mean"] / c["image_rmse_mean"]
            r["seeds"] = o["seeds"]
        r["indirect"] = o.get("indirect", "photons")
        if "caster_fraction" in o:
            r["caster_fraction"] = o["caster_fraction"]
        r["pixels"] = o["image"]["pixels"]
        r["peers"] = flat_peers(s)
        p = _at(s["curves"].get("ours_photons", []), seconds)
        if p is not None:
            r["photons_image_rmse"] = p["image"]["rmse"] / c["image"]["rmse"]
        g = _at(s["curves"].get("ours_merge", []), seconds)
        if g is not None:       # what the photons' light tracing gives: ours over the merge alone
            r["ours_over_merge_alone"] = o["image"]["rmse"] / g["image"]["rmse"]
        # issue 25: no firefly that Cycles does not have; ours' brightest pixel at this budget
        # (over the seeds where there are several) within the reference's range (up to
        # FIREFLY_MARGIN) or no brighter than Cycles' brightest at the same time
        # (a run's JSON from before the check has none)
        if "brightest_half" in s["reference"] and "brightest" in o and "brightest" in c:
            ref_range = s["reference"]["brightest_half"]
            ceiling = s["reference"]["firefly_ceiling"]
            ob = max(o.get("brightest_seeds", [o["brightest"]]))
            cb = max(c.get("brightest_seeds", [c["brightest"]]))
            r["brightest"] = {"ours": ob, "cycles": cb, "reference_range": ref_range,
                              "firefly_ceiling": ceiling,
                              "ours_over_range": sum(o.get("over_reference_range_seeds",
                                                           [o["over_reference_range"]])),
                              "cycles_over_range": sum(c.get("over_reference_range_seeds",
                                                             [c["over_reference_range"]]))}
            r["no_firefly"] = bool(ob <= max(ceiling, cb))
        if name in TARGETS:
            r["target"] = TARGETS[name]
            r["met"] = bool(r.get("image_rmse_seeds", r["image_rmse"]) <= TARGETS[name])
        elif name in TARGETS_BEST_PEER:
            r["target_best_peer"] = TARGETS_BEST_PEER[name]
            r["met"] = bool(r["image_rmse_vs_best_peer"] <= TARGETS_BEST_PEER[name])
        elif name in TARGETS_MNEE and "image_rmse_vs_mnee" in r:
            r["target_mnee"] = TARGETS_MNEE[name]
            r["met"] = bool(r["image_rmse_vs_mnee"] <= TARGETS_MNEE[name])
        elif name in TARGETS_LUXCORE and "image_rmse_vs_luxcore" in r:
            r["target_luxcore"] = TARGETS_LUXCORE[name]
            r["met"] = bool(r["image_rmse_vs_luxcore"] <= TARGETS_LUXCORE[name])
        out[name] = r
    return out


def stats_info(line: str) -> dict:
    """What a render's last stats line (PassStats.line) says of it: the estimator of indirect
    light it used, and the share of its caustic photons that reached a caster (aimed
    emission), where it says one."""
    info = {"indirect": "paths" if " · paths" in line else "photons"}
    reach = re.search(r" · ([0-9.e+-]+) % reach a caster", line)
    if reach:
        info["caster_fraction"] = float(reach.group(1)) / 100.0
    return info
