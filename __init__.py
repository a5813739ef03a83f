from .ppm_engine import register, unregister  # noqa: F401
