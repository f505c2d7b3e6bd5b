"""Integral action, current limit, delay compensation, flux source and start-up rules, at the law and
drive level.  Expected values come from the definitions written out here, from finite differences
along the closed-loop flow, or from a second mode of the drive (never from the code under test)."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from test_backstepping import _flow_derivative, load, measure, ref

from satmotor.control.backstepping import BacksteppingGains, ControllerConfig, control, error_system
from satmotor.control.delay import DelayCompensator
from satmotor.control.drive import PREMAG, RUN, BacksteppingDrive, DriveConfig
from satmotor.control.fo_model import FluxOrientedModel
from satmotor.errors import ParameterError
from satmotor.interface import ControllerUnit
from satmotor.machine.params import MotorParams
from satmotor.machine.plant import Plant

P = MotorParams()
GI = BacksteppingGains(c0=1.0e4, d0=2500.0)
CT = ControllerConfig(Ts=0.0, V_dc=1e9)


# ----- integral action: the error system and the Lyapunov function along the flow ---------------

def _closed_loop_integral(t_end=0.05):
    """Continuous closed loop (Ts = 0) of the law with integral action on the exact model; state
    (Phi_rd, i_mu_d, i_mu_q, omega_m, rho, e0, z0)."""
    model = FluxOrientedModel(P)

    def out_of(t, y):
        return control(measure(P, y[:4], y[4]), ref(t), load(t), P, GI, CT, 0.0, (y[5], y[6]))

    def rhs(t, y):
        o = out_of(t, y)
        c, s = math.cos(y[4]), math.sin(y[4])
        d = model.derivatives_with_angle(t, y[:5], c * o.v_s_alpha + s * o.v_s_beta,
                                         -s * o.v_s_alpha + c * o.v_s_beta, load(t)[0])
        return tuple(d) + (o.e0_dot, o.z0_dot)

    I0 = P.curve.current(0.8)
    y0 = [0.84, I0 * 1.1, 0.5, 5.0, 0.2, 1e-3, -0.02]
    sol = solve_ivp(rhs, (0.0, t_end), y0, method="DOP853", rtol=1e-10, atol=1e-10,
                    t_eval=np.linspace(0.0, t_end, 21))
    assert sol.success
    return sol, rhs, out_of


def test_integral_action_error_dynamics_and_lyapunov_decrease_along_the_flow():
    sol, rhs, out_of = _closed_loop_integral()
    g = GI
    worst = {"e1dot": 0.0, "z1dot": 0.0, "Vdot": 0.0}
    V = []
    for t, y in zip(sol.t, sol.y.T):
        o = out_of(t, y)
        e0, z0 = y[5], y[6]
        # V written out: the four errors and the two integral states weighted by their gains
        V.append(0.5 * (o.e1**2 + o.e2**2 + o.z1**2 + o.z2**2 + g.c0 * e0**2 + g.d0 * z0**2))
        assert o.V == pytest.approx(V[-1], rel=1e-12)
        e1dot = _flow_derivative(rhs, lambda s, z: out_of(s, z).e1, t, y)
        want = -g.c1 * o.e1 - g.c0 * e0 + o.e2
        scale = g.c1 * abs(o.e1) + g.c0 * abs(e0) + abs(o.e2)
        worst["e1dot"] = max(worst["e1dot"], abs(e1dot - want) / scale)
        z1dot = _flow_derivative(rhs, lambda s, z: out_of(s, z).z1, t, y)
        want = -g.d1 * o.z1 - g.d0 * z0 + o.z2
        scale = g.d1 * abs(o.z1) + g.d0 * abs(z0) + abs(o.z2)
        worst["z1dot"] = max(worst["z1dot"], abs(z1dot - want) / scale)
        vdot = _flow_derivative(rhs, lambda s, z: out_of(s, z).V, t, y)
        vref = -(g.c1 * o.e1**2 + g.c2 * o.e2**2 + g.d1 * o.z1**2 + g.d2 * o.z2**2)
        worst["Vdot"] = max(worst["Vdot"], abs(vdot - vref) / abs(vref))
    assert max(worst.values()) < 1e-5, worst
    assert all(v1 <= v0 * (1 + 1e-9) for v0, v1 in zip(V, V[1:]))
    assert V[-1] < 0.05 * V[0]


def test_zero_integral_gains_and_an_unbound_limit_leave_the_law_bit_identical():
    x = (0.9, 5.0, 3.0, 100.0)
    base = error_system(x, ref(0.01), P, BacksteppingGains(), theta=0.5)
    assert error_system(x, ref(0.01), P, BacksteppingGains(), theta=0.5, integ=(0.3, -2.0)) == base
    assert error_system(x, ref(0.01), P, BacksteppingGains(), theta=0.5, i_max=1e3) == base
    assert base.flux_limited == base.torque_limited == 0
    meas = measure(P, x, 0.4)
    plain = control(meas, ref(0.01), load(0.01), P, BacksteppingGains(), ControllerConfig())
    bound = control(meas, ref(0.01), load(0.01), P, BacksteppingGains(), ControllerConfig(), i_max=1e3)
    assert bound == plain


# ----- current limit ----------------------------------------------------------------------------

def _demanded_currents(p, x, alpha1, gamma1):
    """i_sd*, i_sq* demanded by the virtual controls (written out from the flux-frame algebra)."""
    phi, d, q, _ = x
    m = p.curve.m(math.hypot(d, q))
    cc = 1.0 + p.k**2 * m / p.l_r
    i_mud = alpha1 / (p.R_r / p.l_r * p.k * m)
    i_muq = gamma1 / (1.5 * p.n_p * p.k / (p.J * p.l_r) * m * phi)
    return cc * i_mud - p.k / p.l_r * phi, cc * i_muq


def test_a_bound_virtual_control_demands_exactly_i_max_and_its_gradient_holds_it_constant():
    x, t, i_max = (0.9, 5.0, 3.0, 20.0), 0.013, 12.0
    es = error_system(x, ref(t), P, BacksteppingGains(), theta=5.0, i_max=i_max)
    assert es.torque_limited == 1 and es.flux_limited == 1  # 50 rad/s below the reference: full torque
    phi, d, q, w = x
    m = P.curve.m(math.hypot(d, q))
    a, K = P.R_r / P.l_r, 1.5 * P.n_p * P.k / (P.J * P.l_r)
    alpha1 = a * P.k * m * d - es.e2
    gamma1 = K * m * phi * q - es.z2
    i_sd, i_sq = _demanded_currents(P, x, alpha1, gamma1)
    assert math.hypot(i_sd, i_sq) == pytest.approx(i_max, rel=1e-12)
    # gamma1 held: dz2/domega_m = 0 and no reference derivative terms
    assert es.grad_z2[3] == 0.0 and es.dt_z2 == 0.0
    free = error_system(x, ref(t), P, BacksteppingGains(), theta=5.0)
    assert free.grad_z2[:3] == es.grad_z2[:3]
    i_sd_f, i_sq_f = _demanded_currents(P, x, a * P.k * m * d - free.e2, K * m * phi * q - free.z2)
    assert math.hypot(i_sd_f, i_sq_f) > 2.5 * i_max  # the bound matters here


def test_the_flux_current_is_bounded_first():
    x = (0.2, 1.0, 0.0, 0.0)  # far below a 0.9 Wb reference: a large flux demand
    es = error_system(x, ref(0.0), P, BacksteppingGains(), i_max=10.0)
    assert es.flux_limited == 1
    m = P.curve.m(1.0)
    alpha1 = P.R_r / P.l_r * P.k * m * 1.0 - es.e2
    i_sd, _ = _demanded_currents(P, x, alpha1, 1.0)
    assert i_sd == pytest.approx(0.9 * 10.0, rel=1e-12)
    assert es.grad_e2[0] == 0.0 and es.dt_e2 == 0.0


# ----- drive: flux source, start-up, delay ------------------------------------------------------

def _meas_run(drive, n, phi=0.0, w=0.0, i=(5.0, 0.0)):
    return [drive.step((i[0], i[1], phi, 0.0, 0.0, 0.0, w), 50.0, 0.95, 0.0) for _ in range(n)]


def test_no_switch_to_the_law_below_the_minimum_flux_even_after_the_time_out():
    d = BacksteppingDrive(P)
    n_timeout = round(d.dcfg.premag_time_max / d.Ts)
    outs = _meas_run(d, n_timeout + 50, phi=0.2 * 0.95)  # 20 % of the set-point: never enough
    assert all(o.phase == PREMAG for o in outs)
    d2 = BacksteppingDrive(P)
    outs = _meas_run(d2, n_timeout + 2, phi=0.6 * 0.95)  # above premag_min_fraction: after the time-out
    assert outs[n_timeout - 1].phase == PREMAG and outs[-1].phase == RUN


def test_a_moving_rotor_hands_over_at_the_minimum_flux_with_the_fastest_flux_current():
    d = BacksteppingDrive(P)
    o = _meas_run(d, 1, phi=0.3, w=-5.0, i=(25.0, 0.0))[0]
    assert o.phase == PREMAG  # 0.3 Wb < 0.5 x 0.95
    assert o.v_sd == pytest.approx(P.R_s * 27.0 + d.dcfg.premag_gain * (27.0 - 25.0), rel=1e-12)  # 0.9 I_max
    assert _meas_run(d, 1, phi=0.5, w=-5.0)[0].phase == RUN


def test_observer_mode_ignores_the_flux_inputs_and_reports_its_estimate():
    plant = Plant(P)
    x = (0.0,) * 6
    drives = [ControllerUnit({"flux_source": "observer"}).drive for _ in range(2)]
    rng = np.random.default_rng(3)
    for k in range(1500):
        o = plant.outputs(x)
        meas = (o.i_s_alpha, o.i_s_beta, x[2], x[3], x[0], x[1], x[4])
        junk = (o.i_s_alpha, o.i_s_beta, *rng.normal(size=4), x[4])
        a, b = drives[0].step(meas, 20.0, 0.95, 0.0), drives[1].step(junk, 20.0, 0.95, 0.0)
        assert a == b
        x = plant.step(k * 1e-4, x, a.v_s_alpha, a.v_s_beta, 0.0, 1e-4, 1)
    assert a.phase == RUN
    assert math.hypot(a.psi_r_hat_alpha - x[2], a.psi_r_hat_beta - x[3]) < 2e-3  # the estimate, not junk


def test_observer_with_measured_stator_flux_is_refused():
    with pytest.raises(ParameterError, match="use_stator_flux"):
        ControllerUnit({"flux_source": "observer", "use_stator_flux": True})


@pytest.mark.parametrize("values, field", [({"flux_source": "estimated"}, "flux_source"),
                                           ({"delay_samples": 2}, "delay_samples"),
                                           ({"c0": -1.0}, "c0"), ({"d0": math.nan}, "d0")])
def test_bad_new_controller_parameters_are_refused_by_name(values, field):
    with pytest.raises(ParameterError) as e:
        ControllerUnit(values)
    assert e.value.field == field


def test_delay_output_is_the_previous_samples_command():
    x = (0.9, 5.0, 3.0, 50.0)
    d0, d1 = (BacksteppingDrive(P, drive_cfg=DriveConfig(delay_samples=k)) for k in (0, 1))
    meas = measure(P, x, 0.3)
    outs = [d1.step(meas, 50.0, 0.9, 0.0) for _ in range(3)]
    assert (outs[0].v_s_alpha, outs[0].v_s_beta) == (0.0, 0.0)  # nothing computed before t_0
    assert all(o.phase == RUN for o in outs)
    # the voltage applied at sample k is the command (v_sd, v_sq in its frame) computed at k - 1
    for prev, now in zip(outs, outs[1:]):
        applied = math.hypot(now.v_s_alpha, now.v_s_beta)
        assert applied == pytest.approx(math.hypot(prev.v_sd, prev.v_sq), rel=1e-12)
    assert d0.step(meas, 50.0, 0.9, 0.0).v_s_alpha != 0.0


def test_prediction_of_the_exact_model_matches_the_plant_one_sample_later():
    """No model error: the predicted measurements equal the plant's next sample (RK4 with 10 sub-steps)
    up to the RK4 error of one 100 us step."""
    plant, Ts = Plant(P), 1e-4
    comp = DelayCompensator(P, Ts, bias_gain=0.0)
    x = (0.8, 0.1, 0.75, 0.05, 80.0, 0.0)
    comp.swap(150.0, -60.0)  # the pending voltage, held over the next sample
    o = plant.outputs(x)
    pred = comp.predict((o.i_s_alpha, o.i_s_beta, x[2], x[3], x[0], x[1], x[4]), 5.0)
    x1 = plant.step(0.0, x, 150.0, -60.0, 5.0, Ts, 10)
    o1 = plant.outputs(x1)
    truth = (o1.i_s_alpha, o1.i_s_beta, x1[2], x1[3], x1[0], x1[1], x1[4])
    for p_, t_, scale in zip(pred, truth, (10.0, 10.0, 1.0, 1.0, 1.0, 1.0, 100.0)):
        assert abs(p_ - t_) < 1e-7 * scale
    moved = max(abs(a - b) / s for a, b, s in zip((o.i_s_alpha, o.i_s_beta), truth[:2], (10.0, 10.0)))
    assert moved > 1e-3  # the prediction had somewhere to go


def test_the_measurement_layout_is_the_controllers_input_order():
    """The drive's measurement tuple is the controller unit's first inputs as they come (no reordering)."""
    from satmotor.control import measurements as m
    names = list(ControllerUnit.INPUTS)
    want = {"MEAS_I_S_A": "i_s_alpha", "MEAS_I_S_B": "i_s_beta", "MEAS_PSI_R_A": "psi_r_alpha",
            "MEAS_PSI_R_B": "psi_r_beta", "MEAS_PSI_S_A": "psi_s_alpha", "MEAS_PSI_S_B": "psi_s_beta",
            "MEAS_OMEGA_M": "omega_m"}
    assert {k: getattr(m, k) for k in want} == {k: names.index(n) for k, n in want.items()}
    assert m.MEAS_LEN == len(want) and tuple(m.MEAS_NAMES) == tuple(names[:m.MEAS_LEN])
    assert (m.MEAS_I_MU_A, m.MEAS_I_MU_B) == (m.MEAS_LEN, m.MEAS_LEN + 1)  # appended by the plain loop


def test_pre_magnetization_reports_the_shapers_at_rest_not_the_measurements():
    """Before the law runs the shaped-reference outputs are the shapers' values (at rest: 0), whatever the
    measured flux and speed; the first run sample starts them at the measured state (no jump for the law)."""
    d = BacksteppingDrive(P)
    n_timeout = round(d.dcfg.premag_time_max / d.Ts)
    outs = _meas_run(d, n_timeout + 2, phi=0.6 * 0.95, w=1.5)  # flux and speed measured, below the switch
    pre, first = outs[:n_timeout], outs[n_timeout]
    assert all(o.phase == PREMAG for o in pre) and first.phase == RUN
    assert {(o.omega_ref_shaped, o.psi_ref_shaped) for o in pre} == {(0.0, 0.0)}
    assert first.omega_ref_shaped == 1.5 and first.psi_ref_shaped == pytest.approx(0.6 * 0.95, rel=1e-15)
    assert first.z1 == 0.0 and first.e1 == pytest.approx(0.0, abs=1e-15)
