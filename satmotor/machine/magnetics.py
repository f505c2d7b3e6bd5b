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

from satmotor.errors import ParameterError, require_integer, require_number
from satmotor.machine import atan as _atan
from satmotor.machine.atan import atan

_REL_TOL = 4.0e-16
_MAX_ITER = 200


class _Curve:
    """Shared algorithms: root solve, inverse, energy.  Subclasses give
    ``_psi_dpsi(I) -> (psi, dpsi/dI)``, ``m``, ``dm_dI``, ``coenergy`` and ``m0``."""

    name = "curve"

    def psi(self, I):
        return self._psi_dpsi(I)[0]

    def L_dyn(self, I):
        return self._psi_dpsi(I)[1]

    def energy(self, I):
        """Stored main-field energy ``int_0^psi I dpsi`` for current magnitude I."""
        return I * self.psi(I) - self.coenergy(I)

    def evaluate(self, I):
        """Return ``(psi, m, dm_dI, L_dyn)`` at the magnitude I [A]."""
        psi, ldyn = self._psi_dpsi(I)
        return psi, self.m(I), self.dm_dI(I), ldyn

    def current(self, psi):
        """Inverse characteristic: the magnitude I [A] with ``psi(I) = psi`` (psi >= 0)."""
        return self.solve(0.0, psi)[0]

    def solve(self, a, c, guess=0.0):
        """Root ``I >= 0`` of ``a I + psi(I) = c`` for ``a >= 0``, ``c >= 0``.

        Safeguarded Newton iteration started from the lower bound ``c / (a + m(0))``, or from
        ``guess`` [A] (a warm start: e.g. the root of a nearby solve) when it is finite and above
        that bound; returns ``(I, psi(I))``.  For the concave curves the iterates from the bound
        increase monotonically to the root (from a guess above the root, the first Newton step lands
        below it); bisection guards the table curve.  Both starts stop at the same relative step
        ``_REL_TOL``, so their roots agree to within that tolerance (not always to the last bit).
        """
        if c <= 0.0:
            return 0.0, 0.0
        lo = 0.0
        x = c / (a + self.m0)
        hi = math.inf
        if x < guess < hi:
            x = guess
        psi, dpsi = self._psi_dpsi(x)
        for _ in range(_MAX_ITER):
            g = a * x + psi - c
            if g > 0.0:
                hi = x
            elif g < 0.0:
                lo = x
            else:
                return x, psi
            x_new = x - g / (a + dpsi)
            if not (lo < x_new < hi):
                x_new = 0.5 * (lo + hi) if hi < math.inf else 2.0 * x
            step = x_new - x
            x = x_new
            psi, dpsi = self._psi_dpsi(x)
            if abs(step) <= _REL_TOL * x:
                return x, psi
        raise ArithmeticError(f"{self.name}: no convergence solving a I + psi(I) = c (a={a}, c={c})")


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


def _check_saturating(L_m0, L_m_inf, I_par):
    require_number("L_m0", L_m0, 0)
    require_number("L_m_inf", L_m_inf, 0)
    require_number("I_par", I_par, 0)
    if L_m_inf >= L_m0:
        raise ParameterError(
            "L_m_inf", L_m_inf, f"must be < L_m0 = {L_m0!r} for a saturating curve"
        )


@dataclass(frozen=True)
class ArctanCurve(_Curve):
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

    def __post_init__(self):
        _check_saturating(self.L_m0, self.L_m_inf, self.I_par)

    @property
    def m0(self):
        return self.L_m0

    def _psi_dpsi(self, I):
        x = I / self.I_par
        d = self.L_m0 - self.L_m_inf
        return (self.L_m_inf * I + d * self.I_par * atan(x), self.L_m_inf + d / (1.0 + x * x))

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

    def m(self, I):
        x = I / self.I_par
        if x < 1e-2:
            x2 = x * x
            g = 1.0 - x2 * (1.0 / 3.0 - x2 * (1.0 / 5.0 - x2 * (1.0 / 7.0 - x2 / 9.0)))
        else:
            g = atan(x) / x
        return self.L_m_inf + (self.L_m0 - self.L_m_inf) * g

    def dm_dI(self, I):
        x = I / self.I_par
        if x < 1e-2:
            x2 = x * x
            dg = -x * (2.0 / 3.0 - x2 * (4.0 / 5.0 - x2 * (6.0 / 7.0 - x2 * 8.0 / 9.0)))
        else:
            dg = (x / (1.0 + x * x) - atan(x)) / (x * x)
        return (self.L_m0 - self.L_m_inf) * dg / self.I_par

    def coenergy(self, I):
        x = I / self.I_par
        d = self.L_m0 - self.L_m_inf
        return 0.5 * self.L_m_inf * I * I + d * self.I_par**2 * (
            x * atan(x) - 0.5 * math.log1p(x * x)
        )


@dataclass(frozen=True)
class ExponentialCurve(_Curve):
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

    def __post_init__(self):
        _check_saturating(self.L_m0, self.L_m_inf, self.I_par)

    @property
    def m0(self):
        return self.L_m0

    def _psi_dpsi(self, I):
        x = I / self.I_par
        d = self.L_m0 - self.L_m_inf
        return (
            self.L_m_inf * I - d * self.I_par * math.expm1(-x),
            self.L_m_inf + d * math.exp(-x),
        )

    def m(self, I):
        x = I / self.I_par
        g = 1.0 - x / 2.0 if x == 0.0 else -math.expm1(-x) / x
        return self.L_m_inf + (self.L_m0 - self.L_m_inf) * g

    def dm_dI(self, I):
        x = I / self.I_par
        if x < 2e-2:
            dg = -0.5 + x * (1 / 3 - x * (1 / 8 - x * (1 / 30 - x * (1 / 144 - x * (1 / 840 - x / 5760)))))
        else:
            dg = (math.exp(-x) * (1.0 + x) - 1.0) / (x * x)
        return (self.L_m0 - self.L_m_inf) * dg / self.I_par

    def coenergy(self, I):
        x = I / self.I_par
        d = self.L_m0 - self.L_m_inf
        return 0.5 * self.L_m_inf * I * I + d * self.I_par**2 * (x + math.expm1(-x))


@dataclass(frozen=True)
class PolynomialCurve(_Curve):
    """Inverse-polynomial characteristic ``I = psi / L_m0 + poly_b psi**poly_n``.

    The classical single-valued approximation of a magnetization curve by a
    polynomial in the flux (a linear term plus one power, typically n = 7 to
    13), written for the current so that psi(I) is strictly increasing for every
    ``poly_b >= 0``.  Then ``m = 1 / (1/L_m0 + poly_b psi**(n-1))``.  The curve maps the
    magnitudes ``psi = |psi_m| >= 0`` and ``I = |i_mu|``, so an even n is as valid as an odd one:
    the curve of Qu et al. (2012), ``L_s(psi) = 0.34 / (1 + (0.84 psi)**7)`` H, is exactly
    ``I = psi/0.34 + (0.84**7/0.34) psi**8`` (n = 8, see :mod:`satmotor.machine.library`).

    Parameters
    ----------
    L_m0 : float
        Unsaturated inductance [H].
    poly_b : float
        Coefficient of the saturating term [A / Wb**poly_n], >= 0.
    poly_n : int
        Exponent, an integer >= 2 (odd or even).
    """

    L_m0: float = 0.2772
    poly_b: float = 2.46
    poly_n: int = 7
    name = "polynomial"

    def __post_init__(self):
        require_number("L_m0", self.L_m0, 0)
        require_number("poly_b", self.poly_b, 0, inclusive=True)
        require_integer("poly_n", self.poly_n, 2)

    @property
    def m0(self):
        return self.L_m0

    def current(self, psi):
        return psi / self.L_m0 + self.poly_b * psi**self.poly_n

    def _flux(self, a, c):
        """Root psi of ``a I(psi) + psi = c`` (convex in psi; Newton from above)."""
        if c <= 0.0:
            return 0.0
        inv_l, b, n = 1.0 / self.L_m0, self.poly_b, self.poly_n
        y = c / (1.0 + a * inv_l)
        older = math.nan
        for _ in range(_MAX_ITER):
            yn1 = y ** (n - 1)
            h = a * (y * inv_l + b * yn1 * y) + y - c
            step = h / (a * (inv_l + n * b * yn1) + 1.0)
            prev = y
            y -= step
            if abs(step) <= _REL_TOL * y:
                return y
            if y == older:  # a two-cycle of the rounding (_two_cycle)
                return min(y, prev)
            older = prev
        raise ArithmeticError(f"polynomial: no convergence (a={a}, c={c})")

    def solve(self, a, c, guess=0.0):
        """Root of ``a I + psi(I) = c`` by its Newton on psi from above (``guess`` unused: a warm start
        in I could start it below the root)."""
        y = self._flux(a, c)
        return self.current(y), y

    def psi(self, I):
        return self._psi_of_current(I)

    def _psi_of_current(self, I):
        """Root psi of ``psi / L_m0 + b psi^n = I`` (convex; Newton from psi = L_m0 I above)."""
        if I <= 0.0:
            return 0.0
        inv_l, b, n = 1.0 / self.L_m0, self.poly_b, self.poly_n
        y = self.L_m0 * I
        older = math.nan
        for _ in range(_MAX_ITER):
            yn1 = y ** (n - 1)
            step = (y * inv_l + b * yn1 * y - I) / (inv_l + n * b * yn1)
            prev = y
            y -= step
            if abs(step) <= _REL_TOL * y:
                return y
            if y == older:
                # a two-cycle of the rounding: y_k+1 == y_k-1, so the iteration repeats these two
                # iterates and steps forever, neither step within _REL_TOL (both were tested): the root
                # is between them to an ulp or two.  Before, no convergence (I = 1.1068596558489188 A
                # on qu2012_2kw2: steps of +-1.506e-16 at 0.3762 Wb, 4.003e-16 relative)
                return min(y, prev)
            older = prev
        raise ArithmeticError(f"polynomial: no convergence for psi(I={I})")

    def _psi_dpsi(self, I):
        y = self._psi_of_current(I)
        return y, 1.0 / (1.0 / self.L_m0 + self.poly_n * self.poly_b * y ** (self.poly_n - 1))

    def _m_of_psi(self, y):
        return 1.0 / (1.0 / self.L_m0 + self.poly_b * y ** (self.poly_n - 1))

    def m(self, I):
        return self._m_of_psi(self._psi_of_current(I))

    def dm_dI(self, I):
        y = self._psi_of_current(I)
        n, b = self.poly_n, self.poly_b
        m = self._m_of_psi(y)
        ldyn = 1.0 / (1.0 / self.L_m0 + n * b * y ** (n - 1))
        return -m * m * b * (n - 1) * y ** (n - 2) * ldyn

    def evaluate(self, I):
        y = self._psi_of_current(I)
        n, b = self.poly_n, self.poly_b
        m = self._m_of_psi(y)
        ldyn = 1.0 / (1.0 / self.L_m0 + n * b * y ** (n - 1))
        return y, m, -m * m * b * (n - 1) * y ** (n - 2) * ldyn, ldyn

    def energy(self, I):
        y = self._psi_of_current(I)
        n = self.poly_n
        return 0.5 * y * y / self.L_m0 + self.poly_b * y ** (n + 1) / (n + 1)

    def coenergy(self, I):
        return I * self._psi_of_current(I) - self.energy(I)


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
