"""The benchmark (``python -m ppm_engine bench``; docs/BENCHMARKS.md): error against time with
Cycles side by side (curves.py), micro benchmarks of the kernels and the BVH (micro.py), where a
pass spends its time (phases.py), what each skip of unneeded work saves (skips.py); its scene data
(scenes.py), the glass balls' exact-geometry reference (exact_caustic.py: point_caustic,
rough_caustic, far_caustic; independent of the engine), LuxCore (luxcore.py, luxcore_scene.py: a
curve, and the light tracer that is the bulb box's and the mirror caustic's reference;
reference_check.py sets it against ours) and outputs (report.py); command.py runs one of them from
the CLI's arguments.

Tooling, not the add-on: blender_manifest.toml's build excludes leave this subpackage out of the
extension zip.  It drives the engine only through public interfaces (RenderOptions, Renderer,
the pass objects, session.listening and session.renders, blender_io)."""
