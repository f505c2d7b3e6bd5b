"""Automatic field weakening on the magnetizing curve: the largest rotor-flux set-point whose steady
state at the present torque and speed needs at most ``ratio V_max`` of stator voltage (SI units).

Steady state of the control model (:mod:`satmotor.control.fo_model`) in the rotor-flux frame
(``Phi_rq = 0``, ``Phi_rd' = 0``, ``i_mu' = 0``) at the rotor flux ``Phi`` [Wb], the electromagnetic
torque ``T`` [N m] and the speed ``omega_m`` [rad/s].  The main flux ``psi_m = m(I) i_mu`` has the
components ``psi_md = Phi / k`` (from ``k m i_mu_d = Phi``) and ``psi_mq = T l_r / (kappa k Phi)``
(from ``T = kappa k m Phi i_mu_q / l_r``, ``kappa = 3/2 n_p``), so ``psi_md psi_mq = c`` with
``c = T l_r / (kappa k^2)``.  Parametrized by the magnetizing current ``I = |i_mu|`` on the curve
(no inversion): ``psi_m = curve.psi(I)``, ``m = psi_m / I`` and::

    psi_md^2 = (psi_m^2 + sqrt(psi_m^4 - 4 c^2)) / 2        (the flux-axis root, psi_md >= |psi_mq|)
    Phi = k psi_md,   i_mu = (psi_md, c / psi_md) / m
    i_s   = (1 + k^2 m / l_r) i_mu - (k / l_r) Phi e_d
    psi_s = (l_s + sigma m) i_mu - (k l_s / l_r) Phi e_d
    omega_s = n_p omega_m + R_r k m i_mu_q / (l_r Phi)
    v_s = R_s i_s + omega_s J2 psi_s

(no ``I`` gives a steady state with ``psi_m^2 < 2 |c|``: too little flux for the torque).  The
flux-to-magnetizing-current relation is the curve's at every point, not a constant inductance:
the saturated knee is where the default motor runs at its rated flux.

Along this branch ``Phi`` rises with ``I`` and ``|v_s|`` has one minimum (the breakdown point:
the most torque per volt at this speed, where ``psi_mq / psi_md`` is about
``l_r / (sigma (l_r + k^2 m))``).  :meth:`FieldWeakening.flux_reference`:

1. ``T`` from the measured (or observed) state (:func:`satmotor.control.measurements.from_rotor_flux`,
   ``T = kappa k m Phi_rd i_mu_q / l_r``), the speed ``omega_m + (3 / w_n) omega_ref_shaped'``: where
   the speed will be after the flux shaper's delay ``3 / w_n`` (its DC group delay), so that the
   shaped flux is down in time on a ramp.
2. If the steady state at the nominal flux ``psi_ref`` (one curve inversion,
   ``I = curve.current(hypot(psi_ref / k, c k / psi_ref))``) needs at most ``ratio V_max``, the
   set-point is ``psi_ref`` itself: below the voltage limit nothing changes, bit for bit.
3. Otherwise a bisection over ``I`` in ``(0, I(psi_ref)]`` for the largest ``I`` that fits, moving up
   where ``|v_s| <= ratio V_max`` or where ``|v_s|`` still falls with ``I`` (or no steady state
   exists), down otherwise (when no ``I`` fits it ends where ``|v_s|`` is least).  The set-point is
   ``Phi(I)``, at least ``FLOOR psi_ref`` and at most ``psi_ref``.
4. Beyond the breakdown torque (no ``I`` fits) the torque is limited: a bisection over ``s`` in [0, 2]
   finds the largest ``T_bd = s T`` whose least voltage is at most ``V_bd = (ratio + 1) V_max / 2``
   (:meth:`FieldWeakening.breakdown`); the set-point is the flux of that breakdown point and the law's
   current bound (its ``i_max``) becomes ``min(I_max, |i_s|)`` there, so that the law asks for no
   more torque than ``T_bd``: its torque demand is bounded, its integral and adaptation states stop
   (the law's anti-windup), and the voltage stays within what the inverter gives.  ``V_bd`` above
   ``ratio V_max`` is the hysteresis: held at ``T_bd`` the drive stays beyond what ``ratio V_max``
   allows, so the bound does not switch on and off from one sample to the next; it lets go when the
   load falls below the breakdown torque of ``ratio V_max``.  (The IFOC baseline keeps its own
   current limit.)

The current limit is the law's: it bounds the currents it demands by ``I_max``
(:mod:`satmotor.control.backstepping`); the torque used here is the one the motor produces, so a
flux is never chosen for a torque the currents cannot give.
"""

from __future__ import annotations

import math

from satmotor.control.measurements import (
    MEAS_I_S_A,
    MEAS_I_S_B,
    MEAS_OMEGA_M,
    MEAS_PSI_R_A,
    MEAS_PSI_R_B,
    from_rotor_flux,
)
from satmotor.errors import require_number

N_BISECT = 24  # bisection steps of the set-point: I(psi_ref) / 2^24 [A], far below what matters
N_BREAKDOWN = 16  # bisection steps of the breakdown point, both loops: T / 2^15 [N m], I(psi_ref) / 2^16 [A]
FLOOR = 0.1  # [1] the flux set-point never goes below this fraction of psi_ref
_SLOPE = 1e-7  # [1] relative step in I of the slope test


def steady_point(params, I, T, omega_m):
    """The steady state at the magnetizing current ``I`` [A] (> 0), torque ``T`` [N m] and speed
    ``omega_m`` [rad/s] on the flux-axis root (module docstring): ``(Phi, |v_s|, |i_s|, omega_s)``
    [Wb, V, A, rad/s], or None where no steady state has this ``I`` (``psi_m^2 < 2 |c|``)."""
    k = params.k
    psi = params.curve.psi(I)
    c = T * params.l_r / (1.5 * params.n_p * k * k)
    disc = psi * psi * psi * psi - 4.0 * c * c
    if not disc >= 0.0:
        return None
    pmd = math.sqrt(0.5 * (psi * psi + math.sqrt(disc)))
    return _point(params, psi / I, k * pmd, pmd, c / pmd, omega_m)


def _point(params, m, Phi, pmd, pmq, omega_m):
    k, l_r, l_s = params.k, params.l_r, params.l_s
    imd, imq = pmd / m, pmq / m
    cc = 1.0 + k * k * m / l_r
    k_lr = k / l_r
    i_sd, i_sq = cc * imd - k_lr * Phi, cc * imq
    L = l_s + params.sigma * m
    psd, psq = L * imd - l_s * k_lr * Phi, L * imq
    ws = params.n_p * omega_m + params.R_r * k * m * imq / (l_r * Phi)
    vd, vq = params.R_s * i_sd - ws * psq, params.R_s * i_sq + ws * psd
    return Phi, math.hypot(vd, vq), math.hypot(i_sd, i_sq), ws


def steady_point_at_flux(params, Phi, T, omega_m):
    """:func:`steady_point` at the rotor flux ``Phi`` [Wb] (> 0) instead of ``I``: one curve inversion.
    Returns ``(I, (Phi, |v_s|, |i_s|, omega_s))``."""
    k = params.k
    pmd = Phi / k
    pmq = T * params.l_r / (1.5 * params.n_p * k * k) / pmd
    psi = math.hypot(pmd, pmq)
    I = params.curve.current(psi)
    return I, _point(params, psi / I, Phi, pmd, pmq, omega_m)


class FieldWeakening:
    """The flux set-point of the drive above base speed (module docstring).

    Parameters
    ----------
    params : MotorParams
        The controller's model (its curve gives the flux-to-current relation).
    V_max : float
        [V] the voltage the inverter gives, ``V_dc / sqrt(3)``.
    ratio : float
        [1] the share of ``V_max`` a steady state may use, in (0, 1]: the rest is the law's margin.
    ref_bandwidth : float
        [rad/s] the reference shapers' ``w_n`` (the speed lead ``3 / w_n``).
    """

    def __init__(self, params, V_max, ratio, ref_bandwidth):
        self.params = params
        V_max = require_number("V_max", V_max, 0)
        self.V_lim = V_max * require_number("fw_voltage_ratio", ratio, 0, upper=1)
        self.V_bd = 0.5 * (self.V_lim + V_max)  # [V] the breakdown point's voltage (step 4)
        self.lead = 3.0 / require_number("ref_bandwidth", ref_bandwidth, 0)
        self._kt = 1.5 * params.n_p * params.k / params.l_r  # T = _kt m Phi_rd i_mu_q

    def torque(self, meas):
        """The electromagnetic torque [N m] of the control model at the measured state."""
        ms = from_rotor_flux(meas[MEAS_I_S_A], meas[MEAS_I_S_B], meas[MEAS_PSI_R_A], meas[MEAS_PSI_R_B],
                             self.params)
        return self._kt * ms.m * ms.Phi_rd * ms.i_mu_q

    def flux_reference(self, meas, omega_ref_rate, psi_ref, I_max=math.inf):
        """``(psi, i_max)``: the rotor-flux set-point [Wb] for the nominal ``psi_ref`` [Wb] and the
        current bound [A] for the law (``I_max`` [A], or less beyond the breakdown torque) at the
        measurement tuple ``meas`` (:mod:`satmotor.control.measurements`) and the shaped speed
        reference's slope ``omega_ref_rate`` [rad/s^2]; ``(psi_ref, I_max)`` themselves while the
        voltage suffices."""
        return self.set_points(self.torque(meas), meas[MEAS_OMEGA_M] + self.lead * omega_ref_rate, psi_ref,
                               I_max)

    def flux_at(self, T, omega, psi_ref):
        """The flux set-point [Wb] for the torque ``T`` [N m] at the speed ``omega`` [rad/s]."""
        return self.set_points(T, omega, psi_ref, math.inf)[0]

    def set_points(self, T, omega, psi_ref, I_max):
        """``(psi, i_max)`` for the torque ``T`` [N m] at the speed ``omega`` [rad/s] (steps 2 to 4 of
        the module docstring)."""
        p, V_lim = self.params, self.V_lim
        I_hi, pt = steady_point_at_flux(p, psi_ref, T, omega)
        if pt[1] <= V_lim:
            return psi_ref, I_max
        pt = steady_point(p, self.search(T, omega, I_hi, V_lim), T, omega)
        if pt is None or pt[1] > V_lim:  # beyond the breakdown torque: the breakdown point
            _, _, pt = self.breakdown(T, omega, I_hi, self.V_bd)
            if pt is None:
                return FLOOR * psi_ref, I_max
            I_max = min(I_max, pt[2])
        return min(max(pt[0], FLOOR * psi_ref), psi_ref), I_max

    def search(self, T, omega, I_hi, V_lim, n=N_BISECT):
        """The bisection over ``I`` in ``(0, I_hi]`` [A] (module docstring, step 3): the largest ``I``
        whose steady voltage at ``T`` [N m], ``omega`` [rad/s] is at most ``V_lim`` [V], or that of the
        least voltage when none is (0.0 where no steady state is found)."""
        p = self.params
        lo, hi = 0.0, I_hi
        for _ in range(n):
            mid = 0.5 * (lo + hi)
            pt = steady_point(p, mid, T, omega)
            if pt is None or pt[1] <= V_lim:
                lo = mid
                continue
            up = steady_point(p, mid * (1.0 + _SLOPE), T, omega)
            if up is not None and up[1] < pt[1]:  # still falling: the breakdown point is above
                lo = mid
            else:
                hi = mid
        return lo

    def breakdown(self, T, omega, I_hi, V):
        """The breakdown point for the voltage ``V`` [V] at ``omega`` [rad/s] in the direction of ``T``
        [N m]: the largest ``T_bd = s T`` (``s`` in [0, 2], bisection) whose least steady voltage
        (:meth:`search` with no voltage allowed) is at most ``V``, ``N_BREAKDOWN`` steps in both;
        returns ``(T_bd, I, steady_point)`` (the point None if none is found)."""
        p, lo, hi = self.params, 0.0, 2.0
        for _ in range(N_BREAKDOWN):
            mid = 0.5 * (lo + hi)
            T_mid = mid * T
            pt = steady_point(p, self.search(T_mid, omega, I_hi, -1.0, N_BREAKDOWN), T_mid, omega)
            if pt is not None and pt[1] <= V:
                lo = mid
            else:
                hi = mid
        T_bd = lo * T
        I = self.search(T_bd, omega, I_hi, -1.0, N_BREAKDOWN)
        return T_bd, I, (steady_point(p, I, T_bd, omega) if I > 0.0 else None)


__all__ = ["FLOOR", "N_BISECT", "N_BREAKDOWN", "FieldWeakening", "steady_point", "steady_point_at_flux"]
