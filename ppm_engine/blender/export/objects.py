"""Object instances as shader programs read them (Object Info, Object coordinates): one row of
SceneArrays.objects per instance whose material reads object data."""
from __future__ import annotations

import numpy as np

from ppm_engine.scene.arrays import OBJECT_ROWS


def _rot(x: int, k: int) -> int:
    return ((x << k) | (x >> (32 - k))) & 0xFFFFFFFF


def _hash_uint2(kx: int, ky: int) -> int:
    """Bob Jenkins' lookup3 of two 32-bit keys (Cycles' hash_uint2; kernels/svm/svm_noise.h)."""
    a = b = c = (0xDEADBEEF + (2 << 2) + 13) & 0xFFFFFFFF
    a, b = (a + kx) & 0xFFFFFFFF, (b + ky) & 0xFFFFFFFF
    v = {"a": a, "b": b, "c": c}
    for x, y, r in (("c", "b", 14), ("a", "c", 11), ("b", "a", 25), ("c", "b", 16),
                    ("a", "c", 4), ("b", "a", 14), ("c", "b", 24)):    # lookup3's final
        v[x] = ((v[x] ^ v[y]) - _rot(v[y], r)) & 0xFFFFFFFF
    return v["c"]


def random_id(obj, inst) -> int:
    """Cycles' random id of an object instance: the depsgraph's for an instance, else a hash of
    the object's name (Cycles' hash_string, then hash_uint2 with 0)."""
    if getattr(inst, "is_instance", False):
        return int(inst.random_id) & 0xFFFFFFFF
    h = 0
    for ch in obj.name.encode("utf-8"):
        h = (h * 37 + ch) & 0xFFFFFFFF
    return _hash_uint2(h, 0)


def object_row(obj, m: np.ndarray, inst, texspace=None) -> np.ndarray:
    """(OBJECT_ROWS, 4) float32 of one object instance as shader programs read it
    (kernels/svm/svm_context.h): its inverse world matrix (3 rows), (location, pass index), its
    colour and alpha, (random, 0, 0, 0) with Cycles' random number (random_id / (2^32 - 1)), its
    world matrix (3 rows), and the Generated coordinates of a point inside it as (scale, 0) and
    (offset, 0) of its object-space position (a volume's, as Cycles' generated transform: the
    mesh's texture space ``texspace`` (location, size) mapped to 0..1, mesh.generated_coords)."""
    row = np.zeros((OBJECT_ROWS, 4), np.float64)
    loc, size = (np.asarray(v, np.float64) for v in (texspace or ((0, 0, 0), (1, 1, 1))))
    size = np.where(np.abs(size) > 1e-30, size, 1.0)
    row[9, :3] = 1.0 / (2.0 * size)
    row[10, :3] = 0.5 - loc / (2.0 * size)
    row[6:9] = m[:3]
    try:
        row[:3] = np.linalg.inv(m)[:3]
    except np.linalg.LinAlgError:
        row[:3] = np.eye(4)[:3]
    row[3] = (*m[:3, 3], float(obj.pass_index))
    row[4] = tuple(obj.color)
    row[5, 0] = random_id(obj, inst) / float(0xFFFFFFFF)
    return np.nan_to_num(row).astype(np.float32)
