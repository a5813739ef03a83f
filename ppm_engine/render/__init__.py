"""The renderer on an OpenCL device (no bpy): ``device/`` (contexts, programs, launches), the BVH,
the scene's buffers (``device_scene``), the kernels' feature flags (``features``), the passes of
one SPPM iteration (``passes/``), the photon map, the film, ``Renderer`` (one render: the
algorithm in ``Renderer.iterate``), the viewport's session and the light tracer used for
references."""
