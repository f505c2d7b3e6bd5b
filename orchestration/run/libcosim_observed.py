"""The libcosim engine's execution with libcosim's observers (:mod:`orchestration.run.libcosim_engine`):
a time-series observer on every Real and Integer output and a file observer on the controller's
Booleans, read per chunk into the master's rows.  What the engine uses to run an SSP package as it
is (:func:`orchestration.run.libcosim_engine.run_package`) and to take the rows after the last chunk
of a failed run; a scenario's run records through the RowRecorder FMU
(:mod:`orchestration.run.libcosim_rows`), which costs libcosim less.

libcosim's observers see a controller output once its step is complete, at ``t_j + Ts``: the
execution takes it from there, and runs up to one controller step beyond ``stop_time`` for the last
row.  Reals and Integers come from the time-series observer, exact doubles; the controller's
Booleans, which that observer cannot read, from the file observer's CSV (0 / 1)."""

from __future__ import annotations

import numpy as np

from orchestration.packaging.ssd import NS, SIGNALS_UNIT
from orchestration.process.interrupts import signal_name
from orchestration.run.libcosim_readers import BoolFile, Lib, Series, file_observer, positions
from orchestration.scenario.system import CONTROLLER, PLANT

__all__ = ["ObservedExecution"]

SIGNALS = SIGNALS_UNIT


class ObservedExecution:
    """One libcosim execution of the system and its observers, and the rows taken from them."""

    def __init__(self, sc, structure, outputs, work, chunk_time):
        from libcosimpy.CosimEnums import CosimVariableType
        from libcosimpy.CosimExecution import CosimExecution
        from libcosimpy.CosimObserver import CosimObserver

        self.sc, self.outputs, self.lib = sc, outputs, Lib()
        self.h, self.N = sc.step, sc.controller_every
        self.n = round(sc.stop_time / self.h)
        self.every = max(1, round(sc.record.interval / self.h))
        self.last_step = self.N * (self.n // self.N + 1)  # completes the last row's controller values
        self.pending = []  # row tables waiting for the Booleans of their controller samples
        self.next_row = 0
        self.file_obs = None
        try:
            self.ex = CosimExecution.from_ssp_file(str(structure))  # a package (.ssp) or a .ssd
        except AssertionError as exc:
            raise RuntimeError(str(exc)) from None
        self.index = {name: self.ex.slave_index_from_instance_name(name) for name in outputs}
        self.chunk = max(self.N, round(chunk_time / self.h) // self.N * self.N)  # base steps, a multiple of N
        # samples kept per variable: the rows of a chunk and the controller sample of the last one.  No
        # more: libcosim 0.11 copies the observer's whole time map at every sample read
        self.observer = CosimObserver.create_time_series(self.chunk + 2 * self.N + 8)
        self.ex.add_observer(self.observer)
        for name, o in outputs.items():
            for _, ref in o.real:
                self.observer.start_time_series(self.index[name], ref, CosimVariableType.REAL)
            for _, ref in o.integer:
                self.observer.start_time_series(self.index[name], ref, CosimVariableType.INTEGER)
        bools = outputs[CONTROLLER].boolean
        self.bools = BoolFile(work / "observer" / f"{CONTROLLER}.csv", len(bools))
        if bools:
            self.file_obs = file_observer([b for b, _ in bools], CONTROLLER, work)
            self.ex.add_observer(self.file_obs)
        self.series = Series(self.lib, self.observer.ptr())
        profiles = sorted(sc.profiles)
        self.sig_refs = [dict(outputs[SIGNALS].real)[p] for p in profiles]
        self.p_refs = [r for _, r in outputs[PLANT].real]
        self.c_real = [r for _, r in outputs[CONTROLLER].real]
        self.c_int = [r for _, r in outputs[CONTROLLER].integer]

    def simulate(self, rec, stop):
        h, chunk = self.h, self.chunk
        reached = 0  # the base step libcosim has reached
        while reached < self.last_step:
            if stop.signum:
                return "interrupted", f"stopped by {signal_name(stop.signum)} at t = {reached * h:.6g} s", \
                    reached * h, ""
            target = min(reached + chunk, self.last_step)
            ok = self.ex.step(target - reached)
            if not ok:
                text = self.lib.error().strip()
                now = self.ex.status().current_time // round(h * NS)
                self._take(now, rec)
                unit = next((u for u in self.outputs if f"{u}: " in text), "")
                kind = "discard" if "Step not complete" in text else "error"
                return kind, f"{unit or 'libcosim'}: libcosim: {text}", now * h, unit
            reached = target
            self._take(reached, rec)
        return "ok", "", self.n * h, ""

    def close(self, rec):
        """End the execution (the file observer closes its CSV) and record the rows still waiting
        for their Booleans."""
        self.ex = self.observer = self.file_obs = None  # libcosim objects freed here (refcounts)
        self.bools.update()
        self._emit(rec)

    def _take(self, reached, rec):
        """Read the rows ``next_row..`` complete once libcosim has reached base step ``reached``
        (row k needs the plant and profile samples of step k and the controller sample of step
        ``N * (k // N + 1)``) and record those whose Booleans are on disk."""
        N, n = self.N, self.n
        last = n if reached >= self.last_step else min(n, (reached // N) * N - 1)
        rows = [k for k in range(self.next_row, last + 1) if k % self.every == 0]
        self.next_row = max(self.next_row, last + 1)
        if rows:
            self.pending.append(self._table(np.array(rows)))
        self.bools.update()
        self._emit(rec)

    def _table(self, ks):
        N, ix = self.N, self.index
        k0, count = int(ks[0]), int(ks[-1] - ks[0] + 1)
        cs = N * (ks // N + 1)  # the controller sample of each row
        p_steps, pv = self.series.read(ix[PLANT], self.p_refs, "real", k0, count)
        c0, c_count = int(cs[0]), int(cs[-1] - cs[0] + 1)
        c_steps, cv = self.series.read(ix[CONTROLLER], self.c_real, "real", c0, c_count)
        parts = [cv]
        if self.c_int:
            parts.append(self.series.read(ix[CONTROLLER], self.c_int, "int", c0, c_count)[1])
        cols = [ks * self.h, pv[:, positions(p_steps, ks)], np.vstack(parts)[:, positions(c_steps, cs)]]
        if self.bools.n:
            cols.append(np.full((self.bools.n, len(ks)), np.nan))  # filled by _emit
        s_steps, sv = self.series.read(ix[SIGNALS], self.sig_refs, "real", k0, count)
        cols.append(sv[:, positions(s_steps, ks)])
        return cs, np.vstack(cols).T

    def _emit(self, rec):
        """Record the pending rows, in order, up to the first whose Booleans are not on disk yet."""
        nb = self.bools.n
        while self.pending:
            cs, table = self.pending[0]
            upto = len(cs)
            if nb:
                upto, flags = self.bools.take(cs)
                if upto == 0:
                    return
                nc = table.shape[1] - nb - len(self.sig_refs)  # first Boolean column
                table[:upto, nc:nc + nb] = flags
            for row in table[:upto]:  # rows of the float64 table: the recorder stacks them per chunk
                rec.append(row)
            if upto == len(cs):
                self.pending.pop(0)
            else:
                self.pending[0] = (cs[upto:], table[upto:])
