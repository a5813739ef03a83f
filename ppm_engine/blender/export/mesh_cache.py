"""The mesh data an export reads, kept across the viewport's exports (ViewportDriver): a
value edit (a colour, a light, a transform) reads no mesh again; ``forget_changed`` drops what
the depsgraph's updates say changed."""
from __future__ import annotations

import contextlib

import numpy as np

from ppm_engine.blender.export import mesh as _mesh


class MeshCache:
    """One read per evaluated geometry: 1000 instances of a mesh cost one read.

    Kept across exports (the viewport's ViewportDriver): an entry stays valid while its
    geometry does not change; ``forget`` drops the entries of objects or data whose geometry
    the depsgraph says changed, ``begin``/``prune`` drop the entries an export did not use
    (deleted objects, old evaluated meshes).  A hit is also checked against the data's name
    and sizes (an evaluated mesh freed and another allocated at its address).

    What reading an entry warned (NaN vertices, a normal map without UVs, an attribute not
    read) is kept with it and said again, through ``warn`` (the current export's Warnings,
    which says each once), by every export that uses it."""

    def __init__(self, warn):
        self.warn = warn
        self._warned: dict = {}         # (table, key) -> what making that entry warned
        self.reads = 0                  # meshes read (not served from the cache)
        self._cache: dict = {}
        self._tangents: dict = {}
        self._attributes: dict = {}
        self._sig: dict = {}            # key -> (data name, sizes) when read
        self._owners: dict = {}         # key -> {original object names, ("data", name)}
        self._used: set = set()
        self._parts: dict = {}          # (key, placement...) -> a transform_part's result
        self._used_parts: set = set()
        self._cat = None                # (key, arrays) of the last concatenation

    def part(self, obj, placement: tuple, make) -> dict:
        """The world-space part of ``obj``'s geometry at ``placement`` (its matrix, slots,
        flags: what transform_part reads besides the mesh), ``make()`` once per placement
        (as long as the geometry is kept).  Treat it as read-only."""
        key = (self._key(obj),) + placement
        self._used_parts.add(key)
        return self._made("parts", self._parts, key, make)

    def _made(self, name: str, table: dict, key, make):
        """``table[key]``, made by ``make()`` if missing, with what it warned kept (``warn``
        while it runs records it); on a hit the kept warnings are said again."""
        if key in table:
            for msg in self._warned.get((name, key), ()):
                self._say(msg)
            return table[key]
        said, outer = [], self.warn

        def record(msg: str) -> None:
            if msg not in said:
                said.append(msg)
            if outer is not None:
                outer(msg)
        self.warn = record
        try:
            table[key] = make()
        finally:
            self.warn = outer
        if said:
            self._warned[(name, key)] = said
        return table[key]

    def _say(self, msg: str) -> None:
        if self.warn is not None:
            self.warn(msg)

    def concatenated(self, key):
        """The arrays kept by keep_concatenated for ``key`` (the parts, by identity, and
        what else the concatenation read), or None."""
        if self._cat is None:
            return None
        k, arrays = self._cat
        same = (len(k[0]) == len(key[0]) and all(a is b for a, b in zip(k[0], key[0]))
                and k[1:] == key[1:])
        return arrays if same else None

    def keep_concatenated(self, key, arrays: dict) -> None:
        self._cat = (key, dict(arrays))

    @staticmethod
    def _signature(obj) -> tuple:
        data = obj.data
        if data is None:
            return (obj.name,)
        if obj.type == 'MESH':
            return (data.name, len(data.vertices), len(data.loops), len(data.polygons))
        return (data.name,)

    @staticmethod
    def _names(obj) -> set:
        names = {getattr(obj, "original", obj).name}
        if obj.data is not None:
            names.add(("data", getattr(obj.data, "original", obj.data).name))
        return names

    def _check(self, obj, key) -> None:
        """Drop the entry of ``key`` when it is not this object's geometry (its signature
        differs); note the object as one of its owners and the key as used."""
        sig = self._signature(obj)
        if key in self._sig and self._sig[key] != sig:
            self._drop({key})
        self._sig[key] = sig
        self._owners.setdefault(key, set()).update(self._names(obj))
        self._used.add(key)

    def _drop(self, keys: set) -> None:
        for d in (self._cache, self._sig, self._owners):
            for k in keys:
                d.pop(k, None)
        for k in keys & set(self._tangents):
            del self._tangents[k]
        for k in [k for k in self._attributes if k[0] in keys]:
            del self._attributes[k]
        for k in [k for k in self._parts if k[0] in keys]:
            del self._parts[k]
        for name, k in list(self._warned):
            if (k if name in ("mesh", "tangents") else k[0]) in keys:
                del self._warned[(name, k)]
        if keys:
            self._cat = None

    def forget(self, objects=(), data=()) -> None:
        """Drop the geometry read for these (original) object names and data names."""
        names = set(objects) | {("data", n) for n in data}
        self._drop({k for k, owners in self._owners.items() if owners & names})

    def begin(self) -> None:
        """An export starts: nothing used yet."""
        self._used = set()
        self._used_parts = set()

    def prune(self) -> None:
        """An export ended: drop what it did not use."""
        self._drop(set(self._sig) - self._used)
        for k in set(self._parts) - self._used_parts:
            del self._parts[k]
            self._warned.pop(("parts", k), None)

    @staticmethod
    def _direct(obj) -> bool:
        """Whether the object's evaluated data is the mesh to read: a mesh object's, unless it
        is in Edit Mode (then the data is the edit mesh's wrapper, without the corner arrays:
        read through to_mesh(), as Cycles does)."""
        return obj.type == 'MESH' and not obj.data.is_editmode

    def _key(self, obj):
        """The cache key of an object's geometry: its mesh datablock (1000 instances, one
        read), or the object and its data where the mesh comes from to_mesh() (the result
        depends on the evaluated object: its modifiers)."""
        if self._direct(obj):
            return obj.data.as_pointer()
        return (obj.as_pointer(), obj.data.as_pointer() if obj.data is not None else 0)

    @contextlib.contextmanager
    def _mesh(self, obj, copy: bool = False):
        """The evaluated mesh to read (None where the object gives none): the object's data
        (_direct, unless ``copy``), else a temporary mesh from to_mesh() (curves, surfaces,
        text, metaballs, a mesh in Edit Mode), outside the blend data, always cleared."""
        if self._direct(obj) and not copy:
            yield obj.data
            return
        try:
            mesh = obj.to_mesh()
        except RuntimeError:
            mesh = None
        try:
            yield mesh
        finally:
            obj.to_mesh_clear()

    def uv_tangents(self, obj) -> np.ndarray:
        """read_uv_tangents of an object's geometry (once per datablock)."""
        name = obj.data.name if obj.data is not None else obj.name
        return self._made("tangents", self._tangents, self._key(obj),
                          lambda: _mesh.read_uv_tangents(self.get(obj), name, self.warn,
                                                         lambda: self._mesh(obj, copy=True)))

    def attributes(self, obj, names: list) -> np.ndarray | None:
        """read_attributes of a mesh object's data for these names; None for other geometry
        (warned: its attributes read 0)."""
        if obj.type != 'MESH':
            self.warn(f"Object '{obj.name}' is not a mesh: its attributes are not read (0)")
            return None
        def read():
            local = self.get(obj)
            with self._mesh(obj) as mesh:
                return (_mesh.read_attributes(mesh, local, list(names), self.warn)
                        if mesh is not None else None)
        # once per datablock, not per instance
        return self._made("attributes", self._attributes, (self._key(obj), tuple(names)), read)

    def get(self, obj) -> _mesh.LocalMesh:
        key = self._key(obj)
        self._check(obj, key)

        def read():
            self.reads += 1
            with self._mesh(obj) as mesh:
                return _mesh.read_mesh(mesh) if mesh is not None else _mesh.EMPTY
        return self._made("mesh", self._cache, key, read)

    def clear(self):
        self._cache.clear()
        self._warned.clear()
        self._tangents.clear()
        self._attributes.clear()
        self._sig.clear()
        self._owners.clear()
        self._used = set()
        self._parts.clear()
        self._used_parts = set()
        self._cat = None


# data whose geometry update names the datablock a MeshCache entry was read from
_DATA_TYPES = {'MESH', 'CURVE', 'CURVES', 'META', 'POINTCLOUD', 'VOLUME', 'TEXT', 'SURFACE'}


def forget_changed(updates, meshes, images: dict, value_types) -> None:
    """Drop from the kept mesh data (MeshCache) and decoded images what ``updates`` say
    changed: the geometry of the objects and data updated so; all meshes where objects were
    added, deleted or hidden (a collection), a geometry node tree or other data changed;
    every image where one did.  A value or transform edit drops nothing.  ``value_types``:
    the id types of values (the viewport's _VALUE_TYPES)."""
    objects, data = set(), set()
    for u in updates:
        ident = u.id
        idt = getattr(ident, "id_type", "") if ident is not None else ""
        name = getattr(getattr(ident, "original", ident), "name", None)
        geometry = u.is_updated_geometry
        if idt == 'OBJECT':
            if geometry:
                objects.add(name)
        elif idt == 'IMAGE':
            images.clear()
        elif idt == 'COLLECTION' or (idt == 'NODETREE'
                                     and getattr(ident, "type", "") == 'GEOMETRY'):
            meshes.clear()
        elif idt in _DATA_TYPES:
            if geometry or u.is_updated_transform:
                data.add(name)
        elif idt not in value_types and (geometry or u.is_updated_transform):
            meshes.clear()                         # other data (a shape key, an armature)
    if objects or data:
        meshes.forget(objects, data)
