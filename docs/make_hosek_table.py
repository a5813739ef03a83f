"""Write the Hosek-Wilkie sky model's XYZ coefficients into the package data
(ppm_engine/data/hosek_wilkie_xyz.npz), read from the data file of the authors' reference
implementation that Blender ships (intern/sky/source/sky_hosek_data.h, or
third_party/sky/source/sky_hosek_data.h of the Cycles repository).

The data: Hosek & Wilkie, "An Analytic Model for Full Spectral Sky-Dome Radiance" (ACM TOG 31(4),
SIGGRAPH 2012), version 1.4a of their coefficients (Copyright 2012-2013 Lukas Hosek and
Alexander Wilkie, BSD-3-Clause), for the CIE XYZ channels: per channel ``config`` (albedo 0/1,
turbidity 1..10, 6 Bezier control points over the solar elevation, 9 distribution parameters
A..I) and ``radiance`` (albedo, turbidity, 6 control points).

Run: python docs/make_hosek_table.py PATH/TO/sky_hosek_data.h
"""
from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np


def read(text: str) -> dict:
    arrays = {}
    for name, body in re.findall(r"static const double (\w+)\[\] = \{(.*?)\};", text, re.S):
        body = re.sub(r"//[^\n]*", "", body)
        arrays[name] = np.array([float(x) for x in body.replace(",", " ").split()])
    config = np.stack([arrays[f"datasetXYZ{c}"] for c in (1, 2, 3)]).reshape(3, 2, 10, 6, 9)
    radiance = np.stack([arrays[f"datasetXYZRad{c}"] for c in (1, 2, 3)]).reshape(3, 2, 10, 6)
    return {"config": config, "radiance": radiance}


if __name__ == "__main__":
    data = read(Path(sys.argv[1]).read_text())
    out = Path(__file__).resolve().parents[1] / "ppm_engine" / "data" / "hosek_wilkie_xyz.npz"
    np.savez_compressed(out, **data)
    print(out, {k: v.shape for k, v in data.items()})
