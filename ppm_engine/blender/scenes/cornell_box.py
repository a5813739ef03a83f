"""The Cornell box, built with bpy from nothing (also the room of the bulb box).

Box: x, y in [-1, 1], z in [0, 2], open towards -y where the camera is.  Walls are Lambertian
(Principled with Roughness 1 and Specular IOR Level 0, so Cycles renders them as pure Lambert
too).  Light: a 0.5 x 0.5 m emissive quad 1 cm under the ceiling facing down, radiance
``LAMP_RADIANCE`` (power pi * A * L = 11.8 W).  Two white boxes stand on the floor.

The geometry matches ``ppm_engine.oracle.procedural.cornell_box`` (the arrays version)."""
from __future__ import annotations

import math

import bpy

import bmesh
import numpy as np

from ppm_engine.blender.harness import unbiased_light_paths

WHITE = (0.73, 0.73, 0.73)
RED = (0.63, 0.065, 0.05)
GREEN = (0.14, 0.45, 0.091)
LAMP_RADIANCE = 15.0
RESOLUTION = 256


# --- helpers shared with bulb_box.py ------------------------------------------------------------
def principled(name, inputs):
    """A material of the default Principled BSDF with these inputs (an RGB tuple is a colour,
    alpha 1); the others keep Blender's defaults."""
    m = bpy.data.materials.new(name)
    node = m.node_tree.nodes["Principled BSDF"]
    for k, v in inputs.items():
        node.inputs[k].default_value = (*v, 1.0) if isinstance(v, tuple) else v
    return m


def lambert(name, color):
    return principled(name, {"Base Color": tuple(color), "Roughness": 1.0,
                             "Specular IOR Level": 0.0})


def glass(name, ior=1.5):
    """Clear glass: Principled, Transmission Weight 1, Roughness 0 (Specular IOR Level default)."""
    return principled(name, {"Base Color": (1.0, 1.0, 1.0), "Roughness": 0.0,
                             "Transmission Weight": 1.0, "IOR": ior})


def emission(name, radiance):
    """Emission shader, white, Strength = radiance in W/(m^2 sr)."""
    m = bpy.data.materials.new(name)
    tree = m.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    e = tree.nodes.new("ShaderNodeEmission")
    e.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    e.inputs["Strength"].default_value = radiance
    tree.links.new(e.outputs["Emission"], tree.nodes["Material Output"].inputs["Surface"])
    return m


def _link(scene, name, mesh, material):
    mesh.materials.append(material)
    obj = bpy.data.objects.new(name, mesh)
    scene.collection.objects.link(obj)
    return obj


def quad(scene, name, corners, material):
    """One quad; its normal follows the corner order (right hand)."""
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(map(float, c)) for c in corners], [], [(0, 1, 2, 3)])
    mesh.update()
    return _link(scene, name, mesh, material)


def box(scene, name, lo, hi, material):
    """Axis-aligned closed box with outward normals."""
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    v = [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0),
         (x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)]
    f = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(map(float, p)) for p in v], [], f)
    mesh.update()
    return _link(scene, name, mesh, material)


def grid_mesh(name: str, co):
    """A mesh of quads on an (n, n, 3) grid of vertex positions (rows along y, columns along
    x), built with foreach_set (no Python loop per vertex); normals up for a grid ordered as
    numpy.meshgrid(xs, ys) orders it."""
    co = np.asarray(co, np.float32)
    n = co.shape[0]
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    a = (i * n + j).ravel()                      # each quad's corner at (row, column)
    quads = np.stack([a, a + 1, a + n + 1, a + n], 1).astype(np.int32)
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(n * n)
    mesh.vertices.foreach_set("co", co.reshape(-1))
    mesh.loops.add(quads.size)
    mesh.loops.foreach_set("vertex_index", quads.ravel())
    mesh.polygons.add(quads.shape[0])
    mesh.polygons.foreach_set("loop_start", np.arange(0, quads.size, 4, dtype=np.int32))
    mesh.update()
    mesh.validate()
    return mesh


def _sort(seq, key) -> None:
    """A bmesh sequence in the order of ``key`` (bmesh sorts by a number: the rank)."""
    seq.index_update()
    items = list(seq)
    rank = [0] * len(items)
    for r, e in enumerate(sorted(items, key=key)):
        rank[e.index] = r
    seq.sort(key=lambda e: rank[e.index])
    seq.index_update()


def sphere(scene, name, center, radius, material, segments=32, rings=16):
    """Smooth-shaded UV sphere (bmesh: no operator context needed)."""
    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=segments, v_segments=rings, radius=radius)
    # bmesh orders the sphere's elements differently from one process to the next: sorted, the
    # mesh (and so a render of it with a given seed) is the same in every run
    _sort(bm.verts, lambda v: tuple(v.co))
    _sort(bm.faces, lambda f: sorted(v.index for v in f.verts))
    bm.to_mesh(mesh)
    bm.free()
    mesh.shade_smooth()
    obj = _link(scene, name, mesh, material)
    obj.location = center
    return obj


def new_scene(scene=None):
    """``scene`` None: reset to an empty file and use its scene.  Otherwise empty the given
    scene (its objects and child collections are unlinked, nothing else in the file changes)."""
    if scene is None:
        bpy.ops.wm.read_factory_settings(use_empty=True)
        return bpy.context.scene
    for child in list(scene.collection.children):
        scene.collection.children.unlink(child)
    for obj in list(scene.collection.objects):
        scene.collection.objects.unlink(obj)
    return scene


def room(scene):
    """The five walls (floor, ceiling, back white; left red; right green), facing inwards."""
    white, red, green = lambert("White", WHITE), lambert("Red", RED), lambert("Green", GREEN)
    quad(scene, "Floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], white)
    quad(scene, "Ceiling", [(-1, -1, 2), (-1, 1, 2), (1, 1, 2), (1, -1, 2)], white)
    quad(scene, "Back", [(-1, 1, 0), (1, 1, 0), (1, 1, 2), (-1, 1, 2)], white)
    quad(scene, "Left", [(-1, -1, 0), (-1, 1, 0), (-1, 1, 2), (-1, -1, 2)], red)
    quad(scene, "Right", [(1, -1, 0), (1, -1, 2), (1, 1, 2), (1, 1, 0)], green)
    return white


def camera_world_render(scene, location=(0.0, -2.9, 1.0), rotation=(math.pi / 2, 0.0, 0.0),
                        resolution=RESOLUTION):
    """A 35 mm lens on a 36 mm sensor (by default at (0, -2.9, 1) looking along +y); black
    world; ``resolution`` squared at 100 %, no dithering, opaque film; Light Paths of 12
    bounces of every kind, no clamping (harness.unbiased_light_paths: the converged light
    the benchmark's references render; Cycles' defaults would stop diffuse light after 4
    bounces and clamp it).  The render engine is left to the caller."""
    cam_data = bpy.data.cameras.new("Camera")
    cam_data.lens, cam_data.sensor_width = 35.0, 36.0
    cam_data.clip_start, cam_data.clip_end = 0.1, 100.0
    cam = bpy.data.objects.new("Camera", cam_data)
    scene.collection.objects.link(cam)
    cam.location = location
    cam.rotation_euler = rotation
    scene.camera = cam

    world = bpy.data.worlds.new("World")
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    world.color = (0.0, 0.0, 0.0)
    scene.world = world
    r = scene.render
    r.resolution_x = r.resolution_y = resolution
    r.resolution_percentage = 100
    r.pixel_aspect_x = r.pixel_aspect_y = 1.0
    r.use_border = False
    r.dither_intensity = 0.0
    r.film_transparent = False
    unbiased_light_paths(scene)
    scene.frame_set(1)


# --- the example ------------------------------------------------------------------------------
def build(scene=None):
    """Build the Cornell box (see the module docstring); returns the scene."""
    scene = new_scene(scene)
    white = room(scene)
    quad(scene, "Lamp", [(-0.25, -0.25, 1.99), (-0.25, 0.25, 1.99), (0.25, 0.25, 1.99),
                         (0.25, -0.25, 1.99)], emission("Lamp", LAMP_RADIANCE))
    box(scene, "TallBox", (-0.6, -0.1, 0.0), (-0.1, 0.5, 1.2), white)
    box(scene, "ShortBox", (0.15, -0.5, 0.0), (0.65, 0.0, 0.6), white)
    camera_world_render(scene)
    return scene
