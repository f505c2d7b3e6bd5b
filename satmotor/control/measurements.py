"""Magnetizing state from measured stator currents and fluxes (controller side).

Everything here uses the *controller's* parameter set (its curve may differ from
the plant's one, e.g. the constant-m baseline passes a ``LinearCurve``).

Rotor-flux variant (:func:`from_rotor_flux`): with ``i_r = (psi_r - k m i_mu)/l_r``
and ``i_mu = i_s + k i_r``::

    i_mu (1 + k^2 m(I) / l_r) = w,   w = i_s + (k / l_r) psi_r

so i_mu is collinear with w and ``I = |i_mu|`` is the root of
``(l_r/k^2) I + psi_m(I) = (l_r/k^2) |w|`` (``curve.solve``); ``m = psi_m(I)/I``.

Stator-flux variant (:func:`from_stator_flux`, the seed's H1 with the errata's eq 18
fix): ``i_mu = sigma i_s + (k/l_r)(psi_r - k psi_s)`` (pure algebra, no curve) and
``m = |psi_s - l_s i_s| / |i_mu|`` (no 0/0 at i_mu_q = 0; ``m(0)`` of the curve at I = 0).

Both return a :class:`MagnetizingState` that also gives the rotor-flux frame:
``Phi_rd = |psi_r|``, ``rho = atan2(psi_r_beta, psi_r_alpha)`` and i_mu rotated by -rho.

The measurement tuple a drive reads every sample is
``meas = (i_s_alpha, i_s_beta, psi_r_alpha, psi_r_beta, psi_s_alpha, psi_s_beta, omega_m)``
[A, A, Wb, Wb, Wb, Wb, rad/s]: the controller unit's first seven inputs in their order
(``satmotor.interface.CONTROLLER_INPUTS``, passed through as they come; a test checks the positions);
its indices are the constants ``MEAS_I_S_A`` ... ``MEAS_OMEGA_M``, ``MEAS_NAMES`` the input names
(psi_s is read only with the stator-flux variant).  The C core's ``SM_MEAS_*`` are generated from
these (``orchestration/packaging/native/tables.py``, into ``sm_params.h``; the generation checks them against
the interface table).  The plain-Python loop appends the plant's true magnetizing current
``(i_mu_alpha, i_mu_beta)`` [A] (``MEAS_I_MU_A``, ``MEAS_I_MU_B``), which
:func:`from_magnetizing_current` takes as it is: the design comparison's "true i_mu" setting (no
drive can measure it).
"""

from __future__ import annotations

import math
from typing import NamedTuple

from satmotor.machine.atan import atan2

MEAS_I_S_A, MEAS_I_S_B, MEAS_PSI_R_A, MEAS_PSI_R_B, MEAS_PSI_S_A, MEAS_PSI_S_B, MEAS_OMEGA_M = range(7)
MEAS_LEN = 7
MEAS_NAMES = ("i_s_alpha", "i_s_beta", "psi_r_alpha", "psi_r_beta", "psi_s_alpha", "psi_s_beta", "omega_m")
MEAS_I_MU_A, MEAS_I_MU_B = 7, 8  # the plant's true i_mu, carried by the plain loop for the comparison


class MagnetizingState(NamedTuple):
    """Magnetizing current and rotor-flux frame (SI units)."""

    i_mu_alpha: float  # [A]
    i_mu_beta: float  # [A]
    I: float  # [A] |i_mu|
    m: float  # [H] static magnetizing inductance psi_m / I
    Phi_rd: float  # [Wb] rotor flux magnitude (Phi_rq = 0 in its own frame)
    i_mu_d: float  # [A]
    i_mu_q: float  # [A]
    rho: float  # [rad] rotor flux angle


def _in_flux_frame(ima, imb, I, m, pra, prb):
    phi = math.hypot(pra, prb)
    rho = atan2(prb, pra)  # the own atan2 (sm_atan2 in C): the same bits on every platform
    c, s = math.cos(rho), math.sin(rho)
    return MagnetizingState(ima, imb, I, m, phi, c * ima + s * imb, c * imb - s * ima, rho)


def from_rotor_flux(i_sa, i_sb, psi_ra, psi_rb, params):
    """Magnetizing state from i_s [A] and psi_r [Wb] (alpha, beta) via the curve of ``params``."""
    k_lr = params.k / params.l_r
    wa = i_sa + k_lr * psi_ra
    wb = i_sb + k_lr * psi_rb
    wn = math.hypot(wa, wb)
    a = params.l_r / (params.k * params.k)
    curve = params.curve
    I, psi = curve.solve(a, a * wn)
    if I == 0.0:
        return _in_flux_frame(0.0, 0.0, 0.0, curve.m(0.0), psi_ra, psi_rb)
    s = I / wn
    return _in_flux_frame(s * wa, s * wb, I, psi / I, psi_ra, psi_rb)


def from_magnetizing_current(i_mu_a, i_mu_b, psi_ra, psi_rb, params):
    """Magnetizing state from a given i_mu [A] (the plant's true one) and psi_r [Wb]; m from the
    curve of ``params`` at |i_mu| (``L_m0`` for a constant-m design)."""
    I = math.hypot(i_mu_a, i_mu_b)
    return _in_flux_frame(i_mu_a, i_mu_b, I, params.curve.m(I), psi_ra, psi_rb)


def from_stator_flux(i_sa, i_sb, psi_ra, psi_rb, psi_sa, psi_sb, params):
    """Magnetizing state from i_s [A], psi_r and psi_s [Wb] (alpha, beta); no curve inversion."""
    k, ls = params.k, params.l_s
    k_lr = k / params.l_r
    sg = params.sigma
    ima = sg * i_sa + k_lr * (psi_ra - k * psi_sa)
    imb = sg * i_sb + k_lr * (psi_rb - k * psi_sb)
    I = math.hypot(ima, imb)
    if I == 0.0:
        m = params.curve.m(0.0)
    else:
        m = math.hypot(psi_sa - ls * i_sa, psi_sb - ls * i_sb) / I
    return _in_flux_frame(ima, imb, I, m, psi_ra, psi_rb)


__all__ = ["MagnetizingState", "from_rotor_flux", "from_stator_flux", "from_magnetizing_current",
           "MEAS_I_MU_A", "MEAS_I_MU_B", "MEAS_LEN", "MEAS_NAMES",
           "MEAS_I_S_A", "MEAS_I_S_B", "MEAS_PSI_R_A", "MEAS_PSI_R_B", "MEAS_OMEGA_M", "MEAS_PSI_S_A",
           "MEAS_PSI_S_B"]
