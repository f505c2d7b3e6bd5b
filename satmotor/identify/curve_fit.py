"""Least-squares fit of the magnetizing-curve families to points (i_mu [A], psi_m [Wb]).

Every family :func:`satmotor.machine.params.make_curve` builds from parameters is fitted to the points by
``scipy.optimize.least_squares`` on the flux residual ``psi_fit(i_mu) - psi_m``: without a covariance
absolute, in Wb, all points weighted alike; with the points' covariance ``cov`` (``(n, 2, 2)`` of
``(i_mu, psi_m)``, :mod:`satmotor.identify.uncertainty`) errors in both variables: each residual is
divided by its effective standard deviation ``sqrt(var(psi) + L^2 var(i) - 2 L cov(i, psi))`` with
``L = dpsi_fit/di`` at the point (the orthogonal-distance fit in the metric of the point's own
covariance, to first order: the maximum likelihood of the curve for Gaussian errors), so the
chi-square ``chi2`` (sum of squared weighted residuals) is in units of the stated uncertainty.
``satmotor`` depends on numpy only (``tests/test_packaging.py`` holds it to that), so the caller
hands the solver in: ``fit_all(i, psi, least_squares)`` with
``from scipy.optimize import least_squares`` (``orchestration.tools.fit_curve`` does).

* ``arctan``, ``exponential``: ``(L_m0, L_m_inf, I_par)``, fitted as ``(L_m_inf, L_m0 - L_m_inf,
  I_par)`` with each bounded below by 1e-9 of its scale, so ``0 < L_m_inf < L_m0`` and
  ``I_par > 0`` hold (the validity constraints of the curve classes).  Starting values from the
  data: ``L_m0`` the largest secant ``psi/i`` (the lowest-current point), ``L_m_inf`` a fraction
  of the secant slope between the last two points, ``I_par`` from a few fractions of the largest
  current (the best start is kept).
* ``polynomial``: ``i = psi / L_m0 + poly_b psi**poly_n`` with ``(L_m0 > 0, poly_b >= 0)`` for every
  odd ``poly_n`` in 3, 5, ..., 15; the n with the smallest residual is kept.
* ``linear``: ``psi = L_m0 i``, the closed-form least-squares slope.

The family with the smallest RMS residual (with ``cov``: the weighted one, ``sqrt(chi2 / n)``) wins,
with a tie rule: a family with fewer parameters is preferred when its RMS residual is within 1 % of
the best (``linear`` has 1 parameter,
``arctan`` and ``exponential`` 3, ``polynomial`` 3: L_m0, poly_b and the exponent chosen from the
data).  Every fitted curve is built through ``make_curve``, so it satisfies the classes' checks.
With ``cov`` each fit also carries ``sigma_rel``, the largest 1-sigma relative uncertainty of
``psi_fit`` over the points' current range from the parameters' covariance ``(J^T J)^-1`` (the
Cramer-Rao bound of the fit, for the stated uncertainty), and :func:`rivals` names the families the
data cannot tell from the chosen one (chi-square within ``RIVAL_CHI2``), and ``cov``, the covariance of
its continuous parameters ``names`` (``L_m0, L_m_inf, I_par``; ``L_m0, poly_b``; ``L_m0``: the same
``(J^T J)^-1`` carried from the solver's parameters), ``sigma`` their 1-sigma values.

:func:`monotone_table` turns noisy points into a table the ``table`` curve accepts (isotonic
regression by pool-adjacent-violators, see there).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from satmotor.errors import ParameterError
from satmotor.machine.params import make_curve

POLY_EXPONENTS = tuple(range(3, 16, 2))
N_PARAMS = {"linear": 1, "arctan": 3, "exponential": 3, "polynomial": 3}
TIE = 0.01  # relative RMS margin within which the family with fewer parameters wins
RIVAL_CHI2 = 4.0  # a family whose chi-square is within this of the chosen one's fits the data as well
# (likelihood ratio e^2: less than 2-sigma evidence between them)


class Fit(NamedTuple):
    family: str
    params: dict  # make_curve keyword arguments (without the name)
    rms: float  # [Wb] RMS of psi_fit(i_mu) - psi_m over the points
    max_abs: float  # [Wb] largest |psi_fit - psi_m|
    curve: object  # the curve object
    chi2: float | None = None  # [1] sum of squared weighted residuals (None: fitted unweighted)
    sigma_rel: float | None = None  # [1] largest 1-sigma relative uncertainty of psi_fit over the range
    band: object = None  # band(x): the 1-sigma relative uncertainty [1] of psi_fit at currents x [A]
    names: tuple = ()  # the continuous parameters of ``params`` that ``cov`` covers, in its order
    cov: object = None  # their covariance matrix [SI units squared] (None: fitted unweighted)

    @property
    def sigma(self):
        """``{name: 1-sigma}`` of the continuous parameters (empty when fitted unweighted)."""
        if self.cov is None:
            return {}
        return {n: float(math.sqrt(max(self.cov[k][k], 0.0))) for k, n in enumerate(self.names)}

    @property
    def n_params(self):
        return N_PARAMS[self.family]

    def score(self):
        """What the choice compares: the RMS residual, or ``sqrt(chi2)`` if fitted with ``cov`` (the
        weighted RMS times sqrt(n), the same for every family)."""
        return self.rms if self.chi2 is None else math.sqrt(self.chi2)


def _psi(curve, i):
    return np.array([curve.psi(float(v)) for v in i])


#: the continuous parameters of each family, and the matrix T that makes them of the solver's (``T p``)
_NAMES = {"arctan": ("L_m0", "L_m_inf", "I_par"), "exponential": ("L_m0", "L_m_inf", "I_par"),
          "polynomial": ("L_m0", "poly_b"), "linear": ("L_m0",)}
_SOLVER_TO_PARAMS = {"arctan": ((1.0, 1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),  # (L_m_inf, d, I_par)
                     "exponential": ((1.0, 1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
                     "polynomial": ((1.0, 0.0), (0.0, 1.0)), "linear": ((1.0,),)}


def _finish(family, params, i, psi, res=None, model=None):
    """The Fit; with the solver result ``res`` of a weighted fit and ``model(p, x)`` the fitted
    psi(x) in the solver's parameters, also ``chi2``, ``band``, ``sigma_rel`` and the parameters'
    covariance ``cov`` (the solver's ``(J^T J)^-1`` carried to the curve's parameters)."""
    curve = make_curve(family, **params)
    r = _psi(curve, i) - psi
    chi2 = sig = band = cov = None
    if res is not None:
        chi2 = float(2.0 * res.cost)
        band = _band(model, np.asarray(res.x, dtype=float), res.jac)
        sig = float(np.max(band(np.linspace(float(i.min()), float(i.max()), 200))))
        T = np.array(_SOLVER_TO_PARAMS[family])
        cov = T @ _covariance(res.jac) @ T.T
        cov = 0.5 * (cov + cov.T)  # symmetric to the last bit (a prior's matrix is checked so)
    return Fit(family, params, float(math.sqrt(np.mean(r * r))), float(np.max(np.abs(r))), curve, chi2, sig,
               band, _NAMES[family], cov)


def _covariance(jac):
    """The parameters' covariance ``(J^T J)^-1`` of a weighted fit (J the weighted residuals' Jacobian):
    the Cramer-Rao bound for the stated uncertainty of the points, not scaled by the chi-square."""
    J = np.asarray(jac, dtype=float)
    return np.linalg.pinv(J.T @ J)


def _band(model, p, jac):
    """``band(x)``: the 1-sigma relative uncertainty of ``model(p, x)``, the parameters' covariance
    ``(J^T J)^-1`` (J the weighted residuals' Jacobian) carried to psi by central differences."""
    C = _covariance(jac)
    floor = 1e-3 * float(np.max(np.abs(p)))  # a parameter at its bound (near 0) still gets a usable step

    def band(x):
        x = np.asarray(x, dtype=float)
        G = np.empty((x.size, p.size))
        for k in range(p.size):
            h = 1e-6 * max(abs(p[k]), floor)
            up, dn = p.copy(), p.copy()
            up[k] += h
            dn[k] -= h
            G[:, k] = (model(up, x) - model(dn, x)) / (2.0 * h)
        var = np.einsum("xk,kl,xl->x", G, C, G)
        return np.sqrt(np.maximum(var, 0.0)) / model(p, x)
    return band


def _residual(model, slope, i, psi, cov):
    """Residual function of the solver: plain ``model - psi``, or weighted by the effective standard
    deviation (``slope(p, x)`` = dpsi/di of the model) when ``cov`` is given."""
    if cov is None:
        return lambda p: model(p, i) - psi

    def fun(p):
        d = slope(p, i)
        var = cov[:, 1, 1] + d * d * cov[:, 0, 0] - 2.0 * d * cov[:, 0, 1]
        return (model(p, i) - psi) / np.sqrt(np.maximum(var, 1e-300))
    return fun


def _start(i, psi):
    L0 = float(np.max(psi / i))
    if i.size >= 2:
        s_end = (psi[-1] - psi[-2]) / (i[-1] - i[-2]) if i[-1] > i[-2] else 0.0
    else:
        s_end = 0.0
    Linf = float(min(max(0.5 * s_end, 0.01 * L0), 0.5 * L0))
    return L0, Linf


def _fit_saturating(family, i, psi, least_squares, cov=None):
    L0, Linf = _start(i, psi)
    imax = float(i.max())

    if family == "arctan":
        def model(p, x):
            return p[0] * x + p[1] * p[2] * np.arctan(x / p[2])

        def slope(p, x):
            return p[0] + p[1] / (1.0 + (x / p[2]) ** 2)
    else:
        def model(p, x):
            return p[0] * x - p[1] * p[2] * np.expm1(-x / p[2])

        def slope(p, x):
            return p[0] + p[1] * np.exp(-x / p[2])

    best = None
    scale = np.array([L0, L0, imax])
    lower = 1e-9 * scale
    fun = _residual(model, slope, i, psi, cov)
    for frac in (0.15, 0.3, 0.6, 1.2):
        p0 = np.array([Linf, L0 - Linf, frac * imax])
        res = least_squares(fun, p0, bounds=(lower, np.inf), x_scale=scale,
                            xtol=1e-14, ftol=1e-14, gtol=1e-14, max_nfev=2000)
        if best is None or res.cost < best.cost:
            best = res
    Li, d, Ip = (float(v) for v in best.x)
    return _finish(family, {"L_m0": Li + d, "L_m_inf": Li, "I_par": Ip}, i, psi,
                   None if cov is None else best, model)


def _poly_psi(L0, b, n, I):
    """Vectorized root psi of psi / L0 + b psi^n = I (Newton from psi = L0 I, above the root)."""
    y = L0 * I
    for _ in range(200):
        yn1 = y ** (n - 1)
        step = (y / L0 + b * yn1 * y - I) / (1.0 / L0 + n * b * yn1)
        y = y - step
        if np.all(np.abs(step) <= 1e-15 * np.maximum(y, 1e-300)):
            break
    return y


def _fit_polynomial(i, psi, least_squares, cov=None):
    L0, _ = _start(i, psi)
    best = None
    for n in POLY_EXPONENTS:
        # start: the linear term through the lowest point, poly_b from the highest
        b0 = max((i[-1] - psi[-1] / L0) / psi[-1] ** n, 1e-6)
        scale = np.array([L0, b0])

        def model(p, x, n=n):
            return _poly_psi(p[0], p[1], n, x)

        def slope(p, x, n=n):
            return 1.0 / (1.0 / p[0] + n * p[1] * _poly_psi(p[0], p[1], n, x) ** (n - 1))

        res = least_squares(_residual(model, slope, i, psi, cov), np.array([L0, b0]),
                            bounds=([1e-9 * L0, 0.0], np.inf), x_scale=scale,
                            xtol=1e-14, ftol=1e-14, gtol=1e-14, max_nfev=2000)
        fit = _finish("polynomial", {"L_m0": float(res.x[0]), "poly_b": float(res.x[1]), "poly_n": n},
                      i, psi, None if cov is None else res, model)
        if best is None or fit.score() < best.score():
            best = fit
    return best


def _fit_linear(i, psi, least_squares, cov=None):
    L = float(np.dot(i, psi) / np.dot(i, i))
    if cov is None:
        return _finish("linear", {"L_m0": L}, i, psi)

    def model(p, x):
        return p[0] * x

    res = least_squares(_residual(model, lambda p, x: p[0] + 0.0 * x, i, psi, cov), np.array([L]),
                        bounds=([1e-9 * L], np.inf), x_scale=np.array([L]),
                        xtol=1e-14, ftol=1e-14, gtol=1e-14)
    return _finish("linear", {"L_m0": float(res.x[0])}, i, psi, res, model)


def fit_all(i_mu, psi_m, least_squares, cov=None):
    """Fit every family; returns ``(fits, failures)``: ``{family: Fit}`` and, for a family that
    could not be fitted, ``{family: reason}``.  ``least_squares``: ``scipy.optimize.least_squares``
    (or a function with its signature and result attributes ``x``, ``cost`` and ``jac``).  ``cov``:
    the ``(n, 2, 2)`` covariance of each point's ``(i_mu, psi_m)`` [A^2, A Wb, Wb^2] (None: unweighted)."""
    i = np.asarray(i_mu, dtype=float)
    psi = np.asarray(psi_m, dtype=float)
    order = np.argsort(i, kind="stable")
    i, psi = i[order], psi[order]
    if cov is not None:
        cov = np.asarray(cov, dtype=float)
        if cov.shape != (i.size, 2, 2):
            raise ParameterError("cov", cov.shape, f"must be ({i.size}, 2, 2): one 2x2 covariance per point")
        cov = cov[order]
    if i.size < 3:
        raise ParameterError("points", i.size, "at least 3 points are needed (3 parameters per family)")
    fits, failures = {}, {}
    for family, fn in (("arctan", lambda: _fit_saturating("arctan", i, psi, least_squares, cov)),
                       ("exponential", lambda: _fit_saturating("exponential", i, psi, least_squares, cov)),
                       ("polynomial", lambda: _fit_polynomial(i, psi, least_squares, cov)),
                       ("linear", lambda: _fit_linear(i, psi, least_squares, cov))):
        try:
            fits[family] = fn()
        except (ParameterError, ArithmeticError, ValueError, FloatingPointError) as exc:
            failures[family] = str(exc)
    return fits, failures


def choose(fits):
    """The best fit: smallest RMS (the weighted one, ``Fit.score``, for fits with ``chi2``); a family
    with fewer parameters wins within ``TIE`` (1 %)."""
    best = min(fits.values(), key=lambda f: f.score())
    near = [f for f in fits.values() if f.score() <= best.score() * (1.0 + TIE)]
    return min(near, key=lambda f: (f.n_params, f.score()))


def rivals(fits, best, i_lo, i_hi):
    """``{family: largest relative difference of its psi from the chosen fit's over [i_lo, i_hi]}``
    for the other families whose chi-square is within ``RIVAL_CHI2`` of the chosen one's: the data
    (at the stated uncertainty) do not tell them apart, so that difference is part of the curve's
    uncertainty.  Empty for unweighted fits."""
    if best.chi2 is None:
        return {}
    grid = np.linspace(i_lo, i_hi, 200)
    ref = _psi(best.curve, grid)
    return {name: float(np.max(np.abs(_psi(f.curve, grid) / ref - 1.0)))
            for name, f in fits.items()
            if f is not best and f.chi2 is not None and f.chi2 - best.chi2 <= RIVAL_CHI2}


def monotone_table(i_mu, psi_m):
    """Points made strictly increasing for :class:`satmotor.machine.table_curve.TableCurve`.

    Sorted by i_mu; then the isotonic regression of psi_m on i_mu (pool-adjacent-violators: a run
    of points whose psi_m decreases is replaced by one point at the mean i_mu and mean psi_m of the
    run), which is the least-squares non-decreasing fit of the points.  Pooling continues while
    neighbours are not strictly increasing in both coordinates, and, at the end, while the
    table's monotone interpolation would end flat (its end slope must be > 0: the last segment's
    slope must exceed about a third of the one before; noise in saturation breaks that), the last
    two points are pooled.  Returns ``(i, psi, n_pooled)`` with ``n_pooled`` the number of points
    merged away.
    """
    from satmotor.machine.table_curve import TableCurve

    i = np.asarray(i_mu, dtype=float)
    psi = np.asarray(psi_m, dtype=float)
    order = np.argsort(i, kind="stable")
    blocks = []  # [sum_i, sum_psi, count]
    for a, b in zip(i[order], psi[order]):
        blocks.append([a, b, 1])
        while len(blocks) > 1:
            x1, y1, n1 = blocks[-2]
            x2, y2, n2 = blocks[-1]
            if y2 / n2 > y1 / n1 and x2 / n2 > x1 / n1:
                break
            blocks[-2:] = [[x1 + x2, y1 + y2, n1 + n2]]
    while True:
        x = np.array([s / n for s, _, n in blocks])
        y = np.array([s / n for _, s, n in blocks])
        if len(blocks) < 2:
            raise ParameterError("points", len(blocks), "too few distinct points remain for a table "
                                 "after making psi_m increase with i_mu")
        try:
            TableCurve(tuple(x.tolist()), tuple(y.tolist()))
            return x, y, int(i.size - len(blocks))
        except ParameterError:
            x1, y1, n1 = blocks[-2]
            x2, y2, n2 = blocks[-1]
            blocks[-2:] = [[x1 + x2, y1 + y2, n1 + n2]]
