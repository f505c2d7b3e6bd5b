"""Direct-on-line start of a motor of the library (default: the 4 kW, 400 V, 50 Hz motor): CSV and plot.

Usage::

    python demos/dol_start.py --out results [--t-end 1.0] [--step 1e-4] [--motor qu2012_2kw2]

The supply is the motor's rated voltage and frequency, the load step its rated torque at 0.6 s
(satmotor/machine/library.py gives the nameplates).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from satmotor.machine.library import MOTORS  # noqa: E402
from satmotor.simulate_open_loop import dol_start  # noqa: E402

UNITS = {
    "t": "s", "v_s_alpha": "V", "v_s_beta": "V", "T_load": "N m",
    "i_s_alpha": "A", "i_s_beta": "A", "psi_s_alpha": "Wb", "psi_s_beta": "Wb",
    "psi_r_alpha": "Wb", "psi_r_beta": "Wb", "omega_m": "rad/s", "theta_m": "rad",
    "T_e": "N m", "i_mu": "A", "psi_r_mag": "Wb", "i_s_mag": "A",
}
TITLE = "DOL start, {title}, rated load step"


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description="Simulate a direct-on-line start of the default motor; "
                                 "write a CSV and a PNG plot.")
    ap.add_argument("--out", default="results", help="output directory, created if missing (default results)")
    ap.add_argument("--t-end", type=float, default=1.0, help="simulated time [s] (default 1.0)")
    ap.add_argument("--step", type=float, default=1e-4, help="integration/sampling step [s] (default 1e-4)")
    ap.add_argument("--motor", choices=tuple(MOTORS), default="default_4kw",
                    help="motor of the library, satmotor/machine/library.py (default default_4kw)")
    return ap.parse_args(argv)


def plot(r, path, title=MOTORS["default_4kw"].title):
    t = r["t"]
    fig, ax = plt.subplots(5, 1, sharex=True, figsize=(9, 11), constrained_layout=True)
    ax[0].plot(t, r["omega_m"], label="omega_m")
    ax[0].set_ylabel("speed [rad/s]")
    ax[1].plot(t, r["T_e"], label="T_e (electromagnetic)")
    ax[1].plot(t, r["T_load"], label="T_load")
    ax[1].set_ylabel("torque [N m]")
    ax[2].plot(t, r["i_s_alpha"], lw=0.7, label="i_s_alpha")
    ax[2].plot(t, r["i_s_beta"], lw=0.7, label="i_s_beta")
    ax[2].plot(t, r["i_s_mag"], "k", lw=1.0, label="|i_s|")
    ax[2].set_ylabel("stator current [A]")
    ax[3].plot(t, r["psi_r_mag"], label="|psi_r|")
    ax[3].set_ylabel("rotor flux [Wb]")
    ax[4].plot(t, r["i_mu"], label="|i_mu|")
    ax[4].set_ylabel("magnetizing current [A]")
    ax[4].set_xlabel("time t [s]")
    for a in ax:
        a.grid(True, alpha=0.4)
        a.legend(loc="upper right", fontsize=8)
    fig.suptitle(TITLE.format(title=title))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    args = parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    m = MOTORS[args.motor]
    r = dol_start(params=m.params(), rated=m.nameplate, t_end=args.t_end, h=args.step)
    stem = "dol_start" if args.motor == "default_4kw" else f"dol_start_{args.motor}"
    csv_path, png_path = out / f"{stem}.csv", out / f"{stem}.png"
    pd.DataFrame({f"{k} [{UNITS[k]}]": v for k, v in r.items()}).to_csv(csv_path, index=False)
    plot(r, png_path, m.title)
    print(f"wrote {csv_path}")
    print(f"wrote {png_path}")
    print(f"final speed {r['omega_m'][-1]:.2f} rad/s ({r['omega_m'][-1] * 30 / math.pi:.0f} rpm), "
          f"final torque {r['T_e'][-1]:.2f} N m, peak stator current {r['i_s_mag'].max():.1f} A")


if __name__ == "__main__":
    main()
