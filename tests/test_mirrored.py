"""Mirrored objects (a negative scale, a parent's, an instancer's) and rough glass on smooth-shaded
low-poly meshes, against their unmirrored twins and against Cycles.

A mirroring matrix reverses a mesh's winding: the export swaps two corners of each triangle
(ppm_engine/blender/export/mesh.py transform_part) so that the face's normal keeps its side
with the shading normals, outside a closed mesh, as Cycles keeps it.  A mirrored object must
export and render as its unmirrored twin.

A smooth-shaded 32-sided glass cylinder seen from the side showed dark bands along its
silhouettes (the report's cylinder was mirrored; its unmirrored twin rendered the same): there
the interpolated normal leans from the face until the view meets it at grazing or from behind,
and a rough glass closure on it sampled nothing.  Cycles raises the normal of its glossy, glass
and translucent closures towards the face until the view's mirror reflection lies above the
surface (ensure_valid_specular_reflection; the material's Bump Map Correction), for a smooth
mesh's normal as for a driven one; this engine did it for driven normals only
(kernels/svm/shader_inputs.h specular_normal)."""
import functools
import math

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from tests.helpers.blender_scenes import add_camera, add_light, export

W = 48          # the image: 6 x 6 blocks of 8 x 8 pixels


def _cylinder(*, scale=(1.0, 1.0, 1.0), smooth=True, parent_scale=None, instance_scale=None,
              duplicate_scale=None, correction=True):
    """A closed 32-sided cylinder (radius 0.6, height 1.6) of Glass BSDF (roughness 0.175, IOR
    1.55) at z = 1 with object scale ``scale``, or under an empty of scale ``parent_scale``, or
    instanced by an empty of scale ``instance_scale`` (a collection instance), or a linked
    duplicate of scale ``duplicate_scale`` there (sharing the mesh) and the first one moved 5 m
    aside (out of view); a point light
    above it, a grey world, a camera 3.2 m in front at mid-height (63 mm: the cylinder spans
    the middle 32 pixels of a square image, its silhouettes on block edges).  The scene."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_cylinder_add(vertices=32, radius=0.6, depth=1.6, location=(0, 0, 1))
    cyl = bpy.context.active_object
    if smooth:
        bpy.ops.object.shade_smooth()
    mat = bpy.data.materials.new("Glass")
    mat.cycles.use_bump_map_correction = correction
    t = mat.node_tree
    t.nodes.remove(t.nodes["Principled BSDF"])
    g = t.nodes.new("ShaderNodeBsdfGlass")
    g.inputs["Roughness"].default_value = 0.175
    g.inputs["IOR"].default_value = 1.55
    t.links.new(g.outputs[0], t.nodes["Material Output"].inputs["Surface"])
    cyl.data.materials.append(mat)
    cyl.scale = scale
    if parent_scale is not None:
        empty = bpy.data.objects.new("Parent", None)
        scene.collection.objects.link(empty)
        empty.location, empty.scale = (0, 0, 1), parent_scale
        cyl.location = (0, 0, 0)
        cyl.parent = empty
    if instance_scale is not None:
        col = bpy.data.collections.new("Instanced")
        col.objects.link(cyl)
        scene.collection.objects.unlink(cyl)
        cyl.location = (0, 0, 0)
        inst = bpy.data.objects.new("Instancer", None)
        inst.instance_type, inst.instance_collection = "COLLECTION", col
        inst.location, inst.scale = (0, 0, 1), instance_scale
        scene.collection.objects.link(inst)
    if duplicate_scale is not None:
        dup = bpy.data.objects.new("Duplicate", cyl.data)
        dup.location, dup.scale = (0, 0, 1), duplicate_scale
        scene.collection.objects.link(dup)
        cyl.location = (5, 0, 1)
    add_light("POINT", loc=(0, 0, 4), energy=300.0)
    add_camera(scene, location=(0, -3.2, 1), rotation=(math.pi / 2, 0, 0))
    scene.camera.data.lens = 63
    scene.world = bpy.data.worlds.new("Grey")
    scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (.3, .3, .3, 1)
    bpy.context.view_layer.update()
    return scene


def _soup(arrays):
    """The exported surface as rows of (a corner's position, its shading normal, its face's
    unit normal from the winding), to be matched whatever the triangles' order and however the
    polygons are cut (a mirrored quad is cut along its other diagonal); and the fraction of
    triangles whose face normal lies on the side of their shading normals and points out of the
    cylinder (away from its axis on the sides)."""
    near = np.abs(arrays.positions[:, :, 0]).max(axis=1) < 2.0     # (not a duplicate aside)
    p, n = arrays.positions[near].astype(np.float64), arrays.normals[near].astype(np.float64)
    ng = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    ng /= np.linalg.norm(ng, axis=1, keepdims=True)
    rows = np.concatenate([p, n, np.repeat(ng[:, None], 3, axis=1)], axis=2).reshape(-1, 9)
    centre = p.mean(axis=1) - (0.0, 0.0, 1.0)
    centre[np.abs(centre[:, 2]) < 0.79, 2] = 0.0                       # sides: from the axis
    agree = (np.einsum("ij,ikj->ik", ng, n) > 0).all(axis=1)
    out = np.einsum("ij,ij->i", ng, centre) > 0
    return rows, (agree & out).mean()


MIRRORS = {
    "scale z -1": dict(scale=(1, 1, -1)),
    "scale x -1": dict(scale=(-1, 1, 1)),
    "scale -1 -1 -1": dict(scale=(-1, -1, -1)),
    "parent scale z -1": dict(parent_scale=(1, 1, -1)),
    "instancer scale y -1": dict(instance_scale=(1, -1, 1)),
    "linked duplicate scale z -1": dict(duplicate_scale=(1, 1, -1)),
}


@functools.cache
def _twin(smooth: bool) -> np.ndarray:
    """_soup's rows of the unmirrored cylinder (once per shading)."""
    _cylinder(smooth=smooth)
    rows, ok = _soup(export())
    assert ok == 1.0
    return rows


@pytest.mark.parametrize("smooth", [True, False])
@pytest.mark.parametrize("mirror", list(MIRRORS))
def test_a_mirrored_cylinder_exports_as_its_twin(mirror, smooth):
    """The same surface (corners, shading normals, face normals), every triangle wound so that
    its face normal points out of the cylinder, on the side of its shading normals, smooth or
    flat, whatever mirrors it."""
    twin = _twin(smooth)
    _cylinder(smooth=smooth, **MIRRORS[mirror])
    rows, ok = _soup(export())
    assert ok == 1.0, f"{1 - ok:.0%} of the triangles face inwards or against their normals"
    d = np.abs(rows[:, None] - twin[None]).max(axis=2)     # every row has its match both ways
    assert d.min(axis=1).max() < 1e-4 and d.min(axis=0).max() < 1e-4


def test_a_mirrored_glass_cylinder_renders_as_its_twin(tiny, render_exr, tmp_path):
    """The smooth glass cylinder mirrored through z and not, 24 x 24 pixels, 16 passes: the
    same image (each 4 x 4 block within 1 % + 0.001; measured 2e-5, the same paths through the
    same surface; the winding left reversed by a mirror turned the glass into an air bubble
    and 57 of 108 block values off, by up to 67 %)."""
    images = []
    for k, scale in enumerate(((1, 1, 1), (1, 1, -1))):
        scene = _cylinder(scale=scale)
        tiny(scene, width=24, height=24, passes=16, photons=1024)
        images.append(render_exr(tmp_path / f"ours{k}.exr"))
    a, b = (im.reshape(6, 4, 6, 4, 3).mean(axis=(1, 3)) for im in images)
    np.testing.assert_allclose(b, a, rtol=0.01, atol=0.001)


@pytest.mark.parametrize("correction", [True, pytest.param(False, marks=pytest.mark.slow)])
def test_rough_glass_on_a_mirrored_smooth_cylinder_per_block_as_cycles(
        correction, cycles, tiny, render_exr, tmp_path):
    """The report's cylinder (mirrored through z, smooth shaded, rough glass, a point light, a
    grey world): every 8 x 8 block within 4 % of Cycles (256 samples) + 0.002 (measured: within
    1.2 %).  Before the normals of the glass were raised as Cycles raises them, 6 blocks of 36
    failed: those at the ends of both silhouettes at 0.855-0.872 of Cycles, the top edge's at
    1.11.  With the material's Bump Map Correction off Cycles does not raise them, nor does this
    engine: both show the dark rims (the slow tier: the default run checks the flag's export)."""
    scene = _cylinder(scale=(1, 1, -1), correction=correction)
    cycles(scene, 256, width=W)
    ref = render_exr(tmp_path / "cycles.exr")
    tiny(scene, width=W, height=W, passes=64, photons=1024)
    ours = render_exr(tmp_path / "ours.exr")
    a, b = (im.reshape(W // 8, 8, W // 8, 8, 3).mean(axis=(1, 3)).mean(-1) for im in (ours, ref))
    np.testing.assert_allclose(a, b, rtol=0.04, atol=0.002, err_msg=str(np.round(a / b, 3)))


def test_bump_map_correction_off_is_exported():
    """A material with Cycles' Bump Map Correction off: every BSDF node of it carries
    NODE_FLAG_NO_BUMP_CORRECTION (its glossy normals are not raised); on (the default): none."""
    from ppm_engine.scene.arrays import NODE_FLAG_NO_BUMP_CORRECTION
    for correction in (True, False):
        _cylinder(correction=correction)
        a = export()
        k = list(a.material_names).index("Glass")
        flags = a.shader_nodes["flags"][a.shader_nodes["material"] == k]
        assert len(flags) == 1
        assert bool(flags[0] & NODE_FLAG_NO_BUMP_CORRECTION) == (not correction)
