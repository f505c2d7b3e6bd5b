"""Classical indirect field-oriented control (IFOC) with PI loops: the baseline controller.

Drives the stationary alpha-beta plant of :mod:`satmotor.machine.plant` (same conventions:
amplitude-invariant Clarke, mechanical speed ``omega_m`` [rad/s], rotor quantities
on the rotor side with the turns ratio ``k``).  The controller's model is the
*unsaturated* machine with a constant magnetizing inductance ``L_m`` [H], so
``psi_s = L_s i_s + k L_m i_r``, ``psi_r = k L_m i_s + L_ra i_r``.  Which ``L_m``: in the drive
(:class:`satmotor.control.drive.IFOCDrive`, the controller FMU's ``mode: pi``) the secant inductance of
the controller's curve at the nominal flux set-point, taken at the switch to the loops:
``L_m = (psi_ref / k) / I``, ``I = curve.current(psi_ref / k)`` (the no-load magnetizing point of that
flux, as a no-load test at rated voltage would give it), held whatever the flux set-point does later
(a constant ``L_m`` is what this baseline is).  :class:`IFOCController` alone defaults to
``params.curve.m`` at the default motor's rated magnetizing current ``RatedData.I_mu_n`` (5.7 A):
on another machine (``qu2012_2kw2``: deep in its saturation) that default missed a 0.95 Wb set-point
by 10 % (issue 20, item 4).

Model constants (rotor side; stator-referred: ``L_r' = L_ra / k^2 = l_r/k^2 + L_m``)::

    L_s   = l_s + L_m                    L_ra = l_r + k^2 L_m
    sigL  = L_s - (k L_m)^2 / L_ra       (= L_s - L_m^2 / L_r', transient inductance)
    tau_r = L_ra / R_r                   (= L_r' / R_r', R_r' = R_r / k^2)
    R_eq  = R_s + R_r (k L_m / L_ra)^2   (= R_s + R_r' (L_m / L_r')^2)

Rotor-flux frame (angle ``theta_f``, rotor flux ``psi_r = Phi + j 0``), from the plant::

    tau_r dPhi/dt = k L_m i_sd - Phi
    omega_f = n_p omega_m + omega_slip,  omega_slip = R_r k L_m i_sq / (L_ra Phi)
    v_sd = R_eq i_sd + sigL di_sd/dt - omega_f sigL i_sq - (k L_m R_r / L_ra^2) Phi
    v_sq = R_eq i_sq + sigL di_sq/dt + omega_f sigL i_sd + (k L_m / L_ra) n_p omega_m Phi
    T_e  = 3/2 n_p (k L_m / L_ra) Phi i_sq

Indirect scheme: ``i_sd* = Phi_ref / (k L_m)`` (steady state, ``i_r,d = 0``: the
rotor flux is ``k L_m i_sd``; ``Phi_ref`` is the rotor-side flux of the plant state);
``omega_slip = R_r k L_m i_sq* / (L_ra Phi_ref) = i_sq* / (tau_r i_sd*)``; the
frame angle is ``theta_f = int (n_p omega_m + omega_slip) dt`` (forward Euler per
sample; the output is rotated by ``theta_f + omega_f Ts / 2``, the mean angle of
the hold interval).

Tuning rule
-----------
* Current PIs (d and q, in the flux frame), pole-zero cancellation:
  ``K_p = sigL w_c``, ``K_i = R_eq w_c`` so ``PI(s) / (sigL s + R_eq) = w_c / s`` and
  the closed current loop is ``w_c / (s + w_c)``.  Decoupling feed-forward: the
  cross terms ``-+ omega_f sigL i_s(q,d)`` with the measured currents and the flux
  terms above with the model flux ``Phi_hat`` (``tau_r dPhi_hat/dt = k L_m i_sd -
  Phi_hat``, exact ZOH update).  Anti-windup: back-calculation with tracking time
  constant ``1/w_c`` (gain ``min(1, w_c Ts)`` per sample) on the vector-limited
  output ``|v_s| <= V_dc / sqrt(3)``.
* Speed PI (output torque ``T*`` [N m]), symmetric optimum for ``K_T / (J s)`` in
  series with the small time constant ``T_sigma = 1/w_c + Ts`` (current loop plus
  sampling): crossover ``w_speed``, ``a = 1 / (w_speed T_sigma) >= 2``,
  ``K_p = J w_speed``, ``T_i = a^2 T_sigma``, ``K_i = K_p / T_i`` (phase margin
  ``asin((a^2 - 1)/(a^2 + 1))``).  ``i_sq* = T* / (3/2 n_p (k L_m / L_ra) Phi_ref)``.
  Current limit: ``|i_s*| <= I_max`` (``i_sd*`` first, ``|i_sq*| <= sqrt(I_max^2 -
  i_sd*^2)``); anti-windup by clamping (the integrator holds while the output is
  limited and the error pushes further into the limit).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

from satmotor.errors import ParameterError, require_number
from satmotor.machine.params import MotorParams, RatedData

_TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class IFOCGains:
    """Design parameters of the IFOC loops.

    Parameters
    ----------
    w_c : float
        Current-loop bandwidth [rad/s].
    w_speed : float
        Speed-loop crossover frequency [rad/s] (symmetric optimum).
    I_max : float
        Stator current vector limit [A] (peak, space-vector magnitude).
    V_dc : float
        DC-link voltage [V]; the voltage vector is limited to ``V_dc / sqrt(3)``.
    """

    w_c: float = 2000.0
    w_speed: float = 200.0
    I_max: float = 20.0
    V_dc: float = 540.0

    def __post_init__(self):
        for name in ("w_c", "w_speed", "I_max", "V_dc"):
            require_number(name, getattr(self, name), 0)


class IFOCDiagnostics(NamedTuple):
    """Internal signals of one controller sample (SI units)."""

    i_sd: float  # [A] measured currents in the flux frame
    i_sq: float  # [A]
    i_sd_ref: float  # [A]
    i_sq_ref: float  # [A]
    T_ref: float  # [N m] speed-loop torque command (after the current limit)
    omega_slip: float  # [rad/s] electrical slip frequency
    theta_f: float  # [rad] flux-frame angle used in this sample
    phi_hat: float  # [Wb] model rotor flux magnitude
    v_sd: float  # [V] applied (limited) voltages in the flux frame
    v_sq: float  # [V]
    voltage_limited: bool
    current_limited: bool


class IFOCController:
    """Indirect field-oriented PI speed controller, sampled with period ``Ts`` (ZOH).

    Parameters
    ----------
    params : satmotor.machine.params.MotorParams
        Motor data of the controller's model.
    gains : IFOCGains
    Ts : float
        Sample period [s]; each call advances the internal state by ``Ts``.
    L_m : float or None
        Constant magnetizing inductance [H] of the model; ``None`` gives
        ``params.curve.m(RatedData().I_mu_n)``.

    Call ``ctrl(i_s_alpha, i_s_beta, omega_m, omega_ref_shaped, psi_ref_shaped)`` with measured
    currents [A], speed [rad/s], the drive's shaped speed reference [rad/s] and rotor-flux
    reference [Wb] (> 0); returns ``(v_s_alpha, v_s_beta, IFOCDiagnostics)`` to hold over the
    next period.
    """

    __slots__ = ("params", "gains", "Ts", "L_m", "sigL", "R_eq", "tau_r", "L_ra",
                 "Kp_i", "Ki_i", "Kp_w", "Ki_w", "T_sigma", "a_so", "V_max",
                 "_inv_kLm", "_kLm", "_kT", "_c_fd", "_c_fq", "_np", "_I_max", "_I_max2",
                 "_kiT_i", "_kiT_w", "_k_aw", "_phi_gain", "_half_Ts", "_V_max2",
                 "_x_w", "_x_d", "_x_q", "_theta", "_phi")

    def __init__(self, params, gains=None, Ts=1e-4, L_m=None):
        if not isinstance(params, MotorParams):
            raise ParameterError("params", params, "must be a satmotor.machine.params.MotorParams")
        gains = IFOCGains() if gains is None else gains
        if not isinstance(gains, IFOCGains):
            raise ParameterError("gains", gains, "must be an IFOCGains")
        self.params, self.gains = params, gains
        self.Ts = Ts = require_number("Ts", Ts, 0)
        if L_m is None:
            L_m = params.curve.m(RatedData().I_mu_n)
        L_m = require_number("L_m", L_m, 0)
        if gains.w_c * Ts > 1.0:
            raise ParameterError("w_c", gains.w_c, f"w_c Ts must be <= 1 (Ts = {Ts!r} s)")
        self.T_sigma = 1.0 / gains.w_c + Ts
        self.a_so = 1.0 / (gains.w_speed * self.T_sigma)
        if self.a_so < 2.0:
            raise ParameterError(
                "w_speed", gains.w_speed,
                f"symmetric optimum needs w_speed <= 1/(2 T_sigma) = {0.5 / self.T_sigma:.6g} rad/s",
            )
        self.Kp_w = params.J * gains.w_speed
        self.Ki_w = self.Kp_w / (self.a_so * self.a_so * self.T_sigma)
        self.V_max = gains.V_dc / math.sqrt(3.0)
        self._V_max2 = self.V_max * self.V_max
        self._np = params.n_p
        self._I_max = gains.I_max
        self._I_max2 = gains.I_max * gains.I_max
        self._kiT_w = self.Ki_w * Ts
        self._k_aw = min(1.0, gains.w_c * Ts)
        self._half_Ts = 0.5 * Ts
        self.set_inductance(L_m)
        self.reset()

    def set_inductance(self, L_m):
        """Take the constant magnetizing inductance ``L_m`` [H] (> 0): every model constant and current-loop
        gain that depends on it is derived again (the tuning rule of the module docstring); the loops'
        states are left as they are.  The drive (:class:`satmotor.control.drive.IFOCDrive`) calls it
        at the switch to the loops with the secant inductance of the nominal flux set-point."""
        self.L_m = L_m = require_number("L_m", L_m, 0)
        params, gains, Ts = self.params, self.gains, self.Ts
        k = params.k
        self.L_ra = L_ra = params.l_r + k * k * L_m
        kLm = k * L_m
        self.sigL = params.l_s + L_m - kLm * kLm / L_ra
        self.R_eq = params.R_s + params.R_r * (kLm / L_ra) ** 2
        self.tau_r = L_ra / params.R_r
        self.Kp_i = self.sigL * gains.w_c
        self.Ki_i = self.R_eq * gains.w_c
        self._kLm = kLm
        self._inv_kLm = 1.0 / kLm
        self._kT = 1.5 * params.n_p * kLm / L_ra  # T_e = _kT Phi i_sq
        self._c_fd = kLm * params.R_r / (L_ra * L_ra)
        self._c_fq = params.n_p * kLm / L_ra
        self._kiT_i = self.Ki_i * Ts
        self._phi_gain = -math.expm1(-Ts / self.tau_r)

    def set_link_voltage(self, V_dc):
        """The voltage bound ``V_dc / sqrt(3)`` from a measured DC-link voltage [V] > 0 (as __init__)."""
        self.V_max = V_dc / math.sqrt(3.0)
        self._V_max2 = self.V_max * self.V_max

    def reset(self, theta_f=0.0, phi_r=0.0):
        """Zero the speed integrator and q integrator; start the flux model at ``phi_r`` [Wb]
        and the frame at ``theta_f`` [rad] (the rotor-flux angle of the plant).

        The d integrator starts at its steady value for a magnetized machine at rest,
        ``R_eq phi_r / (k L_m)`` (zero for ``phi_r = 0``).
        """
        theta_f = require_number("theta_f", theta_f)
        phi_r = require_number("phi_r", phi_r, 0, inclusive=True)
        self._x_w = 0.0
        self._x_d = self.R_eq * phi_r * self._inv_kLm
        self._x_q = 0.0
        self._theta = math.remainder(theta_f, _TWO_PI)
        self._phi = phi_r

    def get_state(self):
        """``(x_speed [N m], x_d [V], x_q [V], theta_f [rad], phi_hat [Wb])``: every internal state."""
        return self._x_w, self._x_d, self._x_q, self._theta, self._phi

    def set_state(self, state):
        """Restore a state returned by :meth:`get_state`."""
        try:
            vals = tuple(float(v) for v in state)
        except (TypeError, ValueError) as exc:
            raise ParameterError("state", state, "must be a sequence of 5 numbers") from exc
        if len(vals) != 5 or not all(math.isfinite(v) for v in vals):
            raise ParameterError("state", state, "must be 5 finite numbers (see get_state)")
        self._x_w, self._x_d, self._x_q, self._theta, self._phi = vals

    def __call__(self, i_s_alpha, i_s_beta, omega_m, omega_ref_shaped, psi_ref_shaped):
        if not 0.0 < psi_ref_shaped < math.inf:  # per-sample fast path; require_number raises
            require_number("psi_ref_shaped", psi_ref_shaped, 0)
        # --- speed loop -> current references (current limit, clamping anti-windup)
        i_d_ref = psi_ref_shaped * self._inv_kLm
        if i_d_ref > self._I_max:
            i_d_ref = self._I_max
        kT = self._kT * psi_ref_shaped
        T_lim = kT * math.sqrt(self._I_max2 - i_d_ref * i_d_ref)
        e_w = omega_ref_shaped - omega_m
        x_w = self._x_w
        T_u = self.Kp_w * e_w + x_w
        current_limited = False
        if T_u > T_lim:
            T_ref, current_limited = T_lim, True
            if e_w < 0.0:
                x_w += self._kiT_w * e_w
        elif T_u < -T_lim:
            T_ref, current_limited = -T_lim, True
            if e_w > 0.0:
                x_w += self._kiT_w * e_w
        else:
            T_ref = T_u
            x_w += self._kiT_w * e_w
        if x_w > T_lim:
            x_w = T_lim
        elif x_w < -T_lim:
            x_w = -T_lim
        i_q_ref = T_ref / kT
        w_slip = i_q_ref / (self.tau_r * i_d_ref)
        w_f = self._np * omega_m + w_slip
        # --- current loops in the flux frame
        th = self._theta
        c, s = math.cos(th), math.sin(th)
        i_d = c * i_s_alpha + s * i_s_beta
        i_q = c * i_s_beta - s * i_s_alpha
        e_d = i_d_ref - i_d
        e_q = i_q_ref - i_q
        phi = self._phi
        wsig = w_f * self.sigL
        Kp = self.Kp_i
        v_du = Kp * e_d + self._x_d - wsig * i_q - self._c_fd * phi
        v_qu = Kp * e_q + self._x_q + wsig * i_d + self._c_fq * omega_m * phi
        mag2 = v_du * v_du + v_qu * v_qu
        if mag2 > self._V_max2:
            g = self.V_max / math.sqrt(mag2)
            v_d, v_q, voltage_limited = v_du * g, v_qu * g, True
        else:
            v_d, v_q, voltage_limited = v_du, v_qu, False
        # --- state update (one sample)
        k_aw = self._k_aw
        self._x_d += self._kiT_i * e_d + k_aw * (v_d - v_du)
        self._x_q += self._kiT_i * e_q + k_aw * (v_q - v_qu)
        self._x_w = x_w
        self._phi = phi + self._phi_gain * (self._kLm * i_d - phi)
        th_next = th + self.Ts * w_f
        if th_next > math.pi or th_next < -math.pi:
            th_next = math.remainder(th_next, _TWO_PI)
        self._theta = th_next
        # --- back to alpha-beta at the mean angle of the hold interval
        tho = th + self._half_Ts * w_f
        co, so = math.cos(tho), math.sin(tho)
        v_a = co * v_d - so * v_q
        v_b = so * v_d + co * v_q
        return v_a, v_b, IFOCDiagnostics(i_d, i_q, i_d_ref, i_q_ref, T_ref, w_slip, th, phi, v_d, v_q,
                                         voltage_limited, current_limited)
