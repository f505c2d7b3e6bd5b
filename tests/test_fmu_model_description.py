"""The model descriptions as other tools read them (fmpy's parser): units with their SI dimensions,
default experiment, version and license, model structure; fmpy.simulate_fmu with no options."""

from __future__ import annotations

from pathlib import Path

import pytest
from fmpy import read_model_description, simulate_fmu

import satmotor
import satmotor.interface as itf

TABLES = {
    "SaturatedInductionMotor": itf.PLANT_INPUTS + itf.PLANT_OUTPUTS + itf.PLANT_PARAMETERS,
    "BacksteppingController": itf.CONTROLLER_INPUTS + itf.CONTROLLER_OUTPUTS + itf.CONTROLLER_PARAMETERS,
}
# SI dimensions written out by hand (kg m s A K mol cd rad), independent of the build's table:
# V = W/A = kg m2 s-3 A-1, Wb = V s, Ohm = V/A, H = Wb/A, N m = kg m2 s-2, "1" dimensionless
DIMENSIONS = {
    "V": "kg m2 s-3 A-1", "Wb/s": "kg m2 s-3 A-1", "V s/s": "kg m2 s-3 A-1", "Wb": "kg m2 s-2 A-1", "A": "A",
    "Ohm": "kg m2 s-3 A-2", "H": "kg m2 s-2 A-2", "N m": "kg m2 s-2", "N m s": "kg m2 s-1",
    "kg m2": "kg m2", "rad": "rad", "rad/s": "rad s-1", "rad/s2": "rad s-2", "s": "s", "1/s": "s-1",
    "Hz": "s-1",
    "1/s2": "s-2", "1": "", "N m s2/rad2": "kg m2 rad-2",
    "J": "kg m2 s-2", "F": "kg-1 m-2 s4 A2",  # the DC link
    "W": "kg m2 s-3", "K": "K", "1/K": "K-1", "J/K": "kg m2 s-2 K-1", "K/W": "kg-1 m-2 s3 K",
    "N m s/(A2 rad)": "kg m2 s-1 A-2 rad-1",  # issue 35: the stray-load coefficient
}
NO_DIMENSION = {"A/Wb^n"}  # poly_b: its dimension depends on the Integer poly_n
BASE = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")


def _exponents(text):
    out = dict.fromkeys(BASE, 0)
    for part in text.split():
        base = part.rstrip("-0123456789")
        out[base] = int(part[len(base):] or 1)
    return out


@pytest.fixture(scope="module")
def mds(fmu_dir):
    return {name: read_model_description(str(Path(fmu_dir) / f"{name}.fmu")) for name in TABLES}


@pytest.mark.parametrize("name", list(TABLES))
def test_every_real_has_the_interface_unit_and_every_unit_its_si_dimension(mds, name):
    md = mds[name]
    units = {u.name: u for u in md.unitDefinitions}
    table = {v.name: v for v in TABLES[name]}
    reals = [v for v in md.modelVariables if v.type == "Real"]
    assert reals and all(v.unit == table[v.name].unit for v in reals), [(v.name, v.unit) for v in reals]
    assert all(v.unit is None for v in md.modelVariables if v.type != "Real")
    assert set(units) == {v.unit for v in reals}  # each unit used is defined, and only those
    for u in units.values():
        if u.name in NO_DIMENSION:
            assert u.baseUnit is None, u.name
            continue
        b = u.baseUnit
        got = {k: getattr(b, k) for k in BASE}
        assert got == _exponents(DIMENSIONS[u.name]), u.name
        assert b.factor == 1.0 and b.offset == 0.0, u.name  # all coherent SI


def test_default_experiment_version_license(mds):
    plant, ctrl = mds["SaturatedInductionMotor"], mds["BacksteppingController"]
    e = plant.defaultExperiment  # fmpy keeps the attributes as text
    assert (float(e.startTime), float(e.stopTime), float(e.stepSize), e.tolerance) == (0.0, 1.5, 1e-4, None)
    e = ctrl.defaultExperiment
    Ts = {v.name: v.start for v in itf.CONTROLLER_PARAMETERS}["Ts"]
    assert (float(e.startTime), float(e.stepSize), e.tolerance) == (0.0, Ts, None)
    assert float(e.stopTime) == pytest.approx(1000 * Ts, rel=1e-15)  # fmpy keeps dt = Ts up to 1000 steps
    for md in mds.values():
        assert (md.version, md.license) == (satmotor.__version__, "MIT")
        line = next(ln for ln in Path("LICENSE").read_text().splitlines() if ln.startswith("Copyright"))
        assert md.copyright == line  # the same holder and year as LICENSE


def test_outputs_have_no_direct_feedthrough_and_initial_unknowns_are_the_plant_outputs(mds):
    for name, md in mds.items():
        outputs = [v for v in md.modelVariables if v.causality == "output"]
        assert [u.variable for u in md.outputs] == outputs
        assert all(u.dependencies == [] for u in md.outputs), name  # dependencies=""
    plant, ctrl = mds["SaturatedInductionMotor"], mds["BacksteppingController"]
    params = {v for v in plant.modelVariables if v.causality == "parameter"}
    outputs = [v for v in plant.modelVariables if v.causality == "output"]
    assert all(v.initial == "calculated" and v.start is None for v in outputs)
    assert [u.variable for u in plant.initialUnknowns] == outputs
    for u in plant.initialUnknowns:  # computed from the parameters (not h_int), never from the inputs
        assert set(u.dependencies) == {v for v in params if v.name != "h_int"}, u.variable.name
    assert ctrl.initialUnknowns == []  # outputs exact, 0 until the first sample
    assert all(v.initial == "exact" and v.start in ("0.0", "0", "false")
               for v in ctrl.modelVariables if v.causality == "output")


@pytest.mark.parametrize("name", list(TABLES))
def test_simulate_fmu_with_no_options_runs_to_the_stop_time_without_a_discard(fmu_dir, mds, name):
    log = []
    res = simulate_fmu(str(Path(fmu_dir) / f"{name}.fmu"), debug_logging=True,
                       logger=lambda env, inst, status, cat, msg: log.append((status, msg)))
    bad = [m for s, m in log if s > 0]  # fmpy stops quietly at a discard: the log and the end time tell
    assert bad == [] and res["time"][-1] == pytest.approx(float(mds[name].defaultExperiment.stopTime))
    print(f"{name}: {len(res)} rows to t = {res['time'][-1]}")
