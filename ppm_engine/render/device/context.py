"""Device discovery and the per-device context, queue, program cache and buffer checks."""
from __future__ import annotations

import dataclasses
import threading

import numpy as np

from ppm_engine.errors import DeviceError
from ppm_engine.render.device.program import ProgramCache


@dataclasses.dataclass(frozen=True)
class DeviceInfo:
    key: str          # stable id: "<platform index>:<device index>:<device name>"
    name: str
    platform: str
    type: str         # 'GPU' | 'CPU' | 'OTHER'


def _cl():
    try:
        import pyopencl as cl
    except ImportError as e:  # pragma: no cover - the package depends on it
        raise DeviceError(f"pyopencl is not installed ({e}); install the engine's "
                          "requirements") from e
    return cl


def _enumerate():
    cl = _cl()
    try:
        platforms = cl.get_platforms()
    except cl.Error as e:
        raise DeviceError(
            "no OpenCL platform found: install a GPU driver with OpenCL support or the PoCL CPU "
            f"device (pip install pocl-binary-distribution); OpenCL said: {e}") from e
    out = []
    for pi, p in enumerate(platforms):
        try:
            devs = p.get_devices()
        except cl.Error:
            continue
        for di, d in enumerate(devs):
            t = d.type
            kind = "GPU" if t & cl.device_type.GPU else "CPU" if t & cl.device_type.CPU else "OTHER"
            name = d.name.strip()
            out.append((DeviceInfo(f"{pi}:{di}:{name}", name, p.name.strip(), kind), d))
    return out


def list_devices() -> list[DeviceInfo]:
    """Every OpenCL device on this machine (raises DeviceError when there is no platform)."""
    return [info for info, _ in _enumerate()]


_devices: dict[str, Device] = {}
_lock = threading.Lock()


def get_device(name: str = "") -> Device:
    """The shared Device for ``name`` (a key from list_devices(), or a case-insensitive
    substring of a device or platform name; "" or "DEFAULT": a GPU if present, else a CPU).
    A suffix "#N" (N >= 1) is another context and queue on the same device, its own Device
    (render/multi_device.py: one device as two, for tests and for a CPU shared by two
    renders)."""
    instance = 0
    base, sep, tail = name.rpartition("#")
    if sep and tail.isdigit():
        name, instance = base, int(tail)
    found = _enumerate()
    if not found:
        raise DeviceError("no OpenCL device found: install a GPU OpenCL driver or the PoCL CPU "
                          "device (pip install pocl-binary-distribution)")
    if name in ("", "DEFAULT"):
        gpus = [f for f in found if f[0].type == "GPU"]
        info, dev = (gpus or found)[0]
    else:
        match = [f for f in found if f[0].key == name]
        if not match:
            low = name.lower()
            match = [f for f in found if low in f[0].name.lower() or low in f[0].platform.lower()]
        if not match:
            names = ", ".join(f"'{f[0].name}'" for f in found)
            raise DeviceError(f"no OpenCL device matches '{name}'; available: {names}")
        info, dev = match[0]
    key = info.key if instance == 0 else f"{info.key}#{instance}"
    with _lock:
        if key not in _devices:
            _devices[key] = Device(info, dev)
        return _devices[key]


class Device:
    """One OpenCL context and in-order profiling queue, kept for the life of the process."""

    def __init__(self, info: DeviceInfo, cl_device):
        cl = _cl()
        self.info = info
        self.cl_device = cl_device
        # bytes of every buffer made on this device so far (freed ones included): the
        # difference around a render is what it allocated (bench --phases)
        self.allocated = 0
        self.context = cl.Context([cl_device])
        self.queue = cl.CommandQueue(
            self.context, properties=cl.command_queue_properties.PROFILING_ENABLE)
        self.max_alloc = int(cl_device.max_mem_alloc_size)
        self.global_mem = int(cl_device.global_mem_size)
        ext = cl_device.extensions
        self.int64_atomics = ("cl_khr_int64_extended_atomics" in ext
                              and "cl_khr_int64_base_atomics" in ext)
        # held by whoever uses the queue or the shared kernel objects (a kernel's arguments are
        # set, then it is enqueued): renderers of different threads (the viewport's worker, a
        # final render, a preview) take turns by pass; builds hold it too
        self.lock = threading.RLock()
        self.programs = ProgramCache(self.context, cl_device, self.lock)
        self._algorithms = {}

    def __repr__(self):
        return f"<Device {self.info.name} ({self.info.platform})>"

    # -- buffers --------------------------------------------------------------------------------
    def check_alloc(self, nbytes: int, what: str) -> None:
        if nbytes > self.max_alloc:
            raise DeviceError(
                f"{what} needs {nbytes / 2**20:.1f} MiB in one buffer, more than this device "
                f"allows ({self.max_alloc / 2**20:.1f} MiB, CL_DEVICE_MAX_MEM_ALLOC_SIZE on "
                f"'{self.info.name}'); reduce photons per pass or the resolution")

    def buffer(self, nbytes: int, what: str):
        cl = _cl()
        nbytes = max(int(nbytes), 16)
        self.check_alloc(nbytes, what)
        self.allocated += nbytes
        try:
            return cl.Buffer(self.context, cl.mem_flags.READ_WRITE, nbytes)
        except cl.Error as e:
            raise DeviceError(f"could not allocate {what} ({nbytes / 2**20:.1f} MiB) on "
                              f"'{self.info.name}': {e}") from e

    def upload(self, array: np.ndarray, what: str):
        cl = _cl()
        a = np.ascontiguousarray(array)
        if a.nbytes == 0:
            a = np.zeros(16, np.uint8)
        self.check_alloc(a.nbytes, what)
        self.allocated += a.nbytes
        try:
            return cl.Buffer(self.context, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR,
                             hostbuf=a)
        except cl.Error as e:
            raise DeviceError(f"could not upload {what} ({a.nbytes / 2**20:.1f} MiB) to "
                              f"'{self.info.name}': {e}") from e

    # -- library primitives, built once per device -------------------------------------------------
    def _algorithm(self, name: str, factory):
        """pyopencl library kernel ``name``, made by ``factory()`` once (counted as a build)."""
        alg = self._algorithms.get(name)
        if alg is None:
            with self.programs.lock:
                alg = self._algorithms.get(name)
                if alg is None:
                    alg = self._algorithms[name] = self.programs._timed(name, factory)
        return alg

    def box_area_sum(self):
        """pyopencl ReductionKernel: the summed surface area of boxes (lo[i], hi[i]) (float4)."""
        def make():
            from pyopencl.reduction import ReductionKernel
            return ReductionKernel(
                self.context, np.float32, neutral="0", reduce_expr="a+b",
                map_expr="box_area(lo[i], hi[i])", arguments="__global const float4 *lo, "
                "__global const float4 *hi",
                preamble="float box_area(float4 a, float4 b) { float4 d = fmax(b - a, 0.0f); "
                         "return 2.0f * (d.x * d.y + d.y * d.z + d.z * d.x); }")
        return self._algorithm("box area sum", make)

    def exclusive_scan_uint(self):
        """pyopencl ExclusiveScanKernel over uint (compaction positions)."""
        def make():
            from pyopencl.scan import ExclusiveScanKernel
            return ExclusiveScanKernel(self.context, np.uint32, "a+b", "0")
        return self._algorithm("exclusive scan", make)

    def radix_sort_uint_pairs(self):
        """pyopencl's RadixSort of (uint key, uint value) pairs."""
        def make():
            from pyopencl.algorithm import RadixSort
            return RadixSort(self.context, "uint *keys, uint *values", key_expr="keys[i]",
                             sort_arg_names=["keys", "values"], key_dtype=np.uint32)
        return self._algorithm("radix sort", make)
