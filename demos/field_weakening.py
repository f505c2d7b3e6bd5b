"""Field weakening to 2.5 times base speed: rotor flux, stator voltage and torque against speed.

The plain-Python units (satmotor.interface: the code both FMUs run) at the controller's defaults, once
with field weakening (the default) and once without (``field_weakening = False``): a slow speed ramp
0 -> 375 rad/s over [0.2, 4.2] s (2.5 times the base speed of 150 rad/s) against a constant-power
load, 4 kW / max(omega_ref, 150 rad/s) from 0.3 s.  Beside the runs, the steady-state curves of
satmotor.control.field_weakening at that load: the flux set-point, the breakdown torque within
0.95 V_dc/sqrt(3) and the torque the 30 A current limit gives at the set-point's flux
(satmotor.limits.torque_limit).  Writes a CSV of both runs and a PNG (docs/figures/field_weakening.png
is this figure).

Usage::

    python demos/field_weakening.py --out results
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
import pandas as pd

from satmotor.control.field_weakening import FieldWeakening, steady_point_at_flux
from satmotor.interface import ControllerUnit, PlantUnit
from satmotor.limits import torque_limit
from satmotor.machine.params import MotorParams

P_LOAD = 4000.0  # [W] the rated power
W_BASE, W_END = 150.0, 375.0  # [rad/s]
T_RAMP = (0.2, 4.2)  # [s]
V_MAX = 540.0 / math.sqrt(3.0)  # [V] the default V_dc


def load(t, omega_ref):
    """[N m] the constant-power load on the set-point (none before 0.3 s)."""
    return P_LOAD / max(omega_ref, W_BASE) if t >= 0.3 else 0.0


def run(field_weakening, t_end=4.6, every=20):
    """The closed loop; a DataFrame every ``every`` samples."""
    plant, ctrl = PlantUnit({}), ControllerUnit({"field_weakening": field_weakening})
    Ts, rows = ctrl.Ts, []
    names = ControllerUnit.OUTPUTS
    i_va, i_vb, i_ps = names.index("v_s_alpha"), names.index("v_s_beta"), names.index("psi_ref_shaped")
    i_vl, i_cl = names.index("voltage_limited"), names.index("current_limited")
    for k in range(round(t_end / Ts) + 1):
        t = k * Ts
        w_ref = min(max((t - T_RAMP[0]) / (T_RAMP[1] - T_RAMP[0]), 0.0), 1.0) * W_END
        tl = load(t, w_ref)
        o = plant.outputs()
        ctrl.step(t, Ts, (o[0], o[1], o[4], o[5], o[2], o[3], o[6], w_ref, 0.95, tl, 0.0))
        c = ctrl.outputs()
        plant.step(t, Ts, (c[i_va], c[i_vb], tl))
        if k % every == 0:
            rows.append((t, w_ref, o[6], math.hypot(o[4], o[5]), c[i_ps], math.hypot(c[i_va], c[i_vb]),
                         o[8], tl, math.hypot(o[0], o[1]), c[i_vl], c[i_cl]))
    return pd.DataFrame(rows, columns=["t [s]", "omega_ref [rad/s]", "omega_m [rad/s]", "psi_r [Wb]",
                                       "psi_ref_shaped [Wb]", "v_s [V]", "T_e [N m]", "T_load [N m]",
                                       "i_s [A]", "voltage_limited", "current_limited"])


def steady_curves(speeds):
    """The steady-state flux set-point [Wb], its voltage [V], the breakdown torque [N m] within
    0.95 V_max and the current-limit torque [N m] at the set-point's flux, per speed [rad/s], at the
    constant-power load (friction included)."""
    p = MotorParams()
    fw = FieldWeakening(p, V_MAX, 0.95, 40.0)
    out = []
    for w in speeds:
        T = P_LOAD / max(w, W_BASE) + p.B * w
        psi = fw.flux_at(T, w, 0.95)
        v = steady_point_at_flux(p, psi, T, w)[1][1]
        T_bd = fw.breakdown(200.0, w, 60.0, fw.V_lim)[0]
        out.append((psi, v, T_bd, torque_limit(p, psi, 30.0).T_max))
    return np.array(out)


def plot(on, off, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    speeds = np.linspace(5.0, W_END, 75)
    ss = steady_curves(speeds)
    fig, ax = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
    for df, label, style in ((on, "field weakening (default)", "-"), (off, "field_weakening = False", "--")):
        w = df["omega_m [rad/s]"]
        ax[0].plot(w, df["psi_r [Wb]"], style, label=f"|psi_r|, {label}")
        ax[1].plot(w, df["v_s [V]"], style, label=f"|v_s| command, {label}")
        ax[2].plot(w, df["T_e [N m]"], style, label=f"T_e, {label}")
    ax[0].plot(speeds, ss[:, 0], ":", color="k", label="steady-state flux set-point (the curve's)")
    ax[1].axhline(V_MAX, color="r", lw=0.8, label="V_dc/sqrt(3) = 311.8 V")
    ax[1].axhline(0.95 * V_MAX, color="k", ls=":", lw=0.8, label="0.95 V_dc/sqrt(3) (fw_voltage_ratio)")
    ax[2].plot(speeds, ss[:, 2], ":", color="r", label="breakdown torque within 0.95 V_dc/sqrt(3)")
    ax[2].plot(speeds, ss[:, 3], "-.", color="g", lw=0.8, label="current-limit torque (30 A) at that flux")
    ax[2].plot(on["omega_ref [rad/s]"], on["T_load [N m]"], color="k", lw=0.8, label="load 4 kW / omega")
    ax[0].set_ylabel("rotor flux [Wb]")
    ax[1].set_ylabel("stator voltage [V]")
    ax[2].set_ylabel("torque [N m]")
    ax[2].set_ylim(0.0, 80.0)
    ax[2].set_xlabel("speed omega_m [rad/s] (base speed 150 rad/s)")
    for a in ax:
        a.grid(True, lw=0.3)
        a.legend(fontsize=7, loc="best")
    ax[0].set_title("Ramp to 2.5 x base speed against a 4 kW constant-power load (satmotor, default drive)",
                    fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description="Field weakening to 2.5 x base speed: CSV and PNG of flux, "
                                 "voltage and torque against speed, with and without field weakening.")
    ap.add_argument("--out", default="results", help="output directory (default results)")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    on, off = run(True), run(False)
    stem = out / "field_weakening"
    pd.concat([on.assign(field_weakening=True), off.assign(field_weakening=False)]).to_csv(f"{stem}.csv",
                                                                                          index=False)
    plot(on, off, f"{stem}.png")
    for ext in ("csv", "png"):
        print(f"wrote {stem}.{ext}")
    for df, label in ((on, "on"), (off, "off")):
        end = df[df["t [s]"] >= 4.4]
        print(f"field weakening {label}: final speed {end['omega_m [rad/s]'].mean():.2f} rad/s, flux "
              f"{end['psi_r [Wb]'].mean():.4f} Wb, |v_s| {end['v_s [V]'].mean():.1f} V, peak |i_s| "
              f"{df['i_s [A]'].max():.2f} A, voltage limited in {100 * df['voltage_limited'].mean():.1f} % "
              f"of the samples")


if __name__ == "__main__":
    main()
