"""Benchmark against two open-source induction-motor simulators, side by side in one run:
gym-electric-motor (its squirrel-cage induction motor environment) and motulator (its saturated
2.2 kW induction-motor drive example), against our closed loop, in wall seconds per simulated second.

Run ``python -m bench peers`` after ``pip install -e ".[bench]"`` (``make bench`` does both);
prints the numbers and replaces its own section of ``bench/RESULTS.md`` (between
``<!-- peers:start -->`` and ``<!-- peers:end -->``); ``--no-write`` leaves the file alone.

What each side computes (every one at a 100 us control / communication period):

* gym-electric-motor: ``gem.make("Cont-SC-SCIM-v0", constraints=())`` stepped at its default
  ``tau = 1e-4`` s.  Its squirrel-cage motor is linear (constant inductances: no saturation),
  5 electrical states (``i_s``, ``psi_r`` in alpha-beta, the rotor angle) and 1 mechanical (speed,
  polynomial static load), integrated by ``scipy.integrate.ode('dopri5')`` (adaptive Runge-Kutta
  4(5), rtol 1e-6, atol 1e-12) over each period; the converter is the continuous (averaged) B6
  bridge.  Each ``env.step`` also draws the Wiener-process speed reference, computes the reward and
  normalizes the observation.  The action is an open-loop V/f start computed here (0 to 50 Hz in
  0.5 s, 8 V boost, 258 V at 50 Hz); the current constraint is removed so that the episode runs the
  whole simulated time without a reset (the start draws up to about 8 A, above the environment's
  5.5 A limit).
* motulator: the example "2.2-kW induction motor, saturated" of release 0.5.0
  (``examples/drive/vector/plot_vector_ctrl_im_2kw.py``), with the control period set to 100 us
  (the example uses 250 us): Gamma-model machine with main-flux saturation
  ``L_s(|psi_s|) = 0.34 / (1 + (0.84 |psi_s|)^7)``, states ``psi_s``, ``psi_r`` (complex),
  speed and ``exp(j theta_M)``, integrated by ``scipy.integrate.solve_ivp`` RK45 (adaptive,
  rtol 1e-3, atol 1e-6: its defaults) over each period; zero-order-hold converter (no PWM model),
  one-sample computational delay; sensorless current-vector control (flux observer, PI current
  controller, 2DOF PI speed controller), speed step to 0.5 p.u. at 0.2 s, rated load at 0.75 s.
* ours: the default scenario (``scenarios/ramp_rated_load.yaml``: pre-magnetization, speed ramp,
  rated load step) of the 4 kW motor: saturated plant (magnetizing curve, safeguarded Newton solve
  of the magnetizing current in every right-hand-side evaluation), 6 states (``psi_s``, ``psi_r``,
  speed, angle), one fixed-step RK4 step per 100 us period; the backstepping controller (saturated
  control model, reference shapers, limits) every 100 us; every step recorded.  Four ways: the
  plain-Python loop (``orchestration.run.reference.plain_reference``: the same units without FMI) and
  the fmpy master (``orchestration.run.master.run``) with the pythonfmu FMUs, the native C FMI 2.0
  FMUs and the native C FMI 3.0 FMUs.

Each measurement is a child process running one side twice and keeping its better run (a fresh
interpreter holding only that side's modules: one side's imports do not slow another's garbage
collections); rounds alternate the sides; the table keeps the best of each, in wall time and in
CPU time
(``time.process_time``: on a shared machine the time spent waiting for a core is in the wall time
only, so the CPU times give the steadier ratios; on an idle machine the two agree).
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import subprocess
import sys
import time
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

from bench.common import cpu_model, write_section

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from orchestration.packaging import fmus  # noqa: E402
from orchestration.run.master import run  # noqa: E402
from orchestration.run.reference import plain_reference  # noqa: E402
from orchestration.scenario.load import load_scenario  # noqa: E402

SCENARIO = ROOT / "scenarios" / "ramp_rated_load.yaml"
GEM_TIME = 1.0  # [s] simulated by gym-electric-motor
MOTULATOR_TIME = 1.5  # [s] simulated by motulator (the example's whole run)


def package_version(name):
    try:
        return version(name)
    except PackageNotFoundError:
        return None


def gem_run(t_stop=GEM_TIME):
    """gym-electric-motor's SCIM environment stepped for ``t_stop`` seconds with an open-loop V/f
    action; returns (simulated seconds, final speed [rad/s])."""
    import gym_electric_motor as gem
    import numpy as np

    env = gem.make("Cont-SC-SCIM-v0", constraints=())
    system = env.unwrapped.physical_system
    tau = system.tau
    env.reset(seed=0)
    n = round(t_stop / tau)
    u_max = float(system.limits[system.state_names.index("u_sa")])  # the action's full scale [V]
    state = None
    two_thirds_pi = 2.0 * math.pi / 3.0
    for k in range(n):
        t = k * tau
        f = min(50.0, 100.0 * t)  # [Hz] 0 to 50 Hz in 0.5 s
        theta = 2.0 * math.pi * (50.0 * t * t if t < 0.5 else 12.5 + 50.0 * (t - 0.5))
        a = (8.0 + 250.0 * f / 50.0) / u_max
        action = np.array([a * math.cos(theta), a * math.cos(theta - two_thirds_pi),
                           a * math.cos(theta + two_thirds_pi)])
        (state, _), _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            raise RuntimeError(f"gym-electric-motor ended the episode at t = {t:.4f} s")
    omega = float(state[system.state_names.index("omega")] * system.limits[system.state_names.index("omega")])
    return n * tau, omega


def motulator_run(t_stop=MOTULATOR_TIME, T_s=100e-6):
    """motulator 0.5.0's saturated 2.2 kW induction-motor drive example at control period ``T_s``;
    returns (simulated seconds, final rotor speed [rad/s])."""
    import motulator.drive.control.im as control
    from motulator.drive import model
    from motulator.drive.utils import (
        BaseValues,
        InductionMachineInvGammaPars,
        InductionMachinePars,
        NominalValues,
    )

    nom = NominalValues(U=400, I=5, f=50, P=2.2e3, tau=14.6)
    base = BaseValues.from_nominal(nom, n_p=2)

    def L_s(psi, L_su=0.34, beta=0.84, S=7):  # the example's main-flux saturation model [H]
        return L_su / (1 + (beta * psi) ** S)

    mdl_par = InductionMachinePars(n_p=2, R_s=3.7, R_r=2.5, L_ell=0.023, L_s=L_s)
    mdl = model.Drive(model.VoltageSourceConverter(u_dc=540), model.InductionMachine(mdl_par),
                      model.StiffMechanicalSystem(J=0.015))
    par = InductionMachineInvGammaPars(n_p=2, R_s=3.7, R_R=2.1, L_sgm=0.021, L_M=0.224)
    cfg = control.CurrentReferenceCfg(par, max_i_s=1.5 * base.i, nom_u_s=base.u, nom_w_s=base.w)
    ctrl = control.CurrentVectorControl(par, cfg, J=0.015, T_s=T_s, sensorless=True)
    ctrl.ref.w_m = lambda t: (t > 0.2) * (0.5 * base.w)
    mdl.mechanics.tau_L = lambda t: (t > 0.75) * nom.tau
    sim = model.Simulation(mdl, ctrl)
    sim.simulate(t_stop=t_stop)
    return t_stop, float(mdl_par.n_p * mdl.mechanics.state.w_M.real)


def ours(kind, sc, paths):
    """One run of our default scenario; returns (simulated seconds, final speed [rad/s])."""
    if kind == "plain":
        df = plain_reference(sc)
        return sc.stop_time, float(df["plant.omega_m"].iloc[-1])
    res = run(sc, *paths[kind])
    if not res.ok:
        raise RuntimeError(f"{kind}: {res.message}")
    return sc.stop_time, float(res.recorder.arrays(["plant.omega_m"])["plant.omega_m"][-1])


LABELS = {
    "gem": "gym-electric-motor {gym-electric-motor}",
    "motulator": "motulator {motulator}",
    "plain": "ours, plain Python loop",
    "python": "ours, fmpy master + pythonfmu FMUs",
    "native": "ours, fmpy master + native FMI 2.0 FMUs",
    "native-fmi3": "ours, fmpy master + native FMI 3.0 FMUs",
}


def side(key):
    """The function running side ``key`` once: ``() -> (simulated seconds, final speed)``."""
    if key == "gem":
        return gem_run
    if key == "motulator":
        return motulator_run
    fmu_dir = ROOT / "build" / "fmus"
    paths = {v: tuple(str(p) for p in fmus.paths(fmu_dir, v)) for v in ("python", "native", "native-fmi3")}
    sc = load_scenario(SCENARIO)
    return lambda: ours(key, sc, paths)


def child(key, runs=2):
    """Run side ``key`` ``runs`` times in this process; print the best wall and CPU time as JSON."""
    fn = side(key)
    wall = cpu = math.inf
    for _ in range(runs):
        t0, c0 = time.perf_counter(), time.process_time()
        simulated, final = fn()
        wall, cpu = min(wall, time.perf_counter() - t0), min(cpu, time.process_time() - c0)
    print(json.dumps({"wall": wall, "cpu": cpu, "simulated": simulated, "final": final}))


def measure(key):
    r = subprocess.run([sys.executable, "-m", "bench.bench_peers", "--child", key], capture_output=True,
                       text=True, cwd=ROOT)
    if r.returncode != 0:
        raise SystemExit(f"{key}: the measuring child failed:\n{r.stderr[-3000:]}")
    return json.loads(r.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=2, help="alternating rounds (default 2)")
    ap.add_argument("--no-write", action="store_true", help="do not rewrite bench/RESULTS.md")
    ap.add_argument("--child", choices=tuple(LABELS), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        child(args.child)
        return
    versions = {p: package_version(p) for p in ("gym-electric-motor", "motulator", "fmpy", "numpy", "scipy")}
    missing = [p for p in ("gym-electric-motor", "motulator") if versions[p] is None]
    if missing:
        raise SystemExit(f"{', '.join(missing)} not installed: pip install -e \".[bench]\" (or make bench)")
    fmus.ensure(ROOT / "build" / "fmus", quiet=True)
    sides = {key: (label.format(**versions), None) for key, label in LABELS.items()}
    load0 = os.getloadavg()[0]
    best, cpu, simulated, final = {}, {}, {}, {}
    for r in range(args.rounds):
        for key in sides:
            out = measure(key)
            simulated[key], final[key] = out["simulated"], out["final"]
            best[key] = min(best.get(key, math.inf), out["wall"] / simulated[key])
            cpu[key] = min(cpu.get(key, math.inf), out["cpu"] / simulated[key])
            print(f"round {r + 1}: {key}: {out['wall']:.2f} s wall, {out['cpu']:.2f} s CPU for "
                  f"{simulated[key]:.2f} s simulated", flush=True)
    load1 = os.getloadavg()[0]

    lines = [
        "## Peers: gym-electric-motor and motulator against our closed loop",
        "",
        f"Measured {datetime.date.today()}, Python {platform.python_version()}, CPU: {cpu_model()} "
        f"({os.cpu_count()} cores, shared: load average {load0:.1f} at the start, {load1:.1f} at the end); "
        + ", ".join(f"{p} {v}" for p, v in versions.items())
        + f"; best of {args.rounds} alternating rounds x 2 runs, one child process per side and round.",
        "",
        "| simulator (100 us period) | simulated | CPU (wall) s per simulated s "
        "| native FMI 2.0 is faster by, CPU (wall) |",
        "|---|---|---|---|",
    ]
    for key, (label, _) in sides.items():
        lines.append(f"| {label} | {simulated[key]:.2f} s | {cpu[key]:.3f} ({best[key]:.3f}) | "
                     f"**{cpu[key] / cpu['native']:.1f}x** ({best[key] / best['native']:.1f}x) |")
    lines += [
        "",
        "Final speeds (a sanity check that each ran its scenario): gym-electric-motor "
        f"{final['gem']:.1f} rad/s mechanical (V/f at 50 Hz, 2 pole pairs: 157.1 rad/s synchronous), "
        f"motulator {final['motulator']:.1f} rad/s electrical (set-point 0.5 p.u. = 157.1 rad/s), ours "
        f"{final['native']:.2f} rad/s mechanical (set-point 100 rad/s).",
        "",
        "What each computes (all at a 100 us period): gym-electric-motor: linear squirrel-cage motor "
        "(no saturation), 6 states, adaptive dopri5 (rtol 1e-6) over each period, open-loop V/f action, "
        "plus its reference, reward and observation per step. motulator: saturated Gamma model "
        "(L_s(|psi_s|)), 4 complex states, adaptive RK45 (rtol 1e-3) over each period, sensorless "
        "current-vector control with observer and speed controller. Ours: saturated model (Newton "
        "solve of the magnetizing current per right-hand side), 6 states, one fixed RK4 step per "
        "period, backstepping controller with its shapers and limits, every step recorded. The models, "
        "integrators and controllers differ: the ratios compare the cost of a simulated second of a "
        "closed-loop induction-motor drive, not the same computation. See the docstring of "
        "`bench/bench_peers.py`.",
        "",
        "Rerun with `python -m bench peers` (needs `pip install -e \".[bench]\"`; `make bench` does "
        "both); it rewrites this section.",
    ]
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        write_section("peers", text)


if __name__ == "__main__":
    main()
