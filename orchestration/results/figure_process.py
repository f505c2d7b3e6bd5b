"""The ``run`` command's figure, drawn by a forked helper while the run steps and its CSV is written.

Importing matplotlib costs about 0.3 s and drawing the figure about 0.25 s; writing the last chunk
of the time series to CSV about 0.2 s for 15 001 rows.  :class:`FigureProcess` forks a helper
(multiprocessing's ``fork`` context) before the run starts; the helper imports
:mod:`orchestration.results.plots` and makes the empty canvas while the parent loads the FMUs and steps, on
another core (a warm batch child has matplotlib imported already: its helper only draws).  When
the run ends, the recorder completes the Parquet file first and tells the helper
(:attr:`orchestration.results.recorder.StreamingRecorder.on_parquet`); the helper reads it and draws while
the parent writes the last CSV lines.  It draws exactly what :func:`orchestration.results.plots.figure`
draws in the parent from the same rows (the same code on the same float64 values): the PNG is byte
for byte the same.  A long run's figure shows every k-th row
(:func:`orchestration.results.running.figure_step`): the helper reads the file one row group at a
time and keeps those rows only, so its memory does not grow with the run either.  If anything
about the helper fails (it was killed, the pipe broke, the figure raised), the parent draws the
figure itself, so the result and any error are those of the plain path.

Nothing is left behind: the helper ignores SIGINT (a Ctrl-C reaches the whole process group; the
parent decides, and it still wants the figure of a partial run), gets SIGKILL from Linux when the
parent dies (``PR_SET_PDEATHSIG``), and :meth:`FigureProcess.close`, called in a ``finally`` by the
parent, waits for a figure being drawn (a whole PNG, never a cut one) and kills the helper in every
other case (before it has been told to draw, it holds nothing but its imports).
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import threading

from orchestration.process.interrupts import WATCHER
from orchestration.process.title import set_title
from orchestration.results.recorder import read_every


def wanted():
    """Whether a helper can be forked here: ``fork`` available, and no other Python thread than the
    watchers of :func:`orchestration.process.interrupts.die_with` (blocked in ``select``, holding no lock;
    forking a process whose other threads may hold locks is unsafe).  In a warm batch child,
    matplotlib is imported already: the helper then only draws while the files are written."""
    others = [t for t in threading.enumerate() if t is not threading.current_thread()]
    return ("fork" in multiprocessing.get_all_start_methods()
            and all(t.name.startswith(WATCHER) for t in others))


def _helper(conn, parent, parquet, path, title, step=1):
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # not the parent's stop request
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL), 0, 0, 0)  # 1: PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass
    if os.getppid() != parent:  # the parent died before prctl took effect
        return
    set_title(f"satmotor figure helper of process {parent}: {path}")  # not its parent's command line
    from orchestration.results.plots import canvas, figure

    blank = canvas()
    try:
        conn.recv()
    except EOFError:  # the parent needs no figure
        return
    try:
        figure(read_every(parquet, step), path, title, blank)
        answer = "ok"
    except Exception as exc:  # noqa: BLE001 - the parent draws it again and gets the error itself
        answer = repr(exc)
    try:
        conn.send(answer)
    except OSError:  # the parent no longer listens
        pass


class FigureProcess:
    """A helper process that draws one figure, of every ``step``-th row of the record in the
    Parquet file ``parquet``, to ``path`` with ``title``: :meth:`parquet_done` (the recorder's
    ``on_parquet``), then :meth:`draw` (``write_results``' ``draw``), then :meth:`close`.  Raises
    OSError if it cannot fork."""

    def __init__(self, parquet, path, title, step=1):
        import pyarrow.parquet  # noqa: F401 - imported once, before the fork: the helper reads the file

        self.path, self.title = str(path), title
        self._parquet, self._step = str(parquet), step
        ctx = multiprocessing.get_context("fork")
        self._conn, child_end = ctx.Pipe()
        args = (child_end, os.getpid(), str(parquet), self.path, title, step)
        self._proc = ctx.Process(target=_helper, args=args, daemon=True, name="satmotor-figure")
        self._proc.start()
        child_end.close()
        self._sent = False
        self.drawn_by_helper = False  #: after draw(): whether the helper drew the figure

    def parquet_done(self, rows):
        """The Parquet file is complete with ``rows`` rows: the helper draws, if there is a figure."""
        if rows < 2 or self._proc is None:  # write_results draws no figure of fewer than 2 rows
            return
        try:
            self._conn.send("draw")
            self._sent = True
        except OSError:  # the helper is gone: draw() draws here
            pass

    def draw(self, data, path, title):
        """Write the figure: the helper's, if it was told to draw it for ``path`` and ``title``,
        else drawn here from ``data`` (:func:`orchestration.results.plots.figure`; None: the rows
        the helper would have read, read here)."""
        ok = False
        if self._sent and (str(path), title) == (self.path, self.title):
            try:
                ok = self._conn.recv() == "ok"
            except (OSError, EOFError):  # the helper died
                ok = False
        self.drawn_by_helper = ok
        self.close()
        if not ok:
            from orchestration.results.plots import figure

            figure(read_every(self._parquet, self._step) if data is None else data, path, title)

    def discard(self):
        """End the helper without a figure (the time series it was drawing were not kept): killed,
        and whatever it wrote removed (:mod:`orchestration.results.atomic`)."""
        from pathlib import Path

        from orchestration.results import atomic

        self._sent = False
        self.close()
        atomic.discard(self.path)
        atomic.remove_partial(Path(self.path).parent)

    def close(self):
        """End the helper: it finishes a figure it was told to draw, it is killed otherwise."""
        if self._proc is None:
            return
        self._conn.close()
        if not self._sent:
            self._proc.kill()
        self._proc.join()
        self._proc.close()
        self._proc = None
