"""The closed-loop flux observer against the open-loop current model, through the FMUs and the master.

Two figures and one Markdown table, every number from runs of the built FMUs (default: the native
FMI 2.0 ones) under the project's master (orchestration.run.master.run), metrics on the plant's true
flux (plant.psi_r_*), never on the controller's estimate:

* ``observer_rotor_resistance.png``: the plant's R_r 50 % above the controller's model
  (scenarios/observer_rotor_resistance.yaml, integral action, rated load from 1 s) at 10, 50 and
  100 rad/s: the true rotor flux's error against its set-point, observer = current_model (before)
  and closed_loop (the default);
* ``observer_noise.png``: scenarios/noisy_measurements.yaml with flux_source = observer (the psi
  inputs unused), at the library's "medium" noise (0.06 A, 0.05 rad/s quantized to 0.01) and at
  twice it ("high": 0.12 A, 0.10 rad/s): the bias of the true flux over [1.3, 1.5] s and the
  standard deviation of the true flux there.

Usage::

    python demos/observer_figures.py --fmus build/fmus --out docs/figures
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import matplotlib
import numpy as np
import yaml

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from orchestration.packaging import fmus  # noqa: E402
from orchestration.run.master import run  # noqa: E402
from orchestration.scenario.load import load_scenario  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PSI_REF = 0.95  # [Wb] the set-point of both scenarios
OBSERVERS = ("current_model", "closed_loop")
SPEEDS = (10.0, 50.0, 100.0)  # [rad/s]
NOISE = {"medium": {"i_s_alpha": 0.06, "i_s_beta": 0.06, "omega_m": 0.05},
         "high": {"i_s_alpha": 0.12, "i_s_beta": 0.12, "omega_m": 0.10}}


def _run(raw, plant, ctrl):
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / f"{raw['name']}.yaml"
        path.write_text(yaml.safe_dump(raw))
        sc = load_scenario(path)
    res = run(sc, str(plant), str(ctrl))
    if not res.ok:
        raise RuntimeError(f"{raw['name']}: {res.message}")
    df = res.frame
    t = df["time"].to_numpy()
    psi = np.hypot(df["plant.psi_r_alpha"], df["plant.psi_r_beta"]).to_numpy()
    return t, psi, df["plant.omega_m"].to_numpy()


def _window(t, y, w=(1.3, 1.5)):
    return y[(t >= w[0]) & (t <= w[1])]


def rotor_resistance(plant, ctrl):
    """{(observer, speed): (t, psi)} for the hot-rotor scenario at each speed."""
    base = yaml.safe_load((ROOT / "scenarios" / "observer_rotor_resistance.yaml").read_text())
    out = {}
    for obs in OBSERVERS:
        for w in SPEEDS:
            raw = {**base, "name": f"rr_{obs}_{w:g}", "controller": {**base["controller"], "observer": obs}}
            raw["profiles"] = {**base["profiles"], "omega_ref": {**base["profiles"]["omega_ref"], "to": w}}
            t, psi, _ = _run(raw, plant, ctrl)
            out[obs, w] = (t, psi)
    return out


def noise(plant, ctrl):
    """{(observer, level): (t, psi, omega)} for the noisy scenario with the flux observer."""
    base = yaml.safe_load((ROOT / "scenarios" / "noisy_measurements.yaml").read_text())
    out = {}
    for obs in OBSERVERS:
        for level, std in NOISE.items():
            meas = {**base["measurements"], "noise": std}
            raw = {**base, "name": f"noise_{obs}_{level}", "measurements": meas,
                   "controller": {"flux_source": "observer", "observer": obs}}
            out[obs, level] = _run(raw, plant, ctrl)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fmus", default=str(ROOT / "build" / "fmus"), help="directory of the built FMUs")
    ap.add_argument("--variant", default="native", choices=sorted(fmus.VARIANTS))
    ap.add_argument("--out", default=str(ROOT / "docs" / "figures"))
    args = ap.parse_args(argv)
    plant, ctrl = fmus.paths(args.fmus, args.variant)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    rr = rotor_resistance(plant, ctrl)
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6), sharey=False)
    print("| R_r +50 %, rated load | true flux error, current_model: mean, largest "
          "| closed_loop: mean, largest |")
    print("|---|---|---|")
    for ax, w in zip(axes, SPEEDS):
        cells = []
        for obs, style in zip(OBSERVERS, ("--", "-")):
            t, psi = rr[obs, w]
            err = 100.0 * (psi - PSI_REF) / PSI_REF
            ax.plot(t, err, style, label=obs)
            win = _window(t, err)
            cells.append(f"{np.mean(win):+.3g} %, {np.max(np.abs(win)):.3g} %")
        print(f"| {w:g} rad/s | {cells[0]} | {cells[1]} |")
        ax.set_title(f"{w:g} rad/s, plant R_r +50 %")
        ax.set_xlabel("t [s]")
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel("true |psi_r| - psi_ref [% of 0.95 Wb]")
    axes[0].legend()
    fig.tight_layout()
    fig.savefig(out / "observer_rotor_resistance.png", dpi=110)

    nz = noise(plant, ctrl)
    fig, ax = plt.subplots(figsize=(7, 3.6))
    print("\n| noise | observer | true flux bias [mWb] | its std [mWb] | speed bias [rad/s] |")
    print("|---|---|---|---|---|")
    for (obs, level), (t, psi, w) in nz.items():
        bias = 1e3 * (np.mean(_window(t, psi)) - PSI_REF)
        std = 1e3 * np.std(_window(t, psi))
        wb = np.mean(_window(t, w)) - 100.0
        print(f"| {level} | {obs} | {bias:+.3g} | {std:.3g} | {wb:+.3g} |")
        ax.plot(t, 1e3 * (psi - PSI_REF), "--" if obs == "current_model" else "-", label=f"{obs}, {level}",
                lw=0.8)
    ax.set_xlim(0.8, 1.5)
    late = np.concatenate([1e3 * (_window(t, psi, (0.8, 1.5)) - PSI_REF) for t, psi, _ in nz.values()])
    ax.set_ylim(1.2 * late.min(), 1.2 * late.max())
    ax.set_xlabel("t [s]")
    ax.set_ylabel("true |psi_r| - psi_ref [mWb]")
    ax.set_title("Measurement noise through the flux observer")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "observer_noise.png", dpi=110)


if __name__ == "__main__":
    main()
