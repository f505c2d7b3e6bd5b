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

Run ``python -m bench floor`` (after ``make``); it prints the numbers and replaces its section
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
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.common import cpu_model, git_head, write_section  # noqa: E402
from bench.floor_host import SETPOINTS, H, build_floor, floor_args, run_floor, unit  # noqa: E402
from orchestration.packaging import fmus  # noqa: E402

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


CHILD = """
import json, sys, time
from orchestration.run.master import run
from orchestration.scenario.load import load_scenario
yaml, plant, ctrl, repeats, names = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4]), sys.argv[5:]
scenario = load_scenario(yaml)
best = (float("inf"), float("inf"))
for _ in range(repeats):
    c0, w0 = time.process_time(), time.perf_counter()
    r = run(scenario, plant, ctrl)
    best = min(best, (time.process_time() - c0, time.perf_counter() - w0))
    if not r.ok:
        raise SystemExit(f"master run failed: {r.message}")
last = r.frame[[f"plant.{n}" for n in names]].to_numpy()[-1]
print(json.dumps({"cpu": best[0], "wall": best[1], "outputs": [float(x) for x in last]}))
"""


def python_of(root):
    """The interpreter of checkout ``root`` (its own .venv, else this one) and its environment
    (``PYTHONPATH=root``: the checkout's own packages, whichever venv runs them)."""
    py = root / ".venv" / "bin" / "python"
    env = dict(os.environ, PYTHONPATH=str(root))
    return (str(py) if py.exists() else sys.executable), env


def run_master(root, yaml, plant_path, ctrl_path, names, repeats=2):
    """The project master of checkout ``root`` in a child process, best of ``repeats`` whole runs
    (extraction, instantiation, loop, recording in memory): its (CPU, wall) [s] and last plant outputs."""
    py, env = python_of(root)
    got = subprocess.run([py, "-c", CHILD, str(yaml), str(plant_path), str(ctrl_path), str(repeats), *names],
                         check=True, capture_output=True, text=True, env=env, cwd=str(root))
    return json.loads(got.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=15000, help="steps per floor/master run (default 1.5 s)")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--latency-steps", type=int, default=1_000_000)
    ap.add_argument("--fmus", default=str(ROOT / "build" / "fmus"))
    ap.add_argument("--compare", metavar="DIR",
                    help="another checkout (its FMUs in DIR/build/fmus, its master run by "
                    "DIR/.venv/bin/python if any, else this interpreter with PYTHONPATH=DIR), measured in "
                    "the same alternating rounds")
    ap.add_argument("--no-write", action="store_true")
    a = ap.parse_args(argv)
    checkouts = {"this": (ROOT, Path(a.fmus))}
    if a.compare:
        other = Path(a.compare).resolve()
        checkouts = {"before": (other, other / "build" / "fmus"), "this": (ROOT, Path(a.fmus))}
    with tempfile.TemporaryDirectory(prefix="floor_") as tmp_name:
        tmp = Path(tmp_name)
        exe = build_floor(tmp)
        yaml = tmp / "floor.yaml"
        yaml.write_text(SCENARIO.format(stop=a.steps * H))
        units, paths = {}, {}
        for name, (_, fmu_dir) in checkouts.items():
            paths[name] = fmus.paths(fmu_dir, "native")
            units[name] = tuple(unit(path, tmp / name) for path in paths[name])
        names = [v.name for v in units["this"][0][0].modelVariables if v.causality == "output"]
        load0 = loadavg()
        inf2 = (float("inf"), float("inf"))
        best = {(n, k): inf2 for n in checkouts for k in ("floor", "master")}
        same, last = {n: True for n in checkouts}, {}
        for r in range(a.rounds):
            for name, (root, _) in checkouts.items():
                plant, ctrl = units[name]
                got, cpu, wall = run_floor(floor_args(exe, plant, ctrl, a.steps, "floor"))
                best[name, "floor"] = min(best[name, "floor"], (cpu, wall))
                m = run_master(root, yaml, *paths[name], names)
                best[name, "master"] = min(best[name, "master"], (m["cpu"], m["wall"]))
                same[name] &= [float(x) for x in got["outputs"]] == m["outputs"]
                last[name] = m["outputs"]
            now = ", ".join(f"{n} {k} {best[n, k][0] / a.steps * 1e6:.2f}"
                            for n in checkouts for k in ("floor", "master"))
            print(f"round {r + 1}/{a.rounds} (best CPU us/step so far): {now}", flush=True)
        lat = {name: run_floor(floor_args(exe, *units[name], a.latency_steps, "latency"))[0]
               for name in checkouts}
        load1 = loadavg()
    us = {key: (c / a.steps * 1e6, w / a.steps * 1e6) for key, (c, w) in best.items()}
    heads = {name: git_head(root) for name, (root, _) in checkouts.items()}
    heads = {name: h if h != "?" else checkouts[name][0].name for name, h in heads.items()}  # not in git
    env = (f"{datetime.date.today().isoformat()}, Python {platform.python_version()}, CPU: {cpu_model()} "
           f"({os.cpu_count()} cores, shared), load average {load0:.2f} -> {load1:.2f}")
    rows = []
    for name in checkouts:
        (fc, fw), (mc, mw) = us[name, "floor"], us[name, "master"]
        tag = f"{name} `{heads[name]}`" if len(checkouts) > 1 else f"`{heads[name]}`"
        rows.append(f"| {tag} | C floor master (native FMI 2.0, nothing recorded; the loop only) | "
                    f"{fc:.2f} | {fw:.2f} | 1 |")
        rows.append(f"| {tag} | project master (fmpy, native FMI 2.0, every step recorded; the whole "
                    f"`run`) | {mc:.2f} | {mw:.2f} | **{mc / fc:.2f}x** (wall {mw / fw:.2f}x) |")
    agree = all(same.values())
    quantiles = ("median", "p99", "p9999", "max")
    lines = [f"| {name} {u} | " + " | ".join(f"{lat[name][u][q]:.0f}" for q in quantiles) + " |"
             for name in checkouts for u in ("controller", "plant")]
    extra = ""
    if len(checkouts) > 1:
        b, t = us["before", "floor"][0], us["this", "floor"][0]
        diff = max(abs(x - y) / max(abs(y), 1e-300) for x, y in zip(last["before"], last["this"]))
        mb, mt = us["before", "master"][0], us["this", "master"][0]
        extra = (f"\nFloor before -> after: {b:.2f} -> {t:.2f} us per step ({100 * (t / b - 1):+.1f} %); "
                 f"master before -> after: {mb:.2f} -> {mt:.2f} us per step ({100 * (mt / mb - 1):+.1f} %).  "
                 f"The last plant outputs of the two checkouts differ by at most {diff:.2g} (relative).\n")
    text = f"""## The C floor and the HIL latency

Measured {env}. Best of {a.rounds} alternating rounds of {a.steps} steps (h = Ts = 100 us), constant
set-points ({', '.join(f'{k} = {v:g}' for k, v in SETPOINTS.items())}); each master run in a child
process, best of 2 whole runs. Within each checkout the floor and the master end in
{'the same plant outputs to the last bit' if agree else 'DIFFERENT plant outputs (a bug: investigate)'}.

| checkout | path | CPU per step [us] | wall per step [us] | CPU ratio to the floor |
|---|---|---|---|---|
{chr(10).join(rows)}
{extra}
Latency of one `doStep` of the native FMI 2.0 FMUs in the floor master, {a.latency_steps} steps
(clock_gettime around each call; the machine is shared, so the tail includes other processes):

| unit | median [ns] | 99th [ns] | 99.99th [ns] | max [ns] |
|---|---|---|---|---|
{chr(10).join(lines)}

Rerun with `python -m bench floor` (`--compare DIR`: another checkout in the same rounds); it
rebuilds `bench/floor_master.c` with cc and rewrites this section.
"""
    print(text)
    if not agree:
        print("error: the floor master and the project master disagree", file=sys.stderr)
    if not a.no_write:
        write_section("floor", text)
    return 0 if agree else 1


if __name__ == "__main__":
    sys.exit(main())
