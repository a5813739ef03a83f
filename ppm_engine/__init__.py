"""Progressive Photon Mapping: a Blender render engine (stochastic progressive photon mapping
in OpenCL kernels).

Importing the package is cheap on purpose: Blender imports add-ons at startup, and the bpy-free
core (``ppm_engine.render.renderer`` and friends) is imported by tests and the CLI without Blender.
``register()`` imports the Blender layer lazily; nothing here imports pyopencl.
"""


def _modules():
    # fixed order: properties < engine < ui (each registers its own classes)
    from ppm_engine.blender import engine, properties, ui
    return (properties, engine, ui)


def register():
    for module in _modules():
        module.register()


def unregister():
    for module in reversed(_modules()):
        module.unregister()
