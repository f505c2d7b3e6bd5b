"""Run a scenario with libcosim, the C++ co-simulation engine of the Open Simulation Platform
(through libcosimpy), instead of the fmpy master.

What libcosim runs: the plant, the controller and the scenario's profiles as a third FMU
(:mod:`orchestration.build.signals_fmu`, outputs ``omega_ref``, ``psi_ref``, ``T_load``), wired by
:data:`orchestration.scenario.system.DEFAULT_CONNECTIONS`.  The system is written as the SSP description
``SystemStructure.ssd`` of :func:`orchestration.build.ssd.ssd_xml` (the one ``export-ssp`` packs), with
the FMUs by absolute ``file:`` URI, in the engine's temporary directory, and loaded with
``CosimExecution.from_ssp_file``.  That route, not an ``OspSystemStructure.xml``, because only the
SSP annotation sets libcosim's worker threads (``numWorkerThreads``): 0 here, the units stepped one
after the other in the calling thread.  libcosim's default pool of (hardware threads - 1) workers
costs two or more thread switches per step, several times what these small units cost to step
(``bench/RESULTS.md``, section libcosim).

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
at ``t_k``.  libcosim's observers see a controller output once its step is complete, at
``t_j + Ts``: the engine takes it from there, and runs up to one controller step beyond
``stop_time`` for the last row.  Reals and Integers come from a time-series observer, exact doubles;
the controller's Booleans, which that observer cannot read, from a file observer's CSV (0 / 1).

Agreement.  libcosim counts time in integer nanoseconds and hands the FMUs
``dt = double(t + h) - double(t)``, which differs from ``h`` by up to one unit in the last place of
``t``; the records therefore equal the master's Jacobi run bit for bit when the step is exact in
binary, and within about 1e-12 of each column's scale otherwise (``tests/test_libcosim.py``).

Interrupts and failures.  libcosim steps in C++; the engine advances in chunks of
:data:`CHUNK_TIME` of simulated time, records each chunk and checks ``stop.signum`` between
chunks, so an interrupted run keeps every row up to the last chunk.  An FMU failure ends the run
with a :class:`orchestration.run.master.RunResult` as the master's (status ``error``, ``discard`` or
``fatal``, the unit, the time, the FMU's own message) and the rows up to the last completed step;
nothing raises.  The plant and the controller are first initialized once with fmpy
(:func:`_preflight`), so an FMU refusing its parameters is reported as the master reports it, with
the unit and its status (with libcosim's default worker threads such a failure would even end the
process: the exception escapes a worker thread).  The FMUs' messages reach only libcosim's console
log on stdout, which is captured while libcosim runs
(:class:`orchestration.run.libcosim_readers.CapturedLog`).

:func:`run_package` runs an SSP package of :func:`orchestration.tools.ssp.export` as libcosim loads it.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import tempfile
import time
import zipfile
from pathlib import Path

import numpy as np

from orchestration.process.interrupts import signal_name
from orchestration.run.libcosim_readers import (
    FAILED,
    BoolFile,
    CapturedLog,
    Lib,
    Series,
    file_observer,
    positions,
)
from orchestration.run.recorder import Recorder
from orchestration.run.result import RunResult, failure_message
from orchestration.scenario.problems import Problem
from orchestration.scenario.recording import recorded_columns
from orchestration.scenario.system import CONTROLLER, PLANT

__all__ = ["run", "run_package", "signals_fmu_for", "problems", "system_structure", "CHUNK_TIME", "SIGNALS",
           "NS", "VARIANTS"]

VARIANTS = ("native", "python")  # the FMU variants it runs (FMI 2.0: libcosim 0.11 has no FMI 3.0)

SIGNALS = "signals"  # instance name of the profiles FMU
CHUNK_TIME = 0.02  # [s] simulated time stepped in C++ between two looks at the stop flag
NS = 1_000_000_000  # libcosim's time unit: integer nanoseconds
ENGINE_NOTE = "libcosim fixed-step algorithm: Jacobi coupling"  # the message of a run that completed


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
    from orchestration.build.signals_fmu import UnsupportedProfile, profiles_text

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
    :func:`orchestration.build.ssd.ssd_xml` (parameters, connections, base step ``h``, the controller's step
    hint ``Ts``, no worker thread) with each component's ``source`` the absolute ``file:`` URI of its
    FMU in ``fmus``.  ``outputs``: ``{unit: _Outputs}`` (their model descriptions).  Returns the
    path."""
    from orchestration.build.ssd import ssd_xml
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

        md = self.md = read_model_description(str(path))
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
    from orchestration.build import native_build, native_tables, signals_fmu

    h = hashlib.sha256(signals_fmu.profiles_text(scenario).encode())
    for f in (*signals_fmu.sources(), *sorted(native_build.GLUE_DIR.glob("*.[ch]")),
              Path(signals_fmu.__file__), Path(native_build.__file__), Path(native_tables.__file__)):
        h.update(Path(f).name.encode() + b"\0" + Path(f).read_bytes() + b"\0")
    d = Path(cache_dir) / h.hexdigest()[:24]
    fmu = d / f"{signals_fmu.MODEL_NAME}.fmu"
    if not fmu.is_file():
        d.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory(dir=d) as tmp:  # built aside, then renamed: never half-written
            os.replace(signals_fmu.build(scenario, tmp), fmu)
    return fmu


def run(scenario, plant_fmu, controller_fmu, recorder=None, stop=None, algorithm=None,
        signals_fmu=None, chunk_time=CHUNK_TIME, signals_cache=None):
    """Run ``scenario`` with libcosim; returns a :class:`orchestration.run.master.RunResult`.

    ``signals_fmu``: the profiles FMU (None: built with :func:`orchestration.build.signals_fmu.build`, into
    ``signals_cache`` when given (:func:`signals_fmu_for`), else for this run only); ``recorder``:
    ``columns -> Recorder`` (default in memory); ``stop``: ``.signum`` non-zero stops the run at the
    next chunk; ``algorithm``: None or "jacobi" (anything else is refused: see :func:`problems`).
    Raises ValueError for a scenario :func:`problems` refuses; never raises for an FMU failure."""

    def system(work):
        fmus = {PLANT: plant_fmu, CONTROLLER: controller_fmu,
                SIGNALS: signals_fmu or signals_fmu_for(scenario, signals_cache or work / "signals")}
        return fmus, lambda outputs: system_structure(scenario, fmus, outputs, work)

    return _run(scenario, system, recorder, stop, algorithm, chunk_time)


def run_package(scenario, package, recorder=None, stop=None, chunk_time=CHUNK_TIME):
    """Run an SSP package written by :func:`orchestration.tools.ssp.export` for ``scenario`` as libcosim
    loads it (``CosimExecution.from_ssp_file``: its components, connections, parameter bindings and
    OSP step annotations), recorded as :func:`run` records.  ``scenario`` gives the record's layout
    and the parameters of the pre-flight initialization; the package must have been exported from
    it."""
    from orchestration.build.ssd import RESOURCES

    def system(work):
        with zipfile.ZipFile(package) as z:
            fmus = {unit: Path(z.extract(member, work / "package")) for unit, member in RESOURCES.items()}
        return fmus, lambda outputs: Path(package)

    return _run(scenario, system, recorder, stop, None, chunk_time)


def _run(scenario, system, recorder, stop, algorithm, chunk_time):
    """The run of :func:`run` and :func:`run_package`: ``system(work directory)`` gives ``({unit:
    FMU path}, outputs -> the system file libcosim loads)``."""
    found = problems(scenario, algorithm)
    if found:
        raise ValueError("\n".join(map(str, found)))
    stop = stop or _NoStop()
    wall0 = time.perf_counter()
    work = Path(tempfile.mkdtemp(prefix="satmotor-libcosim-"))
    rec, status, message, t_reached, unit = None, "ok", "", 0.0, ""
    note = ENGINE_NOTE + ("" if scenario.algorithm == "jacobi" else
                          f"; the scenario's {scenario.algorithm} is not available in this engine")
    try:
        fmus, structure_of = system(work)
        failed = _preflight(scenario, fmus[PLANT], fmus[CONTROLLER])
        if failed:
            raise _Failed(*failed)
        outputs = {name: _Outputs(path) for name, path in fmus.items()}
        structure = structure_of(outputs)
        columns = recorded_columns([n for n, _ in outputs[PLANT].real],
                                   [n for n, _ in outputs[CONTROLLER].real + outputs[CONTROLLER].integer
                                    + outputs[CONTROLLER].boolean], sorted(scenario.profiles))
        rec = recorder(columns) if recorder else Recorder(columns)
        status, message, t_reached, unit = _simulate(scenario, structure, outputs, rec, stop, chunk_time,
                                                     work)
    except _Failed as exc:
        status, message, unit = exc.args
    except Exception as exc:  # noqa: BLE001 - libcosimpy raises AssertionError for a bad structure
        status, message = "setup", f"libcosim: {exc}"
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


def _simulate(sc, structure, outputs, rec, stop, chunk_time, work):
    """Step libcosim chunk by chunk, recording every complete row; returns (status, message, t_end,
    failed unit)."""
    with CapturedLog(work / "libcosim.log") as log:
        run = _Execution(sc, structure, outputs, work, chunk_time)
        try:
            status, message, t_end, unit = run.simulate(rec, stop)
        finally:
            run.close(rec)
    if status in FAILED:
        first = log.first_fmu_error()
        message += f" -- {first}" if first else ""
    return status, message, t_end, unit


class _Execution:
    """One libcosim execution of the system and its observers, and the rows taken from them."""

    def __init__(self, sc, structure, outputs, work, chunk_time=CHUNK_TIME):
        from libcosimpy.CosimEnums import CosimVariableType
        from libcosimpy.CosimExecution import CosimExecution
        from libcosimpy.CosimObserver import CosimObserver

        self.sc, self.outputs, self.lib = sc, outputs, Lib()
        self.h, self.N = sc.step, sc.controller_every
        self.n = round(sc.stop_time / self.h)
        self.every = max(1, round(sc.record.interval / self.h))
        self.last_step = self.N * (self.n // self.N + 1)  # completes the last row's controller values
        self.pending = []  # row tables waiting for the Booleans of their controller samples
        self.next_row = 0
        self.file_obs = None
        try:
            self.ex = CosimExecution.from_ssp_file(str(structure))  # a package (.ssp) or a .ssd
        except AssertionError as exc:
            raise RuntimeError(str(exc)) from None
        self.index = {name: self.ex.slave_index_from_instance_name(name) for name in outputs}
        self.chunk = max(self.N, round(chunk_time / self.h) // self.N * self.N)  # base steps, a multiple of N
        # samples kept per variable: the rows of a chunk and the controller sample of the last one.  No
        # more: libcosim 0.11 copies the observer's whole time map at every sample read
        self.observer = CosimObserver.create_time_series(self.chunk + 2 * self.N + 8)
        self.ex.add_observer(self.observer)
        for name, o in outputs.items():
            for _, ref in o.real:
                self.observer.start_time_series(self.index[name], ref, CosimVariableType.REAL)
            for _, ref in o.integer:
                self.observer.start_time_series(self.index[name], ref, CosimVariableType.INTEGER)
        bools = outputs[CONTROLLER].boolean
        self.bools = BoolFile(work / "observer" / f"{CONTROLLER}.csv", len(bools))
        if bools:
            self.file_obs = file_observer([b for b, _ in bools], CONTROLLER, work)
            self.ex.add_observer(self.file_obs)
        self.series = Series(self.lib, self.observer.ptr())
        profiles = sorted(sc.profiles)
        self.sig_refs = [dict(outputs[SIGNALS].real)[p] for p in profiles]
        self.p_refs = [r for _, r in outputs[PLANT].real]
        self.c_real = [r for _, r in outputs[CONTROLLER].real]
        self.c_int = [r for _, r in outputs[CONTROLLER].integer]

    def simulate(self, rec, stop):
        h, chunk = self.h, self.chunk
        reached = 0  # the base step libcosim has reached
        while reached < self.last_step:
            if stop.signum:
                return "interrupted", f"stopped by {signal_name(stop.signum)} at t = {reached * h:.6g} s", \
                    reached * h, ""
            target = min(reached + chunk, self.last_step)
            ok = self.ex.step(target - reached)
            if not ok:
                text = self.lib.error().strip()
                now = self.ex.status().current_time // round(h * NS)
                self._take(now, rec)
                unit = next((u for u in self.outputs if f"{u}: " in text), "")
                kind = "discard" if "Step not complete" in text else "error"
                return kind, f"{unit or 'libcosim'}: libcosim: {text}", now * h, unit
            reached = target
            self._take(reached, rec)
        return "ok", "", self.n * h, ""

    def close(self, rec):
        """End the execution (the file observer closes its CSV) and record the rows still waiting
        for their Booleans."""
        self.ex = self.observer = self.file_obs = None  # libcosim objects freed here (refcounts)
        self.bools.update()
        self._emit(rec)

    def _take(self, reached, rec):
        """Read the rows ``next_row..`` complete once libcosim has reached base step ``reached``
        (row k needs the plant and profile samples of step k and the controller sample of step
        ``N * (k // N + 1)``) and record those whose Booleans are on disk."""
        N, n = self.N, self.n
        last = n if reached >= self.last_step else min(n, (reached // N) * N - 1)
        rows = [k for k in range(self.next_row, last + 1) if k % self.every == 0]
        self.next_row = max(self.next_row, last + 1)
        if rows:
            self.pending.append(self._table(np.array(rows)))
        self.bools.update()
        self._emit(rec)

    def _table(self, ks):
        N, ix = self.N, self.index
        k0, count = int(ks[0]), int(ks[-1] - ks[0] + 1)
        cs = N * (ks // N + 1)  # the controller sample of each row
        p_steps, pv = self.series.read(ix[PLANT], self.p_refs, "real", k0, count)
        c0, c_count = int(cs[0]), int(cs[-1] - cs[0] + 1)
        c_steps, cv = self.series.read(ix[CONTROLLER], self.c_real, "real", c0, c_count)
        parts = [cv]
        if self.c_int:
            parts.append(self.series.read(ix[CONTROLLER], self.c_int, "int", c0, c_count)[1])
        cols = [ks * self.h, pv[:, positions(p_steps, ks)], np.vstack(parts)[:, positions(c_steps, cs)]]
        if self.bools.n:
            cols.append(np.full((self.bools.n, len(ks)), np.nan))  # filled by _emit
        s_steps, sv = self.series.read(ix[SIGNALS], self.sig_refs, "real", k0, count)
        cols.append(sv[:, positions(s_steps, ks)])
        return cs, np.vstack(cols).T

    def _emit(self, rec):
        """Record the pending rows, in order, up to the first whose Booleans are not on disk yet."""
        nb = self.bools.n
        while self.pending:
            cs, table = self.pending[0]
            upto = len(cs)
            if nb:
                upto, flags = self.bools.take(cs)
                if upto == 0:
                    return
                nc = table.shape[1] - nb - len(self.sig_refs)  # first Boolean column
                table[:upto, nc:nc + nb] = flags
            for row in table[:upto]:  # rows of the float64 table: the recorder stacks them per chunk
                rec.append(row)
            if upto == len(cs):
                self.pending.pop(0)
            else:
                self.pending[0] = (cs[upto:], table[upto:])
