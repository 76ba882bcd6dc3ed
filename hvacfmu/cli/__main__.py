"""``python -m hvacfmu.cli``: the ``hvacfmu`` command."""

import sys

from .commands import main

sys.exit(main())
