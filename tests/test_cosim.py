"""The fmpy co-simulation master against the plain-Python closed loop, the CLI, batch and Dask."""

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from orchestration.packaging import fmus
from orchestration.run.master import DEFAULT_CONNECTIONS, Connection, run
from orchestration.run.reference import COLUMNS, plain_reference
from orchestration.scenario.load import load_scenario
from orchestration.scenario.profiles import Constant, Step, Sum

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[1]
LIBRARY = sorted((ROOT / "scenarios").glob("*.yaml"))


def _on_common_times(co, ref, h):
    k_co = np.rint(co["time"].to_numpy() / h).astype(np.int64)
    k_ref = np.rint(ref["time"].to_numpy() / h).astype(np.int64)
    common, i, j = np.intersect1d(k_co, k_ref, return_indices=True)
    return co.iloc[i], ref.iloc[j], len(common)


def _max_rel_diff(a, b, columns):
    return max(np.max(np.abs(a[c].to_numpy() - b[c].to_numpy()))
               / max(np.max(np.abs(b[c].to_numpy())), 1e-300) for c in columns)


def test_library_has_the_required_scenarios():
    names = {p.stem for p in LIBRARY}
    assert len(names) >= 7
    assert {"startup_premag", "ramp_rated_load", "speed_reversal", "deep_saturation", "sinusoidal_load",
            "rotor_resistance_mismatch", "field_weakening"} <= names


@pytest.mark.parametrize("path", LIBRARY, ids=lambda p: p.stem)
def test_cosimulation_matches_the_plain_python_closed_loop(path, fmu_dir):
    sc = load_scenario(path)
    plant, ctrl = fmus.paths(fmu_dir)
    res = run(sc, str(plant), str(ctrl))
    assert res.ok, res.message
    assert res.frame["time"].iloc[-1] == pytest.approx(sc.stop_time)
    co, ref, n = _on_common_times(res.frame, plain_reference(sc), sc.step)
    assert n >= 100
    assert _max_rel_diff(co, ref, COLUMNS) <= 1e-8


def test_jacobi_and_gauss_seidel_differ_less_with_a_smaller_step(fmu_dir):
    base = load_scenario(ROOT / "scenarios" / "startup_premag.yaml")
    plant, ctrl = fmus.paths(fmu_dir)
    diffs = []
    for h in (2e-4, 1e-4, 5e-5):
        sc = dataclasses.replace(base, step=h, stop_time=0.4,
                                 record=dataclasses.replace(base.record, interval=2e-4))
        gs, ja = run(sc, str(plant), str(ctrl), algorithm="gauss-seidel"), run(sc, str(plant), str(ctrl),
                                                                            algorithm="jacobi")
        assert gs.ok and ja.ok
        diffs.append(float(np.max(np.abs(gs.frame["plant.omega_m"] - ja.frame["plant.omega_m"]))))
    assert diffs[0] > 0.0
    assert diffs[1] < 0.7 * diffs[0] and diffs[2] < 0.7 * diffs[1], diffs


def test_an_fmu_failure_stops_cleanly_and_keeps_what_was_recorded(tmp_path, fmu_dir):
    # validation refuses an unreachable flux set-point; the master must still handle the controller
    # refusing it at run time (a scenario built in code skips the file checks)
    f = tmp_path / "reachable.yaml"
    f.write_text("name: reachable\nstop_time: 0.3\nprofiles:\n  psi_ref: {type: constant, value: 0.9}\n"
                 "  omega_ref: {type: constant, value: 20.0}\n")
    sc = load_scenario(f)
    sc = dataclasses.replace(sc, profiles={**sc.profiles, "psi_ref": Sum((Constant(0.9), Step(0.2, 1.5)))})
    plant, ctrl = fmus.paths(fmu_dir)
    res = run(sc, str(plant), str(ctrl))
    assert res.status == "discard" and res.failed_unit == "controller"
    assert "BacksteppingController at t = 0.2 s" in res.message  # the FMU's own words, not "unknown error"
    assert "psi_ref" in res.message and "2.4" in res.message  # the value 0.9 + 1.5, named by the drive
    assert res.t_end == pytest.approx(0.2) and res.frame["time"].iloc[-1] == pytest.approx(0.2 - 1e-4)


class _NanAfter:
    """A profile that turns NaN at ``t_nan`` [s]."""

    def __init__(self, t_nan):
        self.t_nan = t_nan

    def value(self, t):
        return float("nan") if t >= self.t_nan else 0.0


def test_a_plant_failure_inside_the_master_carries_the_plants_reason(fmu_dir):
    # only the plant sees the bad value; the controller is created last, so with fmpy's global
    # logger proxy the plant's message used to land in the controller's log and the report said nothing
    sc = dataclasses.replace(load_scenario(LIBRARY[0]), stop_time=0.05)
    sc = dataclasses.replace(sc, profiles={**sc.profiles, "bad": _NanAfter(0.02)})
    conns = tuple(c for c in DEFAULT_CONNECTIONS if c.target != "plant.T_load")
    conns += (Connection("profile.bad", "plant.T_load"),)
    plant, ctrl = fmus.paths(fmu_dir)
    res = run(sc, str(plant), str(ctrl), connections=conns)
    assert res.status == "discard" and res.failed_unit == "plant" and res.t_end == pytest.approx(0.02)
    assert "SaturatedInductionMotor at t = 0.02 s: T_load = nan: must be a finite number" in res.message


def test_a_bad_parameter_reaches_the_master_in_the_fmus_words(fmu_dir):
    sc = dataclasses.replace(load_scenario(LIBRARY[0]), stop_time=0.05, plant={"J": 0.0})
    plant, ctrl = fmus.paths(fmu_dir)
    res = run(sc, str(plant), str(ctrl))
    assert not res.ok and res.failed_unit == "plant"
    assert "J = 0.0: must be a finite number > 0" in res.message


def _cli(*args, cwd=ROOT):
    return subprocess.run([sys.executable, "-m", "orchestration", *map(str, args)], capture_output=True,
                          text=True, cwd=cwd, timeout=600)


@pytest.mark.parametrize("verb", ["", "build", "run", "batch", "validate"])
def test_help_everywhere(verb):
    r = _cli(*([verb] if verb else []), "--help")
    assert r.returncode == 0 and "usage" in r.stdout


def test_cli_run_writes_timeseries_metrics_and_figure(tmp_path, fmu_dir):
    r = _cli("run", ROOT / "scenarios" / "startup_premag.yaml", "--out", tmp_path, "--fmus", fmu_dir)
    assert r.returncode == 0, r.stderr
    d = tmp_path / "startup_premag"
    csv, parquet = pd.read_csv(d / "timeseries.csv"), pd.read_parquet(d / "timeseries.parquet")
    assert len(csv) == len(parquet) > 1000 and np.allclose(csv["plant.omega_m"], parquet["plant.omega_m"])
    m = json.loads((d / "metrics.json").read_text())
    assert m["status"] == "ok" and m["metrics"]["min_W"] > 0
    # the metric and the recorded series agree (an independent recomputation)
    i_peak = np.max(np.hypot(csv["plant.i_s_alpha"], csv["plant.i_s_beta"]))
    assert m["metrics"]["peak_current"] == pytest.approx(i_peak, rel=1e-12)
    assert (d / "figure.png").stat().st_size > 20_000


def test_cli_validate_reports_a_bad_file_and_exits_nonzero(tmp_path):
    f = tmp_path / "bad.yaml"
    f.write_text("name: bad\nstop_time: -1.0\nprofiles: {omega_ref: {type: constant, value: 1.0}}\n")
    r = _cli("validate", f)
    assert r.returncode == 2
    assert str(f) in r.stderr and "stop_time" in r.stderr and "-1.0" in r.stderr and "psi_ref" in r.stderr


@pytest.fixture
def small_batch(tmp_path):
    d = tmp_path / "batch"
    d.mkdir()
    for name, stop in (("short_a", 0.25), ("short_b", 0.3)):
        (d / f"{name}.yaml").write_text(
            f"name: {name}\nstop_time: {stop}\nprofiles:\n  psi_ref: {{type: constant, value: 0.95}}\n"
            "  omega_ref: {type: step, time: 0.15, value: 30.0}\n")
    (d / "broken.yaml").write_text("name: broken\nstop_time: 0.2\nprofiles: {psi_ref: {type: nope}}\n")
    return d


def _check_batch(r, out):
    assert r.returncode == 2, r.stdout + r.stderr  # one invalid scenario: non-zero, the others done
    summary = pd.read_csv(out / "summary.csv")
    status = dict(zip(summary["scenario"], summary["status"]))
    assert status == {"short_a": "ok", "short_b": "ok", "broken": "invalid"}
    assert "INVALID" in r.stderr and "broken.yaml" in r.stderr
    for name in ("short_a", "short_b"):
        assert (out / name / "metrics.json").exists()


def test_batch_completes_the_others_when_one_scenario_is_broken(tmp_path, small_batch, fmu_dir):
    out = tmp_path / "out"
    r = _cli("batch", small_batch, "--jobs", 2, "--out", out, "--fmus", fmu_dir)
    _check_batch(r, out)
    assert "iae_speed" in r.stdout  # the summary table on screen


def test_batch_on_a_dask_local_cluster(tmp_path, small_batch, fmu_dir):
    from distributed import LocalCluster

    out = tmp_path / "out"
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        r = _cli("batch", small_batch, "--scheduler", cluster.scheduler_address, "--out", out,
                 "--fmus", fmu_dir)
    _check_batch(r, out)


def test_cli_run_of_a_failing_scenario_writes_the_partial_results(tmp_path, fmu_dir):
    # an inertia so small that RK4 at 100 us is unstable once the speed step comes (0.15 s)
    f = tmp_path / "fails.yaml"
    f.write_text("name: fails\nstop_time: 0.3\nplant: {J: 1.0e-7}\nprofiles:\n"
                 "  psi_ref: {type: constant, value: 0.9}\n"
                 "  omega_ref: {type: step, time: 0.15, value: 50.0}\n")
    r = _cli("run", f, "--out", tmp_path / "out", "--fmus", fmu_dir)
    assert r.returncode == 1 and "discard" in r.stdout
    d = tmp_path / "out" / "fails"
    m = json.loads((d / "metrics.json").read_text())
    assert m["status"] == "discard" and "non-finite" in m["message"] and 0.15 < m["t_end"] < 0.3
    csv = pd.read_csv(d / "timeseries.csv")
    assert len(csv) == m["rows"] and csv["time"].iloc[-1] == pytest.approx(m["t_end"])


def test_fmu_instance_do_step_raises_tagged_with_the_unit_time_and_the_fmus_words(fmu_dir):
    from fmpy.fmi1 import FMICallException

    from orchestration.run.fmu_instance import FMUInstance

    plant, _ = fmus.paths(fmu_dir)
    inst = FMUInstance(plant, "p")
    try:
        inst.initialize(0.0)
        inst.do_step(0.0, 1e-4)
        with pytest.raises(FMICallException) as err:
            inst.do_step(float("nan"), 1e-4)
        assert err.value.unit == "p" and err.value.status == 2
        assert "currentCommunicationPoint = nan: must be finite" in inst.first_error()
    finally:
        inst.close()
    assert not Path(inst.unzip_dir).exists()  # its own extraction, removed


def test_a_run_recorded_in_memory_writes_the_same_files_as_a_streamed_run(tmp_path, fmu_dir):
    from orchestration.results.writer import prepare_dir, streaming_recorder, write_results

    sc = dataclasses.replace(load_scenario(ROOT / "scenarios" / "load_cycle_csv.yaml"), stop_time=0.05)
    plant, ctrl = fmus.paths(fmu_dir)
    mem = run(sc, str(plant), str(ctrl))
    write_results(mem, tmp_path / "mem", plot=False)
    disk = prepare_dir(tmp_path / "disk", sc)
    streamed = run(sc, str(plant), str(ctrl), recorder=streaming_recorder(sc, disk))
    write_results(streamed, tmp_path / "disk", plot=False)
    a, b = tmp_path / "mem" / sc.name, tmp_path / "disk" / sc.name
    assert (a / "timeseries.csv").read_bytes() == (b / "timeseries.csv").read_bytes()
    assert pd.read_parquet(a / "timeseries.parquet").equals(pd.read_parquet(b / "timeseries.parquet"))
    header = (a / "timeseries.csv").read_text().splitlines()[0].split(",")
    # record.outputs plus what the metrics and the figure need, not every column of the run
    assert len(header) < len(mem.recorder.columns) and "plant.omega_m" in header
