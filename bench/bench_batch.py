"""Benchmark of ``batch`` on the scenario library: scenarios per minute with 1 and 2 jobs, and the
overhead a scenario pays for running in its own process.

Run ``python bench/bench_batch.py``; prints the numbers and replaces its own section of
``bench/RESULTS.md`` (between ``<!-- batch:start -->`` and ``<!-- batch:end -->``).

Both job counts run in this one session, one after the other (the FMUs are built first, once).
The overhead per scenario is what ``--jobs 1`` costs beyond the master's own ``wall_time`` of each
run (which includes FMU extraction and instantiation, the loop and the streamed files), divided by
the number of scenarios: process start, imports, scenario loading, metrics, figure and the batch's
own bookkeeping.
"""

from __future__ import annotations

import datetime
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd
from bench_plant import cpu_model, write_section

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from orchestration import fmus  # noqa: E402


def batch(jobs, fmu_dir, out):
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "orchestration", "batch", str(ROOT / "scenarios"), "--jobs",
                        str(jobs), "--out", str(out), "--fmus", str(fmu_dir)], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if r.returncode != 0:
        raise SystemExit(f"batch --jobs {jobs} failed ({r.returncode}): {r.stderr[-2000:]}")
    return wall, pd.read_csv(Path(out) / "summary.csv")


def main():
    with tempfile.TemporaryDirectory() as tmp:
        fmu_dir = Path(tmp) / "fmus"
        fmus.ensure(fmu_dir, quiet=True)
        runs = {jobs: batch(jobs, fmu_dir, Path(tmp) / f"out{jobs}") for jobs in (1, 2)}
    n = len(runs[1][1])
    wall1, summary1 = runs[1]
    inside = float(summary1["wall_time"].sum())
    lines = [
        "## Batch benchmark",
        "",
        f"Measured {datetime.date.today()}, Python {platform.python_version()}, CPU: {cpu_model()} "
        "(2 cores).",
        "",
        "| quantity | value |",
        "|---|---|",
        *(f"| `batch scenarios --jobs {jobs}` ({n} scenarios) | {wall:.1f} s, "
          f"**{60 * n / wall:.1f} scenarios per minute** |" for jobs, (wall, _) in runs.items()),
        f"| sum of the runs' own `wall_time` (master: extraction, instantiation, loop, files) | "
        f"{inside:.1f} s |",
        f"| **overhead per scenario beyond its run** (`--jobs 1`: process start, imports, loading, "
        f"metrics, figure, batch bookkeeping) | **{(wall1 - inside) / n:.2f} s** |",
        "",
        "Rerun with `python bench/bench_batch.py` (or `make bench`); it rewrites this section.",
    ]
    text = "\n".join(lines)
    print(text)
    write_section("batch", text)


if __name__ == "__main__":
    main()
