"""Photon guides (ppm_engine/scene/guide.py, kernels/light/guide.h): a light outside a room lit
through a small window sends its guided photons through the window, and the room receives the
same light per emitted photon as from photons in the light's own distribution, for every kind
of light guided; the bins' native shares are the lights' own distributions (brute force)."""
import numpy as np
import pyopencl as cl
import pytest

from ppm_engine.oracle.procedural import gap_room
from ppm_engine.render.renderer import Renderer
from ppm_engine.scene.guide import (
    GUIDE_BINS,
    GUIDE_COLS,
    GUIDE_NATIVE,
    GUIDE_ROWS,
    Guides,
    native_mass,
)
from tests.helpers.renders import every_feature


def room_flux(scene, guided: bool, passes: int, photons: int, seed=0):
    """Per pass: the flux stored on the room's floor per emitted photon, in its halves y < 0
    and y >= 0, and the Renderer's photons stored per photon emitted over the passes."""
    r = Renderer(scene, every_feature(seed=seed, indirect="photons", light_tracing=False,
                                      photons_per_pass=photons, skip_unguided_photons=guided))
    out, stored = [], 0
    for _ in range(passes):
        st = r.iterate()
        n = min(st.photons_stored, r.photon_map.capacity)
        stored += n
        pos, flux = np.empty((max(n, 1), 4), np.float32), np.empty((max(n, 1), 4), np.float32)
        cl.enqueue_copy(r.queue, pos, r.photon_map.ph_pos)
        cl.enqueue_copy(r.queue, flux, r.photon_map.ph_flux)
        pos, flux = pos[:n], flux[:n]
        floor = (np.abs(pos[:, 2]) < 1e-3) & (np.abs(pos[:, 0]) < 2) & (np.abs(pos[:, 1]) < 2)
        half = (pos[:, 1] >= 0).astype(int)
        out.append(np.bincount(half[floor], flux[floor, :3].mean(axis=1), minlength=2)
                   / r.photon_count)
    assert r.guided == guided
    g = r.scene.guides
    r.close()
    return np.array(out), stored / (passes * r.photon_count), g


@pytest.mark.parametrize("kind", ["point", "sphere", "spot", "area"])
def test_guided_photons_bring_the_room_the_light_all_photons_bring(kind):
    scene = gap_room(24, 24, kind)
    passes = 24
    guided, yield_g, g = room_flux(scene, True, passes, 1 << 14)
    plain, yield_p, _ = room_flux(scene, False, passes, 1 << 14)
    assert len(g) == 1 and g.native[0] == GUIDE_NATIVE        # learned
    mg, mp = guided.mean(axis=0), plain.mean(axis=0)
    se = np.sqrt(guided.var(axis=0, ddof=1) / passes + plain.var(axis=0, ddof=1) / passes)
    assert mp.sum() > 0
    assert np.all(np.abs(mg - mp) <= 4.5 * se), (kind, mg, mp, se)
    # the guide sends the photons through the window: more stored per photon emitted, and
    # less noise per pass on the floor (an area light's cosine already favours the window,
    # and from across its 0.5 m the window lies in many directions: the guide, by direction
    # only, gains less there)
    assert yield_g > (1.5 if kind == "area" else 2.0) * yield_p, (yield_g, yield_p)
    late = slice(8, None)           # once learned (after passes 1, 2, 4 and 8)
    ratio = guided[late].var(axis=0, ddof=1).sum() / plain[late].var(axis=0, ddof=1).sum()
    assert ratio < (0.8 if kind == "area" else 0.5), ratio


def _bins(d, axis, zmin):
    """The bin of each direction (light/guide.h guide_bin), with the kernels' frame."""
    n = np.asarray(axis, np.float64)
    sign = np.copysign(1.0, n[2])
    a = -1.0 / (sign + n[2])
    bb = n[0] * n[1] * a
    t = np.array([1.0 + sign * n[0] * n[0] * a, sign * bb, -sign * n[0]])
    b = np.array([bb, sign + n[1] * n[1] * a, -n[1]])
    z = d @ n
    row = np.clip(((z - zmin) / (1 - zmin) * GUIDE_ROWS).astype(int), 0, GUIDE_ROWS - 1)
    turns = np.arctan2(d @ b, d @ t) / (2 * np.pi) % 1.0
    col = np.clip((turns * GUIDE_COLS).astype(int), 0, GUIDE_COLS - 1)
    return row * GUIDE_COLS + col


@pytest.mark.parametrize("kind", ["point", "spot", "area"])
def test_native_shares_are_the_lights_own_distributions(kind):
    """Each bin's native share against directions drawn from the light's own distribution
    (power-weighted for the spot's falloff) and binned."""
    L = gap_room(8, 8, kind).lights[0]
    g = Guides(np.array([L]), np.array([1.0]))
    zmin = g.zmin[0]
    rng = np.random.default_rng(1)
    n = 400_000
    axis = L["direction"] if kind != "point" else (0.0, 0.0, 1.0)
    if kind == "area":      # cosine-weighted hemisphere
        u1, u2 = rng.random(n), rng.random(n)
        r, phi = np.sqrt(u1), 2 * np.pi * u2
        local = np.c_[r * np.cos(phi), r * np.sin(phi), np.sqrt(1 - u1)]
        weight = np.ones(n)
    else:                   # uniform over the sphere (a point) or the spot's cone, weighted
        z = zmin + (1 - zmin) * rng.random(n)
        phi = 2 * np.pi * rng.random(n)
        s = np.sqrt(1 - z * z)
        local = np.c_[s * np.cos(phi), s * np.sin(phi), z]
        weight = np.ones(n)
        if kind == "spot":
            c0, sm = float(L["spot_cos_half"]), float(L["spot_smooth"])
            x = np.clip((z - c0) / sm, 0, 1)
            weight = x * x * (3 - 2 * x)
    # to world with an arbitrary frame around the axis: the bins' azimuth origin is the
    # kernels', so rotate with that frame
    nz = np.asarray(axis, np.float64)
    sign = np.copysign(1.0, nz[2])
    a = -1.0 / (sign + nz[2])
    bb = nz[0] * nz[1] * a
    t = np.array([1.0 + sign * nz[0] * nz[0] * a, sign * bb, -sign * nz[0]])
    b = np.array([bb, sign + nz[1] * nz[1] * a, -nz[1]])
    d = local[:, :1] * t + local[:, 1:2] * b + local[:, 2:] * nz
    hist = np.bincount(_bins(d, nz, zmin), weight, minlength=GUIDE_BINS)
    hist /= hist.sum()
    m = g.mass[0]
    assert m.shape == (GUIDE_BINS,) and m.sum() == pytest.approx(1.0)
    big = m > 0.2 / GUIDE_BINS
    # per bin: the binomial spread of the histogram, 5 sigma
    sd = np.sqrt(m * (1 - m) / n) * 1.5 + 1e-9
    assert np.all(np.abs(hist - m)[big] < 5 * sd[big] + 0.01 * m[big]), kind
    assert native_mass(L, zmin).sum() == pytest.approx(1.0)
