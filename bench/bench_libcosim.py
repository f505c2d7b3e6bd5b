"""Benchmark of the libcosim engine (orchestration.run.libcosim_engine) against our fmpy master.

Run ``python bench/bench_libcosim.py [--repeats N] [--out FILE] [--no-write]``; prints a table,
writes it to FILE if given, and rewrites its section of ``bench/RESULTS.md`` (between
``<!-- libcosim:start -->`` and ``<!-- libcosim:end -->``) unless ``--no-write``.
The default scenario (``scenarios/ramp_rated_load.yaml``: 1.5 s at
h = Ts = 100 us, 15 000 steps of each FMU), all runs Jacobi, in memory, measured alternately in
one process, best of N (default 5):

* libcosim, native FMUs, stepping only, no observer: ``CosimExecution.step`` over the whole run
  on the engine's ``SystemStructure.ssd`` (what libcosim and the FMUs cost, nothing recorded),
  twice: with libcosim's default pool of (hardware threads - 1) worker threads (no
  ``numWorkerThreads``: how the engine ran before) and with none (``numWorkerThreads="0"``, the
  engine's setting: every unit stepped in the calling thread);
* the same with the engine's observers attached (a time-series observer on every Real and Integer
  output, a file observer on the controller's Booleans) and nothing read: libcosim's own cost of
  recording;
* libcosim, native FMUs, stepping and recording: the engine's loop (the observers, samples read
  per chunk into rows), without the set-up;
* libcosim, native FMUs, the whole ``libcosim_engine.run`` (pre-flight initialization, loading the
  system, stepping, recording), the ScenarioSignals FMU built beforehand (its build, a C compile,
  is timed once apart);
* the same whole run with the pythonfmu FMUs;
* the fmpy master (``orchestration.run.master.run``, ``wall_time``) with the native FMUs and with the
  pythonfmu FMUs;
* the native plant FMU alone, stepped by a C host without Python (the physics' floor).

Real-time factor = simulated time / wall time.  The libcosim run is checked against the master's.
The context switches per step of the process's threads show libcosim's thread pool at work.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from orchestration.build import fmus  # noqa: E402
from orchestration.build.signals_fmu import build as build_signals  # noqa: E402
from orchestration.run import libcosim_engine  # noqa: E402
from orchestration.run.master import run as master_run  # noqa: E402
from orchestration.run.recorder import Recorder  # noqa: E402
from orchestration.scenario.load import load_scenario  # noqa: E402

SCENARIO = ROOT / "scenarios" / "ramp_rated_load.yaml"


def context_switches():
    """(voluntary + involuntary context switches of every thread of this process, threads)."""
    tasks = list(Path(f"/proc/{os.getpid()}/task").glob("*"))
    total = 0
    for t in tasks:
        for line in (t / "status").read_text().splitlines():
            if "ctxt_switches" in line:
                total += int(line.split()[1])
    return total, len(tasks)


def libcosim_parts(sc, plant, ctrl, signals, work):
    """{part: wall seconds} of one run each, and {pool: context switches per step} of the stepping."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

    from orchestration.build.ssd import ssd_xml

    log_output_level(CosimLogLevel.ERROR)
    fmus_ = {"plant": plant, "controller": ctrl, "signals": signals}
    outputs = {k: libcosim_engine._Outputs(p) for k, p in fmus_.items()}
    structure = libcosim_engine.system_structure(sc, fmus_, outputs, work)
    pooled = work / "pooled.ssd"  # libcosim's default thread pool: no numWorkerThreads
    pooled.write_bytes(ssd_xml(sc, {u: o.md for u, o in outputs.items()}, worker_threads=None,
                               sources={u: Path(f).resolve().as_uri() for u, f in fmus_.items()}))
    n = round(sc.stop_time / sc.step)
    out, switches = {}, {}
    for name, ssd in (("pooled", pooled), ("bare", structure)):
        ex = CosimExecution.from_ssp_file(str(ssd))
        assert ex.step(1)  # initialization
        c0 = context_switches()[0]
        t0 = time.perf_counter()
        assert ex.step(n)
        out[name] = time.perf_counter() - t0
        switches[name] = ((context_switches()[0] - c0) / n, context_switches()[1])
        del ex
    columns = ["c"] * 32
    e = libcosim_engine._Execution(sc, structure, outputs, work)
    assert e.ex.step(1)
    t0 = time.perf_counter()
    assert e.ex.step(n)  # the observers record, nothing is read
    out["observed"] = time.perf_counter() - t0
    e.ex = e.observer = e.file_obs = None
    e = libcosim_engine._Execution(sc, structure, outputs, work)
    rec = Recorder(columns)
    t0 = time.perf_counter()
    status = e.simulate(rec, libcosim_engine._NoStop())
    e.close(rec)
    out["recorded"] = time.perf_counter() - t0
    assert status[0] == "ok" and rec.n_rows + len(rec.rows) == n + 1, status
    return out, switches


def plant_floor(plant, work):
    """Wall seconds per step of the native plant FMU alone, stepped by a C host with no Python
    (``tests/native_c_host.c``, constant inputs): the difference of 20 000 and 2 000 steps, so
    process start and instantiation cancel; best of 3.  None when gcc is missing."""
    import shutil
    import subprocess
    import zipfile

    from fmpy import __file__ as fmpy_file
    from fmpy import read_model_description

    if shutil.which("gcc") is None:
        return None
    host = work / "host"
    subprocess.run(["gcc", "-std=c99", "-O2", f"-I{Path(fmpy_file).parent / 'c-code'}",
                    str(ROOT / "tests" / "native_c_host.c"), "-o", str(host), "-ldl"], check=True)
    with zipfile.ZipFile(plant) as z:
        z.extractall(work / "plant")
    md = read_model_description(plant)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    lib = work / "plant" / "binaries" / "linux64" / f"{md.coSimulation.modelIdentifier}.so"

    def wall(steps):
        inputs = [f"{vr['v_s_alpha']}=150", f"{vr['v_s_beta']}=-40", f"{vr['T_load']}=5"]
        args = [str(host), str(lib), md.guid, (work / "plant" / "resources").as_uri(), str(steps), "1e-4",
                *inputs, "--", str(vr["omega_m"])]
        t0 = time.perf_counter()
        subprocess.run(args, check=True, capture_output=True)
        return time.perf_counter() - t0

    return min((wall(20_000) - wall(2_000)) / 18_000 for _ in range(3))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--fmus", default=str(ROOT / "build" / "fmus"))
    ap.add_argument("--out", help="also write the table to this file")
    ap.add_argument("--no-write", action="store_true", help="do not rewrite bench/RESULTS.md")
    args = ap.parse_args()
    sc = load_scenario(SCENARIO)
    native = list(map(str, fmus.paths(args.fmus, "native")))
    python = list(map(str, fmus.paths(args.fmus, "python")))
    with tempfile.TemporaryDirectory(prefix="bench_libcosim_") as tmp:
        work = Path(tmp)
        t0 = time.perf_counter()
        signals = str(build_signals(sc, work / "signals"))
        t_build = time.perf_counter() - t0
        floor = plant_floor(native[0], work)
        best = {k: math.inf for k in ("pooled", "bare", "observed", "recorded", "engine", "engine_python",
                                      "master_native", "master_python")}
        for _ in range(args.repeats):
            parts, switches = libcosim_parts(sc, *native, signals, work)
            best.update({k: min(best[k], v) for k, v in parts.items()})
            got = libcosim_engine.run(sc, *native, signals_fmu=signals)
            assert got.ok, got.message
            best["engine"] = min(best["engine"], got.wall_time)
            ref = master_run(sc, *native, algorithm="jacobi")
            best["master_native"] = min(best["master_native"], ref.wall_time)
            py = master_run(sc, *python, algorithm="jacobi")
            best["master_python"] = min(best["master_python"], py.wall_time)
            got_py = libcosim_engine.run(sc, *python, signals_fmu=signals)
            assert got_py.ok, got_py.message
            best["engine_python"] = min(best["engine_python"], got_py.wall_time)
    a, b = ref.frame, got.frame
    worst = max(np.max(np.abs(a[c].to_numpy() - b[c].to_numpy()))
                / max(np.max(np.abs(a[c].to_numpy())), 1e-300) for c in a.columns)
    T, n = sc.stop_time, round(sc.stop_time / sc.step)
    rows = [("libcosim + native, stepping only, default thread pool", best["pooled"]),
            ("libcosim + native, stepping only, no worker thread", best["bare"]),
            ("libcosim + native, stepping + observers, nothing read", best["observed"]),
            ("libcosim + native, stepping + recording (engine loop)", best["recorded"]),
            ("libcosim + native, whole libcosim_engine.run", best["engine"]),
            ("libcosim + pythonfmu, whole libcosim_engine.run", best["engine_python"]),
            ("fmpy master + native (wall_time)", best["master_native"]),
            ("fmpy master + pythonfmu (wall_time)", best["master_python"])]
    lines = [f"bench_libcosim: {sc.name}, {T} s simulated, {n} steps of h = {sc.step} s, Jacobi, in memory; "
             f"best of {args.repeats}, alternating, one process",
             f"machine: {platform.machine()}, {platform.python_version()}, "
             f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}",
             "", f"{'run':58s} {'wall [s]':>9s} {'us/step':>8s} {'real-time factor':>17s}"]
    for name, wall in rows:
        lines.append(f"{name:58s} {wall:9.3f} {wall / n * 1e6:8.1f} {T / wall:17.1f}")
    if floor is not None:
        lines.append(f"{'native plant FMU alone, C host, no Python (floor)':58s} {'':9s} {floor * 1e6:8.1f} "
                     f"{sc.step / floor:17.1f}")
    lines += ["", "libcosim stepping, context switches per step (threads in the process): default pool "
              f"{switches['pooled'][0]:.1f} ({switches['pooled'][1]}), no worker thread "
              f"{switches['bare'][0]:.2f} ({switches['bare'][1]})",
              "(the default pool has hardware threads - 1 workers; the engine sets numWorkerThreads = 0)",
              f"ScenarioSignals FMU build (C compile, once per scenario): {t_build:.2f} s",
              f"largest |libcosim - master| / column scale, every column: {worst:.2e}",
              f"speed of the whole engine relative to the fmpy master, same FMUs: native "
              f"{best['master_native'] / best['engine']:.2f}x, pythonfmu "
              f"{best['master_python'] / best['engine_python']:.2f}x"]
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        Path(args.out).write_text(text)
    if not args.no_write:
        from bench_plant import write_section

        write_section("libcosim", "## libcosim engine against the fmpy master (`bench/bench_libcosim.py`)\n\n"
                      "Generated by `python bench/bench_libcosim.py`; what each row measures is in the "
                      "script's docstring. Real-time factor = simulated time / wall time.\n\n"
                      f"```\n{text}```")


if __name__ == "__main__":
    main()
