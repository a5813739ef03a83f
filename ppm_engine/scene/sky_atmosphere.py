"""The single-scattering (Nishita) sky of Cycles' Sky Texture, precomputed on the host in
vectorised NumPy: the model of Blender's sky library (its sky_single_scattering.cpp), learnt
and written again here.

Nishita, Sirai, Tadamura & Nakamae, "Display of the Earth Taking into Account Atmospheric
Scattering" (SIGGRAPH 1993): the light of the sun scattered once towards the viewer by air
(Rayleigh) and aerosols (Mie, Cornette-Shanks phase g = 0.76), attenuated on both legs by
Rayleigh, Mie (extinction 1.11 x scattering) and ozone absorption, in 21 wavelengths 380-780 nm,
integrated against the CIE 1931 colour matching functions into XYZ.  The viewer is at the
node's altitude above a sphere of 6360 km under a 60 km atmosphere; densities fall
exponentially (8 km air, 1.2 km aerosols), ozone is a tent 10-40 km.  The view ray is
marched in 32 segments (midpoints); the optical depth towards the sun by 8-point
Gauss-Laguerre quadrature (nodes over 25 of the ray's length).

The spectral tables are the published data the library uses: the solar irradiance at the top
of the atmosphere (W m^-2 nm^-1), Rayleigh scattering and ozone absorption coefficients
(m^-1), the CIE 1931 2-degree observer (tabulated every 20 nm).
"""
from __future__ import annotations

import functools
import math

import numpy as np

RAYLEIGH_SCALE, MIE_SCALE = 8e3, 1.2e3           # scale heights (m)
MIE_COEFF, MIE_G = 2e-5, 0.76                   # aerosol scattering (m^-1), anisotropy
EARTH_RADIUS, ATMOSPHERE_RADIUS = 6360e3, 6420e3  # (m)
STEPS = 32
STEP_LAMBDA = 20.0                              # nm between the 21 wavelengths 380..780
IRRADIANCE = np.array([
    1.45756829855593, 1.56596305559738, 1.65148449067670, 1.71496242737209, 1.75797983805021,
    1.78256407885925, 1.79095108475839, 1.78541550133411, 1.76815554864306, 1.74122069647250,
    1.70647127164944, 1.66556087452740, 1.61993437242452, 1.57083597368892, 1.51932335059305,
    1.46628494965214, 1.41245852740172, 1.35844961970384, 1.30474913844739, 1.25174963272611,
    1.19975998755421])
RAYLEIGH = np.array([
    5.424820087636473e-5, 4.418549866505454e-5, 3.635151910165377e-5, 3.017929012024763e-5,
    2.526320226989157e-5, 2.130859310621843e-5, 1.809838025320633e-5, 1.547057129129042e-5,
    1.330284977336850e-5, 1.150184784075764e-5, 9.99557429990163e-6, 8.72799973630707e-6,
    7.65513700977967e-6, 6.74217203751443e-6, 5.96134125832052e-6, 5.29034598065810e-6,
    4.71115687557433e-6, 4.20910481110487e-6, 3.77218381260133e-6, 3.39051255477280e-6,
    3.05591531679811e-6])
OZONE = np.array([
    3.25126849861e-9, 5.85395365047e-9, 1.977191155085e-8, 7.309568762914e-8,
    2.0084561514287e-7, 4.0383958096161e-7, 6.3551335912363e-7, 9.6707041180970e-7,
    1.54797400424410e-6, 2.09038647223331e-6, 2.46128056164565e-6, 2.73551299461512e-6,
    2.15125863128643e-6, 1.59051840791988e-6, 1.12356197979857e-6, 7.3527551487574e-7,
    4.6450130357806e-7, 3.3096079921048e-7, 2.2512612292678e-7, 1.4879129266490e-7,
    1.6828623364192e-7])
CMF = np.array([  # CIE 1931 x, y, z at 380, 400, ..., 780 nm
    (0.001368, 0.000039, 0.006450001), (0.01431, 0.000396, 0.06785001),
    (0.13438, 0.004, 0.6456), (0.34828, 0.023, 1.74706), (0.2908, 0.06, 1.6692),
    (0.09564, 0.13902, 0.8129501), (0.0049, 0.323, 0.272), (0.06327, 0.71, 0.07824999),
    (0.2904, 0.954, 0.0203), (0.5945, 0.995, 0.0039), (0.9163, 0.87, 0.001650001),
    (1.0622, 0.631, 0.0008), (0.8544499, 0.381, 0.00019), (0.4479, 0.175, 0.00002),
    (0.1649, 0.061, 0.0), (0.04677, 0.017, 0.0), (0.01135916, 0.004102, 0.0),
    (0.002899327, 0.001047, 0.0), (0.0006900786, 0.0002492, 0.0),
    (0.0001661505, 0.00006, 0.0), (0.00004150994, 0.00001499, 0.0)])


def _quadrature():
    """Gauss-Laguerre nodes and weights (8 points) for int f(x) e^-x, with e^x folded into the
    weights and x mapped onto [0, 1] over 25 (the last node stays inside the atmosphere)."""
    x, w = np.polynomial.laguerre.laggauss(8)
    return x / 25.0, w * np.exp(x) / 25.0


QUAD_NODES, QUAD_WEIGHTS = _quadrature()


def _geographic(lat, lon):
    lat, lon = np.broadcast_arrays(np.asarray(lat, np.float64), np.asarray(lon, np.float64))
    return np.stack([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)], -1)


def _densities(p):
    """(Rayleigh, Mie, ozone) densities at points p (..., 3)."""
    h = np.linalg.norm(p, axis=-1) - EARTH_RADIUS
    return np.stack([np.exp(-h / RAYLEIGH_SCALE), np.exp(-h / MIE_SCALE),
                     np.maximum(0.0, 1.0 - np.abs(h - 25000.0) / 15000.0)], -1)


def _exit_distance(p, d):
    """Distance from p along unit d to the top of the atmosphere."""
    b = 2.0 * np.sum(d * p, -1)
    c = np.sum(p * p, -1) - ATMOSPHERE_RADIUS ** 2
    return (-b + np.sqrt(np.maximum(b * b - 4.0 * c, 0.0))) / 2.0


def _optical_depth(p, d):
    """(Rayleigh, Mie, ozone) optical depths (unscaled) from points p (..., 3) along unit d."""
    length = _exit_distance(p, d)
    seg = length[..., None] * d                                     # (..., 3)
    q = p[..., None, :] + QUAD_NODES[:, None] * seg[..., None, :]   # (..., 8, 3)
    with np.errstate(over="ignore"):     # (through the Earth: infinite, where the sun is hidden)
        return np.einsum("...kc,k->...c", _densities(q), QUAD_WEIGHTS) * length[..., None]


def _blocked(p, s):
    """Whether the Earth hides the sun (unit s) from points p (..., 3)."""
    if s[2] >= 0.0:
        return np.zeros(p.shape[:-1], bool)
    b = 2.0 * np.sum(s * p, -1)
    c = np.sum(p * p, -1) - EARTH_RADIUS ** 2
    return b * b - 4.0 * c >= 0.0


def _phases(mu):
    rayleigh = 0.1875 / math.pi * (1.0 + mu * mu)
    g2 = MIE_G * MIE_G
    mie = 3.0 * (1.0 - g2) * (1.0 + mu * mu) / (
        8.0 * math.pi * (2.0 + g2) * (1.0 + g2 - 2.0 * MIE_G * mu) ** 1.5)
    return rayleigh, mie


def single_scattering_xyz(dirs, sun, altitude, air, aerosol, ozone, chunk=2048):
    """XYZ of the light scattered once towards the viewer along unit directions dirs (n, 3)."""
    scale = np.array([air, aerosol, ozone])
    cam = np.array([0.0, 0.0, EARTH_RADIUS + altitude])
    ext = np.stack([RAYLEIGH, np.full(21, 1.11 * MIE_COEFF), OZONE])      # (3, 21)
    out = np.zeros((len(dirs), 3))
    for a in range(0, len(dirs), chunk):
        d = dirs[a:a + chunk]
        seg_len = _exit_distance(cam, d) / STEPS                          # (n,)
        k = np.arange(STEPS) + 0.5
        p = cam + (k[None, :, None] * seg_len[:, None, None]) * d[:, None, :]   # (n, 32, 3)
        dens = scale * _densities(p)
        depth = np.cumsum(dens * seg_len[:, None, None], axis=1)          # to each midpoint
        lit = ~_blocked(p, sun)                       # (where not, the sun's leg is not used)
        total = depth + scale * np.where(lit[..., None], _optical_depth(p, sun), 0.0)
        atten = np.exp(-(total @ ext))                                    # (n, 32, 21)
        ray_ph, mie_ph = _phases(d @ sun)
        scatter = (ray_ph[:, None, None] * dens[..., :1] * RAYLEIGH
                   + (mie_ph[:, None] * dens[..., 1] * MIE_COEFF)[..., None])
        spec = np.einsum("nk,nkw->nw", lit * seg_len[:, None], atten * scatter) * IRRADIANCE
        out[a:a + chunk] = spec @ CMF * STEP_LAMBDA
    return out


@functools.lru_cache(maxsize=8)
def sky_lut(sun_elevation: float, altitude: float, air: float, aerosol: float, ozone: float,
            width: int = 512, height: int = 256) -> np.ndarray:
    """Cycles' sky texture (height, width, 3) XYZ, row 0 at the nadir: rows above the middle
    at latitude pi/2 (y / (h/2) - 1)^2 (more rows near the horizon), columns at longitude
    2 pi x / w - pi mirrored about the sun's meridian; rows below the horizon are the
    horizon's row faded to black (1 - 2.5 sin(latitude))^3."""
    altitude = min(max(altitude, 1.0), 59999.0)
    half_w, half_h = width // 2, height // 2
    sun = _geographic(sun_elevation, 0.0)
    lat = np.pi / 2 * (np.arange(half_h, height) / half_h - 1.0) ** 2
    lon = 2 * np.pi / width * np.arange(half_w) - np.pi
    dirs = _geographic(lat[:, None], lon[None, :]).reshape(-1, 3)
    upper = single_scattering_xyz(dirs, sun, altitude, air, aerosol, ozone)
    upper = upper.reshape(height - half_h, half_w, 3)
    lut = np.zeros((height, width, 3))
    lut[half_h:, :half_w] = upper
    lut[half_h:, half_w:] = upper[:, ::-1]
    z = np.sin(np.pi / 2 * (np.arange(half_h) / half_h - 1.0) ** 2)
    fade = np.where(z < 0.4, (1.0 - 2.5 * z) ** 3, 0.0)
    lut[:half_h] = lut[half_h][None] * fade[:, None, None]
    lut.setflags(write=False)
    return lut


def sun_pixels(sun_elevation, diameter, altitude, air, aerosol):
    """XYZ radiance of the sun disc at its lower and upper edge (black below the horizon): the
    irradiance through the air (Rayleigh and Mie, no ozone) over the disc's solid angle."""
    altitude = min(max(altitude, 1.0), 59999.0)
    half = diameter / 2.0
    solid = 2.0 * math.pi * (1.0 - math.cos(half))
    lo, hi = max(sun_elevation - half, 0.0), max(sun_elevation + half, 0.0)
    if hi <= 0.0:
        return np.zeros(3), np.zeros(3)
    cam = np.array([0.0, 0.0, EARTH_RADIUS + altitude])
    depth = _optical_depth(cam, _geographic(np.array([lo, hi]), 0.0))    # (2, 3)
    tau = np.outer(depth[:, 0] * air, RAYLEIGH) + np.outer(depth[:, 1] * aerosol,
                                                           np.full(21, 1.11 * MIE_COEFF))
    xyz = (IRRADIANCE * np.exp(-tau) / solid) @ CMF * STEP_LAMBDA
    return xyz[0], xyz[1]


def earth_intersection_angle(altitude: float) -> float:
    """The angle below the horizon at which the view meets the Earth (Blender's sky library:
    a 6371 km Earth, the altitude in m)."""
    return math.pi / 2 - math.asin(6371.0 / (6371.0 + altitude / 1000.0))
