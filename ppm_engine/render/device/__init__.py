"""OpenCL devices: discovery, one context/queue per device (reused), programs built once,
kernels launched with arguments bound by name."""
from ppm_engine.render.device.context import Device, DeviceInfo, get_device, list_devices
from ppm_engine.render.device.program import SHADING_GROUP, Launch, global_size, kernel_dir

__all__ = [
           "SHADING_GROUP",
           "Device",
           "DeviceInfo",
           "Launch",
           "get_device",
           "global_size",
           "kernel_dir",
           "list_devices",
]
