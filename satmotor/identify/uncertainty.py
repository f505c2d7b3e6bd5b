"""Measurement uncertainty of a no-load test carried into its magnetizing points, numpy only.

Every column of a no-load row (``V_ll_rms``, ``I_rms``, ``f``, ``P_in``) has a relative standard
uncertainty ``rel_sigma`` [1] (default 1 % on each: no column is assumed better than another; the
fits depend only on the ratios, the reported uncertainty on the level).  The row's point is a smooth
function of its four readings (:func:`satmotor.identify.noload.magnetizing_points`), so to first order
the covariance of the point's quantities ``q = (i_mu, psi_m, E_m^2, P_loss)`` is ``J S J^T`` with
``J = dq / d(reading)`` and ``S = diag((rel_sigma reading)^2)``; rows are independent (one reading
each), so ``J`` is one derivative per column, taken by central differences of
``magnetizing_points`` itself (a relative step of 1e-6 on that column of every row at once).

How 1 % on each reading reaches the point (measured on the 10-level sweep of
``tests/test_fit_curve_losses.py``: default motor, R_fe = 800 Ohm, 70 W friction, 20-120 % of rated
voltage):

* ``psi_m = |E_m| / omega``: 1 % on ``V`` and 1 % on ``f`` give about 1 % each (the stator drops are
  a few % of ``V``): 1.45-1.49 %;
* ``i_mu`` (the current in quadrature with ``E_m``): 1 % on ``I`` gives 1 %; ``P_in`` and ``V`` turn
  the current's angle, which moves ``i_mu`` in proportion to the power factor: 1.01 % at 120 %
  voltage (power factor 0.09), 1.33 % at 30 % (0.46), 3.0 % at 20 % (0.74, where the friction's
  rotor current is as large as i_mu);
* what counts for the curve ``psi_m(i_mu)`` is the scatter across it: an ``i_mu`` error moves the
  point along the curve's slope, ``d psi / psi = (L_dyn i_mu / psi_m) d i_mu / i_mu``, with
  ``L_dyn i / psi`` 0.97 at 20 % voltage and 0.31 at 120 %; the effective scatter
  ``sqrt(var psi + L_dyn^2 var i - 2 L_dyn cov)`` is 2.8 % at 20 % voltage, 1.78 % at 30 % and
  1.53 % at 120 %.  Conversely, in ``i_mu(psi)`` a 1 % flux error is a ``psi / (L_dyn i)``-fold
  (about 3-fold at 120 %) current error.
"""

from __future__ import annotations

import numpy as np

from satmotor.errors import ParameterError, require_number
from satmotor.identify.noload import (
    COPPER_TOL,
    magnetizing_points,
    plant_core_loss_resistance,
    separate_losses,
)

COLUMNS = ("V_ll_rms", "I_rms", "f", "P_in")
REL_SIGMA = (0.01, 0.01, 0.01, 0.01)  # [1] default relative standard uncertainty of each column
STEP = 1e-6  # [1] relative step of the central differences


def check_rel_sigma(rel_sigma):
    """The relative uncertainties (one per column of ``COLUMNS``) as a tuple of floats, each finite and
    > 0 (a ParameterError naming the column otherwise)."""
    vals = tuple(rel_sigma)
    if len(vals) != len(COLUMNS):
        raise ParameterError("rel_sigma", vals, f"needs one value per column ({', '.join(COLUMNS)})")
    return tuple(require_number(f"rel_sigma[{name}]", v, 0.0) for name, v in zip(COLUMNS, vals))


def point_covariance(points_of, columns, rel_sigma=REL_SIGMA):
    """Covariance [(n, k, k)] of the point quantities of each row.

    ``points_of(columns)`` maps the reading columns (a list of ``n``-arrays, ``V_ll_rms, I_rms, f`` and
    optionally ``P_in``) to a ``(k, n)`` array of the point quantities (e.g. ``i_mu, psi_m, E_m^2,
    P_loss``), the corrections held fixed; ``rel_sigma`` the relative standard uncertainty of each
    column.  First order: ``sum_j J_j J_j^T (rel_sigma_j)^2`` with ``J_j`` the derivative with respect
    to the relative change of column j (central differences)."""
    cols = [np.asarray(c, dtype=float) for c in columns]
    sig = check_rel_sigma(rel_sigma)
    q0 = np.asarray(points_of(cols), dtype=float)
    cov = np.zeros((q0.shape[1], q0.shape[0], q0.shape[0]))
    for j, s in enumerate(sig[: len(cols)]):
        up = [c * (1.0 + STEP) if m == j else c for m, c in enumerate(cols)]
        dn = [c * (1.0 - STEP) if m == j else c for m, c in enumerate(cols)]
        d = (np.asarray(points_of(up)) - np.asarray(points_of(dn))) / (2.0 * STEP) * s  # (k, n)
        cov += np.einsum("an,bn->nab", d, d)
    return cov


def noload_points(V_ll_rms, I_rms, f, R_s, l_s, P_in=None, l_r=None, copper_tol=COPPER_TOL,
                  rel_sigma=REL_SIGMA):
    """``(points, losses)`` of a no-load test with the readings' uncertainty carried along.

    With ``P_in``: the points at ``R_fe = 0``, the loss separated with the covariance of
    ``(E_m^2, P_loss)`` (:func:`~satmotor.identify.noload.separate_losses`; neither depends on
    ``R_fe``), the points again with the separated ``R_fe`` (the core-loss current out of the
    rotor-leakage correction), and the plant's ``R_fe``
    (:func:`~satmotor.identify.noload.plant_core_loss_resistance`).  ``points.cov`` is the covariance
    of each point's ``(i_mu, psi_m)`` at that ``R_fe``; ``losses`` is None without ``P_in``.
    ParameterError as :func:`~satmotor.identify.noload.magnetizing_points` raises it."""
    sig = check_rel_sigma(rel_sigma)
    base = [V_ll_rms, I_rms, f] + ([] if P_in is None else [P_in])

    def points(cols, R_fe=0.0, tol=copper_tol):
        P = cols[3] if len(cols) > 3 else None
        return magnetizing_points(cols[0], cols[1], cols[2], R_s, l_s, P, l_r, tol, R_fe)

    def stepped(cols, R_fe=0.0):  # a row at the tolerance's edge must not be refused for the 1e-6 step
        return points(cols, R_fe, copper_tol + 1e-5)

    pts = points(base)
    losses = None
    if P_in is not None:
        cl = point_covariance(lambda c: np.stack([stepped(c).E_m ** 2, stepped(c).P_loss]), base, sig)
        losses = separate_losses(pts.E_m, pts.P_loss, P_in, cl)
        pts = points(base, losses.R_fe)
        losses = losses._replace(R_fe_plant=plant_core_loss_resistance(losses.R_fe, pts.E_m, pts.E_s))
    R_fe = 0.0 if losses is None else losses.R_fe
    cov = point_covariance(lambda c: np.stack([stepped(c, R_fe).i_mu, stepped(c, R_fe).psi_m]), base, sig)
    return pts._replace(cov=cov), losses
