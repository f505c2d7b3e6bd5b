"""The paper's result on its machine (issue 35, item 6): the loss-minimizing flux of ``qu2012_2kw2``
(Qu, Ranta, Hinkkanen, Luomi, IEEE Trans. Ind. Appl. 48(3), 2012) against torque at a few speeds, and
the loss reduction against the nominal flux, with the saturated curve and with a constant inductance.

The preset gives no core loss; without it the losses of a steady state do not depend on the speed
(copper only), so the speeds differ only where the field weakening acts.  The table and the figure take
``R_FE = 2700 Ohm`` in the plant and the same in the controller's loss model (``loss_R_fe``): about 50 W
of core loss at the rated point, the estimate of the preset's thermal notes (an assumption, not the
paper's figure), and give the copper-only case (the preset as it is) at 100 rad/s beside it.

* Model (the controller's own loss model, :mod:`satmotor.control.loss_min`): the optimum on the saturated
  curve, and the optimum a constant-inductance minimizer chooses (the same search on the line
  ``m = L_m(psi_nominal)``, the secant inductance at the nominal flux, as the IFOC baseline takes it),
  whose losses are then those of the saturated machine at that flux.  Upper flux 1.15 Wb, the field
  weakening's set-point within 0.95 V_dc/sqrt(3) where it is lower.
* Closed loop (native FMUs under the project's master, 0.8 s from a magnetized machine at speed): the
  input power at the terminals from the plant's outputs (``3/2 v_avg . i_s``) minus the load's
  ``T omega_m``, averaged over [0.6, 0.8] s (with core loss, integral action on: c0 = 1e4 1/s2,
  d0 = 2500 1/s2, so that every run holds the speed), for flux_mode nominal (psi_ref = 0.95 Wb), flux_mode
  loss_minimizing (psi_ref = 0.95 Wb: the nominal is its upper flux) and the constant-inductance
  optimum as a fixed set-point.

Writes ``loss_min_qu2012.csv`` (the table) and ``loss_min_qu2012.png`` into ``--out``
(docs/figures/loss_min_qu2012.png is this figure), and prints the table in Markdown.

Usage::

    python scripts/loss_min_qu2012.py --out results [--fmus build/fmus] [--no-cosim]
"""

from __future__ import annotations

import argparse
import math
import tempfile
from pathlib import Path

import numpy as np

from satmotor.control.field_weakening import FieldWeakening, steady_point_at_flux
from satmotor.control.loss_min import LossMinimizer, steady_losses
from satmotor.machine.library import preset
from satmotor.machine.magnetics import LinearCurve

MOTOR = preset("qu2012_2kw2")
P = MOTOR.params()
T_N = MOTOR.nameplate.T_n  # [N m] 14.6
PSI_NOM = 0.95  # [Wb] the library scenario's nominal flux (scenarios/qu2012_ramp_rated_load.yaml)
PSI_TOP = 1.15  # [Wb] the figure's upper flux
V_MAX = 540.0 / math.sqrt(3.0)  # [V] the controller's default V_dc
SPEEDS = (50.0, 100.0, 150.0)  # [rad/s] (base speed about 150)
SHARES = (0.1, 0.25, 0.5)  # of the rated torque: the table
FLOOR, RATE = 0.25, 5.0  # the controller's defaults flux_floor [Wb], flux_rate_max [V s/s]
R_FE = 2700.0  # [Ohm] assumed core-loss resistance (module docstring)
CASES = tuple((w, R_FE) for w in SPEEDS) + ((100.0, 0.0),)  # (speed [rad/s], R_fe [Ohm]) of the table


def constant_inductance_params():
    """The machine with the line ``m = L_m(PSI_NOM)``: the secant inductance at the nominal flux."""
    import dataclasses

    psi_m = PSI_NOM / P.k
    return dataclasses.replace(P, curve=LinearCurve(psi_m / P.curve.current(psi_m)))


P_LIN = constant_inductance_params()


def loss_at(Phi, T, w, R_fe):
    """The saturated machine's modelled loss [W] at the rotor flux Phi [Wb]."""
    I, _ = steady_point_at_flux(P, Phi, T, w)
    return steady_losses(P, I, T, w, R_fe)[1]


def optima(T, w, psi_top, R_fe):
    fw = FieldWeakening(P, V_MAX, 0.95, 40.0)
    hi = fw.flux_at(T, w, psi_top)
    sat = LossMinimizer(P, 1e-4, FLOOR, RATE, R_fe).optimum(T, w, hi)
    lin = LossMinimizer(P_LIN, 1e-4, FLOOR, RATE, R_fe).optimum(T, w, hi)
    return sat, lin, hi


def cosim(fmu_dir, T, w, R_fe, mode, psi_ref, psi0, work):
    """Closed-loop steady (loss [W], flux [Wb]) through the native FMUs (module docstring)."""
    from orchestration.packaging import fmus
    from orchestration.run.master import run
    from orchestration.scenario.load import load_scenario

    path = work / "case.yaml"
    # with core loss the law's model (no core loss) needs integral action to hold the speed
    integral = ", c0: 10000.0, d0: 2500.0" if R_fe else ""
    path.write_text(f"""name: loss_min_qu2012
stop_time: 0.8
step: 1.0e-4
controller_every: 1
motor: {{preset: qu2012_2kw2}}
plant: {{omega_m0: {w}, psi_r0: {psi0}, R_fe: {R_fe}}}
controller: {{flux_mode: {mode}, loss_R_fe: {R_fe}{integral}}}
profiles:
  psi_ref: {{type: constant, value: {psi_ref}}}
  omega_ref: {{type: constant, value: {w}}}
  T_load: {{type: constant, value: {T}}}
record: {{interval: 1.0e-4}}
""")
    plant, ctrl = fmus.paths(fmu_dir, "native")
    res = run(load_scenario(path), str(plant), str(ctrl))
    if not res.ok:
        raise RuntimeError(res.message)
    df = res.frame
    t = df["time"].to_numpy()
    ia, ib = df["plant.i_s_alpha"].to_numpy(), df["plant.i_s_beta"].to_numpy()
    va, vb = df["plant.v_avg_alpha"].to_numpy()[1:], df["plant.v_avg_beta"].to_numpy()[1:]
    p_in = 1.5 * (va * 0.5 * (ia[1:] + ia[:-1]) + vb * 0.5 * (ib[1:] + ib[:-1]))
    s = t[1:] > 0.6 + 1e-9
    w_m = df["plant.omega_m"].to_numpy()[1:][s]
    phi = np.hypot(df["plant.psi_r_alpha"], df["plant.psi_r_beta"]).to_numpy()[1:][s]
    return float(np.mean(p_in[s] - T * w_m)), float(np.mean(phi))


def table(fmu_dir):
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for w, R_fe in CASES:
            for share in SHARES:
                T = share * T_N
                sat, lin, hi = optima(T, w, PSI_NOM, R_fe)
                nom = min(PSI_NOM, hi)
                row = dict(speed=w, R_fe=R_fe, torque_share=share, torque=T, psi_nominal=nom, psi_lm=sat,
                           psi_const_L=lin, model_loss_nominal=loss_at(nom, T, w, R_fe),
                           model_loss_lm=loss_at(sat, T, w, R_fe),
                           model_loss_const_L=loss_at(lin, T, w, R_fe))
                if fmu_dir is not None:
                    work = Path(tmp)
                    row["cosim_loss_nominal"], _ = cosim(fmu_dir, T, w, R_fe, "nominal", PSI_NOM, nom, work)
                    row["cosim_loss_lm"], row["cosim_psi_lm"] = cosim(fmu_dir, T, w, R_fe, "loss_minimizing",
                                                                      PSI_NOM, nom, work)
                    row["cosim_loss_const_L"], _ = cosim(fmu_dir, T, w, R_fe, "nominal", round(lin, 6),
                                                         round(lin, 6), work)
                rows.append(row)
    return rows


def markdown(rows):
    cos = "cosim_loss_lm" in rows[0]
    head = ("| speed, R_fe | torque | flux: nominal / loss-min / const.-L | loss at nominal "
            "| loss-min: loss, reduction | const.-L: loss, reduction |")
    out = [head, "|---|---|---|---|---|---|"]
    for r in rows:
        src = "cosim" if cos else "model"
        ln, lm, lc = r[f"{src}_loss_nominal"], r[f"{src}_loss_lm"], r[f"{src}_loss_const_L"]
        out.append(f"| {r['speed']:.0f} rad/s, {r['R_fe']:.0f} Ohm | "
                   f"{r['torque_share'] * 100:.0f} % ({r['torque']:.2f} N m) | "
                   f"{r['psi_nominal']:.3f} / {r['psi_lm']:.3f} / {r['psi_const_L']:.3f} Wb | {ln:.1f} W | "
                   f"{lm:.1f} W, {(1 - lm / ln) * 100:.1f} % | {lc:.1f} W, {(1 - lc / ln) * 100:.1f} % |")
    return "\n".join(out)


def _reduction(psi, T, w, hi):
    """[%] the loss reduction of the set-point min(psi, PSI_NOM) against min(PSI_NOM, hi) (R_FE)."""
    return (1 - loss_at(min(psi, PSI_NOM), T, w, R_FE) / loss_at(min(PSI_NOM, hi), T, w, R_FE)) * 100


def figure(rows, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    shares = np.linspace(0.02, 1.0, 50)
    colors = dict(zip(SPEEDS, ("C0", "C1", "C2")))
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    for w, c in colors.items():
        opt = [optima(s * T_N, w, PSI_TOP, R_FE) for s in shares]
        a.plot(shares * 100, [o[0] for o in opt], color=c, label=f"{w:.0f} rad/s, saturated curve")
        a.plot(shares * 100, [o[1] for o in opt], color=c, ls="--", label=f"{w:.0f} rad/s, constant L")
        b.plot(shares * 100, [_reduction(o[0], s * T_N, w, o[2]) for s, o in zip(shares, opt)], color=c,
               label=f"{w:.0f} rad/s, saturated curve")
        b.plot(shares * 100, [_reduction(o[1], s * T_N, w, o[2]) for s, o in zip(shares, opt)], color=c,
               ls="--", label=f"{w:.0f} rad/s, constant L")
    for r in (r for r in rows if r["R_fe"] == R_FE and "cosim_loss_lm" in r):
        x, c, ln = r["torque_share"] * 100, colors[r["speed"]], r["cosim_loss_nominal"]
        b.plot(x, (1 - r["cosim_loss_lm"] / ln) * 100, "o", color=c)
        b.plot(x, (1 - r["cosim_loss_const_L"] / ln) * 100, "x", color=c)
    a.axhline(PSI_NOM, color="k", lw=0.8, ls=":", label="nominal 0.95 Wb")
    a.set(xlabel="torque [% of 14.6 N m]", ylabel="loss-minimizing rotor flux [Wb]",
          title=f"qu2012_2kw2, R_fe {R_FE:.0f} Ohm: least-loss flux (upper {PSI_TOP} Wb)")
    b.axhline(0.0, color="k", lw=0.8)
    b.set(xlabel="torque [% of 14.6 N m]", ylabel="loss reduction against 0.95 Wb [%]", ylim=(-5, 80),
          title="set-point at most 0.95 Wb (lines: model; o, x: closed loop)")
    for ax in (a, b):
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("results"))
    ap.add_argument("--fmus", type=Path, default=Path("build/fmus"))
    ap.add_argument("--no-cosim", action="store_true", help="the model only (no FMU runs)")
    a = ap.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    rows = table(None if a.no_cosim else a.fmus)
    import csv

    with open(a.out / "loss_min_qu2012.csv", "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows(rows)
    figure(rows, a.out / "loss_min_qu2012.png")
    print(markdown(rows))


if __name__ == "__main__":
    main()
