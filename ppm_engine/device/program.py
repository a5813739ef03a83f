"""OpenCL programs: built once per (file, defines) from kernels/*.cl with -I kernels/, each
kernel fetched once.  A failed build raises KernelBuildError carrying the compiler log."""
from __future__ import annotations

from pathlib import Path

from ..errors import KernelBuildError

KERNEL_DIR = Path(__file__).resolve().parents[2] / "kernels"


class Program:
    def __init__(self, cl_program):
        self._program = cl_program
        self._kernels = {}

    def kernel(self, name: str):
        k = self._kernels.get(name)
        if k is None:
            import pyopencl as cl
            k = self._kernels[name] = cl.Kernel(self._program, name)
        return k

    def __getattr__(self, name):
        if name.startswith("_"):
            raise AttributeError(name)
        return self.kernel(name)


class ProgramCache:
    def __init__(self, context, device):
        self.context = context
        self.device = device
        self._programs: dict[tuple, Program] = {}

    def get(self, filename: str, defines: dict | None = None) -> Program:
        defines = dict(sorted((defines or {}).items()))
        key = (filename, tuple(defines.items()))
        prog = self._programs.get(key)
        if prog is None:
            prog = self._programs[key] = Program(self._build(filename, defines))
        return prog

    def _build(self, filename: str, defines: dict):
        import pyopencl as cl
        path = KERNEL_DIR / filename
        if not path.is_file():
            raise KernelBuildError(f"kernel source {path} is missing: the installation is "
                                   "incomplete; reinstall the add-on")
        options = [f"-I{KERNEL_DIR}"]   # no fast-relaxed-math: the NaN/Inf guards need isfinite
        for k, v in defines.items():
            options.append(f"-D{k}" if v is True else f"-D{k}={v}")
        src = path.read_text()
        try:
            return cl.Program(self.context, src).build(options=options)
        except cl.RuntimeError as e:
            log = _build_log(e)
            raise KernelBuildError(
                f"OpenCL build of kernels/{filename} failed on '{self.device.name.strip()}' "
                f"(options {' '.join(options)}):\n{log}") from e


def _build_log(err) -> str:
    text = str(err)
    return text.strip() or "(the OpenCL compiler gave no log)"
