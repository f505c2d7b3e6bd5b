"""The one metrics implementation (satmotor.metrics) and its two callers (the plain loop's
run_metrics, the co-simulation's compute_metrics/check_acceptance) on hand-made series whose
figures are computed by hand."""

import math
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from orchestration.results.writer import check_acceptance, compute_metrics
from orchestration.results.writer import setpoint_status as results_setpoint_status
from orchestration.scenario.load import Acceptance
from satmotor.control.drive import PREMAG, RUN
from satmotor.metrics import (
    SERIES,
    SS_FLUX_MARGIN,
    SS_SPEED_MARGIN,
    RunningMetrics,
    acceptance,
    closed_loop_metrics,
    final_overshoot,
    iae,
    overshoot,
    run_metrics,
    setpoint_status,
    settling_time,
    steady_state_bounds,
    steady_state_error,
    steady_state_window,
)

# ----- the parts ------------------------------------------------------------------------------


def test_iae_of_a_ramp_is_the_triangle_area():
    t = np.linspace(0.0, 2.0, 11)
    assert iae(t, 3.0 * t) == pytest.approx(0.5 * 2.0 * 6.0, rel=1e-15)  # linear: trapezoids exact
    assert iae(t, -3.0 * t) == pytest.approx(6.0, rel=1e-15)  # |e|


def test_iae_of_an_error_crossing_zero_counts_both_triangles():
    t = np.array([0.0, 1.0, 2.0])
    assert iae(t, t - 1.0) == pytest.approx(1.0, rel=1e-15)  # 1/2 + 1/2


@pytest.mark.parametrize("n", [0, 1])
def test_iae_of_fewer_than_two_samples_is_zero(n):
    assert iae(np.zeros(n), np.ones(n)) == 0.0


def test_steady_state_window_ends_included_and_default_last_tenth():
    t = np.arange(11.0)  # 0 .. 10 s
    assert np.flatnonzero(steady_state_window(t, (3.0, 5.0))).tolist() == [3, 4, 5]
    assert np.flatnonzero(steady_state_window(t, None)).tolist() == [9, 10]  # t >= 9
    assert np.flatnonzero(steady_state_window(0.1 * np.arange(11), (0.3, 0.6))).tolist() == [3, 4, 5, 6]


def test_steady_state_error_of_a_constant_offset():
    y_set = np.full(6, 50.0)
    inside = np.array([False, False, True, True, True, True])
    y = np.array([0.0, 80.0, 49.0, 50.5, 49.8, 50.2])  # largest |error| in the window: 1.0
    assert steady_state_error(y, y_set, inside) == pytest.approx(1.0 / 50.0, rel=1e-15)
    # relative to the set-point at the window's last sample, at least the floor
    assert steady_state_error(y - 50.0, y_set - 50.0, inside, floor=1.0) == pytest.approx(1.0, rel=1e-15)
    assert math.isnan(steady_state_error(y, y_set, np.zeros(6, dtype=bool)))


def test_overshoot_of_a_known_step_response():
    assert overshoot([0.0, 60.0, 110.0, 98.0, 100.0], 100.0, 0.0) == pytest.approx(0.1, rel=1e-15)
    assert overshoot([0.0, 50.0, 99.0, 100.0], 100.0, 0.0) == 0.0  # no excursion beyond the set-point
    # a step down (speed reversal): beyond means below
    assert overshoot([100.0, 0.0, -55.0, -50.0], -50.0, 100.0) == pytest.approx(5.0 / 150.0, rel=1e-15)
    assert overshoot([20.0, 25.0, 20.0], 20.0, 20.0) == 0.0  # no change asked


def test_final_overshoot_is_the_excursion_after_the_last_change_of_the_set_point():
    """A run up to 150 rad/s (overshooting to 155 while the set-point is still 150: not counted), then a
    stop commanded at sample 4 that undershoots to -3 rad/s: 3 rad/s; a set-point that never changes: 0."""
    w_ref = np.array([0.0, 150.0, 150.0, 150.0, 150.0, 0.0, 0.0, 0.0, 0.0])
    w = np.array([0.0, 100.0, 155.0, 150.0, 150.0, 80.0, -3.0, -1.0, 0.0])
    assert final_overshoot(w, w_ref) == 3.0
    assert final_overshoot(w, np.full(9, 0.0)) == 0.0
    assert final_overshoot(-w, -w_ref) == 3.0  # a stop from -150 rad/s: the same excursion
    assert final_overshoot(np.abs(w), w_ref) == 0.0  # no excursion below zero: 0
    r = {k: np.resize(v, 9) for k, v in record().items()}
    r["t"], r["omega_ref"], r["omega_m"] = np.arange(9.0), w_ref, w
    whole = closed_loop_metrics(**r, run=np.ones(9, dtype=bool))
    assert whole["final_overshoot_speed"] == 3.0
    for cut in range(1, 9):  # chunk by chunk, wherever the chunks are cut
        run = RunningMetrics(8.0, 0.0)
        for lo, hi in ((0, cut), (cut, 9)):
            run.update(**{k: v[lo:hi] for k, v in r.items()}, run=np.ones(hi - lo, dtype=bool))
        assert run.result()["final_overshoot_speed"] == 3.0, cut


def test_settling_time_is_the_last_sample_outside_the_2_percent_band():
    t = np.arange(8.0)
    y = np.array([0.0, 50.0, 103.0, 99.0, 97.9, 101.0, 100.0, 100.0])  # band +-2: last out at t = 4
    assert settling_time(t, y, 100.0) == 4.0
    assert settling_time(t, np.full(8, 100.5), 100.0) == 0.0  # never outside: t[0]
    assert settling_time(t, y[::-1], 100.0) == 7.0  # outside at the end: t[-1]
    assert math.isnan(settling_time(t, y, 0.0))


def test_acceptance_at_the_bound():
    m = {"ss_speed": 0.01, "ss_flux": 0.0100000001, "peak_current": math.nan, "overshoot_speed": 0.0}
    out = acceptance(m, {"ss_speed": 0.01, "ss_flux": 0.01, "peak_current": 25.0, "overshoot_speed": None})
    assert out == {"ss_speed": {"limit": 0.01, "value": 0.01, "pass": True},
                   "ss_flux": {"limit": 0.01, "value": 0.0100000001, "pass": False},
                   "peak_current": {"limit": 25.0, "value": m["peak_current"], "pass": False}}


# ----- a whole record, through both callers -----------------------------------------------------

T = np.arange(0.0, 10.25, 0.5)  # 21 samples, 0 .. 10 s
N = T.size


def record():
    """A hand-made run: law running from t = 1 s, speed step to 100 rad/s with a 10 % overshoot."""
    w = np.full(N, 100.5)
    w[:9] = [0.0, 30.0, 70.0, 95.0, 110.0, 104.0, 99.0, 97.5, 103.0]  # last out of +-2 at t = 4 s
    ang = 0.3 * T
    i_a, i_b = np.full(N, 1.0), np.zeros(N)
    i_a[3], i_b[3] = 3.0, 4.0  # |i_s| = 5 A, the peak of the run phase
    i_a[1] = 6.0  # 6 A at t = 0.5 s, before the law runs: the peak of the record
    v_a, v_b = np.full(N, 2.0), np.zeros(N)
    v_a[6], v_b[6] = -6.0, 8.0  # |v_s| = 10 V, the peak
    run = T >= 1.0
    return {
        "t": T, "omega_m": w, "omega_ref": np.full(N, 100.0),
        "psi_r_alpha": 0.909 * np.cos(ang), "psi_r_beta": 0.909 * np.sin(ang), "psi_ref": np.full(N, 0.9),
        "z1": np.where(run, -2.0, 0.0),  # |z1| = 2 over 9 s
        "e1": np.where(run, 0.01 * (T - 1.0), -0.9),  # ramp 0 .. 0.09 Wb over 9 s
        "i_s_alpha": i_a, "i_s_beta": i_b, "v_s_alpha": v_a, "v_s_beta": v_b,
        "W": np.where(run, 3.0 + T, 0.0),
    }


EXPECTED = {
    "t_switch": 1.0,
    "iae_speed": 2.0 * 9.0,
    "iae_flux": 0.5 * 9.0 * 0.09,
    "ss_speed": 0.5 / 100.0,
    "ss_flux": 0.009 / 0.9,
    "overshoot_speed": 0.1,
    "settling_time_speed": 4.0,
    "peak_current": 6.0,
    "peak_voltage": 10.0,
    "peak_current_run": 5.0,
    "min_W": 4.0,
}


def check(m, expected=EXPECTED):
    assert set(m) >= set(expected)
    for k, v in expected.items():
        assert m[k] == pytest.approx(v, rel=1e-12, abs=1e-15), k


@pytest.mark.parametrize("window", [None, (8.0, 10.0)])
def test_closed_loop_metrics_of_the_hand_made_run(window):
    r = record()
    check(closed_loop_metrics(**r, run=r["t"] >= 1.0, ss_window=window))


def test_a_window_before_the_end_is_measured_against_its_own_set_point():
    r = record()
    r["omega_ref"] = np.where(T <= 6.0, 100.0, 120.0)  # window [5, 6]: omega 100.5 against 100
    m = closed_loop_metrics(**r, run=T >= 1.0, ss_window=(5.0, 6.0))
    assert m["ss_speed"] == pytest.approx(0.005, rel=1e-12)
    assert math.isnan(closed_loop_metrics(**r, run=T >= 1.0, ss_window=(20.0, 30.0))["ss_speed"])


def test_a_law_that_never_runs_has_no_run_phase_figures():
    r = record()
    m = closed_loop_metrics(**r, run=np.zeros(N, dtype=bool))
    for k in ("t_switch", "iae_speed", "iae_flux", "min_W"):
        assert math.isnan(m[k]), k
    assert m["peak_current"] == 6.0 and math.isnan(m["peak_current_run"])


def test_empty_and_one_sample_records():
    assert closed_loop_metrics(**{k: np.zeros(0) for k in SERIES}, run=np.zeros(0, dtype=bool)) == {}
    one = {k: v[4:5] for k, v in record().items()}  # t = 2 s, running, omega 110 against 100
    m = closed_loop_metrics(**one, run=np.ones(1, dtype=bool))
    check(m, {"t_switch": 2.0, "iae_speed": 0.0, "iae_flux": 0.0, "ss_speed": 0.1, "ss_flux": 0.01,
              "overshoot_speed": 0.0, "settling_time_speed": 2.0, "min_W": 5.0})


def test_run_metrics_reads_a_plain_loop_record():
    r = record()
    r["phase"] = np.where(T >= 1.0, RUN, PREMAG)
    r["voltage_limited"] = T >= 7.5  # 6 of 21 samples
    m = run_metrics(r, (8.0, 10.0))
    check(m)
    assert m["voltage_limited_fraction"] == pytest.approx(6 / 21, rel=1e-15)


COSIM = {"t": "time", "omega_m": "plant.omega_m", "omega_ref": "profile.omega_ref",
         "psi_r_alpha": "plant.psi_r_alpha", "psi_r_beta": "plant.psi_r_beta", "psi_ref": "profile.psi_ref",
         "z1": "controller.z1", "e1": "controller.e1", "i_s_alpha": "plant.i_s_alpha",
         "i_s_beta": "plant.i_s_beta", "v_s_alpha": "controller.v_s_alpha",
         "v_s_beta": "controller.v_s_beta", "W": "controller.W"}


def frame(r):
    """The co-simulation's DataFrame of a record (plus columns the metrics do not read)."""
    df = pd.DataFrame({COSIM[k]: v for k, v in r.items()})
    df["plant.T_e"] = 0.0
    df["profile.T_load"] = 0.0
    df["controller.phase"] = np.where(r["t"] >= 1.0, RUN, PREMAG)  # the run phase of every record here
    df["controller.voltage_limited"] = r["t"] >= 7.5  # 6 of 21 samples
    df["controller.current_limited"] = False
    return df


def scenario(**acceptance_bounds):
    return SimpleNamespace(acceptance=Acceptance(**acceptance_bounds) if acceptance_bounds else None)


def test_compute_metrics_is_the_same_figures_from_the_dataframe():
    r = record()
    m = compute_metrics(frame(r), scenario(ss_window=(8.0, 10.0)))
    assert m == closed_loop_metrics(**r, run=T >= 1.0, ss_window=(8.0, 10.0), voltage_limited=T >= 7.5,
                                    current_limited=np.zeros(N))
    assert list(m) == ["t_switch", "iae_speed", "iae_flux", "ss_speed", "ss_flux", "overshoot_speed",
                       "final_overshoot_speed", "settling_time_speed", "peak_current", "peak_voltage",
                       "peak_current_run", "min_W",
                       "voltage_limited_fraction", "ss_voltage_limited_fraction", "current_limited_fraction",
                       "ss_current_limited_fraction"]
    assert m["voltage_limited_fraction"] == pytest.approx(6 / 21, rel=1e-15)
    assert m["ss_voltage_limited_fraction"] == 1.0  # t = 8 .. 10 s: 5 samples, all flagged
    assert m["current_limited_fraction"] == 0.0
    check(m)
    check(compute_metrics(frame(r), scenario()))  # default window: the last 10 %


def test_compute_metrics_takes_the_run_phase_from_the_controllers_phase_not_from_W():
    r = record()
    r["W"] = np.zeros(N)  # the PI baseline reports W = 0: its run phase is still the phase output's
    m = compute_metrics(frame(r), scenario())
    check(m, {**EXPECTED, "min_W": 0.0})


def test_compute_metrics_of_empty_and_one_row_frames():
    assert compute_metrics(frame(record()).iloc[:0], scenario()) == {}
    m = compute_metrics(frame({k: v[4:5] for k, v in record().items()}), scenario())
    check(m, {"t_switch": 2.0, "iae_speed": 0.0, "ss_speed": 0.1, "overshoot_speed": 0.0, "min_W": 5.0})


@pytest.mark.parametrize("limit, passes", [(0.005, True), (0.0049, False)])
def test_check_acceptance_pass_and_fail_at_the_bound(limit, passes):
    m = compute_metrics(frame(record()), scenario(ss_window=(8.0, 10.0)))
    sc = scenario(ss_speed=limit, ss_flux=0.01 + 1e-12, overshoot_speed=0.1 + 1e-12, peak_current=4.9,
                  ss_window=(8.0, 10.0))
    out = check_acceptance(m, sc)
    assert out["ss_speed"] == {"limit": limit, "value": m["ss_speed"], "pass": passes}
    assert out["ss_flux"]["pass"] and out["overshoot_speed"]["pass"]
    assert out["peak_current"] == {"limit": 4.9, "value": 6.0, "pass": False}
    assert check_acceptance(m, scenario(ss_window=(8.0, 10.0))) == {}  # no bounds given
    assert check_acceptance(m, scenario()) == {}  # no acceptance section
    assert check_acceptance({}, sc) == {}  # a failed run has no metrics


# ----- holding the set-points ---------------------------------------------------------------------


def test_limiter_shares_over_the_window():
    r = record()
    flags = T >= 9.0  # t = 9, 9.5, 10: 3 of the 5 samples of [8, 10], 3 of 21 overall
    m = closed_loop_metrics(**r, run=T >= 1.0, ss_window=(8.0, 10.0), voltage_limited=np.zeros(N),
                            current_limited=flags)
    assert m["ss_current_limited_fraction"] == pytest.approx(3 / 5, rel=1e-15)
    assert m["current_limited_fraction"] == pytest.approx(3 / 21, rel=1e-15)
    assert m["ss_voltage_limited_fraction"] == 0.0
    m = closed_loop_metrics(**r, run=T >= 1.0, ss_window=(20.0, 30.0), current_limited=flags)
    assert math.isnan(m["ss_current_limited_fraction"])


def _m(**kw):
    return {"ss_speed": 0.001, "ss_flux": 0.001, "ss_current_limited_fraction": 0.0,
            "ss_voltage_limited_fraction": 0.0, **kw}


def test_a_run_within_the_default_margins_holds():
    holds, line = setpoint_status(_m(ss_speed=0.0199, ss_flux=0.02), (1.3, 1.5))
    assert holds is True and line.startswith("set-points held in [1.3, 1.5] s")
    assert "margin 2 %" in line


@pytest.mark.parametrize("kw, words", [
    ({"ss_speed": 0.0201}, ["speed off its set-point by up to 2.01 % (margin 2 %)"]),
    ({"ss_flux": 0.4}, ["flux off its set-point by up to 40 % (margin 2 %)"]),
    ({"ss_current_limited_fraction": 1.0}, ["current limit active in 100 % of the window"]),
    ({"ss_voltage_limited_fraction": 0.25}, ["voltage limit active in 25 % of the window"]),
    ({"ss_speed": 0.4, "ss_current_limited_fraction": 0.5}, ["speed off", "current limit active in 50 %"]),
])
def test_what_is_missed_is_named_in_one_line(kw, words):
    holds, line = setpoint_status(_m(**kw), (1.35, 1.5))
    assert holds is False and "\n" not in line
    assert line.startswith("set-points NOT held in [1.35, 1.5] s: ")
    for w in words:
        assert w in line, line


def test_stated_margins_replace_the_defaults():
    assert setpoint_status(_m(ss_speed=0.025), (0, 1), speed_margin=0.03)[0] is True
    assert setpoint_status(_m(ss_flux=0.005), (0, 1), flux_margin=0.001)[0] is False
    assert SS_SPEED_MARGIN == 0.02 and SS_FLUX_MARGIN == 0.02  # the documented defaults


def test_not_judged_without_metrics_or_samples():
    assert setpoint_status({}, (0, 1)) == (None, "")
    holds, line = setpoint_status(_m(ss_speed=math.nan), (2.0, 3.0))
    assert holds is None and "no sample" in line


def test_the_default_window_bounds_are_the_last_tenth():
    assert steady_state_bounds(np.array([1.0, 2.0, 11.0])) == (10.0, 11.0)
    assert steady_state_bounds(np.array([0.0, 1.0]), (0.2, 0.5)) == (0.2, 0.5)


@pytest.mark.parametrize("bounds, margins", [({}, "2 %"), ({"ss_speed": 0.05, "ss_flux": 0.05}, "5 %")])
def test_results_judge_with_the_scenarios_window_and_bounds(bounds, margins):
    r = record()  # ss_speed 0.005, ss_flux 0.01 over [8, 10]; no limiter flag there
    sc = scenario(ss_window=(8.0, 10.0), **bounds)
    m = compute_metrics(frame(r), sc)
    holds, line = results_setpoint_status(m, T, sc)
    assert holds is False  # the voltage flags of frame() cover t >= 7.5 s
    assert "[8, 10] s" in line and "voltage limit active in 100 %" in line and "speed off" not in line
    df = frame(r)
    df["controller.voltage_limited"] = False
    holds, line = results_setpoint_status(compute_metrics(df, sc), T, sc)
    assert holds is True and f"margin {margins}" in line
    holds, line = results_setpoint_status(compute_metrics(df, scenario()), T, scenario())
    assert "[9, 10] s" in line  # the default window: the last 10 % of 0 .. 10 s
