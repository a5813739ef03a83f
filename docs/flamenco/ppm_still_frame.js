// Flamenco job type: one still frame of the Progressive Photon Mapping engine split by passes.
//
// N render tasks, each `python -m ppm_engine render SCENE.blend --pass-range A-B -o PART.npz`
// on whichever worker takes it (the global radius schedule: every pass renders the same
// anywhere), then one merge task, `python -m ppm_engine merge PARTS... -o OUTPUT`, once every
// render task is done.  A failed task is rerun by Flamenco as any task; each pass is in one part
// only, and the merge refuses a pass counted twice.  docs/USAGE.md, "On a render farm:
// Flamenco", says how to install it (copy this file into the Manager's scripts/ folder).
//
// Workers need this repository's package installed (pip install ".") in the Python that
// `python` names (a Manager variable such as {ppm_python} works there too), and the .blend and
// the output folder on shared storage, as for Flamenco's own Blender jobs.

const JOB_TYPE = {
  label: "PPM Still Frame (pass ranges)",
  description: "One frame of the PPM engine rendered as pass ranges on many workers, merged",
  settings: [
    { key: "blendfile", type: "string", subtype: "file_path", required: true,
      description: "The .blend to render (its PPM settings; resolution, photons, seed)" },
    { key: "passes", type: "int32", default: 2000, required: true,
      description: "Passes of the whole frame" },
    { key: "chunk_passes", type: "int32", default: 250, required: true,
      description: "Passes per render task" },
    { key: "frame", type: "int32", default: 1, required: true,
      description: "The frame to render" },
    { key: "output", type: "string", subtype: "file_path", required: true,
      description: "The merged image (.exr or .png); the parts go to a folder beside it" },
    { key: "python", type: "string", default: "python3", visible: "submission",
      description: "The Python with the ppm_engine package on the workers" },
    { key: "device", type: "string", default: "", visible: "submission",
      description: "OpenCL device on the workers (empty: each worker's default, a GPU if any)" },
  ],
};

// [first, last] pass ranges (from 1) of `chunk` passes covering 1..passes
function passRanges(passes, chunk) {
  const out = [];
  for (let a = 1; a <= passes; a += chunk) {
    out.push([a, Math.min(a + chunk - 1, passes)]);
  }
  return out;
}

function ppmCommand(settings, args) {
  return author.Command("exec", { exe: settings.python, args: ["-m", "ppm_engine"].concat(args) });
}

function compileJob(job) {
  const settings = job.settings;
  if (settings.passes < 1 || settings.chunk_passes < 1) {
    throw "passes and chunk_passes must be at least 1";
  }
  const partsDir = path.join(path.dirname(settings.output), `${path.stem(settings.output)}-parts`);
  const device = settings.device ? ["--device", settings.device] : [];
  const parts = [];
  const renderTasks = [];
  for (const [a, b] of passRanges(settings.passes, settings.chunk_passes)) {
    const part = path.join(partsDir, `passes-${a}-${b}.npz`);
    const task = author.Task(`render-passes-${a}-${b}`, "blender");
    task.addCommand(author.Command("exec", {
      exe: settings.python,
      args: ["-c", "import os, sys; os.makedirs(sys.argv[1], exist_ok=True)", partsDir],
    }));
    task.addCommand(ppmCommand(settings, ["render", settings.blendfile, "--frame",
      `${settings.frame}`, "--pass-range", `${a}-${b}`, "-o", part].concat(device)));
    job.addTask(task);
    renderTasks.push(task);
    parts.push(part);
  }
  const merge = author.Task("merge-parts", "misc");
  merge.addCommand(ppmCommand(settings, ["merge"].concat(parts, ["-o", settings.output])));
  for (const t of renderTasks) {
    merge.addDependency(t);
  }
  job.addTask(merge);
}
