"""The loss-minimizing flux set-point (satmotor/control/loss_min.py, fmu/native/core/sm_lossmin.c).

* The optimum against a dense grid of fluxes, the losses computed here from the plant's own steady
  state (the plant integrated to steady state at that flux; copper losses from its currents).
* The bounds: the floor, the upper flux (nominal or field weakening), the current limit, the rate limit.
* C against Python at random operating points on every curve family, with and without core loss:
  the same floats.
* The drive: flux_mode nominal is today's drive bit for bit; loss_minimizing lowers the flux at light
  load and raises it on a load step at the stated rate.
The brute-force check through the plant FMU: tests/test_loss_min_cosim.py (slow).
"""

from __future__ import annotations

import ctypes
import math
import random

import pytest
from native_core import MotorParams as CMotorParams
from native_core import load, new_motor, params

from satmotor.control.drive_config import DriveConfig
from satmotor.control.loss_min import LossMinimizer, steady_losses
from satmotor.errors import ParameterError
from satmotor.interface import ControllerUnit, PlantUnit
from satmotor.machine.library import preset
from satmotor.machine.params import MotorParams, make_curve

D = ctypes.c_double
P = MotorParams()
QU = preset("qu2012_2kw2").params()


def _plant_losses(p, Phi, T, w):
    """Stator and rotor copper loss [W] of the steady state at the rotor flux Phi [Wb], torque T [N m] and
    speed w [rad/s], from the machine equations written here (not the module's parametrization by I): in
    the rotor-flux frame psi_r = k psi_m + l_r i_r, i_mu = i_s + k i_r, and in steady state i_rd = 0, so
    psi_md = Phi / k, psi_mq from the torque, i_rq = -k psi_mq / l_r; the curve inverted by bisection."""
    k, l_r = p.k, p.l_r
    pmd = Phi / k
    pmq = T * l_r / (1.5 * p.n_p * k * k * pmd)
    psi = math.hypot(pmd, pmq)
    lo, hi = 0.0, 100.0
    for _ in range(64):  # the curve's current at psi, by bisection
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if p.curve.psi(mid) < psi else (lo, mid)
    m = psi / (0.5 * (lo + hi))
    i_rq = -k * pmq / l_r
    i_rd = 0.0
    i_mu_d, i_mu_q = pmd / m, pmq / m
    i_sd, i_sq = i_mu_d - k * i_rd, i_mu_q - k * i_rq
    return 1.5 * (p.R_s * (i_sd ** 2 + i_sq ** 2) + p.R_r * i_rq ** 2)


@pytest.mark.parametrize("p, T_n", [(P, 26.71), (QU, 14.6)], ids=["default", "qu2012_2kw2"])
@pytest.mark.parametrize("frac", [0.1, 0.5, 1.0])
def test_the_optimum_is_the_least_loss_of_a_dense_grid(p, T_n, frac):
    T, w = frac * T_n, 100.0
    got = LossMinimizer(p, 1e-4, 0.2, 5.0, 0.0).optimum(T, w, 1.3)
    coarse = min((0.2 + 0.01 * j for j in range(111)), key=lambda F: _plant_losses(p, F, T, w))
    best = min((coarse - 0.02 + 0.0002 * j for j in range(201)), key=lambda F: _plant_losses(p, F, T, w))
    assert abs(got - best) <= 1e-3 * best
    assert _plant_losses(p, got, T, w) <= _plant_losses(p, best, T, w) * (1 + 1e-6)


def test_the_module_losses_are_the_machine_equations():
    rng = random.Random(3)
    for p in (P, QU):
        for _ in range(50):
            T, w, I = rng.uniform(-30, 30), rng.uniform(-200, 200), rng.uniform(0.5, 12.0)
            pt = steady_losses(p, I, T, w, 0.0)
            if pt is None:
                continue
            assert pt[1] == pytest.approx(_plant_losses(p, pt[0], T, w), rel=1e-9)


def test_core_loss_lowers_the_optimum_at_speed():
    lm0, lm1 = LossMinimizer(P, 1e-4, 0.2, 5.0, 0.0), LossMinimizer(P, 1e-4, 0.2, 5.0, 400.0)
    a, b = lm0.optimum(10.0, 140.0, 1.3), lm1.optimum(10.0, 140.0, 1.3)
    assert b < a - 0.02
    # at standstill-like low speed core loss hardly matters
    assert lm1.optimum(10.0, 1.0, 1.3) == pytest.approx(lm0.optimum(10.0, 1.0, 1.3), rel=2e-3)


def test_bounds_floor_upper_flux_and_current_limit():
    lm = LossMinimizer(P, 1e-4, 0.4, 5.0, 0.0)
    assert lm.optimum(0.0, 100.0, 0.95) == pytest.approx(0.4, rel=1e-4)  # no load: the floor
    assert lm.optimum(26.71, 100.0, 0.9) == pytest.approx(0.9, rel=1e-4)  # the optimum 1.08 Wb is above
    assert lm.optimum(5.0, 100.0, 0.3) == 0.3  # upper flux below the floor: the upper flux
    free = lm.optimum(26.71, 100.0, 1.3)
    i_free = steady_losses(P, _current_at(P, free, 26.71), 26.71, 100.0, 0.0)[2]
    bound = 0.97 * i_free  # a bound below the loss optimum's current: the flux moves towards least current
    lim = lm.optimum(26.71, 100.0, 1.3, bound)
    i_lim = steady_losses(P, _current_at(P, lim, 26.71), 26.71, 100.0, 0.0)[2]
    assert i_lim < i_free and lim != free


def _current_at(p, Phi, T):
    pmd = Phi / p.k
    return p.curve.current(math.hypot(pmd, T * p.l_r / (1.5 * p.n_p * p.k ** 2) / pmd))


def test_rate_limit_and_field_weakening_take_the_smaller():
    Ts, rate = 1e-4, 5.0
    lm = LossMinimizer(P, Ts, 0.25, rate, 0.0)
    lm.reset(0.95)
    got = [lm.set_point(1.0, 100.0, 0.95) for _ in range(3)]
    assert got == pytest.approx([0.95 - rate * Ts, 0.95 - 2 * rate * Ts, 0.95 - 3 * rate * Ts], abs=1e-15)
    assert lm.set_point(1.0, 100.0, 0.5) == 0.5  # a lower upper flux (field weakening) at once
    assert lm.psi > 0.5  # while the rate-limited state moves on


@pytest.mark.parametrize("field, value", [("flux_mode", "minimal"), ("flux_floor", 0.0),
                                          ("flux_rate_max", -1.0), ("loss_R_fe", -1.0),
                                          ("flux_rate_max", math.nan)])
def test_bad_settings_are_refused_naming_them(field, value):
    with pytest.raises(ParameterError) as exc:
        DriveConfig(**{field: value})
    assert exc.value.field == field


# ------------------------------------------------------------------------------ C against Python

@pytest.fixture(scope="module")
def lib():
    return load()


def _motors(lib, tmp_path):
    tf = tmp_path / "curve.csv"
    c = make_curve("arctan")
    tf.write_text("i_mu,psi_m\n" + "".join(f"{x!r},{c.psi(x)!r}\n" for x in [0.5 * i for i in range(1, 41)]))
    rng = random.Random(35)
    for name in ("arctan", "exponential", "polynomial", "table", "linear"):
        for k in (1.0, 0.83):
            L_m0, I_par = (0.330, 3.66) if name == "exponential" else (0.2772, 3.31)
            vals = dict(R_s=1.405 * rng.uniform(0.7, 1.3), R_r=1.395 * rng.uniform(0.7, 1.3),
                        l_s=5.839e-3 * rng.uniform(0.7, 1.3) * (k == 1.0),
                        l_r=5.839e-3 * rng.uniform(0.7, 1.3), k=k, n_p=rng.choice((1, 2, 3)), J=0.0131,
                        B=2.985e-3, curve=name, L_m0=L_m0, L_m_inf=0.01, I_par=I_par, poly_b=2.46, poly_n=7,
                        table_file=str(tf) if name == "table" else "")
            curve = make_curve(name, L_m0, 0.01, I_par, 2.46, 7, vals["table_file"])
            p = MotorParams(vals["R_s"], vals["R_r"], vals["l_s"], vals["l_r"], k, vals["n_p"], 0.0131,
                            2.985e-3, curve)
            buf = new_motor(lib)
            msg = ctypes.create_string_buffer(256)
            assert lib.sm_motor_init(buf, params(lib, CMotorParams, vals), None, msg, 256) == 0, msg.value
            yield f"{name}, k={k}", p, buf


def test_c_loss_minimizer_equals_the_python(lib, tmp_path):
    rng = random.Random(36)
    n = n_floor = n_upper = n_inner = 0
    for label, p, buf in _motors(lib, tmp_path):
        for R_fe in (0.0, rng.uniform(200.0, 2000.0)):
            Ts, floor, rate = 1e-4, rng.uniform(0.1, 0.5), rng.uniform(0.5, 20.0)
            lm = LossMinimizer(p, Ts, floor, rate, R_fe)
            clm = (D * 4)()
            lib.sm_lm_init(clm, Ts, floor, rate, R_fe)
            out, got = (D * 3)(), D()
            for _ in range(60):
                T, w, psi_hi = rng.uniform(-40.0, 40.0), rng.uniform(-400.0, 400.0), rng.uniform(0.05, 1.3)
                I_mu, i_lim = rng.uniform(0.01, 12.0), rng.choice((math.inf, rng.uniform(3.0, 30.0)))
                pt = steady_losses(p, I_mu, T, w, R_fe)
                assert lib.sm_lm_steady_losses(buf, I_mu, T, w, R_fe, out) == (pt is not None), label
                if pt is not None:
                    assert tuple(out) == pt, (label, I_mu, T, w)
                want = lm.optimum(T, w, psi_hi, i_lim)
                assert lib.sm_lm_optimum(clm, buf, T, w, psi_hi, i_lim, ctypes.byref(got)) == 0
                assert got.value == want, (label, T, w, psi_hi, i_lim)
                want = lm.set_point(T, w, psi_hi, i_lim)
                assert lib.sm_lm_set_point(clm, buf, T, w, psi_hi, i_lim, ctypes.byref(got)) == 0
                assert (got.value, clm[3]) == (want, lm.psi), label
                n += 1
                opt = lm.optimum(T, w, psi_hi, i_lim)
                n_upper += opt == psi_hi
                n_floor += abs(opt - floor) < 1e-6
                n_inner += floor + 1e-6 < opt < psi_hi
    print(f"\n[loss minimizer] {n} operating points equal in C and Python: {n_inner} inner optima, "
          f"{n_floor} at the floor, {n_upper} at the upper flux")
    assert n_inner > n // 4 and n_upper > n // 20


# ------------------------------------------------------------------------------ the drive

def _loop(values, t_end, T_load, t_step, w_set=100.0, psi=0.95, plant_values=None):
    plant = PlantUnit({"omega_m0": w_set, "psi_r0": psi, **(plant_values or {})})
    ctrl = ControllerUnit(values)
    Ts = ctrl.Ts
    rows = []
    for k in range(round(t_end / Ts)):
        t = k * Ts
        o = plant.outputs()
        load = T_load if t >= t_step else 0.1 * T_load
        ctrl.step(t, Ts, (o[0], o[1], o[4], o[5], o[2], o[3], o[6], w_set, psi, load, 0.0))
        out = ctrl.outputs()
        rows.append((t, math.hypot(o[4], o[5]), out[0], out[1], o[0], o[1], o[6]))
        plant.step(t, Ts, (out[0], out[1], load))
    return rows


def test_nominal_is_the_drive_of_before_bit_for_bit():
    a = _loop({}, 0.1, 10.0, 0.05)
    b = _loop({"flux_mode": "nominal", "flux_floor": 0.3, "flux_rate_max": 1.0, "loss_R_fe": 100.0}, 0.1,
              10.0, 0.05)
    assert a == b


def test_light_load_lowers_the_flux_and_a_load_step_raises_it_at_the_rate():
    rate = 5.0
    rows = _loop({"flux_mode": "loss_minimizing", "flux_rate_max": rate}, 0.8, 26.71, 0.4)
    phi = [r[1] for r in rows]
    w = [r[6] for r in rows]
    lm = LossMinimizer(P, 1e-4, 0.25, rate, 0.0)
    light, rated = lm.optimum(2.671 + P.B * 100, 100.0, 0.95), lm.optimum(26.71 + P.B * 100, 100.0, 0.95)
    assert phi[3999] == pytest.approx(light, rel=0.01)  # 0.4 s: settled at the light-load optimum
    assert phi[-1] == pytest.approx(min(rated, 0.95), rel=0.01)
    # the rise: no faster than the rate limit (and the shaper) allow
    for j in range(4000, len(phi) - 100, 100):
        assert phi[j + 100] - phi[j] <= rate * 0.01 * 1.02
    assert min(w[4000:]) > 95.0  # the speed holds through the step


def test_get_and_set_state_restore_the_rate_limited_set_point():
    values = {"flux_mode": "loss_minimizing"}
    plant, ctrl = PlantUnit({"omega_m0": 100.0, "psi_r0": 0.95}), ControllerUnit(values)
    Ts = ctrl.Ts

    def steps(k0, n):
        out = []
        for k in range(k0, k0 + n):
            o = plant.outputs()
            ctrl.step(k * Ts, Ts, (o[0], o[1], o[4], o[5], o[2], o[3], o[6], 100.0, 0.95, 5.0, 0.0))
            c = ctrl.outputs()
            out.append(tuple(c))
            plant.step(k * Ts, Ts, (c[0], c[1], 5.0))
        return out

    steps(0, 500)  # the flux set-point on its way down
    s_ctrl, s_plant = ctrl.drive.get_state(), plant.get_state()
    first = steps(500, 50)
    ctrl.drive.set_state(s_ctrl)
    plant.set_state(s_plant)
    assert steps(500, 50) == first
    assert len(s_ctrl) == len(ControllerUnit({}).drive.get_state()) + 1  # one state more: the set-point
