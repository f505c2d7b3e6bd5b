"""Benchmark of ``batch`` on the scenario library: scenarios per minute with 1 and 2 jobs, and the
overhead a scenario pays for running in its own process, with its parts.

Run ``python -m bench batch``; prints the numbers and replaces its own section of
``bench/RESULTS.md`` (between ``<!-- batch:start -->`` and ``<!-- batch:end -->``).
``--compare DIR`` also measures another checkout (its ``.venv``, its ``scenarios/`` and its FMUs
in ``DIR/build/fmus``) in the same rounds, alternating, so "before" and "after" see the same load;
``--variant`` picks the FMUs (default python); ``--no-write`` leaves RESULTS.md alone.

Per checkout and round: ``batch scenarios --jobs 1`` then ``--jobs 2`` (best of the rounds kept), in
wall time and in CPU time of the batch's whole process tree (``RUSAGE_CHILDREN``: steadier than the
wall time on a shared machine).
The overhead per scenario is what ``--jobs 1`` costs beyond the master's own ``wall_time`` of each
run (FMU extraction and instantiation, the loop and the streamed files), divided by the number of
scenarios: process start, imports, scenario loading, metrics, figure and the batch's bookkeeping.
Its parts are measured apart, each in a child process of the checkout's interpreter: Python
start-up (``-c pass``), the imports of the ``run`` command (start-up included), the extraction of
the two FMUs (inside ``wall_time``) and drawing the figure of the default scenario.  The results
must be identical between the job counts and the checkouts: the summary's metrics and every
scenario's ``timeseries.csv`` (SHA-256).
"""

from __future__ import annotations

import argparse
import datetime
import hashlib
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd

from bench.common import cpu_model, git_head, interpreter, write_section

ROOT = Path(__file__).resolve().parents[1]
IMPORTS = ("import orchestration.cli.commands, orchestration.run.master, orchestration.results.writer, "
           "orchestration.scenario.load, orchestration.results.plots, orchestration.process.interrupts, "
           "pyarrow.parquet")
METRICS = ("iae_speed", "iae_flux", "ss_speed", "ss_flux", "overshoot_speed", "settling_time_speed",
           "peak_current", "peak_voltage", "min_W")

# run with the measured checkout's interpreter, in its directory: extraction of the FMU pair, then the
# figure of a recorded run (argv: variant, a timeseries.parquet, a scratch directory)
PARTS = r"""
import json, sys, time
from orchestration.packaging import fmus
from orchestration.run.fmu_instance import extract_owned, remove_extracted
variant, parquet, scratch = sys.argv[1:4]
best = float("inf")
for _ in range(5):
    t0 = time.perf_counter()
    dirs = [extract_owned(p) for p in fmus.paths("build/fmus", variant)]
    best = min(best, time.perf_counter() - t0)
    for d in dirs:
        remove_extracted(d)
t0 = time.perf_counter()
from orchestration.results.plots import figure
t_import = time.perf_counter() - t0
import pyarrow.parquet as pq
with pq.ParquetFile(parquet) as f:
    table = f.read()
data = {c: table.column(c).to_numpy() for c in table.column_names}
fig = float("inf")
for _ in range(3):
    t0 = time.perf_counter()
    figure(data, scratch + "/figure.png", "bench")
    fig = min(fig, time.perf_counter() - t0)
print(json.dumps({"extract": best, "plots_import": t_import, "figure": fig}))
"""


def children_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def batch(root, jobs, out, variant):
    """(wall time, CPU time of the batch's whole process tree, summary, {scenario: CSV digest})."""
    c0, t0 = children_cpu(), time.perf_counter()
    r = subprocess.run([interpreter(root), "-m", "orchestration", "batch", "scenarios", "--jobs", str(jobs),
                        "--out", str(out), "--fmus", "build/fmus", "--variant", variant],
                       cwd=root, capture_output=True, text=True)
    wall, cpu = time.perf_counter() - t0, children_cpu() - c0
    if r.returncode not in (0, 3):  # 3: a scenario missed its acceptance bounds (a result, not a failure)
        raise SystemExit(f"{root}: batch --jobs {jobs} failed ({r.returncode}): {r.stderr[-2000:]}")
    summary = pd.read_csv(Path(out) / "summary.csv")
    digests = {}
    for name in summary["scenario"]:
        f = Path(out) / name / "timeseries.csv"
        digests[name] = hashlib.sha256(f.read_bytes()).hexdigest() if f.exists() else None
    return wall, cpu, summary, digests


def best_child(root, args, repeats=3):
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        subprocess.run([interpreter(root), *args], cwd=root, check=True, capture_output=True)
        best = min(best, time.perf_counter() - t0)
    return best


def parts(root, variant, parquet):
    with tempfile.TemporaryDirectory() as d:
        r = subprocess.run([interpreter(root), "-c", PARTS, variant, str(parquet), d], cwd=root,
                           capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"{root}: measuring the parts failed: {r.stderr[-2000:]}")
    out = json.loads(r.stdout.strip().splitlines()[-1])
    out["start"] = best_child(root, ["-c", "pass"])
    out["imports"] = best_child(root, ["-c", IMPORTS])
    return out


def same_results(a, b):
    """Whether two summaries hold the same rows and metrics (bit for bit) and the same CSV digests."""
    (sa, da), (sb, db) = a, b
    cols = ["scenario", "status", *[m for m in METRICS if m in sa.columns]]
    ka = sa[cols].sort_values("scenario").reset_index(drop=True)
    kb = sb[cols].sort_values("scenario").reset_index(drop=True)
    return ka.equals(kb) and da == db


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=1, help="alternating rounds (default 1)")
    ap.add_argument("--variant", default="python", help="FMU variant (default python)")
    ap.add_argument("--compare", metavar="DIR", help="another checkout to measure in the same rounds")
    ap.add_argument("--no-write", action="store_true", help="do not rewrite bench/RESULTS.md")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    from orchestration.packaging import fmus

    fmus.ensure(ROOT / "build" / "fmus", quiet=True)
    checkouts = {"this": ROOT}
    if args.compare:
        checkouts = {"before": Path(args.compare).resolve(), "this": ROOT}
    heads = {n: git_head(r) for n, r in checkouts.items()}
    load0 = os.getloadavg()[0]
    wall, cpu, results, part = {}, {}, {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.rounds):
            for jobs in (1, 2):
                for name, root in checkouts.items():
                    w, c, summary, digests = batch(root, jobs, Path(tmp) / f"{name}{jobs}-{r}", args.variant)
                    if w < wall.get((name, jobs), float("inf")):
                        wall[name, jobs], results[name, jobs] = w, (summary, digests)
                    cpu[name, jobs] = min(cpu.get((name, jobs), float("inf")), c)
                    print(f"round {r + 1}: {name} --jobs {jobs}: {w:.1f} s wall, {c:.1f} s CPU", flush=True)
        for name, root in checkouts.items():
            parquet = Path(tmp) / f"{name}1-0" / "ramp_rated_load" / "timeseries.parquet"
            part[name] = parts(root, args.variant, parquet)
    load1 = os.getloadavg()[0]
    first = results[next(iter(checkouts)), 1]
    identical = all(same_results(first, res) for res in results.values())
    names = list(checkouts)
    n = {name: len(results[name, 1][0]) for name in names}
    inside = {name: float(results[name, 1][0]["wall_time"].sum()) for name in names}
    over = {name: (wall[name, 1] - inside[name]) / n[name] for name in names}

    def row(label, fn):
        return f"| {label} | " + " | ".join(fn(name) for name in names) + " |"

    lines = [
        "## Batch benchmark",
        "",
        f"Measured {datetime.date.today()}, Python {platform.python_version()}, CPU: {cpu_model()} "
        f"({os.cpu_count()} cores, shared: load average {load0:.1f} at the start, {load1:.1f} at the end); "
        f"variant `{args.variant}`, best of {args.rounds} round(s)"
        + (", the checkouts alternating." if len(names) > 1 else "."),
        "",
        "| quantity | " + " | ".join(f"{name} `{heads[name]}`" for name in names) + " |",
        "|---|" + "---|" * len(names),
        *(row(f"`batch scenarios --jobs {jobs}`",
              lambda name, jobs=jobs: f"{wall[name, jobs]:.1f} s, **{60 * n[name] / wall[name, jobs]:.1f} "
              "scenarios per minute**") for jobs in (1, 2)),
        row("scenarios", lambda name: str(n[name])),
        row("each scenario's process", lambda name: "forked from a warm server (imports once per batch)"
            if (checkouts[name] / "orchestration" / "warm_children.py").exists()
            else "a fresh interpreter (imports per scenario)"),
        row("CPU time of the batch's process tree per scenario (`--jobs 1`)",
            lambda name: f"{cpu[name, 1] / n[name]:.2f} s"),
        row("sum of the runs' own `wall_time` (master: extraction, instantiation, loop, files)",
            lambda name: f"{inside[name]:.1f} s"),
        row("**overhead per scenario beyond its run** (`--jobs 1`)", lambda name: f"**{over[name]:.2f} s**"),
        row("part: Python start-up (`python -c pass`)", lambda name: f"{part[name]['start']:.3f} s"),
        row("part: imports of the `run` command (start-up included)",
            lambda name: f"{part[name]['imports']:.3f} s"),
        row("part: importing `orchestration.results.plots` (matplotlib) after the rest",
            lambda name: f"{part[name]['plots_import']:.3f} s"),
        row("part: drawing the figure (default scenario)", lambda name: f"{part[name]['figure']:.3f} s"),
        row(f"part: extracting the two `{args.variant}` FMUs (inside `wall_time`)",
            lambda name: f"{part[name]['extract']:.3f} s"),
        "",
        "Results identical between the job counts" + (" and the checkouts" if len(names) > 1 else "")
        + " (every metric of the summary, every `timeseries.csv` byte for byte): "
        + ("yes." if identical else "NO."),
        "",
        "Rerun with `python -m bench batch` (or `make bench`; `--compare DIR` adds another checkout); "
        "it rewrites this section.",
    ]
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        write_section("batch", text)
    return 0 if identical else 1


if __name__ == "__main__":
    sys.exit(main())
