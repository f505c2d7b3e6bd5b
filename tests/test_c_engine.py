"""The compiled stepping engine (``run --engine c``) against the fmpy master: the same rows to the last
bit, the same metrics, the same failures, for the library's scenarios, both algorithms, FMI 2.0 and
3.0; what it does not run is refused naming the feature."""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from orchestration.cli.commands import run_file
from orchestration.packaging import fmus
from orchestration.results.recorder import Recorder
from orchestration.run import c_engine
from orchestration.run.c_engine.stepper import Unsupported, profile_table
from orchestration.run.master import run as master_run
from orchestration.scenario.load import load_scenario
from orchestration.scenario.profiles import Constant, Ramp, Sine, Step, Sum, Table
from orchestration.scenario.system import DEFAULT_CONNECTIONS, Connection

ROOT = Path(__file__).resolve().parents[1]
LIBRARY = sorted((ROOT / "scenarios").glob("*.yaml"))
ALGORITHMS = ("gauss-seidel", "jacobi")
# a representative few for make test: Gauss-Seidel and FMI 2.0 / Jacobi and FMI 3.0, multi-rate
# (controller_every 4), measurement noise and quantization, a CSV table profile, a sine, delay_samples
FAST = [("rated_point", "gauss-seidel", "native"), ("noisy_measurements", "jacobi", "native-fmi3"),
        ("deep_saturation", "gauss-seidel", "native-fmi3"), ("load_cycle_csv", "jacobi", "native"),
        ("sinusoidal_load", "gauss-seidel", "native"), ("delay_compensated", "jacobi", "native-fmi3")]


def assert_same(ref, got):
    """The same status, message, failing unit, last time and every recorded value, bit for bit, handed to
    the recorder's observer (the metrics as the run goes) in the same chunks."""
    assert (got.status, got.message, got.failed_unit, got.t_end) == (ref.status, ref.message, ref.failed_unit,
                                                                      ref.t_end)
    assert got.recorder.seen == ref.recorder.seen
    a, b = ref.recorder.arrays(), got.recorder.arrays()
    assert list(a) == list(b)
    assert len(a["time"]) > 0
    for c in a:
        assert a[c].tobytes() == b[c].tobytes(), c


def chunks(columns):
    """An in-memory recorder whose observer keeps each chunk's shape and bytes (small chunks: many
    boundaries, some inside a block of noise draws)."""
    seen = []
    rec = Recorder(columns, chunk_rows=700, observer=lambda a: seen.append((a.shape, a.tobytes())))
    rec.seen = seen
    return rec


def both(sc, variant, fmu_dir, **kw):
    plant, ctrl = map(str, fmus.paths(fmu_dir, variant))
    kw.setdefault("recorder", chunks)
    return master_run(sc, plant, ctrl, **kw), c_engine.run(sc, plant, ctrl, **kw)


@pytest.mark.parametrize("name,algorithm,variant", FAST)
def test_a_representative_scenario_gives_the_masters_rows_bit_for_bit(fmu_dir, name, algorithm, variant):
    ref, got = both(load_scenario(ROOT / "scenarios" / f"{name}.yaml"), variant, fmu_dir, algorithm=algorithm)
    assert ref.ok
    assert_same(ref, got)


@pytest.mark.slow
@pytest.mark.parametrize("variant", c_engine.VARIANTS)
@pytest.mark.parametrize("algorithm", ALGORITHMS)
@pytest.mark.parametrize("path", LIBRARY, ids=[p.stem for p in LIBRARY])
def test_every_library_scenario_gives_the_masters_rows_bit_for_bit(fmu_dir, path, algorithm, variant):
    ref, got = both(load_scenario(path), variant, fmu_dir, algorithm=algorithm)
    assert_same(ref, got)


def test_every_profile_kind_and_their_sum_are_the_pythons_values(tmp_path, fmu_dir):
    # the profiles the engine evaluates in C, all at once in one Sum feeding the load, and a table with
    # its points between the grid times: the recorded profile column is each profile's value(t)
    f = tmp_path / "kinds.yaml"
    f.write_text("name: kinds\nstop_time: 0.3\nprofiles:\n  psi_ref: {type: constant, value: 0.9}\n"
                 "  omega_ref: {type: ramp, start: 0.05, end: 0.25, from: 0.0, to: 30.0}\n")
    sc = load_scenario(f)
    load = Sum((Constant(1.0), Step(0.1, 2.5, -0.5), Ramp(0.02, 0.2, -3.0, 1.0),
                Table((0.0, 0.01234, 0.1777, 0.29), (0.0, 4.0, -2.0, 1.0)), Sine(1.5, 37.0, 0.3, 0.2, 0.05)))
    sc = dataclasses.replace(sc, profiles={**sc.profiles, "T_load": load})
    ref, got = both(sc, "native", fmu_dir)
    assert ref.ok
    assert_same(ref, got)
    t = got.recorder.arrays()["time"]
    assert got.recorder.arrays()["profile.T_load"].tolist() == [load.value(x) for x in t.tolist()]


def test_a_controller_failure_is_the_masters_with_the_rows_before_it(tmp_path, fmu_dir):
    # the controller refuses an unreachable flux set-point at 0.2 s (tests/test_cosim.py)
    f = tmp_path / "reachable.yaml"
    f.write_text("name: reachable\nstop_time: 0.3\nprofiles:\n  psi_ref: {type: constant, value: 0.9}\n"
                 "  omega_ref: {type: constant, value: 20.0}\n")
    sc = load_scenario(f)
    sc = dataclasses.replace(sc, profiles={**sc.profiles, "psi_ref": Sum((Constant(0.9), Step(0.2, 1.5)))})
    for variant in c_engine.VARIANTS:
        ref, got = both(sc, variant, fmu_dir)
        assert got.status == "discard" and got.failed_unit == "controller"
        assert "BacksteppingController at t = 0.2" in got.message and "psi_ref = 2.4" in got.message
        assert_same(ref, got)


def test_a_plant_step_failure_is_the_masters_with_the_rows_before_it(fmu_dir):
    # an inertia so small that RK4 at 100 us is unstable once the speed step comes (tests/test_libcosim.py)
    sc = dataclasses.replace(load_scenario(ROOT / "scenarios" / "rated_point.yaml"), stop_time=0.3,
                             plant={"J": 1.0e-7}, controller={"field_weakening": False})
    ref, got = both(sc, "native", fmu_dir, algorithm="jacobi")
    assert got.status == "discard" and got.failed_unit == "plant"
    assert_same(ref, got)


def test_a_bad_parameter_is_the_masters_setup_failure(fmu_dir):
    sc = dataclasses.replace(load_scenario(LIBRARY[0]), stop_time=0.05, plant={"J": 0.0})
    ref, got = both(sc, "native-fmi3", fmu_dir)
    assert not got.ok and got.failed_unit == "plant" and "J = 0.0: must be a finite number > 0" in got.message
    assert (got.status, got.message) == (ref.status, ref.message)


class _Stop:
    signum = 0


def test_a_stop_request_ends_the_run_interrupted_with_the_rows_so_far(fmu_dir):
    sc = load_scenario(ROOT / "scenarios" / "rated_point.yaml")
    stop = _Stop()

    def recorder(columns):
        def observe(chunk):
            stop.signum = 2  # after the first chunk

        return Recorder(columns, chunk_rows=500, observer=observe)

    got = c_engine.run(sc, *map(str, fmus.paths(fmu_dir, "native")), stop=stop, recorder=recorder)
    assert got.status == "interrupted" and "SIGINT" in got.message
    assert len(got.recorder.arrays()["time"]) == 500 and got.t_end == pytest.approx(500 * sc.step)


def test_the_pythonfmu_fmus_are_refused_naming_them(tmp_path, fmu_dir):
    sc = dataclasses.replace(load_scenario(ROOT / "scenarios" / "rated_point.yaml"), stop_time=0.01)
    got = c_engine.run(sc, *map(str, fmus.paths(fmu_dir, "python")))
    assert got.status == "setup" and "pythonfmu FMU" in got.message and "--engine fmpy" in got.message
    assert c_engine.problems("python") and not c_engine.problems("native-fmi3")
    code, summary = run_file(ROOT / "scenarios" / "rated_point.yaml", tmp_path, fmu_dir, build=False,
                             plot=False, variant="python", engine="c")
    assert code == 2 and "the c engine runs the native FMUs" in summary["message"]


class _Custom:
    def value(self, t):
        return 1.0


def test_a_profile_it_cannot_evaluate_is_refused_naming_it(fmu_dir):
    with pytest.raises(Unsupported, match="profile bad: _Custom"):
        profile_table([_Custom().value], ["bad"])
    sc = dataclasses.replace(load_scenario(LIBRARY[0]), stop_time=0.01)
    sc = dataclasses.replace(sc, profiles={**sc.profiles, "bad": _Custom()})
    conns = tuple(c for c in DEFAULT_CONNECTIONS if c.target != "plant.T_load")
    conns += (Connection("profile.bad", "plant.T_load"),)
    got = c_engine.run(sc, *map(str, fmus.paths(fmu_dir, "native")), connections=conns)
    assert got.status == "setup" and "profile bad" in got.message


def test_the_cli_writes_the_masters_metrics_at_level_metrics(tmp_path, fmu_dir):
    text = (ROOT / "scenarios" / "noisy_measurements.yaml").read_text()
    f = tmp_path / "noisy_metrics.yaml"
    f.write_text(text.replace("name: noisy_measurements", "name: noisy_metrics") + "\nrecord: metrics\n")
    out = {}
    for engine in ("fmpy", "c"):
        code, summary = run_file(f, tmp_path / engine, fmu_dir, build=False, plot=False, variant="native",
                                 engine=engine)
        assert code == 0, summary
        m = json.loads((tmp_path / engine / "noisy_metrics" / "metrics.json").read_text())
        m.pop("wall_time", None)
        out[engine] = m
    assert out["c"] == out["fmpy"]
    assert not (tmp_path / "c" / "noisy_metrics" / "timeseries.csv").exists()


def test_the_noise_blocks_the_engine_reads_are_the_draws_the_master_adds():
    from orchestration.run.measurement_noise import MeasurementNoise
    from orchestration.scenario.system import MEASUREMENTS, Measurements

    names = list(MEASUREMENTS[:2])
    spec = Measurements(seed=7, noise=((names[0], 0.5), (names[1], 0.1)))
    master = MeasurementNoise(spec, names, block=3)  # the master's path: a block of 3 rows at a time
    rows = [master([1.0, 2.0])[1] for _ in range(5)]
    engine = MeasurementNoise(spec, names, block=5)
    assert engine.n_noisy == 2 and engine.ops == ((0, 0, 0.0), (1, 1, 0.0))
    z = engine.draw()
    ref = np.random.default_rng(7).standard_normal((5, 2)) * np.array([0.5, 0.1])
    assert z.tobytes() == ref.tobytes()
    assert rows == [[1.0 + ref[k, 0], 2.0 + ref[k, 1]] for k in range(5)]


@pytest.mark.parametrize("variant,algorithm", [("native", "gauss-seidel"), ("native-fmi3", "jacobi")])
def test_variants_on_instances_reset_between_them_are_the_fresh_runs(fmu_dir, variant, algorithm):
    # a worker's pool: the FMUs instantiated once, fmi2Reset / fmi3Reset and new parameters per variant
    from fmpy import read_model_description

    from orchestration.run.fmu_instance import UnitPool, extract_owned, remove_extracted
    from orchestration.scenario.variants import load_variant

    plant, ctrl = map(str, fmus.paths(fmu_dir, variant))
    dirs = [extract_owned(p) for p in (plant, ctrl)]
    mds = [read_model_description(p) for p in (plant, ctrl)]
    pool = UnitPool()
    try:
        first = None
        for i in range(3):
            sc = load_variant(ROOT / "scenarios" / "montecarlo_rr.yaml", i, None)
            fresh = master_run(sc, plant, ctrl, algorithm=algorithm, recorder=chunks)
            got = c_engine.run(sc, plant, ctrl, algorithm=algorithm, unzip_dirs=dirs, descriptions=mds,
                               pool=pool, recorder=chunks)
            assert fresh.ok
            assert_same(fresh, got)
            units = tuple(pool._units[n] for n in ("plant", "controller"))
            first = first or units
            assert units == first  # the same instances, reset
    finally:
        pool.close()
        for d in dirs:
            remove_extracted(d)


def test_the_engine_builds_with_zig_too(tmp_path, monkeypatch):
    # the project's zig when the host has no C compiler: C99, warnings as errors, as the FMUs are built
    from orchestration.packaging.native.compiler import zig_available
    from orchestration.run.c_engine import build

    if not zig_available():
        pytest.skip("zig is not installed")
    monkeypatch.setattr(build, "host_compiler", lambda: None)
    monkeypatch.setenv("SATMOTOR_ENGINE_CACHE", str(tmp_path))
    lib = build.library_path()
    assert lib.is_file() and lib.parent.parent == tmp_path
    from ctypes import CDLL

    assert CDLL(str(lib)).se_abi() == 1


def test_the_fmus_are_extracted_and_read_once_per_content(tmp_path, monkeypatch, fmu_dir):
    from fmpy import read_model_description

    from orchestration.run.c_engine.prepared import prepared

    monkeypatch.setenv("SATMOTOR_ENGINE_CACHE", str(tmp_path))
    plant = fmus.paths(fmu_dir, "native")[0]
    d, md = prepared(plant)
    assert Path(d).parent == tmp_path / "fmus" and (Path(d) / "modelDescription.xml").is_file()
    assert md.guid == read_model_description(str(plant)).guid
    assert not any(p.name.startswith(".part-") for p in (tmp_path / "fmus").iterdir())
    (Path(d) / "marker").touch()
    assert prepared(plant)[0] == d and (Path(d) / "marker").is_file()  # the same copy, not made again


def test_the_model_descriptions_are_parsed_once_per_content(tmp_path, monkeypatch, fmu_dir):
    import importlib

    from fmpy import read_model_description

    from orchestration.cli.commands import unit_variables

    prep = importlib.import_module("orchestration.run.c_engine.prepared")  # the package names its function

    monkeypatch.setenv("SATMOTOR_ENGINE_CACHE", str(tmp_path))
    paths = fmus.paths(fmu_dir)  # the default (pythonfmu) FMUs: the scenario checks read these
    fresh = [read_model_description(str(p)) for p in paths]
    for path, md in zip(paths, fresh):
        got = prep.description(path)
        assert unit_variables(got) == unit_variables(md) and got.guid == md.guid
    kept = sorted((tmp_path / "descriptions").iterdir())
    assert len(kept) == 2 and not any(p.name.startswith(".part-") for p in kept)
    with monkeypatch.context() as m:  # the second time from the cache, not parsed
        m.setattr(prep, "read_model_description", lambda *a: pytest.fail("parsed again"))
        assert [prep.description(p).guid for p in paths] == [md.guid for md in fresh]
    blocked = tmp_path / "a_file"
    blocked.write_text("")
    monkeypatch.setenv("SATMOTOR_ENGINE_CACHE", str(blocked))  # no cache to write: read from the FMU
    assert unit_variables(prep.description(paths[1])) == unit_variables(fresh[1])
