"""The 3D view's camera, headless: pixel_size and view_camera on fake regions, and
camera_from_view round-tripping world points through window matrices built as Blender builds a
3D view's (perspective, orthographic with a negative near clip, a camera view zoomed and
panned).  The same against Blender's own camera projection: test_viewport_blender.py."""
import types

import numpy as np
import pytest

from tests.helpers.viewport_stubs import context_stub


@pytest.mark.parametrize("setting, ui, want", [
    ("AUTO", 1.0, 1), ("AUTO", 1.5, 1), ("AUTO", 1.51, 2), ("AUTO", 2.0, 2), ("AUTO", 3.0, 2),
    ("1", 2.0, 1), ("2", 1.0, 2), ("4", 1.0, 4), ("8", 2.0, 8)])
def test_pixel_size_is_blender_s(setting, ui, want):
    """Blender's BKE_render_preview_pixel_size: Automatic is 2 above an interface pixel size of
    1.5, else 1 (rounding made 3 from 3.0); the engine's own answer when it has one."""
    from ppm_engine.blender.viewport import pixel_size
    scene = types.SimpleNamespace(render=types.SimpleNamespace(preview_pixel_size=setting))
    assert pixel_size(context_stub(ui_pixel_size=ui), scene) == want

    class Asks:
        def get_preview_pixel_size(self, scene):
            return 4
    assert pixel_size(context_stub(ui_pixel_size=ui), scene, Asks()) == 4


def blender_window_matrix(width, height, *, ortho=False, lens=50.0, sensor=36.0,
                          clip=(0.01, 1000.0), ortho_scale=1.0, zoom=2.0, shift=(0.0, 0.0),
                          offset=(0.0, 0.0)):
    """A RegionView3D.window_matrix as Blender makes it (BKE_camera_params_compute_viewplane,
    sensor fit Automatic, square pixels, then perspective_m4 or orthographic_m4; a 3D view's
    zoom is 2, a camera view's 1 / its zoom factor, its offset 2 x camdx x that factor)."""
    n, f = clip
    fit = width if width >= height else height
    pix = (ortho_scale if ortho else sensor * n / lens) / fit * zoom
    dx, dy = shift[0] * fit + width * offset[0], shift[1] * fit + height * offset[1]
    left, right = (-0.5 * width + dx) * pix, (0.5 * width + dx) * pix
    bottom, top = (-0.5 * height + dy) * pix, (0.5 * height + dy) * pix
    p = np.zeros((4, 4))
    if ortho:
        p[0, 0], p[1, 1], p[2, 2] = 2 / (right - left), 2 / (top - bottom), -2 / (f - n)
        p[0, 3] = -(right + left) / (right - left)
        p[1, 3] = -(top + bottom) / (top - bottom)
        p[2, 3], p[3, 3] = -(f + n) / (f - n), 1.0
    else:
        p[0, 0], p[1, 1] = 2 * n / (right - left), 2 * n / (top - bottom)
        p[0, 2], p[1, 2] = (right + left) / (right - left), (top + bottom) / (top - bottom)
        p[2, 2], p[2, 3], p[3, 2] = -(f + n) / (f - n), -2 * f * n / (f - n), -1.0
    return p


def camera_view_factor(camzoom):
    """Blender's BKE_screen_view3d_zoom_to_fac: the camera view's zoom slider as a scale."""
    return (np.sqrt(2.0) + camzoom / 50.0) ** 2 / 4.0


def camera_rays(cam, px, py):
    """kernels/geom/camera.h camera_ray for a pinhole, in NumPy: (origin on the near clipping
    plane, unit direction, length to the far one) of the ray through raster (px, py), y up."""
    c = cam[0]
    m = c["to_world"].astype(np.float64)
    xc = (px / c["width"] - 0.5) * c["extent"][0] + c["shift"][0]
    yc = (py / c["height"] - 0.5) * c["extent"][1] + c["shift"][1]
    one = np.ones_like(xc)
    if c["type"] == 1:                                    # CAMERA_ORTHO
        oc, dc = np.stack([xc, yc, 0 * one], -1), np.stack([0 * one, 0 * one, -one], -1)
    else:
        oc, dc = np.zeros((len(xc), 3)), np.stack([xc, yc, -one], -1)
    dc /= np.linalg.norm(dc, axis=-1, keepdims=True)
    t0, t1 = c["clip"][0] / -dc[:, 2], c["clip"][1] / -dc[:, 2]
    d = dc @ m[:, :3].T
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    return oc @ m[:, :3].T + m[:, 3] + t0[:, None] * d, d, t1 - t0


def look(eye, target):
    """A view matrix (world to view, as RegionView3D.view_matrix) looking from eye to target."""
    eye, target = np.asarray(eye, float), np.asarray(target, float)
    back = (eye - target) / np.linalg.norm(eye - target)
    right = np.cross([0.0, 0.0, 1.0], back)
    right /= np.linalg.norm(right)
    to_world = np.eye(4)
    to_world[:3, :3] = np.stack([right, np.cross(back, right), back], 1)
    to_world[:3, 3] = eye
    return np.linalg.inv(to_world)


VIEWS = {
    # a 3D view in perspective: lens 50, Blender's default clipping, zoom 2
    "perspective": dict(clip=(0.01, 1000.0)),
    # orthographic: clip_end halved, clip_start its negative (behind the view's plane)
    "orthographic": dict(ortho=True, ortho_scale=8.0 * 36.0 / 50.0, clip=(-500.0, 500.0)),
    # through a camera: its lens and shift, zoomed in (camzoom 20) and panned (camdx, camdy)
    "camera view": dict(lens=35.0, clip=(0.1, 100.0),
                        shift=(0.1 * camera_view_factor(20.0), -0.05 * camera_view_factor(20.0)),
                        zoom=1.0 / camera_view_factor(20.0),
                        offset=(2 * 0.12 * camera_view_factor(20.0),
                                2 * -0.07 * camera_view_factor(20.0))),
}


@pytest.mark.parametrize("name", VIEWS)
def test_camera_from_view_round_trips_world_points(name):
    """World points anywhere in a 3D view's frustum, projected by Blender's matrices to a
    raster position, lie on the ray the camera record makes through that position, at the
    depth Blender's clipping gives them (on the near plane at NDC z = -1, the far at +1)."""
    from ppm_engine.scene.camera import CAMERA_ORTHO, camera_from_view
    width, height = 97, 55
    v = look((3.0, -6.0, 2.5), (0.2, 0.4, 0.8))
    p = blender_window_matrix(width, height, **VIEWS[name])
    cam = camera_from_view(v, p, width, height)
    assert (cam["type"][0] == CAMERA_ORTHO) == (name == "orthographic")
    rng = np.random.default_rng(5)
    ndc = np.concatenate([rng.uniform(-0.98, 0.98, (200, 3)),
                          [[0.3, -0.4, -1.0], [-0.6, 0.2, 1.0]]])   # on the clipping planes
    world = np.c_[ndc, np.ones(len(ndc))] @ np.linalg.inv(p @ v).T
    world = world[:, :3] / world[:, 3:]
    clip = np.c_[world, np.ones(len(world))] @ (p @ v).T           # Blender's projection
    px = (clip[:, 0] / clip[:, 3] + 1) / 2 * width
    py = (clip[:, 1] / clip[:, 3] + 1) / 2 * height
    o, d, length = camera_rays(cam, px, py)
    t = ((world - o) * d).sum(-1)
    scale = np.abs(world - o).max()
    np.testing.assert_allclose(o + t[:, None] * d, world, atol=2e-5 * scale)
    assert (t > -1e-4 * length).all() and (t < length * (1 + 1e-4)).all()
    np.testing.assert_allclose(t[-2:], [0.0, length[-1]], atol=2e-4 * length.max())


def test_the_test_s_window_matrix_is_blender_s(bpy, empty):
    """blender_window_matrix above, for a camera with zoom 1 and no offset, is Blender's own
    projection of that camera (Object.calc_matrix_camera)."""
    cam = empty.camera
    cam.data.lens, cam.data.shift_x, cam.data.shift_y = 35.0, 0.1, -0.05
    cam.data.clip_start, cam.data.clip_end = 0.1, 100.0
    dg = bpy.context.evaluated_depsgraph_get()
    want = np.array(cam.evaluated_get(dg).calc_matrix_camera(dg, x=97, y=55))
    got = blender_window_matrix(97, 55, lens=35.0, clip=(0.1, 100.0), shift=(0.1, -0.05),
                                zoom=1.0)
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-6)


def test_view_camera_reads_the_region_the_pixel_size_and_the_camera_s_depth_of_field(bpy,
                                                                                     empty):
    from ppm_engine.blender.export.camera import export_camera, film_settings
    from ppm_engine.blender.viewport import view_camera
    from ppm_engine.scene.camera import camera_from_view
    scene = empty
    scene.camera.data.dof.use_dof = True
    scene.camera.data.dof.focus_distance, scene.camera.data.dof.aperture_fstop = 3.0, 1.4
    scene.render.preview_pixel_size = 'AUTO'
    dg = bpy.context.evaluated_depsgraph_get()
    v, p = look((3.0, -6.0, 2.5), (0.0, 0.0, 0.0)), blender_window_matrix(97, 55)
    rv3d = types.SimpleNamespace(view_matrix=v, window_matrix=p, view_perspective='PERSP')
    assert view_camera(context_stub(None, 97, 55), dg) is None        # no 3D view
    cam = view_camera(context_stub(rv3d, 97, 55, ui_pixel_size=2.0), dg)
    assert (cam["width"][0], cam["height"][0]) == (48, 27)           # Automatic: 2 x 2 pixels
    np.testing.assert_array_equal(cam, camera_from_view(v, p, 48, 27, **film_settings(scene)))
    assert cam["aperture_radius"][0] == 0.0          # a free view: no depth of field
    rv3d.view_perspective = 'CAMERA'
    cam = view_camera(context_stub(rv3d, 97, 55), dg)
    want = export_camera(scene, dg)
    assert cam["aperture_radius"][0] == want["aperture_radius"][0] > 0
    assert cam["focus_distance"][0] == want["focus_distance"][0] == np.float32(3.0)


def test_view_camera_takes_the_depth_of_field_of_the_view_s_local_camera(bpy, empty):
    """A 3D view with a Local Camera looks through that camera (as Cycles' viewport does): its
    depth of field, not the scene camera's."""
    from ppm_engine.blender.export.camera import export_camera
    from ppm_engine.blender.viewport import view_camera
    scene = empty
    scene.camera.data.dof.use_dof = False                # the scene's camera: none
    local = bpy.data.objects.new("Local", bpy.data.cameras.new("Local"))
    scene.collection.objects.link(local)
    local.data.dof.use_dof = True
    local.data.dof.focus_distance, local.data.dof.aperture_fstop = 2.5, 2.0
    dg = bpy.context.evaluated_depsgraph_get()
    rv3d = types.SimpleNamespace(view_matrix=look((3.0, -6.0, 2.5), (0.0, 0.0, 0.0)),
                                 window_matrix=blender_window_matrix(64, 36),
                                 view_perspective='CAMERA')
    ctx = context_stub(rv3d, 64, 36)
    assert view_camera(ctx, dg)["aperture_radius"][0] == 0.0
    ctx.space_data = types.SimpleNamespace(use_local_camera=True, camera=local)
    cam, want = view_camera(ctx, dg), export_camera(scene, dg, local)
    assert cam["aperture_radius"][0] == want["aperture_radius"][0] > 0
    assert cam["focus_distance"][0] == np.float32(2.5)
    ctx.space_data.use_local_camera = False              # the option off: the scene's again
    assert view_camera(ctx, dg)["aperture_radius"][0] == 0.0


def test_the_viewport_exports_what_its_3d_view_shows(bpy, empty):
    """A 3D view's object-type visibility (and its local view and local collections, through
    the same Object.visible_in_viewport_get) decide what the viewport renders, as in Cycles'
    viewport; a change of them changes the viewport's export key."""
    from ppm_engine.blender.export import export_scene, hidden_in_view
    bpy.ops.mesh.primitive_cube_add()
    bpy.ops.mesh.primitive_uv_sphere_add(location=(3.0, 0.0, 0.0))
    bpy.ops.object.light_add(type='POINT', location=(0.0, 0.0, 3.0))
    view = next(a.spaces[0] for s in bpy.data.screens for a in s.areas if a.type == 'VIEW_3D')
    dg = bpy.context.evaluated_depsgraph_get()
    everything = export_scene(dg)
    shown = export_scene(dg, view=view)
    assert shown.positions.shape == everything.positions.shape and shown.lights.shape == (1,)
    assert hidden_in_view(dg, view) == ()
    view.show_object_viewport_light = False
    assert export_scene(dg, view=view).lights.shape == (0,)
    assert hidden_in_view(dg, view) == ("Point",)
    view.show_object_viewport_light = True
    view.show_object_viewport_mesh = False
    assert export_scene(dg, view=view).positions.shape[0] == 0
    assert export_scene(dg).positions.shape == everything.positions.shape   # a final render


def test_a_render_region_renders_and_draws_only_its_part(bpy, empty, monkeypatch):
    """The viewport's render region, as Cycles': outside the camera view the view's own
    (View > Render Region), through the camera the scene's Render Region on the camera's frame;
    the region's pixels only are rendered (the camera record's region, kept at the reduced
    first resolutions) and drawn in their place."""
    from ppm_engine.blender.viewport import draw_frame, view_camera
    from ppm_engine.render.viewport_frame import Frame
    from ppm_engine.scene.camera import region_fraction, scaled_camera
    from tests.helpers.viewport_stubs import Engine, stub_gpu
    scene = empty
    scene.render.resolution_x, scene.render.resolution_y = 64, 36     # the region's aspect
    dg = bpy.context.evaluated_depsgraph_get()
    rv3d = types.SimpleNamespace(view_matrix=look((3.0, -6.0, 2.5), (0.0, 0.0, 0.0)),
                                 window_matrix=blender_window_matrix(64, 36),
                                 view_perspective='PERSP')
    ctx = context_stub(rv3d, 64, 36)
    ctx.space_data = types.SimpleNamespace(
        use_render_border=True, render_border_min_x=0.25, render_border_min_y=0.5,
        render_border_max_x=0.75, render_border_max_y=1.0)
    cam = view_camera(ctx, dg)
    assert tuple(cam["region"][0]) == (16, 18, 32, 18)
    assert tuple(scaled_camera(cam, 4)["region"][0]) == (4, 4, 8, 5)    # covers it
    ctx.space_data.use_render_border = False
    assert tuple(view_camera(ctx, dg)["region"][0]) == (0, 0, 64, 36)
    # through the camera (zoomed so that its frame is the region, as camera_view_factor 1):
    # the scene's region on the camera's frame
    rv3d.view_perspective = 'CAMERA'
    rv3d.window_matrix = blender_window_matrix(64, 36, zoom=1.0)
    assert tuple(view_camera(ctx, dg)["region"][0]) == (0, 0, 64, 36)
    scene.render.use_border = True
    scene.render.border_min_x, scene.render.border_max_x = 0.5, 1.0
    scene.render.border_min_y, scene.render.border_max_y = 0.0, 0.5
    cam = view_camera(ctx, dg)
    assert tuple(cam["region"][0]) == (32, 0, 32, 18)
    rv3d.window_matrix = blender_window_matrix(64, 36, zoom=2.0)    # the frame: half the view
    assert tuple(view_camera(ctx, dg)["region"][0]) == (32, 9, 16, 9)
    gpu = stub_gpu(monkeypatch)
    frame = Frame(np.zeros((18, 32, 4), np.float32), 64, 36, 1, 1, generation=1, restart=0,
                  region=region_fraction(cam))
    draw_frame(Engine(gpu), object(), frame, 128, 72, {})
    assert [c[2:] for c in gpu if c[0] == "draw_texture_2d"] == [((64, 0), 64, 36)]
