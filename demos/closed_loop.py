"""The default closed-loop scenario, plain Python: backstepping drive on the saturated motor.

Pre-magnetization from rest, rotor-flux set-point 0.95 Wb (in the knee of the curve), speed ramp
to 100 rad/s, rated-load step at 1 s.  Writes a CSV, the metrics as JSON and a PNG of the
references against the responses.

Usage::

    python demos/closed_loop.py --out results [--load-mode known|estimated] [--psi 0.95]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import pandas as pd

import satmotor.interface as itf
from orchestration.results.plots import figure
from orchestration.run.reference import COLUMNS
from satmotor.control.backstepping import ControllerConfig
from satmotor.control.drive import BacksteppingDrive
from satmotor.machine.params import MotorParams
from satmotor.metrics import run_metrics
from satmotor.simulate import RECORDED, RampScenario

# the units from the FMUs' variable tables (no unit: "1"), and the three columns that are not FMU variables
UNITS = {v.name: v.unit or "1" for table in (itf.PLANT_INPUTS, itf.PLANT_OUTPUTS, itf.CONTROLLER_INPUTS,
                                             itf.CONTROLLER_OUTPUTS) for v in table} | {
    "t": "s", "psi_r_mag": "Wb", "V": "1"}


def plot(r, path, title):
    """The co-simulation figure (orchestration.results.plots) of a plain-Python record."""
    frame = pd.DataFrame({"time": r["t"], **{col: r[key] for col, key in COLUMNS.items()},
                          "profile.omega_ref": r["omega_ref"], "profile.psi_ref": r["psi_ref"],
                          "profile.T_load": r["T_load"]})
    figure(frame, path, title)


def main(argv=None):
    ap = argparse.ArgumentParser(description="Run the default closed-loop scenario (plain Python) and "
                                 "write CSV, metrics JSON and a PNG.")
    ap.add_argument("--out", default="results", help="output directory (default results)")
    ap.add_argument("--load-mode", choices=("known", "estimated"), default="known",
                    help="load torque known to the law, or estimated adaptively (default known)")
    ap.add_argument("--psi", type=float, default=0.95, help="rotor flux set-point [Wb] (default 0.95)")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    p, sc = MotorParams(), RampScenario(psi_ref=args.psi)
    res = sc.run(p, BacksteppingDrive(p, cfg=ControllerConfig(load_mode=args.load_mode)))
    res.pop("x_end")
    metrics = run_metrics(res, sc.ss_window)
    stem = out / "closed_loop"
    pd.DataFrame({f"{k} [{UNITS[k]}]": res[k] for k in RECORDED}).to_csv(f"{stem}.csv", index=False)
    Path(f"{stem}.json").write_text(json.dumps(metrics, indent=2) + "\n")
    plot(res, f"{stem}.png", f"Backstepping drive, saturated 4 kW motor: psi_ref {sc.psi_ref} Wb, "
         f"ramp to {sc.omega_final} rad/s, {sc.T_load} N m load ({args.load_mode} load)")
    for ext in ("csv", "json", "png"):
        print(f"wrote {stem}.{ext}")
    print(", ".join(f"{k} {v:.4g}" for k, v in metrics.items()))


if __name__ == "__main__":
    main()
