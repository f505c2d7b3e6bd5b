"""Backstepping speed and rotor-flux controller for the saturated motor (seed section 4, corrected).

Control model: :mod:`satmotor.control.fo_model`, ``x = [Phi_rd, i_mu_d, i_mu_q, omega_m]``,
``x' = F(x) + G(x) v``; the law takes F, ``L^-1`` (G's nonzero rows) and omega_s from
:func:`satmotor.control.fo_model.vector_fields` and the parameter groups below from
:func:`satmotor.control.fo_model.model_constants` (nothing of the model is derived here).
Notation: ``a = R_r/l_r``, ``K = kappa k / (J l_r)``, ``kappa = 3/2 n_p``, ``b = B/J``,
``theta = T_L/J`` (or its estimate ``theta_hat``)::

    e1 = Phi_rd - psi_ref_shaped,   alpha1 = -c1 e1 + a Phi_rd + psi_ref_shaped',   e2 = a k m i_mu_d - alpha1
    z1 = omega_m - omega_ref_shaped, gamma1 = -d1 z1 + theta + b omega_m + omega_ref_shaped',
    z2 = K m Phi_rd i_mu_q - gamma1
    =>  e1' = -c1 e1 + e2,    z1' = -d1 z1 + z2 (+ theta_hat - theta in the estimated mode)

Gradients (``M = [[M_d, M_dq], [M_dq, M_q]] = d(m i_mu)/d i_mu``)::

    de2/dx = (c1 - a,   a k M_d,        a k M_dq,       0     )
    dz2/dx = (K m i_mu_q, K Phi_rd M_dq, K Phi_rd M_q,  d1 - b)
    de2/dt = -c1 psi_ref_shaped' - psi_ref_shaped''
    dz2/dt = -d1 omega_ref_shaped' - omega_ref_shaped'' - theta'

with ``theta' = (dT_L/dt)/J`` (known load) or ``theta_hat'`` of the update law (estimated).
``beta = (de/dx) F + de/dt`` and ``Lambda = (de/dx) G = diag(a k, K Phi_rd) M L^-1``, i.e.::

    beta1 = (c1 - a) Phi_rd' + a k (M_d F_d + M_dq F_q) - c1 psi_ref_shaped' - psi_ref_shaped''
    beta2 = K m i_mu_q Phi_rd' + K Phi_rd (M_dq F_d + M_q F_q) + (d1 - b) F_w
            - d1 omega_ref_shaped' - omega_ref_shaped'' - theta'
    W = det Lambda = a k K Phi_rd m L_dyn / det L

(F_d, F_q, F_w the drift of i_mu_d, i_mu_q, omega_m; F_w uses theta or theta_hat.)  The law
(seed eq 67) ``v = Lambda^-1 (-c2 e2 - e1 - beta1, -d2 z2 - z1 - beta2)`` gives
``V' = -c1 e1^2 - c2 e2^2 - d1 z1^2 - d2 z2^2`` for ``V = (e1^2 + e2^2 + z1^2 + z2^2)/2``.

Estimated load: with theta constant and ``theta_t = theta_hat - theta``, the estimated-mode
closed loop has ``z1' = -d1 z1 + z2 + theta_t`` and ``z2' = -d2 z2 - z1 + (d1 - b) theta_t``, so
``V' = -c1 e1^2 - ... - d2 z2^2 + theta_t (z1 + (d1 - b) z2)``.  The update
``theta_hat' = -g_theta (z1 + (d1 - b) z2)`` cancels the cross term:
``d/dt [V + theta_t^2 / (2 g_theta)] = -c1 e1^2 - c2 e2^2 - d1 z1^2 - d2 z2^2``.  Projection onto
``|theta_hat| <= theta_max`` (update zeroed at a bound when pushing outward) only adds
``theta_t (theta_hat'_proj - theta_hat'_nom) / g_theta <= 0`` when ``|theta| <= theta_max``.

Integral action (gains c0, d0 >= 0; 0 gives the seed's law): the states ``e0 = int e1 dt``,
``z0 = int z1 dt`` enter the virtual controls, ``alpha1 = -c1 e1 - c0 e0 + a Phi_rd + psi_ref_shaped'`` and
``gamma1 = -d1 z1 - d0 z0 + theta + b omega_m + omega_ref_shaped'``.  Since ``e0' = e1`` is known, it adds
``c0 e1`` to de2/dt and ``d0 z1`` to dz2/dt; then ``e1' = -c1 e1 - c0 e0 + e2`` and, with
``V = (e1^2 + e2^2 + z1^2 + z2^2 + c0 e0^2 + d0 z0^2)/2``, V' is as above.  A constant model error
(plant parameters differ from the controller's) is then absorbed by e0, z0 at e1 = z1 = 0.

Current limit (``i_max``): the virtual controls demand ``i_mu_d* = alpha1 / (a k m)`` and
``i_mu_q* = gamma1 / (K m Phi_rd)``, i.e. the stator currents (flux frame, ``psi_rq = 0``)
``i_sd* = (1 + k^2 m/l_r) i_mu_d* - (k/l_r) Phi_rd`` and ``i_sq* = (1 + k^2 m/l_r) i_mu_q*``.  alpha1 is
bounded so that ``|i_sd*| <= D_SHARE i_max`` (flux first), then gamma1 so that
``|i_sq*| <= sqrt(i_max^2 - i_sd*^2)`` (m held at its present value).  A bounded virtual control is
treated as constant: its gradient and time derivative drop out of beta and the Lyapunov cross term
(e1 in the flux row, z1 in the speed row) is not added; the adaptation and the integral states stop
where they would push the virtual control further into its bound, and move where they pull it out
(anti-windup without a lock-up).  Away from the bound the law is unchanged.

Voltage limit: while the voltage vector is scaled to V_dc/sqrt(3), the law's Lyapunov decrease does
not hold (the applied v is not the law's), and the tracking errors it leaves are not a load or a
model error: the integral states and the load estimate are frozen (``e0_dot = z0_dot =
theta_hat_dot = 0``).  Without the freeze of theta_hat, a regenerative stop from the voltage limit
(``scenarios/regenerative_stop_limits.yaml`` with the freeze off) winds the estimate to its bound
(655 N m for a 26.7 N m load), keeps motoring for 82 ms and undershoots to -25.7 rad/s.

Singularity: W = 0 only where Phi_rd = 0.  Below ``phi_min`` the controller uses
``max(Phi_rd, phi_min)`` in Lambda's second row and in omega_s (never a division by ~0), and a
W that is tiny relative to its terms is floored; both set ``singular_limited``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

from satmotor.control.fo_model import model_constants, vector_fields
from satmotor.control.measurements import (
    MEAS_I_MU_A,
    MEAS_I_MU_B,
    MEAS_I_S_A,
    MEAS_I_S_B,
    MEAS_OMEGA_M,
    MEAS_PSI_R_A,
    MEAS_PSI_R_B,
    MEAS_PSI_S_A,
    MEAS_PSI_S_B,
    from_magnetizing_current,
    from_rotor_flux,
    from_stator_flux,
)
from satmotor.control.modulation import MODULATIONS, limit_voltage
from satmotor.errors import ParameterError, require_choice, require_number

_SQRT3 = math.sqrt(3.0)
_W_REL_FLOOR = 1e-12
D_SHARE = 0.9  # share of I_max the flux (d) current may take; the torque (q) current gets the rest
LOAD_MODES = ("known", "estimated")



@dataclass(frozen=True)
class BacksteppingGains:
    """Backstepping gains [1/s] for the default motor.

    c1 = 200 is close to the natural flux rate R_r/l_r = 239 1/s of this (i_mu-state) model, so
    the flux loop asks little more than the rotor circuit gives; d1 = 100 makes a 10 rad/s speed
    error demand about 1000 rad/s^2, i.e. J * 1000 = 13 N m, half the rated torque.  c2 = 1000
    and d2 = 500 put the inner (current) loops 5x above the outer ones and keep c2 Ts = 0.1 at a
    10 kHz sample rate; faster inner loops mostly buy voltage saturation.
    """

    c1: float = 200.0
    c2: float = 1000.0
    d1: float = 100.0
    d2: float = 500.0
    c0: float = 0.0
    d0: float = 0.0

    def __post_init__(self):
        for name in ("c1", "c2", "d1", "d2"):
            require_number(name, getattr(self, name), 0)
        for name in ("c0", "d0"):
            require_number(name, getattr(self, name), 0, inclusive=True)


@dataclass(frozen=True)
class ControllerConfig:
    """Controller settings.

    V_dc [V] (voltage vector limited to V_dc/sqrt(3), or with modulation 'overmodulation' to the
    inverter's hexagon, up to 2 V_dc/3: :mod:`satmotor.control.modulation`); Ts [s] sample period
    of the zero-order hold (0: continuous, no mid-sample compensation); phi_min [Wb] flux floor of the
    singularity guard; load_mode 'known' (uses T_L, dT_L/dt) or 'estimated' (adaptive theta_hat);
    g_theta [1/s^2] adaptation gain; theta_max [rad/s^2] bound on theta_hat = T_L/J;
    use_stator_flux: magnetizing state from psi_s as well (seed H1) instead of the curve;
    true_i_mu: the plant's true i_mu, appended to the measurements by the plain-Python loop (the
    design comparison only: no drive measures it, the FMU does not offer it).

    g_theta = 5 1/s^2: with the default gains the linear (z1, z2, theta_t) error system then has
    real eigenvalues (about -100, -137, -363 1/s); larger g_theta only adds an oscillation
    (g_theta = 100: -250 +- 970j) and more noise from z2 into theta_hat.  theta_max = 1e4 rad/s^2
    is about 130 N m with the default inertia (5x rated torque).
    """

    V_dc: float = 540.0
    Ts: float = 1e-4
    phi_min: float = 0.05
    load_mode: str = "known"
    g_theta: float = 5.0
    theta_max: float = 1.0e4
    use_stator_flux: bool = False
    true_i_mu: bool = False
    modulation: str = "linear"

    def __post_init__(self):
        require_number("V_dc", self.V_dc, 0)
        require_number("Ts", self.Ts, 0, inclusive=True)
        require_number("phi_min", self.phi_min, 0)
        require_choice("load_mode", self.load_mode, LOAD_MODES)
        require_choice("modulation", self.modulation, MODULATIONS)
        require_number("g_theta", self.g_theta, 0)
        require_number("theta_max", self.theta_max, 0)
        for name in ("use_stator_flux", "true_i_mu"):
            if not isinstance(getattr(self, name), bool):
                raise ParameterError(name, getattr(self, name), "must be a bool")


class ErrorSystem(NamedTuple):
    """Backstepping error system at one state (see the module docstring)."""

    e1: float
    e2: float
    z1: float
    z2: float
    grad_e2: tuple  # de2/dx
    grad_z2: tuple  # dz2/dx
    dt_e2: float  # explicit de2/dt
    dt_z2: float  # explicit dz2/dt
    beta1: float
    beta2: float
    Lambda: tuple  # ((l1, l2), (l3, l4)) as used (Phi_rd floored at phi_min)
    W: float  # det Lambda with the true Phi_rd (0 at Phi_rd = 0; Lambda itself is floored)
    omega_s: float  # [rad/s]
    theta_dot: float  # theta' used in dz2/dt
    singular_limited: bool
    flux_limited: int  # alpha1 bounded by the current limit (its i_sd): +1 from above, -1 from below, 0
    torque_limited: int  # gamma1 bounded by the current limit (its i_sq): +1, -1 or 0


class ControlOutput(NamedTuple):
    """Result of one :func:`control` call (SI units)."""

    v_s_alpha: float
    v_s_beta: float
    v_sd: float
    v_sq: float
    e1: float
    e2: float
    z1: float
    z2: float
    V: float
    W: float
    m: float
    i_mu: float
    Phi_rd: float
    rho: float
    omega_s: float
    theta_hat_dot: float
    voltage_limited: bool
    singular_limited: bool
    e0_dot: float  # [Wb] derivative of the flux integral state (0 while a limit holds it)
    z0_dot: float  # [rad/s] derivative of the speed integral state (0 while a limit holds it)
    current_limited: bool


def _clip(x, lo, hi):
    return lo if x < lo else hi if x > hi else x


def _core(p, g, phi_min, phi, imd, imq, w, m, dm, I, ref, theta, theta_dot, adapt, e0=0.0, z0=0.0,
          i_max=math.inf):
    """Error system at ``x = (phi, imd, imq, w)`` with the static m and dm/dI at I = |i_mu|.

    ``adapt`` is None (theta' = theta_dot given) or ``(g_theta, theta_max)`` (theta = theta_hat,
    theta' from the projected update law).  ``e0``, ``z0`` the integral states (used with the gains
    c0, d0); ``i_max`` [A] the stator current bound on the virtual controls (module docstring).
    Returns the fields of an :class:`ErrorSystem` as a plain tuple (the per-sample path unpacks it).
    """
    # the drive's shaped references and their first two time derivatives
    (psi_ref_shaped, psi_ref_shaped_dot, psi_ref_shaped_ddot,
     omega_ref_shaped, omega_ref_shaped_dot, omega_ref_shaped_ddot) = ref
    c1, d1, c0, d0 = g.c1, g.d1, g.c0, g.d0
    c = model_constants(p)
    a, ak, K, b = c.a, c.ak, c.K, c.b
    limited = phi < phi_min
    phe = phi_min if limited else phi
    # drift F and L^-1 of the control model (Phi_rd floored in omega_s)
    (dphi, Fd, Fq, Fw, a11, a12, a22, ws, Md, Mq, Mdq, _, _, _, _, te_J,
     _) = vector_fields(c, phi, imd, imq, w, m, dm, I, theta, phe)
    e1 = phi - psi_ref_shaped
    z1 = w - omega_ref_shaped
    # virtual controls: alpha1 for a k m i_mu_d, gamma1 for T_e/J
    alpha1 = -c1 * e1 - c0 * e0 + a * phi + psi_ref_shaped_dot
    gamma1 = -d1 * z1 - d0 * z0 + theta + b * w + omega_ref_shaped_dot
    d_lim = q_lim = 0  # +1 / -1: the virtual control was bounded from above / below
    if i_max < math.inf:  # the currents they demand, bounded (quasi-static: m held at its value)
        cc = 1.0 + c.k2_lr * m
        ak_m = ak * m
        i_sd = cc * alpha1 / ak_m - c.k_lr * phi
        i_sd_c = _clip(i_sd, -D_SHARE * i_max, D_SHARE * i_max)
        if i_sd_c != i_sd:
            d_lim = 1 if i_sd > i_sd_c else -1
            alpha1 = ak_m * (i_sd_c + c.k_lr * phi) / cc
        g_max = K * m * phi * math.sqrt(i_max * i_max - i_sd_c * i_sd_c) / cc
        if not -g_max <= gamma1 <= g_max:
            q_lim = 1 if gamma1 > g_max else -1
            gamma1 = _clip(gamma1, -g_max, g_max)
    e2 = ak * m * imd - alpha1
    z2 = te_J - gamma1
    if adapt is not None:
        g_theta, theta_max = adapt
        theta_dot = -g_theta * (z1 + (d1 - b) * z2)
        if q_lim * theta_dot > 0.0:  # anti-windup: not further into the bound (theta adds to gamma1)
            theta_dot = 0.0
        if (theta >= theta_max and theta_dot > 0.0) or (theta <= -theta_max and theta_dot < 0.0):
            theta_dot = 0.0
    # gradients and explicit time derivatives; a bounded virtual control is held constant
    if d_lim:
        ge2, dt_e2 = (0.0, ak * Md, ak * Mdq, 0.0), 0.0
    else:
        ge2 = (c1 - a, ak * Md, ak * Mdq, 0.0)
        dt_e2 = -c1 * psi_ref_shaped_dot - psi_ref_shaped_ddot + c0 * e1
    if q_lim:
        gz2, dt_z2 = (K * m * imq, K * phi * Mdq, K * phi * Mq, 0.0), 0.0
    else:
        gz2 = (K * m * imq, K * phi * Mdq, K * phi * Mq, d1 - b)
        dt_z2 = -d1 * omega_ref_shaped_dot - omega_ref_shaped_ddot - theta_dot + d0 * z1
    beta1 = ge2[0] * dphi + ge2[1] * Fd + ge2[2] * Fq + dt_e2
    beta2 = gz2[0] * dphi + gz2[1] * Fd + gz2[2] * Fq + gz2[3] * Fw + dt_z2
    # Lambda = diag(a k, K Phi_rd) M L^-1
    Kp = K * phe
    L11 = ak * (Md * a11 + Mdq * a12)
    L12 = ak * (Md * a12 + Mdq * a22)
    L21 = Kp * (Mdq * a11 + Mq * a12)
    L22 = Kp * (Mdq * a12 + Mq * a22)
    W = L11 * L22 - L12 * L21
    floor = _W_REL_FLOOR * (abs(L11 * L22) + abs(L12 * L21))
    if not abs(W) > floor:
        limited = True
    return (e1, e2, z1, z2, ge2, gz2, dt_e2, dt_z2, beta1, beta2, ((L11, L12), (L21, L22)),
            W * (phi / phe), ws, theta_dot, limited, d_lim, q_lim)


def error_system(x, ref, params, gains, theta=0.0, theta_dot=0.0, phi_min=0.05, adapt=None, integ=(0.0, 0.0),
                 i_max=math.inf):
    """Error system at the flux-oriented state ``x = (Phi_rd, i_mu_d, i_mu_q, omega_m)``.

    ``ref = (psi_ref_shaped, psi_ref_shaped', psi_ref_shaped'', omega_ref_shaped, omega_ref_shaped',
    omega_ref_shaped'')`` (the drive's shaped references); theta [rad/s^2] the (estimated) T_L/J and
    theta_dot its derivative; ``adapt = (g_theta, theta_max)`` switches to the update law for theta'.
    m and dm/dI come from ``params.curve`` at ``|i_mu|``.
    """
    phi, imd, imq, w = (float(v) for v in x)
    I = math.hypot(imd, imq)
    _, m, dm, _ = params.curve.evaluate(I)
    return ErrorSystem(*_core(params, gains, phi_min, phi, imd, imq, w, m, dm, I, ref, theta, theta_dot,
                              adapt, integ[0], integ[1], i_max))


def control(meas, ref, load, params, gains, cfg, theta_hat=0.0, integ=(0.0, 0.0), i_max=math.inf):
    """One backstepping control step (pure function).

    Parameters
    ----------
    meas : tuple
        The measurement tuple of :mod:`satmotor.control.measurements`, ``(i_s_alpha, i_s_beta,
        psi_r_alpha, psi_r_beta, psi_s_alpha, psi_s_beta, omega_m)`` [A, A, Wb, Wb, Wb, Wb, rad/s]
        (the controller unit's input order); psi_s is read only with ``cfg.use_stator_flux``.
    ref : tuple
        ``(psi_ref_shaped, psi_ref_shaped', psi_ref_shaped'', omega_ref_shaped, omega_ref_shaped',
        omega_ref_shaped'')`` [Wb, Wb/s, Wb/s^2, rad/s, rad/s^2, rad/s^3] (mechanical speed): the
        drive's shaped references.
    load : tuple
        ``(T_L, dT_L/dt)`` [N m, N m/s]; used in the 'known' load mode only.
    params : MotorParams
        The controller's model (its curve need not be the plant's).  With ``use_stator_flux``
        the measured m = |psi_s - l_s i_s| / |i_mu| is used and only dm/dI comes from the curve.
    gains : BacksteppingGains
    cfg : ControllerConfig
    theta_hat : float
        Estimated T_L/J [rad/s^2] ('estimated' mode); clipped to ``+-cfg.theta_max``.  The caller
        integrates ``theta_hat_dot`` over the sample period (and clips to the bound).
    integ : tuple
        The integral states ``(e0, z0)`` [Wb s, rad] (gains c0, d0); the caller integrates
        ``e0_dot``, ``z0_dot`` (zero while a current or voltage limit holds them: anti-windup).
    i_max : float
        [A] bound on the stator current the virtual controls demand (inf: no bound).

    Returns
    -------
    ControlOutput
        Voltages (v_s rotated by ``rho + omega_s Ts / 2``), errors, V, W, the magnetizing state,
        theta_hat_dot (0 in the known mode) and the limiter flags.
    """
    if cfg.true_i_mu:
        ms = from_magnetizing_current(meas[MEAS_I_MU_A], meas[MEAS_I_MU_B], meas[MEAS_PSI_R_A],
                                      meas[MEAS_PSI_R_B], params)
    elif cfg.use_stator_flux:
        ms = from_stator_flux(meas[MEAS_I_S_A], meas[MEAS_I_S_B], meas[MEAS_PSI_R_A], meas[MEAS_PSI_R_B],
                              meas[MEAS_PSI_S_A], meas[MEAS_PSI_S_B], params)
    else:
        ms = from_rotor_flux(meas[MEAS_I_S_A], meas[MEAS_I_S_B], meas[MEAS_PSI_R_A], meas[MEAS_PSI_R_B],
                             params)
    w = meas[MEAS_OMEGA_M]
    I = ms.I
    dm = params.curve.dm_dI(I)
    if cfg.load_mode == "known":
        T_L, dT_L = load
        theta, theta_dot, adapt = T_L / params.J, dT_L / params.J, None
    else:
        tm = cfg.theta_max
        theta, theta_dot, adapt = min(max(theta_hat, -tm), tm), 0.0, (cfg.g_theta, tm)
    (e1, e2, z1, z2, _, _, _, _, beta1, beta2, ((L11, L12), (L21, L22)), W_true, ws, theta_dot,
     singular, d_lim, q_lim) = _core(params, gains, cfg.phi_min, ms.Phi_rd, ms.i_mu_d, ms.i_mu_q, w, ms.m,
                                     dm, I, ref, theta, theta_dot, adapt, integ[0], integ[1], i_max)
    W = L11 * L22 - L12 * L21
    if singular:
        floor = max(_W_REL_FLOOR * (abs(L11 * L22) + abs(L12 * L21)), 1e-300)
        if not abs(W) > floor:
            W = math.copysign(floor, W) if W == W else floor
    q1 = -gains.c2 * e2 - beta1 - (0.0 if d_lim else e1)
    q2 = -gains.d2 * z2 - beta2 - (0.0 if q_lim else z1)
    vd = (L22 * q1 - L12 * q2) / W
    vq = (L11 * q2 - L21 * q1) / W
    rho_out = ms.rho + 0.5 * ws * cfg.Ts
    c, s = math.cos(rho_out), math.sin(rho_out)
    vd, vq, vlim = limit_voltage(vd, vq, c, s, cfg.V_dc, cfg.modulation == "overmodulation")
    e0, z0 = integ
    V = 0.5 * (e1 * e1 + e2 * e2 + z1 * z1 + z2 * z2 + gains.c0 * e0 * e0 + gains.d0 * z0 * z0)
    # anti-windup: an integral state stops while the voltage is limited, or while its virtual control
    # is bounded and integrating would push it further (e0, z0 enter alpha1, gamma1 with a minus sign)
    theta_hat_dot = 0.0 if (adapt is None or vlim) else theta_dot  # anti-windup: frozen at the voltage limit
    e0_dot = 0.0 if (vlim or d_lim * e1 < 0.0) else e1
    z0_dot = 0.0 if (vlim or q_lim * z1 < 0.0) else z1
    return ControlOutput(c * vd - s * vq, s * vd + c * vq, vd, vq, e1, e2, z1, z2, V, W_true, ms.m, I,
                         ms.Phi_rd, ms.rho, ws, theta_hat_dot, vlim, singular, e0_dot, z0_dot,
                         bool(d_lim or q_lim))


__all__ = ["BacksteppingGains", "ControllerConfig", "ControlOutput", "ErrorSystem", "control",
           "error_system", "LOAD_MODES"]
