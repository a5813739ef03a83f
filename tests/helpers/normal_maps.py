"""A tangent-space normal map on a subdivided icosphere, as reported from outside: an
icosphere with a Subdivision Surface modifier (viewport level 1, render level 2), smooth
shading, a Normal Map node (tangent space, its UV map field empty: the rendered UV map)
whose Color is a Non-Color PNG read through Texture Coordinate > UV, strength 1.  The
normal map's image is made here with NumPy and saved as an 8-bit PNG through bpy."""
import math

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")


def tilted_normals_png(path, n=64, tilt=0.5, tiles=8, smooth=False):
    """An n x n Non-Color PNG of tangent-space normals: tiles x tiles tiles, each tilted by
    ``tilt`` (the normal's xy length) in its own random direction; with ``smooth`` a tilt
    whose direction turns smoothly over the image instead (no edges: every pixel's normal is
    one value, whatever the pixel's samples)."""
    y, x = (np.mgrid[0:n, 0:n] + 0.5) / n
    if smooth:
        angle = 2.0 * np.pi * (2.0 * x + y)
    else:
        rng = np.random.default_rng(3)
        k = np.minimum((np.mgrid[0:n, 0:n] * tiles) // n, tiles - 1)
        angle = rng.uniform(0.0, 2.0 * np.pi, (tiles, tiles))[k[0], k[1]]
    xy = tilt * np.stack([np.cos(angle), np.sin(angle)], -1)
    rgb = np.concatenate([xy, np.sqrt(1.0 - (xy ** 2).sum(-1))[..., None]], -1) * 0.5 + 0.5
    img = bpy.data.images.new("Tilts", n, n)
    img.pixels.foreach_set(np.concatenate([rgb, np.ones((n, n, 1))], -1).astype(np.float32)
                           .ravel())
    img.filepath_raw, img.file_format = str(path), "PNG"
    img.save()
    bpy.data.images.remove(img)
    img = bpy.data.images.load(str(path))
    img.colorspace_settings.name = "Non-Color"
    return img


def normal_mapped_icosphere(png, **image):
    """The reported icosphere in a new empty scene, and its material's tree and Normal Map
    node, whose Color is the image tilted_normals_png(png, **image) makes, read through
    Texture Coordinate > UV; the material's Principled BSDF is left unlinked from it."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=2, radius=1.0)
    ob = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    mod = ob.modifiers.new("Subdivision", "SUBSURF")
    mod.levels, mod.render_levels = 1, 2
    m = bpy.data.materials.new("NormalMapped")
    ob.data.materials.append(m)
    t = m.node_tree
    tc, tex, nm = (t.nodes.new(k) for k in ("ShaderNodeTexCoord", "ShaderNodeTexImage",
                                              "ShaderNodeNormalMap"))
    tex.image = tilted_normals_png(png, **image)
    t.links.new(tc.outputs["UV"], tex.inputs["Vector"])
    t.links.new(tex.outputs["Color"], nm.inputs["Color"])
    return ob, t, nm


def look_at(scene, location, ortho_scale=None, lens=50.0):
    """The scene's camera at ``location`` looking at the origin (orthographic ``ortho_scale``
    wide, else perspective of ``lens`` mm); a black world."""
    import mathutils
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    cam.location = mathutils.Vector(location)
    cam.rotation_euler = (-cam.location).to_track_quat("-Z", "Y").to_euler()
    if ortho_scale is not None:
        cam.data.type, cam.data.ortho_scale = "ORTHO", ortho_scale
    else:
        cam.data.lens = lens
    scene.world = bpy.data.worlds.new("World")
    scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0, 0, 0, 1)
    scene.render.dither_intensity = 0.0
    return cam


def point_light(scene, location, energy=1000.0):
    """A point light of radius 0."""
    light = bpy.data.objects.new("Point", bpy.data.lights.new("Point", "POINT"))
    light.data.energy, light.data.shadow_soft_size = energy, 0.0
    light.location = location
    scene.collection.objects.link(light)
    return light


CAMERA = (0.0, -2.6, 0.0)          # the sphere fills most of the frame (perspective, 50 mm)


def reported_camera(scene):
    """The camera of the per-block comparisons: ahead of the sphere, close, looking at it."""
    cam = look_at(scene, CAMERA)
    cam.rotation_euler = (math.pi / 2, 0.0, 0.0)
    return cam
