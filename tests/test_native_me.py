"""The model-exchange plant SaturatedInductionMotorME (native C, FMI 2.0 in native-me/, FMI 3.0 in
native-me-fmi3/): fmpy validates both; its derivatives and outputs at random states are the Python
plant's (satmotor.machine.plant.Plant) to the last bit; fmpy's CVode integrates it to the reference
(reference/SaturatedInductionMotorME: the plain-Python plant at a small RK4 step) and to the
co-simulation plant at a small step; the event-mode calls of a model without events; and the closed
loop with the controller FMU in a small master of this file, against the project's co-simulation
closed loop: with an RK4 over the ME derivatives at the master's step it is the co-simulation run
bit for bit, with CVode between the controller samples it is within the integration error."""

from __future__ import annotations

import dataclasses
import math
import sys
from ctypes import c_double
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    FMU2Model,
    FMU2Slave,
    calloc,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
    free,
)
from fmpy.fmi3 import FMU3Model, FMU3Slave
from fmpy.util import read_csv, read_ref_opt_file
from fmpy.validation import validate_fmu

from orchestration.packaging import fmus, reference_results
from orchestration.packaging.native import model_exchange as native_me
from orchestration.run.master import run
from orchestration.scenario.load import load_scenario
from satmotor.interface import PLANT_PARAMETERS, STEP_MEAN_OUTPUTS, PlantUnit

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "reference" / native_me.NAME
VERSIONS = ("2.0", "3.0")
STATES = native_me.STATES
NX = len(STATES)  # eleven, whatever the parameters (the extra ones' derivatives zero when not integrated)
OUTPUTS = PlantUnit.OUTPUTS
# the outputs a model-exchange integration is compared on: not v_avg_alpha/beta, which the ME plant gives as
# the input itself (its average-value inverter) and the co-simulation plant as the last step's average
COMPARED = tuple(o for o in OUTPUTS if o not in ("v_avg_alpha", "v_avg_beta", *STEP_MEAN_OUTPUTS))
TARGET = 1e-6  # relative error of the ME plant under CVode (rtol 1e-10) against the co-simulation plant


def me_path(fmu_dir, version):
    return Path(fmu_dir) / native_me.DIRS[version] / native_me.FILE


class MEPlant:
    """One instance of the ME plant through fmpy's model-exchange classes, its log collected."""

    def __init__(self, path, name="me"):
        self.md = read_model_description(str(path))
        self.fmi3 = self.md.fmiVersion.startswith("3")
        self.log = []
        d = extract(str(path))
        kind = FMU3Model if self.fmi3 else FMU2Model
        self.fmu = kind(guid=self.md.guid, unzipDirectory=d,
                        modelIdentifier=self.md.modelExchange.modelIdentifier, instanceName=name)
        if self.fmi3:
            self.fmu.instantiate(
                logMessage=lambda env, status, cat, msg: self.log.append((status, msg.decode())))
        else:
            cb = fmi2CallbackFunctions()  # the FMU pre-formats its messages (no variadic arguments)
            cb.logger = fmi2CallbackLoggerTYPE(
                lambda env, inst, status, cat, msg: self.log.append((status, msg.decode())))
            cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
            cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
            self._cb = cb
            self.fmu.instantiate(callbacks=cb)
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.types = {v.name: v.type for v in self.md.modelVariables}
        self.x, self.dx = (c_double * NX)(), (c_double * NX)()

    def set(self, values):
        for name, value in values.items():
            t, vr = self.types[name], [self.vr[name]]
            if t == "String":
                self.fmu.setString(vr, [value])
            elif t == "Boolean":
                self.fmu.setBoolean(vr, [bool(value)])
            elif t in ("Integer", "Int32"):
                (self.fmu.setInt32 if self.fmi3 else self.fmu.setInteger)(vr, [int(value)])
            else:
                (self.fmu.setFloat64 if self.fmi3 else self.fmu.setReal)(vr, [float(value)])

    def get(self, names):
        return (self.fmu.getFloat64 if self.fmi3 else self.fmu.getReal)([self.vr[n] for n in names])

    def initialize(self, params=None):
        """Parameters, initialization, event update; ends in event mode."""
        if not self.fmi3:
            self.fmu.setupExperiment(startTime=0.0)
        self.set(params or {})
        if self.fmi3:
            self.fmu.enterInitializationMode(startTime=0.0)
        else:
            self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()
        assert not any(self.update()[:4])

    def update(self):
        return self.fmu.updateDiscreteStates() if self.fmi3 else self.fmu.newDiscreteStates()

    def states(self):
        self.fmu.getContinuousStates(self.x, NX)
        return list(self.x)

    def set_states(self, x):
        self.x[:] = [float(v) for v in x]
        self.fmu.setContinuousStates(self.x, NX)

    def derivatives(self):
        (self.fmu.getContinuousStateDerivatives if self.fmi3 else self.fmu.getDerivatives)(self.dx, NX)
        return list(self.dx)

    def close(self):
        self.fmu.terminate()
        self.fmu.freeInstance()


def test_both_me_fmus_validate_and_are_model_exchange_only(fmu_dir):
    for version in VERSIONS:
        path = me_path(fmu_dir, version)
        assert validate_fmu(str(path)) == [], path
        md = read_model_description(str(path))
        assert md.fmiVersion == version and md.coSimulation is None
        assert md.modelExchange.modelIdentifier == "SaturatedInductionMotorME"
        assert md.numberOfContinuousStates == NX and md.numberOfEventIndicators == 0
        assert [d.variable.name for d in md.derivatives] == [f"der({s})" for s in STATES]
        assert [d.variable.derivative.name for d in md.derivatives] == list(STATES)
        cs_variant = "native" if version == "2.0" else "native-fmi3"
        cs = read_model_description(str(fmus.paths(fmu_dir, cs_variant)[0]))
        # the co-simulation plant's variables, value references and start values, and the derivatives
        same = [(v.name, v.valueReference, v.causality, v.start) for v in cs.modelVariables]
        mine = [(v.name, v.valueReference, v.causality, v.start) for v in md.modelVariables]
        assert mine[:len(same)] == same and len(mine) == len(same) + NX
        # outputs depend on states only, but: the step-average applied voltage, which is the input v_s
        # itself (the average-value inverter; the controller does not read it), and the terminal current
        # and the core loss, which with R_fe > 0 read the stator voltage at the same instant (direct
        # feedthrough: a tool sees the algebraic loop with a controller that feeds back i_s at once)
        inputs = {v.name for v in md.modelVariables if v.causality == "input"}
        for out in md.outputs:
            assert out.dependencies is not None
            deps = {d.name for d in out.dependencies}
            name = out.variable.name
            if name in ("v_avg_alpha", "v_avg_beta"):
                assert deps == {name.replace("v_avg", "v_s")}
            elif name in ("i_s_alpha", "i_s_beta", "P_fe", "P_cu_s", "P_stray", "P_inv", "P_in"):
                assert deps & inputs == {"v_s_alpha", "v_s_beta"}, name  # the terminal current (R_fe)
            elif name == "P_mech":  # the load at the instant (issue 35)
                assert deps & inputs == {"T_load"}, name
            else:
                assert not deps & inputs, name
            if name in STATES:
                assert deps == {name}
        # the initial values of the fed-through outputs read the inputs too (the initial unknowns)
        fed = [u for u in md.initialUnknowns if u.variable.name in ("i_s_alpha", "i_s_beta", "P_fe")]
        assert len(fed) == 3
        for u in fed:
            assert {"v_s_alpha", "v_s_beta"} <= {d.name for d in u.dependencies}, u.variable.name


@pytest.mark.parametrize("version", VERSIONS)
def test_the_me_plant_refuses_the_pwm_inverter(fmu_dir, version):
    """Switching belongs to co-simulation: inverter = pwm is an error at initialization, naming it."""
    me = MEPlant(me_path(fmu_dir, version), "pwm")
    with pytest.raises(Exception) as exc:
        me.initialize({"inverter": "pwm"})
    assert exc.value.status == 3  # fmi2Error / fmi3Error, not fatal
    assert any("inverter = 'pwm'" in msg and "co-simulation" in msg for _, msg in me.log), me.log
    me.fmu.freeInstance()
    good = MEPlant(me_path(fmu_dir, version), "average")
    good.initialize({"inverter": "average", "t_dead": 1e-6})
    good.close()


@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize("parameter", [v.name for v in PLANT_PARAMETERS if v.choices])
def test_a_string_parameter_outside_its_choices_is_an_error_naming_them(fmu_dir, version, parameter):
    """The generated parser's refusal (sm_choice_parse) in the ME plant: an error at initialization,
    the message naming the parameter, the value and every allowed value."""
    choices = next(v.choices for v in PLANT_PARAMETERS if v.name == parameter)
    me = MEPlant(me_path(fmu_dir, version), "bad")
    bad = choices[-1].capitalize()
    with pytest.raises(FMICallException) as exc:
        me.initialize({parameter: bad})
    assert exc.value.status == 3  # fmi2Error / fmi3Error, not fatal
    text = " ".join(m for _, m in me.log)
    assert f"{parameter} = {bad!r}: must be one of {', '.join(choices)}" in text, text
    me.fmu.freeInstance()


def _random_states(rng, n):
    x = np.empty((n, NX))
    x[:, 6:8] = rng.uniform(280.0, 420.0, (n, 2))  # T_s, T_r [K]
    x[:, 8] = rng.uniform(200.0, 700.0, n)  # v_dc [V] (some below the command's need: the bound acts)
    x[:, 9:11] = rng.uniform(0.0, 2000.0, (n, 2))  # E_regen, E_chop [J]
    x[:, :4] = rng.uniform(-1.6, 1.6, (n, 4))
    x[:, 4] = rng.uniform(-320.0, 320.0, n)
    x[:, 5] = rng.uniform(-10.0, 10.0, n)
    x[:5, :4] = rng.uniform(-1e-9, 1e-9, (5, 4))  # near the unmagnetized origin
    x[0, :4] = 0.0
    u = np.column_stack([rng.uniform(-400, 400, n), rng.uniform(-400, 400, n), rng.uniform(-40, 40, n)])
    return x, u


NO_LINK_EVENTS = dict(dc_link="capacitor", R_chop=0.0, V_dc_max=0.0, C_dc=470e-6)  # what ME takes of it
WARM = dict(thermal=True, C_th_s=30.0, C_th_r=12.0, T_s0=330.0, T_r0=320.0)
CASES = [
    ("default", {}),
    ("exponential+fan", dict(curve="exponential", L_m0=0.33, L_m_inf=0.01, I_par=3.66, B_2=0.002)),
    ("polynomial", dict(curve="polynomial", L_m0=0.3, poly_b=10.0, poly_n=11)),
    ("linear", dict(curve="linear", L_m0=0.1722, n_p=3, J=0.05)),
    ("R_fe", dict(R_fe=500.0)),
    ("thermal", WARM),
    ("R_fe thermal gamma", dict(WARM, R_fe=400.0, l_s=0.0)),
    ("capacitor", NO_LINK_EVENTS),
    ("capacitor R_fe thermal rectifier", dict(NO_LINK_EVENTS, **WARM, R_fe=500.0, dc_source="rectifier")),
]


def python_me(unit, t, xs, us):
    """What the ME plant must give at time t [s], its eleven states xs and the inputs us, from the
    Python unit: the derivatives (Plant.derivatives, or DCLink.derivatives with the chopper off; zero
    for a state the parameter set does not integrate) and the outputs (PlantUnit.outputs with the
    state set and the input voltage held; a state output is the state)."""
    plant, link = unit.plant, unit._link
    idx = list(range(6)) + ([6, 7] if plant.th.thermal else []) + ([8, 9, 10] if link is not None else [])
    x = [xs[j] for j in idx]
    d = link.derivatives(t, x, *us, False) if link is not None else plant.derivatives(t, x, *us)
    der = [0.0] * NX
    for j, v in zip(idx, d):
        der[j] = v
    unit.instant = True  # the powers at the instant (P_in, P_inv), as the ME plant gives them
    unit.set_state([*x, *((0.0, 0.0) if link is not None else ()), us[0], us[1], us[2], *(0.0,) * 5])
    out = dict(zip(OUTPUTS, unit.outputs()))
    out.update(zip(STATES, xs))
    return der, [out[n] for n in OUTPUTS]


@pytest.mark.parametrize("version", VERSIONS)
def test_derivatives_and_outputs_at_random_states_are_the_python_plants_bit_for_bit(fmu_dir, version):
    """Every continuous option (core loss, the thermal model, the capacitor link without chopper and
    fault, the rectifier source at a random time): the derivatives and every output of the Python unit
    to the last bit."""
    rng = np.random.default_rng(21)
    der_names = [f"der({s})" for s in STATES]
    n_values = 0
    for label, params in CASES:
        me = MEPlant(me_path(fmu_dir, version), label)
        me.initialize(params)
        me.fmu.enterContinuousTimeMode()
        unit = PlantUnit(params)
        x, u = _random_states(rng, 150)
        for xi, ui in zip(x, u):
            xs, us = [float(v) for v in xi], [float(v) for v in ui]
            t = float(rng.uniform(0.0, 0.1))
            me.fmu.setTime(t)
            me.set(dict(zip(("v_s_alpha", "v_s_beta", "T_load"), us)))
            me.set_states(xs)
            der, out = python_me(unit, t, xs, us)
            assert me.derivatives() == der, (label, xs, us)
            assert me.get(der_names) == der  # the derivative variables too
            assert me.get(OUTPUTS) == out, (label, xs)
            assert me.states() == xs
            # an input set alone: the outputs follow it at once (R_fe: direct feedthrough)
            us2 = [us[0] * 0.5, -us[1], us[2]]
            me.set(dict(zip(("v_s_alpha", "v_s_beta", "T_load"), us2)))
            assert me.get(OUTPUTS) == python_me(unit, t, xs, us2)[1], (label, xs)
            n_values += NX
        me.close()
    print(f"FMI {version}: {n_values} derivatives equal to the Python plant's bit for bit")


@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize("params, want", [
    ({"dc_link": "capacitor", "R_chop": 40.0, "V_chop_on": 750.0, "V_chop_off": 720.0},
     "R_chop = 40.0: the model-exchange plant SaturatedInductionMotorME has no brake chopper (it switches "
     "with hysteresis"),
    ({"dc_link": "capacitor"}, "V_dc_max = 800.0: the model-exchange plant SaturatedInductionMotorME has no "
     "over-voltage fault (latched"),
])
def test_the_capacitor_links_switching_parts_are_refused_with_their_reason(fmu_dir, version, params, want):
    """What switches in the capacitor link (satmotor/converter/dc_link.py) needs events the ME plant does
    not have: the brake chopper's hysteresis and the latched over-voltage fault are errors at
    initialization naming the parameter and what to set; without them the link is taken."""
    me = MEPlant(me_path(fmu_dir, version))
    with pytest.raises(FMICallException):
        me.initialize(params)
    text = " ".join(m for _, m in me.log)
    assert want in text, text
    me.fmu.freeInstance()
    good = MEPlant(me_path(fmu_dir, version), "continuous link")
    good.initialize({**params, "R_chop": 0.0, "V_dc_max": 0.0})
    assert good.states()[8:] == [PlantUnit({}).link.V_dc, 0.0, 0.0]
    good.close()


@pytest.mark.parametrize("version", VERSIONS)
def test_event_mode_calls_of_a_model_without_events(fmu_dir, version):
    me = MEPlant(me_path(fmu_dir, version))
    nominal = (c_double * NX)()
    me.fmu.getNominalsOfContinuousStates(nominal, NX)  # constants: also before initialization
    assert list(nominal) == [1.0] * 6 + [300.0, 300.0, 500.0, 1000.0, 1000.0]
    me.initialize({"psi_r0": 0.8, "omega_m0": 10.0})
    x0 = me.states()
    assert x0[2] == 0.8 and x0[4] == 10.0 and x0[0] > 0.8  # the magnetized start of the CS plant
    with pytest.raises(FMICallException):  # event mode: no new states
        me.set_states(x0)
    assert "only allowed in continuous-time mode" in me.log[-1][1]
    me.fmu.enterEventMode()  # already in event mode: nothing changes (tools call it so)
    assert not any(me.update()[:5])  # nothing to update, no time event: a model without events
    me.fmu.enterContinuousTimeMode()
    with pytest.raises(FMICallException):
        me.update()
    me.fmu.setTime(1e-3)
    me.set_states(x0)
    assert me.fmu.completedIntegratorStep() == (False, False)
    z = (c_double * 1)()
    me.fmu.getEventIndicators(z, 0)
    with pytest.raises(FMICallException):
        me.fmu.getEventIndicators(z, 1)
    with pytest.raises(FMICallException):
        me.fmu.getContinuousStates(me.x, 5)
    assert f"5 values, the model has {NX}" in me.log[-1][1]
    # an input event as fmpy handles one: event mode, the new input, the update, back
    me.fmu.enterEventMode()
    me.set({"T_load": 5.0})
    assert not any(me.update()[:5])
    me.fmu.enterContinuousTimeMode()
    assert me.states() == x0
    # a non-finite state is a discard naming it, the states stay; a non-finite input too
    bad = list(x0)
    bad[4] = math.nan
    with pytest.raises(FMICallException) as exc:
        me.set_states(bad)
    assert exc.value.args[0].endswith("(discard).")
    assert "continuous state omega_m = nan is not finite" in me.log[-1][1]
    assert me.states() == x0
    me.set({"v_s_beta": math.inf})
    with pytest.raises(FMICallException):
        me.derivatives()
    assert "v_s_beta = inf: must be a finite number" in me.log[-1][1]
    # reset: back to instantiated; initialized again it is in event mode, not continuous-time mode
    me.fmu.reset()
    me.initialize()
    with pytest.raises(FMICallException):
        me.set_states(x0)
    me.close()
    # co-simulation is refused by the ME binary: it is the other FMU's job
    md = read_model_description(str(me_path(fmu_dir, version)))
    kind = FMU3Slave if version == "3.0" else FMU2Slave
    slave = kind(guid=md.guid, unzipDirectory=extract(str(me_path(fmu_dir, version))),
                 modelIdentifier=md.modelExchange.modelIdentifier, instanceName="cs")
    with pytest.raises(Exception, match="Failed to instantiate"):
        slave.instantiate()


@pytest.mark.parametrize("version", VERSIONS)
def test_fmu_state_of_the_me_plant_restores_its_states_bit_for_bit(fmu_dir, version):
    me = MEPlant(me_path(fmu_dir, version))
    me.initialize({"psi_r0": 0.7})
    me.fmu.enterContinuousTimeMode()
    if me.fmi3:
        assert (me.fmu.getNumberOfContinuousStates(), me.fmu.getNumberOfEventIndicators()) == (NX, 0)
    me.set({"v_s_alpha": 300.0, "v_s_beta": -20.0, "T_load": 3.0})
    x0 = me.states()
    dx0 = me.derivatives()
    get, put = ((me.fmu.getFMUState, me.fmu.setFMUState) if me.fmi3
                else (me.fmu.getFMUstate, me.fmu.setFMUstate))
    serialize = me.fmu.serializeFMUState if me.fmi3 else me.fmu.serializeFMUstate
    deserialize = me.fmu.deserializeFMUState if me.fmi3 else me.fmu.deSerializeFMUstate
    state = get()
    blob = bytes(serialize(state))
    me.set_states([v + 0.25 for v in x0])
    me.set({"v_s_alpha": 0.0})
    assert me.states() != x0
    put(state)
    assert me.states() == x0 and me.derivatives() == dx0  # the inputs are part of the state
    me.set_states([v - 0.5 for v in x0])
    put(deserialize(blob))
    assert me.states() == x0 and me.derivatives() == dx0
    me.close()


def _deviation(res, ref, names):
    dev = {n: float(np.max(np.abs(res[n] - ref[n])) / max(np.max(np.abs(ref[n])), 1e-300)) for n in names}
    worst = max(dev, key=dev.get)
    return dev[worst], worst


def test_the_reference_is_the_co_simulation_plant_at_a_small_step(fmu_dir):
    """The ME reference (the plain-Python plant, RK4 at H/10) is what the native co-simulation plant
    gives at that internal step with the same held inputs."""
    cs_in = read_csv(ROOT / "reference" / "SaturatedInductionMotor" / "SaturatedInductionMotor_in.csv")
    ref = read_csv(REFERENCE / f"{native_me.NAME}_ref.csv")
    res = simulate_fmu(str(fmus.paths(fmu_dir, "native")[0]), stop_time=0.3, output_interval=1e-4,
                       input=cs_in, output=list(COMPARED), start_values={"h_int": reference_results.ME_H_INT})
    assert len(res) == len(ref)
    dev, worst = _deviation(res, ref, COMPARED)
    print(f"native co-simulation plant (h_int {reference_results.ME_H_INT}) vs the ME reference: "
          f"{dev:.3g} ({worst})")
    assert dev <= 1e-12


@pytest.mark.parametrize("version", VERSIONS)
def test_cvode_integrates_the_me_plant_to_the_reference(fmu_dir, version):
    """Direct-on-line start at 400 V, 50 Hz (the voltage held over each 1e-4 s step, as the co-simulation
    plant sees it: fmpy makes each step an input event) and the rated-load step at 0.2 s, integrated by
    fmpy's CVode at rtol 1e-10."""
    opts = read_ref_opt_file(str(REFERENCE / "ReferenceOptions.txt"))
    inputs = read_csv(REFERENCE / f"{native_me.NAME}_in.csv")
    ref = read_csv(REFERENCE / f"{native_me.NAME}_ref.csv")
    res = simulate_fmu(str(me_path(fmu_dir, version)), start_time=opts["StartTime"],
                       stop_time=opts["StopTime"], output_interval=opts["StepSize"], solver="CVode",
                       relative_tolerance=opts["RelTol"],
                       input=inputs, output=list(COMPARED), record_events=False)
    assert len(res) == len(ref) and np.allclose(res["time"], ref["time"], rtol=0, atol=1e-12)
    dev, worst = _deviation(res, ref, COMPARED)
    print(f"FMI {version} ME plant, CVode rtol {opts['RelTol']}: max relative error {dev:.3g} ({worst})")
    assert dev < TARGET
    assert ref["omega_m"][-1] > 140.0 and max(ref["i_mu"]) > 5.0  # the start and the knee were run


# the ME plant's options against the co-simulation plant: the states and what depends on the states only
# (the terminal current, P_fe and P_cu_s read the voltage of the instant with R_fe: at a sample the
# co-simulation plant gives them at the voltage held over the step that ended, the ME plant at the new
# input)
OPTIONS_COMPARED = tuple(n for n in COMPARED if n not in ("i_s_alpha", "i_s_beta", "P_fe", "P_cu_s"))
OPTIONS_TARGET = 1e-6  # relative error (of each column's largest magnitude) under CVode at rtol 1e-10


@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize("label", ["R_fe thermal", "capacitor R_fe thermal"])
def test_cvode_integrates_the_me_plant_with_its_options_to_the_co_simulation_plant(fmu_dir, version, label):
    """Core loss and the thermal model (a hot, light motor: the temperatures move), with and without the
    capacitor link (no chopper, no fault), the first 0.05 s of the direct-on-line start: fmpy's CVode
    over the ME plant against the native co-simulation plant at the reference's small RK4 step."""
    params = dict(WARM, R_fe=500.0, C_th_s=3.0, C_th_r=1.2)
    params.update(NO_LINK_EVENTS if "capacitor" in label else {})
    inputs = read_csv(REFERENCE / f"{native_me.NAME}_in.csv")
    inputs = inputs[inputs["time"] <= 0.05]
    cs = simulate_fmu(str(fmus.paths(fmu_dir, "native")[0]), stop_time=0.05, output_interval=1e-4,
                      input=inputs, output=list(OPTIONS_COMPARED),
                      start_values={**params, "h_int": reference_results.ME_H_INT})
    res = simulate_fmu(str(me_path(fmu_dir, version)), stop_time=0.05, output_interval=1e-4, solver="CVode",
                       relative_tolerance=1e-10, input=inputs, output=list(OPTIONS_COMPARED),
                       start_values=params, record_events=False)
    assert len(res) == len(cs)
    energies = ("E_regen", "E_chop")
    dev, worst = _deviation(res, cs, [n for n in OPTIONS_COMPARED if n not in energies])
    print(f"FMI {version} ME plant ({label}), CVode rtol 1e-10 vs co-simulation: {dev:.3g} ({worst})")
    assert dev < OPTIONS_TARGET
    # the link's energy counters integrate max(0, -p_inv) (a kink where the power changes sign, at which
    # the co-simulation plant's fixed-step RK4 is first order): against the energy the capacitor holds
    stored = 0.5 * NO_LINK_EVENTS["C_dc"] * PlantUnit({}).link.V_dc ** 2
    for n in energies:
        err = float(np.max(np.abs(res[n] - cs[n])))
        print(f"  {n}: {err:.3g} J of the capacitor's {stored:.3g} J")
        assert err < OPTIONS_TARGET * stored, n
    assert cs["T_s"][-1] - cs["T_s"][0] > 0.1  # the stator heated
    if "capacitor" in label:
        assert cs["v_dc"][0] - min(cs["v_dc"]) > 2.0  # the link voltage sagged (the start's current)


# ---- the closed loop ---------------------------------------------------------------------------------

CLOSED_LOOP_STOP = 0.4  # [s]: pre-magnetization, the switch to the law (~0.11 s), the ramp from 0.2 s
MEASURED = ("i_s_alpha", "i_s_beta", "psi_r_alpha", "psi_r_beta", "psi_s_alpha", "psi_s_beta", "omega_m")


def _controller(fmu_dir):
    path = fmus.paths(fmu_dir, "native")[1]
    md = read_model_description(str(path))
    c = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(path)),
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName="ctrl")
    c.instantiate()
    c.setupExperiment(startTime=0.0)
    c.enterInitializationMode()
    c.exitInitializationMode()
    return c, {v.name: v.valueReference for v in md.modelVariables}


def _closed_loop(fmu_dir, frame, integrate):
    """Gauss-Seidel as the master: at t_k the controller gets the plant outputs and the profiles (taken
    from the master's record ``frame``) and steps; the plant then runs over [t_k, t_k + h] with its
    voltages (``integrate(me, t, h)``).  Returns the plant outputs at every t_k."""
    ctrl, cvr = _controller(fmu_dir)
    me = MEPlant(me_path(fmu_dir, "2.0"), "me-loop")
    me.initialize()
    me.fmu.enterContinuousTimeMode()
    h = 1e-4
    n = len(frame) - 1
    prof = {p: frame[f"profile.{p}"].to_numpy() for p in ("omega_ref", "psi_ref", "T_load")}
    c_in = [cvr[n_] for n_ in (*MEASURED, "omega_ref", "psi_ref", "T_load")]
    c_out = [cvr["v_s_alpha"], cvr["v_s_beta"]]
    rows = []
    for k in range(n + 1):
        t = k * h
        y = me.get(COMPARED)
        rows.append(y)
        if k == n:
            break
        meas = dict(zip(COMPARED, y))
        ctrl.setReal(c_in, [meas[m] for m in MEASURED]
                     + [prof[p][k] for p in ("omega_ref", "psi_ref", "T_load")])
        ctrl.doStep(t, h)
        va, vb = ctrl.getReal(c_out)
        me.set({"v_s_alpha": va, "v_s_beta": vb, "T_load": prof["T_load"][k]})
        integrate(me, t, h)
    ctrl.terminate()
    ctrl.freeInstance()
    me.close()
    return np.array(rows)


def _rk4(me, t, h):
    """One RK4 step over the ME derivatives, in the float operations of the plant's RK4
    (satmotor/numerics integrate.rk4 and sm_plant_step)."""
    x = me.states()
    half, sixth = 0.5 * h, h / 6.0
    me.fmu.setTime(t)
    k1 = me.derivatives()
    me.set_states([x[i] + half * k1[i] for i in range(NX)])
    me.fmu.setTime(t + half)
    k2 = me.derivatives()
    me.set_states([x[i] + half * k2[i] for i in range(NX)])
    k3 = me.derivatives()
    me.set_states([x[i] + h * k3[i] for i in range(NX)])
    me.fmu.setTime(t + h)
    k4 = me.derivatives()
    me.set_states([x[i] + sixth * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]) for i in range(NX)])
    assert me.fmu.completedIntegratorStep() == (False, False)


class _CVode:
    """fmpy's CVode solver (BDF, rtol 1e-10) over the ME plant, restarted at each controller sample
    (the voltages jump there), as fmpy's own model-exchange loop restarts it at an input event."""

    def __init__(self, me):
        from fmpy.sundials import CVodeSolver

        fmu = me.fmu
        self.solver = CVodeSolver(nx=NX, nz=0, get_x=fmu.getContinuousStates, set_x=fmu.setContinuousStates,
                                  get_dx=fmu.getDerivatives, get_z=fmu.getEventIndicators,
                                  get_nominals=fmu.getNominalsOfContinuousStates, set_time=fmu.setTime,
                                  input=None, startTime=0.0, maxStep=1e-4, relativeTolerance=1e-10,
                                  maxNumSteps=100000)

    def __call__(self, me, t, h):
        if t > 0.0:
            self.solver.reset(t)
        _, _, t_end = self.solver.step(t, t + h)
        assert abs(t_end - (t + h)) <= 1e-15
        me.fmu.setTime(t + h)
        assert me.fmu.completedIntegratorStep() == (False, False)


def test_closed_loop_with_the_controller_fmu_against_the_co_simulation_loop(fmu_dir):
    sc = dataclasses.replace(load_scenario(ROOT / "scenarios" / "ramp_rated_load.yaml"),
                             stop_time=CLOSED_LOOP_STOP)
    assert sc.step == 1e-4 and sc.controller_every == 1 and sc.algorithm == "gauss-seidel"
    res = run(sc, *map(str, fmus.paths(fmu_dir, "native")))
    assert res.ok, res.message
    frame = res.frame
    cs = np.column_stack([frame[f"plant.{o}"].to_numpy() for o in COMPARED])
    # RK4 over the ME derivatives at the master's step: the co-simulation plant's arithmetic, but each
    # derivative's curve solve cold where the co-simulation plant warm-starts stages 2-4 (Plant.step):
    # the same to within the solve's rounding, amplified by no more than the loop's 4000 steps
    rk4 = _closed_loop(fmu_dir, frame, _rk4)
    assert rk4.shape == cs.shape
    dev = np.max(np.abs(rk4 - cs), axis=0) / np.maximum(np.max(np.abs(cs), axis=0), 1.0)
    print(f"closed loop, ME plant under RK4 vs the co-simulation loop: max relative difference "
          f"{dev.max():.3g}")
    assert dev.max() <= 1e-11, dev
    # CVode between the samples: the co-simulation plant's RK4 error and CVode's, nothing else
    holder = {}

    def cvode(me, t, h):
        holder.setdefault("solver", _CVode(me))(me, t, h)

    got = _closed_loop(fmu_dir, frame, cvode)
    dev = np.max(np.abs(got - cs), axis=0) / np.maximum(np.max(np.abs(cs), axis=0), 1e-300)  # E_regen: 0
    worst = int(np.argmax(dev))
    print(f"closed loop, ME plant under CVode vs the co-simulation loop: max relative difference "
          f"{dev[worst]:.3g} ({COMPARED[worst]})")
    assert dev[worst] < 1e-5
    psi_r = math.hypot(cs[-1, COMPARED.index("psi_r_alpha")], cs[-1, COMPARED.index("psi_r_beta")])
    assert psi_r > 0.9  # magnetized: the loop ran the law


# ---- orchestration check learns model exchange ------------------------------------------------------

def _check(capsys, *argv):
    import re

    from orchestration.cli import commands as cli

    line = re.compile(r"^(PASS|FAIL|SKIP|KNOWN) +(\S+)  ([a-z-]+): (.*)$")
    code = cli.main(["check", *map(str, argv)])
    verdicts = {}
    for text in capsys.readouterr().out.splitlines():
        m = line.match(text)
        assert m, text
        verdicts[(m.group(2), m.group(3))] = (m.group(1), m.group(4))
    return code, verdicts


def test_check_passes_both_me_fmus_with_the_model_exchange_checks(fmu_dir, capsys):
    from orchestration.check import model_exchange

    paths = [me_path(fmu_dir, v) for v in VERSIONS]
    code, verdicts = _check(capsys, *paths)
    assert code == 0, verdicts
    for p in paths:
        for c in model_exchange.CHECKS:
            assert verdicts[(str(p), c)][0] == "PASS", (c, verdicts[(str(p), c)])
        assert "a model without events" in verdicts[(str(p), "me-events")][1]
        assert "worst" in verdicts[(str(p), "me-reference")][1]
        assert verdicts[(str(p), "instantiate")] == ("SKIP", "no CoSimulation element (model exchange only)")


def test_check_fails_an_me_fmu_whose_description_declares_an_event_indicator(fmu_dir, tmp_path, capsys):
    import zipfile

    src, broken = me_path(fmu_dir, "2.0"), tmp_path / native_me.FILE
    with zipfile.ZipFile(src) as z:
        files = {n: z.read(n) for n in z.namelist()}
    md = files["modelDescription.xml"].decode()
    files["modelDescription.xml"] = md.replace('numberOfEventIndicators="0"',
                                               'numberOfEventIndicators="1"').encode()
    with zipfile.ZipFile(broken, "w", zipfile.ZIP_DEFLATED) as z:
        for n, data in files.items():
            z.writestr(n, data)
    code, verdicts = _check(capsys, broken)
    assert code == 1
    verdict, detail = verdicts[(str(broken), "me-events")]
    assert verdict == "FAIL" and "1 values, the model has 0" in detail, detail
    assert verdicts[(str(broken), "me-states")][0] == "PASS"


def test_check_fails_an_me_reference_one_percent_off(fmu_dir, tmp_path, capsys):
    import shutil

    ref = tmp_path / "reference" / native_me.NAME
    shutil.copytree(REFERENCE, ref)
    csv = ref / f"{native_me.NAME}_ref.csv"
    head, *rows = csv.read_text().splitlines()
    col = head.split(",").index("omega_m")
    out = []
    for row in rows:
        cells = row.split(",")
        cells[col] = repr(float(cells[col]) * 1.01)
        out.append(",".join(cells))
    csv.write_text("\n".join([head, *out]) + "\n")
    path = me_path(fmu_dir, "3.0")
    code, verdicts = _check(capsys, path, "--reference", ref.parent)
    assert code == 1
    verdict, detail = verdicts[(str(path), "me-reference")]
    assert verdict == "FAIL" and "omega_m" in detail and "band 1e-06" in detail, detail


# ---- C hygiene --------------------------------------------------------------------------------------

def test_no_global_mutable_state_in_the_me_glue_or_model(tmp_path):
    """No writable data (bss/data/common symbols) in the objects the model-exchange build adds or
    compiles differently: the ME glue, fmi2_glue.c / fmi3_glue.c with -DFG_MODEL_EXCHANGE, the model
    and its generated tables (the rest of the glue and the core: tests/test_native_glue.py,
    tests/test_native_fmus.py): every instance independent."""
    import shutil
    import subprocess

    from orchestration.packaging.native import compiler as native_build

    if shutil.which("gcc") is None or shutil.which("nm") is None:
        pytest.skip("needs gcc and nm")
    inc = native_build.fmi_headers_dir()
    generated = native_me.generated(tmp_path)
    own = ("fg_me.c", "fmi2_me_glue.c", "fmi3_me_glue.c", "fmi2_glue.c", "fmi3_glue.c", "native_me.c",
           "sm_vars.c")
    everything = [*native_me.sources(), *native_build.glue_files("2.0"), *native_build.glue_files("3.0"),
                  native_build.GLUE_DIR / "fmi2_me_glue.c", native_build.GLUE_DIR / "fmi3_me_glue.c",
                  *generated]
    srcs = sorted({p for p in everything if p.name in own})
    assert len(srcs) == len(own)
    dirs = sorted({p.parent for p in native_me.sources()} | {tmp_path})
    for src in srcs:
        obj = tmp_path / (src.stem + ".o")
        subprocess.run(["gcc", "-std=c99", "-O2", "-fPIC", "-c", "-Wall", "-Wextra", "-Werror", "-pedantic",
                        f"-I{inc}", *(f"-I{d}" for d in dirs), *native_me.EXTRA_CFLAGS,
                        f"-DMODEL_IDENTIFIER={native_me.NAME}", '-DINSTANTIATION_TOKEN="{x}"', str(src), "-o",
                        str(obj)], check=True, capture_output=True)
        out = subprocess.run(["nm", "-f", "sysv", str(obj)], capture_output=True, text=True,
                             check=True).stdout
        rows = [[c.strip() for c in line.split("|")] for line in out.splitlines() if line.count("|") == 6]
        writable = [r for r in rows if r[2] in "bBdDcC" and not r[6].startswith(".data.rel.ro")]
        assert writable == [], (src.name, writable)


@pytest.mark.parametrize("version", VERSIONS)
def test_the_me_fmu_under_valgrind_touches_no_bad_memory(fmu_dir, version, tmp_path):
    """fmpy's CVode over the ME plant (0.02 s of the reference) and the refusals of the event-mode test
    under valgrind: no error in the FMU binary, a clean exit."""
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from test_process_exit import VALGRIND, python_child, run_under_valgrind

    if VALGRIND is None:
        pytest.skip("valgrind is not installed (scripts/system_packages.sh installs it)")
    child = python_child(f"""
        from fmpy import simulate_fmu
        from fmpy.util import read_csv
        inputs = read_csv({str(REFERENCE / f"{native_me.NAME}_in.csv")!r})
        r = simulate_fmu({str(me_path(fmu_dir, version))!r}, stop_time=0.02, output_interval=1e-4,
                         solver="CVode", relative_tolerance=1e-8, input=inputs[:401], record_events=False)
        print("ok", len(r))
    """)
    runs = run_under_valgrind({version: (child, {})}, tmp_path)
    r = runs[version]
    assert r.returncode == 0 and r.stdout.split()[0] == "ok", r.describe()
    in_fmu = [e for e in r.errors if e["stack"] and "/binaries/" in e["stack"][0]["obj"]]
    assert not in_fmu and not r.exit_errors, r.describe()


# ---- a C host without Python; the Windows binary under wine -------------------------------------------

ME_HOST_C = ROOT / "tests" / "native_me_host.c"
HOST_STEPS, HOST_H = 300, 1e-4
HOST_INPUTS = {"v_s_alpha": 150.0, "v_s_beta": -40.0, "T_load": 5.0}  # as tests/test_native_windows.py


def _host_args(unpacked, windows, md):
    """The C host's arguments for the unpacked ME FMU (``windows``: paths as wine sees them)."""
    fmi3 = md.fmiVersion.startswith("3")
    folder = (("x86_64-windows" if windows else "x86_64-linux") if fmi3
              else ("win64" if windows else "linux64"))
    lib = unpacked / "binaries" / folder / (native_me.NAME + (".dll" if windows else ".so"))
    res = unpacked / "resources"
    if windows:
        win = "Z:" + str(lib).replace("/", "\\")
        res_arg = ("Z:" + str(res).replace("/", "\\") + "\\") if fmi3 else "file:///Z:" + str(res)
        lib_arg = win
    else:
        lib_arg, res_arg = str(lib), (str(res) + "/" if fmi3 else res.as_uri())
    vr = {v.name: v.valueReference for v in md.modelVariables}
    return [lib_arg, md.guid, res_arg, str(HOST_STEPS), repr(HOST_H),
            *(f"{vr[n]}={v!r}" for n, v in HOST_INPUTS.items()), "--", *(str(vr[o]) for o in OUTPUTS)]


def _unzip(path, into):
    import zipfile

    with zipfile.ZipFile(path) as z:
        z.extractall(into)
    return into


@pytest.mark.parametrize("version", VERSIONS)
def test_a_c_host_integrating_the_me_plant_with_rk4_gets_the_python_plant_bit_for_bit(fmu_dir, version,
                                                                                        tmp_path):
    """tests/native_me_host.c (no Python): the ME plant's derivatives integrated by the host's RK4 at
    1e-4 s for 300 steps with constant inputs = the Python plant's derivatives under integrate.rk4, to
    the last bit; and within rounding (1e-12 of each output's size, floor 1) of PlantUnit stepped with
    h_int = 1e-4, whose RK4 stages 2-4 warm-start the curve solve (Plant.step) where an ME importer's
    derivative calls each start cold."""
    import shutil
    import subprocess

    from orchestration.packaging.native import compiler as native_build

    if shutil.which("gcc") is None:
        pytest.skip("needs gcc")
    host = tmp_path / "me_host"
    subprocess.run(["gcc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic",
                    f"-I{native_build.fmi_headers_dir()}", str(ME_HOST_C), "-o", str(host), "-ldl"],
                   check=True)
    path = me_path(fmu_dir, version)
    md = read_model_description(str(path))
    r = subprocess.run([str(host), *_host_args(_unzip(path, tmp_path / "fmu"), False, md)],
                       capture_output=True, text=True, timeout=120, env={})
    assert r.returncode == 0, (r.returncode, r.stderr)
    got = [float(v) for v in r.stdout.split()]
    from satmotor.machine.integrate import rk4

    unit, cold = PlantUnit({"h_int": HOST_H}), PlantUnit({"h_int": HOST_H})
    x, u = cold.x, tuple(HOST_INPUTS.values())
    for k in range(HOST_STEPS):
        unit.step(k * HOST_H, HOST_H, u)
        x = rk4(cold.plant.derivatives, k * HOST_H, x, HOST_H, 1, u)  # every solve cold, as the host's
    cold.instant = unit.instant = True  # the powers at the instant (P_in, P_inv), as the ME plant's
    cold.set_state((*x, *u, *(0.0,) * 5))  # the state, then the held stator voltage and load, no means
    assert got == list(cold.outputs())
    warm = list(unit.outputs())
    assert all(abs(g - w) <= 1e-12 * max(1.0, abs(w)) for g, w in zip(got, warm)), (got, warm)
    assert abs(got[OUTPUTS.index("i_s_alpha")]) > 10.0 and got[OUTPUTS.index("omega_m")] > 0.1  # it moved


def test_the_windows_binaries_of_the_me_plant_under_wine_give_the_linux_numbers(fmu_dir_all_platforms,
                                                                                 tmp_path):
    """The ME plant of the distributable build (Windows binaries by zig) run by the C host cross-compiled
    for Windows under wine, against the Linux binary in the Linux host: within 1e-12 of each output's size
    (floor 1): the libm differs (see tests/test_native_windows.py), nothing else may."""
    import os
    import shutil
    import subprocess
    import tempfile

    from orchestration.packaging.native import compiler as native_build

    wine = shutil.which("wine64") or shutil.which("wine")
    if wine is None or not native_build.zig_available() or shutil.which("gcc") is None:
        pytest.skip("needs wine, zig (pip install ziglang) and gcc")
    inc = native_build.fmi_headers_dir()
    flags = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", f"-I{inc}"]
    subprocess.run(["gcc", *flags, str(ME_HOST_C), "-o", str(tmp_path / "host"), "-ldl"], check=True)
    zig = [sys.executable, "-m", "ziglang", "cc", "-target", "x86_64-windows-gnu"]
    r = subprocess.run([*zig, *flags, "-O2", "-Wno-strict-prototypes", "-ffp-contract=off", str(ME_HOST_C),
                        "-o", str(tmp_path / "host.exe")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    prefix = tempfile.mkdtemp(prefix="wineprefix-")
    env = {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "HOME": os.environ.get("HOME", prefix),
           "WINEPREFIX": prefix, "WINEDEBUG": "-all", "WINEDLLOVERRIDES": "mscoree,mshtml="}
    try:
        subprocess.run([wine, "wineboot", "-i"], env=env, capture_output=True, timeout=180)
        for version in VERSIONS:
            path = native_me.path(fmu_dir_all_platforms, version)
            md = read_model_description(str(path))
            unpacked = _unzip(path, tmp_path / f"fmu{version}")
            lin = subprocess.run([str(tmp_path / "host"), *_host_args(unpacked, False, md)],
                                 capture_output=True, text=True, timeout=120)
            win = subprocess.run([wine, str(tmp_path / "host.exe"), *_host_args(unpacked, True, md)],
                                 capture_output=True, text=True, timeout=300, env=env)
            assert lin.returncode == 0 and win.returncode == 0, (lin.stderr, win.returncode,
                                                                  win.stderr[-500:])
            a, b = [float(v) for v in win.stdout.split()], [float(v) for v in lin.stdout.split()]
            assert len(a) == len(b) == len(OUTPUTS)
            worst = max(abs(x - y) / max(abs(y), 1.0) for x, y in zip(a, b))
            print(f"FMI {version} ME plant, Windows binary under wine vs Linux after {HOST_STEPS} RK4 steps: "
                  f"{worst:.3g}; bit-identical outputs {sum(x == y for x, y in zip(a, b))}/{len(a)}")
            assert worst <= 1e-12
    finally:
        server = shutil.which("wineserver")
        if server is not None:
            subprocess.run([server, "-k"], env=env, capture_output=True, timeout=60)
        shutil.rmtree(prefix, ignore_errors=True)


@pytest.mark.parametrize("version", VERSIONS)
def test_the_me_fmu_builds_from_its_own_sources_and_runs_bit_for_bit(fmu_dir, version, tmp_path):
    """A source-code FMU like the co-simulation ones: the C files its description lists (FMI 2.0:
    <SourceFiles> in <ModelExchange>; FMI 3.0: sources/buildDescription.xml) compiled alone, no -D
    (fg_identity.h carries the identity and FG_MODEL_EXCHANGE), run by the C host: the shipped
    binary's outputs to the last bit."""
    import shutil
    import subprocess
    import xml.etree.ElementTree as ET

    from orchestration.packaging.native import compiler as native_build

    if shutil.which("gcc") is None:
        pytest.skip("needs gcc")
    path = me_path(fmu_dir, version)
    md = read_model_description(str(path))
    unpacked = _unzip(path, tmp_path / "fmu")
    src = unpacked / "sources"
    if version == "2.0":
        root = ET.parse(unpacked / "modelDescription.xml").getroot()
        c_files = [f.get("name") for f in root.findall("./ModelExchange/SourceFiles/File")]
    else:
        root = ET.parse(src / "buildDescription.xml").getroot()
        c_files = [f.get("name") for f in root.iter("SourceFile")]
    assert "native_me.c" in c_files and "fg_me.c" in c_files and len(c_files) == len(list(src.glob("*.c")))
    built = tmp_path / "built.so"
    r = subprocess.run(["gcc", "-std=c99", "-O2", "-shared", "-fPIC", "-ffp-contract=off", "-Wall", "-Wextra",
                        "-Werror", "-pedantic", *c_files, "-o", str(built), "-lm"], cwd=src,
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    host = tmp_path / "me_host"
    subprocess.run(["gcc", "-std=c99", f"-I{native_build.fmi_headers_dir()}", str(ME_HOST_C), "-o", str(host),
                    "-ldl"], check=True)
    args = _host_args(unpacked, False, md)
    shipped = subprocess.run([str(host), *args], capture_output=True, text=True, timeout=120)
    mine = subprocess.run([str(host), str(built), *args[1:]], capture_output=True, text=True, timeout=120)
    assert shipped.returncode == mine.returncode == 0, (shipped.stderr, mine.stderr)
    assert mine.stdout == shipped.stdout and len(mine.stdout.split()) == len(OUTPUTS)
