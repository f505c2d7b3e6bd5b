"""Phase and alpha/beta quantities of a three-phase machine with a floating star point (amplitude-invariant
Clarke transform), shared by the inverter (:mod:`satmotor.converter.inverter`), the pwm stage on the
capacitor link (:mod:`satmotor.converter.pwm_link`) and the controller's dead-time compensation."""

from __future__ import annotations

import math

SQRT3 = math.sqrt(3.0)
SQRT3_2 = 0.5 * SQRT3


def phase_currents(i_alpha, i_beta):
    """Phase currents [A] of an alpha/beta current (amplitude-invariant Clarke, no zero sequence)."""
    return (i_alpha, -0.5 * i_alpha + SQRT3_2 * i_beta, -0.5 * i_alpha - SQRT3_2 * i_beta)


def alpha_beta(va, vb, vc):
    """Alpha/beta voltage [V] of phase voltages [V] (the star point floating: zero sequence removed)."""
    return (2.0 * va - vb - vc) / 3.0, (vb - vc) / SQRT3
