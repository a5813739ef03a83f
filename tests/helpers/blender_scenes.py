"""Blender scenes built with bpy for the exporter's and the renders' tests: a light, a plane, a
camera, a plane with an image texture, an area light with a grey world and a camera; and the
current scene exported to SceneArrays; a built scene set to a square size."""
import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from ppm_engine.blender.export import export_scene


def export():
    """The current scene exported to SceneArrays; a built scene set to a square size."""
    return export_scene(bpy.context.evaluated_depsgraph_get())


def square(scene, width):
    """``scene`` rendering ``width`` x ``width`` pixels at 100 %, its objects' matrices current
    (a script's edits): the bench's scenes at a test's size."""
    scene.render.resolution_x = scene.render.resolution_y = width
    scene.render.resolution_percentage = 100
    bpy.context.view_layer.update()
    return scene


def add_light(kind, name="L", loc=(0, 0, 3), **props):
    """A light of ``kind`` (its data's props set) at ``loc`` in the current scene."""
    data = bpy.data.lights.new(name, kind)
    for k, v in props.items():
        setattr(data, k, v)
    obj = bpy.data.objects.new(name, data)
    obj.location = loc
    bpy.context.scene.collection.objects.link(obj)
    return obj


def add_plane(name="Plane", material=None, loc=(0, 0, 0), size=2.0):
    """A plane ``size`` wide at ``loc``, with ``material`` if one is given."""
    bpy.ops.mesh.primitive_plane_add(size=size, location=loc)
    obj = bpy.context.active_object
    obj.name = name
    if material is not None:
        obj.data.materials.append(material)
    return obj


def add_camera(scene, ortho_width=None, location=(0, 0, 5), rotation=(0, 0, 0)):
    """The scene's camera: orthographic ``ortho_width`` wide, else perspective."""
    cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
    if ortho_width is not None:
        cam.data.type, cam.data.ortho_scale = "ORTHO", ortho_width
    cam.location, cam.rotation_euler = location, rotation
    scene.collection.objects.link(cam)
    scene.camera = cam


# a 4 x 2 image, rows bottom-up (Blender's order), values on the 8-bit grid
PIXELS = np.array([[[0.0, 0.2, 0.4, 1], [1.0, 0.0, 0.0, 1], [0.0, 1.0, 0.0, 1],
                    [0.0, 0.0, 1.0, 1]],
                   [[1.0, 1.0, 1.0, 1], [0.5, 0.5, 0.5, 1], [0.2, 0.6, 0.8, 1],
                    [0.8, 0.4, 0.1, 1]]], np.float32)
PIXELS = np.round(PIXELS * 255) / 255


def scene_with_texture(socket="Base Color", float_image=False, packed=False, path=None,
                       extension="REPEAT", interpolation="Linear"):
    """A factory scene with a camera and a plane whose Principled BSDF's ``socket`` reads a
    4 x 2 image of PIXELS (float or 8-bit, packed or from ``path``): (scene, image)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
    cam.location = (0, 0, 3)
    scene.collection.objects.link(cam)
    scene.camera = cam
    img = bpy.data.images.new("Tex", 4, 2, float_buffer=float_image)
    img.pixels.foreach_set(PIXELS.ravel())
    if packed:
        img.pack()
    if path is not None:
        img.filepath = str(path)
        img.source = 'FILE'
    m = bpy.data.materials.new("Textured")
    t = m.node_tree
    p = t.nodes["Principled BSDF"]
    node = t.nodes.new("ShaderNodeTexImage")
    node.image, node.extension, node.interpolation = img, extension, interpolation
    t.links.new(node.outputs["Color"], p.inputs[socket])
    if socket == "Emission Color":
        p.inputs["Emission Strength"].default_value = 3.0
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    bpy.context.active_object.data.materials.append(m)
    return scene, img


def light_world_camera(scene, *, light, world, camera):
    """An area light ((energy, size), location, rotation) or none, a constant grey world and a
    camera (location, rotation, lens) with a 1-pixel box filter."""
    if light is not None:
        (energy, size), location, rotation = light
        ld = bpy.data.lights.new("Area", "AREA")
        ld.energy, ld.size = energy, size
        lo = bpy.data.objects.new("Area", ld)
        lo.location, lo.rotation_euler = location, rotation
        scene.collection.objects.link(lo)
    scene.world = bpy.data.worlds.new("W")
    scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (world, world,
                                                                               world, 1)
    location, rotation, lens = camera
    cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
    cam.location, cam.rotation_euler, cam.data.lens = location, rotation, lens
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.render.dither_intensity = 0.0
    scene.cycles.pixel_filter_type, scene.cycles.filter_width = "BOX", 1.0
    scene.render.filter_size = 0.0
