"""Locked-rotor test -> rotor branch (R_r, l_r) and the stator leakage l_s, with a saturating curve.

At standstill with a balanced sinusoidal supply the fluxes rotate with constant magnitudes, so
``|i_mu|`` and ``m = m(|i_mu|)`` are constant and the T circuit holds with phasors (peak values,
amplitude-invariant; the voltage on the real axis, the current lagging by ``phi``,
``cos(phi) = P_in / (sqrt(3) V_ll_rms I_rms)``)::

    E_m = V - (R_s + j omega l_s) I,   psi_m = |E_m| / omega,   m = psi_m / I_mu(psi_m)   (the curve)
    1 / (R_r + j omega l_r) = I / E_m - 1 / (j omega m) - 1 / R_fe                       (R_fe = 0: none)

:func:`rotor_branch` is that, exact for the model.  The test gives two real numbers for three
unknowns (l_s, l_r, R_r): the leakage split ``l_r = ratio l_s`` closes it (IEEE 112: 1 for design A
and D, 1.5 for B, 7/3 for C).  Since the curve from the no-load test depends on l_s too,
:func:`leakage_from_tests` finds the root of ``l_r(l_s) - ratio l_s`` with the caller's
``curve_of(l_s)`` (the no-load fit at that l_s) in the loop.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from satmotor.errors import ParameterError, require_number

SQRT3 = math.sqrt(3.0)


class RotorBranch(NamedTuple):
    """Rotor branch and leakage from a locked-rotor test (SI)."""

    R_r: float  # [Ohm] rotor resistance (referred, k = 1)
    l_r: float  # [H] rotor leakage
    l_s: float  # [H] stator leakage used
    psi_m: float  # [Wb] main flux of the test (peak)


def rotor_branch(R_s, l_s, curve, test, R_fe=0.0):
    """:class:`RotorBranch` from a locked-rotor test (``satmotor.machine.forms.LockedRotorTest``), the
    stator resistance and leakage [Ohm, H], the magnetizing curve and the core-loss resistance
    [Ohm] (0: none).  Raises :class:`ParameterError` naming the test field."""
    for fld in ("V_ll_rms", "I_rms", "f"):
        require_number(f"locked_rotor.{fld}", getattr(test, fld), 0)
    require_number("locked_rotor.P_in", test.P_in, 0, inclusive=True)
    S = SQRT3 * test.V_ll_rms * test.I_rms
    if test.P_in > S:
        raise ParameterError("locked_rotor.P_in", test.P_in, f"exceeds the apparent power {S!r} VA")
    w = 2.0 * math.pi * test.f
    V = math.sqrt(2.0 / 3.0) * test.V_ll_rms
    c = test.P_in / S
    I = math.sqrt(2.0) * test.I_rms * complex(c, -math.sqrt(max(0.0, 1.0 - c * c)))
    E = V - complex(R_s, w * l_s) * I
    psi = abs(E) / w
    if not psi > 0.0:
        raise ParameterError("locked_rotor.V_ll_rms", test.V_ll_rms, "leaves no main-flux voltage: check R_s")
    m = psi / curve.current(psi)
    y = I / E - 1.0 / complex(0.0, w * m) - (1.0 / R_fe if R_fe > 0.0 else 0.0)
    z = 1.0 / y if y != 0 else complex(math.inf, 0.0)
    return RotorBranch(z.real, z.imag / w, l_s, psi)


def leakage_from_tests(R_s, test, curve_of, ratio=1.0, root=None):
    """``(RotorBranch, curve, R_fe)`` with ``l_r = ratio l_s``: ``curve_of(l_s) -> (curve, R_fe)`` is the
    no-load identification at that stator leakage; ``root(f, a, b)`` a bracketing scalar root finder
    (default: bisection).  The bracket is ``(0, L_1)``, L_1 the locked-rotor test's total inductance
    ``X / omega``.  Raises :class:`ParameterError` when no split fits."""
    ratio = require_number("leakage_ratio", ratio, 0)
    w = 2.0 * math.pi * require_number("locked_rotor.f", test.f, 0)
    z = SQRT3 * test.V_ll_rms / (3.0 * test.I_rms)
    r = test.P_in / (3.0 * test.I_rms ** 2)
    L1 = math.sqrt(max(0.0, z * z - r * r)) / w

    def g(l_s):
        curve, R_fe = curve_of(l_s)
        return rotor_branch(R_s, l_s, curve, test, R_fe).l_r - ratio * l_s

    lo, hi = L1 * 1e-6, L1 / (1.0 + ratio) * 1.5
    hi = min(hi, L1 * (1.0 - 1e-9))
    g_lo, g_hi = g(lo), g(hi)
    if not (g_lo > 0.0 > g_hi):
        raise ParameterError("locked_rotor", test, f"no leakage split l_r = {ratio!r} l_s fits it with "
                             f"R_s = {R_s!r} Ohm and the no-load test (l_s in ({lo:.3g}, {hi:.3g}) H)")
    if root is None:
        for _ in range(100):
            mid = 0.5 * (lo + hi)
            if g(mid) > 0.0:
                lo = mid
            else:
                hi = mid
            if hi - lo <= 1e-12 * hi:
                break
        l_s = 0.5 * (lo + hi)
    else:
        l_s = root(g, lo, hi)
    curve, R_fe = curve_of(l_s)
    rb = rotor_branch(R_s, l_s, curve, test, R_fe)
    if not rb.R_r > 0.0:
        raise ParameterError("locked_rotor.P_in", test.P_in, f"leaves no rotor resistance (R_r = {rb.R_r!r} "
                             "Ohm): check P_in and R_s")
    return rb, curve, R_fe
