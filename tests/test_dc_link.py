"""The DC link in the plant (satmotor/converter/dc_link.py, fmu/native/core/sm_dclink.c): the capacitor's
energy balance against an independent quadrature, the six-pulse rectifier's no-load voltage against its
closed form, the chopper's hysteresis and energy, the over-voltage fault, ``ideal`` as today's plant bit
for bit, and the C port against the Python bit for bit (ctypes)."""

from __future__ import annotations

import ctypes
import math
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from satmotor.control.backstepping import ControllerConfig
from satmotor.converter.dc_link import E_CHOP, E_REGEN, V_DC, DCLinkParams
from satmotor.errors import ParameterError
from satmotor.interface import PlantUnit
from satmotor.machine.params import MotorParams
from satmotor.machine.plant import Plant, initial_state

sys.path.insert(0, str(Path(__file__).resolve().parent))
import native_core as nc  # noqa: E402

SQRT3 = math.sqrt(3.0)


def _rotating(t, amp, f):
    ph = 2.0 * math.pi * f * t
    return amp * math.cos(ph), amp * math.sin(ph)


def _clamp(v_a, v_b, v_dc):
    """The inverter's voltage, written here again: the command within |v| <= v_dc/sqrt(3), else on it."""
    r = math.sqrt(v_a * v_a + v_b * v_b)
    lim = v_dc / SQRT3
    return (v_a, v_b) if r <= lim else (v_a * lim / r, v_b * lim / r)


def test_default_link_voltage_is_the_controllers():
    assert DCLinkParams().V_dc == ControllerConfig().V_dc


def test_ideal_is_todays_plant_bit_for_bit():
    """dc_link = ideal (the default): the states of Plant.step, v_dc = V_dc reported, no energies."""
    u = PlantUnit({"psi_r0": 0.9, "V_dc": 600.0})
    plant = Plant(MotorParams())
    x = initial_state(MotorParams(), psi_r_alpha=0.9)
    t, dt = 0.0, 2e-4
    for _ in range(500):
        v = _rotating(t, 700.0, 40.0)  # far beyond V_dc/sqrt(3): ideal does not bound it
        u.step(t, dt, (*v, 5.0))
        x = plant.step(t, x, *v, 5.0, dt, 2)
        t += dt
        assert u.get_state()[:len(x) + 2] == (*x, *v)  # then the held voltage (the outputs' with R_fe)
    out = dict(zip(PlantUnit.OUTPUTS, u.outputs()))
    assert (out["v_dc"], out["E_regen"], out["E_chop"], out["dc_fault"]) == (600.0, 0.0, 0.0, 0.0)


@pytest.mark.parametrize("values, field", [
    ({"dc_link": "battery"}, "dc_link"), ({"dc_source": "grid"}, "dc_source"), ({"C_dc": 0.0}, "C_dc"),
    ({"R_src": -1.0}, "R_src"), ({"V_dc": 0.0}, "V_dc"), ({"f_grid": math.nan}, "f_grid"),
    ({"R_chop": -2.0}, "R_chop"), ({"V_dc_max": -1.0}, "V_dc_max"),
    ({"R_chop": 10.0, "V_chop_on": 700.0, "V_chop_off": 700.0}, "V_chop_off"),
    ({"V_chop_on": 700.0, "V_chop_off": 750.0}, "V_chop_off"),  # inverted, without a chopper (issue 31)
    ({"dc_link": "capacitor", "V_chop_on": 0.0}, "V_chop_on"),
])
def test_bad_parameters_named(values, field):
    with pytest.raises(ParameterError) as e:
        PlantUnit(values)
    assert e.value.field == field


def _run(values, t_end, dt, command, load, record=None):
    """PlantUnit over [0, t_end] in steps dt; command(t) -> (v_a, v_b); record(u, t) each step."""
    u = PlantUnit(values)
    n = round(t_end / dt)
    for k in range(n):
        t = k * dt
        u.step(t, dt, (*command(t), load(t)))
        if record is not None:
            record(u, (k + 1) * dt)
    return u


def _powers(u, v_a, v_b, values):
    """(v_dc, p_inv, i_src, i_chop) at the unit's state, written here from the physics (the motor's
    currents from Plant.outputs): p_inv = 3/2 v.i_s with the clamped voltage, i_src through the diode."""
    x = u.x
    o = u.plant.outputs(x)
    v_dc = x[V_DC]
    va, vb = _clamp(v_a, v_b, v_dc)
    p = 1.5 * (va * o.i_s_alpha + vb * o.i_s_beta)
    i_src = max(0.0, (values["V_dc"] - v_dc) / values["R_src"])
    return v_dc, p, i_src


class Braking:
    """A V/f command whose field slows from 47 Hz (the rotor at 150 rad/s, 47.7 Hz electrical, 2 pole
    pairs) by 60 Hz/s to 3 Hz: the motor generates; the angle is accumulated per call of :meth:`at`."""

    def __init__(self):
        self.theta = 0.0

    @staticmethod
    def frequency(t):
        return max(47.0 - 60.0 * t, 3.0)

    def at(self, t, dt):
        f = self.frequency(t)
        v = 326.0 * f / 50.0
        c = (v * math.cos(self.theta), v * math.sin(self.theta))
        self.theta += 2.0 * math.pi * f * dt
        return c


BRAKE = {"dc_link": "capacitor", "psi_r0": 0.9, "omega_m0": 150.0, "J": 5 * MotorParams().J}


def test_capacitor_energy_balance():
    """1/2 C (v1^2 - v0^2) = int (i_src - i_dc) v_dc dt over a braking run with a dc source (the motor
    draws from it first, then returns energy the diode blocks), no chopper: Simpson's rule on each step
    of held command, its midpoint from two half steps, the powers written here from the physics."""
    values = dict(BRAKE, V_dc=540.0, C_dc=470e-6, R_src=0.5, V_dc_max=0.0, h_int=1e-5)
    dt = 2e-5
    u = PlantUnit(values)
    cmd = Braking()
    lhs0 = 0.5 * values["C_dc"] * u.x[V_DC] ** 2
    src = inv = regen = throughput = 0.0
    for k in range(round(0.3 / dt)):
        t = k * dt
        v = cmd.at(t, dt)
        f = []
        for j in range(3):
            v_dc, p, i_src = _powers(u, *v, values)
            f.append((i_src * v_dc, p))
            if j < 2:
                u.step(t + j * 0.5 * dt, 0.5 * dt, (*v, 0.0))
        simpson = [(a + 4.0 * b + c) * dt / 6.0 for a, b, c in zip(*f)]
        src += simpson[0]
        inv += simpson[1]
        throughput += (abs(f[0][1]) + 4.0 * abs(f[1][1]) + abs(f[2][1])) * dt / 6.0
        regen += (max(0.0, -f[0][1]) + 4.0 * max(0.0, -f[1][1]) + max(0.0, -f[2][1])) * dt / 6.0
    lhs = 0.5 * values["C_dc"] * u.x[V_DC] ** 2 - lhs0
    rhs = src - inv
    print(f"link energy balance: 1/2 C dv^2 = {lhs:.9g} J, int (i_src - i_dc) v dt = {rhs:.9g} J, "
          f"throughput {throughput:.6g} J, residual {abs(lhs - rhs) / throughput:.3g}; E_regen "
          f"{u.x[E_REGEN]:.9g} J, quadrature {regen:.9g} J")
    assert throughput > 100.0 and u.x[E_REGEN] > 100.0 and src > 1.0  # it drew and it regenerated
    assert abs(lhs - rhs) <= 1e-6 * throughput
    assert abs(u.x[E_REGEN] - regen) <= 1e-5 * regen


def test_chopper_hysteresis_and_energy():
    """The motor returns energy the source cannot take: the chopper switches on above V_chop_on and off
    below V_chop_off (at sub-step ends), holds the link in the band, and E_chop is int v^2/R dt while on
    (trapezoid over the steps, each step with the chopper state it started with)."""
    values = dict(BRAKE, C_dc=100e-6, R_chop=10.0, V_chop_on=700.0, V_chop_off=680.0, V_dc_max=720.0,
                  h_int=1e-5)
    dt = 1e-5
    u = PlantUnit(values)
    cmd = Braking()
    rows = [(u.x[V_DC], u._chop)]
    for k in range(round(0.25 / dt)):
        u.step(k * dt, dt, (*cmd.at(k * dt, dt), 0.0))
        rows.append((u.x[V_DC], u._chop))
    a = np.array(rows, dtype=float)
    v, on = a[:, 0], a[:, 1]
    assert on.any() and not on.all()
    rise = np.nonzero(np.diff(on) > 0)[0] + 1
    fall = np.nonzero(np.diff(on) < 0)[0] + 1
    assert len(rise) >= 2 and (v[rise] > 700.0).all() and (v[fall] < 680.0).all()
    assert v.max() < 720.0 and not u._fault
    e_chop = float(np.sum(0.5 * (v[:-1] ** 2 + v[1:] ** 2) / 10.0 * on[:-1]) * dt)
    print(f"E_chop {u.x[E_CHOP]:.6g} J, quadrature {e_chop:.6g} J; v_dc in [{v.min():.1f}, {v.max():.1f}] V, "
          f"{len(rise)} switch-ons")
    assert abs(u.x[E_CHOP] - e_chop) <= 2e-3 * e_chop


def test_rectifier_no_load_voltage_is_the_peak():
    """Six-pulse bridge, no load: the capacitor charges to sqrt(2) V_grid (never above); with a resistive
    load (the chopper held on) the link ripples between the envelope's minimum sqrt(2) V_grid cos(pi/6)
    and the peak."""
    V_grid = 400.0
    peak = math.sqrt(2.0) * V_grid
    values = {"dc_link": "capacitor", "dc_source": "rectifier", "V_grid": V_grid, "f_grid": 50.0,
              "V_dc": 500.0, "C_dc": 470e-6, "R_src": 0.5}
    vs = []
    _run(values, 0.1, 1e-4, lambda t: (0.0, 0.0), lambda t: 0.0, lambda u, t: vs.append(u.x[V_DC]))
    vs = np.array(vs)
    print(f"no-load link {vs[-1]:.6f} V, sqrt(2) V_grid = {peak:.6f} V")
    assert vs.max() <= peak and vs[-1] >= peak * (1.0 - 1e-4)
    # loaded: R = 50 Ohm (the chopper on from the start: V_chop_on below the initial voltage)
    loaded = dict(values, R_chop=50.0, V_chop_on=1.0, V_chop_off=0.5, V_dc=540.0)
    vs = []
    _run(loaded, 0.2, 1e-5, lambda t: (0.0, 0.0), lambda t: 0.0, lambda u, t: vs.append(u.x[V_DC]))
    v = np.array(vs[len(vs) // 2:])
    ripple = v.max() - v.min()
    print(f"50-Ohm load: link in [{v.min():.2f}, {v.max():.2f}] V, mean {v.mean():.2f} V, "
          f"ripple {ripple:.2f} V")
    assert v.max() < peak and v.min() > peak * math.cos(math.pi / 6.0) and ripple > 1.0


def test_over_voltage_fault_latched_and_logged_once():
    values = dict(BRAKE, C_dc=100e-6, V_dc_max=600.0)
    u = PlantUnit(values)
    cmd = Braking()
    t, dt, faults, logged = 0.0, 1e-4, [], []
    for _ in range(2000):
        u.step(t, dt, (*cmd.at(t, dt), 0.0))
        t += dt
        faults.append(dict(zip(PlantUnit.OUTPUTS, u.outputs()))["dc_fault"])
        logged += u.warnings
        u.warnings.clear()
    first = faults.index(1.0)
    assert faults[first] == 1.0 and set(faults[first:]) == {1.0} and set(faults[:first]) == {0.0}
    assert len(logged) == 1 and "V_dc_max = 600.0 V" in logged[0]
    assert "DC-link over-voltage" in logged[0]


def test_state_round_trip():
    values = {"dc_link": "capacitor", "psi_r0": 0.9, "R_chop": 30.0, "V_chop_on": 560.0, "V_chop_off": 550.0}
    u = PlantUnit(values)
    for k in range(50):
        u.step(k * 1e-4, 1e-4, (300.0, 0.0, 0.0))
    s = u.get_state()
    a = [u.step(50e-4, 1e-4, (300.0, 0.0, 0.0)) or u.get_state() for _ in range(1)]
    u.set_state(s)
    b = [u.step(50e-4, 1e-4, (300.0, 0.0, 0.0)) or u.get_state() for _ in range(1)]
    assert a == b and len(s) == 19  # nine states, chopper, fault, the held voltage, load and step means


# --- the C port (ctypes) ---------------------------------------------------------------------------

needs_gcc = pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")


@pytest.fixture(scope="module")
def lib():
    return nc.load()


def _c_link(lib, values):
    m = nc.new_motor(lib)
    msg = ctypes.create_string_buffer(512)
    st = lib.sm_motor_init(m, nc.params(lib, nc.MotorParams, values), nc.params(lib, nc.PlantParams, values),
                           msg, 512)
    assert st == 0, msg.value
    link = (ctypes.c_double * ((lib.sm_dclink_size() + 7) // 8))()
    st = lib.sm_dclink_init(link, nc.params(lib, nc.DCLinkParams, values), msg, 512)
    return m, link, st, msg.value.decode()


CASES = [
    {"dc_link": "capacitor", "psi_r0": 0.9},
    {"dc_link": "capacitor", "psi_r0": 0.9, "dc_source": "rectifier", "R_chop": 40.0, "V_chop_on": 560.0,
     "V_chop_off": 550.0, "V_dc_max": 565.0, "V_dc": 500.0},
    {"dc_link": "capacitor", "omega_m0": 150.0, "psi_r0": 0.9, "C_dc": 2e-4, "R_chop": 25.0,
     "V_dc_max": 700.0, "V_chop_on": 650.0, "V_chop_off": 600.0, "l_s": 0.0},
]


@needs_gcc
@pytest.mark.parametrize("values", CASES)
def test_c_step_bit_for_bit(lib, values):
    u = PlantUnit(values)
    m, link, st, msg = _c_link(lib, values)
    assert st == 0, msg
    x = (ctypes.c_double * 9)(*u.x)
    chop, fault, tf = ctypes.c_int(0), ctypes.c_int(0), ctypes.c_double()
    rng = np.random.default_rng(19)
    t, seen_chop, seen_fault = 0.0, False, False
    for k in range(400):
        dt = float(rng.choice([1e-4, 3e-4, 1e-3]))
        va, vb = _rotating(t, float(rng.uniform(100.0, 500.0)), float(rng.uniform(-20.0, 60.0)))
        TL = float(rng.uniform(-40.0, 30.0))
        u.step(t, dt, (va, vb, TL))
        assert lib.sm_dclink_step(m, link, t, x, va, vb, TL, dt, u._n_sub, chop, fault, tf) == 0
        t += dt
        assert u.get_state()[:13] == (*x, float(chop.value), float(fault.value), va, vb), k
        seen_chop |= bool(chop.value)
        if u.warnings:
            seen_fault = True
            buf = ctypes.create_string_buffer(512)
            lib.sm_dclink_over_voltage_message(tf.value, x[V_DC], values["V_dc_max"], buf, 512)
            assert u.warnings.pop() == buf.value.decode()
    print(f"C = Python over 400 steps: chopper used {seen_chop}, fault {seen_fault}")


@needs_gcc
def test_c_source_and_clamp_bit_for_bit(lib):
    from satmotor.converter.dc_link import DCLink

    values = {"dc_link": "capacitor", "dc_source": "rectifier", "V_grid": 415.0, "f_grid": 60.0}
    u = PlantUnit(values)
    _, link, _, _ = _c_link(lib, values)
    rng = np.random.default_rng(5)
    for t in np.concatenate([rng.uniform(0.0, 10.0, 2000), [0.0, 1.0 / 360.0, 1e-12]]):
        assert lib.sm_dclink_source_voltage(link, float(t)) == u._link.source_voltage(float(t))
    a, b = ctypes.c_double(), ctypes.c_double()
    for va, vb, vdc in rng.uniform(-600.0, 600.0, (2000, 3)):
        lib.sm_dclink_applied(va, vb, vdc, a, b)
        assert (a.value, b.value) == DCLink.applied(float(va), float(vb), float(vdc))


@needs_gcc
@pytest.mark.parametrize("values", [
    {"dc_link": "battery"}, {"dc_source": "grid"}, {"C_dc": 0.0}, {"R_src": -1.0}, {"V_dc_max": -1.0},
    {"R_chop": 10.0, "V_chop_on": 700.0, "V_chop_off": 700.0}, {"R_chop": 10.0, "V_chop_on": -1.0},
    {"V_grid": math.inf}, {"V_chop_on": 700.0, "V_chop_off": 750.0}, {"V_chop_off": -1.0},
])
def test_c_parameter_errors_as_python(lib, values):
    with pytest.raises(ParameterError) as e:
        PlantUnit(values)
    _, _, st, msg = _c_link(lib, values)
    assert st != 0 and msg == str(e.value)


# --- the controller reads the link voltage ---------------------------------------------------------

def _c_controller(lib, values):
    buf = ctypes.create_string_buffer(lib.sm_controller_size())
    msg = ctypes.create_string_buffer(256)
    st = lib.sm_controller_init(buf, nc.params(lib, nc.ControllerParams, values),
                                nc.params(lib, nc.MotorParams, values), msg, 256)
    assert st == 0, msg.value
    return buf


def _link_loop(ctrl_values, connected, c_check=None):
    """A closed loop on a weak 300 V link (the controller's parameter V_dc, 540 V, is larger; the link
    sags under the start, the chopper holds the stop); the controller's v_dc input is the plant's v_dc
    (``connected``) or 0.  ``c_check(t, inputs, outputs)`` sees every sample.  Returns the largest
    ``|v_s| sqrt(3) / v_dc`` of the commands against the link they were computed at."""
    from satmotor.interface import ControllerUnit

    plant = PlantUnit({"dc_link": "capacitor", "C_dc": 200e-6, "R_src": 1.0, "V_dc": 300.0, "R_chop": 20.0,
                       "V_chop_on": 420.0, "V_chop_off": 400.0})
    ctrl = ControllerUnit(ctrl_values)
    Ts, worst = ctrl.Ts, 0.0
    for k in range(6000):
        t = k * Ts
        o = dict(zip(PlantUnit.OUTPUTS, plant.outputs()))
        w_ref = 150.0 if t < 0.35 else 0.0
        inputs = (o["i_s_alpha"], o["i_s_beta"], o["psi_r_alpha"], o["psi_r_beta"], o["psi_s_alpha"],
                  o["psi_s_beta"], o["omega_m"], w_ref, 0.9, 0.0, o["v_dc"] if connected else 0.0)
        ctrl.step(t, Ts, inputs)
        out = ctrl.outputs()
        if c_check is not None:
            c_check(t, inputs, out)
        c = dict(zip(ctrl.OUTPUTS, out))
        worst = max(worst, math.hypot(c["v_s_alpha"], c["v_s_beta"]) * SQRT3 / o["v_dc"])
        plant.step(t, Ts, (c["v_s_alpha"], c["v_s_beta"], 0.0))
    return worst


@needs_gcc
@pytest.mark.parametrize("ctrl_values", [{}, {"mode": "pi"}, {"field_weakening": False}],
                         ids=["backstepping", "pi", "no field weakening"])
def test_controller_reads_the_link_voltage_c_as_python(lib, ctrl_values):
    """With the link voltage read, every command is within v_dc/sqrt(3) of the link it was computed at
    (the field weakening and the limiter use it); not read, the commands ask for more than the link
    gives; the C controller, given the same inputs, gives the Python's outputs bit for bit."""
    from satmotor.interface import CONTROLLER_OUTPUTS

    buf = _c_controller(lib, ctrl_values)
    n_out = len(CONTROLLER_OUTPUTS)
    msg = ctypes.create_string_buffer(256)
    Ts = 1e-4

    def c_check(t, inputs, want):
        arr = (ctypes.c_double * len(inputs))(*inputs)
        assert lib.sm_controller_step(buf, t, Ts, arr, msg, 256) == 0, msg.value
        got = list((ctypes.c_double * n_out).from_buffer(buf, lib.sm_controller_size() - 8 * n_out))
        assert got == [float(v) for v in want], t

    read = _link_loop(ctrl_values, True, c_check)
    unread = _link_loop(ctrl_values, False)
    print(f"{ctrl_values}: largest |v_s| sqrt(3) / v_dc {read:.12f} reading the link, {unread:.4f} not")
    assert read <= 1.0 + 1e-12 < 1.05 < unread


def test_controller_v_dc_input_checked_and_zero_is_the_parameter():
    from satmotor.interface import ControllerUnit

    base = (1.0, 0.0, 0.5, 0.0, 0.55, 0.0, 0.0, 0.0, 0.9, 0.0)
    a, b = ControllerUnit({"V_dc": 300.0}), ControllerUnit({"V_dc": 300.0})
    for k in range(200):
        a.step(k * 1e-4, 1e-4, (*base, 0.0))
        b.step(k * 1e-4, 1e-4, (*base, 300.0))  # the same voltage read as an input
        assert a.outputs() == b.outputs()
    with pytest.raises(ParameterError) as e:
        a.step(0.02, 1e-4, (*base, -1.0))
    assert e.value.field == "v_dc"


def test_link_metrics_running_equal_whole_record():
    """E_regen, E_chop (last values), peak and least v_dc, dc_fault: chunk by chunk as over the whole
    record, and only when asked for (the link on)."""
    from satmotor.metrics import LINK_SERIES, SERIES, RunningMetrics, closed_loop_metrics

    rng = np.random.default_rng(3)
    n = 1000
    t = np.arange(n) * 1e-3
    series = {k: rng.normal(size=n) for k in SERIES if k != "t"}
    series["t"] = t
    series["omega_ref"] = np.full(n, 10.0)
    link = {"v_dc": 540.0 + 200.0 * rng.random(n), "E_regen": np.cumsum(rng.random(n)),
            "E_chop": np.cumsum(rng.random(n)), "dc_fault": (np.arange(n) > 700).astype(float)}
    whole = closed_loop_metrics(**series, run=np.ones(n, bool), link=link)
    assert set(LINK_SERIES) - {"v_dc"} <= set(whole) and "peak_v_dc" in whole
    assert whole["E_regen"] == link["E_regen"][-1] and whole["dc_fault"] == 1.0
    assert whole["peak_v_dc"] == link["v_dc"].max() and whole["min_v_dc"] == link["v_dc"].min()
    running = RunningMetrics(t[-1], 10.0, link=True)
    for a in range(0, n, 137):
        sl = slice(a, a + 137)
        running.update(**{k: v[sl] for k, v in series.items()}, run=np.ones(len(t[sl]), bool),
                       link={k: v[sl] for k, v in link.items()})
    got = running.result()
    for k in ("E_regen", "E_chop", "peak_v_dc", "min_v_dc", "dc_fault"):
        assert got[k] == whole[k], k
    assert "E_regen" not in closed_loop_metrics(**series, run=np.ones(n, bool))
