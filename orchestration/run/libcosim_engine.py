"""Run a scenario with libcosim, the C++ co-simulation engine of the Open Simulation Platform
(through libcosimpy), instead of the fmpy master.

What libcosim runs: the plant, the controller and the scenario's profiles as a third FMU
(:mod:`orchestration.packaging.signals_fmu`, outputs ``omega_ref``, ``psi_ref``, ``T_load``), wired by
:data:`orchestration.scenario.system.DEFAULT_CONNECTIONS`.  The system is written as the SSP description
``SystemStructure.ssd`` of :func:`orchestration.packaging.ssd.ssd_xml` (the one ``export-ssp`` packs), with
the FMUs by absolute ``file:`` URI, in the engine's temporary directory, and loaded with
``CosimExecution.from_ssp_file``.  That route, not an ``OspSystemStructure.xml``, because only the
SSP annotation sets libcosim's worker threads (``numWorkerThreads``): 0 here, the units stepped one
after the other in the calling thread.  libcosim's default pool of (hardware threads - 1) workers
costs two or more thread switches per step, several times what these small units cost to step
(``bench/RESULTS.md``, section engines).

Coupling.  libcosim's fixed-step algorithm (``src/cosim/algorithm/fixed_step_algorithm.cpp``) steps
every due simulator from ``t_k`` with the inputs set at the last transfer, then copies every
connected output to its input: a Jacobi scheme.  The base step is the scenario's ``step`` (the plant
step ``h``); the controller's step is ``Ts = controller_every * h`` (libcosim's decimation factor:
it steps every ``controller_every`` base steps and its connections are transferred at those
instants only).  That is exactly :func:`orchestration.run.master.run` with ``algorithm="jacobi"``: at a
sample the controller reads the plant outputs and profiles of ``t_k`` and the plant integrates over
``[t_k, t_k + h)`` with the voltages of the previous sample.  libcosim has no Gauss-Seidel: a
scenario asking for it runs as Jacobi and the result's message says so; an explicit request
(``algorithm="gauss-seidel"``, ``--algorithm gauss-seidel``) is refused, as is a ``measurements:``
section (noise applied between the FMUs is the fmpy master's feature, not a libcosim one).

Rows.  Row ``k`` holds, as the master's, the plant outputs at ``t_k``, the controller outputs
computed at its sample ``t_j = controller_every * floor(k / controller_every) * h`` and the profiles
at ``t_k``.  :func:`run` records them through a fourth unit, the RowRecorder FMU, connected to the
outputs recorded (only the metrics' columns at ``record: metrics``), which writes them as binary
rows read per chunk (:mod:`orchestration.run.row_recorder`, :mod:`orchestration.run.libcosim_rows`);
the FMUs are loaded as lean copies (:mod:`orchestration.run.lean_fmu`).  :func:`run_package`, which
runs a package as it is, records through libcosim's observers
(:mod:`orchestration.run.libcosim_observed`).  Either way a controller output is seen once its step
is complete, at ``t_j + Ts``, and the engine runs up to one controller step beyond ``stop_time``
for the last row (with the RowRecorder, one base step more, for it to take that row).

Agreement.  libcosim counts time in integer nanoseconds and hands the FMUs
``dt = double(t + h) - double(t)``, which differs from ``h`` by up to one unit in the last place of
``t``; the records therefore equal the master's Jacobi run bit for bit when the step is exact in
binary, and within about 1e-12 of each column's scale otherwise (``tests/test_libcosim.py``).

Interrupts and failures.  libcosim steps in C++; the engine advances in chunks of
:data:`ROWS_CHUNK_TIME` (RowRecorder) or :data:`CHUNK_TIME` (observers) of simulated time, records
each chunk and checks ``stop.signum`` between chunks, so an interrupted run keeps every row up to
the last chunk.  An FMU failure ends the run with a :class:`orchestration.run.master.RunResult` as
the master's (status ``error``, ``discard`` or ``fatal``, the unit, the time, the FMU's own message)
and the rows up to the last completed step (those after the RowRecorder's last block from a second
run with the observers); nothing raises.  A run that fails before its first step (and every
:func:`run_package`, first) initializes the plant and the controller once with fmpy
(:func:`_preflight`), so an FMU refusing its parameters is reported as the master reports it, with
the unit and its status (with libcosim's default worker threads such a failure would even end the
process: the exception escapes a worker thread).  The FMUs' messages reach only libcosim's console
log on stdout, which is captured while libcosim runs
(:class:`orchestration.run.libcosim_readers.CapturedLog`).

:func:`run_package` runs an SSP package of :func:`orchestration.tools.ssp.export` as libcosim loads it.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
import zipfile
from pathlib import Path

from orchestration.results.recorder import Recorder
from orchestration.run import row_recorder
from orchestration.run.libcosim_observed import ObservedExecution
from orchestration.run.libcosim_readers import FAILED, CapturedLog
from orchestration.run.libcosim_rows import RowsExecution
from orchestration.run.result import RunResult, failure_message
from orchestration.scenario.problems import Problem
from orchestration.scenario.recording import recorded_columns
from orchestration.scenario.system import CONTROLLER, PLANT

__all__ = ["run", "run_package", "signals_fmu_for", "problems", "system_structure", "CHUNK_TIME",
           "ROWS_CHUNK_TIME", "SIGNALS", "NS", "VARIANTS"]

VARIANTS = ("native", "python")  # the FMU variants it runs (FMI 2.0: libcosim 0.11 has no FMI 3.0)

SIGNALS = "signals"  # instance name of the profiles FMU
CHUNK_TIME = 0.02  # [s] simulated time stepped in C++ between two looks at the stop flag (observers)
# [s] the same with the RowRecorder (run): its rows are read and folded into the metrics per chunk, and
# larger chunks cost less per row (the running metrics' numpy calls per chunk)
ROWS_CHUNK_TIME = 0.1
NS = 1_000_000_000  # libcosim's time unit: integer nanoseconds
ENGINE_NOTE = "libcosim fixed-step algorithm: Jacobi coupling"  # the message of a run that completed
# where run() builds the RowRecorder FMU once when neither recorder_cache nor signals_cache is given
_USER = getattr(os, "getuid", lambda: "user")()  # one cache per user (os.getuid: POSIX only)
RECORDER_CACHE = Path(tempfile.gettempdir()) / f"satmotor-{_USER}" / "recorder"


class _NoStop:
    signum = 0


def problems(scenario, algorithm=None):
    """What this engine cannot run in ``scenario``, as :class:`Problem` s (empty: it can run it).

    ``algorithm``: an explicit request (the CLI's ``--algorithm``); only ``jacobi`` or None."""
    file = str(scenario.path or "scenario")
    out = []
    if algorithm not in (None, "jacobi"):
        out.append(Problem(file, "--algorithm", algorithm, "the libcosim engine couples the FMUs by Jacobi "
                           "only (libcosim's fixed-step algorithm); use --algorithm jacobi or --engine fmpy"))
    if getattr(scenario, "measurements", None) is not None:
        out.append(Problem(file, "measurements", scenario.measurements, "measurement noise is applied by "
                           "the fmpy master only; remove the section or run with --engine fmpy"))
    from orchestration.packaging.signals_fmu import UnsupportedProfile, profiles_text

    try:
        profiles_text(scenario)
    except UnsupportedProfile as exc:
        out.append(Problem(exc.file, exc.field, exc.value, exc.reason))
    ns = round(scenario.step * NS)
    if ns < 1 or abs(ns - scenario.step * NS) > 1e-9 * ns:  # as the scenario's "multiple of step"
        out.append(Problem(file, "step", scenario.step, "libcosim counts time in whole nanoseconds: the step "
                           "must be a whole number of ns"))
    return out


def system_structure(scenario, fmus, outputs, directory):
    """Write ``directory/SystemStructure.ssd``, the system libcosim loads: the SSP description of
    :func:`orchestration.packaging.ssd.ssd_xml` (parameters, connections, base step ``h``, the controller's
    step
    hint ``Ts``, no worker thread) with each component's ``source`` the absolute ``file:`` URI of its
    FMU in ``fmus``.  ``outputs``: ``{unit: _Outputs}`` (their model descriptions).  Returns the
    path."""
    from orchestration.packaging.ssd import ssd_xml
    from orchestration.scenario.system import connections_for

    path = Path(directory) / "SystemStructure.ssd"
    path.write_bytes(ssd_xml(scenario, {u: o.md for u, o in outputs.items()}, connections_for(scenario.plant),
                             sources={u: Path(f).resolve().as_uri() for u, f in fmus.items()}))
    return path


class _Outputs:
    """The outputs of one FMU as the master records them: names and value references by declared
    type, in model-description order (:func:`orchestration.run.master._outputs`)."""

    def __init__(self, path):
        from fmpy import read_model_description

        # not validated against the schema (7 of its 10 ms): libcosim parses the description itself
        # and refuses a broken one
        md = self.md = read_model_description(str(path), validate=False)
        self.types = {v.name: v.type for v in md.modelVariables}
        fmi3 = md.fmiVersion.startswith("3")
        names = {"Real": "Float64" if fmi3 else "Real", "Integer": "Int32" if fmi3 else "Integer",
                 "Boolean": "Boolean"}
        out = [v for v in md.modelVariables if v.causality == "output"]
        self.real = [(v.name, v.valueReference) for v in out if v.type == names["Real"]]
        self.integer = [(v.name, v.valueReference) for v in out if v.type == names["Integer"]]
        self.boolean = [(v.name, v.valueReference) for v in out if v.type == names["Boolean"]]
        self.fmi3 = fmi3


def signals_fmu_for(scenario, cache_dir):
    """The ScenarioSignals FMU of ``scenario``'s profiles, built once into ``cache_dir/<key>/`` and
    reused while the profiles and the C sources it is built from are unchanged (the key is a SHA-256
    over both); the build takes about a second (a C compile), the reuse nothing."""
    from orchestration.packaging import signals_fmu
    from orchestration.packaging.native.compiler import build_once

    inputs = [*signals_fmu.sources(), Path(signals_fmu.__file__)]
    return build_once(cache_dir, f"{signals_fmu.MODEL_NAME}.fmu", inputs,
                      lambda directory: signals_fmu.build(scenario, directory),
                      signals_fmu.profiles_text(scenario))


def run(scenario, plant_fmu, controller_fmu, recorder=None, stop=None, algorithm=None,
        signals_fmu=None, chunk_time=ROWS_CHUNK_TIME, signals_cache=None, recorder_cache=None):
    """Run ``scenario`` with libcosim; returns a :class:`orchestration.run.master.RunResult`.

    ``signals_fmu``: the profiles FMU (None: built with :func:`orchestration.packaging.signals_fmu.build`,
    into
    ``signals_cache`` when given (:func:`signals_fmu_for`), else for this run only); ``recorder_cache``:
    where the RowRecorder FMU is built once
    (:func:`orchestration.packaging.native.recorder_fmu.recorder_fmu_for`)
    and the lean copies of the four FMUs libcosim loads are kept (:mod:`orchestration.run.lean_fmu`;
    default: next to ``signals_cache``, else :data:`RECORDER_CACHE`); ``recorder``:
    ``columns -> Recorder`` (default in memory); ``stop``: ``.signum`` non-zero stops the run at the
    next chunk; ``algorithm``: None or "jacobi" (anything else is refused: see :func:`problems`).
    Raises ValueError for a scenario :func:`problems` refuses; never raises for an FMU failure."""

    from orchestration.run.lean_fmu import lean_fmu

    cache = Path(recorder_cache or (Path(signals_cache).parent / "recorder" if signals_cache
                                    else RECORDER_CACHE))

    def system(work):
        fmus = {PLANT: plant_fmu, CONTROLLER: controller_fmu,
                SIGNALS: signals_fmu or signals_fmu_for(scenario, signals_cache or work / "signals")}
        fmus = {unit: lean_fmu(path, cache / "lean") for unit, path in fmus.items()}
        return fmus, lambda outputs: system_structure(scenario, fmus, outputs, work)

    return _run(scenario, system, recorder, stop, algorithm, chunk_time, rows_cache=cache)


def run_package(scenario, package, recorder=None, stop=None, chunk_time=CHUNK_TIME):
    """Run an SSP package written by :func:`orchestration.tools.ssp.export` for ``scenario`` as libcosim
    loads it (``CosimExecution.from_ssp_file``: its components, connections, parameter bindings and
    OSP step annotations), recorded as :func:`run` records.  ``scenario`` gives the record's layout
    and the parameters of the pre-flight initialization; the package must have been exported from
    it."""
    from orchestration.packaging.ssd import RESOURCES

    def system(work):
        with zipfile.ZipFile(package) as z:
            fmus = {unit: Path(z.extract(member, work / "package")) for unit, member in RESOURCES.items()}
        return fmus, lambda outputs: Path(package)

    return _run(scenario, system, recorder, stop, None, chunk_time)


def _run(scenario, system, recorder, stop, algorithm, chunk_time, rows_cache=None):
    """The run of :func:`run` and :func:`run_package`: ``system(work directory)`` gives ``({unit:
    FMU path}, outputs -> the system file libcosim loads)``.  ``rows_cache``: record through the
    RowRecorder FMU built there (:mod:`orchestration.run.libcosim_rows`); None: libcosim's
    observers (an SSP package run as it is)."""
    found = problems(scenario, algorithm)
    if found:
        raise ValueError("\n".join(map(str, found)))
    stop = stop or _NoStop()
    wall0 = time.perf_counter()
    work = Path(tempfile.mkdtemp(prefix="satmotor-libcosim-"))
    rec, status, message, t_reached, unit = None, "ok", "", 0.0, ""
    note = ENGINE_NOTE + ("" if scenario.algorithm == "jacobi" else
                          f"; the scenario's {scenario.algorithm} is not available in this engine")
    fmus = None
    try:
        fmus, structure_of = system(work)
        if rows_cache is None:  # else only after a failure (below): it costs more than the stepping saves
            failed = _preflight(scenario, fmus[PLANT], fmus[CONTROLLER])
            if failed:
                raise _Failed(*failed)
        outputs = {name: _Outputs(path) for name, path in fmus.items()}
        structure = structure_of(outputs)
        if rows_cache is not None:
            columns, sources = row_recorder.columns_for(
                scenario, {u: [(n, o.types[n]) for n, _ in o.real + o.integer + o.boolean]
                           for u, o in outputs.items()}, SIGNALS)
            with_rows = _with_recorder(scenario, structure, sources, rows_cache, work, chunk_time)
            structure = (structure, with_rows)
        else:
            sources, columns = None, _all_columns(scenario, outputs)
        rec = recorder(columns) if recorder else Recorder(columns)
        status, message, t_reached, unit = _simulate(scenario, structure, outputs, rec, stop, chunk_time,
                                                     work, sources, columns)
        if rows_cache is not None and status in FAILED and t_reached == 0:
            failed = _preflight(scenario, fmus[PLANT], fmus[CONTROLLER])
            status, message, unit = failed or (status, message, unit)
    except _Failed as exc:
        status, message, unit = exc.args
    except Exception as exc:  # noqa: BLE001 - libcosimpy raises AssertionError for a bad structure
        status, message = "setup", f"libcosim: {exc}"
        failed = rows_cache and fmus and _preflight(scenario, fmus[PLANT], fmus[CONTROLLER])
        if failed:
            status, message, unit = failed
    finally:
        shutil.rmtree(work, ignore_errors=True)
    if rec is None:
        try:
            rec = recorder(["time"]) if recorder else Recorder(["time"])
        except Exception:  # noqa: BLE001 - as the master: an empty record of the same kind
            rec = Recorder(["time"])
    rec.close()
    if status == "ok":
        message = note
    return RunResult(scenario, rec, status, message, t_reached, time.perf_counter() - wall0, unit)


class _Failed(Exception):
    """(status, message, unit) of an FMU that failed before libcosim ran."""


def _preflight(scenario, plant_fmu, controller_fmu):
    """Instantiate and initialize the plant and the controller once with fmpy, with the scenario's
    parameters, as :func:`orchestration.run.master.run` does: ``(status, message, unit)`` of the first
    that fails (the FMU's own words), or None.  libcosim's own error names neither the unit nor the
    FMI status; and with its default worker threads (not the engine's setting) it would end the
    whole process (std::terminate) instead of failing the run."""
    from fmpy.fmi1 import FMICallException

    from orchestration.run.fmu_instance import STATUS, FMUInstance

    for path, unit, values in ((plant_fmu, PLANT, scenario.plant),
                               (controller_fmu, CONTROLLER, {**scenario.controller, "Ts": scenario.Ts})):
        inst = None
        try:
            inst = FMUInstance(path, unit)
            inst.set_parameters(values)
            inst.initialize(0.0)
        except FMICallException as exc:
            status = STATUS[exc.status] if 0 <= exc.status < len(STATUS) else str(exc.status)
            return status, failure_message(unit, exc, inst), unit
        except Exception as exc:  # noqa: BLE001 - instantiation, a bad override: as the master
            return "setup", failure_message(unit, exc, inst), unit
        finally:
            if inst is not None:
                inst.close()
    return None


def _chunk_steps(sc, chunk_time, sources=None):
    """Base steps stepped between two looks at the stop flag: a multiple of the controller's; with
    the RowRecorder recording ``sources``, no more than it holds in a block (one write per chunk)."""
    N = sc.controller_every
    most = row_recorder.max_block_rows(sources) if sources else None
    steps = round(chunk_time / sc.step) if most is None else min(round(chunk_time / sc.step), most)
    return max(N, steps // N * N)


def _with_recorder(sc, structure, sources, cache, work, chunk_time):
    """The system file ``structure`` with the RowRecorder (built in ``cache``) recording ``sources``
    into ``work/rows.bin``, a block per chunk; returns its path."""
    from orchestration.packaging.native.recorder_fmu import recorder_fmu_for
    from orchestration.run.lean_fmu import lean_fmu

    fmu = lean_fmu(recorder_fmu_for(cache), cache / "lean")
    path = work / "SystemStructureRows.ssd"
    text = row_recorder.add_to_ssd(Path(structure).read_bytes(), sc, sources, fmu.resolve().as_uri(),
                                   work / row_recorder.ROWS_FILE, _chunk_steps(sc, chunk_time, sources))
    path.write_bytes(text)
    return path


class _Selected:
    """``append(row)`` of ``columns``' rows into ``rec``, which records ``wanted`` of them."""

    def __init__(self, rec, columns, wanted):
        self.rec, self.index = rec, [columns.index(c) for c in wanted]

    def append(self, row):
        self.rec.append(row[self.index])


def _all_columns(sc, outputs):
    """Every column of a row, as the master records them (all outputs, the profiles)."""
    return recorded_columns([n for n, _ in outputs[PLANT].real],
                            [n for n, _ in outputs[CONTROLLER].real + outputs[CONTROLLER].integer
                             + outputs[CONTROLLER].boolean], sorted(sc.profiles))


def _simulate(sc, structure, outputs, rec, stop, chunk_time, work, sources=None, rec_columns=None):
    """Step libcosim chunk by chunk, recording every complete row; returns (status, message, t_end,
    failed unit).  ``sources``: recorded by the RowRecorder, ``structure`` is then ``(the system
    without it, with it)``; None: by observers.  A failed run through the recorder, which has written
    the rows up to its last chunk only, is run again with the observers for the rows after those:
    a failure costs two runs, and keeps every row as before."""
    with CapturedLog(work / "libcosim.log") as log:
        if sources is not None:
            run = RowsExecution(sc, structure[1], sources, work / row_recorder.ROWS_FILE,
                                _chunk_steps(sc, chunk_time, sources))
            try:
                status, message, t_end, unit = run.simulate(rec, stop, list(outputs))
            finally:
                run.close()
            if status in FAILED:
                again = ObservedExecution(sc, structure[0], outputs, work, chunk_time)
                again.next_row = run.rows.next_row  # the rows before it are recorded
                tail = _Selected(rec, _all_columns(sc, outputs), rec_columns)
                try:
                    status, message, t_end, unit = again.simulate(tail, stop)
                finally:
                    again.close(tail)
        else:
            run = ObservedExecution(sc, structure, outputs, work, chunk_time)
            try:
                status, message, t_end, unit = run.simulate(rec, stop)
            finally:
                run.close(rec)
    if status in FAILED:
        first = log.first_fmu_error()
        message += f" -- {first}" if first else ""
    return status, message, t_end, unit
