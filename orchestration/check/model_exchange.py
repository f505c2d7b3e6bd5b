"""The model-exchange checks of ``satmotor-cosim check``, for any FMI 2.0 or 3.0 FMU with a
``<ModelExchange>`` element (ours: ``SaturatedInductionMotorME``), each in a child process like the
co-simulation probes (:mod:`orchestration.check.probes`)::

    python -m orchestration.check.model_exchange MODE FMU [REFERENCE_DIR]

* ``me-instantiate``: instantiate for model exchange, initialize, the initial event iteration,
  continuous-time mode; the continuous states, their nominals (> 0) and derivatives are finite and
  of the declared number.
* ``me-states``: set continuous states (a perturbation of the initial ones): read back bit-identical,
  finite derivatives; set the initial states again: the first derivatives again, bit-identical
  (derivatives are a function of time, states and inputs).
* ``me-events``: the calls a tool makes at a step and at an event, also for a model without events:
  ``completedIntegratorStep``, ``enterEventMode``, the event iteration (``newDiscreteStates`` /
  ``updateDiscreteStates`` until nothing is left to update, at most 100), the event indicators,
  ``enterContinuousTimeMode``; the states do not change where the FMU says they did not.  A model
  that declares no event indicators and asks for no event is reported as such.
* ``me-reference``: fmpy's CVode at the reference's ``RelTol`` against ``reference/<modelName>/``
  (cross-check layout) when it exists, within :data:`BAND` of each column's largest value; else SKIP.

Verdicts PASS / FAIL / SKIP as for the co-simulation checks; a crash of the FMU FAILs the check.
"""

from __future__ import annotations

import math
import sys
import tempfile
import time
from pathlib import Path

from fmpy import calloc, extract, free, read_model_description
from fmpy.fmi2 import (
    FMU2Model,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)
from fmpy.fmi3 import FMU3Model

from orchestration.check.children import died, reference_dir, report, run_probe_lines

CHECKS = ("me-instantiate", "me-states", "me-events", "me-reference")
BAND = 1e-6  # me-reference: of each column's largest |value| (an integrator's error, not the last bits)
MAX_EVENT_ITERATIONS = 100


# ---- the checker's side ----------------------------------------------------------------------------

def check_model_exchange(path, root, references):
    """``[(check, verdict, detail, seconds)]`` of the model-exchange checks of the FMU ``path``
    (``root``: its model description)."""
    out = []
    ref = reference_dir(root, references)
    for check in CHECKS:
        t0 = time.perf_counter()
        if check == "me-reference" and ref is None:
            out.append((check, "SKIP", f"no reference/{root.get('modelName')}/ (not one of ours)", 0.0))
            continue
        cmd_extra = (ref,) if check == "me-reference" else ()
        code, objects, tail = run_probe_lines(check, path, *cmd_extra, module=__name__)
        result = objects[-1] if objects else None
        if code != 0 or result is None:
            verdict, detail = "FAIL", died(code, tail) if code != 0 else f"no result from the probe: {tail}"
        elif "skip" in result:
            verdict, detail = "SKIP", result["skip"]
        elif check == "me-reference" and "dev" in result:
            dev, worst = result["dev"], result["worst"]
            verdict = "PASS" if dev[worst] <= BAND else "FAIL"
            detail = (f"CVode rtol {result['rtol']:g}: {len(dev)} outputs over {result['rows']} rows, "
                      f"worst {worst} {dev[worst]:.3g} of max|ref| (band {BAND:g})")
        else:
            verdict, detail = ("PASS" if result.get("ok") else "FAIL"), result.get("detail", "")
        out.append((check, verdict, detail, time.perf_counter() - t0))
    return out


# ---- the child's side ------------------------------------------------------------------------------

class Model:
    """The FMU extracted once and a factory of logged fmpy model-exchange instances."""

    def __init__(self, path):
        self.md = read_model_description(path)
        self.unzip = extract(path, unzipdir=tempfile.mkdtemp(prefix="fmucheck_me_"))
        self.major = int(self.md.fmiVersion.split(".")[0])
        self.nx, self.nz = self.md.numberOfContinuousStates, self.md.numberOfEventIndicators
        self.log = []
        self._logger = self._log3 if self.major == 3 else fmi2CallbackLoggerTYPE(self._log)
        ex = self.md.defaultExperiment
        self.h = float(ex.stepSize) if ex is not None and ex.stepSize else 1e-3
        self.count = 0

    def _log(self, env, instance, status, category, message):
        self.log.append((status, (message or b"").decode("utf-8", "replace")))

    def _log3(self, env, status, category, message):
        self.log.append((status, (message or b"").decode("utf-8", "replace")))

    def errors(self):
        return " | ".join(m for s, m in self.log[-5:] if s >= 2)[:300]

    def instance(self):
        """Instantiated, initialized, the initial event iteration done, in continuous-time mode."""
        self.count += 1
        kw = dict(guid=self.md.guid, unzipDirectory=self.unzip, instanceName=f"checkme{self.count}",
                  modelIdentifier=self.md.modelExchange.modelIdentifier)
        if self.major == 3:
            fmu = FMU3Model(**kw)
            fmu.instantiate(loggingOn=True, logMessage=self._logger)
            fmu.enterInitializationMode(startTime=0.0)
        else:
            fmu = FMU2Model(**kw)
            cb = fmi2CallbackFunctions()
            cb.logger = self._logger
            cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
            cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
            fmu._keep = cb
            fmu.instantiate(callbacks=cb, loggingOn=True)
            fmu.setupExperiment(startTime=0.0)
            fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        self.event_iteration(fmu)
        fmu.enterContinuousTimeMode()
        return fmu

    def event_iteration(self, fmu):
        """``(iterations, the last update's flags)``; raises if it does not end or asks to terminate."""
        update = fmu.updateDiscreteStates if self.major == 3 else fmu.newDiscreteStates
        for i in range(1, MAX_EVENT_ITERATIONS + 1):
            flags = update()
            if flags[1]:
                raise RuntimeError("the event iteration asks to terminate the simulation")
            if not flags[0]:
                return i, flags
        raise RuntimeError(f"the event iteration did not end in {MAX_EVENT_ITERATIONS} iterations")

    def array(self, n):
        from ctypes import c_double

        return (c_double * max(n, 1))()

    def states(self, fmu):
        x = self.array(self.nx)
        fmu.getContinuousStates(x, self.nx)
        return list(x)[:self.nx]

    def set_states(self, fmu, values):
        x = self.array(self.nx)
        x[:self.nx] = values
        fmu.setContinuousStates(x, self.nx)

    def derivatives(self, fmu):
        dx = self.array(self.nx)
        (fmu.getContinuousStateDerivatives if self.major == 3 else fmu.getDerivatives)(dx, self.nx)
        return list(dx)[:self.nx]

    def nominals(self, fmu):
        n = self.array(self.nx)
        fmu.getNominalsOfContinuousStates(n, self.nx)
        return list(n)[:self.nx]

    def indicators(self, fmu):
        z = self.array(self.nz)
        fmu.getEventIndicators(z, self.nz)
        return list(z)[:self.nz]

    def close(self, fmu):
        fmu.terminate()
        fmu.freeInstance()


def _finite(values):
    return all(math.isfinite(v) for v in values)


def probe_instantiate(m):
    fmu = m.instance()
    x, dx, nom = m.states(fmu), m.derivatives(fmu), m.nominals(fmu)
    m.close(fmu)
    if not (_finite(x) and _finite(dx)):
        return {"ok": False, "detail": f"non-finite initial states {x} or derivatives {dx}"}
    if not all(math.isfinite(v) and v > 0.0 for v in nom):
        return {"ok": False, "detail": f"nominals {nom}: must be finite and > 0"}
    return {"ok": True, "detail": f"{m.nx} continuous states, {m.nz} event indicators; initial states, "
                                  "derivatives and nominals (> 0) finite"}


def probe_states(m):
    fmu = m.instance()
    x0, nom = m.states(fmu), m.nominals(fmu)
    dx0 = m.derivatives(fmu)
    fmu.setTime(m.h)
    x1 = [x + 1e-3 * n * (j + 1) for j, (x, n) in enumerate(zip(x0, nom))]
    m.set_states(fmu, x1)
    back, dx1 = m.states(fmu), m.derivatives(fmu)
    fmu.setTime(0.0)
    m.set_states(fmu, x0)
    dx0_again = m.derivatives(fmu)
    m.close(fmu)
    if [v.hex() for v in back] != [v.hex() for v in x1]:
        return {"ok": False, "detail": f"set {x1}, read back {back}"}
    if not _finite(dx1):
        return {"ok": False, "detail": f"non-finite derivatives {dx1} at the states {x1}"}
    if [v.hex() for v in dx0_again] != [v.hex() for v in dx0]:
        return {"ok": False,
                "detail": f"the initial states again give the derivatives {dx0_again}, first {dx0}"}
    moved = sum(a != b for a, b in zip(dx0, dx1))
    return {"ok": True, "detail": f"{m.nx} states set and read back bit-identical; derivatives finite, "
                                  f"{moved} of {m.nx} changed with the states; the initial states give the "
                                  "initial derivatives again, bit-identical"}


def probe_events(m):
    fmu = m.instance()
    x0 = m.states(fmu)
    asked = 0
    for k in (1, 2):
        fmu.setTime(k * m.h)
        step_event, terminate = fmu.completedIntegratorStep()
        if terminate:
            return {"ok": False, "detail": f"completedIntegratorStep at t = {k * m.h:g} s asks to terminate"}
        asked += bool(step_event)
        z = m.indicators(fmu)
        if not _finite(z):
            return {"ok": False, "detail": f"non-finite event indicators {z}"}
        fmu.enterEventMode()
        iterations, flags = m.event_iteration(fmu)
        fmu.enterContinuousTimeMode()
        x = m.states(fmu)
        if not flags[3] and [v.hex() for v in x] != [v.hex() for v in x0]:
            return {"ok": False,
                    "detail": f"the states changed over an event that says they did not: {x0} -> {x}"}
    m.close(fmu)
    kind = ("a model without events (no event indicators, no step or time event)"
            if m.nz == 0 and not asked and not flags[4] else f"{m.nz} event indicators")
    return {"ok": True, "detail": f"{kind}: completedIntegratorStep, enterEventMode, the event iteration "
                                  f"({iterations} call(s)), enterContinuousTimeMode, twice; states kept"}


def probe_reference(m, path, ref_dir):
    import numpy as np
    from fmpy import simulate_fmu
    from fmpy.util import read_csv, read_ref_opt_file

    d, name = Path(ref_dir), m.md.modelName
    opts = read_ref_opt_file(str(d / "ReferenceOptions.txt"))
    inputs, ref = read_csv(d / f"{name}_in.csv"), read_csv(d / f"{name}_ref.csv")
    outputs = [n for n in ref.dtype.names if n != "time"]
    rtol = float(opts.get("RelTol") or 1e-6)
    res = simulate_fmu(m.unzip, fmi_type="ModelExchange", solver="CVode", relative_tolerance=rtol,
                       start_time=opts["StartTime"], stop_time=opts["StopTime"],
                       output_interval=opts["StepSize"],
                       input=inputs, output=outputs, record_events=False,
                       logger=m._log3 if m.major == 3 else m._log)
    if len(res) != len(ref):
        return {"ok": False, "detail": f"{len(res)} rows, the reference has {len(ref)}"}
    dev = {n: float(np.max(np.abs(res[n] - ref[n])) / max(float(np.max(np.abs(ref[n]))), 1e-300))
           for n in outputs}
    return {"dev": dev, "worst": max(dev, key=dev.get), "rows": len(ref), "rtol": rtol}


PROBES = {"me-instantiate": probe_instantiate, "me-states": probe_states, "me-events": probe_events}


def main(argv):
    mode, path = argv[0], argv[1]
    m = Model(path)

    def probe():
        if m.nx == 0:
            return {"skip": "no continuous states"}
        if mode == "me-reference":
            return probe_reference(m, path, argv[2])
        return PROBES[mode](m)

    report(m, probe)


if __name__ == "__main__":
    main(sys.argv[1:])
