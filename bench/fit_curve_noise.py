"""fit-curve under measurement noise: the estimator before and after the weighting, and the Cramer-Rao bound.

Run ``python bench/fit_curve_noise.py [--seeds 200]``; prints the numbers quoted in docs/model.md ("How good
a fit noisy data allow").  The data: ``tests/test_fit_curve_losses.py``'s no-load sweep (the default motor's
arctan curve, T circuit with R_fe = 800 Ohm across E_m and 70 W friction, 10 levels 20-120 % of rated
voltage, 50 Hz), each column times ``1 + 0.01 N(0, 1)`` (``--noise``; seed s:
``numpy.random.default_rng(s)``).  The metric: the largest relative error of psi_m(i_mu) over the
measured current range (300 points), and ``|R_fe / 800 - 1|``.

* ``before``: the points as ``magnetizing_points`` gives them, the loss line and the curves fitted
  unweighted (absolute Wb residuals), the family with the smallest RMS chosen (what fit-curve did);
* ``after``: :func:`satmotor.identify.uncertainty.noload_points` (the readings' noise level carried into each
  point's covariance), the weighted loss line and the errors-in-variables fits, the smallest chi-square;
* ``arctan``: the fit of the true family alone (the family known);
* ``bound``: the Cramer-Rao bound of the arctan parameters from the weighted residuals' Jacobian at the
  true curve, 20000 parameter draws from it, the same metric;
* ``f exact``: noise on V_ll_rms, I_rms and P_in only, and fit-curve told so (``rel_sigma`` f = 1e-4).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from test_fit_curve_losses import L_S, R_S, TRUE, no_load  # noqa: E402

from satmotor.identify.curve_fit import choose, fit_all, rivals  # noqa: E402
from satmotor.identify.noload import magnetizing_points, separate_losses  # noqa: E402
from satmotor.identify.uncertainty import noload_points  # noqa: E402


def _stats(a):
    a = np.asarray(a)
    return (f"median {100 * np.median(a):5.2f} %  p90 {100 * np.quantile(a, 0.9):5.2f} %  worst "
            f"{100 * a.max():5.2f} %  P(>2 %) {np.mean(a > 0.02):.3f}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=200)
    ap.add_argument("--noise", type=float, default=0.01, help="relative standard deviation of every column")
    args = ap.parse_args(argv)
    n, eps = args.seeds, args.noise
    rows, xs = no_load(R_fe=800.0, P_fw=70.0)
    grid = np.linspace(xs.min(), xs.max(), 300)
    true = np.array([TRUE.psi(g) for g in grid])

    def err(curve):
        return float(np.max(np.abs(np.array([curve.psi(g) for g in grid]) / true - 1.0)))

    res = {k: [] for k in ("before", "before arctan", "before R_fe", "after", "arctan", "R_fe", "f exact",
                           "f exact R_fe")}
    wrong = named = 0
    for seed in range(n):
        r = rows * (1.0 + eps * np.random.default_rng(seed).standard_normal(rows.shape))
        a = (r[:, 0], r[:, 1], r[:, 2], R_S, L_S, r[:, 3])
        p = magnetizing_points(*a)
        lo = separate_losses(p.E_m, p.P_loss, r[:, 3])
        p = magnetizing_points(*a, R_fe=lo.R_fe)
        fits, _ = fit_all(p.i_mu, p.psi_m, least_squares)
        res["before"].append(err(choose(fits).curve))
        res["before arctan"].append(err(fits["arctan"].curve))
        res["before R_fe"].append(abs(lo.R_fe / 800.0 - 1.0))
        p, lo = noload_points(*a, rel_sigma=(eps,) * 4)
        fits, _ = fit_all(p.i_mu, p.psi_m, least_squares, p.cov)
        best = choose(fits)
        rv = rivals(fits, best, p.i_mu.min(), p.i_mu.max())
        wrong += best.family != "arctan"
        named += best.family != "arctan" and "arctan" in rv
        res["after"].append(err(best.curve))
        res["arctan"].append(err(fits["arctan"].curve))
        res["R_fe"].append(abs(lo.R_fe / 800.0 - 1.0))
        r = rows.copy()
        r[:, [0, 1, 3]] *= 1.0 + eps * np.random.default_rng(seed).standard_normal((rows.shape[0], 3))
        p, lo = noload_points(r[:, 0], r[:, 1], r[:, 2], R_S, L_S, r[:, 3],
                              rel_sigma=(eps, eps, 1e-4, eps))
        fits, _ = fit_all(p.i_mu, p.psi_m, least_squares, p.cov)
        res["f exact"].append(err(choose(fits).curve))
        res["f exact R_fe"].append(abs(lo.R_fe / 800.0 - 1.0))
    print(f"{n} seeds, {100 * eps:g} % on every column; the largest relative error of psi_m(i_mu) over "
          f"{xs.min():.3g}-{xs.max():.3g} A, and of R_fe:")
    for k, v in res.items():
        print(f"  {k:14s} {_stats(v)}")
    print(f"  after: another family chosen on {wrong} draws, the true one named a rival on {named} of them")
    _bound(rows, xs, grid, true, eps)


def _bound(rows, xs, grid, true, eps):
    p, lo = noload_points(rows[:, 0], rows[:, 1], rows[:, 2], R_S, L_S, rows[:, 3], rel_sigma=(eps,) * 4)
    fits, _ = fit_all(p.i_mu, p.psi_m, least_squares, p.cov)
    for k in ("exponential", "polynomial"):
        lam = fits[k].chi2
        off = max(abs(fits[k].curve.psi(g) / t - 1) for g, t in zip(grid, true))
        beats = 0.5 * math.erfc(math.sqrt(lam) / 2 / math.sqrt(2))
        print(f"  noiseless {k}: chi2 {lam:.2f} (off the truth by {100 * off:.2f} %); it beats arctan with "
              f"probability about Phi(-sqrt(chi2)/2) = {beats:.3f}")

    def model(q, x):
        return q[0] * x + q[1] * q[2] * np.arctan(x / q[2])

    def slope(q, x):
        return q[0] + q[1] / (1.0 + (x / q[2]) ** 2)

    q0 = np.array([TRUE.L_m_inf, TRUE.L_m0 - TRUE.L_m_inf, TRUE.I_par])
    i, c = p.i_mu, p.cov
    sd = np.sqrt(c[:, 1, 1] + slope(q0, i) ** 2 * c[:, 0, 0] - 2.0 * slope(q0, i) * c[:, 0, 1])
    steps = np.diag(1e-7 * q0)
    J = np.column_stack([(model(q0 + h, i) - model(q0 - h, i)) / (2 * h[k]) / sd
                         for k, h in enumerate(steps)])
    G = np.column_stack([(model(q0 + h, grid) - model(q0 - h, grid)) / (2 * h[k])
                         for k, h in enumerate(steps)])
    C = np.linalg.inv(J.T @ J)
    band = np.sqrt(np.einsum("xk,kl,xl->x", G, C, G)) / true
    L = np.linalg.cholesky(C)
    rng = np.random.default_rng(12345)
    m = np.array([np.max(np.abs(model(q0 + L @ rng.standard_normal(3), grid) / true - 1.0))
                  for _ in range(20000)])
    qs = {k: 100 * np.quantile(m, k) for k in (0.5, 0.9, 0.99, 0.999)}
    print(f"  bound: pointwise 1-sigma of psi_m(i_mu) {100 * band.min():.2f}-{100 * band.max():.2f} % "
          f"(ends {100 * band[0]:.2f} %, {100 * band[-1]:.2f} %); the largest error over the range: median "
          f"{qs[0.5]:.2f} %, p90 {qs[0.9]:.2f} %, p99 {qs[0.99]:.2f} %, p99.9 {qs[0.999]:.2f} % "
          f"({qs[0.999] / 100 / band.max():.2f} sigma_max), "
          f"P(>2 %) {np.mean(m > 0.02):.3f}")
    E2 = p.E_m ** 2
    cl = _loss_cov(rows, eps)
    a = 1.5 / 800.0
    var = cl[:, 1, 1] + a * a * cl[:, 0, 0] - 2.0 * a * cl[:, 0, 1]
    A = np.column_stack([E2, np.ones_like(E2)]) / np.sqrt(var)[:, None]
    s = math.sqrt(np.linalg.inv(A.T @ A)[0, 0]) / a
    print(f"  bound: R_fe 1-sigma {100 * s:.2f} %; 5 % is {0.05 / s:.2f} sigma "
          f"(two-sided {math.erfc(0.05 / s / math.sqrt(2)):.1e} per draw)")


def _loss_cov(rows, eps):
    from satmotor.identify.uncertainty import point_covariance

    def q(c):
        m = magnetizing_points(c[0], c[1], c[2], R_S, L_S, c[3], None, 0.05 + 1e-5, 0.0)
        return np.stack([m.E_m ** 2, m.P_loss])
    return point_covariance(q, [rows[:, k] for k in range(4)], (eps,) * 4)


if __name__ == "__main__":
    main()
