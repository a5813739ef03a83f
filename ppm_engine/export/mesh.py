"""Triangles, shading normals and UVs of evaluated meshes, read once per mesh datablock and
transformed per instance."""
from __future__ import annotations

import dataclasses

import numpy as np

# object types that evaluate to a mesh
GEOMETRY_TYPES = {'MESH', 'CURVE', 'SURFACE', 'META', 'FONT', 'CURVES', 'POINTCLOUD', 'VOLUME'}


@dataclasses.dataclass
class LocalMesh:
    positions: np.ndarray      # (T, 3, 3) float32, object space
    normals: np.ndarray        # (T, 3, 3) float32
    uvs: np.ndarray            # (T, 3, 2) float32
    slot: np.ndarray           # (T,) int32 material slot index

    @property
    def n_triangles(self) -> int:
        return self.positions.shape[0]


def _attr(mesh, name, domain_len, comps, dtype, prop):
    a = mesh.attributes.get(name)
    if a is None:
        return None
    buf = np.empty(domain_len * comps, dtype)
    a.data.foreach_get(prop, buf)
    return buf.reshape(domain_len, comps) if comps > 1 else buf


def read_mesh(mesh) -> LocalMesh:
    mesh.calc_loop_triangles()
    n_tri = len(mesh.loop_triangles)
    n_v, n_loops, n_polys = len(mesh.vertices), len(mesh.loops), len(mesh.polygons)
    if n_tri == 0:
        z = np.zeros((0, 3, 3), np.float32)
        return LocalMesh(z, z, np.zeros((0, 3, 2), np.float32), np.zeros(0, np.int32))
    pos = _attr(mesh, "position", n_v, 3, np.float32, "vector")
    corner_vert = _attr(mesh, ".corner_vert", n_loops, 1, np.int32, "value")
    if n_loops == 3 * n_polys:                       # all triangles: loops are in order
        tri_loops = np.arange(3 * n_tri, dtype=np.int32)
    else:
        tri_loops = np.empty(3 * n_tri, np.int32)
        mesh.loop_triangles.foreach_get("loops", tri_loops)
    tri_poly = np.empty(n_tri, np.int32)
    mesh.loop_triangle_polygons.foreach_get("value", tri_poly)
    tri_vert = corner_vert[tri_loops]
    positions = pos[tri_vert].reshape(n_tri, 3, 3)

    domain = mesh.normals_domain
    if domain == 'FACE':
        pn = np.empty(n_polys * 3, np.float32)
        mesh.polygon_normals.foreach_get("vector", pn)
        normals = np.repeat(pn.reshape(-1, 3)[tri_poly][:, None, :], 3, axis=1)
    elif domain == 'POINT':
        vn = np.empty(n_v * 3, np.float32)
        mesh.vertex_normals.foreach_get("vector", vn)
        normals = vn.reshape(-1, 3)[tri_vert].reshape(n_tri, 3, 3)
    else:
        cn = np.empty(n_loops * 3, np.float32)
        mesh.corner_normals.foreach_get("vector", cn)
        normals = cn.reshape(-1, 3)[tri_loops].reshape(n_tri, 3, 3)

    uvs = np.zeros((n_tri, 3, 2), np.float32)
    uv_layer = mesh.uv_layers.active
    if uv_layer is not None:
        uv = _attr(mesh, uv_layer.name, n_loops, 2, np.float32, "vector")
        if uv is not None:
            uvs = uv[tri_loops].reshape(n_tri, 3, 2)
    mat = _attr(mesh, "material_index", n_polys, 1, np.int32, "value")
    slot = mat[tri_poly] if mat is not None else np.zeros(n_tri, np.int32)
    return LocalMesh(positions, normals.astype(np.float32), uvs, slot.astype(np.int32))


class MeshCache:
    """One read per mesh datablock: 1000 instances of a mesh cost one read."""

    def __init__(self, warn):
        self.warn = warn
        self._cache: dict[int, LocalMesh] = {}

    def get(self, obj) -> LocalMesh | None:
        if obj.type == 'MESH':
            key = obj.data.as_pointer()
            if key not in self._cache:
                self._cache[key] = read_mesh(obj.data)
            return self._cache[key]
        # curves, text, metaballs...: evaluate to a temporary mesh, always cleared
        try:
            mesh = obj.to_mesh()
        except RuntimeError:
            return None
        try:
            return read_mesh(mesh) if mesh is not None else None
        finally:
            obj.to_mesh_clear()

    def clear(self):
        self._cache.clear()


def transform_part(mesh: LocalMesh, m: np.ndarray, slot_map: np.ndarray, visibility: int,
                   name: str, warn) -> dict:
    """World-space arrays of one instance; triangles with NaN/Inf corners are dropped."""
    m3, t = m[:3, :3], m[:3, 3]
    p = mesh.positions.astype(np.float64) @ m3.T + t
    with np.errstate(invalid="ignore", over="ignore"):
        nm = np.linalg.inv(m3).T if abs(np.linalg.det(m3)) > 1e-300 else np.eye(3)
        n = mesh.normals.astype(np.float64) @ nm.T
        n /= np.maximum(np.linalg.norm(n, axis=2, keepdims=True), 1e-30)
    good = np.isfinite(p).all(axis=(1, 2))
    if not good.all():
        warn(f"Object '{name}': {int((~good).sum())} triangles with NaN or infinite vertex "
             "coordinates were skipped")
    n = np.where(np.isfinite(n), n, 0.0)
    slot = np.clip(mesh.slot, 0, len(slot_map) - 1)
    return dict(positions=p[good].astype(np.float32), normals=n[good].astype(np.float32),
                uvs=mesh.uvs[good], material=slot_map[slot][good].astype(np.int32),
                visibility=np.full(int(good.sum()), visibility, np.uint32))
