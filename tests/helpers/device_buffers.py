"""Every OpenCL device this machine has, and host <-> device copies, for the kernel tests
(test_kernels*.py): each kernel runs on every device found, GPUs included."""
import numpy as np
import pytest

pytest.importorskip("pyopencl")
import pyopencl as cl

from ppm_engine.render.device import list_devices

DEVICES = [d.key for d in list_devices()]


def upload(dev, a):
    return cl.Buffer(dev.context, cl.mem_flags.READ_WRITE | cl.mem_flags.COPY_HOST_PTR,
                     hostbuf=np.ascontiguousarray(a))


def read(dev, buf, shape, dtype):
    out = np.empty(shape, dtype)
    cl.enqueue_copy(dev.queue, out, buf)
    return out
