"""A value of a shader program while it is compiled: a constant or stack slots (shared by the
compiler, shader_graph.py, and the node modules, shader_nodes.py and shader_textures.py)."""
from __future__ import annotations


class Val:
    """A value in the program: a constant (tuple of floats) or stack slots; n = 1 or 3."""
    __slots__ = ("const", "n", "slot")

    def __init__(self, n, const=None, slot=None):
        self.n, self.const, self.slot = n, const, slot

    @property
    def is_const(self):
        return self.const is not None

    def __repr__(self):
        return f"Val({self.n}, {self.const if self.is_const else f'slot {self.slot:d}'})"


class ShadingNormal(Val):
    """The shading normal as an unlinked Normal input reads it: the constant 0 a BSDF node's
    or a Bump node's Normal takes for its own shading normal (no program needed); any other
    input it feeds reads the Geometry node's Normal instead (Compiler.input)."""
    __slots__ = ()

    def __init__(self):
        super().__init__(3, const=(0.0, 0.0, 0.0))


def width(socket_type: str) -> int:
    """Floats a socket of this type holds (colour and vector 3, the rest 1)."""
    return 3 if socket_type in ("RGBA", "VECTOR") else 1
