"""Per-step cost of the controller unit, Python (``satmotor.interface.ControllerUnit.step``) and C
(``sm_controller_step`` of the native core, called through ctypes), on recorded inputs; optionally
against another checkout in the same rounds.

Run ``python -m bench controller_step [--compare DIR]``; prints a table and rewrites its section of
RESULTS.md (``--no-write``: leave it).
``DIR`` is another checkout of this project with its own ``.venv`` (e.g. ``git archive
COMMIT | tar -x -C DIR`` and ``make .venv/.installed`` there).

The inputs: the controller's inputs at every sample of closed loops of this checkout's
plain-Python units (PlantUnit + ControllerUnit at their defaults, Ts = 100 us), recorded once:

* ``below base speed``: ``scenarios/ramp_rated_load.yaml`` (100 rad/s, rated load; 1.5 s);
* ``field weakening``: ``scenarios/field_weakening.yaml`` (250 rad/s, 16 N m; 2.0 s);
* ``beyond breakdown``: ``scenarios/field_weakening_constant_power.yaml`` with the load 7/4 times
  (7 kW: at 375 rad/s beyond the breakdown torque; 2.0 s).

Each checkout replays them in a child process (its own interpreter and sources): a fresh controller at
the defaults steps through the inputs in order; the time per step is the best of ``--repeats`` passes.
The C core is compiled by the checkout's ``tests/native_core.build`` (gcc -O2).  A checkout from
before the field weakening steps the same inputs with its fixed flux set-point (its outputs differ;
the work per step is what is compared).  CPU time (``time.process_time``), best of the rounds.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from bench.common import measured, write_section

ROOT = Path(__file__).resolve().parents[1]
CASES = {"below base speed": ("ramp_rated_load", 1.0), "field weakening": ("field_weakening", 1.0),
         "beyond breakdown": ("field_weakening_constant_power", 7.0 / 4.0)}

CHILD = r"""
import ctypes, json, sys, time
sys.path.insert(0, "tests")
from satmotor.interface import ControllerUnit
inputs = json.load(open(sys.argv[1]))
repeats = int(sys.argv[2])
out = {}
from native_core import ControllerParams, MotorParams, build, params
lib = ctypes.CDLL(str(build()))
lib.sm_controller_size.restype = ctypes.c_size_t
lib.sm_controller_init.argtypes = [ctypes.c_void_p, ctypes.POINTER(ControllerParams),
                                   ctypes.POINTER(MotorParams), ctypes.c_char_p, ctypes.c_size_t]
lib.sm_controller_step.argtypes = [ctypes.c_void_p, ctypes.c_double, ctypes.c_double,
                                   ctypes.POINTER(ctypes.c_double), ctypes.c_char_p, ctypes.c_size_t]
lib.sm_controller_params_default.argtypes = [ctypes.POINTER(ControllerParams)]
lib.sm_motor_params_default.argtypes = [ctypes.POINTER(MotorParams)]
n_in = len(ControllerUnit.INPUTS)  # 10 before the v_dc input (last) existed: the rows fitted to it
for case, rows in inputs.items():
    rows = [(list(r) + [0.0] * n_in)[:n_in] for r in rows]
    best_py = best_c = float("inf")
    arrs = [(ctypes.c_double * n_in)(*r) for r in rows]
    for _ in range(repeats):
        u = ControllerUnit({})
        t0 = time.process_time()
        for k, r in enumerate(rows):
            u.step(k * 1e-4, 1e-4, r)
        best_py = min(best_py, time.process_time() - t0)
        buf = ctypes.create_string_buffer(lib.sm_controller_size())
        msg = ctypes.create_string_buffer(256)
        cp, mp = params(lib, ControllerParams), params(lib, MotorParams)
        assert lib.sm_controller_init(buf, cp, mp, msg, 256) == 0
        step = lib.sm_controller_step
        t0 = time.process_time()
        for k, a in enumerate(arrs):
            step(buf, k * 1e-4, 1e-4, a, msg, 256)
        best_c = min(best_c, time.process_time() - t0)
    out[case] = {"n": len(rows), "python_us": 1e6 * best_py / len(rows), "c_us": 1e6 * best_c / len(rows)}
print(json.dumps(out))
"""


def record():
    """``{case: [inputs per sample]}`` from this checkout's plain-Python closed loops."""
    sys.path.insert(0, str(ROOT))
    from orchestration.scenario.load import load_scenario
    from orchestration.scenario.profiles import Table
    from satmotor.interface import ControllerUnit, PlantUnit

    out = {}
    for case, (name, scale) in CASES.items():
        sc = load_scenario(ROOT / "scenarios" / f"{name}.yaml")
        tl = sc.profiles["T_load"]
        load = (Table(tl.times, tuple(scale * v for v in tl.values)) if scale != 1.0 else tl).value
        w_ref, psi_ref = sc.profiles["omega_ref"].value, sc.profiles["psi_ref"].value
        plant, ctrl = PlantUnit({}), ControllerUnit({})
        rows = []
        for k in range(round(sc.stop_time / 1e-4)):
            t = k * 1e-4
            o = plant.outputs()
            row = (o[0], o[1], o[4], o[5], o[2], o[3], o[6], w_ref(t), psi_ref(t), load(t), 0.0)  # v_dc: none
            rows.append(row)
            ctrl.step(t, 1e-4, row)
            c = ctrl.outputs()
            plant.step(t, 1e-4, (c[0], c[1], load(t)))
        out[case] = rows
    return out


def measure(checkout, inputs_file, repeats):
    py = Path(checkout) / ".venv" / "bin" / "python"
    env = {**os.environ, "PYTHONPATH": str(checkout)}
    res = subprocess.run([str(py), "-c", CHILD, inputs_file, str(repeats)], cwd=checkout, env=env,
                         capture_output=True, text=True, check=True)
    return json.loads(res.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--compare", metavar="DIR", help="another checkout to measure in the same rounds")
    ap.add_argument("--rounds", type=int, default=3, help="alternating rounds (default 3)")
    ap.add_argument("--repeats", type=int, default=2, help="passes per child, best kept (default 2)")
    ap.add_argument("--no-write", action="store_true", help="do not rewrite bench/RESULTS.md")
    args = ap.parse_args(argv)
    load0 = os.getloadavg()[0]
    checkouts = {"this": str(ROOT)}
    if args.compare:
        checkouts["compared"] = str(Path(args.compare).resolve())
    with tempfile.TemporaryDirectory() as tmp:
        inputs_file = str(Path(tmp) / "inputs.json")
        Path(inputs_file).write_text(json.dumps(record()))
        best = {}
        for _ in range(args.rounds):
            for label, d in checkouts.items():
                for case, m in measure(d, inputs_file, args.repeats).items():
                    b = best.setdefault((label, case), dict(m))
                    b["python_us"] = min(b["python_us"], m["python_us"])
                    b["c_us"] = min(b["c_us"], m["c_us"])
    lines = [f"| inputs | samples | {' | '.join(f'Python, {k} [us/step]' for k in checkouts)} | "
             f"{' | '.join(f'C via ctypes, {k} [us/step]' for k in checkouts)} |",
             "|---|---|" + "---|" * (2 * len(checkouts))]
    for case in CASES:
        n = best[("this", case)]["n"]
        py = " | ".join(f"{best[(k, case)]['python_us']:.1f}" for k in checkouts)
        c = " | ".join(f"{best[(k, case)]['c_us']:.2f}" for k in checkouts)
        lines.append(f"| {case} | {n} | {py} | {c} |")
    print("\n".join(lines))
    if not args.no_write:
        head = ["## The controller unit's cost per step (`python -m bench controller_step`)", "",
                measured(load0) + f" Best of {args.rounds} rounds x {args.repeats} passes, CPU time"
                + (f"; compared: `{args.compare}`." if args.compare else "."), ""]
        write_section("controller_step", "\n".join(head + lines))


if __name__ == "__main__":
    main()
