"""The benchmark's scenes as built (no render): the volume scenes of issue 42 are examples and
bench scenes with their reference, Light Paths and regions (the quick run that renders every
bench scene: tests/test_bench.py, slow)."""
import numpy as np
import pytest

from ppm_engine.tools.bench.curves import SCENES


def test_volume_bench_scenes_build_and_are_registered(bpy):
    """The volume scenes of issue 42 (no render): each an example and a bench scene whose
    reference is Cycles' long render with Cycles' default Light Paths, which its builder sets
    (Volume bounces 0); the fog room's fog a homogeneous medium, the smoke's density a Noise
    Texture at its default vector (Generated) through a clamped Map Range."""
    from ppm_engine.blender.export import export_scene
    from ppm_engine.blender.scenes import EXAMPLES, build_example, fog_room
    from ppm_engine.scene.light_paths import CYCLES_DEFAULTS
    from ppm_engine.tools.bench.curves import REFERENCE_ENGINE
    from ppm_engine.tools.bench.scenes import CAUSTIC_MASKS, LIGHT_PATHS, REGIONS
    from ppm_engine.tools.bench.scoring import TARGETS
    for name in ("fog_room", "smoke"):
        assert name in EXAMPLES and name in SCENES and REFERENCE_ENGINE[name] == "CYCLES"
        assert LIGHT_PATHS[name] == CYCLES_DEFAULTS and TARGETS[name] == 1.0
        assert CAUSTIC_MASKS[name]["kind"] == "all"
        scene = build_example(name)
        assert {k: getattr(scene.cycles, k) for k in CYCLES_DEFAULTS} == pytest.approx(
            CYCLES_DEFAULTS)
        volumes = [o for o in scene.objects if o.type == "MESH" and o.active_material.node_tree
                   .nodes["Material Output"].inputs["Volume"].is_linked]
        assert len(volumes) == 1
    nodes = volumes[0].active_material.node_tree.nodes
    density = nodes["Principled Volume"].inputs["Density"].links[0].from_node
    assert density.bl_idname == "ShaderNodeMapRange" and density.clamp
    noise = density.inputs["Value"].links[0].from_node
    assert noise.bl_idname == "ShaderNodeTexNoise" and not noise.inputs["Vector"].is_linked
    assert {o.type for o in scene.objects} == {"MESH", "LIGHT", "CAMERA"}
    assert scene.world.node_tree.nodes["Background"].inputs["Color"].links[0].from_node \
        .bl_idname == "ShaderNodeTexSky"
    # the fog room's fog: sigma_s = colour x density, one medium (the smoke's export, its
    # Sky Texture's tables, takes seconds: the slow tier's quick run of every bench scene)
    scene = build_example("fog_room")
    # its regions (where the error lies) partition the image, none empty
    regions = REGIONS["fog_room"](scene, 24, 24)
    assert set(regions) == {"pool", "cone", "fog", "room"}
    assert sum(m.astype(int) for m in regions.values()).tolist() == np.ones((24, 24)).tolist()
    assert all(m.any() for m in regions.values())
    arrays = export_scene(bpy.context.evaluated_depsgraph_get())
    assert not arrays.warnings
    sigma_s = arrays.materials["scattering"]
    assert sigma_s.max() == pytest.approx(fog_room.FOG_DENSITY * fog_room.FOG_COLOR[0])
