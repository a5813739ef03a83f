"""The world's importance map (Cycles' background map): the radiance of the world's shader
program baked on the device at the texel centres of a lat-long map (kernels/light/world_map.cl),
then, on the host, the map's values f = mean(|rgb|) x sin(theta) and their 2-D CDF, which the
kernels sample for next-event estimation and photon emission (kernels/light/world.h).  The density
of a direction is f / mean(f) in (u, v), over solid angle / (2 pi^2 sin(theta)); the world's
power is pi R^2 x 2 pi^2 mean(f) (radiance over the sphere through a disc of radius R)."""
from __future__ import annotations

import dataclasses

import numpy as np

from ppm_engine.scene.shader_program import (
    SKY_TYPES,
    SVM_END,
    SVM_IMAGE,
    SVM_OPS,
    SVM_TEX_SKY,
    op_words,
    ops_define,
    ops_used,
    stack_used,
)

DEFAULT_WIDTH = 512        # without an Environment Texture
# With an Environment Texture the map has ENV_OVERSAMPLING texels per image texel across, at
# least ENV_MIN_WIDTH and at most ENV_MAX_WIDTH wide.  Its texels are the radiance at their
# centres, and an image's linear interpolation spreads a texel over the half texel around it:
# at one map texel per image texel, the half of that spread outside a bright texel (a sun of a
# few texels in an HDRI) has the density of its dark neighbours, and the sample of a closure
# that finds it is a firefly (Cycles bakes at least 4096 x 2048 there).  Measured on a 256 x 128
# HDRI with a 2 x 2-texel sun, direct light on the floor per sample: standard deviation 40 at
# 1x, 1.66 at 4x, 1.50 at 16x (docs/BENCHMARKS.md, "Settings chosen by measurement").
ENV_OVERSAMPLING = 4
ENV_MIN_WIDTH = 1024
ENV_MAX_WIDTH = 4096
MANUAL_MAX_WIDTH = 8192    # Cycles' Map Resolution (Manual) is taken up to this


@dataclasses.dataclass
class WorldMap:
    width: int
    height: int
    f: np.ndarray          # (h, w) float64 mean radiance x sin(theta) at the texel centres
    buffer: np.ndarray     # float32: marginal CDF, row CDFs, f (kernels/light/world.h layout)
    mean: float            # mean of f

    @property
    def integral(self) -> float:
        """The world's mean radiance integrated over the sphere (2 pi^2 mean(f))."""
        return 2 * np.pi ** 2 * self.mean


def map_size(width: int, height: int, manual: bool = False) -> tuple[int, int]:
    """(w, h) of the map: with ``manual`` (WORLD_MAP_MANUAL) the given size, else from the
    environment images' largest size (0: none), ENV_OVERSAMPLING times it within the bounds
    (the image's aspect kept)."""
    if manual:
        w = int(np.clip(width, 4, MANUAL_MAX_WIDTH))
        return w, int(np.clip(height, 2, MANUAL_MAX_WIDTH))
    if width <= 0 or height <= 0:
        return DEFAULT_WIDTH, DEFAULT_WIDTH // 2
    w = int(np.clip(ENV_OVERSAMPLING * int(width), ENV_MIN_WIDTH, ENV_MAX_WIDTH))
    h = int(np.clip(round(int(height) * w / int(width)), 1, ENV_MAX_WIDTH))
    return w, h


def build_map(rgb: np.ndarray) -> WorldMap:
    """The map of baked radiance ``rgb`` (h, w, 3), row 0 at the nadir."""
    h, w = rgb.shape[:2]
    rad = np.nan_to_num(np.abs(rgb.astype(np.float64)), nan=0.0, posinf=0.0).mean(axis=2)
    v = (np.arange(h) + 0.5) / h
    f = rad * np.sin(np.pi * v)[:, None]
    rows = f.sum(axis=1)
    total = float(rows.sum())
    marginal = np.concatenate([[0.0], np.cumsum(rows)]) / total if total > 0 else \
        np.linspace(0.0, 1.0, h + 1)
    cond = np.empty((h, w + 1))
    cond[:, 0] = 0.0
    cond[:, 1:] = np.cumsum(f, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        cond = np.where(rows[:, None] > 0, cond / rows[:, None], np.linspace(0.0, 1.0, w + 1))
    marginal[-1], cond[:, -1] = 1.0, 1.0
    buf = np.concatenate([marginal, cond.ravel(), f.ravel()]).astype(np.float32)
    return WorldMap(w, h, f, buf, total / (w * h))


def direction_to_uv(d: np.ndarray) -> np.ndarray:
    """Cycles' equirectangular (u, v) of directions (n, 3) (kernels/svm/svm.h)."""
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)
    return np.stack([0.5 - np.arctan2(d[..., 1], d[..., 0]) / (2 * np.pi),
                     1.0 - np.arccos(np.clip(d[..., 2], -1, 1)) / np.pi], -1)


def uv_to_direction(u, v) -> np.ndarray:
    phi, theta = np.pi * (1.0 - 2.0 * np.asarray(u)), np.pi * (1.0 - np.asarray(v))
    return np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1)


def map_pdf(m: WorldMap, d: np.ndarray) -> np.ndarray:
    """The map's density over solid angle of directions d (n, 3) (kernels/light/world.h)."""
    uv = direction_to_uv(d)
    j = np.clip(np.floor(uv[:, 0] * m.width).astype(int), 0, m.width - 1)
    i = np.clip(np.floor(uv[:, 1] * m.height).astype(int), 0, m.height - 1)
    s = np.sin(np.pi * uv[:, 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        p = m.f[i, j] / (m.mean * 2 * np.pi ** 2 * s)
    return np.where(s > 0, p, 0.0)


def bake_defines(svm: np.ndarray, program: int) -> dict:
    """-D flags of kernels/light/world_map.cl for the world's program."""
    ops = ops_used(svm, [program])
    return {"PPM_SPECIALIZED": True, "PPM_SVM": True, "PPM_SVM_OPS": ops_define(ops),
            "PPM_SVM_STACK": max(stack_used(svm, [program]), 1),
            **({"PPM_TEXTURES": True} if ops & (1 << SVM_IMAGE) else {})}


def sun_hint(svm: np.ndarray, program: int, width: int, height: int) -> np.ndarray:
    """(sun direction, cos of the angle within which texels are supersampled): the first sun
    disc of a Sky Texture in the world's program (its Vector is then the ray's direction), or
    a direction no texel is near; the disc (0.5 degrees for the real sun) is smaller than a
    texel, which the texel's centre alone would mostly miss."""
    none = np.array([0.0, 0.0, 1.0, 2.0], np.float32)
    if program <= 0:
        return none
    n_binds, n_words = int(svm[program, 0]), int(svm[program, 1])
    i, end = program + 1 + n_binds, program + n_words
    while i < end:
        op = int(svm[i, 0])
        if op == SVM_END or not 0 < op < SVM_OPS:
            break
        if op == SVM_TEX_SKY and int(svm[i, 3]) == SKY_TYPES["SINGLE_SCATTERING"]:
            p = svm[i + 2:i + 5].ravel().view(np.float32)
            elevation, rotation, diameter = float(p[6]), float(p[7]), float(p[8])
            if diameter > 0.0:            # (Cycles' sun direction of the kernel's sky)
                st, sp = elevation - np.pi / 2, rotation - np.pi / 2
                d = (np.sin(st) * np.cos(sp), np.sin(st) * np.sin(sp), np.cos(st))
                margin = 1.5 * max(2 * np.pi / width, np.pi / height)
                return np.array([*d, np.cos(diameter / 2 + margin)], np.float32)
        i += op_words(svm, i)
    return none


SUN_SUPERSAMPLING = 8      # points per side of a texel near a sun disc


def bake(device, args: dict, svm: np.ndarray, program: int, width: int, height: int,
         specialize: bool = True) -> np.ndarray:
    """The world's radiance (h, w, 3) at the map's texel centres (near a sun disc: the mean
    over the texel, sun_hint), evaluated on ``device``; ``args``: the scene's buffers by name
    (device_scene.SCENE_BUFFERS; the program reads svm and the textures).  ``specialize``: the
    program built for the world's own nodes (bake_defines), else for every node (one build
    that every world shares, as the passes' kernels of every feature)."""
    import pyopencl as cl
    prog = device.programs.get("light/world_map.cl",
                               bake_defines(svm, program) if specialize else {})
    kernel = prog.launch("world_bake", "world map")
    n = width * height
    out = device.buffer(16 * n, "world map")
    q = device.queue
    kernel(q, n, **args, program=np.int32(program), w=np.int32(width), h=np.int32(height),
           sun=sun_hint(svm, program, width, height), sub=np.int32(SUN_SUPERSAMPLING), out=out)
    rgba = np.empty((height, width, 4), np.float32)
    cl.enqueue_copy(q, rgba, out).wait()
    out.release()
    return rgba[..., :3]
