"""The scene model (no bpy, no OpenCL): ``SceneArrays`` and its record types (``arrays``), the
scene as the device renders it (``prep``), materials and their shader programs, emitters and the
light tree, the camera model, Cycles' Light Paths, and the host precomputations the closures and
nodes read (shading tables, spectra, the sky models)."""
