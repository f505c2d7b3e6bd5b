"""The saturated induction motor in the stationary alpha-beta frame, flux states.

Conventions
-----------
* Amplitude-invariant Clarke transform: a balanced set of phase quantities of
  amplitude A gives a space vector of magnitude A; powers carry the factor 3/2.
* State ``x = [psi_s_alpha, psi_s_beta, psi_r_alpha, psi_r_beta, omega_m, theta_m]``
  (fluxes [Wb], mechanical speed [rad/s], mechanical angle [rad]); indices are the
  constants ``PSI_S_A`` ... ``THETA_M``.
* Inputs: stator voltages ``v_s_alpha``, ``v_s_beta`` [V], load torque ``T_load`` [N m].
* Plant-only parameter ``B_2`` [N m s2/rad2] (>= 0, default 0): a quadratic (fan/pump) load
  torque ``B_2 omega_m |omega_m|`` opposing motion.  It is an argument of :class:`Plant`, not a
  field of :class:`~satmotor.machine.params.MotorParams`, because MotorParams is also the controller's
  model: the controller does not know the fan load and sees it as part of an unknown load.
* Plant-only too: the core-loss resistance ``R_fe`` and the two-body thermal model (two more states
  ``T_s``, ``T_r`` when on), :mod:`satmotor.machine.thermal`; both off by default, then the equations
  below exactly (the fast paths of :meth:`Plant.derivatives`).  And the friction, windage and stray
  torques of :mod:`satmotor.machine.losses` (``losses``; zero by default: none subtracted below).

Equations (seed eqs 1, 4, 10-13 with the factor k of the errata)::

    psi_s = l_s i_s + m(I) i_mu,  psi_r = l_r i_r + k m(I) i_mu,  i_mu = i_s + k i_r
    d psi_s/dt = v_s - R_s i_s
    d psi_r/dt = -R_r i_r + n_p omega_m J2 psi_r          (J2 = rotation by +90 deg)
    J d omega_m/dt = T_e - T_load - B omega_m - B_2 omega_m |omega_m| [- T_fw - T_stray]
    d theta_m/dt = omega_m
    T_e = 3/2 n_p (psi_s_alpha i_s_beta - psi_s_beta i_s_alpha)

Currents from fluxes: eliminating i_s and i_r gives
``(l_e + m(I)) i_mu = l_e (psi_s/l_s + k psi_r/l_r)`` with ``1/l_e = 1/l_s + k^2/l_r``,
so i_mu is collinear with ``u = psi_s/l_s + k psi_r/l_r`` and its magnitude is the
scalar root of ``l_e I + psi_m(I) = l_e |u|`` (unique: the left side increases).

The Gamma-equivalent model is the case ``l_s = 0`` (exact, not a limit; all the stator-side
leakage is in l_r).  Then ``psi_s = m(I) i_mu`` is the main flux itself, so i_mu is collinear with
psi_s and ``I = |i_mu|`` solves ``psi_m(I) = |psi_s|`` (the inverse curve, ``curve.solve(0, |psi_s|)``);
then ``i_r = (psi_r - k psi_s) / l_r`` and ``i_s = i_mu - k i_r``.  (Substituting: ``psi_r = l_r i_r +
k m i_mu`` is the seed's rotor equation; ``i_s + k i_r = i_mu`` its definition of i_mu.)
"""

from __future__ import annotations

import math
from typing import NamedTuple

from satmotor.errors import require_number
from satmotor.machine.integrate import rk4
from satmotor.machine.losses import LossParams, friction_torque, loss_torque
from satmotor.machine.thermal import ThermalParams, resistance

PSI_S_A, PSI_S_B, PSI_R_A, PSI_R_B, OMEGA_M, THETA_M = range(6)
N_STATES = 6
T_S, T_R = 6, 7  # the thermal states (only with the thermal model on)
N_THERMAL_STATES = 8
STATE_NAMES = ("psi_s_alpha", "psi_s_beta", "psi_r_alpha", "psi_r_beta", "omega_m", "theta_m")


class PlantOutputs(NamedTuple):
    """Algebraic outputs of the plant at one state (SI units)."""

    i_s_alpha: float  # [A]
    i_s_beta: float  # [A]
    i_r_alpha: float  # [A] (rotor side, not referred)
    i_r_beta: float  # [A]
    i_mu_alpha: float  # [A]
    i_mu_beta: float  # [A]
    i_mu: float  # [A] magnitude of the magnetizing current
    psi_m: float  # [Wb] main flux linkage magnitude
    m: float  # [H] static magnetizing inductance psi_m / i_mu
    T_e: float  # [N m] electromagnetic torque
    P_fe: float = 0.0  # [W] core loss 3/2 |e_s|^2 / R_fe (0 without R_fe)
    T_s: float = 0.0  # [K] stator temperature
    T_r: float = 0.0  # [K] rotor temperature


class Plant:
    """Stationary-frame saturated induction motor bound to one parameter set.

    Parameters
    ----------
    params : satmotor.machine.params.MotorParams
    B_2 : float
        Quadratic (fan/pump) load coefficient [N m s2/rad2], >= 0: load torque
        ``B_2 omega_m |omega_m|`` opposing motion (default 0: none).
    R_fe : float
        Core-loss resistance [Ohm], >= 0 (0: no core loss), across the stator emf
        (:mod:`satmotor.machine.thermal`).  Then the terminal current and P_fe depend on v_s:
        :meth:`outputs` takes the voltage.
    thermal : satmotor.machine.thermal.ThermalParams or None
        The two-body thermal model (None: the defaults, off).  On, the state has two more entries,
        ``T_s``, ``T_r`` [K] (:data:`N_THERMAL_STATES`); off, the resistances are R_s(T_s0), R_r(T_r0).
    losses : satmotor.machine.losses.LossParams or None
        Friction, windage and stray torques and the inverter's switching loss (None: none).
    """

    __slots__ = ("p", "B_2", "_curve", "_inv_ls", "_k_lr", "_le", "_k", "_ls", "_lr", "_Rs", "_Rr",
                 "_np", "_kappa", "_inv_J", "_B", "_B2", "_m0", "_gamma", "R_fe", "th", "_ext", "_th_on",
                 "lp", "_mech")

    def __init__(self, params, B_2=0.0, R_fe=0.0, thermal=None, losses=None):
        self.p = params
        self.lp = LossParams() if losses is None else losses
        self._mech = self.lp.mechanical  # a friction, windage or stray torque acts (_rates)
        self.B_2 = self._B2 = require_number("B_2", B_2, 0, inclusive=True)
        self.R_fe = require_number("R_fe", R_fe, 0, inclusive=True)
        self.th = th = ThermalParams() if thermal is None else thermal
        self._th_on = th.thermal
        self._ext = self.R_fe > 0.0 or self._th_on  # the general path (_derivatives_ext)
        self._curve = params.curve
        self._gamma = params.l_s == 0.0  # the Gamma-equivalent model (module docstring)
        self._inv_ls = 0.0 if self._gamma else 1.0 / params.l_s
        self._k_lr = params.k / params.l_r
        self._le = params.l_e
        self._k = params.k
        self._ls = params.l_s
        self._lr = params.l_r
        # thermal off: the resistances at T_s0, T_r0 (with T_s0 = T_ref exactly R_s: R_s * 1.0)
        self._Rs = resistance(params.R_s, th.alpha_s, th.T_s0, th.T_ref)
        self._Rr = resistance(params.R_r, th.alpha_r, th.T_r0, th.T_ref)
        self._np = params.n_p
        self._kappa = 1.5 * params.n_p
        self._inv_J = 1.0 / params.J
        self._B = params.B
        self._m0 = params.curve.m0

    def _magnetizing_gamma(self, psa, psb, warm=None):
        """:meth:`magnetizing` for l_s = 0: i_mu along psi_s, ``psi_m(I) = |psi_s|`` (``warm``: as in
        :meth:`derivatives`)."""
        pn = math.hypot(psa, psb)
        I, psi = self._curve.solve(0.0, pn, 0.0 if warm is None else warm[0])
        if warm is not None:
            warm[0] = I
        if I == 0.0:
            return 0.0, 0.0, 0.0, 0.0, self._m0
        s = I / pn
        return s * psa, s * psb, I, psi, psi / I

    def _currents_gamma(self, psa, psb, pra, prb, warm=None):
        """``(i_s_alpha, i_s_beta, i_r_alpha, i_r_beta, i_mu_alpha, i_mu_beta, I, psi_m, m)`` for l_s = 0."""
        ima, imb, I, psi, m = self._magnetizing_gamma(psa, psb, warm)
        k = self._k
        ira = (pra - k * psa) / self._lr
        irb = (prb - k * psb) / self._lr
        return ima - k * ira, imb - k * irb, ira, irb, ima, imb, I, psi, m

    def magnetizing(self, psa, psb, pra, prb, warm=None):
        """Return ``(i_mu_alpha, i_mu_beta, I, psi_m, m)`` from the four fluxes [Wb] (``warm``: as in
        :meth:`derivatives`)."""
        if self._gamma:
            return self._magnetizing_gamma(psa, psb, warm)
        ua = psa * self._inv_ls + self._k_lr * pra
        ub = psb * self._inv_ls + self._k_lr * prb
        un = math.hypot(ua, ub)
        le = self._le
        I, psi = self._curve.solve(le, le * un, 0.0 if warm is None else warm[0])
        if warm is not None:
            warm[0] = I
        if I == 0.0:
            return 0.0, 0.0, 0.0, 0.0, self._m0
        s = I / un
        return s * ua, s * ub, I, psi, psi / I

    def derivatives(self, t, x, v_a, v_b, T_load, warm=None):
        """Right-hand side ``dx/dt`` [SI per s] for constant inputs over the call (state order).

        ``warm``: None (the magnetizing-curve solve starts cold), or a one-element list: the solve
        starts from ``warm[0]`` [A] and leaves its root |i_mu| there (:meth:`step`'s stages)."""
        if self._ext:
            return self._derivatives_ext(x, v_a, v_b, T_load, warm)
        psa, psb, pra, prb, w = x[PSI_S_A], x[PSI_S_B], x[PSI_R_A], x[PSI_R_B], x[OMEGA_M]
        if self._gamma:  # l_s = 0: the currents of _currents_gamma
            isa, isb, ira, irb = self._currents_gamma(psa, psb, pra, prb, warm)[:4]
        else:  # self.currents written out (same operations): one call less per evaluation
            ua = psa * self._inv_ls + self._k_lr * pra
            ub = psb * self._inv_ls + self._k_lr * prb
            un = math.hypot(ua, ub)
            le = self._le
            I, psi = self._curve.solve(le, le * un, 0.0 if warm is None else warm[0])
            if warm is not None:
                warm[0] = I
            if I == 0.0:
                ima = imb = 0.0
                m = self._m0
            else:
                s = I / un
                ima, imb, m = s * ua, s * ub, psi / I
            isa = (psa - m * ima) * self._inv_ls
            isb = (psb - m * imb) * self._inv_ls
            km = self._k * m
            ira = (pra - km * ima) / self._lr
            irb = (prb - km * imb) / self._lr
        return self._rates(v_a - self._Rs * isa, v_b - self._Rs * isb, self._Rr, isa, isb, ira, irb, psa, psb,
                           pra, prb, w, T_load)

    def _rates(self, ea, eb, Rr, isa, isb, ira, irb, psa, psb, pra, prb, w, T_load):
        """The flux and mechanics equations, written once for every path: ``dx/dt`` of (psi_s, psi_r,
        omega_m, theta_m) from the stator's ``e = d psi_s / dt`` [V] (``v_s - R_s i_s`` without core
        loss), the rotor resistance ``Rr`` [Ohm], the currents [A] (the torque's stator current the one
        through the leakage), the fluxes [Wb], the speed [rad/s] and the load [N m]."""
        we = self._np * w
        te = self._kappa * (psa * isb - psb * isa)
        if self._mech:  # the friction, windage and stray torques (losses.loss_torque; off: not a float more)
            T_load = T_load + loss_torque(self.lp, w, isa * isa + isb * isb)
        return (
            ea,
            eb,
            -Rr * ira - we * prb,
            -Rr * irb + we * pra,
            # (B + B_2 |w|) w: with B_2 = 0 exactly B w (B + 0.0 = B), so the same floats as without
            (te - T_load - (self._B + self._B2 * abs(w)) * w) * self._inv_J,
            w,
        )

    def currents(self, psa, psb, pra, prb, warm=None):
        """``(i_s0_alpha, i_s0_beta, i_r_alpha, i_r_beta, i_mu_alpha, i_mu_beta, I, psi_m, m)`` from the
        fluxes [Wb]: i_s0 the stator current through the leakage (the terminal current without R_fe);
        ``warm``: as in :meth:`derivatives`."""
        if self._gamma:
            return self._currents_gamma(psa, psb, pra, prb, warm)
        ima, imb, I, psi, m = self.magnetizing(psa, psb, pra, prb, warm)
        km = self._k * m
        return ((psa - m * ima) * self._inv_ls, (psb - m * imb) * self._inv_ls, (pra - km * ima) / self._lr,
                (prb - km * imb) / self._lr, ima, imb, I, psi, m)

    def _resistances(self, x):
        """``(R_s, R_r)`` [Ohm] at the temperatures of ``x`` (thermal on), else the constant ones."""
        if self._th_on:
            th = self.th
            return (resistance(self.p.R_s, th.alpha_s, x[T_S], th.T_ref),
                    resistance(self.p.R_r, th.alpha_r, x[T_R], th.T_ref))
        return self._Rs, self._Rr

    def stator_resistance(self, x):
        """R_s [Ohm] at the stator temperature of ``x`` (thermal on), else the constant one."""
        return self._resistances(x)[0]

    def _ext_terms(self, x, v_a, v_b, warm=None):
        """The general path's quantities at ``x`` and the voltage: ``(currents, R_s, R_r, e_a, e_b,
        i_fe_a, i_fe_b)`` with e_s = d psi_s/dt [V] and i_fe the core-loss current [A]."""
        c = self.currents(x[PSI_S_A], x[PSI_S_B], x[PSI_R_A], x[PSI_R_B], warm)
        Rs, Rr = self._resistances(x)
        ua = v_a - Rs * c[0]  # the emf without core loss (R_fe infinite)
        ub = v_b - Rs * c[1]
        R_fe = self.R_fe
        if R_fe > 0.0:
            g = 1.0 / (R_fe + Rs)
            fa, fb = ua * g, ub * g  # i_fe = (v_s - R_s i_s0) / (R_fe + R_s)
            return c, Rs, Rr, R_fe * fa, R_fe * fb, fa, fb
        return c, Rs, Rr, ua, ub, 0.0, 0.0

    def _derivatives_ext(self, x, v_a, v_b, T_load, warm=None):
        """:meth:`derivatives` with core loss and/or the thermal model (module thermal's equations)."""
        (isa, isb, ira, irb, *_), Rs, Rr, ea, eb, fa, fb = self._ext_terms(x, v_a, v_b, warm)
        d = self._rates(ea, eb, Rr, isa, isb, ira, irb, x[PSI_S_A], x[PSI_S_B], x[PSI_R_A], x[PSI_R_B],
                        x[OMEGA_M], T_load)
        if not self._th_on:
            return d
        th = self.th
        Ts, Tr = x[T_S], x[T_R]
        ta, tb = isa + fa, isb + fb  # the terminal current heats the stator copper
        p_s = 1.5 * Rs * (ta * ta + tb * tb) + (1.5 * (ea * fa + eb * fb))  # copper + core (e.i_fe)
        p_r = 1.5 * Rr * (ira * ira + irb * irb)
        q_sr = (Ts - Tr) / th.R_th_sr
        return d + ((p_s - (Ts - th.T_amb) / th.R_th_s - q_sr) / th.C_th_s,
                    (p_r - (Tr - th.T_amb) / th.R_th_r + q_sr) / th.C_th_r)

    def outputs(self, x, v_a=0.0, v_b=0.0):
        """Currents, magnetizing state, torque, core loss and temperatures at state ``x``; with
        R_fe > 0 the terminal current and P_fe need the stator voltage ``v_a``, ``v_b`` [V]."""
        if self._ext:
            (isa, isb, ira, irb, ima, imb, I, psi, m), _, _, ea, eb, fa, fb = self._ext_terms(x, v_a, v_b)
            te = self._kappa * (x[PSI_S_A] * isb - x[PSI_S_B] * isa)
            ts, tr = (x[T_S], x[T_R]) if self._th_on else (self.th.T_s0, self.th.T_r0)
            return PlantOutputs(isa + fa, isb + fb, ira, irb, ima, imb, I, psi, m, te,
                                1.5 * (ea * fa + eb * fb), ts, tr)
        psa, psb, pra, prb = x[PSI_S_A], x[PSI_S_B], x[PSI_R_A], x[PSI_R_B]
        ts, tr = self.th.T_s0, self.th.T_r0
        if self._gamma:
            isa, isb, ira, irb, ima, imb, I, psi, m = self._currents_gamma(psa, psb, pra, prb)
            te = self._kappa * (psa * isb - psb * isa)
            return PlantOutputs(isa, isb, ira, irb, ima, imb, I, psi, m, te, 0.0, ts, tr)
        ima, imb, I, psi, m = self.magnetizing(psa, psb, pra, prb)
        isa = (psa - m * ima) * self._inv_ls
        isb = (psb - m * imb) * self._inv_ls
        km = self._k * m
        ira = (pra - km * ima) / self._lr
        irb = (prb - km * imb) / self._lr
        te = self._kappa * (psa * isb - psb * isa)
        return PlantOutputs(isa, isb, ira, irb, ima, imb, I, psi, m, te, 0.0, ts, tr)

    def powers(self, x, o, T_load):
        """``(P_cu_s, P_cu_r, P_fe, P_fw, P_stray, P_mech)`` [W] at state ``x`` with its outputs ``o``
        (:meth:`outputs` at the voltage applied) and the load ``T_load`` [N m]
        (:mod:`satmotor.machine.losses`)."""
        Rs, Rr = self._resistances(x)
        isa, isb = o.i_s_alpha, o.i_s_beta
        ira, irb = o.i_r_alpha, o.i_r_beta
        w = x[OMEGA_M]
        lp = self.lp
        p_stray = 0.0
        if lp.k_stray > 0.0:
            if self.R_fe > 0.0:  # the current through the leakage, as the torque (_rates) takes it
                isa, isb = self.currents(x[PSI_S_A], x[PSI_S_B], x[PSI_R_A], x[PSI_R_B])[:2]
            p_stray = lp.k_stray * (isa * isa + isb * isb) * w * w
            isa, isb = o.i_s_alpha, o.i_s_beta
        return (1.5 * Rs * (isa * isa + isb * isb), 1.5 * Rr * (ira * ira + irb * irb), o.P_fe,
                (self._B * w + friction_torque(lp, w)) * w, p_stray, (T_load + self._B2 * abs(w) * w) * w)

    def thermal_state(self):
        """The state's thermal entries at the start: ``(T_s0, T_r0)`` with the thermal model on, or ``()``."""
        return (self.th.T_s0, self.th.T_r0) if self._th_on else ()

    def step(self, t, x, v_a, v_b, T_load, h, n_sub=1):
        """Advance the state over ``h`` [s] with inputs held (zero-order hold), RK4.  The
        magnetizing-curve solve of stages 2 to 4 starts from the previous stage's root (a warm start:
        fewer Newton iterates, the same tolerance); each sub-step's first stage starts cold, so the
        step depends on ``x`` and the inputs only, never on an earlier step."""
        return rk4(self.derivatives, t, x, h, n_sub, (v_a, v_b, T_load), [0.0])

    def magnetic_energy(self, x):
        """Stored magnetic energy [J]: 3/2 (l_s|i_s0|^2/2 + l_r|i_r|^2/2 + int_0^psi_m I dpsi), i_s0 the
        current through the stator leakage (the terminal current without core loss)."""
        isa, isb, ira, irb, _, _, I, _, _ = self.currents(x[PSI_S_A], x[PSI_S_B], x[PSI_R_A], x[PSI_R_B])
        return 1.5 * (
            0.5 * self._ls * (isa**2 + isb**2)
            + 0.5 * self._lr * (ira**2 + irb**2)
            + self._curve.energy(I)
        )


def initial_state(params, omega_m=0.0, theta_m=0.0, psi_r_alpha=0.0, psi_r_beta=0.0):
    """State with the given speed and a steady (DC) rotor flux [Wb]: i_r = 0, i_s = i_mu.

    With i_r = 0 the rotor flux is ``k psi_m(I)`` along i_mu and the stator flux is
    ``(l_s + m) i_mu``.  A zero rotor flux gives the zero electrical state.
    """
    phi = math.hypot(psi_r_alpha, psi_r_beta)
    x = [0.0] * N_STATES
    x[OMEGA_M], x[THETA_M] = float(omega_m), float(theta_m)
    if phi == 0.0:
        return tuple(x)
    I = params.curve.current(phi / params.k)
    m = params.curve.m(I)
    ca, sb = psi_r_alpha / phi, psi_r_beta / phi
    x[PSI_S_A], x[PSI_S_B] = (params.l_s + m) * I * ca, (params.l_s + m) * I * sb
    x[PSI_R_A], x[PSI_R_B] = float(psi_r_alpha), float(psi_r_beta)
    return tuple(x)
