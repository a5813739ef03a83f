"""Scenes built directly as SceneArrays (no Blender): primitives for kernel tests, analytic
scenes and the benchmark.  The Blender versions of the examples live in ``scenes/``."""
from __future__ import annotations

import numpy as np

from ppm_engine.scene.arrays import (
    CAMERA_PERSP,
    LIGHT_DTYPE,
    MATERIAL_DTYPE,
    NODE_DIFFUSE,
    NODE_PRINCIPLED,
    SHADER_NODE_DTYPE,
    VIS_ALL,
    SceneArrays,
    shader_node,
)
from ppm_engine.scene.camera import make_camera, perspective_extent


class MeshBuilder:
    """Accumulates triangles with per-corner normals and a material index."""

    def __init__(self):
        self.pos, self.nrm, self.mat = [], [], []
        self.materials = []
        self.nodes = []
        self.names = []

    def material(self, name, base=(0.8, 0.8, 0.8), emission=(0, 0, 0), metallic=0.0,
                 roughness=1.0, transmission=0.0, ior=1.5, absorption=(0, 0, 0)) -> int:
        """A Principled BSDF without its specular layer (IOR Level 0): a Lambert base of colour
        ``base``, a metal of reflectance ``base`` (metallic), glass (transmission) and
        emission."""
        return self.shader(name, [dict(type=NODE_PRINCIPLED, color=base, emission=emission,
                                       metallic=metallic, roughness=roughness,
                                       transmission=transmission, ior=ior,
                                       specular_ior_level=0.0)], absorption)

    def diffuse(self, name, color=(0.8, 0.8, 0.8)) -> int:
        return self.shader(name, [dict(type=NODE_DIFFUSE, color=color)])

    def shader(self, name, nodes, absorption=(0, 0, 0)) -> int:
        """A material of BSDF nodes: dicts of SHADER_NODE_DTYPE fields (type required, Blender's
        defaults for the rest; arrays.shader_node)."""
        k = len(self.materials)
        m = np.zeros(1, MATERIAL_DTYPE)
        m["absorption"] = absorption
        self.materials.append(m)
        self.nodes.extend(shader_node(material=k, **n) for n in nodes)
        self.names.append(name)
        return k

    def add(self, tris, mat, normals=None):
        tris = np.asarray(tris, np.float32).reshape(-1, 3, 3)
        if normals is None:
            n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
            n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
            normals = np.repeat(n[:, None, :], 3, axis=1)
        self.pos.append(tris)
        self.nrm.append(np.asarray(normals, np.float32).reshape(-1, 3, 3))
        self.mat.append(np.full(tris.shape[0], mat, np.int32))

    def quad(self, center, u, v, mat):
        """Quad center +- u +- v; normal = u x v."""
        c, u, v = (np.asarray(a, np.float64) for a in (center, u, v))
        p = [c - u - v, c + u - v, c + u + v, c - u + v]
        self.add([[p[0], p[1], p[2]], [p[0], p[2], p[3]]], mat)

    def box(self, lo, hi, mat, inward=False):
        lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
        c, h = (lo + hi) / 2, (hi - lo) / 2
        s = -1.0 if inward else 1.0
        ex, ey, ez = np.eye(3)
        for axis, (a, b) in enumerate(((ey, ez), (ez, ex), (ex, ey))):
            n = np.eye(3)[axis]
            for sign in (1, -1):
                u, v = a * h, b * h
                if sign * s < 0:
                    u, v = v, u
                self.quad(c + sign * n * h, u, v, mat)

    def sphere(self, center, radius, mat, segments=32, rings=16, smooth=True, inward=False):
        th = np.linspace(0, np.pi, rings + 1)
        ph = np.linspace(0, 2 * np.pi, segments + 1)
        T, P = np.meshgrid(th, ph, indexing="ij")
        d = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1)
        a, b = d[:-1, :-1], d[1:, :-1]
        c, e = d[1:, 1:], d[:-1, 1:]
        t1 = np.stack([a, b, c], 2).reshape(-1, 3, 3)
        t2 = np.stack([a, c, e], 2).reshape(-1, 3, 3)
        dirs = np.concatenate([t1, t2])
        if inward:
            dirs = dirs[:, ::-1]
        area = np.linalg.norm(np.cross(dirs[:, 1] - dirs[:, 0], dirs[:, 2] - dirs[:, 0]), axis=1)
        dirs = dirs[area > 1e-12]
        tris = np.asarray(center) + radius * dirs
        self.add(tris, mat, (-dirs if inward else dirs) if smooth else None)

    def build(self, *, lights=None, camera, world=(0, 0, 0)) -> SceneArrays:
        pos = np.concatenate(self.pos) if self.pos else np.zeros((0, 3, 3), np.float32)
        nrm = np.concatenate(self.nrm) if self.nrm else np.zeros((0, 3, 3), np.float32)
        mat = np.concatenate(self.mat) if self.mat else np.zeros(0, np.int32)
        if self.materials:
            mats = np.concatenate(self.materials)
            nodes = np.concatenate(self.nodes) if self.nodes else np.zeros(0, SHADER_NODE_DTYPE)
        else:
            mats, nodes = np.zeros(1, MATERIAL_DTYPE), shader_node(NODE_DIFFUSE)
        t = pos.shape[0]
        return SceneArrays(positions=pos, normals=nrm, uvs=np.zeros((t, 3, 2), np.float32),
                           material=mat, visibility=np.full(t, VIS_ALL, np.uint32),
                           materials=mats, shader_nodes=nodes, lights=lights if lights is not None
                           else np.zeros(0, LIGHT_DTYPE), camera=camera,
                           world=np.asarray(world, np.float32),
                           material_names=tuple(self.names))


def look_at(eye, target, up=(0, 0, 1)) -> np.ndarray:
    """Camera-to-world 3x4 for a camera at eye looking at target (Blender: looks down -Z)."""
    eye, target, up = (np.asarray(a, np.float64) for a in (eye, target, up))
    f = target - eye
    f /= np.linalg.norm(f)
    r = np.cross(f, up)
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    m = np.zeros((3, 4))
    m[:, 0], m[:, 1], m[:, 2], m[:, 3] = r, u, -f, eye
    return m


def cornell_box(width=64, height=64, light_radiance=15.0, bulb=False,
                filament_radiance=120.0) -> SceneArrays:
    """The classic box (x, y in [-1, 1], z in [0, 2], open towards -y where the camera is).
    ``bulb``: no ceiling light; an emissive sphere inside a glass sphere, and a glass ball on
    the floor (the paper's bulb box)."""
    mb = MeshBuilder()
    white = mb.material("white", (0.73, 0.73, 0.73))
    red = mb.material("red", (0.63, 0.065, 0.05))
    green = mb.material("green", (0.14, 0.45, 0.091))
    mb.quad((0, 0, 0), (1, 0, 0), (0, 1, 0), white)        # floor, normal +z
    mb.quad((0, 0, 2), (0, 1, 0), (1, 0, 0), white)        # ceiling, normal -z
    mb.quad((0, 1, 1), (0, 0, 1), (1, 0, 0), white)        # back wall, normal -y
    mb.quad((-1, 0, 1), (0, 0, 1), (0, 1, 0), red)         # left wall, normal +x
    mb.quad((1, 0, 1), (0, 1, 0), (0, 0, 1), green)        # right wall, normal -x
    if bulb:
        glass = mb.material("glass", (1, 1, 1), transmission=1.0, roughness=0.0, ior=1.5)
        filament = mb.material("filament", (0, 0, 0), emission=(filament_radiance,) * 3)
        mb.sphere((0, 0, 1.6), 0.05, filament, 16, 8)
        mb.sphere((0, 0, 1.6), 0.15, glass, 32, 16)
        mb.sphere((0.3, 0.2, 0.3), 0.3, glass, 32, 16)
    else:
        lamp = mb.material("lamp", (0, 0, 0), emission=(light_radiance,) * 3)
        mb.quad((0, 0, 1.99), (0, 0.25, 0), (0.25, 0, 0), lamp)   # faces down
        mb.box((-0.6, -0.1, 0), (-0.1, 0.5, 1.2), white)
        mb.box((0.15, -0.5, 0), (0.65, 0.0, 0.6), white)
    ext = perspective_extent(width, height, 35.0, 36.0)
    cam = make_camera(type=CAMERA_PERSP, width=width, height=height,
                      to_world=look_at((0, -2.9, 1), (0, 0, 1)), extent=ext[:2], clip=(0.1, 100))
    return mb.build(camera=cam)


def gap_room(width=48, height=48, light="point", hole=0.4, power=400.0) -> SceneArrays:
    """Light through a small gap: a closed room (x, y in [-2, 2], z in [0, 2.5], white walls
    facing in) whose wall at x = 2 has a square window of side ``hole`` at (2, 0, 1.6), a
    ground plane outside, and one light 1.5 m outside the window, 0.3 m above it: a ``point``
    light (``power`` W), a ``spot`` aimed at the window (a 60 degree cone), an ``area`` light
    (a 0.5 m square facing the window) or a ``sphere`` (a point light of radius 0.1 m).  The
    camera inside looks at the patch of floor the window lights.  A photon emitted in the
    light's own distribution reaches the room with the window's solid angle (0.4 m: ~1 % of
    a point light's sphere): what photon guides are for (ppm_engine/scene/guide.py)."""
    from ppm_engine.scene.arrays import LIGHT_AREA_RECT, LIGHT_POINT, LIGHT_SPOT
    mb = MeshBuilder()
    white = mb.material("white", (0.7, 0.7, 0.7))
    ground = mb.material("ground", (0.5, 0.5, 0.5))
    x0, x1, y0, y1, z0, z1 = -2.0, 2.0, -2.0, 2.0, 0.0, 2.5
    mb.quad((0, 0, z0), (0, y1, 0), (x1, 0, 0), white)               # floor, normal +z (inside)
    mb.quad((0, 0, z1), (x1, 0, 0), (0, y1, 0), white)               # ceiling, normal -z
    mb.quad((0, y1, 1.25), (x1, 0, 0), (0, 0, 1.25), white)          # walls, normals inward
    mb.quad((0, y0, 1.25), (0, 0, 1.25), (x1, 0, 0), white)
    mb.quad((x0, 0, 1.25), (0, y1, 0), (0, 0, 1.25), white)
    # the wall at x = 2 (normal -x) around the window (centre (2, 0, wz), side `hole`)
    wz, h = 1.6, hole / 2

    def wall(ya, yb, za, zb):
        if yb > ya and zb > za:
            mb.quad((x1, (ya + yb) / 2, (za + zb) / 2), (0, 0, (zb - za) / 2),
                    (0, (yb - ya) / 2, 0), white)
    wall(y0, -h, z0, z1)
    wall(h, y1, z0, z1)
    wall(-h, h, z0, wz - h)
    wall(-h, h, wz + h, z1)
    # the wall's outside face (normal +x), with the window, and the ground outside: where most
    # photons go

    def outside(ya, yb, za, zb):
        if yb > ya and zb > za:
            mb.quad((x1 + 0.01, (ya + yb) / 2, (za + zb) / 2), (0, (yb - ya) / 2, 0),
                    (0, 0, (zb - za) / 2), white)
    outside(y0, -h, z0, z1)
    outside(h, y1, z0, z1)
    outside(-h, h, z0, wz - h)
    outside(-h, h, wz + h, z1)
    mb.quad((0, 0, -0.01), (8, 0, 0), (0, 8, 0), ground)
    pos = np.array([x1 + 1.5, 0.0, wz + 0.3])
    to = np.array([x1, 0.0, wz]) - pos
    to /= np.linalg.norm(to)
    L = np.zeros(1, LIGHT_DTYPE)
    L["position"], L["direction"] = pos, to
    if light in ("point", "sphere"):
        L["type"], L["emit"] = LIGHT_POINT, power / (4 * np.pi)
        L["radius"] = 0.1 if light == "sphere" else 0.0
    elif light == "spot":
        L["type"], L["emit"] = LIGHT_SPOT, power / (4 * np.pi)
        t, b = np.cross(to, (0, 0, 1)), None
        t /= np.linalg.norm(t)
        b = np.cross(to, t)
        L["axis_x"], L["axis_y"], L["spot_scale_z"] = t, b, 1.0
        L["spot_cos_half"] = np.cos(np.radians(30.0))
        L["spot_smooth"] = (1 - np.cos(np.radians(30.0))) * 0.2
    elif light == "area":
        t = np.cross(to, (0, 0, 1))
        t /= np.linalg.norm(t)
        b = np.cross(to, t)
        L["type"], L["emit"] = LIGHT_AREA_RECT, power / (np.pi * 0.25)
        L["axis_x"], L["axis_y"] = 0.5 * t, 0.5 * b
    else:
        raise ValueError(f"gap_room: light {light!r} is none of point, sphere, spot, area")
    ext = perspective_extent(width, height, 35.0, 36.0)
    cam = make_camera(type=CAMERA_PERSP, width=width, height=height,
                      to_world=look_at((-1.8, 0.3, 2.2), (0.9, -0.1, 0.0)), extent=ext[:2],
                      clip=(0.05, 100))
    return mb.build(camera=cam, lights=L)
