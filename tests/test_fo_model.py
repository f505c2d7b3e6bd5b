"""The rotor-flux-oriented control model against the stationary plant (a second frame)."""

import math

import numpy as np
import pytest
from conftest import CURVES
from scipy.integrate import solve_ivp

from satmotor.control.fo_model import FluxOrientedModel, from_stationary, to_stationary
from satmotor.machine.params import MotorParams
from satmotor.machine.plant import Plant, initial_state

T_STEP, T_END, LOAD = 0.2, 0.4, 15.0


def v_dq(t):
    """Flux-frame voltages of an open-loop start-up [V]."""
    return 25.0 + 20.0 * math.sin(30.0 * t), 30.0 + 600.0 * t


def run_both(p, times):
    plant, fo = Plant(p), FluxOrientedModel(p)
    x0 = initial_state(p, psi_r_alpha=0.55 * math.cos(0.3), psi_r_beta=0.55 * math.sin(0.3))
    z0, rho0 = from_stationary(plant, x0)

    def f_stat(t, x, load):
        rho = math.atan2(x[3], x[2])
        vd, vq = v_dq(t)
        c, s = math.cos(rho), math.sin(rho)
        return plant.derivatives(t, x, c * vd - s * vq, s * vd + c * vq, load)

    def f_fo(t, z, load):
        return fo.derivatives_with_angle(t, z, *v_dq(t), load)

    opts = dict(method="DOP853", rtol=1e-12, atol=1e-12)
    res = []
    for f, y0 in ((f_stat, x0), (f_fo, tuple(z0) + (rho0,))):
        t1 = [t for t in times if t <= T_STEP]
        t2 = [t for t in times if t > T_STEP]
        a = solve_ivp(f, (0, T_STEP), y0, t_eval=t1, args=(0.0,), **opts)
        b = solve_ivp(f, (T_STEP, T_END), a.y[:, -1] if t1[-1] == T_STEP else None, t_eval=t2,
                      args=(LOAD,), **opts)
        res.append(np.hstack([a.y, b.y]))
    return plant, res[0], res[1]


@pytest.mark.parametrize("name", ["arctan", "table", "linear"])
def test_flux_oriented_model_agrees_with_stationary_plant(name):
    p = MotorParams(curve=CURVES[name], k=0.9, l_r=5.839e-3 * 0.81, R_r=1.395 * 0.81)
    times = list(np.linspace(0.0, T_END, 81))
    assert T_STEP in times
    plant, xs, zs = run_both(p, times)
    got = np.array([from_stationary(plant, xs[:, j])[0] for j in range(len(times))]).T
    scale = np.max(np.abs(zs[:4]), axis=1)  # per-state magnitude over the run
    err = np.max(np.abs(got - zs[:4]), axis=1) / scale
    assert np.all(err < 1e-6), err
    # the start-up actually happened: flux kept, speed reached, the load step felt
    assert np.min(zs[0]) > 0.3 and zs[3, -1] > 30.0
    # the flux angle too
    rho_stat = np.unwrap(np.arctan2(xs[3], xs[2]))
    assert np.max(np.abs(rho_stat - zs[4])) < 1e-6


def test_state_conversion_round_trips():
    p = MotorParams(k=0.9)
    plant = Plant(p)
    z = (0.8, 4.0, -2.5, 100.0)
    x = to_stationary(p, z, rho=1.1, theta_m=0.3)
    z2, rho = from_stationary(plant, x)
    assert rho == pytest.approx(1.1, rel=1e-14)
    assert np.allclose(z2, z, rtol=1e-12, atol=1e-12)


def test_model_is_regular_at_zero_quadrature_current():
    """The seed's a, b3, g0 divide by M_dq = 0 at i_mu_q = 0; the compact form does not."""
    fo = FluxOrientedModel(MotorParams())
    F, G, aux = fo.fields((0.9, 5.5, 0.0, 0.0), 0.0)
    assert all(math.isfinite(v) for v in F) and all(math.isfinite(v) for row in G for v in row)
    assert aux["M_dq"] == 0.0
