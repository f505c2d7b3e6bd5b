"""The PWM inverter at low speed: current ripple, dead-time distortion and what the compensation recovers.

scenarios/pwm_low_speed.yaml (10 rad/s, half the rated load from 1 s; a 5 kHz PWM inverter with 4 us dead
time and 1.5 V drops) run three times with the plain-Python units (satmotor.interface: the code both
FMUs run, Gauss-Seidel as the master): the average-value inverter (the ideal), the PWM inverter without
dead-time compensation, and with ``deadtime_comp_voltage = t_dead f_sw V_dc + v_on`` (12.3 V, the
first-order error of satmotor/converter/inverter.py).  Over the steady window [1.3, 1.5] s it prints:

* the voltage error ``|v_avg - v_law|`` [V] rms: the step-average applied voltage (plant outputs
  v_avg_alpha/beta) against the law's voltage (the command less the compensation);
* the speed and rotor-flux errors (max relative), and the ripple of the stator current magnitude
  sampled at the controller's instants (std / mean) -- the low-frequency distortion the law sees;
* the current's in-step ripple, peak to peak [A], from a replay of the switched intervals.

The figure (docs/figures/pwm_low_speed.png is this figure): the phase-a current over 250 ms of the
steady state, at the controller's samples and resolved within the carrier period (the ripple), for
the three runs; the alpha voltage error against the closed form -sign(i_x) (t_dead f_sw V_dc + v_on) per
phase; the speed; a close-up of the current ripple over 15 carrier periods.

Usage::

    python demos/pwm_low_speed.py --out results
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from orchestration.scenario.load import load_scenario
from satmotor.control.deadtime import compensate
from satmotor.interface import ControllerUnit, PlantUnit
from satmotor.machine.phases import phase_currents

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scenarios" / "pwm_low_speed.yaml"
WINDOW = (1.3, 1.5)  # [s] the steady window of the scenario
ZOOM = (1.25, 1.5)  # [s] the figure's current window (in-step ripple resolved here)
RIPPLE = (1.300, 1.303)  # [s] the figure's close-up of the ripple: 15 carrier periods
SUB = 8  # pieces per constant interval in the ripple replay


def run(sc, plant_values, comp):
    """The closed loop of ``sc`` with the plant's ``plant_values`` and the compensation ``comp`` [V];
    a dict of arrays per controller sample and the in-step replay over ZOOM."""
    plant = PlantUnit(plant_values)
    ctrl = ControllerUnit({**sc.controller, "Ts": sc.Ts, "deadtime_comp_voltage": comp})
    prof = {k: p.value for k, p in sc.profiles.items()}
    h = sc.step
    names = ControllerUnit.OUTPUTS
    i_va, i_vb = names.index("v_s_alpha"), names.index("v_s_beta")
    rows, fine = [], []
    for k in range(round(sc.stop_time / h)):
        t = k * h
        o = plant.outputs()
        ctrl.step(t, h, (o[0], o[1], o[4], o[5], o[2], o[3], o[6], prof["omega_ref"](t), prof["psi_ref"](t),
                         prof["T_load"](t)))
        c = ctrl.outputs()
        law = (c[i_va], c[i_vb])
        if comp > 0.0:  # the law's voltage: the command less the compensation from the same currents
            dv = compensate(0.0, 0.0, o[0], o[1], comp)
            law = (c[i_va] - dv[0], c[i_vb] - dv[1])
        x0 = plant.x
        inv_before = plant.inverter.get_state() if plant.inverter is not None else None
        plant.step(t, h, (c[i_va], c[i_vb], prof["T_load"](t)))
        o2 = plant.outputs()
        rows.append((t + h, o2[0], o2[1], o2[6], math.hypot(o2[4], o2[5]), o2[10], o2[11], c[i_va], c[i_vb],
                     *law))
        if ZOOM[0] <= t < ZOOM[1]:
            fine += replay(plant, x0, inv_before, t, h, c[i_va], c[i_vb], prof["T_load"](t))
    a = np.array(rows)
    keys = ("t", "i_a", "i_b", "w", "psi", "v_avg_a", "v_avg_b", "v_cmd_a", "v_cmd_b", "v_law_a", "v_law_b")
    out = {key: a[:, j] for j, key in enumerate(keys)}
    out["fine"] = np.array(fine) if fine else np.empty((0, 2))
    return out


def replay(unit, x0, inv_state, t, h, va, vb, T_load):
    """(time, i_s_alpha) within the step: the switched intervals integrated again in SUB pieces each
    (the average inverter: the step in SUB pieces)."""
    plant = unit.plant
    if unit.inverter is None:
        pieces = [(t, h, va, vb)]
    else:
        inv = type(unit.inverter)(unit.inverter.params)
        inv.set_state(inv_state)
        trace = []
        inv.step(plant, t, x0, va, vb, T_load, h, unit.h_int, trace)
        pieces = [(r[0], r[1], r[2], r[3]) for r in trace]
    x, out = x0, []
    for t0, L, a, b in pieces:
        for j in range(SUB):
            x = plant.step(t0, x, a, b, T_load, L / SUB, 1)
            out.append((t0 + (j + 1) * L / SUB, plant.outputs(x).i_s_alpha))
    return out


def summary(r, E):
    m = (r["t"] >= WINDOW[0]) & (r["t"] <= WINDOW[1])
    dv = np.hypot(r["v_avg_a"] - r["v_law_a"], r["v_avg_b"] - r["v_law_b"])[m]
    i_mag = np.hypot(r["i_a"], r["i_b"])[m]
    f = r["fine"]
    ripple = 0.0
    if len(f):  # peak to peak of the in-step current about its step-sampled values (interpolated)
        base = np.interp(f[:, 0], r["t"], r["i_a"])
        ripple = float(np.max(f[:, 1] - base) - np.min(f[:, 1] - base))
    return {"v_err_rms [V]": float(np.sqrt(np.mean(dv ** 2))),
            "speed_err_max [1]": float(np.max(np.abs(r["w"][m] - 10.0)) / 10.0),
            "flux_err_max [1]": float(np.max(np.abs(r["psi"][m] - 0.95)) / 0.95),
            "i_s_ripple_lowfreq [1]": float(np.std(i_mag) / np.mean(i_mag)),
            "i_a_instep_ripple_pp [A]": ripple,
            "first_order_dead_time_error E [V]": E}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="results", help="directory for pwm_low_speed.png (default results)")
    args = ap.parse_args(argv)
    sc = load_scenario(SCENARIO)
    pv = dict(sc.plant)
    E = pv["t_dead"] * pv["f_sw"] * pv["V_dc"]
    comp = E + pv["v_on"]
    runs = {"average inverter": run(sc, dict(pv, inverter="average"), 0.0),
            "pwm, no compensation": run(sc, pv, 0.0),
            f"pwm, compensation {comp:.1f} V": run(sc, pv, comp)}
    for name, r in runs.items():
        print(name, {k: round(v, 5) for k, v in summary(r, E).items()})
    plot(runs, E, pv["v_on"], Path(args.out))


def plot(runs, E, v_on, out):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(4, 1, figsize=(9, 12), sharex=False)
    colors = ("k", "tab:red", "tab:blue")
    for (name, r), col in zip(runs.items(), colors):
        f = r["fine"]
        ideal = name.startswith("average")  # dashed, on top: the compensated run lies under it
        style = {"ls": "--", "zorder": 3} if ideal else {}
        ax[0].plot(f[:, 0], f[:, 1], color=col, lw=0.6, label=f"{name} (within the carrier period)", **style)
        m = (r["t"] >= ZOOM[0]) & (r["t"] <= ZOOM[1])
        if name.startswith("pwm"):
            # the alpha component of the voltage error: the step averages against the law's voltage
            ea = r["v_avg_a"] - r["v_law_a"]
            ax[1].plot(r["t"][m], ea[m], color=col, lw=0.8, label=f"{name}: v_avg_alpha - v_law_alpha")
        if name.startswith("pwm, no"):
            # first order: -sign(i_x) (t_dead f_sw V_dc + v_on) per phase, its alpha component
            e = [-np.sign(i) * (E + v_on) for i in phase_currents(r["i_a"], r["i_b"])]
            closed = (2.0 * e[0] - e[1] - e[2]) / 3.0
            ax[1].plot(r["t"][m], closed[m], "k--", lw=0.8,
                       label="closed form: -sign(i_x) (t_dead f_sw V_dc + v_on) per phase, alpha")
        ax[2].plot(r["t"], r["w"], color=col, lw=0.8, label=name, **style)
        z = (f[:, 0] >= RIPPLE[0]) & (f[:, 0] <= RIPPLE[1])
        ax[3].plot(f[z, 0], f[z, 1] - np.mean(f[z, 1]), color=col, lw=0.8, label=name, **style)
    ax[0].set_ylabel("i_s_alpha = i_a [A]")
    ax[0].set_title("10 rad/s, half rated load: 5 kHz PWM, 4 us dead time, 1.5 V drops "
                    "(scenarios/pwm_low_speed.yaml)")
    ax[1].set_ylabel("voltage error [V]")
    ax[2].set_ylabel("omega_m [rad/s]")
    ax[3].set_ylabel("i_a - its mean there [A]")
    ax[3].set_xlabel("t [s]")
    for a in ax:
        a.grid(alpha=0.3)
        a.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(out / "pwm_low_speed.png", dpi=110)
    print("wrote", out / "pwm_low_speed.png")


if __name__ == "__main__":
    main()
