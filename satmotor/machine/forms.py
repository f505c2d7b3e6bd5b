"""Equivalent-circuit forms of the induction motor and their conversion into :class:`MotorParams`.

The seed's parameters (``R_s``, ``R_r``, ``l_s``, ``l_r``, ``k`` and a magnetizing curve
``psi_m(|i_mu|)``, ``i_mu = i_s + k i_r``) cover three textbook forms, all per phase, in the
amplitude-invariant space-vector convention (an impedance is the same in rms and in peak values):

* **T form** (:class:`TForm`): stator leakage ``L_ls``, rotor leakage ``L_lr`` (referred to the
  stator), magnetizing curve.  It is the seed's form with ``k = 1``: ``l_s = L_ls``, ``l_r = L_lr``,
  ``R_r`` as given, the same curve.  :func:`t_form_of` refers a seed parameter set with any ``k``
  to it (``i_r' = k i_r``, ``psi_r' = psi_r / k``: ``L_lr = l_r / k^2``, ``R_r' = R_r / k^2``, the
  same i_mu and curve).
* **Gamma form** (:class:`GammaForm`; Slemon's Gamma-equivalent circuit, the form of motulator and
  of Qu et al. 2012): all leakage on the rotor side, ``psi_s = L_M(.) i_mu``,
  ``psi_R = psi_s + L_sigma i_R``, ``i_mu = i_s + i_R``.  It is the seed's form with ``l_s = 0``,
  ``k = 1``, ``l_r = L_sigma``, ``R_r = R_R`` and the curve ``psi_s(I)`` (exact, saturation
  included; the plant solves it as :mod:`satmotor.machine.plant` says).
* **Inverse-Gamma form** (:class:`InverseGammaForm`): all leakage on the stator side,
  ``psi_s = L_sigma i_s + psi_R``, ``psi_R = L_M (i_s + i_R)``.  The seed's form would need
  ``l_r = 0``, which the control model cannot take (it divides by l_r); for a linear machine the
  forms are equivalent and :meth:`InverseGammaForm.to_gamma` converts exactly:
  with the T-model self inductances ``L_s``, ``L_r``, mutual ``L_m`` and
  ``sigma = 1 - L_m^2 / (L_s L_r)``::

      Gamma:          L_M = L_s,               L_sigma = L_s sigma / (1 - sigma),  R_R = (L_s / L_m)^2 R_r
      inverse Gamma:  L_M' = L_m^2 / L_r,      L_sigma' = sigma L_s,               R_R' = (L_m / L_r)^2 R_r

  hence ``L_M = L_sigma' + L_M'``, ``L_sigma = L_M L_sigma' / L_M'``, ``R_R = R_R' (L_M / L_M')^2``.
  With a saturating curve the two forms saturate different fluxes and no exact conversion exists.

:func:`from_tests` turns the classical tests (DC resistance, no-load at synchronous speed,
locked rotor) into a T form, exactly for the model (no small-quantity approximation):

* no load (slip 0): ``Z_0 = R_s + j omega_0 (L_ls + L_m)``, so ``L_ls + L_m = X_0 / omega_0`` with
  ``X_0 = sqrt(|Z_0|^2 - R_0^2)``, ``|Z_0| = V_phase / I``, ``R_0 = P_in / (3 I^2)``;
* locked rotor (slip 1): ``Z_1 = R_s + j omega_1 L_ls + (j omega_1 L_m) || (R_r + j omega_1 L_lr)``;
* with the leakage split ``L_lr = ratio L_ls`` (IEEE 112: 1 for design A and wound rotors, 1.5 for B,
  7/3 for C, 1 for D), removing ``R_s + j omega_1 L_ls`` and the magnetizing branch from ``Z_1`` leaves
  the rotor branch ``R_r + j omega_1 L_lr``; the one unknown L_ls is the root of
  ``Im(rotor branch) / omega_1 - ratio L_ls = 0`` (bisection on ``(0, L_ls + L_m)``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from satmotor.errors import ParameterError, require_number
from satmotor.machine.magnetics import LinearCurve, PolynomialCurve
from satmotor.machine.params import MotorParams

__all__ = ["TForm", "GammaForm", "InverseGammaForm", "t_form_of", "NoLoadTest", "LockedRotorTest",
           "from_tests", "polynomial_from_inductance"]


def _curve_of(curve):
    """A curve object from a curve or a constant inductance [H] (a :class:`LinearCurve`)."""
    if hasattr(curve, "solve"):
        return curve
    return LinearCurve(require_number("L_m", curve, 0))


def _linear_inductance(curve, what):
    c = _curve_of(curve)
    if not isinstance(c, LinearCurve):
        raise ParameterError(what, c, "must be a constant inductance (LinearCurve or a number [H]): the "
                             "conversion between the forms is exact only for an unsaturated machine")
    return c.L_m0


def polynomial_from_inductance(L_0, beta, p):
    """The curve ``psi = L(psi) I`` with ``L(psi) = L_0 / (1 + (beta psi)^p)`` as a :class:`PolynomialCurve`.

    ``I = psi / L(psi) = psi / L_0 + (beta^p / L_0) psi^(p+1)``: exact, ``poly_n = p + 1``.
    L_0 [H], beta [1/Wb], p an integer >= 1.  Qu et al. (2012): ``L_0 = 0.34``, ``beta = 0.84``, ``p = 7``.
    """
    L_0 = require_number("L_0", L_0, 0)
    beta = require_number("beta", beta, 0, inclusive=True)
    if not isinstance(p, int) or isinstance(p, bool) or p < 1:
        raise ParameterError("p", p, "must be an integer >= 1")
    return PolynomialCurve(L_0, beta**p / L_0, p + 1)


@dataclass(frozen=True)
class TForm:
    """T-equivalent circuit, rotor referred to the stator (k = 1).

    R_s, R_r [Ohm]; L_ls, L_lr [H] (L_ls >= 0, L_lr > 0); curve: the magnetizing curve psi_m(|i_mu|)
    or a constant L_m [H].
    """

    R_s: float
    R_r: float
    L_ls: float
    L_lr: float
    curve: object = field(default=None)

    def __post_init__(self):
        object.__setattr__(self, "curve", _curve_of(self.curve))

    def to_motor(self, n_p, J, B=0.0):
        """:class:`MotorParams` (k = 1) with pole pairs n_p, inertia J [kg m2], friction B [N m s]."""
        return MotorParams(self.R_s, self.R_r, self.L_ls, self.L_lr, 1.0, n_p, J, B, self.curve)

    def to_gamma(self):
        """The :class:`GammaForm` of this (unsaturated) machine."""
        L_m = _linear_inductance(self.curve, "curve")
        L_s, L_r = self.L_ls + L_m, self.L_lr + L_m
        g = L_s / L_m  # referral factor of the Gamma form
        return GammaForm(self.R_s, g * g * self.R_r, g * g * L_r - L_s, LinearCurve(L_s))

    def to_inverse_gamma(self):
        """The :class:`InverseGammaForm` of this (unsaturated) machine."""
        L_m = _linear_inductance(self.curve, "curve")
        L_s, L_r = self.L_ls + L_m, self.L_lr + L_m
        g = L_m / L_r
        return InverseGammaForm(self.R_s, g * g * self.R_r, L_s - L_m * g, L_m * g)


@dataclass(frozen=True)
class GammaForm:
    """Gamma-equivalent circuit: R_s, R_R [Ohm], leakage L_sigma [H] (> 0), magnetizing curve
    ``psi_s(|i_mu|)`` (or a constant L_M [H]) on the stator side."""

    R_s: float
    R_R: float
    L_sigma: float
    curve: object = field(default=None)

    def __post_init__(self):
        object.__setattr__(self, "curve", _curve_of(self.curve))

    def to_motor(self, n_p, J, B=0.0):
        """:class:`MotorParams` with l_s = 0, k = 1, l_r = L_sigma, R_r = R_R (exact, saturation included)."""
        return MotorParams(self.R_s, self.R_R, 0.0, self.L_sigma, 1.0, n_p, J, B, self.curve)


@dataclass(frozen=True)
class InverseGammaForm:
    """Inverse-Gamma circuit: R_s, R_R [Ohm], stator-side leakage L_sigma [H], constant L_M [H]."""

    R_s: float
    R_R: float
    L_sigma: float
    L_M: float

    def to_gamma(self):
        """The :class:`GammaForm` of the same (unsaturated) machine (module docstring)."""
        L_M = self.L_sigma + self.L_M
        r = L_M / self.L_M
        return GammaForm(self.R_s, self.R_R * r * r, L_M * self.L_sigma / self.L_M, LinearCurve(L_M))

    def to_motor(self, n_p, J, B=0.0):
        """:class:`MotorParams` of the equivalent Gamma form (l_s = 0)."""
        return self.to_gamma().to_motor(n_p, J, B)


def t_form_of(params):
    """The :class:`TForm` of a :class:`MotorParams` (rotor referred with its k; the same curve)."""
    k2 = params.k * params.k
    return TForm(params.R_s, params.R_r / k2, params.l_s, params.l_r / k2, params.curve)


@dataclass(frozen=True)
class NoLoadTest:
    """No-load test at (about) synchronous speed: V_ll_rms [V] line-to-line, I_rms [A] line, P_in [W]
    three-phase input power, f [Hz]."""

    V_ll_rms: float
    I_rms: float
    P_in: float
    f: float


@dataclass(frozen=True)
class LockedRotorTest:
    """Locked-rotor test: V_ll_rms [V], I_rms [A], P_in [W] three-phase, f [Hz] (often reduced)."""

    V_ll_rms: float
    I_rms: float
    P_in: float
    f: float


def _impedance(test, name):
    for fld in ("V_ll_rms", "I_rms", "f"):
        require_number(f"{name}.{fld}", getattr(test, fld), 0)
    require_number(f"{name}.P_in", test.P_in, 0, inclusive=True)
    z = test.V_ll_rms / math.sqrt(3.0) / test.I_rms
    r = test.P_in / (3.0 * test.I_rms * test.I_rms)
    if r > z:
        raise ParameterError(f"{name}.P_in", test.P_in, f"exceeds the apparent power sqrt(3) V I = "
                             f"{math.sqrt(3.0) * test.V_ll_rms * test.I_rms!r} W")
    return r, math.sqrt(z * z - r * r), 2.0 * math.pi * test.f


def from_tests(R_s, no_load, locked_rotor, leakage_ratio=1.0):
    """:class:`TForm` (linear L_m) from the stator resistance R_s [Ohm] (DC test), a
    :class:`NoLoadTest` and a :class:`LockedRotorTest`; ``leakage_ratio = L_lr / L_ls`` (module
    docstring).  For a saturation curve, run ``fit-curve`` on a no-load voltage sweep with the
    L_ls found here.  Raises :class:`ParameterError` naming the test and field."""
    R_s = require_number("R_s", R_s, 0)
    ratio = require_number("leakage_ratio", leakage_ratio, 0)
    _, X0, w0 = _impedance(no_load, "no_load")
    R1, X1, w1 = _impedance(locked_rotor, "locked_rotor")
    L0 = X0 / w0  # L_ls + L_m
    z1 = complex(R1 - R_s, X1)

    def rotor_branch(L_ls):
        zp = z1 - 1j * w1 * L_ls  # magnetizing branch || rotor branch
        return 1.0 / (1.0 / zp - 1.0 / (1j * w1 * (L0 - L_ls)))

    def g(L_ls):
        return rotor_branch(L_ls).imag / w1 - ratio * L_ls

    lo, hi = 0.0, min(X1 / w1, L0) * (1.0 - 1e-12)  # L_ls below the locked-rotor inductance
    if not (g(lo) > 0.0 > g(hi)):
        raise ParameterError("locked_rotor", locked_rotor, f"is not consistent with the no-load test "
                             f"(L_ls + L_m = {L0!r} H) and R_s = {R_s!r} Ohm: no leakage split found")
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi):
            break
        if g(mid) > 0.0:
            lo = mid
        else:
            hi = mid
    L_ls = 0.5 * (lo + hi)
    zr = rotor_branch(L_ls)
    if zr.real <= 0.0:
        raise ParameterError("locked_rotor.P_in", locked_rotor.P_in, f"leaves no rotor resistance "
                             f"(R_r = {zr.real!r} Ohm): check P_in and R_s")
    return TForm(R_s, zr.real, L_ls, ratio * L_ls, LinearCurve(L0 - L_ls))
