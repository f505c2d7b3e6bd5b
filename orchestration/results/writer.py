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
``setpoints``, one line saying what missed.  It does not change the exit code: only acceptance
bounds do.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from orchestration.results import atomic
from orchestration.run.recorder import FILES, StreamingRecorder
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
    columns = {"t": "time", "omega_m": "plant.omega_m", "omega_ref": "profile.omega_ref",
               "psi_r_alpha": "plant.psi_r_alpha", "psi_r_beta": "plant.psi_r_beta",
               "psi_ref": "profile.psi_ref", "z1": "controller.z1", "e1": "controller.e1",
               "i_s_alpha": "plant.i_s_alpha", "i_s_beta": "plant.i_s_beta",
               "v_s_alpha": "controller.v_s_alpha", "v_s_beta": "controller.v_s_beta", "W": "controller.W"}
    acc = scenario.acceptance
    return closed_loop_metrics(**{k: np.asarray(df[c]) for k, c in columns.items()},
                               run=np.asarray(df["controller.phase"]) == RUN,
                               ss_window=acc.ss_window if acc is not None and acc.ss_window else None,
                               voltage_limited=np.asarray(df["controller.voltage_limited"]),
                               current_limited=np.asarray(df["controller.current_limited"]),
                               psi_set=(np.asarray(df["controller.psi_ref_shaped"])
                                        if "controller.psi_ref_shaped" in df else None))


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


def streaming_recorder(scenario, directory, on_parquet=None):
    """A ``columns -> StreamingRecorder`` factory for :func:`orchestration.run.master.run`;
    ``on_parquet``: see :attr:`StreamingRecorder.on_parquet`.  ``make.error``: the OSError of a
    recorder it could not create (None otherwise; a created one keeps its own ``error``)."""
    def make(columns):
        try:
            rec = StreamingRecorder(columns, directory, keep=recorded_selection(scenario, columns))
        except OSError as exc:
            make.error = make.error or exc
            raise
        rec.on_parquet = on_parquet
        return rec

    make.error = None
    return make


def write_failure(result, write_error=None):
    """The OSError that kept the time series of ``result`` from being written (its recorder's
    :attr:`~orchestration.run.recorder.StreamingRecorder.error`, or ``write_error``), or None."""
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
    if error is None and not isinstance(rec, StreamingRecorder):  # the same writer as a streamed run
        try:
            disk = StreamingRecorder(rec.columns, d, keep=recorded_selection(sc, rec.columns))
            for row in np.column_stack(list(rec.arrays().values())).tolist():
                disk.append(row)
            disk.close()
            error = disk.error
        except OSError as exc:
            error = exc
    df = rec.arrays() if error is None else {}  # {column: array}: metrics and figure need no DataFrame
    rows = len(df["time"]) if "time" in df else 0
    metrics = compute_metrics(df, sc) if result.ok and rows else {}
    acceptance = check_acceptance(metrics, sc)
    holds, setpoints = setpoint_status(metrics, df["time"] if rows else (), sc)
    status, message = result.status, result.message
    if error is not None:
        for name in FILES:  # e.g. the empty record a run that failed at its start falls back to
            atomic.discard(d / name)
        if discard_figure is not None:  # a helper drawing from a Parquet file not kept
            discard_figure()
        status, message = "failed", (f"{atomic.describe(error)}: the time series were not kept (the run "
                                     f"reached t = {result.t_end:.6g} s)")
    elif plot and rows > 1:
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
        "stop_time": sc.stop_time,
        "wall_time": result.wall_time, "rows": rows, "metrics": metrics, "acceptance": acceptance,
        "accepted": all(v["pass"] for v in acceptance.values()) if acceptance else None,
        "holds_setpoints": holds, "setpoints": setpoints,
        "notes": [str(n) for n in getattr(sc, "notes", ())],
    }
    try:
        atomic.write_json(d / "metrics.json", summary)
    except OSError as exc:  # the status on disk stays "running" with the pid: a later reader sees it died
        summary.update(status="failed", message=f"{atomic.describe(exc, d / 'metrics.json')}: the results "
                       "are not complete"
                       + (f" ({message})" if message else ""), metrics_written=False)
    return summary
