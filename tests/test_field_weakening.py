"""Automatic field weakening (satmotor/control/field_weakening.py, fmu/native/core/sm_fieldweak.c).

* The steady state it computes is checked against the plant (satmotor/machine/plant.py, flux states,
  its own curve solve): the plant driven by the rotating voltage of that magnitude and frequency at
  that speed settles at that rotor flux, torque and current.
* The set-point: psi_ref itself (the same float) while the voltage suffices; above, the largest flux
  whose steady voltage fits; beyond the breakdown torque, the flux of the least voltage.
* The C functions against the Python ones at random points on every curve family: the same floats.
* The drive: off reproduces the fixed set-point; on changes nothing below base speed (bit for bit)
  and holds 150 rad/s at rated load where the fixed set-point runs into the voltage limit.
"""

from __future__ import annotations

import ctypes
import math
import random

import pytest
from native_core import MotorParams as CMotorParams
from native_core import load, new_motor, params

from satmotor.control.field_weakening import FLOOR, FieldWeakening, steady_point, steady_point_at_flux
from satmotor.control.measurements import MEAS_LEN
from satmotor.interface import ControllerUnit, PlantUnit
from satmotor.machine.params import MotorParams, make_curve
from satmotor.machine.plant import OMEGA_M, Plant, initial_state

P = MotorParams()
V_MAX = 540.0 / math.sqrt(3.0)
D = ctypes.c_double


def _plant_steady(params, v, ws, omega_m, T, phi0, t_end=2.0, h=1e-4):
    """The plant (inertia 1e6: the speed held) driven by v e^{j ws t} with the load T - B omega_m:
    |psi_r|, T_e, |i_s| at t_end (classical RK4 on the plant's own derivatives, the voltage evaluated
    at every stage; the rotor flux starts at phi0 on the alpha axis, the stator flux at rest)."""
    p = MotorParams(params.R_s, params.R_r, params.l_s, params.l_r, params.k, params.n_p, 1e6, params.B,
                    params.curve)
    plant = Plant(p)
    x = initial_state(p, omega_m=omega_m, psi_r_alpha=phi0)
    T_load = T - p.B * omega_m

    def f(t, x):
        return plant.derivatives(t, x, v * math.cos(ws * t), v * math.sin(ws * t), T_load)

    for k in range(round(t_end / h)):
        t = k * h
        k1 = f(t, x)
        k2 = f(t + h / 2, [a + h / 2 * b for a, b in zip(x, k1)])
        k3 = f(t + h / 2, [a + h / 2 * b for a, b in zip(x, k2)])
        k4 = f(t + h, [a + h * b for a, b in zip(x, k3)])
        x = [a + h / 6 * (b1 + 2 * b2 + 2 * b3 + b4) for a, b1, b2, b3, b4 in zip(x, k1, k2, k3, k4)]
    o = plant.outputs(x)
    assert x[OMEGA_M] == pytest.approx(omega_m, rel=1e-6)
    return math.hypot(x[2], x[3]), o.T_e, math.hypot(o.i_s_alpha, o.i_s_beta)


@pytest.mark.parametrize("I, T, omega_m", [(5.0, 26.71, 150.0), (1.5, 11.0, 375.0), (3.0, -15.0, 250.0)])
def test_the_steady_state_is_the_plants(I, T, omega_m):
    Phi, v, i_s, ws = steady_point(P, I, T, omega_m)
    phi_p, T_p, i_p = _plant_steady(P, v, ws, omega_m, T, Phi)
    # RK4's error: at most 6e-6 here with h = 1e-4 s, 16 times less with h/2 (fourth order)
    assert phi_p == pytest.approx(Phi, rel=2e-5)
    assert T_p == pytest.approx(T, rel=2e-5)
    assert i_p == pytest.approx(i_s, rel=2e-5)
    # the same point from its flux (one curve inversion)
    I2, pt = steady_point_at_flux(P, Phi, T, omega_m)
    assert I2 == pytest.approx(I, rel=1e-12) and pt[1] == pytest.approx(v, rel=1e-12)


def test_no_steady_state_below_the_flux_a_torque_needs():
    # psi_m^2 >= 2 |c|, c = T l_r / (kappa k^2): at I = 0.2 A the main flux is 0.055 Wb
    assert steady_point(P, 0.2, 26.71, 100.0) is None
    assert steady_point(P, 0.2, 0.0, 100.0) is not None


def test_the_set_point_below_the_limit_is_psi_ref_itself():
    fw = FieldWeakening(P, V_MAX, 0.95, 40.0)
    for T, w in ((26.71, 100.0), (0.0, 140.0), (-26.71, -120.0), (10.0, 0.0)):
        psi = 0.95 * (1.0 + 1e-9 * w)  # any float
        assert fw.flux_at(T, w, psi) is psi


@pytest.mark.parametrize("T, w", [(27.16, 150.0), (16.75, 250.0), (11.8, 375.0), (0.0, 600.0),
                                  (-20.0, 250.0), (10.0, -300.0)])
def test_the_set_point_is_the_largest_flux_that_fits(T, w):
    fw = FieldWeakening(P, V_MAX, 0.95, 40.0)
    phi = fw.flux_at(T, w, 0.95)
    assert FLOOR * 0.95 < phi < 0.95
    _, pt = steady_point_at_flux(P, phi, T, w)
    assert pt[1] == pytest.approx(0.95 * V_MAX, rel=1e-6)
    for j in range(1, 21):  # every larger flux needs more
        larger = phi + (0.95 - phi) * j / 20
        assert steady_point_at_flux(P, larger, T, w)[1][1] > 0.95 * V_MAX


def test_beyond_the_breakdown_torque_the_torque_is_limited_at_the_breakdown_point():
    fw = FieldWeakening(P, V_MAX, 0.95, 40.0)
    T, w = 25.0, 375.0  # about twice what the voltage gives at 2.5 times base speed
    phi, i_max = fw.set_points(T, w, 0.95, 30.0)
    V_bd = 0.975 * V_MAX  # halfway between the steady-state share and the inverter's limit
    # the breakdown torque: the most torque any flux gives within V_bd, found here on a grid of fluxes
    # by bisection over the torque, independently of FieldWeakening.breakdown
    fluxes = [0.1 + 0.002 * j for j in range(300)]

    def least(T_):
        return min(steady_point_at_flux(P, f, T_, w)[1][1] for f in fluxes)

    lo, hi = 0.0, T
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if least(mid) <= V_bd else (lo, mid)
    T_bd = lo
    assert 0.3 * T < T_bd < T
    # the set-point is the breakdown flux and the law's current bound the current there
    I, pt = steady_point_at_flux(P, phi, T_bd, w)
    assert pt[1] == pytest.approx(V_bd, rel=1e-4)
    assert i_max == pytest.approx(pt[2], rel=1e-4) and i_max < 30.0
    for f in (0.97, 1.03):  # the least voltage for T_bd
        assert steady_point_at_flux(P, phi * f, T_bd, w)[1][1] > pt[1]
    # below the breakdown torque of the steady-state share the limit lets go
    assert fw.set_points(0.8 * T_bd, w, 0.95, 30.0)[1] == 30.0


def test_a_lower_voltage_ratio_weakens_earlier():
    hi, lo = FieldWeakening(P, V_MAX, 0.95, 40.0), FieldWeakening(P, V_MAX, 0.8, 40.0)
    assert lo.flux_at(26.71, 150.0, 0.95) < hi.flux_at(26.71, 150.0, 0.95) < 0.95
    assert hi.flux_at(26.71, 100.0, 0.95) == 0.95 and lo.flux_at(26.71, 125.0, 0.95) < 0.95


# ------------------------------------------------------------------------------ C against Python


@pytest.fixture(scope="module")
def lib():
    return load()  # the signatures read from the headers


def _motors(lib, tmp_path):
    tf = tmp_path / "curve.csv"
    c = make_curve("arctan")
    tf.write_text("i_mu,psi_m\n" + "".join(f"{x!r},{c.psi(x)!r}\n" for x in [0.5 * i for i in range(1, 41)]))
    rng = random.Random(5)
    for name in ("arctan", "exponential", "polynomial", "table", "linear"):
        for k in (1.0, 0.83):
            L_m0, I_par = (0.330, 3.66) if name == "exponential" else (0.2772, 3.31)
            vals = dict(R_s=1.405 * rng.uniform(0.7, 1.3), R_r=1.395 * rng.uniform(0.7, 1.3),
                        l_s=5.839e-3 * rng.uniform(0.7, 1.3), l_r=5.839e-3 * rng.uniform(0.7, 1.3), k=k,
                        n_p=rng.choice((1, 2, 3)), J=0.0131, B=2.985e-3, curve=name, L_m0=L_m0, L_m_inf=0.01,
                        I_par=I_par, poly_b=2.46, poly_n=7, table_file=str(tf) if name == "table" else "")
            curve = make_curve(name, L_m0, 0.01, I_par, 2.46, 7, vals["table_file"])
            p = MotorParams(vals["R_s"], vals["R_r"], vals["l_s"], vals["l_r"], k, vals["n_p"], 0.0131,
                            2.985e-3, curve)
            buf = new_motor(lib)
            msg = ctypes.create_string_buffer(256)
            assert lib.sm_motor_init(buf, params(lib, CMotorParams, vals), None, msg, 256) == 0, msg.value
            yield f"{name}, k={k}", p, buf


def test_c_field_weakening_equals_the_python(lib, tmp_path):
    rng = random.Random(17)
    n_active = n = n_limited = 0
    for label, p, buf in _motors(lib, tmp_path):
        V_max, ratio, bw = rng.uniform(150.0, 350.0), rng.uniform(0.7, 1.0), rng.uniform(10.0, 400.0)
        fw = FieldWeakening(p, V_max, ratio, bw)
        cfw = (D * 8)()
        lib.sm_fw_init(cfw, buf, V_max, ratio, bw)
        out, I = (D * 4)(), D()
        for _ in range(150):
            T, w, psi_ref = rng.uniform(-40.0, 40.0), rng.uniform(-500.0, 500.0), rng.uniform(0.3, 1.1)
            I_mu = rng.uniform(0.01, 12.0)
            pt = steady_point(p, I_mu, T, w)
            assert lib.sm_fw_steady_point(buf, I_mu, T, w, out) == (pt is not None), label
            if pt is not None:
                assert tuple(out) == pt, (label, I_mu, T, w)
            if psi_ref > 0.0:
                I_p, pt = steady_point_at_flux(p, psi_ref, T, w)
                assert lib.sm_fw_steady_point_at_flux(buf, psi_ref, T, w, ctypes.byref(I), out) == 0
                assert (I.value, tuple(out)) == (I_p, pt), (label, psi_ref, T, w)
            want = fw.flux_at(T, w, psi_ref)
            got, i_got = D(), D()
            assert lib.sm_fw_flux_at(cfw, buf, T, w, psi_ref, ctypes.byref(got)) == 0
            assert got.value == want, (label, T, w, psi_ref)
            n_active += want != psi_ref
            n += 1
            I_max = rng.uniform(5.0, 40.0)
            want = fw.set_points(T, w, psi_ref, I_max)
            assert lib.sm_fw_set_points(cfw, buf, T, w, psi_ref, I_max, ctypes.byref(got),
                                        ctypes.byref(i_got)) == 0
            assert (got.value, i_got.value) == want, (label, T, w, psi_ref, I_max)
            n_limited += want[1] != I_max
            # from a measurement: the torque of the magnetizing state, the speed lead
            meas = (rng.uniform(-20, 20), rng.uniform(-20, 20), rng.uniform(-1, 1), rng.uniform(-1, 1),
                    0.0, 0.0, w)
            rate = rng.uniform(-3000.0, 3000.0)
            m = (D * MEAS_LEN)(*meas)
            assert lib.sm_fw_torque(cfw, buf, m, ctypes.byref(got)) == 0
            assert got.value == fw.torque(meas)
            assert lib.sm_fw_flux_reference(cfw, buf, m, rate, psi_ref, I_max, ctypes.byref(got),
                                            ctypes.byref(i_got)) == 0
            assert (got.value, i_got.value) == fw.flux_reference(meas, rate, psi_ref, I_max)
    print(f"\n[field weakening] {n} set-points equal in C and Python, {n_active} of them weakened, "
          f"{n_limited} beyond the breakdown torque")
    assert n_active > n // 4 and n_limited > n // 20


# ------------------------------------------------------------------------------ the drive


def _loop(values, w_set, T_set, t_end, ramp=(0.2, 1.2), t_load=1.3):
    plant, ctrl = PlantUnit({}), ControllerUnit(values)
    Ts, rows = ctrl.Ts, []
    for k in range(round(t_end / Ts) + 1):
        t = k * Ts
        w = min(max((t - ramp[0]) / (ramp[1] - ramp[0]), 0.0), 1.0) * w_set
        TL = T_set if t >= t_load else 0.0
        o = plant.outputs()
        ctrl.step(t, Ts, (o[0], o[1], o[4], o[5], o[2], o[3], o[6], w, 0.95, TL, 0.0))
        out = ctrl.outputs()
        plant.step(t, Ts, (out[0], out[1], TL))
        rows.append((t,) + tuple(plant.outputs()) + tuple(out))
    return rows


def test_below_base_speed_on_and_off_are_the_same_floats():
    on = _loop({}, 100.0, 26.71, 1.6)
    off = _loop({"field_weakening": False}, 100.0, 26.71, 1.6)
    assert on == off


def test_rated_point_held_with_field_weakening_not_without():
    # 150 rad/s with the rated load: the fixed 0.95 Wb needs more than V_dc/sqrt(3) = 311.8 V
    on = _loop({}, 150.0, 26.71, 2.0)
    off = _loop({"field_weakening": False}, 150.0, 26.71, 2.0)
    W = 1 + PlantUnit.OUTPUTS.index("omega_m")  # plant omega_m column
    VLIM = 1 + len(PlantUnit.OUTPUTS) + ControllerUnit.OUTPUTS.index("voltage_limited")  # controller column
    tail = slice(-2000, None)
    w_on = [r[W] for r in on[tail]]
    w_off = [r[W] for r in off[tail]]
    assert max(abs(w - 150.0) for w in w_on) < 0.005 * 150.0
    assert not any(r[VLIM] for r in on[tail])
    assert sum(w_off) / len(w_off) < 0.97 * 150.0 and all(r[VLIM] for r in off[tail])


def test_the_demo_writes_its_figure(tmp_path):
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "demos"))
    import field_weakening as demo

    ss = demo.steady_curves([100.0, 300.0])
    assert ss[0, 0] == 0.95 and ss[1, 0] < 0.5  # no weakening at 100 rad/s, deep at 300 rad/s
    assert ss[1, 1] == pytest.approx(0.95 * V_MAX, rel=1e-6) and ss[1, 2] > 4000.0 / 300.0
    run = demo.run(True, t_end=0.3, every=100)
    assert len(run) == 31 and run["omega_m [rad/s]"].iloc[-1] > 2.0  # on the ramp (9.4 rad/s at 0.3 s)
    demo.plot(run, run, tmp_path / "fw.png")
    assert (tmp_path / "fw.png").stat().st_size > 10_000


def test_ss_flux_is_against_the_set_point_the_drive_works_to():
    import numpy as np

    from satmotor.metrics import closed_loop_metrics

    t = np.linspace(0.0, 1.0, 11)
    one, zero = np.ones_like(t), np.zeros_like(t)
    series = dict(t=t, omega_m=100.0 * one, omega_ref=100.0 * one, psi_r_alpha=0.5 * one, psi_r_beta=zero,
                  psi_ref=0.95 * one, z1=zero, e1=zero, i_s_alpha=one, i_s_beta=zero, v_s_alpha=one,
                  v_s_beta=zero, W=one, run=t >= 0.0)
    # against the nominal 0.95 Wb: (0.95 - 0.5) / 0.95; against the drive's 0.505 Wb: 0.005 / 0.505
    assert closed_loop_metrics(**series)["ss_flux"] == pytest.approx(0.45 / 0.95, rel=1e-12)
    assert closed_loop_metrics(**series, psi_set=0.505 * one)["ss_flux"] == pytest.approx(0.005 / 0.505,
                                                                                         rel=1e-9)
