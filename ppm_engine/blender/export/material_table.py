"""The scene's materials: each material read once (materials.read_material), its row, BSDF
nodes and shader program collected in the order the kernels index them (MATERIAL_DTYPE,
SHADER_NODE_DTYPE, SceneArrays.svm), and each object's material slots mapped to them."""
from __future__ import annotations

import numpy as np

from ppm_engine.blender.export.material_nodes import (
    DEFAULT_NAME,
    default_row,
    read_material,
    read_volume_object,
)
from ppm_engine.blender.export.material_volume import DEFAULT_VOLUME
from ppm_engine.scene.arrays import SHADER_NODE_DTYPE, shader_node
from ppm_engine.scene.materials import anisotropic_nodes
from ppm_engine.scene.shader_program import attributes_read


class MaterialTable:
    """Materials deduplicated by (full) name; index 0 is the default grey diffuse."""

    def __init__(self, warn, textures=None):
        self.warn = warn
        self.textures = textures          # textures.TextureTable (None: textures not read)
        row, nodes = default_row()
        self.rows = [row]
        self.nodes = [nodes]
        self.programs = [np.zeros((1, 4), np.int32)]    # word 0: never a program
        self.words = 1
        self.program_flags: dict = {}                   # material -> its header's flags
        self.attributes: list = []                      # mesh attribute names programs read
        self.camera = None                              # camera-to-world (camera space nodes)
        self.names = [DEFAULT_NAME]
        self._index = {}

    def index(self, material) -> int:
        if material is None:
            return 0
        key = material.name_full
        if key not in self._index:
            field: list = []
            row, nodes, program = read_material(material, self.warn, self.textures,
                                                self.attributes, self.camera, field)
            self._index[key] = self._append(row, nodes, program, field[0] if field else None,
                                            material.name)
        return self._index[key]

    def volume_index(self, material, grids: tuple, scale: float) -> tuple | None:
        """(row, names of the grids its density reads) of ``material`` (None: Cycles' default
        volume) on a Volume object whose grids are named ``grids``: its Volume output alone, the
        coefficients times ``scale`` (material_nodes.read_volume_object); None where its density
        reads none of those grids (Cycles then has no voxels to build the volume's bounds from:
        nothing is rendered)."""
        key = ("volume object", material.name_full if material is not None else None, grids,
               float(scale))
        if key not in self._index:
            made = read_volume_object(material, self.warn, self.textures, self.attributes,
                                      self.camera, grids, scale)
            names = [] if made is None or made[2] is None else [
                self.attributes[k] for k in attributes_read(made[2], 0)]
            names = [n for n in names if n in grids]
            self._index[key] = (self._append(made[0], made[1], None, made[2],
                                             material.name if material is not None
                                             else DEFAULT_VOLUME), tuple(names)) \
                if names else None
        return self._index[key]

    def _append(self, row, nodes, program, field, name: str) -> int:
        """A new material row with its BSDF nodes, shader program and density program."""
        k = len(self.rows)
        for words, what in ((program, "program"), (field, "density_program")):
            if words is not None:
                row[what] = self.words
                self.programs.append(words)
                self.words += words.shape[0]
                self.program_flags[k] = self.program_flags.get(k, 0) | int(words[0, 3])
        self.rows.append(row)
        self.nodes.append(nodes)
        self.names.append(name)
        return k

    def bind_volumes(self, slots: np.ndarray, k_obj: int) -> np.ndarray:
        """The slots with each heterogeneous medium's material bound to the object whose row of
        SceneArrays.objects is ``k_obj`` (its density field reads the object's space and
        Generated coordinates): a material whose field another object reads already is copied
        for this one (the copy shares its nodes and programs)."""
        out = slots.copy()
        for i, k in enumerate(slots):
            k = int(k)
            row = self.rows[k]
            if k_obj < 0 or row["density_program"][0] <= 0 \
                    or row["volume_object"][0] in (0, k_obj + 1):
                if k_obj >= 0 and row["density_program"][0] > 0:
                    row["volume_object"] = k_obj + 1
                continue
            key = (k, "volume object", k_obj)
            if key not in self._index:
                self._index[key] = len(self.rows)
                copy = row.copy()
                copy["volume_object"] = k_obj + 1
                self.rows.append(copy)
                self.nodes.append(self.nodes[k])
                self.names.append(self.names[k])
                if k in self.program_flags:
                    self.program_flags[len(self.rows) - 1] = self.program_flags[k]
            out[i] = self._index[key]
        return out

    def slot_map(self, obj) -> np.ndarray:
        """Global material index for each of the object's slots (at least one entry)."""
        slots = [self.index(s.material) if s is not None else 0 for s in obj.material_slots]
        return np.array(slots or [0], np.int32)

    def reads(self, slots: np.ndarray, flag: int) -> bool:
        """Whether the program of a material of these (global) slots has header flag ``flag``
        (PROGRAM_TANGENTS: a tangent-space Normal Map; PROGRAM_GENERATED: Generated
        coordinates): the object's mesh must export what it reads."""
        return any(self.program_flags.get(int(k), 0) & flag for k in slots)

    def anisotropic(self, slots: np.ndarray) -> bool:
        """Whether a material of these (global) slots is anisotropic: it needs tangents."""
        for k in {int(i) for i in slots}:
            rows = [shader_node(**n) if isinstance(n, dict) else n for n in self.nodes[k]]
            if rows and anisotropic_nodes(np.concatenate(rows)).any():
                return True
        return False

    def array(self) -> np.ndarray:
        return np.concatenate(self.rows)

    def svm(self) -> np.ndarray:
        """Every material's shader program, one after another (SceneArrays.svm)."""
        return np.concatenate(self.programs)

    def node_array(self) -> np.ndarray:
        """Every material's BSDF nodes, ordered by material."""
        rows = []
        for k, nodes in enumerate(self.nodes):
            for n in nodes:
                if isinstance(n, dict):
                    n = shader_node(**n)
                n = n.copy()
                n["material"] = k
                rows.append(n)
        return np.concatenate(rows) if rows else np.zeros(0, SHADER_NODE_DTYPE)
