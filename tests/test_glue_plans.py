"""The glue's fmi2Get*/fmi2SetReal plans (fmu/common/satmotor_fmu_glue.py), in Python without the
pythonfmu binary: whatever the list of value references (all inputs in the unit's order, another
order, a subset, repeats, outputs in any order, a mix with parameters that takes pythonfmu's
per-variable path), the values read back and the values the unit steps with are those of a plain
record of the sets, applied one by one, and of the plain satmotor units stepped alongside."""

from __future__ import annotations

import importlib.util

import pytest

from orchestration.packaging.fmu_build import GLUE
from satmotor.interface import (
    CONTROLLER_INPUTS,
    CONTROLLER_OUTPUTS,
    CONTROLLER_PARAMETERS,
    PLANT_INPUTS,
    PLANT_OUTPUTS,
    PLANT_PARAMETERS,
    ControllerUnit,
    PlantUnit,
)


@pytest.fixture(scope="module")
def glue():
    """The glue's source, loaded under a private name (the FMUs import their own copy by its name)."""
    spec = importlib.util.spec_from_file_location("_glue_under_test", GLUE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _slave(glue, variables, unit):
    cls = type("Slave", (glue.UnitSlave,), {"VARIABLES": variables, "UNIT": unit, "FINGERPRINT": ""})
    s = cls(instance_name="test", resources=None)
    s.enter_initialization_mode()
    s.exit_initialization_mode()
    vr = {v.name: k for k, v in s.vars.items()}
    params = {v.name: v.start for v in variables if v.causality == "parameter"}
    return s, vr, unit(params)


PLANT_SETS = [  # (names, values) applied in turn; the plant steps after each
    (["v_s_alpha", "v_s_beta", "T_load"], [120.0, -40.0, 3.0]),  # every input, the unit's order
    (["T_load", "v_s_alpha", "v_s_beta"], [5.0, 80.0, 60.0]),  # another order
    (["v_s_beta"], [-150.0]),  # one input
    (["v_s_alpha", "T_load", "v_s_alpha"], [10.0, 1.5, 200.0]),  # a repeat: the last value wins
    (["v_s_alpha", "v_s_beta", "T_load"], [0.0, 0.0, 0.0]),
]


def test_plant_sets_and_gets_match_a_record_of_the_sets_and_the_plain_unit(glue):
    s, vr, unit = _slave(glue, PLANT_INPUTS + PLANT_OUTPUTS + PLANT_PARAMETERS, PlantUnit)
    record = {v.name: v.start for v in PLANT_INPUTS}
    J = next(v.start for v in PLANT_PARAMETERS if v.name == "J")
    t, h = 0.0, 1e-4
    for k, (names, values) in enumerate(PLANT_SETS * 3):
        s.set_real([vr[n] for n in names], values)
        for n, v in zip(names, values):
            record[n] = v
        inputs = tuple(record[n] for n in PlantUnit.INPUTS)
        assert s.get_real([vr[n] for n in PlantUnit.INPUTS]) == list(inputs)  # pythonfmu's path
        assert s.do_step(t, h) is True
        unit.step(t, h, inputs)
        t += h
        want = dict(zip(PlantUnit.OUTPUTS, unit.outputs()))
        for names_out in (PlantUnit.OUTPUTS, PlantUnit.OUTPUTS[::-1], ("omega_m", "T_e", "omega_m"),
                          ("i_mu",), ()):
            assert s.get_real([vr[n] for n in names_out]) == [want[n] for n in names_out], (k, names_out)
        mixed = ("J", "omega_m", "v_s_beta")  # a parameter, an output, an input: the per-variable path
        assert s.get_real([vr[n] for n in mixed]) == [J, want["omega_m"], record["v_s_beta"]]
        assert s.omega_m == want["omega_m"] and s.T_load == record["T_load"]  # the attributes
    assert want["omega_m"] != 0.0  # the inputs reached the unit


def test_controller_discrete_outputs_and_inputs_in_the_masters_order(glue):
    s, vr, unit = _slave(glue, CONTROLLER_INPUTS + CONTROLLER_OUTPUTS + CONTROLLER_PARAMETERS, ControllerUnit)
    order = ["omega_ref", "psi_ref", "T_load", "i_s_alpha", "i_s_beta", "psi_r_alpha", "psi_r_beta",
             "psi_s_alpha", "psi_s_beta", "omega_m"]  # not the unit's order
    reals = [v.name for v in CONTROLLER_OUTPUTS if v.type == "Real"]
    flags = [v.name for v in CONTROLLER_OUTPUTS if v.type == "Boolean"]
    Ts = unit.Ts
    for k in range(40):
        t = k * Ts
        values = [150.0, 0.9, 2.0, 3.0 + k, -1.0, 0.5, 0.1 * k, 0.6, -0.2, 10.0 * k]
        s.set_real([vr[n] for n in order], values)
        record = {"v_dc": 0.0, **dict(zip(order, values))}  # v_dc not set: its start value
        assert s.do_step(t, Ts) is True
        unit.step(t, Ts, tuple(record[n] for n in ControllerUnit.INPUTS))
        want = dict(zip(ControllerUnit.OUTPUTS, unit.outputs()))
        assert s.get_real([vr[n] for n in reals]) == [want[n] for n in reals]
        assert s.get_integer([vr["phase"]]) == [want["phase"]]
        assert s.get_boolean([vr[n] for n in flags[::-1]]) == [want[n] for n in flags[::-1]]
    assert any(want[n] != 0.0 for n in reals)


def test_a_refused_set_after_initialization_leaves_the_inputs_and_parameters_alone(glue):
    s, vr, _ = _slave(glue, PLANT_INPUTS + PLANT_OUTPUTS + PLANT_PARAMETERS, PlantUnit)
    s.set_real([vr["v_s_alpha"], vr["v_s_beta"], vr["T_load"]], [1.0, 2.0, 3.0])
    J = s.J
    s.set_real([vr["v_s_alpha"], vr["J"]], [7.0, 99.0])  # a fixed parameter in the list: per variable
    assert s.J == J and s.v_s_alpha == 7.0 and s.v_s_beta == 2.0  # pythonfmu sets in order, J refused
    assert s.do_step(0.0, 1e-4) is False  # the refusal is reported by the next doStep
    s.set_real([vr["i_mu"]], [5.0])  # an output: refused, unchanged
    assert s.get_real([vr["i_mu"]]) != [5.0]
