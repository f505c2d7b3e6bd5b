"""The inverse-polynomial magnetizing curve ``I = psi / L_m0 + poly_b psi**poly_n`` (one of the
curves of :mod:`satmotor.machine.magnetics`, which re-exports it)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from satmotor.errors import require_integer, require_number
from satmotor.machine.curve_base import MAX_ITER as _MAX_ITER
from satmotor.machine.curve_base import REL_TOL as _REL_TOL
from satmotor.machine.curve_base import Curve as _Curve


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
