"""The two FMUs (built once by build_fmus.build_all) against the FMI checkers, their contract, and
the plain-Python units and closed loop they wrap (satmotor.interface, satmotor.simulate)."""

from __future__ import annotations

import functools
import html
import json
import math
import re
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.validation import validate_fmu
from fmu_helpers import (
    SIM_START,
    SIM_STEPS,
    STATE_INPUTS,
    STATE_STEPS,
    Slave,
    open_fmu,
    tamper_fingerprint,
)

from satmotor.control.backstepping import BacksteppingGains, ControllerConfig
from satmotor.control.drive import PREMAG, RUN, DriveConfig
from satmotor.interface import (
    CONTROLLER_PARAMETERS,
    PLANT_PARAMETERS,
    ControllerUnit,
    PlantUnit,
    motor_params,
)
from satmotor.machine.magnetics import PolynomialCurve
from satmotor.machine.params import MotorParams, RatedData
from satmotor.simulate import RampScenario

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
import build_fmus  # noqa: E402

HELPERS = Path(__file__).with_name("fmu_helpers.py")
H = 1e-4  # communication step = controller Ts [s]
PLANT_IN = ("v_s_alpha", "v_s_beta", "T_load")
PLANT_OUT = ("i_s_alpha", "i_s_beta", "psi_s_alpha", "psi_s_beta", "psi_r_alpha", "psi_r_beta", "omega_m",
             "theta_m", "T_e", "i_mu", "v_dc", "E_regen", "E_chop", "dc_fault",  # the DC link
             "P_fe", "T_s", "T_r",  # then the losses
             "v_avg_alpha", "v_avg_beta",  # then the inverter's
             # issue 35: every loss
             "P_cu_s", "P_cu_r", "P_fw", "P_stray", "P_inv", "P_chop", "P_in", "P_mech")
DC_LINK = ("dc_link", "V_dc", "C_dc", "dc_source", "R_src", "V_grid", "f_grid", "V_chop_on", "V_chop_off",
           "R_chop", "V_dc_max")
# issue 19: core loss and the thermal model (plant only)
LOSS_THERMAL = ("R_fe", "thermal", "T_amb", "T_s0", "T_r0", "T_ref", "alpha_s", "alpha_r", "C_th_s", "C_th_r",
                "R_th_s", "R_th_r", "R_th_sr")
INVERTER = ("inverter", "f_sw", "t_dead", "v_on")  # the link voltage: the DC link's V_dc
LOSSES = ("T_fric", "k_wind", "k_stray", "E_sw", "V_sw_ref", "I_sw_ref")  # issue 35
MOTOR = ("R_s", "R_r", "l_s", "l_r", "k", "n_p", "J", "B", "curve", "L_m0", "L_m_inf", "I_par", "poly_b",
         "poly_n", "table_file")
CTRL_IN = ("i_s_alpha", "i_s_beta", "psi_r_alpha", "psi_r_beta", "psi_s_alpha", "psi_s_beta", "omega_m",
           "omega_ref", "psi_ref", "T_load", "v_dc")
CTRL_OUT = ("v_s_alpha", "v_s_beta", "v_sd", "v_sq", "e1", "e2", "z1", "z2", "W", "T_load_est",
            "psi_r_hat_alpha", "psi_r_hat_beta", "omega_ref_shaped", "psi_ref_shaped", "phase",
            "voltage_limited", "current_limited", "singular_limited", "omega_m_hat", "R_s_hat", "R_r_hat")
PREMAG_PARAMS = ("premag_fraction", "premag_min_fraction", "premag_speed_tol", "premag_time_max",
                 "premag_boost", "premag_gain")
CONTRACT = {
    "SaturatedInductionMotor": {"input": PLANT_IN, "output": PLANT_OUT,
                                "parameter": MOTOR + ("B_2", "omega_m0", "psi_r0", "h_int", "max_substeps",
                                                      "v_warn", "i_warn", "omega_warn")
                                 + DC_LINK + LOSS_THERMAL + INVERTER + LOSSES},
    "BacksteppingController": {"input": CTRL_IN, "output": CTRL_OUT, "parameter": (
        "c1", "c2", "d1", "d2", "Ts", "mode", "load_mode", "V_dc", "ref_bandwidth", "g_theta", "theta_max",
        "I_max", "use_stator_flux", "c0", "d0", "flux_source", "delay_samples", "observer",
        "speed_source", "field_weakening", "fw_voltage_ratio") + PREMAG_PARAMS + MOTOR
        + ("current_limit_gain", "host_delay_samples", "deadtime_comp_voltage", "max_samples", "flux_mode",
           "flux_floor", "flux_rate_max", "loss_R_fe", "rs_adaptation", "rr_tracking", "modulation")},
}
UNITS = {"V": "v_s_alpha v_s_beta v_sd v_sq V_dc v_warn v_dc V_grid V_chop_on V_chop_off V_dc_max "
              "v_avg_alpha v_avg_beta v_on deadtime_comp_voltage",
         "A": "i_s_alpha i_s_beta i_mu I_par I_max i_warn",
         "J": "E_regen E_chop", "F": "C_dc", "Hz": "f_grid f_sw",
         "Wb": "psi_s_alpha psi_s_beta psi_r_alpha psi_r_beta psi_ref psi_r0 e1 psi_r_hat_alpha "
               "psi_r_hat_beta "
               "psi_ref_shaped flux_floor", "Wb/s": "e2", "V s/s": "flux_rate_max",
         "rad/s": "omega_m omega_ref omega_m0 z1 ref_bandwidth omega_ref_shaped omega_m_hat premag_speed_tol "
                  "omega_warn",
         "rad": "theta_m",
         "rad/s2": "z2 theta_max",
         "N m": "T_load T_e T_load_est", "Ohm": "R_s R_r premag_gain R_src R_chop R_s_hat R_r_hat",
         "H": "l_s l_r L_m0 L_m_inf",
         "1": "k W delay_samples max_samples fw_voltage_ratio premag_fraction premag_min_fraction "
              "premag_boost host_delay_samples dc_fault",
         "kg m2": "J", "N m s": "B", "A/Wb^n": "poly_b", "s": "h_int Ts premag_time_max t_dead",
         "1/s": "c1 c2 d1 d2 current_limit_gain",
         "1/s2": "g_theta c0 d0", "N m s2/rad2": "B_2",
         "W": "P_fe", "K": "T_s T_r T_amb T_s0 T_r0 T_ref", "1/K": "alpha_s alpha_r", "J/K": "C_th_s C_th_r",
         "K/W": "R_th_s R_th_r R_th_sr"}
UNITS["Ohm"] += " R_fe loss_R_fe"
UNITS["W"] += " P_cu_s P_cu_r P_fw P_stray P_inv P_chop P_in P_mech"  # issue 35
UNITS["N m"] += " T_fric"
UNITS["N m s2/rad2"] += " k_wind"
UNITS["N m s/(A2 rad)"] = "k_stray"
UNITS["J"] += " E_sw"
UNITS["V"] += " V_sw_ref"
UNITS["A"] += " I_sw_ref"
UNIT_OF = {name: unit for unit, names in UNITS.items() for name in names.split()}


def _defaults():
    m, g, c, d = MotorParams(), BacksteppingGains(), ControllerConfig(), DriveConfig()
    poly = PolynomialCurve()
    motor = {n: getattr(m, n) for n in MOTOR[:8]}
    motor |= {n: getattr(m.curve, n) for n in ("L_m0", "L_m_inf", "I_par")}
    motor |= {"curve": m.curve.name, "poly_b": poly.poly_b, "poly_n": poly.poly_n, "table_file": ""}
    ctrl = motor | {n: getattr(g, n) for n in ("c1", "c2", "d1", "d2", "c0", "d0")} | {
        n: getattr(c, n) for n in ("Ts", "V_dc", "load_mode", "g_theta", "theta_max")} | {
        "ref_bandwidth": d.ref_bandwidth, "I_max": d.I_max, "mode": "saturated",
        "use_stator_flux": c.use_stator_flux, "flux_source": d.flux_source, "delay_samples": d.delay_samples,
        "observer": d.observer, "speed_source": d.speed_source,
        "field_weakening": d.field_weakening} | {
        n: getattr(d, n) for n in ("fw_voltage_ratio", "current_limit_gain", "host_delay_samples",
                                   "rs_adaptation", "rr_tracking") + PREMAG_PARAMS} | {
        "deadtime_comp_voltage": 0.0}
    # bounded work per doStep: 10^5 samples (10 s at the default Ts), as the plant's max_substeps
    ctrl |= {"max_samples": 100000}
    # the nominal flux set-point (today's); the loss minimizer's floor 0.25 Wb, rate 5 V s/s, copper only
    ctrl |= {"flux_mode": "nominal", "flux_floor": 0.25, "flux_rate_max": 5.0, "loss_R_fe": 0.0}
    # the voltage limited to the modulator's linear range, |v_s| <= V_dc / sqrt(3) (today's)
    ctrl |= {"modulation": "linear"}
    # at rest, unmagnetized (closed_loop's x0); one RK4 step per sample (closed_loop's n_sub = 1)
    plant = motor | {"B_2": 0.0, "omega_m0": 0.0, "psi_r0": 0.0, "h_int": c.Ts}
    # bounded work per doStep and the plausibility bounds: 4 V_dc, 10 I_max, about 10 x 157 rad/s
    plant |= {"max_substeps": 50000, "v_warn": 4 * c.V_dc, "i_warn": 10 * d.I_max, "omega_warn": 1500.0}
    # the DC link: off (ideal), at the controller's V_dc; the capacitor's settings (docs/model.md)
    plant |= {"dc_link": "ideal", "V_dc": c.V_dc, "C_dc": 470e-6, "dc_source": "dc", "R_src": 0.1,
              "V_grid": 400.0, "f_grid": 50.0, "V_chop_on": 750.0, "V_chop_off": 720.0, "R_chop": 0.0,
              "V_dc_max": 800.0}
    # no core loss, thermal model off, 20 C; copper and aluminium; the default motor's thermal estimate
    plant |= {"R_fe": 0.0, "thermal": False, "T_amb": 293.15, "T_s0": 293.15, "T_r0": 293.15, "T_ref": 293.15,
              "alpha_s": 3.93e-3, "alpha_r": 4.03e-3, "C_th_s": 6000.0, "C_th_r": 2200.0, "R_th_s": 0.2,
              "R_th_r": 0.5, "R_th_sr": 0.15}
    # the average-value inverter (today's plant); the pwm settings' defaults: 5 kHz, no dead time or drops
    plant |= {"inverter": "average", "f_sw": 5000.0, "t_dead": 0.0, "v_on": 0.0}
    # no friction, windage, stray or switching loss (issue 35); the switching references 600 V, 10 A
    plant |= {"T_fric": 0.0, "k_wind": 0.0, "k_stray": 0.0, "E_sw": 0.0, "V_sw_ref": 600.0, "I_sw_ref": 10.0}
    return {"SaturatedInductionMotor": plant, "BacksteppingController": ctrl}


DEFAULTS = _defaults()


def _typed(var, text):
    if var.type == "Boolean":
        return str(text).lower() in ("true", "1")
    return {"Real": float, "Integer": int}.get(var.type, str)(text)


def _child(*args):
    r = subprocess.run([sys.executable, str(HELPERS), *map(str, args)], capture_output=True, text=True,
                       timeout=120, cwd=HELPERS.parent)
    return r.returncode, r.stdout.strip().splitlines()[-1] if r.stdout.strip() else "", r.stderr


@pytest.fixture(scope="module")
def fmus(fmu_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("unzipped")
    return {p.stem: open_fmu(p, out / p.stem) for p in sorted(Path(fmu_dir).glob("*.fmu"))}


@pytest.fixture(scope="module")
def repeat_check(fmus):
    """Instantiating the same FMU several times in one process, checked in a child first: a
    crash there must fail these tests, not kill the pytest process."""
    return _child("repeat", *(f.path for f in fmus.values()))


@pytest.fixture
def new(fmus, repeat_check):
    """Factory: ``new(name, params)`` -> initialized Slave, freed after the test."""
    if repeat_check[0] != 0:
        pytest.fail(f"not run in-process: instantiating an FMU repeatedly failed in a child: {repeat_check}")
    made = []

    def make(name, params=None, **kw):
        made.append(Slave(fmus[name], f"{name[:5]}{len(made)}", params, **kw))
        return made[-1]
    yield make
    for s in made:
        if not s.dead:
            s.free()


# --- plain-Python references -------------------------------------------------------------------------

def dol_inputs(k):
    """Direct-on-line start at rated voltage, rated load from 0.2 s, sampled at t_k = k H."""
    r, t = RatedData(), k * H
    return {"v_s_alpha": r.V_phase_peak * math.cos(r.omega_e * t), "v_s_beta": r.V_phase_peak *
            math.sin(r.omega_e * t), "T_load": r.T_n if k >= 2000 else 0.0}


@functools.cache
def plant_reference(n=3000):
    """PlantUnit outputs at t_0 .. t_n of the DOL start (inputs held over each step)."""
    unit, rows = PlantUnit({}), []
    for k in range(n + 1):
        rows.append(dict(zip(PlantUnit.OUTPUTS, unit.outputs())))
        if k < n:
            unit.step(k * H, H, tuple(dol_inputs(k)[v] for v in PLANT_IN))
    return {name: np.array([r[name] for r in rows]) for name in PLANT_OUT}


@functools.cache
def ramp_run(params=()):
    """Plain closed loop of the ramp scenario with the drive ControllerUnit(params) builds."""
    drive = ControllerUnit(dict(params)).drive
    return RampScenario(t_end=0.4, t_ramp=0.15, t_load=0.3).run(MotorParams(), drive)


def ctrl_inputs(rec, k):
    meas = {n: rec[n][k] for n in CTRL_IN[:7]}
    return meas | {"omega_ref": rec["omega_ref"][k], "psi_ref": rec["psi_ref"][k], "T_load": rec["T_load"][k],
                   "v_dc": 0.0}  # the link voltage: not connected


def rel_err(got, ref, names):
    """Largest |got - ref| over all samples, relative to max |ref|, over the variables ``names``
    (``ref`` keyed by the plain loop's names)."""
    def r(n):
        want = np.asarray(ref[n], dtype=float)
        return np.max(np.abs(np.asarray(got[n], dtype=float) - want)) / max(np.max(np.abs(want)), 1e-300)
    return max(r(n) for n in names)


def run_plant(s, k0, k1):
    out = []
    for k in range(k0, k1):
        s.step(k * H, H, dol_inputs(k))
        out.append(s.get(PLANT_OUT))
    return out


def run_ctrl(s, k0, k1, rec):
    out = []
    for k in range(k0, k1):
        s.step(k * H, H, ctrl_inputs(rec, k))
        out.append(s.get(CTRL_OUT))
    return out


# --- 1-4: checkers, contract, reproducibility, documentation ----------------------------------------

@pytest.mark.parametrize("name", list(CONTRACT))
def test_fmpy_validation_and_fmutool_check_pass(fmus, name):
    from fmu_manipulation_toolbox.assistant.fmutools import check_fmu

    assert validate_fmu(fmus[name].path) == []
    report = check_fmu(Path(fmus[name].path))
    assert report["compliant"] and report["error_count"] == 0, report


@pytest.mark.parametrize("name", list(CONTRACT))
def test_model_description_matches_the_contract(fmus, name):
    md = fmus[name].md
    by_causality = {c: {v.name for v in md.modelVariables if v.causality == c} for c in CONTRACT[name]}
    assert by_causality == {c: set(names) for c, names in CONTRACT[name].items()}
    assert len(md.modelVariables) == sum(map(len, CONTRACT[name].values()))
    for v in md.modelVariables:
        if v.type == "Real":
            assert v.description.endswith(f"[{UNIT_OF[v.name]}]"), (v.name, v.description)
        if v.causality == "parameter":
            assert _typed(v, v.start) == DEFAULTS[name][v.name], v.name
    integers = {"n_p", "poly_n"} | ({"delay_samples", "phase", "host_delay_samples", "max_samples"}
                                    if name == "BacksteppingController" else {"max_substeps"})
    assert {v.name for v in md.modelVariables if v.type == "Integer"} == integers
    booleans = {"use_stator_flux", "voltage_limited", "current_limited", "singular_limited",
                "field_weakening", "rs_adaptation", "rr_tracking"}
    assert {v.name for v in md.modelVariables if v.type == "Boolean"} == (
        booleans if name == "BacksteppingController" else {"thermal"})
    cs = md.coSimulation
    assert cs.canGetAndSetFMUstate and cs.canSerializeFMUstate
    assert cs.canHandleVariableCommunicationStepSize == (name == "SaturatedInductionMotor")


@pytest.mark.slow
def test_two_builds_are_byte_identical(fmus, fmu_dir, tmp_path):
    """Every FMU of a second build (pythonfmu, native FMI 2.0 and 3.0 co-simulation, the model-exchange
    plant in both versions, the clocked FMI 3.0 controller, for this machine, as the session's) has the
    same bytes as the first build's.  (The cross-compiles: tests/test_native_glue.py.)"""
    built = build_fmus.build_all(tmp_path / "again")
    assert len(built) == 9
    for p in built:
        first = Path(fmu_dir) / p.relative_to(tmp_path / "again")
        with zipfile.ZipFile(p) as a, zipfile.ZipFile(first) as b:
            assert a.read("modelDescription.xml") == b.read("modelDescription.xml")
        assert p.read_bytes() == first.read_bytes(), p
    for p in built[:2]:
        assert open_fmu(p, tmp_path / p.stem).md.guid == fmus[p.stem].md.guid


@pytest.mark.parametrize("name", list(CONTRACT))
def test_documentation_lists_every_variable_with_its_default(fmus, name):
    with zipfile.ZipFile(fmus[name].path) as z:
        doc = z.read("documentation/index.html").decode()
    rows = {}
    for row in re.findall(r"<tr>(<td>.*?)</tr>", doc):
        cells = [html.unescape(c) for c in re.findall(r"<td>(.*?)</td>", row)]
        rows[cells[0]] = cells
    assert set(rows) == {v.name for v in fmus[name].md.modelVariables}
    for v in fmus[name].md.modelVariables:
        assert rows[v.name][1] == v.causality, v.name
        if v.start is None:  # initial="calculated" (the plant's outputs)
            assert v.initial == "calculated" and rows[v.name][3] == "calculated", v.name
        else:
            assert _typed(v, rows[v.name][3]) == _typed(v, v.start), v.name
        if v.causality == "parameter":
            assert _typed(v, rows[v.name][3]) == DEFAULTS[name][v.name], v.name


# --- 5-6: standalone FMUs against the plain-Python units ------------------------------------------

def test_plant_fmu_matches_plant_unit_low_level_and_simulate_fmu(fmus, new):
    ref = plant_reference()
    s = new("SaturatedInductionMotor")
    rows = [s.get(PLANT_OUT)] + run_plant(s, 0, 3000)
    low = dict(zip(PLANT_OUT, np.array(rows).T))
    assert ref["omega_m"][-1] > 100.0 and abs(ref["T_e"][-1]) > 10.0  # a real start, loaded
    # simulate_fmu applies inputs at each communication point, interpolating the table linearly:
    # given on the exact communication grid t_k = k H they are the held values of the reference
    sig = np.array([(k * H, *(dol_inputs(k)[v] for v in PLANT_IN)) for k in range(3001)],
                   dtype=[("time", float)] + [(v, float) for v in PLANT_IN])
    res = simulate_fmu(fmus["SaturatedInductionMotor"].path, start_time=0.0, stop_time=0.3, output_interval=H,
                       input=sig, output=list(PLANT_OUT))
    assert len(res) == 3001 and np.allclose(res["time"], np.arange(3001) * H, rtol=0, atol=1e-12)
    err_low, err_sim = rel_err(low, ref, PLANT_OUT), rel_err(res, ref, PLANT_OUT)
    print(f"plant: max rel diff low-level {err_low:.3g}, simulate_fmu {err_sim:.3g}")
    assert err_low <= 1e-9 and err_sim <= 1e-9


@pytest.mark.parametrize("params", [(), (("mode", "pi"),), (("load_mode", "estimated"),),
                                    (("use_stator_flux", True),)])
def test_controller_fmu_reproduces_the_plain_closed_loop_voltages(new, params):
    rec = ramp_run(params)
    assert set(rec["phase"]) == {PREMAG, RUN}  # pre-magnetization, switch and the law are all covered
    s = new("BacksteppingController", dict(params))
    got = dict(zip(CTRL_OUT, np.array(run_ctrl(s, 0, len(rec["t"]), rec)).T))
    err = rel_err(got, rec, CTRL_OUT)
    print(f"controller {dict(params)}: max rel diff {err:.3g}")
    assert err <= 1e-9


def test_controller_fmu_under_simulate_fmu_matches_the_plain_loop(fmus):
    """fmpy.simulate_fmu with the plain loop's measurements as the input table (on the grid):
    the output row after doStep(t_k, Ts) is the plain loop's sample k."""
    rec = ramp_run()
    n = len(rec["t"])
    sig = np.array([(k * H, *ctrl_inputs(rec, k).values()) for k in range(n)],
                   dtype=[("time", float)] + [(v, float) for v in CTRL_IN])
    res = simulate_fmu(fmus["BacksteppingController"].path, start_time=0.0, stop_time=(n - 1) * H,
                       output_interval=H, input=sig, output=list(CTRL_OUT))
    got = {v: res[v][1:] for v in CTRL_OUT}
    ref = {v: np.asarray(rec[v][: n - 1]) for v in CTRL_OUT}
    err = rel_err(got, ref, CTRL_OUT)
    print(f"controller simulate_fmu: max rel diff {err:.3g}")
    assert err <= 1e-9


# --- 7: FMU state ------------------------------------------------------------------------------------

def _replays(s, run, n, m):
    """Run n steps, save the state, run m steps: on, again without restoring, after setFMUState,
    after deserialization.  Returns the four output lists."""
    run(s, 0, n)
    state = s.fmu.getFMUState()
    blob = s.fmu.serializeFMUState(state)
    first = run(s, n, n + m)
    unrestored = run(s, n, n + m)
    s.fmu.setFMUState(state)
    second = run(s, n, n + m)
    restored = s.fmu.deSerializeFMUstate(blob)
    s.fmu.setFMUState(restored)
    third = run(s, n, n + m)
    s.fmu.freeFMUState(state)
    s.fmu.freeFMUState(restored)
    return first, second, third, unrestored


def test_plant_state_get_set_and_serialize_replay_bit_identically(new):
    first, second, third, unrestored = _replays(new("SaturatedInductionMotor"), run_plant, 1900, 200)
    assert first == second == third  # the load step at 2000 is inside the window
    assert unrestored != first


def test_controller_state_replays_bit_identically_across_the_premag_switch(new):
    rec = ramp_run()
    n, m = 1100, 100
    assert rec["phase"][n] == PREMAG and rec["phase"][n + m] == RUN
    first, second, third, unrestored = _replays(new("BacksteppingController"),
                                                functools.partial(run_ctrl, rec=rec), n, m)
    assert first == second == third
    # Setting the registered variables again (the inputs; pythonfmu's default FMU state holds nothing else)
    # is not enough: the drive's hidden state (phase, shapers, law) stayed in run mode, so the window
    # replayed without setFMUState differs from the start of the window on.
    assert unrestored[0] != first[0]


# --- 8-9: bad parameters and bad inputs ---------------------------------------------------------------

BAD_PARAMETERS = [
    ("SaturatedInductionMotor", {"R_s": -1.0}), ("SaturatedInductionMotor", {"curve": "tanh"}),
    ("SaturatedInductionMotor", {"n_p": 0}), ("SaturatedInductionMotor", {"L_m_inf": 0.5}),
    ("SaturatedInductionMotor", {"curve": "table", "table_file": ""}),
    ("SaturatedInductionMotor", {"curve": "table", "table_file": "/nonexistent/no_load.csv"}),
    ("BacksteppingController", {"mode": "fuzzy"}), ("BacksteppingController", {"c1": 0.0}),
    ("BacksteppingController", {"R_s": -1.0}),
]


def test_bad_parameters_are_refused_at_initialization_naming_the_value(new):
    """pythonfmu cannot return fmi2Error from Python, and an exception would be fmi2Fatal (after which
    freeing the instance crashed the host): exitInitializationMode logs the refusal (status error)
    and returns fmi2OK; every doStep then discards, naming it; the instance can be freed."""
    for name, params in BAD_PARAMETERS:
        s = new(name, initialize=False)
        s.set(params)
        s.fmu.setupExperiment(startTime=0.0)
        s.fmu.enterInitializationMode()
        s.fmu.exitInitializationMode()
        bad, value = list(params.items())[-1]
        log = s.messages(min_status=3)
        assert f"{bad} = {value!r}" in log and "bad parameter" in log, (params, s.log)
        for k in range(2):
            with pytest.raises(FMICallException) as exc:
                s.fmu.doStep(k * H, H)
            assert exc.value.status == 2, params
            assert "exitInitializationMode refused its parameters" in s.messages(min_status=3), s.log
    s = new("SaturatedInductionMotor")  # the host goes on: a fresh instance runs
    assert np.array(run_plant(s, 0, 20))[-1].tolist() == [plant_reference()[n][20] for n in PLANT_OUT]


# every String parameter with a closed set of values (satmotor.interface Variable.choices), by unit
CHOICE_PARAMETERS = [(unit, v.name, v.choices) for unit, table in (
    ("SaturatedInductionMotor", PLANT_PARAMETERS), ("BacksteppingController", CONTROLLER_PARAMETERS))
    for v in table if v.choices]


@pytest.mark.parametrize("name, parameter, choices", CHOICE_PARAMETERS,
                         ids=[f"{u[:5]}-{n}" for u, n, _ in CHOICE_PARAMETERS])
def test_a_string_parameter_outside_its_choices_is_refused_naming_them(new, name, parameter, choices):
    """An unknown text (a near miss: another case) refused at initialization, the log naming the
    parameter, the value and every allowed value, in the table's order."""
    s = new(name, initialize=False)
    bad = choices[-1].capitalize()
    s.set({parameter: bad})
    s.fmu.setupExperiment(startTime=0.0)
    s.fmu.enterInitializationMode()
    s.fmu.exitInitializationMode()
    log = s.messages(min_status=3)
    assert f"{parameter} = {bad!r}: must be one of {', '.join(choices)}" in log, s.log


def test_non_finite_input_is_discarded_with_a_message_and_the_step_can_be_redone(new):
    s, unit = new("SaturatedInductionMotor"), PlantUnit({})
    run_plant(s, 0, 5)
    s.set({"v_s_alpha": math.nan})
    with pytest.raises(FMICallException) as exc:
        s.fmu.doStep(5 * H, H)
    assert exc.value.status == 2 and "v_s_alpha = nan" in s.messages(min_status=2)
    for k in range(6):
        unit.step(k * H, H, tuple(dol_inputs(k)[v] for v in PLANT_IN))
    assert run_plant(s, 5, 6)[0] == list(unit.outputs())  # the discarded step left the state alone


def test_controller_discards_infinite_set_point_and_wrong_step(new):
    s = new("BacksteppingController")
    rec = ramp_run()
    s.set(ctrl_inputs(rec, 0) | {"psi_ref": math.inf})
    with pytest.raises(FMICallException) as exc:
        s.fmu.doStep(0.0, H)
    assert exc.value.status == 2 and "psi_ref = inf" in s.messages(min_status=2)
    s.set({"psi_ref": rec["psi_ref"][0]})
    with pytest.raises(FMICallException) as exc:
        s.fmu.doStep(0.0, 1.5 * H)
    assert exc.value.status == 2
    assert "communicationStepSize = 0.00015000000000000001" in s.messages(min_status=2)
    assert run_ctrl(s, 0, 3, rec) == [[rec[n][k] for n in CTRL_OUT] for k in range(3)]


# --- 10: two closed loops in one process, reset -------------------------------------------------------

def test_two_interleaved_closed_loops_match_their_plain_loops_and_reset_replays(new):
    scen, n = RampScenario(t_end=0.25, t_ramp=0.12, t_load=0.2), 2500
    params = [{}, {"J": 0.02, "R_r": 1.5}]
    pairs = [(new("BacksteppingController", p), new("SaturatedInductionMotor", p)) for p in params]
    got = [{"y": [], "v": []} for _ in pairs]
    for k in range(n + 1):
        t = k * H
        for (ctrl, plant), g in zip(pairs, got):
            y = dict(zip(PLANT_OUT, plant.get(PLANT_OUT)))
            ctrl.step(t, H, {c: y[c] for c in CTRL_IN[:7]} | {
                "omega_ref": scen.omega_ref(t), "psi_ref": scen.psi_ref, "T_load": scen.load(t)})
            v = ctrl.get(("v_s_alpha", "v_s_beta"))
            g["y"].append(y)
            g["v"].append(v)
            if k < n:
                plant.step(t, H, {"v_s_alpha": v[0], "v_s_beta": v[1], "T_load": scen.load(t)})
    for p, g in zip(params, got):
        ref = scen.run(motor_params(p), ControllerUnit(p).drive)
        fmu = {name: [y[name] for y in g["y"]] for name in PLANT_OUT} | dict(zip(PLANT_IN[:2], zip(*g["v"])))
        err = rel_err(fmu, ref, PLANT_OUT[:PLANT_OUT.index("v_dc")] + PLANT_IN[:2])  # the closed loop's keys
        print(f"closed loop {p}: max rel diff {err:.3g}")
        assert err <= 1e-9 and ref["omega_m"][-1] > 5.0
    assert got[0]["y"][-1]["omega_m"] != got[1]["y"][-1]["omega_m"]  # J differs: the instances are separate
    plant, g = pairs[1][1], got[1]
    plant.fmu.reset()
    assert plant.get(["J"]) == [DEFAULTS["SaturatedInductionMotor"]["J"]]  # reset: back to the start values
    plant.initialize(params[1])
    replay = [plant.get(PLANT_OUT)]
    for k in range(n):
        v_a, v_b = g["v"][k]
        plant.step(k * H, H, {"v_s_alpha": v_a, "v_s_beta": v_b, "T_load": scen.load(k * H)})
        replay.append(plant.get(PLANT_OUT))
    assert replay == [[y[name] for name in PLANT_OUT] for y in g["y"]]


# --- 11: bundle check ---------------------------------------------------------------------------------

def test_same_fmu_instantiates_repeatedly_in_one_process(repeat_check):
    assert repeat_check[0] == 0, repeat_check


def test_plant_with_another_fingerprint_refuses_to_instantiate(fmus, tmp_path):
    tampered = tmp_path / "SaturatedInductionMotor.fmu"
    tamper_fingerprint(fmus["SaturatedInductionMotor"].path, tampered)
    rc, out, err = _child("tamper", tampered, fmus["BacksteppingController"].path)
    assert rc == 0, err
    res = json.loads(out)
    assert not res["instantiated"] and res["error"] and res["alive"]  # refused; the process ran on
    assert "fingerprint" in res["log"] and "satmotor" in res["log"], res


def test_plant_with_another_fingerprint_is_refused_after_a_genuine_plant(fmus, tmp_path):
    tampered = tmp_path / "SaturatedInductionMotor.fmu"
    tamper_fingerprint(fmus["SaturatedInductionMotor"].path, tampered)
    rc, out, err = _child("tamper", tampered, fmus["BacksteppingController"].path,
                          fmus["SaturatedInductionMotor"].path)
    assert rc == 0, err
    assert not json.loads(out)["instantiated"]


def test_simulate_fmu_runs_each_fmu_three_times_in_one_process(fmus):
    """fmpy.simulate_fmu extracts into a temporary directory and deletes it; pythonfmu keeps the
    modules of the first run cached: later runs (of the same FMU and of the other one, which shares
    the glue module) must neither read from the deleted directory nor differ from the plain units."""
    paths = [fmus[n].path for n in ("SaturatedInductionMotor", "BacksteppingController")]
    rc, out, err = _child("simulate", *paths)
    assert rc == 0, err
    runs = json.loads(out)
    plant, ctrl = PlantUnit({}), ControllerUnit({})
    u_plant = {n: SIM_START[0].get(n, 0.0) for n in PLANT_IN}
    u_ctrl = {n: SIM_START[1].get(n, 0.0) for n in CTRL_IN}
    for k in range(SIM_STEPS):
        plant.step(k * H, H, tuple(u_plant[n] for n in PlantUnit.INPUTS))
        ctrl.step(k * H, H, tuple(u_ctrl[n] for n in ControllerUnit.INPUTS))
    want = {paths[0]: dict(zip(PLANT_OUT, plant.outputs())), paths[1]: dict(zip(CTRL_OUT, ctrl.outputs()))}
    for path, results in runs.items():
        assert len(results) == 3
        for i, r in enumerate(results):
            assert r["error"] == "", (Path(path).name, i, r)
            assert math.isclose(r["last"]["time"], SIM_STEPS * H, abs_tol=1e-12)
            # fmpy's communication points are sums of the step, not k H: equal to rounding
            for n, v in want[path].items():
                assert math.isclose(r["last"][n], v, rel_tol=1e-9, abs_tol=1e-12), (Path(path).name, i, n)
        assert results[1] == results[2] == results[0]


# --- 12: the FMI call contract: life cycle, communication points -------------------------------------

def _refused_step(s, t, dt):
    """doStep(t, dt) must be refused without harm: fmi2Discard (pythonfmu 0.7.0 cannot return
    fmi2Error without fmi2Fatal) or fmi2Error; returns the messages logged by the call."""
    n = len(s.log)
    with pytest.raises(FMICallException) as exc:
        s.fmu.doStep(t, dt)
    assert exc.value.status in (2, 3), (t, dt, exc.value.status)
    return "\n".join(m for status, m in s.log[n:] if status >= 2)


def _run_checked(name, s, k0, k1):
    """Steps k0 .. k1-1 of the plant's DOL start or the controller's ramp run; the outputs must be
    the plain units' from the start (nothing refused before left a trace)."""
    if name == "SaturatedInductionMotor":
        ref = plant_reference()
        assert run_plant(s, k0, k1) == [[ref[n][k + 1] for n in PLANT_OUT] for k in range(k0, k1)]
    else:
        rec = ramp_run()
        want = [[rec[n][k] for n in CTRL_OUT] for k in range(k0, k1)]
        assert run_ctrl(s, k0, k1, rec) == want


@pytest.mark.parametrize("name", list(CONTRACT))
def test_do_step_outside_the_initialized_state_is_refused_with_a_message(new, name):
    s = new(name, initialize=False)
    assert "not initialized" in _refused_step(s, 0.0, H)
    s.fmu.setupExperiment(startTime=0.0)
    s.fmu.enterInitializationMode()
    assert "initialization mode" in _refused_step(s, 0.0, H)
    s.fmu.exitInitializationMode()
    _run_checked(name, s, 0, 3)
    s.fmu.terminate()
    outputs = s.get(CONTRACT[name]["output"])
    assert "terminated" in _refused_step(s, 3 * H, H)
    assert s.get(CONTRACT[name]["output"]) == outputs


BAD_COMMUNICATION_POINTS = [
    (math.nan, H, "currentCommunicationPoint = nan"), (math.inf, H, "currentCommunicationPoint = inf"),
    (-math.inf, H, "currentCommunicationPoint = -inf"), (0.0, math.nan, "communicationStepSize = nan"),
    (0.0, math.inf, "communicationStepSize = inf"), (0.0, 0.0, "communicationStepSize = 0.0"),
    (0.0, -H, "communicationStepSize = -0.0001"),
]


@pytest.mark.parametrize("name", list(CONTRACT))
def test_non_finite_communication_point_or_bad_step_size_is_refused_naming_it(new, name):
    s = new(name)
    for t, dt, text in BAD_COMMUNICATION_POINTS:
        assert text in _refused_step(s, t, dt)
    _run_checked(name, s, 0, 3)


SET_AFTER_INITIALIZATION = {  # a value of every type; none is the default
    "SaturatedInductionMotor": {"R_s": 2.0, "n_p": 3, "curve": "linear", "J": 1.0, "h_int": 1e-5},
    "BacksteppingController": {"R_s": 2.0, "c1": 1.0, "Ts": 2e-4, "mode": "pi", "use_stator_flux": True},
}


@pytest.mark.parametrize("name", list(CONTRACT))
def test_parameters_and_outputs_set_after_initialization_are_refused_and_stay(new, name):
    s = new(name)
    _run_checked(name, s, 0, 2)
    output = CONTRACT[name]["output"][0]
    before = s.get([output])[0]
    for var, value in [*SET_AFTER_INITIALIZATION[name].items(), (output, before + 1.0)]:
        assert value != DEFAULTS[name].get(var, before)
        n = len(s.log)
        try:
            s.set({var: value})
        except FMICallException as exc:  # fmi2Error, should pythonfmu ever let a set return it
            assert exc.value.status == 3, (var, exc.value.status)
        what = "an output" if var == output else "a fixed parameter"
        assert f"{var}: {what} cannot be set after initialization" in "\n".join(
            m for status, m in s.log[n:] if status >= 3), (var, s.log[n:])
        assert s.value(var) == DEFAULTS[name].get(var, before), var
    # reported again (no host can miss it): the next doStep is discarded, naming every refused variable
    message = _refused_step(s, 2 * H, H)
    assert all(f"{var}:" in message for var in [*SET_AFTER_INITIALIZATION[name], output]), message
    # inputs can still be set, and the run goes on as if no parameter had been touched
    var = CONTRACT[name]["input"][0]
    s.set({var: 123.0})
    assert s.value(var) == 123.0
    _run_checked(name, s, 2, 6)


def test_a_valid_state_set_after_a_refusal_clears_it_and_the_run_goes_on_from_that_state(new):
    """A refused call makes the next doStep discard, unless the host then sets a valid state: the
    instance is then exactly that state, and it steps as the plain PlantUnit from there."""
    s = new("SaturatedInductionMotor")
    run_plant(s, 0, 20)
    state = s.fmu.getFMUState()
    run_plant(s, 20, 25)
    s.set({"J": 0.5})  # a fixed parameter after initialization: refused, pending
    assert "J: a fixed parameter cannot be set after initialization" in s.messages(min_status=3)
    s.fmu.setFMUState(state)
    s.fmu.freeFMUState(state)
    n = len(s.log)
    got = run_plant(s, 20, 40)  # raises FMICallException on a discard
    assert all(st < 2 for st, _ in s.log[n:]), s.log[n:]
    unit = PlantUnit({})
    for k in range(40):
        unit.step(k * H, H, tuple(dol_inputs(k)[v] for v in PLANT_IN))
    assert got[-1] == list(unit.outputs())


FOREIGN_STATES = {  # attempt (tests/fmu_helpers.py _child_state): what its refusal must name
    "controller state": "BacksteppingController", "controller blob": "BacksteppingController",
    "truncated": "not valid", "garbled": "not valid", "empty": "not valid", "not an object": "list",
    "non-numeric entry": "entry 0 = 'x'", "null entry": "entry 1 = None",
    # the default plant's state less one entry (PlantUnit.get_state)
    "entry missing": f"{len(PlantUnit({}).get_state()) - 1} entries",
    "entry missing, tag adjusted": f"{len(PlantUnit({}).get_state()) - 1} entries",
    "other build": "build", "other guid": "guid {0}",
    "untagged": "untagged", "plant state": "SaturatedInductionMotor",
}


def test_foreign_or_malformed_fmu_states_are_refused_and_leave_the_instance_unchanged(fmus):
    """In a child (a state pointer of another FMU could crash the host): a controller's state set on
    the plant (it once gave i_s = -9452 A), serialized states across FMUs, truncated, garbled and
    forged blobs.  Each is refused with a message (no fmi2Fatal), the outputs stay, the refusal is
    reported by a status, and the plant then runs on exactly like the plain PlantUnit."""
    rc, out, err = _child("state", fmus["SaturatedInductionMotor"].path, fmus["BacksteppingController"].path)
    assert rc == 0, err
    res = json.loads(out)
    plant, ctrl = PlantUnit({}), ControllerUnit({})
    plant_ref, ctrl_ref = [dict(zip(PLANT_OUT, plant.outputs()))], [dict(zip(CTRL_OUT, ctrl.outputs()))]
    for k in range(max(r["k"] for r in res.values())):
        plant.step(k * H, H, tuple(STATE_INPUTS[n] for n in PlantUnit.INPUTS))
        ctrl.step(k * H, H, tuple({"psi_ref": 0.9}.get(n, 0.0) for n in ControllerUnit.INPUTS))
        plant_ref.append(dict(zip(PLANT_OUT, plant.outputs())))
        ctrl_ref.append(dict(zip(CTRL_OUT, ctrl.outputs())))
    assert set(res) == set(FOREIGN_STATES) | {"own state", "own blob"}
    for label, r in res.items():
        ref = ctrl_ref if label == "plant state" else plant_ref
        if label in FOREIGN_STATES:
            assert r.get("deserialize", 0) in (0, 3) and r["set"] in (0, 3), (label, r)  # never fmi2Fatal
            assert r["unchanged"], label
            assert FOREIGN_STATES[label] in r["log"] and "refused" in r["log"], (label, r["log"])
            # the host learns it from a status: setFMUState's fmi2Error, or the next doStep's fmi2Discard
            assert r["set"] == 3 or (r["step"] in (2, 3) and r["redo"] == 0), (label, r)
        else:  # the genuine state goes back to step STATE_STEPS, set or deserialized
            assert r["log"] == "" and r["step"] == 0 and r["k"] == STATE_STEPS + 1, (label, r)
        assert r["outputs"] == ref[r["k"]], label


def test_state_of_another_instance_with_other_parameters_is_adopted_with_them(new):
    """A serialized state carries the parameters: restored in another instance of the same FMU, that
    instance continues the first one's run (here with another inertia), step for step."""
    params = {"J": 0.02, "R_r": 1.5}
    a, b = new("SaturatedInductionMotor", params), new("SaturatedInductionMotor")
    run_plant(a, 0, 50)
    state = a.fmu.getFMUState()
    blob = a.fmu.serializeFMUState(state)
    a.fmu.freeFMUState(state)
    state = b.fmu.deSerializeFMUstate(blob)
    b.fmu.setFMUState(state)
    b.fmu.freeFMUState(state)
    assert b.messages(min_status=2) == "" and b.value("J") == 0.02
    unit = PlantUnit(params)
    for k in range(80):
        unit.step(k * H, H, tuple(dol_inputs(k)[v] for v in PLANT_IN))
    assert run_plant(b, 50, 80)[-1] == run_plant(a, 50, 80)[-1] == list(unit.outputs())
