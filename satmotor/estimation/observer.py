"""Rotor-flux observer ("current model") on the saturated model, for sampled i_s and omega_m.

Model.  The rotor equation of :mod:`satmotor.machine.plant` in the stationary frame::

    d psi_r/dt = -R_r i_r(psi_r, i_s) + n_p omega_m J2 psi_r      (J2 = rotation by +90 deg)

needs only the stator current i_s [A] and the speed omega_m [rad/s], both measured.  The rotor
current follows from psi_r and i_s through the curve exactly as in
:func:`satmotor.control.measurements.from_rotor_flux`: ``w = i_s + (k/l_r) psi_r``, ``I`` the root of
``(l_r/k^2) I + psi_m(I) = (l_r/k^2)|w|`` (``curve.solve``, the controller's solve),
``i_mu = (I/|w|) w`` and ``i_r = (psi_r - k m i_mu)/l_r = (psi_r - k psi_m(I) w/|w|)/l_r``.

Discretization over one sample interval [t_{k-1}, t_k] of length Ts [s]:

* Inputs: i_s and omega_m are taken linear in time between the two samples (first-order hold).
  Two samples are all the interval provides; a line through them is the interpolant they fix,
  and for smooth signals its error is at most Ts^2/8 max|x''|, i.e. O(Ts^2), whereas holding the
  first sample (zero-order hold) is O(Ts) and also delays by Ts/2.
* Rotation: with theta(tau) = n_p int_0^tau omega_m = n_p (omega_0 tau + (omega_1 - omega_0)
  tau^2 / (2 Ts)) (exact for linear omega_m) write psi_r = R(theta) phi.  Since R' = theta' J2 R,
  the rotation term cancels and ``phi' = R(-theta) (-R_r i_r(R(theta) phi, i_s(tau)))``; this
  is integrated by classical RK4 in n_sub equal sub-steps, and psi_r(t_k) = R(theta(Ts)) phi(Ts).
  The rotation is thus exact at any speed: forward Euler of J2 alone would multiply the flux by
  |1 + j n_p omega Ts| > 1 every sample; here RK4 only sees the resistive part, whose rate
  R_r/l_r (about 240 1/s for the default motor) is far inside RK4's stability region for any
  practical Ts.  theta restarts at 0 every interval, so no angle accumulates.

Why no correction term (voltage model, gain) is needed.  Let e = psi_r - psi_hat for the same
i_s.  Linear curve (m constant): i_r = (psi_r - k m i_mu)/l_r with i_mu = w/(1 + k^2 m/l_r)
gives di_r/dpsi_r = 1/(l_r + k^2 m), so in complex notation
``e' = (-R_r/(l_r + k^2 m) + j n_p omega_m) e``: the real part is -1/tau_r at every speed,
the speed only turns e.  Saturated curve: psi_r = l_r i_r + k lambda(i_s + k i_r) has the
Jacobian dpsi_r/di_r = l_r + k^2 M(i_mu) with M = d lambda/d i_mu symmetric, eigenvalues
L_dyn(I) (along i_mu) and m(I) (across), both > 0 for a monotone curve.  So i_r(psi_r) is the
inverse of a strongly monotone map (this is why the scalar solve has one root), its Jacobian is
symmetric positive definite with eigenvalues >= 1/(l_r + k^2 L_max), L_max = sup max(L_dyn, m)
(= m(0) for the concave curves, where L_dyn <= m <= m(0)), and by the mean value theorem
``d|e|^2/dt = -2 R_r e.(i_r(psi_r) - i_r(psi_hat)) + 0 <= -2 R_r/(l_r + k^2 L_max) |e|^2``
(J2 is skew, it drops out).  The error contracts at least at the unsaturated rotor time
constant, at every speed, from any initial estimate; near an operating point it decays at
R_r/(l_r + k^2 m(I)) across the flux and R_r/(l_r + k^2 L_dyn(I)) along it.  tests/test_observer
checks this numerically.

Weakness: the observer is open loop in the model.  A wrong R_r, l_r, k or curve is not seen by
anything and maps straight into a steady flux error (magnitude and angle) that grows with the
slip; nothing here corrects it (that needs a second model, e.g. the voltage model).
"""

from __future__ import annotations

import math

from satmotor.errors import ParameterError, require_integer, require_number


class RotorFluxObserver:
    """Current-model rotor-flux estimator fed with sampled i_s [A] (alpha, beta) and omega_m [rad/s].

    Parameters
    ----------
    params : satmotor.machine.params.MotorParams
        The controller's model (R_r, l_r, k, n_p, curve).
    Ts : float
        Sampling period [s], > 0.
    n_sub : int
        RK4 sub-steps per sample, >= 1.
    """

    __slots__ = ("params", "Ts", "n_sub", "_curve", "_k", "_k_lr", "_a", "_Rr_lr", "_np",
                 "_pa", "_pb", "_isa", "_isb", "_w", "_has_prev")

    def __init__(self, params, Ts, n_sub=1):
        for name in ("R_r", "l_r", "k", "n_p", "curve"):
            if not hasattr(params, name):
                raise ParameterError("params", params, f"has no {name}; a MotorParams is needed")
        self.Ts = require_number("Ts", Ts, 0)
        self.n_sub = require_integer("n_sub", n_sub, 1)
        self.params = params
        self._curve = params.curve
        self._k = float(params.k)
        self._k_lr = params.k / params.l_r
        self._a = params.l_r / (params.k * params.k)
        self._Rr_lr = params.R_r / params.l_r
        self._np = float(params.n_p)
        self.reset()

    def reset(self, psi_r_alpha=0.0, psi_r_beta=0.0):
        """Set the estimate [Wb] and forget the previous sample (the next update only stores)."""
        self._pa = require_number("psi_r_alpha", psi_r_alpha)
        self._pb = require_number("psi_r_beta", psi_r_beta)
        self._isa = self._isb = self._w = 0.0
        self._has_prev = False

    @property
    def estimate(self):
        """(psi_hat_alpha, psi_hat_beta) [Wb]."""
        return (self._pa, self._pb)

    def get_state(self):
        """Flat tuple ``(psi_a, psi_b, i_sa_prev, i_sb_prev, omega_m_prev, has_prev)`` of floats."""
        return (self._pa, self._pb, self._isa, self._isb, self._w, 1.0 if self._has_prev else 0.0)

    def set_state(self, state):
        """Restore a tuple from :meth:`get_state`."""
        if len(state) != 6:
            raise ParameterError("state", state, "must have 6 entries (see get_state)")
        pa, pb, isa, isb, w, flag = (require_number(f"state[{j}]", v) for j, v in enumerate(state))
        self._pa, self._pb, self._isa, self._isb, self._w = pa, pb, isa, isb, w
        self._has_prev = flag != 0.0

    def set_rotor_resistance(self, R_r):
        """The model's R_r [Ohm] from now on (the tracked estimate; unchecked, per-sample path)."""
        self._Rr_lr = R_r / self.params.l_r

    def restart(self, psi_r_alpha, psi_r_beta, i_s_alpha, i_s_beta, omega_m):
        """Set the estimate [Wb] and the previous sample (i_s [A], omega_m [rad/s]) unchecked (per-sample
        path of :class:`satmotor.estimation.flux_observer.ClosedLoopObserver`)."""
        self._pa, self._pb, self._isa, self._isb = psi_r_alpha, psi_r_beta, i_s_alpha, i_s_beta
        self._w = omega_m
        self._has_prev = True

    def _rhs(self, c, s, fa, fb, isa, isb):
        """phi' = R(-theta)(-R_r i_r) at phi = (fa, fb), cos/sin theta = (c, s), i_s = (isa, isb)."""
        pa = c * fa - s * fb
        pb = s * fa + c * fb
        wa = isa + self._k_lr * pa
        wb = isb + self._k_lr * pb
        wn = math.hypot(wa, wb)
        a = self._a
        psi = self._curve.solve(a, a * wn)[1]
        q = self._k * psi / wn if wn > 0.0 else 0.0
        ga = -self._Rr_lr * (pa - q * wa)  # -R_r i_r = -(R_r/l_r)(psi_r - k psi_m w/|w|)
        gb = -self._Rr_lr * (pb - q * wb)
        return c * ga + s * gb, c * gb - s * ga

    def update(self, i_s_alpha, i_s_beta, omega_m):
        """Advance the estimate to this sample; returns (psi_hat_alpha, psi_hat_beta) [Wb].

        The first call after :meth:`reset` only stores the inputs and returns the estimate.  The inputs
        are not checked (per-sample path): a NaN propagates into the estimate.
        """
        isa1, isb1, w1 = float(i_s_alpha), float(i_s_beta), float(omega_m)
        if not self._has_prev:
            self._isa, self._isb, self._w, self._has_prev = isa1, isb1, w1, True
            return (self._pa, self._pb)
        Ts, n = self.Ts, self.n_sub
        isa0, isb0, w0 = self._isa, self._isb, self._w
        dia, dib = (isa1 - isa0) / Ts, (isb1 - isb0) / Ts  # i_s(tau) = i_s0 + di tau
        th1 = self._np * w0  # theta(tau) = th1 tau + th2 tau^2
        th2 = 0.5 * self._np * (w1 - w0) / Ts
        h = Ts / n
        hh = 0.5 * h
        rhs = self._rhs
        cos, sin = math.cos, math.sin
        fa, fb = self._pa, self._pb  # phi(0) = psi_r(t_{k-1}) since theta(0) = 0
        c0, s0, t0 = 1.0, 0.0, 0.0
        for j in range(n):
            tm = (j + 0.5) * h
            t1 = (j + 1) * h
            thm = (th1 + th2 * tm) * tm
            th = (th1 + th2 * t1) * t1
            cm, sm, c1, s1 = cos(thm), sin(thm), cos(th), sin(th)
            iam, ibm = isa0 + dia * tm, isb0 + dib * tm
            k1a, k1b = rhs(c0, s0, fa, fb, isa0 + dia * t0, isb0 + dib * t0)
            k2a, k2b = rhs(cm, sm, fa + hh * k1a, fb + hh * k1b, iam, ibm)
            k3a, k3b = rhs(cm, sm, fa + hh * k2a, fb + hh * k2b, iam, ibm)
            k4a, k4b = rhs(c1, s1, fa + h * k3a, fb + h * k3b, isa0 + dia * t1, isb0 + dib * t1)
            fa += h / 6.0 * (k1a + 2.0 * (k2a + k3a) + k4a)
            fb += h / 6.0 * (k1b + 2.0 * (k2b + k3b) + k4b)
            c0, s0, t0 = c1, s1, t1
        self._pa, self._pb = c0 * fa - s0 * fb, s0 * fa + c0 * fb
        self._isa, self._isb, self._w = isa1, isb1, w1
        return (self._pa, self._pb)


__all__ = ["RotorFluxObserver"]
