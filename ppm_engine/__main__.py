"""``python -m ppm_engine``: see ppm_engine/tools/cli.py."""
import sys

from ppm_engine.tools.cli import main

sys.exit(main())
