"""Result files after a full disk, a failed write, a SIGKILL of a run or of the batch (issue 23).

Whatever happens, every scenario's state on disk is either complete or says why it is not: no
``.part`` file left, no ``metrics.json`` left ``running`` by a process that is gone (or, after the
batch itself was killed, one that a reader can tell is gone), the time series as many rows as
``metrics.json`` says, a figure a whole PNG, ``summary.csv`` one whole table; no traceback.

The full disk is a real one where this machine lets us mount a 300 kB tmpfs (root), else those
tests are skipped; the same states are also reached with two fault injectors that work anywhere:
the per-file size limit ``RLIMIT_FSIZE`` of a child process (the kernel refuses every write past
it, ``EFBIG``) and, in this process, Python writes that raise ``ENOSPC`` once a byte budget is spent.
"""

from __future__ import annotations

import errno
import json
import os
import resource
import shutil
import signal
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pandas as pd
import pytest

from orchestration.results import atomic

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[1]
PNG_END = b"IEND\xaeB`\x82"  # the last chunk of a whole PNG
PROFILES = ("profiles:\n  psi_ref: {type: constant, value: 0.9}\n"
            "  omega_ref: {type: step, time: 0.1, value: 40.0}\n")


def _scenario(d, name, stop_time):
    f = d / f"{name}.yaml"
    f.write_text(f"name: {name}\nstop_time: {stop_time}\n{PROFILES}")
    return f


def _cli(*args, timeout=600, **kw):
    return subprocess.run([sys.executable, "-m", "orchestration", *map(str, args)], cwd=ROOT,
                          capture_output=True, text=True, timeout=timeout, **kw)


def _csv_rows(path):
    """Data lines of a CSV file, counted without pandas' parser (an independent reading)."""
    with open(path, "rb") as f:
        lines = f.read().splitlines()
    return len(lines) - 1


def check_scenario_dir(d, why="no space left on device", stale_ok=False):
    """The state of one results directory is complete or says why not; returns its metrics.json
    (None when the run could not even write that: then the batch's row must say why).  ``stale_ok``:
    a ``running`` status may stay when its writer is gone (a lone ``run`` that could not write its
    final status: nobody else is there to settle it)."""
    assert not list(d.glob(".*.part")), f"{d}: temporary files left: {list(d.glob('.*.part'))}"
    m = d / "metrics.json"
    if not m.exists():
        assert not any((d / n).exists() for n in ("timeseries.csv", "timeseries.parquet", "figure.png"))
        return None
    s = json.loads(m.read_text())  # parses: never a cut file
    if s["status"] == "running" and stale_ok:
        assert atomic.stale_reason(s) and str(s["pid"]) in atomic.stale_reason(s), s
        assert not any((d / n).exists() for n in ("timeseries.csv", "timeseries.parquet", "figure.png"))
        return s
    assert s["status"] != "running", s
    files = {n: (d / n).exists() for n in ("timeseries.csv", "timeseries.parquet", "figure.png")}
    if s["status"] == "failed" and why in s["message"]:
        if "the time series were not kept" in s["message"]:
            assert not files["timeseries.csv"] and not files["timeseries.parquet"], files
        if "no figure" in s["message"]:
            assert not files["figure.png"]
    if files["timeseries.csv"] or files["timeseries.parquet"]:  # then both, whole
        assert files["timeseries.csv"] and files["timeseries.parquet"], files
        import pyarrow.parquet as pq

        assert _csv_rows(d / "timeseries.csv") == pq.ParquetFile(d / "timeseries.parquet").metadata.num_rows \
            == s["rows"]
    if files["figure.png"]:
        assert (d / "figure.png").read_bytes().endswith(PNG_END)
    if s["status"] == "ok":
        assert files["timeseries.csv"] and s["rows"] > 0
    return s


def check_batch_out(out, names, stdout, stderr, why="no space left on device"):
    assert "Traceback" not in stdout + stderr, stderr
    text = (out / "summary.csv").read_text() if (out / "summary.csv").exists() else ""
    assert text or "could not be written" in stderr
    table = pd.read_csv(out / "summary.csv") if text else None
    if table is not None:
        assert sorted(table["scenario"]) == sorted(names)
    for name in names:
        s = check_scenario_dir(out / name, why)
        row = table[table["scenario"] == name].iloc[0] if table is not None else None
        if s is None and row is not None:
            assert why in row["message"], row.to_dict()
        if s is not None and row is not None:
            assert row["status"] == s["status"], (row.to_dict(), s)
    return table


# --- a real full disk: a 300 kB tmpfs -------------------------------------------------------------------

@pytest.fixture
def small_disk(tmp_path):
    d = tmp_path / f"disk-{uuid.uuid4().hex[:8]}"
    d.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=300k", "tmpfs", str(d)], capture_output=True,
                       text=True) if shutil.which("mount") else None
    if r is None or r.returncode != 0:
        pytest.skip("cannot mount a tmpfs here (not root, or no mount): the fault injectors cover it")
    try:
        yield d
    finally:
        subprocess.run(["umount", "-l", str(d)], capture_output=True)


@pytest.mark.parametrize("variant", ["native", "python"])
def test_batch_on_a_full_disk_leaves_each_scenario_complete_or_saying_why(tmp_path, small_disk, fmu_dir,
                                                                            variant):
    src = tmp_path / "scenarios"
    src.mkdir()
    names = {"tiny": 0.05, "mid": 0.4, "big": 1.5}
    for name, stop in names.items():
        _scenario(src, name, stop)
    out = small_disk / "out"
    r = _cli("batch", src, "--out", out, "--fmus", fmu_dir, "--variant", variant, "--jobs", 2)
    table = check_batch_out(out, names, r.stdout, r.stderr)
    failed = table[table["status"] == "failed"]
    assert len(failed) >= 1 and failed["message"].str.contains("no space left on device").all(), table
    assert r.returncode == 1, r.stderr


def test_a_full_disk_before_the_summary_refuses_the_batch_cleanly(tmp_path, small_disk, fmu_dir):
    (small_disk / "filler").write_bytes(b"\0" * (300 * 1024 - 4096 * 2))
    while True:  # fill the last pages too
        try:
            with open(small_disk / f"f{uuid.uuid4().hex}", "wb") as f:
                f.write(b"\0" * 4096)
        except OSError:
            break
    src = tmp_path / "scenarios"
    src.mkdir()
    _scenario(src, "tiny", 0.05)
    r = _cli("batch", src, "--out", small_disk / "out", "--fmus", fmu_dir)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    assert "no space left on device" in r.stderr


def _fill(d):
    """Fill the filesystem of ``d`` to the last byte (4 kB files, then single bytes); returns the bytes."""
    n = 0
    for size in (4096, 1):
        while True:
            try:
                with open(d / f"filler-{uuid.uuid4().hex}", "wb") as f:
                    f.write(b"\1" * size)
                n += size
            except OSError:
                break
    return n


def _sweep_file(d, name, count, stop_time, record="metrics"):
    f = d / f"{name}.yaml"
    f.write_text(f"name: {name}\nstop_time: {stop_time}\nrecord: {{level: {record}}}\n{PROFILES}"
                 f"sweep:\n  parameters:\n    motor.J: {{start: 0.01, stop: 0.05, num: {count}}}\n")
    return f


def _final_tables(out, name, count, stdout, stderr):
    """summary.csv and the sweep's table: whole, one row per variant, each with a final status; a failed
    one names the full disk.  Returns the summary table."""
    assert "Traceback" not in stdout + stderr, stderr
    table = pd.read_csv(out / "summary.csv")
    sweep = pd.read_csv(out / name / "sweep.csv")
    names = [f"{name}-{i:02d}" for i in range(count)]
    assert sorted(table["scenario"]) == names and sorted(sweep["variant"]) == names
    for t in (table, sweep):
        assert set(t["status"]) <= {"ok", "failed"}, t["status"].tolist()  # never running, never invalid
        failed = t[t["status"] == "failed"]
        assert failed["message"].str.contains("no space left on device").all(), failed["message"].tolist()
    assert dict(zip(table["scenario"], table["status"])) == dict(zip(sweep["variant"], sweep["status"]))
    return table


def test_a_sweep_that_fills_the_disk_names_the_cause_for_every_variant(tmp_path, small_disk, fmu_dir):
    """20 variants recording their time series (each 0.3 s: more than the 300 kB disk): the variants
    that met the full disk, early (its directory) or late (its metrics.json), are failed rows naming it
    in summary.csv and sweep.csv; none says ``running``, ``invalid`` or "the child process ended"
    (before: one variant invalid, its child's later variants "not run: the child process ended (exit 2)
    before this variant", the batch's exit code 2)."""
    f = _sweep_file(tmp_path, "full", 20, 0.3, record="full")
    out = small_disk / "out"
    r = _cli("batch", f, "--out", out, "--fmus", fmu_dir, "--variant", "native", "--no-plot", "--jobs", 2)
    table = _final_tables(out, "full", 20, r.stdout, r.stderr)
    assert (table["status"] == "failed").sum() >= 10 and not table["message"].str.contains("child").any()
    assert r.returncode == 1, r.stderr
    assert not (out / ".satmotor-reserve").exists()


def test_a_disk_filled_by_another_writer_during_a_sweep_leaves_whole_final_tables(tmp_path, small_disk,
                                                                                  fmu_dir):
    """Another process fills the disk to its last byte once the batch has written its first summary:
    the batch's runs fail naming the full disk, and the final summary.csv and sweep table are written
    whole all the same, from the room the batch kept (orchestration.results.reserve) (before: the
    summary on disk kept every row ``running``, the final one on stderr only, and no sweep table)."""
    f = _sweep_file(tmp_path, "filled", 12, 0.5)
    out = small_disk / "out"
    p = subprocess.Popen([sys.executable, "-m", "orchestration", "batch", str(f), "--out", str(out), "--fmus",
                          str(fmu_dir), "--variant", "native", "--no-plot", "--jobs", "1"], cwd=ROOT,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        _wait(lambda: (out / "summary.csv").exists(), p, what="first summary")
        assert _fill(small_disk) > 0
        stdout, stderr = p.communicate(timeout=300)
    finally:
        p.kill()
    table = _final_tables(out, "filled", 12, stdout, stderr)
    assert (table["status"] == "failed").sum() >= 1, table
    assert p.returncode == 1 and "summary: " + str(out / "summary.csv") in stdout, stderr


def test_a_variant_without_its_metrics_json_is_the_row_its_child_reported(tmp_path):
    """The rows of a child's variants whose metrics.json could not be written: from the child's report
    lines (``run --batch-rows``), a --out that could not be written a failed run (not an invalid file)."""
    from orchestration.cli import batch
    from orchestration.results.batch_summary import report_line

    msg = "--out /x: cannot write the results: no space left on device"
    stdout = "\n".join([report_line({"scenario": "s-0", "status": "invalid", "message": msg,
                                      "write_failed": True}),
                        report_line({"scenario": "s-1", "status": "failed", "message": "no space left on "
                                     "device writing /x/s-1/metrics.json: the results are not complete"}),
                        report_line({"scenario": "s-2", "status": "invalid", "message": "motor.J: bad"}),
                        "satmotor-batch-row {cut"])
    (tmp_path / "s-1").mkdir()
    (tmp_path / "s-1" / "metrics.json").write_text(json.dumps({"status": "running", "pid": 1}))
    rows = [batch._variant_row("s.yaml", n, 2, stdout, "", tmp_path / n / "metrics.json", False)
            for n in ("s-0", "s-1", "s-2", "s-3")]
    assert [(r["status"], r["exit_code"]) for r in rows] == [("failed", 1), ("failed", 1), ("invalid", 2),
                                                             ("failed", 2)]
    assert rows[0]["message"] == msg and "metrics.json: the results are not complete" in rows[1]["message"]
    assert rows[3]["message"] == "not run: the child process ended (exit 2) before this variant"


# --- a fault injector in a child process: RLIMIT_FSIZE ------------------------------------------------------

def _file_size_limit(limit):
    def apply():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # the write fails with EFBIG instead
    return apply


# 0: not even metrics.json; then (a 0.6 s run: figure ~140 kB, Parquet ~1.2 MB, CSV ~2.7 MB; the native
# binaries, extracted by the run, ~125 kB) the time series, the CSV alone, the figure, nothing
@pytest.mark.parametrize("limit", [0, 200_000, 1_500_000, 10_000_000])
def test_run_with_a_file_size_limit_says_which_file_and_why(tmp_path, fmu_dir, limit):
    src = _scenario(tmp_path, "lim", 0.6)
    out = tmp_path / "out"
    r = _cli("run", src, "--out", out, "--fmus", fmu_dir, "--no-build", "--variant", "native",
             preexec_fn=_file_size_limit(limit))
    assert "Traceback" not in r.stdout + r.stderr, r.stderr
    s = check_scenario_dir(out / "lim", why="file too large", stale_ok=True)
    if s is None:  # not even metrics.json: refused before running, the reason on stderr
        assert r.returncode == 2 and "file too large" in r.stderr, r.stderr
        return
    if s["status"] == "running":  # its final status did not fit: said on stderr, the process gone
        assert r.returncode == 1 and "lim: failed: file too large writing" in r.stderr, r.stderr
        return
    if s["status"] == "ok":
        assert r.returncode == 0
        assert all((out / "lim" / n).stat().st_size <= limit for n in ("timeseries.csv", "figure.png"))
    else:
        assert r.returncode == 1 and s["status"] == "failed" and "file too large writing" in s["message"], s


# --- a fault injector in this process: Python writes fail once a byte budget is spent ---------------------

class _Budget:
    def __init__(self, n):
        self.left = n

    def spend(self, n):
        if n > self.left:
            self.left = 0
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        self.left -= n


class _Limited:
    """A file object whose writes spend a shared budget (an ENOSPC past it)."""

    def __init__(self, f, budget):
        self._f, self._budget = f, budget

    def write(self, data):
        self._budget.spend(len(data.encode() if isinstance(data, str) else data))
        return self._f.write(data)

    def __getattr__(self, name):
        return getattr(self._f, name)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self._f.close()


@pytest.fixture
def disk_budget(monkeypatch):
    """``set(n)``: from now on the run's Python writes (CSV, JSON, PNG) and Parquet chunks share n bytes."""
    import builtins

    from orchestration.results import recorder

    state = {}
    real_fdopen, real_open, real_parquet = os.fdopen, builtins.open, recorder.StreamingRecorder._write_parquet

    def fdopen(fd, *a, **k):
        return _Limited(real_fdopen(fd, *a, **k), state["budget"])

    def open_(path, mode="r", *a, **k):
        f = real_open(path, mode, *a, **k)
        return _Limited(f, state["budget"]) if any(c in mode for c in "wa") else f

    def parquet(self, chunk):
        state["budget"].spend(chunk.nbytes)
        return real_parquet(self, chunk)

    monkeypatch.setattr(os, "fdopen", fdopen)
    monkeypatch.setattr(recorder, "open", open_, raising=False)
    monkeypatch.setattr(recorder.StreamingRecorder, "_write_parquet", parquet)
    return lambda n: state.__setitem__("budget", _Budget(n))


@pytest.mark.parametrize("budget", [150, 2_000, 40_000, 300_000, 700_000, 10**9])
def test_run_out_of_space_at_every_stage_leaves_a_whole_state(tmp_path, fmu_dir, disk_budget, budget, capsys):
    from orchestration.cli.commands import run_file

    src = _scenario(tmp_path, "budget", 0.5)
    disk_budget(budget)
    code, s = run_file(src, tmp_path / "out", fmu_dir, build=False, variant="native")
    d = tmp_path / "out" / "budget"
    if budget == 10**9:
        assert code == 0 and check_scenario_dir(d)["status"] == "ok"
        return
    assert code in (1, 2) and s["status"] in ("failed", "invalid"), s
    assert "no space left on device" in s["message"], s
    if s.get("metrics_written") is False:  # the budget, unlike a disk, is not given back by removed files
        on_disk = json.loads((d / "metrics.json").read_text())
        assert on_disk["status"] == "running" and on_disk["pid"] == os.getpid()  # its writer: this process
        assert sorted(p.name for p in d.iterdir()) == ["metrics.json"]
    else:
        on_disk = check_scenario_dir(d)
        assert on_disk is None or on_disk["status"] == "failed"


def test_a_figure_that_cannot_be_written_leaves_whole_time_series_and_says_so(tmp_path, fmu_dir, monkeypatch):
    from matplotlib.figure import Figure

    from orchestration.cli.commands import run_file

    def savefig(self, f, **kw):  # half a PNG, then the disk is full
        f.write(b"\x89PNG\r\n\x1a\n" + b"\0" * 5000)
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(Figure, "savefig", savefig)
    src = _scenario(tmp_path, "fig", 0.3)
    code, s = run_file(src, tmp_path / "out", fmu_dir, build=False, variant="native")
    d = tmp_path / "out" / "fig"
    on_disk = check_scenario_dir(d)
    assert code == 1 and on_disk["status"] == "failed" and on_disk["rows"] > 1000
    assert on_disk["message"].startswith(f"no space left on device writing {d / 'figure.png'}: ")
    assert "no figure (the time series are complete)" in on_disk["message"]
    assert sorted(p.name for p in d.iterdir()) == ["metrics.json", "timeseries.csv", "timeseries.parquet"]


def test_a_failed_write_leaves_the_previous_file_and_no_temporary(tmp_path, monkeypatch):
    target = tmp_path / "metrics.json"
    atomic.write_text(target, "old\n")

    class Full:
        def write(self, data):
            raise OSError(errno.ENOSPC, "No space left on device")

    with pytest.raises(OSError), atomic.atomic_file(target) as f:
        f.write("new, longer text\n")
        Full().write("x")
    assert target.read_text() == "old\n" and list(tmp_path.iterdir()) == [target]
    assert atomic.describe(OSError(errno.ENOSPC, "x"), target) == f"no space left on device writing {target}"


def test_the_batch_summary_on_stderr_when_it_cannot_be_written(tmp_path, fmu_dir, monkeypatch, capsys):
    from orchestration.cli.batch import run_batch
    from orchestration.results import batch_summary

    src = tmp_path / "scenarios"
    src.mkdir()
    _scenario(src, "tiny", 0.05)
    writes = []
    real = batch_summary.SummaryFile.write

    def write(self, rows):  # the first (before any run) works, then the disk is full
        writes.append(len(rows))
        if len(writes) == 1:
            return real(self, rows)
        self.error = OSError(errno.ENOSPC, "No space left on device")
        return False

    monkeypatch.setattr(batch_summary.SummaryFile, "write", write)
    code = run_batch([src], tmp_path / "out", fmu_dir, jobs=1, variant="native")
    err = capsys.readouterr().err
    assert code == 1 and "could not be written (no space left on device writing" in err
    lines = err[err.index("the summary follows here:"):].splitlines()
    assert lines[1].startswith("file,scenario,status") and ",tiny,ok," in lines[2]
    first = pd.read_csv(tmp_path / "out" / "summary.csv")  # the one written before the runs: whole
    assert list(first["status"]) == ["running"] and first["pid"].iloc[0] == os.getpid()


# --- SIGKILL: of a run child, of the batch ------------------------------------------------

def _wait(predicate, proc, timeout=240.0, what="state"):
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        v = predicate()
        if v:
            return v
        if proc is not None and proc.poll() is not None:
            raise AssertionError(f"the process ended before the {what}: {proc.communicate()}")
        time.sleep(0.05)
    raise AssertionError(f"no {what} within {timeout} s")


def _running_pid(d):
    """The pid in ``d/metrics.json`` once the run is stepping (rows in its temporary CSV), else None."""
    try:
        s = json.loads((d / "metrics.json").read_text())
    except (OSError, ValueError):
        return None
    csv = atomic.being_written(d, "timeseries.csv")
    if s.get("status") != "running" or not csv.name.endswith(".part") or csv.stat().st_size < 10_000:
        return None
    return s["pid"]


def _alive(pid):
    return Path(f"/proc/{pid}").exists() and "Z" not in Path(f"/proc/{pid}/stat").read_text().split()[2]


@pytest.mark.parametrize("variant", ["native", "python"])
def test_a_child_killed_by_sigkill_is_marked_failed_with_nothing_half_written(tmp_path, fmu_dir, variant):
    src = tmp_path / "scenarios"
    src.mkdir()
    _scenario(src, "victim", 150.0)
    _scenario(src, "tiny", 0.05)
    out = tmp_path / "out"
    p = subprocess.Popen([sys.executable, "-m", "orchestration", "batch", str(src), "--out", str(out),
                          "--fmus",
                          str(fmu_dir), "--variant", variant], cwd=ROOT, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    try:
        pid = _wait(lambda: _running_pid(out / "victim"), p, what="first rows of the run")
        assert pid != p.pid
        os.kill(pid, signal.SIGKILL)
        stdout, stderr = p.communicate(timeout=240)
    finally:
        p.kill()
    assert p.returncode == 128 + signal.SIGKILL, stderr
    table = check_batch_out(out, ["victim", "tiny"], stdout, stderr)
    s = json.loads((out / "victim" / "metrics.json").read_text())
    assert s["status"] == "failed" and s["message"].startswith("killed (SIGKILL)") and s["pid"] == pid
    assert not (out / "victim" / "timeseries.csv").exists()
    row = table.set_index("scenario").loc["victim"]
    assert row["status"] == "failed" and row["exit_code"] == 137 and "SIGKILL" in row["message"]
    assert table.set_index("scenario").loc["tiny", "status"] == "ok"


def test_a_batch_killed_by_sigkill_leaves_a_whole_summary_and_interrupted_runs(tmp_path, fmu_dir):
    src = tmp_path / "scenarios"
    src.mkdir()
    _scenario(src, "long_a", 150.0)
    _scenario(src, "long_b", 150.0)
    out = tmp_path / "out"
    p = subprocess.Popen([sys.executable, "-m", "orchestration", "batch", str(src), "--out", str(out),
                          "--fmus",
                          str(fmu_dir), "--variant", "native", "--jobs", "2"], cwd=ROOT,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        pids = [_wait(lambda n=n: _running_pid(out / n), p, what=f"first rows of {n}")
                for n in ("long_a", "long_b")]
        os.kill(p.pid, signal.SIGKILL)
        p.communicate(timeout=60)
    finally:
        p.kill()
    # the children see the batch die (SIGTERM to them): they write their partial results and end
    for pid in pids:
        _wait(lambda pid=pid: not _alive(pid), None, what=f"end of child {pid}")
    table = pd.read_csv(out / "summary.csv")  # whole: written before the runs, the batch died before the end
    assert sorted(table["scenario"]) == ["long_a", "long_b"]
    assert (table["status"] == "running").all() and (table["pid"] == p.pid).all()
    assert not _alive(p.pid)
    for row in table.to_dict("records"):  # a reader tells that the batch is gone
        reason = atomic.stale_reason({**row, "pid": int(row["pid"]), "pid_start": int(row["pid_start"])})
        assert reason and str(p.pid) in reason
    for name in ("long_a", "long_b"):
        s = check_scenario_dir(out / name)
        assert s["status"] == "interrupted" and "SIGTERM" in s["message"] and 0 < s["t_end"] < 150.0, s


# --- the smaller items: export-ssp onto a directory, an unreachable scheduler, absurd inputs ----------------

def test_export_ssp_onto_an_existing_directory_is_refused_naming_it(tmp_path, fmu_dir):
    target = tmp_path / "pkg.ssp"
    target.mkdir()
    r = _cli("export-ssp", ROOT / "scenarios" / "fan_load.yaml", target, "--fmus", fmu_dir)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    assert f"{target}: is a directory" in r.stderr and str(target / "fan_load.ssp") in r.stderr
    assert list(tmp_path.iterdir()) == [target] and not list(target.iterdir())  # nothing left behind


def test_export_ssp_on_a_full_disk_leaves_nothing_and_says_why(tmp_path, small_disk, fmu_dir):
    r = _cli("export-ssp", ROOT / "scenarios" / "fan_load.yaml", small_disk / "pkg.ssp", "--fmus", fmu_dir)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    assert "cannot write the SSP package: no space left on device" in r.stderr
    assert list(small_disk.iterdir()) == []


def _free_port():
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_batch_with_no_scheduler_listening_fails_within_seconds(tmp_path, fmu_dir):
    src = tmp_path / "scenarios"
    src.mkdir()
    _scenario(src, "tiny", 0.05)
    address = f"tcp://127.0.0.1:{_free_port()}"
    t0 = time.monotonic()
    r = _cli("batch", src, "--scheduler", address, "--out", tmp_path / "out", "--fmus", fmu_dir, timeout=60)
    wall = time.monotonic() - t0
    assert r.returncode == 1 and "Traceback" not in r.stderr, r.stderr
    assert f"--scheduler {address}: nothing listens there (connection refused)" in r.stderr
    assert wall < 15.0, wall  # was 30 s of Dask's connect retries (plus the interpreter's start)
    row = pd.read_csv(tmp_path / "out" / "summary.csv").iloc[0]
    assert row["status"] == "failed" and "nothing listens there" in row["message"]


def test_a_peer_that_is_no_scheduler_fails_within_the_client_timeout():
    import socket
    import threading

    from orchestration.cli import scheduler

    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(4)
    held = []
    threading.Thread(target=lambda: held.append(server.accept()), daemon=True).start()
    address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
    t0 = time.monotonic()
    try:
        with pytest.raises(scheduler.SchedulerUnreachable, match="no Dask scheduler answered within 2 s"):
            scheduler.connect(address, timeout=2.0)
    finally:
        server.close()
    assert time.monotonic() - t0 < 8.0


def _notes(tmp_path, body):
    from orchestration.scenario.load import load_scenario

    f = tmp_path / "s.yaml"
    f.write_text("name: s\nstop_time: 0.3\n" + body)
    return [n for n in load_scenario(f).notes]


def test_absurd_inputs_are_noted_and_ordinary_ones_are_not(tmp_path):
    psi = "  psi_ref: {type: constant, value: 0.9}\n"
    notes = _notes(tmp_path, "controller: {V_dc: 1.0e+12, I_max: 1.0e+4}\nprofiles:\n" + psi
                   + "  omega_ref: {type: step, time: 0.1, value: 1.0e+5}\n"
                   + "  T_load: {type: step, time: 0.2, value: 400.0}\n")
    by_field = {n.field: str(n) for n in notes}
    link = 400.0 * 2 ** 0.5  # [V] the line-to-line peak of the 400 V name plate
    assert f"{1e12 / link:.3g} x the {link:.4g} V DC link" in by_field["controller.V_dc"]
    rated_speed = 1430 * 3.141592653589793 / 30  # [rad/s]
    assert f"{1e5 / rated_speed:.3g} x the motor's rated speed" in by_field["profiles.omega_ref"]
    rated_torque = 4000.0 / rated_speed  # [N m]
    assert f"{400 / rated_torque:.3g} x the motor's rated torque" in by_field["profiles.T_load"]
    # the speed beyond what the voltage allows at the flux set-point: V_dc/sqrt(3) = n_p omega psi, n_p = 2
    # (with a fixed set-point: field_weakening false)
    omega_v = 540.0 / 3 ** 0.5 / (2 * 0.9)
    fixed = "controller: {field_weakening: false}\n"
    below, above = (_notes(tmp_path, fixed + "profiles:\n" + psi + f"  omega_ref: {{type: step, time: 0.1, "
                           f"value: {k * omega_v!r}}}\n") for k in (1.9, 2.1))
    assert below == [] and [n.field for n in above] == ["profiles.omega_ref"]
    assert f"{omega_v:.4g} rad/s, the speed at which" in str(above[0])
    # with the field weakening (the default) the drive lowers the flux, down to 0.1 psi_ref: not noted
    assert _notes(tmp_path, "profiles:\n" + psi + f"  omega_ref: {{type: step, time: 0.1, value: "
                  f"{2.1 * omega_v!r}}}\n") == []
    for f in sorted((ROOT / "scenarios").glob("*.yaml")):  # the library's scenarios: nothing absurd
        from orchestration.scenario.load import load_scenario

        said = [str(n) for n in load_scenario(f).notes]
        assert not [n for n in said if "far outside" in n or "cannot follow" in n], f


def test_a_preset_motor_is_judged_by_its_own_name_plate(tmp_path):
    """The 2.2-kW preset is rated 14.6 N m (Qu et al. 2012): a 160 N m load is 11 x that (noted),
    though only 6 x the default 4-kW motor's 26.7 N m (which would not be noted).  (I_max raised so
    that the torque-limit note, which supersedes this one on the same field, does not fire.)"""
    notes = _notes(tmp_path, "motor: {preset: qu2012_2kw2}\ncontroller: {I_max: 200.0}\nprofiles:\n"
                   "  psi_ref: {type: constant, value: 0.8}\n"
                   "  T_load: {type: step, time: 0.2, value: 160.0}\n")
    (note,) = [str(n) for n in notes if n.field == "profiles.T_load" and "rated torque" in str(n)]
    assert f"{160 / 14.6:.3g} x the motor's rated torque 14.6 N m" in note


def test_an_absurd_input_is_said_by_validate_and_run(tmp_path, fmu_dir):
    f = tmp_path / "absurd.yaml"
    f.write_text("name: absurd\nstop_time: 0.05\ncontroller: {V_dc: 1.0e+12}\n" + PROFILES)
    r = _cli("validate", f, "--fmus", fmu_dir)
    assert r.returncode == 0 and "valid (1 note(s))" in r.stdout and "note: controller.V_dc" in r.stderr
    r = _cli("run", f, "--out", tmp_path / "out", "--fmus", fmu_dir, "--no-build", "--variant", "native")
    assert r.returncode == 0 and "note: controller.V_dc" in r.stderr, r.stderr
    assert "far outside" in json.loads((tmp_path / "out" / "absurd" / "metrics.json").read_text())["notes"][0]


# --- one writer per --out (issue 31: two runs at once on one --out overwrote each other silently) -----

def _lock_of(pid, command):
    from orchestration.results.atomic import owner

    return json.dumps({**owner(pid), "command": command})


def test_a_second_run_onto_an_out_in_use_is_refused_naming_the_other(tmp_path, fmu_dir, capsys):
    """A live process holds the run's directory (its lock file, as a run writes it): ``run`` exits 2
    naming that process and the lock, and leaves the directory alone; the same for ``batch`` on its
    ``--out``."""
    from orchestration.cli.commands import main
    from orchestration.results.out_lock import LOCK_NAME

    f = _scenario(tmp_path, "locked", 0.05)
    other = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        out = tmp_path / "out"
        (out / "locked").mkdir(parents=True)
        (out / "locked" / "timeseries.csv").write_text("kept\n")
        (out / "locked" / LOCK_NAME).write_text(_lock_of(other.pid, "run other.yaml"))
        assert main(["run", str(f), "--out", str(out), "--fmus", str(fmu_dir), "--no-build"]) == 2
        err = capsys.readouterr().err
        assert f"is in use by run other.yaml (process {other.pid}" in err and LOCK_NAME in err, err
        assert (out / "locked" / "timeseries.csv").read_text() == "kept\n"
        (out / LOCK_NAME).write_text(_lock_of(other.pid, "batch a.yaml"))
        assert main(["batch", str(f), "--out", str(out), "--fmus", str(fmu_dir)]) == 2
        err = capsys.readouterr().err
        assert f"is in use by batch a.yaml (process {other.pid}" in err, err
        assert not (out / "summary.csv").exists()
    finally:
        other.kill()
        other.wait()


def test_a_stale_lock_is_taken_over_and_the_run_goes_on(tmp_path, fmu_dir, capsys):
    """The lock of a process that has ended (a killed run) is taken over, said on stderr; the run
    writes its results and removes its own lock at the end."""
    from orchestration.cli.commands import main
    from orchestration.results.out_lock import LOCK_NAME

    f = _scenario(tmp_path, "stale", 0.05)
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    out = tmp_path / "out"
    (out / "stale").mkdir(parents=True)
    (out / "stale" / LOCK_NAME).write_text(_lock_of(gone.pid, "run killed.yaml"))
    assert main(["run", str(f), "--out", str(out), "--fmus", str(fmu_dir), "--no-build", "--no-plot"]) == 0
    err = capsys.readouterr().err
    assert "a stale lock of run killed.yaml" in err and "taken over" in err, err
    assert json.loads((out / "stale" / "metrics.json").read_text())["status"] == "ok"
    assert not (out / "stale" / LOCK_NAME).exists()
