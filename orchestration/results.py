"""Results of a co-simulation run: metrics, acceptance checks, and the files written.

Files per run, under ``OUT/<scenario name>/``: ``timeseries.csv`` and ``timeseries.parquet`` (the
recorded outputs, streamed as the run goes; column names ``unit.variable``, SI units as in the
FMUs' descriptions),
``metrics.json`` (metrics, acceptance verdicts and how the run ended) and ``figure.png``.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from satmotor.metrics import iae, overshoot

from .recorder import FILES, StreamingRecorder

SETTLING_BAND = 0.02  # [1] relative band of the settling time


def _run_phase(df):
    """Rows where the control law runs (W > 0; the PI baseline reports W = 0: all rows after the
    flux error is first within 10 % of the set-point)."""
    W = df["controller.W"].to_numpy()
    if np.any(W > 0):
        return W > 0
    e1 = df["controller.e1"].to_numpy()
    psi = df["profile.psi_ref"].to_numpy()
    reached = np.abs(e1) <= 0.1 * np.abs(psi)
    return np.cumsum(reached) > 0


def compute_metrics(df, scenario):
    """Metrics of a recorded run (SI units).

    IAE of the tracking errors z1 [rad/s] and e1 [Wb] (against the shaped references) over the
    run phase; steady-state errors: the largest |response - set-point| over the acceptance window
    (default: the last 10 % of the run), relative to the final set-point (at least 1 rad/s,
    1 mWb); overshoot of the speed relative to its total change; settling time into a 2 % band.
    """
    if df.empty:
        return {}
    t = df["time"].to_numpy()
    w = df["plant.omega_m"].to_numpy()
    phi = np.hypot(df["plant.psi_r_alpha"], df["plant.psi_r_beta"]).to_numpy()
    w_set = df["profile.omega_ref"].to_numpy()
    psi_set = df["profile.psi_ref"].to_numpy()
    run = _run_phase(df)
    t_run = float(t[np.argmax(run)]) if run.any() else math.nan
    acc = scenario.acceptance
    t_from = acc.ss_window[0] if acc is not None and acc.ss_window else t[0] + 0.9 * (t[-1] - t[0])
    ss = t >= t_from
    w_final, psi_final = float(w_set[-1]), float(psi_set[-1])
    m = {
        "t_switch": t_run,
        "iae_speed": iae(t[run], np.abs(df["controller.z1"].to_numpy()[run]), 0.0) if run.any() else math.nan,
        "iae_flux": iae(t[run], np.abs(df["controller.e1"].to_numpy()[run]), 0.0) if run.any() else math.nan,
        "ss_speed": float(np.max(np.abs(w[ss] - w_set[ss]))) / max(abs(w_final), 1.0),
        "ss_flux": float(np.max(np.abs(phi[ss] - psi_set[ss]))) / max(abs(psi_final), 1e-3),
        "overshoot_speed": overshoot(w, w_final, w[0]) if w_final != w[0] else 0.0,
        "settling_time_speed": _settling_time(t, w, w_final),
        "peak_current": float(np.max(np.hypot(df["plant.i_s_alpha"], df["plant.i_s_beta"]))),
        "peak_voltage": float(np.max(np.hypot(df["controller.v_s_alpha"], df["controller.v_s_beta"]))),
        "min_W": float(np.min(df["controller.W"].to_numpy()[run])) if run.any() else math.nan,
    }
    return m


def _settling_time(t, y, final):
    """Last time [s] |y - final| left the band SETTLING_BAND |final| (0 if never; nan if final = 0)."""
    if final == 0:
        return math.nan
    out = np.nonzero(np.abs(y - final) > SETTLING_BAND * abs(final))[0]
    return float(t[out[-1]]) if out.size else float(t[0])


def check_acceptance(metrics, scenario):
    """``{bound: {"limit": x, "value": y, "pass": bool}}`` for the scenario's acceptance bounds."""
    acc = scenario.acceptance
    if acc is None or not metrics:
        return {}
    out = {}
    for key, metric in (("ss_speed", "ss_speed"), ("ss_flux", "ss_flux"),
                        ("overshoot_speed", "overshoot_speed"), ("peak_current", "peak_current")):
        limit = getattr(acc, key)
        if limit is not None:
            value = metrics[metric]
            out[key] = {"limit": limit, "value": value, "pass": bool(value <= limit)}
    return out


RESULT_FILES = (*FILES, "metrics.json", "figure.png")
# what compute_metrics and the figure read: always recorded, whatever record.outputs lists
NEEDED = ("plant.omega_m", "plant.psi_r_alpha", "plant.psi_r_beta", "plant.i_s_alpha", "plant.i_s_beta",
          "plant.T_e", "plant.i_mu", "controller.v_s_alpha", "controller.v_s_beta", "controller.v_sd",
          "controller.v_sq", "controller.e1", "controller.z1", "controller.W", "controller.T_load_est")


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


def recorded_selection(scenario, columns):
    """Indices of ``columns`` to record: time, the profiles, ``record.outputs`` (all outputs when
    empty) and the columns the metrics and the figure need."""
    wanted = set(scenario.record.outputs) | set(NEEDED) if scenario.record.outputs else None
    return [i for i, c in enumerate(columns)
            if c == "time" or c.startswith("profile.") or wanted is None or c in wanted]


def streaming_recorder(scenario, directory):
    """A ``columns -> StreamingRecorder`` factory for :func:`orchestration.master.run`."""
    return lambda columns: StreamingRecorder(columns, directory, keep=recorded_selection(scenario, columns))


def write_results(result, out_dir, plot=True):
    """Write the files of one run under ``out_dir/<name>/``; returns the summary dict (also in
    metrics.json).  A streamed run has its time series on disk already; a run recorded in memory
    gets them written here.  Partial results of a failed or interrupted run are written too."""
    sc = result.scenario
    d = Path(out_dir) / sc.name
    d.mkdir(parents=True, exist_ok=True)
    rec = result.recorder
    if not isinstance(rec, StreamingRecorder):
        df = rec.frame()
        df = df[[df.columns[i] for i in recorded_selection(sc, list(df.columns))]]
        df.to_csv(d / FILES[0], index=False)
        df.to_parquet(d / FILES[1], index=False)
    df = rec.frame()
    metrics = compute_metrics(df, sc) if result.ok else {}
    acceptance = check_acceptance(metrics, sc)
    summary = {
        "scenario": sc.name, "file": str(sc.path), "status": result.status, "message": result.message,
        "failed_unit": result.failed_unit, "t_end": result.t_end, "stop_time": sc.stop_time,
        "wall_time": result.wall_time, "rows": len(df), "metrics": metrics, "acceptance": acceptance,
        "accepted": all(v["pass"] for v in acceptance.values()) if acceptance else None,
    }
    (d / "metrics.json").write_text(json.dumps(summary, indent=2, default=float) + "\n")
    if plot and len(df) > 1:
        from .plots import figure

        figure(df, d / "figure.png", f"{sc.name}: {sc.description}"[:110])
    return summary
