"""The largest steady torque a stator current limit allows at a rotor flux (SI units).

In the rotor-flux frame (``Phi_rq = 0``) a steady state at the flux ``Phi_rd`` needs
``Phi_rd' = 0``, i.e. ``k m i_mu_d = Phi_rd`` (:func:`satmotor.control.fo_model.flux_rate`).  With the stator
current at its limit, ``i_s = I_max (cos g, sin g)``, the magnetizing state follows from the curve
(:func:`satmotor.control.measurements.from_rotor_flux`, the controller's own inversion), and
``k m i_mu_d - Phi_rd`` falls strictly as the angle g goes from 0 (all the current on the flux axis)
to pi/2; the steady angle is its root, found by bisection.  The torque there is
``T_max = J K m Phi_rd i_mu_q`` (``K`` of :func:`satmotor.control.fo_model.model_constants`, i.e.
``3/2 n_p k m Phi_rd i_mu_q / l_r``): the most the motor gives at that flux without the current
exceeding ``I_max``.  With a constant inductance it is the textbook
``3/2 n_p (k m / (l_r + k^2 m)) Phi_rd sqrt(I_max^2 - (Phi_rd / (k m))^2)``.

Friction (``B omega_m``) is not subtracted: it is a load like ``T_load``.  The drive's law gives the
flux axis at most ``D_SHARE I_max`` (:mod:`satmotor.control.backstepping`); :attr:`TorqueLimit.i_sd` says how
much of the limit the flux takes.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from satmotor.control.fo_model import model_constants
from satmotor.control.measurements import from_rotor_flux
from satmotor.errors import ParameterError, require_number

_ITER = 200  # bisection steps (stops earlier when the angle no longer changes)


class TorqueLimit(NamedTuple):
    """The steady state at the current limit: torque and currents in the rotor-flux frame."""

    T_max: float  # [N m] electromagnetic torque
    i_sd: float  # [A] stator current, flux axis
    i_sq: float  # [A] stator current, torque axis
    i_mu_d: float  # [A] magnetizing current, flux axis
    i_mu_q: float  # [A]
    m: float  # [H] static magnetizing inductance at |i_mu|


def _state(params, psi_r, I_max, g):
    i_sd, i_sq = I_max * math.cos(g), I_max * math.sin(g)
    ms = from_rotor_flux(i_sd, i_sq, psi_r, 0.0, params)
    return i_sd, i_sq, ms


def torque_limit(params, psi_r, I_max):
    """:class:`TorqueLimit` of the motor ``params`` (:class:`satmotor.machine.params.MotorParams`) at the
    steady rotor flux ``psi_r`` [Wb] with ``|i_s| = I_max`` [A].  Raises :class:`ParameterError`
    (field ``psi_ref``) when even ``I_max`` on the flux axis cannot hold ``psi_r``."""
    require_number("psi_ref", psi_r, 0)
    require_number("I_max", I_max, 0)
    k = params.k

    def excess(g):  # k m i_mu_d - Phi_rd: > 0 while the flux axis has more current than it needs
        _, _, ms = _state(params, psi_r, I_max, g)
        return k * ms.m * ms.i_mu_d - psi_r

    if excess(0.0) < 0.0:
        raise ParameterError("psi_ref", psi_r, f"cannot be held with |i_s| <= I_max = {I_max!r} A on the "
                             f"'{params.curve.name}' curve")
    lo, hi = 0.0, 0.5 * math.pi
    for _ in range(_ITER):
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi):
            break
        if excess(mid) >= 0.0:
            lo = mid
        else:
            hi = mid
    i_sd, i_sq, ms = _state(params, psi_r, I_max, lo)
    c = model_constants(params)
    return TorqueLimit(params.J * c.K * ms.m * psi_r * ms.i_mu_q, i_sd, i_sq, ms.i_mu_d, ms.i_mu_q, ms.m)


__all__ = ["TorqueLimit", "torque_limit"]
