"""Small scenes of media for the volume tests (test_volumes.py, test_volume_fields.py): materials
with a Volume output, boxes and planes, the fog room, and renders by both engines."""
import pytest

bpy = pytest.importorskip("bpy")

from tests.helpers.blender_scenes import add_light, light_world_camera

W = 32


def volume_material(name, kind="ShaderNodeVolumePrincipled", surface=None, **inputs):
    """A material whose Volume output is a ``kind`` node with ``inputs``; ``surface``: a BSDF
    node type on its Surface output (none: a volume only)."""
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    for n in list(nt.nodes):
        if n.bl_idname != "ShaderNodeOutputMaterial":
            nt.nodes.remove(n)
    out = nt.nodes["Material Output"]
    v = nt.nodes.new(kind)
    for k, val in inputs.items():
        v.inputs[k].default_value = val
    nt.links.new(v.outputs[0], out.inputs["Volume"])
    if surface is not None:
        s = nt.nodes.new(surface)
        nt.links.new(s.outputs[0], out.inputs["Surface"])
    return m


def diffuse(name, color):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    m.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (*color, 1)
    m.node_tree.nodes["Principled BSDF"].inputs["Roughness"].default_value = 1.0
    m.node_tree.nodes["Principled BSDF"].inputs["Specular IOR Level"].default_value = 0.0
    return m


def cube(name, material, loc=(0, 0, 0), size=2.0):
    bpy.ops.mesh.primitive_cube_add(size=size, location=loc)
    obj = bpy.context.active_object
    obj.name = name
    obj.data.materials.append(material)
    return obj


def plane(name, material, loc, rot=(0, 0, 0), size=8.0):
    bpy.ops.mesh.primitive_plane_add(size=size, location=loc, rotation=rot)
    obj = bpy.context.active_object
    obj.name = name
    obj.data.materials.append(material)
    return obj


def base_scene(camera=((0, -6, 1.5), (1.35, 0, 0), 35.0)):
    """Empty factory scene: black world, a camera, a box filter."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    light_world_camera(scene, light=None, world=0.0, camera=camera)
    return scene


def spot(loc=(0, 0, 3.5), energy=800.0, angle=0.6):
    return add_light("SPOT", "Spot", loc, energy=energy, spot_size=angle, shadow_soft_size=0.0)


def fog_room(density=0.3, anisotropy=0.0):
    """A floor and a back wall, a fog cube (Principled Volume) under a spot light."""
    scene = base_scene()
    grey = diffuse("Grey", (0.6, 0.6, 0.6))
    plane("Floor", grey, (0, 0, -1.2))
    plane("Wall", grey, (0, 3, 2), rot=(1.5708, 0, 0))
    fog = volume_material("Fog", Density=density, Anisotropy=anisotropy,
                          Color=(0.9, 0.9, 0.9, 1))
    cube("Fog", fog, loc=(0, 0, 0.6), size=3.0)
    spot()
    return scene


def both(scene, cycles, render_exr, tmp_path, tiny, samples, passes, bounces=0):
    """(ours, Cycles') W x W RGB: Cycles at ``samples``, this engine in ``passes`` passes, both
    with ``bounces`` bounces of every surface kind and Volume bounces 0 (single scattering)."""
    cycles(scene, samples, width=W)
    c = scene.cycles
    c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = bounces
    c.volume_bounces = 0
    c.transparent_max_bounces = 8
    ref = render_exr(tmp_path / "cycles.exr")
    tiny(scene, width=W, height=W, passes=passes, photons=4096)
    ours = render_exr(tmp_path / "ours.exr")
    return ours, ref


def absorption_scene(color, density):
    """An orthographic view through a Volume Absorption cube 1 m deep onto an emissive wall of
    radiance 1 behind it (the cube covers the middle of the image)."""
    scene = base_scene(camera=((0, 0, 5), (0, 0, 0), 50.0))
    scene.camera.data.type, scene.camera.data.ortho_scale = "ORTHO", 2.0
    wall = bpy.data.materials.new("Glow")
    wall.use_nodes = True
    nt = wall.node_tree
    nt.nodes.remove(nt.nodes["Principled BSDF"])
    em = nt.nodes.new("ShaderNodeEmission")
    nt.links.new(em.outputs[0], nt.nodes["Material Output"].inputs["Surface"])
    plane("Wall", wall, (0, 0, -2), size=4.0)
    ink = volume_material("Ink", "ShaderNodeVolumeAbsorption", Color=(*color, 1), Density=density)
    cube("Ink", ink, size=1.0)
    return scene
