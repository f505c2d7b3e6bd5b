"""Sampled speed-and-flux drives: the state machine around a control law.

A drive is called once per sample period ``Ts`` with the measurements and the raw
set-points, and returns the stator voltages to hold over the next period (zero-order
hold).  It owns every internal state (phase, reference shapers, load estimate, the
baseline's integrators), all exposed by ``get_state``/``set_state`` for FMU rollback.

Start from standstill (the backstepping law is singular at Phi_rd = 0; steps 1 and 2 are
:mod:`satmotor.control.startup`; the settings and the output record :mod:`satmotor.control.drive_config`):

1. *Pre-magnetization*: a proportional current loop with resistive feed-forward holds the
   stator current on the alpha axis at ``premag_boost`` times the magnetizing current of the
   flux set-point (``i_ref = min(boost I(psi_ref/k), I_max)``)::

       v_s_alpha = R_s i_ref + K_pm (i_ref - i_s_alpha),   v_s_beta = -K_pm i_s_beta

2. *Switch* when ``|psi_r| >= premag_fraction psi_ref`` (or after ``premag_time_max``): the
   flux shaper is put at the measured state ``(Phi_rd, Phi_rd', 0)`` with
   ``Phi_rd' = (R_r/l_r)(k m i_mu_d - Phi_rd)`` (:func:`satmotor.control.fo_model.flux_rate`) and the
   speed shaper at ``(omega_m, 0, 0)``, so that ``e1 = e2 = z1 = 0`` at the switch: the law
   takes over without a jump.

3. *Run*: with ``field_weakening`` the flux shaper's input is the set-point of
   :class:`satmotor.control.field_weakening.FieldWeakening` (``psi_ref`` itself while the steady
   voltage at ``psi_ref`` fits in ``fw_voltage_ratio V_dc/sqrt(3)``; lower above base speed), with
   ``flux_mode = loss_minimizing`` the rate-limited least-loss flux of
   :class:`satmotor.control.loss_min.LossMinimizer` at most that (the same torque and speed); references
   from the shapers (third-order, exact derivatives), the control law, and
   in the estimated-load mode ``theta_hat <- clip(theta_hat + Ts theta_hat', +-theta_max)``
   (forward Euler over the hold).  In the known-load mode the load torque input is taken as
   piecewise constant (dT_L/dt = 0: a difference quotient would turn a load step into a
   voltage spike).  The law's current bound is I_max lowered by the measured-current limiter
   (:mod:`satmotor.control.current_limit`); ``current_limited`` is also set while the measured |i_s|
   exceeds I_max.  With a delay (``delay_samples``, the host's ``host_delay_samples``), the law works on
   the state predicted n samples on and the references n samples ahead (:mod:`satmotor.control.delay`).
"""

from __future__ import annotations

import dataclasses
import math

from satmotor.control.backstepping import BacksteppingGains, ControllerConfig, control
from satmotor.control.current_limit import CurrentLimiter
from satmotor.control.delay import DelayCompensator
from satmotor.control.drive_config import (  # re-exported: the drive's callers import them from here
    FLUX_MODES,
    FLUX_SOURCES,
    HOST_DELAY_MAX,
    OBSERVERS,
    PREMAG,
    RUN,
    SPEED_SOURCES,
    DriveConfig,
    DriveOutput,
)
from satmotor.control.field_weakening import FieldWeakening
from satmotor.control.ifoc import IFOCController, IFOCGains
from satmotor.control.loss_min import LossMinimizer
from satmotor.control.measurements import (
    MEAS_I_S_A,
    MEAS_I_S_B,
    MEAS_OMEGA_M,
    MEAS_PSI_R_A,
    MEAS_PSI_R_B,
)
from satmotor.control.references import REF_RATE, REF_VALUE, ReferenceShaper
from satmotor.control.startup import premag_output, switch_now, switch_state
from satmotor.errors import ParameterError, require_number
from satmotor.estimation.flux_observer import ClosedLoopObserver
from satmotor.estimation.observer import RotorFluxObserver

__all__ = ["PREMAG", "RUN", "FLUX_MODES", "FLUX_SOURCES", "OBSERVERS", "SPEED_SOURCES", "HOST_DELAY_MAX",
           "DriveConfig", "DriveOutput", "BacksteppingDrive", "IFOCDrive"]

_SQRT3 = math.sqrt(3.0)


class _Drive:
    """Flux source, pre-magnetization, set-point checks, shapers and delay, shared by every law."""

    def __init__(self, params, Ts, V_dc, drive_cfg):
        self.params = params
        self.dcfg = drive_cfg = DriveConfig() if drive_cfg is None else drive_cfg
        require_number("Ts", Ts, 0)
        self.Ts = Ts
        self._V_max = V_dc / _SQRT3
        self._flux = ReferenceShaper(drive_cfg.ref_bandwidth)
        self._speed = ReferenceShaper(drive_cfg.ref_bandwidth)
        self._checked = (None, 0.0)  # last flux set-point checked, its magnetizing current
        self._n_switch = round(drive_cfg.premag_time_max / Ts)
        self._observer = self._cl = None
        if drive_cfg.flux_source == "observer":
            if drive_cfg.observer == "closed_loop":
                sensorless = drive_cfg.speed_source == "estimated"
                self._cl = ClosedLoopObserver(params, Ts, sensorless, drive_cfg.speed_bandwidth,
                                              drive_cfg.rs_adaptation, drive_cfg.rr_tracking)
                self._observer = self._cl
            else:
                self._observer = RotorFluxObserver(params, Ts)
        self._w_used = 0.0  # [rad/s] the speed of the last sample (not a state: set by every step)
        n_delay = drive_cfg.delay_samples + drive_cfg.host_delay_samples
        self._delay = DelayCompensator(params, Ts, n_samples=n_delay) if n_delay else None
        self._fw = (FieldWeakening(params, self._V_max, drive_cfg.fw_voltage_ratio, drive_cfg.ref_bandwidth)
                    if drive_cfg.field_weakening else None)
        self._lm = self._lm_fw = None
        if drive_cfg.flux_mode == "loss_minimizing":  # its torque and speed: the field weakening's
            self._lm = LossMinimizer(params, Ts, drive_cfg.flux_floor, drive_cfg.flux_rate_max,
                                     drive_cfg.loss_R_fe)
            self._lm_fw = self._fw if self._fw is not None else FieldWeakening(
                params, self._V_max, drive_cfg.fw_voltage_ratio, drive_cfg.ref_bandwidth)
        self._i_lim = drive_cfg.I_max  # [A] the law's current bound this sample (lower beyond breakdown)
        self._limiter = CurrentLimiter(drive_cfg.I_max, drive_cfg.current_limit_gain, Ts)
        self._p_hat = params  # the law's model with the tracked resistances (_law_params)
        self.warnings = self._limiter.warnings  # messages for the host's log (the FMU glue takes them)
        self.reset()

    @property
    def V_max(self):
        """Largest stator voltage magnitude [V] the law may apply: V_dc / sqrt(3)."""
        return self._V_max

    def set_link_voltage(self, V_dc):
        """Bound the voltage by a measured DC-link voltage ``V_dc`` [V] > 0 from the next sample on:
        ``V_max = V_dc / sqrt(3)`` for the pre-magnetization, the law and the field weakening (the plant's
        link voltage, read by the controller unit's ``v_dc`` input; C: ``sm_drive_set_link_voltage``)."""
        self._V_max = V_max = V_dc / _SQRT3
        if self._fw is not None:  # as FieldWeakening.__init__
            self._fw.V_lim = V_max * self.dcfg.fw_voltage_ratio
            self._fw.V_bd = 0.5 * (self._fw.V_lim + V_max)
        self._set_law_voltage(V_dc)

    def reset(self):
        self._phase = PREMAG
        self._n = 0
        self._limiter.reset()
        if self._lm is not None:
            self._lm.reset()
        self._flux.reset(0.0)
        self._speed.reset(0.0)
        if self._observer is not None:
            self._observer.reset()
        if self._delay is not None:
            self._delay.reset()
        self._reset_law()

    def magnetizing_current(self, psi_ref):
        """Steady magnetizing current [A] for a rotor flux set-point [Wb]; error beyond I_max."""
        checked_psi, checked_I = self._checked
        if psi_ref == checked_psi:
            return checked_I
        require_number("psi_ref", psi_ref, 0)
        p = self.params
        I = p.curve.current(psi_ref / p.k)
        if I > self.dcfg.I_max:
            raise ParameterError(
                "psi_ref", psi_ref,
                f"needs a magnetizing current of {I:.4g} A on the '{p.curve.name}' curve, "
                f"more than I_max = {self.dcfg.I_max!r} A",
            )
        self._checked = (psi_ref, I)
        return I

    def step(self, meas, omega_ref, psi_ref, T_load):
        """One sample (see :meth:`_step`); the closed-loop observer learns the voltage applied next."""
        out = self._step(meas, omega_ref, psi_ref, T_load)
        if self.dcfg.rs_adaptation and not (out.phase != RUN or out.voltage_limited or out.current_limited):
            self._cl.adapt_resistance()  # held while a limit is active or before the law runs
        if self._cl is not None:  # the voltage over the coming sample: with a delay, the queue's first
            v = (out.v_s_alpha, out.v_s_beta) if self._delay is None else self._delay.applied_now
            self._cl.applied(*v)
        return out

    @property
    def resistances(self):
        """(R_s_hat, R_r_hat) [Ohm]: the closed-loop observer's estimates after the last sample, the model's
        R_s, R_r where not adapted (C: ``sm_drive_output.R_s_hat``, ``R_r_hat``)."""
        return (self.params.R_s, self.params.R_r) if self._cl is None else self._cl.resistances

    def _law_params(self):
        """The model the law uses: the given one, or with the tracked R_s, R_r (rs_adaptation)."""
        if not self.dcfg.rs_adaptation:
            return self.params
        rs, rr = self._cl.resistances
        if self._p_hat.R_s != rs or self._p_hat.R_r != rr:
            self._p_hat = dataclasses.replace(self.params, R_s=rs, R_r=rr)
        return self._p_hat

    @property
    def omega_m_hat(self):
        """The speed [rad/s] the last sample used: the observer's estimate (speed_source estimated) or
        the omega_m measurement (C: ``sm_drive_output.omega_m_hat``)."""
        return self._w_used

    def _step(self, meas, omega_ref, psi_ref, T_load):
        """One sample: ``meas`` the measurement tuple of :mod:`satmotor.control.measurements`
        [A, A, Wb, Wb, Wb, Wb, rad/s] (the controller unit's input order); the raw set-points
        ``omega_ref`` [rad/s], ``psi_ref`` [Wb] (shaped inside: ``omega_ref_shaped``,
        ``psi_ref_shaped``); load torque [N m].
        Returns a :class:`DriveOutput`."""
        I_set = self.magnetizing_current(psi_ref)
        require_number("omega_ref", omega_ref)
        if self._cl is not None:  # the psi inputs (and with speed_source estimated omega_m) are ignored
            pa, pb, w = self._cl.update(meas[MEAS_I_S_A], meas[MEAS_I_S_B], meas[MEAS_OMEGA_M])
            meas = (meas[MEAS_I_S_A], meas[MEAS_I_S_B], pa, pb, 0.0, 0.0, w)  # MEAS_* order
        elif self._observer is not None:  # the psi inputs are ignored: the estimate replaces them
            pa, pb = self._observer.update(meas[MEAS_I_S_A], meas[MEAS_I_S_B], meas[MEAS_OMEGA_M])
            meas = (meas[MEAS_I_S_A], meas[MEAS_I_S_B], pa, pb, 0.0, 0.0, meas[MEAS_OMEGA_M])  # MEAS_* order
        self._w_used = meas[MEAS_OMEGA_M]
        if self._phase == PREMAG:
            phi = math.hypot(meas[MEAS_PSI_R_A], meas[MEAS_PSI_R_B])
            if not switch_now(self.dcfg, phi, psi_ref, meas[MEAS_OMEGA_M], self._n, self._n_switch):
                self._n += 1
                out = premag_output(self.params, self.dcfg, meas, I_set, phi, psi_ref, self._V_max,
                                    self._speed.value[REF_VALUE], self._flux.value[REF_VALUE])
                return self._delayed(out)
            self._switch(meas)
        i_meas = math.hypot(meas[MEAS_I_S_A], meas[MEAS_I_S_B])  # the measured current (never predicted)
        self._i_lim = self._limiter.bound(i_meas)
        if self._lm is not None:  # the least loss within the nominal (or field-weakening) flux
            fw = self._lm_fw
            T, w = fw.torque(meas), meas[MEAS_OMEGA_M] + fw.lead * self._speed.value[REF_RATE]
            if self._fw is not None:
                psi_ref, self._i_lim = fw.set_points(T, w, psi_ref, self._i_lim)
            psi_ref = self._lm.set_point(T, w, psi_ref, self._i_lim)
        elif self._fw is not None:  # the nominal flux, or lower where the voltage does not suffice
            psi_ref, self._i_lim = self._fw.flux_reference(meas, self._speed.value[REF_RATE], psi_ref,
                                                           self._i_lim)
        if self._delay is None:
            out = self._run(meas, self._flux.value, self._speed.value, T_load)
            self._flux.step(psi_ref, self.Ts)
            self._speed.step(omega_ref, self.Ts)
        else:  # the command takes effect n samples on: the state and the references there
            pred = self._delay.predict(meas, self._model_load(T_load))
            self._flux.step(psi_ref, self.Ts)
            self._speed.step(omega_ref, self.Ts)
            ref_flux, ref_speed = self._ahead(self._flux, psi_ref), self._ahead(self._speed, omega_ref)
            out = self._delayed(self._run(pred, ref_flux, ref_speed, T_load))
        if i_meas > self.dcfg.I_max and not out.current_limited:  # the measured current is over its limit
            out = out._replace(current_limited=True)
        return out

    def _ahead(self, shaper, u):
        """The shaper's ``(r, r', r'')`` n - 1 samples after its present state (the raw set-point ``u``
        held), its state untouched: the references at the instant the command takes effect."""
        n = self._delay.n
        if n == 1:
            return shaper.value
        z = shaper.get_state()
        for _ in range(n - 1):
            shaper.step(u, self.Ts)
        ahead = shaper.value
        shaper.set_state(z)
        return ahead

    def _delayed(self, out):
        if self._delay is None:
            return out
        va, vb = self._delay.push(out.v_s_alpha, out.v_s_beta, self.dcfg.delay_samples == 1)
        return out._replace(v_s_alpha=va, v_s_beta=vb)

    def _switch(self, meas):
        flux_state, ms = switch_state(self.params, meas)
        self._flux.set_state(flux_state)
        if self._lm is not None:  # the loss minimizer's rate limit starts at the measured flux
            self._lm.reset(flux_state[0])
        self._speed.reset(meas[MEAS_OMEGA_M])
        self._phase = RUN
        self._on_switch(ms)

    def _model_load(self, T_load):
        """Load torque [N m] the law's model assumes (used by the delay compensation)."""
        return 0.0

    def get_state(self):
        """Every internal state as a flat tuple of floats: phase, pre-magnetization sample count,
        the flux and speed shapers' (r, r', r''), the observer's and the delay's states (when
        configured), the law's own states, then the measured-current limiter's reduction [A] and whether
        its warning was logged, then (flux_mode loss_minimizing) the rate-limited flux set-point [Wb]."""
        obs = () if self._observer is None else self._observer.get_state()
        dly = () if self._delay is None else self._delay.get_state()
        lm = () if self._lm is None else (self._lm.psi,)
        return (float(self._phase), float(self._n)) + self._flux.get_state() + \
            self._speed.get_state() + tuple(obs) + tuple(dly) + self._law_state() + \
            self._limiter.get_state() + lm

    def set_state(self, state):
        """Restore a tuple from :meth:`get_state`."""
        s = tuple(float(v) for v in state)
        if self._lm is not None:
            self._lm.psi, s = s[-1], s[:-1]
        self._phase, self._n = int(s[0]), int(s[1])
        self._flux.set_state(s[2:5])
        self._speed.set_state(s[5:8])
        i = 8
        if self._observer is not None:
            n = len(self._observer.get_state())
            self._observer.set_state(s[i:i + n])
            i += n
        if self._delay is not None:
            n = self._delay.state_size()
            self._delay.set_state(s[i:i + n])
            i += n
        self._set_law_state(s[i:-2])
        self._limiter.set_state(s[-2:])


class BacksteppingDrive(_Drive):
    """The seed's backstepping law (eq 67, corrected) in a sampled drive.

    Parameters
    ----------
    params : MotorParams
        The controller's model; a ``LinearCurve`` gives the constant-m baseline.
    gains : BacksteppingGains
    cfg : ControllerConfig
        Sample period, V_dc, load mode (known/estimated) and the adaptation settings.
    drive_cfg : DriveConfig
    """

    def __init__(self, params, gains=None, cfg=None, drive_cfg=None):
        self.gains = BacksteppingGains() if gains is None else gains
        self.cfg = ControllerConfig() if cfg is None else cfg
        if self.cfg.Ts <= 0:
            raise ParameterError("Ts", self.cfg.Ts, "must be > 0 for a sampled drive")
        super().__init__(params, self.cfg.Ts, self.cfg.V_dc, drive_cfg)
        if self.cfg.true_i_mu and (self.dcfg.flux_source == "observer" or self.dcfg.delay_samples):
            raise ParameterError("true_i_mu", True, "is a comparison setting of the plain loop: not with "
                                 "the observer or the delay compensation")

    def _reset_law(self):
        self._theta_hat = 0.0
        self._e0 = self._z0 = 0.0

    def _set_law_voltage(self, V_dc):
        self.cfg = dataclasses.replace(self.cfg, V_dc=V_dc)

    def _on_switch(self, ms):
        pass

    def _law_state(self):
        return (self._theta_hat, self._e0, self._z0)

    def _set_law_state(self, s):
        self._theta_hat, self._e0, self._z0 = s

    def _model_load(self, T_load):
        return self._theta_hat * self.params.J if self.cfg.load_mode == "estimated" else T_load

    def _run(self, meas, psi_ref_shaped, omega_ref_shaped, T_load):
        cfg, p = self.cfg, self._law_params()
        o = control(meas, psi_ref_shaped + omega_ref_shaped, (T_load, 0.0), p, self.gains, cfg,
                    self._theta_hat, (self._e0, self._z0), self._i_lim)
        if cfg.load_mode == "estimated":
            t_load = self._theta_hat * p.J
            th = self._theta_hat + cfg.Ts * o.theta_hat_dot
            self._theta_hat = min(max(th, -cfg.theta_max), cfg.theta_max)
        else:
            t_load = T_load
        self._e0 += cfg.Ts * o.e0_dot
        self._z0 += cfg.Ts * o.z0_dot
        return DriveOutput(o.v_s_alpha, o.v_s_beta, o.v_sd, o.v_sq, o.e1, o.e2, o.z1, o.z2, o.V, o.W,
                           t_load, omega_ref_shaped[REF_VALUE], psi_ref_shaped[REF_VALUE], RUN,
                           o.voltage_limited, o.singular_limited, o.current_limited, meas[MEAS_PSI_R_A],
                           meas[MEAS_PSI_R_B])


class IFOCDrive(_Drive):
    """The indirect field-oriented PI baseline (:mod:`satmotor.control.ifoc`) in the same drive frame:
    same pre-magnetization and shaped references; the PI loops see only currents and speed.

    ``L_m`` [H]: the loops' constant magnetizing inductance; None (the controller FMU's ``mode: pi``)
    takes, at each switch to the loops, the secant inductance of the controller's curve at the raw
    flux set-point of that sample, ``(psi_ref / k) / curve.current(psi_ref / k)`` (the nominal flux:
    the field weakening only moves the shaper's input), and holds it."""

    def __init__(self, params, gains=None, Ts=1e-4, L_m=None, drive_cfg=None):
        self.ifoc = IFOCController(params, IFOCGains() if gains is None else gains, Ts, L_m)
        self._L_m_auto = L_m is None
        super().__init__(params, Ts, self.ifoc.gains.V_dc, drive_cfg)

    def _reset_law(self):
        self.ifoc.reset()

    def _set_law_voltage(self, V_dc):
        self.ifoc.set_link_voltage(V_dc)

    def _on_switch(self, ms):
        if self._L_m_auto:  # _checked: the raw set-point of this sample and its magnetizing current
            psi_n, I_n = self._checked
            self.ifoc.set_inductance(psi_n / self.params.k / I_n)
        self.ifoc.reset(theta_f=ms.rho, phi_r=ms.Phi_rd)

    def _law_state(self):
        return self.ifoc.get_state() + (self.ifoc.L_m,)

    def _set_law_state(self, s):
        if s[5] != self.ifoc.L_m:
            self.ifoc.set_inductance(s[5])
        self.ifoc.set_state(s[:5])

    def _run(self, meas, psi_ref_shaped, omega_ref_shaped, T_load):
        # the shaped references' values only (the PI loops use no derivatives)
        omega_ref_shaped, psi_ref_shaped = omega_ref_shaped[REF_VALUE], psi_ref_shaped[REF_VALUE]
        w = meas[MEAS_OMEGA_M]
        va, vb, d = self.ifoc(meas[MEAS_I_S_A], meas[MEAS_I_S_B], w, omega_ref_shaped, psi_ref_shaped)
        # diagnostics only: the PI loops never see the flux
        e1 = math.hypot(meas[MEAS_PSI_R_A], meas[MEAS_PSI_R_B]) - psi_ref_shaped
        return DriveOutput(va, vb, d.v_sd, d.v_sq, e1, 0.0, w - omega_ref_shaped, 0.0, 0.0, 0.0, 0.0,
                           omega_ref_shaped, psi_ref_shaped, RUN, d.voltage_limited, False, d.current_limited,
                           meas[MEAS_PSI_R_A], meas[MEAS_PSI_R_B])
