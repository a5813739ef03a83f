"""The BVH over all triangles, built data-parallel on the device (kernels/geom/bvh_build.cl): Morton
codes sorted with pyopencl's RadixSort, then PLOC (Meister & Bittner 2018, the default: nearest
neighbours merged bottom-up) or Karras' LBVH hierarchy, bottom-up boxes; that binary tree
collapsed into a 4-wide one (collapse4: the children's boxes in a node's vector lanes) and
packed; refitted in place when only positions change."""
from __future__ import annotations

import time

import numpy as np

from ppm_engine.render.device.program import grid
from ppm_engine.scene.arrays import SceneArrays
from ppm_engine.scene.prep import corner_box

# a 4-wide node's bytes (kernels/geom/bvh.h: 7 float4), and an empty slot among its sources
# (bvh_build.cl BVH4_EMPTY: never a leaf's ~k, as no scene has 2^31 triangles)
BVH_NODE_BYTES = 7 * 16
BVH4_EMPTY = np.iinfo(np.int32).min


def half_areas(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Half the surface area of each box (lo, hi: (m, 4) float32 corners, w unused), in
    float64; an inverted box's 0."""
    e = np.maximum(hi[:, :3].astype(np.float64) - lo[:, :3], 0.0)
    return e[:, 0] * e[:, 1] + e[:, 1] * e[:, 2] + e[:, 2] * e[:, 0]


def collapse4(left: np.ndarray, right: np.ndarray, area: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
    """A 4-wide tree over the binary tree (left, right: node i's children, >= 0 internal, < 0
    the leaf ~k; root 0; area: each internal node's box's half surface area): from each of its
    nodes' two children, the internal child of largest area is replaced by its two children
    while fewer than four (the greedy collapse of Wald et al., "Getting Rid of Packets", 2008,
    and Embree's, by area: the children a ray most likely meets are opened).  Level by level
    in NumPy.  Returns (src, child), (m, 4) int32 each: node j's children as the binary tree's
    references (BVH4_EMPTY: none) and as the 4-wide tree's (internal: its index > 0; the leaf
    ~k; 0: none), node 0 the root."""
    left, right = np.asarray(left, np.int32), np.asarray(right, np.int32)
    pad = left.shape[0]                  # leaves and empty slots read this area: never opened
    area_of = np.empty(pad + 1, np.float64)
    area_of[:pad], area_of[pad] = area, -1.0
    level = np.zeros(1, np.int32)        # binary nodes heading this level's nodes
    srcs = []
    while level.size:
        f = level.size
        ch = np.full((f, 4), BVH4_EMPTY, np.int32)
        ch[:, 0], ch[:, 1] = left[level], right[level]
        rows = np.arange(f)
        for slot in (2, 3):
            j = area_of[np.where(ch >= 0, ch, pad)].argmax(axis=1)
            x = ch[rows, j]
            ok = x >= 0
            r, j, x = rows[ok], j[ok], x[ok]
            ch[r, j] = left[x]
            ch[r, slot] = right[x]
        srcs.append(ch)
        level = ch[ch >= 0]
    src = np.concatenate(srcs)
    # the 4-wide index of each binary node heading a node: its place in the level order
    heads = np.concatenate([np.zeros(1, np.int32), src[src >= 0]])
    index = np.zeros(left.shape[0], np.int32)
    index[heads] = np.arange(heads.size, dtype=np.int32)
    child = np.where(src >= 0, index[np.maximum(src, 0)],
                     np.where(src == BVH4_EMPTY, 0, src)).astype(np.int32)
    return np.ascontiguousarray(src), np.ascontiguousarray(child)


class BVH:
    """Device buffers ``nodes``, ``tri_v0``, ``tri_e1``, ``tri_e2`` (layout: kernels/geom/bvh.h) and
    ``leaf_order`` (host copy: original triangle index of each leaf)."""

    def __init__(self, device, scene: SceneArrays, method: str = "ploc"):
        """``method``: "ploc" (default: near-SAH quality, docs/BENCHMARKS.md, "Micro benchmarks") or
        "lbvh" (Karras' hierarchy from the Morton codes alone: faster to build, slower to trace)."""
        if method not in ("ploc", "lbvh"):
            raise ValueError(f"unknown BVH build method {method!r}")
        t0 = time.perf_counter()
        self.device = device
        q = device.queue
        n = scene.n_triangles
        self.n_triangles = n
        prog = self.prog = device.programs.get("geom/bvh_build.cl")
        self._scene = scene
        self.cost = self.built_cost = 1.0
        self.src4 = self.child4 = None           # the 4-wide tree's shape (_collapse)
        ntri = max(n, 1)
        f4 = 16
        self.tri_v0 = device.buffer(ntri * f4, "triangles")
        self.tri_e1 = device.buffer(ntri * f4, "triangles")
        self.tri_e2 = device.buffer(ntri * f4, "triangles")
        if n < 2:
            self._tiny(scene)
            self.build_seconds = time.perf_counter() - t0
            return

        pos = device.upload(scene.positions, "triangle positions")
        p = scene.positions.reshape(-1, 3, 3).mean(axis=1)
        if not np.isfinite(p).all():
            p = p[np.isfinite(p).all(axis=1)]
        lo, hi = corner_box(p) if p.size else (np.zeros(3, np.float32), np.ones(3, np.float32))
        ext = np.maximum(hi - lo, 1e-30)
        cmin = np.array([*lo, 0], np.float32)
        cscale = np.array([*(1023.0 / ext), 0], np.float32)

        codes = device.buffer(4 * n, "Morton codes")
        ids = device.buffer(4 * n, "triangle ids")
        ev = prog.morton_codes(q, *grid(n), pos, np.uint32(n), cmin, cscale, codes,
                               ids)
        ev.wait()
        import pyopencl.array as cla
        keys_a = cla.Array(q, (n,), np.uint32, data=codes)
        vals_a = cla.Array(q, (n,), np.uint32, data=ids)
        if self._on_host(n):                 # the same stable order as the radix sort's
            k, v = keys_a.get(), vals_a.get()
            order = np.argsort(k, kind="stable")
            skeys, svals = cla.to_device(q, k[order]), cla.to_device(q, v[order])
        else:
            sort = device.radix_sort_uint_pairs()
            (skeys, svals), ev = sort(keys_a, vals_a, key_bits=30)
            ev.wait()
        # the hierarchy (kept: refit() reuses it with new positions)
        self.sorted_ids = svals
        self.left = device.buffer(4 * (n - 1), "BVH")
        self.right = device.buffer(4 * (n - 1), "BVH")
        self.parent_int = device.buffer(4 * (n - 1), "BVH")
        self.parent_leaf = device.buffer(4 * n, "BVH")
        self.method = method
        if method == "ploc":
            self._ploc(pos, n)
        else:
            prog.build_hierarchy(q, *grid(n - 1), skeys.data, np.int32(n), self.left,
                                 self.right, self.parent_int, self.parent_leaf)
        self.cost = self._boxes(scene, pos)
        self.built_cost = self.cost
        self.leaf_order = svals.get().astype(np.int64)
        q.finish()
        self.build_seconds = time.perf_counter() - t0

    # Below this many triangles the build's three library primitives (pyopencl's radix sort of
    # the Morton codes, the scan that compacts PLOC's clusters, the reduction of the boxes'
    # areas) run in NumPy on the host instead, with the same results: they are microseconds
    # there, while their kernels cost a process 0.6 s to load from the kernel cache and a cold
    # cache some 10 s to compile (docs/BENCHMARKS.md, "Viewport").  0: always the device.
    HOST_PRIMITIVES = 1 << 14

    def _on_host(self, n: int) -> bool:
        return n <= self.HOST_PRIMITIVES

    @property
    def args(self) -> dict:
        """Its buffers by their names among the scene's (device_scene.SCENE_BUFFERS)."""
        return dict(nodes=self.nodes, tri_v0=self.tri_v0, tri_e1=self.tri_e1,
                    tri_e2=self.tri_e2)

    def _ploc(self, pos, n: int) -> None:
        """PLOC over the Morton-sorted leaves (kernels/geom/bvh_build.cl): rounds of nearest
        neighbours in a window, mutual pairs merged, survivors compacted by a pyopencl scan."""
        import pyopencl as cl
        device, q, prog = self.device, self.device.queue, self.prog
        a = [device.buffer(16 * n, "BVH build"), device.buffer(16 * n, "BVH build"),
             device.buffer(4 * n, "BVH build")]
        b = [device.buffer(16 * n, "BVH build"), device.buffer(16 * n, "BVH build"),
             device.buffer(4 * n, "BVH build")]
        nn = device.buffer(4 * n, "BVH build")
        valid = device.buffer(4 * n, "BVH build")
        position = device.buffer(4 * n, "BVH build")
        counter = device.buffer(4, "BVH build")
        cl.enqueue_copy(q, counter, np.array([n - 1], np.int32))
        prog.ploc_init(q, *grid(n), pos, self.sorted_ids.data, np.int32(n), *a)
        host = self._on_host(n)
        scan = None if host else device.exclusive_scan_uint()
        import pyopencl.array as cla
        m = n
        total = np.empty(2, np.uint32)
        while m > 1:
            prog.ploc_nearest(q, *grid(m), a[0], a[1], np.int32(m), nn)
            prog.ploc_merge(q, *grid(m), *a, nn, np.int32(m), counter, self.left,
                            self.right, self.parent_int, self.parent_leaf, valid)
            if host:
                flags = np.empty(m, np.uint32)
                cl.enqueue_copy(q, flags, valid)
                starts = np.zeros(m, np.uint32)
                np.cumsum(flags[:-1], out=starts[1:])
                cl.enqueue_copy(q, position, starts)
            else:
                v = cla.Array(q, (m,), np.uint32, data=valid)
                p = cla.Array(q, (m,), np.uint32, data=position)
                scan(v, p)
            prog.ploc_compact(q, *grid(m), *a, valid, position, np.int32(m), *b)
            cl.enqueue_copy(q, total[:1], position, src_offset=4 * (m - 1))
            cl.enqueue_copy(q, total[1:], valid, src_offset=4 * (m - 1))
            merged_to = int(total[0]) + int(total[1])
            if merged_to >= m:         # nothing merged (cannot happen for finite boxes)
                raise RuntimeError("PLOC made no progress")
            m = merged_to
            a, b = b, a

    def _collapse(self, node_min, node_max) -> np.ndarray:
        """The 4-wide tree's topology from the binary one's (collapse4), its sources and
        children uploaded for pack_nodes4 (kept: a refit packs new boxes into it).  Returns
        the binary nodes' half areas it read (the build's cost needs their sum)."""
        import pyopencl as cl
        q, n = self.device.queue, self.n_triangles
        left, right = np.empty(n - 1, np.int32), np.empty(n - 1, np.int32)
        lo, hi = np.empty((n - 1, 4), np.float32), np.empty((n - 1, 4), np.float32)
        for host, buf in ((left, self.left), (right, self.right), (lo, node_min),
                          (hi, node_max)):
            cl.enqueue_copy(q, host, buf)
        area = half_areas(lo, hi)
        src, child = collapse4(left, right, area)
        self.n_nodes = src.shape[0]
        self.src4 = self.device.upload(src, "BVH")
        self.child4 = self.device.upload(child, "BVH")
        self.nodes = self.device.buffer(self.n_nodes * BVH_NODE_BYTES, "BVH nodes")
        return area

    def _boxes(self, scene: SceneArrays, pos) -> float:
        """Boxes bottom-up over the hierarchy, packed nodes and leaf-ordered triangles from the
        positions in ``pos``; returns the tree's cost for refit(): the summed surface area of
        the internal nodes over that of the leaves (the SAH's traversal term up to a constant,
        unchanged by moving the whole scene; it grows when a refit stretches nodes across the
        old and new places of what moved)."""
        import pyopencl as cl
        device, q, n, prog = self.device, self.device.queue, self.n_triangles, self.prog
        mat = device.upload(scene.material, "triangle materials")
        vis = device.upload(scene.visibility, "triangle visibility")
        leaf_min = device.buffer(16 * n, "BVH")
        leaf_max = device.buffer(16 * n, "BVH")
        node_min = device.buffer(16 * (n - 1), "BVH")
        node_max = device.buffer(16 * (n - 1), "BVH")
        arrivals = device.buffer(4 * (n - 1), "BVH")
        cl.enqueue_fill_buffer(q, arrivals, np.uint32(0), 0, 4 * (n - 1))
        ids = self.sorted_ids.data
        prog.bottom_up_boxes(q, *grid(n), pos, ids, np.int32(n), self.left,
                             self.right, self.parent_int, self.parent_leaf, leaf_min, leaf_max,
                             node_min, node_max, arrivals)
        # a build: the 4-wide tree's shape, from the nodes' boxes read once
        node_area = self._collapse(node_min, node_max) if self.src4 is None else None
        prog.pack_nodes4(q, *grid(self.n_nodes), np.int32(self.n_nodes), self.src4, self.child4,
                         leaf_min, leaf_max, node_min, node_max, self.nodes)
        prog.reorder_triangles(q, *grid(n), pos, ids, mat, vis, np.int32(n),
                               self.tri_v0, self.tri_e1, self.tri_e2)
        import pyopencl.array as cla
        from pyopencl import cltypes

        def area_sum(a, b, m):
            if self._on_host(n):
                lo, hi = np.empty((m, 4), np.float32), np.empty((m, 4), np.float32)
                cl.enqueue_copy(q, lo, a)
                cl.enqueue_copy(q, hi, b)
                return float(2.0 * half_areas(lo, hi).sum())
            return float(device.box_area_sum()(cla.Array(q, (m,), cltypes.float4, data=a),
                                               cla.Array(q, (m,), cltypes.float4, data=b)).get())
        leaves = area_sum(leaf_min, leaf_max, n)
        nodes = (float(2.0 * node_area.sum()) if node_area is not None
                 else area_sum(node_min, node_max, n - 1))
        return nodes / leaves if leaves > 0 else float("inf")

    # A refitted tree (the hierarchy of the first build, boxes from new positions) is used while
    # its cost stays within this factor of a fresh build's; beyond it refit() says rebuild.
    REFIT_MAX_COST = 1.5

    def refit(self, scene: SceneArrays) -> bool:
        """New positions (materials, visibility) for the same triangles: the boxes are
        recomputed over the existing hierarchy -- no Morton codes, no sort.  Returns False (and
        changes nothing) when the scene's triangle count differs, or the refitted tree costs
        more than REFIT_MAX_COST x the first build's (objects moved too far: rebuild)."""
        n = self.n_triangles
        if scene.n_triangles != n or n < 2:
            return False
        t0 = time.perf_counter()
        pos = self.device.upload(scene.positions, "triangle positions")
        cost = self._boxes(scene, pos)
        if not cost <= self.REFIT_MAX_COST * self.built_cost:
            self._boxes(self._scene, self.device.upload(self._scene.positions,
                                                        "triangle positions"))
            return False
        self.cost, self._scene = cost, scene
        self.device.queue.finish()
        self.build_seconds = time.perf_counter() - t0
        return True

    def _tiny(self, scene: SceneArrays):
        """0 or 1 triangles: one root whose missing children have empty (inverted) boxes."""
        import pyopencl as cl
        q = self.device.queue
        node = np.zeros((BVH_NODE_BYTES // 16, 4), np.float32)
        node[0:6:2] = np.inf                     # every slot empty: inverted boxes, child 0
        node[1:6:2] = -np.inf
        tri = np.zeros((3, 4), np.float32)
        if scene.n_triangles == 1:
            v = scene.positions[0]
            node[0:6:2, 0], node[1:6:2, 0] = v.min(axis=0), v.max(axis=0)
            node[6, 0] = np.int32(~0).view(np.float32)
            tri[0, :3], tri[1, :3], tri[2, :3] = v[0], v[1] - v[0], v[2] - v[0]
            tri[0, 3] = np.uint32(0).view(np.float32)
            tri[1, 3] = scene.visibility[0].view(np.float32)
            tri[2, 3] = scene.material[0].view(np.float32)
        # (0 triangles: visibility 0, nothing is ever hit)
        self.n_nodes = 1
        self.nodes = self.device.buffer(BVH_NODE_BYTES, "BVH nodes")
        cl.enqueue_copy(q, self.nodes, node)
        for buf, row in ((self.tri_v0, 0), (self.tri_e1, 1), (self.tri_e2, 2)):
            cl.enqueue_copy(q, buf, np.ascontiguousarray(tri[row]))
        q.finish()
        self.leaf_order = np.arange(scene.n_triangles, dtype=np.int64)
