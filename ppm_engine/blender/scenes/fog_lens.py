"""``fog_lens``: a lens in fog (issue 42), built with bpy from nothing.  A box of fog (Volume
Scatter plus Volume Absorption, a mesh with only a Volume output, FOG_LO to FOG_HI) in a black
world, a clear glass ball (IOR 1.5) in a hollow of it (fog_box: Cycles' volume stack would fill
a glass ball in fog with fog) and a point light of radius 0 above the box: the
ball focuses the light into a bright cone in the fog below it, narrowing to a focus and
widening again (a volumetric caustic: the light paths L S+ M, which no camera path can sample
from a light of no size), around it the fog lit straight by the light and the ball's shadow.
The camera looks at the box from the front; the lamp is above the fog (none of its
singular glow in view).

The fog mostly absorbs (albedo FOG_SCATTER / (FOG_SCATTER + FOG_ABSORB)), so the light
scattered more than once is a few percent of the image: its exact reference
(ppm_engine/tools/bench/exact_fog.py) is single scattering.  Light Paths: 12 bounces of every
kind and Volume bounces 1, which a camera path needs to reach the light through the ball after
scattering in the fog (as in Cycles; path_state.h path_join_volume)."""
from __future__ import annotations

import math

import bpy

from ppm_engine.blender.scenes.cornell_box import camera_world_render, glass, new_scene, sphere

RESOLUTION = 128
FOG_LO, FOG_HI = (-1.2, -1.2, 0.0), (1.2, 1.2, 2.4)
FOG_SCATTER, FOG_ABSORB = 0.02, 0.38            # per metre
BALL = ((0.0, 0.0, 1.45), 0.35)                 # centre, radius
BALL_SEGMENTS = (128, 64)
LIGHT_POS = (0.0, 0.0, 2.9)
LIGHT_POWER = 5000.0                            # W (Cycles units)
CAMERA = ((0.0, -5.0, 1.2), (math.pi / 2, 0.0, 0.0))
LENS = 50.0                                     # mm, on a 36 mm sensor


def fog_material(name="Fog", scatter=FOG_SCATTER, absorb=FOG_ABSORB):
    """A material with only a Volume output: Volume Scatter (white, density ``scatter``) plus
    Volume Absorption (black, density ``absorb``): sigma_s = scatter, sigma_a = absorb."""
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    nt.nodes.remove(nt.nodes["Principled BSDF"])
    s, a = nt.nodes.new("ShaderNodeVolumeScatter"), nt.nodes.new("ShaderNodeVolumeAbsorption")
    s.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    s.inputs["Density"].default_value = scatter
    a.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    a.inputs["Density"].default_value = absorb
    add = nt.nodes.new("ShaderNodeAddShader")
    nt.links.new(s.outputs[0], add.inputs[0])
    nt.links.new(a.outputs[0], add.inputs[1])
    nt.links.new(add.outputs[0], nt.nodes["Material Output"].inputs["Volume"])
    return m


def fog_box(scene, material, lo=FOG_LO, hi=FOG_HI, cavity=None):
    """A closed box mesh (outward faces) from lo to hi; ``cavity`` (centre, radius, (segments,
    rings)): with a spherical hollow there (inward faces) just around a ball of that radius
    meshed so, its faces a little outside the ball's.  A glass ball in a fog box without one
    is full of fog in Cycles, whose volume stack keeps the box's volume inside a surface (and
    so in this engine: kernels/geom/medium.h media_mix); the hollow leaves the ball clear."""
    import bmesh
    mesh = bpy.data.meshes.new("FogBox")
    bm = bmesh.new()
    bmesh.ops.create_cube(bm, size=1.0)
    for v in bm.verts:
        v.co = [lo[k] + (v.co[k] + 0.5) * (hi[k] - lo[k]) for k in range(3)]
    if cavity is not None:
        (cx, cy, cz), r, (seg, rings) = cavity
        # the faces of a UV sphere of radius R come within R cos(pi / n) of its centre
        r_out = r * 1.002 / min(math.cos(math.pi / seg), math.cos(math.pi / rings))
        hollow = bmesh.ops.create_uvsphere(bm, u_segments=seg, v_segments=rings,
                                           radius=r_out)["verts"]
        for v in hollow:
            v.co = (v.co[0] + cx, v.co[1] + cy, v.co[2] + cz)
        faces = list({f for v in hollow for f in v.link_faces})
        bmesh.ops.reverse_faces(bm, faces=faces)
    bm.to_mesh(mesh)
    bm.free()
    mesh.materials.append(material)
    obj = bpy.data.objects.new("FogBox", mesh)
    scene.collection.objects.link(obj)
    return obj


def build(scene=None, ball=True, segments=BALL_SEGMENTS, resolution=RESOLUTION,
          fog=(FOG_SCATTER, FOG_ABSORB)):
    """The scene (see the module docstring); ``ball`` False: the fog and the light alone;
    ``fog``: its (sigma_s, sigma_a)."""
    scene = new_scene(scene)
    camera_world_render(scene, *CAMERA, resolution)
    scene.camera.data.lens = LENS
    scene.cycles.volume_bounces = 1
    fog_box(scene, fog_material(scatter=fog[0], absorb=fog[1]),
            cavity=(BALL[0], BALL[1], segments) if ball else None)
    if ball:
        sphere(scene, "GlassBall", *BALL, glass("Glass"), *segments)
    data = bpy.data.lights.new("Point", 'POINT')
    data.energy, data.shadow_soft_size = LIGHT_POWER, 0.0
    light = bpy.data.objects.new("Point", data)
    light.location = LIGHT_POS
    light.visible_camera = False
    scene.collection.objects.link(light)
    return scene
