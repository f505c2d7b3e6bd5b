"""Per-step cost of the plant's options, side by side in one run: today's plant, core loss (R_fe), the
thermal model, both, the capacitor DC link, the PWM inverter (with and without dead time and drops); the
native co-simulation FMU (C, FMI 2.0, through fmpy) and the Python plant
(``satmotor.interface.PlantUnit``, what the pythonfmu FMU runs).

Run ``python -m bench plant_options [--fmus build/fmus]`` (the FMUs built first:
``satmotor-cosim build --out build/fmus``).  Prints, per option, the CPU and wall time per RK4 sub-step
and the ratio to today's plant, and the load average before and after (a shared machine).

Method: a direct-on-line start of the default motor at rated voltage and frequency, the voltage vector
``V (cos w t, sin w t)`` held over each communication step of 1 ms, ``h_int`` = 1e-5 s (100 RK4 sub-steps
per ``doStep``, so the per-call overhead of fmpy and ctypes is spread over them), rated load from 0.3 s;
native: 1 s simulated (1e5 sub-steps), Python: 0.1 s (1e4 sub-steps); the best of ``REPEATS`` runs.
Each option is a row of :data:`OPTIONS`: (name, plant parameter overrides).  The cost is given per
``doStep`` of 1 ms (the same work for every option: 1 ms of the motor) and per RK4 sub-step of today's
plant (the ``doStep`` cost / 100): the PWM inverter integrates more, shorter intervals (its switching
instants) within the same step.  (Folds the former ``bench/bench_plant_pwm.py``.)
"""

from __future__ import annotations

import argparse
import math
import os
import time
from pathlib import Path

from bench.common import measured, write_section

OPTIONS = [
    ("today (average-value, no core loss, thermal off)", {}),
    ("core loss R_fe = 1200 Ohm", {"R_fe": 1200.0}),
    ("thermal model on", {"thermal": True}),
    ("core loss + thermal", {"R_fe": 1200.0, "thermal": True}),
    ("DC link capacitor (470 uF, dc source)", {"dc_link": "capacitor"}),
    ("pwm 5 kHz", {"inverter": "pwm", "f_sw": 5000.0}),
    ("pwm 5 kHz, 2 us dead time, 1 V drops",
     {"inverter": "pwm", "f_sw": 5000.0, "t_dead": 2e-6, "v_on": 1.0}),
    ("pwm 20 kHz", {"inverter": "pwm", "f_sw": 20000.0}),
    # the options combined (issue 19 item 5 made whole)
    ("capacitor + core loss + thermal", {"dc_link": "capacitor", "R_fe": 1200.0, "thermal": True}),
    ("pwm 5 kHz + core loss + thermal", {"inverter": "pwm", "f_sw": 5000.0, "R_fe": 1200.0, "thermal": True}),
    ("pwm 5 kHz on the capacitor", {"inverter": "pwm", "f_sw": 5000.0, "dc_link": "capacitor"}),
    ("pwm 5 kHz, dead time, drops, capacitor, chopper, R_fe, thermal",
     {"inverter": "pwm", "f_sw": 5000.0, "t_dead": 2e-6, "v_on": 1.0, "dc_link": "capacitor", "R_chop": 40.0,
      "R_fe": 1200.0, "thermal": True}),
]
REPEATS = 3
DT, H_INT, T_LOAD_ON, T_N = 1e-3, 1e-5, 0.3, 26.71
V, W = 400.0 * math.sqrt(2.0 / 3.0), 2.0 * math.pi * 50.0


def _inputs(k):
    t = k * DT
    return V * math.cos(W * t), V * math.sin(W * t), (T_N if t >= T_LOAD_ON else 0.0)


def native_run(fmu, overrides, t_end):
    """(cpu, wall) [s] of ``t_end`` simulated through the native co-simulation FMU."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    types = {v.name: v.type for v in md.modelVariables}
    d = extract(str(fmu))
    s = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName="bench")
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.setReal([vr["h_int"]], [H_INT])
    for name, value in overrides.items():
        if types[name] == "Boolean":
            s.setBoolean([vr[name]], [bool(value)])
        elif types[name] == "String":
            s.setString([vr[name]], [value])
        else:
            s.setReal([vr[name]], [float(value)])
    s.exitInitializationMode()
    ins = [vr["v_s_alpha"], vr["v_s_beta"], vr["T_load"]]
    n = round(t_end / DT)
    c0, w0 = time.process_time(), time.perf_counter()
    for k in range(n):
        s.setReal(ins, list(_inputs(k)))
        s.doStep(k * DT, DT)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    omega = s.getReal([vr["omega_m"]])[0]
    s.terminate()
    s.freeInstance()
    assert omega > 100.0, omega  # the start happened
    return cpu, wall


def python_run(overrides, t_end):
    """(cpu, wall) [s] of ``t_end`` simulated by PlantUnit."""
    from satmotor.interface import PlantUnit

    u = PlantUnit({"h_int": H_INT, **overrides})
    n = round(t_end / DT)
    c0, w0 = time.process_time(), time.perf_counter()
    for k in range(n):
        u.step(k * DT, DT, _inputs(k))
    return time.process_time() - c0, time.perf_counter() - w0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--fmus", default="build/fmus", help="FMU directory (default build/fmus)")
    ap.add_argument("--rows", default="", help="comma-separated row numbers of OPTIONS to run (0, today's, "
                    "is always run: the ratios' base); default all")
    ap.add_argument("--no-write", action="store_true", help="do not rewrite bench/RESULTS.md")
    args = ap.parse_args(argv)
    keep = set(range(len(OPTIONS)))
    if args.rows:
        keep = {0, *(int(i) for i in args.rows.split(",") if i.strip())}
    fmu = Path(args.fmus) / "native" / "SaturatedInductionMotor.fmu"
    load0 = os.getloadavg()[0]
    print(f"load average before: {os.getloadavg()}")
    rows = []
    for i, (name, ov) in enumerate(OPTIONS):
        if i not in keep:
            continue
        n_sub_native = round(1.0 / H_INT)
        n_sub_py = round(0.1 / H_INT)
        nat = min((native_run(fmu, ov, 1.0) for _ in range(REPEATS)), key=lambda r: r[0])
        py = min((python_run(ov, 0.1) for _ in range(REPEATS)), key=lambda r: r[0])
        rows.append((name, [x / n_sub_native * 1e6 for x in nat], [x / n_sub_py * 1e6 for x in py]))
    print(f"load average after: {os.getloadavg()}")
    base_n, base_p = rows[0][1][0], rows[0][2][0]
    per_step = DT / H_INT  # today's RK4 sub-steps per doStep
    lines = ["per doStep of 1 ms [us], CPU (wall), ratio of CPU to today's; [per today's RK4 sub-step]",
             f"{'option':64s} {'native':>26s} {'ratio':>6s} {'Python':>28s} {'ratio':>6s}"]
    for name, (nc, nw), (pc, pw) in rows:
        lines.append(f"{name:64s} {nc * per_step:8.1f} ({nw * per_step:7.1f}) [{nc:6.3f}] {nc / base_n:6.2f} "
                     f"{pc * per_step:9.0f} ({pw * per_step:8.0f}) [{pc:6.2f}] {pc / base_p:6.2f}")
    print("\n".join(lines))
    if not args.no_write:
        head = ["## The plant's options: per-step cost (`python -m bench plant_options`)", "",
                measured(load0), "", "```"]
        write_section("plant_options", "\n".join(head + lines + ["```"]))


if __name__ == "__main__":
    main()
