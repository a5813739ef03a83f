"""``python -m ppm_engine``: see ppm_engine/cli.py."""
import sys

from .cli import main

sys.exit(main())
