"""Result files written whole or not at all, and a status that says who is writing them.

Every file ``run`` and ``batch`` leave is written to a temporary name in its own directory
(``.NAME.<random>.part``: hidden, never taken for a result) and renamed onto ``NAME`` when it is
complete (:func:`atomic_file`, :func:`write_text`; ``os.replace`` is atomic on one filesystem).  A
write that fails (a full disk, a quota, a read-only mount) removes its temporary file and leaves
any previous ``NAME`` as it was.  A process killed while writing leaves at most a ``.part`` file:
:func:`remove_partial` clears them, :data:`PARTIAL_GLOB` finds them.

A run's ``metrics.json`` says ``running`` while the run goes, together with :func:`owner`: the pid,
the host and the pid's start time (Linux: from ``/proc``, so that a pid reused by another process is
not taken for the writer).  :func:`writer_alive` tells a later reader whether that process still
runs; :func:`stale_reason` turns a ``running`` status whose writer is gone into the one line to
show.  :func:`describe` is the one line of an ``OSError`` (``no space left on device``).
"""

from __future__ import annotations

import errno
import json
import os
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

from orchestration.process.interrupts import pid_exists

PARTIAL_SUFFIX = ".part"
PARTIAL_GLOB = ".*" + PARTIAL_SUFFIX

#: the words of the errors a results directory meets (the rest: the system's own text, lower case)
_WORDS = {errno.ENOSPC: "no space left on device", errno.EDQUOT: "disk quota exceeded",
          errno.EROFS: "read-only file system", errno.EACCES: "permission denied",
          errno.EFBIG: "file too large", errno.EIO: "input/output error"}


def _hostname():
    """This machine's name (``gethostname``: on POSIX the kernel's node name, without importing socket)."""
    if hasattr(os, "uname"):
        return os.uname().nodename
    import socket

    return socket.gethostname()


def describe(exc, path=None):
    """``"no space left on device writing PATH"``: the one line of an ``OSError`` (its path, or
    ``path``, named when known), without the ``[Errno N]`` noise."""
    words = _WORDS.get(getattr(exc, "errno", None)) or (getattr(exc, "strerror", None) or str(exc)).lower()
    where = path or getattr(exc, "filename", None)
    return f"{words} writing {where}" if where else words


def _umask():
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


_MODE = 0o666 & ~_umask()  # what open() would give a new file (mkstemp gives 0o600)


def _temporary(path):
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=PARTIAL_SUFFIX, dir=path.parent)
    try:
        os.fchmod(fd, _MODE)
    except OSError:
        pass
    return fd, Path(tmp)


def partial_path(path):
    """A new empty temporary file beside ``path`` (``.NAME.<random>.part``), for a writer that
    renames it onto ``path`` itself when complete (e.g. a file written as a run goes)."""
    fd, tmp = _temporary(path)
    os.close(fd)
    return tmp


def discard(path):
    """Remove ``path`` if it is there (a temporary file given up)."""
    _unlink(path)


@contextmanager
def atomic_file(path, mode="w", **open_args):
    """An open file object (``mode``: ``"w"`` or ``"wb"``) of a temporary name beside ``path``;
    closed and renamed onto ``path`` when the block ends without an exception, closed and removed
    otherwise (the exception goes on).  A failing ``close`` (the last buffer not fitting on the
    disk) counts as a failure."""
    if mode not in ("w", "wb"):
        raise ValueError(f"mode = {mode!r}: must be 'w' or 'wb'")
    fd, tmp = _temporary(path)
    try:
        f = os.fdopen(fd, mode, **open_args)
    except BaseException:
        os.close(fd)
        _unlink(tmp)
        raise
    try:
        with f:
            yield f
        os.replace(tmp, path)
    except BaseException:
        _unlink(tmp)
        raise


def write_text(path, text):
    """``path`` holds ``text`` whole, or is as it was (OSError raised)."""
    with atomic_file(path, "w", newline="") as f:
        f.write(text)


def write_json(path, obj):
    """``obj`` as indented JSON, written by :func:`write_text`."""
    write_text(path, json.dumps(obj, indent=2, default=float) + "\n")


def _unlink(path):
    try:
        os.unlink(path)
    except OSError:
        pass


def remove_partial(directory):
    """Remove the ``.part`` files a killed writer left in ``directory``; returns their names."""
    removed = []
    try:
        leftovers = sorted(Path(directory).glob(PARTIAL_GLOB))
    except OSError:
        return removed
    for p in leftovers:
        _unlink(p)
        removed.append(p.name)
    return removed


def _start_ticks(pid):
    """The start time of process ``pid`` in clock ticks since boot (``/proc/PID/stat`` field 22),
    None where there is no ``/proc`` or no such process."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            stat = f.read().decode(errors="replace")
    except OSError:
        return None
    # the command name (field 2) is in parentheses and may hold spaces: fields after its last ')'
    fields = stat[stat.rfind(")") + 2:].split()
    try:
        return int(fields[19])
    except (IndexError, ValueError):
        return None


def owner(pid=None):
    """``{"pid", "host", "pid_start", "started"}`` of this process (or ``pid``): who writes a
    ``running`` status, and since when (``started``: UTC, ISO 8601)."""
    pid = os.getpid() if pid is None else pid
    return {"pid": pid, "host": _hostname(), "pid_start": _start_ticks(pid),
            "started": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}


def writer_alive(status):
    """True when the process named by ``status`` (a dict with :func:`owner`'s keys) still runs,
    False when it is gone, None when this cannot be told (another host, no pid recorded)."""
    pid = status.get("pid")
    if not isinstance(pid, int) or status.get("host") != _hostname():
        return None
    ticks = _start_ticks(pid)
    if ticks is not None:  # a process of that pid runs: the writer if it started when the writer did
        return status.get("pid_start") in (None, ticks)
    if Path("/proc/self/stat").exists():  # /proc works and has no such process
        return False
    return pid_exists(pid)


def stale_reason(status):
    """For a ``running`` status whose writer is gone: the line saying so; else None."""
    if status.get("status") != "running" or writer_alive(status) is not False:
        return None
    return (f"the process {status.get('pid')} that ran it (started {status.get('started', '?')}) "
            "ended without writing its results")


def settle_abandoned(path, status, message):
    """A JSON status file ``path`` (a run's ``metrics.json``) left ``running`` by a process that is
    gone gets ``status`` and ``message`` (the pid and start it recorded stay), written whole, and
    the ``.part`` files beside it are removed.  Returns the dict written, or None when there was
    nothing to settle (no such file, not ``running``, its writer still alive) or it could not be
    written (the ``running`` status stays: :func:`stale_reason` still tells it)."""
    path = Path(path)
    try:
        old = json.loads(path.read_text())
    except (OSError, ValueError):
        old = None
    if not isinstance(old, dict) or old.get("status") != "running" or writer_alive(old) is True:
        return None
    remove_partial(path.parent)
    new = {**old, "status": status, "message": message}
    try:
        write_json(path, new)
    except OSError:
        return None
    return new


def being_written(directory, name):
    """The file ``name`` of ``directory`` as it is now: the ``.part`` file of a writer at work (the
    newest, when several), else ``directory/name`` itself (complete, or not there)."""
    parts = sorted(Path(directory).glob(f".{name}.*{PARTIAL_SUFFIX}"), key=_mtime)
    return parts[-1] if parts else Path(directory) / name


def _mtime(path):
    try:
        return path.stat().st_mtime
    except OSError:
        return 0.0
