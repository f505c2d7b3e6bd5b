"""The plant's PWM inverter (satmotor/converter/inverter.py, fmu/native/core/sm_inverter.c) and the
controller's dead-time compensation (satmotor/control/deadtime.py).

Expected values come from the command and from hand computations written here: the step average of the
switched voltage against the commanded one (zero dead time and drops), the switching instants of one
carrier period computed by hand, a brute-force carrier comparison on a fine grid, the closed-form dead-time
and on-state errors with constant current signs; the C core against the Python bit for bit (==)."""

from __future__ import annotations

import ctypes
import math
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from satmotor.control.deadtime import compensate
from satmotor.converter.inverter import InverterParams, PwmInverter, duties
from satmotor.errors import ParameterError
from satmotor.interface import ControllerUnit, PlantUnit
from satmotor.machine.params import MotorParams
from satmotor.machine.plant import Plant, initial_state

sys.path.insert(0, str(Path(__file__).resolve().parent))
import native_core as nc  # noqa: E402

V_DC = 540.0
SQ3 = math.sqrt(3.0)
V_A, V_B = PlantUnit.OUTPUTS.index("v_avg_alpha"), PlantUnit.OUTPUTS.index("v_avg_beta")


def _unit(**kw):
    return PlantUnit(dict({"inverter": "pwm", "psi_r0": 0.9}, **kw))


def _plant():
    p = MotorParams()
    return Plant(p), initial_state(p, psi_r_alpha=0.9)


# ---- the modulator and the exact average ---------------------------------------------------------

def test_duties_min_max_injection_by_hand():
    # v = (120, 80): phases a = 120, b = -60 + 40 sqrt3, c = -60 - 40 sqrt3; v0 = -(max + min)/2
    a, b, c = 120.0, -60.0 + 40.0 * SQ3, -60.0 - 40.0 * SQ3
    v0 = -0.5 * (a + c)
    d = duties(120.0, 80.0, V_DC)
    assert d == pytest.approx([0.5 + (v + v0) / V_DC for v in (a, b, c)], rel=1e-15)
    # the linear range is the circle V_dc/sqrt(3): on it the duties stay in [0, 1] (no clipping),
    # centred (d_max + d_min = 1), reaching 0 and 1 where a line-to-line voltage peaks (every 60 deg)
    spreads = []
    for ang in np.linspace(0.0, 2.0 * math.pi, 3601):
        d = duties(V_DC / SQ3 * math.cos(ang), V_DC / SQ3 * math.sin(ang), V_DC)
        assert max(d) + min(d) == pytest.approx(1.0, abs=1e-12)
        spreads.append(max(d) - min(d))
    assert max(spreads) == pytest.approx(1.0, abs=1e-6) and max(spreads) <= 1.0 + 1e-12
    assert duties(1e4, 0.0, V_DC) == (1.0, 0.0, 0.0)  # over-modulation: clipped


@pytest.mark.parametrize("f_sw", [5000.0, 10000.0, 20000.0])
def test_step_average_equals_command(f_sw):
    """t_dead = 0, v_on = 0, the half carrier period equal to (5 kHz) or dividing (10, 20 kHz) the step of
    1e-4 s: the step average of the applied alpha/beta voltage is the command, to rounding, while the
    motor runs (random commands in the linear range, a new one every step)."""
    u = _unit(f_sw=f_sw)
    rng = np.random.default_rng(3)
    dt, worst = 1e-4, 0.0
    for n in range(400):
        r, ang = rng.uniform(0.0, V_DC / SQ3), rng.uniform(0.0, 2.0 * math.pi)
        va, vb = r * math.cos(ang), r * math.sin(ang)
        u.step(n * dt, dt, (va, vb, 0.0))
        o = u.outputs()
        worst = max(worst, abs(o[V_A] - va), abs(o[V_B] - vb))
    print(f"f_sw = {f_sw} Hz: worst |v_avg - v_cmd| = {worst:.3g} V over 400 steps")
    assert worst <= 1e-12 * V_DC


def test_average_inverter_is_the_command():
    u, ref = PlantUnit({"psi_r0": 0.9}), Plant(MotorParams())
    x = initial_state(MotorParams(), psi_r_alpha=0.9)
    for n in range(5):
        u.step(n * 1e-4, 1e-4, (100.0 + n, -20.0, 1.0))
        x = ref.step(0.0, x, 100.0 + n, -20.0, 1.0, 1e-4, 1)
        assert u.x == x  # today's plant, bit for bit
        assert u.outputs()[V_A:V_B + 1] == (100.0 + n, -20.0)


def _hand_levels(d, t, T_h):
    """Leg states at time t from the carrier comparison, written independently: carrier c in [0, 1],
    0 at even multiples of T_h, 1 at odd ones; a leg is high where c < d (d held over a half period)."""
    k = math.floor(t / T_h)
    frac = t / T_h - k
    c = frac if k % 2 == 0 else 1.0 - frac
    return [1 if c < dx else 0 for dx in d]


def test_switching_instants_of_one_period_by_hand():
    va, vb, f_sw = 120.0, 80.0, 5000.0
    T_h = 0.5 / f_sw
    plant, x = _plant()
    inv = PwmInverter(InverterParams(V_DC, "pwm", f_sw))
    trace = []
    inv.step(plant, 0.0, x, va, vb, 0.0, 2.0 * T_h, 1e-4, trace)
    d = duties(va, vb, V_DC)
    # by hand: rising half, legs fall at d T_h; falling half, legs rise at T_h + (1 - d) T_h
    expect = sorted({0.0, *(dx * T_h for dx in d), *(T_h + (1.0 - dx) * T_h for dx in d)})
    assert [r[0] for r in trace] == pytest.approx(expect, rel=0, abs=1e-18)
    assert sum(r[1] for r in trace) == pytest.approx(2.0 * T_h, rel=1e-15)
    for t0, L, v_alpha, v_beta, *v_ph in trace:
        s = _hand_levels(d, t0 + 0.5 * L, T_h)
        assert v_ph == [(sx - 0.5) * V_DC for sx in s]
        assert v_alpha == pytest.approx((2 * v_ph[0] - v_ph[1] - v_ph[2]) / 3.0, abs=1e-12)
        assert v_beta == pytest.approx((v_ph[1] - v_ph[2]) / SQ3, abs=1e-12)


def test_against_a_brute_force_carrier_comparison():
    """An unaligned start, f_sw = 7300 Hz (not dividing the step), commands changing every step: the
    volt-seconds of every step against a fine-grid evaluation of the carrier comparison (duties taken at
    the peaks and valleys from the command then held)."""
    f_sw, dt, t0 = 7300.0, 1e-4, 3.3e-5
    T_h = 0.5 / f_sw
    plant, x = _plant()
    inv = PwmInverter(InverterParams(V_DC, "pwm", f_sw))
    rng = np.random.default_rng(5)
    cmds = [(rng.uniform(-250, 250), rng.uniform(-250, 250)) for _ in range(12)]

    def cmd_at(t):  # the command held at time t (step n from t0 + n dt)
        return cmds[min(int(math.floor((t - t0) / dt + 1e-9)), len(cmds) - 1)]

    for n, (va, vb) in enumerate(cmds):
        a = t0 + n * dt
        x, avg_a, avg_b = inv.step(plant, a, x, va, vb, 0.0, dt, 1e-4)
        N = 200_000
        ts = a + (np.arange(N) + 0.5) * (dt / N)
        # vectorised: the duty of each half period from the command at its start (the first: from
        # the step's command when the half started before t0, as the inverter's first step does)
        k = np.floor(ts / T_h).astype(np.int64)
        dcache = {}
        for kk in np.unique(k):
            start = kk * T_h
            dcache[kk] = duties(*(cmd_at(start) if start >= t0 - 1e-12 else cmds[0]), V_DC)
        d = np.array([dcache[kk] for kk in k])
        frac = ts / T_h - k
        c = np.where(k % 2 == 0, frac, 1.0 - frac)
        s = (c[:, None] < d).astype(float)
        v = (s - 0.5) * V_DC
        acc_a = np.mean((2 * v[:, 0] - v[:, 1] - v[:, 2]) / 3.0)
        acc_b = np.mean((v[:, 1] - v[:, 2]) / SQ3)
        # the grid resolves an edge to dt/N: 6 edges per half, 3-4 halves per step
        tol = 30 * V_DC / N
        assert avg_a == pytest.approx(acc_a, abs=tol) and avg_b == pytest.approx(acc_b, abs=tol), n


# ---- dead time and on-state drop: closed forms -------------------------------------------------------

def test_dead_time_and_drop_closed_form():
    """Magnetized at rest, i_s along +alpha (i_a > 0, i_b = i_c < 0), the command holding that current
    (R_s i): the signs do not change over the steps, so each carrier period loses t_dead V_dc per phase
    against sign(i): phase errors e_a = -E, e_b = e_c = +E with E = t_dead f_sw V_dc, alpha error
    (2 e_a - e_b - e_c)/3 = -4E/3, beta 0; with v_on: -sign(i) v_on per phase, alpha -4 v_on/3."""
    f_sw, t_dead, v_on, dt = 5000.0, 2e-6, 1.5, 1e-4
    u0 = PlantUnit({"psi_r0": 0.9})
    i_a = u0.outputs()[0]
    assert i_a > 0 and abs(u0.outputs()[1]) < 1e-12
    cmd = (MotorParams().R_s * i_a, 0.0)
    for td, von in ((t_dead, 0.0), (0.0, v_on), (t_dead, v_on)):
        u = _unit(f_sw=f_sw, t_dead=td, v_on=von)
        E = td * f_sw * V_DC
        for n in range(20):
            u.step(n * dt, dt, (*cmd, 0.0))
            i = u.outputs()[:2]
            ph = (i[0], -0.5 * i[0] + 0.5 * SQ3 * i[1], -0.5 * i[0] - 0.5 * SQ3 * i[1])
            assert ph[0] > 0 and ph[1] < 0 and ph[2] < 0
            o = u.outputs()
            assert o[V_A] == pytest.approx(cmd[0] - 4.0 * E / 3.0 - 4.0 * von / 3.0, abs=1e-9)
            assert o[V_B] == pytest.approx(0.0, abs=1e-9)


def test_dead_time_first_order_on_a_slow_current():
    """A slowly rotating current (2 Hz at 10 kHz switching): over each step the applied-minus-commanded
    phase voltage is -sign(i_x) t_dead f_sw V_dc to first order (steps where a phase current changes sign
    excluded)."""
    f_sw, t_dead, dt = 10000.0, 3e-6, 1e-4
    u = _unit(f_sw=f_sw, t_dead=t_dead, psi_r0=0.0)
    E = t_dead * f_sw * V_DC
    R = MotorParams().R_s
    checked = 0
    for n in range(2500):
        t = n * dt
        i_before = u.outputs()[:2]
        ang = 2.0 * math.pi * 2.0 * t
        va, vb = 40.0 * math.cos(ang), 40.0 * math.sin(ang)
        u.step(t, dt, (va, vb, 0.0))
        i_after = u.outputs()[:2]
        sa = [math.copysign(1.0, v) for v in _ph(i_before)]
        sb = [math.copysign(1.0, v) for v in _ph(i_after)]
        if sa != sb or min(abs(v) for v in _ph(i_before)) < 0.2:
            continue
        e = [-s * E for s in sa]
        ea, eb = (2 * e[0] - e[1] - e[2]) / 3.0, (e[1] - e[2]) / SQ3
        o = u.outputs()
        assert o[V_A] - va == pytest.approx(ea, abs=1e-3 * E)
        assert o[V_B] - vb == pytest.approx(eb, abs=1e-3 * E)
        checked += 1
    assert checked > 1000 and R > 0


def _ph(i):
    return (i[0], -0.5 * i[0] + 0.5 * SQ3 * i[1], -0.5 * i[0] - 0.5 * SQ3 * i[1])


def test_parameter_errors():
    for kw, field in (({"inverter": "svm"}, "inverter"), ({"f_sw": 0.0}, "f_sw"),
                      ({"t_dead": -1e-6}, "t_dead"), ({"t_dead": 1e-4}, "t_dead"), ({"v_on": 300.0}, "v_on"),
                      ({"V_dc": 0.0}, "V_dc"), ({"v_on": -1.0}, "v_on")):
        with pytest.raises(ParameterError) as e:
            PlantUnit(kw)
        assert e.value.field == field


def test_state_round_trip():
    u = _unit(t_dead=2e-6, v_on=1.0, f_sw=7000.0)
    for n in range(7):
        u.step(n * 1e-4, 1e-4, (150.0, 60.0, 0.0))
    s = u.get_state()
    u.step(7e-4, 1e-4, (150.0, -60.0, 0.0))
    after = u.get_state()
    u.set_state(s)
    u.step(7e-4, 1e-4, (150.0, -60.0, 0.0))
    assert u.get_state() == after


def test_compensation_closed_form():
    # i along +alpha: i_a > 0, i_b = i_c < 0: phase additions (+V, -V, -V) -> alpha 4V/3, beta 0
    assert compensate(10.0, 20.0, 5.0, 0.0, 6.0) == pytest.approx((10.0 + 8.0, 20.0), abs=1e-14)
    # i along +beta: i_a = 0 (adds nothing), i_b > 0, i_c < 0: (0, +V, -V) -> alpha 0, beta 2V/sqrt3
    assert compensate(0.0, 0.0, 0.0, 3.0, 6.0) == pytest.approx((0.0, 12.0 / SQ3), abs=1e-14)
    assert compensate(1.5, -2.5, 7.0, 8.0, 0.0) == (1.5, -2.5)


def test_controller_compensation_is_off_by_default_and_adds_when_on():
    vals = {"Ts": 1e-4}
    meas = (3.0, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.9, 0.0, 0.0)  # v_dc 0: not connected
    a, b = ControllerUnit(vals), ControllerUnit(dict(vals, deadtime_comp_voltage=0.0))
    c = ControllerUnit(dict(vals, deadtime_comp_voltage=5.0))
    for u in (a, b, c):
        u.step(0.0, 1e-4, meas)
    assert a.outputs() == b.outputs()
    assert c.outputs()[:2] == compensate(*a.outputs()[:2], 3.0, 0.5, 5.0)
    assert c.outputs()[2:] == a.outputs()[2:]
    with pytest.raises(ParameterError) as e:
        ControllerUnit(dict(vals, deadtime_comp_voltage=-1.0))
    assert e.value.field == "deadtime_comp_voltage"


# ---- the C core, bit for bit -----------------------------------------------------------------------

needs_gcc = pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")


@pytest.fixture(scope="module")
def lib():
    return nc.load()


def _c_setup(lib, values):
    motor = nc.new_motor(lib)
    msg = ctypes.create_string_buffer(1024)
    mp, pp = nc.params(lib, nc.MotorParams, values), nc.params(lib, nc.PlantParams, values)
    assert lib.sm_motor_init(motor, mp, pp, msg, 1024) == 0, msg.value
    inv = nc.new_inverter(lib)
    # the link voltage: the DC link's parameter V_dc (one parameter for the link and the inverter)
    st = lib.sm_inverter_init(inv, pp, nc.params(lib, nc.DCLinkParams, values).V_dc, msg, 1024)
    return st, motor, inv, msg.value.decode()


CASES = [
    dict(f_sw=5000.0),
    dict(f_sw=10000.0, t_dead=2e-6),
    dict(f_sw=7300.0, t_dead=3e-6, v_on=1.2),
    dict(f_sw=2500.0, t_dead=1e-5, v_on=0.7, V_dc=600.0),
    dict(f_sw=16000.0, t_dead=1e-6, h_int=2e-5, l_s=0.0),
]


@needs_gcc
@pytest.mark.parametrize("case", CASES)
def test_c_equals_python_bit_for_bit(lib, case):
    values = dict({"inverter": "pwm", "psi_r0": 0.8}, **case)
    u = PlantUnit(values)
    st, motor, inv, msg = _c_setup(lib, values)
    assert st == 0, msg
    x = (ctypes.c_double * 6)(*u.x)
    avg = (ctypes.c_double * 2)()
    # the native plant's path: sm_inverter_step_memo with the plant's solve memo (the same results)
    inv_m, x_m, avg_m = nc.new_inverter(lib), (ctypes.c_double * 6)(*u.x), (ctypes.c_double * 2)()
    ctypes.memmove(inv_m, inv, lib.sm_inverter_size())
    memo = (ctypes.c_double * 4)()
    lib.sm_solve_memo_clear(memo)
    cap = 4096
    tr = (ctypes.c_double * (7 * cap))()
    ntr = ctypes.c_size_t()
    rng = np.random.default_rng(17)
    t = 1.7e-5 if case.get("f_sw") == 7300.0 else 0.0  # an unaligned start too
    for n in range(300):
        dt = 1e-4 if n % 7 else float(rng.choice([5e-5, 2e-4, 3.3e-5]))
        va, vb = rng.uniform(-420, 420, 2) if n % 3 else rng.uniform(-60, 60, 2)
        T_load = float(rng.uniform(-5, 5))
        trace = []
        xp, a_p, b_p = u.inverter.step(u.plant, t, u.x, float(va), float(vb), T_load, dt, u.h_int, trace)
        u.x = xp
        assert lib.sm_inverter_step(inv, motor, x, t, dt, float(va), float(vb), T_load, avg, tr, cap,
                                    ctypes.byref(ntr)) == 0
        assert ntr.value == len(trace)
        got = [tuple(tr[7 * i:7 * i + 7]) for i in range(ntr.value)]
        assert got == trace, n
        assert tuple(x) == tuple(xp), n
        assert (avg[0], avg[1]) == (a_p, b_p), n
        assert lib.sm_inverter_step_memo(inv_m, motor, memo, x_m, t, dt, float(va), float(vb), T_load, avg_m,
                                         None, 0, None) == 0
        assert tuple(x_m) == tuple(xp) and (avg_m[0], avg_m[1]) == (a_p, b_p), n
        assert lib.sm_inverter_intervals_bound(inv, dt) == u.inverter.intervals_bound(dt)
        t += dt


@needs_gcc
def test_c_parameter_errors_equal_python(lib):
    for kw in ({"inverter": "svm"}, {"f_sw": 0.0}, {"t_dead": -1e-6}, {"t_dead": 1e-4}, {"v_on": 300.0},
               {"V_dc": 0.0}, {"v_on": -1.0}, {"V_dc": 100.0, "v_on": 50.0}):
        with pytest.raises(ParameterError) as e:
            PlantUnit(kw)
        st, _, _, msg = _c_setup(lib, kw)
        assert st == 1 and msg == str(e.value), kw


@needs_gcc
def test_c_duties_and_compensation_equal_python(lib):
    rng = np.random.default_rng(9)
    d = (ctypes.c_double * 3)()
    va, vb = ctypes.c_double(), ctypes.c_double()
    for _ in range(3000):
        a, b, V = rng.uniform(-500, 500), rng.uniform(-500, 500), rng.uniform(100, 800)
        lib.sm_inverter_duties(a, b, V, d)
        assert tuple(d) == duties(a, b, V)
        ia, ib, vc = rng.uniform(-9, 9), rng.uniform(-9, 9), float(rng.choice([0.0, rng.uniform(0, 20)]))
        if rng.uniform() < 0.1:
            ia = 0.0
        va.value, vb.value = a, b
        lib.sm_deadtime_compensate(ctypes.byref(va), ctypes.byref(vb), ia, ib, vc)
        assert (va.value, vb.value) == compensate(a, b, ia, ib, vc)


# ---- the plant FMUs ---------------------------------------------------------------------------------

@pytest.mark.parametrize("variant", ["python", "native", "native-fmi3"])
def test_plant_fmu_pwm_equals_the_plant_unit_and_restores_its_state(variant, fmu_dir):
    """The plant FMU with inverter = pwm (dead time, drops, an unaligned carrier) against PlantUnit, every
    output bit for bit; an FMU state taken mid-run and restored gives the same continuation."""
    from orchestration.packaging import fmus
    from orchestration.run.fmu_instance import FMUInstance

    values = {"inverter": "pwm", "f_sw": 7300.0, "t_dead": 3e-6, "v_on": 1.2, "psi_r0": 0.8}
    inst = FMUInstance(str(fmus.paths(fmu_dir, variant)[0]), "pwm")
    inst.set_parameters(values)
    inst.initialize(0.0)
    s = inst.slave
    get, set_ = (s.getFloat64, s.setFloat64) if inst.fmi3 else (s.getReal, s.setReal)
    outs, ins = inst.vr(list(PlantUnit.OUTPUTS)), inst.vr(list(PlantUnit.INPUTS))
    u = PlantUnit(values)
    rng = np.random.default_rng(23)
    cmds = [tuple(float(v) for v in (*rng.uniform(-300, 300, 2), rng.uniform(-5, 5))) for _ in range(60)]
    state = None
    for k, c in enumerate(cmds):
        if k == 30:
            state = s.getFMUState() if inst.fmi3 else s.getFMUstate()
            saved = u.get_state()
        set_(ins, list(c))
        s.doStep(k * 1e-4, 1e-4)
        u.step(k * 1e-4, 1e-4, c)
        assert get(outs) == list(u.outputs()), k
    end = get(outs)
    (s.setFMUState if inst.fmi3 else s.setFMUstate)(state)
    u.set_state(saved)
    for k in range(30, 60):
        set_(ins, list(cmds[k]))
        s.doStep(k * 1e-4, 1e-4)
    assert get(outs) == end
    inst.close()


@needs_gcc
def test_c_controller_compensation_equals_python(lib):
    """sm_controller with deadtime_comp_voltage against ControllerUnit over a closed loop on the pwm plant
    (the outputs bit for bit); and its check of a negative value."""
    ctl = lib  # the signatures read from the headers (native_core.declare)
    msg = ctypes.create_string_buffer(256)
    bad = nc.params(ctl, nc.ControllerParams, {"deadtime_comp_voltage": -1.0})
    buf = ctypes.create_string_buffer(ctl.sm_controller_size())
    assert ctl.sm_controller_init(buf, bad, nc.params(ctl, nc.MotorParams), msg, 256) == 1
    with pytest.raises(ParameterError) as e:
        ControllerUnit({"deadtime_comp_voltage": -1.0})
    assert msg.value.decode() == str(e.value)
    vals = {"deadtime_comp_voltage": 12.3}
    cp = nc.params(ctl, nc.ControllerParams, vals)
    assert ctl.sm_controller_init(buf, cp, nc.params(ctl, nc.MotorParams), msg, 256) == 0, msg.value
    py, plant = ControllerUnit(vals), _unit(t_dead=4e-6, v_on=1.5, psi_r0=0.0)
    out_c = ctypes.cast(ctypes.addressof(buf) + ctl.sm_controller_size() - 8 * len(ControllerUnit.OUTPUTS),
                        ctypes.POINTER(ctypes.c_double))
    for k in range(3000):
        t = k * 1e-4
        o = plant.outputs()
        row = (o[0], o[1], o[4], o[5], o[2], o[3], o[6], 10.0 if t > 0.2 else 0.0, 0.95, 0.0, 0.0)  # v_dc: 0
        py.step(t, 1e-4, row)
        assert ctl.sm_controller_step(buf, t, 1e-4, (ctypes.c_double * 11)(*row), msg, 256) == 0, msg.value
        c = py.outputs()
        assert [out_c[j] for j in range(len(c))] == [float(v) for v in c], k
        plant.step(t, 1e-4, (c[0], c[1], 0.0))


def test_scenario_sets_the_inverter_and_notes_a_link_the_controller_does_not_assume(tmp_path):
    """The inverter parameters are scenario parameters; a pwm plant whose V_dc differs from the
    controller's is a note (allowed, said), a bad one a problem naming it."""
    from orchestration.scenario.problems import Note
    from orchestration.scenario.validate import check_scenario_file

    path = Path(__file__).resolve().parents[1] / "scenarios" / "pwm_low_speed.yaml"
    src = path.read_text()
    assert check_scenario_file(path) == ([], [])
    f = tmp_path / "link.yaml"
    f.write_text(src.replace("  V_dc: 540.0 ", "  V_dc: 600.0 "))
    problems, (note,) = check_scenario_file(f)
    assert not problems and isinstance(note, Note) and note.field == "plant.V_dc" and "600 V" in note.message
    g = tmp_path / "bad.yaml"
    g.write_text(src.replace("  t_dead: 4.0e-6 ", "  t_dead: 1.0e-3 "))
    problems = check_scenario_file(g)[0]
    assert problems and "t_dead" in str(problems[0]), problems


@pytest.mark.parametrize("variant", ["python", "native", "native-fmi3"])
def test_plant_fmu_step_average_equals_the_command(variant, fmu_dir):
    """Through the FMU: inverter = pwm, no dead time or drops, 5 and 10 kHz at 100 us steps: the outputs
    v_avg_alpha/beta equal the inputs v_s_alpha/beta (the average-value model's voltage) to rounding."""
    from orchestration.packaging import fmus
    from orchestration.run.fmu_instance import FMUInstance

    for f_sw in (5000.0, 10000.0):
        inst = FMUInstance(str(fmus.paths(fmu_dir, variant)[0]), "avg")
        inst.set_parameters({"inverter": "pwm", "f_sw": f_sw, "psi_r0": 0.9})
        inst.initialize(0.0)
        s = inst.slave
        get, set_ = (s.getFloat64, s.setFloat64) if inst.fmi3 else (s.getReal, s.setReal)
        outs, ins = inst.vr(["v_avg_alpha", "v_avg_beta"]), inst.vr(["v_s_alpha", "v_s_beta", "T_load"])
        rng = np.random.default_rng(29)
        worst = 0.0
        for k in range(300):
            r, ang = rng.uniform(0.0, V_DC / SQ3), rng.uniform(0.0, 2.0 * math.pi)
            cmd = [r * math.cos(ang), r * math.sin(ang), 0.0]
            set_(ins, cmd)
            s.doStep(k * 1e-4, 1e-4)
            got = get(outs)
            worst = max(worst, abs(got[0] - cmd[0]), abs(got[1] - cmd[1]))
        inst.close()
        print(f"{variant}, f_sw = {f_sw} Hz: worst |v_avg - v_s| = {worst:.3g} V over 300 steps")
        assert worst <= 1e-12 * V_DC


SANITIZED_RUN = """
import ctypes, sys
sys.path.insert(0, {tests!r})
import native_core as nc
lib = nc.declare(ctypes.CDLL({lib!r}))
msg = ctypes.create_string_buffer(64)  # short: messages are truncated, never overrun
for bad in ({{"inverter": "x" * 1000}}, {{"f_sw": 0.0}}, {{"t_dead": 1.0}}, {{"v_on": 1e3}}):
    inv = nc.new_inverter(lib)
    assert lib.sm_inverter_init(inv, nc.params(lib, nc.PlantParams, bad), 540.0, msg, 64) == 1
for case in ({{"inverter": "pwm", "t_dead": 3e-6, "v_on": 1.0, "psi_r0": 0.8}},
             {{"inverter": "pwm", "f_sw": 7300.0, "t_dead": 1e-5}}):
    motor, inv = nc.new_motor(lib), nc.new_inverter(lib)
    mp, pp = nc.params(lib, nc.MotorParams, case), nc.params(lib, nc.PlantParams, case)
    assert lib.sm_motor_init(motor, mp, pp, msg, 64) == 0
    assert lib.sm_inverter_init(inv, pp, 540.0, msg, 64) == 0
    x = (ctypes.c_double * 6)()
    lib.sm_plant_initial_state(motor, 0.0, 0.0, 0.8, 0.0, x)
    avg, tr, n = (ctypes.c_double * 2)(), (ctypes.c_double * 21)(), ctypes.c_size_t()
    t = 1.3e-5
    for k in range(400):
        dt = (1e-4, 3.3e-5, 2e-4)[k % 3]
        va, vb = (300.0 * (k % 7 - 3), 120.0 * (k % 5 - 2))
        assert lib.sm_inverter_step(inv, motor, x, t, dt, va, vb, 1.0, avg, tr, 3, ctypes.byref(n)) == 0
        assert n.value >= 1
        assert lib.sm_inverter_step(inv, motor, x, t + dt, dt, va, vb, 1.0, avg, None, 0, None) == 0
        t += 2 * dt
    assert lib.sm_inverter_step(inv, motor, x, t, float("nan"), 0.0, 0.0, 0.0, avg, None, 0, None) == 3
print("SANITIZED RUN OK")
"""


@needs_gcc
def test_inverter_under_address_and_undefined_behaviour_sanitizers(tmp_path):
    import os
    import subprocess

    gcc = shutil.which("gcc")
    asan = subprocess.run([gcc, "-print-file-name=libasan.so"], capture_output=True, text=True).stdout.strip()
    if not os.path.isabs(asan) or not os.path.exists(asan):
        pytest.skip("no libasan runtime")
    lib = nc.build(nc.SANITIZE, tmp_path)
    script = tmp_path / "run.py"
    script.write_text(SANITIZED_RUN.format(tests=str(Path(__file__).parent), lib=str(lib)))
    env = dict(os.environ, LD_PRELOAD=asan, ASAN_OPTIONS="detect_leaks=0:abort_on_error=0:exitcode=99",
               UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:exitcode=98")
    res = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, env=env, timeout=300)
    report = res.stdout + res.stderr
    assert res.returncode == 0 and "SANITIZED RUN OK" in res.stdout, report[:4000]
    assert "AddressSanitizer" not in report and "runtime error" not in report, report[:4000]


@pytest.mark.parametrize("param", [{"dc_link": "capacitor"}, {"R_fe": 500.0}, {"thermal": True},
                                   {"dc_link": "capacitor", "R_fe": 500.0, "thermal": True}])
def test_pwm_takes_the_capacitor_link_core_loss_and_the_thermal_model(param):
    """inverter = pwm with dc_link = capacitor, R_fe > 0 or the thermal model (refused until issue 19 item
    5 was made whole): accepted; on the ideal link with zero dead time and drops the step average is still
    the command exactly (the switched voltages do not depend on the plant), on the capacitor link the
    link voltage moves with the motor's power."""
    u = PlantUnit({"inverter": "pwm", "psi_r0": 0.8, **param})
    for k in range(20):
        cmd = (250.0 * math.cos(300.0 * k * 1e-4), 250.0 * math.sin(300.0 * k * 1e-4), 3.0)
        u.step(k * 1e-4, 1e-4, cmd)
        out = dict(zip(PlantUnit.OUTPUTS, u.outputs()))
        if param.get("dc_link") != "capacitor":
            assert abs(out["v_avg_alpha"] - cmd[0]) < 1e-9 and abs(out["v_avg_beta"] - cmd[1]) < 1e-9
    assert all(math.isfinite(v) for v in u.outputs())
    if param.get("dc_link") == "capacitor":
        assert out["v_dc"] != 540.0


@pytest.mark.parametrize("variant", ["native", "python"])
@pytest.mark.parametrize("param", [("dc_link", "capacitor"), ("R_fe", 500.0), ("thermal", True)])
def test_the_plant_fmu_takes_pwm_with_them(fmu_dir, variant, param):
    """The co-simulation plant FMUs initialize and step with pwm and each of them, as PlantUnit (its
    outputs bit for bit: tests/test_plant_combinations.py)."""
    from fmu_helpers import Slave, open_fmu

    path = fmu_dir / ("native" if variant == "native" else "") / "SaturatedInductionMotor.fmu"
    s = Slave(open_fmu(path), initialize=False)
    values = {"inverter": "pwm", param[0]: param[1], "psi_r0": 0.8}
    s.initialize(values)
    u = PlantUnit(values)
    for k in range(5):
        s.step(k * 1e-4, 1e-4, {"v_s_alpha": 200.0, "v_s_beta": -50.0, "T_load": 1.0})
        u.step(k * 1e-4, 1e-4, (200.0, -50.0, 1.0))
    assert s.get(list(PlantUnit.OUTPUTS)) == list(u.outputs()), s.messages()
    s.free()


def test_a_scenario_with_pwm_and_the_capacitor_link_is_accepted(tmp_path):
    """The scenario check takes pwm on the capacitor link (no refusal naming plant.inverter)."""
    from orchestration.scenario.validate import validate_scenario_file

    src = (Path(__file__).resolve().parents[1] / "scenarios" / "pwm_low_speed.yaml").read_text()
    assert "\nplant:\n" in src
    path = tmp_path / "combo.yaml"
    path.write_text(src.replace("\nplant:\n", "\nplant:\n  dc_link: capacitor\n", 1))
    text = "\n".join(str(p) for p in validate_scenario_file(path))
    assert "cannot be combined" not in text and "plant.inverter" not in text, text
