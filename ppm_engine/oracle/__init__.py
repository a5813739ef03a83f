"""Test and benchmark oracles (no bpy): slow, readable NumPy versions of the kernels
(``reference``), scenes with exact answers (``analytic``) and scenes built directly as
SceneArrays (``procedural``)."""
