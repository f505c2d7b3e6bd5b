"""Least-squares fit of the magnetizing-curve families to points (i_mu [A], psi_m [Wb]).

Every family :func:`satmotor.machine.params.make_curve` builds from parameters is fitted to the points by
``scipy.optimize.least_squares`` on the flux residual ``psi_fit(i_mu) - psi_m`` (absolute, in Wb,
all points weighted alike).  ``satmotor`` depends on numpy only (``tests/test_packaging.py``
holds it to that), so the caller hands the solver in: ``fit_all(i, psi, least_squares)`` with
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

The family with the smallest RMS residual wins, with a tie rule: a family with fewer parameters
is preferred when its RMS residual is within 1 % of the best (``linear`` has 1 parameter,
``arctan`` and ``exponential`` 3, ``polynomial`` 3: L_m0, poly_b and the exponent chosen from the
data).  Every fitted curve is built through ``make_curve``, so it satisfies the classes' checks.

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


class Fit(NamedTuple):
    family: str
    params: dict  # make_curve keyword arguments (without the name)
    rms: float  # [Wb] RMS of psi_fit(i_mu) - psi_m over the points
    max_abs: float  # [Wb] largest |psi_fit - psi_m|
    curve: object  # the curve object

    @property
    def n_params(self):
        return N_PARAMS[self.family]


def _psi(curve, i):
    return np.array([curve.psi(float(v)) for v in i])


def _finish(family, params, i, psi):
    curve = make_curve(family, **params)
    r = _psi(curve, i) - psi
    return Fit(family, params, float(math.sqrt(np.mean(r * r))), float(np.max(np.abs(r))), curve)


def _start(i, psi):
    L0 = float(np.max(psi / i))
    if i.size >= 2:
        s_end = (psi[-1] - psi[-2]) / (i[-1] - i[-2]) if i[-1] > i[-2] else 0.0
    else:
        s_end = 0.0
    Linf = float(min(max(0.5 * s_end, 0.01 * L0), 0.5 * L0))
    return L0, Linf


def _fit_saturating(family, i, psi, least_squares):
    L0, Linf = _start(i, psi)
    imax = float(i.max())

    if family == "arctan":
        def model(p, x):
            return p[0] * x + p[1] * p[2] * np.arctan(x / p[2])
    else:
        def model(p, x):
            return p[0] * x - p[1] * p[2] * np.expm1(-x / p[2])

    best = None
    scale = np.array([L0, L0, imax])
    lower = 1e-9 * scale
    for frac in (0.15, 0.3, 0.6, 1.2):
        p0 = np.array([Linf, L0 - Linf, frac * imax])
        res = least_squares(lambda p: model(p, i) - psi, p0, bounds=(lower, np.inf), x_scale=scale,
                            xtol=1e-14, ftol=1e-14, gtol=1e-14, max_nfev=2000)
        if best is None or res.cost < best.cost:
            best = res
    Li, d, Ip = (float(v) for v in best.x)
    return _finish(family, {"L_m0": Li + d, "L_m_inf": Li, "I_par": Ip}, i, psi)


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


def _fit_polynomial(i, psi, least_squares):
    L0, _ = _start(i, psi)
    best = None
    for n in POLY_EXPONENTS:
        # start: the linear term through the lowest point, poly_b from the highest
        b0 = max((i[-1] - psi[-1] / L0) / psi[-1] ** n, 1e-6)
        scale = np.array([L0, b0])
        res = least_squares(lambda p, n=n: _poly_psi(p[0], p[1], n, i) - psi, np.array([L0, b0]),
                            bounds=([1e-9 * L0, 0.0], np.inf), x_scale=scale,
                            xtol=1e-14, ftol=1e-14, gtol=1e-14, max_nfev=2000)
        fit = _finish("polynomial", {"L_m0": float(res.x[0]), "poly_b": float(res.x[1]), "poly_n": n},
                      i, psi)
        if best is None or fit.rms < best.rms:
            best = fit
    return best


def _fit_linear(i, psi):
    return _finish("linear", {"L_m0": float(np.dot(i, psi) / np.dot(i, i))}, i, psi)


def fit_all(i_mu, psi_m, least_squares):
    """Fit every family; returns ``(fits, failures)``: ``{family: Fit}`` and, for a family that
    could not be fitted, ``{family: reason}``.  ``least_squares``: ``scipy.optimize.least_squares``
    (or a function with its signature and result attributes ``x`` and ``cost``)."""
    i = np.asarray(i_mu, dtype=float)
    psi = np.asarray(psi_m, dtype=float)
    order = np.argsort(i, kind="stable")
    i, psi = i[order], psi[order]
    if i.size < 3:
        raise ParameterError("points", i.size, "at least 3 points are needed (3 parameters per family)")
    fits, failures = {}, {}
    for family, fn in (("arctan", lambda: _fit_saturating("arctan", i, psi, least_squares)),
                       ("exponential", lambda: _fit_saturating("exponential", i, psi, least_squares)),
                       ("polynomial", lambda: _fit_polynomial(i, psi, least_squares)),
                       ("linear", lambda: _fit_linear(i, psi))):
        try:
            fits[family] = fn()
        except (ParameterError, ArithmeticError, ValueError, FloatingPointError) as exc:
            failures[family] = str(exc)
    return fits, failures


def choose(fits):
    """The best fit: smallest RMS; a family with fewer parameters wins within ``TIE`` (1 %)."""
    best = min(fits.values(), key=lambda f: f.rms)
    near = [f for f in fits.values() if f.rms <= best.rms * (1.0 + TIE)]
    return min(near, key=lambda f: (f.n_params, f.rms))


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
