"""The drive's safeguards (issue 20, item 5): the measured-current limiter, the load estimate frozen at the
voltage limit (the regenerative stop), the host's coupling delay (host_delay_samples) under a Jacobi master.

Expected values come from independent computations: the limiter's integral in closed form, a
delay's equivalence (the same total delay placed in the host or in the controller gives the same plant
trajectory, bit for bit), the true load torque of the scenario and the sign of a stop.  The Python and
C cores are compared sample by sample in test_native_controller.py (cases "host delay ...",
"measured-current limiter ...", "estimated load at the voltage limit")."""

from __future__ import annotations

import dataclasses
import math
import os
from pathlib import Path

import numpy as np
import pytest

from satmotor.control.current_limit import CURRENT_FLOOR, CurrentLimiter, current_warning
from satmotor.control.drive import DriveConfig
from satmotor.errors import ParameterError
from satmotor.interface import CONTROLLER_INPUTS, CONTROLLER_OUTPUTS, ControllerUnit, PlantUnit

ROOT = Path(__file__).resolve().parents[1]
FMU_DIR = Path(os.environ.get("SATMOTOR_TEST_FMUS", ROOT / "build" / "fmus"))
OUT = {v.name: j for j, v in enumerate(CONTROLLER_OUTPUTS)}


# --- the measured-current limiter (satmotor/control/current_limit.py) -------------------------------------

def test_the_limiter_integrates_the_excess_unwinds_and_warns_once_at_its_floor():
    Ts, gain, I_max = 1e-4, 200.0, 10.0
    lim = CurrentLimiter(I_max, gain, Ts)
    assert lim.bound(9.99) == I_max and lim.i_red == 0.0  # below the limit: nothing moves
    for k in range(1, 51):  # 3 A over the limit: i_red = k Ts gain 3 (a ramp, closed form)
        b = lim.bound(13.0)
        assert b == pytest.approx(I_max - k * Ts * gain * 3.0, rel=1e-12)
    red = lim.i_red
    for k in range(1, 11):  # 2 A under: unwinds at Ts gain 2 per sample
        lim.bound(8.0)
        assert lim.i_red == pytest.approx(red - k * Ts * gain * 2.0, rel=1e-12)
    for _ in range(20000):  # far over, for long: the reduction stops at its cap, one warning
        b = lim.bound(20.0)
    assert b == pytest.approx(CURRENT_FLOOR * I_max, rel=1e-12)
    assert lim.warnings == [current_warning(20.0, I_max)]
    assert "|i_s| = 20 A exceeds I_max = 10 A" in lim.warnings[0]
    for _ in range(20000):  # back under the limit: fully unwound, exactly 0 (the clip)
        b = lim.bound(5.0)
    assert b == I_max and lim.i_red == 0.0
    off = CurrentLimiter(I_max, 0.0, Ts)  # gain 0: off
    assert all(off.bound(50.0) == I_max for _ in range(100)) and off.warnings == []


def test_new_drive_settings_are_checked():
    with pytest.raises(ParameterError, match="host_delay_samples"):
        DriveConfig(host_delay_samples=4)
    with pytest.raises(ParameterError, match="host_delay_samples"):
        DriveConfig(host_delay_samples=True)
    with pytest.raises(ParameterError, match="current_limit_gain"):
        DriveConfig(current_limit_gain=-1.0)


def _closed_loop(ctrl, plant, stop, w_ref, load, host_delay=0):
    """Python plant and controller units, Gauss-Seidel; ``host_delay`` samples of FIFO between the
    controller's output and the plant's input (a host's coupling delay).  Columns: t, omega_m, |psi_r|,
    |i_s|, current_limited, phase."""
    P, C = PlantUnit(plant), ControllerUnit(ctrl)
    Ts = C.Ts
    fifo = [(0.0, 0.0)] * host_delay
    n = round(stop / Ts)
    rec = np.zeros((n, 6))
    for k in range(n):
        t = k * Ts
        o = P.outputs()
        C.step(t, Ts, (o[0], o[1], o[4], o[5], o[2], o[3], o[6], w_ref(t), 0.95, load(t), 0.0))  # v_dc: none
        co = C.outputs()
        fifo.append((co[0], co[1]))
        va, vb = fifo.pop(0)
        P.step(t, Ts, (va, vb, load(t)))
        o = P.outputs()
        rec[k] = (t + Ts, o[6], math.hypot(o[4], o[5]), math.hypot(o[0], o[1]), co[OUT["current_limited"]],
                  co[OUT["phase"]])
    return rec, C


def _ramp(t):
    return 100.0 * min(max((t - 0.2) / 0.5, 0.0), 1.0)


def test_a_plant_that_needs_more_current_than_the_model_is_held_near_I_max():
    """The plant's L_m0 is 60 % of the controller's (21.7 A magnetizing at 0.95 Wb, the model 5.3 A) under
    50 N m with the observer: more than I_max = 30 A can carry.  Without the limiter (gain 0) the measured
    |i_s| peaks at 31.6 A and stays above I_max; with it, it stays within 1.05 I_max and ends below I_max,
    and current_limited is set wherever |i_s| > I_max."""
    ctrl = {"c0": 1e4, "d0": 2500.0, "flux_source": "observer"}

    def load(t):
        return 50.0 if t >= 1.0 else 0.0

    runs = {g: _closed_loop({**ctrl, "current_limit_gain": g}, {"L_m0": 0.166}, 1.5, _ramp, load)[0]
            for g in (0.0, 200.0)}
    off, on = runs[0.0], runs[200.0]
    run_off, run_on = off[:, 5] == 1, on[:, 5] == 1
    print(f"peak |i_s| off {off[run_off, 3].max():.2f} A, on {on[run_on, 3].max():.2f} A; "
          f"final off {off[-1, 3]:.2f} A, on {on[-1, 3]:.2f} A")
    assert off[run_off, 3].max() > 1.05 * 30.0 and off[-1, 3] > 30.0
    assert on[run_on, 3].max() <= 1.05 * 30.0 and on[-1, 3] < 30.0
    over = on[:, 3] > 30.0  # the plant's current after the step; the flag is the controller's next sample
    assert np.all(on[1:, 4][over[:-1] & run_on[1:]] == 1.0)


def test_the_warning_when_the_limit_cannot_be_held_is_logged_by_every_controller_fmu(tmp_path):
    """Measured currents of 20 A (a rotating vector) with I_max = 12 A: the limiter reaches its floor and
    the FMU logs one warning, the text of ControllerUnit's; outputs as the Python unit's."""
    from orchestration.run.fmu_instance import FMUInstance

    fmus = FMU_DIR
    values = {"I_max": 12.0, "premag_time_max": 0.01}
    Ts, n = 1e-4, 2000

    def inputs(k):
        a = 2.0 * math.pi * 5.0 * k * Ts
        return (20.0 * math.cos(a), 20.0 * math.sin(a), 0.95 * math.cos(a), 0.95 * math.sin(a), 0.0, 0.0,
                10.0, 10.0, 0.95, 0.0, 0.0)  # the last: v_dc, not connected

    unit = ControllerUnit(values)
    want = []
    for k in range(n):
        unit.step(k * Ts, Ts, inputs(k))
        want.append(unit.outputs()[0])
    assert len(unit.warnings) == 1 and "I_max = 12 A" in unit.warnings[0], unit.warnings
    names = [v.name for v in CONTROLLER_INPUTS]
    tried = 0
    for sub in ("native", "native-fmi3", "."):
        path = fmus / sub / "BacksteppingController.fmu"
        if not path.exists():
            continue
        tried += 1
        inst = FMUInstance(path, "c")
        try:
            inst.set_parameters(values)
            inst.initialize(0.0)
            vr_in, vr_v = inst.vr(names), inst.vr(["v_s_alpha"])
            s = inst.slave
            setr, getr = (s.setFloat64, s.getFloat64) if inst.fmi3 else (s.setReal, s.getReal)
            got = []
            for k in range(n):
                setr(vr_in, list(inputs(k)))
                inst.do_step(k * Ts, Ts)
                got.append(getr(vr_v)[0])
            warned = [m for level, m in inst.messages if level == "warning"]
        finally:
            inst.close()
        assert got == want, sub
        assert warned == unit.warnings, (sub, warned)
    if not tried:
        pytest.skip(f"no controller FMU under {fmus}")


@pytest.mark.parametrize("variant", ["native", "native-fmi3", "python"])
def test_a_current_the_drive_cannot_hold_is_said_by_the_run(variant, tmp_path):
    """A machine coasting at 400 rad/s, magnetized (0.95 Wb), caught by the drive: its back-EMF (760 V)
    is far beyond V_dc/sqrt(3) (312 V), so the current is not the drive's to bound (78 A peak).  The
    controller logs that the limit cannot be held, the master's result carries it, the CLI's
    metrics.json too; current_limited is set."""
    from orchestration.results.writer import write_results
    from orchestration.scenario.profiles import Constant

    df, m, acc, res = _master("ramp_rated_load", fmu_variant=variant, full=True, stop_time=0.1,
                              plant={"omega_m0": 400.0, "psi_r0": 0.95},
                              profiles={"omega_ref": Constant(400.0), "T_load": Constant(0.0)})
    warned = [text for unit, text in res.warnings if unit == "controller"]
    assert len(warned) == 1 and "the current limit cannot be held" in warned[0], res.warnings
    i_s = np.hypot(df["plant.i_s_alpha"], df["plant.i_s_beta"]).to_numpy()
    assert i_s.max() > 1.05 * 30.0
    assert df["controller.current_limited"].to_numpy()[1:][i_s[:-1] > 30.0].all()
    summary = write_results(res, tmp_path, plot=False)
    assert summary["warnings"] == [f"controller: {warned[0]}"]


# --- the regenerative stop (scenarios/regenerative_stop_limits.yaml) through the master ----------------

def _master(name, fmu_variant="native", algorithm=None, full=False, plant=None, profiles=None, stop_time=None,
            **controller):
    from orchestration.packaging import fmus as fmu_paths
    from orchestration.results.writer import check_acceptance, compute_metrics
    from orchestration.run.master import run
    from orchestration.scenario.load import load_scenario

    plant_fmu, ctrl = fmu_paths.paths(FMU_DIR, fmu_variant)
    if not ctrl.exists():
        pytest.skip(f"{ctrl} not built")
    sc = load_scenario(ROOT / "scenarios" / f"{name}.yaml")
    sc = dataclasses.replace(sc, controller={**sc.controller, **controller},
                             plant={**sc.plant, **(plant or {})}, stop_time=stop_time or sc.stop_time,
                             profiles={**sc.profiles, **(profiles or {})})
    res = run(sc, str(plant_fmu), str(ctrl), algorithm=algorithm)
    assert res.ok, res.message
    m = compute_metrics(res.frame, sc)
    return (res.frame, m, check_acceptance(m, sc)) + ((res,) if full else ())


@pytest.mark.parametrize("field_weakening", [False, True])
def test_the_regenerative_stop_brakes_when_commanded_and_does_not_cross_zero(field_weakening):
    """Stop command at 1.3 s from the voltage limit (field weakening off, as in the issue) or from
    150 rad/s under field weakening.  Before the freeze: the load estimate at its bound (655 N m),
    82 ms of motoring, -25.7 rad/s (field weakening: 184 rad/s before the stop, -26.5 rad/s)."""
    df, m, acc = _master("regenerative_stop_limits", field_weakening=field_weakening)
    t, w = df["time"].to_numpy(), df["plant.omega_m"].to_numpy()
    T_e, T_est = df["plant.T_e"].to_numpy(), df["controller.T_load_est"].to_numpy()
    k0 = int(np.searchsorted(t, 1.3 - 1e-9))
    braking = t[k0 + int(np.argmax(T_e[k0:] < 0.0))] - t[k0]
    print(f"T_e < 0 after {1e3 * braking:.1f} ms; lowest speed {w.min():.3g} rad/s; largest load estimate "
          f"{T_est.max():.2f} N m; speed before the stop {w[k0]:.2f} rad/s")
    assert all(a["pass"] for a in acc.values()), acc
    assert m["final_overshoot_speed"] < 2.0 and w.min() > -2.0
    assert braking < 0.03  # [s] braking within 30 ms of the command (82 ms before)
    assert T_est.max() < 1.1 * 26.71  # the estimate never exceeds the true load by more than 10 %
    if field_weakening:
        assert abs(w[k0] - 150.0) < 0.01 * 150.0  # the set-point held before the stop (212 rad/s before)


# --- the host's coupling delay (host_delay_samples) -------------------------------------------------------

def test_a_jacobi_master_with_host_delay_compensated_runs_as_gauss_seidel():
    """Through the project's master, the default scenario: under Jacobi the plant gets the controller's
    output one sample late.  Uncompensated the steady errors grow 150-fold (speed 1.5e-3, flux 2.9e-3);
    with host_delay_samples = 1 they are Gauss-Seidel's (9.9e-6, 2.3e-5), and the plant's trajectory is
    bit for bit that of Gauss-Seidel with delay_samples = 1 (the same one-sample delay, placed in the
    controller instead of the host, compensated by the same prediction)."""
    gs, m_gs, _ = _master("ramp_rated_load", algorithm="gauss-seidel")
    gs1, _, _ = _master("ramp_rated_load", algorithm="gauss-seidel", delay_samples=1)
    raw, m_raw, _ = _master("ramp_rated_load", algorithm="jacobi")
    jac, m_jac, acc = _master("ramp_rated_load", algorithm="jacobi", host_delay_samples=1)
    for k in ("ss_speed", "ss_flux"):
        print(f"{k}: Gauss-Seidel {m_gs[k]:.3g}, Jacobi {m_raw[k]:.3g}, Jacobi compensated {m_jac[k]:.3g}")
        assert m_raw[k] > 20.0 * m_gs[k]
        assert m_jac[k] <= 1.1 * m_gs[k] + 1e-9
    assert all(a["pass"] for a in acc.values()), acc
    plant_cols = [c for c in jac.columns if c.startswith("plant.")]
    for c in plant_cols:
        assert np.array_equal(jac[c].to_numpy(), gs1[c].to_numpy()), c
    t = gs["time"].to_numpy()
    flux = {n: np.hypot(d["plant.psi_r_alpha"], d["plant.psi_r_beta"]).to_numpy() for n, d in
            (("gs", gs), ("raw", raw), ("jac", jac))}
    late = t >= 0.2
    d_jac, d_raw = (np.max(np.abs(flux[n] - flux["gs"])[late]) for n in ("jac", "raw"))
    print(f"largest flux difference to Gauss-Seidel after 0.2 s: compensated {d_jac:.3g} Wb, uncompensated "
          f"{d_raw:.3g} Wb")
    assert d_jac < 0.01 * d_raw


def test_two_samples_of_host_delay_equal_one_own_and_one_host_sample():
    """A host that delays by two samples (FIFO of 2, host_delay_samples = 2) and a controller that delays
    its output by one with a host adding one (delay_samples = 1, host_delay_samples = 1): the same plant
    trajectory, bit for bit (the prediction over two samples, the shapers looked ahead two samples).
    Compensated, the steady errors are those of Gauss-Seidel without any delay (speed 9.8e-6, flux 2.3e-5);
    uncompensated they are 3.3e-3 and 5.8e-3."""

    def load(t):
        return 26.71 if t >= 0.8 else 0.0

    a, _ = _closed_loop({"host_delay_samples": 2}, {}, 1.2, _ramp, load, host_delay=2)
    b, _ = _closed_loop({"host_delay_samples": 1, "delay_samples": 1}, {}, 1.2, _ramp, load, host_delay=1)
    u, _ = _closed_loop({}, {}, 1.2, _ramp, load, host_delay=2)
    g, _ = _closed_loop({}, {}, 1.2, _ramp, load)
    assert np.array_equal(a, b)
    tail = a[:, 0] >= 1.1
    for col, ref, what in ((1, 100.0, "speed"), (2, 0.95, "flux")):
        err_c, err_u, err_g = (np.max(np.abs(r[tail, col] - ref)) / ref for r in (a, u, g))
        print(f"steady {what} error, 2 samples of host delay: compensated {err_c:.3g}, uncompensated "
              f"{err_u:.3g}; Gauss-Seidel without delay {err_g:.3g}")
        assert err_c <= 1.01 * err_g + 1e-9 and err_u > 20.0 * err_g


def test_the_delay_state_holds_the_queue():
    """The delay's state grows with the samples it queues (Python: 2 n + 11 values)."""
    from satmotor.control.delay import DelayCompensator
    from satmotor.machine.params import MotorParams

    for n in (1, 2, 4):
        d = DelayCompensator(MotorParams(), 1e-4, n_samples=n)
        assert len(d.get_state()) == d.state_size() == 2 * n + 11
        d.push(1.0, 2.0, True)
        s = d.get_state()
        e = DelayCompensator(MotorParams(), 1e-4, n_samples=n)
        e.set_state(s)
        assert e.get_state() == s
