"""A process's name in ``ps``: the helpers of ``run`` and ``batch`` show what they are."""

from __future__ import annotations


def set_title(text):
    """Show ``text`` as this process's command line in ``ps`` (``setproctitle``; nothing without it)."""
    try:
        from setproctitle import setproctitle
    except ImportError:  # a dependency, but only cosmetic
        return
    setproctitle(text)
