"""Benchmark of the libcosim engine (orchestration.libcosim_engine) against our fmpy master.

Run ``python bench/bench_libcosim.py [--repeats N] [--out FILE]``; prints a table and writes it to
FILE (default: print only).  The default scenario (``scenarios/ramp_rated_load.yaml``: 1.5 s at
h = Ts = 100 us, 15 000 steps of each FMU), all runs Jacobi, in memory, measured alternately in
one process, best of N (default 5):

* libcosim, native FMUs, stepping only, no observer: ``CosimExecution.step`` over the whole run
  on the engine's ``OspSystemStructure.xml`` (what libcosim and the FMUs cost, nothing recorded);
* libcosim, native FMUs, stepping and recording: the engine's loop (time-series and file
  observers, samples read per chunk into rows), without the set-up;
* libcosim, native FMUs, the whole ``libcosim_engine.run`` (pre-flight initialization, loading the
  system, stepping, recording), the ScenarioSignals FMU built beforehand (its build, a C compile,
  is timed once apart);
* the fmpy master (``orchestration.master.run``, ``wall_time``) with the native FMUs and with the
  pythonfmu FMUs.

Real-time factor = simulated time / wall time.  The libcosim run is checked against the master's.
"""

from __future__ import annotations

import argparse
import math
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from orchestration import fmus, libcosim_engine  # noqa: E402
from orchestration.master import run as master_run  # noqa: E402
from orchestration.recorder import Recorder  # noqa: E402
from orchestration.scenario import load_scenario  # noqa: E402
from orchestration.signals_fmu import build as build_signals  # noqa: E402

SCENARIO = ROOT / "scenarios" / "ramp_rated_load.yaml"


def libcosim_parts(sc, plant, ctrl, signals, work):
    """(stepping without observers [s], stepping and recording [s]) of one run each."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

    log_output_level(CosimLogLevel.ERROR)
    fmus_ = {"plant": plant, "controller": ctrl, "signals": signals}
    outputs = {k: libcosim_engine._Outputs(p) for k, p in fmus_.items()}
    structure = libcosim_engine.system_structure(sc, fmus_, work, libcosim_engine._types_of(outputs))
    n = round(sc.stop_time / sc.step)
    ex = CosimExecution.from_osp_config_file(str(structure))
    t0 = time.perf_counter()
    assert ex.step(n)
    bare = time.perf_counter() - t0
    del ex
    columns = ["c"] * 32
    e = libcosim_engine._Execution(sc, structure, outputs, work)
    rec = Recorder(columns)
    t0 = time.perf_counter()
    status = e.simulate(rec, libcosim_engine._NoStop())
    e.close(rec)
    recorded = time.perf_counter() - t0
    assert status[0] == "ok" and rec.n_rows + len(rec.rows) == n + 1, status
    return bare, recorded


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--fmus", default=str(ROOT / "build" / "fmus"))
    ap.add_argument("--out", help="also write the table to this file")
    args = ap.parse_args()
    sc = load_scenario(SCENARIO)
    native = list(map(str, fmus.paths(args.fmus, "native")))
    python = list(map(str, fmus.paths(args.fmus, "python")))
    with tempfile.TemporaryDirectory(prefix="bench_libcosim_") as tmp:
        work = Path(tmp)
        t0 = time.perf_counter()
        signals = str(build_signals(sc, work / "signals"))
        t_build = time.perf_counter() - t0
        best = {k: math.inf for k in ("bare", "recorded", "engine", "master_native", "master_python")}
        for _ in range(args.repeats):
            bare, recorded = libcosim_parts(sc, *native, signals, work)
            best["bare"], best["recorded"] = min(best["bare"], bare), min(best["recorded"], recorded)
            got = libcosim_engine.run(sc, *native, signals_fmu=signals)
            assert got.ok, got.message
            best["engine"] = min(best["engine"], got.wall_time)
            ref = master_run(sc, *native, algorithm="jacobi")
            best["master_native"] = min(best["master_native"], ref.wall_time)
            py = master_run(sc, *python, algorithm="jacobi")
            best["master_python"] = min(best["master_python"], py.wall_time)
    a, b = ref.frame, got.frame
    worst = max(np.max(np.abs(a[c].to_numpy() - b[c].to_numpy()))
                / max(np.max(np.abs(a[c].to_numpy())), 1e-300) for c in a.columns)
    T, n = sc.stop_time, round(sc.stop_time / sc.step)
    rows = [("libcosim + native, stepping only, no observer", best["bare"]),
            ("libcosim + native, stepping + recording (engine loop)", best["recorded"]),
            ("libcosim + native, whole libcosim_engine.run", best["engine"]),
            ("fmpy master + native (wall_time)", best["master_native"]),
            ("fmpy master + pythonfmu (wall_time)", best["master_python"])]
    lines = [f"bench_libcosim: {sc.name}, {T} s simulated, {n} steps of h = {sc.step} s, Jacobi, in memory; "
             f"best of {args.repeats}, alternating, one process",
             f"machine: {platform.machine()}, {platform.python_version()}, "
             f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}",
             "", f"{'run':58s} {'wall [s]':>9s} {'us/step':>8s} {'real-time factor':>17s}"]
    for name, wall in rows:
        lines.append(f"{name:58s} {wall:9.3f} {wall / n * 1e6:8.1f} {T / wall:17.1f}")
    lines += ["", f"ScenarioSignals FMU build (C compile, once per scenario): {t_build:.2f} s",
              f"largest |libcosim - master| / column scale, every column: {worst:.2e}",
              f"whole engine vs fmpy master + native: {best['master_native'] / best['engine']:.2f}x; "
              f"vs fmpy master + pythonfmu: {best['master_python'] / best['engine']:.2f}x"]
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        Path(args.out).write_text(text)


if __name__ == "__main__":
    main()
