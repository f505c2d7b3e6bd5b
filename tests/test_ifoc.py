"""IFOC baseline: model constants, closed loop on the exact (unsaturated) plant, limits, state."""

import math

import pytest

from satmotor.control.ifoc import IFOCController, IFOCGains
from satmotor.errors import ParameterError
from satmotor.machine.magnetics import LinearCurve
from satmotor.machine.params import MotorParams, RatedData
from satmotor.machine.plant import OMEGA_M, PSI_R_A, PSI_R_B, Plant, initial_state

TS = 1e-4
L_M = 0.1722
T_N = RatedData().T_n  # 26.7 N m


def motors(k=1.0):
    """(controller params: default saturating curve, plant params: linear curve L_M)."""
    kw = dict(k=k, l_r=5.839e-3 * k * k, R_r=1.395 * k * k) if k != 1.0 else {}
    return MotorParams(**kw), MotorParams(curve=LinearCurve(L_M), **kw)


def simulate(ctrl, plant, x, n, w_ref, phi_ref, t_load, t0=0.0, log=None):
    """Closed loop, controller every plant step (h = Ts).  ``w_ref``/``t_load``: functions of t."""
    for j in range(n):
        t = t0 + j * TS
        o = plant.outputs(x)
        va, vb, d = ctrl(o.i_s_alpha, o.i_s_beta, x[OMEGA_M], w_ref(t), phi_ref)
        if log is not None:
            log.append((t, x, va, vb, d))
        x = plant.step(t, x, va, vb, t_load(t), TS)
    return x


def test_model_constants_in_stator_referred_form():
    k = 0.8
    pc, _ = motors(k)
    c = IFOCController(pc, IFOCGains(), TS, L_m=L_M)
    Rr_ref, Lr_ref = pc.R_r / k**2, pc.l_r / k**2 + L_M  # stator-referred R_r', L_r'
    L_s = pc.l_s + L_M
    assert c.sigL == pytest.approx(L_s - L_M**2 / Lr_ref, rel=1e-13)
    assert c.R_eq == pytest.approx(pc.R_s + Rr_ref * (L_M / Lr_ref) ** 2, rel=1e-13)
    assert c.tau_r == pytest.approx(Lr_ref / Rr_ref, rel=1e-13)
    assert c.Kp_i == pytest.approx(c.sigL * 2000.0) and c.Ki_i == pytest.approx(c.R_eq * 2000.0)
    # symmetric optimum: |L(j w_speed)| = 1 and the phase margin asin((a^2-1)/(a^2+1))
    w = c.gains.w_speed
    K_T = 1.0  # the loop is formed in torque units: PI(s) / (J s) / (1 + T_sigma s)
    L = (c.Kp_w + c.Ki_w / (1j * w)) * K_T / (pc.J * 1j * w) / (1.0 + 1j * w * c.T_sigma)
    assert abs(L) == pytest.approx(1.0, rel=1e-12)
    a = c.a_so
    assert math.pi + math.atan2(L.imag, L.real) == pytest.approx(math.asin((a * a - 1) / (a * a + 1)))


@pytest.mark.parametrize("k", [1.0, 0.8])
def test_torque_constant_matches_plant(k):
    """T_e = 3/2 n_p (k L_m / L_ra) Phi i_sq for a plant state with rotor flux Phi and given i_s."""
    pc, pp = motors(k)
    c = IFOCController(pc, IFOCGains(), TS, L_m=L_M)
    phi, i_d, i_q, th = 0.9 * k, 5.0, 7.0, 0.7
    L_ra = pp.l_r + k * k * L_M
    i_rd, i_rq = (phi - k * L_M * i_d) / L_ra, -k * L_M * i_q / L_ra  # psi_r = k L_m i_s + L_ra i_r
    psi_sd = (pp.l_s + L_M) * i_d + k * L_M * i_rd
    psi_sq = (pp.l_s + L_M) * i_q + k * L_M * i_rq
    cs, sn = math.cos(th), math.sin(th)
    x = (cs * psi_sd - sn * psi_sq, sn * psi_sd + cs * psi_sq, cs * phi, sn * phi, 0.0, 0.0)
    o = Plant(pp).outputs(x)
    assert o.i_s_alpha == pytest.approx(cs * i_d - sn * i_q, rel=1e-12)
    assert o.T_e == pytest.approx(1.5 * pp.n_p * k * L_M / L_ra * phi * i_q, rel=1e-12)
    assert c._kT * phi * i_q == pytest.approx(o.T_e, rel=1e-12)


@pytest.mark.parametrize("k", [1.0, 0.8])
def test_closed_loop_speed_step_and_rated_load(k):
    pc, pp = motors(k)
    ctrl = IFOCController(pc, IFOCGains(), TS, L_m=L_M)
    plant = Plant(pp)
    phi_ref = k * L_M * RatedData().I_mu_n  # rated rotor flux (rotor side: factor k)
    x = initial_state(pp, psi_r_alpha=phi_ref)
    ctrl.reset(theta_f=0.0, phi_r=phi_ref)
    log = []
    simulate(ctrl, plant, x, 9000, lambda t: 100.0, phi_ref, lambda t: T_N if t >= 0.45 else 0.0,
             log=log)
    w = [e[1][OMEGA_M] for e in log]
    flux = [math.hypot(e[1][PSI_R_A], e[1][PSI_R_B]) / phi_ref - 1.0 for e in log]
    v = [math.hypot(e[2], e[3]) for e in log]
    tail = w[-500:]  # last 50 ms, rated load applied 0.4 s earlier
    err = max(abs(s - 100.0) for s in tail) / 100.0
    assert err < 5e-3
    assert max(abs(f) for f in flux) < 0.02
    assert max(v) <= ctrl.V_max * (1.0 + 1e-12)
    assert abs(w[4490] - 100.0) < 0.5  # settled before the load step
    d = log[-1][4]
    assert not d.current_limited and not d.voltage_limited
    assert d.T_ref == pytest.approx(T_N + pp.B * 100.0, rel=2e-3)  # integrator carries the load
    print(f"k={k}: speed error {err:.2e}, max flux deviation {max(abs(f) for f in flux):.2e}, "
          f"max |v| {max(v):.1f} V, overshoot {max(w[:4500]) - 100.0:.2f} rad/s")


@pytest.mark.parametrize("w_c", [1000.0, 2000.0])
def test_current_loop_bandwidth(w_c):
    """i_sd follows a step of its reference like w_c / (s + w_c) (flux-reference step at rest)."""
    pc, pp = motors()
    g = IFOCGains(w_c=w_c)
    ctrl = IFOCController(pc, g, TS, L_m=L_M)
    plant = Plant(pp)
    phi0 = L_M * 5.0
    x = initial_state(pp, psi_r_alpha=phi0)
    ctrl.reset(phi_r=phi0)
    x = simulate(ctrl, plant, x, 20, lambda t: 0.0, phi0, lambda t: 0.0)
    log = []
    simulate(ctrl, plant, x, 100, lambda t: 0.0, 1.2 * phi0, lambda t: 0.0, log=log)
    i_d = [e[4].i_sd for e in log]  # sample n is t = n Ts after the reference step
    i0, i1 = 5.0, 6.0
    resp = [(i - i0) / (i1 - i0) for i in i_d]
    tau_samples = round(1.0 / (g.w_c * TS))  # samples per 1/w_c
    for n_tau in (1, 2, 3):
        ideal = 1.0 - math.exp(-n_tau)
        got = resp[n_tau * tau_samples]
        assert abs(got - ideal) < 0.05, (n_tau, got, ideal)  # discrete pole 1 - w_c Ts vs exp(-w_c Ts)
    assert max(resp) < 1.03  # no overshoot worth the name
    assert resp[5 * tau_samples] == pytest.approx(1.0, abs=0.02)
    print("i_sd step response at 1, 2, 3, 5 /w_c:", [round(resp[n * tau_samples], 4) for n in (1, 2, 3, 5)])


def test_voltage_limit_and_anti_windup():
    pc, pp = motors()
    ctrl = IFOCController(pc, IFOCGains(V_dc=300.0), TS, L_m=L_M)  # 173 V < 203 V needed at 100 rad/s
    plant = Plant(pp)
    phi = L_M * 5.7
    x = initial_state(pp, psi_r_alpha=phi)
    ctrl.reset(phi_r=phi)
    log = []
    x = simulate(ctrl, plant, x, 3000, lambda t: 100.0, phi, lambda t: 0.0, log=log)
    assert sum(e[4].voltage_limited for e in log[1000:]) == 2000  # held at the limit for 0.2 s
    _, x_d, x_q, _, _ = ctrl.get_state()
    assert math.hypot(x_d, x_q) < ctrl.V_max  # back-calculation: no integrator windup
    simulate(ctrl, plant, x, 4000, lambda t: 50.0, phi, lambda t: 0.0, t0=0.3, log=log)
    v = [math.hypot(e[2], e[3]) for e in log]
    assert max(v) <= ctrl.V_max * (1.0 + 1e-12)
    assert not any(e[4].voltage_limited for e in log[-3000:])
    tail = [e[1][OMEGA_M] for e in log[-500:]]  # recovers to 50 rad/s after the limited phase
    assert max(abs(s - 50.0) for s in tail) < 0.25


def test_turns_ratio_invariance():
    """A k != 1 machine with l_r, R_r scaled by k^2 is the same machine referred: same speed."""
    traces = []
    for k in (1.0, 0.7):
        pc, pp = motors(k)
        ctrl = IFOCController(pc, IFOCGains(), TS, L_m=L_M)
        phi = k * L_M * 5.7
        ctrl.reset(phi_r=phi)
        log = []
        simulate(ctrl, Plant(pp), initial_state(pp, psi_r_alpha=phi), 800, lambda t: 60.0, phi,
                 lambda t: 0.5 * T_N, log=log)
        traces.append([e[1][OMEGA_M] for e in log])
    assert max(abs(a - b) for a, b in zip(*traces)) < 1e-9 * 60.0


def test_state_restore_bit_identical():
    pc, pp = motors()
    ctrl = IFOCController(pc, IFOCGains(), TS, L_m=L_M)
    plant = Plant(pp)
    phi = L_M * 5.7
    x = initial_state(pp, psi_r_alpha=phi)
    ctrl.reset(phi_r=phi)
    x = simulate(ctrl, plant, x, 300, lambda t: 80.0, phi, lambda t: 10.0)
    s = ctrl.get_state()
    runs = []
    for _ in range(2):
        ctrl.set_state(s)
        log = []
        simulate(ctrl, plant, x, 400, lambda t: 80.0, phi, lambda t: 10.0, t0=0.03, log=log)
        runs.append([(e[1], e[2], e[3], tuple(e[4])) for e in log] + [ctrl.get_state()])
    assert runs[0] == runs[1]
    ctrl.reset()
    assert ctrl.get_state() == (0.0, 0.0, 0.0, 0.0, 0.0)


def test_default_L_m_is_curve_at_rated_flux():
    p = MotorParams()
    c = IFOCController(p)
    assert c.L_m == p.curve.m(RatedData().I_mu_n)
    assert c.L_m == pytest.approx(0.1722, rel=1e-3)
    assert c.V_max == pytest.approx(540.0 / math.sqrt(3.0))


@pytest.mark.parametrize("field, value", [("w_c", 0.0), ("w_speed", -1.0), ("I_max", math.nan),
                                          ("V_dc", math.inf), ("I_max", "20")])
def test_bad_gains(field, value):
    with pytest.raises(ParameterError) as e:
        IFOCGains(**{field: value})
    assert e.value.field == field


def test_bad_controller_inputs():
    p = MotorParams()
    for kwargs, field in ((dict(Ts=0.0), "Ts"), (dict(L_m=-0.1), "L_m"),
                          (dict(gains=IFOCGains(w_speed=2000.0)), "w_speed"),
                          (dict(gains=IFOCGains(w_c=2e4)), "w_c"), (dict(gains=(1, 2)), "gains")):
        with pytest.raises(ParameterError) as e:
            IFOCController(p, **kwargs)
        assert e.value.field == field
    with pytest.raises(ParameterError) as e:
        IFOCController("motor")
    assert e.value.field == "params"
    c = IFOCController(p)
    for bad in (0.0, -1.0, math.nan, math.inf):
        with pytest.raises(ParameterError) as e:
            c(0.0, 0.0, 0.0, 0.0, bad)
        assert e.value.field == "psi_ref_shaped"
    with pytest.raises(ParameterError) as e:
        c.set_state((0.0, 1.0))
    assert e.value.field == "state"
