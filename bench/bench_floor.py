"""The C floor and the hardware-in-the-loop latency of the native FMUs, beside the Python master.

``bench/floor_master.c`` (built here with the host's cc, never shipped) steps the shipped native
FMI 2.0 plant and controller Gauss-Seidel in C, as the project's master orders the calls, with
constant set-points and nothing recorded: the least a co-simulation of these FMUs can cost.  In the
same run, alternating rounds, the project's master (``orchestration.run.master.run``, fmpy, every
step recorded in memory) runs the same constant-set-point scenario with the same FMUs; the script
checks that both end in the same plant outputs to the last bit and prints the ratio of their CPU
times per step.  Last, the floor master times every ``doStep`` of each unit over ``--latency-steps``
steps (default 10^6, 100 s simulated) and prints the median, 99th, 99.99th percentile and maximum:
what a real-time target's step budget must cover.

Run ``python bench/bench_floor.py`` (after ``make``); it prints the numbers and replaces its section
of ``bench/RESULTS.md`` (``--no-write``: leave it).  CPU times: the floor's from ``getrusage`` of its
process, the master's from ``time.process_time``; both are printed with the wall times and the load
average, because on a shared machine the wall time includes waiting for a core.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_plant import cpu_model, git_head, write_section

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from fmpy import extract, read_model_description  # noqa: E402

from orchestration.build import fmus  # noqa: E402
from orchestration.build.native_build import fmi_headers_dir  # noqa: E402
from orchestration.run.master import run  # noqa: E402
from orchestration.scenario.load import load_scenario  # noqa: E402
from orchestration.scenario.system import MEASUREMENTS  # noqa: E402

H = 1e-4
SETPOINTS = {"omega_ref": 100.0, "psi_ref": 0.95, "T_load": 10.0}  # [rad/s], [Wb], [N m]
SCENARIO = f"""name: floor
description: constant set-points, the C floor's scenario
stop_time: {{stop}}
step: {H}
controller_every: 1
algorithm: gauss-seidel
motor: {{{{}}}}
plant: {{{{}}}}
controller: {{{{}}}}
profiles:
  psi_ref: {{{{type: constant, value: {SETPOINTS['psi_ref']}}}}}
  omega_ref: {{{{type: constant, value: {SETPOINTS['omega_ref']}}}}}
  T_load: {{{{type: constant, value: {SETPOINTS['T_load']}}}}}
record:
  interval: {H}
  outputs: []
"""


def loadavg():
    return os.getloadavg()[0]


def build_floor(tmp):
    exe = tmp / "floor_master"
    cc = os.environ.get("CC", "cc")
    subprocess.run([cc, "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-I", str(fmi_headers_dir()),
                    str(ROOT / "bench" / "floor_master.c"), "-o", str(exe), "-ldl"], check=True)
    return exe


def unit(path, tmp):
    md = read_model_description(str(path))
    d = Path(extract(str(path), unzipdir=str(tmp / md.coSimulation.modelIdentifier)))
    lib = d / "binaries" / "linux64" / f"{md.coSimulation.modelIdentifier}.so"
    return md, lib, {v.name: v.valueReference for v in md.modelVariables}


def floor_args(exe, plant, ctrl, steps, mode):
    (pmd, plib, pvr), (cmd_, clib, cvr) = plant, ctrl
    spec = [f"P2C:{pvr[n]}:{cvr[n]}" for n in MEASUREMENTS]
    spec += [f"C2P:{cvr[n]}:{pvr[n]}" for n in ("v_s_alpha", "v_s_beta")]
    spec += [f"C:{cvr[n]}={v!r}" for n, v in SETPOINTS.items()]
    spec += [f"P:{pvr['T_load']}={SETPOINTS['T_load']!r}"]
    spec += [f"OUT:{v.valueReference}" for v in pmd.modelVariables if v.causality == "output"]
    return [str(exe), str(plib), pmd.guid, str(clib), cmd_.guid, str(steps), repr(H), mode, *spec]


def run_floor(args):
    """The floor master's printout and its loop's (CPU, wall) time [s] (instantiation excluded)."""
    got = json.loads(subprocess.run(args, check=True, capture_output=True, text=True).stdout)
    return got, got["cpu_ns_per_step"] * got["steps"] * 1e-9, got["ns_per_step"] * got["steps"] * 1e-9


def run_master(scenario, plant_path, ctrl_path):
    """The whole run (extraction, instantiation, loop, recording): its result and (CPU, wall) [s]."""
    c0, w0 = time.process_time(), time.perf_counter()
    r = run(scenario, str(plant_path), str(ctrl_path))
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    if not r.ok:
        raise SystemExit(f"master run failed: {r.message}")
    return r, cpu, wall


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=15000, help="steps per floor/master run (default 1.5 s)")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--latency-steps", type=int, default=1_000_000)
    ap.add_argument("--fmus", default=str(ROOT / "build" / "fmus"))
    ap.add_argument("--no-write", action="store_true")
    a = ap.parse_args(argv)
    plant_path, ctrl_path = fmus.paths(a.fmus, "native")
    with tempfile.TemporaryDirectory(prefix="floor_") as tmp_name:
        tmp = Path(tmp_name)
        exe = build_floor(tmp)
        plant, ctrl = unit(plant_path, tmp), unit(ctrl_path, tmp)
        yaml = tmp / "floor.yaml"
        yaml.write_text(SCENARIO.format(stop=a.steps * H))
        scenario = load_scenario(yaml)
        load0 = loadavg()
        best = {"floor": (float("inf"), float("inf")), "master": (float("inf"), float("inf"))}
        same = True
        for _ in range(a.rounds):
            got, cpu, wall = run_floor(floor_args(exe, plant, ctrl, a.steps, "floor"))
            best["floor"] = min(best["floor"], (cpu, wall))
            r, mcpu, mwall = run_master(scenario, plant_path, ctrl_path)
            best["master"] = min(best["master"], (mcpu, mwall))
            names = [v.name for v in plant[0].modelVariables if v.causality == "output"]
            last = r.frame[[f"plant.{n}" for n in names]].to_numpy()[-1]
            same &= [float(x) for x in got["outputs"]] == [float(x) for x in last]
        lat, _, _ = run_floor(floor_args(exe, plant, ctrl, a.latency_steps, "latency"))
        load1 = loadavg()
    us = {k: (c / a.steps * 1e6, w / a.steps * 1e6) for k, (c, w) in best.items()}
    ratio_cpu, ratio_wall = us["master"][0] / us["floor"][0], us["master"][1] / us["floor"][1]
    env = (f"{datetime.date.today().isoformat()}, commit {git_head(ROOT)}, "
           f"Python {platform.python_version()}, CPU: {cpu_model()}, load average {load0:.2f} -> {load1:.2f}")
    (fc, fw), (mc, mw) = us["floor"], us["master"]
    rows = [f"| C floor master (native FMI 2.0, nothing recorded; the loop only) | {fc:.2f} | {fw:.2f} | 1 |",
            f"| project master (fmpy, native FMI 2.0, every step recorded; the whole `run`) | {mc:.2f} | "
            f"{mw:.2f} | **{ratio_cpu:.2f}x** (wall {ratio_wall:.2f}x) |"]
    lat_rows = [f"| {u} | " + " | ".join(f"{lat[u][q]:.0f}" for q in ("median", "p99", "p9999", "max")) + " |"
                for u in ("controller", "plant")]
    text = f"""## The C floor and the HIL latency

Measured {env}. Best of {a.rounds} alternating rounds of {a.steps} steps (h = Ts = 100 us), constant
set-points ({', '.join(f'{k} = {v:g}' for k, v in SETPOINTS.items())}). The floor and the master end
in {'the same plant outputs to the last bit' if same else 'DIFFERENT plant outputs (a bug: investigate)'}.

| path | CPU per step [us] | wall per step [us] | CPU ratio to the floor |
|---|---|---|---|
{chr(10).join(rows)}

Latency of one `doStep` of the native FMI 2.0 FMUs in the floor master, {a.latency_steps} steps
(clock_gettime around each call; the machine is shared, so the tail includes other processes):

| unit | median [ns] | 99th [ns] | 99.99th [ns] | max [ns] |
|---|---|---|---|---|
{chr(10).join(lat_rows)}

Rerun with `python bench/bench_floor.py`; it rebuilds `bench/floor_master.c` with cc and rewrites
this section.
"""
    print(text)
    if not same:
        print("error: the floor master and the project master disagree", file=sys.stderr)
    if not a.no_write:
        write_section("floor", text)
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
