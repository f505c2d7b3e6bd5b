"""The compiled engines (libcosim, Ecos) against the project's master and the C floor, side by side.

Run ``python -m bench engines [--rounds N] [--no-write]``; prints a table and rewrites its
section of ``bench/RESULTS.md`` (between ``<!-- engines:start -->`` and ``<!-- engines:end -->``)
unless ``--no-write``.  The default scenario (``scenarios/ramp_rated_load.yaml``: 1.5 s at
h = Ts = 100 us, 15 000 steps) with ``record: metrics`` (the metrics computed as the run goes from
the columns they read, no time series kept), native FMI 2.0 FMUs, one process, rounds alternating,
best of N (default 5) per row, CPU time (``time.process_time``) and wall time per step, the load
average before and after:

* the fmpy master, Gauss-Seidel (what users run) and Jacobi, whole ``master.run`` (extraction,
  instantiation, the loop, the metrics);
* ``libcosim_engine.run``: the whole run (the system written, libcosim loading it, stepping,
  the RowRecorder's rows read and the metrics), the ScenarioSignals and RowRecorder FMUs built
  beforehand (cached by the engine);
* the same run with libcosim's observers instead of the RowRecorder (how the engine recorded
  before; every output);
* libcosim's parts, on the lean copies the engine loads (:mod:`orchestration.run.lean_fmu`):
  loading the system (``CosimExecution.from_ssp_file``) and freeing it; stepping the three units
  only; stepping with the RowRecorder (nothing read);
* Ecos (``ecospy``; its extra and Debian's ``libtbb12``), on packages of the same lean copies:
  stepping the three units only; with the RowRecorder; the whole run (loading the package,
  stepping, the rows read, the metrics); and stepping the three units with a Python listener that
  reads the recorded outputs by name after every step (ecospy's only way to see values as the run
  goes).  Ecos steps the units with a TBB ``parallel_for`` per step (its
  ``ecos::simulation::Impl::step``), which its C API cannot turn off;
* the C floor (``bench/floor_master.c`` of ``bench/bench_floor.py``, built here with cc): the native
  plant and controller stepped Gauss-Seidel in C with constant set-points, nothing recorded;
* the whole ``run`` command, a process of its own (start-up, imports, the run, ``metrics.json``;
  ``--no-plot``), with the default engine and with ``--engine libcosim``: CPU of the child process.

The metrics of every engine run are compared with the Jacobi master's, printed as ``run`` prints
them (``%.6g``).
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import math
import os
import platform
import re
import resource
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.common import cpu_model, git_head, write_section  # noqa: E402
from bench.floor_host import build_floor, floor_args, run_floor, unit  # noqa: E402
from orchestration.packaging import fmus  # noqa: E402
from orchestration.packaging.native.recorder_fmu import recorder_fmu_for  # noqa: E402
from orchestration.packaging.ssd import RESOURCES, ssd_xml  # noqa: E402
from orchestration.results.recorder import MetricsOnly  # noqa: E402
from orchestration.results.running import MetricsObserver  # noqa: E402
from orchestration.results.writer import streaming_recorder  # noqa: E402
from orchestration.run import libcosim_engine, row_recorder  # noqa: E402
from orchestration.run.lean_fmu import lean_fmu  # noqa: E402
from orchestration.run.master import run as master_run  # noqa: E402
from orchestration.scenario.load import load_scenario  # noqa: E402

SCENARIO = ROOT / "scenarios" / "ramp_rated_load.yaml"
CHUNK = 200  # base steps between two reads of the rows, as the libcosim engine (CHUNK_TIME / h)


def timed(f):
    """``(cpu, wall, value)`` of ``f()`` [s]."""
    c0, w0 = time.process_time(), time.perf_counter()
    value = f()
    return time.process_time() - c0, time.perf_counter() - w0, value


def lean_system(native, signals, work):
    """{unit: lean copy} of the plant, controller and signals FMUs, as the libcosim engine loads them."""
    units = ("plant", "controller", "signals")
    return {u: lean_fmu(p, work / "lean") for u, p in zip(units, (*native, signals))}


def metrics_of(result):
    return result.recorder.metrics_observer.metrics.result()


class Ecos:
    """The scenario as an Ecos package with the RowRecorder: every component's parameter set named
    ``scenario`` (Ecos applies one named set at initialization), the FMUs stored uncompressed."""

    def __init__(self, sc, native, signals, recorder, work):
        import ecospy

        ecospy.EcosLib.set_log_level("warn")
        self.eco, self.sc, self.work = ecospy, sc, work
        fm = lean_system(native, signals, work)
        recorder = lean_fmu(recorder, work / "lean")
        outs = {u: libcosim_engine._Outputs(p) for u, p in fm.items()}
        outputs = {u: [(n, o.types[n]) for n, _ in o.real + o.integer + o.boolean] for u, o in outs.items()}
        self.columns, self.sources = row_recorder.columns_for(sc, outputs, "signals")
        self.rows_file = work / "ecos_rows.bin"
        mds = {u: o.md for u, o in outs.items()}
        plain = ssd_xml(sc, mds)
        with_rows = row_recorder.add_to_ssd(plain, sc, self.sources, "resources/RowRecorder.fmu",
                                            self.rows_file, CHUNK)
        named = (rb'ParameterSet version="1.0" name="[^"]*"', b'ParameterSet version="1.0" name="scenario"')
        plain, with_rows = (re.sub(*named, x) for x in (plain, with_rows))
        self.bare, self.package = work / "bare.ssp", work / "rows.ssp"
        for path, ssd in ((self.bare, plain), (self.package, with_rows)):
            with zipfile.ZipFile(path, "w", zipfile.ZIP_STORED) as z:
                z.writestr("SystemStructure.ssd", ssd)
                for u, f in fm.items():
                    z.write(f, RESOURCES[u])
                z.write(recorder, "resources/RowRecorder.fmu")
        self.steps = row_recorder.steps_needed(sc)

    def stepping(self, package):
        """CPU [s] of stepping the whole run (loading and initialization excluded)."""
        with self.eco.EcosSimulation(ssp_path=str(package), step_size=self.sc.step) as sim:
            assert sim.init(parameter_set="scenario")
            c0 = time.process_time()
            sim.step(self.steps)
            return time.process_time() - c0

    def listener_stepping(self):
        """CPU [s] of stepping the three units with a Python listener (ecospy's ``SimulationListener``,
        a ctypes callback after every step) reading the recorded outputs one by one by name, as the
        Python API offers them (what the RowRecorder replaces); the values are dropped."""
        eco = self.eco
        getters = []
        with eco.EcosSimulation(ssp_path=str(self.bare), step_size=self.sc.step) as sim:
            kinds = {"Real": sim.get_real, "Integer": sim.get_integer, "Boolean": sim.get_bool}
            getters = [(kinds[t], f"{u}::{n}") for u, n, t in self.sources]

            class Reader(eco.SimulationListener):
                def post(self, info):
                    for get, name in getters:
                        get(name)

            sim.add_listener("reader", Reader())
            assert sim.init(parameter_set="scenario")
            c0 = time.process_time()
            sim.step(self.steps)
            return time.process_time() - c0

    def run(self):
        """The whole run: load, step in chunks, the rows read into the running metrics."""
        rec = MetricsOnly(self.columns, observer=MetricsObserver(self.columns, self.sc))
        with self.eco.EcosSimulation(ssp_path=str(self.package), step_size=self.sc.step) as sim:
            assert sim.init(parameter_set="scenario")
            rows = row_recorder.Rows(self.rows_file, self.sc, self.sources)
            done = 0
            while done < self.steps:
                k = min(CHUNK, self.steps - done)
                sim.step(k)
                done += k
                for row in rows.table():
                    rec.append(row)
        rec.close()
        return rec.observer.metrics.result()


def libcosim_parts(sc, native, signals, recorder, work):
    """CPU [s] of libcosim's load + free, stepping three units, stepping with the RowRecorder."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

    log_output_level(CosimLogLevel.ERROR)
    fm = lean_system(native, signals, work)
    recorder = lean_fmu(recorder, work / "lean")
    outs = {u: libcosim_engine._Outputs(p) for u, p in fm.items()}
    outputs = {u: [(n, o.types[n]) for n, _ in o.real + o.integer + o.boolean] for u, o in outs.items()}
    _, sources = row_recorder.columns_for(sc, outputs, "signals")
    bare = libcosim_engine.system_structure(sc, fm, outs, work)
    rows = work / "SystemStructureRows.ssd"
    uri = Path(recorder).resolve().as_uri()
    rows.write_bytes(row_recorder.add_to_ssd(bare.read_bytes(), sc, sources, uri, work / "rows.bin", CHUNK))
    steps = row_recorder.steps_needed(sc)
    out = {}
    for name, path in (("bare", bare), ("rows", rows)):
        c0 = time.process_time()
        ex = CosimExecution.from_ssp_file(str(path))
        c1 = time.process_time()
        assert ex.step(steps)
        c2 = time.process_time()
        del ex
        c3 = time.process_time()
        out[f"libcosim_step_{name}"] = c2 - c1
        out[f"libcosim_load_{name}"] = (c1 - c0) + (c3 - c2)
    return out


def observed_run(sc, native, signals, work):
    """libcosim_engine's run with libcosim's observers (every output), as the engine recorded
    before the RowRecorder: CPU [s]."""
    fm = {"plant": native[0], "controller": native[1], "signals": signals}

    def system(w):
        return fm, lambda outputs: libcosim_engine.system_structure(sc, fm, outputs, w)

    c0 = time.process_time()
    res = libcosim_engine._run(sc, system, None, None, None, libcosim_engine.CHUNK_TIME, rows_cache=None)
    assert res.ok, res.message
    return time.process_time() - c0, res.wall_time


def command(yaml, out, fmu_dir, *extra):
    """(CPU, wall) [s] of one whole ``run`` command (a new process: start-up, imports, the run, the
    files), CPU of the child from ``getrusage``."""
    args = [sys.executable, "-m", "orchestration", "run", str(yaml), "--out", str(out),
            "--fmus", str(fmu_dir), "--no-build", "--no-plot", *extra]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    w0 = time.perf_counter()
    done = subprocess.run(args, cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - w0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode not in (0, 3):  # 3: acceptance missed, still a complete run
        raise SystemExit(f"run {' '.join(extra)} failed ({done.returncode}): {done.stderr}")
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), wall


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--fmus", default=str(ROOT / "build" / "fmus"))
    ap.add_argument("--no-ecos", action="store_true", help="leave Ecos out")
    ap.add_argument("--no-write", action="store_true", help="do not rewrite bench/RESULTS.md")
    a = ap.parse_args(argv)
    full = load_scenario(SCENARIO)
    sc = dataclasses.replace(full, record=dataclasses.replace(full.record, level="metrics"))
    n = round(sc.stop_time / sc.step)
    native = list(map(str, fmus.paths(a.fmus, "native")))
    load0 = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="bench_engines_") as tmp:
        work = Path(tmp)
        signals = str(libcosim_engine.signals_fmu_for(sc, work / "signals"))
        recorder = recorder_fmu_for(work / "recorder")
        floor_exe = build_floor(work)
        floor_units = unit(native[0], work), unit(native[1], work)
        eco = None
        if not a.no_ecos:
            try:
                eco = Ecos(sc, native, signals, recorder, work)
            except (ImportError, OSError) as exc:
                print(f"Ecos left out: {exc}")
        yaml = work / f"{sc.name}.yaml"  # the default scenario at record: metrics, for the run command
        yaml.write_text(SCENARIO.read_text().replace("record:", "record:\n  level: metrics", 1))
        cpu, wall = {}, {}
        got = {}

        def keep(name, c, w):
            cpu[name], wall[name] = min(cpu.get(name, math.inf), c), min(wall.get(name, math.inf), w)

        for _ in range(a.rounds):
            for name, algorithm in (("master_gs", None), ("master_jacobi", "jacobi")):
                c, w, r = timed(lambda alg=algorithm: master_run(sc, *native, algorithm=alg,
                                                                 recorder=streaming_recorder(sc, work)))
                assert r.ok, r.message
                keep(name, c, w)
                got[name] = metrics_of(r)
            c, w, r = timed(lambda: libcosim_engine.run(sc, *native, signals_fmu=signals,
                                                        recorder=streaming_recorder(sc, work),
                                                        recorder_cache=work / "recorder"))
            assert r.ok, r.message
            keep("libcosim", c, w)
            got["libcosim"] = metrics_of(r)
            keep("libcosim_observed", *observed_run(full, native, signals, work))
            for k, v in libcosim_parts(sc, native, signals, recorder, work).items():
                keep(k, v, math.inf)
            if eco is not None:
                keep("ecos_step_bare", eco.stepping(eco.bare), math.inf)
                keep("ecos_step_rows", eco.stepping(eco.package), math.inf)
                keep("ecos_step_listener", eco.listener_stepping(), math.inf)
                c, w, m = timed(eco.run)
                keep("ecos", c, w)
                got["ecos"] = m
            _, c, w = run_floor(floor_args(floor_exe, *floor_units, n, "floor"))
            keep("floor", c, w)
            keep("command_fmpy", *command(yaml, work / "out", a.fmus, "--variant", "native"))
            keep("command_libcosim", *command(yaml, work / "out", a.fmus, "--engine", "libcosim"))
    load1 = os.getloadavg()
    us = {k: v / n * 1e6 for k, v in cpu.items()}
    uw = {k: (v / n * 1e6 if math.isfinite(v) else math.nan) for k, v in wall.items()}
    rows = [("floor", "C floor master (native, Gauss-Seidel, constant set-points, nothing recorded)"),
            ("master_gs", "fmpy master, Gauss-Seidel, whole run"),
            ("master_jacobi", "fmpy master, Jacobi, whole run"),
            ("libcosim", "**libcosim engine, whole run (RowRecorder)**"),
            ("libcosim_observed", "libcosim engine with libcosim's observers, every output (before)"),
            ("libcosim_load_rows", "libcosim: loading the system and freeing it (4 units)"),
            ("libcosim_step_bare", "libcosim: stepping 3 units only"),
            ("libcosim_step_rows", "libcosim: stepping 3 units + the RowRecorder, nothing read"),
            ("ecos", "Ecos, whole run (RowRecorder)"),
            ("ecos_step_bare", "Ecos: stepping 3 units only"),
            ("ecos_step_rows", "Ecos: stepping 3 units + the RowRecorder, nothing read"),
            ("ecos_step_listener", "Ecos: stepping 3 units, a Python listener reading those outputs by name"),
            ("command_fmpy", "`run --variant native` command, whole process, fmpy master (Gauss-Seidel)"),
            ("command_libcosim", "`run --engine libcosim` command, whole process")]
    f = us["floor"]
    table = ["| run | CPU per step [us] | wall per step [us] | CPU / floor | fmpy GS / this (CPU) "
             "| fmpy Jacobi / this (CPU) |", "|---|---|---|---|---|---|"]
    for key, label in rows:
        if key not in us:
            continue
        wtext = f"{uw[key]:.2f}" if math.isfinite(uw[key]) else "-"
        table.append(f"| {label} | {us[key]:.2f} | {wtext} | {us[key] / f:.2f}x | "
                     f"{us['master_gs'] / us[key]:.2f}x | {us['master_jacobi'] / us[key]:.2f}x |")
    ref = got["master_jacobi"]
    agree = []
    for key in ("libcosim", "ecos"):
        if key in got:
            diff = [k for k in ref if f"{ref[k]:.6g}" != f"{got[key][k]:.6g}"]
            agree.append(f"{key}: {len(ref) - len(diff)} of {len(ref)} metrics print as the Jacobi master's"
                         + (f" (differ: {', '.join(diff)})" if diff else ""))
    gs = got["master_gs"]
    same_gs = sum(f"{gs[k]:.6g}" == f"{ref[k]:.6g}" for k in ref)
    now = datetime.datetime.now(datetime.timezone.utc)
    env = (f"{now:%Y-%m-%d %H:%M} UTC, commit {git_head(ROOT)}, Python "
           f"{platform.python_version()}, CPU: {cpu_model()} ({os.cpu_count()} logical), load average "
           f"{load0[0]:.2f} -> {load1[0]:.2f}")
    text = f"""## Compiled engines against the fmpy master and the C floor (`bench/bench_engines.py`)

Measured {env}. Scenario {sc.name} ({sc.stop_time} s, {n} steps of h = Ts = {sc.step} s) with
`record: metrics`, native FMI 2.0 FMUs; best of {a.rounds} alternating rounds per row, one process.
The floor master runs the same number of steps with constant set-points.

{chr(10).join(table)}

Agreement: {'; '.join(agree)}. (The Gauss-Seidel master's metrics are another coupling:
{same_gs} of {len(ref)} print the same.)

Rerun with `python -m bench engines`; what each row measures is in the script's docstring.
"""
    print(text)
    if not a.no_write:
        write_section("engines", text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
