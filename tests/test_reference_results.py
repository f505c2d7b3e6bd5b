"""The reference results in reference/ (FMI cross-check layout): regenerated from the plain-Python
units they are byte-identical, and each FMU run alone by fmpy against its _in.csv reproduces its
_ref.csv.  Two implementation paths: the files come from satmotor.interface's units stepped in plain
Python, the results under test from the pythonfmu FMUs driven by fmpy."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.util import read_csv, read_ref_opt_file

from orchestration.packaging import reference_results

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "reference"
NAMES = ("SaturatedInductionMotor", "BacksteppingController")
# The FMUs run the same Python code on the same floats (repr in the CSV round-trips exactly, and the
# table's time points are the communication points), so the deviation is at the last bits: 0 for the
# controller, 9e-15 of max|ref| for the plant (fmpy's input interpolation at its own time grid, over
# 3000 steps).  The band, 1e-12 of each column's largest value, leaves room for another libm or numpy
# in the FMU's interpreter and nothing more: any change of the model shows far above it.
BAND = 1e-12


def test_regenerating_the_reference_files_gives_the_same_bytes(tmp_path):
    written = reference_results.write(tmp_path)
    assert sorted(p.relative_to(tmp_path) for p in written) == sorted(
        p.relative_to(REFERENCE) for p in REFERENCE.rglob("*") if p.is_file())
    for p in written:
        assert p.read_bytes() == (REFERENCE / p.relative_to(tmp_path)).read_bytes(), p.name


def test_the_references_exercise_the_models():
    plant = read_csv(REFERENCE / "SaturatedInductionMotor" / "SaturatedInductionMotor_ref.csv")
    plant_in = read_csv(REFERENCE / "SaturatedInductionMotor" / "SaturatedInductionMotor_in.csv")
    assert plant["omega_m"][-1] > 140.0 and plant["T_e"][-1] > 20.0 and plant_in["T_load"][-1] > 20.0
    assert max(plant["i_mu"]) > 5.0  # in the knee of the magnetizing curve and beyond
    ctrl = read_csv(REFERENCE / "BacksteppingController" / "BacksteppingController_ref.csv")
    running = ctrl["W"] > 0.0
    assert 0.1 < ctrl["time"][np.argmax(running)] < 0.2 and running[-1]  # pre-magnetization, then the law
    ctrl_in = read_csv(REFERENCE / "BacksteppingController" / "BacksteppingController_in.csv")
    assert ctrl_in["omega_ref"][-1] > 0.0  # the ramp has started


@pytest.mark.parametrize("name", NAMES)
def test_each_fmu_alone_reproduces_its_reference(fmu_dir, name):
    d = REFERENCE / name
    opts = read_ref_opt_file(str(d / "ReferenceOptions.txt"))
    inputs, ref = read_csv(d / f"{name}_in.csv"), read_csv(d / f"{name}_ref.csv")
    outputs = [n for n in ref.dtype.names if n != "time"]
    res = simulate_fmu(str(Path(fmu_dir) / f"{name}.fmu"), start_time=opts["StartTime"],
                       stop_time=opts["StopTime"], output_interval=opts["StepSize"], input=inputs,
                       output=outputs)
    assert len(res) == len(ref) and np.allclose(res["time"], ref["time"], rtol=0, atol=1e-12)
    dev = {n: np.max(np.abs(res[n] - ref[n])) / max(np.max(np.abs(ref[n])), 1e-300) for n in outputs}
    worst = max(dev, key=dev.get)
    print(f"{name}: worst deviation {dev[worst]:.3g} of max|ref| ({worst})")
    assert dev[worst] <= BAND, dev
