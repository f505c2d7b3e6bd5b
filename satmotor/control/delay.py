"""The one-sample computational delay of a digital drive, and its compensation by prediction.

A drive that samples at ``t_k`` and needs most of the period to compute applies its voltage at
``t_{k+1}`` (``delay_samples = 1``): the voltage computed from the samples at ``t_k`` is held over
``[t_{k+1}, t_{k+2})``, while the voltage computed at ``t_{k-1}`` (the *pending* one) is held over
``[t_k, t_{k+1})``.  A law fed with the samples of ``t_k`` would act one period late; at 10 kHz that
is 0.03 rad of the 50 Hz field and a third of the inner loops' 1/c2 = 1 ms.

Compensation: the law is fed the state *predicted* at ``t_{k+1}``, the instant its voltage takes
effect.  The prediction integrates the controller's own stationary-frame model
(:class:`satmotor.machine.plant.Plant` with the controller's parameters, one RK4 step of ``Ts``) from the
sampled state under the pending voltage and the load the law believes in.  The stator flux the
model needs is rebuilt from the samples, ``psi_s = l_s i_s + m(|i_mu|) i_mu`` with i_mu from
:func:`satmotor.control.measurements.from_rotor_flux`.

A model error (the plant's R_s, R_r or curve differ from the controller's, an unknown load)
biases every prediction by about ``Ts`` times the error in the derivatives, and a steady bias in
the predicted speed or flux is a steady error of the drive (the law, its integral action included,
regulates the prediction).  So the prediction carries a correction ``c``, a low-pass estimate of the
last prediction errors ``e_k = y_k - yhat_k`` (measured minus predicted at ``t_k``):
``c <- c + bias_gain (e_k - c)``, ``yhat_{k+1} = f(y_k, v_pending) + c``.  In steady state ``c``
equals the bias and the prediction of a constant signal is exact.  The vectors (i_s, psi_r) are
corrected in the rotor-flux frame, where a steady state is constant (their error is rotated by
``-rho_k`` before the filter and the correction by ``+rho_{k+1}`` after it); the speed is a scalar.
``bias_gain`` = 0.05 per sample (time constant 20 samples, 2 ms at 10 kHz) keeps the correction
slow against the inner loops and passes only 1/39 of white measurement noise's variance.

A host's coupling delay: a Jacobi master (SSP tools, libcosim) gives the plant over ``[t_k, t_{k+1})``
the output the controller produced at the *previous* exchange, one sample more (``host_delay_samples =
1``).  The controller knows the voltages it produced, so ``n = delay_samples + host_delay_samples``
samples are compensated alike: the queue holds the ``n`` voltages that act over ``[t_k, t_{k+n})`` in
their order, and the prediction is ``n`` corrected one-sample steps, each from the corrected tuple of
the one before (its stator flux rebuilt from i_s and psi_r as above), under the queue's voltage of its
interval.  The correction still learns from one-sample predictions (the first step's, against the next
sample): its estimate of the bias per sample is added after every step.  Only the controller's own
delay (``delay_samples``) holds its output back; the host's delay is the host's.
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
from satmotor.errors import require_integer, require_number
from satmotor.machine.plant import OMEGA_M, PSI_R_A, PSI_R_B, PSI_S_A, PSI_S_B, Plant

# state layout: the queued voltages (2 per sample), last prediction (5) and its valid flag, correction (5)
N_STATE = 13  # with n_samples = 1 (:meth:`DelayCompensator.state_size` in general)


class DelayCompensator:
    """Holds the pending voltage and predicts the sampled state one period ahead (SI units).

    Parameters
    ----------
    params : MotorParams
        The controller's model.
    Ts : float
        Sample period [s].
    bias_gain : float
        [1] per-sample gain of the prediction-error correction (0 turns it off).
    n_samples : int
        Samples from a voltage's computation to its effect (``delay_samples + host_delay_samples``), >= 1.
    """

    def __init__(self, params, Ts, bias_gain=0.05, n_samples=1):
        self.params = params
        self.Ts = require_number("Ts", Ts, 0)
        self.bias_gain = require_number("bias_gain", bias_gain, 0, upper=1, inclusive=True)
        self.n = require_integer("n_samples", n_samples, 1)
        self._plant = Plant(params)
        self.reset()

    def reset(self):
        self.queue = ((0.0, 0.0),) * self.n  # [V] the voltages over [t_k, t_k+1), ..., [t_k+n-1, t_k+n)
        self.applied_now = (0.0, 0.0)  # [V] the voltage over [t_k, t_k+1) at the last push
        self._pred = None  # (i_sd, i_sq, psi_rd, psi_rq, omega) predicted for this sample, flux frame
        self._corr = (0.0,) * 5

    def push(self, v_alpha, v_beta, hold):
        """Queue the voltage [V] just computed (it acts n samples on); return the controller's output:
        with ``hold`` (its own one-sample delay) the voltage computed one sample earlier, else this one."""
        q = self.queue
        self.applied_now = q[0]
        self.queue = q[1:] + ((v_alpha, v_beta),)
        return q[-1] if hold else (v_alpha, v_beta)

    def swap(self, v_alpha, v_beta):
        """Store the voltage [V] just computed; return the one to apply now (``push`` with ``hold``)."""
        return self.push(v_alpha, v_beta, True)

    def state_size(self):
        """Length of :meth:`get_state`: ``2 n + 11``."""
        return 2 * self.n + 11

    def predict(self, meas, T_load):
        """The measurement tuple (layout of :mod:`satmotor.control.measurements`) predicted n samples on
        under the queued voltages, with the load torque ``T_load`` [N m] held."""
        i_a, i_b, w = meas[MEAS_I_S_A], meas[MEAS_I_S_B], meas[MEAS_OMEGA_M]
        pr_a, pr_b = meas[MEAS_PSI_R_A], meas[MEAS_PSI_R_B]
        phi = math.hypot(pr_a, pr_b)
        c, s = (pr_a / phi, pr_b / phi) if phi > 0.0 else (1.0, 0.0)
        if self._pred is not None and self.bias_gain > 0.0:  # correction, in this sample's flux frame
            y = (c * i_a + s * i_b, c * i_b - s * i_a, phi, 0.0, w)
            g = self.bias_gain
            self._corr = tuple(ck + g * (yk - pk - ck) for yk, pk, ck in zip(y, self._pred, self._corr))
        out = meas
        for j, (va, vb) in enumerate(self.queue):
            pred, out = self._step(out, va, vb, T_load)
            if j == 0:
                self._pred = pred  # the one-sample prediction: the correction learns from it
        return out

    def _step(self, meas, va, vb, T_load):
        """One corrected sample ahead of ``meas`` under ``(va, vb)`` [V]: (the raw prediction in its
        flux frame, the corrected measurement tuple)."""
        p = self.params
        i_a, i_b, w = meas[MEAS_I_S_A], meas[MEAS_I_S_B], meas[MEAS_OMEGA_M]
        pr_a, pr_b = meas[MEAS_PSI_R_A], meas[MEAS_PSI_R_B]
        phi = math.hypot(pr_a, pr_b)
        c, s = (pr_a / phi, pr_b / phi) if phi > 0.0 else (1.0, 0.0)
        ms = from_rotor_flux(i_a, i_b, pr_a, pr_b, p)
        x = (p.l_s * i_a + ms.m * ms.i_mu_alpha, p.l_s * i_b + ms.m * ms.i_mu_beta, pr_a, pr_b, w, 0.0)
        x1 = self._plant.step(0.0, x, va, vb, T_load, self.Ts, 1)
        o = self._plant.outputs(x1)
        qa, qb = x1[PSI_R_A], x1[PSI_R_B]
        phi1 = math.hypot(qa, qb)
        c1, s1 = (qa / phi1, qb / phi1) if phi1 > 0.0 else (c, s)
        pred = (c1 * o.i_s_alpha + s1 * o.i_s_beta, c1 * o.i_s_beta - s1 * o.i_s_alpha, phi1, 0.0,
                x1[OMEGA_M])
        d, q, pd, pq, wc = (v + ck for v, ck in zip(pred, self._corr))
        return pred, (c1 * d - s1 * q, s1 * d + c1 * q, c1 * pd - s1 * pq, s1 * pd + c1 * pq,
                      x1[PSI_S_A], x1[PSI_S_B], wc)  # the order of satmotor.control.measurements

    def get_state(self):
        pred = (0.0,) * 5 + (0.0,) if self._pred is None else self._pred + (1.0,)
        return tuple(v for pair in self.queue for v in pair) + pred + self._corr

    def set_state(self, s):
        n2 = 2 * self.n
        self.queue = tuple((s[2 * j], s[2 * j + 1]) for j in range(self.n))
        self._pred = tuple(s[n2:n2 + 5]) if s[n2 + 5] else None
        self._corr = tuple(s[n2 + 6:n2 + 11])
