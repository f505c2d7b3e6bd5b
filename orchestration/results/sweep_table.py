"""A sweep's results in one place: ``OUT/<sweep name>/sweep.csv`` and ``sweep.parquet`` (a row per
variant: its name and index, the varied parameters, how its run ended, every metric) and
``sweep.png`` (each metric against each varied parameter for a grid, each metric's histogram for a
Monte Carlo sweep).

A variant that did not run to the end is a row too, with its status and the reason (``message``)
and no metric; the table is written whatever happened to the runs (the batch calls
:func:`write_sweep` after an interrupt as well).  The metrics come from each variant's
``metrics.json`` (:mod:`orchestration.results.writer`), read only for a run that reported one.
Each file is written to a temporary name first and renamed: a table on disk is complete.
"""

from __future__ import annotations

import json
import math
import textwrap
from pathlib import Path

from orchestration.results import atomic

__all__ = ["FILES", "sweep_frame", "write_sweep", "figure"]

FILES = ("sweep.csv", "sweep.parquet", "sweep.png")
ROW_KEYS = ("status", "exit_code", "accepted", "holds_setpoints")  # from the batch's row of a variant
_NO_METRICS = ("invalid",)  # statuses whose run wrote no metrics.json of its own


def _metrics(directory, row):
    if row is None or row.get("status") in _NO_METRICS:
        return {}
    try:
        data = json.loads((Path(directory) / row["scenario"] / "metrics.json").read_text())
    except (OSError, ValueError):
        return {}
    return data.get("metrics") or {} if data.get("status") != "running" else {}


def sweep_frame(sweep, rows, directory, file=None):
    """The table of ``sweep`` (a :class:`orchestration.scenario.sweep.Sweep`) as a DataFrame:
    ``rows`` the batch's rows (those of its variants are picked by name, and by ``file`` when
    given), ``directory`` where the variants wrote their results."""
    import pandas as pd

    mine = {r["scenario"]: r for r in rows if file is None or r.get("file") == str(file)}
    records, metric_names = [], []
    for v in sweep.variants:
        row = mine.get(v.name)
        metrics = _metrics(directory, row)
        metric_names += [k for k in metrics if k not in metric_names]
        rec = {"variant": v.name, "index": v.index, **dict(v.values)}
        rec.update({k: (row or {}).get(k) for k in ROW_KEYS})
        if row is None:
            rec.update(status="interrupted", exit_code=0)
        rec.update(metrics)
        rec["wall_time"] = (row or {}).get("wall_time")
        rec["message"] = (row or {}).get("message", "no result: the batch was interrupted") or ""
        records.append(rec)
    columns = ["variant", "index", *sweep.parameters, *ROW_KEYS, *metric_names, "wall_time", "message"]
    df = pd.DataFrame(records, columns=columns)
    for p in sweep.parameters:  # a column of mixed kinds (numbers and names) is written as text
        kinds = {isinstance(x, (int, float)) and not isinstance(x, bool) for x in df[p]}
        if len(kinds) > 1:
            df[p] = df[p].astype(str)
    for c in metric_names:
        df[c] = pd.to_numeric(df[c], errors="coerce")
    return df


def _replace(path, write):
    """``write(file object)`` into a temporary file renamed onto ``path`` when complete
    (:func:`orchestration.results.atomic.atomic_file`: nothing half-written is ever at ``path``)."""
    with atomic.atomic_file(path, "wb") as f:
        write(f)


def write_sweep(sweep, rows, directory, plot=True, file=None):
    """Write the table (CSV, Parquet) and, ``plot`` True, the figure of ``sweep`` into
    ``directory``; returns the paths written."""
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    df = sweep_frame(sweep, rows, d, file)
    paths = [d / FILES[0], d / FILES[1]]
    _replace(paths[0], lambda f: df.to_csv(f, index=False))
    _replace(paths[1], lambda f: df.to_parquet(f, index=False))
    for stale in (d / FILES[2],):
        stale.unlink(missing_ok=True)
    if plot and figure(df, sweep, d / FILES[2]):
        paths.append(d / FILES[2])
    return paths


def sweep_name(df):
    """The sweep's name: its variants' names without the index."""
    return str(df["variant"].iloc[0]).rpartition("-")[0] if len(df) else ""


def _finite(values):
    return [x for x in values if isinstance(x, (int, float)) and math.isfinite(x)]


def figure(df, sweep, path):
    """Draw ``sweep.png``: a grid's metric against each varied parameter (a point per variant that
    has the metric), a Monte Carlo sweep's metric histograms.  False when no metric has a finite
    value (nothing to draw)."""
    skip = {"variant", "index", *sweep.parameters, *ROW_KEYS, "wall_time", "message"}
    metrics = [c for c in df.columns if c not in skip and _finite(df[c].tolist())]
    same = [m for m in metrics if len(set(_finite(df[m].tolist()))) == 1]  # said in the title, not drawn
    metrics = [m for m in metrics if m not in same] or metrics
    if not metrics:
        return False
    said = f"the same in every variant: {', '.join(same)}" if same and metrics != same else ""
    width = 3.4 * len(sweep.parameters) if sweep.kind == "grid" else 3.2 * min(4, len(metrics))
    said = "\n" + textwrap.fill(said, int(width * 13)) if said else ""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if sweep.kind != "grid":  # draws: Monte Carlo, a sensitivity design
        ncol = min(4, len(metrics))
        nrow = math.ceil(len(metrics) / ncol)
        fig, axes = plt.subplots(nrow, ncol, figsize=(3.2 * ncol, 2.4 * nrow), squeeze=False)
        for ax, m in zip(axes.flat, metrics):
            ax.hist(_finite(df[m].tolist()), bins=min(30, max(5, len(df) // 3)), color="tab:blue")
            ax.set_title(m, fontsize=9)
            ax.tick_params(labelsize=7)
        for ax in list(axes.flat)[len(metrics):]:
            ax.axis("off")
        varied = ", ".join(sweep.parameters)
        fig.suptitle(f"{sweep_name(df)}: {len(df)} draws (seed {sweep.seed}) of {varied}: the metrics' "
                     f"distributions{said}", fontsize=10)
    else:
        ncol = len(sweep.parameters)
        fig, axes = plt.subplots(len(metrics), ncol, figsize=(3.4 * ncol, 1.9 * len(metrics)), squeeze=False)
        for i, m in enumerate(metrics):
            for j, p in enumerate(sweep.parameters):
                ax = axes[i][j]
                ok = df[m].notna()
                ax.plot(df[p][ok].tolist(), df[m][ok].tolist(), "o", ms=4, color="tab:blue")
                if j == 0:
                    ax.set_ylabel(m, fontsize=8)
                if i == len(metrics) - 1:
                    ax.set_xlabel(p, fontsize=9)
                ax.tick_params(labelsize=7)
        fig.suptitle(f"{sweep_name(df)}: {len(df)} variants, each metric against each varied parameter{said}",
                     fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 1 - (0.3 + 0.17 * said.count(chr(10))) / fig.get_figheight()))
    _replace(path, lambda f: fig.savefig(f, dpi=90, format="png"))
    plt.close(fig)
    return True
