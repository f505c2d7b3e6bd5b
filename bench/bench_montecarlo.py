"""A Monte Carlo study of the default scenario on the compiled engine, FMUs instantiated once per worker,
against the C floor's stepping of one variant, side by side in one run.

Run ``python -m bench montecarlo [--samples N] [--jobs J] [--no-write]``; prints a table and
rewrites its section of ``bench/RESULTS.md`` (between ``<!-- montecarlo:start -->`` and
``<!-- montecarlo:end -->``) unless ``--no-write``.  The study: the default scenario
(``scenarios/ramp_rated_load.yaml``, 1.5 s, 15 000 steps) at ``record: metrics`` with four plant
parameters drawn (``sweep: {samples: N}``: R_s, R_r, J, L_m0, as ``scenarios/sobol_motor.yaml``
varies them), native FMI 2.0 FMUs.  Measured, CPU and wall, the load average before and after:

* the floor (``bench/floor_master.c``): 15 000 Gauss-Seidel steps of the native FMUs, constant
  set-points, nothing recorded, the loop only: the floor's stepping of one variant;
* in this process, the variants one after the other on one worker's FMUs
  (:class:`~orchestration.run.fmu_instance.UnitPool`: instantiated once, ``fmi2Reset`` and new
  parameters per variant), the c engine, the metrics computed: CPU per variant of the whole
  ``c_engine.run``, of the engine's stepping (``se_advance``), and their difference, the per-variant
  overhead (instance reset, parameters, initialization, set-up of the run, the metrics); the variant's
  scenario loaded from the file (``load_variant``) timed apart;
* the same variants on the fmpy master (instances made anew per run, the extraction shared);
* ``batch STUDY --jobs J --no-plot`` as a whole process tree (``RUSAGE_CHILDREN``): the native
  variants run with ``--engine c``, several to a child process, the FMUs instantiated once per child.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from fmpy import read_model_description  # noqa: E402

from bench.common import cpu_model, git_head, write_section  # noqa: E402
from bench.floor_host import build_floor, floor_args, run_floor, unit  # noqa: E402
from orchestration.packaging import fmus  # noqa: E402
from orchestration.results.writer import streaming_recorder  # noqa: E402
from orchestration.run import c_engine  # noqa: E402
from orchestration.run.c_engine import stepper  # noqa: E402
from orchestration.run.fmu_instance import UnitPool, extract_owned, remove_extracted  # noqa: E402
from orchestration.run.master import run as master_run  # noqa: E402
from orchestration.scenario.variants import load_variant  # noqa: E402

SCENARIO = ROOT / "scenarios" / "ramp_rated_load.yaml"
STUDY = """mismatch: true
sweep:
  samples: {samples}
  seed: 2026
  parameters:
    plant.R_s: {{tolerance: 0.1}}
    plant.R_r: {{tolerance: 0.2}}
    plant.J: {{normal: [0.0131, 0.0013]}}
    plant.L_m0: {{tolerance: 0.1}}
"""


def study_file(work, samples):
    text = SCENARIO.read_text().replace("name: ramp_rated_load", "name: montecarlo_default")
    text = text.replace("record:", "record:\n  level: metrics", 1)
    path = work / "montecarlo_default.yaml"
    path.write_text(text + STUDY.format(samples=samples))
    return path


class SteppingClock:
    """``se_advance`` of the loaded engine timed (CPU, summed) while in use."""

    def __init__(self):
        self.cpu = 0.0
        self.lib = stepper.library()
        self._orig = self.lib.se_advance

    def __enter__(self):
        orig = self._orig

        def timed(*args):
            c0 = time.process_time()
            r = orig(*args)
            self.cpu += time.process_time() - c0
            return r

        self.lib.se_advance = timed
        return self

    def __exit__(self, *exc):
        self.lib.se_advance = self._orig


class MetricsClock:
    """A ``streaming_recorder`` factory whose recorders' observers (the metrics) are timed (CPU, summed)."""

    def __init__(self):
        self.cpu = 0.0

    def __call__(self, sc, work):
        make = streaming_recorder(sc, work)

        def timed_make(columns):
            rec = make(columns)
            observe = rec.observer

            def timed(chunk):
                c0 = time.process_time()
                observe(chunk)
                self.cpu += time.process_time() - c0

            rec.observer = timed
            return rec

        return timed_make


def in_process(path, n, paths, work, engine):
    """CPU [s] of loading the variants, of running them, (c engine) of the stepping and of the metrics;
    wall of the runs."""
    dirs = [extract_owned(p) for p in paths]
    mds = [read_model_description(p) for p in paths]
    pool = UnitPool()
    try:
        c0 = time.process_time()
        scenarios = [load_variant(path, i) for i in range(n)]
        load = time.process_time() - c0
        metrics = MetricsClock()
        with SteppingClock() as clock:
            c0, w0 = time.process_time(), time.perf_counter()
            for sc in scenarios:
                if engine == "c":
                    r = c_engine.run(sc, *paths, unzip_dirs=dirs, descriptions=mds, pool=pool,
                                     recorder=metrics(sc, work))
                else:
                    r = master_run(sc, *paths, unzip_dirs=dirs, descriptions=mds, recorder=metrics(sc, work))
                assert r.ok, r.message
            cpu, wall = time.process_time() - c0, time.perf_counter() - w0
        return load, cpu, clock.cpu, metrics.cpu, wall
    finally:
        pool.close()
        for d in dirs:
            remove_extracted(d)


def batch(path, out, fmu_dir, jobs, *extra):
    """``(CPU [s] of the whole process tree, wall [s])`` of ``batch`` on the study ``path``; ``extra``:
    more options (``--scheduler ADDRESS``)."""
    args = [sys.executable, "-m", "orchestration", "batch", str(path), "--out", str(out),
            "--fmus", str(fmu_dir), "--variant", "native", "--jobs", str(jobs), "--no-plot", *extra]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    w0 = time.perf_counter()
    done = subprocess.run(args, cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - w0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode not in (0, 3):
        raise SystemExit(f"batch failed ({done.returncode}): {done.stderr[-2000:]}")
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), wall


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--samples", type=int, default=200, help="variants of the study (default 200)")
    ap.add_argument("--in-process", type=int, default=100, help="variants run in this process (default 100)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--fmus", default=str(ROOT / "build" / "fmus"))
    ap.add_argument("--no-write", action="store_true", help="do not rewrite bench/RESULTS.md")
    a = ap.parse_args(argv)
    paths = list(map(str, fmus.paths(a.fmus, "native")))
    load0 = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="bench_montecarlo_") as tmp:
        work = Path(tmp)
        path = study_file(work, a.samples)
        steps = round(load_variant(path, 0).stop_time / load_variant(path, 0).step)
        exe = build_floor(work)
        units = unit(paths[0], work), unit(paths[1], work)
        _, floor_cpu, floor_wall = run_floor(floor_args(exe, *units, steps, "floor"))
        m = a.in_process
        c_load, c_cpu, c_step, c_metrics, c_wall = in_process(path, m, paths, work, "c")
        f_load, f_cpu, _, _, f_wall = in_process(path, m, paths, work, "fmpy")
        b_cpu, b_wall = batch(path, work / "out", a.fmus, a.jobs)
        _, floor_cpu2, _ = run_floor(floor_args(exe, *units, steps, "floor"))
        floor_cpu = min(floor_cpu, floor_cpu2)
    load1 = os.getloadavg()
    ms = 1e3
    per = {"floor": floor_cpu, "c": c_cpu / m, "c_step": c_step / m, "fmpy": f_cpu / m,
           "batch": b_cpu / a.samples}
    overhead = (c_cpu - c_step) / m
    rows = [("C floor's stepping of one variant (15 000 steps, nothing recorded)", per["floor"], floor_wall),
            (f"c engine, one worker's FMUs reset per variant, whole run ({m} variants)", per["c"],
             c_wall / m),
            ("  of which the engine's stepping (se_advance)", per["c_step"], None),
            ("  **per-variant overhead** (reset, parameters, initialization, set-up, metrics)", overhead,
             None),
            ("  of which the metrics (MetricsObserver, the fmpy master's code)", c_metrics / m, None),
            ("  of which the rest (reset, parameters, initialization, set-up)", overhead - c_metrics / m,
             None),
            ("  loading the variant's scenario from the file (load_variant)", c_load / m, None),
            (f"fmpy master, instances made per run ({m} variants)", per["fmpy"], f_wall / m),
            (f"`batch --jobs {a.jobs} --no-plot`, {a.samples} variants, whole process tree", per["batch"],
             b_wall / a.samples)]
    table = ["| per variant | CPU [ms] | wall [ms] | CPU / floor's stepping |", "|---|---|---|---|"]
    for label, c, w in rows:
        wtxt = f"{w * ms:.1f}" if w is not None else ""
        table.append(f"| {label} | {c * ms:.2f} | {wtxt} | {c / per['floor']:.2f}x |")
    env = (f"{datetime.date.today().isoformat()}, `{git_head(ROOT)}`, Python {platform.python_version()}, "
           f"CPU: {cpu_model()} ({os.cpu_count()} cores, shared), "
           f"load average {load0[0]:.2f} -> {load1[0]:.2f}")
    text = f"""## A Monte Carlo study on the c engine, FMUs once per worker (`bench/bench_montecarlo.py`)

{env}.  The default scenario at `record: metrics`, four plant parameters drawn, native FMI 2.0.

{chr(10).join(table)}
"""
    print(text)
    if not a.no_write:
        write_section("montecarlo", text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
