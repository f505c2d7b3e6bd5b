"""The plant's quadratic (fan/pump) load B_2 omega_m |omega_m|: against hand-written equations, a
closed-form coast-down, the energy balance, and the refusal of bad values (unit and scenario)."""

import math
import random

import pytest

from orchestration.scenario.validate import validate_scenario_file
from satmotor.errors import ParameterError
from satmotor.interface import PLANT_PARAMETERS, PlantUnit
from satmotor.machine.integrate import rk4
from satmotor.machine.params import MotorParams, RatedData
from satmotor.machine.plant import OMEGA_M, Plant

RATED = RatedData()
V, W = RATED.V_phase_peak, RATED.omega_e


def test_b2_is_a_plant_parameter_with_its_unit_and_default():
    var = {v.name: v for v in PLANT_PARAMETERS}["B_2"]
    assert (var.causality, var.type, var.start, var.unit) == ("parameter", "Real", 0.0, "N m s2/rad2")
    assert PlantUnit({}).plant.B_2 == 0.0 and PlantUnit({"B_2": 2.5e-3}).plant.B_2 == 2.5e-3
    assert not hasattr(MotorParams(), "B_2")  # not in the controller's model


def test_derivatives_with_b2_equal_the_hand_written_equations():
    """At random states, both speed signs: the mechanical derivative is
    (T_e - T_load - B w - B_2 w |w|) / J with T_e from the generic outputs, the rest unchanged."""
    rng = random.Random(11)
    p = MotorParams()
    for b2 in (0.0, 2.67e-3, 0.5):
        plant = Plant(p, b2)
        for _ in range(2000):
            x = tuple(rng.uniform(-1.5, 1.5) for _ in range(4)) + (rng.uniform(-300, 300), rng.uniform(-9, 9))
            v_a, v_b, T = rng.uniform(-400, 400), rng.uniform(-400, 400), rng.uniform(-50, 50)
            ima, imb, _, _, m = plant.magnetizing(*x[:4])
            isa, isb = (x[0] - m * ima) / p.l_s, (x[1] - m * imb) / p.l_s
            ira, irb = (x[2] - p.k * m * ima) / p.l_r, (x[3] - p.k * m * imb) / p.l_r
            te = plant.outputs(x).T_e
            w = x[4]
            want = (v_a - p.R_s * isa, v_b - p.R_s * isb, -p.R_r * ira - p.n_p * w * x[3],
                    -p.R_r * irb + p.n_p * w * x[2], (te - T - p.B * w - b2 * w * abs(w)) / p.J, w)
            assert plant.derivatives(0.0, x, v_a, v_b, T) == pytest.approx(want, rel=1e-12, abs=1e-12)


def test_b2_zero_gives_the_very_floats_of_the_plant_without_it():
    rng = random.Random(3)
    a, b = Plant(MotorParams()), Plant(MotorParams(), 0.0)
    for _ in range(2000):
        x = tuple(rng.uniform(-1.5, 1.5) for _ in range(4)) + (rng.uniform(-300, 300), 0.0)
        u = (rng.uniform(-400, 400), rng.uniform(-400, 400), rng.uniform(-50, 50))
        assert a.derivatives(0.0, x, *u) == b.derivatives(0.0, x, *u)
        assert a.step(0.0, x, *u, 1e-4, 2) == b.step(0.0, x, *u, 1e-4, 2)


@pytest.mark.parametrize("B", [0.0, 2.985e-3, 0.2])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_coast_down_matches_the_closed_form(B, sign):
    """Unmagnetized (T_e = 0), no load: J w' = -B w - B_2 w |w|, solved by hand:
    w(t) = B w0 e^(-Bt/J) / (B + B_2 |w0| (1 - e^(-Bt/J)))   (B -> 0: w0 / (1 + B_2 |w0| t / J))."""
    p = MotorParams(B=B)
    b2, w0, J, h, t_end = 2.67e-3, sign * 150.0, p.J, 1e-3, 2.0
    plant = Plant(p, b2)
    x = (0.0, 0.0, 0.0, 0.0, w0, 0.0)
    for j in range(round(t_end / h)):
        x = plant.step(j * h, x, 0.0, 0.0, 0.0, h)
    if B == 0.0:
        want = w0 / (1.0 + b2 * abs(w0) * t_end / J)
    else:
        e = math.exp(-B * t_end / J)
        want = B * w0 * e / (B + b2 * abs(w0) * (1.0 - e))
    assert abs(want) < 0.5 * abs(w0)  # the fan load did most of the braking
    assert x[OMEGA_M] == pytest.approx(want, rel=1e-8)


def test_energy_balance_closes_with_the_fan_load():
    """Input = copper + viscous + fan (int B_2 |w|^3 dt) + load work + kinetic + magnetic energy."""
    p, b2, h = MotorParams(), 2.67e-3, 2e-5
    plant = Plant(p, b2)

    def f(t, x, load):
        va, vb = V * math.cos(W * t), V * math.sin(W * t)
        o = plant.outputs(x[:6])
        w = x[OMEGA_M]
        p_in = 1.5 * (va * o.i_s_alpha + vb * o.i_s_beta)
        p_cu = 1.5 * (p.R_s * (o.i_s_alpha**2 + o.i_s_beta**2) + p.R_r * (o.i_r_alpha**2 + o.i_r_beta**2))
        return tuple(plant.derivatives(t, x[:6], va, vb, load)) + (p_in, p_cu, p.B * w * w,
                                                                    b2 * abs(w) ** 3, load * w)

    x = (0.0,) * 11
    for j in range(round(0.25 / h)):
        x = rk4(f, j * h, x, h, 1, (0.0,))
    for j in range(round(0.15 / h)):
        x = rk4(f, 0.25 + j * h, x, h, 1, (5.0,))
    e_in, e_cu, e_visc, e_fan, e_load = x[6:]
    e_kin = 0.5 * p.J * x[OMEGA_M] ** 2
    residual = e_in - (e_cu + e_visc + e_fan + e_load + e_kin + plant.magnetic_energy(x[:6]))
    assert e_fan > 100.0 and e_load > 1.0  # the fan load takes part
    assert abs(residual) / e_in < 1e-6


@pytest.mark.parametrize("bad", [-1.0e-3, float("nan"), float("inf"), "fan", True])
def test_plant_unit_refuses_a_bad_b2_naming_it(bad):
    with pytest.raises(ParameterError) as err:
        PlantUnit({"B_2": bad})
    assert err.value.field == "B_2" and str(err.value).startswith(f"B_2 = {bad!r}")
    with pytest.raises(ParameterError, match="B_2"):
        Plant(MotorParams(), bad)


@pytest.mark.parametrize("text, value, reason", [("-2.0e-3", -2.0e-3, ">= 0"), (".nan", None, "finite"),
                                                 ("'2e-3'", "2e-3", "must be a number")])
def test_validate_refuses_a_bad_b2_naming_file_field_and_value(tmp_path, text, value, reason):
    f = tmp_path / "fan.yaml"
    f.write_text(f"name: fan\nstop_time: 0.1\nplant: {{B_2: {text}}}\n"
                 "profiles: {psi_ref: {type: constant, value: 0.9}}\n")
    problems = validate_scenario_file(f)
    assert [p.field for p in problems] == ["plant.B_2"], problems
    p = problems[0]
    assert p.file == str(f) and reason in p.message
    assert (math.isnan(p.value) if value is None else p.value == value)


def test_the_fan_load_scenario_settles_on_the_mechanical_balance():
    """scenarios/fan_load.yaml through the plain-Python twin: at steady state (1.3-1.5 s) the motor
    torque equals B w + B_2 w^2 computed from the speed, and the controller's load estimate, which
    knows B but not B_2, equals the fan torque B_2 w^2."""
    from pathlib import Path

    from orchestration.run.reference import plain_reference
    from orchestration.scenario.load import load_scenario

    sc = load_scenario(Path(__file__).resolve().parents[1] / "scenarios" / "fan_load.yaml")
    b2, B = sc.plant["B_2"], MotorParams().B
    df = plain_reference(sc)
    s = df[df["time"] >= 1.3]
    w = s["plant.omega_m"].to_numpy()
    assert w.min() > 99.0
    assert s["plant.T_e"].mean() == pytest.approx(B * w.mean() + b2 * w.mean() ** 2, rel=1e-3)
    assert s["controller.T_load_est"].mean() == pytest.approx(b2 * w.mean() ** 2, rel=2e-3)
    assert b2 * 100.0**2 == pytest.approx(RATED.T_n, rel=0.01)  # the fan takes the rated torque at 100 rad/s
