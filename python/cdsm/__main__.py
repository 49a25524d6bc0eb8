"""``python -m cdsm``: the command line (see :mod:`cdsm.cli`)."""

import sys

from .cli import main

sys.exit(main())
