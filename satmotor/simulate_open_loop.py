"""Open-loop simulations of the saturated induction motor (no controller).

:func:`dol_start` runs a direct-on-line (DOL) start: the motor, at standstill and
de-energised, is connected to the rated balanced sinusoidal supply, and a load
torque step is applied once it has run up.
"""

from __future__ import annotations

import math

import numpy as np

from satmotor.machine.params import MotorParams, RatedData
from satmotor.machine.plant import N_STATES, STATE_NAMES, Plant

_OUTPUT_NAMES = (
    "t", "v_s_alpha", "v_s_beta", "T_load", "i_s_alpha", "i_s_beta",
    "psi_s_alpha", "psi_s_beta", "psi_r_alpha", "psi_r_beta", "omega_m", "theta_m",
    "T_e", "i_mu", "psi_r_mag", "i_s_mag",
)


def dol_start(params=None, rated=None, t_end=1.0, h=1e-4, n_sub=1, t_load=0.6, load_torque=None):
    """Simulate a direct-on-line start at rated voltage and frequency.

    The stator voltage is the balanced set ``v_s_alpha = V cos(w t_mid)``,
    ``v_s_beta = V sin(w t_mid)`` with ``V = rated.V_phase_peak`` [V] and
    ``w = rated.omega_e`` [rad/s], evaluated at the middle ``t_mid = t_k + h/2`` of each
    step and held over the step (zero-order hold; ``t_k = k h``, never accumulated).
    The load torque is 0 before ``t_load`` and ``load_torque`` (default ``rated.T_n``)
    from ``t_load`` on, as seen at the start of a step.  The motor starts at standstill
    with zero fluxes and is integrated with :meth:`Plant.step` (RK4, ``n_sub`` sub-steps).

    Parameters
    ----------
    params : MotorParams, optional
        Motor; the default 4 kW, 400 V, 50 Hz motor if None.
    rated : RatedData or satmotor.machine.library.Nameplate, optional
        Supply and rated data; ``RatedData()`` if None.
    t_end : float
        Simulated time [s].
    h : float
        Step (and sampling) interval [s].
    n_sub : int
        RK4 sub-steps per step [1].
    t_load : float
        Time of the load torque step [s].
    load_torque : float, optional
        Load torque after ``t_load`` [N m]; ``rated.T_n`` if None.

    Returns
    -------
    dict of str -> numpy.ndarray
        1-D float arrays of length ``n + 1`` (``n = round(t_end / h)``), sampled at every
        ``t_k = k h`` including 0:

        * ``t`` [s]
        * ``v_s_alpha``, ``v_s_beta`` [V]: voltage held over the step starting at ``t_k``
          (the last sample repeats the formula for a step that is not taken)
        * ``T_load`` [N m]: load torque over the step starting at ``t_k``
        * ``i_s_alpha``, ``i_s_beta`` [A]: stator current
        * ``psi_s_alpha``, ``psi_s_beta``, ``psi_r_alpha``, ``psi_r_beta`` [Wb]: fluxes
        * ``omega_m`` [rad/s]: mechanical speed; ``theta_m`` [rad]: mechanical angle
        * ``T_e`` [N m]: electromagnetic torque
        * ``i_mu`` [A]: magnetizing current magnitude
        * ``psi_r_mag`` [Wb]: rotor flux magnitude; ``i_s_mag`` [A]: stator current magnitude
    """
    params = MotorParams() if params is None else params
    rated = RatedData() if rated is None else rated
    if not (h > 0.0 and t_end >= 0.0):
        raise ValueError(f"need h > 0 and t_end >= 0, got h={h!r}, t_end={t_end!r}")
    T_step = rated.T_n if load_torque is None else float(load_torque)
    V, w = rated.V_phase_peak, rated.omega_e
    plant = Plant(params)
    n = int(round(t_end / h))

    out = {name: np.empty(n + 1) for name in _OUTPUT_NAMES}
    t_arr = out["t"]
    va_arr, vb_arr, tl_arr = out["v_s_alpha"], out["v_s_beta"], out["T_load"]
    isa_arr, isb_arr = out["i_s_alpha"], out["i_s_beta"]
    te_arr, imu_arr = out["T_e"], out["i_mu"]
    state_arrs = [out[name] for name in STATE_NAMES]

    x = (0.0,) * N_STATES
    for k in range(n + 1):
        t = k * h
        t_mid = t + 0.5 * h
        va, vb = V * math.cos(w * t_mid), V * math.sin(w * t_mid)
        tl = T_step if t >= t_load else 0.0
        o = plant.outputs(x)
        t_arr[k], va_arr[k], vb_arr[k], tl_arr[k] = t, va, vb, tl
        isa_arr[k], isb_arr[k], te_arr[k], imu_arr[k] = o.i_s_alpha, o.i_s_beta, o.T_e, o.i_mu
        for arr, xi in zip(state_arrs, x):
            arr[k] = xi
        if k < n:
            x = plant.step(t, x, va, vb, tl, h, n_sub)

    np.hypot(out["psi_r_alpha"], out["psi_r_beta"], out=out["psi_r_mag"])
    np.hypot(isa_arr, isb_arr, out=out["i_s_mag"])
    return out
