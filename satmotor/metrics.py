"""Performance figures of a closed-loop run (numpy arrays in, floats out, SI units)."""

from __future__ import annotations

import numpy as np


def iae(t, y, ref, t_from=None):
    """Integral of |y - ref| dt (trapezoidal) over ``t >= t_from`` [unit of y times s]."""
    t, e = np.asarray(t), np.abs(np.asarray(y) - np.asarray(ref))
    if t_from is not None:
        keep = t >= t_from
        t, e = t[keep], e[keep]
    if t.size < 2:
        return 0.0
    return float(np.sum(0.5 * (e[1:] + e[:-1]) * np.diff(t)))


def steady_state_error(t, y, setpoint, t_from):
    """Largest |y - setpoint| / |setpoint| over ``t >= t_from`` [1]."""
    keep = np.asarray(t) >= t_from
    return float(np.max(np.abs(np.asarray(y)[keep] - setpoint)) / abs(setpoint))


def overshoot(y, setpoint, start=0.0):
    """Peak excursion beyond the set-point, relative to the step ``setpoint - start`` [1] (>= 0)."""
    step = setpoint - start
    peak = np.max((np.asarray(y) - setpoint) * np.sign(step))
    return float(max(peak, 0.0) / abs(step))


def run_metrics(res, omega_final, psi_set, t_steady):
    """The comparison figures of a :func:`satmotor.simulate.closed_loop` result.

    IAE against the shaped references over the run phase (after pre-magnetization);
    steady-state errors against the raw set-points over ``t >= t_steady``.
    """
    run = res["phase"] == 1
    t0 = float(res["t"][np.argmax(run)]) if run.any() else float(res["t"][-1])
    i_mag = np.hypot(res["i_s_alpha"], res["i_s_beta"])
    W = res["W"][run]
    return {
        "t_switch": t0,
        "iae_speed": iae(res["t"], res["omega_m"], res["omega_ref"], t0),
        "iae_flux": iae(res["t"], res["psi_r_mag"], res["psi_ref"], t0),
        "ss_speed": steady_state_error(res["t"], res["omega_m"], omega_final, t_steady),
        "ss_flux": steady_state_error(res["t"], res["psi_r_mag"], psi_set, t_steady),
        "overshoot_speed": overshoot(res["omega_m"], omega_final),
        "peak_current": float(np.max(i_mag)),
        "peak_voltage": float(np.max(np.hypot(res["v_s_alpha"], res["v_s_beta"]))),
        "min_W": float(np.min(W)) if W.size else float("nan"),
        "voltage_limited_fraction": float(np.mean(res["voltage_limited"])),
    }
