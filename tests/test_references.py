"""Reference shaper: exact discretization against an independent integrator and the calculus."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm

from satmotor.control.references import (
    RISE_TIME_PRODUCT,
    ReferenceShaper,
    design_bandwidth_from_rise_time,
    input_vector,
    transition_matrix,
)
from satmotor.errors import ParameterError

W = 40.0  # [rad/s]


def raw(t):
    """A raw set-point: a step to 1 at t = 0, a step to -0.5 at t = 0.3, a ramp from 0.5 s."""
    if t < 0.3:
        return 1.0
    if t < 0.5:
        return -0.5
    return -0.5 + 4.0 * (t - 0.5)


def companion(w):
    return np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-(w**3), -3.0 * w**2, -3.0 * w]])


def run(shaper, h, t_end, u_of_t=raw):
    n = round(t_end / h)
    out = [shaper.value]
    for j in range(n):
        out.append(shaper.step(u_of_t(j * h), h))
    return np.array(out)


@pytest.mark.parametrize("w, h", [(W, 1e-3), (3.0, 0.05), (2000.0, 1e-4), (1e4, 1e-2)])
def test_closed_form_matches_expm(w, h):
    P = np.array(transition_matrix(w, h))
    A = companion(w)
    P_ref = expm(A * h)
    scale = np.array([1.0, w, w * w])  # r, r', r'' magnitudes
    assert np.max(np.abs(P - P_ref) * scale[None, :] / scale[:, None]) < 1e-13
    b = np.array([0.0, 0.0, w**3])
    G_ref = np.linalg.solve(A, (P_ref - np.eye(3)) @ b)
    G = np.array(input_vector(w, h))
    assert np.max(np.abs(G - G_ref) / scale) < 1e-13
    assert input_vector(w, h)[0] > 0.0


def test_tiny_step_input_vector_has_full_relative_accuracy():
    x = 1e-4
    g0 = input_vector(1.0, x)[0]
    assert g0 == pytest.approx(x**3 / 6.0 - x**4 / 8.0, rel=1e-12)


def test_exact_against_solve_ivp_with_steps():
    h, t_end = 2e-3, 0.5  # piecewise constant raw signal: ZOH is exact
    sh = ReferenceShaper(W, initial=0.2)
    z = run(sh, h, t_end)
    A = companion(W)
    b = np.array([0.0, 0.0, W**3])
    x = np.array([0.2, 0.0, 0.0])
    worst = 0.0
    for t0, t1 in ((0.0, 0.3), (0.3, 0.5)):
        u = raw(t0)
        sol = solve_ivp(lambda t, y, u=u: A @ y + b * u, (t0, t1), x, method="DOP853",
                        rtol=1e-12, atol=1e-14, dense_output=True)
        for j in range(round(t0 / h), round(t1 / h) + 1):
            ref = sol.sol(j * h)
            err = np.abs(z[j] - ref) / np.array([1.0, W, W * W])
            worst = max(worst, err.max())
        x = sol.y[:, -1]
    assert worst < 1e-10


def test_derivatives_are_the_derivatives_of_r():
    h = 2e-5  # central differences: O(h^2) error away from the input jumps
    sh = ReferenceShaper(W)
    z = run(sh, h, 0.6)
    r, r1, r2 = z[:, 0], z[:, 1], z[:, 2]
    d1 = (r[2:] - r[:-2]) / (2.0 * h)
    d2 = (r[2:] - 2.0 * r[1:-1] + r[:-2]) / (h * h)
    assert np.max(np.abs(d1 - r1[1:-1])) / np.max(np.abs(r1)) < 1e-6
    # r''' jumps at the sample instants of the steps: the central second difference is O(h) there
    assert np.max(np.abs(d2 - r2[1:-1])) / np.max(np.abs(r2)) < 2e-3
    smooth = np.ones_like(d2, dtype=bool)
    for t_jump in (0.0, 0.3, 0.5):
        j = round(t_jump / h)
        smooth[max(j - 2, 0): j + 2] = False
    assert np.max(np.abs(d2 - r2[1:-1])[smooth]) / np.max(np.abs(r2)) < 1e-6


def test_step_response_no_overshoot_dc_gain_and_rise_time():
    w, h = 25.0, 1e-3
    sh = ReferenceShaper(w)
    z = run(sh, h, 2.0, lambda t: 3.0)
    r = z[:, 0]
    assert np.all(np.diff(r) >= 0.0)  # monotone
    assert r.max() <= 3.0
    assert r[-1] == pytest.approx(3.0, rel=1e-12)  # DC gain 1
    t = np.arange(len(r)) * h
    t10, t90 = np.interp(0.3, r, t), np.interp(2.7, r, t)
    assert (t90 - t10) * w == pytest.approx(RISE_TIME_PRODUCT, abs=5e-3)
    assert RISE_TIME_PRODUCT == pytest.approx(4.2202, abs=1e-4)
    assert design_bandwidth_from_rise_time(0.1) == pytest.approx(42.202, abs=1e-3)


def test_two_sample_times_same_trajectory():
    h1, h2 = 1e-3, 5e-3  # the raw signal only changes at multiples of 0.1 s
    u = lambda t: math.floor(t / 0.1 + 1e-9) % 3 - 1.0  # noqa: E731
    z1 = run(ReferenceShaper(W), h1, 1.0, u)
    z2 = run(ReferenceShaper(W), h2, 1.0, u)
    assert np.max(np.abs(z1[::5] - z2) / np.array([1.0, W, W * W])) < 1e-12


def test_changing_h_and_cache():
    sh = ReferenceShaper(W)
    sh.step(1.0, 1e-3)
    sh.step(1.0, 2e-3)
    a = sh.step(1.0, 1e-3)
    ref = ReferenceShaper(W)
    for _ in range(4):
        b = ref.step(1.0, 1e-3)
    assert np.max(np.abs(np.array(a) - b) / np.array([1.0, W, W * W])) < 1e-14


def test_state_save_restore_bit_identical():
    sh = ReferenceShaper(W, initial=1.0)
    for j in range(50):
        sh.step(raw(j * 1e-3), 1e-3)
    s = sh.get_state()
    a = [sh.step(raw(0.05 + j * 1e-3), 1e-3) for j in range(100)]
    sh.set_state(s)
    b = [sh.step(raw(0.05 + j * 1e-3), 1e-3) for j in range(100)]
    assert a == b
    sh.reset(2.0)
    assert sh.value == (2.0, 0.0, 0.0)


@pytest.mark.parametrize("bad", [0.0, -1.0, math.inf, math.nan, "10", True])
def test_bad_bandwidth(bad):
    with pytest.raises(ParameterError) as e:
        ReferenceShaper(bad)
    assert e.value.field == "bandwidth"


@pytest.mark.parametrize("bad", [0.0, -1e-3, math.inf, math.nan])
def test_bad_h_and_input(bad):
    sh = ReferenceShaper(W)
    with pytest.raises(ParameterError) as e:
        sh.step(1.0, bad)
    assert e.value.field == "h"
    with pytest.raises(ParameterError) as e:
        sh.step(math.nan, 1e-3)
    assert e.value.field == "u"
    with pytest.raises(ParameterError) as e:
        sh.set_state((1.0, 2.0))
    assert e.value.field == "state"
