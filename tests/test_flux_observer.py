"""ClosedLoopObserver (satmotor.estimation.flux_observer) against the plant's true flux and speed and against
the closed form of its error dynamics; the C twin (fmu/native/core/sm_flux_observer.c) sample by sample.

The plant (satmotor.machine.plant, its own equations and integrator) runs at a constant speed (a huge
inertia) from a rotating stator voltage; the observer gets the plant's sampled stator currents, the
voltage applied and (unless it estimates it) the speed.  Expected values: the plant's state, and the
error equation of the module docstring, e' = -b e with b = a = R_r/(l_r + k^2 m) on a linear curve
(a real pole: the error decays without turning, at any speed), written out here.
"""

import ctypes
import math
from dataclasses import replace

import numpy as np
import pytest
from native_core import build, declare

from satmotor.errors import ParameterError
from satmotor.estimation.flux_observer import N_STATE, ClosedLoopObserver
from satmotor.estimation.observer import RotorFluxObserver
from satmotor.machine.library import preset
from satmotor.machine.magnetics import LinearCurve
from satmotor.machine.params import MotorParams
from satmotor.machine.plant import OMEGA_M, PSI_R_A, PSI_R_B, Plant, initial_state

P = MotorParams()
GAMMA = preset("qu2012_2kw2").params()  # the Gamma form: l_s = 0, k = 1, the polynomial curve
TS = 1e-4


def plant_run(p, omega, t_end, v_amp=300.0, settle=0.6):
    """The plant at constant speed omega [rad/s] (J = 1e6) under a rotating voltage at the stator
    frequency of a slip of 4 rad/s; returns per sample (i_sa, i_sb, v_a, v_b, psi_ra, psi_rb, omega)
    after ``settle`` [s]."""
    pl = replace(p, J=1e6)
    plant = Plant(pl)
    x = initial_state(pl, omega_m=omega, psi_r_alpha=0.9)
    ws = p.n_p * omega + 4.0
    amp = v_amp * max(abs(ws), 20.0) / 314.0
    rows = []
    n_settle, n = round(settle / TS), round((settle + t_end) / TS)
    for k in range(n + 1):
        t = k * TS
        va, vb = amp * math.cos(ws * t), amp * math.sin(ws * t)
        if k >= n_settle:
            o = plant.outputs(x)
            rows.append((o.i_s_alpha, o.i_s_beta, va, vb, x[PSI_R_A], x[PSI_R_B], x[OMEGA_M]))
        x = plant.step(t, x, va, vb, 0.0, TS, 1)
    return rows


def observe(obs, rows, w_input=None):
    est = []
    for isa, isb, va, vb, _, _, w in rows:
        est.append(obs.update(isa, isb, w if w_input is None else w_input))
        obs.applied(va, vb)
    return est


@pytest.mark.parametrize("l_s", [5.839e-3, 0.0], ids=["T form", "Gamma form"])
@pytest.mark.parametrize("omega", [0.0, 10.0, 50.0, 100.0])
def test_error_decays_at_the_rotor_rate_without_turning_on_a_linear_curve(omega, l_s):
    p = MotorParams(l_s=l_s, curve=LinearCurve(0.2772))
    rows = plant_run(p, omega, 0.06)
    obs = ClosedLoopObserver(p, TS)
    obs.reset(rows[0][4] + 0.2, rows[0][5] - 0.1)  # a wrong start: error (-0.2, +0.1) Wb
    est = observe(obs, rows)
    b = p.R_r / (p.l_r + p.k ** 2 * 0.2772)  # the closed form's pole, written out
    e0 = complex(rows[1][4] - est[1][0], rows[1][5] - est[1][1])
    for k in (100, 200, 400, 599):
        e = complex(rows[k][4] - est[k][0], rows[k][5] - est[k][1])
        want = e0 * math.exp(-b * (k - 1) * TS)
        assert abs(e - want) <= 0.01 * abs(e0), (omega, k, e, want)
    # the open-loop current model's error turns at the rotor speed: a different, checkable behaviour
    if omega >= 50.0:
        cm = RotorFluxObserver(p, TS)
        cm.reset(rows[0][4] + 0.2, rows[0][5] - 0.1)
        est_cm = [cm.update(r[0], r[1], r[6]) for r in rows]
        ec = [complex(r[4] - q[0], r[5] - q[1]) for r, q in zip(rows, est_cm)]
        turned = abs(math.remainder(np.angle(ec[400]) - np.angle(ec[1]), 2 * math.pi))
        assert turned > 0.5


@pytest.mark.parametrize("omega", [10.0, 50.0, 100.0])
def test_a_wrong_rotor_resistance_leaves_far_less_flux_error_than_the_current_model(omega):
    rows = plant_run(P, omega, 0.3)
    model = replace(P, R_r=P.R_r / 1.5)  # the plant's R_r is 50 % above the model's
    errs = {}
    for name, obs in (("closed", ClosedLoopObserver(model, TS)), ("current", RotorFluxObserver(model, TS))):
        obs.reset(rows[0][4], rows[0][5])
        est = [obs.update(r[0], r[1], r[6]) + (obs.applied(r[2], r[3]) if name == "closed" else None,)
               for r in rows]
        errs[name] = max(abs(math.hypot(*q[:2]) - math.hypot(r[4], r[5]))
                         for r, q in zip(rows[-500:], est[-500:]))
    print(omega, errs)
    assert errs["closed"] < 0.2 * errs["current"]
    assert errs["closed"] < {10.0: 0.02, 50.0: 5e-3, 100.0: 2e-3}[omega]  # [Wb] of about 0.9


@pytest.mark.parametrize("p", [P, GAMMA], ids=["default (T form)", "qu2012_2kw2 (Gamma form, l_s = 0)"])
@pytest.mark.parametrize("omega", [-60.0, 20.0, 100.0])
def test_the_speed_estimate_converges_to_the_plants_speed_without_reading_it(omega, p):
    rows = plant_run(p, omega, 0.4)
    obs = ClosedLoopObserver(p, TS, estimate_speed=True)
    obs.reset(rows[0][4], rows[0][5], 0.0)
    est = observe(obs, rows, w_input=math.nan)  # the speed argument is not read
    w_hat = np.array([q[2] for q in est[-1000:]])
    assert abs(w_hat.mean() - omega) <= 0.005 * abs(omega)
    psi = [math.hypot(r[4], r[5]) for r in rows[-1000:]]
    psi_hat = [math.hypot(q[0], q[1]) for q in est[-1000:]]
    assert max(abs(a - b) for a, b in zip(psi, psi_hat)) <= 0.01


def test_state_round_trip_and_argument_checks():
    rows = plant_run(P, 50.0, 0.02)
    a, b = ClosedLoopObserver(P, TS, True), ClosedLoopObserver(P, TS, True)
    observe(a, rows[:100])
    b.set_state(a.get_state())
    assert len(a.get_state()) == N_STATE
    assert observe(a, rows[100:]) == observe(b, rows[100:])
    with pytest.raises(ParameterError) as e:
        ClosedLoopObserver(P, 0.0)
    assert e.value.field == "Ts"
    with pytest.raises(ParameterError) as e:
        ClosedLoopObserver(P, TS, alpha_w=-1.0)
    assert e.value.field == "alpha_w"
    with pytest.raises(ParameterError):
        a.set_state((0.0,) * (N_STATE - 1))


D = ctypes.c_double


@pytest.fixture(scope="module")
def lib():
    return declare(ctypes.CDLL(str(build())))  # the signatures read from the headers


def _c_curve(lib, c, msg):
    buf = ctypes.create_string_buffer(lib.sm_curve_size())
    defaults = (("L_m0", 0.2772), ("L_m_inf", 0.01), ("I_par", 3.31), ("poly_b", 2.46))
    args = [getattr(c, n, d) for n, d in defaults]
    assert lib.sm_curve_init(buf, c.name.encode(), *args, int(getattr(c, "poly_n", 7)), b"", msg, 256) == 0
    return buf


@pytest.mark.parametrize("tracking", [False, True], ids=["as given", "R_s adapted, R_r tracked"])
@pytest.mark.parametrize("p", [P, GAMMA], ids=["default (T form)", "qu2012_2kw2 (Gamma form, l_s = 0)"])
@pytest.mark.parametrize("estimate_speed", [False, True])
def test_c_observer_is_the_python_one_bit_for_bit(lib, estimate_speed, p, tracking):
    msg = ctypes.create_string_buffer(256)
    curve = _c_curve(lib, p.curve, msg)
    obs = ctypes.create_string_buffer(lib.sm_cl_observer_size())
    assert lib.sm_cl_observer_init(obs, p.R_s, p.R_r, p.l_s, p.l_r, p.k, p.n_p, TS, int(estimate_speed),
                                   200.0, msg, 256) == 0, msg.value
    assert lib.sm_cl_observer_set_tracking(obs, int(tracking), int(tracking), msg, 256) == 0
    assert lib.sm_cl_observer_reset(obs, 0.5, -0.2, 3.0, msg, 256) == 0
    py = ClosedLoopObserver(p, TS, estimate_speed, 200.0, tracking, tracking)
    py.reset(0.5, -0.2, 3.0)
    rng = np.random.default_rng(5)
    pa, pb, w = D(), D(), D()
    state = (D * N_STATE)()
    hot = replace(p, R_s=1.3 * p.R_s, R_r=1.3 * p.R_r) if tracking else p  # a warm plant
    for j, r in enumerate(plant_run(hot, 70.0, 0.1, settle=0.05)):
        isa, isb = r[0] + rng.normal(0, 0.3), r[1] + rng.normal(0, 0.3)
        want = py.update(isa, isb, r[6] + rng.normal(0, 1.0))
        assert lib.sm_cl_observer_update(obs, curve, isa, isb, r[6] + 0.0 if estimate_speed else want[2],
                                         ctypes.byref(pa), ctypes.byref(pb), ctypes.byref(w)) == 0
        assert (pa.value, pb.value, w.value) == want, j
        py.applied(r[2], r[3])
        lib.sm_cl_observer_applied(obs, r[2], r[3])
        if tracking:
            py.adapt_resistance()
            lib.sm_cl_observer_adapt_resistance(obs)
        lib.sm_cl_observer_get_state(obs, state)
        assert tuple(state) == py.get_state(), j
    if tracking:  # the adaptation ran (and, with the speed measured, toward the plant's)
        rs, rr = py.resistances
        assert rs != p.R_s and rr == p.R_r * (1.0 + 4.03e-3 / 3.93e-3 * (rs / p.R_s - 1.0))
        assert estimate_speed or (rs > 1.05 * p.R_s and rr > 1.05 * p.R_r)


def test_c_observer_refuses_bad_arguments_by_name(lib):
    obs = ctypes.create_string_buffer(lib.sm_cl_observer_size())
    msg = ctypes.create_string_buffer(256)
    assert lib.sm_cl_observer_init(obs, 1.4, 1.4, 6e-3, 6e-3, 1.0, 2, TS, 1, 0.0, msg, 256) != 0
    assert msg.value.decode().startswith("alpha_w = ")
    assert lib.sm_cl_observer_init(obs, math.nan, 1.4, 6e-3, 6e-3, 1.0, 2, TS, 1, 200.0, msg, 256) != 0
    assert msg.value.decode().startswith("R_s = ")
    assert lib.sm_cl_observer_init(obs, 1.4, 1.4, -1e-9, 6e-3, 1.0, 2, TS, 1, 200.0, msg, 256) != 0
    assert msg.value.decode() == "l_s = -1e-09: must be a finite number >= 0"
    assert lib.sm_cl_observer_init(obs, 1.4, 1.4, 0.0, 0.0, 1.0, 2, TS, 1, 200.0, msg, 256) != 0
    assert msg.value.decode().startswith("l_r = ")
    assert lib.sm_cl_observer_init(obs, 1.4, 1.4, 0.0, 6e-3, 1.0, 2, TS, 1, 200.0, msg, 256) == 0  # Gamma
