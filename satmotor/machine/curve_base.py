"""The shared algorithms of the magnetizing curves (:mod:`satmotor.machine.magnetics`): the root
solve, the inverse and the energies, on a subclass's ``_psi_dpsi(I) -> (psi, dpsi/dI)``; and what the
two saturating closed forms (arctan, exponential) share, on their knee shape."""

from __future__ import annotations

import math
from dataclasses import dataclass

from satmotor.errors import ParameterError, require_number

REL_TOL = 4.0e-16
MAX_ITER = 200


class Curve:
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
        ``REL_TOL``, so their roots agree to within that tolerance (not always to the last bit).
        """
        if c <= 0.0:
            return 0.0, 0.0
        lo = 0.0
        x = c / (a + self.m0)
        hi = math.inf
        if x < guess < hi:
            x = guess
        psi, dpsi = self._psi_dpsi(x)
        for _ in range(MAX_ITER):
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
            if abs(step) <= REL_TOL * x:
                return x, psi
        raise ArithmeticError(f"{self.name}: no convergence solving a I + psi(I) = c (a={a}, c={c})")


@dataclass(frozen=True)
class SaturatingCurve(Curve):
    """``psi = L_m_inf I + (L_m0 - L_m_inf) I_par f(I / I_par)`` with a knee shape ``f`` (``f(0) = 0``,
    ``f'(0) = 1``, ``f'`` falling to 0): slope ``L_m0`` [H] at the origin, ``L_m_inf`` [H] far in
    saturation, the knee near ``I_par`` [A].  The parameters' checks, ``m0``, ``psi``, ``L_dyn``, ``m``,
    ``dm_dI`` and ``coenergy`` are written once here; a subclass gives the shape at ``x = I / I_par``:

    * ``_knee(x)``: ``f(x)``;
    * ``_knee_slope(d, x)``: ``d f'(x)`` [H] for ``d = L_m0 - L_m_inf`` (the subclass's own expression,
      e.g. ``d / (1 + x^2)``: a product with a reciprocal would round differently);
    * ``_g(x)``: ``f(x) / x`` (``m = L_m_inf + d g``), ``_dg(x)``: its derivative, both finite at 0;
    * ``_integral(x)``: ``int_0^x f`` (``coenergy = L_m_inf I^2 / 2 + d I_par^2 int_0^x f``).
    """

    L_m0: float
    L_m_inf: float
    I_par: float

    def __post_init__(self):
        require_number("L_m0", self.L_m0, 0)
        require_number("L_m_inf", self.L_m_inf, 0)
        require_number("I_par", self.I_par, 0)
        if self.L_m_inf >= self.L_m0:
            raise ParameterError("L_m_inf", self.L_m_inf,
                                 f"must be < L_m0 = {self.L_m0!r} for a saturating curve")

    @property
    def m0(self):
        return self.L_m0

    def _psi_dpsi(self, I):
        x = I / self.I_par
        d = self.L_m0 - self.L_m_inf
        return self.L_m_inf * I + d * self.I_par * self._knee(x), self.L_m_inf + self._knee_slope(d, x)

    def m(self, I):
        return self.L_m_inf + (self.L_m0 - self.L_m_inf) * self._g(I / self.I_par)

    def dm_dI(self, I):
        return (self.L_m0 - self.L_m_inf) * self._dg(I / self.I_par) / self.I_par

    def coenergy(self, I):
        d = self.L_m0 - self.L_m_inf
        return 0.5 * self.L_m_inf * I * I + d * self.I_par**2 * self._integral(I / self.I_par)
