"""Batch runs: one process per scenario, locally (a process pool of ``jobs``) or on a Dask cluster.

Each scenario runs as ``python -m orchestration run FILE --no-build`` in its own process (pythonfmu
FMUs share one interpreter per process, so a fresh process per scenario keeps runs independent);
its exit code and ``metrics.json`` make its row of the summary.  A failing scenario is reported
and the others complete; the batch exits with the largest exit code.
"""

from __future__ import annotations

import json
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor, as_completed
from pathlib import Path

import pandas as pd

from . import fmus

SUMMARY_METRICS = ("iae_speed", "iae_flux", "ss_speed", "ss_flux", "overshoot_speed", "settling_time_speed",
                   "peak_current", "peak_voltage", "min_W")


def collect(items):
    """Scenario files from files and directories (their ``*.yaml``, sorted)."""
    out = []
    for item in items:
        p = Path(item)
        out.extend(sorted(p.glob("*.yaml")) if p.is_dir() else [p])
    return out


def run_one(path, out, fmu_dir, algorithm=None):
    """Run one scenario in a child process; returns the summary row (a dict).  Never raises."""
    path, out, fmu_dir = Path(path).resolve(), Path(out).resolve(), Path(fmu_dir).resolve()
    cmd = [sys.executable, "-m", "orchestration", "run", str(path), "--out", str(out), "--fmus", str(fmu_dir),
           "--no-build"]
    if algorithm:
        cmd += ["--algorithm", algorithm]
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=fmus.ROOT)
    row = {"file": str(path), "exit_code": proc.returncode}
    try:
        name = _scenario_name(path)
        summary = json.loads((Path(out) / name / "metrics.json").read_text()) if name else None
    except (OSError, ValueError):
        summary = None
    if summary is None or proc.returncode == 2:
        lines = (proc.stderr or proc.stdout).strip().splitlines()
        row.update(scenario=Path(path).stem, status="invalid" if proc.returncode == 2 else "failed",
                   message=" | ".join(lines[-6:]))
        return row
    row.update(scenario=summary["scenario"], status=summary["status"], message=summary["message"],
               accepted=summary["accepted"], wall_time=summary["wall_time"],
               **{k: summary["metrics"].get(k) for k in SUMMARY_METRICS})
    return row


def _scenario_name(path):
    from .scenario import ScenarioError, load_scenario

    try:
        return load_scenario(path).name
    except ScenarioError:
        return None


def _progress(total):
    try:
        from tqdm import tqdm

        return tqdm(total=total, unit="scenario", file=sys.stderr)
    except ImportError:  # pragma: no cover - tqdm is a dependency
        return None


def run_batch(items, out, fmu_dir, jobs=2, scheduler=None, algorithm=None):
    """Run every scenario of ``items``; write ``out/summary.csv``; return the exit code."""
    files = collect(items)
    if not files:
        print("no scenario files found", file=sys.stderr)
        return 2
    Path(out).mkdir(parents=True, exist_ok=True)
    fmus.ensure(fmu_dir, quiet=True)  # once, before any worker starts
    bar = _progress(len(files))
    rows = []
    if scheduler:
        from distributed import Client
        from distributed import as_completed as dask_completed

        with Client(scheduler) as client:
            futures = client.map(run_one, [str(f) for f in files], out=str(Path(out).resolve()),
                                 fmu_dir=str(Path(fmu_dir).resolve()), algorithm=algorithm, pure=False)
            for fut in dask_completed(futures):
                rows.append(fut.result())
                bar and bar.update(1)
    else:
        with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:  # each task runs a child process
            futures = [pool.submit(run_one, f, out, fmu_dir, algorithm) for f in files]
            for fut in as_completed(futures):
                rows.append(fut.result())
                bar and bar.update(1)
    bar and bar.close()
    df = pd.DataFrame(rows).sort_values("file").reset_index(drop=True)
    df.to_csv(Path(out) / "summary.csv", index=False)
    shown = [c for c in ("scenario", "status", "accepted", *SUMMARY_METRICS, "wall_time") if c in df]
    print(df[shown].to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    for r in rows:
        if r["exit_code"] != 0:
            print(f"FAILED {r['file']} (exit {r['exit_code']}): {r.get('message', '')}", file=sys.stderr)
    print(f"summary: {Path(out) / 'summary.csv'}")
    return max(r["exit_code"] for r in rows)
