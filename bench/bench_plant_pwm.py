"""Per-step cost of the plant's inverter options against today's average-value plant, Python
(``satmotor.interface.PlantUnit.step``) and C (``sm_plant_step`` / ``sm_inverter_step`` of the native core,
through ctypes), side by side.

Run ``python bench/bench_plant_pwm.py [--seconds S]``; prints a table (RESULTS.md is not written; the
coordinator folds this with ``bench/bench_plant_options.py``).

The inputs: the plant's inputs (v_s_alpha, v_s_beta, T_load) at every 100 us step of a closed loop of the
plain-Python units at their defaults on ``scenarios/ramp_rated_load.yaml`` (its first ``S`` seconds,
default 1.0: pre-magnetization, the ramp towards 100 rad/s), recorded once with the average plant.  Every
option then replays them open loop from the same initial state (the switched plants drift a little from
the recorded trajectory; the work per step is what is compared).  One run per option: CPU time
(``time.process_time``) and wall time (``time.perf_counter``) per step, the load average before and after
(the machine is shared), and each option's ratio to the average plant.
"""

from __future__ import annotations

import argparse
import ctypes
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
H = 1e-4
OPTIONS = {
    "average (today)": {},
    "pwm 5 kHz": {"inverter": "pwm", "f_sw": 5000.0},
    "pwm 10 kHz": {"inverter": "pwm", "f_sw": 10000.0},
    "pwm 5 kHz, 2 us dead time": {"inverter": "pwm", "f_sw": 5000.0, "t_dead": 2e-6},
    "pwm 10 kHz, 2 us dead time, 1 V drops": {"inverter": "pwm", "f_sw": 10000.0, "t_dead": 2e-6,
                                              "v_on": 1.0},
}


def record(seconds):
    """The plant's inputs per step of the default closed loop (plain Python, average plant)."""
    from orchestration.scenario.load import load_scenario
    from satmotor.interface import ControllerUnit, PlantUnit

    sc = load_scenario(ROOT / "scenarios" / "ramp_rated_load.yaml")
    load, w_ref, psi_ref = (sc.profiles[n].value for n in ("T_load", "omega_ref", "psi_ref"))
    plant, ctrl = PlantUnit({}), ControllerUnit({})
    rows = []
    for k in range(round(seconds / H)):
        t = k * H
        o = plant.outputs()
        ctrl.step(t, H, (o[0], o[1], o[4], o[5], o[2], o[3], o[6], w_ref(t), psi_ref(t), load(t)))
        c = ctrl.outputs()
        rows.append((c[0], c[1], load(t)))
        plant.step(t, H, rows[-1])
    return rows


def python_cost(values, rows):
    from satmotor.interface import PlantUnit

    u = PlantUnit(values)
    w0, c0 = time.perf_counter(), time.process_time()
    for k, r in enumerate(rows):
        u.step(k * H, H, r)
    return (time.process_time() - c0) / len(rows), (time.perf_counter() - w0) / len(rows)


def c_cost(lib, nc, values, rows):
    motor, inv = nc.new_motor(lib), nc.new_inverter(lib)
    msg = ctypes.create_string_buffer(256)
    mp, pp = nc.params(lib, nc.MotorParams, values), nc.params(lib, nc.PlantParams, values)
    assert lib.sm_motor_init(motor, mp, pp, msg, 256) == 0, msg.value
    assert lib.sm_inverter_init(inv, pp, msg, 256) == 0, msg.value
    x = (ctypes.c_double * 6)()
    lib.sm_plant_initial_state(motor, 0.0, 0.0, 0.0, 0.0, x)
    avg = (ctypes.c_double * 2)()
    pwm = values.get("inverter") == "pwm"
    step, istep = lib.sm_plant_step, lib.sm_inverter_step
    w0, c0 = time.perf_counter(), time.process_time()
    for k, (va, vb, tl) in enumerate(rows):
        if pwm:
            st = istep(inv, motor, x, k * H, H, va, vb, tl, avg, None, 0, None)
        else:
            st = step(motor, x, va, vb, tl, H, 1)
        assert st == 0
    return (time.process_time() - c0) / len(rows), (time.perf_counter() - w0) / len(rows)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=1.0, help="simulated seconds replayed (default 1.0)")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(ROOT / "tests"))
    import native_core as nc

    lib = nc.load()
    rows = record(args.seconds)
    load0 = os.getloadavg()
    res = {name: (python_cost(v, rows), c_cost(lib, nc, v, rows)) for name, v in OPTIONS.items()}
    load1 = os.getloadavg()
    print(f"plant per-step cost, {len(rows)} steps of {H} s (scenarios/ramp_rated_load.yaml inputs), "
          f"one run; load average {load0[0]:.2f} before, {load1[0]:.2f} after ({os.cpu_count()} CPUs)")
    (bp, _), (bc, _) = res["average (today)"]
    print(f"{'option':40s} {'Python CPU us':>13s} {'wall us':>8s} {'x avg':>6s}   {'C CPU us':>8s} "
          f"{'wall us':>8s} {'x avg':>6s}")
    for name, ((pc, pw), (cc, cw)) in res.items():
        print(f"{name:40s} {1e6 * pc:13.1f} {1e6 * pw:8.1f} {pc / bp:6.2f}   {1e6 * cc:8.2f} {1e6 * cw:8.2f} "
              f"{cc / bc:6.2f}")


if __name__ == "__main__":
    main()
