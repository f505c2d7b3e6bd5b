"""The libcosim engine (orchestration.run.libcosim_engine) against our fmpy master's Jacobi run.

libcosim's fixed-step algorithm is a Jacobi scheme with the same order of step and transfer as
``master.run(..., algorithm="jacobi")`` (see the engine's docstring).  One thing differs: libcosim
counts time in integer nanoseconds and hands each FMU ``dt = double(t + h) - double(t)``, which
differs from ``h`` by up to one unit in the last place of ``t`` (2.2e-16 s for t < 2 s, i.e. up to
2.2e-12 of h = 100 us); the FMUs integrate with that dt.  So:

* with a step whose times are exact in binary (h = 2^-9 s = 1953125 ns: ``t + h - t == h``) the two
  engines agree bit for bit on every column;
* at the library's steps every column agrees within ``RTOL`` of the column's largest magnitude; the
  Integer and Boolean columns, the time and the profiles are equal.
"""

import dataclasses
import json
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("libcosimpy")

from orchestration.cli.commands import run_file  # noqa: E402
from orchestration.packaging import fmus  # noqa: E402
from orchestration.results.atomic import being_written  # noqa: E402
from orchestration.run import libcosim_engine  # noqa: E402
from orchestration.run.master import run as master_run  # noqa: E402
from orchestration.scenario.load import Record, load_scenario  # noqa: E402
from orchestration.scenario.profiles import Constant  # noqa: E402

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[1]
DEFAULT = ROOT / "scenarios" / "ramp_rated_load.yaml"
DECIMATED = ROOT / "scenarios" / "deep_saturation.yaml"  # step 50 us, controller_every = 2
# 1e-10 of the column's largest magnitude: the dt perturbation above is at most 2.2e-12 of h per
# step and the closed loop is stable, so the differences stay at rounding level: largest seen
# 4.9e-13 over the whole default scenario, 5.2e-11 in the speed-controller error e2 over its first
# 0.3 s, where e2 is still small (largest |e2| 5e-3, absolute difference 3e-13).  The coupling
# itself matters far more: the master's Jacobi and Gauss-Seidel runs of the default scenario differ
# by 5e-2 of the column's scale (median over the columns)
RTOL = 1e-10
# A pwm plant integrates each communication step interval by interval between the carrier's edges,
# and the last interval ends at t + dt: the dt perturbation moves that end, so the switched
# voltages' sub-intervals differ at rounding level in every step (tens of RK4 stages instead of
# four).  Measured on pwm_low_speed's first 0.3 s: 4.7e-10 of e2's largest magnitude (absolute
# 2.6e-12), 10x the average-value plant's; bounded at 1e-8, still 1e-6 of the coupling effect above.
RTOL_PWM = 1e-8
DISCRETE = ("controller.phase", "controller.voltage_limited", "controller.current_limited",
            "controller.singular_limited")
VARIANTS = ("native", "python")


def _pair(sc, fmu_dir, variant):
    plant, ctrl = map(str, fmus.paths(fmu_dir, variant))
    ref = master_run(sc, plant, ctrl, algorithm="jacobi")
    got = libcosim_engine.run(sc, plant, ctrl)
    assert ref.ok, ref.message
    assert got.ok, got.message
    return ref.frame, got.frame


def _constant_profiles(sc):
    return dataclasses.replace(sc, profiles={"psi_ref": Constant(0.9), "omega_ref": Constant(60.0),
                                             "T_load": Constant(8.0)})


@pytest.mark.parametrize("variant", VARIANTS)
def test_bit_for_bit_equal_to_the_jacobi_master_when_libcosims_clock_is_exact(variant, fmu_dir):
    h = 2.0 ** -9  # 1953125 ns: k h, (k+1) h and their difference are exact doubles
    sc = dataclasses.replace(load_scenario(DEFAULT), step=h, stop_time=512 * h, record=Record(h, ()))
    ref, got = _pair(sc, fmu_dir, variant)
    assert list(got.columns) == list(ref.columns) and len(got) == len(ref) == 513
    assert np.abs(ref["plant.i_s_alpha"]).max() > 1.0  # something happens
    for c in ref.columns:
        assert np.array_equal(got[c].to_numpy(), ref[c].to_numpy()), c


@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("case", ["default", "decimated", "constant"])
def test_equal_to_the_jacobi_master_within_the_clock_rounding(case, variant, fmu_dir):
    if case == "default":  # time-varying profiles: the ScenarioSignals FMU
        sc = load_scenario(DEFAULT)
    elif case == "decimated":  # the controller steps every 2nd base step (libcosim's decimation)
        sc = load_scenario(DECIMATED)
        assert sc.controller_every == 2
    else:  # constant profiles (in the ScenarioSignals FMU as constants)
        sc = dataclasses.replace(load_scenario(DEFAULT), stop_time=0.4)
        sc = _constant_profiles(sc)
    if variant == "python" and case != "default":
        sc = dataclasses.replace(sc, stop_time=0.4)  # the pythonfmu FMUs are 5x slower
    ref, got = _pair(sc, fmu_dir, variant)
    assert list(got.columns) == list(ref.columns) and len(got) == len(ref)
    assert len(ref) == round(sc.stop_time / sc.record.interval) + 1
    exact = ("time", *DISCRETE, *[c for c in ref.columns if c.startswith("profile.")])
    for c in ref.columns:
        a, b = ref[c].to_numpy(), got[c].to_numpy()
        if c in exact:
            assert np.array_equal(a, b), c
        else:
            assert np.max(np.abs(a - b)) <= RTOL * max(np.max(np.abs(a)), 1e-300), c
    assert (ref["controller.phase"].to_numpy() != ref["controller.phase"].iloc[0]).any()  # the law ran


@pytest.mark.parametrize("path", sorted((ROOT / "scenarios").glob("*.yaml")), ids=lambda p: p.stem)
def test_every_library_scenario_runs_as_the_jacobi_master_or_is_refused_for_its_measurements(path, fmu_dir):
    sc = load_scenario(path)
    sc = dataclasses.replace(sc, stop_time=min(sc.stop_time, 0.3))
    found = libcosim_engine.problems(sc)
    if sc.measurements is not None:
        assert [p.field for p in found] == ["measurements"]
        return
    assert found == []
    ref, got = _pair(sc, fmu_dir, "native")
    assert list(got.columns) == list(ref.columns) and len(got) == len(ref)
    rtol = RTOL_PWM if dict(sc.plant).get("inverter") == "pwm" else RTOL
    for c in ref.columns:
        a, b = ref[c].to_numpy(), got[c].to_numpy()
        assert np.max(np.abs(a - b)) <= rtol * max(np.max(np.abs(a)), 1e-300), c


def test_the_system_libcosim_loads_is_the_ssp_description_with_no_worker_thread(tmp_path, fmu_dir):
    from orchestration.packaging.ssd import OSP_NS, SSD_NS, SSV_NS

    sc = dataclasses.replace(load_scenario(DECIMATED), plant={"J": 0.05})
    paths = dict(zip(("plant", "controller"), fmus.paths(fmu_dir, "native")))
    paths["signals"] = libcosim_engine.signals_fmu_for(sc, tmp_path / "signals")
    outputs = {u: libcosim_engine._Outputs(p) for u, p in paths.items()}
    root = ET.parse(libcosim_engine.system_structure(sc, paths, outputs, tmp_path)).getroot()
    algo = root.find(f".//{{{OSP_NS}}}FixedStepAlgorithm")
    assert algo.get("numWorkerThreads") == "0"  # the units stepped in the calling thread
    assert int(float(algo.get("baseStepSize")) * 1e9) == 50_000  # libcosim truncates to whole ns
    comps = {c.get("name"): c for c in root.iter(f"{{{SSD_NS}}}Component")}
    assert {u: c.get("source") for u, c in comps.items()} == {u: Path(p).resolve().as_uri()
                                                               for u, p in paths.items()}
    hint = comps["controller"].find(f".//{{{OSP_NS}}}StepSizeHint").get("value")
    assert int(float(hint) * 1e9) == 100_000  # Ts = 2 h
    j = comps["plant"].find(f".//{{{SSV_NS}}}Parameter[@name='J']/{{{SSV_NS}}}Real")
    assert float(j.get("value")) == 0.05


@pytest.mark.parametrize("ns", [1, 3, 50_000, 65_000, 100_000, 123_457, 129_000, 1_953_125, 10**9 - 1])
def test_a_time_that_libcosim_would_truncate_is_written_so_it_reads_back_exactly(ns):
    from orchestration.packaging.ssd import seconds_text

    assert int(float(seconds_text(ns / 1e9)) * 1e9) == ns


def test_the_plain_decimal_text_of_65_us_would_make_libcosims_step_64999_ns():
    """Why the texts above are needed: libcosim parses the double and truncates toward zero."""
    assert int(float(repr(65_000 / 1e9)) * 1e9) == 64_999


@pytest.mark.parametrize("every", [1, 2])
def test_a_step_whose_decimal_text_truncates_runs_as_the_jacobi_master(every, fmu_dir):
    """h = 65 us and Ts = 130 us are both below their decimal text once times 1e9 (see above): written
    naively, libcosim would step 64 999 ns and find Ts no multiple of it."""
    h = 6.5e-5
    sc = dataclasses.replace(load_scenario(DEFAULT), step=h, controller_every=every, stop_time=400 * h,
                             record=Record(h, ()))
    ref, got = _pair(sc, fmu_dir, "native")
    assert len(got) == len(ref) == 401
    assert np.array_equal(got["time"].to_numpy(), ref["time"].to_numpy())
    for c in ref.columns:
        a, b = ref[c].to_numpy(), got[c].to_numpy()
        assert np.max(np.abs(a - b)) <= RTOL * max(np.max(np.abs(a)), 1e-300), c


def test_a_step_of_a_fraction_of_a_nanosecond_is_refused_naming_the_field():
    sc = dataclasses.replace(load_scenario(DEFAULT), step=1.0000005e-4)
    (p,) = libcosim_engine.problems(sc)
    assert (p.file, p.field, p.value) == (str(DEFAULT), "step", 1.0000005e-4)
    assert "nanoseconds" in p.message
    assert libcosim_engine.problems(load_scenario(DEFAULT)) == []
    with pytest.raises(ValueError, match="step"):
        libcosim_engine.run(sc, "plant.fmu", "controller.fmu")


def test_a_bad_parameter_fails_the_run_in_the_fmus_words_without_ending_the_process(fmu_dir):
    # libcosim 0.11 itself would std::terminate here (an exception in its initialization thread)
    sc = dataclasses.replace(load_scenario(DEFAULT), stop_time=0.05, plant={"J": 0.0})
    res = libcosim_engine.run(sc, *map(str, fmus.paths(fmu_dir, "native")))
    assert res.status == "error" and res.failed_unit == "plant" and len(res.frame) == 0
    assert "J = 0.0: must be a finite number > 0" in res.message


def test_a_step_failure_keeps_the_rows_and_carries_the_fmus_message(fmu_dir):
    # an inertia so small that RK4 at 100 us is unstable once the speed step comes (0.15 s); without
    # field weakening, whose steady-state search at the diverging state fails one sample before the plant
    sc = dataclasses.replace(load_scenario(DEFAULT), stop_time=0.3, plant={"J": 1.0e-7},
                             controller={"field_weakening": False})
    plant, ctrl = map(str, fmus.paths(fmu_dir, "native"))
    ref = master_run(sc, plant, ctrl, algorithm="jacobi")
    res = libcosim_engine.run(sc, plant, ctrl)
    assert ref.status == res.status == "discard" and res.failed_unit == "plant"
    assert res.t_end == pytest.approx(ref.t_end)
    assert "the plant state became non-finite" in res.message
    # every row up to the last completed step; the master has one more (the controller output it
    # computed at the failing sample, which libcosim's observers never see)
    assert len(res.frame) == len(ref.frame) - 1 > 1000
    # equal while the loop is stable; as it diverges, the clock rounding grows with the states
    stable = ref.frame["time"].to_numpy() < 0.15
    got, want = res.frame[stable[:-1]], ref.frame[stable]
    for c in want.columns:
        a, b = want[c].to_numpy(), got[c].to_numpy()
        assert np.max(np.abs(a - b)) <= RTOL * max(np.max(np.abs(a)), 1e-300), c


class _StopAt:
    """A stop request raised once the recorder got a row at or after ``t``."""

    def __init__(self, t):
        self.t, self.signum = t, 0

    def recorder(self, columns):
        from orchestration.results.recorder import Recorder

        rec = Recorder(columns)
        append, append_rows = rec.append, rec.append_rows

        def app(row):
            append(row)
            if row[0] >= self.t:
                self.signum = 2

        def app_rows(rows):  # the engine hands a chunk's rows over at once
            append_rows(rows)
            if len(rows) and rows[-1][0] >= self.t:
                self.signum = 2

        rec.append, rec.append_rows = app, app_rows
        return rec


def test_an_interrupted_run_keeps_its_rows(fmu_dir):
    sc = load_scenario(DEFAULT)
    plant, ctrl = map(str, fmus.paths(fmu_dir, "native"))
    stop = _StopAt(0.2)
    res = libcosim_engine.run(sc, plant, ctrl, recorder=stop.recorder, stop=stop)
    assert res.status == "interrupted" and "SIGINT" in res.message
    got = res.frame
    assert 0.2 <= got["time"].iloc[-1] < 1.0 and res.t_end < 1.0
    assert np.array_equal(got["time"].to_numpy(), np.arange(len(got)) * sc.step)  # no gap
    ref = master_run(dataclasses.replace(sc, stop_time=round(res.t_end, 6)), plant, ctrl,
                     algorithm="jacobi").frame.iloc[:len(got)]
    for c in ref.columns:
        a, b = ref[c].to_numpy(), got[c].to_numpy()
        assert np.max(np.abs(a - b)) <= RTOL * max(np.max(np.abs(a)), 1e-300), c


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "orchestration", *map(str, args)], capture_output=True,
                          text=True, cwd=ROOT, timeout=600)


@pytest.mark.parametrize("extra, field", [((ROOT / "scenarios" / "noisy_measurements.yaml",), "measurements"),
                                          ((DEFAULT, "--algorithm", "gauss-seidel"), "--algorithm"),
                                          ((DEFAULT, "--variant", "native-fmi3"), "--variant")])
def test_the_cli_refuses_what_libcosim_cannot_run_with_exit_2(extra, field, tmp_path, fmu_dir):
    r = _cli("run", *extra, "--engine", "libcosim", "--out", tmp_path, "--fmus", fmu_dir, "--no-build")
    assert r.returncode == 2, r.stderr
    assert field in r.stderr
    if field != "--variant":
        assert f"{extra[0]}: {field} = " in r.stderr  # file: field = value: reason
    assert not (tmp_path / "ramp_rated_load").exists()


def test_run_with_libcosim_writes_the_same_files_as_the_default_engine(tmp_path, fmu_dir):
    sc = tmp_path / "short.yaml"
    sc.write_text(DEFAULT.read_text().replace("stop_time: 1.5", "stop_time: 0.3")
                  .replace("ss_window: [1.3, 1.5]", "ss_window: [0.2, 0.3]")
                  .replace("algorithm: gauss-seidel", "algorithm: jacobi"))
    code_f, sum_f = run_file(sc, tmp_path / "fmpy", fmu_dir, build=False, variant="native")
    code_l, sum_l = run_file(sc, tmp_path / "libcosim", fmu_dir, build=False, variant="native",
                             engine="libcosim")
    assert code_l == code_f and sum_l["status"] == "ok" and sum_l["rows"] == sum_f["rows"] == 3001
    assert "libcosim" in sum_l["message"]
    for name in ("timeseries.csv", "timeseries.parquet", "metrics.json", "figure.png"):
        assert (tmp_path / "libcosim" / "ramp_rated_load" / name).is_file(), name
    a = pd.read_parquet(tmp_path / "fmpy" / "ramp_rated_load" / "timeseries.parquet")
    b = pd.read_csv(tmp_path / "libcosim" / "ramp_rated_load" / "timeseries.csv")
    assert list(a.columns) == list(b.columns)
    m = json.loads((tmp_path / "libcosim" / "ramp_rated_load" / "metrics.json").read_text())
    for key, v in sum_f["metrics"].items():
        assert m["metrics"][key] == pytest.approx(v, rel=1e-8, abs=1e-12), key


@pytest.mark.parametrize("variant, path", [("native", DEFAULT), ("native", DECIMATED), ("python", DEFAULT)])
def test_libcosim_runs_the_exported_ssp_package_as_the_engine_runs_the_scenario(variant, path, tmp_path,
                                                                                fmu_dir):
    from orchestration.tools.ssp import export

    sc = load_scenario(path)
    if variant == "python":
        sc = dataclasses.replace(sc, stop_time=0.3)
    plant, ctrl = map(str, fmus.paths(fmu_dir, variant))
    package = export(sc, tmp_path / f"{sc.name}.ssp", plant, ctrl)
    got = libcosim_engine.run_package(sc, package)  # CosimExecution.from_ssp_file on the .ssp
    want = libcosim_engine.run(sc, plant, ctrl)  # its SystemStructure.ssd, the FMUs by file URI
    assert got.ok and want.ok, (got.message, want.message)
    assert list(got.frame.columns) == list(want.frame.columns) and len(got.frame) == len(want.frame)
    for c in want.frame.columns:  # the same system: bit for bit
        assert np.array_equal(got.frame[c].to_numpy(), want.frame[c].to_numpy()), c


@pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_run_with_libcosim_stops_on_a_signal_and_writes_what_it_has(sig, code, tmp_path, fmu_dir):
    # libcosim steps in C++: the handler runs between two chunks of ROWS_CHUNK_TIME simulated seconds
    f = tmp_path / "long.yaml"
    f.write_text("name: long\nstop_time: 30.0\nprofiles:\n  psi_ref: {type: constant, value: 0.9}\n"
                 "  omega_ref: {type: step, time: 0.15, value: 50.0}\n")
    out = tmp_path / "out"
    args = ["run", f, "--engine", "libcosim", "--out", out, "--fmus", fmu_dir, "--no-build", "--no-plot"]
    p = subprocess.Popen([sys.executable, "-m", "orchestration", *map(str, args)], cwd=ROOT,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    csv = out / "long" / "timeseries.csv"
    for _ in range(2400):  # until the first chunk of rows is on disk (at most 120 s)
        assert p.poll() is None, p.communicate()
        part = being_written(csv.parent, csv.name)  # streamed under its temporary name
        if part.exists() and part.stat().st_size > 10_000:
            break
        time.sleep(0.05)
    p.send_signal(sig)
    stdout, stderr = p.communicate(timeout=120)
    assert p.returncode == code, stderr
    m = json.loads((out / "long" / "metrics.json").read_text())
    assert m["status"] == "interrupted" and signal.Signals(sig).name in m["message"]
    assert "Traceback" not in stderr
    rows = pd.read_csv(csv)
    # at least the first chunk on disk when the signal came (the engine's chunk: ROWS_CHUNK_TIME =
    # 0.1 s, at most one RowRecorder block, about 990 rows of every output; its rows are one write)
    assert len(rows) == m["rows"] >= 900 and rows["time"].iloc[-1] <= m["t_end"] < 30.0
    assert np.array_equal(rows["time"].to_numpy(), np.arange(len(rows)) * 1e-4)  # no gap
    assert len(pd.read_parquet(out / "long" / "timeseries.parquet")) == m["rows"]
