"""Benchmark of a sweep: what ``batch`` costs for a 64-variant sweep recording the metrics only,
against the pure stepping of the same 64 runs in the same engine, measured side by side in one run.

Run ``python -m bench sweep``; prints the numbers and replaces its own section of
``bench/RESULTS.md`` (between ``<!-- sweep:start -->`` and ``<!-- sweep:end -->``; ``--no-write``
leaves it alone).  ``--variant`` picks the FMUs (default native, the fastest shipped path),
``--side`` the grid's side (default 8: 8 x 8 = 64 variants), ``--jobs`` batch's processes
(default 2), ``--rounds`` how many times each side is measured (best kept; default 1).

The sweep is the default scenario (``scenarios/ramp_rated_load.yaml``, 1.5 s, 15 001 steps) with
``sweep: {parameters: {motor.J: ..., controller.d1: ...}}``, a grid of ``side`` x ``side``, written
to a temporary directory.  The two sides, each in a child process of this checkout's interpreter:

* **stepping**: every variant loaded once, then run with :func:`orchestration.run.master.run` and a
  recorder that keeps nothing (the loop still builds its rows); the CPU time of the stepping loop
  alone (:func:`time.process_time` from the recorder's creation, right before the loop, to its
  close, right after) summed over the variants, and the CPU time of the whole ``run`` calls
  (extraction, instantiation, loop).
* **sweep**: ``batch SWEEP --no-plot --jobs J`` (``record: metrics``, the sweep's default), the CPU
  time of its whole process tree (``RUSAGE_CHILDREN``), and its wall time; once more without
  ``--no-plot`` (the sweep's figure, no figure per run since no series is kept).

The ratio asked for is sweep CPU / stepping-loop CPU.  Every variant of the sweep must end ``ok``.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

from bench.common import cpu_model, git_head, interpreter, write_section

ROOT = Path(__file__).resolve().parents[1]

# the stepping side (argv: sweep file, variant): the variants loaded, then each run with a recorder
# that keeps nothing and times its own life (the loop) in CPU time
STEPPING = r"""
import json, sys, time
from orchestration.packaging import fmus
from orchestration.run.master import run
from orchestration.results.recorder import Recorder
from orchestration.scenario.variants import load_sweep

class Null(Recorder):
    spans = []
    def __init__(self, columns):
        super().__init__(columns)
        self._t0 = time.process_time()
    def _chunk_array(self):
        self.n_seen += len(self.rows)
        return self.rows
    def _write(self, chunk):
        pass
    def close(self):
        self.flush()
        Null.spans.append(time.process_time() - self._t0)

path, variant = sys.argv[1:3]
_, sweep, variants = load_sweep(path)
plant, ctrl = map(str, fmus.paths("build/fmus", variant))
run_cpu, statuses = 0.0, []
w0 = time.perf_counter()
for v, sc in variants:
    c0 = time.process_time()
    res = run(sc, plant, ctrl, recorder=Null)
    run_cpu += time.process_time() - c0
    statuses.append(res.status)
print(json.dumps({"loop_cpu": sum(Null.spans), "run_cpu": run_cpu, "wall": time.perf_counter() - w0,
                  "runs": len(variants), "ok": statuses.count("ok")}))
"""


def children_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def sweep_file(directory, side):
    """The default scenario with a ``side`` x ``side`` grid over J and d1, written in ``directory``."""
    data = yaml.safe_load((ROOT / "scenarios" / "ramp_rated_load.yaml").read_text())
    data["name"] = "bench_sweep"
    data.pop("record", None)  # the sweep's default: record: metrics
    data["sweep"] = {"parameters": {
        "motor.J": {"start": 0.0131, "stop": 0.0262, "num": side},  # [kg m^2]
        "controller.d1": {"start": 60.0, "stop": 140.0, "num": side},  # [1/s]
    }}
    path = Path(directory) / "bench_sweep.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def stepping(path, variant):
    c0 = children_cpu()
    r = subprocess.run([interpreter(ROOT), "-c", STEPPING, str(path), variant], cwd=ROOT, capture_output=True,
                       text=True)
    if r.returncode != 0:
        raise SystemExit(f"the stepping side failed: {r.stderr[-2000:]}")
    out = json.loads(r.stdout.strip().splitlines()[-1])
    out["process_cpu"] = children_cpu() - c0
    return out


def batch(path, out, variant, jobs, plot):
    """(wall, CPU of the batch's process tree, number of ok variants)."""
    c0, t0 = children_cpu(), time.perf_counter()
    r = subprocess.run([interpreter(ROOT), "-m", "orchestration", "batch", str(path), "--jobs", str(jobs),
                        "--out", str(out), "--fmus", "build/fmus", "--variant", variant,
                        *([] if plot else ["--no-plot"])], cwd=ROOT, capture_output=True, text=True)
    wall, cpu = time.perf_counter() - t0, children_cpu() - c0
    if r.returncode not in (0, 3):
        raise SystemExit(f"batch failed ({r.returncode}): {r.stderr[-2000:]}")
    import pandas as pd

    table = pd.read_csv(Path(out) / "bench_sweep" / "sweep.csv")
    return wall, cpu, int((table["status"] == "ok").sum()), len(table)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--variant", default="native", help="FMU variant (default native)")
    ap.add_argument("--side", type=int, default=8, help="grid side: side x side variants (default 8)")
    ap.add_argument("--jobs", type=int, default=2, help="batch --jobs (default 2)")
    ap.add_argument("--rounds", type=int, default=1, help="rounds, best kept (default 1)")
    ap.add_argument("--no-write", action="store_true", help="do not rewrite bench/RESULTS.md")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    from orchestration.packaging import fmus

    fmus.ensure(ROOT / "build" / "fmus", quiet=True)
    load0 = os.getloadavg()
    best = {}
    with tempfile.TemporaryDirectory() as tmp:
        path = sweep_file(tmp, args.side)
        for r in range(args.rounds):
            s = stepping(path, args.variant)
            b = batch(path, Path(tmp) / f"noplot{r}", args.variant, args.jobs, plot=False)
            f = batch(path, Path(tmp) / f"plot{r}", args.variant, args.jobs, plot=True)
            print(f"round {r + 1}: stepping loop {s['loop_cpu']:.2f} s CPU (run calls {s['run_cpu']:.2f} s, "
                  f"process {s['process_cpu']:.2f} s); batch --no-plot {b[1]:.2f} s CPU, {b[0]:.2f} s wall; "
                  f"batch {f[1]:.2f} s CPU, {f[0]:.2f} s wall", flush=True)
            if s["ok"] != s["runs"] or b[2] != b[3] or f[2] != f[3]:
                raise SystemExit(f"not every variant ran ok: stepping {s['ok']}/{s['runs']}, "
                                 f"batch {b[2]}/{b[3]}, {f[2]}/{f[3]}")
            for key, value in (("loop", s["loop_cpu"]), ("run", s["run_cpu"]),
                               ("step_proc", s["process_cpu"]), ("step_wall", s["wall"]), ("b_cpu", b[1]),
                               ("b_wall", b[0]), ("f_cpu", f[1]), ("f_wall", f[0])):
                best[key] = min(best.get(key, float("inf")), value)
    load1 = os.getloadavg()
    n = args.side ** 2
    ratio = best["b_cpu"] / best["loop"]
    lines = [
        "## Sweep benchmark",
        "",
        f"Measured {datetime.date.today()} at `{git_head(ROOT)}`, Python {platform.python_version()}, CPU: "
        f"{cpu_model()} ({os.cpu_count()} cores, shared: load average {load0[0]:.2f} {load0[1]:.2f} "
        f"{load0[2]:.2f} at the start, {load1[0]:.2f} {load1[1]:.2f} {load1[2]:.2f} at the end); variant "
        f"`{args.variant}`, {n} variants of the default scenario (1.5 s, 15 001 steps each; a grid over "
        f"`motor.J` and `controller.d1`), `batch --jobs {args.jobs}`, best of {args.rounds} round(s).",
        "",
        "| quantity | CPU [s] | per variant [ms] | wall [s] |",
        "|---|---|---|---|",
        f"| pure stepping: the master's loop, recorder keeping nothing (sum of {n}) | {best['loop']:.2f} | "
        f"{1e3 * best['loop'] / n:.1f} | - |",
        f"| the same {n} `master.run` calls (extraction, instantiation, loop) | {best['run']:.2f} | "
        f"{1e3 * best['run'] / n:.1f} | {best['step_wall']:.2f} |",
        "| **`batch` of the sweep, `record: metrics`, `--no-plot`** (whole process tree) | "
        f"**{best['b_cpu']:.2f}** | {1e3 * best['b_cpu'] / n:.1f} | {best['b_wall']:.2f} |",
        f"| `batch` of the sweep with its figure (`sweep.png`) | {best['f_cpu']:.2f} | "
        f"{1e3 * best['f_cpu'] / n:.1f} | {best['f_wall']:.2f} |",
        "",
        f"**Sweep / pure stepping (CPU): {ratio:.2f}x** (target: at most 1.3x); against the whole `run` "
        f"calls: {best['b_cpu'] / best['run']:.2f}x; with the figure: {best['f_cpu'] / best['loop']:.2f}x.",
        "",
        "Rerun with `python -m bench sweep`; it rewrites this section.",
    ]
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        write_section("sweep", text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
