"""The bench's scoring of a peer whose error is flat with time (ppm_engine/tools/bench/
scoring.py flat_peers, report.py flat_peer_lines): a bias, never a speed-up, with the budget at
which our error crosses it."""
import math

from ppm_engine.tools.bench.report import flat_peer_lines
from ppm_engine.tools.bench.scoring import flat_peers


def _rows(times, rmse, pixels=256):
    return [{"seconds": t, "image": {"rmse": e, "pixels": pixels}} for t, e in zip(times, rmse,
                                                                                    strict=True)]


def test_flat_peer_is_a_bias_and_ours_crossing_is_interpolated():
    times = [2.0, 8.0, 32.0]
    scene = {"resolution": [16, 16], "curves": {
        "ours": _rows(times, [0.4, 0.2, 0.1]),                  # noise: slope -1/2
        "cycles": _rows(times, [0.8, 0.4, 0.2]),
        "cycles_mnee": _rows(times, [0.31, 0.30, 0.30])}}        # flat: a bias
    p = flat_peers(scene)
    assert not p["cycles"]["flat"] and p["cycles"]["slope"] == -0.5
    m = p["cycles_mnee"]
    assert m["flat"] and m["plateau"] == 0.30
    # ours reaches 0.30 between 2 s (0.4) and 8 s (0.2), log-log: 2 x 4^(log(4/3) / log 2)
    assert math.isclose(m["ours_crosses_at"], 2 * 4 ** (math.log(0.4 / 0.3) / math.log(2)))
    result = {"times": times, "scenes": {"point_caustic": scene},
              "ratios": {"point_caustic": {"peers": p}}}
    (line,) = flat_peer_lines(result)
    assert "flat with time" in line and "bias" in line and "not a speed-up" in line
    assert "whole image" in line and "crosses it at 3.56 s" in line
    # never crossed within the run; partial pixels named
    scene["curves"]["ours"] = _rows(times, [0.9, 0.6, 0.5], pixels=200)
    result["ratios"]["point_caustic"]["peers"] = flat_peers(scene)
    (line,) = flat_peer_lines(result)
    assert "stays above it up to 32 s" in line and "200 of 256 pixels" in line
