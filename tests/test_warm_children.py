"""batch's warm children (orchestration.cli.warm_children): the same files and rows as a fresh
``python -m orchestration run`` process, the child's own error in its row, a crash as a failed row,
and no forkserver left once the batch is done."""

from __future__ import annotations

import json
import signal
import time
from pathlib import Path

import psutil
import pytest

from orchestration.cli import main, warm_children
from orchestration.cli.batch import run_one

pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(not warm_children.available(), reason="no forkserver on this system")]
FILES = ("timeseries.csv", "timeseries.parquet", "figure.png")


def _scenario(d, name, stop_time=0.2, extra=""):
    f = Path(d) / f"{name}.yaml"
    f.write_text(f"name: {name}\nstop_time: {stop_time}\nprofiles:\n"
                 "  psi_ref: {type: constant, value: 0.9}\n"
                 "  omega_ref: {type: step, time: 0.1, value: 50.0}\n" + extra)
    return f


@pytest.fixture
def tmp(tmp_path):
    d = tmp_path / "tmp"
    d.mkdir()
    yield d
    warm_children.stop_server()


def _forkservers():
    return [p for p in psutil.Process().children() if "forkserver" in " ".join(p.cmdline())]


def test_a_warm_child_writes_what_a_fresh_process_writes(tmp_path, tmp, fmu_dir):
    f = _scenario(tmp_path, "twin")
    warm = run_one(f, tmp_path / "warm", fmu_dir, tmpdir=tmp, warm=main)
    assert _forkservers()  # the warm server ran it
    fresh = run_one(f, tmp_path / "fresh", fmu_dir, tmpdir=tmp, warm=None)
    assert warm.pop("wall_time") > 0 and fresh.pop("wall_time") > 0
    assert warm["status"] == "ok" and warm["exit_code"] == 0
    assert {k: v for k, v in warm.items() if k != "file"} == {k: v for k, v in fresh.items() if k != "file"}
    for name in FILES:
        w, fr = (tmp_path / d / "twin" / name for d in ("warm", "fresh"))
        assert w.read_bytes() == fr.read_bytes(), name
    mw, mf = (json.loads((tmp_path / d / "twin" / "metrics.json").read_text()) for d in ("warm", "fresh"))
    mw.pop("wall_time"), mf.pop("wall_time")
    assert mw == mf
    assert list(tmp.iterdir()) == []  # extracted FMUs and the child's output files removed
    warm_children.stop_server()
    assert _forkservers() == []


def test_a_child_that_refuses_its_scenario_gives_its_own_message(tmp_path, tmp, fmu_dir):
    f = _scenario(tmp_path, "bad", extra="plant: {no_such_parameter: 1.0}\n")
    row = run_one(f, tmp_path / "out", fmu_dir, tmpdir=tmp, warm=main)
    assert row["status"] == "invalid" and row["exit_code"] == 2
    assert "plant.no_such_parameter = 1.0: unknown plant variable" in row["message"]  # the child's stderr


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGSEGV])
def test_a_crashed_warm_child_is_a_failed_row(tmp_path, tmp, fmu_dir, sig):
    f = _scenario(tmp_path, "crash", stop_time=30.0)
    out = tmp_path / "out"
    polls = []

    def crash_once_running():  # run_one's stop poll, used here to crash the child mid-run
        metrics = out / "crash" / "metrics.json"
        if not polls and metrics.exists() and '"running"' in metrics.read_text():
            time.sleep(0.5)
            child = [p for p in psutil.Process().children(recursive=True) if " run " in " ".join(p.cmdline())]
            assert len(child) == 1
            child[0].send_signal(sig)
            polls.append(child[0].pid)
        return False

    row = run_one(f, out, fmu_dir, tmpdir=tmp, warm=main, should_stop=crash_once_running)
    assert polls and row["status"] == "failed" and row["exit_code"] == 128 + sig
    assert signal.Signals(sig).name in row["message"]
