"""Image Texture nodes -> the texture table and texels of SceneArrays (kernels/svm/textures.h).

Images are read once each (deduplicated by datablock) with ``pixels.foreach_get`` into a
float32 buffer (rows bottom-up; 8-bit images read as their stored bytes / 255)
and stored as float16 RGBA: float images linear, 8-bit sRGB images still encoded and decoded
by the kernel after interpolation (TEX_FLAG_SRGB, as Cycles' byte textures); colours with alpha
stored associated, as Cycles stores them.  Packed and
external images read the same way; an image that cannot be loaded (a missing file) renders
magenta, as in Cycles, with a warning naming the material and the file.  A UDIM image (source
'TILED') is one texture per tile, each read from its own file (a tile whose file cannot be
read: warned, magenta as in Cycles).
"""
from __future__ import annotations

import contextlib
import os
import tempfile

import numpy as np

from ppm_engine.scene.arrays import (
    TEX_CLIP,
    TEX_EXTEND,
    TEX_FLAG_CLOSEST,
    TEX_FLAG_CUBIC,
    TEX_FLAG_SRGB,
    TEX_MIRROR,
    TEX_REPEAT,
    TEXTURE_DTYPE,
)

MISSING = (1.0, 0.0, 1.0)          # Cycles' colour for an image it cannot load
_EXTENSION = {"REPEAT": TEX_REPEAT, "EXTEND": TEX_EXTEND, "CLIP": TEX_CLIP,
              "MIRROR": TEX_MIRROR}
# Cycles renders 'Smart' as 'Cubic' (its CPU kernels and GPUs alike)
_INTERPOLATION = {"Closest": TEX_FLAG_CLOSEST, "Cubic": TEX_FLAG_CUBIC, "Smart": TEX_FLAG_CUBIC}
# Vector inputs that mean "the UV map" (anything else is not evaluated: warned)
_UV_SOURCES = {("ShaderNodeTexCoord", "UV"), ("ShaderNodeUVMap", "UV")}


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    """The sRGB transfer function, inverted (IEC 61966-2-1), on values in [0, 1]."""
    c = np.clip(c, 0.0, 1.0)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _follow(socket):
    """(node, output socket) feeding ``socket``, through reroutes; (None, None) if unlinked."""
    if socket is None or not socket.is_linked:
        return None, None
    link = socket.links[0]
    node, out = link.from_node, link.from_socket
    for _ in range(64):
        if node.bl_idname != "NodeReroute" or not node.inputs[0].is_linked:
            break
        link = node.inputs[0].links[0]
        node, out = link.from_node, link.from_socket
    return node, out


def _associable(image) -> bool:
    """Whether Cycles stores this image with associated alpha (the colour times alpha): unless
    it is data, its alpha is channel-packed or ignored, or it has no alpha channel."""
    if image.colorspace_settings.is_data or image.alpha_mode in ("CHANNEL_PACKED", "NONE"):
        return False
    return int(image.channels) in (2, 4)


def _unassociates(node) -> bool:
    """Whether Cycles divides this Image Texture's Color by its alpha: where its Alpha output
    is linked and its image is stored associated (an Environment Texture has no Alpha)."""
    alpha = node.outputs.get("Alpha")
    return (node.image is not None and alpha is not None and alpha.is_linked
            and _associable(node.image))


class TextureTable:
    """The textures of one export, 1-based indices (0 = none), one entry per image datablock
    and sampling mode."""

    def __init__(self, warn, decoded: dict | None = None):
        self.warn = warn
        self.decoded = decoded      # (image, tile) -> a read's result, kept across exports
        self.reads = 0              # images read (not from ``decoded``)
        self.rows: list[np.ndarray] = []
        self.texels: list[np.ndarray] = []
        self.count = 0
        self.opaque: list[bool] = []       # per texture: every alpha is 1
        self._index: dict = {}

    def from_socket(self, socket, what: str, material: str, output: str = "Color"):
        """For a colour input (``output`` "Color") or an alpha input ("Alpha"): (texture index,
        None) when an Image Texture node drives it, (0, rgb) when it must take a constant
        instead (a missing image: magenta), (0, None) when it is not linked to an image
        texture (the caller reads its value)."""
        node, out = _follow(socket)
        if node is None or node.bl_idname != "ShaderNodeTexImage":
            return 0, None
        if out is not None and out.name != output:
            return 0, None                 # the other output: the shader program's
        vec, vec_out = _follow(node.inputs.get("Vector"))
        if vec is not None and ((vec.bl_idname, getattr(vec_out, "name", "")) not in _UV_SOURCES
                                or getattr(vec, "uv_map", "")):
            return 0, None                 # other coordinates: the shader program's
        if node.image is not None and (node.image.source == "TILED"
                                       or getattr(node, "projection", "FLAT") != "FLAT"):
            return 0, None                 # tiles, projections: the shader program's
        tex, missing = self.image_index(node, material)
        if tex and output == "Color" and self.unassociates(node, tex):
            return 0, None                 # a colour divided by alpha: the shader program's
        return tex, missing

    def unassociates(self, node, tex: int) -> bool:
        """Whether Cycles divides this node's Color from texture ``tex`` by its alpha: the
        texture has partial alpha and _unassociates."""
        return _unassociates(node) and not self.opaque[tex - 1]

    def image_index(self, node, material: str, tile: int = 0):
        """(texture index, None) for an Image Texture node's image and sampling mode, or
        (0, MISSING) when it has no image or the image cannot be loaded.  Of a UDIM image: its
        ``tile`` (default 1001, the tile Cycles' box projection reads)."""
        image = node.image
        if image is None:
            self.warn(f"Material '{material}': image node '{node.name}' has no image; it renders "
                      "magenta, as in Cycles")
            return 0, MISSING
        flags = _EXTENSION.get(getattr(node, "extension", "REPEAT"), TEX_REPEAT)
        flags |= _INTERPOLATION.get(node.interpolation, 0)
        tile = (tile or 1001) if image.source == "TILED" else 0
        key = (image.name_full, tile, flags)
        if key not in self._index:
            texels, srgb, (w, h), opaque = self._decoded(image, tile, material)
            if texels is None:
                self._index[key] = 0
                return 0, MISSING
            if srgb:
                flags |= TEX_FLAG_SRGB
            row = np.zeros(1, TEXTURE_DTYPE)
            row["offset"], row["width"], row["height"], row["flags"] = self.count, w, h, flags
            self.rows.append(row)
            self.texels.append(texels)
            self.opaque.append(opaque)
            self.count += texels.shape[0]
            self._index[key] = len(self.rows)
        tex = self._index[key]
        return (tex, None) if tex else (0, MISSING)

    def _decoded(self, image, tile: int, material: str):
        """_read or _read_tile, and whether every alpha is 1: (texels, srgb, (w, h), opaque);
        from ``decoded`` where this image was read before, with what reading it warned said
        again (an image that could not be read is read again: its warning is this export's)."""
        key = (image.name_full, tile)
        if self.decoded is not None and key in self.decoded:
            *got, said = self.decoded[key]
            for msg in said:
                self.warn(msg)
            return tuple(got)
        self.reads += 1
        said, warn = [], self.warn
        self.warn = lambda msg: said.append(msg) or warn(msg)
        try:
            got = self._read_tile(image, tile, material) if tile else self._read(image, material)
        finally:
            self.warn = warn
        if got[0] is None:
            return (*got, False)
        got = (*got, bool((got[0][:, 3] >= 1.0).all()))
        if self.decoded is not None:
            self.decoded[key] = (*got, tuple(said))
        return got

    def tiles(self, node, material: str) -> list[tuple[int, int]]:
        """(tile number, texture index or 0 when it cannot be read) of each tile of a UDIM
        image (Cycles' tile list: the image's tiles)."""
        return [(int(t.number), self.image_index(node, material, int(t.number))[0])
                for t in node.image.tiles]

    def _read_tile(self, image, tile: int, material: str):
        """A UDIM tile read from its packed data or its own file (the image's path with the
        tile's number for its <UDIM> or <UVTILE> token), through a temporary image datablock
        removed after."""
        import bpy
        path = bpy.path.abspath(image.filepath, library=image.library)
        u, v = (tile - 1001) % 10, (tile - 1001) // 10
        tile_path = path.replace("<UDIM>", str(tile)).replace("<UVTILE>", f"u{u + 1}_v{v + 1}")
        packed = next((p for p in image.packed_files if p.tile_number == tile), None)
        if tile_path == path and packed is None:   # generated tiles: the first is readable
            if image.tiles and tile == int(image.tiles[0].number):
                return self._read(image, material)
            self.warn(f"Material '{material}': tile {tile} of image '{image.name}' is not in a "
                      "file this engine can read; it renders magenta")
            return None, False, (0, 0)
        with tempfile.TemporaryDirectory(prefix="ppm-tile-") as folder:
            if packed is not None:
                tile_path = os.path.join(folder, "tile" + os.path.splitext(packed.filepath)[1])
                with open(tile_path, "wb") as f:
                    f.write(packed.packed_file.data)
            try:
                img = bpy.data.images.load(tile_path, check_existing=False)
            except (RuntimeError, OSError):
                self.warn(f"Material '{material}': tile {tile} of image '{image.name}' "
                          f"('{tile_path}') cannot be loaded (a missing or unreadable file); "
                          "it renders magenta, as in Cycles")
                return None, False, (0, 0)
            try:
                try:
                    img.colorspace_settings.name = image.colorspace_settings.name
                    img.alpha_mode = image.alpha_mode
                except (TypeError, ValueError):
                    pass
                return self._read(img, material, f"tile {tile} of image '{image.name}'")
            finally:
                bpy.data.images.remove(img)

    def _read(self, image, material: str, label: str = ""):
        w, h = image.size
        if w == 0 or h == 0:
            with contextlib.suppress(RuntimeError):   # not loaded yet (a render loads it lazily)
                image.reload()
            w, h = image.size
        if w == 0 or h == 0 or not image.has_data:
            where = f" ('{image.filepath}')" if image.filepath else ""
            label = label or f"image '{image.name}'"
            self.warn(f"Material '{material}': {label}{where} cannot be loaded (a missing or "
                      "unreadable file); it renders magenta, as in Cycles")
            return None, False, (0, 0)
        c = int(image.channels) or 4
        raw = np.empty(w * h * c, np.float32)
        image.pixels.foreach_get(raw)
        raw = raw.reshape(-1, c)
        px = np.ones((w * h, 4), np.float32)             # RGBA; grey images fill RGB
        px[:, :3] = raw[:, :3] if c >= 3 else raw[:, :1]
        if c in (2, 4):
            px[:, 3] = raw[:, c - 1]
        if _associable(image) and not image.is_float:
            # Cycles associates 8-bit images in their bytes (c a / 255, truncated) before the
            # sRGB decoding; Blender's float buffers are associated already
            b = np.round(np.clip(px, 0.0, 1.0) * 255.0).astype(np.int32)
            px[:, :3] = ((b[:, :3] * b[:, 3:]) // 255).astype(np.float32) / 255.0
        cs = image.colorspace_settings
        srgb = False
        if not image.is_float and not cs.is_data:
            name = cs.name
            if not name.lower().startswith("srgb") and "linear" not in name.lower():
                self.warn(f"Material '{material}': image '{image.name}' is in colour space "
                          f"'{name}', which this engine reads as sRGB")
            # 8-bit sRGB: kept encoded (float16 holds every byte value / 255 to 2e-4) and
            # decoded after interpolation in the kernel (TEX_FLAG_SRGB), as Cycles does
            srgb = "linear" not in name.lower()
        px = np.nan_to_num(px, nan=0.0, posinf=65504.0, neginf=0.0)
        return np.clip(px, 0.0, 65504.0).astype(np.float16), srgb, (w, h)

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        if not self.rows:
            return np.zeros(0, TEXTURE_DTYPE), np.zeros((0, 4), np.float16)
        texels = self.texels[0] if len(self.texels) == 1 else np.concatenate(self.texels)
        return np.concatenate(self.rows), texels          # (one image: its decoded array)
