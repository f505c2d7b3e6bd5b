"""The co-simulation master: the plant and controller FMUs stepped together over a scenario.

Three small parts, FMPy's way: the wiring (:mod:`orchestration.run.wiring`: connections resolved once
into named sources), the recorder (:mod:`orchestration.results.recorder`: in memory, or streamed to disk)
and the stepping loop here.

* Time is ``t_k = t0 + k h`` (never accumulated); the controller is stepped every
  ``controller_every`` plant steps with ``dt = Ts``, the plant every ``h``.
* Gauss-Seidel (default): at a sample the controller steps first, then the plant uses its new
  voltages.  Jacobi: the plant uses the voltages of the previous sample (both units see only
  values of the previous communication point), so the two orders differ by a one-sample delay
  that shrinks with the step.
* Row ``k`` of the record holds the plant outputs at ``t_k``, the controller outputs computed at
  ``t_k`` and the profiles at ``t_k``, as in :func:`satmotor.simulate.closed_loop`.
* Measurements (the scenario's ``measurements:`` section, :mod:`orchestration.run.measurement_noise`):
  at each controller sample the clean plant outputs are read, then the noise and quantization are
  applied to the values passed to the controller only (the plant and the ``plant.*`` columns keep
  the clean values); the measured signals are recorded as ``measured.NAME`` columns after the
  profiles.  Without the section the loop passes the plant outputs through untouched.
* An FMI discard, error or fatal status stops the run: what was recorded so far is kept, with the
  status, the time and the first error the failing FMU logged.  A stop request (``stop.signum``
  set, e.g. by a signal handler) ends the run at the next controller sample with status
  ``interrupted``.
* The master extracts each FMU once per run into a temporary directory it removes at the end
  (unless the caller passes its own ``unzip_dirs``).
"""

from __future__ import annotations

import gc
import time
from ctypes import c_double
from struct import Struct

import numpy as np
from fmpy.fmi1 import FMICallException

from orchestration.process.interrupts import signal_name
from orchestration.results.recorder import Recorder
from orchestration.run.fmu_instance import (
    STATUS,
    DiscretePort,
    FMUInstance,
    RealPort,
    check,
    extract_owned,
    remove_extracted,
)
from orchestration.run.measurement_noise import MeasurementNoise
from orchestration.run.result import RunResult, failure_message
from orchestration.run.step_plans import chained_port, evaluator, input_port
from orchestration.scenario.recording import record_steps, recorded_columns
from orchestration.scenario.system import CONTROLLER, DEFAULT_CONNECTIONS, PLANT, Connection, connections_for

__all__ = ["run", "Connection", "DEFAULT_CONNECTIONS"]


def _outputs(inst, kind="Real"):
    declared = inst.declared_type(kind)
    return [v.name for v in inst.md.modelVariables if v.causality == "output" and v.type == declared]


class _NoStop:
    signum = 0


def run(scenario, plant_fmu, controller_fmu, connections=None, algorithm=None,
        unzip_dirs=None, recorder=None, stop=None, descriptions=None, loop=None, pool=None):
    """Run ``scenario`` (an :class:`orchestration.scenario.load.Scenario`) with the two FMU files.

    ``algorithm`` overrides the scenario's ('gauss-seidel' or 'jacobi'); ``unzip_dirs`` optional
    (plant, controller) extracted copies, to share between runs (the caller owns them);
    ``recorder``: a function ``columns -> Recorder`` (default: in memory, every column);
    ``stop``: an object whose ``signum`` becomes non-zero to stop the run; ``descriptions``:
    optional (plant, controller) model descriptions (fmpy's), read once by a caller that runs the
    same FMUs many times; ``loop``: the stepping loop (default :func:`_loop`; the compiled engine's
    :func:`orchestration.run.c_engine.stepper.loop` takes the same arguments); ``pool``: a
    :class:`~orchestration.run.fmu_instance.UnitPool` whose instances are reset and reused instead of
    instantiated (with ``unzip_dirs`` that outlive the pool).  Never raises for an FMU
    failure: the :class:`RunResult` says what happened.
    """
    if connections is None:  # the default ones, with the link voltage for a capacitor link
        connections = connections_for(scenario.plant)
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
        mds = descriptions or (None, None)
        make = pool.get if pool is not None and not owned else FMUInstance
        plant = make(plant_fmu, PLANT, ud[0], mds[0])
        units.append(plant)
        current = CONTROLLER
        ctrl = make(controller_fmu, CONTROLLER, ud[1], mds[1])
        units.append(ctrl)
        for inst, overrides in ((plant, scenario.plant), (ctrl, {**scenario.controller, "Ts": scenario.Ts})):
            current = inst.name
            inst.set_parameters(overrides)
            inst.initialize(0.0)
        current = "master"
        p_out, c_out = RealPort(plant, _outputs(plant)), RealPort(ctrl, _outputs(ctrl))
        c_disc = DiscretePort(ctrl, _outputs(ctrl, "Integer"), _outputs(ctrl, "Boolean"))
        profiles = {k: p.value for k, p in scenario.profiles.items()}
        meas = getattr(scenario, "measurements", None)
        measure = MeasurementNoise(meas, p_out.names) if meas is not None and meas.signals else None
        columns = recorded_columns(p_out.names, c_out.names + c_disc.names, sorted(profiles),
                                   measure.columns if measure else ())
        rec = recorder(columns) if recorder else Recorder(columns)
        t_reached, complete = (loop or _loop)(scenario, jacobi=algorithm == "jacobi", plant=plant, ctrl=ctrl,
                                    p_out=p_out, c_out=c_out, c_disc=c_disc, connections=connections,
                                    profiles=profiles, rec=rec, stop=stop, measure=measure)
        if not complete:
            status, message = "interrupted", f"stopped by {signal_name(stop.signum)} at t = {t_reached:.6g} s"
    except FMICallException as exc:
        current = getattr(exc, "unit", current)  # FMUInstance.do_step tags the unit and the time
        t_reached = getattr(exc, "time", t_reached)
        inst = next((u for u in units if u.name == current), None)
        status = STATUS[exc.status] if 0 <= exc.status < len(STATUS) else str(exc.status)
        message = failure_message(current, exc, inst)
    except Exception as exc:  # noqa: BLE001 - instantiation, a bad override, a missing variable
        inst = next((u for u in units if u.name == current), None)
        status = "setup"
        message = failure_message(current, exc, inst)
    finally:
        logged = tuple((u.name, text) for u in units for level, text in u.messages if level == "warning")
        for u in units:
            if pool is None or owned:
                u.close()
            else:
                pool.put(u)
        for d in extracted:
            remove_extracted(d)
    if rec is None:  # the run failed before its first row: an empty record of the same kind
        try:
            rec = recorder(["time"]) if recorder else Recorder(["time"])
        except Exception:  # noqa: BLE001 - e.g. the streaming recorder's directory went away
            rec = Recorder(["time"])
    rec.close()
    return RunResult(scenario, rec, status, message, t_reached, time.perf_counter() - wall0,
                     current if status not in ("ok", "interrupted") else "", logged)


def _loop(sc, jacobi, plant, ctrl, p_out, c_out, c_disc, connections, profiles, rec, stop, measure=None):
    """The stepping loop; returns (the last communication point reached [s], whether the run
    reached its stop time).  A failing doStep raises FMICallException tagged with the unit and the
    time (:meth:`FMUInstance.step_failed`).  The garbage collector is off while it runs (the loop
    makes no reference cycle; it is switched back on, if it was on, when the loop ends)."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        return _steps(sc, jacobi, plant, ctrl, p_out, c_out, c_disc, connections, profiles, rec, stop,
                      measure)
    finally:
        if enabled:
            gc.enable()


def _steps(sc, jacobi, plant, ctrl, p_out, c_out, c_disc, connections, profiles, rec, stop, measure):
    """:func:`_loop`'s steps.  The FMI functions are called through private ctypes pointers declaring
    no argument types (:meth:`FMUInstance.fast`) with argument tuples made once: the communication
    point is one ``c_double`` whose value is set once per step and shared by both units; the profiles
    are evaluated once per step (pure functions of t).  The outputs stay in the ports' ctypes arrays:
    the inputs are picked from them (:func:`~orchestration.run.step_plans.input_port`), and each
    recorded row is those arrays' bytes appended to the recorder's raw chunk
    (:meth:`Recorder.raw_rows`: time, plant Reals, controller Reals, Integers, Booleans, then the
    profiles and the measured signals packed as doubles), flushed every :attr:`Recorder.chunk_rows`
    rows: no Python float per recorded value.  The controller's Integer and Boolean outputs
    (``c_disc``) follow its Reals in each row (stored as float64, as every column).
    ``measure``: None, or a :class:`MeasurementNoise` giving, at each controller sample, the plant
    outputs as the controller receives them and the row of measured values."""
    h, N = sc.step, sc.controller_every
    n, every = record_steps(sc)
    outputs = {PLANT: p_out.names, CONTROLLER: c_out.names}
    prof = [profiles[p] for p in sorted(profiles)]
    c_in, c_values = input_port(ctrl, CONTROLLER, connections, outputs, profiles, prof)
    p_in, p_values = input_port(plant, PLANT, connections, outputs, profiles, prof)
    calls_p, calls_c = plant.calls, ctrl.calls
    get_p, get_c = plant.fast(calls_p["get_real"]), ctrl.fast(calls_c["get_real"])
    set_p, set_c = plant.fast(calls_p["set_real"]), ctrl.fast(calls_c["set_real"])
    T = c_double(0.0)  # the communication point of both doSteps
    step_p, sp = plant.step_args(T, c_double(h))
    step_c, sc_args = ctrl.step_args(T, c_double(sc.Ts))
    pg, cg, pvals, cvals = p_out.get_args, c_out.get_args, p_out.values, c_out.values
    ps, cs, p_invals, c_invals = p_in.set_args, c_in.set_args, p_in.values, c_in.values
    get_i, get_b, ia, ba = c_disc.get_int, c_disc.get_bool, c_disc.int_args, c_disc.bool_args
    ivals, bvals = c_disc.int_values, c_disc.bool_values
    evaluate = evaluator(prof)
    p_out.read()
    c_out.read()
    c_disc.read()  # the initial values, in the ports' arrays
    if not jacobi and measure is None:  # Gauss-Seidel: the ports wired through memory when they can be
        wiring = (connections, outputs, profiles, prof)
        c_chain = chained_port(plant, PLANT, p_out.names, ctrl, CONTROLLER, *wiring)
        p_chain = chained_port(ctrl, CONTROLLER, c_out.names, plant, PLANT, *wiring)
        if c_chain is not None and p_chain is not None:
            return _chained(sc, plant, ctrl, c_chain, p_chain, c_disc, len(prof), rec, stop, T, evaluate,
                            (step_p, sp), (step_c, sc_args))
    held = cvals[:] if jacobi else cvals  # controller outputs seen by the plant (Jacobi: one sample old)
    mrow = ()  # the measured signals' values at the last sample (recorded after the profiles)
    nm = len(measure.columns) if measure is not None else 0
    pack = Struct(f"<{len(prof) + nm}d").pack
    raw = rec.raw_rows((("<f8", 1 + p_out.n + c_out.n), (np.dtype(type(ivals)._type_), len(ivals)),
                        (np.dtype(type(bvals)._type_), len(bvals)), ("<f8", len(prof) + nm)))
    t0, t = 0.0, 0.0
    left = chunk = rec.chunk_rows
    for k in range(n + 1):
        t = t0 + k * h
        T.value = t
        fv = evaluate(t)
        if k % N == 0:
            if stop.signum:
                return t, False
            if measure is None:
                c_invals[:] = c_values(pvals, held, fv)
            else:
                mv, mrow = measure(pvals[:])
                c_invals[:] = c_values(mv, held, fv)
            r = set_c(*cs)
            if r > 1:
                check(calls_c["set_real"], r)
            if jacobi:
                held = cvals[:]  # the previous sample's voltages
            r = step_c(*sc_args)
            if r > 1:
                ctrl.step_failed(r, t)
            r = get_c(*cg)
            if r > 1:
                check(calls_c["get_real"], r)
            if ia is not None:
                r = get_i(*ia)
                if r > 1:
                    check(calls_c["get_int"], r)
            if ba is not None:
                r = get_b(*ba)
                if r > 1:
                    check(calls_c["get_bool"], r)
        if k % every == 0:
            raw += T
            raw += pvals
            raw += cvals
            raw += ivals
            raw += bvals
            raw += pack(*fv, *mrow)
            left -= 1
            if not left:
                rec.flush()  # empties raw in place
                left = chunk
        if k == n:
            break
        p_invals[:] = p_values(pvals, held, fv)
        r = set_p(*ps)
        if r > 1:
            check(calls_p["set_real"], r)
        r = step_p(*sp)
        if r > 1:
            plant.step_failed(r, t)
        r = get_p(*pg)
        if r > 1:
            check(calls_p["get_real"], r)
    return t, True


def _chained(sc, plant, ctrl, c_chain, p_chain, c_disc, n_prof, rec, stop, T, evaluate, plant_step,
             ctrl_step):
    """:func:`_steps` for Gauss-Seidel without measurements, the ports wired through memory
    (:func:`~orchestration.run.step_plans.chained_port`): the plant's get call writes the controller's
    inputs and the controller's get call the plant's, the loop writes only the profile-fed inputs (when
    a profile's value changed).  The
    same calls in the same order with the same values as :func:`_steps`; the rows are recorded from the
    chains' buffers (outputs in the chains' order, put back in column order per chunk)."""
    h, N = sc.step, sc.controller_every
    n, every = record_steps(sc)
    calls_p, calls_c = plant.calls, ctrl.calls
    get_p, get_c = plant.fast(calls_p["get_real"]), ctrl.fast(calls_c["get_real"])
    set_p, set_c = plant.fast(calls_p["set_real"]), ctrl.fast(calls_c["set_real"])
    (step_p, sp), (step_c, sc_args) = plant_step, ctrl_step
    pg, cs, p_rec, c_prof, pick_c = c_chain.get_args, c_chain.set_args, c_chain.outputs, c_chain.profiles, \
        c_chain.pick
    cg, ps, c_rec, p_prof, pick_p = p_chain.get_args, p_chain.set_args, p_chain.outputs, p_chain.profiles, \
        p_chain.pick
    get_i, get_b, ia, ba = c_disc.get_int, c_disc.get_bool, c_disc.int_args, c_disc.bool_args
    ivals, bvals = c_disc.int_values, c_disc.bool_values
    for get, args, name in ((get_p, pg, "get_real"), (get_c, cg, "get_real")):  # the initial outputs
        r = get(*args)
        if r > 1:
            check(calls_p[name], r)
    n_p, n_c = len(p_rec), len(c_rec)
    pos_p, pos_c = {i: j for j, i in enumerate(c_chain.order)}, {i: j for j, i in enumerate(p_chain.order)}
    order = ([0] + [1 + pos_p[i] for i in range(n_p)] + [1 + n_p + pos_c[i] for i in range(n_c)]
             + list(range(1 + n_p + n_c, 1 + n_p + n_c + len(ivals) + len(bvals) + n_prof)))
    pack = Struct(f"<{n_prof}d").pack
    raw = rec.raw_rows((("<f8", 1 + n_p + n_c), (np.dtype(type(ivals)._type_), len(ivals)),
                        (np.dtype(type(bvals)._type_), len(bvals)), ("<f8", n_prof)), order)
    t0, t = 0.0, 0.0
    left = chunk = rec.chunk_rows
    last = None  # the profile values (as bytes) last written to the profile-fed inputs
    for k in range(n + 1):
        t = t0 + k * h
        T.value = t
        fv = evaluate(t)
        packed = pack(*fv)
        if packed != last:  # rewritten only when a value changed, compared bit for bit
            last = packed
            c_prof[:] = pick_c(fv)  # read by the controller's next set, at its next sample
            p_prof[:] = pick_p(fv)
        if k % N == 0:
            if stop.signum:
                return t, False
            r = set_c(*cs)
            if r > 1:
                check(calls_c["set_real"], r)
            r = step_c(*sc_args)
            if r > 1:
                ctrl.step_failed(r, t)
            r = get_c(*cg)
            if r > 1:
                check(calls_c["get_real"], r)
            if ia is not None:
                r = get_i(*ia)
                if r > 1:
                    check(calls_c["get_int"], r)
            if ba is not None:
                r = get_b(*ba)
                if r > 1:
                    check(calls_c["get_bool"], r)
        if k % every == 0:
            raw += T
            raw += p_rec
            raw += c_rec
            raw += ivals
            raw += bvals
            raw += packed
            left -= 1
            if not left:
                rec.flush()  # empties raw in place
                left = chunk
        if k == n:
            break
        r = set_p(*ps)
        if r > 1:
            check(calls_p["set_real"], r)
        r = step_p(*sp)
        if r > 1:
            plant.step_failed(r, t)
        r = get_p(*pg)
        if r > 1:
            check(calls_p["get_real"], r)
    return t, True
