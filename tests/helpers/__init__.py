"""Helpers that more than one test module uses, imported as ``from tests.helpers.X import
name`` (pytest.ini's ``pythonpath = ..`` puts the repository root on sys.path, where tests/ is a
namespace package): no test module imports another and none changes sys.path
(test_layout.py checks both).  A helper one module uses stays in that module; fixtures stay in
conftest.py.

- blender_scenes: Blender scenes built with bpy (a light, a plane, a camera, a textured plane,
  an area light with a grey world and a camera) and their export to SceneArrays
- shader_grid: the shader nodes' harness against Cycles, per pixel (one plane per case)
- cycles_blocks: a Blender scene rendered by Cycles and by this engine, compared per 8 x 8 block
- procedural_scenes: SceneArrays built without Blender (a light, the furnace, a small room)
- renders: a SceneArrays rendered by the engine without Blender
- debug_kernels: debug.cl's kernels at chosen points (the emitter pick)
"""
