"""OpenCL programs: built once per (file, defines) from the kernel sources with -I on their
folder, each kernel fetched once and launched with its arguments bound by name.  A failed build
raises KernelBuildError carrying the compiler log."""
from __future__ import annotations

from pathlib import Path

from ppm_engine.errors import KernelBuildError

_PACKAGE = Path(__file__).resolve().parents[2]


def kernel_dir() -> Path:
    """The folder of the OpenCL sources, wherever the engine is installed: ``ppm_engine/kernels``
    in a wheel (pyproject.toml maps the repository's top-level ``kernels/`` into the package),
    or ``kernels/`` beside the package in a source checkout, an editable install and the
    extension zip (which keep the repository's layout)."""
    for folder in (_PACKAGE / "kernels", _PACKAGE.parent / "kernels"):
        if (folder / "types.h").is_file():
            return folder
    raise KernelBuildError(f"the OpenCL kernel sources were not found next to {_PACKAGE}: the "
                           "installation is incomplete; reinstall the add-on or the package")


# Work-group size of the kernels that shade hits (eye, photon, gather): their closure lists
# are large private arrays, and PoCL keeps one per work-item of a group on a thread's stack, so
# a group of the driver's choice (up to 4096) overflows it; 64 suits GPUs as well.
SHADING_GROUP = 64


# Work-group size of every launch that names none.  Never the driver's choice: PoCL compiles a
# kernel anew for each work-group size it is launched with (its kernel cache keeps one binary per
# size), and the size it chooses follows the global size (often the whole launch, up to 4096):
# every scene with another triangle or pixel count compiled the BVH's, the film's and the hash's
# kernels again (a cold test run compiled the BVH's nine kernels 320 times).  One size, one
# compile; 64 keeps GPUs' groups whole.
WORK_GROUP = 64


def global_size(n: int, wg: int = WORK_GROUP) -> int:
    """``n`` work-items rounded up to whole work-groups of ``wg`` (at least one group)."""
    return max(wg, (n + wg - 1) // wg * wg)


# PoCL compiles a kernel twice more: for grids whose every dimension is under 65,536 items (its
# "small grid" specialisation) and for larger ones; a scene's small launches (a preview, the
# viewport's first reduced images, a test's tiny image) and large ones (the full image, 65,536
# photons) compiled each kernel twice.  So a launch of that many items or more runs as rows of
# at most GRID_ROW items (a 2D grid, kernels/builtins.h WORK_ITEM): every launch is a small
# grid, one binary per kernel.  (Any OpenCL device takes 2D grids; GPUs' rows stay whole.)
SMALL_GRID = 1 << 16


def grid(n: int, wg: int = WORK_GROUP) -> tuple[tuple, tuple]:
    """(global size, local size) of a launch of ``n`` work-items in groups of ``wg``: one row
    under SMALL_GRID items, else rows of the most whole groups under it."""
    g = global_size(n, wg)
    if g < SMALL_GRID:
        return (g,), (wg,)
    row = (SMALL_GRID - 1) // wg * wg
    return (row, -(-g // row)), (wg, 1)


def in_pieces(launch, n: int, piece: int, interrupt, label: str) -> list | None:
    """``launch(count, start)`` (an event) over ``n`` work items: in one launch, not waited
    for, without ``interrupt`` or below two pieces of ``piece`` items; else over ``n //
    piece`` consecutive ranges (whole work-groups of SHADING_GROUP), each waited for and
    ``interrupt()`` asked after it.  [(label, event)], or None when it answered True (the rest
    is not launched)."""
    pieces = n // piece
    if interrupt is None or pieces < 2:
        return [(label, launch(n, 0))]
    step = max(-(-n // pieces // SHADING_GROUP) * SHADING_GROUP, SHADING_GROUP)
    events = []
    for start in range(0, n, step):
        ev = launch(min(step, n - start), start)
        events.append((label, ev))
        ev.wait()
        if start + step < n and interrupt():
            return None
    return events


class Launch:
    """A kernel launched with its arguments bound by name: the names of its OpenCL signature
    (programs are built with -cl-kernel-arg-info).  A missing or unknown name is refused with
    both lists, so a signature change cannot silently shift positional arguments."""

    def __init__(self, kernel, label: str):
        import pyopencl as cl
        self.kernel = kernel
        self.label = label
        self.names = tuple(kernel.get_arg_info(i, cl.kernel_arg_info.NAME)
                           for i in range(kernel.num_args))

    def __call__(self, queue, size: int, local: int | None = None, /, *, wait_for=None,
                 offset: int = 0, **args):
        """Enqueue over ``global_size(size)`` work-items (work-group ``local``, WORK_GROUP
        unless given), their ids from ``offset`` on; returns the event.  (The first three are
        positional-only: kernels have arguments named ``n``.)"""
        import pyopencl as cl
        if args.keys() != set(self.names):
            missing = [k for k in self.names if k not in args]
            unknown = sorted(set(args) - set(self.names))
            raise TypeError(f"kernel {self.kernel.function_name}: missing {missing}, "
                            f"unknown {unknown}")
        self.kernel.set_args(*(args[k] for k in self.names))
        local = local or WORK_GROUP
        if offset:       # (pieces, kernels/builtins.h WORK_ITEM: one row from the offset)
            if global_size(size, local) >= SMALL_GRID:
                raise ValueError(f"kernel {self.kernel.function_name}: a launch from an "
                                 f"offset takes under {SMALL_GRID} items")
            return cl.enqueue_nd_range_kernel(queue, self.kernel, (global_size(size, local),),
                                              (local,), wait_for=wait_for,
                                              global_work_offset=(offset,))
        glob, loc = grid(size, local)
        return cl.enqueue_nd_range_kernel(queue, self.kernel, glob, loc, wait_for=wait_for)


class Program:
    def __init__(self, cl_program):
        self._program = cl_program
        self._kernels = {}
        self._launches = {}

    def kernel(self, name: str):
        k = self._kernels.get(name)
        if k is None:
            import pyopencl as cl
            k = self._kernels[name] = cl.Kernel(self._program, name)
        return k

    def launch(self, name: str, label: str) -> Launch:
        """Kernel ``name`` with named arguments (one Launch per kernel and label)."""
        key = (name, label)
        if key not in self._launches:
            self._launches[key] = Launch(self.kernel(name), label)
        return self._launches[key]

    def __getattr__(self, name):
        if name.startswith("_"):
            raise AttributeError(name)
        return self.kernel(name)


class ProgramCache:
    """The device's programs by (file, defines), each built once per process; the binaries are
    also cached on disk by the OpenCL driver across processes (PoCL's kernel cache, the GPU
    drivers' caches), which makes a second process's build a load.

    ``builds`` counts the programs built (or loaded from the driver's disk cache) in this
    process, pyopencl's library kernels (Device.radix_sort_uint_pairs ...) included: the
    viewport asserts that an edit adds none.  ``listeners`` are called as ``f(filename,
    done)`` around every build, from the thread that builds (the viewport's status line).
    Building is serialised by a lock: the viewport's worker and a final render or preview may
    share the device."""

    def __init__(self, context, device, lock=None):
        import threading
        self.context = context
        self.device = device
        self._programs: dict[tuple, Program] = {}
        self.builds = 0
        self.build_seconds = 0.0
        self.listeners: list = []
        self.lock = lock if lock is not None else threading.RLock()

    def get(self, filename: str, defines: dict | None = None) -> Program:
        defines = dict(sorted((defines or {}).items()))
        key = (filename, tuple(defines.items()))
        prog = self._programs.get(key)
        if prog is None:
            with self.lock:
                prog = self._programs.get(key)
                if prog is None:
                    prog = self._programs[key] = Program(self._timed(filename, self._build,
                                                                     filename, defines))
        return prog

    def _timed(self, label: str, build, *args, **kwargs):
        """``build(*args, **kwargs)``, counted and timed, the listeners told before and
        after."""
        import time
        for f in tuple(self.listeners):
            f(label, False)
        t0 = time.perf_counter()
        try:
            return build(*args, **kwargs)
        finally:
            self.builds += 1
            self.build_seconds += time.perf_counter() - t0
            for f in tuple(self.listeners):
                f(label, True)

    def _build(self, filename: str, defines: dict):
        import pyopencl as cl
        folder = kernel_dir()
        path = folder / filename
        if not path.is_file():
            raise KernelBuildError(f"kernel source {path} is missing: the installation is "
                                   "incomplete; reinstall the add-on")
        # no fast-relaxed-math: the NaN/Inf guards need isfinite; argument names for Launch
        options = [f"-I{folder}", "-cl-kernel-arg-info"]
        # PoCL calls its vector builtins out of line: the kernels' inline versions
        # (kernels/builtins.h)
        if "Portable Computing Language" in self.device.platform.name:
            options.append("-DPPM_INLINE_BUILTINS")
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
