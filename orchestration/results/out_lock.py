"""One writer per results directory: a lock file with its owner, so that a second ``run`` or
``batch`` onto a directory in use is refused naming the other one instead of overwriting it.

``batch`` locks its ``--out``; ``run`` (also a batch's child) locks the run's own directory
``OUT/<scenario>/`` (``OUT/<sweep>/<variant>/``): two batches onto one ``--out``, or two runs of
one scenario onto one ``--out``, cannot overlap.  The lock file ``.satmotor-lock`` holds
:func:`orchestration.results.atomic.owner` (pid, host, the pid's start) and the command line; it
is created with ``O_EXCL`` and removed on release.  A lock whose process is gone (a killed run:
:func:`~orchestration.results.atomic.writer_alive` is False) is stale and taken over, said on
standard error; one of another host is respected (nothing here can tell whether it still runs).
"""

from __future__ import annotations

import json
import os
import sys
from contextlib import contextmanager
from pathlib import Path

from orchestration.results.atomic import owner, writer_alive

LOCK_NAME = ".satmotor-lock"


class OutInUse(RuntimeError):
    """The directory is being written by another live process; the message names it."""


def _describe(held):
    return (f"{held.get('command', 'another run')} (process {held.get('pid')} on {held.get('host')}, started "
            f"{held.get('started', '?')})")


def _create(path, record):
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        json.dump(record, f)


def acquire(directory, command, stream=None):
    """Lock ``directory`` (made if missing) for this process; returns the lock file's path.  Raises
    :class:`OutInUse` when a live process holds it, ``OSError`` when it cannot be written."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / LOCK_NAME
    record = {**owner(), "command": command}
    for _ in range(3):  # a lock released or taken over between our two looks: try again
        try:
            _create(path, record)
            return path
        except FileExistsError:
            pass
        try:
            held = json.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            continue
        except (OSError, ValueError):
            held = {}
        if not isinstance(held, dict):
            held = {}
        alive = writer_alive(held) if held else False  # an unreadable lock: its writer died writing it
        if alive is not False:
            raise OutInUse(f"{directory} is in use by {_describe(held)}: its lock file {path}; wait for it "
                           "to end or choose another --out (remove the lock file if that process is "
                           "not writing there)")
        print(f"{path}: a stale lock of {_describe(held)}, which has ended: taken over",
              file=stream or sys.stderr)
        try:
            path.unlink()
        except FileNotFoundError:
            pass
    raise OutInUse(f"{directory}: its lock file {path} keeps changing: another run is starting there")


def release(path):
    """Remove the lock file ``path`` if it is still this process's."""
    try:
        held = json.loads(Path(path).read_text(encoding="utf-8"))
        if held.get("pid") == os.getpid():
            Path(path).unlink()
    except (OSError, ValueError, AttributeError):
        pass


@contextmanager
def locked(directory, command, stream=None):
    """:func:`acquire` for the block, :func:`release` after it."""
    path = acquire(directory, command, stream)
    try:
        yield path
    finally:
        release(path)
