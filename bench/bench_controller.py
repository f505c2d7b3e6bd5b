"""Benchmark of the controllers: control-law and drive throughput against the plant step, and the closed loop.

Run ``python bench/bench_controller.py``; prints the numbers and replaces its own section of
``bench/RESULTS.md`` (the block between ``<!-- controller:start -->`` and ``<!-- controller:end -->``).

The inputs are the running states of closed-loop runs of the default ``RampScenario`` (default motor,
Ts = 100 us, one RK4 step per sample): every sample after pre-magnetization (ramp, steady speed, load
step) is recorded with the drive's internal state, then replayed.

(a) ``backstepping.control`` calls per second: known load, estimated load, and the constant-m model
    (``LinearCurve(L_m0)``), each on the inputs of its own closed-loop run.
(b) ``BacksteppingDrive.step`` and ``IFOCDrive.step`` calls per second: the drive is put at its
    recorded state at the first running sample and fed the recorded measurements and set-points in
    order (the replay reproduces the recorded voltages exactly; checked).
(c) ``Plant.step`` (RK4, n_sub = 1, h = Ts) per second on the recorded plant states and voltages.
(d) ``RampScenario().run`` (``closed_loop``) with the backstepping drive: wall seconds per simulated
    second and the real-time factor; the controller/plant cost ratio from (a) and (c).
"""

from __future__ import annotations

import dataclasses
import datetime
import math
import platform
import sys
import time
from typing import NamedTuple

import numpy as np
from bench_plant import best_time, cpu_model, write_section

from satmotor.control.backstepping import BacksteppingGains, ControllerConfig, control
from satmotor.control.drive import (
    RUN,
    STATE_FLUX,
    STATE_LAW,
    STATE_PHASE,
    STATE_SPEED,
    BacksteppingDrive,
    IFOCDrive,
)
from satmotor.machine.magnetics import LinearCurve
from satmotor.machine.params import MotorParams
from satmotor.machine.plant import Plant
from satmotor.simulate import RampScenario

REPEATS = 3
TS = 1e-4  # [s] sample period of both drives and the plant step
P = MotorParams()
P_LIN = dataclasses.replace(P, curve=LinearCurve(P.curve.L_m0))
GAINS = BacksteppingGains()
CFG_KNOWN = ControllerConfig(Ts=TS)
CFG_EST = ControllerConfig(Ts=TS, load_mode="estimated")
SCENARIO = RampScenario()


class Sample(NamedTuple):
    """One logged drive call: its arguments, the drive state before it and its output."""

    meas: tuple
    omega_ref: float
    psi_ref: float
    T_load: float
    state: tuple
    out: tuple


class Recorder:
    """Drive wrapper for ``closed_loop``: logs a :class:`Sample` per call."""

    def __init__(self, drive):
        self.drive, self.Ts, self.log = drive, drive.Ts, []

    def step(self, meas, omega_ref, psi_ref, T_load):
        s0 = self.drive.get_state()
        out = self.drive.step(meas, omega_ref, psi_ref, T_load)
        self.log.append(Sample(meas, omega_ref, psi_ref, T_load, s0, out))
        return out


def capture(make_drive):
    """One closed-loop RampScenario run; returns (drive, running samples of the log, recorded arrays)."""
    rec_drive = Recorder(make_drive())
    rec = SCENARIO.run(P, rec_drive)
    k0 = next(k for k, e in enumerate(rec_drive.log) if e.state[STATE_PHASE] == RUN)
    return make_drive(), rec_drive.log[k0:], rec, k0


def control_inputs(run_log):
    """(meas, ref, load, theta_hat) of each running sample, from the drive state before the step."""
    out = []
    for e in run_log:
        (theta_hat,) = e.state[STATE_LAW]
        out.append((e.meas, e.state[STATE_FLUX] + e.state[STATE_SPEED], (e.T_load, 0.0), theta_hat))
    return out


def control_rate(inputs, params, cfg):
    def loop():
        for meas, ref, load, th in inputs:
            control(meas, ref, load, params, GAINS, cfg, th)

    return len(inputs) / best_time(loop)[0]


def drive_rate(drive, run_log):
    s0 = run_log[0].state
    args = [(e.meas, e.omega_ref, e.psi_ref, e.T_load) for e in run_log]
    step, set_state = drive.step, drive.set_state

    def loop():
        set_state(s0)
        return [step(*a) for a in args]

    t, outs = best_time(loop)
    assert all(o == e.out for o, e in zip(outs, run_log)), "drive replay differs from the recorded run"
    return len(args) / t


def plant_rates(rec, k0):
    plant = Plant(P)
    n = len(rec["t"]) - 1
    X = np.column_stack([rec[k] for k in ("psi_s_alpha", "psi_s_beta", "psi_r_alpha", "psi_r_beta",
                                          "omega_m", "theta_m")])
    args = [(float(rec["t"][k]), tuple(X[k].tolist()), float(rec["v_s_alpha"][k]),
             float(rec["v_s_beta"][k]), float(rec["T_load"][k])) for k in range(k0, n)]
    step, outputs = plant.step, plant.outputs

    def loop_step():
        for t, x, va, vb, tl in args:
            step(t, x, va, vb, tl, TS)

    def loop_outputs():
        for a in args:
            outputs(a[1])

    return len(args) / best_time(loop_step)[0], len(args) / best_time(loop_outputs)[0]


def closed_loop_time(make_drive):
    """Best wall time of a full RampScenario run (fresh drive each time, drive construction excluded)."""
    best = math.inf
    for _ in range(REPEATS):
        drive = make_drive()
        t0 = time.perf_counter()
        SCENARIO.run(P, drive)
        best = min(best, time.perf_counter() - t0)
    return best


def us(rate):
    return 1e6 / rate


def main():
    t_start = time.perf_counter()
    makers = {
        "known": lambda: BacksteppingDrive(P, GAINS, CFG_KNOWN),
        "estimated": lambda: BacksteppingDrive(P, GAINS, CFG_EST),
        "constant_m": lambda: BacksteppingDrive(P_LIN, GAINS, CFG_KNOWN),
        "ifoc": lambda: IFOCDrive(P, Ts=TS),
    }
    runs = {}
    for name, mk in makers.items():
        runs[name] = capture(mk)
    drv, log, rec, k0 = runs["known"]
    n_run = len(log)
    print(f"captured RampScenario runs: {len(rec['t'])} samples, {n_run} after pre-magnetization "
          f"(from t = {rec['t'][k0]:.4f} s)")

    r_ctrl = {
        "known": control_rate(control_inputs(runs["known"][1]), P, CFG_KNOWN),
        "estimated": control_rate(control_inputs(runs["estimated"][1]), P, CFG_EST),
        "constant_m": control_rate(control_inputs(runs["constant_m"][1]), P_LIN, CFG_KNOWN),
    }
    r_drive = {name: drive_rate(runs[name][0], runs[name][1]) for name in ("known", "estimated", "ifoc")}
    r_step, r_out = plant_rates(rec, k0)
    t_cl = closed_loop_time(makers["known"])
    t_cl_ifoc = closed_loop_time(makers["ifoc"])

    for name, r in r_ctrl.items():
        print(f"(a) control() {name:10s}: {r:10,.0f} /s ({us(r):6.2f} us) = {us(r) / us(r_step):.2f} "
              "Plant.step")
    for name, r in r_drive.items():
        print(f"(b) drive.step {name:9s}: {r:10,.0f} /s ({us(r):6.2f} us) = {us(r) / us(r_step):.2f} "
              "Plant.step")
    print(f"(c) Plant.step RK4 h=Ts : {r_step:10,.0f} /s ({us(r_step):6.2f} us); "
          f"Plant.outputs {us(r_out):.2f} us")
    n_samples = round(SCENARIO.t_end / TS)
    per_sample = t_cl / n_samples
    print(f"(d) closed loop backstepping: {t_cl:.3f} s for {SCENARIO.t_end} s simulated = "
          f"{t_cl / SCENARIO.t_end:.3f} s/s, real-time factor {SCENARIO.t_end / t_cl:.2f}, "
          f"{per_sample * 1e6:.1f} us per sample; IFOC {t_cl_ifoc / SCENARIO.t_end:.3f} s/s")
    share = us(r_ctrl["known"]) / (us(r_ctrl["known"]) + us(r_step))
    print(f"    control()/Plant.step = {us(r_ctrl['known']) / us(r_step):.2f}, controller share "
          f"{100 * share:.0f} % of control + plant")

    env = (f"{datetime.date.today().isoformat()}, Python {platform.python_version()}, "
           f"numpy {np.__version__}, CPU: {cpu_model()}")
    print(f"environment: {env}; benchmark wall time {time.perf_counter() - t_start:.1f} s")
    write_results(env, n_run, float(rec["t"][k0]), r_ctrl, r_drive, (r_step, r_out), (t_cl, t_cl_ifoc))


def write_results(env, n_run, t_run, r_ctrl, r_drive, plant, cl):
    r_step, r_out = plant
    t_cl, t_cl_ifoc = cl
    t_end = SCENARIO.t_end
    u_step = us(r_step)
    n_samples = round(t_end / TS)
    u_sample = 1e6 * t_cl / n_samples
    u_rest = u_sample - us(r_drive["known"]) - u_step - us(r_out)

    def row(label, r):
        return f"| {label} | {r:,.0f} | {us(r):.2f} | {us(r) / u_step:.2f} |"

    rows = "\n".join([
        row("(a) `control()`, known load", r_ctrl["known"]),
        row("(a) `control()`, estimated load", r_ctrl["estimated"]),
        row("(a) `control()`, constant-m model (`LinearCurve(L_m0)`), known load", r_ctrl["constant_m"]),
        row("(b) `BacksteppingDrive.step`, known load", r_drive["known"]),
        row("(b) `BacksteppingDrive.step`, estimated load", r_drive["estimated"]),
        row("(b) `IFOCDrive.step`", r_drive["ifoc"]),
        row("(c) `Plant.step` (RK4, n_sub = 1, h = 100 us)", r_step),
        row("(info) `Plant.outputs` (read once per sample by the loop)", r_out),
    ])
    u_known = us(r_ctrl["known"])
    text = f"""## Controller benchmark

Measured {env}.

| quantity | calls per second | us per call | relative to one `Plant.step` |
|---|---|---|---|
{rows}

| closed loop, `RampScenario().run` ({t_end} s simulated, Ts = 100 us, {n_samples} samples) | value |
|---|---|
| (d) backstepping (known load): wall seconds per simulated second | {t_cl / t_end:.3f} s/s |
| (d) backstepping: real-time factor (simulated / wall time) | {t_end / t_cl:.2f} |
| (d) backstepping: wall time per sample | {u_sample:.1f} us |
| (info) IFOC drive, same loop: wall seconds per simulated second | {t_cl_ifoc / t_end:.3f} s/s |
| **`control()` (known load) / `Plant.step`** | **{u_known / u_step:.2f}** |
| controller share of control + plant, `control()` / (`control()` + `Plant.step`) | \
{100 * u_known / (u_known + u_step):.0f} % |
| per-sample split of (d): drive.step / Plant.step / Plant.outputs / loop rest (recording, profiles) \
| {us(r_drive["known"]):.1f} / {u_step:.1f} / {us(r_out):.1f} / {u_rest:.1f} us |

What was measured: the inputs of (a)-(c) are the {n_run} running samples (t = {t_run:.4f} s to {t_end} s:
speed ramp, steady speed, rated load step) of closed-loop `RampScenario` runs of the default 4 kW motor
(saturated plant), one run per design, so every controller sees its own trajectory. (a) calls of the
pure function `satmotor.control.backstepping.control` with the recorded measurements, shaped references, load
torque and load estimate; the constant-m model is `dataclasses.replace(params, curve=LinearCurve(L_m0))`
(closed-form magnetizing state instead of the Newton solve on the curve). (b) the same samples replayed
in order through `drive.step` from the drive state recorded at the first running sample (shapers,
load estimate or PI integrators; the replayed voltages equal the recorded ones). (c) `Plant.step`
(four right-hand-side evaluations) on the recorded plant states and held voltages. (d) the whole
scenario (pre-magnetization from rest included; its {n_samples - n_run} samples are cheaper) through
`satmotor.simulate.closed_loop`, recording every sample, fresh drive each run. Times are the best of
{REPEATS} runs with `time.perf_counter`; all ratios come from the same run of the script. The per-sample
split subtracts the mean costs (b), (c) and `Plant.outputs` from the loop's per-sample time; the rest is
the loop's own work (profiles, measurement tuple, recording). Rerun with
`python bench/bench_controller.py` (or `make bench`); it prints the same numbers and rewrites this
section only.
"""
    write_section("controller", text)


if __name__ == "__main__":
    sys.exit(main())
