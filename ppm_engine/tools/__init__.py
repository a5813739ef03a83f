"""Tooling around the engine: the command line (``cli``), the benchmark (``bench/``), the
extension packager (``packaging``) and the generator of the kernels' shared header
(``shared_header``).  Not needed to render inside Blender: the extension zip leaves out
``bench/`` and ``packaging``."""
