"""The Blender layer: the only code that imports ``bpy``.  In import order: ``properties`` (the
engine's settings) < ``export/`` (the depsgraph -> SceneArrays, the only code that reads Blender
scene data) < ``session`` (one render) and ``viewport`` (the 3D view's hand-offs) < ``engine``
(the RenderEngine) < ``ui`` (panels); ``harness`` and ``batch`` serve the CLI, the benchmark and
the tests; ``scenes/`` builds the example scenes with bpy.  The core (``scene/``, ``render/``,
``oracle/``) never imports this package."""
