"""The plant's co-simulation unit in C (fmu/native/core/sm_plant_unit.c) against PlantUnit of
satmotor/interface.py through ctypes, bit for bit: every inverter (average, pwm) x link (ideal,
capacitor) x core loss (R_fe) x thermal model combination, at random inputs and at random states set
into both units (outputs, states, warnings' text); the refusals with PlantUnit's messages; a refused
or failed step changes nothing; the model-exchange derivatives of the unit against the Python's."""

from __future__ import annotations

import itertools
import math
import zlib

import numpy as np
import pytest
from native_core import load
from native_plant_unit import CPlantUnit, CUnitError

from satmotor.errors import ParameterError
from satmotor.interface import PLANT_OUTPUTS, PlantUnit

BASE = dict(psi_r0=0.8, C_dc=470e-6, f_sw=5000.0, t_dead=2e-6, v_on=1.0)
WARM = dict(thermal=True, T_s0=353.15, T_r0=343.15, C_th_s=30.0, C_th_r=12.0)
CHOPPER = dict(R_chop=40.0, V_chop_on=548.0, V_chop_off=544.0, V_dc_max=900.0)
COMBOS = {f"{inv} {link} R_fe={r_fe} thermal={th}": {
    **BASE, "inverter": inv, "dc_link": link, "R_fe": r_fe, **(WARM if th else {}),
    **(CHOPPER if link == "capacitor" else {})}
    for inv, link, r_fe, th in itertools.product(("average", "pwm"), ("ideal", "capacitor"), (0.0, 500.0),
                                                  (False, True))}


@pytest.fixture(scope="module")
def lib():
    return load()


def _inputs(rng, n):
    out = []
    for k in range(n):
        amp = float(rng.uniform(20.0, 400.0)) if k % 4 else float(rng.uniform(0.0, 30.0))
        ph = float(rng.uniform(-math.pi, math.pi))
        out.append((amp * math.cos(ph), amp * math.sin(ph), float(rng.uniform(-20.0, 20.0))))
    return out


def _same(c, py, label):
    assert c.outputs() == py.outputs(), label
    assert c.get_state() == py.get_state(), label
    assert c.warnings == py.warnings, label


@pytest.mark.parametrize("label", COMBOS)
def test_c_unit_is_plant_unit_bit_for_bit_at_random_inputs_and_states(lib, label):
    values = COMBOS[label]
    rng = np.random.default_rng(zlib.crc32(label.encode()))
    py, c = PlantUnit(values), CPlantUnit(lib, values)
    assert PlantUnit.OUTPUTS == tuple(v.name for v in PLANT_OUTPUTS)
    _same(c, py, label)
    t, n = 0.0, 12 if "pwm" in label else 40
    dts = (1e-4, 2.5e-4, 1e-4, 3e-5)
    for k, u in enumerate(_inputs(rng, n)):
        dt = dts[k % len(dts)]
        py.step(t, dt, u)
        c.step(t, dt, u)
        t += dt
        _same(c, py, (label, k))
    # random states near the trajectory's, set into both (PlantUnit.set_state), then a step
    base = py.get_state()
    n_x = len(py.x)
    for k, u in enumerate(_inputs(rng, 4 if "pwm" in label else 12)):
        s = list(base)
        for j in range(n_x):
            s[j] = base[j] * float(rng.uniform(0.7, 1.3)) + float(rng.normal(0.0, 0.05))
        s[n_x + (2 if "capacitor" in label else 0)] = float(rng.uniform(-300.0, 300.0))  # the held voltage
        py.set_state(s)
        c.set_state(s)
        _same(c, py, (label, "set", k))
        py.step(t, 1e-4, u)
        c.step(t, 1e-4, u)
        t += 1e-4
        _same(c, py, (label, "set step", k))


@pytest.mark.parametrize("label", ["average ideal R_fe=0.0 thermal=False",
                                   "pwm capacitor R_fe=500.0 thermal=True",
                                   "average capacitor R_fe=500.0 thermal=False"])
def test_every_warning_text_and_order_is_plant_units(lib, label):
    """Plausibility (|v_s| before the step, |i_s| and |omega_m| after it), the over-voltage fault: the
    same texts in the same order, each once per run."""
    values = dict(COMBOS[label], v_warn=50.0, i_warn=5.0, omega_warn=0.5, omega_m0=1.0, V_dc_max=500.0)
    if values.get("R_chop", 0.0) > 0.0:  # a fault level below the chopper's is refused: the chopper off here
        values["R_chop"] = 0.0
    py, c = PlantUnit(values), CPlantUnit(lib, values)
    t = 0.0
    for u in [(300.0, -200.0, -30.0)] * 6:
        py.step(t, 1e-4, u)
        c.step(t, 1e-4, u)
        t += 1e-4
        _same(c, py, label)
    text = " | ".join(py.warnings)
    for what in ("implausible input at t = 0.0 s: |v_s|", "|i_s|", "|omega_m|"):
        assert text.count(what) == 1, (what, py.warnings)
    assert len(py.warnings) == (4 if "capacitor" in label else 3), py.warnings


@pytest.mark.parametrize("values, field", [
    ({"max_substeps": 0}, "max_substeps"), ({"v_warn": -1.0}, "v_warn"), ({"i_warn": math.nan}, "i_warn"),
    ({"omega_warn": -2.0}, "omega_warn"), ({"h_int": 0.0}, "h_int"), ({"psi_r0": -1.0}, "psi_r0"),
    ({"R_fe": -1.0}, "R_fe"), ({"B_2": -1.0}, "B_2"), ({"dc_link": "battery"}, "dc_link"),
    ({"C_dc": 0.0, "dc_link": "capacitor"}, "C_dc"), ({"inverter": "pwm", "f_sw": -1.0}, "f_sw"),
    ({"inverter": "sine"}, "inverter"), ({"thermal": True, "C_th_s": 0.0}, "C_th_s"),
])
def test_c_unit_refuses_what_plant_unit_refuses_with_the_same_message(lib, values, field):
    with pytest.raises(ParameterError) as py_err:
        PlantUnit(values)
    with pytest.raises(CUnitError) as c_err:
        CPlantUnit(lib, values)
    assert c_err.value.message == str(py_err.value), field
    assert c_err.value.message.startswith(f"{field} = ")


@pytest.mark.parametrize("label", ["average ideal R_fe=0.0 thermal=False",
                                   "pwm ideal R_fe=0.0 thermal=False"])
def test_a_refused_step_changes_nothing_with_plant_units_message(lib, label):
    values = dict(COMBOS[label], max_substeps=30)
    py, c = PlantUnit(values), CPlantUnit(lib, values)
    py.step(0.0, 1e-4, (100.0, 0.0, 0.0))
    c.step(0.0, 1e-4, (100.0, 0.0, 0.0))
    before = c.get_state(), c.outputs()
    for dt, u in ((1e-2, (1.0, 0.0, 0.0)), (-1e-4, (1.0, 0.0, 0.0)), (1e-4, (math.nan, 0.0, 0.0)),
                  (1e-4, (0.0, 0.0, math.inf))):
        with pytest.raises(ParameterError) as py_err:
            py.step(1e-4, dt, u)
        with pytest.raises(CUnitError) as c_err:
            c.step(1e-4, dt, u)
        assert c_err.value.message == str(py_err.value), (dt, u)
        assert (c.get_state(), c.outputs()) == before
    _same(c, py, label)


@pytest.mark.parametrize("label", [k for k in COMBOS if k.startswith("average")])
def test_the_units_derivatives_are_the_python_plants_and_links_bit_for_bit(lib, label):
    """sm_plant_unit_derivatives (the model-exchange path): Plant.derivatives on the ideal link,
    DCLink.derivatives (chopper held) on the capacitor link, at random states and inputs."""
    values = COMBOS[label]
    rng = np.random.default_rng(7)
    py, c = PlantUnit(values), CPlantUnit(lib, values)
    x0 = py.x
    for u in _inputs(rng, 50):
        x = [v * float(rng.uniform(0.5, 1.5)) + float(rng.normal(0.0, 0.1)) for v in x0]
        t = float(rng.uniform(0.0, 1.0))
        want = (py._link.derivatives(t, x, *u, py._chop) if py._link is not None
                else py.plant.derivatives(t, x, *u))
        assert c.derivatives(t, x, u) == tuple(want), (label, x, u)
