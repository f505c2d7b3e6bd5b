"""``python -m orchestration``: see :mod:`orchestration.cli.commands`."""

from orchestration.cli import main
from orchestration.process.clean_exit import exit_now

exit_now(main())
