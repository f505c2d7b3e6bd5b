"""Every pair of parameters with an order, checked in Python and in C alike (issue 31): the value that
breaks the order refused at initialization naming the field, the value and the other bound, with the
same text in the Python units (``satmotor.interface``) and the native FMUs (the C core through fmpy);
the nearest value that keeps the order accepted by both.

The pairs (found by reading every parameter of ``satmotor/interface.py`` and the checks of the
parameter dataclasses and of the C core): the brake chopper's hysteresis ``V_chop_off < V_chop_on``
(also without a chopper), the over-voltage fault above the chopper ``V_chop_on < V_dc_max`` (when both
are on: ``R_chop > 0``, ``V_dc_max > 0``), the saturating curves' ``L_m_inf < L_m0`` (plant and
controller), the pre-magnetization's ``premag_min_fraction <= premag_fraction``, the pwm inverter's
``t_dead < 1 / (2 f_sw)`` and ``v_on < V_dc / 2``.
"""

from __future__ import annotations

import math

import pytest
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave, defaultCallbacks, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE

from satmotor.interface import ControllerUnit, PlantUnit

PLANT, CONTROLLER = "SaturatedInductionMotor", "BacksteppingController"
CAP = {"dc_link": "capacitor", "R_chop": 40.0}
PWM = {"inverter": "pwm", "f_sw": 5000.0}

#: (unit, the pair broken (the last key is the field refused), the pair kept, what the message says)
PAIRS = [
    (PLANT, {"V_chop_on": 720.0, "V_chop_off": 720.0}, {"V_chop_on": 720.0, "V_chop_off": 719.9},
     "V_chop_off = 720.0: must be below V_chop_on = 720.0 V"),
    (PLANT, {**CAP, "V_chop_on": 700.0, "V_chop_off": 750.0},
     {**CAP, "V_chop_on": 750.0, "V_chop_off": 700.0},
     "V_chop_off = 750.0: must be below V_chop_on = 700.0 V"),
    (PLANT, {**CAP, "V_chop_on": 750.0, "V_dc_max": 750.0},
     {**CAP, "V_chop_on": 750.0, "V_dc_max": 750.1},
     "V_dc_max = 750.0: must be above V_chop_on = 750.0 V with a brake chopper (R_chop > 0)"),
    (PLANT, {"curve": "arctan", "L_m0": 0.2772, "L_m_inf": 0.2772},
     {"curve": "arctan", "L_m0": 0.2772, "L_m_inf": 0.277}, "L_m_inf = 0.2772: "),
    (PLANT, {"curve": "exponential", "L_m0": 0.2772, "L_m_inf": 0.3},
     {"curve": "exponential", "L_m0": 0.2772, "L_m_inf": 0.277}, "L_m_inf = 0.3: "),
    (CONTROLLER, {"curve": "arctan", "L_m0": 0.2772, "L_m_inf": 0.2772},
     {"curve": "arctan", "L_m0": 0.2772, "L_m_inf": 0.277}, "L_m_inf = 0.2772: "),
    (CONTROLLER, {"premag_fraction": 0.9, "premag_min_fraction": 0.91},
     {"premag_fraction": 0.9, "premag_min_fraction": 0.9}, "premag_min_fraction = 0.91: "),
    (PLANT, {**PWM, "t_dead": 1e-4}, {**PWM, "t_dead": 0.99e-4}, "t_dead = 0.0001: must be less than half"),
    (PLANT, {**PWM, "V_dc": 540.0, "v_on": 270.0}, {**PWM, "V_dc": 540.0, "v_on": 269.9},
     "v_on = 270.0: must be less than V_dc/2 = 270.0 V"),
]
IDS = [f"{u[:5]}-{list(bad)[-1]}-{i}" for i, (u, bad, _, _) in enumerate(PAIRS)]


def python_refusal(unit, params):
    """The Python unit's message for ``params`` (None: accepted)."""
    try:
        (PlantUnit if unit == PLANT else ControllerUnit)(params)
    except ValueError as exc:
        return str(exc)
    return None


def native_refusal(fmu_dir, tmp_path, unit, params):
    """The native FMU's error messages at exitInitializationMode with ``params`` (None: accepted)."""
    path = fmu_dir / "native" / f"{unit}.fmu"
    md = read_model_description(str(path))
    variables = {v.name: v for v in md.modelVariables}
    log = []
    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(lambda env, name, st, cat, msg: log.append((st, msg.decode())))
    callbacks.allocateMemory = defaultCallbacks.allocateMemory
    callbacks.freeMemory = defaultCallbacks.freeMemory
    where = tmp_path / f"x{len(list(tmp_path.iterdir()))}"
    s = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(path), str(where)),
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName="pairs")
    s.instantiate(callbacks=callbacks, loggingOn=True)
    try:
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        for name, value in params.items():
            vr, kind = [variables[name].valueReference], variables[name].type
            if kind == "String":
                s.setString(vr, [value])
            elif kind == "Integer":
                s.setInteger(vr, [int(value)])
            else:
                s.setReal(vr, [float(value)])
        try:
            s.exitInitializationMode()
        except FMICallException:
            return " | ".join(m for st, m in log if st >= 3)
        return None
    finally:
        s.freeInstance()


@pytest.mark.parametrize("unit, bad, good, said", PAIRS, ids=IDS)
def test_a_parameter_pair_out_of_order_is_refused_in_python_and_c_alike(fmu_dir, tmp_path, unit, bad, good,
                                                                       said):
    py = python_refusal(unit, bad)
    assert py is not None and said in py, py
    c = native_refusal(fmu_dir, tmp_path, unit, bad)
    assert c is not None and py in c, (py, c)  # the C core's text is the Python unit's
    assert python_refusal(unit, good) is None
    assert native_refusal(fmu_dir, tmp_path, unit, good) is None


def test_the_fault_level_is_free_without_a_chopper_or_without_the_check():
    """V_dc_max <= V_chop_on is an order only when both act: without the chopper (R_chop = 0) the fault
    may sit anywhere, and V_dc_max = 0 switches the check off."""
    assert python_refusal(PLANT, {"dc_link": "capacitor", "R_chop": 0.0, "V_dc_max": 600.0}) is None
    assert python_refusal(PLANT, {**CAP, "V_dc_max": 0.0}) is None
    assert math.isclose(PlantUnit({**CAP}).link.V_dc_max, 800.0)
