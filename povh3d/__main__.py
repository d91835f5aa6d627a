"""``python -m povh3d``: the ``povh3d`` command, for an environment whose scripts folder is not on PATH."""

import sys

from .cli.main import main

sys.exit(main())
