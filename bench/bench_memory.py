"""Benchmark of memory against simulated time: the peak resident memory of ``run`` for the default
scenario over 1.5 s and over 600 s, both recording every row to disk (``record: full``), side by side.

Run ``python -m bench memory``; prints the numbers and replaces its own section of
``bench/RESULTS.md`` (``--no-write`` leaves it alone).  ``--long`` sets the long run's simulated time
(default 600 s), ``--variant`` the FMUs (default native), ``--compare DIR`` measures another checkout
(its ``.venv``) in the same run, with this checkout's FMUs (``--no-build``).

Both runs are ``scenarios/ramp_rated_load.yaml`` (the ramp to 100 rad/s, the rated-load step at
1 s, then steady state) with ``stop_time`` changed, ``record.interval`` 1 ms (every 10th step: the
600 s run writes 600 001 rows, within the recording bound), ``acceptance.ss_window`` at the end of
the run, and the figure.  Each ``run`` is a child process; its process tree (the run, its figure
helper) is sampled every 20 ms with psutil: the peak of the tree's summed RSS, and the peak of the
largest single process.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import psutil
import yaml

from bench.common import cpu_model, git_head, interpreter, write_section

ROOT = Path(__file__).resolve().parents[1]


def scenario(directory, stop_time):
    data = yaml.safe_load((ROOT / "scenarios" / "ramp_rated_load.yaml").read_text())
    data["name"] = f"memory_{stop_time:g}s".replace(".", "_")
    data["stop_time"] = float(stop_time)
    data["record"] = {"interval": 1.0e-3}  # level full, the default (a checkout from before levels reads it)
    data["acceptance"]["ss_window"] = [float(stop_time) - 0.2, float(stop_time)]
    path = Path(directory) / f"{data['name']}.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def measure(root, path, out, variant):
    """(peak summed RSS of the run's process tree [MB], peak RSS of its largest process [MB],
    wall [s], rows)."""
    t0 = time.perf_counter()
    p = subprocess.Popen([interpreter(root), "-m", "orchestration", "run", str(path), "--out", str(out),
                          "--fmus", str(ROOT / "build" / "fmus"), "--no-build", "--variant", variant],
                         cwd=root, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    proc, peak, single = psutil.Process(p.pid), 0, 0
    while p.poll() is None:
        try:
            rss = [q.memory_info().rss for q in [proc, *proc.children(recursive=True)]]
            peak, single = max(peak, sum(rss)), max(single, *rss)
        except psutil.Error:
            pass
        time.sleep(0.02)
    stdout, stderr = p.communicate()
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise SystemExit(f"{root}: run {path.name} failed ({p.returncode}): {stderr[-2000:]}")
    rows = int(stdout.split(" rows,")[0].rsplit(" ", 1)[-1])
    return peak / 2**20, single / 2**20, wall, rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--long", type=float, default=600.0, help="the long run's stop time [s] (default 600)")
    ap.add_argument("--variant", default="native", help="FMU variant (default native)")
    ap.add_argument("--compare", metavar="DIR", help="another checkout, measured in the same run")
    ap.add_argument("--no-write", action="store_true", help="do not rewrite bench/RESULTS.md")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    from orchestration.packaging import fmus

    fmus.ensure(ROOT / "build" / "fmus", quiet=True)
    checkouts = {"this": ROOT} if not args.compare else {"before": Path(args.compare).resolve(), "this": ROOT}
    load0 = os.getloadavg()
    res = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, root in checkouts.items():
            for stop in (1.5, args.long):  # the short one first: ru_maxrss only grows
                res[name, stop] = measure(root, scenario(tmp, stop), Path(tmp) / name, args.variant)
                tree, largest, wall, rows = res[name, stop]
                print(f"{name} {stop:g} s: tree peak {tree:.0f} MB, largest process {largest:.0f} MB, "
                      f"{rows} rows, {wall:.1f} s wall", flush=True)
    load1 = os.getloadavg()
    lines = [
        "## Memory benchmark",
        "",
        f"Measured {datetime.date.today()}, Python {platform.python_version()}, CPU: {cpu_model()} "
        f"({os.cpu_count()} cores, shared: load average {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f} at the "
        f"start, {load1[0]:.2f} {load1[1]:.2f} {load1[2]:.2f} at the end); `run` of the default scenario, "
        f"variant `{args.variant}`, `record: {{level: full, interval: 1.0e-3}}` (every row on disk), figure "
        "drawn.",
        "",
        "| checkout | simulated | rows on disk | peak RSS, run + figure helper [MB] | peak RSS, largest "
        "process [MB] | wall [s] |",
        "|---|---|---|---|---|---|",
    ]
    for name in checkouts:
        for stop in (1.5, args.long):
            tree, largest, wall, rows = res[name, stop]
            lines.append(f"| {name} `{git_head(checkouts[name])}` | {stop:g} s | {rows} | {tree:.0f} | "
                         f"{largest:.0f} | {wall:.1f} |")
    lines.append("")
    for name in checkouts:
        a, b = res[name, 1.5], res[name, args.long]
        lines.append(f"* {name}: **{args.long:g} s / 1.5 s peak RSS: {b[0] / a[0]:.2f}x** (run + helper), "
                     f"{b[1] / a[1]:.2f}x (largest process); target at most 1.2x.")
    lines += ["", "Rerun with `python -m bench memory`; it rewrites this section."]
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        write_section("memory", text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
