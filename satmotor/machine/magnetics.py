"""Main-flux magnetizing characteristics psi_m = f(i_mu) and the dynamic inductances.

Every curve maps the magnitude ``I = |i_mu|`` [A] (I >= 0) of the magnetizing
current ``i_mu = i_s + k i_r`` to the main flux linkage ``psi_m`` [Wb] seen by the
stator (seed eqs 4 and 16-17: ``k_s n_s Phi = m(I) i_mu``).  The vector relation is
``lambda(i_mu) = m(I) i_mu`` with the static inductance ``m = psi_m / I`` [H].

Each curve gives, all finite and smooth at ``I = 0``:

* ``psi(I)``      main flux linkage [Wb]
* ``m(I)``        static inductance psi/I [H] (``m(0)`` is the initial slope)
* ``dm_dI(I)``    derivative of m [H/A]
* ``L_dyn(I)``    incremental inductance dpsi/dI = m + I dm/dI [H]
* ``current(psi)``  the inverse I(psi) [A]
* ``coenergy(I)`` integral of psi dI from 0 to I [J per unit of the space-vector scaling]
* ``energy(I)``   integral of I dpsi, i.e. I psi - coenergy [J, same scaling]
* ``solve(a, c)`` the root I >= 0 of ``a I + psi(I) = c`` (a >= 0), with psi(I)

The dynamic inductance matrix ``M = d lambda / d i_mu`` (seed eqs 20-22, eq 21
corrected per ``docs/errata.md``: no ``m`` term in M_dq) is returned by
:func:`dynamic_inductances`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from satmotor.errors import require_number
from satmotor.machine import atan as _atan
from satmotor.machine.atan import atan
from satmotor.machine.curve_base import MAX_ITER as _MAX_ITER
from satmotor.machine.curve_base import REL_TOL as _REL_TOL
from satmotor.machine.curve_base import Curve as _Curve
from satmotor.machine.curve_base import SaturatingCurve as _SaturatingCurve
from satmotor.machine.polynomial_curve import PolynomialCurve  # noqa: F401 (re-exported)


@dataclass(frozen=True)
class LinearCurve(_Curve):
    """Unsaturated characteristic ``psi = L_m0 I``.

    Parameters
    ----------
    L_m0 : float
        Magnetizing inductance [H].
    """

    L_m0: float = 0.1722
    name = "linear"

    def __post_init__(self):
        require_number("L_m0", self.L_m0, 0)

    @property
    def m0(self):
        return self.L_m0

    def _psi_dpsi(self, I):
        return self.L_m0 * I, self.L_m0

    def m(self, I):
        return self.L_m0

    def dm_dI(self, I):
        return 0.0

    def coenergy(self, I):
        return 0.5 * self.L_m0 * I * I

    def solve(self, a, c, guess=0.0):
        """Closed form (``guess`` is not needed)."""
        if c <= 0.0:
            return 0.0, 0.0
        I = c / (a + self.L_m0)
        return I, self.L_m0 * I


@dataclass(frozen=True)
class ArctanCurve(_SaturatingCurve):
    """``psi = L_m_inf I + (L_m0 - L_m_inf) I_par atan(I / I_par)``.

    ``atan`` is :func:`satmotor.machine.atan.atan` (within 0.62 ulp of the exact arc tangent, the
    floats of the C core's ``sm_atan``), not the platform's ``math.atan``.

    The form of the Modelica Standard Library's
    ``Modelica.Electrical.Analog.Basic.SaturatingInductor``.  Slope ``L_m0`` at
    the origin, ``L_m_inf`` far in saturation, knee near ``I_par``.

    Parameters
    ----------
    L_m0 : float
        Unsaturated (initial) inductance [H].
    L_m_inf : float
        Fully saturated incremental inductance [H], 0 < L_m_inf < L_m0.
    I_par : float
        Knee current scale [A].
    """

    L_m0: float = 0.2772
    L_m_inf: float = 0.01
    I_par: float = 3.31
    name = "arctan"

    def _knee(self, x):
        return atan(x)

    def _knee_slope(self, d, x):
        return d / (1.0 + x * x)

    def solve(self, a, c, guess=0.0):
        """:meth:`_Curve.solve` with ``_psi_dpsi`` written out: the same operations in the same order
        (so the same iterates and the same root, bit for bit), without a call per iterate; the main
        branch of :func:`~satmotor.machine.atan.atan` (1/16 <= u <= 4, where the iterates of the
        curve's working range are) is written out too (``tests/test_atan.py`` checks that this equals
        :meth:`_Curve.solve` bit for bit)."""
        if c <= 0.0:
            return 0.0, 0.0
        inf = math.inf
        L_inf, I_par = self.L_m_inf, self.I_par
        d = self.L_m0 - L_inf
        dI = d * I_par
        table, c1, c2, c3, rnd = _atan.TABLE, _atan.C1, _atan.C2, _atan.C3, _atan.ROUND
        lo = 0.0
        x = c / (a + self.m0)
        hi = inf
        if x < guess < hi:
            x = guess
        it, step = 0, 0.0
        while True:
            u = x / I_par
            if 0.0625 <= u <= 4.0:  # atan(u), its main branch
                y = u * 64.0
                n = (y + rnd) - rnd
                at_hi, at_lo = table[n]
                t = (y - n) / (64.0 + u * n)
                z = t * t
                at = at_hi + ((t + at_lo) + t * z * ((c1 + z * c2) + (z * z) * c3))
            else:
                at = atan(u)
            psi = L_inf * x + dI * at
            if it:
                if abs(step) <= _REL_TOL * x:
                    return x, psi
                if it == _MAX_ITER:
                    break
            it += 1
            g = a * x + psi - c
            if g > 0.0:
                hi = x
            elif g < 0.0:
                lo = x
            else:
                return x, psi
            x_new = x - g / (a + (L_inf + d / (1.0 + u * u)))
            if not (lo < x_new < hi):
                x_new = 0.5 * (lo + hi) if hi < inf else 2.0 * x
            step = x_new - x
            x = x_new
        raise ArithmeticError(f"{self.name}: no convergence solving a I + psi(I) = c (a={a}, c={c})")

    def evaluate(self, I):
        """:meth:`_Curve.evaluate` with one ``atan`` for psi, m and dm_dI (the same floats as the
        three one by one)."""
        x = I / self.I_par
        d = self.L_m0 - self.L_m_inf
        at = atan(x)
        psi, ldyn = self.L_m_inf * I + d * self.I_par * at, self.L_m_inf + d / (1.0 + x * x)
        if x < 1e-2:
            x2 = x * x
            g = 1.0 - x2 * (1.0 / 3.0 - x2 * (1.0 / 5.0 - x2 * (1.0 / 7.0 - x2 / 9.0)))
            dg = -x * (2.0 / 3.0 - x2 * (4.0 / 5.0 - x2 * (6.0 / 7.0 - x2 * 8.0 / 9.0)))
        else:
            g = at / x
            dg = (x / (1.0 + x * x) - at) / (x * x)
        return psi, self.L_m_inf + d * g, d * dg / self.I_par, ldyn

    def _g(self, x):
        if x < 1e-2:
            x2 = x * x
            return 1.0 - x2 * (1.0 / 3.0 - x2 * (1.0 / 5.0 - x2 * (1.0 / 7.0 - x2 / 9.0)))
        return atan(x) / x

    def _dg(self, x):
        if x < 1e-2:
            x2 = x * x
            return -x * (2.0 / 3.0 - x2 * (4.0 / 5.0 - x2 * (6.0 / 7.0 - x2 * 8.0 / 9.0)))
        return (x / (1.0 + x * x) - atan(x)) / (x * x)

    def _integral(self, x):
        return x * atan(x) - 0.5 * math.log1p(x * x)


@dataclass(frozen=True)
class ExponentialCurve(_SaturatingCurve):
    """``psi = L_m_inf I + (L_m0 - L_m_inf) I_par (1 - exp(-I / I_par))``.

    The saturating-exponential magnetization curve (an exponential knee added to
    a linear asymptote), one of the closed forms fitted to no-load test data in
    the main-flux saturation literature (e.g. the curve fits surveyed by E. Levi,
    IEEE Trans. Energy Conversion 10(3), 1995).  Slope ``L_m0`` at the origin,
    ``L_m_inf`` in saturation.

    Parameters
    ----------
    L_m0 : float
        Unsaturated inductance [H].
    L_m_inf : float
        Saturated incremental inductance [H], 0 < L_m_inf < L_m0.
    I_par : float
        Current scale of the exponential [A].
    """

    L_m0: float = 0.330
    L_m_inf: float = 0.01
    I_par: float = 3.66
    name = "exponential"

    def _knee(self, x):
        return -math.expm1(-x)

    def _knee_slope(self, d, x):
        return d * math.exp(-x)

    def _g(self, x):
        return 1.0 - x / 2.0 if x == 0.0 else -math.expm1(-x) / x

    def _dg(self, x):
        if x < 2e-2:
            return -0.5 + x * (1 / 3 - x * (1 / 8 - x * (1 / 30 - x * (1 / 144 - x * (1 / 840 - x / 5760)))))
        return (math.exp(-x) * (1.0 + x) - 1.0) / (x * x)

    def _integral(self, x):
        return x + math.expm1(-x)


def inductance_matrix(m, dm_dI, i_mu_d, i_mu_q, I):
    """``(M_d, M_q, M_dq)`` [H] of ``M = m I2 + (dm/dI / I) i_mu i_mu^T`` from the static m [H], its
    derivative dm/dI [H/A] and ``i_mu = (i_mu_d, i_mu_q)`` of magnitude ``I`` [A]; ``M = m I2`` at
    I = 0.  The one formula of seed eqs 20-22 (eq 21 corrected: ``M_dq = dm/dI i_mu_d i_mu_q / I``
    has no ``m`` term); m need not come from a curve (the controller may measure it)."""
    s = dm_dI / I if I > 0.0 else 0.0
    return m + s * i_mu_d * i_mu_d, m + s * i_mu_q * i_mu_q, s * i_mu_d * i_mu_q


def dynamic_inductances(curve, i_mu_d, i_mu_q):
    """Dynamic inductances of the main field at ``i_mu = (i_mu_d, i_mu_q)`` [A].

    ``M = d(m(I) i_mu)/d i_mu`` (:func:`inductance_matrix` with m and dm/dI of ``curve``).
    Its eigenvalues are ``m`` (across i_mu) and ``L_dyn`` (along i_mu).

    Returns
    -------
    tuple
        ``(M_d, M_q, M_dq, m, dm_dI, L_dyn)`` in [H], [H], [H], [H], [H/A], [H].
    """
    I = math.hypot(i_mu_d, i_mu_q)
    _, m, dm, ldyn = curve.evaluate(I)
    return inductance_matrix(m, dm, i_mu_d, i_mu_q, I) + (m, dm, ldyn)
