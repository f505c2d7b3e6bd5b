"""The controller unit in C (fmu/native/core/sm_controller.c, sm_drive.c, sm_delay.c, ...) against
satmotor.interface.ControllerUnit: a plain-Python closed loop (PlantUnit + ControllerUnit) runs a
scenario; the C controller receives the same inputs at every sample and must give the same
outputs.  Every mode and option of the drive: the Python is the specification."""

import ctypes
import math

import numpy as np
import pytest
from native_core import ControllerParams, MotorParams, build, declare, params

from satmotor.interface import CONTROLLER_OUTPUTS, ControllerUnit, PlantUnit
from satmotor.machine.library import preset


@pytest.fixture(scope="module", params=["plain", "sanitized"])
def lib(request):
    extra = ("-fsanitize=undefined", "-fno-sanitize-recover=all") if request.param == "sanitized" else ()
    so = declare(ctypes.CDLL(str(build(extra))))  # the signatures read from the headers
    assert so.sm_controller_params_size() == ctypes.sizeof(ControllerParams)
    assert so.sm_motor_params_size() == ctypes.sizeof(MotorParams)
    return so


def _c_controller(lib, values):
    buf = ctypes.create_string_buffer(lib.sm_controller_size())
    msg = ctypes.create_string_buffer(256)
    unknown = set(values) - {n for n, _ in ControllerParams._fields_ + MotorParams._fields_}
    assert not unknown, unknown
    status = lib.sm_controller_init(buf, params(lib, ControllerParams, values),
                                    params(lib, MotorParams, values), msg, 256)
    return buf, status, msg.value.decode()


def _out(buf, lib):
    # the outputs array is the last member of sm_controller: read it from the end of the struct
    n = len(CONTROLLER_OUTPUTS)
    arr = (ctypes.c_double * n).from_buffer(buf, lib.sm_controller_size() - 8 * n)
    return list(arr)


def _closed_loop(values, plant_values, t_end, omega, psi, load):
    """Python plant + Python controller; yields (t, inputs, Python outputs)."""
    plant, ctrl = PlantUnit(plant_values), ControllerUnit(values)
    Ts = ctrl.Ts
    for k in range(round(t_end / Ts) + 1):
        t = k * Ts
        o = plant.outputs()
        inputs = (o[0], o[1], o[4], o[5], o[2], o[3], o[6], omega(t), psi(t), load(t), 0.0)  # v_dc: 0
        ctrl.step(t, Ts, inputs)
        yield t, inputs, ctrl.outputs()
        out = ctrl.outputs()
        plant.step(t, Ts, (out[0], out[1], load(t)))


def _ramp(t):
    return 0.0 if t < 0.15 else min(100.0, (t - 0.15) * 400.0)


def _load(t):
    return 20.0 if t >= 0.35 else 0.0


QU = {**preset("qu2012_2kw2").values, **preset("qu2012_2kw2").controller}  # the Gamma form: l_s = 0
EXP = {"curve": "exponential", "k": 0.9, "l_r": 5.839e-3 * 0.81, "R_r": 1.395 * 0.81}
CASES = {
    "saturated known": ({}, {}),
    "estimated load, integral action": ({"load_mode": "estimated", "c0": 1e4, "d0": 2500.0}, {"R_r": 2.0}),
    "constant m": ({"mode": "constant_m"}, {}),
    "IFOC PI": ({"mode": "pi"}, {}),
    "observer": ({"flux_source": "observer"}, {}),
    "delay, integral action, mismatch": ({"delay_samples": 1, "c0": 1e4, "d0": 2500.0}, {"R_s": 1.8}),
    "observer and delay": ({"flux_source": "observer", "delay_samples": 1}, {}),
    "current-model observer": ({"flux_source": "observer", "observer": "current_model"}, {}),
    "closed-loop observer, R_r +50 %, integral action": ({"flux_source": "observer", "c0": 1e4, "d0": 2500.0},
                                                         {"R_r": 2.0925}),
    "sensorless": ({"flux_source": "observer", "speed_source": "estimated"}, {}),
    "sensorless, delay, estimated load": ({"flux_source": "observer", "speed_source": "estimated",
                                           "delay_samples": 1, "load_mode": "estimated"}, {}),
    "sensorless, Gamma form (qu2012_2kw2, l_s = 0)": (
        {**QU, "flux_source": "observer", "speed_source": "estimated"}, QU),
    "closed-loop observer, Gamma form, delay": ({**QU, "flux_source": "observer", "delay_samples": 1}, QU),
    "R_s adaptation, R_r tracking, warm plant": ({"flux_source": "observer", "rs_adaptation": True,
                                                  "rr_tracking": True}, {"R_s": 1.8467, "R_r": 1.8448}),
    "R_s adaptation, delay, estimated load": ({"flux_source": "observer", "rs_adaptation": True,
                                               "delay_samples": 1, "load_mode": "estimated"}, {"R_s": 1.7}),
    "sensorless, R_s adaptation, R_r tracking, Gamma form": (
        {**QU, "flux_source": "observer", "speed_source": "estimated", "rs_adaptation": True,
         "rr_tracking": True}, {**QU, "R_s": 4.2, "R_r": 2.9}),
    "stator flux (H1)": ({"use_stator_flux": True}, {}),
    "current limit binding": ({"I_max": 12.0, "ref_bandwidth": 400.0}, {}),
    "exponential curve, k = 0.9": (EXP, EXP),
    "field weakening active (V_dc 250 V)": ({"V_dc": 250.0}, {}),
    "field weakening, observer and delay": ({"V_dc": 250.0, "flux_source": "observer", "delay_samples": 1},
                                            {}),
    "field weakening, constant m": ({"V_dc": 250.0, "mode": "constant_m", "fw_voltage_ratio": 0.8}, {}),
    "field weakening, IFOC PI": ({"V_dc": 250.0, "mode": "pi"}, {}),
    "field weakening off": ({"V_dc": 250.0, "field_weakening": False}, {}),
    "host delay (Jacobi)": ({"host_delay_samples": 1}, {}),
    "host delay 2 and own delay, observer, estimated load": (
        {"host_delay_samples": 2, "delay_samples": 1, "flux_source": "observer", "load_mode": "estimated"},
        {}),
    "sensorless, host delay": (
        {"flux_source": "observer", "speed_source": "estimated", "host_delay_samples": 1}, {}),
    "measured-current limiter at its floor": ({"I_max": 12.0, "c0": 1e4, "d0": 2500.0}, {"L_m0": 0.166}),
    "measured-current limiter, IFOC PI": ({"I_max": 12.0, "mode": "pi"}, {"L_m0": 0.166}),
    "estimated load at the voltage limit": (
        {"V_dc": 250.0, "field_weakening": False, "load_mode": "estimated", "c0": 1e4, "d0": 2500.0}, {}),
    "overmodulation at the voltage limit": (
        {"modulation": "overmodulation", "V_dc": 250.0, "field_weakening": False}, {}),
    "overmodulation, field weakening (V_dc 250 V), estimated load": (
        {"modulation": "overmodulation", "V_dc": 250.0, "load_mode": "estimated"}, {}),
    "loss minimizing": ({"flux_mode": "loss_minimizing"}, {}),
    "loss minimizing, core loss, fast rate, current limit": (
        {"flux_mode": "loss_minimizing", "loss_R_fe": 600.0, "flux_rate_max": 50.0, "flux_floor": 0.4,
         "I_max": 14.0}, {}),
    "loss minimizing, field weakening (V_dc 250 V), observer, delay": (
        {"flux_mode": "loss_minimizing", "V_dc": 250.0, "flux_source": "observer", "delay_samples": 1}, {}),
    "loss minimizing, field weakening off, constant m": (
        {"flux_mode": "loss_minimizing", "field_weakening": False, "mode": "constant_m"}, {}),
    "loss minimizing, IFOC PI": ({"flux_mode": "loss_minimizing", "mode": "pi"}, {}),
    "start-up tolerances": ({"premag_fraction": 0.8, "premag_min_fraction": 0.3, "premag_speed_tol": 0.5,
                             "premag_time_max": 0.05, "premag_boost": 2.0, "premag_gain": 30.0}, {}),
}


@pytest.mark.parametrize("case", list(CASES))
def test_c_controller_matches_python_sample_by_sample(lib, case):
    values, plant_values = CASES[case]
    buf, status, msg = _c_controller(lib, values)
    assert status == 0, msg
    msgbuf = ctypes.create_string_buffer(256)
    worst, n, phases, v_top = 0.0, 0, set(), 0.0
    for t, inputs, want in _closed_loop(values, plant_values, 0.5, _ramp, lambda t: 0.95, _load):
        arr = (ctypes.c_double * 11)(*inputs)
        assert lib.sm_controller_step(buf, t, 1e-4, arr, msgbuf, 256) == 0, msgbuf.value
        got = _out(buf, lib)
        for g, w in zip(got, want):
            worst = max(worst, abs(g - float(w)) / max(abs(float(w)), 1e-9))
        phases.add(int(got[14]))
        v_top = max(v_top, math.hypot(got[0], got[1]))
        n += 1
    print(f"{case}: {n} samples, worst relative difference {worst:.3g}")
    assert phases == {0, 1}  # pre-magnetization and the law
    assert worst <= 1e-12
    if values.get("modulation") == "overmodulation" and values.get("field_weakening") is False:
        # at the voltage limit without field weakening the law used the hexagon beyond the circle
        assert v_top > 1.01 * values["V_dc"] / math.sqrt(3.0), v_top


BAD = [({"mode": "fuzzy"}, "mode"), ({"flux_source": "estimated"}, "flux_source"),
       ({"delay_samples": 2}, "delay_samples"), ({"c1": -1.0}, "c1"), ({"d0": math.nan}, "d0"),
       ({"J": 0.0}, "J"),
       ({"flux_source": "observer", "use_stator_flux": True}, "use_stator_flux"),
       ({"load_mode": "guess"}, "load_mode"), ({"curve": "spline"}, "curve"),
       ({"observer": "luenberger"}, "observer"), ({"speed_source": "guessed"}, "speed_source"),
       ({"speed_source": "estimated"}, "speed_source"),
       ({"flux_source": "observer", "observer": "current_model", "speed_source": "estimated"},
        "speed_source"),
       ({"fw_voltage_ratio": 1.5}, "fw_voltage_ratio"), ({"fw_voltage_ratio": 0.0}, "fw_voltage_ratio"),
       ({"premag_fraction": 0.0}, "premag_fraction"), ({"premag_min_fraction": 0.95}, "premag_min_fraction"),
       ({"premag_speed_tol": 0.0}, "premag_speed_tol"), ({"premag_time_max": -1.0}, "premag_time_max"),
       ({"premag_boost": 0.5}, "premag_boost"), ({"premag_gain": math.inf}, "premag_gain"),
       ({"host_delay_samples": 4}, "host_delay_samples"), ({"host_delay_samples": -1}, "host_delay_samples"),
       ({"rs_adaptation": True}, "rs_adaptation"),
       ({"flux_source": "observer", "rr_tracking": True}, "rr_tracking"),
       ({"current_limit_gain": -1.0}, "current_limit_gain"), ({"current_limit_gain": math.nan},
                                                               "current_limit_gain"),
       ({"flux_mode": "minimal"}, "flux_mode"), ({"flux_floor": 0.0}, "flux_floor"),
       ({"flux_rate_max": -1.0}, "flux_rate_max"), ({"flux_rate_max": math.inf}, "flux_rate_max"),
       ({"loss_R_fe": -1.0}, "loss_R_fe"), ({"modulation": "six_step"}, "modulation")]


@pytest.mark.parametrize("values, field", BAD)
def test_c_controller_refuses_what_python_refuses_with_the_same_message(lib, values, field):
    _, status, msg = _c_controller(lib, values)
    assert status != 0
    with pytest.raises(Exception) as exc:
        ControllerUnit(values)
    assert getattr(exc.value, "field", None) == field
    assert msg == str(exc.value), (msg, str(exc.value))


def test_c_controller_refuses_bad_inputs_and_steps_and_changes_nothing(lib):
    buf, status, _ = _c_controller(lib, {})
    msg = ctypes.create_string_buffer(256)
    good = (ctypes.c_double * 11)(1.0, 0.0, 0.1, 0.0, 0.1, 0.0, 0.0, 0.0, 0.95, 0.0, 0.0)
    assert lib.sm_controller_step(buf, 0.0, 1e-4, good, msg, 256) == 0
    before = bytes(buf)
    bad = (ctypes.c_double * 11)(*good)
    bad[6] = math.nan
    assert lib.sm_controller_step(buf, 1e-4, 1e-4, bad, msg, 256) != 0
    assert msg.value.decode() == "omega_m = nan: must be a finite number"
    assert lib.sm_controller_step(buf, 1e-4, 1.5e-4, good, msg, 256) != 0
    assert msg.value.decode() == ("communicationStepSize = 0.00015: must be a whole multiple of the sample "
                                  "period Ts = 0.0001 s")
    unreachable = (ctypes.c_double * 11)(*good)
    unreachable[8] = 5.0
    assert lib.sm_controller_step(buf, 1e-4, 1e-4, unreachable, msg, 256) != 0
    with pytest.raises(Exception) as exc:
        ControllerUnit({}).step(0.0, 1e-4, tuple(unreachable))
    assert msg.value.decode() == str(exc.value)
    assert bytes(buf) == before
    assert np.isfinite(_out(buf, lib)).all()


@pytest.mark.parametrize("garbage", [math.nan, math.inf, 1e300, -77.0])
def test_sensorless_controller_does_not_read_omega_m(lib, garbage):
    """speed_source = estimated: the omega_m input may hold anything (NaN included); the C and the Python
    controllers give the outputs they give with the true speed, sample by sample."""
    values = {"flux_source": "observer", "speed_source": "estimated"}
    buf, status, msg = _c_controller(lib, values)
    assert status == 0, msg
    py = ControllerUnit(values)
    msgbuf = ctypes.create_string_buffer(256)
    n = 0
    for t, inputs, want in _closed_loop(values, {}, 0.3, _ramp, lambda t: 0.95, _load):
        bad = inputs[:6] + (garbage,) + inputs[7:]
        py.step(t, 1e-4, bad)
        arr = (ctypes.c_double * 11)(*bad)
        assert lib.sm_controller_step(buf, t, 1e-4, arr, msgbuf, 256) == 0, msgbuf.value
        assert list(py.outputs()) == list(want)  # bit for bit: omega_m was not read
        got = _out(buf, lib)
        scale = 1.0 + max(abs(float(w)) for w in want)
        assert max(abs(g - float(w)) for g, w in zip(got, want)) <= 1e-12 * scale
        n += 1
    assert n > 2000
