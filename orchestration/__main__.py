"""``python -m orchestration``: see :mod:`orchestration.cli`."""

from .clean_exit import exit_now
from .cli import main

exit_now(main())
