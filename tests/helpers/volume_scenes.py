"""Small scenes of media for the volume tests (test_volumes.py, test_volume_fields.py): materials
with a Volume output, boxes and planes, the fog room, and renders by both engines."""
import numpy as np
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


def drive_density(material, node_name, kind, output="Fac", **inputs):
    """A ``kind`` texture node (its default vector: Generated coordinates) into the Density of
    the material's volume node ``node_name``; returns the texture node.  The material's Cycles
    Step Rate 4: Cycles' unbiased volumes then bound the density on a coarser grid (the same
    image, measured bit for bit on the Noise fog below, in half the time: 4 s against 8 s)."""
    material.cycles.volume_step_rate = 4.0
    nt = material.node_tree
    tex = nt.nodes.new(kind)
    for k, v in inputs.items():
        if hasattr(tex, k):
            setattr(tex, k, v)
        else:
            tex.inputs[k].default_value = v
    nt.links.new(tex.outputs[output], nt.nodes[node_name].inputs["Density"])
    return tex


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


def volume_cube(name, material=None, res=8, loc=(0, 0, 0), ramp=1.0):
    """A Volume object whose "density" grid a geometry-nodes Volume Cube writes: ``res``^3
    voxels with centres from -1 to 1 (object space), the density x + ``ramp`` there (0 on the
    x = -1 face: those voxels are inactive); ``material`` set on the grid by the nodes (a
    volume made by nodes keeps only the materials they set), none: Cycles' default volume."""
    bpy.ops.object.volume_add(location=loc)
    obj = bpy.context.active_object
    obj.name = name
    tree = bpy.data.node_groups.new(name, "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    nodes, links = tree.nodes, tree.links
    cube = nodes.new("GeometryNodeVolumeCube")
    for axis in "XYZ":
        cube.inputs[f"Resolution {axis}"].default_value = res
    sep = nodes.new("ShaderNodeSeparateXYZ")
    links.new(nodes.new("GeometryNodeInputPosition").outputs[0], sep.inputs[0])
    add = nodes.new("ShaderNodeMath")
    add.inputs[1].default_value = ramp
    links.new(sep.outputs["X"], add.inputs[0])
    links.new(add.outputs[0], cube.inputs["Density"])
    out = cube.outputs[0]
    if material is not None:
        setm = nodes.new("GeometryNodeSetMaterial")
        setm.inputs["Material"].default_value = material
        links.new(out, setm.inputs["Geometry"])
        out = setm.outputs[0]
    links.new(out, nodes.new("NodeGroupOutput").inputs[0])
    obj.modifiers.new("Cube", "NODES").node_group = tree
    return obj


def vdb_volume(name, path, grids):
    """A Volume object reading the .vdb file ``path`` that this writes with Blender's openvdb
    module: ``grids`` {name: (values (nx, ny, nz) float32, or (nx, ny, nz, 3) for a vector
    grid, voxel size, index (i, j, k) of
    values[0, 0, 0], translation)}."""
    from ppm_engine.blender.export.volume_object import openvdb_module
    ovdb = openvdb_module()
    made = []
    for grid_name, (values, size, ijk, shift) in grids.items():
        g = ovdb.Vec3SGrid() if np.ndim(values) == 4 else ovdb.FloatGrid()
        g.name = grid_name
        g.copyFromArray(values, ijk=ijk)
        t = ovdb.createLinearTransform(voxelSize=size)
        t.postTranslate(shift)
        g.transform = t
        made.append(g)
    ovdb.write(str(path), grids=made)
    vol = bpy.data.volumes.new(name)
    vol.filepath = str(path)
    obj = bpy.data.objects.new(name, vol)
    bpy.context.scene.collection.objects.link(obj)
    return obj
