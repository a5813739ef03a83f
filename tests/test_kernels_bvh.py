"""The BVH's kernels (closest and any hit, refit, the host primitives' build, visibility masks)
against brute force, on every OpenCL device (test_kernels.py has the rest)."""

import numpy as np
import pytest

pytest.importorskip("pyopencl")
import pyopencl as cl

from ppm_engine.oracle import reference as ref
from ppm_engine.oracle.procedural import MeshBuilder, look_at
from ppm_engine.render.bvh import BVH, BVH4_EMPTY, collapse4
from ppm_engine.render.device import get_device
from ppm_engine.render.device_scene import placeholders
from ppm_engine.scene.camera import make_camera
from tests.helpers.device_buffers import DEVICES, read, upload

pytestmark = pytest.mark.gpu      # every kernel on every OpenCL device found, GPUs included


@pytest.fixture(params=DEVICES, scope="module")
def device(request):
    return get_device(request.param)


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
    ob = upload(device, np.c_[o, np.zeros(n)].astype(np.float32))
    db = upload(device, np.c_[d, tmax].astype(np.float32))
    hits = cl.Buffer(device.context, cl.mem_flags.READ_WRITE, 16 * n)
    device.programs.get("test/debug.cl").launch("trace_rays", "test")(
        device.queue, n, **placeholders(device, **bvh.args), origins=ob, dirs=db,
        mask=np.uint32(mask), any_hit=np.int32(any_hit), hits=hits, n=np.uint32(n))
    h = read(device, hits, (n, 4), np.float32)
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
    d[(d == 0.0) & (rng.random((n, 3)) < 0.5)] = -0.0        # zero components as -0.0 too
    assert np.signbit(d[d == 0.0]).any()
    tmax = np.where(rng.random(n) < 0.5, np.inf, 1e30)      # the integrators' PPM_INF too
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
        nodes = np.empty((bvh.n_nodes, 7, 4), np.uint32)   # (row 6 holds child indices)
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


# --- the 4-wide tree -----------------------------------------------------------------------------
def test_collapse4_opens_the_largest_boxes_first():
    """collapse4 on a small tree whose answer is known: the root's two children, then the larger
    internal one opened (area 10), then the larger of the three (5)."""
    left = np.array([1, ~0, 3, ~2, ~4], np.int32)
    right = np.array([2, ~1, 4, ~3, ~5], np.int32)
    area = np.array([20.0, 1.0, 10.0, 5.0, 2.0])
    src, child = collapse4(left, right, area)
    e = BVH4_EMPTY
    assert src.tolist() == [[1, ~2, 4, ~3], [~0, ~1, e, e], [~4, ~5, e, e]]
    assert child.tolist() == [[1, ~2, 2, ~3], [~0, ~1, 0, 0], [~4, ~5, 0, 0]]


def test_collapse4_keeps_every_leaf_once():
    """On a random binary tree of 3,000 leaves: every leaf under the root exactly once, every
    node with two to four children and with fewer than four only when none is internal (the
    greedy collapse opened all it could), each internal child a later node (the level order)."""
    rng = np.random.default_rng(5)
    n = 3000
    left, right = np.zeros(n - 1, np.int32), np.zeros(n - 1, np.int32)
    todo, count = [(0, 0, n)], 1          # (node, first leaf, leaves)
    while todo:
        node, first, size = todo.pop()
        cut = int(rng.integers(1, size))
        for side, (f, s) in ((left, (first, cut)), (right, (first + cut, size - cut))):
            if s == 1:
                side[node] = ~f
            else:
                side[node] = count
                todo.append((count, f, s))
                count += 1
    src, child = collapse4(left, right, rng.uniform(0.1, 1.0, n - 1))
    seen, stack = [], [0]
    while stack:
        j = stack.pop()
        kids = child[j][child[j] != 0]
        assert 2 <= kids.size <= 4
        assert kids.size == 4 or (kids < 0).all()
        assert (kids[kids > 0] > j).all()
        seen += [~k for k in kids[kids < 0]]
        stack += kids[kids > 0].tolist()
    assert sorted(seen) == list(range(n))
    assert ((src == BVH4_EMPTY) == (child == 0)).all()

    # each lane's 4-wide child holds the leaves of the binary node its box is taken from
    def leaves2(x):
        out, todo = [], [x]
        while todo:
            y = todo.pop()
            if y < 0:
                out.append(~y)
            else:
                todo += [left[y], right[y]]
        return sorted(out)

    def leaves4(j):
        out, todo = [], [j]
        while todo:
            kids = child[todo.pop()]
            out += [~k for k in kids[kids < 0]]
            todo += kids[kids > 0].tolist()
        return sorted(out)
    for j, s_ in zip(*np.nonzero(src >= 0)):
        assert leaves4(child[j, s_]) == leaves2(src[j, s_])


@pytest.mark.parametrize("order", [(0, 1), (1, 0)])
def test_bvh_coincident_faces_the_one_the_ray_leaves_first(device, order):
    """A glass block's bottom face on a floor: two triangles in one plane, facing apart.  A ray
    down from above (inside the block) meets both at the same t and must get the face it leaves
    (the block's: facing down), a ray up from below the floor's, whichever comes first in the
    scene or the tree (tri_hit's ties)."""
    floor = np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0]], np.float64)      # facing +z
    bottom = floor[[0, 2, 1]]                                             # the same, facing -z
    tris = np.stack([floor, bottom])[list(order)]
    mb = MeshBuilder()
    mb.add(tris, mb.material("m"))
    mb.add(np.array([[[5, 5, 5], [6, 5, 5], [5, 6, 5]]], np.float64), mb.material("m"))
    scene = mb.build(camera=make_camera(width=4, height=4, to_world=np.eye(4)[:3], extent=(1, 1)))
    bvh = BVH(device, scene)
    xy = np.array([[0.25, 0.25], [0.5, 0.75], [1.0, 0.5], [0.125, 1.5]])
    o = np.r_[np.c_[xy, np.ones(4)], np.c_[xy, -np.ones(4)]]
    d = np.r_[np.tile([0.0, 0.0, -1.0], (4, 1)), np.tile([0.0, 0.0, 1.0], (4, 1))]
    t, idx = _trace(device, bvh, o, d, np.full(8, 1e30))
    np.testing.assert_array_equal(t, 1.0)
    down_face, up_face = order.index(1), order.index(0)   # the face each ray leaves
    assert idx[:4].tolist() == [down_face] * 4 and idx[4:].tolist() == [up_face] * 4
