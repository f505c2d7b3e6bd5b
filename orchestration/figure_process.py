"""The ``run`` command's figure, drawn by a forked helper while the run steps and its files are written.

Importing matplotlib costs about 0.3 s and drawing the figure about 0.2 s; writing the last chunk
of the time series (CSV and Parquet) about 0.25 s for 15 001 rows.  :class:`FigureProcess` forks a
helper (multiprocessing's ``fork`` context) before the run starts; the helper imports
:mod:`orchestration.plots` and makes the empty canvas while the parent loads the FMUs and steps, on
another core.  As the recorder's tee (:attr:`orchestration.recorder.StreamingRecorder.tee`) it
keeps each recorded chunk; when the run ends it sends them (float64 arrays, pickled through a
pipe) *before* the last chunk's files are written, so the helper draws while the parent writes.
The helper draws exactly what :func:`orchestration.plots.figure` draws in the parent, the same code
on the same values (the Parquet file holds the same float64 values): the PNG is byte for byte the
same.  If anything about the helper fails (it was killed, the pipe broke, the figure raised), the
parent draws the figure itself, so the result and any error are those of the plain path.

The recorded chunks are kept until the end (the parent reads the whole record back for the
metrics then anyway).  Nothing is left behind: the helper ignores SIGINT (a Ctrl-C reaches the
whole process group; the parent decides, and it still wants the figure of a partial run), gets
SIGKILL from Linux when the parent dies (``PR_SET_PDEATHSIG``), and :meth:`FigureProcess.close`,
called in a ``finally`` by the parent, waits for a figure being drawn and kills the helper in every
other case (before it has been sent data, it holds nothing but its imports).
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import threading

import numpy as np

from .interrupts import WATCHER


def wanted():
    """Whether a helper can be forked here: ``fork`` available, and no other Python thread than the
    watchers of :func:`orchestration.interrupts.die_with` (blocked in ``select``, holding no lock;
    forking a process whose other threads may hold locks is unsafe).  In a warm batch child,
    matplotlib is imported already: the helper then only draws while the files are written."""
    others = [t for t in threading.enumerate() if t is not threading.current_thread()]
    return ("fork" in multiprocessing.get_all_start_methods()
            and all(t.name.startswith(WATCHER) for t in others))


def _helper(conn, parent, path, title):
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # not the parent's stop request
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL), 0, 0, 0)  # 1: PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass
    if os.getppid() != parent:  # the parent died before prctl took effect
        return
    from setproctitle import setproctitle

    setproctitle(f"satmotor figure helper of process {parent}: {path}")  # not its parent's command line
    from .plots import canvas, figure

    blank = canvas()
    try:
        data = conn.recv()
    except EOFError:  # the parent needs no figure
        return
    try:
        figure(data, path, title, blank)
        answer = "ok"
    except Exception as exc:  # noqa: BLE001 - the parent draws it again and gets the error itself
        answer = repr(exc)
    try:
        conn.send(answer)
    except OSError:  # the parent no longer listens
        pass


class FigureProcess:
    """A helper process that draws one figure, to ``path`` with ``title``: the tee of the run's
    recorder, then :meth:`draw` (``write_results``' ``draw``), then :meth:`close`."""

    def __init__(self, path, title):
        self.path, self.title = str(path), title
        ctx = multiprocessing.get_context("fork")
        self._conn, child_end = ctx.Pipe()
        self._proc = ctx.Process(target=_helper, args=(child_end, os.getpid(), self.path, title), daemon=True,
                                 name="satmotor-figure")
        self._proc.start()
        child_end.close()
        self._chunks = []
        self._sent = False
        self.drawn_by_helper = False  #: after draw(): whether the helper drew the figure

    def chunk(self, a):
        """A recorded chunk (rows x recorded columns), kept for the figure."""
        self._chunks.append(a)

    def done(self, columns, rows):
        """The run has ended with ``rows`` rows: send them, unless there is no figure to draw."""
        chunks, self._chunks = self._chunks, []
        if rows < 2 or self._proc is None:  # write_results draws no figure of fewer than 2 rows
            return
        a = np.concatenate(chunks) if len(chunks) > 1 else chunks[0]
        try:
            self._conn.send({c: a[:, i] for i, c in enumerate(columns)})
            self._sent = True
        except OSError:  # the helper is gone: draw() draws here
            pass

    def draw(self, data, path, title):
        """Write the figure: the helper's, if it was sent this run's record for ``path`` and
        ``title``, else drawn here from ``data`` (:func:`orchestration.plots.figure`)."""
        ok = False
        if self._sent and (str(path), title) == (self.path, self.title):
            try:
                ok = self._conn.recv() == "ok"
            except (OSError, EOFError):  # the helper died
                ok = False
        self.drawn_by_helper = ok
        self.close()
        if not ok:
            from .plots import figure

            figure(data, path, title)

    def close(self):
        """End the helper: it finishes a figure it was sent (a whole PNG, never a cut one), it is
        killed otherwise."""
        if self._proc is None:
            return
        self._conn.close()
        if not self._sent:
            self._proc.kill()
        self._proc.join()
        self._proc.close()
        self._proc = None
