"""The run-time checks of ``satmotor-cosim check``, each in a child process of its own::

    python -m orchestration.check.probes MODE FMU [REFERENCE_DIR]

so that an FMU that crashes or corrupts the heap takes down the probe, not the checker.  A probe
prints one JSON object (its last line of stdout) and exits normally: the exit code is part of the
result (:mod:`orchestration.check.checker` reads both).  Modes: ``instantiate``, ``wrong-guid``,
``cycles``, ``state``, ``reset``, ``bad-parameter``, ``steps``, ``reference``, ``serialize`` (writes a
serialized state to a file, for the other FMUs' ``foreign-state``).  Two probes try several items,
each on a fresh instance: ``non-finite-input`` (one NaN input at a time) and ``foreign-state`` (one
state blob not the FMU's own at a time); they take the index of the first item (the checker restarts the probe
after the item it died on) and print ``{"trying": ...}`` before and ``{"item": ...}`` after each
item, then their result.  Only fmpy here: the probes work for any FMI 2.0 or FMI 3.0 co-simulation
FMU (:class:`Slave` hides the version differences: the probes are written once).
"""

from __future__ import annotations

import json
import math
import sys
import tempfile
import uuid
from pathlib import Path

from fmpy import calloc, extract, free, read_model_description
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)
from fmpy.fmi3 import FMU3Slave

from orchestration.check.children import report

STEPS = 5  # steps before a state is taken, and steps replayed
CYCLES = 20
STATUS = {0: "ok", 1: "warning", 2: "discard", 3: "error", 4: "fatal", 5: "pending"}
# a parameter our FMUs refuse (when no Real parameter declares a min > 0)
KNOWN_BAD = {"SaturatedInductionMotor": ("J", 0.0), "BacksteppingController": ("J", 0.0)}


def status_of(f, *args):
    """``(status name, result)`` of an fmpy call: fmpy raises for statuses above warning."""
    try:
        return "ok", f(*args)
    except Exception as exc:  # fmpy.fmi2's FMICallException carries the status
        return STATUS.get(getattr(exc, "status", None), repr(exc)), None


class Slave:
    """One fmpy co-simulation instance, FMI 2.0 or 3.0, behind the calls the probes make: Float64
    (FMI 3.0) and Real (FMI 2.0) alike are "reals"."""

    def __init__(self, fmu, major):
        self.fmu, self.major = fmu, major

    def set_reals(self, vrs, values):
        (self.fmu.setFloat64 if self.major == 3 else self.fmu.setReal)(vrs, values)

    def get_reals(self, vrs):
        return (self.fmu.getFloat64 if self.major == 3 else self.fmu.getReal)(vrs)

    def initialize(self, start=0.0):
        if self.major == 3:
            self.fmu.enterInitializationMode(startTime=start)
        else:
            self.fmu.setupExperiment(startTime=start)
            self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    def do_step(self, t, h):
        # the state probe sets the state back to an earlier time: no promise of the contrary (fmpy's
        # default, noSetFMUStatePriorToCurrentPoint = true, would let an FMU drop what it needs)
        self.fmu.doStep(t, h, noSetFMUStatePriorToCurrentPoint=False)

    def get_state(self):
        return self.fmu.getFMUState()

    def set_state(self, state):
        self.fmu.setFMUState(state)

    def free_state(self, state):
        self.fmu.freeFMUState(state)

    def serialize(self, state):
        return bytes(self.fmu.serializeFMUState(state))

    def deserialize(self, blob):
        return (self.fmu.deserializeFMUState if self.major == 3 else self.fmu.deSerializeFMUstate)(blob)

    def reset(self):
        self.fmu.reset()

    def terminate(self):
        self.fmu.terminate()

    def free(self):
        self.fmu.freeInstance()


class Probe:
    """The FMU extracted once, its variables, and a factory of logged fmpy instances."""

    def __init__(self, path):
        self.md = read_model_description(path)
        self.unzip = extract(path, unzipdir=tempfile.mkdtemp(prefix="fmucheck_"))
        self.major = int(self.md.fmiVersion.split(".")[0])
        self.fmi = f"fmi{self.major}"
        self.log = []
        # FMI 2.0: the ctypes callback, kept alive as long as the instances (FMU3Slave wraps and keeps
        # the plain function itself)
        self._logger = self._log3 if self.major == 3 else fmi2CallbackLoggerTYPE(self._log)
        ex = self.md.defaultExperiment
        self.h = float(ex.stepSize) if ex is not None and ex.stepSize else 1e-4
        # scalar ones only: an FMI 3.0 array variable holds more values than its value reference
        self.reals = [v for v in self.md.modelVariables
                      if v.type in ("Real", "Float64") and not v.dimensions]
        # by causality: FMI 3.0's independent variable (time) is neither
        self.inputs = [v for v in self.reals if v.causality == "input"]
        self.outputs = [v.valueReference for v in self.reals if v.causality == "output"]
        self.count = 0

    def _log(self, env, instance, status, category, message):
        self.log.append((status, (message or b"").decode("utf-8", "replace")))

    def _log3(self, env, status, category, message):  # FMI 3.0: no instance, no variadic arguments
        self.log.append((status, (message or b"").decode("utf-8", "replace")))

    def errors(self):
        return " | ".join(m for s, m in self.log[-5:] if s >= 2)[:300]

    def instance(self, initialize=True, params=(), guid=None):
        self.count += 1
        kw = dict(guid=guid or self.md.guid, unzipDirectory=self.unzip, instanceName=f"check{self.count}",
                  modelIdentifier=self.md.coSimulation.modelIdentifier)
        if self.major == 3:
            fmu = FMU3Slave(**kw)
            fmu.instantiate(loggingOn=True, logMessage=self._logger)
        else:
            fmu = FMU2Slave(**kw)
            cb = fmi2CallbackFunctions()
            cb.logger = self._logger
            cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
            cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
            fmu._keep = cb
            fmu.instantiate(callbacks=cb, loggingOn=True)
        s = Slave(fmu, self.major)
        if initialize:
            self.initialize(s, params)
        return s

    def initialize(self, s, params=()):
        for vr, value in params:
            s.set_reals([vr], [value])
        s.initialize(0.0)

    def input_values(self):
        """The inputs' start values; 1.0 (within min/max) where the start is 0 or missing, so that
        the replays compare something that moves."""
        values = []
        for v in self.inputs:
            x = float(v.start) if v.start not in (None, "") else 0.0
            if x == 0.0:
                x = min(max(1.0, float(v.min) if v.min else -math.inf), float(v.max) if v.max else math.inf)
            values.append(x)
        return values

    def run(self, s, k0, n):
        """``n`` steps from step ``k0`` with the input values; the outputs after each (bit patterns)."""
        vrs, values, rows = [v.valueReference for v in self.inputs], self.input_values(), []
        for k in range(k0, k0 + n):
            if vrs:
                s.set_reals(vrs, values)
            s.do_step(k * self.h, self.h)
            rows.append([x.hex() for x in s.get_reals(self.outputs)] if self.outputs else [])
        return rows


def probe_instantiate(p):
    s = p.instance()
    p.run(s, 0, 1)
    s.terminate()
    s.free()
    return {"ok": True, "detail": f"one doStep of {p.h:g} s"}


def wrong_guid(guid):
    """A GUID (instantiationToken) that is not ``guid``, derived from it."""
    return "{" + str(uuid.uuid5(uuid.NAMESPACE_URL, "satmotor-check-wrong-guid:" + guid)) + "}"


def probe_wrong_guid(p):
    wrong = wrong_guid(p.md.guid)
    out = {"wrong": wrong, "guid": p.md.guid, "generationTool": p.md.generationTool or "",
           "token": "instantiationToken" if p.major == 3 else "fmuGUID"}
    try:
        s = p.instance(initialize=False, guid=wrong)
    except Exception as exc:  # fmpy: "Failed to instantiate ..." (NULL)
        return {**out, "refused": True, "detail": f"{exc}" + (f" (log: {p.errors()})" if p.errors() else "")}
    s.free()
    return {**out, "refused": False}


def probe_cycles(p):
    for _ in range(CYCLES):
        s = p.instance()
        s.terminate()
        s.free()
    return {"ok": True, "detail": f"{CYCLES} instantiate/initialize/free cycles"}


def probe_state(p):
    cs = p.md.coSimulation
    if not cs.canGetAndSetFMUstate:
        return {"skip": "canGetAndSetFMUstate is false"}
    s = p.instance()
    p.run(s, 0, STEPS)
    state = s.get_state()
    first = p.run(s, STEPS, STEPS)
    s.set_state(state)
    again = p.run(s, STEPS, STEPS)
    if again != first:
        return {"ok": False, "detail": "get/set state: the replay differs"}
    detail = f"get/set state after {STEPS} steps, {STEPS} steps replayed bit-identical"
    if cs.canSerializeFMUstate:
        blob = s.serialize(state)
        restored = s.deserialize(blob)
        s.set_state(restored)
        if p.run(s, STEPS, STEPS) != first:
            return {"ok": False, "detail": "serialize/deserialize: the replay differs"}
        s.free_state(restored)
        detail += f"; serialized ({len(blob)} bytes) round trip too"
    s.free_state(state)
    s.terminate()
    s.free()
    return {"ok": True, "detail": detail}


def probe_reset(p):
    s = p.instance()
    first = p.run(s, 0, 2 * STEPS)
    s.reset()
    p.initialize(s)
    again = p.run(s, 0, 2 * STEPS)
    s.terminate()
    s.free()
    return {"ok": again == first, "detail": f"{2 * STEPS} steps before and after {p.fmi}Reset"
            + (" bit-identical" if again == first else ": outputs differ")}


def alive(p):
    """A fresh instance steps fine (the host lives on)."""
    s = p.instance()
    p.run(s, 0, 1)
    s.free()
    return True


def probe_bad_parameter(p):
    params = [v for v in p.reals
              if v.causality == "parameter" and v.min not in (None, "") and float(v.min) > 0]
    if params:
        name, value = params[0].name, 0.0
    elif p.md.modelName in KNOWN_BAD:
        name, value = KNOWN_BAD[p.md.modelName]
    else:
        return {"skip": "no Real (Float64) parameter with min > 0 (and not one of our FMUs)"}
    vr = next(v.valueReference for v in p.reals if v.name == name)
    s = p.instance(initialize=False)
    status, _ = status_of(s.set_reals, [vr], [value])
    where = f"{p.fmi}SetFloat64" if p.major == 3 else "fmi2SetReal"
    if status == "ok":
        where = "initialization"
        status, _ = status_of(p.initialize, s)
        if status == "ok" and p.errors():  # refused in words only (pythonfmu: no fmi2Error from Python)
            step, _ = status_of(s.do_step, 0.0, p.h)
            if step in ("error", "discard"):
                status, where = "logged", f"initialization (fmi2OK with an error logged; doStep: {step})"
    if status in ("error", "discard", "logged"):
        s.free()
    # after fmi2Fatal/fmi3Fatal no further call on that instance (FMI 2.0 section 2.1.3)
    out = {"status": status, "where": where, "param": f"{name} = {value!r}", "log": p.errors(),
           "fmi": p.fmi}
    out["alive"] = alive(p)
    out["generationTool"] = p.md.generationTool or ""
    out["needsExecutionTool"] = bool(p.md.coSimulation.needsExecutionTool)
    return out


def emit(obj):
    print(json.dumps(obj), flush=True)


def each_item(labels, start, attempt):
    """``attempt(i)`` for the items from ``start`` on, announced before (so that the checker can name
    the item a crash happened on) and reported after; ``{label: result}``."""
    results = {}
    for i in range(start, len(labels)):
        emit({"trying": i, "label": labels[i]})
        results[labels[i]] = attempt(i)
        emit({"item": i, "label": labels[i], "result": results[labels[i]]})
    return results


def probe_non_finite_input(p, start=0):
    if not p.inputs:
        return {"skip": "no Real (Float64) input"}

    def attempt(i):
        s = p.instance()
        values = p.input_values()
        values[i] = math.nan
        s.set_reals([u.valueReference for u in p.inputs], values)
        status, _ = status_of(s.do_step, 0.0, p.h)
        if status != "fatal":
            s.free()
        return status

    results = each_item([v.name for v in p.inputs], start, attempt)
    return {"results": results, "alive": alive(p)}


def own_blob(p):
    """The FMU's serialized state after STEPS steps of a fresh instance (freed again)."""
    s = p.instance()
    p.run(s, 0, STEPS)
    state = s.get_state()
    blob = s.serialize(state)
    s.free_state(state)
    s.free()
    return blob


def probe_serialize(p, out_file):
    """The FMU's serialized state after STEPS steps, written to ``out_file`` (offered to the other
    FMUs of one ``check`` command by their ``foreign-state`` probe)."""
    cs = p.md.coSimulation
    if not (cs.canGetAndSetFMUstate and cs.canSerializeFMUstate):
        return {"skip": "canSerializeFMUstate is false"}
    blob = own_blob(p)
    Path(out_file).write_bytes(blob)
    return {"ok": True, "bytes": len(blob)}


def offer_state(p, blob):
    """Offer ``blob`` (not this FMU's own state) to a fresh instance after STEPS steps.  ``outcome``:
    ``refused`` (deserialize or setFMUState returned error or discard), ``log-only`` (both returned
    OK, but an error was logged and the next doStep discards), ``accepted`` or ``fatal``;
    ``usable``: the instance, set back to its own state, replays the next STEPS steps bit-identical."""
    s = p.instance()
    p.run(s, 0, STEPS)
    good = s.get_state()
    first = p.run(s, STEPS, STEPS)
    s.set_state(good)
    mark = len(p.log)
    st_d, restored = status_of(s.deserialize, blob)
    st_s = None
    if st_d == "ok":
        st_s, _ = status_of(s.set_state, restored)
        status_of(s.free_state, restored)
    logged = " | ".join(m for st, m in p.log[mark:] if st >= 2)[:300]
    out = {"deserialize": st_d, "set": st_s, "log": logged}
    if "fatal" in (st_d, st_s):
        return {**out, "outcome": "fatal", "usable": False}
    if st_d in ("error", "discard") or st_s in ("error", "discard"):
        out["outcome"] = "refused"
    elif logged:
        out["next_step"], _ = status_of(s.do_step, STEPS * p.h, p.h)
        out["outcome"] = "log-only" if out["next_step"] in ("discard", "error") else "accepted"
    else:
        out["outcome"] = "accepted"
    again = replay(p, s, good)
    out["usable"] = again == first
    if not out["usable"]:
        out["why"] = again if isinstance(again, str) else "the replay from its own state differs"
    status_of(s.free_state, good)
    status_of(s.free)
    return out


def replay(p, s, good):
    """The outputs of STEPS steps after setting ``good`` back, or why they could not be taken.  FMI 2.0
    and 3.0: after an error or a discard, setFMUState to an earlier state may continue; a refusal still
    pending (reported by the first doStep after it) gets a second try."""
    for _ in range(2):
        try:
            s.set_state(good)
            return p.run(s, STEPS, STEPS)
        except Exception as exc:  # noqa: PERF203 - two tries at most
            why = f"set back to its own state, it fails: {exc}"
            why += f" (log: {p.errors()})" if p.errors() else ""
    return why


def probe_foreign_state(p, start=0, *offers):
    """Blobs a host could hand over by mistake: ``offers`` (pairs of label and file: the other FMUs'
    serialized states), then this FMU's own blob truncated to half its length and with every byte
    inverted (same length).  Each must be refused and leave the instance usable."""
    cs = p.md.coSimulation
    if not (cs.canGetAndSetFMUstate and cs.canSerializeFMUstate):
        return {"skip": "canGetAndSetFMUstate or canSerializeFMUstate is false"}
    own = own_blob(p)
    blobs = [(f"the state of {label}", Path(f).read_bytes()) for label, f in zip(offers[::2], offers[1::2])]
    blobs += [(f"its own blob truncated to {len(own) // 2} of {len(own)} bytes", own[:len(own) // 2]),
              (f"its own blob with every byte inverted ({len(own)} bytes)", bytes(b ^ 0xFF for b in own))]
    results = each_item([label for label, _ in blobs], int(start), lambda i: offer_state(p, blobs[i][1]))
    return {"results": results, "generationTool": p.md.generationTool or ""}


def probe_reference(p, path, ref_dir):
    import numpy as np
    from fmpy import simulate_fmu
    from fmpy.util import read_csv, read_ref_opt_file

    d, name = Path(ref_dir), p.md.modelName
    opts = read_ref_opt_file(str(d / "ReferenceOptions.txt"))
    inputs, ref = read_csv(d / f"{name}_in.csv"), read_csv(d / f"{name}_ref.csv")
    outputs = [n for n in ref.dtype.names if n != "time"]
    # the archive unpacked whole (as most importers do; fmpy.simulate_fmu on the file would unpack only
    # resources/ and binaries/, hiding modelDescription.xml from an FMU that compares it with its build)
    res = simulate_fmu(p.unzip, start_time=opts["StartTime"], stop_time=opts["StopTime"],
                       output_interval=opts["StepSize"], input=inputs, output=outputs,
                       logger=p._log3 if p.major == 3 else p._log, debug_logging=True)  # pythonfmu
    # logs nothing, not even its fmi2Fatal, with loggingOn = false
    if len(res) != len(ref):
        return {"ok": False, "detail": f"{len(res)} rows, the reference has {len(ref)}"}
    dev = {n: float(np.max(np.abs(res[n] - ref[n])) / max(float(np.max(np.abs(ref[n]))), 1e-300))
           for n in outputs}
    worst = max(dev, key=dev.get)
    return {"dev": dev, "worst": worst, "rows": len(ref)}


PROBES = {"instantiate": probe_instantiate, "wrong-guid": probe_wrong_guid, "cycles": probe_cycles,
          "state": probe_state, "reset": probe_reset, "bad-parameter": probe_bad_parameter,
          "non-finite-input": probe_non_finite_input, "serialize": probe_serialize,
          "foreign-state": probe_foreign_state}


def main(argv, more=None):
    """Run the probe ``argv[0]`` on the FMU ``argv[1]`` and print its JSON result; ``more``: further
    probes by mode (:data:`orchestration.check.user_probes.PROBES` runs through here too)."""
    mode, path = argv[0], argv[1]
    p = Probe(path)

    def probe():
        if mode == "reference":
            return probe_reference(p, path, argv[2])
        if mode in ("non-finite-input", "foreign-state"):
            return PROBES[mode](p, int(argv[2]) if len(argv) > 2 else 0, *argv[3:])
        return {**PROBES, **(more or {})}[mode](p, *argv[2:])

    report(p, probe)


if __name__ == "__main__":
    main(sys.argv[1:])
