"""The multiple-scattering sky of Cycles' Sky Texture (Blender 5.0), precomputed on the host in
vectorised NumPy: the model of Blender's sky library (its sky_multiple_scattering.cpp), learnt
and written again here.

García Liñán's atmosphere (his Master's thesis, 2022; https://fgarlin.com/posts/2024-12-06-
spectral_sky/): four wavelengths (630, 560, 490, 430 nm) mapped to XYZ by a fitted matrix;
air (Rayleigh scattering falling as exp(-0.0777 h^1.1636), ozone absorption by a log-normal
profile), aerosols (exponential, 0.73 km, over a background density; Cornette-Shanks-like phase
g = 0.8); the sun's light reaching each point through a transmittance LUT (256 sun angles x 64
altitudes, 64 steps each); the light scattered more than once by a fitted term plus the
ground's (albedo 0.3) second bounce; the view ray marched in 64 steps with Hillaire's
energy-conserving integration of each step.  Distances in km over an Earth of 6371 km under
100 km of atmosphere.  The constants are the model's published data.
"""
from __future__ import annotations

import functools
import math

import numpy as np

EARTH_RADIUS, THICKNESS = 6371.0, 100.0
ATMOSPHERE_RADIUS = EARTH_RADIUS + THICKNESS
STEPS, T_STEPS, T_W, T_H = 64, 64, 256, 64
G = 0.8
GROUND_ALBEDO = 0.3
SUN_IRRADIANCE = np.array([1.679, 1.828, 1.986, 1.307])
MOLECULAR_SCATTERING = np.array([6.605e-3, 1.067e-2, 1.842e-2, 3.156e-2])
OZONE_CROSS_SECTION = np.array([3.472e-25, 3.914e-25, 1.349e-25, 11.03e-27])
OZONE_MEAN_DOBSON = 334.5
AEROSOL_ABSORPTION = np.array([2.8722e-24, 4.6168e-24, 7.9706e-24, 1.3578e-23])
AEROSOL_SCATTERING = np.array([1.5908e-22, 1.7711e-22, 2.0942e-22, 2.4033e-22])
AEROSOL_BASE, AEROSOL_BACKGROUND, AEROSOL_SCALE = 1.3681e20, 2e6, 0.73
SPECTRAL_XYZ = np.array([
    (53.386917738564668023, 22.981337506691024754, 0.0),
    (43.904844466369358263, 71.347795700053393866, 0.102506867965741307),
    (1.6137278251608962005, 18.422960591455485011, 31.742921188390805758),
    (20.762668673810577145, 2.3614213523314368527, 110.48009643252140334)])
MS_FIT = 0.02 * np.array([0.217, 0.347, 0.594, 1.0])


def _coefficients(h, air, aerosol, ozone):
    """(scattering by air, scattering by aerosols, extinction) (..., 4) at altitudes h (km)."""
    h = np.asarray(h, np.float64)[..., None]
    dens = AEROSOL_BASE * (np.exp(-h / AEROSOL_SCALE) + AEROSOL_BACKGROUND / AEROSOL_BASE) \
        * aerosol
    log_h = np.log(np.maximum(h, 1e-4))
    ozone_dens = 3.78547397e20 * np.exp(-(log_h - 3.22261) ** 2 * 5.55555555 - log_h)
    mol_abs = OZONE_CROSS_SECTION * OZONE_MEAN_DOBSON * ozone_dens * ozone
    mol_scat = MOLECULAR_SCATTERING * np.exp(-0.07771971 * h ** 1.16364243) * air
    aer_scat = AEROSOL_SCATTERING * dens
    return mol_scat, aer_scat, AEROSOL_ABSORPTION * dens + aer_scat + mol_abs + mol_scat


def _sphere_distance(p, d, radius):
    """Distance along unit d from p to the sphere about the Earth's centre (-1: none)."""
    r = np.asarray(radius, p.dtype)
    b = p[..., 0] * d[..., 0] + p[..., 1] * d[..., 1] + p[..., 2] * d[..., 2]
    c = p[..., 0] * p[..., 0] + p[..., 1] * p[..., 1] + p[..., 2] * p[..., 2] - r * r
    disc = b * b - c
    root = np.sqrt(np.maximum(disc, 0.0))
    t = np.where(disc >= b * b, -b + root, -b - root)
    return np.where((c > 0.0) & (b > 0.0) | (disc < 0.0), -1.0, t)


def _sun_dir(cos_theta):
    cos_theta = np.asarray(cos_theta, np.float64)
    return np.stack([-np.sqrt(np.maximum(1.0 - cos_theta ** 2, 0.0)),
                     np.zeros_like(cos_theta), cos_theta], -1)


def transmittance(cos_theta, altitude01, air, aerosol, ozone):
    """The transmittance (..., 4) towards a sun at cos_theta from the zenith, from a point at
    the normalised altitude (0: ground, 1: the atmosphere's top)."""
    cos_theta, altitude01 = np.broadcast_arrays(np.asarray(cos_theta, np.float64),
                                                np.asarray(altitude01, np.float64))
    d = _sun_dir(cos_theta)
    origin = np.zeros(d.shape)
    origin[..., 2] = EARTH_RADIUS + (ATMOSPHERE_RADIUS - EARTH_RADIUS) * altitude01
    dt = _sphere_distance(origin, d, ATMOSPHERE_RADIUS) / T_STEPS
    t = (np.arange(T_STEPS) + 0.5).reshape((-1,) + (1,) * dt.ndim) * dt   # (64, ...)
    x = origin + t[..., None] * d
    h = np.maximum(np.linalg.norm(x, axis=-1) - EARTH_RADIUS, 0.0)
    ext = _coefficients(h, air, aerosol, ozone)[2]
    return np.exp(-(ext * dt[..., None]).sum(0))


class _Lut:
    """The transmittance LUT and its lookups (as the library interpolates it)."""

    def __init__(self, air, aerosol, ozone):
        v, u = np.mgrid[0:T_H, 0:T_W] / np.array([T_H - 1, T_W - 1])[:, None, None]
        self.t = transmittance(u * 2.0 - 1.0, v, air, aerosol, ozone)      # (64, 256, 4)

    def __call__(self, cos_theta, altitude01):
        x = (T_W - 1) * np.clip(cos_theta * 0.5 + 0.5, 0.0, 1.0)
        y = (T_H - 1) * np.clip(altitude01, 0.0, 1.0)
        x1, y1 = x.astype(int), y.astype(int)
        x2, y2 = np.minimum(x1 + 1, T_W - 1), np.minimum(y1 + 1, T_H - 1)
        fx, fy = (x - x1)[..., None], (y - y1)[..., None]
        lo = self.t[y1, x1] + (self.t[y1, x2] - self.t[y1, x1]) * fx
        hi = self.t[y2, x1] + (self.t[y2, x2] - self.t[y2, x1]) * fx
        return lo + (hi - lo) * fy

    def multiscattering(self, cos_theta, altitude01, dist):
        """The fitted multiple scattering plus the ground's bounce (its second order)."""
        omega = 2 * np.pi * (1.0 - np.sqrt(np.maximum(1.0 - (EARTH_RADIUS / dist) ** 2, 0.0)))
        x = (T_W - 1) * np.clip(cos_theta * 0.5 + 0.5, 0.0, 1.0)     # at the ground
        x1 = x.astype(int)
        g = self.t[0]
        to_ground = g[x1] + (g[np.minimum(x1 + 1, T_W - 1)] - g[x1]) * (x - x1)[..., None]
        y = (T_H - 1) * np.clip(altitude01, 0.0, 1.0)                 # sun at the zenith
        y1 = y.astype(int)
        z = self.t[:, -1]
        to_sun = z[y1] + (z[np.minimum(y1 + 1, T_H - 1)] - z[y1]) * (y - y1)[..., None]
        ground = (1.0 / (4 * np.pi)) * omega[..., None] * (GROUND_ALBEDO / np.pi) * to_ground \
            * (z[0] / to_sun) * cos_theta[..., None]
        fit = MS_FIT / (1.0 + 5.0 * np.exp(-17.92 * cos_theta))[..., None]
        return fit + ground


def _inscattering(lut, sun, origin, dirs, t_d, air, aerosol, ozone):
    """Spectral radiance (n, 4) scattered towards the viewer along dirs (n, 3)."""
    mu = -(dirs @ sun)
    mol_phase = 3.0 / (16.0 * np.pi) * (1.0 + mu * mu)
    den = 1.0 + G * G + 2.0 * G * mu
    aer_phase = (1.0 - G * G) / (4 * np.pi * den * np.sqrt(den))
    dt = t_d / STEPS
    t = (np.arange(STEPS) + 0.5)[None, :] * dt[:, None]                   # (n, 64)
    x = origin + t[..., None] * dirs[:, None, :]
    dist = np.linalg.norm(x, axis=-1)
    h = np.maximum(dist - EARTH_RADIUS, 0.0)
    alt01 = h / THICKNESS
    cos_sun = (x @ sun) / dist
    mol, aer, ext = _coefficients(h, air, aerosol, ozone)
    to_sun = lut(cos_sun, alt01)
    ms = lut.multiscattering(cos_sun, alt01, dist)
    S = SUN_IRRADIANCE * (mol * (mol_phase[:, None, None] * to_sun + ms)
                          + aer * (aer_phase[:, None, None] * to_sun + ms))
    step = np.exp(-dt[:, None, None] * ext)
    s_int = (S - S * step) / np.maximum(ext, 1e-7)
    before = np.concatenate([np.ones_like(step[:, :1]), np.cumprod(step, 1)[:, :-1]], 1)
    return (before * s_int).sum(1)


@functools.lru_cache(maxsize=8)
def sky_lut(sun_elevation, altitude, air, aerosol, ozone, width=512, height=256):
    """Cycles' multiple-scattering sky texture (height, width, 3) XYZ, row 0 at the nadir:
    texel (x, y) at azimuth 2 pi (x + 0.5) / w (mirrored about the sun's), elevation
    l |l| pi / 2 with l = 2 (y + 0.5) / h - 1; rays that meet the ground end there."""
    lut = _Lut(air, aerosol, ozone)
    alt = min(max(altitude, 1.0), 99999.0) / 1000.0
    sun = _sun_dir(math.cos(math.pi / 2 - sun_elevation))
    half = width // 2
    # the view rays and their lengths in single precision, as the library computes them: the
    # distance to the ground of a ray from a low viewer is that precision's (3 % off at 1 m)
    f = np.float32
    az = f(2 * np.pi) * ((np.arange(half, dtype=f) + f(0.5)) / f(width))
    ll = (np.arange(height, dtype=f) + f(0.5)) / f(height) * f(2.0) - f(1.0)
    el = np.copysign(ll * ll, ll) * f(np.pi / 2)
    el, az = np.broadcast_arrays(el[:, None], az[None, :])
    dirs = np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)],
                    -1).reshape(-1, 3)
    origin = np.array([0.0, 0.0, f(EARTH_RADIUS) + f(alt)], f)
    atmos = _sphere_distance(origin, dirs, ATMOSPHERE_RADIUS)
    ground = _sphere_distance(origin, dirs, EARTH_RADIUS)
    t_d = np.where(ground < 0.0, atmos, ground).astype(np.float64)
    dirs, origin = dirs.astype(np.float64), origin.astype(np.float64)
    xyz = np.empty((len(dirs), 3))
    for a in range(0, len(dirs), 2048):
        s = slice(a, a + 2048)
        xyz[s] = _inscattering(lut, sun, origin, dirs[s], t_d[s], air, aerosol,
                               ozone) @ SPECTRAL_XYZ
    xyz = xyz.reshape(height, half, 3)
    out = np.concatenate([xyz, xyz[:, ::-1]], 1)
    out.setflags(write=False)
    return out


def sun_pixels(sun_elevation, diameter, altitude, air, aerosol, ozone):
    """XYZ radiance of the sun disc at its lower and upper edge: the irradiance through the
    atmosphere over the disc's solid angle."""
    alt01 = min(max(altitude, 1.0), 99999.0) / 1000.0 / THICKNESS
    half = diameter / 2.0
    solid = 2 * math.pi * (1.0 - math.cos(half))
    cos = np.cos(np.pi / 2 - np.array([sun_elevation - half, sun_elevation + half]))
    spec = SUN_IRRADIANCE * transmittance(cos, alt01, air, aerosol, ozone) / solid
    xyz = spec @ SPECTRAL_XYZ
    return xyz[0], xyz[1]
