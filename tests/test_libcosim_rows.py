"""Recording inside a compiled engine: the RowRecorder FMU (orchestration.packaging.native.recorder_fmu,
fmu/recorder/native_model.c), the rows the libcosim engine makes of it
(orchestration.run.row_recorder) and the engine's ``record: metrics`` fast path against the project's
master.

The FMU is checked alone under fmpy (the rows it writes are the inputs the test set, the parameters
it refuses name the parameter and the value); the row alignment against a second formulation of the
Jacobi rule written here; the engine's metrics against the master's Jacobi run, as ``run`` prints
them (``%.6g``).
"""

import dataclasses
import json
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmu_helpers import Slave, open_fmu

from orchestration.packaging import fmus
from orchestration.packaging.native.recorder_fmu import (
    BLOCK,
    N_BOOLEAN,
    N_INTEGER,
    N_REAL,
    VR,
    recorder_fmu_for,
)
from orchestration.results.running import FLAG_COLUMNS, METRIC_COLUMNS, PHASE_COLUMN, PSI_SET_COLUMN
from orchestration.results.writer import streaming_recorder
from orchestration.run import row_recorder
from orchestration.run.lean_fmu import lean_fmu
from orchestration.run.master import run as master_run
from orchestration.scenario.load import load_scenario
from orchestration.scenario.recording import record_steps

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = ROOT / "scenarios" / "ramp_rated_load.yaml"
DECIMATED = ROOT / "scenarios" / "deep_saturation.yaml"  # step 50 us, controller_every = 2


@pytest.fixture(scope="module")
def recorder(tmp_path_factory):
    return recorder_fmu_for(tmp_path_factory.mktemp("recorder"))


def _instance(fmu, tmp_path, **params):
    """A RowRecorder instance in initialization mode with ``params`` set (fmpy, messages logged)."""
    s = Slave(open_fmu(fmu, str(tmp_path / "x")), "rec", initialize=False)
    s.fmu.setupExperiment(startTime=0.0)
    s.fmu.enterInitializationMode()
    s.set(params)
    return s


def test_the_recorder_writes_the_inputs_set_at_each_step_start_as_rows_of_doubles(recorder, tmp_path):
    rows_file = tmp_path / "rows.bin"
    s = _instance(recorder, tmp_path, rows_file=str(rows_file), n_real=2, n_integer=1, n_boolean=1,
                  rows=5, block_rows=2)
    slave = s.fmu
    slave.exitInitializationMode()
    want = []
    t, h = 0.0, 0.25
    for k in range(7):  # two more steps than rows: they record nothing
        x = [1.0 / 3.0 + k, -2.5e300 * k]
        slave.setReal([VR["x0"], VR["x1"]], x)
        slave.setInteger([VR["k0"]], [k - 3])
        slave.setBoolean([VR["b0"]], [k % 2 == 1])
        if k < 5:
            want.append([t, *x, float(k - 3), float(k % 2)])
        if k == 3:  # blocks of two rows: rows 0 and 1 on disk, then 2 and 3 after this step
            assert len(np.fromfile(rows_file)) == 2 * 5
        slave.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        t += h
    slave.terminate()
    slave.freeInstance()
    got = np.fromfile(rows_file, dtype=np.float64).reshape(-1, 5)
    assert np.array_equal(got, np.array(want))  # exact: the doubles as set, Integers and Booleans too


@pytest.mark.parametrize("params, words", [
    ({"n_real": N_REAL + 1}, f"n_real = {N_REAL + 1} is invalid: must be in 0 .. {N_REAL}"),
    ({"n_boolean": N_BOOLEAN + 1}, f"n_boolean = {N_BOOLEAN + 1} is invalid: must be in 0 .. {N_BOOLEAN}"),
    ({"n_integer": N_INTEGER + 1}, f"n_integer = {N_INTEGER + 1} is invalid: must be in 0 .. {N_INTEGER}"),
    ({"n_boolean": -1}, "n_boolean = -1 is invalid"),
    ({"n_real": 0}, "nothing to record"),
    ({"rows": 0}, "rows = 0 is invalid"),
    ({"block_rows": BLOCK // 3 + 1}, f"block_rows = {BLOCK // 3 + 1} is invalid"),
    ({"rows_file": "/nonexistent-dir/rows.bin"}, "/nonexistent-dir/rows.bin': cannot create"),
])
def test_the_recorder_refuses_bad_parameters_naming_them(recorder, tmp_path, params, words):
    from fmpy.fmi1 import FMICallException

    base = {"rows_file": str(tmp_path / "r.bin"), "n_real": 2, "rows": 3, "block_rows": 1}
    s = _instance(recorder, tmp_path, **{**base, **params})
    with pytest.raises(FMICallException):
        s.fmu.exitInitializationMode()
    assert words in s.messages(), s.messages()
    s.fmu.freeInstance()


def test_rows_follow_the_jacobi_rule_for_a_decimated_controller(tmp_path):
    """Recorder row r holds the plant at t_r and the controller output last transferred: the sample
    of t_j reaches the recorder at t_j + N h.  Written here a second way: the master's row k takes
    the controller's sample of t_{N floor(k / N)}."""
    N, n, h = 3, 20, 1e-3
    sc = dataclasses.replace(load_scenario(DEFAULT), step=h, controller_every=N, stop_time=n * h)
    sources = [("plant", "omega_m", "Real"), ("controller", "v_s_alpha", "Real"),
               ("controller", "phase", "Integer")]
    steps = row_recorder.steps_needed(sc)
    rec = np.zeros((steps, 4))
    for r in range(steps):
        sample = N * (r // N) - N  # the sample whose output was transferred at t_r (none before t_N)
        rec[r] = [r * h, 10.0 * r, 1000.0 + sample if r >= N else 0.0, sample if r >= N else 0]
    path = tmp_path / "rows.bin"
    rows = row_recorder.Rows(path, sc, sources)
    got = []
    for upto in (7, 15, steps):  # the file grows in blocks, as the engine steps
        rec[:upto].tofile(path)
        got.append(rows.table())
    table = np.concatenate(got)
    k = np.arange(n + 1)
    assert np.array_equal(table[:, 0], k * h)
    assert np.array_equal(table[:, 1], 10.0 * k)
    assert np.array_equal(table[:, 2], 1000.0 + N * (k // N))
    assert np.array_equal(table[:, 3], N * (k // N))


def test_a_lean_copy_keeps_what_an_importer_runs_and_is_made_once(tmp_path, fmu_dir):
    plant = fmus.paths(fmu_dir, "native")[0]
    copy = lean_fmu(plant, tmp_path)
    with zipfile.ZipFile(plant) as a, zipfile.ZipFile(copy) as b:
        kept = [n for n in a.namelist() if n == "modelDescription.xml" or n.startswith(("binaries/linux64/",
                                                                                        "resources/"))]
        assert sorted(b.namelist()) == sorted(kept) and any(n.startswith("sources/") for n in a.namelist())
        for name in kept:
            assert a.read(name) == b.read(name), name
        assert {i.compress_type for i in b.infolist()} == {zipfile.ZIP_STORED}
    mtime = copy.stat().st_mtime_ns
    assert lean_fmu(plant, tmp_path) == copy and copy.stat().st_mtime_ns == mtime


def _metrics_scenario(path, stop):
    sc = load_scenario(path)
    return dataclasses.replace(sc, stop_time=stop, record=dataclasses.replace(sc.record, level="metrics"))


def _printed(metrics):
    return {k: f"{v:.6g}" for k, v in metrics.items()}


@pytest.mark.slow
@pytest.mark.parametrize("path, stop", [(DEFAULT, 0.4), (DECIMATED, 0.2)])
def test_the_metrics_fast_path_prints_the_metrics_of_the_jacobi_master(path, stop, tmp_path, fmu_dir):
    pytest.importorskip("libcosimpy", reason="the libcosim extra: pip install 'satmotor[libcosim]'")
    from orchestration.run import libcosim_engine

    sc = _metrics_scenario(path, stop)
    plant, ctrl = map(str, fmus.paths(fmu_dir, "native"))
    ref = master_run(sc, plant, ctrl, algorithm="jacobi", recorder=streaming_recorder(sc, tmp_path))
    got = libcosim_engine.run(sc, plant, ctrl, recorder=streaming_recorder(sc, tmp_path),
                              recorder_cache=tmp_path / "cache")
    assert ref.ok and got.ok, (ref.message, got.message)
    read = {"time", *METRIC_COLUMNS.values(), *FLAG_COLUMNS.values(), PHASE_COLUMN, PSI_SET_COLUMN}
    assert set(got.recorder.columns) == read  # only what the metrics read
    n, every = record_steps(sc)
    assert got.recorder.n_seen == ref.recorder.n_seen == n // every + 1
    want = ref.recorder.metrics_observer.metrics.result()
    have = got.recorder.metrics_observer.metrics.result()
    assert want and _printed(have) == _printed(want)


@pytest.mark.slow
def test_a_failed_metrics_run_sees_every_row_up_to_the_failure(tmp_path, fmu_dir):
    """The rows after the recorder's last block come from libcosim's observers (a second run)."""
    pytest.importorskip("libcosimpy", reason="the libcosim extra: pip install 'satmotor[libcosim]'")
    from orchestration.run import libcosim_engine

    sc = dataclasses.replace(_metrics_scenario(DEFAULT, 0.3), plant={"J": 1.0e-7},
                             controller={"field_weakening": False})
    plant, ctrl = map(str, fmus.paths(fmu_dir, "native"))
    ref = master_run(sc, plant, ctrl, algorithm="jacobi", recorder=streaming_recorder(sc, tmp_path))
    got = libcosim_engine.run(sc, plant, ctrl, recorder=streaming_recorder(sc, tmp_path),
                              recorder_cache=tmp_path / "cache")
    assert ref.status == got.status == "discard" and got.failed_unit == "plant"
    assert "the plant state became non-finite" in got.message
    # the master also records the controller output of the failing sample (as the observers' run)
    assert got.recorder.n_seen == ref.recorder.n_seen - 1 > 1000


@pytest.mark.slow
def test_run_engine_libcosim_with_record_metrics_writes_the_masters_metrics(tmp_path, fmu_dir):
    pytest.importorskip("libcosimpy", reason="the libcosim extra: pip install 'satmotor[libcosim]'")
    from orchestration.cli.commands import run_file

    text = DEFAULT.read_text().replace("stop_time: 1.5", "stop_time: 0.4").replace(
        "ss_window: [1.3, 1.5]", "ss_window: [0.3, 0.4]")
    assert "record:" in text
    path = tmp_path / "short.yaml"
    path.write_text(text.replace("record:", "record:\n  level: metrics", 1))
    code_m, want = run_file(path, tmp_path / "fmpy", fmu_dir, build=False, variant="native",
                            algorithm="jacobi")
    code_l, got = run_file(path, tmp_path / "libcosim", fmu_dir, build=False, variant="native",
                           engine="libcosim")
    assert code_l == code_m and got["status"] == want["status"] == "ok"  # exit 3 at 0.4 s: not accepted
    assert sorted(p.name for p in (tmp_path / "libcosim" / "ramp_rated_load").iterdir()) == ["metrics.json"]
    m = json.loads((tmp_path / "libcosim" / "ramp_rated_load" / "metrics.json").read_text())
    assert _printed(m["metrics"]) == _printed(want["metrics"])
    verdicts = [{k: v["pass"] for k, v in s["acceptance"].items()} for s in (m, want)]
    assert verdicts[0] == verdicts[1]
