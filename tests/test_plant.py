"""The stationary-frame plant against independent references."""

import cmath
import math

import numpy as np
import pytest
from conftest import CURVES
from scipy.integrate import solve_ivp

from satmotor.machine.integrate import rk4
from satmotor.machine.magnetics import LinearCurve
from satmotor.machine.params import MotorParams, RatedData
from satmotor.machine.plant import OMEGA_M, Plant, initial_state

RATED = RatedData()
V, W = RATED.V_phase_peak, RATED.omega_e


def equivalent_circuit(p, L_m, w_e, slip, v_peak):
    """Per-phase T-equivalent circuit, rotor referred to the stator by the turns ratio k.

    Returns the stator current phasor (peak, for v = v_peak at angle 0) and the torque [N m]
    (amplitude-invariant scaling: air-gap power 3/2 |I_r'|^2 R_r'/s).
    """
    Rr, lr = p.R_r / p.k**2, p.l_r / p.k**2
    zm = 1j * w_e * L_m
    zr = Rr / slip + 1j * w_e * lr
    zs = p.R_s + 1j * w_e * p.l_s
    i_s = v_peak / (zs + zm * zr / (zm + zr))
    i_r = -i_s * zm / (zm + zr)
    torque = 1.5 * p.n_p * abs(i_r) ** 2 * Rr / (slip * w_e)
    return i_s, torque


@pytest.mark.parametrize("k", [1.0, 0.8])
@pytest.mark.parametrize("slip", [-0.04, 0.01, 0.03, 0.1, 0.4, 1.0])
def test_linear_steady_state_matches_equivalent_circuit(k, slip):
    p = MotorParams(curve=LinearCurve(0.1722), k=k, l_r=5.839e-3 * k**2, R_r=1.395 * k**2)
    plant = Plant(p)
    w_m = (1.0 - slip) * W / p.n_p

    def f(t, x):
        d = list(plant.derivatives(t, x, V * math.cos(W * t), V * math.sin(W * t), 0.0))
        d[OMEGA_M] = 0.0  # speed held: a steady-state test bench
        return d

    t_end = 3.0
    sol = solve_ivp(f, (0.0, t_end), initial_state(p, omega_m=w_m), method="DOP853",
                    rtol=1e-11, atol=1e-12)
    out = plant.outputs(sol.y[:, -1])
    i_ref, t_ref = equivalent_circuit(p, 0.1722, W, slip, V)
    i_sim = complex(out.i_s_alpha, out.i_s_beta) * cmath.exp(-1j * W * t_end)  # back to a phasor
    assert abs(i_sim - i_ref) / abs(i_ref) < 1e-4
    assert out.T_e == pytest.approx(t_ref, rel=1e-4)


def _energy_run(curve, t_end=0.4, t_load=0.25, h=2e-5):
    p = MotorParams(curve=curve, k=0.9, l_r=5.839e-3 * 0.81, R_r=1.395 * 0.81)
    plant = Plant(p)
    T_L = RATED.T_n

    def f(t, x, load):
        va, vb = V * math.cos(W * t), V * math.sin(W * t)
        d = plant.derivatives(t, x[:6], va, vb, load)
        o = plant.outputs(x[:6])
        w = x[OMEGA_M]
        p_in = 1.5 * (va * o.i_s_alpha + vb * o.i_s_beta)
        p_cu = 1.5 * (p.R_s * (o.i_s_alpha**2 + o.i_s_beta**2) + p.R_r * (o.i_r_alpha**2 + o.i_r_beta**2))
        return tuple(d) + (p_in, p_cu, p.B * w * w, load * w)

    x = (0.0,) * 10
    n1, n2 = round(t_load / h), round((t_end - t_load) / h)
    for j in range(n1):
        x = rk4(f, j * h, x, h, 1, (0.0,))
    for j in range(n2):
        x = rk4(f, t_load + j * h, x, h, 1, (T_L,))
    return p, plant, x


@pytest.mark.parametrize("name", ["arctan", "exponential", "polynomial", "table"])
def test_energy_balance_closes(name):
    """Input = copper + friction + load work + kinetic + stored magnetic (int i dpsi) energy."""
    p, plant, x = _energy_run(CURVES[name])
    e_in, e_cu, e_fric, e_load = x[6:]
    e_kin = 0.5 * p.J * x[OMEGA_M] ** 2
    e_mag = plant.magnetic_energy(x[:6])
    residual = e_in - (e_cu + e_fric + e_load + e_kin + e_mag)
    assert e_in > 100.0 and e_load > 1.0 and e_mag > 1.0  # every term takes part
    assert abs(residual) / e_in < 1e-6


def _dol(plant, x0, t_end, h, rot=0.0, n_sub=1):
    x = x0
    c, s = math.cos(rot), math.sin(rot)
    for j in range(round(t_end / h)):
        tm = (j + 0.5) * h
        va, vb = V * math.cos(W * tm), V * math.sin(W * tm)
        load = RATED.T_n if j * h >= 0.1 else 0.0
        x = plant.step(j * h, x, c * va - s * vb, s * va + c * vb, load, h, n_sub)
    return x


@pytest.mark.parametrize("delta", [0.7, -2.0, math.pi])
def test_rotating_the_inputs_rotates_every_vector_output(delta):
    plant = Plant(MotorParams())
    x0 = (0.0,) * 6
    a = _dol(plant, x0, 0.15, 1e-4)
    b = _dol(plant, x0, 0.15, 1e-4, rot=delta)
    oa, ob = plant.outputs(a), plant.outputs(b)
    r = cmath.exp(1j * delta)
    pairs = [
        (complex(a[0], a[1]), complex(b[0], b[1])),
        (complex(a[2], a[3]), complex(b[2], b[3])),
        (complex(oa.i_s_alpha, oa.i_s_beta), complex(ob.i_s_alpha, ob.i_s_beta)),
        (complex(oa.i_r_alpha, oa.i_r_beta), complex(ob.i_r_alpha, ob.i_r_beta)),
        (complex(oa.i_mu_alpha, oa.i_mu_beta), complex(ob.i_mu_alpha, ob.i_mu_beta)),
    ]
    for va, vb in pairs:
        assert abs(vb - r * va) <= 1e-9 * abs(va)
    for name in ("T_e", "i_mu", "psi_m", "m"):
        assert getattr(ob, name) == pytest.approx(getattr(oa, name), rel=1e-9)
    assert b[4] == pytest.approx(a[4], rel=1e-9) and b[5] == pytest.approx(a[5], rel=1e-9)


def test_rk4_converges_at_fourth_order_on_a_free_acceleration():
    plant = Plant(MotorParams())

    def f(t, x):
        return plant.derivatives(t, x, V * math.cos(W * t), V * math.sin(W * t), 0.0)

    t_end = 0.04
    ref = solve_ivp(f, (0, t_end), [0.0] * 6, method="DOP853", rtol=1e-13, atol=1e-13).y[:, -1]
    errors = []
    for n in (100, 200, 400, 800):
        x = rk4(f, 0.0, (0.0,) * 6, t_end, n)
        errors.append(np.max(np.abs(np.array(x) - ref) / (np.abs(ref) + 1e-3)))
    orders = [math.log2(errors[i] / errors[i + 1]) for i in range(3)]
    assert all(3.8 < q < 4.3 for q in orders), orders


@pytest.mark.parametrize("name", list(CURVES))
def test_current_recovery_satisfies_the_flux_relations(name):
    p = MotorParams(curve=CURVES[name], k=0.85)
    plant = Plant(p)
    rng = np.random.default_rng(7)
    for _ in range(20):
        x = tuple(rng.normal(0, 0.8, 4)) + (rng.normal(0, 100), 0.0)
        o = plant.outputs(x)
        ima, imb = o.i_s_alpha + p.k * o.i_r_alpha, o.i_s_beta + p.k * o.i_r_beta
        assert ima == pytest.approx(o.i_mu_alpha, rel=1e-12, abs=1e-12)
        assert imb == pytest.approx(o.i_mu_beta, rel=1e-12, abs=1e-12)
        m = p.curve.psi(math.hypot(ima, imb)) / math.hypot(ima, imb)
        assert x[0] == pytest.approx(p.l_s * o.i_s_alpha + m * ima, rel=1e-11, abs=1e-12)
        assert x[1] == pytest.approx(p.l_s * o.i_s_beta + m * imb, rel=1e-11, abs=1e-12)
        assert x[2] == pytest.approx(p.l_r * o.i_r_alpha + p.k * m * ima, rel=1e-11, abs=1e-12)
        assert x[3] == pytest.approx(p.l_r * o.i_r_beta + p.k * m * imb, rel=1e-11, abs=1e-12)
        # torque from the rotor side: -3/2 n_p (psi_r x i_r)
        t_rotor = -1.5 * p.n_p * (x[2] * o.i_r_beta - x[3] * o.i_r_alpha)
        assert o.T_e == pytest.approx(t_rotor, rel=1e-9, abs=1e-9)


def test_initial_state_is_a_dc_equilibrium():
    p = MotorParams()
    plant = Plant(p)
    x = initial_state(p, psi_r_alpha=0.6, psi_r_beta=-0.5)
    o = plant.outputs(x)
    assert math.hypot(x[2], x[3]) == pytest.approx(math.hypot(0.6, -0.5), rel=1e-14)
    d = plant.derivatives(0.0, x, p.R_s * o.i_s_alpha, p.R_s * o.i_s_beta, 0.0)
    assert max(abs(v) for v in d) < 1e-10  # rounding of i_r = (psi_r - k m i_mu) / l_r ~ 1e-14 A


def test_open_loop_start_reaches_the_mechanical_balance():
    """The demo's DOL start: at steady no load the torque only covers friction, T_e = B omega_m."""
    from satmotor.simulate_open_loop import dol_start

    r = dol_start(t_end=1.0, t_load=10.0)
    p = MotorParams()
    assert r["T_e"][-1] == pytest.approx(p.B * r["omega_m"][-1], rel=5e-3)  # a weakly damped mode remains
    assert r["omega_m"][-1] == pytest.approx(W / p.n_p, rel=2e-3)
    assert len(r["t"]) == 10001 and r["t"][-1] == pytest.approx(1.0, abs=1e-15)


def test_the_written_out_fast_paths_equal_the_generic_code_bit_for_bit():
    """ArctanCurve.solve and Plant.derivatives inline their inner calls for speed; they must give
    the very floats of the generic code (_Curve.solve with _psi_dpsi; Plant.magnetizing, then the
    same flux-state equations), so that the co-simulation equals the plain loop and any edit to one
    copy that forgets the other fails here."""
    import random

    from satmotor.machine.magnetics import ArctanCurve, _Curve
    from satmotor.machine.params import MotorParams
    from satmotor.machine.plant import Plant

    rng = random.Random(7)
    curve = ArctanCurve()
    for _ in range(20000):
        a, c = 10 ** rng.uniform(-4, 0), 10 ** rng.uniform(-6, 1)
        assert curve.solve(a, c) == _Curve.solve(curve, a, c)
    p = MotorParams()
    plant = Plant(p)
    for _ in range(5000):
        x = tuple(rng.uniform(-1.5, 1.5) for _ in range(4)) + (rng.uniform(-300, 300), rng.uniform(-10, 10))
        v_a, v_b, T = rng.uniform(-400, 400), rng.uniform(-400, 400), rng.uniform(-50, 50)
        ima, imb, I, psi, m = plant.magnetizing(*x[:4])
        isa, isb = (x[0] - m * ima) / p.l_s, (x[1] - m * imb) / p.l_s
        ira, irb = (x[2] - p.k * m * ima) / p.l_r, (x[3] - p.k * m * imb) / p.l_r
        te = 1.5 * p.n_p * (x[0] * isb - x[1] * isa)
        we = p.n_p * x[4]
        want = (v_a - p.R_s * isa, v_b - p.R_s * isb, -p.R_r * ira - we * x[3], -p.R_r * irb + we * x[2],
                (te - T - p.B * x[4]) / p.J, x[4])
        got = plant.derivatives(0.0, x, v_a, v_b, T)
        assert got == pytest.approx(want, rel=1e-12, abs=1e-12)
