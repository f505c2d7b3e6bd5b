"""Every loss of the drive as plant outputs (issue 35 item 1, satmotor/machine/losses.py).

* the energy balance ``P_in = P_cu_s + P_cu_r + P_fe + P_fw + P_stray + P_inv + P_mech + d(E_mag +
  E_kin)/dt`` through the FMUs (native and pythonfmu), every loss on, average and pwm inverter, integrated
  here over a window (the stored energies compared between its two instants, computed here);
* the C unit against PlantUnit bit for bit with every loss on (each inverter, link, R_fe, thermal);
* the mechanical losses against closed-form coast-downs; the outputs against formulas written here; the
  pwm inverter's mean switching and conduction loss against the textbook averages;
* every new parameter refused when negative (or zero, the references) with a message naming it.
"""

from __future__ import annotations

import itertools
import math
import zlib

import numpy as np
import pytest
from fmu_helpers import Slave, open_fmu
from native_core import load
from native_plant_unit import CPlantUnit, CUnitError

from satmotor.errors import ParameterError
from satmotor.interface import PLANT_OUTPUTS, PlantUnit
from satmotor.machine.library import preset
from satmotor.machine.phases import phase_currents

DEFAULT = dict(preset("default_4kw").values)
# every loss on: core loss, the thermal model (fast, so the temperatures move), the fan load, friction,
# windage, stray load, switching (E_on + E_off 1 mJ at 600 V, 10 A) and the pwm's drops and dead time
LOSSES = dict(R_fe=300.0, thermal=True, T_s0=330.0, T_r0=320.0, C_th_s=40.0, C_th_r=20.0, B_2=2e-4,
              T_fric=0.4, k_wind=2e-5, k_stray=1e-5, E_sw=1e-3, V_sw_ref=600.0, I_sw_ref=10.0)
PWM = dict(inverter="pwm", f_sw=5000.0, t_dead=2e-6, v_on=1.5)
STORED = ("psi_s_alpha", "psi_s_beta", "psi_r_alpha", "psi_r_beta", "omega_m")
MEANS = ("P_in", "P_inv", "P_chop")  # the means over a step; the others at the step's end
INSTANT = ("P_cu_s", "P_cu_r", "P_fe", "P_fw", "P_stray", "P_mech")
NEW = ("T_fric", "k_wind", "k_stray", "E_sw", "V_sw_ref", "I_sw_ref")


@pytest.fixture(scope="module")
def lib():
    return load()


def _stored(values, y):
    """E_mag + E_kin [J] at the outputs ``y`` (fluxes, speed): the magnetic energy of the fluxes (the
    plant's integral of the curve, independent of the losses), 1/2 J omega^2."""
    plant = PlantUnit(values).plant
    x = (y["psi_s_alpha"], y["psi_s_beta"], y["psi_r_alpha"], y["psi_r_beta"], y["omega_m"], 0.0)
    return plant.magnetic_energy(x) + 0.5 * values["J"] * y["omega_m"] ** 2


def _run(path, values, t_end, dt, tmp_path):
    """Open loop on the FMU at ``path``: 50 Hz at 326.6 V (the rated phase peak), magnetized at 148 rad/s,
    20 N m; returns the time series of the outputs (row k after step k) and the stored energies."""
    s = Slave(open_fmu(path, tmp_path / path.parent.name), params=values)
    names = [v.name for v in PLANT_OUTPUTS]
    rows = []
    n = round(t_end / dt)
    for k in range(n):
        t = k * dt
        th = 2.0 * math.pi * 50.0 * t
        s.step(t, dt, {"v_s_alpha": 326.6 * math.cos(th), "v_s_beta": 326.6 * math.sin(th), "T_load": 20.0})
        rows.append(s.get(names))
    s.free()
    return names, np.array(rows)


def _balance(values, names, rows, dt, k0):
    """The energy balance over rows k0 .. end: the input energy, and the residual input - losses - shaft -
    stored-energy change, both [J]; step means summed, values at the step ends by the trapezoid."""
    col = {n: rows[:, j] for j, n in enumerate(names)}
    e = {n: float(np.sum(col[n][k0 + 1:]) * dt) for n in MEANS}
    for n in INSTANT:
        v = col[n][k0:]
        e[n] = float(np.sum(0.5 * (v[1:] + v[:-1])) * dt)
    y0 = {n: col[n][k0] for n in STORED}
    y1 = {n: col[n][-1] for n in STORED}
    d_stored = _stored(values, y1) - _stored(values, y0)
    out = sum(e[n] for n in INSTANT) + e["P_inv"] + e["P_chop"] + d_stored
    return e["P_in"], e["P_in"] - out, e


@pytest.mark.parametrize("kind", ["native", "pythonfmu"])
@pytest.mark.parametrize("inverter", ["average", "pwm"])
def test_energy_balance_through_the_fmus_every_loss_on(fmu_dir, tmp_path, kind, inverter):
    values = dict(DEFAULT, **LOSSES, omega_m0=148.0, psi_r0=0.9, **(PWM if inverter == "pwm" else {}))
    path = (fmu_dir / "native" if kind == "native" else fmu_dir) / "SaturatedInductionMotor.fmu"
    dt = 1e-4 if inverter == "average" else 2e-5
    t_end = 0.2 if kind == "native" or inverter == "average" else 0.08
    names, rows = _run(path, values, t_end, dt, tmp_path)
    k0 = round(0.04 / dt)  # the window from 40 ms on (the start's transient decayed in part)
    e_in, res, e = _balance(values, names, rows, dt, k0)
    print(f"{kind} {inverter}: E_in = {e_in:.6g} J over {(len(rows) - 1 - k0) * dt:.3g} s, residual "
          f"{res:.4g} J ({res / e_in:.3g} of E_in); " + ", ".join(f"{n} {v:.4g}" for n, v in e.items()))
    for n in ("P_cu_s", "P_cu_r", "P_fe", "P_fw", "P_stray", "P_inv", "P_mech"):
        assert e[n] > 0.0, n  # every loss is on
    assert abs(res) < 3e-4 * e_in


def _outputs(u):
    return dict(zip(PlantUnit.OUTPUTS, u.outputs()))


def test_the_loss_outputs_are_their_formulas():
    """At a running state (R_fe = 0, thermal off): the copper, friction, windage, stray and shaft powers
    from the currents and speed by the formulas written here; the average inverter's P_in against 3/2 v.i
    by the trapezoid over a fine step."""
    values = dict(DEFAULT, T_fric=0.4, k_wind=2e-5, k_stray=1e-5, B_2=2e-4, omega_m0=140.0, psi_r0=0.9,
                  E_sw=1e-3)
    u = PlantUnit(values)
    v = (300.0, 40.0)
    i_prev = None
    for k in range(50):
        o = _outputs(u)
        i_prev = (o["i_s_alpha"], o["i_s_beta"])
        u.step(k * 1e-5, 1e-5, (*v, 12.0))
    o = _outputs(u)
    i2 = o["i_s_alpha"] ** 2 + o["i_s_beta"] ** 2
    w = o["omega_m"]
    ir = u.plant.outputs(u.x)
    assert o["P_cu_s"] == pytest.approx(1.5 * DEFAULT["R_s"] * i2, rel=1e-14)
    i2r = ir.i_r_alpha ** 2 + ir.i_r_beta ** 2
    assert o["P_cu_r"] == pytest.approx(1.5 * DEFAULT["R_r"] * i2r, rel=1e-14)
    assert o["P_fw"] == pytest.approx((DEFAULT["B"] * w + 0.4 + 2e-5 * w * w) * w, rel=1e-14)
    assert o["P_stray"] == pytest.approx(1e-5 * i2 * w * w, rel=1e-14)
    assert o["P_mech"] == pytest.approx((12.0 + 2e-4 * w * w) * w, rel=1e-14)
    cur = phase_currents(o["i_s_alpha"], o["i_s_beta"])
    p_sw = 5000.0 * 1e-3 * (540.0 / 600.0) * sum(abs(c) for c in cur) / 10.0
    assert o["P_inv"] == pytest.approx(p_sw, rel=1e-14)
    p_term = 1.5 * (v[0] * 0.5 * (i_prev[0] + o["i_s_alpha"]) + v[1] * 0.5 * (i_prev[1] + o["i_s_beta"]))
    assert o["P_in"] - o["P_inv"] == pytest.approx(p_term, rel=1e-6)


@pytest.mark.parametrize("what", ["T_fric", "k_wind"])
def test_friction_and_windage_act_on_the_shaft_as_closed_form_coast_downs(what):
    """No flux, no voltage: J dw/dt = -T_fric (w > 0) gives w0 - T_fric t / J; J dw/dt = -k_wind w^2 gives
    w0 / (1 + k_wind w0 t / J); P_fw is the torque times the speed."""
    J, w0, c = 0.0131, 100.0, (0.5 if what == "T_fric" else 1e-4)
    u = PlantUnit(dict(DEFAULT, B=0.0, omega_m0=w0, **{what: c}))
    for k in range(500):
        u.step(k * 1e-3, 1e-3, (0.0, 0.0, 0.0))
    t = 0.5
    want = w0 - c * t / J if what == "T_fric" else w0 / (1.0 + c * w0 * t / J)
    o = _outputs(u)
    assert o["omega_m"] == pytest.approx(want, rel=1e-10)
    torque = c if what == "T_fric" else c * want * want
    assert o["P_fw"] == pytest.approx(torque * o["omega_m"], rel=1e-9)
    assert o["P_mech"] == 0.0 and o["P_in"] == 0.0


def test_the_pwm_inverters_mean_losses_are_the_textbook_averages():
    """Steady 50 Hz currents on the pwm inverter: over whole periods the switching loss is f_sw E_sw
    (V/V_ref) sum|i_j| / I_ref with sum|i_j| averaging 6/pi I_peak, the conduction loss v_on sum|i_j|."""
    base = dict(DEFAULT, omega_m0=148.0, psi_r0=0.9, inverter="pwm", f_sw=5000.0)
    six_pi = 6.0 / math.pi  # the mean of sum |i_j| per ampere of the amplitude
    for extra, law in ((dict(E_sw=2e-3), lambda ipk: 5000.0 * 2e-3 * 540.0 / 600.0 * six_pi * ipk / 10.0),
                       (dict(v_on=2.0), lambda ipk: 2.0 * six_pi * ipk)):
        u = PlantUnit(dict(base, **extra))
        dt, p_inv, i_pk = 1e-4, [], []
        for k in range(1200):  # 0.12 s: the last 0.04 s (two periods) averaged
            th = 2.0 * math.pi * 50.0 * k * dt
            u.step(k * dt, dt, (300.0 * math.cos(th), 300.0 * math.sin(th), 20.0))  # linear range
            if k >= 800:
                o = _outputs(u)
                p_inv.append(o["P_inv"])
                i_pk.append(math.hypot(o["i_s_alpha"], o["i_s_beta"]))
        want = law(float(np.mean(i_pk)))
        print(f"{extra}: mean P_inv {np.mean(p_inv):.5g} W, textbook {want:.5g} W")
        assert float(np.mean(p_inv)) == pytest.approx(want, rel=0.03)


COMBOS = {f"{inv} {link} R_fe={r_fe} thermal={th}": {
    **DEFAULT, "psi_r0": 0.8, "omega_m0": 120.0, **PWM, "inverter": inv, "dc_link": link, "R_fe": r_fe,
    "T_fric": 0.3, "k_wind": 3e-5, "k_stray": 2e-5, "E_sw": 1.5e-3, "B_2": 1e-4,
    **(dict(thermal=True, T_s0=353.15, T_r0=343.15, C_th_s=30.0, C_th_r=12.0) if th else {}),
    **(dict(C_dc=470e-6, R_chop=40.0, V_chop_on=548.0, V_chop_off=544.0) if link == "capacitor" else {})}
    for inv, link, r_fe, th in itertools.product(("average", "pwm"), ("ideal", "capacitor"), (0.0, 500.0),
                                                  (False, True))}


@pytest.mark.parametrize("label", COMBOS)
def test_c_unit_is_plant_unit_bit_for_bit_with_every_loss_on(lib, label):
    values = COMBOS[label]
    rng = np.random.default_rng(zlib.crc32(label.encode()))
    py, c = PlantUnit(values), CPlantUnit(lib, values)
    t = 0.0
    for k in range(10 if "pwm" in label else 30):
        amp, ph = float(rng.uniform(50.0, 400.0)), float(rng.uniform(-math.pi, math.pi))
        u = (amp * math.cos(ph), amp * math.sin(ph), float(rng.uniform(-20.0, 20.0)))
        dt = (1e-4, 2.5e-4, 3e-5)[k % 3]
        py.step(t, dt, u)
        c.step(t, dt, u)
        t += dt
        assert c.outputs() == py.outputs(), (label, k)
        assert c.get_state() == py.get_state(), (label, k)
    o = dict(zip(PlantUnit.OUTPUTS, py.outputs()))
    assert o["P_stray"] > 0.0 and o["P_fw"] > 0.0 and o["P_inv"] > 0.0, o
    c.set_state(py.get_state())  # the held means restored with the state
    assert c.outputs() == py.outputs()


@pytest.mark.parametrize("name", NEW)
def test_every_new_parameter_is_refused_negative_with_its_name(lib, name):
    bad = -1.0 if name in NEW[:4] else 0.0
    with pytest.raises(ParameterError) as py_err:
        PlantUnit({name: bad})
    with pytest.raises(CUnitError) as c_err:
        CPlantUnit(lib, {name: bad})
    assert str(py_err.value).startswith(f"{name} = ")
    assert c_err.value.message == str(py_err.value)
