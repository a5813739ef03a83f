"""The node-graph compiler (ppm_engine/blender/export/shader_graph.py): constant folding, node
groups inlined, a shared sub-graph evaluated once, an unsupported node warned once, a cycle cut, the
program's layout and ops (shader_program.ops_used), a graph too large for the stack."""
import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from ppm_engine.blender.export.material_nodes import read_material
from ppm_engine.scene.arrays import shader_node
from ppm_engine.scene.shader_program import (
    BOUND,
    FIELD_WORD,
    GEOM_WINDOW,
    MAX_STACK,
    PROGRAM_WINDOW,
    SVM_BLACKBODY,
    SVM_GEOMETRY,
    SVM_MATH,
    SVM_RGB_TO_BW,
    SVM_WAVELENGTH,
    ops_used,
)
from ppm_engine.scene.spectra import blackbody_rgb, wavelength_rgb


def _material(name="M"):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    mat = bpy.data.materials.new(name)
    return mat, mat.node_tree, mat.node_tree.nodes["Principled BSDF"]


def _read(mat):
    warnings = []
    row, nodes, program = read_material(mat, warnings.append)
    nodes = [(shader_node(**n) if isinstance(n, dict) else n)[0] for n in nodes]
    return row, nodes, program, warnings


def _math(t, op, a=None, b=None, va=0.0, vb=0.0):
    n = t.nodes.new("ShaderNodeMath")
    n.operation = op
    n.inputs[0].default_value, n.inputs[1].default_value = va, vb
    if a is not None:
        t.links.new(a, n.inputs[0])
    if b is not None:
        t.links.new(b, n.inputs[1])
    return n


def _ops(program):
    return [int(w[0]) for w in program[1 + int(program[0, 0]):]]


def test_constant_graph_folds_to_constants():
    mat, t, p = _material()
    v = t.nodes.new("ShaderNodeValue")
    v.outputs[0].default_value = 0.3
    m = _math(t, "MULTIPLY", v.outputs[0], vb=2.0)
    s = _math(t, "SQRT", m.outputs[0])
    t.links.new(s.outputs[0], p.inputs["Roughness"])
    rgb = t.nodes.new("ShaderNodeRGB")
    rgb.outputs[0].default_value = (0.2, 0.4, 0.6, 1.0)
    t.links.new(rgb.outputs[0], p.inputs["Base Color"])
    _row, (node,), program, warnings = _read(mat)
    assert program is None and node["bound"] == 0 and not warnings
    assert node["roughness"] == pytest.approx(np.sqrt(0.6), rel=1e-6)
    np.testing.assert_allclose(node["color"], (0.2, 0.4, 0.6), rtol=1e-6)


def test_driven_inputs_bound_and_the_program_laid_out():
    mat, t, p = _material()
    geo = t.nodes.new("ShaderNodeNewGeometry")
    sep = t.nodes.new("ShaderNodeSeparateXYZ")
    t.links.new(geo.outputs["Incoming"], sep.inputs[0])
    m = _math(t, "MULTIPLY", sep.outputs[2], vb=0.5)
    t.links.new(m.outputs[0], p.inputs["Roughness"])
    t.links.new(m.outputs[0], p.inputs["Metallic"])
    _row, (node,), program, warnings = _read(mat)
    assert program is not None and not warnings
    n_binds, n_words, stack, _ = program[0]
    assert n_words == program.shape[0] and 0 < stack <= MAX_STACK
    binds = program[1:1 + n_binds]
    assert sorted(binds[:, 1].tolist()) == sorted([FIELD_WORD["roughness"],
                                                   FIELD_WORD["metallic"]])
    assert node["bound"] == BOUND["roughness"] | BOUND["metallic"]
    # the shared Math node is computed once for both inputs
    assert _ops(program).count(SVM_MATH) == 1
    assert binds[0, 3] == binds[1, 3]
    assert ops_used(program[None, :][0], [0]) == 0            # word 0: no program
    assert ops_used(np.concatenate([np.zeros((1, 4), np.int32), program]), [1]) \
        & (1 << SVM_MATH)


def test_node_groups_inlined_and_reroutes_followed():
    mat, t, p = _material()
    g = bpy.data.node_groups.new("Half", "ShaderNodeTree")
    g.interface.new_socket("In", in_out="INPUT", socket_type="NodeSocketFloat")
    g.interface.new_socket("Out", in_out="OUTPUT", socket_type="NodeSocketFloat")
    gi, go = g.nodes.new("NodeGroupInput"), g.nodes.new("NodeGroupOutput")
    half = g.nodes.new("ShaderNodeMath")
    half.operation = "MULTIPLY"
    half.inputs[1].default_value = 0.5
    g.links.new(gi.outputs[0], half.inputs[0])
    g.links.new(half.outputs[0], go.inputs[0])
    node = t.nodes.new("ShaderNodeGroup")
    node.node_tree = g
    v = t.nodes.new("ShaderNodeValue")
    v.outputs[0].default_value = 0.8
    reroute = t.nodes.new("NodeReroute")
    t.links.new(v.outputs[0], reroute.inputs[0])
    t.links.new(reroute.outputs[0], node.inputs[0])
    t.links.new(node.outputs[0], p.inputs["Roughness"])
    # the same group fed by a varying value: its Math node runs in the program
    node2 = t.nodes.new("ShaderNodeGroup")
    node2.node_tree = g
    geo = t.nodes.new("ShaderNodeNewGeometry")
    t.links.new(geo.outputs["Backfacing"], node2.inputs[0])
    t.links.new(node2.outputs[0], p.inputs["Metallic"])
    _row, (bsdf,), program, warnings = _read(mat)
    assert not warnings
    assert bsdf["roughness"] == pytest.approx(0.4)          # folded through the group
    assert bsdf["bound"] == BOUND["metallic"] and _ops(program).count(SVM_MATH) == 1


def test_unsupported_node_warned_once_with_its_default():
    mat, t, p = _material("Odd")
    odd = t.nodes.new("ShaderNodeWireframe")
    t.links.new(odd.outputs[0], p.inputs["Roughness"])
    t.links.new(odd.outputs[0], p.inputs["Metallic"])
    _row, (bsdf,), _program, warnings = _read(mat)
    assert sum(odd.name in w and "Odd" in w for w in warnings) == 1
    assert bsdf["roughness"] == pytest.approx(odd.outputs[0].default_value)


def test_blackbody_and_wavelength_fold_or_run_and_window_flags_the_program():
    """A constant Temperature or Wavelength folds into the colour (no program); a linked one
    is an op; the Window coordinates flag the program (the camera is read)."""
    mat, t, p = _material()
    bb, wl = t.nodes.new("ShaderNodeBlackbody"), t.nodes.new("ShaderNodeWavelength")
    bb.inputs[0].default_value, wl.inputs[0].default_value = 3000.0, 550.0
    t.links.new(bb.outputs[0], p.inputs["Base Color"])
    t.links.new(wl.outputs[0], p.inputs["Emission Color"])
    p.inputs["Emission Strength"].default_value = 1.0
    _row, (node,), program, warnings = _read(mat)
    assert program is None and not warnings
    np.testing.assert_allclose(node["color"], blackbody_rgb(3000.0), rtol=1e-6)
    np.testing.assert_allclose(node["emission"], wavelength_rgb(550.0), rtol=1e-6)
    # the fit's constant ends (below 800 K, from 12000 K); the rest: tests/test_shader_nodes.py
    assert blackbody_rgb(500.0) == pytest.approx((5.4133, 0.0, 0.0), abs=1e-4)
    assert blackbody_rgb(2e4) == pytest.approx((0.8263, 0.9945, 1.5663), abs=1e-4)
    assert wavelength_rgb(370.0) == wavelength_rgb(780.0) == (0.0, 0.0, 0.0)
    tc = t.nodes.new("ShaderNodeTexCoord")
    sep = t.nodes.new("ShaderNodeSeparateXYZ")
    t.links.new(tc.outputs["Window"], sep.inputs[0])
    k = _math(t, "MULTIPLY", sep.outputs[0], vb=10000.0)
    t.links.new(k.outputs[0], bb.inputs[0])
    t.links.new(sep.outputs[1], wl.inputs[0])
    _row, (node,), program, warnings = _read(mat)
    assert not warnings and program[0, 3] & PROGRAM_WINDOW
    ops = _ops(program)
    assert SVM_BLACKBODY in ops and SVM_WAVELENGTH in ops
    geom = [w for w in program[1 + int(program[0, 0]):] if w[0] == SVM_GEOMETRY]
    assert [int(w[2]) for w in geom] == [GEOM_WINDOW]


def test_a_muted_node_passes_its_input_through_and_colour_converts_to_float():
    mat, t, p = _material()
    rgb = t.nodes.new("ShaderNodeRGB")
    rgb.outputs[0].default_value = (0.1, 0.5, 0.9, 1.0)
    inv = t.nodes.new("ShaderNodeInvert")
    inv.mute = True
    t.links.new(rgb.outputs[0], inv.inputs["Color"])
    t.links.new(inv.outputs[0], p.inputs["Roughness"])
    _row, (bsdf,), program, _warnings = _read(mat)
    assert program is None
    # colour -> float by luminance (Cycles' Rec. 709 weights)
    assert bsdf["roughness"] == pytest.approx(0.2126729 * 0.1 + 0.7151522 * 0.5
                                              + 0.0721750 * 0.9, rel=1e-5)
    bw = t.nodes.new("ShaderNodeTexCoord")
    t.links.new(bw.outputs["UV"], inv.inputs["Color"])
    _row, (bsdf,), program, _warnings = _read(mat)
    assert SVM_RGB_TO_BW not in _ops(program)             # UV is a vector: averaged


def test_a_cycle_is_cut():
    """Blender marks a link closing a cycle invalid; like Cycles, the input it feeds takes its
    unlinked value (the compiler also cuts a cycle it meets itself, with a warning)."""
    mat, t, p = _material("Loop")
    a = _math(t, "ADD", vb=0.1)
    b = _math(t, "ADD", a.outputs[0], vb=0.1)
    t.links.new(b.outputs[0], a.inputs[0])
    t.links.new(b.outputs[0], p.inputs["Roughness"])
    _row, (bsdf,), program, _warnings = _read(mat)
    assert program is None
    assert bsdf["roughness"] == pytest.approx(0.2) or bsdf["roughness"] == pytest.approx(0.1)


def test_linked_mix_shader_factor_drives_the_weights():
    mat, t, p = _material()
    lw = t.nodes.new("ShaderNodeLayerWeight")
    mix = t.nodes.new("ShaderNodeMixShader")
    glossy = t.nodes.new("ShaderNodeBsdfGlossy")
    t.links.new(lw.outputs["Facing"], mix.inputs[0])
    t.links.new(p.outputs[0], mix.inputs[1])
    t.links.new(glossy.outputs[0], mix.inputs[2])
    t.links.new(mix.outputs[0], t.nodes["Material Output"].inputs["Surface"])
    _row, nodes, program, _warnings = _read(mat)
    assert len(nodes) == 2 and all(n["bound"] & BOUND["weight"] for n in nodes)
    assert program[0, 0] == 2


def test_too_large_a_graph_falls_back_to_constants():
    mat, t, p = _material("Big")
    geo = t.nodes.new("ShaderNodeNewGeometry")
    prev = geo.outputs["Backfacing"]
    for _ in range(MAX_STACK + 8):
        prev = _math(t, "ADD", prev, vb=0.001).outputs[0]
    t.links.new(prev, p.inputs["Roughness"])
    _row, (bsdf,), program, warnings = _read(mat)
    assert program is None and bsdf["bound"] == 0
    assert any("Big" in w and str(MAX_STACK) in w for w in warnings)
    assert bsdf["roughness"] == pytest.approx(p.inputs["Roughness"].default_value)
