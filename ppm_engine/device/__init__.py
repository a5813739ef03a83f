"""OpenCL devices: discovery, one context/queue per device (reused), programs built once."""
from .context import Device, DeviceInfo, get_device, list_devices
from .program import KERNEL_DIR

__all__ = ["Device", "DeviceInfo", "get_device", "list_devices", "KERNEL_DIR"]
