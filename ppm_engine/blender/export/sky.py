"""Cycles' Sky Texture node in shader programs (SVM_TEX_SKY, kernels/svm/svm_sky.h): the host
precomputes what Cycles precomputes (its scene/shader_nodes.cpp SkyTextureNode), the kernel
evaluates the rest.

- PREETHAM: Preetham, Shirley & Smits, "A Practical Analytic Model for Daylight" (SIGGRAPH
  1999): the Perez distribution with turbidity-dependent coefficients, the zenith luminance
  and chromaticity (the paper's fits, as Cycles uses them) divided by the distribution at the
  zenith, xyY -> XYZ -> scene linear.  The sun is the node's Sun Direction (normalised).
- SINGLE_SCATTERING (Nishita): a 512 x 256 LUT of the sky's XYZ ray-marched through the
  atmosphere (ppm_engine/scene/sky_atmosphere.py) and the sun disc's colour at its lower and upper
  edge, for the sun elevation and rotation Cycles wraps into range (its simplify_settings).
- HOSEK_WILKIE: Hosek & Wilkie, "An Analytic Model for Full Spectral Sky-Dome Radiance"
  (SIGGRAPH 2012): the 9 parameters and radiance of each XYZ channel cooked from the authors'
  coefficients (a quintic Bezier over the sun's elevation, linear in turbidity and ground
  albedo), the kernel's distribution times 2 pi / 683.
- MULTIPLE_SCATTERING: García Liñán's atmosphere (ppm_engine/scene/sky_multiple.py), its LUT and
  sun disc evaluated by the same kernel code as single scattering (as in Cycles 5.0).

The node's Vector (unlinked: Generated, a world's ray direction) goes through its texture
mapping as Cycles applies it; like Cycles the vector is not normalised.
"""
from __future__ import annotations

import functools
import math

import numpy as np

from ppm_engine.blender.export.shader_textures import _texture_mapping
from ppm_engine.blender.export.shader_values import Val
from ppm_engine.scene.shader_program import SKY_TYPES, SVM_TEX_SKY


def _perez(p, theta: float, gamma: float) -> float:
    return (1.0 + p[0] * math.exp(p[1] / math.cos(theta))) * (
        1.0 + p[2] * math.exp(p[3] * gamma) + p[4] * math.cos(gamma) ** 2)


def preetham_params(sun_direction, turbidity: float) -> list:
    """The 20 floats of SKY_PREETHAM: sun phi and theta (Cycles' convention: phi from +Y
    towards +X), the zenith Y, x, y over the Perez function at the zenith, the Perez
    coefficients A..E of Y, x and y (Preetham et al. 1999, appendix A.2)."""
    s = np.asarray(sun_direction, np.float64)
    n = np.linalg.norm(s)
    s = s / n if n > 0 else np.array([0.0, 0.0, 1.0])
    theta, phi = math.acos(min(max(s[2], -1.0), 1.0)), math.atan2(s[0], s[1])
    t, t2, th, th2, th3 = turbidity, turbidity ** 2, theta, theta ** 2, theta ** 3
    chi = (4.0 / 9.0 - t / 120.0) * (math.pi - 2.0 * theta)
    zen_Y = ((4.0453 * t - 4.9710) * math.tan(chi) - 0.2155 * t + 2.4192) * 0.06
    zen_x = ((0.00166 * th3 - 0.00375 * th2 + 0.00209 * th) * t2
             + (-0.02903 * th3 + 0.06377 * th2 - 0.03202 * th + 0.00394) * t
             + (0.11693 * th3 - 0.21196 * th2 + 0.06052 * th + 0.25886))
    zen_y = ((0.00275 * th3 - 0.00610 * th2 + 0.00317 * th) * t2
             + (-0.04214 * th3 + 0.08970 * th2 - 0.04153 * th + 0.00516) * t
             + (0.15346 * th3 - 0.26756 * th2 + 0.06670 * th + 0.26688))
    coef = {  # (slope in T, offset) of the Perez coefficients A..E
        "Y": ((0.1787, -1.4630), (-0.3554, 0.4275), (-0.0227, 5.3251), (0.1206, -2.5771),
              (-0.0670, 0.3703)),
        "x": ((-0.0193, -0.2592), (-0.0665, 0.0008), (-0.0004, 0.2125), (-0.0641, -0.8989),
              (-0.0033, 0.0452)),
        "y": ((-0.0167, -0.2608), (-0.0950, 0.0092), (-0.0079, 0.2102), (-0.0441, -1.6537),
              (-0.0109, 0.0529))}
    perez = {k: [a * t + b for a, b in v] for k, v in coef.items()}
    zen = [z / _perez(perez[k], 0.0, theta) for z, k in ((zen_Y, "Y"), (zen_x, "x"),
                                                         (zen_y, "y"))]
    return [phi, theta] + zen + perez["Y"] + perez["x"] + perez["y"]


@functools.lru_cache(maxsize=1)
def _hosek_data():
    from pathlib import Path
    with np.load(Path(__file__).resolve().parents[2] / "data" / "hosek_wilkie_xyz.npz") as f:
        return f["config"], f["radiance"]


def _bezier_elevation(ctrl, elevation: float, turbidity: float, albedo: float):
    """A Hosek-Wilkie quantity at the solar elevation: the quintic Bezier over
    (elevation / (pi/2))^(1/3) of its 6 control points (the last-but-one axis of ``ctrl``),
    linear in the albedo (axis 0) and the turbidity (axis 1, 1..10)."""
    t = (elevation / (math.pi / 2)) ** (1.0 / 3.0)
    basis = np.array([math.comb(5, k) * (1 - t) ** (5 - k) * t ** k for k in range(6)])
    lo = int(turbidity)
    frac = turbidity - lo
    res = 0.0
    for a, wa in ((0, 1.0 - albedo), (1, albedo)):
        for k, wt in ((lo - 1, 1.0 - frac), (lo, frac)):
            if wt != 0.0 and 0 <= k < 10:
                res = res + wa * wt * np.tensordot(basis, ctrl[a, k], axes=(0, 0))
    return res


def hosek_params(sun_direction, turbidity: float, albedo: float) -> list:
    """The 32 floats of SKY_HOSEK: sun phi and theta (the sun clamped to the horizon), the
    X, Y, Z radiances and the 9 distribution parameters of each channel (Hosek & Wilkie 2012,
    their XYZ coefficients, ppm_engine/data/hosek_wilkie_xyz.npz)."""
    s = np.asarray(sun_direction, np.float64)
    n = np.linalg.norm(s)
    s = s / n if n > 0 else np.array([0.0, 0.0, 1.0])
    theta = min(max(math.acos(min(max(s[2], -1.0), 1.0)), 0.0), math.pi / 2)
    phi = math.atan2(s[0], s[1])
    t = min(max(turbidity, 1.0), 10.0)          # (Blender's range; Cycles clamps to 0..10)
    config, radiance = _hosek_data()
    elevation = math.pi / 2 - theta
    rad = [float(_bezier_elevation(radiance[c], elevation, t, albedo)) for c in range(3)]
    cfg = [_bezier_elevation(config[c], elevation, t, albedo) for c in range(3)]
    return [phi, theta] + rad + [float(x) for c in cfg for x in c]


def simplify_sun(elevation: float, rotation: float) -> tuple[float, float]:
    """The sun's elevation in [-pi/2, pi/2] and rotation as Cycles' kernel takes them
    (SkyTextureNode::simplify_settings: the same position, the rotation mirrored)."""
    f32 = np.float32
    e, r, tau, pi = f32(elevation), f32(rotation), f32(2 * math.pi), f32(math.pi)
    e = f32(math.fmod(e, tau))
    if abs(e) >= pi:
        e = f32(e - f32(math.copysign(2.0, e)) * pi)
    if e >= pi / 2 or e <= -pi / 2:
        e = f32(f32(math.copysign(pi, e)) - e)
        r = f32(r + pi)
    r = f32(math.fmod(r, tau))
    if r < 0:
        r = f32(r + tau)
    return float(e), float(tau - r)


def nishita_params(node, multiple: bool) -> list:
    """The floats of SKY_SINGLE (both atmosphere models): the sun disc, the sun, the LUT
    (sky_atmosphere.py, single scattering; sky_multiple.py, multiple scattering)."""
    from ppm_engine.scene import sky_atmosphere, sky_multiple
    elevation, rotation = simplify_sun(node.sun_elevation, node.sun_rotation)
    size = max(float(node.sun_size), 0.0005)
    atmosphere = (float(node.altitude), float(node.air_density), float(node.aerosol_density))
    ozone = float(node.ozone_density)
    if multiple:
        lo, hi = sky_multiple.sun_pixels(elevation, size, *atmosphere, ozone)
        lut = sky_multiple.sky_lut(elevation, *atmosphere, ozone)
    else:
        lo, hi = sky_atmosphere.sun_pixels(elevation, size, *atmosphere)
        lut = sky_atmosphere.sky_lut(elevation, *atmosphere, ozone)
    head = list(lo) + list(hi) + [elevation, rotation, size if node.sun_disc else -1.0,
                                  float(node.sun_intensity),
                                  -sky_atmosphere.earth_intersection_angle(atmosphere[0]),
                                  lut.shape[1], lut.shape[0]]
    return head + [lut]


def _words(params) -> np.ndarray:
    """Float parameters (a trailing array: the LUT) as int4 words."""
    arrays = [np.asarray(p, np.float32).ravel() if isinstance(p, np.ndarray)
              else np.array([p], np.float32) for p in params]
    f = np.concatenate(arrays)
    f = np.concatenate([f, np.zeros(-len(f) % 4, np.float32)])
    return f.view(np.int32).reshape(-1, 4)


def _sky(c, node, out, ctx):
    kind = node.sky_type
    if kind not in SKY_TYPES:                  # (another Blender version's model)
        c.warn(f"'{node.name}' (Sky Texture): the sky type {kind} is not evaluated by this "
               "engine; the Preetham model with its Sun Direction and Turbidity is used")
        kind = "PREETHAM"
    if kind == "PREETHAM":
        params = preetham_params(tuple(node.sun_direction), float(node.turbidity))
    elif kind == "HOSEK_WILKIE":
        params = hosek_params(tuple(node.sun_direction), float(node.turbidity),
                              float(node.ground_albedo))
    else:
        params = nishita_params(node, kind == "MULTIPLE_SCATTERING")
    words = _words(params)
    vec = c.slot(_texture_mapping(c, node, c.texture_vector(node, ctx)))
    o = c.alloc(3)
    c.ops.append((SVM_TEX_SKY, o, vec, SKY_TYPES[kind]))
    c.ops.append((len(words), 0, 0, 0))
    c.ops.extend(map(tuple, words.tolist()))
    return Val(3, slot=o)


SKY_NODES = {"ShaderNodeTexSky": _sky}
