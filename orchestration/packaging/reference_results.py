"""Reference results of each FMU run standalone, in the layout of the FMI cross-check::

    python -m orchestration.packaging.reference_results --out reference

writes, for each FMU ``<Name>``, ``<out>/<Name>/<Name>_in.csv`` (the inputs at each communication
point), ``<Name>_ref.csv`` (the outputs at each communication point) and ``ReferenceOptions.txt``
(``StartTime, StopTime, StepSize, RelTol``, as ``fmpy.util.read_ref_opt_file`` reads it).

The results come from the plain-Python units (:class:`satmotor.interface.PlantUnit`,
:class:`~satmotor.interface.ControllerUnit`) stepped as an FMU importer steps the FMU alone:
outputs at ``t_0``, then for each ``k`` the inputs of row ``k`` set, ``doStep(t_k, h)``, the outputs
at ``t_(k+1)``.  No FMU is involved in making them; ``tests/test_reference_results.py`` runs the FMUs
against them.  Numbers are written with ``repr`` (shortest round-trip), so a file read back gives the
very floats that were used, and regenerating gives the same bytes.

* ``SaturatedInductionMotor``: direct-on-line start at the rated voltage (400 V, 50 Hz), rated load
  torque from 0.2 s, 0.3 s at 1e-4 s, default parameters.
* ``SaturatedInductionMotorME`` (the model-exchange plant): the same inputs, written as the
  piecewise-constant signal the co-simulation plant sees (each row held over its step: every inner
  time point twice, the value before and after, which an importer reads as a discontinuity), and
  the outputs of that signal integrated by the plain-Python plant with RK4 at ``H / 10``
  (:data:`ME_H_INT`; within about 1e-11 of the converged solution, relative to each column's
  largest value); ``RelTol`` :data:`ME_REL_TOL` for the importer's solver.
* ``BacksteppingController``: the measurements, set-points and load of the plain closed loop of the
  default scenario (``scenarios/ramp_rated_load.yaml``) over its first 0.3 s: pre-magnetization,
  the switch to the law (0.114 s), the start of the speed ramp (0.2 s); default parameters.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from satmotor.interface import STEP_MEAN_OUTPUTS, ControllerUnit, PlantUnit
from satmotor.machine.params import RatedData
from satmotor.simulate import closed_loop

H = 1e-4  # [s] communication step of both references (plant h_int, controller Ts)
N = 3000  # steps: 0.3 s
T_LOAD_STEP = 2000  # plant reference: rated load from step 2000 (0.2 s)
REL_TOL = 1e-6  # required by the format; both FMUs are fixed-step and ignore it
ME_NAME = "SaturatedInductionMotorME"
ME_H_INT = H / 10  # [s] RK4 step of the model-exchange plant's reference
ME_REL_TOL = 1e-10  # the importer's solver tolerance its reference asks for
DEFAULT_SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "ramp_rated_load.yaml"


def plant_inputs():
    """Rows ``(v_s_alpha, v_s_beta, T_load)`` at ``t_k = k H``, k = 0..N."""
    r = RatedData()
    return [(r.V_phase_peak * math.cos(r.omega_e * k * H), r.V_phase_peak * math.sin(r.omega_e * k * H),
             r.T_n if k >= T_LOAD_STEP else 0.0) for k in range(N + 1)]


def controller_inputs(scenario_path=DEFAULT_SCENARIO):
    """Rows of the controller inputs (order of ``ControllerUnit.INPUTS``) at ``t_k``, k = 0..N, from
    the plain closed loop of the scenario (as :func:`orchestration.run.reference.plain_reference`)."""
    from orchestration.scenario.load import load_scenario

    sc = load_scenario(scenario_path)
    if (sc.step, sc.controller_every, dict(sc.plant), dict(sc.controller)) != (H, 1, {}, {}):
        raise ValueError(f"{scenario_path}: the reference needs step {H}, controller_every 1 and the "
                         f"default parameters")
    plant, ctrl = PlantUnit({}), ControllerUnit({"Ts": H})
    prof = sc.profiles
    rec = closed_loop(plant.params, ctrl.drive, N * H, prof["omega_ref"].value, prof["psi_ref"].value,
                      prof["T_load"].value, x0=plant.x0)
    cols = ("i_s_alpha", "i_s_beta", "psi_r_alpha", "psi_r_beta", "psi_s_alpha", "psi_s_beta", "omega_m",
            "omega_ref", "psi_ref", "T_load")
    return [tuple(float(rec[c][k]) for c in cols) + (0.0,) for k in range(N + 1)]  # v_dc: not connected


def run_unit(unit, inputs):
    """Outputs at ``t_0 .. t_N`` of ``unit`` stepped with ``inputs[k]`` over ``[t_k, t_k + H]``."""
    rows = [tuple(unit.outputs())]
    for k in range(N):
        unit.step(k * H, H, inputs[k])
        rows.append(tuple(unit.outputs()))
    return rows


def _csv(path, names, rows):
    lines = [",".join(("time",) + tuple(names))]
    lines += [",".join(repr(float(v)) for v in (k * H, *row)) for k, row in enumerate(rows)]
    path.write_text("\n".join(lines) + "\n", encoding="ascii", newline="\n")


def _held_csv(path, names, rows):
    """``rows[k]`` held over ``[t_k, t_(k+1))``: every inner time point twice (left and right value)."""
    lines = [",".join(("time",) + tuple(names))]
    for k, row in enumerate(rows):
        if k > 0:
            lines.append(",".join(repr(float(v)) for v in (k * H, *rows[k - 1])))
        lines.append(",".join(repr(float(v)) for v in (k * H, *row)))
    path.write_text("\n".join(lines) + "\n", encoding="ascii", newline="\n")


def write_me(out="reference"):
    """The model-exchange plant's reference under ``out``; returns the paths written."""
    d = Path(out) / ME_NAME
    d.mkdir(parents=True, exist_ok=True)
    inputs = plant_inputs()
    _held_csv(d / f"{ME_NAME}_in.csv", PlantUnit.INPUTS, inputs)
    # not v_avg_alpha/beta: the ME plant gives the input itself, the co-simulation plant the step's average;
    # nor the other step means (P_in, ...: the ME plant's are at the instant)
    keep = [j for j, n in enumerate(PlantUnit.OUTPUTS)
            if n not in ("v_avg_alpha", "v_avg_beta", *STEP_MEAN_OUTPUTS)]
    rows = [tuple(r[j] for j in keep) for r in run_unit(PlantUnit({"h_int": ME_H_INT}), inputs)]
    _csv(d / f"{ME_NAME}_ref.csv", [PlantUnit.OUTPUTS[j] for j in keep], rows)
    opts = {"StartTime": 0.0, "StopTime": round(N * H, 12), "StepSize": H, "RelTol": ME_REL_TOL}
    (d / "ReferenceOptions.txt").write_text("".join(f"{k}, {v!r}\n" for k, v in opts.items()),
                                            encoding="ascii", newline="\n")
    return [d / f"{ME_NAME}_in.csv", d / f"{ME_NAME}_ref.csv", d / "ReferenceOptions.txt"]


def write(out="reference"):
    """Write both references under ``out``; returns the paths written."""
    cases = {"SaturatedInductionMotor": (PlantUnit, {}, plant_inputs()),
             "BacksteppingController": (ControllerUnit, {"Ts": H}, controller_inputs())}
    paths = []
    for name, (cls, params, inputs) in cases.items():
        d = Path(out) / name
        d.mkdir(parents=True, exist_ok=True)
        _csv(d / f"{name}_in.csv", cls.INPUTS, inputs)
        _csv(d / f"{name}_ref.csv", cls.OUTPUTS, run_unit(cls(params), inputs))
        opts = {"StartTime": 0.0, "StopTime": round(N * H, 12), "StepSize": H, "RelTol": REL_TOL}
        (d / "ReferenceOptions.txt").write_text("".join(f"{k}, {v!r}\n" for k, v in opts.items()),
                                                encoding="ascii", newline="\n")
        paths += [d / f"{name}_in.csv", d / f"{name}_ref.csv", d / "ReferenceOptions.txt"]
    return paths + write_me(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description="Write the FMUs' reference results (FMI cross-check layout).")
    ap.add_argument("--out", default="reference", help="output directory (default reference/)")
    for p in write(ap.parse_args(argv).out):
        print(f"wrote {p} ({p.stat().st_size} bytes)")


if __name__ == "__main__":
    main()
