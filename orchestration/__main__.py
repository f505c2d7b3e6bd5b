"""``python -m orchestration``: see :mod:`orchestration.cli`."""

import sys

from .cli import main

sys.exit(main())
