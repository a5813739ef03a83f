"""The Flamenco job type (docs/flamenco/ppm_still_frame.js) compiled as Flamenco's Manager would,
by node with stand-ins for Flamenco's `author` and `path` (its job-compiler API): N render tasks
whose pass ranges cover the frame once, a merge task after all of them, and every command line
one that `python -m ppm_engine` accepts."""
import json
import shutil
import subprocess
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "docs" / "flamenco" / "ppm_still_frame.js"

# Flamenco's job-compiler globals, as far as the script uses them (posix paths)
HARNESS = r"""
const fs = require("fs");
const nodePath = require("path").posix;
const tasks = [];
globalThis.print = () => {};
globalThis.path = {
  join: (...p) => nodePath.join(...p), dirname: nodePath.dirname,
  stem: (p) => nodePath.basename(p, nodePath.extname(p)),
};
globalThis.author = {
  Task: (name, type) => {
    const t = { name, type, commands: [], deps: [] };
    t.addCommand = (c) => t.commands.push(c);
    t.addDependency = (d) => t.deps.push(d.name);
    return t;
  },
  Command: (type, params) => ({ type, params }),
};
eval(fs.readFileSync(process.argv[2], "utf8") + "\nglobalThis.compileJob = compileJob;"
     + "\nglobalThis.JOB_TYPE = JOB_TYPE;");
const settings = JSON.parse(process.argv[3]);
for (const s of JOB_TYPE.settings) {
  if (!(s.key in settings) && "default" in s) settings[s.key] = s.default;
}
compileJob({ settings, addTask: (t) => tasks.push(t) });
console.log(JSON.stringify(tasks.map(({ name, type, commands, deps }) =>
  ({ name, type, commands, deps }))));
"""


def _compile(tmp_path, **settings):
    node = shutil.which("node")
    if node is None:
        pytest.skip("node is not installed")
    harness = tmp_path / "harness.js"
    harness.write_text(HARNESS)
    proc = subprocess.run([node, str(harness), str(SCRIPT), json.dumps(settings)],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def test_flamenco_job_renders_ranges_then_merges(tmp_path):
    from ppm_engine.tools.cli import _build_parser
    tasks = _compile(tmp_path, blendfile="/farm/shot.blend", passes=1000, chunk_passes=300,
                     output="/farm/out/shot.exr", device="GPU")
    *renders, merge = tasks
    assert [t["type"] for t in renders] == ["blender"] * 4 and merge["type"] == "misc"
    assert merge["deps"] == [t["name"] for t in renders]
    covered, parts = [], []
    for t in renders:
        mkdir, render = t["commands"]
        assert mkdir["params"]["args"][-1] == "/farm/out/shot-parts"
        args = render["params"]["args"]
        assert render["params"]["exe"] == "python3" and args[:2] == ["-m", "ppm_engine"]
        a = _build_parser().parse_args(args[2:])
        assert a.command == "render" and a.scene == "/farm/shot.blend" and a.device == "GPU"
        covered += range(a.pass_range[0], a.pass_range[1] + 1)
        parts.append(a.output)
    assert covered == list(range(1, 1001))             # every pass once, in order
    [cmd] = merge["commands"]
    m = _build_parser().parse_args(cmd["params"]["args"][2:])
    assert m.command == "merge" and m.parts == parts and m.output == "/farm/out/shot.exr"
