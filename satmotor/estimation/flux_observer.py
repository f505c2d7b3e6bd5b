"""Closed-loop rotor-flux observer on the saturated model, optionally speed-adaptive (sensorless).

Two models of the same rotor flux psi_r [Wb] (stationary frame, the plant's equations of
:mod:`satmotor.machine.plant`, the controller's parameters):

* the *current model* (:class:`satmotor.estimation.observer.RotorFluxObserver`)::

      d psi_r/dt = -R_r i_r(psi_r, i_s) + n_p omega_m J2 psi_r = f_i(psi_r)

  exact at standstill, but it inherits every error of R_r (and l_r, k, curve) as a flux error
  that grows with the slip;
* the *voltage model*: ``d psi_s/dt = v_s - R_s i_s`` with the algebraic relations
  ``psi_s = l_s i_s + psi_m``, ``psi_r = k psi_m + (l_r/k)(i_mu - i_s)``, ``psi_m = psi_m(|i_mu|)
  i_mu/|i_mu|`` (the magnetizing curve inside, both ways: ``curve.solve`` from (psi_r, i_s) to
  psi_s, ``curve.current`` from (psi_s, i_s) back to psi_r).  It needs no R_r and no speed, but
  it is an open integration: it drifts with any offset, and at zero stator frequency it has
  nothing to integrate.

The observer blends the two increments with a complex (2 x 2) speed-dependent gain G,
``d psi_hat/dt = f_i(psi_hat) + G (f_v - f_i(psi_hat))``.  In the linear case f_v does not depend
on the estimate (it is the true flux's rate), so the estimation error e = psi_r - psi_hat obeys
``e' = (1 - G)(delta - (a - j w_r) e)``, with ``a = R_r/(l_r + k^2 m(I))`` the rotor rate across
the flux, ``w_r = n_p omega_m`` and ``delta = f_i(psi_r) - f_i_hat(psi_r)`` the current model's own
error (e.g. from a wrong R_r).  We place the error pole at ``-b`` at every speed:
``1 - G = b/(a - j w_r)``, i.e.::

    G = ((a - b) a + w_r^2 - j b w_r) / (a^2 + w_r^2),       with the speed measured b = a:
    G = (w_r^2 - j a w_r) / (a^2 + w_r^2)

(the reduced-order design of Verghese and Sanders 1988 and Hinkkanen et al. 2010, written here
on the saturated model).  Consequences, all from the error equation:

* at standstill (b = a) G = 0: the current model alone (no drift, no integration of offsets);
* the error decays at the rate b at every speed (it is not merely turned by the speed,
  as in the open-loop current model, and not marginal, as in the pure voltage model);
* the steady error the current model's error leaves, at the stator frequency w_s, is
  ``e = b delta / ((a - j w_r)(j w_s + b))``: against the open-loop ``delta/(a + j (w_s - w_r))``
  it is smaller by about ``b/|w_r|``, i.e. 25 times at 100 rad/s for the default motor.

Speed adaptation (``speed_source = estimated``).  Over one sample, both models start from the
same estimate; their difference ``d = psi_v - psi_i`` holds ``Ts j n_p (omega_m - omega_hat)
psi_hat`` plus the flux error's own terms.  The speed error seen in one sample is
``eps = Im(d conj(psi_hat)) / (n_p Ts |psi_hat|^2)`` [rad/s], and ``omega_hat <- omega_hat + Ts
alpha_w eps`` (an integral law of bandwidth ``alpha_w`` [rad/s]); below ``PSI_ADAPT_MIN`` (0.2 Wb)
of estimated flux the estimate is held: there the current noise, divided by the small flux,
swamps eps (at 0.1 Wb, 0.12 A of noise tripped the pre-magnetization's "rotor moves" test).
The speed estimate then drives both the current model's rotation and the gain G.  The speed
error and the flux error are coupled (a flux error turns into a speed error and back); with b = a
that mode rings for about a second (period about 0.1 s), so with the speed estimated the pole
moves from b = a at standstill to b = 3a at speed (``POLE_FACTOR_ESTIMATED``),
``b = a + 2 a w_r^2/(a^2 + w_r^2)``: the mode is damped within about 0.3 s and G stays 0 at
standstill (a constant b = 3a gave G = -2 there, and under a Jacobi master the pre-magnetization
locked into a spurious rotating estimate).  Limits: at zero
stator frequency (``w_s = 0``: standstill without load, or the slip cancelling the rotation in
regeneration) d carries no speed information; in low-speed regeneration the estimate can drift
(documented in docs/controller.md).

The Gamma form (``l_s = 0``, e.g. the ``qu2012_2kw2`` preset) is exact here: l_s enters only as a
product (``psi_s = l_s i_s + psi_m``, ``psi_m = psi_s - l_s i_s``), never as a divisor, so l_s = 0 gives
``psi_s = psi_m``: the Gamma model's stator flux is its magnetizing flux, ``psi_r = k psi_m + (l_r/k)
(i_mu - i_s)`` its rotor flux with L_sigma = l_r/k^2 (derivation in docs/controller.md, "The Gamma form
in the observer").  What the observer needs: R_s > 0, l_s >= 0, l_r > 0, k > 0.

Discretization over [t_{k-1}, t_k] (Ts [s]): i_s linear between its samples (as in the current
model), v_s the voltage the controller applied over the interval (zero-order hold, exact), the
speed linear (measured) or held (estimated).  Current model: the RK4 step of
:class:`RotorFluxObserver` (rotation exact).  Voltage model: psi_s from the estimate at t_{k-1},
``psi_s += Ts (v_s - R_s (i_s0 + i_s1)/2)`` (exact for linear i_s), back to psi_r at t_k.  Then
``psi_hat = psi_i + G d`` with G at the interval's mean speed and ``a`` at the estimate's
magnetizing current at t_{k-1}.
"""

from __future__ import annotations

import math

from satmotor.errors import ParameterError, require_number
from satmotor.estimation.observer import RotorFluxObserver
from satmotor.estimation.resistance import adapt_stator_resistance, rotor_resistance

POLE_FACTOR_MEASURED = 1.0  # [1] b/a with the speed measured: the current model alone at standstill
POLE_FACTOR_ESTIMATED = 3.0  # [1] b/a with the speed estimated: the speed loop's damping (see the docstring)
PSI_ADAPT_MIN = 0.2  # [Wb] below this estimated flux the speed estimate is held (no speed information)
N_STATE = 10  # get_state's length


class ClosedLoopObserver:
    """Rotor flux (and, with ``estimate_speed``, speed) from sampled i_s [A], the applied v_s [V]
    and, unless estimated, omega_m [rad/s].

    Parameters
    ----------
    params : satmotor.machine.params.MotorParams
        The controller's model.
    Ts : float
        Sampling period [s], > 0.
    estimate_speed : bool
        Ignore the speed input and adapt a speed estimate (sensorless).
    alpha_w : float
        Bandwidth of the speed adaptation [rad/s], > 0.
    adapt_rs : bool
        Adapt the stator resistance (:mod:`satmotor.estimation.resistance`); False: R_s as given.
    track_rr : bool
        The rotor resistance from the temperature R_s_hat implies (needs ``adapt_rs``).

    With ``adapt_rs`` the drive calls :meth:`adapt_resistance` after a sample in which no limit held
    (the freezing conditions of :mod:`satmotor.estimation.resistance`).
    """

    __slots__ = ("params", "Ts", "estimate_speed", "alpha_w", "_cm", "_curve", "_k", "_ls", "_lr", "_Rs",
                 "_Rr", "_np", "_lr_k", "_a_solve", "_k_lr", "_pa", "_pb", "_isa", "_isb", "_w", "_va", "_vb",
                 "_w_hat", "_has_prev", "_pole", "adapt_rs", "track_rr", "_Rs0", "_Rr0", "_res")

    def __init__(self, params, Ts, estimate_speed=False, alpha_w=200.0, adapt_rs=False, track_rr=False):
        for name in ("R_s", "R_r", "l_s", "l_r", "k", "n_p", "curve"):
            if not hasattr(params, name):
                raise ParameterError("params", params, f"has no {name}; a MotorParams is needed")
        self.Ts = require_number("Ts", Ts, 0)
        self.alpha_w = require_number("alpha_w", alpha_w, 0)
        require_number("R_s", params.R_s, 0)
        require_number("l_s", params.l_s, 0, inclusive=True)  # 0: the Gamma form, exact
        if not isinstance(estimate_speed, bool):
            raise ParameterError("estimate_speed", estimate_speed, "must be a Boolean")
        self.estimate_speed = estimate_speed
        for name, v in (("adapt_rs", adapt_rs), ("track_rr", track_rr)):
            if not isinstance(v, bool):
                raise ParameterError(name, v, "must be a Boolean")
        if track_rr and not adapt_rs:
            raise ParameterError("track_rr", track_rr, "needs adapt_rs (the temperature comes from R_s_hat)")
        self.adapt_rs, self.track_rr = adapt_rs, track_rr
        self._pole = POLE_FACTOR_ESTIMATED if estimate_speed else POLE_FACTOR_MEASURED
        self.params = params
        self._cm = RotorFluxObserver(params, Ts)
        self._curve = params.curve
        self._k = float(params.k)
        self._ls = float(params.l_s)
        self._lr = float(params.l_r)
        self._Rs = self._Rs0 = float(params.R_s)
        self._Rr = self._Rr0 = float(params.R_r)
        self._np = float(params.n_p)
        self._lr_k = params.l_r / params.k
        self._k_lr = params.k / params.l_r
        self._a_solve = params.l_r / (params.k * params.k)
        self.reset()

    def reset(self, psi_r_alpha=0.0, psi_r_beta=0.0, omega_m_hat=0.0):
        """Set the estimates [Wb, rad/s], forget the previous sample and the applied voltage."""
        self._pa = require_number("psi_r_alpha", psi_r_alpha)
        self._pb = require_number("psi_r_beta", psi_r_beta)
        self._w_hat = require_number("omega_m_hat", omega_m_hat)
        self._isa = self._isb = self._w = self._va = self._vb = 0.0
        self._has_prev = False
        self._res = None  # the last update's residual (not a state: used within its sample)
        if self.adapt_rs:
            self._set_resistance(self._Rs0)

    def adapt_resistance(self):
        """One step of the R_s adaptation (and R_r tracking) from the last update's residual, if it had
        one (:mod:`satmotor.estimation.resistance`: held below PSI_ADAPT_MIN of flux, at low excitation)."""
        r = self._res
        self._res = None
        if r is None or r[6] < PSI_ADAPT_MIN * PSI_ADAPT_MIN:
            return
        rs = adapt_stator_resistance(self._Rs, self._Rs0, self.Ts, *r, self.estimate_speed)
        if rs != self._Rs:
            self._set_resistance(rs)

    def _set_resistance(self, R_s_hat):
        """R_s_hat [Ohm] and, with track_rr, the R_r_hat it implies, in both models."""
        self._Rs = R_s_hat
        if self.track_rr:
            self._Rr = rotor_resistance(R_s_hat, self._Rs0, self._Rr0)
            self._cm.set_rotor_resistance(self._Rr)

    @property
    def resistances(self):
        """(R_s_hat, R_r_hat) [Ohm]: the estimates (the given values where not adapted)."""
        return (self._Rs, self._Rr)

    @property
    def estimate(self):
        """(psi_hat_alpha, psi_hat_beta) [Wb]."""
        return (self._pa, self._pb)

    @property
    def speed(self):
        """The speed estimate omega_m_hat [rad/s] (estimate_speed), else the last speed input."""
        return self._w_hat if self.estimate_speed else self._w

    def applied(self, v_s_alpha, v_s_beta):
        """The stator voltage [V] applied from this sample to the next (the drive's output)."""
        self._va, self._vb = float(v_s_alpha), float(v_s_beta)

    def get_state(self):
        """Flat tuple ``(psi_a, psi_b, i_sa_prev, i_sb_prev, omega_m_prev, v_sa, v_sb, omega_m_hat,
        has_prev, R_s_hat)`` of floats (the last entry 0 without adapt_rs)."""
        return (self._pa, self._pb, self._isa, self._isb, self._w, self._va, self._vb, self._w_hat,
                1.0 if self._has_prev else 0.0, self._Rs if self.adapt_rs else 0.0)

    def set_state(self, state):
        """Restore a tuple from :meth:`get_state`."""
        if len(state) != N_STATE:
            raise ParameterError("state", state, f"must have {N_STATE} entries (see get_state)")
        s = tuple(require_number(f"state[{j}]", v) for j, v in enumerate(state))
        self._pa, self._pb, self._isa, self._isb, self._w, self._va, self._vb, self._w_hat = s[:8]
        self._has_prev = s[8] != 0.0
        if self.adapt_rs:
            self._set_resistance(s[9])

    def _stator_flux(self, pa, pb, isa, isb):
        """psi_s [Wb] and the magnetizing current magnitude I [A], psi_m(I) [Wb] at (psi_r, i_s)."""
        wa = isa + self._k_lr * pa
        wb = isb + self._k_lr * pb
        wn = math.hypot(wa, wb)
        a = self._a_solve
        I, psi = self._curve.solve(a, a * wn)
        q = psi / wn if wn > 0.0 else 0.0
        return self._ls * isa + q * wa, self._ls * isb + q * wb, I, psi

    def _rotor_flux(self, sa, sb, isa, isb):
        """psi_r [Wb] at (psi_s, i_s): psi_m = psi_s - l_s i_s, i_mu from the curve's inverse."""
        ma = sa - self._ls * isa
        mb = sb - self._ls * isb
        mn = math.hypot(ma, mb)
        r = self._curve.current(mn) / mn if mn > 0.0 else 0.0
        return (self._k * ma + self._lr_k * (r * ma - isa), self._k * mb + self._lr_k * (r * mb - isb))

    def update(self, i_s_alpha, i_s_beta, omega_m):
        """Advance to this sample; returns (psi_hat_alpha, psi_hat_beta, omega_m_hat) [Wb, Wb, rad/s].

        With ``estimate_speed`` the omega_m argument is not read.  The first call after :meth:`reset`
        only stores the inputs.  Inputs unchecked (per-sample path): a NaN propagates."""
        isa1, isb1 = float(i_s_alpha), float(i_s_beta)
        w1 = self._w_hat if self.estimate_speed else float(omega_m)
        if not self._has_prev:
            self._isa, self._isb, self._w, self._has_prev = isa1, isb1, w1, True
            return (self._pa, self._pb, self.speed)
        isa0, isb0, w0, pa, pb = self._isa, self._isb, self._w, self._pa, self._pb
        if self.estimate_speed:
            w0 = w1
        # current model: one RK4 step from the estimate
        cm = self._cm
        cm.restart(pa, pb, isa0, isb0, w0)
        ia, ib = cm.update(isa1, isb1, w1)
        # voltage model: psi_s at t_{k-1}, integrated over the interval, back to psi_r at t_k
        sa, sb, I0, psi0 = self._stator_flux(pa, pb, isa0, isb0)
        Ts = self.Ts
        sa += Ts * (self._va - self._Rs * 0.5 * (isa0 + isa1))
        sb += Ts * (self._vb - self._Rs * 0.5 * (isb0 + isb1))
        va, vb = self._rotor_flux(sa, sb, isa1, isb1)
        da, db = va - ia, vb - ib
        # gain: the error pole at -b = -pole a at every speed
        m = psi0 / I0 if I0 > 0.0 else self._curve.m0
        a = self._Rr / (self._lr + self._k * self._k * m)
        wr = self._np * 0.5 * (w0 + w1)
        den = a * a + wr * wr
        b = a + (self._pole - 1.0) * a * (wr * wr / den)  # a at standstill, pole a at speed
        g_re = ((a - b) * a + wr * wr) / den
        g_im = -b * wr / den
        self._pa = ia + g_re * da - g_im * db
        self._pb = ib + g_im * da + g_re * db
        n2 = pa * pa + pb * pb
        if self.estimate_speed and n2 >= PSI_ADAPT_MIN * PSI_ADAPT_MIN:  # below: no speed information
            eps = (db * pa - da * pb) / (self._np * Ts * n2)
            self._w_hat = w1 + Ts * self.alpha_w * eps
            w1 = self._w_hat
        if self.adapt_rs:  # this sample's residual, for adapt_resistance
            self._res = (da, db, pa, pb, 0.5 * (isa0 + isa1), 0.5 * (isb0 + isb1), n2)
        self._isa, self._isb, self._w = isa1, isb1, w1
        return (self._pa, self._pb, self.speed)


__all__ = ["ClosedLoopObserver", "N_STATE", "POLE_FACTOR_ESTIMATED", "POLE_FACTOR_MEASURED", "PSI_ADAPT_MIN"]
