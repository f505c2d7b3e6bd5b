"""The sweep: section (orchestration.scenario.sweep) alone: grids, ranges, seeded Monte Carlo draws,
and the refusals; then the loader checking every variant (load_sweep, check_scenario_file, validate)."""

import math
import subprocess
import sys

import numpy as np
import pytest
import yaml

from orchestration.scenario.load import ScenarioError, load_scenario
from orchestration.scenario.sweep import expand
from orchestration.scenario.validate import check_scenario_file
from orchestration.scenario.variants import load_sweep, load_variant

BASE = {"name": "s", "stop_time": 0.2, "motor": {"J": 0.02}, "controller": {"d1": 100.0},
        "profiles": {"psi_ref": {"type": "constant", "value": 0.9},
                     "T_load": [{"type": "step", "time": 0.1, "value": 5.0},
                                {"type": "constant", "value": 1.0}]}}


def _expand(sweep, base=BASE):
    return expand({**base, "sweep": sweep}, "f.yaml")


def _field(problems):
    return [p.field for p in problems]


def test_a_grid_of_2_by_3_gives_6_variants_with_every_combination():
    sw, problems = _expand({"parameters": {"motor.J": [0.01, 0.03], "controller.d1": [50.0, 100.0, 150.0]}})
    assert problems == []
    assert sw.kind == "grid" and sw.parameters == ("motor.J", "controller.d1")
    expected = [(0.01, 50.0), (0.01, 100.0), (0.01, 150.0), (0.03, 50.0), (0.03, 100.0), (0.03, 150.0)]
    assert [tuple(x for _, x in v.values) for v in sw.variants] == expected
    for v, (j, d1) in zip(sw.variants, expected):
        assert v.data["motor"]["J"] == j and v.data["controller"]["d1"] == d1
        assert v.data["name"] == f"s-{v.index}" and "sweep" not in v.data
        assert v.data["record"] == {"level": "metrics"}  # a sweep's default
        assert v.data["profiles"] == BASE["profiles"] and v.data["stop_time"] == 0.2
    assert BASE["motor"] == {"J": 0.02}  # the base mapping is not touched


def test_ranges_by_count_and_by_step_include_both_ends():
    sw, _ = _expand({"parameters": {"controller.d1": {"start": 10.0, "stop": 20.0, "num": 5}}})
    assert [v.values[0][1] for v in sw.variants] == [10.0, 12.5, 15.0, 17.5, 20.0]
    sw, _ = _expand({"parameters": {"profiles.T_load[0].value": {"start": 0.0, "stop": 0.3, "step": 0.1}}})
    assert [v.values[0][1] for v in sw.variants] == [0.0, 0.1, 0.2, 0.3]  # 0.1 * 3 reads 0.3
    assert [v.data["profiles"]["T_load"][0]["value"] for v in sw.variants] == [0.0, 0.1, 0.2, 0.3]
    sw, _ = _expand({"parameters": {"motor.n_p": {"start": 1, "stop": 3, "step": 1}}})
    assert [v.values[0][1] for v in sw.variants] == [1, 2, 3] and all(
        type(v.values[0][1]) is int for v in sw.variants)
    sw, _ = _expand({"parameters": {"controller.d1": {"start": 30.0, "stop": 10.0, "step": -10.0}}})
    assert [v.values[0][1] for v in sw.variants] == [30.0, 20.0, 10.0]


def test_names_are_padded_to_the_width_of_the_count():
    sw, _ = _expand({"parameters": {"controller.d1": {"start": 1.0, "stop": 12.0, "num": 12}}})
    assert [v.name for v in sw.variants][:2] == ["s-00", "s-01"] and sw.variants[-1].name == "s-11"


def test_a_record_section_keeps_its_fields_and_its_level():
    sw, _ = _expand({"parameters": {"motor.J": [0.01]}}, {**BASE, "record": {"interval": 2e-4}})
    assert sw.variants[0].data["record"] == {"interval": 2e-4, "level": "metrics"}
    sw, _ = _expand({"parameters": {"motor.J": [0.01]}}, {**BASE, "record": {"level": "full"}})
    assert sw.variants[0].data["record"] == {"level": "full"}


def _draws(seed, n=5):
    sw, problems = _expand({"samples": n, "seed": seed, "parameters": {
        "motor.J": {"uniform": [0.01, 0.03]}, "controller.d1": {"normal": [100.0, 5.0]}}})
    assert problems == []
    return [tuple(x for _, x in v.values) for v in sw.variants]


def test_monte_carlo_draws_repeat_with_the_seed_and_change_with_another():
    a, b, c = _draws(7), _draws(7), _draws(8)
    assert a == b and len(a) == 5
    assert a != c and len(set(a)) == 5


def test_monte_carlo_distributions_have_their_stated_mean_and_spread():
    n = 4000
    sw, _ = _expand({"samples": n, "seed": 1, "parameters": {
        "motor.J": {"uniform": [0.01, 0.03]}, "controller.d1": {"normal": [100.0, 5.0]},
        "motor.R_r": {"tolerance": 0.1}}})
    x = np.array([[v for _, v in var.values] for var in sw.variants])
    uni, nor, tol = x[:, 0], x[:, 1], x[:, 2]
    # uniform on [a, b]: mean (a + b) / 2, standard deviation (b - a) / sqrt(12); bounds of 5 sigma
    sd_u = 0.02 / math.sqrt(12)
    assert abs(uni.mean() - 0.02) < 5 * sd_u / math.sqrt(n)
    assert abs(uni.std() - sd_u) < 5 * sd_u / math.sqrt(2 * n) * 1.2
    assert uni.min() >= 0.01 and uni.max() <= 0.03
    assert abs(nor.mean() - 100.0) < 5 * 5.0 / math.sqrt(n)
    assert abs(nor.std() - 5.0) < 5 * 5.0 / math.sqrt(2 * n)
    # a tolerance of 10 % around the FMU's default R_r (the file does not set it): 1.395 Ohm
    assert tol.min() >= 1.395 * 0.9 and tol.max() <= 1.395 * 1.1
    assert abs(tol.mean() - 1.395) < 5 * (0.2 * 1.395 / math.sqrt(12)) / math.sqrt(n)


def test_a_tolerance_is_around_the_value_the_file_writes():
    sw, _ = _expand({"samples": 200, "seed": 3, "parameters": {"motor.J": {"tolerance": 0.05},
                                                                "plant.J": {"tolerance": 0.01}}})
    j = [v.values[0][1] for v in sw.variants]
    jp = [v.values[1][1] for v in sw.variants]
    assert min(j) >= 0.02 * 0.95 and max(j) <= 0.02 * 1.05 and max(j) > 0.02 * 1.04
    assert min(jp) >= 0.02 * 0.99 and max(jp) <= 0.02 * 1.01  # plant.J: the motor: value, own none


@pytest.mark.parametrize("sweep,field,words", [
    ({"parameters": {"motor.R_ss": [1.0]}}, "sweep.parameters.motor.R_ss", "not a motor parameter"),
    ({"parameters": {"rotor.J": [1.0]}}, "sweep.parameters.rotor.J", "a parameter path is"),
    ({"parameters": {"controller.Ts": [1e-4]}}, "sweep.parameters.controller.Ts", "step * controller_every"),
    ({"parameters": {"profiles.omega_ref.value": [1.0]}}, "sweep.parameters.profiles.omega_ref.value",
     "defines no profile omega_ref"),
    ({"parameters": {"profiles.T_load.value": [1.0]}}, "sweep.parameters.profiles.T_load.value",
     "summed profile"),
    ({"parameters": {"motor.J": {"uniform": [0.01, 0.02]}}}, "sweep.parameters.motor.J",
     "needs sweep.samples"),
    ({"parameters": {"motor.J": []}}, "sweep.parameters.motor.J", "varies nothing"),
    ({"parameters": {"motor.J": {"start": 1.0, "stop": 2.0}}}, "sweep.parameters.motor.J", "exactly one of"),
    ({"parameters": {"motor.J": {"start": 1.0, "stop": 2.0, "step": -1.0}}}, "sweep.parameters.motor.J.step",
     "lead from start"),
    ({"samples": 3, "seed": 1, "parameters": {"motor.J": [0.01]}}, "sweep.parameters.motor.J",
     "a Monte Carlo parameter is one of"),
    ({"samples": 3, "parameters": {"motor.J": {"tolerance": 0.1}}}, "sweep.seed", "needs a seed"),
    ({"samples": 3, "seed": 1, "parameters": {"motor.J": {"uniform": [0.03, 0.01]}}},
     "sweep.parameters.motor.J.uniform", "low must be <= high"),
    ({"samples": 3, "seed": 1, "parameters": {"motor.curve": {"tolerance": 0.1}}},
     "sweep.parameters.motor.curve.tolerance", "numeric nominal"),
    ({"seed": 1, "parameters": {"motor.J": [0.01]}}, "sweep.seed", "needs sweep.samples"),
    ({"parameters": {"motor.J": [0.01]}, "grid": True}, "sweep.grid", "unknown key"),
    ({"parameters": {"controller.d1": {"start": 0.0, "stop": 1.0, "num": 200},
                     "controller.d2": {"start": 0.0, "stop": 1.0, "num": 200}}}, "sweep.parameters",
     "at most"),
])
def test_bad_sweeps_are_refused_naming_the_field(sweep, field, words):
    sw, problems = _expand(sweep)
    assert sw is None
    assert field in _field(problems), problems
    p = next(p for p in problems if p.field == field)
    assert words in p.message and p.file == "f.yaml"


def test_a_bad_path_is_named_with_its_value():
    _, problems = _expand({"parameters": {"motor.R_ss": [1.0], "motor.J": [0.01]}})
    assert len(problems) == 1 and "R_ss" in str(problems[0]) and "motor.R_ss" in str(problems[0])


# ----- the loader: every variant checked ------------------------------------------------------


def _file(tmp_path, sweep, base=None):
    data = {**(base or {"name": "sw", "stop_time": 0.2, "profiles": {"psi_ref": {"type": "constant",
                                                                                   "value": 0.9}}}),
            "sweep": sweep}
    f = tmp_path / "sw.yaml"
    f.write_text(yaml.safe_dump(data))
    return f


def test_load_sweep_checks_every_variant_and_names_the_bad_one(tmp_path):
    f = _file(tmp_path, {"parameters": {"motor.J": [0.01, -1.0, 0.02]}})
    with pytest.raises(ScenarioError) as exc:
        load_sweep(f)
    (p,) = exc.value.problems
    assert p.file == str(f) and p.field == "motor.J" and p.value == -1.0
    assert "variant sw-1" in p.message and "motor.J = -1.0" in p.message
    problems, notes = check_scenario_file(f)
    assert problems == [p] and notes == []
    r = subprocess.run([sys.executable, "-m", "orchestration", "validate", str(f)], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 2 and "variant sw-1" in r.stderr and "motor.J = -1.0" in r.stderr


def test_load_sweep_gives_the_base_and_each_variant_as_a_scenario(tmp_path):
    f = _file(tmp_path, {"parameters": {"motor.J": [0.01, 0.02], "plant.B_2": [0.0, 1e-3]}})
    base, sweep, variants = load_sweep(f)
    assert base.name == "sw" and base.record.level == "full" and len(variants) == 4
    assert [sc.plant["J"] for _, sc in variants] == [0.01, 0.01, 0.02, 0.02]
    assert [sc.controller["J"] for _, sc in variants] == [0.01, 0.01, 0.02, 0.02]  # motor: both units
    assert [sc.plant["B_2"] for _, sc in variants] == [0.0, 1e-3, 0.0, 1e-3]
    assert all(sc.record.level == "metrics" for _, sc in variants)
    assert load_variant(f, 3) == variants[3][1]
    r = subprocess.run([sys.executable, "-m", "orchestration", "validate", str(f)], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0 and r.stdout.strip() == f"{f}: valid (4 variants, every one checked)"
    assert load_scenario(f) == base  # the file's own scenario: the sweep ignored
    with pytest.raises(ScenarioError, match="no variant 4: the file has 4"):
        load_variant(f, 4)


def test_the_library_sweeps_are_valid_and_small():
    from pathlib import Path

    root = Path(__file__).resolve().parents[1] / "scenarios"
    for name, kind, count in (("sweep_inertia", "grid", 6), ("montecarlo_rr", "montecarlo", 8)):
        base, sweep, variants = load_sweep(root / f"{name}.yaml")
        assert sweep.kind == kind and len(variants) == count and base.stop_time <= 1.0
        assert check_scenario_file(root / f"{name}.yaml") == ([], [])


def test_a_tolerance_on_a_preset_motor_is_around_the_preset_value():
    """The 2.2-kW preset's R_r is 2.5 Ohm (Qu et al. 2012, the table in satmotor/machine/library.py),
    not the default motor's: a 10 % tolerance draws within [2.25, 2.75]."""
    base = {**BASE, "motor": {"preset": "qu2012_2kw2"}}
    sw, problems = _expand({"samples": 100, "seed": 1, "parameters": {"motor.R_r": {"tolerance": 0.1}}}, base)
    assert problems == []
    r = [v.values[0][1] for v in sw.variants]
    assert 2.25 <= min(r) and max(r) <= 2.75 and max(r) - min(r) > 0.4
