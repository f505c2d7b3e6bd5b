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

Equations (seed eqs 1, 4, 10-13 with the factor k of the errata)::

    psi_s = l_s i_s + m(I) i_mu,  psi_r = l_r i_r + k m(I) i_mu,  i_mu = i_s + k i_r
    d psi_s/dt = v_s - R_s i_s
    d psi_r/dt = -R_r i_r + n_p omega_m J2 psi_r          (J2 = rotation by +90 deg)
    J d omega_m/dt = T_e - T_load - B omega_m - B_2 omega_m |omega_m|,   d theta_m/dt = omega_m
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

PSI_S_A, PSI_S_B, PSI_R_A, PSI_R_B, OMEGA_M, THETA_M = range(6)
N_STATES = 6
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


class Plant:
    """Stationary-frame saturated induction motor bound to one parameter set.

    Parameters
    ----------
    params : satmotor.machine.params.MotorParams
    B_2 : float
        Quadratic (fan/pump) load coefficient [N m s2/rad2], >= 0: load torque
        ``B_2 omega_m |omega_m|`` opposing motion (default 0: none).
    """

    __slots__ = ("p", "B_2", "_curve", "_inv_ls", "_k_lr", "_le", "_k", "_ls", "_lr", "_Rs", "_Rr",
                 "_np", "_kappa", "_inv_J", "_B", "_B2", "_m0", "_gamma")

    def __init__(self, params, B_2=0.0):
        self.p = params
        self.B_2 = self._B2 = require_number("B_2", B_2, 0, inclusive=True)
        self._curve = params.curve
        self._gamma = params.l_s == 0.0  # the Gamma-equivalent model (module docstring)
        self._inv_ls = 0.0 if self._gamma else 1.0 / params.l_s
        self._k_lr = params.k / params.l_r
        self._le = params.l_e
        self._k = params.k
        self._ls = params.l_s
        self._lr = params.l_r
        self._Rs = params.R_s
        self._Rr = params.R_r
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

    def magnetizing(self, psa, psb, pra, prb):
        """Return ``(i_mu_alpha, i_mu_beta, I, psi_m, m)`` from the four fluxes [Wb]."""
        if self._gamma:
            return self._magnetizing_gamma(psa, psb)
        ua = psa * self._inv_ls + self._k_lr * pra
        ub = psb * self._inv_ls + self._k_lr * prb
        un = math.hypot(ua, ub)
        le = self._le
        I, psi = self._curve.solve(le, le * un)
        if I == 0.0:
            return 0.0, 0.0, 0.0, 0.0, self._m0
        s = I / un
        return s * ua, s * ub, I, psi, psi / I

    def derivatives(self, t, x, v_a, v_b, T_load, warm=None):
        """Right-hand side ``dx/dt`` [SI per s] for constant inputs over the call (state order).

        ``warm``: None (the magnetizing-curve solve starts cold), or a one-element list: the solve
        starts from ``warm[0]`` [A] and leaves its root |i_mu| there (:meth:`step`'s stages)."""
        psa, psb, pra, prb, w = x[PSI_S_A], x[PSI_S_B], x[PSI_R_A], x[PSI_R_B], x[OMEGA_M]
        if self._gamma:
            return self._derivatives_gamma(psa, psb, pra, prb, w, v_a, v_b, T_load, warm)
        # self.magnetizing written out (same operations): one call less per evaluation
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
        we = self._np * w
        te = self._kappa * (psa * isb - psb * isa)
        return (
            v_a - self._Rs * isa,
            v_b - self._Rs * isb,
            -self._Rr * ira - we * prb,
            -self._Rr * irb + we * pra,
            # (B + B_2 |w|) w: with B_2 = 0 exactly B w (B + 0.0 = B), so the same floats as without
            (te - T_load - (self._B + self._B2 * abs(w)) * w) * self._inv_J,
            w,
        )

    def _derivatives_gamma(self, psa, psb, pra, prb, w, v_a, v_b, T_load, warm=None):
        """:meth:`derivatives` for l_s = 0 (the same equations, the currents of :meth:`_currents_gamma`)."""
        isa, isb, ira, irb = self._currents_gamma(psa, psb, pra, prb, warm)[:4]
        we = self._np * w
        te = self._kappa * (psa * isb - psb * isa)
        return (
            v_a - self._Rs * isa,
            v_b - self._Rs * isb,
            -self._Rr * ira - we * prb,
            -self._Rr * irb + we * pra,
            (te - T_load - (self._B + self._B2 * abs(w)) * w) * self._inv_J,
            w,
        )

    def outputs(self, x):
        """Currents, magnetizing state and torque at state ``x``."""
        psa, psb, pra, prb = x[PSI_S_A], x[PSI_S_B], x[PSI_R_A], x[PSI_R_B]
        if self._gamma:
            isa, isb, ira, irb, ima, imb, I, psi, m = self._currents_gamma(psa, psb, pra, prb)
            te = self._kappa * (psa * isb - psb * isa)
            return PlantOutputs(isa, isb, ira, irb, ima, imb, I, psi, m, te)
        ima, imb, I, psi, m = self.magnetizing(psa, psb, pra, prb)
        isa = (psa - m * ima) * self._inv_ls
        isb = (psb - m * imb) * self._inv_ls
        km = self._k * m
        ira = (pra - km * ima) / self._lr
        irb = (prb - km * imb) / self._lr
        te = self._kappa * (psa * isb - psb * isa)
        return PlantOutputs(isa, isb, ira, irb, ima, imb, I, psi, m, te)

    def step(self, t, x, v_a, v_b, T_load, h, n_sub=1):
        """Advance the state over ``h`` [s] with inputs held (zero-order hold), RK4.  The
        magnetizing-curve solve of stages 2 to 4 starts from the previous stage's root (a warm start:
        fewer Newton iterates, the same tolerance); each sub-step's first stage starts cold, so the
        step depends on ``x`` and the inputs only, never on an earlier step."""
        return rk4(self.derivatives, t, x, h, n_sub, (v_a, v_b, T_load), [0.0])

    def magnetic_energy(self, x):
        """Stored magnetic energy [J]: 3/2 (l_s|i_s|^2/2 + l_r|i_r|^2/2 + int_0^psi_m I dpsi)."""
        o = self.outputs(x)
        return 1.5 * (
            0.5 * self._ls * (o.i_s_alpha**2 + o.i_s_beta**2)
            + 0.5 * self._lr * (o.i_r_alpha**2 + o.i_r_beta**2)
            + self._curve.energy(o.i_mu)
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
