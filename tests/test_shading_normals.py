"""Photons on smooth-shaded low-poly meshes as Cycles renders them
(kernels/integrator/photon_pass.cl, kernels/integrator/gather.cl): a cone of 16 sides with its base,
smooth shaded, so that its normals lean up to 60 degrees from its faces near the base and the tip
(the base's normals average in the base's), on a white floor under a sun, its indirect light by
photons, per block against Cycles."""
import math

import numpy as np
import pytest

from tests.helpers.blender_scenes import add_camera

W = 48


def _black_world(bpy, scene):
    scene.world = bpy.data.worlds.new("Black")
    scene.world.color = (0, 0, 0)


def _cone(bpy):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=20)
    floor = bpy.data.materials.new("Floor")
    bpy.context.active_object.data.materials.append(floor)
    fp = floor.node_tree.nodes["Principled BSDF"]
    fp.inputs["Base Color"].default_value = (0.8, 0.8, 0.8, 1)
    fp.inputs["Specular IOR Level"].default_value = 0.0
    bpy.ops.mesh.primitive_cone_add(radius1=1.0, depth=2.0, location=(0, 0, 1.0), vertices=16)
    bpy.ops.object.shade_smooth()
    cone = bpy.data.materials.new("Cone")
    bpy.context.active_object.data.materials.append(cone)
    t = cone.node_tree
    t.nodes.remove(t.nodes["Principled BSDF"])
    d = t.nodes.new("ShaderNodeBsdfDiffuse")
    d.inputs["Color"].default_value = (0.8, 0.8, 0.8, 1)
    t.links.new(d.outputs[0], t.nodes["Material Output"].inputs["Surface"])
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 5.0
    sun.rotation_euler = (math.radians(40), 0, math.radians(30))
    scene.collection.objects.link(sun)
    add_camera(scene, location=(0, -3.2, 1.05), rotation=(math.radians(88), 0, 0))
    scene.camera.data.lens = 35
    _black_world(bpy, scene)
    return scene


@pytest.mark.parametrize("passes,photons,rtol", [
    (512, 1 << 15, 0.15),                                      # 8 s on 2 cores
    pytest.param(1024, 1 << 16, 0.08, marks=pytest.mark.slow),  # 29 s
])
def test_photons_on_a_smooth_low_poly_cone_as_cycles(bpy, cycles, tiny, render_exr, tmp_path,
                                                     passes, photons, rtol):
    """Every 6 x 6 block within 8 % of Cycles (1024 samples) at 1024 passes, within 15 % at 512
    (the noise of fewer photons; the bug below fails either).  Photons lie on the faces, so the
    gather's disc lies in the face (the geometric normal), not in the plane of the shading
    normal, which kept only a band of the disc's photons where the two part; and a photon
    counts cos_N / cos_Ng of its arrival (Veach's adjoint of shading normals).  Before both,
    the cone's lower half rendered at 0.28-0.73 of Cycles (the issue's sun-lit cone: 5-13 %
    dark at its base, where its indirect light is a small share)."""
    scene = _cone(bpy)
    cycles(scene, 1024, width=W)
    ref = render_exr(tmp_path / "cycles.exr")
    tiny(scene, width=W, height=W, passes=passes, photons=photons)
    scene.ppm.indirect = "PHOTONS"
    ours = render_exr(tmp_path / "ours.exr")
    a, b = (im.reshape(W // 6, 6, W // 6, 6, 3).mean(axis=(1, 3)).mean(-1) for im in (ours, ref))
    np.testing.assert_allclose(a, b, rtol=rtol, err_msg=str(np.round(a / b, 3)))


def _icosphere(bpy, offset):
    """A smooth-shaded icosphere of 42 vertices lit from the side by a sun, its object's Shadow
    Terminator > Geometry Offset set, seen by an orthographic camera; direct light only."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=1, radius=1.0)
    bpy.ops.object.shade_smooth()
    ob = bpy.context.active_object
    ob.data.materials.append(bpy.data.materials.new("Grey"))
    ob.shadow_terminator_geometry_offset = offset
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 3.0
    sun.rotation_euler = (0, math.radians(80), 0)
    scene.collection.objects.link(sun)
    add_camera(scene, ortho_width=2.4, location=(0, -5, 0), rotation=(math.pi / 2, 0, 0))
    _black_world(bpy, scene)
    return scene


@pytest.mark.parametrize("offset", [0.1, 0.0])
def test_the_shadow_terminator_offset_as_cycles(bpy, cycles, tiny, render_exr, tmp_path, offset):
    """A low-poly smooth sphere's terminator: the shadow ray leaves from the smooth surface its
    normals describe (kernels/geom/bvh.h terminator_lift) near the terminator, by the object's
    Geometry Offset (Cycles' default 0.1); each 8 x 8 block within 3 % of Cycles (256
    samples, direct light) plus a small absolute margin for the dark side.  Without it the
    image's mean was 4 % below Cycles' at the default (the two Cycles settings differ by 4 %)."""
    scene = _icosphere(bpy, offset)
    cycles(scene, 256, width=64)
    scene.cycles.max_bounces = 0
    ref = render_exr(tmp_path / "cycles.exr")
    tiny(scene, width=64, height=64, passes=256)
    ours = render_exr(tmp_path / "ours.exr")
    a, b = (im.reshape(8, 8, 8, 8, 3).mean(axis=(1, 3)).mean(-1) for im in (ours, ref))
    np.testing.assert_allclose(a, b, rtol=0.03, atol=0.003, err_msg=str(np.round(a / b, 3)))
    assert ours.mean() == pytest.approx(ref.mean(), rel=0.01)
