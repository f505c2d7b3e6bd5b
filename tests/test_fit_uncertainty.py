"""The readings' uncertainty carried into fit-curve's points and fits (satmotor/identify/uncertainty.py),
each against a closed form written here.

* Without P_in the point is ``psi_m = sqrt(V^2 - (R_s I)^2) / omega - l_s I``, ``i_mu = I`` (peaks), so
  the derivatives with respect to the relative readings are closed forms: the propagated covariance
  matches them to 1e-8 (central differences of step 1e-6).
* With equal variances on P_loss only, the weighted loss separation is the ordinary least squares; with
  row-dependent variances on P_loss only, the weighted one (numpy.polyfit with weights 1/sigma).
* The linear family with the points' covariance: the slope minimizes ``sum((L i - psi)^2 / (var psi +
  L^2 var i))``, and the slope's variance ``1 / sum((d r_k / d L)^2)`` of the weighted residuals gives
  sigma_rel = sigma_L / L over the whole range.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from satmotor.errors import ParameterError
from satmotor.identify.noload import magnetizing_points, separate_losses
from satmotor.identify.uncertainty import noload_points, point_covariance

R_S, L_S = 1.405, 5.839e-3
V_LL = np.array([80.0, 160.0, 240.0, 320.0, 400.0, 460.0])
I_RMS = np.array([0.5, 1.1, 1.8, 2.9, 4.6, 6.8])
F = np.full(6, 50.0)


def test_covariance_without_p_in_is_the_closed_form():
    sig = (0.01, 0.02, 0.003, 0.01)
    pts, losses = noload_points(V_LL, I_RMS, F, R_S, L_S, rel_sigma=sig)
    assert losses is None
    V, I, w = math.sqrt(2.0 / 3.0) * V_LL, math.sqrt(2.0) * I_RMS, 2.0 * math.pi * F
    root = np.sqrt(V * V - (R_S * I) ** 2)
    d_psi = {"V": V * V / (w * root), "I": -(R_S * I) ** 2 / (w * root) - L_S * I, "f": -root / w}
    d_i = {"V": 0.0 * I, "I": I, "f": 0.0 * I}
    s = dict(zip("VIf", sig))
    var_psi = sum((d_psi[k] * s[k]) ** 2 for k in "VIf")
    var_i = sum((d_i[k] * s[k]) ** 2 for k in "VIf")
    cov_ip = sum(d_i[k] * d_psi[k] * s[k] ** 2 for k in "VIf")
    assert np.allclose(pts.cov[:, 1, 1], var_psi, rtol=1e-8, atol=0)
    assert np.allclose(pts.cov[:, 0, 0], var_i, rtol=1e-8, atol=0)
    assert np.allclose(pts.cov[:, 0, 1], cov_ip, rtol=1e-7, atol=0)
    assert np.array_equal(pts.cov[:, 0, 1], pts.cov[:, 1, 0])


def test_point_covariance_is_first_order_exact_on_a_product():
    """q = V^2 I / f: d q / d(rel V) = 2 q, d/d(rel I) = q, d/d(rel f) = -q."""
    cols = [np.array([1.0, 2.0]), np.array([3.0, 5.0]), np.array([50.0, 60.0])]
    cov = point_covariance(lambda c: np.stack([c[0] ** 2 * c[1] / c[2]]), cols, (0.01, 0.02, 0.03, 0.04))
    q = cols[0] ** 2 * cols[1] / cols[2]
    assert np.allclose(cov[:, 0, 0], q * q * ((2 * 0.01) ** 2 + 0.02**2 + 0.03**2), rtol=1e-9)


@pytest.mark.parametrize("bad", [(0.01, 0.01, 0.01), (0.01, 0.0, 0.01, 0.01),
                                 (0.01, float("nan"), 0.01, 0.01)])
def test_bad_uncertainties_are_refused(bad):
    with pytest.raises(ParameterError, match="rel_sigma"):
        noload_points(V_LL, I_RMS, F, R_S, L_S, rel_sigma=bad)


def test_weighted_loss_separation_is_the_weighted_line():
    E = np.array([50.0, 100.0, 150.0, 200.0, 250.0, 300.0])
    rng = np.random.default_rng(3)
    y = 1.5 * E**2 / 800.0 + 70.0 + rng.standard_normal(E.size) * 2.0
    P_in = y + 100.0
    plain = separate_losses(E, y, P_in)
    cov = np.zeros((E.size, 2, 2))
    cov[:, 1, 1] = 4.0
    same = separate_losses(E, y, P_in, cov)
    assert same.R_fe == pytest.approx(plain.R_fe, rel=1e-12)
    assert same.P_fw == pytest.approx(plain.P_fw, rel=1e-12)
    sd = np.linspace(1.0, 6.0, E.size)
    cov[:, 1, 1] = sd**2
    a, b = np.polyfit(E**2, y, 1, w=1.0 / sd)
    got = separate_losses(E, y, P_in, cov)
    assert got.R_fe == pytest.approx(1.5 / a, rel=1e-10) and got.P_fw == pytest.approx(b, rel=1e-10)


def test_linear_family_sigma_is_the_weighted_slope_variance():
    from scipy.optimize import least_squares

    from satmotor.identify.curve_fit import fit_all

    i = np.array([0.5, 1.0, 1.5, 2.0, 2.5])
    psi = 0.3 * i * np.array([1.01, 0.99, 1.0, 1.02, 0.985])
    cov = np.zeros((i.size, 2, 2))
    cov[:, 0, 0] = (0.01 * i) ** 2
    cov[:, 1, 1] = (0.014 * psi) ** 2
    fits, _ = fit_all(i, psi, least_squares, cov)
    lin = fits["linear"]
    L = lin.params["L_m0"]
    var = cov[:, 1, 1] + L * L * cov[:, 0, 0]
    r = L * i - psi
    # the slope minimizes sum(r^2 / var(L)): its derivative vanishes
    assert np.sum(r * i / var - r * r * L * cov[:, 0, 0] / var**2) == pytest.approx(
        0.0, abs=1e-9 * np.sum(psi * i / var))
    dr = i / np.sqrt(var) - r * L * cov[:, 0, 0] / var**1.5  # d(r / sqrt(var)) / dL
    sigma_L = 1.0 / math.sqrt(np.sum(dr * dr))
    assert lin.sigma_rel == pytest.approx(sigma_L / L, rel=1e-5)
    assert lin.chi2 == pytest.approx(np.sum((L * i - psi) ** 2 / var), rel=1e-9)
    assert lin.names == ("L_m0",) and lin.sigma["L_m0"] == pytest.approx(sigma_L, rel=1e-5)


def _flux_only_points():
    """Points of an arctan curve with a little scatter and a 1 % flux uncertainty only (no current
    uncertainty: every point's weight is then a constant 1 / sigma_psi)."""
    i = np.array([0.4, 0.8, 1.3, 2.0, 2.8, 3.7, 4.8, 6.0, 7.5, 9.0])
    L0, Linf, Ip = 0.28, 0.012, 2.6
    psi = Linf * i + (L0 - Linf) * Ip * np.arctan(i / Ip)
    psi = psi * (1.0 + 0.004 * np.sin(7.0 * i))
    cov = np.zeros((i.size, 2, 2))
    cov[:, 1, 1] = (0.01 * psi) ** 2
    return i, psi, cov


def test_the_linear_slopes_sigma_is_that_of_weighted_least_squares():
    """psi = L i with flux errors only: ordinary weighted least squares, the design matrix X = i / sigma
    (one column), the slope's variance (X^T X)^-1 = 1 / sum(i^2 / sigma^2), written here."""
    from scipy.optimize import least_squares

    from satmotor.identify.curve_fit import fit_all

    i, psi, cov = _flux_only_points()
    lin = fit_all(i, psi, least_squares, cov)[0]["linear"]
    X = (i / np.sqrt(cov[:, 1, 1]))[:, None]
    assert lin.params["L_m0"] == pytest.approx(float(np.linalg.lstsq(X, psi / np.sqrt(cov[:, 1, 1]),
                                                                     rcond=None)[0][0]), rel=1e-9)
    assert lin.cov[0][0] == pytest.approx(float(np.linalg.inv(X.T @ X)[0, 0]), rel=1e-6)


def test_the_arctan_parameters_covariance_is_that_of_the_linearized_fit():
    """The arctan family with flux errors only: the covariance of (L_m0, L_m_inf, I_par) is (J^T J)^-1
    of the weighted model's Jacobian in these parameters, taken here by central differences of the
    curve's closed form (not the fit's own parameterization, nor its Jacobian); the sigmas are its
    diagonal, and fit-curve's prior writes them with the same matrix."""
    from scipy.optimize import least_squares

    from orchestration.tools.fit_curve import prior
    from satmotor.identify.curve_fit import fit_all

    i, psi, cov = _flux_only_points()
    fit = fit_all(i, psi, least_squares, cov)[0]["arctan"]
    p = np.array([fit.params[n] for n in ("L_m0", "L_m_inf", "I_par")])

    def model(q):
        return q[1] * i + (q[0] - q[1]) * q[2] * np.arctan(i / q[2])

    J = np.empty((i.size, 3))
    for k in range(3):
        h = 1e-6 * p[k]
        up, dn = p.copy(), p.copy()
        up[k] += h
        dn[k] -= h
        J[:, k] = (model(up) - model(dn)) / (2.0 * h) / np.sqrt(cov[:, 1, 1])
    C = np.linalg.inv(J.T @ J)
    assert fit.names == ("L_m0", "L_m_inf", "I_par")
    np.testing.assert_allclose(fit.cov, C, rtol=1e-5)  # 1.3e-7 seen
    for k, n in enumerate(fit.names):
        assert fit.sigma[n] == pytest.approx(math.sqrt(C[k, k]), rel=1e-5)
    written = prior(fit)
    assert written["family"] == "arctan" and written["covariance"]["parameters"] == list(fit.names)
    assert written["parameters"]["I_par"] == {"value": fit.params["I_par"], "sigma": fit.sigma["I_par"]}
    np.testing.assert_array_equal(np.array(written["covariance"]["matrix"]), fit.cov)


def test_points_with_p_in_are_those_of_magnetizing_points():
    P = np.array([40.0, 60.0, 90.0, 150.0, 260.0, 420.0])
    pts, losses = noload_points(V_LL, I_RMS, F, R_S, L_S, P)
    ref = magnetizing_points(V_LL, I_RMS, F, R_S, L_S, P, R_fe=losses.R_fe)
    assert np.array_equal(pts.i_mu, ref.i_mu) and np.array_equal(pts.psi_m, ref.psi_m)
    assert pts.cov.shape == (6, 2, 2) and np.all(pts.cov[:, 0, 0] > 0) and np.all(pts.cov[:, 1, 1] > 0)
