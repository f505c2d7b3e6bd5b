"""Measurement noise and quantization between plant and controller: statistics against the requested
values, the documented draw stream reproduced by hand, quantization, seeds, block sizes, the master
against its plain-Python twin, and the refusals of a bad ``measurements:`` section."""

from __future__ import annotations

import dataclasses
import math
import pickle
from pathlib import Path

import numpy as np
import pytest

from orchestration.cli.commands import main as cli_main
from orchestration.run.measurement_noise import MeasurementNoise
from orchestration.run.reference import COLUMNS, plain_reference
from orchestration.scenario.load import load_scenario
from orchestration.scenario.system import MEASUREMENTS, Measurements
from orchestration.scenario.validate import validate_scenario_file
from satmotor.interface import CONTROLLER_OUTPUTS, ControllerUnit, PlantUnit
from satmotor.simulate import closed_loop

ROOT = Path(__file__).resolve().parents[1]
BASE = """name: noisy
stop_time: 0.5
step: 1.0e-4
profiles:
  psi_ref: {type: constant, value: 0.95}
  omega_ref: {type: ramp, start: 0.2, end: 0.45, to: 50.0}
  T_load: {type: step, time: 0.3, value: 10.0}
"""
NOISE = {"i_s_alpha": 0.05, "i_s_beta": 0.05, "psi_r_beta": 0.003, "omega_m": 0.1}
SECTION = """measurements:
  seed: {seed}
  noise: {{i_s_alpha: 0.05, i_s_beta: 0.05, psi_r_beta: 3.0e-3, omega_m: 0.1}}
  quantization: {{omega_m: 0.02}}
"""


def _scenario(tmp_path, text, name="noisy.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return load_scenario(path)


@pytest.fixture(scope="module")
def clean_and_noisy(tmp_path_factory):
    d = tmp_path_factory.mktemp("noise")
    sc = _scenario(d, BASE)
    return sc, plain_reference(sc), _scenario(d, BASE + SECTION.format(seed=1), "n.yaml")


def test_the_section_is_read_into_the_scenario(clean_and_noisy):
    _, _, sc = clean_and_noisy
    m = sc.measurements
    assert m.seed == 1 and dict(m.noise) == NOISE and dict(m.quantization) == {"omega_m": 0.02}
    assert m.signals == ("i_s_alpha", "i_s_beta", "psi_r_beta", "omega_m")
    assert m.columns == tuple("measured." + n for n in m.signals)
    assert pickle.loads(pickle.dumps(sc)) == sc  # batch and Dask send scenarios to other processes


def test_measured_minus_clean_has_the_requested_std_and_zero_mean_at_the_unit():
    """200 000 samples of constant clean values: sample std within 5 of its standard errors
    (sigma / sqrt(2 n)) of the requested one, mean within 5 sigma / sqrt(n) of 0, no correlation."""
    names = PlantUnit.OUTPUTS
    clean = [float(i) + 0.25 for i in range(len(names))]
    noise = MeasurementNoise(Measurements(7, tuple(NOISE.items())), names, block=1000)
    n = 200_000
    got = np.array([noise(clean)[1] for _ in range(n)]) - [clean[names.index(s)] for s in noise.signals]
    for j, s in enumerate(noise.signals):
        sigma = NOISE[s]
        assert abs(got[:, j].std() - sigma) < 5 * sigma / math.sqrt(2 * n), s
        assert abs(got[:, j].mean()) < 5 * sigma / math.sqrt(n), s
    c = np.corrcoef(got.T)
    assert np.max(np.abs(c - np.eye(len(NOISE)))) < 5 / math.sqrt(n)


def test_the_run_records_clean_and_measured_signals_with_the_requested_noise(clean_and_noisy):
    _, _, sc = clean_and_noisy
    df = plain_reference(sc)
    n = len(df)
    for s in ("i_s_alpha", "i_s_beta", "psi_r_beta"):  # unquantized: measured - clean = sigma z
        d = df[f"measured.{s}"].to_numpy() - df[f"plant.{s}"].to_numpy()
        assert abs(d.std() - NOISE[s]) < 5 * NOISE[s] / math.sqrt(2 * n), s
        assert abs(d.mean()) < 5 * NOISE[s] / math.sqrt(n), s
    assert "measured.psi_r_alpha" not in df and "measured.psi_s_alpha" not in df  # clean ones: no column


def test_the_draws_are_the_documented_stream_and_quantization_rounds_to_the_nearest_step(clean_and_noisy):
    """Reproduce the measured values from numpy by hand: one row of standard normals per controller
    sample, one column per signal with noise in the order of MEASUREMENTS, scaled by its std."""
    _, _, sc = clean_and_noisy
    df = plain_reference(sc)
    noisy = [s for s in MEASUREMENTS if s in NOISE]
    z = np.random.default_rng(1).standard_normal((len(df), len(noisy))) * [NOISE[s] for s in noisy]
    for j, s in enumerate(noisy):
        want = df[f"plant.{s}"].to_numpy() + z[:, j]
        got = df[f"measured.{s}"].to_numpy()
        if s != "omega_m":
            assert np.array_equal(got, want), s
            continue
        q = 0.02
        k = np.rint(got / q)
        assert np.array_equal(got, k * q)  # an exact multiple of the step
        assert np.all(np.abs(got - want) <= q / 2 * (1 + 1e-9))  # the nearest one to clean + noise
        assert len(np.unique(k)) > 100 and np.any(np.abs(got - want) > 0.4 * q)  # it does round


def test_same_seed_same_run_other_seed_other_run(tmp_path, clean_and_noisy):
    _, clean, sc = clean_and_noisy
    a, b = plain_reference(sc), plain_reference(_scenario(tmp_path, BASE + SECTION.format(seed=1)))
    c = plain_reference(_scenario(tmp_path, BASE + SECTION.format(seed=2), "other.yaml"))
    assert a.equals(b)
    assert not np.array_equal(a["measured.omega_m"], c["measured.omega_m"])
    assert not np.array_equal(a["controller.v_s_alpha"], c["controller.v_s_alpha"])
    # the controller acts on the measured values; the plant starts from the same clean state
    assert not np.array_equal(a["controller.v_s_alpha"], clean["controller.v_s_alpha"])
    assert a["plant.i_s_alpha"].iloc[0] == clean["plant.i_s_alpha"].iloc[0]


@pytest.mark.parametrize("block", [1, 3, 1000])
def test_the_stream_does_not_depend_on_the_block_size(block):
    spec = Measurements(5, tuple(NOISE.items()), (("omega_m", 0.02), ("psi_s_alpha", 1e-3)))
    names = PlantUnit.OUTPUTS
    values = [0.1 * i for i in range(len(names))]
    ref, test = MeasurementNoise(spec, names, block=4096), MeasurementNoise(spec, names, block=block)
    for _ in range(5000):
        assert test(values) == ref(values)


def test_quantization_alone_draws_nothing_and_keeps_the_other_values():
    names = PlantUnit.OUTPUTS
    q = MeasurementNoise(Measurements(0, (("omega_m", 0.0),), (("omega_m", 0.5),)), names)
    assert q.columns == ("measured.omega_m",)
    values = [1.0] * len(names)
    i = names.index("omega_m")
    for w, want in ((0.74, 0.5), (0.75, 1.0), (-0.24, 0.0), (-0.26, -0.5), (10.0, 10.0)):
        values[i] = w
        measured, row = q(values)
        assert row == [want] and measured[i] == want
        assert measured[:i] + measured[i + 1:] == values[:i] + values[i + 1:]


def test_without_measurements_the_twin_is_satmotors_closed_loop_bit_for_bit(clean_and_noisy):
    sc, clean, _ = clean_and_noisy
    plant, ctrl = PlantUnit(dict(sc.plant)), ControllerUnit({**sc.controller, "Ts": sc.Ts})
    p = sc.profiles
    rec = closed_loop(plant.params, ctrl.drive, sc.stop_time, p["omega_ref"].value, p["psi_ref"].value,
                      p["T_load"].value, x0=plant.x0)
    profiles = ["profile.T_load", "profile.omega_ref", "profile.psi_ref"]
    assert list(clean.columns) == ["time", *COLUMNS, *profiles]
    assert np.array_equal(clean["time"], rec["t"])
    for col, key in zip(profiles, ("T_load", "omega_ref", "psi_ref")):
        assert np.array_equal(clean[col], rec[key]), col
    for col, key in COLUMNS.items():
        assert np.array_equal(clean[col], rec[key]), col


@pytest.mark.parametrize("section", ["measurements: {seed: 4}\n", "measurements:\n",
                                     "measurements: {noise: {omega_m: 0.0}}\n"])
def test_a_section_that_changes_nothing_changes_nothing(tmp_path, clean_and_noisy, section):
    _, clean, _ = clean_and_noisy
    sc = _scenario(tmp_path, BASE + section)
    assert not (sc.measurements and sc.measurements.signals)
    assert plain_reference(sc).equals(clean)


BAD = [
    ("unknown signal", "measurements: {noise: {omega_e: 0.1}}\n", "measurements.noise.omega_e", "0.1"),
    ("not measured", "measurements: {quantization: {T_e: 0.1}}\n", "measurements.quantization.T_e", "0.1"),
    ("negative std", "measurements: {noise: {i_s_alpha: -0.05}}\n", "measurements.noise.i_s_alpha", "-0.05"),
    ("nan std", "measurements: {noise: {omega_m: .nan}}\n", "measurements.noise.omega_m", "nan"),
    ("infinite step", "measurements: {quantization: {omega_m: .inf}}\n", "measurements.quantization.omega_m",
     "inf"),
    ("zero step", "measurements: {quantization: {omega_m: 0.0}}\n", "measurements.quantization.omega_m",
     "0.0"),
    ("string std", "measurements: {noise: {omega_m: 1e-3}}\n", "measurements.noise.omega_m", "'1e-3'"),
    ("float seed", "measurements: {seed: 1.5}\n", "measurements.seed", "1.5"),
    ("bool seed", "measurements: {seed: true}\n", "measurements.seed", "True"),
    ("negative seed", "measurements: {seed: -3}\n", "measurements.seed", "-3"),
    ("unknown key", "measurements: {offset: {omega_m: 1.0}}\n", "measurements.offset", "{'omega_m': 1.0}"),
    ("noise not a mapping", "measurements: {noise: [0.1]}\n", "measurements.noise", "[0.1]"),
    ("section not a mapping", "measurements: 0.1\n", "measurements", "0.1"),
]


@pytest.mark.parametrize("text, field, shown", [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_a_bad_section_is_refused_naming_file_field_and_value(tmp_path, capsys, text, field, shown):
    path = tmp_path / "bad.yaml"
    path.write_text(BASE + text)
    problems = validate_scenario_file(path)
    assert [p.field for p in problems] == [field], problems
    assert cli_main(["validate", str(path), "--fmus", str(tmp_path / "no_fmus")]) == 2
    err = capsys.readouterr().err
    assert f"{path}: {field} = {shown}: " in err, err


def test_every_problem_of_a_section_at_once(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text(BASE + "measurements:\n  seed: 0.5\n  noise: {omega_m: -1.0, speed: 0.1}\n"
                    "  quantization: {omega_m: -0.01}\n")
    assert [p.field for p in validate_scenario_file(path)] == [
        "measurements.seed", "measurements.noise.omega_m", "measurements.noise.speed",
        "measurements.quantization.omega_m"]


# --- the co-simulation master against its plain-Python twin (FMUs) ---------------------------------


def _cosim(sc, fmu_dir, **kw):
    from orchestration.packaging import fmus
    from orchestration.run.master import run

    plant, ctrl = fmus.paths(fmu_dir)
    res = run(sc, str(plant), str(ctrl), **kw)
    assert res.ok, res.message
    return res


@pytest.mark.slow
@pytest.mark.parametrize("every, algorithm", [(1, "gauss-seidel"), (2, "jacobi")])
def test_the_master_applies_the_same_noise_as_its_plain_python_twin(tmp_path, fmu_dir, every, algorithm):
    text = BASE.replace("stop_time: 0.5", "stop_time: 0.3") + f"controller_every: {every}\n"
    text += f"algorithm: {algorithm}\n" + SECTION.format(seed=3)
    sc = _scenario(tmp_path, text)
    co, ref = _cosim(sc, fmu_dir).frame, plain_reference(sc)
    measured = list(sc.measurements.columns)
    assert list(co.columns[-len(measured):]) == measured  # after the profiles
    co_s = co.iloc[::every].reset_index(drop=True)  # one row per controller sample, as the twin
    assert len(co_s) == len(ref) and np.array_equal(co_s["time"], ref["time"])
    for c in [*COLUMNS, *measured]:
        assert np.array_equal(co_s[c], ref[c]), c
    if every > 1:  # between samples the column holds what the controller last received
        held = co["measured.omega_m"].to_numpy()[1::every]  # rows between samples (none after the last)
        assert np.array_equal(held, ref["measured.omega_m"].to_numpy()[:len(held)])


@pytest.mark.slow
def test_without_a_section_the_master_records_the_same_columns_and_numbers(tmp_path, fmu_dir):
    from orchestration.results.writer import write_results
    from orchestration.scenario.recording import recorded_columns

    sc = _scenario(tmp_path, BASE.replace("stop_time: 0.5", "stop_time: 0.2"))
    none = _cosim(sc, fmu_dir).frame
    idle = _cosim(dataclasses.replace(sc, measurements=Measurements(9, (("omega_m", 0.0),))), fmu_dir).frame
    # the master reads the controller's Reals, then its Integers and Booleans (each in table order)
    ctrl = [v.name for v in CONTROLLER_OUTPUTS if v.type == "Real"] + \
        [v.name for v in CONTROLLER_OUTPUTS if v.type != "Real"]
    assert sorted(ctrl) == sorted(ControllerUnit.OUTPUTS)
    assert list(none.columns) == recorded_columns(PlantUnit.OUTPUTS, ctrl, sorted(sc.profiles))
    assert none.equals(idle)
    ref = plain_reference(sc)
    for c in ["time", *COLUMNS]:
        assert np.array_equal(none[c], ref[c]), c
    # measured columns are kept when record.outputs lists only a few outputs
    noisy = dataclasses.replace(sc, measurements=Measurements(1, tuple(NOISE.items())),
                                record=dataclasses.replace(sc.record, outputs=("plant.theta_m",)))
    write_results(_cosim(noisy, fmu_dir), tmp_path / "out", plot=False)
    header = (tmp_path / "out" / sc.name / "timeseries.csv").read_text().splitlines()[0].split(",")
    assert header[-4:] == ["measured." + s for s in MEASUREMENTS if s in NOISE]
    assert "plant.theta_m" in header and "plant.psi_s_alpha" not in header
