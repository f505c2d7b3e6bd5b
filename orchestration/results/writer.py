"""Results of a co-simulation run: metrics, acceptance checks, and the files written.

Files per run, under ``OUT/<scenario name>/``: ``timeseries.csv`` and ``timeseries.parquet`` (the
recorded outputs, streamed as the run goes; column names ``unit.variable``, SI units as in the
FMUs' descriptions; with a ``measurements:`` section also ``measured.NAME``, the values the controller
received),
``metrics.json`` (metrics, acceptance verdicts, whether the set-points were held, the scenario's
notes and how the run ended) and ``figure.png``.

Whether a completed run held its set-points (:func:`setpoint_status`; the rule and the default
margins in :mod:`satmotor.metrics`) is judged with or without acceptance bounds: ``metrics.json``
has ``holds_setpoints`` (true, false, or null when not judged: a failed run, an empty window) and
``setpoints``, one line saying what missed.  It does not change the exit code: only acceptance
bounds do.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from orchestration.results.running import (
    FLAG_COLUMNS,
    METRIC_COLUMNS,
    PHASE_COLUMN,
    FigureCopy,
    MetricsObserver,
    observers,
    ss_window,
)
from orchestration.run.recorder import FILES, MetricsOnly, StreamingRecorder
from orchestration.scenario.recording import recorded_selection
from satmotor import metrics as _m
from satmotor.control.drive import RUN
from satmotor.metrics import acceptance, closed_loop_metrics


def compute_metrics(df, scenario):
    """Metrics of a recorded run (SI units): :func:`satmotor.metrics.closed_loop_metrics` on the
    columns of ``df`` (a DataFrame, or ``{column: array}``; definitions there), the steady-state
    window from the scenario's acceptance ``ss_window`` (default: the last 10 % of the run).  ``{}``
    for an empty record."""
    if len(df["time"]) == 0:
        return {}
    return closed_loop_metrics(**{k: np.asarray(df[c]) for k, c in METRIC_COLUMNS.items()},
                               run=np.asarray(df[PHASE_COLUMN]) == RUN, ss_window=ss_window(scenario),
                               **{k: np.asarray(df[c]) for k, c in FLAG_COLUMNS.items()})


def check_acceptance(metrics, scenario):
    """``{bound: {"limit": x, "value": y, "pass": bool}}`` for the scenario's acceptance bounds
    (:func:`satmotor.metrics.acceptance`; a nan value fails)."""
    acc = scenario.acceptance
    if acc is None or not metrics:
        return {}
    keys = ("ss_speed", "ss_flux", "overshoot_speed", "peak_current", "peak_current_run")
    return acceptance(metrics, {key: getattr(acc, key) for key in keys})


def setpoint_status(metrics, times, scenario):
    """``(holds, line)`` of :func:`satmotor.metrics.setpoint_status` for a run of ``scenario``:
    the window is the acceptance ``ss_window`` (default the last 10 % of ``times``), the margins the
    acceptance ``ss_speed`` / ``ss_flux`` bounds when stated, else the defaults."""
    if not metrics or len(times) == 0:
        return None, ""
    acc = scenario.acceptance
    window = _m.steady_state_bounds(times, acc.ss_window if acc is not None and acc.ss_window else None)
    return _m.setpoint_status(metrics, window, acc and acc.ss_speed, acc and acc.ss_flux)


RESULT_FILES = (*FILES, "metrics.json", "figure.png")
def prepare_dir(out_dir, scenario):
    """``out_dir/<name>/``, made ready before a run: created, the previous results of the scenario
    removed (a failed rerun never sits beside an old figure), and ``metrics.json`` written with
    status ``running``.  An OSError here means the results could not be written: nothing has run."""
    d = Path(out_dir) / scenario.name
    d.mkdir(parents=True, exist_ok=True)
    for name in RESULT_FILES:
        (d / name).unlink(missing_ok=True)
    (d / "metrics.json").write_text(json.dumps({"scenario": scenario.name, "file": str(scenario.path),
                                                "status": "running"}) + "\n")
    return d


def level(scenario):
    """The scenario's record level: ``full`` (every recorded row on disk), ``decimated`` (one row
    of ``record.every`` on disk) or ``metrics`` (none on disk).  All three compute the metrics as
    the run goes, from every recorded row, and the first two keep a bounded copy for the figure
    (:mod:`orchestration.results.running`): nothing reads the series back."""
    return getattr(scenario.record, "level", "full") if scenario.record is not None else "full"


def streaming_recorder(scenario, directory, on_parquet=None, figure_copy=True):
    """A ``columns -> recorder`` factory for :func:`orchestration.run.master.run`, as the scenario's
    record level asks (:func:`level`): a :class:`StreamingRecorder` (``decimated``: keeping one row
    of ``record.every``) or a :class:`MetricsOnly`, carrying its
    :class:`~orchestration.results.running.MetricsObserver` as ``metrics_observer`` and its
    :class:`~orchestration.results.running.FigureCopy` (None at level ``metrics``) as
    ``figure_copy`` (None too with ``figure_copy`` False: the figure helper reads the file).
    ``on_parquet``: see :attr:`StreamingRecorder.on_parquet`."""
    lv = level(scenario)

    def make(columns):
        metrics = MetricsObserver(columns, scenario)
        copy = FigureCopy(columns, scenario) if lv != "metrics" and figure_copy else None
        if lv == "metrics":
            rec = MetricsOnly(columns, observer=metrics)
        else:
            rec = StreamingRecorder(columns, directory, keep=recorded_selection(scenario, columns),
                                    observer=observers(metrics, copy),
                                    every=scenario.record.every if lv == "decimated" else 1)
            rec.on_parquet = on_parquet
        rec.metrics_observer, rec.figure_copy = metrics, copy
        return rec

    return make


def figure_target(scenario, out_dir):
    """(path, title) of the run's figure."""
    return Path(out_dir) / scenario.name / "figure.png", f"{scenario.name}: {scenario.description}"[:110]


def write_results(result, out_dir, plot=True, draw=None):
    """Write the files of one run under ``out_dir/<name>/``; returns the summary dict (also in
    metrics.json).  A streamed run has its time series on disk already; a run recorded in memory
    gets them written here.  Partial results of a failed or interrupted run are written too.
    ``draw(data, path, title)`` draws the figure (default :func:`orchestration.results.plots.figure`)."""
    sc = result.scenario
    d = Path(out_dir) / sc.name
    d.mkdir(parents=True, exist_ok=True)
    rec = result.recorder
    observer = getattr(rec, "metrics_observer", None)
    if observer is None and not isinstance(rec, StreamingRecorder):  # the same writer as a streamed run
        disk = StreamingRecorder(rec.columns, d, keep=recorded_selection(sc, rec.columns))
        for row in np.column_stack(list(rec.arrays().values())).tolist():
            disk.append(row)
        disk.close()
    if observer is None:  # a recorder of its own (master.run's default, in memory): from its rows
        df = rec.arrays()  # {column: array}: the metrics and the figure need no DataFrame
        rows = written = len(df["time"]) if "time" in df else 0
        metrics = compute_metrics(df, sc) if result.ok and rows else {}
        times = df["time"] if rows else ()
    else:  # computed as the run went; the figure from the bounded copy
        rows, written = rec.n_seen, rec.n_rows
        metrics = observer.metrics.result() if result.ok and rows else {}
        times = observer.times() if metrics else ()
        if metrics is None and isinstance(rec, StreamingRecorder) and rec.every == 1:
            # the run did not end where the scenario said (never seen): the metrics of the file
            df = rec.arrays()
            metrics, times = compute_metrics(df, sc), df["time"]
        metrics = metrics or {}
        copy = getattr(rec, "figure_copy", None)
        df = copy.arrays() if plot and copy is not None and rows > 1 else None
    acceptance = check_acceptance(metrics, sc)
    holds, setpoints = setpoint_status(metrics, times, sc)
    summary = {
        "scenario": sc.name, "file": str(sc.path), "status": result.status, "message": result.message,
        "failed_unit": result.failed_unit, "t_end": result.t_end, "stop_time": sc.stop_time,
        "wall_time": result.wall_time, "rows": rows, "rows_written": written, "record": level(sc),
        "metrics": metrics, "acceptance": acceptance,
        "accepted": all(v["pass"] for v in acceptance.values()) if acceptance else None,
        "holds_setpoints": holds, "setpoints": setpoints,
        "notes": [str(n) for n in getattr(sc, "notes", ())],
    }
    (d / "metrics.json").write_text(json.dumps(summary, indent=2, default=float) + "\n")
    if plot and rows > 1 and (df is not None or draw is not None):  # df None: the helper reads the file
        if draw is None:
            from orchestration.results.plots import figure as draw
        draw(df, *figure_target(sc, out_dir))
    return summary
