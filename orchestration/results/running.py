"""What a run's results need, gathered as it goes by the recorder's observer
(:class:`orchestration.results.recorder.Recorder`), so that nothing reads the whole series back and a
run's memory does not grow with its simulated time:

* :class:`MetricsObserver` feeds :class:`satmotor.metrics.RunningMetrics` each chunk of rows; the
  columns the metrics read are :data:`METRIC_COLUMNS`, also used by
  :func:`orchestration.results.writer.compute_metrics` (the whole-record computation);
* :class:`FigureCopy` keeps every k-th row of the columns the figure reads, at most
  :data:`FIGURE_ROWS` rows (every row of a run that records no more).
"""

from __future__ import annotations

import numpy as np

from orchestration.scenario.recording import NEEDED, last_row_time, record_steps
from orchestration.scenario.system import link_on as _plant_link_on
from satmotor.drive_phase import RUN
from satmotor.metrics import LINK_SERIES, RunningMetrics

__all__ = ["METRIC_COLUMNS", "FLAG_COLUMNS", "LINK_COLUMNS", "link_on", "PSI_SET_COLUMN", "FIGURE_ROWS",
           "MetricsObserver", "FigureCopy", "ss_window", "figure_step", "observers"]

#: most rows the figure of a run shows (every k-th row beyond: the default scenario's 15 001, every 4th).
#: The figure is 900 pixels wide; drawing costs memory: a figure of 8000 rows about 40 MB more than one
#: of 4000 (measured on a 600 s run)
FIGURE_ROWS = 4_000

#: {argument of satmotor.metrics.closed_loop_metrics: recorded column}
METRIC_COLUMNS = {"t": "time", "omega_m": "plant.omega_m", "omega_ref": "profile.omega_ref",
                  "psi_r_alpha": "plant.psi_r_alpha", "psi_r_beta": "plant.psi_r_beta",
                  "psi_ref": "profile.psi_ref", "z1": "controller.z1", "e1": "controller.e1",
                  "i_s_alpha": "plant.i_s_alpha", "i_s_beta": "plant.i_s_beta",
                  "v_s_alpha": "controller.v_s_alpha", "v_s_beta": "controller.v_s_beta", "W": "controller.W"}
#: the run-phase column and the limiter flags
PHASE_COLUMN = "controller.phase"
#: the flux set-point the drive works to (under field weakening below the nominal psi_ref), when recorded
PSI_SET_COLUMN = "controller.psi_ref_shaped"
FLAG_COLUMNS = {"voltage_limited": "controller.voltage_limited",
                "current_limited": "controller.current_limited"}
#: {series of satmotor.metrics.link_metrics: recorded column}, read when the plant's link is on
LINK_COLUMNS = {k: f"plant.{k}" for k in LINK_SERIES}


def link_on(scenario):
    """Whether the scenario's plant has its DC link on (``dc_link: capacitor``): the link's metrics."""
    return _plant_link_on(getattr(scenario, "plant", None))


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
        self._psi_set = index.get(PSI_SET_COLUMN)
        self._link = [(k, index[c]) for k, c in LINK_COLUMNS.items()] if link_on(scenario) else None
        t_last = last_row_time(scenario)
        w_final = scenario.profiles["omega_ref"].value(t_last)
        self.metrics = RunningMetrics(t_last, w_final, ss_window(scenario), link=self._link is not None)

    def __call__(self, chunk):
        self.metrics.update(**{k: chunk[:, i] for k, i in self._cols + self._flags},
                            run=chunk[:, self._phase] == RUN,
                            psi_set=None if self._psi_set is None else chunk[:, self._psi_set],
                            link=None if self._link is None else {k: chunk[:, i] for k, i in self._link})

    def times(self):
        """``[t_first, t_last]`` [s] of the rows seen (empty before the first)."""
        m = self.metrics
        return np.array([m.t_first, m.t_seen]) if m.n else np.empty(0)


def figure_step(scenario):
    """k: the figure of a complete run of ``scenario`` shows every k-th recorded row (1: all)."""
    n, every = record_steps(scenario)
    return max(1, -(-(n // every + 1) // FIGURE_ROWS))


class FigureCopy:
    """``observer(chunk)`` keeping every :attr:`step`-th row (:func:`figure_step`, counted across the
    chunks) of the columns the figure reads (time, the profiles, :data:`NEEDED`); :meth:`arrays`
    gives them as the figure takes them."""

    def __init__(self, columns, scenario):
        keep = [i for i, c in enumerate(columns) if c == "time" or c.startswith("profile.") or c in NEEDED]
        self.columns = [columns[i] for i in keep]
        self._keep = keep
        self.step = figure_step(scenario)
        self._skip = 0
        self._chunks = []

    def __call__(self, chunk):
        first = self._skip
        self._skip = (first - len(chunk)) % self.step
        self._chunks.append(chunk[first::self.step][:, self._keep])

    def arrays(self):
        a = np.concatenate(self._chunks) if self._chunks else np.empty((0, len(self.columns)))
        return {c: a[:, i] for i, c in enumerate(self.columns)}


def observers(*functions):
    """One observer calling each of ``functions`` (None ones left out) with the chunk."""
    fs = [f for f in functions if f is not None]

    def observe(chunk):
        for f in fs:
            f(chunk)
    return observe
