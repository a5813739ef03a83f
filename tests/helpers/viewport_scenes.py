"""The viewport tests' look-dev scene (test_viewport.py, test_viewport_blender.py): a ball on a
floor under a point light, and the camera a 3D view looking through the scene camera hands
view_draw."""
import numpy as np

# the look-dev scene's region and settings: levels 16x12 -> 32x24 -> 64x48, then 3 passes
W, H, START, PASSES = 64, 48, 16, 3


def sphere_scene(bpy, tiny):
    """A Principled ball on a floor under a point light and a grey world: every edit of the
    issue has something to change."""
    from ppm_engine.blender.scenes.cornell_box import principled
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    tiny(scene, width=W, height=H, passes=PASSES, photons=4096, specialize=True)
    scene.ppm.viewport_passes = PASSES
    scene.ppm.viewport_start_resolution = START
    bpy.ops.mesh.primitive_plane_add(size=8.0)
    bpy.context.object.name = "Floor"
    bpy.context.object.data.materials.append(principled("Grey", {"Base Color": (0.5, 0.5, 0.5),
                                                                 "Roughness": 1.0}))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.6, location=(0, 0, 0.6), segments=24,
                                         ring_count=12)
    bpy.context.object.name = "Ball"
    bpy.context.object.data.materials.append(principled("Ball", {"Base Color": (0.8, 0.8, 0.8),
                                                                 "Roughness": 0.5}))
    light = bpy.data.lights.new("Lamp", 'POINT')
    light.energy = 200.0
    lamp = bpy.data.objects.new("Lamp", light)
    lamp.location = (1.5, -1.5, 3.0)
    scene.collection.objects.link(lamp)
    # Filter Glossy off: the ball's specular layer starts caustics, whose photons are aimed at
    # it (with Cycles' default the eye paths carry its glossy light: casters.caustic_roughness)
    scene.cycles.blur_glossy = 0.0
    world = bpy.data.worlds.new("World")          # (with its node tree in Blender 5)
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.3, 0.3, 0.3, 1.0)
    scene.world = world
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location = (0.0, -3.6, 1.4)
    cam.rotation_euler = (np.radians(78), 0.0, 0.0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    bpy.context.view_layer.update()
    return scene


def view(bpy, scene, width=W, height=H):
    """The camera record a 3D view looking through the scene camera hands view_draw: Blender's
    own projection of that camera (Object.calc_matrix_camera) and its inverse placement (the
    benchmark's view)."""
    from ppm_engine.tools.bench import viewport_latency
    return viewport_latency.view(bpy, scene, (width, height))
