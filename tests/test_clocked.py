"""The clocked controller (``native-fmi3-clocked/BacksteppingController.fmu``): an FMI 3.0 Scheduled
Execution FMU whose sampling is a periodic input clock of constant interval Ts.

Its model description passes ``fmpy validate`` and the FMI 3.0 schema (the copy fmpy ships) and declares
the clock as the co-simulation controller declares its step (``fixedInternalStepSize``); the closed loop
with the native FMI 3.0 plant, the clock activated by a small scheduler of this file through fmpy's
Scheduled Execution class, is the project's master's co-simulation closed loop bit for bit (plant and
controller outputs); the glue refuses what the clock forbids (another time, another clock, another Ts,
co-simulation calls) with a message, and a non-finite input is a discard as in co-simulation."""

from __future__ import annotations

import dataclasses
import xml.etree.ElementTree as ET
import zipfile
from ctypes import c_double, c_int
from pathlib import Path

import fmpy
import numpy as np
import pytest
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import FMU3ScheduledExecution, FMU3Slave, fmi3IntervalUnchanged, fmi3ValueReference
from fmpy.validation import validate_fmu
from lxml import etree

from orchestration.packaging import fmus
from orchestration.packaging.native import clocked
from orchestration.run.master import run
from orchestration.scenario.load import load_scenario

ROOT = Path(__file__).resolve().parents[1]
SCHEMA = Path(fmpy.__file__).parent / "schema" / "fmi3" / "fmi3ModelDescription.xsd"
MEASURED = ("i_s_alpha", "i_s_beta", "psi_r_alpha", "psi_r_beta", "psi_s_alpha", "psi_s_beta", "omega_m")
PROFILES = ("omega_ref", "psi_ref", "T_load")
FLAGS = ("phase", "voltage_limited", "current_limited", "singular_limited")  # not Float64
TS = 1e-4  # [s] the controller's default sample period, written here independently of the tables


@pytest.fixture(scope="module")
def fmu(fmu_dir):
    return clocked.path(fmu_dir)


class Clocked:
    """One instance of the clocked controller through fmpy's FMU3ScheduledExecution, its log kept."""

    def __init__(self, path, name="clocked"):
        self.md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.clock = self.vr[clocked.CLOCK]
        self.log = []

        def logger(env, status, category, message):
            self.log.append((status, message.decode()))

        self.fmu = FMU3ScheduledExecution(guid=self.md.guid, unzipDirectory=extract(str(path)),
                                          modelIdentifier=self.md.scheduledExecution.modelIdentifier,
                                          instanceName=name)
        self.fmu.instantiate(logMessage=logger)

    def start(self, **params):
        self.fmu.enterInitializationMode(startTime=0.0)
        if params:
            self.fmu.setFloat64([self.vr[k] for k in params], list(params.values()))
        self.fmu.exitInitializationMode()

    def activate(self, t):
        self.fmu.activateModelPartition(self.clock, t)

    def close(self):
        self.fmu.terminate()
        self.fmu.freeInstance()


def test_the_clocked_controller_validates_and_declares_its_sample_period(fmu, fmu_dir):
    assert validate_fmu(str(fmu)) == []
    xml = zipfile.ZipFile(fmu).read("modelDescription.xml")
    schema = etree.XMLSchema(file=str(SCHEMA))
    assert schema.validate(etree.ElementTree(etree.fromstring(xml))), schema.error_log
    root = ET.fromstring(xml)
    assert root.find("CoSimulation") is None and root.find("ModelExchange") is None
    assert root.find("ScheduledExecution").get("modelIdentifier") == "BacksteppingController"
    (clock,) = root.findall("ModelVariables/Clock")
    assert (clock.get("causality"), clock.get("variability"), clock.get("intervalVariability")) == (
        "input", "discrete", "constant")
    assert float(clock.get("intervalDecimal")) == TS
    cs = ET.fromstring(zipfile.ZipFile(fmus.paths(fmu_dir, "native-fmi3")[1]).read("modelDescription.xml"))
    assert float(cs.find("CoSimulation").get("fixedInternalStepSize")) == TS  # the same period, both ways
    ports = [v for v in root.find("ModelVariables")
             if v.get("causality") in ("input", "output") and v.tag != "Clock"]
    assert ports and all(v.get("clocks") == clock.get("valueReference") for v in ports)
    assert all(v.get("variability") == "discrete" for v in ports)
    # the same variables as the co-simulation controller, with the same value references, plus the clock
    names = {(v.get("name"), v.get("valueReference")) for v in cs.find("ModelVariables")}
    assert {(v.get("name"), v.get("valueReference")) for v in root.find("ModelVariables")} == (
        names | {(clocked.CLOCK, clock.get("valueReference"))})


def _scenario(name, stop):
    """The scenario ``name`` over [0, stop], every output recorded at every step (as ramp_rated_load)."""
    every_step = load_scenario(ROOT / "scenarios" / "ramp_rated_load.yaml").record
    sc = dataclasses.replace(load_scenario(ROOT / "scenarios" / f"{name}.yaml"), stop_time=stop,
                             record=every_step)
    assert sc.step == TS and sc.controller_every == 1 and sc.algorithm == "gauss-seidel"
    return sc


def _clocked_loop(fmu_dir, path, frame):
    """Gauss-Seidel, as the master: at t_k = k Ts the controller's inputs are the plant's outputs and the
    profiles (the master's record ``frame``), its clock is activated at t_k, its voltages go to the native
    FMI 3.0 plant, which steps over [t_k, t_k + Ts].  Returns the plant outputs at every t_k and the
    controller's Float64 outputs after each activation, with their names."""
    pp = fmus.paths(fmu_dir, "native-fmi3")[0]
    pmd = read_model_description(str(pp))
    plant = FMU3Slave(guid=pmd.guid, unzipDirectory=extract(str(pp)),
                      modelIdentifier=pmd.coSimulation.modelIdentifier, instanceName="plant")
    plant.instantiate()
    plant.enterInitializationMode(startTime=0.0)
    plant.exitInitializationMode()
    pvr = {v.name: v.valueReference for v in pmd.modelVariables}
    ctrl = Clocked(path)
    ctrl.start()
    p_names = [c.split(".", 1)[1] for c in frame.columns if c.startswith("plant.")]
    c_names = [c.split(".", 1)[1] for c in frame.columns if c.startswith("controller.")
               and c.split(".", 1)[1] not in FLAGS]
    p_vr, c_vr = [pvr[n] for n in p_names], [ctrl.vr[n] for n in c_names]
    c_in = [ctrl.vr[n] for n in (*MEASURED, *PROFILES)]
    prof = {p: frame[f"profile.{p}"].to_numpy() for p in PROFILES}
    p_in = [pvr["v_s_alpha"], pvr["v_s_beta"], pvr["T_load"]]
    plant_rows, ctrl_rows = [], []
    n = len(frame) - 1
    for k in range(n + 1):
        t = k * TS
        y = dict(zip(p_names, plant.getFloat64(p_vr)))
        plant_rows.append([y[m] for m in p_names])
        if k == n:
            break
        ctrl.fmu.setFloat64(c_in, [y[m] for m in MEASURED] + [prof[p][k] for p in PROFILES])
        ctrl.activate(t)
        out = dict(zip(c_names, ctrl.fmu.getFloat64(c_vr)))
        ctrl_rows.append([out[m] for m in c_names])
        plant.setFloat64(p_in, [out["v_s_alpha"], out["v_s_beta"], prof["T_load"][k]])
        plant.doStep(t, TS)
    assert not [m for m in ctrl.log if m[0] > 0], ctrl.log
    ctrl.close()
    plant.terminate()
    plant.freeInstance()
    return np.array(plant_rows), p_names, np.array(ctrl_rows), c_names


@pytest.mark.parametrize("scenario", ["ramp_rated_load", "speed_reversal"])
def test_the_clocked_closed_loop_is_the_co_simulation_closed_loop_bit_for_bit(fmu_dir, fmu, scenario):
    """0.3 s: pre-magnetization, the switch to the law (~0.11 s), the start of the ramp; the master runs
    the co-simulation controller (native FMI 3.0, a doStep of Ts at each t_k)."""
    res = run(_scenario(scenario, 0.3), *map(str, fmus.paths(fmu_dir, "native-fmi3")))
    assert res.ok, res.message
    frame = res.frame
    plant, p_names, ctrl, c_names = _clocked_loop(fmu_dir, fmu, frame)
    cs_plant = np.column_stack([frame[f"plant.{n}"].to_numpy() for n in p_names])
    cs_ctrl = np.column_stack([frame[f"controller.{n}"].to_numpy() for n in c_names])
    assert plant.shape == cs_plant.shape and ctrl.shape == cs_ctrl[:-1].shape
    # the master records the controller's outputs of the step taken at t_k on row k
    dp, dc = np.max(np.abs(plant - cs_plant)), np.max(np.abs(ctrl - cs_ctrl[:-1]))
    print(f"{scenario}: clocked controller (fmpy FMU3ScheduledExecution) vs the master's co-simulation loop, "
          f"{len(frame)} rows: plant outputs max |difference| {dp}, controller outputs {dc}")
    assert np.array_equal(plant, cs_plant) and np.array_equal(ctrl, cs_ctrl[:-1])
    assert frame["controller.phase"].iloc[-1] == 1 and frame["controller.phase"].iloc[0] == 0  # the law ran
    assert np.max(np.abs(cs_ctrl[:, c_names.index("v_s_alpha")])) > 10.0


def test_the_interval_is_read_through_the_api(fmu):
    c = Clocked(fmu)
    c.start()
    vr = (fmi3ValueReference * 1)(c.clock)
    intervals, qualifiers = (c_double * 1)(), (c_int * 1)()
    c.fmu.getIntervalDecimal(vr, intervals, qualifiers)
    assert (intervals[0], qualifiers[0]) == (TS, fmi3IntervalUnchanged)
    c.close()


def _error(c, call, *args):
    with pytest.raises(FMICallException, match="status 3"):
        call(*args)
    return c.log[-1][1]


def test_an_activation_off_the_clock_or_of_another_clock_is_refused_and_changes_nothing(fmu):
    c = Clocked(fmu)
    c.start()
    c.fmu.setFloat64([c.vr["psi_ref"]], [0.9])
    assert "is not the clock's next tick 0 s" in _error(c, c.activate, 2e-4)
    assert "value reference 3 is not a clock" in _error(
        c, c.fmu.fmi3ActivateModelPartition, c.fmu.component, 3, 0.0)
    c.activate(0.0)
    first = c.fmu.getFloat64([c.vr["v_s_alpha"], c.vr["v_s_beta"]])
    assert "is not the clock's next tick 0.0001 s" in _error(c, c.activate, 0.0)
    assert "is not the clock's next tick" in _error(c, c.activate, 3e-4)
    assert c.fmu.getFloat64([c.vr["v_s_alpha"], c.vr["v_s_beta"]]) == first
    c.activate(1e-4)
    c.activate(2e-4)
    refused = _error(c, c.fmu.fmi3DoStep, c.fmu.component, 3e-4, TS, False, None, None, None, None)
    assert "a Scheduled Execution FMU is not stepped" in refused
    c.close()


def test_a_sample_period_other_than_the_clocks_interval_is_refused(fmu):
    c = Clocked(fmu)
    with pytest.raises(FMICallException, match="status 3"):
        c.start(Ts=2e-4)
    assert any("the sample period 0.00020000000000000001 s differs from the constant interval 0.0001 s" in m
               for _, m in c.log), c.log
    c.fmu.freeInstance()


def test_a_non_finite_input_is_a_discard(fmu):
    c = Clocked(fmu)
    c.start()
    c.fmu.setFloat64([c.vr["i_s_alpha"]], [float("nan")])
    with pytest.raises(FMICallException, match="status 2"):
        c.activate(0.0)
    assert "i_s_alpha" in c.log[-1][1] and c.log[-1][0] == 2
    c.close()


def test_co_simulation_is_refused(fmu):
    md = read_model_description(str(fmu))
    log = []
    slave = FMU3Slave(guid=md.guid, unzipDirectory=extract(str(fmu)),
                      modelIdentifier="BacksteppingController", instanceName="cs")
    with pytest.raises(Exception, match="Failed to instantiate"):
        slave.instantiate(logMessage=lambda env, status, cat, msg: log.append(msg.decode()))
    assert "Scheduled Execution only" in log[-1]
