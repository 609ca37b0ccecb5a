"""``python -m wdendrite``: the same as the ``wdendrite`` command."""

import sys

from .cli import main

sys.exit(main())
