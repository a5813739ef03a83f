"""Every kernel against the NumPy reference (ppm_engine/oracle/reference.py), on every OpenCL
device."""
import numpy as np
import pytest

pytest.importorskip("pyopencl")
import pyopencl as cl

from ppm_engine.oracle import reference as ref
from ppm_engine.oracle.procedural import MeshBuilder, look_at
from ppm_engine.render.bvh import BVH
from ppm_engine.render.counters import N_COUNTERS, Counter
from ppm_engine.render.device import get_device, list_devices
from ppm_engine.render.device_scene import placeholders
from ppm_engine.render.passes import Gather, HashBuild, unshaded
from ppm_engine.render.photon_map import GRID_DTYPE, PhotonMap
from ppm_engine.scene.arrays import CAMERA_DTYPE, LIGHT_DTYPE
from ppm_engine.scene.camera import make_camera
from ppm_engine.scene.emitters import EMITTER_INFO_DTYPE
from ppm_engine.scene.materials import KMATERIAL_DTYPE

DEVICES = [d.key for d in list_devices()]

pytestmark = pytest.mark.gpu      # every kernel on every OpenCL device found, GPUs included


@pytest.fixture(params=DEVICES, scope="module")
def device(request):
    return get_device(request.param)


def _upload(dev, a):
    return cl.Buffer(dev.context, cl.mem_flags.READ_WRITE | cl.mem_flags.COPY_HOST_PTR,
                     hostbuf=np.ascontiguousarray(a))


def _read(dev, buf, shape, dtype):
    out = np.empty(shape, dtype)
    cl.enqueue_copy(dev.queue, out, buf)
    return out


def test_struct_layouts_match_dtypes(device):
    out = cl.Buffer(device.context, cl.mem_flags.WRITE_ONLY, 4 * 8)
    device.programs.get("test/debug.cl").struct_sizes(device.queue, (1,), None, out)
    sizes = _read(device, out, 8, np.uint32)[:5]
    assert list(sizes) == [LIGHT_DTYPE.itemsize, CAMERA_DTYPE.itemsize, KMATERIAL_DTYPE.itemsize,
                           EMITTER_INFO_DTYPE.itemsize, GRID_DTYPE.itemsize]


# --- ray tracing -------------------------------------------------------------------------------
def _random_scene(rng, n):
    mb = MeshBuilder()
    m = mb.material("m")
    centers = rng.uniform(-1, 1, (n, 1, 3))
    tris = centers + rng.normal(0, 0.08, (n, 3, 3))
    tris[: n // 10] = rng.uniform(-1.5, 1.5, (n // 10, 3, 3))      # some large ones
    tris[n // 10: n // 10 + 50] = tris[n // 10]                     # duplicates (equal codes)
    mb.add(tris, m)
    cam = make_camera(width=4, height=4, to_world=look_at((0, -5, 0), (0, 0, 0)), extent=(1, 1))
    return mb.build(camera=cam)


def _trace(device, bvh, o, d, tmax, any_hit=False, mask=0xFFFFFFFF):
    n = o.shape[0]
    ob = _upload(device, np.c_[o, np.zeros(n)].astype(np.float32))
    db = _upload(device, np.c_[d, tmax].astype(np.float32))
    hits = cl.Buffer(device.context, cl.mem_flags.READ_WRITE, 16 * n)
    device.programs.get("test/debug.cl").launch("trace_rays", "test")(
        device.queue, n, **placeholders(device, **bvh.args), origins=ob, dirs=db,
        mask=np.uint32(mask), any_hit=np.int32(any_hit), hits=hits, n=np.uint32(n))
    h = _read(device, hits, (n, 4), np.float32)
    return h[:, 0], h[:, 3].view(np.int32)


@pytest.mark.parametrize("n_tris", [1, 2, 3, 2000])
def test_bvh_closest_hit_equals_brute_force(device, n_tris):
    rng = np.random.default_rng(n_tris)
    scene = _random_scene(rng, n_tris) if n_tris > 3 else None
    if scene is None:
        mb = MeshBuilder()
        mb.add(rng.uniform(-1, 1, (n_tris, 3, 3)), mb.material("m"))
        scene = mb.build(camera=make_camera(width=4, height=4, to_world=np.eye(4)[:3],
                                            extent=(1, 1)))
    bvh = BVH(device, scene)
    n = 3000
    o = rng.uniform(-2, 2, (n, 3))
    target = rng.uniform(-1, 1, (n, 3))
    # half the rays aim at a random point on a random triangle
    k = rng.integers(0, scene.n_triangles, n // 2)
    b = rng.dirichlet((1, 1, 1), n // 2)
    target[: n // 2] = np.einsum("nk,nkj->nj", b, scene.positions[k])
    d = target - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    tmax = np.where(rng.random(n) < 0.2, rng.uniform(0.5, 2, n), 1e30)
    t, idx = _trace(device, bvh, o, d, tmax)
    t_ref, i_ref = ref.closest_hits(o, d, tmax, scene.positions)
    assert ((t < 0) == (t_ref < 0)).mean() > 0.999          # grazing edge cases only
    both = (t >= 0) & (t_ref >= 0)
    # float32 t is ill-conditioned at grazing incidence: error bound ~ eps * t / |cos|
    p = scene.positions[np.maximum(i_ref, 0)].astype(np.float64)
    nrm = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    cos = np.abs((nrm * d).sum(1)) / np.maximum(np.linalg.norm(nrm, axis=1), 1e-30)
    tol = 1e-5 + 2e-5 * (np.abs(o).max(1) + np.abs(t_ref)) / np.maximum(cos, 1e-6)
    assert (np.abs(t - t_ref)[both] <= tol[both]).all()
    same_t = np.isclose(t, t_ref, rtol=1e-5, atol=1e-6)
    assert (idx[both & ~same_t] == i_ref[both & ~same_t]).all()
    assert (idx[both] == i_ref[both]).mean() > 0.99         # ties between coplanar duplicates
    assert (t_ref >= 0).sum() > n // 3                      # the test really hits things
    # any-hit (shadow) queries agree on occlusion
    t_any, _ = _trace(device, bvh, o, d, tmax, any_hit=True)
    assert ((t_any >= 0) == (t_ref >= 0)).mean() > 0.999


def test_bvh_axis_parallel_rays_equal_brute_force(device):
    """Rays with zero direction components (orthographic cameras, axis-aligned walls), some with
    zero origin components too, against boxes that are flat along an axis (a floor, a quad)."""
    rng = np.random.default_rng(5)
    mb = MeshBuilder()
    m = mb.material("m")
    mb.quad((0, 0, 0), (1, 0, 0), (0, 1, 0), m)              # flat in z: a zero-height box
    mb.quad((0, 0, 1), (0.5, 0, 0), (0, 0, 0.5), m)          # flat in y
    mb.add(rng.uniform(-1, 1, (200, 3, 3)) * [1, 1, 0.2] + [0, 0, 2], m)
    scene = mb.build(camera=make_camera(width=4, height=4, to_world=np.eye(4)[:3], extent=(1, 1)))
    bvh = BVH(device, scene)
    n = 3000
    axis = rng.integers(0, 3, n)
    d = np.zeros((n, 3))
    d[np.arange(n), axis] = rng.choice([-1.0, 1.0], n)
    o = rng.uniform(-1.0, 1.0, (n, 3))
    o[np.arange(n), axis] = -3.0 * d[np.arange(n), axis]     # start outside, look inwards
    zero = rng.random((n, 3)) < 0.2                          # exact zeros off the ray's axis
    zero[np.arange(n), axis] = False
    o[zero] = 0.0
    tmax = np.full(n, 1e30)
    t, _idx = _trace(device, bvh, o, d, tmax)
    t_ref, _i_ref = ref.closest_hits(o, d, tmax, scene.positions)
    assert (t_ref >= 0).sum() > n // 4
    assert ((t < 0) == (t_ref < 0)).mean() > 0.999
    both = (t >= 0) & (t_ref >= 0)
    np.testing.assert_allclose(t[both], t_ref[both], atol=1e-5)


def test_bvh_refit_equals_a_fresh_build(device):
    """A refitted BVH answers ray queries exactly as a BVH built from the moved triangles."""
    from ppm_engine.oracle.procedural import cornell_box
    dev = device
    scene = cornell_box(8, 8)
    bvh = BVH(dev, scene)
    pos = scene.positions.copy()
    pos[-24:] += np.float32([0.05, -0.1, 0.0])               # the short box moved
    moved = scene.replace(positions=pos)
    assert bvh.refit(moved)
    assert 0.9 < bvh.cost / bvh.built_cost < BVH.REFIT_MAX_COST     # a small move: a tree as good
    fresh = BVH(dev, moved)
    rng = np.random.default_rng(1)
    o = rng.uniform(-0.9, 0.9, (4000, 3)) + [0, 0, 1]
    d = rng.normal(size=(4000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    t1, i1 = _trace(dev, bvh, o, d, np.full(4000, 1e30))
    t2, i2 = _trace(dev, fresh, o, d, np.full(4000, 1e30))
    np.testing.assert_allclose(t1, t2, rtol=1e-6)
    assert (i1 == i2).mean() > 0.99         # the rest: ties on the shared edge of a quad's halves
    far = pos.copy()
    far[-24:] += np.float32([40.0, 0, 0])                   # the box 40 m away: refused
    assert not bvh.refit(scene.replace(positions=far))
    t3, _ = _trace(dev, bvh, o, d, np.full(4000, 1e30))     # and the BVH is left as it was
    np.testing.assert_allclose(t3, t1, rtol=1e-6)


@pytest.mark.parametrize("method", ["ploc", "lbvh"])
def test_bvh_host_primitives_build_the_device_s_tree(device, method, monkeypatch):
    """Small scenes sort, scan and sum areas in NumPy (BVH.HOST_PRIMITIVES): the tree that
    pyopencl's radix sort, scan and reduction build.  LBVH's is the same node for node; PLOC
    numbers its nodes in the order threads merge them, so there the same leaves, cost and
    answers to rays."""
    rng = np.random.default_rng(11)
    scene = _random_scene(rng, 3000)
    o = rng.uniform(-1.5, 1.5, (3000, 3))
    d = rng.normal(size=(3000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    q = device.queue
    trees = []
    for limit in (1 << 14, 0):                 # the host's primitives, then the device's
        monkeypatch.setattr(BVH, "HOST_PRIMITIVES", limit)
        bvh = BVH(device, scene, method=method)
        nodes = np.empty((2999, 4, 4), np.uint32)          # (w holds child indices)
        cl.enqueue_copy(q, nodes, bvh.nodes)
        trees.append((nodes, bvh.leaf_order, bvh.cost, _trace(device, bvh, o, d,
                                                              np.full(3000, 1e30))))
    (n1, l1, c1, (t1, i1)), (n2, l2, c2, (t2, i2)) = trees
    assert np.array_equal(l1, l2)
    assert c1 == pytest.approx(c2, rel=1e-5) and c1 > 1.0
    assert ((t1 > 0) & (t1 < 1e29)).sum() > 300            # rays that hit something
    np.testing.assert_array_equal(t1, t2)
    assert np.array_equal(i1, i2)
    if method == "lbvh":
        assert np.array_equal(n1, n2)


def test_bvh_visibility_mask(device):
    rng = np.random.default_rng(7)
    scene = _random_scene(rng, 500)
    vis = np.where(np.arange(500) % 2 == 0, 1, 2).astype(np.uint32)
    scene = scene.replace(visibility=vis)
    bvh = BVH(device, scene)
    o = rng.uniform(-2, 2, (1000, 3))
    d = rng.normal(size=(1000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    tmax = np.full(1000, 1e30)
    t, idx = _trace(device, bvh, o, d, tmax, mask=1)
    keep = vis == 1
    t_ref, _i_ref = ref.closest_hits(o, d, tmax, scene.positions[keep])
    assert ((t >= 0) == (t_ref >= 0)).mean() > 0.999
    assert (vis[idx[t >= 0]] == 1).all()


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
    counters = _upload(device, _stored(n_ph))
    vp_pos = _upload(device, np.c_[vp, np.ones(n_vp)].astype(np.float32))
    vp_nrm = _upload(device, np.tile([0, 0, 1, 0], (n_vp, 1)).astype(np.float32))
    rad = _upload(device, radius)
    hb = HashBuild(device, pm, counters, cell_scale=cell_scale)
    hb.grid(q, vp_pos, rad, n_vp)
    return dict(pm=pm, hb=hb, gather=Gather(device, pm), ph=ph, flux=flux, up=up, wi=wi, vp=vp,
                radius=radius, counters=counters, vp_pos=vp_pos, vp_nrm=vp_nrm,
                vp_shade=unshaded(device, n_vp), rad=rad, n_vp=n_vp)


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
    s["hb"].build(q, 0, 1)
    counts, idx = pm.read_table()
    g = pm.read_grid()
    expect = ref.hash_counts(s["ph"], g["bmin"], g["inv_cell_size"], pm.table_size)
    assert counts.sum() == s["ph"].shape[0]                      # every stored photon counted
    assert (counts == expect).mean() > 0.999                     # float rounding at cell walls
    occupied = np.nonzero(counts)[0]
    h_sel = ref.cell_hash(ref.cell_of(s["ph"][idx[occupied]], g["bmin"], g["inv_cell_size"]),
                          pm.table_size - 1)
    assert (h_sel == occupied).all()                             # photon really hashed there
    assert _read(device, s["counters"], N_COUNTERS, np.uint32)[Counter.OCCUPIED] == occupied.size


def test_selection_is_uniform_within_an_entry(device):
    """Each of the n photons of an entry is kept with probability 1/n (chi-square)."""
    s = _photon_setup(device, np.random.default_rng(3), n_ph=4000, n_vp=50)
    pm, q = s["pm"], device.queue
    trials = 300
    picks = []
    for t in range(trials):
        s["hb"].build(q, t, 5)
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


@pytest.mark.parametrize("table,cell_scale", [(None, 0.5), (None, 2.0), (64, 0.5), (64, 1.0)])
def test_stochastic_gather_is_unbiased(device, table, cell_scale):
    """Mean over passes of the stochastic gather = the brute-force range sum (and it fails if
    an entry shared by two cells is counted twice, or the selection is not uniform)."""
    s = _photon_setup(device, np.random.default_rng(4 if table is None else 5), table=table,
                      cell_scale=cell_scale)
    q = device.queue
    n_vp = s["n_vp"]
    gathered = cl.Buffer(device.context, cl.mem_flags.READ_WRITE, 16 * n_vp)
    trials = 200
    est = np.zeros((trials, n_vp, 4))
    for t in range(trials):
        s["hb"].build(q, t, 11)
        s["gather"].enqueue(q, s["vp_pos"], s["vp_nrm"], s["vp_shade"], s["rad"], gathered, n_vp)
        est[t] = _read(device, gathered, (n_vp, 4), np.float32)
    phi_ref, M_ref = ref.gather_exact(s["vp"], np.tile([0, 0, 1.0], (n_vp, 1)), s["radius"],
                                      s["ph"], s["up"], s["wi"], s["flux"])
    mean, se = est.mean(axis=0), est.std(axis=0, ddof=1) / np.sqrt(trials)
    for k, exact in ((3, M_ref), (0, phi_ref[:, 0]), (2, phi_ref[:, 2])):
        # the sum over all visible points, trial by trial: a z-test with its own spread
        total = est[:, :, k].sum(axis=1)
        z_total = (total.mean() - exact.sum()) / (total.std(ddof=1) / np.sqrt(trials))
        assert abs(z_total) < 5, (k, z_total)
        # each visible point with enough photons in reach
        many = M_ref >= 20
        z = (mean[many, k] - exact[many]) / se[many, k]
        assert np.abs(z).max() < 5.5, (k, np.abs(z).max())
    if table is None:
        assert mean[:, 3].sum() == pytest.approx(M_ref.sum(), rel=0.01)
    assert M_ref.mean() > 5                                       # the test has photons to find


@pytest.mark.parametrize("table", [None, 64])
def test_exact_gather_equals_brute_force(device, table):
    """The reference mode (photons sorted by entry with RadixSort) finds exactly the photons a
    brute-force range search finds."""
    s = _photon_setup(device, np.random.default_rng(6), n_ph=5000, table=table, exact=True)
    q, n_vp = device.queue, s["n_vp"]
    gathered = cl.Buffer(device.context, cl.mem_flags.READ_WRITE, 16 * n_vp)
    s["hb"].build(q, 0, 0)
    s["gather"].enqueue(q, s["vp_pos"], s["vp_nrm"], s["vp_shade"], s["rad"], gathered, n_vp)
    got = _read(device, gathered, (n_vp, 4), np.float32)
    phi_ref, M_ref = ref.gather_exact(s["vp"], np.tile([0, 0, 1.0], (n_vp, 1)), s["radius"],
                                      s["ph"], s["up"], s["wi"], s["flux"])
    assert M_ref.sum() > 100
    assert (got[:, 3] == M_ref).mean() > 0.99            # float rounding at the radius only
    np.testing.assert_allclose(got[:, 3].sum(), M_ref.sum(), rtol=1e-3)
    np.testing.assert_allclose(got[:, :3].sum(0), phi_ref.sum(0), rtol=1e-3)


# --- progressive update ---------------------------------------------------------------------------
def test_progressive_update_equals_closed_form(device):
    rng = np.random.default_rng(9)
    n = 1000
    valid = (rng.random(n) < 0.9).astype(np.float32)
    M = np.where(rng.random(n) < 0.2, 0, rng.integers(1, 500, n)).astype(np.float32)
    phi = rng.uniform(0, 10, (n, 3)).astype(np.float32)
    beta = rng.uniform(0, 1, (n, 3)).astype(np.float32)
    N = rng.uniform(0, 1000, n).astype(np.float32)
    R = rng.uniform(1e-3, 1, n).astype(np.float32)
    tau = rng.uniform(0, 100, (n, 3)).astype(np.float32)
    alpha = 0.7
    f4 = lambda a, w=0: np.c_[a, np.full(n, w)].astype(np.float32)
    vp_pos = _upload(device, np.c_[np.zeros((n, 3)), valid].astype(np.float32))
    bufs = dict(beta=_upload(device, f4(beta)), g=_upload(device, np.c_[phi, M].astype(np.float32)),
                R=_upload(device, R), N=_upload(device, N), tau=_upload(device, f4(tau)))
    device.programs.get("integrator/progressive.cl").progressive_update(
        device.queue, (n,), None, vp_pos, bufs["beta"], bufs["g"], bufs["R"], bufs["N"],
        bufs["tau"], np.float32(alpha), np.uint32(n))
    M_eff = np.where(valid > 0, M, 0)
    N_ref, R_ref, tau_ref = ref.ppm_update(alpha, M_eff, beta * phi, N, R, tau)
    np.testing.assert_allclose(_read(device, bufs["N"], n, np.float32), N_ref, rtol=1e-5)
    np.testing.assert_allclose(_read(device, bufs["R"], n, np.float32), R_ref, rtol=1e-5)
    np.testing.assert_allclose(_read(device, bufs["tau"], (n, 4), np.float32)[:, :3], tau_ref,
                               rtol=1e-5)
    assert (R_ref <= R + 1e-7).all() and (R_ref[M_eff > 0] < R[M_eff > 0]).all()


def test_counter_table_matches_the_kernel_header():
    """kernels/shared.h (generated) and ppm_engine/render/counters.py state the same indices."""
    import re

    from ppm_engine.render.device import kernel_dir
    text = (kernel_dir() / "shared.h").read_text()
    header = {m[1]: int(m[2]) for m in re.finditer(r"#define CNT_(\w+) (\d+)", text)}
    assert header == {c.name: int(c) for c in Counter}
    assert int(re.search(r"#define N_COUNTERS (\d+)", text)[1]) == N_COUNTERS


def _debug_run(device, kernel, n, inputs, out_shape, out_dtype=np.float32):
    bufs = [_upload(device, a) for a in inputs]
    out = cl.Buffer(device.context, cl.mem_flags.WRITE_ONLY, int(np.prod(out_shape)) * 4)
    getattr(device.programs.get("test/debug.cl"), kernel)(device.queue, (n,), None, *bufs,
                                                        np.uint32(n), out)
    return _read(device, out, out_shape, out_dtype)


def test_inline_builtins_equal_numpy(device):
    """kernels/builtins.h (PoCL's builtins as inline code) against NumPy: fmin and fmax keep the
    non-NaN argument, clamp is fmin(fmax), length and normalize hold for vectors whose squared
    length overflows or underflows a float (the library's fallback), the rest to rounding."""
    rng = np.random.default_rng(5)
    n = 4096
    x = rng.normal(size=(n, 4)).astype(np.float32) * 3
    y = rng.normal(size=(n, 4)).astype(np.float32) * 3
    x[:64] *= np.float32(1e25)                    # squared length over FLT_MAX
    x[64:128] *= np.float32(1e-25)                # under FLT_MIN
    x[128:136] = 0.0                              # normalize(0) and length(0)
    x[136:160, 3] = np.nan                        # fmin/fmax: the other argument
    y[160:184, :3] = np.nan
    out = _debug_run(device, "builtins_at", n, [x, y], (n, 8, 4)).astype(np.float64)
    x64, y64, x3 = x.astype(np.float64), y.astype(np.float64), x[:, :3]
    close = dict(rtol=2e-6, atol=1e-6)
    np.testing.assert_array_equal(out[:, 0], np.fmin(x, y))
    np.testing.assert_array_equal(out[:, 1], np.fmax(x, y))
    np.testing.assert_array_equal(out[:, 2, :3], np.fmin(np.fmax(x3, -1), 1))
    ok = np.isfinite(x64[:, 3])
    lo, hi = np.fmin(y[:, 3], 0), np.fmax(y[:, 3], 0)
    np.testing.assert_array_equal(out[ok, 2, 3], np.fmin(np.fmax(x[ok, 3], lo[ok]), hi[ok]))
    fin = np.isfinite(x64).all(1) & np.isfinite(y64).all(1) & (np.abs(x64) < 1e20).all(1)
    mix = x64[:, :3] + (y64[:, :3] - x64[:, :3]) * 0.25
    np.testing.assert_allclose(out[fin, 3, :3], mix[fin], **close)
    np.testing.assert_allclose(out[fin, 3, 3], (x64[:, :3] * y64[:, :3]).sum(1)[fin],
                               rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(out[fin, 4, :3], np.cross(x64[:, :3], y64[:, :3])[fin],
                               rtol=1e-5, atol=1e-5)
    norm = np.linalg.norm(x64[:, :3], axis=1)
    np.testing.assert_allclose(out[:, 4, 3], norm, rtol=2e-6)      # tiny and huge ones too
    nz = norm > 0
    np.testing.assert_allclose(out[nz, 5, :3], x64[nz, :3] / norm[nz, None], rtol=2e-6,
                               atol=1e-7)
    np.testing.assert_array_equal(out[128:136, 5, :3], 0.0)
    np.testing.assert_allclose(out[ok, 5, 3], np.sqrt(np.abs(x64[ok, 3])), rtol=1e-6)
    np.testing.assert_array_equal(out[:, 6, :3], np.abs(x3))
    fin4 = fin & np.isfinite(x64[:, 3])
    np.testing.assert_allclose(out[fin4, 6, 3], (x64 * y64).sum(1)[fin4], rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(out[:, 7], np.fmin(x, y[:, :1]) + np.fmax(x, y) * np.float32(0.5),
                               rtol=1e-6)


def test_inline_isfinite_equals_numpy(device):
    """isfinite (kernels/builtins.h on PoCL): false for infinities and NaN, true for every finite
    float up to FLT_MAX and the subnormals; 1 for a scalar, -1 for a vector's component."""
    f = np.finfo(np.float32)
    vals = np.array([0.0, -0.0, 1.0, -3.5, f.max, -f.max, f.tiny, f.tiny / 8, np.inf, -np.inf,
                     np.nan, -np.nan, 1e38, 3e38, -1e-45, 7.0], np.float32)
    x = np.stack([np.roll(vals, k) for k in range(4)], axis=1)
    out = _debug_run(device, "isfinite_at", len(x), [x], (len(x), 2, 4))
    fin = np.isfinite(x)
    np.testing.assert_array_equal(out[:, 0, :3], np.where(fin[:, :3], -1.0, 0.0))
    np.testing.assert_array_equal(out[:, 0, 3], np.where(fin[:, 3], 1.0, 0.0))
    np.testing.assert_array_equal(out[:, 1], np.where(fin, -1.0, 0.0))


def test_sincos_in_turns_equals_numpy(device):
    """geometry.h's sincos_turns (the samplers' sin and cos of 2 pi u, reduced in turns) within
    2e-7 of float64's over [-1/8, 1] (the concentric disk map's turns start at -1/8), exactly
    0 and +-1 at the quarter turns."""
    rng = np.random.default_rng(3)
    u = np.concatenate([np.linspace(-0.125, 1.0, 9001), rng.random(8192),
                        [0.0, 0.25, 0.5, 0.75, 1.0, 1e-8, 0.999999]]).astype(np.float32)
    out = _debug_run(device, "sincos_turns_at", len(u), [u], (len(u), 2)).astype(np.float64)
    a = 2 * np.pi * u.astype(np.float64)
    assert np.abs(out[:, 0] - np.sin(a)).max() < 2e-7
    assert np.abs(out[:, 1] - np.cos(a)).max() < 2e-7
    quarter = out[-7:-2]
    np.testing.assert_array_equal(np.abs(quarter), [[0, 1], [1, 0], [0, 1], [1, 0], [0, 1]])
