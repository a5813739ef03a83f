"""The stochastic hash of the photons and the gather (the grid's bounds, the counts, the
selection's uniformity, unbiased and exact gathers) against the NumPy reference
(ppm_engine/oracle/reference.py), on every OpenCL device (test_kernels.py has the rest)."""

import numpy as np
import pytest

pytest.importorskip("pyopencl")
import pyopencl as cl

from ppm_engine.oracle import reference as ref
from ppm_engine.render.counters import N_COUNTERS, Counter
from ppm_engine.render.device import get_device
from ppm_engine.render.options import RenderOptions
from ppm_engine.render.passes import (
    Gather,
    GridSetup,
    HashBuild,
    Iteration,
    PassContext,
    VisiblePoints,
    unshaded,
)
from ppm_engine.render.photon_map import PhotonMap
from tests.helpers.device_buffers import DEVICES, read, upload

pytestmark = pytest.mark.gpu      # every kernel on every OpenCL device found, GPUs included


@pytest.fixture(params=DEVICES, scope="module")
def device(request):
    return get_device(request.param)


# --- stochastic hash ------------------------------------------------------------------------------
def _stored(n_ph):
    """The counters after a photon pass that stored n_ph photons."""
    c = np.zeros(N_COUNTERS, np.uint32)
    c[Counter.STORED] = n_ph
    return c


def _photon_setup(device, rng, n_ph=20000, n_vp=300, table=None, exact=False,
                  cell_scale=HashBuild.CELL_SCALE):
    """Photons on the plane z=0 sorted by x (order correlated with position, which breaks a
    last-writer selection), visible points on the same plane."""
    ph = np.c_[rng.uniform(0, 1, (n_ph, 2)), np.zeros(n_ph)]
    ph = ph[np.argsort(ph[:, 0])]
    flux = rng.uniform(0.5, 1.5, (n_ph, 3))
    up = np.tile([0.0, 0.0, 1.0], (n_ph, 1))
    wi = np.c_[rng.normal(size=(n_ph, 2)) * 0.3, np.ones(n_ph)]
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    wi[::7, 2] *= -1                       # some arrive from below: rejected
    vp = np.c_[rng.uniform(0.1, 0.9, (n_vp, 2)), np.zeros(n_vp)]
    radius = rng.uniform(0.01, 0.03, n_vp).astype(np.float32)
    pm = PhotonMap(device, n_ph, exact=exact)
    if table is not None:                  # force hash collisions between cells
        pm.table_size = table
    q = device.queue
    pos4 = np.zeros((n_ph, 4), np.float32)
    flux4 = np.zeros((n_ph, 4), np.float32)
    pos4[:, :3], flux4[:, :3] = ph, flux
    pos4.view(np.uint32)[:, 3] = ref.pack_unit(up)      # bit patterns, never through float64
    flux4.view(np.uint32)[:, 3] = ref.pack_unit(wi)
    cl.enqueue_copy(q, pm.ph_pos, pos4)
    cl.enqueue_copy(q, pm.ph_flux, flux4)
    counters = upload(device, _stored(n_ph))
    vp_pos = upload(device, np.c_[vp, np.ones(n_vp)].astype(np.float32))
    vp_nrm = upload(device, np.tile([0, 0, 1, 0], (n_vp, 1)).astype(np.float32))
    rad = upload(device, radius)
    # the visible points' path weight: the normals' buffer, any float4 of n
    vps = VisiblePoints(device, n_vp, pos=vp_pos, nrm=vp_nrm, beta=vp_nrm,
                        shade=unshaded(device, n_vp))
    ctx = PassContext(device, vps=vps, photon_map=pm, counters=counters, radius=rad)
    GridSetup(ctx, cell_scale=cell_scale).enqueue(q, _it(0, 0))
    return dict(pm=pm, hb=HashBuild(ctx), gather=Gather(ctx), ph=ph, flux=flux, up=up, wi=wi,
                vp=vp, radius=radius, counters=counters, n_vp=n_vp, gathered=vps.gathered)


def _it(pass_index, seed) -> Iteration:
    """Pass ``pass_index`` of a render with this seed."""
    return Iteration(pass_index, RenderOptions(seed=seed))


def test_grid_bounds_cover_visible_points(device):
    s = _photon_setup(device, np.random.default_rng(1))
    g = s["pm"].read_grid()
    lo = (s["vp"] - s["radius"][:, None]).min(axis=0)
    hi = (s["vp"] + s["radius"][:, None]).max(axis=0)
    np.testing.assert_allclose(g["bmin"], lo, rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(g["bmax"], hi, rtol=1e-6, atol=1e-7)
    assert g["r_max"] == pytest.approx(s["radius"].max())
    assert g["cell_size"] == pytest.approx(max(HashBuild.CELL_SCALE, 0.5) * s["radius"].max())
    assert g["valid"] == s["n_vp"]


@pytest.mark.parametrize("n_ph", [20000, 9999])     # 9999: the build's last batch is partial
def test_hash_counts_and_selected_photons(device, n_ph):
    s = _photon_setup(device, np.random.default_rng(2), n_ph=n_ph)
    pm, q = s["pm"], device.queue
    s["hb"].enqueue(q, _it(0, 1))
    counts, idx = pm.read_table()
    g = pm.read_grid()
    expect = ref.hash_counts(s["ph"], g["bmin"], g["inv_cell_size"], pm.table_size)
    assert counts.sum() == s["ph"].shape[0]                      # every stored photon counted
    assert (counts == expect).mean() > 0.999                     # float rounding at cell walls
    occupied = np.nonzero(counts)[0]
    h_sel = ref.cell_hash(ref.cell_of(s["ph"][idx[occupied]], g["bmin"], g["inv_cell_size"]),
                          pm.table_size - 1)
    assert (h_sel == occupied).all()                             # photon really hashed there
    assert read(device, s["counters"], N_COUNTERS, np.uint32)[Counter.OCCUPIED] == occupied.size


def test_selection_is_uniform_within_an_entry(device):
    """Each of the n photons of an entry is kept with probability 1/n (chi-square)."""
    s = _photon_setup(device, np.random.default_rng(3), n_ph=4000, n_vp=50)
    pm, q = s["pm"], device.queue
    trials = 300
    picks = []
    for t in range(trials):
        s["hb"].enqueue(q, _it(t, 5))
        counts, idx = pm.read_table()
        picks.append(idx.copy())
    picks = np.array(picks)
    counts = counts.astype(np.int64)
    entries = np.nonzero(counts >= 4)[0][:40]
    assert entries.size >= 10
    chi2, dof = 0.0, 0
    for e in entries:
        members, freq = np.unique(picks[:, e], return_counts=True)
        n = counts[e]
        full = np.zeros(n)
        full[: members.size] = freq
        chi2 += ((full - trials / n) ** 2 / (trials / n)).sum()
        dof += n - 1
    # chi-square with dof degrees of freedom: mean dof, sd sqrt(2 dof)
    assert chi2 < dof + 5 * np.sqrt(2 * dof), (chi2, dof)


def test_the_photon_kept_does_not_depend_on_the_order_photons_were_stored(device):
    """The photon pass stores photons in the order its threads reach an atomic counter, which
    changes with whatever else runs (a viewport beside a final render): the photon an entry
    keeps is the same with the photons stored in reverse order."""
    s = _photon_setup(device, np.random.default_rng(3), n_ph=4000, n_vp=50)
    pm, q = s["pm"], device.queue
    s["hb"].enqueue(q, _it(7, 5))
    counts, idx = pm.read_table()
    occupied = np.nonzero(counts)[0]
    kept = s["ph"][idx[occupied]]
    for buf in (pm.ph_pos, pm.ph_flux):
        a = np.empty((4000, 4), np.float32)
        cl.enqueue_copy(q, a, buf)
        cl.enqueue_copy(q, buf, np.ascontiguousarray(a[::-1]))
    s["hb"].enqueue(q, _it(7, 5))
    counts2, idx2 = pm.read_table()
    assert (counts2 == counts).all()
    assert (s["ph"][::-1][idx2[occupied]] == kept).all()
    assert (idx2[occupied] != idx[occupied]).mean() > 0.9          # the slots did change


@pytest.mark.parametrize("table,cell_scale", [(None, 0.5), (None, 2.0), (64, 0.5), (64, 1.0)])
def test_stochastic_gather_is_unbiased(device, table, cell_scale):
    """Mean over passes of the stochastic gather = the brute-force range sum (and it fails if
    an entry shared by two cells is counted twice, or the selection is not uniform)."""
    s = _photon_setup(device, np.random.default_rng(4 if table is None else 5), table=table,
                      cell_scale=cell_scale)
    q = device.queue
    n_vp = s["n_vp"]
    gathered = s["gathered"]
    trials = 200
    est = np.zeros((trials, n_vp, 4))
    for t in range(trials):
        s["hb"].enqueue(q, _it(t, 11))
        s["gather"].enqueue(q, _it(t, 11))
        est[t] = read(device, gathered, (n_vp, 4), np.float32)
    phi_ref, M_ref = ref.gather_exact(s["vp"], np.tile([0, 0, 1.0], (n_vp, 1)), s["radius"],
                                      s["ph"], s["up"], s["wi"], s["flux"])
    mean, se = est.mean(axis=0), est.std(axis=0, ddof=1) / np.sqrt(trials)
    for k, exact in ((3, M_ref), (0, phi_ref[:, 0]), (2, phi_ref[:, 2])):
        # the sum over all visible points, trial by trial: a z-test with its own spread
        total = est[:, :, k].sum(axis=1)
        z_total = (total.mean() - exact.sum()) / (total.std(ddof=1) / np.sqrt(trials))
        assert abs(z_total) < 4, (k, z_total)
        # each visible point with enough photons in reach
        many = M_ref >= 20
        z = (mean[many, k] - exact[many]) / se[many, k]
        assert np.abs(z).max() < 5.5, (k, np.abs(z).max())
    assert M_ref.mean() > 5                                       # the test has photons to find


@pytest.mark.parametrize("table", [None, 64])
def test_exact_gather_equals_brute_force(device, table):
    """The reference mode (photons sorted by entry with RadixSort) finds exactly the photons a
    brute-force range search finds."""
    s = _photon_setup(device, np.random.default_rng(6), n_ph=5000, table=table, exact=True)
    q, n_vp = device.queue, s["n_vp"]
    gathered = s["gathered"]
    s["hb"].enqueue(q, _it(0, 0))
    s["gather"].enqueue(q, _it(0, 0))
    got = read(device, gathered, (n_vp, 4), np.float32)
    phi_ref, M_ref = ref.gather_exact(s["vp"], np.tile([0, 0, 1.0], (n_vp, 1)), s["radius"],
                                      s["ph"], s["up"], s["wi"], s["flux"])
    assert M_ref.sum() > 100
    assert (got[:, 3] == M_ref).mean() > 0.99            # float rounding at the radius only
    np.testing.assert_allclose(got[:, 3].sum(), M_ref.sum(), rtol=1e-3)
    np.testing.assert_allclose(got[:, :3].sum(0), phi_ref.sum(0), rtol=1e-3)
