"""Performance figures of a closed-loop run: the one implementation (numpy arrays in, floats out).

Used by the plain-Python loop (:func:`run_metrics` on a :func:`satmotor.simulate.closed_loop`
record) and by the co-simulation (``orchestration.results.writer.compute_metrics``, a thin adapter that
pulls the columns of its DataFrame and calls :func:`closed_loop_metrics`).

Definitions (SI units; ``t`` the sample times [s], increasing)
-------------------------------------------------------------
run phase
    The samples from the first one at which the control law runs (the drive's ``phase`` output
    is 1) to the end of the record.
``t_switch`` [s]
    Time of the first run-phase sample; nan if the law never runs.
``iae_speed`` [rad], ``iae_flux`` [Wb s]
    Integral of ``|z1|`` and ``|e1|`` (trapezoidal) over the run phase: the controller's tracking
    errors ``z1 = omega_m - omega_ref``, ``e1 = |psi_r| - psi_ref`` against the *shaped*
    references; nan if the law never runs, 0 with a single run-phase sample.
``ss_speed``, ``ss_flux`` [1]
    Largest ``|omega_m - omega_set|`` (``||psi_r| - psi_set|``) against the *raw* set-points over
    the steady-state window, divided by ``|set-point|`` at the window's last sample, at least
    1 rad/s (1 mWb).  Window: ``[t_from, t_to]`` [s], both ends included; default the last 10 %
    of the record, ``t >= t[0] + 0.9 (t[-1] - t[0])``; nan if no sample falls in it.
``overshoot_speed`` [1]
    Peak excursion of omega_m beyond the final set-point ``omega_set[-1]``, in the direction of
    the change from ``omega_m[0]``, relative to ``|omega_set[-1] - omega_m[0]|`` (>= 0), over the
    whole record; 0 when there is no change.
``settling_time_speed`` [s]
    Time of the last sample outside the band ``|omega_m - omega_set[-1]| <= SETTLING_BAND
    |omega_set[-1]|`` (``t[0]`` if none is outside, ``t[-1]`` if the last one is; nan if the
    final set-point is 0).
``peak_current`` [A], ``peak_voltage`` [V]
    Largest ``|i_s|`` and ``|v_s|`` over the whole record (pre-magnetization included).
``peak_current_run`` [A]
    Largest ``|i_s|`` over the run phase (what the law's current limit bounds); nan if the law
    never runs.
``min_W`` [1]
    Smallest ``W = det Lambda`` over the run phase (0 for the PI baseline); nan if the law never
    runs.
``voltage_limited_fraction``, ``current_limited_fraction`` [1]
    Share of all samples whose voltage command was limited to V_dc/sqrt(3), resp. whose current
    demand was bounded by I_max (the controller's flags; only when the flags are given).
"""

from __future__ import annotations

import math

import numpy as np

from .drive import RUN

SETTLING_BAND = 0.02  # [1] relative band of the settling time
SS_SPEED_FLOOR = 1.0  # [rad/s] least denominator of ss_speed
SS_FLUX_FLOOR = 1e-3  # [Wb] least denominator of ss_flux
SS_DEFAULT_FRACTION = 0.1  # [1] default steady-state window: this last fraction of the record
_T_REL = 1e-9  # relative tolerance of the window bounds (sample times carry rounding)
#: The series :func:`closed_loop_metrics` reads (also the keys of a closed_loop record).
SERIES = ("t", "omega_m", "omega_set", "psi_r_alpha", "psi_r_beta", "psi_set", "z1", "e1", "i_s_alpha",
          "i_s_beta", "v_s_alpha", "v_s_beta", "W")


def iae(t, e):
    """Integral of ``|e| dt`` (trapezoidal) [unit of e times s]; 0 with fewer than two samples."""
    t, e = np.asarray(t, dtype=float), np.abs(np.asarray(e, dtype=float))
    if t.size < 2:
        return 0.0
    return float(np.sum(0.5 * (e[1:] + e[:-1]) * np.diff(t)))


def from_first(mask):
    """``mask`` extended from its first True sample to the end (all False if it has none)."""
    return np.cumsum(np.asarray(mask, dtype=bool)) > 0


def steady_state_window(t, window=None):
    """Mask of the samples in ``window = (t_from, t_to)`` [s], ends included; ``None``: the last
    ``SS_DEFAULT_FRACTION`` of the record."""
    t = np.asarray(t, dtype=float)
    if t.size == 0:
        return np.zeros(0, dtype=bool)
    if window is None:
        return t >= t[0] + (1.0 - SS_DEFAULT_FRACTION) * (t[-1] - t[0])
    t_from, t_to = window
    tol = _T_REL * max(abs(t_from), abs(t_to), 1.0)
    return (t >= t_from - tol) & (t <= t_to + tol)


def steady_state_error(y, y_set, in_window, floor=0.0):
    """Largest ``|y - y_set|`` over the ``in_window`` samples relative to ``max(|y_set|, floor)`` at
    the window's last sample [1]; nan if the window is empty."""
    y, y_set = np.asarray(y, dtype=float)[in_window], np.asarray(y_set, dtype=float)[in_window]
    if y.size == 0:
        return math.nan
    return float(np.max(np.abs(y - y_set))) / max(abs(float(y_set[-1])), floor)


def overshoot(y, final, start):
    """Peak excursion of ``y`` beyond ``final`` in the direction of ``final - start``, relative to
    ``|final - start|`` [1] (>= 0; 0 when ``final == start``)."""
    step = final - start
    if step == 0:
        return 0.0
    peak = np.max((np.asarray(y, dtype=float) - final) * np.sign(step))
    return float(max(peak, 0.0) / abs(step))


def settling_time(t, y, final, band=SETTLING_BAND):
    """Time [s] of the last sample with ``|y - final| > band |final|``; ``t[0]`` if there is none;
    nan if ``final == 0``."""
    if final == 0:
        return math.nan
    out = np.nonzero(np.abs(np.asarray(y, dtype=float) - final) > band * abs(final))[0]
    return float(t[out[-1]]) if out.size else float(t[0])


def closed_loop_metrics(*, t, omega_m, omega_set, psi_r_alpha, psi_r_beta, psi_set, z1, e1,
                        i_s_alpha, i_s_beta, v_s_alpha, v_s_beta, W, run, ss_window=None,
                        voltage_limited=None, current_limited=None):
    """The figures of the module docstring from the recorded series (1-D arrays of one length).

    ``omega_set``, ``psi_set`` the raw set-points; ``z1``, ``e1`` the controller's tracking errors;
    ``run`` the run-phase mask (``phase == RUN``), extended to the end of the record;
    ``ss_window = (t_from, t_to)`` [s] or None; the limiter flags optional.  ``{}`` for an empty
    record.
    """
    t = np.asarray(t, dtype=float)
    if t.size == 0:
        return {}
    w, w_set = np.asarray(omega_m, dtype=float), np.asarray(omega_set, dtype=float)
    run = from_first(run)
    running = bool(run.any())
    ss = steady_state_window(t, ss_window)
    w_final = float(w_set[-1])
    out = {
        "t_switch": float(t[np.argmax(run)]) if running else math.nan,
        "iae_speed": iae(t[run], np.asarray(z1)[run]) if running else math.nan,
        "iae_flux": iae(t[run], np.asarray(e1)[run]) if running else math.nan,
        "ss_speed": steady_state_error(w, w_set, ss, SS_SPEED_FLOOR),
        "ss_flux": steady_state_error(np.hypot(psi_r_alpha, psi_r_beta), psi_set, ss, SS_FLUX_FLOOR),
        "overshoot_speed": overshoot(w, w_final, float(w[0])),
        "settling_time_speed": settling_time(t, w, w_final),
        "peak_current": float(np.max(np.hypot(i_s_alpha, i_s_beta))),
        "peak_voltage": float(np.max(np.hypot(v_s_alpha, v_s_beta))),
        "peak_current_run": float(np.max(np.hypot(i_s_alpha, i_s_beta)[run])) if running else math.nan,
        "min_W": float(np.min(np.asarray(W, dtype=float)[run])) if running else math.nan,
    }
    for name, flags in (("voltage_limited_fraction", voltage_limited), ("current_limited_fraction",
                                                                        current_limited)):
        if flags is not None:
            out[name] = float(np.mean(np.asarray(flags, dtype=float) != 0.0))
    return out


def run_metrics(res, ss_window=None):
    """:func:`closed_loop_metrics` of a :func:`satmotor.simulate.closed_loop` record (run phase:
    the drive's ``phase``; the limiter fractions from its flags)."""
    return closed_loop_metrics(**{k: res[k] for k in SERIES}, run=np.asarray(res["phase"]) == RUN,
                               ss_window=ss_window, voltage_limited=res["voltage_limited"],
                               current_limited=res.get("current_limited"))


def acceptance(metrics, bounds):
    """``{name: {"limit": x, "value": y, "pass": y <= x}}`` for each upper bound in ``bounds``
    (``{metric name: limit or None}``; None: not checked).  A nan value fails."""
    out = {}
    for name, limit in bounds.items():
        if limit is not None:
            value = metrics[name]
            out[name] = {"limit": limit, "value": value, "pass": bool(value <= limit)}
    return out
