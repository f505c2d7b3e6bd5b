"""The voltage limit of the backstepping law: the modulator's linear range or overmodulation (SI units).

``modulation = linear`` (the default): the command vector is scaled onto the circle
``|v_s| = V_dc / sqrt(3)``, the largest the inverter gives in every direction.

``modulation = overmodulation``: the minimum-phase-error limit onto the inverter's voltage hexagon
(vertices ``2 V_dc / 3`` on the phase axes, flats ``V_dc / sqrt(3)`` between them): a command outside
the hexagon keeps its direction and is scaled to the boundary, where the largest line-to-line voltage
(the spread ``max - min`` of the three phase voltages, amplitude-invariant Clarke) is ``V_dc``; inside
the hexagon it passes unchanged.  The plant's inverter (min-max zero sequence, duties clipped to
[0, 1]) gives every vector of the hexagon, so the limited command is what the plant applies on
average; beyond the circle the pwm's current ripple grows and the six-step's low harmonics are not
modelled by the average inverter.  C: ``sm_law.c`` (``voltage_limit``), bit for bit.
"""

from __future__ import annotations

import math

MODULATIONS = ("linear", "overmodulation")
_SQRT3 = math.sqrt(3.0)


def phase_spread(v_alpha, v_beta):
    """Largest line-to-line voltage [V] of the stationary vector: max - min of the phase voltages."""
    s32 = 0.5 * _SQRT3
    v0 = v_alpha
    v1 = -0.5 * v_alpha + s32 * v_beta
    v2 = -0.5 * v_alpha - s32 * v_beta
    hi = v0 if v0 > v1 else v1
    hi = hi if hi > v2 else v2
    lo = v0 if v0 < v1 else v1
    lo = lo if lo < v2 else v2
    return hi - lo


def limit_voltage(vd, vq, c, s, V_dc, overmodulation):
    """The command ``(vd, vq)`` [V] in the frame at angle (cos ``c``, sin ``s``) limited:
    ``(vd, vq, limited)``.  Linear: onto the circle ``V_dc / sqrt(3)``; overmodulation: onto the
    hexagon, the direction kept (a non-finite spread of a finite vector: the circle; a non-finite
    vector: the linear rule's axis)."""
    vmax = V_dc / _SQRT3
    vn = math.hypot(vd, vq)
    if overmodulation:
        spread = phase_spread(c * vd - s * vq, s * vd + c * vq)
        vlim = not spread <= V_dc
        if vlim and math.isfinite(spread):
            f = V_dc / spread
            return vd * f, vq * f, True
    else:
        vlim = not vn <= vmax
    if vlim:
        if math.isfinite(vn):
            f = vmax / vn
            vd, vq = vd * f, vq * f
        else:  # overflow: keep the direction where it is defined
            vd, vq = (math.copysign(vmax, vd), 0.0) if abs(vd) >= abs(vq) else (0.0, math.copysign(vmax, vq))
    return vd, vq, vlim


__all__ = ["MODULATIONS", "limit_voltage", "phase_spread"]
