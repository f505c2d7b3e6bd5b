"""batch on sweep files: one table and one figure per sweep, a variant equal to the scenario written out
by hand, the variants run several to a child process (native FMUs) and a row per variant whatever
happens to that child: killed, interrupted (Ctrl-C, SIGTERM), or finished."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from orchestration.cli.batch import Job, grouped

ROOT = Path(__file__).resolve().parents[1]


def _cli(*args, **kw):
    return subprocess.run([sys.executable, "-m", "orchestration", *map(str, args)], capture_output=True,
                          text=True, timeout=900, cwd=ROOT, **kw)


def test_variants_are_grouped_for_native_fmus_only():
    f = Path("s.yaml")
    jobs = [Job(Path("plain.yaml"), ("plain",))] + [Job(f, (f"s-{i}",), (i,), "s") for i in range(10)]
    native = grouped(jobs, 2, "native")
    assert native[0] == jobs[0]
    assert [j.indexes for j in native[1:]] == [(0, 1), (2, 3), (4, 5), (6, 7), (8, 9)]  # ceil(10 / 8) each
    assert [j.names for j in native[1:]][0] == ("s-0", "s-1") and {j.group for j in native[1:]} == {"s"}
    assert grouped(jobs, 2, "python") == jobs  # a pythonfmu FMU: a process per run
    many = grouped([Job(f, (f"s-{i}",), (i,), "s") for i in range(200)], 1, "native")
    assert max(len(j.indexes) for j in many) == 16 and sum(len(j.indexes) for j in many) == 200


def test_a_sweep_writes_one_table_and_one_figure_and_a_variant_is_its_scenario(tmp_path, fmu_dir):
    out = tmp_path / "out"
    r = _cli("batch", ROOT / "scenarios" / "sweep_inertia.yaml", "--out", out, "--fmus", fmu_dir,
             "--variant", "native")
    assert r.returncode == 0, r.stderr
    d = out / "sweep_inertia"
    table = pd.read_csv(d / "sweep.csv")
    assert list(table.columns[:8]) == ["variant", "index", "motor.J", "controller.d1", "status", "exit_code",
                                       "accepted", "holds_setpoints"]
    assert list(table.columns[-2:]) == ["wall_time", "message"]
    assert table["variant"].tolist() == [f"sweep_inertia-{i}" for i in range(6)]
    assert table["motor.J"].tolist() == [0.0131, 0.0131, 0.0262, 0.0262, 0.0524, 0.0524]
    assert table["controller.d1"].tolist() == [50.0, 100.0] * 3
    assert (table["status"] == "ok").all()
    metrics = json.loads((d / "sweep_inertia-3" / "metrics.json").read_text())["metrics"]
    assert set(metrics) < set(table.columns) and len(metrics) >= 11
    row = table.set_index("variant").loc["sweep_inertia-3"]
    assert all(row[k] == v or (math.isnan(v) and math.isnan(row[k])) for k, v in metrics.items())
    parquet = pd.read_parquet(d / "sweep.parquet")
    same = ["variant", "index", "motor.J", "controller.d1", "status", "exit_code", "holds_setpoints",
            *metrics]
    assert parquet[same].equals(table[same]) and list(parquet.columns) == list(table.columns)
    assert (d / "sweep.png").stat().st_size > 10_000
    assert sorted(p.name for p in (d / "sweep_inertia-0").iterdir()) == ["metrics.json"]  # record: metrics
    assert len(pd.read_csv(out / "summary.csv")) == 6
    # variant 3 (J = 0.0262, d1 = 100) is the scenario written out by hand, run on its own
    text = (ROOT / "scenarios" / "sweep_inertia.yaml").read_text().split("sweep:")[0]
    hand = tmp_path / "hand.yaml"
    hand.write_text(text.replace("name: sweep_inertia", "name: hand")
                    + "motor: {J: 0.0262}\ncontroller: {d1: 100.0}\nrecord: metrics\n")
    r = _cli("run", hand, "--out", tmp_path / "hand", "--fmus", fmu_dir, "--variant", "native")
    assert r.returncode == 0, r.stderr
    assert json.loads((tmp_path / "hand" / "hand" / "metrics.json").read_text())["metrics"] == metrics


def test_a_monte_carlo_sweep_without_figures(tmp_path, fmu_dir):
    out = tmp_path / "out"
    r = _cli("batch", ROOT / "scenarios" / "montecarlo_rr.yaml", "--out", out, "--fmus", fmu_dir,
             "--variant", "native", "--no-plot")
    assert r.returncode == 0, r.stderr
    table = pd.read_csv(out / "montecarlo_rr" / "sweep.csv")
    assert len(table) == 8 and (table["status"] == "ok").all()
    assert table["plant.R_r"].between(1.6 * 0.85, 1.6 * 1.15).all() and table["plant.R_r"].nunique() == 8
    assert not (out / "montecarlo_rr" / "sweep.png").exists()
    assert table["iae_speed"].nunique() == 8  # each draw ran with its own resistance


def test_a_sweep_on_the_fmi3_fmus_is_the_sweep_on_the_fmi2_ones(tmp_path, fmu_dir):
    # the overrides are checked against the FMI 3.0 model descriptions too (Float64, not Real)
    tables = {}
    for variant in ("native", "native-fmi3"):
        r = _cli("batch", ROOT / "scenarios" / "montecarlo_rr.yaml", "--out", tmp_path / variant, "--fmus",
                 fmu_dir, "--variant", variant, "--no-plot")
        assert r.returncode == 0, r.stdout + r.stderr
        tables[variant] = pd.read_csv(tmp_path / variant / "montecarlo_rr" / "sweep.csv")
    a, b = tables["native"], tables["native-fmi3"]
    assert (b["status"] == "ok").all() and len(b) == 8
    assert a.drop(columns=["wall_time"]).equals(b.drop(columns=["wall_time"]))


def test_a_variant_its_child_never_ran_says_how_the_child_ended(tmp_path):
    from orchestration.cli.batch import _variant_row

    message = "s.yaml: plant.R_r = -1.0: must be a finite number > 0"  # of an earlier variant of the child
    row = _variant_row(tmp_path / "s.yaml", "s-3", 2, "", f"s.yaml: 1 problem(s):\n  {message}\n",
                       tmp_path / "s-3" / "metrics.json", False)
    assert row["status"] == "failed" and row["exit_code"] == 2 and message in row["message"]
    assert row["message"].startswith("not run: the child process ended (exit 2) before this variant")
    row = _variant_row(tmp_path / "s.yaml", "s-4", 1, "", "Traceback ...\nMemoryError\n",
                       tmp_path / "s-4" / "metrics.json", False)
    assert row["status"] == "failed" and "MemoryError" in row["message"]


def test_the_table_says_why_a_variant_has_no_metrics(tmp_path):
    from orchestration.results.sweep_table import write_sweep
    from orchestration.scenario.sweep import expand

    sweep, _ = expand({"name": "s", "stop_time": 0.1,
                       "profiles": {"psi_ref": {"type": "constant", "value": 0.9}},
                       "sweep": {"parameters": {"motor.J": [0.01, 0.02, 0.03]}}}, "s.yaml")
    (tmp_path / "s-0").mkdir()
    (tmp_path / "s-0" / "metrics.json").write_text(json.dumps({"status": "ok",
                                                               "metrics": {"iae_speed": 0.5}}))
    (tmp_path / "s-1").mkdir()
    (tmp_path / "s-1" / "metrics.json").write_text(json.dumps({"status": "running"}))  # a killed run's
    rows = [{"file": "s.yaml", "scenario": "s-0", "status": "ok", "exit_code": 0, "message": ""},
            {"file": "s.yaml", "scenario": "s-1", "status": "failed", "exit_code": 137,
             "message": "the child process was killed by SIGKILL"}]
    paths = write_sweep(sweep, rows, tmp_path, plot=False, file="s.yaml")
    assert [p.name for p in paths] == ["sweep.csv", "sweep.parquet"]
    t = pd.read_csv(tmp_path / "sweep.csv").set_index("variant")
    assert t.loc["s-0", "iae_speed"] == 0.5 and t.loc["s-0", "status"] == "ok"
    assert t.loc["s-1", "status"] == "failed" and "SIGKILL" in t.loc["s-1", "message"]
    assert math.isnan(t.loc["s-1", "iae_speed"])
    assert t.loc["s-2", "status"] == "interrupted" and "interrupted" in t.loc["s-2", "message"]
    assert list(pd.read_parquet(tmp_path / "sweep.parquet")["motor.J"]) == [0.01, 0.02, 0.03]



def test_a_sweep_table_that_cannot_be_written_leaves_nothing_half_written(tmp_path, monkeypatch):
    """A disk that fills while the Parquet table is written: the CSV is whole, no sweep.parquet and no
    temporary file are left (orchestration.results.atomic), the error goes on to the batch."""
    import errno

    import pandas

    from orchestration.results.sweep_table import write_sweep
    from orchestration.scenario.sweep import expand

    sweep, _ = expand({"name": "s", "stop_time": 0.1,
                       "profiles": {"psi_ref": {"type": "constant", "value": 0.9}},
                       "sweep": {"parameters": {"motor.J": [0.01, 0.02]}}}, "s.yaml")
    rows = [{"file": "s.yaml", "scenario": f"s-{i}", "status": "failed", "exit_code": 1, "message": "x"}
            for i in range(2)]

    def full(self, f, *args, **kwargs):
        f.write(b"PAR1")  # a first block, then the disk is full
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(pandas.DataFrame, "to_parquet", full)
    with pytest.raises(OSError, match="No space left"):
        write_sweep(sweep, rows, tmp_path, plot=False, file="s.yaml")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sweep.csv"]
    assert len(pd.read_csv(tmp_path / "sweep.csv")) == 2

# --- robustness: a killed child, an interrupted batch ------------------------------------------------

def _ps(marker):
    out = subprocess.run(["ps", "-ww", "-eo", "pid,stat,args"], capture_output=True, text=True).stdout
    rows = [line.split(None, 2) for line in out.splitlines()[1:]]
    return [(int(r[0]), r[2]) for r in rows if len(r) == 3 and marker in r[2] and not r[1].startswith("Z")]


def _status(path):
    try:
        return json.loads(path.read_text()).get("status")
    except (OSError, ValueError):
        return None


def _until(condition, proc, what, timeout=300.0):
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        assert proc.poll() is None, proc.communicate()
        if condition():
            return
        time.sleep(0.05)
    raise AssertionError(f"never: {what}")


@pytest.mark.slow
@pytest.mark.parametrize("sig,code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_killed_child_and_an_interrupt_leave_a_row_per_variant(sig, code, tmp_path, fmu_dir):
    """Five variants, one process, two to a child: variant 0 finishes, variant 1's child is killed
    while it runs (variant 1 failed, killed; the child's variants never run a separate row), then the
    batch is interrupted while the next child runs: every variant is a row of the table."""
    f = tmp_path / "long.yaml"
    # 40 s (400 000 steps, over a second a variant on the compiled engine) at record: metrics: each
    # variant runs long enough to be caught running
    f.write_text("name: long\nstop_time: 40.0\nrecord: metrics\n"
                 "profiles:\n  psi_ref: {type: constant, value: 0.9}\n"
                 "  omega_ref: {type: step, time: 0.15, value: 50.0}\n"
                 "sweep:\n  parameters:\n    motor.J: [0.010, 0.011, 0.012, 0.013, 0.014]\n")
    out = tmp_path / "out"
    p = subprocess.Popen([sys.executable, "-m", "orchestration", "batch", str(f), "--jobs", "1", "--out",
                          str(out), "--fmus", str(fmu_dir), "--variant", "native"], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, start_new_session=True)
    d = out / "long"
    _until(lambda: _status(d / "long-0" / "metrics.json") == "ok"
           and _status(d / "long-1" / "metrics.json") == "running", p, "variant 1 running after variant 0")
    (pid, args), = _ps("--sweep-variant 0,1")
    os.kill(pid, signal.SIGKILL)
    _until(lambda: _status(d / "long-2" / "metrics.json") == "running", p, "the next child running")
    if sig == signal.SIGINT:
        os.killpg(p.pid, sig)  # Ctrl-C: the whole foreground process group
    else:
        p.send_signal(sig)
    stdout, stderr = p.communicate(timeout=300)
    assert p.returncode == code, stderr
    assert "Traceback" not in stderr and _ps(str(f)) == []
    t = pd.read_csv(d / "sweep.csv").set_index("variant")
    assert t["status"].to_dict() == {"long-0": "ok", "long-1": "failed", "long-2": "interrupted",
                                     "long-3": "interrupted", "long-4": "interrupted"}
    assert "SIGKILL" in t.loc["long-1", "message"] and t.loc["long-1", "exit_code"] == 128 + signal.SIGKILL
    assert not math.isnan(t.loc["long-0", "iae_speed"]) and math.isnan(t.loc["long-2", "iae_speed"])
    assert _status(d / "long-2" / "metrics.json") == "interrupted"  # it wrote what it had
    summary = pd.read_csv(out / "summary.csv")
    assert sorted(summary["scenario"]) == [f"long-{i}" for i in range(5)]


def test_a_sweep_on_a_dask_local_cluster(tmp_path, fmu_dir):
    from distributed import LocalCluster

    f = tmp_path / "d.yaml"
    f.write_text("name: d\nstop_time: 0.3\nprofiles:\n  psi_ref: {type: constant, value: 0.9}\n"
                 "  omega_ref: {type: step, time: 0.15, value: 50.0}\n"
                 "sweep:\n  samples: 3\n  seed: 5\n  parameters:\n    motor.J: {uniform: [0.01, 0.02]}\n")
    out = tmp_path / "out"
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        r = _cli("batch", f, "--scheduler", cluster.scheduler_address, "--out", out, "--fmus", fmu_dir,
                 "--variant", "native", "--no-plot")
    assert r.returncode == 0, r.stderr
    t = pd.read_csv(out / "d" / "sweep.csv")
    assert t["variant"].tolist() == ["d-0", "d-1", "d-2"] and (t["status"] == "ok").all()
    assert t["motor.J"].between(0.01, 0.02).all() and t["iae_speed"].nunique() == 3


@pytest.mark.slow
@pytest.mark.parametrize("target", ["batch", "child", "group"])
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
def test_an_interrupted_run_is_reported_interrupted_naming_its_partial_results(sig, target, tmp_path,
                                                                              fmu_dir):
    """Issue 31: SIGTERM to the batch's process group once gave ``failed, 255, exit 255 without
    results`` while the run directory held valid partial results marked ``interrupted``.  Whether the
    signal reaches the batch, its child or the whole group, for SIGINT, SIGTERM and SIGHUP: the row is
    ``interrupted`` and names the run's results directory, whose metrics.json says ``interrupted``."""
    f = tmp_path / "long.yaml"
    f.write_text("name: long\nstop_time: 30.0\nprofiles:\n  psi_ref: {type: constant, value: 0.9}\n"
                 "  omega_ref: {type: step, time: 0.15, value: 50.0}\n")
    out = tmp_path / "out"
    p = subprocess.Popen([sys.executable, "-m", "orchestration", "batch", str(f), "--jobs", "1", "--out",
                          str(out), "--fmus", str(fmu_dir), "--variant", "native", "--no-plot"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    _until(lambda: _status(out / "long" / "metrics.json") == "running", p, "the run running")
    time.sleep(0.5)  # into the stepping loop
    if target == "group":
        os.killpg(p.pid, sig)
    elif target == "batch":
        p.send_signal(sig)
    else:
        (pid, _), = _ps(f"run {f}")
        os.kill(pid, sig)
    stdout, stderr = p.communicate(timeout=300)
    assert "Traceback" not in stderr and _ps(str(f)) == []
    assert p.returncode == 128 + sig, (p.returncode, stderr[-2000:])
    row = pd.read_csv(out / "summary.csv").set_index("scenario").loc["long"]
    assert row["status"] == "interrupted", (row.to_dict(), stderr[-2000:])
    assert str(out / "long") in row["message"] and "partial results" in row["message"], row["message"]
    assert _status(out / "long" / "metrics.json") == "interrupted"
