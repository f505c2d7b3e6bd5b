"""The ``run`` command's figure helper (orchestration.results.figure_process): the same files as the plain
path, a figure even when the helper dies, and no process left after Ctrl-C or a killed run."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest

from orchestration.results.atomic import being_written

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[1]
PNG = b"\x89PNG\r\n\x1a\n"

# the run command in a child process, saying whether the helper drew the figure; "plain" starts a
# thread first, so that no helper is forked (figure_process.wanted)
RUN = r"""
import sys, threading, time
if sys.argv[1] == "plain":
    threading.Thread(target=time.sleep, args=(600,), daemon=True).start()
from orchestration.results import figure_process as fp
used = []
draw = fp.FigureProcess.draw
def spy(self, *a):
    draw(self, *a)
    used.append(self.drawn_by_helper)
fp.FigureProcess.draw = spy
from orchestration.cli.commands import main
code = main(sys.argv[2:])
print("HELPER", used)
sys.exit(code)
"""


def _scenario(d, name, stop_time):
    f = Path(d) / f"{name}.yaml"
    f.write_text(f"name: {name}\ndescription: helper test\nstop_time: {stop_time}\nprofiles:\n"
                 "  psi_ref: {type: constant, value: 0.9}\n"
                 "  omega_ref: {type: step, time: 0.1, value: 50.0}\n")
    return f


def _run(mode, f, out, fmu_dir):
    args = ["run", str(f), "--out", str(out), "--fmus", str(fmu_dir), "--no-build"]
    r = subprocess.run([sys.executable, "-c", RUN, mode, *args], capture_output=True, text=True, timeout=600,
                       cwd=ROOT)
    assert r.returncode == 0, r.stderr
    return r.stdout


def test_the_helpers_files_equal_the_plain_paths(tmp_path, fmu_dir):
    f = _scenario(tmp_path, "same", 0.3)
    assert "HELPER [True]" in _run("helper", f, tmp_path / "a", fmu_dir)
    assert "HELPER []" in _run("plain", f, tmp_path / "b", fmu_dir)  # drawn by plots.figure in the process
    a, b = tmp_path / "a" / "same", tmp_path / "b" / "same"
    for name in ("figure.png", "timeseries.csv", "timeseries.parquet"):
        assert (a / name).read_bytes() == (b / name).read_bytes(), name
    assert (a / "figure.png").read_bytes().startswith(PNG)
    ma, mb = (json.loads((d / "metrics.json").read_text()) for d in (a, b))
    ma.pop("wall_time"), mb.pop("wall_time")
    assert ma == mb and ma["rows"] == 3001


def _start(f, out, fmu_dir, *extra):
    args = ["run", str(f), "--out", str(out), "--fmus", str(fmu_dir), "--no-build", *extra]
    return subprocess.Popen([sys.executable, "-m", "orchestration", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=ROOT, start_new_session=True)


def _lines(path):
    """Lines begun in the first 64 kB of ``path``."""
    with open(path, "rb") as fh:
        return fh.read(65536).count(b"\n")


def _helper_when_running(p, metrics, rows=False, timeout=300.0):
    """The helper process of the run ``p`` once the run is on its way: its directory prepared
    (metrics.json says ``running``) and the helper forked; with ``rows``, once the first chunk of rows
    is in timeseries.csv too (the run is stepping and a figure can be drawn of what it has: a run
    stopped before its second row writes none).  The states, not a time: under load, loading the FMUs
    alone can take seconds."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        assert p.poll() is None, p.communicate()
        csv = being_written(metrics.parent, "timeseries.csv")  # streamed under its temporary name
        kids = psutil.Process(p.pid).children(recursive=True)
        if kids and metrics.exists() and '"running"' in metrics.read_text():
            if not rows or (csv.exists() and _lines(csv) > 1):  # a data line below the header
                assert len(kids) == 1
                return kids[0]
        time.sleep(0.05)
    raise AssertionError("the run never started, or started no helper" + (", or recorded no rows" * rows))


def _gone(proc, timeout=30.0):
    try:
        proc.wait(timeout)
    except psutil.TimeoutExpired:
        return False
    return True


def test_a_run_whose_helper_dies_still_writes_its_figure(tmp_path, fmu_dir):
    f, out = _scenario(tmp_path, "orphan", 4.0), tmp_path / "out"
    p = _start(f, out, fmu_dir)
    helper = _helper_when_running(p, out / "orphan" / "metrics.json")
    helper.kill()
    stdout, stderr = p.communicate(timeout=300)
    assert p.returncode == 0 and "Traceback" not in stderr, stderr
    png = (out / "orphan" / "figure.png").read_bytes()
    import pyarrow.parquet as pq

    from orchestration.results.plots import figure

    data = pq.read_table(out / "orphan" / "timeseries.parquet").to_pydict()
    figure(data, tmp_path / "plain.png", "orphan: helper test")
    assert png.startswith(PNG) and png == (tmp_path / "plain.png").read_bytes()


def test_ctrl_c_writes_the_partial_figure_and_leaves_no_helper(tmp_path, fmu_dir):
    f, out = _scenario(tmp_path, "long", 30.0), tmp_path / "out"
    p = _start(f, out, fmu_dir)
    helper = _helper_when_running(p, out / "long" / "metrics.json", rows=True)
    os.killpg(p.pid, signal.SIGINT)  # Ctrl-C in a terminal: the whole process group, the helper too
    stdout, stderr = p.communicate(timeout=300)
    assert p.returncode == 130, stderr
    assert json.loads((out / "long" / "metrics.json").read_text())["status"] == "interrupted"
    assert (out / "long" / "figure.png").read_bytes().startswith(PNG)
    assert _gone(helper, 0)


def test_a_killed_run_leaves_no_helper(tmp_path, fmu_dir):
    f, out = _scenario(tmp_path, "killed", 30.0), tmp_path / "out"
    p = _start(f, out, fmu_dir)
    helper = _helper_when_running(p, out / "killed" / "metrics.json")
    p.kill()
    p.communicate(timeout=60)
    assert _gone(helper)  # SIGKILL from Linux when its parent died
    assert not (out / "killed" / "figure.png").exists()
