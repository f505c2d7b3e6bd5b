"""Ctrl-C, SIGTERM and SIGHUP for the long-running commands: a stop request instead of an exception.

Inside :func:`catch`, SIGINT, SIGTERM and SIGHUP (a closed terminal, where the system has it) only set
``stop.signum``; the stepping loop and the batch
look at it and wind down, writing what they have.  No exception is raised in the middle of an FMU
call (a pythonfmu FMU runs its Python in this interpreter: a KeyboardInterrupt there would turn
into an FMI fatal).  A second signal of the same kind while winding down is ignored; the exit
code of an interrupted command is ``128 + signum`` (130 for Ctrl-C, 143 for SIGTERM, 129 for SIGHUP).
"""

from __future__ import annotations

import os
import select
import signal
import threading
import time
from contextlib import contextmanager

SIGNALS = (signal.SIGINT, signal.SIGTERM, *((signal.SIGHUP,) if hasattr(signal, "SIGHUP") else ()))
PARENT_ENV = "SATMOTOR_PARENT_PID"  # set by batch for its children: see die_with_parent
WATCHER = "satmotor-die-with-"  # the name of die_with's threads (they start with it)


def signal_name(signum):
    """``"SIGTERM"`` for 15, ``"signal 99"`` for a number that names no signal."""
    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"signal {signum}"


class StopRequest:
    """``signum``: 0, or the first signal received; ``event`` is set when one arrives."""

    def __init__(self):
        self.signum = 0
        self.event = threading.Event()

    def request(self, signum):
        if not self.signum:
            self.signum = int(signum)
        self.event.set()

    @property
    def exit_code(self):
        return 128 + self.signum if self.signum else 0


@contextmanager
def catch(stop=None):
    """Within the block, SIGINT/SIGTERM/SIGHUP set ``stop.signum`` (a new :class:`StopRequest` if None).
    A signal this process inherited as ignored (e.g. SIGINT of a job started with ``&`` by a
    non-interactive shell, or under ``nohup``) stays ignored, as Python itself does.  Only the
    main thread can install handlers; elsewhere the block runs with the handlers as they are."""
    stop = stop or StopRequest()
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return
    previous = {s: signal.getsignal(s) for s in SIGNALS if signal.getsignal(s) is not signal.SIG_IGN}
    for s in previous:
        signal.signal(s, lambda signum, frame: stop.request(signum))
    try:
        yield stop
    finally:
        for s, h in previous.items():
            signal.signal(s, h)


def die_with_parent():
    """In a child started by ``batch`` (``SATMOTOR_PARENT_PID`` set): ask Linux to send SIGTERM
    to this process when its parent dies, so that even a killed batch leaves no child running.
    Elsewhere (other systems, or not a batch child) this does nothing."""
    parent = os.environ.get(PARENT_ENV)
    if not parent or not hasattr(os, "getppid"):
        return
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        PR_SET_PDEATHSIG = 1
        libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0)
    except (OSError, AttributeError):
        return
    if str(os.getppid()) != parent:  # the parent died before prctl took effect
        os.kill(os.getpid(), signal.SIGTERM)


def die_with(pid):
    """SIGTERM to this process when process ``pid`` (not necessarily its parent) ends: a daemon
    thread waits on a pidfd of ``pid`` (Linux 5.3+), or, where there is none, looks every second
    whether it still exists.  If ``pid`` is gone already, SIGTERM is sent at once."""

    def terminate():
        os.kill(os.getpid(), signal.SIGTERM)

    try:
        fd = os.pidfd_open(pid)
    except ProcessLookupError:
        terminate()
        return
    except (AttributeError, OSError):
        fd = None

    def watch():
        if fd is not None:
            select.select([fd], [], [])
        else:
            while pid_exists(pid):
                time.sleep(1.0)
        terminate()

    threading.Thread(target=watch, name=f"{WATCHER}{pid}", daemon=True).start()


def pid_exists(pid):
    """Whether a process ``pid`` exists (one we may not signal counts as existing)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True
