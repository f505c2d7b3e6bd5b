"""The drive's start from standstill: the pre-magnetization current loop and the switch to the law.

The backstepping law is singular at Phi_rd = 0, so a drive (:mod:`satmotor.control.drive`) first
builds the flux with a current loop (:func:`premag_output`) and hands over to the law once the flux is
there (:func:`switch_now`), its reference shapers started at the measured state
(:func:`switch_state`) so that the law takes over without a jump.  Pure functions of the drive's
settings (:class:`satmotor.control.drive_config.DriveConfig`) and its state, in the order of the C
(``fmu/native/core/sm_drive.c``).
"""

from __future__ import annotations

import math

from satmotor.control.backstepping import D_SHARE
from satmotor.control.drive_config import PREMAG, DriveOutput
from satmotor.control.fo_model import flux_rate, model_constants
from satmotor.control.measurements import (
    MEAS_I_S_A,
    MEAS_I_S_B,
    MEAS_OMEGA_M,
    MEAS_PSI_R_A,
    MEAS_PSI_R_B,
    from_rotor_flux,
)

_FRAME_MIN = 1e-3  # [1] below this fraction of the set-point the premag current stays on alpha


def switch_now(cfg, phi, psi_ref, omega_m, n, n_switch):
    """Whether the law takes over at this sample: at ``premag_fraction`` of the set-point ``psi_ref``
    [Wb]; from ``premag_min_fraction`` on when the rotor moves (``|omega_m|`` [rad/s] above
    ``premag_speed_tol``) or the time is up (``n`` pre-magnetization samples of ``n_switch``); never
    below (no law at near-zero flux).  ``phi`` [Wb]: the rotor flux magnitude; ``cfg``: DriveConfig."""
    if phi >= cfg.premag_fraction * psi_ref:
        return True
    return phi >= cfg.premag_min_fraction * psi_ref and (
        n >= n_switch or abs(omega_m) > cfg.premag_speed_tol)


def premag_output(params, cfg, meas, I_set, phi, psi_ref, V_max, omega_ref_shaped, psi_ref_shaped):
    """One pre-magnetization sample: a current loop in the rotor-flux frame (on alpha until there is a
    flux to align with) with resistive feed-forward::

        v_sd = R_s i_ref + K_pm (i_ref - i_sd),   v_sq = -K_pm i_sq

    i_ref = min(premag_boost I_set, I_max) (``I_set`` [A]: the steady magnetizing current of
    ``psi_ref``), whatever the rotor does; when a load drives the rotor (|omega_m| > premag_speed_tol)
    i_ref -> D_SHARE I_max, the fastest flux build-up the limit allows, so that the law can take over
    and hold the rotor sooner.  The voltage is bounded by ``V_max`` [V].

    ``omega_ref_shaped``, ``psi_ref_shaped``: the reference shapers' values, reported as they are (the
    shapers do not run before the law does: at rest, 0; the switch starts them at the measured state);
    no measured value is reported as a reference.  e1 is the flux against the raw set-point
    (``|psi_r| - psi_ref``: how far the build-up has come).  Returns a :class:`DriveOutput`."""
    K = cfg.premag_gain
    bounded = cfg.premag_boost * I_set > cfg.I_max
    i_ref = min(cfg.premag_boost * I_set, cfg.I_max)
    if abs(meas[MEAS_OMEGA_M]) > cfg.premag_speed_tol:
        i_ref = max(i_ref, D_SHARE * cfg.I_max)
    pa, pb = meas[MEAS_PSI_R_A], meas[MEAS_PSI_R_B]
    c, s = (pa / phi, pb / phi) if phi > _FRAME_MIN * psi_ref else (1.0, 0.0)
    ia, ib = meas[MEAS_I_S_A], meas[MEAS_I_S_B]
    vd = params.R_s * i_ref + K * (i_ref - (c * ia + s * ib))
    vq = -K * (c * ib - s * ia)
    vn = math.hypot(vd, vq)
    lim = vn > V_max
    if lim:
        vd, vq = vd * V_max / vn, vq * V_max / vn
    return DriveOutput(c * vd - s * vq, s * vd + c * vq, vd, vq, phi - psi_ref, 0.0, 0.0, 0.0, 0.0,
                       0.0, 0.0, omega_ref_shaped, psi_ref_shaped, PREMAG, lim, False, bounded, pa, pb)


def switch_state(params, meas):
    """The flux shaper's state at the switch, ``(Phi_rd, Phi_rd', 0)`` with
    ``Phi_rd' = (R_r/l_r)(k m i_mu_d - Phi_rd)`` (:func:`satmotor.control.fo_model.flux_rate`) from the
    measurements ``meas``, and the magnetizing state there
    (:func:`satmotor.control.measurements.from_rotor_flux`): ``e1 = e2 = 0`` at the switch."""
    ms = from_rotor_flux(meas[MEAS_I_S_A], meas[MEAS_I_S_B], meas[MEAS_PSI_R_A], meas[MEAS_PSI_R_B], params)
    c = model_constants(params)
    dphi = flux_rate(c.a, c.k, ms.Phi_rd, ms.i_mu_d, ms.m)
    return (ms.Phi_rd, dphi, 0.0), ms
