"""``efficiency-map SCENARIO --speed FROM:TO:N --torque FROM:TO:N --out DIR [--flux-mode M1,M2]``: the
steady-state efficiency of the scenario's drive over a grid of operating points.

Each point (speed set-point [rad/s], load torque [N m]; a negative torque is generating) and flux mode
(controller ``flux_mode``) is a closed-loop run of the scenario's drive: its motor, plant, controller,
step and ``psi_ref`` kept; ``omega_ref`` held constant at the point's speed from t = 0 (the controller
shapes it); ``T_load`` ramped from 0 to the point's torque over ``[0.2 T, 0.4 T]`` (``T``: ``--time``,
default the scenario's ``stop_time``) and then held; the last ``--window`` seconds (default 0.1 T)
averaged.  The points are the variants of a grid sweep per flux mode (``OUT/scenarios/*.yaml``,
:mod:`orchestration.scenario.sweep`), run by :func:`orchestration.cli.batch.run_batch` (in parallel,
``--jobs``, with its progress bar, the native FMUs several to a child under the compiled engine; Ctrl-C
and SIGTERM stop it, the points finished are kept), into ``OUT/runs/``.  Then
:func:`gather` averages each run's recorded window into a row (:data:`COLUMNS`), written to
``OUT/efficiency_map.csv`` and ``.parquet``, and the figure ``OUT/efficiency_map.png``
(:mod:`orchestration.tools.efficiency_map_figure`).

A point is ``reachable`` when its run finished and held its set-points over the window (speed and flux
within the margins of :mod:`satmotor.metrics`, neither limiter flag set at any sample); else ``why`` says
what missed (``holds_setpoints`` of the run's ``metrics.json``) or how the run ended: a row, not a failure.

Efficiency: motoring (``P_mech > 0``, ``P_in > 0``) ``P_mech / P_in``; generating (both negative)
``P_in / P_mech`` (electric power returned over shaft power taken); else (no shaft power, or the losses
exceed the power regenerated) NaN; NaN too at a point not reachable (its other columns are the means of
the run's window as it was).

Exit codes: 0 the map written (unreachable points included), 2 a bad argument or scenario (nothing run),
1 a point's run failed or the table could not be written, ``128 + signum`` interrupted (what finished
written).
"""

from __future__ import annotations

import contextlib
import copy
import io
import math
import sys
from pathlib import Path

import numpy as np
import yaml

FLUX_MODES = ("nominal", "loss_minimizing")
LOSSES = ("P_cu_s", "P_cu_r", "P_fe", "P_fw", "P_stray", "P_inv", "P_chop")
POWERS = (*LOSSES, "P_in", "P_mech")
#: the columns of efficiency_map.csv, in order
COLUMNS = ("speed", "torque", "flux_mode", "omega_m", "T_e", "psi_r", "i_s", "i_mu", "v_s", *POWERS,
           "efficiency", "reachable", "why", "status", "run")
LOAD_RAMP = (0.2, 0.4)  # [1] of the run time: T_load from 0 to the point's torque
WINDOW = 0.1  # [1] of the run time: the default averaging window
WINDOW_ROWS = 100  # recorded rows the window holds at least (record.interval chosen so)
#: the result of a point without metrics.json: {interrupted: ...}
NOT_RUN = {True: {"status": "interrupted", "message": "not run: the map was interrupted"},
           False: {"status": "not run", "message": "no results: its run did not start"}}


class ArgumentError(ValueError):
    """A bad argument: the message names it and its value (exit 2)."""


def parse_grid(text, name):
    """``FROM:TO:N`` -> N values from FROM to TO, both ends included (N = 1: FROM alone); refused
    (:class:`ArgumentError` naming ``name`` and ``text``) when malformed or N < 1."""
    parts = str(text).split(":")
    if len(parts) != 3:
        raise ArgumentError(f"{name} {text!r}: expected FROM:TO:N (e.g. 0:150:6)")
    try:
        lo, hi = float(parts[0]), float(parts[1])
    except ValueError:
        raise ArgumentError(f"{name} {text!r}: FROM and TO must be numbers") from None
    try:
        n = int(parts[2])
    except ValueError:
        raise ArgumentError(f"{name} {text!r}: N must be an integer >= 1") from None
    if n < 1:
        raise ArgumentError(f"{name} {text!r}: N must be an integer >= 1, not {n}")
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ArgumentError(f"{name} {text!r}: FROM and TO must be finite")
    return [lo] if n == 1 else [float(round(v, 12)) for v in np.linspace(lo, hi, n)]


def parse_modes(text):
    """``--flux-mode nominal,loss_minimizing`` -> the list (each once, in order); an unknown one refused."""
    modes = [m.strip() for m in str(text).split(",")]
    bad = [m for m in modes if m not in FLUX_MODES]
    if bad or not modes:
        raise ArgumentError(f"--flux-mode {text!r}: unknown flux mode {bad[0] if bad else ''!r} "
                            f"(one or more of {', '.join(FLUX_MODES)}, comma-separated)")
    return list(dict.fromkeys(modes))


def _absolute_files(data, base_dir):
    """The file references of a scenario mapping (``table_file``, csv profiles' ``file``) made absolute:
    the generated sweep files live elsewhere."""
    if isinstance(data, dict):
        for k, v in data.items():
            if k in ("table_file", "file") and isinstance(v, str) and not Path(v).is_absolute():
                data[k] = str((base_dir / v).resolve())
            else:
                _absolute_files(v, base_dir)
    elif isinstance(data, list):
        for v in data:
            _absolute_files(v, base_dir)


def sweep_mapping(base, base_dir, mode, speeds, torques, stop_time, window):
    """The sweep scenario (parsed YAML) of one flux mode: ``base`` (the scenario file's mapping) with the
    point's profiles, recording and window, its grid varying the speed (outer) and the torque (inner)."""
    data = copy.deepcopy(base)
    for key in ("sweep", "acceptance", "description", "measurements"):
        data.pop(key, None)
    _absolute_files(data, Path(base_dir))
    step = float(data.get("step", 1.0e-4))
    data["name"] = f"efficiency_map-{mode}"
    data["stop_time"] = stop_time
    data["controller"] = {**(data.get("controller") or {}), "flux_mode": mode}
    profiles = data.setdefault("profiles", {})
    profiles["omega_ref"] = {"type": "constant", "value": speeds[0]}
    profiles["T_load"] = {"type": "ramp", "start": round(LOAD_RAMP[0] * stop_time, 12),
                          "end": round(LOAD_RAMP[1] * stop_time, 12), "from": 0.0, "to": torques[0]}
    every = max(1, int(window / WINDOW_ROWS / step))
    data["record"] = {"level": "full", "interval": every * step,
                      "outputs": [f"plant.{p}" for p in POWERS] + ["plant.omega_m", "plant.T_e"]}
    data["acceptance"] = {"ss_window": [round(stop_time - window, 12), stop_time]}
    data["sweep"] = {"parameters": {"profiles.omega_ref.value": list(speeds),
                                    "profiles.T_load.to": list(torques)}}
    return data


def write_sweeps(scenario, out, modes, speeds, torques, stop_time=None, window=None):
    """Write one sweep file per flux mode under ``OUT/scenarios/``; returns ``(files, stop_time, window)``.
    Raises :class:`ArgumentError` for a scenario that cannot be read or a bad time or window."""
    path = Path(scenario)
    try:
        base = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise ArgumentError(f"SCENARIO {str(path)!r}: cannot be read: {exc}") from None
    if not isinstance(base, dict):
        raise ArgumentError(f"SCENARIO {str(path)!r}: not a scenario mapping")
    stop_time = float(base.get("stop_time", 1.0)) if stop_time is None else float(stop_time)
    if not stop_time > 0:
        raise ArgumentError(f"--time {stop_time!r}: must be > 0 [s]")
    window = WINDOW * stop_time if window is None else float(window)
    if not 0 < window < (1 - LOAD_RAMP[1]) * stop_time:
        raise ArgumentError(f"--window {window!r}: must be > 0 and below the {1 - LOAD_RAMP[1]:.0%} of "
                            f"--time after the load ramp ({(1 - LOAD_RAMP[1]) * stop_time:g} s)")
    folder = Path(out) / "scenarios"
    folder.mkdir(parents=True, exist_ok=True)
    files = []
    for mode in modes:
        f = folder / f"efficiency_map-{mode}.yaml"
        data = sweep_mapping(base, path.parent, mode, speeds, torques, stop_time, window)
        f.write_text(yaml.safe_dump(data, sort_keys=False))
        files.append(f)
    return files, stop_time, window


def efficiency(p_mech, p_in):
    """Motoring ``P_mech / P_in``, generating ``P_in / P_mech``, else NaN (module docstring)."""
    if p_mech > 0 and p_in > 0:
        return p_mech / p_in
    if p_mech < 0 and p_in < 0:
        return p_in / p_mech
    return float("nan")


def window_means(frame, t_from):
    """The point's quantities averaged over the rows at ``time >= t_from`` of a run's time series."""
    w = frame[frame["time"] >= t_from - 1e-12]

    def mean(col):
        return float(w[col].mean()) if col in w and len(w) else float("nan")

    def amplitude(a, b):
        return float(np.hypot(w[a], w[b]).mean()) if a in w and b in w and len(w) else float("nan")

    row = {p: mean(f"plant.{p}") for p in POWERS}
    row.update(omega_m=mean("plant.omega_m"), T_e=mean("plant.T_e"), i_mu=mean("plant.i_mu"),
               psi_r=amplitude("plant.psi_r_alpha", "plant.psi_r_beta"),
               i_s=amplitude("plant.i_s_alpha", "plant.i_s_beta"),
               v_s=amplitude("controller.v_s_alpha", "controller.v_s_beta"))
    row["efficiency"] = efficiency(row["P_mech"], row["P_in"])
    return row


def gather(runs, modes, speeds, torques, stop_time, window, interrupted=False):
    """The rows of the map from the runs under ``runs`` (``OUT/runs``): a row per point and mode, a
    point without results saying why (``interrupted``: the map was stopped before it ran)."""
    import json

    import pandas as pd

    rows = []
    for mode in modes:
        name = f"efficiency_map-{mode}"
        width = len(str(len(speeds) * len(torques) - 1))
        for i, (speed, torque) in enumerate((s, t) for s in speeds for t in torques):
            run = Path(runs) / name / f"{name}-{i:0{width}d}"
            row = {"speed": speed, "torque": torque, "flux_mode": mode, "run": str(run),
                   **{c: float("nan") for c in COLUMNS[3:-5]}}
            try:
                summary = json.loads((run / "metrics.json").read_text())
            except (OSError, ValueError):
                summary = NOT_RUN[bool(interrupted)]
            status = summary.get("status", "unknown")
            row["status"] = status
            if status in ("ok", "interrupted"):
                try:
                    row.update(window_means(pd.read_parquet(run / "timeseries.parquet"), stop_time - window))
                except (OSError, ValueError) as exc:
                    status, summary = "failed", {"message": f"its time series cannot be read: {exc}"}
            held = summary.get("holds_setpoints")
            row["reachable"] = bool(status == "ok" and held is True)
            if not row["reachable"]:  # the means of a run that did not hold its point: no efficiency of it
                row["efficiency"] = float("nan")
            row["why"] = ("" if row["reachable"] else summary.get("setpoints") or summary.get("message")
                          or f"run {status}")
            rows.append(row)
    return pd.DataFrame(rows, columns=list(COLUMNS))


def run_map(run_batch, scenario, out, speeds, torques, modes, fmu_dir, jobs=2, stop=None, stop_time=None,
            window=None, plot=True, variant="native", command=None):
    """Run the map; write the table and figure; returns the exit code (module docstring).
    ``run_batch``: the batch that runs the points (:func:`orchestration.cli.batch.run_batch`, given by
    the command line above this package)."""
    from orchestration.process.interrupts import StopRequest

    stop = stop or StopRequest()
    out = Path(out)
    try:
        files, stop_time, window = write_sweeps(scenario, out, modes, speeds, torques, stop_time, window)
    except OSError as exc:
        print(f"--out {out}: cannot write the results: {exc}", file=sys.stderr)
        return 2
    from orchestration.scenario.load import ScenarioError
    from orchestration.scenario.variants import load_sweep

    for f in files:  # every point checked before any runs (as batch would, but refusing the map)
        try:
            load_sweep(f)
        except ScenarioError as exc:
            print(f"efficiency-map: SCENARIO {str(scenario)!r}: its points are invalid:", file=sys.stderr)
            for p in exc.problems:
                print(f"  {p}", file=sys.stderr)
            return 2
    screen = io.StringIO()  # batch's table of every point: the map's own table replaces it
    with contextlib.redirect_stdout(screen):
        code = run_batch([str(f) for f in files], out / "runs", fmu_dir, jobs=jobs, stop=stop,
                         variant=variant, command=command, plot=False)
    if code == 2 and not (out / "runs" / "summary.csv").exists():  # refused before anything ran (--out)
        return 2
    table = gather(out / "runs", modes, speeds, torques, stop_time, window, bool(stop.signum))
    try:
        table.to_csv(out / "efficiency_map.csv", index=False)
        table.to_parquet(out / "efficiency_map.parquet", index=False)
    except OSError as exc:
        print(f"--out {out}: cannot write the table: {exc}", file=sys.stderr)
        return 1
    written = [out / "efficiency_map.csv", out / "efficiency_map.parquet"]
    if plot and len(table):
        from orchestration.tools.efficiency_map_figure import draw

        written.append(draw(table, out / "efficiency_map.png", LOSSES))
    n_ok = int(table["reachable"].sum())
    print(f"efficiency map: {len(table)} points, {n_ok} reachable, {len(table) - n_ok} not")
    for p in written:
        print(p)
    if stop.signum:
        return stop.exit_code
    failed = table["status"].isin(("failed", "not run", "unknown")).any()
    return 1 if failed else 0
