"""Per-step cost of ``flux_mode = loss_minimizing`` against ``nominal``, side by side, Python
(``satmotor.interface.ControllerUnit.step``) and C (``sm_controller_step`` of the native core, through
ctypes, gcc -O2 by ``tests/native_core.build``).

Run ``python -m bench loss_min [--rounds 3] [--repeats 2]``; prints a table and rewrites its section of
RESULTS.md (``--no-write``: leave it).
The inputs: the controller's inputs at every sample of plain-Python closed loops
(PlantUnit + ControllerUnit, Ts = 100 us) in flux_mode loss_minimizing, recorded once:

* ``light load, step``: ``scenarios/light_load_loss_min.yaml`` (qu2012_2kw2, 10 % load at 100 rad/s,
  a step to 50 % at 1.2 s; 2.0 s);
* ``default motor, rated load``: ``scenarios/ramp_rated_load.yaml`` with flux_mode loss_minimizing
  (100 rad/s, rated load from 1 s; 1.5 s).

A fresh controller of each mode (the scenario's settings, flux_mode set) steps through the same inputs
in order, the modes alternating within each round; the time per step is the best of the passes and
rounds (CPU time, ``time.process_time``).  The ratio is loss_minimizing / nominal of the same language.
"""

from __future__ import annotations

import argparse
import ctypes
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

CASES = {"light load, step": "light_load_loss_min", "default motor, rated load": "ramp_rated_load"}
MODES = ("nominal", "loss_minimizing")


def record(name):
    """(controller values, [inputs per sample]) of the scenario ``name`` in flux_mode loss_minimizing."""
    from orchestration.scenario.load import load_scenario
    from satmotor.interface import ControllerUnit, PlantUnit

    sc = load_scenario(ROOT / "scenarios" / f"{name}.yaml")
    values = {**sc.controller, "flux_mode": "loss_minimizing"}
    prof = sc.profiles
    plant, ctrl = PlantUnit(dict(sc.plant)), ControllerUnit(values)
    Ts = ctrl.Ts
    rows = []
    for k in range(round(sc.stop_time / Ts)):
        t = k * Ts
        o = plant.outputs()
        load = prof["T_load"].value(t)
        row = (o[0], o[1], o[4], o[5], o[2], o[3], o[6], prof["omega_ref"].value(t), prof["psi_ref"].value(t),
               load, 0.0)
        rows.append(row)
        ctrl.step(t, Ts, row)
        c = ctrl.outputs()
        plant.step(t, Ts, (c[0], c[1], load))
    return values, rows, Ts


def _python(values, rows, Ts):
    from satmotor.interface import ControllerUnit

    u = ControllerUnit(values)
    t0 = time.process_time()
    for k, r in enumerate(rows):
        u.step(k * Ts, Ts, r)
    return time.process_time() - t0


def _c(lib, values, arrs, Ts):
    from native_core import ControllerParams, MotorParams, params

    names = {n for n, _ in ControllerParams._fields_ + MotorParams._fields_}
    v = {n: x for n, x in values.items() if n in names}
    buf = ctypes.create_string_buffer(lib.sm_controller_size())
    msg = ctypes.create_string_buffer(256)
    assert lib.sm_controller_init(buf, params(lib, ControllerParams, v), params(lib, MotorParams, v), msg,
                                  256) == 0, msg.value
    step = lib.sm_controller_step
    t0 = time.process_time()
    for k, a in enumerate(arrs):
        step(buf, k * Ts, Ts, a, msg, 256)
    return time.process_time() - t0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3, help="rounds, the modes alternating (default 3)")
    ap.add_argument("--repeats", type=int, default=2, help="passes per mode and round, best kept (default 2)")
    ap.add_argument("--no-write", action="store_true", help="do not rewrite bench/RESULTS.md")
    args = ap.parse_args(argv)
    from native_core import build, declare

    from bench.common import measured, write_section

    load0 = os.getloadavg()[0]
    lib = declare(ctypes.CDLL(str(build())))
    lines = ["| inputs | samples | Python nominal [us/step] | Python loss_minimizing [us/step] | ratio "
             "| C nominal [us/step] | C loss_minimizing [us/step] | ratio |",
             "|---|---|---|---|---|---|---|---|"]
    print("\n".join(lines))
    for case, name in CASES.items():
        values, rows, Ts = record(name)
        n_in = len(rows[0])
        arrs = [(ctypes.c_double * n_in)(*r) for r in rows]
        best = {}
        for _ in range(args.rounds):
            for mode in MODES:
                v = {**values, "flux_mode": mode}
                for _ in range(args.repeats):
                    best[("py", mode)] = min(best.get(("py", mode), float("inf")), _python(v, rows, Ts))
                    best[("c", mode)] = min(best.get(("c", mode), float("inf")), _c(lib, v, arrs, Ts))
        us = {k: 1e6 * s / len(rows) for k, s in best.items()}
        py_n, py_l, c_n, c_l = (us[(lang, m)] for lang in ("py", "c") for m in MODES)
        lines.append(f"| {case} | {len(rows)} | {py_n:.1f} | {py_l:.1f} | {py_l / py_n:.2f} | {c_n:.2f} "
                     f"| {c_l:.2f} | {c_l / c_n:.2f} |")
        print(lines[-1], flush=True)
    if not args.no_write:
        head = ["## The loss-minimizing flux: per-step cost against the nominal set-point "
                "(`python -m bench loss_min`)", "",
                measured(load0) + f" {args.rounds} rounds of {args.repeats} passes, the modes alternating, "
                "CPU time, best kept; the same recorded inputs for both modes.", ""]
        write_section("loss_min", "\n".join(head + lines))


if __name__ == "__main__":
    main()
