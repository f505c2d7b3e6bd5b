"""The command line as a user meets it: bad input stopped before any FMU runs, failures explained,
Ctrl-C and SIGTERM safe in run and batch (partial results, exit codes, no process left), batch
rows that say the truth, outputs that are checked first and cleaned on a rerun."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from orchestration.results.atomic import being_written

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[1]
PSI = "  psi_ref: {type: constant, value: 0.9}\n"


def _cli(*args, env=None, **kw):
    return subprocess.run([sys.executable, "-m", "orchestration", *map(str, args)], capture_output=True,
                          text=True, timeout=600, env=env, **kw)


def _start(*args, **kw):
    return subprocess.Popen([sys.executable, "-m", "orchestration", *map(str, args)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kw)


def _scenario(d, name, stop_time=0.3, extra=""):
    f = Path(d) / f"{name}.yaml"
    f.write_text(f"name: {name}\nstop_time: {stop_time}\nprofiles:\n{PSI}"
                 "  omega_ref: {type: step, time: 0.15, value: 50.0}\n" + extra)
    return f


def _processes(marker):
    """Command lines of the live processes whose arguments contain ``marker``."""
    out = subprocess.run(["ps", "-ww", "-eo", "pid,stat,args"], capture_output=True, text=True).stdout
    rows = [line.split(None, 2) for line in out.splitlines()[1:]]
    return [" ".join(r) for r in rows if len(r) == 3 and str(marker) in r[2] and not r[1].startswith("Z")]


def _wait_running(metrics, proc, timeout=120.0):
    """Until ``metrics`` says the run has started and its first chunk of rows is in timeseries.csv
    beside it (a state, not a time: a loaded machine only makes the wait longer)."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        assert proc.poll() is None, proc.communicate()
        csv = being_written(metrics.parent, "timeseries.csv")  # streamed under its temporary name
        if metrics.exists() and '"running"' in metrics.read_text() and csv.exists():
            with open(csv) as f:
                if len(f.readlines(1 << 16)) >= 2:  # the header and at least one row
                    return
        time.sleep(0.05)
    raise AssertionError("the run never wrote its first rows")


# --- bad input stopped before any FMU runs ----------------------------------------------------------------

BAD = {
    "plant.R_s": ("plant: {R_s: -1.0}\n", "-1.0"),
    "plant.J": ("plant: {J: 0}\n", "0"),
    "profiles.psi_ref": ("controller: {I_max: 2.0}\n", "needs a magnetizing current"),
    "stop_time": ("record: {interval: 1.0e-4}\n", "1e+08 values"),
}


@pytest.mark.parametrize("field", list(BAD))
def test_validate_and_run_refuse_what_the_fmus_would_refuse(field, tmp_path, fmu_dir):
    extra, value = BAD[field]
    stop = 1.0e9 if field == "stop_time" else 0.3
    f = _scenario(tmp_path, "bad", stop, extra)
    r = _cli("validate", f, "--fmus", fmu_dir)
    assert r.returncode == 2
    line = next(ln for ln in r.stderr.splitlines() if f": {field} = " in ln)
    assert str(f) in line and value in line
    r = _cli("run", f, "--out", tmp_path / "out", "--fmus", fmu_dir, "--no-build")
    assert r.returncode == 2 and field in r.stderr
    assert not (tmp_path / "out").exists()  # refused before anything ran or was written


def test_every_bad_override_is_reported_at_once(tmp_path, fmu_dir):
    f = _scenario(tmp_path, "bad", extra="plant: {R_s: -1.0, J: 0, l_s: -1.0e-3}\ncontroller: {c1: -3.0}\n")
    r = _cli("validate", f, "--fmus", fmu_dir)
    assert r.returncode == 2
    for field in ("plant.R_s", "plant.J", "plant.l_s", "controller.c1"):
        assert f": {field} = " in r.stderr, r.stderr


# --- set-points held or not, mismatch notes: said, never refused ------------------------------------------

LOADED = "  omega_ref: {type: step, time: 0.15, value: 50.0}\n"


def _loaded(d, name, T_load, stop_time=0.5, extra=""):
    f = Path(d) / f"{name}.yaml"
    f.write_text(f"name: {name}\nstop_time: {stop_time}\nprofiles:\n{PSI}{LOADED}"
                 f"  T_load: {{type: step, time: 0.3, value: {T_load!r}}}\n" + extra)
    return f


def test_run_says_in_one_line_when_the_set_points_are_not_held(tmp_path, fmu_dir):
    # 90 N m on the default motor at 0.9 Wb with the default I_max = 30 A: more than the current allows
    f = _loaded(tmp_path, "overload", 90.0)
    r = _cli("run", f, "--out", tmp_path / "out", "--fmus", fmu_dir, "--no-build", "--no-plot")
    assert r.returncode == 0, r.stderr  # no acceptance bounds: the exit code is unchanged
    first = r.stdout.splitlines()[0]
    assert first.startswith("overload: ok, set-points NOT held in [0.45, 0.5] s: speed off its set-point")
    assert "current limit active in" in first
    m = json.loads((tmp_path / "out" / "overload" / "metrics.json").read_text())
    assert m["holds_setpoints"] is False and m["setpoints"] in first and m["accepted"] is None
    assert m["metrics"]["ss_speed"] > 0.02 and m["metrics"]["ss_current_limited_fraction"] > 0
    (note,) = [ln for ln in r.stderr.splitlines() if ": note: " in ln]  # said before it ran, too
    assert note.startswith(f"{f}: note: profiles.T_load: the load's peak |T_load| = 90 N m exceeds")
    assert m["notes"] == [note]


def test_run_says_when_the_set_points_are_held(tmp_path, fmu_dir):
    f = _loaded(tmp_path, "held", 20.0)
    r = _cli("run", f, "--out", tmp_path / "out", "--fmus", fmu_dir, "--no-build", "--no-plot")
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert lines[0].startswith("held: ok, ") and "NOT held" not in r.stdout
    assert lines[1].startswith("  set-points held in [0.45, 0.5] s: speed within")
    m = json.loads((tmp_path / "out" / "held" / "metrics.json").read_text())
    assert m["holds_setpoints"] is True and m["notes"] == [] and ": note: " not in r.stderr


@pytest.mark.parametrize("share, held", [(0.95, True), (1.05, False)])
def test_the_torque_limit_validate_notes_is_where_the_closed_loop_stops_holding(tmp_path, fmu_dir, share,
                                                                                  held):
    from satmotor.limits import torque_limit
    from satmotor.machine.params import MotorParams

    T = round(share * torque_limit(MotorParams(), 0.9, 30.0).T_max, 3)
    f = _loaded(tmp_path, "near", T, stop_time=1.0)
    r = _cli("validate", f, "--fmus", fmu_dir)
    assert r.returncode == 0 and ("profiles.T_load" in r.stderr) == (not held), r.stderr
    r = _cli("run", f, "--out", tmp_path / "out", "--fmus", fmu_dir, "--no-build", "--no-plot")
    m = json.loads((tmp_path / "out" / "near" / "metrics.json").read_text())
    assert r.returncode == 0 and m["holds_setpoints"] is held, m["setpoints"]


def test_batch_lists_the_runs_that_do_not_hold(tmp_path, fmu_dir):
    d = tmp_path / "scenarios"
    d.mkdir()
    _loaded(d, "overload", 90.0)
    _loaded(d, "held", 20.0)
    r = _cli("batch", d, "--out", tmp_path / "out", "--fmus", fmu_dir, "--jobs", 1)
    assert r.returncode == 0, r.stderr
    summary = pd.read_csv(tmp_path / "out" / "summary.csv").set_index("scenario")
    assert summary.loc["overload", "holds_setpoints"] == False  # noqa: E712 - read back from CSV
    assert summary.loc["held", "holds_setpoints"] == True  # noqa: E712
    assert summary.loc["overload", "setpoints"].startswith("set-points NOT held")
    (line,) = [ln for ln in r.stderr.splitlines() if ln.startswith("NOT HELD")]
    assert "overload.yaml (exit 0): set-points NOT held in [0.45, 0.5] s" in line
    assert sum(": note: profiles.T_load" in ln for ln in r.stderr.splitlines()) == 1


def test_holding_the_set_points_is_an_acceptance_bound_when_the_scenario_asks(tmp_path, fmu_dir):
    f = _loaded(tmp_path, "overload", 90.0, extra="acceptance: {holds_setpoints: true}\n")
    r = _cli("run", f, "--out", tmp_path / "out", "--fmus", fmu_dir, "--no-build", "--no-plot")
    assert r.returncode == 3, r.stderr
    assert "  accept holds_setpoints      False: FAIL" in r.stdout.splitlines()
    m = json.loads((tmp_path / "out" / "overload" / "metrics.json").read_text())
    assert m["accepted"] is False and m["acceptance"] == {"holds_setpoints": {"limit": True, "value": False,
                                                                              "pass": False}}


def test_batch_names_the_variants_of_a_sweep_that_do_not_hold(tmp_path, fmu_dir):
    sweep = "sweep:\n  parameters:\n    profiles.T_load.value: [20.0, 90.0]\n"
    f = _loaded(tmp_path, "loads", 20.0, extra=sweep)
    r = _cli("batch", f, "--out", tmp_path / "out", "--fmus", fmu_dir, "--jobs", 1, "--variant", "native",
             "--no-plot")
    assert r.returncode == 0, r.stderr
    (line,) = [ln for ln in r.stderr.splitlines() if ln.startswith("NOT HELD")]
    said = f"NOT HELD {f} variant loads-1 (profiles.T_load.value = 90.0) (exit 0): set-points NOT held"
    assert line.startswith(said), line


def test_a_plant_only_motor_parameter_is_said_by_validate_and_run(tmp_path, fmu_dir):
    f = _scenario(tmp_path, "bigger", stop_time=0.05, extra="plant: {J: 0.05}\n")
    for args in (("validate", f, "--fmus", fmu_dir),
                 ("run", f, "--out", tmp_path / "out", "--fmus", fmu_dir, "--no-build", "--no-plot")):
        r = _cli(*args)
        assert r.returncode == 0, r.stderr
        (note,) = [ln for ln in r.stderr.splitlines() if ": note: " in ln]
        assert note.startswith(f"{f}: note: plant.J: plant 0.05 kg m2, controller 0.0131 kg m2 (default)")
    f.write_text(f.read_text() + "mismatch: true\n")
    r = _cli("validate", f, "--fmus", fmu_dir)
    assert r.returncode == 0 and ": note: " not in r.stderr


# --- failures explained -----------------------------------------------------------------------------------

def test_a_plant_failure_names_the_plant_and_quotes_its_message(tmp_path, fmu_dir):
    # J so small that the mechanical mode is unstable under RK4 at h = 100 us: the plant's state
    # becomes non-finite after the speed step; the reason is the plant's, not the controller's
    f = _scenario(tmp_path, "stiff", extra="plant: {J: 1.0e-7}\n")
    r = _cli("run", f, "--out", tmp_path / "out", "--fmus", fmu_dir, "--no-build", "--no-plot")
    assert r.returncode == 1
    m = json.loads((tmp_path / "out" / "stiff" / "metrics.json").read_text())
    assert m["status"] == "discard" and m["failed_unit"] == "plant"
    assert "SaturatedInductionMotor at t = " in m["message"] and "non-finite" in m["message"]
    assert m["message"] in r.stdout
    assert 0.15 < m["t_end"] < 0.3 and m["rows"] == round(m["t_end"] / 1e-4) + 1  # rows up to t_end


# --- outputs ------------------------------------------------------------------------------------------------

def test_an_unwritable_out_is_found_before_the_run(tmp_path, fmu_dir):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a directory")
    f = _scenario(tmp_path, "ok")
    t0 = time.monotonic()
    r = _cli("run", f, "--out", blocker / "sub", "--fmus", fmu_dir, "--no-build")
    assert r.returncode == 2 and "--out" in r.stderr and str(blocker / "sub") in r.stderr
    assert "Traceback" not in r.stderr and time.monotonic() - t0 < 20


def test_a_rerun_clears_the_previous_results_and_leaves_no_extracted_fmu(tmp_path, fmu_dir):
    f = _scenario(tmp_path, "again", stop_time=0.05)
    d = tmp_path / "out" / "again"
    d.mkdir(parents=True)
    (d / "figure.png").write_bytes(b"old figure")
    (d / "timeseries.parquet").write_bytes(b"old")
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    r = _cli("run", f, "--out", tmp_path / "out", "--fmus", fmu_dir, "--no-build", "--no-plot",
             env={**os.environ, "TMPDIR": str(tmp)})
    assert r.returncode == 0, r.stderr
    assert not (d / "figure.png").exists()  # --no-plot: the old figure must not pass for this run's
    assert len(pd.read_parquet(d / "timeseries.parquet")) == 501
    assert list(tmp.iterdir()) == []  # the two extracted FMUs were removed


# --- interrupts ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("sig,code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_run_stops_on_a_signal_and_writes_what_it_has(sig, code, tmp_path, fmu_dir):
    f = _scenario(tmp_path, "long", stop_time=30.0)
    out = tmp_path / "out"
    p = _start("run", f, "--out", out, "--fmus", fmu_dir, "--no-build", "--no-plot")
    _wait_running(out / "long" / "metrics.json", p)
    p.send_signal(sig)
    stdout, stderr = p.communicate(timeout=60)
    assert p.returncode == code, stderr
    m = json.loads((out / "long" / "metrics.json").read_text())
    assert m["status"] == "interrupted" and signal.Signals(sig).name in m["message"]
    assert "Traceback" not in stderr and "fatal" not in stdout
    csv = pd.read_csv(out / "long" / "timeseries.csv")
    assert len(csv) == m["rows"] > 100 and csv["time"].iloc[-1] <= m["t_end"] < 30.0
    assert len(pd.read_parquet(out / "long" / "timeseries.parquet")) == m["rows"]


def _batch_dir(tmp_path, n_long=3):
    d = tmp_path / "scenarios"
    d.mkdir()
    _scenario(d, "quick", stop_time=0.05)
    for i in range(n_long):
        _scenario(d, f"long{i}", stop_time=30.0)
    return d


def _descendants(pid):
    """Every process below ``pid`` (the warm children, their forkserver, multiprocessing's resource
    tracker, figure helpers): each must be gone when the command is."""
    import psutil

    return psutil.Process(pid).children(recursive=True)


def _alive(procs):
    import psutil

    out = []
    for p in procs:
        try:
            if p.is_running() and p.status() != psutil.STATUS_ZOMBIE:
                out.append(p)
        except psutil.NoSuchProcess:
            pass
    return out


def _wait_children(marker, n, timeout=120.0):
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        if len([p for p in _processes(marker) if " run " in p]) >= n:
            time.sleep(1.5)
            return
        time.sleep(0.1)
    raise AssertionError(f"fewer than {n} children running: {_processes(marker)}")


@pytest.mark.parametrize("sig,code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_batch_stops_on_a_signal_summarizes_everything_and_leaves_no_process(sig, code, tmp_path, fmu_dir):
    d, out = _batch_dir(tmp_path), tmp_path / "out"
    p = _start("batch", d, "--jobs", 2, "--out", out, "--fmus", fmu_dir, start_new_session=True)
    _wait_children(d, 2)
    _wait_running(out / "long0" / "metrics.json", p)  # a loaded machine: rows before the signal
    below = _descendants(p.pid)
    if sig == signal.SIGINT:
        os.killpg(p.pid, sig)  # Ctrl-C in a terminal: the whole foreground process group
    else:
        p.send_signal(sig)  # SIGTERM to the batch parent only
    stdout, stderr = p.communicate(timeout=120)
    assert p.returncode == code, stderr
    assert "Traceback" not in stderr
    assert _processes(d) == []
    assert len(below) >= 2 and _alive(below) == []  # nor a forkserver, nor any other helper
    summary = pd.read_csv(out / "summary.csv")
    status = dict(zip(summary["scenario"], summary["status"]))
    assert set(status) == {"quick", "long0", "long1", "long2"}
    assert [status[f"long{i}"] for i in range(3)] == ["interrupted"] * 3
    stopped = [json.loads((out / f"long{i}" / "metrics.json").read_text()) for i in range(2)
               if (out / f"long{i}" / "metrics.json").exists()]
    assert any(m["status"] == "interrupted" and m["rows"] > 0 for m in stopped)  # partial results kept


def test_a_killed_batch_leaves_no_child_behind(tmp_path, fmu_dir):
    d, out = _batch_dir(tmp_path, n_long=2), tmp_path / "out"
    tmp = tmp_path / "tmp"  # a killed batch cannot remove its temporary directory: keep it here
    tmp.mkdir()
    p = _start("batch", d, "--jobs", 2, "--out", out, "--fmus", fmu_dir, start_new_session=True,
               env={**os.environ, "TMPDIR": str(tmp)})
    _wait_children(d, 2)
    below = _descendants(p.pid)
    p.kill()
    p.communicate(timeout=60)
    t0 = time.monotonic()
    while (_processes(d) or _alive(below)) and time.monotonic() - t0 < 60:
        time.sleep(0.2)
    assert _processes(d) == []
    assert len(below) >= 2 and _alive(below) == []  # the forkserver went too


def test_a_child_killed_by_a_signal_is_a_failed_row_and_a_failed_batch(tmp_path, fmu_dir):
    d, out = _batch_dir(tmp_path, n_long=1), tmp_path / "out"
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    p = _start("batch", d, "--jobs", 2, "--out", out, "--fmus", fmu_dir,
               env={**os.environ, "TMPDIR": str(tmp)})
    _wait_children(d / "long0.yaml", 1)
    pid = int(next(ln for ln in _processes(d / "long0.yaml") if " run " in ln).split()[0])
    os.kill(pid, signal.SIGKILL)
    stdout, stderr = p.communicate(timeout=120)
    assert p.returncode == 128 + signal.SIGKILL
    row = pd.read_csv(out / "summary.csv").set_index("scenario").loc["long0"]
    assert row["status"] == "failed" and "SIGKILL" in row["message"]
    assert list(tmp.iterdir()) == []  # the killed child's extracted FMUs went with the batch's directory


# --- batch correctness -------------------------------------------------------------------------------------

def test_duplicate_names_refuse_the_batch_before_anything_runs(tmp_path, fmu_dir):
    d = tmp_path / "scenarios"
    d.mkdir()
    _scenario(d, "twin", stop_time=0.05)
    (d / "twin_copy.yaml").write_text((d / "twin.yaml").read_text())
    r = _cli("batch", d, "--out", tmp_path / "out", "--fmus", fmu_dir)
    assert r.returncode == 2 and "'twin'" in r.stderr and "twin_copy.yaml" in r.stderr
    assert not (tmp_path / "out" / "twin").exists()


def test_files_that_cannot_load_are_rows_and_the_others_run(tmp_path, fmu_dir):
    d = tmp_path / "scenarios"
    d.mkdir()
    _scenario(d, "good", stop_time=0.05)
    (d / "semicolon.csv").write_text("t;T\n0;0\n0.02;5\n")  # ';' separators are read
    _scenario(d, "semi", stop_time=0.05, extra="  T_load: {type: csv, file: semicolon.csv}\n")
    (d / "one_column.csv").write_text("t\n0\n0.02\n")  # a column is missing: a problem, not an IndexError
    _scenario(d, "short_rows", stop_time=0.05, extra="  T_load: {type: csv, file: one_column.csv}\n")
    (d / "binary.yaml").write_bytes(b"\xff\xfe\x00garbage")
    (d / "not_a_mapping.yaml").write_text("- 1\n- 2\n")
    r = _cli("batch", d, "--out", tmp_path / "out", "--fmus", fmu_dir)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    summary = pd.read_csv(tmp_path / "out" / "summary.csv").set_index("file")
    status = {Path(k).stem: v for k, v in summary["status"].items()}
    assert status == {"good": "ok", "semi": "ok", "short_rows": "invalid", "binary": "invalid",
                      "not_a_mapping": "invalid"}
    msg = {Path(k).stem: v for k, v in summary["message"].items()}
    assert "1 column(s)" in msg["short_rows"] and "cannot read" in msg["binary"]


def test_a_dask_batch_stops_its_children_on_sigterm(tmp_path, fmu_dir):
    from distributed import LocalCluster

    d, out = _batch_dir(tmp_path, n_long=2), tmp_path / "out"
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        p = _start("batch", d, "--scheduler", cluster.scheduler_address, "--out", out, "--fmus", fmu_dir)
        _wait_children(d, 2)
        p.send_signal(signal.SIGTERM)
        stdout, stderr = p.communicate(timeout=120)
        assert p.returncode == 143, stderr
        assert _processes(d) == []  # the children on the workers were stopped, not left running
    status = dict(pd.read_csv(out / "summary.csv")[["scenario", "status"]].itertuples(index=False))
    assert status["long0"] == status["long1"] == "interrupted"


def test_a_reader_that_goes_away_ends_the_command_quietly():
    """``satmotor-cosim validate ... | head -1``: the reader closes the pipe while the command still
    prints; the command ends with 141 (128 + SIGPIPE, as a shell reports it), no traceback."""
    files = sorted(str(f) for f in Path("scenarios").glob("*.yaml")) * 60  # > a pipe buffer of lines
    p = subprocess.Popen([sys.executable, "-m", "orchestration", "validate", *files], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE)
    p.stdout.readline()
    p.stdout.close()
    stderr = p.stderr.read().decode()
    assert p.wait(timeout=120) == 141, stderr
    assert "Traceback" not in stderr and "BrokenPipe" not in stderr


def test_a_batch_runs_where_tmpdir_is_too_deep_for_a_unix_socket(tmp_path, fmu_dir):
    """multiprocessing's forkserver (the warm children) listens on a Unix socket in TMPDIR, whose path
    may hold 107 bytes: below a deeper TMPDIR the batch runs its scenarios in fresh interpreters
    (before: every row 'failed: cannot start the child process: AF_UNIX path too long')."""
    d = tmp_path / "scenarios"
    d.mkdir()
    _scenario(d, "quick", stop_time=0.05)
    deep = tmp_path / ("t" * 60) / ("u" * 60)
    deep.mkdir(parents=True)
    out = tmp_path / "out"
    r = subprocess.run([sys.executable, "-m", "orchestration", "batch", str(d), "--out", str(out), "--fmus",
                        str(fmu_dir)], capture_output=True, text=True, timeout=600,
                       env={**os.environ, "TMPDIR": str(deep)})
    assert r.returncode == 0, r.stderr
    summary = pd.read_csv(out / "summary.csv")
    assert list(summary["status"]) == ["ok"]
