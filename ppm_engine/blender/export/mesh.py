"""Triangles, shading normals and UVs of evaluated meshes, read once per mesh datablock and
transformed per instance.  No per-vertex or per-triangle Python loops: attribute-API
``foreach_get`` into buffers of the stored dtype, then NumPy."""
from __future__ import annotations

import dataclasses

import numpy as np

from ppm_engine.scene.arrays import TERMINATOR_OFFSET
from ppm_engine.scene.prep import finite_triangles

# object types that can evaluate to a mesh (non-MESH types go through ``to_mesh()``)
GEOMETRY_TYPES = {'MESH', 'CURVE', 'SURFACE', 'META', 'FONT', 'CURVES', 'POINTCLOUD', 'VOLUME'}


@dataclasses.dataclass
class LocalMesh:
    positions: np.ndarray      # (T, 3, 3) float32, object space
    normals: np.ndarray        # (T, 3, 3) float32
    uvs: np.ndarray            # (T, 3, 2) float32
    slot: np.ndarray           # (T,) int32 material slot index
    # the mesh's texture space (location, size): where "Generated" coordinates are 0..1
    texspace: tuple = ((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    tri_loops: np.ndarray | None = None     # (3T,) the corners' loop indexes
    tri_vert: np.ndarray | None = None      # (3T,) the corners' vertex indexes
    flat: np.ndarray | None = None          # (T,) bool: the triangle's face is flat-shaded
    uv_name: str | None = None              # the UV map in ``uvs`` (render_uv_layer), if any

    @property
    def n_triangles(self) -> int:
        return self.positions.shape[0]


EMPTY = LocalMesh(np.zeros((0, 3, 3), np.float32), np.zeros((0, 3, 3), np.float32),
                  np.zeros((0, 3, 2), np.float32), np.zeros(0, np.int32))


def _attr(mesh, name, domain_len, comps, dtype, prop):
    a = mesh.attributes.get(name)
    if a is None:
        return None
    buf = np.empty(domain_len * comps, dtype)
    a.data.foreach_get(prop, buf)
    return buf.reshape(domain_len, comps) if comps > 1 else buf


def read_mesh(mesh) -> LocalMesh:
    """Object-space triangle soup of one (evaluated) mesh."""
    mesh.calc_loop_triangles()
    n_tri = len(mesh.loop_triangles)
    n_v, n_loops, n_polys = len(mesh.vertices), len(mesh.loops), len(mesh.polygons)
    if n_tri == 0:
        return EMPTY
    pos = _attr(mesh, "position", n_v, 3, np.float32, "vector")
    corner_vert = _attr(mesh, ".corner_vert", n_loops, 1, np.int32, "value")
    tri_poly = np.empty(n_tri, np.int32)
    mesh.loop_triangle_polygons.foreach_get("value", tri_poly)
    if n_loops == 3 * n_polys and n_tri == n_polys:   # all triangles: loops are in order
        tri_loops = np.arange(3 * n_tri, dtype=np.int32)
    else:
        tri_loops = np.empty(3 * n_tri, np.int32)
        mesh.loop_triangles.foreach_get("loops", tri_loops)
    tri_vert = corner_vert[tri_loops]
    positions = pos[tri_vert].reshape(n_tri, 3, 3)

    if mesh.normals_domain == 'FACE':                   # flat: one normal per polygon
        pn = np.empty(n_polys * 3, np.float32)
        mesh.polygon_normals.foreach_get("vector", pn)
        normals = np.repeat(pn.reshape(-1, 3)[tri_poly][:, None, :], 3, axis=1)
    else:  # POINT or CORNER: corner normals hold either (and are far faster than vertex_normals)
        cn = np.empty(n_loops * 3, np.float32)
        mesh.corner_normals.foreach_get("vector", cn)
        normals = cn.reshape(-1, 3)[tri_loops].reshape(n_tri, 3, 3)

    uvs = None
    uv_layer = render_uv_layer(mesh)
    if uv_layer is not None:
        uv = _attr(mesh, uv_layer.name, n_loops, 2, np.float32, "vector")
        if uv is not None:
            uvs = uv[tri_loops].reshape(n_tri, 3, 2)
    if uvs is None:
        uvs = np.zeros((n_tri, 3, 2), np.float32)
    mat = _attr(mesh, "material_index", n_polys, 1, np.int32, "value")
    slot = mat[tri_poly] if mat is not None else np.zeros(n_tri, np.int32)
    texspace = (tuple(getattr(mesh, "texspace_location", (0.0, 0.0, 0.0))),
                tuple(getattr(mesh, "texspace_size", (1.0, 1.0, 1.0))))
    if mesh.normals_domain == 'FACE':
        flat = np.ones(n_tri, bool)
    else:
        sharp = _attr(mesh, "sharp_face", n_polys, 1, bool, "value")
        flat = sharp[tri_poly] if sharp is not None else np.zeros(n_tri, bool)
    return LocalMesh(positions, normals.astype(np.float32, copy=False), uvs,
                     slot.astype(np.int32, copy=False), texspace, tri_loops,
                     tri_vert.astype(np.int32, copy=False), flat,
                     uv_layer.name if uv_layer is not None else None)


def render_uv_layer(mesh):
    """The UV map Cycles reads where a node names none (UVs, the Normal Map's tangents): the
    one marked for rendering (the camera icon in the UV Maps list: active_render, Cycles'
    ATTR_STD_UV), not the one selected for editing; None without UV maps."""
    layers = mesh.uv_layers
    return next((uv for uv in layers if uv.active_render), layers.active)


def cycles_tangent_normals(local: LocalMesh) -> np.ndarray:
    """(T, 3, 3) the normals Cycles gives MikkTSpace at the triangles' corners: the mesh's
    (vertex or corner) normal on smooth faces, the triangle's own normal on flat ones
    (Cycles' MikkMeshWrapper::GetNormal; (1, 0, 0) for a degenerate triangle)."""
    normals = local.normals.copy()
    if local.flat is not None and local.flat.any():
        p = local.positions[local.flat].astype(np.float64)
        n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        length = np.linalg.norm(n, axis=1, keepdims=True)
        n = np.where(length > 0, n / np.where(length > 0, length, 1.0), (1.0, 0.0, 0.0))
        normals[local.flat] = n[:, None, :].astype(np.float32)
    return normals


def read_uv_tangents(local: LocalMesh, name: str, warn, scratch) -> np.ndarray:
    """(T, 3, 4) object-space tangents of the rendered UV map at the triangles' corners and
    their bitangent signs, as Cycles computes the tangent attribute its Normal Map reads:
    MikkTSpace (Blender's, ``Mesh.calc_tangents``) on the mesh's triangles (Cycles runs it
    on its triangulated mesh, not on the quads and n-gons ``calc_tangents`` would see on the
    mesh itself: up to ~1 degree apart around a subdivided mesh's irregular vertices), with
    the normals Cycles gives it (cycles_tangent_normals) as custom normals of a triangle mesh
    built for it; the corners keep their vertices (MikkTSpace joins the corners of a vertex
    that agree in UV and normal).  ``scratch()``: a context manager giving a mesh outside
    the blend data to build it in (MeshCache.uv_tangents: the object's to_mesh(), cleared;
    never a new datablock of bpy.data, which a render's thread must not add), or None.
    Zeros (the normal map then leaves the normal alone, as Cycles without tangents) where
    they cannot be computed."""
    n_tri = local.n_triangles
    out = np.zeros((n_tri, 3, 4), np.float32)
    if n_tri == 0:
        return out
    if local.uv_name is None or local.tri_vert is None:
        warn(f"Mesh '{name}' has no UV map: its tangent-space normal maps are not applied")
        return out
    n_v = int(local.tri_vert.max()) + 1
    pos = np.zeros((n_v, 3), np.float32)
    pos[local.tri_vert] = local.positions.reshape(-1, 3)
    with scratch() as tmp:
        try:
            if tmp is None:
                raise RuntimeError("no mesh to compute them in")
            tmp.clear_geometry()
            tmp.vertices.add(n_v)
            tmp.attributes["position"].data.foreach_set("vector", pos.ravel())
            tmp.loops.add(3 * n_tri)
            tmp.attributes[".corner_vert"].data.foreach_set("value", local.tri_vert)
            tmp.polygons.add(n_tri)
            tmp.polygons.foreach_set("loop_start", np.arange(0, 3 * n_tri, 3, dtype=np.int32))
            uv_name = tmp.uv_layers.new(name="UVMap").name
            tmp.attributes[uv_name].data.foreach_set("vector", local.uvs.ravel())
            # free custom normals (Blender 4.5+): the corners' normals exactly, in a memcpy
            tmp.attributes.new("custom_normal", "FLOAT_VECTOR", "CORNER").data.foreach_set(
                "vector", cycles_tangent_normals(local).ravel())
            tmp.calc_tangents(uvmap=uv_name)
            t, sign = np.empty(9 * n_tri, np.float32), np.empty(3 * n_tri, np.float32)
            tmp.loops.foreach_get("tangent", t)
            tmp.loops.foreach_get("bitangent_sign", sign)
        except RuntimeError as e:
            warn(f"Mesh '{name}': its tangents could not be computed ({e}); its "
                 "tangent-space normal maps are not applied")
            return out
    out[..., :3] = t.reshape(-1, 3, 3)
    out[..., 3] = sign.reshape(-1, 3)
    return out


# attribute data type -> (foreach_get property, components)
_ATTR_READ = {"FLOAT_COLOR": ("color", 4), "BYTE_COLOR": ("color", 4),
              "FLOAT_VECTOR": ("vector", 3), "FLOAT2": ("vector", 2), "FLOAT": ("value", 1),
              "INT": ("value", 1)}


def read_attributes(mesh, local: LocalMesh, names: list, warn) -> np.ndarray:
    """(T, 3, len(names), 4) float32: the named attributes at the triangles' corners (colours
    in scene linear; a float f as (f, f, f, 1), a vector's alpha 1), "" being the mesh's
    default colour attribute; zeros for an attribute the mesh lacks (as Cycles)."""
    n_tri = local.n_triangles
    out = np.zeros((n_tri, 3, len(names), 4), np.float32)
    out[..., 3] = 1.0
    if n_tri == 0 or local.tri_loops is None:
        return out
    for k, name in enumerate(names):
        if not name:
            name = (getattr(mesh.attributes, "default_color_name", "")
                    or getattr(mesh.color_attributes, "active_color_name", "") or "")
        a = mesh.attributes.get(name) if name else None
        if a is None:
            out[:, :, k] = 0.0
            continue
        how = _ATTR_READ.get(a.data_type)
        if how is None or a.domain not in ("POINT", "CORNER", "FACE"):
            warn(f"Mesh '{mesh.name}': the attribute '{name}' ({a.data_type.lower()} on "
                 f"{a.domain.lower()}s) is not read; it is 0")
            out[:, :, k] = 0.0
            continue
        prop, comps = how
        buf = np.empty(len(a.data) * comps, np.int32 if a.data_type == "INT" else np.float32)
        a.data.foreach_get(prop, buf)
        vals = buf.astype(np.float32).reshape(-1, comps)
        if a.domain == "POINT":
            cv = np.empty(len(mesh.loops), np.int32)
            mesh.attributes[".corner_vert"].data.foreach_get("value", cv)
            idx = cv[local.tri_loops]
        elif a.domain == "CORNER":
            idx = local.tri_loops
        else:
            idx = np.empty(n_tri, np.int32)
            mesh.loop_triangle_polygons.foreach_get("value", idx)
            idx = np.repeat(idx, 3)
        v = vals[idx].reshape(n_tri, 3, comps)
        if comps == 1:
            out[:, :, k, :3] = v
        else:
            out[:, :, k, :comps] = v
    return out


def _texspace_centred(mesh: LocalMesh) -> np.ndarray:
    """(T, 3, 3) float64 Generated coordinates minus 1/2 at the corners: the object-space
    position over the mesh's texture space, centred."""
    loc, size = (np.asarray(v, np.float64) for v in mesh.texspace)
    size = np.where(np.abs(size) > 1e-30, size, 1.0)
    return (mesh.positions.astype(np.float64) - loc) / (2.0 * size)


def radial_tangents(mesh: LocalMesh) -> np.ndarray:
    """(T, 3, 3) object-space radial tangents around Z at the corners, Cycles' default tangent
    (its Tangent node, Radial, Z): (-(g.y - 1/2), g.x - 1/2, 0) of the Generated coordinates
    g, which map the mesh's texture space to 0..1.  Linear in the position, so interpolating
    the corners' is exact."""
    g = _texspace_centred(mesh)                                          # g - 1/2
    t = np.zeros(mesh.positions.shape, np.float32)
    t[..., 0], t[..., 1] = -g[..., 1], g[..., 0]
    return t


def generated_coords(mesh: LocalMesh) -> np.ndarray:
    """(T, 3, 3) Generated coordinates at the corners: the object-space position mapped from
    the mesh's texture space to 0..1 (Cycles' "generated" attribute)."""
    return (_texspace_centred(mesh) + 0.5).astype(np.float32)


def transform_part(mesh: LocalMesh, m: np.ndarray, slot_map: np.ndarray, visibility: int,
                   name: str, warn, tangents: bool = False,
                   uv_tangents: np.ndarray | None = None, generated: bool = False,
                   attributes: np.ndarray | None = None,
                   terminator: float = TERMINATOR_OFFSET) -> dict:
    """World-space arrays of one instance.

    Positions by the world matrix, normals by its inverse transpose (renormalised).  A mirroring
    matrix (negative determinant) also reverses the winding (corners 1 and 2 swapped) so that
    the geometric normal from the winding keeps its side relative to the shading normals, as
    Cycles' negative-scale flag does.  Triangles with NaN/Inf corners are dropped with a warning;
    non-finite or zero shading normals are replaced by the geometric normal.  With
    ``tangents``, the radial tangents (radial_tangents) transformed as normals are (Cycles'
    object_normal_transform), else zeros; ``uv_tangents`` (read_uv_tangents) as directions,
    renormalised, their signs flipped by a mirroring matrix (the bitangent is the normal
    crossed with the tangent), else zeros; with ``generated`` the Generated coordinates
    (generated_coords), else zeros; ``attributes`` (read_attributes) carried as they are;
    ``terminator`` the object's Shadow Terminator > Geometry Offset, per triangle."""
    m3, t = m[:3, :3], m[:3, 3]
    det = float(np.linalg.det(m3))
    # float32 arithmetic (as Cycles transforms): the result is float32 anyway, and 1M triangles
    # transform in ~30 ms instead of ~150 ms in float64
    p = mesh.positions.reshape(-1, 3) @ m3.T.astype(np.float32)
    p += t.astype(np.float32)
    p = p.reshape(-1, 3, 3)
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        # normals by the inverse transpose; for a rotation times a uniform scale (the usual
        # object transform) that is m3 / scale and unit normals stay unit
        gram = m3.T @ m3
        s2 = float(np.trace(gram)) / 3.0
        similarity = s2 > 0 and np.allclose(gram, s2 * np.eye(3), rtol=1e-6, atol=1e-12 * s2)
        if similarity:
            nm = m3 / np.sqrt(s2)
        else:
            nm = np.linalg.inv(m3).T if abs(det) > 1e-300 else np.eye(3)
        n = mesh.normals.reshape(-1, 3) @ nm.T.astype(np.float32)
        len2 = np.einsum("ij,ij->i", n, n)
        if not similarity:
            n /= np.sqrt(len2)[:, None]
        n = n.reshape(-1, 3, 3)
        zero = ~(len2.reshape(-1, 3) > 1e-24)              # zero-length (or NaN) normals
        tg = ((radial_tangents(mesh).reshape(-1, 3) @ nm.T.astype(np.float32)).reshape(-1, 3, 3)
              if tangents else np.zeros(p.shape, np.float32))
        ut = np.zeros(p.shape[:2] + (4,), np.float32)
        if uv_tangents is not None:
            d = uv_tangents[..., :3].reshape(-1, 3) @ m3.T.astype(np.float32)
            length = np.linalg.norm(d, axis=1, keepdims=True)
            ut[..., :3] = np.where(length > 0, d / np.where(length > 0, length, 1), 0).reshape(
                -1, 3, 3)
            ut[..., 3] = uv_tangents[..., 3] * (1.0 if det >= 0 else -1.0)
        gen = generated_coords(mesh) if generated else np.zeros(p.shape, np.float32)
        attr = attributes if attributes is not None else np.zeros(p.shape[:2] + (0, 4),
                                                                   np.float32)
        good, warning = finite_triangles(p, f"Object '{name}'")
        uvs = mesh.uvs
        if good is not None:
            warn(warning)
            p, n, zero, uvs, tg, ut = p[good], n[good], zero[good], uvs[good], tg[good], ut[good]
            gen, attr = gen[good], attr[good]
        if det < 0:
            order = [0, 2, 1]
            p, n, uvs, zero = p[:, order], n[:, order], uvs[:, order], zero[:, order]
            tg, ut, gen, attr = tg[:, order], ut[:, order], gen[:, order], attr[:, order]
        if zero.any() or not np.isfinite(n.reshape(len(n), 9).sum(axis=1)).all():
            bad = zero | ~np.isfinite(n).all(axis=2)
            ng = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]).astype(np.float64)
            ng /= np.linalg.norm(ng, axis=1, keepdims=True)
            ng = np.where(np.isfinite(ng), ng, (0.0, 0.0, 1.0))
            n = np.where(bad[:, :, None], ng[:, None, :], n).astype(np.float32)
    slot = np.clip(mesh.slot, 0, len(slot_map) - 1)
    mat = slot_map[slot]
    if good is not None:
        mat = mat[good]
    return dict(positions=p.astype(np.float32, copy=False),
                normals=n.astype(np.float32, copy=False),
                uvs=np.ascontiguousarray(uvs, np.float32), material=mat.astype(np.int32),
                visibility=np.full(p.shape[0], visibility, np.uint32),
                terminator=np.full(p.shape[0], terminator, np.float32),
                tangents=np.ascontiguousarray(tg, np.float32),
                uv_tangents=np.ascontiguousarray(np.nan_to_num(ut), np.float32),
                generated=np.ascontiguousarray(np.nan_to_num(gen), np.float32),
                attributes=np.ascontiguousarray(np.nan_to_num(attr), np.float32))
