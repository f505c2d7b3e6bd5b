"""Batch runs: one process per scenario, locally (``jobs`` at a time) or on a Dask cluster.

1. Every file is loaded and checked first, in this process: a file that cannot be read or is
   invalid becomes a row with its message (never a traceback); two scenarios with the same
   ``name`` (they would write the same results directory) refuse the batch before anything runs.
2. Each valid scenario runs as ``python -m orchestration run FILE --no-build`` in its own process
   (pythonfmu FMUs share one interpreter per process; a process of its own keeps runs independent).
   Locally that process is forked from a server that has imported the run path once
   (:mod:`orchestration.cli.warm_children`: about 0.5 s less per scenario); on Dask it is a fresh
   interpreter.  Its exit code and ``metrics.json`` make its row, the tail of its standard error
   the row's message when it fails; a child killed by a signal is a failed row.
3. SIGINT/SIGTERM/SIGHUP (:mod:`orchestration.process.interrupts`): nothing new starts, running children get
   SIGTERM (they write their partial results), and every scenario not finished is a row with
   status ``interrupted``.  ``summary.csv`` is written in every case once runs have started.
4. A file with a ``sweep:`` section (:mod:`orchestration.scenario.sweep`) is checked variant by
   variant first (one bad variant makes the file an invalid row: none of its variants runs); each
   variant then runs as a scenario of its own into ``OUT/<sweep name>/<variant name>/``: with the
   native FMUs several to a child process (``run FILE --sweep-variant I,J,... --engine c``,
   :func:`grouped`: the FMUs extracted, read and instantiated once per child, reset per variant, the
   compiled engine stepping them, results bit-identical to the fmpy master's), with the pythonfmu ones a
   process each.  A row per
   variant whatever happens to its child (:func:`run_variants`).  Once the runs are over (finished,
   failed or interrupted) the sweep's table and figure go to ``OUT/<sweep name>/``
   (:mod:`orchestration.results.sweep_table`), with the study's summary, its sensitivity indices
   (``analysis: sobol | morris``) and ``report.html`` (:mod:`orchestration.study.report`).
5. Files (:mod:`orchestration.results.atomic`, :mod:`orchestration.results.batch_summary`):
   ``summary.csv`` is written whole before the first run (the unfinished rows ``running`` with the
   batch's pid) and again as each scenario finishes, so a batch killed even by SIGKILL leaves a
   complete table; room for the final table and the sweeps' is kept from the start
   (:mod:`orchestration.results.reserve`), so a disk filled by the runs still gets them; when it
   cannot be written even so, it is printed on standard error at the end and the exit code is at
   least 1.  A variant whose ``metrics.json`` could not be written is the row its child reported
   (``run --batch-rows``: :func:`orchestration.results.batch_summary.reported`), naming the cause.
   A child that dies (a signal, or an exit without results)
   leaving its ``metrics.json`` at ``running`` gets it rewritten ``failed`` (``interrupted`` when the
   batch stopped it) with the reason, e.g. ``killed (SIGKILL)``, and its ``.part`` files removed.

Each row also says whether the run held its set-points (``holds_setpoints``, ``setpoints``: see
:mod:`orchestration.results`); a row that did not is listed after the table (``NOT HELD ...``, the
variant's name and its parameters for a sweep), without changing the exit code unless the scenario
says ``acceptance: {holds_setpoints: true}`` (:mod:`orchestration.results.writer`).  The notes of the
scenarios (plant/controller mismatch, a load beyond the current limit's torque) are printed when the
files are loaded.

Exit code: ``128 + signum`` when interrupted, else the largest exit code of the rows (0: all ok;
1: a run failed; 2: a file invalid; 3: a run missed its acceptance bounds; a child killed by
signal N counts as 128 + N).
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor, as_completed
from pathlib import Path
from typing import NamedTuple

from orchestration.cli.scheduler import SchedulerUnreachable
from orchestration.packaging import fmus
from orchestration.process.interrupts import PARENT_ENV, SIGNALS, StopRequest, signal_name
from orchestration.results.atomic import describe, owner, settle_abandoned
from orchestration.results.batch_summary import REPORT_PREFIX, SummaryFile, reported, running_row

SUMMARY_METRICS = ("iae_speed", "iae_flux", "ss_speed", "ss_flux", "overshoot_speed", "settling_time_speed",
                   "peak_current", "peak_voltage", "min_W")
INVALID, NOT_ACCEPTED = 2, 3
STOPPED_CODES = tuple(128 + int(s) for s in SIGNALS)  # a run's exit code after SIGINT/SIGTERM/SIGHUP
_STOPPED_BY = re.compile(r"stopped by (SIG[A-Z]+)")  # an interrupted run's message (run.master)
POLL = 0.2  # [s] how often a waiting batch looks for a stop request
GRACE = 30.0  # [s] a child has to write its partial results after SIGTERM before it is killed


def collect(items):
    """Scenario files from files and directories (their ``*.yaml``, sorted)."""
    out = []
    for item in items:
        p = Path(item)
        out.extend(sorted(p.glob("*.yaml")) if p.is_dir() else [p])
    return out


class Job(NamedTuple):
    """What one child process of a batch runs: a scenario file (``indexes`` None), or variants
    ``indexes`` of a file's sweep, one after the other; the results of each go to
    ``OUT/<group>/<name>/`` (``group`` None: ``OUT/<name>/``)."""

    file: Path
    names: tuple
    indexes: tuple | None = None
    group: str | None = None

    def out(self, out):
        return Path(out) / self.group if self.group else Path(out)


#: most variants of a sweep one child process runs (native FMUs only: a pythonfmu FMU needs a process
#: of its own); fewer when that leaves a job count's processes without work
MAX_VARIANTS_PER_CHILD = 16


def grouped(runnable, jobs, variant):
    """``runnable`` with the consecutive variants of each sweep joined into jobs of up to
    :data:`MAX_VARIANTS_PER_CHILD` (about four jobs per process), for the native FMUs; unchanged
    for the pythonfmu ones."""
    if variant == "python":
        return list(runnable)
    out, sweeps = [], {}
    for job in runnable:
        if job.indexes is None:
            out.append(job)
        else:
            sweeps.setdefault((job.file, job.group), []).append(job)
    for (file, group), js in sweeps.items():
        size = max(1, min(MAX_VARIANTS_PER_CHILD, -(-len(js) // (4 * max(1, jobs)))))
        for i in range(0, len(js), size):
            part = js[i:i + size]
            out.append(Job(file, tuple(n for j in part for n in j.names),
                           tuple(k for j in part for k in j.indexes), group))
    return out


def _row(path, name, status, exit_code, message=""):
    return {"file": str(path), "scenario": name, "status": status, "exit_code": exit_code, "message": message}


def plan(files, variables=None, notes=None, sweeps=None):
    """``(runnable, rows)``: the :class:`Job` list to run (a sweep's variants one by one) and the
    rows of the files that cannot run (invalid or unreadable).  ``notes``: a list the scenarios'
    notes are appended to; ``sweeps``: a dict that gets ``{sweep name: (file, Sweep)}``.
    Never raises."""
    from orchestration.scenario.load import ScenarioError
    from orchestration.scenario.variants import load_sweep

    runnable, rows = [], []
    for f in files:
        try:
            sc, sweep, variants = load_sweep(f, variables)
            path = Path(f).resolve()
            if sweep is None:
                runnable.append(Job(path, (sc.name,)))
            else:
                runnable.extend(Job(path, (v.name,), (v.index,), sc.name) for v, _ in variants)
                if sweeps is not None:
                    sweeps[sc.name] = (path, sweep)
            if notes is not None:
                notes.extend(sc.notes if sweep is None else [n for _, vs in variants for n in vs.notes])
        except ScenarioError as exc:
            rows.append(_row(f, Path(f).stem, "invalid", INVALID, " | ".join(str(p) for p in exc.problems)))
        except Exception as exc:  # noqa: BLE001 - a batch reports a file it cannot load, it goes on
            rows.append(_row(f, Path(f).stem, "invalid", INVALID, f"cannot load: {exc!r}"))
    return runnable, rows


def duplicates(runnable):
    """``{name: [files]}`` of the results directories (scenario names, sweep names) used by more
    than one file."""
    by_name, seen = {}, set()
    for job in runnable:
        key = job.group or job.names[0]
        if job.group and (key, job.file) in seen:
            continue  # the variants of one sweep share its directory
        seen.add((key, job.file))
        by_name.setdefault(key, []).append(str(job.file))
    return {n: fs for n, fs in by_name.items() if len(fs) > 1}


def run_one(path, out, fmu_dir, algorithm=None, name=None, should_stop=None, tmpdir=None, variant="python",
            warm=None, sweep_index=None, plot=True):
    """Run one scenario in a child process; returns its summary row (a dict).  Never raises.

    ``should_stop``: a function polled while the child runs; when it returns True the child gets
    SIGTERM (it writes its partial results) and the row says ``interrupted``.  ``tmpdir``: the
    child's TMPDIR (where it extracts the FMUs).  ``warm``: the command-line entry point
    (:func:`orchestration.cli.commands.main`) to call in a child forked from the warm server
    (:mod:`orchestration.cli.warm_children`; ``tmpdir`` required, it also holds the child's
    output) instead of starting ``python -m orchestration run`` afresh (None); the row is the same.
    ``sweep_index``: run that variant of the file's sweep (named ``name``); ``plot`` False: no figure.
    """
    name = name or Path(path).stem
    return run_variants(path, out, fmu_dir, algorithm, [name], None if sweep_index is None else [sweep_index],
                        should_stop, tmpdir, variant, warm, plot)[0]


def run_variants(path, out, fmu_dir, algorithm=None, names=(), indexes=None, should_stop=None, tmpdir=None,
                 variant="python", warm=None, plot=True):
    """Run the scenario file ``path`` (``indexes`` None, ``names`` its one name), or the variants
    ``indexes`` of its sweep (named ``names``) one after the other, in one child process; returns
    a row per name.  Never raises.  The other arguments as for :func:`run_one`.  A variant the
    child did not finish is a row saying why: killed (by what), interrupted, or not started."""
    path, out, fmu_dir = Path(path).resolve(), Path(out).resolve(), Path(fmu_dir).resolve()
    names = list(names)
    if should_stop and should_stop():
        return [_row(path, n, "interrupted", 0, "not started: the batch was interrupted") for n in names]
    files = [out / n / "metrics.json" for n in names]
    for f in files:
        f.unlink(missing_ok=True)  # a child that dies early must not leave an old row to read
    argv = ["run", str(path), "--out", str(out), "--fmus", str(fmu_dir), "--no-build", "--batch-rows"]
    if algorithm:
        argv += ["--algorithm", algorithm]
    argv += ["--variant", variant]
    if variant != "python":  # the native FMUs: the compiled engine, instances reset per variant
        argv += ["--engine", "c"]
    if indexes is not None:
        argv += ["--sweep-variant", ",".join(map(str, indexes))]
    if not plot:
        argv += ["--no-plot"]
    try:
        if warm:
            from orchestration.cli.warm_children import WarmChild, preload

            try:
                child = WarmChild(warm, argv, tmpdir, tmpdir, preload(plot, variant == "python"))
            except OSError:  # no warm server here (e.g. "AF_UNIX path too long": a deep TMPDIR holds
                child = _FreshChild(argv, tmpdir)  # multiprocessing's socket): a fresh interpreter
        else:
            child = _FreshChild(argv, tmpdir)
    except OSError as exc:
        return [_row(path, n, "failed", 1, f"cannot start the child process: {exc}") for n in names]
    stopped = False
    while not child.wait(POLL):
        if should_stop and should_stop():
            stopped = True
            child.terminate()
            if not child.wait(GRACE):
                child.kill()
                child.wait(None)
            break
    stdout, stderr = child.output()
    # a signal to the whole process group reaches the child (and the warm server) as well as the batch:
    # the child may end before the batch's next look (then its exit code may be lost: 255)
    stopped = stopped or bool(should_stop and should_stop())
    if len(names) == 1:
        return [_child_row(path, names[0], child.returncode, stdout, stderr, files[0], stopped)]
    return [_variant_row(path, n, child.returncode, stdout, stderr, f, stopped) for n, f in zip(names, files)]


def _variant_row(path, name, rc, stdout, stderr, metrics, stopped):
    """The row of one of several variants a child ran: from its own results when it finished
    (its exit code from its status), else as :func:`_child_row` says of the child, or not started."""
    said = reported(stdout).get(name)
    try:
        summary = json.loads(metrics.read_text())
    except FileNotFoundError:
        if said is not None:  # it ran, and could not write its metrics.json (a full disk): as it said
            return _reported_row(path, name, said, rc, stopped)
        if stopped or rc in STOPPED_CODES:  # the batch stopped the child, or Ctrl-C reached it first
            return _row(path, name, "interrupted", 0, "not started: the batch was interrupted")
        why = f"killed by {signal_name(-rc)}" if rc < 0 else f"ended (exit {rc})"
        tail = " | ".join((stderr or "").strip().splitlines()[-6:])  # why the child ended (its stdout: rows)
        return _row(path, name, "failed", 128 - rc if rc < 0 else max(rc, 1),
                    f"not run: the child process {why} before this variant" + (f": {tail}" if tail else ""))
    except (OSError, ValueError):
        summary = None
    if summary is None or summary.get("status") in ("running", "invalid"):
        if said is not None:
            settle_abandoned(metrics, "interrupted" if said["status"] == "interrupted" else "failed",
                             said.get("message", ""))
            return _reported_row(path, name, said, rc, stopped)
        return _child_row(path, name, rc if rc else 1, stdout, stderr, metrics, stopped)
    status = summary.get("status")
    code = (NOT_ACCEPTED if summary.get("accepted") is False else 0) if status == "ok" else (
        rc if status == "interrupted" else 1)
    return _child_row(path, name, code, "", "", metrics, stopped)


class _FreshChild:
    """``python -m orchestration run ...`` in a new interpreter (the interface of
    :class:`orchestration.cli.warm_children.WarmChild`)."""

    def __init__(self, argv, tmpdir=None):
        env = {**os.environ, PARENT_ENV: str(os.getpid()), **({"TMPDIR": str(tmpdir)} if tmpdir else {})}
        self._proc = subprocess.Popen([sys.executable, "-m", "orchestration", *argv], stdout=subprocess.PIPE,
                                      stderr=subprocess.PIPE, text=True, env=env)
        self._output = ("", "")

    def wait(self, timeout):
        try:
            self._output = self._proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            return False
        return True

    @property
    def returncode(self):
        return self._proc.returncode

    def terminate(self):
        self._proc.terminate()

    def kill(self):
        self._proc.kill()

    def output(self):
        return self._output


def _reported_row(path, name, said, rc, stopped):
    """The row of a run whose ``metrics.json`` is missing or unfinished, from what its child printed
    (:func:`orchestration.results.batch_summary.reported`): ``--out`` that could not be written is a
    failed run (not an invalid file), the message the run's own (e.g. ``no space left on device
    writing ...``)."""
    status, message = said["status"], said.get("message", "")
    if status == "invalid" and not said.get("write_failed"):
        return _row(path, name, "invalid", INVALID, message)
    if status == "interrupted" or (stopped and status != "ok"):
        return _row(path, name, "interrupted", rc if rc in STOPPED_CODES else 0, message)
    if status == "ok":  # finished, yet nothing on disk says so (its metrics.json was removed since)
        status, message = "failed", "its metrics.json is missing"
    return _row(path, name, "failed", 1, message or f"exit {rc} without results")


def _child_row(path, name, rc, stdout, stderr, metrics, stopped):
    lines = [line for line in (stderr or stdout or "").strip().splitlines()
             if not line.startswith(REPORT_PREFIX)]
    tail = " | ".join(lines[-6:])
    said = reported(stdout).get(name)
    try:
        summary = json.loads(metrics.read_text())
    except (OSError, ValueError):
        summary = None
    if rc < 0:
        sig = signal_name(-rc)
        status = "interrupted" if stopped else "failed"
        settle_abandoned(metrics, status, f"killed ({sig}): the run ended without writing its results")
        return _row(path, name, status, 128 - rc, f"the child process was killed by {sig}" + (
            f"; {tail}" if tail else ""))
    if rc == INVALID:
        return _reported_row(path, name, said, rc, stopped) if said else _row(path, name, "invalid", rc, tail)
    if summary is not None and summary.get("status") == "interrupted":  # stopped by a signal: it wrote
        return _interrupted_row(path, name, rc, summary, metrics)      # its partial results
    if (summary is None or summary.get("status") == "running") and said is not None:
        settle_abandoned(metrics, "interrupted" if stopped else "failed", said.get("message", ""))
        return _reported_row(path, name, said, rc, stopped)
    if summary is None or summary.get("status") == "running":
        message = f"exit {rc} without results" + (f": {tail}" if tail else "")
        settle_abandoned(metrics, "interrupted" if stopped else "failed", message)
        return _row(path, name, "interrupted" if stopped else "failed", rc or 1, message)
    row = _row(path, name, summary["status"], rc, summary.get("message", ""))
    row.update(accepted=summary.get("accepted"), holds_setpoints=summary.get("holds_setpoints"),
               setpoints=summary.get("setpoints", ""), wall_time=summary.get("wall_time"),
               **{k: (summary.get("metrics") or {}).get(k) for k in SUMMARY_METRICS})
    return row


def _interrupted_row(path, name, rc, summary, metrics):
    """The row of a run that stopped on a signal and wrote its partial results (``metrics.json``
    says ``interrupted``), whatever its exit code says (a warm child whose server the same signal
    ended reports 255): ``interrupted``, exit ``128 + `` the signal, naming the results."""
    message = summary.get("message", "")
    found = _STOPPED_BY.search(message)
    if rc in STOPPED_CODES:
        code = rc
    elif found and found.group(1) in signal.Signals.__members__:
        code = 128 + int(signal.Signals[found.group(1)])
    else:
        code = rc or 1
    row = _row(path, name, "interrupted", code, f"{message}; partial results in {metrics.parent}")
    row.update(accepted=summary.get("accepted"), holds_setpoints=summary.get("holds_setpoints"),
               setpoints=summary.get("setpoints", ""), wall_time=summary.get("wall_time"),
               **{k: (summary.get("metrics") or {}).get(k) for k in SUMMARY_METRICS})
    return row


def _progress(total):
    try:
        from tqdm import tqdm

        return tqdm(total=total, unit="scenario", file=sys.stderr)
    except ImportError:  # pragma: no cover - tqdm is a dependency
        return None


def _run_local(runnable, out, fmu_dir, jobs, algorithm, stop, done, variant, command, plot=True):
    # the children extract their FMUs under a directory of ours, removed at the end: even a child
    # killed with SIGKILL (which cannot clean up) leaves nothing in the system's temporary directory
    from orchestration.cli import warm_children

    warm = command if command is not None and warm_children.available() else None
    try:
        with tempfile.TemporaryDirectory(prefix="satmotor-batch-") as tmp, \
                ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:  # each task runs and watches a child
            futures = [pool.submit(run_variants, job.file, job.out(out), fmu_dir, algorithm, job.names,
                                   job.indexes, lambda: bool(stop.signum), tmp, variant, warm, plot)
                       for job in runnable]
            for fut in as_completed(futures):
                for row in fut.result():
                    done(row)
    finally:
        if warm is not None:
            warm_children.stop_server()


def _run_dask(runnable, out, fmu_dir, scheduler, algorithm, stop, done, variant, plot=True):
    import uuid

    from distributed import Event

    from orchestration.cli.scheduler import connect

    with connect(scheduler) as client:  # within seconds, or SchedulerUnreachable saying why
        event_name = f"satmotor-batch-stop-{uuid.uuid4().hex}"
        event = Event(event_name, client=client)
        remaining = {client.submit(_dask_task, str(job.file), str(job.out(out)), str(fmu_dir), algorithm,
                                   job.names, event_name, variant, job.indexes, plot,
                                   pure=False, retries=1): job for job in runnable}
        # a chunk whose worker dies is run again on another one by the scheduler (allowed-failures);
        # retries: once more after an exception in the task itself (run_variants never raises)
        while remaining:
            if stop.signum and not event.is_set():
                event.set()  # every task still to start, or running, sees it and stops its child
            for fut in [f for f in remaining if f.done()]:
                job = remaining.pop(fut)
                try:
                    rows = fut.result()
                except Exception as exc:  # noqa: BLE001 - a lost worker is a failed row
                    rows = [_row(job.file, n, "failed", 1, f"the Dask task failed: {exc!r}")
                            for n in job.names]
                for row in rows:
                    done(row)
            if remaining:
                stop.event.wait(POLL)


def _dask_task(path, out, fmu_dir, algorithm, names, event_name, variant, indexes=None, plot=True):
    """``run_variants`` on a Dask worker, stopping when the batch's Dask Event is set."""
    from distributed import Event

    event = Event(event_name)
    return run_variants(path, out, fmu_dir, algorithm, names, indexes, should_stop=event.is_set,
                        variant=variant, plot=plot)


def run_batch(items, out, fmu_dir, jobs=2, scheduler=None, algorithm=None, stop=None, variant="python",
              command=None, plot=True):
    """Run every scenario of ``items``; write ``out/summary.csv``; return the exit code.  ``command``:
    the command-line entry point that warm children call (:mod:`orchestration.cli.warm_children`;
    the CLI passes its own ``main``); None starts a fresh ``python -m orchestration`` per scenario.
    ``plot`` False: no figure (neither the runs' nor the sweeps')."""
    stop = stop or StopRequest()
    files = collect(items)
    if not files:
        print("no scenario files found", file=sys.stderr)
        return INVALID
    notes = []
    sweeps = {}
    runnable, rows = plan(files, notes=notes, sweeps=sweeps)
    for note in notes:
        print(note, file=sys.stderr)
    dup = duplicates(runnable)
    if dup:
        for name, fs in dup.items():
            print(f"scenario name {name!r} is used by {len(fs)} files (they would write the same results "
                  f"directory): {', '.join(fs)}", file=sys.stderr)
        print("batch refused: nothing was run", file=sys.stderr)
        return INVALID
    out = Path(out)
    summary = SummaryFile(out / "summary.csv")
    me = owner()
    running = {(str(job.file), n): running_row(job.file, n, me)  # replaced as they finish
               for job in runnable for n in job.names}
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        print(f"--out {out}: cannot write the results: {describe(exc)}", file=sys.stderr)
        return INVALID
    from orchestration.results import out_lock

    try:  # one batch per --out: a second one is refused naming the first
        lock = out_lock.acquire(out, "batch " + " ".join(map(str, items)))
    except out_lock.OutInUse as exc:
        print(f"--out {out}: {exc}", file=sys.stderr)
        return INVALID
    except OSError as exc:
        print(f"--out {out}: cannot write the results: {describe(exc)}", file=sys.stderr)
        return INVALID
    from orchestration.results.reserve import Reserve, size_for

    reserve = Reserve(out, size_for(len(rows) + len(running)))  # room for the final tables (a full disk)
    try:
        return _run_locked(rows, running, runnable, summary, out, fmu_dir, jobs, scheduler, algorithm, stop,
                           variant, command, plot, sweeps, reserve)
    finally:
        reserve.release()
        out_lock.release(lock)


def _run_locked(rows, running, runnable, summary, out, fmu_dir, jobs, scheduler, algorithm, stop, variant,
                command, plot, sweeps, reserve=None):
    """The body of :func:`run_batch` once ``out`` is locked; ``reserve`` (a
    :class:`~orchestration.results.reserve.Reserve`) is given back before the final tables."""
    if not summary.write([*rows, *running.values()]):  # --out is writable before anything runs
        print(f"--out {out}: cannot write the results: {describe(summary.error)}", file=sys.stderr)
        return INVALID
    started = set()
    bar = _progress(len(runnable) + len(rows))
    runnable = grouped(runnable, jobs, variant)
    bar and bar.update(len(rows))

    def done(row):
        rows.append(row)
        started.add((row["file"], row["scenario"]))
        running.pop((row["file"], row["scenario"]), None)
        summary.write([*rows, *running.values()])  # whole at every moment (a failure: said at the end)
        bar and bar.update(1)

    error = ""
    try:
        if runnable:
            fmus.ensure(fmu_dir, quiet=True)  # once, before any child starts
            if scheduler:
                _run_dask(runnable, out, fmu_dir, scheduler, algorithm, stop, done, variant, plot)
            else:
                _run_local(runnable, out, fmu_dir, jobs, algorithm, stop, done, variant, command, plot)
    except Exception as exc:  # noqa: BLE001 - the summary is written whatever happened
        said = exc if isinstance(exc, SchedulerUnreachable) else repr(exc)
        error = f"the batch failed before running it: {said}"
        print(error, file=sys.stderr)
    finally:
        bar and bar.close()
        for job in runnable:  # what never reported: interrupted, or not run because of the error
            for name in job.names:
                if (str(job.file), name) not in started:
                    rows.append(_row(job.file, name, "failed", 1, error) if error and not stop.signum else
                                _row(job.file, name, "interrupted", 0,
                                     "no result: the batch was interrupted"))
        if reserve is not None:  # every run has ended: the room kept goes to the final tables
            reserve.release()
        written = _write_summary(rows, out, summary, sweeps)
        _write_sweeps(sweeps, rows, out, plot)
    if stop.signum:
        return stop.exit_code
    return max(max(r["exit_code"] for r in rows), 0 if written else 1)


def _write_sweeps(sweeps, rows, out, plot):
    """Each sweep's table and figure (:mod:`orchestration.results.sweep_table`); a sweep whose table
    cannot be written is said on stderr, the others are still written."""
    if not sweeps:
        return
    from orchestration.study.report import write_study

    for name, (path, sweep) in sweeps.items():
        try:
            written, lines = write_study(sweep, rows, Path(out) / name, plot, path)
            for line in lines:  # the variants outside a bound, failed or not held: by name and parameters
                print(line, file=sys.stderr)
            print(f"sweep {name}: {', '.join(map(str, written))}")
        except Exception as exc:  # noqa: BLE001 - the other sweeps' tables are still written
            print(f"sweep {name} ({path}): cannot write its table: {exc!r}", file=sys.stderr)


def variant_labels(sweeps):
    """``{(file, variant name): "variant NAME (path = value, ...)"}`` of the sweeps' variants (``sweeps`` as
    :func:`plan` fills it): how the screen names a variant that failed or did not hold."""
    return {(str(path), v.name): f"variant {v.name} (" + ", ".join(f"{p} = {x!r}" for p, x in v.values) + ")"
            for path, sweep in (sweeps or {}).values() for v in sweep.variants}


def _write_summary(rows, out, summary, sweeps=None):
    """Write ``summary.csv`` (:class:`~orchestration.results.batch_summary.SummaryFile`: on standard
    error when it cannot be written) and show the table; True when the file was written.  A row that
    failed or did not hold its set-points is listed after the table, a sweep's variant by its name and
    its parameters (``sweeps`` as :func:`plan` fills it)."""
    import pandas as pd

    written = summary.write_or_print(rows)
    df = pd.DataFrame(rows).sort_values("file").reset_index(drop=True)
    table = df.rename(columns={"holds_setpoints": "held"})
    shown = [c for c in ("scenario", "status", "accepted", "held", *SUMMARY_METRICS, "wall_time")
             if c in table]
    print(table[shown].to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    labels = variant_labels(sweeps)
    for r in rows:
        label = labels.get((r["file"], r["scenario"]))
        what = f"{r['file']} {label}" if label else r["file"]
        if r["status"] != "ok" or r["exit_code"] != 0:
            print(f"{r['status'].upper()} {what} (exit {r['exit_code']}): {r.get('message', '')}",
                  file=sys.stderr)
        elif r.get("holds_setpoints") is False:
            print(f"NOT HELD {what} (exit {r['exit_code']}): {r.get('setpoints', '')}", file=sys.stderr)
    print(f"summary: {out / 'summary.csv'}" if written else "summary: on standard error (not written)")
    return written
