"""The plant's options combined (issue 19 item 5): the capacitor DC link with core loss and the thermal
model, the pwm inverter with them, and the pwm inverter on the capacitor link.

* the C core against the Python specification, bit for bit (ctypes);
* every plant FMU variant against PlantUnit, every output bit for bit, and an FMU state restored;
* the energy balance with everything on: the capacitor's energy given up = chopper + copper + core +
  friction + load work + stored magnetic and kinetic energy change (+ the devices' conduction loss,
  zero without on-state drops), each power written here from the terminal quantities and integrated as
  extra states of a metered plant (the source blocked: a rectifier on a 1 V grid never conducts);
* the options off: today's results bit for bit (the existing tests; here the ideal-link pwm plant with
  the thermal model off equals the unit without it).
"""

from __future__ import annotations

import ctypes
import math
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from satmotor.converter.dc_link import DCLink
from satmotor.interface import PlantUnit
from satmotor.machine.integrate import rk4
from satmotor.machine.library import preset
from satmotor.machine.plant import OMEGA_M

sys.path.insert(0, str(Path(__file__).resolve().parent))
import native_core as nc  # noqa: E402

needs_gcc = pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")

QU = dict(preset("qu2012_2kw2").values)
WARM = dict(thermal=True, T_s0=353.15, T_r0=343.15, C_th_s=30.0, C_th_r=12.0)
LINK = dict(dc_link="capacitor", C_dc=470e-6, R_chop=40.0, V_chop_on=548.0, V_chop_off=544.0, V_dc_max=900.0)
PWM = dict(inverter="pwm", f_sw=5000.0, t_dead=2e-6, v_on=1.0)

COMBOS = {
    "capacitor R_fe": dict(LINK, R_fe=500.0, psi_r0=0.8),
    "capacitor thermal": dict(LINK, **WARM, psi_r0=0.8),
    "capacitor R_fe thermal qu": dict(QU, **LINK, R_fe=600.0, **WARM, psi_r0=0.7),
    "pwm R_fe thermal": dict(PWM, R_fe=500.0, **WARM, psi_r0=0.8),
    "pwm thermal qu": dict(QU, **PWM, **WARM, psi_r0=0.7),
    "pwm capacitor": dict(PWM, **LINK, psi_r0=0.8),
    "pwm capacitor R_fe thermal rectifier": dict(PWM, **LINK, R_fe=500.0, **WARM, dc_source="rectifier",
                                                 psi_r0=0.8),
    "pwm capacitor qu no drops": {**QU, **PWM, **LINK, "v_on": 0.0, "R_fe": 600.0,
                                                       "psi_r0": 0.7},
}


def _commands(seed, n):
    rng = np.random.default_rng(seed)
    out = []
    for k in range(n):
        amp = float(rng.uniform(50.0, 380.0)) if k % 5 else float(rng.uniform(0.0, 40.0))
        ph = float(rng.uniform(-math.pi, math.pi))
        out.append((amp * math.cos(ph), amp * math.sin(ph), float(rng.uniform(-30.0, 20.0))))
    return out


# ---- the C core, bit for bit ------------------------------------------------------------------------

@pytest.fixture(scope="module")
def lib():
    if shutil.which("gcc") is None:
        pytest.skip("needs gcc")
    return nc.load()


def _c_plant(lib, values):
    v = {k: (int(x) if isinstance(x, bool) else x) for k, x in values.items()}
    msg = ctypes.create_string_buffer(1024)
    motor = nc.new_motor(lib)
    pp = nc.params(lib, nc.PlantParams, v)
    assert lib.sm_motor_init(motor, nc.params(lib, nc.MotorParams, v), pp, msg, 1024) == 0, msg.value
    link = (ctypes.c_double * ((lib.sm_dclink_size() + 7) // 8))()
    lp = nc.params(lib, nc.DCLinkParams, v)
    assert lib.sm_dclink_init(link, lp, msg, 1024) == 0, msg.value
    inv = nc.new_inverter(lib)
    assert lib.sm_inverter_init(inv, pp, lp.V_dc, msg, 1024) == 0, msg.value
    return motor, link, inv


@needs_gcc
@pytest.mark.parametrize("label", list(COMBOS))
def test_c_core_equals_python_bit_for_bit(lib, label):
    values = dict(COMBOS[label], omega_m0=150.0)  # spinning: the random commands brake it (the chopper)
    u = PlantUnit(values)
    motor, link, inv = _c_plant(lib, values)
    x = (ctypes.c_double * 11)(*u.x)
    n = len(u.x)
    chop, fault, tf = ctypes.c_int(0), ctypes.c_int(0), ctypes.c_double()
    avg = (ctypes.c_double * 2)()
    memo = (ctypes.c_double * 4)()
    lib.sm_solve_memo_clear(memo)
    pwm, cap = values.get("inverter") == "pwm", values.get("dc_link") == "capacitor"
    t, seen_chop = 0.0, False
    for k, (va, vb, tl) in enumerate(_commands(3, 120)):
        dt = 1e-4 if k % 4 else 2.5e-4
        u.step(t, dt, (va, vb, tl))
        if pwm and cap:
            st = lib.sm_inverter_step_link(inv, motor, link, memo, x, t, dt, va, vb, tl, avg, chop, fault, tf,
                                           None, 0, None)
        elif pwm:
            st = lib.sm_inverter_step(inv, motor, x, t, dt, va, vb, tl, avg, None, 0, None)
        else:
            st = lib.sm_dclink_step(motor, link, t, x, va, vb, tl, dt, u._n_sub, chop, fault, tf)
        assert st == 0, k
        t += dt
        assert tuple(x)[:n] == u.x, (label, k)
        if pwm:
            assert (avg[0], avg[1]) == u._v, (label, k)
        if cap:
            assert (bool(chop.value), bool(fault.value)) == (u._chop, u._fault), (label, k)
            seen_chop |= bool(chop.value)
        u.warnings.clear()
    if cap:
        assert seen_chop, "the chopper took part"


# ---- the plant FMUs -------------------------------------------------------------------------------

@pytest.mark.parametrize("variant", ["python", "native", "native-fmi3"])
@pytest.mark.parametrize("label", ["capacitor R_fe thermal qu", "pwm R_fe thermal",
                                   "pwm capacitor R_fe thermal rectifier"])
def test_plant_fmu_equals_the_plant_unit_and_restores_its_state(variant, label, fmu_dir):
    """Every output bit for bit against PlantUnit; an FMU state taken mid-run and restored gives the same
    continuation."""
    from orchestration.packaging import fmus
    from orchestration.run.fmu_instance import FMUInstance

    values = COMBOS[label]
    inst = FMUInstance(str(fmus.paths(fmu_dir, variant)[0]), "combo")
    inst.set_parameters(values)
    inst.initialize(0.0)
    s = inst.slave
    get, set_ = (s.getFloat64, s.setFloat64) if inst.fmi3 else (s.getReal, s.setReal)
    outs, ins = inst.vr(list(PlantUnit.OUTPUTS)), inst.vr(list(PlantUnit.INPUTS))
    u = PlantUnit(values)
    assert get(outs) == list(u.outputs())
    cmds = _commands(11, 60)
    for k, c in enumerate(cmds):
        if k == 30:
            state = s.getFMUState() if inst.fmi3 else s.getFMUstate()
        set_(ins, list(c))
        s.doStep(k * 1e-4, 1e-4)
        u.step(k * 1e-4, 1e-4, c)
        assert get(outs) == list(u.outputs()), (label, k)
    end = get(outs)
    (s.setFMUState if inst.fmi3 else s.setFMUstate)(state)
    for k in range(30, 60):
        set_(ins, list(cmds[k]))
        s.doStep(k * 1e-4, 1e-4)
    assert get(outs) == end
    inst.close()


# ---- the energy balance -------------------------------------------------------------------------------

class Metered:
    """A plant that carries, after its own states, the integrals of the powers written here from the
    terminal quantities at the voltage applied (input, stator and rotor copper, core, friction, load):
    the link and the inverter see it as a plant with five more "thermal" states."""

    N_E = 5

    def __init__(self, plant, mp, th, R_fe, B_2):
        self.plant, self.mp, self.th, self.R_fe, self.B_2 = plant, mp, th, R_fe, B_2
        self.n = 6 + len(plant.thermal_state())

    def thermal_state(self):
        return self.plant.thermal_state() + (0.0,) * self.N_E

    def outputs(self, x, v_a=0.0, v_b=0.0):
        return self.plant.outputs(x[:self.n], v_a, v_b)

    def stator_resistance(self, x):  # the pwm inverter's loss accounting (satmotor.machine.losses)
        return self.plant.stator_resistance(x[:self.n])

    def derivatives(self, t, x, v_a, v_b, T_load, warm=None):
        n, mp, th = self.n, self.mp, self.th
        xm = x[:n]
        o = self.plant.outputs(xm, v_a, v_b)
        Ts, Tr = (xm[6], xm[7]) if n == 8 else (th.T_s0, th.T_r0)
        Rs = mp.R_s * (1.0 + th.alpha_s * (Ts - th.T_ref))  # written here, not the plant's
        Rr = mp.R_r * (1.0 + th.alpha_r * (Tr - th.T_ref))
        ea, eb = v_a - Rs * o.i_s_alpha, v_b - Rs * o.i_s_beta
        w = xm[OMEGA_M]
        return (*self.plant.derivatives(t, xm, v_a, v_b, T_load),
                1.5 * (v_a * o.i_s_alpha + v_b * o.i_s_beta),
                1.5 * (Rs * (o.i_s_alpha**2 + o.i_s_beta**2) + Rr * (o.i_r_alpha**2 + o.i_r_beta**2)),
                1.5 * (ea * ea + eb * eb) / self.R_fe if self.R_fe > 0.0 else 0.0,
                (mp.B + self.B_2 * abs(w)) * w * w,
                T_load * w)

    def step(self, t, x, v_a, v_b, T_load, h, n_sub=1):
        return rk4(self.derivatives, t, x, h, n_sub, (v_a, v_b, T_load))


def _metered_unit(values):
    u = PlantUnit(values)
    m = Metered(u.plant, u.params, u.plant.th, values.get("R_fe", 0.0), values.get("B_2", 0.0))
    x0 = u.x[:m.n] + (0.0,) * Metered.N_E
    u.plant = m
    if u._link is not None:
        u._link = DCLink(m, u.link)
        x0 = u._link.initial_state(x0)
    u.x = x0
    return u, m


BRAKE = dict(QU, **LINK, dc_source="rectifier", V_grid=1.0, R_fe=600.0, **WARM, psi_r0=0.9, omega_m0=150.0,
             J=0.075, B=0.002, B_2=2e-5, h_int=2e-5)


def _brake_run(values, t_end, dt):
    """A V/f command slowing from 47 Hz by 60 Hz/s (the 2-pole-pair rotor at 150 rad/s: it generates);
    returns (unit, metered plant, x0)."""
    u, m = _metered_unit(values)
    x0, theta = u.x, 0.0
    for k in range(round(t_end / dt)):
        f = max(47.0 - 60.0 * k * dt, 3.0)
        v = 326.0 * f / 50.0
        u.step(k * dt, dt, (v * math.cos(theta), v * math.sin(theta), 2.0))
        theta += 2.0 * math.pi * f * dt
    return u, m, x0


def _residual(u, m, x0, values):
    n, iv = m.n, u._link.iv
    x = u.x
    e_in, e_cu, e_fe, e_fric, e_load = x[n:n + Metered.N_E]
    w_cap = 0.5 * values["C_dc"] * (x0[iv] ** 2 - x[iv] ** 2)  # the energy the capacitor gave up
    d_mag = m.plant.magnetic_energy(x[:n]) - m.plant.magnetic_energy(x0[:n])
    d_kin = 0.5 * values["J"] * (x[OMEGA_M] ** 2 - x0[OMEGA_M] ** 2)
    e_chop = x[iv + 2]
    motor = e_in - (e_cu + e_fe + e_fric + e_load + d_mag + d_kin)
    link = w_cap - (e_chop + e_in)
    scale = abs(e_chop) + abs(e_cu) + abs(e_fe) + abs(d_kin)
    return motor, link, scale, dict(E_chop=e_chop, E_cu=e_cu, E_fe=e_fe, dW_kin=d_kin, W_cap=w_cap,
                                    E_regen=x[iv + 1], v_dc=x[iv])


def test_energy_balance_capacitor_link_with_core_loss_and_thermal_model():
    """Average inverter on the capacitor link, chopper, R_fe, thermal model: the capacitor's energy given up
    = chopper + copper + core + friction + load + magnetic and kinetic change, within 1e-6 of the energy
    that flowed (the source blocked)."""
    u, m, x0 = _brake_run(BRAKE, 0.5, 1e-4)
    motor, link, scale, e = _residual(u, m, x0, BRAKE)
    print(f"average/capacitor: {e}; motor residual {motor:.3g} J, link residual {link:.3g} J, "
          f"relative {max(abs(motor), abs(link)) / scale:.3g}")
    assert e["E_chop"] > 50.0 and e["E_fe"] > 1.0 and e["dW_kin"] < -100.0
    assert u.x[6] > WARM["T_s0"]  # the stator heated
    assert max(abs(motor), abs(link)) / scale < 1e-6


@pytest.mark.slow
@pytest.mark.parametrize("v_on", [0.0, 1.0])
def test_energy_balance_pwm_on_the_capacitor_link_with_everything_on(v_on):
    """pwm (dead time; drops v_on) on the capacitor link with chopper, R_fe and the thermal model: the
    same balance; with drops the capacitor gives up the devices' conduction loss more, which is positive
    and below v_on times the rectified phase currents' integral bound."""
    values = {**BRAKE, **PWM, "v_on": v_on}
    u, m, x0 = _brake_run(values, 0.3, 1e-4)
    motor, link, scale, e = _residual(u, m, x0, values)
    print(f"pwm/capacitor v_on={v_on}: {e}; motor residual {motor:.3g} J, link residual {link:.3g} J "
          f"(relative {abs(motor) / scale:.3g}, {abs(link) / scale:.3g})")
    assert e["E_chop"] > 20.0 and e["E_fe"] > 1.0
    assert abs(motor) / scale < 1e-6
    if v_on == 0.0:
        assert abs(link) / scale < 1e-6
    else:
        assert link > 0.0  # conduction loss


def test_energy_balance_pwm_ideal_link_with_core_loss_and_thermal_model():
    """pwm on the ideal link with R_fe and the thermal model: the motor-side balance (input = copper + core
    + friction + load + stored) over a start with the switched voltages."""
    values = dict(QU, **PWM, R_fe=600.0, **WARM, h_int=2e-5)
    u, m = _metered_unit(values)
    x0 = u.x
    V, W = 400.0 * math.sqrt(2.0 / 3.0), 2.0 * math.pi * 50.0
    for k in range(2000):
        t = k * 1e-4
        u.step(t, 1e-4, (V * math.cos(W * t), V * math.sin(W * t), 5.0))
    n, x = m.n, u.x
    e_in, e_cu, e_fe, e_fric, e_load = x[n:n + 5]
    stored = (m.plant.magnetic_energy(x[:n]) - m.plant.magnetic_energy(x0[:n])
              + 0.5 * values["J"] * (x[OMEGA_M] ** 2 - x0[OMEGA_M] ** 2))
    res = e_in - (e_cu + e_fe + e_fric + e_load + stored)
    print(f"pwm/ideal: input {e_in:.6g} J, core {e_fe:.6g} J, residual {res:.3g} J ({res / e_in:.3g})")
    assert e_fe > 0.01 * e_in and abs(res) / e_in < 1e-6


def test_options_off_pwm_ideal_link_is_unchanged():
    """The pwm plant with the thermal model off at T_ref and R_fe = 0 takes the six-state path: the same
    floats as the PwmInverter on the bare plant."""
    from satmotor.converter.inverter import InverterParams, PwmInverter
    from satmotor.machine.plant import Plant

    values = dict(PWM, psi_r0=0.8)
    u = PlantUnit(values)
    plant = Plant(u.params)
    inv = PwmInverter(InverterParams(540.0, "pwm", 5000.0, 2e-6, 1.0))
    x = u.x
    for k, (va, vb, tl) in enumerate(_commands(5, 40)):
        u.step(k * 1e-4, 1e-4, (va, vb, tl))
        x, *_ = inv.step(plant, k * 1e-4, x, va, vb, tl, 1e-4, u.h_int)
        assert u.x == x


# ---- the scenario -------------------------------------------------------------------------------------

@pytest.mark.slow
def test_the_pwm_capacitor_stop_scenario(fmu_dir):
    """scenarios/pwm_capacitor_stop.yaml through the native FMUs and the master: its acceptance holds, no
    fault, the chopper takes part and holds the link between its thresholds and the fault level, and the
    chopper burns less than the kinetic energy 1/2 J w^2 the stop releases."""
    from orchestration.packaging import fmus
    from orchestration.results.writer import check_acceptance, compute_metrics
    from orchestration.run.master import run
    from orchestration.scenario.load import load_scenario

    sc = load_scenario(Path(__file__).resolve().parents[1] / "scenarios" / "pwm_capacitor_stop.yaml")
    p, c = fmus.paths(fmu_dir, "native")
    res = run(sc, str(p), str(c))
    assert res.ok, res.message
    m = compute_metrics(res.frame, sc)
    verdicts = check_acceptance(m, sc)
    kinetic = 0.5 * 0.075 * 150.0**2
    print(f"E_regen {m['E_regen']:.2f} J, E_chop {m['E_chop']:.2f} J, peak v_dc {m['peak_v_dc']:.2f} V, "
          f"kinetic {kinetic:.2f} J; {verdicts}")
    assert set(verdicts) >= {"peak_v_dc", "ss_speed", "ss_flux"} and all(v["pass"] for v in verdicts.values())
    assert m["dc_fault"] == 0.0
    assert sc.plant["V_chop_off"] < m["peak_v_dc"] < sc.plant["V_dc_max"]
    assert 0.0 < m["E_chop"] < m["E_regen"] < kinetic
