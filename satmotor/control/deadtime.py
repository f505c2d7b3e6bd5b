"""Dead-time compensation of the voltage command (the controller's ``deadtime_comp_voltage``).

An inverter's dead time costs each phase about ``t_dead f_sw V_dc`` of voltage against the sign of its
current (:mod:`satmotor.converter.inverter`).  The compensation adds ``sign(i_x) V_comp`` [V] to each
phase ``x`` of the command, the signs from the measured stator current at the sample (amplitude-invariant
Clarke: ``i_a = i_alpha``, ``i_b,c = -i_alpha/2 +- sqrt(3)/2 i_beta``; an exactly zero current adds
nothing), and returns the alpha/beta command (the zero sequence of the added set removed, as the
floating star point does).  ``V_comp = 0``: the command as it is (the controller before the option).
The C core's ``sm_deadtime_compensate`` (``fmu/native/core/sm_inverter.c``) is the same floats.
"""

from __future__ import annotations

from satmotor.machine.phases import alpha_beta, phase_currents


def _sign_times(i, v):
    return v if i > 0.0 else -v if i < 0.0 else 0.0


def compensate(v_alpha, v_beta, i_alpha, i_beta, V_comp):
    """The command ``(v_alpha, v_beta)`` [V] with ``sign(i_phase) V_comp`` [V] added per phase, from the
    measured current ``(i_alpha, i_beta)`` [A]; unchanged for ``V_comp = 0``."""
    if V_comp == 0.0:
        return v_alpha, v_beta
    ia, ib, ic = phase_currents(i_alpha, i_beta)
    ca, cb = alpha_beta(_sign_times(ia, V_comp), _sign_times(ib, V_comp), _sign_times(ic, V_comp))
    return v_alpha + ca, v_beta + cb
