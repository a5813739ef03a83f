"""Errors a user can act on.  Every message says what is wrong and what to do about it."""


class PPMError(Exception):
    """Base class: the CLI prints it to stderr and exits non-zero; the engine reports it."""


class SceneError(PPMError):
    """The scene cannot be rendered as it is (no camera, nothing to render, bad data)."""


class DeviceError(PPMError):
    """No usable OpenCL device, or a buffer does not fit on the chosen device."""


class KernelBuildError(DeviceError):
    """An OpenCL program failed to build; the message carries the compiler log."""


class UsageError(PPMError):
    """A command was given arguments it cannot use (the CLI exits with 2)."""
