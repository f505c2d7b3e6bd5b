"""The metrics of a run computed as it goes: the recorder's observer
(:class:`orchestration.run.recorder.Recorder`) feeding :class:`satmotor.metrics.RunningMetrics`
each chunk of rows, so levels ``metrics`` and ``decimated`` need no time series read back.  The
columns the metrics read are :data:`METRIC_COLUMNS`, also used by
:func:`orchestration.results.writer.compute_metrics` (the whole-record computation)."""

from __future__ import annotations

import numpy as np

from orchestration.scenario.recording import last_row_time
from satmotor.control.drive import RUN
from satmotor.metrics import RunningMetrics

__all__ = ["METRIC_COLUMNS", "FLAG_COLUMNS", "MetricsObserver", "ss_window"]

#: {argument of satmotor.metrics.closed_loop_metrics: recorded column}
METRIC_COLUMNS = {"t": "time", "omega_m": "plant.omega_m", "omega_ref": "profile.omega_ref",
                  "psi_r_alpha": "plant.psi_r_alpha", "psi_r_beta": "plant.psi_r_beta",
                  "psi_ref": "profile.psi_ref", "z1": "controller.z1", "e1": "controller.e1",
                  "i_s_alpha": "plant.i_s_alpha", "i_s_beta": "plant.i_s_beta",
                  "v_s_alpha": "controller.v_s_alpha", "v_s_beta": "controller.v_s_beta", "W": "controller.W"}
#: the run-phase column and the limiter flags
PHASE_COLUMN = "controller.phase"
FLAG_COLUMNS = {"voltage_limited": "controller.voltage_limited",
                "current_limited": "controller.current_limited"}


def ss_window(scenario):
    """The scenario's steady-state window ``(t_from, t_to)`` [s], or None (the last 10 %)."""
    acc = scenario.acceptance
    return acc.ss_window if acc is not None and acc.ss_window else None


class MetricsObserver:
    """``observer(chunk)`` for a recorder whose rows have ``columns``: the chunk's metric columns
    go to :attr:`metrics` (a :class:`RunningMetrics` expecting the complete run of ``scenario``)."""

    def __init__(self, columns, scenario):
        index = {c: i for i, c in enumerate(columns)}
        self._cols = [(k, index[c]) for k, c in METRIC_COLUMNS.items()]
        self._flags = [(k, index[c]) for k, c in FLAG_COLUMNS.items()]
        self._phase = index[PHASE_COLUMN]
        t_last = last_row_time(scenario)
        w_final = scenario.profiles["omega_ref"].value(t_last)
        self.metrics = RunningMetrics(t_last, w_final, ss_window(scenario))

    def __call__(self, chunk):
        self.metrics.update(**{k: chunk[:, i] for k, i in self._cols + self._flags},
                            run=chunk[:, self._phase] == RUN)

    def times(self):
        """``[t_first, t_last]`` [s] of the rows seen (empty before the first)."""
        m = self.metrics
        return np.array([m.t_first, m.t_seen]) if m.n else np.empty(0)
