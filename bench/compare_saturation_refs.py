"""Saturation-aware references against a constant-inductance design and the IFOC baseline, 0.5 to
2.5 times base speed, through the FMUs and the project's master (issue 20, item 4).

For each motor preset (``default_4kw``, ``qu2012_2kw2``), each speed ``x omega_n`` (``x`` in
0.5 .. 2.5, ``omega_n`` the name plate's rated speed) and each controller design (the controller's
String parameter ``mode``):

* ``saturated``: the backstepping law, its field weakening and its references on the magnetizing curve;
* ``constant_m``: the same law and the same field-weakening code with the curve replaced by the line
  ``m = L_m0`` (the unsaturated inductance) in the controller's model: references, voltage
  prediction and current bound of a constant-inductance design;
* ``m_rated``: the same again with the line through the nominal point instead, ``m`` the secant
  inductance at the no-load magnetizing current of ``psi_ref`` (a constant inductance fitted where the
  machine runs at base speed; the controller's ``curve: linear``, ``L_m0`` that value; the plant keeps
  its curve);
* ``pi``: the IFOC baseline (``satmotor/control/ifoc.py``), constant ``L_m``, fed the (saturation-aware)
  flux set-point of the drive's field weakening;

one run: plant and controller at the preset (``psi_ref`` 0.95 Wb nominal, field weakening on, measured
flux and speed, known load), pre-magnetization, a speed ramp at 300 rad/s^2 from 0.3 s, then the load
ramped over 0.2 s to the rated torque (``x <= 1``) or the rated power ``P_n / omega`` (``x > 1``,
constant power), then 0.7 s of steady state.  Over the last 0.3 s (the window):

* ``speed err``: mean ``omega_m / omega_ref - 1``;
* ``set-point``: mean ``psi_ref_shaped`` [Wb] (the flux the design works to);
* ``flux err``: the plant's true ``|psi_r|`` against it, mean relative error;
* ``T/A``: mean plant ``T_e`` over mean ``|i_s|`` [N m/A];
* ``peak/I_max``: the largest ``|i_s|`` of the whole run over the controller's ``I_max``;
* ``margin``: ``1 - max |v_s| / (V_dc / sqrt 3)`` in the window; ``v-lim``: the share of samples with
  the output ``voltage_limited`` in the window.

Usage::

    python bench/compare_saturation_refs.py --fmus build/fmus --variant native \
        --csv bench/saturation_refs.csv --figure docs/figures/saturation_refs.png
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import tempfile
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from orchestration.packaging import fmus  # noqa: E402
from orchestration.run.master import run  # noqa: E402
from orchestration.scenario.load import load_scenario  # noqa: E402
from satmotor.machine.library import MOTORS  # noqa: E402

PRESETS = ("default_4kw", "qu2012_2kw2")
MODES = ("saturated", "constant_m", "m_rated", "pi")
FACTORS = (0.5, 1.0, 1.5, 2.0, 2.5)
PSI_REF = 0.95  # [Wb] nominal flux
ACCEL = 300.0  # [rad/s^2] speed ramp
T_RAMP0 = 0.3  # [s] ramp start
LOAD_RISE = 0.2  # [s] load ramp
SETTLE = 0.7  # [s] steady state after the load
WINDOW = 0.3  # [s] last part of the run that is judged
V_DC = 540.0  # [V] the controller's default
COLUMNS = ("motor", "x", "omega_ref", "T_load", "mode", "speed_err", "set_point", "flux_err", "T_per_A",
           "peak_over_I_max", "margin", "v_limited")


def load_torque(preset, x):
    """[N m] the rated torque up to base speed, the rated power over the speed above."""
    plate = MOTORS[preset].nameplate
    w_n = plate.n_n * math.pi / 30.0
    return plate.T_n if x <= 1.0 else plate.P_n / (x * w_n)


def rated_inductance(preset):
    """[H] the secant inductance of the preset's curve at the no-load magnetizing point of PSI_REF."""
    p = MOTORS[preset].params()
    psi_m = PSI_REF / p.k
    return psi_m / p.curve.current(psi_m)


def controller(preset, mode):
    """The scenario's controller section of one design."""
    if mode == "m_rated":
        return {"mode": "saturated", "curve": "linear", "L_m0": rated_inductance(preset)}
    return {"mode": mode}


def scenario(preset, x, mode):
    """The raw scenario dict of one run (module docstring)."""
    plate = MOTORS[preset].nameplate
    w = x * plate.n_n * math.pi / 30.0
    t1 = T_RAMP0 + w / ACCEL
    T = load_torque(preset, x)
    stop = round(t1 + 0.05 + LOAD_RISE + SETTLE, 3)
    return {
        "name": f"satrefs_{preset}_{x:g}_{mode}",
        "description": f"{preset} at {x:g} x base speed, {mode}",
        "stop_time": stop,
        "step": 1.0e-4,
        "motor": {"preset": preset},
        "controller": controller(preset, mode),
        **({"mismatch": True} if mode == "m_rated" else {}),
        "profiles": {
            "psi_ref": {"type": "constant", "value": PSI_REF},
            "omega_ref": {"type": "ramp", "start": T_RAMP0, "end": round(t1, 6), "from": 0.0, "to": w},
            "T_load": {"type": "table", "points": [[0.0, 0.0], [round(t1 + 0.05, 6), 0.0],
                                                   [round(t1 + 0.05 + LOAD_RISE, 6), T]]},
        },
    }


def measure(frame, raw, I_max):
    """The metrics of the module docstring from a run's frame."""
    t = frame["time"].to_numpy()
    stop = raw["stop_time"]
    win = t >= stop - WINDOW - 1e-9
    w_ref = raw["profiles"]["omega_ref"]["to"]
    psi = np.hypot(frame["plant.psi_r_alpha"], frame["plant.psi_r_beta"]).to_numpy()
    i_s = np.hypot(frame["plant.i_s_alpha"], frame["plant.i_s_beta"]).to_numpy()
    v_s = np.hypot(frame["controller.v_s_alpha"], frame["controller.v_s_beta"]).to_numpy()
    set_point = float(np.mean(frame["controller.psi_ref_shaped"].to_numpy()[win]))
    return {
        "speed_err": float(np.mean(frame["plant.omega_m"].to_numpy()[win])) / w_ref - 1.0,
        "set_point": set_point,
        "flux_err": float(np.mean(psi[win])) / set_point - 1.0,
        "T_per_A": float(np.mean(frame["plant.T_e"].to_numpy()[win])) / float(np.mean(i_s[win])),
        "peak_over_I_max": float(np.max(i_s)) / I_max,
        "margin": 1.0 - float(np.max(v_s[win])) / (V_DC / math.sqrt(3.0)),
        "v_limited": float(np.mean(frame["controller.voltage_limited"].to_numpy()[win].astype(float))),
    }


def run_one(preset, x, mode, plant, ctrl):
    raw = scenario(preset, x, mode)
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / f"{raw['name']}.yaml"
        path.write_text(yaml.safe_dump(raw))
        sc = load_scenario(path)
    res = run(sc, str(plant), str(ctrl))
    if not res.ok:
        raise RuntimeError(f"{raw['name']}: {res.message}")
    I_max = MOTORS[preset].controller.get("I_max", 30.0)
    row = {"motor": preset, "x": x, "omega_ref": raw["profiles"]["omega_ref"]["to"],
           "T_load": load_torque(preset, x), "mode": mode}
    row.update(measure(res.frame, raw, I_max))
    return row


def table(rows):
    """The Markdown table of the rows."""
    out = ["| motor | speed | load [N m] | design | speed err | set-point [Wb] | true flux err | T/A [N m/A] "
           "| peak/I_max | voltage margin | v-limited |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        out.append(f"| {r['motor']} | {r['x']:g}x ({r['omega_ref']:.0f} rad/s) | {r['T_load']:.2f} "
                   f"| {r['mode']} | {100 * r['speed_err']:+.3g} % | {r['set_point']:.3f} "
                   f"| {100 * r['flux_err']:+.3g} % "
                   f"| {r['T_per_A']:.3f} | {r['peak_over_I_max']:.3f} | {100 * r['margin']:.2f} % "
                   f"| {100 * r['v_limited']:.0f} % |")
    return "\n".join(out)


def figure(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 3, figsize=(13, 6.4), sharex=True)
    styles = {"saturated": "o-", "constant_m": "s--", "m_rated": "d-.", "pi": "^:"}
    for i, preset in enumerate(PRESETS):
        for mode in MODES:
            rs = [r for r in rows if r["motor"] == preset and r["mode"] == mode]
            if not rs:
                continue
            x = [r["x"] for r in rs]
            axes[i][0].plot(x, [100 * r["speed_err"] for r in rs], styles[mode], label=mode)
            axes[i][1].plot(x, [100 * r["flux_err"] for r in rs], styles[mode], label=mode)
            axes[i][2].plot(x, [100 * r["margin"] for r in rs], styles[mode], label=mode)
        axes[i][0].set_ylabel(f"{preset}\nspeed error [%]")
        axes[i][1].set_ylabel("true flux vs set-point [%]")
        axes[i][2].set_ylabel("voltage margin [% of V_max]\n(0.5x: about 44 %, off the scale)")
        axes[i][2].set_ylim(0.0, 8.0)
    for ax in axes.flat:
        ax.grid(True, alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("speed / base speed")
    axes[0][0].legend()
    fig.suptitle("Saturation-aware references (saturated) vs constant m = L_m0 (constant_m), m at the "
                 "nominal point (m_rated) and IFOC (pi); native FMUs, master", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fmus", default=str(ROOT / "build" / "fmus"), help="directory of the built FMUs")
    ap.add_argument("--variant", default="native", choices=sorted(fmus.VARIANTS))
    ap.add_argument("--csv", default=None, help="write the rows here")
    ap.add_argument("--figure", default=None, help="write the figure here")
    ap.add_argument("--presets", nargs="*", default=PRESETS)
    ap.add_argument("--modes", nargs="*", default=MODES)
    ap.add_argument("--factors", nargs="*", type=float, default=FACTORS)
    args = ap.parse_args(argv)
    plant, ctrl = fmus.paths(args.fmus, args.variant)
    rows = []
    for preset in args.presets:
        for x in args.factors:
            for mode in args.modes:
                rows.append(run_one(preset, x, mode, plant, ctrl))
                print(table(rows[-1:]).splitlines()[-1], flush=True)
    print(table(rows))
    if args.csv:
        with open(args.csv, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=COLUMNS)
            w.writeheader()
            w.writerows(rows)
    if args.figure:
        figure(rows, args.figure)
    return rows


if __name__ == "__main__":
    main()
