"""Warm children for ``batch``: each scenario runs ``python -m orchestration run ...`` in its own
process, forked from a server that has imported the run path once.

A fresh interpreter per scenario spends about 0.5 s importing numpy, fmpy, pyarrow and matplotlib
before its first step.  Here the batch starts one :mod:`multiprocessing` forkserver that imports
:data:`PRELOAD` once; each scenario is a new process forked from it (never a reused one: pythonfmu
FMUs run their Python inside the host process, so two scenarios never share one).  The forkserver
never instantiates an FMU.

A child behaves as the ``run`` command does in a process of its own: it executes
:func:`orchestration.cli.commands.main` with the same arguments, ends with :func:`~.clean_exit.exit_now`,
shows that command line in ``ps`` (``setproctitle``), writes its standard output and error to files
that the batch reads for the row, and extracts its FMUs under the batch's temporary directory.
Its parent is the forkserver, not the batch, so it watches the batch itself
(:func:`orchestration.process.interrupts.die_with`): a batch that dies, even by SIGKILL, gets its children
SIGTERM (they write their partial results and exit), and then the forkserver, left without
clients, exits too.  :func:`stop_server` ends the forkserver (and multiprocessing's resource
tracker) when the batch is done, so nothing outlives the batch's own exit.
"""

from __future__ import annotations

import multiprocessing
import os
import sys
import tempfile
import threading
import time
import traceback
from multiprocessing.connection import wait

from orchestration.process.interrupts import pid_exists
from orchestration.process.title import set_title

#: what a ``run`` child imports (the pythonfmu glue and FMU binaries are not among them: every
#: child loads its own FMUs)
PRELOAD = ("orchestration.cli", "orchestration.run.master", "orchestration.results.writer",
           "orchestration.scenario.load", "orchestration.results.recorder", "orchestration.run.fmu_instance",
           "orchestration.run.c_engine", "orchestration.process.interrupts", "orchestration.results.plots",
           "pyarrow.parquet", "fmpy.fmi2",
           "fmpy.fmi3", "pythonfmu", "satmotor.control.drive", "satmotor.machine.plant", "satmotor.metrics",
           "setproctitle")

# multiprocessing's Popen of a forkserver child reads the exit status from a pipe once: two threads
# that poll the same child at the same moment (Process.start polls every child) could both read
# it, and one would see 255.  Every start and every status read goes through this lock.
_LOCK = threading.Lock()


def available():
    """Whether this system has the forkserver start method (Linux and the other POSIX systems)."""
    return "forkserver" in multiprocessing.get_all_start_methods()


def preload(plot=True, pythonfmu=True):
    """:data:`PRELOAD` without what a batch will not use: the figure's matplotlib (``plot`` False),
    pythonfmu (``pythonfmu`` False: the native FMUs); 0.35 s less CPU per batch when both go."""
    drop = {*(() if plot else ("orchestration.results.plots",)), *(() if pythonfmu else ("pythonfmu",))}
    return tuple(m for m in PRELOAD if m not in drop)


def _context(modules=PRELOAD):
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload(list(modules))  # read once, when the server starts
    return ctx


def _child(main, argv, stdout_path, stderr_path, batch_pid, tmpdir):
    """The body of a forked child: the command-line entry point ``main`` with ``argv``; never returns."""
    from orchestration.process.clean_exit import exit_now
    from orchestration.process.interrupts import die_with

    for fd, path in ((1, stdout_path), (2, stderr_path)):
        f = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        os.dup2(f, fd)
        os.close(f)
    set_title(" ".join([sys.executable, "-m", "orchestration", *argv]))
    if tmpdir:  # where the FMUs are extracted, as TMPDIR does for a fresh process
        os.environ["TMPDIR"] = str(tmpdir)
        tempfile.tempdir = None
    die_with(batch_pid)
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse refusing an argument, as in a process of its own
        code = exc.code
    except BaseException:  # noqa: BLE001 - printed as an uncaught exception would be, then exit 1
        traceback.print_exc()
        code = 1
    exit_now(code)


def _running(pid):
    """Whether process ``pid`` exists and is no zombie (an orphan whose new parent never reaps it)."""
    if not pid_exists(pid):
        return False
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rpartition(")")[2].split()[0] != "Z"
    except (OSError, IndexError):
        return True  # no /proc: pid_exists said it exists


class WarmChild:
    """One ``run`` child forked from the warm server; the interface ``batch.run_one`` drives.
    ``modules``: what the server imports when this child starts it (:func:`preload`)."""

    def __init__(self, main, argv, workdir, tmpdir=None, modules=PRELOAD):
        fd, self._out = tempfile.mkstemp(prefix="child-", suffix=".out", dir=workdir)
        os.close(fd)
        self._err = self._out[:-4] + ".err"
        args = (main, list(argv), self._out, self._err, os.getpid(), tmpdir and str(tmpdir))
        self._proc = _context(modules).Process(target=_child, args=args, daemon=False)
        with _LOCK:
            self._proc.start()
        self.pid = self._proc.pid
        self._returncode = None

    def wait(self, timeout):
        """True once the child has ended (within ``timeout`` seconds; None: however long it takes).
        A signal to the batch's process group may end the forkserver while the child still writes
        its partial results: the sentinel then fires at once (and the exit code is lost, 255), so
        the child's own pid is waited for too."""
        t_end = None if timeout is None else time.monotonic() + timeout
        if not wait([self._proc.sentinel], timeout):
            return False
        while _running(self.pid):  # the server is gone, the child (now init's) still runs
            if t_end is not None and time.monotonic() >= t_end:
                return False
            time.sleep(0.02)
        with _LOCK:
            return self._proc.exitcode is not None

    @property
    def returncode(self):
        """The exit code (negative: the signal that ended the child), None while it runs."""
        if self._returncode is None:
            with _LOCK:
                self._returncode = self._proc.exitcode
        return self._returncode

    def terminate(self):
        self._proc.terminate()

    def kill(self):
        self._proc.kill()

    def output(self):
        """(standard output, standard error) of the ended child; the files are removed."""
        self.returncode  # noqa: B018 - read before the process object is closed
        texts = []
        for path in (self._out, self._err):
            try:
                with open(path, errors="replace") as f:
                    texts.append(f.read())
                os.unlink(path)
            except OSError:
                texts.append("")
        self._proc.close()
        return tuple(texts)


def stop_server():
    """End the forkserver and multiprocessing's resource tracker now (they would end by themselves
    once the batch exits, a moment later).  Uses their private ``_stop`` methods (CPython's own tests
    stop them so; looked up, not assumed: without them the two end with the batch)."""
    from multiprocessing import forkserver, resource_tracker

    for server in (forkserver._forkserver, resource_tracker._resource_tracker):
        stop = getattr(server, "_stop", None)
        if stop is not None:
            try:
                stop()
            except OSError:  # already gone
                pass
