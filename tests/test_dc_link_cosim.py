"""The regenerative stop of issue 19 (150 -> 0 rad/s, 5x inertia) through the native FMUs and the
project's master (scenarios/regenerative_stop.yaml): the energy the motor returned, E_regen, against the
kinetic energy less the losses computed here from the recorded signals; the link's own balance; the
chopper holding the link below V_dc_max; without the chopper, the over-voltage fault reported; the
controller fed the link voltage by the master."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from orchestration.packaging import fmus
from orchestration.results.writer import check_acceptance, compute_metrics
from orchestration.run.master import run
from orchestration.scenario.load import load_scenario
from orchestration.scenario.system import LINK_CONNECTION, connections_for
from satmotor.interface import motor_params

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scenarios" / "regenerative_stop.yaml"
T_BRAKE = 1.0  # [s] the stop's ramp starts (the scenario)


def _cosim(fmu_dir, **plant):
    sc = load_scenario(SCENARIO)
    sc = dataclasses.replace(sc, plant={**sc.plant, **plant})
    p, c = fmus.paths(fmu_dir, "native")
    res = run(sc, str(p), str(c))
    assert res.ok, res.message
    return sc, res.frame


def _trapezoid(t, y):
    return float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(t)))


@pytest.fixture(scope="module")
def stop(fmu_dir):
    return _cosim(fmu_dir)


def test_the_master_connects_the_link_voltage_for_a_capacitor_link():
    assert LINK_CONNECTION in connections_for({"dc_link": "capacitor"})
    assert LINK_CONNECTION not in connections_for({}) and LINK_CONNECTION not in connections_for(
        {"dc_link": "ideal"})


def test_regenerated_energy_is_the_kinetic_energy_less_the_losses(stop):
    """From the stop's start to the end: E_regen (the plant's integral of max(0, -3/2 v_s.i_s)) against
    1/2 J (w0^2 - w1^2) - int (3/2 R_s |i_s|^2 + 3/2 R_r |i_r|^2 + B w^2) dt - d(magnetic energy) +
    int max(0, 3/2 v_s.i_s) dt, each term computed here from the recorded signals (i_r from the fluxes:
    i_r = (psi_r - k (psi_s - l_s i_s)) / l_r), trapezoids over the 1e-4 s grid."""
    sc, df = stop
    p = motor_params(dict(sc.motor))
    t = df["time"].to_numpy()
    sel = t >= T_BRAKE - 1e-9
    g = {c: df[c].to_numpy()[sel] for c in df.columns}
    t = g["time"]
    isa, isb = g["plant.i_s_alpha"], g["plant.i_s_beta"]
    psa, psb, pra, prb = (g[f"plant.psi_{a}"] for a in ("s_alpha", "s_beta", "r_alpha", "r_beta"))
    ira = (pra - p.k * (psa - p.l_s * isa)) / p.l_r
    irb = (prb - p.k * (psb - p.l_s * isb)) / p.l_r
    w = g["plant.omega_m"]
    losses = _trapezoid(t, 1.5 * p.R_s * (isa**2 + isb**2) + 1.5 * p.R_r * (ira**2 + irb**2) + p.B * w**2)
    i_mu = g["plant.i_mu"]
    d_mag = (1.5 * (0.5 * p.l_s * (isa[-1]**2 + isb[-1]**2) + 0.5 * p.l_r * (ira[-1]**2 + irb[-1]**2)
                    + p.curve.energy(float(i_mu[-1])))
             - 1.5 * (0.5 * p.l_s * (isa[0]**2 + isb[0]**2) + 0.5 * p.l_r * (ira[0]**2 + irb[0]**2)
                      + p.curve.energy(float(i_mu[0]))))
    # the power the inverter gave the motor: the controller's command (held over each step, the link
    # above v_dc/sqrt(3) of it: no clamping), the currents at the step's ends
    va, vb = g["controller.v_s_alpha"], g["controller.v_s_beta"]
    assert (np.hypot(va, vb) <= g["plant.v_dc"] / np.sqrt(3.0)).all()
    p_left = 1.5 * (va[:-1] * isa[:-1] + vb[:-1] * isb[:-1])
    p_right = 1.5 * (va[:-1] * isa[1:] + vb[:-1] * isb[1:])
    dt = np.diff(t)
    motoring = float(np.sum(0.5 * (np.maximum(p_left, 0.0) + np.maximum(p_right, 0.0)) * dt))
    kinetic = 0.5 * p.J * (w[0] ** 2 - w[-1] ** 2)
    expected = kinetic - losses - d_mag + motoring
    e_regen = g["plant.E_regen"][-1] - g["plant.E_regen"][0]
    print(f"kinetic {kinetic:.2f} J, losses {losses:.2f} J, d(magnetic) {d_mag:.3f} J, motoring "
          f"{motoring:.2f} J: expected {expected:.2f} J, E_regen {e_regen:.2f} J "
          f"({e_regen / expected - 1.0:+.2e})")
    assert kinetic > 700.0 and w[-1] == pytest.approx(0.0, abs=0.5)
    assert e_regen == pytest.approx(expected, rel=5e-3)


def test_link_balance_and_the_chopper_holds_the_link(stop):
    """From the first sample above 540 V in the stop (the source's diode blocked from there on):
    1/2 C (v1^2 - v0^2) = E_regen - E_motoring - E_chop, E_motoring the power the motor drew from the
    link (computed here as in the test above); the chopper keeps v_dc below V_dc_max; no fault; the
    acceptance bounds pass."""
    sc, df = stop
    t = df["time"].to_numpy()
    v_all = df["plant.v_dc"].to_numpy()
    k0 = int(np.argmax((t >= T_BRAKE - 1e-9) & (v_all > 540.0)))
    g = {c: df[c].to_numpy()[k0:] for c in df.columns}
    v = g["plant.v_dc"]
    assert v.min() > 540.0  # no source current from here on
    m = compute_metrics(df, sc)
    print(f"peak v_dc {m['peak_v_dc']:.2f} V, E_regen {m['E_regen']:.1f} J, E_chop {m['E_chop']:.1f} J, "
          f"fault {m['dc_fault']}")
    assert m["dc_fault"] == 0.0 and 750.0 < m["peak_v_dc"] < sc.plant["V_dc_max"]
    verdicts = check_acceptance(m, sc)
    assert set(verdicts) >= {"peak_v_dc", "ss_speed"} and all(x["pass"] for x in verdicts.values()), verdicts
    isa, isb = g["plant.i_s_alpha"], g["plant.i_s_beta"]
    va, vb = g["controller.v_s_alpha"], g["controller.v_s_beta"]
    p_left = 1.5 * (va[:-1] * isa[:-1] + vb[:-1] * isb[:-1])
    p_right = 1.5 * (va[:-1] * isa[1:] + vb[:-1] * isb[1:])
    motoring = float(np.sum(0.5 * (np.maximum(p_left, 0.0) + np.maximum(p_right, 0.0)) * np.diff(g["time"])))
    stored = 0.5 * sc.plant["C_dc"] * (v[-1] ** 2 - v[0] ** 2)
    e_regen = g["plant.E_regen"][-1] - g["plant.E_regen"][0]
    e_chop = g["plant.E_chop"][-1] - g["plant.E_chop"][0]
    print(f"1/2 C dv^2 {stored:.3f} J = E_regen {e_regen:.3f} - motoring {motoring:.3f} - E_chop "
          f"{e_chop:.3f} = {e_regen - motoring - e_chop:.3f} J")
    assert e_chop > 0.5 * e_regen
    assert stored == pytest.approx(e_regen - motoring - e_chop, abs=1e-3 * e_regen)


def test_without_the_chopper_the_fault_is_reported(fmu_dir):
    sc, df = _cosim(fmu_dir, R_chop=0.0)
    m = compute_metrics(df, sc)
    fault = df["plant.dc_fault"].to_numpy()
    first = int(np.argmax(fault))
    v = df["plant.v_dc"].to_numpy()
    print(f"no chopper: peak v_dc {m['peak_v_dc']:.1f} V, fault at t = {df['time'].to_numpy()[first]:.4f} s")
    assert m["dc_fault"] == 1.0 and m["E_chop"] == 0.0 and m["peak_v_dc"] > 1000.0
    assert (fault[first:] == 1.0).all() and (fault[:first] == 0.0).all() and v[first] > 800.0 >= v[first - 1]
    assert not check_acceptance(m, sc)["peak_v_dc"]["pass"]

