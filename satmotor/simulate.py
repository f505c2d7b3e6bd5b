"""Plain-Python closed loop (no FMI): the reference every FMU and co-simulation run is compared with.

Timing: samples at ``t_k = t0 + k Ts`` (never accumulated).  At ``t_k`` the drive reads the
plant state (currents, fluxes, speed), the set-points and the load torque at ``t_k``; its
voltages are held over ``[t_k, t_k + Ts)`` while the plant is integrated by RK4 in ``n_sub``
sub-steps, with the load torque held as well.  Row k of the result holds the state at
``t_k`` and the drive's output computed there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from satmotor.machine.plant import N_STATES, OMEGA_M, PSI_R_A, PSI_R_B, PSI_S_A, PSI_S_B, THETA_M, Plant

RECORDED = ("t", "v_s_alpha", "v_s_beta", "v_sd", "v_sq", "T_load", "omega_ref", "psi_ref",
            "omega_ref_shaped", "psi_ref_shaped", "i_s_alpha", "i_s_beta", "psi_s_alpha", "psi_s_beta",
            "psi_r_alpha", "psi_r_beta", "omega_m", "theta_m", "T_e", "i_mu", "psi_r_mag",
            "e1", "e2", "z1", "z2", "V", "W", "T_load_est", "phase", "voltage_limited",
            "singular_limited", "current_limited", "psi_r_hat_alpha", "psi_r_hat_beta", "omega_m_hat",
            "R_s_hat", "R_r_hat")


def _as_profile(v):
    return v if callable(v) else (lambda t, _c=float(v): _c)


def closed_loop(plant_params, drive, t_end, omega_ref, psi_ref, T_load=0.0, n_sub=1, x0=None,
                t0=0.0, record_every=1, plant_steps=1):
    """Simulate the plant under a sampled drive.

    Parameters
    ----------
    plant_params : MotorParams
        The plant (may differ from the drive's model: mismatch studies).
    drive : satmotor.control.drive.BacksteppingDrive or IFOCDrive
        Called every ``drive.Ts`` [s].
    t_end : float
        Stop time [s] (``round((t_end - t0) / Ts)`` samples).
    omega_ref, psi_ref, T_load : float or callable t -> float
        Raw speed set-point [rad/s], rotor flux set-point [Wb], load torque [N m].
    n_sub : int
        RK4 sub-steps of each plant step.
    plant_steps : int
        Plant steps per sample (the co-simulation master's ``controller_every``): the plant is
        stepped ``plant_steps`` times by ``h = Ts / plant_steps`` with the load torque sampled
        at each plant step ``t0 + j h``; the set-points are sampled with the controller.
    x0 : tuple, optional
        Initial plant state (default: at rest, unmagnetized).

    Returns
    -------
    dict of numpy arrays, keys :data:`RECORDED`, one row every ``record_every`` samples,
    plus ``"x_end"`` (the final plant state, a tuple).
    """
    plant = Plant(plant_params)
    omega_ref_at, psi_ref_at, load = _as_profile(omega_ref), _as_profile(psi_ref), _as_profile(T_load)
    Ts = drive.Ts
    h = Ts / plant_steps
    n = round((t_end - t0) / Ts)
    rows = n // record_every + 1
    rec = {k: np.empty(rows) for k in RECORDED}
    x = tuple(x0) if x0 is not None else (0.0,) * N_STATES
    r = 0
    for k in range(n + 1):
        t = t0 + k * Ts
        o = plant.outputs(x)
        psa, psb, pra, prb, w = x[PSI_S_A], x[PSI_S_B], x[PSI_R_A], x[PSI_R_B], x[OMEGA_M]
        # layout of satmotor.control.measurements, the plant's true i_mu last (the design comparison)
        meas = (o.i_s_alpha, o.i_s_beta, pra, prb, psa, psb, w, o.i_mu_alpha, o.i_mu_beta)
        omega_ref, psi_ref, tl = omega_ref_at(t), psi_ref_at(t), load(t)
        d = drive.step(meas, omega_ref, psi_ref, tl)
        if k % record_every == 0:
            row = (t, d.v_s_alpha, d.v_s_beta, d.v_sd, d.v_sq, tl, omega_ref, psi_ref, d.omega_ref_shaped,
                   d.psi_ref_shaped,
                   o.i_s_alpha, o.i_s_beta, psa, psb, pra, prb, w, x[THETA_M], o.T_e, o.i_mu,
                   (pra * pra + prb * prb) ** 0.5, d.e1, d.e2, d.z1, d.z2, d.V, d.W,
                   d.T_load_est, d.phase, d.voltage_limited, d.singular_limited, d.current_limited,
                   d.psi_r_hat_alpha, d.psi_r_hat_beta, drive.omega_m_hat, *drive.resistances)
            for key, v in zip(RECORDED, row):
                rec[key][r] = v
            r += 1
        if k < n:
            if plant_steps == 1:
                x = plant.step(t, x, d.v_s_alpha, d.v_s_beta, tl, Ts, n_sub)
            else:
                for j in range(plant_steps):
                    tj = t0 + (k * plant_steps + j) * h
                    x = plant.step(tj, x, d.v_s_alpha, d.v_s_beta, load(tj), h, n_sub)
    rec["x_end"] = x
    return rec


@dataclass(frozen=True)
class RampScenario:
    """The default closed-loop scenario: pre-magnetization from rest, a flux set-point, a speed
    ramp and a load-torque step (SI units)."""

    psi_ref: float = 0.95  # [Wb] rotor flux set-point (in the knee of the default curve)
    omega_final: float = 100.0  # [rad/s]
    t_ramp: float = 0.2  # [s] ramp start
    ramp_rate: float = 200.0  # [rad/s^2]
    t_load: float = 1.0  # [s] load step
    T_load: float = 26.71  # [N m] rated torque of the default motor
    t_end: float = 1.5  # [s]
    t_steady: float = 1.3  # [s] start of the steady-state window

    @property
    def ss_window(self):
        """Steady-state window ``(t_steady, t_end)`` [s] of :func:`satmotor.metrics.run_metrics`."""
        return self.t_steady, self.t_end

    def omega_ref(self, t):
        return 0.0 if t < self.t_ramp else min(self.omega_final, (t - self.t_ramp) * self.ramp_rate)

    def load(self, t):
        return self.T_load if t >= self.t_load else 0.0

    def run(self, plant_params, drive, **kw):
        return closed_loop(plant_params, drive, self.t_end, self.omega_ref, self.psi_ref, self.load, **kw)
