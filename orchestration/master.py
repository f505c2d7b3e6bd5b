"""The co-simulation master: the plant and controller FMUs stepped together over a scenario.

Three small parts, FMPy's way: the wiring (:mod:`orchestration.wiring`: connections resolved once
into named sources), the recorder (:mod:`orchestration.recorder`: in memory, or streamed to disk)
and the stepping loop here.

* Time is ``t_k = t0 + k h`` (never accumulated); the controller is stepped every
  ``controller_every`` plant steps with ``dt = Ts``, the plant every ``h``.
* Gauss-Seidel (default): at a sample the controller steps first, then the plant uses its new
  voltages.  Jacobi: the plant uses the voltages of the previous sample (both units see only
  values of the previous communication point), so the two orders differ by a one-sample delay
  that shrinks with the step.
* Row ``k`` of the record holds the plant outputs at ``t_k``, the controller outputs computed at
  ``t_k`` and the profiles at ``t_k``, as in :func:`satmotor.simulate.closed_loop`.
* An FMI discard, error or fatal status stops the run: what was recorded so far is kept, with the
  status, the time and the first error the failing FMU logged.  A stop request (``stop.signum``
  set, e.g. by a signal handler) ends the run at the next controller sample with status
  ``interrupted``.
* The master extracts each FMU once per run into a temporary directory it removes at the end
  (unless the caller passes its own ``unzip_dirs``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from fmpy.fmi1 import FMICallException

from .fmu_instance import STATUS, FMUInstance, RealPort, extract_owned, remove_extracted
from .recorder import Recorder
from .wiring import CONTROLLER, DEFAULT_CONNECTIONS, PLANT, PROFILE, Connection, inputs_of, resolve

__all__ = ["run", "RunResult", "Connection", "DEFAULT_CONNECTIONS", "recorded_columns"]


@dataclass
class RunResult:
    """Outcome of one run: the recorder and how the run ended."""

    scenario: object
    recorder: Recorder
    status: str  # ok, discard, error, fatal (FMI status of the failing call), setup, or interrupted
    message: str
    t_end: float  # [s] last communication point reached (where a failure happened)
    wall_time: float  # [s]
    failed_unit: str = ""  # "plant" or "controller" when an FMU failed

    @property
    def ok(self):
        return self.status == "ok"

    @property
    def frame(self):
        """The recorded rows as a DataFrame."""
        return self.recorder.frame()


def _outputs(inst):
    return [v.name for v in inst.md.modelVariables if v.causality == "output"]


def recorded_columns(plant_outputs, controller_outputs, profile_names):
    """Column names of a row: time, the plant and controller outputs, the profiles."""
    return (["time"] + [f"{PLANT}.{v}" for v in plant_outputs]
            + [f"{CONTROLLER}.{v}" for v in controller_outputs] + [f"{PROFILE}.{v}" for v in profile_names])


class _NoStop:
    signum = 0


def run(scenario, plant_fmu, controller_fmu, connections=DEFAULT_CONNECTIONS, algorithm=None,
        unzip_dirs=None, recorder=None, stop=None):
    """Run ``scenario`` (an :class:`orchestration.scenario.Scenario`) with the two FMU files.

    ``algorithm`` overrides the scenario's ('gauss-seidel' or 'jacobi'); ``unzip_dirs`` optional
    (plant, controller) extracted copies, to share between runs (the caller owns them);
    ``recorder``: a function ``columns -> Recorder`` (default: in memory, every column);
    ``stop``: an object whose ``signum`` becomes non-zero to stop the run.  Never raises for an FMU
    failure: the :class:`RunResult` says what happened.
    """
    algorithm = algorithm or scenario.algorithm
    if algorithm not in ("gauss-seidel", "jacobi"):
        raise ValueError(f"algorithm = {algorithm!r}: must be gauss-seidel or jacobi")
    stop = stop or _NoStop()
    owned = unzip_dirs is None
    wall0 = time.perf_counter()
    units, current = [], "plant"
    rec, extracted = None, []
    status, message, t_reached = "ok", "", 0.0
    try:
        if owned:
            for path in (plant_fmu, controller_fmu):
                extracted.append(extract_owned(path))
        ud = extracted if owned else unzip_dirs
        plant = FMUInstance(plant_fmu, PLANT, ud[0])
        units.append(plant)
        current = CONTROLLER
        ctrl = FMUInstance(controller_fmu, CONTROLLER, ud[1])
        units.append(ctrl)
        for inst, overrides in ((plant, scenario.plant), (ctrl, {**scenario.controller, "Ts": scenario.Ts})):
            current = inst.name
            inst.set_parameters(overrides)
            inst.initialize(0.0)
        current = "master"
        p_out, c_out = RealPort(plant, _outputs(plant)), RealPort(ctrl, _outputs(ctrl))
        profiles = {k: p.value for k, p in scenario.profiles.items()}
        columns = recorded_columns(p_out.names, c_out.names, sorted(profiles))
        rec = recorder(columns) if recorder else Recorder(columns)
        t_reached, complete = _loop(scenario, jacobi=algorithm == "jacobi", plant=plant, ctrl=ctrl,
                                    p_out=p_out, c_out=c_out, connections=connections, profiles=profiles,
                                    rec=rec, stop=stop)
        if not complete:
            status, message = "interrupted", f"stopped by {_signame(stop.signum)} at t = {t_reached:.6g} s"
    except FMICallException as exc:
        current = getattr(exc, "unit", current)  # FMUInstance.do_step tags the unit and the time
        t_reached = getattr(exc, "time", t_reached)
        inst = next((u for u in units if u.name == current), None)
        status = STATUS[exc.status] if 0 <= exc.status < len(STATUS) else str(exc.status)
        message = _report(current, exc, inst)
    except Exception as exc:  # noqa: BLE001 - instantiation, a bad override, a missing variable
        inst = next((u for u in units if u.name == current), None)
        status = "setup"
        message = _report(current, exc, inst)
    finally:
        for u in units:
            u.close()
        for d in extracted:
            remove_extracted(d)
    if rec is None:  # the run failed before its first row: an empty record of the same kind
        try:
            rec = recorder(["time"]) if recorder else Recorder(["time"])
        except Exception:  # noqa: BLE001 - e.g. the streaming recorder's directory went away
            rec = Recorder(["time"])
    rec.close()
    return RunResult(scenario, rec, status, message, t_reached, time.perf_counter() - wall0,
                     current if status not in ("ok", "interrupted") else "")


def _report(unit, exc, inst):
    """``unit: what failed -- the FMU's first error message``."""
    first = inst.first_error() if inst else ""
    return f"{unit}: {exc}" + (f" -- {first}" if first else "")


def _loop(sc, jacobi, plant, ctrl, p_out, c_out, connections, profiles, rec, stop):
    """The stepping loop; returns (the last communication point reached [s], whether the run
    reached its stop time).  A failing doStep raises FMICallException tagged with the unit and the
    time (:meth:`FMUInstance.do_step`)."""
    h, N = sc.step, sc.controller_every
    n = round(sc.stop_time / h)
    every = max(1, round(sc.record.interval / h))
    outputs = {PLANT: p_out.names, CONTROLLER: c_out.names}
    p_in = RealPort(plant, inputs_of(connections, PLANT))
    c_in = RealPort(ctrl, inputs_of(connections, CONTROLLER))
    c_src = [(s.unit, s.ref) for s in resolve(connections, CONTROLLER, c_in.names, outputs, profiles)]
    p_src = [(s.unit, s.ref) for s in resolve(connections, PLANT, p_in.names, outputs, profiles)]
    prof = [profiles[p] for p in sorted(profiles)]
    pv, cv = p_out.read(), c_out.read()
    held = list(cv)  # controller outputs seen by the plant (Jacobi: one sample old); made once
    Ts, t0, t = sc.Ts, 0.0, 0.0
    append = rec.append
    for k in range(n + 1):
        t = t0 + k * h
        if k % N == 0:
            if stop.signum:
                return t, False
            for j, (unit, src) in enumerate(c_src):
                c_in.values[j] = pv[src] if unit == PLANT else (held[src] if unit == CONTROLLER else src(t))
            c_in.write()
            if jacobi:
                held[:] = cv  # the previous sample's voltages, copied into the list made once
            ctrl.do_step(t, Ts)
            cv = c_out.read()  # the port's own array, refreshed in place
            if not jacobi:
                held = cv
        if k % every == 0:
            append([t, *pv, *cv, *[f(t) for f in prof]])
        if k == n:
            break
        for j, (unit, src) in enumerate(p_src):
            p_in.values[j] = held[src] if unit == CONTROLLER else (pv[src] if unit == PLANT else src(t))
        p_in.write()
        plant.do_step(t, h)
        pv = p_out.read()
    return t, True


def _signame(signum):
    import signal

    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"signal {signum}"
