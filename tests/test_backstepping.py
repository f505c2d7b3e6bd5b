"""Backstepping controller and measurement reconstruction against independent references.

References: central finite differences of the error functions written out here from their
definitions, FluxOrientedModel.fields for F and G, the stationary Plant's own outputs, and
closed-loop integrations with scipy's solve_ivp.
"""

import math

import numpy as np
import pytest
from conftest import CURVES
from scipy.integrate import solve_ivp

from satmotor.control.backstepping import BacksteppingGains, ControllerConfig, control, error_system
from satmotor.control.fo_model import FluxOrientedModel, from_stationary, to_stationary
from satmotor.control.measurements import from_rotor_flux, from_stator_flux
from satmotor.errors import ParameterError
from satmotor.machine.integrate import rk4
from satmotor.machine.magnetics import LinearCurve
from satmotor.machine.params import MotorParams
from satmotor.machine.plant import PSI_R_A, PSI_R_B, PSI_S_A, PSI_S_B, Plant

P = MotorParams()
G = BacksteppingGains()
PARAMS = {name: MotorParams(curve=c) for name, c in CURVES.items()}
# k != 1 exercises every k in the formulas
PARAMS["arctan_k"] = MotorParams(k=0.9, l_r=5.839e-3 * 0.81, R_r=1.395 * 0.81)
_PLANTS = {}

WF, WW, WL = 2 * math.pi * 8.0, 2 * math.pi * 3.0, 2 * math.pi * 5.0


def ref(t):
    """Smooth references with analytic derivatives: (Phi, Phi', Phi'', w, w', w'')."""
    sf, cf, sw, cw = math.sin(WF * t), math.cos(WF * t), math.sin(WW * t), math.cos(WW * t)
    return (0.9 + 0.1 * sf, 0.1 * WF * cf, -0.1 * WF**2 * sf,
            60.0 + 40.0 * sw, 40.0 * WW * cw, -40.0 * WW**2 * sw)


def load(t):
    return 8.0 + 4.0 * math.sin(WL * t), 4.0 * WL * math.cos(WL * t)


def measure(p, x, rho):
    """Stationary-frame measurements of the flux-oriented state x at flux angle rho (via the Plant)."""
    plant = _PLANTS.setdefault(id(p), Plant(p))
    xs = to_stationary(p, x, rho)
    o = plant.outputs(xs)
    return (o.i_s_alpha, o.i_s_beta, xs[PSI_R_A], xs[PSI_R_B], xs[PSI_S_A], xs[PSI_S_B], x[3])


# ----- the error functions, written out from their definitions ---------------------------------

def e2_of(p, g, x, t):
    phi, d, q, _ = x
    a = p.R_r / p.l_r
    pr, dpr = ref(t)[:2]
    alpha1 = -g.c1 * (phi - pr) + a * phi + dpr
    return a * p.k * p.curve.m(math.hypot(d, q)) * d - alpha1


def z2_of(p, g, x, t, theta=None):
    phi, d, q, w = x
    _, _, _, wr, dwr, _ = ref(t)
    th = load(t)[0] / p.J if theta is None else theta
    gamma1 = -g.d1 * (w - wr) + th + p.B / p.J * w + dwr
    return 1.5 * p.n_p * p.k / (p.J * p.l_r) * p.curve.m(math.hypot(d, q)) * phi * q - gamma1


def fd_grad(f, x, t):
    out = []
    for i in range(4):
        h = 1e-6 * max(abs(x[i]), 1.0)
        xp, xm = list(x), list(x)
        xp[i] += h
        xm[i] -= h
        out.append((f(xp, t) - f(xm, t)) / (2 * h))
    ht = 1e-6
    return out, (f(x, t + ht) - f(x, t - ht)) / (2 * ht)


STATES = [(0.9, 5.0, 3.0, 100.0), (0.6, 4.0, 0.0, -50.0), (1.1, 8.0, -6.0, 20.0),
          (0.3, -1.0, 2.0, 0.0), (0.95, 6.5, 0.0, 140.0)]


def _check_error_system(p, x, t):
    g = G
    th, dth = load(t)[0] / p.J, load(t)[1] / p.J
    es = error_system(x, ref(t), p, g, theta=th, theta_dot=dth)
    ge, dte = fd_grad(lambda y, s: e2_of(p, g, y, s), x, t)
    gz, dtz = fd_grad(lambda y, s: z2_of(p, g, y, s), x, t)
    phi, d, q, _ = x
    m = p.curve.m(math.hypot(d, q))
    a, K = p.R_r / p.l_r, 1.5 * p.n_p * p.k / (p.J * p.l_r)
    se = (a, a * p.k * m, a * p.k * m, 1.0)
    sz = (K * m * math.hypot(d, q), K * phi * m, K * phi * m, g.d1)
    errs = {}
    errs["grad"] = max(max(abs(u - v) / (abs(v) + s) for u, v, s in zip(es.grad_e2, ge, se)),
                       max(abs(u - v) / (abs(v) + s) for u, v, s in zip(es.grad_z2, gz, sz)))
    errs["dt"] = max(abs(es.dt_e2 - dte) / (abs(dte) + 1.0), abs(es.dt_z2 - dtz) / (abs(dtz) + 1.0))
    F, Gm, aux = FluxOrientedModel(p).fields(x, load(t)[0])
    for name, gr, dt, beta in (("beta1", ge, dte, es.beta1), ("beta2", gz, dtz, es.beta2)):
        ref_b = sum(u * f for u, f in zip(gr, F)) + dt
        scale = sum(abs(u * f) for u, f in zip(gr, F)) + abs(dt)
        errs[name] = abs(beta - ref_b) / scale
    lam = [[sum(gr[k] * Gm[k][j] for k in range(4)) for j in range(2)] for gr in (ge, gz)]
    errs["Lambda"] = max(abs(es.Lambda[i][j] - lam[i][j]) / max(abs(v) for v in lam[i])
                         for i in range(2) for j in range(2))
    _, m_, _, ldyn = p.curve.evaluate(math.hypot(d, q))
    sg = p.sigma
    w_cf = a * p.k * K * phi * m_ * ldyn / ((p.l_s + sg * m_) * (p.l_s + sg * ldyn))
    det_fd = lam[0][0] * lam[1][1] - lam[0][1] * lam[1][0]
    errs["W"] = max(abs(w_cf - es.W), abs(w_cf - det_fd)) / abs(w_cf)
    assert math.isclose(es.omega_s, aux["omega_s"], rel_tol=1e-12)
    return errs


TOL = {"grad": 1e-6, "dt": 1e-6, "beta1": 1e-6, "beta2": 1e-6, "Lambda": 1e-6, "W": 1e-6}


@pytest.mark.parametrize("name", list(PARAMS))
@pytest.mark.parametrize("x", STATES)
def test_gradients_beta_lambda_W_against_finite_differences(name, x):
    errs = _check_error_system(PARAMS[name], x, t=0.013)
    for key, tol in TOL.items():
        assert errs[key] < tol, (key, errs[key])


def test_estimated_mode_beta2_includes_update_law():
    p, x, t = P, STATES[0], 0.02
    th_hat, gth = 400.0, 7.0
    es = error_system(x, ref(t), p, G, theta=th_hat, adapt=(gth, 1e4))
    z1 = x[3] - ref(t)[3]
    z2 = z2_of(p, G, x, t, theta=th_hat)
    expected = -gth * (z1 + (G.d1 - p.B / p.J) * z2)
    assert es.theta_dot == pytest.approx(expected, rel=1e-12)
    known = error_system(x, ref(t), p, G, theta=th_hat, theta_dot=expected)
    assert es.beta2 == pytest.approx(known.beta2, rel=1e-13)
    # projection: at the bound and pushing outward -> no update; pushing inward -> update kept
    at_max = error_system(x, ref(t), p, G, theta=1e4, adapt=(gth, 1e4))
    at_min = error_system(x, ref(t), p, G, theta=-1e4, adapt=(gth, 1e4))
    pushes = [-gth * (e.z1 + (G.d1 - p.B / p.J) * e.z2) for e in (at_max, at_min)]
    assert (at_max.theta_dot == 0.0) == (pushes[0] > 0) and (at_min.theta_dot == 0.0) == (pushes[1] < 0)
    assert (at_max.theta_dot == 0.0) or (at_min.theta_dot == 0.0)


# ----- measurements ---------------------------------------------------------------------------

def _random_states(n, seed):
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        phi, ang = rng.uniform(0.05, 1.3), rng.uniform(-math.pi, math.pi)
        imd, imq = rng.uniform(-2.0, 12.0), rng.uniform(-10.0, 10.0)
        out.append(((phi, imd, imq, rng.uniform(-150, 150)), ang))
    return out


@pytest.mark.parametrize("name", list(PARAMS))
def test_measurements_match_plant_outputs(name):
    p = PARAMS[name]
    plant = Plant(p)
    for x, rho in _random_states(20, 1):
        xs = to_stationary(p, x, rho)
        o = plant.outputs(xs)
        x_fo, rho_fo = from_stationary(plant, xs)
        for ms in (from_rotor_flux(o.i_s_alpha, o.i_s_beta, xs[PSI_R_A], xs[PSI_R_B], p),
                   from_stator_flux(o.i_s_alpha, o.i_s_beta, xs[PSI_R_A], xs[PSI_R_B],
                                    xs[PSI_S_A], xs[PSI_S_B], p)):
            s = o.i_mu
            assert abs(ms.i_mu_alpha - o.i_mu_alpha) < 1e-10 * s
            assert abs(ms.i_mu_beta - o.i_mu_beta) < 1e-10 * s
            assert ms.I == pytest.approx(o.i_mu, rel=1e-10)
            assert ms.m == pytest.approx(o.m, rel=1e-10)
            assert ms.Phi_rd == pytest.approx(x_fo[0], rel=1e-12)
            assert abs(ms.i_mu_d - x_fo[1]) < 1e-10 * s and abs(ms.i_mu_q - x_fo[2]) < 1e-10 * s
            assert math.isclose(ms.rho, rho_fo, abs_tol=1e-12)
            assert abs(ms.i_mu_d - x[1]) < 1e-9 * s and abs(ms.i_mu_q - x[2]) < 1e-9 * s


def test_controller_uses_its_own_curve_not_the_plants():
    p_ctrl = MotorParams(curve=LinearCurve(0.1722))
    meas = measure(P, (0.9, 5.0, 3.0, 100.0), 0.4)  # saturated plant
    ms = from_rotor_flux(*meas[:4], p_ctrl)
    k_lr = p_ctrl.k / p_ctrl.l_r
    den = 1.0 + p_ctrl.k**2 * 0.1722 / p_ctrl.l_r
    assert ms.i_mu_alpha == pytest.approx((meas[0] + k_lr * meas[2]) / den, rel=1e-13)
    assert ms.m == pytest.approx(0.1722, rel=1e-13)
    out = control(meas, ref(0.0), load(0.0), p_ctrl, G, ControllerConfig())
    assert all(math.isfinite(v) for v in out[:16])


# ----- closed loop ----------------------------------------------------------------------------

def _closed_loop(p, cfg, y0, t_end, adaptive):
    model = FluxOrientedModel(p)
    t_load = 15.0

    def rhs(t, y):
        th = y[5] if adaptive else 0.0
        tl = (t_load, 0.0) if adaptive else load(t)
        out = control(measure(p, y[:4], y[4]), ref(t), tl, p, G, cfg, th)
        c, s = math.cos(y[4]), math.sin(y[4])  # Ts = 0: rotated by rho itself
        vsd = c * out.v_s_alpha + s * out.v_s_beta
        vsq = -s * out.v_s_alpha + c * out.v_s_beta
        d = model.derivatives_with_angle(t, y[:5], vsd, vsq, tl[0])
        return d + (out.theta_hat_dot,) if adaptive else d

    def state_out(t, y):
        th = y[5] if adaptive else 0.0
        tl = (t_load, 0.0) if adaptive else load(t)
        return control(measure(p, y[:4], y[4]), ref(t), tl, p, G, cfg, th)

    t_eval = np.linspace(0.0, t_end, 25)
    sol = solve_ivp(rhs, (0.0, t_end), y0, method="DOP853", rtol=1e-10, atol=1e-10, t_eval=t_eval)
    assert sol.success
    return sol, rhs, state_out, t_load / p.J


def _flow_derivative(rhs, fn, t, y, h=4e-6):
    """d fn(t, y(t))/dt along the closed-loop flow: Richardson-extrapolated central differences."""
    def central(hh):
        yp = rk4(lambda s, z: rhs(s, z), t, y, hh, 4)
        ym = rk4(lambda s, z: rhs(s, z), t, y, -hh, 4)
        return (fn(t + hh, yp) - fn(t - hh, ym)) / (2 * hh)
    return (4.0 * central(h / 2) - central(h)) / 3.0


def _premagnetized(p, phi0=0.8):
    I0 = p.curve.current(phi0 / p.k)
    return [phi0 * 1.05, I0 * 1.1, 0.5, 5.0, 0.2]


CT = dict(Ts=0.0, V_dc=1e9)


@pytest.mark.parametrize("use_stator_flux", [False, True])
def test_lyapunov_known_load(use_stator_flux):
    p = P
    cfg = ControllerConfig(**CT, use_stator_flux=use_stator_flux)
    sol, rhs, out_of, _ = _closed_loop(p, cfg, _premagnetized(p), 0.05, adaptive=False)
    outs = [out_of(t, y) for t, y in zip(sol.t, sol.y.T)]
    V = [o.V for o in outs]
    assert all(v1 <= v0 * (1 + 1e-9) for v0, v1 in zip(V, V[1:]))
    assert V[-1] < 1e-3 * V[0]
    worst = {"Vdot": 0.0, "e1dot": 0.0, "z1dot": 0.0}
    for t, y, o in list(zip(sol.t, sol.y.T, outs))[::3]:
        vdot = _flow_derivative(rhs, lambda s, z: out_of(s, z).V, t, y)
        vref = -(G.c1 * o.e1**2 + G.c2 * o.e2**2 + G.d1 * o.z1**2 + G.d2 * o.z2**2)
        worst["Vdot"] = max(worst["Vdot"], abs(vdot - vref) / abs(vref))
        e1dot = _flow_derivative(rhs, lambda s, z: out_of(s, z).e1, t, y)
        worst["e1dot"] = max(worst["e1dot"], abs(e1dot + G.c1 * o.e1 - o.e2) / (G.c1 * abs(o.e1) + abs(o.e2)))
        z1dot = _flow_derivative(rhs, lambda s, z: out_of(s, z).z1, t, y)
        worst["z1dot"] = max(worst["z1dot"], abs(z1dot + G.d1 * o.z1 - o.z2) / (G.d1 * abs(o.z1) + abs(o.z2)))
    assert max(worst.values()) < 1e-5, worst


def test_lyapunov_estimated_load_and_convergence():
    p = P
    cfg = ControllerConfig(**CT, load_mode="estimated")
    sol, rhs, out_of, theta = _closed_loop(p, cfg, _premagnetized(p) + [0.0], 0.1, adaptive=True)

    def va(t, y):
        o = out_of(t, y)
        return o.V + (y[5] - theta) ** 2 / (2 * cfg.g_theta)

    Va = [va(t, y) for t, y in zip(sol.t, sol.y.T)]
    assert all(v1 <= v0 * (1 + 1e-9) for v0, v1 in zip(Va, Va[1:]))
    for t, y in list(zip(sol.t, sol.y.T))[::4]:
        o = out_of(t, y)
        vref = -(G.c1 * o.e1**2 + G.c2 * o.e2**2 + G.d1 * o.z1**2 + G.d2 * o.z2**2)
        assert _flow_derivative(rhs, va, t, y) == pytest.approx(vref, rel=1e-5)
    th = sol.y[5]
    assert abs(th[-1] - theta) < 1e-2 * abs(th[0] - theta)


# ----- output transform, singularity, limits, validation ------------------------------------------

@pytest.mark.parametrize("Ts", [0.0, 1e-4, 2.5e-4])
def test_output_rotation(Ts):
    cfg = ControllerConfig(Ts=Ts)
    for x, rho in _random_states(10, 2):
        meas = measure(P, x, rho)
        o = control(meas, ref(0.01), load(0.01), P, G, cfg)
        assert math.isclose(o.rho, math.atan2(meas[3], meas[2]), abs_tol=1e-15)
        r = o.rho + o.omega_s * Ts / 2
        c, s = math.cos(r), math.sin(r)
        vd, vq = c * o.v_s_alpha + s * o.v_s_beta, -s * o.v_s_alpha + c * o.v_s_beta
        n = math.hypot(o.v_sd, o.v_sq)
        assert abs(vd - o.v_sd) < 1e-12 * n and abs(vq - o.v_sq) < 1e-12 * n


@pytest.mark.parametrize("phi", [0.0, 1e-9, 0.01])
@pytest.mark.parametrize("i_s", [(0.0, 0.0), (3.0, -2.0)])
@pytest.mark.parametrize("mode", ["known", "estimated"])
def test_near_singular_flux_is_finite_and_flagged(phi, i_s, mode):
    cfg = ControllerConfig(load_mode=mode)
    meas = (i_s[0], i_s[1], phi, 0.0, 0.0, 0.0, 10.0)
    o = control(meas, ref(0.0), load(0.0), P, G, cfg, theta_hat=100.0)
    assert all(math.isfinite(v) for v in o[:16])
    assert o.singular_limited
    assert math.hypot(o.v_sd, o.v_sq) <= cfg.V_dc / math.sqrt(3) * (1 + 1e-12)
    _, m, _, ldyn = P.curve.evaluate(o.i_mu)  # reported W: the true det Lambda (errata closed form)
    w_cf = (P.R_r / P.l_r * P.k * P.kappa * P.k * phi / (P.J * P.l_r) * m * ldyn
            / ((P.l_s + P.sigma * m) * (P.l_s + P.sigma * ldyn)))
    assert o.W == pytest.approx(w_cf, rel=1e-12, abs=0.0)
    ok = control(measure(P, (0.9, 5.0, 3.0, 100.0), 0.1), ref(0.0), load(0.0), P, G, cfg)
    assert not ok.singular_limited


def test_voltage_limit():
    meas = measure(P, (0.9, 5.0, 1.0, 100.0), 0.3)
    r = list(ref(0.0))
    big = ControllerConfig(V_dc=1e12)
    free = control(meas, r, load(0.0), P, G, big)
    n0 = math.hypot(free.v_sd, free.v_sq)
    roomy = control(meas, r, load(0.0), P, G, ControllerConfig(V_dc=2 * n0 * math.sqrt(3)))
    assert not roomy.voltage_limited and roomy.v_sd == free.v_sd and roomy.v_sq == free.v_sq
    tight = control(meas, r, load(0.0), P, G, ControllerConfig(V_dc=0.5 * n0 * math.sqrt(3)))
    assert tight.voltage_limited
    assert math.hypot(tight.v_sd, tight.v_sq) == pytest.approx(0.5 * n0, rel=1e-13)
    assert tight.v_sd * free.v_sq - tight.v_sq * free.v_sd == pytest.approx(0.0, abs=1e-9 * n0 * n0)
    r[3] = 1e5  # huge speed error
    cfg = ControllerConfig()
    o = control(meas, r, load(0.0), P, G, cfg)
    assert o.voltage_limited
    assert math.hypot(o.v_sd, o.v_sq) == pytest.approx(cfg.V_dc / math.sqrt(3), rel=1e-13)
    assert math.hypot(o.v_s_alpha, o.v_s_beta) == pytest.approx(cfg.V_dc / math.sqrt(3), rel=1e-13)


@pytest.mark.parametrize("field", ["c1", "c2", "d1", "d2"])
@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf")])
def test_bad_gains(field, bad):
    with pytest.raises(ParameterError) as ei:
        BacksteppingGains(**{field: bad})
    assert ei.value.field == field


@pytest.mark.parametrize("field, bad", [("Ts", -1e-4), ("Ts", float("nan")), ("V_dc", 0.0), ("V_dc", -540.0),
                                        ("phi_min", 0.0), ("load_mode", "guess"), ("g_theta", 0.0),
                                        ("theta_max", -1.0), ("use_stator_flux", 1)])
def test_bad_config(field, bad):
    with pytest.raises(ParameterError) as ei:
        ControllerConfig(**{field: bad})
    assert ei.value.field == field
