"""The compiled stepping engine (``run --engine c``) against the fmpy master and the C floor, side by side.

Run ``python -m bench c_engine [--rounds N] [--no-write]``; prints a table and rewrites its
section of ``bench/RESULTS.md`` (between ``<!-- c_engine:start -->`` and ``<!-- c_engine:end -->``)
unless ``--no-write``.  The default scenario (``scenarios/ramp_rated_load.yaml``: 1.5 s at h = Ts =
100 us, 15 000 steps) with ``record: metrics``, one process, rounds alternating, best of N (default 5)
and the median, CPU (``time.process_time``; the floor: ``getrusage`` of its process) and wall time per
step, the load average before and after:

* the fmpy master, Gauss-Seidel, native FMI 2.0, the whole ``master.run`` (extraction, instantiation,
  the loop, the metrics);
* the c engine (``orchestration.run.c_engine.run``), the same whole run, native FMI 2.0 and FMI 3.0;
* the C floor (``bench/floor_master.c``, built by ``bench/bench_floor.py``'s helper): the native FMI 2.0
  plant and controller stepped Gauss-Seidel with constant set-points, nothing recorded, the loop only;
* the ``run --engine c --no-plot`` command as a whole process (start-up, imports, the run,
  ``metrics.json``): CPU of the child.

The metrics of the c engine's runs are checked equal to the fmpy master's (every digit).
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import os
import platform
import statistics
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.bench_engines import command, metrics_of, timed  # noqa: E402
from bench.common import cpu_model, git_head, write_section  # noqa: E402
from bench.floor_host import build_floor, floor_args, run_floor, unit  # noqa: E402
from orchestration.packaging import fmus  # noqa: E402
from orchestration.results.writer import streaming_recorder  # noqa: E402
from orchestration.run import c_engine  # noqa: E402
from orchestration.run.master import run as master_run  # noqa: E402
from orchestration.scenario.load import load_scenario  # noqa: E402

SCENARIO = ROOT / "scenarios" / "ramp_rated_load.yaml"
ROWS = [("floor", "C floor master (native FMI 2.0, Gauss-Seidel, constant set-points, nothing recorded)"),
        ("fmpy", "fmpy master, native FMI 2.0, whole run"),
        ("c", "**c engine, native FMI 2.0, whole run**"),
        ("c_fmi3", "c engine, native FMI 3.0, whole run"),
        ("command_c", "`run --engine c --no-plot` command, whole process")]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--fmus", default=str(ROOT / "build" / "fmus"))
    ap.add_argument("--no-write", action="store_true", help="do not rewrite bench/RESULTS.md")
    a = ap.parse_args(argv)
    full = load_scenario(SCENARIO)
    sc = dataclasses.replace(full, record=dataclasses.replace(full.record, level="metrics"))
    n = round(sc.stop_time / sc.step)
    fmi2 = list(map(str, fmus.paths(a.fmus, "native")))
    fmi3 = list(map(str, fmus.paths(a.fmus, "native-fmi3")))
    c_engine.stepper.library()  # compiled (once per source) before anything is timed
    load0 = os.getloadavg()
    cpu, wall, same = {}, {}, True
    with tempfile.TemporaryDirectory(prefix="bench_c_engine_") as tmp:
        work = Path(tmp)
        floor_exe = build_floor(work)
        floor_units = unit(fmi2[0], work), unit(fmi2[1], work)
        yaml = work / f"{sc.name}.yaml"  # the default scenario at record: metrics, for the run command
        yaml.write_text(SCENARIO.read_text().replace("record:", "record:\n  level: metrics", 1))

        def keep(name, c, w):
            cpu.setdefault(name, []).append(c)
            wall.setdefault(name, []).append(w)

        for r in range(a.rounds):
            _, c, w = run_floor(floor_args(floor_exe, *floor_units, n, "floor"))
            keep("floor", c, w)
            got = {}
            for name, run, paths in (("fmpy", master_run, fmi2), ("c", c_engine.run, fmi2),
                                     ("c_fmi3", c_engine.run, fmi3)):
                c, w, res = timed(lambda run=run, paths=paths: run(sc, *paths,
                                                                   recorder=streaming_recorder(sc, work)))
                assert res.ok, res.message
                keep(name, c, w)
                got[name] = metrics_of(res)
            same &= got["c"] == got["fmpy"] == got["c_fmi3"]
            keep("command_c", *command(yaml, work / "out", a.fmus, "--engine", "c"))
            print(f"round {r + 1}/{a.rounds}: "
                  + ", ".join(f"{k} {min(v) / n * 1e6:.2f}" for k, v in cpu.items())
                  + " us/step CPU (best so far)", flush=True)
    load1 = os.getloadavg()
    best = {k: min(v) / n * 1e6 for k, v in cpu.items()}
    med = {k: statistics.median(v) / n * 1e6 for k, v in cpu.items()}
    bw = {k: min(v) / n * 1e6 for k, v in wall.items()}
    f = best["floor"]
    table = ["| run | CPU per step [us] best (median) | wall per step [us] | CPU / floor "
             "| fmpy / this (CPU) |",
             "|---|---|---|---|---|"]
    for key, label in ROWS:
        table.append(f"| {label} | {best[key]:.2f} ({med[key]:.2f}) | {bw[key]:.2f} | {best[key] / f:.2f}x | "
                     f"{best['fmpy'] / best[key]:.2f}x |")
    env = (f"{datetime.date.today().isoformat()}, `{git_head(ROOT)}`, Python {platform.python_version()}, "
           f"CPU: {cpu_model()} ({os.cpu_count()} cores, shared), "
           f"load average {load0[0]:.2f} -> {load1[0]:.2f}")
    text = f"""## The compiled engine against the fmpy master and the C floor (`bench/bench_c_engine.py`)

{env}.  The default scenario at `record: metrics`, {n} steps, best of {a.rounds} alternating rounds (median
in brackets); the floor runs the same number of steps with constant set-points.  The c engine's metrics
{'equal' if same else '**differ from**'} the fmpy master's, FMI 2.0 and 3.0.

{chr(10).join(table)}
"""
    print(text)
    if not a.no_write:
        write_section("c_engine", text)
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
