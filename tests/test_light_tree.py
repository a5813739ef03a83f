"""The light tree (ppm_engine/scene/light_tree.py, kernels/light/light_tree.h): its build (every
node bounds its emitters), and next-event estimation's pick through it on the device held to a
float64 reference of the same importance, with the frequencies of the pick, the pmf it
returns, and the pmf the MIS of a ray that finds the emitter uses (kernels/test/debug.cl
emitter_pick_at)."""
import numpy as np
import pytest

from ppm_engine.oracle.procedural import MeshBuilder, look_at
from ppm_engine.render.renderer import Renderer
from ppm_engine.scene import light_tree as lt
from ppm_engine.scene.arrays import (
    CAMERA_ORTHO,
    LIGHT_AREA_RECT,
    LIGHT_POINT,
    LIGHT_SPOT,
    LIGHT_SUN,
)
from ppm_engine.scene.camera import make_camera
from ppm_engine.scene.emitters import local_share
from tests.helpers.debug_kernels import emitter_picks
from tests.helpers.procedural_scenes import furnace_scene, light
from tests.helpers.renders import every_feature, render


def _tree(n, rng):
    c = rng.random((n, 3)) * 4
    ax = rng.normal(size=(n, 3))
    ax /= np.linalg.norm(ax, axis=1, keepdims=True)
    th_o = np.where(rng.random(n) < 0.5, 0.0, np.pi)
    return lt.build_light_tree(c - 0.05, c + 0.05, ax, th_o, np.full(n, np.pi / 2),
                               rng.random(n) + 0.01, np.arange(n) + 7), (c, ax, th_o)


@pytest.mark.parametrize("n", [2, 3, 9, 1000])
def test_each_node_bounds_its_emitters(n):
    rng = np.random.default_rng(n)
    (nodes, leaf_of, order, energy), (c, ax, th_o) = _tree(n, rng)
    assert nodes.shape[0] == 2 * n - 1 and nodes["parent"][0] == -1
    assert (nodes["child"][leaf_of] == -1 - (np.arange(n) + 7)).all()
    # a node's emitters are [first, first + count) of the tree's order; a leaf's, its own
    assert (order[nodes["first"][leaf_of]] == np.arange(n) + 7).all()
    assert (nodes["count"][leaf_of] == 1).all() and nodes["count"][0] == n
    inner = nodes["child"] >= 0
    ch = nodes["child"][inner]
    assert (nodes["first"][ch] == nodes["first"][inner]).all()
    assert (nodes["first"][ch + 1] == nodes["first"][inner] + nodes["count"][ch]).all()
    assert (nodes["count"][ch] + nodes["count"][ch + 1] == nodes["count"][inner]).all()
    np.testing.assert_allclose(np.add.reduceat(energy, [0]), nodes["energy"][0], rtol=1e-5)
    # walk up from every leaf: each ancestor's box, energy and cone hold the emitter
    for e in range(n):
        k = leaf_of[e]
        while k >= 0:
            nd = nodes[k]
            assert (nd["bmin"] <= c[e] - 0.05 + 1e-6).all()
            assert (nd["bmax"] >= c[e] + 0.05 - 1e-6).all()
            spread = np.arccos(np.clip(ax[e] @ nd["axis"], -1, 1))
            assert spread + th_o[e] <= nd["theta_o"] or nd["theta_o"] >= np.pi - 1e-6
            k = nd["parent"]
    inner = nodes["child"] >= 0
    ch = nodes["child"][inner]
    np.testing.assert_allclose(nodes["energy"][inner],
                               nodes["energy"][ch] + nodes["energy"][ch + 1], rtol=1e-5)


def test_the_pmf_sums_to_one_and_favours_the_near_emitters():
    rng = np.random.default_rng(3)
    (nodes, leaf_of, _, energy), (c, ax, th_o) = _tree(500, rng)
    p, n = np.array([1.0, 1.0, 1.0]), np.array([0.0, 0.0, 1.0])
    q = lt.pmf(nodes, leaf_of, p, n)
    # from afar the descent stops at a node and picks by power; the probabilities still sum
    # to one
    far = lt.pmf(nodes, leaf_of, [40.0, 2.0, 2.0], n, energy)
    assert lt.stops(nodes, [40.0, 2.0, 2.0]).any() and far.sum() == pytest.approx(1.0, abs=1e-9)
    assert q.sum() == pytest.approx(1.0, abs=1e-9)
    # every emitter that can light p can be picked (one-sided ones facing away cannot)
    faces = (th_o > 0) | (((p - c) * ax).sum(1) > 0)
    assert (q[faces] > 0).all() and faces.sum() > 300 and (~faces).sum() > 100
    # the purpose: next-event estimation's variance.  Each emitter's light at p (a small
    # emitter: power x its cosine towards p, one-sided ones, x the cosine at p / d^2); the
    # estimate's relative variance sum(c^2 / q) / sum(c)^2 - 1 against the power pick's
    v = p - c
    d2 = (v * v).sum(1)
    w = np.linalg.norm(v, axis=1)
    energy = nodes["energy"][leaf_of].astype(np.float64)
    emit = np.where(th_o > 0, 1.0, np.maximum((v * ax).sum(1) / w, 0.0))
    light = energy * emit * np.abs(v @ n) / w / d2
    power = energy / energy.sum()
    rel = [(light ** 2 / np.maximum(x, 1e-300)).sum() / light.sum() ** 2 - 1 for x in (q, power)]
    assert rel[0] < 0.5 * rel[1], rel


def test_a_dense_cluster_of_dim_emitters_keeps_to_its_own_nodes():
    """A street of 300 lamps (20-40 W, 1.4 x 1 m apart) and a neon sign of 3,000 dim
    triangles in one metre: the build splits each node at the middle of its cell (a radix
    split of the Morton codes), so the sign's triangles fill a subtree of their own.  Split at
    the middle of the emitter range instead, node after node of lamps carried a few of the
    sign's triangles and a box as wide as the street, and from 18 cm beside a lamp the
    estimate's relative variance (sum(c^2 / q) / sum(c)^2 - 1) was 15.6 (median of 20
    lamps) where the radix split gives 1.7."""
    rng = np.random.default_rng(1)
    g = np.stack(np.meshgrid(np.arange(15), np.arange(20)), -1).reshape(-1, 2) * 1.0
    lamps = np.column_stack([g[:, 0] * 1.4, g[:, 1], np.full(len(g), 2.5)])
    sign = rng.random((3000, 3)) * [1.0, 1.0, 0.5] + [3.0, 25.0, 4.0]
    c = np.concatenate([lamps, sign])
    ext = np.concatenate([np.full(len(lamps), 0.05), np.full(len(sign), 0.01)])[:, None]
    E = np.concatenate([20 + 20 * rng.random(len(lamps)), np.full(len(sign), 0.02)])
    m = len(c)
    nodes, leaf_of, _, energy = lt.build_light_tree(
        c - ext, c + ext, np.tile([0.0, 0.0, 1.0], (m, 1)), np.full(m, np.pi),
        np.full(m, np.pi / 2), E, np.arange(m))
    # the sign's triangles under one node holding nothing else
    first, count = nodes["first"].astype(np.int64), nodes["count"].astype(np.int64)
    sign_rank = np.sort(nodes["first"][leaf_of[len(lamps):]])
    assert ((first == sign_rank[0]) & (count == len(sign))).any()
    assert (np.diff(sign_rank) == 1).all()
    rel = []
    for k in rng.choice(len(lamps), 20, replace=False):
        p, n = c[k] + [0.15, 0.0, -0.1], np.array([-1.0, 0.0, 0.0])
        q = lt.pmf(nodes, leaf_of, p, n, energy)
        v = c - p
        d2 = (v * v).sum(1)
        light = E * np.abs(v @ n) / np.sqrt(d2) / d2
        rel.append((light ** 2 / np.maximum(q, 1e-300)).sum() / light.sum() ** 2 - 1)
    assert np.median(rel) < 3.0, np.round(rel, 2)


def _many_lights_scene(rng):
    """A grey floor, 40 point and spot lights at random under a ceiling, 3 area lights, 6
    emissive triangles, a sun and a world: 52 emitters, 49 of them in the tree."""
    mb = MeshBuilder()
    grey = mb.material("grey", (0.5, 0.5, 0.5))
    mb.quad((0, 0, 0), (4, 0, 0), (0, 4, 0), grey)
    for k in range(6):
        lamp = mb.material(f"lamp{k}", (0, 0, 0), emission=(1.0 + k,) * 3)
        o = rng.random(3) * [6, 6, 1] - [3, 3, -0.5]
        mb.add((o + rng.normal(size=(3, 3)) * 0.2)[None], lamp)
    ls = []
    for k in range(40):
        ls.append(light(LIGHT_POINT if k % 2 else LIGHT_SPOT, emit=(rng.random() * 5,) * 3,
                        position=rng.random(3) * [6, 6, 1] - [3, 3, -2], radius=0.02 * (k % 3),
                        spot_cos_half=0.5, spot_smooth=0.1, spot_scale_z=1.0,
                        axis_x=(1, 0, 0), axis_y=(0, 1, 0)))
    for k in range(3):
        ls.append(light(LIGHT_AREA_RECT, emit=(2.0,) * 3, position=(k - 1.0, 0.5, 2.5),
                        direction=(0, 0.3 * (k - 1), -1), axis_x=(0.5, 0, 0), axis_y=(0, 0.4, 0)))
    ls.append(light(LIGHT_SUN, emit=(1.5,) * 3, direction=(0.2, 0.1, -1), radius=0.01))
    cam = make_camera(type=CAMERA_ORTHO, width=4, height=4,
                      to_world=look_at((0, 0, 5), (0, 0, 0), up=(0, 1, 0)), extent=(2, 2),
                      clip=(0.01, 100))
    return mb.build(camera=cam, lights=np.concatenate(ls), world=(0.1, 0.1, 0.1))


def test_the_devices_pick_through_the_tree_matches_the_reference():
    """At points on the floor, above it, and facing away: the pick's frequencies over
    stratified numbers are its pmf; that pmf is the one the MIS of a ray uses (to float
    rounding: both multiply the same choices, top down and bottom up) and the float64
    reference's (the local emitters' share at the point, emitters.local_share, x the tree; the
    far ones' share x their power's share among them); they sum to one."""
    rng = np.random.default_rng(11)
    scene = _many_lights_scene(rng)
    r = Renderer(scene, every_feature(max_bounces=0))
    em = r.scene.emitters
    m, n_lights = int(em.info["n_emitters"][0]), int(em.info["n_lights"][0])
    assert (m, n_lights, int(em.info["n_emissive"][0])) == (51, 44, 6)
    assert int(em.info["n_tree"][0]) == 2 * 49 - 1 and em.info["local_radius"][0] == 0
    pts = np.float32([[0, 0, 0, 0], [1.5, -1, 0.01, 0], [0.3, 0.2, 1.8, 0], [-2, 2, 0.5, 0],
                      [40, 5, 1, 0]])
    nrm = np.float32([[0, 0, 1, 0], [0, 0, 1, 0], [0, 0.6, -0.8, 0], [1, 0, 0, 0],
                      [-1, 0, 0, 0]])
    # from the last point the descent stops early and picks by power; from the first it does not
    assert lt.stops(em.tree, pts[4, :3]).any() and not lt.stops(em.tree, pts[0, :3])[0]
    n, n_u = len(pts), 1 << 18
    got = emitter_picks(r, pts, nrm, n_u)
    r.close()
    far = np.diff(np.concatenate([[0.0], em.far_cdf.astype(np.float64)]))
    member = em.emitter_leaf >= 0
    assert member.sum() == 49 and not member[n_lights - 1] and not member[m - 1]  # sun, world
    far_energy = float(em.info["far_energy"][0])
    assert far_energy > 0 and far[member].sum() == 0 and far.sum() == pytest.approx(1.0)
    for i in range(n):
        share = local_share(em, pts[i, :3], nrm[i, :3])
        ref = np.where(member, 0.0, (1 - share) * far)
        ref[member] = share * lt.pmf(em.tree, em.emitter_leaf[member], pts[i, :3], nrm[i, :3],
                                     em.power[em.tree_emitters])
        assert ref.sum() == pytest.approx(1.0, abs=1e-6)
        np.testing.assert_allclose(got["table"][i], ref, rtol=2e-3, atol=1e-7)
        picked = got["counts"][i] > 0
        np.testing.assert_allclose(got["pmf"][i][picked], got["table"][i][picked], rtol=1e-5)
        freq = got["counts"][i] / n_u
        np.testing.assert_allclose(freq, ref, atol=3e-3 + 0.02 * ref.max())


def _room_of_lights(bpy, n_side, energy, radius=0.01):
    """A white room (4 x 4 x 3 m, Lambert 0.7) with n_side^2 point lights of radius `radius`
    2 cm below its ceiling, the camera inside looking at the floor and a wall (not at the
    lights: 1 cm spheres a pixel cannot resolve would make the blocks their aliasing
    noise)."""
    import bmesh
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    me = bpy.data.meshes.new("Room")
    bm = bmesh.new()
    bmesh.ops.create_cube(bm, size=1.0)
    for v in bm.verts:
        v.co.x, v.co.y, v.co.z = 4 * v.co.x, 4 * v.co.y, 3 * (v.co.z + 0.5)
    bmesh.ops.reverse_faces(bm, faces=bm.faces[:])
    bm.to_mesh(me)
    bm.free()
    room = bpy.data.objects.new("Room", me)
    scene.collection.objects.link(room)
    m = bpy.data.materials.new("White")
    me.materials.append(m)
    p = m.node_tree.nodes["Principled BSDF"]
    p.inputs["Base Color"].default_value = (0.7, 0.7, 0.7, 1)
    p.inputs["Roughness"].default_value = 1.0
    p.inputs["Specular IOR Level"].default_value = 0.0
    data = bpy.data.lights.new("P", 'POINT')
    data.energy, data.shadow_soft_size = energy, radius
    xs = (np.arange(n_side) + 0.5) / n_side * 3.6 - 1.8
    for i, x in enumerate(xs):
        for j, y in enumerate(xs):
            o = bpy.data.objects.new(f"P{i}_{j}", data)
            o.location = (x, y, 2.98)
            scene.collection.objects.link(o)
    import math

    from tests.helpers.blender_scenes import add_camera
    add_camera(scene, location=(0, -1.9, 1.2), rotation=(math.radians(55), 0, 0))
    scene.camera.data.lens = 14
    scene.world = None
    return scene


@pytest.mark.parametrize("n_side", [
    20,                                                   # 400 lights
    pytest.param(70, marks=pytest.mark.slow),             # 4,900: the stress case
])
def test_a_room_lit_by_many_small_lights_as_cycles(bpy, n_side, cycles, tiny, render_exr,
                                                   tmp_path):
    """Hundreds to thousands of 1 cm point lights under a ceiling: the image's mean within 3 %
    of Cycles', each 8 x 8 block within 10 % (before the tree the issue measured 0.67 of
    Cycles' mean with 5,000 such lights)."""
    scene = _room_of_lights(bpy, n_side, 80.0 / n_side ** 2 * 16)
    w = 32
    cycles(scene, 128, width=w)
    ref = render_exr(tmp_path / "cycles.exr")
    tiny(scene, width=w, height=w, passes=128, photons=1 << 12)
    ours = render_exr(tmp_path / "ours.exr")
    assert ours.mean() == pytest.approx(ref.mean(), rel=0.03)
    a, b = (im.reshape(4, 8, 4, 8, 3).mean(axis=(1, 3)).mean(-1) for im in (ours, ref))
    np.testing.assert_allclose(a, b, rtol=0.10, err_msg=str(np.round(a / b, 3)))


def _pixel_noise(scene, passes, **opts):
    """The RMS of two renders' difference over sqrt(2): one render's noise per pixel."""
    a, b = (render(scene, passes, seed=s, **opts)[..., :3].astype(np.float64) for s in (1, 2))
    return float(np.sqrt(np.mean((a - b) ** 2) / 2))


def test_one_emissive_material_alone_is_picked_by_power_not_by_the_tree():
    """Emissive triangles of one material and no light (a closed emissive sphere: the
    furnace) keep the power table, which picks them by area (exact inside a sphere): the
    tree's bound favours the triangles beside a point on the sphere, whose light there is
    grazing, and left 1.6x this noise here (0.023 against 0.015 at 32 x 32, 32 passes).  A
    second emissive material, or a light, brings the tree back."""
    scene = furnace_scene(0.5, 1.0, W=32)
    r = Renderer(scene, every_feature())
    em = r.scene.emitters
    assert int(em.info["n_emissive"][0]) > 8 and int(em.info["n_tree"][0]) == 0
    r.close()
    assert _pixel_noise(scene, 32, indirect="paths", max_bounces=64) < 0.019

    cam = make_camera(width=8, height=8, to_world=look_at((0, -5, 0), (0, 0, 0)),
                      extent=(1, 1), clip=(0.01, 100))
    for materials, lights in ((2, None), (1, light(LIGHT_POINT, emit=(1.0,) * 3,
                                                   position=(0, 0, 3)))):
        mb = MeshBuilder()
        lamps = [mb.material(f"lamp{k}", (0.5,) * 3, emission=(1.0,) * 3)
                 for k in range(materials)]
        for k in range(2):
            mb.sphere((3.0 * k, 0, 0), 1.0, lamps[k % materials], 8, 4, smooth=False)
        r = Renderer(mb.build(camera=cam, lights=lights), every_feature())
        assert int(r.scene.emitters.info["n_tree"][0]) > 0, (materials, lights)
        r.close()


def _grid_of_lights(bpy, scene, nx, ny, z, visible_camera=False):
    """nx x ny point lights of one light datablock (4 mW each, radius 1 cm, Blender's soft
    falloff) 1 cm apart along x and 2 cm along y around (0, 0, z): neighbouring spheres
    overlap."""
    data = bpy.data.lights.new("P", 'POINT')
    data.energy, data.shadow_soft_size = 0.004, 0.01
    for i in range(nx):
        for j in range(ny):
            o = bpy.data.objects.new(f"P{i}_{j}", data)
            o.location = ((i - (nx - 1) / 2) * 0.01, (j - (ny - 1) / 2) * 0.02, z)
            o.visible_camera = visible_camera
            scene.collection.objects.link(o)


def _ceiling_over_lights(bpy, nx, ny, z, visible_camera, view):
    """A white ceiling (Lambert 0.8) at z = 2 over a grid of lights (_grid_of_lights) at z, seen
    from 1 m below by an orthographic camera ``view`` metres wide; no world."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    m = bpy.data.materials.new("White")
    p = m.node_tree.nodes["Principled BSDF"]
    p.inputs["Base Color"].default_value = (0.8, 0.8, 0.8, 1)
    p.inputs["Roughness"].default_value = 1.0
    p.inputs["Specular IOR Level"].default_value = 0.0
    me = bpy.data.meshes.new("Ceiling")
    me.from_pydata([(-0.5, -0.5, 2), (-0.5, 0.5, 2), (0.5, 0.5, 2), (0.5, -0.5, 2)], [],
                   [(0, 1, 2, 3)])
    me.materials.append(m)
    scene.collection.objects.link(bpy.data.objects.new("Ceiling", me))
    _grid_of_lights(bpy, scene, nx, ny, z, visible_camera)
    import math

    from tests.helpers.blender_scenes import add_camera
    add_camera(scene, ortho_width=view, location=(0, 0, 1.0), rotation=(math.pi, 0, 0))
    scene.world = None
    return scene


@pytest.mark.parametrize("nx, ny, z, visible_camera, transparent, view", [
    (20, 10, 1.95, False, 8, 0.32),      # the grid, 5 cm under the ceiling
    (20, 10, 1.95, True, 2, 0.32),       # the camera sees them: 2 at most, then the path ends
    (1, 1, 1.995, False, 8, 0.04),       # one light 5 mm under the ceiling, radius 1 cm
], ids=["grid", "grid_seen_limit_2", "within_radius"])
def test_overlapping_lights_near_a_ceiling_as_cycles(bpy, nx, ny, z, visible_camera,
                                                     transparent, view, cycles, tiny,
                                                     render_exr, tmp_path):
    """Point lights of radius 1 cm, 1 x 2 cm apart (their spheres overlap), 5 cm under a ceiling:
    its direct light per 8 x 8 block within 6 % of Cycles'.  Lights do not block rays in Cycles:
    a ray that meets one adds its emission and goes on past it, each light a transparent bounce
    (at the Light Paths' limit the path ends there).  Counting only the nearest light a ray met,
    the sample's side of MIS lost the others: the centre blocks were 0.63 of Cycles' (0.62 with
    the lights seen by the camera, 0.87 at a limit of 2).  And a surface within a light's
    radius is lit by the disk facing it (I cos / (d^2 + r^2) on the axis), where the point's
    I / d^2 lit it 2.6 x."""
    scene = _ceiling_over_lights(bpy, nx, ny, z, visible_camera, view)
    w = 32
    cycles(scene, 64, width=w)
    scene.cycles.max_bounces = 0
    scene.cycles.transparent_max_bounces = transparent
    ref = render_exr(tmp_path / "cycles.exr")
    tiny(scene, width=w, height=w, passes=32, photons=1 << 12)
    ours = render_exr(tmp_path / "ours.exr")
    a, b = (im.reshape(4, 8, 4, 8, 3).mean(axis=(1, 3)).mean(-1) for im in (ours, ref))
    np.testing.assert_allclose(a, b, rtol=0.06, err_msg=str(np.round(a / b, 3)))


@pytest.mark.slow
def test_the_cornell_box_lit_by_a_dense_grid_of_lights_as_cycles(bpy, cycles, tiny, render_exr,
                                                                  tmp_path):
    """The Cornell box with its lamp replaced by 100 x 50 overlapping point lights 5 cm under
    its ceiling (_grid_of_lights, 20 W), every bounce: the mean within 3 % of Cycles', each
    8 x 8 block within 8 % (the issue measured 0.73 of Cycles' mean, 0.61 in the top rows).
    Cycles ends a path at its 8th light (Light Paths' transparent limit): 3.7 % of the image
    here, which the eye paths follow."""
    from ppm_engine.blender.scenes import cornell_box as cb
    scene = cb.new_scene()
    white = cb.room(scene)
    cb.box(scene, "TallBox", (-0.6, -0.1, 0.0), (-0.1, 0.5, 1.2), white)
    cb.box(scene, "ShortBox", (0.15, -0.5, 0.0), (0.65, 0.0, 0.6), white)
    cb.camera_world_render(scene, resolution=32)
    _grid_of_lights(bpy, scene, 100, 50, 1.95)
    cycles(scene, 256, width=32)
    ref = render_exr(tmp_path / "cycles.exr")
    tiny(scene, width=32, height=32, passes=128, photons=1 << 12)
    ours = render_exr(tmp_path / "ours.exr")
    assert ours.mean() == pytest.approx(ref.mean(), rel=0.03)
    a, b = (im.reshape(4, 8, 4, 8, 3).mean(axis=(1, 3)).mean(-1) for im in (ours, ref))
    np.testing.assert_allclose(a, b, rtol=0.08, err_msg=str(np.round(a / b, 3)))
