"""Loss-minimizing rotor-flux set-point on the magnetizing curve (``flux_mode = loss_minimizing``; SI units).

The steady state of the control model at the torque ``T`` [N m] and the speed ``omega_m`` [rad/s] is
parametrized by the magnetizing current ``I = |i_mu|`` on the flux-axis root, as in
:mod:`satmotor.control.field_weakening` (``psi_m = curve.psi(I)``, ``m = psi_m / I``,
``psi_md psi_mq = c = T l_r / (kappa k^2)``, ``Phi = k psi_md``)::

    i_s   = (1 + k^2 m / l_r) i_mu - (k / l_r) Phi e_d,     i_r = (0, -(k m / l_r) i_mu_q)
    psi_s = (l_s + sigma m) i_mu - (k l_s / l_r) Phi e_d,   omega_s = n_p omega_m + R_r k m i_mu_q / (l_r Phi)
    e_s = j omega_s psi_s,   i_s,term = i_s + e_s / R_fe
    P(I)  = 3/2 (R_s |i_s,term|^2 + R_r |i_r|^2 + |e_s|^2 / R_fe)

the stator and rotor copper losses and the core loss of a resistance ``R_fe`` across the stator emf
``e_s`` (the plant's placement: its current adds to the terminal current, and so to the stator copper
loss; ``loss_R_fe = 0``: copper only, ``i_s,term = i_s``).  ``|i_s,term|`` is the current the limit
bounds.  Only the flux-axis root
(``psi_md >= |psi_mq|``) is searched: its mirror with the same ``|i_mu|`` and torque puts more of the
magnetizing current on the q axis, where it is rotor current, and loses more.

:meth:`LossMinimizer.optimum`: the bracket in ``I`` from the flux floor (or, if the floor lies below the
flux-axis root, from ``psi_m = sqrt(2 |c|)``, the root's least flux) to the upper flux ``psi_hi`` (the
field weakening's set-point, i.e. the nominal ``psi_ref`` below base speed), two curve inversions; then
``N_GOLDEN`` golden-section steps on ``P(I)`` (one curve evaluation each, no inversion), a fixed count:
the bracket shrinks to ``0.618^N_GOLDEN`` (4.6e-4) of its width, deterministic and the same floats in C.
A point whose ``|i_s|`` exceeds the law's current bound is penalized
(``P (1 + PENALTY (|i_s| / i_lim - 1))``): the search keeps to the current limit where it can.  The result
is the flux of the best of the two last points and the bracket's ends (evaluated first: an optimum on a
bound is found exactly), within ``[flux_floor, psi_hi]``.

:meth:`LossMinimizer.set_point`: the optimum, rate limited by ``flux_rate_max`` [Wb/s = V s/s] (a state,
started at the measured flux at the switch to the law), then ``min(., psi_hi)``: the field weakening
lowers the flux at once, the loss minimizer moves it at most ``flux_rate_max Ts`` a sample.
"""

from __future__ import annotations

import math

N_GOLDEN = 16  # golden-section steps: the bracket in I shrinks to 0.618^16 = 4.6e-4 of its width
GOLDEN = 0.6180339887498949  # (sqrt(5) - 1) / 2
PENALTY = 1e3  # [1] per unit of |i_s| above the current bound


def steady_losses(params, I, T, omega_m, R_fe):
    """``(Phi, P, |i_s|)`` [Wb, W, A]: the steady state's rotor flux, modelled loss and stator current at
    the magnetizing current ``I`` [A] > 0, torque ``T`` [N m] and speed ``omega_m`` [rad/s] (module
    docstring), the core-loss resistance ``R_fe`` [Ohm] (0: none); None where the flux-axis root does
    not exist."""
    k, l_r = params.k, params.l_r
    psi = params.curve.psi(I)
    c = T * l_r / (1.5 * params.n_p * k * k)
    disc = psi * psi * psi * psi - 4.0 * c * c
    if not disc >= 0.0:
        return None
    pmd = math.sqrt(0.5 * (psi * psi + math.sqrt(disc)))
    m = psi / I
    Phi = k * pmd
    imd, imq = pmd / m, c / pmd / m
    cc = 1.0 + k * k * m / l_r
    k_lr = k / l_r
    i_sd, i_sq = cc * imd - k_lr * Phi, cc * imq
    i_rq = k_lr * m * imq
    if R_fe > 0.0:  # the terminal current: the core branch's e_s / R_fe beside the leakage's
        l_s = params.l_s
        L = l_s + params.sigma * m
        psd, psq = L * imd - l_s * k_lr * Phi, L * imq
        ws = params.n_p * omega_m + params.R_r * k * m * imq / (l_r * Phi)
        ed, eq = -ws * psq, ws * psd
        i_sd, i_sq = i_sd + ed / R_fe, i_sq + eq / R_fe
        P = params.R_s * (i_sd * i_sd + i_sq * i_sq) + params.R_r * (i_rq * i_rq) + (ed * ed + eq * eq) / R_fe
    else:
        P = params.R_s * (i_sd * i_sd + i_sq * i_sq) + params.R_r * (i_rq * i_rq)
    return Phi, 1.5 * P, math.hypot(i_sd, i_sq)


class LossMinimizer:
    """The loss-minimizing flux set-point (module docstring).

    Parameters
    ----------
    params : MotorParams
        The controller's model (its curve: the saturation the optimum sees).
    Ts : float
        [s] sample period.
    floor : float
        [Wb] the lowest flux set-point (``flux_floor``), > 0.
    rate : float
        [Wb/s] the set-point's largest rate of change (``flux_rate_max``), > 0.
    R_fe : float
        [Ohm] core-loss resistance of the loss model (``loss_R_fe``), >= 0; 0: copper loss only.
    """

    def __init__(self, params, Ts, floor, rate, R_fe):
        self.params = params
        self.floor = floor
        self.d_max = rate * Ts  # [Wb] the most the set-point moves in a sample
        self.R_fe = R_fe
        self.psi = 0.0  # [Wb] the rate-limited set-point (state)

    def reset(self, psi=0.0):
        """Put the rate-limited set-point at ``psi`` [Wb] (the measured flux at the switch)."""
        self.psi = psi

    def _loss(self, I, T, omega, i_lim):
        pt = steady_losses(self.params, I, T, omega, self.R_fe)
        if pt is None:
            return math.inf, 0.0
        Phi, P, i_s = pt
        if i_s > i_lim:
            P *= 1.0 + PENALTY * (i_s / i_lim - 1.0)
        return P, Phi

    def optimum(self, T, omega, psi_hi, i_lim=math.inf):
        """The flux [Wb] in ``[floor, psi_hi]`` of the least modelled loss at the torque ``T`` [N m] and the
        speed ``omega`` [rad/s] with the stator current bound ``i_lim`` [A] (``psi_hi`` itself when
        ``psi_hi <= floor`` or when the flux-axis root has no flux up to ``psi_hi``)."""
        p, floor = self.params, self.floor
        if psi_hi <= floor:
            return psi_hi
        k = p.k
        c = T * p.l_r / (1.5 * p.n_p * k * k)
        ac = abs(c)
        pmd = psi_hi / k
        if pmd * pmd <= ac:
            return psi_hi
        b = p.curve.current(math.hypot(pmd, c / pmd))
        pmd = floor / k
        a = p.curve.current(math.hypot(pmd, c / pmd) if pmd * pmd >= ac else math.sqrt(2.0 * ac))
        fa, phia = self._loss(a, T, omega, i_lim)  # the ends: an optimum on a bound is found exactly
        fb, phib = self._loss(b, T, omega, i_lim)
        g = GOLDEN
        x1, x2 = b - g * (b - a), a + g * (b - a)
        f1, phi1 = self._loss(x1, T, omega, i_lim)
        f2, phi2 = self._loss(x2, T, omega, i_lim)
        for _ in range(N_GOLDEN):
            if f1 < f2:
                b, x2, f2, phi2 = x2, x1, f1, phi1
                x1 = b - g * (b - a)
                f1, phi1 = self._loss(x1, T, omega, i_lim)
            else:
                a, x1, f1, phi1 = x1, x2, f2, phi2
                x2 = a + g * (b - a)
                f2, phi2 = self._loss(x2, T, omega, i_lim)
        f, Phi = (f1, phi1) if f1 < f2 else (f2, phi2)
        if fa < f:
            f, Phi = fa, phia
        if fb < f:
            f, Phi = fb, phib
        if not f < math.inf:
            return psi_hi
        return min(max(Phi, floor), psi_hi)

    def set_point(self, T, omega, psi_hi, i_lim=math.inf):
        """The rate-limited optimum [Wb] (module docstring), ``min(., psi_hi)``; advances the state."""
        d = self.d_max
        s = self.psi
        s = min(max(self.optimum(T, omega, psi_hi, i_lim), s - d), s + d)
        self.psi = s
        return min(s, psi_hi)


__all__ = ["GOLDEN", "N_GOLDEN", "PENALTY", "LossMinimizer", "steady_losses"]
