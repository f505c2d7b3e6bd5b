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
    errors ``z1 = omega_m - omega_ref_shaped``, ``e1 = |psi_r| - psi_ref_shaped`` against the *shaped*
    references; nan if the law never runs, 0 with a single run-phase sample.
``ss_speed``, ``ss_flux`` [1]
    Largest ``|omega_m - omega_ref|`` (``||psi_r| - psi_ref|``) against the *raw* set-points over
    the steady-state window, divided by ``|set-point|`` at the window's last sample, at least
    1 rad/s (1 mWb).  The flux set-point is the one the drive works to when it is given
    (``psi_set``: the controller's ``psi_ref_shaped``): under field weakening the drive lowers the
    nominal ``psi_ref`` above base speed, and the flux is judged against what the drive set, not
    against the nominal value; below base speed, in the window, the two are the same.
    Window: ``[t_from, t_to]`` [s], both ends included; default the last 10 %
    of the record, ``t >= t[0] + 0.9 (t[-1] - t[0])``; nan if no sample falls in it.
``overshoot_speed`` [1]
    Peak excursion of omega_m beyond the final set-point ``omega_ref[-1]``, in the direction of
    the change from ``omega_m[0]``, relative to ``|omega_ref[-1] - omega_m[0]|`` (>= 0), over the
    whole record; 0 when there is no change.
``final_overshoot_speed`` [rad/s]
    Peak excursion of omega_m beyond the final set-point ``omega_ref[-1]`` after the raw set-point
    last differed from it, in the direction of that last change (absolute, >= 0; 0 when the
    set-point never differs from its final value): a stop's undershoot through zero.
``settling_time_speed`` [s]
    Time of the last sample outside the band ``|omega_m - omega_ref[-1]| <= SETTLING_BAND
    |omega_ref[-1]|`` (``t[0]`` if none is outside, ``t[-1]`` if the last one is; nan if the
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
``ss_voltage_limited_fraction``, ``ss_current_limited_fraction`` [1]
    The same share over the steady-state window only (nan if no sample falls in it).
``E_regen`` [J], ``E_chop`` [J], ``peak_v_dc`` [V], ``min_v_dc`` [V], ``dc_fault`` [1]
    Only with the plant's DC link on (``dc_link: capacitor``, the series :data:`LINK_SERIES` given):
    the energy the motor returned into the link and the energy the brake chopper dissipated over the
    run (the plant's integrals at the last sample), the link voltage's extremes, and 1 if the
    over-voltage fault was set (else 0).

Holding the set-points (:func:`setpoint_status`)
------------------------------------------------
A run holds its set-points when, over the steady-state window, ``ss_speed`` and ``ss_flux`` stay
within their margins and neither limiter flag is set at any sample.  The margins are the
scenario's acceptance bounds ``ss_speed`` / ``ss_flux`` when it states them, else
:data:`SS_SPEED_MARGIN` and :data:`SS_FLUX_MARGIN` (2 %).  A limit active in the window means the
drive is saturated there: what it holds is what the limit allows, not the set-point.
"""

from __future__ import annotations

import math

import numpy as np

from satmotor.drive_phase import RUN

SETTLING_BAND = 0.02  # [1] relative band of the settling time
SS_SPEED_FLOOR = 1.0  # [rad/s] least denominator of ss_speed
SS_FLUX_FLOOR = 1e-3  # [Wb] least denominator of ss_flux
SS_DEFAULT_FRACTION = 0.1  # [1] default steady-state window: this last fraction of the record
SS_SPEED_MARGIN = 0.02  # [1] default margin of ss_speed for holding the set-points
SS_FLUX_MARGIN = 0.02  # [1] default margin of ss_flux
_T_REL = 1e-9  # relative tolerance of the window bounds (sample times carry rounding)
#: The DC link's series (plant outputs), read when the plant's link is on (:func:`link_metrics`).
LINK_SERIES = ("v_dc", "E_regen", "E_chop", "dc_fault")
#: The series :func:`closed_loop_metrics` reads (also the keys of a closed_loop record).
SERIES = ("t", "omega_m", "omega_ref", "psi_r_alpha", "psi_r_beta", "psi_ref", "z1", "e1", "i_s_alpha",
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


def steady_state_bounds(t, window=None):
    """``(t_from, t_to)`` [s] of the steady-state window of the sample times ``t`` (non-empty):
    ``window`` itself, or the last ``SS_DEFAULT_FRACTION`` of the record (as
    :func:`steady_state_window` selects it)."""
    if window is not None:
        return float(window[0]), float(window[1])
    t0, t1 = float(t[0]), float(t[-1])
    return t0 + (1.0 - SS_DEFAULT_FRACTION) * (t1 - t0), t1


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


def final_overshoot(y, y_ref):
    """Peak excursion of ``y`` beyond ``y_ref[-1]`` after the last sample where ``y_ref`` differs from
    it, in the direction of that change [unit of y] (>= 0; 0 when ``y_ref`` is constant)."""
    y, y_ref = np.asarray(y, dtype=float), np.asarray(y_ref, dtype=float)
    final = y_ref[-1]
    changed = np.nonzero(y_ref != final)[0]
    if changed.size == 0 or changed[-1] + 1 >= y.size:
        return 0.0
    j = changed[-1]
    return float(max(float(np.max((y[j + 1:] - final) * np.sign(final - y_ref[j]))), 0.0))


def settling_time(t, y, final, band=SETTLING_BAND):
    """Time [s] of the last sample with ``|y - final| > band |final|``; ``t[0]`` if there is none;
    nan if ``final == 0``."""
    if final == 0:
        return math.nan
    out = np.nonzero(np.abs(np.asarray(y, dtype=float) - final) > band * abs(final))[0]
    return float(t[out[-1]]) if out.size else float(t[0])


def link_metrics(v_dc, E_regen, E_chop, dc_fault):
    """The DC link's figures (module docstring) from its recorded series (1-D arrays, one length)."""
    return {"E_regen": float(np.asarray(E_regen)[-1]), "E_chop": float(np.asarray(E_chop)[-1]),
            "peak_v_dc": float(np.max(v_dc)), "min_v_dc": float(np.min(v_dc)),
            "dc_fault": float(np.max(dc_fault))}


def closed_loop_metrics(*, t, omega_m, omega_ref, psi_r_alpha, psi_r_beta, psi_ref, z1, e1,
                        i_s_alpha, i_s_beta, v_s_alpha, v_s_beta, W, run, ss_window=None,
                        voltage_limited=None, current_limited=None, psi_set=None, link=None):
    """The figures of the module docstring from the recorded series (1-D arrays of one length).

    ``omega_ref``, ``psi_ref`` the raw set-points; ``z1``, ``e1`` the controller's tracking errors;
    ``run`` the run-phase mask (``phase == RUN``), extended to the end of the record;
    ``ss_window = (t_from, t_to)`` [s] or None; the limiter flags optional; ``psi_set`` the flux
    set-point the drive works to (its ``psi_ref_shaped``), optional: ``ss_flux`` against it when
    given, else against ``psi_ref``; ``link`` the DC link's series ``{name: array}`` (names
    :data:`LINK_SERIES`) when the plant's link is on, else None.  ``{}`` for an empty record.
    """
    t = np.asarray(t, dtype=float)
    if t.size == 0:
        return {}
    w, omega_ref = np.asarray(omega_m, dtype=float), np.asarray(omega_ref, dtype=float)
    run = from_first(run)
    running = bool(run.any())
    ss = steady_state_window(t, ss_window)
    w_final = float(omega_ref[-1])
    out = {
        "t_switch": float(t[np.argmax(run)]) if running else math.nan,
        "iae_speed": iae(t[run], np.asarray(z1)[run]) if running else math.nan,
        "iae_flux": iae(t[run], np.asarray(e1)[run]) if running else math.nan,
        "ss_speed": steady_state_error(w, omega_ref, ss, SS_SPEED_FLOOR),
        "ss_flux": steady_state_error(np.hypot(psi_r_alpha, psi_r_beta),
                                      psi_ref if psi_set is None else psi_set, ss, SS_FLUX_FLOOR),
        "overshoot_speed": overshoot(w, w_final, float(w[0])),
        "final_overshoot_speed": final_overshoot(w, omega_ref),
        "settling_time_speed": settling_time(t, w, w_final),
        "peak_current": float(np.max(np.hypot(i_s_alpha, i_s_beta))),
        "peak_voltage": float(np.max(np.hypot(v_s_alpha, v_s_beta))),
        "peak_current_run": float(np.max(np.hypot(i_s_alpha, i_s_beta)[run])) if running else math.nan,
        "min_W": float(np.min(np.asarray(W, dtype=float)[run])) if running else math.nan,
    }
    for name, flags in (("voltage_limited", voltage_limited), ("current_limited", current_limited)):
        if flags is not None:
            on = np.asarray(flags, dtype=float) != 0.0
            out[f"{name}_fraction"] = float(np.mean(on))
            out[f"ss_{name}_fraction"] = float(np.mean(on[ss])) if ss.any() else math.nan
    if link is not None:
        out.update(link_metrics(**link))
    return out


def setpoint_status(metrics, window, speed_margin=None, flux_margin=None):
    """``(holds, line)``: whether the run held its set-points over the steady-state ``window``
    ``(t_from, t_to)`` [s] (module docstring; margins None: :data:`SS_SPEED_MARGIN`,
    :data:`SS_FLUX_MARGIN`), and one line saying so, naming what missed.  ``holds`` is None (not
    judged) for empty metrics (a failed run) or an empty window."""
    if not metrics:
        return None, ""
    speed_margin = SS_SPEED_MARGIN if speed_margin is None else speed_margin
    flux_margin = SS_FLUX_MARGIN if flux_margin is None else flux_margin
    where = f"[{window[0]:.6g}, {window[1]:.6g}] s"
    ss_w, ss_f = metrics["ss_speed"], metrics["ss_flux"]
    if math.isnan(ss_w) or math.isnan(ss_f):
        return None, f"set-points not judged: no sample in the steady-state window {where}"
    missed = []
    for what, value, margin in (("speed", ss_w, speed_margin), ("flux", ss_f, flux_margin)):
        if not value <= margin:
            missed.append(f"{what} off its set-point by up to {_percent(value)} (margin {_percent(margin)})")
    for what in ("current", "voltage"):
        share = metrics.get(f"ss_{what}_limited_fraction", 0.0)
        if share > 0.0:
            missed.append(f"{what} limit active in {_percent(share)} of the window")
    if missed:
        return False, f"set-points NOT held in {where}: " + "; ".join(missed)
    return True, (f"set-points held in {where}: speed within {ss_w:.2g} (margin {_percent(speed_margin)}), "
                  f"flux within {ss_f:.2g} (margin {_percent(flux_margin)}), no limit active")


def _percent(x):
    return f"{100.0 * x:.3g} %"


def run_metrics(res, ss_window=None):
    """:func:`closed_loop_metrics` of a :func:`satmotor.simulate.closed_loop` record (run phase:
    the drive's ``phase``; the limiter fractions from its flags)."""
    return closed_loop_metrics(**{k: res[k] for k in SERIES}, run=np.asarray(res["phase"]) == RUN,
                               ss_window=ss_window, voltage_limited=res["voltage_limited"],
                               current_limited=res.get("current_limited"), psi_set=res.get("psi_ref_shaped"))


def acceptance(metrics, bounds):
    """``{name: {"limit": x, "value": y, "pass": y <= x}}`` for each upper bound in ``bounds``
    (``{metric name: limit or None}``; None: not checked).  A nan value fails."""
    out = {}
    for name, limit in bounds.items():
        if limit is not None:
            value = metrics[name]
            out[name] = {"limit": limit, "value": value, "pass": bool(value <= limit)}
    return out


class RunningMetrics:
    """:func:`closed_loop_metrics` computed as the run goes, chunk by chunk, in memory that does not
    grow with the run: the same definitions (module docstring), the same float operations, so every
    figure equals the whole-record one bit for bit but ``iae_speed`` and ``iae_flux`` (summed chunk
    by chunk: equal to within a few units in the last place).

    What the whole-record computation takes from the end of the record must be known before:
    ``t_last`` [s] the time of the last sample, ``omega_ref_final`` [rad/s] the speed set-point
    there (the profiles are functions of time).  :meth:`update` takes the chunks' series (the keys
    of :data:`SERIES`, ``run`` the ``phase == RUN`` mask, the limiter flags), :meth:`result` gives
    the metrics, or None when the record did not end at ``t_last`` with ``omega_ref_final`` (a run
    cut short: its metrics are not these).
    """

    def __init__(self, t_last, omega_ref_final, ss_window=None, flags=True, link=False):
        self.t_last, self.w_final = float(t_last), float(omega_ref_final)
        # the DC link (link_metrics): peak and least v_dc, last E_regen and E_chop, largest dc_fault
        self._link = [-math.inf, math.inf, math.nan, math.nan, -math.inf] if link else None
        self.ss_window, self.flags = ss_window, flags
        self.n = 0
        self.t_first = self.t_seen = math.nan
        self._last_ref = math.nan
        self._prev = None  # (t, |z1|, |e1|) of the last run-phase sample
        self._t_switch = math.nan
        self._iae = [0.0, 0.0]
        # largest speed and flux errors in the window; their set-points at its last sample
        self._ss = [-math.inf, -math.inf, math.nan, math.nan]
        self._w = [math.inf, -math.inf, math.nan]  # min, max of omega_m, omega_m[0]
        self._settle = math.nan  # time of the last sample outside the band
        self._fo = [0.0, 0.0]  # direction of the set-point's last change (0: none yet), peak excursion
        self._peak = [-math.inf, -math.inf, -math.inf, math.inf]  # |i_s|, |v_s|, |i_s| run, min W run
        self._on = [0, 0, 0, 0, 0]  # voltage, current limited: all samples, in the window; window size

    def _window(self, t):
        if self.ss_window is None:  # as steady_state_window, with t[0] and t[-1] of the record
            return t >= self.t_first + (1.0 - SS_DEFAULT_FRACTION) * (self.t_last - self.t_first)
        return steady_state_window(t, self.ss_window)

    def update(self, *, t, omega_m, omega_ref, psi_r_alpha, psi_r_beta, psi_ref, z1, e1, i_s_alpha, i_s_beta,
               v_s_alpha, v_s_beta, W, run, voltage_limited=None, current_limited=None, psi_set=None,
               link=None):
        """Fold in the next chunk of samples (1-D arrays of one length, in time order); ``psi_set``
        and ``link`` as for :func:`closed_loop_metrics` (``link`` read when constructed with
        ``link=True``)."""
        t, w = np.asarray(t, dtype=float), np.asarray(omega_m, dtype=float)
        if t.size == 0:
            return
        if self.n == 0:
            self.t_first, self._w[2] = float(t[0]), float(w[0])
        self.n += t.size
        self.t_seen, self._last_ref = float(t[-1]), float(np.asarray(omega_ref)[-1])
        ss = self._window(t)
        if ss.any():
            flux = np.hypot(np.asarray(psi_r_alpha, dtype=float)[ss], np.asarray(psi_r_beta, dtype=float)[ss])
            for i, (y, y_set) in enumerate(((w[ss], np.asarray(omega_ref, dtype=float)[ss]),
                                            (flux, np.asarray(psi_ref if psi_set is None else psi_set,
                                                              dtype=float)[ss]))):
                self._ss[i] = max(self._ss[i], float(np.max(np.abs(y - y_set))))
                self._ss[2 + i] = float(y_set[-1])
        self._w[0], self._w[1] = min(self._w[0], float(np.min(w))), max(self._w[1], float(np.max(w)))
        w_ref = np.asarray(omega_ref, dtype=float)
        changed = np.nonzero(w_ref != self.w_final)[0]
        after = 0
        if changed.size:  # a (later) change: the excursion counts from it on
            after = changed[-1] + 1
            self._fo = [float(np.sign(self.w_final - w_ref[changed[-1]])), 0.0]
        if self._fo[0] != 0.0 and after < w.size:
            self._fo[1] = max(self._fo[1], float(np.max((w[after:] - self.w_final) * self._fo[0])))
        if self.w_final != 0:
            out = np.nonzero(np.abs(w - self.w_final) > SETTLING_BAND * abs(self.w_final))[0]
            if out.size:
                self._settle = float(t[out[-1]])
        i_abs = np.hypot(i_s_alpha, i_s_beta)
        self._peak[0] = max(self._peak[0], float(np.max(i_abs)))
        self._peak[1] = max(self._peak[1], float(np.max(np.hypot(v_s_alpha, v_s_beta))))
        run = np.asarray(run, dtype=bool)
        if self._prev is None:
            run = from_first(run)
            if run.any():
                self._t_switch = float(t[np.argmax(run)])
        else:
            run = np.ones(t.size, dtype=bool)
        if run.any():
            tr = t[run]
            z, e = np.abs(np.asarray(z1, dtype=float)[run]), np.abs(np.asarray(e1, dtype=float)[run])
            if self._prev is not None:  # the trapezoid across the chunks' boundary
                tr, z, e = (np.concatenate(([p], a)) for p, a in zip(self._prev, (tr, z, e)))
            if tr.size >= 2:
                dt = np.diff(tr)
                self._iae[0] += float(np.sum(0.5 * (z[1:] + z[:-1]) * dt))
                self._iae[1] += float(np.sum(0.5 * (e[1:] + e[:-1]) * dt))
            self._prev = (tr[-1], z[-1], e[-1])
            self._peak[2] = max(self._peak[2], float(np.max(i_abs[run])))
            self._peak[3] = min(self._peak[3], float(np.min(np.asarray(W, dtype=float)[run])))
        if self.flags and voltage_limited is not None and current_limited is not None:
            for i, f in enumerate((voltage_limited, current_limited)):
                on = np.asarray(f, dtype=float) != 0.0
                self._on[i] += int(np.count_nonzero(on))
                self._on[2 + i] += int(np.count_nonzero(on[ss]))
        self._on[4] += int(np.count_nonzero(ss))
        if self._link is not None and link is not None:
            m = link_metrics(**link)
            k = self._link
            k[0], k[1] = max(k[0], m["peak_v_dc"]), min(k[1], m["min_v_dc"])
            k[2], k[3], k[4] = m["E_regen"], m["E_chop"], max(k[4], m["dc_fault"])

    def result(self):
        """The metrics of :func:`closed_loop_metrics` (``{}`` for no sample), or None when the record
        did not end at ``t_last`` with the speed set-point ``omega_ref_final``."""
        if self.n == 0:
            return {}
        if self.t_seen != self.t_last or self._last_ref != self.w_final:
            return None
        running = self._prev is not None
        step = self.w_final - self._w[2]
        if step == 0:
            over = 0.0
        else:
            peak = self._w[1] - self.w_final if step > 0 else -(self._w[0] - self.w_final)
            over = float(max(peak, 0.0) / abs(step))
        if self.w_final == 0:
            settle = math.nan
        else:
            settle = self._settle if not math.isnan(self._settle) else self.t_first
        empty = self._on[4] == 0
        out = {
            "t_switch": self._t_switch if running else math.nan,
            "iae_speed": self._iae[0] if running else math.nan,
            "iae_flux": self._iae[1] if running else math.nan,
            "ss_speed": math.nan if empty else self._ss[0] / max(abs(self._ss[2]), SS_SPEED_FLOOR),
            "ss_flux": math.nan if empty else self._ss[1] / max(abs(self._ss[3]), SS_FLUX_FLOOR),
            "overshoot_speed": over,
            "final_overshoot_speed": self._fo[1],
            "settling_time_speed": settle,
            "peak_current": self._peak[0],
            "peak_voltage": self._peak[1],
            "peak_current_run": self._peak[2] if running else math.nan,
            "min_W": self._peak[3] if running else math.nan,
        }
        if self.flags:
            for i, name in enumerate(("voltage_limited", "current_limited")):
                out[f"{name}_fraction"] = self._on[i] / self.n
                out[f"ss_{name}_fraction"] = self._on[2 + i] / self._on[4] if not empty else math.nan
        if self._link is not None:
            k = self._link
            out.update({"E_regen": k[2], "E_chop": k[3], "peak_v_dc": k[0], "min_v_dc": k[1],
                        "dc_fault": k[4]})
        return out
