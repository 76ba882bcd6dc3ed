"""``python -m hvacfmu``: the ``hvacfmu`` command."""

import sys

from .cli import main

sys.exit(main())
