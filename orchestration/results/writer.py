"""Results of a co-simulation run: metrics, acceptance checks, and the files written.

Files per run, under ``OUT/<scenario name>/``: ``timeseries.csv`` and ``timeseries.parquet`` (the
recorded outputs, streamed as the run goes; column names ``unit.variable``, SI units as in the
FMUs' descriptions; with a ``measurements:`` section also ``measured.NAME``, the values the controller
received),
``metrics.json`` (metrics, acceptance verdicts, whether the set-points were held, the scenario's
notes and how the run ended) and ``figure.png``.  Each is written under a temporary name and
renamed when complete (:mod:`orchestration.results.atomic`); ``metrics.json`` says ``running`` (with
the pid) until the others are complete, then how the run ended, ``failed`` with the reason when a
file could not be written (``no space left on device writing ...``).

Whether a completed run held its set-points (:func:`setpoint_status`; the rule and the default
margins in :mod:`satmotor.metrics`) is judged with or without acceptance bounds: ``metrics.json``
has ``holds_setpoints`` (true, false, or null when not judged: a failed run, an empty window) and
``setpoints``, one line saying what missed.  It changes the exit code only when the scenario asks
for it, ``acceptance: {holds_setpoints: true}`` (then a bound like the others: exit 3 when not held).
Chosen on purpose: a scenario without acceptance bounds claims nothing to be judged by, and short
runs (a smoke test that ends while the flux is still rising) do not hold their set-points by design.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from orchestration.results import atomic
from orchestration.results.recorder import FILES, MetricsOnly, StreamingRecorder
from orchestration.results.running import (
    FLAG_COLUMNS,
    LINK_COLUMNS,
    METRIC_COLUMNS,
    PHASE_COLUMN,
    PSI_SET_COLUMN,
    FigureCopy,
    MetricsObserver,
    link_on,
    observers,
    ss_window,
)
from orchestration.scenario.recording import recorded_selection
from satmotor import metrics as _m
from satmotor.drive_phase import RUN
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
                               **{k: np.asarray(df[c]) for k, c in FLAG_COLUMNS.items()},
                               psi_set=np.asarray(df[PSI_SET_COLUMN]) if PSI_SET_COLUMN in df else None,
                               link={k: np.asarray(df[c]) for k, c in LINK_COLUMNS.items()}
                               if link_on(scenario) else None)


def check_acceptance(metrics, scenario):
    """``{bound: {"limit": x, "value": y, "pass": bool}}`` for the scenario's acceptance bounds
    (:func:`satmotor.metrics.acceptance`; a nan value fails)."""
    acc = scenario.acceptance
    if acc is None or not metrics:
        return {}
    keys = ("ss_speed", "ss_flux", "overshoot_speed", "peak_current", "peak_current_run",
            "final_overshoot_speed", "peak_v_dc")
    # peak_v_dc: a metric only with the plant's link on (a NaN, failing, without it)
    return acceptance({"peak_v_dc": math.nan, **metrics}, {key: getattr(acc, key) for key in keys})


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
    removed (a failed rerun never sits beside an old figure) with any ``.part`` file a killed run
    left, and ``metrics.json`` written with status ``running`` and who runs it
    (:func:`orchestration.results.atomic.owner`: pid, host, start).  An OSError here means the
    results could not be written: nothing has run."""
    d = Path(out_dir) / scenario.name
    d.mkdir(parents=True, exist_ok=True)
    for name in RESULT_FILES:
        (d / name).unlink(missing_ok=True)
    atomic.remove_partial(d)
    atomic.write_text(d / "metrics.json", json.dumps({"scenario": scenario.name, "file": str(scenario.path),
                                                      "status": "running", **atomic.owner()}) + "\n")
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
    ``on_parquet``: see :attr:`StreamingRecorder.on_parquet`.  ``make.error``: the OSError of a
    recorder it could not create (None otherwise; a created one keeps its own ``error``)."""
    lv = level(scenario)

    def make(columns):
        metrics = MetricsObserver(columns, scenario)
        copy = FigureCopy(columns, scenario) if lv != "metrics" and figure_copy else None
        if lv == "metrics":
            rec = MetricsOnly(columns, observer=metrics)
        else:
            try:
                rec = StreamingRecorder(columns, directory, keep=recorded_selection(scenario, columns),
                                        observer=observers(metrics, copy),
                                        every=scenario.record.every if lv == "decimated" else 1)
            except OSError as exc:
                make.error = make.error or exc
                raise
            rec.on_parquet = on_parquet
        rec.metrics_observer, rec.figure_copy = metrics, copy
        return rec

    make.error = None
    return make


def write_failure(result, write_error=None):
    """The OSError that kept the time series of ``result`` from being written (its recorder's
    :attr:`~orchestration.results.recorder.StreamingRecorder.error`, or ``write_error``), or None."""
    return write_error or getattr(result.recorder, "error", None)


def figure_target(scenario, out_dir):
    """(path, title) of the run's figure."""
    return Path(out_dir) / scenario.name / "figure.png", f"{scenario.name}: {scenario.description}"[:110]


def write_results(result, out_dir, plot=True, draw=None, write_error=None, discard_figure=None):
    """Write the files of one run under ``out_dir/<name>/``; returns the summary dict (also in
    metrics.json).  A streamed run has its time series on disk already; a run recorded in memory
    gets them written here.  Partial results of a failed or interrupted run are written too.
    ``draw(data, path, title)`` draws the figure (default :func:`orchestration.results.plots.figure`);
    ``discard_figure()``, when the time series cannot be kept, stops whatever draws one elsewhere
    (:meth:`orchestration.results.figure_process.FigureProcess.discard`).

    Every file is written under a temporary name and renamed when complete
    (:mod:`orchestration.results.atomic`), ``metrics.json`` last: once it no longer says
    ``running``, the other files are complete.  A file that cannot be written (``write_error``: the
    recorder's failure, see :func:`write_failure`; or the figure) makes the status ``failed`` and the
    message say which and why (``no space left on device writing ...``); the time series of a
    record cut short are not kept.  When ``metrics.json`` itself cannot be written, its ``running``
    status (with the pid) stays for a later reader, and the summary returned says ``failed`` and
    has ``metrics_written: False``.  Never raises OSError."""
    sc = result.scenario
    d = Path(out_dir) / sc.name
    d.mkdir(parents=True, exist_ok=True)
    rec = result.recorder
    error = write_failure(result, write_error)
    observer = getattr(rec, "metrics_observer", None)
    if error is None and observer is None and not isinstance(rec, StreamingRecorder):
        try:  # the same writer as a streamed run
            disk = StreamingRecorder(rec.columns, d, keep=recorded_selection(sc, rec.columns))
            for row in np.column_stack(list(rec.arrays().values())).tolist():
                disk.append(row)
            disk.close()
            error = disk.error
        except OSError as exc:
            error = exc
    df = None
    if error is not None:  # the time series were not kept: no metrics, no figure
        rows = written = 0
        metrics, times = {}, ()
    elif observer is None:  # a recorder of its own (master.run's default, in memory): from its rows
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
    if metrics and sc.acceptance is not None and sc.acceptance.holds_setpoints:  # a bound like the others
        acceptance["holds_setpoints"] = {"limit": True, "value": holds, "pass": holds is True}
    status, message = result.status, result.message
    if error is not None:
        for name in FILES:  # e.g. the empty record a run that failed at its start falls back to
            atomic.discard(d / name)
        if discard_figure is not None:  # a helper drawing from a Parquet file not kept
            discard_figure()
        status, message = "failed", (f"{atomic.describe(error)}: the time series were not kept (the run "
                                     f"reached t = {result.t_end:.6g} s)")
    elif plot and rows > 1 and (df is not None or draw is not None):  # df None: the helper reads the file
        if draw is None:
            from orchestration.results.plots import figure as draw
        try:
            draw(df, *figure_target(sc, out_dir))
        except OSError as exc:
            run = f"; the run: {result.status}, {result.message}" if not result.ok else ""
            status, message = "failed", (f"{atomic.describe(exc, d / 'figure.png')}: no figure (the time "
                                         f"series are complete{run})")
    summary = {
        "scenario": sc.name, "file": str(sc.path), "status": status, "message": message,
        "failed_unit": result.failed_unit if error is None else "", "t_end": result.t_end,
        "stop_time": sc.stop_time, "wall_time": result.wall_time, "rows": rows, "rows_written": written,
        "record": level(sc), "metrics": metrics, "acceptance": acceptance,
        "accepted": all(v["pass"] for v in acceptance.values()) if acceptance else None,
        "holds_setpoints": holds, "setpoints": setpoints,
        "notes": [str(n) for n in getattr(sc, "notes", ())],
        "warnings": [f"{unit}: {text}" for unit, text in getattr(result, "warnings", ())],
    }
    try:
        atomic.write_json(d / "metrics.json", summary)
    except OSError as exc:  # the status on disk stays "running" with the pid: a later reader sees it died
        summary.update(status="failed", message=f"{atomic.describe(exc, d / 'metrics.json')}: the results "
                       "are not complete"
                       + (f" ({message})" if message else ""), metrics_written=False)
    return summary
