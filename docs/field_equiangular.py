"""The RMSE of a constant density field (a program: tracked with null collisions) under the fog
room's spot light at 64 passes, against its homogeneous twin's image at 2 x 1024 passes (the
same fog by closed forms): docs/VOLUMES.md's figure for equiangular sampling in fields.
Run from the repository's root: python docs/field_equiangular.py"""
import os
import sys

import numpy as np

sys.path.insert(0, os.getcwd())


def main():
    import bpy

    from ppm_engine.blender.harness import ensure_registered, read_exr, set_output
    from ppm_engine.render.device import list_devices
    from tests.conftest import configure_tiny
    from tests.helpers.volume_scenes import fog_room
    ensure_registered()
    key = next(d.key for d in list_devices()
               if "portable" in d.platform.lower() or "pocl" in d.platform.lower())

    def render(scene, passes, seed):
        configure_tiny(scene, key, width=32, height=32, passes=passes, photons=4096)
        scene.ppm.seed = seed
        path = f"/tmp/field_equiangular_{passes}_{seed}.exr"
        set_output(scene, path)
        bpy.ops.render.render(write_still=True)
        return read_exr(path)[..., :3]

    scene = fog_room(density=0.8)
    c = scene.cycles
    c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = 0
    c.volume_bounces, c.transparent_max_bounces = 0, 8
    ref = np.mean([render(scene, 1024, s) for s in range(2)], axis=0)
    nt = bpy.data.materials["Fog"].node_tree
    grad = nt.nodes.new("ShaderNodeTexGradient")
    mul, add = nt.nodes.new("ShaderNodeMath"), nt.nodes.new("ShaderNodeMath")
    mul.operation, mul.inputs[1].default_value = "MULTIPLY", 0.0
    add.operation, add.inputs[1].default_value = "ADD", 0.8
    nt.links.new(grad.outputs["Fac"], mul.inputs[0])
    nt.links.new(mul.outputs[0], add.inputs[0])
    nt.links.new(add.outputs[0], nt.nodes["Principled Volume"].inputs["Density"])
    errs = [np.sqrt(((render(scene, 64, s) - ref) ** 2).mean()) for s in range(4)]
    print(f"field RMSE at 64 passes {np.mean(errs):.5f} (the image's mean {ref.mean():.5f})")


if __name__ == "__main__":
    main()
