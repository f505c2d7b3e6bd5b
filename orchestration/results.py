"""Results of a co-simulation run: metrics, acceptance checks, and the files written.

Files per run, under ``OUT/<scenario name>/``: ``timeseries.csv`` and ``timeseries.parquet`` (the
recorded outputs; column names ``unit.variable``, SI units as in the FMUs' descriptions),
``metrics.json`` (metrics, acceptance verdicts and how the run ended) and ``figure.png``.
"""

from __future__ import annotations

import json
from pathlib import Path

from satmotor.metrics import acceptance, closed_loop_metrics, run_phase


def _run_phase(df):
    """Run-phase mask of a recorded run (:func:`satmotor.metrics.run_phase`: from the first W > 0,
    or for the PI baseline, which reports W = 0, from the first flux error within 10 % of the
    set-point)."""
    return run_phase(df["controller.W"].to_numpy(), df["controller.e1"].to_numpy(),
                     df["profile.psi_ref"].to_numpy())


def compute_metrics(df, scenario):
    """Metrics of a recorded run (SI units): :func:`satmotor.metrics.closed_loop_metrics` on the
    frame's columns (definitions there), the steady-state window from the scenario's acceptance
    ``ss_window`` (default: the last 10 % of the run).  ``{}`` for an empty frame."""
    if df.empty:
        return {}
    columns = {"t": "time", "omega_m": "plant.omega_m", "omega_set": "profile.omega_ref",
               "psi_r_alpha": "plant.psi_r_alpha", "psi_r_beta": "plant.psi_r_beta",
               "psi_set": "profile.psi_ref", "z1": "controller.z1", "e1": "controller.e1",
               "i_s_alpha": "plant.i_s_alpha", "i_s_beta": "plant.i_s_beta",
               "v_s_alpha": "controller.v_s_alpha", "v_s_beta": "controller.v_s_beta", "W": "controller.W"}
    acc = scenario.acceptance
    return closed_loop_metrics(**{k: df[c].to_numpy() for k, c in columns.items()}, run=_run_phase(df),
                               ss_window=acc.ss_window if acc is not None and acc.ss_window else None)


def check_acceptance(metrics, scenario):
    """``{bound: {"limit": x, "value": y, "pass": bool}}`` for the scenario's acceptance bounds
    (:func:`satmotor.metrics.acceptance`; a nan value fails)."""
    acc = scenario.acceptance
    if acc is None or not metrics:
        return {}
    return acceptance(metrics, {key: getattr(acc, key) for key in
                                ("ss_speed", "ss_flux", "overshoot_speed", "peak_current")})


def write_results(result, out_dir, plot=True):
    """Write the files of one run under ``out_dir/<name>/``; returns the summary dict (also in
    metrics.json).  Partial results of a failed run are written too."""
    sc = result.scenario
    d = Path(out_dir) / sc.name
    d.mkdir(parents=True, exist_ok=True)
    df = result.frame
    keep = ["time"] + [c for c in df.columns if c.startswith("profile.")]
    wanted = list(sc.record.outputs) or [c for c in df.columns if c not in keep]
    df[keep + [c for c in wanted if c not in keep]].to_csv(d / "timeseries.csv", index=False)
    df[keep + [c for c in wanted if c not in keep]].to_parquet(d / "timeseries.parquet", index=False)
    metrics = compute_metrics(df, sc) if result.ok else {}
    acceptance = check_acceptance(metrics, sc)
    summary = {
        "scenario": sc.name, "file": str(sc.path), "status": result.status, "message": result.message,
        "t_end": result.t_end, "stop_time": sc.stop_time, "wall_time": result.wall_time,
        "rows": len(df), "metrics": metrics, "acceptance": acceptance,
        "accepted": all(v["pass"] for v in acceptance.values()) if acceptance else None,
    }
    (d / "metrics.json").write_text(json.dumps(summary, indent=2, default=float) + "\n")
    if plot and len(df) > 1:
        from .plots import figure

        figure(df, d / "figure.png", f"{sc.name}: {sc.description}"[:110])
    return summary
