"""The libcosim engine's execution with the RowRecorder FMU (:mod:`orchestration.run.row_recorder`):
no libcosim observer, no value read per variable; libcosim's own transfers hand the recorded outputs
to the recorder, which writes them as binary rows; each chunk's rows are read in one call and made
into the master's rows.  Used by :func:`orchestration.run.libcosim_engine.run` (every record level;
``record: metrics`` records only the columns the metrics read).

Measured on the default scenario with ``record: metrics`` (``bench/bench_engines.py``,
``bench/RESULTS.md``, section engines): the recorder adds about 1 us per step to libcosim's
stepping, and the whole run takes 7.2 us per step of CPU, against 16.7 with the observers recording
every output."""

from __future__ import annotations

from orchestration.process.interrupts import signal_name
from orchestration.run import row_recorder
from orchestration.run.libcosim_readers import Lib

__all__ = ["RowsExecution"]


class RowsExecution:
    """One libcosim execution of the system ``structure`` (with the recorder, writing ``rows_file``,
    recording ``sources``: :func:`orchestration.run.row_recorder.columns_for`), stepped in chunks of
    ``chunk`` base steps (a multiple of the controller's ``N``)."""

    def __init__(self, sc, structure, sources, rows_file, chunk):
        from libcosimpy.CosimExecution import CosimExecution

        self.sc, self.lib, self.h = sc, Lib(), sc.step
        self.chunk = chunk
        self.steps = row_recorder.steps_needed(sc)
        try:
            self.ex = CosimExecution.from_ssp_file(str(structure))
        except AssertionError as exc:
            raise RuntimeError(str(exc)) from None
        self.rows = row_recorder.Rows(rows_file, sc, sources)

    def simulate(self, rec, stop, units):
        """Step to the end, recording every row; returns (status, message, t_end, failed unit).
        ``units``: the component names, to find the failing one in libcosim's error."""
        h, reached = self.h, 0
        n = round(self.sc.stop_time / h)
        while reached < self.steps:
            if stop.signum:
                return "interrupted", f"stopped by {signal_name(stop.signum)} at t = {reached * h:.6g} s", \
                    reached * h, ""
            target = min(reached + self.chunk, self.steps)
            if not self.ex.step(target - reached):
                text = self.lib.error().strip()
                self._take(rec)
                now = min(n, self.ex.status().current_time // round(h * row_recorder.NS))
                unit = next((u for u in units if f"{u}: " in text), "")
                kind = "discard" if "Step not complete" in text else "error"
                return kind, f"{unit or 'libcosim'}: libcosim: {text}", now * h, unit
            reached = target
            self._take(rec)
        return "ok", "", n * h, ""

    def _take(self, rec):
        rec.append_rows(self.rows.table())

    def close(self):
        self.ex = None  # libcosim's execution freed here (refcount): the FMUs are freed
