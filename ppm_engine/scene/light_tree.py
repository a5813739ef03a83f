"""A light tree over the scene's local emitters (lights other than suns, and emissive
triangles), for next-event estimation: from a shading point the kernel walks down the tree
choosing each child in proportion to an importance bound of its emitters at that point --
their power, over the square of the distance, times the cosines the orientation bounds allow
at the emitters and at the point (Estevez & Conty 2018, "Importance Sampling of Many Lights
with Adaptive Tree Splitting"; the same idea as Cycles' kernel/light/tree.h).  The MIS of an
emitter a ray finds walks up from its leaf and multiplies the same choices
(kernels/light/light_tree.h).  Suns and the world are not members: next-event estimation first
chooses between the local emitters and them by importance (emitters.py, bound_node's node over
every local emitter), then picks the far ones by their power.

The tree is binary with one emitter per leaf (2 n - 1 nodes for n emitters), built level by
level over the emitters sorted along a Morton curve of their centres, each node splitting its
range where the highest bit its codes differ in changes (the spatial middle of its cell, as
a radix tree; the middle of the range where the codes are equal): every level is a few NumPy
reductions over all emitters (reduceat), so the build is O(n log n) in vectorised steps
(10^5 emitters in 0.4 s).  Split at the middle of the range instead, node after node of the
bench's city (lamps, spots, windows) carried a few of its neon sign's 3,000 dim triangles and
a box as wide as the street, and its next-event estimation had 1.25x Cycles' RMSE at equal
time where the radix split gives 0.76x (docs/history/benchmarks-notebook.md, "Many lights").

Bounds, all conservative (an emitter that can light the point always has importance > 0):
- the box holds the emitter whole (a point light's ball, an area light's rectangle);
- the orientation cone: axis and theta_o (every emitter's normal within theta_o of the axis;
  pi for a point or spot light and a two-sided emissive triangle, which gives the cone no
  say), theta_e = pi/2 (how far past its normal an emitter emits);
- the energy is the sum of the members' power, as the power table has it."""
from __future__ import annotations

import numpy as np

from ppm_engine.scene.arrays import LIGHT_AREA_ELLIPSE, LIGHT_AREA_RECT, LIGHT_SUN

# kernels/shared.h LightTreeNode
LIGHT_TREE_NODE_DTYPE = np.dtype([
    ("bmin", np.float32, 3),      # the box of the emitters below
    ("energy", np.float32),       # their power
    ("bmax", np.float32, 3),
    ("theta_o", np.float32),      # every emitter's normal within theta_o of axis (rad)
    ("axis", np.float32, 3),
    ("theta_e", np.float32),      # how far past its normal an emitter emits (rad)
    ("child", np.int32),          # the first child (the second follows it); a leaf: -1 - emitter
    ("parent", np.int32),         # -1: the root
    ("first", np.int32),          # its emitters: tree_emitters[first:first + count]
    ("count", np.int32),
])

# a node whose ball is seen under sin^2 of its half angle below this picks among its emitters
# by power (the tree's order keeps them contiguous) instead of descending: from that far the
# importance of its parts is their power to within the angle (kernels/light/light_tree.h)
LIGHT_TREE_STOP = 0.01


# the margin added to every orientation bound (rad)
ANGLE_MARGIN = 1e-3
# the kernels' traversal stack for rays (kernels/integrator/direct_light.h lights_seen) and the
# MIS's path from a leaf (kernels/light/light_tree.h light_tree_pmf): the tree is at most 30 radix
# levels deep (a 30-bit Morton code loses a bit per level) and then splits equal codes at their
# middle, so 2^32 emitters in one cell would need 63 (build_light_tree checks the depth)
LIGHT_TREE_STACK = 64


def _morton(c: np.ndarray) -> np.ndarray:
    """30-bit Morton codes of points c (n, 3) in their bounding box."""
    lo, hi = c.min(axis=0), c.max(axis=0)
    q = np.clip(((c - lo) / np.maximum(hi - lo, 1e-30) * 1023.0).astype(np.int64), 0, 1023)
    code = np.zeros(c.shape[0], np.int64)
    for bit in range(10):
        for k in range(3):
            code |= ((q[:, k] >> bit) & 1) << (3 * bit + (2 - k))
    return code


def emitter_bounds(lights: np.ndarray, tri_corners: np.ndarray):
    """Per tree member (lights other than suns, then emissive triangles): box (lo, hi), normal
    axis, theta_o and theta_e, and which lights are members."""
    member = lights["type"] != LIGHT_SUN
    L = lights[member]
    pos = L["position"].astype(np.float64)
    area = (L["type"] == LIGHT_AREA_RECT) | (L["type"] == LIGHT_AREA_ELLIPSE)
    ext = np.where(area[:, None],
                   0.5 * (np.abs(L["axis_x"].astype(np.float64))
                          + np.abs(L["axis_y"].astype(np.float64))),
                   np.abs(L["radius"].astype(np.float64))[:, None])
    lo_l, hi_l = pos - ext, pos + ext
    axis_l = np.where(area[:, None], L["direction"].astype(np.float64), [0.0, 0.0, 1.0])
    theta_o_l = np.where(area, 0.0, np.pi)
    theta_e_l = np.full(L.shape[0], 0.5 * np.pi)
    t = tri_corners.astype(np.float64)
    lo_t, hi_t = t.min(axis=1), t.max(axis=1)
    nt = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    ln = np.linalg.norm(nt, axis=1, keepdims=True)
    axis_t = np.where(ln > 0, nt / np.where(ln > 0, ln, 1.0), [0.0, 0.0, 1.0])
    n_t = t.shape[0]
    lo = np.concatenate([lo_l, lo_t])
    hi = np.concatenate([hi_l, hi_t])
    axis = np.concatenate([axis_l, axis_t])
    # both sides of a triangle emit, every direction: theta_o = pi (no orientation bound; with
    # theta_o = pi the bound is 1 whatever theta_e, so every emitter has theta_e = pi / 2 and
    # a node's cosine bound is never negative)
    theta_o = np.concatenate([theta_o_l, np.full(n_t, np.pi)])
    theta_e = np.concatenate([theta_e_l, np.full(n_t, 0.5 * np.pi)])
    return lo, hi, axis, theta_o, theta_e, member


def _split(code: np.ndarray, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Where each range [start, end) (at least two emitters) of the Morton-sorted codes
    splits: at the highest bit in which its first and last codes differ (the spatial middle
    of its cell, as a radix tree splits), or at the middle of the range where every code is
    the same."""
    a, b = code[start], code[end - 1]
    _, e = np.frexp((a ^ b).astype(np.float64))      # highest differing bit: e - 1
    bit = np.maximum(e - 1, 0)
    at = np.searchsorted(code, (b >> bit) << bit, side="left")
    return np.where(a == b, (start + end) // 2, np.clip(at, start + 1, end - 1))


def build_light_tree(lo: np.ndarray, hi: np.ndarray, axis: np.ndarray, theta_o: np.ndarray,
                     theta_e: np.ndarray, energy: np.ndarray, index: np.ndarray):
    """The tree over n >= 2 emitters (their bounds, power and emitter-table index): (nodes,
    leaf_of, sorted_index, sorted_energy): leaf_of[k] the leaf node of emitter index[k], and
    the emitters and their power in the tree's order (a node's are [first, first + count))."""
    n = lo.shape[0]
    code = _morton(0.5 * (lo + hi))
    order = np.argsort(code, kind="stable")
    code = code[order]
    lo, hi, axis = lo[order], hi[order], axis[order]
    theta_o, theta_e, energy, index = theta_o[order], theta_e[order], energy[order], index[order]
    nodes = np.zeros(2 * n - 1, LIGHT_TREE_NODE_DTYPE)
    leaf_of = np.zeros(n, np.int64)
    w_axis = axis * energy[:, None]
    # the ranges [start, end) of the emitters under the nodes of one level, their node indices
    # and their parents
    start, end = np.array([0]), np.array([n])
    ids, parents = np.array([0]), np.array([-1])
    next_id = 1
    depth = 0
    while start.size:
        depth += 1
        size = end - start
        first = np.cumsum(size) - size
        own = np.repeat(np.arange(size.size), size)
        pos = start[own] + np.arange(own.size) - first[own]      # the members, node by node
        nlo = np.minimum.reduceat(lo[pos], first)
        nhi = np.maximum.reduceat(hi[pos], first)
        ne = np.add.reduceat(energy[pos], first)
        s = np.add.reduceat(w_axis[pos], first)
        ls = np.linalg.norm(s, axis=1, keepdims=True)
        nax = np.where(ls > 1e-9 * np.maximum(ne[:, None], 1e-30), s / np.maximum(ls, 1e-300),
                       [0.0, 0.0, 1.0])
        spread = np.arccos(np.clip((axis[pos] * nax[own]).sum(1), -1.0, 1.0))
        # (a milliradian more: float32 axes and acos near 1 must not cut an emitter off)
        m_o = np.maximum.reduceat(np.minimum(spread + theta_o[pos] + ANGLE_MARGIN, np.pi), first)
        m_e = np.maximum.reduceat(theta_e[pos], first)
        nd = nodes[ids]
        nd["bmin"], nd["bmax"], nd["energy"] = nlo, nhi, ne
        nd["axis"], nd["theta_o"], nd["theta_e"] = nax, m_o, m_e
        nd["parent"] = parents
        nd["first"], nd["count"] = start, size
        leaf = size == 1
        nd["child"][leaf] = -1 - index[start[leaf]]
        leaf_of[start[leaf]] = ids[leaf]
        inner = ~leaf
        k = int(inner.sum())
        first_child = next_id + 2 * np.arange(k)
        nd["child"][inner] = first_child
        nodes[ids] = nd
        next_id += 2 * k
        mid = _split(code, start[inner], end[inner])
        start = np.stack([start[inner], mid], axis=1).ravel()
        end = np.stack([mid, end[inner]], axis=1).ravel()
        parents = np.repeat(ids[inner], 2)
        ids = np.stack([first_child, first_child + 1], axis=1).ravel()
    assert next_id == 2 * n - 1 and depth < LIGHT_TREE_STACK
    return nodes, leaf_of[np.argsort(order)], index, energy


def bound_node(lo: np.ndarray, hi: np.ndarray, axis: np.ndarray, theta_o: np.ndarray,
               theta_e: np.ndarray, energy: np.ndarray) -> np.ndarray:
    """One LIGHT_TREE_NODE_DTYPE node bounding every emitter given (the root build_light_tree
    would make of them, without the tree: its box, its orientation cone about the energy-weighted
    axis, the sum of their energy); no child, no emitters.  An energy of 0 when there are
    none."""
    nd = np.zeros(1, LIGHT_TREE_NODE_DTYPE)
    nd["child"], nd["parent"] = -1, -1
    e = np.asarray(energy, np.float64)
    if e.shape[0] == 0 or not e.sum() > 0:
        return nd
    nd["bmin"], nd["bmax"] = lo.min(axis=0), hi.max(axis=0)
    s = (axis * e[:, None]).sum(axis=0)
    ls = np.linalg.norm(s)
    ax = s / ls if ls > 1e-9 * e.sum() else np.array([0.0, 0.0, 1.0])
    spread = np.arccos(np.clip(axis @ ax, -1.0, 1.0))
    nd["axis"], nd["energy"] = ax, e.sum()
    nd["theta_o"] = np.minimum(spread + theta_o + ANGLE_MARGIN, np.pi).max()
    nd["theta_e"] = theta_e.max()
    return nd


def importance(nodes: np.ndarray, p, n) -> np.ndarray:
    """Each node's importance at point p of normal n (kernels/light/light_tree.h
    light_tree_importance, in float64: the reference the tests hold the kernel to)."""
    p, n = np.asarray(p, np.float64), np.asarray(n, np.float64)
    lo, hi = nodes["bmin"].astype(np.float64), nodes["bmax"].astype(np.float64)
    E = nodes["energy"].astype(np.float64)
    v = 0.5 * (lo + hi) - p
    r2 = 0.25 * ((hi - lo) ** 2).sum(1)
    d2 = (v * v).sum(1)
    inside = ~(d2 > r2)
    with np.errstate(divide="ignore", invalid="ignore"):
        d = np.sqrt(d2)
        theta_u = np.arcsin(np.minimum(np.sqrt(r2 / d2), 1.0))
        cos_e = np.clip(-(nodes["axis"] * v).sum(1) / d, -1, 1)
        theta = np.maximum(np.arccos(cos_e) - nodes["theta_o"] - theta_u, 0.0)
        cos_i = np.minimum(np.abs(v @ n) / d, 1.0)
        theta_i = np.maximum(np.arccos(cos_i) - theta_u, 0.0)
        out = np.where(theta >= nodes["theta_e"], 0.0, E * np.cos(theta) * np.cos(theta_i) / d2)
        out = np.where(inside, E / np.maximum(np.maximum(d2, 0.0625 * r2), 1e-30), out)
    return np.where(E > 0, out, 0.0)


def surely_lights(nodes: np.ndarray, p, n) -> np.ndarray:
    """Whether each node surely lights point p of normal n (kernels/light/light_tree.h
    light_tree_surely_lights, in float64)."""
    p, n = np.asarray(p, np.float64), np.asarray(n, np.float64)
    lo, hi = nodes["bmin"].astype(np.float64), nodes["bmax"].astype(np.float64)
    v = 0.5 * (lo + hi) - p
    r2 = 0.25 * ((hi - lo) ** 2).sum(1)
    d2 = (v * v).sum(1)
    with np.errstate(divide="ignore", invalid="ignore"):
        d = np.sqrt(d2)
        theta_u = np.arcsin(np.minimum(np.sqrt(r2 / d2), 1.0))
        theta_i = np.arccos(np.minimum(np.abs(v @ n) / d, 1.0))
        theta = (np.arccos(np.clip(-(nodes["axis"] * v).sum(1) / d, -1, 1)) + theta_u
                 + nodes["theta_o"])
    return ((d2 > r2) & (nodes["energy"] > 0) & (theta_i + theta_u < 0.5 * np.pi)
            & (theta <= nodes["theta_e"]) & (theta < 0.5 * np.pi))


def stops(nodes: np.ndarray, p) -> np.ndarray:
    """Whether the descent picks by power at each node (LIGHT_TREE_STOP)."""
    lo, hi = nodes["bmin"].astype(np.float64), nodes["bmax"].astype(np.float64)
    v = 0.5 * (lo + hi) - np.asarray(p, np.float64)
    r2 = 0.25 * ((hi - lo) ** 2).sum(1)
    return (nodes["child"] >= 0) & (r2 < LIGHT_TREE_STOP * (v * v).sum(1))


def pmf(nodes: np.ndarray, leaf_of_emitter: np.ndarray, p, n,
        sorted_energy: np.ndarray | None = None) -> np.ndarray:
    """The probability of each emitter's leaf (leaf_of_emitter: node indices) at p, normal n:
    the choices down the tree, and where the descent stops (sorted_energy given) the emitter's
    power over its node's (kernels/light/light_tree.h light_tree_pmf)."""
    imp = importance(nodes, p, n)
    stop = stops(nodes, p) if sorted_energy is not None else np.zeros(nodes.shape[0], bool)
    prob = np.ones(nodes.shape[0])           # the probability of reaching each node
    out = np.zeros(nodes.shape[0])           # per leaf
    inner = np.nonzero(nodes["child"] >= 0)[0]
    reached = np.zeros(nodes.shape[0], bool)
    reached[0] = True
    for k in inner:                          # parents come before their children
        if not reached[k]:
            continue
        if stop[k]:
            f, c = nodes["first"][k], nodes["count"][k]
            e = sorted_energy[f:f + c].astype(np.float64)
            # the leaves below k, in the tree's order, are the nodes whose first is f .. f + c
            leaves = np.nonzero((nodes["child"] < 0) & (nodes["first"] >= f)
                                & (nodes["first"] < f + c))[0]
            out[leaves] = prob[k] * e[nodes["first"][leaves] - f] / e.sum()
            continue
        c = nodes["child"][k]
        s = imp[c] + imp[c + 1]
        p0 = imp[c] / s if s > 0 and np.isfinite(s) else 0.5
        prob[c], prob[c + 1] = prob[k] * p0, prob[k] * (1 - p0)
        reached[c] = reached[c + 1] = True
    leaf = nodes["child"] < 0
    out[leaf & reached & (out == 0)] = prob[leaf & reached & (out == 0)]
    return out[leaf_of_emitter]
